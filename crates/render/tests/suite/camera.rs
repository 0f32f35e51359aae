//! Cameras: the OpenCV model against OpenCV's documented projection formula (written out here
//! independently), rays through projected points, a rendered point's centroid, the thin-lens
//! circle of confusion, refusal of non-invertible distortion, and calibration files.

use crate::common::{scene, settings};
use glam::{Vec2, Vec3};
use render::camera::{Camera, Distortion, Extrinsics, Intrinsics, OpenCv};
use render::integrator::{render_pass, IntegratorKind};
use render::load::calibration::{parse_calibration, CalibrationNodes};
use render::math::sampling::Pcg32;

/// OpenCV's `projectPoints` as its documentation writes it: R, t world → camera, then
/// x′ = X/Z, radial (1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶), tangential p1, p2,
/// thin prism s1…s4, and the tilted sensor: s·(x‴, y‴, 1) = [[R₃₃, 0, −R₁₃], [0, R₃₃, −R₂₃],
/// [0, 0, 1]]·R(τx, τy)·(x″, y″, 1) with R(τx, τy) multiplied out as the documentation prints it.
#[allow(clippy::too_many_arguments)]
fn opencv_formula(r: &[[f64; 3]; 3], t: [f64; 3], k: [f64; 14], f: [f64; 4], p: [f64; 3]) -> [f64; 2] {
    let [k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tx, ty] = k;
    let cam: Vec<f64> = (0..3).map(|a| r[a][0] * p[0] + r[a][1] * p[1] + r[a][2] * p[2] + t[a]).collect();
    let (x, y) = (cam[0] / cam[2], cam[1] / cam[2]);
    let r2 = x * x + y * y;
    let radial = (1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2) / (1.0 + k4 * r2 + k5 * r2 * r2 + k6 * r2 * r2 * r2);
    let xpp = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + s1 * r2 + s2 * r2 * r2;
    let ypp = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * r2 + s4 * r2 * r2;
    let (sx, cx) = tx.sin_cos();
    let (sy, cy) = ty.sin_cos();
    let rt = [[cy, sy * sx, -sy * cx], [0.0, cx, sx], [sy, -cy * sx, cy * cx]];
    let v: Vec<f64> = (0..3).map(|a| rt[a][0] * xpp + rt[a][1] * ypp + rt[a][2]).collect();
    let w = [rt[2][2] * v[0] - rt[0][2] * v[2], rt[2][2] * v[1] - rt[1][2] * v[2], v[2]];
    [f[0] * w[0] / w[2] + f[2], f[1] * w[1] / w[2] + f[3]]
}

/// Rotation of a Rodrigues vector, written as the exponential of the cross-product matrix
/// summed as a power series (independent of the closed form in the camera module).
fn rotation_series(v: [f64; 3]) -> [[f64; 3]; 3] {
    let k = [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]];
    let mut r = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut term = r;
    for n in 1..40 {
        let mut next = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                next[a][b] = (0..3).map(|c| term[a][c] * k[c][b]).sum::<f64>() / n as f64;
            }
        }
        term = next;
        for a in 0..3 {
            for b in 0..3 {
                r[a][b] += term[a][b];
            }
        }
    }
    r
}

fn uniform(rng: &mut Pcg32, a: f64, b: f64) -> f64 {
    a + (b - a) * rng.next_f64()
}

#[test]
fn opencv_projection_matches_the_formula_and_rays_pass_through_the_points() {
    let mut rng = Pcg32::new(7, 1);
    let (w, h) = (640u32, 480u32);
    let (mut cameras, mut points, mut refused, mut folded) = (0, 0, 0, 0);
    let (mut worst_px, mut worst_px_f32, mut worst_ray, mut worst_ray_f32) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    while cameras < 40 {
        let f = [uniform(&mut rng, 400.0, 900.0), uniform(&mut rng, 400.0, 900.0), uniform(&mut rng, 300.0, 340.0), uniform(&mut rng, 220.0, 260.0)];
        let rational = rng.next_f64() < 0.5;
        // A third of the cameras add thin-prism and tilt terms (OpenCV's 14-coefficient model).
        let full = rng.next_f64() < 1.0 / 3.0;
        let s = |rng: &mut Pcg32, a: f64| uniform(rng, -a, a);
        let k = [
            s(&mut rng, 0.3),
            s(&mut rng, 0.1),
            s(&mut rng, 0.003),
            s(&mut rng, 0.003),
            s(&mut rng, 0.05),
            if rational { s(&mut rng, 0.2) } else { 0.0 },
            if rational { s(&mut rng, 0.05) } else { 0.0 },
            if rational { s(&mut rng, 0.02) } else { 0.0 },
            if full { s(&mut rng, 0.004) } else { 0.0 },
            if full { s(&mut rng, 0.002) } else { 0.0 },
            if full { s(&mut rng, 0.004) } else { 0.0 },
            if full { s(&mut rng, 0.002) } else { 0.0 },
            if full { s(&mut rng, 0.08) } else { 0.0 },
            if full { s(&mut rng, 0.08) } else { 0.0 },
        ];
        let rvec = [s(&mut rng, 2.0), s(&mut rng, 2.0), s(&mut rng, 2.0)];
        let t = [s(&mut rng, 1.0), s(&mut rng, 1.0), s(&mut rng, 1.0)];
        let r = rotation_series(rvec);
        let intr = Intrinsics { fx: f[0], fy: f[1], cx: f[2], cy: f[3] };
        let dist = Distortion::from_opencv(&k).unwrap();
        let cam = match OpenCv::new(intr, dist, Extrinsics::from_rvec(rvec, t).unwrap(), w, h) {
            Ok(c) => c,
            Err(_) => {
                refused += 1;
                continue;
            }
        };
        let camera = Camera::opencv(cam.clone(), w, h).unwrap();
        cameras += 1;
        let mut n = 0;
        while n < 50 {
            // A world point in front of the camera: camera coordinates (x z, y z, z), mapped back.
            let z = uniform(&mut rng, 0.5, 20.0);
            let (x, y) = (s(&mut rng, 0.6), s(&mut rng, 0.45));
            let pc = [x * z - t[0], y * z - t[1], z - t[2]];
            let pw = [0, 1, 2].map(|a| r[0][a] * pc[0] + r[1][a] * pc[1] + r[2][a] * pc[2]);
            // Round to f32 so that every path sees the same point.
            let p32 = Vec3::new(pw[0] as f32, pw[1] as f32, pw[2] as f32);
            let p = [p32.x as f64, p32.y as f64, p32.z as f64];
            let want = opencv_formula(&r, t, k, f, p);
            if !(want[0] >= -0.5 && want[0] < w as f64 - 0.5 && want[1] >= -0.5 && want[1] < h as f64 - 0.5) {
                continue;
            }
            // Polynomial models fold back far outside the calibrated field: a point beyond the
            // radius where r·radial(r) stops increasing can land inside the image, but it is not
            // what the pixel sees (the ray goes through the preimage on the increasing branch).
            let radial = |r: f64| {
                let r2 = r * r;
                r * (1.0 + k[0] * r2 + k[1] * r2 * r2 + k[4] * r2 * r2 * r2) / (1.0 + k[5] * r2 + k[6] * r2 * r2 + k[7] * r2 * r2 * r2)
            };
            let rp = x.hypot(y);
            if (1..=200).any(|m| radial(rp * m as f64 / 200.0) <= radial(rp * (m - 1) as f64 / 200.0)) {
                folded += 1;
                continue;
            }
            n += 1;
            let got = cam.project_pixel(p).unwrap();
            worst_px = worst_px.max((got[0] - want[0]).hypot(got[1] - want[1]));
            let film = camera.project(p32).unwrap();
            worst_px_f32 = worst_px_f32.max((film.x as f64 - 0.5 - want[0]).hypot(film.y as f64 - 0.5 - want[1]));
            // The ray through that position, f64 and the renderer's f32 ray.
            let dist_to_ray = |o: [f64; 3], d: [f64; 3]| {
                let v = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
                // |v × d| / (|v| |d|): the miss distance relative to the point's distance.
                let c = [v[1] * d[2] - v[2] * d[1], v[2] * d[0] - v[0] * d[2], v[0] * d[1] - v[1] * d[0]];
                let n = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                n(c) / (n(v) * n(d))
            };
            let (o, d) = cam.ray_pixel(want[0], want[1]);
            worst_ray = worst_ray.max(dist_to_ray(o, d));
            let (fxp, fyp) = (want[0] + 0.5, want[1] + 0.5);
            let (i, j) = (fxp.floor(), fyp.floor());
            let ray = camera.generate_ray(i as u32, j as u32, Vec2::new((fxp - i) as f32, (fyp - j) as f32));
            let f3 = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
            worst_ray_f32 = worst_ray_f32.max(dist_to_ray(f3(ray.o), f3(ray.d)));
            points += 1;
        }
    }
    eprintln!(
        "opencv: {cameras} cameras ({refused} refused), {points} points ({folded} on the folded branch skipped): projection error {worst_px:.2e} px (f64), {worst_px_f32:.2e} px (film, f32); ray miss / distance {worst_ray:.2e} (f64), {worst_ray_f32:.2e} (f32 ray)"
    );
    assert!(worst_px < 1e-9, "f64 projection differs from the formula by {worst_px:e} px");
    assert!(worst_px_f32 < 1e-4, "film projection differs from the formula by {worst_px_f32:e} px");
    assert!(worst_ray < 1e-9, "f64 ray misses by {worst_ray:e} of the distance");
    assert!(worst_ray_f32 < 1e-6, "ray misses by {worst_ray_f32:e} of the distance");
}

