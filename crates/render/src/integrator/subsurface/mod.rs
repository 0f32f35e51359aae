//! Subsurface scattering with dipole BSSRDFs, rendered progressively by the point-cloud method
//! with rejection control (Jensen et al. 2001; Frisvad, Hachisuka & Kjeldsen 2014; Dal Corso &
//! Frisvad 2018; the tutorial's "Progressive rendering of subsurface scattering").
//!
//! A [`Translucent`] material is a closed object with a smooth or GGX-rough dielectric boundary of
//! relative index η whose interior is described by σ_s(λ), σ_a(λ), g(λ). Its appearance is the
//! surface reflection of the boundary (a mirror, or the rough dielectric's reflection lobe; traced
//! by the path tracer) plus the diffusive BSSRDF term
//!
//! L_d(x_o, ω_o) = T21(ω_o) · (1/M) Σ_i S_d(x_i, ω_i; x_o) · L_t,i,
//! L_t,i = T12(ω_i) · L_i(x_i, ω_i) · π · A,
//!
//! where, once per pass ([`SubsurfacePass::build`]), M points x_i are drawn uniformly on the
//! object's surface (pdf 1/A), a cosine-distributed direction ω_i is drawn about the outward
//! normal and L_i is found by full path tracing (other objects and lights are lit correctly).
//!
//! Rejection control: point i is accepted with probability p_i = p(‖x_o − x_i‖),
//! p(d) = e^{−σ_tr,min d}·min(1, (r0/d)³) (σ_tr,min the smallest transport coefficient over the
//! pass's wavelengths, r0 = `rejection_radius_mfp`/σ'_t,min), and its term is divided by p_i.
//! Any non-increasing p keeps the scheme below exact; the (r0/d)³ factor follows the dipoles'
//! mid-range falloff, so far points (small terms, little variance) are rarely evaluated.
//! To keep the cost per shading point from growing linearly with M, the points
//! are stored in a kd-tree; a node whose box is at distance d_min from x_o bounds every p_i in it
//! by q = p(d_min). Nodes that are far (n·q small) or leaves are handled as a whole:
//! candidates are drawn from the node's points with probability q by geometric skipping, and a
//! candidate is kept with probability p_i/q. Every point is thus accepted with probability exactly
//! q·p_i/q = p_i whatever the cut, so the estimator is unbiased; its cost is about the number of
//! nodes on the cut plus the number of candidates. `rejection_control = false` accepts every
//! point (p_i = 1, cost linear in M) — the reference for the unbiasedness test.
//!
//! Wavelengths: the stored L_t are spectral, so a camera path uses a cloud traced at its own four
//! hero wavelengths. A pass builds K clouds ([`Translucent::wavelength_sets`]) at K interleaved
//! sets of wavelengths (one random offset per pass, stratified in the sampling CDF), and each
//! pixel uses one set ([`SubsurfacePass::set_of_pixel`]), so a pass no longer tints the whole
//! image with the colour of four wavelengths; passes average over wavelengths as they do over
//! everything else.
//!
//! Limitation (default `bounces = 1`): the paths traced from cloud points see translucent
//! surfaces as their specular reflection only, so light that leaves one translucent surface by
//! subsurface scattering and reaches a translucent point (another object, or the same one via its
//! surroundings, e.g. a glass around milk) is dropped. With `bounces = N` each pass builds N
//! clouds, the paths of each seeing translucent surfaces with the BSSRDF term of the one before
//! ([`Translucent::bounces`]), which counts that light up to N − 1 times.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod line_dipole4;

use crate::integrator::nee;
use crate::interaction::{offset_origin, shadow_t_max};
use crate::material::translucent::Translucent;
use crate::material::Material;
use crate::math::geometry::{Aabb, Ray};
use crate::math::sampling::{cosine_hemisphere, uniform_sphere, uniform_triangle, Frame, Pcg32};
use crate::math::spectral::{SampledSpectrum, SampledWavelengths, N_LAMBDA};
use crate::scene::Scene;
use crate::shape::Shape;
use anyhow::Result;
use glam::{Vec3, Vec4};
use crate::math::fastexp::exp1;
use line_dipole4::{refract_in, LineDipole4};
use optics::bssrdf::{DipoleModel, DirectionalDipole, DirectionalLineDipole, StandardDipole};
use optics::spectrum::DenseSpectrum;
use rayon::prelude::*;
use std::sync::Arc;

