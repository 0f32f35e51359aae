//! Inputs at and beyond the supported limits: each gives a correct result or an `Err` that
//! names the limit, quickly and without a panic (Mie sizes, medium recipes, dipole η, far
//! profiles), and the small-particle limit of Mie theory against the Rayleigh closed form.

use optics::bssrdf::{self, DirectionalDipole, DirectionalLineDipole, OpticalProperties, StandardDipole};
use optics::fresnel::fresnel_dielectric;
use optics::media::Recipe;
use optics::mie::{self, Complex64, MieWorkspace};
use std::f64::consts::PI;
use std::time::{Duration, Instant};

fn c(re: f64, im: f64) -> Complex64 {
    Complex64::new(re, im)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

fn quick<T>(what: &str, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let v = f();
    assert!(t.elapsed() < Duration::from_secs(5), "{what} took {:?}", t.elapsed());
    v
}

// ---------------------------------------------------------------------------------------------
// Mie: small particles

/// Rayleigh: Q_sca = 8/3 x⁴ |K|², Q_abs = 4x Im K, K = (m²−1)/(m²+2), g → 0, and the phase
/// function 3(1 + cos²θ)/(16π), down to the smallest supported size parameter.
#[test]
fn small_spheres_match_the_rayleigh_closed_form() {
    let mut w = MieWorkspace::new();
    for &x in &[1e-4, 1e-6, 1e-10, 1e-20, 1e-30] {
        for &m in &[c(1.5, 0.0), c(1.33, 0.01), c(3.0, 2.0), c(0.75, 0.0)] {
            let e = w.efficiencies(x, m);
            let k = (m * m - 1.0) / (m * m + 2.0);
            let qsca = 8.0 / 3.0 * x.powi(4) * k.norm_sqr();
            let qabs = 4.0 * x * k.im;
            assert!(rel(e.qsca, qsca) < 1e-6, "x={x} m={m}: qsca {} vs {qsca}", e.qsca);
            if m.im > 0.0 {
                assert!(rel(e.qabs, qabs) < 1e-6, "x={x} m={m}: qabs {} vs {qabs}", e.qabs);
                assert!(rel(e.qext, qsca + qabs) < 1e-6);
            } else {
                assert_eq!(e.qabs, 0.0, "x={x} m={m}: no absorption for a real index");
            }
            assert!(e.g.abs() < 1e-6 && e.qback.is_finite(), "x={x} m={m}: g {}", e.g);
            let (a, b) = w.coefficients(c(x, 0.0), m);
            let (a, b) = (a.to_vec(), b.to_vec());
            for mu in [1.0, 0.5, 0.0, -0.7] {
                let p = mie::phase_function(&a, &b, mu);
                let pr = 3.0 * (1.0 + mu * mu) / (16.0 * PI);
                assert!(rel(p, pr) < 1e-6, "x={x} m={m} mu={mu}: p {p} vs {pr}");
            }
        }
    }
}

/// The small-particle expansion (|x|, |mx| < 0.01) against the series just inside the range where
/// the series is used (x = 0.009: both within 10⁻⁹), and continuity across the switch at 0.01.
#[test]
fn small_particle_expansion_agrees_with_the_series() {
    let mut w = MieWorkspace::new();
    for &m in &[c(1.5, 0.0), c(1.33, 1e-3), c(0.8, 0.1)] {
        let x = 0.009;
        let e = w.efficiencies(x, m);
        let (a, b) = w.coefficients_upward(c(x, 0.0), m);
        let sca: f64 = a.iter().zip(b).enumerate().map(|(k, (an, bn))| (2 * k + 3) as f64 * (an.norm_sqr() + bn.norm_sqr())).sum();
        let ext: f64 = a.iter().zip(b).enumerate().map(|(k, (an, bn))| (2 * k + 3) as f64 * (an + bn).re).sum();
        assert!(rel(e.qsca, 2.0 * sca / (x * x)) < 1e-9, "m={m}: qsca {} vs {}", e.qsca, 2.0 * sca / (x * x));
        assert!(rel(e.qext, 2.0 * ext / (x * x)) < 1e-9, "m={m}: qext {} vs {}", e.qext, 2.0 * ext / (x * x));
        let below = w.efficiencies(0.01 * (1.0 - 1e-9), m);
        let above = w.efficiencies(0.01 * (1.0 + 1e-9), m);
        assert!(rel(below.qsca, above.qsca) < 1e-8, "m={m}: {} vs {}", below.qsca, above.qsca);
        assert!(rel(below.qext, above.qext) < 1e-8, "m={m}: {} vs {}", below.qext, above.qext);
    }
    // Absorbing host, tiny sphere: finite, and matching a non-absorbing host as n″ → 0.
    let s0 = mie::sphere(1e-12, 500e-9, c(1.5, 0.01), c(1.33, 0.0));
    let s1 = mie::sphere(1e-12, 500e-9, c(1.5, 0.01), c(1.33, 1e-12));
    assert!(rel(s1.c_ext_m2, s0.c_ext_m2) < 1e-6 && rel(s1.c_sca_m2, s0.c_sca_m2) < 1e-6, "{s0:?} {s1:?}");
}

/// A real index absorbs nothing: Q_abs is exactly 0, never a round-off like −8.9e-16.
#[test]
fn real_index_has_zero_absorption() {
    let mut w = MieWorkspace::new();
    for &x in &[0.05, 0.5, 3.0, 47.0, 1000.0] {
        for &m in &[c(1.59 / 1.333, 0.0), c(1.5, 0.0), c(2.0, 0.0)] {
            let e = w.efficiencies(x, m);
            assert_eq!(e.qabs, 0.0, "x={x} m={m}");
            assert!(e.qext > 0.0 && rel(e.qext, e.qsca) < 1e-9, "x={x} m={m}: {e:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Mie: bounded work

#[test]
fn unsupported_mie_sizes_are_refused_quickly() {
    let mut w = MieWorkspace::new();
    let cases: &[(Complex64, Complex64, &str)] = &[
        (c(1e-300, 0.0), c(1.5, 0.0), "1e-30"),
        (c(1.0, 0.0), c(1.5, 1e308), "10000000"),
        (c(1e4, 0.0), c(1e6, 1e6), "10000000"),
        (c(2e6, 0.0), c(1.5, 0.0), "1000000"),
        (c(1e-6, 0.0), c(1e5, 0.0), "small-particle"),
        (c(f64::INFINITY, 0.0), c(1.5, 0.0), "finite"),
        (c(f64::NAN, 0.0), c(1.5, 0.0), "finite"),
        (c(1e-5, 0.0), c(f64::NAN, 0.0), "finite"),
    ];
    for &(x, m, limit) in cases {
        let e = mie::check_size(x, m).expect_err(&format!("x={x} m={m}"));
        let msg = format!("{e:#}");
        assert!(msg.contains(limit) && !msg.contains('\n'), "x={x} m={m}: {msg}");
        // The functions without a Result give NaN or nothing, promptly, instead of hanging.
        quick("efficiencies", || {
            let e = w.efficiencies(x.re, m);
            assert!(e.qext.is_nan() && e.terms == 0, "x={x} m={m}: {e:?}");
        });
        quick("coefficients", || assert!(w.coefficients(x, m).0.is_empty()));
        quick("sphere", || assert!(w.sphere(1e-6, 1e-6 / x.re.max(1e-300), m, c(1.0, 0.0)).c_ext_m2.is_nan()));
    }
}

/// Normal use stays supported: x up to 10⁵ with |m| up to 3, also with absorption.
#[test]
fn large_spheres_of_ordinary_index_still_work() {
    let mut w = MieWorkspace::new();
    for &(x, m) in &[(1e4, c(1.33, 1e-5)), (1e5, c(1.5, 0.0)), (1e5, c(3.0, 0.1)), (9.9e5, c(1.2, 0.0))] {
        mie::check_size(c(x, 0.0), m).unwrap();
        let e = w.efficiencies(x, m);
        assert!(e.terms as f64 > x && e.terms <= mie::MAX_TERMS, "x={x}: {} terms", e.terms);
        // Extinction paradox: Q_ext → 2 for large spheres.
        assert!((e.qext - 2.0).abs() < 0.02, "x={x} m={m}: qext {}", e.qext);
        assert!(e.qabs >= 0.0 && e.g > 0.3 && e.g < 1.0, "x={x} m={m}: {e:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Medium recipes

fn beads() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../media/polystyrene-beads.toml")).unwrap()
}

fn recipe_error(text: &str, lambda: Option<&[f64]>) -> String {
    let r = Recipe::from_toml(text).unwrap();
    let e = match quick("recipe", || r.bulk_properties(lambda)) {
        Ok(_) => panic!("must be refused: {lambda:?} {}", text.lines().filter(|l| l.contains("index") || l.contains("grid") || l.contains("wavelengths") || l.contains("phase")).collect::<Vec<_>>().join(" | ")),
        Err(e) => e,
    };
    let msg = format!("{e:#}");
    assert!(!msg.contains('\n'), "{msg}");
    msg
}

#[test]
fn recipes_beyond_the_supported_sizes_are_refused() {
    let text = beads();
    // Wavelengths so short that the series would need astronomically many terms (or x = ∞).
    for l in [1e-9, 1e-30, 1e-320] {
        let msg = recipe_error(&text, Some(&[l]));
        assert!(msg.contains("polystyrene") && (msg.contains("terms") || msg.contains("finite")), "{l}: {msg}");
    }
    // Host indices that make m tiny and x huge.
    for host in ["4294967296", "9223372036854775807"] {
        let t = text.replace("index = 1.333", &format!("index = {host}"));
        let msg = recipe_error(&t, None);
        assert!(msg.contains("terms"), "{host}: {msg}");
    }
    // A strongly absorbing particle (|mx| ~ 10⁷) and a grid out to 1 m radius.
    let msg = recipe_error(&text.replace("\"1.59+0i\"", "\"1+1e7i\""), None);
    assert!(msg.contains("recurrence"), "{msg}");
    let msg = recipe_error(&text.replace("r_vs_um = 0.5, c_s_um = 0.01", "r_vs_um = 5e5, c_s_um = 1e4"), None);
    assert!(msg.contains("terms"), "{msg}");
    // A grid out to 1 m over a narrow distribution: the empty bins are dropped, the rest is quick.
    let r = Recipe::from_toml(&text.replace("grid = { bins = 200 }", "grid = { bins = 200, r_max_um = 1e6 }")).unwrap();
    let _ = quick("wide grid", || r.bulk_properties(None));
    // Phase tables: the same cap as `lucent medium --phase-angles`.
    for n in ["9223372036854775807", "100000000"] {
        let msg = recipe_error(&text.replace("phase_angles = 181", &format!("phase_angles = {n}")), None);
        assert!(msg.contains("phase_angles") && msg.contains("100000"), "{n}: {msg}");
    }
    // Many wavelengths × bins: the work bound (about 10¹⁰ recurrence steps).
    let t = text.replace("wavelengths_nm = [450, 500, 550, 600, 650]", "wavelengths_nm = \"400:700:0.003\"").replace("bins = 200", "bins = 1000000");
    let msg = recipe_error(&t, None);
    assert!(msg.contains("recurrence steps"), "{msg}");
}

/// The beads recipe itself: non-absorbing, so σ_a is exactly 0 (no negative round-off).
#[test]
fn non_absorbing_recipe_has_zero_absorption() {
    let r = Recipe::from_toml(&beads()).unwrap();
    let b = r.bulk_properties(None).unwrap();
    for (i, &sa) in b.sigma_a_per_m.iter().enumerate() {
        assert!(sa == 0.0 && b.sigma_s_per_m[i] > 0.0, "{} nm: sigma_a {sa}", b.lambda_nm[i]);
    }
}

// ---------------------------------------------------------------------------------------------
// Dipole boundary terms for every supported η

/// 2∫₀¹ R(μ; η_rel) μ dμ by a 200 000-point midpoint rule (independent of `fresnel_moment`).
fn fdr_midpoint(eta_rel: f64) -> f64 {
    let n = 200_000;
    (0..n).map(|i| {
        let mu = (i as f64 + 0.5) / n as f64;
        fresnel_dielectric(mu, eta_rel) * mu
    }).sum::<f64>() * 2.0 / n as f64
}

/// Outside the ranges of the polynomial fits the boundary terms come from the numerical Fresnel
/// moments: A(η) = (1 + F_dr)/(1 − F_dr) with F_dr = 2C₁(1/η) matches a midpoint rule, A ≥ 1, and
/// R_d of the standard dipole lies in [0, α'] (η = 100 used to give R_d < 0, η = 10 R_d = 2.29).
#[test]
fn dipole_boundary_terms_hold_over_the_supported_eta() {
    for &eta in &[0.01, 0.05, 0.2, 0.35, 2.2, 2.5, 3.0, 4.0, 10.0, 30.0, 100.0] {
        let f = fdr_midpoint(1.0 / eta);
        assert!((bssrdf::fdr(eta) - f).abs() < 2e-6, "eta {eta}: F_dr {} vs {f}", bssrdf::fdr(eta));
        assert!((bssrdf::two_c1_moment(eta) - f).abs() < 2e-6, "eta {eta}");
        let fd = bssrdf::fdr(eta);
        assert_eq!(bssrdf::a_standard(eta), (1.0 + fd) / (1.0 - fd));
        assert!(bssrdf::a_standard(eta) >= 1.0);
        assert!(bssrdf::c_phi(eta) > 0.0 && bssrdf::c_e(eta) > 0.0 && bssrdf::a_directional(eta) > 0.0, "eta {eta}");
        for &(ss, sa) in &[(1000.0, 10.0), (1000.0, 0.0), (100.0, 100.0)] {
            let p = OpticalProperties { eta, sigma_s_per_m: ss, sigma_a_per_m: sa, g: 0.0 };
            let d = StandardDipole::new(&p).unwrap();
            let ap = d.props.alpha_prime;
            for rd in [d.rd_closed_form(), d.rd_numerical()] {
                assert!((0.0..=ap + 1e-9).contains(&rd), "eta {eta} ss {ss} sa {sa}: rd {rd}");
            }
            assert!(rel(d.rd_numerical(), d.rd_closed_form()) < 1e-4 || d.rd_closed_form() < 1e-12);
            for rd in [DirectionalDipole::new(&p).unwrap().rd_numerical(), DirectionalLineDipole::new(&p).unwrap().rd_numerical()] {
                assert!(rd.is_finite() && rd >= 0.0, "eta {eta} ss {ss} sa {sa}: directional rd {rd}");
            }
        }
    }
    // The reproducer: η = 100, σ_s = 1 mm⁻¹, σ_a = 0.01 mm⁻¹.
    let d = StandardDipole::new(&OpticalProperties { eta: 100.0, sigma_s_per_m: 1e3, sigma_a_per_m: 10.0, g: 0.0 }).unwrap();
    assert!(d.rd_numerical() > 0.0 && d.rd_closed_form() < 1.0);
    // Beyond the supported range: a one-line error naming η and the range.
    for eta in [0.001, 1e3, 1e300] {
        let e = OpticalProperties { eta, sigma_s_per_m: 1e3, sigma_a_per_m: 10.0, g: 0.0 }.validate().unwrap_err();
        let msg = format!("{e:#}");
        assert!(msg.contains("eta") && msg.contains("100") && msg.contains("0.01"), "{msg}");
    }
}

/// Inside the fit ranges nothing changes: the published fits are used as before.
#[test]
fn fits_are_kept_within_their_ranges() {
    for &eta in &[0.4, 0.8, 1.0, 1.3, 1.5, 2.0] {
        assert_eq!(bssrdf::two_c1_moment(eta), bssrdf::two_c1(eta));
        assert_eq!(bssrdf::three_c2_moment(eta), bssrdf::three_c2(eta));
    }
    for &eta in &[1.0, 1.3, 2.0] {
        assert_eq!(bssrdf::fdr(eta), bssrdf::fdr_egan_hilgeman(eta));
    }
}

/// Far from the source the profile is 0, not NaN (r² and d³ overflow there).
#[test]
fn far_profile_is_zero() {
    for sa in [0.0, 10.0] {
        let d = StandardDipole::new(&OpticalProperties { eta: 1.3, sigma_s_per_m: 1e3, sigma_a_per_m: sa, g: 0.0 }).unwrap();
        for r in [1e5, 1e160, 1e305, f64::MAX] {
            let v = d.rd_profile(r);
            assert!(v.is_finite() && v >= 0.0 && v < 1e-10, "sa {sa} r {r}: {v}");
        }
        assert!(d.rd_profile(1e-3) > 0.0);
    }
}

/// The colour and spectrum modules keep their public paths (the CSV reader and the wavelength grid
/// live in `csv` and `color`, re-exported from `spectrum`).
#[test]
fn spectrum_and_color_paths_are_reachable() {
    let (names, cols) = optics::spectrum::read_csv_columns("# c\nlambda_nm,v\n400,1\n500,2\n").unwrap();
    assert_eq!(names, ["lambda_nm", "v"]);
    assert_eq!(cols[1], [1.0, 2.0]);
    assert!(optics::csv::read_csv_columns("a,b\n1,nan\n").is_err());
    assert_eq!(optics::spectrum::N_DENSE, optics::color::N_DENSE);
    assert_eq!(optics::spectrum::LAMBDA_MIN_NM, optics::color::LAMBDA_MIN_NM);
    assert_eq!(optics::spectrum::LAMBDA_MAX_NM - optics::spectrum::LAMBDA_MIN_NM + 1.0, optics::spectrum::N_DENSE as f64);
}
