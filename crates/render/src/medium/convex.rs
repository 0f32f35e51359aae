//! A medium bounded by one closed convex triangle mesh with no other surface inside it: then the
//! distance from an interior point to the nearest surface of the whole scene is the smallest
//! distance to the mesh's face planes, and a ray from an interior point first meets a surface
//! where it leaves the intersection of the faces' half-spaces. Both take a loop over the planes
//! (a cylinder of 128 segments has 130) instead of a BVH descent, which `volpath` runs for every
//! surface-free ball and every refraction-guide probe near a milk glass's wall.
//!
//! Why these are exact: let K be the intersection of the half-spaces n_f·x ≤ b_f of the mesh's
//! faces (outward normals n_f). K is convex, and for x in K the distance from x to the
//! complement of K is min_f (b_f − n_f·x). A closed mesh whose every vertex lies in every face's
//! half-space is the boundary of K (the faces are K's facets). If every other surface of the
//! scene lies outside the interior of K (checked at build: for each other triangle some face
//! plane has all three vertices on or beyond it; for a sphere, its centre at least a radius
//! beyond), no surface comes closer to x than K's boundary, and a ray from x meets no surface
//! before it leaves K, which it does on the mesh, at the facet whose plane it crosses first.

use glam::{DVec3, Vec3, Vec4};

use crate::shape::mesh::TriangleMesh;
use crate::shape::Shape;

/// The face planes of a medium's closed convex boundary mesh, four planes at a time.
#[derive(Clone, Debug)]
pub struct ConvexBoundary {
    /// Per group of four planes: the normals' x, y, z and the offsets b (m), n·x = b on the plane,
    /// n outward; unused lanes have n = 0 and b = +∞.
    nx: Vec<Vec4>,
    ny: Vec<Vec4>,
    nz: Vec<Vec4>,
    b: Vec<Vec4>,
    /// The object (shape index) whose mesh this is.
    object: u32,
    /// Per plane, its triangles wound counter-clockwise about the outward normal, when it has at
    /// most [`FACET_TRIANGLES`] (else empty): a crossing of the plane inside one of them is
    /// where the ray leaves ([`Self::exit_near`]).
    facets: Vec<Vec<[Vec3; 3]>>,
}

/// Most triangles of a plane that [`ConvexBoundary::exit_near`] tests before the full search.
const FACET_TRIANGLES: usize = 4;

/// Most distinct planes kept; a finer mesh is left to the BVH (the loop would cost more).
const MAX_PLANES: usize = 1024;

impl ConvexBoundary {
    /// The boundary of the medium inside `shapes[object]`, if that shape is a closed convex
    /// mesh and no other shape reaches into it.
    pub fn build(shapes: &[Shape], object: usize) -> Option<ConvexBoundary> {
        let Shape::Mesh(mesh) = shapes.get(object)? else { return None };
        let (planes, plane_of) = convex_planes(mesh)?;
        let (lo, hi) = bounds(mesh);
        for (i, shape) in shapes.iter().enumerate() {
            if i == object {
                continue;
            }
            match shape {
                Shape::Mesh(m) => {
                    for t in &m.indices {
                        let v = t.map(|k| m.positions[k as usize].as_dvec3());
                        let (tlo, thi) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
                        // Outside the mesh's box, so outside K (K is the hull of its vertices).
                        if (0..3).any(|a| thi[a] < lo[a] || tlo[a] > hi[a]) {
                            continue;
                        }
                        if !planes.iter().any(|&(n, b)| v.iter().all(|&x| n.dot(x) - b >= 0.0)) {
                            return None;
                        }
                    }
                }
                Shape::Sphere(s) => {
                    let c = s.center.as_dvec3();
                    if !planes.iter().any(|&(n, b)| n.dot(c) - b >= s.radius as f64) {
                        return None;
                    }
                }
            }
        }
        let groups = planes.len().div_ceil(4);
        let mut out = ConvexBoundary {
            nx: vec![Vec4::ZERO; groups],
            ny: vec![Vec4::ZERO; groups],
            nz: vec![Vec4::ZERO; groups],
            b: vec![Vec4::splat(f32::INFINITY); groups],
            object: object as u32,
            facets: vec![Vec::new(); planes.len()],
        };
        for (t, &k) in mesh.indices.iter().zip(&plane_of) {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            let n = planes[k].0.as_vec3();
            out.facets[k].push(if (b - a).cross(c - a).dot(n) >= 0.0 { [a, b, c] } else { [a, c, b] });
        }
        for f in &mut out.facets {
            if f.len() > FACET_TRIANGLES {
                f.clear();
            }
        }
        for (i, (n, b)) in planes.iter().enumerate() {
            let (g, l) = (i / 4, i % 4);
            out.nx[g][l] = n.x as f32;
            out.ny[g][l] = n.y as f32;
            out.nz[g][l] = n.z as f32;
            out.b[g][l] = *b as f32;
        }
        Some(out)
    }

