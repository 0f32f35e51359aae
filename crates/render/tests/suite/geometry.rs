//! Ray–primitive tests: closed forms, exact edge/vertex ownership, t bounds, robustness.

use glam::Vec3;
use render::math::geometry::{Aabb, Ray};
use render::shape::sphere::Sphere;
use render::shape::triangle::intersect_triangle;

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

#[test]
fn triangle_hit_point_and_barycentrics() {
    let (a, b, c) = (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0));
    let ray = Ray::new(v(0.25, 0.5, 2.0), v(0.0, 0.0, -1.0));
    let (t, u, w) = intersect_triangle(&ray, a, b, c).expect("hit");
    assert!((t - 2.0).abs() < 1e-6, "t = {t}");
    // p = (1-u-w) a + u b + w c = (u, w, 0)
    assert!((u - 0.25).abs() < 1e-6 && (w - 0.5).abs() < 1e-6, "u = {u}, v = {w}");
    // Back side is hit too (no culling), same point.
    let back = Ray::new(v(0.25, 0.5, -3.0), v(0.0, 0.0, 1.0));
    let (t, u, w) = intersect_triangle(&back, a, b, c).expect("hit from behind");
    assert!((t - 3.0).abs() < 1e-6 && (u - 0.25).abs() < 1e-6 && (w - 0.5).abs() < 1e-6);
    // Outside the triangle.
    assert!(intersect_triangle(&Ray::new(v(0.6, 0.6, 1.0), v(0.0, 0.0, -1.0)), a, b, c).is_none());
}

#[test]
fn triangle_t_bounds_are_open() {
    let (a, b, c) = (v(-1.0, -1.0, 1.0), v(1.0, -1.0, 1.0), v(0.0, 1.0, 1.0));
    let d = v(0.0, 0.0, 1.0);
    assert!(intersect_triangle(&Ray::with_bounds(Vec3::ZERO, d, 0.0, 1.0), a, b, c).is_none(), "t = t_max excluded");
    assert!(intersect_triangle(&Ray::with_bounds(Vec3::ZERO, d, 1.0, 5.0), a, b, c).is_none(), "t = t_min excluded");
    assert!(intersect_triangle(&Ray::with_bounds(Vec3::ZERO, d, 0.999, 1.001), a, b, c).is_some());
    assert!(intersect_triangle(&Ray::with_bounds(Vec3::ZERO, -d, 0.0, f32::INFINITY), a, b, c).is_none(), "behind the origin");
    // Direction not normalised: t is in units of |d|.
    let (t, _, _) = intersect_triangle(&Ray::new(Vec3::ZERO, 4.0 * d), a, b, c).unwrap();
    assert!((t - 0.25).abs() < 1e-7);
}

#[test]
fn parallel_and_degenerate_rays_miss() {
    let (a, b, c) = (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0));
    // In the plane of the triangle, through its interior.
    assert!(intersect_triangle(&Ray::new(v(-1.0, 0.25, 0.0), v(1.0, 0.0, 0.0)), a, b, c).is_none());
    // Parallel, above.
    assert!(intersect_triangle(&Ray::new(v(-1.0, 0.25, 0.5), v(1.0, 0.0, 0.0)), a, b, c).is_none());
    // Degenerate (zero-area) triangle.
    assert!(intersect_triangle(&Ray::new(v(0.5, 0.0, 1.0), v(0.0, 0.0, -1.0)), a, b, b).is_none());
    // Zero direction.
    assert!(intersect_triangle(&Ray::new(v(0.2, 0.2, 1.0), Vec3::ZERO), a, b, c).is_none());
}

/// A z = 0 grid of n×n unit squares, each split along a diagonal (alternating), counter-clockwise seen from +z.
fn grid(n: i32) -> Vec<[Vec3; 3]> {
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (i as f32, j as f32);
            let p00 = v(x, y, 0.0);
            let p10 = v(x + 1.0, y, 0.0);
            let p01 = v(x, y + 1.0, 0.0);
            let p11 = v(x + 1.0, y + 1.0, 0.0);
            if (i + j) % 2 == 0 {
                tris.push([p00, p10, p11]);
                tris.push([p00, p11, p01]);
            } else {
                tris.push([p00, p10, p01]);
                tris.push([p10, p11, p01]);
            }
        }
    }
    tris
}

fn count_hits(ray: &Ray, tris: &[[Vec3; 3]]) -> usize {
    tris.iter().filter(|t| intersect_triangle(ray, t[0], t[1], t[2]).is_some()).count()
}

/// Rays through every vertex, edge midpoint and quarter point of a triangulated grid, from both
/// sides and along tilted directions whose shear is exact in binary: each must hit exactly one
/// triangle (watertight: at least one; tie rule: no more than one).
#[test]
fn shared_edges_and_vertices_hit_exactly_once() {
    let n = 4;
    let tris = grid(n);
    let dirs = [v(0.0, 0.0, -1.0), v(0.0, 0.0, 1.0), v(0.25, 0.5, -1.0), v(-0.5, 0.125, 1.0), v(0.5, -0.25, -1.0)];
    let mut checked = 0;
    for &d in &dirs {
        for i in 1..(4 * n) {
            for j in 1..(4 * n) {
                // Target on the plane at quarter-unit spacing: vertices, edge midpoints, diagonals, interiors.
                let target = v(i as f32 * 0.25, j as f32 * 0.25, 0.0);
                let o = target - d * 2.0;
                let ray = Ray::new(o, d);
                let hits = count_hits(&ray, &tris);
                assert_eq!(hits, 1, "ray through {target:?} along {d:?} hit {hits} triangles");
                checked += 1;
            }
        }
    }
    assert!(checked > 1000);
}

