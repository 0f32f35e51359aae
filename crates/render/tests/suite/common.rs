//! Helpers shared by the render tests.

use render::integrator::{IntegratorKind, IntegratorSettings};
use render::scene::Scene;
use std::path::{Path, PathBuf};
use glam::Vec3;
use render::integrator::render_pass;

#[allow(dead_code)]
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[allow(dead_code)]
pub fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, "test.toml", Path::new(".")).unwrap_or_else(|e| panic!("{e:#}"))
}

#[allow(dead_code)]
pub fn settings(kind: IntegratorKind, max_depth: u32, rr_depth: u32) -> IntegratorSettings {
    IntegratorSettings { kind, max_depth, rr_depth }
}

/// Y of an equal-energy spectrum of value 1 as the renderer's colour tables give it (≈ 1).
#[allow(dead_code)]
pub fn y_of_one() -> f64 {
    render::math::spectral::xyz_of(|_| 1.0)[1]
}

/// Form factor from a differential area to a parallel rectangle [0, a]×[0, b] at distance c with a
/// corner straight above it (Howell, A Catalog of Radiation Heat Transfer Configuration Factors,
/// case B-3). Odd in a and in b, so signed sides give the corner decomposition of any rectangle.
#[allow(dead_code)]
pub fn form_factor_corner(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// Asserts that loading a scene failed with a one-line error mentioning every string in `needles`.
pub fn assert_one_line_error(loaded: anyhow::Result<Scene>, needles: &[&str]) {
    let e = match loaded {
        Ok(_) => panic!("expected an error mentioning {needles:?}"),
        Err(e) => format!("{e:#}"),
    };
    assert!(!e.contains('\n'), "error is not one line: {e}");
    for n in needles {
        assert!(e.contains(n), "error `{e}` does not mention `{n}`");
    }
}

#[allow(dead_code)]
/// A temporary folder for a test's files.
pub fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lucent-test-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[allow(dead_code)]
/// A scene from `text`, its files relative to `dir`.
pub fn load_in(dir: &Path, text: &str) -> Scene {
    Scene::from_toml_str(text, "test.toml", dir).unwrap_or_else(|e| panic!("{e:#}"))
}

#[allow(dead_code)]
/// The quad [−1, 1]² in the plane z = 0, normal +z, u along +x and v along +y (so the tangent
/// frame is (x, y, z)), seen from `eye`, under `lights`.
pub fn quad_scene(eye: Vec3, material: &str, lights: &str) -> String {
    format!(
        r#"
        [camera]
        eye = [{}, {}, {}]
        look_at = [0, 0, 0]
        up = [0, 1, 0]
        vfov_deg = 8
        width = 16
        height = 16
        [integrator]
        type = "direct"
        emitter_samples = 1
        bsdf_samples = 0
        [materials.m]
        {material}
        [[objects]]
        material = "m"
        quad = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
        {lights}
        "#,
        eye.x, eye.y, eye.z
    )
}

#[allow(dead_code)]
pub fn directional(to_light: Vec3, e: f64) -> String {
    let d = -to_light.normalize();
    format!("[[lights]]\ntype = \"directional\"\ndirection = [{}, {}, {}]\nirradiance = {e}", d.x, d.y, d.z)
}

#[allow(dead_code)]
/// Mean luminance Y over the image, and its standard error, from 128 passes: each camera
/// sample's one light sample is exact, so the noise is only that of the sampled wavelengths.
pub fn pixels(s: &Scene) -> (f64, f64) {
    pixels_with(s, 128, 1)
}

#[allow(dead_code)]
/// Mean luminance Y over the image, and its standard error, from `passes` passes of one sample
/// per pixel with the render seed `seed`.
pub fn pixels_with(s: &Scene, passes: u64, seed: u64) -> (f64, f64) {
    let (w, h) = s.resolution();
    let mut buf = vec![[0f32; 3]; (w * h) as usize];
    let means: Vec<f64> = (0..passes)
        .map(|p| {
            render_pass(s, &s.integrator, seed, p, &mut buf);
            buf.iter().map(|xyz| xyz[1] as f64).sum::<f64>() / buf.len() as f64
        })
        .collect();
    let m = means.iter().sum::<f64>() / passes as f64;
    let se = (means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / ((passes - 1) * passes) as f64).sqrt();
    (m, se)
}


#[allow(dead_code)]
/// A ball of radius 1 mm at the origin with boundary material `mat` (TOML lines) and medium
/// `medium`, seen by the `[camera]` table `camera` (TOML lines, without the header), under a
/// uniform environment of spectral radiance 1.
pub fn medium_ball_scene(camera: &str, mat: &str, medium: &str) -> String {
    format!(
        r#"
unit = "mm"
[camera]
{camera}
[materials.boundary]
{mat}
[[objects]]
name = "ball"
material = "boundary"
sphere = {{ center = [0, 0, 0], radius = 1 }}
medium = {medium}
[[lights]]
type = "environment"
radiance = 1
"#
    )
}
