//! Physics tests of the integrators against closed forms (furnaces, form factors, AO of corners).
//!
//! Every Monte Carlo test renders independent passes with fixed seeds; the tolerance is a multiple
//! of the standard error of the mean estimated from the spread between passes.

#[allow(unused_imports)]
use crate::common::*;

use render::integrator::{render_pass, IntegratorKind, IntegratorSettings};
use render::scene::Scene;
use std::f64::consts::PI;


/// Mean and standard error over `passes` passes of the region mean of XYZ component `c`.
/// `region(i, j)` selects pixels.
fn region_stats(
    s: &Scene,
    settings: &IntegratorSettings,
    seed: u64,
    passes: u64,
    c: usize,
    region: impl Fn(u32, u32) -> bool,
) -> (f64, f64) {
    let (w, h) = s.resolution();
    let mut buf = vec![[0f32; 3]; (w * h) as usize];
    let mut vals = Vec::new();
    for p in 0..passes {
        render_pass(s, settings, seed, p, &mut buf);
        let (mut sum, mut n) = (0.0f64, 0usize);
        for j in 0..h {
            for i in 0..w {
                if region(i, j) {
                    sum += buf[(j * w + i) as usize][c] as f64;
                    n += 1;
                }
            }
        }
        assert!(n > 0);
        vals.push(sum / n as f64);
    }
    let m = vals.iter().sum::<f64>() / vals.len() as f64;
    let var = vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (vals.len() - 1) as f64;
    (m, (var / vals.len() as f64).sqrt())
}



fn assert_close(what: &str, m: f64, se: f64, expect: f64, k: f64) {
    assert!(se.is_finite() && se >= 0.0);
    let tol = k * se + 1e-6 * expect.abs();
    assert!((m - expect).abs() <= tol, "{what}: {m} ± {se} (se) vs expected {expect}; |diff| = {} > {tol}", (m - expect).abs());
}

#[test]
fn furnace_convex_lambertian_sphere_under_uniform_environment() {
    // A convex Lambertian object of albedo ρ under a uniform environment of radiance L reflects
    // exactly ρL everywhere: ∫ρ/π L cos dω = ρL. The background shows L.
    let (rho, l) = (0.6, 1.5);
    let s = scene(&format!(
        r#"
        unit = "m"
        [camera]
        eye = [0, 0, -3]
        look_at = [0, 0, 0]
        vfov_deg = 40
        width = 16
        height = 16
        [materials.grey]
        type = "lambertian"
        albedo = {rho}
        [[objects]]
        name = "ball"
        material = "grey"
        sphere = {{ center = [0, 0, 0], radius = 0.8 }}
        [[lights]]
        type = "environment"
        radiance = {{ constant = {l} }}
        "#
    ));
    let centre = |i: u32, j: u32| (4..12).contains(&i) && (4..12).contains(&j);
    let corner = |i: u32, j: u32| !(2..14).contains(&i) && !(2..14).contains(&j);
    for kind in [IntegratorKind::Path, IntegratorKind::Direct] {
        let st = settings(kind, 8, 5);
        let (m, se) = region_stats(&s, &st, 11, 64, 1, centre);
        assert_close(&format!("{kind:?} sphere"), m, se, rho * l * y_of_one(), 4.5);
        let (m, se) = region_stats(&s, &st, 12, 16, 1, corner);
        assert_close(&format!("{kind:?} background"), m, se, l * y_of_one(), 4.5);
    }
}

#[test]
fn furnace_camera_inside_emitting_lambertian_sphere() {
    // Inside a closed sphere that emits L_e and reflects with albedo ρ, radiance is the same in
    // every direction and satisfies L = L_e + ρL, so L = L_e/(1−ρ). Tests multiple bounces, MIS
    // between light and BSDF sampling, and Russian roulette for bias (paths effectively unbounded).
    for (rho, le, seed) in [(0.5, 1.0, 21u64), (0.8, 0.5, 22)] {
        let s = scene(&format!(
            r#"
            unit = "cm"
            [camera]
            eye = [10, 20, 30]
            look_at = [11, 20, 30]
            vfov_deg = 60
            width = 12
            height = 12
            [materials.wall]
            type = "lambertian"
            albedo = {rho}
            [[objects]]
            name = "shell"
            material = "wall"
            sphere = {{ center = [10, 20, 30], radius = 50 }}
            [[lights]]
            type = "area"
            object = "shell"
            radiance = {le}
            two_sided = true
            "#
        ));
        let st = settings(IntegratorKind::Path, 100_000, 5);
        let (m, se) = region_stats(&s, &st, seed, 64, 1, |_, _| true);
        assert_close(&format!("rho {rho}"), m, se, le / (1.0 - rho) * y_of_one(), 4.5);
    }
}

