//! Integrators: ambient occlusion, direct lighting, path tracing with NEE + MIS.
//!
//! Path lengths count segments as in Mitsuba 3: a path of depth 1 is a camera ray that sees an
//! emitter, depth 2 adds one bounce (direct lighting), and so on up to `max_depth`. Russian
//! roulette starts once a path has `rr_depth` segments: the path continues with probability
//! q = min(max throughput, 0.95) and its throughput is divided by q.
//!
//! - `ao`: at the first hit, one cosine-weighted direction about the shading normal; the value is
//!   1 when that direction is not blocked within the scene's `ao_distance`, else 0, written as
//!   equal-energy white with Y = value (an unoccluded point shows Y = 1 exactly). Rays that miss
//!   everything give 0.
//! - `direct`: emission seen by the camera ray plus one light sample (lights chosen in proportion
//!   to power, a point chosen on the light, visibility tested) at the first hit — light sampling
//!   only, the tutorial's soft-shadow estimator.
//! - `path`: unidirectional path tracing; at every vertex one light sample and one BSDF sample,
//!   combined by multiple importance sampling with the power heuristic (Veach 1997).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::bvh::Hit;
use crate::geometry::Ray;
use crate::material::{Bsdf, Material};
use crate::subsurface::{SubsurfaceMode, SubsurfacePass};
use crate::sampling::{cosine_hemisphere, power_heuristic, Frame, Pcg32};
use crate::scene::Scene;
use crate::spectral::{SampledSpectrum, SampledWavelengths};
use glam::{Vec3, Vec4};
use rayon::prelude::*;

/// Which light-transport estimator to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IntegratorKind {
    /// Unidirectional path tracing with next-event estimation, MIS and Russian roulette.
    Path,
    /// Emission plus one light sample at the first hit (soft shadows, no indirect light).
    Direct,
    /// Ambient occlusion by cosine-weighted hemisphere sampling.
    Ao,
    /// Volumetric path tracing through homogeneous media (see [`crate::volpath`]).
    Volpath,
}

/// Settings of an integrator (Mitsuba's defaults for `path`: 8 bounces, Russian roulette from the 5th).
#[derive(Clone, Debug)]
pub struct IntegratorSettings {
    /// The estimator.
    pub kind: IntegratorKind,
    /// Longest path in segments (1: emitters seen directly, 2: direct lighting; Mitsuba's `max_depth`).
    pub max_depth: u32,
    /// Russian roulette starts once a path has this many segments (Mitsuba's `rr_depth`).
    pub rr_depth: u32,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        IntegratorSettings { kind: IntegratorKind::Path, max_depth: 8, rr_depth: 5 }
    }
}

impl std::str::FromStr for IntegratorKind {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        match s {
            "path" => Ok(IntegratorKind::Path),
            "direct" => Ok(IntegratorKind::Direct),
            "ao" => Ok(IntegratorKind::Ao),
            "volpath" => Ok(IntegratorKind::Volpath),
            _ => anyhow::bail!("unknown integrator `{s}` (path, volpath, direct, ao)"),
        }
    }
}

/// Render one sample per pixel for pass number `pass`, writing the CIE XYZ estimate of each pixel
/// (row-major, `width*height` entries, Y = 1 for spectral radiance 1) into `xyz_out`.
/// Deterministic in (`seed`, `pass`, pixel) whatever the thread count.
pub fn render_pass(scene: &Scene, settings: &IntegratorSettings, seed: u64, pass: u64, xyz_out: &mut [[f32; 3]]) {
    let (w, h) = scene.resolution();
    let n = (w as usize) * (h as usize);
    assert!(xyz_out.len() >= n, "render_pass: output has {} entries, need {}×{}", xyz_out.len(), w, h);
    // Subsurface hook: with translucent objects and `path`, the pass's point cloud is built first.
    let sss = if settings.kind == IntegratorKind::Path { SubsurfacePass::build(scene, settings, seed, pass) } else { None };
    xyz_out[..n].par_chunks_mut(w as usize).enumerate().for_each(|(j, row)| {
        for (i, out) in row.iter_mut().enumerate() {
            let pixel = (j as u64) * (w as u64) + i as u64;
            let mut rng = Pcg32::for_pixel(seed, pass, pixel);
            *out = sample_pixel_sss(scene, settings, i as u32, j as u32, &mut rng, sss.as_ref());
        }
    });
}

