//! OpenCV's fisheye camera model (`cv::fisheye`), after Kannala & Brandt ("A generic camera model
//! and calibration method for conventional, wide-angle, and fish-eye lenses", IEEE PAMI 28(8),
//! 2006) with OpenCV's four odd terms, and its calibration from views of a planar target.
//!
//! A point (X, Y, Z) in camera coordinates (x right, y down, z forward; Z > 0) projects as
//!   a = X/Z,  b = Y/Z,  r = √(a² + b²),  θ = atan r  (the angle off the optical axis),
//!   θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸),
//!   (x_d, y_d) = (θ_d / r) (a, b)  (and (a, b) itself at r = 0),
//!   u = fx (x_d + α y_d) + cx,  v = fy y_d + cy,
//! α the skew (OpenCV's K₀₁ = α fx). With k = 0 the image radius is fx·θ, the equidistant
//! projection. The model covers θ < 90° only, as OpenCV's does; points at or behind the camera's
//! plane (Z ≤ 0) have no image here (OpenCV mirrors them through the centre).
//!
//! The inverse solves θ_d(θ) = ‖(x_d, y_d)‖ for θ on the interval [0, θ_max) where θ_d increases
//! (θ_max ≤ 90°), by Newton's method kept inside a bracket (bisection when a step leaves it), and
//! undoes the skew exactly; OpenCV's `fisheye::undistortPoints` ignores the skew and takes
//! Newton's steps from θ = θ_d unbracketed. With α = 0 and a monotonic θ_d the two agree.
//!
//! Calibration (OpenCV's `fisheye::calibrate`): the start is OpenCV's (fx = fy = max(w, h)/2,
//! the principal point at (w/2 − ½, h/2 − ½), no distortion, no skew) or the caller's guess; each
//! view's first pose comes from its pixels taken through that lens's inverse (`pnp::solve_pnp`
//! on normalised coordinates); then Levenberg–Marquardt over all reprojection errors, the lens
//! terms and every pose together ([`super::schur_lm`], central differences). OpenCV alternates
//! a step of the lens terms with, under `CALIB_RECOMPUTE_EXTRINSIC`, a new pose per view, and
//! without that flag keeps the first poses; both reach the same minimum where OpenCV's
//! alternation converges with the flag.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::bundle::observed;
use super::homography::Point2;
use super::model::{Lens, Pose};
use super::pnp::solve_pnp;
use super::schur_lm::{self, Blocks, Layout};
use anyhow::{bail, Result};
use nalgebra::Vector3;

/// Intrinsics, skew and distortion of a fisheye camera (OpenCV's K and D of `cv::fisheye`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FisheyeLens {
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels, OpenCV convention: integer coordinates at pixel centres).
    pub cx: f64,
    /// Principal point y (pixels).
    pub cy: f64,
    /// Skew α (dimensionless: K₀₁ = α·fx).
    pub skew: f64,
    /// k1…k4, the coefficients of θ³, θ⁵, θ⁷, θ⁹ in θ_d (dimensionless, θ in radians).
    pub k: [f64; 4],
}

/// Newton's residual in θ (radians) at which the inverse stops.
const THETA_TOLERANCE: f64 = 1e-15;

