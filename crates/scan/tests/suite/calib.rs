//! Calibration core against closed forms and known synthetic truth: normalised-DLT homographies,
//! Zhang's closed form, and the Levenberg–Marquardt refinement of a projector–camera pair.

use crate::common::{board, observe, rig, Pcg};
use nalgebra::{Matrix3, Vector3};
use scan::calib::bundle::{rms, State, ViewObs};
use scan::calib::homography::{apply, fit_homography, fit_homography_fast, fit_homography_robust};
use scan::calib::model::Lens;
use scan::calib::zhang::{intrinsics, pose_from_homography};
use scan::calib::{calibrate_corners, CaptureCorners, ProcamCalibration, Rig};

fn rel(a: f64, b: f64, scale: f64) -> f64 {
    (a - b).abs() / scale
}

#[test]
fn homography_from_exact_correspondences_is_exact() {
    let h = Matrix3::new(1.7, 0.21, 412.0, -0.13, 1.52, 305.0, 2.1e-4, -1.3e-4, 1.0);
    let src: Vec<[f64; 2]> = (0..30).map(|k| [(k % 6) as f64 * 75.0 - 10.0, (k / 6) as f64 * 75.0 + 3.0]).collect();
    let dst: Vec<[f64; 2]> = src.iter().map(|p| apply(&h, *p)).collect();
    let f = fit_homography(&src, &dst).unwrap();
    for (a, b) in f.iter().zip(h.iter()) {
        assert!((a - b).abs() <= 1e-9 * b.abs().max(1e-3), "{f} vs {h}");
    }
    // Four points are the minimum; three collinear plus one still determine H, all collinear do not.
    let four = [0, 1, 6, 7];
    let f4 = fit_homography(&four.map(|i| src[i]), &four.map(|i| dst[i])).unwrap();
    assert!((f4 - h).norm() < 1e-9 * h.norm());
    let line: Vec<[f64; 2]> = (0..8).map(|k| [k as f64, 2.0 * k as f64]).collect();
    assert!(fit_homography(&line, &line).is_none());
    // The H₃₃ = 1 fit of the chessboard search: the same on exact points, and no fit for a line.
    for (s, d) in [(&src[..], &dst[..]), (&four.map(|i| src[i])[..], &four.map(|i| dst[i])[..])] {
        let f = fit_homography_fast(s, d).unwrap();
        assert!((f - h).norm() < 1e-9 * h.norm(), "{f} vs {h}");
    }
    assert!(fit_homography_fast(&line, &line).is_none());
    // Noisy points: both fits predict a lattice node alike (the algebraic errors differ).
    let mut rng = Pcg::new(3);
    let noisy: Vec<[f64; 2]> = dst.iter().map(|p| [p[0] + 0.5 * (rng.uniform() - 0.5), p[1] + 0.5 * (rng.uniform() - 0.5)]).collect();
    let (fa, fb) = (fit_homography(&src, &noisy).unwrap(), fit_homography_fast(&src, &noisy).unwrap());
    let q = [200.0, 180.0];
    let (a, b) = (apply(&fa, q), apply(&fb, q));
    assert!((a[0] - b[0]).abs() < 0.05 && (a[1] - b[1]).abs() < 0.05, "{a:?} vs {b:?}");
}

#[test]
fn robust_homography_ignores_gross_outliers() {
    let h = Matrix3::new(0.8, 0.05, 300.0, -0.02, 0.83, 200.0, 1e-5, 2e-5, 1.0);
    let mut rng = Pcg::new(7);
    let src: Vec<[f64; 2]> = (0..2000).map(|_| [rng.uniform() * 47.0 + 600.0, rng.uniform() * 47.0 + 500.0]).collect();
    let mut dst: Vec<[f64; 2]> = src.iter().map(|p| apply(&h, *p)).collect();
    // 5 % wrong by 30–60 projector pixels (decoding errors at stripe boundaries).
    for d in dst.iter_mut().step_by(20) {
        d[0] += 30.0 + 30.0 * rng.uniform();
    }
    let (f, inliers) = fit_homography_robust(&src, &dst, 3, 3.0, 0.5).unwrap();
    assert_eq!(inliers, 1900);
    let c = [623.4, 521.7];
    let (a, b) = (apply(&f, c), apply(&h, c));
    assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
}

