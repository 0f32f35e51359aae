//! Scenes: the TOML scene format (documented in `docs/scene-format.md`) and the built-in measured
//! Cornell box.
//!
//! A scene file declares its length unit (`unit = "mm"`); every position and length in it is in
//! that unit and converted to metres here. Spectra are given inline or by name (`[spectra.NAME]`):
//! a constant, `blackbody = K`, `rgb = [r, g, b]`, `csv = "file.csv"` with `column`, or inline
//! `lambda_nm`/`values`, each with an optional `scale`; tabulated spectra are zero outside their
//! range. Materials and objects refer to each other by name. Errors name the file, the line and
//! column, and the field; unknown keys are rejected.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

use crate::bvh::{Accel, Shape};
use crate::camera::Camera;
use crate::geometry::Sphere;
use crate::integrator::{IntegratorKind, IntegratorSettings};
use crate::light::{Emitter, Light};
use crate::material::Material;
use crate::mesh::TriangleMesh;
use anyhow::{anyhow, bail, Context, Result};
use glam::{Mat4, Vec3};
use optics::spectrum::DenseSpectrum;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// What the renderer knows about one scene object (parallel to the shapes in the accelerator).
#[derive(Clone, Debug)]
pub struct ObjectInfo {
    /// Name from the scene file (or generated).
    pub name: String,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Index into [`Scene::lights`] when the object is an area light.
    pub light: Option<u32>,
    /// Index into [`Scene::media`] of the medium inside this (closed) object, if it bounds one.
    pub interior_medium: Option<u32>,
}

/// Everything a render needs: camera, geometry with its acceleration structure, materials, lights.
pub struct Scene {
    /// The pinhole camera (its resolution is the render's).
    pub camera: Camera,
    /// Geometry: one shape per object, BVH over all of them.
    pub accel: Accel,
    /// Per-object material and light links, indexed like the accelerator's shapes.
    pub objects: Vec<ObjectInfo>,
    /// Materials, indexed by [`ObjectInfo::material`].
    pub materials: Vec<Material>,
    /// Material names, parallel to `materials`.
    pub material_names: Vec<String>,
    /// All lights.
    pub lights: Vec<Light>,
    /// Probability of choosing each light for next-event estimation (proportional to power).
    pub light_pmf: Vec<f32>,
    /// Cumulative of `light_pmf`.
    pub light_cdf: Vec<f32>,
    /// Index of the environment light, if any (rays that escape see it).
    pub environment: Option<u32>,
    /// Homogeneous participating media (object interiors and the global medium).
    pub media: Vec<crate::medium::HomogeneousMedium>,
    /// Per medium, the free-flight distance bounds over its bounding objects (`volpath` skips ray
    /// casts for collisions closer than them); `None` for the global medium and pure absorbers.
    pub medium_grids: Vec<Option<crate::medium::FreeFlightGrid>>,
    /// Index into `media` of the medium filling space outside every medium-bounding object
    /// (the camera's medium), if any.
    pub global_medium: Option<u32>,
    /// Integrator settings given in the scene file (defaults: path, 8, 5).
    pub integrator: IntegratorSettings,
    /// Ambient-occlusion ray length in metres (infinite by default).
    pub ao_distance_m: f32,
    /// Offset (m) for spawning rays off surfaces, relative to the scene's size.
    pub ray_epsilon_m: f32,
    /// Metres per scene length unit.
    pub unit_m: f64,
    /// Where the scene came from (file name or "built-in Cornell box").
    pub source: String,
    content_hash: u64,
}

/// Access to the files a scene refers to (the file system, or files embedded in the binary).
trait SceneFiles {
    /// Text of a file named in the scene (path as written, relative to the scene's folder).
    fn read_text(&self, rel: &str) -> Result<String>;
    /// Meshes in a file named in the scene, with the file's bytes for hashing.
    fn load_mesh(&self, rel: &str) -> Result<(Vec<(String, TriangleMesh)>, Vec<u8>)>;
}

struct DiskFiles {
    base: PathBuf,
}

impl SceneFiles for DiskFiles {
    fn read_text(&self, rel: &str) -> Result<String> {
        let p = self.base.join(rel);
        std::fs::read_to_string(&p).with_context(|| format!("cannot read {}", p.display()))
    }
    fn load_mesh(&self, rel: &str) -> Result<(Vec<(String, TriangleMesh)>, Vec<u8>)> {
        let p = self.base.join(rel);
        let bytes = std::fs::read(&p).with_context(|| format!("cannot read mesh {}", p.display()))?;
        let meshes = TriangleMesh::load(&p).with_context(|| format!("cannot load mesh {}", p.display()))?;
        Ok((meshes, bytes))
    }
}

/// Text of the built-in Cornell box scene (the same file as `scenes/cornell-box.toml`).
pub const CORNELL_BOX_TOML: &str = include_str!("../../../scenes/cornell-box.toml");
const CBOX_REFLECTANCE_CSV: &str = include_str!("../data/cornell-box/cbox_reflectance.csv");
const CBOX_EMISSION_CSV: &str = include_str!("../data/cornell-box/cbox_light_emission.csv");

struct EmbeddedFiles;

impl SceneFiles for EmbeddedFiles {
    fn read_text(&self, rel: &str) -> Result<String> {
        let name = rel.rsplit(['/', '\\']).next().unwrap_or(rel);
        match name {
            "cbox_reflectance.csv" => Ok(CBOX_REFLECTANCE_CSV.to_string()),
            "cbox_light_emission.csv" => Ok(CBOX_EMISSION_CSV.to_string()),
            _ => bail!("{rel} is not embedded in the binary"),
        }
    }
    fn load_mesh(&self, rel: &str) -> Result<(Vec<(String, TriangleMesh)>, Vec<u8>)> {
        bail!("mesh {rel} is not embedded in the binary")
    }
}

impl Scene {
    /// Load a TOML scene; errors name the file and the field or line.
    pub fn load(path: &Path) -> anyhow::Result<Scene> {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read scene", path.display()))?;
        let base = path.parent().map(|p| p.to_path_buf()).unwrap_or_default();
        Scene::from_toml(&text, &path.display().to_string(), &DiskFiles { base })
    }

    /// Parse a TOML scene held in memory; relative file names resolve against `base_dir`;
    /// `name` labels error messages.
    pub fn from_toml_str(text: &str, name: &str, base_dir: &Path) -> anyhow::Result<Scene> {
        Scene::from_toml(text, name, &DiskFiles { base: base_dir.to_path_buf() })
    }

    /// The built-in default scene: the measured Cornell box (same as `scenes/cornell-box.toml`).
    pub fn cornell_box() -> Scene {
        Scene::from_toml(CORNELL_BOX_TOML, "built-in scenes/cornell-box.toml", &EmbeddedFiles)
            .expect("the built-in Cornell box scene is valid")
    }

    /// Override the camera resolution in pixels.
    pub fn set_resolution(&mut self, width: u32, height: u32) {
        self.camera.set_resolution(width, height);
    }

