//! Environment maps: the RGBE reader on hand-made files, the per-texel uplift against the scene
//! file's `rgb` emission, a constant map against the constant environment, a χ² test of the
//! sampling density against the documented luminance × sin θ cells, irradiance of a horizontal
//! Lambertian plane under a bright upper hemisphere (E = π L) by light sampling, BSDF sampling
//! and MIS, and the Mitsuba 3 orientation of a single bright texel under a rotation.

use crate::common::settings;
use glam::{Mat3, Vec3, Vec4};
use render::image_io::{decode_hdr, read_image, write_image, Image};
use render::integrator::{render_pass, IntegratorKind, IntegratorSettings};
use render::light::envmap::{luminance, texel_spectrum, EnvMap};
use render::light::Light;
use render::math::sampling::{cosine_hemisphere, uniform_sphere, Pcg32};
use render::math::spectral::{xyz_of, SampledWavelengths};
use render::scene::Scene;
use std::f64::consts::PI;
use std::path::PathBuf;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lucent-envmap-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) -> Image {
    let mut im = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            im.set(x, y, f(x, y));
        }
    }
    im
}

/// Y of normalised D65 as the renderer's colour tables give it (≈ 1).
fn y_d65() -> f64 {
    xyz_of(|l| optics::spectrum::d65_normalized(l as f64) as f32)[1]
}

/// Mean Y over the image per pass: (mean over passes, standard error).
fn render_mean_y(scene: &Scene, s: &IntegratorSettings, passes: u64, seed: u64) -> (f64, f64) {
    let (w, h) = scene.resolution();
    let mut buf = vec![[0.0f32; 3]; (w * h) as usize];
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for pass in 0..passes {
        render_pass(scene, s, seed, pass, &mut buf);
        let m = buf.iter().map(|p| p[1] as f64).sum::<f64>() / buf.len() as f64;
        s1 += m;
        s2 += m * m;
    }
    let m = s1 / passes as f64;
    (m, ((s2 / passes as f64 - m * m).max(0.0) / (passes - 1) as f64).sqrt())
}

fn load(dir: &std::path::Path, text: &str) -> Scene {
    Scene::from_toml_str(text, "envmap-test.toml", dir).unwrap_or_else(|e| panic!("{e:#}"))
}

/// Mean Y and its standard error over each of 4 × 4 blocks of the image, from `passes` passes of
/// `kind` to depth 2 (roulette off).
fn block_means(scene: &Scene, kind: IntegratorKind, seed: u64, passes: u64) -> Vec<(f64, f64)> {
    let (w, h) = scene.resolution();
    let s = settings(kind, 2, 100);
    let mut buf = vec![[0.0f32; 3]; (w * h) as usize];
    let mut acc = vec![(0.0f64, 0.0f64); 16];
    for pass in 0..passes {
        render_pass(scene, &s, seed, pass, &mut buf);
        let mut b = [0.0f64; 16];
        for (k, p) in buf.iter().enumerate() {
            let (x, y) = (k as u32 % w, k as u32 / w);
            b[(y * 4 / h * 4 + x * 4 / w) as usize] += p[1] as f64 / ((w * h / 16) as f64);
        }
        for (a, v) in acc.iter_mut().zip(b) {
            a.0 += v;
            a.1 += v * v;
        }
    }
    acc.iter()
        .map(|(s1, s2)| {
            let m = s1 / passes as f64;
            (m, ((s2 / passes as f64 - m * m).max(0.0) / (passes - 1) as f64).sqrt())
        })
        .collect()
}

fn env_light(scene: &Scene) -> &Light {
    &scene.lights[scene.environment.expect("scene has an environment") as usize]
}

