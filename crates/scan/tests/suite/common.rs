//! Helpers shared by the scan tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use scan::decode::Capture;
use scan::graycode::PatternSet;

/// The shared real captures (kamino410/procam-calibration sample data), `capture_0` … `capture_2`.
pub fn sample_capture(i: usize) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../../shared/data/structured-light/procam-sample/capture_{i}"))
}

/// A fresh empty folder under the target directory, unique per call.
pub fn scratch(name: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let n = N.fetch_add(1, Ordering::SeqCst);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("scan-{name}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The pattern frames as a capture seen by a camera that is the projector image itself (1:1).
pub fn ideal_capture(p: &PatternSet) -> Capture {
    Capture { width: p.width as usize, height: p.height as usize, frames: (0..p.len()).map(|i| p.image(i).unwrap()).collect() }
}

/// Writes a capture as `graycode_NN.png` files into `dir`.
pub fn write_capture(dir: &Path, c: &Capture) {
    for (i, f) in c.frames.iter().enumerate() {
        let img = image::GrayImage::from_raw(c.width as u32, c.height as u32, f.clone()).unwrap();
        img.save(dir.join(format!("graycode_{i:02}.png"))).unwrap();
    }
}
