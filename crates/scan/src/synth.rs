//! Synthetic structured-light captures with known truth, rendered by lucent's renderer: the
//! Gray-code sequence of OpenCV's `GrayCodePattern` projected by a projector light (an OpenCV
//! model run backwards, `render::light::projector`) onto a checkerboard-textured calibration
//! board, a sphere or a mesh, seen by an OpenCV camera with lens distortion and a thin lens,
//! under a constant ambient environment, with Gaussian sensor noise and 8-bit sRGB
//! quantisation. The captures are written as the real ones are (`graycode_NN.png`, 8-bit grey,
//! in sequence order) and the truth (both devices' intrinsics, distortion and relative pose in the
//! [`ProcamCalibration`] form, board poses, sphere, mesh transform) as JSON beside them.
//!
//! Frame coordinates: the world is the camera frame (x right, y down, z forward, millimetres),
//! so the camera's pose is the identity and the projector's extrinsics are the stereo pose
//! X_p = R X_c + T. A board's frame has its origin at the first inner corner, x along the rows
//! of `corners[0]` inner corners, y along the `corners[1]` rows, z into the board (OpenCV's
//! object-point convention, corner (i, j) at (i·s, j·s, 0)); the square whose corner is the
//! board frame's (−s, −s) is dark.
//!
//! How a frame is made (`render_capture`):
//! - The projector's share is rendered with the `direct` integrator and the projector as the
//!   scene's only light (a delta light, so each sample is exact up to where in the pixel and the
//!   lens aperture it falls); every frame of a capture uses the same seed, so each pixel integrates
//!   the same sample positions in every frame, as a sensor pixel integrates the same area.
//! - Light adds linearly, so the ambient share (the constant environment, sampled by next-event
//!   estimation and therefore noisy per sample) is rendered once per capture with more samples
//!   and added to every frame; it does not depend on the pattern.
//! - With the same samples, a pattern and its inverse sum to the all-white frame sample by sample
//!   (each sample sees projector value v or 1 − v times the same factor), so the inverse is formed
//!   as white − pattern; `tests/suite/synth.rs` renders an inverse and checks the identity.
//! - The sensor's spectral response is x̄ + ȳ + z̄ (grey = (X + Y + Z)/3): every spectrum here is
//!   flat, and the hero-wavelength density is proportional to x̄ + ȳ + z̄, so the grey value of
//!   a sample carries no wavelength noise (a flat radiance L gives grey L).
//! - Sensor noise: Gaussian of `noise_sigma` (linear units, full scale 1) per pixel and frame,
//!   from a fixed seed; then the sRGB curve, rounding and clamping to 0…255.

use crate::calib::{CapturePose, DeviceCalibration, ProcamCalibration};
use crate::graycode::{Frame, PatternSet};
use anyhow::{bail, Context, Result};
use nalgebra::{Matrix3, Vector3};
use render::camera::{Camera, Distortion, Extrinsics, Intrinsics, OpenCv};
use render::integrator::{render_pass, IntegratorKind, IntegratorSettings};
use render::light::projector::Projector;
use render::light::Light;
use render::math::sampling::Pcg32;
use render::scene::Scene;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One device's intrinsics and distortion (OpenCV model and pixel convention).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Device {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels, OpenCV convention).
    pub cx: f64,
    /// Principal point y (pixels, OpenCV convention).
    pub cy: f64,
    /// [k1, k2, p1, p2, k3] (dimensionless).
    pub distortion: [f64; 5],
}

impl Device {
    /// The renderer's OpenCV model of this device with world → device rotation `r` and
    /// translation `t_mm` (millimetres).
    pub fn opencv(&self, r: [[f64; 3]; 3], t_mm: [f64; 3]) -> Result<OpenCv> {
        let intr = Intrinsics { fx: self.fx, fy: self.fy, cx: self.cx, cy: self.cy };
        let dist = Distortion::from_opencv(&self.distortion)?;
        let extr = Extrinsics::from_rt(r, t_mm.map(|x| x * 1e-3))?;
        OpenCv::new(intr, dist, extr, self.width, self.height)
    }

    /// OpenCV pixel position of point `p` (device coordinates, any length unit), or None behind it.
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        if !(p[2] > 0.0) {
            return None;
        }
        let d = Distortion::from_opencv(&self.distortion).ok()?;
        let (x, y) = d.distort(p[0] / p[2], p[1] / p[2]);
        Some([self.fx * x + self.cx, self.fy * y + self.cy])
    }

    /// This device as a calibration entry (RMS 0: the truth).
    pub fn calibration(&self) -> DeviceCalibration {
        DeviceCalibration {
            width: self.width,
            height: self.height,
            fx: self.fx,
            fy: self.fy,
            cx: self.cx,
            cy: self.cy,
            distortion: self.distortion.to_vec(),
            rms_px: 0.0,
        }
    }
}