fn homographies(s: &State, views: &[ViewObs], projector: bool) -> Vec<Matrix3<f64>> {
    let obj = board();
    let _ = s;
    views.iter().map(|v| fit_homography(&obj, if projector { &v.proj } else { &v.cam }).unwrap()).collect()
}

#[test]
fn zhang_closed_form_is_exact_on_noiseless_corners() {
    let truth = rig(false);
    let views = observe(&truth, &board());
    for (projector, lens, size) in [(false, truth.cam, (1280, 1024)), (true, truth.proj.unwrap(), (1024, 768))] {
        let hs = homographies(&truth, &views, projector);
        let k = intrinsics(&hs[..3], size.0, size.1).unwrap();
        let f = lens.fx;
        for (a, b) in [(k.fx, lens.fx), (k.fy, lens.fy), (k.cx, lens.cx), (k.cy, lens.cy)] {
            assert!(rel(a, b, f) < 1e-9, "projector={projector}: {k:?} vs {lens:?}");
        }
        // The board poses from H and K.
        for (v, h) in hs.iter().enumerate() {
            let pose = pose_from_homography(h, &k.k()).unwrap();
            let want = if projector { truth.stereo.after(&truth.poses[v]) } else { truth.poses[v] };
            assert!((pose.r() - want.r()).norm() < 1e-9, "view {v}");
            assert!((pose.t - want.t).norm() < 1e-9 * want.t.norm(), "view {v}: {} vs {}", pose.t, want.t);
        }
    }
}

#[test]
fn zhang_refuses_parallel_boards() {
    let mut s = rig(false);
    for p in s.poses.iter_mut() {
        p.rvec = Vector3::zeros();
    }
    let views = observe(&s, &board());
    let e = intrinsics(&homographies(&s, &views, false), 1280, 1024).unwrap_err().to_string();
    assert!(e.contains("degenerate pose set"), "{e}");
}

fn corners(views: &[ViewObs]) -> Vec<CaptureCorners> {
    views.iter().enumerate().map(|(i, v)| CaptureCorners { name: format!("v{i}"), cam: v.cam.clone(), proj: v.proj.clone() }).collect()
}

const RIG: Rig = Rig { cols: 9, rows: 7, square: 75.0, camera: (1280, 1024), projector: (1024, 768) };

fn lens_of(d: &scan::calib::DeviceCalibration) -> Lens {
    Lens::from_opencv(d.fx, d.fy, d.cx, d.cy, &d.distortion)
}

/// Largest deviation of a calibration from the truth: intrinsics relative to fx, distortion
/// absolute, rotation (Frobenius), translation relative to |T|.
fn deviation(c: &ProcamCalibration, truth: &State) -> f64 {
    let mut worst: f64 = 0.0;
    for (got, want) in [(lens_of(&c.camera), truth.cam), (lens_of(&c.projector), truth.proj.unwrap())] {
        let (g, w) = (got.to_array(), want.to_array());
        for i in 0..4 {
            worst = worst.max(rel(g[i], w[i], want.fx));
        }
        for i in 4..18 {
            worst = worst.max((g[i] - w[i]).abs());
        }
    }
    let r = Matrix3::from_fn(|i, j| c.rotation[i][j]);
    worst = worst.max((r - truth.stereo.r()).norm());
    worst = worst.max((Vector3::from(c.translation) - truth.stereo.t).norm() / truth.stereo.t.norm());
    worst
}

#[test]
fn levenberg_marquardt_recovers_noiseless_truth() {
    let truth = rig(true);
    let views = observe(&truth, &board());
    let c = calibrate_corners(&RIG, &corners(&views)).unwrap();
    let d = deviation(&c, &truth);
    assert!(d < 1e-9, "deviation {d:e}: {c:?}");
    assert!(c.rms_px < 1e-9 && c.camera.rms_px < 1e-9 && c.projector.rms_px < 1e-9);
    for (p, want) in c.captures.iter().zip(&truth.poses) {
        assert!((Vector3::from(p.tvec) - want.t).norm() < 1e-9 * want.t.norm());
    }
}

