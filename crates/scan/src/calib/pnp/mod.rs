//! The pose of a known object from its image in a calibrated camera (OpenCV's `solvePnP`). With
//! `SOLVEPNP_ITERATIVE` ([`solve_pnp`], [`solve_pnp_from`]): a closed-form start, then
//! Levenberg–Marquardt on the reprojection error in pixels through the full lens model.
//!
//! - **Start.** The pixels are taken to normalised coordinates with the camera matrix alone (the
//!   distortion is left to the refinement). Coplanar points (the smallest singular value of the
//!   centred points below 10⁻⁹ of the largest): the homography from their plane to the image
//!   gives the pose (Zhang's decomposition, `zhang::pose_from_homography`), at least 4 points.
//!   Otherwise the direct linear transform (Hartley & Zisserman, Multiple View Geometry, §7.1) on
//!   Hartley-normalised points gives the 3 × 4 projection, whose left 3 × 3 block is rescaled to
//!   the nearest rotation, at least 6 points. Or a pose the caller gives (`solve_pnp_from`,
//!   OpenCV's `useExtrinsicGuess`), from at least 4 points of any layout.
//! - **Refinement.** Levenberg–Marquardt over the Rodrigues vector and the translation, with
//!   central-difference derivatives, until the step or the relative decrease of the squared error
//!   falls below 10⁻¹⁴, at most 200 iterations.
//!
//! OpenCV's other methods are [`solve_pnp_generic`] with a [`Method`]: EPnP (`epnp`), P3P on
//! three points with a fourth to choose among its poses (`p3p`), SQPnP (`sqpnp`) and IPPE for
//! points on a plane (`ippe`). Like OpenCV's, they run on the pixels taken through the lens's
//! inverse and return their own closed-form or globally optimal pose without a refinement in
//! pixels; [`solve_pnp_from`] refines any of them (OpenCV's `solvePnPRefineLM`).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod epnp;
mod ippe;
mod p3p;
mod sqpnp;

use anyhow::{bail, Result};
use nalgebra::{DMatrix, Matrix3, Matrix6, SVector, Vector3, Vector6};
use render::camera::{Extrinsics, Intrinsics, OpenCv};

use super::homography::{fit_homography, Point2};
use super::model::{nearest_rotation, Lens, Pose};
use super::zhang::pose_from_homography;

/// OpenCV's `SolvePnPMethod`s, with OpenCV 5's numbers ([`Method::from_opencv`]; OpenCV 4
/// numbered AP3P 5, IPPE 6, IPPE_SQUARE 7 and SQPNP 8, with DLS 3 and UPnP 4 falling back to
/// EPnP).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// `SOLVEPNP_ITERATIVE` (0): closed-form start, then Levenberg–Marquardt in pixels.
    Iterative,
    /// `SOLVEPNP_EPNP` (1).
    Epnp,
    /// `SOLVEPNP_P3P` (2) and `SOLVEPNP_AP3P` (3): exactly 4 points, the first three posed,
    /// the fourth choosing among their poses.
    P3p,
    /// `SOLVEPNP_IPPE` (4): points on a plane, at least 4.
    Ippe,
    /// `SOLVEPNP_IPPE_SQUARE` (5): the corners of a square of side s, (−s/2, s/2, 0),
    /// (s/2, s/2, 0), (s/2, −s/2, 0), (−s/2, −s/2, 0) in that order.
    IppeSquare,
    /// `SOLVEPNP_SQPNP` (6): at least 3 points.
    Sqpnp,
}

impl Method {
    /// OpenCV's name of the method.
    pub fn opencv_name(self) -> &'static str {
        match self {
            Method::Iterative => "SOLVEPNP_ITERATIVE",
            Method::Epnp => "SOLVEPNP_EPNP",
            Method::P3p => "SOLVEPNP_P3P",
            Method::Ippe => "SOLVEPNP_IPPE",
            Method::IppeSquare => "SOLVEPNP_IPPE_SQUARE",
            Method::Sqpnp => "SOLVEPNP_SQPNP",
        }
    }

    /// The method of OpenCV's flag value; None for a value OpenCV does not define.
    pub fn from_opencv(flag: i64) -> Option<Method> {
        Some(match flag {
            0 => Method::Iterative,
            1 => Method::Epnp,
            2 | 3 => Method::P3p,
            4 => Method::Ippe,
            5 => Method::IppeSquare,
            6 => Method::Sqpnp,
            _ => return None,
        })
    }
}

