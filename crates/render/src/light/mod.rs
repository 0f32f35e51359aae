//! Luminaires: point, spot, directional, diffuse area lights on triangle meshes and spheres, a
//! constant environment, a latitude–longitude environment map ([`envmap`]) and image
//! projectors ([`projector`]).
//!
//! Every light has a spectrum at 1-nm resolution. Units: area and environment lights give spectral
//! radiance (W·m⁻²·sr⁻¹·nm⁻¹), point and spot lights spectral intensity (W·sr⁻¹·nm⁻¹), directional
//! lights spectral irradiance on a surface perpendicular to them (W·m⁻²·nm⁻¹). Positions in metres.
//!
//! `sample_li` draws a point or direction on the light as seen from a shading point and returns
//! the incident radiance and the density per steradian of the direction (area lights: uniform by
//! area on triangle meshes, pdf 1/A converted to solid angle; spheres seen from outside: uniform in
//! the cone they subtend). `pdf_li` gives the same density for a direction found by BSDF sampling,
//! for multiple importance sampling. Environment maps are sampled in proportion to luminance ×
//! sin θ (see [`envmap`]).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod envmap;
pub mod projector;
pub mod refracted;

use crate::math::sampling::{sample_cdf, uniform_cone, uniform_sphere, uniform_triangle, Frame, UNIFORM_SPHERE_PDF};
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use crate::shape::sphere::texture_uv;
use crate::texture::SpectrumTexture;
use glam::{Vec2, Vec3, Vec4};
use optics::spectrum::DenseSpectrum;
use std::f32::consts::PI;
use std::sync::Arc;

/// The surface an area light emits from (world coordinates, metres).
#[derive(Clone, Debug)]
pub enum Emitter {
    /// Triangles, sampled uniformly by area.
    Triangles {
        /// Each triangle as (p0, p1 − p0, p2 − p0, unit normal along (p1 − p0) × (p2 − p0)).
        tris: Vec<[Vec3; 4]>,
        /// Cumulative areas (m²); the last entry is the total area.
        cdf: Vec<f32>,
        /// Texture coordinates of each triangle's vertices (for a textured radiance), in the
        /// order of `tris`.
        uvs: Option<Vec<[Vec2; 3]>>,
    },
    /// A sphere.
    Sphere {
        /// Centre (m).
        center: Vec3,
        /// Radius (m).
        radius: f32,
    },
}

/// A light source.
#[derive(Clone, Debug)]
pub enum Light {
    /// Isotropic point source.
    Point {
        /// Position (m).
        position: Vec3,
        /// Spectral intensity (W·sr⁻¹·nm⁻¹).
        intensity: DenseSpectrum,
    },
    /// Spot light: intensity along the axis, smooth (smoothstep in cos θ) falloff from
    /// `cos_falloff_start` to zero at `cos_total`.
    Spot {
        /// Position (m).
        position: Vec3,
        /// Frame whose normal is the spot's axis.
        frame: Frame,
        /// Cosine of the total cone half-angle.
        cos_total: f32,
        /// Cosine of the half-angle where the falloff starts.
        cos_falloff_start: f32,
        /// The shape of the falloff between the two.
        falloff: SpotFalloff,
        /// Spectral intensity on the axis (W·sr⁻¹·nm⁻¹).
        intensity: DenseSpectrum,
    },
    /// Distant source.
    Directional {
        /// Unit direction in which the light travels.
        direction: Vec3,
        /// Spectral irradiance on a surface perpendicular to it (W·m⁻²·nm⁻¹).
        irradiance: DenseSpectrum,
    },
    /// Diffuse emitter on the surface of a scene object; its radiance may vary over the surface
    /// with the texture coordinates (an emissive image).
    Area {
        /// Index of the emitting object in the scene.
        object: u32,
        /// Its surface.
        emitter: Emitter,
        /// Emitting area (m²).
        area_m2: f32,
        /// Spectral radiance (W·m⁻²·sr⁻¹·nm⁻¹), constant or textured (image texels uplifted
        /// to illuminant spectra).
        radiance: SpectrumTexture,
        /// Whether it emits on both sides (else only on the side of the geometric normal).
        two_sided: bool,
    },
    /// Point light emitting an image through a camera model (see [`projector`]).
    Projector(Box<projector::Projector>),
    /// Radiance arriving from every direction not blocked by the scene.
    Environment {
        /// Spectral radiance (W·m⁻²·sr⁻¹·nm⁻¹).
        radiance: DenseSpectrum,
    },
    /// Radiance from an image over the sphere of directions (latitude–longitude), arriving from
    /// every direction not blocked by the scene.
    EnvMap(Arc<envmap::EnvMap>),
}