/// OpenCV 5.1.0's `cv2.projectPoints` on a camera with all 14 distortion coefficients
/// (`benches-peers/opencv_project_points.py` prints these values): lucent's projection agrees to
/// 1e-9 px, and the ray through each of OpenCV's pixels passes through its point.
#[test]
fn opencv_14_coefficients_match_opencv_project_points() {
    const POINTS: [[f64; 3]; 18] = [[-0.45, -0.3, -0.2], [-0.45, -0.3, 0.25], [-0.45, 0.1, -0.2], [-0.45, 0.1, 0.25], [-0.45, 0.33, -0.2], [-0.45, 0.33, 0.25], [0.0, -0.3, -0.2], [0.0, -0.3, 0.25], [0.0, 0.1, -0.2], [0.0, 0.1, 0.25], [0.0, 0.33, -0.2], [0.0, 0.33, 0.25], [0.38, -0.3, -0.2], [0.38, -0.3, 0.25], [0.38, 0.1, -0.2], [0.38, 0.1, 0.25], [0.38, 0.33, -0.2], [0.38, 0.33, 0.25]];
    const PIXELS: [[f64; 2]; 18] = [
        [173.666089138722, 30.321154942307],
        [168.099042053963, 54.075816954271],
        [157.601974706262, 225.333755649041],
        [155.546881104685, 207.463468393134],
        [150.973838531664, 335.834819047914],
        [149.962224446141, 294.946320278981],
        [387.862691526272, 51.492591913419],
        [338.339679459480, 69.488471125257],
        [372.234127832613, 237.950223199829],
        [325.949499260973, 218.043482187036],
        [362.911098398425, 343.527145997291],
        [318.972516918266, 302.698775162763],
        [549.167038915666, 72.148951711113],
        [471.676490195479, 84.301042310782],
        [534.277657507966, 247.465071483463],
        [459.606004622591, 226.612583771074],
        [523.586826912924, 346.808893731239],
        [451.807663695927, 307.708163661156],
    ];
    let d = [-0.21, 0.08, 0.0012, -0.0009, -0.02, 0.05, 0.01, -0.004, 0.0021, -0.0013, -0.0017, 0.0008, 0.031, -0.022];
    let intr = Intrinsics { fx: 812.5, fy: 805.0, cx: 331.25, cy: 236.75 };
    let cam = OpenCv::new(intr, Distortion::from_opencv(&d).unwrap(), Extrinsics::from_rvec([0.11, -0.23, 0.07], [0.05, -0.12, 1.9]).unwrap(), 640, 480).unwrap();
    let (mut worst_px, mut worst_ray) = (0.0f64, 0.0f64);
    for (p, want) in POINTS.iter().zip(PIXELS) {
        let got = cam.project_pixel(*p).unwrap();
        worst_px = worst_px.max((got[0] - want[0]).hypot(got[1] - want[1]));
        let (o, dir) = cam.ray_pixel(want[0], want[1]);
        let v = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        let c = [v[1] * dir[2] - v[2] * dir[1], v[2] * dir[0] - v[0] * dir[2], v[0] * dir[1] - v[1] * dir[0]];
        let n = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        worst_ray = worst_ray.max(n(c) / n(v));
    }
    // The reference values carry 12 decimals.
    assert!(worst_px < 2e-9, "lucent vs OpenCV projectPoints: {worst_px:e} px");
    assert!(worst_ray < 1e-10, "ray through OpenCV's pixel misses by {worst_ray:e} of the distance");
    // Without the tilt the same camera moves every point by pixels: the reference sees it.
    let mut untilted = d;
    untilted[12] = 0.0;
    untilted[13] = 0.0;
    let flat = OpenCv::new(intr, Distortion::from_opencv(&untilted).unwrap(), cam.extrinsics, 640, 480).unwrap();
    let shift = POINTS.iter().zip(PIXELS).map(|(p, w)| {
        let g = flat.project_pixel(*p).unwrap();
        (g[0] - w[0]).hypot(g[1] - w[1])
    });
    let shift = shift.fold(0.0f64, f64::max);
    assert!(shift > 1.0, "the tilt moves the points by at most {shift} px");
}

#[test]
fn undistorted_opencv_camera_is_the_pinhole() {
    // The pinhole with camera constant d at W×H is OpenCV's fx = fy = d·H, cx = W/2 − ½,
    // cy = H/2 − ½, rows (right, −up, forward): the same rays and projections.
    let (w, h) = (40u32, 30u32);
    let pin = Camera::look_at(Vec3::new(0.3, 0.2, -2.0), Vec3::new(0.1, 0.0, 0.5), Vec3::Y, 35.0, w, h).unwrap();
    let p = pin.pinhole().unwrap().clone();
    let row = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
    let r = [row(p.right), row(-p.up), row(p.forward)];
    let e = row(p.eye);
    let t = [0, 1, 2].map(|a| -(r[a][0] * e[0] + r[a][1] * e[1] + r[a][2] * e[2]));
    let fpx = p.d as f64 * h as f64;
    let intr = Intrinsics { fx: fpx, fy: fpx, cx: w as f64 / 2.0 - 0.5, cy: h as f64 / 2.0 - 0.5 };
    let cv = Camera::opencv(OpenCv::new(intr, Distortion::default(), Extrinsics::from_rt(r, t).unwrap(), w, h).unwrap(), w, h).unwrap();
    let mut rng = Pcg32::new(3, 3);
    let mut worst = 0.0f32;
    for _ in 0..200 {
        let (i, j, u) = (rng.next_u32() % w, rng.next_u32() % h, rng.next_2d());
        let (a, b) = (pin.generate_ray(i, j, u), cv.generate_ray(i, j, u));
        worst = worst.max((a.d - b.d).length()).max((a.o - b.o).length());
        let q = a.o + a.d * 3.0;
        let (pa, pb) = (pin.project(q).unwrap(), cv.project(q).unwrap());
        assert!((pa - pb).length() < 2e-3, "{pa} vs {pb}");
        assert!((pa - Vec2::new(i as f32 + u.x, j as f32 + u.y)).length() < 2e-3);
    }
    assert!(worst < 1e-6, "pinhole and OpenCV rays differ by {worst}");
}

