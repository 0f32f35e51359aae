//! Rays, axis-aligned boxes, rounding-error bounds and orthonormal bases.
//!
//! Lengths are in the scene's unit (metres after scene loading); `t` is in units of `|d|`.
//! The primitives' ray tests are in [`crate::shape`].

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a < b)` is deliberate: it is true for NaN.

use glam::{DVec3, Vec3};

/// A ray r(t) = o + t d, valid for t in the open interval (t_min, t_max).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction (need not be unit length; t is measured in units of |d|).
    pub d: Vec3,
    /// Hits must have t > t_min.
    pub t_min: f32,
    /// Hits must have t < t_max.
    pub t_max: f32,
}

impl Ray {
    /// A ray with t in (0, ∞).
    pub fn new(o: Vec3, d: Vec3) -> Ray {
        Ray { o, d, t_min: 0.0, t_max: f32::INFINITY }
    }

    /// A ray with the given t interval.
    pub fn with_bounds(o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Ray {
        Ray { o, d, t_min, t_max }
    }

    /// The point o + t d.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// An axis-aligned bounding box; empty when any min > max.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::EMPTY
    }
}

impl Aabb {
    /// The empty box (min = +∞, max = −∞), the identity of `union`.
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// The box spanned by two corners (in any order).
    pub fn new(a: Vec3, b: Vec3) -> Aabb {
        Aabb { min: a.min(b), max: a.max(b) }
    }

    /// The smallest box holding all the points.
    pub fn from_points(points: &[Vec3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, &p| b.grow(p))
    }

    /// True when the box holds no point.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// The box extended to hold `p`.
    #[inline]
    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }

    /// The smallest box holding both.
    #[inline]
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// max − min (negative for the empty box).
    #[inline]
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Centre point.
    #[inline]
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Surface area (0 for the empty box).
    #[inline]
    pub fn surface_area(&self) -> f32 {
        let e = self.extent();
        if e.x < 0.0 || e.y < 0.0 || e.z < 0.0 {
            return 0.0;
        }
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Index (0, 1, 2) of the longest axis.
    pub fn longest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// True when `p` is inside or on the boundary.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The parametric interval (t0, t1) of the ray inside the box, clipped to the ray's
    /// bounds, or None. Conservative: rounding is compensated as in pbrt (1 + 2γ₃).
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (ray.t_min, ray.t_max);
        for a in 0..3 {
            if ray.d[a] == 0.0 {
                // Parallel to the slab: inside it (boundary included) or never.
                if ray.o[a] < self.min[a] || ray.o[a] > self.max[a] || ray.o[a].is_nan() {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / ray.d[a];
            let ta = (self.min[a] - ray.o[a]) * inv;
            let tb = (self.max[a] - ray.o[a]) * inv;
            let (near, far) = (ta.min(tb), ta.max(tb) * (1.0 + 2.0 * gamma(3)));
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        if t0 <= t1 {
            Some((t0, t1))
        } else {
            None
        }
    }
}

/// γ_n = n ε / (1 − n ε), the bound on relative rounding error of n operations (pbrt).
#[inline]
pub fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}


/// An orthonormal basis (s, t) completing the unit vector `n` (Duff et al. 2017).
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// The point of triangle (a, b, c) closest to `p` (Ericson, *Real-Time Collision Detection*,
/// §5.1.5: the Voronoi regions of the vertices, then of the edges, else the face). A
/// zero-area triangle gives the nearest of its vertices.
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    if !denom.is_finite() {
        return [a, b, c].into_iter().min_by(|x, y| (*x - p).length_squared().total_cmp(&(*y - p).length_squared())).unwrap_or(a);
    }
    a + ab * (vb * denom) + ac * (vc * denom)
}
