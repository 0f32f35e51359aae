//! A ray's hit turned into a shading point, and the rules for leaving it: where a new ray starts
//! (offset off the surface on the side it leaves to) and how long a shadow ray towards a light
//! sample is. Every integrator uses these, so every integrator agrees on them.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::accel::Hit;
use crate::math::geometry::Ray;
use crate::math::sampling::Frame;
use crate::scene::Scene;
use glam::Vec3;

/// Geometry of a shading point, oriented towards the viewer.
#[derive(Clone, Copy, Debug)]
pub struct Shading {
    /// Position (m).
    pub p: Vec3,
    /// Geometric normal on the side of wo.
    pub ng: Vec3,
    /// Frame of the shading normal on the side of wo (the geometric normal where the
    /// interpolated one points below the surface).
    pub frame: Frame,
    /// Index of the object hit.
    pub object: u32,
    /// Geometric normal as stored (for the side an area light emits to, and the side of a
    /// closed object the ray arrives from).
    pub ng_raw: Vec3,
    /// Primitive index of the hit within its object.
    pub prim: u32,
    /// The hit's barycentric coordinates (sphere: its angular parameters), from which
    /// [`Shading::uv`] computes texture coordinates where a texture needs them.
    pub bary: glam::Vec2,
}

impl Shading {
    /// The shading point of `hit` along `ray`.
    #[inline(always)]
    pub fn at(scene: &Scene, ray: &Ray, hit: &Hit) -> Shading {
        let sp = scene.accel.surface_point(ray, hit);
        let flip = sp.ng.dot(ray.d) > 0.0;
        let ng = if flip { -sp.ng } else { sp.ng };
        let mut ns = if flip { -sp.ns } else { sp.ns };
        if !(ns.dot(ng) > 0.0) || !ns.is_finite() {
            ns = ng;
        }
        Shading { p: sp.p, ng, frame: Frame::from_normal(ns), object: sp.object, ng_raw: sp.ng, prim: hit.prim, bary: glam::Vec2::new(hit.u, hit.v) }
    }

    /// Texture coordinates of this point ([`crate::accel::Accel::uv`]); computed on demand, so
    /// untextured surfaces never pay for them.
    #[inline]
    pub fn uv(&self, scene: &Scene) -> glam::Vec2 {
        scene.accel.uv(self.object, self.prim, self.bary.x, self.bary.y)
    }

    /// Ray leaving this point in direction `d` (unit), offset off the surface on the side of `d`.
    #[inline]
    pub fn spawn(&self, scene: &Scene, d: Vec3) -> Ray {
        Ray { o: offset_origin(self.p, self.ng, d, scene.ray_epsilon_m), d, t_min: 0.0, t_max: f32::INFINITY }
    }

    /// Whether nothing blocks the shadow ray from this point towards direction `d` up to a light
    /// sample `dist` away ([`shadow_t_max`]).
    #[inline]
    pub fn unoccluded(&self, scene: &Scene, d: Vec3, dist: f32) -> bool {
        let mut r = self.spawn(scene, d);
        r.t_max = shadow_t_max(dist, scene.ray_epsilon_m, true);
        if !(r.t_max > 0.0) {
            return true;
        }
        !scene.accel.occluded(&r)
    }
}

/// Origin of a ray leaving surface point `p` (geometric normal `ng`) in direction `d`: moved by
/// `eps` (m) along the normal, on the side of `d`.
#[inline]
pub fn offset_origin(p: Vec3, ng: Vec3, d: Vec3, eps: f32) -> Vec3 {
    let off = if d.dot(ng) >= 0.0 { ng } else { -ng };
    p + off * eps
}

/// Length (m) of a shadow ray towards a light sample `dist` away (infinite for lights at
/// infinity): short of the light by a relative 10⁻⁴ and by the spawn offset `eps` at the light
/// and, when the ray was offset off a surface (`from_surface`), at its origin too. A result ≤ 0
/// means the light is closer than the offsets: nothing can block it.
#[inline]
pub fn shadow_t_max(dist: f32, eps: f32, from_surface: bool) -> f32 {
    if !dist.is_finite() {
        return f32::INFINITY;
    }
    let ends = if from_surface { 2.0 } else { 1.0 };
    dist * (1.0 - 1e-4) - ends * eps
}