/// The path tracer a pass's cloud points are lit by: radiance along a ray (`wl` may lose its
/// secondary wavelengths), with translucent surfaces treated as the [`SubsurfaceMode`] says and
/// the ray's sampling density for MIS on its first segment (0: none).
pub type Tracer<'a> = dyn Fn(Ray, &mut SampledWavelengths, &mut Pcg32, SubsurfaceMode, f32) -> SampledSpectrum + Sync + 'a;

/// The dipole of one wavelength lane.
#[derive(Clone, Copy, Debug)]
enum LaneModel {
    Standard(StandardDipole),
    Directional(DirectionalDipole),
    DirectionalLine(DirectionalLineDipole),
    /// α' = 0 or otherwise nothing diffuses.
    Black,
}

impl LaneModel {
    /// S_d for the refracted direction `w12` (into the medium) of a cloud point.
    #[inline]
    fn sd(&self, xi: Vec3, ni: Vec3, w12: Vec3, xo: Vec3, no: Vec3) -> f64 {
        let c = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
        match self {
            LaneModel::Standard(m) => m.sd(xo.distance(xi) as f64),
            LaneModel::Directional(m) => m.sd_refracted(c(xi), c(ni), c(w12), c(xo), c(no)),
            LaneModel::DirectionalLine(m) => m.sd_refracted(c(xi), c(ni), c(w12), c(xo), c(no)),
            LaneModel::Black => 0.0,
        }
    }
}

/// One stored sample of transmitted light.
#[derive(Clone, Copy, Debug)]
struct CloudPoint {
    p: Vec3,
    /// Outward unit normal.
    n: Vec3,
    /// Refracted direction ω₁₂ into the medium (unit) of the direction towards the light.
    w12: Vec3,
    /// L_t = T12 L_i π A at the pass's wavelengths.
    lt: Vec4,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    start: u32,
    end: u32,
    /// Index of the first child (the second is `left + 1`), 0 for a leaf.
    left: u32,
}

const LEAF_SIZE: usize = 8;

/// The point cloud of one translucent object for one pass.
struct ObjectCloud {
    lanes: [LaneModel; N_LAMBDA],
    /// The lanes packed for the four-wide evaluation (line-source directional dipole only).
    packed: Option<LineDipole4>,
    eta: f32,
    /// Smallest σ_tr over the pass's wavelengths (m⁻¹).
    sigma_tr_min: f32,
    /// Radius r0 (m) beyond which acceptance falls by an extra (r0/d)³.
    rc_radius_m: f32,
    rejection_control: bool,
    /// Number of points drawn (the estimator divides by it).
    m: usize,
    points: Vec<CloudPoint>,
    nodes: Vec<Node>,
}

/// Statistics of one query (for tests and benchmarks).
#[derive(Clone, Copy, Debug, Default)]
pub struct QueryStats {
    /// Tree nodes visited.
    pub nodes: u64,
    /// Points evaluated with S_d (accepted).
    pub accepted: u64,
}

/// Per-pass subsurface state: the wavelengths every path of the pass uses and the point cloud of
/// each translucent object.
pub struct SubsurfacePass {
    /// The wavelengths of every path of this pass.
    pub wl: SampledWavelengths,
    clouds: Vec<Option<ObjectCloud>>,
}

/// How the path tracer treats translucent materials.
#[derive(Clone, Copy)]
pub enum SubsurfaceMode<'a> {
    /// As their dielectric boundary, smooth or rough (light enters the interior; volumetric path tracing).
    Dielectric,
    /// Surface reflection of the boundary only (paths traced from cloud points).
    ReflectOnly,
    /// Surface reflection plus the BSSRDF term from this pass's cloud (camera paths).
    Bssrdf(&'a SubsurfacePass),
}

/// Whether `scene` has any translucent object.
pub fn scene_has_translucent(scene: &Scene) -> bool {
    scene.objects.iter().any(|o| {
        matches!(
            scene.materials[o.material as usize],
            Material::Translucent(_)
        )
    })
}

/// Area-uniform point sampler over one shape.
struct SurfaceSampler<'a> {
    shape: &'a Shape,
    cdf: Vec<f32>,
    area: f32,
    /// +1 if the mesh winding gives outward normals, −1 if inward.
    orient: f32,
}

