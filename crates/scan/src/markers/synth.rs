//! Synthetic marker photographs with known truth: a Lambertian sphere carrying flat circular
//! markers (black discs tangent to it, lifted 0.3 mm off the surface) on a black background, seen
//! by two OpenCV cameras with lens distortion, rendered by lucent's renderer
//! (the `direct` integrator; pinhole lenses) with Gaussian sensor noise and 8-bit sRGB
//! quantisation as [`crate::synth`] makes its captures. The sphere is self-luminous (an area light
//! of constant radiance with a black surface) and there is no other light: a lit sphere would let
//! a disc lifted off it cast a shadow next to its own edge (up to 0.7 mm from a 7-mm disc on a
//! 60-mm sphere) that displaces the edge seen in the image by a few tenths of a pixel, and an
//! ambient environment is noisy at the sample counts of a test. So the images have two levels,
//! the sphere's radiance and black, anti-aliased by the renderer's 16 samples per pixel.
//!
//! Frame: view A's camera coordinates (x right, y down, z forward, millimetres); view B maps them
//! as X_B = R·X_A + T, as the calibration's projector entry does. A disc is a fan of 128
//! triangles (its polygon lies within 2·10⁻³ mm of the circle for a 7-mm marker).
//! The model frame has its origin at the sphere's centre; the truth maps it to view A by
//! X_A = Q·X_model + C.

use anyhow::{Context, Result};
use nalgebra::{Matrix3, Vector3};
use render::camera::{Camera, Extrinsics};
use render::math::sampling::Pcg32;
use render::scene::Scene;
use std::fmt::Write as _;
use std::path::Path;

use crate::calib::ProcamCalibration;
use crate::synth::{render_grey, sensor, Device};

/// One flat circular marker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disc {
    /// Centre (view A coordinates, mm).
    pub centre_mm: [f64; 3],
    /// Unit normal (outwards from the sphere).
    pub normal: [f64; 3],
    /// Radius (mm).
    pub radius_mm: f64,
}

/// The scene and the two views.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkerScene {
    /// Views A and B.
    pub cameras: [Device; 2],
    /// Rotation view A → view B (row-major).
    pub rotation: [[f64; 3]; 3],
    /// Translation view A → view B (mm).
    pub translation_mm: [f64; 3],
    /// Sphere centre (view A coordinates, mm).
    pub sphere_centre_mm: [f64; 3],
    /// Sphere radius (mm).
    pub sphere_radius_mm: f64,
    /// Radiance the sphere emits (W·m⁻²·sr⁻¹·nm⁻¹, flat).
    pub sphere_radiance: f64,
    /// The markers.
    pub discs: Vec<Disc>,
    /// Rotation model → view A (Q; the model's origin is the sphere's centre).
    pub model_rotation: [[f64; 3]; 3],
}

/// Rodrigues rotation of `v` about unit `axis` by `angle` radians.
fn rotate(v: Vector3<f64>, axis: Vector3<f64>, angle: f64) -> Vector3<f64> {
    nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle) * v
}

