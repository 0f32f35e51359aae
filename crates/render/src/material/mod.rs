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

pub mod translucent;

use crate::bsdf::coated::{CoatedDiffuse, CoatingTable};
use crate::bsdf::conductor::{RoughConductor, SmoothConductor};
use crate::bsdf::dielectric::{RoughDielectric, SmoothDielectric, ThinDielectric};
use crate::bsdf::Bsdf;
use crate::bsdf::microfacet::{Distribution, Masking, Microfacet};
use crate::math::spectral::SampledWavelengths;
use crate::texture::{FloatTexture, SpectrumTexture};
use glam::Vec2;
use optics::spectrum::DenseSpectrum;

/// A surface material.
#[derive(Clone, Debug)]
pub enum Material {
    /// Ideal diffuse reflector with spectral albedo ρ(λ) ∈ [0, 1]: f = ρ/π on the side of the
    /// outgoing direction (two-sided).
    Lambertian {
        /// Albedo (directional-hemispherical reflectance), dimensionless; constant or textured.
        albedo: SpectrumTexture,
    },
    /// Diffuse reflector and transmitter (pbrt-v4's `diffusetransmission`): f = ρ/π on the side
    /// light comes from, τ/π through to the other (ρ + τ ≤ 1); two-sided.
    DiffuseTransmitter {
        /// Diffuse reflectance ρ(λ) ∈ [0, 1] (directional-hemispherical), dimensionless; constant
        /// or textured.
        albedo: SpectrumTexture,
        /// Diffuse transmittance τ(λ) ∈ [0, 1], dimensionless; constant or textured.
        transmittance: SpectrumTexture,
    },
    /// Absorbs everything (an emitter with no reflectance, or a light trap).
    Black,
    /// Dielectric interface (glass, water), smooth when α < `microfacet::SMOOTH_ALPHA`, else rough.
    Dielectric {
        /// Index of the inside relative to the outside, per wavelength (nm).
        ior: DenseSpectrum,
        /// Whether `ior` varies with wavelength (then the secondary wavelengths are terminated).
        dispersive: bool,
        /// Microfacet roughness (α = 0: smooth).
        distrib: Microfacet,
        /// Roughness r ∈ [0, 1] over the surface (α = r², isotropic), replacing `distrib` where given.
        roughness: Option<FloatTexture>,
    },
    /// Thin dielectric sheet (a window pane): Fresnel reflection summed over the light bouncing
    /// between its two faces, unbent transmission ([`ThinDielectric`]).
    ThinDielectric {
        /// Index of the sheet relative to its surroundings, per wavelength (nm).
        ior: DenseSpectrum,
    },
    /// Conductor with complex index η + i k per wavelength; smooth or rough.
    Conductor {
        /// Real part of the index relative to the outside.
        eta: DenseSpectrum,
        /// Extinction coefficient.
        k: DenseSpectrum,
        /// Microfacet roughness (α = 0: smooth).
        distrib: Microfacet,
        /// Roughness r ∈ [0, 1] over the surface (α = r², isotropic), replacing `distrib` where given.
        roughness: Option<FloatTexture>,
    },
    /// Dielectric coating (index `ior`, roughness α) over a Lambertian base ("plastic").
    Plastic {
        /// Base albedo; constant or textured.
        albedo: SpectrumTexture,
        /// Coating index relative to the outside (non-dispersive).
        ior: f32,
        /// Coating roughness α (isotropic; 0 = smooth).
        alpha: f32,
        /// Shape of the coating's microfacet distribution.
        distribution: Distribution,
        /// Mitsuba 3's diffuse term instead of lucent's ([`crate::bsdf::MitsubaCoupling`]).
        mitsuba: Option<&'static crate::bsdf::MitsubaCoupling>,
        /// Albedo table of the coating (computed once per (α, ior)).
        table: &'static CoatingTable,
        /// Whether `albedo` is the base's (true) or the effective albedo under the coating
        /// ([`CoatedDiffuse::nonlinear`]).
        nonlinear: bool,
    },
    /// A blend of two materials (Mitsuba 3's `blendbsdf`): f = (1 − w) f_a + w f_b. The
    /// integrators take one of the two at each shading point, `b` with probability w
    /// ([`Material::select`], pbrt-v4's `MixMaterial`), which has the blend as its expectation.
    Blend {
        /// The material at weight 0.
        a: Box<Material>,
        /// The material at weight 1.
        b: Box<Material>,
        /// The weight w ∈ [0, 1] of `b`; constant or textured.
        weight: FloatTexture,
    },
    /// Translucent object (closed mesh) rendered with a dipole BSSRDF ([`crate::integrator::subsurface`]); as a
    /// BSDF it is its smooth or rough dielectric boundary (what volumetric path tracing sees).
    Translucent(std::sync::Arc<translucent::Translucent>),
}

