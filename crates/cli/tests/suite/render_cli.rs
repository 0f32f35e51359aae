//! End-to-end tests of `lucent render` and `lucent merge` on small images of the built-in
//! Cornell box: resume reproduces an uninterrupted run bit for bit, merging independent seeds
//! weights by sample count and lowers the error, bad input fails on one line without touching
//! existing files.

use std::path::Path;
use std::process::{Command, Output};

use render::checkpoint::Checkpoint;
use render::image_io::{read_image, Image};

use crate::common::{lucent, run, Scratch};

fn run_ok(dir: &Path, args: &[&str]) -> Output {
    let out = run(dir, args);
    assert!(
        out.status.success(),
        "lucent {args:?} failed ({:?}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Small render of the built-in Cornell box: 32×32, `spp` samples, `seed`, extra arguments.
fn small(dir: &Path, spp: u32, seed: u64, extra: &[&str]) -> Output {
    let spp = spp.to_string();
    let seed = seed.to_string();
    let mut args = vec!["render", "--width", "32", "--height", "32", "--spp", &spp, "--seed", &seed, "--quiet"];
    args.extend_from_slice(extra);
    run_ok(dir, &args)
}

/// Mean absolute difference over all pixels and channels. (Not the squared error: path-traced
/// pixels have heavy-tailed noise, and one firefly decides a 32×32 MSE.)
fn mean_abs_error(a: &Image, b: &Image) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut s = 0.0;
    for (p, q) in a.rgb.iter().zip(&b.rgb) {
        for c in 0..3 {
            s += (p[c] as f64 - q[c] as f64).abs();
        }
    }
    s / (3 * a.rgb.len()) as f64
}

#[test]
fn resume_gives_the_same_image_as_one_uninterrupted_run() {
    let t = Scratch::new("resume");
    // 2N = 8 samples in one go (2 threads) ...
    small(&t.0, 8, 3, &["--threads", "2", "--out", &t.arg("full.pfm"), "--checkpoint", &t.arg("full.ckpt")]);
    // ... versus N = 4, then resumed to 8 in total (1 thread: passes must not depend on threads).
    small(&t.0, 4, 3, &["--threads", "1", "--out", &t.arg("half.pfm"), "--checkpoint", &t.arg("part.ckpt")]);
    let half = Checkpoint::read(&t.path("part.ckpt")).unwrap();
    assert_eq!(half.film.samples_per_pixel(), 4);
    run_ok(&t.0, &["render", "--resume", &t.arg("part.ckpt"), "--spp", "8", "--threads", "1", "--quiet", "--out", &t.arg("resumed.pfm")]);

    let full = std::fs::read(t.path("full.pfm")).unwrap();
    let resumed = std::fs::read(t.path("resumed.pfm")).unwrap();
    assert!(full == resumed, "resumed PFM differs from the uninterrupted one");
    assert!(full != std::fs::read(t.path("half.pfm")).unwrap(), "half render should differ");
    // The checkpoints agree too: same sums, same single run of seed 3, passes 0..8.
    let a = Checkpoint::read(&t.path("full.ckpt")).unwrap();
    let b = Checkpoint::read(&t.path("part.ckpt")).unwrap();
    assert_eq!(a.film, b.film);
    assert_eq!(a.runs, b.runs);
    assert_eq!(b.resume_point(&t.path("part.ckpt")).unwrap(), (3, 8));
    // And the image is the checkpoint's film converted to linear sRGB.
    let img = read_image(&t.path("full.pfm")).unwrap();
    assert_eq!(img, a.film.to_image());
}

#[test]
fn resume_without_spp_continues_to_the_checkpoint_target_and_a_finished_one_stays_put() {
    let t = Scratch::new("resume-target");
    small(&t.0, 6, 5, &["--out", &t.arg("full.pfm")]);
    // Ask for 6, save after 6: nothing left; re-running with --resume only writes the images.
    small(&t.0, 6, 5, &["--out", &t.arg("a.pfm"), "--checkpoint", &t.arg("a.ckpt")]);
    run_ok(&t.0, &["render", "--resume", &t.arg("a.ckpt"), "--quiet", "--out", &t.arg("again.pfm")]);
    assert_eq!(std::fs::read(t.path("full.pfm")).unwrap(), std::fs::read(t.path("again.pfm")).unwrap());
    assert_eq!(Checkpoint::read(&t.path("a.ckpt")).unwrap().film.samples_per_pixel(), 6);
}

/// Ctrl-C: the render finishes its pass, writes checkpoint and images, exits 130; resuming
/// gives the same image as an uninterrupted run.
#[cfg(unix)]
#[test]
fn ctrl_c_saves_and_resume_matches_an_uninterrupted_run() {
    use std::time::{Duration, Instant};
    let t = Scratch::new("ctrlc");
    let mut child = lucent()
        .current_dir(&t.0)
        .args(["render", "--width", "32", "--height", "32", "--spp", "100000000", "--seed", "9", "--quiet"])
        .args(["--checkpoint", &t.arg("c.ckpt"), "--checkpoint-interval", "0.05", "--out", &t.arg("i.pfm")])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(120);
    while !t.path("c.ckpt").exists() {
        assert!(Instant::now() < deadline, "no checkpoint written within 120 s");
        assert!(child.try_wait().unwrap().is_none(), "render ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(200));
    let kill = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("render did not stop after SIGINT");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(130), "exit status after Ctrl-C");
    let ck = Checkpoint::read(&t.path("c.ckpt")).unwrap();
    let k = ck.film.samples_per_pixel();
    assert!(k >= 1);
    // The image written on interrupt is the checkpoint's state.
    assert_eq!(read_image(&t.path("i.pfm")).unwrap(), ck.film.to_image());
    let total = (k + 3).to_string();
    run_ok(&t.0, &["render", "--resume", &t.arg("c.ckpt"), "--spp", &total, "--quiet", "--out", &t.arg("resumed.pfm")]);
    small(&t.0, (k + 3) as u32, 9, &["--out", &t.arg("straight.pfm")]);
    assert!(std::fs::read(t.path("resumed.pfm")).unwrap() == std::fs::read(t.path("straight.pfm")).unwrap());
}

#[test]
fn merge_weights_by_sample_count_and_two_seeds_beat_either() {
    let t = Scratch::new("merge");
    // Reference: 1024 spp of another seed.
    small(&t.0, 1024, 100, &["--out", &t.arg("ref.pfm")]);
    small(&t.0, 32, 1, &["--out", &t.arg("a.pfm"), "--checkpoint", &t.arg("a.ckpt")]);
    small(&t.0, 32, 2, &["--out", &t.arg("b.pfm"), "--checkpoint", &t.arg("b.ckpt")]);
    small(&t.0, 96, 3, &["--out", &t.arg("c.pfm"), "--checkpoint", &t.arg("c.ckpt")]);
    run_ok(&t.0, &["merge", &t.arg("a.ckpt"), &t.arg("b.ckpt"), "--out", &t.arg("ab.pfm"), "--out", &t.arg("ab.png"), "--checkpoint", &t.arg("ab.ckpt")]);
    run_ok(&t.0, &["merge", &t.arg("a.ckpt"), &t.arg("c.ckpt"), "--out", &t.arg("ac.pfm")]);

    let img = |f: &str| read_image(&t.path(f)).unwrap();
    let (reference, a, b, c) = (img("ref.pfm"), img("a.pfm"), img("b.pfm"), img("c.pfm"));
    let (ab, ac) = (img("ab.pfm"), img("ac.pfm"));

    // Weighting by counts: 32 + 96 samples → (32 a + 96 c) / 128 pixel by pixel (XYZ → RGB is
    // linear), not the plain average (a + c) / 2.
    let mut worst = 0.0f64;
    let mut unweighted_gap = 0.0f64;
    for i in 0..ac.rgb.len() {
        for k in 0..3 {
            let (pa, pc) = (a.rgb[i][k] as f64, c.rgb[i][k] as f64);
            let expect = (32.0 * pa + 96.0 * pc) / 128.0;
            let scale = pa.abs().max(pc.abs()).max(1e-3);
            worst = worst.max((ac.rgb[i][k] as f64 - expect).abs() / scale);
            unweighted_gap = unweighted_gap.max((0.5 * (pa + pc) - expect).abs() / scale);
        }
    }
    assert!(worst < 1e-5, "merged pixel differs from the count-weighted mean by {worst:e} (relative)");
    assert!(unweighted_gap > 1e-2, "test would not tell weighted from unweighted means");

    // Two independent 32-spp runs merged (64 spp) are closer to the reference than either. For
    // Gaussian-like noise the mean absolute error scales as σ: expected ratio to a single run
    // √((1/64 + 1/1024) / (1/32 + 1/1024)) ≈ 0.72 (0.68–0.76 seen over three seed pairs);
    // 0.9 leaves room for noise, and an unweighted or broken merge (ratio ≥ 1) fails.
    let (ea, eb, eab) = (mean_abs_error(&a, &reference), mean_abs_error(&b, &reference), mean_abs_error(&ab, &reference));
    assert!(eab < ea.min(eb), "merged error {eab:e} not below {ea:e} and {eb:e}");
    assert!(eab < 0.9 * 0.5 * (ea + eb), "merged error {eab:e} vs mean single-run error {:e}", 0.5 * (ea + eb));

    // The merged checkpoint holds both runs and can be merged again (with a third seed).
    let m = Checkpoint::read(&t.path("ab.ckpt")).unwrap();
    assert_eq!(m.film.samples_per_pixel(), 64);
    assert_eq!(m.runs.iter().map(|r| r.seed).collect::<Vec<_>>(), vec![1, 2]);
    run_ok(&t.0, &["merge", &t.arg("ab.ckpt"), &t.arg("c.ckpt"), "--out", &t.arg("abc.pfm")]);
    assert!(t.path("ab.png").exists());
}

/// Run `args` expecting failure: exit status 1, exactly one line on stderr, starting `lucent: error:`.
fn fails_on_one_line(dir: &Path, args: &[&str]) -> String {
    let out = run(dir, args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "lucent {args:?} should fail; stderr: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "lucent {args:?}: not one line: {stderr}");
    assert!(stderr.starts_with("lucent: error: "), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn bad_input_fails_on_one_line_and_leaves_existing_files_untouched() {
    let t = Scratch::new("bad");
    let precious = b"precious bytes that must survive";
    for f in ["out.png", "out.pfm", "keep.ckpt", "garbage.ckpt"] {
        std::fs::write(t.path(f), precious).unwrap();
    }
    std::fs::write(t.path("malformed.toml"), "[camera]\neye = [1, 2\n").unwrap();
    std::fs::write(t.path("unknown-key.toml"), "unit = \"mm\"\nbogus = 3\n").unwrap();
    // A real checkpoint of a 16×16 path-traced render, for mismatch tests.
    run_ok(&t.0, &["render", "--width", "16", "--height", "16", "--spp", "2", "--quiet", "--out", &t.arg("small.pfm"), "--checkpoint", &t.arg("small.ckpt")]);
    let small_ckpt = std::fs::read(t.path("small.ckpt")).unwrap();

    let out = ["--out", "out.png", "--out", "out.pfm", "--checkpoint", "keep.ckpt", "--width", "16", "--height", "16"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--spp", "-5"], "--spp"),
        (vec!["--spp", "0"], "--spp"),
        (vec!["--spp", "1.5"], "--spp"),
        (vec!["--time", "0"], "--time"),
        (vec!["--time", "-1"], "--time"),
        (vec!["--time", "nan"], "--time"),
        (vec!["--threads", "0"], "--threads"),
        (vec!["--seed", "-1"], "--seed"),
        (vec!["--integrator", "bidir"], "--integrator"),
        (vec!["--exposure", "inf"], "--exposure"),
        (vec!["--max-depth", "x"], "--max-depth"),
        (vec!["--checkpoint-interval", "0"], "--checkpoint-interval"),
        (vec!["--out", "picture.jpg"], "picture.jpg"),
        (vec!["--out", "no/such/folder/x.png"], "no/such/folder"),
        (vec!["missing.toml"], "missing.toml"),
        (vec!["malformed.toml"], "malformed.toml"),
        (vec!["unknown-key.toml"], "bogus"),
        (vec!["--resume", "garbage.ckpt"], "garbage.ckpt"),
        (vec!["--resume", "absent.ckpt"], "absent.ckpt"),
        (vec!["--resume", "small.ckpt", "--integrator", "ao"], "small.ckpt"),
        (vec!["--resume", "small.ckpt", "--seed", "7"], "small.ckpt"),
    ];
    for (extra, mention) in &cases {
        let mut args = vec!["render"];
        args.extend_from_slice(&out);
        args.extend_from_slice(extra);
        let msg = fails_on_one_line(&t.0, &args);
        assert!(msg.contains(mention), "lucent {args:?}: message should name `{mention}`: {msg}");
    }
    // Resolution mismatch: the 16×16 checkpoint resumed at 24×24.
    let msg = fails_on_one_line(&t.0, &["render", "--resume", "small.ckpt", "--width", "24", "--height", "24", "--out", "out.png"]);
    assert!(msg.contains("small.ckpt") && msg.contains("16×16"), "{msg}");
    // Another scene: the same 16×16 settings on a scene file that differs from the built-in box.
    let repo = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let scene = std::fs::read_to_string(format!("{repo}/scenes/cornell-box.toml")).unwrap();
    let moved = scene
        .replace("eye = [278.0, 273.0, -800.0]", "eye = [278.0, 273.0, -700.0]")
        .replace("\"../crates/", &format!("\"{repo}/crates/"));
    assert_ne!(moved, scene, "scene edit did not apply");
    std::fs::write(t.path("moved.toml"), &moved).unwrap();
    let out = run(&t.0, &["render", "moved.toml", "--resume", "small.ckpt", "--out", "out.png"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("small.ckpt") && stderr.contains("another scene"), "{stderr}");

    // Merge refusals: same seed twice, different resolutions, nothing to write.
    std::fs::write(t.path("copy.ckpt"), &small_ckpt).unwrap();
    let msg = fails_on_one_line(&t.0, &["merge", "small.ckpt", "copy.ckpt", "--out", "out.png"]);
    assert!(msg.contains("copy.ckpt") && msg.contains("seed 0"), "{msg}");
    run_ok(&t.0, &["render", "--width", "8", "--height", "8", "--spp", "1", "--seed", "4", "--quiet", "--out", "tiny.pfm", "--checkpoint", "tiny.ckpt"]);
    let msg = fails_on_one_line(&t.0, &["merge", "small.ckpt", "tiny.ckpt", "--out", "out.png", "--checkpoint", "keep.ckpt"]);
    assert!(msg.contains("tiny.ckpt"), "{msg}");
    fails_on_one_line(&t.0, &["merge", "small.ckpt", "tiny.ckpt"]);
    fails_on_one_line(&t.0, &["merge", "garbage.ckpt", "small.ckpt", "--out", "out.pfm"]);

    for f in ["out.png", "out.pfm", "keep.ckpt", "garbage.ckpt"] {
        assert_eq!(std::fs::read(t.path(f)).unwrap(), precious, "{f} was modified by a failed run");
    }
    assert_eq!(std::fs::read(t.path("small.ckpt")).unwrap(), small_ckpt, "small.ckpt was modified by a failed resume");
    // No temporary files left behind.
    for entry in std::fs::read_dir(&t.0).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.contains(".tmp-"), "left-over temporary {name}");
    }
}

#[test]
fn outputs_in_every_format_and_the_default_name_with_its_absolute_path() {
    let t = Scratch::new("outputs");
    // No --out: lucent.png in the working folder, reported with its absolute path on stdout.
    let out = run_ok(&t.0, &["render", "--width", "16", "--height", "16", "--spp", "2", "--quiet"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let png = t.path("lucent.png");
    assert!(png.exists());
    let abs = std::fs::canonicalize(&png).unwrap();
    assert!(
        stdout.lines().any(|l| Path::new(l.trim_start_matches("wrote ")).canonicalize().ok() == Some(abs.clone())),
        "stdout does not name {}: {stdout}",
        abs.display()
    );
    assert!(stdout.contains(&format!("{}", t.0.display())) || stdout.contains(&format!("{}", abs.display())), "{stdout}");

    // One run, three formats: EXR and PFM hold the same linear values; PNG is the same image encoded.
    small(&t.0, 4, 1, &["--out", &t.arg("x.exr"), "--out", &t.arg("x.pfm"), "--out", &t.arg("x.png")]);
    let (exr, pfm, png) = (read_image(&t.path("x.exr")).unwrap(), read_image(&t.path("x.pfm")).unwrap(), read_image(&t.path("x.png")).unwrap());
    assert_eq!(exr, pfm);
    assert_eq!((png.width, png.height), (32, 32));
    let mut max_diff = 0.0f32;
    for (p, q) in png.rgb.iter().zip(&pfm.rgb) {
        for k in 0..3 {
            // 8-bit sRGB quantisation: ≤ half a code step, at most ~0.0024 in linear at the top end.
            max_diff = max_diff.max((p[k] - q[k].clamp(0.0, 1.0)).abs());
        }
    }
    assert!(max_diff < 0.01, "PNG differs from PFM by {max_diff}");
}

#[test]
fn time_limit_stops_and_records_no_spp_target() {
    let t = Scratch::new("time");
    run_ok(&t.0, &["render", "--width", "16", "--height", "16", "--time", "0.3", "--quiet", "--out", &t.arg("t.pfm"), "--checkpoint", &t.arg("t.ckpt")]);
    let ck = Checkpoint::read(&t.path("t.ckpt")).unwrap();
    assert!(ck.film.samples_per_pixel() >= 1);
    assert_eq!(ck.target_spp, None);
    // Continuing a --time run needs a new stopping rule.
    let msg = fails_on_one_line(&t.0, &["render", "--resume", "t.ckpt", "--out", "u.pfm"]);
    assert!(msg.contains("t.ckpt") && msg.contains("--time"), "{msg}");
    let more = (ck.film.samples_per_pixel() + 2).to_string();
    run_ok(&t.0, &["render", "--resume", "t.ckpt", "--spp", &more, "--quiet", "--out", "u.pfm"]);
    assert_eq!(Checkpoint::read(&t.path("t.ckpt")).unwrap().film.samples_per_pixel(), ck.film.samples_per_pixel() + 2);
}

/// A checkpoint that cannot be written any more (its folder vanished mid-render) does not cost
/// the render: lucent warns, keeps going, still writes the images, and then fails (exit 1).
#[test]
fn lost_checkpoint_folder_still_yields_the_images() {
    use std::time::{Duration, Instant};
    let t = Scratch::new("lost-ckpt");
    std::fs::create_dir_all(t.path("ckpts")).unwrap();
    let child = lucent()
        .current_dir(&t.0)
        .args(["render", "--width", "16", "--height", "16", "--time", "2", "--quiet"])
        .args(["--checkpoint", "ckpts/c.ckpt", "--checkpoint-interval", "0.05", "--out", "img.pfm"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !t.path("ckpts/c.ckpt").exists() {
        assert!(Instant::now() < deadline, "no checkpoint within 60 s");
        std::thread::sleep(Duration::from_millis(10));
    }
    std::fs::remove_dir_all(t.path("ckpts")).unwrap();
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("warning") && stderr.contains("c.ckpt"), "{stderr}");
    assert!(stderr.lines().last().unwrap().starts_with("lucent: error: "), "{stderr}");
    let img = read_image(&t.path("img.pfm")).unwrap();
    assert!(img.rgb.iter().any(|p| p[1] > 0.0));
}

/// `lucent bench --json` prints the documented JSON keys (a contract for scripts) with sane values; the packet,
/// batched and single-ray camera traversals found the same hits (the command checks and fails
/// otherwise); `--scaling` adds the one-thread figure. Speeds are not asserted (benchmarks, not tests).
#[test]
fn bench_json_has_the_contract_keys() {
    let out = lucent()
        .args(["bench", "--json", "--size", "64", "--mrays", "0.02", "--reps", "1", "--cornell-seconds", "0.3", "--scaling", "--threads", "2"])
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in ["bvh_build_s", "camera_mrays_per_s", "incoherent_mrays_per_s", "cornell_msamples_per_s", "camera_packet_mrays_per_s", "cornell_msamples_per_s_1_thread", "cornell_thread_speedup"] {
        let x = v[key].as_f64().unwrap_or_else(|| panic!("{key} missing or not a number in {v}"));
        assert!(x > 0.0 && x.is_finite(), "{key} = {x}");
    }
    assert_eq!(v["threads"].as_u64(), Some(2));
    assert_eq!(v["triangles"].as_u64(), Some(47794), "the bundled 48k dragon");
    let hit = v["camera_hit_fraction"].as_f64().unwrap();
    assert!(hit > 0.05 && hit < 0.95, "camera hit fraction {hit}");
}

/// `lucent bench bssrdf --json` (BSSRDF vs volpath, time to equal noise) on a tiny marble bunny:
/// the keys are present, both estimators see the same object (region means within 15 %, the
/// BSSRDF being a model), the speed-up is σ²·CPU of volpath over that of the BSSRDF, and bad
/// arguments are one-line errors. Speeds are not asserted.
#[test]
fn bench_bssrdf_json_reports_both_estimators() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let out = lucent()
        .args(["bench", "bssrdf", "--json", "--width", "48", "--height", "48", "--volpath-spp", "8", "--bssrdf-spp", "4", "--threads", "2"])
        .current_dir(root)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let num = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} missing or not a number in {v}"));
    for key in ["volpath_cpu_s", "volpath_sigma_y", "bssrdf_cpu_s", "bssrdf_sigma_y", "volpath_mean_y", "bssrdf_mean_y"] {
        let x = num(key);
        assert!(x >= 0.0 && x.is_finite(), "{key} = {x}");
    }
    let (vm, bm) = (num("volpath_mean_y"), num("bssrdf_mean_y"));
    assert!(vm > 0.1 && (bm / vm - 1.0).abs() < 0.15, "region means: volpath {vm}, BSSRDF {bm}");
    let s2 = |p: &str| num(&format!("{p}_sigma_y")).powi(2) * num(&format!("{p}_cpu_s"));
    let speedup = num("bssrdf_speedup_vs_volpath");
    assert!((speedup - s2("volpath") / s2("bssrdf")).abs() <= 1e-9 * speedup, "{v}");
    assert_eq!(v["volpath_spp"].as_u64(), Some(8));
    for bad in [&["--seeds", "1"][..], &["--region", "0.6,0.2,0.5,0.9"], &["--bssrdf-spp", "0"], &["scenes/cornell-box.toml"]] {
        let out = lucent().args(["bench", "bssrdf", "--width", "8", "--height", "8"]).args(bad).current_dir(root).output().unwrap();
        assert!(!out.status.success(), "{bad:?} was accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.trim().lines().count() == 1 && err.starts_with("lucent: error: "), "{bad:?}: {err}");
    }
}
