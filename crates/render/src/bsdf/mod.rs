//! Scattering functions at fixed wavelengths (BSDFs): the [`Bsdf`] dispatch and its lobes — smooth and rough dielectrics, thin dielectric sheets, smooth and rough
//! conductors, and a dielectric coating over a diffuse base (plastic).
//!
//! Frame convention (as in pbrt-v4): every lobe works in a local frame whose +z is the surface
//! normal pointing to the *outside* (the side whose index is 1 for dielectrics); `wo` and `wi`
//! may lie on either side. The renderer's shading frame has z on the side of `wo`, so for a
//! dielectric hit from the inside the material flips the lobe (η → 1/η, see
//! [`Bsdf::from_inside`]); the reflection-only lobes (conductors, plastic) are
//! two-sided and mirror both directions when `wo.z < 0`.
//!
//! Conventions:
//! * `eta` of a dielectric is the relative index n_inside/n_outside at the wavelength(s) carried.
//!   A lobe has ONE real η: for a dispersive glass the material evaluates η at the hero
//!   wavelength and the secondary wavelengths must be terminated (pbrt-v4's
//!   `TerminateSecondary`): [`crate::material::Material::bsdf_at`] does it when the BSDF is made,
//!   and every sample of such a lobe has `terminate_secondary` set.
//! * Transmission values are for *radiance* transport (camera paths): f_t carries the factor
//!   1/η'² with η' = n_(wi side)/n_(wo side) (Veach 1997 §5.2; pbrt-v4 `TransportMode::Radiance`).
//!   The generalised reciprocity (Veach 1997 eq. 5.14) is then
//!   f(wo, wi)/n_(wo side)² = f(wi, wo)/n_(wi side)².
//! * Rough transmission is Walter et al. 2007 ("Microfacet models for refraction through rough
//!   surfaces") with the generalised half vector m ∝ η_i wi + η_o wo, height-correlated Smith G2.
//! * Conductors use the complex index η + i k per wavelength (relative to the outside medium)
//!   and the exact unpolarised Fresnel reflectance (`optics::fresnel::fresnel_complex`).
//!
//! Coated diffuse ("plastic"): a dielectric coating of index η (smooth or GGX-rough) over a
//! Lambertian base of albedo ρ, in the classic Fresnel-weighted layering: specular reflection of
//! the coating plus a diffuse term
//!   f_d(wo, wi) = ρ_eff · (1 − E(μo)) (1 − E(μi)) / (π (1 − E_avg)),
//!   ρ_eff = ρ (1 − F_dr,in)/(1 − ρ F_dr,in),
//! where E(μ) is the directional albedo of the coating's specular lobe (the Fresnel reflectance
//! for a smooth coating, tabulated by quadrature for a rough one), E_avg = 2∫E(μ)μ dμ and F_dr,in
//! the diffuse Fresnel reflectance seen from inside the coating (internal reflections between base
//! and coating summed as a geometric series). For a smooth coating this is exactly the physical
//! two-interface result T(μo) T(μi) ρ / (π η² (1 − ρ F_dr,in)); for any roughness it is
//! reciprocal and energy conserving: ∫(f_s + f_d) cos θi dωi = E(μo) + (1 − E(μo)) ρ_eff ≤ 1, with
//! equality for a white base (ρ = 1). (Kelemen & Szirmay-Kalos 2001's albedo coupling.)

//!
//! A new lobe family is a file here and a variant of [`Bsdf`]; every `match` on it must then
//! handle it (none has a catch-all arm).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod coated;
pub mod conductor;
pub mod dielectric;
pub mod fresnel;
pub mod microfacet;

pub use coated::{CoatedDiffuse, CoatingTable, MitsubaCoupling};
pub use conductor::{RoughConductor, SmoothConductor};
pub use dielectric::{RoughDielectric, SmoothDielectric, ThinDielectric};

use crate::math::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::math::spectral::SampledSpectrum;
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::FRAC_1_PI;

