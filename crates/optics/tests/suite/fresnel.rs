//! Fresnel equations: closed forms, Brewster and critical angles, conservation, complex
//! indices against published reflectances, and the diffuse Fresnel reflectance against
//! Egan & Hilgeman's polynomial fit.

use num_complex::Complex64;
use optics::fresnel::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn normal_incidence_is_squared_index_ratio() {
    for &n in &[1.0, 1.33, 1.5, 2.4, 0.75, 1.0 / 1.5] {
        let expect = ((n - 1.0) / (n + 1.0)) * ((n - 1.0) / (n + 1.0));
        assert!(close(fresnel_dielectric(1.0, n), expect, 1e-15), "n = {n}");
    }
    // Glass in air: 4 %.
    assert!(close(fresnel_dielectric(1.0, 1.5), 0.04, 1e-15));
}

#[test]
fn brewster_angle_has_zero_p_reflectance() {
    for &n in &[1.33f64, 1.5, 2.0, 1.0 / 1.5] {
        let theta_b = n.atan(); // tan θ_B = n_t / n_i
        let (rs, rp) = fresnel_dielectric_sp(theta_b.cos(), n);
        assert!(rp < 1e-28, "R_p at Brewster = {rp} for n = {n}");
        assert!(rs > 0.01, "R_s at Brewster should not vanish: {rs}");
        // And R_p is positive on both sides of it.
        let (_, rp_lo) = fresnel_dielectric_sp((theta_b - 0.05).cos(), n);
        let (_, rp_hi) = fresnel_dielectric_sp((theta_b + 0.05).cos(), n);
        assert!(rp_lo > 1e-6 && rp_hi > 1e-6);
    }
}

#[test]
fn total_internal_reflection_above_critical_angle() {
    let eta: f64 = 1.0 / 1.5; // glass to air
    let theta_c = eta.asin();
    for k in 1..=20 {
        let theta = theta_c + (std::f64::consts::FRAC_PI_2 - theta_c) * k as f64 / 20.0;
        assert_eq!(fresnel_dielectric(theta.cos(), eta), 1.0);
        assert!(cos_theta_transmitted(theta.cos(), eta).is_none());
    }
    let just_below = fresnel_dielectric((theta_c - 1e-3).cos(), eta);
    assert!(just_below < 1.0 && just_below > 0.5, "{just_below}");
    // Incidence from the other side through a negative cosine inverts η.
    let c = (theta_c + 0.1).cos();
    assert_eq!(fresnel_dielectric(-c, 1.5), 1.0);
}

#[test]
fn reflectance_plus_transmittance_is_one_and_reciprocal() {
    for &n in &[1.2, 1.5, 2.4] {
        for k in 0..=50 {
            let cos_i = k as f64 / 50.0;
            let r = fresnel_dielectric(cos_i, n);
            let t = fresnel_dielectric_transmittance(cos_i, n);
            assert!((0.0..=1.0).contains(&r));
            assert!(close(r + t, 1.0, 1e-15));
            // Stokes reciprocity: the reverse path through the refracted angle has the same R.
            if let Some(cos_t) = cos_theta_transmitted(cos_i, n).filter(|_| cos_i > 0.0) {
                let r_back = fresnel_dielectric(cos_t, 1.0 / n);
                assert!(
                    close(r, r_back, 1e-12),
                    "n {n} cos {cos_i}: {r} vs {r_back}"
                );
                // Power transmittance from the amplitude coefficient:
                // T_s = (n cos_t / cos_i) t_s², t_s = 2 cos_i / (cos_i + n cos_t).
                if cos_i > 0.0 {
                    let ts = 2.0 * cos_i / (cos_i + n * cos_t);
                    let tp = 2.0 * cos_i / (n * cos_i + cos_t);
                    let t_amp = 0.5 * (n * cos_t / cos_i) * (ts * ts + tp * tp);
                    assert!(close(t, t_amp, 1e-12), "{t} vs {t_amp}");
                }
            }
        }
    }
}