/// A projector–camera rig and the light of the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rig {
    /// The camera (at the world origin, identity pose).
    pub camera: Device,
    /// The projector.
    pub projector: Device,
    /// Rotation camera → projector, row-major (X_p = R X_c + T).
    pub rotation: [[f64; 3]; 3],
    /// Translation camera → projector (mm).
    pub translation_mm: [f64; 3],
    /// Camera thin-lens aperture radius (mm; 0 for a pinhole).
    pub aperture_radius_mm: f64,
    /// Camera focus distance along the optical axis (mm).
    pub focus_distance_mm: f64,
    /// Projector intensity of a pixel of value 1 (W·sr⁻¹·nm⁻¹, flat over wavelength).
    pub projector_intensity: f64,
    /// Constant ambient radiance of the environment (W·m⁻²·sr⁻¹·nm⁻¹, flat).
    pub ambient_radiance: f64,
}

impl Rig {
    /// The rig of the synthetic round trip: a 320 × 256 camera with barrel and tangential
    /// distortion and an f/… thin lens focused at 470 mm, a 256 × 192 projector (8 + 8 bits,
    /// 34 images) 140 mm to the camera's left and 15 mm below it, aimed at (0, 0, 470) mm.
    pub fn standard() -> Rig {
        let camera = Device { width: 320, height: 256, fx: 420.0, fy: 421.5, cx: 161.3, cy: 126.2, distortion: [-0.12, 0.09, 6e-4, -4e-4, 0.0] };
        let projector = Device { width: 256, height: 192, fx: 330.0, fy: 331.0, cx: 130.4, cy: 101.7, distortion: [-0.03, 0.01, 0.0, 0.0, 0.0] };
        let e = Extrinsics::look_at([-140.0, 15.0, 0.0], [0.0, 0.0, 470.0], [0.0, -1.0, 0.0]).expect("valid projector pose");
        Rig {
            camera,
            projector,
            rotation: e.r,
            translation_mm: e.t_m,
            aperture_radius_mm: 2.5,
            focus_distance_mm: 470.0,
            projector_intensity: 0.45,
            ambient_radiance: 0.03,
        }
    }

    /// The rig at `k` times its resolution in both devices: image sizes and focal lengths × k,
    /// principal points k·(c + ½) − ½ (pixel centres at integers, so pixel edges map to pixel
    /// edges), the camera's aperture radius ÷ k, so that the defocus blur keeps its diameter in
    /// pixels (2·aperture·|1/z − 1/z_focus|·fx); distortion, poses, focus and light unchanged.
    /// The same views, sampled k times finer. (With the aperture kept, the 2.5 mm of
    /// [`Rig::standard`] at 4× blurs the sphere's front by about 5 camera pixels, wider than the
    /// finest stripes of 2 projector pixels: a quarter of its lit pixels leave the last column
    /// bit undecided and decoding errs by 0.56 projector pixels RMS.)
    pub fn scaled(&self, k: u32) -> Rig {
        let s = |d: &Device| {
            let k = k as f64;
            Device {
                width: d.width * k as u32,
                height: d.height * k as u32,
                fx: d.fx * k,
                fy: d.fy * k,
                cx: k * (d.cx + 0.5) - 0.5,
                cy: k * (d.cy + 0.5) - 0.5,
                distortion: d.distortion,
            }
        };
        Rig { camera: s(&self.camera), projector: s(&self.projector), aperture_radius_mm: self.aperture_radius_mm / k as f64, ..self.clone() }
    }

    /// [`Rig::standard`] at the size of the shared real captures: a 1280 × 1024 camera and a
    /// 1024 × 768 projector (10 + 10 bits, 42 images).
    pub fn full() -> Rig {
        Rig::standard().scaled(4)
    }

    /// The truth as a calibration: both devices, the stereo pose, RMS 0, and `captures`.
    pub fn calibration(&self, captures: Vec<CapturePose>) -> ProcamCalibration {
        ProcamCalibration {
            camera: self.camera.calibration(),
            projector: self.projector.calibration(),
            rotation: self.rotation,
            translation: self.translation_mm,
            rms_px: 0.0,
            captures,
        }
    }

