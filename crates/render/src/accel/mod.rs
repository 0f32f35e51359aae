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

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a < b)` is deliberate: it is true for NaN.

use crate::math::geometry::{closest_point_on_triangle, Aabb, Ray};
use crate::shape::triangle::RayTri;
use crate::shape::sphere::{sphere_uv, Sphere};
use crate::shape::Shape;
use glam::{Vec3, Vec4};

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

/// Wide node: the boxes of four children in SoA layout, `b[side][axis][child]` (side 0 = min,
/// 1 = max), and the children's references. 128 bytes (two cache lines).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(128))]
struct Node4 {
    b: [[[f32; 4]; 3]; 2],
    child: [u32; 4],
    _pad: [u32; 4],
}

impl Node4 {
    const EMPTY: Node4 = Node4 {
        b: [[[f32::INFINITY; 4]; 3], [[f32::NEG_INFINITY; 4]; 3]],
        child: [EMPTY_CHILD; 4],
        _pad: [0; 4],
    };
}

/// Four primitives in SoA layout: `v[vertex][axis][lane]` (a sphere lane: centre in vertex 0,
/// radius in vertex 1's x). Unused lanes hold NaN and never hit.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Packet {
    v: [[[f32; 4]; 3]; 3],
}

/// Child reference of an empty slot (its box is empty, so it is never entered).
const EMPTY_CHILD: u32 = u32::MAX;
/// Child reference flag of a leaf: bits 27..30 hold the packet count, bits 0..26 the first packet.
const LEAF_BIT: u32 = 1 << 31;
const LEAF_SHIFT: u32 = 27;
const LEAF_OFFSET: u32 = (1 << LEAF_SHIFT) - 1;
/// Lane id of an unused lane.
const NO_PRIM: (u32, u32) = (u32::MAX, u32::MAX);

const SPHERE_BIT: u32 = 0x8000_0000;
const MAX_LEAF: usize = 8;
const MAX_DEPTH: usize = 60;
/// Traversal stack size on the machine stack; deeper trees use a heap stack.
const STACK: usize = 64;
/// Traversal stack size for shallow trees (small scenes).
const SMALL_STACK: usize = 16;
const BINS: usize = 16;

/// A binned-SAH BVH over all triangles and spheres, flattened for traversal.
#[derive(Clone, Debug)]
pub struct Accel {
    shapes: Vec<Shape>,
    /// Wide nodes; the root is node 0.
    nodes: Vec<Node4>,
    /// Primitives in leaf order, four per packet.
    packets: Vec<Packet>,
    /// (object, prim | SPHERE_BIT for spheres) of each lane, NO_PRIM for unused lanes.
    ids: Vec<[(u32, u32); 4]>,
    /// Whether a packet holds a sphere (then it is tested lane by lane).
    has_sphere: Vec<bool>,
    bounds: Aabb,
    /// Traversal stack entries the tree can need (3 per level below the root, plus one).
    stack_needed: usize,
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

/// Cost of a node visit relative to one 4-wide triangle test (SAH).
const TRAVERSAL_COST: f32 = 1.0;

/// SAH cost of intersecting `n` primitives: one 4-wide test per started group of 4.
#[inline]
fn leaf_cost(n: usize) -> f32 {
    n.div_ceil(4) as f32
}

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
    if depth >= MAX_DEPTH {
        // Too deep for the SAH to be trusted (pathological input): leaf, or a median split.
        if n <= MAX_LEAF {
            return leaf;
        }
    } else if !degenerate {
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
                right_cost[i] = if acc.n > 0 { half_area(acc.lo, acc.hi) * leaf_cost(acc.n as usize) } else { 0.0 };
            }
            let mut accl = Bin::default();
            for k in 1..BINS {
                accl.merge(&bins_a[k - 1]);
                if accl.n == 0 || accl.n as usize == n {
                    continue;
                }
                let cost = half_area(accl.lo, accl.hi) * leaf_cost(accl.n as usize) + right_cost[k];
                if cost < best.0 {
                    best = (cost, axis, k);
                }
            }
        }
        // Leaf if splitting does not pay (costs in units of one 4-wide triangle test).
        let split_cost = TRAVERSAL_COST + best.0 / half_area(lo, hi).max(f32::MIN_POSITIVE);
        if n <= MAX_LEAF && (split_cost >= leaf_cost(n) || !best.0.is_finite()) {
            return leaf;
        }
    } else if n <= MAX_LEAF {
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

/// Output of the collapse of the binary tree into wide nodes.
struct Wide<'a> {
    shapes: &'a [Shape],
    prims: &'a [PrimRef],
    ids_all: &'a [(u32, u32)],
    nodes: Vec<Node4>,
    packets: Vec<Packet>,
    ids: Vec<[(u32, u32); 4]>,
    has_sphere: Vec<bool>,
    depth: usize,
    max_depth: usize,
}

impl Wide<'_> {
    /// Emit the primitives `start..start+count` as packets; returns the leaf reference.
    fn leaf(&mut self, start: usize, count: usize) -> u32 {
        let first = self.packets.len();
        for chunk in self.prims[start..start + count].chunks(4) {
            let mut pk = Packet { v: [[[f32::NAN; 4]; 3]; 3] };
            let mut ids = [NO_PRIM; 4];
            let mut sphere = false;
            for (lane, p) in chunk.iter().enumerate() {
                let (o, i) = self.ids_all[p.index as usize];
                ids[lane] = (o, i);
                let verts = match &self.shapes[o as usize] {
                    Shape::Mesh(m) => m.triangle(i as usize),
                    Shape::Sphere(s) => {
                        sphere = true;
                        [s.center, Vec3::new(s.radius, 0.0, 0.0), Vec3::ZERO]
                    }
                };
                for (k, v) in verts.iter().enumerate() {
                    for axis in 0..3 {
                        pk.v[k][axis][lane] = v[axis];
                    }
                }
            }
            self.packets.push(pk);
            self.ids.push(ids);
            self.has_sphere.push(sphere);
        }
        let n = self.packets.len() - first;
        assert!(n < 16 && first <= LEAF_OFFSET as usize, "BVH leaf too large or too many primitives");
        LEAF_BIT | ((n as u32) << LEAF_SHIFT) | first as u32
    }

    /// Emit the wide node for an inner node of the binary tree; returns its index.
    fn inner(&mut self, children: &[BuildNode; 2]) -> u32 {
        // Open the largest inner grandchildren until there are four children.
        let mut list: Vec<&BuildNode> = vec![&children[0], &children[1]];
        while list.len() < 4 {
            let pick = list
                .iter()
                .enumerate()
                .filter(|(_, c)| matches!(c, BuildNode::Inner { .. }))
                .max_by(|a, b| {
                    let (la, ha) = a.1.bounds();
                    let (lb, hb) = b.1.bounds();
                    half_area(la, ha).total_cmp(&half_area(lb, hb))
                })
                .map(|(i, _)| i);
            let Some(i) = pick else { break };
            let BuildNode::Inner { children: cc, .. } = list[i] else { unreachable!() };
            list[i] = &cc[0];
            list.push(&cc[1]);
        }
        let index = self.nodes.len();
        self.nodes.push(Node4::EMPTY);
        let mut node = Node4::EMPTY;
        for (k, c) in list.iter().enumerate() {
            let (lo, hi) = c.bounds();
            for axis in 0..3 {
                node.b[0][axis][k] = lo[axis];
                node.b[1][axis][k] = hi[axis];
            }
            node.child[k] = self.child(c);
        }
        self.nodes[index] = node;
        index as u32
    }

    fn child(&mut self, c: &BuildNode) -> u32 {
        match c {
            BuildNode::Leaf { start, count, .. } => self.leaf(*start, *count),
            BuildNode::Inner { children, .. } => {
                self.depth += 1;
                self.max_depth = self.max_depth.max(self.depth);
                let r = self.inner(children);
                self.depth -= 1;
                r
            }
        }
    }
}

/// Per-ray constants for box and triangle tests.
#[derive(Clone, Copy)]
struct Pre {
    inv: [f32; 3],
    o: [f32; 3],
    /// For each axis, which side (0 = min, 1 = max) of a box the ray enters through.
    near_side: [usize; 3],
    /// Some direction component is zero (or its inverse overflows): use the careful box test.
    parallel: bool,
    rt: RayTri,
    /// Permuted axes (kx, ky, kz) of the watertight test, each < 3.
    k: [usize; 3],
    o4: [Vec4; 3],
    inv4: [Vec4; 3],
}

impl Pre {
    #[inline(always)]
    fn new(ray: &Ray) -> Pre {
        let inv = ray.d.recip();
        let rt = RayTri::new(ray);
        Pre {
            inv: inv.to_array(),
            o: ray.o.to_array(),
            near_side: [(inv.x < 0.0) as usize, (inv.y < 0.0) as usize, (inv.z < 0.0) as usize],
            // Also rays with a non-finite origin or direction (not `traceable`): the careful
            // test hits nothing for them. x·0 is 0 for finite x and NaN otherwise, so one
            // comparison tests all nine numbers.
            parallel: {
                let z = ray.o * 0.0 + ray.d * 0.0 + inv * 0.0;
                !(z.x + z.y + z.z == 0.0)
            },
            k: [rt.k[0].min(2), rt.k[1].min(2), rt.k[2].min(2)],
            rt,
            o4: [Vec4::splat(ray.o.x), Vec4::splat(ray.o.y), Vec4::splat(ray.o.z)],
            inv4: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
        }
    }

    /// Entry distances of the four child boxes and a bit mask of those hit within (t_min, t_max).
    #[inline(always)]
    fn hit4(&self, n: &Node4, t_min: f32, t_max: f32) -> ([f32; 4], u32) {
        if self.parallel {
            return self.hit4_parallel(n, t_min, t_max);
        }
        let (sx, sy, sz) = (self.near_side[0] & 1, self.near_side[1] & 1, self.near_side[2] & 1);
        let tnx = (Vec4::from_array(n.b[sx][0]) - self.o4[0]) * self.inv4[0];
        let tny = (Vec4::from_array(n.b[sy][1]) - self.o4[1]) * self.inv4[1];
        let tnz = (Vec4::from_array(n.b[sz][2]) - self.o4[2]) * self.inv4[2];
        let tfx = (Vec4::from_array(n.b[sx ^ 1][0]) - self.o4[0]) * self.inv4[0];
        let tfy = (Vec4::from_array(n.b[sy ^ 1][1]) - self.o4[1]) * self.inv4[1];
        let tfz = (Vec4::from_array(n.b[sz ^ 1][2]) - self.o4[2]) * self.inv4[2];
        let near = tnx.max(tny).max(tnz.max(Vec4::splat(t_min)));
        let far = tfx.min(tfy).min(tfz.min(Vec4::splat(t_max))) * ROUND_UP;
        (near.to_array(), near.cmple(far).bitmask())
    }

    /// Box test for rays with a zero direction component: such a slab holds the ray for all t
    /// when the origin is inside it (boundary included), for no t otherwise.
    #[inline(never)]
    fn hit4_parallel(&self, n: &Node4, t_min: f32, t_max: f32) -> ([f32; 4], u32) {
        let mut tn = [0.0f32; 4];
        if self.o.iter().any(|x| !x.is_finite()) || self.inv.iter().any(|x| x.is_nan() || *x == 0.0) {
            return (tn, 0); // an untraceable ray (non-finite origin, NaN direction) hits nothing
        }
        let mut hit = 0u32;
        for i in 0..4 {
            let (mut near, mut far) = (t_min, t_max);
            let mut inside = true;
            for a in 0..3 {
                let (lo, hi) = (n.b[0][a][i], n.b[1][a][i]);
                if self.inv[a].is_finite() {
                    let t0 = (lo - self.o[a]) * self.inv[a];
                    let t1 = (hi - self.o[a]) * self.inv[a];
                    near = near.max(t0.min(t1));
                    far = far.min(t0.max(t1) * ROUND_UP);
                } else if !(self.o[a] >= lo && self.o[a] <= hi) {
                    inside = false;
                }
            }
            tn[i] = near;
            hit |= ((inside && near <= far) as u32) << i;
        }
        (tn, hit)
    }
}

/// Rays traversed together by [`Accel::intersect_batch`].
const BATCH: usize = 8;

/// State of one closest-hit traversal of a batch.
struct Trav {
    pre: Pre,
    index: usize,
    cur: u32,
    sp: usize,
    t_max: f32,
    best: Option<(usize, usize, f32, f32)>,
    stack: [(u32, f32); STACK],
}

impl Trav {
    #[inline(always)]
    fn new(ray: &Ray, index: usize) -> Trav {
        Trav { pre: Pre::new(ray), index, cur: 0, sp: 0, t_max: ray.t_max, best: None, stack: [(0, 0.0); STACK] }
    }
}

/// Result of a 4-wide triangle test.
struct Lanes {
    t: [f32; 4],
    u: [f32; 4],
    v: [f32; 4],
    /// Bit mask of lanes hit within (t_min, t_max).
    ok: u32,
    /// Bit mask of lanes with an edge function exactly 0: redo them with the scalar test (f64
    /// fallback, tie rule).
    exact: u32,
}

impl Packet {
    /// Watertight test of the four triangles, the same arithmetic as [`RayTri::intersect`]
    /// lane by lane (so results agree bit for bit).
    #[inline(always)]
    fn intersect(&self, pre: &Pre, t_min: f32, t_max: f32) -> Lanes {
        let [kx, ky, kz] = pre.k;
        let (ox, oy, oz) = (Vec4::splat(pre.o[kx]), Vec4::splat(pre.o[ky]), Vec4::splat(pre.o[kz]));
        let (sx, sy, sz) = (Vec4::splat(pre.rt.s.x), Vec4::splat(pre.rt.s.y), Vec4::splat(pre.rt.s.z));
        let v = &self.v;
        let az = Vec4::from_array(v[0][kz]) - oz;
        let bz = Vec4::from_array(v[1][kz]) - oz;
        let cz = Vec4::from_array(v[2][kz]) - oz;
        let ax = (Vec4::from_array(v[0][kx]) - ox) - sx * az;
        let ay = (Vec4::from_array(v[0][ky]) - oy) - sy * az;
        let bx = (Vec4::from_array(v[1][kx]) - ox) - sx * bz;
        let by = (Vec4::from_array(v[1][ky]) - oy) - sy * bz;
        let cx = (Vec4::from_array(v[2][kx]) - ox) - sx * cz;
        let cy = (Vec4::from_array(v[2][ky]) - oy) - sy * cz;
        let e0 = cx * by - cy * bx;
        let e1 = ax * cy - ay * cx;
        let e2 = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let pos = e0.cmpge(zero) & e1.cmpge(zero) & e2.cmpge(zero);
        let neg = e0.cmple(zero) & e1.cmple(zero) & e2.cmple(zero);
        let exact = e0.cmpeq(zero) | e1.cmpeq(zero) | e2.cmpeq(zero);
        if (pos | neg | exact).bitmask() == 0 {
            // Every lane misses on an edge test: skip the depth and the division.
            return Lanes { t: [0.0; 4], u: [0.0; 4], v: [0.0; 4], ok: 0, exact: 0 };
        }
        let det = e0 + e1 + e2;
        let t_scaled = sz * (e0 * az + e1 * bz + e2 * cz);
        let inv_det = Vec4::ONE / det;
        let t = t_scaled * inv_det;
        let ok = (pos | neg) & det.cmpne(zero) & t.cmpgt(Vec4::splat(t_min)) & t.cmplt(Vec4::splat(t_max));
        Lanes { t: t.to_array(), u: (e1 * inv_det).to_array(), v: (e2 * inv_det).to_array(), ok: ok.bitmask(), exact: exact.bitmask() }
    }

    #[inline(always)]
    fn vertices(&self, lane: usize) -> [Vec3; 3] {
        let v = &self.v;
        [0, 1, 2].map(|k| Vec3::new(v[k][0][lane], v[k][1][lane], v[k][2][lane]))
    }
}

/// Sort a node's hit children by entry distance `key`, farthest first (insertion sort: at most 4).
#[inline(always)]
fn far_first<T: Copy>(c: &mut [T], key: impl Fn(&T) -> f32) {
    for i in 1..c.len() {
        let x = c[i];
        let mut j = i;
        while j > 0 && key(&c[j - 1]) < key(&x) {
            c[j] = c[j - 1];
            j -= 1;
        }
        c[j] = x;
    }
}

/// 1 + 2γ₃: makes the far slab distance conservative against rounding (pbrt-v4).
const ROUND_UP: f32 = 1.000_000_4;

/// A ray the traversals can follow: finite origin and direction. Box tests of a ray with a NaN
/// coordinate compare as "hit" in the SIMD min/max (which return the other operand), so such a
/// ray would enter empty child slots; it hits nothing instead.
#[inline(always)]
fn traceable(ray: &Ray) -> bool {
    ray.o.is_finite() && ray.d.is_finite()
}

impl Accel {
    /// Build the hierarchy over every triangle and sphere of `shapes`. Triangles with an
    /// out-of-range index are left out (meshes from [`crate::shape::mesh::TriangleMesh::load`] are validated already).
    pub fn build(shapes: Vec<Shape>) -> Accel {
        let total: usize = shapes.iter().map(Shape::primitive_count).sum();
        let mut prims = Vec::with_capacity(total);
        let mut ids_all = Vec::with_capacity(total);
        for (o, s) in shapes.iter().enumerate() {
            match s {
                Shape::Mesh(m) => {
                    for (i, t) in m.indices.iter().enumerate() {
                        let n = m.positions.len();
                        if t.iter().any(|&k| k as usize >= n) {
                            continue; // invalid (TriangleMesh::validate reports it); never hit
                        }
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
        let mut bounds = Aabb::EMPTY;
        let mut wide = Wide { shapes: &shapes, prims: &[], ids_all: &ids_all, nodes: Vec::new(), packets: Vec::new(), ids: Vec::new(), has_sphere: Vec::new(), depth: 0, max_depth: 0 };
        if !prims.is_empty() {
            let root = build_rec(&mut prims, 0, 0);
            let (lo, hi) = root.bounds();
            bounds = Aabb { min: lo, max: hi };
            wide.prims = &prims;
            wide.packets.reserve(prims.len() / 3);
            match &root {
                BuildNode::Inner { children, size, .. } => {
                    wide.nodes.reserve(size / 2 + 1);
                    wide.inner(children);
                }
                leaf @ BuildNode::Leaf { .. } => {
                    wide.nodes.push(Node4::EMPTY);
                    let r = wide.child(leaf);
                    let mut n = Node4::EMPTY;
                    for axis in 0..3 {
                        n.b[0][axis][0] = lo[axis];
                        n.b[1][axis][0] = hi[axis];
                    }
                    n.child[0] = r;
                    wide.nodes[0] = n;
                }
            }
        }
        let Wide { nodes, packets, ids, has_sphere, max_depth, .. } = wide;
        Accel { shapes, nodes, packets, ids, has_sphere, bounds, stack_needed: 3 * max_depth + 4 }
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

    /// Closest hit and the work it took: (wide nodes visited, 4-triangle packets tested).
    /// A machine-independent measure of the tree's quality.
    pub fn intersect_counting(&self, ray: &Ray) -> (Option<Hit>, [u32; 2]) {
        let mut count = [0u32; 2];
        if self.nodes.is_empty() || !traceable(ray) {
            return (None, count);
        }
        let hit = self.closest::<true>(ray, &mut vec![(0u32, 0f32); self.stack_needed.max(STACK)], &mut count);
        (hit, count)
    }

    /// Use the heap traversal stack whatever the depth (for tests of that path).
    #[doc(hidden)]
    pub fn force_heap_stack(&mut self) {
        self.stack_needed = self.stack_needed.max(STACK + 1);
    }

    /// Depth of the 4-wide tree (levels of inner nodes below the root).
    pub fn depth(&self) -> usize {
        (self.stack_needed - 4) / 3
    }

    /// Number of (4-wide) nodes of the flattened tree.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest hit with t in (ray.t_min, ray.t_max).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        // Untraceable rays (see `traceable`) hit no box: `Pre::hit4` sends them to the careful test.
        if self.nodes.is_empty() {
            return None;
        }
        if self.stack_needed <= SMALL_STACK {
            // Small scenes: a small stack is cheaper to set up.
            self.closest::<false>(ray, &mut [(0u32, 0f32); SMALL_STACK], &mut [0; 2])
        } else if self.stack_needed <= STACK {
            self.closest::<false>(ray, &mut [(0u32, 0f32); STACK], &mut [0; 2])
        } else {
            self.closest::<false>(ray, &mut vec![(0u32, 0f32); self.stack_needed], &mut [0; 2])
        }
    }

    /// Start loading a node or leaf that will probably be visited soon (a plain load whose value
    /// is kept opaque to the optimiser, which the CPU overlaps with the work on the near child).
    #[inline(always)]
    fn touch(&self, c: u32) {
        if c & LEAF_BIT == 0 {
            if let Some(n) = self.nodes.get(c as usize) {
                prefetch(n as *const Node4 as *const i8, 2);
            }
        } else if let Some(p) = self.packets.get((c & LEAF_OFFSET) as usize) {
            prefetch(p as *const Packet as *const i8, 3);
        }
    }

    #[inline(always)]
    fn closest<const COUNT: bool>(&self, ray: &Ray, stack: &mut [(u32, f32)], count: &mut [u32; 2]) -> Option<Hit> {
        let pre = Pre::new(ray);
        let t_min = ray.t_min;
        let mut t_max = ray.t_max;
        let mut best: Option<(usize, usize, f32, f32)> = None;
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            if cur & LEAF_BIT == 0 {
                let node = &self.nodes[cur as usize];
                if COUNT {
                    count[0] += 1;
                }
                let (tn, mut hit) = pre.hit4(node, t_min, t_max);
                let mut c = [(0u32, 0f32); 4];
                let mut cnt = 0;
                while hit != 0 {
                    let i = hit.trailing_zeros() as usize;
                    hit &= hit - 1;
                    c[cnt] = (node.child[i], tn[i]);
                    cnt += 1;
                }
                if cnt == 1 {
                    cur = c[0].0;
                    continue;
                }
                if cnt > 1 {
                    // Farthest first onto the stack; descend into the nearest.
                    far_first(&mut c[..cnt], |e| e.1);
                    for &e in &c[..cnt - 1] {
                        self.touch(e.0);
                        stack[sp] = e;
                        sp += 1;
                    }
                    cur = c[cnt - 1].0;
                    continue;
                }
            } else {
                let first = (cur & LEAF_OFFSET) as usize;
                let n = ((cur & !LEAF_BIT) >> LEAF_SHIFT) as usize;
                for p in first..first + n {
                    if COUNT {
                        count[1] += 1;
                    }
                    self.packet_closest(p, &pre, ray, &mut t_max, &mut best);
                }
            }
            // Pop the next node that may still hold a closer hit.
            loop {
                if sp == 0 {
                    return best.map(|(p, lane, u, v)| self.make_hit(p, lane, u, v, t_max, ray));
                }
                sp -= 1;
                let (n, tn) = stack[sp];
                if tn <= t_max * ROUND_UP {
                    cur = n;
                    break;
                }
            }
        }
    }

    /// Closest hits of four rays traversed together (a ray packet, for coherent rays such as a
    /// 2×2 block of camera pixels); see [`Accel::intersect_packet`].
    pub fn intersect4(&self, rays: &[Ray; 4]) -> [Option<Hit>; 4] {
        let mut hits = [None; 4];
        self.intersect_packet(rays, &mut hits);
        hits
    }

    /// Closest hits of a packet of coherent rays (such as a block of camera pixels), 4, 8 or 16
    /// of them: one walk of the tree for the packet, each node's child boxes tested against the
    /// rays with one SIMD lane per ray, so the node loads, the ordering and the stack are shared.
    /// Every ray keeps its own active mask, interval and closest hit, and the box and triangle
    /// tests are the single-ray arithmetic, so `hits[k]` is `intersect(&rays[k])` (the same t and
    /// primitive; of two primitives hit at exactly the same t either may be reported). A packet
    /// whose rays differ in direction signs, or has a zero direction component, or another size,
    /// is traced ray by ray.
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "intersect_packet: rays and hits differ in length");
        match rays.len() {
            4 => self.packet::<1>(rays, hits),
            8 => self.packet::<2>(rays, hits),
            16 => self.packet::<4>(rays, hits),
            _ => {
                for (r, h) in rays.iter().zip(hits.iter_mut()) {
                    *h = self.intersect(r);
                }
            }
        }
    }

    /// Packet traversal of `4 * G` rays (`G` SIMD groups of four).
    #[inline(always)]
    fn packet<const G: usize>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        if self.nodes.is_empty() {
            hits.fill(None);
            return;
        }
        let pres: [[Pre; 4]; G] = std::array::from_fn(|g| std::array::from_fn(|l| Pre::new(&rays[4 * g + l])));
        let side = pres[0][0].near_side;
        let coherent = pres.iter().flatten().all(|p| !p.parallel && p.near_side == side) && rays.iter().all(traceable);
        if !coherent || self.stack_needed > STACK {
            for (r, h) in rays.iter().zip(hits.iter_mut()) {
                *h = self.intersect(r);
            }
            return;
        }
        let lanes = |g: usize, f: &dyn Fn(&Ray) -> f32| Vec4::new(f(&rays[4 * g]), f(&rays[4 * g + 1]), f(&rays[4 * g + 2]), f(&rays[4 * g + 3]));
        let mut o = [[Vec4::ZERO; 3]; G];
        let mut inv = [[Vec4::ZERO; 3]; G];
        let mut t_min = [Vec4::ZERO; G];
        let mut t_max = [[0f32; 4]; G];
        let mut best: [[Option<(usize, usize, f32, f32)>; 4]; G] = [[None; 4]; G];
        // Bit 4g + l of a mask is ray l of group g. Rays with an empty or NaN interval never hit.
        let mut active = 0u32;
        for g in 0..G {
            o[g] = [lanes(g, &|r| r.o.x), lanes(g, &|r| r.o.y), lanes(g, &|r| r.o.z)];
            for a in 0..3 {
                inv[g][a] = Vec4::new(pres[g][0].inv[a], pres[g][1].inv[a], pres[g][2].inv[a], pres[g][3].inv[a]);
            }
            t_min[g] = lanes(g, &|r| r.t_min);
            t_max[g] = [0, 1, 2, 3].map(|l| rays[4 * g + l].t_max);
            active |= t_min[g].cmple(Vec4::from_array(t_max[g])).bitmask() << (4 * g);
        }
        let [sx, sy, sz] = side;
        // Rays from one point (a pinhole's): a whole-packet interval test of the four child boxes
        // first (Boulos et al. 2007, interval arithmetic over the packet's inverse directions), which
        // rejects, for one box test, the children no ray of the packet can hit.
        let common = rays.iter().all(|r| r.o == rays[0].o);
        let o0 = [Vec4::splat(rays[0].o.x), Vec4::splat(rays[0].o.y), Vec4::splat(rays[0].o.z)];
        let (mut ilo, mut ihi) = ([Vec4::splat(f32::INFINITY); 3], [Vec4::splat(f32::NEG_INFINITY); 3]);
        let mut tmin_lo = Vec4::splat(f32::INFINITY);
        for g in 0..G {
            for a in 0..3 {
                ilo[a] = ilo[a].min(inv[g][a]);
                ihi[a] = ihi[a].max(inv[g][a]);
            }
            tmin_lo = tmin_lo.min(t_min[g]);
        }
        let ilo = ilo.map(|v| Vec4::splat(v.min_element()));
        let ihi = ihi.map(|v| Vec4::splat(v.max_element()));
        let tmin_lo = Vec4::splat(tmin_lo.min_element());
        // (node, ray mask, smallest entry distance of those rays)
        let mut stack = [(0u32, 0u32, 0f32); STACK];
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            if cur & LEAF_BIT == 0 {
                let node = &self.nodes[cur as usize];
                let mut c = [(0u32, 0u32, f32::INFINITY); 4];
                let mut cnt = 0;
                let mut cand = 0b1111u32;
                if common {
                    let mut tmax_hi = Vec4::from_array(t_max[0]);
                    for tm in &t_max[1..] {
                        tmax_hi = tmax_hi.max(Vec4::from_array(*tm));
                    }
                    let tmax_hi = Vec4::splat(tmax_hi.max_element());
                    let mut near = tmin_lo;
                    let mut far = tmax_hi;
                    for (a, s) in [sx, sy, sz].into_iter().enumerate() {
                        let dn = Vec4::from_array(node.b[s][a]) - o0[a];
                        let df = Vec4::from_array(node.b[s ^ 1][a]) - o0[a];
                        near = near.max((dn * ilo[a]).min(dn * ihi[a]));
                        far = far.min((df * ilo[a]).max(df * ihi[a]));
                    }
                    cand = near.cmple(far * ROUND_UP).bitmask();
                }
                for i in 0..4 {
                    if node.child[i] == EMPTY_CHILD || cand & (1 << i) == 0 {
                        continue;
                    }
                    let (bnx, bny, bnz) = (node.b[sx][0][i], node.b[sy][1][i], node.b[sz][2][i]);
                    let (bfx, bfy, bfz) = (node.b[sx ^ 1][0][i], node.b[sy ^ 1][1][i], node.b[sz ^ 1][2][i]);
                    let mut m = 0u32;
                    let mut key = Vec4::splat(f32::INFINITY);
                    for g in 0..G {
                        if (active >> (4 * g)) & 0xF == 0 {
                            continue;
                        }
                        let (og, ig) = (&o[g], &inv[g]);
                        let tnx = (Vec4::splat(bnx) - og[0]) * ig[0];
                        let tny = (Vec4::splat(bny) - og[1]) * ig[1];
                        let tnz = (Vec4::splat(bnz) - og[2]) * ig[2];
                        let tfx = (Vec4::splat(bfx) - og[0]) * ig[0];
                        let tfy = (Vec4::splat(bfy) - og[1]) * ig[1];
                        let tfz = (Vec4::splat(bfz) - og[2]) * ig[2];
                        let near = tnx.max(tny).max(tnz.max(t_min[g]));
                        let far = tfx.min(tfy).min(tfz.min(Vec4::from_array(t_max[g]))) * ROUND_UP;
                        let hit = near.cmple(far);
                        m |= hit.bitmask() << (4 * g);
                        key = key.min(Vec4::select(hit, near, Vec4::splat(f32::INFINITY)));
                    }
                    m &= active;
                    if m != 0 {
                        c[cnt] = (node.child[i], m, key.min_element());
                        cnt += 1;
                    }
                }
                if cnt > 0 {
                    // Farthest first onto the stack; descend into the nearest.
                    far_first(&mut c[..cnt], |e| e.2);
                    for &e in &c[..cnt - 1] {
                        self.touch(e.0);
                        stack[sp] = e;
                        sp += 1;
                    }
                    cur = c[cnt - 1].0;
                    active = c[cnt - 1].1;
                    continue;
                }
            } else {
                let first = (cur & LEAF_OFFSET) as usize;
                let n = ((cur & !LEAF_BIT) >> LEAF_SHIFT) as usize;
                let mut m = active;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let (g, l) = (k / 4, k % 4);
                    for p in first..first + n {
                        self.packet_closest(p, &pres[g][l], &rays[k], &mut t_max[g][l], &mut best[g][l]);
                    }
                }
            }
            // Pop the next node that may still hold a closer hit for one of its rays.
            loop {
                if sp == 0 {
                    for (k, h) in hits.iter_mut().enumerate() {
                        let (g, l) = (k / 4, k % 4);
                        *h = best[g][l].map(|(p, lane, u, v)| self.make_hit(p, lane, u, v, t_max[g][l], &rays[k]));
                    }
                    return;
                }
                sp -= 1;
                let (n, m, near) = stack[sp];
                let mut live = 0u32;
                for g in 0..G {
                    live |= Vec4::splat(near).cmple(Vec4::from_array(t_max[g]) * ROUND_UP).bitmask() << (4 * g);
                }
                live &= m;
                if live != 0 {
                    cur = n;
                    active = live;
                    break;
                }
            }
        }
    }

    /// Closest hits of many rays: `hits[i]` is `intersect(&rays[i])`, the same hit bit for bit.
    /// Several traversals are interleaved, each advancing one node at a time in turn, and the
    /// next node of each is loaded early, so their memory accesses overlap: faster than one ray
    /// at a time when the tree does not fit in cache.
    pub fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "intersect_batch: rays and hits differ in length");
        if self.nodes.is_empty() || self.stack_needed > STACK || !rays.iter().all(traceable) {
            for (r, h) in rays.iter().zip(hits.iter_mut()) {
                *h = self.intersect(r);
            }
            return;
        }
        let mut active: Vec<Trav> = Vec::with_capacity(BATCH);
        let mut next = 0;
        while next < rays.len() && active.len() < BATCH {
            active.push(Trav::new(&rays[next], next));
            next += 1;
        }
        self.touch(0);
        while !active.is_empty() {
            let mut i = 0;
            while i < active.len() {
                let tr = &mut active[i];
                let ray = &rays[tr.index];
                if self.step(tr, ray) {
                    hits[tr.index] = tr.best.map(|(p, lane, u, v)| self.make_hit(p, lane, u, v, tr.t_max, ray));
                    if next < rays.len() {
                        *tr = Trav::new(&rays[next], next);
                        next += 1;
                        i += 1;
                    } else {
                        active.swap_remove(i);
                    }
                } else {
                    i += 1;
                }
            }
        }
    }

    /// One node (or leaf) of a traversal; true when the traversal has finished.
    #[inline(always)]
    fn step(&self, tr: &mut Trav, ray: &Ray) -> bool {
        let cur = tr.cur;
        if cur & LEAF_BIT == 0 {
            let node = &self.nodes[cur as usize];
            let (tn, mut hit) = tr.pre.hit4(node, ray.t_min, tr.t_max);
            let mut c = [(0u32, 0f32); 4];
            let mut cnt = 0;
            while hit != 0 {
                let i = hit.trailing_zeros() as usize;
                hit &= hit - 1;
                c[cnt] = (node.child[i], tn[i]);
                cnt += 1;
            }
            if cnt > 0 {
                far_first(&mut c[..cnt], |e| e.1);
                for &e in &c[..cnt - 1] {
                    tr.stack[tr.sp] = e;
                    tr.sp += 1;
                }
                tr.cur = c[cnt - 1].0;
                self.touch(tr.cur);
                return false;
            }
        } else {
            let first = (cur & LEAF_OFFSET) as usize;
            let n = ((cur & !LEAF_BIT) >> LEAF_SHIFT) as usize;
            for p in first..first + n {
                self.packet_closest(p, &tr.pre, ray, &mut tr.t_max, &mut tr.best);
            }
        }
        loop {
            if tr.sp == 0 {
                return true;
            }
            tr.sp -= 1;
            let (n, tn) = tr.stack[tr.sp];
            if tn <= tr.t_max * ROUND_UP {
                tr.cur = n;
                self.touch(n);
                return false;
            }
        }
    }

    #[inline(always)]
    fn packet_closest(&self, p: usize, pre: &Pre, ray: &Ray, t_max: &mut f32, best: &mut Option<(usize, usize, f32, f32)>) {
        let pk = &self.packets[p];
        if self.has_sphere[p] {
            self.packet_scalar(p, pre, ray, t_max, best);
            return;
        }
        let r = pk.intersect(pre, ray.t_min, *t_max);
        let mut bits = r.ok | r.exact;
        while bits != 0 {
            let lane = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            if r.exact & (1 << lane) != 0 {
                let [a, b, c] = pk.vertices(lane);
                if let Some((t, u, v)) = pre.rt.intersect(a, b, c, ray.t_min, *t_max) {
                    *t_max = t;
                    *best = Some((p, lane, u, v));
                }
            } else if r.t[lane] < *t_max {
                *t_max = r.t[lane];
                *best = Some((p, lane, r.u[lane], r.v[lane]));
            }
        }
    }

    /// Lane-by-lane test of a packet holding spheres.
    #[inline(never)]
    fn packet_scalar(&self, p: usize, pre: &Pre, ray: &Ray, t_max: &mut f32, best: &mut Option<(usize, usize, f32, f32)>) {
        let pk = &self.packets[p];
        for lane in 0..4 {
            let (o, i) = self.ids[p][lane];
            if o == u32::MAX {
                continue;
            }
            let [a, b, c] = pk.vertices(lane);
            if i & SPHERE_BIT != 0 {
                if let Some(t) = (Sphere { center: a, radius: b.x }).intersect(&Ray { t_max: *t_max, ..*ray }) {
                    *t_max = t;
                    *best = Some((p, lane, 0.0, 0.0));
                }
            } else if let Some((t, u, v)) = pre.rt.intersect(a, b, c, ray.t_min, *t_max) {
                *t_max = t;
                *best = Some((p, lane, u, v));
            }
        }
    }

    fn make_hit(&self, p: usize, lane: usize, u: f32, v: f32, t: f32, ray: &Ray) -> Hit {
        let (object, prim) = self.ids[p][lane];
        if prim & SPHERE_BIT != 0 {
            let c = self.packets[p].vertices(lane)[0];
            let (u, v) = sphere_uv(ray.at(t) - c);
            Hit { t, object, prim: 0, u, v }
        } else {
            Hit { t, object, prim, u, v }
        }
    }

    /// True when anything is hit with t in (ray.t_min, ray.t_max) (shadow rays).
    pub fn occluded(&self, ray: &Ray) -> bool {
        // Untraceable rays (see `traceable`) hit no box: `Pre::hit4` sends them to the careful test.
        if self.nodes.is_empty() {
            return false;
        }
        if self.stack_needed <= SMALL_STACK {
            self.any_hit(ray, &mut [0u32; SMALL_STACK])
        } else if self.stack_needed <= STACK {
            self.any_hit(ray, &mut [0u32; STACK])
        } else {
            self.any_hit(ray, &mut vec![0u32; self.stack_needed])
        }
    }

    #[inline(always)]
    fn any_hit(&self, ray: &Ray, stack: &mut [u32]) -> bool {
        let pre = Pre::new(ray);
        let (t_min, t_max) = (ray.t_min, ray.t_max);
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            if cur & LEAF_BIT == 0 {
                let node = &self.nodes[cur as usize];
                let (_, mut hit) = pre.hit4(node, t_min, t_max);
                while hit != 0 {
                    let i = hit.trailing_zeros() as usize;
                    hit &= hit - 1;
                    stack[sp] = node.child[i];
                    sp += 1;
                }
            } else {
                let first = (cur & LEAF_OFFSET) as usize;
                let n = ((cur & !LEAF_BIT) >> LEAF_SHIFT) as usize;
                for p in first..first + n {
                    if self.has_sphere[p] {
                        let mut tm = t_max;
                        let mut best = None;
                        self.packet_scalar(p, &pre, ray, &mut tm, &mut best);
                        if best.is_some() {
                            return true;
                        }
                        continue;
                    }
                    let pk = &self.packets[p];
                    let r = pk.intersect(&pre, t_min, t_max);
                    if r.ok & !r.exact != 0 {
                        return true;
                    }
                    let mut bits = r.exact;
                    while bits != 0 {
                        let lane = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        let [a, b, c] = pk.vertices(lane);
                        if pre.rt.intersect(a, b, c, t_min, t_max).is_some() {
                            return true;
                        }
                    }
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            cur = stack[sp];
        }
    }

    /// The distance (m) from `p` to the nearest primitive, or `cap` when none is nearer: a
    /// depth-first descent that leaves out every node whose box lies at least the best distance
    /// so far away; triangles by their closest point (Ericson, *Real-Time Collision Detection*,
    /// 5.1.5), spheres by |‖p − c‖ − r|. Exact up to f32 rounding; callers that need a bound
    /// shrink it.
    pub fn distance(&self, p: Vec3, cap: f32) -> f32 {
        if self.nodes.is_empty() {
            return cap;
        }
        const N: usize = 128;
        if self.stack_needed + 4 <= N {
            self.distance_with(p, cap, &mut [(0u32, 0.0f32); N])
        } else {
            self.distance_with(p, cap, &mut vec![(0u32, 0.0f32); self.stack_needed + 4])
        }
    }

    #[inline(always)]
    fn distance_with(&self, p: Vec3, cap: f32, stack: &mut [(u32, f32)]) -> f32 {
        let mut best2 = cap * cap;
        let mut sp = 0usize;
        let mut cur = (0u32, 0.0f32);
        loop {
            if cur.1 < best2 {
                let c = cur.0;
                if c & LEAF_BIT == 0 {
                    let node = &self.nodes[c as usize];
                    let mut near = [(0u32, 0.0f32); 4];
                    let mut k = 0usize;
                    for i in 0..4 {
                        if node.child[i] == EMPTY_CHILD {
                            continue;
                        }
                        let mut d2 = 0.0f32;
                        for a in 0..3 {
                            let (lo, hi) = (node.b[0][a][i], node.b[1][a][i]);
                            let e = (lo - p[a]).max(p[a] - hi).max(0.0);
                            d2 += e * e;
                        }
                        if d2 < best2 {
                            near[k] = (node.child[i], d2);
                            k += 1;
                        }
                    }
                    // Nearest on top: the best distance shrinks early and prunes the rest.
                    far_first(&mut near[..k], |e| e.1);
                    for e in &near[..k] {
                        stack[sp] = *e;
                        sp += 1;
                    }
                } else {
                    let first = (c & LEAF_OFFSET) as usize;
                    let n = ((c & !LEAF_BIT) >> LEAF_SHIFT) as usize;
                    for pi in first..first + n {
                        let pk = &self.packets[pi];
                        for lane in 0..4 {
                            let (o, prim) = self.ids[pi][lane];
                            if o == u32::MAX {
                                continue;
                            }
                            let [a, b, cc] = pk.vertices(lane);
                            let d2 = if prim & SPHERE_BIT != 0 {
                                let d = ((p - a).length() - b.x).abs();
                                d * d
                            } else {
                                (closest_point_on_triangle(p.as_dvec3(), a.as_dvec3(), b.as_dvec3(), cc.as_dvec3()) - p.as_dvec3()).length_squared() as f32
                            };
                            if d2 < best2 {
                                best2 = d2;
                            }
                        }
                    }
                }
            }
            if sp == 0 {
                return best2.sqrt().min(cap);
            }
            sp -= 1;
            cur = stack[sp];
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

    /// Texture coordinates (u left to right, v bottom to top of an image) of the point with
    /// barycentrics (`u`, `v`) on primitive `prim` of shape `object` (a [`Hit`]'s fields):
    /// interpolated vertex (u, v) on meshes that have them (0 on meshes without); on spheres
    /// [`crate::shape::sphere::texture_uv`]. Computed only where a texture is looked up.
    #[inline]
    pub fn uv(&self, object: u32, prim: u32, u: f32, v: f32) -> glam::Vec2 {
        match self.shape(object) {
            // The hit's (u, v) is (azimuth from +x towards +z, polar angle from +y) / (2π, π).
            Shape::Sphere(_) => glam::Vec2::new(1.0 - u, 1.0 - v),
            Shape::Mesh(m) => match &m.uvs {
                Some(uv) => {
                    let t = m.indices[prim as usize];
                    let w = 1.0 - u - v;
                    w * uv[t[0] as usize] + u * uv[t[1] as usize] + v * uv[t[2] as usize]
                }
                None => glam::Vec2::ZERO,
            },
        }
    }

    /// Partial derivatives (∂p/∂u, ∂p/∂v) of position (m) with respect to the texture
    /// coordinates of [`Accel::uv`] at the hit (`prim`, `u`, `v`): constant over a mesh triangle
    /// (from its vertices' positions and texture coordinates, as pbrt-v4 and Mitsuba 3 compute
    /// them), analytic on spheres. `None` where there are none: a mesh without texture
    /// coordinates, a triangle whose texture coordinates are degenerate, a sphere's poles.
    pub fn position_derivatives(&self, object: u32, prim: u32, u: f32, v: f32) -> Option<(Vec3, Vec3)> {
        match self.shape(object) {
            Shape::Sphere(s) => {
                // p = c + r (sin θ cos φ, cos θ, sin θ sin φ) with φ = 2π(1 − u_tex), θ = π(1 − v_tex)
                // (`crate::shape::sphere::texture_uv`; the hit's (u, v) are (φ/2π, θ/π)).
                let (phi, theta) = (u * 2.0 * std::f32::consts::PI, v * std::f32::consts::PI);
                let (sp, cp) = phi.sin_cos();
                let (st, ct) = theta.sin_cos();
                let r = s.radius.abs();
                if !(st > 1e-6) {
                    return None;
                }
                let dpdu = 2.0 * std::f32::consts::PI * r * st * Vec3::new(sp, 0.0, -cp);
                let dpdv = -std::f32::consts::PI * r * Vec3::new(ct * cp, -st, ct * sp);
                Some((dpdu, dpdv))
            }
            Shape::Mesh(m) => {
                let uvs = m.uvs.as_ref()?;
                let t = m.indices[prim as usize];
                let [a, b, c] = m.triangle(prim as usize);
                let (ta, tb, tc) = (uvs[t[0] as usize], uvs[t[1] as usize], uvs[t[2] as usize]);
                let (d1, d2) = (tb - ta, tc - ta);
                let (e1, e2) = (b - a, c - a);
                let det = d1.x * d2.y - d1.y * d2.x;
                if !(det.abs() > 1e-12 * (d1.length_squared() + d2.length_squared())) {
                    return None;
                }
                let inv = 1.0 / det;
                let dpdu = (d2.y * e1 - d1.y * e2) * inv;
                let dpdv = (d1.x * e2 - d2.x * e1) * inv;
                (dpdu.is_finite() && dpdv.is_finite()).then_some((dpdu, dpdv))
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
                        if m.indices[i].iter().any(|&k| k as usize >= m.positions.len()) {
                            continue;
                        }
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
            if let Shape::Sphere(s) = &self.shapes[h.object as usize] {
                let (u, v) = sphere_uv(ray.at(h.t) - s.center);
                Hit { u, v, ..h }
            } else {
                h
            }
        })
    }
}


/// Ask the CPU to start loading `lines` cache lines from `p`.
#[inline(always)]
fn prefetch(p: *const i8, lines: usize) {
    #[cfg(target_arch = "x86_64")]
    for k in 0..lines {
        // SAFETY: a prefetch never faults or changes memory; the pointer is only a hint
        // (and points into a live Vec element anyway).
        unsafe { std::arch::x86_64::_mm_prefetch(p.wrapping_add(64 * k), std::arch::x86_64::_MM_HINT_T0) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, lines);
}

