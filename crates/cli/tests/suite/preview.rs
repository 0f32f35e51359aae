//! Live previews of `lucent render`: the tev protocol against a stub viewer in the test
//! (`--display-server`), the preview page over plain HTTP and in headless Chromium (`--serve`).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use render::checkpoint::Checkpoint;
use render::image_io::{decode_image, read_image, Format, Image};

use crate::common::{lucent, run, Scratch};

/// Split a byte stream into tev packets by their u32 length fields (length included).
fn packets(mut bytes: &[u8]) -> Vec<&[u8]> {
    let mut out = Vec::new();
    while !bytes.is_empty() {
        assert!(bytes.len() >= 5, "a partial packet header at the end");
        let n = u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
        assert!(n >= 5 && n <= bytes.len(), "packet length {n} with {} bytes left", bytes.len());
        out.push(&bytes[..n]);
        bytes = &bytes[n..];
    }
    out
}

/// `CreateImage` written out field by field (tev's Ipc.cpp: type 4, grab focus, name, width,
/// height, channel count, channel names).
fn expected_create(name: &str, width: i32, height: i32) -> Vec<u8> {
    let mut body = vec![4u8, 1];
    body.extend(name.as_bytes());
    body.push(0);
    for v in [width, height, 3] {
        body.extend(v.to_le_bytes());
    }
    body.extend(b"R\0G\0B\0");
    let mut p = ((body.len() + 4) as u32).to_le_bytes().to_vec();
    p.extend(body);
    p
}

/// `UpdateImageV3` of the whole of a small image (one tile): type 6, no focus, name, 3 channels
/// R, G, B, x = y = 0, width, height, offsets 0 1 2, strides 3 3 3 (i64), then the floats.
fn expected_update(name: &str, image: &Image) -> Vec<u8> {
    let mut body = vec![6u8, 0];
    body.extend(name.as_bytes());
    body.push(0);
    body.extend(3i32.to_le_bytes());
    body.extend(b"R\0G\0B\0");
    for v in [0, 0, image.width as i32, image.height as i32] {
        body.extend(v.to_le_bytes());
    }
    for v in [0i64, 1, 2, 3, 3, 3] {
        body.extend(v.to_le_bytes());
    }
    for px in &image.rgb {
        for c in px {
            body.extend(c.to_le_bytes());
        }
    }
    let mut p = ((body.len() + 4) as u32).to_le_bytes().to_vec();
    p.extend(body);
    p
}

/// A stub tev: accepts one connection and hands back everything it receives until EOF.
fn stub_viewer() -> (u16, std::thread::JoinHandle<Vec<u8>>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let reader = std::thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        let mut all = Vec::new();
        s.read_to_end(&mut all).unwrap();
        all
    });
    (port, reader)
}

#[test]
fn tev_stub_receives_create_and_updates_ending_in_the_exr_image() {
    let t = Scratch::new("tev");
    let (port, reader) = stub_viewer();
    let out = t.arg("x.exr");
    let server = format!("127.0.0.1:{port}");
    let child = lucent()
        .current_dir(&t.0)
        .args(["render", "--width", "20", "--height", "10", "--spp", "6", "--threads", "1", "--quiet"])
        .args(["--display-server", &server, "--out", &out])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let name = format!("{out} ({})", child.id());
    let done = child.wait_with_output().unwrap();
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    assert!(done.stderr.is_empty(), "a warning with the viewer there: {}", String::from_utf8_lossy(&done.stderr));
    let bytes = reader.join().unwrap();
    let got = packets(&bytes);
    // CreateImage, then at least the final UpdateImageV3; at most one update per pass and the last.
    assert!(got.len() >= 2 && got.len() <= 2 + 6, "{} packets", got.len());
    assert_eq!(got[0], expected_create(&name, 20, 10).as_slice());
    // The last update holds exactly the linear values the EXR output holds.
    let exr = read_image(&t.path("x.exr")).unwrap();
    assert_eq!(*got.last().unwrap(), expected_update(&name, &exr).as_slice());
    for p in &got[1..] {
        assert_eq!(p[4], 6, "not an UpdateImageV3 packet");
        assert_eq!(p.len(), expected_update(&name, &exr).len());
    }
}

