//! `[[lights]]`: point, spot, directional, area (on an object) and environment lights, with
//! `scale` or `power_w`.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

use crate::load::desc::SceneDesc;
use crate::load::error::{quote, short, Cx};
use crate::load::object::{finite3, transform_matrix, v3, MAX_COORDINATE_M};
use crate::load::spectrum::{SpectrumCx, SpectrumUse};
use crate::light::{Emitter, Light};
use crate::scene::ObjectInfo;
use crate::shape::Shape;
use anyhow::Result;
use glam::Vec3;
use optics::spectrum::DenseSpectrum;
use toml::Spanned;

/// Largest value of a light's scaled emission spectrum (per nm, in the light's unit: W·sr⁻¹·nm⁻¹,
/// W·m⁻²·nm⁻¹ or W·m⁻²·sr⁻¹·nm⁻¹). Radiance estimates are f32 (largest value 3.4·10³⁸); this bound
/// leaves eight orders of magnitude for the estimators' weights (1/pdf, 1/r²) and the film's
/// colour sums. Brighter lights are refused at load rather than rendered black.
pub const MAX_EMISSION: f64 = 1e30;

/// The lights, linked to their objects (`objects[i].light`), and the index of the environment.
pub(crate) fn lights(cx: &Cx, sp: &SpectrumCx, desc: &SceneDesc, unit_m: f64, shapes: &[Shape], objects: &mut [ObjectInfo]) -> Result<(Vec<Light>, Option<u32>)> {
    let mut lights = Vec::new();
    let mut environment = None;
    for (k, l) in desc.lights.iter().enumerate() {
        let span = l.span();
        let l = l.get_ref();
        let field = format!("lights[{k}] ({})", short(&l.kind));
        let check_keys = |allowed: &[&str]| -> Result<()> {
            let present = [
                ("object", l.object.is_some()),
                ("position", l.position.is_some()),
                ("direction", l.direction.is_some()),
                ("look_at", l.look_at.is_some()),
                ("cone_deg", l.cone_deg.is_some()),
                ("falloff_start_deg", l.falloff_start_deg.is_some()),
                ("radiance", l.radiance.is_some()),
                ("intensity", l.intensity.is_some()),
                ("irradiance", l.irradiance.is_some()),
                ("two_sided", l.two_sided.is_some()),
                ("falloff", l.falloff.is_some()),
                ("image", l.image.is_some()),
                ("response", l.response.is_some()),
                ("profile", l.profile.is_some()),
                ("camera", l.camera.is_some()),
                ("file", l.file.is_some()),
                ("transform", l.transform.is_some()),
            ];
            for (key, is) in present {
                if is && !allowed.contains(&key) {
                    return Err(cx.err(&span, &format!("{field}.{key}"), format!("not used by a {} light", l.kind)));
                }
            }
            Ok(())
        };
        if l.scale.is_some() && l.power_w.is_some() {
            return Err(cx.err(&span, &field, "give scale or power_w, not both"));
        }
        if let Some(s) = l.scale {
            if !(s >= 0.0) || !s.is_finite() {
                return Err(cx.err(&span, &format!("{field}.scale"), format!("must be non-negative, got {s}")));
            }
        }
        if let Some(p) = l.power_w {
            if !(p > 0.0) || !p.is_finite() {
                return Err(cx.err(&span, &format!("{field}.power_w"), format!("must be positive, got {p}")));
            }
        }
        let need = |v: &Option<Spanned<toml::Value>>, key: &str| -> Result<DenseSpectrum> {
            let v = v.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.{key}"), format!("missing (a {} light needs {key})", l.kind)))?;
            sp.resolve(v, &format!("{field}.{key}"), SpectrumUse::Emission)
        };
        let need_point = |v: &Option<[f64; 3]>, key: &str| -> Result<Vec3> {
            let p = v.ok_or_else(|| cx.err(&span, &format!("{field}.{key}"), "missing"))?;
            if !finite3(&p) {
                return Err(cx.err(&span, &format!("{field}.{key}"), "must be finite"));
            }
            if key != "direction" && p.iter().any(|x| !((x * unit_m).abs() <= MAX_COORDINATE_M as f64)) {
                return Err(cx.err(&span, &format!("{field}.{key}"), format!("{p:?} lies beyond ±{MAX_COORDINATE_M:e} m")));
            }
            Ok(v3(p))
        };
        // Scale the spectrum: by `scale`, or so that the light emits `power_w` watts (360–830 nm).
        let scaled = |s: DenseSpectrum, geometric: f64| -> Result<DenseSpectrum> {
            let k = if let Some(p) = l.power_w {
                let integral: f64 = (0..=470).map(|i| s.eval(360.0 + i as f32) as f64).sum();
                if !(integral > 0.0) || !(geometric > 0.0) {
                    return Err(cx.err(&span, &format!("{field}.power_w"), "cannot scale a light whose spectrum or size is zero"));
                }
                p / (integral * geometric)
            } else {
                l.scale.unwrap_or(1.0)
            };
            let peak = (0..=470).map(|i| s.eval(360.0 + i as f32) as f64 * k).fold(0.0, f64::max);
            if !(peak <= MAX_EMISSION) {
                let at = match (l.power_w, l.scale) {
                    (Some(_), _) => format!("{field}.power_w"),
                    (None, Some(_)) => format!("{field}.scale"),
                    (None, None) => field.clone(),
                };
                return Err(cx.err(&span, &at, format!("the scaled spectrum peaks at {peak:.3e} per nm, above the {MAX_EMISSION:e} the renderer carries")));
            }
            Ok(DenseSpectrum::from_fn(|x| s.eval(x as f32) as f64 * k))
        };
        let light = match l.kind.as_str() {
            "point" => {
                check_keys(&["position", "intensity"])?;
                let position = need_point(&l.position, "position")? * unit_m as f32;
                Light::Point { position, intensity: scaled(need(&l.intensity, "intensity")?, 4.0 * std::f64::consts::PI)? }
            }
            "spot" => {
                check_keys(&["position", "look_at", "cone_deg", "falloff_start_deg", "falloff", "intensity"])?;
                let position = need_point(&l.position, "position")? * unit_m as f32;
                let target = need_point(&l.look_at, "look_at")? * unit_m as f32;
                let axis = (target - position).normalize_or_zero();
                if axis == Vec3::ZERO {
                    return Err(cx.err(&span, &format!("{field}.look_at"), "must differ from position"));
                }
                let cone = l.cone_deg.unwrap_or(30.0);
                let start = l.falloff_start_deg.unwrap_or(cone * 0.75);
                if !(cone > 0.0 && cone <= 180.0) {
                    return Err(cx.err(&span, &format!("{field}.cone_deg"), format!("must be in (0, 180], got {cone}")));
                }
                if !(start >= 0.0 && start <= cone) {
                    return Err(cx.err(&span, &format!("{field}.falloff_start_deg"), format!("must be in [0, cone_deg], got {start}")));
                }
                let cos_total = (cone.to_radians().cos()) as f32;
                let cos_falloff_start = (start.to_radians().cos()) as f32;
                let falloff = match &l.falloff {
                    None => crate::light::SpotFalloff::Smoothstep,
                    Some(name) => crate::light::SpotFalloff::from_name(name)
                        .ok_or_else(|| cx.err(&span, &format!("{field}.falloff"), format!("unknown falloff {} (use \"smoothstep\" or \"linear\")", quote(name))))?,
                };
                let solid = falloff.solid_angle(cos_total, cos_falloff_start) as f64;
                Light::Spot {
                    position,
                    frame: crate::math::sampling::Frame::from_normal(axis),
                    cos_total,
                    cos_falloff_start,
                    falloff,
                    intensity: scaled(need(&l.intensity, "intensity")?, solid)?,
                }
            }
            "directional" => {
                check_keys(&["direction", "irradiance"])?;
                let d = need_point(&l.direction, "direction")?.normalize_or_zero();
                if d == Vec3::ZERO {
                    return Err(cx.err(&span, &format!("{field}.direction"), "must be non-zero"));
                }
                if l.power_w.is_some() {
                    return Err(cx.err(&span, &format!("{field}.power_w"), "a directional light has no finite power: use scale"));
                }
                Light::Directional { direction: d, irradiance: scaled(need(&l.irradiance, "irradiance")?, 1.0)? }
            }
            "environment" | "envmap" => {
                check_keys(if l.kind == "environment" { &["radiance"] } else { &["file", "transform"] })?;
                if l.power_w.is_some() {
                    return Err(cx.err(&span, &format!("{field}.power_w"), "an environment has no finite power: use scale"));
                }
                let new = if l.kind == "environment" {
                    Light::Environment { radiance: scaled(need(&l.radiance, "radiance")?, 1.0)? }
                } else {
                    Light::EnvMap(std::sync::Arc::new(envmap(cx, sp, &span, &field, l)?))
                };
                // A constant environment and a map add up (two emitters at infinity, as Mitsuba 3
                // allows): one map with the constant radiance added in every direction.
                if let Some(e) = environment {
                    let old = std::mem::replace(&mut lights[e as usize], Light::Environment { radiance: DenseSpectrum::from_fn(|_| 0.0) });
                    lights[e as usize] = match (old, new) {
                        (Light::Environment { radiance }, Light::EnvMap(map)) | (Light::EnvMap(map), Light::Environment { radiance }) => {
                            let map = std::sync::Arc::try_unwrap(map).unwrap_or_else(|_| unreachable!("a map being loaded has one owner"));
                            Light::EnvMap(std::sync::Arc::new(map.with_ambient(radiance)))
                        }
                        _ => return Err(cx.err(&span, &field, "at most one environment and one envmap (two of the same kind: merge them into one)")),
                    };
                    continue;
                }
                environment = Some(lights.len() as u32);
                new
            }
            "area" => {
                check_keys(&["object", "radiance", "two_sided"])?;
                let oname = l.object.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.object"), "missing (name of the emitting object)"))?;
                let oi = objects.iter().position(|o| &o.name == oname).ok_or_else(|| {
                    cx.err(&span, &format!("{field}.object"), format!("unknown object {}", quote(oname)))
                })?;
                if objects[oi].light.is_some() {
                    return Err(cx.err(&span, &format!("{field}.object"), format!("object {} already has a light", quote(oname))));
                }
                let rv = l.radiance.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.radiance"), format!("missing (a {} light needs radiance)", l.kind)))?;
                let radiance = sp.resolve_texture(rv, &format!("{field}.radiance"), SpectrumUse::Emission)?;
                let textured = radiance.is_textured();
                let emitter = match &shapes[oi] {
                    Shape::Mesh(m) => {
                        let uvs = match (&m.uvs, textured) {
                            (Some(uv), true) => Some(m.indices.iter().map(|t| t.map(|k| uv[k as usize])).collect()),
                            (None, true) => {
                                return Err(cx.err(
                                    &span,
                                    &format!("{field}.radiance"),
                                    format!("is textured but object {} has no texture coordinates (OBJ vt, PLY u/v)", quote(oname)),
                                ))
                            }
                            (_, false) => None,
                        };
                        Emitter::textured_triangles(
                            m.indices.iter().map(|t| [m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]]).collect(),
                            uvs,
                        )
                        .map_err(|e| cx.err(&span, &format!("{field}.object"), format!("{}: {e}", quote(oname))))?
                    }
                    Shape::Sphere(s) => Emitter::Sphere { center: s.center, radius: s.radius },
                };
                let area_m2 = emitter.area_m2();
                if !(area_m2 > 0.0) {
                    return Err(cx.err(&span, &format!("{field}.object"), format!("{} has zero area", quote(oname))));
                }
                let two_sided = l.two_sided.unwrap_or(false);
                let geometric = std::f64::consts::PI * area_m2 as f64 * if two_sided { 2.0 } else { 1.0 };
                objects[oi].light = Some(lights.len() as u32);
                let radiance = match radiance {
                    crate::texture::SpectrumTexture::Constant(c) => crate::texture::SpectrumTexture::Constant(scaled(c, geometric)?),
                    t => scaled_texture(cx, &span, &field, l, t, geometric)?,
                };
                Light::Area { object: oi as u32, emitter, area_m2, radiance, two_sided }
            }
            "projector" => {
                check_keys(&["image", "response", "profile", "camera", "intensity"])?;
                projector(cx, sp, unit_m, l, &span, &field, &scaled, need(&l.intensity, "intensity")?)?
            }
            other => {
                return Err(cx.err(&span, &format!("{field}.type"), format!("unknown light type {} (known: point, spot, directional, area, environment, envmap, projector)", quote(other))))
            }
        };
        lights.push(light);
    }

    Ok((lights, environment))
}