#[test]
fn truncated_paths_sum_the_neumann_series() {
    // With max_depth D and no Russian roulette, the closed-sphere furnace gives L_e Σ_{k<D} ρ^k.
    let (rho, le) = (0.7f64, 1.0f64);
    let s = scene(&format!(
        r#"
        [camera]
        eye = [0, 0, 0]
        look_at = [0, 0, 1]
        vfov_deg = 60
        width = 8
        height = 8
        [materials.wall]
        type = "lambertian"
        albedo = {rho}
        [[objects]]
        name = "shell"
        material = "wall"
        sphere = {{ center = [0, 0, 0], radius = 2 }}
        [[lights]]
        type = "area"
        object = "shell"
        radiance = {le}
        two_sided = true
        "#
    ));
    for d in [1u32, 2, 4] {
        let st = settings(IntegratorKind::Path, d, 1000);
        let expect: f64 = (0..d).map(|k| rho.powi(k as i32)).sum::<f64>() * le * y_of_one();
        let (m, se) = region_stats(&s, &st, 30 + d as u64, 48, 1, |_, _| true);
        assert_close(&format!("max_depth {d}"), m, se, expect, 4.5);
    }
}

/// A large grey plane at y = 0 under a rectangular light `2a`×`2b` at height `h` centred above the
/// origin, facing down; camera looking at the origin from the side through a narrow field of view.
fn plane_under_rect_light(rho: f64, l: f64, a: f64, b: f64, h: f64) -> String {
    format!(
        r#"
        unit = "m"
        [camera]
        eye = [0, 0.6, -2.0]
        look_at = [0, 0, 0]
        vfov_deg = 0.5
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
        [[objects]]
        name = "lamp"
        material = "black"
        quad = [[{a}, {h}, {b}], [-{a}, {h}, {b}], [-{a}, {h}, -{b}], [{a}, {h}, -{b}]]
        [[lights]]
        type = "area"
        object = "lamp"
        radiance = {l}
        "#
    )
}

#[test]
fn direct_lighting_of_a_plane_by_a_rectangular_area_light_matches_the_form_factor() {
    // L_o = ρ/π · E with E = π L F, F the differential-area-to-rectangle form factor (4 corners).
    let (rho, l, a, b, h) = (0.5, 2.0, 0.3, 0.15, 0.4);
    let s = scene(&plane_under_rect_light(rho, l, a, b, h));
    let f = 4.0 * form_factor_corner(a, b, h);
    let expect = rho * l * f * y_of_one();
    for (kind, seed) in [(IntegratorKind::Direct, 41u64), (IntegratorKind::Path, 42)] {
        let (m, se) = region_stats(&s, &settings(kind, 8, 5), seed, 400, 1, |_, _| true);
        assert_close(&format!("{kind:?}"), m, se, expect, 4.5);
    }
}

#[test]
fn path_and_direct_agree_on_a_one_bounce_scene() {
    // The plane cannot see itself and the lamp is black: every path has at most one bounce, so
    // the path tracer and the direct integrator estimate the same image. Compared region by region, tolerance from both standard errors.
    let s = scene(
        r#"
        [camera]
        eye = [0, 1.5, -2.5]
        look_at = [0, 0, 0]
        vfov_deg = 50
        width = 16
        height = 16
        [materials.grey]
        type = "lambertian"
        albedo = { rgb = [0.7, 0.4, 0.2] }
        [materials.black]
        type = "black"
        [[objects]]
        name = "plane"
        material = "grey"
        quad = [[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]]
        [[objects]]
        name = "lamp"
        material = "black"
        quad = [[0.5, 0.8, 0.2], [-0.5, 0.8, 0.2], [-0.5, 0.8, -0.2], [0.5, 0.8, -0.2]]
        [[lights]]
        type = "area"
        object = "lamp"
        radiance = { blackbody = 4000, scale = 3 }
        "#,
    );
    for (ri, rj) in [(0u32, 0u32), (1, 1), (2, 3), (3, 2)] {
        let region = |i: u32, j: u32| i / 4 == ri && j / 4 == rj;
        for c in 0..3 {
            let (m1, s1) = region_stats(&s, &settings(IntegratorKind::Path, 8, 5), 50, 48, c, region);
            let (m2, s2) = region_stats(&s, &settings(IntegratorKind::Direct, 8, 5), 51, 48, c, region);
            let se = (s1 * s1 + s2 * s2).sqrt();
            assert!((m1 - m2).abs() <= 4.5 * se + 1e-7, "region ({ri},{rj}) c{c}: path {m1} ± {s1}, direct {m2} ± {s2}");
        }
    }
}

