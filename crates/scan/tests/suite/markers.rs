//! Circular markers: detection on ideal anti-aliased discs, the geometry of an imaged circle,
//! epipolar matching on exact correspondences, Umeyama on exact points, RANSAC against a wrong
//! match, and a round trip through lucent's renderer (docs/markers.md).

use nalgebra::{Matrix3, Rotation3, Vector3};
use scan::markers::ellipse::{circle_centre_image, circle_normals, ellipse_of, fit_conic};
use scan::markers::register::{register, umeyama, RegisterSettings};
use scan::markers::stereo::{match_markers, MatchSettings, TwoViews};
use scan::markers::synth::MarkerScene;
use scan::markers::{detect, DetectSettings, Image, Marker};

/// An image of `w`×`h` with background `bg` and filled ellipses (centre, semi-axes, angle, level),
/// each pixel the exact mean over 32 × 32 sub-pixel samples where an edge crosses it (box filter).
fn draw(w: usize, h: usize, bg: f32, shapes: &[([f64; 2], [f64; 2], f64, f32)]) -> Image {
    let mut data = vec![bg; w * h];
    for &(c, ax, ang, level) in shapes {
        let (ca, sa) = (ang.cos(), ang.sin());
        let inside = |x: f64, y: f64| {
            let (dx, dy) = (x - c[0], y - c[1]);
            let (u, v) = (ca * dx + sa * dy, -sa * dx + ca * dy);
            (u / ax[0]).powi(2) + (v / ax[1]).powi(2) <= 1.0
        };
        let r = ax[0].max(ax[1]) + 2.0;
        for y in ((c[1] - r).floor() as usize)..=((c[1] + r).ceil() as usize).min(h - 1) {
            for x in ((c[0] - r).floor() as usize)..=((c[0] + r).ceil() as usize).min(w - 1) {
                let n = 32;
                let mut cov = 0usize;
                for j in 0..n {
                    for i in 0..n {
                        let (sx, sy) = (x as f64 - 0.5 + (i as f64 + 0.5) / n as f64, y as f64 - 0.5 + (j as f64 + 0.5) / n as f64);
                        cov += inside(sx, sy) as usize;
                    }
                }
                let f = cov as f32 / (n * n) as f32;
                let p = &mut data[y * w + x];
                *p = *p * (1.0 - f) + level * f;
            }
        }
    }
    Image::new(w, h, data).unwrap()
}

fn nearest(ms: &[Marker], p: [f64; 2]) -> &Marker {
    ms.iter().min_by(|a, b| (a.x - p[0]).hypot(a.y - p[1]).total_cmp(&(b.x - p[0]).hypot(b.y - p[1]))).unwrap()
}

/// Dark and light discs of radius 4 … 25 px at sub-pixel offsets: every one found, centres exact
/// to 0.01 px. The radii come out short by the blur's curvature shift σ²/(2r) (σ² = 1/12 px² of
/// the pixel's box filter plus 1/6 px² of the bilinear interpolation along the rays), to 0.01 px.
#[test]
fn ideal_discs_centres_to_a_hundredth_of_a_pixel() {
    let discs: [([f64; 2], f64, f32); 6] = [
        ([40.37, 42.81], 4.0, 0.1),
        ([110.62, 40.13], 7.5, 0.1),
        ([190.05, 50.5], 12.25, 0.05),
        ([60.71, 130.29], 20.0, 0.1),
        ([150.48, 135.92], 25.3, 0.95),
        ([225.16, 140.77], 9.1, 0.9),
    ];
    let shapes: Vec<_> = discs.iter().map(|&(c, r, l)| (c, [r, r], 0.0, l)).collect();
    let mut img = draw(260, 180, 0.5, &shapes[..4]);
    // The light discs sit on a dark patch.
    for y in 100..180 {
        for x in 120..260 {
            img.data[y * 260 + x] = 0.1;
        }
    }
    let light = draw(260, 180, 0.1, &shapes[4..]);
    for y in 100..180 {
        for x in 120..260 {
            img.data[y * 260 + x] = light.data[y * 260 + x];
        }
    }
    let s = DetectSettings { hough: scan::markers::hough::HoughSettings { radius_min_px: 3.0, radius_max_px: 30.0, ..Default::default() }, ..Default::default() };
    let found = detect(&img, &s);
    assert_eq!(found.len(), discs.len(), "{found:?}");
    let mut worst = 0.0f64;
    for &(c, r, level) in &discs {
        let m = nearest(&found, c);
        let e = (m.x - c[0]).hypot(m.y - c[1]);
        worst = worst.max(e);
        assert!(e < 0.01, "disc r = {r} at {c:?}: centre ({:.4}, {:.4}), error {e:.4} px", m.x, m.y);
        let shift = 0.25 / (2.0 * r);
        assert!((m.radius_px - (r - shift)).abs() < 0.01, "disc r = {r}: radius {:.4}, expected {:.4}", m.radius_px, r - shift);
        assert_eq!(m.dark, level < 0.3);
    }
    eprintln!("ideal discs: largest centre error {worst:.5} px");
}

