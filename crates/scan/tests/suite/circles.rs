//! Circle-grid targets (`scan::markers::grid`, OpenCV's `findCirclesGrid`): grids drawn through a
//! known pinhole camera, with 4 × 4 supersampling, found in the order of OpenCV's object points,
//! their centres checked against the exact centres of the discs' image ellipses, and the camera
//! recovered by calibration from them.

use nalgebra::{Matrix3, Rotation3, Vector3};
use scan::calib::bundle::Free;
use scan::calib::camera::calibrate_camera_planar;
use scan::markers::grid::{find_circles_grid, grid_points, GridKind};
use scan::markers::synth::FlatTarget;
use scan::markers::Image;

const W: usize = 640;
const H: usize = 480;

/// A pinhole camera K and a board pose: the board plane's homography H = K [r₁ r₂ t].
fn homography(k: &Matrix3<f64>, rot: &Rotation3<f64>, t: Vector3<f64>) -> Matrix3<f64> {
    let r = rot.matrix();
    k * Matrix3::from_columns(&[r.column(0).into_owned(), r.column(1).into_owned(), t])
}

fn camera() -> Matrix3<f64> {
    Matrix3::new(600.0, 0.0, 322.5, 0.0, 598.0, 236.0, 0.0, 0.0, 1.0)
}

/// The board seen by the camera: discs of `radius` (board units) at `centres`, dark (0.1) on light
/// paper (0.8) or light (0.9) on dark paper (0.15), over a mid-grey wall (0.4) outside `paper`
/// (x, y range), with a little noise.
fn draw(h: &Matrix3<f64>, centres: &[[f64; 2]], radius: f64, paper: [f64; 4], dark_disc: bool) -> Image {
    let levels = if dark_disc { [0.1, 0.8, 0.4] } else { [0.9, 0.15, 0.4] };
    FlatTarget { homography: *h, centres: centres.to_vec(), radius, paper, levels, noise: 0.01 }.draw(W, H).unwrap()
}

/// The exact centre of the image ellipse of the board circle (c, ρ) under H: the circle's conic
/// C maps to H⁻ᵀ C H⁻¹, whose centre is −A⁻¹ b for the conic [[A, b], [bᵀ, c]].
fn ellipse_centre(h: &Matrix3<f64>, c: [f64; 2], rho: f64) -> [f64; 2] {
    let conic = Matrix3::new(1.0, 0.0, -c[0], 0.0, 1.0, -c[1], -c[0], -c[1], c[0] * c[0] + c[1] * c[1] - rho * rho);
    let hinv = h.try_inverse().unwrap();
    let q = hinv.transpose() * conic * hinv;
    let a = nalgebra::Matrix2::new(q[(0, 0)], q[(0, 1)], q[(1, 0)], q[(1, 1)]);
    let b = nalgebra::Vector2::new(q[(0, 2)], q[(1, 2)]);
    let x = -a.try_inverse().unwrap() * b;
    [x.x, x.y]
}

/// Board poses: the grid centred in front of the camera at `dist`, turned by `spin` about the
/// optical axis and tilted by `tilt` about an in-plane axis.
fn pose(centre: [f64; 2], dist: f64, spin: f64, tilt: (f64, f64)) -> (Rotation3<f64>, Vector3<f64>) {
    let rot = Rotation3::from_euler_angles(tilt.0, tilt.1, 0.0) * Rotation3::from_axis_angle(&Vector3::z_axis(), spin);
    let t = Vector3::new(0.0, 0.0, dist) - rot * Vector3::new(centre[0], centre[1], 0.0);
    (rot, t)
}