#[test]
fn direct_light_and_bsdf_samples_each_give_the_form_factor() {
    // `direct` with light samples only, BSDF samples only, and MIS over several of each: three
    // estimators of the same closed form (the plane under a rectangle of the test above).
    let (rho, l, a, b, h) = (0.5, 2.0, 0.3, 0.15, 0.4);
    let expect = rho * l * 4.0 * form_factor_corner(a, b, h) * y_of_one();
    for (n_e, n_b, seed) in [(1u32, 0u32, 43u64), (0, 1, 44), (2, 3, 45)] {
        let text = plane_under_rect_light(rho, l, a, b, h) + &format!("\n[integrator]\nemitter_samples = {n_e}\nbsdf_samples = {n_b}\n");
        let s = scene(&text);
        let (m, se) = region_stats(&s, &settings(IntegratorKind::Direct, 8, 5), seed, 400, 1, |_, _| true);
        assert_close(&format!("direct, {n_e} light and {n_b} BSDF samples"), m, se, expect, 4.5);
    }
}

#[test]
fn environment_and_lamp_share_the_light_samples_and_the_plane_gets_both() {
    // The plane under the rectangle, with a uniform environment L_e as well. The lamp's back is
    // black and hides L_e over its solid angle, so the plane's irradiance is
    // π (L F + L_e (1 − F)) and it returns ρ (L F + L_e (1 − F)) (no other bounce exists).
    // By power the environment (4π² r² L_e, r the scene's radius) would take almost every light
    // sample; capped, it takes half.
    let (rho, l, a, b, h, le) = (0.5, 2.0, 0.3, 0.15, 0.4, 0.2);
    let text = plane_under_rect_light(rho, l, a, b, h) + &format!("\n[[lights]]\ntype = \"environment\"\nradiance = {le}\n");
    let s = scene(&text);
    assert_eq!(s.lights.len(), 2);
    let env = s.environment.unwrap() as usize;
    let powers: Vec<f32> = s.lights.iter().map(|x| x.power_w(20.0 * 2f32.sqrt())).collect();
    assert!(powers[env] / (powers[0] + powers[1]) > 0.99, "{powers:?}");
    assert!((s.light_pmf[env] - 0.5).abs() < 1e-6 && (s.light_pmf[1 - env] - 0.5).abs() < 1e-6, "{:?}", s.light_pmf);
    let f = 4.0 * form_factor_corner(a, b, h);
    let expect = rho * (l * f + le * (1.0 - f)) * y_of_one();
    for (kind, seed) in [(IntegratorKind::Direct, 48u64), (IntegratorKind::Path, 49)] {
        let (m, se) = region_stats(&s, &settings(kind, 8, 5), seed, 200, 1, |_, _| true);
        assert_close(&format!("lamp and environment, {kind:?}"), m, se, expect, 4.5);
    }
    // A faint environment keeps its share by power: the cap only lowers it.
    let faint = scene(&(plane_under_rect_light(rho, l, a, b, h) + "\n[[lights]]\ntype = \"environment\"\nradiance = 1e-9\n"));
    let env = faint.environment.unwrap() as usize;
    assert!(faint.light_pmf[env] < 1e-3, "{:?}", faint.light_pmf);
}

