//! The evaluators of `scan::eval` on exact synthetic data.

use nalgebra::{Rotation3, Vector3};
use scan::calib::{DeviceCalibration, ProcamCalibration};
use scan::eval::*;

/// Points spread over a spherical cap by a fixed low-discrepancy sequence.
fn cap_points(c: [f64; 3], r: f64, n: usize, max_polar: f64) -> Vec<[f64; 3]> {
    (0..n)
        .map(|k| {
            let u = (k as f64 + 0.5) / n as f64;
            let th = (1.0 - u * (1.0 - max_polar.cos())).acos();
            let ph = k as f64 * 2.399_963_229_728_653; // golden angle
            [c[0] + r * th.sin() * ph.cos(), c[1] + r * th.sin() * ph.sin(), c[2] - r * th.cos()]
        })
        .collect()
}

/// Exact points on a 70-mm sphere, seen as a 60° cap (as a scanner sees it): both fits return
/// the centre and radius to 1e-9 relative, the geometric RMS is 0 to 1e-9.
#[test]
fn sphere_fit_exact_points() {
    let (c, r) = ([12.0, -7.5, 440.0], 70.0);
    let pts = cap_points(c, r, 2000, 60f64.to_radians());
    let (ca, ra) = fit_sphere_algebraic(&pts).unwrap();
    assert!((ra - r).abs() < 1e-9 * r, "algebraic radius {ra}");
    assert!((0..3).all(|k| (ca[k] - c[k]).abs() < 1e-9 * r), "algebraic centre {ca:?}");
    let f = fit_sphere(&pts).unwrap();
    assert!((f.radius - r).abs() < 1e-9 * r && (0..3).all(|k| (f.centre[k] - c[k]).abs() < 1e-9 * r), "{f:?}");
    assert!(f.rms < 1e-9 * r, "rms {}", f.rms);
}

/// With radial noise of known σ the geometric fit's RMS is σ (to 5 %, 20 000 points) and the
/// radius stays within a few σ/√N; the algebraic start alone is biased on a cap, the geometric
/// fit removes that.
#[test]
fn sphere_fit_noisy_points() {
    let (c, r, sigma) = ([0.0, 0.0, 400.0], 50.0, 0.05);
    let mut rng = render::math::sampling::Pcg32::new(5, 1);
    let pts: Vec<[f64; 3]> = cap_points(c, r, 20_000, 70f64.to_radians())
        .into_iter()
        .map(|p| {
            let (u1, u2) = (rng.next_f64().max(1e-300), rng.next_f64());
            let g = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            let d = Vector3::from(p) - Vector3::from(c);
            let q = Vector3::from(c) + d * (1.0 + sigma * g / r);
            [q.x, q.y, q.z]
        })
        .collect();
    let f = fit_sphere(&pts).unwrap();
    assert!((f.rms / sigma - 1.0).abs() < 0.05, "rms {} for σ {sigma}", f.rms);
    assert!((f.radius - r).abs() < 0.02, "radius {}", f.radius);
}

/// The three Voronoi regions of a triangle (face, edge, vertex) against hand-computed closest
/// points.
#[test]
fn closest_point_regions() {
    let (a, b, c) = (Vector3::new(0.0, 0.0, 0.0), Vector3::new(2.0, 0.0, 0.0), Vector3::new(0.0, 2.0, 0.0));
    let q = |p: [f64; 3]| closest_point_on_triangle(Vector3::from(p), a, b, c);
    assert_eq!(q([0.5, 0.5, 3.0]), Vector3::new(0.5, 0.5, 0.0));
    assert_eq!(q([1.0, -1.0, 1.0]), Vector3::new(1.0, 0.0, 0.0));
    assert_eq!(q([-1.0, -1.0, 0.0]), a);
    assert_eq!(q([3.0, 3.0, 0.0]), Vector3::new(1.0, 1.0, 0.0));
    assert_eq!(q([0.0, 5.0, 1.0]), c);
}

