//! Smooth and rough (GGX or Beckmann microfacets, Walter et al. 2007) dielectric interfaces; conventions in [`crate::bsdf`].

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::bsdf::fresnel::fresnel_dielectric;
use crate::bsdf::microfacet::{reflect, refract, Microfacet};
use crate::bsdf::{same_hemisphere, BsdfSample};
use crate::math::spectral::SampledSpectrum;
use glam::{Vec2, Vec3, Vec4};

/// Perfectly smooth dielectric interface: specular reflection and refraction weighted by Fresnel,
/// total internal reflection included.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothDielectric {
    /// Relative index n_inside / n_outside (> 0).
    pub eta: f32,
}

impl SmoothDielectric {
    /// Delta lobes only: f = 0 for any pair of directions.
    pub fn eval(&self, _wo: Vec3, _wi: Vec3) -> SampledSpectrum {
        Vec4::ZERO
    }

    /// Delta lobes only: density 0.
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    /// Choose reflection with probability R (Fresnel), else refraction; `uc` picks the lobe.
    pub fn sample(&self, wo: Vec3, uc: f32, _u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let r = fresnel_dielectric(wo.z, self.eta);
        let t = 1.0 - r;
        if uc < r / (r + t) {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = r / wi.z.abs();
            Some(BsdfSample {
                wi,
                f: Vec4::splat(f),
                pdf: r / (r + t),
                delta: true,
                transmission: false,
                eta: 1.0,
                terminate_secondary: false,
            })
        } else {
            let (wi, etap) = refract(wo, Vec3::Z, self.eta)?;
            if wi.z == 0.0 || same_hemisphere(wo, wi) {
                return None;
            }
            let f = t / wi.z.abs() / (etap * etap);
            Some(BsdfSample {
                wi,
                f: Vec4::splat(f),
                pdf: t / (r + t),
                delta: true,
                transmission: true,
                eta: etap,
                terminate_secondary: false,
            })
        }
    }
}

// ---------------------------------------------------------------------------------------------

/// A thin dielectric sheet (a window pane; Mitsuba 3's `thindielectric`): two parallel smooth
/// faces a negligible distance apart, nothing absorbed between them. Light reflected between the
/// faces, summed incoherently, gives R′ = R + T²R(1 + R² + R⁴ + …) = 2R/(1 + R) and T′ = 1 − R′,
/// R the Fresnel reflectance of one face at the angle of incidence (the path inside refracts to
/// the same angle at both faces, so one R serves every bounce). The transmitted light leaves
/// unbent, along −wo, and its radiance is not compressed (it leaves into the index it came from).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    /// Index of the sheet relative to its surroundings, per carried wavelength (> 0).
    pub eta: Vec4,
}

impl ThinDielectric {
    /// R′ = 2R/(1 + R) per lane at |cos θ| = `cos_theta`.
    #[inline]
    pub fn reflectance(&self, cos_theta: f32) -> Vec4 {
        let c = cos_theta.abs();
        let r = Vec4::new(
            fresnel_dielectric(c, self.eta.x),
            fresnel_dielectric(c, self.eta.y),
            fresnel_dielectric(c, self.eta.z),
            fresnel_dielectric(c, self.eta.w),
        );
        2.0 * r / (Vec4::ONE + r)
    }

    /// Delta lobes only: f = 0.
    pub fn eval(&self, _wo: Vec3, _wi: Vec3) -> SampledSpectrum {
        Vec4::ZERO
    }

    /// Delta lobes only: density 0.
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    /// Reflection with probability the lanes' mean R′, else straight transmission; `uc` picks.
    pub fn sample(&self, wo: Vec3, uc: f32, _u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let r = self.reflectance(wo.z);
        let p = (r.x + r.y + r.z + r.w) / 4.0;
        let reflect = if p >= 1.0 { true } else if p <= 0.0 { false } else { uc < p };
        let (wi, f, pdf) = if reflect {
            (Vec3::new(-wo.x, -wo.y, wo.z), r, p)
        } else {
            (-wo, Vec4::ONE - r, 1.0 - p)
        };
        Some(BsdfSample {
            wi,
            f: f / wi.z.abs(),
            pdf,
            delta: true,
            transmission: !reflect,
            eta: 1.0,
            terminate_secondary: false,
        })
    }
}


