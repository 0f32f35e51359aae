//! The whole chain of scene reassembly on one synthetic scene with known truth, run through the
//! three commands as a user runs them: `lucent scan markers` registers a sphere model onto the
//! markers it finds in two calibrated views, `lucent scan label` labels the registered sphere and
//! the board from the white-frame photograph, and `lucent fit photo` fits the labelled scene to
//! the photographs under five projector patterns (docs/digitization.md, "Synthetic round trip of
//! the whole chain", has the measured values).
//!
//! The scene (the geometry of `scan::markers::synth::MarkerScene::standard`, in millimetres,
//! view A's camera frame): a 60-mm sphere 420 mm in front of camera A (400 × 320, barrel and
//! tangential distortion), painted grey (albedo 0.42, the reference of known albedo) and carrying
//! four printed 10-mm discs of dark ink (0.01), in front of a board of three grey Lambertian
//! stripes (0.2, 0.45, 0.8) 520 mm away that fills A's view; camera B (the markers' second view)
//! 180 mm to the side; a 64 × 48 OpenCV projector 5 mm above camera A as the light, and a constant
//! ambient environment. The printed discs are spherical caps of the ink 0.02 mm above the
//! sphere: their rims are planar circles (a sphere meets a sphere in a circle), whose centres are
//! the markers' centres, and nothing stands off the surface to cast a shadow beside a rim (a flat
//! disc tangent to the sphere would: docs/markers.md).
//!
//! Photographs are lucent renders (`direct` integrator, as the photo fit's basis model, which has
//! no interreflection) with Gaussian sensor noise, the camera response y = b + g·x^(1/γ) and
//! 8-bit codes: the white frames that the markers and the labelling use at 32 samples per pixel,
//! the fit's five frames at 8, and a second set of those with other seeds for the noise floor.
//! `REASSEMBLY_KEEP=DIR` keeps every file (photographs, meshes, the labelled scene, the fit's
//! images) in DIR.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use analysis::photo_fit::basis::render_frame;
use analysis::photo_fit::model::{self, camera_response, Params};
use render::math::sampling::Pcg32;
use render::scene::Scene;
use scan::calib::{DeviceCalibration, ProcamCalibration};
use scan::markers::synth::MarkerScene;
use scan::synth::Device;

use crate::common::{ok_json, Scratch};

/// Board: three vertical stripes at z = BOARD_Z_MM (mm), boundaries at x = ±STRIPE_X_MM.
const BOARD_Z_MM: f64 = 520.0;
const STRIPE_X_MM: f64 = 62.0;
const BOARD_HALF_MM: [f64; 2] = [300.0, 240.0];
const BOARD_ALBEDO: [f64; 3] = [0.2, 0.45, 0.8];
/// The sphere's paint (the reference of known albedo) and the markers' ink (linear RGB).
const PAINT: [f64; 3] = [0.42, 0.42, 0.42];
const INK: f64 = 0.01;
/// Radius of the printed markers (mm).
const MARKER_RADIUS_MM: f64 = 10.0;
/// Height of the printed caps above the sphere (mm).
const INK_LIFT_MM: f64 = 0.02;
/// Projector: size, focal length (pixels), centre in view A (mm), intensity (per pixel of value 1).
const PW: u32 = 64;
const PH: u32 = 48;
const PROJECTOR_Y_MM: f64 = -5.0;
/// 0.8 × the start that `lucent scan label` writes, π·z² for the board's depth z = 520 mm (the
/// median depth of the labelled micropolygons).
const INTENSITY: f64 = 0.8 * std::f64::consts::PI * 520.0 * 520.0;
const AMBIENT: f64 = 0.06;
/// Camera response and sensor of the photographs.
const BLACK_LEVEL: f64 = 0.03;
const GAIN: f64 = 0.92;
const GAMMA: f64 = 2.2;
const SENSOR_SIGMA: f64 = 0.002;
const SPP: u64 = 8;
/// Samples per pixel of the white-frame photographs of the markers and the labelling (both views;
/// four exposures' worth).
const WHITE_SPP: u64 = 32;

