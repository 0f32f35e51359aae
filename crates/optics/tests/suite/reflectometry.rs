//! Tests of optics::reflectometry and optics::fitting: closed forms, agreement of independent
//! models, exact recovery from model data, error messages on bad input.

use optics::fitting::{levenberg_marquardt, student_t_975, LmOptions};
use optics::reflectometry::*;
use std::f64::consts::PI;

/// ∫₀^∞ f(r) 2πr dr by the substitution r = L u/(1 − u) and a 20 000-point midpoint rule.
fn integrate_plane(f: impl Fn(f64) -> f64, l: f64) -> f64 {
    let n = 20_000;
    (0..n)
        .map(|i| {
            let u = (i as f64 + 0.5) / n as f64;
            let r = l * u / (1.0 - u);
            f(r) * 2.0 * PI * r * l / ((1.0 - u) * (1.0 - u)) / n as f64
        })
        .sum()
}

/// Small deterministic generator for test noise (SplitMix64 + Box–Muller).
struct Noise(u64);
impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
    }
}

#[test]
fn dipole_integrates_to_its_closed_form_total_reflectance() {
    // Total diffuse reflectance of the dipole (Jensen et al. 2001, eq. after (9), from Farrell's
    // R(r)): R_d = (α'/2)(1 + e^{−(4/3)A√(3(1−α'))}) e^{−√(3(1−α'))}, times T₁₂ here.
    for &(mua, musp, eta) in &[(0.01, 1.0, 1.0), (0.005, 2.6, 1.5), (0.1, 1.0, 1.3), (0.0014, 0.7, 1.3)] {
        let num = integrate_plane(|r| dipole_rd_per_mm2(r, mua, musp, eta), 1.0 / (mua + musp));
        let ap: f64 = musp / (mua + musp);
        let fdr = 2.0 * optics::fresnel::fresnel_moment(1, 1.0 / eta);
        let a = (1.0 + fdr) / (1.0 - fdr);
        let s = (3.0 * (1.0 - ap)).sqrt();
        let closed = t12_normal(eta) * 0.5 * ap * (1.0 + (-(4.0 / 3.0) * a * s).exp()) * (-s).exp();
        assert!((num - closed).abs() < 1e-4 * closed, "{mua} {musp} {eta}: {num} vs {closed}");
    }
}

#[test]
fn dipole_boundary_term_matches_egan_hilgeman_fit() {
    // Jensen et al. 2001 use F_dr(n) = −1.440/n² + 0.710/n + 0.668 + 0.0636 n (Egan & Hilgeman);
    // ours is the exact 2C₁(1/n). The fit is good to ~1 % in the range of turbid media.
    for &n in &[1.3f64, 1.4, 1.5] {
        let fit = -1.440 / (n * n) + 0.710 / n + 0.668 + 0.0636 * n;
        let exact = 2.0 * optics::fresnel::fresnel_moment(1, 1.0 / n);
        assert!((fit - exact).abs() < 0.01, "n {n}: fit {fit} exact {exact}");
    }
}

#[test]
fn directional_dipole_agrees_with_standard_dipole_far_from_the_source() {
    // Both are diffusion solutions with the same σ_tr: far from the source (many transport
    // lengths, μ_eff r ≫ 1) their profiles must decay alike; the amplitudes differ only through
    // the boundary and source-depth conventions (≈10 %). Index-matched and mismatched.
    for &(mua, musp, eta) in &[(0.01, 1.0, 1.0), (0.0071, 3.0, 1.5), (0.014, 1.9, 1.3)] {
        let mut_p: f64 = mua + musp;
        let meff = (3.0 * mua * mut_p).sqrt();
        let (r1, r2) = (10.0 / mut_p, 10.0 / mut_p + 3.0 / meff);
        let slope = |f: &dyn Fn(f64) -> f64| (f(r2) * r2 * r2).ln() - (f(r1) * r1 * r1).ln();
        let sd = slope(&|r| dipole_rd_per_mm2(r, mua, musp, eta));
        let dd = slope(&|r| directional_dipole_rd_per_mm2(r, mua, musp, eta));
        assert!((sd - dd).abs() < 0.05 * sd.abs(), "{eta}: slopes {sd} vs {dd}");
        let ratio = directional_dipole_rd_per_mm2(r1, mua, musp, eta) / dipole_rd_per_mm2(r1, mua, musp, eta);
        assert!((0.7..1.3).contains(&ratio), "{eta}: amplitude ratio {ratio}");
    }
}

