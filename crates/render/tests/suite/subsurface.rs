//! Point-cloud BSSRDF rendering: rejection control is unbiased, a flat
//! slab under uniform light reproduces the standard dipole's closed-form total diffuse
//! reflectance, zero albedo gives zero, the cost per shading point is far below M, bad input;
//! the rough boundary: roughness 0 is the smooth boundary bit for bit, the rough reflection lobe
//! integrates to its directional albedo and leaves the diffusion term (T12, T21 at the macro
//! normal) unchanged.

use glam::Vec3;
use render::math::geometry::Ray;
use render::integrator::path::{li_path_mode, subsurface_pass};
use render::math::spectral::SampledWavelengths;
use render::integrator::subsurface::SubsurfaceMode;
use optics::bssrdf::{OpticalProperties, StandardDipole};
use render::material::Material;
use render::math::sampling::Pcg32;
use render::scene::Scene;
use std::path::Path;

/// A 200 × 200 × 100 mm box (top face at y = 0) of a translucent material under a constant
/// environment of radiance 1. `sub` is the material's `subsurface` table.
fn slab_scene(sub: &str, ior: f64) -> Scene {
    slab_scene_lit(sub, ior, "type = \"environment\"\nradiance = 1")
}

/// The slab box of [`slab_scene`] with the given `[[lights]]` body.
fn slab_scene_lit(sub: &str, ior: f64, light: &str) -> Scene {
    slab_scene_with(sub, ior, "", light)
}

/// The slab box of [`slab_scene`] with extra lines in the material table (e.g. `roughness = 0.3`).
fn slab_scene_with(sub: &str, ior: f64, extra: &str, light: &str) -> Scene {
    slab_scene_objects(sub, ior, extra, "", light)
}

/// The slab box of [`slab_scene_with`] with extra TOML after the slab object (materials, objects).
fn slab_scene_objects(sub: &str, ior: f64, extra: &str, objects: &str, light: &str) -> Scene {
    let a = 100.0;
    let h = 100.0;
    let q = |c: [[f64; 3]; 4]| {
        format!(
            "[{}]",
            c.iter()
                .map(|p| format!("[{}, {}, {}]", p[0], p[1], p[2]))
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    let quads = [
        q([[-a, 0.0, -a], [-a, 0.0, a], [a, 0.0, a], [a, 0.0, -a]]),
        q([[-a, -h, -a], [a, -h, -a], [a, -h, a], [-a, -h, a]]),
        q([[a, -h, -a], [a, 0.0, -a], [a, 0.0, a], [a, -h, a]]),
        q([[-a, -h, -a], [-a, -h, a], [-a, 0.0, a], [-a, 0.0, -a]]),
        q([[-a, -h, a], [a, -h, a], [a, 0.0, a], [-a, 0.0, a]]),
        q([[-a, -h, -a], [-a, 0.0, -a], [a, 0.0, -a], [a, -h, -a]]),
    ]
    .join(", ");
    let text = format!(
        r#"unit = "mm"
[camera]
eye = [0, 300, 0.1]
look_at = [0, 0, 0]
vfov_deg = 40
width = 8
height = 8
[materials.slab]
type = "translucent"
ior = {ior}
{extra}
subsurface = {sub}
[[objects]]
name = "slab"
material = "slab"
quads = [{quads}]
{objects}
[[lights]]
{light}
"#
    );
    Scene::from_toml_str(&text, "slab.toml", Path::new(".")).unwrap()
}

/// 2∫₀¹ F(μ) μ dμ: cosine-weighted hemispherical Fresnel reflectance from outside (midpoint rule).
fn fresnel_hemispherical(eta: f64) -> f64 {
    let n = 200_000;
    (0..n)
        .map(|i| {
            let mu = (i as f64 + 0.5) / n as f64;
            optics::fresnel::fresnel_dielectric(mu, eta) * mu
        })
        .sum::<f64>()
        * 2.0
        / n as f64
}

fn mean_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (v / n).sqrt())
}

