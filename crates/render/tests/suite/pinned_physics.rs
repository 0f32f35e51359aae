//! Physics that a single-light or closed-object test cannot see: light selection in the MIS weight
//! with several lights, the η² radiance scaling of refraction, and the geometric-vs-shading normal
//! side check of light sampling on smooth-shaded meshes.
//!
//! Every Monte Carlo test renders independent passes with fixed seeds; the tolerance is a multiple
//! of the standard error of the mean estimated from the spread between passes.

#[allow(unused_imports)]
use crate::common::*;

use render::integrator::{render_pass, IntegratorKind, IntegratorSettings};
use render::scene::Scene;
use std::path::Path;

fn scene_in(text: &str, dir: &Path) -> Scene {
    Scene::from_toml_str(text, "test.toml", dir).unwrap_or_else(|e| panic!("{e:#}"))
}

fn scene(text: &str) -> Scene {
    scene_in(text, Path::new("."))
}



/// Per pass, the mean of XYZ component `c` over all pixels; returns (mean, standard error, the
/// largest |value| of any single pixel in any pass).
fn image_stats(s: &Scene, st: &IntegratorSettings, seed: u64, passes: u64, c: usize) -> (f64, f64, f64) {
    let (w, h) = s.resolution();
    let mut buf = vec![[0f32; 3]; (w * h) as usize];
    let mut vals = Vec::new();
    let mut max_abs = 0.0f64;
    for p in 0..passes {
        render_pass(s, st, seed, p, &mut buf);
        let sum: f64 = buf.iter().map(|v| v[c] as f64).sum();
        max_abs = buf.iter().map(|v| (v[c] as f64).abs()).fold(max_abs, f64::max);
        vals.push(sum / buf.len() as f64);
    }
    let m = vals.iter().sum::<f64>() / vals.len() as f64;
    let var = vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (vals.len() - 1) as f64;
    (m, (var / vals.len() as f64).sqrt(), max_abs)
}

fn assert_close(what: &str, m: f64, se: f64, expect: f64, k: f64) {
    assert!(se.is_finite() && se >= 0.0);
    let tol = k * se + 1e-6 * expect.abs();
    assert!((m - expect).abs() <= tol, "{what}: {m} ± {se} (se) vs expected {expect}; |diff| = {} > {tol}", (m - expect).abs());
}

/// Form factor from a differential area at the origin (normal +y) to the parallel rectangle
/// [x0, x1]×[z0, z1] at height h (superposition of four corner rectangles).
fn form_factor_rect(x0: f64, x1: f64, z0: f64, z1: f64, h: f64) -> f64 {
    form_factor_corner(x1, z1, h) - form_factor_corner(x0, z1, h) - form_factor_corner(x1, z0, h) + form_factor_corner(x0, z0, h)
}

/// Several area lights of unequal power over a Lambertian plane, direct lighting only.
///
/// Checks the light-selection probability inside the MIS weight of light sampling: the
/// light-sampled estimate is f L cos w / (p_pick p_ω) with the power heuristic
/// w = (p_pick p_ω)² / ((p_pick p_ω)² + p_bsdf²) (Veach 1997, §9.2: the densities in the weight are
/// those the samples were drawn with, the light choice included; pbrt-v4 `PathIntegrator::SampleLd`).
/// With one light p_pick = 1 and an error there is invisible; here three lamps are picked in
/// proportion to their power (pmf ≈ 0.30, 0.60, 0.09). Reference: L_o = ρ Σ_k L_k F_k with F_k the
/// differential-area-to-rectangle form factor (Howell B-3), for `path` with max_depth 2 (light +
/// BSDF sampling, MIS) and for `direct` (light sampling only, no MIS weight), and path vs direct.
#[test]
fn several_lights_of_unequal_power_with_mis_match_the_form_factor_sum() {
    let rho = 0.5;
    // (x0, x1, z0, z1, height, radiance): sizes, heights and radiances all differ; seen from the
    // origin no lamp hides another; the lamps are large and close so that p_bsdf ~ p_pick p_ω.
    let lamps = [
        (-0.3, 0.3, -0.2, 0.2, 0.5, 2.0),
        (0.6, 1.0, 0.1, 0.5, 0.4, 6.0),
        (-0.95, -0.45, -0.55, -0.25, 0.6, 1.0),
    ];
    let mut toml = format!(
        r#"
        unit = "m"
        [camera]
        eye = [0, 0.6, -2.0]
        look_at = [0, 0, 0]
        vfov_deg = 0.2
        width = 4
        height = 4
        [materials.grey]
        type = "lambertian"
        albedo = {rho}
        [materials.black]
        type = "black"
        [[objects]]
        name = "plane"
        material = "grey"
        quad = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]
        "#
    );
    let mut expect = 0.0;
    for (k, &(x0, x1, z0, z1, h, l)) in lamps.iter().enumerate() {
        // Corner order (x1,z1), (x0,z1), (x0,z0), (x1,z0): the normal (p1−p0)×(p2−p0) points down.
        toml += &format!(
            r#"
            [[objects]]
            name = "lamp{k}"
            material = "black"
            quad = [[{x1}, {h}, {z1}], [{x0}, {h}, {z1}], [{x0}, {h}, {z0}], [{x1}, {h}, {z0}]]
            [[lights]]
            type = "area"
            object = "lamp{k}"
            radiance = {l}
            "#
        );
        expect += rho * l * form_factor_rect(x0, x1, z0, z1, h);
    }
    let s = scene(&toml);
    assert_eq!(s.lights.len(), 3);
    assert!(s.light_pmf.iter().all(|&p| p > 0.05 && p < 0.7), "light pmf {:?}", s.light_pmf);
    let expect = expect * y_of_one();
    let (mp, sp, _) = image_stats(&s, &settings(IntegratorKind::Path, 2, 5), 61, 1600, 1);
    assert_close("path (MIS), three lights", mp, sp, expect, 5.0);
    let (md, sd, _) = image_stats(&s, &settings(IntegratorKind::Direct, 2, 5), 62, 1600, 1);
    assert_close("direct (light sampling), three lights", md, sd, expect, 5.0);
    let se = (sp * sp + sd * sd).sqrt();
    assert!((mp - md).abs() <= 5.0 * se, "path {mp} ± {sp} vs direct {md} ± {sd}");
}