/// Path throughput `beta` times the radiance of the environment seen along an escaping `ray`, MIS-weighted against light
/// sampling from `prev_p` (power heuristic) unless the last direction was not BSDF/phase-sampled
/// with a density (`no_mis`: camera ray or delta lobe). Zero without an environment.
#[inline]
pub(crate) fn environment_emission(scene: &Scene, ray: &Ray, beta: SampledSpectrum, prev_p: Vec3, prev_pdf: f32, no_mis: bool, wl: &SampledWavelengths) -> SampledSpectrum {
    let Some(ei) = scene.environment else { return Vec4::ZERO };
    let env = &scene.lights[ei as usize];
    let le = env.le(Vec3::ZERO, -ray.d, wl);
    let w = if no_mis {
        1.0
    } else {
        power_heuristic(1.0, prev_pdf, 1.0, scene.light_pmf[ei as usize] * env.pdf_li(prev_p, ray.d, Vec3::ZERO, Vec3::ZERO))
    };
    beta * le * w
}

/// One sample of pixel (`i`, `j`): XYZ estimate; non-finite estimates are replaced by 0.
#[inline]
pub fn sample_pixel(scene: &Scene, settings: &IntegratorSettings, i: u32, j: u32, rng: &mut Pcg32) -> [f32; 3] {
    sample_pixel_sss(scene, settings, i, j, rng, None)
}

/// [`sample_pixel`] with this pass's subsurface state (`None`: translucent materials act as
/// their dielectric boundary); with it, the path uses the pass's wavelengths.
#[inline]
pub fn sample_pixel_sss(scene: &Scene, settings: &IntegratorSettings, i: u32, j: u32, rng: &mut Pcg32, sss: Option<&SubsurfacePass>) -> [f32; 3] {
    let u_lambda = rng.next_f32();
    let ray = scene.camera.generate_ray(i, j, rng.next_2d());
    let xyz = match settings.kind {
        IntegratorKind::Ao => {
            // Visibility is wavelength-independent: report it as equal-energy white with Y = v.
            let v = ao_visibility(scene, ray, rng);
            let w = equal_energy_white();
            [w[0] * v, w[1] * v, w[2] * v]
        }
        kind => {
            let mut wl = match sss {
                Some(p) => p.wl,
                None => SampledWavelengths::sample(u_lambda),
            };
            let l = match kind {
                IntegratorKind::Path => match sss {
                    Some(p) => li_path_mode(scene, settings, ray, &mut wl, rng, SubsurfaceMode::Bssrdf(p), 0.0),
                    None => li_path(scene, settings, ray, &mut wl, rng),
                },
                IntegratorKind::Volpath => crate::volpath::li_volpath(scene, settings, ray, &mut wl, rng),
                _ => li_direct(scene, ray, &wl, rng),
            };
            wl.to_xyz(l)
        }
    };
    if xyz.iter().all(|c| c.is_finite()) {
        xyz
    } else {
        [0.0; 3]
    }
}

/// Geometry of a shading point, oriented towards the viewer.
struct Shading {
    p: Vec3,
    /// Geometric normal on the side of wo.
    ng: Vec3,
    /// Frame of the shading normal on the side of wo.
    frame: Frame,
    object: u32,
    /// Geometric normal as stored (for the side an area light emits to).
    ng_raw: Vec3,
}

#[inline]
fn shade(scene: &Scene, ray: &Ray, hit: &Hit) -> Shading {
    let sp = scene.accel.surface_point(ray, hit);
    let flip = sp.ng.dot(ray.d) > 0.0;
    let ng = if flip { -sp.ng } else { sp.ng };
    let mut ns = if flip { -sp.ns } else { sp.ns };
    if !(ns.dot(ng) > 0.0) || !ns.is_finite() {
        ns = ng;
    }
    Shading { p: sp.p, ng, frame: Frame::from_normal(ns), object: sp.object, ng_raw: sp.ng }
}

/// Ray leaving `p` in direction `d` (unit), offset off the surface on the side of `d`.
#[inline]
fn spawn(scene: &Scene, s: &Shading, d: Vec3) -> Ray {
    let off = if d.dot(s.ng) >= 0.0 { s.ng } else { -s.ng };
    Ray { o: s.p + off * scene.ray_epsilon_m, d, t_min: 0.0, t_max: f32::INFINITY }
}

/// Shadow ray from shading point `s` towards direction `d` up to distance `dist` (short of the light).
#[inline]
fn unoccluded(scene: &Scene, s: &Shading, d: Vec3, dist: f32) -> bool {
    let mut r = spawn(scene, s, d);
    r.t_max = if dist.is_finite() { dist * (1.0 - 1e-4) - 2.0 * scene.ray_epsilon_m } else { f32::INFINITY };
    if !(r.t_max > 0.0) {
        return true;
    }
    !scene.accel.occluded(&r)
}