#[test]
fn rgbe_reader_decodes_run_length_and_flat_scanlines() {
    // 8×2: row 0 run-length encoded, row 1 flat. Exponent 129 → 2^(129 − 136) = 1/128.
    let mut b = b"#?RADIANCE\n# made by hand\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n-Y 2 +X 8\n".to_vec();
    b.extend_from_slice(&[2, 2, 0, 8]);
    b.extend_from_slice(&[128 + 8, 128]); // R: run of 8 × 128
    b.extend_from_slice(&[8, 0, 16, 32, 48, 64, 80, 96, 112]); // G: 8 literals
    b.extend_from_slice(&[128 + 3, 64, 5, 1, 2, 3, 4, 5]); // B: run of 3 × 64, then 5 literals
    b.extend_from_slice(&[128 + 8, 129]); // E
    for x in 0..8u8 {
        b.extend_from_slice(&[10 * x, 255, 0, if x == 7 { 0 } else { 130 }]); // e = 130 → 1/64; e = 0 → black
    }
    let im = decode_hdr(&b).unwrap();
    assert_eq!((im.width, im.height), (8, 2));
    let g = [0.0, 16.0, 32.0, 48.0, 64.0, 80.0, 96.0, 112.0];
    let bl = [64.0, 64.0, 64.0, 1.0, 2.0, 3.0, 4.0, 5.0];
    for x in 0..8 {
        assert_eq!(im.get(x, 0), [1.0, g[x as usize] / 128.0, bl[x as usize] / 128.0], "pixel ({x}, 0)");
        let want = if x == 7 { [0.0; 3] } else { [10.0 * x as f32 / 64.0, 255.0 / 64.0, 0.0] };
        assert_eq!(im.get(x, 1), want, "pixel ({x}, 1)");
    }
    // Bottom-to-top files, and a width below 8 (always flat).
    let mut b = b"#?RGBE\n\n+Y 2 +X 1\n".to_vec();
    b.extend_from_slice(&[128, 0, 0, 129, 0, 128, 0, 129]);
    let im = decode_hdr(&b).unwrap();
    assert_eq!(im.get(0, 0), [0.0, 1.0, 0.0]); // the last scanline is the top row
    assert_eq!(im.get(0, 1), [1.0, 0.0, 0.0]);
    // Malformed input: one-line errors, no panic.
    for (bad, why) in [
        (b"P6\n".to_vec(), "not a Radiance"),
        (b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\0\0\0\0".to_vec(), "FORMAT"),
        (b"#?RADIANCE\n\n-Y 1 -X 1\n\0\0\0\0".to_vec(), "resolution"),
        (b"#?RADIANCE\n\n-Y 2 +X 1\n\0\0\0\0".to_vec(), "truncated"),
        ([b"#?RADIANCE\n\n-Y 1 +X 8\n".to_vec(), vec![2, 2, 0, 8, 0]].concat(), "run length"),
    ] {
        let e = format!("{:#}", decode_hdr(&bad).unwrap_err());
        assert!(e.contains(why) && !e.contains('\n'), "{e}");
    }
}

#[test]
fn rgbe_writer_round_trips_through_the_reader() {
    let dir = tmp_dir("rgbe");
    for (w, h) in [(37u32, 5u32), (4, 3)] {
        let im = image(w, h, |x, y| {
            let t = (x * 7 + y * 13) as f32;
            if x == 3 { [0.0; 3] } else if y == 1 { [2.5, 2.5, 2.5] } else { [1e-3 * t + 1e-4, 40.0 / (1.0 + t), 0.5 * (t * 0.37).sin().abs()] }
        });
        let p = dir.join(format!("rt{w}.hdr"));
        write_image(&p, &im, 0.0).unwrap();
        let back = read_image(&p).unwrap();
        assert_eq!((back.width, back.height), (w, h));
        for (a, b) in im.rgb.iter().zip(&back.rgb) {
            let m = a[0].max(a[1]).max(a[2]);
            for k in 0..3 {
                // 8-bit mantissa of the largest component: error ≤ 2⁻⁸ · 2 · max.
                assert!((a[k] - b[k]).abs() <= m / 128.0 + 1e-30, "{a:?} vs {b:?}");
            }
        }
    }
}

#[test]
fn texel_uplift_is_the_scene_files_rgb_emission() {
    let wl = SampledWavelengths::fixed([405.0, 487.5, 561.0, 700.0]);
    for rgb in [[0.5f32, 0.5, 0.5], [2.0, 0.3, 0.1], [0.0, 0.0, 7.0], [0.2, 1.0, 0.6]] {
        let t = texel_spectrum(rgb).eval(&wl);
        let r = optics::spectrum::RgbIlluminant::new(rgb.map(|c| c as f64));
        for k in 0..4 {
            let l = wl.lambda_nm[k] as f64;
            let want = r.eval(l) / optics::spectrum::d65_normalized(l);
            assert!((t[k] as f64 - want).abs() <= 1e-5 * want.abs().max(1e-3), "{rgb:?} at {l} nm: {} vs {want}", t[k]);
        }
    }
    assert_eq!(texel_spectrum([0.0; 3]).eval(&wl), Vec4::ZERO);
}

const SPHERE_SCENE: &str = r#"
[camera]
eye = [0, 0.3, -3]
look_at = [0, 0, 0]
vfov_deg = 40
width = 20
height = 20
[materials.grey]
type = "lambertian"
albedo = 0.6
[[objects]]
material = "grey"
sphere = { center = [0, 0, 0], radius = 0.8 }
"#;

#[test]
fn constant_map_renders_as_the_constant_environment() {
    let dir = tmp_dir("constant");
    write_image(&dir.join("grey.pfm"), &image(6, 3, |_, _| [0.5, 0.5, 0.5]), 0.0).unwrap();
    let map = load(&dir, &format!("{SPHERE_SCENE}\n[[lights]]\ntype = \"envmap\"\nfile = \"grey.pfm\"\nscale = 2.0\n"));
    let env = load(&dir, &format!("{SPHERE_SCENE}\n[[lights]]\ntype = \"environment\"\nradiance = {{ rgb = [1.0, 1.0, 1.0] }}\n"));
    // Same radiance in every direction, at any wavelengths.
    let mut rng = Pcg32::new(11, 1);
    for _ in 0..200 {
        let wl = SampledWavelengths::sample(rng.next_f32());
        let d = uniform_sphere(rng.next_2d());
        let (a, b) = (env_light(&map).le(Vec3::ZERO, -d, || glam::Vec2::ZERO, &wl), env_light(&env).le(Vec3::ZERO, -d, || glam::Vec2::ZERO, &wl));
        assert!((a - b).abs().max_element() <= 1e-5 * b.max_element(), "{a} vs {b} towards {d}");
    }
    // Same image mean within noise (different light sampling, so not the same samples).
    let s = settings(IntegratorKind::Path, 4, 100);
    let (m1, e1) = render_mean_y(&map, &s, 48, 5);
    let (m2, e2) = render_mean_y(&env, &s, 48, 6);
    let se = (e1 * e1 + e2 * e2).sqrt();
    eprintln!("constant map {m1:.4} ± {e1:.4}, environment {m2:.4} ± {e2:.4}");
    assert!((m1 - m2).abs() < 4.5 * se, "map {m1} ± {e1}, environment {m2} ± {e2}");
    assert!(se < 0.01 * m2, "noise too large for the test to mean anything: {se}");
}

/// The test's own model of the documented density: cell (i, j) between texel centres i, i+1 and
/// rows j, j+1 has probability ∝ mean corner luminance × (cos θ_j − cos θ_{j+1}).
fn cell_probabilities(im: &Image) -> Vec<f64> {
    let (w, h) = (im.width as usize, im.height as usize);
    let lum = |i: usize, j: usize| luminance(im.get((i % w) as u32, j as u32)) as f64;
    let mut p = Vec::new();
    for j in 0..h - 1 {
        let band = (PI * j as f64 / (h - 1) as f64).cos() - (PI * (j + 1) as f64 / (h - 1) as f64).cos();
        for i in 0..w {
            p.push(0.25 * (lum(i, j) + lum(i + 1, j) + lum(i, j + 1) + lum(i + 1, j + 1)) * band);
        }
    }
    let t: f64 = p.iter().sum();
    p.iter().map(|x| x / t).collect()
}

/// Image coordinates of a map-frame direction, Mitsuba 3's envmap convention written out.
fn mitsuba_uv(d: Vec3) -> (f64, f64) {
    let (x, y, z) = (d.x as f64, d.y as f64, d.z as f64);
    let u = x.atan2(-z) / (2.0 * PI);
    (if u < 0.0 { u + 1.0 } else { u }, y.clamp(-1.0, 1.0).acos() / PI)
}

#[test]
fn sampling_density_follows_the_map_chi_square() {
    let (w, h) = (16u32, 9u32);
    // A patchy map: a smooth gradient, a bright blob and a black stripe.
    let im = image(w, h, |x, y| {
        let base = 0.2 + 0.1 * ((x as f32 * 0.7).sin() + 1.0) * (y as f32 + 1.0);
        let blob = if (5..8).contains(&x) && (2..4).contains(&y) { 20.0 } else { 0.0 };
        if x == 12 { [0.0; 3] } else { [base + blob, 0.5 * base, 0.2 * base + blob] }
    });
    let rot = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, -0.2).normalize(), 1.1);
    let map = EnvMap::new(&im, 1.0, rot).unwrap();
    let light = Light::EnvMap(std::sync::Arc::new(map));
    let probs = cell_probabilities(&im);
    let n = 400_000usize;
    let mut counts = vec![0u64; probs.len()];
    let mut rng = Pcg32::new(2024, 7);
    let wl = SampledWavelengths::fixed([450.0, 520.0, 580.0, 640.0]);
    for _ in 0..n {
        let Some(ls) = light.sample_li(Vec3::ZERO, rng.next_2d(), &wl) else { continue };
        // The density reported with the sample is the one pdf_li gives for it.
        let pdf = light.pdf_li(Vec3::ZERO, ls.wi, Vec3::ZERO, Vec3::ZERO);
        assert!((pdf / ls.pdf - 1.0).abs() < 2e-3, "{pdf} vs {}", ls.pdf);
        let (u, v) = mitsuba_uv(rot.transpose() * ls.wi);
        let up = (u - 0.5 / w as f64).rem_euclid(1.0);
        let i = ((up * w as f64) as usize).min(w as usize - 1);
        let j = ((v * (h - 1) as f64) as usize).min(h as usize - 2);
        counts[j * w as usize + i] += 1;
    }
    let mut chi2 = 0.0;
    let mut dof = 0usize;
    for (c, p) in counts.iter().zip(&probs) {
        let e = p * n as f64;
        if e == 0.0 {
            assert_eq!(*c, 0, "a sample landed in a cell of zero density");
            continue;
        }
        chi2 += (*c as f64 - e).powi(2) / e;
        dof += 1;
    }
    let k = (dof - 1) as f64;
    // Wilson–Hilferty 0.999 quantile of χ²_k.
    let q = k * (1.0 - 2.0 / (9.0 * k) + 3.09 * (2.0 / (9.0 * k)).sqrt()).powi(3);
    eprintln!("envmap χ² = {chi2:.1}, {k} dof, 0.999 quantile {q:.1}");
    assert!(chi2 < q, "χ² = {chi2} with {k} degrees of freedom (0.999 quantile {q})");
    // The density integrates to 1 over the sphere (uniform directions: E[4π pdf] = 1).
    let m = 200_000;
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..m {
        let v = 4.0 * PI * light.pdf_li(Vec3::ZERO, uniform_sphere(rng.next_2d()), Vec3::ZERO, Vec3::ZERO) as f64;
        s1 += v;
        s2 += v * v;
    }
    let mean = s1 / m as f64;
    let se = ((s2 / m as f64 - mean * mean) / m as f64).sqrt();
    assert!((mean - 1.0).abs() < 4.5 * se, "∫ pdf dω = {mean} ± {se}");
}

