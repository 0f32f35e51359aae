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

// A synthetic projector–camera rig with known truth (calibration tests).
use nalgebra::Vector3;
use scan::calib::bundle::{State, ViewObs};
use scan::calib::homography::Point2;
use scan::calib::model::{Lens, Pose};
use scan::calib::zhang::board_points;

/// A synthetic rig: a 1280 × 1024 camera and a 1024 × 768 projector with OpenCV distortion, the
/// projector 150 units to the right of the camera and turned towards it, and five board poses.
pub fn rig(distorted: bool) -> State {
    let mut cam = Lens::pinhole(1780.0, 1772.0, 651.0, 497.0);
    let mut proj = Lens::pinhole(2210.0, 2205.0, 498.0, 790.0);
    if distorted {
        cam.dist = [-0.12, 0.18, 0.0007, -0.0004, -0.05];
        proj.dist = [0.03, -0.09, -0.0011, 0.0006, 0.02];
    }
    let stereo = Pose { rvec: Vector3::new(0.02, -0.21, 0.01), t: Vector3::new(-160.0, 8.0, 25.0) };
    let poses = [
        ([0.05, 0.02, 0.01], [-340.0, -250.0, 2300.0]),
        ([0.45, -0.10, 0.05], [-300.0, -260.0, 2400.0]),
        ([-0.35, 0.15, -0.08], [-320.0, -200.0, 2250.0]),
        ([0.10, 0.50, 0.12], [-280.0, -240.0, 2500.0]),
        ([-0.08, -0.45, -0.15], [-380.0, -230.0, 2200.0]),
    ]
    .iter()
    .map(|(r, t)| Pose { rvec: Vector3::from(*r), t: Vector3::from(*t) })
    .collect();
    State { cam, proj: Some(proj), stereo, poses }
}

/// The 9 × 7 board of 75-unit squares.
pub fn board() -> Vec<Point2> {
    board_points(9, 7, 75.0)
}

/// Noiseless projections of the board in every view of `s`.
pub fn observe(s: &State, obj: &[Point2]) -> Vec<ViewObs> {
    let proj = s.proj.unwrap();
    s.poses
        .iter()
        .map(|pose| {
            let xs: Vec<Vector3<f64>> = obj.iter().map(|p| pose.apply(&Vector3::new(p[0], p[1], 0.0))).collect();
            ViewObs {
                cam: xs.iter().map(|x| s.cam.project(x)).collect(),
                proj: xs.iter().map(|x| proj.project(&s.stereo.apply(x))).collect(),
            }
        })
        .collect()
}

/// A PCG32 stream (O'Neill 2014) for reproducible noise.
pub struct Pcg(u64);

impl Pcg {
    pub fn new(seed: u64) -> Pcg {
        Pcg(seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407))
    }
    pub fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let x = (((old >> 18) ^ old) >> 27) as u32;
        x.rotate_right((old >> 59) as u32)
    }
    pub fn uniform(&mut self) -> f64 {
        (self.next_u32() as f64 + 0.5) / 4294967296.0
    }
    /// A standard normal deviate (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}
