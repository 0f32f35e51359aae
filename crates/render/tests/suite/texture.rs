//! Textures: RGB uplift through the film's colour pipeline, texture coordinates of every shape
//! (an asymmetric image comes out the right way round), a textured Lambertian quad under a
//! uniform environment against the bilinearly filtered texels, emissive textures (seen directly,
//! and light sampling against direction sampling), and one-line errors.

#[allow(unused_imports)]
use crate::common::*;

use glam::{Vec2, Vec3};
use optics::uplift::{CoefficientTable, SigmoidSpectrum, TABLE_RES};
use render::bsdf::Bsdf;
use render::image_io::{write_image, Image};
use render::integrator::{render_pass, IntegratorKind};
use render::interaction::Shading;
use render::math::spectral::SampledWavelengths;
use render::scene::Scene;
use std::path::{Path, PathBuf};

/// Deterministic xorshift in [0, 1).
fn rng(seed: &mut u64) -> f64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// Linear sRGB of spectral radiance `f` as the film computes it (XYZ from the renderer's CIE
/// tables, then the sRGB matrix).
fn film_srgb(f: impl Fn(f64) -> f64) -> [f64; 3] {
    let xyz = render::math::spectral::xyz_of(|l| f(l as f64) as f32);
    optics::color::xyz_to_linear_srgb(xyz)
}

fn d65(l: f64) -> f64 {
    optics::spectrum::d65_normalized(l)
}