const PLANE_SCENE: &str = r#"
[camera]
eye = [0, 1, 0]
look_at = [0, 0, 0]
up = [0, 0, 1]
vfov_deg = 20
width = 16
height = 16
[materials.grey]
type = "lambertian"
albedo = 0.5
[[objects]]
material = "grey"
quad = [[-10, 0, -10], [-10, 0, 10], [10, 0, 10], [10, 0, -10]]
[[lights]]
type = "envmap"
file = "hemi.pfm"
scale = 3.0
"#;

#[test]
fn bright_upper_hemisphere_gives_pi_l_by_light_bsdf_and_mis_sampling() {
    // Rows j ≤ 4 of 9 (θ ≤ π/2, the horizon row at exactly 90°) white, the rest black: radiance
    // L = 3 × D65 above the horizon, so a horizontal plane facing up receives E = π L and a
    // Lambertian albedo ρ = 0.5 shows ρ L, Y = 1.5 Y(D65).
    let dir = tmp_dir("hemi");
    write_image(&dir.join("hemi.pfm"), &image(8, 9, |_, y| if y <= 4 { [1.0; 3] } else { [0.0; 3] }), 0.0).unwrap();
    let scene = load(&dir, PLANE_SCENE);
    let want = 1.5 * y_d65();
    for (kind, depth) in [(IntegratorKind::Direct, 2), (IntegratorKind::Path, 2), (IntegratorKind::Volpath, 2), (IntegratorKind::Path, 6)] {
        let (m, se) = render_mean_y(&scene, &settings(kind, depth, 100), 64, 3);
        eprintln!("hemisphere plane {kind:?} depth {depth}: Y = {m:.4} ± {se:.4}, analytic {want:.4}");
        assert!((m - want).abs() < 4.5 * se && se < 0.015 * want, "{kind:?} depth {depth}: {m} ± {se} vs {want}");
    }
    // BSDF sampling alone: cosine-distributed directions, f cos / pdf = ρ, so Y = ρ E[Y(L)].
    let light = env_light(&scene);
    let mut rng = Pcg32::new(9, 2);
    let n = 100_000;
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let wl = SampledWavelengths::sample(rng.next_f32());
        let c = cosine_hemisphere(rng.next_2d());
        let wi = Vec3::new(c.x, c.z, c.y); // around +y
        let y = 0.5 * wl.to_xyz(light.le(Vec3::ZERO, -wi, || glam::Vec2::ZERO, &wl))[1] as f64;
        s1 += y;
        s2 += y * y;
    }
    let m = s1 / n as f64;
    let se = ((s2 / n as f64 - m * m) / n as f64).sqrt();
    eprintln!("hemisphere plane BSDF sampling: Y = {m:.4} ± {se:.4}, analytic {want:.4}");
    assert!((m - want).abs() < 4.5 * se, "BSDF sampling: {m} ± {se} vs {want}");
}

