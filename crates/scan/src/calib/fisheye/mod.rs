//! Calibration of OpenCV's fisheye model (`cv::fisheye::calibrate`; the model is
//! [`render::camera::fisheye`]) from views of a planar target.
//!
//! The start is OpenCV's (fx = fy = max(w, h)/2, the principal point at (w/2 − ½, h/2 − ½), no
//! distortion, no skew) or the caller's guess; each view's first pose comes from its pixels taken
//! through that lens's inverse (`pnp::solve_pnp` on normalised coordinates); then
//! Levenberg–Marquardt over all reprojection errors, the lens terms and every pose together
//! ([`super::schur_lm`], central differences). OpenCV alternates a step of the lens terms with,
//! under `CALIB_RECOMPUTE_EXTRINSIC`, a new pose per view, and without that flag keeps the first
//! poses; both reach the same minimum where OpenCV's alternation converges with the flag.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod pair;
pub mod pnp;
pub mod rectify;

use super::bundle::observed;
use super::homography::Point2;
use super::model::{Lens, Pose};
use super::pnp::solve_pnp;
use super::schur_lm::{self, Blocks, Layout};
use anyhow::{bail, Result};
use nalgebra::Vector3;
pub use render::camera::fisheye::FisheyeLens;

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

impl FisheyeHold {
    /// Whether the fit moves term `i` of [`FisheyeLens::to_array`]'s order (fx, fy, cx, cy, α, k1…k4).
    fn frees(&self, i: usize) -> bool {
        match i {
            0 | 1 => !self.focal,
            2 | 3 => !self.principal_point,
            4 => !self.skew,
            _ => !self.k[i - 5],
        }
    }
}

/// The pose stored as (Rodrigues vector, translation) at `x[at..at + 6]`.
fn pose_at(x: &[f64], at: usize) -> Pose {
    Pose { rvec: Vector3::new(x[at], x[at + 1], x[at + 2]), t: Vector3::new(x[at + 3], x[at + 4], x[at + 5]) }
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
        let pose = pose_at(x, LENS + 6 * v);
        let rot = pose.r();
        r.fill(0.0);
        for (k, (xo, q)) in self.obj.iter().zip(&self.views[v]).enumerate() {
            if observed(*q) {
                // NaN at or behind the camera, so that the minimiser refuses a step there.
                let c = rot * xo + pose.t;
                let p = lens.project([c[0], c[1], c[2]]);
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
    let global: Vec<usize> = (0..LENS).filter(|&i| hold.frees(i)).collect();
    let layout = Layout { global, local: (0..views.len()).map(|v| std::array::from_fn(|k| LENS + 6 * v + k)).collect() };
    let problem = Problem { obj: &obj3, views };
    schur_lm::minimize(&problem, &layout, &mut x, MAX_ITERATIONS)?;
    let lens = FisheyeLens::from_slice(&x[..LENS]);
    let poses: Vec<Pose> = (0..views.len()).map(|v| pose_at(&x, LENS + 6 * v)).collect();
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
                let c = pose.apply(xo);
                let p = lens.project([c[0], c[1], c[2]]);
                s += (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                n += 1;
            }
        }
    }
    (s / n.max(1) as f64).sqrt()
}

/// A fisheye camera calibration as `lucent scan calibrate-camera --fisheye` writes it: lucent's
/// camera JSON with `"model": "fisheye"`, which `lucent render --camera` reads
/// (`render::load::calibration`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct FisheyeCameraCalibration {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Always `fisheye`.
    pub model: String,
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels, OpenCV convention).
    pub cx: f64,
    /// Principal point y (pixels).
    pub cy: f64,
    /// The skew α (dimensionless; K₀₁ = α fx).
    pub skew: f64,
    /// k1, k2, k3, k4 (dimensionless).
    pub dist: [f64; 4],
    /// RMS reprojection error over all points (pixels).
    pub rms_px: f64,
    /// The target pose of each view.
    pub views: Vec<super::camera::ViewPose>,
}