#[test]
fn slab_matches_closed_form_total_diffuse_reflectance() {
    // σ'_s = 1/mm, σ_a = 0.01/mm: σ_tr ≈ 0.174/mm, so the box's half-width (100 mm) and depth are
    // > 17/σ_tr and the slab is a half-space to e^{-17}. Uniform radiance L = 1 from above:
    // L_d(x_o, ω_o) = T21(ω_o) · R_d · (1 − F̄(η)) with R_d the closed form and F̄ = 2∫F μ dμ.
    let eta = 1.3;
    let scene = slab_scene(
        r#"{ model = "standard", sigma_s_per_mm = 1.0, sigma_a_per_mm = 0.01, points_per_pass = 65536 }"#,
        eta,
    );
    let dip = StandardDipole::new(&OpticalProperties {
        eta,
        sigma_s_per_m: 1000.0,
        sigma_a_per_m: 10.0,
        g: 0.0,
    })
    .unwrap();
    let fbar = fresnel_hemispherical(eta);
    let t21 = 1.0 - optics::fresnel::fresnel_dielectric(1.0, eta);
    let expected = t21 * dip.rd_closed_form() * (1.0 - fbar);
    let mut pass_means = Vec::new();
    for pass in 0..24u64 {
        let p = subsurface_pass(&scene, &scene.integrator, 7, pass).unwrap();
        let mut rng = Pcg32::new(99, pass);
        let mut acc = 0.0f64;
        let nq = 300;
        for k in 0..nq {
            // Shading points spread over the central 20 × 20 mm (all far from the edges).
            let x = -0.01 + 0.02 * ((k % 17) as f32 / 16.0);
            let z = -0.01 + 0.02 * ((k / 17 % 17) as f32 / 16.0);
            let l = p.radiance(0, Vec3::new(x, 0.0, z), Vec3::Y, Vec3::Y, &mut rng);
            acc += l.x as f64;
        }
        pass_means.push(acc / nq as f64);
    }
    let (m, se) = mean_se(&pass_means);
    println!(
        "slab: estimate {m:.5} ± {se:.5}, closed form {expected:.5} (R_d = {:.5}, F̄ = {fbar:.5})",
        dip.rd_closed_form()
    );
    assert!(se < 0.02 * expected, "too noisy to test: se {se}");
    assert!(
        (m - expected).abs() < 4.0 * se + 0.003 * expected,
        "estimate {m} ± {se} vs closed form {expected}"
    );
}

fn with_forced_acceptance(scene: &mut Scene) {
    for m in scene.materials.iter_mut() {
        if let Material::Translucent(t) = m {
            let mut t2 = (**t).clone();
            t2.rejection_control = false;
            *t = std::sync::Arc::new(t2);
        }
    }
}

#[test]
fn rejection_control_is_unbiased() {
    // For one cloud, the estimate with acceptance forced to 1 is deterministic; the mean of many
    // rejection-controlled estimates at the same point must agree with it within noise.
    // r0 = 0: the tutorial's pure exponential acceptance (the default); r0 = 8 and 1 transport
    // mean free paths (≈ 10 and 1.2 mm here): the (r0/d)³ falloff acts on far points, or on most points.
    for (model, r0) in [
        ("standard", 0.0),
        ("directional-corrected", 0.0),
        ("standard", 8.0),
        ("directional", 8.0),
        ("directional-corrected", 8.0),
        ("directional", 1.0),
    ] {
        let sub = format!(
            r#"{{ model = "{model}", sigma_s_per_mm = [1.2, 0.9, 0.6], sigma_a_per_mm = [0.02, 0.01, 0.05], g = 0.2, points_per_pass = 8192, rejection_radius_mfp = {r0} }}"#
        );
        let scene = slab_scene(&sub, 1.4);
        let mut forced = slab_scene(&sub, 1.4);
        with_forced_acceptance(&mut forced);
        let prc = subsurface_pass(&scene, &scene.integrator, 3, 0).unwrap();
        let pf = subsurface_pass(&forced, &forced.integrator, 3, 0).unwrap();
        // Centre of the top, near an edge, on a side face (normal +x), oblique view.
        let cases = [
            (Vec3::new(0.0, 0.0, 0.0), Vec3::Y, Vec3::Y),
            (
                Vec3::new(0.095, 0.0, 0.03),
                Vec3::Y,
                Vec3::new(0.3, 1.0, 0.0).normalize(),
            ),
            (
                Vec3::new(0.1, -0.004, 0.0),
                Vec3::X,
                Vec3::new(1.0, 0.2, 0.1).normalize(),
            ),
        ];
        for (xo, no, wo) in cases {
            let mut rng = Pcg32::new(5, 0);
            let reference = pf.radiance(0, xo, no, wo, &mut rng);
            let n = 4000;
            for lane in 0..4 {
                let mut rng = Pcg32::new(11, lane as u64);
                let xs: Vec<f64> = (0..n)
                    .map(|_| prc.radiance(0, xo, no, wo, &mut rng)[lane] as f64)
                    .collect();
                let (m, se) = mean_se(&xs);
                let r = reference[lane] as f64;
                println!("{model} {xo:?} lane {lane}: RC {m:.6} ± {se:.6}, forced {r:.6}");
                assert!(r > 0.0);
                assert!(
                    (m - r).abs() < 4.5 * se + 1e-4 * r,
                    "{model} at {xo:?} lane {lane}: RC {m} ± {se} vs forced {r}"
                );
            }
        }
    }
}

