//! Triangulation: exact correspondences give the points back; range images, normals and meshes.

use scan::cloud::DEFAULT_MAX_EDGE_PIXELS;
use scan::decode::DecodeMap;
use scan::triangulate::{triangulate_map, Rig};

use crate::common::synthetic_calibration;

/// Points projected into both devices (distortion on) triangulate back to themselves within
/// 1e-9 (scene about 1 unit away), with a ray gap below 1e-9.
#[test]
fn exact_correspondences_triangulate_to_1e9() {
    let rig = Rig::new(&synthetic_calibration()).unwrap();
    let mut worst = 0.0f64;
    let mut n = 0;
    for i in 0..21 {
        for j in 0..17 {
            for &z in &[0.6, 1.0, 1.7] {
                let p = [(i as f64 / 20.0 - 0.5) * 0.6 * z, (j as f64 / 16.0 - 0.5) * 0.45 * z, z];
                let (cam, proj) = rig.project(p).unwrap();
                let t = rig.triangulate(cam, proj).unwrap();
                let e = ((t.point[0] - p[0]).powi(2) + (t.point[1] - p[1]).powi(2) + (t.point[2] - p[2]).powi(2)).sqrt();
                assert!(t.ray_gap < 1e-9, "{p:?}: gap {}", t.ray_gap);
                worst = worst.max(e);
                n += 1;
            }
        }
    }
    assert!(worst < 1e-9, "worst error {worst:e} over {n} points");
}

/// A decode map of two planes at different depths (the ideal decoder output a renderer would
/// give, projector coordinates rounded to f32): points lie on their planes, normals are the
/// plane normals, the mesh joins each plane and not across the depth step.
#[test]
fn range_image_of_two_planes_gives_planar_points_normals_and_a_split_mesh() {
    let calib = synthetic_calibration();
    let rig = Rig::new(&calib).unwrap();
    let (w, h) = (calib.camera.width as usize, calib.camera.height as usize);
    // Plane n·X = d; left half of the image sees plane A, right half plane B (farther).
    let na = normalize([0.1, -0.2, -1.0]);
    let nb = normalize([-0.3, 0.05, -1.0]);
    let (da, db) = (-0.9, -1.4);
    let k = &calib.camera;
    let cam_opencv = {
        use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};
        let id = Extrinsics::from_rt([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]).unwrap();
        OpenCv::new(Intrinsics { fx: k.fx, fy: k.fy, cx: k.cx, cy: k.cy }, Distortion::from_opencv(&k.distortion).unwrap(), id, k.width, k.height).unwrap()
    };
    let mut map = DecodeMap { width: w, height: h, col: vec![f32::NAN; w * h], row: vec![f32::NAN; w * h], white: vec![200.0; w * h], black: vec![10.0; w * h] };
    let mut truth = vec![None; w * h];
    for y in 0..h {
        for x in 0..w {
            let (n, d) = if x < w / 2 { (na, da) } else { (nb, db) };
            let (_, dir) = cam_opencv.ray_pixel(x as f64, y as f64);
            let t = d / dot(n, dir);
            let p = [t * dir[0], t * dir[1], t * dir[2]];
            let (_, proj) = rig.project(p).unwrap();
            if proj[0] < -0.5 || proj[1] < -0.5 || proj[0] > 255.5 || proj[1] > 191.5 {
                continue;
            }
            map.col[y * w + x] = proj[0] as f32;
            map.row[y * w + x] = proj[1] as f32;
            truth[y * w + x] = Some((p, n, d));
        }
    }
    let range = triangulate_map(&map, &rig, &|| {}).unwrap();
    let cloud = range.cloud(&map.white, DEFAULT_MAX_EDGE_PIXELS, true);
    let valid = truth.iter().filter(|t| t.is_some()).count();
    assert!(valid > w * h / 2, "{valid}");
    assert_eq!(cloud.points.len(), valid);
    let mut worst_plane = 0.0f64;
    let mut worst_normal = 0.0f64;
    for (i, (&(x, y), p)) in cloud.pixel.iter().zip(&cloud.points).enumerate() {
        let (_, n, d) = truth[y as usize * w + x as usize].unwrap();
        worst_plane = worst_plane.max((dot(n, *p) - d).abs());
        let m = cloud.normals[i];
        // Away from the step between the planes, normals are the plane's.
        if (x as usize).abs_diff(w / 2) > 2 && m != [0.0; 3] {
            worst_normal = worst_normal.max(1.0 - dot(m, n));
        }
    }
    // f32 projector coordinates (≈ 1.5e-5 px) limit the accuracy: 1e-5 in depth at z ≈ 1.
    assert!(worst_plane < 2e-5, "distance to plane {worst_plane:e}");
    assert!(worst_normal < 1e-6, "normal 1 − cos {worst_normal:e}");
    // Mesh: every triangle lies on one plane; the blocks inside each plane are all meshed.
    let side = |v: u32| cloud.pixel[v as usize].0 as usize >= w / 2;
    for t in &cloud.triangles {
        assert!(side(t[0]) == side(t[1]) && side(t[1]) == side(t[2]), "triangle across the depth step");
        // Facing the camera.
        let p = t.map(|v| cloud.points[v as usize]);
        let nrm = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        assert!(dot(nrm, p[0]) < 0.0);
    }
    let mut expected = 0;
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            if x + 1 == w / 2 {
                continue;
            }
            let ok = |a: usize, b: usize| truth[b * w + a].is_some();
            expected += (ok(x, y) && ok(x, y + 1) && ok(x + 1, y)) as usize;
            expected += (ok(x + 1, y) && ok(x, y + 1) && ok(x + 1, y + 1)) as usize;
        }
    }
    assert_eq!(cloud.triangles.len(), expected);
    let s = cloud.summary();
    assert_eq!(s.points, valid);
    assert!(s.median_ray_gap < 1e-5, "{}", s.median_ray_gap);
    assert!(s.bbox_min[2] > 0.5 && s.bbox_max[2] < 2.5, "{s:?}");

    // The size of the map must match the calibration.
    let small = DecodeMap { width: 10, height: 10, col: vec![0.0; 100], row: vec![0.0; 100], white: vec![0.0; 100], black: vec![0.0; 100] };
    assert!(triangulate_map(&small, &rig, &|| {}).is_err());
}

#[test]
fn bad_calibrations_are_refused_naming_the_field() {
    let mut c = synthetic_calibration();
    c.camera.fx = -1.0;
    assert!(format!("{:#}", Rig::new(&c).unwrap_err()).contains("camera"));
    let mut c = synthetic_calibration();
    c.projector.distortion = vec![0.1, 0.2, 0.3];
    assert!(format!("{:#}", Rig::new(&c).unwrap_err()).contains("projector.distortion"));
    let mut c = synthetic_calibration();
    c.rotation[0][0] = 2.0;
    assert!(format!("{:#}", Rig::new(&c).unwrap_err()).contains("rotation"));
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}