#[test]
fn light_sampling_alone_matches_mis_on_a_patchy_map() {
    // A sphere under a map with a small bright patch: `direct` (light sampling only) and `path`
    // to depth 2 (light and BSDF sampling, MIS) estimate the same direct illumination, compared
    // over 4 × 4 blocks of the image.
    let dir = tmp_dir("patch");
    write_image(&dir.join("patch.pfm"), &image(32, 17, |x, y| {
        if (20..22).contains(&x) && (4..6).contains(&y) { [400.0, 300.0, 200.0] } else { [0.05 + 0.01 * y as f32, 0.05, 0.08] }
    }), 0.0).unwrap();
    let scene = load(&dir, &format!("{SPHERE_SCENE}\n[[lights]]\ntype = \"envmap\"\nfile = \"patch.pfm\"\ntransform = {{ rotate = [0, 1, 0, 200] }}\n"));
    let light_only = block_means(&scene, IntegratorKind::Direct, 1, 96);
    let mis = block_means(&scene, IntegratorKind::Path, 2, 96);
    let mut lit = 0;
    for (k, ((a, ea), (b, eb))) in light_only.iter().zip(&mis).enumerate() {
        let se = (ea * ea + eb * eb).sqrt();
        assert!((a - b).abs() < 4.5 * se + 1e-9, "block {k}: light sampling {a} ± {ea}, MIS {b} ± {eb}");
        if *b > 1.0 {
            lit += 1;
        }
    }
    eprintln!("patchy map blocks (light only, MIS): {:?}", light_only.iter().zip(&mis).map(|(a, b)| (a.0 as f32, b.0 as f32)).collect::<Vec<_>>());
    assert!(lit >= 2, "the patch lights too little of the sphere to test anything: {mis:?}");
}

