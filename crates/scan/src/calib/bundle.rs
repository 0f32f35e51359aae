//! Levenberg–Marquardt refinement of a calibration over all reprojection errors (Zhang 2000,
//! §3.2, extended to a stereo pair as OpenCV's `stereoCalibrate`): the intrinsics and distortion
//! of each device, one board pose per view, and — for a pair — the rigid transform from the first
//! device (the camera) to the second (the projector), X_p = R·X_c + T. The minimiser is
//! [`super::schur_lm`]: each view's residuals depend on the lenses, the stereo pose and that
//! view's board pose only, so the board poses are eliminated per view (Schur complement) and an
//! iteration costs time linear in the number of views; the Jacobian is by central differences.

use super::homography::Point2;
use super::model::{Lens, Pose};
use super::schur_lm::{self, Blocks, Layout};
use anyhow::{bail, Result};
use nalgebra::{DVector, Vector3};

/// Observations of one board view: the corners in each device (pixels), in object-point order.
#[derive(Clone, Debug)]
pub struct ViewObs {
    /// Corners seen by the first device (the camera); NaN where a corner is not observed.
    pub cam: Vec<Point2>,
    /// Corners seen by the second device (the projector), NaN where not observed; empty for a
    /// single-device fit.
    pub proj: Vec<Point2>,
}

/// A calibration state: lenses, stereo pose and board poses (board → first device).
#[derive(Clone, Debug)]
pub struct State {
    /// The first device (camera).
    pub cam: Lens,
    /// The second device (projector), when the fit is a pair.
    pub proj: Option<Lens>,
    /// Camera → projector transform (ignored for a single device).
    pub stereo: Pose,
    /// Board → camera pose per view.
    pub poses: Vec<Pose>,
}

/// Which parameters the fit may move.
#[derive(Clone, Copy, Debug)]
pub struct Free {
    /// Intrinsics fx, fy, cx, cy and distortion.
    pub lenses: bool,
    /// k3 (the sixth-order radial term); OpenCV's `CALIB_FIX_K3` is `false` here.
    pub k3: bool,
    /// Tangential p1, p2.
    pub tangential: bool,
    /// The rational model's k4, k5, k6 (OpenCV's `CALIB_RATIONAL_MODEL`); off by default, as in
    /// OpenCV, when they stay at their start (0).
    pub rational: bool,
    /// With `rational`: the normalised radius of each device's image corners (camera, projector;
    /// 0: no bound). The fit then keeps the denominator 1 + k4 r² + k5 r⁴ + k6 r⁶ at or above
    /// [`RATIONAL_FLOOR`] out to 1.1 times that radius by a barrier residual, so that the model
    /// stays invertible over the image (numerator and denominator otherwise trade freely, and a
    /// fit may put a pole inside the image that the board's corners never see).
    pub rational_radius: [f64; 2],
    /// The thin prism terms s1…s4 (OpenCV's `CALIB_THIN_PRISM_MODEL`); off by default.
    pub thin_prism: bool,
    /// The sensor tilt τx, τy (OpenCV's `CALIB_TILTED_MODEL`); off by default.
    pub tilted: bool,
    /// Lens terms held at their start values, one bit per term in [`Lens::to_array`]'s order
    /// (bit 0 fx … bit 17 τy; [`HOLD_FOCAL`], [`HOLD_PRINCIPAL_POINT`], [`hold_k`]), for every device: OpenCV's
    /// `CALIB_FIX_PRINCIPAL_POINT`, `CALIB_FIX_FOCAL_LENGTH`, `CALIB_FIX_K1` … `CALIB_FIX_K6`,
    /// `CALIB_FIX_TANGENT_DIST`, `CALIB_FIX_S1_S2_S3_S4`, `CALIB_FIX_TAUX_TAUY`.
    pub held: u32,
    /// Per device (camera, projector or second camera): fx/fy held at this ratio, fy fitted
    /// (OpenCV's `CALIB_FIX_ASPECT_RATIO`, whose ratio is that of the input camera matrix).
    pub aspect_ratio: [Option<f64>; 2],
    /// For a pair: the second device's fx and fy are the first's (OpenCV's
    /// `CALIB_SAME_FOCAL_LENGTH`).
    pub same_focal: bool,
}