/// OpenCV's CALIB_FIX_K3 and CALIB_ZERO_TANGENT_DIST (`scan calibrate --fix-k3 --zero-tangent`):
/// a rig whose lenses have no k3 and no tangential terms is recovered exactly with those terms
/// held at 0; held on the distorted rig, they stay exactly 0 and the residual the fit can no
/// longer absorb shows in its RMS.
#[test]
fn held_distortion_terms_stay_zero() {
    use scan::calib::bundle::Free;
    use scan::calib::calibrate_corners_with;
    let held = Free { k3: false, tangential: false, ..Free::default() };
    let mut truth = rig(true);
    for l in [&mut truth.cam, truth.proj.as_mut().unwrap()] {
        l.dist[2] = 0.0;
        l.dist[3] = 0.0;
        l.dist[4] = 0.0;
    }
    let c = calibrate_corners_with(&RIG, &corners(&observe(&truth, &board())), None, held).unwrap();
    for d in [&c.camera, &c.projector] {
        assert_eq!(&d.distortion[2..5], &[0.0, 0.0, 0.0]);
    }
    let dev = deviation(&c, &truth);
    assert!(dev < 1e-9 && c.rms_px < 1e-9, "deviation {dev:e}, RMS {}", c.rms_px);
    let full = rig(true);
    let views = corners(&observe(&full, &board()));
    let c = calibrate_corners_with(&RIG, &views, None, held).unwrap();
    for d in [&c.camera, &c.projector] {
        assert_eq!(&d.distortion[2..5], &[0.0, 0.0, 0.0]);
    }
    // The truth's tangential terms shift corners by up to about a pixel: held at 0, they leave a
    // residual well above the free fit's 1e-9.
    assert!(c.rms_px > 1e-3, "RMS {}", c.rms_px);
    let free = calibrate_corners_with(&RIG, &views, None, Free::default()).unwrap();
    assert!(free.rms_px < 1e-9);
}

/// OpenCV's CALIB_THIN_PRISM_MODEL (`scan calibrate --thin-prism`): a rig whose lenses have thin
/// prism terms s1…s4 is recovered to 1e-9 with them
/// fitted, k4…k6 held at exactly 0 in the twelve coefficients written; the five-coefficient fit
/// cannot absorb them.
#[test]
fn thin_prism_model_recovers_its_truth() {
    use scan::calib::bundle::Free;
    use scan::calib::calibrate_corners_with;
    let mut truth = rig(true);
    truth.cam.prism = [0.004, -0.002, -0.003, 0.001];
    truth.proj.as_mut().unwrap().prism = [-0.002, 0.001, 0.003, 0.0];
    let views = corners(&observe(&truth, &board()));
    let c = calibrate_corners_with(&RIG, &views, None, Free { thin_prism: true, ..Free::default() }).unwrap();
    for d in [&c.camera, &c.projector] {
        assert_eq!(d.distortion.len(), 12);
        assert_eq!(&d.distortion[5..8], &[0.0, 0.0, 0.0]);
    }
    let dev = deviation(&c, &truth);
    assert!(dev < 1e-9 && c.rms_px < 1e-9, "deviation {dev:e}, RMS {}", c.rms_px);
    let five = calibrate_corners_with(&RIG, &views, None, Free::default()).unwrap();
    assert_eq!(five.camera.distortion.len(), 5);
    assert!(five.rms_px > 1e-3, "five coefficients: RMS {}", five.rms_px);
}

/// OpenCV's CALIB_TILTED_MODEL (`scan calibrate --tilted`): a rig whose sensors are tilted (τ of
/// 0.5–2°) is recovered to 1e-9 with the tilt fitted, in fourteen coefficients with k4…k6 and
/// s1…s4 exactly 0; the five-coefficient fit leaves a residual.
#[test]
fn tilted_model_recovers_its_truth() {
    use scan::calib::bundle::Free;
    use scan::calib::calibrate_corners_with;
    let mut truth = rig(true);
    truth.cam.tilt = [0.02, -0.012];
    truth.proj.as_mut().unwrap().tilt = [-0.009, 0.035];
    let views = corners(&observe(&truth, &board()));
    let c = calibrate_corners_with(&RIG, &views, None, Free { tilted: true, ..Free::default() }).unwrap();
    for d in [&c.camera, &c.projector] {
        assert_eq!(d.distortion.len(), 14);
        assert!(d.distortion[5..12].iter().all(|&x| x == 0.0), "{:?}", d.distortion);
    }
    let dev = deviation(&c, &truth);
    assert!(dev < 1e-9 && c.rms_px < 1e-9, "deviation {dev:e}, RMS {}", c.rms_px);
    let five = calibrate_corners_with(&RIG, &views, None, Free::default()).unwrap();
    assert!(five.rms_px > 1e-3, "five coefficients: RMS {}", five.rms_px);
}