#[test]
fn a_viewer_that_goes_away_does_not_stop_the_render() {
    let t = Scratch::new("tev-gone");
    // The stub reads the first packet and closes, listener and all, while the render goes on.
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let stub = std::thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        let mut head = [0u8; 5];
        s.read_exact(&mut head).unwrap();
        head[4]
    });
    let server = format!("127.0.0.1:{port}");
    let out = run(
        &t.0,
        &["render", "--width", "64", "--height", "64", "--time", "1.5", "--threads", "1", "--quiet", "--display-server", &server, "--out", &t.arg("x.png")],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert_eq!(stub.join().unwrap(), 4, "the first packet is CreateImage");
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("display server")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(warnings[0].starts_with("lucent: warning: display server 127.0.0.1:") && warnings[0].contains("rendering goes on"), "{stderr}");
    assert!(read_image(&t.path("x.png")).is_ok());

    // No viewer at all: one warning, the render completes.
    let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let server = format!("127.0.0.1:{port}");
    let out = run(&t.0, &["render", "--width", "16", "--height", "16", "--spp", "4", "--quiet", "--display-server", &server, "--out", &t.arg("y.png")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("cannot connect"), "{stderr}");
    assert!(t.path("y.png").is_file());
}

#[test]
fn bad_preview_addresses_fail_on_one_line_before_any_work() {
    let t = Scratch::new("serve-bad");
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    for (flag, value, says) in [
        ("--serve", port.as_str(), "in use"),
        ("--serve", "localhost", "PORT or ADDR:PORT"),
        ("--display-server", "14158", "HOST:PORT"),
    ] {
        let out = run(
            &t.0,
            &["render", "--width", "8", "--height", "8", "--spp", "1", flag, value, "--out", &t.arg("x.png"), "--checkpoint", &t.arg("x.ckpt")],
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag} {value}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with("lucent: error: ") && stderr.contains(flag) && stderr.contains(says), "{stderr}");
        assert_eq!(std::fs::read_dir(&t.0).unwrap().count(), 0, "{flag} {value} left files");
    }
}

/// A `lucent render --serve 127.0.0.1:0` that never finishes by itself, its page's address and
/// its stderr lines after the address.
struct Served {
    child: Child,
    url: String,
    stderr: mpsc::Receiver<String>,
}

impl Served {
    fn start(dir: &Path, checkpoint: &str) -> Served {
        let mut child = lucent()
            .current_dir(dir)
            .args(["render", "--width", "48", "--height", "32", "--spp", "1000000", "--threads", "1", "--quiet"])
            .args(["--serve", "127.0.0.1:0", "--checkpoint", checkpoint, "--out", "x.png"])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let (tx, rx) = mpsc::channel();
        let stderr = child.stderr.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        let first = rx.recv_timeout(Duration::from_secs(20)).expect("no line from lucent");
        let url = first.strip_prefix("lucent: preview at ").unwrap_or_else(|| panic!("first line: {first}")).to_string();
        assert!(url.starts_with("http://127.0.0.1:") && url.ends_with('/'), "{url}");
        Served { child, url, stderr: rx }
    }

    /// Wait for the process to end (at most 20 s); its exit status and remaining stderr.
    fn wait(mut self) -> (std::process::ExitStatus, String) {
        let until = Instant::now() + Duration::from_secs(20);
        let status = loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                break s;
            }
            if Instant::now() > until {
                let _ = self.child.kill();
                panic!("lucent did not stop");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let rest: Vec<String> = self.stderr.try_iter().collect();
        (status, rest.join("\n"))
    }
}

/// One HTTP/1.0 request to `url` + `path`: status code and body.
fn http(url: &str, method: &str, path: &str) -> (u16, Vec<u8>) {
    let host = url.trim_start_matches("http://").trim_end_matches('/');
    let mut s = TcpStream::connect(host).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(s, "{method} {path} HTTP/1.0\r\nHost: {host}\r\nContent-Length: 0\r\n\r\n").unwrap();
    let mut all = Vec::new();
    s.read_to_end(&mut all).unwrap();
    let split = all.windows(4).position(|w| w == b"\r\n\r\n").expect("no header end");
    let head = String::from_utf8_lossy(&all[..split]).to_string();
    let code = head.split_whitespace().nth(1).and_then(|c| c.parse().ok()).expect("no status code");
    (code, all[split + 4..].to_vec())
}

fn status(url: &str) -> serde_json::Value {
    let (code, body) = http(url, "GET", "/status");
    assert_eq!(code, 200);
    serde_json::from_slice(&body).unwrap()
}