/// A tilted ideal ellipse: centre to 0.01 px, semi-axes to 0.05 px (the curvature shift of the
/// blur, largest at the ends of the major axis), angle to 0.2°.
#[test]
fn ideal_ellipse_centre_axes_and_angle() {
    let (c, ax, ang) = ([80.43, 61.77], [14.0, 8.5], 0.6);
    let img = draw(160, 120, 0.7, &[(c, ax, ang, 0.1)]);
    let found = detect(&img, &DetectSettings::default());
    assert_eq!(found.len(), 1, "{found:?}");
    let e = found[0].ellipse;
    assert!((e.centre[0] - c[0]).hypot(e.centre[1] - c[1]) < 0.01, "{e:?}");
    assert!((e.semi_major - ax[0]).abs() < 0.05 && (e.semi_minor - ax[1]).abs() < 0.05, "{e:?}");
    assert!((e.angle_rad - ang).abs() < 0.2f64.to_radians(), "{e:?}");
}

/// Points of the circle (centre `c`, unit normal `n`, radius `r`) in camera coordinates.
fn circle_points(c: Vector3<f64>, n: Vector3<f64>, r: f64, k: usize) -> Vec<Vector3<f64>> {
    let e1 = n.cross(&Vector3::x()).normalize();
    let e2 = n.cross(&e1);
    (0..k).map(|i| std::f64::consts::TAU * i as f64 / k as f64).map(|a| c + (e1 * a.cos() + e2 * a.sin()) * r).collect()
}

/// The image of a tilted circle is a conic; with the true normal, Q⁻¹n is exactly the image of the
/// circle's centre, which differs from the ellipse's centre; the normal is one of the two the
/// conic allows.
#[test]
fn circle_centre_image_is_the_pole_of_the_vanishing_line() {
    let c = Vector3::new(0.12, -0.08, 1.0);
    let n = Vector3::new(0.5, -0.3, -0.8).normalize();
    let pts: Vec<[f64; 2]> = circle_points(c, n, 0.05, 90).iter().map(|p| [p.x / p.z, p.y / p.z]).collect();
    let q = fit_conic(&pts).unwrap();
    let got = circle_centre_image(&q, &n).unwrap();
    let truth = [c.x / c.z, c.y / c.z];
    assert!((got[0] - truth[0]).hypot(got[1] - truth[1]) < 1e-10, "{got:?} vs {truth:?}");
    let e = ellipse_of(&q).unwrap();
    let bias = (e.centre[0] - truth[0]).hypot(e.centre[1] - truth[1]);
    assert!(bias > 1e-4, "the ellipse centre should be off the centre's image here, by {bias}");
    let ns = circle_normals(&q).unwrap();
    let best = ns.iter().map(|m| m.dot(&n)).fold(-1.0, f64::max);
    assert!(best > 1.0 - 1e-9, "{ns:?} vs {n:?}");
}

/// A marker built from the exact projections of a 3-D circle's points into one view.
fn exact_marker(views: &TwoViews, view: usize, pts_a: &[Vector3<f64>], to_view: &dyn Fn(Vector3<f64>) -> Vector3<f64>) -> Marker {
    let edge: Vec<[f64; 2]> = pts_a.iter().map(|p| to_view(*p)).map(|p| views.pixel(view, [p.x / p.z, p.y / p.z]).unwrap()).collect();
    let q = fit_conic(&edge).unwrap();
    let e = ellipse_of(&q).unwrap();
    Marker { x: e.centre[0], y: e.centre[1], radius_px: (e.semi_major * e.semi_minor).sqrt(), ellipse: e, dark: true, support: 1.0, rms_px: 0.0, score: 1.0, edge_points: edge }
}