#[test]
fn resolution_change_keeps_the_view() {
    let intr = Intrinsics { fx: 500.0, fy: 510.0, cx: 330.0, cy: 235.0 };
    let dist = Distortion::from_opencv(&[-0.2, 0.05, 0.001, -0.001, 0.0]).unwrap();
    let cam = OpenCv::new(intr, dist, Extrinsics::from_rvec([0.1, -0.2, 0.05], [0.0, 0.1, 2.0]).unwrap(), 640, 480).unwrap();
    let mut a = Camera::opencv(cam, 640, 480).unwrap();
    let p = Vec3::new(0.3, -0.2, 1.0);
    let before = a.project(p).unwrap();
    a.set_resolution(320, 240);
    let after = a.project(p).unwrap();
    assert!((after * 2.0 - before).length() < 1e-3, "{before} → {after}");
}

/// Centroid (film coordinates) and second moment about it of an image's Y channel.
fn moments(img: &[[f32; 3]], w: u32) -> (Vec2, f64, f64) {
    let (mut s, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
    for (n, p) in img.iter().enumerate() {
        let (x, y) = ((n as u32 % w) as f64 + 0.5, (n as u32 / w) as f64 + 0.5);
        s += p[1] as f64;
        sx += p[1] as f64 * x;
        sy += p[1] as f64 * y;
    }
    let (cx, cy) = (sx / s, sy / s);
    let m2 = img.iter().enumerate().map(|(n, p)| {
        let (x, y) = ((n as u32 % w) as f64 + 0.5, (n as u32 / w) as f64 + 0.5);
        p[1] as f64 * ((x - cx).powi(2) + (y - cy).powi(2))
    });
    (Vec2::new(cx as f32, cy as f32), m2.sum::<f64>() / s, s)
}

fn render_mean(s: &render::scene::Scene, spp: u64, seed: u64) -> Vec<[f32; 3]> {
    let (w, h) = s.resolution();
    let n = (w * h) as usize;
    let st = settings(IntegratorKind::Direct, 1, 5);
    let mut acc = vec![[0.0f32; 3]; n];
    let mut buf = vec![[0.0f32; 3]; n];
    for pass in 0..spp {
        render_pass(s, &st, seed, pass, &mut buf);
        for (a, b) in acc.iter_mut().zip(&buf) {
            for c in 0..3 {
                a[c] += b[c] / spp as f32;
            }
        }
    }
    acc
}

/// A black sphere of radius 0.13 m at `centre` (m) that emits radiance 1, seen by the camera
/// described by `camera` (the lines of a `[camera]` table).
fn emissive_dot(camera: &str, centre: [f64; 3]) -> render::scene::Scene {
    scene(&format!(
        r#"
        unit = "m"
        [camera]
        {camera}
        [materials.black]
        type = "lambertian"
        albedo = 0
        [[objects]]
        name = "dot"
        material = "black"
        sphere = {{ center = [{}, {}, {}], radius = 0.13 }}
        [[lights]]
        type = "area"
        object = "dot"
        radiance = 1
        "#,
        centre[0], centre[1], centre[2]
    ))
}

/// The distance (px) between a rendered dot's image centroid (64 px wide image, 512 spp) and the
/// camera's projection of its centre.
fn centroid_offset(s: &render::scene::Scene, centre: [f64; 3], what: &str) -> f32 {
    let img = render_mean(s, 512, 5);
    let (c, _, _) = moments(&img, 64);
    let want = s.camera.project(Vec3::new(centre[0] as f32, centre[1] as f32, centre[2] as f32)).unwrap();
    let err = (c - want).length();
    eprintln!("{what}: centroid {c}, projected centre {want}, |Δ| = {err:.4} px");
    err
}

#[test]
fn rendered_emissive_sphere_centroid_is_the_projected_centre() {
    // A sphere of image radius ≈ 2.5 px through a distorted OpenCV camera, direct lighting (the
    // camera ray sees the emitter). Its image centroid differs from the projection of its centre
    // by the distortion's curvature (≈ h R²/8 ≈ 0.003 px here) and the coverage noise.
    let centre = [0.35, -0.2, 3.0];
    let camera = r#"model = "opencv"
        width = 64
        height = 48
        fx = 60.0
        fy = 62.0
        cx = 31.2
        cy = 24.1
        k1 = -0.12
        k2 = 0.02
        p1 = 0.002
        p2 = -0.001
        rvec = [0.02, -0.03, 0.01]
        t = [0.05, 0.02, 0.1]"#;
    let err = centroid_offset(&emissive_dot(camera, centre), centre, "emissive sphere");
    assert!(err < 0.05, "centroid off the projected centre by {err} px");
}

#[test]
fn thin_lens_blur_circle_matches_the_thin_lens_formula() {
    // Pinhole + thin lens of aperture radius A focused at z_f; a small emitter on the axis at
    // depth z images as a disc of radius R = f_px·A·|z − z_f|/(z·z_f) (see camera::thin_lens),
    // convolved with the emitter's own image (radius s) and the pixel box: second moment
    // M₂ = R²/2 + s²/2 + 1/6 px².
    let (a, zf, z, rs) = (0.15f64, 1.2f64, 3.0f64, 0.05f64);
    let s = scene(&format!(
        r#"
        unit = "m"
        [camera]
        eye = [0, 0, 0]
        look_at = [0, 0, 1]
        vfov_deg = 40
        width = 48
        height = 48
        aperture_radius = {a}
        focus_distance = {zf}
        [materials.black]
        type = "lambertian"
        albedo = 0
        [[objects]]
        name = "dot"
        material = "black"
        sphere = {{ center = [0, 0, {z}], radius = {rs} }}
        [[lights]]
        type = "area"
        object = "dot"
        radiance = 1
        "#
    ));
    let fpx = s.camera.focal_length_px();
    let r_want = fpx * a * (z - zf).abs() / (z * zf);
    let s_px = fpx * rs / (z * z - rs * rs).sqrt();
    let img = render_mean(&s, 256, 9);
    let (c, m2, _) = moments(&img, 48);
    let r_got = (2.0 * (m2 - s_px * s_px / 2.0 - 1.0 / 6.0)).sqrt();
    eprintln!("thin lens: blur radius {r_got:.3} px, formula {r_want:.3} px (centroid {c})");
    assert!((r_got / r_want - 1.0).abs() < 0.02, "blur radius {r_got} px, thin-lens formula {r_want} px");
    // The centroid stays on the axis (within the coverage noise of a few thousand lens hits).
    assert!((c - Vec2::new(24.0, 24.0)).length() < 0.3, "centroid {c}");
    // f-number: A = f/(2N).
    let l = render::camera::ThinLens::from_f_number(2.0, 0.05, 1.0).unwrap();
    assert!((l.aperture_radius_m - 0.0125).abs() < 1e-7);
}

#[test]
fn non_invertible_distortion_is_refused() {
    let intr = Intrinsics { fx: 400.0, fy: 400.0, cx: 319.5, cy: 239.5 };
    let e = Extrinsics::from_rt([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]).unwrap();
    // r(1 + k1 r²) turns back at r = 1/√(−3 k1) = 0.577 < the corner radius 1.0.
    let bad = Distortion::from_opencv(&[-1.0, 0.0, 0.0, 0.0]).unwrap();
    let err = OpenCv::new(intr, bad, e, 640, 480).unwrap_err().to_string();
    assert!(err.contains("not invertible") && !err.contains('\n'), "{err}");
    // The same coefficient is fine for a narrower image (corner radius 0.25).
    assert!(OpenCv::new(Intrinsics { fx: 1600.0, fy: 1600.0, ..intr }, bad, e, 640, 480).is_ok());
    // A rational denominator that vanishes inside the image.
    let pole = Distortion::from_opencv(&[0.0, 0.0, 0.0, 0.0, 0.0, -2.0, 0.0, 0.0]).unwrap();
    assert!(OpenCv::new(intr, pole, e, 640, 480).unwrap_err().to_string().contains("not invertible"));
    // In a scene: one line naming the file and the camera.
    let text = "[camera]\nmodel = \"opencv\"\nwidth = 640\nheight = 480\nfx = 400\nfy = 400\ncx = 319.5\ncy = 239.5\nk1 = -1.0\nR = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nt = [0, 0, 0]\n[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nmaterial = \"m\"\nsphere = { center = [0, 0, 5], radius = 1 }\n";
    let e = render::scene::Scene::from_toml_str(text, "bad.toml", std::path::Path::new(".")).err().unwrap();
    let msg = format!("{e:#}");
    assert!(msg.starts_with("bad.toml:1:1: camera") && msg.contains("not invertible") && !msg.contains('\n'), "{msg}");
}

/// The named keys s1…s4, tau_x_rad, tau_y_rad are OpenCV's entries 9–14 of `dist`; a tilt of 45°
/// or more is one line naming its key.
#[test]
fn prism_and_tilt_keys_are_opencv_entries_9_to_14() {
    let base = "[camera]\nmodel = \"opencv\"\nwidth = 320\nheight = 240\nfx = 300\nfy = 310\ncx = 160.2\ncy = 118.9\nR = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nt = [0, 0, 0]\n";
    let tail = "[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nmaterial = \"m\"\nsphere = { center = [0, 0, 5], radius = 1 }\n";
    let named = scene(&format!("{base}k1 = -0.1\np2 = 0.001\ns1 = 0.003\ns2 = -0.002\ns3 = -0.001\ns4 = 0.004\ntau_x_rad = 0.04\ntau_y_rad = -0.03\n{tail}"));
    let listed = scene(&format!("{base}dist = [-0.1, 0, 0, 0.001, 0, 0, 0, 0, 0.003, -0.002, -0.001, 0.004, 0.04, -0.03]\n{tail}"));
    let plain = scene(&format!("{base}k1 = -0.1\np2 = 0.001\n{tail}"));
    let mut moved = 0.0f32;
    for (x, y) in [(-0.5f32, -0.4f32), (0.0, 0.0), (0.45, 0.3), (-0.2, 0.35)] {
        let p = Vec3::new(x * 4.0, y * 4.0, 4.0);
        let (a, b) = (named.camera.project(p).unwrap(), listed.camera.project(p).unwrap());
        assert!((a - b).length() < 1e-4, "{a} vs {b}");
        moved = moved.max((a - plain.camera.project(p).unwrap()).length());
    }
    assert!(moved > 0.5, "prism and tilt moved the points by at most {moved} px");
    let bad = format!("{base}tau_x_rad = 0.8\n{tail}");
    let e = render::scene::Scene::from_toml_str(&bad, "tilt.toml", std::path::Path::new(".")).err().unwrap();
    let msg = format!("{e:#}");
    assert!(msg.starts_with("tilt.toml:") && msg.contains("tau_x_rad") && msg.contains("45°") && !msg.contains('\n'), "{msg}");
}

const YAML: &str = r#"%YAML:1.0
---
calibration_time: "Tue Dec  1 12:00:00 2026"
nr_of_frames: 14
image_width: 640
image_height: 480
board_width: 9
board_height: 6
square_size: 25.
flags: 0
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 5.3221e+02, 0., 3.1877e+02, 0., 5.3260e+02,
       2.4375e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ -2.8089e-01, 2.5e-02, 1.2e-03, -1.4e-04, 1.6e-01 ]
