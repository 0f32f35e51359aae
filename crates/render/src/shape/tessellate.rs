//! Disks and open cylinders as fine triangle meshes, with Mitsuba 3's texture coordinates.
//!
//! Both are built around a right-handed frame (s, t, a): a is the disk's normal or the
//! cylinder's axis (p0 → p1), (s, t) the basis of [`orthonormal_basis`] (Duff et al. 2017, the
//! basis of Mitsuba 3's `coordinate_system` and `Frame3f`), so s × t = a. The azimuth φ of a point
//! is measured from s towards t, in [0, 2π).
//!
//! * Disk (centre c, radius R): (u, v) = (ρ/R, φ/2π), ρ the distance from c, as Mitsuba 3's `disk`
//!   with `to_world = translate(c) · to_frame(Frame3f(a)) · scale(R)`. The front side (the
//!   triangles' counter-clockwise side) is the side a points to.
//! * Cylinder (p0, p1, radius r, no caps): (u, v) = (φ/2π, h/|p1 − p0|), h the distance along the
//!   axis from p0, as Mitsuba 3's `cylinder` with `p0`, `p1`, `radius`; the front side and the
//!   per-vertex shading normals (radial, unit) point outwards.
//!
//! The rim (or each ring of the cylinder) is a regular polygon of [`SEGMENTS`] sides inscribed in
//! the circle: the disk's area is (N/2π) sin(2π/N) = 1 − 2.5·10⁻⁵ of πR², the cylinder's
//! (N/π) sin(π/N) = 1 − 6.3·10⁻⁶ of 2πrh, and no point of the outline lies more than
//! 1 − cos(π/N) = 1.9·10⁻⁵ of the radius inside the circle. The seam at φ = 0 has its own
//! vertices (v = 0 and v = 1 on the disk, u = 0 and u = 1 on the cylinder) at the same positions,
//! so the mesh stays watertight. The triangles are kept compact (their long side at most about
//! [`ASPECT`] times their short one, the disk's rings halving their segment counts towards the
//! centre), so that their bounding boxes overlap little whatever the shape's orientation.

use crate::math::geometry::orthonormal_basis;
use crate::shape::mesh::TriangleMesh;
use glam::{DVec3, Vec2};
use std::f64::consts::TAU;

/// Segments of the rim of a disk and of each ring of a cylinder.
pub const SEGMENTS: usize = 512;

/// Largest ratio of a triangle's radial (disk) or axial (cylinder) extent to the rim segment's
/// length.
pub const ASPECT: f64 = 16.0;

/// Most rings along a cylinder's axis (a long thin cylinder gets longer triangles).
pub const MAX_CYLINDER_RINGS: usize = 128;

fn frame(a: DVec3) -> (DVec3, DVec3) {
    let (s, _) = orthonormal_basis(a.as_vec3());
    // Re-orthonormalise in f64 so that the vertices do not inherit f32 rounding of the basis.
    let s = s.as_dvec3();
    let s = (s - a * a.dot(s)).normalize();
    (s, a.cross(s))
}

/// The rings of a disk of radius 1, from the rim inwards: (radius, segments). Each ring is
/// [`ASPECT`] times its segment length inside the one before; the segment count halves when the
/// segments would become shorter than half of the rim's. The last ring is the outline of the
/// central fan.
fn disk_rings() -> Vec<(f64, usize)> {
    let rim_arc = TAU / SEGMENTS as f64;
    let mut rings = vec![(1.0f64, SEGMENTS)];
    loop {
        let (rho, n) = *rings.last().unwrap();
        let width = ASPECT * TAU * rho / n as f64;
        let next = rho - width;
        // Stop where what is left is less than one and a half rings: the fan covers it.
        if next < 0.5 * width || n < 8 {
            return rings;
        }
        let n_next = if TAU * next / (n as f64) < 0.5 * rim_arc { n / 2 } else { n };
        rings.push((next, n_next));
    }
}

/// A flat disk (see the module's documentation), f64 arithmetic rounded to f32 vertices.
/// `normal` need not be unit but must be non-zero; `radius` must be positive.
pub fn disk(center: DVec3, normal: DVec3, radius: f64) -> TriangleMesh {
    let a = normal.normalize();
    let (s, t) = frame(a);
    let rings = disk_rings();
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let mut first = Vec::with_capacity(rings.len());
    for &(rho, n) in &rings {
        first.push(positions.len() as u32);
        for k in 0..=n {
            let phi = TAU * (k % n) as f64 / n as f64;
            let p = center + radius * rho * (phi.cos() * s + phi.sin() * t);
            positions.push(p.as_vec3());
            uvs.push(Vec2::new(rho as f32, (k as f64 / n as f64) as f32));
        }
    }
    let mut indices = Vec::new();
    for w in 0..rings.len() - 1 {
        let (o, i) = (first[w], first[w + 1]);
        let (no, ni) = (rings[w].1 as u32, rings[w + 1].1 as u32);
        if ni == no {
            for k in 0..no {
                indices.push([i + k, o + k, o + k + 1]);
                indices.push([i + k, o + k + 1, i + k + 1]);
            }
        } else {
            for j in 0..ni {
                indices.push([i + j, o + 2 * j, o + 2 * j + 1]);
                indices.push([i + j, o + 2 * j + 1, i + j + 1]);
                indices.push([i + j + 1, o + 2 * j + 1, o + 2 * j + 2]);
            }
        }
    }
    // The central fan: one centre vertex per triangle, with v at the middle of its segment.
    let (last, n) = (*first.last().unwrap(), rings.last().unwrap().1 as u32);
    for k in 0..n {
        let c = positions.len() as u32;
        positions.push(center.as_vec3());
        uvs.push(Vec2::new(0.0, ((k as f64 + 0.5) / n as f64) as f32));
        indices.push([c, last + k, last + k + 1]);
    }
    TriangleMesh { positions, normals: None, uvs: Some(uvs), indices }
}