#[test]
fn zero_albedo_gives_zero_and_cost_is_sublinear() {
    // σ_s = 0: α' = 0, nothing diffuses back.
    let scene = slab_scene(
        r#"{ model = "directional", sigma_s_per_mm = 0.0, sigma_a_per_mm = 0.5, points_per_pass = 1024 }"#,
        1.3,
    );
    let p = subsurface_pass(&scene, &scene.integrator, 1, 0).unwrap();
    let mut rng = Pcg32::new(1, 1);
    for k in 0..100 {
        let x = (k as f32 - 50.0) * 1e-3;
        assert_eq!(
            p.radiance(0, Vec3::new(x, 0.0, 0.0), Vec3::Y, Vec3::Y, &mut rng),
            glam::Vec4::ZERO
        );
    }
    // Small albedo gives small radiance: α' = 0.01 → R_d tiny compared with α' = 0.99.
    let lo = slab_scene(
        r#"{ model = "standard", sigma_s_per_mm = 0.01, sigma_a_per_mm = 0.99, points_per_pass = 65536 }"#,
        1.3,
    );
    let p = subsurface_pass(&lo, &lo.integrator, 1, 0).unwrap();
    let m: f32 = (0..200)
        .map(|_| p.radiance(0, Vec3::ZERO, Vec3::Y, Vec3::Y, &mut rng).x)
        .sum::<f32>()
        / 200.0;
    assert!(m >= 0.0 && m < 2e-3, "albedo 0.01 gives {m}");
    // Cost: with M = 65536 points a query visits far fewer nodes + points than M.
    let big = slab_scene(
        r#"{ model = "standard", sigma_s_per_mm = 1.0, sigma_a_per_mm = 0.01, points_per_pass = 65536 }"#,
        1.3,
    );
    let p = subsurface_pass(&big, &big.integrator, 1, 0).unwrap();
    let (mut nodes, mut acc) = (0u64, 0u64);
    for _ in 0..100 {
        let (_, st) = p.radiance_stats(0, Vec3::ZERO, Vec3::Y, Vec3::Y, &mut rng);
        nodes += st.nodes;
        acc += st.accepted;
    }
    println!(
        "per query: {} nodes, {} accepted of {}",
        nodes / 100,
        acc / 100,
        p.point_count(0)
    );
    assert!(
        (nodes + acc) / 100 < 65536 / 20,
        "query cost {} not ≪ M",
        (nodes + acc) / 100
    );
}

