//! `[materials.NAME]`: every material type and its keys (see docs/scene-format.md).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

use crate::load::desc::{MaterialDesc, SceneDesc};
use crate::load::error::{quote, short, Cx};
use crate::load::spectrum::{as_f64, is_texture, SpectrumCx, SpectrumUse};
use crate::material::Material;
use crate::scene::SurfaceFrame;
use anyhow::Result;
use optics::spectrum::DenseSpectrum;
use std::ops::Range;
use toml::Spanned;

/// What the `[materials]` table gives: the materials, their names, whether each is one-sided, its
/// shading frame and its opacity (masks).
pub(crate) type Materials = (Vec<Material>, Vec<String>, Vec<bool>, Vec<Option<SurfaceFrame>>, Vec<Option<crate::texture::FloatTexture>>);

/// The `[materials]` table: the materials, their names, whether each is one-sided
/// (`two_sided = false`) and its shading frame (normal and bump maps, anisotropy along u), in the
/// table's (sorted) order; `unit_m` is metres per scene unit.
pub(crate) fn materials(cx: &Cx, sp: &SpectrumCx, desc: &SceneDesc, unit_m: f64) -> Result<Materials> {
    let mut materials = Vec::new();
    let mut material_names = Vec::new();
    let mut one_sided = Vec::new();
    let mut frames = Vec::new();
    let mut blends = Vec::new();
    let mut masks = Vec::new();
    for (name, m) in &desc.materials {
        let span = m.span();
        let m = m.get_ref();
        let field = format!("materials.{}", short(name));
        for (key, present, kind) in [("materials", m.materials.is_some(), "blend"), ("weight", m.weight.is_some(), "blend"), ("material", m.material.is_some(), "mask"), ("opacity", m.opacity.is_some(), "mask")] {
            if present && m.kind != kind {
                return Err(cx.err(&span, &format!("{field}.{key}"), format!("only allowed for a {kind} material, not {}", quote(&m.kind))));
            }
        }
        if matches!(m.kind.as_str(), "blend" | "mask") && m.albedo.is_some() {
            return Err(cx.err(&span, &format!("{field}.albedo"), format!("not allowed for a {} material (its materials have theirs)", m.kind)));
        }
        if m.kind == "mask" && (m.two_sided.is_some() || m.normal_map.is_some() || m.bump_map.is_some()) {
            return Err(cx.err(&span, &field, "a mask takes its material's two_sided and maps: give them to that material"));
        }
        if matches!(m.kind.as_str(), "lambertian" | "diffuse" | "diffuse_transmitter" | "black" | "interface" | "null" | "blend" | "mask") {
            for (name, present) in [("ior", m.ior.is_some()), ("metal", m.metal.is_some()), ("eta", m.eta.is_some()), ("k", m.k.is_some()), ("roughness", m.roughness.is_some()), ("alpha", m.alpha.is_some())] {
                if present {
                    return Err(cx.err(&span, &format!("{field}.{name}"), format!("not allowed for a {} material", m.kind)));
                }
            }
        }
        if m.two_sided.is_some() && !matches!(m.kind.as_str(), "lambertian" | "diffuse" | "plastic" | "conductor" | "rough_conductor" | "blend") {
            return Err(cx.err(&span, &format!("{field}.two_sided"), format!("only allowed for a reflecting material (lambertian, plastic, conductor, blend), not {}", quote(&m.kind))));
        }
        if m.coupling.is_some() && m.kind != "plastic" {
            return Err(cx.err(&span, &format!("{field}.coupling"), format!("only allowed for a plastic material, not {}", quote(&m.kind))));
        }
        if m.nonlinear.is_some() && m.kind != "plastic" {
            return Err(cx.err(&span, &format!("{field}.nonlinear"), format!("only allowed for a plastic material, not {}", quote(&m.kind))));
        }
        if m.masking.is_some() && !matches!(m.kind.as_str(), "dielectric" | "rough_dielectric" | "conductor" | "rough_conductor") {
            return Err(cx.err(&span, &format!("{field}.masking"), format!("only allowed for a dielectric or conductor material, not {}", quote(&m.kind))));
        }
        if m.distribution.is_some() && !matches!(m.kind.as_str(), "dielectric" | "rough_dielectric" | "conductor" | "rough_conductor" | "plastic") {
            return Err(cx.err(&span, &format!("{field}.distribution"), format!("only allowed for a dielectric, conductor or plastic material, not {}", quote(&m.kind))));
        }
        if m.transmittance.is_some() && m.kind != "diffuse_transmitter" {
            return Err(cx.err(&span, &format!("{field}.transmittance"), format!("only allowed for a diffuse_transmitter material, not {}", quote(&m.kind))));
        }
        if m.subsurface.is_some() && m.kind != "translucent" {
            return Err(cx.err(&span, &format!("{field}.subsurface"), format!("only allowed for a translucent material, not {}", quote(&m.kind))));
        }
        let mat = match m.kind.as_str() {
            "lambertian" | "diffuse" => {
                let albedo = m.albedo.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.albedo"), "missing (a lambertian material needs an albedo)"))?;
                Material::lambertian(sp.resolve_texture(albedo, &format!("{field}.albedo"), SpectrumUse::Albedo)?)
            }
            "diffuse_transmitter" => {
                let t = m.transmittance.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.transmittance"), "missing (a diffuse_transmitter material needs a transmittance)"))?;
                let transmittance = sp.resolve_texture(t, &format!("{field}.transmittance"), SpectrumUse::Albedo)?;
                // The reflectance defaults to 0 (a pure transmitter).
                let albedo = match &m.albedo {
                    Some(a) => sp.resolve_texture(a, &format!("{field}.albedo"), SpectrumUse::Albedo)?,
                    None => crate::texture::SpectrumTexture::Constant(DenseSpectrum::from_fn(|_| 0.0)),
                };
                // ρ + τ ≤ 1 weighted by ȳ (as a grey sheet's plain numbers, or the luminances of
                // RGB values): an RGB's uplifted spectrum overshoots its values in the far red,
                // where ȳ is near 0 and no colour depends on it.
                if let (Some(a), Some(b)) = (albedo.as_constant(), transmittance.as_constant()) {
                    let y = crate::math::spectral::xyz_of(|l| a.eval(l) + b.eval(l))[1];
                    if y > 1.0 + 1e-4 {
                        return Err(cx.err(&span, &format!("{field}.transmittance"), format!("albedo + transmittance is {y:.4} (weighted by the luminous efficiency ȳ): a sheet cannot scatter more than it receives")));
                    }
                }
                Material::DiffuseTransmitter { albedo, transmittance }
            }
            "interface" | "null" => {
                if m.albedo.is_some() {
                    return Err(cx.err(&span, &format!("{field}.albedo"), format!("not allowed for an {} material", m.kind)));
                }
                // Index-matched boundary of a medium: a dielectric of relative index 1 (pass-through).
                Material::dielectric(DenseSpectrum::from_fn(|_| 1.0), crate::bsdf::microfacet::Microfacet::isotropic(0.0))
            }
            "black" => {
                if m.albedo.is_some() {
                    return Err(cx.err(&span, &format!("{field}.albedo"), "not allowed for a black material"));
                }
                Material::Black
            }
            "translucent" => {
                let sub = m.subsurface.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.subsurface"), "missing (a translucent material needs subsurface = { ... })"))?;
                let ior = match &m.ior {
                    None => None,
                    Some(v) => Some(as_f64(v.get_ref()).ok_or_else(|| cx.err(&v.span(), &format!("{field}.ior"), "must be a number"))?),
                };
                if m.alpha.is_some() {
                    return Err(cx.err(&span, &format!("{field}.alpha"), "not allowed for a translucent material (give the boundary's roughness r ∈ [0, 1], α = r²)"));
                }
                let roughness = match &m.roughness {
                    None => None,
                    Some(v) => Some(as_f64(v.get_ref()).ok_or_else(|| cx.err(&v.span(), &format!("{field}.roughness"), "must be a number in [0, 1]"))?),
                };
                let t = crate::load::translucent::translucent_from_toml(ior, roughness, sub.get_ref()).map_err(|e| cx.err(&sub.span(), &field, format!("{e:#}")))?;
                Material::Translucent(std::sync::Arc::new(t))
            }
            "dielectric" | "rough_dielectric" | "thin_dielectric" | "conductor" | "rough_conductor" | "plastic" => bsdf_material(cx, &sp, m, &span, &field)?,
            // Resolved below, once every other material is built.
            "blend" => {
                blends.push((materials.len(), name, m, span.clone(), field.clone()));
                Material::Black
            }
            "mask" => {
                masks.push((materials.len(), name, m, span.clone(), field.clone()));
                Material::Black
            }
            other => {
                return Err(cx.err(
                    &span,
                    &format!("{field}.type"),
                    format!("unknown material type {} (known: lambertian, diffuse_transmitter, black, interface, dielectric, rough_dielectric, thin_dielectric, conductor, rough_conductor, plastic, blend, mask, translucent)", quote(other)),
                ))
            }
        };
        // A blend's frame is made once its materials are known (below).
        frames.push(if matches!(m.kind.as_str(), "blend" | "mask") { None } else { surface_frame(cx, sp, m, &field, &mat, unit_m)? });
        materials.push(mat);
        material_names.push(name.clone());
        one_sided.push(m.two_sided == Some(false));
    }
    for (i, name, m, span, field) in blends {
        let mat = blend(cx, sp, m, &span, &field, name, &materials, &material_names, &desc.materials)?;
        frames[i] = surface_frame(cx, sp, m, &field, &mat, unit_m)?;
        materials[i] = mat;
    }
    let mut opacity = vec![None; materials.len()];
    for (i, name, m, span, field) in masks {
        let target = m.material.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.material"), "missing (the name of the material it masks)"))?;
        let t = target.get_ref();
        let at = material_names.iter().position(|x| x == t).ok_or_else(|| cx.err(&target.span(), &format!("{field}.material"), format!("unknown material {}", quote(t))))?;
        let kind = desc.materials[t].get_ref().kind.as_str();
        if t == name || matches!(kind, "mask" | "translucent" | "interface" | "null") {
            return Err(cx.err(&target.span(), &format!("{field}.material"), format!("{} is a {kind} material; a mask takes a reflecting or transmitting one", quote(t))));
        }
        let o = m.opacity.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.opacity"), "missing (0 to 1: 0 lets every ray through, or a texture)"))?;
        opacity[i] = Some(match sp.resolve_float_texture(o, &format!("{field}.opacity"), 0.0, 1.0)? {
            Some(tex) => tex,
            None => {
                let x = as_f64(o.get_ref()).filter(|x| (0.0..=1.0).contains(x)).ok_or_else(|| cx.err(&o.span(), &format!("{field}.opacity"), "must be a number in [0, 1] or a texture"))?;
                crate::texture::FloatTexture::Constant(x as f32)
            }
        });
        materials[i] = materials[at].clone();
        frames[i] = frames[at].clone();
        one_sided[i] = one_sided[at];
    }
    if frames.iter().all(|f| f.is_none()) {
        frames.clear();
    }
    if opacity.iter().all(|o| o.is_none()) {
        opacity.clear();
    }
    Ok((materials, material_names, one_sided, frames, opacity))
}