    /// The projector position in camera coordinates (mm): −Rᵀ T.
    pub fn projector_centre_mm(&self) -> [f64; 3] {
        let r = Matrix3::from_fn(|i, j| self.rotation[i][j]);
        let c = -(r.transpose() * Vector3::from(self.translation_mm));
        [c.x, c.y, c.z]
    }

    /// A point in camera coordinates (mm) in projector coordinates (mm).
    pub fn to_projector(&self, p: [f64; 3]) -> [f64; 3] {
        let r = Matrix3::from_fn(|i, j| self.rotation[i][j]);
        let q = r * Vector3::from(p) + Vector3::from(self.translation_mm);
        [q.x, q.y, q.z]
    }
}

/// A printed chessboard: `corners` inner corners, squares of `square_mm`, a light margin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Board {
    /// Inner corners along the board's x and y (both odd: the square counts must be even).
    pub corners: [u32; 2],
    /// Square side (mm).
    pub square_mm: f64,
    /// Width of the light margin around the squares (mm).
    pub margin_mm: f64,
    /// Albedo of the dark squares (Lambertian, flat spectrum).
    pub dark_albedo: f64,
    /// Albedo of the light squares and the margin.
    pub light_albedo: f64,
}

impl Board {
    /// 9 × 7 inner corners (10 × 8 squares, as the shared real captures), 20 mm squares.
    pub fn standard() -> Board {
        Board { corners: [9, 7], square_mm: 20.0, margin_mm: 20.0, dark_albedo: 0.1, light_albedo: 0.8 }
    }

    /// The checkered region in board coordinates: x ∈ [x0, x1], y ∈ [y0, y1] (mm).
    fn extent(&self) -> (f64, f64, f64, f64) {
        let s = self.square_mm;
        (-s, self.corners[0] as f64 * s, -s, self.corners[1] as f64 * s)
    }

    /// Inner corner (i, j) in board coordinates (mm).
    pub fn corner(&self, i: u32, j: u32) -> [f64; 3] {
        [i as f64 * self.square_mm, j as f64 * self.square_mm, 0.0]
    }
}

/// What a capture shows.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// The board with pose board → camera: Rodrigues `rvec` (radians), `tvec_mm`.
    Board { rvec: [f64; 3], tvec_mm: [f64; 3] },
    /// A Lambertian sphere (centre and radius in mm, camera coordinates).
    Sphere { centre_mm: [f64; 3], radius_mm: f64, albedo: f64 },
    /// A Lambertian triangle mesh placed by `matrix` (mesh file units → camera mm, rows acting
    /// on column vectors).
    Mesh { path: PathBuf, matrix: [[f64; 4]; 4], albedo: f64 },
}

/// Board pose as a rotation matrix and translation (mm), board → camera.
fn board_rt(rvec: [f64; 3], tvec_mm: [f64; 3]) -> (Matrix3<f64>, Vector3<f64>) {
    let r = render::camera::opencv::rodrigues(rvec);
    (Matrix3::from_fn(|i, j| r[i][j]), Vector3::from(tvec_mm))
}

impl Target {
    /// The first surface point (camera coordinates, mm) on the ray from `o` along `d`, for the
    /// analytic targets (board plane within its margin, sphere); None for meshes and misses.
    pub fn surface_point(&self, board: &Board, o: [f64; 3], d: [f64; 3]) -> Option<[f64; 3]> {
        let (o, d) = (Vector3::from(o), Vector3::from(d));
        match self {
            Target::Board { rvec, tvec_mm } => {
                let (r, t) = board_rt(*rvec, *tvec_mm);
                let n = r.column(2).into_owned();
                let denom = n.dot(&d);
                if denom.abs() < 1e-12 {
                    return None;
                }
                let s = n.dot(&(t - o)) / denom;
                if !(s > 0.0) {
                    return None;
                }
                let p = o + d * s;
                let q = r.transpose() * (p - t);
                let (x0, x1, y0, y1) = board.extent();
                let m = board.margin_mm;
                if q.x < x0 - m || q.x > x1 + m || q.y < y0 - m || q.y > y1 + m {
                    return None;
                }
                Some([p.x, p.y, p.z])
            }
            Target::Sphere { centre_mm, radius_mm, .. } => {
                let oc = o - Vector3::from(*centre_mm);
                let b = oc.dot(&d);
                let c = oc.norm_squared() - radius_mm * radius_mm;
                let disc = b * b - d.norm_squared() * c;
                if disc < 0.0 {
                    return None;
                }
                let s = (-b - disc.sqrt()) / d.norm_squared();
                if !(s > 0.0) {
                    return None;
                }
                let p = o + d * s;
                Some([p.x, p.y, p.z])
            }
            Target::Mesh { .. } => None,
        }
    }
}

