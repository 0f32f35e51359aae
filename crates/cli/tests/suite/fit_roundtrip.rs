//! Round trips of diffuse reflectance spectroscopy: R(r) simulated by the layered Monte Carlo
//! (`optics::slab`, fixed seeds) for skim, low-fat and whole milk and Jensen's marble, with 1 %
//! multiplicative noise, fitted by `optics::reflectometry` with the three forward models.
//!
//! Optical properties (blue channel, where absorption is largest and walks are shortest, so the
//! simulations stay fast): Jensen, Marschner, Levoy & Hanrahan 2001, table in fig. 5 — skim milk
//! σ'_s = 1.90, σ_a = 0.0142 mm⁻¹; whole milk 3.77, 0.014; marble 3.00, 0.0071 (η = 1.5);
//! low-fat milk from Narasimhan et al. 2006 (σ_s = 17.9572 mm⁻¹, g = 0.859 → σ'_s = 2.532,
//! σ_a = 0.0115). Milks at η = 1.3 as in Jensen et al. The simulations use g = 0 with σ_s = σ'_s
//! (these tables give only reduced coefficients; far from the source only σ'_s matters).
//!
//! Targets (docs/inverse.md): σ'_s within 5 %, σ_a within 20 %. The tabulated Monte Carlo model meets
//! both over the whole profile; the dipoles are fitted from 1 mm outwards (about 2–4 transport
//! lengths), where diffusion holds — each test asserts what its model reaches (docs/inverse.md).

use optics::reflectometry::{bundled_table, fit_reflectance, FitOptions, ReflectanceModel, ReflectanceProfile};
use optics::slab::{simulate, Layer, RadialGrid, SlabSettings};

struct Case {
    name: &'static str,
    sigma_a_per_mm: f64,
    sigma_s_prime_per_mm: f64,
    eta: f64,
    seed: u64,
}