#[test]
fn a_single_bright_texel_lights_the_plane_facing_it_mitsuba_orientation() {
    let (w, h) = (16u32, 9u32);
    let (ti, tj) = (5u32, 3u32);
    let dir = tmp_dir("texel");
    write_image(&dir.join("texel.pfm"), &image(w, h, |x, y| if (x, y) == (ti, tj) { [100.0; 3] } else { [0.0; 3] }), 0.0).unwrap();
    // Mitsuba 3: texel (i, j) sits at u = (i + ½)/W, v = j/(H − 1); d = (sin φ sin θ, cos θ, −cos φ sin θ).
    let (phi, theta) = (2.0 * PI * (ti as f64 + 0.5) / w as f64, PI * tj as f64 / (h - 1) as f64);
    let d = Vec3::new((phi.sin() * theta.sin()) as f32, theta.cos() as f32, (-phi.cos() * theta.sin()) as f32);
    let (axis, angle_deg) = (Vec3::new(1.0, 0.5, 0.2), 70.0f32);
    let n = Mat3::from_axis_angle(axis.normalize(), angle_deg.to_radians()) * d;
    let scene_text = |eye: Vec3| {
        let t = Vec3::new(-n.z, 0.0, n.x).normalize(); // a tangent of the plane
        let b = n.cross(t);
        let q = |a: f32, c: f32| { let p = t * a + b * c; format!("[{}, {}, {}]", p.x, p.y, p.z) };
        format!(
            "[camera]\neye = [{}, {}, {}]\nlook_at = [0, 0, 0]\nup = [{}, {}, {}]\nvfov_deg = 10\nwidth = 8\nheight = 8\n\
             [materials.grey]\ntype = \"lambertian\"\nalbedo = 0.5\n\
             [[objects]]\nmaterial = \"grey\"\nquad = [{}, {}, {}, {}]\n\
             [[lights]]\ntype = \"envmap\"\nfile = \"texel.pfm\"\ntransform = {{ rotate = [{}, {}, {}, {}] }}\n",
            eye.x, eye.y, eye.z, t.x, t.y, t.z, q(-10.0, -10.0), q(10.0, -10.0), q(10.0, 10.0), q(-10.0, 10.0),
            axis.x, axis.y, axis.z, angle_deg
        )
    };
    let facing = load(&dir, &scene_text(n * 2.0));
    // The full texel value arrives from the rotated texel direction.
    let wl = SampledWavelengths::fixed([450.0, 520.0, 580.0, 640.0]);
    let d65 = Vec4::from_array(wl.lambda_nm.map(|l| optics::spectrum::d65_normalized(l as f64) as f32));
    let le = env_light(&facing).le(Vec3::ZERO, -n, || glam::Vec2::ZERO, &wl);
    assert!((le - d65 * 100.0).abs().max_element() < 1e-3 * 100.0 * d65.max_element(), "{le} vs {}", d65 * 100.0);
    // Irradiance from the bilinear footprint (tent of one texel in u and in v), by quadrature
    // over the footprint: E = ∫ L cos dω, dω = 2π² sin θ du dv.
    let (du, dv) = (1.0 / w as f64, 1.0 / (h - 1) as f64);
    let (u0, v0) = ((ti as f64 + 0.5) * du, tj as f64 * dv);
    let k = 200;
    let mut e = 0.0;
    for a in 0..k {
        for c in 0..k {
            let u = u0 + du * (2.0 * (a as f64 + 0.5) / k as f64 - 1.0);
            let v = v0 + dv * (2.0 * (c as f64 + 0.5) / k as f64 - 1.0);
            let tent = (1.0 - ((u - u0) / du).abs()) * (1.0 - ((v - v0) / dv).abs());
            let (p, t) = (2.0 * PI * u, PI * v);
            let dir = glam::DVec3::new(p.sin() * t.sin(), t.cos(), -p.cos() * t.sin());
            let cos = dir.dot(d.as_dvec3()).max(0.0);
            e += 100.0 * tent * cos * 2.0 * PI * PI * t.sin() * (2.0 * du / k as f64) * (2.0 * dv / k as f64);
        }
    }
    let want = 0.5 / PI * e * y_d65();
    let (m, se) = render_mean_y(&facing, &settings(IntegratorKind::Direct, 2, 100), 64, 4);
    eprintln!("single texel, light sampling: {m:.5} ± {se:.5}, quadrature {want:.5}");
    assert!((m - want).abs() < 4.5 * se && se < 0.02 * want, "facing the texel: {m} ± {se} vs {want}");
    let (m, se) = render_mean_y(&facing, &settings(IntegratorKind::Path, 2, 100), 64, 5);
    eprintln!("single texel, MIS: {m:.5} ± {se:.5}, quadrature {want:.5}");
    assert!((m - want).abs() < 4.5 * se, "facing the texel, MIS: {m} ± {se} vs {want}");
    // Seen from the other side, the plane faces away from the texel and stays black.
    let away = load(&dir, &scene_text(-n * 2.0));
    let (m, _) = render_mean_y(&away, &settings(IntegratorKind::Path, 3, 100), 8, 6);
    assert_eq!(m, 0.0);
}

