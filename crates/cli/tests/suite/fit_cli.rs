//! End-to-end tests of `lucent fit reflectance | oblique | particles`: JSON contract keys, values
//! recovered from model data, and one-line errors on bad input.

use optics::reflectometry::dipole_rd_per_mm2;
use std::path::PathBuf;
use std::process::Command;

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lucent-fit-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn lucent(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

fn dipole_csv(mua: f64, musp: f64, eta: f64, lambdas: &[Option<f64>], relative: bool) -> String {
    let mut s = String::new();
    s.push_str(if lambdas[0].is_some() { "wavelength_nm," } else { "" });
    s.push_str(if relative { "r_mm,relative\n" } else { "r_mm,reflectance\n" });
    for (i, l) in lambdas.iter().enumerate() {
        for k in 1..=50 {
            let r = 0.3 * k as f64;
            // Deterministic ±1 % ripple as noise.
            let v = dipole_rd_per_mm2(r, mua * (1.0 + i as f64), musp, eta) * (1.0 + 0.01 * ((k * 7 + i) as f64).sin());
            if let Some(l) = l {
                s.push_str(&format!("{l},"));
            }
            s.push_str(&format!("{r},{}\n", if relative { v * 1e3 } else { v }));
        }
    }
    s
}

#[test]
fn reflectance_json_has_the_contract_keys_and_recovers_the_parameters() {
    let p = tmp("abs.csv", &dipole_csv(0.01, 2.0, 1.4, &[None], false));
    let (ok, out, err) = lucent(&["fit", "reflectance", p.to_str().unwrap(), "--eta", "1.4", "--json"]);
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    for k in ["sigma_a_per_mm", "sigma_s_prime_per_mm", "sigma_a_ci_per_mm", "sigma_s_prime_ci_per_mm", "residual_rms"] {
        assert!(j.get(k).is_some(), "missing {k}: {out}");
    }
    let sa = j["sigma_a_per_mm"].as_f64().unwrap();
    let ss = j["sigma_s_prime_per_mm"].as_f64().unwrap();
    assert!((sa / 0.01 - 1.0).abs() < 0.1 && (ss / 2.0 - 1.0).abs() < 0.03, "{out}");
    let ci = j["sigma_s_prime_ci_per_mm"].as_array().unwrap();
    assert!(ci[0].as_f64().unwrap() < ss && ss < ci[1].as_f64().unwrap());
}

#[test]
fn several_wavelengths_give_arrays() {
    let p = tmp("multi.csv", &dipole_csv(0.01, 2.0, 1.3, &[Some(450.0), Some(550.0)], false));
    let (ok, out, err) = lucent(&["fit", "reflectance", p.to_str().unwrap(), "--eta", "1.3", "--model", "dipole", "--json"]);
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let sa = j["sigma_a_per_mm"].as_array().unwrap();
    assert_eq!(sa.len(), 2);
    assert_eq!(j["sigma_s_prime_ci_per_mm"].as_array().unwrap().len(), 2);
    // The second wavelength was generated with twice the absorption.
    let ratio = sa[1].as_f64().unwrap() / sa[0].as_f64().unwrap();
    assert!((ratio - 2.0).abs() < 0.05, "{out}");
    assert_eq!(j["wavelength_nm"], serde_json::json!([450.0, 550.0]));
}

#[test]
fn relative_data_say_what_is_identifiable() {
    let p = tmp("rel.csv", &dipole_csv(0.01, 2.0, 1.3, &[None], true));
    let (ok, out, err) = lucent(&["fit", "reflectance", p.to_str().unwrap(), "--eta", "1.3", "--json"]);
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["relative"], true);
    let meff = (3.0f64 * 0.01 * 2.01).sqrt();
    assert!((j["mu_eff_per_mm"].as_f64().unwrap() / meff - 1.0).abs() < 0.03, "{out}");
    assert!(j["notes"].to_string().contains("relative data"), "{out}");
}

#[test]
fn bad_input_gives_one_line_errors_naming_file_and_column() {
    let cases = [
        ("empty.csv", "", "empty"),
        ("nonmono.csv", "r_mm,reflectance\n1,0.1\n2,0.05\n1.5,0.03\n", "line 4: column r_mm"),
        ("neg.csv", "r_mm,reflectance\n1,0.1\n2,-0.05\n", "line 3: column reflectance: negative"),
        ("nocol.csv", "r_mm,value\n1,0.1\n", "missing column reflectance"),
    ];
    for (name, text, want) in cases {
        let p = tmp(name, text);
        let (ok, _, err) = lucent(&["fit", "reflectance", p.to_str().unwrap(), "--eta", "1.3"]);
        assert!(!ok, "{name} accepted");
        let line = err.trim_end();
        assert!(!line.contains('\n') && line.contains(name) && line.contains(want), "{name}: {err}");
    }
    let p = tmp("x.csv", &dipole_csv(0.01, 2.0, 1.3, &[None], false));
    let (ok, _, err) = lucent(&["fit", "reflectance", p.to_str().unwrap(), "--eta", "1.37", "--model", "montecarlo"]);
    assert!(!ok && err.contains("mc-table"), "{err}");
    let (ok, _, err) = lucent(&["fit", "reflectance", "/nonexistent/data.csv", "--eta", "1.3"]);
    assert!(!ok && err.contains("/nonexistent/data.csv"), "{err}");
    let s = tmp("spectra.csv", "wavelength_nm,sigma_s_prime_per_mm\n500,1\n450,1.1\n");
    let (ok, _, err) = lucent(&["fit", "particles", s.to_str().unwrap(), "--medium", "milk"]);
    assert!(!ok && err.contains("spectra.csv") && err.contains("line 3"), "{err}");
}