/// A `blend` material (`materials = ["a", "b"]`, `weight` w ∈ [0, 1] of `b`, a number or a
/// texture) from the other materials, already built; a blend's materials must be plain
/// reflecting or transmitting materials (no blend, translucent or interface, and without maps or
/// `two_sided`, which the blend itself carries).
#[allow(clippy::too_many_arguments)]
fn blend(
    cx: &Cx,
    sp: &SpectrumCx,
    m: &MaterialDesc,
    span: &Range<usize>,
    field: &str,
    name: &str,
    materials: &[Material],
    names: &[String],
    descs: &std::collections::BTreeMap<String, Spanned<MaterialDesc>>,
) -> Result<Material> {
    let list = m.materials.as_ref().ok_or_else(|| cx.err(span, &format!("{field}.materials"), "missing (a blend needs materials = [\"first\", \"second\"])"))?;
    if list.get_ref().len() != 2 {
        return Err(cx.err(&list.span(), &format!("{field}.materials"), format!("must name exactly two materials, got {}", list.get_ref().len())));
    }
    let mut parts = Vec::new();
    for n in list.get_ref() {
        let at = names.iter().position(|x| x == n).ok_or_else(|| cx.err(&list.span(), &format!("{field}.materials"), format!("unknown material {}", quote(n))))?;
        let d = descs[n].get_ref();
        if n == name || matches!(d.kind.as_str(), "blend" | "mask" | "translucent" | "interface" | "null") {
            return Err(cx.err(&list.span(), &format!("{field}.materials"), format!("{} is a {} material; a blend takes two plain materials", quote(n), d.kind)));
        }
        if d.normal_map.is_some() || d.bump_map.is_some() || d.two_sided.is_some() {
            return Err(cx.err(&list.span(), &format!("{field}.materials"), format!("{} has a normal or bump map or two_sided; give those to the blend {}", quote(n), quote(name))));
        }
        parts.push(Box::new(materials[at].clone()));
    }
    let w = m.weight.as_ref().ok_or_else(|| cx.err(span, &format!("{field}.weight"), "missing (the weight of the second material, 0 to 1, or a texture)"))?;
    let weight = match sp.resolve_float_texture(w, &format!("{field}.weight"), 0.0, 1.0)? {
        Some(t) => t,
        None => {
            let x = as_f64(w.get_ref()).filter(|x| (0.0..=1.0).contains(x)).ok_or_else(|| cx.err(&w.span(), &format!("{field}.weight"), "must be a number in [0, 1] or a texture"))?;
            crate::texture::FloatTexture::Constant(x as f32)
        }
    };
    let b = parts.pop().expect("two");
    let a = parts.pop().expect("two");
    Ok(Material::Blend { a, b, weight })
}