fn f(x: f64) -> String {
    format!("{x:?}")
}

fn v3(p: [f64; 3]) -> String {
    format!("[{}, {}, {}]", f(p[0]), f(p[1]), f(p[2]))
}

fn projector() -> DeviceCalibration {
    DeviceCalibration { width: PW, height: PH, fx: 70.0, fy: 70.0, cx: 31.5, cy: 23.5, distortion: vec![-0.02, 0.0, 0.0, 0.0, 0.0], rms_px: 0.0 }
}

/// Camera A with the projector (the labelling's and the fit's calibration).
fn procam(sc: &MarkerScene) -> ProcamCalibration {
    ProcamCalibration {
        camera: sc.cameras[0].calibration(),
        projector: projector(),
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [0.0, -PROJECTOR_Y_MM, 0.0],
        rms_px: 0.0,
        captures: Vec::new(),
    }
}

/// A printed disc: unit normal n, the circle's planar centre and angular radius on the sphere.
struct Print {
    n: [f64; 3],
    centre: [f64; 3],
    half_angle: f64,
}

fn prints(sc: &MarkerScene) -> Vec<Print> {
    let (c, r) = (sc.sphere_centre_mm, sc.sphere_radius_mm + INK_LIFT_MM);
    sc.discs
        .iter()
        .map(|d| {
            let a = (MARKER_RADIUS_MM / r).asin();
            let n = d.normal;
            Print { n, centre: [0, 1, 2].map(|k| c[k] + r * a.cos() * n[k]), half_angle: a }
        })
        .collect()
}

