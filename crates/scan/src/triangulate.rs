//! Triangulation of camera–projector correspondences with a [`ProcamCalibration`].
//!
//! Frame and units: camera coordinates (OpenCV axes: x right, y down, z forward, origin at the
//! camera centre), lengths in the calibration's unit (chessboard square units). The projector
//! maps camera coordinates as X_p = R·X_c + T; its centre is C_p = −Rᵀ·T.
//!
//! A camera pixel (u, v) and its projector coordinate (u_p, v_p) (both OpenCV pixel positions,
//! integers at pixel centres) give two rays: each pixel is undistorted to normalised coordinates
//! (x′, y′) by Newton's method on OpenCV's distortion model (`render::camera::Distortion`) to a
//! residual below 1e-9 px, the solution required inside the radius where the radial map
//! r ↦ r·(radial factor) still increases (the one physical preimage; checked per pixel, so a
//! calibration whose polynomial folds just outside the image corners — common for projectors with
//! an off-centre principal point — still triangulates). The camera ray is t·(x′, y′, 1), the
//! projector ray
//! C_p + s·Rᵀ(x′_p, y′_p, 1). The point is the midpoint of the shortest segment between the two
//! rays (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., §12.2, the mid-point method), and
//! the segment's length is the ray gap, a quality figure (0 for exact correspondences; it grows
//! with decoding noise and calibration error). Both ray parameters must be positive (the point
//! in front of both devices).

use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use render::camera::{Distortion, Extrinsics};

use crate::calib::{DeviceCalibration, ProcamCalibration};
use crate::decode::DecodeMap;

/// One device's intrinsics and distortion with a per-pixel Newton undistortion.
#[derive(Clone, Debug)]
pub(crate) struct Lens {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    d: Distortion,
    /// Squared normalised radius where the radial map stops increasing (∞ if it never does).
    r_fold2: f64,
}

impl Lens {
    pub(crate) fn new(c: &DeviceCalibration, what: &str) -> Result<Lens> {
        if !(c.fx > 0.0 && c.fy > 0.0 && c.fx.is_finite() && c.fy.is_finite()) {
            bail!("{what}: focal lengths fx, fy must be positive pixels, got {}, {}", c.fx, c.fy);
        }
        if !(c.cx.is_finite() && c.cy.is_finite()) {
            bail!("{what}: principal point cx, cy must be finite");
        }
        if c.width == 0 || c.height == 0 {
            bail!("{what}: image size must be at least 1x1");
        }
        let d = Distortion::from_opencv(&c.distortion).with_context(|| format!("{what}.distortion"))?;
        // Walk the radial map outwards (to 10× the image corners' radius) until it turns back.
        let (w, h) = (c.width as f64 - 0.5, c.height as f64 - 0.5);
        let corner = [(-0.5, -0.5), (w, h), (-0.5, h), (w, -0.5)].iter().map(|&(u, v)| ((u - c.cx) / c.fx).hypot((v - c.cy) / c.fy)).fold(0.0f64, f64::max);
        let mut r_fold2 = f64::INFINITY;
        let n = 20000;
        for i in 1..=n {
            let r = 10.0 * corner * i as f64 / n as f64;
            let (f, g, m) = radial(&d, r * r);
            if !(m > 0.0) || !(f + 2.0 * r * r * g > 0.0) {
                r_fold2 = r * r;
                break;
            }
        }
        Ok(Lens { fx: c.fx, fy: c.fy, cx: c.cx, cy: c.cy, d, r_fold2 })
    }

    /// Undistorted normalised coordinates of OpenCV pixel position (u, v); None where Newton's
    /// method does not reach 1e-9 px or lands beyond the fold of the radial map.
    fn undistort(&self, u: f64, v: f64) -> Option<(f64, f64)> {
        let (xd, yd) = ((u - self.cx) / self.fx, (v - self.cy) / self.fy);
        let resid2 = |a: f64, b: f64| ((a - xd) * self.fx).powi(2) + ((b - yd) * self.fy).powi(2);
        let (mut x, mut y) = (xd, yd);
        let ((mut a, mut b), mut j) = distort_jacobian(&self.d, x, y);
        let mut e2 = resid2(a, b);
        for _ in 0..100 {
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if e2 < 1e-18 {
                return (x * x + y * y < self.r_fold2 && det > 0.0).then_some((x, y));
            }
            if !(det.abs() > 0.0) || !det.is_finite() {
                return None;
            }
            let (rx, ry) = (a - xd, b - yd);
            let sx = (j[1][1] * rx - j[0][1] * ry) / det;
            let sy = (j[0][0] * ry - j[1][0] * rx) / det;
            // Halve the step while it does not reduce the residual.
            let mut t = 1.0;
            loop {
                let (nx, ny) = (x - t * sx, y - t * sy);
                let ((na, nb), nj) = distort_jacobian(&self.d, nx, ny);
                let ne2 = resid2(na, nb);
                if ne2 < e2 {
                    (x, y, a, b, j, e2) = (nx, ny, na, nb, nj, ne2);
                    break;
                }
                t *= 0.5;
                if t < 1e-8 {
                    return None;
                }
            }
        }
        None
    }

