//! The progressive image streamed to the tev viewer (github.com/Tom94/tev) over its TCP
//! protocol, as pbrt-v4's `--display-server` does.
//!
//! The protocol (tev's `include/tev/Ipc.h` and `src/Ipc.cpp`) is one-way: a stream of packets,
//! each `u32` total length in bytes (the length field included), a `u8` packet type, then the
//! fields, little-endian, strings NUL-terminated, booleans one byte. tev has no version
//! handshake; each packet type is versioned instead. We send
//!
//! - `CreateImage` (type 4, tev ≥ 1.16): grab focus, image name, width, height, channel count,
//!   channel names: an empty image of that size;
//! - `UpdateImageV3` (type 6, tev ≥ 1.18): grab focus, image name, channel count, channel names,
//!   x, y, width, height of a tile, one `i64` offset and one `i64` stride per channel (in
//!   floats), then the `f32` pixels — here R, G, B interleaved (offsets 0, 1, 2; stride 3);
//! - `CloseImage` (type 2, every tev with IPC): image name.
//!
//! These three are unchanged in tev 2.x (checked against tev 2.14, 2026). The image is linear
//! sRGB, exactly the values an EXR output holds; it is cut into 128×128 tiles (pbrt-v4's size)
//! and a tile is sent only when one of its values changed since it was last sent.

use std::io::Write;
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use render::image_io::Image;

use super::{Slot, Warn};

/// tev's default port (it listens on 127.0.0.1:14158).
pub const DEFAULT_PORT: u16 = 14158;
/// Packet types: tev's `IpcPacket::EType`.
#[allow(dead_code)]
pub const CLOSE_IMAGE: u8 = 2;
pub const CREATE_IMAGE: u8 = 4;
pub const UPDATE_IMAGE_V3: u8 = 6;
/// Edge of the square tiles sent, in pixels.
pub const TILE: u32 = 128;
/// The channels sent.
pub const CHANNELS: [&str; 3] = ["R", "G", "B"];
/// Time between attempts to reach a viewer that is not there.
pub const RETRY: Duration = Duration::from_secs(10);
/// Longest wait to connect, and for one packet to be taken by the viewer.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(1);
const WRITE_TIMEOUT: Duration = Duration::from_secs(3);

/// A packet being built: the length is filled in by [`Packet::finish`].
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Packet {
        let mut bytes = Vec::with_capacity(64);
        bytes.extend_from_slice(&[0, 0, 0, 0, kind]);
        Packet(bytes)
    }
    fn boolean(mut self, v: bool) -> Packet {
        self.0.push(v as u8);
        self
    }
    /// A NUL-terminated string (a NUL inside `s` would end it early, so it is replaced).
    fn string(mut self, s: &str) -> Packet {
        self.0.extend(s.bytes().map(|b| if b == 0 { b'?' } else { b }));
        self.0.push(0);
        self
    }
    fn i32(mut self, v: i32) -> Packet {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn i64(mut self, v: i64) -> Packet {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn finish(mut self) -> Vec<u8> {
        let n = u32::try_from(self.0.len()).expect("tev packet over 4 GiB");
        self.0[..4].copy_from_slice(&n.to_le_bytes());
        self.0
    }
}

/// `CreateImage`: an empty `width`×`height` image called `name` with these channels.
pub fn create_image(name: &str, grab_focus: bool, width: u32, height: u32, channels: &[&str]) -> Vec<u8> {
    let mut p = Packet::new(CREATE_IMAGE).boolean(grab_focus).string(name).i32(width as i32).i32(height as i32).i32(channels.len() as i32);
    for c in channels {
        p = p.string(c);
    }
    p.finish()
}

/// `UpdateImageV3`: the tile at (`x`, `y`) of `width`×`height` pixels of image `name`, its
/// channels interleaved in `pixels` (row-major, `channels.len()` floats per pixel).
pub fn update_image(name: &str, grab_focus: bool, channels: &[&str], x: u32, y: u32, width: u32, height: u32, pixels: &[f32]) -> Vec<u8> {
    let n = channels.len();
    assert_eq!(pixels.len(), n * width as usize * height as usize, "tile data does not match its size");
    let mut p = Packet::new(UPDATE_IMAGE_V3).boolean(grab_focus).string(name).i32(n as i32);
    for c in channels {
        p = p.string(c);
    }
    p = p.i32(x as i32).i32(y as i32).i32(width as i32).i32(height as i32);
    for c in 0..n {
        p = p.i64(c as i64);
    }
    for _ in 0..n {
        p = p.i64(n as i64);
    }
    p.0.reserve(pixels.len() * 4);
    for v in pixels {
        p.0.extend_from_slice(&v.to_le_bytes());
    }
    p.finish()
}

/// `CloseImage`: remove image `name` from the viewer. `lucent render` does not send it: the
/// finished image stays in the viewer, as pbrt-v4 leaves it.
#[allow(dead_code)]
pub fn close_image(name: &str) -> Vec<u8> {
    Packet::new(CLOSE_IMAGE).string(name).finish()
}

/// Where the viewer listens, as given to `--display-server`.
#[derive(Clone, Debug)]
pub struct Target {
    /// The text given (`HOST:PORT`), for messages.
    pub spec: String,
    /// Its addresses, tried in order.
    pub addrs: Vec<SocketAddr>,
}

impl Target {
    /// Parse `HOST:PORT` (`localhost:14158`, `127.0.0.1:14158`, `[::1]:14158`) and resolve the host.
    pub fn parse(spec: &str) -> Result<Target> {
        let ok_form = spec.rsplit_once(':').is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok_and(|p| p > 0));
        if !ok_form {
            bail!("--display-server must be HOST:PORT (tev listens on 127.0.0.1:{DEFAULT_PORT}), got `{spec}`");
        }
        let addrs: Vec<SocketAddr> =
            spec.to_socket_addrs().with_context(|| format!("--display-server {spec}: cannot resolve the host"))?.collect();
        if addrs.is_empty() {
            bail!("--display-server {spec}: the host has no address");
        }
        Ok(Target { spec: spec.to_string(), addrs })
    }
}