impl Free {
    /// Device `d`'s `lens` with the terms this fit does not model set to 0 (p1, p2 without
    /// `tangential`, k3 without `k3`, and so on) and fx tied to fy where the aspect ratio is
    /// held, as a start value must have them.
    pub fn without_unmodelled(&self, mut l: Lens, d: usize) -> Lens {
        if !self.tangential {
            (l.dist[2], l.dist[3]) = (0.0, 0.0);
        }
        if !self.k3 {
            l.dist[4] = 0.0;
        }
        if !self.rational {
            l.rational = [0.0; 3];
        }
        if !self.thin_prism {
            l.prism = [0.0; 4];
        }
        if !self.tilted {
            l.tilt = [0.0; 2];
        }
        if let Some(a) = self.aspect_ratio[d] {
            l.fx = a * l.fy;
        }
        l
    }

    /// This fit for device `d` alone (its aspect ratio in the first place).
    pub fn for_device(&self, d: usize) -> Free {
        Free { aspect_ratio: [self.aspect_ratio[d], None], ..*self }
    }
}

/// [`Free::held`] bits: fx and fy.
pub const HOLD_FOCAL: u32 = 0b11;
/// [`Free::held`] bits: cx and cy.
pub const HOLD_PRINCIPAL_POINT: u32 = 0b1100;
/// [`Free::held`] bit of radial term k_i (i = 1…6).
pub const fn hold_k(i: usize) -> u32 {
    match i {
        1 => 1 << 4,
        2 => 1 << 5,
        3 => 1 << 8,
        4 => 1 << 9,
        5 => 1 << 10,
        6 => 1 << 11,
        _ => 0,
    }
}

impl Default for Free {
    fn default() -> Self {
        Free { lenses: true, k3: true, tangential: true, rational: false, rational_radius: [0.0; 2], thin_prism: false, tilted: false, held: 0, aspect_ratio: [None; 2], same_focal: false }
    }
}

/// The least value the rational denominator may take over the image (see [`Free`]).
pub const RATIONAL_FLOOR: f64 = 0.2;
/// Radii at which the barrier checks the denominator, per device.
const BARRIER_SAMPLES: usize = 24;
/// Pixels of residual per unit the denominator falls below the floor.
const BARRIER_WEIGHT: f64 = 1e3;

const LENS: usize = 18;

struct Problem<'a> {
    obj: &'a [Vector3<f64>],
    views: &'a [ViewObs],
    stereo: bool,
    /// Image-corner radius per device for the rational model's barrier (0: none).
    barrier: [f64; 2],
    /// fx / fy per device where the aspect ratio is held (fx then follows fy).
    aspect: [Option<f64>; 2],
    /// The second device takes the first's fx and fy.
    same_focal: bool,
}

impl Problem<'_> {
    /// Device `d`'s lens in `x`, with fx tied to fy where the aspect ratio is held.
    fn lens(&self, x: &[f64], d: usize) -> Lens {
        let mut l = Lens::from_slice(&x[d * LENS..(d + 1) * LENS]);
        if let Some(a) = self.aspect[d] {
            l.fx = a * l.fy;
        }
        if d == 1 && self.same_focal {
            let first = self.lens(x, 0);
            (l.fx, l.fy) = (first.fx, first.fy);
        }
        l
    }

    fn layout_view(&self, v: usize) -> usize {
        if self.stereo { 2 * LENS + 6 + 6 * v } else { LENS + 6 * v }
    }

    fn pose_at(x: &[f64], at: usize) -> Pose {
        Pose { rvec: Vector3::new(x[at], x[at + 1], x[at + 2]), t: Vector3::new(x[at + 3], x[at + 4], x[at + 5]) }
    }

    fn barrier_rows(&self) -> usize {
        if self.barrier.iter().any(|&b| b > 0.0) { 2 * BARRIER_SAMPLES } else { 0 }
    }
}