/// A textured radiance scaled by `scale`, or so that the light emits `power_w` watts with the
/// representative spectrum of the texture ([`crate::texture::SpectrumTexture::representative`]);
/// refused when its peak exceeds [`MAX_EMISSION`].
fn scaled_texture(
    cx: &Cx,
    span: &std::ops::Range<usize>,
    field: &str,
    l: &crate::load::desc::LightDesc,
    t: crate::texture::SpectrumTexture,
    geometric: f64,
) -> Result<crate::texture::SpectrumTexture> {
    let k = if let Some(p) = l.power_w {
        let rep = t.representative();
        let integral: f64 = (0..=470).map(|i| rep.eval(360.0 + i as f32) as f64).sum();
        if !(integral > 0.0) || !(geometric > 0.0) {
            return Err(cx.err(span, &format!("{field}.power_w"), "cannot scale a light whose texture or size is zero"));
        }
        p / (integral * geometric)
    } else {
        l.scale.unwrap_or(1.0)
    };
    let peak = t.peak() * k;
    if !(peak <= MAX_EMISSION) {
        let at = if l.power_w.is_some() { format!("{field}.power_w") } else if l.scale.is_some() { format!("{field}.scale") } else { format!("{field}.radiance") };
        return Err(cx.err(span, &at, format!("the scaled texture peaks at {peak:.3e} per nm, above the {MAX_EMISSION:e} the renderer carries")));
    }
    Ok(if k == 1.0 { t } else { t.scaled(k) })
}

