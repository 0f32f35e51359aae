//! Basis renders for `lucent fit photo` (see [`super::model`] for how they combine): each label's
//! surfaces at albedo 1 with the other labels black, under the environment alone, under an
//! all-white projector image and under each frame's pattern; and the same for the rest of the
//! scene (objects whose material is not a label, and the environment seen directly). All renders
//! use the `direct` integrator, one light at a time (the light choice never wastes samples on a
//! light that is off), and the same seed and passes (common random numbers): the
//! estimator is then linear in the albedos, the light spectra and the projector's image values
//! sample by sample, so a pattern and its complement sum to the all-white render exactly and the
//! complement is formed as all-white − pattern instead of being rendered.

use std::time::Instant;

use anyhow::{bail, Result};
use optics::spectrum::DenseSpectrum;
use render::integrator::{IntegratorKind, IntegratorSettings};
use render::light::Light;
use render::material::Material;
use render::scene::Scene;
use render::texture::SpectrumTexture;

use crate::scene_fit::render_image;

/// Prefix of the material names the fit adjusts (`label0`, `label1`, …).
pub const LABEL_PREFIX: &str = "label";

/// One label: its material's name and index, and its starting albedo (linear sRGB).
#[derive(Clone, Debug)]
pub struct Label {
    /// Material name (`label<k>`).
    pub name: String,
    /// Index into `Scene::materials`.
    pub material: usize,
    /// The material's albedo as linear sRGB under D65 (the starting guess); for a glossy label
    /// the albedo seen under its coating (ρ_eff, `plastic` with `nonlinear = false`).
    pub albedo: [f64; 3],
    /// The coating of a `plastic` label (None: Lambertian).
    pub gloss: Option<Gloss>,
}

/// The dielectric coating of a glossy (`plastic`) label: the fit keeps its index and roughness
/// (the roughness can be searched, [`crate::photo_fit::fit_roughness`]) and fits the albedo under it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gloss {
    /// Coating index relative to the outside.
    pub ior: f32,
    /// Microfacet roughness α.
    pub alpha: f32,
    /// Shape of the coating's microfacet distribution.
    pub distribution: render::bsdf::microfacet::Distribution,
}

/// Linear-sRGB image data, row-major from the top row.
pub type Plane = Vec<[f32; 3]>;

/// The basis renders of a scene for a set of frames. Index `labels.len()` of each per-label list
/// is the rest of the scene; with glossy labels, index `labels.len() + 1` is their coatings'
/// specular reflection (albedo-independent, lit like the rest).
pub struct Basis {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The labels, in the order of the albedos in the parameter vector.
    pub labels: Vec<Label>,
    /// Per label (+ rest): under the environment alone (zero without an environment).
    pub ambient: Vec<Plane>,
    /// Per label (+ rest): under the all-white projector image (zero without a projector).
    pub flood: Vec<Plane>,
    /// Per frame, per label (+ rest): under the frame's pattern.
    pub frames: Vec<Vec<Plane>>,
    /// Whether the lists hold the glossy labels' specular reflection after the rest.
    pub specular: bool,
    /// Wall-clock seconds of each render made, in order.
    pub render_seconds: Vec<f64>,
}