impl FisheyeLens {
    /// From OpenCV's camera matrix (row-major, K₁₀ = K₂₀ = K₂₁ = 0, K₂₂ = 1) and its four
    /// distortion coefficients.
    pub fn from_opencv(k: &[f64; 9], d: &[f64; 4]) -> Result<FisheyeLens> {
        if k.iter().chain(d.iter()).any(|v| !v.is_finite()) {
            bail!("the camera matrix and the distortion coefficients must be finite");
        }
        if k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
            bail!("expected a camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]], got {k:?}");
        }
        if !(k[0] > 0.0 && k[4] > 0.0) {
            bail!("focal lengths fx, fy must be positive pixels, got {}, {}", k[0], k[4]);
        }
        Ok(FisheyeLens { fx: k[0], fy: k[4], cx: k[2], cy: k[5], skew: k[1] / k[0], k: *d })
    }

    /// OpenCV's camera matrix, row-major.
    pub fn camera_matrix(&self) -> [f64; 9] {
        [self.fx, self.skew * self.fx, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0]
    }

    /// θ_d(θ) (radians).
    #[inline]
    pub fn theta_d(&self, theta: f64) -> f64 {
        let t2 = theta * theta;
        let [k1, k2, k3, k4] = self.k;
        theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
    }

    /// dθ_d/dθ.
    #[inline]
    fn theta_d_slope(&self, theta: f64) -> f64 {
        let t2 = theta * theta;
        let [k1, k2, k3, k4] = self.k;
        1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
    }

    /// The end of the range [0, θ_max) over which θ_d increases (radians, at most π/2): where
    /// the slope first reaches 0, found on a grid of 10⁴ steps and refined by bisection.
    pub fn theta_max(&self) -> f64 {
        let n = 10_000;
        let end = std::f64::consts::FRAC_PI_2;
        let mut prev = 0.0;
        for i in 1..=n {
            let t = end * i as f64 / n as f64;
            if !(self.theta_d_slope(t) > 0.0) {
                let (mut lo, mut hi) = (prev, t);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if self.theta_d_slope(mid) > 0.0 {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                return lo;
            }
            prev = t;
        }
        end
    }

    /// Distorted normalised coordinates (x_d, y_d) of (a, b) = (X/Z, Y/Z).
    #[inline]
    pub fn distort(&self, a: f64, b: f64) -> (f64, f64) {
        let r = a.hypot(b);
        if r == 0.0 {
            return (a, b);
        }
        let s = self.theta_d(r.atan()) / r;
        (a * s, b * s)
    }

    /// Pixel of distorted normalised coordinates.
    #[inline]
    pub fn to_pixel(&self, xd: f64, yd: f64) -> Point2 {
        [self.fx * (xd + self.skew * yd) + self.cx, self.fy * yd + self.cy]
    }

    /// Pixel position of a point in camera coordinates; NaN at or behind the camera's plane.
    pub fn project(&self, x: &Vector3<f64>) -> Point2 {
        if !(x[2] > 0.0) {
            return [f64::NAN; 2];
        }
        let (xd, yd) = self.distort(x[0] / x[2], x[1] / x[2]);
        self.to_pixel(xd, yd)
    }

    /// Distorted normalised coordinates of a pixel: the camera matrix and the skew undone.
    #[inline]
    pub fn normalise(&self, u: f64, v: f64) -> (f64, f64) {
        let yd = (v - self.cy) / self.fy;
        ((u - self.cx) / self.fx - self.skew * yd, yd)
    }

    /// The angle θ (radians) whose θ_d is `theta_d` ≥ 0, within [0, `theta_max`), or None beyond
    /// the increasing range.
    pub fn solve_theta(&self, theta_d: f64, theta_max: f64) -> Option<f64> {
        if !(theta_d >= 0.0) {
            return None;
        }
        if theta_d == 0.0 {
            return Some(0.0);
        }
        if !(theta_d < self.theta_d(theta_max)) {
            return None;
        }
        let (mut lo, mut hi) = (0.0, theta_max);
        let mut t = theta_d.min(0.5 * theta_max);
        for _ in 0..200 {
            let g = self.theta_d(t) - theta_d;
            if g > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let step = g / self.theta_d_slope(t);
            let next = t - step;
            let next = if next > lo && next < hi && step.is_finite() { next } else { 0.5 * (lo + hi) };
            if (next - t).abs() <= THETA_TOLERANCE * t.max(1e-300) || hi - lo <= THETA_TOLERANCE * hi {
                return Some(next);
            }
            t = next;
        }
        Some(t)
    }

    /// Undistorted normalised coordinates (X/Z, Y/Z) of distorted ones (x_d, y_d), or None where
    /// the ray would lie at or beyond the increasing range of θ_d.
    pub fn undistort(&self, xd: f64, yd: f64, theta_max: f64) -> Option<(f64, f64)> {
        let td = xd.hypot(yd);
        let theta = self.solve_theta(td, theta_max)?;
        if td == 0.0 {
            return Some((xd, yd));
        }
        if !(theta < std::f64::consts::FRAC_PI_2) {
            return None;
        }
        let s = theta.tan() / td;
        Some((xd * s, yd * s))
    }

    /// The nine parameters fx, fy, cx, cy, α, k1…k4 (OpenCV's `IntrinsicParams` order).
    pub fn to_array(&self) -> [f64; 9] {
        [self.fx, self.fy, self.cx, self.cy, self.skew, self.k[0], self.k[1], self.k[2], self.k[3]]
    }

    /// Inverse of [`FisheyeLens::to_array`].
    pub fn from_slice(p: &[f64]) -> FisheyeLens {
        FisheyeLens { fx: p[0], fy: p[1], cx: p[2], cy: p[3], skew: p[4], k: [p[5], p[6], p[7], p[8]] }
    }
}

