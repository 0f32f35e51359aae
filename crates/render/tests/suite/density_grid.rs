//! Media with a density grid (`medium::grid`, σ(λ, x) = σ(λ) ρ(x)) rendered by `volpath`:
//! a closed form for an absorber whose density varies across the image, agreement with the
//! homogeneous medium for a constant grid, a furnace with a strongly varying density, and the
//! loader's errors.

#[allow(unused_imports)]
use crate::common::*;

use render::integrator::{render_pass, IntegratorKind, IntegratorSettings};
use render::math::sampling::Pcg32;
use render::medium::grid::DensityGrid;
use render::scene::Scene;

fn volpath() -> IntegratorSettings {
    IntegratorSettings { kind: IntegratorKind::Volpath, max_depth: 100_000, rr_depth: 5 }
}

/// A ball of radius 1 mm with boundary `mat` and medium `medium` under a uniform environment of
/// radiance 1, seen along +z by an orthographic camera 2.4 mm wide (`w` × `w` pixels).
fn ball_scene(mat: &str, medium: &str, w: u32) -> String {
    let camera = format!("model = \"orthographic\"\neye = [0, 0, -5]\nlook_at = [0, 0, 0]\nview_width = 2.4\nwidth = {w}\nheight = {w}");
    medium_ball_scene(&camera, mat, medium)
}

/// An inline grid of `n` cells over the box ±`half` mm with densities `f(x, y, z)` at the cell
/// centres (mm).
fn inline_grid(n: [usize; 3], half: f64, mut f: impl FnMut(f64, f64, f64) -> f64) -> String {
    let mut v = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let c = |i: usize, n: usize| -half + (i as f64 + 0.5) * 2.0 * half / n as f64;
                v.push(format!("{}", f(c(i, n[0]), c(j, n[1]), c(k, n[2]))));
            }
        }
    }
    format!(
        "{{ resolution = [{}, {}, {}], values = [{}], min = [-{half}, -{half}, -{half}], max = [{half}, {half}, {half}] }}",
        n[0],
        n[1],
        n[2],
        v.join(", ")
    )
}

/// Mean Y over the image of `passes` one-sample-per-pixel `volpath` renders, and its standard
/// error (from the spread of the passes' means).
fn mean_y(mut s: Scene, passes: u64, seed: u64) -> (f64, f64) {
    s.integrator = volpath();
    pixels_with(&s, passes, seed)
}