impl<'a> SurfaceSampler<'a> {
    fn new(shape: &'a Shape) -> SurfaceSampler<'a> {
        match shape {
            Shape::Sphere(s) => SurfaceSampler {
                shape,
                cdf: Vec::new(),
                area: 4.0 * std::f32::consts::PI * s.radius * s.radius,
                orient: 1.0,
            },
            Shape::Mesh(m) => {
                let mut acc = 0.0f64;
                let mut vol = 0.0f64;
                let mut cdf = Vec::with_capacity(m.indices.len());
                for i in 0..m.indices.len() {
                    acc += m.triangle_area(i) as f64;
                    cdf.push(acc as f32);
                    let [a, b, c] = m.triangle(i);
                    vol += a.as_dvec3().dot(b.as_dvec3().cross(c.as_dvec3()));
                }
                SurfaceSampler {
                    shape,
                    cdf,
                    area: acc as f32,
                    orient: if vol < 0.0 { -1.0 } else { 1.0 },
                }
            }
        }
    }

    /// Uniform point and its outward unit normal.
    fn sample(&self, rng: &mut Pcg32) -> (Vec3, Vec3) {
        match self.shape {
            Shape::Sphere(s) => {
                let n = uniform_sphere(rng.next_2d());
                (s.center + n * s.radius.abs(), n)
            }
            Shape::Mesh(m) => {
                let u = rng.next_f32() * self.area;
                let i = self
                    .cdf
                    .partition_point(|&c| c <= u)
                    .min(self.cdf.len() - 1);
                let [a, b, c] = m.triangle(i);
                let bc = uniform_triangle(rng.next_2d());
                let p = a * (1.0 - bc.x - bc.y) + b * bc.x + c * bc.y;
                let n = (b - a).cross(c - a).normalize_or_zero() * self.orient;
                (p, n)
            }
        }
    }
}

/// Outward normal of `shape` at a surface point with geometric normal `ng_raw` (as stored).
pub fn outward_normal(shape: &Shape, ng_raw: Vec3) -> Vec3 {
    // Meshes marked translucent are oriented outwards at load (scene.rs); spheres always are.
    let _ = shape;
    ng_raw
}

#[inline]
fn fresnel_t(cos: f32, eta: f32) -> f32 {
    (1.0 - optics::fresnel::fresnel_dielectric(cos.clamp(0.0, 1.0) as f64, eta as f64)) as f32
}

#[inline]
fn box_distance(b: &Aabb, p: Vec3) -> f32 {
    let d = (b.min - p).max(p - b.max).max(Vec3::ZERO);
    d.length()
}

impl SubsurfacePass {
    /// Wavelengths of pass `pass` (every path of a pass with translucent objects and one
    /// wavelength set uses them).
    pub fn pass_wavelengths(seed: u64, pass: u64) -> SampledWavelengths {
        Self::set_wavelengths(seed, pass, 0, 1)
    }

    /// Wavelengths of set `set` of `sets` in pass `pass`: one random offset u per pass, set k at
    /// u + k/(4K), so the 4K wavelengths of a pass are stratified (evenly spaced in the sampling
    /// CDF, as the four of one set are); set 0 of 1 is [`SubsurfacePass::pass_wavelengths`].
    pub fn set_wavelengths(seed: u64, pass: u64, set: u32, sets: u32) -> SampledWavelengths {
        let mut rng = Pcg32::for_pixel(seed ^ 0x5b5d_2c1e_9e37_79b9, pass, u64::MAX);
        let mut u = rng.next_f32();
        if set > 0 {
            u += set as f32 / (N_LAMBDA as f32 * sets.max(1) as f32);
            if u >= 1.0 {
                u -= 1.0;
            }
        }
        SampledWavelengths::sample(u)
    }

    /// Number of wavelength sets (point clouds) per pass of `scene`: the largest
    /// [`Translucent::wavelength_sets`] of its translucent materials (1 without any).
    pub fn wavelength_sets(scene: &Scene) -> u32 {
        scene.materials.iter().filter_map(|m| m.as_translucent().map(|t| t.wavelength_sets)).max().unwrap_or(1).max(1)
    }

    /// Which of `sets` wavelength sets pixel (`i`, `j`) uses in a pass whose sets are shifted by
    /// `offset`: (i + s·j + offset) mod K with s = ⌊K/2⌋ (at least 1), so that every K
    /// consecutive pixels of a row, and for K = 4 every 2×2 block, hold each set once.
    pub fn set_of_pixel(i: u32, j: u32, offset: u32, sets: u32) -> u32 {
        let k = sets.max(1);
        let s = (k / 2).max(1);
        ((i % k) + (s * (j % k)) + offset % k) % k
    }

