//! Loading scenes: the TOML scene format (documented in `docs/scene-format.md`) and the built-in measured
//! Cornell box.
//!
//! A scene file declares its length unit (`unit = "mm"`); every position and length in it is in
//! that unit and converted to metres here. Spectra are given inline or by name (`[spectra.NAME]`):
//! a constant, `blackbody = K`, `rgb = [r, g, b]`, `csv = "file.csv"` with `column`, or inline
//! `lambda_nm`/`values`, each with an optional `scale`; tabulated spectra are zero outside their
//! range. Materials and objects refer to each other by name. Errors name the file, the line and
//! column, and the field; unknown keys are rejected.

//!
//! This is the only module that reads TOML. Each kind of thing has its own file here, which
//! knows that kind's keys: [`material`], [`translucent`], [`medium`], [`object`], [`light`],
//! [`camera`], [`integrator`]; [`spectrum`] resolves every spectrum value and [`error`] writes
//! positions. A new material, light or camera model is parsed in its file here and built by the
//! constructor of its core module.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

pub mod calibration;
pub mod camera;
pub mod desc;
pub mod error;
pub mod integrator;
pub mod light;
pub mod material;
pub mod medium;
pub mod object;
pub mod spectrum;
pub mod template;
pub mod translucent;

pub use medium::{milk_wavelengths_nm, MILK_PRESETS};

use crate::accel::Accel;
use crate::math::hash::Fnv1a64;
use crate::scene::Scene;
use crate::shape::mesh::TriangleMesh;
use anyhow::{anyhow, bail, Context, Result};
use desc::SceneDesc;
use error::Cx;
use spectrum::SpectrumCx;
use std::path::{Path, PathBuf};

/// Access to the files a scene refers to (the file system, or files embedded in the binary).
pub(crate) trait SceneFiles {
    /// Text of a file named in the scene (path as written, relative to the scene's folder).
    fn read_text(&self, rel: &str) -> Result<String>;
    /// Meshes in a file named in the scene, with the file's bytes for hashing.
    fn load_mesh(&self, rel: &str) -> Result<(Vec<(String, TriangleMesh)>, Vec<u8>)>;
    /// Path of a file named in the scene, for readers that open files themselves.
    fn path(&self, rel: &str) -> Result<PathBuf>;
    /// An image file named in the scene (.exr, .pfm, .hdr, .png), with the file's bytes for hashing.
    fn load_image(&self, rel: &str) -> Result<(crate::image_io::Image, Vec<u8>)>;
    /// Path of an image named in the scene, with the file's bytes for hashing.
    fn image_path(&self, rel: &str) -> Result<(PathBuf, Vec<u8>)>;
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
    fn path(&self, rel: &str) -> Result<PathBuf> {
        Ok(self.base.join(rel))
    }
    fn load_image(&self, rel: &str) -> Result<(crate::image_io::Image, Vec<u8>)> {
        let p = self.base.join(rel);
        let bytes = std::fs::read(&p).with_context(|| format!("cannot read image {}", p.display()))?;
        let image = crate::image_io::read_image(&p)?;
        Ok((image, bytes))
    }
    fn image_path(&self, rel: &str) -> Result<(PathBuf, Vec<u8>)> {
        let p = self.base.join(rel);
        let bytes = std::fs::read(&p).with_context(|| format!("cannot read image {}", p.display()))?;
        Ok((p, bytes))
    }
}

/// Text of the built-in Cornell box scene (the same file as `scenes/cornell-box.toml`).
pub const CORNELL_BOX_TOML: &str = include_str!("../../../../scenes/cornell-box.toml");
const CBOX_REFLECTANCE_CSV: &str = include_str!("../../data/cornell-box/cbox_reflectance.csv");
const CBOX_EMISSION_CSV: &str = include_str!("../../data/cornell-box/cbox_light_emission.csv");

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
    fn path(&self, rel: &str) -> Result<PathBuf> {
        bail!("{rel} is not embedded in the binary")
    }
    fn load_image(&self, rel: &str) -> Result<(crate::image_io::Image, Vec<u8>)> {
        bail!("image {rel} is not embedded in the binary")
    }
    fn image_path(&self, rel: &str) -> Result<(PathBuf, Vec<u8>)> {
        bail!("image {rel} is not embedded in the binary")
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

    fn from_toml(text: &str, file: &str, files: &dyn SceneFiles) -> Result<Scene> {
        let cx = Cx { file, text };
        let desc: SceneDesc = toml::from_str(text).map_err(|e| {
            let msg = error::one_line(e.message().trim());
            match e.span() {
                Some(s) => anyhow!("{}: {}", cx.pos(s.start), msg),
                None => anyhow!("{file}: {msg}"),
            }
        })?;
        build(&cx, desc, files)
    }
}

/// What every part of the loader shares: positions for errors, spectrum resolution, the files the
/// scene names, its unit, and the running hash of everything read.
pub(crate) struct Build<'a> {
    pub(crate) cx: &'a Cx<'a>,
    pub(crate) sp: SpectrumCx<'a>,
    pub(crate) files: &'a dyn SceneFiles,
    /// Metres per scene length unit.
    pub(crate) unit_m: f64,
    pub(crate) hash: Fnv1a64,
}