#[test]
fn complex_index_reduces_to_dielectric_limit() {
    for &n in &[1.33, 1.5, 1.0 / 1.5] {
        for k in 0..=40 {
            let cos_i = k as f64 / 40.0;
            let a = fresnel_complex(cos_i, Complex64::new(n, 0.0));
            let b = fresnel_dielectric(cos_i, n);
            assert!(close(a, b, 1e-12), "n {n} cos {cos_i}: {a} vs {b}");
            let (cs, cp) = fresnel_complex_sp(cos_i, Complex64::new(n, 0.0));
            let (ds, dp) = fresnel_dielectric_sp(cos_i, n);
            assert!(close(cs, ds, 1e-12) && close(cp, dp, 1e-12));
        }
    }
}

#[test]
fn complex_index_closed_forms() {
    // Normal incidence: R = ((n−1)² + k²)/((n+1)² + k²).
    // Abelès (1950): at 45° incidence R_p = R_s² for ANY complex index.
    for &(n, k) in &[(0.3455, 2.730625), (0.963, 6.7), (1.5, 0.01), (0.13, 2.88)] {
        let eta = Complex64::new(n, k);
        let r0 = fresnel_complex(1.0, eta);
        let expect = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!(close(r0, expect, 1e-13));
        let (rs, rp) = fresnel_complex_sp(std::f64::consts::FRAC_1_SQRT_2, eta);
        assert!(
            close(rp, rs * rs, 1e-12),
            "Abelès: R_p {rp} vs R_s² {}",
            rs * rs
        );
        // Grazing incidence reflects everything; transmittance is the complement.
        assert!(close(fresnel_complex(0.0, eta), 1.0, 1e-12));
        assert!(close(
            fresnel_complex_transmittance(0.5, eta) + fresnel_complex(0.5, eta),
            1.0,
            1e-15
        ));
        // Metals: R_s grows monotonically with angle, R_p dips at the pseudo-Brewster angle.
        let (rs30, _) = fresnel_complex_sp(30f64.to_radians().cos(), eta);
        let (rs60, _) = fresnel_complex_sp(60f64.to_radians().cos(), eta);
        assert!(rs60 > rs30 && rs30 > r0 - 1e-12);
    }
}

/// Read (wavelength_nm, eta, k) rows of a bundled optical-constants table.
fn ior_table(name: &str) -> Vec<(f64, f64, f64)> {
    let path = format!("{}/data/ior/{name}.csv", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    text.lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|s| s.trim().parse().unwrap()).collect();
            (v[0], v[1], v[2])
        })
        .collect()
}

fn nearest(table: &[(f64, f64, f64)], lambda_nm: f64) -> Complex64 {
    let r = table
        .iter()
        .min_by(|a, b| (a.0 - lambda_nm).abs().total_cmp(&(b.0 - lambda_nm).abs()))
        .unwrap();
    Complex64::new(r.1, r.2)
}

#[test]
fn metals_match_published_normal_reflectance() {
    // Normal-incidence reflectance of bulk metals in air, from the handbook curves
    // (M. Bass (ed.), Handbook of Optics vol. II, 2nd ed., ch. 35 "Optical properties of
    // metals"; the same values appear in the CRC Handbook table "Reflection of metals"):
    // Al ≈ 0.92 across the visible, Ag ≈ 0.96 at 550 nm, Au ≈ 0.38 at 450 nm (why gold is
    // yellow) and ≈ 0.94 at 650 nm, Cu ≈ 0.60 at 500 nm and ≈ 0.94 at 650 nm.
    let cases = [
        ("Al", 550.0, 0.92, 0.01),
        ("Ag", 550.0, 0.96, 0.01),
        ("Au", 450.0, 0.38, 0.03),
        ("Au", 650.0, 0.94, 0.02),
        ("Cu", 500.0, 0.60, 0.03),
        ("Cu", 650.0, 0.94, 0.02),
    ];
    for (metal, lambda, expect, tol) in cases {
        let eta = nearest(&ior_table(metal), lambda);
        let r = fresnel_complex(1.0, eta);
        assert!(
            close(r, expect, tol),
            "{metal} at {lambda} nm: R = {r}, handbook {expect}"
        );
    }
    // Gold: the red end reflects more than the blue end by a factor > 2.
    let au = ior_table("Au");
    assert!(
        fresnel_complex(1.0, nearest(&au, 700.0)) > 2.0 * fresnel_complex(1.0, nearest(&au, 450.0))
    );
}