#[test]
fn bad_translucent_input_is_rejected() {
    let base = |mat: &str, shape: &str| {
        format!(
            "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov_deg = 40\n[materials.m]\n{mat}\n[[objects]]\nmaterial = \"m\"\n{shape}\n"
        )
    };
    let sphere = "sphere = { center = [0, 0, 0], radius = 1 }";
    let cases = [
        (
            base(
                "type = \"translucent\"\nior = -1\nsubsurface = { sigma_s_per_mm = 1, sigma_a_per_mm = 0.1 }",
                sphere,
            ),
            "ior",
        ),
        (
            base(
                "type = \"translucent\"\nsubsurface = { sigma_s_per_mm = -1, sigma_a_per_mm = 0.1 }",
                sphere,
            ),
            "materials.m",
        ),
        (
            base(
                "type = \"translucent\"\nsubsurface = { preset = \"unobtainium\" }",
                sphere,
            ),
            "unobtainium",
        ),
        (
            base(
                "type = \"translucent\"\nsubsurface = { preset = \"marble\", bounces = 0 }",
                sphere,
            ),
            "subsurface.bounces",
        ),
        (
            base(
                "type = \"translucent\"\nsubsurface = { model = \"tripole\", preset = \"marble\" }",
                sphere,
            ),
            "tripole",
        ),
        (
            base(
                "type = \"translucent\"\nsubsurface = { preset = \"marble\", colour = 1 }",
                sphere,
            ),
            "colour",
        ),
        (
            base(
                "type = \"translucent\"\nsubsurface = { preset = \"marble\", rejection_radius_mfp = -2 }",
                sphere,
            ),
            "rejection_radius_mfp",
        ),
        (
            base(
                "type = \"translucent\"\nroughness = 1.5\nsubsurface = { preset = \"marble\" }",
                sphere,
            ),
            "materials.m: roughness: must be in [0, 1]",
        ),
        (
            base(
                "type = \"translucent\"\nroughness = \"rough\"\nsubsurface = { preset = \"marble\" }",
                sphere,
            ),
            "materials.m.roughness",
        ),
        (
            base(
                "type = \"translucent\"\nalpha = 0.1\nsubsurface = { preset = \"marble\" }",
                sphere,
            ),
            "materials.m.alpha",
        ),
        (base("type = \"translucent\"", sphere), "subsurface"),
        (
            base(
                "type = \"lambertian\"\nalbedo = 0.5\nsubsurface = { preset = \"marble\" }",
                sphere,
            ),
            "subsurface",
        ),
        // An open mesh (one quad) marked translucent.
        (
            base(
                "type = \"translucent\"\nsubsurface = { preset = \"marble\" }",
                "quad = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]",
            ),
            "closed",
        ),
    ];
    for (text, needle) in cases {
        let e = Scene::from_toml_str(&text, "bad.toml", Path::new("."))
            .err()
            .unwrap_or_else(|| panic!("accepted:\n{text}"));
        let msg = format!("{e:#}");
        assert!(
            msg.contains(needle) && msg.contains("bad.toml"),
            "message `{msg}` lacks `{needle}`"
        );
        assert!(!msg.contains('\n'), "multi-line: {msg}");
    }
    // Presets load (Jensen's marble with its own η).
    let ok = base("type = \"translucent\"\nsubsurface = { preset = \"marble\" }", sphere);
    let s = Scene::from_toml_str(&ok, "ok.toml", Path::new(".")).unwrap();
    assert!(matches!(&s.materials[0], Material::Translucent(t) if (t.eta - 1.5).abs() < 1e-6));
}

#[test]
fn example_scenes_load_and_render_a_pass() {
    // The potato sphere and the marble bunny load (closed meshes, coefficients from the media) and
    // one pass at low resolution gives finite, non-negative XYZ with some light on the object.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    for name in ["potato.toml", "marble-bunny.toml"] {
        let mut scene = Scene::load(&dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e:#}"));
        scene.set_resolution(24, 18);
        let mut xyz = vec![[0f32; 3]; 24 * 18];
        let mut settings = scene.integrator.clone();
        settings.kind = render::integrator::IntegratorKind::Path;
        render::integrator::render_pass(&scene, &settings, 1, 0, &mut xyz);
        assert!(
            xyz.iter().flatten().all(|v| v.is_finite() && *v >= -1e-3),
            "{name}: bad pixel"
        );
        let centre = xyz[9 * 24 + 12][1];
        assert!(centre > 0.0, "{name}: object centre is black");
    }
}

