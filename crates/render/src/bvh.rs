//! Bounding volume hierarchy over all triangles and spheres of a scene.
//!
//! Built top-down with the binned surface-area heuristic (Wald 2007), the large top-level
//! nodes binned in parallel and the two subtrees of every large node built in parallel with
//! rayon. The tree is flattened into an array of 32-byte nodes with the two children of every
//! inner node stored next to each other (one cache line), and the primitives are copied into
//! leaf order (the three vertices of each triangle) so a leaf is one contiguous read.
//! Closest-hit traversal tests both children, descends into the nearer one first and skips
//! stacked nodes that lie beyond the closest hit found so far; the any-hit (shadow) query stops
//! at the first hit.

use crate::geometry::{Aabb, Ray, RayTri, Sphere};
use crate::mesh::TriangleMesh;
use glam::Vec3;

/// A shape of the scene.
#[derive(Clone, Debug)]
pub enum Shape {
    /// A triangle mesh.
    Mesh(TriangleMesh),
    /// A sphere.
    Sphere(Sphere),
}

impl Shape {
    /// Number of primitives (triangles, or 1 for a sphere).
    pub fn primitive_count(&self) -> usize {
        match self {
            Shape::Mesh(m) => m.indices.len(),
            Shape::Sphere(_) => 1,
        }
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Mesh(m) => Aabb::from_points(&m.positions),
            Shape::Sphere(s) => s.bounds(),
        }
    }
}

/// The closest intersection found along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Index of the shape in the list given to [`Accel::build`].
    pub object: u32,
    /// Triangle index within the mesh (0 for a sphere).
    pub prim: u32,
    /// Barycentric coordinate of the triangle's second vertex (sphere: azimuth / 2π).
    pub u: f32,
    /// Barycentric coordinate of the third vertex (sphere: polar angle / π).
    pub v: f32,
}

/// Local geometry at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Position.
    pub p: Vec3,
    /// Geometric normal, unit: (p1−p0)×(p2−p0) for triangles (the front side is the
    /// counter-clockwise one), outward for spheres. Not flipped towards the ray.
    pub ng: Vec3,
    /// Shading normal, unit, on the same side as `ng` (interpolated vertex normals when the
    /// mesh has them, else `ng`).
    pub ns: Vec3,
    /// Shape index.
    pub object: u32,
    /// Primitive index within the shape.
    pub prim: u32,
}

/// Flattened BVH node, 32 bytes.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
struct Node {
    min: [f32; 3],
    /// Leaf: index of the first primitive. Inner: index of the left child (the right is next).
    offset: u32,
    max: [f32; 3],
    /// Leaf: primitive count (> 0). Inner: 0.
    count: u32,
}

const SPHERE_BIT: u32 = 0x8000_0000;
const MAX_LEAF: usize = 8;
const MAX_DEPTH: usize = 60;
const STACK: usize = 64;
const BINS: usize = 16;

/// A binned-SAH BVH over all triangles and spheres, flattened for traversal.
#[derive(Clone, Debug)]
pub struct Accel {
    shapes: Vec<Shape>,
    nodes: Vec<Node>,
    /// Triangle vertices in leaf order (sphere: centre, (radius, 0, 0), unused).
    verts: Vec<[Vec3; 3]>,
    /// (object, prim | SPHERE_BIT for spheres) in leaf order.
    ids: Vec<(u32, u32)>,
    bounds: Aabb,
}

#[derive(Clone, Copy, Debug)]
struct PrimRef {
    lo: Vec3,
    hi: Vec3,
    index: u32,
}

impl PrimRef {
    #[inline]
    fn centroid(&self) -> Vec3 {
        (self.lo + self.hi) * 0.5
    }
}

enum BuildNode {
    Leaf { lo: Vec3, hi: Vec3, start: usize, count: usize },
    Inner { lo: Vec3, hi: Vec3, children: Box<[BuildNode; 2]>, size: usize },
}