/// Which lens terms the fit holds at their start (OpenCV's `fisheye::CALIB_FIX_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FisheyeHold {
    /// fx and fy (`CALIB_FIX_FOCAL_LENGTH`).
    pub focal: bool,
    /// cx and cy (`CALIB_FIX_PRINCIPAL_POINT`).
    pub principal_point: bool,
    /// The skew α (`CALIB_FIX_SKEW`).
    pub skew: bool,
    /// k1…k4 (`CALIB_FIX_K1` … `CALIB_FIX_K4`).
    pub k: [bool; 4],
}

/// A fisheye calibration: the lens, each view's target → camera pose, and the RMS reprojection
/// error (pixels, √(Σ‖e‖²/N) over the N observed points, OpenCV's `rms`).
#[derive(Clone, Debug)]
pub struct FisheyeFit {
    /// The lens.
    pub lens: FisheyeLens,
    /// Target → camera, per view (in the target points' unit).
    pub poses: Vec<Pose>,
    /// RMS reprojection error (pixels).
    pub rms_px: f64,
}

/// The residuals of a fisheye calibration: per view, (predicted − observed) pixels of each
/// target point (0 where not observed).
struct Problem<'a> {
    obj: &'a [Vector3<f64>],
    views: &'a [Vec<Point2>],
}

impl Blocks for Problem<'_> {
    fn n_blocks(&self) -> usize {
        self.views.len()
    }

    fn block_rows(&self) -> usize {
        2 * self.obj.len()
    }

    fn global_rows(&self) -> usize {
        0
    }

    fn block(&self, x: &[f64], v: usize, r: &mut [f64]) {
        let lens = FisheyeLens::from_slice(&x[..LENS]);
        let at = LENS + 6 * v;
        let pose = Pose { rvec: Vector3::new(x[at], x[at + 1], x[at + 2]), t: Vector3::new(x[at + 3], x[at + 4], x[at + 5]) };
        let rot = pose.r();
        r.fill(0.0);
        for (k, (xo, q)) in self.obj.iter().zip(&self.views[v]).enumerate() {
            if observed(*q) {
                // NaN at or behind the camera, so that the minimiser refuses a step there.
                let p = lens.project(&(rot * xo + pose.t));
                r[2 * k] = p[0] - q[0];
                r[2 * k + 1] = p[1] - q[1];
            }
        }
    }

    fn global(&self, _x: &[f64], _r: &mut [f64]) {}
}

/// Parameters of the lens in the fit's vector.
const LENS: usize = 9;

/// Iterations the fit allows (it converges in tens on the tests' and real views).
const MAX_ITERATIONS: usize = 300;

