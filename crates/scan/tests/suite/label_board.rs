//! The board plane and shading normals of `scan label` against closed forms: the move between
//! two board poses carries board points exactly and the plane distance is the offset along the
//! board normal; diffused shading normals keep a plane's normal exactly, lower the scatter of a
//! noisy plane's facet normals, and stay radial on a sphere.

use scan::calib::CapturePose;
use scan::label::board::BoardPose;
use scan::label::normals::smooth_normals;
use scan::label::Mesh;

use crate::common::Pcg;

fn pose(rvec: [f64; 3], tvec: [f64; 3]) -> BoardPose {
    BoardPose::from_capture(&CapturePose { name: String::new(), rvec, tvec, rms_px: 0.0, projector_corners: 63 })
}

fn apply(m: &nalgebra::Matrix4<f64>, p: [f64; 3]) -> [f64; 3] {
    let v = m * nalgebra::Vector4::new(p[0], p[1], p[2], 1.0);
    [v[0], v[1], v[2]]
}

/// A point fixed to the board (board coordinates X) seen at R_i X + t_i is moved by
/// `move_to` to R_j X + t_j; moving there and back is the identity; a point offset by d along
/// the board normal is at plane distance d.
#[test]
fn board_move_carries_board_points_and_plane_distance_is_the_normal_offset() {
    let a = pose([-0.127, 0.072, 0.010], [-228.6, -261.4, 3681.8]);
    let b = pose([-0.139, 0.991, 0.053], [-60.4, -259.2, 3462.4]);
    let m = a.move_to(&b);
    let back = b.move_to(&a);
    for (k, x) in [[0.0, 0.0, 0.0], [600.0, 0.0, 0.0], [0.0, 450.0, 0.0], [300.0, 200.0, -15.0], [-80.0, 510.0, 40.0]].iter().enumerate() {
        let xb = nalgebra::Vector3::from(*x);
        let pa = a.r * xb + a.t;
        let pb = b.r * xb + b.t;
        let moved = apply(&m, [pa[0], pa[1], pa[2]]);
        for c in 0..3 {
            assert!((moved[c] - pb[c]).abs() < 1e-9 * 4000.0, "point {k}: {moved:?} vs {pb:?}");
        }
        let round = apply(&(back * m), [pa[0], pa[1], pa[2]]);
        for c in 0..3 {
            assert!((round[c] - pa[c]).abs() < 1e-9 * 4000.0);
        }
        // x[2] is the offset along the board's z axis, i.e. the signed plane distance.
        assert!((a.plane_distance([pa[0], pa[1], pa[2]]) - x[2]).abs() < 1e-9 * 4000.0);
        assert!((b.plane_distance([pb[0], pb[1], pb[2]]) - x[2]).abs() < 1e-9 * 4000.0);
    }
}

/// An n × n grid (spacing 1) at depth 10, triangulated, with depth `jitter(x, y)`.
fn grid(n: usize, mut depth: impl FnMut(usize, usize) -> f64) -> Mesh {
    let mut m = Mesh::default();
    for y in 0..n {
        for x in 0..n {
            m.positions.push([x as f64 - n as f64 / 2.0, y as f64 - n as f64 / 2.0, depth(x, y)]);
        }
    }
    for y in 0..n - 1 {
        for x in 0..n - 1 {
            let v = (y * n + x) as u32;
            let n = n as u32;
            m.triangles.push([v, v + 1, v + n + 1]);
            m.triangles.push([v, v + n + 1, v + n]);
        }
    }
    m
}

fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (d / (n(a) * n(b))).clamp(-1.0, 1.0).acos()
}

/// A tilted plane keeps its normal exactly (turned towards the camera); on a plane whose depth
/// scatters (σ = 0.1 of the spacing, as a scan's depth noise), 100 passes lower the RMS angle
/// of the normals from the plane's to under a fifth of the facet normals' (the average over
/// about 100 neighbours would give a tenth); faces not kept take no part.
#[test]
fn smoothed_normals_keep_a_plane_and_lower_scan_noise() {
    let n = 60;
    let tilted = grid(n, |x, y| 40.0 + 0.3 * x as f64 - 0.2 * y as f64);
    // The plane z = 40 + 0.3 (x' + 30) − 0.2 (y' + 30) in camera coordinates: normal ∝ (0.3, −0.2, −1)
    // towards the camera at the origin.
    let truth = [0.3, -0.2, -1.0];
    let keep = vec![true; tilted.triangles.len()];
    for iterations in [0, 25] {
        for (v, nn) in smooth_normals(&tilted, &keep, iterations).iter().enumerate() {
            assert!(angle(*nn, truth) < 1e-9, "vertex {v}, {iterations} passes: {nn:?}");
        }
    }
    let mut rng = Pcg::new(11);
    let noisy = grid(n, |_, _| 10.0 + 0.1 * rng.normal());
    let rms = |normals: &[[f64; 3]]| {
        // Interior vertices (10 from the border), against the plane's normal (0, 0, −1).
        let mut s = (0.0, 0usize);
        for y in 10..n - 10 {
            for x in 10..n - 10 {
                s.0 += angle(normals[y * n + x], [0.0, 0.0, -1.0]).powi(2);
                s.1 += 1;
            }
        }
        (s.0 / s.1 as f64).sqrt()
    };
    let raw = rms(&smooth_normals(&noisy, &keep, 0));
    let smooth = rms(&smooth_normals(&noisy, &keep, 100));
    assert!(raw > 0.05, "facet normals scatter by {raw} rad");
    assert!(smooth < raw / 5.0, "smoothed {smooth} rad vs facets {raw} rad");
    // Only the first half of the faces kept: the vertices of the other half alone get zero.
    let half: Vec<bool> = (0..noisy.triangles.len()).map(|t| t < noisy.triangles.len() / 2).collect();
    let nh = smooth_normals(&noisy, &half, 10);
    assert_eq!(nh[n * n - 1], [0.0; 3]);
    assert!(angle(nh[0], [0.0, 0.0, -1.0]) < 0.5);
}

