//! The pose of a known object from a calibrated camera (`scan::calib::pnp`, OpenCV's `solvePnP`):
//! exact projections through a distorted lens give the pose back to 1e-9 from points off a plane
//! (the direct linear transform start) and on planes (the homography start), including a plane
//! that is not z = 0; too few points, mismatched counts and collinear points are one-line errors.
//! OpenCV's other methods (EPnP, P3P, IPPE, SQPnP) give exact poses back from exact pixels, and
//! SQPnP's pose is a minimum of its object-space error that no nearby rotation lowers.

use nalgebra::{Rotation3, Vector3};
use scan::calib::model::{Lens, Pose};
use scan::calib::pnp::{solve_pnp, solve_pnp_from, solve_pnp_generic, Method};

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

fn cloud(count: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut state = seed;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..count).map(|_| [120.0 * next() - 60.0, 120.0 * next() - 60.0, 120.0 * next() - 60.0]).collect()
}

/// The angle between two rotations, from the Frobenius norm of the matrices' difference
/// (2√2 sin(θ/2); an arccosine of the trace loses half the digits near 0).
fn angle_between(a: &Pose, b: &Pose) -> f64 {
    let d = (Rotation3::new(a.rvec).into_inner() - Rotation3::new(b.rvec).into_inner()).norm();
    2.0 * (d / (2.0 * 2f64.sqrt())).min(1.0).asin()
}

/// Each of OpenCV's closed-form methods gives the pose back from exact pixels through a
/// distorted lens (the pixels taken through the lens's inverse first): EPnP from 20 and from 6
/// points off a plane (and from a chessboard to 10⁻⁵); P3P from 4 points (three posed, the fourth
/// choosing the first of their poses, the others exact for the three); SQPnP from 20 points, a board and 4 points; IPPE from a board and a tilted plane,
/// its second pose the mirror ambiguity with a larger error; IPPE_SQUARE from a square's corners.
#[test]
fn every_method_recovers_exact_poses() {
    let l = lens();
    let truth = Pose { rvec: Vector3::new(0.3, -0.45, 0.2), t: Vector3::new(-40.0, 25.0, 520.0) };
    let board: Vec<[f64; 3]> = (0..54).map(|k| [(k % 9) as f64 * 20.0, (k / 9) as f64 * 20.0, 0.0]).collect();
    let tilted: Vec<[f64; 3]> = board.iter().map(|p| [p[0], p[1] * 0.8, 0.6 * p[1] + 0.2 * p[0] + 35.0]).collect();
    let pts = cloud(20, 7);
    let square = [[-15.0, 15.0, 0.0], [15.0, 15.0, 0.0], [15.0, -15.0, 0.0], [-15.0, -15.0, 0.0]];
    let cases: Vec<(Method, &[[f64; 3]])> = vec![
        (Method::Epnp, &pts),
        (Method::Epnp, &pts[..6]),
        (Method::Epnp, &board),
        (Method::P3p, &pts[..4]),
        (Method::P3p, &pts[5..9]),
        (Method::Sqpnp, &pts),
        (Method::Sqpnp, &board),
        (Method::Sqpnp, &pts[..4]),
        (Method::Ippe, &board),
        (Method::Ippe, &tilted),
        (Method::IppeSquare, &square),
    ];
    for (method, obj) in cases {
        let px: Vec<[f64; 2]> = obj.iter().map(|p| l.project(&truth.apply(&Vector3::from(*p)))).collect();
        let poses = solve_pnp_generic(obj, &px, &l, method, None).unwrap_or_else(|e| panic!("{method:?}, {} points: {e}", obj.len()));
        let (pose, rms) = poses[0];
        let dr = angle_between(&pose, &truth);
        let dt = (pose.t - truth.t).norm() / truth.t.norm();
        // EPnP on a plane: the fourth control point coincides with the centroid and the β
        // linearisations are approximate (as OpenCV's, whose planar poses are no closer).
        let (tol, tol_px) = if method == Method::Epnp && obj.iter().all(|p| p[2] == 0.0) { (1e-5, 0.02) } else { (1e-8, 1e-6) };
        assert!(dr < tol && dt < tol && rms < tol_px, "{method:?}, {} points: rotation off by {dr}, translation by {dt}, RMS {rms}", obj.len());
        if matches!(method, Method::Ippe | Method::IppeSquare) {
            assert_eq!(poses.len(), 2, "{method:?}");
            assert!(poses[1].1 >= rms, "{method:?}: the second pose reprojects better than the first");
        } else if method == Method::P3p {
            // Every pose of the first three points (up to four, as OpenCV's solvePnPGeneric),
            // each reprojecting those three exactly; the fourth point picks the first.
            assert!((1..=4).contains(&poses.len()), "{} poses", poses.len());
            for (p, e) in &poses[1..] {
                let three: f64 = obj[..3].iter().zip(&px).map(|(o, q)| {
                    let u = l.project(&p.apply(&Vector3::from(*o)));
                    (u[0] - q[0]).powi(2) + (u[1] - q[1]).powi(2)
                }).sum();
                assert!(three < 1e-12 && *e > rms, "{method:?}: another pose, three points off by {three}, RMS {e}");
            }
        } else {
            assert_eq!(poses.len(), 1, "{method:?}");
        }
    }
}