#[test]
fn passes_are_deterministic_for_resume() {
    // Checkpoint/resume and merging rely on a pass being a pure function of (seed, pass): the
    // point cloud and the pass wavelengths are too.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut scene = Scene::load(&dir.join("potato.toml")).unwrap();
    scene.set_resolution(16, 12);
    let settings = scene.integrator.clone();
    let mut a = vec![[0f32; 3]; 16 * 12];
    let mut b = a.clone();
    let mut c = a.clone();
    render::integrator::render_pass(&scene, &settings, 4, 3, &mut a);
    render::integrator::render_pass(&scene, &settings, 4, 3, &mut b);
    render::integrator::render_pass(&scene, &settings, 4, 4, &mut c);
    assert_eq!(a, b);
    assert_ne!(a, c);
}

#[test]
fn normal_incidence_matches_numerical_rd_for_both_dipoles() {
    // A directional light of irradiance E = 1 at normal incidence on the slab: the stored entries come
    // from light sampling only (a delta light), and L_d(x_o, +n) = T21(0) T12(0) E rd/π, with rd = π∫S_d dA
    // integrated numerically by optics::bssrdf (independent of the renderer's point cloud and tree).
    use optics::bssrdf::{DirectionalDipole, DirectionalLineDipole, StandardDipole};
    let eta = 1.3;
    let props = OpticalProperties { eta, sigma_s_per_m: 1000.0, sigma_a_per_m: 10.0, g: 0.0 };
    let t = 1.0 - optics::fresnel::fresnel_dielectric(1.0, eta);
    for (model, rd) in [
        ("standard", StandardDipole::new(&props).unwrap().rd_numerical()),
        ("directional", DirectionalDipole::new(&props).unwrap().rd_numerical()),
        (
            "directional-corrected",
            DirectionalLineDipole::new(&props).unwrap().rd_numerical(),
        ),
    ] {
        let sub = format!(r#"{{ model = "{model}", sigma_s_per_mm = 1.0, sigma_a_per_mm = 0.01, points_per_pass = 65536 }}"#);
        let scene = slab_scene_lit(&sub, eta, "type = \"directional\"\ndirection = [0, -1, 0]\nirradiance = 1");
        let expected = t * t * rd / std::f64::consts::PI;
        let mut pass_means = Vec::new();
        for pass in 0..16u64 {
            let p = subsurface_pass(&scene, &scene.integrator, 21, pass).unwrap();
            let mut rng = Pcg32::new(5, pass);
            let nq = 200;
            let acc: f64 = (0..nq)
                .map(|k| {
                    let x = -0.01 + 0.02 * ((k % 13) as f32 / 12.0);
                    let z = -0.01 + 0.02 * ((k / 13 % 13) as f32 / 12.0);
                    p.radiance(0, Vec3::new(x, 0.0, z), Vec3::Y, Vec3::Y, &mut rng).x as f64
                })
                .sum();
            pass_means.push(acc / nq as f64);
        }
        let (m, se) = mean_se(&pass_means);
        println!("{model}: estimate {m:.5} ± {se:.5}, T21 T12 rd/π = {expected:.5} (rd = {rd:.5})");
        assert!(se < 0.02 * expected, "{model}: too noisy: {se}");
        assert!((m - expected).abs() < 4.0 * se + 0.003 * expected, "{model}: {m} ± {se} vs {expected}");
    }
}

/// Directional albedo E(μo) = ∫ f_r cos θi dωi of the GGX (Trowbridge–Reitz, height-correlated
/// Smith G2) reflection lobe of a dielectric of index `eta` with roughness `alpha`, by a midpoint
/// product rule over (θi, φi) in f64: written here from the closed forms of D and Λ, independent
/// of the renderer's lobe, sampling and MIS.
fn ggx_reflection_albedo(mu_o: f64, alpha: f64, eta: f64) -> f64 {
    use std::f64::consts::PI;
    let a2 = alpha * alpha;
    let lambda = |cos: f64| {
        let tan2 = (1.0 - cos * cos).max(0.0) / (cos * cos);
        0.5 * (-1.0 + (1.0 + a2 * tan2).sqrt())
    };
    let wo = [(1.0 - mu_o * mu_o).max(0.0).sqrt(), 0.0, mu_o];
    let (nt, np) = (1200, 1200);
    let mut sum = 0.0;
    for i in 0..nt {
        let th = (i as f64 + 0.5) / nt as f64 * PI / 2.0;
        let (st, ct) = th.sin_cos();
        for j in 0..np {
            let ph = (j as f64 + 0.5) / np as f64 * 2.0 * PI;
            let wi = [st * ph.cos(), st * ph.sin(), ct];
            let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
            let hl = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            let h = [h[0] / hl, h[1] / hl, h[2] / hl];
            let ch = h[2];
            let tan2h = (1.0 - ch * ch).max(0.0) / (ch * ch);
            let d = a2 / (PI * ch.powi(4) * (a2 + tan2h).powi(2));
            let g2 = 1.0 / (1.0 + lambda(mu_o) + lambda(ct));
            let f = optics::fresnel::fresnel_dielectric(wo[0] * h[0] + wo[2] * h[2], eta);
            // f_r cos θi = D G2 F / (4 μo); dω = sin θ dθ dφ.
            sum += d * g2 * f / (4.0 * mu_o) * st;
        }
    }
    sum * (PI / 2.0 / nt as f64) * (2.0 * PI / np as f64)
}

/// Mean and standard error of `n` radiance estimates (lane 0; the scenes are grey) of camera paths
/// that hit the slab's top near the origin from direction `wo` (upper hemisphere).
fn boundary_estimate(scene: &Scene, mode: SubsurfaceMode, wo: Vec3, wl: Option<SampledWavelengths>, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Pcg32::new(seed, 1);
    let xs: Vec<f64> = (0..n)
        .map(|k| {
            let mut wl = wl.unwrap_or_else(|| SampledWavelengths::sample(rng.next_f32()));
            // x_o on a rank-1 (R2) lattice over the central 40 × 40 mm (80 mm ≈ 14/σ_tr from the
            // edges in the diffusion test): the cloud's noise is spatially correlated, so spreading
            // the queries averages it down.
            let (u, v) = ((k as f64 * 0.754_877_666_2).fract(), (k as f64 * 0.569_840_291).fract());
            let off = Vec3::new((-0.02 + 0.04 * u) as f32, 0.0, (-0.02 + 0.04 * v) as f32);
            let ray = Ray { o: off + wo * 0.05, d: -wo, t_min: 0.0, t_max: f32::INFINITY };
            li_path_mode(scene, &scene.integrator, ray, &mut wl, &mut rng, mode, 0.0).x as f64
        })
        .collect();
    mean_se(&xs)
}

#[test]
fn zero_roughness_is_the_smooth_boundary_bit_for_bit() {
    // The potato scene as shipped, with `roughness = 0` added, and with `roughness = 0.3`: one
    // pass of `path` (point cloud + boundary reflection) and of `volpath` (boundary as a dielectric).
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let text = std::fs::read_to_string(dir.join("potato.toml")).unwrap();
    assert!(text.contains("type = \"translucent\"\nior = 1.3\n"));
    let with = |r: &str| text.replace("type = \"translucent\"\nior = 1.3\n", &format!("type = \"translucent\"\nior = 1.3\nroughness = {r}\n"));
    let render = |t: &str, kind: render::integrator::IntegratorKind| {
        let mut scene = Scene::from_toml_str(t, "potato.toml", &dir).unwrap();
        scene.set_resolution(16, 12);
        let mut settings = scene.integrator.clone();
        settings.kind = kind;
        settings.max_depth = 12;
        let mut xyz = vec![[0f32; 3]; 16 * 12];
        render::integrator::render_pass(&scene, &settings, 4, 1, &mut xyz);
        xyz
    };
    for kind in [render::integrator::IntegratorKind::Path, render::integrator::IntegratorKind::Volpath] {
        let base = render(&text, kind);
        assert_eq!(base, render(&with("0"), kind), "{kind:?}: roughness = 0 differs from the smooth boundary");
        assert_ne!(base, render(&with("0.3"), kind), "{kind:?}: roughness = 0.3 has no effect");
    }
}

#[test]
fn rough_boundary_reflection_integrates_to_its_albedo() {
    // Uniform environment L = 1 above a slab (η = 1.5): with the cloud's term left out
    // (ReflectOnly), a camera path sees the boundary's surface reflection only, whose value is the
    // lobe's directional albedo E(μo): F(μo) for the smooth boundary, the GGX reflection lobe's
    // albedo for roughness r = 0.3 (α = 0.09), reached through light sampling + BSDF sampling + MIS.
    let eta = 1.5;
    let sub = r#"{ model = "standard", sigma_s_per_mm = 1.0, sigma_a_per_mm = 0.01, points_per_pass = 16 }"#;
    let env = "type = \"environment\"\nradiance = 1";
    let smooth = slab_scene_with(sub, eta, "", env);
    let rough = slab_scene_with(sub, eta, "roughness = 0.3", env);
    for mu in [1.0f64, 0.5, 0.2] {
        let wo = Vec3::new((1.0 - mu * mu).sqrt() as f32, mu as f32, 0.0);
        let f = optics::fresnel::fresnel_dielectric(mu, eta);
        let (ms, ses) = boundary_estimate(&smooth, SubsurfaceMode::ReflectOnly, wo, None, 64, 1);
        assert!((ms - f).abs() < 1e-5 * f.max(1.0) && ses < 1e-6, "smooth μo = {mu}: {ms} ± {ses} vs F = {f}");
        let e = ggx_reflection_albedo(mu, 0.09, eta);
        let (m, se) = boundary_estimate(&rough, SubsurfaceMode::ReflectOnly, wo, None, 20000, 2);
        println!("μo = {mu}: rough {m:.5} ± {se:.5}, E_GGX {e:.5}; smooth F = {f:.5}");
        assert!(se < 0.01 * e, "μo = {mu}: too noisy: {se}");
        assert!((m - e).abs() < 4.0 * se + 2e-3 * e, "μo = {mu}: rough boundary {m} ± {se} vs E = {e}");
    }
    // The lobe is not the mirror: at grazing view the rough albedo is measurably below F.
    let (e, f) = (ggx_reflection_albedo(0.2, 0.09, eta), optics::fresnel::fresnel_dielectric(0.2, eta));
    assert!(f - e > 0.01, "E = {e}, F = {f}");
}

#[test]
fn rough_boundary_keeps_the_diffusion_closed_form() {
    // The flat slab of `slab_matches_closed_form_total_diffuse_reflectance` with roughness 0.3,
    // seen by full camera paths (boundary lobe + BSSRDF term): L = E(μo) + T21(μo) R_d (1 − F̄),
    // the diffusion part unchanged because T12 and T21 stay at the macro normal.
    let eta = 1.3;
    let scene = slab_scene_with(
        r#"{ model = "standard", sigma_s_per_mm = 1.0, sigma_a_per_mm = 0.01, points_per_pass = 65536 }"#,
        eta,
        "roughness = 0.3",
        "type = \"environment\"\nradiance = 1",
    );
    let dip = StandardDipole::new(&OpticalProperties { eta, sigma_s_per_m: 1000.0, sigma_a_per_m: 10.0, g: 0.0 }).unwrap();
    let fbar = fresnel_hemispherical(eta);
    for (mu, seed) in [(1.0f64, 7u64), (0.5, 8)] {
        let wo = Vec3::new((1.0 - mu * mu).sqrt() as f32, mu as f32, 0.0);
        let t21 = 1.0 - optics::fresnel::fresnel_dielectric(mu, eta);
        let e = ggx_reflection_albedo(mu, 0.09, eta);
        let expected = e + t21 * dip.rd_closed_form() * (1.0 - fbar);
        let mut pass_means = Vec::new();
        for pass in 0..24u64 {
            let p = subsurface_pass(&scene, &scene.integrator, seed, pass).unwrap();
            let (m, _) = boundary_estimate(&scene, SubsurfaceMode::Bssrdf(&p), wo, Some(p.wl), 400, 100 + pass);
            pass_means.push(m);
        }
        let (m, se) = mean_se(&pass_means);
        println!("μo = {mu}: estimate {m:.5} ± {se:.5}, E + T21 R_d (1 − F̄) = {expected:.5} (E = {e:.5})");
        assert!(se < 0.02 * expected, "too noisy to test: se {se}");
        assert!((m - expected).abs() < 4.0 * se + 0.003 * expected, "μo = {mu}: {m} ± {se} vs {expected}");
    }
}


/// `bounces`: the slab of [`slab_scene`] under a Lambertian ceiling (albedo ρ = 0.8, emitting
/// L_e = 1 downwards, two-sided) 1 mm above its top face — two parallel plates, so every radiance
/// between them is uniform and the series has a closed form. With S = (1 − F̄)²R_d the slab's
/// subsurface reflectance for uniform light (the standard dipole's closed form; see
/// `slab_matches_closed_form_total_diffuse_reflectance`) and F̄ its Fresnel reflectance, the
/// ceiling's radiance when the cloud counts N subsurface bounces is
///   L₁ = L_e/(1 − ρF̄),  L_N = (L_e + ρS·L_{N−1})/(1 − ρF̄),
/// and the subsurface radiance of the slab at normal exit is T21(1)·R_d·(1 − F̄)·L_N. With N = 1
/// (the default) the slab's own subsurface light sent back by the ceiling is dropped (−30 % here);
/// N = 2 must count it once.
#[test]
fn bounces_count_light_returned_by_the_surroundings() {
    let eta = 1.3;
    let (rho, le) = (0.8, 1.0);
    let dip = StandardDipole::new(&OpticalProperties { eta, sigma_s_per_m: 1000.0, sigma_a_per_m: 10.0, g: 0.0 }).unwrap();
    let fbar = fresnel_hemispherical(eta);
    let t21 = 1.0 - optics::fresnel::fresnel_dielectric(1.0, eta);
    let s = (1.0 - fbar) * (1.0 - fbar) * dip.rd_closed_form();
    let mut l_n = le / (1.0 - rho * fbar);
    for n in 1..=2u32 {
        if n > 1 {
            l_n = (le + rho * s * l_n) / (1.0 - rho * fbar);
        }
        let expected = t21 * dip.rd_closed_form() * (1.0 - fbar) * l_n;
        let sub = format!(
            r#"{{ model = "standard", sigma_s_per_mm = 1.0, sigma_a_per_mm = 0.01, points_per_pass = 32768, bounces = {n} }}"#
        );
        let ceiling = "[[objects]]\nname = \"ceiling\"\nmaterial = \"ceiling\"\nquad = [[-400, 1, -400], [400, 1, -400], [400, 1, 400], [-400, 1, 400]]\n[materials.ceiling]\ntype = \"lambertian\"\nalbedo = 0.8";
        let scene = slab_scene_objects(&sub, eta, "", ceiling, "type = \"area\"\nobject = \"ceiling\"\nradiance = 1\ntwo_sided = true");
        let mut pass_means = Vec::new();
        for pass in 0..24u64 {
            let p = subsurface_pass(&scene, &scene.integrator, 11, pass).unwrap();
            let mut rng = Pcg32::new(5, pass);
            let mut acc = 0.0f64;
            let nq = 200;
            for k in 0..nq {
                let x = -0.01 + 0.02 * ((k % 15) as f32 / 14.0);
                let z = -0.01 + 0.02 * ((k / 15 % 15) as f32 / 14.0);
                acc += p.radiance(0, Vec3::new(x, 0.0, z), Vec3::Y, Vec3::Y, &mut rng).x as f64;
            }
            pass_means.push(acc / nq as f64);
        }
        let (m, se) = mean_se(&pass_means);
        println!("bounces = {n}: estimate {m:.5} ± {se:.5}, closed form {expected:.5} (L_N = {l_n:.4}, S = {s:.4}, F̄ = {fbar:.4})");
        assert!(se < 0.02 * expected, "too noisy to test: se {se}");
        assert!((m - expected).abs() < 4.0 * se + 0.01 * expected, "bounces = {n}: {m} ± {se} vs {expected}");
    }
}