/// Sampling and noise of the renders.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Samples per pixel of the projector's share of each frame.
    pub spp: u32,
    /// Samples per pixel of the ambient share (once per capture).
    pub ambient_spp: u32,
    /// Seed of the renders and of the sensor noise.
    pub seed: u64,
    /// Standard deviation of the Gaussian sensor noise (linear grey, full scale 1).
    pub noise_sigma: f64,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings { spp: 16, ambient_spp: 64, seed: 14, noise_sigma: 0.002 }
    }
}

/// One rendered capture: the frames of the sequence as 8-bit grey, row-major.
#[derive(Clone, Debug)]
pub struct Capture {
    /// Folder name.
    pub name: String,
    /// Camera width (pixels).
    pub width: u32,
    /// Camera height (pixels).
    pub height: u32,
    /// Frames in sequence order (`graycode_00` first).
    pub frames: Vec<Vec<u8>>,
    /// Linear grey of the all-white and all-black frames before noise and quantisation.
    pub white_linear: Vec<f64>,
    /// See `white_linear`.
    pub black_linear: Vec<f64>,
    /// Wall-clock seconds spent rendering (both shares, all frames).
    pub render_seconds: f64,
    /// Number of renderer calls of `spp` passes made for the projector's share.
    pub projector_renders: usize,
}

fn f(x: f64) -> String {
    format!("{x:?}")
}
fn v3s(p: [f64; 3]) -> String {
    format!("[{}, {}, {}]", f(p[0]), f(p[1]), f(p[2]))
}

/// The TOML text of a capture's scene: the camera, the target, and either no light (the
/// projector is added in code) or the ambient environment.
pub fn scene_toml(rig: &Rig, board: &Board, target: &Target, ambient: bool) -> Result<String> {
    let c = &rig.camera;
    let mut s = String::new();
    let _ = writeln!(s, "# Synthetic structured-light capture (scan::synth). Camera coordinates, millimetres.\nunit = \"mm\"\n");
    let _ = writeln!(s, "[camera]\nmodel = \"opencv\"\nwidth = {}\nheight = {}", c.width, c.height);
    let _ = writeln!(s, "fx = {}\nfy = {}\ncx = {}\ncy = {}", f(c.fx), f(c.fy), f(c.cx), f(c.cy));
    let d = c.distortion;
    let _ = writeln!(s, "dist = [{}, {}, {}, {}, {}]", f(d[0]), f(d[1]), f(d[2]), f(d[3]), f(d[4]));
    let _ = writeln!(s, "R = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nt = [0, 0, 0]");
    if rig.aperture_radius_mm > 0.0 {
        let _ = writeln!(s, "aperture_radius = {}\nfocus_distance = {}", f(rig.aperture_radius_mm), f(rig.focus_distance_mm));
    }
    let _ = writeln!(s, "\n[integrator]\ntype = \"direct\"\n");
    match target {
        Target::Board { rvec, tvec_mm } => {
            if board.corners.iter().any(|&n| n % 2 == 0 || n < 3) {
                bail!("board corners {}×{}: both must be odd and at least 3 (even square counts)", board.corners[0], board.corners[1]);
            }
            let (r, t) = board_rt(*rvec, *tvec_mm);
            let cam = |x: f64, y: f64| {
                let p = r * Vector3::new(x, y, 0.0) + t;
                [p.x, p.y, p.z]
            };
            let quad = |x0: f64, x1: f64, y0: f64, y1: f64| {
                format!("[{}, {}, {}, {}]", v3s(cam(x0, y0)), v3s(cam(x1, y0)), v3s(cam(x1, y1)), v3s(cam(x0, y1)))
            };
            let _ = writeln!(
                s,
                "[materials.squares]\ntype = \"lambertian\"\nalbedo = {{ checkerboard = {{ squares = 2, even = {}, odd = {} }} }}\n",
                f(board.dark_albedo),
                f(board.light_albedo)
            );
            let _ = writeln!(s, "[materials.margin]\ntype = \"lambertian\"\nalbedo = {}\n", f(board.light_albedo));
            // 2 × 2-square blocks, each a quad whose (u, v) square holds one checkerboard period,
            // dark square at its (0, 0) corner: the parity is the same across blocks.
            let sq = board.square_mm;
            let (x0, x1, y0, y1) = board.extent();
            let mut quads = Vec::new();
            for by in 0..(board.corners[1] + 1) / 2 {
                for bx in 0..(board.corners[0] + 1) / 2 {
                    let (ax, ay) = (x0 + 2.0 * sq * bx as f64, y0 + 2.0 * sq * by as f64);
                    quads.push(quad(ax, ax + 2.0 * sq, ay, ay + 2.0 * sq));
                }
            }
            let _ = writeln!(s, "[[objects]]\nname = \"board\"\nmaterial = \"squares\"\nquads = [\n  {},\n]\n", quads.join(",\n  "));
            let m = board.margin_mm;
            if m > 0.0 {
                let strips = [
                    quad(x0 - m, x1 + m, y0 - m, y0),
                    quad(x0 - m, x1 + m, y1, y1 + m),
                    quad(x0 - m, x0, y0, y1),
                    quad(x1, x1 + m, y0, y1),
                ];
                let _ = writeln!(s, "[[objects]]\nname = \"margin\"\nmaterial = \"margin\"\nquads = [\n  {},\n]\n", strips.join(",\n  "));
            }
        }
        Target::Sphere { centre_mm, radius_mm, albedo } => {
            let _ = writeln!(s, "[materials.white]\ntype = \"lambertian\"\nalbedo = {}\n", f(*albedo));
            let _ = writeln!(s, "[[objects]]\nname = \"sphere\"\nmaterial = \"white\"\nsphere = {{ center = {}, radius = {} }}\n", v3s(*centre_mm), f(*radius_mm));
        }
        Target::Mesh { path, matrix, albedo } => {
            let _ = writeln!(s, "[materials.white]\ntype = \"lambertian\"\nalbedo = {}\n", f(*albedo));
            let rows: Vec<String> = matrix.iter().map(|r| format!("[{}, {}, {}, {}]", f(r[0]), f(r[1]), f(r[2]), f(r[3]))).collect();
            let p = path.to_str().with_context(|| format!("{}: mesh path is not UTF-8", path.display()))?;
            let _ = writeln!(s, "[[objects]]\nname = \"mesh\"\nmaterial = \"white\"\nmesh = {:?}\ntransform = {{ matrix = [{}] }}\n", p, rows.join(", "));
        }
    }
    if ambient {
        let _ = writeln!(s, "[[lights]]\ntype = \"environment\"\nradiance = {}", f(rig.ambient_radiance));
    }
    Ok(s)
}

