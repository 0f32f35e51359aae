//! The watertight ray–triangle test of Woop, Benthin and Wald (JCGT 2013) with a top-left style
//! tie rule, so a ray through an edge or vertex shared by triangles that face it the same way hits
//! exactly one of them.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a < b)` is deliberate: it is true for NaN.

use crate::math::geometry::Ray;
use glam::Vec3;

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