    /// Camera resolution (width, height) in pixels.
    pub fn resolution(&self) -> (u32, u32) {
        (self.camera.width, self.camera.height)
    }

    /// 64-bit hash (FNV-1a) of the scene's content (scene text, every file it reads) and resolution,
    /// for refusing checkpoints of another scene.
    pub fn content_hash(&self) -> u64 {
        let mut h = Fnv::new();
        h.write(&self.content_hash.to_le_bytes());
        h.write(&self.camera.width.to_le_bytes());
        h.write(&self.camera.height.to_le_bytes());
        h.0
    }

    /// Index of the light chosen for next-event estimation with uniform `u`, and its probability.
    #[inline]
    pub fn pick_light(&self, u: f32) -> Option<(usize, f32)> {
        match self.lights.len() {
            0 => return None,
            1 => return Some((0, 1.0)),
            _ => {}
        }
        let (i, _) = crate::sampling::sample_cdf(&self.light_cdf, u);
        Some((i, self.light_pmf[i]))
    }

    fn from_toml(text: &str, file: &str, files: &dyn SceneFiles) -> Result<Scene> {
        let cx = Cx { file, text };
        let desc: SceneDesc = toml::from_str(text).map_err(|e| {
            let msg = e.message().trim().replace('\n', " ");
            match e.span() {
                Some(s) => anyhow!("{}: {}", cx.pos(s.start), msg),
                None => anyhow!("{file}: {msg}"),
            }
        })?;
        build(&cx, desc, files)
    }
}

// ---------------------------------------------------------------------------------------------
// Error positions

struct Cx<'a> {
    file: &'a str,
    text: &'a str,
}

impl Cx<'_> {
    fn pos(&self, offset: usize) -> String {
        let before = &self.text[..offset.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map(|l| l.chars().count()).unwrap_or(0) + 1;
        format!("{}:{line}:{col}", self.file)
    }
    fn err(&self, span: &Range<usize>, field: &str, msg: impl std::fmt::Display) -> anyhow::Error {
        anyhow!("{}: {field}: {msg}", self.pos(span.start))
    }
}

