//! Normal and bump maps, and the shading frame tied to ∂p/∂u, against closed forms: a flat
//! Lambertian quad whose normal a constant map tilts, lit by a directional light (one light
//! sample per camera sample is exact), gives ρ/π · E · (n_p·l) times Estevez et al.'s shadowing
//! term; a tilt that turns the light below the shading normal gives 0; a normal facing away
//! from the viewer is mirrored (or, without the flip, shows black); a bump map of a linear ramp
//! tilts the normal by the ramp's slope; under a uniform environment the tilted quad reflects
//! ρ L (1 + cos θ_p)/2 (the sky-view factor of a tilted plane); an anisotropic roughness follows
//! the texture's u direction. Mitsuba 3.9.1's `normalmap` and `bumpmap` are compared in
//! `benches-peers/mitsuba_normalmap.py`.

#[allow(unused_imports)]
use crate::common::*;

use glam::Vec3;
use render::image_io::{write_image, Image};
use render::scene::Scene;
use std::f64::consts::PI;
use std::path::Path;

/// A 4 × 4 PFM whose every texel is the tangent-space normal `n` stored as (n + 1)/2.
fn constant_normal_map(dir: &Path, name: &str, n: Vec3) -> String {
    let n = n.normalize();
    let c = [(n.x + 1.0) / 2.0, (n.y + 1.0) / 2.0, (n.z + 1.0) / 2.0];
    write_image(&dir.join(name), &Image::from_rgb(4, 4, vec![c; 16]).unwrap(), 0.0).unwrap();
    name.to_string()
}

fn assert_all(what: &str, (m, se): (f64, f64), expect: f64) {
    assert!(se <= 1.5e-3 * expect.abs().max(1e-3), "{what}: too noisy to tell ({se})");
    assert!((m - expect).abs() <= 4.0 * se + 1e-6, "{what}: {m} ± {se}, expected {expect}");
}

/// Estevez et al.'s shadowing term for a normal tilted by θ_p (cos_p) and a light at θ_l (cos_l)
/// from the unperturbed normal, written out here independently of the renderer.
fn estevez(cos_p: f64, cos_l: f64) -> f64 {
    let tan2_p = (1.0 - cos_p * cos_p) / (cos_p * cos_p);
    let tan2_l = (1.0 - cos_l * cos_l) / (cos_l * cos_l);
    let a2 = (0.125 * tan2_p).min(1.0);
    2.0 / (1.0 + (1.0 + a2 * tan2_l).sqrt())
}