/// One light sample at shading point `s` (MIS-weighted against BSDF sampling when `mis`).
#[inline]
fn sample_one_light(scene: &Scene, s: &Shading, wo: Vec3, bsdf: &Bsdf, wl: &SampledWavelengths, rng: &mut Pcg32, mis: bool) -> SampledSpectrum {
    let u_pick = rng.next_f32();
    let u = rng.next_2d();
    let Some((li_idx, pmf)) = scene.pick_light(u_pick) else { return Vec4::ZERO };
    let light = &scene.lights[li_idx];
    let Some(ls) = light.sample_li(s.p, u, wl) else { return Vec4::ZERO };
    if !(ls.pdf > 0.0) || ls.li == Vec4::ZERO {
        return Vec4::ZERO;
    }
    // Light arriving from below the geometric surface cannot reach a reflecting point's front.
    let wi_l = s.frame.to_local(ls.wi);
    let wo_l = s.frame.to_local(wo);
    let f = bsdf.eval(wo_l, wi_l);
    if f == Vec4::ZERO || (ls.wi.dot(s.ng) <= 0.0) != (wi_l.z <= 0.0) {
        return Vec4::ZERO;
    }
    if !unoccluded(scene, s, ls.wi, ls.dist) {
        return Vec4::ZERO;
    }
    let light_pdf = pmf * ls.pdf;
    let w = if ls.delta || !mis { 1.0 } else { power_heuristic(1.0, light_pdf, 1.0, bsdf.pdf(wo_l, wi_l)) };
    f * ls.li * (wi_l.z.abs() * w / light_pdf)
}

/// Radiance along `ray` by path tracing with NEE, MIS and Russian roulette.
/// `wl` may lose its secondary wavelengths on the way (dispersion): convert the result with the
/// `wl` as it is on return.
pub fn li_path(scene: &Scene, settings: &IntegratorSettings, ray: Ray, wl: &mut SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    li_path_mode(scene, settings, ray, wl, rng, SubsurfaceMode::Dielectric, 0.0)
}

/// [`li_path`] with a choice of how translucent materials are treated (see [`SubsurfaceMode`]).
/// `first_pdf` > 0: `ray` was sampled with this density per steradian from a point that also
/// sampled the lights, so emission found by the first segment is MIS-weighted against light
/// sampling (power heuristic); 0: no MIS on the first segment (camera rays).
pub fn li_path_mode(scene: &Scene, settings: &IntegratorSettings, mut ray: Ray, wl: &mut SampledWavelengths, rng: &mut Pcg32, sss: SubsurfaceMode, first_pdf: f32) -> SampledSpectrum {
    let mut l = Vec4::ZERO;
    let mut beta = Vec4::ONE;
    let mut depth = 0u32; // segments traced so far
    let mut prev_pdf = first_pdf; // BSDF density of the last direction (per sr)
    let mut prev_delta = !(first_pdf > 0.0); // camera ray or specular bounce: no MIS on emission
    let mut prev_p = ray.o;
    loop {
        let hit = scene.accel.intersect(&ray);
        depth += 1;
        let Some(hit) = hit else {
            l += environment_emission(scene, &ray, beta, prev_p, prev_pdf, prev_delta, wl);
            break;
        };
        let s = shade(scene, &ray, &hit);
        let wo = -ray.d;
        let obj = &scene.objects[s.object as usize];
        if let Some(li_idx) = obj.light {
            let light = &scene.lights[li_idx as usize];
            let le = light.le(s.ng_raw, wo, wl);
            if le != Vec4::ZERO {
                let w = if prev_delta {
                    1.0
                } else {
                    let lp = scene.light_pmf[li_idx as usize] * light.pdf_li(prev_p, ray.d, s.p, s.ng_raw);
                    power_heuristic(1.0, prev_pdf, 1.0, lp)
                };
                l += beta * le * w;
            }
        }
        if depth >= settings.max_depth {
            break;
        }
        let mat = &scene.materials[obj.material as usize];
        let bsdf = match (mat, sss) {
            // Translucent with a BSSRDF: the boundary's surface reflection (mirror, or the rough
            // dielectric's reflection lobe), plus the diffusive term.
            (Material::Translucent(t), SubsurfaceMode::ReflectOnly | SubsurfaceMode::Bssrdf(_)) => {
                if let SubsurfaceMode::Bssrdf(p) = sss {
                    l += beta * p.radiance(s.object, s.p, s.ng, wo, rng);
                }
                t.boundary_reflection()
            }
            _ => mat.bsdf_at(wl, s.ng_raw.dot(wo) > 0.0), // back face: η → 1/η; dispersion: hero only
        };
        if bsdf.is_black() {
            break;
        }
        if !bsdf.is_delta() {
            l += beta * sample_one_light(scene, &s, wo, &bsdf, wl, rng, true);
        }
        let wo_l = s.frame.to_local(wo);
        let uc = rng.next_f32();
        let Some(bs) = bsdf.sample(wo_l, uc, rng.next_2d()) else { break };
        let wi = s.frame.to_world(bs.wi);
        // Reject directions whose side of the geometric surface disagrees with the shading frame.
        if (wi.dot(s.ng) > 0.0) == bs.transmission {
            break;
        }
        beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
        if bs.terminate_secondary {
            wl.terminate_secondary();
        }
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        prev_p = s.p;
        ray = spawn(scene, &s, wi);
        if depth >= settings.rr_depth {
            let q = beta.max_element().min(0.95);
            if !(rng.next_f32() < q) {
                break;
            }
            beta /= q;
        }
    }
    l
}

