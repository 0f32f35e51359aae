//! `lucent render`, `compare` and `bench` at the edges a new user and a fuzzer reach: typos get a
//! suggestion on the one error line, flags agree with the scene format, renders are named after
//! their scene, an integrator that ignores part of the scene says so, EXR bytes are reproducible,
//! SSIM stays in [−1, 1] and benchmark rates are numbers or "n/a".

use std::path::Path;
use std::process::Output;

use render::image_io::{write_image, Image};

use crate::common::{run, Scratch};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The one-line error of a command that must fail with exit status `code`.
fn fails(dir: &Path, args: &[&str], code: i32) -> String {
    let o = run(dir, args);
    assert_eq!(o.status.code(), Some(code), "lucent {args:?}: {}", stderr(&o));
    let e = stderr(&o);
    assert_eq!(e.trim_end().lines().count(), 1, "lucent {args:?}: not one line:\n{e}");
    e
}

fn ok(dir: &Path, args: &[&str]) -> Output {
    let o = run(dir, args);
    assert!(o.status.success(), "lucent {args:?} failed: {}", stderr(&o));
    o
}

/// A small scene: a ball of `material` with an optional medium, under a constant environment.
fn small_scene(material: &str, medium: &str) -> String {
    format!(
        r#"unit = "m"
[camera]
eye = [0, 0, -3]
look_at = [0, 0, 0]
vfov_deg = 30
width = 8
height = 8
[materials.m]
{material}
[[objects]]
name = "ball"
material = "m"
sphere = {{ center = [0, 0, 0], radius = 0.8 }}
{medium}
[[lights]]
type = "environment"
radiance = 1
"#
    )
}

#[test]
fn typos_get_a_suggestion_on_the_error_line() {
    let t = Scratch::new("typos");
    let e = fails(&t.0, &["rendr"], 2);
    assert!(e.contains("'rendr'") && e.contains("'render'"), "{e}");
    let e = fails(&t.0, &["render", "--sp", "4"], 2);
    assert!(e.contains("'--sp'") && e.contains("'--spp'"), "{e}");
}

#[test]
fn help_and_flags_match_the_scene_format() {
    let t = Scratch::new("help");
    let help = String::from_utf8_lossy(&ok(&t.0, &["render", "--help"]).stdout).into_owned();
    assert!(help.contains("path|volpath|direct|ao"), "{help}");
    assert!(help.contains("path segments (1 = emitters only"), "{help}");
    assert!(!help.contains("bounces"), "{help}");
    // `max_depth = 0` is refused in a scene, and so on the command line.
    let e = fails(&t.0, &["render", "--max-depth", "0", "--spp", "1", "--width", "4", "--height", "4", "--quiet"], 1);
    assert!(e.contains("--max-depth must be a whole number ≥ 1, got 0"), "{e}");
}

#[test]
fn a_scene_renders_to_its_own_name_and_says_where() {
    let t = Scratch::new("names");
    std::fs::write(t.path("tiny.toml"), small_scene("type = \"lambertian\"\nalbedo = 0.5", "")).unwrap();
    let o = ok(&t.0, &["render", "tiny.toml", "--spp", "1", "--quiet"]);
    let png = t.path("tiny.png");
    assert!(png.exists(), "no tiny.png; stdout {}", String::from_utf8_lossy(&o.stdout));
    assert!(!t.path("lucent.png").exists());
    let stdout = String::from_utf8_lossy(&o.stdout);
    let abs = std::fs::canonicalize(&png).unwrap();
    assert!(stdout.lines().any(|l| Path::new(l.trim_start_matches("wrote ")).canonicalize().ok() == Some(abs.clone())), "{stdout}");
    // The scene's name is used in the current folder, not next to the scene.
    std::fs::create_dir_all(t.path("run")).unwrap();
    ok(&t.path("run"), &["render", &t.arg("tiny.toml"), "--spp", "1", "--quiet"]);
    assert!(t.path("run/tiny.png").exists());
}