/// Points placed at known distances along the face normals of the bunny (inside the faces'
/// interiors, closer to their own face than to any other by construction below) give those
/// distances to 1e-9; the grid search agrees with brute force on random points.
#[test]
fn mesh_distance_exact_points() {
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/bunny.ply");
    let m = [[10.0, 0.0, 0.0, 1.0], [0.0, 10.0, 0.0, -2.0], [0.0, 0.0, 10.0, 300.0], [0.0, 0.0, 0.0, 1.0]];
    let mesh = MeshDistance::from_file(&path, &m).unwrap();
    let diag = mesh.bbox_diagonal();
    assert!(diag > 100.0 && diag < 200.0, "diagonal {diag}");
    // Exact points on the surface: distance 0.
    let meshes = render::shape::mesh::TriangleMesh::load(&path).unwrap();
    let tri = |t: [u32; 3]| t.map(|i| {
        let v = meshes[0].1.positions[i as usize];
        Vector3::new(10.0 * v.x as f64 + 1.0, 10.0 * v.y as f64 - 2.0, 10.0 * v.z as f64 + 300.0)
    });
    let mut on = Vec::new();
    for t in meshes[0].1.indices.iter().step_by(7) {
        let [a, b, c] = tri(*t);
        let p = (a + b + c) / 3.0;
        on.push([p.x, p.y, p.z]);
    }
    let d = mesh_distances(&mesh, &on).unwrap();
    assert!(d.median < 1e-9 && d.rms < 1e-9, "{d:?}");
    // Off the surface: the grid search equals the brute-force minimum.
    let mut rng = render::math::sampling::Pcg32::new(9, 2);
    for _ in 0..300 {
        let p = [0, 1, 2].map(|k| {
            let (lo, hi) = [(-55.0, 55.0), (-10.0, 100.0), (260.0, 345.0)][k];
            lo + (hi - lo) * rng.next_f64()
        });
        let brute = meshes[0].1.indices.iter().map(|t| {
            let [a, b, c] = tri(*t);
            (closest_point_on_triangle(Vector3::from(p), a, b, c) - Vector3::from(p)).norm()
        }).fold(f64::INFINITY, f64::min);
        let g = mesh.distance(p);
        assert!((g - brute).abs() < 1e-9, "grid {g} vs brute force {brute} at {p:?}");
    }
}

fn device(fx: f64) -> DeviceCalibration {
    DeviceCalibration { width: 320, height: 256, fx, fy: fx * 1.002, cx: 160.0, cy: 128.0, distortion: vec![0.0; 5], rms_px: 0.0 }
}

/// A calibration against itself has zero errors; one rotated by 0.05° about an oblique axis,
/// with |T| 0.2 % long, fx 0.1 % long and cx 1.5 px off, shows exactly those and meets the
/// targets; a rotation of 0.2° misses the rotation target only.
#[test]
fn calibration_comparison() {
    let r0 = Rotation3::from_axis_angle(&Vector3::y_axis(), 0.3);
    let truth = ProcamCalibration {
        camera: device(420.0),
        projector: device(330.0),
        rotation: [0, 1, 2].map(|i| [0, 1, 2].map(|j| r0[(i, j)])),
        translation: [140.0, -15.0, 40.0],
        rms_px: 0.0,
        captures: vec![],
    };
    let e = compare_calibration(&truth, &truth);
    assert!(e.rotation_deg.abs() < 1e-9 && e.translation_rel.abs() < 1e-15 && e.camera.fx_rel == 0.0);
    let with = |deg: f64| {
        let axis = nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, -0.5));
        let r = Rotation3::from_axis_angle(&axis, deg.to_radians()) * r0;
        let mut est = truth.clone();
        est.rotation = [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[(i, j)]));
        est.translation = truth.translation.map(|x| x * 1.002);
        est.camera.fx *= 1.001;
        est.projector.cx += 1.5;
        est.rms_px = 0.15;
        compare_calibration(&est, &truth)
    };
    let e = with(0.05);
    assert!((e.rotation_deg - 0.05).abs() < 1e-9, "{}", e.rotation_deg);
    assert!((e.translation_rel - 0.002).abs() < 1e-12 && e.translation_angle_deg.abs() < 1e-6);
    assert!((e.camera.fx_rel - 0.001).abs() < 1e-12 && (e.projector.cx_px - 1.5).abs() < 1e-12);
    assert!(e.failures(&CalibrationTargets::default()).is_empty(), "{:?}", e.failures(&CalibrationTargets::default()));
    let f = with(0.2).failures(&CalibrationTargets::default());
    assert!(f.len() == 1 && f[0].starts_with("rotation"), "{f:?}");
}
