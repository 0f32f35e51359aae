//! The TOML scene format: the built-in Cornell box equals the file, geometry equals the published
//! OBJ, units, transforms, light power, and one-line errors naming file, line and field.

#[allow(unused_imports)]
use crate::common::*;

use render::shape::Shape;
use render::integrator::{render_pass, IntegratorSettings};
use render::light::Light;
use render::shape::mesh::TriangleMesh;
use render::scene::Scene;
use std::path::Path;


fn parse(text: &str) -> anyhow::Result<Scene> {
    Scene::from_toml_str(text, "bad.toml", &repo().join("scenes"))
}

const MINIMAL: &str = r#"
unit = "mm"
[camera]
eye = [0, 0, -10]
look_at = [0, 0, 0]
vfov_deg = 40
width = 8
height = 8
[materials.grey]
type = "lambertian"
albedo = 0.5
[[objects]]
name = "ball"
material = "grey"
sphere = { center = [0, 0, 0], radius = 1 }
[[objects]]
name = "panel"
material = "grey"
quad = [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]]
[[lights]]
type = "area"
object = "panel"
radiance = 1
"#;

#[test]
fn builtin_cornell_box_renders_exactly_like_the_scene_file() {
    let mut a = Scene::cornell_box();
    let mut b = Scene::load(&repo().join("scenes/cornell-box.toml")).unwrap();
    assert_eq!(a.resolution(), b.resolution());
    a.set_resolution(24, 24);
    b.set_resolution(24, 24);
    assert_eq!(a.content_hash(), b.content_hash());
    let st = IntegratorSettings::default();
    let mut ia = vec![[0f32; 3]; 24 * 24];
    let mut ib = vec![[0f32; 3]; 24 * 24];
    for pass in 0..3 {
        render_pass(&a, &st, 5, pass, &mut ia);
        render_pass(&b, &st, 5, pass, &mut ib);
        assert!(ia == ib, "pass {pass} differs");
    }
    assert!(ia.iter().any(|p| p[1] > 0.0));
}

#[test]
fn cornell_geometry_is_the_published_obj() {
    // Every object of the scene has the triangles of the OBJ group of the same name, in mm → m,
    // except the light, lowered by 0.1 mm below the ceiling.
    let s = Scene::cornell_box();
    let groups = TriangleMesh::load(&repo().join("crates/render/data/cornell-box/cbox.obj")).unwrap();
    assert_eq!(s.objects.len(), 8);
    for (k, obj) in s.objects.iter().enumerate() {
        let Shape::Mesh(m) = s.accel.shape(k as u32) else { panic!("{} is not a mesh", obj.name) };
        let g = groups.iter().find(|(n, _)| *n == obj.name).unwrap_or_else(|| panic!("no group {}", obj.name));
        let tri = |mesh: &TriangleMesh, t: usize| -> [glam::Vec3; 3] {
            let i = mesh.indices[t];
            [mesh.positions[i[0] as usize], mesh.positions[i[1] as usize], mesh.positions[i[2] as usize]]
        };
        assert_eq!(m.indices.len(), g.1.indices.len(), "{}", obj.name);
        let dy = if obj.name == "light" { -0.1 } else { 0.0 };
        for t in 0..m.indices.len() {
            let (a, b) = (tri(m, t), tri(&g.1, t));
            for v in 0..3 {
                let expect = (b[v] + glam::Vec3::new(0.0, dy, 0.0)) * 1e-3;
                assert!((a[v] - expect).length() < 1e-6, "{} triangle {t} vertex {v}: {:?} vs {:?}", obj.name, a[v], expect);
            }
        }
    }
    // The light emits the measured spectrum as radiance with scale 1, zero outside 400–700 nm,
    // downwards only.
    let li = s.objects.iter().find(|o| o.name == "light").unwrap().light.unwrap();
    let Light::Area { radiance, two_sided, area_m2, .. } = &s.lights[li as usize] else { panic!() };
    let radiance = radiance.as_constant().unwrap();
    assert!(!two_sided);
    assert!((area_m2 - 0.130 * 0.105).abs() < 1e-6);
    for (l, v) in [(400.0, 0.0), (450.0, 4.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4), (399.0, 0.0), (701.0, 0.0)] {
        assert!((radiance.eval(l) - v).abs() < 1e-5, "{l} nm: {}", radiance.eval(l));
    }
    // Camera: 39.3077° vertical field of view at (278, 273, −800) mm looking +z.
    assert!((s.camera.vfov_deg() - 39.3077).abs() < 1e-3);
    assert!((s.camera.eye() - glam::Vec3::new(0.278, 0.273, -0.8)).length() < 1e-6);
    assert!((s.camera.forward() - glam::Vec3::Z).length() < 1e-6);
}