fn build(cx: &Cx, desc: SceneDesc, files: &dyn SceneFiles) -> Result<Scene> {
    let mut hash = Fnv1a64::new();
    hash.write(cx.text.as_bytes());
    let unit_m = match &desc.unit {
        None => 1.0,
        Some(u) => object::unit_in_metres(u.get_ref()).ok_or_else(|| {
            cx.err(&u.span(), "unit", format!("unknown length unit {} (use m, dm, cm, mm, um, km, in or ft)", error::quote(u.get_ref())))
        })?,
    };
    let sp = SpectrumCx { cx, named: &desc.spectra, files, hash: std::cell::RefCell::new(Fnv1a64::new()) };
    let mut ld = Build { cx, sp, files, unit_m, hash };
    let (materials, material_names, one_sided, surface_frames, opacity) = material::materials(cx, &ld.sp, &desc, unit_m)?;
    // Materials with a normal or bump map or a textured opacity: their meshes need texture coordinates.
    let mapped: Vec<bool> = (0..materials.len())
        .map(|i| matches!(surface_frames.get(i), Some(Some(f)) if f.map.is_some()) || matches!(opacity.get(i), Some(Some(crate::texture::FloatTexture::Image(_)))))
        .collect();
    let (shapes, mut objects, media, global_medium) = object::objects(&mut ld, &desc, &materials, &material_names, &mapped)?;
    let (lights, environment) = light::lights(cx, &ld.sp, &desc, unit_m, &shapes, &mut objects)?;
    // A mask lets rays through its surface: it cannot bound a medium (whose crossings `volpath`
    // counts) or emit (light samples would land where rays pass).
    for (k, (o, d)) in objects.iter().zip(&desc.objects).enumerate() {
        if matches!(opacity.get(o.material as usize), Some(Some(_))) && (o.interior_medium.is_some() || o.light.is_some()) {
            let what = if o.light.is_some() { "an area light" } else { "a medium's boundary" };
            return Err(cx.err(&d.span(), &format!("objects[{k}] ({})", error::short(&o.name)), format!("a mask material cannot be on {what}")));
        }
    }
    let spectra_hash = ld.sp.hash.borrow().finish();
    ld.hash.write(&spectra_hash.to_le_bytes());
    let camera = camera::camera(&mut ld, &desc)?;
    let integrator::IntegratorParams { settings: integrator, ao_distance_m, guiding: refraction_guiding, splits: refraction_splits, direct: direct_samples } =
        integrator::integrator(cx, &desc, unit_m)?;

    if shapes.is_empty() {
        return Err(anyhow!("{}: the scene has no objects", cx.file));
    }
    let accel = Accel::build(shapes);
    let b = accel.bounds();
    let extent = (b.max - b.min).max_element().max(b.max.abs().max_element()).max(b.min.abs().max_element());
    let ray_epsilon_m = (extent * 2e-6).max(1e-9);
    let scene_radius = 0.5 * (b.max - b.min).length();

    // Light selection: by power, lights at infinity capped (`light::selection_pmf`).
    let powers: Vec<f32> = lights.iter().map(|l| l.power_w(scene_radius).max(0.0)).collect();
    let total: f32 = powers.iter().sum();
    if !total.is_finite() {
        // Light selection divides by the total: an overflow would select no light (a black image).
        let which = match powers.iter().position(|p| !p.is_finite()) {
            Some(k) => format!("lights[{k}]: its emitted power"),
            None => "the lights' total power".to_string(),
        };
        return Err(anyhow!("{}: {which} overflows f32 at this scene's size ({scene_radius:.3e} m radius): lower the scale", cx.file));
    }
    let light_pmf = crate::light::selection_pmf(&lights, &powers);
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
            let mut region: Option<crate::math::geometry::Aabb> = None;
            let mut bounding = Vec::new();
            for (o, info) in objects.iter().enumerate() {
                if info.interior_medium == Some(m as u32) {
                    bounding.push(o);
                    let b = accel.shape(o as u32).bounds();
                    region = Some(match region {
                        None => b,
                        Some(r) => crate::math::geometry::Aabb { min: r.min.min(b.min), max: r.max.max(b.max) },
                    });
                }
            }
            // One closed convex mesh around the medium, nothing inside: exact plane distances.
            let convex = match bounding[..] {
                [o] => crate::medium::convex::ConvexBoundary::build(accel.shapes(), o),
                _ => None,
            };
            region.map(|r| crate::medium::FreeFlightGrid::build(&r, accel.shapes(), 64).with_convex(convex))
        })
        .collect();

    let has_area_lights = lights.iter().any(|l| matches!(l, crate::light::Light::Area { .. }));
    let refracted_lights = if media.is_empty() { None } else { crate::light::refracted::RefractedLights::new(&lights, &light_pmf, refraction_guiding, refraction_splits) };
    Ok(Scene {
        medium_grids,
        refracted_lights,
        camera,
        accel,
        objects,
        materials,
        material_names,
        one_sided,
        surface_frames,
        opacity,
        lights,
        light_pmf,
        light_cdf,
        environment,
        media,
        global_medium,
        integrator,
        ao_distance_m,
        direct_samples,
        has_area_lights,
        ray_epsilon_m,
        unit_m,
        source: cx.file.to_string(),
        content_hash: ld.hash.finish(),
    })
}
