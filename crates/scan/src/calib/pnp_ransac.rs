//! The pose of a known object from correspondences of which some are wrong (OpenCV's
//! `solvePnPRansac` with `SOLVEPNP_ITERATIVE`; Fischler & Bolles, CACM 24(6), 1981).
//!
//! - **Hypotheses.** Sets drawn at random (a fixed seed, so a call is repeatable): five points
//!   posed by EPnP on their rays, as OpenCV draws them; with a guess (or fewer than five points
//!   with a ray), four points when all the object's points lie on one plane, six otherwise, each
//!   refined from the guess by [`super::pnp::solve_pnp_from`].
//! - **Inliers.** A correspondence is an inlier of a pose when its reprojection through the full
//!   lens lies within `threshold_px` of its pixel (OpenCV's `reprojectionError`). The pose with
//!   the most inliers wins (ties: the smaller sum of their squared errors).
//! - **Iterations.** At most `iterations`, and no more than the standard bound
//!   ⌈ln(1 − confidence) / ln(1 − wˢ)⌉ for the best inlier share w so far and set size s.
//! - **Result.** The pose refined on the winner's inliers, and those inliers (the winning
//!   hypothesis's set, as OpenCV returns it).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use anyhow::{bail, Result};
use nalgebra::Vector3;
use render::math::sampling::Pcg32;

use super::homography::Point2;
use super::model::{Lens, Pose};
use super::pnp::{coplanar, solve_pnp_from};

/// The RANSAC settings (OpenCV's defaults: 100 iterations, 8 px, 0.99).
#[derive(Clone, Copy, Debug)]
pub struct RansacSettings {
    /// The most hypotheses drawn.
    pub iterations: usize,
    /// Largest reprojection error of an inlier (pixels).
    pub threshold_px: f64,
    /// Probability of drawing at least one set of inliers, which bounds the iterations.
    pub confidence: f64,
}

impl Default for RansacSettings {
    fn default() -> Self {
        RansacSettings { iterations: 100, threshold_px: 8.0, confidence: 0.99 }
    }
}

/// A RANSAC pose: the pose, the indices of its inliers (ascending), and the RMS reprojection
/// error over them (pixels).
#[derive(Clone, Debug)]
pub struct RansacPose {
    /// Object → camera.
    pub pose: Pose,
    /// Indices of the inlier correspondences.
    pub inliers: Vec<usize>,
    /// RMS reprojection error over the inliers (pixels).
    pub rms_px: f64,
}

/// Squared reprojection errors of every correspondence under `pose` (infinite at or behind the
/// camera).
fn sq_errors(obj: &[[f64; 3]], px: &[Point2], lens: &Lens, pose: &Pose) -> Vec<f64> {
    obj.iter()
        .zip(px)
        .map(|(p, q)| {
            let c = pose.apply(&Vector3::from(*p));
            if !(c[2] > 0.0) {
                return f64::INFINITY;
            }
            let u = lens.project(&c);
            (u[0] - q[0]).powi(2) + (u[1] - q[1]).powi(2)
        })
        .collect()
}

