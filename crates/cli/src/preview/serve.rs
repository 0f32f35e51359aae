//! The preview page of `--serve`: a small HTTP server (tiny_http) on its own thread.
//!
//! | request | answer |
//! |---|---|
//! | `GET /` | the page (`page.html`): the image, spp, samples/s, time left, an exposure slider, a Stop button |
//! | `GET /status` | JSON: `version` (grows by one per new image), `spp`, `target_spp`, `samples_per_second`, `elapsed_s`, `time_left_s`, `time_left`, `state` (`starting`, `rendering`, `stopping`, `finished`, `stopped`, `interrupted`), `width`, `height`, `title`, `checkpoint` |
//! | `GET /image.png?exposure=STOPS` | the newest image as PNG, scaled by 2^STOPS and sRGB-encoded as `--out x.png` writes it |
//! | `POST /stop` | asks the render to stop after its pass and write its checkpoint, as Ctrl-C does; answers the status |
//!
//! The page polls `/status` four times a second and loads a new PNG when the version changes.

use std::io::ErrorKind;
use std::net::{SocketAddr, TcpListener, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use serde_json::json;

use super::{format_duration, request_stop, Frame, Slot};

/// The page, with its script and style inline.
const PAGE: &str = include_str!("page.html");
/// How long the server stays up after the render for a page that is watching to fetch the
/// final image.
const LINGER: Duration = Duration::from_secs(3);

/// A listening socket for the page, bound before the render starts.
pub struct Bound {
    listener: TcpListener,
    /// The address bound (with the port chosen by the system for port 0).
    pub addr: SocketAddr,
}

impl Bound {
    /// The page's address, for people to open.
    pub fn url(&self) -> String {
        let host = match self.addr {
            SocketAddr::V4(a) if a.ip().is_unspecified() => "127.0.0.1".to_string(),
            SocketAddr::V4(a) => a.ip().to_string(),
            SocketAddr::V6(a) if a.ip().is_unspecified() => "[::1]".to_string(),
            SocketAddr::V6(a) => format!("[{}]", a.ip()),
        };
        format!("http://{host}:{}/", self.addr.port())
    }
}

/// Bind `--serve [ADDR:]PORT`: a bare port binds 127.0.0.1 (this machine only); an address
/// (`0.0.0.0:8080`, `[::1]:8080`, `localhost:8080`) binds there. Port 0 takes any free port.
pub fn bind(spec: &str) -> Result<Bound> {
    let text = spec.trim();
    let addrs: Vec<SocketAddr> = if let Ok(port) = text.parse::<u16>() {
        vec![SocketAddr::from(([127, 0, 0, 1], port))]
    } else if let Ok(a) = text.parse::<SocketAddr>() {
        vec![a]
    } else {
        let ok_form = text.rsplit_once(':').is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok());
        if !ok_form {
            bail!("--serve must be PORT or ADDR:PORT (e.g. 8080 or 0.0.0.0:8080), got `{spec}`");
        }
        text.to_socket_addrs().with_context(|| format!("--serve {spec}: cannot resolve the address"))?.collect()
    };
    let Some(first) = addrs.first() else { bail!("--serve {spec}: the address resolves to nothing") };
    match TcpListener::bind(&addrs[..]) {
        Ok(listener) => {
            let addr = listener.local_addr().unwrap_or(*first);
            Ok(Bound { listener, addr })
        }
        Err(e) if e.kind() == ErrorKind::AddrInUse => {
            bail!("--serve {spec}: port {} is in use by another program; choose another port (0 takes any free one)", first.port())
        }
        Err(e) if e.kind() == ErrorKind::AddrNotAvailable => bail!("--serve {spec}: {} is not an address of this machine", first.ip()),
        Err(e) => bail!("--serve {spec}: cannot listen on {first}: {e}"),
    }
}

/// What the request thread shares with the render thread.
struct Shared {
    slot: Arc<Slot>,
    title: String,
    checkpoint: Option<String>,
    cancel: Arc<AtomicBool>,
    stop_requested: AtomicBool,
    shutdown: AtomicBool,
    /// When the last request came (for lingering only while someone watches).
    last_request: Mutex<Option<Instant>>,
    /// Whether the image of the last frame has been served.
    final_served: AtomicBool,
}

