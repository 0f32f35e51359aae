//! Fresnel reflectance and transmittance of a smooth interface, for dielectrics and for
//! complex refractive indices (conductors, absorbing media), and hemispherical moments
//! of the Fresnel reflectance.
//!
//! Conventions used throughout:
//! * `cos_theta_i` is the cosine of the angle between the incident direction and the
//!   surface normal on the incident side (dimensionless, in [0, 1]).
//! * `eta` is the *relative* index n_transmitted / n_incident (dimensionless). For a
//!   complex index, η = n' + i·n'' with n'' ≥ 0 meaning absorption in the transmitting
//!   medium (fields ∝ e^{i(kz − ωt)}).
//! * "s" is the polarisation perpendicular to the plane of incidence (TE), "p" parallel (TM).
//!   Unpolarised reflectance is (R_s + R_p)/2.
//!
//! The formulas are the Fresnel equations written with w = η·cos θ_t = √(η² − sin²θ_i):
//! r_s = (cos θ_i − w)/(cos θ_i + w),  r_p = (η² cos θ_i − w)/(η² cos θ_i + w),
//! which covers total internal reflection (w purely imaginary, |r| = 1) and absorbing media
//! (branch of the square root with Im w ≥ 0, the wave decaying into the medium).

use num_complex::Complex64;

/// Cosine of the refraction angle for a dielectric interface (Snell's law), or `None` under
/// total internal reflection. `cos_theta_i` in [0, 1], `eta` = n_t / n_i.
pub fn cos_theta_transmitted(cos_theta_i: f64, eta: f64) -> Option<f64> {
    let sin2_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        None
    } else {
        Some((1.0 - sin2_t).sqrt())
    }
}

/// Fresnel reflectances (R_s, R_p) of a dielectric interface, `eta` = n_t / n_i > 0.
/// A negative `cos_theta_i` means incidence from the other side (η is then inverted).
/// Total internal reflection gives (1, 1).
pub fn fresnel_dielectric_sp(cos_theta_i: f64, eta: f64) -> (f64, f64) {
    let (cos_i, eta) = if cos_theta_i < 0.0 {
        (-cos_theta_i, 1.0 / eta)
    } else {
        (cos_theta_i, eta)
    };
    let cos_i = cos_i.min(1.0);
    let Some(cos_t) = cos_theta_transmitted(cos_i, eta) else {
        return (1.0, 1.0);
    };
    // r_s = (n_i cos_i − n_t cos_t)/(n_i cos_i + n_t cos_t), r_p = (n_t cos_i − n_i cos_t)/(n_t cos_i + n_i cos_t)
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (r_s * r_s, r_p * r_p)
}

/// Unpolarised Fresnel reflectance of a dielectric interface; `eta` = n_t / n_i.
/// Total internal reflection gives 1. A negative `cos_theta_i` means incidence from the
/// other side of the interface (as in pbrt-v4): η is inverted and |cos θ_i| used.
pub fn fresnel_dielectric(cos_theta_i: f64, eta: f64) -> f64 {
    let (rs, rp) = fresnel_dielectric_sp(cos_theta_i, eta);
    0.5 * (rs + rp)
}

/// Unpolarised Fresnel transmittance of a dielectric interface, T = 1 − R (the fraction of
/// incident power crossing the interface); `eta` = n_t / n_i.
pub fn fresnel_dielectric_transmittance(cos_theta_i: f64, eta: f64) -> f64 {
    1.0 - fresnel_dielectric(cos_theta_i, eta)
}

/// Fresnel reflectances (R_s, R_p) for a complex relative index η = n' + i·n'' (n'' ≥ 0):
/// conductors and absorbing media. `cos_theta_i` is clamped to [0, 1].
pub fn fresnel_complex_sp(cos_theta_i: f64, eta: Complex64) -> (f64, f64) {
    let cos_i = cos_theta_i.clamp(0.0, 1.0);
    let sin2_i = 1.0 - cos_i * cos_i;
    let eta2 = eta * eta;
    // Principal square root: for Re η > 0, Im η ≥ 0 it has Im w ≥ 0 (decaying wave).
    let w = (eta2 - sin2_i).sqrt();
    let ci = Complex64::new(cos_i, 0.0);
    let r_s = (ci - w) / (ci + w);
    let r_p = (eta2 * cos_i - w) / (eta2 * cos_i + w);
    let rs = r_s.norm_sqr();
    let rp = r_p.norm_sqr();
    // At grazing incidence on an index-matched interface both numerator and denominator vanish.
    (if rs.is_finite() { rs } else { 1.0 }, if rp.is_finite() { rp } else { 1.0 })
}