#[test]
fn student_t_quantiles_match_tables() {
    // Abramowitz & Stegun table 26.10: t_{0.975} for ν = 5, 20, 60, 120, ∞.
    for &(nu, t) in &[(5usize, 2.571), (20, 2.086), (60, 2.000), (120, 1.980), (100_000, 1.960)] {
        assert!((student_t_975(nu) - t).abs() < 2e-3, "{nu}: {} vs {t}", student_t_975(nu));
    }
}

#[test]
fn levenberg_marquardt_reproduces_linear_least_squares_and_its_covariance() {
    // For a linear model the LM optimum and s²(JᵀJ)⁻¹ equal the closed-form regression.
    let mut noise = Noise(3);
    let x: Vec<f64> = (0..50).map(|i| i as f64 / 10.0).collect();
    let y: Vec<f64> = x.iter().map(|&xi| 1.5 - 0.7 * xi + 0.05 * noise.normal()).collect();
    let res = |p: &[f64]| Some(x.iter().zip(&y).map(|(xi, yi)| p[0] + p[1] * xi - yi).collect::<Vec<_>>());
    let fit = levenberg_marquardt(&res, &[0.0, 0.0], &LmOptions::default()).unwrap();
    let n = x.len() as f64;
    let (sx, sy) = (x.iter().sum::<f64>(), y.iter().sum::<f64>());
    let sxx: f64 = x.iter().map(|v| v * v).sum();
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| a * b).sum();
    let det = n * sxx - sx * sx;
    let b = (n * sxy - sx * sy) / det;
    let a = (sy - b * sx) / n;
    assert!((fit.params[0] - a).abs() < 1e-8 && (fit.params[1] - b).abs() < 1e-8, "{:?} vs {a} {b}", fit.params);
    let s2: f64 = x.iter().zip(&y).map(|(xi, yi)| (a + b * xi - yi).powi(2)).sum::<f64>() / (n - 2.0);
    let var_b = s2 * n / det;
    let cov = fit.covariance.unwrap();
    assert!((cov[1][1] - var_b).abs() < 1e-6 * var_b, "{} vs {var_b}", cov[1][1]);
}

fn profile(r: &[f64], v: Vec<f64>, relative: bool) -> ReflectanceProfile {
    ReflectanceProfile { lambda_nm: None, r_mm: r.to_vec(), value: v, stderr: None, relative }
}

#[test]
fn fit_recovers_dipole_parameters_from_dipole_data_with_noise() {
    // Model data with 1 % multiplicative noise: the estimate must fall in its 95 % interval
    // (checked on four media; a fixed seed) and close to the truth.
    let mut noise = Noise(11);
    for &(mua, musp, eta) in &[(0.0071, 3.0, 1.5), (0.0142, 1.9, 1.3), (0.014, 3.77, 1.3), (0.05, 1.0, 1.0)] {
        for model in [ReflectanceModel::Dipole, ReflectanceModel::Directional] {
            let r: Vec<f64> = (1..=60).map(|k| k as f64 * 0.25).collect();
            let v: Vec<f64> = r
                .iter()
                .map(|&ri| model.rd_per_mm2(ri, mua, musp, eta).unwrap() * (1.0 + 0.01 * noise.normal()))
                .collect();
            let f = fit_reflectance(&profile(&r, v, false), &model, eta, &FitOptions::default()).unwrap();
            let sa = f.sigma_a_per_mm.unwrap();
            let ss = f.sigma_s_prime_per_mm.unwrap();
            assert!(sa.ci95[0] < mua && mua < sa.ci95[1], "{} σ_a {mua}: {sa:?}", model.name());
            assert!(ss.ci95[0] < musp && musp < ss.ci95[1], "{} σ'_s {musp}: {ss:?}", model.name());
            assert!((ss.value / musp - 1.0).abs() < 0.05 && (sa.value / mua - 1.0).abs() < 0.2);
            // Weighted residuals are N(0, 1) when the assumed 1 % noise is right.
            assert!((0.8..1.2).contains(&f.residual_rms), "{}", f.residual_rms);
        }
    }
}

