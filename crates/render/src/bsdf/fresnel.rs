//! Fresnel reflectance of dielectric and conductor interfaces on the four carried wavelengths.

use crate::math::spectral::SampledSpectrum;
use glam::Vec4;

/// Unpolarised dielectric Fresnel reflectance (f32 wrapper of `optics::fresnel::fresnel_dielectric`);
/// `cos_theta_i` < 0 means incidence from inside (η inverted).
#[inline]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    optics::fresnel::fresnel_dielectric(cos_theta_i as f64, eta as f64) as f32
}

/// Conductor Fresnel reflectance per wavelength for complex relative indices η + i k, unpolarised,
/// in real arithmetic on four lanes at once. With a² + b² = |(η + ik)² − sin²θ| and
/// a = √((a² + b² + η² − k² − sin²θ)/2) (a + ib = √((η + ik)² − sin²θ)):
/// R_s = (a² + b² − 2a cos θ + cos²θ)/(a² + b² + 2a cos θ + cos²θ),
/// R_p = R_s (cos²θ (a² + b²) − 2a cos θ sin²θ + sin⁴θ)/(cos²θ (a² + b²) + 2a cos θ sin²θ + sin⁴θ).
/// Agrees with the complex-arithmetic `optics::fresnel::fresnel_complex` (tested).
#[inline]
pub fn fresnel_conductor(cos_theta_i: f32, eta: Vec4, k: Vec4) -> SampledSpectrum {
    let c = cos_theta_i.abs().min(1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - Vec4::splat(s2);
    let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).powf(0.5);
    let a = (0.5 * (a2b2 + t0)).max(Vec4::ZERO).powf(0.5);
    let t1 = a2b2 + Vec4::splat(c2);
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2).max(Vec4::splat(1e-30));
    let t3 = c2 * a2b2 + Vec4::splat(s2 * s2);
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4).max(Vec4::splat(1e-30));
    (0.5 * (rs + rp)).clamp(Vec4::ZERO, Vec4::ONE)
}