    /// The per-pass shift of the pixel pattern of [`SubsurfacePass::set_of_pixel`].
    pub fn set_offset(seed: u64, pass: u64) -> u32 {
        Pcg32::for_pixel(seed ^ 0x2f1c_6a3b_5d4e_8f70, pass, u64::MAX).next_u32()
    }

    /// Build the pass state: for each translucent object draw its points, trace them with the
    /// path tracer (translucent surfaces reflect only) and build the kd-tree. `None` when the
    /// scene has no translucent object. Deterministic in (`seed`, `pass`). One wavelength set:
    /// every path of the pass at [`SubsurfacePass::pass_wavelengths`].
    pub fn build(scene: &Scene, seed: u64, pass: u64, trace: &Tracer) -> Option<SubsurfacePass> {
        Self::build_set(scene, seed, pass, 0, 1, trace)
    }

    /// [`SubsurfacePass::build`] for set `set` of `sets`: wavelengths
    /// [`SubsurfacePass::set_wavelengths`], cloud points independent of the other sets' (set 0
    /// draws the points of [`SubsurfacePass::build`]).
    pub fn build_set(scene: &Scene, seed: u64, pass: u64, set: u32, sets: u32, trace: &Tracer) -> Option<SubsurfacePass> {
        if !scene_has_translucent(scene) {
            return None;
        }
        let wl = Self::set_wavelengths(seed, pass, set, sets);
        let seed = if set == 0 { seed } else { seed ^ (set as u64).wrapping_mul(0xa076_1d64_78bd_642f) };
        let bounces = scene
            .materials
            .iter()
            .filter_map(|m| m.as_translucent().map(|t| t.bounces))
            .max()
            .unwrap_or(1)
            .max(1);
        // Generations g = N−1, …, 0; generation 0 (the camera's) keeps the seed stream of the
        // single-cloud scheme, so `bounces = 1` is unchanged bit for bit.
        let mut prev: Option<SubsurfacePass> = None;
        for g in (0..bounces as u64).rev() {
            let seed_g = if g == 0 { seed } else { seed ^ g.wrapping_mul(0x9e37_79b9_7f4a_7c15) };
            let mode = match &prev {
                None => SubsurfaceMode::ReflectOnly,
                Some(p) => SubsurfaceMode::Bssrdf(p),
            };
            let mut clouds = Vec::with_capacity(scene.objects.len());
            for (oi, obj) in scene.objects.iter().enumerate() {
                let Material::Translucent(t) = &scene.materials[obj.material as usize] else {
                    clouds.push(None);
                    continue;
                };
                clouds.push(Some(build_cloud(scene, trace, t, oi, &wl, seed_g, pass, mode)));
            }
            prev = Some(SubsurfacePass { wl, clouds });
        }
        prev
    }

    /// Diffusive BSSRDF radiance leaving object `object` at `xo` (outward unit normal `no`)
    /// towards `wo` (unit, outside): T21 · (1/M) Σ S_d L_t / p_i over the accepted points.
    pub fn radiance(
        &self,
        object: u32,
        xo: Vec3,
        no: Vec3,
        wo: Vec3,
        rng: &mut Pcg32,
    ) -> SampledSpectrum {
        self.radiance_stats(object, xo, no, wo, rng).0
    }