/// The running server.
pub struct Server {
    shared: Arc<Shared>,
    thread: JoinHandle<()>,
}

impl Server {
    /// Serve the page on `bound`, showing the frames of `slot`; the Stop button sets `cancel`.
    pub fn start(bound: Bound, slot: Arc<Slot>, title: String, cancel: Arc<AtomicBool>, checkpoint: Option<String>) -> Result<Server> {
        let server = tiny_http::Server::from_listener(bound.listener, None).map_err(|e| anyhow!("--serve: cannot start the server: {e}"))?;
        let shared = Arc::new(Shared {
            slot,
            title,
            checkpoint,
            cancel,
            stop_requested: AtomicBool::new(false),
            shutdown: AtomicBool::new(false),
            last_request: Mutex::new(None),
            final_served: AtomicBool::new(false),
        });
        let s2 = shared.clone();
        let thread = std::thread::Builder::new()
            .name("lucent-serve".into())
            .spawn(move || serve(server, &s2))
            .context("cannot start the preview server thread")?;
        Ok(Server { shared, thread })
    }

    /// Whether the Stop button was pressed.
    pub fn stop_requested(&self) -> bool {
        self.shared.stop_requested.load(Ordering::SeqCst)
    }

    /// Stop serving, once a page that is watching has fetched the final image (at most
    /// [`LINGER`] later); at once when no page has asked for anything lately.
    pub fn close(self) {
        let watched = self.shared.last_request.lock().map(|t| t.is_some_and(|t| t.elapsed() < Duration::from_secs(5))).unwrap_or(false);
        if watched {
            let until = Instant::now() + LINGER;
            while !self.shared.final_served.load(Ordering::SeqCst) && Instant::now() < until {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        self.shared.shutdown.store(true, Ordering::SeqCst);
        let _ = self.thread.join();
    }
}

fn serve(server: tiny_http::Server, shared: &Shared) {
    let mut png_cache: Option<(u64, u32, Arc<Vec<u8>>)> = None;
    while !shared.shutdown.load(Ordering::SeqCst) {
        let request = match server.recv_timeout(Duration::from_millis(50)) {
            Ok(Some(r)) => r,
            Ok(None) => continue,
            Err(_) => break,
        };
        if let Ok(mut t) = shared.last_request.lock() {
            *t = Some(Instant::now());
        }
        let url = request.url().to_string();
        let (path, query) = url.split_once('?').unwrap_or((url.as_str(), ""));
        let method = request.method().clone();
        let response = match (&method, path) {
            (tiny_http::Method::Get, "/") => respond(PAGE.as_bytes().to_vec(), "text/html; charset=utf-8", 200),
            (tiny_http::Method::Get, "/status") => respond(status(shared).to_string().into_bytes(), "application/json", 200),
            (tiny_http::Method::Get, "/image.png") => {
                let exposure = exposure_of(query);
                let (version, frame) = shared.slot.latest();
                match frame {
                    Some(frame) => {
                        let png = match &png_cache {
                            Some((v, e, png)) if *v == version && *e == exposure.to_bits() => Some(png.clone()),
                            _ => {
                                let before = super::cpu_time(false).unwrap_or_default();
                                let png = encode(&frame, exposure).map(Arc::new);
                                let after = super::cpu_time(false).unwrap_or_default();
                                shared.slot.report_cpu(after, after.saturating_sub(before));
                                png
                            }
                        };
                        match png {
                            Some(png) => {
                                png_cache = Some((version, exposure.to_bits(), png.clone()));
                                if frame.end.is_some() {
                                    shared.final_served.store(true, Ordering::SeqCst);
                                }
                                respond(png.as_ref().clone(), "image/png", 200)
                            }
                            None => respond(b"cannot encode the image".to_vec(), "text/plain", 500),
                        }
                    }
                    None => respond(b"no image yet".to_vec(), "text/plain", 404),
                }
            }
            (tiny_http::Method::Post, "/stop") => {
                if shared.slot.latest().1.is_none_or(|f| f.end.is_none()) {
                    shared.stop_requested.store(true, Ordering::SeqCst);
                    request_stop(&shared.cancel);
                }
                respond(status(shared).to_string().into_bytes(), "application/json", 200)
            }
            (_, "/stop") => respond(b"use POST".to_vec(), "text/plain", 405),
            _ => respond(b"not found".to_vec(), "text/plain", 404),
        };
        // A page that went away mid-answer is no error of the render's.
        let _ = request.respond(response);
    }
}

fn respond(body: Vec<u8>, content_type: &str, code: u16) -> tiny_http::Response<std::io::Cursor<Vec<u8>>> {
    let mut r = tiny_http::Response::from_data(body).with_status_code(code);
    for (k, v) in [("Content-Type", content_type), ("Cache-Control", "no-store")] {
        if let Ok(h) = tiny_http::Header::from_bytes(k.as_bytes(), v.as_bytes()) {
            r.add_header(h);
        }
    }
    r
}

/// `exposure=STOPS` from a query string: finite, within ±20 stops; 0 otherwise.
fn exposure_of(query: &str) -> f32 {
    query
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == "exposure")
        .and_then(|(_, v)| v.parse::<f32>().ok())
        .filter(|v| v.is_finite())
        .map_or(0.0, |v| v.clamp(-20.0, 20.0))
}

fn encode(frame: &Frame, exposure_stops: f32) -> Option<Vec<u8>> {
    let mut png = Vec::new();
    render::image_io::encode_png(&mut png, &frame.film.to_image(), exposure_stops, render::image_io::PngEffort::Quick).ok()?;
    Some(png)
}

fn status(shared: &Shared) -> serde_json::Value {
    let (version, frame) = shared.slot.latest();
    let stopping = shared.cancel.load(Ordering::SeqCst);
    let Some(f) = frame else {
        return json!({ "version": 0, "state": if stopping { "stopping" } else { "starting" }, "title": shared.title, "checkpoint": shared.checkpoint });
    };
    let state = match f.end {
        Some(end) => end.name(),
        None if stopping => "stopping",
        None => "rendering",
    };
    let s = &f.stats;
    let time_left = if f.end.is_some() { None } else { s.time_left };
    json!({
        "version": version,
        "state": state,
        "spp": s.spp,
        "target_spp": s.target_spp,
        "samples_per_second": s.samples_per_s,
        "elapsed_s": s.elapsed.as_secs_f64(),
        "time_left_s": time_left.map(|t| t.as_secs_f64()),
        "time_left": time_left.map(format_duration),
        "width": f.film.width(),
        "height": f.film.height(),
        "title": shared.title,
        "checkpoint": shared.checkpoint,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bare_port_binds_this_machine_only() {
        let b = bind("0").unwrap();
        assert!(b.addr.ip().is_loopback(), "{}", b.addr);
        assert!(b.url().starts_with("http://127.0.0.1:"));
        let b = bind("127.0.0.1:0").unwrap();
        assert!(b.addr.port() > 0);
    }

    #[test]
    fn a_port_in_use_is_one_clear_line() {
        let taken = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = taken.local_addr().unwrap().port();
        let e = bind(&port.to_string()).err().expect("bound a port in use").to_string();
        assert!(e.contains("in use") && e.contains(&port.to_string()) && !e.contains('\n'), "{e}");
        for bad in ["", "x", "host:", "127.0.0.1:99999", "-1"] {
            assert!(bind(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn exposure_comes_from_the_query() {
        assert_eq!(exposure_of("exposure=1.5&v=3"), 1.5);
        assert_eq!(exposure_of("v=3&exposure=-2"), -2.0);
        assert_eq!(exposure_of("v=3"), 0.0);
        assert_eq!(exposure_of("exposure=NaN"), 0.0);
        assert_eq!(exposure_of("exposure=1e9"), 20.0);
    }
}
