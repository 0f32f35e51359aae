//! OpenCV's fisheye model (`scan::calib::fisheye`): closed forms of the equidistant projection,
//! the inverse against the forward map, and calibration round trips with known truth.

use crate::common::Pcg;
use nalgebra::Vector3;
use scan::calib::fisheye::{calibrate_fisheye, FisheyeHold, FisheyeLens};
use scan::calib::model::Pose;
use scan::calib::zhang::board_points;

/// A wide-angle lens with OpenCV-sized terms (a 1280 × 960 image covers about ±75° across).
fn lens() -> FisheyeLens {
    FisheyeLens { fx: 352.4, fy: 351.1, cx: 641.3, cy: 478.9, skew: 0.0, k: [0.052, -0.021, 0.0043, -0.0004] }
}

/// Eight views of a 9 × 6 board of 40-unit squares, up to 60° off the axis and tilted up to 55°.
fn poses() -> Vec<Pose> {
    [
        ([0.05, -0.03, 0.02], [-160.0, -100.0, 420.0]),
        ([0.6, 0.1, -0.05], [-180.0, -60.0, 330.0]),
        ([-0.55, 0.2, 0.1], [-150.0, -140.0, 360.0]),
        ([0.1, 0.7, 0.05], [-300.0, -90.0, 300.0]),
        ([0.2, -0.75, -0.1], [60.0, -110.0, 310.0]),
        ([-0.3, -0.4, 0.3], [40.0, 80.0, 380.0]),
        ([0.45, 0.45, -0.2], [-420.0, 120.0, 330.0]),
        ([-0.2, 0.1, 0.9], [-60.0, -260.0, 290.0]),
    ]
    .iter()
    .map(|(r, t)| Pose { rvec: Vector3::from(*r), t: Vector3::from(*t) })
    .collect()
}

fn observe(l: &FisheyeLens, obj: &[[f64; 2]], poses: &[Pose], noise_px: f64, seed: u64) -> Vec<Vec<[f64; 2]>> {
    let mut rng = Pcg::new(seed);
    poses
        .iter()
        .map(|p| {
            obj.iter()
                .map(|q| {
                    let x = p.apply(&Vector3::new(q[0], q[1], 0.0));
                    let c = l.project([x[0], x[1], x[2]]);
                    [c[0] + noise_px * rng.normal(), c[1] + noise_px * rng.normal()]
                })
                .collect()
        })
        .collect()
}

/// With k = 0 the image radius is f·θ (the equidistant projection), θ the angle off the axis,
/// up to 89°; the skew shifts u by α·fx·y_d.
#[test]
fn equidistant_lens_puts_angle_at_radius() {
    let l = FisheyeLens { fx: 300.0, fy: 300.0, cx: 0.0, cy: 0.0, skew: 0.0, k: [0.0; 4] };
    for deg in [0.5, 10.0, 45.0, 70.0, 89.0] {
        let th = f64::to_radians(deg);
        for phi in [0.3, 2.0, 4.0] {
            let p = l.project([th.sin() * f64::cos(phi), th.sin() * f64::sin(phi), th.cos()]);
            let want = [300.0 * th * f64::cos(phi), 300.0 * th * f64::sin(phi)];
            assert!((p[0] - want[0]).abs() < 1e-10 && (p[1] - want[1]).abs() < 1e-10, "{deg}°: {p:?} against {want:?}");
        }
    }
    let s = FisheyeLens { skew: 0.01, ..l };
    let p = s.project([0.0, 0.5f64.tan(), 1.0]);
    assert!((p[0] - 300.0 * 0.01 * 0.5).abs() < 1e-12 && (p[1] - 150.0).abs() < 1e-12);
    // At or behind the camera's plane there is no image.
    assert!(l.project([1.0, 0.0, 0.0])[0].is_nan() && l.project([0.0, 1.0, -1.0])[1].is_nan());
}