    /// [`SubsurfacePass::radiance`] with the query's statistics.
    pub fn radiance_stats(
        &self,
        object: u32,
        xo: Vec3,
        no: Vec3,
        wo: Vec3,
        rng: &mut Pcg32,
    ) -> (SampledSpectrum, QueryStats) {
        let mut st = QueryStats::default();
        let Some(Some(c)) = self.clouds.get(object as usize) else {
            return (Vec4::ZERO, st);
        };
        let cos_o = wo.dot(no);
        if !(cos_o > 0.0) || c.points.is_empty() {
            return (Vec4::ZERO, st);
        }
        let mut sum = [0f64; N_LAMBDA];
        let sigma = c.sigma_tr_min;
        let r0 = c.rc_radius_m;
        // Acceptance p(d) = e^{−σ_tr,min d}·min(1, (r0/d)³), non-increasing in d, so
        // p(box distance) bounds every point of a node.
        let accept = |d: f32| -> f32 {
            let e = exp1(-sigma * d);
            if d > r0 {
                let k = r0 / d;
                e * k * k * k
            } else {
                e
            }
        };
        let mut sum4 = Vec4::ZERO;
        let mut eval = |pt: &CloudPoint, p: f32, st: &mut QueryStats| {
            st.accepted += 1;
            if let Some(pk) = &c.packed {
                sum4 += pk.sd_refracted(pt.p, pt.n, pt.w12, xo, no) * pt.lt * p.recip();
                return;
            }
            for (k, lane) in c.lanes.iter().enumerate() {
                let lt = pt.lt[k];
                if lt != 0.0 {
                    sum[k] += lane.sd(pt.p, pt.n, pt.w12, xo, no) * lt as f64 / p as f64;
                }
            }
        };
        let mut stack = [0u32; 64];
        let mut sp = 1usize;
        stack[0] = 0;
        while sp > 0 {
            sp -= 1;
            let node = &c.nodes[stack[sp] as usize];
            st.nodes += 1;
            let q = if c.rejection_control {
                accept(box_distance(&node.bounds, xo))
            } else {
                1.0
            };
            if !(q > 0.0) {
                continue;
            }
            let n = (node.end - node.start) as f32;
            if node.left == 0 || n * q < 4.0 || sp + 2 > stack.len() {
                // Candidates with probability q by geometric skipping, then keep with p/q.
                let (start, end) = (node.start as usize, node.end as usize);
                if q >= 1.0 || node.left == 0 {
                    // Every point of a leaf is tested directly: with at most LEAF_SIZE points
                    // this is cheaper than drawing geometric skips.
                    for pt in &c.points[start..end] {
                        let p = if c.rejection_control {
                            accept(pt.p.distance(xo))
                        } else {
                            1.0
                        };
                        if p > 0.0 && (p >= 1.0 || rng.next_f32() < p) {
                            eval(pt, p, &mut st);
                        }
                    }
                } else {
                    let ln1q = (-(q as f64)).ln_1p();
                    let mut j = start;
                    loop {
                        let u = 1.0 - rng.next_f64(); // (0, 1]
                        let skip = (u.ln() / ln1q).floor();
                        if !(skip < (end - j) as f64) {
                            break;
                        }
                        j += skip as usize;
                        let pt = &c.points[j];
                        let p = accept(pt.p.distance(xo));
                        if p > 0.0 && rng.next_f32() * q < p {
                            eval(pt, p, &mut st);
                        }
                        j += 1;
                        if j >= end {
                            break;
                        }
                    }
                }
            } else {
                stack[sp] = node.left;
                stack[sp + 1] = node.left + 1;
                sp += 2;
            }
        }
        let t21 = fresnel_t(cos_o, c.eta);
        let scale = t21 as f64 / c.m as f64;
        for k in 0..N_LAMBDA {
            sum[k] += sum4[k] as f64;
        }
        (
            Vec4::new(
                (sum[0] * scale) as f32,
                (sum[1] * scale) as f32,
                (sum[2] * scale) as f32,
                (sum[3] * scale) as f32,
            ),
            st,
        )
    }

