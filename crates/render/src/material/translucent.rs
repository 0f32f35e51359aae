//! The translucent material: a closed object with a smooth or GGX-rough dielectric boundary of
//! relative index η over a homogeneous scattering interior σ_s(λ), σ_a(λ), g(λ), rendered with a
//! dipole BSSRDF by the point-cloud method of [`crate::integrator::subsurface`].

use crate::bsdf::conductor::{RoughConductor, SmoothConductor};
use crate::bsdf::dielectric::{RoughDielectric, SmoothDielectric};
use crate::bsdf::microfacet::Microfacet;
use crate::bsdf::Bsdf;
use anyhow::{bail, Context, Result};
use glam::Vec4;
use optics::bssrdf::{DipoleModel, OpticalProperties};
use optics::spectrum::DenseSpectrum;

/// Default r0 of rejection control, in transport mean free paths ([`Translucent::rejection_radius_mfp`]):
/// 0, the tutorial's pure exponential acceptance e^{−σ_tr d}. Scenes may ask for a distance-adaptive
/// acceptance (r0 > 0; 3 is what the example scenes use, about 10× faster at equal noise on the marble bunny).
pub const DEFAULT_REJECTION_RADIUS_MFP: f32 = 0.0;

/// Default number of cloud points per pass and translucent object.
pub const DEFAULT_POINTS_PER_PASS: usize = 16384;

/// Default number of wavelength sets (point clouds) per pass, [`Translucent::wavelength_sets`].
pub const DEFAULT_WAVELENGTH_SETS: u32 = 4;

/// A translucent material: smooth dielectric boundary over a homogeneous scattering interior,
/// rendered with a dipole BSSRDF.
#[derive(Clone, Debug)]
pub struct Translucent {
    /// Relative index of refraction η = n_inside / n_outside (non-dispersive).
    pub eta: f32,
    /// Which dipole evaluates S_d.
    pub model: DipoleModel,
    /// Scattering coefficient σ_s(λ), m⁻¹.
    pub sigma_s_per_m: DenseSpectrum,
    /// Absorption coefficient σ_a(λ), m⁻¹.
    pub sigma_a_per_m: DenseSpectrum,
    /// Henyey–Greenstein asymmetry g(λ) (only σ'_s = σ_s(1 − g) matters to the dipoles).
    pub g: DenseSpectrum,
    /// Cloud points per pass on each object with this material.
    pub points_per_pass: usize,
    /// Rejection control on (acceptance e^{−σ_tr,min d}·min(1, (r0/d)³)); off: every point is
    /// accepted.
    pub rejection_control: bool,
    /// r0 of rejection control in transport mean free paths 1/σ'_t (the largest over the pass's
    /// wavelengths); beyond r0 the acceptance falls by an extra (r0/d)³, about as fast as the
    /// dipoles' mid-range falloff, so distant points, which add little variance, are rarely
    /// evaluated. 0: pure e^{−σ_tr,min d} (the original scheme).
    pub rejection_radius_mfp: f32,
    /// Take σ_s, σ_a and g from the object's interior `medium` instead (the same coefficients
    /// volumetric path tracing uses; the spectra above are then unused).
    pub from_medium: bool,
    /// GGX (Trowbridge–Reitz) α of the boundary; below `microfacet::SMOOTH_ALPHA` the boundary is
    /// smooth (the scene key `roughness` r gives α = r², as for `rough_dielectric`). Only the
    /// boundary's reflection lobe (and, for `volpath`, its transmission) is rough; the diffusion
    /// term keeps the Fresnel transmittances T12, T21 at the macro normal (pbrt-v3's
    /// `SubsurfaceMaterial`), see docs/subsurface.md.
    pub boundary_alpha: f32,
    /// Subsurface bounces of the point cloud (`bounces`, default 1): with N > 1 each pass builds
    /// N clouds in turn, and the paths traced from the points of each cloud see translucent
    /// surfaces with the BSSRDF term of the cloud before it (the first sees them as reflectors
    /// only). Light that leaves the object by subsurface scattering, is sent back by its
    /// surroundings (a glass around milk) and enters again is then counted up to N − 1 times
    /// instead of dropped. The scene uses the largest N of its translucent materials.
    pub bounces: u32,
    /// Wavelength sets per pass (`wavelength_sets`, default [`DEFAULT_WAVELENGTH_SETS`]): each pass
    /// builds K point clouds (each of `points_per_pass` points), at K interleaved sets of hero
    /// wavelengths, and every pixel of the pass uses one of them (each 2×2 block of pixels holds
    /// all four sets when K = 4). With K = 1 every path of a pass shares four wavelengths, which
    /// gives each pass an image-wide colour cast. The scene uses the largest K of its
    /// translucent materials.
    pub wavelength_sets: u32,
}