#[test]
fn particles_json_has_the_contract_keys() {
    let lambda: Vec<f64> = (0..6).map(|k| 420.0 + 60.0 * k as f64).collect();
    let (sp, sa) = optics::fitting::milk_model_spectra(3.0, 3.4, 12.0, &lambda).unwrap();
    let mut text = "wavelength_nm,sigma_s_prime_per_mm,sigma_a_per_mm\n".to_string();
    for i in 0..6 {
        text.push_str(&format!("{},{},{}\n", lambda[i], sp[i], sa[i]));
    }
    let p = tmp("milk.csv", &text);
    let (ok, out, err) = lucent(&["fit", "particles", p.to_str().unwrap(), "--medium", "milk", "--protein-percent", "3.4", "--json"]);
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    for k in ["fat_percent", "pressure_mpa", "fat_percent_ci", "pressure_mpa_ci", "residual_rms"] {
        assert!(j.get(k).is_some(), "missing {k}: {out}");
    }
    assert!((j["fat_percent"].as_f64().unwrap() - 3.0).abs() < 0.01, "{out}");
    assert!((j["pressure_mpa"].as_f64().unwrap() / 12.0 - 1.0).abs() < 0.01, "{out}");
}

#[test]
fn oblique_reads_a_line_profile_and_reports_sigma_s_prime() {
    // A diffusion-theory line profile centred at Δx = 3D sin θ_t (θ_i = 40°, n = 1.33).
    let (mua, musp, n, deg) = (0.02, 1.2, 1.33, 40.0f64);
    let d = 1.0 / (3.0 * (0.35 * mua + musp));
    let dx = 3.0 * d * deg.to_radians().sin() / n;
    let mut text = "x_mm,rd_per_mm2,rd_per_mm2_stderr\n".to_string();
    for k in 0..121 {
        let x = -6.0 + 0.1 * k as f64;
        let v = dipole_rd_per_mm2((x - dx).abs(), mua, musp, n);
        text.push_str(&format!("{x},{v},{}\n", 0.005 * v));
    }
    let p = tmp("line.csv", &text);
    let (ok, out, err) = lucent(&["fit", "oblique", p.to_str().unwrap(), "--eta", "1.33", "--incidence-deg", "40", "--json"]);
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!((j["delta_x_mm"].as_f64().unwrap() / dx - 1.0).abs() < 0.01, "{out}");
    assert!((j["sigma_s_prime_per_mm"].as_f64().unwrap() / musp - 1.0).abs() < 0.02, "{out}");
    assert!(j["sigma_s_prime_ci_per_mm"].as_array().unwrap().len() == 2);
    let (ok, _, err) = lucent(&["fit", "oblique", p.to_str().unwrap(), "--eta", "1.33", "--incidence-deg", "0"]);
    assert!(!ok && err.contains("incidence-deg"), "{err}");
    // The same profile with the position column last gives the same fit; positions that do not
    // increase are named in the file's own numbers.
    let swapped: String = text
        .lines()
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            format!("{},{},{}\n", c[1], c[2], c[0])
        })
        .collect();
    let q = tmp("line-swapped.csv", &swapped);
    let (ok, out2, err) = lucent(&["fit", "oblique", q.to_str().unwrap(), "--eta", "1.33", "--incidence-deg", "40", "--json"]);
    assert!(ok, "{err}");
    let j2: serde_json::Value = serde_json::from_str(&out2).unwrap();
    assert!((j2["delta_x_mm"].as_f64().unwrap() / j["delta_x_mm"].as_f64().unwrap() - 1.0).abs() < 1e-9, "{out2}");
    let r = tmp("line-back.csv", "x_mm,reflectance\n3,0.1\n2,0.2\n");
    let (ok, _, err) = lucent(&["fit", "oblique", r.to_str().unwrap(), "--eta", "1.33", "--incidence-deg", "40"]);
    assert!(!ok && err.contains("line 3") && err.contains("2 does not increase (previous 3)"), "{err}");
}

#[test]
fn particles_with_a_recipe_fit_radius_and_volume_fraction() {
    let recipe = concat!(env!("CARGO_MANIFEST_DIR"), "/../../media/polystyrene-beads.toml");
    let s = tmp("beads.csv", "wavelength_nm,sigma_s_prime_per_mm\n450,0.5\n550,0.4\n650,0.3\n");
    let (ok, out, err) = lucent(&["fit", "particles", s.to_str().unwrap(), "--medium", recipe, "--particle", "polystyrene", "--json"]);
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    for k in ["radius_um", "radius_um_ci", "volume_fraction", "volume_fraction_ci", "residual_rms"] {
        assert!(j.get(k).is_some(), "missing {k}: {out}");
    }
    let (ok, _, err) = lucent(&["fit", "particles", s.to_str().unwrap(), "--medium", recipe]);
    assert!(!ok && err.contains("--particle"), "{err}");
}