/// OpenCV's CALIB_RATIONAL_MODEL (`scan calibrate --rational`): corners of a rig whose lenses have
/// the rational denominator k4, k5, k6 are reproduced to 1e-8 px with them fitted, with the
/// intrinsics and the stereo pose of the truth, and the distortion lists eight coefficients;
/// the five-coefficient fit leaves a residual. (The six radial coefficients themselves are not
/// identifiable over a board's field: numerator and denominator trade against each other, in
/// OpenCV as here, so they are not compared.)
#[test]
fn rational_model_recovers_its_truth() {
    use scan::calib::bundle::Free;
    use scan::calib::calibrate_corners_with;
    let mut truth = rig(true);
    truth.cam.rational = [0.08, -0.02, 0.01];
    truth.proj.as_mut().unwrap().rational = [-0.05, 0.03, 0.0];
    let views = corners(&observe(&truth, &board()));
    let c = calibrate_corners_with(&RIG, &views, None, Free { rational: true, ..Free::default() }).unwrap();
    assert_eq!((c.camera.distortion.len(), c.projector.distortion.len()), (8, 8));
    let mut geometry: f64 = 0.0;
    for (got, want) in [(lens_of(&c.camera), truth.cam), (lens_of(&c.projector), truth.proj.unwrap())] {
        let (g, w) = (got.to_array(), want.to_array());
        for i in 0..4 {
            geometry = geometry.max(rel(g[i], w[i], want.fx));
        }
    }
    geometry = geometry.max((Matrix3::from_fn(|i, j| c.rotation[i][j]) - truth.stereo.r()).norm());
    geometry = geometry.max((Vector3::from(c.translation) - truth.stereo.t).norm() / truth.stereo.t.norm());
    assert!(geometry < 1e-6 && c.rms_px < 1e-8, "intrinsics and pose off by {geometry:e}, RMS {}", c.rms_px);
    let five = calibrate_corners_with(&RIG, &views, None, Free::default()).unwrap();
    assert_eq!(five.camera.distortion.len(), 5);
    assert!(five.rms_px > 100.0 * c.rms_px.max(1e-10), "five coefficients: RMS {}", five.rms_px);
}

/// Corners outside the projector's throw: with a third of each view's projector corners missing
/// (NaN, a different third per view: the right-hand columns, the top rows, a checkerboard of
/// corners), noiseless data still give the truth to 1e-9, the missing corners add nothing to
/// the projector's RMS, and each capture reports how many it had.
#[test]
fn missing_projector_corners_leave_noiseless_truth_exact() {
    let truth = rig(true);
    let views = observe(&truth, &board());
    let mut caps = corners(&views);
    let (cols, rows) = (RIG.cols, RIG.rows);
    for (v, c) in caps.iter_mut().enumerate() {
        for k in 0..cols * rows {
            let (x, y) = (k % cols, k / cols);
            let drop = match v % 3 {
                0 => x >= 6,
                1 => y < 2,
                _ => (x + y) % 3 == 0,
            };
            if drop {
                c.proj[k] = [f64::NAN, f64::NAN];
            }
        }
    }
    let kept: Vec<usize> = caps.iter().map(|c| c.proj.iter().filter(|p| p[0].is_finite()).count()).collect();
    assert!(kept.iter().all(|&k| k < cols * rows && k >= 8), "{kept:?}");
    let c = calibrate_corners(&RIG, &caps).unwrap();
    let d = deviation(&c, &truth);
    assert!(d < 1e-9, "deviation {d:e}");
    assert!(c.rms_px < 1e-9 && c.projector.rms_px < 1e-9, "{} {}", c.rms_px, c.projector.rms_px);
    assert_eq!(c.captures.iter().map(|p| p.projector_corners).collect::<Vec<_>>(), kept);
}

