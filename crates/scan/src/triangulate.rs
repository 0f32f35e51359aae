//! Triangulation of camera–projector correspondences with a [`ProcamCalibration`].
//!
//! Frame and units: camera coordinates (OpenCV axes: x right, y down, z forward, origin at the
//! camera centre), lengths in the calibration's unit (chessboard square units). The projector
//! maps camera coordinates as X_p = R·X_c + T; its centre is C_p = −Rᵀ·T.
//!
//! A camera pixel (u, v) and its projector coordinate (u_p, v_p) (both OpenCV pixel positions,
//! integers at pixel centres) give two rays: each pixel is undistorted to normalised coordinates
//! (x′, y′) by Newton's method on OpenCV's distortion model (`render::camera::OpenCv::undistort`,
//! residual below 1e-9 px), the camera ray is t·(x′, y′, 1), the projector ray
//! C_p + s·Rᵀ(x′_p, y′_p, 1). The point is the midpoint of the shortest segment between the two
//! rays (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., §12.2, the mid-point method), and
//! the segment's length is the ray gap, a quality figure (0 for exact correspondences; it grows
//! with decoding noise and calibration error). Both ray parameters must be positive (the point
//! in front of both devices).

use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};

use crate::calib::{DeviceCalibration, ProcamCalibration};
use crate::decode::DecodeMap;

/// A calibrated camera–projector pair ready to triangulate.
#[derive(Clone, Debug)]
pub struct Rig {
    camera: OpenCv,
    projector: OpenCv,
    /// Rotation camera → projector (row-major).
    r: [[f64; 3]; 3],
    /// Projector centre in camera coordinates (square units).
    projector_centre: [f64; 3],
    /// Camera image size (pixels).
    pub camera_size: (u32, u32),
    /// Projector image size (pixels).
    pub projector_size: (u32, u32),
}

/// One triangulated correspondence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangulated {
    /// The midpoint, camera coordinates (square units).
    pub point: [f64; 3],
    /// Distance between the two rays at their closest approach (square units).
    pub ray_gap: f64,
}

fn device(d: &DeviceCalibration, extrinsics: Extrinsics, what: &str) -> Result<OpenCv> {
    let distortion = Distortion::from_opencv(&d.distortion).with_context(|| format!("{what}.distortion"))?;
    OpenCv::new(Intrinsics { fx: d.fx, fy: d.fy, cx: d.cx, cy: d.cy }, distortion, extrinsics, d.width, d.height).with_context(|| what.to_string())
}

impl Rig {
    /// The rig of a calibration; an error naming the field for a bad one (non-positive focal
    /// length, a distortion not invertible over the image, a rotation that is not one).
    pub fn new(c: &ProcamCalibration) -> Result<Rig> {
        let identity = Extrinsics::from_rt([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3])?;
        let camera = device(&c.camera, identity, "camera")?;
        let pose = Extrinsics::from_rt(c.rotation, c.translation).context("rotation, translation")?;
        let projector = device(&c.projector, pose, "projector")?;
        Ok(Rig {
            camera,
            projector,
            r: c.rotation,
            projector_centre: pose.centre_m(),
            camera_size: (c.camera.width, c.camera.height),
            projector_size: (c.projector.width, c.projector.height),
        })
    }

    /// Mean camera focal length (pixels).
    pub fn camera_focal_px(&self) -> f64 {
        0.5 * (self.camera.intrinsics.fx + self.camera.intrinsics.fy)
    }

    /// Triangulates camera pixel position `cam` with projector pixel position `proj` (OpenCV
    /// convention); None where a pixel cannot be undistorted, the rays are parallel, or the
    /// point is not in front of both devices.
    pub fn triangulate(&self, cam: [f64; 2], proj: [f64; 2]) -> Option<Triangulated> {
        let d1 = normalised(&self.camera, cam)?;
        let dp = normalised(&self.projector, proj)?;
        // Projector direction in camera coordinates: Rᵀ·dp.
        let r = &self.r;
        let d2 = [0, 1, 2].map(|k| r[0][k] * dp[0] + r[1][k] * dp[1] + r[2][k] * dp[2]);
        let o2 = self.projector_centre;
        // Closest points of o1 + s·d1 (o1 = 0) and o2 + t·d2.
        let w0 = [-o2[0], -o2[1], -o2[2]];
        let (a, b, c) = (dot(d1, d1), dot(d1, d2), dot(d2, d2));
        let (d, e) = (dot(d1, w0), dot(d2, w0));
        let den = a * c - b * b;
        if !(den > 1e-14 * a * c) {
            return None;
        }
        let s = (b * e - c * d) / den;
        let t = (a * e - b * d) / den;
        if !(s > 0.0 && t > 0.0) {
            return None;
        }
        let p1 = [s * d1[0], s * d1[1], s * d1[2]];
        let p2 = [o2[0] + t * d2[0], o2[1] + t * d2[1], o2[2] + t * d2[2]];
        let gap = ((p1[0] - p2[0]).powi(2) + (p1[1] - p2[1]).powi(2) + (p1[2] - p2[2]).powi(2)).sqrt();
        Some(Triangulated { point: [0.5 * (p1[0] + p2[0]), 0.5 * (p1[1] + p2[1]), 0.5 * (p1[2] + p2[2])], ray_gap: gap })
    }

    /// Projects a camera-coordinate point into the camera and the projector (OpenCV pixel
    /// positions, distortion applied); None behind either.
    pub fn project(&self, p: [f64; 3]) -> Option<([f64; 2], [f64; 2])> {
        Some((self.camera.project_pixel(p)?, self.projector.project_pixel(p)?))
    }
}

/// Undistorted normalised direction (x′, y′, 1) of an OpenCV pixel position.
fn normalised(dev: &OpenCv, px: [f64; 2]) -> Option<[f64; 3]> {
    let k = &dev.intrinsics;
    let (x, y, ok) = dev.undistort((px[0] - k.cx) / k.fx, (px[1] - k.cy) / k.fy);
    (ok && x.is_finite() && y.is_finite()).then_some([x, y, 1.0])
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Triangulated points over the camera image (row-major), None where a pixel is invalid or
/// did not triangulate.
#[derive(Clone, Debug)]
pub struct RangeImage {
    /// Camera image width (pixels).
    pub width: usize,
    /// Camera image height (pixels).
    pub height: usize,
    /// Per camera pixel: the point and its ray gap.
    pub points: Vec<Option<Triangulated>>,
    /// Camera focal length (pixels), for the footprint of a pixel at a depth.
    pub focal_px: f64,
}

/// Triangulates every valid pixel of a decode map; `progress` is called once per camera row.
/// An error when the map's size differs from the calibrated camera's.
pub fn triangulate_map(map: &DecodeMap, rig: &Rig, progress: &(dyn Fn() + Sync)) -> Result<RangeImage> {
    if (map.width as u32, map.height as u32) != rig.camera_size {
        bail!("the capture is {}x{} pixels but the calibrated camera is {}x{}", map.width, map.height, rig.camera_size.0, rig.camera_size.1);
    }
    let w = map.width;
    let mut points = vec![None; w * map.height];
    points.par_chunks_mut(w).enumerate().for_each(|(y, line)| {
        for (x, p) in line.iter_mut().enumerate() {
            let i = y * w + x;
            let (c, r) = (map.col[i], map.row[i]);
            if c.is_finite() && r.is_finite() {
                *p = rig.triangulate([x as f64, y as f64], [c as f64, r as f64]);
            }
        }
        progress();
    });
    Ok(RangeImage { width: w, height: map.height, points, focal_px: rig.camera_focal_px() })
}