#[test]
fn direct_shows_the_environment_in_a_smooth_dielectric() {
    // A smooth glass plane (n = 1.5) over a black plane under a uniform environment L, seen at
    // 45° through a narrow field of view: the reflection is R(45°) L (Fresnel, unpolarised), the
    // refracted ray ends on the black plane. Light samples cannot reach a delta BSDF, so only the
    // BSDF samples find it; with bsdf_samples = 0 the plane is black.
    let (n, l): (f64, f64) = (1.5, 1.3);
    let ci = (45f64).to_radians().cos();
    let ct = (1.0 - (1.0 - ci * ci) / (n * n)).sqrt();
    let rs = ((ci - n * ct) / (ci + n * ct)).powi(2);
    let rp = ((n * ci - ct) / (n * ci + ct)).powi(2);
    let r = 0.5 * (rs + rp);
    let text = |n_b: u32| {
        format!(
            r#"
            unit = "m"
            [camera]
            eye = [0, 2, -2]
            look_at = [0, 0, 0]
            vfov_deg = 0.5
            width = 4
            height = 4
            [integrator]
            bsdf_samples = {n_b}
            [materials.glass]
            type = "dielectric"
            ior = {n}
            [materials.black]
            type = "black"
            [[objects]]
            material = "glass"
            quad = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]
            [[objects]]
            material = "black"
            quad = [[-20, -0.5, -20], [-20, -0.5, 20], [20, -0.5, 20], [20, -0.5, -20]]
            [[lights]]
            type = "environment"
            radiance = {l}
            "#
        )
    };
    let (m, se) = region_stats(&scene(&text(1)), &settings(IntegratorKind::Direct, 8, 5), 46, 32, 1, |_, _| true);
    assert_close("glass plane, direct", m, se, r * l * y_of_one(), 4.5);
    assert!((r - 0.0503).abs() < 1e-3, "Fresnel at 45° for n = 1.5: {r}");
    let (m0, _) = region_stats(&scene(&text(0)), &settings(IntegratorKind::Direct, 8, 5), 47, 4, 1, |_, _| true);
    assert_eq!(m0, 0.0, "light samples alone cannot see a smooth surface's reflection");
}

#[test]
fn point_spot_and_directional_lights_give_their_irradiance() {
    // Point light of intensity I at height h above the plane: L_o = ρ/π · I/h².
    // Spot light inside its cone: the same; a directional light at 60° from the normal: ρ/π · E cos 60°.
    let (rho, i, h) = (0.5, 2.0, 0.5);
    let base = |light: &str| {
        format!(
            r#"
            [camera]
            eye = [0, 0.6, -2.0]
            look_at = [0, 0, 0]
            vfov_deg = 0.5
            width = 4
            height = 4
            [materials.grey]
            type = "lambertian"
            albedo = {rho}
            [[objects]]
            name = "plane"
            material = "grey"
            quad = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]
            {light}
            "#
        )
    };
    let point = scene(&base(&format!("[[lights]]\ntype = \"point\"\nposition = [0, {h}, 0]\nintensity = {i}")));
    let spot = scene(&base(&format!(
        "[[lights]]\ntype = \"spot\"\nposition = [0, {h}, 0]\nlook_at = [0, 0, 0]\ncone_deg = 30\nfalloff_start_deg = 20\nintensity = {i}"
    )));
    let spot_away = scene(&base(&format!(
        "[[lights]]\ntype = \"spot\"\nposition = [0, {h}, 0]\nlook_at = [5, 0, 0]\ncone_deg = 30\nintensity = {i}"
    )));
    let dir = scene(&base("[[lights]]\ntype = \"directional\"\ndirection = [0.8660254, -0.5, 0]\nirradiance = 3"));
    let expect_point = rho / PI * i / (h * h) * y_of_one();
    for (s, expect, name) in [
        (&point, expect_point, "point"),
        (&spot, expect_point, "spot"),
        (&spot_away, 0.0, "spot outside cone"),
        (&dir, rho / PI * 3.0 * 0.5 * y_of_one(), "directional"),
    ] {
        for kind in [IntegratorKind::Direct, IntegratorKind::Path] {
            let (m, se) = region_stats(s, &settings(kind, 8, 5), 60, 64, 1, |_, _| true);
            assert_close(&format!("{name} {kind:?}"), m, se, expect, 4.5);
        }
    }
}

/// Ambient occlusion seen by a camera looking straight down at the point (x, 0, z) through a tiny field of view.
fn ao_scene(x: f64, z: f64, objects: &str) -> Scene {
    scene(&format!(
        r#"
        [camera]
        eye = [{x}, 1, {z}]
        look_at = [{x}, 0, {z}]
        up = [0, 0, 1]
        vfov_deg = 0.05
        width = 2
        height = 2
        [integrator]
        type = "ao"
        [materials.white]
        type = "lambertian"
        albedo = 0.5
        [[objects]]
        name = "floor"
        material = "white"
        quad = [[-500, 0, -500], [-500, 0, 500], [500, 0, 500], [500, 0, -500]]
        {objects}
        "#
    ))
}

#[test]
fn ao_of_an_open_plane_is_one() {
    let s = ao_scene(0.3, -0.2, "");
    let (m, se) = region_stats(&s, &settings(IntegratorKind::Ao, 8, 5), 70, 16, 1, |_, _| true);
    assert!((m - 1.0).abs() < 1e-6 && se < 1e-6, "{m} ± {se}");
}

