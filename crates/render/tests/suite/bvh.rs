//! The BVH against brute force (every primitive tested), any-hit against closest-hit,
//! surface points, and spheres mixed with meshes.

use glam::Vec3;
use render::accel::{Accel, Hit};
use render::shape::Shape;
use render::math::geometry::Ray;
use render::shape::sphere::Sphere;
use render::shape::mesh::TriangleMesh;
use std::path::Path;

struct Rng(u64);
impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn dir(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * self.f32();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

fn load(name: &str) -> TriangleMesh {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes").join(name);
    TriangleMesh::load(&p).unwrap().remove(0).1
}

/// Random rays: half with origins uniform in the (enlarged) box and uniform directions, half from
/// a sphere around the box aimed at random points inside it (mostly hits); some with finite t_max.
fn rays(accel: &Accel, n: usize, seed: u64) -> Vec<Ray> {
    let b = accel.bounds();
    let (c, ext) = (b.center(), b.extent());
    let radius = ext.length();
    let mut rng = Rng(seed);
    (0..n)
        .map(|k| {
            let inside = c + (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * ext * 1.2;
            let mut ray = if k % 2 == 0 {
                Ray::new(inside, rng.dir())
            } else {
                let o = c + rng.dir() * radius;
                Ray::new(o, inside - o)
            };
            if k % 5 == 0 {
                ray.t_max = rng.f32() * 1.5;
            }
            if k % 7 == 0 {
                ray.t_min = rng.f32() * 0.5;
            }
            ray
        })
        .collect()
}

fn same(a: Option<Hit>, b: Option<RefHit>, ray: &Ray) {
    match (a, b) {
        (None, None) => {}
        (Some(a), Some(b)) => {
            if (a.object, a.prim) == (b.object, b.prim) {
                // Same primitive test on the same data: bitwise the same t (and barycentrics;
                // the reference leaves spheres' (u, v) unset).
                assert_eq!(a.t, b.t, "{ray:?}");
                if !b.is_sphere {
                    assert_eq!((a.u, a.v), (b.u, b.v), "{ray:?}");
                }
            } else {
                // Another primitive at the same distance (shared edge, coplanar faces): t may
                // differ by rounding only.
                assert!((a.t - b.t).abs() <= 4.0 * f32::EPSILON * a.t.abs().max(b.t.abs()), "{a:?} vs {b:?} for {ray:?}");
            }
        }
        _ => panic!("BVH {a:?} vs brute force {b:?} for {ray:?}"),
    }
}

/// A hit of the reference.
#[derive(Clone, Copy, Debug)]
struct RefHit {
    t: f32,
    object: u32,
    prim: u32,
    u: f32,
    v: f32,
    is_sphere: bool,
}

/// Brute-force reference: every triangle's box (enlarged, so it never rejects a triangle the
/// exact test would hit) is tested in a loop the compiler vectorises, then every surviving
/// triangle and every sphere is tested exactly. No hierarchy. Rays with a zero direction
/// component skip the box cull.
struct BruteForce {
    lo: [Vec<f32>; 3],
    hi: [Vec<f32>; 3],
    tris: Vec<(u32, u32, [Vec3; 3])>,
    spheres: Vec<(u32, Sphere)>,
}

impl BruteForce {
    fn new(accel: &Accel) -> BruteForce {
        let mut bf = BruteForce { lo: Default::default(), hi: Default::default(), tris: Vec::new(), spheres: Vec::new() };
        for (o, s) in accel.shapes().iter().enumerate() {
            match s {
                Shape::Mesh(m) => {
                    for i in 0..m.indices.len() {
                        let t = m.triangle(i);
                        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                        // Enlarged so rounding in the slab test can never reject a true hit.
                        let pad = (hi - lo) * 1e-3 + (lo.abs().max(hi.abs()) + Vec3::splat(1e-3)) * 1e-4;
                        let (lo, hi) = (lo - pad, hi + pad);
                        for a in 0..3 {
                            bf.lo[a].push(lo[a]);
                            bf.hi[a].push(hi[a]);
                        }
                        bf.tris.push((o as u32, i as u32, t));
                    }
                }
                Shape::Sphere(sp) => bf.spheres.push((o as u32, *sp)),
            }
        }
        bf
    }

    fn intersect(&self, ray: &Ray, mask: &mut Vec<u8>) -> Option<RefHit> {
        let n = self.tris.len();
        mask.clear();
        mask.resize(n, 0);
        let inv = ray.d.recip();
        if inv.is_finite() {
            // Slab test of every (enlarged) triangle box, 16 at a time in straight-line code.
            let (o, t_lo, t_hi) = (ray.o, ray.t_min, ray.t_max);
            let full = n / 16 * 16;
            let test = |i: usize| -> u8 {
                let mut near = t_lo;
                let mut far = t_hi;
                for a in 0..3 {
                    let t0 = (self.lo[a][i] - o[a]) * inv[a];
                    let t1 = (self.hi[a][i] - o[a]) * inv[a];
                    let (x, y) = if t0 < t1 { (t0, t1) } else { (t1, t0) };
                    near = if x > near { x } else { near };
                    far = if y < far { y } else { far };
                }
                (near > far) as u8
            };
            for c in (0..full).step_by(16) {
                let m: &mut [u8; 16] = (&mut mask[c..c + 16]).try_into().unwrap();
                for (k, mk) in m.iter_mut().enumerate() {
                    *mk = test(c + k);
                }
            }
            for i in full..n {
                mask[i] = test(i);
            }
        }
        // The exact test on the survivors.
        let rt = render::shape::triangle::RayTri::new(ray);
        let mut t_max = ray.t_max;
        let mut best = None;
        for (i, &(obj, prim, t)) in self.tris.iter().enumerate() {
            if mask[i] != 0 {
                continue;
            }
            if let Some((th, u, v)) = rt.intersect(t[0], t[1], t[2], ray.t_min, t_max) {
                t_max = th;
                best = Some(RefHit { t: th, object: obj, prim, u, v, is_sphere: false });
            }
        }
        for &(obj, sp) in &self.spheres {
            if let Some(th) = sp.intersect(&Ray { t_max, ..*ray }) {
                t_max = th;
                best = Some(RefHit { t: th, object: obj, prim: 0, u: 0.0, v: 0.0, is_sphere: true });
            }
        }
        best
    }
}

fn check_against_brute_force(accel: &Accel, n: usize, seed: u64) -> usize {
    use rayon::prelude::*;
    let rs = rays(accel, n, seed);
    let bf = BruteForce::new(accel);
    rs.par_chunks(256)
        .map(|ch| {
            let mut hits = 0;
            let mut mask = Vec::new();
            // The batched traversal gives the single-ray hits exactly.
            let mut batch = vec![None; ch.len()];
            accel.intersect_batch(ch, &mut batch);
            for (r, b) in ch.iter().zip(&batch) {
                assert_eq!(*b, accel.intersect(r), "intersect_batch differs for {r:?}");
            }
            for r in ch {
                let fast = accel.intersect(r);
                let slow = bf.intersect(r, &mut mask);
                same(fast, slow, r);
                assert_eq!(accel.occluded(r), slow.is_some(), "occluded disagrees for {r:?}");
                hits += slow.is_some() as usize;
            }
            hits
        })
        .sum()
}

#[test]
fn bunny_bvh_matches_brute_force_on_100k_rays() {
    let accel = Accel::build(vec![Shape::Mesh(load("bunny.ply"))]);
    let hits = check_against_brute_force(&accel, 100_000, 1);
    // Both kinds of ray must be well represented.
    assert!(hits > 30_000 && hits < 90_000, "hits = {hits}");
}

#[test]
fn dragon_48k_bvh_matches_brute_force_on_100k_rays() {
    let accel = Accel::build(vec![Shape::Mesh(load("dragon-48k.ply"))]);
    let hits = check_against_brute_force(&accel, 100_000, 2);
    assert!(hits > 20_000 && hits < 90_000, "hits = {hits}");
}

/// The teapot, 200 random spheres (from `rng`) and a ground quad.
fn teapot_spheres_and_quad(rng: &mut Rng) -> Vec<Shape> {
    let mut shapes = vec![Shape::Mesh(load("teapot.ply"))];
    for _ in 0..200 {
        let c = (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * Vec3::new(40.0, 20.0, 25.0);
        shapes.push(Shape::Sphere(Sphere { center: c, radius: 0.2 + 2.0 * rng.f32() }));
    }
    shapes.push(Shape::Mesh(TriangleMesh::quad([
        Vec3::new(-30.0, -8.0, -30.0),
        Vec3::new(-30.0, -8.0, 30.0),
        Vec3::new(30.0, -8.0, 30.0),
        Vec3::new(30.0, -8.0, -30.0),
    ])));
    shapes
}

#[test]
fn spheres_and_meshes_mixed() {
    let accel = Accel::build(teapot_spheres_and_quad(&mut Rng(9)));
    let hits = check_against_brute_force(&accel, 20_000, 3);
    assert!(hits > 5_000);
}

#[test]
fn surface_point_normals() {
    // Sphere: outward unit normal, point on the surface.
    let s = Sphere { center: Vec3::new(0.0, 0.0, 5.0), radius: 2.0 };
    let mut quad = TriangleMesh::quad([
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ]);
    // Shading normals tilted and pointing to −z (the back side): must be flipped to the +z side.
    quad.normals = Some(vec![Vec3::new(0.3, 0.0, -1.0).normalize(); 4]);
    quad.transform(&glam::Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0)));
    let accel = Accel::build(vec![Shape::Sphere(s), Shape::Mesh(quad)]);
    let ray = Ray::new(Vec3::new(0.5, 0.3, -3.0), Vec3::Z);
    let hit = accel.intersect(&ray).unwrap();
    assert_eq!(hit.object, 0);
    let sp = accel.surface_point(&ray, &hit);
    assert!(((sp.p - s.center).length() - 2.0).abs() < 1e-5);
    assert!((sp.ng - (sp.p - s.center) / 2.0).length() < 1e-5);
    // From inside the sphere the normal still points outwards (not towards the ray).
    let ray_in = Ray::new(s.center, Vec3::Y);
    let h = accel.intersect(&ray_in).unwrap();
    assert!((h.t - 2.0).abs() < 1e-5);
    assert!((accel.surface_point(&ray_in, &h).ng - Vec3::Y).length() < 1e-5);

    let ray = Ray::new(Vec3::new(10.2, 0.4, 3.0), -Vec3::Z);
    let hit = accel.intersect(&ray).unwrap();
    assert_eq!((hit.object, hit.t), (1, 3.0));
    let sp = accel.surface_point(&ray, &hit);
    assert!((sp.p - Vec3::new(10.2, 0.4, 0.0)).length() < 1e-5);
    assert!((sp.ng - Vec3::Z).length() < 1e-6, "counter-clockwise front: {:?}", sp.ng);
    assert!(sp.ns.dot(sp.ng) > 0.0 && (sp.ns.length() - 1.0).abs() < 1e-5);
    assert!((sp.ns - Vec3::new(-0.3, 0.0, 1.0).normalize()).length() < 1e-5);
    assert_eq!(accel.bounds().max.x, 11.0);
}

#[test]
fn empty_scene_and_degenerate_input() {
    let accel = Accel::build(vec![]);
    assert!(accel.intersect(&Ray::new(Vec3::ZERO, Vec3::X)).is_none());
    assert!(!accel.occluded(&Ray::new(Vec3::ZERO, Vec3::X)));
    // Many triangles with the same centroid (the SAH cannot separate them) and zero-area ones.
    let n = 100;
    let mut m = TriangleMesh::default();
    for k in 0..n {
        let s = 1.0 + k as f32;
        let base = m.positions.len() as u32;
        m.positions.extend([Vec3::new(-s, -s, 0.0), Vec3::new(2.0 * s, -s, 0.0), Vec3::new(-s, 2.0 * s, 0.0)]);
        m.indices.push([base, base + 1, base + 2]);
        m.indices.push([base, base, base + 1]);
    }
    let accel = Accel::build(vec![Shape::Mesh(m)]);
    let r = Ray::new(Vec3::new(0.1, 0.1, 1.0), -Vec3::Z);
    let h = accel.intersect(&r).unwrap();
    assert!((h.t - 1.0).abs() < 1e-6, "t = {}", h.t);
    assert!((accel.intersect_brute_force(&r).unwrap().t - 1.0).abs() < 1e-6);
    check_against_brute_force(&accel, 2000, 5);
    // An out-of-range index (a mesh built by hand, not validated) is left out, not a panic.
    let bad = TriangleMesh { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], normals: None, uvs: None, indices: vec![[0, 1, 2], [0, 1, 7]] };
    assert!(bad.validate().is_err());
    let accel = Accel::build(vec![Shape::Mesh(bad)]);
    let h = accel.intersect(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z)).unwrap();
    assert_eq!(h.prim, 0);
    assert!(accel.intersect_brute_force(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z)).is_some());
}

