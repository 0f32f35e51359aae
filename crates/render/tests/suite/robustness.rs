//! Inputs at the edge of the representable: geometry and lights beyond f32, malformed transforms,
//! user strings that would break the one-line error rule, forged checkpoint counters, and
//! reproducible EXR bytes. Each ends in a one-line refusal naming the field, or a correct result,
//! never a panic or a silently black image.

use glam::Vec3;
use render::accel::Accel;
use render::checkpoint::{Checkpoint, RenderIdentity, Run};
use render::film::Film;
use render::image_io::{write_image, Image};
use render::integrator::{render_pass, IntegratorKind, IntegratorSettings};
use render::math::geometry::{Aabb, Ray};
use render::medium::FreeFlightGrid;
use render::scene::Scene;
use render::shape::mesh::TriangleMesh;
use render::shape::sphere::Sphere;
use render::shape::Shape;
use std::path::{Path, PathBuf};

/// A folder of its own under the system's temporary folder, removed at the end.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("lucent-robustness-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A scene: a camera, the material `m` given by `material`, the objects and lights as written.
fn scene_text(material: &str, objects: &str, lights: &str) -> String {
    format!(
        r#"
unit = "m"
[camera]
eye = [0, 0, -3]
look_at = [0, 0, 0]
vfov_deg = 30
width = 8
height = 8
[materials.m]
{material}
{objects}
{lights}
"#
    )
}

const ENV: &str = "[[lights]]\ntype = \"environment\"\nradiance = 1";
const BALL: &str = "[[objects]]\nname = \"ball\"\nmaterial = \"m\"\nsphere = { center = [0, 0, 0], radius = 0.8 }";
const TRANSLUCENT: &str = "type = \"translucent\"\nsubsurface = { preset = \"Ketchup\" }";

fn parse_in(text: &str, dir: &Path) -> anyhow::Result<Scene> {
    Scene::from_toml_str(text, "edge.toml", dir)
}

/// The one-line error of a scene that must be refused, checked to mention every needle.
fn refused_in(text: &str, dir: &Path, needles: &[&str]) -> String {
    let e = match parse_in(text, dir) {
        Ok(_) => panic!("expected an error mentioning {needles:?} for:\n{text}"),
        Err(e) => format!("{e:#}"),
    };
    assert!(!e.contains('\n'), "error is not one line: {e}");
    for n in needles {
        assert!(e.contains(n), "error `{e}` does not mention `{n}`");
    }
    e
}

fn refused(text: &str, needles: &[&str]) -> String {
    refused_in(text, Path::new("."), needles)
}

#[test]
fn spheres_beyond_the_coordinate_limit_are_refused_naming_the_object() {
    // 4e38 is finite in the file (f64) but not in f32; 1e19 is finite in f32 but its square is not.
    for material in [TRANSLUCENT, "type = \"lambertian\"\nalbedo = 0.5"] {
        for (center, radius) in [("[0, 4e38, 0]", "1"), ("[0, 1e19, 0]", "1"), ("[0, 0, 0]", "1e30")] {
            let objects = format!("[[objects]]\nname = \"far\"\nmaterial = \"m\"\nsphere = {{ center = {center}, radius = {radius} }}");
            refused(&scene_text(material, &objects, ENV), &["objects[0] (far)", "beyond"]);
        }
    }
    // A transform can carry a sphere out of range too; the unit counts (1e17 km = 1e20 m).
    let scaled = "[[objects]]\nname = \"big\"\nmaterial = \"m\"\nsphere = { center = [0, 0, 0], radius = 1 }\ntransform = { scale = 1e30 }";
    refused(&scene_text(TRANSLUCENT, scaled, ENV), &["objects[0] (big)", "after the unit and transform"]);
    let km = scene_text("type = \"lambertian\"\nalbedo = 0.5", "[[objects]]\nmaterial = \"m\"\nsphere = { center = [1e17, 0, 0], radius = 1 }", ENV)
        .replace("unit = \"m\"", "unit = \"km\"");
    refused(&km, &["objects[0] (object0)", "beyond"]);
    // At the limit's scale but inside it, the scene loads.
    let near = "[[objects]]\nname = \"ok\"\nmaterial = \"m\"\nsphere = { center = [0, 1e17, 0], radius = 1 }";
    parse_in(&scene_text(TRANSLUCENT, near, ENV), Path::new(".")).unwrap_or_else(|e| panic!("{e:#}"));
}