/// A projector light: `image` (through `response`), `camera` (a camera table; its size defaults to
/// the image's and must equal it), `intensity` for a pixel of value 1.
#[allow(clippy::too_many_arguments)]
fn projector(
    cx: &Cx,
    sp: &SpectrumCx,
    unit_m: f64,
    l: &crate::load::desc::LightDesc,
    span: &std::ops::Range<usize>,
    field: &str,
    scaled: impl Fn(DenseSpectrum, f64) -> Result<DenseSpectrum>,
    intensity: DenseSpectrum,
) -> Result<Light> {
    use crate::light::projector::{read_projector_image, Profile, Projector, Response};
    let rel = l.image.as_ref().ok_or_else(|| cx.err(span, &format!("{field}.image"), "missing (the image to project)"))?;
    let response = match &l.response {
        None => Response::Srgb,
        Some(toml::Value::String(s)) if s == "srgb" => Response::Srgb,
        Some(toml::Value::String(s)) if s == "linear" => Response::Linear,
        Some(v) => match v.as_float().or(v.as_integer().map(|i| i as f64)) {
            Some(g) if g > 0.0 && g.is_finite() => Response::Gamma(g),
            _ => return Err(cx.err(span, &format!("{field}.response"), format!("unknown response {v} (use \"linear\", \"srgb\" or a gamma > 0)"))),
        },
    };
    let profile = match &l.profile {
        None => Profile::Intensity,
        Some(name) => Profile::from_name(name)
            .ok_or_else(|| cx.err(span, &format!("{field}.profile"), format!("unknown profile {} (use \"intensity\" or \"irradiance\")", quote(name))))?,
    };
    let path = sp.files.path(rel).map_err(|e| cx.err(span, &format!("{field}.image"), e))?;
    let (w, h, values) = read_projector_image(&path, response).map_err(|e| cx.err(span, &format!("{field}.image"), format!("{e:#}")))?;
    if let Ok(bytes) = std::fs::read(&path) {
        sp.hash.borrow_mut().write(&bytes);
    }
    let cam = l.camera.as_ref().ok_or_else(|| cx.err(span, &format!("{field}.camera"), "missing (the projector's camera model and pose)"))?;
    let cfield = format!("{field}.camera");
    let camera = crate::load::camera::camera_from(cx, sp.files, unit_m, cam.get_ref(), &cam.span(), &cfield, Some((w, h)), &mut |b| sp.hash.borrow_mut().write(b))?;
    if (camera.width, camera.height) != (w, h) {
        return Err(cx.err(span, &cfield, format!("is {}×{} but the image {rel} is {w}×{h}", camera.width, camera.height)));
    }
    if camera.lens.is_some() {
        return Err(cx.err(span, &cfield, "a projector has no lens (aperture_radius, f_number)"));
    }
    let p = Projector::with_colours(camera, &values, intensity).map_err(|e| cx.err(span, &format!("{field}.image"), e))?.with_profile(profile);
    let intensity = scaled(p.intensity.clone(), p.weighted_solid_angle_sr as f64)?;
    Ok(Light::Projector(Box::new(Projector { intensity, ..p })))
}