/// With ±0.5-px noise on a chessboard and on a cloud, every method's pose lies within 5 mrad of
/// the truth (EPnP on the plane 20 mrad), and SQPnP's is a minimum of its object-space error
/// Σ‖(I − vvᵀ/vᵀv)(RX + t)‖² over R (t at its best for each R): none of 200 rotations up to
/// 3 mrad away lowers it.
#[test]
fn methods_agree_on_noisy_pixels_and_sqpnp_is_a_minimum() {
    let l = lens();
    let truth = Pose { rvec: Vector3::new(-0.25, 0.35, 0.1), t: Vector3::new(30.0, -20.0, 600.0) };
    let board: Vec<[f64; 3]> = (0..54).map(|k| [(k % 9) as f64 * 20.0 - 80.0, (k / 9) as f64 * 20.0 - 50.0, 0.0]).collect();
    let mut state = 99u64;
    let mut noise = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1.0
    };
    for obj in [board.clone(), cloud(30, 3)] {
        let px: Vec<[f64; 2]> = obj.iter().map(|p| l.project(&truth.apply(&Vector3::from(*p)))).map(|q| [q[0] + noise(), q[1] + noise()]).collect();
        let planar = obj.iter().all(|p| p[2] == 0.0);
        let methods: &[Method] = if planar { &[Method::Iterative, Method::Epnp, Method::Sqpnp, Method::Ippe] } else { &[Method::Iterative, Method::Epnp, Method::Sqpnp] };
        for &m in methods {
            let (pose, _) = solve_pnp_generic(&obj, &px, &l, m, None).unwrap()[0];
            let dr = angle_between(&pose, &truth);
            // EPnP's planar case is the least accurate (OpenCV's no better: same reprojection error).
            let tol = if planar && m == Method::Epnp { 2e-2 } else { 5e-3 };
            assert!(dr < tol, "{m:?} (planar {planar}): {dr} rad from the truth");
        }
        // SQPnP's objective, on the pixels through the lens's inverse.
        let (pose, _) = solve_pnp_generic(&obj, &px, &l, Method::Sqpnp, None).unwrap()[0];
        let cam = render::camera::OpenCv::unchecked(
            render::camera::Intrinsics { fx: l.fx, fy: l.fy, cx: l.cx, cy: l.cy },
            l.distortion(),
            render::camera::Extrinsics::identity(),
        )
        .unwrap();
        let norm: Vec<Vector3<f64>> = px
            .iter()
            .map(|q| {
                let (x, y, ok) = cam.undistort((q[0] - l.cx) / l.fx, (q[1] - l.cy) / l.fy);
                assert!(ok);
                Vector3::new(x, y, 1.0)
            })
            .collect();
        let qs: Vec<nalgebra::Matrix3<f64>> = norm.iter().map(|v| nalgebra::Matrix3::identity() - v * v.transpose() / v.norm_squared()).collect();
        let objective = |r: &nalgebra::Matrix3<f64>| {
            // Best t for R: Σ Q (R X + t) = 0.
            let sq: nalgebra::Matrix3<f64> = qs.iter().sum();
            let rhs: Vector3<f64> = qs.iter().zip(&obj).map(|(q, x)| q * (r * Vector3::from(*x))).sum();
            let t = -(sq.try_inverse().unwrap() * rhs);
            qs.iter().zip(&obj).map(|(q, x)| (q * (r * Vector3::from(*x) + t)).norm_squared()).sum::<f64>()
        };
        let r0 = Rotation3::new(pose.rvec).into_inner();
        let e0 = objective(&r0);
        for k in 0..200 {
            let a = (k as f64 * 0.7).sin();
            let b = (k as f64 * 1.3).cos();
            let axis = Vector3::new(a, b, (k as f64 * 0.37).sin()).normalize();
            let angle = 3e-3 * ((k % 10) as f64 + 1.0) / 10.0;
            let r = Rotation3::new(axis * angle).into_inner() * r0;
            assert!(objective(&r) >= e0 * (1.0 - 1e-12), "a rotation {angle} rad away lowers SQPnP's error");
        }
    }
}

