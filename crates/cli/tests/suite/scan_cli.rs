//! `lucent scan …`: the command-line contract (names, flags, JSON keys) and bad input.

use std::path::{Path, PathBuf};

use render::image_io::read_image;

use crate::common::{fails_on_one_line, lucent, ok_json, Scratch};

fn sample_capture(i: usize) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../../shared/data/structured-light/procam-sample/capture_{i}"))
}

/// The patterns of a small projector written by `scan patterns`, renamed as a capture, decode to
/// every projector pixel exactly (camera = projector image) through `scan decode --out`.
#[test]
fn patterns_then_decode_round_trip_through_the_command() {
    let s = Scratch::new("scan-roundtrip");
    let v = ok_json(&["scan", "patterns", "--projector", "40x24", "--out", &s.arg("pat"), "--json"]);
    assert_eq!((v["width"].as_u64(), v["height"].as_u64(), v["column_bits"].as_u64(), v["row_bits"].as_u64()), (Some(40), Some(24), Some(6), Some(5)));
    assert_eq!(v["images"].as_u64(), Some(24));
    let cap = s.path("cap");
    std::fs::create_dir_all(&cap).unwrap();
    for i in 0..24 {
        let name = format!("pattern_{i:02}.png");
        assert!(s.path("pat").join(&name).is_file(), "{name}");
        std::fs::copy(s.path("pat").join(&name), cap.join(format!("graycode_{i:02}.png"))).unwrap();
    }
    assert!(!s.path("pat").join("pattern_24.png").exists());
    // Frame 0 lights the right half.
    let f0 = read_image(&s.path("pat").join("pattern_00.png")).unwrap();
    assert_eq!((f0.get(31, 3)[0], f0.get(32, 3)[0]), (0.0, 1.0));
    let map = s.path("map.exr");
    let v = ok_json(&["scan", "decode", &s.arg("cap"), "--projector", "40x24", "--out", &s.arg("map.exr"), "--json"]);
    assert_eq!((v["width"].as_u64(), v["height"].as_u64(), v["valid_pixels"].as_u64()), (Some(40), Some(24), Some(960)));
    assert_eq!(v["valid_fraction"].as_f64(), Some(1.0));
    let img = read_image(&map).unwrap();
    for y in 0..24 {
        for x in 0..40 {
            let p = img.get(x, y);
            assert_eq!((p[0], p[1], p[2]), (x as f32, y as f32, 1.0), "({x}, {y})");
        }
    }
    // With a step, decoding needs the same step: 40x24 step 3 has 14 × 8 codes, 4 + 3 bits.
    let v = ok_json(&["scan", "patterns", "--projector", "40x24", "--step", "3", "--out", &s.arg("pat3"), "--json"]);
    assert_eq!((v["column_bits"].as_u64(), v["row_bits"].as_u64(), v["images"].as_u64()), (Some(4), Some(3), Some(16)));
}

/// The shared real capture: the JSON contract keys, and a valid fraction covering the lit board.
#[test]
fn decode_real_capture_json_contract() {
    let cap = sample_capture(0);
    let v = ok_json(&["scan", "decode", cap.to_str().unwrap(), "--projector", "1024x768", "--black-threshold", "40", "--white-threshold", "5", "--json"]);
    assert_eq!((v["width"].as_u64(), v["height"].as_u64()), (Some(1280), Some(1024)));
    let frac = v["valid_fraction"].as_f64().unwrap();
    assert!((0.45..0.65).contains(&frac), "{frac}");
    assert_eq!(v["valid_pixels"].as_u64().unwrap(), (frac * 1280.0 * 1024.0).round() as u64);
    // A higher black threshold can only remove pixels.
    let v2 = ok_json(&["scan", "decode", cap.to_str().unwrap(), "--projector", "1024x768", "--black-threshold", "100", "--json"]);
    assert!(v2["valid_pixels"].as_u64() < v["valid_pixels"].as_u64());
}

/// The shared capture with its white and black frames moved first (as some capture tools save
/// them), in natural-order file names: `--white-black first` decodes it to the same map, bit for
/// bit, as the capture in its own order; without the flag a warning names the other order.
#[test]
fn decode_white_and_black_first() {
    let s = Scratch::new("scan-white-first");
    let cap = s.path("cap");
    std::fs::create_dir_all(&cap).unwrap();
    for i in 0..42 {
        let to = (i + 2) % 42;
        std::fs::copy(sample_capture(0).join(format!("graycode_{i:02}.png")), cap.join(format!("{to}.png"))).unwrap();
    }
    let want = ok_json(&["scan", "decode", sample_capture(0).to_str().unwrap(), "--projector", "1024x768", "--out", &s.arg("want.pfm"), "--json"]);
    let got = ok_json(&["scan", "decode", &s.arg("cap"), "--projector", "1024x768", "--white-black", "first", "--out", &s.arg("got.pfm"), "--json"]);
    assert_eq!(want, got);
    assert_eq!(std::fs::read(s.path("want.pfm")).unwrap(), std::fs::read(s.path("got.pfm")).unwrap());
    let out = lucent().args(["scan", "decode", &s.arg("cap"), "--projector", "1024x768", "--json"]).output().unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("warning") && err.contains("--white-black first"), "{err}");
}