/// The poses of [`Method`] `method` for the points `obj` seen at pixels `px` by `lens`, each with
/// its RMS reprojection error (pixels, through the full lens), best first, as OpenCV's
/// `solvePnPGeneric` (IPPE returns its two poses; the others one). `guess` is used by
/// `Method::Iterative` only (OpenCV's `useExtrinsicGuess`). Errors are one line: too few points,
/// a layout the method does not take, non-finite values, a pixel the lens's inverse does not
/// reach, or no pose.
pub fn solve_pnp_generic(obj: &[[f64; 3]], px: &[Point2], lens: &Lens, method: Method, guess: Option<Pose>) -> Result<Vec<(Pose, f64)>> {
    if method == Method::Iterative {
        return Ok(vec![solve_pnp_from(obj, px, lens, guess)?]);
    }
    if obj.len() != px.len() {
        bail!("{} object points but {} image points", obj.len(), px.len());
    }
    if obj.iter().flatten().chain(px.iter().flatten()).any(|v| !v.is_finite()) {
        bail!("object and image points must be finite");
    }
    let least = if method == Method::Sqpnp { 3 } else { 4 };
    if obj.len() < least {
        bail!("a pose by {} needs at least {least} points, got {}", method.opencv_name(), obj.len());
    }
    let x: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::from(*p)).collect();
    if spread_rank(&x) < 2 {
        bail!("the object points lie on one line or at one point, which fixes no pose");
    }
    let m = normalised(px, lens)?;
    let poses: Vec<(Matrix3<f64>, Vector3<f64>)> = match method {
        Method::Iterative => unreachable!(),
        Method::Epnp => epnp::epnp(&x, &m, lens.fx, lens.fy).into_iter().collect(),
        Method::P3p => {
            if x.len() != 4 {
                bail!("P3P takes exactly 4 points (3 posed, the fourth choosing), got {}", x.len());
            }
            // Every pose of the first three points that puts the fourth in front of the camera,
            // as OpenCV's solvePnPGeneric returns them; sorted below by the error over all four
            // points, so the first is the one whose fourth point lies nearest its pixel (solvePnP's).
            let cands = p3p::p3p(&[x[0], x[1], x[2]], &[m[0], m[1], m[2]]);
            cands.into_iter().filter(|(r, t)| (r * x[3] + t)[2] > 0.0).collect()
        }
        Method::Ippe | Method::IppeSquare => {
            if method == Method::IppeSquare {
                if x.len() != 4 {
                    bail!("IPPE_SQUARE takes exactly the 4 corners of a square, got {} points", x.len());
                }
                let s = x[1][0] - x[0][0];
                let want = [[-s / 2.0, s / 2.0], [s / 2.0, s / 2.0], [s / 2.0, -s / 2.0], [-s / 2.0, -s / 2.0]];
                let tol = 1e-9 * s.abs().max(1e-300);
                if !(s > 0.0) || x.iter().zip(want).any(|(p, w)| (p[0] - w[0]).abs() > tol || (p[1] - w[1]).abs() > tol || p[2].abs() > tol) {
                    bail!("IPPE_SQUARE: the object points must be the corners of a square, (-s/2, s/2, 0), (s/2, s/2, 0), (s/2, -s/2, 0), (-s/2, -s/2, 0) with s > 0");
                }
            }
            if !coplanar(&x) {
                bail!("IPPE needs object points on one plane");
            }
            ippe::ippe(&x, &m).ok_or_else(|| anyhow::anyhow!("the points determine no homography (collinear?)"))?
        }
        Method::Sqpnp => {
            let start = closed_form_start(&x, &m).ok().map(|p| p.r());
            sqpnp::sqpnp(&x, &m, start).into_iter().collect()
        }
    };
    let mut out: Vec<(Pose, f64)> = poses
        .into_iter()
        .map(|(r, t)| {
            let pose = Pose::from_rt(&r, t);
            (pose, (sq_error(&x, px, lens, &pose) / px.len() as f64).sqrt())
        })
        .filter(|(_, e)| e.is_finite())
        .collect();
    if out.is_empty() {
        bail!("{} found no pose (degenerate configuration)", method.opencv_name());
    }
    out.sort_by(|a, b| a.1.total_cmp(&b.1));
    Ok(out)
}