impl MarkerScene {
    /// A 60-mm sphere 420 mm in front of view A (400 × 320 pixels, f ≈ 560 px, barrel and
    /// tangential distortion); view B (same size, other lens) 180 mm to the right, 20 mm up and
    /// 30 mm forward, aimed at the sphere's centre (a 25° vergence); four 7-mm markers 22°–32°
    /// from the direction that bisects the two views, about 9 px in radius in both images.
    pub fn standard() -> MarkerScene {
        let a = Device { width: 400, height: 320, fx: 560.0, fy: 561.0, cx: 199.6, cy: 160.3, distortion: [-0.08, 0.05, 3e-4, -2e-4, 0.0] };
        let b = Device { width: 400, height: 320, fx: 555.0, fy: 556.5, cx: 201.1, cy: 158.8, distortion: [-0.06, 0.03, -2e-4, 1e-4, 0.0] };
        let centre = Vector3::new(0.0, 0.0, 420.0);
        let eye_b = Vector3::new(180.0, -20.0, 30.0);
        let e = Extrinsics::look_at([eye_b.x, eye_b.y, eye_b.z], [centre.x, centre.y, centre.z], [0.0, -1.0, 0.0]).expect("valid pose");
        let radius = 60.0;
        let bis = ((-centre).normalize() + (eye_b - centre).normalize()).normalize();
        let up = bis.cross(&Vector3::new(1.0, 0.0, 0.0)).normalize();
        let discs = [(0.0f64, 25.0f64), (95.0, 32.0), (190.0, 22.0), (280.0, 30.0)]
            .iter()
            .map(|&(az, tilt)| {
                let axis = rotate(up, bis, az.to_radians());
                let n = rotate(bis, axis, tilt.to_radians());
                let c = centre + n * (radius + 0.3);
                Disc { centre_mm: [c.x, c.y, c.z], normal: [n.x, n.y, n.z], radius_mm: 7.0 }
            })
            .collect();
        let q = *nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.3, -0.5, 0.2)).matrix();
        MarkerScene {
            cameras: [a, b],
            rotation: e.r,
            translation_mm: e.t_m,
            sphere_centre_mm: [centre.x, centre.y, centre.z],
            sphere_radius_mm: radius,
            sphere_radiance: 0.5,
            discs,
            model_rotation: [[q[(0, 0)], q[(0, 1)], q[(0, 2)]], [q[(1, 0)], q[(1, 1)], q[(1, 2)]], [q[(2, 0)], q[(2, 1)], q[(2, 2)]]],
        }
    }

    /// The true calibration of the two views (view A as `camera`, view B as `projector`; mm).
    pub fn calibration(&self) -> ProcamCalibration {
        ProcamCalibration {
            camera: self.cameras[0].calibration(),
            projector: self.cameras[1].calibration(),
            rotation: self.rotation,
            translation: self.translation_mm,
            rms_px: 0.0,
            captures: Vec::new(),
        }
    }

    /// The marker centres in the model frame (mm): Qᵀ(c − C).
    pub fn model_markers(&self) -> Vec<[f64; 3]> {
        let q = Matrix3::from_fn(|i, j| self.model_rotation[i][j]);
        let c = Vector3::from(self.sphere_centre_mm);
        self.discs.iter().map(|d| q.transpose() * (Vector3::from(d.centre_mm) - c)).map(|v| [v.x, v.y, v.z]).collect()
    }

    /// A point of view A in view `view`'s coordinates (mm).
    pub fn to_view(&self, view: usize, p: [f64; 3]) -> [f64; 3] {
        if view == 0 {
            return p;
        }
        let r = Matrix3::from_fn(|i, j| self.rotation[i][j]);
        let q = r * Vector3::from(p) + Vector3::from(self.translation_mm);
        [q.x, q.y, q.z]
    }

    /// The true image of each marker's centre in view `view` (pixels, distortion applied).
    pub fn projected_centres(&self, view: usize) -> Vec<[f64; 2]> {
        self.discs.iter().map(|d| self.cameras[view].project(self.to_view(view, d.centre_mm)).expect("marker in front of the view")).collect()
    }

    /// The scene file (view A's camera; the caller swaps in view B's).
    pub fn scene_toml(&self) -> String {
        let f = |x: f64| format!("{x:?}");
        let v = |p: Vector3<f64>| format!("[{}, {}, {}]", f(p.x), f(p.y), f(p.z));
        let c = &self.cameras[0];
        let d = c.distortion;
        let mut s = String::new();
        let _ = writeln!(s, "# Synthetic marker photograph (scan::markers::synth). View A coordinates, millimetres.\nunit = \"mm\"\n");
        let _ = writeln!(s, "[camera]\nmodel = \"opencv\"\nwidth = {}\nheight = {}\nfx = {}\nfy = {}\ncx = {}\ncy = {}", c.width, c.height, f(c.fx), f(c.fy), f(c.cx), f(c.cy));
        let _ = writeln!(s, "dist = [{}, {}, {}, {}, {}]\nR = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nt = [0, 0, 0]\n", f(d[0]), f(d[1]), f(d[2]), f(d[3]), f(d[4]));
        let _ = writeln!(s, "[integrator]\ntype = \"direct\"\n");
        let _ = writeln!(s, "[materials.black]\ntype = \"lambertian\"\nalbedo = 0.0\n");
        let _ = writeln!(s, "[[objects]]\nname = \"sphere\"\nmaterial = \"black\"\nsphere = {{ center = {}, radius = {} }}\n", v(Vector3::from(self.sphere_centre_mm)), f(self.sphere_radius_mm));
        for (k, disc) in self.discs.iter().enumerate() {
            let n = Vector3::from(disc.normal);
            let e1 = n.cross(&if n.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() }).normalize();
            let e2 = n.cross(&e1);
            let c = Vector3::from(disc.centre_mm);
            let m = 128;
            let p = |i: usize| {
                let a = std::f64::consts::TAU * i as f64 / m as f64;
                c + (e1 * a.cos() + e2 * a.sin()) * disc.radius_mm
            };
            let quads: Vec<String> = (0..m / 2).map(|q| format!("[{}, {}, {}, {}]", v(c), v(p(2 * q)), v(p(2 * q + 1)), v(p(2 * q + 2)))).collect();
            let _ = writeln!(s, "[[objects]]\nname = \"marker_{k}\"\nmaterial = \"black\"\nquads = [\n  {},\n]\n", quads.join(",\n  "));
        }
        let _ = writeln!(s, "[[lights]]\ntype = \"area\"\nobject = \"sphere\"\nradiance = {}", f(self.sphere_radiance));
        s
    }

    /// Linear grey of view `view` averaged over `spp` passes (before noise).
    pub fn render_linear(&self, view: usize, spp: u32, seed: u64) -> Result<Vec<f64>> {
        let mut scene = Scene::from_toml_str(&self.scene_toml(), "synthetic markers", Path::new(".")).context("synthetic marker scene")?;
        if view == 1 {
            let d = &self.cameras[1];
            scene.camera = Camera::opencv(d.opencv(self.rotation, self.translation_mm)?, d.width, d.height)?;
        }
        Ok(render_grey(&scene, spp, seed ^ ((view as u64) << 20)))
    }

    /// View `view` as an 8-bit sRGB grey photograph: `spp` samples per pixel, Gaussian noise of
    /// `noise_sigma` (linear, full scale 1) from a fixed seed, rounding.
    pub fn photograph(&self, view: usize, spp: u32, seed: u64, noise_sigma: f64) -> Result<Vec<u8>> {
        let lin = self.render_linear(view, spp, seed)?;
        let mut rng = Pcg32::new(seed ^ 0x4D41_524B, view as u64);
        Ok(sensor(&lin, noise_sigma, &mut rng))
    }

    /// Writes a photograph as an 8-bit grey PNG.
    pub fn write_png(&self, view: usize, pixels: &[u8], path: &Path) -> Result<()> {
        let d = &self.cameras[view];
        render::image_io::write_atomic(path, |tmp| {
            image::save_buffer_with_format(tmp, pixels, d.width, d.height, image::ExtendedColorType::L8, image::ImageFormat::Png).with_context(|| format!("writing {}", path.display()))
        })
    }
}

