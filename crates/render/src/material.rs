//! Materials (what a surface is made of) and the BSDFs they yield at the wavelengths of a path.
//!
//! A [`Material`] holds spectra; [`Material::bsdf`] evaluates them at the carried wavelengths and
//! returns a [`Bsdf`], a small value with `eval`/`pdf`/`sample` in the local shading frame (z = the
//! shading normal turned towards the outgoing direction). The integrators only talk to `Bsdf`, so
//! adding a variant (smooth or rough dielectric and conductor, coated diffuse, index-matched medium
//! boundary, BSSRDF boundary) means adding match arms here, not changing the integrators: a sample
//! reports whether it is a delta lobe (no light sampling, no MIS), whether it transmits (the path
//! changes side and medium) and the relative index of refraction it crossed.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::spectral::{SampledSpectrum, SampledWavelengths};
use glam::{Vec2, Vec3, Vec4};
use optics::spectrum::DenseSpectrum;
use std::f32::consts::FRAC_1_PI;

/// A surface material.
#[derive(Clone, Debug)]
pub enum Material {
    /// Ideal diffuse reflector with spectral albedo ρ(λ) ∈ [0, 1]: f = ρ/π on the side of the
    /// outgoing direction (two-sided).
    Lambertian {
        /// Albedo (directional-hemispherical reflectance), dimensionless.
        albedo: DenseSpectrum,
    },
    /// Absorbs everything (an emitter with no reflectance, or a light trap).
    Black,
}

/// A scattering function at fixed wavelengths, in the local shading frame.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    /// f = r/π for wi, wo in the same hemisphere.
    Diffuse {
        /// Albedo at the carried wavelengths.
        r: SampledSpectrum,
    },
    /// No scattering.
    Black,
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

impl Material {
    /// Lambertian material with albedo given as a function of wavelength in nm.
    pub fn lambertian(albedo: DenseSpectrum) -> Material {
        Material::Lambertian { albedo }
    }

    /// The BSDF of this material at the wavelengths `wl`.
    #[inline]
    pub fn bsdf(&self, wl: &SampledWavelengths) -> Bsdf {
        match self {
            Material::Lambertian { albedo } => Bsdf::Diffuse { r: wl.eval(albedo) },
            Material::Black => Bsdf::Black,
        }
    }
}

impl Bsdf {
    /// True when every lobe is a Dirac delta (light sampling is useless).
    #[inline]
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Diffuse { .. } => false,
            Bsdf::Black => true,
        }
    }

    /// True when the BSDF scatters no light at all.
    #[inline]
    pub fn is_black(&self) -> bool {
        match self {
            Bsdf::Diffuse { r } => *r == Vec4::ZERO,
            Bsdf::Black => true,
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
            Bsdf::Black => Vec4::ZERO,
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
            Bsdf::Black => 0.0,
        }
    }

    /// Sample an incident direction given `wo`, a uniform `uc` (lobe choice) and `u` ∈ [0,1)².
    #[inline]
    pub fn sample(&self, wo: Vec3, _uc: f32, u: Vec2) -> Option<BsdfSample> {
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
            Bsdf::Black => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

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
}