impl Material {
    /// The translucent material's data, if this is one.
    #[inline]
    pub fn as_translucent(&self) -> Option<&std::sync::Arc<translucent::Translucent>> {
        match self {
            Material::Translucent(t) => Some(t),
            Material::Lambertian { .. } | Material::DiffuseTransmitter { .. } | Material::Black | Material::Dielectric { .. } | Material::ThinDielectric { .. } | Material::Conductor { .. } | Material::Plastic { .. } | Material::Blend { .. } => None,
        }
    }

    /// The material a shading point uses: a blend's `b` when `u()` (uniform in [0, 1), drawn
    /// once per shading point) is below its weight at `uv()`, else its `a`; any other material
    /// is itself. Neither closure is called for a material that is not a blend.
    #[inline(always)]
    pub fn select(&self, u: impl FnOnce() -> f32, uv: impl FnOnce() -> Vec2) -> &Material {
        match self {
            Material::Blend { a, b, weight } => {
                if u() < weight.eval_with(uv) {
                    b
                } else {
                    a
                }
            }
            _ => self,
        }
    }

    /// Lambertian material with albedo given as a function of wavelength in nm.
    pub fn lambertian(albedo: impl Into<SpectrumTexture>) -> Material {
        Material::Lambertian { albedo: albedo.into() }
    }

    /// Dielectric with relative index `ior(λ)` (dispersive when it varies over 360–830 nm) and
    /// microfacet distribution `distrib` (α below `microfacet::SMOOTH_ALPHA`: smooth).
    pub fn dielectric(ior: DenseSpectrum, distrib: Microfacet) -> Material {
        let s = ior.samples();
        let dispersive = s.iter().any(|&x| (x - s[0]).abs() > 1e-6 * s[0].abs());
        Material::Dielectric { ior, dispersive, distrib, roughness: None }
    }

    /// Conductor with complex index η + i k (relative to the outside) and roughness `distrib`.
    pub fn conductor(eta: DenseSpectrum, k: DenseSpectrum, distrib: Microfacet) -> Material {
        Material::Conductor { eta, k, distrib, roughness: None }
    }

    /// Plastic: a coating of index `ior` and roughness `alpha` over a Lambertian base `albedo`.
    pub fn plastic(albedo: impl Into<SpectrumTexture>, ior: f32, alpha: f32) -> Material {
        Material::Plastic { albedo: albedo.into(), ior, alpha, distribution: Distribution::Ggx, table: CoatingTable::get(alpha, ior), nonlinear: true, mitsuba: None }
    }

    /// This material with `nonlinear` set, if it is a plastic ([`CoatedDiffuse::nonlinear`]).
    pub fn with_nonlinear(self, nonlinear: bool) -> Option<Material> {
        match self {
            Material::Plastic { albedo, ior, alpha, distribution, table, mitsuba, .. } => Some(Material::Plastic { albedo, ior, alpha, distribution, table, nonlinear, mitsuba }),
            _ => None,
        }
    }

    /// This material with a plastic coating of microfacet `distribution` (None if it is not a plastic).
    pub fn with_coating_distribution(self, distribution: Distribution) -> Option<Material> {
        match self {
            Material::Plastic { albedo, ior, alpha, nonlinear, mitsuba, .. } => Some(Material::Plastic {
                albedo,
                ior,
                alpha,
                distribution,
                table: CoatingTable::get_for(alpha, ior, distribution),
                nonlinear,
                mitsuba: mitsuba.map(|_| crate::bsdf::MitsubaCoupling::get(alpha, ior, distribution)),
            }),
            _ => None,
        }
    }

    /// This plastic with Mitsuba 3's diffuse term ([`crate::bsdf::MitsubaCoupling`]; None if it
    /// is not a plastic).
    pub fn with_mitsuba_coupling(self) -> Option<Material> {
        match self {
            Material::Plastic { albedo, ior, alpha, distribution, table, nonlinear, .. } => Some(Material::Plastic {
                albedo,
                ior,
                alpha,
                distribution,
                table,
                nonlinear,
                mitsuba: Some(crate::bsdf::MitsubaCoupling::get(alpha, ior, distribution)),
            }),
            _ => None,
        }
    }

    /// This material with its roughness given by `roughness` (r ∈ [0, 1] over the surface,
    /// α = r²); only dielectrics and conductors have one (None for the others).
    pub fn with_roughness_texture(self, roughness: FloatTexture) -> Option<Material> {
        match self {
            Material::Dielectric { ior, dispersive, distrib, .. } => Some(Material::Dielectric { ior, dispersive, distrib, roughness: Some(roughness) }),
            Material::Conductor { eta, k, distrib, .. } => Some(Material::Conductor { eta, k, distrib, roughness: Some(roughness) }),
            Material::Lambertian { .. } | Material::DiffuseTransmitter { .. } | Material::Black | Material::ThinDielectric { .. } | Material::Plastic { .. } | Material::Translucent(_) | Material::Blend { .. } => None,
        }
    }