/// On a UV sphere (radius 5, centre 20 in front of the camera, 96 × 48 segments) the
/// smoothed normals of the half facing the camera stay radial: averaging over a neighbourhood
/// that is symmetric about the vertex cancels the tilt of its sides, so what is left is the
/// asymmetry of the grid's diagonal triangulation, under 2°, not the neighbourhood's angular
/// size (√25 edges ≈ 19°).
#[test]
fn smoothed_normals_of_a_sphere_are_radial() {
    let (r, c, nu, nv) = (5.0, [0.0, 0.0, 20.0], 96usize, 48usize);
    let mut m = Mesh::default();
    for j in 0..=nv {
        let th = std::f64::consts::PI * j as f64 / nv as f64;
        for i in 0..nu {
            let ph = std::f64::consts::TAU * i as f64 / nu as f64;
            m.positions.push([c[0] + r * th.sin() * ph.cos(), c[1] + r * th.cos(), c[2] + r * th.sin() * ph.sin()]);
        }
    }
    for j in 0..nv {
        for i in 0..nu {
            let a = (j * nu + i) as u32;
            let b = (j * nu + (i + 1) % nu) as u32;
            let (a2, b2) = (a + nu as u32, b + nu as u32);
            m.triangles.push([a, b, b2]);
            m.triangles.push([a, b2, a2]);
        }
    }
    let keep = vec![true; m.triangles.len()];
    let normals = smooth_normals(&m, &keep, 25);
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for (p, n) in m.positions.iter().zip(&normals) {
        let radial = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        // Within 50° of the view direction (the camera at the origin sees −z of the sphere).
        if angle(radial, [-p[0], -p[1], -p[2]]) < 50f64.to_radians() {
            worst = worst.max(angle(*n, radial));
            checked += 1;
        }
    }
    assert!(checked > 300, "{checked}");
    assert!(worst < 2f64.to_radians(), "worst deviation {:.3}°", worst.to_degrees());
}

/// Depth smoothing along the normal keeps a tilted plane exactly (every vertex within 1e-9),
/// and lowers a noisy plane's depth scatter (σ = 0.1) by more than 5× in the interior after 100
/// passes (the mean of about 100 independent depths would lower it 10×), moving no vertex
/// sideways by more than a tenth of the spacing (the moves are along the smoothed normals, whose
/// tilt is small: the sampling stays).
#[test]
fn depth_smoothing_keeps_a_plane_and_lowers_depth_noise() {
    use scan::label::normals::smooth_depth;
    let n = 60;
    let tilted = grid(n, |x, y| 40.0 + 0.3 * x as f64 - 0.2 * y as f64);
    let keep = vec![true; tilted.triangles.len()];
    let nt = smooth_normals(&tilted, &keep, 10);
    for (a, b) in smooth_depth(&tilted, &keep, &nt, 50).iter().zip(&tilted.positions) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-9, "{a:?} vs {b:?}");
        }
    }
    let mut rng = Pcg::new(5);
    let noisy = grid(n, |_, _| 10.0 + 0.1 * rng.normal());
    let nn = smooth_normals(&noisy, &keep, 100);
    let p = smooth_depth(&noisy, &keep, &nn, 100);
    let rms = |pos: &[[f64; 3]]| {
        let mut s = (0.0, 0usize);
        for y in 10..n - 10 {
            for x in 10..n - 10 {
                s.0 += (pos[y * n + x][2] - 10.0).powi(2);
                s.1 += 1;
            }
        }
        (s.0 / s.1 as f64).sqrt()
    };
    let (before, after) = (rms(&noisy.positions), rms(&p));
    assert!(after < before / 5.0, "depth scatter {before} → {after}");
    let sideways = p.iter().zip(&noisy.positions).map(|(a, b)| (a[0] - b[0]).abs().max((a[1] - b[1]).abs())).fold(0.0, f64::max);
    assert!(sideways < 0.1, "moved sideways by {sideways}");
}