/// Axis-parallel rays lying exactly in a bounding plane of the scene and of its nodes (as camera
/// rays in a box scene do): the slab test must treat the plane as inside, not as NaN.
#[test]
fn axis_parallel_rays_in_bounding_planes() {
    // A wall in the plane x = 0 (its node box is flat in x) crossing a larger back quad at z = 2.
    // (Points exactly on a mesh's open boundary belong to it or not by the tie rule; avoid them.)
    let wall = TriangleMesh::quad([Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 2.5), Vec3::new(0.0, 2.0, 2.5), Vec3::new(0.0, 2.0, 0.0)]);
    let back = TriangleMesh::quad([Vec3::new(-1.0, -1.0, 2.0), Vec3::new(3.0, -1.0, 2.0), Vec3::new(3.0, 3.0, 2.0), Vec3::new(-1.0, 3.0, 2.0)]);
    let accel = Accel::build(vec![Shape::Mesh(wall), Shape::Mesh(back)]);
    for (o, d, obj, t) in [
        (Vec3::new(0.0, 0.5, -1.0), Vec3::Z, 1, 3.0),  // in the wall's plane x = 0
        (Vec3::new(0.0, 2.0, -1.0), Vec3::Z, 1, 3.0),  // along the wall's top edge (y = 2, its max)
        (Vec3::new(0.0, 0.0, -1.0), Vec3::Z, 1, 3.0),  // along its bottom edge
        (Vec3::new(-1.0, 1.0, 2.0), Vec3::X, 0, 1.0),  // in the back quad's plane (flat box in z): hits the wall
        (Vec3::new(1.0, -1.0, 1.0), Vec3::Y, 2, 0.0),  // in the scene's min-y plane: nothing to hit
    ] {
        if obj == 2 {
            let r = Ray::new(o, d);
            assert!(accel.intersect(&r).is_none() && !accel.occluded(&r));
            continue;
        }
        let r = Ray::new(o, d);
        let h = accel.intersect(&r).unwrap_or_else(|| panic!("missed {r:?}"));
        assert_eq!((h.object, h.t), (obj, t), "{r:?}");
        assert!(accel.occluded(&r));
        let shadow = Ray::with_bounds(o, d, 1e-3, 0.5 * t);
        assert!(!accel.occluded(&shadow) && accel.intersect(&shadow).is_none());
    }
}

