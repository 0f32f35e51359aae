//! Smooth and rough (GGX or Beckmann microfacet) conductors with the complex Fresnel reflectance; conventions in [`crate::bsdf`].

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::bsdf::fresnel::fresnel_conductor;
use crate::bsdf::microfacet::{reflect, Microfacet};
use crate::bsdf::{flip_z, to_upper, BsdfSample};
use crate::math::spectral::SampledSpectrum;
use glam::{Vec2, Vec3, Vec4};

/// Perfectly smooth conductor: mirror reflection with the complex Fresnel reflectance per wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothConductor {
    /// Real part η of the relative complex index, per carried wavelength.
    pub eta: Vec4,
    /// Extinction coefficient k, per carried wavelength.
    pub k: Vec4,
}

impl SmoothConductor {
    /// Delta lobe only: f = 0.
    pub fn eval(&self, _wo: Vec3, _wi: Vec3) -> SampledSpectrum {
        Vec4::ZERO
    }

    /// Delta lobe only: density 0.
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    /// The mirror direction with f = F(θ)/|cos θ| and discrete probability 1.
    pub fn sample(&self, wo: Vec3, _uc: f32, _u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        let f = fresnel_conductor(wi.z, self.eta, self.k) / wi.z.abs();
        Some(BsdfSample {
            wi,
            f,
            pdf: 1.0,
            delta: true,
            transmission: false,
            eta: 1.0,
            terminate_secondary: false,
        })
    }
}

// ---------------------------------------------------------------------------------------------

/// Rough conductor: GGX or Beckmann microfacets with complex Fresnel, visible-normal sampling (two-sided).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughConductor {
    /// Microfacet distribution.
    pub distrib: Microfacet,
    /// Real part η of the relative complex index, per carried wavelength.
    pub eta: Vec4,
    /// Extinction coefficient k, per carried wavelength.
    pub k: Vec4,
}

impl RoughConductor {
    /// f = D(m) G2 F(wo·m) / (4 |cos θo cos θi|), m the half vector.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let (wo, wi, _) = to_upper(wo, wi);
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Vec4::ZERO;
        }
        let wm = wo + wi;
        if wm.length_squared() == 0.0 {
            return Vec4::ZERO;
        }
        let wm = wm.normalize();
        let f = fresnel_conductor(wo.dot(wm), self.eta, self.k);
        f * (self.distrib.d(wm) * self.distrib.g(wo, wi) / (4.0 * wo.z * wi.z))
    }

    /// D_wo(m) / (4 |wo·m|).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi, _) = to_upper(wo, wi);
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let wm = wo + wi;
        if wm.length_squared() == 0.0 {
            return 0.0;
        }
        let wm = wm.normalize();
        self.distrib.d_visible(wo, wm) / (4.0 * wo.dot(wm))
    }

    /// Reflect `wo` about a sampled visible normal.
    pub fn sample(&self, wo: Vec3, _uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        let wou = flip_z(wo, flip);
        let wm = self.distrib.sample_visible_normal(wou, u);
        let wiu = reflect(wou, wm);
        if wiu.z <= 0.0 {
            return None;
        }
        let pdf = self.distrib.d_visible(wou, wm) / (4.0 * wou.dot(wm));
        if !(pdf > 0.0) {
            return None;
        }
        let f = fresnel_conductor(wou.dot(wm), self.eta, self.k)
            * (self.distrib.d(wm) * self.distrib.g(wou, wiu) / (4.0 * wou.z * wiu.z));
        Some(BsdfSample {
            wi: flip_z(wiu, flip),
            f,
            pdf,
            delta: false,
            transmission: false,
            eta: 1.0,
            terminate_secondary: false,
        })
    }
}