/// The labels of `scene`: every material whose name starts with `label`, which must be an
/// untextured Lambertian or `plastic` (glossy: its albedo is fitted as the albedo seen under the
/// coating, as `nonlinear = false` takes it). Errors when there is none.
pub fn scene_labels(scene: &Scene) -> Result<Vec<Label>> {
    let white = DenseSpectrum::from_fn(optics::spectrum::d65_normalized);
    let white_rgb = spectrum_rgb(&DenseSpectrum::from_fn(|_| 1.0), &white);
    let mut labels = vec![];
    for (i, (name, m)) in scene.material_names.iter().zip(&scene.materials).enumerate() {
        if !name.starts_with(LABEL_PREFIX) {
            continue;
        }
        let albedo = match m {
            Material::Lambertian { albedo } => match albedo.as_constant() {
                Some(s) => {
                    let rgb = spectrum_rgb(s, &white);
                    std::array::from_fn(|c| (rgb[c] / white_rgb[c]).clamp(0.0, 1.0))
                }
                None => bail!("materials.{name}: a fitted label must have a constant albedo, not a texture"),
            },
            Material::Black => [0.0; 3],
            Material::Plastic { mitsuba: Some(_), .. } => bail!("materials.{name}: a fitted label's plastic must use the default coupling, not coupling = \"mitsuba\""),
            Material::Plastic { albedo, nonlinear, table, .. } => match albedo.as_constant() {
                Some(s) => {
                    let rgb = spectrum_rgb(s, &white);
                    std::array::from_fn(|c| {
                        let r = (rgb[c] / white_rgb[c]).clamp(0.0, 1.0);
                        // The albedo under the coating (the base's, darkened by its internal reflections).
                        if *nonlinear { table.albedo_under(glam::Vec4::splat(r as f32)).x as f64 } else { r }
                    })
                }
                None => bail!("materials.{name}: a fitted label must have a constant albedo, not a texture"),
            },
            Material::Dielectric { .. } | Material::ThinDielectric { .. } | Material::Conductor { .. } | Material::Translucent(_) | Material::Blend { .. } | Material::DiffuseTransmitter { .. } => {
                bail!("materials.{name}: a fitted label must be lambertian or plastic")
            }
        };
        let gloss = match m {
            Material::Plastic { ior, alpha, distribution, .. } => Some(Gloss { ior: *ior, alpha: *alpha, distribution: *distribution }),
            _ => None,
        };
        labels.push(Label { name: name.clone(), material: i, albedo, gloss });
    }
    if labels.is_empty() {
        bail!("{}: no material named label* to fit", scene.source);
    }
    labels.sort_by(|a, b| natural_key(&a.name).cmp(&natural_key(&b.name)));
    Ok(labels)
}

fn natural_key(name: &str) -> (u64, String) {
    let digits: String = name[LABEL_PREFIX.len()..].chars().take_while(|c| c.is_ascii_digit()).collect();
    (digits.parse().unwrap_or(u64::MAX), name.to_string())
}

/// Linear sRGB of reflectance `s` under illuminant `light` (both dense spectra).
fn spectrum_rgb(s: &DenseSpectrum, light: &DenseSpectrum) -> [f64; 3] {
    let xyz = optics::color::spectrum_to_xyz(|l| s.eval(l as f32) as f64 * light.eval(l as f32) as f64);
    optics::color::xyz_to_linear_srgb(xyz)
}

/// Index of the projector and of the environment among the scene's lights; errors on any other light.
pub fn scene_lights(scene: &Scene) -> Result<(Option<usize>, Option<usize>)> {
    let (mut projector, mut environment) = (None, None);
    for (i, l) in scene.lights.iter().enumerate() {
        match l {
            Light::Projector(_) => {
                if projector.replace(i).is_some() {
                    bail!("lights[{i}]: lucent fit photo handles one projector");
                }
            }
            Light::Environment { .. } => environment = Some(i),
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::Area { .. } | Light::EnvMap(_) => {
                bail!("lights[{i}]: lucent fit photo handles a projector and a constant environment only")
            }
        }
    }
    if projector.is_none() && environment.is_none() {
        bail!("{}: no projector and no environment light: nothing lights the labels", scene.source);
    }
    Ok((projector, environment))
}

/// Size (width, height) of the scene's projector image, if it has a projector.
pub fn projector_size(scene: &Scene) -> Option<(u32, u32)> {
    scene.lights.iter().find_map(|l| if let Light::Projector(p) = l { Some((p.camera.width, p.camera.height)) } else { None })
}

/// Renders `scene` lit by light `index` alone (light choice pmf 1): each light's share is
/// rendered on its own, so that next-event estimation never spends samples on another light.
fn render_one_light(scene: &mut Scene, index: usize, settings: &IntegratorSettings, seed: u64, spp: u64) -> Plane {
    let lights = std::mem::take(&mut scene.lights);
    let (pmf, cdf, env) = (std::mem::take(&mut scene.light_pmf), std::mem::take(&mut scene.light_cdf), scene.environment);
    let light = lights[index].clone();
    scene.environment = if matches!(light, Light::Environment { .. } | Light::EnvMap(_)) { Some(0) } else { None };
    scene.lights = vec![light];
    scene.light_pmf = vec![1.0];
    scene.light_cdf = vec![1.0];
    let img = render_image(scene, settings, seed, 0..spp);
    scene.lights = lights;
    scene.light_pmf = pmf;
    scene.light_cdf = cdf;
    scene.environment = env;
    img.rgb
}

