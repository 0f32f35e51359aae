//! Dipole BSSRDF tests: Fresnel-moment fits against numerical integration of the Fresnel
//! equations, the standard dipole's closed-form total reflectance, Jensen et al. 2001's published
//! diffuse reflectances, and the directional dipole against symmetry and a Monte Carlo simulation.

use optics::bssrdf::*;
use optics::fresnel::{fresnel_dielectric, fresnel_moment};

/// ∫₀¹ R(μ) μⁿ dμ for light inside a medium of relative index `n_rel` hitting its boundary
/// (Fresnel with n_t/n_i = 1/n_rel), by composite Simpson; the total-internal-reflection part is
/// integrated exactly and the √ kink at the critical angle removed by μ = μ_c + (1 − μ_c)s².
fn moment_numerical(order: i32, n_rel: f64) -> f64 {
    let eta_t_i = 1.0 / n_rel;
    let f = |mu: f64| fresnel_dielectric(mu, eta_t_i) * mu.powi(order);
    let simpson = |a: f64, b: f64, g: &dyn Fn(f64) -> f64| {
        let n = 4000;
        let h = (b - a) / n as f64;
        let mut s = g(a) + g(b);
        for i in 1..n {
            s += g(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    };
    if n_rel > 1.0 {
        let mu_c = (1.0 - 1.0 / (n_rel * n_rel)).sqrt();
        let span = 1.0 - mu_c;
        mu_c.powi(order + 1) / (order as f64 + 1.0)
            + simpson(0.0, 1.0, &|s| f(mu_c + span * s * s) * 2.0 * span * s)
    } else {
        simpson(0.0, 1.0, &f)
    }
}

/// d'Eon & Irving's (2011) polynomial fits of 2C₁ and 3C₂ (as used by Frisvad et al. 2014) against
/// numerical integration of the Fresnel equations for η ∈ [0.6, 2], with the tolerances below, and
/// H5's independent quadrature (`fresnel_moment`) against ours to 1e-8.
#[test]
fn fresnel_moment_fits_match_numerical_integration() {
    let mut worst = (0.0f64, 0.0f64);
    for i in 0..=70 {
        let eta = 0.6 + i as f64 * 0.02;
        let c1 = moment_numerical(1, eta);
        let c2 = moment_numerical(2, eta);
        assert!(
            (c1 - fresnel_moment(1, 1.0 / eta)).abs() < 1e-8,
            "eta {eta}"
        );
        assert!(
            (c2 - fresnel_moment(2, 1.0 / eta)).abs() < 1e-8,
            "eta {eta}"
        );
        let e1 = (two_c1(eta) - 2.0 * c1).abs();
        let e2 = (three_c2(eta) - 3.0 * c2).abs();
        worst = (worst.0.max(e1), worst.1.max(e2));
        // Observed: below 1.2e-4 for η < 1, up to 4.5e-3 (2C₁) and 6.9e-3 (3C₂) at and just above
        // η = 1 where the moments rise steeply from 0, below 1e-3 (2C₁) and 3.6e-3 (3C₂) for η ≥ 1.2.
        let (t1, t2) = if eta < 0.99 {
            (2e-4, 2e-4)
        } else if eta < 1.19 {
            (5e-3, 8e-3)
        } else {
            (1.5e-3, 4e-3)
        };
        assert!(
            e1 < t1,
            "2C1({eta}): fit {} vs {} (numerical)",
            two_c1(eta),
            2.0 * c1
        );
        assert!(
            e2 < t2,
            "3C2({eta}): fit {} vs {} (numerical)",
            three_c2(eta),
            3.0 * c2
        );
    }
    eprintln!(
        "max |fit - numerical|: 2C1 {:.2e}, 3C2 {:.2e}",
        worst.0, worst.1
    );
    // Boundary terms of the directional dipole at η = 1 (index-matched): no reflection, so
    // C_φ = 1/4, C_E = 1/2, A = 1.
    assert!((c_phi(1.0) - 0.25).abs() < 2e-3 && (c_e(1.0) - 0.5).abs() < 5e-3);
    assert!((a_directional(1.0) - 1.0).abs() < 1e-2);
}

/// Egan & Hilgeman's F_dr fit (used by Jensen 2001) against the numerical internal diffuse
/// reflectance 2∫R μ dμ, and A(η) of the standard dipole (Jensen 2001 quotes A ≈ 2.6 at η = 1.3 —
/// our check is against the numerical F_dr: (1 + F)/(1 − F)).
#[test]
fn diffuse_fresnel_reflectance_fit() {
    for i in 0..=10 {
        let eta = 1.0 + i as f64 * 0.1;
        let num = 2.0 * moment_numerical(1, eta);
        assert!(
            (fdr_egan_hilgeman(eta) - num).abs() < 6e-3,
            "eta {eta}: {} vs {num}",
            fdr_egan_hilgeman(eta)
        );
    }
    let num = 2.0 * moment_numerical(1, 1.3);
    let a_num = (1.0 + num) / (1.0 - num);
    assert!(
        (a_standard(1.3) - a_num).abs() < 0.01,
        "{} vs {a_num}",
        a_standard(1.3)
    );
}

fn props(eta: f64, sigma_s_per_mm: f64, sigma_a_per_mm: f64, g: f64) -> OpticalProperties {
    OpticalProperties {
        eta,
        sigma_s_per_m: sigma_s_per_mm * 1e3,
        sigma_a_per_m: sigma_a_per_mm * 1e3,
        g,
    }
}

/// ∫R_d(r) 2πr dr equals the closed form (α'/2)(1 + e^{−(4/3)A√(3(1−α'))})e^{−√(3(1−α'))} to
/// 1e-4, over a range of albedos, indices and scales.
#[test]
fn standard_dipole_integral_equals_closed_form() {
    let mut worst = 0.0f64;
    for &eta in &[1.0, 1.3, 1.5, 0.8] {
        for &(s, a) in &[
            (1.0, 0.001),
            (1.0, 0.1),
            (0.5, 0.5),
            (2.0, 0.0),
            (0.01, 1.0),
            (100.0, 0.3),
        ] {
            let d = StandardDipole::new(&props(eta, s, a, 0.0)).unwrap();
            let num = d.rd_numerical();
            let cf = d.rd_closed_form();
            worst = worst.max((num - cf).abs());
            assert!(
                (num - cf).abs() < 1e-4,
                "eta {eta} s {s} a {a}: {num} vs {cf}"
            );
        }
    }
    eprintln!("standard dipole: max |numerical - closed form| = {worst:.2e}");
    // α' = 1, index matched: half the light returns from each source, R_d = 1.
    let d = StandardDipole::new(&props(1.0, 1.0, 0.0, 0.0)).unwrap();
    assert!((d.rd_closed_form() - 1.0).abs() < 1e-15);
}

/// The profile follows the anisotropy through σ'_s = σ_s(1 − g) only (similarity relation).
#[test]
fn standard_dipole_similarity() {
    let a = StandardDipole::new(&props(1.3, 2.0, 0.01, 0.0)).unwrap();
    let b = StandardDipole::new(&props(1.3, 20.0, 0.01, 0.9)).unwrap();
    for r in [0.01e-3, 0.1e-3, 1e-3, 5e-3] {
        assert!((a.rd_profile(r) / b.rd_profile(r) - 1.0).abs() < 1e-12);
    }
}

/// Jensen et al. 2001, Fig. 5 table (published total diffuse reflectance R_d, two decimals):
/// apple (0.85, 0.84, 0.53), potato (0.77, 0.62, 0.21). The closed-form dipole with η = 1.3
/// reproduces them to within 0.01 (the table was computed with the same dipole; the last digit
/// depends on rounding of the tabulated coefficients).
#[test]
fn jensen_2001_published_reflectances() {
    let published = [
        ("Apple", [0.85, 0.84, 0.53]),
        ("Potato", [0.77, 0.62, 0.21]),
    ];
    for (name, rd) in published {
        let m = find_medium(name).unwrap();
        for c in 0..3 {
            let d = StandardDipole::new(&m.channel(c)).unwrap();
            let cf = d.rd_closed_form();
            let num = d.rd_numerical();
            eprintln!(
                "{name} channel {c}: closed form {cf:.4}, numerical {num:.4}, published {}",
                rd[c]
            );
            assert!((cf - rd[c]).abs() < 0.01, "{name} {c}: {cf} vs {}", rd[c]);
            assert!((num - cf).abs() < 1e-4);
        }
    }
    // All 12 Jensen media give reflectances in (0, 1]; Spectralon (σ_a = 0, η = 1.3) gives the
    // α' = 1 value (1 + e^0)/2 = 1: all light returns.
    for m in jensen2001_media() {
        for c in 0..3 {
            let rd = StandardDipole::new(&m.channel(c)).unwrap().rd_closed_form();
            assert!(rd > 0.0 && rd <= 1.0, "{} {c}: {rd}", m.name);
        }
    }
    let sp = find_medium("spectralon").unwrap();
    assert!(
        (StandardDipole::new(&sp.channel(1))
            .unwrap()
            .rd_closed_form()
            - 1.0)
            .abs()
            < 1e-12
    );
}

#[test]
fn presets_are_complete_and_in_si_units() {
    assert_eq!(jensen2001_media().len(), 12);
    assert_eq!(narasimhan2006_media().len(), 35);
    let apple = find_medium("apple").unwrap();
    assert_eq!(apple.sigma_s_per_m, [2290.0, 2390.0, 1970.0]);
    assert!((apple.sigma_a_per_m[2] - 46.0).abs() < 1e-9);
    assert_eq!(apple.eta, 1.3);
    assert_eq!(find_medium("Marble").unwrap().eta, 1.5);
    let milk = find_medium("regular milk").unwrap();
    assert!((milk.sigma_s_per_m[0] - 18205.2).abs() < 1e-6 && milk.g[0] == 0.75);
    assert!(find_medium("unobtainium").is_none());
    for m in jensen2001_media().iter().chain(narasimhan2006_media()) {
        for c in 0..3 {
            m.channel(c).validate().unwrap();
        }
    }
}

#[test]
fn bad_input_is_rejected_with_the_field_named() {
    let e = |p: OpticalProperties| StandardDipole::new(&p).unwrap_err().to_string();
    assert!(e(props(0.0, 1.0, 0.1, 0.0)).contains("eta"));
    assert!(e(props(-1.3, 1.0, 0.1, 0.0)).contains("eta"));
    assert!(e(props(1.3, 1.0, -0.5, 0.0)).contains("alpha'"));
    assert!(e(props(1.3, -1.0, 2.0, 0.0)).contains("alpha'"));
    assert!(e(props(1.3, 0.0, 0.0, 0.0)).contains("alpha'"));
    assert!(e(props(1.3, f64::NAN, 0.1, 0.0)).contains("sigma_s"));
    assert!(e(props(1.3, 1.0, 0.1, 1.0)).contains("g"));
    assert!(DirectionalDipole::new(&props(0.0, 1.0, 0.1, 0.0)).is_err());
}

fn rotate(q: [[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| q[i][0] * v[0] + q[i][1] * v[1] + q[i][2] * v[2])
}

/// Asserts that `sd(x_i, n_i, ω_i, x_o, n_o)` depends only on relative geometry: a rigid rotation
/// (about the axis (1,2,3)/√14 by 0.9 rad, Rodrigues) and translation of the whole configuration
/// (oblique incidence, exit normal tilted) leaves it unchanged to 1e-10. Returns the unmoved value.
fn assert_rigid_invariance(sd: impl Fn([f64; 3], [f64; 3], [f64; 3], [f64; 3], [f64; 3]) -> f64) -> f64 {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let ni = [0.0, 0.0, 1.0];
    let wi = [s, 0.0, s];
    let no = {
        let v: [f64; 3] = [0.2, 0.1, 1.0];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / l)
    };
    let xo = [0.7e-3, 0.4e-3, -0.1e-3];
    let base = sd([0.0; 3], ni, wi, xo, no);
    assert!(base > 0.0);
    let k = [1.0 / 14f64.sqrt(), 2.0 / 14f64.sqrt(), 3.0 / 14f64.sqrt()];
    let (c, sn) = (0.9f64.cos(), 0.9f64.sin());
    let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    let q: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| if i == j { c } else { 0.0 } + sn * kx[i][j] + (1.0 - c) * k[i] * k[j]));
    let t = [3e-3, -1e-3, 2e-3];
    let mv = |p: [f64; 3]| {
        let r = rotate(q, p);
        [r[0] + t[0], r[1] + t[1], r[2] + t[2]]
    };
    let moved = sd(mv([0.0; 3]), rotate(q, ni), rotate(q, wi), mv(xo), rotate(q, no));
    assert!((moved / base - 1.0).abs() < 1e-10, "{moved} vs {base}");
    base
}