/// One viewer connection: (re)connects, creates the image, sends the tiles that changed.
pub struct Client {
    target: Target,
    name: String,
    stream: Option<TcpStream>,
    next_attempt: Option<Instant>,
    /// The image as the viewer has it (`None` right after connecting: every tile is sent).
    shown: Option<Image>,
    warned: bool,
    warn: Warn,
}

impl Client {
    /// A client that will show images under `name` on `target`; it connects on the first show.
    pub fn new(target: Target, name: String, warn: Warn) -> Client {
        Client { target, name, stream: None, next_attempt: None, shown: None, warned: false, warn }
    }

    /// Whether a connection is open.
    #[cfg(test)]
    pub fn connected(&self) -> bool {
        self.stream.is_some()
    }

    fn lost(&mut self, what: String) {
        if !self.warned {
            (self.warn)(&format!(
                "display server {}: {what}; rendering goes on without it (trying again every {} s)",
                self.target.spec,
                RETRY.as_secs()
            ));
            self.warned = true;
        }
        self.stream = None;
        self.shown = None;
        self.next_attempt = Some(Instant::now() + RETRY);
    }

    fn connect(&mut self, width: u32, height: u32) {
        let mut last_err = None;
        for addr in self.target.addrs.iter().take(4) {
            match TcpStream::connect_timeout(addr, CONNECT_TIMEOUT) {
                Ok(s) => {
                    let _ = s.set_nodelay(true);
                    let _ = s.set_write_timeout(Some(WRITE_TIMEOUT));
                    self.stream = Some(s);
                    break;
                }
                Err(e) => last_err = Some(e),
            }
        }
        match (&self.stream, last_err) {
            (Some(_), _) => {
                self.shown = None;
                let packet = create_image(&self.name, true, width, height, &CHANNELS);
                self.send(&packet);
            }
            (None, Some(e)) => self.lost(format!("cannot connect ({e})")),
            (None, None) => self.lost("no address".to_string()),
        }
    }

    fn send(&mut self, packet: &[u8]) -> bool {
        let result = match &mut self.stream {
            Some(s) => s.write_all(packet),
            None => return false,
        };
        match result {
            Ok(()) => true,
            Err(e) => {
                self.lost(format!("the viewer went away ({e})"));
                false
            }
        }
    }

