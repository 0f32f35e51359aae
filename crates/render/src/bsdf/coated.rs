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

/// Per-coating data computed once per (α, η, distribution) and kept for the process's lifetime.
type CoatingCache<T> = Mutex<Option<HashMap<(u32, u32, Distribution), &'static T>>>;

/// The entry of `cache` for (α, η, distribution), computed by `make` the first time.
fn cached<T>(cache: &CoatingCache<T>, alpha: f32, eta: f32, distribution: Distribution, make: fn(f32, f32, Distribution) -> T) -> &'static T {
    let key = (alpha.to_bits(), eta.to_bits(), distribution);
    let mut guard = cache.lock().unwrap_or_else(|e| e.into_inner());
    let map = guard.get_or_insert_with(HashMap::new);
    map.entry(key).or_insert_with(|| Box::leak(Box::new(make(alpha, eta, distribution))))
}

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
        static CACHE: CoatingCache<CoatingTable> = Mutex::new(None);
        cached(&CACHE, alpha, eta, distribution, CoatingTable::compute)
    }
}

/// The diffuse term as Mitsuba 3's `plastic` and `roughplastic` write it:
/// f_d = ρ′ t(μo) t(μi) / (π η²), ρ′ = ρ/(1 − ρ F_int) (`nonlinear`) or ρ/(1 − F_int), with
/// t(μ) the light the coating lets through from outside, ∫ D_wo(m) (1 − F(wo·m)) G1(wt, m) dm
/// (wt the refracted direction, separable masking), tabulated at 64 equally spaced cosines and
/// interpolated linearly, and F_int twice the mean of R_in(μ) μ over the same 64 cosines, R_in the
/// coating's specular reflectance from inside (total internal reflection included), as
/// Mitsuba 3.9.1's `roughplastic` computes them. For a smooth coating t = 1 − F and F_int = F_dr,in
/// (Mitsuba's `plastic`), and the term equals lucent's; for a rough one the light the single-scattering lobes lose to masking is
/// not given back, so a white base reflects less than all the light (Mitsuba's model).
#[derive(Debug)]
pub struct MitsubaCoupling {
    /// t(μ) at μ = max(10⁻⁶, i/63).
    t: Vec<f32>,
    /// F_int.
    pub f_int: f32,
    /// 1/η².
    inv_eta2: f32,
    /// For a smooth coating, its index: t(μ) = 1 − F(μ) exactly.
    smooth_eta: Option<f32>,
}

const MTS_N: usize = 64;

impl MitsubaCoupling {
    /// t(μ), interpolated linearly between the 64 nodes (exact for a smooth coating).
    #[inline]
    pub fn t(&self, mu: f32) -> f32 {
        if let Some(eta) = self.smooth_eta {
            return 1.0 - fresnel_dielectric(mu.clamp(0.0, 1.0), eta);
        }
        let x = mu.clamp(0.0, 1.0) * (MTS_N - 1) as f32;
        let i = (x as usize).min(MTS_N - 2);
        let f = x - i as f32;
        self.t[i] * (1.0 - f) + self.t[i + 1] * f
    }

    fn compute(alpha: f32, eta: f32, distribution: Distribution) -> MitsubaCoupling {
        let distrib = Microfacet::isotropic(alpha).with_distribution(distribution).with_masking(crate::bsdf::microfacet::Masking::Separable);
        let smooth = distrib.effectively_smooth();
        // ∫ over the visible normals of `wo` of `g(wo, m)`, midpoint rule on the sampler's unit square.
        let vndf_mean = |wo: Vec3, n: usize, g: &dyn Fn(Vec3) -> f32| -> f64 {
            let mut sum = 0.0f64;
            for a in 0..n {
                for b in 0..n {
                    let u = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                    sum += g(distrib.sample_visible_normal(wo, u)) as f64;
                }
            }
            sum / (n * n) as f64
        };
        let mut t = Vec::with_capacity(MTS_N);
        let mut r_in_mu = 0.0f64;
        for i in 0..MTS_N {
            let mu = (i as f32 / (MTS_N - 1) as f32).max(1e-6);
            if smooth {
                t.push(1.0 - fresnel_dielectric(mu, eta));
                continue;
            }
            let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            let trans = vndf_mean(wo, 64, &|m| {
                let c = wo.dot(m);
                match crate::bsdf::microfacet::refract(wo, m, eta) {
                    Some((wt, _)) if wt.z < 0.0 => (1.0 - fresnel_dielectric(c, eta)) * distrib.g1(wt) * if wt.dot(m) < 0.0 { 1.0 } else { 0.0 },
                    _ => 0.0,
                }
            });
            t.push(trans as f32);
            let refl = vndf_mean(wo, 96, &|m| {
                let wr = reflect(wo, m);
                if wr.z <= 0.0 || wr.dot(m) <= 0.0 {
                    return 0.0;
                }
                fresnel_dielectric(wo.dot(m), 1.0 / eta) * distrib.g1(wr)
            });
            r_in_mu += refl * mu as f64;
        }
        // A smooth coating's F_int is the exact diffuse Fresnel reflectance (Mitsuba's `plastic`).
        let f_int = if smooth { optics::fresnel::fresnel_diffuse_reflectance(1.0 / eta as f64) } else { 2.0 * r_in_mu / MTS_N as f64 };
        MitsubaCoupling { t, f_int: f_int as f32, inv_eta2: 1.0 / (eta * eta), smooth_eta: smooth.then_some(eta) }
    }

    /// The (cached, process-lifetime) coupling for a coating of roughness `alpha`, index `eta` and
    /// microfacet `distribution`.
    pub fn get(alpha: f32, eta: f32, distribution: Distribution) -> &'static MitsubaCoupling {
        static CACHE: CoatingCache<MitsubaCoupling> = Mutex::new(None);
        cached(&CACHE, alpha, eta, distribution, MitsubaCoupling::compute)
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
    /// The diffuse term as Mitsuba 3 writes it ([`MitsubaCoupling`]) instead of lucent's
    /// energy-conserving coupling (None, the default).
    pub mitsuba: Option<&'static MitsubaCoupling>,
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
            mitsuba: None,
        }
    }

    /// The same lobe with a coating of microfacet `distribution` (and its tables).
    pub fn with_distribution(self, distribution: Distribution) -> CoatedDiffuse {
        CoatedDiffuse {
            distrib: self.distrib.with_distribution(distribution),
            table: CoatingTable::get_for(self.distrib.alpha_x, self.eta, distribution),
            mitsuba: self.mitsuba.map(|_| MitsubaCoupling::get(self.distrib.alpha_x, self.eta, distribution)),
            ..self
        }
    }

    /// The same lobe with Mitsuba 3's diffuse term ([`MitsubaCoupling`]) and its separable
    /// masking on the specular lobe.
    pub fn with_mitsuba_coupling(self) -> CoatedDiffuse {
        CoatedDiffuse {
            mitsuba: Some(MitsubaCoupling::get(self.distrib.alpha_x, self.eta, self.distrib.distribution)),
            distrib: self.distrib.with_masking(crate::bsdf::microfacet::Masking::Separable),
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
        if let Some(c) = self.mitsuba {
            let fi = Vec4::splat(c.f_int);
            let rho = if self.nonlinear { self.albedo / (Vec4::ONE - self.albedo * fi) } else { self.albedo / (Vec4::ONE - fi) };
            return rho * (c.t(wo.z) * c.t(wi.z) * FRAC_1_PI * c.inv_eta2);
        }
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
