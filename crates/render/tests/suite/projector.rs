//! Projector lights: a projector and a camera with the same intrinsics, distortion and pose see
//! the projected image on a Lambertian plane pixel for pixel (ρ/π · v · I₀ · cos θ / r²), and the
//! irradiance falls with the inverse square of distance and the cosine of incidence; in the
//! `irradiance` profile (Mitsuba 3's) a constant image lights a plane perpendicular to the axis
//! evenly, in the `intensity` profile (pbrt-v4's) with cos³ of the angle off the axis.

use crate::common::{settings, y_of_one};
use render::image_io::{write_image, Image};
use render::integrator::{render_pass, IntegratorKind};
use render::math::sampling::Pcg32;
use render::scene::Scene;

/// Per-pixel mean and standard error of Y over `passes` passes of `direct`, and the number of
/// passes in which the pixel received any light.
fn mean_se(s: &Scene, passes: u64, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<u32>) {
    let (w, h) = s.resolution();
    let n = (w * h) as usize;
    let st = settings(IntegratorKind::Direct, 2, 5);
    let (mut s1, mut s2, mut lit) = (vec![0.0f64; n], vec![0.0f64; n], vec![0u32; n]);
    let mut buf = vec![[0.0f32; 3]; n];
    for pass in 0..passes {
        render_pass(s, &st, seed, pass, &mut buf);
        for k in 0..n {
            let y = buf[k][1] as f64;
            s1[k] += y;
            s2[k] += y * y;
            lit[k] += u32::from(y > 0.0);
        }
    }
    let m: Vec<f64> = s1.iter().map(|a| a / passes as f64).collect();
    let se = (0..n).map(|k| ((s2[k] / passes as f64 - m[k] * m[k]).max(0.0) / (passes - 1) as f64).sqrt()).collect();
    (m, se, lit)
}

/// A white Lambertian plane z = `d` (albedo `rho`) seen by the camera `cam` (inline TOML keys) and
/// lit by a projector with the same model showing `image`, with the light's other keys `light`.
fn plane_scene(cam: &str, rho: f64, d: f64, image: &str, light: &str) -> String {
    format!(
        r#"
        unit = "m"
        camera = {{ {cam} }}
        [materials.white]
        type = "lambertian"
        albedo = {rho}
        [[objects]]
        material = "white"
        quad = [[-5, -5, {d}], [5, -5, {d}], [5, 5, {d}], [-5, 5, {d}]]
        [[lights]]
        type = "projector"
        image = "{image}"
        {light}
        camera = {{ {cam} }}
        "#
    )
}

/// cos θ / r² = d_z³ / D² for the plane z = D, averaged over pixel (i, j) of the scene's camera
/// (8 × 8 points).
fn pixel_geometry(s: &Scene, i: u32, j: u32, d: f64) -> f64 {
    let n = 8;
    let mut g = 0.0;
    for a in 0..n {
        for b in 0..n {
            let u = glam::Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
            let dz = s.camera.generate_ray(i, j, u).d.z as f64;
            g += dz * dz * dz / (d * d) / (n * n) as f64;
        }
    }
    g
}