/// What one basis render lights and shows.
#[derive(Clone, Copy, PartialEq)]
enum Target {
    Label(usize),
    Rest,
    /// The glossy labels' coatings alone (their albedo 0).
    Specular,
}

/// A label's material in a render: albedo `albedo` (a spectrum), Lambertian or under its coating.
fn label_material(gloss: Option<Gloss>, albedo: DenseSpectrum) -> Material {
    match gloss {
        None => Material::Lambertian { albedo: SpectrumTexture::from(albedo) },
        Some(g) => Material::plastic(albedo, g.ior, g.alpha).with_coating_distribution(g.distribution).and_then(|m| m.with_nonlinear(false)).expect("a plastic"),
    }
}

/// Sets every glossy label's roughness to `alpha` in `scene` and in `labels`.
pub fn set_roughness(scene: &mut Scene, labels: &mut [Label], alpha: f32) {
    for l in labels.iter_mut() {
        if let Some(g) = &mut l.gloss {
            g.alpha = alpha;
            if let Material::Plastic { albedo, ior, nonlinear, distribution, .. } = &scene.materials[l.material] {
                let m = Material::plastic(albedo.clone(), *ior, alpha).with_coating_distribution(*distribution).and_then(|m| m.with_nonlinear(*nonlinear)).expect("a plastic");
                scene.materials[l.material] = m;
            }
        }
    }
}