#[test]
fn bunny_scene_loads_and_renders() {
    let mut s = Scene::load(&repo().join("scenes/bunny.toml")).unwrap_or_else(|e| panic!("{e:#}"));
    let Shape::Mesh(m) = s.accel.shape(0) else { panic!() };
    assert_eq!(m.indices.len(), 3674);
    // 9.66 units tall in cm → about 0.0966 m.
    let ymax = m.positions.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!((ymax - 0.09655).abs() < 1e-4, "{ymax}");
    s.set_resolution(16, 12);
    let mut buf = vec![[0f32; 3]; 16 * 12];
    render_pass(&s, &IntegratorSettings::default(), 1, 0, &mut buf);
    assert!(buf.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
    assert!(buf.iter().map(|p| p[1]).sum::<f32>() > 0.0);
}

#[test]
fn units_and_transforms_are_applied() {
    let s = parse(MINIMAL).unwrap();
    let Shape::Sphere(sp) = s.accel.shape(0) else { panic!() };
    assert!((sp.radius - 1e-3).abs() < 1e-9);
    let t = MINIMAL.replace(
        "sphere = { center = [0, 0, 0], radius = 1 }",
        "sphere = { center = [0, 0, 0], radius = 1 }\ntransform = { scale = 2, rotate = [0, 0, 1, 90], translate = [5, 0, 0] }",
    );
    let s = parse(&t).unwrap();
    let Shape::Sphere(sp) = s.accel.shape(0) else { panic!() };
    assert!((sp.radius - 2e-3).abs() < 1e-9);
    assert!((sp.center - glam::Vec3::new(5e-3, 0.0, 0.0)).length() < 1e-8);
    // Quad rotated 90° about z then translated: (1, 3, 1) → (−3, 1, 1) → (−3, 1, 11) mm.
    let t = MINIMAL.replace(
        "quad = [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]]",
        "quad = [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]]\ntransform = { rotate = [0, 0, 1, 90], translate = [0, 0, 10] }",
    );
    let s = parse(&t).unwrap();
    let Shape::Mesh(m) = s.accel.shape(1) else { panic!() };
    assert!(m.positions.iter().any(|p| (*p - glam::Vec3::new(-3e-3, 1e-3, 11e-3)).length() < 1e-8), "{:?}", m.positions);
    // Row-major matrix: translation in the last column.
    let t = MINIMAL.replace(
        "sphere = { center = [0, 0, 0], radius = 1 }",
        "sphere = { center = [0, 0, 0], radius = 1 }\ntransform = { matrix = [[1, 0, 0, 7], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]] }",
    );
    let Shape::Sphere(sp) = parse(&t).unwrap().accel.shape(0).clone() else { panic!() };
    assert!((sp.center - glam::Vec3::new(7e-3, 0.0, 0.0)).length() < 1e-8);
}

#[test]
fn power_scale_sets_the_emitted_power() {
    // A one-sided 2×2 mm panel emitting 3 W with a constant spectrum over 360–830 nm (471 1-nm
    // samples): radiance = Φ / (π A Σ s Δλ).
    let t = MINIMAL.replace("radiance = 1", "radiance = 1\npower_w = 3");
    let s = parse(&t).unwrap();
    let Light::Area { radiance, area_m2, .. } = &s.lights[0] else { panic!() };
    let radiance = radiance.as_constant().unwrap();
    let expect = 3.0 / (std::f64::consts::PI * (*area_m2 as f64) * 471.0);
    assert!(((radiance.eval(550.0) as f64) / expect - 1.0).abs() < 1e-5);
    assert!((area_m2 - 4e-6).abs() < 1e-10);
}

#[test]
fn rgb_albedo_never_exceeds_one_and_blackbody_peaks_at_scale() {
    let t = MINIMAL.replace("albedo = 0.5", "albedo = { rgb = [0.9, 0.1, 0.05] }").replace("radiance = 1", "radiance = { blackbody = 5000, scale = 2 }");
    let s = parse(&t).unwrap();
    let render::material::Material::Lambertian { albedo } = &s.materials[0] else { panic!() };
    assert!(albedo.as_constant().unwrap().samples().iter().all(|v| (0.0..=1.0).contains(v)));
    let Light::Area { radiance, .. } = &s.lights[0] else { panic!() };
    let radiance = radiance.as_constant().unwrap();
    // Wien: the 5000 K peak is at 579.6 nm.
    assert!((radiance.max_value() - 2.0).abs() < 1e-3);
    assert!(radiance.eval(580.0) > radiance.eval(450.0) && radiance.eval(580.0) > radiance.eval(750.0));
}

/// Asserts `text` fails with a one-line error mentioning every string in `needles`.
fn fails_with(text: &str, needles: &[&str]) {
    crate::common::assert_one_line_error(parse(text), needles);
}

#[test]
fn bad_input_gives_one_line_errors_naming_file_line_and_field() {
    fails_with(&MINIMAL.replace("vfov_deg = 40", "vfov_deg = 40\nfocus = 3"), &["bad.toml:", "focus"]);
    fails_with(&MINIMAL.replace("unit = \"mm\"", "unit = \"mm\"\ncolour = 1"), &["bad.toml:3:1:", "colour"]);
    fails_with(&MINIMAL.replace("[[lights]]", "[[lights]]\nbrightness = 3"), &["bad.toml:", "brightness"]);
    fails_with(&MINIMAL.replace("albedo = 0.5", "albedo = -0.5"), &["bad.toml:", "materials.grey.albedo", "negative"]);
    fails_with(&MINIMAL.replace("albedo = 0.5", "albedo = 1.5"), &["materials.grey.albedo", "exceeds 1"]);
    fails_with(&MINIMAL.replace("albedo = 0.5", "albedo = { rbg = [1, 0, 0] }"), &["materials.grey.albedo", "rbg"]);
    fails_with(&MINIMAL.replace("radius = 1", "radius = -1"), &["bad.toml:", "objects[0] (ball).sphere.radius", "positive"]);
    fails_with(&MINIMAL.replace("material = \"grey\"\nsphere", "material = \"gray\"\nsphere"), &["objects[0] (ball).material", "gray"]);
    fails_with(
        &MINIMAL.replace("sphere = { center = [0, 0, 0], radius = 1 }", "mesh = \"no/such/mesh.ply\""),
        &["bad.toml:", "objects[0] (ball).mesh", "no/such/mesh.ply"],
    );
    fails_with(
        &MINIMAL.replace("quad = [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]]", "quad = [[-1, 3, -1], [1, 3, -1], [1, 3, -1], [-1, 3, -1]]"),
        &["bad.toml:", "lights[0] (area).object", "zero area"],
    );
    fails_with(&MINIMAL.replace("radiance = 1", "radiance = 1\nscale = -2"), &["lights[0] (area).scale", "non-negative"]);
    fails_with(&MINIMAL.replace("radiance = 1", "radiance = { csv = \"missing.csv\" }"), &["lights[0] (area).radiance.csv", "missing.csv"]);
    fails_with(
        &MINIMAL.replace("radiance = 1", "radiance = { csv = \"../crates/render/data/cornell-box/cbox_reflectance.csv\", column = \"blue\" }"),
        &["radiance.column", "blue"],
    );
    fails_with(&MINIMAL.replace("unit = \"mm\"", "unit = \"furlong\""), &["bad.toml:2:", "unit", "furlong"]);
    fails_with(&MINIMAL.replace("width = 8", "width = 8,"), &["bad.toml:7:"]);
    fails_with(&MINIMAL.replace("vfov_deg = 40", "vfov_deg = 400"), &["bad.toml:", "camera", "field of view"]);
    fails_with(&MINIMAL.replace("object = \"panel\"", "object = \"lamp\""), &["lights[0] (area).object", "lamp"]);
    fails_with(&MINIMAL.replace("type = \"area\"", "type = \"laser\""), &["lights[0] (laser).type", "laser"]);
    fails_with(&MINIMAL.replace("radius = 1 }", "radius = nan }"), &["sphere.radius"]);
    let direct = |keys: &str| format!("{MINIMAL}\n[integrator]\ntype = \"direct\"\n{keys}\n");
    fails_with(&direct("emitter_samples = 0\nbsdf_samples = 0"), &["bad.toml:", "integrator.emitter_samples", "cannot both be 0"]);
    fails_with(&direct("bsdf_samples = 5000"), &["bad.toml:", "integrator.bsdf_samples", "[0, 1024]"]);
    fails_with(&direct("bsdf_samples = -1"), &["bad.toml:27:", "expected u32"]);
}

#[test]
fn missing_scene_file_is_an_error_naming_it() {
    let e = format!("{:#}", Scene::load(Path::new("/no/such/scene.toml")).err().unwrap());
    assert!(e.contains("/no/such/scene.toml") && !e.contains('\n'), "{e}");
}

#[test]
fn obj_groups_are_selected_by_name() {
    let obj = "../crates/render/data/cornell-box/cbox.obj";
    let t = MINIMAL.replace(
        "sphere = { center = [0, 0, 0], radius = 1 }",
        &format!("mesh = \"{obj}\"\ngroup = \"tallblock\"\ntransform = {{ translate = [0, 10, 0] }}"),
    );
    let s = parse(&t).unwrap_or_else(|e| panic!("{e:#}"));
    let Shape::Mesh(m) = s.accel.shape(0) else { panic!() };
    assert_eq!(m.indices.len(), 10); // 5 quads
    let ymax = m.positions.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!((ymax - 0.340).abs() < 1e-6, "{ymax}"); // 330 mm + 10 mm
    // Without a group, all 16 quads of the file form one object.
    let t = MINIMAL.replace("sphere = { center = [0, 0, 0], radius = 1 }", &format!("mesh = \"{obj}\""));
    let Shape::Mesh(m) = parse(&t).unwrap().accel.shape(0).clone() else { panic!() };
    assert_eq!(m.indices.len(), 32);
    fails_with(
        &MINIMAL.replace("sphere = { center = [0, 0, 0], radius = 1 }", &format!("mesh = \"{obj}\"\ngroup = \"teapot\"")),
        &["objects[0] (ball).group", "teapot", "tallblock"],
    );
}

#[test]
fn content_hash_covers_the_files_a_scene_reads_and_the_resolution() {
    let dir = std::env::temp_dir().join(format!("lucent-scene-hash-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = MINIMAL.replace("radiance = 1", "radiance = { csv = \"lamp.csv\" }");
    std::fs::write(dir.join("s.toml"), &scene).unwrap();
    std::fs::write(dir.join("lamp.csv"), "wavelength_nm,value\n400,1\n700,2\n").unwrap();
    let mut a = Scene::load(&dir.join("s.toml")).unwrap();
    let h1 = a.content_hash();
    assert_eq!(h1, Scene::load(&dir.join("s.toml")).unwrap().content_hash());
    std::fs::write(dir.join("lamp.csv"), "wavelength_nm,value\n400,1\n700,2.5\n").unwrap();
    let h2 = Scene::load(&dir.join("s.toml")).unwrap().content_hash();
    a.set_resolution(9, 8);
    let h3 = a.content_hash();
    std::fs::remove_dir_all(&dir).ok();
    assert!(h1 != h2 && h1 != h3 && h2 != h3);
}

#[test]
fn truncated_or_mutated_scene_files_never_panic() {
    // Every prefix of the Cornell box file (by lines) and 300 single-character mutations either
    // load or give a one-line error naming the file; none panics.
    let text = render::load::CORNELL_BOX_TOML;
    let dir = repo().join("scenes");
    let check = |t: &str| {
        let r = std::panic::catch_unwind(|| Scene::from_toml_str(t, "mutant.toml", &dir).map(|_| ()));
        match r {
            Err(_) => panic!("panicked on:\n{t}"),
            Ok(Err(e)) => {
                let m = format!("{e:#}");
                assert!(m.starts_with("mutant.toml") && !m.contains('\n'), "{m}");
            }
            Ok(Ok(())) => {}
        }
    };
    let lines: Vec<&str> = text.lines().collect();
    for k in 0..lines.len() {
        check(&lines[..k].join("\n"));
    }
    let mut rng = render::math::sampling::Pcg32::new(77, 3);
    let bytes: Vec<char> = text.chars().collect();
    let alphabet: Vec<char> = "0123456789-.=[]{},\"#xyz_ \nenan".chars().collect();
    for _ in 0..300 {
        let mut b = bytes.clone();
        let i = (rng.next_u32() as usize) % b.len();
        b[i] = alphabet[(rng.next_u32() as usize) % alphabet.len()];
        check(&b.iter().collect::<String>());
    }
}

/// `{ d65 = Y }` is CIE D65 with luminance Y: the same spectrum as an emitter's `rgb = [Y, Y, Y]`
/// (within the uplift's fit) and Y times the CIE table's shape (100 at 560 nm); its luminance
/// integral is Y; a negative value is an error naming the key.
#[test]
fn d65_spectrum_has_the_luminance_given() {
    let with = |r: &str| parse(&MINIMAL.replace("radiance = 1", &format!("radiance = {r}")));
    let get = |s: &Scene| {
        let li = s.objects.iter().find(|o| o.name == "panel").unwrap().light.unwrap();
        let Light::Area { radiance, .. } = &s.lights[li as usize] else { panic!() };
        radiance.as_constant().unwrap().clone()
    };
    let (ds, rs) = (get(&with("{ d65 = 2.5 }").unwrap()), get(&with("{ rgb = [2.5, 2.5, 2.5] }").unwrap()));
    let d = |l: f64| ds.eval(l as f32) as f64;
    let rgb = |l: f64| rs.eval(l as f32) as f64;
    let r560 = d(560.0);
    for l in [400.0, 450.0, 500.0, 600.0, 650.0, 700.0] {
        let want = optics::spectrum::d65_relative(l) / 100.0 * r560;
        assert!((d(l) - want).abs() < 1e-6 * r560, "{l} nm: {} against {want}", d(l));
        assert!((d(l) / rgb(l) - 1.0).abs() < 0.02, "{l} nm: d65 {} against rgb {}", d(l), rgb(l));
    }
    let y = optics::color::spectrum_to_xyz(d)[1];
    assert!((y - 2.5).abs() < 1e-3, "Y = {y}");
    let e = format!("{:#}", with("{ d65 = -1 }").err().unwrap());
    assert!(e.contains("d65") && e.contains("bad.toml"), "{e}");
}