/// The pixels taken through the lens's inverse to normalised coordinates ((x/z, y/z) of their
/// rays): exactly (Newton's method), where OpenCV's `undistortPoints` stops after 5 fixed-point
/// steps.
fn normalised(px: &[Point2], lens: &Lens) -> Result<Vec<Point2>> {
    normalised_each(px, lens)?
        .into_iter()
        .enumerate()
        .map(|(i, m)| m.ok_or_else(|| anyhow::anyhow!("image point {i} ({}, {}) has no ray through the lens's inverse", px[i][0], px[i][1])))
        .collect()
}

/// [`normalised`] point by point: None for a pixel without a ray.
pub(crate) fn normalised_each(px: &[Point2], lens: &Lens) -> Result<Vec<Option<Point2>>> {
    let intr = Intrinsics { fx: lens.fx, fy: lens.fy, cx: lens.cx, cy: lens.cy };
    let cam = OpenCv::unchecked(intr, lens.distortion(), Extrinsics::identity())?;
    Ok(px
        .iter()
        .map(|q| {
            let (x, y, ok) = cam.undistort((q[0] - lens.cx) / lens.fx, (q[1] - lens.cy) / lens.fy);
            ok.then_some([x, y])
        })
        .collect())
}

/// EPnP's pose ([`Method::Epnp`]) of object points `x` at normalised coordinates `m`, the
/// equations weighed by `fx`, `fy`; None when they determine none.
pub(crate) fn epnp_pose(x: &[Vector3<f64>], m: &[Point2], fx: f64, fy: f64) -> Option<Pose> {
    epnp::epnp(x, m, fx, fy).map(|(r, t)| Pose::from_rt(&r, t))
}

/// The pose (object → camera) of the points `obj` seen at pixels `px` by `lens`, and the RMS
/// reprojection error (pixels). Errors are one line: too few points, points and pixels of
/// different counts, non-finite values, or a configuration that determines no pose.
pub fn solve_pnp(obj: &[[f64; 3]], px: &[Point2], lens: &Lens) -> Result<(Pose, f64)> {
    solve_pnp_from(obj, px, lens, None)
}

/// [`solve_pnp`], refined from `guess` instead of the closed-form start when one is given
/// (OpenCV's `useExtrinsicGuess`): the minimum nearest the guess, from at least 4 points on a
/// plane or off it.
pub fn solve_pnp_from(obj: &[[f64; 3]], px: &[Point2], lens: &Lens, guess: Option<Pose>) -> Result<(Pose, f64)> {
    if obj.len() != px.len() {
        bail!("{} object points but {} image points", obj.len(), px.len());
    }
    if obj.iter().flatten().chain(px.iter().flatten()).any(|v| !v.is_finite()) {
        bail!("object and image points must be finite");
    }
    if obj.len() < 4 {
        bail!("a pose needs at least 4 points, got {}", obj.len());
    }
    let x: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::from(*p)).collect();
    if let Some(g) = &guess {
        if g.rvec.iter().chain(g.t.iter()).any(|v| !v.is_finite()) {
            bail!("the pose guess must be finite");
        }
    }
    // The closed form takes the undistorted normalised points, as OpenCV's does (a pixel without
    // a ray through the lens's inverse keeps its pinhole position): with four points on a plane
    // the homography fits them exactly, and a distorted start can lead the refinement into the
    // other of the plane's two minima.
    let pinhole = |p: &Point2| [(p[0] - lens.cx) / lens.fx, (p[1] - lens.cy) / lens.fy];
    let norm: Vec<Point2> = match normalised_each(px, lens) {
        Ok(m) => m.iter().zip(px).map(|(m, p)| m.unwrap_or_else(|| pinhole(p))).collect(),
        Err(_) => px.iter().map(pinhole).collect(),
    };
    let start = match guess {
        Some(g) => g,
        None => closed_form_start(&x, &norm)?,
    };
    // The rotation vector of the same rotation with angle ≤ π (the minimiser may leave it anywhere
    // on its 2π-periodic line), as OpenCV returns it.
    let refined = refine(&x, px, lens, start);
    let theta = refined.rvec.norm();
    let wrapped = theta - std::f64::consts::TAU * (theta / std::f64::consts::TAU).round();
    let pose = if theta > std::f64::consts::PI { Pose { rvec: refined.rvec * (wrapped / theta), t: refined.t } } else { refined };
    let rms = (sq_error(&x, px, lens, &pose) / px.len() as f64).sqrt();
    if !rms.is_finite() {
        bail!("the pose puts points behind the camera");
    }
    Ok((pose, rms))
}