/// Calibrate a fisheye camera from views of one planar target (its points `obj` in the plane
/// z = 0; per view, their pixels, NaN where not seen) in `width` × `height` images. `guess`
/// starts the lens (OpenCV's `CALIB_USE_INTRINSIC_GUESS`); `hold` keeps terms at the start.
/// Errors on one line: too few views or points, a view whose first pose cannot be found, a fit
/// whose RMS exceeds `max_rms_px`, or a fitted θ_d that turns back inside the observed field.
pub fn calibrate_fisheye(obj: &[Point2], views: &[Vec<Point2>], width: u32, height: u32, hold: FisheyeHold, guess: Option<FisheyeLens>, max_rms_px: f64) -> Result<FisheyeFit> {
    if views.is_empty() {
        bail!("no views");
    }
    if obj.len() < 4 || obj.iter().flatten().any(|v| !v.is_finite()) {
        bail!("the target needs at least 4 finite points, got {}", obj.len());
    }
    if width == 0 || height == 0 {
        bail!("image size must be at least 1×1, got {width}×{height}");
    }
    for (i, v) in views.iter().enumerate() {
        if v.len() != obj.len() {
            bail!("view {i} has {} points, the target {}", v.len(), obj.len());
        }
        if v.iter().filter(|q| observed(**q)).count() < 4 {
            bail!("view {i} sees fewer than 4 of the target's points");
        }
    }
    let start = match guess {
        Some(g) => {
            if !(g.fx > 0.0 && g.fy > 0.0) || g.to_array().iter().any(|v| !v.is_finite()) {
                bail!("the lens guess must be finite with positive focal lengths");
            }
            g
        }
        None => {
            let f = f64::from(width.max(height)) / 2.0;
            FisheyeLens { fx: f, fy: f, cx: f64::from(width) / 2.0 - 0.5, cy: f64::from(height) / 2.0 - 0.5, skew: 0.0, k: [0.0; 4] }
        }
    };
    let theta_max = start.theta_max();
    let obj3: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let unit = Lens::pinhole(1.0, 1.0, 0.0, 0.0);
    let mut x: Vec<f64> = start.to_array().to_vec();
    for (i, v) in views.iter().enumerate() {
        let (o, n): (Vec<[f64; 3]>, Vec<Point2>) = obj
            .iter()
            .zip(v)
            .filter(|(_, q)| observed(**q))
            .filter_map(|(p, q)| {
                let (xd, yd) = start.normalise(q[0], q[1]);
                start.undistort(xd, yd, theta_max).map(|(a, b)| ([p[0], p[1], 0.0], [a, b]))
            })
            .unzip();
        if o.len() < 4 {
            bail!("view {i}: fewer than 4 of its points lie within the starting lens's field of view (fx = {:.1} px); give a lens guess", start.fx);
        }
        let (pose, _) = solve_pnp(&o, &n, &unit).map_err(|e| anyhow::anyhow!("view {i}: no first pose: {e}"))?;
        x.extend(pose.rvec.iter().chain(pose.t.iter()));
    }
    let global: Vec<usize> = (0..LENS)
        .filter(|&i| match i {
            0 | 1 => !hold.focal,
            2 | 3 => !hold.principal_point,
            4 => !hold.skew,
            _ => !hold.k[i - 5],
        })
        .collect();
    let layout = Layout { global, local: (0..views.len()).map(|v| std::array::from_fn(|k| LENS + 6 * v + k)).collect() };
    let problem = Problem { obj: &obj3, views };
    schur_lm::minimize(&problem, &layout, &mut x, MAX_ITERATIONS)?;
    let lens = FisheyeLens::from_slice(&x[..LENS]);
    let poses: Vec<Pose> = (0..views.len())
        .map(|v| {
            let at = LENS + 6 * v;
            Pose { rvec: Vector3::new(x[at], x[at + 1], x[at + 2]), t: Vector3::new(x[at + 3], x[at + 4], x[at + 5]) }
        })
        .collect();
    let rms_px = rms(&lens, &obj3, views, &poses);
    if !(rms_px <= max_rms_px) {
        bail!("the fisheye calibration did not converge: reprojection RMS {rms_px:.3} px exceeds {max_rms_px} px");
    }
    if !(lens.fx > 0.0 && lens.fy > 0.0) {
        bail!("the fit reached focal lengths fx = {:.6}, fy = {:.6} px; both must be > 0", lens.fx, lens.fy);
    }
    // θ_d must increase over every observed ray, or the image folds over there.
    let theta_seen = poses
        .iter()
        .zip(views)
        .flat_map(|(p, v)| obj3.iter().zip(v).filter(|(_, q)| observed(**q)).map(move |(xo, _)| p.apply(xo)))
        .map(|c| c[0].hypot(c[1]).atan2(c[2]))
        .fold(0.0f64, f64::max);
    let tm = lens.theta_max();
    if theta_seen >= tm {
        bail!("the fitted distortion turns back at θ = {:.2}° inside the observed field (up to {:.2}°): k = {:?}", tm.to_degrees(), theta_seen.to_degrees(), lens.k);
    }
    Ok(FisheyeFit { lens, poses, rms_px })
}

/// √(Σ‖e‖²/N) over the observed points of every view (pixels).
pub fn rms(lens: &FisheyeLens, obj: &[Vector3<f64>], views: &[Vec<Point2>], poses: &[Pose]) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for (pose, v) in poses.iter().zip(views) {
        for (xo, q) in obj.iter().zip(v) {
            if observed(*q) {
                let p = lens.project(&pose.apply(xo));
                s += (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                n += 1;
            }
        }
    }
    (s / n.max(1) as f64).sqrt()
}