/// The checkpoint stopped at is valid: it reads, holds fewer samples than aimed at, and a
/// resumed render continues it by one pass.
fn check_resumable(dir: &Path, checkpoint: &Path) -> u64 {
    let c = Checkpoint::read(checkpoint).unwrap();
    let spp = c.film.samples_per_pixel();
    assert!(spp >= 1 && spp < 1_000_000, "{spp} spp");
    let more = (spp + 1).to_string();
    let out = run(dir, &["render", "--resume", &checkpoint.display().to_string(), "--spp", &more, "--quiet", "--out", "resumed.png"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(Checkpoint::read(checkpoint).unwrap().film.samples_per_pixel(), spp + 1);
    spp
}

#[test]
fn preview_page_serves_status_image_and_stop() {
    let t = Scratch::new("serve-http");
    let served = Served::start(&t.0, "c.ckpt");
    let url = served.url.clone();
    let (code, page) = http(&url, "GET", "/");
    assert_eq!(code, 200);
    let page = String::from_utf8_lossy(&page);
    assert!(page.contains("id=\"stop\"") && page.contains("id=\"exposure\""), "{page}");
    // Two different images as the render converges, each a 48×32 PNG, with growing spp.
    let until = Instant::now() + Duration::from_secs(20);
    let mut seen: Vec<(u64, u64)> = Vec::new();
    while seen.len() < 2 {
        assert!(Instant::now() < until, "status did not move: {seen:?}");
        let s = status(&url);
        let v = s["version"].as_u64().unwrap();
        if v > 0 && seen.last().is_none_or(|l| l.0 != v) {
            assert_eq!(s["state"], "rendering");
            assert_eq!((s["width"].as_u64(), s["height"].as_u64(), s["target_spp"].as_u64()), (Some(48), Some(32), Some(1_000_000)));
            assert!(s["samples_per_second"].as_f64().unwrap() > 0.0 && s["time_left_s"].as_f64().unwrap() > 0.0, "{s}");
            seen.push((v, s["spp"].as_u64().unwrap()));
            let (code, png) = http(&url, "GET", "/image.png?exposure=1");
            assert_eq!(code, 200);
            let img = decode_image(&png, Format::Png).unwrap();
            assert_eq!((img.width, img.height), (48, 32));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(seen[1].1 > seen[0].1, "{seen:?}");
    assert_eq!(http(&url, "GET", "/stop").0, 405);
    assert_eq!(http(&url, "GET", "/nothing").0, 404);
    let (code, body) = http(&url, "POST", "/stop");
    assert_eq!(code, 200);
    let s: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert!(s["state"] == "stopping" || s["state"] == "stopped", "{s}");
    let (exit, stderr) = served.wait();
    assert!(exit.success(), "{exit:?}: {stderr}");
    assert!(stderr.contains("stopped from the preview page; continue with --resume c.ckpt"), "{stderr}");
    assert!(read_image(&t.path("x.png")).is_ok(), "the image is written on Stop");
    check_resumable(&t.0, &t.path("c.ckpt"));
}

// ---- Headless Chromium through the DevTools protocol ----

/// The Chromium to drive: $LUCENT_CHROMIUM, else Debian's /usr/bin/chromium, else `chromium`
/// on the PATH.
fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("LUCENT_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let candidates = [PathBuf::from("/usr/bin/chromium"), PathBuf::from("/usr/bin/chromium-browser")];
    if let Some(p) = candidates.into_iter().find(|p| p.is_file()) {
        return Some(p);
    }
    std::env::var_os("PATH")?.to_str()?.split(':').map(|d| Path::new(d).join("chromium")).find(|p| p.is_file())
}

type Ws = tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<TcpStream>>;

/// A DevTools-protocol session with one page of a browser.
struct Cdp {
    ws: Ws,
    next: u64,
    session: String,
}

impl Cdp {
    fn call_in(ws: &mut Ws, next: &mut u64, session: Option<&str>, method: &str, params: serde_json::Value) -> serde_json::Value {
        *next += 1;
        let id = *next;
        let mut msg = serde_json::json!({ "id": id, "method": method, "params": params });
        if let Some(s) = session {
            msg["sessionId"] = s.into();
        }
        ws.send(tungstenite::Message::text(msg.to_string())).unwrap();
        loop {
            let m = ws.read().unwrap_or_else(|e| panic!("{method}: {e}"));
            let Ok(text) = m.to_text() else { continue };
            let v: serde_json::Value = serde_json::from_str(text).unwrap();
            if v["id"].as_u64() == Some(id) {
                assert!(v.get("error").is_none(), "{method}: {v}");
                return v["result"].clone();
            }
        }
    }

    fn call(&mut self, method: &str, params: serde_json::Value) -> serde_json::Value {
        let session = self.session.clone();
        Cdp::call_in(&mut self.ws, &mut self.next, Some(&session), method, params)
    }

    /// The value of a JavaScript expression in the page.
    fn eval(&mut self, expr: &str) -> serde_json::Value {
        let r = self.call("Runtime.evaluate", serde_json::json!({ "expression": expr, "returnByValue": true }));
        r["result"]["value"].clone()
    }

    fn wait_for(&mut self, expr: &str, what: &str, timeout: Duration) {
        let until = Instant::now() + timeout;
        while self.eval(expr) != serde_json::Value::Bool(true) {
            assert!(Instant::now() < until, "timed out waiting for {what}");
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

/// Headless Chromium with a fresh profile; killed when dropped (if it has not closed).
struct Browser(Child);

impl Browser {
    /// Wait up to `timeout` for the browser to exit by itself.
    fn wait_exit(&mut self, timeout: Duration) {
        let until = Instant::now() + timeout;
        while self.0.try_wait().ok().flatten().is_none() && Instant::now() < until {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn browser_shows_the_render_converging_and_stop_leaves_a_resumable_checkpoint() {
    let Some(chrome) = chromium() else {
        eprintln!("skipped: no Chromium (install Debian's `chromium` package, or set LUCENT_CHROMIUM)");
        return;
    };
    let t = Scratch::new("browser");
    let served = Served::start(&t.0, "c.ckpt");
    let profile = t.path("profile");
    let mut child = Command::new(&chrome)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--remote-debugging-port=0",
            "--window-size=900,600",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("about:blank")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {}: {e}", chrome.display()));
    let stderr = child.stderr.take().unwrap();
    let mut browser = Browser(child);
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if let Some(ws) = line.strip_prefix("DevTools listening on ") {
                let _ = tx.send(ws.to_string());
            }
        }
    });
    let ws_url = rx.recv_timeout(Duration::from_secs(20)).expect("Chromium did not open its DevTools port");
    let (mut ws, _) = tungstenite::connect(ws_url.as_str()).unwrap();
    if let tungstenite::stream::MaybeTlsStream::Plain(s) = ws.get_mut() {
        s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    }
    let mut next = 0;
    let target = Cdp::call_in(&mut ws, &mut next, None, "Target.createTarget", serde_json::json!({ "url": served.url }));
    let target_id = target["targetId"].as_str().unwrap().to_string();
    let attached = Cdp::call_in(&mut ws, &mut next, None, "Target.attachToTarget", serde_json::json!({ "targetId": target_id, "flatten": true }));
    let mut cdp = Cdp { ws, next, session: attached["sessionId"].as_str().unwrap().to_string() };

    // The page loads and shows at least two successive images, with a growing sample count.
    cdp.wait_for("document.readyState === 'complete' && !!window.lucent", "the page", Duration::from_secs(15));
    cdp.wait_for("window.lucent.frames >= 1", "the first image", Duration::from_secs(15));
    let spp1 = cdp.eval("document.getElementById('spp').textContent");
    cdp.wait_for("window.lucent.frames >= 2", "a second image", Duration::from_secs(15));
    cdp.wait_for(&format!("document.getElementById('spp').textContent !== {spp1}"), "spp to change", Duration::from_secs(15));
    assert_eq!(cdp.eval("document.getElementById('state').textContent"), "rendering");
    assert_eq!(cdp.eval("document.getElementById('image').naturalWidth"), 48);

    // A real click on Stop, at the middle of the button.
    let rect = cdp.eval("(() => { const r = document.getElementById('stop').getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; })()");
    let (x, y) = (rect[0].as_f64().unwrap(), rect[1].as_f64().unwrap());
    for kind in ["mousePressed", "mouseReleased"] {
        cdp.call("Input.dispatchMouseEvent", serde_json::json!({ "type": kind, "x": x, "y": y, "button": "left", "clickCount": 1 }));
    }
    cdp.wait_for("document.getElementById('state').textContent === 'stopped'", "the page to say stopped", Duration::from_secs(15));
    if let Ok(path) = std::env::var("LUCENT_PREVIEW_SCREENSHOT") {
        // For the docs: the page as a user sees it at the end.
        cdp.wait_for("!document.getElementById('image').src || document.getElementById('image').complete", "the last image", Duration::from_secs(5));
        let shot = cdp.call("Page.captureScreenshot", serde_json::json!({ "format": "png" }));
        std::fs::write(&path, base64_decode(shot["data"].as_str().unwrap())).unwrap();
    }
    let (exit, stderr) = served.wait();
    assert!(exit.success(), "{exit:?}: {stderr}");
    assert!(stderr.contains("stopped from the preview page"), "{stderr}");
    // Close the browser the polite way, so that it ends its own helper processes.
    let close = serde_json::json!({ "id": cdp.next + 1, "method": "Browser.close" });
    let _ = cdp.ws.send(tungstenite::Message::text(close.to_string()));
    browser.wait_exit(Duration::from_secs(5));
    check_resumable(&t.0, &t.path("c.ckpt"));
}

/// Standard base64 (RFC 4648) to bytes, for the screenshot DevTools sends.
fn base64_decode(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    } as u32;
    let digits: Vec<u8> = text.bytes().filter(|&c| c != b'=' && !c.is_ascii_whitespace()).collect();
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        let n = chunk.iter().enumerate().fold(0u32, |n, (i, &c)| n | value(c) << (18 - 6 * i));
        out.extend(&n.to_be_bytes()[1..chunk.len()]);
    }
    out
}