avg_reprojection_error: 3.9e-01
"#;

const XML: &str = r#"<?xml version="1.0"?>
<opencv_storage>
<calibration_time>"Tue Dec  1 12:00:00 2026"</calibration_time>
<image_width>640</image_width>
<image_height>480</image_height>
<cam_K type_id="opencv-matrix">
  <rows>3</rows>
  <cols>3</cols>
  <dt>d</dt>
  <data>
    5.3221e+02 0. 3.1877e+02 0. 5.3260e+02 2.4375e+02 0. 0. 1.</data></cam_K>
<cam_D type_id="opencv-matrix">
  <rows>1</rows>
  <cols>5</cols>
  <dt>d</dt>
  <data>
    -2.8089e-01 2.5e-02 1.2e-03 -1.4e-04 1.6e-01</data></cam_D>
<R type_id="opencv-matrix">
  <rows>3</rows>
  <cols>3</cols>
  <dt>d</dt>
  <data>
    1. 0. 0. 0. 1. 0. 0. 0. 1.</data></R>
<T type_id="opencv-matrix">
  <rows>3</rows>
  <cols>1</cols>
  <dt>d</dt>
  <data>
    0.1 -0.2 3.</data></T>
</opencv_storage>
"#;

#[test]
fn filestorage_yaml_xml_and_json_round_trip() {
    let want_k = Intrinsics { fx: 532.21, fy: 532.60, cx: 318.77, cy: 243.75 };
    let want_d = Distortion::from_opencv(&[-0.28089, 0.025, 0.0012, -0.00014, 0.16]).unwrap();
    let y = parse_calibration(YAML, "c.yml", &CalibrationNodes::default()).unwrap();
    assert_eq!((y.width, y.height), (Some(640), Some(480)));
    assert_eq!((y.intrinsics, y.distortion), (want_k, want_d));
    assert!(y.r.is_none() && y.t.is_none());
    let nodes = CalibrationNodes { matrix: "cam_K".into(), dist: "cam_D".into() };
    let x = parse_calibration(XML, "c.xml", &nodes).unwrap();
    assert_eq!((x.width, x.height, x.intrinsics, x.distortion), (Some(640), Some(480), want_k, want_d));
    assert_eq!(x.t, Some([0.1, -0.2, 3.0]));
    let json = r#"{"width": 640, "height": 480, "fx": 532.21, "fy": 532.60, "cx": 318.77, "cy": 243.75,
        "dist": [-0.28089, 0.025, 0.0012, -0.00014, 0.16], "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [100, -200, 3000], "unit": "mm"}"#;
    let j = parse_calibration(json, "c.json", &nodes).unwrap();
    assert_eq!((j.intrinsics, j.distortion), (want_k, want_d));
    let (ex, ej) = (x.extrinsics(1.0).unwrap().unwrap(), j.extrinsics(1.0).unwrap().unwrap());
    assert!(ex.t_m.iter().zip(ej.t_m.iter()).all(|(a, b)| (a - b).abs() < 1e-12));
    // procam-calibration's calibration_result.xml gives the size as img_shape = [rows, cols].
    let procam = XML.replace("<image_width>640</image_width>", "").replace("<image_height>480</image_height>", "").replace(
        "<cam_K ",
        "<img_shape type_id=\"opencv-matrix\">\n  <rows>2</rows>\n  <cols>1</cols>\n  <dt>d</dt>\n  <data>\n    480. 640.</data></img_shape>\n<cam_K ",
    );
    assert!(!procam.contains("image_width") && procam.contains("img_shape"));
    let k = parse_calibration(&procam, "calibration_result.xml", &nodes).unwrap();
    assert_eq!((k.width, k.height, k.intrinsics, k.distortion), (Some(640), Some(480), want_k, want_d));
    // Missing nodes name the node.
    let e = parse_calibration(XML, "c.xml", &CalibrationNodes::default()).unwrap_err().to_string();
    assert!(e.starts_with("c.xml: camera_matrix: no such node"), "{e}");
    let e = parse_calibration(YAML, "c.yml", &CalibrationNodes { matrix: "camera_matrix".into(), dist: "D".into() }).unwrap_err().to_string();
    assert!(e.starts_with("c.yml: D: no such node"), "{e}");
    // The scene reads the same file and places the camera with its R, t.
    let dir = std::env::temp_dir().join(format!("lucent-camera-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("c.xml"), XML).unwrap();
    let text = "[camera]\ncalibration = \"c.xml\"\nmatrix_node = \"cam_K\"\ndist_node = \"cam_D\"\n[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nmaterial = \"m\"\nsphere = { center = [0, 0, 5], radius = 1 }\n";
    let s = render::scene::Scene::from_toml_str(text, "s.toml", &dir).unwrap();
    assert_eq!(s.resolution(), (640, 480));
    let p = Vec3::new(0.3, 0.1, 2.0);
    let cam = OpenCv::new(want_k, want_d, ex, 640, 480).unwrap();
    let q = cam.project_pixel([0.3, 0.1, 2.0]).unwrap();
    let f = s.camera.project(p).unwrap();
    assert!((f.x as f64 - 0.5 - q[0]).abs() < 1e-3 && (f.y as f64 - 0.5 - q[1]).abs() < 1e-3);
    // `lucent render --camera`: the calibration replaces the camera, keeping the scene's pose
    // when the file has none (the YAML has no R, t), and joins the content hash.
    std::fs::write(dir.join("c.yml"), YAML).unwrap();
    let mut cb = render::scene::Scene::cornell_box();
    let (eye, h0) = (cb.camera.eye(), cb.content_hash());
    cb.use_calibration(&dir.join("c.yml"), &CalibrationNodes::default()).unwrap();
    assert_eq!(cb.resolution(), (640, 480));
    assert!((cb.camera.eye() - eye).length() < 1e-4 && (cb.camera.forward() - glam::Vec3::Z).length() < 1e-6);
    assert!(cb.camera.pinhole().is_none() && cb.content_hash() != h0);
    let e = cb.use_calibration(&dir.join("c.yml"), &CalibrationNodes { matrix: "K".into(), dist: "D".into() }).unwrap_err();
    assert!(format!("{e:#}").contains("c.yml: K: no such node"), "{e:#}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn per_ray_inverse_costs_little() {
    // The Newton inverse per ray against the pinhole's ray (the renderer traces each ray through
    // the scene afterwards, which costs far more): printed, and bounded loosely.
    let intr = Intrinsics { fx: 530.0, fy: 530.0, cx: 319.5, cy: 239.5 };
    let dist = Distortion::from_opencv(&[-0.28, 0.08, 0.001, -0.0005, -0.01]).unwrap();
    let e = Extrinsics::from_rvec([0.1, 0.2, 0.3], [0.0, 0.0, 1.0]).unwrap();
    let cv = Camera::opencv(OpenCv::new(intr, dist, e, 640, 480).unwrap(), 640, 480).unwrap();
    let pin = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 48.0, 640, 480).unwrap();
    let time = |c: &Camera| {
        let t0 = std::time::Instant::now();
        let mut acc = 0.0f32;
        for j in 0..480 {
            for i in 0..640 {
                acc += c.generate_ray(i, j, Vec2::new(0.3, 0.7)).d.x;
            }
        }
        (t0.elapsed().as_secs_f64() / (640.0 * 480.0) * 1e9, std::hint::black_box(acc))
    };
    let (tp, _) = time(&pin);
    let (tc, _) = time(&cv);
    // For scale: one `path` sample of the Cornell box (64×64, 4 passes) on the same machine.
    let mut cornell = render::scene::Scene::cornell_box();
    cornell.set_resolution(64, 64);
    let mut buf = vec![[0.0f32; 3]; 64 * 64];
    let t0 = std::time::Instant::now();
    for pass in 0..4 {
        render_pass(&cornell, &settings(IntegratorKind::Path, 8, 5), 1, pass, &mut buf);
    }
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1) as f64;
    let ts = t0.elapsed().as_secs_f64() * threads / (4.0 * 64.0 * 64.0) * 1e9;
    eprintln!("ray generation: pinhole {tp:.1} ns, OpenCV with distortion (Newton per ray) {tc:.1} ns; a Cornell path sample ≈ {ts:.0} ns of one thread");
    assert!(tc < 5000.0);
}

#[test]
fn scan_calibration_json_is_read_as_camera_or_projector() {
    // A `lucent scan calibrate` file: the camera at the origin, the projector at X_p = R·X_c + T.
    let a: f64 = 0.2;
    let text = format!(
        r#"{{"camera": {{"width": 1280, "height": 1024, "fx": 3440.0, "fy": 3437.5, "cx": 536.2, "cy": 514.3, "distortion": [0.17, -4.3, -0.0019, -0.0036, 11.4], "rms_px": 0.37}},
        "projector": {{"width": 1024, "height": 768, "fx": 1893.7, "fy": 1898.3, "cx": 478.4, "cy": 839.3, "distortion": [-0.1, 0.37, 0.008, -0.002, -0.9], "rms_px": 0.23}},
        "rotation": [[{c}, 0, {s}], [0, 1, 0], [{ms}, 0, {c}]], "translation": [92.8, -624.9, -236.6], "rms_px": 0.31,
        "captures": [{{"name": "capture_0", "rvec": [0.1, 0.0, 0.0], "tvec": [0, 0, 3000], "rms_px": 0.2}}]}}"#,
        c = a.cos(),
        s = a.sin(),
        ms = -a.sin()
    );
    let cam = parse_calibration(&text, "calib.json", &CalibrationNodes::default()).unwrap();
    assert_eq!((cam.width, cam.height), (Some(1280), Some(1024)));
    assert_eq!(cam.intrinsics, Intrinsics { fx: 3440.0, fy: 3437.5, cx: 536.2, cy: 514.3 });
    // The same rig as procam-calibration's calibration_result.xml (with lucent's proj_shape), read
    // through the nodes cam_int/cam_dist and proj_int/proj_dist: the same two devices and poses.
    let xml = format!(
        "<?xml version=\"1.0\"?>\n<opencv_storage>\n{}{}{}{}{}{}{}{}</opencv_storage>\n",
        "<img_shape type_id=\"opencv-matrix\"><rows>2</rows><cols>1</cols><dt>d</dt><data>1024. 1280.</data></img_shape>\n",
        "<proj_shape type_id=\"opencv-matrix\"><rows>2</rows><cols>1</cols><dt>d</dt><data>768. 1024.</data></proj_shape>\n",
        "<cam_int type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt><data>3440. 0. 536.2 0. 3437.5 514.3 0. 0. 1.</data></cam_int>\n",
        "<cam_dist type_id=\"opencv-matrix\"><rows>1</rows><cols>5</cols><dt>d</dt><data>0.17 -4.3 -0.0019 -0.0036 11.4</data></cam_dist>\n",
        "<proj_int type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt><data>1893.7 0. 478.4 0. 1898.3 839.3 0. 0. 1.</data></proj_int>\n",
        "<proj_dist type_id=\"opencv-matrix\"><rows>1</rows><cols>5</cols><dt>d</dt><data>-0.1 0.37 0.008 -0.002 -0.9</data></proj_dist>\n",
        format!("<roration type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt><data>{c:e} 0. {s:e} 0. 1. 0. {ms:e} 0. {c:e}</data></roration>\n", c = a.cos(), s = a.sin(), ms = -a.sin()),
        "<translation type_id=\"opencv-matrix\"><rows>3</rows><cols>1</cols><dt>d</dt><data>92.8 -624.9 -236.6</data></translation>\n",
    );
    let proj_nodes = CalibrationNodes { matrix: "projector".into(), ..Default::default() };
    for (fs_nodes, json_nodes) in [(CalibrationNodes { matrix: "cam_int".into(), dist: "cam_dist".into() }, CalibrationNodes::default()), (CalibrationNodes { matrix: "proj_int".into(), dist: "proj_dist".into() }, proj_nodes)] {
        let (x, j) = (parse_calibration(&xml, "calibration_result.xml", &fs_nodes).unwrap(), parse_calibration(&text, "calib.json", &json_nodes).unwrap());
        assert_eq!((x.width, x.height, x.intrinsics, x.distortion, x.t), (j.width, j.height, j.intrinsics, j.distortion, j.t), "{}", fs_nodes.matrix);
        let (rx, rj) = (x.r.unwrap(), j.r.unwrap());
        assert!(rx.iter().flatten().zip(rj.iter().flatten()).all(|(p, q)| (p - q).abs() < 1e-15), "{}", fs_nodes.matrix);
    }
    let e = cam.extrinsics(1.0).unwrap().unwrap();
    assert_eq!(e.t_m, [0.0; 3]);
    let nodes = CalibrationNodes { matrix: "projector".into(), ..Default::default() };
    let proj = parse_calibration(&text, "calib.json", &nodes).unwrap();
    assert_eq!((proj.width, proj.height), (Some(1024), Some(768)));
    assert_eq!(proj.distortion, Distortion::from_opencv(&[-0.1, 0.37, 0.008, -0.002, -0.9]).unwrap());
    // The projector camera projects a point X (camera frame, square units) as the OpenCV model of
    // R·X + T.
    let ex = proj.extrinsics(1.0).unwrap().unwrap();
    let p = OpenCv::new(proj.intrinsics, proj.distortion, ex, 1024, 768).unwrap();
    let x = [-100.0, 300.0, 3200.0];
    let xp = [a.cos() * x[0] + a.sin() * x[2] + 92.8, x[1] - 624.9, -a.sin() * x[0] + a.cos() * x[2] - 236.6];
    let (u, v) = proj.distortion.distort(xp[0] / xp[2], xp[1] / xp[2]);
    let want = [1893.7 * u + 478.4, 1898.3 * v + 839.3];
    let got = p.project_pixel(x).unwrap();
    assert!((got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6, "{got:?} vs {want:?}");
    let e = parse_calibration(&text, "calib.json", &CalibrationNodes { matrix: "K".into(), ..Default::default() }).unwrap_err().to_string();
    assert!(e.starts_with("calib.json: ") && e.contains("`camera` and `projector`"), "{e}");
}