/// The ink caps as one mesh (rings of 128 vertices on the lifted sphere).
fn caps_mesh(sc: &MarkerScene) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let (c, r) = (sc.sphere_centre_mm, sc.sphere_radius_mm + INK_LIFT_MM);
    let (rings, m) = (24usize, 128usize);
    let (mut pos, mut tri) = (vec![], vec![]);
    for p in prints(sc) {
        let n = p.n;
        let a = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
        let cross = |u: [f64; 3], v: [f64; 3]| [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
        let e1 = cross(n, a);
        let l = (e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]).sqrt();
        let e1 = e1.map(|x| x / l);
        let e2 = cross(n, e1);
        let base = pos.len() as u32;
        pos.push([0, 1, 2].map(|k| c[k] + r * n[k]));
        for i in 1..=rings {
            let th = p.half_angle * i as f64 / rings as f64;
            for j in 0..m {
                let ph = std::f64::consts::TAU * j as f64 / m as f64;
                pos.push([0, 1, 2].map(|k| c[k] + r * (th.cos() * n[k] + th.sin() * (ph.cos() * e1[k] + ph.sin() * e2[k]))));
            }
        }
        let id = |i: usize, j: usize| if i == 0 { base } else { base + 1 + ((i - 1) * m + j % m) as u32 };
        for j in 0..m {
            tri.push([id(0, 0), id(1, j), id(1, j + 1)]);
        }
        for i in 1..rings {
            for j in 0..m {
                tri.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tri.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    (pos, tri)
}

/// A UV sphere of radius `r` about the origin, `n` × `n/2` segments, turned by `q` (row-major).
fn uv_sphere(r: f64, n: usize, q: [[f64; 3]; 3]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let rings = n / 2;
    let mut pos = vec![];
    for i in 0..=rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..n {
            let ph = std::f64::consts::TAU * j as f64 / n as f64;
            let p = [r * th.sin() * ph.cos(), r * th.cos(), r * th.sin() * ph.sin()];
            pos.push([0, 1, 2].map(|k| q[k][0] * p[0] + q[k][1] * p[1] + q[k][2] * p[2]));
        }
    }
    let id = |i: usize, j: usize| (i * n + j % n) as u32;
    let mut tri = vec![];
    for i in 0..rings {
        for j in 0..n {
            if i > 0 {
                tri.push([id(i, j), id(i, j + 1), id(i + 1, j)]);
            }
            if i + 1 < rings {
                tri.push([id(i, j + 1), id(i + 1, j + 1), id(i + 1, j)]);
            }
        }
    }
    (pos, tri)
}

fn stripe_quad(k: usize) -> [[f64; 3]; 4] {
    let xs = [-BOARD_HALF_MM[0], -STRIPE_X_MM, STRIPE_X_MM, BOARD_HALF_MM[0]];
    let (x0, x1, y) = (xs[k], xs[k + 1], BOARD_HALF_MM[1]);
    [[x0, -y, BOARD_Z_MM], [x1, -y, BOARD_Z_MM], [x1, y, BOARD_Z_MM], [x0, y, BOARD_Z_MM]]
}

fn camera_toml(d: &Device, r: [[f64; 3]; 3], t: [f64; 3]) -> String {
    let k = d.distortion;
    format!(
        "[camera]\nmodel = \"opencv\"\nwidth = {}\nheight = {}\nfx = {}\nfy = {}\ncx = {}\ncy = {}\ndist = [{}, {}, {}, {}, {}]\nR = [{}, {}, {}]\nt = {}\n\n",
        d.width, d.height, f(d.fx), f(d.fy), f(d.cx), f(d.cy), f(k[0]), f(k[1]), f(k[2]), f(k[3]), f(k[4]), v3(r[0]), v3(r[1]), v3(r[2]), v3(t)
    )
}

/// The true scene seen by view `view` (no `unit`: lengths are the calibration's millimetres, as in
/// the scene `lucent scan label` writes).
fn truth_toml(sc: &MarkerScene, view: usize) -> String {
    let mut s = String::from("# The whole-chain round trip's truth (crates/cli/tests/suite/reassembly_cli.rs)\n\n");
    s += &if view == 0 { camera_toml(&sc.cameras[0], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]) } else { camera_toml(&sc.cameras[1], sc.rotation, sc.translation_mm) };
    s += "[integrator]\ntype = \"direct\"\n\n";
    for (k, a) in BOARD_ALBEDO.iter().enumerate() {
        s += &format!("[materials.board{k}]\ntype = \"lambertian\"\nalbedo = {}\n\n", f(*a));
        let q = stripe_quad(k);
        s += &format!("[[objects]]\nname = \"board{k}\"\nmaterial = \"board{k}\"\nquad = [{}, {}, {}, {}]\n\n", v3(q[0]), v3(q[1]), v3(q[2]), v3(q[3]));
    }
    s += &format!("[materials.paint]\ntype = \"lambertian\"\nalbedo = {{ rgb = {} }}\n\n", v3(PAINT));
    s += &format!("[materials.ink]\ntype = \"lambertian\"\nalbedo = {}\n\n", f(INK));
    s += &format!("[[objects]]\nname = \"sphere\"\nmaterial = \"paint\"\nsphere = {{ center = {}, radius = {} }}\n\n", v3(sc.sphere_centre_mm), f(sc.sphere_radius_mm));
    s += "[[objects]]\nname = \"markers\"\nmaterial = \"ink\"\nmesh = \"caps.ply\"\n\n";
    s += &format!("[[lights]]\ntype = \"projector\"\nimage = \"white.png\"\nintensity = {}\ncamera = {{ calibration = \"procam.json\", matrix_node = \"projector\" }}\n\n", f(INTENSITY));
    s += &format!("[[lights]]\ntype = \"environment\"\nradiance = {}\n", f(AMBIENT));
    s
}