/// Renders the basis of `scene` at its resolution for frames with the given projector images
/// (linear values at the projector's resolution; `None`: the scene's own image), `spp` passes of
/// `seed`. The scene is changed while rendering and restored before returning.
pub fn render_basis(scene: &mut Scene, patterns: &[Option<Vec<f32>>], spp: u64, seed: u64) -> Result<Basis> {
    let labels = scene_labels(scene)?;
    let (proj_i, env_i) = scene_lights(scene)?;
    let (w, h) = scene.resolution();
    let n = w as usize * h as usize;
    let settings = IntegratorSettings { kind: IntegratorKind::Direct, max_depth: 2, rr_depth: 1000 };
    let saved_materials = scene.materials.clone();
    let saved_lights = scene.lights.clone();
    let zero = DenseSpectrum::from_fn(|_| 0.0);
    let one = DenseSpectrum::from_fn(|_| 1.0);
    let label_materials: Vec<usize> = labels.iter().map(|l| l.material).collect();
    let has_rest_objects = scene.objects.iter().any(|o| !label_materials.contains(&(o.material as usize)));
    let scene_image: Option<Vec<f32>> =
        proj_i.and_then(|i| if let Light::Projector(p) = &scene.lights[i] { Some(p.image.clone()) } else { None });
    let mut render_seconds = vec![];

    // Sets the materials and lights for one render: `target` at albedo 1, the other labels black;
    // the environment on or off; the projector showing `image` (None = off).
    // A glossy label's coating reflects in every render but the rest's, so that a label's render
    // minus the coatings' render is its diffuse reflection alone.
    let mut render = |scene: &mut Scene, target: Target, ambient: bool, image: Option<&[f32]>| -> Result<Plane> {
        for (k, &m) in label_materials.iter().enumerate() {
            let on = target == Target::Label(k);
            scene.materials[m] = match (labels[k].gloss, on, target) {
                (_, true, _) => label_material(labels[k].gloss, one.clone()),
                (Some(g), false, Target::Label(_) | Target::Specular) => label_material(Some(g), zero.clone()),
                _ => Material::Lambertian { albedo: SpectrumTexture::from(zero.clone()) },
            };
        }
        for (i, l) in scene.lights.iter_mut().enumerate() {
            match l {
                Light::Projector(p) => {
                    let Light::Projector(orig) = &saved_lights[i] else { unreachable!("lights keep their kinds") };
                    match image {
                        Some(img) => {
                            p.image = img.to_vec();
                            p.colour = None;
                            p.intensity = orig.intensity.clone();
                        }
                        None => p.intensity = zero.clone(),
                    }
                }
                Light::Environment { radiance } => {
                    let Light::Environment { radiance: orig } = &saved_lights[i] else { unreachable!("lights keep their kinds") };
                    *radiance = if ambient { orig.clone() } else { zero.clone() };
                }
                Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::Area { .. } | Light::EnvMap(_) => {}
            }
        }
        let t = Instant::now();
        let only = if image.is_some() { proj_i } else { env_i };
        let img = match only {
            Some(i) => render_one_light(scene, i, &settings, seed, spp),
            None => vec![[0.0; 3]; n],
        };
        render_seconds.push(t.elapsed().as_secs_f64());
        Ok(img)
    };

    let glossy = labels.iter().any(|l| l.gloss.is_some());
    let targets: Vec<Target> =
        (0..labels.len()).map(Target::Label).chain(std::iter::once(Target::Rest)).chain(glossy.then_some(Target::Specular)).collect();
    let blank = || vec![[0.0f32; 3]; n];
    let result = (|| -> Result<Basis> {
        let mut ambient = vec![];
        let mut flood = vec![];
        let proj_n = projector_size(scene).map(|(pw, ph)| pw as usize * ph as usize);
        let ones: Option<Vec<f32>> = proj_n.map(|m| vec![1.0; m]);
        for &t in &targets {
            let skip_rest_projector = t == Target::Rest && !has_rest_objects;
            ambient.push(if env_i.is_some() { render(scene, t, true, None)? } else { blank() });
            flood.push(match (&ones, skip_rest_projector) {
                (Some(o), false) => render(scene, t, false, Some(o))?,
                _ => blank(),
            });
        }
        // A label's render also holds what the rest of the scene shows under the same light (the
        // environment seen directly, non-label objects): the same samples (common random
        // numbers) make subtracting the rest's render leave exactly the label's own reflection.
        // With glossy labels, a label's render minus the coatings' render, and the coatings' minus
        // the rest's.
        let k_rest = labels.len();
        let minus_rest = |planes: &mut Vec<Plane>| {
            let sub = |a: &mut Plane, b: &Plane| {
                for (x, y) in a.iter_mut().zip(b) {
                    for c in 0..3 {
                        x[c] -= y[c];
                    }
                }
            };
            let base = planes[if glossy { k_rest + 1 } else { k_rest }].clone();
            for p in planes.iter_mut().take(k_rest) {
                sub(p, &base);
            }
            if glossy {
                let rest = planes[k_rest].clone();
                sub(&mut planes[k_rest + 1], &rest);
            }
        };
        minus_rest(&mut ambient);
        minus_rest(&mut flood);
        // Distinct patterns rendered so far, with their basis per target.
        let mut rendered: Vec<(Vec<f32>, Vec<Plane>)> = vec![];
        let mut frames = vec![];
        for pat in patterns {
            let Some(pm) = proj_n else {
                frames.push(targets.iter().map(|_| blank()).collect());
                continue;
            };
            let img: &[f32] = match pat {
                Some(p) => p,
                None => scene_image.as_deref().unwrap_or(&[]),
            };
            if img.len() != pm {
                bail!("a frame's pattern has {} pixels, the projector {pm}", img.len());
            }
            // A uniform image v₀ gives v₀ × the all-white render (the estimator is linear in it).
            if let Some(&v0) = img.first().filter(|&&v0| img.iter().all(|&v| v == v0)) {
                frames.push(flood.iter().map(|fl| fl.iter().map(|f| f.map(|c| c * v0)).collect()).collect());
                continue;
            }
            if let Some((_, b)) = rendered.iter().find(|(q, _)| q.as_slice() == img) {
                frames.push(b.clone());
                continue;
            }
            if let Some((_, b)) = rendered.iter().find(|(q, _)| q.iter().zip(img).all(|(a, c)| a + c == 1.0)) {
                let comp: Vec<Plane> = b
                    .iter()
                    .zip(&flood)
                    .map(|(bq, fl)| bq.iter().zip(fl).map(|(q, f)| std::array::from_fn(|c| f[c] - q[c])).collect())
                    .collect();
                frames.push(comp);
                continue;
            }
            let mut per = vec![];
            for &t in &targets {
                let skip_rest_projector = t == Target::Rest && !has_rest_objects;
                per.push(if skip_rest_projector { blank() } else { render(scene, t, false, Some(img))? });
            }
            minus_rest(&mut per);
            rendered.push((img.to_vec(), per.clone()));
            frames.push(per);
        }
        Ok(Basis { width: w, height: h, labels: labels.clone(), ambient, flood, frames, specular: glossy, render_seconds: vec![] })
    })();
    scene.materials = saved_materials;
    scene.lights = saved_lights;
    let mut basis = result?;
    basis.render_seconds = render_seconds;
    Ok(basis)
}

