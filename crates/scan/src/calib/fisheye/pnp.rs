//! The pose of a known object seen by a fisheye camera (OpenCV's `fisheye::solvePnP` with
//! `SOLVEPNP_ITERATIVE`): the pixels are taken through the lens's inverse to the pixels of the
//! distortion-free pinhole camera with the lens's fx, fy, cx, cy, and the pinhole solver
//! (`calib::pnp`: a closed-form start, then Levenberg–Marquardt) finds the pose that reprojects
//! them there, as OpenCV does (its `undistortPoints` with P = K, then `solvePnP` with K). The
//! skew is left out of that pinhole camera (OpenCV's P = K keeps it; with a skew the two weigh
//! the residuals slightly differently). The RMS is measured in pixels through the fisheye lens.

use anyhow::{bail, Result};
use nalgebra::Vector3;

use super::FisheyeLens;
use crate::calib::homography::Point2;
use crate::calib::model::{Lens, Pose};
use crate::calib::pnp::solve_pnp_from;

/// The pose (object → camera) of the points `obj` seen at pixels `px` by the fisheye `lens`,
/// refined from `guess` when one is given (OpenCV's `useExtrinsicGuess`), and the RMS
/// reprojection error (pixels). Errors are one line: those of the pinhole solver, or a pixel
/// that has no ray (beyond the range where θ_d increases).
pub fn solve_pnp_fisheye(
    obj: &[[f64; 3]],
    px: &[Point2],
    lens: &FisheyeLens,
    guess: Option<Pose>,
) -> Result<(Pose, f64)> {
    if obj.len() != px.len() {
        bail!("{} object points but {} image points", obj.len(), px.len());
    }
    let tm = lens.theta_max();
    let mut pinhole = Vec::with_capacity(px.len());
    for (i, q) in px.iter().enumerate() {
        if !(q[0].is_finite() && q[1].is_finite()) {
            bail!("image point {i} is not finite");
        }
        let (xd, yd) = lens.normalise(q[0], q[1]);
        let Some((x, y)) = lens.undistort(xd, yd, tm) else {
            bail!("image point {i} ({}, {}) has no ray: it lies beyond the range where the lens's θ_d increases", q[0], q[1]);
        };
        pinhole.push([lens.fx * x + lens.cx, lens.fy * y + lens.cy]);
    }
    let (pose, _) = solve_pnp_from(obj, &pinhole, &Lens::pinhole(lens.fx, lens.fy, lens.cx, lens.cy), guess)?;
    let mut s = 0.0;
    for (p, q) in obj.iter().zip(px) {
        let c = pose.apply(&Vector3::from(*p));
        let e = lens.project([c[0], c[1], c[2]]);
        s += (e[0] - q[0]).powi(2) + (e[1] - q[1]).powi(2);
    }
    let rms = (s / px.len().max(1) as f64).sqrt();
    if !rms.is_finite() {
        bail!("the pose puts points behind the camera");
    }
    Ok((pose, rms))
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
}