/// Patterns (projector pixels, values in [0, 1] as PNG codes): white, black, vertical stripes of
/// 8 pixels, their complement, horizontal stripes of 6, a horizontal ramp and a uniform grey.
fn patterns() -> Vec<(&'static str, Vec<u8>)> {
    let n = (PW * PH) as usize;
    let f = |g: &dyn Fn(u32, u32) -> u8| (0..n).map(|i| g(i as u32 % PW, i as u32 / PW)).collect::<Vec<u8>>();
    vec![
        ("white", f(&|_, _| 255)),
        ("black", f(&|_, _| 0)),
        ("columns", f(&|x, _| if (x / 8) % 2 == 0 { 255 } else { 0 })),
        ("columns_inv", f(&|x, _| if (x / 8) % 2 == 1 { 255 } else { 0 })),
        ("ramp", f(&|x, _| (255.0 * x as f64 / (PW - 1) as f64).round() as u8)),
    ]
}

fn write_grey_png(path: &Path, w: u32, h: u32, codes: &[u8]) {
    let rgb: Vec<u8> = codes.iter().flat_map(|&c| [c, c, c]).collect();
    image::save_buffer(path, &rgb, w, h, image::ExtendedColorType::Rgb8).unwrap();
}

/// A photograph: the linear render plus Gaussian noise, through the camera response, in 8-bit codes.
fn photograph(lin: &[[f32; 3]], seed: u64, stream: u64) -> Vec<u8> {
    let mut truth = Params::new(&[], GAMMA);
    truth.x[model::BLACK_LEVEL] = BLACK_LEVEL;
    truth.x[model::GAIN] = GAIN;
    let mut rng = Pcg32::new(seed, stream);
    let mut gauss = || {
        let (u1, u2) = (rng.next_f32().max(1e-7) as f64, rng.next_f32() as f64);
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    };
    lin.iter()
        .flat_map(|x| {
            let noisy = x.map(|v| (v as f64 + SENSOR_SIGMA * gauss()).max(0.0));
            camera_response(&truth, noisy, 0.0, None).map(|y| (y.clamp(0.0, 1.0) * 255.0).round() as u8)
        })
        .collect()
}