/// Rough dielectric interface (GGX or Beckmann, visible-normal sampling; Walter et al. 2007 transmission).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    /// Microfacet distribution.
    pub distrib: Microfacet,
    /// Relative index n_inside / n_outside (> 0, ≠ 1 for a visible interface).
    pub eta: f32,
}

impl RoughDielectric {
    /// Generalised half vector (upper side) and etap for the pair, or None when degenerate or
    /// when a direction lies behind the microfacet it would scatter off.
    #[inline]
    fn half_vector(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32, bool)> {
        let (co, ci) = (wo.z, wi.z);
        if co == 0.0 || ci == 0.0 {
            return None;
        }
        let reflect = co * ci > 0.0;
        let etap = if reflect {
            1.0
        } else if co > 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        let wm = wi * etap + wo;
        if wm.length_squared() == 0.0 {
            return None;
        }
        let mut wm = wm.normalize();
        if wm.z < 0.0 {
            wm = -wm;
        }
        if wm.dot(wi) * ci < 0.0 || wm.dot(wo) * co < 0.0 {
            return None;
        }
        Some((wm, etap, reflect))
    }

    /// f(wo, wi) per steradian (radiance transport).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let Some((wm, etap, reflect)) = self.half_vector(wo, wi) else {
            return Vec4::ZERO;
        };
        let f = fresnel_dielectric(wo.dot(wm), self.eta);
        let d = self.distrib.d(wm);
        let g = self.distrib.g(wo, wi);
        let v = if reflect {
            d * g * f / (4.0 * wi.z * wo.z).abs()
        } else {
            let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2) * wi.z * wo.z;
            d * (1.0 - f) * g * (wi.dot(wm) * wo.dot(wm) / denom).abs() / (etap * etap)
        };
        Vec4::splat(v)
    }

    /// Density per steradian of [`RoughDielectric::sample`] producing `wi`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wm, etap, reflect)) = self.half_vector(wo, wi) else {
            return 0.0;
        };
        let r = fresnel_dielectric(wo.dot(wm), self.eta);
        let t = 1.0 - r;
        let dv = self.distrib.d_visible(wo, wm);
        if reflect {
            dv / (4.0 * wo.dot(wm).abs()) * r / (r + t)
        } else {
            let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
            dv * wi.dot(wm).abs() / denom * t / (r + t)
        }
    }

    /// Sample a visible normal, then reflect (probability F) or refract about it.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wm = self.distrib.sample_visible_normal(wo, u);
        let r = fresnel_dielectric(wo.dot(wm), self.eta);
        let t = 1.0 - r;
        let dv = self.distrib.d_visible(wo, wm);
        if uc < r / (r + t) {
            let wi = reflect(wo, wm);
            if !same_hemisphere(wo, wi) {
                return None;
            }
            let pdf = dv / (4.0 * wo.dot(wm).abs()) * r / (r + t);
            let f = self.distrib.d(wm) * self.distrib.g(wo, wi) * r / (4.0 * wi.z * wo.z).abs();
            if !(pdf > 0.0) {
                return None;
            }
            Some(BsdfSample {
                wi,
                f: Vec4::splat(f),
                pdf,
                delta: false,
                transmission: false,
                eta: 1.0,
                terminate_secondary: false,
            })
        } else {
            let (wi, etap) = refract(wo, wm, self.eta)?;
            if same_hemisphere(wo, wi) || wi.z == 0.0 {
                return None;
            }
            let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
            let pdf = dv * wi.dot(wm).abs() / denom * t / (r + t);
            let f = t
                * self.distrib.d(wm)
                * self.distrib.g(wo, wi)
                * (wi.dot(wm) * wo.dot(wm) / (wi.z * wo.z * denom)).abs()
                / (etap * etap);
            if !(pdf > 0.0) || !f.is_finite() {
                return None;
            }
            Some(BsdfSample {
                wi,
                f: Vec4::splat(f),
                pdf,
                delta: false,
                transmission: true,
                eta: etap,
                terminate_secondary: false,
            })
        }
    }
}