/// Exact correspondences in both views of a distorted camera–projector rig (view B listed in
/// another order, plus a marker only view A sees): every pair matched, the centres corrected to
/// the true images (epipolar distance 0, where the ellipse centres are off their epipolar lines by
/// the perspective bias), the points triangulated to the truth.
#[test]
fn epipolar_matching_on_exact_correspondences() {
    let cal = crate::common::synthetic_calibration();
    let views = TwoViews::new(&cal).unwrap();
    let r = Matrix3::from_fn(|i, j| cal.rotation[i][j]);
    let t = Vector3::from(cal.translation);
    let to_b = |p: Vector3<f64>| r * p + t;
    let centres = [Vector3::new(-0.12, -0.1, 1.0), Vector3::new(0.1, -0.06, 1.1), Vector3::new(0.02, 0.09, 0.95), Vector3::new(0.15, 0.12, 1.05), Vector3::new(-0.1, 0.1, 1.02)];
    let normals = [Vector3::new(0.3, 0.1, -1.0), Vector3::new(-0.2, 0.3, -1.0), Vector3::new(0.1, -0.4, -1.0), Vector3::new(0.4, 0.2, -1.0), Vector3::new(-0.3, -0.2, -1.0)];
    let circles: Vec<Vec<Vector3<f64>>> = centres.iter().zip(&normals).map(|(c, n)| circle_points(*c, n.normalize(), 0.02, 120)).collect();
    let a: Vec<Marker> = circles.iter().map(|p| exact_marker(&views, 0, p, &|x| x)).collect();
    let order_b = [3usize, 0, 2, 1];
    let b: Vec<Marker> = order_b.iter().map(|&k| exact_marker(&views, 1, &circles[k], &to_b)).collect();
    let st = match_markers(&views, &a, &b, &MatchSettings::default());
    assert_eq!(st.matches.len(), 4, "{st:?}");
    assert_eq!(st.unmatched, [vec![4], vec![]]);
    for m in &st.matches {
        let k = order_b[m.b];
        assert_eq!(m.a, k, "marker {} of A matched with marker {k}", m.a);
        assert!(m.epipolar_px < 0.05, "{m:?}");
        assert!(views.epipolar_px(m.centre_a, m.centre_b).unwrap() < 1e-6, "{m:?}");
        let truth_a = views.pixel(0, [centres[k].x / centres[k].z, centres[k].y / centres[k].z]).unwrap();
        let cb = to_b(centres[k]);
        let truth_b = views.pixel(1, [cb.x / cb.z, cb.y / cb.z]).unwrap();
        assert!(m.corrected);
        assert!((m.centre_a[0] - truth_a[0]).hypot(m.centre_a[1] - truth_a[1]) < 1e-6, "{m:?} vs {truth_a:?}");
        assert!((m.centre_b[0] - truth_b[0]).hypot(m.centre_b[1] - truth_b[1]) < 1e-6, "{m:?} vs {truth_b:?}");
        let p = Vector3::from(m.point);
        assert!((p - centres[k]).norm() < 1e-8, "{p:?} vs {:?}", centres[k]);
        assert!(m.ray_gap < 1e-8);
        assert!(Vector3::from(m.normal).dot(&normals[k].normalize()) > 1.0 - 1e-9, "{m:?}");
    }
    // The ellipse centres themselves are off by a measurable perspective bias.
    let bias = a.iter().zip(&centres).map(|(m, c)| {
        let tr = views.pixel(0, [c.x / c.z, c.y / c.z]).unwrap();
        (m.x - tr[0]).hypot(m.y - tr[1])
    });
    assert!(bias.fold(0.0, f64::max) > 1e-3);
}

fn points(n: usize, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = render::math::sampling::Pcg32::new(seed, 3);
    (0..n).map(|_| Vector3::new(rng.next_f64() * 2.0 - 1.0, rng.next_f64() * 2.0 - 1.0, rng.next_f64() * 2.0 - 1.0) * 50.0).collect()
}

/// Umeyama on exact points recovers the rotation, translation and scale to 1e-12 (relative).
#[test]
fn umeyama_on_exact_points() {
    let src = points(7, 1);
    let r = *Rotation3::from_scaled_axis(Vector3::new(0.4, -1.1, 0.7)).matrix();
    let t = Vector3::new(12.0, -30.5, 400.0);
    for (with_scale, s) in [(false, 1.0), (true, 1.37)] {
        let dst: Vec<Vector3<f64>> = src.iter().map(|x| r * x * s + t).collect();
        let fit = umeyama(&src, &dst, with_scale).unwrap();
        assert!((fit.rotation - r).abs().max() < 1e-12, "{:?}", fit.rotation - r);
        assert!((fit.translation - t).abs().max() < 1e-12 * t.norm(), "{:?}", fit.translation - t);
        assert!((fit.scale - s).abs() < 1e-12, "{}", fit.scale);
        assert!((fit.rotation.determinant() - 1.0).abs() < 1e-12);
    }
    // A reflection is not a rotation: mirrored targets still give det +1.
    let dst: Vec<Vector3<f64>> = src.iter().map(|x| Vector3::new(-x.x, x.y, x.z)).collect();
    assert!((umeyama(&src, &dst, false).unwrap().rotation.determinant() - 1.0).abs() < 1e-12);
}