    /// Show `image`: connect if not connected (at most every [`RETRY`], or now if `force`), then
    /// send each tile that differs from what the viewer has.
    pub fn show(&mut self, image: &Image, force: bool) {
        if self.stream.is_none() {
            if !force && self.next_attempt.is_some_and(|t| Instant::now() < t) {
                return;
            }
            self.connect(image.width, image.height);
        }
        if self.stream.is_none() {
            return;
        }
        let (w, h) = (image.width, image.height);
        let mut tile = Vec::with_capacity((TILE * TILE * 3) as usize);
        for y0 in (0..h).step_by(TILE as usize) {
            for x0 in (0..w).step_by(TILE as usize) {
                let (tw, th) = (TILE.min(w - x0), TILE.min(h - y0));
                let rows = (y0..y0 + th).map(|y| (y * w + x0) as usize..(y * w + x0 + tw) as usize);
                if let Some(old) = &self.shown {
                    let same = rows.clone().all(|r| {
                        image.rgb[r.clone()].iter().zip(&old.rgb[r]).all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits))
                    });
                    if same {
                        continue;
                    }
                }
                tile.clear();
                for r in rows {
                    tile.extend(image.rgb[r].iter().flatten());
                }
                let packet = update_image(&self.name, false, &CHANNELS, x0, y0, tw, th, &tile);
                if !self.send(&packet) {
                    return;
                }
            }
        }
        self.shown = Some(image.clone());
    }
}

