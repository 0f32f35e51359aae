//! The OpenCV camera model (OpenCV's "Camera Calibration and 3D Reconstruction" documentation,
//! `calib3d`): a pinhole with intrinsics fx, fy, cx, cy (pixels), radial distortion k1, k2, k3
//! and the rational model's k4, k5, k6, tangential distortion p1, p2, thin-prism distortion
//! s1…s4, the tilted sensor's τx, τy, and extrinsics R, t mapping world to camera coordinates
//! (x right, y down, z forward).
//!
//! A world point X projects as
//!   (X, Y, Z) = R·X_w + t,   x′ = X/Z,   y′ = Y/Z,   r² = x′² + y′²,
//!   x″ = x′·(1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶) + 2 p1 x′y′ + p2 (r² + 2x′²)
//!        + s1 r² + s2 r⁴,
//!   y″ = y′·(same radial factor) + p1 (r² + 2y′²) + 2 p2 x′y′ + s3 r² + s4 r⁴,
//!   (a, b, c) = M(τx, τy)·(x″, y″, 1),   u = fx a/c + cx,   v = fy b/c + cy,
//! where the tilt M = P_z·R_xy, R_xy = R_y(τy)·R_x(τx) (R_x = [[1, 0, 0], [0, cos τx, sin τx],
//! [0, −sin τx, cos τx]], R_y = [[cos τy, 0, −sin τy], [0, 1, 0], [sin τy, 0, cos τy]]) and
//! P_z = [[R₂₂, 0, −R₀₂], [0, R₂₂, −R₁₂], [0, 0, 1]] of R = R_xy: the projection onto a sensor
//! tilted by τx about x and τy about y (Louhichi et al. 2007, as OpenCV implements it). With
//! τx = τy = 0, M is the identity.
//!
//! Pixel convention: OpenCV puts integer coordinates at pixel centres, so pixel (i, j) of the
//! film, sampled at offset (uₓ, u_y) ∈ [0,1)², is OpenCV position (i + uₓ − ½, j + u_y − ½):
//! pixel (i, j) covers [i − ½, i + ½) × [j − ½, j + ½) in OpenCV coordinates, and lucent's
//! continuous film coordinate is the OpenCV coordinate plus ½.
//!
//! Rays need the inverse of the distortion map (x′, y′) ↦ (x″, y″). The tilt is a homography,
//! inverted exactly first; the rest is solved per ray by Newton's method in f64 from (x″, y″)
//! to a residual below 1e-9 px: about four iterations of a closed-form 2×2 Jacobian (quadratic convergence from a 50 px start at the image corners),
//! no per-pixel cache; the `camera` test suite times it against the pinhole's ray and a path
//! sample (about a tenth of a Cornell-box path sample). Parameters for which the map is not invertible over the
//! image are refused when the camera is built ([`OpenCv::new`]).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use anyhow::{bail, Result};

/// Intrinsics in pixels (OpenCV's camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels, OpenCV convention: 0 is the centre of the first column).
    pub cx: f64,
    /// Principal point y (pixels, OpenCV convention: 0 is the centre of the first row).
    pub cy: f64,
}

impl Intrinsics {
    /// From OpenCV's camera matrix, row-major: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with finite
    /// fx, fy > 0 and no skew.
    pub fn from_camera_matrix(k: &[f64]) -> Result<Intrinsics> {
        let ok = k.len() == 9 && k.iter().all(|x| x.is_finite()) && k[1] == 0.0 && k[3] == 0.0 && k[6] == 0.0 && k[7] == 0.0 && k[8] == 1.0;
        if !ok || !(k[0] > 0.0 && k[4] > 0.0) {
            bail!("expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with finite fx, fy > 0 (no skew), got {k:?}");
        }
        Ok(Intrinsics { fx: k[0], fy: k[4], cx: k[2], cy: k[5] })
    }
}

