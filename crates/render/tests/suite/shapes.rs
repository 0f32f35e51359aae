//! `disk` and `cylinder` objects: their areas (π r², 2π r h), outlines, outward normals, Mitsuba 3's
//! texture coordinates, a disk lamp's irradiance on its axis (π L r²/(r² + d²), by light sampling
//! and by rendering), and one-line errors naming the field.

#[allow(unused_imports)]
use crate::common::*;

use glam::{Vec2, Vec3};
use render::integrator::{render_pass, IntegratorKind};
use render::light::Light;
use render::math::geometry::Ray;
use render::math::sampling::Pcg32;
use render::math::spectral::SampledWavelengths;
use render::scene::Scene;
use render::shape::mesh::TriangleMesh;
use render::shape::Shape;
use std::f64::consts::PI;
use std::path::Path;

fn parse(text: &str) -> anyhow::Result<Scene> {
    Scene::from_toml_str(text, "shapes.toml", Path::new("."))
}

/// A scene in metres with a grey material and the given objects and lights.
fn with(objects_and_lights: &str) -> String {
    format!(
        r#"
unit = "m"
[camera]
eye = [0, 0, -10]
look_at = [0, 0, 0]
vfov_deg = 40
width = 8
height = 8
[materials.grey]
type = "lambertian"
albedo = 0.5
{objects_and_lights}
"#
    )
}

fn mesh(s: &Scene, object: u32) -> &TriangleMesh {
    match s.accel.shape(object) {
        Shape::Mesh(m) => m,
        Shape::Sphere(_) => panic!("object {object} is a sphere"),
    }
}

