//! A ray's hit turned into a shading point, and the rules for leaving it: where a new ray starts
//! (offset off the surface on the side it leaves to) and how long a shadow ray towards a light
//! sample is. Every integrator uses these, so every integrator agrees on them.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::accel::Hit;
use crate::math::geometry::Ray;
use crate::math::sampling::Frame;
use crate::scene::{Scene, SurfaceFrame};
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
    /// With a normal or bump map and its shadowing term: the unperturbed shading normal (on the
    /// side of wo) and α² of the term ([`Shading::terminator`]); α² = 0 without.
    pub shadow: (Vec3, f32),
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
        let mut s = Shading {
            p: sp.p,
            ng,
            frame: Frame::from_normal(ns),
            object: sp.object,
            ng_raw: sp.ng,
            prim: hit.prim,
            bary: glam::Vec2::new(hit.u, hit.v),
            shadow: (Vec3::ZERO, 0.0),
        };
        if !scene.surface_frames.is_empty() {
            let material = scene.objects[sp.object as usize].material as usize;
            if let Some(Some(f)) = scene.surface_frames.get(material) {
                Self::surface_frame(scene, f, &mut s, flip, -ray.d);
            }
        }
        s
    }

    /// The factor on the BSDF towards the light direction `wi` (world, unit) that a normal or bump
    /// map's shadowing term puts on it: Estevez et al. 2019 ("A microfacet-based shadowing
    /// function to solve the bump terminator problem", Ray Tracing Gems ch. 12), as Mitsuba 3's
    /// `normalmap` and `bumpmap` apply it by default: G = 2 / (1 + √(1 + α² tan² θ)), θ the angle
    /// of `wi` from the unperturbed shading normal, α² = min(tan² θ_p / 8, 1) with θ_p the tilt
    /// of the perturbed normal. 1 without a map.
    #[inline]
    pub fn terminator(&self, wi: Vec3) -> f32 {
        if self.shadow.1 == 0.0 {
            return 1.0;
        }
        let c2 = wi.dot(self.shadow.0).powi(2);
        if !(c2 > 0.0) {
            return 0.0;
        }
        let tan2 = ((1.0 - c2) / c2).max(0.0);
        2.0 / (1.0 + (1.0 + self.shadow.1 * tan2).sqrt())
    }

    /// The shading frame of a material with a [`SurfaceFrame`] (into `s.frame`, and its shadowing
    /// term into `s.shadow`): first tangent along ∂p/∂u, about the normal tilted by its map, if it
    /// has one (computed on the surface's stored side and turned with the hit's side, as the plain
    /// shading normal is). A tilted normal that faces away from `wo` has its tangential part
    /// mirrored first (`flip_invalid`, Mitsuba 3's `flip_invalid_normals`, after Schüssler et al.
    /// 2017). The plain frame where the surface has no ∂p/∂u or the tilted normal still falls
    /// below the geometric surface.
    #[cold]
    #[inline(never)]
    fn surface_frame(scene: &Scene, f: &SurfaceFrame, s: &mut Shading, flip: bool, wo: Vec3) {
        let Some((dpdu, dpdv)) = scene.accel.position_derivatives(s.object, s.prim, s.bary.x, s.bary.y) else { return };
        let sign = if flip { -1.0 } else { 1.0 };
        let n0 = s.frame.n;
        let mut n = n0;
        if let Some(map) = &f.map {
            // On the stored side (where the map's tangent space is defined), then turned.
            let mut nm = map.perturb(s.uv(scene), sign * n0, dpdu, dpdv, sign * s.ng) * sign;
            if f.flip_invalid && !(nm.dot(wo) > 0.0) {
                nm = 2.0 * nm.dot(n0) * n0 - nm;
            }
            if !(nm.dot(s.ng) > 0.0) {
                return;
            }
            n = nm;
            if f.shadowing {
                let c2 = nm.dot(n0).powi(2).max(1e-12);
                let alpha2 = (0.125 * (1.0 - c2) / c2).min(1.0);
                if alpha2 > 0.0 {
                    s.shadow = (n0, alpha2);
                }
            }
        }
        let t0 = (dpdu - n * n.dot(dpdu)).normalize_or_zero();
        s.frame = if t0 == Vec3::ZERO || !t0.is_finite() { Frame::from_normal(n) } else { Frame { s: t0, t: n.cross(t0), n } };
    }

    /// A number in [0, 1) fixed by this point and the direction `wo` it is seen from, that
    /// chooses a blend material's component ([`crate::material::Material::select`]) without
    /// drawing from the path's random numbers (pbrt-v4 hashes the point and wo for its
    /// `MixMaterial`): the bits of both through SplitMix64's finaliser.
    #[inline]
    pub fn selector(&self, wo: Vec3) -> f32 {
        crate::math::hash::hash_unit(self.p, wo, 0)
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
        !scene.occluded(&r)
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