/// Sets the scene to fitted values: each label's albedo to its RGB (uplifted, Jakob & Hanika
/// 2019; a glossy label's as the albedo under its coating, `nonlinear = false`), the projector's
/// intensity × `projector_scale`, the environment's radiance × `ambient_scale`. The projector's
/// black level acts on its image, see [`render_frame`].
pub fn apply_fit(scene: &mut Scene, labels: &[Label], albedo: &[[f64; 3]], projector_scale: f64, ambient_scale: f64) {
    for (l, a) in labels.iter().zip(albedo) {
        let s = optics::spectrum::RgbAlbedo::new(*a);
        scene.materials[l.material] = label_material(l.gloss, DenseSpectrum::from_fn(|x| s.eval(x)));
    }
    for l in scene.lights.iter_mut() {
        match l {
            Light::Projector(p) => {
                let i = p.intensity.clone();
                p.intensity = DenseSpectrum::from_fn(|x| i.eval(x as f32) as f64 * projector_scale);
            }
            Light::Environment { radiance } => {
                let r = radiance.clone();
                *radiance = DenseSpectrum::from_fn(|x| r.eval(x as f32) as f64 * ambient_scale);
            }
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::Area { .. } | Light::EnvMap(_) => {}
        }
    }
}

/// Full render (linear sRGB, `direct`, `spp` passes of `seed`, each light rendered alone and the
/// shares added, as light adds linearly) of the scene with the projector
/// showing `pattern` (None: its own image) lifted by the black level β: v' = (1 − β) v + β.
pub fn render_frame(scene: &mut Scene, pattern: Option<&[f32]>, projector_black: f64, spp: u64, seed: u64) -> Result<Plane> {
    let settings = IntegratorSettings { kind: IntegratorKind::Direct, max_depth: 2, rr_depth: 1000 };
    let mut saved = None;
    for l in scene.lights.iter_mut() {
        if let Light::Projector(p) = l {
            let base = pattern.map(|v| v.to_vec()).unwrap_or_else(|| p.image.clone());
            if base.len() != p.image.len() {
                bail!("a frame's pattern has {} pixels, the projector {}", base.len(), p.image.len());
            }
            let b = projector_black as f32;
            // A grey pattern replaces a colour image's spectra; the projector's own image keeps
            // them (and then the black level lifts only a grey image).
            let colour = if pattern.is_some() { p.colour.take() } else { p.colour.clone() };
            saved = Some((std::mem::replace(&mut p.image, base.iter().map(|v| (1.0 - b) * v + b).collect()), colour));
        }
    }
    let (w, h) = scene.resolution();
    let mut sum = vec![[0.0f32; 3]; w as usize * h as usize];
    for i in 0..scene.lights.len() {
        let img = render_one_light(scene, i, &settings, seed, spp);
        for (a, b) in sum.iter_mut().zip(&img) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
    }
    if let Some((image, colour)) = saved {
        for l in scene.lights.iter_mut() {
            if let Light::Projector(p) = l {
                (p.image, p.colour) = (image.clone(), colour.clone());
            }
        }
    }
    Ok(sum)
}

/// The mean of two bases of the same scene and frames (rendered with independent seeds and the
/// same number of passes): the basis of both renders' samples together.
pub fn average(a: &Basis, b: &Basis) -> Basis {
    let mean = |p: &Plane, q: &Plane| -> Plane { p.iter().zip(q).map(|(x, y)| std::array::from_fn(|c| 0.5 * (x[c] + y[c]))).collect() };
    let both = |p: &[Plane], q: &[Plane]| -> Vec<Plane> { p.iter().zip(q).map(|(x, y)| mean(x, y)).collect() };
    Basis {
        width: a.width,
        height: a.height,
        labels: a.labels.clone(),
        ambient: both(&a.ambient, &b.ambient),
        flood: both(&a.flood, &b.flood),
        frames: a.frames.iter().zip(&b.frames).map(|(x, y)| both(x, y)).collect(),
        specular: a.specular,
        render_seconds: a.render_seconds.iter().chain(&b.render_seconds).cloned().collect(),
    }
}
