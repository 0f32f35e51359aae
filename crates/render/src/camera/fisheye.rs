//! OpenCV's fisheye camera model (`cv::fisheye`), after Kannala & Brandt ("A generic camera model
//! and calibration method for conventional, wide-angle, and fish-eye lenses", IEEE PAMI 28(8),
//! 2006) with OpenCV's four odd terms.
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
//! [`Fisheye`] is a camera of this model for rendering (pixel conventions as [`super::opencv`]):
//! it is built only when every pixel of its image has a ray, i.e. the image corners' θ_d lies
//! below θ_d(θ_max).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::opencv::{mat_vec, transpose, Extrinsics};
use anyhow::{bail, Result};

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
    pub fn to_pixel(&self, xd: f64, yd: f64) -> [f64; 2] {
        [self.fx * (xd + self.skew * yd) + self.cx, self.fy * yd + self.cy]
    }

    /// Pixel position of a point in camera coordinates; NaN at or behind the camera's plane.
    pub fn project(&self, x: [f64; 3]) -> [f64; 2] {
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

/// A fisheye camera of a given resolution: lens, pose, and the end of its increasing θ_d range.
#[derive(Clone, Debug)]
pub struct Fisheye {
    /// Intrinsics, skew and distortion.
    pub lens: FisheyeLens,
    /// World-to-camera transform.
    pub extrinsics: Extrinsics,
    /// θ_max of the lens (radians).
    theta_max: f64,
    /// Camera centre (m).
    centre_m: [f64; 3],
}

impl Fisheye {
    /// Build and check: positive finite focal lengths, finite terms, and every pixel of the
    /// `width` × `height` image (its corners, as θ_d grows with the distance from the principal
    /// point) within the range where θ_d increases, below 90°.
    pub fn new(lens: FisheyeLens, extrinsics: Extrinsics, width: u32, height: u32) -> Result<Fisheye> {
        if !(lens.fx > 0.0 && lens.fy > 0.0) || lens.to_array().iter().any(|v| !v.is_finite()) {
            bail!("a fisheye lens needs finite terms and positive focal lengths, got fx {}, fy {}", lens.fx, lens.fy);
        }
        if width == 0 || height == 0 {
            bail!("resolution must be at least 1×1, got {width}×{height}");
        }
        let theta_max = lens.theta_max();
        let limit = lens.theta_d(theta_max);
        for (u, v) in [(-0.5, -0.5), (width as f64 - 0.5, -0.5), (-0.5, height as f64 - 0.5), (width as f64 - 0.5, height as f64 - 0.5)] {
            let (xd, yd) = lens.normalise(u, v);
            let td = xd.hypot(yd);
            if !(td < limit) || lens.undistort(xd, yd, theta_max).is_none() {
                bail!(
                    "the fisheye lens has no ray for image corner ({u}, {v}): its θ_d = {td:.4} rad lies beyond {limit:.4}, where θ_d stops increasing (θ = {:.2}°)",
                    theta_max.to_degrees()
                );
            }
        }
        Ok(Fisheye { lens, extrinsics, theta_max, centre_m: extrinsics.centre_m() })
    }

    /// OpenCV pixel position of world point `p_m` (m), or None at or behind the camera's plane.
    pub fn project_pixel(&self, p_m: [f64; 3]) -> Option<[f64; 2]> {
        let e = &self.extrinsics;
        let c = mat_vec(&e.r, p_m);
        let x = [c[0] + e.t_m[0], c[1] + e.t_m[1], c[2] + e.t_m[2]];
        let q = self.lens.project(x);
        q[0].is_finite().then_some(q)
    }

    /// Unit world direction (and camera centre, m) of the ray through OpenCV pixel (u, v).
    pub fn ray_pixel(&self, u: f64, v: f64) -> ([f64; 3], [f64; 3]) {
        let (xd, yd) = self.lens.normalise(u, v);
        // The direction from θ and the azimuth (no tan θ, exact up to 90°). Every pixel of the
        // image has a ray (checked in `new`); a film position a pixel filter puts outside the
        // image, beyond the lens's range, takes the edge of the field in its azimuth.
        let td = xd.hypot(yd);
        let theta = self.lens.solve_theta(td, self.theta_max).unwrap_or(self.theta_max);
        let (s, c) = theta.sin_cos();
        let local = if td > 0.0 { [s * xd / td, s * yd / td, c] } else { [0.0, 0.0, 1.0] };
        (self.centre_m, mat_vec(&transpose(&self.extrinsics.r), local))
    }

    /// Camera centre (m).
    pub fn centre_m(&self) -> [f64; 3] {
        self.centre_m
    }

    /// The same view at another resolution: the film scales by (sx, sy), so fx′ = sx·fx,
    /// cx′ = sx·(cx + ½) − ½, likewise in y, and α′ = α·sy/sx keeps the skew's shift in pixels.
    pub fn rescaled(&self, sx: f64, sy: f64) -> Fisheye {
        let l = self.lens;
        let lens = FisheyeLens { fx: l.fx * sx, fy: l.fy * sy, cx: sx * (l.cx + 0.5) - 0.5, cy: sy * (l.cy + 0.5) - 0.5, skew: l.skew * sy / sx, ..l };
        Fisheye { lens, ..self.clone() }
    }
}