/// The closed-form start (module documentation) from object points and normalised pixels.
fn closed_form_start(x: &[Vector3<f64>], norm: &[Point2]) -> Result<Pose> {
    Ok(match plane_frame(x) {
        Some((c, b)) => {
            // Plane coordinates q = Bᵀ(X − c); pose of the plane frame from the homography.
            let q: Vec<Point2> = x.iter().map(|p| b.transpose() * (p - c)).map(|v| [v[0], v[1]]).collect();
            let Some(h) = fit_homography(&q, norm) else { bail!("the points do not determine a homography (collinear?)") };
            let Some(p) = pose_from_homography(&h, &Matrix3::identity()) else { bail!("no pose from the points' homography") };
            let r = p.r() * b.transpose();
            Pose::from_rt(&r, p.t - r * c)
        }
        None => {
            if x.len() < 6 {
                bail!("points off one plane need at least 6 for a pose, got {}", x.len());
            }
            dlt(x, norm).ok_or_else(|| anyhow::anyhow!("the points determine no projection (degenerate configuration)"))?
        }
    })
}

/// The number of directions (0–3) in which the points spread by more than 10⁻⁹ of their
/// largest spread: 0 for coincident points, 1 for points on a line.
fn spread_rank(x: &[Vector3<f64>]) -> usize {
    let c = x.iter().sum::<Vector3<f64>>() / x.len() as f64;
    let mut cov = Matrix3::zeros();
    for p in x {
        cov += (p - c) * (p - c).transpose();
    }
    let s = cov.symmetric_eigenvalues().map(|v| v.max(0.0).sqrt());
    let top = s.max();
    if !(top > 0.0) {
        return 0;
    }
    s.iter().filter(|&&v| v > 1e-9 * top).count()
}

/// Whether the points lie on one plane (the test that chooses the closed-form start).
pub(crate) fn coplanar(x: &[Vector3<f64>]) -> bool {
    plane_frame(x).is_some()
}

/// The centroid and an orthonormal frame (columns e₁, e₂, n) of coplanar points; None when they
/// are not coplanar.
fn plane_frame(x: &[Vector3<f64>]) -> Option<(Vector3<f64>, Matrix3<f64>)> {
    if x.len() < 3 {
        return None;
    }
    let c = x.iter().sum::<Vector3<f64>>() / x.len() as f64;
    let m = DMatrix::from_fn(x.len(), 3, |i, j| x[i][j] - c[j]);
    let svd = m.svd(false, true);
    let s = &svd.singular_values;
    let vt = svd.v_t?;
    let order = {
        let mut o = [0usize, 1, 2];
        o.sort_by(|&a, &b| s[b].total_cmp(&s[a]));
        o
    };
    if s[order[2]] > 1e-9 * s[order[0]] {
        return None;
    }
    let row = |i: usize| Vector3::new(vt[(i, 0)], vt[(i, 1)], vt[(i, 2)]);
    let (e1, e2) = (row(order[0]), row(order[1]));
    let n = e1.cross(&e2);
    Some((c, Matrix3::from_columns(&[e1, e2, n])))
}

