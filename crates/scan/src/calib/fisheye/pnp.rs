//! The pose of a known object seen by a fisheye camera (OpenCV's `fisheye::solvePnP` with
//! `SOLVEPNP_ITERATIVE`): the pixels are taken through the lens's inverse to the pixels of the
//! distortion-free pinhole camera with the lens's fx, fy, cx, cy, and the pinhole solver
//! (`calib::pnp`: a closed-form start, then Levenberg–Marquardt) finds the pose that reprojects
//! them there, as OpenCV does (its `undistortPoints` with P = K, then `solvePnP` with K). The
//! skew is left out of that pinhole camera (OpenCV's P = K keeps it; with a skew the two weigh
//! the residuals slightly differently). The RMS is measured in pixels through the fisheye lens.
//! `solve_pnp_ransac_fisheye` is OpenCV's `fisheye::solvePnPRansac` in the same way:
//! `calib::pnp_ransac` on those pinhole pixels, with the threshold in them.

use anyhow::{bail, Result};
use nalgebra::Vector3;

use super::FisheyeLens;
use crate::calib::homography::Point2;
use crate::calib::model::{Lens, Pose};
use crate::calib::pnp::solve_pnp_from;
use crate::calib::pnp_ransac::{solve_pnp_ransac, RansacPose, RansacSettings};

/// The pose (object → camera) of the points `obj` seen at pixels `px` by the fisheye `lens`,
/// refined from `guess` when one is given (OpenCV's `useExtrinsicGuess`), and the RMS
/// reprojection error (pixels). Errors are one line: those of the pinhole solver, or a pixel
/// that has no ray (beyond the range where θ_d increases).
pub fn solve_pnp_fisheye(obj: &[[f64; 3]], px: &[Point2], lens: &FisheyeLens, guess: Option<Pose>) -> Result<(Pose, f64)> {
    if obj.len() != px.len() {
        bail!("{} object points but {} image points", obj.len(), px.len());
    }
    let mut pinhole = Vec::with_capacity(px.len());
    for (i, (q, p)) in px.iter().zip(to_pinhole(px, lens)).enumerate() {
        if !(q[0].is_finite() && q[1].is_finite()) {
            bail!("image point {i} is not finite");
        }
        let Some(p) = p else {
            bail!("image point {i} ({}, {}) has no ray: it lies beyond the range where the lens's θ_d increases", q[0], q[1]);
        };
        pinhole.push(p);
    }
    let (pose, _) = solve_pnp_from(obj, &pinhole, &pinhole_of(lens), guess)?;
    let rms = fisheye_rms(obj, px, lens, &pose, 0..px.len());
    if !rms.is_finite() {
        bail!("the pose puts points behind the camera");
    }
    Ok((pose, rms))
}

/// OpenCV's `fisheye::solvePnPRansac`: [`solve_pnp_ransac`] on the pixels of the pinhole camera
/// with the lens's fx, fy, cx, cy (the threshold in those pixels, as OpenCV's), after the lens's
/// inverse. A pixel without a ray (beyond the range where θ_d increases) is an outlier; the RMS
/// is over the inliers, through the fisheye lens. None when no pose has a minimal set of inliers.
pub fn solve_pnp_ransac_fisheye(obj: &[[f64; 3]], px: &[Point2], lens: &FisheyeLens, guess: Option<Pose>, settings: &RansacSettings, seed: u64) -> Result<Option<RansacPose>> {
    if obj.len() != px.len() {
        bail!("{} object points but {} image points", obj.len(), px.len());
    }
    if px.iter().flatten().any(|v| !v.is_finite()) {
        bail!("object and image points must be finite");
    }
    let (mut o, mut q, mut index) = (Vec::new(), Vec::new(), Vec::new());
    for (i, p) in to_pinhole(px, lens).into_iter().enumerate() {
        if let Some(p) = p {
            (o.push(obj[i]), q.push(p), index.push(i));
        }
    }
    let Some(r) = solve_pnp_ransac(&o, &q, &pinhole_of(lens), guess, settings, seed)? else { return Ok(None) };
    let inliers: Vec<usize> = r.inliers.iter().map(|&k| index[k]).collect();
    let rms_px = fisheye_rms(obj, px, lens, &r.pose, inliers.iter().copied());
    Ok(Some(RansacPose { pose: r.pose, inliers, rms_px }))
}

/// The distortion-free pinhole camera with the lens's fx, fy, cx, cy (the skew left out).
fn pinhole_of(lens: &FisheyeLens) -> Lens {
    Lens::pinhole(lens.fx, lens.fy, lens.cx, lens.cy)
}

/// Each pixel taken through the lens's inverse to the pixel of [`pinhole_of`]; None without a ray.
fn to_pinhole(px: &[Point2], lens: &FisheyeLens) -> Vec<Option<Point2>> {
    let tm = lens.theta_max();
    px.iter()
        .map(|q| {
            let (xd, yd) = lens.normalise(q[0], q[1]);
            lens.undistort(xd, yd, tm).map(|(x, y)| [lens.fx * x + lens.cx, lens.fy * y + lens.cy])
        })
        .collect()
}