/// The shading frame of material `mat`: with its normal or bump map, if it has one; tied to
/// ∂p/∂u when it is anisotropic (α_x along u, as Mitsuba 3); else `None` (the normal alone).
fn surface_frame(cx: &Cx, sp: &SpectrumCx, m: &MaterialDesc, field: &str, mat: &Material, unit_m: f64) -> Result<Option<SurfaceFrame>> {
    let maps = [("normal_map", &m.normal_map), ("bump_map", &m.bump_map)];
    let (mut map, mut shadowing, mut flip_invalid) = (None, true, true);
    for (key, v) in maps {
        let Some(v) = v else { continue };
        if matches!(mat, Material::Black | Material::Translucent(_)) || matches!(m.kind.as_str(), "interface" | "null") {
            return Err(cx.err(&v.span(), &format!("{field}.{key}"), format!("not allowed for a {} material", m.kind)));
        }
        if map.is_some() {
            return Err(cx.err(&v.span(), &format!("{field}.{key}"), "give either normal_map or bump_map, not both"));
        }
        let (m, sh, fl) = sp.resolve_shading_map(v, &format!("{field}.{key}"), key, unit_m)?;
        (map, shadowing, flip_invalid) = (Some(std::sync::Arc::new(m)), sh, fl);
    }
    fn anisotropic(mat: &Material) -> bool {
        match mat {
            Material::Dielectric { distrib, .. } | Material::Conductor { distrib, .. } => distrib.alpha_x != distrib.alpha_y,
            Material::Blend { a, b, .. } => anisotropic(a) || anisotropic(b),
            _ => false,
        }
    }
    let anisotropic = anisotropic(mat);
    Ok((map.is_some() || anisotropic).then_some(SurfaceFrame { map, shadowing, flip_invalid }))
}

