//! A dielectric coating (smooth, or rough with GGX or Beckmann microfacets) over a Lambertian base ("plastic"); the model is
//! described in [`crate::bsdf`].

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::bsdf::fresnel::fresnel_dielectric;
use crate::bsdf::microfacet::{reflect, Distribution, Microfacet};
use crate::bsdf::{flip_z, to_upper, BsdfSample};
use crate::math::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::math::spectral::SampledSpectrum;
use glam::{Vec2, Vec3, Vec4};
use std::collections::HashMap;
use std::f32::consts::FRAC_1_PI;
use std::sync::Mutex;

/// Directional albedo E(μ) of a coating's specular lobe, tabulated in μ = cos θ, and the
/// constants of the diffuse coupling (see the module docs).
#[derive(Debug)]
pub struct CoatingTable {
    /// E at μ = i/(N−1), i = 0..N.
    e: Vec<f32>,
    /// Hemispherical average E_avg = 2∫E(μ)μ dμ.
    pub e_avg: f32,
    /// Diffuse Fresnel reflectance of the coating seen from inside, F_dr,in.
    pub f_dr_in: f32,
    /// For a smooth coating, its index: E(μ) is then the exact Fresnel reflectance.
    smooth_eta: Option<f32>,
}

const COATING_N: usize = 33;

impl CoatingTable {
    /// Directional albedo of the specular coating lobe at cosine `mu` ∈ [0, 1].
    #[inline]
    pub fn e(&self, mu: f32) -> f32 {
        if let Some(eta) = self.smooth_eta {
            return fresnel_dielectric(mu.clamp(0.0, 1.0), eta);
        }
        let x = mu.clamp(0.0, 1.0) * (COATING_N - 1) as f32;
        let i = (x as usize).min(COATING_N - 2);
        let t = x - i as f32;
        self.e[i] * (1.0 - t) + self.e[i + 1] * t
    }

    /// The albedo seen under the coating of a base of albedo ρ (per lane), darkened by the
    /// base–coating interreflections: ρ(1 − F_dr,in)/(1 − ρ F_dr,in).
    #[inline]
    pub fn albedo_under(&self, rho: Vec4) -> Vec4 {
        let fi = self.f_dr_in;
        rho * (1.0 - fi) / (Vec4::ONE - rho * fi)
    }

    fn compute(alpha: f32, eta: f32, distribution: Distribution) -> CoatingTable {
        let distrib = Microfacet::isotropic(alpha).with_distribution(distribution);
        let smooth = distrib.effectively_smooth();
        let mut e = Vec::with_capacity(COATING_N);
        for i in 0..COATING_N {
            let mu = (i as f32 / (COATING_N - 1) as f32).max(1e-4);
            if smooth {
                e.push(fresnel_dielectric(mu, eta));
                continue;
            }
            // E(μ) = ∫ D_wo(m) F(wo·m) G2(wo, wi)/G1(wo) dm over the VNDF's unit square (midpoint rule).
            let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            let n = 64;
            let mut sum = 0.0f64;
            for a in 0..n {
                for b in 0..n {
                    let u = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                    let wm = distrib.sample_visible_normal(wo, u);
                    let wi = reflect(wo, wm);
                    if wi.z <= 0.0 {
                        continue;
                    }
                    let w = fresnel_dielectric(wo.dot(wm), eta) * distrib.g(wo, wi) / distrib.g1(wo);
                    sum += w as f64;
                }
            }
            e.push((sum / (n * n) as f64) as f32);
        }
        // E_avg = 2∫E μ dμ by the trapezoid rule on the table.
        let h = 1.0 / (COATING_N - 1) as f64;
        let mut avg = 0.0f64;
        for i in 0..COATING_N - 1 {
            let (m0, m1) = (i as f64 * h, (i + 1) as f64 * h);
            avg += 0.5 * h * (e[i] as f64 * m0 + e[i + 1] as f64 * m1);
        }
        let f_dr_in = optics::fresnel::fresnel_diffuse_reflectance(1.0 / eta as f64) as f32;
        if smooth {
            let e_avg = optics::fresnel::fresnel_diffuse_reflectance(eta as f64) as f32;
            return CoatingTable {
                e,
                e_avg,
                f_dr_in,
                smooth_eta: Some(eta),
            };
        }
        CoatingTable {
            e,
            e_avg: (2.0 * avg) as f32,
            f_dr_in,
            smooth_eta: None,
        }
    }

    /// The (cached, process-lifetime) table for a GGX coating of roughness `alpha` and index `eta`.
    pub fn get(alpha: f32, eta: f32) -> &'static CoatingTable {
        CoatingTable::get_for(alpha, eta, Distribution::Ggx)
    }

    /// The (cached, process-lifetime) table for a coating of roughness `alpha`, index `eta` and
    /// microfacet `distribution`.
    pub fn get_for(alpha: f32, eta: f32, distribution: Distribution) -> &'static CoatingTable {
        static CACHE: Mutex<Option<HashMap<(u32, u32, Distribution), &'static CoatingTable>>> = Mutex::new(None);
        let key = (alpha.to_bits(), eta.to_bits(), distribution);
        let mut guard = CACHE.lock().unwrap_or_else(|e| e.into_inner());
        let map = guard.get_or_insert_with(HashMap::new);
        map.entry(key)
            .or_insert_with(|| Box::leak(Box::new(CoatingTable::compute(alpha, eta, distribution))))
    }
}