/// The inverse takes every pixel back to its ray: to 10⁻¹² over the field, with skew; θ_max
/// is where θ_d stops increasing (1 + 3 k1 θ² = 0 for k1 alone), and rays beyond it have none.
#[test]
fn undistort_inverts_the_projection() {
    let l = FisheyeLens { skew: 0.004, ..lens() };
    let tm = l.theta_max();
    let mut rng = Pcg::new(5);
    let mut worst: f64 = 0.0;
    for _ in 0..2000 {
        let th = 1.45 * rng.uniform();
        let phi = std::f64::consts::TAU * rng.uniform();
        let (a, b) = (th.tan() * phi.cos(), th.tan() * phi.sin());
        let p = l.project([a, b, 1.0]);
        let (xd, yd) = l.normalise(p[0], p[1]);
        let (x, y) = l.undistort(xd, yd, tm).expect("inside the increasing range");
        worst = worst.max(((x - a).hypot(y - b)) / (1.0 + a.hypot(b)));
    }
    assert!(worst < 1e-12, "worst relative error {worst:e}");
    let fold = FisheyeLens { k: [-0.5, 0.0, 0.0, 0.0], ..lens() };
    let want = (1.0f64 / 1.5).sqrt();
    assert!((fold.theta_max() - want).abs() < 1e-12, "{} against {want}", fold.theta_max());
    let td_max = fold.theta_d(want);
    assert!(fold.solve_theta(0.999 * td_max, want).is_some() && fold.solve_theta(1.001 * td_max, want).is_none());
}

/// Noiseless views of a known lens give it back exactly: every term to 10⁻⁸ relative, every
/// pose to 10⁻⁸, RMS below 10⁻⁹ px; with the skew in the truth and free in the fit as well.
#[test]
fn calibration_recovers_a_known_fisheye() {
    let obj = board_points(9, 6, 40.0);
    for truth in [lens(), FisheyeLens { skew: 0.0025, ..lens() }] {
        let views = observe(&truth, &obj, &poses(), 0.0, 1);
        let fit = calibrate_fisheye(&obj, &views, 1280, 960, FisheyeHold::default(), None, 1.0).unwrap();
        let (g, w) = (fit.lens.to_array(), truth.to_array());
        for i in 0..9 {
            let scale = if i < 4 { w[0] } else { 1.0 };
            assert!((g[i] - w[i]).abs() < 1e-8 * scale, "term {i}: {} against {}", g[i], w[i]);
        }
        for (p, q) in fit.poses.iter().zip(poses()) {
            assert!((p.rvec - q.rvec).norm() < 1e-8 && (p.t - q.t).norm() < 1e-8 * q.t.norm());
        }
        assert!(fit.rms_px < 1e-9, "RMS {}", fit.rms_px);
    }
}

/// Held terms stay where they start (OpenCV's CALIB_FIX_SKEW, CALIB_FIX_K3, CALIB_FIX_K4,
/// CALIB_FIX_PRINCIPAL_POINT with a guess). On views with 0.3 px of noise, over 16 seeds, the
/// free terms scatter about the truth (mean within 4 standard errors of the 16), and each fit's
/// RMS is what the noise leaves: E[RMS²] = σ²(2N − p)/N for N points and p free terms.
#[test]
fn held_terms_stay_and_noise_gives_the_expected_rms() {
    let obj = board_points(9, 6, 40.0);
    let truth = FisheyeLens { k: [0.052, -0.021, 0.0, 0.0], ..lens() };
    let hold = FisheyeHold { skew: true, k: [false, false, true, true], principal_point: true, ..Default::default() };
    let guess = FisheyeLens { fx: 330.0, fy: 330.0, k: [0.0; 4], ..truth };
    let (n, p): (f64, f64) = (8.0 * 54.0, 4.0 + 48.0);
    let expect = 0.3 * ((2.0 * n - p) / n).sqrt();
    let mut free = Vec::new();
    for seed in 0..16 {
        let views = observe(&truth, &obj, &poses(), 0.3, 100 + seed);
        let fit = calibrate_fisheye(&obj, &views, 1280, 960, hold, Some(guess), 2.0).unwrap();
        let l = fit.lens;
        assert_eq!((l.cx, l.cy, l.skew, l.k[2], l.k[3]), (truth.cx, truth.cy, 0.0, 0.0, 0.0));
        // The RMS² of one fit has 2N − p degrees of freedom: relative sd √(2/(2N − p)) ≈ 5 %.
        assert!((fit.rms_px / expect - 1.0).abs() < 0.1, "seed {seed}: RMS {} against {expect}", fit.rms_px);
        free.push([l.fx - truth.fx, l.fy - truth.fy, l.k[0] - truth.k[0], l.k[1] - truth.k[1]]);
    }
    for i in 0..4 {
        let m = free.iter().map(|f| f[i]).sum::<f64>() / 16.0;
        let sd = (free.iter().map(|f| (f[i] - m).powi(2)).sum::<f64>() / 15.0).sqrt();
        assert!(m.abs() < 4.0 * sd / 4.0, "term {i}: mean error {m:e}, sd {sd:e}");
        assert!(sd > 0.0);
    }
}