/// A camera inside a glass ball (n = 1.5, smooth) under a uniform environment of radiance 1 sees
/// radiance η² = 2.25 in every direction.
///
/// Radiance divided by n² is invariant along a ray through refractions (étendue conservation,
/// Veach 1997 §5.2; pbrt-v4 §9.5.2 and `TransportMode::Radiance`: the transmitted BTDF of a
/// smooth dielectric carries 1/η² with η the relative index across the interface). In the
/// equilibrium every direction inside is fed by transmission T η² L from outside and by internal
/// reflection R of the same inside radiance, so L_in = T η² L + R L_in = η² L. The test checks
/// the camera at the centre (normal incidence everywhere) and off centre at half the radius
/// (every internal incidence below sin θ = 1/2 < 1/n: no total internal reflection, so every
/// direction connects to the outside and the invariant holds in all of them).
///
/// For a closed glass object seen and lit from outside the factors η² and 1/η² cancel, which is
/// why the exterior furnace tests do not see a missing 1/η².
#[test]
fn camera_inside_a_glass_ball_under_a_uniform_sky_sees_eta_squared() {
    let eta: f64 = 1.5;
    for (eye, seed) in [("[0, 0, 0]", 71u64), ("[0.5, 0, 0]", 72)] {
        let s = scene(&format!(
            r#"
            unit = "m"
            [camera]
            eye = {eye}
            look_at = [0.3, 0.2, 1]
            vfov_deg = 90
            width = 8
            height = 8
            [materials.glass]
            type = "dielectric"
            ior = {eta}
            [[objects]]
            name = "ball"
            material = "glass"
            sphere = {{ center = [0, 0, 0], radius = 1 }}
            [[lights]]
            type = "environment"
            radiance = {{ constant = 1 }}
            "#
        ));
        let (m, se, _) = image_stats(&s, &settings(IntegratorKind::Path, 64, 5), seed, 64, 1);
        assert_close(&format!("camera at {eye} inside the ball"), m, se, eta * eta * y_of_one(), 5.0);
    }
}