/// The directional dipole depends only on relative geometry.
#[test]
fn directional_dipole_is_invariant_under_rigid_motion() {
    let m = DirectionalDipole::new(&props(1.3, 1.0, 0.01, 0.0)).unwrap();
    assert_rigid_invariance(|xi, ni, wi, xo, no| m.sd(xi, ni, wi, xo, no));
}

/// Normal incidence on a plane: the 2-D Cartesian integral of π S_d over the plane (the general
/// 3-D code path, all azimuths; midpoint rule on 40 000 × 8 nodes) equals the adaptive radial
/// integral to 2e-5, so the CLI's `rd` meets its 1e-4 accuracy target.
#[test]
fn directional_dipole_plane_integral_two_ways() {
    use std::f64::consts::PI;
    // α' = 0.99 (η = 1.3) and α' = 0.5 (η = 1.5, where clamping at 0 can act), L = 1 mm.
    for &(eta, ss, sa) in &[(1.3, 1.0, 0.01), (1.5, 1.0, 1.0)] {
        let m = DirectionalDipole::new(&props(eta, ss, sa, 0.0)).unwrap();
        let radial = m.rd_numerical();
        let n = [0.0, 0.0, 1.0];
        // Polar grid with azimuths offset so that no sample lies on the axes; r = L u/(1-u).
        let l = 1e-3;
        let (nu, nphi) = (40000, 8);
        let mut sum = 0.0;
        for i in 0..nu {
            let u = (i as f64 + 0.5) / nu as f64;
            let r = l * u / (1.0 - u);
            let jac = l / ((1.0 - u) * (1.0 - u)) / nu as f64;
            for j in 0..nphi {
                let phi = (j as f64 + 0.37) / nphi as f64 * 2.0 * PI;
                let xo = [r * phi.cos(), r * phi.sin(), 0.0];
                sum += PI * m.sd([0.0; 3], n, n, xo, n) * r * jac * 2.0 * PI / nphi as f64;
            }
        }
        eprintln!("directional rd (eta {eta}): radial {radial:.7}, polar grid {sum:.7}");
        assert!((sum - radial).abs() < 2e-5, "{sum} vs {radial}");
    }
}