    /// Number of stored points of `object` (0 if not translucent).
    pub fn point_count(&self, object: u32) -> usize {
        self.clouds
            .get(object as usize)
            .and_then(|c| c.as_ref())
            .map_or(0, |c| c.points.len())
    }
}

/// The lanes' models, the smallest σ_tr and the smallest σ'_t over the lanes (m⁻¹).
fn lane_models(t: &Translucent, wl: &SampledWavelengths) -> ([LaneModel; N_LAMBDA], f32, f32) {
    let mut lanes = [LaneModel::Black; N_LAMBDA];
    let mut smin = f32::INFINITY;
    let mut spt_min = f32::INFINITY;
    for (k, lane) in lanes.iter_mut().enumerate() {
        let p = t.properties(wl.lambda_nm[k]);
        let m = match t.model {
            DipoleModel::Standard => StandardDipole::new(&p).map(LaneModel::Standard),
            DipoleModel::Directional => DirectionalDipole::new(&p).map(LaneModel::Directional),
            DipoleModel::DirectionalCorrected => {
                DirectionalLineDipole::new(&p).map(LaneModel::DirectionalLine)
            }
        };
        if let Ok(m) = m {
            let (ap, str_) = match &m {
                LaneModel::Standard(d) => (d.props.alpha_prime, d.props.sigma_tr_per_m),
                LaneModel::Directional(d) => (d.props.alpha_prime, d.props.sigma_tr_per_m),
                LaneModel::DirectionalLine(d) => {
                    (d.base.props.alpha_prime, d.base.props.sigma_tr_per_m)
                }
                LaneModel::Black => (0.0, f64::INFINITY),
            };
            if ap > 0.0 && str_.is_finite() {
                *lane = m;
                smin = smin.min(str_ as f32);
                let spt = p.sigma_s_per_m * (1.0 - p.g) + p.sigma_a_per_m;
                spt_min = spt_min.min(spt as f32);
            }
        }
    }
    (
        lanes,
        if smin.is_finite() { smin } else { 0.0 },
        spt_min,
    )
}

/// Mean cosine of a medium's phase function at `lambda_nm`.
fn phase_g(phase: &crate::medium::PhaseModel, lambda_nm: f32) -> f64 {
    use crate::medium::PhaseModel;
    match phase {
        PhaseModel::HenyeyGreenstein { g } => g.eval(lambda_nm) as f64,
        PhaseModel::Tabulated {
            lambda_nm: ls,
            tables,
            ..
        } => {
            if tables.is_empty() {
                return 0.0;
            }
            let k = ls.partition_point(|&l| l <= lambda_nm);
            if k == 0 {
                tables[0].g()
            } else if k >= ls.len() {
                tables[ls.len() - 1].g()
            } else {
                let f = ((lambda_nm - ls[k - 1]) / (ls[k] - ls[k - 1])) as f64;
                tables[k - 1].g() * (1.0 - f) + tables[k].g() * f
            }
        }
    }
}

/// The material with its coefficients taken from the object's medium when `from_medium`.
fn effective_material(scene: &Scene, t: &Translucent, object: usize) -> Translucent {
    let mut t = t.clone();
    if t.from_medium {
        if let Some(mi) = scene.objects[object].interior_medium {
            let m = &scene.media[mi as usize];
            t.sigma_s_per_m = m.sigma_s_per_m.clone();
            t.sigma_a_per_m = m.sigma_a_per_m.clone();
            let phase = &m.phase;
            t.g = DenseSpectrum::from_fn(|l| phase_g(phase, l as f32));
        }
    }
    t
}

#[allow(clippy::too_many_arguments)]
fn build_cloud(
    scene: &Scene,
    trace: &Tracer,
    t: &Translucent,
    object: usize,
    wl: &SampledWavelengths,
    seed: u64,
    pass: u64,
    mode: SubsurfaceMode,
) -> ObjectCloud {
    let t = &effective_material(scene, t, object);
    let (lanes, sigma_tr_min, spt_min) = lane_models(t, wl);
    let shape = scene.accel.shape(object as u32);
    let sampler = SurfaceSampler::new(shape);
    let m = t.points_per_pass;
    let area = sampler.area;
    let eps = scene.ray_epsilon_m;
    let any_lane = lanes.iter().any(|l| !matches!(l, LaneModel::Black));
    let mut points: Vec<CloudPoint> = if any_lane {
        (0..m)
            .into_par_iter()
            .map(|i| {
                let mut rng = Pcg32::for_pixel(
                    seed ^ 0xc10d_0000_0000_0000 ^ (object as u64) << 32,
                    pass,
                    i as u64,
                );
                let (p, n) = sampler.sample(&mut rng);
                let d_local = cosine_hemisphere(rng.next_2d());
                let wi = Frame::from_normal(n).to_world(d_local).normalize();
                let ray = Ray {
                    o: p + n * eps,
                    d: wi,
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                };
                // Light sample (next-event estimation), MIS-weighted against the cosine direction.
                let light = sample_light_at(scene, p, n, wl, &mut rng, t.eta, area);
                let cos_pdf = d_local.z * std::f32::consts::FRAC_1_PI;
                let mut wl_path = *wl;
                let mut li = trace(ray, &mut wl_path, &mut rng, mode, cos_pdf);
                if wl_path.secondary_terminated() {
                    li = Vec4::new(li.x * N_LAMBDA as f32, 0.0, 0.0, 0.0);
                }
                if !li.is_finite() {
                    li = Vec4::ZERO;
                }
                let lt = li * (fresnel_t(d_local.z, t.eta) * std::f32::consts::PI * area);
                let w12 = refract_in(wi, n, t.eta);
                [Some(CloudPoint { p, n, w12, lt }), light]
            })
            .flat_map_iter(|pair| pair.into_iter().flatten())
            .filter(|c| c.lt != Vec4::ZERO)
            .collect()
    } else {
        Vec::new()
    };
    let nodes = build_tree(&mut points);
    let packed = (t.model == DipoleModel::DirectionalCorrected).then(|| {
        LineDipole4::new(lanes.each_ref().map(|l| match l {
            LaneModel::DirectionalLine(m) => Some(m),
            _ => None,
        }))
    });
    ObjectCloud {
        lanes,
        packed,
        eta: t.eta,
        sigma_tr_min,
        rc_radius_m: if t.rejection_radius_mfp > 0.0 {
            t.rejection_radius_mfp / spt_min
        } else {
            f32::INFINITY
        },
        rejection_control: t.rejection_control,
        m,
        points,
        nodes,
    }
}

/// Next-event estimation at cloud point `p` (outward normal `n`): one light sample, MIS-weighted
/// (power heuristic) against the cosine sampling of the traced direction; returns the stored
/// entry L_t = T12 · L_e · cos θ · w / pdf · A (with the light's direction) or `None`.
fn sample_light_at(
    scene: &Scene,
    p: Vec3,
    n: Vec3,
    wl: &SampledWavelengths,
    rng: &mut Pcg32,
    eta: f32,
    area: f32,
) -> Option<CloudPoint> {
    let c = nee::sample_light(scene, p, wl, rng)?;
    let ls = &c.ls;
    let cos = ls.wi.dot(n);
    if !(cos > 0.0) {
        return None;
    }
    let eps = scene.ray_epsilon_m;
    let t_max = shadow_t_max(ls.dist, eps, true);
    if t_max > 0.0
        && scene.occluded(&Ray {
            o: offset_origin(p, n, ls.wi, eps),
            d: ls.wi,
            t_min: 0.0,
            t_max,
        })
    {
        return None;
    }
    let light_pdf = c.pdf();
    let w = c.mis_weight(cos * std::f32::consts::FRAC_1_PI);
    let lt = ls.li * (fresnel_t(cos, eta) * cos * w / light_pdf * area);
    lt.is_finite().then_some(CloudPoint {
        p,
        n,
        w12: refract_in(ls.wi, n, eta),
        lt,
    })
}

/// kd-tree over the points (median split on the longest axis); reorders `points` so every node
/// is a contiguous range.
fn build_tree(points: &mut [CloudPoint]) -> Vec<Node> {
    let mut nodes = Vec::with_capacity(2 * points.len() / LEAF_SIZE + 1);
    let bounds = |pts: &[CloudPoint]| pts.iter().fold(Aabb::EMPTY, |b, c| b.grow(c.p));
    nodes.push(Node {
        bounds: bounds(points),
        start: 0,
        end: points.len() as u32,
        left: 0,
    });
    let mut todo = vec![0usize];
    while let Some(ni) = todo.pop() {
        let Node {
            bounds: b,
            start,
            end,
            ..
        } = nodes[ni];
        let n = (end - start) as usize;
        if n <= LEAF_SIZE {
            continue;
        }
        let axis = b.longest_axis();
        let mid = n / 2;
        let slice = &mut points[start as usize..end as usize];
        slice.select_nth_unstable_by(mid, |a, c| a.p[axis].total_cmp(&c.p[axis]));
        let left = nodes.len();
        let m = start + mid as u32;
        nodes.push(Node {
            bounds: bounds(&points[start as usize..m as usize]),
            start,
            end: m,
            left: 0,
        });
        nodes.push(Node {
            bounds: bounds(&points[m as usize..end as usize]),
            start: m,
            end,
            left: 0,
        });
        nodes[ni].left = left as u32;
        todo.push(left);
        todo.push(left + 1);
    }
    nodes
}

/// Check that a shape marked translucent is closed (every edge shared by two triangles after
/// welding equal positions); errors say which edge count is wrong.
pub fn check_closed(shape: &Shape) -> Result<()> {
    match shape {
        Shape::Sphere(_) => Ok(()),
        Shape::Mesh(m) => crate::medium::closed_mesh_volume(m).map(|_| ()),
    }
}

/// Convenience: the material of a translucent object.
pub fn translucent_of(scene: &Scene, object: u32) -> Option<&Arc<Translucent>> {
    scene.materials[scene.objects[object as usize].material as usize].as_translucent()
}
