//! Blend materials (Mitsuba 3's `blendbsdf`): a blend of two Lambertian albedos under a
//! directional light gives the weighted albedo's Lambert radiance; a weight texture that is 0 on
//! one half and 1 on the other shows each material alone on its half; the choice of component per
//! shading point is uniform; errors are one line. Mitsuba 3.9.1's `blendbsdf` is compared in
//! `benches-peers/mitsuba_normalmap.py`.

#[allow(unused_imports)]
use crate::common::*;

use glam::Vec3;
use render::image_io::{write_image, Image};
use render::scene::Scene;
use std::f64::consts::PI;

fn parts(ra: f64, rb: f64) -> String {
    format!("\n[materials.pa]\ntype = \"lambertian\"\nalbedo = {ra}\n[materials.pb]\ntype = \"lambertian\"\nalbedo = {rb}\n")
}

#[test]
fn a_blend_of_two_albedos_reflects_their_weighted_mean() {
    let dir = tmp_dir("blend-mean");
    let (ra, rb, w, e) = (0.2, 0.8, 0.3, 2.0);
    let l = Vec3::new(0.3, 0.2, 0.9).normalize();
    let text = quad_scene(Vec3::new(0.2, -0.1, 4.0), &format!("type = \"blend\"\nmaterials = [\"pa\", \"pb\"]\nweight = {w}"), &directional(l, e)) + &parts(ra, rb);
    let (m, se) = pixels(&load_in(&dir, &text));
    let expect = ((1.0 - w) * ra + w * rb) / PI * e * l.z as f64 * y_of_one();
    assert!((m - expect).abs() < 4.0 * se + 1e-6, "{m} ± {se} vs {expect}");
    // Either component alone is far off: the test tells the weights apart.
    for r in [ra, rb, 0.5 * (ra + rb)] {
        assert!((m - r / PI * e * l.z as f64 * y_of_one()).abs() > 10.0 * se, "indistinguishable from albedo {r}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_zero_one_weight_texture_shows_each_material_on_its_half() {
    // Weight 0 on the left half of the quad (u < ½), 1 on the right: the left shows pa alone,
    // the right pb alone (a weight of 0 or 1 leaves no choice to chance).
    let dir = tmp_dir("blend-halves");
    let (ra, rb, e) = (0.25, 0.7, 1.5);
    let rgb = (0..2).flat_map(|_| (0..8).map(|i| if i < 4 { [0.0f32; 3] } else { [1.0; 3] })).collect();
    write_image(&dir.join("w.pfm"), &Image::from_rgb(8, 2, rgb).unwrap(), 0.0).unwrap();
    let l = Vec3::new(-0.2, 0.1, 0.95).normalize();
    let text = quad_scene(Vec3::new(0.0, 0.0, 4.0), "type = \"blend\"\nmaterials = [\"pa\", \"pb\"]\nweight = { texture = \"w.pfm\", filter = \"nearest\" }", &directional(l, e))
        .replace("vfov_deg = 8", "vfov_deg = 20")
        + &parts(ra, rb);
    let s = load_in(&dir, &text);
    let (w, h) = s.resolution();
    let mut buf = vec![[0f32; 3]; (w * h) as usize];
    let passes = 64;
    let mut means = [Vec::new(), Vec::new()];
    for p in 0..passes {
        render::integrator::render_pass(&s, &s.integrator, 5, p, &mut buf);
        let (mut sum, mut count) = ([0.0f64; 2], [0usize; 2]);
        for y in 0..h {
            for x in 0..w {
                // Pixels (and their filter's reach) whole on one side of the quad's u = ½.
                let side = if x + 2 < w / 2 { 0 } else if x > w / 2 + 1 { 1 } else { continue };
                sum[side] += buf[(y * w + x) as usize][1] as f64;
                count[side] += 1;
            }
        }
        for k in 0..2 {
            means[k].push(sum[k] / count[k] as f64);
        }
    }
    let lam = |r: f64| r / PI * e * l.z as f64 * y_of_one();
    for (side, r) in [(0, ra), (1, rb)] {
        let v = &means[side];
        let m = v.iter().sum::<f64>() / passes as f64;
        let se = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / ((passes - 1) * passes) as f64).sqrt();
        assert!(se < 3e-3 * m, "side {side}: too noisy ({se})");
        assert!((m - lam(r)).abs() < 4.0 * se + 1e-6, "side {side}: {m} ± {se} vs {}", lam(r));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_component_choice_is_uniform_over_shading_points() {
    // The fraction of shading points where a blend of weight w picks `b` is w within its
    // binomial standard error, over the points a camera's rays find on a sphere.
    let s = scene(
        r#"
        [camera]
        eye = [0, 0, 4]
        look_at = [0, 0, 0]
        vfov_deg = 30
        width = 200
        height = 200
        [materials.m]
        type = "lambertian"
        albedo = 0.5
        [[objects]]
        material = "m"
        sphere = { center = [0, 0, 0], radius = 1 }
        "#,
    );
    let w = 0.3f32;
    let (mut n, mut below) = (0usize, 0usize);
    for j in 0..200 {
        for i in 0..200 {
            let d = Vec3::new((i as f32 - 99.5) / 400.0, (j as f32 - 99.5) / 400.0, -1.0).normalize();
            let ray = render::math::geometry::Ray { o: Vec3::new(0.0, 0.0, 4.0), d, t_min: 0.0, t_max: f32::INFINITY };
            let Some(hit) = s.accel.intersect(&ray) else { continue };
            let u = render::interaction::Shading::at(&s, &ray, &hit).selector(-d);
            assert!((0.0..1.0).contains(&u));
            n += 1;
            below += (u < w) as usize;
        }
    }
    let f = below as f64 / n as f64;
    let se = (w as f64 * (1.0 - w as f64) / n as f64).sqrt();
    assert!(n > 10_000 && (f - w as f64).abs() < 4.0 * se, "{f} of {n} points vs {w} ± {se}");
}

#[test]
fn blend_errors_are_one_line_and_name_the_field() {
    let dir = tmp_dir("blend-errors");
    let base = |m: &str, extra: &str| quad_scene(Vec3::new(0.0, 0.0, 4.0), m, &directional(Vec3::Z, 1.0)) + &parts(0.2, 0.8) + extra;
    for (mat, extra, needles) in [
        ("type = \"blend\"\nweight = 0.5", "", vec!["materials.m.materials", "missing"]),
        ("type = \"blend\"\nmaterials = [\"pa\"]\nweight = 0.5", "", vec!["materials.m.materials", "exactly two"]),
        ("type = \"blend\"\nmaterials = [\"pa\", \"nope\"]\nweight = 0.5", "", vec!["materials.m.materials", "unknown material", "nope"]),
        ("type = \"blend\"\nmaterials = [\"pa\", \"pb\"]", "", vec!["materials.m.weight", "missing"]),
        ("type = \"blend\"\nmaterials = [\"pa\", \"pb\"]\nweight = 1.5", "", vec!["materials.m.weight", "[0, 1]"]),
        ("type = \"blend\"\nmaterials = [\"pa\", \"m\"]\nweight = 0.5", "", vec!["materials.m.materials", "plain materials"]),
        ("type = \"blend\"\nmaterials = [\"pa\", \"pc\"]\nweight = 0.5", "[materials.pc]\ntype = \"lambertian\"\nalbedo = 0.5\ntwo_sided = false\n", vec!["materials.m.materials", "two_sided"]),
        ("type = \"lambertian\"\nalbedo = 0.5\nweight = 0.5", "", vec!["materials.m.weight", "only allowed for a blend"]),
        ("type = \"blend\"\nmaterials = [\"pa\", \"pb\"]\nweight = 0.5\nalbedo = 0.5", "", vec!["materials.m.albedo", "not allowed"]),
    ] {
        assert_one_line_error(Scene::from_toml_str(&base(mat, extra), "test.toml", &dir), &needles);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A floor (lambertian, albedo 0.5) seen from straight above, and a quad of the masked material
/// `mask` at height 1 over x ∈ [0.5, 3]: out of the camera's view, across the shadow rays of a
/// directional light from (1, 0, 1) (45°).
fn masked_floor(mask: &str, integrator: &str) -> String {
    let light = directional(Vec3::new(1.0, 0.0, 1.0), 2.0);
    quad_scene(Vec3::new(0.0, 0.0, 4.0), "type = \"lambertian\"\nalbedo = 0.5", &light)
        .replace("type = \"direct\"\n        emitter_samples = 1\n        bsdf_samples = 0", integrator)
        + &format!("\n[materials.shade]\n{mask}\n[materials.grey]\ntype = \"lambertian\"\nalbedo = 0.3\n[[objects]]\nmaterial = \"shade\"\nquad = [[0.5, -3, 1], [3, -3, 1], [3, 3, 1], [0.5, 3, 1]]\n")
}

#[test]
fn a_mask_lets_its_transparent_share_of_the_light_through() {
    // The floor under the mask's shadow: ρ/π · E cos 45° · (1 − opacity), by light samples alone
    // (`direct`) and with MIS (`path`): the mask's test is the same for shadow rays and paths.
    let dir = tmp_dir("mask-shadow");
    let full = 0.5 / PI * 2.0 * std::f64::consts::FRAC_1_SQRT_2 * y_of_one();
    for (integrator, what) in [("type = \"direct\"\n        emitter_samples = 1\n        bsdf_samples = 0", "direct"), ("type = \"path\"\n        max_depth = 3", "path")] {
        for opacity in [0.0, 0.3, 1.0] {
            let text = masked_floor(&format!("type = \"mask\"\nmaterial = \"grey\"\nopacity = {opacity}"), integrator);
            let (m, se) = pixels(&load_in(&dir, &text));
            let expect = full * (1.0 - opacity);
            assert!((m - expect).abs() < 4.0 * se + 1e-4 * full, "{what}, opacity {opacity}: {m} ± {se} vs {expect}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_fully_transparent_mask_changes_no_pixel() {
    // Opacity 0: every ray passes the quad, drawing no random number, so the image is the one
    // without it, bit for bit (camera rays through it, shadow rays through it).
    let dir = tmp_dir("mask-clear");
    let with = load_in(&dir, &masked_floor("type = \"mask\"\nmaterial = \"grey\"\nopacity = 0", "type = \"path\"\n        max_depth = 3").replace("[[0.5, -3, 1], [3, -3, 1], [3, 3, 1], [0.5, 3, 1]]", "[[-3, -3, 1], [3, -3, 1], [3, 3, 1], [-3, 3, 1]]"));
    let without = load_in(&dir, &masked_floor("type = \"lambertian\"\nalbedo = 0.3", "type = \"path\"\n        max_depth = 3").replace("quad = [[0.5, -3, 1], [3, -3, 1], [3, 3, 1], [0.5, 3, 1]]", "sphere = { center = [0, 0, -50], radius = 0.001 }"));
    let (w, h) = with.resolution();
    let (mut a, mut b) = (vec![[0f32; 3]; (w * h) as usize], vec![[0f32; 3]; (w * h) as usize]);
    for p in 0..4 {
        render::integrator::render_pass(&with, &with.integrator, 9, p, &mut a);
        render::integrator::render_pass(&without, &without.integrator, 9, p, &mut b);
        assert!(a.iter().zip(&b).all(|(x, y)| (0..3).all(|c| (x[c] - y[c]).abs() <= 1e-6 * y[c].abs().max(1e-3))), "pass {p}");
        assert!(a.iter().any(|x| x[1] > 0.05));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn mask_errors_are_one_line_and_name_the_field() {
    let dir = tmp_dir("mask-errors");
    let base = |m: &str| masked_floor(m, "type = \"path\"");
    for (mat, needles) in [
        ("type = \"mask\"\nopacity = 0.5", vec!["materials.shade.material", "missing"]),
        ("type = \"mask\"\nmaterial = \"grey\"", vec!["materials.shade.opacity", "missing"]),
        ("type = \"mask\"\nmaterial = \"nope\"\nopacity = 0.5", vec!["materials.shade.material", "unknown material"]),
        ("type = \"mask\"\nmaterial = \"grey\"\nopacity = 2", vec!["materials.shade.opacity", "[0, 1]"]),
        ("type = \"mask\"\nmaterial = \"shade\"\nopacity = 0.5", vec!["materials.shade.material", "mask material"]),
        ("type = \"mask\"\nmaterial = \"grey\"\nopacity = 0.5\ntwo_sided = false", vec!["materials.shade", "two_sided"]),
        ("type = \"lambertian\"\nalbedo = 0.5\nopacity = 0.5", vec!["materials.shade.opacity", "only allowed for a mask"]),
    ] {
        assert_one_line_error(Scene::from_toml_str(&base(mat), "test.toml", &dir), &needles);
    }
    // A mask on an area light.
    let lamp = base("type = \"mask\"\nmaterial = \"grey\"\nopacity = 0.5").replace("material = \"shade\"\nquad", "name = \"lamp\"\nmaterial = \"shade\"\nquad")
        + "[[lights]]\ntype = \"area\"\nobject = \"lamp\"\nradiance = 1\n";
    assert_one_line_error(Scene::from_toml_str(&lamp, "test.toml", &dir), &["objects[1]", "area light"]);
    std::fs::remove_dir_all(&dir).ok();
}