/// A scattering function at fixed wavelengths, in the local shading frame.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    /// f = r/π for wi, wo in the same hemisphere.
    Diffuse {
        /// Albedo at the carried wavelengths.
        r: SampledSpectrum,
    },
    /// Diffuse reflection and transmission (pbrt-v4's `DiffuseTransmissionBxDF`): f = r/π for wi
    /// on the side of wo, t/π on the other; a thin sheet that scatters what meets it (paper, a
    /// leaf, a lamp shade). Sampled on either side with probability ∝ max r, max t.
    DiffuseTransmission {
        /// Diffuse reflectance at the carried wavelengths.
        r: SampledSpectrum,
        /// Diffuse transmittance at the carried wavelengths.
        t: SampledSpectrum,
    },
    /// No scattering.
    Black,
    /// Smooth dielectric (delta reflection + refraction).
    SmoothDielectric {
        /// The lobe (η = n_other side / n_side of z).
        lobe: SmoothDielectric,
        /// η was taken at the hero wavelength: the integrator must terminate the secondary ones.
        dispersive: bool,
    },
    /// Rough dielectric (microfacet).
    RoughDielectric {
        /// The lobe.
        lobe: RoughDielectric,
        /// η was taken at the hero wavelength: the integrator must terminate the secondary ones.
        dispersive: bool,
    },
    /// Thin dielectric sheet (delta reflection + unbent transmission).
    ThinDielectric(ThinDielectric),
    /// Smooth conductor (delta mirror).
    SmoothConductor(SmoothConductor),
    /// Rough conductor (microfacet).
    RoughConductor(RoughConductor),
    /// Dielectric coating over a diffuse base.
    Coated(CoatedDiffuse),
}

/// A direction sampled from a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Incident direction (local frame, unit).
    pub wi: Vec3,
    /// BSDF value f(wo, wi) (for delta lobes, the weight times the delta's pdf).
    pub f: SampledSpectrum,
    /// Density per steradian (for delta lobes, the discrete probability of the lobe).
    pub pdf: f32,
    /// Whether the lobe is a Dirac delta (no light sampling, MIS weight 1).
    pub delta: bool,
    /// Whether wi is on the other side of the surface than wo.
    pub transmission: bool,
    /// Relative index of refraction η_t/η_i crossed by a transmission (1 for reflection).
    pub eta: f32,
    /// The lobe depends on wavelength in direction (dispersion): the path keeps only its hero
    /// wavelength from here on ([`SampledWavelengths::terminate_secondary`]).
    pub terminate_secondary: bool,
}