/// Dielectric, conductor and plastic materials, see docs/scene-format.md ("Glass, metals, rough
/// surfaces and plastic").
pub(crate) fn bsdf_material(cx: &Cx, sp: &SpectrumCx, m: &MaterialDesc, span: &Range<usize>, field: &str) -> Result<Material> {
    use crate::bsdf::microfacet::{roughness_to_alpha, Microfacet};
    let kind = m.kind.as_str();
    let f = |name: &str| format!("{field}.{name}");
    // Fields that do not belong to this type.
    let allowed: &[&str] = match kind {
        "dielectric" | "rough_dielectric" => &["ior", "roughness", "alpha"],
        "thin_dielectric" => &["ior"],
        "conductor" | "rough_conductor" => &["metal", "eta", "k", "roughness", "alpha"],
        _ => &["albedo", "ior", "roughness", "alpha", "nonlinear"],
    };
    for (name, present) in [
        ("albedo", m.albedo.is_some()),
        ("ior", m.ior.is_some()),
        ("metal", m.metal.is_some()),
        ("eta", m.eta.is_some()),
        ("k", m.k.is_some()),
        ("roughness", m.roughness.is_some()),
        ("alpha", m.alpha.is_some()),
        ("nonlinear", m.nonlinear.is_some()),
    ] {
        if present && !allowed.contains(&name) {
            return Err(cx.err(span, &f(name), format!("not allowed for a {kind} material (allowed: {})", allowed.join(", "))));
        }
    }
    // Roughness: `roughness` r ∈ [0, 1] with α = r², or `alpha` = α or [αx, αy] (anisotropic).
    let number = |v: &Spanned<toml::Value>, name: &str, lo: f64, hi: f64| -> Result<f64> {
        let x = as_f64(v.get_ref()).ok_or_else(|| cx.err(&v.span(), &f(name), "expected a number"))?;
        if !(x >= lo && x <= hi) {
            return Err(cx.err(&v.span(), &f(name), format!("{x} is outside [{lo}, {hi}]")));
        }
        Ok(x)
    };
    // A roughness texture (r ∈ [0, 1] per texel); the checks below see its largest value.
    let mut roughness_texture = None;
    if let Some(r) = m.roughness.as_ref().filter(|r| is_texture(r.get_ref())) {
        if kind == "plastic" {
            return Err(cx.err(&r.span(), &f("roughness"), "a plastic coating's roughness cannot be textured (its albedo table is computed per roughness)"));
        }
        roughness_texture = sp.resolve_float_texture(r, &f("roughness"), 0.0, 1.0)?;
    }
    let distrib = match (&m.roughness, &m.alpha) {
        (Some(_), Some(a)) => return Err(cx.err(&a.span(), &f("alpha"), "give either roughness or alpha, not both")),
        (Some(_), None) if roughness_texture.is_some() => {
            let Some(crate::texture::FloatTexture::Image(t)) = &roughness_texture else { unreachable!() };
            Microfacet::isotropic(roughness_to_alpha(t.max_value()))
        }
        (Some(r), None) => Microfacet::isotropic(roughness_to_alpha(number(r, "roughness", 0.0, 1.0)? as f32)),
        (None, Some(a)) => match a.get_ref() {
            toml::Value::Array(xs) if kind != "plastic" => {
                let v: Vec<f64> = xs.iter().filter_map(as_f64).collect();
                if v.len() != 2 || xs.len() != 2 || !v.iter().all(|x| (0.0..=4.0).contains(x)) {
                    return Err(cx.err(&a.span(), &f("alpha"), "expected [alpha_x, alpha_y], each in [0, 4]"));
                }
                Microfacet { alpha_x: v[0] as f32, alpha_y: v[1] as f32, ..Microfacet::isotropic(0.0) }
            }
            _ => Microfacet::isotropic(number(a, "alpha", 0.0, 4.0)? as f32),
        },
        (None, None) => {
            if kind.starts_with("rough_") {
                return Err(cx.err(span, &f("roughness"), format!("missing (a {kind} material needs roughness or alpha)")));
            }
            Microfacet::isotropic(0.0)
        }
    };
    let distrib = match &m.distribution {
        None => distrib,
        Some(dn) => match crate::bsdf::microfacet::Distribution::from_name(dn.get_ref()) {
            Some(d) => distrib.with_distribution(d),
            None => return Err(cx.err(&dn.span(), &f("distribution"), format!("unknown distribution {} (ggx or beckmann)", quote(dn.get_ref())))),
        },
    };
    let distrib = match &m.masking {
        None => distrib,
        Some(mk) => match crate::bsdf::microfacet::Masking::from_name(mk.get_ref()) {
            Some(masking) => distrib.with_masking(masking),
            None => return Err(cx.err(&mk.span(), &f("masking"), format!("unknown masking {} (height-correlated or separable)", quote(mk.get_ref())))),
        },
    };
    if kind.starts_with("rough_") && distrib.effectively_smooth() {
        return Err(cx.err(span, &f("roughness"), format!("a {kind} material needs α ≥ {} (use the smooth type)", crate::bsdf::microfacet::SMOOTH_ALPHA)));
    }
    // A positive spectrum (index of refraction, η, k): number, name of a glass / named spectrum, or table.
    let positive = |v: &Spanned<toml::Value>, name: &str| -> Result<DenseSpectrum> {
        if let toml::Value::String(g) = v.get_ref() {
            if !sp.named.contains_key(g) {
                let glass = optics::ior::glass(g).map_err(|e| cx.err(&v.span(), &f(name), format!("{e:#} (or a spectrum defined under [spectra])")))?;
                return Ok(DenseSpectrum::from_fn(move |l| glass.n(l)));
            }
        }
        let d = sp.resolve(v, &f(name), SpectrumUse::Emission)?;
        // A table that does not cover 360–830 nm is extended with its end values (an index is
        // never 0), instead of the zero that spectra take outside their range.
        let x = d.samples().to_vec();
        match (x.iter().position(|&y| y > 0.0), x.iter().rposition(|&y| y > 0.0)) {
            (Some(a), Some(b)) if a > 0 || b + 1 < x.len() => {
                Ok(DenseSpectrum::from_fn(move |l| x[((l - 360.0).round().max(0.0) as usize).clamp(a, b)] as f64))
            }
            _ => Ok(d),
        }
    };
    match kind {
        "dielectric" | "rough_dielectric" => {
            let ior = match &m.ior {
                Some(v) => positive(v, "ior")?,
                None => return Err(cx.err(span, &f("ior"), "missing (a number such as 1.5, a glass name `bk7` / `fused_silica`, or a spectrum)")),
            };
            if ior.samples().iter().any(|&x| !(x > 0.0)) {
                return Err(cx.err(&m.ior.as_ref().unwrap().span(), &f("ior"), "must be positive at every wavelength"));
            }
            let mat = Material::dielectric(ior, distrib);
            Ok(match roughness_texture {
                Some(t) => mat.with_roughness_texture(t).expect("a dielectric has a roughness"),
                None => mat,
            })
        }
        "thin_dielectric" => {
            let ior = match &m.ior {
                Some(v) => positive(v, "ior")?,
                None => return Err(cx.err(span, &f("ior"), "missing (the sheet's index: a number such as 1.5, a glass name or a spectrum)")),
            };
            if ior.samples().iter().any(|&x| !(x > 0.0)) {
                return Err(cx.err(&m.ior.as_ref().unwrap().span(), &f("ior"), "must be positive at every wavelength"));
            }
            Ok(Material::ThinDielectric { ior })
        }
        "conductor" | "rough_conductor" => {
            let (eta, k) = match (&m.metal, &m.eta, &m.k) {
                (Some(name), None, None) => {
                    let t = optics::ior::metal(name.get_ref()).map_err(|e| cx.err(&name.span(), &f("metal"), format!("{e:#}")))?;
                    let t2 = t.clone();
                    (DenseSpectrum::from_fn(move |l| t.eta_k(l).0), DenseSpectrum::from_fn(move |l| t2.eta_k(l).1))
                }
                (None, Some(e), Some(k)) => (positive(e, "eta")?, positive(k, "k")?),
                (Some(_), _, _) => return Err(cx.err(span, &f("metal"), "give either metal or eta and k, not both")),
                _ => return Err(cx.err(span, &f("metal"), "missing (metal = \"au\" | \"ag\" | \"cu\" | \"al\" | \"cr\", or both eta and k)")),
            };
            let mat = Material::conductor(eta, k, distrib);
            Ok(match roughness_texture {
                Some(t) => mat.with_roughness_texture(t).expect("a conductor has a roughness"),
                None => mat,
            })
        }
        _ => {
            // plastic
            let albedo = m.albedo.as_ref().ok_or_else(|| cx.err(span, &f("albedo"), "missing (a plastic material needs the albedo of its base)"))?;
            let albedo = sp.resolve_texture(albedo, &f("albedo"), SpectrumUse::Albedo)?;
            let ior = match &m.ior {
                Some(v) => number(v, "ior", 1.0001, 4.0)?,
                None => 1.5,
            };
            if distrib.alpha_x != distrib.alpha_y {
                return Err(cx.err(span, &f("alpha"), "a plastic coating is isotropic (one alpha)"));
            }
            let mut mat = Material::plastic(albedo, ior as f32, distrib.alpha_x).with_coating_distribution(distrib.distribution).expect("a plastic has a coating");
            match m.coupling.as_ref().map(|c| (c, c.get_ref().as_str())) {
                None | Some((_, "energy")) => {}
                Some((_, "mitsuba")) => mat = mat.with_mitsuba_coupling().expect("a plastic has a coating"),
                Some((c, other)) => return Err(cx.err(&c.span(), &f("coupling"), format!("unknown coupling {} (energy or mitsuba)", quote(other)))),
            }
            Ok(mat.with_nonlinear(m.nonlinear.unwrap_or(true)).expect("a plastic takes nonlinear"))
        }
    }
}
