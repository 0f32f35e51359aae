//! `lucent fit scene` end to end: a round trip (render at known parameters, fit from 50 % off)
//! and its bad-input errors.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A small diffuse scene: a floor of known albedo 0.5 and a back wall of unknown albedo scale,
/// lit from above by a downward-facing area lamp outside the frame. The floor's brightness fixes
/// the lamp's scale, the wall's then its albedo scale (with the lamp visible, the noise of its
/// edge pixels would dominate the RMSE).
fn scene(lamp_scale: f64, wall_albedo_scale: f64) -> String {
    format!(
        r#"unit = "m"
[camera]
eye = [0, 1.2, -3]
look_at = [0, 0.6, 0]
vfov_deg = 45
width = 32
height = 24
[integrator]
type = "direct"
max_depth = 2
[spectra.lamp]
constant = 1.0
scale = {lamp_scale:?}
[materials.wall]
type = "lambertian"
albedo = {{ rgb = [0.5, 0.4, 0.3], scale = {wall_albedo_scale:?} }}
[materials.floor]
type = "lambertian"
albedo = 0.5
[[objects]]
name = "floor"
material = "floor"
quad = [[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]]
[[objects]]
name = "wall"
material = "wall"
quad = [[-2, 0, 1], [-2, 2, 1], [2, 2, 1], [2, 0, 1]]
[[objects]]
name = "lamp"
material = "floor"
quad = [[-0.5, 2.2, -0.5], [0.5, 2.2, -0.5], [0.5, 2.2, 0.5], [-0.5, 2.2, 0.5]]
[[lights]]
type = "area"
object = "lamp"
radiance = "lamp"
"#
    )
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lucent-fit-scene-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn lucent(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).output().unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Renders the reference (256 spp, seed 7) at lamp scale 10 and wall albedo scale 1, then fits
/// both from 15 and 0.5 (50 % off) with 32 spp at another seed (independent noise): both are
/// recovered within 5 %. (Over seeds 0–3 at 16 spp the errors were ≤ 1.5 %; the residual bias
/// comes from the noise of the 32-spp renders, a few tenths of a percent to a percent.) Both with
/// the plain RMSE and with `--unbiased` (0.5 % and 0.3 % off at seed 1).
#[test]
fn round_trip_recovers_light_scale_and_albedo_scale() {
    let d = dir("roundtrip");
    let truth = d.join("truth.toml");
    let start = d.join("start.toml");
    std::fs::write(&truth, scene(10.0, 1.0)).unwrap();
    std::fs::write(&start, scene(15.0, 0.5)).unwrap();
    let reference = d.join("reference.exr");
    let r = lucent(&["render", s(&truth), "--spp", "256", "--seed", "7", "--out", s(&reference), "--quiet"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));

    for unbiased in [false, true] {
    let out_dir = d.join(if unbiased { "out-unbiased" } else { "out" });
    let mut args = vec![
        "fit",
        "scene",
        s(&start),
        "--reference",
        s(&reference),
        "--param",
        "spectra.lamp.scale=1:30",
        "--param",
        "materials.wall.albedo.scale=0.1:1.3",
        "--spp",
        "32",
        "--seed",
        "1",
        "--max-iterations",
        "80",
        "--out-dir",
        s(&out_dir),
        "--json",
        "--quiet",
    ];
    if unbiased {
        args.push("--unbiased");
    }
    let r = lucent(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(|k| k.as_str()).collect();
    keys.sort();
    assert_eq!(keys, ["final_error", "initial_error", "iterations", "params"]);
    let lamp = v["params"]["spectra.lamp.scale"].as_f64().unwrap();
    let albedo = v["params"]["materials.wall.albedo.scale"].as_f64().unwrap();
    assert!((lamp / 10.0 - 1.0).abs() < 0.05, "lamp scale {lamp} (truth 10)");
    assert!((albedo - 1.0).abs() < 0.05, "wall albedo scale {albedo} (truth 1)");
    let (e0, e1) = (v["initial_error"].as_f64().unwrap(), v["final_error"].as_f64().unwrap());
    assert!(e1 < 0.5 * e0, "error {e0} -> {e1}");
    assert!(v["iterations"].as_u64().unwrap() >= 1);
    for f in ["render.exr", "render.png", "reference.png", "error.png", "comparison.png", "fit.json"] {
        assert!(out_dir.join(f).is_file(), "{f} missing");
    }
    let svg = std::fs::read_to_string(out_dir.join("convergence.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("<polyline") && svg.trim_end().ends_with("</svg>"));
    // No temporary files left behind.
    assert!(std::fs::read_dir(&out_dir).unwrap().all(|e| !e.unwrap().file_name().to_string_lossy().contains(".tmp")));
    }
}

/// Bad input: a path not in the scene, a start outside the bounds, reversed bounds, a reference of
/// another size: one-line error naming the culprit, exit status 1.
#[test]
fn bad_input_gives_one_line_errors() {
    let d = dir("bad");
    let sc = d.join("scene.toml");
    std::fs::write(&sc, scene(10.0, 1.0)).unwrap();
    let reference = d.join("ref.pfm");
    let r = lucent(&["render", s(&sc), "--spp", "1", "--out", s(&reference), "--quiet"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let out_dir = d.join("out");
    let run = |param: &str, extra: &[&str]| -> String {
        let mut a = vec!["fit", "scene", s(&sc), "--reference", s(&reference), "--param", param, "--out-dir", s(&out_dir)];
        a.extend_from_slice(extra);
        let r = lucent(&a);
        assert_eq!(r.status.code(), Some(1), "param {param}: {}", String::from_utf8_lossy(&r.stdout));
        let e = String::from_utf8_lossy(&r.stderr).to_string();
        assert_eq!(e.trim_end().lines().count(), 1, "not one line: {e}");
        assert!(!e.contains("panicked"), "{e}");
        e
    };
    let e = run("objects.wall.medium.milk.fat_percent=0:5", &[]);
    assert!(e.contains("objects.wall.medium.milk.fat_percent") && e.contains("does not exist"), "{e}");
    let e = run("lights.3.scale=0:5", &[]);
    assert!(e.contains("lights.3.scale"), "{e}");
    let e = run("spectra.lamp.scale=20:30", &[]);
    assert!(e.contains("spectra.lamp.scale") && e.contains("outside"), "{e}");
    let e = run("spectra.lamp.scale=5:1", &[]);
    assert!(e.contains("MIN"), "{e}");
    let e = run("objects.wall.name=0:1", &[]);
    assert!(e.contains("not a number"), "{e}");
    let e = run("spectra.lamp.scale=1:30", &["--width", "16", "--height", "12"]);
    assert!(e.contains("32×24"), "{e}");
    let mask = d.join("mask.png");
    let r = lucent(&["render", s(&sc), "--spp", "1", "--width", "16", "--height", "12", "--out", s(&mask), "--quiet"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let e = run("spectra.lamp.scale=1:30", &["--mask", s(&mask)]);
    assert!(e.contains("mask is 16×12"), "{e}");
}
