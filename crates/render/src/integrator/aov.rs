//! Arbitrary output variables (AOVs): what the camera ray of a sample hits first, and the names
//! and channels under which the film writes them.
//!
//! The kinds and their conventions follow Mitsuba 3's `aov` integrator (`albedo`, `depth`,
//! `position`, `sh_normal`, `shape_index`) and pbrt-v4's G-buffer film (`Albedo`, `P`, `N`/`Ns`,
//! `Variance`):
//!
//! | `--aov` | EXR channels | value of one sample (the pixel holds the mean over its samples) |
//! |---|---|---|
//! | `albedo` | `albedo.R`, `.G`, `.B` | linear sRGB (D65) of the first surface's reflectance: Lambertian, plastic and diffuse transmitters: the (base) albedo ρ(λ); other materials π·f(wo, n) towards the shading normal, 0 for smooth glass and mirrors (Mitsuba's `eval_diffuse_reflectance`); black where the ray escapes |
//! | `normal` | `N.X`, `.Y`, `.Z` | world-space unit shading normal, turned to the side the ray arrives from (pbrt-v4 calls it `Ns`); 0 where the ray escapes |
//! | `depth` | `depth.T` | distance in metres from the ray's origin to the first hit along the ray (Mitsuba's `depth`, the ray parameter t, not the planar z); 0 where the ray escapes |
//! | `position` | `P.X`, `.Y`, `.Z` | world-space position of the first hit, metres; 0 where the ray escapes |
//! | `object_id` | `object_id.I` | index of the object hit (0 = the first object of the scene file), −1 where the ray escapes; fractional where a pixel covers several (as Mitsuba's `shape_index`) |
//! | `variance` | `variance.R`, `.G`, `.B` | variance of the pixel's mean radiance in linear sRGB, from per-sample second moments: (Σx²/n − x̄²)/(n − 1); 0 below two samples (exact for independent samples; an upper bound for the passes of one render, whose wavelength and film numbers are stratified) |
//!
//! The albedo of a spectrum is estimated at 16 stratified wavelengths per sample (four hero
//! sets from the sample's own wavelength number), so it converges to the exact colour without
//! drawing another random number: adding AOVs leaves the image bit for bit unchanged.

use crate::interaction::Shading;
use crate::material::Material;
use crate::math::geometry::Ray;
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use crate::scene::Scene;
use glam::{Vec3, Vec4};

/// An AOV the film can accumulate and write (see the module table).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Aov {
    /// First-hit reflectance, linear sRGB.
    Albedo,
    /// First-hit shading normal, world space.
    Normal,
    /// Distance along the camera ray to the first hit, metres.
    Depth,
    /// World position of the first hit, metres.
    Position,
    /// Index of the first object hit.
    ObjectId,
    /// Variance of the pixel mean, linear sRGB.
    Variance,
}

/// Every AOV with its `--aov` name, checkpoint code (never reused) and EXR channels.
const TABLE: [(Aov, &str, u8, &[&str]); 6] = [
    (Aov::Albedo, "albedo", 0, &["albedo.R", "albedo.G", "albedo.B"]),
    (Aov::Normal, "normal", 1, &["N.X", "N.Y", "N.Z"]),
    (Aov::Depth, "depth", 2, &["depth.T"]),
    (Aov::Position, "position", 3, &["P.X", "P.Y", "P.Z"]),
    (Aov::ObjectId, "object_id", 4, &["object_id.I"]),
    (Aov::Variance, "variance", 5, &["variance.R", "variance.G", "variance.B"]),
];

impl Aov {
    /// Every AOV, in the order the film stores them.
    pub const ALL: [Aov; 6] = [Aov::Albedo, Aov::Normal, Aov::Depth, Aov::Position, Aov::ObjectId, Aov::Variance];

    fn row(self) -> &'static (Aov, &'static str, u8, &'static [&'static str]) {
        TABLE.iter().find(|r| r.0 == self).expect("every AOV has a row")
    }

    /// The name `--aov` takes.
    pub fn name(self) -> &'static str {
        self.row().1
    }

    /// The code stored in checkpoints.
    pub fn code(self) -> u8 {
        self.row().2
    }

    /// EXR channel names, in storage order.
    pub fn channels(self) -> &'static [&'static str] {
        self.row().3
    }

    /// The AOV named `name`.
    pub fn from_name(name: &str) -> Option<Aov> {
        TABLE.iter().find(|r| r.1 == name).map(|r| r.0)
    }

    /// The AOV stored as `code`.
    pub fn from_code(code: u8) -> Option<Aov> {
        TABLE.iter().find(|r| r.2 == code).map(|r| r.0)
    }

    /// The names joined by `sep` (`albedo,normal,…`).
    pub fn names(sep: &str) -> String {
        Aov::ALL.iter().map(|a| a.name()).collect::<Vec<_>>().join(sep)
    }

    /// Parse a comma-separated list (`albedo,normal`); the result is sorted and without
    /// repeats. An unknown name gives one line listing the known ones.
    pub fn parse_list(text: &str) -> Result<Vec<Aov>, String> {
        let mut out = Vec::new();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            match Aov::from_name(&item.to_ascii_lowercase()) {
                Some(a) => out.push(a),
                None => return Err(format!("unknown AOV `{item}`; known AOVs: {}", Aov::names(", "))),
            }
        }
        if out.is_empty() {
            return Err(format!("no AOV given; known AOVs: {}", Aov::names(", ")));
        }
        out.sort();
        out.dedup();
        Ok(out)
    }

    /// Whether the AOV is a property of the first hit (the others come from the radiance samples).
    pub fn is_first_hit(self) -> bool {
        match self {
            Aov::Albedo | Aov::Normal | Aov::Depth | Aov::Position | Aov::ObjectId => true,
            Aov::Variance => false,
        }
    }
}