/// RANSAC over unlabelled markers: with one wrong match among the triangulated points (and the
/// model's list shuffled), the transform is exact to 1e-9 and the wrong point is the outlier.
#[test]
fn ransac_registration_rejects_a_wrong_match() {
    let model = points(6, 2);
    let r = *Rotation3::from_scaled_axis(Vector3::new(-0.3, 0.8, 1.9)).matrix();
    let t = Vector3::new(-20.0, 5.0, 300.0);
    for (with_scale, s) in [(false, 1.0), (true, 0.8)] {
        let mut target: Vec<[f64; 3]> = [4usize, 1, 5, 0, 2].iter().map(|&k| r * model[k] * s + t).map(|p| [p.x, p.y, p.z]).collect();
        // A wrong match: a point triangulated from two different markers.
        target.insert(2, [t.x + 31.0, t.y - 17.0, t.z + 44.0]);
        let m: Vec<[f64; 3]> = model.iter().map(|p| [p.x, p.y, p.z]).collect();
        let reg = register(&m, &target, &RegisterSettings { with_scale, ..Default::default() }).unwrap();
        assert_eq!(reg.outliers, vec![2]);
        assert_eq!(reg.pairs.len(), 5);
        assert!((reg.transform.rotation - r).abs().max() < 1e-9);
        assert!((reg.transform.translation - t).norm() < 1e-9 * t.norm());
        assert!((reg.transform.scale - s).abs() < 1e-12);
        assert!(reg.rms < 1e-9);
    }
}

/// A regular grid of 44 markers (OpenCV's asymmetric circle grid, which matches itself under
/// many shifts) triangulated with two wrong matches nearby and three far away (nearly parallel
/// rays, thousands of units off): with the default inlier distance (2 % of the extent without the
/// far points) the grid is registered exactly and the five wrong points are the outliers. With
/// the extent of all points the inlier distance would exceed the grid itself.
#[test]
fn grid_registration_ignores_far_wrong_matches() {
    let model: Vec<Vector3<f64>> = (0..11).flat_map(|i| (0..4).map(move |j| Vector3::new((2 * j + i % 2) as f64, i as f64, 0.0))).collect();
    let r = *Rotation3::from_scaled_axis(Vector3::new(0.2, -0.5, 0.3)).matrix();
    let t = Vector3::new(-3.0, -5.0, 28.0);
    let mut target: Vec<[f64; 3]> = model.iter().map(|p| r * p + t).map(|p| [p.x, p.y, p.z]).collect();
    target.extend([[t.x + 0.5, t.y + 0.4, t.z + 1.5], [t.x + 3.3, t.y + 7.1, t.z - 2.0], [-2054.0, -1349.0, 12812.0], [-30.0, 40.0, 3715.0], [15.0, 9.0, 1729.0]]);
    let m: Vec<[f64; 3]> = model.iter().map(|p| [p.x, p.y, p.z]).collect();
    let reg = register(&m, &target, &RegisterSettings::default()).unwrap();
    assert_eq!(reg.outliers, vec![44, 45, 46, 47, 48]);
    assert_eq!(reg.pairs.len(), 44);
    assert!(reg.pairs.iter().all(|p| p.0 == p.1), "each model marker on its own point");
    assert!((reg.transform.rotation - r).abs().max() < 1e-9 && (reg.transform.translation - t).norm() < 1e-9 * t.norm());
    assert!(reg.inlier_distance < 0.3, "inlier distance {}", reg.inlier_distance);
}