/// Calibrate a `width` × `height` fisheye camera from named views of one planar target (its
/// points `obj`, z = 0); at least 3 views, errors on one line naming the view where one is at fault.
pub fn calibrate_fisheye_camera(obj: &[Point2], views: &[(String, Vec<Point2>)], width: u32, height: u32, hold: FisheyeHold) -> Result<FisheyeCameraCalibration> {
    if views.len() < 3 {
        bail!("degenerate pose set: camera calibration needs at least 3 views of the target, got {}", views.len());
    }
    let pts: Vec<Vec<Point2>> = views.iter().map(|(_, c)| c.clone()).collect();
    let fit = calibrate_fisheye(obj, &pts, width, height, hold, None, super::MAX_RMS_PX).map_err(|e| {
        // Name the photograph where the message names a view.
        let msg = e.to_string();
        match (0..views.len()).find(|i| msg.starts_with(&format!("view {i} ")) || msg.starts_with(&format!("view {i}:"))) {
            Some(i) => anyhow::anyhow!("{}: {msg}", views[i].0),
            None => e,
        }
    })?;
    let obj3: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let per_view = views
        .iter()
        .zip(&fit.poses)
        .zip(&pts)
        .map(|(((name, _), pose), v)| super::camera::ViewPose {
            name: name.clone(),
            rvec: [pose.rvec[0], pose.rvec[1], pose.rvec[2]],
            tvec: [pose.t[0], pose.t[1], pose.t[2]],
            rms_px: rms(&fit.lens, &obj3, std::slice::from_ref(v), std::slice::from_ref(pose)),
        })
        .collect();
    let l = fit.lens;
    Ok(FisheyeCameraCalibration { width, height, model: "fisheye".into(), fx: l.fx, fy: l.fy, cx: l.cx, cy: l.cy, skew: l.skew, dist: l.k, rms_px: fit.rms_px, views: per_view })
}

/// A fisheye stereo calibration (OpenCV's `fisheye::stereoCalibrate`): both lenses, the first →
/// second camera transform X₂ = R·X₁ + T, the target → first camera pose per view, and the RMS
/// reprojection error over every observed point of both cameras (pixels).
#[derive(Clone, Debug)]
pub struct FisheyeStereoFit {
    /// The first and the second camera's lens.
    pub lens: [FisheyeLens; 2],
    /// First → second camera.
    pub stereo: Pose,
    /// Target → first camera, per view.
    pub poses: Vec<Pose>,
    /// RMS reprojection error (pixels).
    pub rms_px: f64,
    /// The views whose relative pose of the two cameras, from their separate fits, disagrees
    /// with the others' (`calib::pose_outliers`), with the angle (degrees).
    pub disagreeing: Vec<(usize, f64)>,
}

/// The residuals of a fisheye stereo fit: per view, the first camera's points, then the
/// second's (0 where not observed).
struct StereoProblem<'a> {
    obj: &'a [Vector3<f64>],
    views: [&'a [Vec<Point2>]; 2],
}

/// Offset of the stereo pose, then of the first view's pose, in a stereo fit's vector.
const STEREO_AT: usize = 2 * LENS;

impl Blocks for StereoProblem<'_> {
    fn n_blocks(&self) -> usize {
        self.views[0].len()
    }

    fn block_rows(&self) -> usize {
        4 * self.obj.len()
    }

    fn global_rows(&self) -> usize {
        0
    }

    fn block(&self, x: &[f64], v: usize, r: &mut [f64]) {
        let lens = [FisheyeLens::from_slice(&x[..LENS]), FisheyeLens::from_slice(&x[LENS..2 * LENS])];
        let (stereo, pose) = (pose_at(x, STEREO_AT), pose_at(x, STEREO_AT + 6 + 6 * v));
        let (rs, rp) = (stereo.r(), pose.r());
        let n = self.obj.len();
        r.fill(0.0);
        for (k, xo) in self.obj.iter().enumerate() {
            let c1 = rp * xo + pose.t;
            let c2 = rs * c1 + stereo.t;
            for (d, c) in [c1, c2].iter().enumerate() {
                let q = self.views[d][v][k];
                if observed(q) {
                    let p = lens[d].project([c[0], c[1], c[2]]);
                    r[2 * (d * n + k)] = p[0] - q[0];
                    r[2 * (d * n + k) + 1] = p[1] - q[1];
                }
            }
        }
    }

    fn global(&self, _x: &[f64], _r: &mut [f64]) {}
}

