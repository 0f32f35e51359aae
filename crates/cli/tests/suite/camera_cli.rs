//! `lucent render SCENE --camera CALIB`: a calibration (lucent JSON or OpenCV FileStorage YAML)
//! replaces the scene's camera — the output has the calibration's size and a small emissive
//! sphere lands where OpenCV's projection formula (written out here) puts its centre — and bad
//! calibrations fail on one line naming the file and the node.

use std::path::Path;

use render::image_io::read_image;

use crate::common::{run, Scratch};

/// A black scene with one small emissive sphere at `c` (metres), radius `r`, and a pinhole camera
/// that does not see it (so only the calibrated view can).
fn scene(c: [f64; 3], r: f64) -> String {
    format!(
        "[camera]\neye = [0, 0, -5]\nlook_at = [0, 0, -10]\nup = [0, 1, 0]\nvfov_deg = 30\nwidth = 16\nheight = 16\n\
         [materials.k]\ntype = \"black\"\n\
         [[objects]]\nname = \"dot\"\nmaterial = \"k\"\nsphere = {{ center = [{}, {}, {}], radius = {r} }}\n\
         [[lights]]\ntype = \"area\"\nobject = \"dot\"\nradiance = 1\n",
        c[0], c[1], c[2]
    )
}

/// OpenCV's projection (calib3d): camera coordinates R·X + t, normalised, distorted by k1, k2,
/// p1, p2, k3, then u = fx x″ + cx, v = fy y″ + cy (pixel centres at integers).
fn opencv_project(x: [f64; 3], rm: [[f64; 3]; 3], t: [f64; 3], k: [f64; 4], d: [f64; 5]) -> [f64; 2] {
    let c: Vec<f64> = (0..3).map(|i| rm[i][0] * x[0] + rm[i][1] * x[1] + rm[i][2] * x[2] + t[i]).collect();
    let (xp, yp) = (c[0] / c[2], c[1] / c[2]);
    let r2 = xp * xp + yp * yp;
    let [k1, k2, p1, p2, k3] = d;
    let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
    let xpp = xp * radial + 2.0 * p1 * xp * yp + p2 * (r2 + 2.0 * xp * xp);
    let ypp = yp * radial + p1 * (r2 + 2.0 * yp * yp) + 2.0 * p2 * xp * yp;
    [k[0] * xpp + k[2], k[1] * ypp + k[3]]
}