/// A low-poly, smooth-shaded, upper half of a sphere (an open mesh: 8 segments, two latitude
/// bands, radial vertex normals) as OBJ text; radius 1, centre at the origin, the open rim on y = 0.
/// Faces wound so that the geometric normal points outwards, like the vertex normals.
fn smooth_hemisphere_obj() -> String {
    let n_az = 8;
    let lats = [0.0f64, 45.0];
    let mut v = Vec::new(); // positions = normals (unit radius)
    for &lat in &lats {
        for k in 0..n_az {
            let az = (22.5 + 45.0 * k as f64).to_radians();
            let lat = lat.to_radians();
            v.push([lat.cos() * az.cos(), lat.sin(), lat.cos() * az.sin()]);
        }
    }
    v.push([0.0, 1.0, 0.0]);
    let pole = v.len() - 1;
    let mut f: Vec<[usize; 3]> = Vec::new();
    for k in 0..n_az {
        let k1 = (k + 1) % n_az;
        let (a, b, c, d) = (k, k1, n_az + k1, n_az + k);
        f.push([a, b, c]);
        f.push([a, c, d]);
        f.push([d, c, pole]);
    }
    let mut out = String::new();
    for p in &v {
        out += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for p in &v {
        out += &format!("vn {} {} {}\n", p[0], p[1], p[2]);
    }
    for t in &mut f {
        // Orient outwards: the geometric normal along the centroid (the mesh is star-shaped).
        let p = |i: usize| glam::DVec3::from_array(v[i]);
        let n = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
        if n.dot(p(t[0]) + p(t[1]) + p(t[2])) < 0.0 {
            t.swap(1, 2);
        }
        out += &format!("f {0}//{0} {1}//{1} {2}//{2}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    out
}

/// A square area light of side `side` centred at `c` (TOML quad) whose emitting normal is `n`
/// (an axis, ±1 in one component).
fn lamp_quad(c: [f64; 3], side: f64, n: [f64; 3]) -> String {
    let h = side / 2.0;
    let axis = n.iter().position(|x| *x != 0.0).unwrap();
    let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
    let corner = |su: f64, sw: f64| {
        let mut p = c;
        p[u] += su * h;
        p[w] += sw * h;
        format!("[{}, {}, {}]", p[0], p[1], p[2])
    };
    // (+,+), (−,+), (−,−), (+,−) has normal (p1−p0)×(p2−p0) along e_u × e_w = +e_axis.
    let mut q = [corner(1.0, 1.0), corner(-1.0, 1.0), corner(-1.0, -1.0), corner(1.0, -1.0)];
    if n[axis] < 0.0 {
        q.reverse();
    }
    format!("[{}]", q.join(", "))
}

/// Smooth shading at grazing light: a light below the plane of the facet seen by the camera, but
/// above the hemisphere of the interpolated shading normal there, contributes nothing.
///
/// Reflection at a surface point is bounded by its geometric surface: light from behind the facet
/// cannot reach its front whatever the interpolated normal says (Veach 1997 §5.3 on shading
/// normals; pbrt-v4 §10.1.1 discards light-sampled directions whose geometric and shading sides
/// disagree). On a closed convex mesh such a shadow ray re-enters the mesh and is blocked anyway,
/// so the check only shows on an open smooth-shaded mesh: here the open upper half of a low-poly
/// sphere, seen from the side at the bottom of the facet that faces the camera, with a small lamp
/// far below and slightly outside the rim facing up. The facet's geometric normal is tilted 21°
/// upwards, the shading normal near the rim only about 5°, and the lamp lies 81° below the
/// horizon: below the facet's plane, above the shading horizon. Nothing else lights the outside
/// of the dome (it cannot see itself), so `direct` and `path` must both give exactly 0.
/// With the lamp moved in front of the dome (above the facet's plane) the same pixels are lit and
/// `path` (max_depth 2, MIS) agrees with `direct` within the standard error: the test is not vacuous.
#[test]
fn smooth_shaded_facet_gets_no_light_from_below_its_plane() {
    let dir = std::env::temp_dir().join(format!("lucent-pinned-physics-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("dome.obj"), smooth_hemisphere_obj()).unwrap();
    let dome_scene = |lamp: &str| {
        scene_in(
            &format!(
                r#"
                unit = "m"
                [camera]
                eye = [4, 0.08, 0]
                look_at = [0, 0.08, 0]
                vfov_deg = 1.5
                width = 8
                height = 8
                [materials.grey]
                type = "lambertian"
                albedo = 0.8
                [materials.black]
                type = "black"
                [[objects]]
                name = "dome"
                material = "grey"
                mesh = "dome.obj"
                [[objects]]
                name = "lamp"
                material = "black"
                quad = {lamp}
                [[lights]]
                type = "area"
                object = "lamp"
                radiance = 100
                "#
            ),
            &dir,
        )
    };
    // Below the facet's plane: far under the rim, slightly outside it, facing up.
    let below = dome_scene(&lamp_quad([1.2, -2.0, 0.0], 0.2, [0.0, 1.0, 0.0]));
    for (kind, depth, seed) in [(IntegratorKind::Direct, 2, 81u64), (IntegratorKind::Path, 2, 82), (IntegratorKind::Path, 8, 83)] {
        for c in 0..3 {
            let (m, _, max_abs) = image_stats(&below, &settings(kind, depth, 5), seed, 32, c);
            assert!(max_abs == 0.0, "{kind:?} max_depth {depth}, XYZ[{c}]: light from below the facet's plane leaks in (image mean {m}, largest pixel {max_abs})");
        }
    }
    // Control: the same lamp in front of the dome, facing it, lights the same pixels.
    let front = dome_scene(&lamp_quad([2.5, 0.6, 0.0], 0.2, [-1.0, 0.0, 0.0]));
    let (mp, sp, _) = image_stats(&front, &settings(IntegratorKind::Path, 2, 5), 84, 64, 1);
    let (md, sd, _) = image_stats(&front, &settings(IntegratorKind::Direct, 2, 5), 85, 64, 1);
    assert!(md > 20.0 * sd && md > 0.0, "control lamp does not light the facet: direct {md} ± {sd}");
    let se = (sp * sp + sd * sd).sqrt();
    assert!((mp - md).abs() <= 5.0 * se, "control: path {mp} ± {sp} vs direct {md} ± {sd}");
    let _ = std::fs::remove_dir_all(&dir);
}