/// Simulated R(r) with 1 % multiplicative Gaussian noise (fixed seed), r up to ≈ 4/μ_eff.
fn simulate_profile(c: &Case, photons: u64) -> ReflectanceProfile {
    let meff = (3.0 * c.sigma_a_per_mm * (c.sigma_a_per_mm + c.sigma_s_prime_per_mm)).sqrt();
    let max_mm = (4.0 / meff).min(20.0);
    let layer = Layer { mua_per_mm: c.sigma_a_per_mm, mus_per_mm: c.sigma_s_prime_per_mm, g: 0.0, n: c.eta, thickness_mm: f64::INFINITY };
    let s = SlabSettings { photons, seed: c.seed, radial: Some(RadialGrid { bins: 100, max_mm }), ..SlabSettings::new(vec![layer]) };
    let r = simulate(&s).unwrap();
    let rad = r.radial.unwrap();
    // SplitMix64 (well mixed from the first output) → sum of 12 uniforms − 6 ≈ N(0, 1).
    let mut state = c.seed;
    let mut normal = || {
        let mut s = 0.0;
        for _ in 0..12 {
            state = state.wrapping_add(0x9E3779B97F4A7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
            s += ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64;
        }
        s - 6.0
    };
    let value: Vec<f64> = rad.rd_per_mm2.iter().map(|v| v * (1.0 + 0.01 * normal())).collect();
    ReflectanceProfile {
        lambda_nm: None,
        r_mm: rad.r_mm.clone(),
        value,
        stderr: Some(rad.rd_per_mm2_stderr.clone()),
        relative: false,
    }
}

/// Fit with one model; returns (σ'_s error, σ_a error) as fractions and asserts the CI contains the estimate.
fn errors(c: &Case, p: &ReflectanceProfile, model: &ReflectanceModel, r_min_mm: f64) -> (f64, f64) {
    let bin_width_mm = Some(p.r_mm[1] - p.r_mm[0]); // histogram data: compare annulus averages
    let f = fit_reflectance(p, model, c.eta, &FitOptions { r_min_mm, bin_width_mm, ..FitOptions::default() }).unwrap();
    let sa = f.sigma_a_per_mm.expect("σ_a determined");
    let ss = f.sigma_s_prime_per_mm.expect("σ'_s determined");
    let e = (ss.value / c.sigma_s_prime_per_mm - 1.0, sa.value / c.sigma_a_per_mm - 1.0);
    eprintln!(
        "{:12} {:12} σ'_s {:.4} [{:.4}, {:.4}] ({:+.1} %)  σ_a {:.5} [{:.5}, {:.5}] ({:+.1} %)  rms {:.2}",
        c.name, model.name(), ss.value, ss.ci95[0], ss.ci95[1], 100.0 * e.0, sa.value, sa.ci95[0], sa.ci95[1], 100.0 * e.1, f.residual_rms
    );
    e
}

/// `mc_sp_tol`: tolerance on σ'_s with the Monte Carlo model (the documented 5 %; the marble needed
/// the η = 1.5 table rebuilt with 6·10⁵ photons per albedo — with 2·10⁵ its far tail was 10 %
/// high and σ'_s came back +5.2 %; now −0.2 to −0.7 % over seeds 101, 202, 303, see docs/inverse.md).
/// `dip_tol`: (σ'_s, σ_a) tolerances for the standard dipole (10 %, 30 % for the milks; the
/// marble's R(r) is not dipole-shaped at η = 1.5 — see docs/inverse.md — and gets 35 %, 50 %).
fn round_trip(c: Case, mc_sp_tol: f64, dip_tol: (f64, f64)) {
    let p = simulate_profile(&c, 150_000);
    let table = ReflectanceModel::MonteCarlo(bundled_table(c.eta).unwrap().expect("bundled table"));
    let (es, ea) = errors(&c, &p, &table, 0.5);
    assert!(es.abs() < mc_sp_tol && ea.abs() < 0.20, "{}: Monte Carlo model: σ'_s {es:+.3}, σ_a {ea:+.3}", c.name);
    let (es, ea) = errors(&c, &p, &ReflectanceModel::Dipole, 1.0);
    assert!(es.abs() < dip_tol.0 && ea.abs() < dip_tol.1, "{}: dipole: σ'_s {es:+.3}, σ_a {ea:+.3}", c.name);
    let (es, ea) = errors(&c, &p, &ReflectanceModel::Directional, 3.0);
    assert!(es.abs() < 0.5 && ea.abs() < 0.6, "{}: directional: σ'_s {es:+.3}, σ_a {ea:+.3}", c.name);
}

#[test]
fn skim_milk_round_trip() {
    round_trip(Case { name: "skim milk", sigma_a_per_mm: 0.0142, sigma_s_prime_per_mm: 1.90, eta: 1.3, seed: 61 }, 0.05, (0.10, 0.30));
}

#[test]
fn low_fat_milk_round_trip() {
    round_trip(Case { name: "low-fat milk", sigma_a_per_mm: 0.0115, sigma_s_prime_per_mm: 2.532, eta: 1.3, seed: 62 }, 0.05, (0.10, 0.30));
}

#[test]
fn whole_milk_round_trip() {
    round_trip(Case { name: "whole milk", sigma_a_per_mm: 0.014, sigma_s_prime_per_mm: 3.77, eta: 1.3, seed: 63 }, 0.05, (0.10, 0.30));
}

#[test]
fn marble_round_trip() {
    round_trip(Case { name: "marble", sigma_a_per_mm: 0.0071, sigma_s_prime_per_mm: 3.00, eta: 1.5, seed: 64 }, 0.05, (0.35, 0.50));
}

#[test]
fn oblique_incidence_reflectometry_round_trip() {
    // Wang & Jacques 1995: a 45° beam on a half-space (σ_a = 0.05, σ_s = 10 mm⁻¹, g = 0.9, so
    // σ'_s = 1 mm⁻¹; n = 1.4). With g = 0 the Monte Carlo centre lies ~25 % short of diffusion
    // theory's 3D sin θ_t (isotropic first scattering forgets the beam direction at once); with
    // tissue-like g = 0.9 it is within ~6 %, as Wang & Jacques found.
    // the line profile R(x, 0) from the Monte Carlo, 1 % noise, then σ'_s from the centre shift.
    use optics::reflectometry::fit_oblique;
    use optics::slab::LineGrid;
    let (mua, musp, n) = (0.05, 1.0, 1.4);
    let layer = Layer { mua_per_mm: mua, mus_per_mm: musp / 0.1, g: 0.9, n, thickness_mm: f64::INFINITY };
    let s = SlabSettings {
        photons: 300_000,
        seed: 71,
        incidence_deg: 45.0,
        line: Some(LineGrid { bins: 40, max_mm: 10.0 }),
        ..SlabSettings::new(vec![layer])
    };
    let r = simulate(&s).unwrap();
    let line = r.line.unwrap();
    let mut state = 0x1234_5678_9abc_def1u64;
    let v: Vec<f64> = line
        .rd_per_mm2
        .iter()
        .map(|x| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            x * (1.0 + 0.01 * 3f64.sqrt() * (2.0 * u - 1.0))
        })
        .collect();
    // Keep bins with < 20 % Monte Carlo error, weighted by it.
    let keep: Vec<usize> = (0..v.len()).filter(|&k| line.rd_per_mm2_stderr[k] < 0.2 * line.rd_per_mm2[k]).collect();
    let x: Vec<f64> = keep.iter().map(|&k| line.x_mm[k]).collect();
    let y: Vec<f64> = keep.iter().map(|&k| v[k]).collect();
    let se: Vec<f64> = keep.iter().map(|&k| line.rd_per_mm2_stderr[k]).collect();
    let f = fit_oblique(&x, &y, Some(&se), 45.0, n, 1.5).unwrap();
    let (es, ea) = (f.sigma_s_prime_per_mm.value / musp - 1.0, f.sigma_a_per_mm.value / mua - 1.0);
    eprintln!("oblique: Δx {:?}  σ'_s {:?} ({:+.1} %)  σ_a {:?} ({:+.1} %)", f.delta_x_mm, f.sigma_s_prime_per_mm, 100.0 * es, f.sigma_a_per_mm, 100.0 * ea);
    // Reached over four seeds (71 here; 5, 6, 7 with `lucent slab` + `lucent fit oblique`):
    // σ'_s +4 %, +17 %, +20 %, +12 % — the fitted centre lies 10–15 % short of 3D sin θ_t (as the
    // slab's own diffuse-centre test finds), so OIR overestimates σ'_s; σ_a (from the slope of a
    // 1-D line profile) −35 … −47 %. Checks: σ'_s within 25 %, σ_a within 60 %, and the 95 %
    // interval of Δx narrower than ±15 % (the estimator's own precision).
    let dx_half = 0.5 * (f.delta_x_mm.ci95[1] - f.delta_x_mm.ci95[0]) / f.delta_x_mm.value;
    assert!(dx_half < 0.15, "Δx interval ±{dx_half:.3}");
    assert!(es.abs() < 0.25 && ea.abs() < 0.6, "σ'_s {es:+.3}, σ_a {ea:+.3}");
}