    /// The object (shape index) whose mesh bounds the medium.
    pub fn object(&self) -> u32 {
        self.object
    }

    /// Number of face planes.
    pub fn plane_count(&self) -> usize {
        self.b.iter().map(|g| g.to_array().iter().filter(|v| v.is_finite()).count()).sum()
    }

    /// min over the planes of b − n·p (m): for `p` inside the mesh, its distance to the nearest
    /// surface of the scene; ≤ 0 outside (no bound then).
    #[inline]
    pub fn distance(&self, p: Vec3) -> f32 {
        let (px, py, pz) = (Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z));
        let mut m = Vec4::splat(f32::INFINITY);
        for g in 0..self.b.len() {
            m = m.min(self.b[g] - (self.nx[g] * px + self.ny[g] * py + self.nz[g] * pz));
        }
        m.min_element()
    }

    /// [`Self::exit`] that first tries plane `*hint` (the last exit's, typically the same facet
    /// for nearby points): a ray from inside a convex body meets its boundary once, so a crossing
    /// of that plane inside one of its triangles is the exit. Otherwise the full search, which
    /// sets `*hint`.
    #[inline]
    pub fn exit_near(&self, p: Vec3, d: Vec3, hint: &mut u32) -> Option<(f32, Vec3)> {
        let k = *hint as usize;
        if let Some(tris) = self.facets.get(k).filter(|f| !f.is_empty()) {
            let (g, l) = (k / 4, k % 4);
            let n = Vec3::new(self.nx[g][l], self.ny[g][l], self.nz[g][l]);
            let (den, num) = (n.dot(d), self.b[g][l] - n.dot(p));
            if den > 0.0 && num > 0.0 {
                let t = num / den;
                let q = p + d * t;
                let on = |[a, b, c]: &[Vec3; 3]| (b - a).cross(q - a).dot(n) >= 0.0 && (c - b).cross(q - b).dot(n) >= 0.0 && (a - c).cross(q - c).dot(n) >= 0.0;
                if tris.iter().any(on) {
                    return Some((t, n));
                }
            }
        }
        let (t, n, k) = self.exit_plane(p, d)?;
        *hint = k as u32;
        Some((t, n))
    }

    /// Where a ray from `p` along the unit `d` leaves the mesh: the distance (m) and the outward
    /// normal of the facet's plane it crosses first; `None` unless `p` lies strictly inside
    /// every face plane (then the BVH must answer).
    #[inline]
    pub fn exit(&self, p: Vec3, d: Vec3) -> Option<(f32, Vec3)> {
        self.exit_plane(p, d).map(|(t, n, _)| (t, n))
    }

    /// [`Self::exit`] with the index of the plane.
    fn exit_plane(&self, p: Vec3, d: Vec3) -> Option<(f32, Vec3, usize)> {
        let (px, py, pz) = (Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z));
        let (dx, dy, dz) = (Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z));
        let inf = Vec4::splat(f32::INFINITY);
        // Per lane: the smallest distance to a plane (inside test), the nearest crossing and
        // the group it was in.
        let (mut inside, mut best, mut group) = (inf, inf, Vec4::ZERO);
        for g in 0..self.b.len() {
            let den = self.nx[g] * dx + self.ny[g] * dy + self.nz[g] * dz;
            let num = self.b[g] - (self.nx[g] * px + self.ny[g] * py + self.nz[g] * pz);
            inside = inside.min(num);
            // Only planes the ray moves towards; the others (and unused lanes, den = 0) give +∞.
            let t = Vec4::select(den.cmpgt(Vec4::ZERO), num / den, inf);
            let closer = t.cmplt(best);
            best = Vec4::select(closer, t, best);
            group = Vec4::select(closer, Vec4::splat(g as f32), group);
        }
        if !(inside.min_element() > 0.0) {
            return None;
        }
        let t = best.min_element();
        let lane = best.to_array().iter().position(|&v| v == t)?;
        if !t.is_finite() {
            return None;
        }
        let g = group[lane] as usize;
        Some((t, Vec3::new(self.nx[g][lane], self.ny[g][lane], self.nz[g][lane]), 4 * g + lane))
    }
}