#[test]
fn meshes_and_quads_beyond_the_limit_are_refused_also_as_medium_boundaries() {
    let t = Scratch::new("meshes");
    // A closed cube with one vertex at x = 3.4e38 (finite in f32), as a medium boundary.
    let mut obj = String::new();
    for (k, v) in [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]].iter().enumerate() {
        let x = if k == 6 { "3.4e38".to_string() } else { v[0].to_string() };
        obj.push_str(&format!("v {x} {} {}\n", v[1], v[2]));
    }
    for f in ["1 4 3 2", "5 6 7 8", "1 2 6 5", "2 3 7 6", "3 4 8 7", "4 1 5 8"] {
        obj.push_str(&format!("f {f}\n"));
    }
    std::fs::write(t.0.join("cube.obj"), obj).unwrap();
    let medium = "[[objects]]\nname = \"cube\"\nmaterial = \"m\"\nmesh = \"cube.obj\"\nmedium = { sigma_a_per_mm = 0.01, sigma_s_per_mm = 1, g = 0 }";
    refused_in(&scene_text("type = \"interface\"", medium, ENV), &t.0, &["objects[0] (cube)", "vertex", "3.4e38", "beyond"]);

    let quad = "[[objects]]\nname = \"wall\"\nmaterial = \"m\"\nquad = [[0, 0, 0], [1e30, 0, 0], [1e30, 1, 0], [0, 1, 0]]";
    refused(&scene_text("type = \"lambertian\"\nalbedo = 0.5", quad, ENV), &["objects[0] (wall)", "vertex", "beyond"]);
    let quads = "[[objects]]\nname = \"walls\"\nmaterial = \"m\"\nquads = [[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 0, 0], [1, 0, 0], [1, 3e38, 0], [0, 1, 0]]]";
    refused(&scene_text("type = \"lambertian\"\nalbedo = 0.5", quads, ENV), &["objects[0] (walls)", "beyond"]);
}

#[test]
fn a_transform_matrix_must_be_affine() {
    let m = |last: &str| {
        format!("{BALL}\ntransform = {{ matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], {last}] }}")
    };
    refused(&scene_text("type = \"lambertian\"\nalbedo = 0.5", &m("[0, 0, 0.5, 1]"), ENV), &["objects[0] (ball).transform.matrix", "last row must be [0, 0, 0, 1]"]);
    refused(&scene_text("type = \"lambertian\"\nalbedo = 0.5", &m("[0, 0, 0, 2]"), ENV), &["last row"]);
    parse_in(&scene_text("type = \"lambertian\"\nalbedo = 0.5", &m("[0, 0, 0, 1]"), ENV), Path::new(".")).unwrap_or_else(|e| panic!("{e:#}"));
}

#[test]
fn the_accelerator_and_the_free_flight_grid_survive_non_finite_geometry_and_rays() {
    // Built directly (the loader refuses these): spheres and triangles with inf and NaN coordinates.
    let inf = f32::INFINITY;
    let shapes = vec![
        Shape::Sphere(Sphere { center: Vec3::new(0.0, inf, 0.0), radius: 1.0 }),
        Shape::Sphere(Sphere { center: Vec3::new(f32::NAN, 0.0, 0.0), radius: 1.0 }),
        Shape::Sphere(Sphere { center: Vec3::ZERO, radius: 0.5 }),
        Shape::Mesh(TriangleMesh { positions: vec![Vec3::new(3.4e38, 0.0, 0.0), Vec3::new(-3.4e38, 1.0, 0.0), Vec3::new(0.0, f32::NAN, 2.0)], normals: None, uvs: None, indices: vec![[0, 1, 2]] }),
    ];
    let accel = Accel::build(shapes.clone());
    let finite = Ray::new(Vec3::new(0.0, 0.0, -3.0), Vec3::Z);
    let bad = [
        Ray::new(Vec3::new(f32::NAN, 0.0, -3.0), Vec3::Z),
        Ray::new(Vec3::new(0.0, inf, -3.0), Vec3::Z),
        Ray::new(Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 1.0)),
    ];
    // The finite ray still finds the finite sphere (at t = 2.5); the others hit nothing.
    let hit = accel.intersect(&finite).expect("the finite sphere is hit");
    assert!((hit.t - 2.5).abs() < 1e-5, "t = {}", hit.t);
    for r in &bad {
        assert!(accel.intersect(r).is_none());
        assert!(!accel.occluded(r));
    }
    let rays: Vec<Ray> = (0..16).map(|k| if k % 4 == 0 { finite } else { bad[k % 3] }).collect();
    let mut hits = vec![None; 16];
    accel.intersect_packet(&rays, &mut hits);
    accel.intersect_batch(&rays, &mut hits);
    for (k, h) in hits.iter().enumerate() {
        assert_eq!(h.is_some(), k % 4 == 0, "ray {k}");
    }
    // The grid over a region reaching 3.4e38 (whose size overflows f32) guarantees nothing (0).
    let region = Aabb { min: Vec3::splat(-1.0), max: Vec3::new(3.4e38, 1.0, 1.0) };
    let grid = FreeFlightGrid::build(&region, &shapes, 64);
    assert_eq!(grid.free_distance(Vec3::ZERO), 0.0);
    let region = Aabb { min: Vec3::splat(f32::NAN), max: Vec3::splat(inf) };
    assert_eq!(FreeFlightGrid::build(&region, &shapes, 64).free_distance(Vec3::ZERO), 0.0);
}