#[test]
fn a_constant_normal_map_tilts_the_lambert_cosine() {
    let dir = tmp_dir("shading-map-constant");
    let (rho, e) = (0.6, 3.0);
    let np = Vec3::new(0.5, 0.3, 0.8).normalize();
    let map = constant_normal_map(&dir, "n.pfm", np);
    let l = Vec3::new(0.4, -0.5, 0.77).normalize();
    let eye = Vec3::new(0.3, 0.2, 4.0);
    let y1 = y_of_one();
    let plain = rho / PI * e * l.z as f64 * y1;
    let tilted = rho / PI * e * np.dot(l) as f64 * y1;
    let shadow = estevez(np.z as f64, l.z as f64);
    assert!(shadow < 0.99, "the test needs a visible shadowing term ({shadow})");
    for (mat, expect, what) in [
        (format!("type = \"lambertian\"\nalbedo = {rho}"), plain, "no map"),
        (format!("type = \"lambertian\"\nalbedo = {rho}\nnormal_map = {{ texture = \"{map}\" }}"), tilted * shadow, "normal map"),
        (format!("type = \"lambertian\"\nalbedo = {rho}\nnormal_map = {{ texture = \"{map}\", shadowing = false }}"), tilted, "without shadowing"),
    ] {
        assert_all(what, pixels(&load_in(&dir, &quad_scene(eye, &mat, &directional(l, e)))), expect);
    }
    // A flat map (0, 0, 1) changes nothing.
    let flat = constant_normal_map(&dir, "flat.pfm", Vec3::Z);
    let mat = format!("type = \"lambertian\"\nalbedo = {rho}\nnormal_map = {{ texture = \"{flat}\" }}");
    assert_all("flat map", pixels(&load_in(&dir, &quad_scene(eye, &mat, &directional(l, e)))), plain);
    // Light above the surface but below the tilted normal: black.
    let steep = constant_normal_map(&dir, "steep.pfm", Vec3::new(0.8, 0.0, 0.6));
    let mat = format!("type = \"lambertian\"\nalbedo = {rho}\nnormal_map = {{ texture = \"{steep}\" }}");
    let below = Vec3::new(-0.9, 0.0, 0.3).normalize();
    assert_all("light below the tilted normal", pixels(&load_in(&dir, &quad_scene(eye, &mat, &directional(below, e)))), 0.0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_tilted_normal_facing_away_from_the_viewer_is_mirrored() {
    // Seen from the −x side at a grazing angle, the normal tilted towards +x faces away from the
    // viewer; Mitsuba 3's flip mirrors its tangential part: n' = (−0.8, 0, 0.6).
    let dir = tmp_dir("shading-map-flip");
    let (rho, e) = (0.5, 2.0);
    let np = Vec3::new(0.8, 0.0, 0.6);
    let map = constant_normal_map(&dir, "n.pfm", np);
    let eye = Vec3::new(-2.4, 0.0, 1.2);
    assert!(np.dot(eye.normalize()) < -0.3);
    let l = Vec3::new(-0.5, 0.0, 0.866).normalize();
    let mirrored = Vec3::new(-0.8, 0.0, 0.6);
    let expect = rho / PI * e * mirrored.dot(l) as f64 * y_of_one() * estevez(0.6, l.z as f64);
    let mat = format!("type = \"lambertian\"\nalbedo = {rho}\nnormal_map = {{ texture = \"{map}\" }}");
    assert_all("flipped", pixels(&load_in(&dir, &quad_scene(eye, &mat, &directional(l, e)))), expect);
    let mat = format!("type = \"lambertian\"\nalbedo = {rho}\nnormal_map = {{ texture = \"{map}\", flip_invalid_normals = false }}");
    assert_all("not flipped", pixels(&load_in(&dir, &quad_scene(eye, &mat, &directional(l, e)))), 0.0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_bump_ramp_tilts_the_normal_by_its_slope() {
    // Texel i of 32 holds (i + ½)/32, so the bilinear height is h = H u (in the scene unit, mm
    // here) between the first and last texel centres. On the quad, ∂p/∂u = (2, 0, 0) mm: the
    // bumped normal is (−H/2, 0, 1)/‖…‖, whatever the unit.
    let dir = tmp_dir("shading-map-bump");
    let (rho, e, h) = (0.7, 1.5, 0.8);
    let w = 32;
    let rgb = (0..4).flat_map(|_| (0..w).map(|i| [(i as f32 + 0.5) / w as f32; 3])).collect();
    write_image(&dir.join("h.pfm"), &Image::from_rgb(w, 4, rgb).unwrap(), 0.0).unwrap();
    let nb = Vec3::new(-h / 2.0, 0.0, 1.0).normalize();
    let l = Vec3::new(-0.5, 0.2, 0.8).normalize();
    let expect = rho / PI * e * nb.dot(l) as f64 * y_of_one();
    for (extra, shadow) in [("", estevez(nb.z as f64, l.z as f64)), (", shadowing = false", 1.0)] {
        let mat = format!("type = \"lambertian\"\nalbedo = {rho}\nbump_map = {{ texture = \"h.pfm\", height = {h}, wrap = \"clamp\"{extra} }}");
        let text = format!("unit = \"mm\"\n{}", quad_scene(Vec3::new(0.0, 0.0, 4.0), &mat, &directional(l, e)));
        // The camera's 8° view of the quad at 4 mm covers |x| < 0.28 mm: inside the ramp.
        assert_all(&format!("bump{extra}"), pixels(&load_in(&dir, &text)), expect * shadow);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_normal_mapped_plane_under_a_uniform_sky_sees_its_tilted_view_factor() {
    // ∫ over the directions above both the plane and the tilted normal n_p of (ω·n_p) dω is
    // π (1 + cos θ_p)/2, so a Lambertian plane of albedo ρ under radiance L reflects
    // ρ L (1 + cos θ_p)/2 (without the shadowing term). Path tracing with light and BSDF samples.
    let dir = tmp_dir("shading-map-sky");
    let (rho, l) = (0.8, 1.0);
    let np = Vec3::new(0.8, 0.0, 0.6);
    let map = constant_normal_map(&dir, "n.pfm", np);
    let text = quad_scene(
        Vec3::new(0.0, 0.0, 4.0),
        &format!("type = \"lambertian\"\nalbedo = {rho}\nnormal_map = {{ texture = \"{map}\", shadowing = false }}"),
        &format!("[[lights]]\ntype = \"environment\"\nradiance = {l}"),
    )
    .replace("type = \"direct\"\n        emitter_samples = 1\n        bsdf_samples = 0", "type = \"path\"\n        max_depth = 2");
    let s = load_in(&dir, &text);
    let (m, se) = pixels(&s);
    let expect = rho * l * (1.0 + np.z as f64) / 2.0 * y_of_one();
    assert!((m - expect).abs() < 4.0 * se + 1e-6, "{m} ± {se} vs {expect}");
    assert!(se < 0.01 * expect, "too noisy to tell: {se}");
    // The untilted plane's ρ L is 25 % brighter: the test tells them apart.
    assert!((rho * l * y_of_one() - m) > 10.0 * se);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn anisotropic_roughness_follows_the_u_direction() {
    // The same quad with its texture coordinates turned by 90° (u along +y) and α_x, α_y swapped
    // gives the same image; with the tangent frame not tied to u (the normal alone) it would not.
    let dir = tmp_dir("shading-map-aniso");
    let write = |name: &str, vt: [[f32; 2]; 4]| {
        let mut s = String::from("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n");
        for t in vt {
            s += &format!("vt {} {}\n", t[0], t[1]);
        }
        s += "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
        std::fs::write(dir.join(name), s).unwrap();
    };
    write("u_along_x.obj", [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    write("u_along_y.obj", [[0.0, 1.0], [0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
    let l = Vec3::new(0.45, 0.35, 0.8).normalize();
    let eye = Vec3::new(-1.2, -1.0, 3.5);
    let image = |mesh: &str, alpha: &str| {
        let text = quad_scene(eye, &format!("type = \"rough_conductor\"\nmetal = \"cu\"\nalpha = {alpha}"), &directional(l, 2.0))
            .replace("quad = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]", &format!("mesh = \"{mesh}\""));
        pixels(&load_in(&dir, &text))
    };
    let a = image("u_along_x.obj", "[0.05, 0.3]");
    let b = image("u_along_y.obj", "[0.3, 0.05]");
    let c = image("u_along_x.obj", "[0.3, 0.05]");
    // The same camera samples and wavelengths: the turned uv with swapped α agree to rounding.
    assert!(a.0 > 1e-3, "the highlight must show ({})", a.0);
    assert!((a.0 - b.0).abs() < 1e-5 * a.0, "turned uv with swapped α: {} vs {}", a.0, b.0);
    assert!((a.0 - c.0).abs() > 0.1 * a.0, "swapping α alone must change the image ({} vs {})", a.0, c.0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn shading_map_errors_are_one_line_and_name_the_field() {
    let dir = tmp_dir("shading-map-errors");
    let map = constant_normal_map(&dir, "n.pfm", Vec3::Z);
    let base = |m: &str| quad_scene(Vec3::new(0.0, 0.0, 4.0), m, &directional(Vec3::Z, 1.0));
    for (mat, needles) in [
        (format!("type = \"black\"\nnormal_map = {{ texture = \"{map}\" }}"), vec!["materials.m.normal_map", "not allowed"]),
        (format!("type = \"lambertian\"\nalbedo = 0.5\nnormal_map = {{ texture = \"{map}\" }}\nbump_map = {{ texture = \"{map}\", height = 1 }}"), vec!["materials.m.bump_map", "either"]),
        (format!("type = \"lambertian\"\nalbedo = 0.5\nbump_map = {{ texture = \"{map}\" }}"), vec!["materials.m.bump_map.height", "missing"]),
        (format!("type = \"lambertian\"\nalbedo = 0.5\nbump_map = {{ texture = \"{map}\", height = 1, filter = \"nearest\" }}"), vec!["materials.m.bump_map.filter"]),
        (format!("type = \"lambertian\"\nalbedo = 0.5\nnormal_map = {{ texture = \"{map}\", shadowing = 2 }}"), vec!["materials.m.normal_map.shadowing", "true or false"]),
        (format!("type = \"lambertian\"\nalbedo = 0.5\nnormal_map = {{ texture = \"{map}\", height = 1 }}"), vec!["materials.m.normal_map", "unknown key `height`"]),
        ("type = \"lambertian\"\nalbedo = 0.5\nnormal_map = \"n.pfm\"".to_string(), vec!["materials.m.normal_map", "must be a table"]),
        ("type = \"lambertian\"\nalbedo = 0.5\nnormal_map = { texture = \"missing.png\" }".to_string(), vec!["materials.m.normal_map.texture", "missing.png"]),
    ] {
        assert_one_line_error(Scene::from_toml_str(&base(&mat), "test.toml", &dir), &needles);
    }
    // A mesh without texture coordinates cannot carry a map.
    std::fs::write(dir.join("bare.obj"), "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nf 1 2 3\n").unwrap();
    let text = base(&format!("type = \"lambertian\"\nalbedo = 0.5\nnormal_map = {{ texture = \"{map}\" }}"))
        .replace("quad = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]", "mesh = \"bare.obj\"");
    assert_one_line_error(Scene::from_toml_str(&text, "test.toml", &dir), &["objects[0]", ".mesh", "normal or bump map", "texture coordinates"]);
    std::fs::remove_dir_all(&dir).ok();
}