/// The pose from the direct linear transform on normalised coordinates.
fn dlt(x: &[Vector3<f64>], norm: &[Point2]) -> Option<Pose> {
    // Hartley normalisation of the object points: centroid at 0, mean distance √3.
    let c = x.iter().sum::<Vector3<f64>>() / x.len() as f64;
    let scale = 3f64.sqrt() / (x.iter().map(|p| (p - c).norm()).sum::<f64>() / x.len() as f64);
    let mut a = DMatrix::zeros(2 * x.len(), 12);
    for (i, (p, q)) in x.iter().zip(norm).enumerate() {
        let xn = (p - c) * scale;
        let hom = [xn[0], xn[1], xn[2], 1.0];
        for k in 0..4 {
            a[(2 * i, k)] = hom[k];
            a[(2 * i, 8 + k)] = -q[0] * hom[k];
            a[(2 * i + 1, 4 + k)] = hom[k];
            a[(2 * i + 1, 8 + k)] = -q[1] * hom[k];
        }
    }
    let svd = a.svd(false, true);
    let vt = svd.v_t?;
    let (imin, _) = svd.singular_values.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
    let p: Vec<f64> = vt.row(imin).iter().copied().collect();
    let m = Matrix3::new(p[0], p[1], p[2], p[4], p[5], p[6], p[8], p[9], p[10]);
    let mut col = Vector3::new(p[3], p[7], p[11]);
    let det = m.determinant();
    if !(det.abs() > 0.0) {
        return None;
    }
    // P = λ[R | t]: λ = ∛det(M) (sign included, so that det R = +1).
    let lam = det.cbrt();
    let r = nearest_rotation(&(m / lam));
    col /= lam;
    // Undo the normalisation: X_n = s(X − c), so R X_n + t = sR X + (t − sR c); the scale of a
    // projection is free, so divide by s.
    let t = col / scale - r * c;
    let pose = Pose::from_rt(&r, t);
    // The points must lie in front of the camera.
    (x.iter().filter(|p| pose.apply(p)[2] > 0.0).count() * 2 > x.len()).then_some(pose)
}

fn residuals(x: &[Vector3<f64>], px: &[Point2], lens: &Lens, pose: &Pose) -> Vec<f64> {
    let r = pose.r();
    x.iter()
        .zip(px)
        .flat_map(|(p, q)| {
            let c = r * p + pose.t;
            if !(c[2] > 0.0) {
                return [f64::INFINITY, f64::INFINITY];
            }
            let u = lens.project(&c);
            [u[0] - q[0], u[1] - q[1]]
        })
        .collect()
}

fn sq_error(x: &[Vector3<f64>], px: &[Point2], lens: &Lens, pose: &Pose) -> f64 {
    residuals(x, px, lens, pose).iter().map(|e| e * e).sum()
}

fn pose_of(v: &Vector6<f64>) -> Pose {
    Pose { rvec: Vector3::new(v[0], v[1], v[2]), t: Vector3::new(v[3], v[4], v[5]) }
}

/// Levenberg–Marquardt over (rvec, t) (module documentation).
fn refine(x: &[Vector3<f64>], px: &[Point2], lens: &Lens, start: Pose) -> Pose {
    let mut v = Vector6::new(start.rvec[0], start.rvec[1], start.rvec[2], start.t[0], start.t[1], start.t[2]);
    let mut err = sq_error(x, px, lens, &pose_of(&v));
    let mut mu = 1e-3;
    for _ in 0..200 {
        let r0 = residuals(x, px, lens, &pose_of(&v));
        let n = r0.len();
        let mut j = DMatrix::zeros(n, 6);
        for k in 0..6 {
            let h = 1e-7 * v[k].abs().max(1e-3);
            let (mut a, mut b) = (v, v);
            a[k] += h;
            b[k] -= h;
            let (ra, rb) = (residuals(x, px, lens, &pose_of(&a)), residuals(x, px, lens, &pose_of(&b)));
            for i in 0..n {
                j[(i, k)] = (ra[i] - rb[i]) / (2.0 * h);
            }
        }
        let jt = j.transpose();
        let jtj: Matrix6<f64> = (&jt * &j).fixed_view::<6, 6>(0, 0).into_owned();
        let g: Vector6<f64> = SVector::from_iterator((&jt * DMatrix::from_vec(n, 1, r0)).iter().copied());
        let mut improved = false;
        for _ in 0..20 {
            let mut a = jtj;
            for d in 0..6 {
                a[(d, d)] += mu * jtj[(d, d)].max(1e-12);
            }
            let Some(step) = a.lu().solve(&(-g)) else { break };
            let cand = v + step;
            let e = sq_error(x, px, lens, &pose_of(&cand));
            if e < err {
                let small = step.norm() <= 1e-14 * (v.norm() + 1e-14) || (err - e) <= 1e-14 * err;
                v = cand;
                err = e;
                mu = (mu / 3.0).max(1e-12);
                improved = true;
                if small {
                    return pose_of(&v);
                }
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    pose_of(&v)
}