/// Deterministic xorshift64* generator.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Monte Carlo reference: a semi-infinite medium with isotropic scattering and a smooth boundary
/// of relative index η, light entering at normal incidence (after the T12 transmission). Returns
/// the fraction of the entered light that leaves through the boundary, and its standard error.
fn mc_half_space(eta: f64, albedo: f64, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Rng(seed);
    let (mut s1, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        // Position z (depth, > 0 inside), direction cosine along +z (into the medium).
        let mut z = 0.0f64;
        let mut mu = 1.0f64;
        let mut w = 1.0f64;
        let mut out = 0.0;
        loop {
            let step = -(1.0 - rng.next()).ln(); // optical depths: σ_t = 1
            let znew = z + mu * step;
            if znew <= 0.0 {
                // Hits the boundary from inside: Fresnel with n_t/n_i = 1/η.
                let r = fresnel_dielectric(-mu, 1.0 / eta);
                if rng.next() >= r {
                    out = w;
                    break;
                }
                // Specular reflection: continue from the boundary with mirrored direction
                // (the remaining path length is resampled: memoryless exponential).
                z = 0.0;
                mu = -mu;
                continue;
            }
            z = znew;
            w *= albedo;
            if w < 1e-3 {
                // Russian roulette.
                if rng.next() < 0.5 {
                    break;
                }
                w *= 2.0;
            }
            mu = 2.0 * rng.next() - 1.0;
        }
        s1 += out;
        s2 += out * out;
    }
    let mean = s1 / n as f64;
    let var = (s2 / n as f64 - mean * mean) / n as f64;
    (mean, var.sqrt())
}