#[test]
fn integrators_say_what_they_ignore() {
    let t = Scratch::new("ignored");
    let medium = "medium = { sigma_a_per_mm = 0.001, sigma_s_per_mm = 0.1, g = 0 }";
    std::fs::write(t.path("milky.toml"), small_scene("type = \"interface\"", medium)).unwrap();
    let out = t.arg("x.pfm");
    let args = |kind: &'static str| -> Vec<String> {
        ["render", "milky.toml", "--spp", "1", "--integrator", kind, "--out", out.as_str()].iter().map(|s| s.to_string()).collect()
    };
    let run_kind = |kind: &'static str| -> String {
        let a = args(kind);
        stderr(&ok(&t.0, &a.iter().map(String::as_str).collect::<Vec<_>>()))
    };
    for kind in ["path", "direct", "ao"] {
        let e = run_kind(kind);
        assert!(e.contains(&format!("warning: the {kind} integrator ignores the media of ball")) && e.contains("--integrator volpath"), "{kind}: {e}");
    }
    assert!(!run_kind("volpath").contains("warning"), "volpath renders the medium");
    // A translucent object without a medium: volpath (and direct, ao) see its clear boundary.
    std::fs::write(t.path("ketchup.toml"), small_scene("type = \"translucent\"\nsubsurface = { preset = \"Ketchup\" }", "")).unwrap();
    let o = ok(&t.0, &["render", "ketchup.toml", "--spp", "1", "--integrator", "volpath", "--out", &out]);
    let e = stderr(&o);
    assert!(e.contains("the volpath integrator ignores the subsurface scattering of ball"), "{e}");
    let o = ok(&t.0, &["render", "ketchup.toml", "--spp", "1", "--integrator", "path", "--out", &out]);
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
}

/// A medium whose density grid file is cut short: one error line naming the field and the file,
/// exit status 1, and the image a good run wrote before stays as it was.
#[test]
fn a_truncated_density_grid_is_one_line_and_leaves_the_last_image() {
    use render::medium::grid::DensityGrid;
    let t = Scratch::new("density");
    let vol = DensityGrid::write_vol([2, 2, 2], &[0.0, 1.0, 2.0, 1.0, 0.5, 0.0, 3.0, 1.0], [-1.0; 3], [1.0; 3]);
    std::fs::write(t.path("g.vol"), &vol).unwrap();
    let medium = r#"medium = { sigma_a_per_mm = 0.0005, sigma_s_per_mm = 0.002, g = 0.3, density = { file = "g.vol" } }"#;
    std::fs::write(t.path("cloud.toml"), small_scene("type = \"interface\"", medium)).unwrap();
    let out = t.arg("cloud.pfm");
    ok(&t.0, &["render", "cloud.toml", "--spp", "2", "--integrator", "volpath", "--out", &out, "--quiet"]);
    let good = std::fs::read(t.path("cloud.pfm")).unwrap();
    std::fs::write(t.path("g.vol"), &vol[..70]).unwrap();
    let e = fails(&t.0, &["render", "cloud.toml", "--spp", "2", "--integrator", "volpath", "--out", &out, "--quiet"], 1);
    assert!(e.contains("medium.density.file") && e.contains("g.vol") && e.contains("bytes"), "{e}");
    assert_eq!(std::fs::read(t.path("cloud.pfm")).unwrap(), good, "the failed run changed the image");
}

#[test]
fn exr_renders_with_the_same_seed_have_the_same_bytes() {
    let t = Scratch::new("exr");
    for name in ["a.exr", "b.exr"] {
        ok(&t.0, &["render", "--width", "96", "--height", "96", "--spp", "1", "--seed", "5", "--quiet", "--out", &t.arg(name)]);
    }
    assert!(std::fs::read(t.path("a.exr")).unwrap() == std::fs::read(t.path("b.exr")).unwrap(), "EXR bytes differ");
}

#[test]
fn ssim_of_a_huge_image_with_itself_is_one() {
    let t = Scratch::new("ssim");
    let image = Image::from_rgb(16, 16, vec![[3e38; 3]; 256]).unwrap();
    write_image(&t.path("big.pfm"), &image, 0.0).unwrap();
    let o = ok(&t.0, &["compare", "big.pfm", "big.pfm", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["ssim"].as_f64(), Some(1.0), "{v}");
}

#[test]
fn bench_rates_over_too_little_cpu_time_are_not_infinite() {
    let t = Scratch::new("bench");
    let args = ["bench", "--reps", "1", "--mrays", "0.001", "--size", "16", "--cornell-seconds", "0.01", "--threads", "1"];
    let text = String::from_utf8_lossy(&ok(&t.0, &args).stdout).into_owned();
    assert!(!text.contains("inf") && !text.contains("NaN"), "{text}");
    assert!(text.contains("n/a"), "{text}");
    let mut json = args.to_vec();
    json.push("--json");
    let v: serde_json::Value = serde_json::from_slice(&ok(&t.0, &json).stdout).unwrap();
    for key in ["camera_mrays_per_cpu_s", "incoherent_mrays_per_cpu_s", "cornell_msamples_per_cpu_s"] {
        assert!(v[key].is_null() || v[key].as_f64().is_some_and(f64::is_finite), "{key}: {}", v[key]);
    }
}