#[test]
fn uplifted_reflectances_and_illuminants_reproduce_their_rgb_through_the_film() {
    let mut seed = 0x1234_5678_9abc_def1u64;
    let (mut worst_r, mut worst_e) = (0.0f64, 0.0f64);
    for k in 0..400 {
        let mut rgb = [rng(&mut seed), rng(&mut seed), rng(&mut seed)];
        if k < 8 {
            // The cube's corners.
            rgb = [(k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64];
        }
        let r = SigmoidSpectrum::reflectance(rgb);
        for i in 0..=470 {
            let v = r.eval(360.0 + i as f64);
            assert!((0.0..=1.0).contains(&v), "{rgb:?} at {} nm: {v}", 360 + i);
        }
        let back = film_srgb(|l| r.eval(l) * d65(l));
        worst_r = (0..3).map(|c| (back[c] - rgb[c]).abs()).fold(worst_r, f64::max);
        // Illuminants up to 10 in radiance.
        let e_rgb = rgb.map(|c| 10.0 * c);
        let e = SigmoidSpectrum::illuminant(e_rgb);
        let back = film_srgb(|l| e.eval(l) * d65(l));
        let m = e_rgb.iter().cloned().fold(1e-12, f64::max);
        worst_e = (0..3).map(|c| (back[c] - e_rgb[c]).abs() / m).fold(worst_e, f64::max);
    }
    eprintln!("uplift through the film: reflectance worst |ΔRGB| {worst_r:.2e}, illuminant worst |ΔRGB|/max {worst_e:.2e}");
    assert!(worst_r < 1e-3 && worst_e < 1e-3, "{worst_r} {worst_e}");
    // White emission is D65 exactly, and the scalar scene uplift equals the texel uplift.
    let w = SigmoidSpectrum::illuminant([1.0, 1.0, 1.0]);
    assert!((w.eval(560.0) - 1.0).abs() < 1e-12);
    let scalar = optics::spectrum::RgbIlluminant::new([0.25, 0.3, 0.4]);
    let texel = SigmoidSpectrum::illuminant([0.25, 0.3, 0.4]);
    for l in (360..=830).step_by(10) {
        let l = l as f64;
        assert!((scalar.eval(l) - texel.eval(l) * d65(l)).abs() < 1e-6, "{l} nm");
    }
}

#[test]
fn coefficient_table_nodes_reproduce_their_colours() {
    let t = CoefficientTable::srgb();
    let mut worst = 0.0f64;
    for (l, zi, yi, xi) in [(0, TABLE_RES - 1, 3, 7), (1, TABLE_RES / 2, 0, TABLE_RES - 2), (2, 4, 11, 2), (0, 9, 9, 1), (1, TABLE_RES - 1, 0, 0)] {
        let rgb = t.node_rgb(l, zi, yi, xi);
        let c = t.node_coeffs(l, zi, yi, xi);
        let back = optics::spectrum::reflectance_to_linear_srgb(|lam| optics::spectrum::sigmoid_polynomial(c, lam));
        worst = (0..3).map(|k| (back[k] - rgb[k]).abs()).fold(worst, f64::max);
    }
    eprintln!("table nodes: worst |ΔRGB| {worst:.2e}");
    assert!(worst < 1e-3, "{worst}");
}

/// A temporary folder for the test's files.
fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lucent-texture-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A 4 × 2 image (4 columns, 2 rows; row 0 the top) of distinct colours.
fn asymmetric_image() -> Image {
    let rgb = vec![
        [0.9, 0.9, 0.1], [0.1, 0.9, 0.9], [0.9, 0.1, 0.1], [0.1, 0.9, 0.1],
        [0.5, 0.2, 0.7], [0.2, 0.2, 0.2], [0.1, 0.1, 0.9], [0.8, 0.8, 0.8],
    ];
    Image::from_rgb(4, 2, rgb).unwrap()
}

const CAMERA: &str = "[camera]\neye = [0, 0, 4]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nvfov_deg = 30\nwidth = 64\nheight = 64\n";

fn load(dir: &Path, text: &str) -> Result<Scene, String> {
    Scene::from_toml_str(text, "test.toml", dir).map_err(|e| format!("{e:#}"))
}

/// The texel (x, y) of the 4 × 2 image whose spectrum the surface point `p`, seen from the
/// camera, has (nearest at four wavelengths).
fn texel_seen(scene: &Scene, p: Vec3, img: &Image) -> (usize, usize) {
    let eye = Vec3::new(0.0, 0.0, 4.0);
    let ray = render::math::geometry::Ray { o: eye, d: (p - eye).normalize(), t_min: 0.0, t_max: f32::INFINITY };
    let hit = scene.accel.intersect(&ray).expect("the ray hits the object");
    let s = Shading::at(scene, &ray, &hit);
    assert!((s.p - p).length() < 1e-4, "the camera sees {p} at {}", s.p);
    let wl = SampledWavelengths::fixed([450.0, 520.0, 600.0, 650.0]);
    let mat = &scene.materials[scene.objects[s.object as usize].material as usize];
    let Bsdf::Diffuse { r } = mat.bsdf(&wl, s.uv(scene)) else { panic!("a lambertian material") };
    let mut best = (f32::INFINITY, (0, 0));
    for y in 0..2 {
        for x in 0..4 {
            let sp = SigmoidSpectrum::reflectance(img.get(x, y).map(|c| c as f64));
            let d: f32 = (0..4).map(|k| (sp.eval(wl.lambda_nm[k] as f64) as f32 - r[k]).abs()).sum();
            if d < best.0 {
                best = (d, (x as usize, y as usize));
            }
        }
    }
    assert!(best.0 < 1e-4, "the albedo seen at {p} is no texel's");
    best.1
}

#[test]
fn an_asymmetric_texture_reads_the_right_way_round_on_quads_obj_ply_and_spheres() {
    let dir = tmp_dir("orient");
    let img = asymmetric_image();
    write_image(&dir.join("tex.pfm"), &img, 0.0).unwrap();
    let img = render::texture::image::read_texture_image(&dir.join("tex.pfm"), render::texture::image::Encoding::Srgb).unwrap();
    // A square facing +z, seen straight on from +z: corners (±1, ±1, 0), uv (0, 0) bottom left.
    std::fs::write(
        dir.join("sq.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("sq.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float s\nproperty float t\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n-1 -1 0 0 0\n1 -1 0 1 0\n1 1 0 1 1\n-1 1 0 0 1\n3 0 1 2\n3 0 2 3\n",
    )
    .unwrap();
    let mat = "[materials.tex]\ntype = \"lambertian\"\nalbedo = { texture = \"tex.pfm\", wrap = \"clamp\" }\n";
    let light = "[[lights]]\ntype = \"environment\"\nradiance = 1\n";
    let flat_shapes = [
        "quad = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]",
        "mesh = \"sq.obj\"",
        "mesh = \"sq.ply\"",
    ];
    // Texel (x, y) (row 0 the top) has its centre at u = (x + ½)/4, v = 1 − (y + ½)/2.
    let centre = |x: usize, y: usize| Vec2::new((x as f32 + 0.5) / 4.0, 1.0 - (y as f32 + 0.5) / 2.0);
    for shape in flat_shapes {
        let scene = load(&dir, &format!("{CAMERA}{mat}[[objects]]\nmaterial = \"tex\"\n{shape}\n{light}")).unwrap();
        for ty in 0..2 {
            for tx in 0..4 {
                let uv = centre(tx, ty);
                let p = Vec3::new(2.0 * uv.x - 1.0, 2.0 * uv.y - 1.0, 0.0);
                assert_eq!(texel_seen(&scene, p, &img), (tx, ty), "{shape}: point {p}");
            }
        }
    }
    // Sphere seen from +z: u = 0.75 faces the camera and grows to the right, v = 1 at the top
    // (+y), so the image's right half (columns 2, 3) appears upright and unmirrored.
    let scene = load(&dir, &format!("{CAMERA}{mat}[[objects]]\nmaterial = \"tex\"\nsphere = {{ center = [0, 0, 0], radius = 1 }}\n{light}")).unwrap();
    for (tx, ty, where_) in [(2, 0, "upper left"), (3, 0, "upper right"), (2, 1, "lower left"), (3, 1, "lower right")] {
        let uv = centre(tx, ty);
        // Independently of the renderer: polar angle θ = π(1 − v) from +y, and the azimuth
        // 2πu about +y from +x towards −z.
        let (theta, phi) = (std::f32::consts::PI * (1.0 - uv.y), 2.0 * std::f32::consts::PI * uv.x);
        let p = Vec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin());
        let seen_x = p.x;
        assert!(p.z > 0.0 && (seen_x < 0.0) == (tx == 2) && (p.y > 0.0) == (ty == 0), "{where_}: {p}");
        assert_eq!(texel_seen(&scene, p, &img), (tx, ty), "sphere {where_}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Bilinear interpolation of `img` at `uv` with clamp wrap, written independently of the
/// renderer: texel centres at ((x + ½)/w, 1 − (y + ½)/h).
fn bilinear_rgb(img: &Image, uv: Vec2) -> [f64; 3] {
    let (w, h) = (img.width as f64, img.height as f64);
    let fx = uv.x as f64 * w - 0.5;
    let fy = (1.0 - uv.y as f64) * h - 0.5;
    let (x0, y0) = (fx.floor(), fy.floor());
    let (ax, ay) = (fx - x0, fy - y0);
    let px = |x: f64, y: f64| img.get(x.clamp(0.0, w - 1.0) as u32, y.clamp(0.0, h - 1.0) as u32);
    let mut out = [0.0; 3];
    for (dx, wx) in [(0.0, 1.0 - ax), (1.0, ax)] {
        for (dy, wy) in [(0.0, 1.0 - ay), (1.0, ay)] {
            let p = px(x0 + dx, y0 + dy);
            for c in 0..3 {
                out[c] += wx * wy * p[c] as f64;
            }
        }
    }
    out
}

#[test]
fn textured_lambertian_quad_under_a_uniform_environment_shows_its_texels() {
    let dir = tmp_dir("quad");
    let img = asymmetric_image();
    write_image(&dir.join("tex.exr"), &img, 0.0).unwrap();
    // The quad fills the view exactly: camera constant 2 at distance 2 sees a unit square.
    let (w, h) = (8u32, 4u32);
    let text = format!(
        "[camera]\neye = [0, 0, 2]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\ncamera_constant = 2\nwidth = {w}\nheight = {h}\n\
         [materials.tex]\ntype = \"lambertian\"\nalbedo = {{ texture = \"tex.exr\", wrap = \"clamp\" }}\n\
         [[objects]]\nmaterial = \"tex\"\nquad = [[-1, -0.5, 0], [1, -0.5, 0], [1, 0.5, 0], [-1, 0.5, 0]]\n\
         [[lights]]\ntype = \"environment\"\nradiance = {{ rgb = [1, 1, 1] }}\n[integrator]\ntype = \"path\"\nmax_depth = 2\n"
    );
    let scene = load(&dir, &text).unwrap();
    let settings = settings(IntegratorKind::Path, 2, 5);
    let n = (w * h) as usize;
    let passes = 400u64;
    let (mut sum, mut sum2) = (vec![[0.0f64; 3]; n], vec![[0.0f64; 3]; n]);
    let mut buf = vec![[0f32; 3]; n];
    for pass in 0..passes {
        render_pass(&scene, &settings, 7, pass, &mut buf);
        for (k, xyz) in buf.iter().enumerate() {
            let rgb = optics::color::xyz_to_linear_srgb(xyz.map(|v| v as f64));
            for c in 0..3 {
                sum[k][c] += rgb[c];
                sum2[k][c] += rgb[c] * rgb[c];
            }
        }
    }
    // Expected: the bilinearly filtered texels averaged over each pixel (64 × 64 sub-samples).
    let mut worst_z = 0.0f64;
    for j in 0..h {
        for i in 0..w {
            let mut e = [0.0; 3];
            let m = 64;
            for a in 0..m {
                for b in 0..m {
                    let u = (i as f64 + (a as f64 + 0.5) / m as f64) / w as f64;
                    let v = 1.0 - (j as f64 + (b as f64 + 0.5) / m as f64) / h as f64;
                    let p = bilinear_rgb(&img, Vec2::new(u as f32, v as f32));
                    for c in 0..3 {
                        e[c] += p[c] / (m * m) as f64;
                    }
                }
            }
            let k = (j * w + i) as usize;
            for c in 0..3 {
                let mean = sum[k][c] / passes as f64;
                let var = (sum2[k][c] / passes as f64 - mean * mean).max(0.0);
                let se = (var / passes as f64).sqrt().max(1e-4);
                let z = (mean - e[c]).abs() / se;
                worst_z = worst_z.max(z);
                assert!(z < 5.0, "pixel ({i}, {j}) channel {c}: {mean:.4} vs {:.4} (σ {se:.4})", e[c]);
            }
        }
    }
    eprintln!("textured quad: worst |render − texels| = {worst_z:.2} standard errors over {} pixel channels", 3 * n);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn texture_errors_are_one_line_and_name_the_field() {
    let dir = tmp_dir("errors");
    let good = asymmetric_image();
    write_image(&dir.join("ok.png"), &good, 0.0).unwrap();
    let mut nan = good.clone();
    nan.set(1, 0, [f32::NAN, 0.0, 0.0]);
    write_image(&dir.join("nan.pfm"), &nan, 0.0).unwrap();
    let mut neg = good.clone();
    neg.set(2, 1, [0.1, -0.5, 0.0]);
    write_image(&dir.join("neg.exr"), &neg, 0.0).unwrap();
    std::fs::write(dir.join("nouv.obj"), "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nf 1 2 3\n").unwrap();
    let scene = |albedo: &str, shape: &str| {
        format!("{CAMERA}[materials.m]\ntype = \"lambertian\"\nalbedo = {albedo}\n[[objects]]\nmaterial = \"m\"\n{shape}\n")
    };
    let quad = "quad = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]";
    let cases = [
        (scene("{ texture = \"missing.png\" }", quad), vec!["materials.m.albedo.texture", "missing.png"]),
        (scene("{ texture = \"nan.pfm\" }", quad), vec!["materials.m.albedo.texture", "texel (1, 0)"]),
        (scene("{ texture = \"neg.exr\" }", quad), vec!["materials.m.albedo.texture", "texel (2, 1)"]),
        (scene("{ texture = \"ok.png\", wrap = \"wobble\" }", quad), vec!["materials.m.albedo.wrap", "wobble", "mirror"]),
        (scene("{ texture = \"ok.png\" }", "mesh = \"nouv.obj\""), vec!["mesh", "no texture coordinates"]),
        (scene("{ texture = \"ok.png\", filter = 1 }", quad), vec!["materials.m.albedo", "filter"]),
        (scene("{ checkerboard = { squares = 0, even = 0.1, odd = 0.9 } }", quad), vec!["squares"]),
    ];
    for (text, needles) in cases {
        let e = load(&dir, &text).err().unwrap_or_else(|| panic!("expected an error for {needles:?}"));
        assert!(!e.contains('\n'), "not one line: {e}");
        for n in &needles {
            assert!(e.contains(n), "`{e}` does not mention `{n}`");
        }
        assert!(e.starts_with("test.toml:"), "{e}");
    }
    // Emission textures: the same checks, and an emitting mesh needs texture coordinates.
    let lamp = |radiance: &str, shape: &str| {
        format!("{CAMERA}[materials.k]\ntype = \"black\"\n[[objects]]\nname = \"lamp\"\nmaterial = \"k\"\n{shape}\n[[lights]]\ntype = \"area\"\nobject = \"lamp\"\nradiance = {radiance}\n")
    };
    let light_cases = [
        (lamp("{ texture = \"missing.png\" }", quad), vec!["lights[0] (area).radiance.texture", "missing.png"]),
        (lamp("{ texture = \"nan.pfm\" }", quad), vec!["lights[0] (area).radiance.texture", "texel (1, 0)"]),
        (lamp("{ texture = \"ok.png\", wrap = \"wobble\" }", quad), vec!["lights[0] (area).radiance.wrap", "wobble"]),
        (lamp("{ texture = \"ok.png\" }", "mesh = \"nouv.obj\""), vec!["lights[0] (area).radiance", "no texture coordinates"]),
    ];
    for (text, needles) in light_cases {
        let e = load(&dir, &text).err().unwrap_or_else(|| panic!("expected an error for {needles:?}"));
        assert!(!e.contains('\n') && e.starts_with("test.toml:"), "{e}");
        for n in &needles {
            assert!(e.contains(n), "`{e}` does not mention `{n}`");
        }
    }
    // A valid checkerboard: squares alternate, the origin's square is `even`.
    let s = load(&dir, &scene("{ checkerboard = { squares = 4, even = 0.1, odd = 0.9 } }", quad)).unwrap();
    let render::material::Material::Lambertian { albedo } = &s.materials[0] else { panic!() };
    let wl = SampledWavelengths::fixed([500.0; 4]);
    assert!((albedo.eval(&wl, Vec2::new(0.1, 0.1))[0] - 0.1).abs() < 1e-6);
    assert!((albedo.eval(&wl, Vec2::new(0.3, 0.1))[0] - 0.9).abs() < 1e-6);
    assert!((albedo.eval(&wl, Vec2::new(0.3, 0.3))[0] - 0.1).abs() < 1e-6);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn emissive_textured_quad_seen_straight_on_shows_its_texels() {
    let dir = tmp_dir("emit");
    let img = asymmetric_image();
    write_image(&dir.join("tex.exr"), &img, 0.0).unwrap();
    // The emitting quad fills the view exactly (camera constant 2 at distance 2), facing the
    // camera; a path sees its radiance directly, so the pixels are the texels' illuminant
    // spectra through the film: the texture's linear RGB, bilinearly filtered.
    let (w, h) = (8u32, 4u32);
    let text = format!(
        "[camera]\neye = [0, 0, 2]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\ncamera_constant = 2\nwidth = {w}\nheight = {h}\n\
         [materials.k]\ntype = \"black\"\n\
         [[objects]]\nname = \"screen\"\nmaterial = \"k\"\nquad = [[-1, -0.5, 0], [1, -0.5, 0], [1, 0.5, 0], [-1, 0.5, 0]]\n\
         [[lights]]\ntype = \"area\"\nobject = \"screen\"\nradiance = {{ texture = \"tex.exr\", wrap = \"clamp\" }}\n\
         [integrator]\ntype = \"path\"\nmax_depth = 2\n"
    );
    let scene = load(&dir, &text).unwrap();
    let settings = settings(IntegratorKind::Path, 2, 5);
    let n = (w * h) as usize;
    let passes = 200u64;
    let (mut sum, mut sum2) = (vec![[0.0f64; 3]; n], vec![[0.0f64; 3]; n]);
    let mut buf = vec![[0f32; 3]; n];
    for pass in 0..passes {
        render_pass(&scene, &settings, 11, pass, &mut buf);
        for (k, xyz) in buf.iter().enumerate() {
            let rgb = optics::color::xyz_to_linear_srgb(xyz.map(|v| v as f64));
            for c in 0..3 {
                sum[k][c] += rgb[c];
                sum2[k][c] += rgb[c] * rgb[c];
            }
        }
    }
    let mut worst_z = 0.0f64;
    for j in 0..h {
        for i in 0..w {
            let mut e = [0.0; 3];
            let m = 64;
            for a in 0..m {
                for b in 0..m {
                    let u = (i as f64 + (a as f64 + 0.5) / m as f64) / w as f64;
                    let v = 1.0 - (j as f64 + (b as f64 + 0.5) / m as f64) / h as f64;
                    let p = bilinear_rgb(&img, Vec2::new(u as f32, v as f32));
                    for c in 0..3 {
                        e[c] += p[c] / (m * m) as f64;
                    }
                }
            }
            let k = (j * w + i) as usize;
            for c in 0..3 {
                let mean = sum[k][c] / passes as f64;
                let var = (sum2[k][c] / passes as f64 - mean * mean).max(0.0);
                // The uplift reproduces an illuminant's RGB to 1e-3 of its largest component.
                let se = (var / passes as f64).sqrt() + 1e-3;
                let z = (mean - e[c]).abs() / se;
                worst_z = worst_z.max(z);
                assert!(z < 5.0, "pixel ({i}, {j}) channel {c}: {mean:.4} vs {:.4} (σ {se:.4})", e[c]);
            }
        }
    }
    eprintln!("emissive textured quad: worst |render − texels| = {worst_z:.2} (standard errors + 1e-3) over {} pixel channels", 3 * n);
    std::fs::remove_dir_all(&dir).ok();
}

/// Irradiance at `p` (normal +y) from the scene's one light, at the wavelengths `wl`, by three
/// estimators: light sampling alone, cosine-weighted direction sampling alone (rays traced to
/// the emitter, its radiance read where they hit), and the two combined by the power
/// heuristic with the light's `pdf_li`. Returns (mean, standard error) of each.
fn irradiance_three_ways(scene: &Scene, p: Vec3, wl: &SampledWavelengths, n: usize, seed: &mut u64) -> [([f64; 4], [f64; 4]); 3] {
    use render::math::geometry::Ray;
    let light = &scene.lights[0];
    let mut acc = [[(0.0f64, 0.0f64); 4]; 3];
    let mut add = |which: usize, v: glam::Vec4| {
        for k in 0..4 {
            acc[which][k].0 += v[k] as f64;
            acc[which][k].1 += (v[k] as f64).powi(2);
        }
    };
    let ny = Vec3::Y;
    for _ in 0..n {
        // Light sampling.
        let u = Vec2::new(rng(seed) as f32, rng(seed) as f32);
        let (mut e_l, mut e_lm) = (glam::Vec4::ZERO, glam::Vec4::ZERO);
        if let Some(ls) = light.sample_li(p, u, wl) {
            let cos = ls.wi.dot(ny);
            if cos > 0.0 && ls.pdf > 0.0 {
                let pdf_b = cos / std::f32::consts::PI;
                e_l = ls.li * (cos / ls.pdf);
                e_lm = e_l * (ls.pdf * ls.pdf / (ls.pdf * ls.pdf + pdf_b * pdf_b));
            }
        }
        // Cosine-weighted directions (Malley's method), written here independently.
        let (r1, r2) = (rng(seed), rng(seed));
        let (r, phi) = (r1.sqrt(), 2.0 * std::f64::consts::PI * r2);
        let d = Vec3::new((r * phi.cos()) as f32, (1.0 - r1).max(0.0).sqrt() as f32, (r * phi.sin()) as f32).normalize();
        let (mut e_b, mut e_bm) = (glam::Vec4::ZERO, glam::Vec4::ZERO);
        let ray = Ray { o: p, d, t_min: 1e-6, t_max: f32::INFINITY };
        if let Some(hit) = scene.accel.intersect(&ray) {
            let s = Shading::at(scene, &ray, &hit);
            if scene.objects[s.object as usize].light == Some(0) {
                let le = light.le(s.ng_raw, -d, || s.uv(scene), wl);
                let pdf_b = d.dot(ny) / std::f32::consts::PI;
                let pdf_l = light.pdf_li(p, d, s.p, s.ng_raw);
                e_b = le * std::f32::consts::PI;
                e_bm = e_b * (pdf_b * pdf_b / (pdf_b * pdf_b + pdf_l * pdf_l));
            }
        }
        add(0, e_l);
        add(1, e_b);
        add(2, e_lm + e_bm);
    }
    acc.map(|a| {
        let mean = a.map(|(s, _)| s / n as f64);
        let se = std::array::from_fn(|k| ((a[k].1 / n as f64 - mean[k] * mean[k]).max(0.0) / n as f64).sqrt());
        (mean, se)
    })
}

#[test]
fn textured_emitters_light_sampling_and_direction_sampling_agree() {
    let dir = tmp_dir("emit-mis");
    let img = asymmetric_image();
    write_image(&dir.join("tex.exr"), &img, 0.0).unwrap();
    // A quad facing down and a sphere, each textured with the asymmetric image, above a point
    // that sees them off-centre (so a mirrored or shifted texture would change the irradiance).
    let shapes = [
        "quad = [[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]]",
        "sphere = { center = [0.4, 1.2, -0.3], radius = 0.6 }",
    ];
    let wl = SampledWavelengths::fixed([450.0, 520.0, 600.0, 650.0]);
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for shape in shapes {
        let text = format!(
            "{CAMERA}[materials.k]\ntype = \"black\"\n[[objects]]\nname = \"lamp\"\nmaterial = \"k\"\n{shape}\n\
             [[lights]]\ntype = \"area\"\nobject = \"lamp\"\nradiance = {{ texture = \"tex.exr\", wrap = \"clamp\" }}\nscale = 3\n"
        );
        let scene = load(&dir, &text).unwrap();
        let p = Vec3::new(0.3, 0.0, 0.2);
        let [(ml, sl), (mb, sb), (mm, sm)] = irradiance_three_ways(&scene, p, &wl, 200_000, &mut seed);
        for k in 0..4 {
            let z_lb = (ml[k] - mb[k]).abs() / (sl[k] * sl[k] + sb[k] * sb[k]).sqrt();
            let z_mb = (mm[k] - mb[k]).abs() / (sm[k] * sm[k] + sb[k] * sb[k]).sqrt();
            eprintln!("{shape}: {} nm: light {:.5} ± {:.5}, directions {:.5} ± {:.5}, MIS {:.5} ± {:.5}", wl.lambda_nm[k], ml[k], sl[k], mb[k], sb[k], mm[k], sm[k]);
            assert!(ml[k] > 0.05, "no irradiance at {} nm", wl.lambda_nm[k]);
            assert!(z_lb < 5.0 && z_mb < 5.0, "{shape} at {} nm: light {} vs directions {} vs MIS {} ({z_lb:.1}, {z_mb:.1} σ)", wl.lambda_nm[k], ml[k], mb[k], mm[k]);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `wrap = "mirror"`: the tile beyond u = 1 is the image mirrored about that edge and the one
/// after it the image again (period 2), in u and in v, so a lookup at 1 + a equals one at 1 − a
/// and one at 2 + a one at a; an unknown mode's message lists the three.
#[test]
fn mirror_wrap_reflects_every_other_tile() {
    use render::texture::{image::FloatImage, Wrap};
    let img = render::image_io::Image::from_rgb(5, 3, (0..15).map(|i| [i as f32 * 0.06 + 0.01; 3]).collect()).unwrap();
    let t = FloatImage::new(&img, Wrap::Mirror, Vec2::ONE);
    for (a, v) in [(0.13f32, 0.41f32), (0.02, 0.9), (0.37, 0.05)] {
        let base = t.eval(Vec2::new(1.0 - a, v));
        assert!((t.eval(Vec2::new(1.0 + a, v)) - base).abs() < 1e-5);
        assert!((t.eval(Vec2::new(-1.0 + a, v)) - base).abs() < 1e-5);
        assert!((t.eval(Vec2::new(2.0 + a, v)) - t.eval(Vec2::new(a, v))).abs() < 1e-5);
        assert!((t.eval(Vec2::new(v, 1.0 + a)) - t.eval(Vec2::new(v, 1.0 - a))).abs() < 1e-5);
    }
    // Across the edge the texels meet without a jump: at the edge itself the edge texel.
    assert!((t.eval(Vec2::new(1.0, 0.5)) - 0.06 * 9.0 - 0.01).abs() < 1e-5, "{}", t.eval(Vec2::new(1.0, 0.5)));
    let dir = tmp_dir("mirror");
    write_image(&dir.join("tex.exr"), &img, 0.0).unwrap();
    let text = "[camera]\neye = [0, 0, 2]\nlook_at = [0, 0, 0]\nvfov_deg = 40\nwidth = 8\nheight = 8\n[materials.m]\ntype = \"lambertian\"\nalbedo = { texture = \"tex.exr\", wrap = \"wobble\" }\n[[objects]]\nmaterial = \"m\"\nquad = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]\n";
    let e = format!("{:#}", render::scene::Scene::from_toml_str(text, "w.toml", &dir).err().unwrap());
    assert!(e.contains("wrap") && e.contains("mirror"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `filter = "nearest"`: every point of a texel's square reads that texel exactly (u left to
/// right, v bottom to top, row 0 the top), with the wrap applied to the texel index, while
/// bilinear filtering blends neighbours off the centres and agrees at them; the scene key is
/// read and an unknown filter's message names both.
#[test]
fn nearest_filter_reads_the_texel_whose_square_holds_the_point() {
    use render::texture::{image::FloatImage, Filter, Wrap};
    let (w, h) = (5usize, 3usize);
    let value = |i: usize, j: usize| (j * w + i) as f32 * 0.06 + 0.01;
    let img = render::image_io::Image::from_rgb(w as u32, h as u32, (0..w * h).map(|k| [value(k % w, k / w); 3]).collect()).unwrap();
    let bil = FloatImage::new(&img, Wrap::Repeat, Vec2::ONE);
    let near = bil.clone().with_filter(Filter::Nearest);
    let mut rng = render::math::sampling::Pcg32::new(5, 1);
    for _ in 0..2000 {
        let (i, j) = ((rng.next_f32() * w as f32) as usize % w, (rng.next_f32() * h as f32) as usize % h);
        // A point strictly inside texel (i, j)'s square, in some tile.
        let (fx, fy) = (0.001 + 0.998 * rng.next_f32(), 0.001 + 0.998 * rng.next_f32());
        let tile = Vec2::new((rng.next_f32() * 6.0).floor() - 3.0, (rng.next_f32() * 6.0).floor() - 3.0);
        let uv = Vec2::new((i as f32 + fx) / w as f32, 1.0 - (j as f32 + fy) / h as f32) + tile;
        assert!((near.eval(uv) - value(i, j)).abs() < 1e-6, "texel ({i}, {j}) at {uv}: {}", near.eval(uv));
    }
    // At texel centres the two filters agree; a quarter texel off they do not.
    let c = Vec2::new(2.5 / w as f32, 1.0 - 1.5 / h as f32);
    assert!((bil.eval(c) - value(2, 1)).abs() < 1e-5 && (near.eval(c) - value(2, 1)).abs() < 1e-6);
    let off = c + Vec2::new(0.25 / w as f32, 0.0);
    assert!((near.eval(off) - value(2, 1)).abs() < 1e-6);
    assert!((bil.eval(off) - (0.75 * value(2, 1) + 0.25 * value(3, 1))).abs() < 1e-5);
    let dir = tmp_dir("nearest");
    write_image(&dir.join("tex.exr"), &img, 0.0).unwrap();
    let scene = |filter: &str| format!("[camera]\neye = [0, 0, 2]\nlook_at = [0, 0, 0]\nvfov_deg = 40\nwidth = 8\nheight = 8\n[materials.m]\ntype = \"lambertian\"\nalbedo = {{ texture = \"tex.exr\", filter = \"{filter}\" }}\n[[objects]]\nmaterial = \"m\"\nquad = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]\n");
    assert!(render::scene::Scene::from_toml_str(&scene("nearest"), "n.toml", &dir).is_ok());
    let e = format!("{:#}", render::scene::Scene::from_toml_str(&scene("cubic"), "n.toml", &dir).err().unwrap());
    assert!(e.contains("filter") && e.contains("nearest") && e.contains("bilinear"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