/// ∫ g over [a, b] by composite Simpson with `n` intervals.
fn simpson(g: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    if b <= a {
        return 0.0;
    }
    let h = (b - a) / n as f64;
    let mut s = g(a) + g(b);
    for k in 1..n {
        s += g(a + h * k as f64) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// The image of a straight emitter edge is the pixel filter's integral. An undistorted OpenCV
/// camera sees an emitter of radiance 1 covering x/z ≥ (e − cx)/fx, i.e. OpenCV columns ≥ e with
/// e = 10.3; pixel i (centre at OpenCV column i) then has expected value
/// ∫_{e−i}^{r} f / ∫ f, with f the filter's profile integrated here by Simpson's rule (the sampler
/// inverts a Gauss–Legendre table). Box, Mitsuba's tent and Gaussian, and pbrt's Gaussian
/// (r = 1.5), each within 5 binomial standard errors of 2048 samples × 4 rows per column; the
/// same scene without `filter` renders exactly as `filter = "box"`.
#[test]
fn a_rendered_edge_is_the_pixel_filter_integral() {
    let (e, cx, fx) = (10.3f64, 11.5f64, 100.0f64);
    let xe = (e - cx) / fx;
    let text = |filter: &str| {
        format!(
            r#"
            unit = "m"
            [camera]
            model = "opencv"
            width = 24
            height = 4
            fx = {fx}
            fy = {fx}
            cx = {cx}
            cy = 1.5
            rvec = [0, 0, 0]
            t = [0, 0, 0]
            {filter}
            [materials.black]
            type = "lambertian"
            albedo = 0
            [[objects]]
            name = "lamp"
            material = "black"
            quad = [[{xe}, -5, 1], [{xe}, 5, 1], [5, 5, 1], [5, -5, 1]]
            [[lights]]
            type = "area"
            object = "lamp"
            radiance = 1
            "#
        )
    };
    let spp = 2048u64;
    let y1 = crate::common::y_of_one();
    let column_means = |s: &render::scene::Scene| {
        let img = render_mean(s, spp, 3);
        (0..24).map(|i| (0..4).map(|j| img[j * 24 + i][1] as f64).sum::<f64>() / 4.0 / y1).collect::<Vec<f64>>()
    };
    for (filter, radius) in [
        ("filter = \"box\"", 0.5),
        ("filter = \"tent\"", 1.0),
        ("filter = \"gaussian\"", 2.0),
        ("filter = { type = \"gaussian\", stddev_px = 0.5, radius_px = 1.5 }", 1.5),
    ] {
        let s = scene(&text(filter));
        assert!((s.camera.filter.radius_px() - radius).abs() < 1e-12, "{filter}");
        let got = column_means(&s);
        let f = |x: f64| s.camera.filter.eval(x);
        let z = simpson(f, -radius, radius, 20_000);
        for (i, g) in got.iter().enumerate() {
            let want = simpson(f, (e - i as f64).clamp(-radius, radius), radius, 20_000) / z;
            let se = (want * (1.0 - want) / (spp as f64 * 4.0)).sqrt();
            assert!((g - want).abs() <= 5.0 * se + 2e-3, "{filter}: column {i}: {g:.4} against {want:.4} (se {se:.4})");
        }
        eprintln!("{filter}: columns 8–13 {:?}", &got[8..14].iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>());
    }
    let plain = render_mean(&scene(&text("")), 64, 5);
    let boxed = render_mean(&scene(&text("filter = \"box\"")), 64, 5);
    assert!(plain == boxed, "the default filter is not the box");
}

/// Bad filter settings name their key.
#[test]
fn bad_filters_name_the_key() {
    let base = |filter: &str| {
        format!("[camera]\neye = [0, 0, 0]\nlook_at = [0, 0, 1]\nvfov_deg = 40\n{filter}\n[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nmaterial = \"m\"\nsphere = {{ center = [0, 0, 3], radius = 1 }}\n")
    };
    for (filter, key) in [
        ("filter = \"mitchell\"", "camera.filter.type"),
        ("filter = { type = \"gaussian\", stddev_px = -1 }", "camera.filter.stddev_px"),
        ("filter = { type = \"tent\", stddev_px = 1 }", "camera.filter.stddev_px"),
        ("filter = { radius_px = 1 }", "camera.filter.type"),
        ("filter = 3", "camera.filter"),
    ] {
        let e = match render::scene::Scene::from_toml_str(&base(filter), "bad.toml", std::path::Path::new(".")) {
            Ok(_) => panic!("{filter}: accepted"),
            Err(e) => format!("{e:#}"),
        };
        assert!(e.contains(key) && e.contains("bad.toml") && !e.contains('\n'), "{filter}: {e}");
    }
}

/// Calibration files are untrusted input: 20 000 random edits of the YAML, XML and JSON above
/// (characters deleted, repeated, swapped for markup and multi-byte characters, lines cut or
/// duplicated) are each read as a calibration and as the FileStorage nodes the scan tools read;
/// none may panic, and every error is one line.
#[test]
fn mutated_calibration_files_never_panic() {
    let json = r#"{"width": 640, "height": 480, "fx": 532.21, "fy": 532.60, "cx": 318.77, "cy": 243.75, "dist": [-0.28089, 0.025, 0.0012, -0.00014, 0.16], "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [100, -200, 3000], "unit": "mm"}"#;
    let seeds = [YAML, XML, json];
    let specials = ['<', '>', '/', ':', '[', ']', '{', '}', '"', ',', '\n', ' ', '-', '.', 'e', '0', '9', 'é', '€', '𝄞', '!', '#', '\t'];
    let nodes = [CalibrationNodes::default(), CalibrationNodes { matrix: "cam_K".into(), dist: "cam_D".into() }];
    let mut rng = Pcg32::new(11, 5);
    let (mut ok, mut failed) = (0usize, 0usize);
    for n in 0..20_000u32 {
        let mut chars: Vec<char> = seeds[n as usize % 3].chars().collect();
        for _ in 0..1 + rng.next_u32() % 6 {
            if chars.is_empty() {
                break;
            }
            let i = (rng.next_u32() as usize) % chars.len();
            match rng.next_u32() % 6 {
                0 => {
                    let len = (1 + rng.next_u32() as usize % 12).min(chars.len() - i);
                    chars.drain(i..i + len);
                }
                1 => chars[i] = specials[rng.next_u32() as usize % specials.len()],
                2 => chars.insert(i, specials[rng.next_u32() as usize % specials.len()]),
                3 => {
                    let len = (1 + rng.next_u32() as usize % 40).min(chars.len() - i);
                    let piece: Vec<char> = chars[i..i + len].to_vec();
                    let j = (rng.next_u32() as usize) % chars.len();
                    chars.splice(j..j, piece);
                }
                4 => chars.truncate(i),
                _ => {
                    let digit = char::from(b'0' + (rng.next_u32() % 10) as u8);
                    chars[i] = if chars[i].is_ascii_digit() { digit } else { chars[i] };
                }
            }
        }
        let text: String = chars.into_iter().collect();
        let result = std::panic::catch_unwind(|| {
            let mut errors = Vec::new();
            let mut read = false;
            for nd in &nodes {
                match parse_calibration(&text, "m.txt", nd) {
                    Ok(c) => {
                        read = true;
                        let _ = c.extrinsics(1e-3);
                        if let (Some(w), Some(h)) = (c.width, c.height) {
                            if w <= 4096 && h <= 4096 {
                                if let Ok(e) = Extrinsics::from_rt([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]) {
                                    let _ = OpenCv::new(c.intrinsics, c.distortion, e, w, h);
                                }
                            }
                        }
                    }
                    Err(e) => errors.push(format!("{e:#}")),
                }
            }
            for name in ["cam_K", "camera_matrix", "img_shape", "image_width", "R", "T"] {
                if let Err(e) = render::load::calibration::filestorage_node(&text, name) {
                    errors.push(format!("{e:#}"));
                }
            }
            (read, errors)
        });
        match result {
            Ok((read, errors)) => {
                for e in &errors {
                    assert!(!e.contains('\n'), "edit {n}: error of more than one line: {e:?}\ninput: {text:?}");
                }
                if read {
                    ok += 1;
                } else {
                    failed += 1;
                }
            }
            Err(_) => panic!("edit {n} panicked on input {text:?}"),
        }
    }
    eprintln!("mutated calibration files: {ok} read, {failed} refused (every error one line)");
    assert!(ok > 100 && failed > 1000, "the edits should both keep and break files: {ok} / {failed}");
}

/// A fisheye camera (OpenCV's `cv::fisheye` model with skew): rays, drawn through the lens's
/// inverse, and the forward projection agree, checked by rendering. An emissive sphere 55° off the
/// axis, seen through a lens whose k1…k4 bend it strongly, has its image centroid at the
/// projection of its centre (the curvature over its ≈ 2.5-px image moves it by < 0.01 px). And
/// with k = 0 a ray's angle off the axis is its pixel's distance from the principal point over f.
#[test]
fn fisheye_camera_renders_where_it_projects() {
    use render::camera::{Fisheye, FisheyeLens};
    let lens = FisheyeLens { fx: 30.0, fy: 30.5, cx: 31.7, cy: 23.4, skew: 0.003, k: [0.05, -0.02, 0.004, -0.0004] };
    let ex = Extrinsics::from_rvec([0.02, -0.03, 0.01], [0.05, 0.02, 0.1]).unwrap();
    let cam = Fisheye::new(lens, ex, 64, 48).unwrap();
    // The sphere's centre 55° off the camera's axis, 3 m away, in world coordinates.
    let th = 55f64.to_radians();
    let c_cam = [3.0 * th.sin() * 0.8, 3.0 * th.sin() * 0.6, 3.0 * th.cos()];
    let rt = [[ex.r[0][0], ex.r[1][0], ex.r[2][0]], [ex.r[0][1], ex.r[1][1], ex.r[2][1]], [ex.r[0][2], ex.r[1][2], ex.r[2][2]]];
    let d = [c_cam[0] - ex.t_m[0], c_cam[1] - ex.t_m[1], c_cam[2] - ex.t_m[2]];
    let centre: Vec<f64> = (0..3).map(|a| rt[a][0] * d[0] + rt[a][1] * d[1] + rt[a][2] * d[2]).collect();
    let mut s = emissive_dot("eye = [0, 0, 0]\n        look_at = [0, 0, 1]\n        vfov_deg = 40\n        width = 64\n        height = 48", [centre[0], centre[1], centre[2]]);
    s.camera = Camera::fisheye(cam, 64, 48).unwrap();
    let err = centroid_offset(&s, [centre[0], centre[1], centre[2]], "fisheye emissive sphere");
    assert!(err < 0.05, "centroid off the projected centre by {err} px");
    // The equidistant lens: angle off the axis = distance from the principal point / f.
    let eq = FisheyeLens { fx: 100.0, fy: 100.0, cx: 50.0, cy: 40.0, skew: 0.0, k: [0.0; 4] };
    let cam = Fisheye::new(eq, Extrinsics::from_rvec([0.0; 3], [0.0; 3]).unwrap(), 120, 90).unwrap();
    for (u, v) in [(50.0, 40.0), (119.5, 40.0), (0.0, 89.5), (80.0, 10.0)] {
        let (_, dir) = cam.ray_pixel(u, v);
        let want = ((u - 50.0f64).hypot(v - 40.0) / 100.0).to_degrees();
        assert!((dir[2].acos().to_degrees() - want).abs() < 1e-9, "({u}, {v}): {dir:?}");
    }
    // Far outside the image, beyond the lens's 90°, a film position takes the edge of the field
    // in its azimuth (a wide pixel filter can reach there), not a ray behind the camera.
    let (_, dir) = cam.ray_pixel(50.0 + 300.0, 40.0 - 300.0);
    assert!(dir[2].abs() < 1e-12 && (dir[0] - 0.5f64.sqrt()).abs() < 1e-12 && (dir[1] + 0.5f64.sqrt()).abs() < 1e-12, "{dir:?}");
    // A lens whose θ_d turns back (at √(2/3) rad for k1 = −0.5) before the image corners has no
    // ray for them: refused.
    let fold = FisheyeLens { k: [-0.5, 0.0, 0.0, 0.0], ..eq };
    let e = Fisheye::new(fold, Extrinsics::from_rvec([0.0; 3], [0.0; 3]).unwrap(), 120, 90).unwrap_err().to_string();
    assert!(e.contains("no ray for image corner"), "{e}");
}

/// lucent's calibration JSON with `"model": "fisheye"` (as `scan calibrate-camera --fisheye`
/// writes it) is read as the fisheye model, and `lucent render --camera` takes it; a wrong number
/// of coefficients, an unknown model or a skew on the pinhole model is one line naming the key.
#[test]
fn fisheye_calibration_json_is_read() {
    let n = CalibrationNodes::default();
    let j = r#"{"width": 640, "height": 480, "fx": 300.0, "fy": 301.0, "cx": 319.5, "cy": 239.5, "model": "fisheye", "skew": 0.001, "dist": [0.05, -0.02, 0.004, -0.0004]}"#;
    let c = parse_calibration(j, "f.json", &n).unwrap();
    let f = c.fisheye.expect("a fisheye model");
    assert_eq!((f.fx, f.fy, f.cx, f.cy, f.skew, f.k), (300.0, 301.0, 319.5, 239.5, 0.001, [0.05, -0.02, 0.004, -0.0004]));
    let base = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 40.0, 64, 48).unwrap();
    let cam = render::load::camera::calibrated_camera(&c, &base, 1.0).unwrap();
    assert_eq!((cam.width, cam.height), (640, 480));
    let p = cam.project(Vec3::new(0.0, 0.0, 2.0)).unwrap();
    assert!((p.x - 320.0).abs() < 1e-4 && (p.y - 240.0).abs() < 1e-4, "{p}");
    for (bad, key) in [
        (j.replace("[0.05, -0.02, 0.004, -0.0004]", "[0.05, -0.02, 0.004, -0.0004, 0.0]"), "dist"),
        (j.replace("\"fisheye\"", "\"omnidir\""), "model"),
        (j.replace("\"model\": \"fisheye\", ", ""), "skew"),
    ] {
        let e = parse_calibration(&bad, "f.json", &n).unwrap_err().to_string();
        assert!(e.starts_with("f.json: ") && e.contains(key) && !e.contains('\n'), "{e}");
    }
}

/// `[camera] model = "fisheye"` builds the fisheye model from its keys (k1…k4 named or as
/// `dist`, `skew`): a point projects where `FisheyeLens` puts it. Pinhole-model terms with it,
/// `skew` without it, a `dist` of 5 entries and a pinhole calibration file under it are one line
/// naming the key.
#[test]
fn fisheye_scene_camera_keys() {
    use render::camera::FisheyeLens;
    let base = "model = \"fisheye\"\nwidth = 64\nheight = 48\nfx = 30.0\nfy = 30.5\ncx = 31.7\ncy = 23.4\neye = [0, 0, 0]\nlook_at = [0, 0, 1]\n";
    let lens = FisheyeLens { fx: 30.0, fy: 30.5, cx: 31.7, cy: 23.4, skew: 0.002, k: [0.05, -0.02, 0.004, -0.0004] };
    for terms in ["k1 = 0.05\nk2 = -0.02\nk3 = 0.004\nk4 = -0.0004\nskew = 0.002\n", "dist = [0.05, -0.02, 0.004, -0.0004]\nskew = 0.002\n"] {
        let s = scene(&format!("unit = \"m\"\n[camera]\n{base}{terms}[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nname = \"s\"\nmaterial = \"m\"\nsphere = {{ center = [0, 0, 3], radius = 1 }}\n"));
        let p = [0.7, -0.4, 1.5];
        let got = s.camera.project(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)).unwrap();
        // look_at with up +y: the camera's x is world −x and its y (image down) world −y.
        let want = lens.project([-p[0], -p[1], p[2]]);
        assert!((got.x as f64 - 0.5 - want[0]).abs() < 1e-4 && (got.y as f64 - 0.5 - want[1]).abs() < 1e-4, "{got} against {want:?}");
    }
    let objects = "[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nname = \"s\"\nmaterial = \"m\"\nsphere = { center = [0, 0, 3], radius = 1 }\n";
    for (extra, key) in [
        (format!("{base}p1 = 0.001\n"), "camera.p1"),
        (format!("{base}dist = [0.1, 0.0, 0.0, 0.0, 0.0]\n"), "camera.dist"),
        (base.replace("\"fisheye\"", "\"opencv\"") + "skew = 0.01\n", "camera.skew"),
    ] {
        let text = format!("unit = \"m\"\n[camera]\n{extra}{objects}");
        let e = render::scene::Scene::from_toml_str(&text, "f.toml", std::path::Path::new(".")).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains(key) && !e.contains('\n'), "{e}");
    }
}