/// The three shared captures with their white and black frames moved first (symbolic links):
/// `scan calibrate` without `--white-black first` fails on one line that names the flag, and
/// with it gives the calibration of the captures in their own order.
#[test]
fn calibrate_names_the_frame_order_when_it_fails() {
    let s = Scratch::new("scan-calib-order");
    let mut moved = Vec::new();
    for c in 0..3 {
        let dir = s.path(&format!("capture_{c}"));
        std::fs::create_dir_all(&dir).unwrap();
        for i in 0..42 {
            let from = sample_capture(c).join(format!("graycode_{i:02}.png")).canonicalize().unwrap();
            std::os::unix::fs::symlink(from, dir.join(format!("graycode_{:02}.png", (i + 2) % 42))).unwrap();
        }
        moved.push(dir.display().to_string());
    }
    let originals: Vec<String> = (0..3).map(|c| sample_capture(c).display().to_string()).collect();
    let tail = ["--projector", "1024x768", "--corners", "9x7", "--square", "75", "--fix-k3"];
    let args = |caps: &[String], extra: &[&'static str]| -> Vec<String> {
        let mut v: Vec<String> = ["scan", "calibrate"].iter().map(|a| a.to_string()).collect();
        v.extend(caps.iter().cloned());
        v.extend(tail.iter().chain(extra).map(|a| a.to_string()));
        v
    };
    let a = args(&moved, &[]);
    let e = fails_on_one_line(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(e.contains("the frames may be in another order") && e.contains("--white-black first"), "{e}");
    let want = ok_json(&args(&originals, &["--json"]).iter().map(String::as_str).collect::<Vec<_>>());
    let got = ok_json(&args(&moved, &["--white-black", "first", "--json"]).iter().map(String::as_str).collect::<Vec<_>>());
    for key in ["camera", "projector", "rotation", "translation", "rms_px"] {
        assert_eq!(got[key], want[key], "{key}");
    }
}

#[test]
fn scan_bad_input_fails_on_one_line_without_output() {
    let s = Scratch::new("scan-bad");
    let cap0 = sample_capture(0);
    let cap0 = cap0.to_str().unwrap();
    let e = fails_on_one_line(&["scan", "decode", cap0, "--projector", "1024by768"]);
    assert!(e.contains("1024by768"), "{e}");
    let e = fails_on_one_line(&["scan", "patterns", "--projector", "0x768", "--out", &s.arg("p")]);
    assert!(e.contains("0x768"), "{e}");
    let e = fails_on_one_line(&["scan", "patterns", "--projector", "64x48", "--step", "0", "--out", &s.arg("p")]);
    assert!(e.contains("step"), "{e}");
    // The wrong projector size: the frame count does not match; the file past the sequence is named.
    let e = fails_on_one_line(&["scan", "decode", cap0, "--projector", "512x768", "--out", &s.arg("m.exr")]);
    assert!(e.contains("graycode_") && e.contains("extra"), "{e}");
    assert!(!s.path("m.exr").exists());
    let e = fails_on_one_line(&["scan", "decode", cap0, "--projector", "1024x768", "--out", &s.arg("m.png")]);
    assert!(e.contains("m.png"), "{e}");
    assert!(!s.path("m.png").exists());
    let e = fails_on_one_line(&["scan", "decode", &s.arg("nowhere"), "--projector", "1024x768"]);
    assert!(e.contains("nowhere"), "{e}");
    // A missing frame and a frame of another size.
    let cap = s.path("cap");
    std::fs::create_dir_all(&cap).unwrap();
    lucent().args(["scan", "patterns", "--projector", "16x8", "--out", &s.arg("pat")]).output().unwrap();
    for i in 0..16 {
        std::fs::copy(s.path("pat").join(format!("pattern_{i:02}.png")), cap.join(format!("graycode_{i:02}.png"))).unwrap();
    }
    std::fs::remove_file(cap.join("graycode_09.png")).unwrap();
    let e = fails_on_one_line(&["scan", "decode", &s.arg("cap"), "--projector", "16x8"]);
    assert!(e.contains("graycode_09.png") && e.contains("missing"), "{e}");
    std::fs::copy(s.path("pat").join("pattern_09.png"), cap.join("graycode_09.png")).unwrap();
    // An extra frame past the sequence of 16.
    std::fs::copy(s.path("pat").join("pattern_09.png"), cap.join("graycode_16.png")).unwrap();
    let e = fails_on_one_line(&["scan", "decode", &s.arg("cap"), "--projector", "16x8", "--out", &s.arg("m.exr")]);
    assert!(e.contains("graycode_16.png") && e.contains("extra"), "{e}");
    assert!(!s.path("m.exr").exists());
    std::fs::remove_file(cap.join("graycode_16.png")).unwrap();
    lucent().args(["scan", "patterns", "--projector", "16x9", "--out", &s.arg("pat9")]).output().unwrap();
    std::fs::copy(s.path("pat9").join("pattern_04.png"), cap.join("graycode_04.png")).unwrap();
    let e = fails_on_one_line(&["scan", "decode", &s.arg("cap"), "--projector", "16x8", "--out", &s.arg("m.exr")]);
    assert!(e.contains("graycode_04.png") && e.contains("16x9"), "{e}");
    assert!(!s.path("m.exr").exists());
}

/// A synthetic rig (camera 160×120, projector 128×96 to its right) as calibration JSON.
fn synthetic_calibration() -> scan::calib::ProcamCalibration {
    use scan::calib::{DeviceCalibration, ProcamCalibration};
    let dev = |width, height, fx, fy, cx, cy, distortion: Vec<f64>| DeviceCalibration { width, height, fx, fy, cx, cy, distortion, rms_px: 0.0 };
    let a = 10f64.to_radians();
    let rotation = [[a.cos(), 0.0, a.sin()], [0.0, 1.0, 0.0], [-a.sin(), 0.0, a.cos()]];
    let c = [0.25, 0.0, 0.02];
    let translation = [0, 1, 2].map(|i| -(rotation[i][0] * c[0] + rotation[i][1] * c[1] + rotation[i][2] * c[2]));
    ProcamCalibration {
        camera: dev(160, 120, 200.0, 200.0, 79.5, 59.5, vec![-0.05, 0.01, 0.0, 0.0, 0.0]),
        projector: dev(128, 96, 170.0, 170.0, 63.5, 47.5, vec![0.0; 5]),
        rotation,
        translation,
        rms_px: 0.0,
        captures: Vec::new(),
    }
}

/// `calib` as OpenCV FileStorage in the form of procam-calibration's `calibration_result.xml`
/// (kamino410/procam-calibration `calibrate.py`: `img_shape` [rows, cols], `rms`, `cam_int`,
/// `cam_dist`, `proj_int`, `proj_dist`, `roration`, `translation`), as XML or as YAML.
fn procam_calibration_filestorage(c: &scan::calib::ProcamCalibration, yaml: bool) -> String {
    let k = |d: &scan::calib::DeviceCalibration| vec![d.fx, 0.0, d.cx, 0.0, d.fy, d.cy, 0.0, 0.0, 1.0];
    let rot: Vec<f64> = c.rotation.iter().flatten().copied().collect();
    let nodes: [(&str, usize, usize, Vec<f64>); 7] = [
        ("img_shape", 2, 1, vec![c.camera.height as f64, c.camera.width as f64]),
        ("cam_int", 3, 3, k(&c.camera)),
        ("cam_dist", 1, c.camera.distortion.len(), c.camera.distortion.clone()),
        ("proj_int", 3, 3, k(&c.projector)),
        ("proj_dist", 1, c.projector.distortion.len(), c.projector.distortion.clone()),
        ("roration", 3, 3, rot),
        ("translation", 3, 1, c.translation.to_vec()),
    ];
    let num = |x: &f64| format!("{x:.17e}");
    let mut out = String::new();
    if yaml {
        out.push_str("%YAML:1.0\n---\n");
        for (i, (n, r, cols, d)) in nodes.iter().enumerate() {
            out.push_str(&format!("{n}: !!opencv-matrix\n   rows: {r}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n", d.iter().map(num).collect::<Vec<_>>().join(", ")));
            if i == 0 {
                out.push_str("rms: 4.2e-01\n");
            }
        }
    } else {
        out.push_str("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
        for (i, (n, r, cols, d)) in nodes.iter().enumerate() {
            out.push_str(&format!("<{n} type_id=\"opencv-matrix\">\n  <rows>{r}</rows>\n  <cols>{cols}</cols>\n  <dt>d</dt>\n  <data>\n    {}</data></{n}>\n", d.iter().map(num).collect::<Vec<_>>().join(" ")));
            if i == 0 {
                out.push_str("<rms>4.2e-01</rms>\n");
            }
        }
        out.push_str("</opencv_storage>\n");
    }
    out
}

/// Renders the Gray-code capture of the plane z = 1 − 0.2·x seen by the synthetic rig (each camera
/// pixel centre sees one projector pixel; lit 220, dark 20 grey levels) and reconstructs it:
/// the JSON contract, points on the plane within the projector-pixel quantisation, PLY files.
#[test]
fn reconstruct_a_rendered_plane_through_the_command() {
    use scan::graycode::PatternSet;
    use scan::triangulate::Rig;
    let s = Scratch::new("scan-reconstruct");
    let calib = synthetic_calibration();
    std::fs::write(s.path("calib.json"), serde_json::to_string_pretty(&calib).unwrap()).unwrap();
    let rig = Rig::new(&calib).unwrap();
    let patterns = PatternSet::new(128, 96, 1).unwrap();
    let cam = {
        use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};
        let k = &calib.camera;
        let id = Extrinsics::from_rt([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]).unwrap();
        OpenCv::new(Intrinsics { fx: k.fx, fy: k.fy, cx: k.cx, cy: k.cy }, Distortion::from_opencv(&k.distortion).unwrap(), id, 160, 120).unwrap()
    };
    // Plane n·X = d with n = (0.2, 0, 1)/|…|, i.e. z = 1 − 0.2 x.
    let l = (1.0f64 + 0.04).sqrt();
    let (n, d) = ([0.2 / l, 0.0, 1.0 / l], 1.0 / l);
    let mut proj_px = vec![None; 160 * 120];
    for y in 0..120 {
        for x in 0..160 {
            let (_, dir) = cam.ray_pixel(x as f64, y as f64);
            let t = d / (n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2]);
            let (_, p) = rig.project([t * dir[0], t * dir[1], t * dir[2]]).unwrap();
            let (u, v) = (p[0].round(), p[1].round());
            if (0.0..128.0).contains(&u) && (0.0..96.0).contains(&v) {
                proj_px[y * 160 + x] = Some((u as u32, v as u32));
            }
        }
    }
    let cap = s.path("cap");
    std::fs::create_dir_all(&cap).unwrap();
    for i in 0..patterns.len() {
        let frame = patterns.frame(i).unwrap();
        let pixels: Vec<u8> = proj_px.iter().map(|p| p.map_or(20, |(u, v)| if patterns.lit(frame, u, v) { 220 } else { 20 })).collect();
        image::GrayImage::from_raw(160, 120, pixels).unwrap().save(cap.join(format!("graycode_{i:02}.png"))).unwrap();
    }
    let lit = proj_px.iter().filter(|p| p.is_some()).count();
    let v = ok_json(&["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg("calib.json"), "--out", &s.arg("points.ply"), "--mesh", &s.arg("mesh.ply"), "--json"]);
    let points = v["points"].as_u64().unwrap() as usize;
    assert_eq!(points, lit);
    let (lo, hi) = (&v["bbox"]["min"], &v["bbox"]["max"]);
    assert!(lo[2].as_f64().unwrap() > 0.8 && hi[2].as_f64().unwrap() < 1.2, "{v}");
    let gap = v["median_ray_gap"].as_f64().unwrap();
    assert!(gap < 0.005, "{gap}");
    assert!(v["triangles"].as_u64().unwrap() as usize > points);
    // Points on the plane: read the PLY back with the renderer's loader (mesh file) and measure.
    let mesh = render::shape::mesh::parse_ply(&std::fs::read(s.path("mesh.ply")).unwrap()).unwrap();
    let mut sum = 0.0;
    for p in &mesh.positions {
        let e = n[0] * p.x as f64 + n[1] * p.y as f64 + n[2] * p.z as f64 - d;
        sum += e * e;
    }
    let rms = (sum / mesh.positions.len() as f64).sqrt();
    // One projector pixel at z ≈ 1 with a 0.25 baseline and f = 170 px is ≈ 0.024 in depth;
    // integer decoding would give ≈ 0.29 of that (≈ 0.007); nearest-sampled frames put every
    // zero crossing half-way between pixels, so refinement gains less than on real blur.
    eprintln!("plane RMS {rms:.5}, median ray gap {gap:.5}");
    assert!(rms < 0.005, "{rms}");
    assert!(s.path("points.ply").is_file());
    // The same calibration as procam-calibration's OpenCV FileStorage (XML and YAML), with the
    // projector's size on the command line: the same points.
    for (name, yaml) in [("calibration_result.xml", false), ("calibration_result.yml", true)] {
        std::fs::write(s.path(name), procam_calibration_filestorage(&calib, yaml)).unwrap();
        let w = ok_json(&["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg(name), "--projector", "128x96", "--out", &s.arg("fs.ply"), "--json"]);
        assert_eq!(w["points"], v["points"], "{name}");
        for (a, b) in [(&w["bbox"]["min"], lo), (&w["bbox"]["max"], hi)] {
            for i in 0..3 {
                assert!((a[i].as_f64().unwrap() - b[i].as_f64().unwrap()).abs() < 1e-12, "{name}: {w} vs {v}");
            }
        }
        let e = fails_on_one_line(&["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg(name), "--out", &s.arg("p2.ply")]);
        assert!(e.contains(name) && e.contains("--projector"), "{e}");
    }
    let e = fails_on_one_line(&["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg("calib.json"), "--projector", "64x48", "--out", &s.arg("p2.ply")]);
    assert!(e.contains("128x96") && e.contains("64x48"), "{e}");
    // A camera lens that folds inside the image (r(1 + k1 r²) peaks at r_d = 0.3, the corners
    // lie at 0.5, as a fit to a board in the image's centre can give): one warning, and the
    // pixels beyond the fold are skipped, every other lit pixel triangulated.
    let mut folded = calib.clone();
    folded.camera.distortion = vec![-1.0 / (3.0 * 0.45 * 0.45), 0.0, 0.0, 0.0, 0.0];
    std::fs::write(s.path("folded.json"), serde_json::to_string(&folded).unwrap()).unwrap();
    let out = lucent().args(["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg("folded.json"), "--out", &s.arg("f.ply"), "--json"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.lines().count() == 1 && err.contains("warning") && err.contains("folded.json") && err.contains("no ray"), "{err}");
    let f: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let fold = {
        use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};
        let k = &folded.camera;
        OpenCv::unchecked(Intrinsics { fx: k.fx, fy: k.fy, cx: k.cx, cy: k.cy }, Distortion::from_opencv(&k.distortion).unwrap(), Extrinsics::identity()).unwrap()
    };
    let with_ray = (0..160 * 120).filter(|&i| proj_px[i].is_some() && fold.undistort((((i % 160) as f64) - 79.5) / 200.0, (((i / 160) as f64) - 59.5) / 200.0).2).count();
    assert!(with_ray < lit * 8 / 10 && with_ray > lit / 2, "{with_ray} of {lit}");
    // (Triangulation's own fold test, a radial walk, may drop a few more at the fold's edge.)
    let points = f["points"].as_u64().unwrap() as usize;
    assert!(points <= with_ray && points + with_ray / 500 >= with_ray, "{points} points, {with_ray} lit pixels with a ray");
    let broken = procam_calibration_filestorage(&calib, false).replace("<rows>3</rows>\n  <cols>3</cols>\n  <dt>d</dt>\n  <data>\n    1.7", "<rows>2</rows>\n  <cols>3</cols>\n  <dt>d</dt>\n  <data>\n    1.7");
    let broken = broken.replacen("0.00000000000000000e0 1.00000000000000000e0</data></proj_int>", "</data></proj_int>", 1);
    std::fs::write(s.path("broken.xml"), broken).unwrap();
    let e = fails_on_one_line(&["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg("broken.xml"), "--projector", "128x96", "--out", &s.arg("p2.ply")]);
    assert!(e.contains("broken.xml") && e.contains("proj_int"), "{e}");
    // Bad input: a calibration that is not one, a capture of the wrong size, a non-PLY output.
    std::fs::write(s.path("bad.json"), "{\"camera\": 3}").unwrap();
    let e = fails_on_one_line(&["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg("bad.json"), "--out", &s.arg("p2.ply")]);
    assert!(e.contains("bad.json"), "{e}");
    let e = fails_on_one_line(&["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg("calib.json"), "--out", &s.arg("p2.xyz")]);
    assert!(e.contains("p2.xyz"), "{e}");
    let mut wrong = calib.clone();
    wrong.camera.width = 320;
    std::fs::write(s.path("wrong.json"), serde_json::to_string(&wrong).unwrap()).unwrap();
    let e = fails_on_one_line(&["scan", "reconstruct", &s.arg("cap"), "--calibration", &s.arg("wrong.json"), "--out", &s.arg("p2.ply")]);
    assert!(e.contains("160x120") && e.contains("320x120"), "{e}");
    assert!(!s.path("p2.ply").exists());
}

/// `scan calibrate-camera` on the white frames of the three shared captures (chessboard
/// photographs): the camera agrees with the one the projector–camera calibration of the same
/// captures finds (two independent estimates: fx within 0.5 %, principal point within 10 px);
/// the JSON and the FileStorage copy read back as the same camera through the renderer's
/// calibration reader; images of two sizes, a photograph without the board and fewer than 3
/// views are one-line errors with no output; held principal point and aspect ratio stay exact.
#[test]
fn calibrate_camera_agrees_with_the_procam_calibration_and_feeds_the_renderer() {
    use render::load::calibration::{read_calibration, CalibrationNodes};
    let s = Scratch::new("scan-calibrate-camera");
    let whites: Vec<String> = (0..3).map(|i| sample_capture(i).join("graycode_40.png").display().to_string()).collect();
    let caps: Vec<String> = (0..3).map(|i| sample_capture(i).display().to_string()).collect();
    let (json, yml) = (s.arg("camera.json"), s.arg("camera.yml"));
    let mut args: Vec<&str> = vec!["scan", "calibrate-camera"];
    args.extend(whites.iter().map(|c| c.as_str()));
    args.extend(["--corners", "9x7", "--square", "75", "--out", &json, "--opencv-out", &yml, "--json"]);
    let v = ok_json(&args);
    let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(|k| k.as_str()).collect();
    keys.sort();
    assert_eq!(keys, ["cx", "cy", "dist", "fx", "fy", "height", "rms_px", "views", "width"]);
    assert_eq!(v["views"].as_array().unwrap().len(), 3);
    assert!(v["rms_px"].as_f64().unwrap() < 0.6, "RMS {}", v["rms_px"]);
    let mut pargs: Vec<&str> = vec!["scan", "calibrate"];
    pargs.extend(caps.iter().map(|c| c.as_str()));
    pargs.extend(["--projector", "1024x768", "--corners", "9x7", "--square", "75", "--json"]);
    let procam = ok_json(&pargs);
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    assert!((f(&v["fx"]) / f(&procam["camera"]["fx"]) - 1.0).abs() < 0.005, "fx {} vs {}", v["fx"], procam["camera"]["fx"]);
    assert!((f(&v["cx"]) - f(&procam["camera"]["cx"])).abs() < 10.0 && (f(&v["cy"]) - f(&procam["camera"]["cy"])).abs() < 10.0);
    let nodes = CalibrationNodes::default();
    let a = read_calibration(std::path::Path::new(&json), &nodes).unwrap();
    let b = read_calibration(std::path::Path::new(&yml), &nodes).unwrap();
    assert_eq!((a.width, a.height), (Some(1280), Some(1024)));
    assert_eq!((a.intrinsics, a.distortion, a.width, a.height), (b.intrinsics, b.distortion, b.width, b.height));
    assert_eq!(a.intrinsics.fx, f(&v["fx"]));
    // Bad input.
    let other = s.arg("small.png");
    image::GrayImage::new(64, 48).save(&other).unwrap();
    let bad = s.arg("bad.json");
    let e = fails_on_one_line(&["scan", "calibrate-camera", &whites[0], &whites[1], &other, "--corners", "9x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("small.png") && e.contains("64x48"), "{e}");
    let black = sample_capture(0).join("graycode_41.png").display().to_string();
    let e = fails_on_one_line(&["scan", "calibrate-camera", &whites[0], &whites[1], &black, "--corners", "9x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("graycode_41.png") && e.contains("9×7"), "{e}");
    let e = fails_on_one_line(&["scan", "calibrate-camera", &whites[0], &whites[1], "--corners", "9x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("at least 3 views"), "{e}");
    assert!(!s.path("bad.json").exists());
    // --skip-missing leaves the photograph without the board out, with one warning naming it,
    // and calibrates from the rest: the same camera as from the three boards alone.
    let out = lucent().args(["scan", "calibrate-camera", &whites[0], &black, &whites[1], &whites[2], "--corners", "9x7", "--square", "75", "--skip-missing", "--json"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.trim_end().lines().count() == 1 && err.contains("graycode_41.png") && err.contains("skipped"), "{err}");
    let skipped: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(skipped["views"].as_array().unwrap().len(), 3);
    assert_eq!(skipped["fx"], v["fx"]);
    // --fix-principal-point and --aspect-ratio hold what they say; the constrained fit cannot
    // fit better than the free one. A ratio that is not positive is a one-line error.
    let mut held_args = args.clone();
    held_args.retain(|a| !["--out", "--opencv-out", json.as_str(), yml.as_str()].contains(a));
    held_args.extend(["--fix-principal-point", "--aspect-ratio", "1"]);
    let h = ok_json(&held_args);
    assert_eq!((f(&h["cx"]), f(&h["cy"])), (639.5, 511.5));
    assert_eq!(f(&h["fx"]), f(&h["fy"]));
    assert!(f(&h["rms_px"]) >= f(&v["rms_px"]), "{} < {}", h["rms_px"], v["rms_px"]);
    let e = fails_on_one_line(&["scan", "calibrate-camera", &whites[0], &whites[1], &whites[2], "--corners", "9x7", "--square", "75", "--aspect-ratio", "0"]);
    assert!(e.contains("aspect-ratio"), "{e}");
}

/// An 8-bit PNG of OpenCV's asymmetric 4 × 11 circle grid (spacing 10) seen by the pinhole camera
/// `k` with the board turned by `spin` (degrees) about its normal and tilted by `tilt` (radians),
/// its centre 250 units in front of the camera (`lr`: a second camera's pose X' = R X + T, else
/// the identity).
fn grid_photo(path: &str, k: &nalgebra::Matrix3<f64>, spin: f64, tilt: (f64, f64), lr: Option<(nalgebra::Rotation3<f64>, nalgebra::Vector3<f64>)>) {
    use nalgebra::{Matrix3, Rotation3, Vector3};
    use scan::markers::grid::{grid_points, GridKind};
    use scan::markers::synth::FlatTarget;
    let mut rot = Rotation3::from_euler_angles(tilt.0, tilt.1, 0.0) * Rotation3::from_axis_angle(&Vector3::z_axis(), spin.to_radians());
    let mut t = Vector3::new(0.0, 0.0, 250.0) - rot * Vector3::new(35.0, 50.0, 0.0);
    if let Some((r_lr, t_lr)) = lr {
        (rot, t) = (r_lr * rot, r_lr * t + t_lr);
    }
    let r = rot.matrix();
    let h = k * Matrix3::from_columns(&[r.column(0).into_owned(), r.column(1).into_owned(), t]);
    let centres = grid_points(GridKind::Asymmetric, 4, 11, 10.0);
    let img = FlatTarget { homography: h, centres, radius: 2.5, paper: [-10.0, 80.0, -10.0, 110.0], levels: [0.05, 0.7, 0.3], noise: 0.0 }.draw(640, 480).unwrap();
    let bytes: Vec<u8> = img.data.iter().map(|&v| (render::image_io::srgb_encode(v as f64) * 255.0).round() as u8).collect();
    image::GrayImage::from_raw(640, 480, bytes).unwrap().save(path).unwrap();
}

const GRID_POSES: [(f64, (f64, f64)); 4] = [(10.0, (0.35, 0.0)), (100.0, (0.0, 0.4)), (190.0, (-0.4, 0.2)), (260.0, (0.25, -0.35))];

/// `scan calibrate-camera --pattern acircles` (OpenCV's asymmetric circle grid, 4 × 11) on four
/// 8-bit photographs drawn through a known pinhole camera: fx, fy within 0.2 % and the principal
/// point within 1 px; the same photographs asked for as a symmetric grid are a one-line error
/// naming the first photograph and the pattern.
#[test]
fn calibrate_camera_from_asymmetric_circle_grids() {
    let s = Scratch::new("scan-calibrate-circles");
    let k = nalgebra::Matrix3::new(600.0, 0.0, 322.5, 0.0, 598.0, 236.0, 0.0, 0.0, 1.0);
    let files: Vec<String> = (0..GRID_POSES.len()).map(|i| s.arg(&format!("grid{i}.png"))).collect();
    for (f, (spin, tilt)) in files.iter().zip(GRID_POSES) {
        grid_photo(f, &k, spin, tilt, None);
    }
    let mut args: Vec<&str> = vec!["scan", "calibrate-camera"];
    args.extend(files.iter().map(|f| f.as_str()));
    args.extend(["--corners", "4x11", "--square", "10", "--pattern", "acircles", "--json"]);
    let v = ok_json(&args);
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    assert!((f(&v["fx"]) / 600.0 - 1.0).abs() < 2e-3 && (f(&v["fy"]) / 598.0 - 1.0).abs() < 2e-3, "fx {} fy {}", v["fx"], v["fy"]);
    assert!((f(&v["cx"]) - 322.5).abs() < 1.0 && (f(&v["cy"]) - 236.0).abs() < 1.0, "cx {} cy {}", v["cx"], v["cy"]);
    assert_eq!(v["views"].as_array().unwrap().len(), 4);
    let mut bad: Vec<&str> = vec!["scan", "calibrate-camera"];
    bad.extend(files.iter().map(|f| f.as_str()));
    bad.extend(["--corners", "4x11", "--square", "10", "--pattern", "circles"]);
    let e = fails_on_one_line(&bad);
    assert!(e.contains("grid0.png") && e.contains("symmetric circle grid"), "{e}");
}

/// `scan calibrate-stereo` on four pairs of circle-grid photographs drawn through two known
/// cameras, plus a pair whose right photograph is blank: with `--skip-missing` the blank pair is
/// left out with one warning, the baseline comes back within 0.5 % and the rotation within 0.1°,
/// and the JSON and FileStorage files read back (`ProcamCalibration::read`) as the same
/// calibration; without it the blank photograph is a one-line error, as are unequal counts. The
/// same photographs given for both cameras calibrate with a one-line warning (zero baseline);
/// photographs paired out of order are a one-line error naming the pairs.
#[test]
fn calibrate_stereo_from_circle_grid_pairs() {
    use nalgebra::{Matrix3, Rotation3, Vector3};
    let s = Scratch::new("scan-calibrate-stereo");
    let (kl, kr) = (Matrix3::new(600.0, 0.0, 322.5, 0.0, 598.0, 236.0, 0.0, 0.0, 1.0), Matrix3::new(580.0, 0.0, 318.0, 0.0, 579.0, 242.5, 0.0, 0.0, 1.0));
    let r_lr = Rotation3::from_axis_angle(&Vector3::y_axis(), 12f64.to_radians());
    let t_lr = Vector3::new(-60.0, 1.5, 3.0);
    let (mut left, mut right) = (Vec::new(), Vec::new());
    for (i, (spin, tilt)) in GRID_POSES.iter().enumerate() {
        left.push(s.arg(&format!("l{i}.png")));
        right.push(s.arg(&format!("r{i}.png")));
        grid_photo(&left[i], &kl, *spin, *tilt, None);
        grid_photo(&right[i], &kr, *spin, *tilt, Some((r_lr, t_lr)));
    }
    left.push(s.arg("l4.png"));
    right.push(s.arg("r4.png"));
    grid_photo(&left[4], &kl, 45.0, (-0.3, -0.1), None);
    image::GrayImage::from_pixel(640, 480, image::Luma([128])).save(&right[4]).unwrap();
    let (json, xml) = (s.arg("stereo.json"), s.arg("stereo.xml"));
    let mut args: Vec<&str> = vec!["scan", "calibrate-stereo", "--left"];
    args.extend(left.iter().map(|f| f.as_str()));
    args.push("--right");
    args.extend(right.iter().map(|f| f.as_str()));
    args.extend(["--corners", "4x11", "--square", "10", "--pattern", "acircles"]);
    let out = lucent().args(&args).args(["--skip-missing", "--out", &json, "--opencv-out", &xml, "--json"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.trim_end().lines().count() == 1 && err.contains("r4.png") && err.contains("skipped"), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["captures"].as_array().unwrap().len(), 4);
    let t = Vector3::new(v["translation"][0].as_f64().unwrap(), v["translation"][1].as_f64().unwrap(), v["translation"][2].as_f64().unwrap());
    assert!((t - t_lr).norm() < 5e-3 * t_lr.norm(), "T {t:?}");
    let r = Matrix3::from_fn(|i, j| v["rotation"][i][j].as_f64().unwrap());
    let angle = Rotation3::from_matrix(&(r * r_lr.matrix().transpose())).angle().to_degrees();
    assert!(angle < 0.1, "rotation off by {angle}°");
    assert!((v["projector"]["fx"].as_f64().unwrap() / 580.0 - 1.0).abs() < 2e-3, "right fx {}", v["projector"]["fx"]);
    let a = scan::calib::ProcamCalibration::read(Path::new(&json), None).unwrap();
    let b = scan::calib::ProcamCalibration::read(Path::new(&xml), Some((640, 480))).unwrap();
    assert_eq!((a.camera.fx, a.projector.fx, a.translation), (b.camera.fx, b.projector.fx, b.translation));
    // The same photographs as both cameras: a calibration with a warning that the two share a
    // centre.
    let mut same: Vec<&str> = vec!["scan", "calibrate-stereo", "--left"];
    same.extend(left[..4].iter().map(|f| f.as_str()));
    same.push("--right");
    same.extend(left[..4].iter().map(|f| f.as_str()));
    same.extend(["--corners", "4x11", "--square", "10", "--pattern", "acircles", "--json"]);
    let o = lucent().args(&same).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.trim_end().lines().count() == 1 && err.contains("share a centre"), "{err}");
    // Without --skip-missing; and unequal counts.
    let e = fails_on_one_line(&args);
    assert!(e.contains("r4.png") && e.contains("asymmetric circle grid"), "{e}");
    let e = fails_on_one_line(&["scan", "calibrate-stereo", "--left", &left[0], &left[1], &left[2], "--right", &right[0], &right[1], "--corners", "4x11", "--square", "10"]);
    assert!(e.contains("--left has 3") && e.contains("--right 2"), "{e}");
    // Photographs paired out of order: two pairs swapped, and one right photograph of a pose 10°
    // from its left one. Each is a one-line error naming those pairs alone and no others, whether
    // the joint fit diverges (the swap) or converges at a few pixels (the 10°).
    let names = |order: &[usize]| -> Vec<&str> {
        let mut m: Vec<&str> = vec!["scan", "calibrate-stereo", "--left"];
        m.extend(left.iter().map(|f| f.as_str()));
        m.push("--right");
        m.extend(order.iter().map(|&i| right[i].as_str()));
        m.extend(["--corners", "4x11", "--square", "10", "--pattern", "acircles", "--out", &json]);
        m
    };
    std::fs::remove_file(&json).unwrap();
    grid_photo(&right[4], &kr, 45.0, (-0.3, -0.1), Some((r_lr, t_lr)));
    let ok = lucent().args(names(&[0, 1, 2, 3, 4])).output().unwrap();
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    std::fs::remove_file(&json).unwrap();
    let e = fails_on_one_line(&names(&[0, 2, 1, 3, 4]));
    assert!(e.contains("l1.png + ") && e.contains("r2.png") && e.contains("l2.png + ") && e.contains("same moment"), "{e}");
    assert!(!e.contains("l0.png") && !e.contains("l3.png") && !e.contains("l4.png"), "{e}");
    grid_photo(&right[4], &kr, 55.0, (-0.3, -0.1), Some((r_lr, t_lr)));
    let e = fails_on_one_line(&names(&[0, 1, 2, 3, 4]));
    assert!(e.contains("l4.png + ") && e.contains("(10.0°)") && e.contains("same moment") && !e.contains("l0.png") && !e.contains("l3.png"), "{e}");
    assert!(!Path::new(&json).exists());
}

/// `scan undistort` on a shared capture's white frame: the PNG it writes is the library's remap of
/// the photograph (`scan::calib::undistort`, tested against a known pattern and OpenCV), grey as
/// the photograph; a camera calibrated at another size, an output that is not PNG and a file that
/// is not a calibration are one-line errors that write nothing.
#[test]
fn undistort_writes_the_remapped_photograph_and_refuses_bad_input() {
    use render::camera::{Distortion, Intrinsics};
    let s = Scratch::new("scan-undistort");
    let photo = sample_capture(0).join("graycode_40.png").display().to_string();
    let cam = s.arg("cam.json");
    std::fs::write(&cam, r#"{"width": 1280, "height": 1024, "fx": 3440.0, "fy": 3441.0, "cx": 530.0, "cy": 515.0, "dist": [-0.2, 0.8, 0.001, -0.002, 0.0]}"#).unwrap();
    let out = s.arg("u.png");
    let o = lucent().args(["scan", "undistort", &photo, "--camera", &cam, "--out", &out]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got = image::open(&out).unwrap();
    assert_eq!(got.color(), image::ColorType::L8);
    let src = image::open(&photo).unwrap().into_luma8();
    let k = Intrinsics { fx: 3440.0, fy: 3441.0, cx: 530.0, cy: 515.0 };
    let d = Distortion::from_opencv(&[-0.2, 0.8, 0.001, -0.002, 0.0]).unwrap();
    let want = scan::calib::undistort::remap_bilinear(src.as_raw(), 1, 1280, 1024, &scan::calib::undistort::undistort_map(&k, &d, &k, 1280, 1024));
    assert!(got.into_luma8().into_raw() == want);
    let small = s.arg("small.json");
    std::fs::write(&small, r#"{"width": 640, "height": 512, "fx": 1720.0, "fy": 1720.0, "cx": 265.0, "cy": 257.0, "dist": []}"#).unwrap();
    let bad = s.arg("bad.png");
    let e = fails_on_one_line(&["scan", "undistort", &photo, "--camera", &small, "--out", &bad]);
    assert!(e.contains("graycode_40.png") && e.contains("640x512"), "{e}");
    let e = fails_on_one_line(&["scan", "undistort", &photo, "--camera", &cam, "--out", &s.arg("u.jpg")]);
    assert!(e.contains("PNG"), "{e}");
    let e = fails_on_one_line(&["scan", "undistort", &photo, "--camera", &photo, "--out", &bad]);
    assert!(e.contains("graycode_40.png"), "{e}");
    assert!(!s.path("bad.png").exists() && !s.path("u.jpg").exists());
}

/// `scan calibrate --thin-prism` (OpenCV's CALIB_THIN_PRISM_MODEL) on the three shared captures:
/// twelve coefficients per device in OpenCV's order with k4…k6 exactly 0, and a stereo RMS no
/// larger than the five-coefficient model's, which it contains.
#[test]
fn calibrate_thin_prism_writes_twelve_coefficients() {
    let caps: Vec<String> = (0..3).map(|i| sample_capture(i).display().to_string()).collect();
    let run = |extra: &[&str]| {
        let mut args: Vec<&str> = vec!["scan", "calibrate"];
        args.extend(caps.iter().map(|c| c.as_str()));
        args.extend(["--projector", "1024x768", "--corners", "9x7", "--square", "75", "--json"]);
        args.extend(extra);
        ok_json(&args)
    };
    let five = run(&[]);
    let prism = run(&["--thin-prism"]);
    for dev in ["camera", "projector"] {
        let d: Vec<f64> = prism[dev]["distortion"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        assert_eq!(d.len(), 12, "{dev}");
        assert_eq!(&d[5..8], &[0.0, 0.0, 0.0], "{dev}");
        assert!(d[8..].iter().any(|&s| s != 0.0), "{dev}: the prism terms were not fitted");
    }
    let (r5, r12) = (five["rms_px"].as_f64().unwrap(), prism["rms_px"].as_f64().unwrap());
    assert!(r12 <= r5 * (1.0 + 1e-9), "thin prism RMS {r12} vs five coefficients {r5}");
    // With --tilted these three captures give a camera whose radial map turns back inside the
    // image (OpenCV's fit with CALIB_TILTED_MODEL tilts the sensor by 20°): refused on one line.
    let mut args: Vec<&str> = vec!["scan", "calibrate"];
    args.extend(caps.iter().map(|c| c.as_str()));
    args.extend(["--projector", "1024x768", "--corners", "9x7", "--square", "75", "--tilted", "--json"]);
    let e = fails_on_one_line(&args);
    assert!(e.contains("--tilted") && e.contains("not usable"), "{e}");
}

/// `scan calibrate` on the three shared captures: the JSON keys of the contract, the stereo RMS
/// target, the file equal to the printed JSON; and bad input as one line with no output file.
#[test]
fn calibrate_writes_the_contract_json_and_refuses_bad_input_cleanly() {
    let s = Scratch::new("scan-calibrate");
    let caps: Vec<String> = (0..3).map(|i| sample_capture(i).display().to_string()).collect();
    let mut args: Vec<&str> = vec!["scan", "calibrate"];
    args.extend(caps.iter().map(|c| c.as_str()));
    let out = s.arg("calib.json");
    let xml = s.arg("calibration_result.xml");
    args.extend(["--projector", "1024x768", "--corners", "9x7", "--square", "75", "--out", &out, "--opencv-out", &xml, "--json"]);
    let v = ok_json(&args);
    // The OpenCV FileStorage copy reads back as the same calibration (17 significant digits),
    // the projector's size included (proj_shape), without board poses.
    let mut from_json: scan::calib::ProcamCalibration = serde_json::from_value(v.clone()).unwrap();
    let from_xml = scan::calib::ProcamCalibration::read(std::path::Path::new(&xml), None).unwrap();
    from_json.captures.clear();
    from_json.camera.rms_px = from_json.rms_px;
    from_json.projector.rms_px = from_json.rms_px;
    assert_eq!(from_xml, from_json);
    let text = std::fs::read_to_string(&xml).unwrap();
    for node in ["<img_shape", "<cam_int", "<cam_dist", "<proj_int", "<proj_dist", "<roration", "<translation", "<proj_shape", "<rms>"] {
        assert!(text.contains(node), "{node} missing");
    }
    for dev in ["camera", "projector"] {
        let d = v[dev].as_object().unwrap();
        let mut keys: Vec<&str> = d.keys().map(|k| k.as_str()).collect();
        keys.sort();
        assert_eq!(keys, ["cx", "cy", "distortion", "fx", "fy", "height", "rms_px", "width"]);
        assert_eq!(d["distortion"].as_array().unwrap().len(), 5);
        assert!(d["rms_px"].as_f64().unwrap() <= 0.6);
    }
    assert_eq!((v["camera"]["width"].as_u64(), v["camera"]["height"].as_u64()), (Some(1280), Some(1024)));
    assert_eq!((v["projector"]["width"].as_u64(), v["projector"]["height"].as_u64()), (Some(1024), Some(768)));
    assert_eq!(v["rotation"].as_array().unwrap().iter().map(|r| r.as_array().unwrap().len()).collect::<Vec<_>>(), [3, 3, 3]);
    assert_eq!(v["translation"].as_array().unwrap().len(), 3);
    assert!(v["rms_px"].as_f64().unwrap() <= 0.6, "stereo RMS {}", v["rms_px"]);
    let c = v["captures"].as_array().unwrap();
    assert_eq!(c.len(), 3);
    for p in c {
        assert!(p["rvec"].as_array().unwrap().len() == 3 && p["tvec"].as_array().unwrap().len() == 3 && p["rms_px"].as_f64().is_some());
    }
    let file: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(file, v);
    // Bad input: too few captures, a board that is not there (wrong corner count), a missing folder.
    let bad = s.arg("bad.json");
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &caps[2], "--projector", "1024x768", "--corners", "9x7", "--square", "75", "--opencv-out", &s.arg("c.txt")]);
    assert!(e.contains("c.txt") && e.contains(".xml"), "{e}");
    // An output in a folder that does not exist: refused before the work, naming the file.
    let lost = s.path("no-such-folder").join("c.xml").display().to_string();
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &caps[2], "--projector", "1024x768", "--corners", "9x7", "--square", "75", "--opencv-out", &lost]);
    assert!(e.contains(&lost) && e.contains("not a folder"), "{e}");
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], "--projector", "1024x768", "--corners", "9x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("degenerate pose set"), "{e}");
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &caps[2], "--projector", "1024x768", "--corners", "11x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("board not found (capture ") && e.contains("capture_0"), "{e}");
    let missing = s.arg("nowhere");
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &missing, "--projector", "1024x768", "--corners", "9x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("nowhere"), "{e}");
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &caps[2], "--projector", "1024x768", "--corners", "9x7", "--square", "0"]);
    assert!(e.contains("--square"), "{e}");
    // A negative value is the option's value (checked by the command), not a flag "-7".
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &caps[2], "--projector", "1024x768", "--corners", "9x7", "--square", "-75"]);
    assert!(e.contains("--square") && e.contains("-75"), "{e}");
    assert!(!s.path("bad.json").exists());
}

fn calibrate_args<'a>(caps: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["scan", "calibrate"];
    a.extend(caps);
    a.extend(["--projector", "1024x768", "--corners", "9x7", "--square", "75"]);
    a.extend(extra);
    a
}

/// `scan calibrate` bad input past the argument checks, each one line, exit ≠ 0, no output file:
/// too few decoded pixels around a corner (a window of 9 × 9 pixels holds fewer than the 100 a
/// local homography needs), one board pose three times (Zhang's system has a null space), and
/// captures of different camera sizes (the 1024 × 768 pattern images as a capture).
#[test]
fn calibrate_refuses_sparse_corners_repeated_poses_and_mixed_sizes() {
    let s = Scratch::new("scan-calibrate-bad");
    let caps: Vec<String> = (0..3).map(|i| sample_capture(i).display().to_string()).collect();
    let out = s.arg("calib.json");
    let e = fails_on_one_line(&calibrate_args(&[&caps[0], &caps[1], &caps[2]], &["--half-window", "4", "--out", &out]));
    assert!(e.contains("too few valid pixels around corner 0 (capture ") && e.contains("capture_0"), "{e}");
    let e = fails_on_one_line(&calibrate_args(&[&caps[1], &caps[1], &caps[1]], &["--out", &out]));
    assert!(e.contains("degenerate pose set"), "{e}");
    lucent().args(["scan", "patterns", "--projector", "1024x768", "--out", &s.arg("pat")]).output().unwrap();
    std::fs::create_dir_all(s.path("small")).unwrap();
    for i in 0..42 {
        std::fs::rename(s.path("pat").join(format!("pattern_{i:02}.png")), s.path("small").join(format!("graycode_{i:02}.png"))).unwrap();
    }
    let small = s.arg("small");
    let e = fails_on_one_line(&calibrate_args(&[&caps[0], &small, &caps[2]], &["--out", &out]));
    assert!(e.contains("small") && e.contains("1024x768") && e.contains("1280x1024"), "{e}");
    assert!(!s.path("calib.json").exists());
}

/// A capture whose projector columns are mirrored (the most significant column bit's pattern and
/// inverse swapped: column c reads as 1023 − c), with two true ones: no projector pose explains a
/// mirrored view together with the others, and the joint fit stops with one line (its RMS is
/// far above any calibration's).
#[test]
fn calibrate_reports_a_fit_that_does_not_converge() {
    let s = Scratch::new("scan-calibrate-diverge");
    let caps: Vec<String> = (0..3).map(|i| sample_capture(i).display().to_string()).collect();
    let mirror = s.path("mirror");
    std::fs::create_dir_all(&mirror).unwrap();
    for i in 0..42usize {
        let from = match i {
            0 => 1,
            1 => 0,
            _ => i,
        };
        std::fs::copy(sample_capture(2).join(format!("graycode_{from:02}.png")), mirror.join(format!("graycode_{i:02}.png"))).unwrap();
    }
    let out = s.arg("calib.json");
    let e = fails_on_one_line(&calibrate_args(&[&caps[0], &caps[1], &s.arg("mirror")], &["--out", &out]));
    assert!(e.contains("did not converge"), "{e}");
    assert!(!s.path("calib.json").exists());
}

/// `scan rectify`: a pair of photographs of three bright dots, drawn through two distorted cameras
/// of a known calibration, rectified: each dot's centroid lands on the same row in both images
/// (within 0.05 px; the dots are blurred discs of 1.5 px, 8-bit), and the --json projections are
/// those of the library's `rectify_calibration`. Two device sizes, a photograph of another size
/// and a non-PNG output are one-line errors with no output.
#[test]
fn rectify_puts_a_pair_on_common_rows() {
    use nalgebra::{Rotation3, Vector3};
    use render::camera::{Distortion, Intrinsics};
    let s = Scratch::new("scan-rectify");
    let (w, h) = (320u32, 240u32);
    let k = [Intrinsics { fx: 400.0, fy: 398.0, cx: 161.0, cy: 118.0 }, Intrinsics { fx: 390.0, fy: 391.0, cx: 157.0, cy: 122.0 }];
    let d = [[-0.1, 0.03, 0.0005, -0.0003, 0.0], [-0.06, 0.01, 0.0, 0.0004, 0.0]];
    let rot = *Rotation3::new(Vector3::new(0.01, -0.04, 0.02)).matrix();
    let t = Vector3::new(-60.0, 1.5, 2.0);
    let calib = s.arg("pair.json");
    let dev = |i: usize| serde_json::json!({"width": w, "height": h, "fx": k[i].fx, "fy": k[i].fy, "cx": k[i].cx, "cy": k[i].cy, "distortion": d[i], "rms_px": 0.0});
    let rows: Vec<Vec<f64>> = (0..3).map(|i| (0..3).map(|j| rot[(i, j)]).collect()).collect();
    let json = serde_json::json!({"camera": dev(0), "projector": dev(1), "rotation": rows, "translation": [t.x, t.y, t.z], "rms_px": 0.0, "captures": []});
    std::fs::write(&calib, serde_json::to_string(&json).unwrap()).unwrap();
    let points = [Vector3::new(-40.0, -25.0, 500.0), Vector3::new(35.0, 10.0, 650.0), Vector3::new(0.0, 40.0, 420.0)];
    // Each dot: a disc of radius 1.5 px around the projected point, 8 × 8 samples per pixel.
    for (i, name) in ["l.png", "r.png"].into_iter().enumerate() {
        let dist = Distortion::from_opencv(&d[i]).unwrap();
        let centres: Vec<[f64; 2]> = points
            .iter()
            .map(|x| {
                let x = if i == 0 { *x } else { rot * x + t };
                let (xd, yd) = dist.distort(x.x / x.z, x.y / x.z);
                [k[i].fx * xd + k[i].cx, k[i].fy * yd + k[i].cy]
            })
            .collect();
        let img = image::GrayImage::from_fn(w, h, |u, v| {
            let mut acc = 0.0f64;
            for sy in 0..8 {
                for sx in 0..8 {
                    let (x, y) = (u as f64 - 0.5 + (sx as f64 + 0.5) / 8.0, v as f64 - 0.5 + (sy as f64 + 0.5) / 8.0);
                    if centres.iter().any(|c| (x - c[0]).hypot(y - c[1]) < 1.5) {
                        acc += 1.0;
                    }
                }
            }
            image::Luma([(acc / 64.0 * 250.0).round() as u8])
        });
        img.save(s.path(name)).unwrap();
    }
    let (ol, or) = (s.arg("lr.png"), s.arg("rr.png"));
    let v = ok_json(&["scan", "rectify", &s.arg("l.png"), &s.arg("r.png"), "--calibration", &calib, "--out-left", &ol, "--out-right", &or, "--json"]);
    let c = scan::calib::ProcamCalibration::read(Path::new(&calib), None).unwrap();
    let (rect, _) = scan::calib::rectify::rectify_calibration(&c, true, -1.0).unwrap();
    for (key, m) in [("P1", rect.p[0]), ("P2", rect.p[1])] {
        for i in 0..3 {
            for j in 0..4 {
                assert_eq!(v[key][i][j].as_f64().unwrap(), m[(i, j)], "{key}");
            }
        }
    }
    // The dots' centroids: one per connected bright region, ordered by x.
    let centroids = |p: &str| {
        let img = image::open(p).unwrap().into_luma8();
        let mut seen = vec![false; (w * h) as usize];
        let mut out = Vec::new();
        for start in 0..(w * h) as usize {
            if seen[start] || img.as_raw()[start] < 5 {
                continue;
            }
            let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
            let mut stack = vec![start];
            seen[start] = true;
            while let Some(q) = stack.pop() {
                let (x, y) = ((q % w as usize) as f64, (q / w as usize) as f64);
                let val = img.as_raw()[q] as f64;
                (sw, sx, sy) = (sw + val, sx + val * x, sy + val * y);
                for n in [q.wrapping_sub(1), q + 1, q.wrapping_sub(w as usize), q + w as usize] {
                    if n < seen.len() && !seen[n] && img.as_raw()[n] >= 5 {
                        seen[n] = true;
                        stack.push(n);
                    }
                }
            }
            out.push([sx / sw, sy / sw]);
        }
        out.sort_by(|a, b| a[0].total_cmp(&b[0]));
        out
    };
    let (a, b) = (centroids(&ol), centroids(&or));
    assert_eq!((a.len(), b.len()), (3, 3), "{a:?} {b:?}");
    for (p, q) in a.iter().zip(&b) {
        assert!((p[1] - q[1]).abs() < 0.05, "rows {} and {}", p[1], q[1]);
    }
    // Bad input.
    let bad = s.arg("bad.png");
    let e = fails_on_one_line(&["scan", "rectify", &s.arg("l.png"), &s.arg("r.png"), "--calibration", &calib, "--out-left", &s.arg("x.jpg"), "--out-right", &bad]);
    assert!(e.contains("PNG"), "{e}");
    let small = s.arg("small.png");
    image::GrayImage::new(160, 120).save(&small).unwrap();
    let e = fails_on_one_line(&["scan", "rectify", &small, &s.arg("r.png"), "--calibration", &calib, "--out-left", &bad, "--out-right", &s.arg("bad2.png")]);
    assert!(e.contains("small.png") && e.contains("320x240"), "{e}");
    let mixed = s.arg("mixed.json");
    let mut j2 = json.clone();
    j2["projector"]["width"] = serde_json::json!(640);
    std::fs::write(&mixed, serde_json::to_string(&j2).unwrap()).unwrap();
    let e = fails_on_one_line(&["scan", "rectify", &s.arg("l.png"), &s.arg("r.png"), "--calibration", &mixed, "--out-left", &bad, "--out-right", &s.arg("bad2.png")]);
    assert!(e.contains("one size"), "{e}");
    assert!(!s.path("bad.png").exists() && !s.path("bad2.png").exists() && !s.path("x.jpg").exists());
}

/// A chessboard photographed through a known fisheye lens (OpenCV's model; 640 × 480, rays up
/// to 76° off the axis), drawn by casting each sub-pixel's ray (`render::camera::Fisheye`) onto
/// the board's plane, 4 × 4 samples per pixel, 8-bit sRGB.
fn fisheye_photo(path: &str, cam: &render::camera::Fisheye, rvec: [f64; 3], centre: [f64; 3]) {
    use nalgebra::{Rotation3, Vector3};
    let (cols, rows, sq) = (9usize, 6usize, 30.0);
    // Board → camera: the board's middle at `centre`, turned by `rvec`.
    let r = Rotation3::new(Vector3::from(rvec));
    let mid = Vector3::new(0.5 * (cols as f64 - 1.0) * sq, 0.5 * (rows as f64 - 1.0) * sq, 0.0);
    let t = Vector3::from(centre) - r * mid;
    let n = r * Vector3::z();
    let (w, h) = (640usize, 480usize);
    let mut bytes = vec![0u8; w * h];
    for j in 0..h {
        for i in 0..w {
            let mut sum = 0.0;
            for s in 0..16 {
                let (u, v) = (i as f64 - 0.375 + 0.25 * (s % 4) as f64, j as f64 - 0.375 + 0.25 * (s / 4) as f64);
                let (_, d) = cam.ray_pixel(u, v);
                let d = Vector3::from(d);
                let denom = n.dot(&d);
                let mut level = 0.3;
                if denom.abs() > 1e-9 {
                    let s_hit = n.dot(&t) / denom;
                    if s_hit > 0.0 {
                        let b = r.inverse() * (d * s_hit - t);
                        // (cols + 1) × (rows + 1) squares from (−sq, −sq), so that the inner
                        // corners lie at (0, 0) … ((cols − 1)·sq, (rows − 1)·sq), then a white margin.
                        let (qx, qy) = ((b.x / sq).floor() as i64 + 1, (b.y / sq).floor() as i64 + 1);
                        if (0..=cols as i64).contains(&qx) && (0..=rows as i64).contains(&qy) {
                            level = if (qx + qy).rem_euclid(2) == 0 { 0.03 } else { 0.8 };
                        } else if b.x > -1.7 * sq && b.x < (cols as f64 + 0.7) * sq && b.y > -1.7 * sq && b.y < (rows as f64 + 0.7) * sq {
                            level = 0.8;
                        }
                    }
                }
                sum += level;
            }
            bytes[j * w + i] = (render::image_io::srgb_encode(sum / 16.0) * 255.0).round() as u8;
        }
    }
    image::GrayImage::from_raw(w as u32, h as u32, bytes).unwrap().save(path).unwrap();
}

/// `scan calibrate-camera --fisheye` on eight chessboard photographs drawn through a known fisheye
/// lens: the focal lengths within 0.3 %, the principal point within 0.5 px, the image radius
/// fx·θ_d(θ) within 0.2 % from 10° to 65° off the axis; the JSON (`"model": "fisheye"`) is a
/// camera `lucent render --camera` reads. Pinhole-model flags and FileStorage output are one-line
/// errors.
#[test]
fn calibrate_camera_fisheye_from_chessboards() {
    use render::camera::{Extrinsics, Fisheye, FisheyeLens};
    let s = Scratch::new("scan-calibrate-fisheye");
    let lens = FisheyeLens { fx: 300.0, fy: 299.0, cx: 321.4, cy: 238.7, skew: 0.0, k: [0.04, -0.015, 0.003, -0.0003] };
    let cam = Fisheye::new(lens, Extrinsics::from_rvec([0.0; 3], [0.0; 3]).unwrap(), 640, 480).unwrap();
    let poses = [
        ([0.05, -0.04, 0.02], [0.0, 0.0, 330.0]),
        ([0.5, 0.1, -0.05], [-120.0, -80.0, 280.0]),
        ([-0.45, 0.2, 0.1], [130.0, 90.0, 280.0]),
        ([0.1, 0.55, 0.05], [-190.0, 40.0, 260.0]),
        ([0.2, -0.5, -0.1], [180.0, -40.0, 270.0]),
        ([-0.3, -0.4, 0.3], [90.0, -120.0, 270.0]),
        ([0.4, 0.4, -0.2], [-150.0, 110.0, 270.0]),
        ([-0.2, 0.1, 0.9], [0.0, 0.0, 230.0]),
    ];
    let files: Vec<String> = (0..poses.len()).map(|i| s.arg(&format!("fish{i}.png"))).collect();
    std::thread::scope(|sc| {
        for (f, (r, c)) in files.iter().zip(poses) {
            let cam = &cam;
            sc.spawn(move || fisheye_photo(f, cam, r, c));
        }
    });
    let out = s.arg("fisheye.json");
    let mut args: Vec<&str> = vec!["scan", "calibrate-camera"];
    args.extend(files.iter().map(|f| f.as_str()));
    args.extend(["--corners", "9x6", "--square", "30", "--fisheye", "--out", &out, "--json"]);
    let v = ok_json(&args);
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    assert_eq!(v["model"], "fisheye");
    assert!((f(&v["fx"]) / lens.fx - 1.0).abs() < 3e-3 && (f(&v["fy"]) / lens.fy - 1.0).abs() < 3e-3, "fx {} fy {}", v["fx"], v["fy"]);
    assert!((f(&v["cx"]) - lens.cx).abs() < 0.5 && (f(&v["cy"]) - lens.cy).abs() < 0.5, "cx {} cy {}", v["cx"], v["cy"]);
    let k: Vec<f64> = v["dist"].as_array().unwrap().iter().map(f).collect();
    let got = FisheyeLens { fx: f(&v["fx"]), fy: f(&v["fy"]), cx: f(&v["cx"]), cy: f(&v["cy"]), skew: 0.0, k: [k[0], k[1], k[2], k[3]] };
    for deg in [10.0, 30.0, 50.0, 65.0] {
        let th = f64::to_radians(deg);
        let (a, b) = (got.fx * got.theta_d(th), lens.fx * lens.theta_d(th));
        assert!((a / b - 1.0).abs() < 2e-3, "{deg}°: image radius {a} px against {b}");
    }
    // The corners of the views that reach 60–70° off the axis, where the squares' edges curve
    // within the corner finder's window, are up to 0.3 px off (RMS per view 0.03–0.30 px).
    assert!(f(&v["rms_px"]) < 0.25, "RMS {}", v["rms_px"]);
    // The JSON reads back as a fisheye camera of the photographs' size.
    let text = std::fs::read_to_string(&out).unwrap();
    let c = render::load::calibration::parse_calibration(&text, &out, &Default::default()).unwrap();
    assert!(c.fisheye.is_some() && c.width == Some(640));
    let mut bad = args.clone();
    bad.retain(|a| *a != "--json");
    let e = fails_on_one_line(&[bad.as_slice(), &["--rational"]].concat());
    assert!(e.contains("--rational") && e.contains("fisheye"), "{e}");
    let yml = s.arg("fisheye.yml");
    let e = fails_on_one_line(&[bad.as_slice(), &["--opencv-out", &yml]].concat());
    assert!(e.contains("--opencv-out"), "{e}");
    // `scan undistort` takes the pinhole model: a fisheye camera is refused, not misread.
    let png = s.arg("flat.png");
    let e = fails_on_one_line(&["scan", "undistort", &files[0], "--camera", &out, "--out", &png]);
    assert!(e.contains("fisheye"), "{e}");
}

/// `scan calibrate-stereo --fisheye` on seven pairs of chessboard photographs drawn through two
/// known fisheye lenses at X₂ = R·X₁ + T: both lenses' focal lengths within 0.3 %, the principal
/// points within 0.5 px, R within 2 mrad and T within 1 % of the baseline; the JSON (`"model":
/// "fisheye"`) is refused by the pinhole readers and read by `lucent render`'s calibration
/// reader as a fisheye camera. `scan rectify` of one pair puts the corners of the rectified left
/// image on the rows of the same corners in the right one (found again in the rectified 8-bit
/// images): the mean row difference within 0.05 px and its rms within 0.15 px, through the
/// fitted and through the true calibration; its --json projections are the library's. Pinhole
/// flags, a pinhole scaling and two pairs swapped are one-line errors.
#[test]
fn calibrate_stereo_and_rectify_a_fisheye_pair() {
    use nalgebra::{Rotation3, Vector3};
    use render::camera::{Extrinsics, Fisheye, FisheyeLens};
    let s = Scratch::new("scan-stereo-fisheye");
    let lens = [
        FisheyeLens { fx: 300.0, fy: 299.0, cx: 321.4, cy: 238.7, skew: 0.0, k: [0.04, -0.015, 0.003, -0.0003] },
        FisheyeLens { fx: 310.0, fy: 310.5, cx: 318.2, cy: 242.1, skew: 0.0, k: [0.035, -0.012, 0.002, -0.0002] },
    ];
    let cams: Vec<Fisheye> = lens.iter().map(|l| Fisheye::new(*l, Extrinsics::from_rvec([0.0; 3], [0.0; 3]).unwrap(), 640, 480).unwrap()).collect();
    let rot = Rotation3::new(Vector3::new(0.02, -0.1, 0.01));
    let t = Vector3::new(-60.0, 1.0, 2.0);
    let poses = [
        ([0.05, -0.04, 0.02], [30.0, 0.0, 330.0]),
        ([0.5, 0.1, -0.05], [-90.0, -70.0, 290.0]),
        ([-0.45, 0.2, 0.1], [130.0, 80.0, 290.0]),
        ([0.1, 0.55, 0.05], [-140.0, 40.0, 270.0]),
        ([0.2, -0.5, -0.1], [170.0, -40.0, 280.0]),
        ([-0.3, -0.4, 0.3], [90.0, -100.0, 280.0]),
        ([0.4, 0.4, -0.2], [-110.0, 100.0, 280.0]),
    ];
    let mut jobs = Vec::new();
    for (i, (r, c)) in poses.iter().enumerate() {
        let r1 = Rotation3::new(Vector3::from(*r));
        let r2 = (rot * r1).scaled_axis();
        let c2 = rot * Vector3::from(*c) + t;
        jobs.push((s.arg(&format!("l{i}.png")), 0usize, *r, *c));
        jobs.push((s.arg(&format!("r{i}.png")), 1usize, [r2.x, r2.y, r2.z], [c2.x, c2.y, c2.z]));
    }
    std::thread::scope(|sc| {
        for (f, d, r, c) in &jobs {
            let cam = &cams[*d];
            sc.spawn(move || fisheye_photo(f, cam, *r, *c));
        }
    });
    let out = s.arg("pair.json");
    let mut args: Vec<String> = vec!["scan".into(), "calibrate-stereo".into(), "--left".into()];
    args.extend((0..poses.len()).map(|i| s.arg(&format!("l{i}.png"))));
    args.push("--right".into());
    args.extend((0..poses.len()).map(|i| s.arg(&format!("r{i}.png"))));
    args.extend(["--corners", "9x6", "--square", "30", "--fisheye", "--out", &out].map(String::from));
    let argv: Vec<&str> = args.iter().map(|a| a.as_str()).collect();
    let v = ok_json(&[argv.as_slice(), &["--json"]].concat());
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    assert_eq!(v["model"], "fisheye");
    assert_eq!(v["captures"].as_array().unwrap().len(), poses.len());
    for (key, l) in [("camera", &lens[0]), ("projector", &lens[1])] {
        let d = &v[key];
        assert!((f(&d["fx"]) / l.fx - 1.0).abs() < 3e-3 && (f(&d["fy"]) / l.fy - 1.0).abs() < 3e-3, "{key}: fx {} fy {}", d["fx"], d["fy"]);
        assert!((f(&d["cx"]) - l.cx).abs() < 0.5 && (f(&d["cy"]) - l.cy).abs() < 0.5, "{key}: cx {} cy {}", d["cx"], d["cy"]);
    }
    let rm = nalgebra::Matrix3::from_fn(|i, j| f(&v["rotation"][i][j]));
    assert!((rm - rot.matrix()).norm() < 2e-3, "R {rm}");
    let tt = Vector3::new(f(&v["translation"][0]), f(&v["translation"][1]), f(&v["translation"][2]));
    assert!((tt - t).norm() < 0.01 * t.norm(), "T {tt}");
    // The pinhole readers refuse the file; the renderer's reads either camera as a fisheye.
    let e = scan::calib::ProcamCalibration::read(Path::new(&out), None).unwrap_err().to_string();
    assert!(e.contains("fisheye"), "{e}");
    let text = std::fs::read_to_string(&out).unwrap();
    let nodes = render::load::calibration::CalibrationNodes { matrix: "projector".into(), ..Default::default() };
    let c = render::load::calibration::parse_calibration(&text, &out, &nodes).unwrap();
    assert!(c.fisheye.is_some() && c.r.is_some());
    // Rectify pair 0 and find the board again in both rectified images.
    let (ol, or) = (s.arg("l0r.png"), s.arg("r0r.png"));
    let rv = ok_json(&["scan", "rectify", &s.arg("l0.png"), &s.arg("r0.png"), "--calibration", &out, "--out-left", &ol, "--out-right", &or, "--balance", "0.5", "--json"]);
    let calib = scan::calib::fisheye::pair::FisheyeStereoCalibration::read(Path::new(&out)).unwrap();
    let (l, r, tv) = calib.parts().unwrap();
    let rect = scan::calib::fisheye::rectify::stereo_rectify_fisheye([&l[0], &l[1]], (640, 480), &r, &tv, true, (0, 0), 0.5, 1.0).unwrap();
    for (key, m) in [("P1", rect.p[0]), ("P2", rect.p[1])] {
        for i in 0..3 {
            for j in 0..4 {
                assert_eq!(f(&rv[key][i][j]), m[(i, j)], "{key}");
            }
        }
    }
    let corners = |p: &str| scan::calib::chessboard::find_chessboard(&scan::calib::chessboard::GrayImage::load(Path::new(p)).unwrap(), 9, 6).expect("the board in the rectified image");
    // The mean and the rms of the row differences (px).
    let rows_apart = |l: &str, r: &str| {
        let d: Vec<f64> = corners(l).iter().zip(&corners(r)).map(|(p, q)| p[1] - q[1]).collect();
        let n = d.len() as f64;
        (d.iter().sum::<f64>() / n, (d.iter().map(|x| x * x).sum::<f64>() / n).sqrt())
    };
    // The corner finder's own error on the rectified 8-bit images is about 0.1 px rms per corner
    // (54 corners: a standard error of 0.015 px on the mean).
    let (mean, rms) = rows_apart(&ol, &or);
    assert!(mean.abs() < 0.05 && rms < 0.15, "rows apart through the fitted calibration: mean {mean:.3}, rms {rms:.3} px");
    // Through the true one: what is left is the corner finder's error.
    let mut truth = calib.clone();
    truth.skew = [0.0; 2];
    for (d, l) in [(&mut truth.pair.camera, &lens[0]), (&mut truth.pair.projector, &lens[1])] {
        (d.fx, d.fy, d.cx, d.cy, d.distortion) = (l.fx, l.fy, l.cx, l.cy, l.k.to_vec());
    }
    truth.pair.rotation = std::array::from_fn(|i| std::array::from_fn(|j| rot.matrix()[(i, j)]));
    truth.pair.translation = [t.x, t.y, t.z];
    let true_json = s.arg("true.json");
    std::fs::write(&true_json, serde_json::to_string(&truth).unwrap()).unwrap();
    let (tl, tr) = (s.arg("l0t.png"), s.arg("r0t.png"));
    ok_json(&["scan", "rectify", &s.arg("l0.png"), &s.arg("r0.png"), "--calibration", &true_json, "--out-left", &tl, "--out-right", &tr, "--balance", "0.5", "--json"]);
    let (mean, rms) = rows_apart(&tl, &tr);
    assert!(mean.abs() < 0.05 && rms < 0.15, "rows apart through the true calibration: mean {mean:.3}, rms {rms:.3} px");
    // Pinhole flags and scaling are refused for a fisheye pair.
    let e = fails_on_one_line(&[argv.as_slice(), &["--same-focal-length"]].concat());
    assert!(e.contains("--same-focal-length"), "{e}");
    let e = fails_on_one_line(&["scan", "rectify", &s.arg("l0.png"), &s.arg("r0.png"), "--calibration", &out, "--out-left", &s.arg("x.png"), "--out-right", &s.arg("y.png"), "--alpha", "0"]);
    assert!(e.contains("--alpha") && e.contains("fisheye"), "{e}");
    assert!(!s.path("x.png").exists());
    // Two pairs swapped: a one-line error naming them alone.
    let mut swapped: Vec<String> = vec!["scan".into(), "calibrate-stereo".into(), "--left".into()];
    swapped.extend((0..poses.len()).map(|i| s.arg(&format!("l{i}.png"))));
    swapped.push("--right".into());
    swapped.extend([0, 1, 3, 2, 4, 5, 6].map(|i| s.arg(&format!("r{i}.png"))));
    swapped.extend(["--corners", "9x6", "--square", "30", "--fisheye", "--out", &s.arg("swapped.json")].map(String::from));
    let e = fails_on_one_line(&swapped.iter().map(|a| a.as_str()).collect::<Vec<_>>());
    assert!(e.contains("l2.png + ") && e.contains("l3.png + ") && e.contains("same moment"), "{e}");
    assert!(!e.contains("l0.png") && !e.contains("l1.png") && !e.contains("l4.png"), "{e}");
    assert!(!s.path("swapped.json").exists());
}

/// Calibrations that the commands cannot use are refused on one line naming the field, before any
/// output is written: a rotation that is not one, a zero or overflowing translation, a focal
/// length of 0, a principal point far outside the image, a distortion that does not invert over
/// the image; and a failing second output leaves the first one's earlier file as it was.
#[test]
fn unusable_calibrations_and_outputs_are_refused_before_any_work() {
    let s = Scratch::new("scan-bad-calib");
    let good = synthetic_calibration();
    let cap0 = sample_capture(0);
    let cases: Vec<(&str, Box<dyn Fn(&mut scan::calib::ProcamCalibration)>)> = vec![
        ("rotation", Box::new(|c| c.rotation[2] = [0.0, 0.0, 0.0])),
        ("rotation", Box::new(|c| c.rotation = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]])),
        ("translation is zero", Box::new(|c| c.translation = [0.0; 3])),
        ("translation", Box::new(|c| c.translation = [1e300, 0.0, 0.0])),
        ("camera: fx", Box::new(|c| c.camera.fx = 0.0)),
        ("projector: principal point", Box::new(|c| c.projector.cx = 1e300)),
        ("camera: distortion is not invertible", Box::new(|c| c.camera.distortion[0] = -50.0)),
    ];
    for (needle, edit) in cases {
        let mut c = good.clone();
        edit(&mut c);
        std::fs::write(s.path("c.json"), serde_json::to_string(&c).unwrap()).unwrap();
        let e = fails_on_one_line(&["scan", "reconstruct", cap0.to_str().unwrap(), "--calibration", &s.arg("c.json"), "--out", &s.arg("o.ply")]);
        assert!(e.contains("c.json") && e.contains(needle), "{needle}: {e}");
        assert!(!s.path("o.ply").exists());
    }
    // Thresholds beyond 8-bit levels.
    let e = fails_on_one_line(&["scan", "decode", cap0.to_str().unwrap(), "--projector", "1024x768", "--black-threshold", "1000"]);
    assert!(e.contains("--black-threshold"), "{e}");
    // A second output that cannot be written: refused before the first is replaced.
    std::fs::write(s.path("keep.ply"), b"earlier").unwrap();
    std::fs::write(s.path("c.json"), serde_json::to_string(&good).unwrap()).unwrap();
    let e = fails_on_one_line(&["scan", "reconstruct", cap0.to_str().unwrap(), "--calibration", &s.arg("c.json"), "--out", &s.arg("keep.ply"), "--mesh", &s.arg("nowhere/m.ply")]);
    assert!(e.contains("m.ply"), "{e}");
    assert_eq!(std::fs::read(s.path("keep.ply")).unwrap(), b"earlier");
}

/// `scan calibrate-camera --pattern charuco` on four 8-bit photographs of a 7 × 5 ChArUco board
/// (DICT_4X4_50, OpenCV's layout) drawn through a known distortion-free pinhole camera, one of
/// them half covered, fitted with k3 and the tangential terms held (four views of a small board
/// leave the principal point loose against them): fx, fy within 0.2 % and the principal point
/// within 1 px; the covered view counts with the corners it shows. A missing board flag is a
/// one-line error naming it.
#[test]
fn calibrate_camera_from_charuco_boards() {
    use nalgebra::{Matrix3, Rotation3, Vector3};
    use scan::markers::aruco::{CharucoBoard, Dictionary};
    let s = Scratch::new("scan-calibrate-charuco");
    let k = Matrix3::new(600.0, 0.0, 322.5, 0.0, 598.0, 236.0, 0.0, 0.0, 1.0);
    let board = CharucoBoard::new(7, 5, 10.0, 5.0, Dictionary::predefined("DICT_4X4_50").unwrap(), false).unwrap();
    let files: Vec<String> = (0..GRID_POSES.len()).map(|i| s.arg(&format!("charuco{i}.png"))).collect();
    for (n, (f, (spin, tilt))) in files.iter().zip(GRID_POSES).enumerate() {
        let rot = Rotation3::from_euler_angles(tilt.0, tilt.1, 0.0) * Rotation3::from_axis_angle(&Vector3::z_axis(), spin.to_radians());
        let t = Vector3::new(0.0, 0.0, 180.0) - rot * Vector3::new(35.0, 25.0, 0.0);
        let r = rot.matrix();
        let h = k * Matrix3::from_columns(&[r.column(0).into_owned(), r.column(1).into_owned(), t]);
        let mut img = board.render(&h, 640, 480);
        if n == 1 {
            for y in 0..480 {
                for x in 0..300 {
                    img.data[y * 640 + x] = 128.0;
                }
            }
        }
        let bytes: Vec<u8> = img.data.iter().map(|&v| v.round() as u8).collect();
        image::GrayImage::from_raw(640, 480, bytes).unwrap().save(f).unwrap();
    }
    let mut args: Vec<&str> = vec!["scan", "calibrate-camera"];
    args.extend(files.iter().map(|f| f.as_str()));
    args.extend(["--pattern", "charuco", "--squares", "7x5", "--square", "10", "--marker-length", "5", "--dictionary", "DICT_4X4_50", "--zero-tangent", "--fix-k3", "--json"]);
    let v = ok_json(&args);
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    assert!((f(&v["fx"]) / 600.0 - 1.0).abs() < 2e-3 && (f(&v["fy"]) / 598.0 - 1.0).abs() < 2e-3, "fx {} fy {}", v["fx"], v["fy"]);
    assert!((f(&v["cx"]) - 322.5).abs() < 1.0 && (f(&v["cy"]) - 236.0).abs() < 1.0, "cx {} cy {}", v["cx"], v["cy"]);
    assert_eq!(v["views"].as_array().unwrap().len(), 4);
    assert!(f(&v["rms_px"]) < 0.15, "RMS {}", v["rms_px"]);
    let mut bad: Vec<&str> = vec!["scan", "calibrate-camera"];
    bad.extend(files.iter().map(|f| f.as_str()));
    bad.extend(["--pattern", "charuco", "--squares", "7x5", "--square", "10", "--dictionary", "DICT_4X4_50"]);
    let e = fails_on_one_line(&bad);
    assert!(e.contains("--marker-length"), "{e}");
}