/// An `envmap` light: the image `file`, `scale` (default 1) and the rotation `transform`.
fn envmap(cx: &Cx, sp: &SpectrumCx, span: &std::ops::Range<usize>, field: &str, l: &crate::load::desc::LightDesc) -> Result<crate::light::envmap::EnvMap> {
    let rel = l.file.as_ref().ok_or_else(|| cx.err(span, &format!("{field}.file"), "missing (the latitude–longitude image: .exr, .pfm or .hdr)"))?;
    let (image, bytes) = sp.files.load_image(rel).map_err(|e| cx.err(span, &format!("{field}.file"), format!("{e:#}")))?;
    sp.hash.borrow_mut().write(&bytes);
    let rotation = match &l.transform {
        Some(t) => glam::Mat3::from_mat4(transform_matrix(cx, span, &format!("{field}.transform"), t)?),
        None => glam::Mat3::IDENTITY,
    };
    let g = rotation.transpose() * rotation - glam::Mat3::IDENTITY;
    if g.to_cols_array().iter().any(|x| x.abs() > 1e-4) {
        return Err(cx.err(span, &format!("{field}.transform"), "must be a rotation (no scale or shear; a translation has no effect)"));
    }
    let scale = l.scale.unwrap_or(1.0);
    if !(scale as f32).is_finite() {
        return Err(cx.err(span, &format!("{field}.scale"), format!("{scale} overflows single precision")));
    }
    crate::light::envmap::EnvMap::new(&image, scale as f32, rotation).map_err(|e| cx.err(span, &format!("{field}.file"), format!("{rel}: {e}")))
}