#[test]
fn moments_closed_forms() {
    // Index-matched: R ≡ 0.
    assert!(fresnel_moment(1, 1.0).abs() < 1e-15);
    // From a dense medium into air: everything beyond the critical angle reflects, so
    // C_0(1/n) ≥ 1 − √(1 − 1/n²)... and internal F_dr obeys the exact relation between
    // internal and external diffuse reflectance (energy + reciprocity, e.g. Walsh; Egan &
    // Hilgeman): 1 − F_dr(1/n) = (1 − F_dr(n)) / n².
    for &n in &[1.1, 1.33, 1.5, 2.0, 2.5] {
        let ext = fresnel_diffuse_reflectance(n);
        let int = fresnel_diffuse_reflectance(1.0 / n);
        assert!(
            close(1.0 - int, (1.0 - ext) / (n * n), 1e-10),
            "n {n}: {ext} {int}"
        );
        let mu_c = (1.0 - 1.0 / (n * n)).sqrt();
        assert!(fresnel_moment(0, 1.0 / n) > mu_c);
    }
    // Normal-ish incidence dominates nothing special: C_i decreases with order.
    for &eta in &[0.6, 1.5] {
        let c: Vec<f64> = (0..4).map(|i| fresnel_moment(i, eta)).collect();
        assert!(c.windows(2).all(|w| w[1] < w[0]), "{c:?}");
    }
}

#[test]
fn moments_agree_with_brute_force_quadrature() {
    // Independent method: midpoint rule with 2 million points.
    for &eta in &[0.5, 1.0 / 1.33, 1.3, 1.5, 3.0] {
        for order in 0..=3u32 {
            let m = 2_000_000;
            let h = 1.0 / m as f64;
            let brute: f64 = (0..m)
                .map(|i| {
                    let mu = (i as f64 + 0.5) * h;
                    fresnel_dielectric(mu, eta) * mu.powi(order as i32) * h
                })
                .sum();
            let fast = fresnel_moment(order, eta);
            assert!(
                close(fast, brute, 1e-8),
                "eta {eta} order {order}: {fast} vs {brute}"
            );
        }
    }
}

#[test]
fn diffuse_reflectance_matches_egan_hilgeman() {
    // Egan & Hilgeman, Optical Properties of Inhomogeneous Materials (Academic Press 1979),
    // fit quoted by Jensen et al. 2001 eq. (4) for the internal diffuse reflectance of a
    // medium of relative index η: F_dr ≈ −1.440/η² + 0.710/η + 0.668 + 0.0636 η.
    // The fit is a least-squares polynomial for the refractive indices of real materials;
    // it is within a few tenths of a percent for 1.2 ≤ η ≤ 2 and degrades beyond η ≈ 2.5
    // (1.7 % high at η = 3), so we check it on 1.05–2.5 only.
    for k in 0..=29 {
        let n = 1.05 + k as f64 * 0.05; // 1.05 .. 2.5
        let fit = -1.440 / (n * n) + 0.710 / n + 0.668 + 0.0636 * n;
        let exact = fresnel_diffuse_reflectance(1.0 / n);
        assert!(
            close(exact, fit, 0.006),
            "η {n}: exact {exact} vs fit {fit}"
        );
        if (1.2..=2.0).contains(&n) {
            assert!(
                (exact - fit).abs() / exact < 0.002,
                "η {n}: exact {exact} vs fit {fit}"
            );
        }
    }
    // Textbook value: water (n = 1.33) internal diffuse reflectance ≈ 0.44 … glass 1.5 ≈ 0.596.
    assert!(close(fresnel_diffuse_reflectance(1.0 / 1.5), 0.596, 0.002));
    // External: diffuse light from air onto glass reflects ≈ 9.2 %.
    assert!(close(fresnel_diffuse_reflectance(1.5), 0.092, 0.001));
}

#[test]
fn invalid_relative_index_gives_nan_not_a_panic() {
    assert!(fresnel_moment(1, 0.0).is_nan());
    assert!(fresnel_moment(1, -1.5).is_nan());
    assert!(fresnel_moment(2, f64::NAN).is_nan());
}