/// Unpolarised Fresnel reflectance for a complex relative index η = n' + i·n''
/// (conductors: η = (eta + i k) / n_ambient from measured optical constants).
pub fn fresnel_complex(cos_theta_i: f64, eta: Complex64) -> f64 {
    let (rs, rp) = fresnel_complex_sp(cos_theta_i, eta);
    0.5 * (rs + rp)
}

/// Unpolarised transmittance 1 − R into an absorbing medium of complex relative index η
/// (the fraction of incident power that crosses the interface and is then absorbed there).
pub fn fresnel_complex_transmittance(cos_theta_i: f64, eta: Complex64) -> f64 {
    1.0 - fresnel_complex(cos_theta_i, eta)
}

/// Hemispherical moment of the dielectric Fresnel reflectance (dimensionless):
///
/// C_order(η) = ∫₀¹ R(μ; η) μ^order dμ,
///
/// with R the unpolarised [`fresnel_dielectric`] reflectance for light incident from the
/// medium of index n_i at cos θ_i = μ and η = n_t / n_i. Computed by numerical quadrature
/// (composite Gauss–Legendre, with the total-internal-reflection part integrated exactly
/// and the square-root kink at the critical angle removed by a change of variable),
/// accurate to about 1e-12.
///
/// Consequences: the diffuse (cosine-weighted hemispherical) Fresnel reflectance is
/// F_dr(η) = 2·C_1(η); the boundary terms of the dipole models are C_φ = (1 − 2C_1)/4 and
/// C_E = (1 − 3C_2)/2. For a medium of relative index n = n_medium/n_outside, light inside
/// hitting the boundary has η = 1/n (e.g. Jensen et al. 2001's F_dr(n) ≈ 2·C_1(1/n), the
/// Egan–Hilgeman fit), and light arriving from outside has η = n.
pub fn fresnel_moment(order: u32, eta: f64) -> f64 {
    assert!(eta > 0.0, "fresnel_moment: eta must be positive");
    let p = order as i32;
    let f = |mu: f64| fresnel_dielectric(mu, eta) * mu.powi(p);
    if eta < 1.0 {
        // TIR for μ < μ_c: R = 1 exactly.
        let mu_c = (1.0 - eta * eta).sqrt();
        let tir = mu_c.powi(p + 1) / (p as f64 + 1.0);
        // μ = μ_c + (1 − μ_c) s², dμ = 2 (1 − μ_c) s ds: smooth in s across the kink.
        let span = 1.0 - mu_c;
        tir + gauss_legendre(0.0, 1.0, 64, |s| f(mu_c + span * s * s) * 2.0 * span * s)
    } else {
        gauss_legendre(0.0, 1.0, 64, f)
    }
}

/// Diffuse Fresnel reflectance F_dr(η) = 2·C_1(η) = ∫ R cos θ dω / π (dimensionless),
/// η = n_t / n_i as in [`fresnel_moment`].
pub fn fresnel_diffuse_reflectance(eta: f64) -> f64 {
    2.0 * fresnel_moment(1, eta)
}

/// Composite 8-point Gauss–Legendre quadrature of `f` over [a, b] with `panels` panels.
fn gauss_legendre(a: f64, b: f64, panels: usize, f: impl Fn(f64) -> f64) -> f64 {
    // Nodes and weights of the 8-point rule on [−1, 1] (Abramowitz & Stegun 25.4.30).
    const X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329_0,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const W: [f64; 4] = [
        0.362_683_783_378_362_0,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];
    let h = (b - a) / panels as f64;
    let mut sum = 0.0;
    for k in 0..panels {
        let mid = a + (k as f64 + 0.5) * h;
        let half = 0.5 * h;
        for j in 0..4 {
            sum += W[j] * (f(mid - half * X[j]) + f(mid + half * X[j])) * half;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadrature_integrates_polynomials_exactly() {
        // ∫0^1 x^7 dx = 1/8; an 8-point rule is exact to degree 15.
        let v = gauss_legendre(0.0, 1.0, 1, |x| x.powi(15));
        assert!((v - 1.0 / 16.0).abs() < 1e-14, "{v}");
    }
}
