//! Next-event estimation, shared by every integrator: choosing a light in proportion to its
//! power and sampling it from a point, evaluating a surface's BSDF towards the sample, the
//! multiple-importance weight against BSDF sampling (power heuristic, Veach 1997), and the
//! MIS-weighted emission found by an escaping ray. Visibility uses the one shadow-ray rule of
//! [`crate::interaction`]; media attenuate shadow rays in [`crate::integrator::volpath`].

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::bsdf::Bsdf;
use crate::interaction::Shading;
use crate::light::LightSample;
use crate::math::geometry::Ray;
use crate::math::sampling::{power_heuristic, Pcg32};
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use crate::scene::Scene;
use glam::{Vec3, Vec4};

/// A light chosen for next-event estimation and a sample on it.
#[derive(Clone, Copy, Debug)]
pub struct LightChoice {
    /// The sample: direction, distance, incident radiance, density per steradian.
    pub ls: LightSample,
    /// Probability with which the light was chosen.
    pub pmf: f32,
}

impl LightChoice {
    /// Density per steradian of the direction over the choice of light and the point on it.
    #[inline]
    pub fn pdf(&self) -> f32 {
        self.pmf * self.ls.pdf
    }

    /// Power-heuristic weight of this light sample against a sampling technique (BSDF or phase
    /// function) that would pick the same direction with density `other_pdf`; 1 for delta lights.
    #[inline]
    pub fn mis_weight(&self, other_pdf: f32) -> f32 {
        if self.ls.delta {
            1.0
        } else {
            power_heuristic(1.0, self.pdf(), 1.0, other_pdf)
        }
    }
}

/// Choose a light by [`Scene::light_pmf`] (power, lights at infinity capped: [`crate::light::selection_pmf`]) and sample it from `p`. Always draws three numbers from
/// `rng` (the choice, then the point), so the random sequence does not depend on the outcome.
/// `None` when the scene has no light or the sample carries no light.
#[inline]
pub fn sample_light(scene: &Scene, p: Vec3, wl: &SampledWavelengths, rng: &mut Pcg32) -> Option<LightChoice> {
    let u_pick = rng.next_f32();
    let u = rng.next_2d();
    let (li_idx, pmf) = scene.pick_light(u_pick)?;
    let ls = scene.lights[li_idx].sample_li(p, u, wl)?;
    if !(ls.pdf > 0.0) || ls.li == Vec4::ZERO {
        return None;
    }
    Some(LightChoice { ls, pmf })
}

/// The BSDF at shading point `s` from `wo` towards the light sample's direction (with a normal or
/// bump map's shadowing term, [`Shading::terminator`]), with both directions in the local frame:
/// (f, wo_local, wi_local). `None` when f is zero or when the
/// direction's side of the geometric surface disagrees with its side of the shading frame
/// (light from below the geometric surface cannot reach a reflecting point's front, whatever the
/// interpolated normal says).
#[inline]
pub fn surface_bsdf(s: &Shading, wo: Vec3, bsdf: &Bsdf, wi: Vec3) -> Option<(SampledSpectrum, Vec3, Vec3)> {
    let wi_l = s.frame.to_local(wi);
    let wo_l = s.frame.to_local(wo);
    let f = bsdf.eval(wo_l, wi_l);
    if f == Vec4::ZERO || (wi.dot(s.ng) <= 0.0) != (wi_l.z <= 0.0) {
        return None;
    }
    Some((f * s.terminator(wi), wo_l, wi_l))
}

/// One light sample at shading point `s` seen from `wo`, with its visibility tested:
/// f · L_i · |cos θ_i| · w / pdf, MIS-weighted against BSDF sampling when `mis`.
#[inline]
pub fn surface_light(scene: &Scene, s: &Shading, wo: Vec3, bsdf: &Bsdf, wl: &SampledWavelengths, rng: &mut Pcg32, mis: bool) -> SampledSpectrum {
    let Some(c) = sample_light(scene, s.p, wl, rng) else { return Vec4::ZERO };
    let Some((f, wo_l, wi_l)) = surface_bsdf(s, wo, bsdf, c.ls.wi) else { return Vec4::ZERO };
    if !s.unoccluded(scene, c.ls.wi, c.ls.dist) {
        return Vec4::ZERO;
    }
    let w = if mis { c.mis_weight(bsdf.pdf(wo_l, wi_l)) } else { 1.0 };
    f * c.ls.li * (wi_l.z.abs() * w / c.pdf())
}

/// Path throughput `beta` times the radiance of the environment seen along an escaping `ray`,
/// MIS-weighted against light sampling from `prev_p` (power heuristic) unless the last direction
/// was not BSDF/phase-sampled with a density (`no_mis`: camera ray or delta lobe). Zero without
/// an environment.
#[inline]
pub fn environment_emission(scene: &Scene, ray: &Ray, beta: SampledSpectrum, prev_p: Vec3, prev_pdf: f32, no_mis: bool, wl: &SampledWavelengths) -> SampledSpectrum {
    let Some(ei) = scene.environment else { return Vec4::ZERO };
    let env = &scene.lights[ei as usize];
    let le = env.le(Vec3::ZERO, -ray.d, || glam::Vec2::ZERO, wl);
    let w = if no_mis {
        1.0
    } else {
        power_heuristic(1.0, prev_pdf, 1.0, environment_light_pdf(scene, ei, prev_p, ray.d))
    };
    beta * le * w
}

/// MIS weight (power heuristic) of emission found at a surface point `q` (stored geometric
/// normal `ng`) of area light `light` by a direction sampled with density `prev_pdf` from
/// `prev_p`, against light sampling from `prev_p`.
#[inline]
pub fn area_emission_weight(scene: &Scene, light: u32, prev_p: Vec3, d: Vec3, q: Vec3, ng: Vec3, prev_pdf: f32) -> f32 {
    power_heuristic(1.0, prev_pdf, 1.0, area_light_pdf(scene, light, prev_p, d, q, ng))
}

/// Density per steradian with which next-event estimation from `prev_p` picks light `light` and
/// the direction `d` that reaches it at `q` (stored geometric normal `ng`).
#[inline]
pub fn area_light_pdf(scene: &Scene, light: u32, prev_p: Vec3, d: Vec3, q: Vec3, ng: Vec3) -> f32 {
    scene.light_pmf[light as usize] * scene.lights[light as usize].pdf_li(prev_p, d, q, ng)
}

/// Density per steradian with which next-event estimation from `p` picks the environment light
/// `ei` and the direction `d` towards it.
#[inline]
pub fn environment_light_pdf(scene: &Scene, ei: u32, p: Vec3, d: Vec3) -> f32 {
    scene.light_pmf[ei as usize] * scene.lights[ei as usize].pdf_li(p, d, Vec3::ZERO, Vec3::ZERO)
}
