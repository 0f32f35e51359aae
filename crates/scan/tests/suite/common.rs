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

/// A synthetic projector–camera calibration in units where the scene is about 1 away: camera
/// 320×240, projector 256×192 to the camera's right, rotated 12° about y towards it, both with
/// OpenCV distortion.
pub fn synthetic_calibration() -> scan::calib::ProcamCalibration {
    use scan::calib::{DeviceCalibration, ProcamCalibration};
    let dev = |width, height, fx, fy, cx, cy, distortion: Vec<f64>| DeviceCalibration { width, height, fx, fy, cx, cy, distortion, rms_px: 0.0 };
    let a = 12f64.to_radians();
    // X_p = R X_c + T with the projector centre at (0.25, −0.02, 0.05) in camera coordinates.
    let rotation = [[a.cos(), 0.0, a.sin()], [0.0, 1.0, 0.0], [-a.sin(), 0.0, a.cos()]];
    let c = [0.25, -0.02, 0.05];
    let t = [0, 1, 2].map(|i| -(rotation[i][0] * c[0] + rotation[i][1] * c[1] + rotation[i][2] * c[2]));
    ProcamCalibration {
        camera: dev(320, 240, 400.0, 402.0, 161.3, 118.7, vec![-0.12, 0.05, 0.001, -0.0007, 0.01]),
        projector: dev(256, 192, 330.0, 331.0, 127.0, 100.0, vec![0.04, -0.02, -0.0004, 0.0006, 0.0]),
        rotation,
        translation: t,
        rms_px: 0.0,
        captures: Vec::new(),
    }
}