/// RMS reprojection error through the fisheye lens over the correspondences `which` (pixels).
fn fisheye_rms(obj: &[[f64; 3]], px: &[Point2], lens: &FisheyeLens, pose: &Pose, which: impl Iterator<Item = usize>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for i in which {
        let c = pose.apply(&Vector3::from(obj[i]));
        let e = lens.project([c[0], c[1], c[2]]);
        s += (e[0] - px[i][0]).powi(2) + (e[1] - px[i][1]).powi(2);
        n += 1;
    }
    (s / n.max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Noiseless pixels of a known pose give it back, for points on a plane and off it, from the
    /// closed-form start and from a guess; a pixel beyond the lens's range is refused.
    #[test]
    fn a_known_pose_is_recovered() {
        let lens = FisheyeLens {
            fx: 290.0,
            fy: 288.0,
            cx: 318.0,
            cy: 243.0,
            skew: 0.001,
            k: [-0.02, 0.008, -0.002, 0.0003],
        };
        let truth = Pose {
            rvec: Vector3::new(0.3, -0.5, 0.2),
            t: Vector3::new(-0.1, 0.05, 0.45),
        };
        let plane: Vec<[f64; 3]> = (0..30)
            .map(|i| {
                [
                    0.04 * (i % 6) as f64 - 0.1,
                    0.04 * (i / 6) as f64 - 0.08,
                    0.0,
                ]
            })
            .collect();
        let solid: Vec<[f64; 3]> = (0..20)
            .map(|i| {
                [
                    0.05 * (i % 5) as f64 - 0.1,
                    0.05 * (i / 5) as f64 - 0.1,
                    0.03 * (i % 3) as f64,
                ]
            })
            .collect();
        for obj in [&plane, &solid] {
            let px: Vec<Point2> = obj
                .iter()
                .map(|p| {
                    let c = truth.apply(&Vector3::from(*p));
                    lens.project([c[0], c[1], c[2]])
                })
                .collect();
            for guess in [
                None,
                Some(Pose {
                    rvec: Vector3::new(0.25, -0.45, 0.1),
                    t: Vector3::new(-0.05, 0.0, 0.5),
                }),
            ] {
                let (pose, rms) = solve_pnp_fisheye(obj, &px, &lens, guess).unwrap();
                assert!(rms < 1e-8, "{rms}");
                assert!(
                    (pose.rvec - truth.rvec).norm() < 1e-9 && (pose.t - truth.t).norm() < 1e-9,
                    "{pose:?}"
                );
            }
        }
        let mut far: Vec<Point2> = plane
            .iter()
            .map(|p| {
                let c = truth.apply(&Vector3::from(*p));
                lens.project([c[0], c[1], c[2]])
            })
            .collect();
        far[3] = [318.0 + 50.0 * 290.0, 243.0];
        let e = solve_pnp_fisheye(&plane, &far, &lens, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("image point 3") && e.contains("no ray"), "{e}");
    }

    /// Fisheye RANSAC: a quarter of the correspondences moved far off (one beyond the lens's
    /// range) are exactly the outliers, and the pose is the true one.
    #[test]
    fn ransac_leaves_out_gross_outliers() {
        let lens = FisheyeLens { fx: 290.0, fy: 288.0, cx: 318.0, cy: 243.0, skew: 0.0, k: [-0.02, 0.008, -0.002, 0.0003] };
        let truth = Pose { rvec: Vector3::new(0.3, -0.5, 0.2), t: Vector3::new(-0.1, 0.05, 0.45) };
        let plane: Vec<[f64; 3]> = (0..32).map(|i| [0.04 * (i % 8) as f64 - 0.14, 0.04 * (i / 8) as f64 - 0.06, 0.0]).collect();
        let mut px: Vec<Point2> = plane.iter().map(|p| {
            let c = truth.apply(&Vector3::from(*p));
            lens.project([c[0], c[1], c[2]])
        }).collect();
        let bad = [2usize, 7, 11, 17, 23, 30];
        for &i in &bad {
            px[i] = [px[i][0] - 35.0, px[i][1] + 20.0 + i as f64];
        }
        px[30] = [318.0 + 50.0 * 290.0, 243.0];
        let r = solve_pnp_ransac_fisheye(&plane, &px, &lens, None, &RansacSettings::default(), 3).unwrap().unwrap();
        let good: Vec<usize> = (0..plane.len()).filter(|i| !bad.contains(i)).collect();
        assert_eq!(r.inliers, good);
        assert!((r.pose.rvec - truth.rvec).norm() < 1e-9 && (r.pose.t - truth.t).norm() < 1e-9 && r.rms_px < 1e-6, "{r:?}");
    }
}