/// Monte Carlo check of the diffusion models: fraction of the light entering a half-space at
/// normal incidence that leaves it again (isotropic scattering, η = 1.3, 2·10⁵ paths, fixed seeds).
/// The standard dipole's R_d (Jensen 2001) must agree within 4 % + 4σ_MC at α' = 0.99 and within
/// 12 % + 4σ_MC at α' = 0.9 (diffusion theory degrades as absorption grows). The directional
/// dipole's π∫S_d dA (with its 1/(4C_φ(1/η)) normalisation; light leaving = that × 4C_φ(1/η)) is
/// printed beside it: as specified in the paper it exceeds the Monte Carlo value (see the report).
#[test]
fn dipoles_against_monte_carlo() {
    for (i, &(albedo, tol)) in [(0.99, 0.04), (0.9, 0.12)].iter().enumerate() {
        let eta = 1.3;
        let (mc, se) = mc_half_space(eta, albedo, 200_000, 12345 + i as u64);
        let p = OpticalProperties {
            eta,
            sigma_s_per_m: albedo * 1e3,
            sigma_a_per_m: (1.0 - albedo) * 1e3,
            g: 0.0,
        };
        let dd = DirectionalDipole::new(&p).unwrap();
        let dd_out = dd.rd_numerical() * 4.0 * c_phi(1.0 / eta);
        let sd = StandardDipole::new(&p).unwrap().rd_closed_form();
        eprintln!(
            "alpha' {albedo}: MC {mc:.4} ± {se:.4}; standard R_d {sd:.4} ({:+.1} %); directional leaving {dd_out:.4} ({:+.1} %)",
            (sd / mc - 1.0) * 100.0,
            (dd_out / mc - 1.0) * 100.0
        );
        assert!(
            (sd - mc).abs() < tol * mc + 4.0 * se,
            "alpha' {albedo}: {sd} vs MC {mc} ± {se}"
        );
        // The diffusion theory the directional dipole approximates, with the same boundary terms
        // but the ray source integrated exactly (see `ray_source_leaving`), is as close to the
        // Monte Carlo as the standard dipole (measured +3 % and +5 %); the paper's closed form
        // is not (+33 %, +63 %): the excess is in its point-source expansion, not in C_φ, C_E, A.
        let rs = ray_source_leaving(&dd);
        eprintln!(
            "  exact ray-source diffusion {rs:.4} ({:+.1} %)",
            (rs / mc - 1.0) * 100.0
        );
        assert!(
            (rs - mc).abs() < tol * mc + 4.0 * se,
            "alpha' {albedo}: ray source {rs} vs MC {mc} ± {se}"
        );
        assert!(
            dd_out > 1.2 * mc,
            "alpha' {albedo}: published directional {dd_out} vs MC {mc}"
        );
        // Our line-source variant (`DirectionalLineDipole`, "directional-corrected") evaluates
        // that theory with 6-node Gauss–Laguerre quadrature in the renderer's code path; stated
        // model error of diffusion theory as for the standard dipole (4 %, 12 %).
        let line = DirectionalLineDipole::new(&p).unwrap();
        let lo = line.rd_numerical() * 4.0 * c_phi(1.0 / eta);
        eprintln!("  directional-corrected {lo:.4} ({:+.1} %)", (lo / mc - 1.0) * 100.0);
        assert!(
            (lo - mc).abs() < tol * mc + 4.0 * se,
            "alpha' {albedo}: directional-corrected {lo} vs MC {mc} ± {se}"
        );
    }
}

/// The infinite-medium term S'_d of the directional dipole integrated over a plane has closed forms
/// for a source at constant offset c below the plane (x·ω = 0, x·n = 0, ω·n = −1, d = √(r² + c²))
/// and for the mirrored (virtual) configuration (x·ω = x·n = −b, ω·n = 1, d = √(r² + b²)), using
/// d/dd[−e^{−σd}/d] = (1 + σd)e^{−σd}/d² and d/dd[−(1 + σd)e^{−σd}/d³] = (3(1 + σd) + σ²d²)e^{−σd}/d⁴:
///   ∫S'_real dA = 2π N [C_φ e^{−σc}/(σD) + 3D C_E e^{−σc}/c],
///   ∫S'_virt dA = 2π N [C_φ e^{−σb}/(σD) − 3C_φ e^{−σb} − C_E e^{−σb}(1 − 3Dσ)],  N = 1/(4C_φ(1/η)4π²).
/// This checks our transcription of the paper's S'_d term by term (and the plane quadrature).
#[test]
fn directional_dipole_infinite_medium_term_closed_forms() {
    let pi = std::f64::consts::PI;
    for &(eta, s, a) in &[(1.3, 1.0, 0.01), (1.0, 2.0, 0.2), (1.5, 0.5, 0.05)] {
        let m = DirectionalDipole::new(&props(eta, s, a, 0.0)).unwrap();
        let n = [0.0, 0.0, 1.0];
        let (d, st, cp, ce, nn) = (m.props.d_m, m.props.sigma_tr_per_m, m.c_phi, m.c_e, m.norm);
        let c = 0.7e-3;
        let real = integrate_plane(
            |r| m.sd_prime([r, 0.0, 0.0], [0.0, 0.0, -1.0], (r * r + c * c).sqrt(), n),
            c,
        );
        let real_cf =
            2.0 * pi * nn * (cp * (-st * c).exp() / (st * d) + 3.0 * d * ce * (-st * c).exp() / c);
        assert!(
            (real / real_cf - 1.0).abs() < 1e-8,
            "real: {real} vs {real_cf}"
        );
        let b = 2.0 * m.a * m.d_e_m;
        let virt = integrate_plane(
            |r| m.sd_prime([r, 0.0, -b], [0.0, 0.0, 1.0], (r * r + b * b).sqrt(), n),
            b,
        );
        let e = (-st * b).exp();
        let virt_cf =
            2.0 * pi * nn * (cp * e / (st * d) - 3.0 * cp * e - ce * e * (1.0 - 3.0 * d * st));
        assert!(
            (virt / virt_cf - 1.0).abs() < 1e-8,
            "virtual: {virt} vs {virt_cf}"
        );
    }
}