    /// OpenCV pixel position of a point in this device's coordinates; None behind it.
    fn project(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        if !(p[2] > 0.0) {
            return None;
        }
        let (xd, yd) = self.d.distort(p[0] / p[2], p[1] / p[2]);
        Some([self.fx * xd + self.cx, self.fy * yd + self.cy])
    }

    /// As [`Lens::project`], and None beyond the fold of the radial map, where the distortion
    /// polynomial no longer maps directions one to one onto the image.
    pub(crate) fn project_unfolded(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        if !(p[2] > 0.0) {
            return None;
        }
        let (x, y) = (p[0] / p[2], p[1] / p[2]);
        if !(x * x + y * y < self.r_fold2) {
            return None;
        }
        let (xd, yd) = self.d.distort(p[0] / p[2], p[1] / p[2]);
        Some([self.fx * xd + self.cx, self.fy * yd + self.cy])
    }
}

/// OpenCV's radial factor (1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶), its derivative
/// with respect to r², and the denominator.
fn radial(d: &Distortion, r2: f64) -> (f64, f64, f64) {
    let k = &d.k;
    let n = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
    let dn = k[0] + r2 * (2.0 * k[1] + 3.0 * r2 * k[2]);
    let m = 1.0 + r2 * (k[3] + r2 * (k[4] + r2 * k[5]));
    let dm = k[3] + r2 * (2.0 * k[4] + 3.0 * r2 * k[5]);
    (n / m, (dn * m - n * dm) / (m * m), m)
}

/// The distorted point and the Jacobian [[∂x″/∂x′, ∂x″/∂y′], [∂y″/∂x′, ∂y″/∂y′]].
fn distort_jacobian(d: &Distortion, x: f64, y: f64) -> ((f64, f64), [[f64; 2]; 2]) {
    let r2 = x * x + y * y;
    let (f, g, _) = radial(d, r2);
    let [p1, p2] = d.p;
    let xd = x * f + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    let yd = y * f + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    let off = 2.0 * x * y * g + 2.0 * p1 * x + 2.0 * p2 * y;
    ((xd, yd), [[f + 2.0 * x * x * g + 2.0 * p1 * y + 6.0 * p2 * x, off], [off, f + 2.0 * y * y * g + 6.0 * p1 * y + 2.0 * p2 * x]])
}

/// A calibrated camera–projector pair ready to triangulate.
#[derive(Clone, Debug)]
pub struct Rig {
    camera: Lens,
    projector: Lens,
    /// Rotation camera → projector (row-major).
    r: [[f64; 3]; 3],
    /// Translation camera → projector (square units).
    t: [f64; 3],
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

impl Rig {
    /// The rig of a calibration; an error naming the field for a bad one (non-positive focal
    /// length, bad distortion coefficients, a rotation that is not one).
    pub fn new(c: &ProcamCalibration) -> Result<Rig> {
        let camera = Lens::new(&c.camera, "camera")?;
        let projector = Lens::new(&c.projector, "projector")?;
        let pose = Extrinsics::from_rt(c.rotation, c.translation).context("rotation, translation")?;
        Ok(Rig {
            camera,
            projector,
            r: c.rotation,
            t: c.translation,
            projector_centre: pose.centre_m(),
            camera_size: (c.camera.width, c.camera.height),
            projector_size: (c.projector.width, c.projector.height),
        })
    }

    /// Mean camera focal length (pixels).
    pub fn camera_focal_px(&self) -> f64 {
        0.5 * (self.camera.fx + self.camera.fy)
    }

