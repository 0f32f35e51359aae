//! `lucent mie | medium | bssrdf | fit` at and beyond their limits: every input ends in a correct
//! result or a one-line error naming the flag, file or field (exit ≠ 0, no panic, promptly), and
//! text output prints measured quantities without float noise.

use optics::reflectometry::dipole_rd_per_mm2;
use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lucent-robustness-optics-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn lucent(args: &[&str]) -> (bool, String, String) {
    let t = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).output().unwrap();
    assert!(t.elapsed() < Duration::from_secs(20), "lucent {args:?} took {:?}", t.elapsed());
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!err.contains("panicked"), "lucent {args:?} panicked: {err}");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), err)
}

/// Runs `lucent args`, expects a one-line error containing every one of `needles`.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let (ok, out, err) = lucent(args);
    assert!(!ok, "lucent {args:?} succeeded: {out}");
    assert_eq!(err.trim_end().lines().count(), 1, "lucent {args:?}: not one line: {err}");
    for n in needles {
        assert!(err.contains(n), "lucent {args:?}: {n:?} missing in {err}");
    }
    err
}

fn json(args: &[&str]) -> Value {
    let (ok, out, err) = lucent(args);
    assert!(ok, "lucent {args:?} failed: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("lucent {args:?}: {e}: {out}"))
}

fn media(name: &str) -> String {
    format!("{}/../../media/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// No run of ≥ 10 digits after the decimal point in text output (e.g. 0.0021000000000000003).
fn no_float_noise(text: &str) {
    let mut run = 0;
    let mut after_point = false;
    for ch in text.chars() {
        if ch == '.' {
            after_point = true;
            run = 0;
        } else if ch.is_ascii_digit() && after_point {
            run += 1;
            assert!(run < 10, "float noise in:\n{text}");
        } else {
            after_point = false;
            run = 0;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// mie

#[test]
fn mie_refuses_sizes_beyond_the_bounded_work() {
    refused(&["mie", "--x", "1", "--m", "1.5+1e308i"], &["--x, --m", "10000000"]);
    refused(&["mie", "--x", "1e4", "--m", "1e6+1e6i"], &["10000000"]);
    refused(&["mie", "--x", "2e6", "--m", "1.5"], &["1000000 "]);
    refused(&["mie", "--x", "1e-300", "--m", "1.5"], &["1e-30"]);
    refused(&["mie", "--radius-um", "1", "--wavelength-nm", "1e-30", "--n-particle", "1.5"], &["--wavelength-nm"]);
    refused(&["mie", "--x", "nan", "--m", "1.5"], &["--x"]);
    // Normal use keeps working: x = 10⁵ with m = 1.5 (Q_ext → 2).
    let o = json(&["mie", "--x", "1e5", "--m", "1.5", "--json"]);
    assert!((o["qext"].as_f64().unwrap() - 2.0).abs() < 0.01, "{o}");
}

/// A tiny sphere gives the Rayleigh values Q_sca = 8/3 x⁴|K|², Q_abs = 4x Im K (no `null`).
#[test]
fn mie_small_sphere_is_rayleigh() {
    for (x, m) in [(1e-6, (1.5, 0.0)), (1e-20, (1.33, 0.01))] {
        let ms = format!("{}+{}i", m.0, m.1);
        let o = json(&["mie", "--x", &x.to_string(), "--m", &ms, "--json"]);
        let m = optics::mie::Complex64::new(m.0, m.1);
        let k = (m * m - 1.0) / (m * m + 2.0);
        let qsca = 8.0 / 3.0 * f64::powi(x, 4) * k.norm_sqr();
        let qabs = 4.0 * x * k.im;
        let got = |k: &str| o[k].as_f64().unwrap_or_else(|| panic!("{k} missing or null: {o}"));
        assert!((got("qsca") / qsca - 1.0).abs() < 1e-6, "{o}");
        if m.im > 0.0 {
            assert!((got("qabs") / qabs - 1.0).abs() < 1e-6, "{o}");
        } else {
            assert_eq!(got("qabs"), 0.0);
        }
    }
}

#[test]
fn mie_text_output_has_no_round_off() {
    let (ok, out, err) = lucent(&["mie", "--x", "3", "--m", "1.5"]);
    assert!(ok, "{err}");
    let qabs = out.lines().find(|l| l.starts_with("qabs")).unwrap();
    assert_eq!(qabs.split_whitespace().nth(1), Some("0"), "{out}");
    assert!(!out.contains("e-16") && !out.contains("e-17"), "{out}");
    // The same wavelength flag as `bssrdf --wavelength-nm`; the old spelling is a hidden alias.
    let a = json(&["mie", "--radius-um", "0.5", "--wavelength-nm", "550", "--n-particle", "1.5", "--json"]);
    let b = json(&["mie", "--radius-um", "0.5", "--lambda-nm", "550", "--n-particle", "1.5", "--json"]);
    assert_eq!(a, b);
}

// ---------------------------------------------------------------------------------------------
// medium

#[test]
fn medium_refuses_recipes_beyond_the_supported_sizes() {
    let beads = media("polystyrene-beads.toml");
    for l in ["1e-9", "1e-30"] {
        refused(&["medium", &beads, "--wavelengths-nm", l], &["polystyrene", "terms"]);
    }
    let text = std::fs::read_to_string(&beads).unwrap();
    for host in ["4294967296", "9223372036854775807"] {
        let p = tmp(&format!("host-{host}.toml"), &text.replace("index = 1.333", &format!("index = {host}")));
        refused(&["medium", p.to_str().unwrap()], &["recipe", "terms"]);
    }
    for n in ["9223372036854775807", "100000000"] {
        let p = tmp(&format!("angles-{n}.toml"), &text.replace("phase_angles = 181", &format!("phase_angles = {n}")));
        refused(&["medium", p.to_str().unwrap()], &["phase_angles", "100000"]);
    }
    refused(&["medium", &beads, "--phase-angles", "100001"], &["--phase-angles", "100000"]);
    let p = tmp("absorbing.toml", &text.replace("\"1.59+0i\"", "\"1+1e7i\""));
    refused(&["medium", p.to_str().unwrap()], &["recurrence"]);
}

/// Text table: the JSON names (`wavelength_nm`, …), σ_a exactly 0 for a non-absorbing recipe,
/// and values to 6 significant digits matching the JSON.
#[test]
fn medium_text_table_matches_json_names_and_values() {
    let beads = media("polystyrene-beads.toml");
    let (ok, out, err) = lucent(&["medium", &beads]);
    assert!(ok, "{err}");
    no_float_noise(&out);
    assert!(!out.contains("lambda_nm") && !out.contains("/mm"), "{out}");
    let header = out.lines().find(|l| l.trim_start().starts_with("wavelength_nm")).expect("header");
    assert!(header.contains("sigma_s_per_mm") && header.contains("sigma_a_per_mm"), "{header}");
    let o = json(&["medium", &beads, "--json"]);
    let rows: Vec<Vec<f64>> = out
        .lines()
        .filter(|l| l.trim_start().starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), o["wavelength_nm"].as_array().unwrap().len());
    for (i, r) in rows.iter().enumerate() {
        let ss = o["sigma_s_per_mm"][i].as_f64().unwrap();
        assert!((r[1] / ss - 1.0).abs() < 1e-5, "{r:?} vs {ss}");
        assert_eq!(r[2], 0.0);
        assert_eq!(o["sigma_a_per_mm"][i].as_f64().unwrap(), 0.0);
    }
}

// ---------------------------------------------------------------------------------------------
// bssrdf

/// R_d lies in [0, 1] for every supported η (η = 100 used to print −0.0165, η = 10 a closed form
/// of 2.29), and η outside [0.01, 100] is refused with the range.
#[test]
fn bssrdf_rd_is_physical_for_large_eta() {
    for eta in ["10", "100", "0.05", "3"] {
        for model in ["standard", "directional-corrected"] {
            let o = json(&["bssrdf", "--model", model, "--eta", eta, "--sigma-s-per-mm", "1", "--sigma-a-per-mm", "0.01", "--rd", "--json"]);
            let rd = o["rd"].as_f64().unwrap();
            let cf = o["rd_closed_form"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&cf) && rd >= 0.0 && o["a"].as_f64().unwrap() > 0.0, "eta {eta} {model}: {o}");
            if model == "standard" {
                assert!(rd <= 1.0 && (rd - cf).abs() < 1e-3, "eta {eta}: {o}");
            }
        }
    }
    refused(&["bssrdf", "--eta", "1000", "--sigma-s-per-mm", "1", "--sigma-a-per-mm", "0.01"], &["eta", "[0.01, 100]"]);
}

#[test]
fn bssrdf_refuses_non_finite_numbers_and_far_profiles() {
    let base = ["bssrdf", "--eta", "1.3", "--sigma-s-per-mm", "1", "--sigma-a-per-mm", "0.01"];
    for (flag, v) in [("--eta", "nan"), ("--sigma-s-per-mm", "inf"), ("--sigma-a-per-mm", "NaN"), ("--g", "-inf")] {
        let mut a = base.to_vec();
        match a.iter().position(|s| *s == flag) {
            Some(i) => a[i + 1] = v,
            None => a.extend([flag, v]),
        }
        refused(&a, &[flag]);
    }
    let mut a = base.to_vec();
    a.extend(["--profile-mm", "1e308"]);
    refused(&a, &["--profile-mm", "1e9"]);
    let mut a = base.to_vec();
    a.extend(["--profile-mm", "0,1,1e6", "--json"]);
    let o = json(&a);
    let p: Vec<f64> = o["profile"].as_array().unwrap().iter().map(|v| v.as_f64().expect("no null")).collect();
    assert!(p[0] > p[1] && p[1] > p[2] && p[2] >= 0.0, "{p:?}");
}

#[test]
fn bssrdf_text_has_meaningful_digits_and_one_unit_style() {
    let (ok, out, err) = lucent(&["bssrdf", "--eta", "1.3", "--sigma-s-per-mm", "2.1", "--sigma-a-per-mm", "0.0021", "--rd"]);
    assert!(ok, "{err}");
    no_float_noise(&out);
    assert!(out.contains("sigma_a 0.0021 mm⁻¹") && !out.contains("/mm") && !out.contains("mm^-1"), "{out}");
    // `--wavelength-nm` as in `mie`; `--lambda-nm` stays a hidden alias.
    let a = json(&["bssrdf", "--milk", "--fat-percent", "3.5", "--wavelength-nm", "550", "--rd", "--json"]);
    let b = json(&["bssrdf", "--milk", "--fat-percent", "3.5", "--lambda-nm", "550", "--rd", "--json"]);
    assert_eq!(a, b);
    let (_, help, _) = lucent(&["bssrdf", "--help"]);
    assert!(help.contains("--wavelength-nm") && !help.contains("--lambda-nm"), "{help}");
}

// ---------------------------------------------------------------------------------------------
// fit

fn binned_profile(h: f64) -> PathBuf {
    let mut s = String::from("r_mm,reflectance\n");
    for k in 0..40 {
        let r = (k as f64 + 0.5) * h;
        s.push_str(&format!("{r},{}\n", dipole_rd_per_mm2(r, 0.01, 1.0, 1.33)));
    }
    tmp(&format!("binned-{h}.csv"), &s)
}

#[test]
fn fit_refuses_non_finite_numbers() {
    let p = binned_profile(0.25);
    let p = p.to_str().unwrap();
    for (flag, v) in [("--r-min-mm", "nan"), ("--r-max-mm", "inf"), ("--noise", "NaN"), ("--eta", "nan")] {
        let mut a = vec!["fit", "reflectance", p];
        if flag != "--eta" {
            a.extend(["--eta", "1.33"]);
        }
        a.extend([flag, v]);
        refused(&a, &[flag]);
    }
    refused(&["fit", "reflectance", p, "--eta", "1.33", "--r-min-mm=-1"], &["--r-min-mm"]);
    refused(&["fit", "oblique", p, "--eta", "1.33", "--incidence-deg", "nan"], &["--incidence-deg"]);
    refused(&["fit", "particles", p, "--medium", "milk", "--protein-percent", "inf"], &["--protein-percent"]);
}

/// Bins of 50/101 mm: the note says 0.49505 mm, not 0.49504950495049505; units are mm⁻¹.
#[test]
fn fit_text_has_meaningful_digits() {
    let p = binned_profile(50.0 / 101.0);
    let (ok, out, err) = lucent(&["fit", "reflectance", p.to_str().unwrap(), "--eta", "1.33", "--r-min-mm", "1"]);
    assert!(ok, "{err}");
    no_float_noise(&out);
    assert!(out.contains("0.49505 mm bins"), "{out}");
    assert!(out.contains("mm⁻¹") && !out.contains("mm^-1"), "{out}");
}

/// A misspelt particle name is blamed on `--particle` and the recipe, not on the data file.
#[test]
fn fit_particles_names_the_right_culprit() {
    let spectra = tmp("beads.csv", "wavelength_nm,sigma_s_prime_per_mm\n450,0.4\n500,0.36\n550,0.33\n600,0.3\n650,0.27\n");
    let beads = media("polystyrene-beads.toml");
    let err = refused(
        &["fit", "particles", spectra.to_str().unwrap(), "--medium", &beads, "--particle", "polystyren"],
        &["--particle", "\"polystyren\"", "polystyrene-beads.toml", "\"polystyrene\""],
    );
    assert!(!err.contains("beads.csv"), "{err}");
}

/// Standard output that cannot be written ends the command without a panic: a full disk
/// (/dev/full) in one line naming standard output with status 1, a closed pipe with status 141
/// (as a process ended by SIGPIPE) and nothing on standard error.
#[test]
fn unwritable_standard_output_is_not_a_panic() {
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
    if let Ok(full) = full {
        let out = Command::new(env!("CARGO_BIN_EXE_lucent")).args(["mie", "--x", "1", "--m", "1.33", "--json"]).stdout(full).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains("writing to standard output") && !err.contains("panicked"), "{err}");
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_lucent"))
        .args(["mie", "--x", "1", "--m", "1.33", "--angles-deg", "0:180:0.001"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Read one byte, then close the pipe while lucent is still writing.
    use std::io::Read;
    let mut first = [0u8; 1];
    child.stdout.take().unwrap().read_exact(&mut first).unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(out.status.code(), Some(141), "{err}");
}

/// Wavelengths the milk model has no data near, an empty distance list and a negative exclusion
/// radius are refused naming the flag; a huge wavelength is echoed in scientific notation.
#[test]
fn milk_wavelengths_empty_profiles_and_negative_exclusions_are_refused() {
    let e = refused(&["medium", "milk", "--fat-percent", "3.5", "--wavelengths-nm", "1e300"], &["--wavelengths-nm", "1e300", "300"]);
    assert!(e.len() < 240, "{e}");
    refused(&["medium", "milk", "--fat-percent", "3.5", "--wavelengths-nm", "200,550"], &["--wavelengths-nm", "200 nm"]);
    refused(&["bssrdf", "--milk", "--fat-percent", "3.5", "--wavelength-nm", "5000"], &["--wavelength-nm", "5000"]);
    refused(&["bssrdf", "--eta", "1.3", "--g", "0", "--sigma-s-per-mm", "1", "--sigma-a-per-mm", "0.01", "--profile-mm", ","], &["--profile-mm", "no distances"]);
    let csv = tmp("oblique.csv", "x_mm,value\n-2,0.1\n-1,0.3\n0,1\n1,0.5\n2,0.2\n3,0.1\n");
    refused(&["fit", "oblique", csv.to_str().unwrap(), "--incidence-deg", "30", "--eta", "1.33", "--exclude-mm", "-1"], &["--exclude-mm"]);
}