/// A flat target of discs (a circle grid) seen through a pinhole camera, drawn directly (no
/// renderer): the board plane maps to pixels by `homography` (board (x, y, 1) → pixel, OpenCV's
/// pixel convention), each pixel is the mean of 4 × 4 samples, and a uniform noise of width
/// `noise` from a fixed sequence is added.
#[derive(Clone, Debug, PartialEq)]
pub struct FlatTarget {
    /// Board plane → pixels (H = K [r₁ r₂ t] for a pinhole camera K and board pose R, t).
    pub homography: Matrix3<f64>,
    /// Disc centres (board units).
    pub centres: Vec<[f64; 2]>,
    /// Disc radius (board units).
    pub radius: f64,
    /// The paper's extent: x from, x to, y from, y to (board units).
    pub paper: [f64; 4],
    /// Levels of the discs, the paper and the wall around it (linear).
    pub levels: [f64; 3],
    /// Width of the uniform noise (linear units).
    pub noise: f64,
}

impl FlatTarget {
    /// The target's image, `width` × `height` pixels (linear grey); `None` when the homography is
    /// singular.
    pub fn draw(&self, width: usize, height: usize) -> Option<super::Image> {
        let hinv = self.homography.try_inverse()?;
        let board = |x: f64, y: f64| {
            let p = hinv * Vector3::new(x, y, 1.0);
            (p.x / p.z, p.y / p.z)
        };
        let [disc, paper, wall] = self.levels;
        let mut data = vec![0f32; width * height];
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        for y in 0..height {
            for x in 0..width {
                // Only the discs near the pixel's centre (2 board units covers a pixel's footprint
                // for any target drawn at a sensible scale).
                let (bx, by) = board(x as f64, y as f64);
                let near: Vec<&[f64; 2]> = self.centres.iter().filter(|c| (bx - c[0]).hypot(by - c[1]) < self.radius + 2.0).collect();
                let mut sum = 0.0;
                for sy in 0..4 {
                    for sx in 0..4 {
                        let (bx, by) = board(x as f64 - 0.375 + 0.25 * sx as f64, y as f64 - 0.375 + 0.25 * sy as f64);
                        let on_paper = bx >= self.paper[0] && bx <= self.paper[1] && by >= self.paper[2] && by <= self.paper[3];
                        sum += if near.iter().any(|c| (bx - c[0]).hypot(by - c[1]) < self.radius) {
                            disc
                        } else if on_paper {
                            paper
                        } else {
                            wall
                        };
                    }
                }
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let u = (state >> 40) as f64 / (1u64 << 24) as f64 - 0.5;
                data[y * width + x] = (sum / 16.0 + u * self.noise) as f32;
            }
        }
        super::Image::new(width, height, data).ok()
    }
}