/// Linear grey (X + Y + Z)/3 per pixel, averaged over `spp` passes of the `direct` integrator.
pub(crate) fn render_grey(scene: &Scene, spp: u32, seed: u64) -> Vec<f64> {
    let settings = IntegratorSettings { kind: IntegratorKind::Direct, max_depth: 2, rr_depth: 5 };
    let (w, h) = scene.resolution();
    let n = w as usize * h as usize;
    let mut buf = vec![[0f32; 3]; n];
    let mut sum = vec![0f64; n];
    for pass in 0..spp.max(1) {
        render_pass(scene, &settings, seed, pass as u64, &mut buf);
        for (s, x) in sum.iter_mut().zip(&buf) {
            *s += (x[0] as f64 + x[1] as f64 + x[2] as f64) / 3.0;
        }
    }
    let k = 1.0 / spp.max(1) as f64;
    sum.iter_mut().for_each(|s| *s *= k);
    sum
}

/// A capture's renderer state: the projector-lit scene (its light replaced per pattern) and the
/// projector's camera.
pub struct CaptureScene {
    scene: Scene,
    projector: Camera,
    intensity: optics::spectrum::DenseSpectrum,
}

impl CaptureScene {
    /// Build the scene of `target` with the projector as its only light (dark until
    /// [`CaptureScene::render_pattern`] sets an image).
    pub fn new(rig: &Rig, board: &Board, target: &Target) -> Result<CaptureScene> {
        let text = scene_toml(rig, board, target, false)?;
        let scene = Scene::from_toml_str(&text, "synthetic capture", Path::new(".")).context("synthetic capture scene")?;
        let p = &rig.projector;
        let projector = Camera::opencv(p.opencv(rig.rotation, rig.translation_mm)?, p.width, p.height)?;
        let i0 = rig.projector_intensity;
        Ok(CaptureScene { scene, projector, intensity: optics::spectrum::DenseSpectrum::from_fn(|_| i0) })
    }

    /// Linear grey of the projector's share with projector image `values` (linear, row-major).
    pub fn render_image(&mut self, values: Vec<f32>, spp: u32, seed: u64) -> Result<Vec<f64>> {
        let p = Projector::new(self.projector.clone(), values, self.intensity.clone())?;
        self.scene.lights = vec![Light::Projector(Box::new(p))];
        self.scene.light_pmf = vec![1.0];
        self.scene.light_cdf = vec![1.0];
        self.scene.environment = None;
        Ok(render_grey(&self.scene, spp, seed))
    }