/// Start the thread that shows each new frame of `slot` on the viewer at `target`; it ends after
/// the last frame.
pub fn spawn(target: Target, name: String, slot: Arc<Slot>, warn: Warn) -> Result<JoinHandle<()>> {
    std::thread::Builder::new()
        .name("lucent-tev".into())
        .spawn(move || {
            let mut client = Client::new(target, name, warn);
            let mut seen = 0;
            loop {
                let (version, frame) = slot.wait_newer(seen);
                seen = version;
                // The last frame is worth one more try at a viewer that was away.
                let before = super::cpu_time(false).unwrap_or_default();
                client.show(&frame.film.to_image(), frame.end.is_some());
                let after = super::cpu_time(false).unwrap_or_default();
                slot.report_cpu(after, after.saturating_sub(before));
                if frame.end.is_some() {
                    break;
                }
            }
        })
        .context("cannot start the display-server thread")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;
    use std::net::TcpListener;
    use std::sync::Mutex;

    /// Bytes of `v` little-endian, for writing out expected packets.
    fn le32(v: u32) -> [u8; 4] {
        v.to_le_bytes()
    }

    #[test]
    fn create_image_packet_is_byte_exact() {
        // "im", 3×2, channels R, G, B: 4 length + 1 type + 1 focus + 3 "im\0" + 12 sizes + 6 names = 27.
        let mut want = Vec::new();
        want.extend(le32(27));
        want.push(4);
        want.push(1);
        want.extend(b"im\0");
        want.extend(le32(3));
        want.extend(le32(2));
        want.extend(le32(3));
        want.extend(b"R\0G\0B\0");
        assert_eq!(create_image("im", true, 3, 2, &CHANNELS), want);
    }

    #[test]
    fn update_image_v3_packet_is_byte_exact() {
        // A 2×1 tile at (5, 7), channels R, G, B interleaved: header 4 + 1 + 1 + 3 + 4 + 6 + 16,
        // offsets 0, 1, 2 and strides 3, 3, 3 as i64 (48), then 6 floats (24): 107 bytes.
        let px = [1.0f32, 0.5, -2.0, 0.25, 3.0, 1e-3];
        let mut want = Vec::new();
        want.extend(le32(107));
        want.push(6);
        want.push(0);
        want.extend(b"im\0");
        want.extend(le32(3));
        want.extend(b"R\0G\0B\0");
        for v in [5u32, 7, 2, 1] {
            want.extend(le32(v));
        }
        for v in [0u64, 1, 2, 3, 3, 3] {
            want.extend(v.to_le_bytes());
        }
        for v in px {
            want.extend(v.to_bits().to_le_bytes());
        }
        assert_eq!(want.len(), 107);
        assert_eq!(update_image("im", false, &CHANNELS, 5, 7, 2, 1, &px), want);
    }

    #[test]
    fn close_image_packet_is_byte_exact() {
        assert_eq!(close_image("im"), vec![8, 0, 0, 0, 2, b'i', b'm', 0]);
        // A NUL inside a name cannot end the string early.
        assert_eq!(close_image("a\0b"), vec![9, 0, 0, 0, 2, b'a', b'?', b'b', 0]);
    }

    #[test]
    fn targets_need_host_and_port() {
        assert_eq!(Target::parse("127.0.0.1:14158").unwrap().addrs[0].port(), 14158);
        for bad in ["14158", ":14158", "localhost", "localhost:0", "localhost:99999", "localhost:x"] {
            let e = Target::parse(bad).unwrap_err().to_string();
            assert!(e.contains("HOST:PORT") && e.contains(bad), "{bad}: {e}");
        }
    }

    /// Split a byte stream into packets by their length fields.
    fn packets(mut bytes: &[u8]) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        while bytes.len() >= 4 {
            let n = u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
            out.push(bytes[..n].to_vec());
            bytes = &bytes[n..];
        }
        assert!(bytes.is_empty(), "a partial packet at the end");
        out
    }

    #[test]
    fn client_sends_create_then_only_changed_tiles() {
        // A 200×130 image is 2×2 tiles of at most 128×128. After a first full show, changing one
        // pixel of the bottom-right tile sends that tile only.
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let target = Target::parse(&listener.local_addr().unwrap().to_string()).unwrap();
        let reader = std::thread::spawn(move || {
            let (mut s, _) = listener.accept().unwrap();
            let mut all = Vec::new();
            s.read_to_end(&mut all).unwrap();
            all
        });
        let warnings = Arc::new(Mutex::new(Vec::<String>::new()));
        let w2 = warnings.clone();
        let mut client = Client::new(target, "t".into(), Arc::new(move |m: &str| w2.lock().unwrap().push(m.to_string())));
        let mut image = Image::new(200, 130);
        for (i, p) in image.rgb.iter_mut().enumerate() {
            *p = [i as f32, 0.5, 1.0];
        }
        client.show(&image, false);
        client.show(&image, false); // unchanged: nothing sent
        image.set(150, 129, [9.0, 9.0, 9.0]);
        client.show(&image, false);
        drop(client);
        let got = packets(&reader.join().unwrap());
        assert!(warnings.lock().unwrap().is_empty());
        assert_eq!(got.len(), 1 + 4 + 1);
        assert_eq!(got[0], create_image("t", true, 200, 130, &CHANNELS));
        let tile = |img: &Image, x0: u32, y0: u32, w: u32, h: u32| {
            let px: Vec<f32> = (y0..y0 + h).flat_map(|y| (x0..x0 + w).flat_map(move |x| img.get(x, y))).collect();
            update_image("t", false, &CHANNELS, x0, y0, w, h, &px)
        };
        let mut first = image.clone();
        first.set(150, 129, [(129 * 200 + 150) as f32, 0.5, 1.0]);
        assert_eq!(got[1], tile(&first, 0, 0, 128, 128));
        assert_eq!(got[2], tile(&first, 128, 0, 72, 128));
        assert_eq!(got[3], tile(&first, 0, 128, 128, 2));
        assert_eq!(got[4], tile(&first, 128, 128, 72, 2));
        assert_eq!(got[5], tile(&image, 128, 128, 72, 2));
    }

    #[test]
    fn a_vanished_viewer_gives_one_warning() {
        // Nothing listens on a port just freed: the first show warns, later ones within the
        // retry interval neither connect nor warn again.
        let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let warnings = Arc::new(Mutex::new(Vec::<String>::new()));
        let w2 = warnings.clone();
        let target = Target::parse(&format!("127.0.0.1:{port}")).unwrap();
        let mut client = Client::new(target, "t".into(), Arc::new(move |m: &str| w2.lock().unwrap().push(m.to_string())));
        let image = Image::new(4, 4);
        for _ in 0..3 {
            client.show(&image, false);
        }
        client.show(&image, true);
        assert!(!client.connected());
        let w = warnings.lock().unwrap();
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("cannot connect") && w[0].contains(&port.to_string()), "{}", w[0]);
    }
}