    /// Triangulates camera pixel position `cam` with projector pixel position `proj` (OpenCV
    /// convention); None where a pixel cannot be undistorted, the rays are parallel, or the
    /// point is not in front of both devices.
    pub fn triangulate(&self, cam: [f64; 2], proj: [f64; 2]) -> Option<Triangulated> {
        let (x, y) = self.camera.undistort(cam[0], cam[1])?;
        let d1 = [x, y, 1.0];
        let (xp, yp) = self.projector.undistort(proj[0], proj[1])?;
        // Projector direction in camera coordinates: Rᵀ·(x′_p, y′_p, 1).
        let r = &self.r;
        let d2 = [0, 1, 2].map(|k| r[0][k] * xp + r[1][k] * yp + r[2][k]);
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

    /// Undistorted normalised coordinates (x′, y′) of a camera pixel position (OpenCV convention);
    /// None where Newton's method fails or lands beyond the fold of the radial map.
    pub fn undistort_camera(&self, px: [f64; 2]) -> Option<[f64; 2]> {
        self.camera.undistort(px[0], px[1]).map(|(x, y)| [x, y])
    }

    /// [`Rig::undistort_camera`] for the projector (the second view).
    pub fn undistort_projector(&self, px: [f64; 2]) -> Option<[f64; 2]> {
        self.projector.undistort(px[0], px[1]).map(|(x, y)| [x, y])
    }

    /// Camera pixel position of a point in camera coordinates (distortion applied); None behind it.
    pub fn project_camera(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        self.camera.project(p)
    }

    /// Projector pixel position of a point in projector coordinates; None behind it.
    pub fn project_projector(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        self.projector.project(p)
    }

    /// Mean projector focal length (pixels).
    pub fn projector_focal_px(&self) -> f64 {
        0.5 * (self.projector.fx + self.projector.fy)
    }

    /// Projects a camera-coordinate point into the camera and the projector (OpenCV pixel
    /// positions, distortion applied); None behind either.
    pub fn project(&self, p: [f64; 3]) -> Option<([f64; 2], [f64; 2])> {
        let r = &self.r;
        let q = [0, 1, 2].map(|i| r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + self.t[i]);
        Some((self.camera.project(p)?, self.projector.project(q)?))
    }
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

/// The point seen at pixel `a` through the projection matrix `p1` and at `b` through `p2`, by
/// the linear (DLT) method OpenCV's `triangulatePoints` uses (Hartley & Zisserman, *Multiple
/// View Geometry*, 2nd ed., §12.2): the right singular vector of the smallest singular value of
/// the 4 × 4 system (u·p₃ − p₁, v·p₃ − p₂ for each view), in homogeneous coordinates of unit
/// length with w ≥ 0 (OpenCV leaves the sign as its SVD gives it).
pub fn triangulate_dlt(p1: &nalgebra::Matrix3x4<f64>, p2: &nalgebra::Matrix3x4<f64>, a: [f64; 2], b: [f64; 2]) -> [f64; 4] {
    let mut m = nalgebra::Matrix4::zeros();
    for (j, (p, x)) in [(p1, a), (p2, b)].into_iter().enumerate() {
        for k in 0..4 {
            m[(2 * j, k)] = x[0] * p[(2, k)] - p[(0, k)];
            m[(2 * j + 1, k)] = x[1] * p[(2, k)] - p[(1, k)];
        }
    }
    // The null vector of M is the eigenvector of MᵀM with the least eigenvalue.
    let eig = nalgebra::SymmetricEigen::new(m.transpose() * m);
    let i = eig.eigenvalues.imin();
    let mut v = eig.eigenvectors.column(i).into_owned();
    if v[3] < 0.0 {
        v = -v;
    }
    [v[0], v[1], v[2], v[3]]
}

#[cfg(test)]
mod dlt_tests {
    use super::*;
    use nalgebra::{Matrix3, Matrix3x4, Rotation3, Vector3, Vector4};

    /// Exact projections through two cameras give back the point to rounding, in unit-length
    /// homogeneous coordinates with w > 0; a point at infinity (parallel rays) gives w ≈ 0.
    #[test]
    fn dlt_recovers_exact_points() {
        let k = Matrix3::new(800.0, 0.0, 320.0, 0.0, 790.0, 240.0, 0.0, 0.0, 1.0);
        let r = *Rotation3::new(Vector3::new(0.03, -0.1, 0.02)).matrix();
        let t = Vector3::new(-150.0, 5.0, 10.0);
        let p1 = k * Matrix3x4::identity();
        let mut rt = Matrix3x4::zeros();
        rt.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        rt.set_column(3, &t);
        let p2 = k * rt;
        let pix = |p: &Matrix3x4<f64>, x: &Vector3<f64>| {
            let h = p * Vector4::new(x.x, x.y, x.z, 1.0);
            [h.x / h.z, h.y / h.z]
        };
        for x in [Vector3::new(10.0, -20.0, 700.0), Vector3::new(-200.0, 90.0, 2500.0), Vector3::new(0.5, 0.5, 300.0)] {
            let h = triangulate_dlt(&p1, &p2, pix(&p1, &x), pix(&p2, &x));
            assert!((h.iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 1e-12 && h[3] > 0.0);
            let back = Vector3::new(h[0], h[1], h[2]) / h[3];
            assert!((back - x).norm() < 1e-9 * x.norm(), "{back:?} vs {x:?}");
        }
        let far = Vector3::new(0.2, -0.1, 1.0);
        let h = triangulate_dlt(&p1, &p2, pix(&p1, &(far * 1e12)), pix(&(k * Matrix3x4::identity()), &(r * far)));
        assert!(h[3].abs() < 1e-6, "{h:?}");
    }
}