struct Fnv(u64);
impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= *b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// File format

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneDesc {
    unit: Option<Spanned<String>>,
    camera: Spanned<CameraDesc>,
    integrator: Option<Spanned<IntegratorDesc>>,
    #[serde(default)]
    spectra: BTreeMap<String, Spanned<toml::Value>>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<MaterialDesc>>,
    #[serde(default)]
    objects: Vec<Spanned<ObjectDesc>>,
    #[serde(default)]
    lights: Vec<Spanned<LightDesc>>,
    /// Global medium (see `medium_desc`).
    medium: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    eye: [f64; 3],
    look_at: [f64; 3],
    up: Option<[f64; 3]>,
    vfov_deg: Option<f64>,
    camera_constant: Option<f64>,
    width: Option<u32>,
    height: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct IntegratorDesc {
    #[serde(rename = "type")]
    kind: Option<String>,
    max_depth: Option<u32>,
    rr_depth: Option<u32>,
    ao_distance: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDesc {
    #[serde(rename = "type")]
    kind: String,
    albedo: Option<Spanned<toml::Value>>,
    // Dielectrics, conductors, plastic (see `bsdf_material`).
    ior: Option<Spanned<toml::Value>>,
    metal: Option<Spanned<String>>,
    eta: Option<Spanned<toml::Value>>,
    k: Option<Spanned<toml::Value>>,
    roughness: Option<Spanned<toml::Value>>,
    alpha: Option<Spanned<toml::Value>>,
    /// Interior of a `translucent` material (see `subsurface::translucent_from_toml`).
    subsurface: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereDesc {
    center: [f64; 3],
    radius: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformDesc {
    scale: Option<toml::Value>,
    rotate: Option<[f64; 4]>,
    translate: Option<[f64; 3]>,
    matrix: Option<[[f64; 4]; 4]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectDesc {
    name: Option<String>,
    material: String,
    mesh: Option<String>,
    group: Option<String>,
    quad: Option<[[f64; 3]; 4]>,
    quads: Option<Vec<[[f64; 3]; 4]>>,
    sphere: Option<SphereDesc>,
    transform: Option<TransformDesc>,
    /// Medium inside the object (its mesh must be closed).
    medium: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDesc {
    #[serde(rename = "type")]
    kind: String,
    object: Option<String>,
    position: Option<[f64; 3]>,
    direction: Option<[f64; 3]>,
    look_at: Option<[f64; 3]>,
    cone_deg: Option<f64>,
    falloff_start_deg: Option<f64>,
    radiance: Option<Spanned<toml::Value>>,
    intensity: Option<Spanned<toml::Value>>,
    irradiance: Option<Spanned<toml::Value>>,
    scale: Option<f64>,
    power_w: Option<f64>,
    two_sided: Option<bool>,
}

/// Dielectric, conductor and plastic materials (issue 4), see docs/scene-format.md.
fn bsdf_material(cx: &Cx, sp: &SpectrumCx, m: &MaterialDesc, span: &Range<usize>, field: &str) -> Result<Material> {
    use crate::microfacet::{roughness_to_alpha, TrowbridgeReitz};
    let kind = m.kind.as_str();
    let f = |name: &str| format!("{field}.{name}");
    // Fields that do not belong to this type.
    let allowed: &[&str] = match kind {
        "dielectric" | "rough_dielectric" => &["ior", "roughness", "alpha"],
        "conductor" | "rough_conductor" => &["metal", "eta", "k", "roughness", "alpha"],
        _ => &["albedo", "ior", "roughness", "alpha"],
    };
    for (name, present) in [
        ("albedo", m.albedo.is_some()),
        ("ior", m.ior.is_some()),
        ("metal", m.metal.is_some()),
        ("eta", m.eta.is_some()),
        ("k", m.k.is_some()),
        ("roughness", m.roughness.is_some()),
        ("alpha", m.alpha.is_some()),
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
    let distrib = match (&m.roughness, &m.alpha) {
        (Some(_), Some(a)) => return Err(cx.err(&a.span(), &f("alpha"), "give either roughness or alpha, not both")),
        (Some(r), None) => TrowbridgeReitz::isotropic(roughness_to_alpha(number(r, "roughness", 0.0, 1.0)? as f32)),
        (None, Some(a)) => match a.get_ref() {
            toml::Value::Array(xs) if kind != "plastic" => {
                let v: Vec<f64> = xs.iter().filter_map(as_f64).collect();
                if v.len() != 2 || xs.len() != 2 || !v.iter().all(|x| (0.0..=4.0).contains(x)) {
                    return Err(cx.err(&a.span(), &f("alpha"), "expected [alpha_x, alpha_y], each in [0, 4]"));
                }
                TrowbridgeReitz { alpha_x: v[0] as f32, alpha_y: v[1] as f32 }
            }
            _ => TrowbridgeReitz::isotropic(number(a, "alpha", 0.0, 4.0)? as f32),
        },
        (None, None) => {
            if kind.starts_with("rough_") {
                return Err(cx.err(span, &f("roughness"), format!("missing (a {kind} material needs roughness or alpha)")));
            }
            TrowbridgeReitz::isotropic(0.0)
        }
    };
    if kind.starts_with("rough_") && distrib.effectively_smooth() {
        return Err(cx.err(span, &f("roughness"), format!("a {kind} material needs α ≥ {} (use the smooth type)", crate::microfacet::SMOOTH_ALPHA)));
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
            Ok(Material::dielectric(ior, distrib))
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
            Ok(Material::conductor(eta, k, distrib))
        }
        _ => {
            // plastic
            let albedo = m.albedo.as_ref().ok_or_else(|| cx.err(span, &f("albedo"), "missing (a plastic material needs the albedo of its base)"))?;
            let albedo = sp.resolve(albedo, &f("albedo"), SpectrumUse::Albedo)?;
            let ior = match &m.ior {
                Some(v) => number(v, "ior", 1.0001, 4.0)?,
                None => 1.5,
            };
            if distrib.alpha_x != distrib.alpha_y {
                return Err(cx.err(span, &f("alpha"), "a plastic coating is isotropic (one alpha)"));
            }
            Ok(Material::plastic(albedo, ior as f32, distrib.alpha_x))
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Spectra

#[derive(Clone, Copy, PartialEq, Eq)]
enum SpectrumUse {
    /// Reflectance: values in [0, 1]; `rgb` uses the bounded reflectance uplift.
    Albedo,
    /// Emission: values ≥ 0; `rgb` uses the illuminant uplift.
    Emission,
    /// Coefficients (σ_a, σ_s): values ≥ 0; `rgb` is max(r,g,b) × the bounded reflectance uplift of rgb/max.
    Coefficient,
}

struct SpectrumCx<'a> {
    cx: &'a Cx<'a>,
    named: &'a BTreeMap<String, Spanned<toml::Value>>,
    files: &'a dyn SceneFiles,
    hash: std::cell::RefCell<Fnv>,
}

const SPECTRUM_KEYS: &[&str] = &["constant", "blackbody", "rgb", "csv", "column", "lambda_nm", "values", "scale"];

fn as_f64(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

fn as_f64_array(v: &toml::Value) -> Option<Vec<f64>> {
    v.as_array()?.iter().map(as_f64).collect()
}

impl SpectrumCx<'_> {
    /// Resolve a spectrum value (number, name, or table) to a function of wavelength in nm.
    fn resolve(&self, v: &Spanned<toml::Value>, field: &str, usage: SpectrumUse) -> Result<DenseSpectrum> {
        let span = v.span();
        let value = v.get_ref();
        if let toml::Value::String(name) = value {
            let Some(def) = self.named.get(name) else {
                let known: Vec<&str> = self.named.keys().map(|s| s.as_str()).collect();
                return Err(self.cx.err(&span, field, format!("unknown spectrum `{name}` (defined: {known:?})")));
            };
            if def.get_ref().is_str() {
                return Err(self.cx.err(&def.span(), &format!("spectra.{name}"), "a named spectrum cannot refer to another name"));
            }
            return self.resolve(def, &format!("spectra.{name}"), usage);
        }
        let f: Box<dyn Fn(f64) -> f64> = self.function(value, &span, field, usage)?;
        // Check the range of values at 1-nm resolution.
        let mut max = 0.0f64;
        for i in 0..=470 {
            let l = 360.0 + i as f64;
            let x = f(l);
            if !x.is_finite() {
                return Err(self.cx.err(&span, field, format!("spectrum is not finite at {l} nm")));
            }
            if x < 0.0 {
                return Err(self.cx.err(&span, field, format!("spectrum is negative ({x}) at {l} nm")));
            }
            max = max.max(x);
        }
        if usage == SpectrumUse::Albedo && max > 1.0 + 1e-9 {
            return Err(self.cx.err(&span, field, format!("albedo exceeds 1 (maximum {max})")));
        }
        Ok(DenseSpectrum::from_fn(f))
    }

    fn function(&self, value: &toml::Value, span: &Range<usize>, field: &str, usage: SpectrumUse) -> Result<Box<dyn Fn(f64) -> f64>> {
        if let Some(x) = as_f64(value) {
            return Ok(Box::new(move |_| x));
        }
        let Some(t) = value.as_table() else {
            return Err(self.cx.err(span, field, "expected a number, a spectrum name or a table"));
        };
        for k in t.keys() {
            if !SPECTRUM_KEYS.contains(&k.as_str()) {
                return Err(self.cx.err(span, field, format!("unknown key `{k}`, expected one of {SPECTRUM_KEYS:?}")));
            }
        }
        let scale = match t.get("scale") {
            None => 1.0,
            Some(v) => as_f64(v).filter(|x| x.is_finite() && *x >= 0.0).ok_or_else(|| {
                self.cx.err(span, &format!("{field}.scale"), "must be a non-negative number")
            })?,
        };
        let kinds: Vec<&str> = ["constant", "blackbody", "rgb", "csv", "lambda_nm"].into_iter().filter(|k| t.contains_key(*k)).collect();
        if kinds.len() != 1 {
            return Err(self.cx.err(span, field, format!(
                "give exactly one of constant, blackbody, rgb, csv, lambda_nm/values (got {kinds:?})")));
        }
        let kind = kinds[0];
        if kind != "csv" && t.contains_key("column") {
            return Err(self.cx.err(span, &format!("{field}.column"), "only allowed with csv"));
        }
        if kind != "lambda_nm" && t.contains_key("values") {
            return Err(self.cx.err(span, &format!("{field}.values"), "only allowed with lambda_nm"));
        }
        match kind {
            "constant" => {
                let x = as_f64(&t["constant"]).ok_or_else(|| self.cx.err(span, &format!("{field}.constant"), "must be a number"))?;
                Ok(Box::new(move |_| x * scale))
            }
            "blackbody" => {
                let temp = as_f64(&t["blackbody"])
                    .filter(|x| x.is_finite() && *x > 0.0)
                    .ok_or_else(|| self.cx.err(span, &format!("{field}.blackbody"), "must be a positive temperature in kelvin"))?;
                let s = optics::spectrum::Spectrum::Blackbody { temperature_k: temp, scale };
                Ok(Box::new(move |l| s.eval(l)))
            }
            "rgb" => {
                let rgb = as_f64_array(&t["rgb"])
                    .filter(|a| a.len() == 3)
                    .ok_or_else(|| self.cx.err(span, &format!("{field}.rgb"), "must be an array of three numbers"))?;
                let rgb = [rgb[0], rgb[1], rgb[2]];
                if rgb.iter().any(|c| !c.is_finite() || *c < 0.0) {
                    return Err(self.cx.err(span, &format!("{field}.rgb"), "components must be non-negative"));
                }
                match usage {
                    SpectrumUse::Albedo => {
                        if rgb.iter().any(|c| *c > 1.0) {
                            return Err(self.cx.err(span, &format!("{field}.rgb"), "albedo components must be at most 1"));
                        }
                        let s = rgb_albedo(rgb).map_err(|e| self.cx.err(span, &format!("{field}.rgb"), e))?;
                        Ok(Box::new(move |l| s.eval(l) * scale))
                    }
                    SpectrumUse::Coefficient => {
                        let m = rgb.iter().cloned().fold(0.0f64, f64::max);
                        if m == 0.0 {
                            return Ok(Box::new(|_| 0.0));
                        }
                        let s = rgb_albedo([rgb[0] / m, rgb[1] / m, rgb[2] / m]).map_err(|e| self.cx.err(span, &format!("{field}.rgb"), e))?;
                        Ok(Box::new(move |l| s.eval(l) * m * scale))
                    }
                    SpectrumUse::Emission => {
                        let s = rgb_illuminant(rgb).map_err(|e| self.cx.err(span, &format!("{field}.rgb"), e))?;
                        Ok(Box::new(move |l| s.eval(l) * scale))
                    }
                }
            }
            "csv" => {
                let rel = t["csv"].as_str().ok_or_else(|| self.cx.err(span, &format!("{field}.csv"), "must be a file name"))?;
                let text = self.files.read_text(rel).map_err(|e| self.cx.err(span, &format!("{field}.csv"), format!("{e:#}")))?;
                self.hash.borrow_mut().write(text.as_bytes());
                let (names, cols) = optics::spectrum::read_csv_columns(&text)
                    .map_err(|e| self.cx.err(span, &format!("{field}.csv"), format!("{rel}: {e:#}")))?;
                if cols.len() < 2 {
                    return Err(self.cx.err(span, &format!("{field}.csv"), format!("{rel}: needs a wavelength column and a value column")));
                }
                let ci = match t.get("column") {
                    None if cols.len() == 2 => 1,
                    None => {
                        return Err(self.cx.err(span, &format!("{field}.column"),
                            format!("{rel} has several value columns {:?}: name one", &names[1..])))
                    }
                    Some(toml::Value::String(c)) => names.iter().position(|n| n == c).filter(|i| *i > 0).ok_or_else(|| {
                        self.cx.err(span, &format!("{field}.column"), format!("{rel} has no column `{c}` (columns: {:?})", &names[1..]))
                    })?,
                    Some(_) => return Err(self.cx.err(span, &format!("{field}.column"), "must be a column name")),
                };
                let tab = optics::spectrum::Tabulated::new(cols[0].clone(), cols[ci].clone())
                    .map_err(|e| self.cx.err(span, &format!("{field}.csv"), format!("{rel}: {e:#}")))?;
                Ok(Box::new(move |l| tab.eval(l) * scale))
            }
            "lambda_nm" => {
                let l = as_f64_array(&t["lambda_nm"]).ok_or_else(|| self.cx.err(span, &format!("{field}.lambda_nm"), "must be an array of numbers"))?;
                let v = t.get("values").and_then(as_f64_array)
                    .ok_or_else(|| self.cx.err(span, &format!("{field}.values"), "must be an array of numbers, as long as lambda_nm"))?;
                let tab = optics::spectrum::Tabulated::new(l, v).map_err(|e| self.cx.err(span, field, format!("{e:#}")))?;
                Ok(Box::new(move |x| tab.eval(x) * scale))
            }
            _ => unreachable!(),
        }
    }
}

/// Reflectance spectrum (≤ 1 everywhere) for a linear-sRGB albedo.
fn rgb_albedo(rgb: [f64; 3]) -> Result<optics::spectrum::Spectrum> {
    Ok(optics::spectrum::Spectrum::RgbAlbedo(optics::spectrum::RgbAlbedo::new(rgb)))
}

/// Emission spectrum for a linear-sRGB radiance (D65 white for equal components).
fn rgb_illuminant(rgb: [f64; 3]) -> Result<optics::spectrum::Spectrum> {
    Ok(optics::spectrum::Spectrum::RgbIlluminant(optics::spectrum::RgbIlluminant::new(rgb)))
}

// ---------------------------------------------------------------------------------------------
// Building

fn unit_in_metres(u: &str) -> Option<f64> {
    Some(match u {
        "m" => 1.0,
        "dm" => 0.1,
        "cm" => 0.01,
        "mm" => 1e-3,
        "um" | "µm" => 1e-6,
        "km" => 1e3,
        "in" => 0.0254,
        "ft" => 0.3048,
        _ => return None,
    })
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

fn finite3(a: &[f64; 3]) -> bool {
    a.iter().all(|x| x.is_finite())
}

fn transform_matrix(cx: &Cx, span: &Range<usize>, field: &str, t: &TransformDesc) -> Result<Mat4> {
    if let Some(m) = &t.matrix {
        if t.scale.is_some() || t.rotate.is_some() || t.translate.is_some() {
            return Err(cx.err(span, field, "give either matrix or scale/rotate/translate, not both"));
        }
        if m.iter().flatten().any(|x| !x.is_finite()) {
            return Err(cx.err(span, &format!("{field}.matrix"), "entries must be finite"));
        }
        // Rows as written (row-major), acting on column vectors.
        let rows: Vec<[f32; 4]> = m.iter().map(|r| [r[0] as f32, r[1] as f32, r[2] as f32, r[3] as f32]).collect();
        let mat = Mat4::from_cols_array_2d(&[rows[0], rows[1], rows[2], rows[3]]).transpose();
        if mat.determinant().abs() < 1e-12 {
            return Err(cx.err(span, &format!("{field}.matrix"), "is singular"));
        }
        return Ok(mat);
    }
    let mut m = Mat4::IDENTITY;
    if let Some(s) = &t.scale {
        let sv = if let Some(x) = as_f64(s) {
            Vec3::splat(x as f32)
        } else if let Some(a) = as_f64_array(s).filter(|a| a.len() == 3) {
            Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
        } else {
            return Err(cx.err(span, &format!("{field}.scale"), "must be a number or [sx, sy, sz]"));
        };
        if !sv.is_finite() || sv.x * sv.y * sv.z == 0.0 {
            return Err(cx.err(span, &format!("{field}.scale"), "must be finite and non-zero"));
        }
        m = Mat4::from_scale(sv) * m;
    }
    if let Some(r) = &t.rotate {
        let axis = Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32);
        if !(axis.length() > 0.0) || !axis.is_finite() || !r[3].is_finite() {
            return Err(cx.err(span, &format!("{field}.rotate"), "must be [axis_x, axis_y, axis_z, angle_deg] with a non-zero axis"));
        }
        m = Mat4::from_axis_angle(axis.normalize(), (r[3] as f32).to_radians()) * m;
    }
    if let Some(tr) = &t.translate {
        if !finite3(tr) {
            return Err(cx.err(span, &format!("{field}.translate"), "must be finite"));
        }
        m = Mat4::from_translation(v3(*tr)) * m;
    }
    Ok(m)
}

fn merge_meshes(list: Vec<TriangleMesh>) -> TriangleMesh {
    let all_normals = list.iter().all(|m| m.normals.is_some());
    let mut out = TriangleMesh { positions: Vec::new(), normals: if all_normals { Some(Vec::new()) } else { None }, indices: Vec::new() };
    for m in list {
        let off = out.positions.len() as u32;
        out.indices.extend(m.indices.iter().map(|t| [t[0] + off, t[1] + off, t[2] + off]));
        out.positions.extend_from_slice(&m.positions);
        if let (Some(dst), Some(src)) = (out.normals.as_mut(), m.normals.as_ref()) {
            dst.extend_from_slice(src);
        }
    }
    out
}

fn build(cx: &Cx, desc: SceneDesc, files: &dyn SceneFiles) -> Result<Scene> {
    let mut hash = Fnv::new();
    hash.write(cx.text.as_bytes());

    // Unit.
    let unit_m = match &desc.unit {
        None => 1.0,
        Some(u) => unit_in_metres(u.get_ref()).ok_or_else(|| {
            cx.err(&u.span(), "unit", format!("unknown length unit `{}` (use m, dm, cm, mm, um, km, in or ft)", u.get_ref()))
        })?,
    };
    let to_m = |x: f64| (x * unit_m) as f32;
    let unit_mat = Mat4::from_scale(Vec3::splat(unit_m as f32));

    let sp = SpectrumCx { cx, named: &desc.spectra, files, hash: std::cell::RefCell::new(Fnv::new()) };

    // Materials.
    let mut materials = Vec::new();
    let mut material_names = Vec::new();
    for (name, m) in &desc.materials {
        let span = m.span();
        let m = m.get_ref();
        let field = format!("materials.{name}");
        if matches!(m.kind.as_str(), "lambertian" | "diffuse" | "black" | "interface" | "null") {
            for (name, present) in [("ior", m.ior.is_some()), ("metal", m.metal.is_some()), ("eta", m.eta.is_some()), ("k", m.k.is_some()), ("roughness", m.roughness.is_some()), ("alpha", m.alpha.is_some())] {
                if present {
                    return Err(cx.err(&span, &format!("{field}.{name}"), format!("not allowed for a {} material", m.kind)));
                }
            }
        }
        if m.subsurface.is_some() && m.kind != "translucent" {
            return Err(cx.err(&span, &format!("{field}.subsurface"), format!("only allowed for a translucent material, not {}", m.kind)));
        }
        let mat = match m.kind.as_str() {
            "lambertian" | "diffuse" => {
                let albedo = m.albedo.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.albedo"), "missing (a lambertian material needs an albedo)"))?;
                Material::lambertian(sp.resolve(albedo, &format!("{field}.albedo"), SpectrumUse::Albedo)?)
            }
            "interface" | "null" => {
                if m.albedo.is_some() {
                    return Err(cx.err(&span, &format!("{field}.albedo"), format!("not allowed for an {} material", m.kind)));
                }
                // Index-matched boundary of a medium: a dielectric of relative index 1 (pass-through).
                Material::dielectric(DenseSpectrum::from_fn(|_| 1.0), crate::microfacet::TrowbridgeReitz::isotropic(0.0))
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
                let t = crate::subsurface::translucent_from_toml(ior, roughness, sub.get_ref()).map_err(|e| cx.err(&sub.span(), &field, format!("{e:#}")))?;
                Material::Translucent(std::sync::Arc::new(t))
            }
            "dielectric" | "rough_dielectric" | "conductor" | "rough_conductor" | "plastic" => bsdf_material(cx, &sp, m, &span, &field)?,
            other => {
                return Err(cx.err(
                    &span,
                    &format!("{field}.type"),
                    format!("unknown material type `{other}` (known: lambertian, black, interface, dielectric, rough_dielectric, conductor, rough_conductor, plastic, translucent)"),
                ))
            }
        };
        materials.push(mat);
        material_names.push(name.clone());
    }

    // Objects.
    let mut shapes = Vec::new();
    let mut objects: Vec<ObjectInfo> = Vec::new();
    let mut media = Vec::new();
    let global_medium = match &desc.medium {
        Some(v) => {
            media.push(medium_desc(cx, &sp, v, "medium", unit_m)?);
            Some(0u32)
        }
        None => None,
    };
    for (k, o) in desc.objects.iter().enumerate() {
        let span = o.span();
        let o = o.get_ref();
        let name = o.name.clone().unwrap_or_else(|| format!("object{k}"));
        let field = format!("objects[{k}] ({name})");
        if objects.iter().any(|x| x.name == name) {
            return Err(cx.err(&span, &format!("{field}.name"), "duplicate object name"));
        }
        let material = material_names.iter().position(|n| *n == o.material).ok_or_else(|| {
            cx.err(&span, &format!("{field}.material"), format!("unknown material `{}` (defined: {material_names:?})", o.material))
        })? as u32;
        let given = [o.mesh.is_some(), o.quad.is_some(), o.quads.is_some(), o.sphere.is_some()].iter().filter(|b| **b).count();
        if given != 1 {
            return Err(cx.err(&span, &field, "give exactly one shape: mesh, quad, quads or sphere"));
        }
        if o.group.is_some() && o.mesh.is_none() {
            return Err(cx.err(&span, &format!("{field}.group"), "only allowed with mesh"));
        }
        let xf = match &o.transform {
            Some(t) => transform_matrix(cx, &span, &format!("{field}.transform"), t)?,
            None => Mat4::IDENTITY,
        };
        let m = unit_mat * xf;
        let shape = if let Some(s) = &o.sphere {
            if !(s.radius > 0.0) || !s.radius.is_finite() {
                return Err(cx.err(&span, &format!("{field}.sphere.radius"), format!("must be positive, got {}", s.radius)));
            }
            if !finite3(&s.center) {
                return Err(cx.err(&span, &format!("{field}.sphere.center"), "must be finite"));
            }
            let (scale, _, _) = xf.to_scale_rotation_translation();
            if (scale.x - scale.y).abs() > 1e-5 * scale.x.abs() || (scale.x - scale.z).abs() > 1e-5 * scale.x.abs() {
                return Err(cx.err(&span, &format!("{field}.transform"), "a sphere allows only uniform scaling"));
            }
            let center = m.transform_point3(v3(s.center));
            let radius = (s.radius as f32) * scale.x.abs() * unit_m as f32;
            Shape::Sphere(Sphere { center, radius })
        } else {
            let mut mesh = if let Some(q) = &o.quad {
                if q.iter().any(|p| !finite3(p)) {
                    return Err(cx.err(&span, &format!("{field}.quad"), "corners must be finite"));
                }
                TriangleMesh::quad([v3(q[0]), v3(q[1]), v3(q[2]), v3(q[3])])
            } else if let Some(qs) = &o.quads {
                if qs.is_empty() {
                    return Err(cx.err(&span, &format!("{field}.quads"), "is empty"));
                }
                if qs.iter().flatten().any(|p| !finite3(p)) {
                    return Err(cx.err(&span, &format!("{field}.quads"), "corners must be finite"));
                }
                merge_meshes(qs.iter().map(|q| TriangleMesh::quad([v3(q[0]), v3(q[1]), v3(q[2]), v3(q[3])])).collect())
            } else {
                let rel = o.mesh.as_ref().unwrap();
                let (list, bytes) = files.load_mesh(rel).map_err(|e| cx.err(&span, &format!("{field}.mesh"), format!("{e:#}")))?;
                hash.write(&bytes);
                match &o.group {
                    Some(g) => {
                        let names: Vec<String> = list.iter().map(|(n, _)| n.clone()).collect();
                        let found: Vec<TriangleMesh> = list.into_iter().filter(|(n, _)| n == g).map(|(_, m)| m).collect();
                        if found.is_empty() {
                            return Err(cx.err(&span, &format!("{field}.group"), format!("{rel} has no group `{g}` (groups: {names:?})")));
                        }
                        merge_meshes(found)
                    }
                    None => merge_meshes(list.into_iter().map(|(_, m)| m).collect()),
                }
            };
            mesh.transform(&m);
            mesh.validate().map_err(|e| cx.err(&span, &field, format!("{e:#}")))?;
            if mesh.indices.is_empty() {
                return Err(cx.err(&span, &field, "mesh has no triangles"));
            }
            let translucent = matches!(materials[material as usize], Material::Translucent(_));
            if o.medium.is_some() || translucent {
                // A medium boundary (or translucent object) must be closed; orient it outwards (the front face is the outside).
                let what = if translucent { "material (translucent)" } else { "medium" };
                let volume = crate::medium::closed_mesh_volume(&mesh).map_err(|e| cx.err(&span, &format!("{field}.{what}"), format!("boundary is not a closed mesh: {e:#}")))?;
                if volume < 0.0 {
                    for t in mesh.indices.iter_mut() {
                        t.swap(1, 2);
                    }
                    if let Some(ns) = mesh.normals.as_mut() {
                        for n in ns.iter_mut() {
                            *n = -*n;
                        }
                    }
                }
            }
            Shape::Mesh(mesh)
        };
        if matches!(&materials[material as usize], Material::Translucent(t) if t.from_medium) && o.medium.is_none() {
            return Err(cx.err(&span, &format!("{field}.medium"), "missing (its translucent material takes the coefficients from the object's medium)"));
        }
        let interior_medium = match &o.medium {
            Some(v) => {
                media.push(medium_desc(cx, &sp, v, &format!("{field}.medium"), unit_m)?);
                Some((media.len() - 1) as u32)
            }
            None => None,
        };
        shapes.push(shape);
        objects.push(ObjectInfo { name, material, light: None, interior_medium });
    }

    // Lights.
    let mut lights = Vec::new();
    let mut environment = None;
    for (k, l) in desc.lights.iter().enumerate() {
        let span = l.span();
        let l = l.get_ref();
        let field = format!("lights[{k}] ({})", l.kind);
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
            Ok(DenseSpectrum::from_fn(|x| s.eval(x as f32) as f64 * k))
        };
        let light = match l.kind.as_str() {
            "point" => {
                check_keys(&["position", "intensity"])?;
                let position = need_point(&l.position, "position")? * unit_m as f32;
                Light::Point { position, intensity: scaled(need(&l.intensity, "intensity")?, 4.0 * std::f64::consts::PI)? }
            }
            "spot" => {
                check_keys(&["position", "look_at", "cone_deg", "falloff_start_deg", "intensity"])?;
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
                let solid = 2.0 * std::f64::consts::PI * (1.0 - 0.5 * (cos_total as f64 + cos_falloff_start as f64));
                Light::Spot {
                    position,
                    frame: crate::sampling::Frame::from_normal(axis),
                    cos_total,
                    cos_falloff_start,
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
            "environment" => {
                check_keys(&["radiance"])?;
                if environment.is_some() {
                    return Err(cx.err(&span, &field, "only one environment light is allowed"));
                }
                if l.power_w.is_some() {
                    return Err(cx.err(&span, &format!("{field}.power_w"), "an environment has no finite power: use scale"));
                }
                environment = Some(lights.len() as u32);
                Light::Environment { radiance: scaled(need(&l.radiance, "radiance")?, 1.0)? }
            }
            "area" => {
                check_keys(&["object", "radiance", "two_sided"])?;
                let oname = l.object.as_ref().ok_or_else(|| cx.err(&span, &format!("{field}.object"), "missing (name of the emitting object)"))?;
                let oi = objects.iter().position(|o| &o.name == oname).ok_or_else(|| {
                    cx.err(&span, &format!("{field}.object"), format!("unknown object `{oname}`"))
                })?;
                if objects[oi].light.is_some() {
                    return Err(cx.err(&span, &format!("{field}.object"), format!("object `{oname}` already has a light")));
                }
                let emitter = match &shapes[oi] {
                    Shape::Mesh(m) => Emitter::triangles(
                        m.indices.iter().map(|t| [m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]]).collect(),
                    )
                    .map_err(|e| cx.err(&span, &format!("{field}.object"), format!("`{oname}`: {e}")))?,
                    Shape::Sphere(s) => Emitter::Sphere { center: s.center, radius: s.radius },
                };
                let area_m2 = emitter.area_m2();
                if !(area_m2 > 0.0) {
                    return Err(cx.err(&span, &format!("{field}.object"), format!("`{oname}` has zero area")));
                }
                let two_sided = l.two_sided.unwrap_or(false);
                let geometric = std::f64::consts::PI * area_m2 as f64 * if two_sided { 2.0 } else { 1.0 };
                objects[oi].light = Some(lights.len() as u32);
                Light::Area { object: oi as u32, emitter, area_m2, radiance: scaled(need(&l.radiance, "radiance")?, geometric)?, two_sided }
            }
            other => {
                return Err(cx.err(&span, &format!("{field}.type"), format!("unknown light type `{other}` (known: point, spot, directional, area, environment)")))
            }
        };
        lights.push(light);
    }
    hash.write(&sp.hash.borrow().0.to_le_bytes());

    // Camera.
    let cspan = desc.camera.span();
    let c = desc.camera.get_ref();
    for (key, p) in [("eye", &c.eye), ("look_at", &c.look_at)] {
        if !finite3(p) {
            return Err(cx.err(&cspan, &format!("camera.{key}"), "must be finite"));
        }
    }
    let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
    let (w, h) = (c.width.unwrap_or(256), c.height.unwrap_or(256));
    let eye = Vec3::new(to_m(c.eye[0]), to_m(c.eye[1]), to_m(c.eye[2]));
    let at = Vec3::new(to_m(c.look_at[0]), to_m(c.look_at[1]), to_m(c.look_at[2]));
    let camera = match (c.vfov_deg, c.camera_constant) {
        (Some(_), Some(_)) => return Err(cx.err(&cspan, "camera", "give vfov_deg or camera_constant, not both")),
        (Some(f), None) => Camera::look_at(eye, at, v3(up), f as f32, w, h),
        (None, Some(d)) => Camera::with_constant(eye, at, v3(up), d as f32, w, h),
        (None, None) => return Err(cx.err(&cspan, "camera.vfov_deg", "missing (or give camera_constant)")),
    }
    .map_err(|e| cx.err(&cspan, "camera", e))?;

    // Integrator settings.
    let mut integrator = IntegratorSettings::default();
    let mut ao_distance_m = f32::INFINITY;
    if let Some(i) = &desc.integrator {
        let span = i.span();
        let i = i.get_ref();
        if let Some(k) = &i.kind {
            integrator.kind = match k.as_str() {
                "path" => IntegratorKind::Path,
                "direct" => IntegratorKind::Direct,
                "ao" => IntegratorKind::Ao,
                "volpath" => IntegratorKind::Volpath,
                other => return Err(cx.err(&span, "integrator.type", format!("unknown integrator `{other}` (path, volpath, direct, ao)"))),
            };
        }
        if let Some(d) = i.max_depth {
            if d == 0 {
                return Err(cx.err(&span, "integrator.max_depth", "must be at least 1"));
            }
            integrator.max_depth = d;
        }
        if let Some(d) = i.rr_depth {
            integrator.rr_depth = d;
        }
        if let Some(d) = i.ao_distance {
            if !(d > 0.0) {
                return Err(cx.err(&span, "integrator.ao_distance", format!("must be positive, got {d}")));
            }
            ao_distance_m = to_m(d);
        }
    }

    if shapes.is_empty() {
        return Err(anyhow!("{}: the scene has no objects", cx.file));
    }
    let accel = Accel::build(shapes);
    let b = accel.bounds();
    let extent = (b.max - b.min).max_element().max(b.max.abs().max_element()).max(b.min.abs().max_element());
    let ray_epsilon_m = (extent * 2e-6).max(1e-9);
    let scene_radius = 0.5 * (b.max - b.min).length();

    // Light selection proportional to power.
    let powers: Vec<f32> = lights.iter().map(|l| l.power_w(scene_radius).max(0.0)).collect();
    let total: f32 = powers.iter().sum();
    let light_pmf: Vec<f32> = if total > 0.0 {
        powers.iter().map(|p| p / total).collect()
    } else {
        vec![1.0 / lights.len().max(1) as f32; lights.len()]
    };
    let mut acc = 0.0;
    let light_cdf = light_pmf.iter().map(|p| {
        acc += p;
        acc
    }).collect();

    let medium_grids = (0..media.len())
        .map(|m| {
            if media[m].pure_absorber {
                return None;
            }
            let mut region: Option<crate::geometry::Aabb> = None;
            for (o, info) in objects.iter().enumerate() {
                if info.interior_medium == Some(m as u32) {
                    let b = accel.shape(o as u32).bounds();
                    region = Some(match region {
                        None => b,
                        Some(r) => crate::geometry::Aabb { min: r.min.min(b.min), max: r.max.max(b.max) },
                    });
                }
            }
            region.map(|r| crate::medium::FreeFlightGrid::build(&r, accel.shapes(), 64))
        })
        .collect();

    Ok(Scene {
        medium_grids,
        camera,
        accel,
        objects,
        materials,
        material_names,
        lights,
        light_pmf,
        light_cdf,
        environment,
        media,
        global_medium,
        integrator,
        ao_distance_m,
        ray_epsilon_m,
        unit_m,
        source: cx.file.to_string(),
        content_hash: hash.0,
    })
}

// ---------------------------------------------------------------------------------------------
// Media

const MEDIUM_KEYS: &[&str] = &["sigma_a_per_mm", "sigma_s_per_mm", "g", "milk", "recipe", "preset", "phase", "similarity"];

/// Milk presets (fat wt-%, protein wt-%, homogenisation pressure MPa) for `medium = { preset = … }`.
pub const MILK_PRESETS: &[(&str, f64, f64, f64)] =
    &[("Skim Milk", 0.1, 3.4, 20.0), ("Low-fat Milk", 1.5, 3.4, 20.0), ("Whole Milk", 3.5, 3.4, 20.0)];

/// Wavelengths (nm) at which the renderer evaluates the milk model (those of its input tables).
pub fn milk_wavelengths_nm() -> Vec<f64> {
    (0..17).map(|k| 375.0 + 25.0 * k as f64).collect()
}

/// Parse a `medium = { … }` value (see docs/scene-format.md); errors name the field. With
/// `similarity = true` the medium is replaced by its similarity-relation equivalent (an
/// approximation, see [`crate::medium::HomogeneousMedium::similarity`]).
fn medium_desc(cx: &Cx, sp: &SpectrumCx, v: &Spanned<toml::Value>, field: &str, unit_m: f64) -> Result<crate::medium::HomogeneousMedium> {
    let similarity = match v.get_ref().as_table().and_then(|t| t.get("similarity")) {
        None => false,
        Some(toml::Value::Boolean(b)) => *b,
        Some(_) => return Err(cx.err(&v.span(), &format!("{field}.similarity"), "must be true or false")),
    };
    let m = medium_desc_exact(cx, sp, v, field, unit_m)?;
    if similarity {
        m.similarity().map_err(|e| cx.err(&v.span(), &format!("{field}.similarity"), format!("{e:#}")))
    } else {
        Ok(m)
    }
}

/// [`medium_desc`] without the similarity option.
fn medium_desc_exact(cx: &Cx, sp: &SpectrumCx, v: &Spanned<toml::Value>, field: &str, unit_m: f64) -> Result<crate::medium::HomogeneousMedium> {
    use crate::medium::{from_bulk, HomogeneousMedium, PhaseModel};
    let span = v.span();
    let t = v.get_ref().as_table().ok_or_else(|| cx.err(&span, field, "expected a table such as { sigma_a_per_mm = 0.01, sigma_s_per_mm = 1, g = 0 } or { milk = { ... } }"))?;
    for k in t.keys() {
        if !MEDIUM_KEYS.contains(&k.as_str()) {
            return Err(cx.err(&span, field, format!("unknown key `{k}`, expected one of {MEDIUM_KEYS:?}")));
        }
    }
    let f = |k: &str| format!("{field}.{k}");
    let kinds: Vec<&str> = ["sigma_a_per_mm", "milk", "recipe", "preset"].into_iter().filter(|k| t.contains_key(*k)).collect();
    if kinds.len() != 1 {
        return Err(cx.err(&span, field, format!("give exactly one of sigma_a_per_mm/sigma_s_per_mm/g, milk, recipe, preset (got {kinds:?})")));
    }
    let use_table = match t.get("phase") {
        None => true,
        Some(toml::Value::String(p)) if p == "mie" || p == "tabulated" => true,
        Some(toml::Value::String(p)) if p == "hg" => false,
        Some(_) => return Err(cx.err(&span, &f("phase"), "must be \"mie\" (tabulated, default) or \"hg\" (Henyey–Greenstein with the Mie g)")),
    };
    let num = |tab: &toml::value::Table, key: &str, path: &str| -> Result<f64> {
        let x = tab.get(key).ok_or_else(|| cx.err(&span, &format!("{path}.{key}"), "missing"))?;
        as_f64(x).filter(|x| x.is_finite()).ok_or_else(|| cx.err(&span, &format!("{path}.{key}"), "must be a number"))
    };
    let milk = |fat: f64, protein: f64, pressure: f64, path: &str| -> Result<HomogeneousMedium> {
        optics::milk::validate(fat, protein, pressure).map_err(|e| cx.err(&span, path, format!("{e:#}")))?;
        let l = milk_wavelengths_nm();
        let opts = optics::media::BulkOptions { phase_angles: if use_table { 181 } else { 0 } };
        let b = optics::milk::milk_properties_with(fat, protein, pressure, &l, &opts).map_err(|e| cx.err(&span, path, format!("{e:#}")))?;
        from_bulk(field, &b, use_table).map_err(|e| cx.err(&span, path, format!("{e:#}")))
    };
    match kinds[0] {
        "sigma_a_per_mm" => {
            if t.contains_key("phase") {
                return Err(cx.err(&span, &f("phase"), "only with milk, recipe or preset (give g here)"));
            }
            let per_mm_to_per_m = 1000.0; // m⁻¹ per mm⁻¹ (coefficients are in mm⁻¹ whatever the scene unit)
            let _ = unit_m;
            let sigma = |key: &str| -> Result<optics::spectrum::DenseSpectrum> {
                let val = t.get(key).ok_or_else(|| cx.err(&span, &f(key), "missing"))?;
                let d = sp.resolve(&Spanned::new(span.clone(), val.clone()), &f(key), SpectrumUse::Coefficient)?;
                Ok(optics::spectrum::DenseSpectrum::from_fn(|l| d.eval(l as f32) as f64 * per_mm_to_per_m))
            };
            let sigma_a = sigma("sigma_a_per_mm")?;
            let sigma_s = sigma("sigma_s_per_mm")?;
            let g = match t.get("g") {
                None => 0.0,
                Some(x) => as_f64(x).ok_or_else(|| cx.err(&span, &f("g"), "must be a number"))?,
            };
            if !(g.abs() < 1.0) {
                return Err(cx.err(&span, &f("g"), format!("must lie in (-1, 1), got {g}")));
            }
            let phase = PhaseModel::HenyeyGreenstein { g: optics::spectrum::DenseSpectrum::from_fn(|_| g) };
            HomogeneousMedium::new(field, sigma_a, sigma_s, phase).map_err(|e| cx.err(&span, field, format!("{e:#}")))
        }
        "milk" => {
            for k in ["sigma_s_per_mm", "g"] {
                if t.contains_key(k) {
                    return Err(cx.err(&span, &f(k), "not allowed with milk"));
                }
            }
            let m = t["milk"].as_table().ok_or_else(|| cx.err(&span, &f("milk"), "expected { fat_percent = …, protein_percent = …, pressure_mpa = … }"))?;
            for k in m.keys() {
                if !["fat_percent", "protein_percent", "pressure_mpa"].contains(&k.as_str()) {
                    return Err(cx.err(&span, &f("milk"), format!("unknown key `{k}` (fat_percent, protein_percent, pressure_mpa)")));
                }
            }
            let path = f("milk");
            let fat = num(m, "fat_percent", &path)?;
            let protein = if m.contains_key("protein_percent") { num(m, "protein_percent", &path)? } else { 3.4 };
            let pressure = if m.contains_key("pressure_mpa") { num(m, "pressure_mpa", &path)? } else { 20.0 };
            milk(fat, protein, pressure, &path)
        }
        "preset" => {
            let name = t["preset"].as_str().ok_or_else(|| cx.err(&span, &f("preset"), "must be a name"))?;
            if let Some(&(_, fat, protein, pressure)) = MILK_PRESETS.iter().find(|p| p.0.eq_ignore_ascii_case(name)) {
                return milk(fat, protein, pressure, &f("preset"));
            }
            // Measured media (Jensen et al. 2001, Narasimhan et al. 2006; RGB, as pbrt's named media).
            let Some(mm) = optics::bssrdf::find_medium(name) else {
                let known: Vec<&str> = MILK_PRESETS.iter().map(|p| p.0).collect();
                return Err(cx.err(&span, &f("preset"), format!(
                    "unknown preset `{name}` (known: {known:?}, or a measured medium of Jensen et al. 2001 / Narasimhan et al. 2006 such as \"Regular Milk\", \"Ketchup\")")));
            };
            let uplift = |rgb: [f64; 3]| -> optics::spectrum::DenseSpectrum {
                let m = rgb.iter().cloned().fold(0.0f64, f64::max);
                if !(m > 0.0) {
                    return optics::spectrum::DenseSpectrum::from_fn(|_| 0.0);
                }
                let sh = optics::spectrum::RgbAlbedo::new([rgb[0] / m, rgb[1] / m, rgb[2] / m]);
                optics::spectrum::DenseSpectrum::from_fn(move |l| sh.eval(l) * m)
            };
            let g = if mm.g.iter().all(|&x| x >= 0.0) { uplift(mm.g) } else {
                let mean = mm.g.iter().sum::<f64>() / 3.0;
                optics::spectrum::DenseSpectrum::from_fn(move |_| mean)
            };
            HomogeneousMedium::new(field, uplift(mm.sigma_a_per_m), uplift(mm.sigma_s_per_m), PhaseModel::HenyeyGreenstein { g })
                .map_err(|e| cx.err(&span, &f("preset"), format!("{e:#}")))
        }
        _ => {
            let rel = t["recipe"].as_str().ok_or_else(|| cx.err(&span, &f("recipe"), "must be a file name"))?;
            let text = sp.files.read_text(rel).map_err(|e| cx.err(&span, &f("recipe"), format!("{e:#}")))?;
            sp.hash.borrow_mut().write(text.as_bytes());
            let recipe = optics::media::Recipe::from_toml(&text).map_err(|e| cx.err(&span, &f("recipe"), format!("{rel}: {e:#}")))?;
            let mut recipe = recipe;
            if use_table && recipe.phase_angles == 0 {
                recipe.phase_angles = 181;
            }
            let b = recipe.bulk_properties(None).map_err(|e| cx.err(&span, &f("recipe"), format!("{rel}: {e:#}")))?;
            from_bulk(field, &b, use_table).map_err(|e| cx.err(&span, &f("recipe"), format!("{rel}: {e:#}")))
        }
    }
}