#[test]
fn projector_and_camera_with_the_same_model_see_the_image_pixel_for_pixel() {
    let (w, h) = (32u32, 24u32);
    let mut rng = Pcg32::new(17, 2);
    let levels = [0.0f32, 0.25, 1.0];
    let values: Vec<f32> = (0..w * h).map(|_| levels[(rng.next_u32() % 3) as usize]).collect();
    let dir = std::env::temp_dir().join(format!("lucent-projector-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let img = Image::from_rgb(w, h, values.iter().map(|&v| [v, v, v]).collect()).unwrap();
    write_image(&dir.join("pattern.pfm"), &img, 0.0).unwrap();
    let (rho, i0, d) = (0.5f64, 3.0f64, 2.0f64);
    let cam = "model = \"opencv\", width = 32, height = 24, fx = 40.0, fy = 41.0, cx = 15.7, cy = 11.8, k1 = -0.05, p1 = 0.001, eye = [0, 0, 0], look_at = [0, 0, 1]";
    let text = plane_scene(cam, rho, d, "pattern.pfm", &format!("intensity = {i0}"));
    let s = Scene::from_toml_str(&text, "projector.toml", &dir).unwrap_or_else(|e| panic!("{e:#}"));
    std::fs::remove_dir_all(&dir).ok();
    let (m, se, lit) = mean_se(&s, 64, 4);
    let (mut worst, mut leaks) = (0.0f64, 0u32);
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            let g = pixel_geometry(&s, i, j, d);
            let want = rho / std::f64::consts::PI * values[k] as f64 * i0 * g * y_of_one();
            if values[k] == 0.0 {
                leaks += lit[k];
            } else {
                let z = (m[k] - want).abs() / (se[k] + 1e-4 * want);
                worst = worst.max(z);
            }
        }
    }
    eprintln!("projector: worst |Δ|/SE {worst:.2} over lit pixels, {leaks} lit samples in dark pixels");
    assert!(worst < 5.0, "projected image differs from ρ/π·v·I₀·cosθ/r² by {worst} standard errors");
    // A sample within about 1e-5 px of a pixel edge can land in the neighbouring projector pixel
    // through the f32 rounding of the ray (one such sample, 5e-6 px from the edge, in this run):
    // about one expected among the ~16 000 samples of the dark pixels. A misalignment of 0.001 px
    // would light about 0.1 % of them, some ten samples.
    assert!(leaks <= 2, "light leaks into dark pixels in {leaks} samples: the projection is misaligned");
}