/// Collinear markers and too few matches are refused with a message naming the cause.
#[test]
fn registration_refuses_collinear_markers_and_too_few_matches() {
    let line: Vec<[f64; 3]> = (0..4).map(|k| [k as f64 * 10.0, 2.0 * k as f64, 0.0]).collect();
    let tri = vec![[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [3.0, 3.0, 5.0]];
    let e = register(&line, &tri, &RegisterSettings::default()).unwrap_err().to_string();
    assert!(e.contains("collinear"), "{e}");
    let e = register(&tri, &line, &RegisterSettings::default()).unwrap_err().to_string();
    assert!(e.contains("collinear"), "{e}");
    let e = register(&tri, &tri[..2], &RegisterSettings::default()).unwrap_err().to_string();
    assert!(e.contains("too few matches"), "{e}");
}

/// The round trip: a sphere carrying four 7-mm markers rendered by lucent through two distorted
/// cameras (16 spp, sensor noise σ = 0.002, 8-bit sRGB). Every marker is detected and matched;
/// the perspective-corrected centres are within 0.1 px of the true images of the markers'
/// centres; the registered model lands within 0.1 % of the sphere's diameter.
#[test]
fn round_trip_sphere_with_four_markers() {
    let sc = MarkerScene::standard();
    let views = TwoViews::new(&sc.calibration()).unwrap();
    let mut found = Vec::new();
    for v in 0..2 {
        let px = sc.photograph(v, 16, 7, 0.002).unwrap();
        let d = &sc.cameras[v];
        let img = Image::new(d.width as usize, d.height as usize, px.iter().map(|&c| render::image_io::srgb_decode(c as f64 / 255.0) as f32).collect()).unwrap();
        let s = DetectSettings { hough: scan::markers::hough::HoughSettings { radius_min_px: 3.0, radius_max_px: 40.0, ..Default::default() }, ..Default::default() };
        let ms = detect(&img, &s);
        let short: Vec<String> = ms.iter().map(|m| format!("({:.2}, {:.2}) r {:.2} support {:.2} rms {:.3} score {:.2}", m.x, m.y, m.radius_px, m.support, m.rms_px, m.score)).collect();
        assert_eq!(ms.len(), 4, "view {v}: {short:?}, truth {:?}", sc.projected_centres(v));
        found.push(ms);
    }
    let st = match_markers(&views, &found[0], &found[1], &MatchSettings::default());
    assert_eq!(st.matches.len(), 4, "{st:?}");
    let truth = [sc.projected_centres(0), sc.projected_centres(1)];
    let mut worst = [0.0f64; 2];
    let mut worst_ellipse = 0.0f64;
    for m in &st.matches {
        let k = (0..4).min_by(|&i, &j| (truth[0][i][0] - m.centre_a[0]).hypot(truth[0][i][1] - m.centre_a[1]).total_cmp(&(truth[0][j][0] - m.centre_a[0]).hypot(truth[0][j][1] - m.centre_a[1]))).unwrap();
        let ea = (truth[0][k][0] - m.centre_a[0]).hypot(truth[0][k][1] - m.centre_a[1]);
        let eb = (truth[1][k][0] - m.centre_b[0]).hypot(truth[1][k][1] - m.centre_b[1]);
        let ma = &found[0][m.a];
        worst_ellipse = worst_ellipse.max((truth[0][k][0] - ma.x).hypot(truth[0][k][1] - ma.y));
        worst = [worst[0].max(ea), worst[1].max(eb)];
        eprintln!("marker {k}: A corrected {:+.3} {:+.3} ellipse {:+.3} {:+.3}; B corrected {:+.3} {:+.3}; normal dis {:.3} rad", m.centre_a[0] - truth[0][k][0], m.centre_a[1] - truth[0][k][1], ma.x - truth[0][k][0], ma.y - truth[0][k][1], m.centre_b[0] - truth[1][k][0], m.centre_b[1] - truth[1][k][1], m.normal_disagreement_rad);
        assert!(m.corrected);
    }
    eprintln!("round trip: centre errors A {:.4} px, B {:.4} px (ellipse centres in A: {:.4} px)", worst[0], worst[1], worst_ellipse);
    assert!(worst[0] < 0.1 && worst[1] < 0.1, "{worst:?}");
    let pts: Vec<[f64; 3]> = st.matches.iter().map(|m| m.point).collect();
    let reg = register(&sc.model_markers(), &pts, &RegisterSettings::default()).unwrap();
    assert_eq!(reg.pairs.len(), 4);
    let q = Matrix3::from_fn(|i, j| sc.model_rotation[i][j]);
    let c = Vector3::from(sc.sphere_centre_mm);
    // Displacement of the model's points over the whole sphere: the centre and the markers.
    let mut err = (reg.transform.translation - c).norm();
    for p in sc.model_markers() {
        let p = Vector3::from(p);
        err = err.max((reg.transform.apply(&p) - (q * p + c)).norm());
    }
    let size = 2.0 * sc.sphere_radius_mm;
    eprintln!("round trip: registration error {err:.4} mm = {:.4} % of {size} mm, rms {:.4} mm", 100.0 * err / size, reg.rms);
    assert!(err < 1e-3 * size, "{err} mm");
}