/// A sample of incident light at a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (infinite for directional and environment lights).
    pub dist: f32,
    /// Incident spectral radiance (for delta lights: intensity/r² or irradiance).
    pub li: SampledSpectrum,
    /// Density per steradian of `wi` (1 for delta lights).
    pub pdf: f32,
    /// Whether the light is a delta distribution in direction (point, spot, directional).
    pub delta: bool,
}

impl Emitter {
    /// Emitting area in m².
    pub fn area_m2(&self) -> f32 {
        match self {
            Emitter::Triangles { cdf, .. } => *cdf.last().unwrap_or(&0.0),
            Emitter::Sphere { radius, .. } => 4.0 * PI * radius * radius,
        }
    }

    /// Build from triangles; errors when the total area is not positive.
    pub fn triangles(tris: Vec<[Vec3; 3]>) -> anyhow::Result<Emitter> {
        Emitter::textured_triangles(tris, None)
    }

    /// Build from triangles with, optionally, the texture coordinates of their vertices (one
    /// entry per triangle); errors when the total area is not positive.
    pub fn textured_triangles(tris: Vec<[Vec3; 3]>, uvs: Option<Vec<[Vec2; 3]>>) -> anyhow::Result<Emitter> {
        if let Some(u) = &uvs {
            anyhow::ensure!(u.len() == tris.len(), "{} triangles but {} texture-coordinate triples", tris.len(), u.len());
        }
        let mut cdf = Vec::with_capacity(tris.len());
        let mut out = Vec::with_capacity(tris.len());
        let mut out_uv = Vec::new();
        let mut acc = 0.0f64;
        for (i, t) in tris.iter().enumerate() {
            let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
            let c = e1.cross(e2);
            let a = 0.5 * c.length() as f64;
            if a > 0.0 {
                acc += a;
                cdf.push(acc as f32);
                out.push([t[0], e1, e2, c.normalize()]);
                if let Some(u) = &uvs {
                    out_uv.push(u[i]);
                }
            }
        }
        if !(acc > 0.0) || !acc.is_finite() {
            anyhow::bail!("emitting surface has zero area");
        }
        Ok(Emitter::Triangles { tris: out, cdf, uvs: uvs.map(|_| out_uv) })
    }
}

/// Probabilities (summing to 1) of choosing each light for next-event estimation, from the
/// lights' powers (`powers_w`, [`Light::power_w`]): in proportion to power, except that the lights
/// at infinity ([`Light::is_at_infinity`]; n of them) together get at most n/(n + 1) when the
/// scene has bounded lights of positive power too, the bounded ones sharing the rest in
/// proportion to power. The power of a light at infinity counts all it sends through a disc of
/// the scene's radius, which overstates its share at the surfaces a lamp lights (a 1 m² lamp of
/// radiance 5 under an environment of 0.3 in a scene of radius 7 m would get 3 % of the samples);
/// the cap is the share pbrt-v4's BVH light sampler gives lights at infinity, and Mitsuba 3's
/// uniform choice gives one environment and one lamp. Uniform when no light has power.
pub fn selection_pmf(lights: &[Light], powers_w: &[f32]) -> Vec<f32> {
    let n = lights.len();
    let total: f32 = powers_w.iter().sum();
    if !(total > 0.0) {
        return vec![1.0 / n.max(1) as f32; n];
    }
    let mut pmf: Vec<f32> = powers_w.iter().map(|p| p / total).collect();
    let at_inf: Vec<bool> = lights.iter().map(Light::is_at_infinity).collect();
    let n_inf = at_inf.iter().filter(|&&b| b).count();
    let inf_share: f32 = pmf.iter().zip(&at_inf).filter(|(_, &b)| b).map(|(p, _)| p).sum();
    let bounded_w: f32 = powers_w.iter().zip(&at_inf).filter(|(_, &b)| !b).map(|(p, _)| p).sum();
    let cap = n_inf as f32 / (n_inf + 1) as f32;
    if n_inf > 0 && bounded_w > 0.0 && inf_share > cap {
        for (i, p) in pmf.iter_mut().enumerate() {
            *p = if at_inf[i] { *p * cap / inf_share } else { (1.0 - cap) * powers_w[i] / bounded_w };
        }
    }
    pmf
}