impl Blocks for Problem<'_> {
    fn n_blocks(&self) -> usize {
        self.views.len()
    }

    fn block_rows(&self) -> usize {
        if self.stereo { 4 * self.obj.len() } else { 2 * self.obj.len() }
    }

    fn global_rows(&self) -> usize {
        self.barrier_rows()
    }

    /// Residuals (predicted − observed, pixels) of view `v`: camera corners (u, v)…, then
    /// projector corners; 0 where a corner is not observed.
    fn block(&self, x: &[f64], v: usize, r: &mut [f64]) {
        let cam = self.lens(x, 0);
        let (proj, stereo) = if self.stereo {
            let s = Self::pose_at(x, 2 * LENS);
            (Some(self.lens(x, 1)), Some((s.r(), s.t)))
        } else {
            (None, None)
        };
        let n = self.obj.len();
        let obs = &self.views[v];
        let pose = Self::pose_at(x, self.layout_view(v));
        let rot = pose.r();
        r.fill(0.0);
        for (k, xo) in self.obj.iter().enumerate() {
            let xc = rot * xo + pose.t;
            if observed(obs.cam[k]) {
                let p = cam.project(&xc);
                r[2 * k] = p[0] - obs.cam[k][0];
                r[2 * k + 1] = p[1] - obs.cam[k][1];
            }
            if let (Some(pl), Some((rs, ts))) = (&proj, &stereo) {
                if observed(obs.proj[k]) {
                    let q = pl.project(&(rs * xc + ts));
                    r[2 * n + 2 * k] = q[0] - obs.proj[k][0];
                    r[2 * n + 2 * k + 1] = q[1] - obs.proj[k][1];
                }
            }
        }
    }

    /// The barrier: max(0, floor − denominator) at radii out to 1.1 × the image corners.
    fn global(&self, x: &[f64], r: &mut [f64]) {
        r.fill(0.0);
        for d in 0..2 {
            let rmax = self.barrier[d];
            if rmax <= 0.0 || (d == 1 && !self.stereo) {
                continue;
            }
            let [k4, k5, k6] = self.lens(x, d).rational;
            for i in 0..BARRIER_SAMPLES {
                let r2 = (1.1 * rmax * (i + 1) as f64 / BARRIER_SAMPLES as f64).powi(2);
                let m = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
                r[d * BARRIER_SAMPLES + i] = BARRIER_WEIGHT * (RATIONAL_FLOOR - m).max(0.0);
            }
        }
    }
}

/// Reprojection statistics of a state.
#[derive(Clone, Debug)]
pub struct Rms {
    /// RMS over the camera's corners (pixels; over both coordinates, i.e. √(Σ‖e‖²/N)).
    pub cam: f64,
    /// RMS over the projector's corners (pixels), NaN for a single device.
    pub proj: f64,
    /// RMS over both devices (pixels).
    pub all: f64,
    /// RMS per view over its devices (pixels).
    pub per_view: Vec<f64>,
}

/// The parameter vector of a state: camera [fx, fy, cx, cy, k1, k2, p1, p2, k3], for a pair the
/// projector likewise and the stereo (rvec, T), then (rvec, t) per view.
pub fn pack_state(s: &State) -> DVector<f64> {
    let mut x: Vec<f64> = s.cam.to_array().to_vec();
    if let Some(p) = &s.proj {
        x.extend(p.to_array());
        x.extend(s.stereo.rvec.iter().chain(s.stereo.t.iter()));
    }
    for p in &s.poses {
        x.extend(p.rvec.iter().chain(p.t.iter()));
    }
    DVector::from_vec(x)
}

fn unpack(x: &[f64], stereo: bool, nviews: usize) -> State {
    let cam = Lens::from_slice(&x[0..LENS]);
    let (proj, st, base) = if stereo {
        (Some(Lens::from_slice(&x[LENS..2 * LENS])), Problem::pose_at(x, 2 * LENS), 2 * LENS + 6)
    } else {
        (None, Pose::identity(), LENS)
    };
    let poses = (0..nviews).map(|v| Problem::pose_at(x, base + 6 * v)).collect();
    State { cam, proj, stereo: st, poses }
}

