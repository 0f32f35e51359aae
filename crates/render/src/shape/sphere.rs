//! The sphere primitive and its ray test.
//!
//! The discriminant is computed from the distance of the centre to the ray line (as pbrt-v4
//! does), which stays accurate when the sphere is small or far away.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a < b)` is deliberate: it is true for NaN.

use crate::math::geometry::{Aabb, Ray};
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
}

impl Sphere {
    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        Aabb { min: self.center - Vec3::splat(self.radius), max: self.center + Vec3::splat(self.radius) }
    }

    /// Smallest t in (t_min, t_max) where the ray meets the sphere.
    ///
    /// The discriminant is b² − a·c = a (r² − |f − (f·d/a) d|²) with f = o − c; the squared distance
    /// of the centre to the ray line is computed directly, avoiding the catastrophic cancellation of
    /// b² − a c. The roots use the q = −(b ± √Δ) form so neither is a difference of near-equal numbers.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<f32> {
        let f = ray.o - self.center;
        let a = ray.d.length_squared();
        if !(a > 0.0) {
            return None;
        }
        let b = f.dot(ray.d); // half of the usual b
        let perp = f - (b / a) * ray.d;
        let r2 = self.radius * self.radius;
        let disc = a * (r2 - perp.length_squared());
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let q = if b < 0.0 { -b + root } else { -b - root };
        let c = f.length_squared() - r2;
        let (mut t0, mut t1) = (q / a, c / q);
        if q == 0.0 {
            // b = 0 and disc = 0: tangent at the closest point.
            t0 = -b / a;
            t1 = t0;
        }
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        if t0 > ray.t_min && t0 < ray.t_max {
            Some(t0)
        } else if t1 > ray.t_min && t1 < ray.t_max {
            Some(t1)
        } else {
            None
        }
    }

    /// Surface area 4πr².
    pub fn area(&self) -> f32 {
        4.0 * std::f32::consts::PI * self.radius * self.radius
    }
}

/// Sphere parametrisation of the direction `d` from the centre: (azimuth about +y from +x
/// towards +z / 2π, polar angle from +y / π), each in [0, 1].
#[inline]
pub fn sphere_uv(d: Vec3) -> (f32, f32) {
    let d = d.normalize_or_zero();
    let phi = d.z.atan2(d.x);
    let phi = if phi < 0.0 { phi + 2.0 * std::f32::consts::PI } else { phi };
    (phi / (2.0 * std::f32::consts::PI), d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI)
}

/// Texture coordinates of the sphere point in direction `d` from the centre: u = φ/2π,
/// v = 1 − θ/π with θ the polar angle from +y and φ the azimuth about +y from +x towards −z
/// (counter-clockwise seen from +y), so an image wrapped round a sphere reads the right way
/// round from outside, its top row at the +y pole.
#[inline]
pub fn texture_uv(d: Vec3) -> Vec2 {
    let (u, v) = sphere_uv(d);
    Vec2::new(1.0 - u, 1.0 - v)
}