impl Light {
    /// True for lights at infinity: the environment, an environment map and directional lights.
    pub fn is_at_infinity(&self) -> bool {
        matches!(self, Light::Environment { .. } | Light::EnvMap(_) | Light::Directional { .. })
    }

    /// True for lights with a delta distribution in direction (cannot be hit by rays).
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::Projector(_))
    }

    /// Approximate emitted power in W (∫ spectrum dλ over 360–830 nm) used to choose lights in
    /// proportion; `scene_radius_m` bounds the scene for distant lights.
    pub fn power_w(&self, scene_radius_m: f32) -> f32 {
        let integral = |s: &DenseSpectrum| -> f32 { (0..=470).map(|i| s.eval(360.0 + i as f32)).sum::<f32>() };
        match self {
            Light::Point { intensity, .. } => 4.0 * PI * integral(intensity),
            Light::Spot { intensity, cos_total, cos_falloff_start, falloff, .. } => falloff.solid_angle(*cos_total, *cos_falloff_start) * integral(intensity),
            Light::Directional { irradiance, .. } => PI * scene_radius_m * scene_radius_m * integral(irradiance),
            Light::Area { area_m2, radiance, two_sided, .. } => {
                PI * area_m2 * integral(&radiance.representative()) * if *two_sided { 2.0 } else { 1.0 }
            }
            Light::Projector(p) => p.weighted_solid_angle_sr * integral(&p.intensity),
            Light::Environment { radiance } => 4.0 * PI * PI * scene_radius_m * scene_radius_m * integral(radiance),
            Light::EnvMap(map) => map.power_w(scene_radius_m),
        }
    }

    /// Sample incident light at point `p` (m); `u` uniform in [0,1)².
    #[inline]
    pub fn sample_li(&self, p: Vec3, u: Vec2, wl: &SampledWavelengths) -> Option<LightSample> {
        match self {
            Light::Point { position, intensity } => {
                let d = *position - p;
                let r2 = d.length_squared();
                if !(r2 > 0.0) {
                    return None;
                }
                let dist = r2.sqrt();
                Some(LightSample { wi: d / dist, dist, li: wl.eval(intensity) / r2, pdf: 1.0, delta: true })
            }
            Light::Spot { position, frame, cos_total, cos_falloff_start, falloff, intensity } => {
                let d = *position - p;
                let r2 = d.length_squared();
                if !(r2 > 0.0) {
                    return None;
                }
                let dist = r2.sqrt();
                let wi = d / dist;
                let cos = (-wi).dot(frame.n);
                let k = falloff.eval(cos, *cos_total, *cos_falloff_start);
                if k <= 0.0 {
                    return None;
                }
                Some(LightSample { wi, dist, li: wl.eval(intensity) * (k / r2), pdf: 1.0, delta: true })
            }
            Light::Projector(pr) => {
                let d = pr.position() - p;
                let r2 = d.length_squared();
                if !(r2 > 0.0) {
                    return None;
                }
                if pr.colour.is_some() {
                    let v = pr.spectrum_at(p, wl);
                    if v == Vec4::ZERO {
                        return None;
                    }
                    let dist = r2.sqrt();
                    return Some(LightSample { wi: d / dist, dist, li: wl.eval(&pr.intensity) * v / r2, pdf: 1.0, delta: true });
                }
                let v = pr.weight_at(p);
                if !(v > 0.0) {
                    return None;
                }
                let dist = r2.sqrt();
                Some(LightSample { wi: d / dist, dist, li: wl.eval(&pr.intensity) * (v / r2), pdf: 1.0, delta: true })
            }
            Light::Directional { direction, irradiance } => Some(LightSample {
                wi: -*direction,
                dist: f32::INFINITY,
                li: wl.eval(irradiance),
                pdf: 1.0,
                delta: true,
            }),
            Light::Area { emitter, area_m2, radiance, two_sided, .. } => {
                // The triangle and barycentrics of the sample (texture coordinates, where needed).
                let (q, n, tri, b) = match emitter {
                    Emitter::Triangles { tris, cdf, .. } => {
                        let (i, ur) = if cdf.len() == 1 { (0, u.x) } else { sample_cdf(cdf, u.x) };
                        let t = &tris[i];
                        let b = uniform_triangle(Vec2::new(ur, u.y));
                        (t[0] + t[1] * b.x + t[2] * b.y, t[3], i, b)
                    }
                    Emitter::Sphere { center, radius } => {
                        let dc = *center - p;
                        let dc2 = dc.length_squared();
                        let r2 = radius * radius;
                        if dc2 > r2 * 1.0001 {
                            // Outside: sample the cone of directions the sphere subtends.
                            let dist_c = dc2.sqrt();
                            let sin2 = r2 / dc2;
                            let cos_max = (1.0 - sin2).max(0.0).sqrt();
                            let frame = Frame::from_normal(dc / dist_c);
                            let wi = frame.to_world(uniform_cone(u, cos_max));
                            // Nearest intersection of the ray p + t wi with the sphere.
                            let b = wi.dot(dc);
                            let disc = (b * b - (dc2 - r2)).max(0.0);
                            let t = b - disc.sqrt();
                            let q = p + wi * t;
                            let n = (q - *center) / *radius;
                            let cos_l = n.dot(-wi);
                            let emits = *two_sided || cos_l > 0.0;
                            if !emits || !(t > 0.0) {
                                return None;
                            }
                            let pdf = 1.0 / (2.0 * PI * (1.0 - cos_max));
                            let li = match radiance {
                                SpectrumTexture::Constant(s) => wl.eval(s),
                                textured => textured_radiance(textured, emitter, 0, Vec2::ZERO, n, wl),
                            };
                            return Some(LightSample { wi, dist: t, li, pdf, delta: false });
                        }
                        let n = uniform_sphere(u);
                        (*center + n * *radius, n, 0, Vec2::ZERO)
                    }
                };
                let d = q - p;
                let dist2 = d.length_squared();
                if !(dist2 > 0.0) {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                let cos_l = n.dot(-wi);
                if !(*two_sided || cos_l > 0.0) || cos_l == 0.0 {
                    return None;
                }
                let pdf = dist2 / (cos_l.abs() * area_m2);
                let li = match radiance {
                    SpectrumTexture::Constant(s) => wl.eval(s),
                    textured => textured_radiance(textured, emitter, tri, b, n, wl),
                };
                Some(LightSample { wi, dist, li, pdf, delta: false })
            }
            Light::Environment { radiance } => {
                let wi = uniform_sphere(u);
                Some(LightSample { wi, dist: f32::INFINITY, li: wl.eval(radiance), pdf: UNIFORM_SPHERE_PDF, delta: false })
            }
            Light::EnvMap(map) => {
                let (wi, pdf) = map.sample(u)?;
                Some(LightSample { wi, dist: f32::INFINITY, li: map.radiance(wi, wl), pdf, delta: false })
            }
        }
    }

    /// Density per steradian with which `sample_li` at `p` would pick direction `wi` that hits this
    /// light at point `q` with geometric normal `ng` (for the environment, `q` and `ng` are unused).
    #[inline]
    pub fn pdf_li(&self, p: Vec3, wi: Vec3, q: Vec3, ng: Vec3) -> f32 {
        match self {
            Light::Area { emitter, area_m2, .. } => {
                if let Emitter::Sphere { center, radius } = emitter {
                    let dc2 = (*center - p).length_squared();
                    let r2 = radius * radius;
                    if dc2 > r2 * 1.0001 {
                        let cos_max = (1.0 - r2 / dc2).max(0.0).sqrt();
                        return 1.0 / (2.0 * PI * (1.0 - cos_max));
                    }
                }
                let dist2 = (q - p).length_squared();
                let cos_l = ng.dot(wi).abs();
                if cos_l == 0.0 {
                    return 0.0;
                }
                dist2 / (cos_l * area_m2)
            }
            Light::Environment { .. } => UNIFORM_SPHERE_PDF,
            Light::EnvMap(map) => map.pdf(wi),
            // Delta lights are never hit by a sampled direction.
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::Projector(_) => 0.0,
        }
    }

    /// Radiance emitted towards `wo` (unit, pointing away from the surface) by an area light at a
    /// point with geometric normal `ng` and texture coordinates `uv()` (called only for a
    /// textured radiance), or by the environment in direction −`wo`.
    #[inline]
    pub fn le(&self, ng: Vec3, wo: Vec3, uv: impl FnOnce() -> Vec2, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Light::Area { radiance, two_sided, .. } => {
                if *two_sided || ng.dot(wo) > 0.0 {
                    radiance.eval_with(wl, uv)
                } else {
                    Vec4::ZERO
                }
            }
            Light::Environment { radiance } => wl.eval(radiance),
            Light::EnvMap(map) => map.radiance(-wo, wl),
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::Projector(_) => Vec4::ZERO,
        }
    }
}