#[test]
fn bad_envmap_input_is_one_line_naming_the_field() {
    let dir = tmp_dir("bad");
    write_image(&dir.join("ok.pfm"), &image(4, 2, |_, _| [1.0; 3]), 0.0).unwrap();
    write_image(&dir.join("nan.pfm"), &image(4, 2, |x, _| if x == 2 { [f32::NAN, 0.0, 0.0] } else { [1.0; 3] }), 0.0).unwrap();
    write_image(&dir.join("neg.pfm"), &image(4, 2, |x, _| if x == 1 { [-1.0, 0.0, 0.0] } else { [1.0; 3] }), 0.0).unwrap();
    for (light, field) in [
        ("file = \"missing.hdr\"", "lights[0] (envmap).file"),
        ("file = \"nan.pfm\"", "lights[0] (envmap).file"),
        ("file = \"neg.pfm\"", "lights[0] (envmap).file"),
        ("", "lights[0] (envmap).file"),
        ("file = \"ok.pfm\"\ntransform = { scale = 2 }", "lights[0] (envmap).transform"),
        ("file = \"ok.pfm\"\npower_w = 3", "lights[0] (envmap).power_w"),
        ("file = \"ok.pfm\"\nradiance = 1", "lights[0] (envmap).radiance"),
    ] {
        let text = format!("{SPHERE_SCENE}\n[[lights]]\ntype = \"envmap\"\n{light}\n");
        let e = format!("{:#}", Scene::from_toml_str(&text, "bad.toml", &dir).err().unwrap_or_else(|| panic!("accepted: {light}")));
        assert!(e.contains(field) && !e.contains('\n'), "{light}: {e}");
    }
    let text = format!("{SPHERE_SCENE}\n[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = 1\nfile = \"ok.pfm\"\n");
    let e = format!("{:#}", Scene::from_toml_str(&text, "bad.toml", &dir).err().unwrap());
    assert!(e.contains("lights[0] (point).file"), "{e}");
}