/// Distortion coefficients (dimensionless, acting on normalised image coordinates; the tilt in
/// radians).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Distortion {
    /// Radial k1…k6 (k4…k6: denominator of the rational model).
    pub k: [f64; 6],
    /// Tangential p1, p2.
    pub p: [f64; 2],
    /// Thin prism s1…s4 (x″ gains s1 r² + s2 r⁴, y″ gains s3 r² + s4 r⁴).
    pub s: [f64; 4],
    /// Sensor tilt τx, τy (radians) about the x and y axes.
    pub tau_rad: [f64; 2],
}

/// 3×3 matrix product.
fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// The tilt homography M(τx, τy) of the module documentation.
pub fn tilt_matrix(tau_x_rad: f64, tau_y_rad: f64) -> [[f64; 3]; 3] {
    let (sx, cx) = tau_x_rad.sin_cos();
    let (sy, cy) = tau_y_rad.sin_cos();
    let rot_x = [[1.0, 0.0, 0.0], [0.0, cx, sx], [0.0, -sx, cx]];
    let rot_y = [[cy, 0.0, -sy], [0.0, 1.0, 0.0], [sy, 0.0, cy]];
    let r = mat_mul(&rot_y, &rot_x);
    let proj_z = [[r[2][2], 0.0, -r[0][2]], [0.0, r[2][2], -r[1][2]], [0.0, 0.0, 1.0]];
    mat_mul(&proj_z, &r)
}

impl Distortion {
    /// Whether the radial part of the map, r ↦ r·g(r²) with g = (1 + k1 s + k2 s² + k3 s³) /
    /// (1 + k4 s + k5 s² + k6 s³), is positive and increasing at s = r² (the monotone branch).
    pub fn radial_increasing(&self, s: f64) -> bool {
        let [k1, k2, k3, k4, k5, k6] = self.k;
        let n = 1.0 + s * (k1 + s * (k2 + s * k3));
        let dn = k1 + s * (2.0 * k2 + 3.0 * s * k3);
        let m = 1.0 + s * (k4 + s * (k5 + s * k6));
        let dm = k4 + s * (2.0 * k5 + 3.0 * s * k6);
        let g = n / m;
        let dg = (dn * m - n * dm) / (m * m);
        g > 0.0 && g + 2.0 * s * dg > 0.0
    }

    /// From OpenCV's coefficient vector (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, τx,
    /// τy]]]]): 0, 4, 5, 8, 12 or 14 entries, τ in radians.
    pub fn from_opencv(c: &[f64]) -> Result<Distortion> {
        if !matches!(c.len(), 0 | 4 | 5 | 8 | 12 | 14) {
            bail!("distortion has {} coefficients; OpenCV uses 4, 5, 8, 12 or 14 (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1..s4[, tx, ty]]]])", c.len());
        }
        if let Some(x) = c.iter().find(|x| !x.is_finite()) {
            bail!("distortion coefficient {x} is not finite");
        }
        let g = |i: usize| c.get(i).copied().unwrap_or(0.0);
        let tau_rad = [g(12), g(13)];
        if tau_rad.iter().any(|t| t.abs() >= std::f64::consts::FRAC_PI_4) {
            bail!("sensor tilt τx, τy = {}, {} rad: a tilt of 45° or more is not a lens model", tau_rad[0], tau_rad[1]);
        }
        Ok(Distortion { k: [g(0), g(1), g(4), g(5), g(6), g(7)], p: [g(2), g(3)], s: [g(8), g(9), g(10), g(11)], tau_rad })
    }

    /// Whether the sensor is tilted (τx or τy not 0).
    #[inline]
    fn tilted(&self) -> bool {
        self.tau_rad != [0.0, 0.0]
    }

    /// The tilt homography M(τx, τy) (identity without tilt).
    pub fn tilt(&self) -> [[f64; 3]; 3] {
        tilt_matrix(self.tau_rad[0], self.tau_rad[1])
    }

    /// (x″, y″) of a point (a, b) on the tilted sensor's normalised plane: M⁻¹·(a, b, 1)
    /// dehomogenised; None where it lies at or behind infinity.
    pub fn untilt(&self, a: f64, b: f64) -> Option<(f64, f64)> {
        if !self.tilted() {
            return Some((a, b));
        }
        let m = self.tilt();
        let inv = inverse3(&m)?;
        let v = mat_vec(&inv, [a, b, 1.0]);
        (v[2] > 0.0).then(|| (v[0] / v[2], v[1] / v[2]))
    }