#[test]
fn relative_data_determine_mu_eff_and_warn() {
    let (mua, musp, eta) = (0.01, 1.5, 1.3);
    let meff = (3.0 * mua * (mua + musp) as f64).sqrt();
    let r: Vec<f64> = (1..=40).map(|k| 2.0 + k as f64 * 0.5).collect();
    let mut noise = Noise(5);
    let v: Vec<f64> = r.iter().map(|&ri| 37.0 * dipole_rd_per_mm2(ri, mua, musp, eta) * (1.0 + 0.01 * noise.normal())).collect();
    let f = fit_reflectance(&profile(&r, v, true), &ReflectanceModel::Dipole, eta, &FitOptions::default()).unwrap();
    let m = f.mu_eff_per_mm.unwrap();
    assert!(m.ci95[0] < meff && meff < m.ci95[1] && (m.value / meff - 1.0).abs() < 0.03, "{m:?} vs {meff}");
    assert!(f.notes.iter().any(|n| n.contains("relative data")), "{:?}", f.notes);
    // Over 2–22 mm the dipole's shape (the 1/r terms) still pins σ'_s; over a short stretch
    // far away only the slope μ_eff is known, and σ_a, σ'_s must be refused.
    let r: Vec<f64> = (0..10).map(|k| 20.0 + 0.2 * k as f64).collect();
    let v: Vec<f64> = r.iter().map(|&ri| 5.0 * dipole_rd_per_mm2(ri, mua, musp, eta) * (1.0 + 0.01 * noise.normal())).collect();
    let f = fit_reflectance(&profile(&r, v, true), &ReflectanceModel::Dipole, eta, &FitOptions::default()).unwrap();
    assert!(f.sigma_s_prime_per_mm.is_none() && f.sigma_a_per_mm.is_none(), "{f:?}");
    assert!(f.notes.iter().any(|n| n.contains("sigma_s_prime_per_mm not determined")), "{:?}", f.notes);
}

#[test]
fn monte_carlo_table_round_trips_through_csv_and_interpolates_nodes() {
    let rho: Vec<f64> = (0..10).map(|k| 0.25 + 0.5 * k as f64).collect();
    let albedo = vec![0.9, 0.95, 0.98, 0.99, 0.995, 0.998, 0.999];
    let r_scaled: Vec<Vec<f64>> = albedo.iter().map(|&a| rho.iter().map(|&p| dipole_rd_per_mm2(p, 1.0 - a, a, 1.3)).collect()).collect();
    let t = MonteCarloTable { eta: 1.3, g: 0.0, albedo, rho: rho.clone(), r_scaled };
    let back = MonteCarloTable::from_csv(&t.to_csv(), "t.csv").unwrap();
    assert_eq!(back.albedo, t.albedo);
    assert_eq!(back.rho.len(), 10);
    // At nodes the table is exact (to the 7 digits written); between and beyond, close to the
    // dipole it was built from; with σ'_t = 2 the similarity scaling applies.
    for &(a, p) in &[(0.99, 2.25), (0.995, 1.0), (0.97, 3.1), (0.999, 7.0)] {
        let exact = dipole_rd_per_mm2(p, 1.0 - a, a, 1.3);
        let got = back.eval_scaled(a, p).unwrap();
        assert!((got / exact - 1.0).abs() < 0.05, "{a} {p}: {got} vs {exact}");
        let scaled = back.rd_per_mm2(p / 2.0, 2.0 * (1.0 - a), 2.0 * a).unwrap();
        assert!((scaled / (4.0 * got) - 1.0).abs() < 1e-9);
    }
    assert!(back.eval_scaled(0.5, 1.0).is_none(), "outside the albedo range");
    let bad = t.to_csv().replacen("0.99,0.75", "0.99,0.8", 1);
    assert!(MonteCarloTable::from_csv(&bad, "bad.csv").unwrap_err().to_string().contains("rho grid"));
}

