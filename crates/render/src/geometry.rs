//! Rays, axis-aligned boxes, spheres and the robust ray–primitive tests.
//!
//! Lengths are in the scene's unit (metres after scene loading); `t` is in units of `|d|`.
//! The ray–triangle test is the watertight algorithm of Woop, Benthin and Wald (JCGT 2013)
//! with a top-left style tie rule, so a ray through an edge or vertex shared by triangles
//! that face it the same way hits exactly one of them. The ray–sphere test computes the
//! discriminant from the distance of the centre to the ray line (as pbrt-v4 does), which
//! stays accurate when the sphere is small or far away.

use glam::Vec3;

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

/// A sphere.
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

/// Per-ray constants of the watertight ray–triangle test (Woop et al. 2013), computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct RayTri {
    /// Origin.
    pub o: Vec3,
    /// Index of the dominant direction axis (kz) and the two others (kx, ky), kx/ky swapped so
    /// the winding is preserved.
    pub k: [usize; 3],
    /// Shear constants (Sx, Sy, Sz).
    pub s: Vec3,
}

impl RayTri {
    /// Precompute the shear for `ray`.
    #[inline]
    pub fn new(ray: &Ray) -> RayTri {
        let ad = ray.d.abs();
        let kz = if ad.x >= ad.y && ad.x >= ad.z {
            0
        } else if ad.y >= ad.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        let d = ray.d.to_array();
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = d[kz];
        RayTri { o: ray.o, k: [kx, ky, kz], s: Vec3::new(d[kx] / dz, d[ky] / dz, 1.0 / dz) }
    }

    /// Sheared, translated vertex (x, y) and unscaled z.
    #[inline(always)]
    fn shear(&self, p: Vec3) -> (f32, f32, f32) {
        let a = (p - self.o).to_array();
        let az = a[self.k[2]];
        (a[self.k[0]] - self.s.x * az, a[self.k[1]] - self.s.y * az, az)
    }

    /// Watertight ray–triangle test. Returns (t, u, v) with the hit point
    /// (1−u−v)·p0 + u·p1 + v·p2, for t in (t_min, t_max).
    #[inline(always)]
    pub fn intersect(&self, p0: Vec3, p1: Vec3, p2: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let (ax, ay, az) = self.shear(p0);
        let (bx, by, bz) = self.shear(p1);
        let (cx, cy, cz) = self.shear(p2);
        // Scaled barycentrics: u_e weights p0, v_e weights p1, w_e weights p2.
        let mut e0 = cx * by - cy * bx;
        let mut e1 = ax * cy - ay * cx;
        let mut e2 = bx * ay - by * ax;
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            // Exact in f64 (products of f32 are exact), so the sign is the true one.
            e0 = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
            e1 = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
            e2 = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
        }
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 || det.is_nan() {
            return None;
        }
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            // On an edge or vertex: the edge belongs to this triangle only if it passes the tie rule.
            let sgn = if det > 0.0 { 1.0 } else { -1.0 };
            if e0 == 0.0 && !owns_edge(sgn, bx, by, cx, cy) {
                return None;
            }
            if e1 == 0.0 && !owns_edge(sgn, cx, cy, ax, ay) {
                return None;
            }
            if e2 == 0.0 && !owns_edge(sgn, ax, ay, bx, by) {
                return None;
            }
        }
        let sz = self.s.z;
        let t_scaled = sz * (e0 * az + e1 * bz + e2 * cz);
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        if !(t > t_min && t < t_max) {
            return None;
        }
        Some((t, e1 * inv_det, e2 * inv_det))
    }
}

/// Tie rule for a point exactly on the directed edge p→q (2D, sheared coordinates) of a triangle
/// whose winding sign is `sgn`: of the two triangles sharing the edge (and facing the ray the same
/// way) exactly one owns it, because they traverse it in opposite directions.
#[inline(never)]
fn owns_edge(sgn: f32, px: f32, py: f32, qx: f32, qy: f32) -> bool {
    let dx = sgn * (qx - px);
    let dy = sgn * (qy - py);
    dy > 0.0 || (dy == 0.0 && dx < 0.0)
}

/// Watertight ray–triangle test for one ray (convenience wrapper around [`RayTri`]).
pub fn intersect_triangle(ray: &Ray, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<(f32, f32, f32)> {
    RayTri::new(ray).intersect(p0, p1, p2, ray.t_min, ray.t_max)
}

/// An orthonormal basis (s, t) completing the unit vector `n` (Duff et al. 2017).
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}