    /// Radial factor (1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶), its derivative with
    /// respect to r², and the denominator.
    #[inline]
    fn radial(&self, r2: f64) -> (f64, f64, f64) {
        let k = &self.k;
        let n = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
        let dn = k[0] + r2 * (2.0 * k[1] + 3.0 * r2 * k[2]);
        let m = 1.0 + r2 * (k[3] + r2 * (k[4] + r2 * k[5]));
        let dm = k[3] + r2 * (2.0 * k[4] + 3.0 * r2 * k[5]);
        (n / m, (dn * m - n * dm) / (m * m), m)
    }

    /// Distorted normalised coordinates of undistorted (x′, y′): (x″, y″) carried through the tilt,
    /// (a/c, b/c) of the module documentation (u = fx·a/c + cx).
    #[inline]
    pub fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let r2 = x * x + y * y;
        let (f, _, _) = self.radial(r2);
        let ([p1, p2], [s1, s2, s3, s4]) = (self.p, self.s);
        let xd = x * f + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (s1 + s2 * r2);
        let yd = y * f + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (s3 + s4 * r2);
        if !self.tilted() {
            return (xd, yd);
        }
        let v = mat_vec(&self.tilt(), [xd, yd, 1.0]);
        (v[0] / v[2], v[1] / v[2])
    }

    /// (x″, y″) before the tilt and the Jacobian [[∂x″/∂x′, ∂x″/∂y′], [∂y″/∂x′, ∂y″/∂y′]].
    #[inline]
    fn distort_jacobian(&self, x: f64, y: f64) -> ((f64, f64), [[f64; 2]; 2]) {
        let r2 = x * x + y * y;
        let (f, g, _) = self.radial(r2);
        let [p1, p2] = self.p;
        let [s1, s2, s3, s4] = self.s;
        let xd = x * f + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (s1 + s2 * r2);
        let yd = y * f + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (s3 + s4 * r2);
        // d(s r² + s′ r⁴)/dx = 2x (s + 2 s′ r²), likewise in y.
        let (px, py) = (2.0 * (s1 + 2.0 * s2 * r2), 2.0 * (s3 + 2.0 * s4 * r2));
        let off = 2.0 * x * y * g + 2.0 * p1 * x + 2.0 * p2 * y;
        let j = [
            [f + 2.0 * x * x * g + 2.0 * p1 * y + 6.0 * p2 * x + px * x, off + px * y],
            [off + py * x, f + 2.0 * y * y * g + 6.0 * p1 * y + 2.0 * p2 * x + py * y],
        ];
        ((xd, yd), j)
    }

    /// Whether every coefficient is zero (the map is the identity).
    pub fn is_zero(&self) -> bool {
        self.k.iter().chain(self.p.iter()).chain(self.s.iter()).chain(self.tau_rad.iter()).all(|&c| c == 0.0)
    }
}

/// World-to-camera rigid transform: X_cam = R·X_world + t (OpenCV axes: x right, y down, z forward).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extrinsics {
    /// Rotation, rows are the camera axes in world coordinates.
    pub r: [[f64; 3]; 3],
    /// Translation (m).
    pub t_m: [f64; 3],
}