/// Dielectric coating (smooth or rough) over a Lambertian base; two-sided (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct CoatedDiffuse {
    /// Albedo of the base, per carried wavelength, in [0, 1].
    pub albedo: Vec4,
    /// Coating index relative to the outside.
    pub eta: f32,
    /// Coating roughness (effectively smooth → delta specular lobe).
    pub distrib: Microfacet,
    /// Albedo table of the coating (from [`CoatingTable::get`] with the same α and η).
    pub table: &'static CoatingTable,
    /// `albedo` is the base's (true, the default): the light the base returns is
    /// ρ(1 − F_in)/(1 − ρF_in) after its internal reflections. False: `albedo` is that
    /// effective albedo itself (Mitsuba 3's `plastic` with `nonlinear = false`, its default).
    pub nonlinear: bool,
}

impl CoatedDiffuse {
    /// Build the lobe (looks up or computes the coating table; isotropic α).
    pub fn new(albedo: Vec4, eta: f32, alpha: f32) -> CoatedDiffuse {
        CoatedDiffuse {
            albedo,
            eta,
            distrib: Microfacet::isotropic(alpha),
            table: CoatingTable::get(alpha, eta),
            nonlinear: true,
        }
    }

    /// The same lobe with a coating of microfacet `distribution` (and its table).
    pub fn with_distribution(self, distribution: Distribution) -> CoatedDiffuse {
        CoatedDiffuse {
            distrib: self.distrib.with_distribution(distribution),
            table: CoatingTable::get_for(self.distrib.alpha_x, self.eta, distribution),
            ..self
        }
    }

    #[inline]
    fn smooth(&self) -> bool {
        self.distrib.effectively_smooth()
    }

    #[inline]
    fn rho_eff(&self) -> Vec4 {
        if !self.nonlinear {
            return self.albedo;
        }
        self.table.albedo_under(self.albedo)
    }

    /// Probability of choosing the specular lobe for upper-side `wo`.
    #[inline]
    fn p_spec(&self, wo: Vec3) -> f32 {
        let e = self.table.e(wo.z);
        let d = (1.0 - e) * self.rho_eff().dot(Vec4::splat(0.25));
        if e + d > 0.0 {
            e / (e + d)
        } else {
            1.0
        }
    }

    #[inline]
    fn diffuse(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let t = &self.table;
        self.rho_eff() * ((1.0 - t.e(wo.z)) * (1.0 - t.e(wi.z)) * FRAC_1_PI / (1.0 - t.e_avg))
    }

    #[inline]
    fn spec_rough(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        let wm = (wo + wi).normalize();
        let f = fresnel_dielectric(wo.dot(wm), self.eta) * self.distrib.d(wm) * self.distrib.g(wo, wi)
            / (4.0 * wo.z * wi.z);
        let pdf = self.distrib.d_visible(wo, wm) / (4.0 * wo.dot(wm));
        (f, pdf)
    }

    /// Diffuse term plus (rough coating) specular term; the smooth coating's mirror lobe is a delta.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let (wo, wi, _) = to_upper(wo, wi);
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Vec4::ZERO;
        }
        let d = self.diffuse(wo, wi);
        if self.smooth() {
            d
        } else {
            d + Vec4::splat(self.spec_rough(wo, wi).0)
        }
    }

    /// Mixture density of the non-delta lobes.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi, _) = to_upper(wo, wi);
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let ps = self.p_spec(wo);
        let pd = (1.0 - ps) * cosine_hemisphere_pdf(wi.z);
        if self.smooth() {
            pd
        } else {
            pd + ps * self.spec_rough(wo, wi).1
        }
    }

    /// Pick the specular lobe with probability E/(E + (1−E)ρ̄_eff), else cosine-sample the base.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        let wou = flip_z(wo, flip);
        let ps = self.p_spec(wou);
        let wiu = if uc < ps {
            if self.smooth() {
                let wi = Vec3::new(-wou.x, -wou.y, wou.z);
                let f = fresnel_dielectric(wou.z, self.eta) / wi.z;
                return Some(BsdfSample {
                    wi: flip_z(wi, flip),
                    f: Vec4::splat(f),
                    pdf: ps,
                    delta: true,
                    transmission: false,
                    eta: 1.0,
                    terminate_secondary: false,
                });
            }
            let wm = self.distrib.sample_visible_normal(wou, u);
            reflect(wou, wm)
        } else {
            cosine_hemisphere(u)
        };
        if wiu.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wou, wiu);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wi: flip_z(wiu, flip),
            f: self.eval(wou, wiu),
            pdf,
            delta: false,
            transmission: false,
            eta: 1.0,
            terminate_secondary: false,
        })
    }
}
