//! The scene: camera, geometry with its acceleration structure, materials, lights and media, and
//! the queries integrators make of it (light choice by power, lights at infinity capped). Scenes are made by [`crate::load`].

use crate::accel::Accel;
use crate::camera::Camera;
use crate::integrator::settings::IntegratorSettings;
use crate::light::Light;
use crate::material::Material;
use crate::math::hash::Fnv1a64;

/// What the renderer knows about one scene object (parallel to the shapes in the accelerator).
#[derive(Clone, Debug)]
pub struct ObjectInfo {
    /// Name from the scene file (or generated).
    pub name: String,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Index into [`Scene::lights`] when the object is an area light.
    pub light: Option<u32>,
    /// Index into [`Scene::media`] of the medium inside this (closed) object, if it bounds one.
    pub interior_medium: Option<u32>,
}

/// Everything a render needs: camera, geometry with its acceleration structure, materials, lights.
pub struct Scene {
    /// The pinhole camera (its resolution is the render's).
    pub camera: Camera,
    /// Geometry: one shape per object, BVH over all of them.
    pub accel: Accel,
    /// Per-object material and light links, indexed like the accelerator's shapes.
    pub objects: Vec<ObjectInfo>,
    /// Materials, indexed by [`ObjectInfo::material`].
    pub materials: Vec<Material>,
    /// Material names, parallel to `materials`.
    pub material_names: Vec<String>,
    /// Per material, whether it reflects from its front side only (`two_sided = false`, Mitsuba 3's
    /// plain BSDFs): a hit on its back face sees a black surface ([`Scene::black_behind`]).
    pub one_sided: Vec<bool>,
    /// Per material, how the shading frame is made ([`crate::interaction::Shading::at`]): the
    /// normal alone (empty or `None`), or with its tangent along ∂p/∂u and possibly a normal or
    /// bump map.
    pub surface_frames: Vec<Option<SurfaceFrame>>,
    /// Per material, its opacity where it is a mask (Mitsuba 3's `mask`; empty when no material
    /// is): a ray passes a masked surface with probability 1 − opacity ([`Scene::intersect`]).
    pub opacity: Vec<Option<crate::texture::FloatTexture>>,
    /// All lights.
    pub lights: Vec<Light>,
    /// Probability of choosing each light for next-event estimation ([`crate::light::selection_pmf`]: by power, lights at infinity capped).
    pub light_pmf: Vec<f32>,
    /// Cumulative of `light_pmf`.
    pub light_cdf: Vec<f32>,
    /// Index of the environment light, if any (rays that escape see it).
    pub environment: Option<u32>,
    /// Homogeneous participating media (object interiors and the global medium).
    pub media: Vec<crate::medium::Medium>,
    /// Per medium, the free-flight distance bounds over its bounding objects (`volpath` skips ray
    /// casts for collisions closer than them); `None` for the global medium and pure absorbers.
    pub medium_grids: Vec<Option<crate::medium::FreeFlightGrid>>,
    /// Area lights as `volpath` aims at them through a smooth dielectric boundary from inside a
    /// medium ([`crate::light::refracted`]); `None` when off or when no light qualifies.
    pub refracted_lights: Option<crate::light::refracted::RefractedLights>,
    /// Index into `media` of the medium filling space outside every medium-bounding object
    /// (the camera's medium), if any.
    pub global_medium: Option<u32>,
    /// Integrator settings given in the scene file (defaults: path, 8, 5).
    pub integrator: IntegratorSettings,
    /// Ambient-occlusion ray length in metres (infinite by default).
    pub ao_distance_m: f32,
    /// Light and BSDF samples per camera sample of the `direct` integrator.
    pub direct_samples: crate::integrator::settings::DirectSamples,
    /// Whether any light is an area light, set on loading (with the environment, the emitters a
    /// ray can hit; point, spot, directional and projector lights are only found by light
    /// sampling). Code that replaces `lights` may leave it true: it only lets `direct` skip work.
    pub has_area_lights: bool,
    /// Offset (m) for spawning rays off surfaces, relative to the scene's size.
    pub ray_epsilon_m: f32,
    /// Metres per scene length unit.
    pub unit_m: f64,
    /// Where the scene came from (file name or "built-in Cornell box").
    pub source: String,
    /// Hash of the scene text and every file it read (see [`Scene::content_hash`]).
    pub(crate) content_hash: u64,
}

/// The salt of the masks' hash, apart from the blends' (whose choice it must not correlate with).
const MASK_SALT: u64 = 0x6d61_736b;