fn point_light(extra: &str) -> String {
    format!("[[lights]]\ntype = \"point\"\nposition = [0, 0, -2]\nintensity = 1\n{extra}")
}

fn mean_y(scene: &Scene) -> f64 {
    let (w, h) = scene.resolution();
    let mut buf = vec![[0f32; 3]; (w * h) as usize];
    let settings = IntegratorSettings { kind: IntegratorKind::Path, max_depth: 3, rr_depth: 5 };
    render_pass(scene, &settings, 7, 0, &mut buf);
    buf.iter().map(|p| p[1] as f64).sum::<f64>() / buf.len() as f64
}

#[test]
fn lights_beyond_the_emission_limit_are_refused_and_bright_ones_render_in_proportion() {
    let lamb = "type = \"lambertian\"\nalbedo = 0.5";
    refused(&scene_text(lamb, BALL, &point_light("scale = 1e39")), &["lights[0] (point).scale", "above"]);
    refused(&scene_text(lamb, BALL, &point_light("power_w = 1e308")), &["lights[0] (point).power_w"]);
    refused(&scene_text(lamb, BALL, "[[lights]]\ntype = \"environment\"\nradiance = 1e36"), &["lights[0] (environment): ", "1.000e36"]);
    refused(&scene_text(lamb, BALL, "[[lights]]\ntype = \"environment\"\nradiance = 1\nscale = 1e36"), &["lights[0] (environment).scale"]);
    let far = "[[lights]]\ntype = \"point\"\nposition = [0, 0, -1e30]\nintensity = 1";
    refused(&scene_text(lamb, BALL, far), &["lights[0] (point).position", "beyond"]);
    // Within the limit per nm, but the power over a scene of radius 1e17 m overflows f32.
    let huge = "[[objects]]\nmaterial = \"m\"\nsphere = { center = [0, 0, 0], radius = 1e17 }";
    refused(&scene_text(lamb, huge, "[[lights]]\ntype = \"environment\"\nradiance = 1e29"), &["lights[0]: its emitted power overflows f32"]);
    // Inside the limit, the image scales with the light: same seed, same paths, ×1e25 radiance.
    let one = mean_y(&parse_in(&scene_text(lamb, BALL, &point_light("")), Path::new(".")).unwrap());
    let bright = mean_y(&parse_in(&scene_text(lamb, BALL, &point_light("scale = 1e25")), Path::new(".")).unwrap());
    assert!(one > 0.0 && bright.is_finite());
    let ratio = bright / one / 1e25;
    assert!((ratio - 1.0).abs() < 1e-5, "bright / dim = {ratio:e} × 1e25");
}