/// The mesh's bounding box, in f64 for the checks.
fn bounds(mesh: &TriangleMesh) -> (DVec3, DVec3) {
    let b = crate::math::geometry::Aabb::from_points(&mesh.positions);
    (b.min.as_dvec3(), b.max.as_dvec3())
}

/// The distinct outward face planes (unit n, b = n·x on the plane) of a closed convex mesh and
/// the plane of each triangle, or
/// `None` when the mesh is open (an edge not shared by exactly two faces, vertices matched by
/// position), not convex (a vertex beyond a face plane by more than 1e-9 of the mesh's size),
/// degenerate, or has more than [`MAX_PLANES`] distinct planes. The faces may all wind either way.
fn convex_planes(mesh: &TriangleMesh) -> Option<(Vec<(DVec3, f64)>, Vec<usize>)> {
    if mesh.indices.len() < 4 {
        return None;
    }
    // Closed: vertices identified by position, every undirected edge in exactly two faces.
    let mut ids = std::collections::HashMap::new();
    let key = |p: Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let vid: Vec<u32> = mesh.positions.iter().map(|&p| {
        let n = ids.len() as u32;
        *ids.entry(key(p)).or_insert(n)
    }).collect();
    let mut edges = std::collections::HashMap::new();
    for t in &mesh.indices {
        let v = t.map(|k| vid[k as usize]);
        for (a, b) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
            *edges.entry((a.min(b), a.max(b))).or_insert(0u32) += 1;
        }
    }
    if edges.values().any(|&c| c != 2) {
        return None;
    }
    let (lo, hi) = bounds(mesh);
    let size = (hi - lo).max_element();
    if !(size > 0.0) || !size.is_finite() {
        return None;
    }
    let tol = 1e-9 * size;
    let centroid = mesh.positions.iter().map(|p| p.as_dvec3()).sum::<DVec3>() / mesh.positions.len() as f64;
    let mut planes: Vec<(DVec3, f64)> = Vec::new();
    let mut plane_of = Vec::with_capacity(mesh.indices.len());
    let mut sign = 0.0f64;
    for t in &mesh.indices {
        let [a, b, c] = t.map(|k| mesh.positions[k as usize].as_dvec3());
        let n = (b - a).cross(c - a);
        let len = n.length();
        if !(len > 1e-12 * size * size) {
            return None;
        }
        let mut n = n / len;
        // Every face must wind the same way: outward where the centroid is behind it.
        let s = if n.dot(centroid - a) < 0.0 { 1.0 } else { -1.0 };
        if sign == 0.0 {
            sign = s;
        } else if s != sign {
            return None;
        }
        n *= s;
        let off = n.dot(a);
        match planes.iter().position(|&(m, o)| m.dot(n) > 1.0 - 1e-12 && (o - off).abs() <= tol) {
            Some(k) => plane_of.push(k),
            None => {
                plane_of.push(planes.len());
                planes.push((n, off));
                if planes.len() > MAX_PLANES {
                    return None;
                }
            }
        }
    }
    // Convex: every vertex behind every plane.
    for &(n, off) in &planes {
        if mesh.positions.iter().any(|p| n.dot(p.as_dvec3()) - off > tol) {
            return None;
        }
    }
    Some((planes, plane_of))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::sphere::Sphere;

    /// A closed cylinder about the y axis (radius r, y from 0 to h, `seg` segments), wound
    /// outward when `outward`.
    fn cylinder(r: f32, h: f32, seg: u32, outward: bool) -> TriangleMesh {
        let mut positions = Vec::new();
        for k in 0..seg {
            let a = std::f32::consts::TAU * k as f32 / seg as f32;
            positions.push(Vec3::new(r * a.cos(), 0.0, r * a.sin()));
            positions.push(Vec3::new(r * a.cos(), h, r * a.sin()));
        }
        positions.push(Vec3::new(0.0, 0.0, 0.0));
        positions.push(Vec3::new(0.0, h, 0.0));
        let (cb, ct) = (2 * seg, 2 * seg + 1);
        let mut indices = Vec::new();
        for k in 0..seg {
            let (b0, t0, b1, t1) = (2 * k, 2 * k + 1, 2 * ((k + 1) % seg), 2 * ((k + 1) % seg) + 1);
            indices.push([b0, t0, b1]);
            indices.push([b1, t0, t1]);
            indices.push([cb, b0, b1]);
            indices.push([ct, t1, t0]);
        }
        if outward != is_outward(&positions, &indices) {
            for t in &mut indices {
                t.swap(1, 2);
            }
        }
        TriangleMesh { positions, normals: None, uvs: None, indices }
    }

    fn is_outward(p: &[Vec3], idx: &[[u32; 3]]) -> bool {
        let [a, b, c] = idx[0].map(|k| p[k as usize]);
        let n = (b - a).cross(c - a);
        n.dot(a - Vec3::new(0.0, 0.5, 0.0)) > 0.0
    }

    /// Brute force: the distance from `p` to the nearest point of any triangle or sphere.
    fn brute_distance(shapes: &[Shape], p: Vec3) -> f32 {
        let mut best = f64::INFINITY;
        for s in shapes {
            match s {
                Shape::Mesh(m) => {
                    for t in &m.indices {
                        let [a, b, c] = t.map(|k| m.positions[k as usize].as_dvec3());
                        let q = crate::math::geometry::closest_point_on_triangle(p.as_dvec3(), a, b, c);
                        best = best.min((q - p.as_dvec3()).length());
                    }
                }
                Shape::Sphere(s) => best = best.min(((p - s.center).length() - s.radius).abs() as f64),
            }
        }
        best as f32
    }

    /// A cylinder (either winding) inside a larger one and beside a sphere: the plane distance
    /// equals the brute-force distance to every surface at interior points, and the exit of a
    /// ray agrees with marching the brute-force distance along it (sphere tracing), with the
    /// facet's normal pointing out of the cylinder.
    #[test]
    fn convex_boundary_distance_and_exit_match_brute_force() {
        for outward in [true, false] {
            let inner = cylinder(0.03, 0.08, 128, outward);
            let outer = cylinder(0.0301, 0.0802, 96, true);
            let ball = Sphere { center: Vec3::new(0.1, 0.04, 0.0), radius: 0.02 };
            let shapes = vec![Shape::Mesh(inner), Shape::Mesh(outer), Shape::Sphere(ball)];
            let cb = ConvexBoundary::build(&shapes, 0).expect("a closed convex cylinder with nothing inside");
            assert_eq!(cb.plane_count(), 130);
            let mut rng = crate::math::sampling::Pcg32::new(3, 1);
            let mut hint = 0u32;
            for _ in 0..300 {
                let u = rng.next_2d();
                let (rr, a) = (0.0299 * rng.next_f32().sqrt(), std::f32::consts::TAU * u.x);
                let p = Vec3::new(rr * a.cos(), 0.0005 + 0.079 * u.y, rr * a.sin());
                let (d, e) = (cb.distance(p), brute_distance(&shapes, p));
                assert!((d - e).abs() <= 2e-7 + 1e-5 * e, "at {p}: planes {d}, brute force {e}");
                let w = crate::math::sampling::uniform_sphere(rng.next_2d());
                let (t, n) = cb.exit(p, w).expect("an exit");
                // From any hint, the facet test gives the same exit (the plane may differ only
                // where the ray leaves through an edge).
                for h in [hint, 0, 7, 129, 1000] {
                    let mut hh = h;
                    let (t2, n2) = cb.exit_near(p, w, &mut hh).expect("an exit");
                    assert!((t2 - t).abs() <= 1e-6 * t.max(1e-3) && (n2 - n).length() < 1e-3 || (t2 - t).abs() < 1e-7, "hint {h}: {t2} {n2} against {t} {n}");
                }
                let _ = cb.exit_near(p, w, &mut hint);
                // Sphere tracing to the first surface along the ray.
                let mut s = 0.0f32;
                for _ in 0..200 {
                    let step = brute_distance(&shapes, p + w * s);
                    if step < 1e-7 {
                        break;
                    }
                    s += step;
                }
                assert!((t - s).abs() < 1e-5, "exit at {t} m, sphere tracing {s} m");
                assert!(n.dot(w) > 0.0 && n.dot(p + w * t - Vec3::new(0.0, 0.04, 0.0)) > 0.0, "normal {n} points out");
            }
        }
    }

    /// A walk of small steps aiming at one far point, as the guide's probes do: the exit through
    /// the remembered facet equals the full search's.
    #[test]
    fn convex_boundary_exit_near_follows_a_walk() {
        let shapes = vec![Shape::Mesh(cylinder(0.03, 0.08, 128, true))];
        let cb = ConvexBoundary::build(&shapes, 0).unwrap();
        let target = Vec3::new(0.5, 0.6, -0.3);
        let mut rng = crate::math::sampling::Pcg32::new(5, 2);
        let (mut p, mut hint, mut same) = (Vec3::new(0.02, 0.05, 0.0), 0u32, 0);
        for _ in 0..2000 {
            let step = crate::math::sampling::uniform_sphere(rng.next_2d()) * 2e-4;
            if cb.distance(p + step) > 0.0 {
                p += step;
            }
            let d = (target - p).normalize();
            let before = hint;
            let (t, n) = cb.exit_near(p, d, &mut hint).unwrap();
            let (t0, n0) = cb.exit(p, d).unwrap();
            same += (hint == before) as u32;
            assert!((t - t0).abs() <= 1e-6 * t0 && (n - n0).length() < 1e-3, "{t} {n} against {t0} {n0}");
        }
        assert!(same > 1500, "the remembered facet served {same} of 2000 probes");
    }

    /// No bound where it would not be exact: an open mesh, a non-convex mesh, another surface
    /// reaching inside (a triangle or a sphere), or a sphere as the boundary.
    #[test]
    fn convex_boundary_refuses_what_it_cannot_bound() {
        let cyl = cylinder(0.03, 0.08, 32, true);
        let mut open = cyl.clone();
        open.indices.truncate(open.indices.len() - 1);
        assert!(ConvexBoundary::build(&[Shape::Mesh(open)], 0).is_none(), "open mesh");
        let mut dented = cyl.clone();
        dented.positions[0] *= 0.8;
        assert!(ConvexBoundary::build(&[Shape::Mesh(dented)], 0).is_none(), "non-convex mesh");
        let small = cylinder(0.01, 0.02, 16, true);
        assert!(ConvexBoundary::build(&[Shape::Mesh(cyl.clone()), Shape::Mesh(small)], 0).is_none(), "a mesh inside");
        let inside = Sphere { center: Vec3::new(0.0, 0.04, 0.0), radius: 0.005 };
        assert!(ConvexBoundary::build(&[Shape::Mesh(cyl.clone()), Shape::Sphere(inside)], 0).is_none(), "a sphere inside");
        let crossing = Sphere { center: Vec3::new(0.035, 0.04, 0.0), radius: 0.01 };
        assert!(ConvexBoundary::build(&[Shape::Mesh(cyl.clone()), Shape::Sphere(crossing)], 0).is_none(), "a sphere through the wall");
        assert!(ConvexBoundary::build(&[Shape::Sphere(inside)], 0).is_none(), "a sphere boundary");
        assert!(ConvexBoundary::build(&[Shape::Mesh(cyl)], 0).is_some());
    }
}