/// A closed octahedron: a ray through any point of it (vertex, edge, face) enters once and leaves once.
#[test]
fn closed_mesh_counts_two_crossings_through_vertices_and_edges() {
    let p = [v(1.0, 0.0, 0.0), v(-1.0, 0.0, 0.0), v(0.0, 1.0, 0.0), v(0.0, -1.0, 0.0), v(0.0, 0.0, 1.0), v(0.0, 0.0, -1.0)];
    // Faces counter-clockwise seen from outside.
    let f = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    let tris: Vec<[Vec3; 3]> = f.iter().map(|t| [p[t[0]], p[t[1]], p[t[2]]]).collect();
    // Check orientation: outward normals.
    for t in &tris {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        assert!(n.dot(t[0] + t[1] + t[2]) > 0.0);
    }
    let mut checked = 0;
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut d = Vec3::ZERO;
            d[axis] = sign;
            // Lattice of offsets perpendicular to the ray, spacing 1/8: hits vertices (0,0),
            // edges (the two in-plane axes and the slanted ones) and faces.
            for a in -7i32..=7 {
                for b in -7i32..=7 {
                    let mut o = -3.0 * d;
                    o[(axis + 1) % 3] = a as f32 / 8.0;
                    o[(axis + 2) % 3] = b as f32 / 8.0;
                    let inside = (a.abs() + b.abs()) < 8;
                    let on_boundary = (a.abs() + b.abs()) == 8;
                    if on_boundary {
                        continue; // grazing the silhouette: 0 or 2 both fine
                    }
                    let hits = count_hits(&Ray::new(o, d), &tris);
                    assert_eq!(hits, if inside { 2 } else { 0 }, "axis {axis} sign {sign} offset ({a},{b})");
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 1000);
}

#[test]
fn sphere_closed_forms() {
    let s = Sphere { center: v(1.0, 2.0, 3.0), radius: 2.0 };
    // From outside along the axis: hits at distance 5 - 2.
    let ray = Ray::new(v(1.0, 2.0, -2.0), v(0.0, 0.0, 1.0));
    assert!((s.intersect(&ray).unwrap() - 3.0).abs() < 1e-6);
    // From the centre: the far side at t = r.
    assert!((s.intersect(&Ray::new(s.center, v(0.0, 1.0, 0.0))).unwrap() - 2.0).abs() < 1e-6);
    // Chord at distance h from the centre: t = L − sqrt(r² − h²).
    let h = 1.2f32;
    let ray = Ray::new(v(1.0 + h, 2.0, -7.0), v(0.0, 0.0, 1.0));
    let expect = 10.0 - (4.0 - h * h).sqrt();
    assert!((s.intersect(&ray).unwrap() - expect).abs() < 1e-5);
    // Miss, behind, and t bounds.
    assert!(s.intersect(&Ray::new(v(3.5, 2.0, -7.0), v(0.0, 0.0, 1.0))).is_none());
    assert!(s.intersect(&Ray::new(v(1.0, 2.0, 8.0), v(0.0, 0.0, 1.0))).is_none());
    assert!(s.intersect(&Ray::with_bounds(v(1.0, 2.0, -2.0), v(0.0, 0.0, 1.0), 0.0, 3.0)).is_none());
    let t = s.intersect(&Ray::with_bounds(v(1.0, 2.0, -2.0), v(0.0, 0.0, 1.0), 3.0, 100.0)).unwrap();
    assert!((t - 7.0).abs() < 1e-5, "second root when the first is excluded: {t}");
}

/// A tiny sphere far from the ray origin: the naive b² − ac discriminant loses all its digits
/// in f32; the distance-to-line form must still hit within float accuracy of the f64 answer.
#[test]
fn sphere_small_and_far_is_robust() {
    let s = Sphere { center: v(0.0, 0.0, 1.0e4), radius: 0.01 };
    let mut hits = 0;
    for k in 0..200 {
        let off = (k as f32 / 200.0 - 0.5) * 0.019; // |off| < r
        let o = v(off, 0.0, 0.0);
        let ray = Ray::new(o, v(0.0, 0.0, 1.0));
        let t = s.intersect(&ray).unwrap_or_else(|| panic!("missed at offset {off}"));
        let (r, c, x) = (0.01f64, 1.0e4f64, off as f64);
        let exact = c - (r * r - x * x).sqrt();
        assert!(((t as f64) - exact).abs() < 2e-3, "t = {t}, exact {exact}");
        hits += 1;
    }
    assert_eq!(hits, 200);
    // Just outside the radius: miss.
    assert!(s.intersect(&Ray::new(v(0.0105, 0.0, 0.0), v(0.0, 0.0, 1.0))).is_none());
}

#[test]
fn aabb_slab_test() {
    let b = Aabb::new(v(-1.0, -1.0, -1.0), v(1.0, 1.0, 1.0));
    let (t0, t1) = b.intersect(&Ray::new(v(-3.0, 0.0, 0.0), v(1.0, 0.0, 0.0))).unwrap();
    assert!((t0 - 2.0).abs() < 1e-6 && (t1 - 4.0).abs() < 1e-5);
    // Axis-parallel ray outside the slab of another axis.
    assert!(b.intersect(&Ray::new(v(-3.0, 2.0, 0.0), v(1.0, 0.0, 0.0))).is_none());
    // Ray on the boundary plane still counts (closed box).
    assert!(b.intersect(&Ray::new(v(-3.0, 1.0, 0.0), v(1.0, 0.0, 0.0))).is_some());
    assert!((b.surface_area() - 24.0).abs() < 1e-6);
    assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
    assert!(Aabb::EMPTY.is_empty());
}