#[test]
fn user_strings_in_errors_are_escaped_and_shortened() {
    let e = refused(&scene_text("type = \"x\\ny\"", BALL, ENV), &["materials.m.type", "`x\\ny`"]);
    assert!(e.contains("unknown material type"), "{e}");
    let long = "q".repeat(100_000);
    let e = refused(&scene_text(&format!("type = \"{long}\""), BALL, ENV), &["100000 characters"]);
    assert!(e.len() < 600, "{} characters: {}", e.len(), &e[..200]);
    // A long object name in the field label and a long unknown material reference.
    let objects = format!("[[objects]]\nname = \"{long}\"\nmaterial = \"{long}\"\nsphere = {{ center = [0, 0, 0], radius = 1 }}");
    let e = refused(&scene_text("type = \"lambertian\"\nalbedo = 0.5", &objects, ENV), &["unknown material"]);
    assert!(e.len() < 600, "{} characters", e.len());
    let e = refused(&scene_text("type = \"lambertian\"\nalbedo = 0.5", BALL, "[[lights]]\ntype = \"sun\\tlamp\"\nradiance = 1"), &["`sun\\tlamp`"]);
    assert!(!e.contains('\t'), "{e}");
}

#[test]
fn milk_errors_name_the_scene_keys_not_command_line_flags() {
    let blob = |milk: &str| format!("[[objects]]\nname = \"blob\"\nmaterial = \"m\"\nsphere = {{ center = [0, 0, 0], radius = 1 }}\nmedium = {{ milk = {{ {milk} }} }}");
    for (milk, key) in [
        ("fat_percent = -1", "objects[0] (blob).medium.milk.fat_percent"),
        ("fat_percent = 3, protein_percent = 101", "objects[0] (blob).medium.milk.protein_percent"),
        ("fat_percent = 3, pressure_mpa = -2", "objects[0] (blob).medium.milk.pressure_mpa"),
        ("fat_percent = 60, protein_percent = 50", "fat_percent + protein_percent"),
    ] {
        let e = refused(&scene_text("type = \"interface\"", &blob(milk), ENV), &[key]);
        assert!(!e.contains("--"), "error names a flag: {e}");
    }
}

#[test]
fn checkpoints_whose_pass_counters_overflow_are_refused() {
    let mut film = Film::new(2, 2);
    film.add_pass(&[[1.0; 3]; 4]);
    let identity = RenderIdentity {
        scene_hash: 1,
        scene_name: "forged".into(),
        width: 2,
        height: 2,
        settings: IntegratorSettings { kind: IntegratorKind::Path, max_depth: 8, rr_depth: 5 },
    };
    let good = Checkpoint { identity: identity.clone(), target_spp: None, runs: vec![Run { seed: 3, first_pass: 0, passes: 1 }], film: film.clone() };
    Checkpoint::from_bytes(&good.to_bytes()).unwrap();
    let forged = Checkpoint { runs: vec![Run { seed: 3, first_pass: u64::MAX, passes: 1 }], ..good.clone() };
    let e = format!("{:#}", Checkpoint::from_bytes(&forged.to_bytes()).unwrap_err());
    assert!(e.contains("overflow"), "{e}");
    // Runs whose passes add up past u64 (the film's count is forged to match modulo 2^64).
    let many = Checkpoint { runs: vec![Run { seed: 3, first_pass: 0, passes: u64::MAX }, Run { seed: 4, first_pass: 0, passes: 2 }], ..good.clone() };
    let e = format!("{:#}", Checkpoint::from_bytes(&many.to_bytes()).unwrap_err());
    assert!(e.contains("overflow"), "{e}");
}

#[test]
fn exr_output_is_byte_for_byte_reproducible() {
    let t = Scratch::new("exr");
    // Large enough for many compressed blocks, which the encoder compresses in parallel.
    let (w, h) = (512u32, 384u32);
    let mut state = 0x2545F4914F6CDD1Du64;
    let rgb: Vec<[f32; 3]> = (0..w * h)
        .map(|_| {
            let mut next = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 40) as f32 / (1u64 << 24) as f32
            };
            [next(), next(), next()]
        })
        .collect();
    let image = Image::from_rgb(w, h, rgb).unwrap();
    let first = t.0.join("a.exr");
    write_image(&first, &image, 0.0).unwrap();
    let bytes = std::fs::read(&first).unwrap();
    for k in 0..4 {
        let p = t.0.join(format!("b{k}.exr"));
        write_image(&p, &image, 0.0).unwrap();
        assert!(std::fs::read(&p).unwrap() == bytes, "write {k} differs from the first");
    }
    assert_eq!(render::image_io::read_image(&first).unwrap(), image);
}