/// `hfov_deg` is the horizontal field of view (Mitsuba 3's `fov` on its default x axis): a point
/// at angle φₓ/2 off the axis, horizontally, lands on the image's left or right edge; it is one
/// of vfov_deg, hfov_deg and camera_constant, checked for its range.
#[test]
fn hfov_puts_the_half_angle_on_the_image_edge() {
    let tail = "[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nmaterial = \"m\"\nsphere = { center = [0, 0, 5], radius = 1 }\n";
    let s = scene(&format!("[camera]\neye = [0, 0, 0]\nlook_at = [0, 0, 1]\nhfov_deg = 70\nwidth = 200\nheight = 120\n{tail}"));
    let half = 35f32.to_radians();
    let p = s.camera.project(Vec3::new(-half.tan(), 0.0, 1.0)).unwrap();
    let q = s.camera.project(Vec3::new(half.tan(), 0.0, 1.0)).unwrap();
    assert!((p.x.min(q.x)).abs() < 1e-3 && (p.x.max(q.x) - 200.0).abs() < 1e-3 && (p.y - 60.0).abs() < 1e-3, "{p} {q}");
    // The same camera by its vertical field of view: tan(φ_y/2) = tan(φₓ/2)·H/W.
    let vfov = (2.0 * (half.tan() * 120.0 / 200.0).atan()).to_degrees();
    let v = scene(&format!("[camera]\neye = [0, 0, 0]\nlook_at = [0, 0, 1]\nvfov_deg = {vfov}\nwidth = 200\nheight = 120\n{tail}"));
    let r = v.camera.project(Vec3::new(0.3, -0.2, 1.0)).unwrap();
    assert!((r - s.camera.project(Vec3::new(0.3, -0.2, 1.0)).unwrap()).length() < 1e-3);
    for bad in ["hfov_deg = 70\nvfov_deg = 40", "hfov_deg = 180", "hfov_deg = 0"] {
        let text = format!("[camera]\neye = [0, 0, 0]\nlook_at = [0, 0, 1]\n{bad}\n{tail}");
        let e = render::scene::Scene::from_toml_str(&text, "c.toml", std::path::Path::new(".")).err().unwrap();
        let msg = format!("{e:#}");
        assert!(msg.contains("c.toml") && msg.contains("fov") && !msg.contains('\n'), "{msg}");
    }
}