/// An asymmetric 4 × 11 grid (OpenCV's calibration target) seen turned by any angle and tilted by
/// up to 35°: found, in OpenCV's object-point order (unique for an odd number of rows once the
/// board is seen from its front), each centre within 0.03 px of its exact image-ellipse centre (the 4 × 4 supersampling
/// quantises each pixel's coverage to 1/16).
#[test]
fn asymmetric_grid_in_perspective_is_found_in_object_order() {
    let (cols, rows, s) = (4, 11, 10.0);
    let obj = grid_points(GridKind::Asymmetric, cols, rows, s);
    let k = camera();
    let mut worst: f64 = 0.0;
    for (i, spin) in [0.0f64, 80.0, 170.0, 200.0, 290.0].iter().enumerate() {
        let tilt = [(0.0, 0.0), (0.5, 0.1), (-0.3, 0.45), (0.2, -0.6), (0.6, 0.3)][i];
        let (rot, t) = pose([35.0, 50.0], 260.0, spin.to_radians(), tilt);
        let h = homography(&k, &rot, t);
        let img = draw(&h, &obj, 3.4, [-10.0, 80.0, -10.0, 110.0], true);
        let found = find_circles_grid(&img, GridKind::Asymmetric, cols, rows).unwrap_or_else(|| panic!("pose {i}: grid not found"));
        assert_eq!(found.len(), cols * rows);
        for (p, o) in found.iter().zip(&obj) {
            let e = ellipse_centre(&h, *o, 3.4);
            let d = (p[0] - e[0]).hypot(p[1] - e[1]);
            assert!(d < 0.03, "pose {i}: point at board ({}, {}) is {d:.4} px from its ellipse centre", o[0], o[1]);
            worst = worst.max(d);
        }
    }
    eprintln!("asymmetric grid: worst centre error {worst:.4} px");
}

/// A symmetric 7 × 5 grid with stray discs beside it (another size, one in line with a row but
/// two steps out, and light discs on the dark wall): found, point 0 the grid corner nearest the
/// image's top-left and the rows running along +x of the board in either of the two 180°-apart
/// labelings, centres within 0.03 px; light discs on a dark ground likewise. A grid of 8 × 5 asked for as 7 × 5, a grid with a disc missing and an empty image
/// give None.
#[test]
fn symmetric_grid_with_strays_and_wrong_sizes() {
    let (cols, rows, s) = (7, 5, 12.0);
    let obj = grid_points(GridKind::Symmetric, cols, rows, s);
    let k = camera();
    let (rot, t) = pose([36.0, 24.0], 230.0, 0.25, (0.3, -0.2));
    let h = homography(&k, &rot, t);
    let mut discs = obj.clone();
    discs.push([-30.0, 12.0]); // in line with the middle row, two and a half steps out
    let img = draw(&h, &discs, 3.5, [-45.0, 90.0, -12.0, 60.0], true);
    let found = find_circles_grid(&img, GridKind::Symmetric, cols, rows).expect("grid with a stray disc");
    let exact: Vec<[f64; 2]> = obj.iter().map(|o| ellipse_centre(&h, *o, 3.5)).collect();
    // Either labeling of the rectangle (180° apart) with its point 0 nearest the top-left.
    let rotated: Vec<[f64; 2]> = exact.iter().rev().copied().collect();
    let corner0 = |v: &[[f64; 2]]| v[0][0] + v[0][1];
    let want = if corner0(&exact) <= corner0(&rotated) { exact } else { rotated };
    for (p, e) in found.iter().zip(&want) {
        assert!((p[0] - e[0]).hypot(p[1] - e[1]) < 0.03, "{p:?} against {e:?}");
    }
    // A larger grid is not this target.
    let wide = grid_points(GridKind::Symmetric, cols + 1, rows, s);
    let img = draw(&h, &wide, 3.5, [-45.0, 110.0, -12.0, 60.0], true);
    assert!(find_circles_grid(&img, GridKind::Symmetric, cols, rows).is_none());
    assert!(find_circles_grid(&img, GridKind::Symmetric, cols + 1, rows).is_some());
    // A disc missing.
    let mut holed = obj.clone();
    holed.remove(17);
    let img = draw(&h, &holed, 3.5, [-45.0, 90.0, -12.0, 60.0], true);
    assert!(find_circles_grid(&img, GridKind::Symmetric, cols, rows).is_none());
    // Nothing at all, and the right discs asked for as the wrong kind.
    let blank = Image::new(W, H, vec![0.5; W * H]).unwrap();
    assert!(find_circles_grid(&blank, GridKind::Symmetric, cols, rows).is_none());
    let img = draw(&h, &obj, 3.5, [-45.0, 90.0, -12.0, 60.0], true);
    assert!(find_circles_grid(&img, GridKind::Asymmetric, cols, rows).is_none());
    // Light discs on a dark ground are found too.
    let img = draw(&h, &obj, 3.5, [-45.0, 90.0, -12.0, 60.0], false);
    let found = find_circles_grid(&img, GridKind::Symmetric, cols, rows).expect("light discs");
    for (p, e) in found.iter().zip(&want) {
        assert!((p[0] - e[0]).hypot(p[1] - e[1]) < 0.03, "light discs: {p:?} against {e:?}");
    }
}