    /// The Gray-code sequence of this projector (step 1).
    pub fn patterns(&self) -> Result<PatternSet> {
        PatternSet::new(self.projector.width, self.projector.height, 1)
    }

    /// Linear grey of the projector's share for image `index` of the Gray-code sequence.
    pub fn render_pattern(&mut self, index: usize, spp: u32, seed: u64) -> Result<Vec<f64>> {
        let img = self.patterns()?.image(index).with_context(|| format!("pattern {index} is past the sequence"))?;
        self.render_image(img.iter().map(|&c| c as f32 / 255.0).collect(), spp, seed)
    }
}

/// Linear grey of the ambient share of `target` (the environment light alone).
pub fn render_ambient(rig: &Rig, board: &Board, target: &Target, spp: u32, seed: u64) -> Result<Vec<f64>> {
    let text = scene_toml(rig, board, target, true)?;
    let scene = Scene::from_toml_str(&text, "synthetic capture (ambient)", Path::new(".")).context("synthetic ambient scene")?;
    Ok(render_grey(&scene, spp, seed ^ 0xA3B1))
}

/// Linear grey → 8-bit sRGB code with Gaussian noise of `sigma` from `rng`.
pub(crate) fn sensor(v: &[f64], sigma: f64, rng: &mut Pcg32) -> Vec<u8> {
    v.iter()
        .map(|&x| {
            // Box–Muller.
            let (u1, u2) = (rng.next_f64().max(1e-300), rng.next_f64());
            let g = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            let y = (x + sigma * g).clamp(0.0, 1.0);
            (optics::color::srgb_encode(y) * 255.0).round().clamp(0.0, 255.0) as u8
        })
        .collect()
}

/// Render every frame of the sequence for `target`.
pub fn render_capture(rig: &Rig, board: &Board, target: &Target, settings: &RenderSettings, name: &str) -> Result<Capture> {
    if let Target::Board { rvec, tvec_mm } = target {
        check_board_visible(rig, board, *rvec, *tvec_mm).with_context(|| format!("capture {name}"))?;
    }
    let t0 = Instant::now();
    let mut cs = CaptureScene::new(rig, board, target)?;
    let set = cs.patterns()?;
    let n_img = set.len();
    let ncode = n_img - 2;
    // The order this relies on: each bit's pattern, then its inverse; then white and black.
    let order_ok = (0..ncode).all(|k| {
        matches!(set.frame(k), Some(Frame::Column { inverse, .. } | Frame::Row { inverse, .. }) if inverse == (k % 2 == 1))
    }) && set.frame(ncode) == Some(Frame::White)
        && set.frame(ncode + 1) == Some(Frame::Black);
    if !order_ok {
        bail!("the pattern sequence is not pattern/inverse pairs followed by white and black");
    }
    let ambient = render_ambient(rig, board, target, settings.ambient_spp, settings.seed)?;
    let white = cs.render_pattern(ncode, settings.spp, settings.seed)?;
    let mut linear: Vec<Vec<f64>> = Vec::with_capacity(n_img);
    for bit in 0..ncode / 2 {
        let p = cs.render_pattern(2 * bit, settings.spp, settings.seed)?;
        let inv: Vec<f64> = white.iter().zip(&p).map(|(w, p)| (w - p).max(0.0)).collect();
        linear.push(p);
        linear.push(inv);
    }
    linear.push(white);
    linear.push(vec![0.0; ambient.len()]);
    for img in &mut linear {
        img.iter_mut().zip(&ambient).for_each(|(x, a)| *x += a);
    }
    let render_seconds = t0.elapsed().as_secs_f64();
    let frames = linear
        .iter()
        .enumerate()
        .map(|(k, img)| {
            let mut rng = Pcg32::new(settings.seed ^ 0x5E45_0000, (k as u64) << 32 | name_hash(name));
            sensor(img, settings.noise_sigma, &mut rng)
        })
        .collect();
    let black_linear = linear.pop().expect("black frame");
    let white_linear = linear.pop().expect("white frame");
    Ok(Capture {
        name: name.to_string(),
        width: rig.camera.width,
        height: rig.camera.height,
        frames,
        white_linear,
        black_linear,
        render_seconds,
        projector_renders: 1 + ncode / 2,
    })
}

fn name_hash(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4u64, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3)) & 0xffff_ffff
}