/// The orthographic camera: an emitting sphere of radius r (radiance 1) seen at two distances
/// covers the same image, whose summed pixels times the pixel area equal the disc's area π r²
/// (a pinhole's image would shrink with distance), centred on the projection of its centre;
/// bad keys are one-line errors.
#[test]
fn orthographic_camera_sees_a_sphere_as_its_true_disc_at_any_distance() {
    let (w, view_w) = (64u32, 0.8f64); // 0.0125 m per pixel
    let cam = |z: f64| format!("model = \"orthographic\"\neye = [0, 0, {z}]\nlook_at = [0, 0, 10]\nview_width = {view_w}\nwidth = {w}\nheight = 48");
    let centre = [0.11, -0.05, 3.0];
    let mut areas = Vec::new();
    for z in [0.0, -20.0] {
        let s = emissive_dot(&cam(z), centre);
        let img = render_mean(&s, 256, 9);
        let px = view_w / w as f64;
        // Y of constant spectral radiance 1 is 1: the green of linear sRGB is close but not exact,
        // so sum the luminance.
        let sum: f64 = img.iter().map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64).sum();
        let area = sum * px * px;
        let (c, _, _) = moments(&img, w);
        let want = s.camera.project(Vec3::new(centre[0] as f32, centre[1] as f32, centre[2] as f32)).unwrap();
        eprintln!("eye at z = {z}: image area {area:.5} m² (π r² = {:.5}), centroid {c}, projection {want}", std::f64::consts::PI * 0.13 * 0.13);
        assert!((area / (std::f64::consts::PI * 0.13 * 0.13) - 1.0).abs() < 0.01, "z {z}: area {area}");
        assert!((c - want).length() < 0.05, "z {z}: centroid {c} vs {want}");
        areas.push(area);
    }
    assert!((areas[0] / areas[1] - 1.0).abs() < 0.01);
    for (extra, key) in [("vfov_deg = 30", "vfov_deg"), ("fx = 100", "fx"), ("aperture_radius = 0.1", "aperture_radius")] {
        let text = format!("[camera]\n{}\n{extra}\n[materials.m]\ntype = \"lambertian\"\nalbedo = 0.5\n[[objects]]\nmaterial = \"m\"\nsphere = {{ center = [0, 0, 3], radius = 1 }}\n", cam(0.0));
        let e = format!("{:#}", render::scene::Scene::from_toml_str(&text, "o.toml", std::path::Path::new(".")).err().expect(key));
        assert!(e.contains(key) && !e.contains('\n'), "{e}");
    }
}
