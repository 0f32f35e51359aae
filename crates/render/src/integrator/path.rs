//! `path`: unidirectional path tracing; at every vertex one light sample and one BSDF sample,
//! combined by multiple importance sampling with the power heuristic (Veach 1997).
//!
//! Russian roulette starts once a path has `rr_depth` segments: the path continues with
//! probability q = min(max throughput, 0.95) and its throughput is divided by q. Translucent
//! materials are their dielectric boundary, their boundary's reflection only (paths traced from
//! a point cloud) or that reflection plus the pass's BSSRDF term ([`SubsurfaceMode`]).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::integrator::nee;
use crate::integrator::settings::IntegratorSettings;
use crate::integrator::subsurface::{SubsurfaceMode, SubsurfacePass};
use crate::interaction::Shading;
use crate::math::geometry::Ray;
use crate::math::sampling::Pcg32;
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use crate::scene::Scene;
use glam::Vec4;

/// This pass's subsurface state (the point clouds of the translucent objects, their light traced
/// by this path tracer), or `None` when the scene has no translucent object.
pub fn subsurface_pass(scene: &Scene, settings: &IntegratorSettings, seed: u64, pass: u64) -> Option<SubsurfacePass> {
    SubsurfacePass::build(scene, seed, pass, &|ray, wl, rng, mode, first_pdf| li_path_mode(scene, settings, ray, wl, rng, mode, first_pdf))
}

/// This pass's subsurface states, one per wavelength set ([`SubsurfacePass::wavelength_sets`];
/// empty when the scene has no translucent object). Pixels choose one with
/// [`SubsurfacePass::set_of_pixel`].
pub fn subsurface_passes(scene: &Scene, settings: &IntegratorSettings, seed: u64, pass: u64) -> Vec<SubsurfacePass> {
    let sets = SubsurfacePass::wavelength_sets(scene);
    (0..sets)
        .filter_map(|k| SubsurfacePass::build_set(scene, seed, pass, k, sets, &|ray, wl, rng, mode, first_pdf| li_path_mode(scene, settings, ray, wl, rng, mode, first_pdf)))
        .collect()
}

/// Radiance along `ray` by path tracing with NEE, MIS and Russian roulette.
/// `wl` may lose its secondary wavelengths on the way (dispersion): convert the result with the
/// `wl` as it is on return.
pub fn li_path(scene: &Scene, settings: &IntegratorSettings, ray: Ray, wl: &mut SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    li_path_mode(scene, settings, ray, wl, rng, SubsurfaceMode::Dielectric, 0.0)
}

/// [`li_path`] with a choice of how translucent materials are treated (see [`SubsurfaceMode`]).
/// `first_pdf` > 0: `ray` was sampled with this density per steradian from a point that also
/// sampled the lights, so emission found by the first segment is MIS-weighted against light
/// sampling (power heuristic); 0: no MIS on the first segment (camera rays).
pub fn li_path_mode(scene: &Scene, settings: &IntegratorSettings, mut ray: Ray, wl: &mut SampledWavelengths, rng: &mut Pcg32, sss: SubsurfaceMode, first_pdf: f32) -> SampledSpectrum {
    let mut l = Vec4::ZERO;
    let mut beta = Vec4::ONE;
    let mut depth = 0u32; // segments traced so far
    let mut prev_pdf = first_pdf; // BSDF density of the last direction (per sr)
    let mut prev_delta = !(first_pdf > 0.0); // camera ray or specular bounce: no MIS on emission
    let mut prev_p = ray.o;
    // Product of the squared relative indices refracted through: roulette leaves out the 1/η²
    // radiance scaling that `beta` carries (pbrt-v4's etaScale, Mitsuba 3's η²).
    let mut eta_scale = 1.0f32;
    loop {
        let hit = scene.intersect(&ray);
        depth += 1;
        let Some(hit) = hit else {
            l += nee::environment_emission(scene, &ray, beta, prev_p, prev_pdf, prev_delta, wl);
            break;
        };
        let s = Shading::at(scene, &ray, &hit);
        let wo = -ray.d;
        let obj = &scene.objects[s.object as usize];
        if let Some(li_idx) = obj.light {
            let light = &scene.lights[li_idx as usize];
            let le = light.le(s.ng_raw, wo, || s.uv(scene), wl);
            if le != Vec4::ZERO {
                let w = if prev_delta {
                    1.0
                } else {
                    nee::area_emission_weight(scene, li_idx, prev_p, ray.d, s.p, s.ng_raw, prev_pdf)
                };
                l += beta * le * w;
            }
        }
        if depth >= settings.max_depth {
            break;
        }
        let mat = scene.materials[obj.material as usize].select(|| s.selector(wo), || s.uv(scene));
        let bsdf = match (mat.as_translucent(), sss) {
            // Translucent with a BSSRDF: the boundary's surface reflection (mirror, or the rough
            // dielectric's reflection lobe), plus the diffusive term.
            (Some(t), SubsurfaceMode::ReflectOnly | SubsurfaceMode::Bssrdf(_)) => {
                if let SubsurfaceMode::Bssrdf(p) = sss {
                    l += beta * p.radiance(s.object, s.p, s.ng, wo, rng);
                }
                t.boundary_reflection()
            }
            // Back face: η → 1/η; dispersion: hero only.
            (Some(_), SubsurfaceMode::Dielectric) | (None, _) => {
                let front = s.ng_raw.dot(wo) > 0.0;
                if scene.black_behind(obj.material, front) {
                    crate::bsdf::Bsdf::Black
                } else {
                    mat.bsdf_at(wl, front, || s.uv(scene))
                }
            }
        };
        if bsdf.is_black() {
            break;
        }
        if !bsdf.is_delta() {
            l += beta * nee::surface_light(scene, &s, wo, &bsdf, wl, rng, true);
        }
        let wo_l = s.frame.to_local(wo);
        let uc = rng.next_f32();
        let Some(bs) = bsdf.sample(wo_l, uc, rng.next_2d()) else { break };
        let wi = s.frame.to_world(bs.wi);
        // Reject directions whose side of the geometric surface disagrees with the shading frame.
        if (wi.dot(s.ng) > 0.0) == bs.transmission {
            break;
        }
        beta *= bs.f * (bs.wi.z.abs() * s.terminator(wi) / bs.pdf);
        if bs.transmission {
            eta_scale *= bs.eta * bs.eta;
        }
        if bs.terminate_secondary {
            wl.terminate_secondary();
        }
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        prev_p = s.p;
        ray = s.spawn(scene, wi);
        if depth >= settings.rr_depth {
            let q = (beta.max_element() * eta_scale).min(0.95);
            if !(rng.next_f32() < q) {
                break;
            }
            beta /= q;
        }
    }
    l
}