/// Calibration from circle-grid photographs: six views of the asymmetric grid drawn through a
/// known pinhole camera give back fx, fy within 0.1 % and the principal point within 0.3 px, and
/// a distortion that moves no disc by more than 0.05 px. The residual is the offset of the image ellipses' centres
/// from the images of the discs' centres, which the target's model (points) does not have.
#[test]
fn circle_grid_calibration_recovers_the_camera() {
    let (cols, rows, s) = (4, 11, 10.0);
    let obj = grid_points(GridKind::Asymmetric, cols, rows, s);
    let k = camera();
    let mut views = Vec::new();
    for (i, (spin, tilt, dist)) in [(10.0f64, (0.35, 0.0), 250.0), (100.0, (0.0, 0.4), 240.0), (190.0, (-0.4, 0.2), 260.0), (260.0, (0.25, -0.35), 250.0), (45.0, (-0.3, -0.3), 270.0), (135.0, (0.5, 0.1), 245.0)].iter().enumerate() {
        let (rot, t) = pose([35.0, 50.0], *dist, spin.to_radians(), *tilt);
        let h = homography(&k, &rot, t);
        let img = draw(&h, &obj, 2.5, [-10.0, 80.0, -10.0, 110.0], true);
        let found = find_circles_grid(&img, GridKind::Asymmetric, cols, rows).unwrap_or_else(|| panic!("view {i}: grid not found"));
        views.push((format!("view{i}"), found));
    }
    let c = calibrate_camera_planar(&obj, &views, W as u32, H as u32, Free::default()).unwrap();
    let rel = |a: f64, b: f64| (a / b - 1.0).abs();
    assert!(rel(c.fx, k[(0, 0)]) < 1e-3 && rel(c.fy, k[(1, 1)]) < 1e-3, "fx {} fy {}", c.fx, c.fy);
    assert!((c.cx - k[(0, 2)]).abs() < 0.3 && (c.cy - k[(1, 2)]).abs() < 0.3, "cx {} cy {}", c.cx, c.cy);
    // The distortion terms trade against each other where the discs are (k2 and k3 above all);
    // what they must not do is move those points: the fitted model's displacement there.
    let d = &c.dist;
    let moved = views
        .iter()
        .flat_map(|(_, v)| v.iter())
        .map(|p| {
            let (x, y) = ((p[0] - c.cx) / c.fx, (p[1] - c.cy) / c.fy);
            let r2 = x * x + y * y;
            let radial = d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
            let (dx, dy) = (x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x), y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y);
            (c.fx * dx).hypot(c.fy * dy)
        })
        .fold(0.0f64, f64::max);
    assert!(moved < 0.05, "the fitted distortion moves the discs by up to {moved} px: {d:?}");
    assert!(c.rms_px < 0.05, "RMS {}", c.rms_px);
    eprintln!("circle-grid calibration: fx {:.3} fy {:.3} cx {:.3} cy {:.3} RMS {:.4} px", c.fx, c.fy, c.cx, c.cy, c.rms_px);
}

