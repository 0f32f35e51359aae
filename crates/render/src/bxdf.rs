//! Scattering lobes at fixed wavelengths: smooth and rough dielectrics, smooth and rough
//! conductors, and a dielectric coating over a diffuse base (plastic).
//!
//! Frame convention (as in pbrt-v4): every lobe works in a local frame whose +z is the surface
//! normal pointing to the *outside* (the side whose index is 1 for dielectrics); `wo` and `wi`
//! may lie on either side. The renderer's shading frame has z on the side of `wo`, so for a
//! dielectric hit from the inside the material flips the lobe (η → 1/η, see
//! [`crate::material::Bsdf::from_inside`]); the reflection-only lobes (conductors, plastic) are
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

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::material::BsdfSample;
use crate::microfacet::{reflect, refract, TrowbridgeReitz};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::spectral::SampledSpectrum;
use glam::{Vec2, Vec3, Vec4};
use std::collections::HashMap;
use std::f32::consts::FRAC_1_PI;
use std::sync::Mutex;

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

#[inline]
fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

/// Mirror both directions to the upper side when `wo` is below (two-sided reflection lobes).
#[inline]
fn to_upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3, bool) {
    if wo.z < 0.0 {
        (-wo, -wi, true)
    } else {
        (wo, wi, false)
    }
}

#[inline]
fn flip_z(v: Vec3, flip: bool) -> Vec3 {
    if flip {
        -v
    } else {
        v
    }
}

// ---------------------------------------------------------------------------------------------

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

/// Rough dielectric interface (GGX, visible-normal sampling; Walter et al. 2007 transmission).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    /// Microfacet distribution.
    pub distrib: TrowbridgeReitz,
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

// ---------------------------------------------------------------------------------------------

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

/// Rough conductor: GGX microfacets with complex Fresnel, visible-normal sampling (two-sided).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughConductor {
    /// Microfacet distribution.
    pub distrib: TrowbridgeReitz,
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

// ---------------------------------------------------------------------------------------------

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

    fn compute(alpha: f32, eta: f32) -> CoatingTable {
        let distrib = TrowbridgeReitz::isotropic(alpha);
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

    /// The (cached, process-lifetime) table for coating roughness `alpha` and index `eta`.
    pub fn get(alpha: f32, eta: f32) -> &'static CoatingTable {
        static CACHE: Mutex<Option<HashMap<(u32, u32), &'static CoatingTable>>> = Mutex::new(None);
        let key = (alpha.to_bits(), eta.to_bits());
        let mut guard = CACHE.lock().unwrap_or_else(|e| e.into_inner());
        let map = guard.get_or_insert_with(HashMap::new);
        map.entry(key)
            .or_insert_with(|| Box::leak(Box::new(CoatingTable::compute(alpha, eta))))
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
    pub distrib: TrowbridgeReitz,
    /// Albedo table of the coating (from [`CoatingTable::get`] with the same α and η).
    pub table: &'static CoatingTable,
}

impl CoatedDiffuse {
    /// Build the lobe (looks up or computes the coating table; isotropic α).
    pub fn new(albedo: Vec4, eta: f32, alpha: f32) -> CoatedDiffuse {
        CoatedDiffuse {
            albedo,
            eta,
            distrib: TrowbridgeReitz::isotropic(alpha),
            table: CoatingTable::get(alpha, eta),
        }
    }

    #[inline]
    fn smooth(&self) -> bool {
        self.distrib.effectively_smooth()
    }

    #[inline]
    fn rho_eff(&self) -> Vec4 {
        let fi = self.table.f_dr_in;
        self.albedo * (1.0 - fi) / (Vec4::ONE - self.albedo * fi)
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
