//! `lucent scan …`: the command-line contract (names, flags, JSON keys) and bad input.

use std::path::{Path, PathBuf};

use render::image_io::read_image;

use crate::common::{lucent, Scratch};

fn sample_capture(i: usize) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../../shared/data/structured-light/procam-sample/capture_{i}"))
}

fn ok_json(args: &[&str]) -> serde_json::Value {
    let out = lucent().args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{args:?}: {e}: {}", String::from_utf8_lossy(&out.stdout)))
}

/// Fails with exit ≠ 0 and one line on stderr; returns that line.
fn fails_on_one_line(args: &[&str]) -> String {
    let out = lucent().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} succeeded");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    err
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
    lucent().args(["scan", "patterns", "--projector", "16x9", "--out", &s.arg("pat9")]).output().unwrap();
    std::fs::copy(s.path("pat9").join("pattern_04.png"), cap.join("graycode_04.png")).unwrap();
    let e = fails_on_one_line(&["scan", "decode", &s.arg("cap"), "--projector", "16x8", "--out", &s.arg("m.exr")]);
    assert!(e.contains("graycode_04.png") && e.contains("16x9"), "{e}");
    assert!(!s.path("m.exr").exists());
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
    args.extend(["--projector", "1024x768", "--corners", "9x7", "--square", "75", "--out", &out, "--json"]);
    let v = ok_json(&args);
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
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], "--projector", "1024x768", "--corners", "9x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("degenerate pose set"), "{e}");
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &caps[2], "--projector", "1024x768", "--corners", "11x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("board not found (capture ") && e.contains("capture_0"), "{e}");
    let missing = s.arg("nowhere");
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &missing, "--projector", "1024x768", "--corners", "9x7", "--square", "75", "--out", &bad]);
    assert!(e.contains("nowhere"), "{e}");
    let e = fails_on_one_line(&["scan", "calibrate", &caps[0], &caps[1], &caps[2], "--projector", "1024x768", "--corners", "9x7", "--square", "0"]);
    assert!(e.contains("--square"), "{e}");
    assert!(!s.path("bad.json").exists());
}