impl Extrinsics {
    /// The identity: camera frame = world frame.
    pub fn identity() -> Extrinsics {
        Extrinsics { r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], t_m: [0.0; 3] }
    }

    /// From R and t (m); R must be a rotation (orthonormal within 1e-6, determinant +1).
    pub fn from_rt(r: [[f64; 3]; 3], t_m: [f64; 3]) -> Result<Extrinsics> {
        if r.iter().flatten().chain(t_m.iter()).any(|x| !x.is_finite()) {
            bail!("R and t must be finite");
        }
        for a in 0..3 {
            for b in 0..3 {
                let dot: f64 = (0..3).map(|k| r[a][k] * r[b][k]).sum();
                let want = if a == b { 1.0 } else { 0.0 };
                if (dot - want).abs() > 1e-6 {
                    bail!("R is not a rotation: rows {a} and {b} have dot product {dot:.3e} (want {want})");
                }
            }
        }
        if det3(&r) < 0.0 {
            bail!("R is a reflection (determinant −1), not a rotation");
        }
        Ok(Extrinsics { r, t_m })
    }

    /// From a Rodrigues rotation vector (axis × angle in radians, as `cv::Rodrigues`) and t (m).
    pub fn from_rvec(rvec: [f64; 3], t_m: [f64; 3]) -> Result<Extrinsics> {
        Extrinsics::from_rt(rodrigues(rvec), t_m)
    }

    /// From a camera-to-world pose: rotation `r_cw` (columns are the camera's x right, y down,
    /// z forward axes in world coordinates) and the camera centre `c_m` (m).
    pub fn from_pose(r_cw: [[f64; 3]; 3], c_m: [f64; 3]) -> Result<Extrinsics> {
        let r = transpose(&r_cw);
        let rc = mat_vec(&r, c_m);
        Extrinsics::from_rt(r, [-rc[0], -rc[1], -rc[2]])
    }

    /// Camera at `eye` (m) looking at `look_at` with approximate up direction `up`: x = forward × up
    /// (right), y = forward × x (down in the image), z = forward.
    pub fn look_at(eye: [f64; 3], look_at: [f64; 3], up: [f64; 3]) -> Result<Extrinsics> {
        let f = sub(look_at, eye);
        let nf = norm(f);
        if !(nf > 0.0) || !nf.is_finite() {
            bail!("eye and look-at point must be distinct finite points");
        }
        let z = scale(f, 1.0 / nf);
        let x = cross(z, up);
        let nx = norm(x);
        if !(nx > 1e-6 * norm(up)) || !nx.is_finite() {
            bail!("up direction must not be parallel to the viewing direction");
        }
        let x = scale(x, 1.0 / nx);
        let y = cross(z, x);
        let r = [x, y, z];
        let re = mat_vec(&r, eye);
        Extrinsics::from_rt(r, [-re[0], -re[1], -re[2]])
    }

    /// Camera centre in world coordinates (m): −Rᵀt.
    pub fn centre_m(&self) -> [f64; 3] {
        let c = mat_vec(&transpose(&self.r), self.t_m);
        [-c[0], -c[1], -c[2]]
    }
}

/// An OpenCV camera of a given resolution, checked to be invertible over its image.
#[derive(Clone, Debug)]
pub struct OpenCv {
    /// Intrinsics (pixels).
    pub intrinsics: Intrinsics,
    /// Distortion coefficients.
    pub distortion: Distortion,
    /// World-to-camera transform.
    pub extrinsics: Extrinsics,
    /// Camera centre (m).
    centre_m: [f64; 3],
}

/// Pixel residual the ray's distortion inverse is solved to.
pub const INVERSE_TOLERANCE_PX: f64 = 1e-9;

impl OpenCv {
    /// Build and check: focal lengths positive, and the distortion invertible over the
    /// `width`×`height` image — the radial map r ↦ r·(radial factor) increasing (and its
    /// denominator positive) up to beyond the image corners' radius, the Jacobian determinant of
    /// the full map positive over a grid covering that disc, and Newton's inverse converging at a
    /// 33×33 grid of image positions including the borders.
    pub fn new(intrinsics: Intrinsics, distortion: Distortion, extrinsics: Extrinsics, width: u32, height: u32) -> Result<OpenCv> {
        let cam = OpenCv::with_size(intrinsics, distortion, extrinsics, width, height)?;
        cam.check_invertible(width, height)?;
        Ok(cam)
    }