impl Bsdf {
    /// True when every lobe is a Dirac delta (light sampling is useless).
    #[inline]
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Diffuse { .. } | Bsdf::DiffuseTransmission { .. } => false,
            Bsdf::Black => true,
            Bsdf::SmoothDielectric { .. } | Bsdf::ThinDielectric(_) | Bsdf::SmoothConductor(_) => true,
            Bsdf::RoughDielectric { .. } | Bsdf::RoughConductor(_) | Bsdf::Coated(_) => false,
        }
    }

    /// The same interface seen from its inside: dielectrics get η → 1/η (call this when the ray
    /// hits the back of the geometric surface, since the shading frame's z is on the side of wo);
    /// reflection-only BSDFs are unchanged.
    #[inline]
    pub fn from_inside(self) -> Bsdf {
        match self {
            Bsdf::SmoothDielectric { lobe, dispersive } => {
                Bsdf::SmoothDielectric { lobe: SmoothDielectric { eta: 1.0 / lobe.eta }, dispersive }
            }
            Bsdf::RoughDielectric { lobe, dispersive } => {
                Bsdf::RoughDielectric { lobe: RoughDielectric { distrib: lobe.distrib, eta: 1.0 / lobe.eta }, dispersive }
            }
            Bsdf::Diffuse { .. } | Bsdf::DiffuseTransmission { .. } | Bsdf::Black | Bsdf::ThinDielectric(_) | Bsdf::SmoothConductor(_) | Bsdf::RoughConductor(_) | Bsdf::Coated(_) => self,
        }
    }

    /// This BSDF for a hit on the front face (`front_face`: the side the geometric normal points
    /// to), else [`Bsdf::from_inside`].
    #[inline]
    pub fn facing(self, front_face: bool) -> Bsdf {
        if front_face {
            self
        } else {
            self.from_inside()
        }
    }

    /// True when the BSDF was evaluated at the hero wavelength only (dispersive dielectric): the
    /// secondary wavelengths must be terminated before it is used for light sampling (see
    /// [`Material::bsdf_at`]); its samples also carry `terminate_secondary`.
    #[inline]
    pub fn terminates_secondary(&self) -> bool {
        match self {
            Bsdf::SmoothDielectric { dispersive, .. } | Bsdf::RoughDielectric { dispersive, .. } => *dispersive,
            Bsdf::Diffuse { .. } | Bsdf::DiffuseTransmission { .. } | Bsdf::Black | Bsdf::ThinDielectric(_) | Bsdf::SmoothConductor(_) | Bsdf::RoughConductor(_) | Bsdf::Coated(_) => false,
        }
    }

    /// True when the BSDF scatters no light at all.
    #[inline]
    pub fn is_black(&self) -> bool {
        match self {
            Bsdf::Diffuse { r } => *r == Vec4::ZERO,
            Bsdf::DiffuseTransmission { r, t } => *r == Vec4::ZERO && *t == Vec4::ZERO,
            Bsdf::Black => true,
            Bsdf::SmoothDielectric { .. } | Bsdf::RoughDielectric { .. } | Bsdf::ThinDielectric(_) | Bsdf::SmoothConductor(_) | Bsdf::RoughConductor(_) | Bsdf::Coated(_) => false,
        }
    }

    /// f(wo, wi) per steradian (local frame, z = shading normal on the side of `wo`).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        match self {
            Bsdf::Diffuse { r } => {
                if wo.z * wi.z > 0.0 {
                    *r * FRAC_1_PI
                } else {
                    Vec4::ZERO
                }
            }
            Bsdf::DiffuseTransmission { r, t } => {
                if wo.z * wi.z > 0.0 {
                    *r * FRAC_1_PI
                } else if wo.z * wi.z < 0.0 {
                    *t * FRAC_1_PI
                } else {
                    Vec4::ZERO
                }
            }
            Bsdf::Black => Vec4::ZERO,
            Bsdf::SmoothDielectric { lobe, .. } => lobe.eval(wo, wi),
            Bsdf::RoughDielectric { lobe, .. } => lobe.eval(wo, wi),
            Bsdf::ThinDielectric(lobe) => lobe.eval(wo, wi),
            Bsdf::SmoothConductor(lobe) => lobe.eval(wo, wi),
            Bsdf::RoughConductor(lobe) => lobe.eval(wo, wi),
            Bsdf::Coated(lobe) => lobe.eval(wo, wi),
        }
    }

    /// Density per steradian with which [`Bsdf::sample`] picks `wi` given `wo`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse { .. } => {
                if wo.z * wi.z > 0.0 {
                    cosine_hemisphere_pdf(wi.z.abs())
                } else {
                    0.0
                }
            }
            Bsdf::DiffuseTransmission { r, t } => {
                let pr = reflection_probability(r, t);
                if wo.z * wi.z > 0.0 {
                    pr * cosine_hemisphere_pdf(wi.z.abs())
                } else if wo.z * wi.z < 0.0 {
                    (1.0 - pr) * cosine_hemisphere_pdf(wi.z.abs())
                } else {
                    0.0
                }
            }
            Bsdf::Black => 0.0,
            Bsdf::SmoothDielectric { lobe, .. } => lobe.pdf(wo, wi),
            Bsdf::RoughDielectric { lobe, .. } => lobe.pdf(wo, wi),
            Bsdf::ThinDielectric(lobe) => lobe.pdf(wo, wi),
            Bsdf::SmoothConductor(lobe) => lobe.pdf(wo, wi),
            Bsdf::RoughConductor(lobe) => lobe.pdf(wo, wi),
            Bsdf::Coated(lobe) => lobe.pdf(wo, wi),
        }
    }

    /// Sample an incident direction given `wo`, a uniform `uc` (lobe choice) and `u` ∈ [0,1)².
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse { r } => {
                let mut wi = cosine_hemisphere(u);
                if wo.z < 0.0 {
                    wi.z = -wi.z;
                }
                let pdf = cosine_hemisphere_pdf(wi.z.abs());
                if pdf <= 0.0 {
                    return None;
                }
                Some(BsdfSample { wi, f: *r * FRAC_1_PI, pdf, delta: false, transmission: false, eta: 1.0, terminate_secondary: false })
            }
            Bsdf::DiffuseTransmission { r, t } => {
                // The cosine lobe on wo's side (reflection) or on the other (transmission).
                let pr = reflection_probability(r, t);
                let reflect = uc < pr;
                let mut wi = cosine_hemisphere(u);
                if (wo.z < 0.0) == reflect {
                    wi.z = -wi.z;
                }
                let pdf = if reflect { pr } else { 1.0 - pr } * cosine_hemisphere_pdf(wi.z.abs());
                if !(pdf > 0.0) || wo.z == 0.0 {
                    return None;
                }
                let f = if reflect { *r } else { *t } * FRAC_1_PI;
                Some(BsdfSample { wi, f, pdf, delta: false, transmission: !reflect, eta: 1.0, terminate_secondary: false })
            }
            Bsdf::Black => None,
            // A dispersive dielectric was evaluated at the hero wavelength only.
            Bsdf::SmoothDielectric { lobe, dispersive } => lobe.sample(wo, uc, u).map(|mut s| {
                s.terminate_secondary = *dispersive;
                s
            }),
            Bsdf::RoughDielectric { lobe, dispersive } => lobe.sample(wo, uc, u).map(|mut s| {
                s.terminate_secondary = *dispersive;
                s
            }),
            Bsdf::ThinDielectric(lobe) => lobe.sample(wo, uc, u),
            Bsdf::SmoothConductor(lobe) => lobe.sample(wo, uc, u),
            Bsdf::RoughConductor(lobe) => lobe.sample(wo, uc, u),
            Bsdf::Coated(lobe) => lobe.sample(wo, uc, u),
        }
    }
}