#[test]
fn a_constant_environment_and_a_map_add_up() {
    // Two emitters at infinity (pbrt-v4 allows several): the image of a sphere under a patchy
    // map and a constant environment together is the sum of its images under each alone, by
    // light sampling alone (`direct`: the mixture of the map's distribution and the uniform one)
    // and with MIS (`path`), over 4 × 4 blocks; the mixture's density is what `sample` returns and
    // integrates to 1 over the sphere.
    let dir = tmp_dir("ambient");
    write_image(&dir.join("patch.pfm"), &image(32, 17, |x, y| {
        if (20..22).contains(&x) && (4..6).contains(&y) { [200.0, 150.0, 100.0] } else { [0.05 + 0.01 * y as f32, 0.05, 0.08] }
    }), 0.0).unwrap();
    let map = "[[lights]]\ntype = \"envmap\"\nfile = \"patch.pfm\"\ntransform = { rotate = [0, 1, 0, 200] }\n";
    let constant = "[[lights]]\ntype = \"environment\"\nradiance = 0.4\n";
    let both = load(&dir, &format!("{SPHERE_SCENE}\n{constant}{map}"));
    let both_other_order = load(&dir, &format!("{SPHERE_SCENE}\n{map}{constant}"));
    let map_only = load(&dir, &format!("{SPHERE_SCENE}\n{map}"));
    let constant_only = load(&dir, &format!("{SPHERE_SCENE}\n{constant}"));
    assert_eq!(both.lights.len(), 1, "the two merge into one light");
    // The density: sample/pdf agreement and the normalisation E_uniform[4π p] = 1.
    let Light::EnvMap(m) = env_light(&both) else { panic!("an envmap") };
    assert!(m.ambient().is_some());
    let mut rng = Pcg32::new(5, 9);
    let (mut s1, n) = (0.0f64, 200_000);
    for _ in 0..n {
        s1 += 4.0 * PI * m.pdf(uniform_sphere(rng.next_2d())) as f64;
        if let Some((d, p)) = m.sample(rng.next_2d()) {
            assert!((p / m.pdf(d) - 1.0).abs() < 1e-3, "sample pdf {p} vs pdf {}", m.pdf(d));
        }
    }
    assert!((s1 / n as f64 - 1.0).abs() < 0.02, "∫ p dω = {}", s1 / n as f64);
    let blocks = |scene: &Scene, kind: IntegratorKind, seed: u64| block_means(scene, kind, seed, 64);
    for kind in [IntegratorKind::Direct, IntegratorKind::Path] {
        let (a, b, c, d) = (blocks(&map_only, kind, 1), blocks(&constant_only, kind, 2), blocks(&both, kind, 3), blocks(&both_other_order, kind, 4));
        for k in 0..16 {
            let sum = a[k].0 + b[k].0;
            for (name, x) in [("map + constant", c[k]), ("constant + map", d[k])] {
                let se = (a[k].1.powi(2) + b[k].1.powi(2) + x.1.powi(2)).sqrt();
                assert!((x.0 - sum).abs() < 4.5 * se + 1e-9, "{kind:?} block {k} {name}: {} ± {} vs {sum} ± {}", x.0, x.1, (a[k].1.powi(2) + b[k].1.powi(2)).sqrt());
            }
        }
    }
    // Two of the same kind stay an error.
    let twice = Scene::from_toml_str(&format!("{SPHERE_SCENE}\n{constant}{constant}"), "t.toml", &dir).err().map(|e| format!("{e:#}")).unwrap_or_default();
    assert!(twice.contains("at most one environment and one envmap") && !twice.contains('\n'), "{twice}");
    std::fs::remove_dir_all(&dir).ok();
}