/// The methods' layouts: P3P takes exactly 4 points, IPPE points on one plane, IPPE_SQUARE a
/// square's corners in OpenCV's order, EPnP at least 4 and SQPnP at least 3; each violation is
/// a one-line error; OpenCV 5's flag numbers map to the methods.
#[test]
fn method_layouts_are_checked() {
    let l = lens();
    let truth = Pose { rvec: Vector3::new(0.3, -0.45, 0.2), t: Vector3::new(-40.0, 25.0, 520.0) };
    let pts = cloud(8, 5);
    let px: Vec<[f64; 2]> = pts.iter().map(|p| l.project(&truth.apply(&Vector3::from(*p)))).collect();
    let err = |m: Method, n: usize| solve_pnp_generic(&pts[..n], &px[..n], &l, m, None).unwrap_err().to_string();
    assert!(err(Method::P3p, 5).contains("exactly 4"));
    assert!(err(Method::Ippe, 6).contains("plane"));
    assert!(err(Method::IppeSquare, 4).contains("square"));
    assert!(err(Method::Epnp, 3).contains("at least 4"));
    assert!(err(Method::Sqpnp, 2).contains("at least 3"));
    let e = solve_pnp_generic(&pts[..4], &px[..3], &l, Method::Epnp, None).unwrap_err().to_string();
    assert!(e.contains("4 object points") && e.contains("3 image points"), "{e}");
    for (flag, m) in [(0, Method::Iterative), (1, Method::Epnp), (2, Method::P3p), (3, Method::P3p), (4, Method::Ippe), (5, Method::IppeSquare), (6, Method::Sqpnp)] {
        assert_eq!(Method::from_opencv(flag), Some(m));
    }
    assert_eq!(Method::from_opencv(7), None);
    assert_eq!(Method::from_opencv(-1), None);
}

/// Four points on a plane seen through a strongly distorted lens: the homography of four points
/// fits them exactly, so a start from the distorted pixels can lie nearer the plane's other
/// minimum. From the undistorted pixels (OpenCV's start) every one of 200 random poses comes back
/// to 1e-7.
#[test]
fn four_coplanar_points_through_a_distorted_lens() {
    let l = Lens::from_opencv(800.0, 760.0, 330.0, 250.0, &[-0.28, 0.09, 0.0012, -0.0009, -0.015]);
    let mut state = 99u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let obj: Vec<[f64; 3]> = (0..4).map(|_| [0.3 * next() - 0.15, 0.3 * next() - 0.15, 0.0]).collect();
        let truth = Pose { rvec: Vector3::new(0.8 * next() - 0.4, 0.8 * next() - 0.4, 0.8 * next() - 0.4), t: Vector3::new(0.2 * next() - 0.1, 0.2 * next() - 0.1, 0.5 + 0.7 * next()) };
        let px: Vec<[f64; 2]> = obj.iter().map(|p| l.project(&truth.apply(&Vector3::from(*p)))).collect();
        let (pose, _) = solve_pnp(&obj, &px, &l).unwrap();
        worst = worst.max(angle_between(&pose, &truth));
    }
    assert!(worst < 1e-7, "worst rotation error {worst} rad");
}