impl Translucent {
    /// A translucent material from spectra; checks η > 0 and that every wavelength gives valid
    /// optical properties (α' ∈ [0, 1], finite non-negative coefficients).
    pub fn new(
        eta: f32,
        model: DipoleModel,
        sigma_s_per_m: DenseSpectrum,
        sigma_a_per_m: DenseSpectrum,
        g: DenseSpectrum,
    ) -> Result<Translucent> {
        if !(eta > 0.0) || !eta.is_finite() {
            bail!("ior must be positive and finite, got {eta}");
        }
        let t = Translucent {
            eta,
            model,
            sigma_s_per_m,
            sigma_a_per_m,
            g,
            points_per_pass: DEFAULT_POINTS_PER_PASS,
            rejection_control: true,
            rejection_radius_mfp: DEFAULT_REJECTION_RADIUS_MFP,
            from_medium: false,
            boundary_alpha: 0.0,
            bounces: 1,
            wavelength_sets: DEFAULT_WAVELENGTH_SETS,
        };
        for l in (360..=830).step_by(5) {
            let p = t.properties(l as f32);
            p.validate().with_context(|| format!("at {l} nm"))?;
            if !(p.sigma_s_per_m * (1.0 - p.g) + p.sigma_a_per_m > 0.0) {
                bail!("at {l} nm: the medium neither scatters nor absorbs (σ'_t = 0)");
            }
        }
        Ok(t)
    }

    /// Constant coefficients (m⁻¹) at every wavelength.
    pub fn constant(
        eta: f32,
        model: DipoleModel,
        sigma_s_per_m: f64,
        sigma_a_per_m: f64,
        g: f64,
    ) -> Result<Translucent> {
        Translucent::new(
            eta,
            model,
            DenseSpectrum::from_fn(|_| sigma_s_per_m),
            DenseSpectrum::from_fn(|_| sigma_a_per_m),
            DenseSpectrum::from_fn(|_| g),
        )
    }

    /// Set the boundary's perceptual roughness r ∈ [0, 1] (α = r², `microfacet::roughness_to_alpha`);
    /// 0 is the smooth boundary.
    pub fn set_roughness(&mut self, roughness: f64) -> Result<()> {
        if !(0.0..=1.0).contains(&roughness) {
            bail!("roughness: must be in [0, 1] (0: smooth boundary), got {roughness}");
        }
        self.boundary_alpha = crate::bsdf::microfacet::roughness_to_alpha(roughness as f32);
        Ok(())
    }

    /// The boundary's microfacet distribution (isotropic GGX of α = `boundary_alpha`).
    pub fn boundary_distrib(&self) -> Microfacet {
        Microfacet::isotropic(self.boundary_alpha)
    }

    /// The boundary's surface reflection alone (what the path tracer continues with on top of the
    /// BSSRDF term): a mirror with the dielectric Fresnel reflectance F(η) when smooth, else the
    /// rough dielectric's reflection lobe D G2 F / (4 cos θo cos θi), importance-sampled by visible
    /// normals and evaluable (light sampling and MIS apply). Written as a conductor of index η + 0i,
    /// whose Fresnel reflectance is the dielectric one.
    pub fn boundary_reflection(&self) -> Bsdf {
        let distrib = self.boundary_distrib();
        let (eta, k) = (Vec4::splat(self.eta), Vec4::ZERO);
        if distrib.effectively_smooth() {
            Bsdf::SmoothConductor(SmoothConductor { eta, k })
        } else {
            Bsdf::RoughConductor(RoughConductor { distrib, eta, k })
        }
    }

    /// The boundary as a full dielectric interface (reflection and refraction; front face), what
    /// `volpath` and paths without a point cloud see: smooth, or GGX-rough (Walter et al. 2007).
    pub fn boundary_dielectric(&self) -> Bsdf {
        let distrib = self.boundary_distrib();
        if distrib.effectively_smooth() || self.eta == 1.0 {
            Bsdf::SmoothDielectric { lobe: SmoothDielectric { eta: self.eta }, dispersive: false }
        } else {
            Bsdf::RoughDielectric { lobe: RoughDielectric { distrib, eta: self.eta }, dispersive: false }
        }
    }

    /// Optical properties at one wavelength (nm).
    pub fn properties(&self, lambda_nm: f32) -> OpticalProperties {
        OpticalProperties {
            eta: self.eta as f64,
            sigma_s_per_m: self.sigma_s_per_m.eval(lambda_nm) as f64,
            sigma_a_per_m: self.sigma_a_per_m.eval(lambda_nm) as f64,
            g: self.g.eval(lambda_nm) as f64,
        }
    }
}