/// Refraction into the medium obeys Snell's law (sin θ_t = sin θ_i / η), gives a unit vector
/// pointing inwards, and S_d is finite and ≥ 0 for random front- and back-lit configurations.
#[test]
fn directional_dipole_refraction_and_positivity() {
    let m = DirectionalDipole::new(&props(1.4, 1.5, 0.02, 0.3)).unwrap();
    let mut rng = Rng(99);
    let unit = |rng: &mut Rng| {
        let z = 2.0 * rng.next() - 1.0;
        let phi = 2.0 * std::f64::consts::PI * rng.next();
        let s = (1.0 - z * z).sqrt();
        [s * phi.cos(), s * phi.sin(), z]
    };
    for _ in 0..2000 {
        let ni = unit(&mut rng);
        let mut wi = unit(&mut rng);
        let c = wi[0] * ni[0] + wi[1] * ni[1] + wi[2] * ni[2];
        if c < 0.0 {
            wi = wi.map(|v| -v);
        }
        let c = c.abs();
        let w12 = m.refract_in(wi, ni);
        let len = (w12[0] * w12[0] + w12[1] * w12[1] + w12[2] * w12[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-12);
        let ct = -(w12[0] * ni[0] + w12[1] * ni[1] + w12[2] * ni[2]);
        assert!(ct > 0.0);
        let (si, st) = (
            (1.0 - c * c).max(0.0).sqrt(),
            (1.0 - ct * ct).max(0.0).sqrt(),
        );
        assert!((st - si / 1.4).abs() < 1e-12, "{st} vs {}", si / 1.4);
        let xo = unit(&mut rng).map(|v| v * 2e-3 * rng.next());
        let no = unit(&mut rng);
        let s = m.sd([0.0; 3], ni, wi, xo, no);
        assert!(s.is_finite() && s >= 0.0, "{s}");
    }
    // Coincident points: the modified normal falls back to nᵢ; the value is finite and positive.
    let n = [0.0, 0.0, 1.0];
    let s0 = m.sd([0.0; 3], n, n, [0.0; 3], n);
    assert!(s0.is_finite() && s0 > 0.0);
}

/// Two independent transcriptions of Narasimhan et al. 2006 agree: σ_s(1 − g) and σ_a of our preset
/// table (from Mitsuba 0.5) against pbrt-v3's reduced table, within 2 % (Sprite's tiny σ_s within
/// 4 %, rounding of 1e-4 values), for all 35 media and channels.
#[test]
fn narasimhan_presets_match_pbrt_reduced_table() {
    let text = include_str!("../../data/media/narasimhan2006_media_reduced_pbrt3.csv");
    let mut rows = 0;
    for line in text
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .skip(1)
    {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let v: Vec<f64> = f[1..].iter().map(|x| x.parse().unwrap()).collect();
        let m = find_medium(f[0]).unwrap_or_else(|| panic!("{} missing", f[0]));
        let tol = if f[0] == "Sprite" { 0.04 } else { 0.02 };
        for c in 0..3 {
            let sp = m.sigma_s_per_m[c] * (1.0 - m.g[c]) * 1e-3;
            let sa = m.sigma_a_per_m[c] * 1e-3;
            let close = |a: f64, b: f64| (a - b).abs() <= tol * b.abs().max(1e-12) + 1e-9;
            assert!(
                close(sp, v[c]),
                "{} ch {c}: sigma_s' {sp} vs {}",
                f[0],
                v[c]
            );
            assert!(
                close(sa, v[3 + c]),
                "{} ch {c}: sigma_a {sa} vs {}",
                f[0],
                v[3 + c]
            );
        }
        rows += 1;
    }
    assert_eq!(rows, 35);
}

/// Total diffuse reflectance, as light leaving per unit light entering, of the diffusion theory the
/// directional dipole approximates, integrated exactly instead of by the paper's point-source
/// expansion: the refracted ray at normal incidence is a line of sources of density
/// α'σ'_t e^{−σ'_t s} at depth s, each with its image mirrored in the extrapolated boundary
/// z_b = A·d_e above the surface, and exitance C_φφ + C_E(E·n) (the same C_φ, C_E, A, d_e, D, σ_tr
/// as the model). Over the plane, a point source at distance h gives ∫G dA = e^{−σ_tr h}/(2Dσ_tr)
/// (G = e^{−σ_tr d}/(4πDd)) and flux ∫E·n dA = e^{−σ_tr h}/2; averaging e^{−σ_tr s} over the source
/// density gives m = σ'_t/(σ'_t + σ_tr), so
///   leaving = α'm [C_φ(1 − e^{−2σ_tr z_b})/(2Dσ_tr) + C_E(1 + e^{−2σ_tr z_b})/2],
/// and for σ_a = 0: leaving = C_φ z_b/D + C_E. Independent derivation (this file, not the paper).
fn ray_source_leaving(m: &DirectionalDipole) -> f64 {
    let p = &m.props;
    let (d, s, ap) = (p.d_m, p.sigma_tr_per_m, p.alpha_prime);
    let zb = m.a * m.d_e_m;
    if s * zb < 1e-9 {
        return ap * (m.c_phi * zb / d + m.c_e);
    }
    let mm = p.sigma_t_prime_per_m / (p.sigma_t_prime_per_m + s);
    let e = (-2.0 * s * zb).exp();
    ap * mm * (m.c_phi * (1.0 - e) / (2.0 * d * s) + m.c_e * 0.5 * (1.0 + e))
}

/// Analysis of the directional dipole's total diffuse reflectance at normal incidence, σ_a = 0
/// (the published model gives rd = 1.346 at α' = 1, η = 1, where all entering light must leave).
/// With σ_tr = 0 every term of π∫S_d dA has a closed form except those of the real source:
///   π∫S_d dA = N/2 [C_φ/D ∫(1/d_r − 1/d_v) r dr + 3C_φ + C_E + 3DC_E ∫ r dr/d_r³],
/// N = 1/(4C_φ(1/η)), d_v = √(r² + (2Ad_e)²). If the real source sat at constant depth c
/// (d_r = √(r² + c²)) this is N/2 [C_φ(2Ad_e − c)/D + 3C_φ + C_E + 3DC_E/c], which for c = 1/σ'_t
/// = 3D (the mean depth of first scattering) equals the exact ray-source value N(C_φAd_e/D + C_E)
/// of [`ray_source_leaving`]. The paper's d_r (Frisvad et al. 2014; tutorial "Diffusive part of
/// the directional dipole") is √(r² + Dμ₀(Dμ₀ − 2d_e cos β)), which tends to D = c/3 at r = 0:
/// at η = 1 (C_φ = 1/4, C_E = 1/2) the fluence terms give 0.653 instead of C_φ·2.131 = 0.533 and
/// the real source's flux term 0.437 instead of C_E/2 = 0.25, so the total exceeds the exact value
/// by 14–30 % (η = 1.5…1; more with absorption). This is a property of the published closed form,
/// which our implementation reproduces term by term (Mitsuba and appleseed ports agree, see
/// docs/validation.md). The test checks (1) the constant-depth identity to 1e-6 through the
/// model's own S'_d, (2) the published model's excess over the exact value, pinned in [1.1, 1.4]
/// with the η = 1 value 1.346 ± 0.002, and (3) reflectometry's normal-incidence R(r) integrates to
/// T12(0)·rd·4C_φ(1/η) (same model, second implementation; it takes C₁, C₂ by quadrature instead
/// of the d'Eon–Irving fits, hence 3e-3: measured 4e-4).
#[test]
fn directional_dipole_total_reflectance_against_ray_source_diffusion() {
    for &eta in &[1.0, 1.3, 1.5] {
        let m = DirectionalDipole::new(&props(eta, 1.0, 0.0, 0.0)).unwrap();
        let n = [0.0, 0.0, 1.0];
        let n0 = 1.0 / (4.0 * c_phi(1.0 / eta));
        let exact = n0 * ray_source_leaving(&m);
        // (1) Real source at the constant depth c = 1/σ'_t, virtual source as in the model.
        let c = 1.0 / m.props.sigma_t_prime_per_m;
        let b = 2.0 * m.a * m.d_e_m;
        let const_depth = integrate_plane(
            |r| {
                std::f64::consts::PI
                    * (m.sd_prime([r, 0.0, 0.0], [0.0, 0.0, -1.0], (r * r + c * c).sqrt(), n)
                        - m.sd_prime([r, 0.0, -b], [0.0, 0.0, 1.0], (r * r + b * b).sqrt(), n))
            },
            c,
        );
        assert!(
            (const_depth / exact - 1.0).abs() < 1e-6,
            "eta {eta}: constant-depth {const_depth} vs exact ray source {exact}"
        );
        // (2) The published model.
        let rd = m.rd_numerical();
        eprintln!(
            "eta {eta}: published rd {rd:.4}, exact ray-source rd {exact:.4}, ratio {:.3}",
            rd / exact
        );
        assert!(
            rd / exact > 1.1 && rd / exact < 1.4,
            "eta {eta}: {rd} vs {exact}"
        );
        if eta == 1.0 {
            assert!((rd - 1.346).abs() < 2e-3, "{rd}");
        }
        // (3) Second implementation (optics::reflectometry), per mm, σ'_t = 1 mm⁻¹.
        let refl = integrate_plane(
            |r| optics::reflectometry::directional_dipole_rd_per_mm2(r, 0.0, 1.0, eta),
            1.0,
        );
        let t12 = optics::reflectometry::t12_normal(eta);
        assert!(
            (refl / (t12 * rd / n0) - 1.0).abs() < 3e-3,
            "eta {eta}: reflectometry {refl} vs {}",
            t12 * rd / n0
        );
    }
}

/// Gauss–Laguerre rule behind `DirectionalLineDipole`: ∫₀^∞ e^{−s} s^k ds = k! exactly for
/// k ≤ 2n − 1, and ∫₀^∞ e^{−(1+c)s} ds = 1/(1 + c) closely for the attenuation rates the model
/// integrates (c = σ_tr μ/σ'_t ≤ 0.8 here).
#[test]
fn gauss_laguerre_rule_is_exact_for_polynomials() {
    for n in [1, 2, 4, LINE_SOURCE_NODES, 10] {
        let rule = gauss_laguerre(n);
        assert_eq!(rule.len(), n);
        let mut fact = 1.0;
        for k in 0..2 * n {
            if k > 0 {
                fact *= k as f64;
            }
            let q: f64 = rule.iter().map(|&(x, w)| w * x.powi(k as i32)).sum();
            assert!((q / fact - 1.0).abs() < 1e-10, "n {n}, k {k}: {q} vs {fact}");
        }
        assert!(rule.windows(2).all(|w| w[0].0 < w[1].0 && w[0].1 > 0.0));
    }
    let rule = gauss_laguerre(LINE_SOURCE_NODES);
    for c in [0.05, 0.3, 0.8] {
        let q: f64 = rule.iter().map(|&(x, w)| w * (-c * x).exp()).sum();
        assert!((q * (1.0 + c) - 1.0).abs() < 1e-5, "c {c}: {q}");
    }
}

/// n-point Gauss–Legendre integrates x^k over [−1, 1] exactly for k < 2n: 2/(k+1) for even k,
/// 0 for odd k.
#[test]
fn gauss_legendre_rule_is_exact_for_polynomials() {
    for n in [2, 5, 12, 48] {
        let rule = gauss_legendre(n);
        assert_eq!(rule.len(), n);
        for k in 0..2 * n {
            let q: f64 = rule.iter().map(|&(x, w)| w * x.powi(k as i32)).sum();
            let exact = if k % 2 == 0 { 2.0 / (k as f64 + 1.0) } else { 0.0 };
            assert!((q - exact).abs() < 1e-12, "n {n}, k {k}: {q} vs {exact}");
        }
    }
}

/// Closed form of the line-source theory over a half-space for light refracted at cosine `mu_t`
/// (depth of the source at distance t along the ray: tμ_t): the image of each source lies
/// 2(z_b + tμ_t) above it, and e^{−σ_tr tμ_t} averaged over the density σ'_t e^{−σ'_t t} is
/// m = σ'_t/(σ'_t + σ_trμ_t). Light leaving per unit light entering (see `ray_source_leaving`).
fn line_source_leaving(m: &DirectionalDipole, mu_t: f64) -> f64 {
    let p = &m.props;
    let (d, s, ap) = (p.d_m, p.sigma_tr_per_m, p.alpha_prime);
    let zb = m.a * m.d_e_m;
    if s * zb < 1e-9 {
        return ap * (m.c_phi * zb / d + m.c_e);
    }
    let mm = p.sigma_t_prime_per_m / (p.sigma_t_prime_per_m + s * mu_t);
    let e = (-2.0 * s * zb).exp();
    ap * mm * (m.c_phi * (1.0 - e) / (2.0 * d * s) + m.c_e * 0.5 * (1.0 + e))
}

/// The corrected (line-source) directional dipole integrated over a plane through the general 3-D
/// code path (oblique incidence, all azimuths) equals the closed form of the theory it
/// implements, at normal and oblique incidence, with and without absorption: checks the source
/// positions, images, monopole terms and normalisation. Tolerance 2e-4 (quadrature).
#[test]
fn directional_corrected_plane_integral_equals_line_source_closed_form() {
    use std::f64::consts::PI;
    let n = [0.0, 0.0, 1.0];
    for &(eta, ss, sa) in &[(1.0, 1.0, 0.0), (1.3, 0.99, 0.01), (1.5, 0.9, 0.1), (1.3, 2.0, 0.02)] {
        let p = props(eta, ss, sa, 0.0);
        let line = DirectionalLineDipole::new(&p).unwrap();
        let m = line.base;
        let n0 = 1.0 / (4.0 * c_phi(1.0 / eta));
        for theta_deg in [0.0f64, 35.0, 70.0] {
            let th = theta_deg.to_radians();
            let wi = [th.sin(), 0.0, th.cos()];
            let w12 = m.refract_in(wi, n);
            let mu_t = -w12[2];
            let nphi = 64;
            let rd = integrate_plane(
                |r| {
                    let mut s = 0.0;
                    for j in 0..nphi {
                        let phi = (j as f64 + 0.5) / nphi as f64 * 2.0 * PI;
                        s += line.sd([0.0; 3], n, wi, [r * phi.cos(), r * phi.sin(), 0.0], n);
                    }
                    PI * s / nphi as f64
                },
                1.0 / m.props.sigma_t_prime_per_m,
            );
            let exact = n0 * line_source_leaving(&m, mu_t);
            eprintln!("eta {eta} ss {ss} sa {sa} theta {theta_deg}: rd {rd:.6} closed form {exact:.6}");
            assert!((rd / exact - 1.0).abs() < 2e-4, "{rd} vs {exact}");
            if theta_deg == 0.0 {
                assert!((line.rd_numerical() / exact - 1.0).abs() < 1e-4);
            }
        }
    }
}

/// The corrected model's radial profile at normal incidence against the line integral evaluated
/// by adaptive quadrature along the ray (independent of the Gauss–Laguerre rule): within 1.5 %
/// from one transport mean free path outwards (closer in, the 6-node rule smooths the 1/r
/// peak by design; the total is unaffected, see the plane-integral test).
#[test]
fn directional_corrected_profile_against_adaptive_line_integral() {
    use std::f64::consts::PI;
    let p = props(1.3, 1.0, 0.01, 0.0);
    let line = DirectionalLineDipole::new(&p).unwrap();
    let m = line.base;
    let (st, d, cp, ce) = (m.props.sigma_tr_per_m, m.props.d_m, m.c_phi, m.c_e);
    let spt = m.props.sigma_t_prime_per_m;
    let zb = m.a * m.d_e_m;
    let mono = |r: f64, h: f64| {
        // Exit point at lateral distance r; source at signed height h below the exit plane
        // (x·n = h).
        let d2 = r * r + h * h;
        let dd = d2.sqrt();
        m.norm * (-st * dd).exp() / (d2 * dd) * (cp * d2 / d + ce * (1.0 + st * dd) * h)
    };
    for r_mfp in [1.0, 2.0, 4.0, 8.0] {
        let r = r_mfp / spt;
        // ∫₀^∞ α'σ'_t e^{−σ'_t t}[S⁰(real at depth t) − S⁰(image at height 2z_b + t)] dt,
        // t = L u/(1 − u).
        let l = 1.0 / spt;
        let f = |u: f64| {
            if u >= 1.0 {
                return 0.0;
            }
            let t = l * u / (1.0 - u);
            let jac = l / ((1.0 - u) * (1.0 - u));
            m.props.alpha_prime * spt * (-spt * t).exp() * (mono(r, t) - mono(r, -(2.0 * zb + t))) * jac
        };
        // Composite Simpson on [0, 1) with many panels (smooth integrand for r ≥ 1 mfp).
        let k = 20000;
        let mut s = f(0.0);
        for i in 1..k {
            s += f(i as f64 / k as f64) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        let exact = PI * s / (3.0 * k as f64);
        let got = line.rd_profile(r);
        eprintln!("r = {r_mfp} mfp: Gauss–Laguerre {got:.6e}, adaptive {exact:.6e}, ratio {:.4}", got / exact);
        assert!((got / exact - 1.0).abs() < 0.015, "r {r_mfp} mfp: {got} vs {exact}");
    }
}

/// Invariance under rigid motion and positivity of the corrected model (oblique incidence,
/// tilted exit normal, back-lit configuration included).
#[test]
fn directional_corrected_is_invariant_and_non_negative() {
    let line = DirectionalLineDipole::new(&props(1.3, 1.0, 0.01, 0.0)).unwrap();
    assert_rigid_invariance(|xi, ni, wi, xo, no| line.sd(xi, ni, wi, xo, no));
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let (ni, wi) = ([0.0, 0.0, 1.0], [s, 0.0, s]);
    // Back-lit exit point (normal facing away from the refracted ray) and a grid of others.
    for i in 0..200 {
        let a = i as f64 * 0.37;
        let xo = [1e-3 * a.cos(), 1e-3 * a.sin(), -2e-3 * (i % 3) as f64];
        let no = [a.sin() * 0.6, 0.0, if i % 2 == 0 { 0.8 } else { -0.8 }];
        let v = line.sd([0.0; 3], ni, wi, xo, no);
        assert!(v.is_finite() && v >= 0.0, "{v}");
    }
}

/// Monte Carlo in the quarter space {x < 0, y < 0} (isotropic scattering, σ_t = 1 per length
/// unit, smooth boundary of index η on both faces y = 0 and x = 0): a pencil beam enters at
/// normal incidence at (−d, 0, 0). Returns the fraction of the entered light leaving through the
/// face y = 0 (the entry face) and its standard error.
fn mc_quarter_space_entry_face(eta: f64, albedo: f64, d: f64, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Rng(seed);
    let (mut s1, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let mut p = [-d, 0.0, 0.0];
        let mut w3 = [0.0, -1.0, 0.0];
        let mut w = 1.0f64;
        let mut out = 0.0;
        loop {
            let step = -(1.0 - rng.next()).ln();
            // Distances to the faces y = 0 (normal +y) and x = 0 (normal +x).
            let ty = if w3[1] > 0.0 { -p[1] / w3[1] } else { f64::INFINITY };
            let tx = if w3[0] > 0.0 { -p[0] / w3[0] } else { f64::INFINITY };
            let (tb, face) = if ty <= tx { (ty, 1) } else { (tx, 0) };
            if step >= tb {
                for k in 0..3 {
                    p[k] += tb * w3[k];
                }
                p[face] = 0.0;
                let r = fresnel_dielectric(w3[face], 1.0 / eta);
                if rng.next() >= r {
                    if face == 1 {
                        out = w;
                    }
                    break;
                }
                w3[face] = -w3[face];
                continue;
            }
            for k in 0..3 {
                p[k] += step * w3[k];
            }
            w *= albedo;
            if w < 1e-3 {
                if rng.next() < 0.5 {
                    break;
                }
                w *= 2.0;
            }
            let mu = 2.0 * rng.next() - 1.0;
            let phi = 2.0 * std::f64::consts::PI * rng.next();
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            w3 = [s * phi.cos(), mu, s * phi.sin()];
        }
        s1 += out;
        s2 += out * out;
    }
    let mean = s1 / n as f64;
    ((mean), ((s2 / n as f64 - mean * mean) / n as f64).sqrt())
}

/// ∫ f dA over the half plane {x < 0} of the plane y = 0, f given at (x, z) (m), in polar
/// coordinates about (−d, 0): panels in ρ graded towards 0, Gauss–Legendre in ρ and φ.
fn integrate_half_plane(f: impl Fn(f64, f64) -> f64, d: f64, length: f64) -> f64 {
    let gl = gauss_legendre(12);
    let gphi = gauss_legendre(48);
    let pi = std::f64::consts::PI;
    let mut total = 0.0;
    // φ measured from +x (towards the edge); four φ panels, split where the edge is near.
    for (a, b) in [(-pi, -pi / 2.0), (-pi / 2.0, 0.0), (0.0, pi / 2.0), (pi / 2.0, pi)] {
        for &(u, wu) in &gphi {
            let phi = 0.5 * (a + b) + 0.5 * (b - a) * u;
            let wphi = 0.5 * (b - a) * wu;
            let rmax = if phi.cos() > 1e-12 { (d / phi.cos()).min(60.0 * length) } else { 60.0 * length };
            let mut lo = 0.0;
            let mut hi = 1e-3 * length;
            while lo < rmax {
                let h = hi.min(rmax);
                for &(v, wv) in &gl {
                    let r = 0.5 * (lo + h) + 0.5 * (h - lo) * v;
                    total += wphi * 0.5 * (h - lo) * wv * r * f(-d + r * phi.cos(), r * phi.sin());
                }
                lo = h;
                hi *= 2.0;
            }
        }
    }
    total
}

/// Edge images (`DirectionalLineDipole::sd_refracted_edge`) against Monte Carlo in a right-angle
/// wedge (quarter space), light entering at normal incidence one diffusion length or less from the
/// edge: the light leaving through the entry face. The half-space dipole evaluated pairwise (as
/// the renderer does by default) ignores the second face and over-predicts it; with the edge
/// image the model must agree with the Monte Carlo as well as it does on the half-space (the
/// tolerance of `dipoles_against_monte_carlo` at α' = 0.99: 4 % + 4σ_MC). η = 1.3, σ'_t = 1/mm,
/// α' = 0.99 (1/σ_tr = 5.8 mm), entry 2 and 5 mm from the edge, 10⁵ paths each, fixed seeds.
#[test]
fn edge_images_against_monte_carlo_in_a_wedge() {
    let (eta, albedo) = (1.3, 0.99);
    let p = OpticalProperties { eta, sigma_s_per_m: albedo * 1e3, sigma_a_per_m: (1.0 - albedo) * 1e3, g: 0.0 };
    let m = DirectionalLineDipole::new(&p).unwrap();
    let k = std::f64::consts::PI * 4.0 * c_phi(1.0 / eta);
    let n = [0.0, 1.0, 0.0];
    let edge_n = [1.0, 0.0, 0.0];
    for (i, &d_mm) in [2.0, 5.0].iter().enumerate() {
        let d = d_mm * 1e-3;
        let xi = [-d, 0.0, 0.0];
        let plain = k * integrate_half_plane(|x, z| m.sd(xi, n, n, [x, 0.0, z], n), d, 1e-3);
        let edge = k * integrate_half_plane(|x, z| m.sd_edge(xi, n, n, [x, 0.0, z], n, edge_n, 0.0), d, 1e-3);
        let half = m.rd_numerical() * 4.0 * c_phi(1.0 / eta);
        let (mc, se) = mc_quarter_space_entry_face(eta, albedo, d_mm, 100_000, 777 + i as u64);
        eprintln!(
            "entry {d_mm} mm from the edge: MC {mc:.4} ± {se:.4}; dipole {plain:.4} ({:+.1} %), with edge image {edge:.4} ({:+.1} %); half-space dipole {half:.4}",
            (plain / mc - 1.0) * 100.0,
            (edge / mc - 1.0) * 100.0
        );
        // The plain dipole on the truncated face is the half-space integral minus the part beyond
        // the edge (a check of the quadrature against `rd_numerical`'s).
        assert!(plain < half, "{plain} vs half-space {half}");
        assert!((edge - mc).abs() < 0.04 * mc + 4.0 * se, "edge image {edge} vs MC {mc} ± {se}");
        // The finite-geometry error being corrected: the plain dipole is further off.
        assert!((plain - mc).abs() > (edge - mc).abs(), "plain {plain}, edge {edge}, MC {mc}");
    }
}
