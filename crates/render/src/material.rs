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

use crate::bxdf::{CoatedDiffuse, CoatingTable, RoughConductor, RoughDielectric, SmoothConductor, SmoothDielectric};
use crate::microfacet::TrowbridgeReitz;
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
    /// Dielectric interface (glass, water), smooth when α < `microfacet::SMOOTH_ALPHA`, else GGX-rough.
    Dielectric {
        /// Index of the inside relative to the outside, per wavelength (nm).
        ior: DenseSpectrum,
        /// Whether `ior` varies with wavelength (then the secondary wavelengths are terminated).
        dispersive: bool,
        /// Microfacet roughness (α = 0: smooth).
        distrib: TrowbridgeReitz,
    },
    /// Conductor with complex index η + i k per wavelength; smooth or GGX-rough.
    Conductor {
        /// Real part of the index relative to the outside.
        eta: DenseSpectrum,
        /// Extinction coefficient.
        k: DenseSpectrum,
        /// Microfacet roughness (α = 0: smooth).
        distrib: TrowbridgeReitz,
    },
    /// Dielectric coating (index `ior`, roughness α) over a Lambertian base ("plastic").
    Plastic {
        /// Base albedo.
        albedo: DenseSpectrum,
        /// Coating index relative to the outside (non-dispersive).
        ior: f32,
        /// Coating roughness α (isotropic; 0 = smooth).
        alpha: f32,
        /// Albedo table of the coating (computed once per (α, ior)).
        table: &'static CoatingTable,
    },
    /// Translucent object (closed mesh) rendered with a dipole BSSRDF (`crate::subsurface`); as a
    /// BSDF it is its smooth or rough dielectric boundary (what volumetric path tracing sees).
    Translucent(std::sync::Arc<crate::subsurface::Translucent>),
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
    /// Smooth dielectric (delta reflection + refraction).
    SmoothDielectric {
        /// The lobe (η = n_other side / n_side of z).
        lobe: SmoothDielectric,
        /// η was taken at the hero wavelength: the integrator must terminate the secondary ones.
        dispersive: bool,
    },
    /// Rough dielectric (GGX).
    RoughDielectric {
        /// The lobe.
        lobe: RoughDielectric,
        /// η was taken at the hero wavelength: the integrator must terminate the secondary ones.
        dispersive: bool,
    },
    /// Smooth conductor (delta mirror).
    SmoothConductor(SmoothConductor),
    /// Rough conductor (GGX).
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

impl Material {
    /// Lambertian material with albedo given as a function of wavelength in nm.
    pub fn lambertian(albedo: DenseSpectrum) -> Material {
        Material::Lambertian { albedo }
    }

    /// Dielectric with relative index `ior(λ)` (dispersive when it varies over 360–830 nm) and
    /// microfacet distribution `distrib` (α below `microfacet::SMOOTH_ALPHA`: smooth).
    pub fn dielectric(ior: DenseSpectrum, distrib: TrowbridgeReitz) -> Material {
        let s = ior.samples();
        let dispersive = s.iter().any(|&x| (x - s[0]).abs() > 1e-6 * s[0].abs());
        Material::Dielectric { ior, dispersive, distrib }
    }

    /// Conductor with complex index η + i k (relative to the outside) and roughness `distrib`.
    pub fn conductor(eta: DenseSpectrum, k: DenseSpectrum, distrib: TrowbridgeReitz) -> Material {
        Material::Conductor { eta, k, distrib }
    }

    /// Plastic: a coating of index `ior` and roughness `alpha` over a Lambertian base `albedo`.
    pub fn plastic(albedo: DenseSpectrum, ior: f32, alpha: f32) -> Material {
        Material::Plastic { albedo, ior, alpha, table: CoatingTable::get(alpha, ior) }
    }

    /// The BSDF for a hit on the front (`front_face`, the side the geometric normal points to) or
    /// back face, with the wavelength bookkeeping the integrators need: a dispersive dielectric
    /// terminates the secondary wavelengths of `wl` (their pdf becomes 0, the hero's is divided by
    /// 4) before its η is taken at the hero wavelength. Equivalent to [`Material::bsdf`] followed
    /// by [`Bsdf::from_inside`] for back faces and `wl.terminate_secondary()` when
    /// [`Bsdf::terminates_secondary`].
    #[inline]
    pub fn bsdf_at(&self, wl: &mut SampledWavelengths, front_face: bool) -> Bsdf {
        let b = self.bsdf(wl);
        if b.terminates_secondary() {
            wl.terminate_secondary();
        }
        if front_face {
            b
        } else {
            b.from_inside()
        }
    }

    /// The BSDF of this material at the wavelengths `wl`, for a hit on the FRONT (outside) face;
    /// for a hit from inside use [`Bsdf::from_inside`] on the result.
    #[inline]
    pub fn bsdf(&self, wl: &SampledWavelengths) -> Bsdf {
        match self {
            Material::Lambertian { albedo } => Bsdf::Diffuse { r: wl.eval(albedo) },
            Material::Black => Bsdf::Black,
            Material::Dielectric { ior, dispersive, distrib } => {
                // One real η per lobe: the hero wavelength's (pbrt-v4's convention for dispersion).
                let eta = ior.eval(wl.lambda_nm[0]);
                let dispersive = *dispersive && !wl.secondary_terminated();
                // An index-matched rough interface does not bend light: it is the smooth pass-through.
                if distrib.effectively_smooth() || eta == 1.0 {
                    Bsdf::SmoothDielectric { lobe: SmoothDielectric { eta }, dispersive }
                } else {
                    Bsdf::RoughDielectric { lobe: RoughDielectric { distrib: *distrib, eta }, dispersive }
                }
            }
            Material::Conductor { eta, k, distrib } => {
                let (eta, k) = (wl.eval(eta), wl.eval(k));
                if distrib.effectively_smooth() {
                    Bsdf::SmoothConductor(SmoothConductor { eta, k })
                } else {
                    Bsdf::RoughConductor(RoughConductor { distrib: *distrib, eta, k })
                }
            }
            Material::Plastic { albedo, ior, alpha, table } => Bsdf::Coated(CoatedDiffuse {
                albedo: wl.eval(albedo),
                eta: *ior,
                distrib: TrowbridgeReitz::isotropic(*alpha),
                table,
            }),
            Material::Translucent(t) => t.boundary_dielectric(),
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
            Bsdf::SmoothDielectric { .. } | Bsdf::SmoothConductor(_) => true,
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
            other => other,
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
            _ => false,
        }
    }

    /// True when the BSDF scatters no light at all.
    #[inline]
    pub fn is_black(&self) -> bool {
        match self {
            Bsdf::Diffuse { r } => *r == Vec4::ZERO,
            Bsdf::Black => true,
            _ => false,
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
            Bsdf::SmoothDielectric { lobe, .. } => lobe.eval(wo, wi),
            Bsdf::RoughDielectric { lobe, .. } => lobe.eval(wo, wi),
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
            Bsdf::Black => 0.0,
            Bsdf::SmoothDielectric { lobe, .. } => lobe.pdf(wo, wi),
            Bsdf::RoughDielectric { lobe, .. } => lobe.pdf(wo, wi),
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
            Bsdf::SmoothConductor(lobe) => lobe.sample(wo, uc, u),
            Bsdf::RoughConductor(lobe) => lobe.sample(wo, uc, u),
            Bsdf::Coated(lobe) => lobe.sample(wo, uc, u),
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