#[test]
fn projector_irradiance_falls_with_inverse_square_and_cosine() {
    // A uniform image through a narrow pinhole projector colocated with a narrow camera: the
    // centre pixels see ρ/π · I₀ · cos α / D² on a plane at distance D tilted by α.
    let dir = std::env::temp_dir().join(format!("lucent-projector-falloff-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_image(&dir.join("white.pfm"), &Image::from_rgb(8, 8, vec![[1.0; 3]; 64]).unwrap(), 0.0).unwrap();
    let (rho, i0) = (0.8f64, 2.0f64);
    for (dist, alpha_deg) in [(1.0f64, 0.0f64), (2.0, 0.0), (2.0, 60.0)] {
        let (s_a, c_a) = alpha_deg.to_radians().sin_cos();
        // Plane through (0, 0, D) with normal (sin α, 0, −cos α).
        let corner = |u: f64, v: f64| [u * c_a, v, dist + u * s_a];
        let q: Vec<String> = [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)]
            .iter()
            .map(|&(u, v)| {
                let c = corner(u, v);
                format!("[{}, {}, {}]", c[0], c[1], c[2])
            })
            .collect();
        let text = format!(
            r#"
            camera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 2, width = 8, height = 8 }}
            [materials.white]
            type = "lambertian"
            albedo = {rho}
            [[objects]]
            material = "white"
            quad = [{}]
            [[lights]]
            type = "projector"
            image = "white.pfm"
            response = "linear"
            intensity = {i0}
            camera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 2 }}
            "#,
            q.join(", ")
        );
        let s = Scene::from_toml_str(&text, "falloff.toml", &dir).unwrap_or_else(|e| panic!("{e:#}"));
        let (m, se, _) = mean_se(&s, 256, 8);
        let centre = [27usize, 28, 35, 36];
        let got: f64 = centre.iter().map(|&k| m[k]).sum::<f64>() / 4.0;
        let err: f64 = (centre.iter().map(|&k| se[k] * se[k]).sum::<f64>()).sqrt() / 4.0;
        let want = rho / std::f64::consts::PI * i0 * c_a / (dist * dist) * y_of_one();
        eprintln!("projector at D = {dist}, α = {alpha_deg}°: {got:.5} ± {err:.5}, ρ/π·I₀·cosα/D² = {want:.5}");
        assert!((got - want).abs() < 5.0 * err + 2e-3 * want, "D = {dist}, α = {alpha_deg}: {got} vs {want}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn irradiance_profile_lights_a_perpendicular_plane_evenly() {
    // A 60° pinhole projector and a camera with the same model at the origin, a white plane at
    // z = D. Irradiance profile: E = π·v·I₀/cos³θ · cos θ / (D/cos θ)² = π·v·I₀/D² everywhere,
    // so Y = ρ·I₀/D² in every pixel. Intensity profile: E = I₀·cos³θ/D², averaged over the
    // pixel's footprint.
    let dir = std::env::temp_dir().join(format!("lucent-projector-profile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let n = 16usize;
    write_image(&dir.join("white.pfm"), &Image::from_rgb(n as u32, n as u32, vec![[1.0; 3]; n * n]).unwrap(), 0.0).unwrap();
    let (rho, i0, d) = (0.8f64, 2.0f64, 2.0f64);
    let f = (n as f64 / 2.0) / 30f64.to_radians().tan();
    // Mean of cos³θ over pixel (i, j), by a 32 × 32 midpoint rule in the pixel (film samples are
    // uniform over it).
    let cos3 = |i: usize, j: usize| -> f64 {
        let m = 32;
        let mut acc = 0.0;
        for a in 0..m {
            for b in 0..m {
                let x = (i as f64 + (a as f64 + 0.5) / m as f64 - n as f64 / 2.0) / f;
                let y = (j as f64 + (b as f64 + 0.5) / m as f64 - n as f64 / 2.0) / f;
                acc += (1.0 + x * x + y * y).powf(-1.5);
            }
        }
        acc / (m * m) as f64
    };
    for profile in ["irradiance", "intensity"] {
        let text = format!(
            r#"
            camera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 60, width = {n}, height = {n} }}
            [materials.white]
            type = "lambertian"
            albedo = {rho}
            [[objects]]
            material = "white"
            quad = [[-5, -5, {d}], [5, -5, {d}], [5, 5, {d}], [-5, 5, {d}]]
            [[lights]]
            type = "projector"
            image = "white.pfm"
            response = "linear"
            profile = "{profile}"
            intensity = {i0}
            camera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 60 }}
            "#
        );
        let s = Scene::from_toml_str(&text, "profile.toml", &dir).unwrap_or_else(|e| panic!("{e:#}"));
        let (m, se, _) = mean_se(&s, 64, 9);
        let mut worst = 0.0f64;
        for j in 0..n {
            for i in 0..n {
                let k = j * n + i;
                let want = match profile {
                    "irradiance" => rho * i0 / (d * d),
                    _ => rho / std::f64::consts::PI * i0 * cos3(i, j) / (d * d),
                } * y_of_one();
                let z = (m[k] - want).abs() / (se[k] + 2e-3 * want);
                worst = worst.max(z);
                assert!(z < 5.0, "{profile}: pixel ({i}, {j}) {} vs {want}", m[k]);
            }
        }
        eprintln!("{profile}: worst |Δ|/(SE + 0.2 %) {worst:.2}; corner / centre {:.3}", m[0] / m[(n / 2) * n + n / 2]);
    }
    // The projector's power in the irradiance profile: π · v · I₀ over the image plane at unit
    // distance, (2 tan 30°)² m².
    let s = Scene::from_toml_str(
        &format!(
            "camera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 60 }}\n[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nmaterial = \"m\"\nsphere = {{ center = [0, 0, 5], radius = 1 }}\n[[lights]]\ntype = \"projector\"\nimage = \"white.pfm\"\nresponse = \"linear\"\nprofile = \"irradiance\"\nintensity = 1\ncamera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 60 }}\n"
        ),
        "power.toml",
        &dir,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let render::light::Light::Projector(p) = &s.lights[0] else { panic!("not a projector") };
    let want = std::f64::consts::PI * (2.0 * 30f64.to_radians().tan()).powi(2);
    let got = p.weighted_solid_angle_sr as f64;
    assert!((got / want - 1.0).abs() < 1e-4, "weighted solid angle {got} vs π·A = {want}");
    // In the intensity profile, the solid angle of a 60° × 60° pyramid: 4 asin(sin² 30°).
    let q = (**p).clone().with_profile(render::light::projector::Profile::Intensity);
    let want = 4.0 * (30f64.to_radians().sin().powi(2)).asin();
    let got = q.weighted_solid_angle_sr as f64;
    assert!((got / want - 1.0).abs() < 1e-4, "solid angle {got} vs {want}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_projector_input_is_one_line_naming_the_field() {
    let dir = std::env::temp_dir().join(format!("lucent-projector-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_image(&dir.join("p.pfm"), &Image::from_rgb(4, 2, vec![[0.5; 3]; 8]).unwrap(), 0.0).unwrap();
    let base = "camera = { eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 40 }\n[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nmaterial = \"m\"\nsphere = { center = [0, 0, 5], radius = 1 }\n[[lights]]\ntype = \"projector\"\nintensity = 1\n";
    for (extra, want) in [
        ("image = \"p.pfm\"\nresponse = \"log\"\ncamera = { eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 40 }\n", "response"),
        ("image = \"missing.png\"\ncamera = { eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 40 }\n", "image"),
        ("image = \"p.pfm\"\ncamera = { eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 40, width = 8, height = 8 }\n", "camera"),
        ("image = \"p.pfm\"\n", "camera"),
        ("image = \"p.pfm\"\nprofile = \"radiance\"\ncamera = { eye = [0, 0, 0], look_at = [0, 0, 1], vfov_deg = 40 }\n", "profile"),
    ] {
        let e = Scene::from_toml_str(&format!("{base}{extra}"), "bad.toml", &dir).err().unwrap();
        let msg = format!("{e:#}");
        assert!(msg.starts_with("bad.toml:") && msg.contains(&format!("(projector).{want}")) && !msg.contains('\n'), "{msg}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A colour image: each pixel's linear RGB becomes an emission spectrum (the sigmoid uplift of
/// emitting textures) times the white I₀ = D65 of luminance 1, so a projector and a camera with the
/// same model see, on a white Lambertian plane, ρ/π · rgb · scale · cos θ / r² in every channel of
/// linear sRGB, components above 1 included; the pixels' order and colours survive the trip.
#[test]
fn colour_images_project_their_colours() {
    let (w, h) = (16u32, 12u32);
    let mut rng = Pcg32::new(23, 4);
    let palette = [[0.9f32, 0.2, 0.1], [0.1, 0.7, 0.3], [0.2, 0.3, 1.4], [0.5, 0.5, 0.5]];
    let values: Vec<[f32; 3]> = (0..w * h).map(|_| palette[(rng.next_u32() % 4) as usize]).collect();
    let dir = std::env::temp_dir().join(format!("lucent-projector-colour-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_image(&dir.join("colours.pfm"), &Image::from_rgb(w, h, values.clone()).unwrap(), 0.0).unwrap();
    let (rho, scale, d) = (0.5f64, 3.0f64, 2.0f64);
    let cam = "model = \"pinhole\", width = 16, height = 12, vfov_deg = 30, eye = [0, 0, 0], look_at = [0, 0, 1]";
    let text = plane_scene(cam, rho, d, "colours.pfm", &format!("intensity = {{ rgb = [1, 1, 1] }}\n        scale = {scale}"));
    let s = Scene::from_toml_str(&text, "projector.toml", &dir).unwrap_or_else(|e| panic!("{e:#}"));
    std::fs::remove_dir_all(&dir).ok();
    let n = (w * h) as usize;
    let st = settings(IntegratorKind::Direct, 2, 5);
    let passes = 256u64;
    let (mut s1, mut s2) = (vec![[0.0f64; 3]; n], vec![[0.0f64; 3]; n]);
    let mut buf = vec![[0.0f32; 3]; n];
    for pass in 0..passes {
        render_pass(&s, &st, 8, pass, &mut buf);
        for k in 0..n {
            let rgb = optics::color::xyz_to_linear_srgb(buf[k].map(|v| v as f64));
            for c in 0..3 {
                s1[k][c] += rgb[c];
                s2[k][c] += rgb[c] * rgb[c];
            }
        }
    }
    let mut worst = 0.0f64;
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            let g = pixel_geometry(&s, i, j, d);
            for c in 0..3 {
                let want = rho / std::f64::consts::PI * values[k][c] as f64 * scale * g;
                let mean = s1[k][c] / passes as f64;
                let se = ((s2[k][c] / passes as f64 - mean * mean).max(0.0) / (passes - 1) as f64).sqrt();
                // The uplift reproduces a colour to about 1e-3 of its largest component.
                let z = (mean - want).abs() / (se + 2e-3 * values[k].iter().cloned().fold(0.0, f32::max) as f64 * rho / std::f64::consts::PI * scale * g);
                worst = worst.max(z);
            }
        }
    }
    eprintln!("colour projector: worst |Δ|/(SE + uplift tolerance) {worst:.2}");
    assert!(worst < 5.0, "projected colours differ from ρ/π·rgb·cosθ/r² by {worst}");
}