/// Rings along the axis of a cylinder of the given length and radius (at least 1).
fn cylinder_rings(length: f64, radius: f64) -> usize {
    let arc = TAU * radius / SEGMENTS as f64;
    let m = (length / (ASPECT * arc)).ceil();
    if m.is_finite() {
        (m as usize).clamp(1, MAX_CYLINDER_RINGS)
    } else {
        MAX_CYLINDER_RINGS
    }
}

/// An open tube from `p0` to `p1` (see the module's documentation), f64 arithmetic rounded to f32
/// vertices. `p0` and `p1` must differ; `radius` must be positive.
pub fn cylinder(p0: DVec3, p1: DVec3, radius: f64) -> TriangleMesh {
    let d = p1 - p0;
    let length = d.length();
    let a = d / length;
    let (s, t) = frame(a);
    let rings = cylinder_rings(length, radius);
    let n = SEGMENTS as u32;
    let mut positions = Vec::with_capacity((rings + 1) * (SEGMENTS + 1));
    let mut normals = Vec::with_capacity(positions.capacity());
    let mut uvs = Vec::with_capacity(positions.capacity());
    for j in 0..=rings {
        let h = j as f64 / rings as f64;
        let base = if j == rings { p1 } else { p0 + h * d };
        for k in 0..=SEGMENTS {
            let phi = TAU * (k % SEGMENTS) as f64 / SEGMENTS as f64;
            let e = phi.cos() * s + phi.sin() * t;
            positions.push((base + radius * e).as_vec3());
            normals.push(e.as_vec3());
            uvs.push(Vec2::new((k as f64 / SEGMENTS as f64) as f32, h as f32));
        }
    }
    let mut indices = Vec::with_capacity(2 * rings * SEGMENTS);
    for j in 0..rings as u32 {
        let (lo, hi) = (j * (n + 1), (j + 1) * (n + 1));
        for k in 0..n {
            // (A, B, C), (A, C, D) with A, B on the lower ring: counter-clockwise seen from outside.
            indices.push([lo + k, lo + k + 1, hi + k + 1]);
            indices.push([lo + k, hi + k + 1, hi + k]);
        }
    }
    TriangleMesh { positions, normals: Some(normals), uvs: Some(uvs), indices }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn area64(m: &TriangleMesh) -> f64 {
        m.indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    #[test]
    fn disk_area_is_that_of_the_inscribed_polygon() {
        let r = 0.37;
        let m = disk(DVec3::new(1.0, -2.0, 0.5), DVec3::new(0.3, 0.5, 0.8), r);
        m.validate().unwrap();
        let n = SEGMENTS as f64;
        let polygon = 0.5 * n * (TAU / n).sin() * r * r;
        let exact = PI * r * r;
        assert!((area64(&m) / polygon - 1.0).abs() < 1e-5, "{} vs {polygon}", area64(&m));
        assert!((area64(&m) / exact - 1.0).abs() < 1e-4);
        // Every triangle faces the normal's side.
        let a = DVec3::new(0.3, 0.5, 0.8).normalize();
        for i in 0..m.indices.len() {
            let [p, q, w] = m.triangle(i).map(|v| v.as_dvec3());
            assert!((q - p).cross(w - p).normalize().dot(a) > 0.999, "triangle {i}");
        }
        assert!(m.indices.len() < 20_000, "{} triangles", m.indices.len());
    }

    #[test]
    fn cylinder_area_and_outward_normals() {
        let (p0, p1, r) = (DVec3::new(0.2, 0.0, -1.0), DVec3::new(1.0, 2.0, 0.5), 0.25);
        let m = cylinder(p0, p1, r);
        m.validate().unwrap();
        let h = (p1 - p0).length();
        let n = SEGMENTS as f64;
        let prism = n * 2.0 * (PI / n).sin() * r * h;
        assert!((area64(&m) / prism - 1.0).abs() < 1e-5);
        assert!((area64(&m) / (2.0 * PI * r * h) - 1.0).abs() < 1e-4);
        let a = (p1 - p0) / h;
        let ns = m.normals.as_ref().unwrap();
        for (i, p) in m.positions.iter().enumerate() {
            let q = p.as_dvec3() - p0;
            let radial = q - a * a.dot(q);
            assert!((radial.length() / r - 1.0).abs() < 1e-5);
            assert!((ns[i].as_dvec3() - radial / r).length() < 1e-5);
        }
    }

    #[test]
    fn disk_rings_shrink_to_a_fan() {
        let rings = disk_rings();
        assert_eq!(rings[0], (1.0, SEGMENTS));
        for w in rings.windows(2) {
            assert!(w[1].0 < w[0].0 && (w[1].1 == w[0].1 || 2 * w[1].1 == w[0].1), "{w:?}");
        }
        let (rho, n) = *rings.last().unwrap();
        assert!(rho > 0.0 && n >= 8, "{rho} {n}");
    }
}