/// Radiance of a textured area light at a sampled point: on triangle `tri` of a mesh emitter
/// at barycentrics `b` (weights 1 − b₁ − b₂, b₁, b₂ of its vertices, as a ray hit's), or on a
/// sphere emitter at unit normal `n`. Kept out of line: untextured lights never come here.
#[cold]
#[inline(never)]
fn textured_radiance(radiance: &SpectrumTexture, emitter: &Emitter, tri: usize, b: Vec2, n: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
    let uv = match emitter {
        Emitter::Triangles { uvs: Some(uvs), .. } => {
            let t = uvs[tri];
            (1.0 - b.x - b.y) * t[0] + b.x * t[1] + b.y * t[2]
        }
        Emitter::Triangles { uvs: None, .. } => Vec2::ZERO,
        Emitter::Sphere { .. } => texture_uv(n),
    };
    radiance.eval(wl, uv)
}

/// How a spot light falls from full intensity at the inner cone's edge to 0 at the outer one's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SpotFalloff {
    /// Smoothstep in the cosine of the angle off the axis (pbrt-v4's `spot`).
    #[default]
    Smoothstep,
    /// Linear in the angle itself (Mitsuba 3's `spot`, between `beam_width` and `cutoff_angle`).
    Linear,
}

impl SpotFalloff {
    /// The name the scene format uses.
    pub fn name(self) -> &'static str {
        match self {
            SpotFalloff::Smoothstep => "smoothstep",
            SpotFalloff::Linear => "linear",
        }
    }

    /// The falloff named `name`.
    pub fn from_name(name: &str) -> Option<SpotFalloff> {
        [SpotFalloff::Smoothstep, SpotFalloff::Linear].into_iter().find(|f| f.name() == name)
    }

    /// Intensity relative to the axis at `cos_theta` off it, for a cone of cosine `cos_total`
    /// whose falloff starts at cosine `cos_falloff_start`.
    #[inline]
    pub fn eval(self, cos_theta: f32, cos_total: f32, cos_falloff_start: f32) -> f32 {
        match self {
            SpotFalloff::Smoothstep => smooth_falloff(cos_theta, cos_total, cos_falloff_start),
            SpotFalloff::Linear => {
                if cos_theta >= cos_falloff_start {
                    return 1.0;
                }
                if cos_theta <= cos_total {
                    return 0.0;
                }
                let (total, start) = (cos_total.acos(), cos_falloff_start.acos());
                ((total - cos_theta.clamp(-1.0, 1.0).acos()) / (total - start)).clamp(0.0, 1.0)
            }
        }
    }

    /// ∫ falloff dω over the sphere (sr): 2π(1 − cos β) inside the inner cone (half-angle β) plus
    /// the falloff ring out to γ. Smoothstep in cos θ integrates to half the ring's cosine span,
    /// 2π(cos β − cos γ)/2; linear in θ to 2π(cos β − (sin γ − sin β)/(γ − β)).
    pub fn solid_angle(self, cos_total: f32, cos_falloff_start: f32) -> f32 {
        let (cg, cb) = (cos_total as f64, cos_falloff_start as f64);
        let inner = 1.0 - cb;
        let ring = match self {
            SpotFalloff::Smoothstep => 0.5 * (cb - cg),
            SpotFalloff::Linear => {
                let (g, b) = (cg.acos(), cb.acos());
                if g - b > 1e-9 {
                    cb - (g.sin() - b.sin()) / (g - b)
                } else {
                    0.0
                }
            }
        };
        (2.0 * std::f64::consts::PI * (inner + ring)) as f32
    }
}

/// Spot-light falloff: 1 inside the inner cone, 0 outside the outer one, smoothstep in between.
#[inline]
pub fn smooth_falloff(cos_theta: f32, cos_total: f32, cos_falloff_start: f32) -> f32 {
    if cos_theta >= cos_falloff_start {
        return 1.0;
    }
    if cos_theta <= cos_total {
        return 0.0;
    }
    let t = (cos_theta - cos_total) / (cos_falloff_start - cos_total);
    t * t * (3.0 - 2.0 * t)
}
