//! Diffuse transmitters (pbrt-v4's `diffusetransmission`: reflectance ρ, transmittance τ): a sheet
//! lit from behind by a directional light shows τ/π · E · cos θ on its front and, lit from the
//! front, ρ/π · E · cos θ; under a uniform environment it shows (ρ + τ)·L by BSDF and light
//! samples combined (`path`, MIS); a blend with a Lambertian reflector reflects and transmits its
//! two shares; errors are one line. Mitsuba 3 has no such BSDF (its `difftrans` was Mitsuba 0.6's),
//! so these closed forms are the check.

#[allow(unused_imports)]
use crate::common::*;

use glam::Vec3;
use std::f64::consts::PI;
use std::path::Path;

/// Asserts that the quad of `material` (with `extra` materials), seen from `eye` under a
/// directional light of irradiance `e` from `to_light`, shows share/π · E · |cos θ| within four
/// standard errors; returns the mean and its standard error.
fn assert_lit_share(dir: &Path, eye: Vec3, material: &str, extra: &str, to_light: Vec3, e: f64, share: f64) -> (f64, f64) {
    let (m, se) = pixels(&load_in(dir, &(quad_scene(eye, material, &directional(to_light, e)) + extra)));
    let expect = share / PI * e * to_light.normalize().z.abs() as f64 * y_of_one();
    assert!((m - expect).abs() < 4.0 * se + 1e-6, "{m} ± {se} vs {expect}");
    (m, se)
}

#[test]
fn a_sheet_lit_from_behind_shows_its_transmittance() {
    let dir = tmp_dir("difftrans-behind");
    let (t, e) = (0.6, 2.0);
    let eye = Vec3::new(0.2, -0.1, 4.0);
    let material = format!("type = \"diffuse_transmitter\"\ntransmittance = {t}");
    // The light on the far side (z < 0), the camera at z > 0.
    let behind = Vec3::new(0.3, 0.2, -0.9).normalize();
    let (m, se) = assert_lit_share(&dir, eye, &material, "", behind, e, t);
    let expect = t / PI * e * behind.z.abs() as f64 * y_of_one();
    assert!(expect > 0.1 && (m - 0.5 * expect).abs() > 10.0 * se.max(1e-4));
    // Lit from the camera's side, a pure transmitter returns nothing, and one with albedo ρ
    // returns ρ/π · E · cos θ (its transmittance does not change that).
    let front = Vec3::new(behind.x, behind.y, -behind.z);
    let (m, _) = pixels(&load_in(&dir, &quad_scene(eye, &material, &directional(front, e))));
    assert_eq!(m, 0.0);
    let rho = 0.3;
    let with_albedo = format!("{material}\nalbedo = {rho}");
    assert_lit_share(&dir, eye, &with_albedo, "", front, e, rho);
    assert_lit_share(&dir, eye, &with_albedo, "", behind, e, t);
    // Seen from behind (the camera on the lit side), the transmitted light leaves the other way:
    // nothing, whichever face the geometric normal marks.
    let (m, _) = pixels(&load_in(&dir, &quad_scene(Vec3::new(0.2, -0.1, -4.0), &material, &directional(behind, e))));
    assert_eq!(m, 0.0);
    assert_lit_share(&dir, Vec3::new(0.2, -0.1, -4.0), &material, "", front, e, t);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn under_a_uniform_environment_a_sheet_shows_its_albedo_plus_transmittance_times_radiance() {
    // ∫ ρ/π · L · |cos| dω over the near hemisphere plus ∫ τ/π · L · |cos| dω over the far one =
    // (ρ + τ) L, by BSDF samples (either lobe) and environment samples combined by MIS (`path`).
    let dir = tmp_dir("difftrans-furnace");
    let (r, t, l) = (0.25, 0.45, 1.5);
    let text = quad_scene(Vec3::new(0.0, 0.0, 4.0), &format!("type = \"diffuse_transmitter\"\nalbedo = {r}\ntransmittance = {t}"), &format!("[[lights]]\ntype = \"environment\"\nradiance = {l}"))
        .replace("type = \"direct\"\n        emitter_samples = 1\n        bsdf_samples = 0", "type = \"path\"\n        max_depth = 3");
    let (m, se) = pixels_with(&load_in(&dir, &text), 256, 3);
    let expect = (r + t) * l * y_of_one();
    assert!((m - expect).abs() < 4.0 * se + 1e-6, "{m} ± {se} vs {expect}");
    assert!((m - t * l * y_of_one()).abs() > 10.0 * se && (m - l * y_of_one()).abs() > 10.0 * se);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_blend_with_a_reflector_reflects_and_transmits_its_shares() {
    // Paper or a leaf: weight w of a transmitter τ, 1 − w of a Lambertian ρ. Lit from the front
    // it returns (1 − w)ρ/π E cos θ, from behind w τ/π E cos θ.
    let dir = tmp_dir("difftrans-blend");
    let (rho, t, w, e) = (0.7, 0.5, 0.4, 1.0);
    let parts = format!("\n[materials.paper]\ntype = \"lambertian\"\nalbedo = {rho}\n[materials.sheet]\ntype = \"diffuse_transmitter\"\ntransmittance = {t}\n");
    let material = format!("type = \"blend\"\nmaterials = [\"paper\", \"sheet\"]\nweight = {w}");
    let eye = Vec3::new(0.1, 0.2, 4.0);
    let front = Vec3::new(0.2, -0.3, 0.9).normalize();
    let behind = Vec3::new(front.x, front.y, -front.z);
    assert_lit_share(&dir, eye, &material, &parts, front, e, (1.0 - w) * rho);
    assert_lit_share(&dir, eye, &material, &parts, behind, e, w * t);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn transmitter_keys_are_checked() {
    let dir = tmp_dir("difftrans-errors");
    let eye = Vec3::new(0.0, 0.0, 4.0);
    let light = directional(Vec3::Z, 1.0);
    let load = |m: &str| render::scene::Scene::from_toml_str(&quad_scene(eye, m, &light), "test.toml", &dir);
    assert_one_line_error(load("type = \"diffuse_transmitter\""), &["materials.m.transmittance", "missing"]);
    assert_one_line_error(load("type = \"diffuse_transmitter\"\ntransmittance = 0.5\nalbedo = 0.6"), &["materials.m.transmittance", "albedo + transmittance", "1.1"]);
    assert_one_line_error(load("type = \"lambertian\"\nalbedo = 0.5\ntransmittance = 0.5"), &["materials.m.transmittance", "diffuse_transmitter"]);
    assert_one_line_error(load("type = \"diffuse_transmitter\"\ntransmittance = 1.5"), &["materials.m.transmittance"]);
    assert_one_line_error(load("type = \"diffuse_transmitter\"\ntransmittance = 0.5\ntwo_sided = false"), &["materials.m.two_sided"]);
    assert_one_line_error(load("type = \"diffuse_transmitter\"\ntransmittance = 0.5\nior = 1.5"), &["materials.m.ior", "not allowed"]);
    assert!(load("type = \"diffuse_transmitter\"\ntransmittance = 0.5\nalbedo = 0.5").is_ok());
    std::fs::remove_dir_all(&dir).ok();
}