/// Refuse a board pose whose checkered region is not inside both images (3 px from the edges).
pub fn check_board_visible(rig: &Rig, board: &Board, rvec: [f64; 3], tvec_mm: [f64; 3]) -> Result<()> {
    let (r, t) = board_rt(rvec, tvec_mm);
    let (x0, x1, y0, y1) = board.extent();
    for (x, y) in [(x0, y0), (x1, y0), (x1, y1), (x0, y1)] {
        let p = r * Vector3::new(x, y, 0.0) + t;
        let pc = [p.x, p.y, p.z];
        for (dev, q, what) in [(&rig.camera, pc, "camera"), (&rig.projector, rig.to_projector(pc), "projector")] {
            let Some(uv) = dev.project(q) else { bail!("the board is behind the {what}") };
            let m = 3.0;
            if uv[0] < m || uv[1] < m || uv[0] > dev.width as f64 - 1.0 - m || uv[1] > dev.height as f64 - 1.0 - m {
                bail!("the board's corner ({x}, {y}) mm projects to ({:.1}, {:.1}) px, outside the {what}'s {}×{} image", uv[0], uv[1], dev.width, dev.height);
            }
        }
    }
    Ok(())
}

/// Write a capture's frames as `graycode_NN.png` (8-bit grey) into `dir` (created).
pub fn write_capture(capture: &Capture, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    for (k, frame) in capture.frames.iter().enumerate() {
        let path = dir.join(format!("graycode_{k:02}.png"));
        render::image_io::write_atomic(&path, |tmp| {
            image::save_buffer_with_format(tmp, frame, capture.width, capture.height, image::ExtendedColorType::L8, image::ImageFormat::Png)
                .with_context(|| format!("writing {}", path.display()))
        })?;
    }
    Ok(())
}

/// The truth of a sphere capture.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SphereTruth {
    /// Capture folder.
    pub name: String,
    /// Centre in camera coordinates (mm).
    pub centre: [f64; 3],
    /// Radius (mm).
    pub radius: f64,
}

/// The truth of a mesh capture.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshTruth {
    /// Capture folder.
    pub name: String,
    /// The mesh file.
    pub mesh: String,
    /// Mesh file units → camera coordinates (mm), rows acting on column vectors.
    pub matrix: [[f64; 4]; 4],
}

/// Everything known about a synthetic capture set, as `truth.json` holds it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// Length unit of every length here ("mm"; the board's square is `board.square_mm`).
    pub unit: String,
    /// The board.
    pub board: Board,
    /// Devices, stereo pose and the board captures' poses (board → camera), lengths in mm.
    pub calibration: ProcamCalibration,
    /// Sphere captures.
    pub spheres: Vec<SphereTruth>,
    /// Mesh captures.
    pub meshes: Vec<MeshTruth>,
    /// The rig, lens and light as rendered.
    pub rig: Rig,
    /// Sampling and noise.
    pub render: RenderSettings,
}

/// The truth of a set of named targets.
pub fn truth(rig: &Rig, board: &Board, targets: &[(String, Target)], settings: &RenderSettings) -> Truth {
    let mut captures = Vec::new();
    let mut spheres = Vec::new();
    let mut meshes = Vec::new();
    for (name, t) in targets {
        match t {
            Target::Board { rvec, tvec_mm } => captures.push(CapturePose {
                name: name.clone(),
                rvec: *rvec,
                tvec: *tvec_mm,
                rms_px: 0.0,
                projector_corners: (board.corners[0] * board.corners[1]) as usize,
            }),
            Target::Sphere { centre_mm, radius_mm, .. } => spheres.push(SphereTruth { name: name.clone(), centre: *centre_mm, radius: *radius_mm }),
            Target::Mesh { path, matrix, .. } => meshes.push(MeshTruth { name: name.clone(), mesh: path.display().to_string(), matrix: *matrix }),
        }
    }
    Truth {
        unit: "mm".into(),
        board: board.clone(),
        calibration: rig.calibration(captures),
        spheres,
        meshes,
        rig: rig.clone(),
        render: settings.clone(),
    }
}

/// Write JSON atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    render::image_io::write_atomic(path, |tmp| std::fs::write(tmp, text.as_bytes()).with_context(|| format!("writing {}", path.display())))
}

