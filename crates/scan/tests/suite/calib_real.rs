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