/// With noise, the RMS counts only the observed corners: σ = 0.1 px on every observed coordinate
/// gives a projector RMS near σ√2 whether or not a third of its corners are missing (an RMS
/// that divided by all corners would come out √(2/3) of it).
#[test]
fn missing_projector_corners_do_not_dilute_the_rms() {
    let truth = rig(false);
    let views = observe(&truth, &board());
    let mut rng = Pcg::new(17);
    let sigma = 0.1;
    let noisy: Vec<CaptureCorners> = views
        .iter()
        .enumerate()
        .map(|(i, v)| CaptureCorners {
            name: format!("v{i}"),
            cam: v.cam.iter().map(|p| [p[0] + sigma * rng.normal(), p[1] + sigma * rng.normal()]).collect(),
            proj: v.proj.iter().enumerate().map(|(k, p)| if k % 3 == 0 { [f64::NAN, f64::NAN] } else { [p[0] + sigma * rng.normal(), p[1] + sigma * rng.normal()] }).collect(),
        })
        .collect();
    let c = calibrate_corners(&RIG, &noisy).unwrap();
    let want = sigma * 2f64.sqrt();
    assert!((c.projector.rms_px / want - 1.0).abs() < 0.15, "projector RMS {} against about {want}", c.projector.rms_px);
    assert!((c.camera.rms_px / want - 1.0).abs() < 0.15, "camera RMS {} against about {want}", c.camera.rms_px);
}

#[test]
fn levenberg_marquardt_on_noisy_corners_stays_within_the_expected_spread() {
    // σ = 0.1 px Gaussian noise on each coordinate of every corner of both devices. The RMS is
    // per corner (√(Σ‖e‖²/N), OpenCV's definition), so a least-squares fit leaves
    // σ·√2·√((m − n)/m) (m residuals, n parameters; relative spread ≈ 1/√(2m) = 2 %); the parameter errors are compared with
    // their standard deviations from the fit's covariance σ²(JᵀJ)⁻¹, each within 4.5 σ.
    let truth = rig(true);
    let obj = board();
    let clean = observe(&truth, &obj);
    let sigma = 0.1;
    let mut rng = Pcg::new(2017);
    let noisy: Vec<ViewObs> = clean
        .iter()
        .map(|v| ViewObs {
            cam: v.cam.iter().map(|p| [p[0] + sigma * rng.normal(), p[1] + sigma * rng.normal()]).collect(),
            proj: v.proj.iter().map(|p| [p[0] + sigma * rng.normal(), p[1] + sigma * rng.normal()]).collect(),
        })
        .collect();
    let c = calibrate_corners(&RIG, &corners(&noisy)).unwrap();
    let m = (4 * obj.len() * noisy.len()) as f64;
    let n = (2 * 9 + 6 + 6 * noisy.len()) as f64;
    let expect = sigma * (2.0 * (m - n) / m).sqrt();
    assert!((c.rms_px - expect).abs() < 0.08 * expect, "RMS {} vs {expect}", c.rms_px);
    let fit = State {
        cam: lens_of(&c.camera),
        proj: Some(lens_of(&c.projector)),
        stereo: scan::calib::model::Pose::from_rt(&Matrix3::from_fn(|i, j| c.rotation[i][j]), Vector3::from(c.translation)),
        poses: c.captures.iter().map(|p| scan::calib::model::Pose { rvec: Vector3::from(p.rvec), t: Vector3::from(p.tvec) }).collect(),
    };
    let sd = scan::calib::bundle::std_devs(&obj, &noisy, &fit, sigma);
    let (got, want) = (scan::calib::bundle::pack_state(&fit), scan::calib::bundle::pack_state(&truth));
    let mut worst: f64 = 0.0;
    for i in 0..got.len() {
        // k4…k6 are held at 0 by this fit (standard deviation NaN): not estimated, not compared.
        if sd[i].is_nan() {
            assert_eq!((got[i], want[i]), (0.0, 0.0));
            continue;
        }
        worst = worst.max((got[i] - want[i]).abs() / sd[i]);
    }
    assert!(worst < 4.5, "worst parameter error {worst:.2} standard deviations");
    // And the fit is not trivially exact: the noise moves the focal lengths measurably.
    assert!((c.camera.fx - truth.cam.fx).abs() > 1e-4);
    let e = rms(&obj, &noisy, &fit);
    assert!((e.all - c.rms_px).abs() < 1e-12);
}