/// The standard targets: ten board poses (`board_0` … `board_5` in the middle of the images,
/// `board_6` … `board_9` shifted towards their four corners), a 70-mm sphere and the bunny
/// `mesh` scaled to about 135 mm tall, all 440–520 mm in front of the camera.
pub fn standard_targets(mesh: &Path) -> Result<Vec<(String, Target)>> {
    let b = Board::standard();
    let centre = [4.0 * b.square_mm, 3.0 * b.square_mm, 0.0];
    let pose = |rvec: [f64; 3], c: [f64; 3]| {
        let (r, _) = board_rt(rvec, [0.0; 3]);
        let t = Vector3::from(c) - r * Vector3::from(centre);
        Target::Board { rvec, tvec_mm: [t.x, t.y, t.z] }
    };
    let mut v = vec![
        ("board_0".to_string(), pose([0.02, -0.03, 0.01], [0.0, 0.0, 470.0])),
        ("board_1".to_string(), pose([0.38, 0.02, 0.0], [0.0, -5.0, 470.0])),
        ("board_2".to_string(), pose([-0.32, 0.25, 0.08], [5.0, 5.0, 490.0])),
        ("board_3".to_string(), pose([0.08, -0.40, -0.05], [-5.0, 0.0, 460.0])),
        ("board_4".to_string(), pose([-0.22, -0.30, 0.12], [0.0, 8.0, 520.0])),
        ("board_5".to_string(), pose([0.25, 0.35, -0.10], [0.0, 0.0, 450.0])),
        ("board_6".to_string(), pose([0.10, 0.30, 0.05], [48.0, 28.0, 480.0])),
        ("board_7".to_string(), pose([-0.15, -0.30, -0.06], [-48.0, -28.0, 480.0])),
        ("board_8".to_string(), pose([0.30, -0.10, 0.10], [48.0, -28.0, 480.0])),
        ("board_9".to_string(), pose([-0.30, 0.12, -0.08], [-48.0, 28.0, 480.0])),
    ];
    v.push(("sphere".to_string(), Target::Sphere { centre_mm: [0.0, 0.0, 440.0], radius_mm: 70.0, albedo: 0.8 }));
    v.push(("bunny".to_string(), Target::Mesh { path: mesh.to_path_buf(), matrix: bunny_matrix(mesh)?, albedo: 0.8 }));
    Ok(v)
}

/// The bunny's placement: centred on its bounding box, scaled to 135 mm tall, upright in the
/// camera frame (mesh +y to camera −y), turned 200° about the vertical, centre at 470 mm.
fn bunny_matrix(mesh: &Path) -> Result<[[f64; 4]; 4]> {
    let meshes = render::shape::mesh::TriangleMesh::load(mesh)?;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for (_, m) in &meshes {
        for p in &m.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as f64);
                hi[k] = hi[k].max(p[k] as f64);
            }
        }
    }
    let c = Vector3::new(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2]));
    let s = 135.0 / (hi[1] - lo[1]);
    let flip = Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0);
    let a = 200f64.to_radians();
    let turn = Matrix3::new(a.cos(), 0.0, a.sin(), 0.0, 1.0, 0.0, -a.sin(), 0.0, a.cos());
    let r = turn * flip * s;
    let t = Vector3::new(0.0, 0.0, 470.0) - r * c;
    Ok([[r[(0, 0)], r[(0, 1)], r[(0, 2)], t.x], [r[(1, 0)], r[(1, 1)], r[(1, 2)], t.y], [r[(2, 0)], r[(2, 1)], r[(2, 2)], t.z], [0.0, 0.0, 0.0, 1.0]])
}

/// Render and write a whole set into `out`: one folder per target, `truth.json` (see [`Truth`])
/// and `calibration.json` (the true [`ProcamCalibration`], lengths in mm). Returns the captures.
pub fn generate(rig: &Rig, board: &Board, targets: &[(String, Target)], settings: &RenderSettings, out: &Path) -> Result<Vec<Capture>> {
    generate_only(rig, board, targets, settings, out, None)
}

/// [`generate`], rendering only the targets named in `only` (all when None); the truth files
/// list every target.
pub fn generate_only(rig: &Rig, board: &Board, targets: &[(String, Target)], settings: &RenderSettings, out: &Path, only: Option<&[String]>) -> Result<Vec<Capture>> {
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    if let Some(names) = only {
        if let Some(n) = names.iter().find(|n| !targets.iter().any(|(t, _)| t == *n)) {
            bail!("no target named {n:?}");
        }
    }
    let mut caps = Vec::new();
    for (name, t) in targets.iter().filter(|(n, _)| only.is_none_or(|o| o.contains(n))) {
        let c = render_capture(rig, board, t, settings, name)?;
        write_capture(&c, &out.join(name))?;
        caps.push(c);
    }
    let tr = truth(rig, board, targets, settings);
    write_json(&out.join("truth.json"), &tr)?;
    write_json(&out.join("calibration.json"), &tr.calibration)?;
    Ok(caps)
}