fn area64(m: &TriangleMesh) -> f64 {
    (0..m.indices.len())
        .map(|i| {
            let [a, b, c] = m.triangle(i).map(|p| p.as_dvec3());
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

#[test]
fn disk_and_cylinder_areas_are_pi_r2_and_2_pi_r_h() {
    // In millimetres, one of each turned and scaled by the object transform (uniformly: the
    // closed forms then scale by s²).
    let text = with(
        r#"
[[objects]]
name = "disk"
material = "grey"
disk = { center = [10, -20, 5], normal = [1, 2, -2], radius = 30 }
[[objects]]
name = "tube"
material = "grey"
cylinder = { p0 = [0, 0, 0], p1 = [30, 40, 0], radius = 7 }
[[objects]]
name = "disk2"
material = "grey"
disk = { center = [0, 0, 0], normal = [0, 0, 1], radius = 4 }
transform = { scale = 2.5, rotate = [1, 1, 0, 37], translate = [100, 0, 0] }
[[objects]]
name = "tube2"
material = "grey"
cylinder = { p0 = [0, 0, -5], p1 = [0, 0, 15], radius = 3 }
transform = { scale = 0.5, rotate = [0, 1, 1, -71] }
[[lights]]
type = "area"
object = "tube"
radiance = 1
two_sided = true
"#,
    )
    .replace("unit = \"m\"", "unit = \"mm\"");
    let s = parse(&text).unwrap_or_else(|e| panic!("{e:#}"));
    let mm2 = 1e-6;
    let expect = [PI * 30.0 * 30.0 * mm2, 2.0 * PI * 7.0 * 50.0 * mm2, PI * 10.0 * 10.0 * mm2, 2.0 * PI * 1.5 * 10.0 * mm2];
    for (k, e) in expect.iter().enumerate() {
        let a = area64(mesh(&s, k as u32));
        // Inscribed polygons: a little smaller, by less than 10⁻⁴.
        let rel = a / e - 1.0;
        assert!(rel < 1e-6 && rel > -1e-4, "object {k}: area {a} m² vs {e} m² (relative {rel:e})");
    }
    // The emitter samples the same area.
    let Light::Area { area_m2, .. } = &s.lights[0] else { panic!() };
    assert!((*area_m2 as f64 / expect[1] - 1.0).abs() < 1e-4, "{area_m2}");
    // Outlines: every vertex of the disk lies within the circle and the rim's on it to 10⁻⁴.
    let m = mesh(&s, 0);
    let c = Vec3::new(10.0, -20.0, 5.0) * 1e-3;
    let n = Vec3::new(1.0, 2.0, -2.0) / 3.0;
    let dist: Vec<f32> = m.positions.iter().map(|p| (*p - c).length() / 30e-3).collect();
    assert!(m.positions.iter().all(|p| ((*p - c).dot(n) / 30e-3).abs() < 1e-5));
    assert!(dist.iter().all(|&d| d <= 1.0 + 1e-5), "{:?}", dist.iter().cloned().fold(0.0, f32::max));
    let rim = dist.iter().filter(|&&d| d > 0.99).count();
    assert_eq!(rim, render::shape::tessellate::SEGMENTS + 1);
    // The midpoints of the rim's edges are the outline's innermost points: 1 − cos(π/N).
    let inner = 1.0 - (PI / render::shape::tessellate::SEGMENTS as f64).cos();
    assert!(inner < 1e-4, "{inner}");
}

#[test]
fn cylinder_normals_point_outwards() {
    // Turned, non-uniformly scaled and mirrored by the transform: the front side and the shading
    // normals still face away from the axis.
    // A non-uniform scale makes the section an ellipse, whose normals are not radial: there the
    // test asks only that they point outwards.
    for (transform, min_cos) in [
        ("", 0.99999f32),
        ("transform = { rotate = [1, 2, 3, 50], translate = [1, 2, 3] }", 0.99999),
        ("transform = { scale = [-1, 2, 0.5] }", 0.0),
    ] {
        let text = with(&format!(
            r#"
[[objects]]
name = "tube"
material = "grey"
cylinder = {{ p0 = [0.2, -0.5, 0.1], p1 = [-0.3, 0.7, 0.4], radius = 0.25 }}
{transform}
"#
        ));
        let s = parse(&text).unwrap_or_else(|e| panic!("{e:#}"));
        let m = mesh(&s, 0);
        // The axis after the transform: the mean of each ring is on it; use the end rings.
        let ring = render::shape::tessellate::SEGMENTS + 1;
        let mean = |r: &[Vec3]| r[..ring - 1].iter().copied().sum::<Vec3>() / (ring - 1) as f32;
        let (a0, a1) = (mean(&m.positions[..ring]), mean(&m.positions[m.positions.len() - ring..]));
        let axis = (a1 - a0).normalize();
        let away = |p: Vec3| {
            let q = p - a0;
            q - axis * axis.dot(q)
        };
        for i in 0..m.indices.len() {
            let [a, b, c] = m.triangle(i);
            let ng = (b - a).cross(c - a).normalize();
            assert!(ng.dot(away((a + b + c) / 3.0).normalize()) > min_cos.min(0.9999), "{transform}: triangle {i}");
        }
        let ns = m.normals.as_ref().expect("smooth normals");
        for (p, n) in m.positions.iter().zip(ns) {
            assert!((n.length() - 1.0).abs() < 1e-5 && n.dot(away(*p).normalize()) > min_cos, "{transform}: {p} {n}");
        }
        // A ray from outside towards the axis meets the front side; one from the axis outwards
        // meets the back side; the shading normal is on the geometric one's side.
        let mid = (a0 + a1) * 0.5;
        let side = axis.any_orthonormal_vector();
        for (o, d) in [(mid + side * 3.0, -side), (mid, side)] {
            let ray = Ray::new(o, d);
            let hit = s.accel.intersect(&ray).expect("hit");
            let sp = s.accel.surface_point(&ray, &hit);
            let outward = away(sp.p).normalize();
            assert!(sp.ng.dot(outward) > min_cos.min(0.999) && sp.ns.dot(outward) > min_cos.min(0.999), "{transform}: {sp:?}");
        }
    }
}

#[test]
fn disk_and_cylinder_texture_coordinates_are_mitsubas() {
    // Points and (u, v) from Mitsuba 3.9.1: a `disk` with to_world = translate(c) ·
    // to_frame(Frame3f(n)) · scale(2) and a `cylinder` with p0, p1, radius 0.5, hit by rays
    // (`Scene.ray_intersect`, `si.uv`). (s, t) is Mitsuba's `coordinate_system(n)`.
    let text = with(
        r#"
[[objects]]
name = "disk"
material = "grey"
disk = { center = [1, 2, 3], normal = [0.3, 0.5, 0.8], radius = 2 }
[[objects]]
name = "tube"
material = "grey"
cylinder = { p0 = [11, 0, 0], p1 = [11, 3, 1], radius = 0.5 }
"#,
    );
    let s = parse(&text).unwrap_or_else(|e| panic!("{e:#}"));
    let n = Vec3::new(0.3, 0.5, 0.8).normalize();
    let (bs, bt) = (Vec3::new(0.949209, -0.084652, -0.303046), Vec3::new(-0.084652, 0.858913, -0.505076));
    let c = Vec3::new(1.0, 2.0, 3.0);
    for (rho, phi, uv) in [(0.5f32, 0.3f32, [0.25, 0.0477465]), (1.5, 2.2, [0.75, 0.350141]), (1.0, 4.3, [0.5, 0.684366]), (1.9, 6.1, [0.95, 0.970845])] {
        let p = c + rho * (phi.cos() * bs + phi.sin() * bt);
        let ray = Ray::new(p + n * 5.0, -n);
        let hit = s.accel.intersect(&ray).expect("disk hit");
        assert_eq!(hit.object, 0);
        let got = s.accel.uv(hit.object, hit.prim, hit.u, hit.v);
        assert!((got - Vec2::from(uv)).abs().max_element() < 2e-4, "disk at ρ {rho}, φ {phi}: {got} vs Mitsuba {uv:?}");
    }
    // Cylinder: Mitsuba's hit points and (u, v).
    for (p, out, uv) in [
        ([1.47767f32, 0.646726, 0.0598225], 0.3f32, [0.0477465, 0.2]),
        ([0.70575, 2.22783, 0.316497], 2.2, [0.350141, 0.7]),
        ([0.7996, 1.35514, 0.934576], 4.3, [0.684366, 0.5]),
        ([1.48009, 2.65582, 1.03254], 6.0, [0.95493, 0.9]),
    ] {
        let (cs, ct) = (Vec3::X, Vec3::new(0.0, 0.316228, -0.948683));
        let e = out.cos() * cs + out.sin() * ct;
        let p = Vec3::from(p) + Vec3::new(10.0, 0.0, 0.0);
        let ray = Ray::new(p + e * 2.0, -e);
        let hit = s.accel.intersect(&ray).expect("cylinder hit");
        assert_eq!(hit.object, 1);
        assert!((ray.at(hit.t) - p).length() < 1e-4, "{} vs {p}", ray.at(hit.t));
        let got = s.accel.uv(hit.object, hit.prim, hit.u, hit.v);
        assert!((got - Vec2::from(uv)).abs().max_element() < 2e-4, "cylinder at {p}: {got} vs Mitsuba {uv:?}");
    }
}

/// Mean and standard error over `n` light samples of the irradiance L cos θ / pdf that light 0 of
/// `s` gives a point `p` facing `normal` (wavelength 550 nm).
fn irradiance(s: &Scene, p: Vec3, normal: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let wl = SampledWavelengths::fixed([550.0, 500.0, 600.0, 450.0]);
    let mut rng = Pcg32::new(seed, 7);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let v = match s.lights[0].sample_li(p, rng.next_2d(), &wl) {
            Some(ls) if ls.pdf > 0.0 => (ls.li.x * ls.wi.dot(normal).max(0.0) / ls.pdf) as f64,
            _ => 0.0,
        };
        sum += v;
        sum2 += v * v;
    }
    let m = sum / n as f64;
    (m, ((sum2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
}

#[test]
fn disk_lamp_gives_the_closed_form_irradiance_on_its_axis() {
    // A disk of radius r and radiance L facing a point at distance d on its axis:
    // E = π L r² / (r² + d²). One-sided: nothing behind it; two-sided: the same behind it.
    let (l, r) = (2.5f64, 0.4f64);
    let lamp = |shape: &str, two_sided: bool| {
        with(&format!(
            "[[objects]]\nname = \"lamp\"\nmaterial = \"grey\"\n{shape}\n[[lights]]\ntype = \"area\"\nobject = \"lamp\"\nradiance = {l}\ntwo_sided = {two_sided}\n"
        ))
    };
    let c = Vec3::new(0.3, -0.2, 1.0);
    let plain = "disk = { center = [0.3, -0.2, 1.0], normal = [0, 0, -1], radius = 0.4 }";
    // The same disk written facing +z and turned half a turn about x by the transform.
    let turned = "disk = { center = [0.3, 0.2, -1.0], normal = [0, 0, 1], radius = 0.4 }\ntransform = { rotate = [1, 0, 0, 180] }";
    for (k, shape) in [plain, turned].into_iter().enumerate() {
        let s = parse(&lamp(shape, false)).unwrap_or_else(|e| panic!("{e:#}"));
        for (j, d) in [0.2f64, 0.9].into_iter().enumerate() {
            let p = c - Vec3::Z * d as f32;
            let expect = PI * l * r * r / (r * r + d * d);
            let (m, se) = irradiance(&s, p, Vec3::Z, 100_000, 10 + (k * 2 + j) as u64);
            assert!((m - expect).abs() < 4.5 * se + 1e-4 * expect, "{shape}, d {d}: {m} ± {se} vs {expect}");
            // Behind the one-sided lamp: dark.
            let (m, _) = irradiance(&s, c + Vec3::Z * d as f32, -Vec3::Z, 1000, 3);
            assert_eq!(m, 0.0, "{shape}: light behind a one-sided disk");
        }
    }
    let s = parse(&lamp(plain, true)).unwrap();
    let d = 0.5f64;
    let expect = PI * l * r * r / (r * r + d * d);
    let (m, se) = irradiance(&s, c + Vec3::Z * d as f32, -Vec3::Z, 100_000, 20);
    assert!((m - expect).abs() < 4.5 * se + 1e-4 * expect, "two-sided, behind: {m} ± {se} vs {expect}");
}

#[test]
fn plane_under_a_disk_lamp_renders_the_closed_form() {
    // A Lambertian plane (albedo ρ) under a one-sided disk lamp (radiance L, radius r, height h),
    // seen at the point below the centre through a narrow field of view: L_o = ρ L r²/(r² + h²).
    // `direct` with light samples only and with BSDF samples only (which must find the disk by
    // tracing rays), each over independent passes; tolerance 4.5 standard errors.
    let (rho, l, r, h) = (0.5f64, 2.0f64, 0.3f64, 0.4f64);
    let expect = rho * l * r * r / (r * r + h * h) * y_of_one();
    for (n_e, n_b, seed) in [(1u32, 0u32, 61u64), (0, 1, 62)] {
        let text = format!(
            r#"
unit = "m"
[camera]
eye = [0, 0.6, -2.0]
look_at = [0, 0, 0]
vfov_deg = 0.5
width = 4
height = 4
[integrator]
type = "direct"
emitter_samples = {n_e}
bsdf_samples = {n_b}
[materials.grey]
type = "lambertian"
albedo = {rho}
[materials.black]
type = "black"
[[objects]]
material = "grey"
quad = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]
[[objects]]
name = "lamp"
material = "black"
disk = {{ center = [0, {h}, 0], normal = [0, -1, 0], radius = {r} }}
[[lights]]
type = "area"
object = "lamp"
radiance = {l}
"#
        );
        let s = parse(&text).unwrap_or_else(|e| panic!("{e:#}"));
        let (w, hgt) = s.resolution();
        let mut buf = vec![[0f32; 3]; (w * hgt) as usize];
        let passes = 400;
        let mut vals = Vec::with_capacity(passes);
        for pass in 0..passes as u64 {
            render_pass(&s, &settings(IntegratorKind::Direct, 8, 5), seed, pass, &mut buf);
            vals.push(buf.iter().map(|p| p[1] as f64).sum::<f64>() / buf.len() as f64);
        }
        let m = vals.iter().sum::<f64>() / passes as f64;
        let se = (vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / ((passes - 1) * passes) as f64).sqrt();
        assert!((m - expect).abs() < 4.5 * se + 1e-4 * expect, "{n_e} light, {n_b} BSDF samples: {m} ± {se} vs {expect}");
    }
}

/// Asserts `text` fails with a one-line error mentioning every string in `needles`.
fn fails_with(text: &str, needles: &[&str]) {
    crate::common::assert_one_line_error(parse(text), needles);
}

#[test]
fn bad_disks_and_cylinders_give_one_line_errors_naming_the_field() {
    let disk = |d: &str| with(&format!("[[objects]]\nname = \"d\"\nmaterial = \"grey\"\ndisk = {{ {d} }}\n"));
    let cyl = |c: &str| with(&format!("[[objects]]\nname = \"c\"\nmaterial = \"grey\"\ncylinder = {{ {c} }}\n"));
    fails_with(&disk("center = [0, 0, 0], normal = [0, 0, 1], radius = -1"), &["shapes.toml:", "objects[0] (d).disk.radius", "positive"]);
    fails_with(&disk("center = [0, 0, 0], normal = [0, 0, 1], radius = nan"), &["objects[0] (d).disk.radius", "positive"]);
    fails_with(&disk("center = [0, 0, 0], normal = [0, 0, 1]"), &["objects[0] (d).disk.radius", "missing"]);
    fails_with(&disk("center = [0, 0, 0], normal = [0, 0, 0], radius = 1"), &["objects[0] (d).disk.normal", "non-zero"]);
    fails_with(&disk("normal = [0, 0, 1], radius = 1"), &["objects[0] (d).disk.center", "missing"]);
    fails_with(&disk("center = [0, 0, inf], normal = [0, 0, 1], radius = 1"), &["objects[0] (d).disk.center", "finite"]);
    fails_with(&disk("center = [0, 0, 0], normal = [0, 0, 1], radius = 1, height = 2"), &["shapes.toml:", "height"]);
    fails_with(&cyl("p0 = [0, 0, 0], p1 = [0, 0, 1], radius = 0"), &["objects[0] (c).cylinder.radius", "positive"]);
    fails_with(&cyl("p0 = [1, 2, 3], p1 = [1, 2, 3], radius = 1"), &["objects[0] (c).cylinder.p1", "differ from p0"]);
    fails_with(&cyl("p0 = [0, 0, 0], radius = 1"), &["objects[0] (c).cylinder.p1", "missing"]);
    fails_with(&cyl("p0 = [0, 0, 0], p1 = [0, 0, 1], radius = 1, caps = true"), &["shapes.toml:", "caps"]);
    fails_with(
        &with("[[objects]]\nname = \"c\"\nmaterial = \"grey\"\ncylinder = { p0 = [0, 0, 0], p1 = [0, 0, 1], radius = 1 }\nmedium = \"water\"\n"),
        &["objects[0] (c).medium", "open surface"],
    );
    fails_with(
        &with("[[objects]]\nname = \"c\"\nmaterial = \"grey\"\ncylinder = { p0 = [0, 0, 0], p1 = [0, 0, 1], radius = 1 }\nsphere = { center = [0, 0, 0], radius = 1 }\n"),
        &["objects[0] (c)", "exactly one shape", "cylinder"],
    );
}