/// A shading frame tied to the surface's texture coordinates (Mitsuba 3's shading frame): its
/// first tangent along ∂p/∂u made orthogonal to the normal, so that an anisotropic roughness's
/// α_x lies along u; with a normal or bump map, about the perturbed normal.
#[derive(Clone, Debug)]
pub struct SurfaceFrame {
    /// The map that tilts the normal, if any.
    pub map: Option<std::sync::Arc<crate::texture::shading_map::ShadingMap>>,
    /// With a map: the BSDF carries Estevez et al.'s shadowing term
    /// ([`crate::interaction::Shading::terminator`]; Mitsuba 3's `use_shadowing_function`).
    pub shadowing: bool,
    /// With a map: a tilted normal facing away from the viewer has its tangential part mirrored
    /// (Mitsuba 3's `flip_invalid_normals`).
    pub flip_invalid: bool,
}

impl Scene {
    /// The closest hit along `ray` (as [`Accel::intersect`]) that is not passed through: a hit on
    /// a masked material ([`Scene::opacity`]) stops the ray with probability opacity(uv), decided
    /// by a hash of the hit point and the ray's direction (pbrt-v4's stochastic alpha test), so
    /// that shadow rays, camera rays and BSDF samples all see one surface with the same
    /// expected visibility 1 − opacity; the ray then goes on from just past it.
    #[inline]
    pub fn intersect(&self, ray: &crate::math::geometry::Ray) -> Option<crate::accel::Hit> {
        let hit = self.accel.intersect(ray)?;
        if self.opacity.is_empty() {
            return Some(hit);
        }
        self.through_masks(ray, hit)
    }

    /// Whether anything stops `ray` before `t_max` ([`Accel::occluded`], masks passed as in
    /// [`Scene::intersect`]).
    #[inline]
    pub fn occluded(&self, ray: &crate::math::geometry::Ray) -> bool {
        if self.opacity.is_empty() {
            self.accel.occluded(ray)
        } else {
            self.intersect(ray).is_some()
        }
    }

    /// [`Scene::intersect`] after the first hit `hit`, for scenes with masks.
    #[cold]
    #[inline(never)]
    fn through_masks(&self, ray: &crate::math::geometry::Ray, mut hit: crate::accel::Hit) -> Option<crate::accel::Hit> {
        let mut r = *ray;
        for _ in 0..256 {
            let material = self.objects[hit.object as usize].material as usize;
            let Some(Some(opacity)) = self.opacity.get(material) else { return Some(hit) };
            let alpha = opacity.eval_with(|| self.accel.uv(hit.object, hit.prim, hit.u, hit.v));
            if crate::math::hash::hash_unit(r.at(hit.t), r.d, MASK_SALT) < alpha {
                return Some(hit);
            }
            // Passed: on from just beyond the surface.
            r.t_min = hit.t + self.ray_epsilon_m;
            hit = self.accel.intersect(&r)?;
        }
        Some(hit)
    }

    /// Whether a hit on material `material` from its back (`front` false) sees black: the
    /// material is one-sided ([`Scene::one_sided`]).
    #[inline]
    pub fn black_behind(&self, material: u32, front: bool) -> bool {
        !front && self.one_sided.get(material as usize).copied().unwrap_or(false)
    }

    /// Override the camera resolution in pixels.
    pub fn set_resolution(&mut self, width: u32, height: u32) {
        self.camera.set_resolution(width, height);
    }

    /// Camera resolution (width, height) in pixels.
    pub fn resolution(&self) -> (u32, u32) {
        (self.camera.width, self.camera.height)
    }

    /// The free-flight grid of `medium` (see [`Scene::medium_grids`]), if it has one.
    #[inline]
    pub fn medium_grid(&self, medium: Option<u32>) -> Option<&crate::medium::FreeFlightGrid> {
        medium.and_then(|m| self.medium_grids.get(m as usize)).and_then(|g| g.as_ref())
    }

    /// 64-bit hash (FNV-1a) of the scene's content (scene text, every file it reads) and resolution,
    /// for refusing checkpoints of another scene.
    pub fn content_hash(&self) -> u64 {
        let mut h = Fnv1a64::new();
        h.write(&self.content_hash.to_le_bytes());
        h.write(&self.camera.width.to_le_bytes());
        h.write(&self.camera.height.to_le_bytes());
        h.finish()
    }

    /// Whether a BSDF-sampled ray can reach emission: the scene has an environment now, or had an
    /// area light when it was loaded ([`Scene::has_area_lights`]).
    #[inline]
    pub fn has_emitters_to_hit(&self) -> bool {
        self.environment.is_some() || self.has_area_lights
    }

    /// Index of the light chosen for next-event estimation with uniform `u`, and its probability.
    #[inline]
    pub fn pick_light(&self, u: f32) -> Option<(usize, f32)> {
        match self.lights.len() {
            0 => return None,
            1 => return Some((0, 1.0)),
            _ => {}
        }
        let (i, _) = crate::math::sampling::sample_cdf(&self.light_cdf, u);
        Some((i, self.light_pmf[i]))
    }
}