    /// Whether the material varies over the surface (the surface then needs texture coordinates).
    pub fn is_textured(&self) -> bool {
        match self {
            Material::Lambertian { albedo } | Material::Plastic { albedo, .. } => albedo.is_textured(),
            Material::DiffuseTransmitter { albedo, transmittance } => albedo.is_textured() || transmittance.is_textured(),
            Material::Dielectric { roughness, .. } | Material::Conductor { roughness, .. } => roughness.is_some(),
            Material::Black | Material::ThinDielectric { .. } | Material::Translucent(_) => false,
            Material::Blend { a, b, weight } => matches!(weight, FloatTexture::Image(_)) || a.is_textured() || b.is_textured(),
        }
    }

    /// The BSDF for a hit on the front (`front_face`, the side the geometric normal points to) or
    /// back face, with the wavelength bookkeeping the integrators need: a dispersive dielectric
    /// terminates the secondary wavelengths of `wl` (their pdf becomes 0, the hero's is divided by
    /// 4) before its η is taken at the hero wavelength. Equivalent to [`Material::bsdf`] followed
    /// by [`Bsdf::from_inside`] for back faces and `wl.terminate_secondary()` when
    /// [`Bsdf::terminates_secondary`].
    /// The texture coordinates come from `uv`, called only by textured materials.
    #[inline(always)]
    pub fn bsdf_at(&self, wl: &mut SampledWavelengths, front_face: bool, uv: impl FnOnce() -> Vec2) -> Bsdf {
        let b = self.bsdf_with(wl, uv);
        if b.terminates_secondary() {
            wl.terminate_secondary();
        }
        if front_face {
            b
        } else {
            b.from_inside()
        }
    }

    /// The BSDF of this material at the wavelengths `wl` and texture coordinates `uv` (which
    /// only textured materials read), for a hit on the FRONT (outside) face; for a hit from
    /// inside use [`Bsdf::from_inside`] on the result.
    #[inline]
    pub fn bsdf(&self, wl: &SampledWavelengths, uv: Vec2) -> Bsdf {
        self.bsdf_with(wl, || uv)
    }

    /// [`Material::bsdf`] with the texture coordinates computed by `uv` only when a texture
    /// is looked up (untextured materials never call it).
    #[inline(always)]
    pub fn bsdf_with(&self, wl: &SampledWavelengths, uv: impl FnOnce() -> Vec2) -> Bsdf {
        match self {
            Material::Lambertian { albedo } => Bsdf::Diffuse { r: albedo.eval_with(wl, uv) },
            Material::DiffuseTransmitter { albedo, transmittance } => {
                // One lookup of the texture coordinates for both textures.
                let uv = if albedo.is_textured() || transmittance.is_textured() { uv() } else { Vec2::ZERO };
                Bsdf::DiffuseTransmission { r: albedo.eval_with(wl, || uv), t: transmittance.eval_with(wl, || uv) }
            }
            Material::Black => Bsdf::Black,
            Material::ThinDielectric { ior } => Bsdf::ThinDielectric(ThinDielectric { eta: wl.eval(ior) }),
            Material::Dielectric { ior, dispersive, distrib, roughness } => {
                let distrib = &textured_distrib(distrib, roughness, uv);
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
            Material::Conductor { eta, k, distrib, roughness } => {
                let distrib = &textured_distrib(distrib, roughness, uv);
                let (eta, k) = (wl.eval(eta), wl.eval(k));
                if distrib.effectively_smooth() {
                    Bsdf::SmoothConductor(SmoothConductor { eta, k })
                } else {
                    Bsdf::RoughConductor(RoughConductor { distrib: *distrib, eta, k })
                }
            }
            Material::Plastic { albedo, ior, alpha, distribution, table, nonlinear, mitsuba } => Bsdf::Coated(CoatedDiffuse {
                albedo: albedo.eval_with(wl, uv),
                eta: *ior,
                // Mitsuba's coupling comes with its separable masking on the specular lobe too.
                distrib: Microfacet::isotropic(*alpha)
                    .with_distribution(*distribution)
                    .with_masking(if mitsuba.is_some() { Masking::Separable } else { Masking::HeightCorrelated }),
                table,
                nonlinear: *nonlinear,
                mitsuba: *mitsuba,
            }),
            Material::Translucent(t) => t.boundary_dielectric(),
            // The integrators choose a blend's component first ([`Material::select`]); here the
            // component that u = ½ would choose.
            Material::Blend { .. } => {
                let uv = uv();
                self.select(|| 0.5, || uv).bsdf(wl, uv)
            }
        }
    }
}

/// The microfacet distribution at `uv`: `distrib` itself when the roughness is not textured.
#[inline]
fn textured_distrib(distrib: &Microfacet, roughness: &Option<FloatTexture>, uv: impl FnOnce() -> Vec2) -> Microfacet {
    match roughness {
        None => *distrib,
        Some(r) => distrib.with_alpha(crate::bsdf::microfacet::roughness_to_alpha(r.eval_with(uv).clamp(0.0, 1.0))),
    }
}