/// Geometrically spaced slivers make a deep, comb-like tree; the traversal on the heap stack
/// (used for trees too deep for the machine-stack one) must agree with brute force too.
#[test]
fn deep_tree_uses_heap_stack_and_stays_exact() {
    let mut m = TriangleMesh::default();
    for k in 0..400 {
        let x = 1.1f32.powi(k);
        let b = m.positions.len() as u32;
        let w = 0.01 * x;
        m.positions.extend([Vec3::new(x, -1.0, -1.0), Vec3::new(x + w, 1.0, -1.0), Vec3::new(x, 0.0, 1.0)]);
        m.indices.push([b, b + 1, b + 2]);
    }
    let mut accel = Accel::build(vec![Shape::Mesh(m)]);
    assert!(accel.depth() > 10, "depth {}", accel.depth());
    check_against_brute_force(&accel, 20_000, 11);
    accel.force_heap_stack();
    check_against_brute_force(&accel, 20_000, 12);
    let r = Ray::new(Vec3::new(0.0, 0.1, 0.0), Vec3::X);
    assert_eq!(accel.intersect(&r).unwrap().prim, 0);
}

/// Coherent packets (a jittered pinhole's 4×4 pixel blocks, some with a finite t_max or t_min > 0,
/// some from origins spread over a small lens) traced with `intersect_packet` give each ray's
/// single-ray closest hit: the same t bit for bit and the same primitive unless two are hit at
/// exactly the same t. Also packets of 4 and 8, and incoherent packets (traced ray by ray).
fn check_packets(accel: &Accel, seed: u64) -> usize {
    let b = accel.bounds();
    let (c, radius) = (b.center(), 0.5 * b.extent().length());
    let mut rng = Rng(seed);
    let mut hits = 0;
    let size = 96u32;
    for view in 0..6 {
        let eye = c + rng.dir() * radius * (1.5 + rng.f32());
        let dir = (c + (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * radius * 0.3 - eye).normalize();
        let right = dir.cross(Vec3::Y).normalize() * 0.45;
        let up = right.cross(dir);
        for j in (0..size).step_by(4) {
            for i in (0..size).step_by(4) {
                let rays: [Ray; 16] = std::array::from_fn(|k| {
                    let (x, y) = (i + k as u32 % 4, j + k as u32 / 4);
                    let sx = 2.0 * (x as f32 + rng.f32()) / size as f32 - 1.0;
                    let sy = 1.0 - 2.0 * (y as f32 + rng.f32()) / size as f32;
                    let o = if view % 2 == 1 { eye + (right * (rng.f32() - 0.5) + up * (rng.f32() - 0.5)) * 0.05 * radius } else { eye };
                    let mut r = Ray::new(o, dir + sx * right + sy * up);
                    if view >= 4 && k % 3 == 0 {
                        r.t_max = radius * (1.0 + 2.0 * rng.f32());
                    }
                    if view >= 4 && k % 5 == 0 {
                        r.t_min = radius * rng.f32();
                    }
                    r
                });
                let single: Vec<Option<Hit>> = rays.iter().map(|r| accel.intersect(r)).collect();
                for n in [4usize, 8, 16] {
                    for start in (0..16).step_by(n) {
                        let mut out = vec![None; n];
                        accel.intersect_packet(&rays[start..start + n], &mut out);
                        for (k, (p, s)) in out.iter().zip(&single[start..start + n]).enumerate() {
                            match (p, s) {
                                (None, None) => {}
                                (Some(p), Some(s)) => {
                                    assert_eq!(p.t.to_bits(), s.t.to_bits(), "packet t differs for {:?}", rays[start + k]);
                                    if (p.object, p.prim) != (s.object, s.prim) {
                                        // Allowed only for an exact tie, which the other primitive must confirm.
                                        assert_eq!(p.t, s.t);
                                    } else {
                                        assert_eq!((p.u, p.v), (s.u, s.v));
                                    }
                                }
                                _ => panic!("packet and single-ray traversal disagree for {:?}: {p:?} vs {s:?}", rays[start + k]),
                            }
                        }
                    }
                }
                hits += single.iter().filter(|h| h.is_some()).count();
            }
        }
    }
    // Incoherent packets fall back to single rays and agree exactly.
    let inc = rays(accel, 1600, seed + 1);
    for ch in inc.chunks(16) {
        let mut out = vec![None; 16];
        accel.intersect_packet(ch, &mut out);
        for (r, h) in ch.iter().zip(&out) {
            assert_eq!(*h, accel.intersect(r));
        }
    }
    hits
}

#[test]
fn packet_traversal_matches_single_rays() {
    let bunny = Accel::build(vec![Shape::Mesh(load("bunny.ply"))]);
    let h = check_packets(&bunny, 21);
    assert!(h > 5_000, "hits = {h}");
    let dragon = Accel::build(vec![Shape::Mesh(load("dragon-48k.ply"))]);
    let h = check_packets(&dragon, 22);
    assert!(h > 5_000, "hits = {h}");
    let mut shapes = vec![Shape::Mesh(load("teapot.ply"))];
    let mut rng = Rng(23);
    for _ in 0..100 {
        let c = (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * Vec3::new(40.0, 20.0, 25.0);
        shapes.push(Shape::Sphere(Sphere { center: c, radius: 0.2 + 2.0 * rng.f32() }));
    }
    let mixed = Accel::build(shapes);
    let h = check_packets(&mixed, 24);
    assert!(h > 5_000, "hits = {h}");
}

/// Distance from `p` to triangle (a, b, c) by another route than the library's Voronoi-region
/// walk: the projection onto the plane if its barycentric coordinates are all ≥ 0, else the
/// nearest of the three edges as clamped segments.
fn triangle_distance(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let seg = |u: Vec3, v: Vec3| {
        let d = v - u;
        let t = if d.length_squared() > 0.0 { ((p - u).dot(d) / d.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
        (u + d * t - p).length()
    };
    let n = (b - a).cross(c - a);
    if n.length_squared() > 0.0 {
        let q = p - n * ((p - a).dot(n) / n.length_squared());
        let area = |x: Vec3, y: Vec3, z: Vec3| (y - x).cross(z - x).dot(n);
        let (wa, wb, wc) = (area(q, b, c), area(a, q, c), area(a, b, q));
        if wa >= 0.0 && wb >= 0.0 && wc >= 0.0 {
            return (p - q).length();
        }
    }
    seg(a, b).min(seg(b, c)).min(seg(c, a))
}

/// `Accel::distance` against brute force over every triangle and sphere of the teapot, 200
/// spheres and a ground quad, at 3000 points in and around the scene: equal to 1e-4 of the
/// scene's size (f32 rounding), and capped where nothing is nearer than the cap.
#[test]
fn distance_to_the_nearest_surface_matches_brute_force() {
    let mut rng = Rng(21);
    let shapes = teapot_spheres_and_quad(&mut rng);
    let accel = Accel::build(shapes.clone());
    let b = accel.bounds();
    let (c, ext) = (b.center(), b.extent());
    let tol = 1e-4 * ext.length();
    let mut capped = 0;
    for k in 0..3000 {
        let p = c + (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * ext * 1.3;
        let mut truth = f32::INFINITY;
        for s in &shapes {
            match s {
                Shape::Mesh(m) => {
                    for t in &m.indices {
                        let [a, b, c] = t.map(|i| m.positions[i as usize]);
                        truth = truth.min(triangle_distance(p, a, b, c));
                    }
                }
                Shape::Sphere(sp) => truth = truth.min(((p - sp.center).length() - sp.radius).abs()),
                #[allow(unreachable_patterns)]
                _ => {}
            }
        }
        let cap = if k % 3 == 0 { 1.0 } else { f32::INFINITY };
        let got = accel.distance(p, cap);
        let want = truth.min(cap);
        capped += (truth > cap) as usize;
        assert!((got - want).abs() <= tol, "point {p}: distance {got}, brute force {want}");
    }
    assert!(capped > 50, "only {capped} points beyond the cap");
}
