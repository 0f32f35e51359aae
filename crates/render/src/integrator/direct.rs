//! `direct`: emission seen by the camera ray plus direct lighting at the first hit, estimated as
//! Mitsuba 3's `direct` integrator does it: `emitter_samples` light samples (a light chosen in
//! proportion to power, a point on it, visibility tested) and `bsdf_samples` BSDF samples whose
//! rays are followed to the emitter they reach, combined by multi-sample MIS with the power
//! heuristic (Veach 1997, §9.2: each technique's density counted with its number of samples).
//! `bsdf_samples = 0` leaves light sampling alone, the tutorial's soft-shadow estimator; a
//! smooth (delta) surface is lit only by its BSDF samples, so a mirror shows the lights and the
//! environment it reflects. Paths end at the emitter a BSDF sample reaches: no indirect light.

pub use crate::integrator::settings::DirectSamples;
use crate::integrator::nee;
use crate::interaction::Shading;
use crate::math::geometry::Ray;
use crate::math::sampling::{power_heuristic, Pcg32};
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use crate::scene::Scene;
use glam::{Vec3, Vec4};

/// Emission seen along `ray` plus direct lighting at the first hit (see the module documentation).
/// A BSDF sample refracted through dispersive glass leaves only the hero wavelength in `wl`, as
/// the path tracer does: convert the result with `wl` as it is on return.
pub fn li_direct(scene: &Scene, ray: Ray, wl: &mut SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    let Some(hit) = scene.intersect(&ray) else {
        return match scene.environment {
            Some(ei) => scene.lights[ei as usize].le(Vec3::ZERO, -ray.d, || glam::Vec2::ZERO, wl),
            None => Vec4::ZERO,
        };
    };
    let s = Shading::at(scene, &ray, &hit);
    let wo = -ray.d;
    let obj = &scene.objects[s.object as usize];
    let mut l = Vec4::ZERO;
    if let Some(li_idx) = obj.light {
        l += scene.lights[li_idx as usize].le(s.ng_raw, wo, || s.uv(scene), wl);
    }
    let front = s.ng_raw.dot(wo) > 0.0;
    let bsdf = if scene.black_behind(obj.material, front) {
        crate::bsdf::Bsdf::Black
    } else {
        // A blend's component first; back face: η → 1/η.
        scene.materials[obj.material as usize].select(|| s.selector(wo), || s.uv(scene)).bsdf_with(wl, || s.uv(scene)).facing(front)
    };
    if bsdf.is_black() {
        return l;
    }
    let DirectSamples { emitter: n_e, bsdf: n_b } = scene.direct_samples;
    let (ne, nb) = (n_e as f32, n_b as f32);
    if !bsdf.is_delta() {
        for _ in 0..n_e {
            let Some(c) = nee::sample_light(scene, s.p, wl, rng) else { continue };
            let Some((f, wo_l, wi_l)) = nee::surface_bsdf(&s, wo, &bsdf, c.ls.wi) else { continue };
            if !s.unoccluded(scene, c.ls.wi, c.ls.dist) {
                continue;
            }
            let w = if c.ls.delta { 1.0 } else { power_heuristic(ne, c.pdf(), nb, bsdf.pdf(wo_l, wi_l)) };
            l += f * c.ls.li * (wi_l.z.abs() * w / (c.pdf() * ne));
        }
    }
    // BSDF samples can only find area lights and the environment: skip them in scenes without.
    if n_b == 0 || !scene.has_emitters_to_hit() {
        return l;
    }
    let wo_l = s.frame.to_local(wo);
    for _ in 0..n_b {
        let uc = rng.next_f32();
        let Some(bs) = bsdf.sample(wo_l, uc, rng.next_2d()) else { continue };
        let wi = s.frame.to_world(bs.wi);
        // Reject directions whose side of the geometric surface disagrees with the shading frame.
        if (wi.dot(s.ng) > 0.0) == bs.transmission || !(bs.pdf > 0.0) {
            continue;
        }
        if bs.terminate_secondary {
            wl.terminate_secondary();
        }
        let beta = bs.f * (bs.wi.z.abs() * s.terminator(wi) / (bs.pdf * nb));
        let r = s.spawn(scene, wi);
        let (le, light_pdf) = match scene.intersect(&r) {
            None => {
                let Some(ei) = scene.environment else { continue };
                (scene.lights[ei as usize].le(Vec3::ZERO, -wi, || glam::Vec2::ZERO, wl), nee::environment_light_pdf(scene, ei, s.p, wi))
            }
            Some(h2) => {
                let s2 = Shading::at(scene, &r, &h2);
                let Some(li_idx) = scene.objects[s2.object as usize].light else { continue };
                let le = scene.lights[li_idx as usize].le(s2.ng_raw, -wi, || s2.uv(scene), wl);
                (le, nee::area_light_pdf(scene, li_idx, s.p, wi, s2.p, s2.ng_raw))
            }
        };
        if le == Vec4::ZERO {
            continue;
        }
        let w = if bs.delta { 1.0 } else { power_heuristic(nb, bs.pdf, ne, light_pdf) };
        l += beta * le * w;
    }
    l
}