/// Renders `scene.toml` in `dir` with the calibration flags `calib`, and returns the image size
/// and the brightness centroid in OpenCV pixel coordinates (pixel (i, j) centred at (i, j)).
fn render_centroid(dir: &Path, calib: &[&str]) -> ((u32, u32), [f64; 2]) {
    let mut args = vec!["render", "scene.toml", "--spp", "256", "--seed", "5", "--max-depth", "1", "--threads", "1", "--quiet", "--out", "out.pfm"];
    args.extend_from_slice(calib);
    let out = run(dir, &args);
    assert!(out.status.success(), "lucent {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    let img = read_image(&dir.join("out.pfm")).unwrap();
    let (mut s, mut su, mut sv) = (0.0f64, 0.0f64, 0.0f64);
    for j in 0..img.height {
        for i in 0..img.width {
            let p = img.get(i, j);
            let w = (p[0] + p[1] + p[2]) as f64;
            s += w;
            su += w * i as f64;
            sv += w * j as f64;
        }
    }
    assert!(s > 0.0, "the calibrated view does not see the sphere");
    ((img.width, img.height), [su / s, sv / s])
}

#[test]
fn render_camera_calibration_replaces_the_view() {
    let t = Scratch::new("calib-view");
    let c = [0.9, 0.6, 3.0];
    std::fs::write(t.path("scene.toml"), scene(c, 0.05)).unwrap();
    // A rotation about y by 0.1 rad and a translation, as OpenCV's R, t (world → camera).
    let (sn, cs) = (0.1f64.sin(), 0.1f64.cos());
    let rm = [[cs, 0.0, -sn], [0.0, 1.0, 0.0], [sn, 0.0, cs]];
    let tv = [0.25, -0.1, 0.2];
    let k = [61.0, 60.2, 23.3, 17.6];
    let d = [-0.1, 0.02, 0.001, -0.0015, 0.0];
    let mat = |m: [[f64; 3]; 3]| format!("[[{}, {}, {}], [{}, {}, {}], [{}, {}, {}]]", m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2]);
    let json = format!(
        "{{\"width\": 48, \"height\": 36, \"fx\": {}, \"fy\": {}, \"cx\": {}, \"cy\": {}, \"dist\": [{}, {}, {}, {}, {}], \"R\": {}, \"t\": [{}, {}, {}]}}",
        k[0], k[1], k[2], k[3], d[0], d[1], d[2], d[3], d[4], mat(rm), tv[0], tv[1], tv[2]
    );
    std::fs::write(t.path("calib.json"), json).unwrap();
    let expect = opencv_project(c, rm, tv, k, d);
    let (size, got) = render_centroid(&t.0, &["--camera", "calib.json"]);
    assert_eq!(size, (48, 36), "the output has the calibration's size");
    let err = ((got[0] - expect[0]).powi(2) + (got[1] - expect[1]).powi(2)).sqrt();
    eprintln!("JSON calibration: centroid ({:.3}, {:.3}) vs OpenCV ({:.3}, {:.3}): {err:.3} px", got[0], got[1], expect[0], expect[1]);
    assert!(err < 0.1, "centroid {got:?} vs projected {expect:?}");

    // The same camera as an OpenCV FileStorage YAML with another image size and named nodes.
    let yml = format!(
        "%YAML:1.0\n---\nimage_width: 40\nimage_height: 30\nK: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {}, 0., {}, 0., {}, {}, 0., 0., 1. ]\n\
         D: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ {}, {}, {}, {}, {} ]\n\
         R: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {}, {}, {}, {}, {}, {}, {}, {}, {} ]\n\
         t: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n   data: [ {}, {}, {} ]\n",
        k[0], k[2] - 4.0, k[1], k[3] - 3.0, d[0], d[1], d[2], d[3], d[4],
        rm[0][0], rm[0][1], rm[0][2], rm[1][0], rm[1][1], rm[1][2], rm[2][0], rm[2][1], rm[2][2], tv[0], tv[1], tv[2]
    );
    std::fs::write(t.path("calib.yml"), yml).unwrap();
    let (size, got) = render_centroid(&t.0, &["--camera", "calib.yml", "--camera-matrix-node", "K", "--camera-dist-node", "D"]);
    assert_eq!(size, (40, 30), "the output has the YAML calibration's size");
    let expect = opencv_project(c, rm, tv, [k[0], k[1], k[2] - 4.0, k[3] - 3.0], d);
    let err = ((got[0] - expect[0]).powi(2) + (got[1] - expect[1]).powi(2)).sqrt();
    eprintln!("YAML calibration: centroid ({:.3}, {:.3}) vs OpenCV ({:.3}, {:.3}): {err:.3} px", got[0], got[1], expect[0], expect[1]);
    assert!(err < 0.1, "centroid {got:?} vs projected {expect:?}");
}

#[test]
fn bad_camera_calibrations_fail_on_one_line_naming_file_and_node() {
    let t = Scratch::new("calib-bad");
    std::fs::write(t.path("scene.toml"), scene([0.0, 0.0, 3.0], 0.1)).unwrap();
    let good = "%YAML:1.0\n---\nimage_width: 40\nimage_height: 30\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 40., 0., 19.5, 0., 40., 14.5, 0., 0., 1. ]\n\
                distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n";
    std::fs::write(t.path("good.yml"), good).unwrap();
    // Barrel distortion so strong that the radial map folds over inside the image.
    std::fs::write(t.path("fold.json"), "{\"width\": 40, \"height\": 30, \"fx\": 20, \"fy\": 20, \"cx\": 19.5, \"cy\": 14.5, \"dist\": [-1.5, 0, 0, 0, 0]}").unwrap();
    let cases: [(&[&str], &[&str]); 4] = [
        (&["--camera", "good.yml", "--camera-matrix-node", "K"], &["good.yml", "K", "no such node"]),
        (&["--camera", "good.yml", "--camera-dist-node", "dist"], &["good.yml", "dist", "no such node"]),
        (&["--camera", "missing.yml"], &["missing.yml"]),
        (&["--camera", "fold.json"], &["fold.json", "not invertible"]),
    ];
    for (extra, needles) in cases {
        let mut args = vec!["render", "scene.toml", "--spp", "1", "--quiet", "--out", "x.pfm"];
        args.extend_from_slice(extra);
        let out = run(&t.0, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{extra:?} succeeded");
        assert_eq!(err.trim_end().lines().count(), 1, "{extra:?}: not one line: {err}");
        for n in needles {
            assert!(err.contains(n), "{extra:?}: `{}` does not mention `{n}`", err.trim_end());
        }
        assert!(!err.contains("panicked"), "{err}");
        assert!(!t.path("x.pfm").exists(), "a failed run wrote its output");
    }
}