#[test]
fn bad_reflectance_files_get_one_line_errors_naming_file_and_place() {
    let cases = [
        ("", "empty"),
        ("r_mm,reflectance\n", "no data rows"),
        ("r_mm,foo\n1,2\n", "missing column reflectance"),
        ("x,reflectance\n1,2\n", "missing column r_mm"),
        ("r_mm,reflectance\n1,0.1\n0.5,0.05\n", "line 3: column r_mm"),
        ("r_mm,reflectance\n1,0.1\n1,0.05\n", "does not increase"),
        ("r_mm,reflectance\n1,-0.1\n", "line 2: column reflectance: negative"),
        ("r_mm,reflectance\n1,abc\n", "line 2: column reflectance"),
        ("r_mm,reflectance\n1,NaN\n", "not finite"),
        ("r_mm,reflectance\n1\n", "line 2: missing column reflectance"),
    ];
    for (text, want) in cases {
        let e = read_reflectance_csv(text, "data.csv").unwrap_err().to_string();
        assert!(e.starts_with("data.csv") && e.contains(want) && !e.contains('\n'), "{text:?}: {e}");
    }
    // Per-wavelength grouping: r restarts for each wavelength.
    let p = read_reflectance_csv("wavelength_nm,r_mm,relative\n500,1,3\n500,2,2\n600,1,4\n600,2,1\n", "d").unwrap();
    assert_eq!(p.len(), 2);
    assert!(p[1].relative && p[1].lambda_nm == Some(600.0) && p[1].value == vec![4.0, 1.0]);
}

#[test]
fn oblique_fit_recovers_the_shift_of_a_displaced_dipole() {
    // Diffusion-theory data: a dipole profile centred at Δx = 3D sin θ_t with D = 1/(3(0.35σ_a + σ'_s))
    // (Lin et al. 1997); the fit must return σ'_s and σ_a.
    let (mua, musp, eta, deg) = (0.02, 1.0, 1.0, 45.0f64);
    let d = 1.0 / (3.0 * (0.35 * mua + musp));
    let dx = 3.0 * d * deg.to_radians().sin() / eta;
    let x: Vec<f64> = (0..161).map(|k| -8.0 + 0.1 * k as f64).collect();
    let v: Vec<f64> = x.iter().map(|&xi| dipole_rd_per_mm2((xi - dx).abs(), mua, musp, eta)).collect();
    let f = fit_oblique(&x, &v, None, deg, eta, 1.0).unwrap();
    assert!((f.delta_x_mm.value - dx).abs() < 0.01 * dx, "{:?} vs {dx}", f.delta_x_mm);
    assert!((f.sigma_s_prime_per_mm.value / musp - 1.0).abs() < 0.02, "{:?}", f.sigma_s_prime_per_mm);
    assert!((f.sigma_a_per_mm.value / mua - 1.0).abs() < 0.1, "{:?}", f.sigma_a_per_mm);
}

#[test]
fn dipoles_agree_with_the_independent_bssrdf_implementations() {
    // optics::bssrdf (the renderer's BSSRDF models, written separately, boundary terms from the
    // d'Eon/Egan–Hilgeman polynomial fits) against our normal-incidence reflectometry forms
    // (exact Fresnel moments). Standard: R = T₁₂ R_d^{bssrdf}; directional: R = T₁₂ 4C_φ(1/η) π S_d.
    use optics::bssrdf::{c_phi, DirectionalDipole, OpticalProperties, StandardDipole};
    for &(mua, musp, eta) in &[(0.0142, 1.9, 1.3), (0.0071, 3.0, 1.5), (0.05, 1.0, 1.0)] {
        let p = OpticalProperties { eta, sigma_s_per_m: musp * 1e3, sigma_a_per_m: mua * 1e3, g: 0.0 };
        let sd = StandardDipole::new(&p).unwrap();
        let dd = DirectionalDipole::new(&p).unwrap();
        for &r in &[0.2, 1.0, 3.0, 10.0] {
            let ours = dipole_rd_per_mm2(r, mua, musp, eta);
            let theirs = t12_normal(eta) * sd.rd_profile(r * 1e-3) * 1e-6;
            assert!((ours / theirs - 1.0).abs() < 0.03, "standard {eta} r {r}: {ours} vs {theirs}");
            let ours = directional_dipole_rd_per_mm2(r, mua, musp, eta);
            let theirs = t12_normal(eta) * 4.0 * c_phi(1.0 / eta) * dd.rd_profile(r * 1e-3) * 1e-6;
            assert!((ours / theirs - 1.0).abs() < 0.03, "directional {eta} r {r}: {ours} vs {theirs}");
        }
    }
}