/// A grey absorber (σ_a = 0.8 /mm, no scattering) whose density rises linearly across the
/// image, ρ = 1 + 0.9 x (x in mm), inside an index-matched ball of radius 1 mm: a camera ray at
/// (x, y) is attenuated by e^{−σ_a (1 + 0.9 x) · 2√(1 − x² − y²)}. The image's mean against that
/// closed form integrated over the view by the midpoint rule; the grid (5 cells a side over
/// ±1.25 mm) holds the linear ramp exactly over the ball (its outer centres lie at ±1 mm).
#[test]
fn absorbing_ramp_matches_the_closed_form_transmittance() {
    let grid = inline_grid([5, 5, 5], 1.25, |x, _, _| 1.0 + 0.9 * x);
    let medium = format!("{{ sigma_a_per_mm = 0.8, sigma_s_per_mm = 0, density = {grid} }}");
    let s = scene(&ball_scene(r#"type = "interface""#, &medium, 24));
    let (m, se) = mean_y(s, 64, 1);
    let y1 = y_of_one();
    let n = 1200;
    let half = 1.2;
    let mut sum = 0.0;
    for j in 0..n {
        for i in 0..n {
            let x = -half + (i as f64 + 0.5) * 2.0 * half / n as f64;
            let y = -half + (j as f64 + 0.5) * 2.0 * half / n as f64;
            let r2 = x * x + y * y;
            sum += if r2 < 1.0 { (-0.8 * (1.0 + 0.9 * x) * 2.0 * (1.0 - r2).sqrt()).exp() } else { 1.0 };
        }
    }
    let want = sum / (n * n) as f64 * y1;
    eprintln!("absorbing ramp: {m} ± {se}, closed form {want}");
    assert!(se < 1e-3, "se {se}");
    assert!((m - want).abs() < 4.0 * se + 1e-5, "mean Y {m} ± {se}, closed form {want}");
    // The same ramp mirrored (ρ = 1 − 0.9 x) gives the same mean; a uniform density of 1 does
    // not: the ramp's weight matters (e^{−a(1+bx)} is convex in x).
    let uniform = format!("{{ sigma_a_per_mm = 0.8, sigma_s_per_mm = 0, density = {} }}", inline_grid([2, 2, 2], 2.0, |_, _, _| 1.0));
    let (mu, seu) = mean_y(scene(&ball_scene(r#"type = "interface""#, &uniform, 24)), 64, 1);
    assert!((mu - m).abs() > 10.0 * (se + seu), "uniform {mu} against ramp {m}: the test would not see the ramp");
}

/// A constant grid of density 2.5 and a homogeneous medium with 2.5 times the coefficients are
/// the same medium: a chromatic, scattering, absorbing medium in a dielectric ball (η = 1.33)
/// gives the same X, Y, Z in both within their standard errors (independent seeds).
#[test]
fn constant_grid_equals_the_homogeneous_medium() {
    let sigma_s = "{ lambda_nm = [360, 550, 551, 830], values = [0.4, 0.4, 8, 8] }";
    let sigma_s_scaled = "{ lambda_nm = [360, 550, 551, 830], values = [1, 1, 20, 20] }";
    let grid = inline_grid([3, 2, 4], 1.5, |_, _, _| 2.5);
    let gridded = format!("{{ sigma_a_per_mm = 0.04, sigma_s_per_mm = {sigma_s}, g = 0.6, density = {grid} }}");
    let homogeneous = format!("{{ sigma_a_per_mm = 0.1, sigma_s_per_mm = {sigma_s_scaled}, g = 0.6 }}");
    let mat = "type = \"dielectric\"\nior = 1.33";
    let a = scene(&ball_scene(mat, &gridded, 16));
    let b = scene(&ball_scene(mat, &homogeneous, 16));
    let (ma, sa) = mean_y(a, 96, 11);
    let (mb, sb) = mean_y(b, 96, 12);
    eprintln!("constant grid {ma} ± {sa}, homogeneous {mb} ± {sb}");
    assert!(sa < 0.01 * ma && sb < 0.01 * mb, "standard errors {sa}, {sb}");
    assert!((ma - mb).abs() < 4.0 * (sa * sa + sb * sb).sqrt(), "grid {ma} ± {sa} against homogeneous {mb} ± {sb}");
}

/// An albedo grid of constant 0.6 on a constant density grid of 2: the medium is the
/// homogeneous one with σ_s' = 2 · 0.6 σ_s and σ_a' = 2 (σ_a + 0.4 σ_s) (σ_t unchanged), chromatic
/// σ_s behind a dielectric boundary; X, Y, Z agree within their standard errors.
#[test]
fn constant_albedo_grid_equals_the_homogeneous_medium() {
    let grid = inline_grid([2, 3, 2], 1.5, |_, _, _| 2.0);
    let albedo = inline_grid([3, 2, 2], 1.5, |_, _, _| 0.6);
    let sigma_s = "{ lambda_nm = [360, 550, 551, 830], values = [0.5, 0.5, 6, 6] }";
    // The density table with the albedo grid as one more key.
    let with_albedo = format!("{}, albedo = {albedo} }}", grid.strip_suffix(" }").unwrap());
    let gridded = format!("{{ sigma_a_per_mm = 0.05, sigma_s_per_mm = {sigma_s}, g = 0.6, density = {with_albedo} }}");
    // σ_s' = 1.2 σ_s; σ_a' = 2 (0.05 + 0.4 σ_s) = 0.1 + 0.8 σ_s.
    let homogeneous = "{ sigma_a_per_mm = { lambda_nm = [360, 550, 551, 830], values = [0.5, 0.5, 4.9, 4.9] }, sigma_s_per_mm = { lambda_nm = [360, 550, 551, 830], values = [0.6, 0.6, 7.2, 7.2] }, g = 0.6 }";
    let mat = "type = \"dielectric\"\nior = 1.33";
    let (ma, sa) = mean_y(scene(&ball_scene(mat, &gridded, 16)), 96, 21);
    let (mb, sb) = mean_y(scene(&ball_scene(mat, homogeneous, 16)), 96, 22);
    let (mc, sc) = mean_y(scene(&ball_scene(mat, &format!("{{ sigma_a_per_mm = 0.05, sigma_s_per_mm = {sigma_s}, g = 0.6, density = {grid} }}"), 16)), 96, 23);
    eprintln!("albedo grid {ma} ± {sa}, homogeneous {mb} ± {sb}, without the albedo grid {mc} ± {sc}");
    assert!((ma - mb).abs() < 4.0 * (sa * sa + sb * sb).sqrt(), "albedo grid {ma} ± {sa} against homogeneous {mb} ± {sb}");
    assert!((ma - mc).abs() > 10.0 * (sa * sa + sc * sc).sqrt(), "the albedo grid must darken the medium: {ma} against {mc}");
}

/// Furnace: a non-absorbing medium whose density varies from 0 to 4 over a few cells (random
/// values) and whose σ_s differs 60× between wavelengths, in an index-matched and in a dielectric
/// ball under a uniform environment of radiance 1, gives radiance 1: light is only redistributed.
#[test]
fn furnace_with_a_random_density_gives_the_environment() {
    let mut rng = Pcg32::new(5, 1);
    let grid = inline_grid([4, 4, 4], 1.2, |_, _, _| (rng.next_f32() * 4.0) as f64);
    let medium = format!("{{ sigma_a_per_mm = 0, sigma_s_per_mm = {{ lambda_nm = [360, 550, 551, 830], values = [1, 1, 15, 15] }}, g = 0.5, density = {grid} }}");
    for mat in [r#"type = "interface""#, "type = \"dielectric\"\nior = 1.33"] {
        let s = scene(&ball_scene(mat, &medium, 16));
        let (m, se) = mean_y(s, 96, 3);
        let y1 = y_of_one();
        eprintln!("furnace {mat}: {m} ± {se} (1 = {y1})");
        assert!(se < 0.005 * y1, "{mat}: se {se}");
        assert!((m - y1).abs() < 4.0 * se, "{mat}: furnace gives {m} ± {se}, expected {y1}");
    }
}

/// A Mitsuba volume file placed by its own box, by `min`/`max`, and scaled, against the
/// inline grid of the same values; bad files and keys are one-line errors naming the field.
#[test]
fn vol_files_load_and_bad_density_input_is_refused() {
    let dir = tmp_dir("density-grid");
    let values: Vec<f32> = (0..8).map(|i| 0.25 * i as f32).collect();
    std::fs::write(dir.join("g.vol"), DensityGrid::write_vol([2, 2, 2], &values, [-1.0; 3], [1.0; 3])).unwrap();
    let inline = "{ resolution = [2, 2, 2], values = [0, 0.25, 0.5, 0.75, 1, 1.25, 1.5, 1.75], min = [-1, -1, -1], max = [1, 1, 1] }";
    let render = |density: &str| {
        let medium = format!("{{ sigma_a_per_mm = 0.5, sigma_s_per_mm = 0, density = {density} }}");
        let s = load_in(&dir, &ball_scene(r#"type = "interface""#, &medium, 8));
        let mut buf = vec![[0f32; 3]; 64];
        render_pass(&s, &volpath(), 1, 0, &mut buf);
        buf
    };
    let a = render(inline);
    let b = render(r#"{ file = "g.vol" }"#);
    let c = render(r#"{ file = "g.vol", min = [-1, -1, -1], max = [1, 1, 1] }"#);
    let d = render(r#"{ file = "g.vol", scale = 2 }"#);
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert_ne!(a, d, "scale must change the image");
    let bad = |density: &str, needles: &[&str]| {
        let medium = format!("{{ sigma_a_per_mm = 0.5, sigma_s_per_mm = 0, density = {density} }}");
        let text = ball_scene(r#"type = "interface""#, &medium, 8);
        assert_one_line_error(Scene::from_toml_str(&text, "t.toml", &dir), needles);
    };
    std::fs::write(dir.join("short.vol"), &DensityGrid::write_vol([2, 2, 2], &values, [-1.0; 3], [1.0; 3])[..50]).unwrap();
    bad(r#"{ file = "short.vol" }"#, &["medium.density.file", "short.vol", "bytes"]);
    bad(r#"{ file = "missing.vol" }"#, &["medium.density.file", "missing.vol"]);
    bad(r#"{ resolution = [2, 1, 1], values = [1] , min = [0, 0, 0], max = [1, 1, 1] }"#, &["medium.density", "need 2 values"]);
    bad(r#"{ resolution = [2, 1, 1], values = [1, -2], min = [0, 0, 0], max = [1, 1, 1] }"#, &["medium.density", "≥ 0"]);
    bad(r#"{ resolution = [2, 1, 1], values = [1, 2] }"#, &["medium.density.min", "missing"]);
    bad(r#"{ resolution = [2, 1, 1], values = [1, 2], min = [0, 0, 0], max = [1, 0, 1] }"#, &["medium.density", "max > min"]);
    bad(r#"{ file = "g.vol", scale = -1 }"#, &["medium.density.scale"]);
    bad(r#"{ file = "g.vol", colour = 1 }"#, &["medium.density", "unknown key"]);
    bad(r#"{ file = "g.vol", min = [0, 0, 0] }"#, &["medium.density", "both min and max"]);
    bad(r#"{ file = "g.vol", albedo = { file = "g.vol" } }"#, &["medium.density.albedo", "[0, 1]"]);
    bad(r#"{ file = "g.vol", albedo = { file = "g.vol", scale = 0.5, albedo = { file = "g.vol" } } }"#, &["medium.density.albedo", "unknown key"]);
    // RGB albedos: a three-channel file against the same colours inline, bit for bit; a
    // three-channel grid is no density; colours outside [0, 1] and mixed values are refused.
    let colours: Vec<f32> = (0..24).map(|i| 0.04 * i as f32).collect();
    std::fs::write(dir.join("rgb.vol"), DensityGrid::write_vol_channels([2, 2, 2], 3, &colours, [-1.0; 3], [1.0; 3])).unwrap();
    let triples: Vec<String> = colours.chunks(3).map(|c| format!("[{}, {}, {}]", c[0], c[1], c[2])).collect();
    let scattering = |albedo: &str| {
        let medium = format!("{{ sigma_a_per_mm = 0.2, sigma_s_per_mm = 1, density = {{ file = \"g.vol\", albedo = {albedo} }} }}");
        let s = load_in(&dir, &ball_scene(r#"type = "interface""#, &medium, 8));
        let mut buf = vec![[0f32; 3]; 64];
        render_pass(&s, &volpath(), 1, 0, &mut buf);
        buf
    };
    let from_file = scattering(r#"{ file = "rgb.vol" }"#);
    assert_eq!(from_file, scattering(&format!("{{ resolution = [2, 2, 2], values = [{}], min = [-1, -1, -1], max = [1, 1, 1] }}", triples.join(", "))));
    assert_ne!(from_file, scattering(r#"{ file = "rgb.vol", scale = 0.5 }"#), "scale must change the image");
    bad(r#"{ file = "rgb.vol" }"#, &["medium.density", "one value per cell", "albedo"]);
    bad(r#"{ file = "g.vol", albedo = { file = "rgb.vol", scale = 2 } }"#, &["medium.density.albedo", "[0, 1]"]);
    bad(r#"{ file = "g.vol", albedo = { resolution = [2, 1, 1], values = [[0.5, 0.5, 0.5], 0.5], min = [0, 0, 0], max = [1, 1, 1] } }"#, &["medium.density.albedo.values", "[r, g, b]"]);
    bad(r#"{ file = "g.vol", albedo = { resolution = [2, 1, 1], values = [[0.5, 0.5, 0.5]], min = [0, 0, 0], max = [1, 1, 1] } }"#, &["medium.density.albedo.values", "need 2 values"]);
    bad(r#"{ resolution = [4294967296, 4294967296, 2], values = [1], min = [0, 0, 0], max = [1, 1, 1] }"#, &["medium.density.resolution", "too many cells"]);
}

/// Mean X, Y, Z over the image of `passes` one-sample-per-pixel `volpath` renders, and their
/// standard errors (from the spread of the passes' means).
fn mean_xyz(mut s: Scene, passes: u64, seed: u64) -> ([f64; 3], [f64; 3]) {
    s.integrator = volpath();
    let (w, h) = s.resolution();
    let mut buf = vec![[0f32; 3]; (w * h) as usize];
    let means: Vec<[f64; 3]> = (0..passes)
        .map(|p| {
            render_pass(&s, &s.integrator, seed, p, &mut buf);
            let n = buf.len() as f64;
            [0, 1, 2].map(|c| buf.iter().map(|xyz| xyz[c] as f64).sum::<f64>() / n)
        })
        .collect();
    let m = [0, 1, 2].map(|c| means.iter().map(|x| x[c]).sum::<f64>() / passes as f64);
    let se = [0, 1, 2].map(|c| (means.iter().map(|x| (x[c] - m[c]).powi(2)).sum::<f64>() / ((passes - 1) * passes) as f64).sqrt());
    (m, se)
}

/// A spectrum as an inline 1-nm table over 360–830 nm.
fn table(f: impl Fn(f64) -> f64) -> String {
    let l: Vec<String> = (360..=830).map(|l| l.to_string()).collect();
    let v: Vec<String> = (360..=830).map(|l| format!("{}", f(l as f64))).collect();
    format!("{{ lambda_nm = [{}], values = [{}] }}", l.join(", "), v.join(", "))
}

/// An RGB albedo grid of one colour on a constant density grid of 2: the medium is the
/// homogeneous one with σ_s'(λ) = 2 A(λ) σ_s and σ_a'(λ) = 2 (σ_a + (1 − A(λ)) σ_s), A the
/// colour's reflectance uplift (Jakob & Hanika 2019, `optics::uplift`), behind a dielectric
/// boundary; X, Y and Z agree within their standard errors, and the colour shows against the
/// grey albedo of the same luminance.
#[test]
fn constant_rgb_albedo_grid_equals_the_homogeneous_medium() {
    use optics::uplift::{Fit, SigmoidSpectrum};
    let colour = [0.85, 0.45, 0.15];
    let a = SigmoidSpectrum::reflectance_by(colour, Fit::Direct);
    let grid = inline_grid([2, 3, 2], 1.5, |_, _, _| 2.0);
    let cells: Vec<String> = (0..12).map(|_| format!("[{}, {}, {}]", colour[0], colour[1], colour[2])).collect();
    let rgb_albedo = format!("{{ resolution = [3, 2, 2], values = [{}], min = [-1.5, -1.5, -1.5], max = [1.5, 1.5, 1.5] }}", cells.join(", "));
    let with_albedo = |albedo: &str| format!("{{ sigma_a_per_mm = 0.05, sigma_s_per_mm = 1.5, g = 0.6, density = {}, albedo = {albedo} }} }}", grid.strip_suffix(" }").unwrap());
    let homogeneous = format!("{{ sigma_a_per_mm = {}, sigma_s_per_mm = {}, g = 0.6 }}", table(|l| 2.0 * (0.05 + 1.5 * (1.0 - a.eval(l)))), table(|l| 2.0 * 1.5 * a.eval(l)));
    let mat = "type = \"dielectric\"\nior = 1.33";
    let (ma, sa) = mean_xyz(scene(&ball_scene(mat, &with_albedo(&rgb_albedo), 16)), 96, 31);
    let (mb, sb) = mean_xyz(scene(&ball_scene(mat, &homogeneous, 16)), 96, 32);
    // The grey albedo of the colour's luminance.
    let y = 0.2126 * colour[0] + 0.7152 * colour[1] + 0.0722 * colour[2];
    let (mc, sc) = mean_xyz(scene(&ball_scene(mat, &with_albedo(&format!("{{ resolution = [1, 1, 1], values = [{y}], min = [-1.5, -1.5, -1.5], max = [1.5, 1.5, 1.5] }}")), 16)), 96, 33);
    eprintln!("RGB albedo grid {ma:?} ± {sa:?}, homogeneous {mb:?} ± {sb:?}, grey {mc:?} ± {sc:?}");
    for c in 0..3 {
        assert!((ma[c] - mb[c]).abs() < 4.0 * (sa[c] * sa[c] + sb[c] * sb[c]).sqrt(), "channel {c}: RGB albedo grid {} ± {} against homogeneous {} ± {}", ma[c], sa[c], mb[c], sb[c]);
    }
    // The colour: X/Z of the coloured medium above the grey one's by many standard errors.
    let (ra, rc) = (ma[0] / ma[2], mc[0] / mc[2]);
    let se = |m: [f64; 3], s: [f64; 3]| m[0] / m[2] * ((s[0] / m[0]).powi(2) + (s[2] / m[2]).powi(2)).sqrt();
    assert!(ra - rc > 10.0 * (se(ma, sa).powi(2) + se(mc, sc).powi(2)).sqrt(), "X/Z {ra} with the colour, {rc} grey");
}