    /// [`OpenCv::new`] without the invertibility check: for point-wise use with a known image size
    /// (triangulation), where [`OpenCv::undistort`] reports per point whether a ray exists.
    pub fn with_size(intrinsics: Intrinsics, distortion: Distortion, extrinsics: Extrinsics, width: u32, height: u32) -> Result<OpenCv> {
        let Intrinsics { fx, fy, cx, cy } = intrinsics;
        if !(fx > 0.0 && fy > 0.0 && fx.is_finite() && fy.is_finite()) {
            bail!("focal lengths fx, fy must be positive pixels, got {fx}, {fy}");
        }
        if !(cx.is_finite() && cy.is_finite()) {
            bail!("principal point cx, cy must be finite, got {cx}, {cy}");
        }
        if width == 0 || height == 0 {
            bail!("resolution must be at least 1×1, got {width}×{height}");
        }
        let span = 10.0 * width.max(height) as f64;
        if !(cx.abs() <= span && cy.abs() <= span) {
            bail!("principal point ({}, {}) lies far outside the {width}×{height} image (more than 10 image widths)", optics::numfmt::short(cx), optics::numfmt::short(cy));
        }
        Ok(OpenCv { intrinsics, distortion, extrinsics, centre_m: extrinsics.centre_m() })
    }

    /// A camera without the invertibility check of [`OpenCv::new`], for point-wise use (OpenCV's
    /// `projectPoints`, `undistortPoints`) where no image size is known; [`OpenCv::undistort`]
    /// reports per point whether its inverse converged. Focal lengths must still be positive.
    pub fn unchecked(intrinsics: Intrinsics, distortion: Distortion, extrinsics: Extrinsics) -> Result<OpenCv> {
        let Intrinsics { fx, fy, cx, cy } = intrinsics;
        if !(fx > 0.0 && fy > 0.0 && fx.is_finite() && fy.is_finite() && cx.is_finite() && cy.is_finite()) {
            bail!("intrinsics must be finite with positive fx, fy, got fx {fx}, fy {fy}, cx {cx}, cy {cy}");
        }
        Ok(OpenCv { intrinsics, distortion, extrinsics, centre_m: extrinsics.centre_m() })
    }

    /// Whether the distortion maps a ray to every pixel of a `width` × `height` image ([`OpenCv::new`]'s
    /// check); the error says where it fails.
    pub fn check_invertible(&self, width: u32, height: u32) -> Result<()> {
        let Intrinsics { fx, fy, cx, cy } = self.intrinsics;
        let d = &self.distortion;
        if d.is_zero() {
            return Ok(());
        }
        let (u0, u1, v0, v1) = (-0.5, width as f64 - 0.5, -0.5, height as f64 - 0.5);
        // The corners' distance from the axis before the tilt.
        let mut rd_max = 0.0f64;
        for (u, v) in [(u0, v0), (u0, v1), (u1, v0), (u1, v1)] {
            let Some((x, y)) = d.untilt((u - cx) / fx, (v - cy) / fy) else {
                bail!("sensor tilt τx, τy = {}, {} rad puts image corner ({u}, {v}) beyond the horizon", d.tau_rad[0], d.tau_rad[1]);
            };
            rd_max = rd_max.max(x.hypot(y));
        }
        // Walk the radial map outwards until it passes the corner radius (with margin for the
        // tangential terms); it must increase and keep a positive denominator all the way.
        let (rm2, [s1, s2, s3, s4]) = (rd_max * rd_max, d.s);
        let prism = (s1.abs() + s3.abs()) * rm2 + (s2.abs() + s4.abs()) * rm2 * rm2;
        let margin = 2.0 * (d.p[0].abs() + d.p[1].abs()) * rm2 + prism;
        // It must pass `need`; the disc checked below reaches on to `want` or to the fold.
        let (need, want) = (rd_max * 1.001 + margin, rd_max * 1.05 + margin);
        let dr = (rd_max / 4000.0).max(1e-6);
        let mut r = 0.0f64;
        let mut reached = 0.0f64;
        let mut r_need = f64::NAN;
        loop {
            let (f, g, m) = d.radial(r * r);
            let slope = f + 2.0 * r * r * g;
            if reached >= need && !(m > 0.0 && slope > 0.0) {
                // Folds between `need` and `want`: the disc ends where the map passed `need`.
                r = r_need;
                break;
            }
            if !(m > 0.0) {
                bail!("distortion is not invertible inside the image: the rational denominator 1 + k4 r² + k5 r⁴ + k6 r⁶ reaches 0 at undistorted r = {}, where the distorted radius is {}, short of the image corners' distorted radius {}", optics::numfmt::fixed(r, 4), optics::numfmt::fixed(reached, 4), optics::numfmt::fixed(rd_max, 4));
            }
            if !(slope > 0.0) {
                bail!(
                    "distortion is not invertible inside the image: the radial map r ↦ r·(1 + k1 r² + …)/(1 + k4 r² + …) turns back at undistorted r = {}, where the distorted radius is {}, short of the image corners' distorted radius {}{}",
                    optics::numfmt::fixed(r, 4),
                    optics::numfmt::fixed(r * f, 4),
                    optics::numfmt::fixed(rd_max, 4),
                    if margin > 0.0 { format!(" (+ {} for the tangential and prism terms)", optics::numfmt::fixed(margin, 4)) } else { String::new() }
                );
            }
            reached = r * f;
            if reached >= need && r_need.is_nan() {
                r_need = r;
            }
            if reached >= want {
                break;
            }
            r += dr;
            if r > 100.0 * rd_max.max(0.01) {
                bail!("distortion is not invertible inside the image: the radial map does not reach the image corners (r = {})", optics::numfmt::fixed(rd_max, 4));
            }
        }
        let r_u = r;
        let n = 64;
        for a in 0..=n {
            for b in 0..=n {
                let x = r_u * (2.0 * a as f64 / n as f64 - 1.0);
                let y = r_u * (2.0 * b as f64 / n as f64 - 1.0);
                if x * x + y * y > r_u * r_u {
                    continue;
                }
                let (_, j) = d.distort_jacobian(x, y);
                let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
                if !(det > 0.0) {
                    bail!("distortion is not invertible inside the image: its Jacobian determinant is {det:.3e} at normalised ({x:.4}, {y:.4})");
                }
            }
        }
        let n = 32;
        for a in 0..=n {
            for b in 0..=n {
                let u = u0 + (u1 - u0) * a as f64 / n as f64;
                let v = v0 + (v1 - v0) * b as f64 / n as f64;
                let (xd, yd) = ((u - cx) / fx, (v - cy) / fy);
                let (x, y, ok) = self.undistort(xd, yd);
                if !ok || x * x + y * y > r_u * r_u * 1.0001 {
                    bail!("distortion is not invertible inside the image: no undistorted point found for pixel ({u:.1}, {v:.1})");
                }
            }
        }
        Ok(())
    }

