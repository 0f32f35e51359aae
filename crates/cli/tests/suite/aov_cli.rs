//! `lucent render --aov … --spectral-bins …` and `lucent merge`: the multi-channel EXR, what the
//! command says it wrote, resume and merge with AOVs, and bad input (one line, exit ≠ 0, no files).

use std::path::Path;

use render::image_io::read_exr_channels;

use crate::common::{run, Scratch};

const AOVS: &str = "albedo,normal,depth,position,object_id,variance";

fn render_ok(dir: &Path, args: &[&str]) -> (String, String) {
    let out = run(dir, args);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned());
    assert!(out.status.success(), "lucent {args:?} failed: {stderr}");
    (stdout, stderr)
}

/// Runs a command that must fail; returns its one stderr line.
fn fails(dir: &Path, args: &[&str]) -> String {
    let out = run(dir, args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "lucent {args:?} should fail");
    assert_eq!(out.status.code(), Some(1), "lucent {args:?}: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line expected: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn aovs_and_spectral_bins_are_channels_of_the_exr_and_the_command_says_so() {
    let s = Scratch::new("aov-exr");
    let (stdout, stderr) = render_ok(
        &s.0,
        &["render", "--width", "16", "--height", "12", "--spp", "4", "--out", "a.exr", "--out", "a.png", "--aov", AOVS, "--spectral-bins", "400:700:10"],
    );
    let exr = s.path("a.exr").canonicalize().unwrap();
    assert!(stdout.lines().any(|l| l == format!("wrote {}", exr.display())), "{stdout}");
    assert!(stderr.contains("a.exr: channels R, G, B, albedo.R") && stderr.contains("S0.405nm … S0.695nm (30 bins)"), "{stderr}");
    assert!(stderr.contains("a.png: RGB image"), "{stderr}");
    let (w, h, channels, attrs) = read_exr_channels(&exr).unwrap();
    assert_eq!((w, h), (16, 12));
    let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    for want in ["R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z", "depth.T", "P.X", "P.Y", "P.Z", "object_id.I", "variance.R", "variance.G", "variance.B", "S0.405nm", "S0.695nm"] {
        assert!(names.contains(&want), "missing {want}: {names:?}");
    }
    assert_eq!(names.len(), 17 + 30);
    assert!(attrs.iter().any(|(k, v)| k == "spectralLayoutVersion" && v == "1.0"), "{attrs:?}");
    // Inside the Cornell box (16×12 crops its square view: the side columns look past it) every
    // pixel has an object and a depth within the box; where every sample escapes, depth 0 and
    // object −1 together.
    let get = |name: &str| &channels.iter().find(|(n, _)| n == name).unwrap().1;
    let (depth, id) = (get("depth.T"), get("object_id.I"));
    assert!(depth.iter().all(|&d| (0.0..5.0).contains(&d)), "{depth:?}");
    assert!(depth.iter().filter(|&&d| d > 0.5).count() > 16 * 12 / 2, "{depth:?}");
    for k in 0..depth.len() {
        assert_eq!(depth[k] == 0.0, id[k] == -1.0, "pixel {k}: depth {} object {}", depth[k], id[k]);
    }
    // The plain RGB reader still reads the image of a multi-channel file.
    let rgb = render::image_io::read_image(&exr).unwrap();
    assert_eq!(rgb.rgb[0][0], get("R")[0]);
}

#[test]
fn resume_and_merge_carry_the_aovs() {
    let s = Scratch::new("aov-merge");
    let base = ["render", "--width", "10", "--height", "8", "--aov", "albedo,depth,variance", "--spectral-bins", "360:830:47"];
    let with = |extra: &[&str]| -> Vec<String> { base.iter().chain(extra).map(|x| x.to_string()).collect() };
    // One run of 6 spp, and the same run interrupted at 3 and resumed: the same EXR, bit for bit.
    let straight = with(&["--spp", "6", "--seed", "1", "--out", "s.exr"]);
    render_ok(&s.0, &strs(&straight));
    let first = with(&["--spp", "3", "--seed", "1", "--out", "r.exr", "--checkpoint", "r.ckpt"]);
    render_ok(&s.0, &strs(&first));
    // Resuming keeps the checkpoint's AOVs (no --aov needed) ...
    render_ok(&s.0, &["render", "--resume", "r.ckpt", "--spp", "6", "--out", "r.exr"]);
    let read = |f: &str| read_exr_channels(&s.path(f)).unwrap().2;
    assert_eq!(read("s.exr"), read("r.exr"));
    // ... and refuses other ones.
    let err = fails(&s.0, &["render", "--resume", "r.ckpt", "--spp", "8", "--aov", "normal", "--out", "x.exr"]);
    assert!(err.contains("r.ckpt") && err.contains("normal"), "{err}");
    // Two seeds merged: the AOV channels of the merge are the sample-weighted means.
    let second = with(&["--spp", "2", "--seed", "2", "--out", "b.exr", "--checkpoint", "b.ckpt"]);
    render_ok(&s.0, &strs(&second));
    let (stdout, _) = render_ok(&s.0, &["merge", "r.ckpt", "b.ckpt", "--out", "m.exr"]);
    assert!(stdout.contains("m.exr"), "{stdout}");
    let (r, b, m) = (read("r.exr"), read("b.exr"), read("m.exr"));
    assert_eq!(m.len(), r.len());
    for ((name, mv), ((_, rv), (_, bv))) in m.iter().zip(r.iter().zip(&b)) {
        if name.starts_with("variance") {
            continue; // not a mean
        }
        for k in 0..mv.len() {
            let expect = (6.0 * rv[k] as f64 + 2.0 * bv[k] as f64) / 8.0;
            assert!((mv[k] as f64 - expect).abs() <= 1e-5 * expect.abs().max(1.0), "{name}[{k}]: {} vs {expect}", mv[k]);
        }
    }
    // A part without those AOVs cannot be merged in.
    render_ok(&s.0, &["render", "--width", "10", "--height", "8", "--spp", "1", "--seed", "3", "--out", "c.png", "--checkpoint", "c.ckpt"]);
    let err = fails(&s.0, &["merge", "r.ckpt", "c.ckpt", "--out", "n.exr"]);
    assert!(err.contains("c.ckpt") && err.contains("AOVs"), "{err}");
    assert!(!s.path("n.exr").exists());
}

#[test]
fn bad_aovs_bins_and_outputs_fail_on_one_line_and_write_nothing() {
    let s = Scratch::new("aov-bad");
    let small = ["render", "--width", "4", "--height", "4", "--spp", "1"];
    let case = |extra: &[&str]| -> String {
        let args: Vec<&str> = small.iter().chain(extra).copied().collect();
        fails(&s.0, &args)
    };
    let e = case(&["--aov", "albedo,emission", "--out", "x.exr"]);
    assert!(e.contains("unknown AOV `emission`") && e.contains("albedo, normal, depth, position, object_id, variance"), "{e}");
    let e = case(&["--spectral-bins", "300:700:10", "--out", "x.exr"]);
    assert!(e.contains("--spectral-bins") && e.contains("360"), "{e}");
    let e = case(&["--spectral-bins", "400:900:10", "--out", "x.exr"]);
    assert!(e.contains("830"), "{e}");
    let e = case(&["--spectral-bins", "400:700:0", "--out", "x.exr"]);
    assert!(e.contains("width"), "{e}");
    let e = case(&["--spectral-bins", "400:700", "--out", "x.exr"]);
    assert!(e.contains("START:END:WIDTH"), "{e}");
    let e = case(&["--aov", "depth", "--out", "x.png"]);
    assert!(e.contains(".exr"), "{e}");
    let e = case(&["--aov", "depth", "--out", "no/such/folder/x.exr"]);
    assert!(e.contains("does not exist"), "{e}");
    std::fs::create_dir(s.path("dir.exr")).unwrap();
    let e = case(&["--aov", "depth", "--out", "dir.exr"]);
    assert!(e.contains("is a folder"), "{e}");
    let e = case(&["--denoise", "--out", "x.exr"]);
    assert!(e.contains("`denoise` cargo feature"), "{e}");
    // Nothing was written, not even a temporary file.
    assert_eq!(files(&s.0), vec!["dir.exr".to_string()]);
}