/// Whether a corner observation is present (a missing one is NaN).
#[inline]
pub fn observed(p: Point2) -> bool {
    p[0].is_finite() && p[1].is_finite()
}

/// RMS reprojection errors of `state` against the observations (over the observed corners).
pub fn rms(obj: &[Point2], views: &[ViewObs], state: &State) -> Rms {
    let obj3: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let stereo = state.proj.is_some();
    let pr = Problem { obj: &obj3, views, stereo, barrier: [0.0; 2], aspect: [None; 2], same_focal: false };
    let x = pack_state(state);
    let n = obj.len();
    let mut r = vec![0.0; pr.block_rows()];
    let (mut sc, mut sp, mut nc, mut np) = (0.0, 0.0, 0usize, 0usize);
    let mut pv = Vec::new();
    for (v, obs) in views.iter().enumerate() {
        pr.block(x.as_slice(), v, &mut r);
        let c: f64 = r[..2 * n].iter().map(|e| e * e).sum();
        let p: f64 = r[2 * n..].iter().map(|e| e * e).sum();
        let vc = obs.cam.iter().filter(|q| observed(**q)).count();
        let vp = if stereo { obs.proj.iter().filter(|q| observed(**q)).count() } else { 0 };
        sc += c;
        sp += p;
        nc += vc;
        np += vp;
        pv.push(((c + p) / (vc + vp).max(1) as f64).sqrt());
    }
    Rms {
        cam: (sc / nc.max(1) as f64).sqrt(),
        proj: if stereo { (sp / np.max(1) as f64).sqrt() } else { f64::NAN },
        all: ((sc + sp) / (nc + np).max(1) as f64).sqrt(),
        per_view: pv,
    }
}

/// The parameters a fit with `free` moves, in [`pack_state`] order: the chosen lens terms of each
/// device and the stereo pose (global), then each view's board pose (one block per view).
fn layout(free: Free, stereo: bool, nviews: usize) -> Layout {
    let mut global = Vec::new();
    let ndev = if stereo { 2 } else { 1 };
    let (r, s, t) = (free.rational, free.thin_prism, free.tilted);
    for d in 0..ndev {
        for (i, on) in [true, true, true, true, true, true, free.tangential, free.tangential, free.k3, r, r, r, s, s, s, s, t, t].iter().enumerate() {
            let held = free.held & (1 << i) != 0 || (free.aspect_ratio[d].is_some() && i == 0) || (free.same_focal && d == 1 && i < 2);
            if free.lenses && *on && !held {
                global.push(d * LENS + i);
            }
        }
    }
    let base = ndev * LENS;
    if stereo {
        global.extend(base..base + 6);
    }
    let first = if stereo { base + 6 } else { base };
    Layout { global, local: (0..nviews).map(|v| std::array::from_fn(|k| first + 6 * v + k)).collect() }
}

/// Iterations [`refine`] allows. Every fit of the tests and of the real photographs converges in
/// fewer than 70; the rational model's valley of equivalent coefficients can use them all while
/// the corners no longer move (OpenCV stops after 30).
const MAX_ITERATIONS: usize = 300;

