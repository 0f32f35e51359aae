//! Calibration on the real captures (kamino410/procam-calibration sample data, three views of a
//! 9 × 7 board with 75-unit squares in front of a 1024 × 768 projector and a 1280 × 1024 camera).

use crate::common::sample_capture;
use scan::calib::{calibrate_corners_from, calibrate_dirs, CalibrateOptions, Rig};

const RIG: Rig = Rig { cols: 9, rows: 7, square: 75.0, camera: (0, 0), projector: (1024, 768) };

#[test]
fn real_captures_calibrate_below_the_stereo_rms_target_and_leave_one_out_is_reported() {
    let dirs: Vec<_> = (0..3).map(sample_capture).collect();
    let t = std::time::Instant::now();
    let (c, caps) = calibrate_dirs(&dirs, &RIG, &CalibrateOptions::default(), &|| {}).unwrap();
    let secs = t.elapsed().as_secs_f64();
    // The board is found in all three (63 corners each, inside the image).
    assert_eq!(caps.len(), 3);
    for cap in &caps {
        assert_eq!(cap.cam.len(), 63);
        assert!(cap.cam.iter().all(|p| p[0] > 0.0 && p[0] < 1279.0 && p[1] > 0.0 && p[1] < 1023.0));
        assert!(cap.proj.iter().all(|p| p[0] > -0.5 && p[0] < 1023.5 && p[1] > -0.5 && p[1] < 767.5), "{}", cap.name);
    }
    eprintln!("calibration of 3 captures (decode included): {secs:.2} s");
    eprintln!("{}", serde_json::to_string_pretty(&c).unwrap());
    // The target of the structured-light calibration: stereo reprojection RMS ≤ 0.6 px.
    assert!(c.rms_px <= 0.6, "stereo RMS {} px", c.rms_px);
    assert!(c.camera.rms_px <= 0.6 && c.projector.rms_px <= 0.6);
    // The captures are about 1 m (≈ 13 squares … 40 squares) in front of the camera.
    for p in &c.captures {
        assert!(p.tvec[2] > 500.0 && p.tvec[2] < 5000.0, "{p:?}");
    }
    // Leave one out: refit from the other two, started from the three-capture result.
    for k in 0..3 {
        let rest: Vec<_> = caps.iter().enumerate().filter(|(i, _)| *i != k).map(|(_, c)| c.clone()).collect();
        let l = calibrate_corners_from(&Rig { camera: (1280, 1024), ..RIG }, &rest, Some(&c)).unwrap();
        eprintln!(
            "without capture_{k}: camera fx {:.1} fy {:.1} cx {:.1} cy {:.1} | projector fx {:.1} fy {:.1} cx {:.1} cy {:.1} | |T| {:.2} | RMS {:.3}",
            l.camera.fx, l.camera.fy, l.camera.cx, l.camera.cy, l.projector.fx, l.projector.fy, l.projector.cx, l.projector.cy,
            l.translation.iter().map(|x| x * x).sum::<f64>().sqrt(), l.rms_px
        );
        assert!(l.rms_px <= c.rms_px * 1.5 + 0.05);
    }
}

/// A board partly outside the projector's throw: capture_0's decoded map is blanked right of
/// camera column 700 (as if the projector did not reach there; its white frame still shows the
/// whole board), so the corners there have no projector position. The calibration then uses
/// them for the camera only and agrees with the full one: intrinsics within 1 % of fx, the
/// stereo translation within 3 % of |T|; the capture reports how many corners it had.
#[test]
fn a_board_partly_outside_the_projector_still_calibrates() {
    use scan::calib::{calibrate_corners, capture_corners, chessboard, procam, CaptureCorners};
    use scan::graycode::PatternSet;
    let opts = CalibrateOptions::default();
    let rig = Rig { camera: (1280, 1024), ..RIG };
    let dirs: Vec<_> = (0..3).map(sample_capture).collect();
    let full: Vec<CaptureCorners> = dirs.iter().map(|d| capture_corners(d, &rig, &opts, &|| {}).unwrap()).collect();
    let reference = calibrate_corners(&rig, &full).unwrap();

    let patterns = PatternSet::new(1024, 768, 1).unwrap();
    let (mut map, _) = scan::decode::decode_dir(&dirs[0], &patterns, &opts.decode, &|| {}).unwrap();
    for y in 0..map.height {
        for x in 700..map.width {
            map.col[y * map.width + x] = f32::NAN;
            map.row[y * map.width + x] = f32::NAN;
        }
    }
    let img = chessboard::GrayImage { width: map.width, height: map.height, data: map.white.clone() };
    let cam = chessboard::find_chessboard_named(&img, 9, 7, "capture_0").unwrap();
    let proj = procam::projector_corners(&map, &cam, &opts.local, "capture_0").unwrap();
    let kept = proj.iter().filter(|p| p[0].is_finite()).count();
    let beyond = cam.iter().filter(|c| c[0] > 700.0 - 23.0).count();
    assert!(kept < 63 && kept >= 63 - beyond, "{kept} corners kept, {beyond} near or right of the cut");
    let mut caps = full.clone();
    caps[0] = CaptureCorners { name: "capture_0 (cut)".into(), cam, proj };
    let c = calibrate_corners(&rig, &caps).unwrap();
    eprintln!("cut capture_0: {kept} of 63 projector corners; projector fx {:.1} (full {:.1}), |T| {:.1} (full {:.1}), RMS {:.3}",
        c.projector.fx, reference.projector.fx,
        c.translation.iter().map(|x| x * x).sum::<f64>().sqrt(), reference.translation.iter().map(|x| x * x).sum::<f64>().sqrt(), c.rms_px);
    assert_eq!(c.captures[0].projector_corners, kept);
    assert_eq!(c.captures[1].projector_corners, 63);
    for (got, want) in [(&c.camera, &reference.camera), (&c.projector, &reference.projector)] {
        for (g, w) in [(got.fx, want.fx), (got.fy, want.fy), (got.cx, want.cx), (got.cy, want.cy)] {
            assert!((g - w).abs() < 0.01 * want.fx, "{g} against {w}");
        }
    }
    let dt: f64 = c.translation.iter().zip(&reference.translation).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
    let t: f64 = reference.translation.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(dt < 0.03 * t, "|ΔT| {dt} of {t}");
    assert!(c.rms_px <= 0.6);
}