/// OpenCV's `solvePnPRansac` (module documentation) for the points `obj` seen at pixels `px` by
/// `lens`; `guess` (OpenCV's `useExtrinsicGuess`) starts each hypothesis's refinement. None when
/// no hypothesis has a minimal set of inliers (OpenCV's `false`); errors are one line for bad
/// input, as [`super::pnp::solve_pnp`]'s.
pub fn solve_pnp_ransac(obj: &[[f64; 3]], px: &[Point2], lens: &Lens, guess: Option<Pose>, settings: &RansacSettings, seed: u64) -> Result<Option<RansacPose>> {
    let n = obj.len();
    if n != px.len() {
        bail!("{} object points but {} image points", n, px.len());
    }
    if obj.iter().flatten().chain(px.iter().flatten()).any(|v| !v.is_finite()) {
        bail!("object and image points must be finite");
    }
    if !(settings.threshold_px > 0.0) || !(settings.confidence > 0.0 && settings.confidence < 1.0) || settings.iterations == 0 {
        bail!("RANSAC needs a positive threshold, a confidence in (0, 1) and at least one iteration; got {} px, {}, {}", settings.threshold_px, settings.confidence, settings.iterations);
    }
    if n < 4 {
        bail!("a RANSAC pose needs at least 4 points, got {n}");
    }
    if let Some(g) = &guess {
        if g.rvec.iter().chain(g.t.iter()).any(|v| !v.is_finite()) {
            bail!("the pose guess must be finite");
        }
    }
    let x: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::from(*p)).collect();
    // Without a guess, hypotheses from EPnP on sets of five, as OpenCV draws them (on the pixels
    // through the lens's inverse; a pixel without a ray is never drawn); with one, or fewer than
    // five points with a ray, from the iterative solver on 4 coplanar or 6 points, refined from
    // the guess.
    let rays = super::pnp::normalised_each(px, lens)?;
    let drawable: Vec<usize> = (0..n).filter(|&i| rays[i].is_some()).collect();
    let by_epnp = guess.is_none() && drawable.len() >= 5;
    let m = if by_epnp {
        5
    } else if coplanar(&x) {
        4
    } else {
        6
    };
    if n < m {
        bail!("a RANSAC pose needs at least {m} points here ({}), got {n}", if m == 4 { "coplanar" } else { "off one plane" });
    }
    let t2 = settings.threshold_px * settings.threshold_px;
    let mut rng = Pcg32::new(seed, 0x706E_7072);
    let mut best: Option<(usize, f64, Pose, Vec<usize>)> = None;
    let mut limit = settings.iterations;
    let mut k = 0;
    let mut set = vec![0usize; m];
    let (mut so, mut sp) = (Vec::with_capacity(m), Vec::with_capacity(m));
    while k < limit {
        k += 1;
        // m distinct indices (of the drawable points for EPnP).
        let pool = if by_epnp { drawable.len() } else { n };
        for i in 0..m {
            set[i] = loop {
                let j = ((rng.next_f64() * pool as f64) as usize).min(pool - 1);
                let j = if by_epnp { drawable[j] } else { j };
                if !set[..i].contains(&j) {
                    break j;
                }
            };
        }
        let pose = if by_epnp {
            let xs: Vec<Vector3<f64>> = set.iter().map(|&i| x[i]).collect();
            let ms: Vec<Point2> = set.iter().map(|&i| rays[i].expect("drawn from the points with a ray")).collect();
            let Some(p) = super::pnp::epnp_pose(&xs, &ms, lens.fx, lens.fy) else { continue };
            p
        } else {
            so.clear();
            sp.clear();
            so.extend(set.iter().map(|&i| obj[i]));
            sp.extend(set.iter().map(|&i| px[i]));
            let Ok((p, _)) = solve_pnp_from(&so, &sp, lens, guess) else { continue };
            p
        };
        let e = sq_errors(obj, px, lens, &pose);
        let inl: Vec<usize> = (0..n).filter(|&i| e[i] <= t2).collect();
        let ss: f64 = inl.iter().map(|&i| e[i]).sum();
        let better = match &best {
            None => inl.len() >= m,
            Some((c, s, _, _)) => inl.len() > *c || (inl.len() == *c && ss < *s),
        };
        if better {
            let w = inl.len() as f64 / n as f64;
            // The standard bound on the draws needed to see one all-inlier set.
            let p_good = w.powi(m as i32);
            if p_good >= 1.0 {
                limit = k;
            } else if p_good > 0.0 {
                let need = ((1.0 - settings.confidence).ln() / (1.0 - p_good).ln()).ceil();
                if need.is_finite() && need >= 0.0 {
                    limit = limit.min(need as usize).max(k);
                }
            }
            best = Some((inl.len(), ss, pose, inl));
        }
    }
    let Some((_, _, start, inliers)) = best else { return Ok(None) };
    let so: Vec<[f64; 3]> = inliers.iter().map(|&i| obj[i]).collect();
    let sp: Vec<Point2> = inliers.iter().map(|&i| px[i]).collect();
    let (pose, rms_px) = solve_pnp_from(&so, &sp, lens, Some(start))?;
    Ok(Some(RansacPose { pose, inliers, rms_px }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A third of the correspondences moved far off: the inliers are exactly the true ones and
    /// the pose is the true one to 10⁻⁹ (noiseless inliers), on a plane and off it; with every
    /// correspondence wrong there is no pose.
    #[test]
    fn gross_outliers_are_found_and_left_out() {
        let lens = Lens { fx: 800.0, fy: 790.0, cx: 321.0, cy: 239.0, dist: [-0.1, 0.02, 0.001, -0.0005, 0.0], ..Lens::pinhole(1.0, 1.0, 0.0, 0.0) };
        let truth = Pose { rvec: Vector3::new(0.2, -0.4, 0.1), t: Vector3::new(-0.05, 0.02, 0.8) };
        let plane: Vec<[f64; 3]> = (0..30).map(|i| [0.03 * (i % 6) as f64 - 0.08, 0.03 * (i / 6) as f64 - 0.06, 0.0]).collect();
        let solid: Vec<[f64; 3]> = (0..30).map(|i| [0.04 * (i % 5) as f64 - 0.1, 0.04 * (i / 5 % 3) as f64 - 0.05, 0.02 * (i % 4) as f64]).collect();
        for obj in [&plane, &solid] {
            let mut px: Vec<Point2> = obj.iter().map(|p| lens.project(&truth.apply(&Vector3::from(*p)))).collect();
            let bad: Vec<usize> = (0..obj.len()).filter(|i| i % 3 == 1).collect();
            for &i in &bad {
                px[i] = [px[i][0] + 40.0 + 3.0 * i as f64, px[i][1] - 25.0];
            }
            let r = solve_pnp_ransac(obj, &px, &lens, None, &RansacSettings::default(), 1).unwrap().unwrap();
            let good: Vec<usize> = (0..obj.len()).filter(|i| !bad.contains(i)).collect();
            assert_eq!(r.inliers, good);
            assert!((r.pose.rvec - truth.rvec).norm() < 1e-9 && (r.pose.t - truth.t).norm() < 1e-9, "{:?}", r.pose);
            assert!(r.rms_px < 1e-6);
        }
        let scrambled: Vec<Point2> = (0..30).map(|i| [(i * 37 % 640) as f64, (i * 53 % 480) as f64]).collect();
        assert!(solve_pnp_ransac(&plane, &scrambled, &lens, None, &RansacSettings { threshold_px: 0.5, ..Default::default() }, 1).unwrap().is_none());
    }
}