/// Bad input is one line: a view that sees fewer than 4 points, a view of another length, no
/// views, a guess with a negative focal length.
#[test]
fn fisheye_calibration_refuses_bad_input() {
    let obj = board_points(9, 6, 40.0);
    let mut views = observe(&lens(), &obj, &poses(), 0.0, 1);
    let e = |v: &[Vec<[f64; 2]>], g: Option<FisheyeLens>| calibrate_fisheye(&obj, v, 1280, 960, FisheyeHold::default(), g, 1.0).unwrap_err().to_string();
    assert!(e(&[], None).contains("no views"));
    views[2].truncate(10);
    assert!(e(&views, None).contains("view 2 has 10 points"));
    views[2] = vec![[f64::NAN; 2]; obj.len()];
    views[2][0] = [1.0, 2.0];
    assert!(e(&views, None).contains("view 2 sees fewer than 4"));
    let views = observe(&lens(), &obj, &poses(), 0.0, 1);
    assert!(e(&views, Some(FisheyeLens { fx: -1.0, ..lens() })).contains("positive focal"));
}

/// A fisheye pair seeing the same eight views: noiseless projections give both lenses, the
/// relative pose and every view's pose back to 10⁻⁸; with the intrinsics held (given exactly,
/// then given 1 % off) the lenses stay where they were given, and the pose is exact only when
/// they are.
#[test]
fn stereo_calibration_recovers_a_known_fisheye_pair() {
    use scan::calib::fisheye::stereo_calibrate_fisheye;
    let obj = board_points(9, 6, 40.0);
    let second = FisheyeLens { fx: 349.0, fy: 348.2, cx: 630.2, cy: 489.5, skew: 0.0, k: [0.047, -0.018, 0.0031, -0.0002] };
    let stereo = Pose { rvec: Vector3::new(0.02, -0.12, 0.01), t: Vector3::new(-60.0, 2.0, 5.0) };
    let v1 = observe(&lens(), &obj, &poses(), 0.0, 1);
    let poses2: Vec<Pose> = poses().iter().map(|p| stereo.after(p)).collect();
    let v2 = observe(&second, &obj, &poses2, 0.0, 1);
    let hold = FisheyeHold { skew: true, ..Default::default() };
    let fit = stereo_calibrate_fisheye(&obj, [&v1, &v2], 1280, 960, hold, false, [None, None], 1.0).unwrap();
    for (got, want) in fit.lens.iter().zip([lens(), second]) {
        let (g, w) = (got.to_array(), want.to_array());
        for i in 0..9 {
            let scale = if i < 4 { w[0] } else { 1.0 };
            assert!((g[i] - w[i]).abs() < 1e-8 * scale, "term {i}: {} against {}", g[i], w[i]);
        }
    }
    assert!((fit.stereo.rvec - stereo.rvec).norm() < 1e-9 && (fit.stereo.t - stereo.t).norm() < 1e-8 * stereo.t.norm(), "{:?}", fit.stereo);
    assert!(fit.rms_px < 1e-9, "RMS {}", fit.rms_px);
    // Held intrinsics: exact ones give the rig exactly; 1 % off they stay off, and the RMS shows it.
    let held = stereo_calibrate_fisheye(&obj, [&v1, &v2], 1280, 960, hold, true, [Some(lens()), Some(second)], 1.0).unwrap();
    assert!((held.stereo.t - stereo.t).norm() < 1e-8 * stereo.t.norm() && held.rms_px < 1e-9);
    let off = FisheyeLens { fx: 1.01 * second.fx, ..second };
    let held = stereo_calibrate_fisheye(&obj, [&v1, &v2], 1280, 960, hold, true, [Some(lens()), Some(off)], 10.0).unwrap();
    assert_eq!(held.lens, [lens(), off]);
    assert!(held.rms_px > 0.1, "RMS {}", held.rms_px);
    let e = stereo_calibrate_fisheye(&obj, [&v1, &v2[..7]], 1280, 960, hold, false, [None, None], 1.0).unwrap_err().to_string();
    assert!(e.contains("8 and 7 views"), "{e}");
}