/// The probability with which [`Bsdf::DiffuseTransmission`] samples its reflection lobe: max r
/// over max r + max t (pbrt-v4's choice); ½ when both are 0.
#[inline]
fn reflection_probability(r: &SampledSpectrum, t: &SampledSpectrum) -> f32 {
    let (pr, pt) = (r.max_element().max(0.0), t.max_element().max(0.0));
    if pr + pt > 0.0 {
        pr / (pr + pt)
    } else {
        0.5
    }
}

#[inline]
pub(crate) fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

/// Mirror both directions to the upper side when `wo` is below (two-sided reflection lobes).
#[inline]
pub(crate) fn to_upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3, bool) {
    if wo.z < 0.0 {
        (-wo, -wi, true)
    } else {
        (wo, wi, false)
    }
}

#[inline]
pub(crate) fn flip_z(v: Vec3, flip: bool) -> Vec3 {
    if flip {
        -v
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Pcg32;

    #[test]
    fn lambertian_sampling_matches_eval() {
        // Estimate of the albedo ∫ f cos dω by sampling equals r, with zero variance for a Lambertian.
        let b = Bsdf::Diffuse { r: Vec4::new(0.2, 0.5, 0.8, 1.0) };
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let mut rng = Pcg32::new(1, 1);
        for _ in 0..1000 {
            let s = b.sample(wo, rng.next_f32(), rng.next_2d()).unwrap();
            let w = s.f * s.wi.z.abs() / s.pdf;
            assert!((w - Vec4::new(0.2, 0.5, 0.8, 1.0)).abs().max_element() < 1e-4);
            assert!((b.pdf(wo, s.wi) - s.pdf).abs() < 1e-5 * s.pdf.max(1.0));
            assert_eq!(b.eval(wo, s.wi), s.f);
            // Reciprocity f(wo, wi) = f(wi, wo).
            assert_eq!(b.eval(s.wi, wo), b.eval(wo, s.wi));
        }
        // Two-sided: from below it reflects below.
        let s = b.sample(-wo, 0.5, Vec2::new(0.3, 0.7)).unwrap();
        assert!(s.wi.z < 0.0);
    }

    #[test]
    fn diffuse_transmission_sampling_matches_eval() {
        // ∫ f |cos| dω is r on wo's side and t on the other, estimated by sampling; the density
        // integrates to 1 over both sides (a midpoint sum over a 256 × 256 grid in (cos θ, φ)
        // per side) and is what `sample` returns; f is reciprocal; reflection and transmission
        // alone work too.
        let mut rng = Pcg32::new(2, 1);
        for (r, t) in [(Vec4::new(0.3, 0.1, 0.6, 0.2), Vec4::new(0.2, 0.5, 0.3, 0.7)), (Vec4::ZERO, Vec4::splat(0.6)), (Vec4::splat(0.4), Vec4::ZERO)] {
            let b = Bsdf::DiffuseTransmission { r, t };
            for wo in [Vec3::new(0.3, 0.1, 0.9).normalize(), Vec3::new(-0.5, 0.2, -0.4).normalize()] {
                let n = 40_000;
                let (mut refl, mut tran) = (Vec4::ZERO, Vec4::ZERO);
                for _ in 0..n {
                    let s = b.sample(wo, rng.next_f32(), rng.next_2d()).unwrap();
                    assert_eq!(s.transmission, s.wi.z * wo.z < 0.0);
                    assert!((b.pdf(wo, s.wi) - s.pdf).abs() < 1e-5 * s.pdf.max(1.0));
                    assert_eq!(b.eval(wo, s.wi), s.f);
                    assert_eq!(b.eval(s.wi, wo), b.eval(wo, s.wi));
                    let w = s.f * s.wi.z.abs() / s.pdf;
                    if s.transmission {
                        tran += w;
                    } else {
                        refl += w;
                    }
                }
                // Each lobe's estimate is a binomial share of exact weights: 4 standard errors, and
                // 2e-3 for the rounding of 40 000 f32 additions.
                for (est, want) in [(refl / n as f32, r), (tran / n as f32, t)] {
                    let p = reflection_probability(&r, &t);
                    let tol = (4.0 * (p * (1.0 - p) / n as f32).sqrt() / p.min(1.0 - p).max(1e-3) + 2e-3) * want.max_element() + 1e-6;
                    assert!((est - want).abs().max_element() <= tol, "{est} vs {want}");
                }
                let m = 256;
                let mut sum = 0.0f64;
                for side in [1.0f32, -1.0] {
                    for i in 0..m {
                        for j in 0..m {
                            let mu = (i as f32 + 0.5) / m as f32;
                            let phi = (j as f32 + 0.5) / m as f32 * std::f32::consts::TAU;
                            let st = (1.0 - mu * mu).sqrt();
                            let wi = Vec3::new(st * phi.cos(), st * phi.sin(), side * mu);
                            sum += b.pdf(wo, wi) as f64 * std::f64::consts::TAU / (m * m) as f64;
                        }
                    }
                }
                assert!((sum - 1.0).abs() < 1e-4, "∫pdf = {sum}");
            }
        }
    }
}