/// Emission seen along `ray` plus one light sample at the first hit (no MIS).
pub fn li_direct(scene: &Scene, ray: Ray, wl: &SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    let Some(hit) = scene.accel.intersect(&ray) else {
        return match scene.environment {
            Some(ei) => scene.lights[ei as usize].le(Vec3::ZERO, -ray.d, wl),
            None => Vec4::ZERO,
        };
    };
    let s = shade(scene, &ray, &hit);
    let wo = -ray.d;
    let obj = &scene.objects[s.object as usize];
    let mut l = Vec4::ZERO;
    if let Some(li_idx) = obj.light {
        l += scene.lights[li_idx as usize].le(s.ng_raw, wo, wl);
    }
    let bsdf = scene.materials[obj.material as usize].bsdf(wl).facing(s.ng_raw.dot(wo) > 0.0); // back face: η → 1/η
    if !bsdf.is_delta() && !bsdf.is_black() {
        l += sample_one_light(scene, &s, wo, &bsdf, wl, rng, false);
    }
    l
}

/// Ambient occlusion: 1 if a cosine-distributed direction at the first hit escapes within the
/// scene's AO distance, else 0 (0 also when the camera ray misses everything).
pub fn ao_visibility(scene: &Scene, ray: Ray, rng: &mut Pcg32) -> f32 {
    let Some(hit) = scene.accel.intersect(&ray) else { return 0.0 };
    let s = shade(scene, &ray, &hit);
    let d = s.frame.to_world(cosine_hemisphere(rng.next_2d()));
    if d.dot(s.ng) <= 0.0 {
        return 0.0;
    }
    let mut r = spawn(scene, &s, d);
    r.t_max = scene.ao_distance_m;
    if scene.accel.occluded(&r) {
        0.0
    } else {
        1.0
    }
}

/// CIE XYZ of the equal-energy spectrum normalised to Y = 1 (the colour `ao` reports).
pub fn equal_energy_white() -> [f32; 3] {
    static W: std::sync::OnceLock<[f32; 3]> = std::sync::OnceLock::new();
    *W.get_or_init(|| {
        let x = crate::spectral::xyz_of(|_| 1.0);
        [(x[0] / x[1]) as f32, 1.0, (x[2] / x[1]) as f32]
    })
}

/// Samples per second (millions) of `path` on the built-in Cornell box at `width`×`height`,
/// max 8 bounces, Russian roulette from the 5th, measured over about `seconds` on the current rayon pool.
pub fn benchmark_cornell(width: u32, height: u32, seconds: f64) -> anyhow::Result<f64> {
    benchmark_cornell_clocked(width, height, seconds, || 0.0).map(|r| r.0)
}

/// [`benchmark_cornell`], also reading `clock` (e.g. the process's CPU time, seconds) before and
/// after the timed passes (the warm-up pass excluded): (Msamples per wall second, Msamples per
/// `clock` second; NaN when the clock did not advance).
pub fn benchmark_cornell_clocked(width: u32, height: u32, seconds: f64, clock: impl Fn() -> f64) -> anyhow::Result<(f64, f64)> {
    if width == 0 || height == 0 {
        anyhow::bail!("benchmark resolution must be at least 1×1, got {width}×{height}");
    }
    if !(seconds > 0.0) || !seconds.is_finite() {
        anyhow::bail!("benchmark duration must be positive, got {seconds}");
    }
    let mut scene = Scene::cornell_box();
    scene.set_resolution(width, height);
    let settings = IntegratorSettings { kind: IntegratorKind::Path, max_depth: 8, rr_depth: 5 };
    let mut buf = vec![[0f32; 3]; (width as usize) * (height as usize)];
    render_pass(&scene, &settings, 0, 0, &mut buf); // warm-up
    let start = std::time::Instant::now();
    let c0 = clock();
    let mut passes = 0u64;
    loop {
        render_pass(&scene, &settings, 1, passes, &mut buf);
        passes += 1;
        if start.elapsed().as_secs_f64() >= seconds {
            break;
        }
    }
    let t = start.elapsed().as_secs_f64();
    let c = clock() - c0;
    let samples = passes as f64 * buf.len() as f64;
    Ok((samples / t / 1e6, if c > 0.0 { samples / c / 1e6 } else { f64::NAN }))
}