    /// Undistorted normalised coordinates (x′, y′) of distorted ones ((u − cx)/fx, (v − cy)/fy):
    /// the tilt inverted exactly, then Newton's method on the rest, and whether its residual
    /// (before the tilt, in pixels of fx, fy) fell below [`INVERSE_TOLERANCE_PX`] at a point where
    /// the distortion keeps the plane's orientation (a root on a folded branch is refused).
    pub fn undistort(&self, xd: f64, yd: f64) -> (f64, f64, bool) {
        let Intrinsics { fx, fy, .. } = self.intrinsics;
        let d = &self.distortion;
        let Some((xd, yd)) = d.untilt(xd, yd) else {
            return (xd, yd, false);
        };
        let tol2 = INVERSE_TOLERANCE_PX * INVERSE_TOLERANCE_PX;
        // Squared pixel residual of a candidate and its normalised residual vector.
        let resid2 = |a: f64, b: f64| {
            let (rx, ry) = ((a - xd) * fx, (b - yd) * fy);
            rx * rx + ry * ry
        };
        let (mut x, mut y) = (xd, yd);
        let ((mut a, mut b), mut j) = d.distort_jacobian(x, y);
        let mut e2 = resid2(a, b);
        for _ in 0..100 {
            if e2 < tol2 {
                // A root where the distortion folds the plane over (its Jacobian's determinant
                // not positive, or the radial map r·g(r²) not increasing there) is no ray of this
                // pixel: e.g. a pixel beyond the largest radius that r(1 + k1 r² + …) reaches,
                // whose root on the far branch the lens maps mirrored through the centre.
                let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
                return (x, y, det > 0.0 && d.radial_increasing(x * x + y * y));
            }
            let (rx, ry) = (a - xd, b - yd);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if !(det.abs() > 0.0) || !det.is_finite() {
                return (x, y, false);
            }
            let sx = (j[1][1] * rx - j[0][1] * ry) / det;
            let sy = (j[0][0] * ry - j[1][0] * rx) / det;
            // Halve the step while it does not reduce the residual.
            let mut t = 1.0;
            loop {
                let (nx, ny) = (x - t * sx, y - t * sy);
                let ((na, nb), nj) = d.distort_jacobian(nx, ny);
                let ne2 = resid2(na, nb);
                if ne2 < e2 || t < 1e-6 {
                    (x, y, a, b, j, e2) = (nx, ny, na, nb, nj, ne2);
                    break;
                }
                t *= 0.5;
            }
        }
        (x, y, e2 < tol2)
    }