/// What one camera ray hits first (all AOVs of one sample that come from geometry).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstHit {
    /// Reflectance of the surface, linear sRGB (D65).
    pub albedo: [f32; 3],
    /// Unit shading normal on the side of the arriving ray (0 on a miss).
    pub normal: [f32; 3],
    /// Distance along the ray, metres (0 on a miss).
    pub depth_m: f32,
    /// Position, metres (0 on a miss).
    pub position_m: [f32; 3],
    /// Object index (−1 on a miss).
    pub object: f32,
}

impl FirstHit {
    /// The record of a ray that escapes.
    pub const MISS: FirstHit = FirstHit { albedo: [0.0; 3], normal: [0.0; 3], depth_m: 0.0, position_m: [0.0; 3], object: -1.0 };

    /// The values of `aov` (as many as its channels); `None` for AOVs that are not first-hit.
    #[inline]
    pub fn values(&self, aov: Aov) -> Option<&[f32]> {
        match aov {
            Aov::Albedo => Some(&self.albedo),
            Aov::Normal => Some(&self.normal),
            Aov::Depth => Some(std::slice::from_ref(&self.depth_m)),
            Aov::Position => Some(&self.position_m),
            Aov::ObjectId => Some(std::slice::from_ref(&self.object)),
            Aov::Variance => None,
        }
    }
}

/// Wavelength sets per albedo estimate (each carries four wavelengths: 16 in all, stratified).
const ALBEDO_SETS: usize = 4;

/// The first-hit record of camera ray `ray`; `u_lambda` is the sample's wavelength number (the
/// albedo's wavelengths are stratified around it).
pub fn first_hit(scene: &Scene, ray: &Ray, u_lambda: f32) -> FirstHit {
    let Some(hit) = scene.intersect(ray) else { return FirstHit::MISS };
    let s = Shading::at(scene, ray, &hit);
    let obj = &scene.objects[s.object as usize];
    let mat = &scene.materials[obj.material as usize];
    let wo_local = s.frame.to_local(-ray.d);
    let front = s.ng_raw.dot(-ray.d) > 0.0;
    let uv = s.uv(scene);
    let mut albedo = [0.0f32; 3];
    for k in 0..ALBEDO_SETS {
        let mut u = u_lambda + k as f32 / (ALBEDO_SETS * crate::math::spectral::N_LAMBDA) as f32;
        if u >= 1.0 {
            u -= 1.0;
        }
        let wl = SampledWavelengths::sample(u);
        let r = if scene.black_behind(obj.material, front) { Vec4::ZERO } else { reflectance(mat, &wl, front, uv, wo_local) };
        let rgb = wl.reflectance_to_srgb(r);
        for c in 0..3 {
            albedo[c] += rgb[c] / ALBEDO_SETS as f32;
        }
    }
    let n = s.frame.n;
    let p = s.p;
    FirstHit {
        albedo,
        normal: [n.x, n.y, n.z],
        depth_m: hit.t * ray.d.length(),
        position_m: [p.x, p.y, p.z],
        object: s.object as f32,
    }
}

/// The reflectance the albedo AOV reports for `mat` at wavelengths `wl` (see the module table).
#[inline]
fn reflectance(mat: &Material, wl: &SampledWavelengths, front: bool, uv: glam::Vec2, wo_local: Vec3) -> SampledSpectrum {
    match mat {
        Material::Lambertian { albedo } | Material::Plastic { albedo, .. } => albedo.eval(wl, uv),
        Material::DiffuseTransmitter { albedo, .. } => albedo.eval(wl, uv),
        Material::Black => Vec4::ZERO,
        Material::Dielectric { .. } | Material::ThinDielectric { .. } | Material::Conductor { .. } | Material::Translucent(_) => {
            let bsdf = mat.bsdf(wl, uv).facing(front);
            bsdf.eval(wo_local, Vec3::Z) * std::f32::consts::PI
        }
        // A blend's reflectance is its components' weighted by w.
        Material::Blend { a, b, weight } => {
            let w = weight.eval(uv).clamp(0.0, 1.0);
            reflectance(a, wl, front, uv, wo_local) * (1.0 - w) + reflectance(b, wl, front, uv, wo_local) * w
        }
    }
}