/// Two cameras from simultaneous photographs of the asymmetric grid (OpenCV's `stereoCalibrate`,
/// `scan::calib::calibrate_planar` with the second camera in the projector's place): five pairs
/// drawn through two known pinhole cameras give back both focal lengths within 0.1 %, the
/// relative rotation within 0.05° and the translation within 0.3 % of the baseline (measured:
/// 0.031° and 0.13 %; the discs' ellipse centres are offset from the images of their centres by
/// an amount that changes with the pose, and both cameras' five distortion terms are free).
#[test]
fn stereo_circle_grids_recover_both_cameras_and_their_pose() {
    use scan::calib::{calibrate_planar, CaptureCorners, Rig};
    let (cols, rows, s) = (4, 11, 10.0);
    let obj = grid_points(GridKind::Asymmetric, cols, rows, s);
    let (kl, kr) = (camera(), Matrix3::new(580.0, 0.0, 318.0, 0.0, 579.0, 242.5, 0.0, 0.0, 1.0));
    // X_right = R X_left + T: the right camera 60 units to the right, turned 12° towards the left
    // camera's axis so that both see the grid.
    let r_lr = Rotation3::from_axis_angle(&Vector3::y_axis(), 12f64.to_radians());
    let t_lr = Vector3::new(-60.0, 1.5, 3.0);
    let mut captures = Vec::new();
    for (i, (spin, tilt, dist)) in [(10.0f64, (0.3, 0.1), 260.0), (100.0, (0.0, 0.35), 250.0), (190.0, (-0.35, 0.2), 270.0), (260.0, (0.25, -0.2), 255.0), (45.0, (-0.3, -0.1), 280.0)].iter().enumerate() {
        let (rot, t) = pose([35.0, 50.0], *dist, spin.to_radians(), *tilt);
        let mut pts = Vec::new();
        for (k, rot, t) in [(&kl, rot, t), (&kr, r_lr * rot, r_lr * t + t_lr)] {
            let img = draw(&homography(k, &rot, t), &obj, 2.5, [-10.0, 80.0, -10.0, 110.0], true);
            pts.push(find_circles_grid(&img, GridKind::Asymmetric, cols, rows).unwrap_or_else(|| panic!("pair {i}: grid not found")));
        }
        let proj = pts.pop().unwrap();
        captures.push(CaptureCorners { name: format!("pair{i}"), cam: pts.pop().unwrap(), proj });
    }
    let rig = Rig { cols, rows, square: s, camera: (W as u32, H as u32), projector: (W as u32, H as u32) };
    let c = calibrate_planar(&rig, &obj, &captures, None, Free::default(), ["left camera", "right camera"]).unwrap();
    for (d, k) in [(&c.camera, &kl), (&c.projector, &kr)] {
        assert!((d.fx / k[(0, 0)] - 1.0).abs() < 1e-3 && (d.fy / k[(1, 1)] - 1.0).abs() < 1e-3, "fx {} fy {} against {}", d.fx, d.fy, k[(0, 0)]);
    }
    let r = Matrix3::from_fn(|i, j| c.rotation[i][j]);
    let angle = Rotation3::from_matrix(&(r * r_lr.matrix().transpose())).angle().to_degrees();
    let dt = (Vector3::from(c.translation) - t_lr).norm() / t_lr.norm();
    assert!(angle < 0.05 && dt < 3e-3, "rotation off by {angle}°, translation by {dt} of the baseline");
    eprintln!("stereo: rotation {angle:.4}°, translation {:.4} % of the baseline, RMS {:.4} px", 100.0 * dt, c.rms_px);
}

/// Under light that falls from one side of the target to the other by 30×, no grey level cuts
/// every disc from the paper, so the thresholded regions ([`scan::markers::blobs`]) do not give
/// the whole grid; `find_circles_grid` then falls back on the Hough candidates, which follow the
/// local edges, and finds it, each centre within 0.05 px of its ellipse centre.
#[test]
fn uneven_light_falls_back_on_the_hough_candidates() {
    use scan::markers::blobs::threshold_candidates;
    use scan::markers::detect::refine_all;
    use scan::markers::grid::find_grid_in;
    use scan::markers::DetectSettings;
    let (cols, rows, s) = (4, 11, 10.0);
    let obj = grid_points(GridKind::Asymmetric, cols, rows, s);
    let (rot, t) = pose([35.0, 50.0], 260.0, 1.4, (0.3, 0.2));
    let h = homography(&camera(), &rot, t);
    let mut img = draw(&h, &obj, 3.4, [-10.0, 80.0, -10.0, 110.0], true);
    for (i, v) in img.data.iter_mut().enumerate() {
        let x = (i % W) as f32 / (W - 1) as f32;
        *v *= (30f32).powf(x - 1.0);
    }
    let blobs = refine_all(&img, &threshold_candidates(&img, true), &DetectSettings::default());
    assert!(find_grid_in(&blobs, GridKind::Asymmetric, cols, rows).is_none(), "the thresholded regions found the grid: this image does not test the fallback");
    let found = find_circles_grid(&img, GridKind::Asymmetric, cols, rows).expect("the Hough candidates find the grid");
    for (p, o) in found.iter().zip(&obj) {
        let e = ellipse_centre(&h, *o, 3.4);
        assert!((p[0] - e[0]).hypot(p[1] - e[1]) < 0.05, "{p:?} against {e:?}");
    }
}