#[test]
fn two_captures_are_refused() {
    let truth = rig(true);
    let views = observe(&truth, &board());
    let e = calibrate_corners(&RIG, &corners(&views[..2])).unwrap_err().to_string();
    assert!(e.contains("degenerate pose set"), "{e}");
}

/// A calibration written as OpenCV FileStorage (XML and YAML, procam-calibration's node names and
/// proj_shape) reads back bit for bit, with every distortion length OpenCV uses; the size given on
/// the command line must agree with proj_shape.
#[test]
fn filestorage_copy_reads_back_exactly() {
    use scan::calib::DeviceCalibration;
    let dir = std::env::temp_dir().join(format!("lucent-fs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let a = 0.3f64;
    let rotation = [[a.cos(), 0.0, a.sin()], [0.0, 1.0, 0.0], [-a.sin(), 0.0, a.cos()]];
    for (n, dist) in [4usize, 5, 8, 12, 14].into_iter().enumerate().map(|(i, n)| (i, (0..n).map(|k| 1e-3 * (k as f64 + 1.0) / 7.0 * if k % 2 == 0 { 1.0 } else { -1.0 }).collect::<Vec<f64>>())) {
        let dev = |w, h, f: f64| DeviceCalibration { width: w, height: h, fx: f, fy: f * 1.0001, cx: w as f64 / 2.0 - 0.37, cy: h as f64 / 2.0 + 0.11, distortion: dist.clone(), rms_px: 0.1 / 3.0 };
        let c = ProcamCalibration {
            camera: dev(1280, 1024, 3441.0 / 3.0),
            projector: dev(1024, 768, 1893.0 / 7.0),
            rotation,
            translation: [92.8 / 3.0, -624.8, -236.7 / 11.0],
            rms_px: 0.1 / 3.0,
            captures: Vec::new(),
        };
        for yaml in [false, true] {
            let path = dir.join(format!("c{n}.{}", if yaml { "yml" } else { "xml" }));
            std::fs::write(&path, c.to_filestorage(yaml)).unwrap();
            assert_eq!(ProcamCalibration::read(&path, None).unwrap(), c, "{} coefficients, yaml {yaml}", dist.len());
            assert_eq!(ProcamCalibration::read(&path, Some((1024, 768))).unwrap(), c);
            let e = ProcamCalibration::read(&path, Some((800, 600))).unwrap_err().to_string();
            assert!(e.contains("1024x768") && e.contains("800x600") && !e.contains('\n'), "{e}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Camera-only calibration (`scan calibrate-camera`, OpenCV's `calibrateCamera`): the noiseless
/// corners of the rig's camera in its board poses give back its intrinsics, distortion and board
/// poses to 1e-9; with --thin-prism on a lens that has prism terms, those too, in twelve
/// coefficients; fewer than 3 views and a view with a missing corner are one-line errors.
#[test]
fn camera_only_calibration_recovers_its_truth() {
    use scan::calib::bundle::Free;
    use scan::calib::camera::calibrate_camera;
    let (w, h) = RIG.camera;
    let check = |truth: &State, free: Free, n_coef: usize| {
        let views: Vec<(String, Vec<[f64; 2]>)> = observe(truth, &board()).into_iter().enumerate().map(|(i, v)| (format!("view{i}"), v.cam)).collect();
        let c = calibrate_camera(&views, w, h, RIG.cols, RIG.rows, RIG.square, free).unwrap();
        assert_eq!(c.dist.len(), n_coef);
        let got = Lens::from_opencv(c.fx, c.fy, c.cx, c.cy, &c.dist).to_array();
        let want = truth.cam.to_array();
        let mut worst: f64 = (0..4).map(|i| rel(got[i], want[i], want[0])).fold(0.0, f64::max);
        worst = (4..18).map(|i| (got[i] - want[i]).abs()).fold(worst, f64::max);
        for (v, p) in c.views.iter().zip(&truth.poses) {
            worst = worst.max((Vector3::from(v.tvec) - p.t).norm() / p.t.norm());
            worst = worst.max((Vector3::from(v.rvec) - p.rvec).norm());
        }
        assert!(worst < 1e-9 && c.rms_px < 1e-9, "deviation {worst:e}, RMS {}", c.rms_px);
        (views, c)
    };
    let (views, _) = check(&rig(true), Free::default(), 5);
    let mut prism = rig(true);
    prism.cam.prism = [0.004, -0.002, -0.003, 0.001];
    check(&prism, Free { thin_prism: true, ..Free::default() }, 12);
    let e = calibrate_camera(&views[..2], w, h, RIG.cols, RIG.rows, RIG.square, Free::default()).unwrap_err().to_string();
    assert!(e.contains("at least 3 views"), "{e}");
    let mut short = views.clone();
    short[1].1.pop();
    let e = calibrate_camera(&short, w, h, RIG.cols, RIG.rows, RIG.square, Free::default()).unwrap_err().to_string();
    assert!(e.contains("view1") && !e.contains('\n'), "{e}");
}

/// OpenCV's `CALIB_FIX_PRINCIPAL_POINT`, `CALIB_FIX_ASPECT_RATIO`, `CALIB_FIX_K*` and
/// `CALIB_USE_INTRINSIC_GUESS` (`Free::held`, `Free::aspect_ratio`, `calibrate_camera_guided`):
/// a camera whose principal point is the image centre and whose fx/fy is known gives back its
/// truth to 1e-9 with those held, and the held values exactly; from a guess, held terms keep the
/// guess's values while the rest converge; on noisy corners the constrained fit cannot fit better
/// than the free one, and holds its constraints exactly.
#[test]
fn held_lens_terms_stay_where_opencv_holds_them() {
    use scan::calib::bundle::{hold_k, Free, HOLD_FOCAL, HOLD_PRINCIPAL_POINT};
    use scan::calib::camera::calibrate_camera_guided;
    let (w, h) = RIG.camera;
    let mut truth = rig(true);
    (truth.cam.cx, truth.cam.cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let ratio = truth.cam.fx / truth.cam.fy;
    let obj = board();
    let views = |s: &State, noise: f64| -> Vec<(String, Vec<[f64; 2]>)> {
        let mut rng = Pcg::new(17);
        observe(s, &obj).into_iter().enumerate().map(|(i, v)| (format!("view{i}"), v.cam.iter().map(|p| [p[0] + noise * rng.normal(), p[1] + noise * rng.normal()]).collect())).collect()
    };
    let exact = views(&truth, 0.0);
    let held = Free { held: HOLD_PRINCIPAL_POINT, aspect_ratio: [Some(ratio), None], ..Free::default() };
    let c = calibrate_camera_guided(&obj, &exact, w, h, held, None).unwrap();
    assert_eq!((c.cx, c.cy), (truth.cam.cx, truth.cam.cy));
    assert!((c.fx / c.fy - ratio).abs() < 1e-15 * ratio);
    let got = Lens::from_opencv(c.fx, c.fy, c.cx, c.cy, &c.dist).to_array();
    let want = truth.cam.to_array();
    let worst = (0..2).map(|i| rel(got[i], want[i], want[0])).chain((4..9).map(|i| (got[i] - want[i]).abs())).fold(0.0, f64::max);
    assert!(worst < 1e-9 && c.rms_px < 1e-9, "deviation {worst:e}, RMS {}", c.rms_px);

    // From a guess: k1 and the focal lengths held at the guess's values, everything else fitted.
    let mut guess = truth.cam;
    guess.dist[0] += 0.01;
    (guess.cx, guess.cy) = (guess.cx + 6.0, guess.cy - 4.0);
    guess.dist[1] -= 0.05;
    let from_guess = Free { held: hold_k(1) | HOLD_FOCAL, ..Free::default() };
    let g = calibrate_camera_guided(&obj, &exact, w, h, from_guess, Some(&guess)).unwrap();
    assert_eq!((g.dist[0], g.fx, g.fy), (guess.dist[0], guess.fx, guess.fy));
    assert!(g.rms_px > 1e-3, "a wrong held k1 must leave a residual, RMS {}", g.rms_px);
    // The same with the true k1: the free terms go back to the truth.
    let mut right_k1 = guess;
    right_k1.dist[0] = truth.cam.dist[0];
    let g = calibrate_camera_guided(&obj, &exact, w, h, from_guess, Some(&right_k1)).unwrap();
    assert!((g.cx - truth.cam.cx).abs() < 1e-6 && (g.dist[1] - truth.cam.dist[1]).abs() < 1e-9 && g.rms_px < 1e-9, "{g:?}");

    // Noisy corners: the constrained fit's minimum lies above the free fit's.
    let noisy = views(&truth, 0.3);
    let free = calibrate_camera_guided(&obj, &noisy, w, h, Free::default(), None).unwrap();
    let c = calibrate_camera_guided(&obj, &noisy, w, h, held, None).unwrap();
    assert!(c.rms_px >= free.rms_px && c.rms_px < 1.01 * free.rms_px, "{} vs {}", c.rms_px, free.rms_px);
    assert_eq!((c.cx, c.cy), (truth.cam.cx, truth.cam.cy));
    assert!((c.fx / c.fy - ratio).abs() < 1e-15 * ratio);
}

/// OpenCV's `CALIB_SAME_FOCAL_LENGTH` (`Free::same_focal`): a pair whose two devices share fx and
/// fy is recovered to 1e-9 with the tie, which holds exactly; with the tie on a pair whose focal
/// lengths differ, the fit cannot reach a zero residual.
#[test]
fn same_focal_length_ties_the_pair() {
    use scan::calib::bundle::Free;
    use scan::calib::calibrate_corners_with;
    let mut truth = rig(true);
    let proj = truth.proj.as_mut().unwrap();
    (proj.fx, proj.fy) = (truth.cam.fx, truth.cam.fy);
    let caps = |s: &State| -> Vec<CaptureCorners> { observe(s, &board()).into_iter().enumerate().map(|(i, v)| CaptureCorners { name: format!("c{i}"), cam: v.cam, proj: v.proj }).collect() };
    let tied = Free { same_focal: true, ..Free::default() };
    let c = calibrate_corners_with(&RIG, &caps(&truth), None, tied).unwrap();
    assert_eq!((c.projector.fx, c.projector.fy), (c.camera.fx, c.camera.fy));
    assert!(rel(c.camera.fx, truth.cam.fx, truth.cam.fx) < 1e-9 && rel(c.projector.cx, truth.proj.unwrap().cx, truth.cam.fx) < 1e-9 && c.rms_px < 1e-9, "{c:?}");
    let c = calibrate_corners_with(&RIG, &caps(&rig(true)), None, tied).unwrap();
    assert_eq!((c.projector.fx, c.projector.fy), (c.camera.fx, c.camera.fy));
    assert!(c.rms_px > 0.1, "RMS {}", c.rms_px);
}

/// x/z and y/z keep their values when a point and a focal length change sign together: turning
/// the second device by π about its y axis, with fy → −fy and p1 → −p1, reprojects every corner
/// exactly, with the board behind it. The fit refuses such a state (an extrinsic guess about π
/// off leads there), and accepts the true rig from the same views.
#[test]
fn a_mirror_image_of_the_rig_is_refused() {
    use scan::calib::bundle::{refine, Free};
    use scan::calib::model::Pose;
    let truth = rig(true);
    let obj = board();
    let views = observe(&truth, &obj);
    let turn = Pose { rvec: Vector3::new(0.0, std::f64::consts::PI, 0.0), t: Vector3::zeros() };
    let mut mirror = truth.clone();
    mirror.stereo = turn.after(&truth.stereo);
    let mut proj = truth.proj.unwrap();
    proj.fy = -proj.fy;
    proj.dist[2] = -proj.dist[2];
    mirror.proj = Some(proj);
    // The mirror reprojects as well as the truth.
    let (e_true, e_mirror) = (rms(&obj, &views, &truth).all, rms(&obj, &views, &mirror).all);
    assert!(e_true < 1e-9 && e_mirror < 1e-9, "RMS {e_true:e}, {e_mirror:e}");
    let err = refine(&obj, &views, &mirror, Free::default(), 1.0).unwrap_err().to_string();
    assert!(err.contains("mirror image") && err.contains("second device"), "{err}");
    // From the true rig, the same views give it back.
    let fit = refine(&obj, &views, &truth, Free::default(), 1.0).unwrap();
    assert!(rms(&obj, &views, &fit).all < 1e-9);
}