/// Refine `init` by Levenberg–Marquardt over all reprojection errors. A single-device fit when
/// `init.proj` is None. Errors when the minimiser fails or the result's RMS exceeds `max_rms_px`.
pub fn refine(obj: &[Point2], views: &[ViewObs], init: &State, free: Free, max_rms_px: f64) -> Result<State> {
    let obj3: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let stereo = init.proj.is_some();
    let mut x = pack_state(init).as_slice().to_vec();
    let barrier = if free.rational { free.rational_radius } else { [0.0; 2] };
    let aspect = [free.aspect_ratio[0].filter(|_| free.lenses), free.aspect_ratio[1].filter(|_| free.lenses && stereo)];
    let problem = Problem { obj: &obj3, views, stereo, barrier, aspect, same_focal: free.same_focal && free.lenses && stereo };
    schur_lm::minimize(&problem, &layout(free, stereo, views.len()), &mut x, MAX_ITERATIONS)?;
    // The tied terms, as the residuals saw them.
    for d in 0..if stereo { 2 } else { 1 } {
        let l = problem.lens(&x, d);
        (x[d * LENS], x[d * LENS + 1]) = (l.fx, l.fy);
    }
    // The iterations can run out in the rational model's valley of equivalent coefficients while
    // the corners no longer move; that state is taken, as OpenCV's is after its iteration count
    // (the RMS is checked below, and the caller checks that the model stays invertible).
    let state = unpack(&x, stereo, views.len());
    let e = rms(obj, views, &state);
    if !(e.all <= max_rms_px) {
        bail!("the calibration did not converge: reprojection RMS {:.3} px exceeds {max_rms_px} px", e.all);
    }
    check_in_front(&obj3, views, &state)?;
    Ok(state)
}

/// Refuses a state that reprojects the corners with a device looking away from the board: x/z
/// and y/z do not change when a point and its focal lengths change sign together, so a fit
/// started on the wrong side (an extrinsic guess about π off) can reach a mirror image of the
/// rig, with the board behind a device and a negative focal length, that reprojects exactly.
fn check_in_front(obj: &[Vector3<f64>], views: &[ViewObs], s: &State) -> Result<()> {
    let name = |d: usize| if d == 0 { "first device (camera)" } else { "second device (projector or second camera)" };
    for (d, lens) in std::iter::once(&s.cam).chain(s.proj.as_ref()).enumerate() {
        if !(lens.fx > 0.0 && lens.fy > 0.0) {
            bail!("the fit reached a mirror image of the rig: the {} has focal lengths fx = {:.6}, fy = {:.6} px, and a device must have both > 0; start from a pose guess on the right side, or without one", name(d), lens.fx, lens.fy);
        }
    }
    let (rs, ts) = (s.stereo.r(), s.stereo.t);
    for (v, (pose, obs)) in s.poses.iter().zip(views).enumerate() {
        let rot = pose.r();
        for (k, xo) in obj.iter().enumerate() {
            let xc = rot * xo + pose.t;
            let behind = |z: f64| !(z > 0.0);
            if observed(obs.cam[k]) && behind(xc[2]) {
                bail!("the fit reached a mirror image of the rig: board corner {k} of view {v} lies behind the {}; start from a pose guess on the right side, or without one", name(0));
            }
            if s.proj.is_some() && observed(obs.proj[k]) && behind((rs * xc + ts)[2]) {
                bail!("the fit reached a mirror image of the rig: board corner {k} of view {v} lies behind the {}; start from a pose guess on the right side, or without one", name(1));
            }
        }
    }
    Ok(())
}

/// Standard deviations of every parameter (in [`pack_state`] order) of a fit with the default
/// [`Free`] (five distortion coefficients per device) for independent Gaussian pixel noise of
/// `sigma_px` on every corner: the square roots of the diagonal of σ²(JᵀJ)⁻¹ over the fitted
/// parameters at `state` (the linearised covariance of the least-squares estimate); NaN for the
/// terms such a fit holds (k4, k5, k6, s1…s4, τx, τy).
pub fn std_devs(obj: &[Point2], views: &[ViewObs], state: &State, sigma_px: f64) -> Vec<f64> {
    let obj3: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let x = pack_state(state);
    let stereo = state.proj.is_some();
    let lay = layout(Free::default(), stereo, views.len());
    let pr = Problem { obj: &obj3, views, stereo, barrier: [0.0; 2], aspect: [None; 2], same_focal: false };
    let cov = schur_lm::normal_equations(&pr, &lay, x.as_slice()).dense().try_inverse().expect("JᵀJ invertible");
    let mut sd = vec![f64::NAN; x.len()];
    let order = lay.global.iter().chain(lay.local.iter().flatten());
    for (c, &i) in order.enumerate() {
        sd[i] = sigma_px * cov[(c, c)].sqrt();
    }
    sd
}
