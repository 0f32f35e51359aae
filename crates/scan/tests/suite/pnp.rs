//! The pose of a known object from a calibrated camera (`scan::calib::pnp`, OpenCV's `solvePnP`):
//! exact projections through a distorted lens give the pose back to 1e-9 from points off a plane
//! (the direct linear transform start) and on planes (the homography start), including a plane
//! that is not z = 0; too few points, mismatched counts and collinear points are one-line errors.

use nalgebra::{Rotation3, Vector3};
use scan::calib::model::{Lens, Pose};
use scan::calib::pnp::{solve_pnp, solve_pnp_from};

fn lens() -> Lens {
    Lens::from_opencv(910.0, 905.0, 322.0, 241.5, &[-0.21, 0.09, 0.0007, -0.0004, -0.02])
}

fn check(obj: &[[f64; 3]], truth: &Pose) {
    let l = lens();
    let px: Vec<[f64; 2]> = obj.iter().map(|p| l.project(&truth.apply(&Vector3::from(*p)))).collect();
    let (pose, rms) = solve_pnp(obj, &px, &l).unwrap();
    let dr = Rotation3::new(pose.rvec).rotation_to(&Rotation3::new(truth.rvec)).angle();
    let dt = (pose.t - truth.t).norm() / truth.t.norm();
    assert!(dr < 1e-9 && dt < 1e-9 && rms < 1e-8, "rotation off by {dr}, translation by {dt}, RMS {rms}");
}

#[test]
fn solve_pnp_recovers_known_poses() {
    let truth = Pose { rvec: Vector3::new(0.3, -0.45, 0.2), t: Vector3::new(-40.0, 25.0, 520.0) };
    // Points off a plane: a deterministic scatter in a 120-unit box.
    let mut state = 7u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let cloud: Vec<[f64; 3]> = (0..20).map(|_| [120.0 * next() - 60.0, 120.0 * next() - 60.0, 120.0 * next() - 60.0]).collect();
    check(&cloud, &truth);
    check(&cloud[..6], &truth);
    // A chessboard (z = 0), and the same board on a tilted, shifted plane.
    let board: Vec<[f64; 3]> = (0..54).map(|k| [(k % 9) as f64 * 20.0, (k / 9) as f64 * 20.0, 0.0]).collect();
    check(&board, &truth);
    let corners = [board[0], board[8], board[45], board[53]];
    check(&corners, &Pose { rvec: Vector3::new(-0.2, 0.1, 2.5), t: Vector3::new(10.0, -30.0, 400.0) });
    let tilted: Vec<[f64; 3]> = board.iter().map(|p| [p[0], p[1] * 0.8, 0.6 * p[1] + 0.2 * p[0] + 35.0]).collect();
    check(&tilted, &truth);
    // Errors.
    let l = lens();
    let px: Vec<[f64; 2]> = cloud.iter().map(|p| l.project(&truth.apply(&Vector3::from(*p)))).collect();
    let e = solve_pnp(&cloud[..3], &px[..3], &l).unwrap_err().to_string();
    assert!(e.contains("at least 4"), "{e}");
    let e = solve_pnp(&cloud[..5], &px[..5], &l).unwrap_err().to_string();
    assert!(e.contains("at least 6"), "{e}");
    let e = solve_pnp(&cloud[..7], &px[..6], &l).unwrap_err().to_string();
    assert!(e.contains("7 object points") && e.contains("6 image points"), "{e}");
    let line: Vec<[f64; 3]> = (0..6).map(|k| [k as f64 * 10.0, 0.0, 0.0]).collect();
    let lpx: Vec<[f64; 2]> = line.iter().map(|p| l.project(&truth.apply(&Vector3::from(*p)))).collect();
    assert!(solve_pnp(&line, &lpx, &l).is_err());
}

/// From a pose guess (OpenCV's `useExtrinsicGuess`) the refinement needs no closed-form start:
/// five points off a plane, too few for the direct linear transform, give the pose back to 1e-9
/// from a guess 0.1 rad and 8 % of the distance away; a guess that is not finite is an error.
#[test]
fn solve_pnp_from_a_guess() {
    let l = lens();
    let truth = Pose { rvec: Vector3::new(0.3, -0.45, 0.2), t: Vector3::new(-40.0, 25.0, 520.0) };
    let obj = [[0.0, 0.0, 0.0], [100.0, 0.0, 10.0], [0.0, 90.0, -20.0], [80.0, 70.0, 40.0], [30.0, 40.0, 90.0]];
    let px: Vec<[f64; 2]> = obj.iter().map(|p| l.project(&truth.apply(&Vector3::from(*p)))).collect();
    assert!(solve_pnp(&obj, &px, &l).unwrap_err().to_string().contains("at least 6"));
    let guess = Pose { rvec: truth.rvec + Vector3::new(0.06, -0.05, 0.06), t: truth.t + Vector3::new(20.0, -15.0, 30.0) };
    let (pose, rms) = solve_pnp_from(&obj, &px, &l, Some(guess)).unwrap();
    let dr = Rotation3::new(pose.rvec).rotation_to(&Rotation3::new(truth.rvec)).angle();
    let dt = (pose.t - truth.t).norm() / truth.t.norm();
    assert!(dr < 1e-9 && dt < 1e-9 && rms < 1e-8, "rotation off by {dr}, translation by {dt}, RMS {rms}");
    let bad = Pose { rvec: Vector3::new(f64::NAN, 0.0, 0.0), t: truth.t };
    assert!(solve_pnp_from(&obj, &px, &l, Some(bad)).unwrap_err().to_string().contains("guess"));
}