#[test]
fn ao_next_to_a_wall_matches_the_strip_form_factor() {
    // Floor point at distance x from a wall of height H (very long): the wall covers the form factor
    // F = ½(1 − x/√(x² + H²)) of the cosine-weighted hemisphere, so AO = ½(1 + x/√(x² + H²)).
    let (x, hh) = (0.1, 0.15);
    let wall = format!(
        "[[objects]]\nname = \"wall\"\nmaterial = \"white\"\nquad = [[0, 0, -500], [0, {hh}, -500], [0, {hh}, 500], [0, 0, 500]]"
    );
    let s = ao_scene(x, 0.0, &wall);
    let expect = 0.5 * (1.0 + x / (x * x + hh * hh).sqrt());
    let (m, se) = region_stats(&s, &settings(IntegratorKind::Ao, 8, 5), 71, 4000, 1, |_, _| true);
    assert_close("wall", m, se, expect, 4.5);
}

#[test]
fn ao_in_a_corner_of_three_perpendicular_planes_is_one_quarter() {
    // Floor and two tall perpendicular walls: a cosine-distributed direction escapes only when it
    // points away from both walls (d_x > 0 and d_z > 0), probability 1/4 by symmetry.
    let walls = "[[objects]]\nname = \"wx\"\nmaterial = \"white\"\nquad = [[0, 0, -0.001], [0, 500, -0.001], [0, 500, 500], [0, 0, 500]]\n\
                 [[objects]]\nname = \"wz\"\nmaterial = \"white\"\nquad = [[-0.001, 0, 0], [500, 0, 0], [500, 500, 0], [-0.001, 500, 0]]";
    let s = ao_scene(0.05, 0.03, walls);
    let (m, se) = region_stats(&s, &settings(IntegratorKind::Ao, 8, 5), 72, 4000, 1, |_, _| true);
    assert_close("corner", m, se, 0.25, 4.5);
}

#[test]
fn render_pass_is_deterministic_whatever_the_thread_count() {
    let mut s = Scene::cornell_box();
    s.set_resolution(24, 20);
    let st = IntegratorSettings::default();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut buf = vec![[0f32; 3]; 24 * 20];
        pool.install(|| render_pass(&s, &st, 99, 3, &mut buf));
        buf
    };
    let a = run(1);
    let b = run(3);
    assert!(a == b);
    let mut c = vec![[0f32; 3]; 24 * 20];
    render_pass(&s, &st, 99, 4, &mut c);
    assert!(a != c, "another pass gives other samples");
}

#[test]
fn furnace_camera_inside_an_emitting_lambertian_cube() {
    // The closed-sphere furnace with a triangle mesh: a cube of 12 triangles, all emitting L_e
    // (two-sided) with albedo ρ, seen from inside → L_e/(1−ρ). Exercises area sampling of a
    // multi-triangle emitter (CDF over triangles, pdf 1/A) and its MIS weights.
    let (rho, le) = (0.6f64, 0.8f64);
    let c = |x: i32, y: i32, z: i32| format!("[{x}, {y}, {z}]");
    let quads = [
        [c(0, 0, 0), c(1, 0, 0), c(1, 1, 0), c(0, 1, 0)],
        [c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)],
        [c(0, 0, 0), c(0, 1, 0), c(0, 1, 1), c(0, 0, 1)],
        [c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)],
        [c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)],
        [c(0, 1, 0), c(1, 1, 0), c(1, 1, 1), c(0, 1, 1)],
    ];
    let quads: Vec<String> = quads.iter().map(|q| format!("[{}]", q.join(", "))).collect();
    let s = scene(&format!(
        r#"
        [camera]
        eye = [0.3, 0.6, 0.4]
        look_at = [0.9, 0.5, 0.6]
        vfov_deg = 70
        width = 12
        height = 12
        [materials.wall]
        type = "lambertian"
        albedo = {rho}
        [[objects]]
        name = "box"
        material = "wall"
        quads = [{}]
        [[lights]]
        type = "area"
        object = "box"
        radiance = {le}
        two_sided = true
        "#,
        quads.join(", ")
    ));
    let st = settings(IntegratorKind::Path, 100_000, 5);
    let (m, se) = region_stats(&s, &st, 81, 64, 1, |_, _| true);
    assert_close("cube", m, se, le / (1.0 - rho) * y_of_one(), 4.5);
}