    /// OpenCV pixel position (integer coordinates at pixel centres) of world point `p_m` (m), or
    /// None behind the camera.
    pub fn project_pixel(&self, p_m: [f64; 3]) -> Option<[f64; 2]> {
        let e = &self.extrinsics;
        let c = mat_vec(&e.r, p_m);
        let (xc, yc, zc) = (c[0] + e.t_m[0], c[1] + e.t_m[1], c[2] + e.t_m[2]);
        if !(zc > 0.0) {
            return None;
        }
        let (xd, yd) = self.distortion.distort(xc / zc, yc / zc);
        let k = &self.intrinsics;
        Some([k.fx * xd + k.cx, k.fy * yd + k.cy])
    }

    /// Unit world direction (and camera centre, m) of the ray through OpenCV pixel position (u, v).
    pub fn ray_pixel(&self, u: f64, v: f64) -> ([f64; 3], [f64; 3]) {
        let k = &self.intrinsics;
        let (x, y, _) = self.undistort((u - k.cx) / k.fx, (v - k.cy) / k.fy);
        let d = mat_vec(&transpose(&self.extrinsics.r), [x, y, 1.0]);
        (self.centre_m, scale(d, 1.0 / norm(d)))
    }

    /// Camera centre (m).
    pub fn centre_m(&self) -> [f64; 3] {
        self.centre_m
    }

    /// The same view at another resolution: the film scales by (sx, sy) = (W′/W, H′/H), so
    /// fx′ = sx·fx and cx′ = sx·(cx + ½) − ½ (pixel centres stay at integers); likewise in y.
    pub fn rescaled(&self, sx: f64, sy: f64) -> OpenCv {
        let k = self.intrinsics;
        let intrinsics = Intrinsics { fx: k.fx * sx, fy: k.fy * sy, cx: sx * (k.cx + 0.5) - 0.5, cy: sy * (k.cy + 0.5) - 0.5 };
        OpenCv { intrinsics, ..self.clone() }
    }
}

/// Rotation matrix of a Rodrigues vector (axis·angle, radians).
pub fn rodrigues(rvec: [f64; 3]) -> [[f64; 3]; 3] {
    let th = norm(rvec);
    if th < 1e-300 {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let k = scale(rvec, 1.0 / th);
    let (s, c) = th.sin_cos();
    let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    let mut r = [[0.0; 3]; 3];
    for a in 0..3 {
        for b in 0..3 {
            r[a][b] = (1.0 - c) * k[a] * k[b] + s * kx[a][b] + if a == b { c } else { 0.0 };
        }
    }
    r
}

pub(crate) fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|a| m[a][0] * v[0] + m[a][1] * v[1] + m[a][2] * v[2])
}
pub(crate) fn transpose(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|a| [m[0][a], m[1][a], m[2][a]])
}
/// Inverse of a 3×3 matrix by its adjugate; None when singular.
fn inverse3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let det = det3(m);
    if !(det.abs() > 0.0) || !det.is_finite() {
        return None;
    }
    let c = |i: usize, j: usize| {
        let (i1, i2, j1, j2) = ((i + 1) % 3, (i + 2) % 3, (j + 1) % 3, (j + 2) % 3);
        m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1]
    };
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            // The adjugate is the transposed cofactor matrix.
            *v = c(j, i) / det;
        }
    }
    Some(inv)
}

fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