impl BuildNode {
    fn bounds(&self) -> (Vec3, Vec3) {
        match self {
            BuildNode::Leaf { lo, hi, .. } | BuildNode::Inner { lo, hi, .. } => (*lo, *hi),
        }
    }
    fn node_count(&self) -> usize {
        match self {
            BuildNode::Leaf { .. } => 1,
            BuildNode::Inner { size, .. } => *size,
        }
    }
}

#[derive(Clone, Copy)]
struct Bin {
    lo: Vec3,
    hi: Vec3,
    n: u32,
}

impl Default for Bin {
    fn default() -> Self {
        Bin { lo: Vec3::splat(f32::INFINITY), hi: Vec3::splat(f32::NEG_INFINITY), n: 0 }
    }
}

impl Bin {
    #[inline]
    fn add(&mut self, p: &PrimRef) {
        self.lo = self.lo.min(p.lo);
        self.hi = self.hi.max(p.hi);
        self.n += 1;
    }
    #[inline]
    fn merge(&mut self, o: &Bin) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
        self.n += o.n;
    }
}

#[inline]
fn half_area(lo: Vec3, hi: Vec3) -> f32 {
    let e = (hi - lo).max(Vec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

const PAR_THRESHOLD: usize = 4096;

fn bin_prims(prims: &[PrimRef], c_lo: Vec3, scale: Vec3) -> [[Bin; BINS]; 3] {
    let fold = |mut bins: [[Bin; BINS]; 3], p: &PrimRef| {
        let c = p.centroid();
        let b = ((c - c_lo) * scale).to_array();
        for (axis, bins_a) in bins.iter_mut().enumerate() {
            let i = (b[axis] as usize).min(BINS - 1);
            bins_a[i].add(p);
        }
        bins
    };
    if prims.len() > 65536 {
        use rayon::prelude::*;
        prims
            .par_chunks(16384)
            .map(|ch| ch.iter().fold([[Bin::default(); BINS]; 3], fold))
            .reduce(
                || [[Bin::default(); BINS]; 3],
                |mut a, b| {
                    for axis in 0..3 {
                        for i in 0..BINS {
                            a[axis][i].merge(&b[axis][i]);
                        }
                    }
                    a
                },
            )
    } else {
        prims.iter().fold([[Bin::default(); BINS]; 3], fold)
    }
}

fn prim_bounds(prims: &[PrimRef]) -> (Vec3, Vec3, Vec3, Vec3) {
    let f = |(lo, hi, clo, chi): (Vec3, Vec3, Vec3, Vec3), p: &PrimRef| {
        let c = p.centroid();
        (lo.min(p.lo), hi.max(p.hi), clo.min(c), chi.max(c))
    };
    let init = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY), Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    if prims.len() > 65536 {
        use rayon::prelude::*;
        prims
            .par_chunks(16384)
            .map(|ch| ch.iter().fold(init, f))
            .reduce(|| init, |a, b| (a.0.min(b.0), a.1.max(b.1), a.2.min(b.2), a.3.max(b.3)))
    } else {
        prims.iter().fold(init, f)
    }
}

fn build_rec(prims: &mut [PrimRef], start: usize, depth: usize) -> BuildNode {
    let n = prims.len();
    let (lo, hi, c_lo, c_hi) = prim_bounds(prims);
    let leaf = BuildNode::Leaf { lo, hi, start, count: n };
    if n <= 1 {
        return leaf;
    }
    let c_ext = c_hi - c_lo;
    // SAH split search over the three axes.
    let mut best = (f32::INFINITY, 0usize, 0usize); // cost, axis, bin boundary (left = bins < k)
    let degenerate = !(c_ext.max_element() > 0.0);
    if !degenerate {
        let scale = Vec3::select(c_ext.cmpgt(Vec3::ZERO), Vec3::splat(BINS as f32 * (1.0 - 1e-6)) / c_ext, Vec3::ZERO);
        let bins = bin_prims(prims, c_lo, scale);
        for (axis, bins_a) in bins.iter().enumerate() {
            if !(c_ext[axis] > 0.0) {
                continue;
            }
            let mut right_cost = [0.0f32; BINS];
            let mut acc = Bin::default();
            for i in (1..BINS).rev() {
                acc.merge(&bins_a[i]);
                right_cost[i] = if acc.n > 0 { half_area(acc.lo, acc.hi) * acc.n as f32 } else { 0.0 };
            }
            let mut accl = Bin::default();
            for k in 1..BINS {
                accl.merge(&bins_a[k - 1]);
                if accl.n == 0 || accl.n as usize == n {
                    continue;
                }
                let cost = half_area(accl.lo, accl.hi) * accl.n as f32 + right_cost[k];
                if cost < best.0 {
                    best = (cost, axis, k);
                }
            }
        }
        // Leaf if splitting does not pay: C_trav = 1, C_isect = 1 (in units of one triangle test).
        let leaf_cost = n as f32;
        let split_cost = 1.0 + best.0 / half_area(lo, hi).max(f32::MIN_POSITIVE);
        if n <= MAX_LEAF && (split_cost >= leaf_cost || !best.0.is_finite()) || depth >= MAX_DEPTH {
            return leaf;
        }
    } else if n <= MAX_LEAF || depth >= MAX_DEPTH {
        return leaf;
    }
    let mid = if best.0.is_finite() {
        let (axis, k) = (best.1, best.2);
        let s = BINS as f32 * (1.0 - 1e-6) / c_ext[axis];
        let lo_a = c_lo[axis];
        partition(prims, |p| (((p.centroid()[axis] - lo_a) * s) as usize).min(BINS - 1) < k)
    } else {
        // All centroids coincide (or binning failed): split by count along the longest axis.
        let axis = Aabb { min: lo, max: hi }.longest_axis();
        prims.select_nth_unstable_by(n / 2, |a, b| a.centroid()[axis].total_cmp(&b.centroid()[axis]));
        n / 2
    };
    let mid = if mid == 0 || mid == n { n / 2 } else { mid };
    let (l, r) = prims.split_at_mut(mid);
    let (a, b) = if n > PAR_THRESHOLD {
        rayon::join(|| build_rec(l, start, depth + 1), || build_rec(r, start + mid, depth + 1))
    } else {
        (build_rec(l, start, depth + 1), build_rec(r, start + mid, depth + 1))
    };
    let size = 1 + a.node_count() + b.node_count();
    BuildNode::Inner { lo, hi, children: Box::new([a, b]), size }
}

fn partition(prims: &mut [PrimRef], pred: impl Fn(&PrimRef) -> bool) -> usize {
    let mut i = 0;
    let mut j = prims.len();
    while i < j {
        if pred(&prims[i]) {
            i += 1;
        } else {
            j -= 1;
            prims.swap(i, j);
        }
    }
    i
}

/// Write `node`'s children at `nodes[at]` and `nodes[at+1]`, their subtrees after `next`.
/// Returns the next free index.
fn flatten(children: &[BuildNode; 2], nodes: &mut [Node], at: usize, mut next: usize) -> usize {
    for (k, c) in children.iter().enumerate() {
        let (lo, hi) = c.bounds();
        let slot = at + k;
        match c {
            BuildNode::Leaf { start, count, .. } => {
                nodes[slot] = Node { min: lo.to_array(), offset: *start as u32, max: hi.to_array(), count: *count as u32 };
            }
            BuildNode::Inner { children: cc, .. } => {
                let child_at = next;
                nodes[slot] = Node { min: lo.to_array(), offset: child_at as u32, max: hi.to_array(), count: 0 };
                next = flatten(cc, nodes, child_at, next + 2);
            }
        }
    }
    next
}

/// Precomputed per-ray data for box tests.
#[derive(Clone, Copy)]
struct RayBox {
    inv: [f32; 3],
    o: [f32; 3],
    /// Some direction component is zero (or subnormal): use the careful test.
    parallel: bool,
}

impl RayBox {
    #[inline(always)]
    fn new(ray: &Ray) -> RayBox {
        let inv = ray.d.recip();
        RayBox { inv: inv.to_array(), o: ray.o.to_array(), parallel: !inv.is_finite() }
    }

    /// Box test for rays with a zero direction component: such a slab holds the ray for all t
    /// when the origin is inside it (boundary included), for no t otherwise.
    #[inline(never)]
    fn hit_parallel(&self, n: &Node, t_min: f32, t_max: f32) -> f32 {
        let (mut near, mut far) = (t_min, t_max);
        for a in 0..3 {
            if self.inv[a].is_finite() {
                let t0 = (n.min[a] - self.o[a]) * self.inv[a];
                let t1 = (n.max[a] - self.o[a]) * self.inv[a];
                near = near.max(t0.min(t1));
                far = far.min(t0.max(t1) * ROUND_UP);
            } else if !(self.o[a] >= n.min[a] && self.o[a] <= n.max[a]) {
                return f32::INFINITY;
            }
        }
        if near <= far {
            near
        } else {
            f32::INFINITY
        }
    }

    /// Entry distance into the node's box within (t_min, t_max), or +∞ when missed.
    #[inline(always)]
    fn hit(&self, n: &Node, t_min: f32, t_max: f32) -> f32 {
        if self.parallel {
            return self.hit_parallel(n, t_min, t_max);
        }
        let tx0 = (n.min[0] - self.o[0]) * self.inv[0];
        let tx1 = (n.max[0] - self.o[0]) * self.inv[0];
        let ty0 = (n.min[1] - self.o[1]) * self.inv[1];
        let ty1 = (n.max[1] - self.o[1]) * self.inv[1];
        let tz0 = (n.min[2] - self.o[2]) * self.inv[2];
        let tz1 = (n.max[2] - self.o[2]) * self.inv[2];
        let near = tx0.min(tx1).max(ty0.min(ty1)).max(tz0.min(tz1)).max(t_min);
        let far = tx0.max(tx1).min(ty0.max(ty1)).min(tz0.max(tz1)).min(t_max) * ROUND_UP;
        if near <= far {
            near
        } else {
            f32::INFINITY
        }
    }
}

/// 1 + 2γ₃: makes the far slab distance conservative against rounding (pbrt-v4).
const ROUND_UP: f32 = 1.000_000_4;

impl Accel {
    /// Build the hierarchy over every triangle and sphere of `shapes`.
    pub fn build(shapes: Vec<Shape>) -> Accel {
        let total: usize = shapes.iter().map(Shape::primitive_count).sum();
        let mut prims = Vec::with_capacity(total);
        let mut ids_all = Vec::with_capacity(total);
        for (o, s) in shapes.iter().enumerate() {
            match s {
                Shape::Mesh(m) => {
                    for (i, t) in m.indices.iter().enumerate() {
                        let (a, b, c) = (m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]);
                        prims.push(PrimRef { lo: a.min(b).min(c), hi: a.max(b).max(c), index: prims.len() as u32 });
                        ids_all.push((o as u32, i as u32));
                    }
                }
                Shape::Sphere(sp) => {
                    let b = sp.bounds();
                    prims.push(PrimRef { lo: b.min.min(b.max), hi: b.max.max(b.min), index: prims.len() as u32 });
                    ids_all.push((o as u32, SPHERE_BIT));
                }
            }
        }
        let mut nodes = Vec::new();
        let mut bounds = Aabb::EMPTY;
        if !prims.is_empty() {
            let root = build_rec(&mut prims, 0, 0);
            let (lo, hi) = root.bounds();
            bounds = Aabb { min: lo, max: hi };
            // Node 0 is the root; node 1 is padding so that sibling pairs start at even indices.
            nodes = vec![Node::default(); root.node_count() + 1];
            match &root {
                BuildNode::Leaf { start, count, .. } => {
                    nodes[0] = Node { min: lo.to_array(), offset: *start as u32, max: hi.to_array(), count: *count as u32 };
                }
                BuildNode::Inner { children, .. } => {
                    nodes[0] = Node { min: lo.to_array(), offset: 2, max: hi.to_array(), count: 0 };
                    let end = flatten(children, &mut nodes, 2, 4);
                    debug_assert_eq!(end, nodes.len());
                }
            }
        }
        let mut verts = Vec::with_capacity(prims.len());
        let mut ids = Vec::with_capacity(prims.len());
        for p in &prims {
            let (o, i) = ids_all[p.index as usize];
            ids.push((o, i));
            verts.push(match &shapes[o as usize] {
                Shape::Mesh(m) => m.triangle(i as usize),
                Shape::Sphere(s) => [s.center, Vec3::new(s.radius, 0.0, 0.0), Vec3::ZERO],
            });
        }
        Accel { shapes, nodes, verts, ids, bounds }
    }

    /// Bounding box of the whole scene.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The shape with index `object`.
    pub fn shape(&self, object: u32) -> &Shape {
        &self.shapes[object as usize]
    }

    /// All shapes, in the order given to `build`.
    pub fn shapes(&self) -> &[Shape] {
        &self.shapes
    }

    /// Number of nodes of the flattened tree.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest hit with t in (ray.t_min, ray.t_max).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let rb = RayBox::new(ray);
        let rt = RayTri::new(ray);
        let mut t_max = ray.t_max;
        let mut best: Option<(usize, f32, f32)> = None;
        let mut stack = [(0u32, 0f32); STACK];
        let mut sp = 0usize;
        let root = &self.nodes[0];
        if rb.hit(root, ray.t_min, t_max) == f32::INFINITY {
            return None;
        }
        let mut node = root;
        loop {
            if node.count > 0 {
                let start = node.offset as usize;
                let end = start + node.count as usize;
                for i in start..end {
                    let v = &self.verts[i];
                    if self.ids[i].1 & SPHERE_BIT == 0 {
                        if let Some((t, u, w)) = rt.intersect(v[0], v[1], v[2], ray.t_min, t_max) {
                            t_max = t;
                            best = Some((i, u, w));
                        }
                    } else if let Some(t) = (Sphere { center: v[0], radius: v[1].x }).intersect(&Ray { t_max, ..*ray }) {
                        t_max = t;
                        best = Some((i, 0.0, 0.0));
                    }
                }
            } else {
                let l = node.offset as usize;
                let (a, b) = (&self.nodes[l], &self.nodes[l + 1]);
                let ta = rb.hit(a, ray.t_min, t_max);
                let tb = rb.hit(b, ray.t_min, t_max);
                if ta != f32::INFINITY {
                    if tb != f32::INFINITY {
                        let (near, far, tfar) = if ta <= tb { (a, l + 1, tb) } else { (b, l, ta) };
                        stack[sp] = (far as u32, tfar);
                        sp += 1;
                        node = near;
                    } else {
                        node = a;
                    }
                    continue;
                } else if tb != f32::INFINITY {
                    node = b;
                    continue;
                }
            }
            // Pop the next node that may still hold a closer hit.
            loop {
                if sp == 0 {
                    return best.map(|(i, u, v)| self.make_hit(i, u, v, t_max, ray));
                }
                sp -= 1;
                let (n, tn) = stack[sp];
                if tn <= t_max * ROUND_UP {
                    node = &self.nodes[n as usize];
                    break;
                }
            }
        }
    }

    fn make_hit(&self, i: usize, u: f32, v: f32, t: f32, ray: &Ray) -> Hit {
        let (object, prim) = self.ids[i];
        if prim & SPHERE_BIT != 0 {
            let c = self.verts[i][0];
            let d = (ray.at(t) - c).normalize_or_zero();
            let phi = d.z.atan2(d.x);
            let phi = if phi < 0.0 { phi + 2.0 * std::f32::consts::PI } else { phi };
            let theta = d.y.clamp(-1.0, 1.0).acos();
            Hit { t, object, prim: 0, u: phi / (2.0 * std::f32::consts::PI), v: theta / std::f32::consts::PI }
        } else {
            Hit { t, object, prim, u, v }
        }
    }

    /// True when anything is hit with t in (ray.t_min, ray.t_max) (shadow rays).
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let rb = RayBox::new(ray);
        let rt = RayTri::new(ray);
        let t_max = ray.t_max;
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        let root = &self.nodes[0];
        if rb.hit(root, ray.t_min, t_max) == f32::INFINITY {
            return false;
        }
        let mut node = root;
        loop {
            if node.count > 0 {
                let start = node.offset as usize;
                let end = start + node.count as usize;
                for i in start..end {
                    let v = &self.verts[i];
                    let hit = if self.ids[i].1 & SPHERE_BIT == 0 {
                        rt.intersect(v[0], v[1], v[2], ray.t_min, t_max).is_some()
                    } else {
                        (Sphere { center: v[0], radius: v[1].x }).intersect(ray).is_some()
                    };
                    if hit {
                        return true;
                    }
                }
            } else {
                let l = node.offset as usize;
                let (a, b) = (&self.nodes[l], &self.nodes[l + 1]);
                let ha = rb.hit(a, ray.t_min, t_max) != f32::INFINITY;
                let hb = rb.hit(b, ray.t_min, t_max) != f32::INFINITY;
                if ha {
                    if hb {
                        stack[sp] = (l + 1) as u32;
                        sp += 1;
                    }
                    node = a;
                    continue;
                } else if hb {
                    node = b;
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            node = &self.nodes[stack[sp] as usize];
        }
    }

    /// Position and normals at `hit` (found for `ray`).
    pub fn surface_point(&self, ray: &Ray, hit: &Hit) -> SurfacePoint {
        match self.shape(hit.object) {
            Shape::Sphere(s) => {
                let n = (ray.at(hit.t) - s.center).normalize_or_zero();
                let n = if n == Vec3::ZERO { Vec3::Z } else { n };
                SurfacePoint { p: s.center + n * s.radius.abs(), ng: n, ns: n, object: hit.object, prim: 0 }
            }
            Shape::Mesh(m) => {
                let t = m.indices[hit.prim as usize];
                let [a, b, c] = m.triangle(hit.prim as usize);
                let w = 1.0 - hit.u - hit.v;
                let p = w * a + hit.u * b + hit.v * c;
                let mut ng = (b - a).cross(c - a).normalize_or_zero();
                if ng == Vec3::ZERO {
                    ng = -ray.d.normalize_or_zero();
                }
                let ns = match &m.normals {
                    Some(ns) => {
                        let n = (w * ns[t[0] as usize] + hit.u * ns[t[1] as usize] + hit.v * ns[t[2] as usize]).normalize_or_zero();
                        if n == Vec3::ZERO {
                            ng
                        } else if n.dot(ng) < 0.0 {
                            -n
                        } else {
                            n
                        }
                    }
                    None => ng,
                };
                SurfacePoint { p, ng, ns, object: hit.object, prim: hit.prim }
            }
        }
    }

    /// Closest hit by testing every primitive (reference for tests).
    pub fn intersect_brute_force(&self, ray: &Ray) -> Option<Hit> {
        let rt = RayTri::new(ray);
        let mut t_max = ray.t_max;
        let mut best = None;
        for (o, s) in self.shapes.iter().enumerate() {
            match s {
                Shape::Mesh(m) => {
                    for i in 0..m.indices.len() {
                        let [a, b, c] = m.triangle(i);
                        if let Some((t, u, v)) = rt.intersect(a, b, c, ray.t_min, t_max) {
                            t_max = t;
                            best = Some(Hit { t, object: o as u32, prim: i as u32, u, v });
                        }
                    }
                }
                Shape::Sphere(sp) => {
                    if let Some(t) = sp.intersect(&Ray { t_max, ..*ray }) {
                        t_max = t;
                        best = Some(Hit { t, object: o as u32, prim: 0, u: 0.0, v: 0.0 });
                    }
                }
            }
        }
        best.map(|h| {
            if matches!(self.shapes[h.object as usize], Shape::Sphere(_)) {
                let c = match &self.shapes[h.object as usize] {
                    Shape::Sphere(s) => s.center,
                    _ => unreachable!(),
                };
                let d = (ray.at(h.t) - c).normalize_or_zero();
                let phi = d.z.atan2(d.x);
                let phi = if phi < 0.0 { phi + 2.0 * std::f32::consts::PI } else { phi };
                Hit { u: phi / (2.0 * std::f32::consts::PI), v: d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI, ..h }
            } else {
                h
            }
        })
    }
}