/// Calibrate a pair of fisheye cameras from the same views of one planar target seen by both
/// (`views[d][v]`: camera d's pixels of view v, NaN where not seen). Each camera is first
/// calibrated alone ([`calibrate_fisheye`], from `guess[d]` when given), or, with
/// `fix_intrinsic`, posed through its given lens; the relative pose starts at the per-view
/// medians of R₂R₁ᵀ (as a Rodrigues vector) and t₂ − R₂R₁ᵀt₁; then Levenberg–Marquardt over
/// both lenses' free terms (none with `fix_intrinsic`), the relative pose and every view's pose.
#[allow(clippy::too_many_arguments)]
pub fn stereo_calibrate_fisheye(obj: &[Point2], views: [&[Vec<Point2>]; 2], width: u32, height: u32, hold: FisheyeHold, fix_intrinsic: bool, guess: [Option<FisheyeLens>; 2], max_rms_px: f64) -> Result<FisheyeStereoFit> {
    if views[0].len() != views[1].len() {
        bail!("the cameras have {} and {} views; a stereo fit needs the same views in both", views[0].len(), views[1].len());
    }
    let every = FisheyeHold { focal: true, principal_point: true, skew: true, k: [true; 4] };
    let mut single = Vec::new();
    for d in 0..2 {
        if fix_intrinsic && guess[d].is_none() {
            bail!("camera {}: holding the intrinsics needs its lens", d + 1);
        }
        let h = if fix_intrinsic { every } else { hold };
        single.push(calibrate_fisheye(obj, views[d], width, height, h, guess[d], max_rms_px).map_err(|e| anyhow::anyhow!("camera {}: {e}", d + 1))?);
    }
    // The relative pose of each view, and their per-component medians.
    let rel: Vec<Pose> = single[0].poses.iter().zip(&single[1].poses).map(|(p1, p2)| {
        let r = p2.r() * p1.r().transpose();
        Pose::from_rt(&r, p2.t - r * p1.t)
    }).collect();
    let median = |f: &dyn Fn(&Pose) -> f64| {
        let mut v: Vec<f64> = rel.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        let m = v.len() / 2;
        if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
    };
    let stereo = Pose {
        rvec: Vector3::new(median(&|p| p.rvec[0]), median(&|p| p.rvec[1]), median(&|p| p.rvec[2])),
        t: Vector3::new(median(&|p| p.t[0]), median(&|p| p.t[1]), median(&|p| p.t[2])),
    };
    let mut x: Vec<f64> = single[0].lens.to_array().into_iter().chain(single[1].lens.to_array()).collect();
    x.extend(stereo.rvec.iter().chain(stereo.t.iter()));
    for p in &single[0].poses {
        x.extend(p.rvec.iter().chain(p.t.iter()));
    }
    let mut global: Vec<usize> = (0..2 * LENS).filter(|&i| !fix_intrinsic && hold.frees(i % LENS)).collect();
    global.extend(STEREO_AT..STEREO_AT + 6);
    let layout = Layout { global, local: (0..views[0].len()).map(|v| std::array::from_fn(|k| STEREO_AT + 6 + 6 * v + k)).collect() };
    let obj3: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let problem = StereoProblem { obj: &obj3, views };
    schur_lm::minimize(&problem, &layout, &mut x, MAX_ITERATIONS)?;
    let lens = [FisheyeLens::from_slice(&x[..LENS]), FisheyeLens::from_slice(&x[LENS..2 * LENS])];
    let stereo = pose_at(&x, STEREO_AT);
    let poses: Vec<Pose> = (0..views[0].len()).map(|v| pose_at(&x, STEREO_AT + 6 + 6 * v)).collect();
    let poses2: Vec<Pose> = poses.iter().map(|p| stereo.after(p)).collect();
    let (e1, e2) = (rms(&lens[0], &obj3, views[0], &poses), rms(&lens[1], &obj3, views[1], &poses2));
    let count = |vs: &[Vec<Point2>]| vs.iter().flatten().filter(|q| observed(**q)).count() as f64;
    let (n1, n2) = (count(views[0]), count(views[1]));
    let rms_px = ((e1 * e1 * n1 + e2 * e2 * n2) / (n1 + n2).max(1.0)).sqrt();
    let disagreeing = crate::calib::pose_outliers(&rel.iter().map(|p| p.r()).collect::<Vec<_>>());
    if !(rms_px <= max_rms_px) {
        let why = if disagreeing.is_empty() { String::new() } else { format!("; {}", crate::calib::disagreement_clause(&|i| format!("view {i}"), &disagreeing, ["camera 1", "camera 2"])) };
        bail!("the fisheye stereo calibration did not converge: reprojection RMS {rms_px:.3} px exceeds {max_rms_px} px{why}");
    }
    if lens.iter().any(|l| !(l.fx > 0.0 && l.fy > 0.0)) {
        bail!("the fit reached a focal length ≤ 0: fx, fy = {:.4}, {:.4} and {:.4}, {:.4} px", lens[0].fx, lens[0].fy, lens[1].fx, lens[1].fy);
    }
    Ok(FisheyeStereoFit { lens, stereo, poses, rms_px, disagreeing })
}