fn render_photo(scene: &mut Scene, pattern: &[u8], spp: u64, seed: u64, stream: u64) -> Vec<u8> {
    let pat: Vec<f32> = pattern.iter().map(|&c| optics::color::srgb_decode(c as f64 / 255.0) as f32).collect();
    let lin = render_frame(scene, Some(&pat), 0.0, spp, seed).unwrap();
    photograph(&lin, seed ^ 0x5EED, stream)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Faces of a labelled PLY of `lucent scan label` (binary, `float x y z`, `uchar int ×3`, `int label`).
fn read_labelled(path: &Path) -> (Vec<[f64; 3]>, Vec<([u32; 3], i32)>) {
    let bytes = std::fs::read(path).unwrap();
    let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let header = String::from_utf8_lossy(&bytes[..end]).into_owned();
    let count = |el: &str| -> usize { header.lines().find_map(|l| l.strip_prefix(&format!("element {el} "))).unwrap().trim().parse().unwrap() };
    let (nv, nf) = (count("vertex"), count("face"));
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as f64;
    let i32_at = |o: usize| i32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let pos = (0..nv).map(|i| [0, 1, 2].map(|k| f32_at(end + 12 * i + 4 * k))).collect();
    let fo = end + 12 * nv;
    let faces = (0..nf)
        .map(|i| {
            let o = fo + 17 * i;
            assert_eq!(bytes[o], 3);
            ([0, 1, 2].map(|k| i32_at(o + 1 + 4 * k) as u32), i32_at(o + 13))
        })
        .collect();
    (pos, faces)
}

#[test]
fn reassembly_markers_labels_and_appearance_fit_on_one_scene() {
    let s = Scratch::new("reassembly");
    let sc = MarkerScene::standard();
    let cam_a = &sc.cameras[0];
    let (w, h) = (cam_a.width, cam_a.height);
    std::fs::write(s.path("rig.json"), serde_json::to_string_pretty(&sc.calibration()).unwrap()).unwrap();
    std::fs::write(s.path("procam.json"), serde_json::to_string_pretty(&procam(&sc)).unwrap()).unwrap();
    let (cp, ct) = caps_mesh(&sc);
    scan::label::io::write_ply(&s.path("caps.ply"), &cp, &ct, None).unwrap();
    write_grey_png(&s.path("white.png"), PW, PH, &vec![255; (PW * PH) as usize]);
    let pats = patterns();
    for (name, p) in &pats {
        write_grey_png(&s.path(&format!("pattern_{name}.png")), PW, PH, p);
    }

    // Photographs: view A under every pattern, twice (seeds 1xx and 2xx); view B under white.
    let t0 = std::time::Instant::now();
    let mut scene_a = Scene::from_toml_str(&truth_toml(&sc, 0), "reassembly truth A", &s.0).unwrap();
    for (i, (name, p)) in pats.iter().enumerate() {
        for (set, seed) in [("photo", 100 + i as u64), ("repeat", 200 + i as u64)] {
            write_rgb_png(&s.path(&format!("{set}_{name}.png")), w, h, &render_photo(&mut scene_a, p, SPP, seed, 1));
        }
    }
    write_rgb_png(&s.path("view_a.png"), w, h, &render_photo(&mut scene_a, &pats[0].1, WHITE_SPP, 400, 3));
    let mut scene_b = Scene::from_toml_str(&truth_toml(&sc, 1), "reassembly truth B", &s.0).unwrap();
    write_rgb_png(&s.path("view_b.png"), w, h, &render_photo(&mut scene_b, &pats[0].1, WHITE_SPP, 300, 2));
    eprintln!("photographs: {:.1} s", t0.elapsed().as_secs_f64());

    // 1. Markers: detect, match, triangulate, register the sphere model (its own frame: the truth
    //    maps it to view A by X_A = Q·X + C).
    let q = sc.model_rotation;
    let qt = [0, 1, 2].map(|i| [0, 1, 2].map(|j| q[j][i]));
    let c = sc.sphere_centre_mm;
    let truth_marks: Vec<[f64; 3]> = prints(&sc).iter().map(|p| p.centre).collect();
    let model_marks: Vec<[f64; 3]> = truth_marks.iter().map(|m| { let d = sub(*m, c); [0, 1, 2].map(|i| dot(qt[i], d)) }).collect();
    std::fs::write(s.path("model.json"), serde_json::json!({ "markers": model_marks }).to_string()).unwrap();
    let (sp, st) = uv_sphere(sc.sphere_radius_mm, 384, qt);
    scan::label::io::write_ply(&s.path("sphere_model.ply"), &sp, &st, None).unwrap();
    let t1 = std::time::Instant::now();
    let m = ok_json(&[
        "scan", "markers", &s.arg("view_a.png"), &s.arg("view_b.png"), "--radius-px", "3:40", "--calibration", &s.arg("rig.json"),
        "--model", &s.arg("model.json"), "--model-mesh", &s.arg("sphere_model.ply"), "--registered", &s.arg("sphere.ply"), "--json",
    ]);
    eprintln!("scan markers: {:.1} s", t1.elapsed().as_secs_f64());
    let matches = m["matches"].as_array().unwrap();
    let inliers: Vec<usize> = m["inliers"].as_array().unwrap().iter().map(|i| i["point"].as_u64().unwrap() as usize).collect();
    eprintln!("markers: {} and {} found, {} matches, {} inliers, outliers {}", m["images"][0]["markers"].as_array().unwrap().len(), m["images"][1]["markers"].as_array().unwrap().len(), matches.len(), inliers.len(), m["outliers"]);
    assert_eq!(inliers.len(), 4, "{m}");
    let mut worst_px = [0.0f64; 2];
    for mm in inliers.iter().map(|&i| &matches[i]) {
        for (v, key) in ["centre_a", "centre_b"].iter().enumerate() {
            let got: Vec<f64> = mm[key].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            let e = truth_marks
                .iter()
                .map(|t| sc.cameras[v].project(sc.to_view(v, *t)).unwrap())
                .map(|p| ((p[0] - got[0]).powi(2) + (p[1] - got[1]).powi(2)).sqrt())
                .fold(f64::INFINITY, f64::min);
            worst_px[v] = worst_px[v].max(e);
        }
    }
    let tr = &m["transform"];
    let rot: Vec<Vec<f64>> = tr["rotation"].as_array().unwrap().iter().map(|r| r.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()).collect();
    let tt: Vec<f64> = tr["translation"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let apply = |p: [f64; 3]| [0, 1, 2].map(|i| rot[i][0] * p[0] + rot[i][1] * p[1] + rot[i][2] * p[2] + tt[i]);
    let mut reg_err = norm(sub(apply([0.0; 3]), c));
    for (mk, t) in model_marks.iter().zip(&truth_marks) {
        reg_err = reg_err.max(norm(sub(apply(*mk), *t)));
    }
    let diameter = 2.0 * sc.sphere_radius_mm;
    eprintln!("markers: corrected centres within {:.4} px (A), {:.4} px (B); registration {:.4} mm = {:.4} % of the sphere's diameter", worst_px[0], worst_px[1], reg_err, 100.0 * reg_err / diameter);

    // 2. Labels of the board and the registered sphere, from the white frame.
    let board: Vec<[f64; 3]> = (0..3).flat_map(stripe_quad).collect();
    // Wound towards the camera, as the sphere is wound outwards (a consistently wound mesh lets
    // the labelling hide the faces turned away).
    let mut tris: Vec<[u32; 3]> = (0..3u32).flat_map(|k| [[4 * k, 4 * k + 2, 4 * k + 1], [4 * k, 4 * k + 3, 4 * k + 2]]).collect();
    let reg = scan::label::io::read_mesh(&s.path("sphere.ply")).unwrap();
    let mut pos = board.clone();
    tris.extend(reg.triangles.iter().map(|t| t.map(|v| v + 12)));
    pos.extend(&reg.positions);
    scan::label::io::write_ply(&s.path("scene-mesh.ply"), &pos, &tris, None).unwrap();
    let t2 = std::time::Instant::now();
    let l = ok_json(&[
        "scan", "label", &s.arg("scene-mesh.ply"), &s.arg("view_a.png"), "--calibration", &s.arg("procam.json"), "--out", &s.arg("lab.ply"),
        "--scene", &s.arg("scene.toml"), "--labels", "5", "--erosion-px", "2", "--overlay", &s.arg("overlay.png"), "--json",
    ]);
    eprintln!("scan label: {:.1} s", t2.elapsed().as_secs_f64());
    keep(&s);
    let (lp, lf) = read_labelled(&s.path("lab.ply"));
    let pr = prints(&sc);
    // Truth per micropolygon: class 0–2 the stripes, 3 the paint, 4 the ink; visible from A.
    let hits_sphere_before = |p: [f64; 3]| {
        let r = sc.sphere_radius_mm;
        let (a, b, cc) = (dot(p, p), -2.0 * dot(p, c), dot(c, c) - r * r);
        let disc = b * b - 4.0 * a * cc;
        disc > 0.0 && (-b - disc.sqrt()) / (2.0 * a) < 1.0 - 1e-9
    };
    let mut votes: HashMap<(usize, i32), f64> = HashMap::new();
    let mut truth = Vec::with_capacity(lf.len());
    for (t, lab) in &lf {
        let [a, b, cc] = t.map(|v| lp[v as usize]);
        let p = [0, 1, 2].map(|k| (a[k] + b[k] + cc[k]) / 3.0);
        let x = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let y = [cc[0] - a[0], cc[1] - a[1], cc[2] - a[2]];
        let area = 0.5 * norm([x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]]);
        let on_sphere = (norm(sub(p, c)) - sc.sphere_radius_mm).abs() < 1.0;
        let class = if on_sphere {
            let d = sub(p, c);
            let d = d.map(|v| v / norm(d));
            if pr.iter().any(|m| dot(d, m.n) > m.half_angle.cos()) { 4 } else { 3 }
        } else if p[0] < -STRIPE_X_MM {
            0
        } else if p[0] < STRIPE_X_MM {
            1
        } else {
            2
        };
        let px = cam_a.project(p).unwrap_or([-1e9, -1e9]);
        let inside = px[0] > -0.5 && px[1] > -0.5 && px[0] < w as f64 - 0.5 && px[1] < h as f64 - 0.5;
        let visible = inside && if on_sphere { dot(sub(p, c), p) < 0.0 } else { !hits_sphere_before(p) };
        if *lab >= 0 && visible {
            *votes.entry((class, *lab)).or_default() += area;
        }
        truth.push((class, visible, area, *lab));
    }
    let label_of: Vec<i32> = (0..5).map(|cl| votes.iter().filter(|((k, _), _)| *k == cl).max_by(|a, b| a.1.total_cmp(b.1)).map_or(-2, |((_, l), _)| *l)).collect();
    assert_eq!(label_of.iter().copied().collect::<HashSet<_>>().len(), 5, "two classes on one label: {label_of:?}: {l}");
    let class_of: HashMap<i32, usize> = label_of.iter().enumerate().map(|(cl, &lb)| (lb, cl)).collect();
    let (mut visible, mut correct, mut inter, mut union) = (0.0, 0.0, [0.0; 5], [0.0; 5]);
    for &(class, vis, a, lab) in &truth {
        let pred = class_of.get(&lab).copied();
        if vis {
            visible += a;
            if pred == Some(class) {
                correct += a;
            }
        }
        for cl in 0..5 {
            let (p, t) = (pred == Some(cl), vis && class == cl);
            if p && t {
                inter[cl] += a;
            }
            if p || t {
                union[cl] += a;
            }
        }
    }
    let mut confusion: HashMap<(usize, i32), f64> = HashMap::new();
    for &(class, vis, a, lab) in &truth {
        if vis {
            *confusion.entry((class, lab)).or_default() += a;
        }
    }
    let mut cv: Vec<_> = confusion.into_iter().collect();
    cv.sort_by(|a, b| a.0.cmp(&b.0));
    eprintln!("visible area by (class, label): {cv:?}");
    let accuracy = correct / visible;
    let iou: Vec<f64> = (0..5).map(|cl| inter[cl] / union[cl]).collect();
    eprintln!("labels: {label_of:?} (stripes, paint, ink); accuracy {accuracy:.4}, IoU {iou:.4?}");

    // 3. The appearance fit on the labelled scene: the paint is the reference of known albedo
    //    (its label's albedo set to the truth and held), with the gain (known) and the projector's
    //    black level (an ideal projector).
    let paint = format!("label{}", label_of[3]);
    let text = std::fs::read_to_string(s.path("scene.toml")).unwrap();
    let start = text.find(&format!("[materials.{paint}]")).unwrap();
    let end = start + text[start..].find("\n\n").unwrap();
    let text = format!("{}[materials.{paint}]\ntype = \"lambertian\"\nalbedo = {{ rgb = {} }}{}", &text[..start], v3(PAINT), &text[end..]);
    std::fs::write(s.path("scene.toml"), &text).unwrap();
    let i_label: f64 = text.lines().find_map(|l| l.strip_prefix("intensity = ")).unwrap().trim().parse().unwrap();
    let mut args: Vec<String> = ["fit", "photo", &s.arg("scene.toml")].map(String::from).to_vec();
    for (name, _) in &pats {
        args.extend(["--photo".into(), s.arg(&format!("photo_{name}.png")), "--pattern".into(), s.arg(&format!("pattern_{name}.png"))]);
        args.extend(["--repeat".into(), s.arg(&format!("repeat_{name}.png"))]);
    }
    // Box-averaged 2 × 2, a photograph's pixel at the fit's size holds 4 × SPP samples; the check
    // renders have half that.
    let fit_spp = (SPP * 2).to_string();
    args.extend(
        ["--width", "200", "--height", "160", "--spp", &fit_spp, "--seed", "11", "--hold", "gain", "--hold", &paint, "--hold", "projector_black", "--gain", &f(GAIN), "--gamma", "1.8", "--edge-px", "2", "--out-dir", &s.arg("fit"), "--json", "-q"]
            .map(String::from),
    );
    let t3 = std::time::Instant::now();
    let v = ok_json(&args.iter().map(String::as_str).collect::<Vec<_>>());
    eprintln!("fit photo: {:.1} s", t3.elapsed().as_secs_f64());
    let full: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(s.path("fit/fit.json")).unwrap()).unwrap();
    let par = &v["params"];
    let mut worst_albedo = 0.0f64;
    for cl in 0..3 {
        let rgb: Vec<f64> = par["albedo"][format!("label{}", label_of[cl])]["rgb"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        eprintln!("stripe {cl} (label{}): albedo {rgb:.4?} (truth {})", label_of[cl], BOARD_ALBEDO[cl]);
        for x in rgb {
            worst_albedo = worst_albedo.max((x / BOARD_ALBEDO[cl] - 1.0).abs());
        }
    }
    let ink: Vec<f64> = par["albedo"][format!("label{}", label_of[4])]["rgb"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let power = par["projector_scale"]["value"].as_f64().unwrap() * i_label;
    let gamma = par["gamma"]["value"].as_f64().unwrap();
    let ambient = par["ambient_scale"]["value"].as_f64().unwrap() * 0.02;
    eprintln!(
        "fit: ink {ink:.4?} (truth {INK}); projector {power:.1} (truth {INTENSITY}, {:+.2} %); gamma {gamma:.4} ({:+.2} %); ambient {ambient:.5} (truth {AMBIENT}); black level {:.4}",
        100.0 * (power / INTENSITY - 1.0),
        100.0 * (gamma / GAMMA - 1.0),
        par["black_level"]["value"]
    );
    let mut worst_ratio = 0.0f64;
    for (fr, fl) in full["verify"]["frames"].as_array().unwrap().iter().zip(full["noise_floor"]["frames"].as_array().unwrap()) {
        let (a, b) = (fr["whole"]["rel_rmse"].as_f64().unwrap(), fl["whole"]["rel_rmse"].as_f64().unwrap());
        eprintln!("frame {}: final render rel. RMSE {a:.5}, noise floor {b:.5}, ratio {:.3} ({} pixels)", fr["name"], a / b, fr["whole"]["pixels"]);
        worst_ratio = worst_ratio.max(a / b);
    }

    keep(&s);
    assert!(worst_px[0] <= 0.1 && worst_px[1] <= 0.1, "marker centres off by {worst_px:?} px");
    assert!(reg_err <= 1e-3 * diameter, "registration off by {reg_err} mm");
    assert!(accuracy >= 0.98, "labelled area {accuracy}, IoU {iou:?}");
    for (cl, &x) in iou.iter().enumerate() {
        assert!(x >= 0.95, "class {cl}: IoU {x} ({iou:?})");
    }
    assert!(worst_albedo <= 0.02, "an albedo is off by {:.2} %", 100.0 * worst_albedo);
    assert!((power / INTENSITY - 1.0).abs() <= 0.02, "projector {power} vs {INTENSITY}");
    assert!((gamma / GAMMA - 1.0).abs() <= 0.02, "gamma {gamma}");
    assert!(worst_ratio <= 1.5, "final render {worst_ratio:.3}× the noise floor");
}

/// With REASSEMBLY_KEEP=DIR set, the scratch files (photographs, meshes, the labelled scene, the
/// fit's images) are copied to DIR.
fn keep(s: &Scratch) {
    if let Ok(d) = std::env::var("REASSEMBLY_KEEP") {
        std::fs::create_dir_all(&d).unwrap();
        let _ = std::process::Command::new("cp").arg("-r").arg(format!("{}/.", s.0.display())).arg(&d).status();
    }
}

fn write_rgb_png(path: &Path, w: u32, h: u32, codes: &[u8]) {
    image::save_buffer(path, codes, w, h, image::ExtendedColorType::Rgb8).unwrap();
}
