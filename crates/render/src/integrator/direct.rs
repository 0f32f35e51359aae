//! `direct`: emission seen by the camera ray plus one light sample (lights chosen in proportion
//! to power, a point chosen on the light, visibility tested) at the first hit — light sampling
//! only, the tutorial's soft-shadow estimator.

use crate::integrator::nee;
use crate::interaction::Shading;
use crate::math::geometry::Ray;
use crate::math::sampling::Pcg32;
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use crate::scene::Scene;
use glam::{Vec3, Vec4};

/// Emission seen along `ray` plus one light sample at the first hit (no MIS).
pub fn li_direct(scene: &Scene, ray: Ray, wl: &SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    let Some(hit) = scene.accel.intersect(&ray) else {
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
    let bsdf = scene.materials[obj.material as usize].bsdf_with(wl, || s.uv(scene)).facing(s.ng_raw.dot(wo) > 0.0); // back face: η → 1/η
    if !bsdf.is_delta() && !bsdf.is_black() {
        l += nee::surface_light(scene, &s, wo, &bsdf, wl, rng, false);
    }
    l
}
