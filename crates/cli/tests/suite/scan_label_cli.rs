//! `lucent scan label`: the contract with the photo fit (files, PLY properties, scene, JSON keys)
//! and bad input (one line, exit ≠ 0, no panic).

use render::image_io::{write_image, Image};
use render::shape::mesh::parse_ply;
use scan::calib::{DeviceCalibration, ProcamCalibration};

use crate::common::{fails_on_one_line, lucent, Scratch};

fn calibration(w: u32, h: u32) -> ProcamCalibration {
    let dev = |width, height, f: f64| DeviceCalibration { width, height, fx: f, fy: f, cx: width as f64 / 2.0 - 0.5, cy: height as f64 / 2.0 - 0.5, distortion: vec![-0.05, 0.0, 0.0, 0.0, 0.0], rms_px: 0.0 };
    ProcamCalibration {
        camera: dev(w, h, 60.0),
        projector: dev(32, 24, 30.0),
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [-2.0, 0.0, 0.0],
        rms_px: 0.0,
        captures: Vec::new(),
    }
}

/// A quad at depth `z` filling the view of the 64 × 48 camera (ASCII PLY).
fn quad_ply(z: f64) -> String {
    let (x, y) = (0.7 * z, 0.5 * z);
    format!("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n{} {} {z}\n{x} {} {z}\n{x} {y} {z}\n{} {y} {z}\n3 0 1 2\n3 0 2 3\n", -x, -y, -y, -x)
}

struct Inputs {
    s: Scratch,
}

/// Calibration, a photo (left half red, right half blue), and the quad.
fn inputs(name: &str) -> Inputs {
    let s = Scratch::new(name);
    std::fs::write(s.path("calib.json"), serde_json::to_string(&calibration(64, 48)).unwrap()).unwrap();
    let rgb = (0..64 * 48).map(|i| if i % 64 < 32 { [0.6, 0.1, 0.1] } else { [0.1, 0.15, 0.5] }).collect();
    write_image(&s.path("photo.png"), &Image { width: 64, height: 48, rgb }, 0.0).unwrap();
    std::fs::write(s.path("mesh.ply"), quad_ply(10.0)).unwrap();
    Inputs { s }
}

/// Two colour halves of a photo give two labels; the labelled PLY carries an `int label` per
/// face and the renderer reads it; each label's mesh and the scene (camera from the
/// calibration, materials label0/label1, projector and ambient lights) load.
#[test]
fn label_writes_the_contract_files() {
    let i = inputs("label-contract");
    let s = &i.s;
    let out = lucent()
        .args(["scan", "label", &s.arg("mesh.ply"), &s.arg("photo.png"), "--calibration", &s.arg("calib.json"), "--out", &s.arg("lab.ply"), "--scene", &s.arg("scene.toml"), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["labels"].as_u64(), Some(2), "{v}");
    assert_eq!(v["faces"].as_u64(), Some(2));
    let micro = v["micropolygons"].as_u64().unwrap();
    assert!(micro > 2000, "{v}");
    assert!(v["image_regions"].as_u64().unwrap() >= 2);
    let per = v["per_label"].as_array().unwrap();
    assert_eq!(per.len(), 2);
    for p in per {
        for key in ["label", "faces", "pixels", "mean_rgb"] {
            assert!(!p[key].is_null(), "{key} in {p}");
        }
    }
    // Label 0 is the larger region (ties: either); its mean colour is one of the two halves.
    let mean: Vec<f64> = per[0]["mean_rgb"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let near = |c: [f64; 3]| (0..3).all(|k| (mean[k] - c[k]).abs() < 0.01);
    assert!(near([0.6, 0.1, 0.1]) || near([0.1, 0.15, 0.5]), "{mean:?}");
    let bytes = std::fs::read(s.path("lab.ply")).unwrap();
    let header = String::from_utf8_lossy(&bytes[..bytes.windows(10).position(|w| w == b"end_header").unwrap()]).into_owned();
    assert!(header.contains("property list uchar int vertex_indices\nproperty int label\n"), "{header}");
    assert!(header.contains("property float x\nproperty float y\nproperty float z\n"), "{header}");
    assert_eq!(parse_ply(&bytes).unwrap().indices.len() as u64, micro);
    let faces: u64 = per.iter().map(|p| p["faces"].as_u64().unwrap()).sum();
    let mut total = 0;
    for k in 0..2 {
        let m = parse_ply(&std::fs::read(s.path(&format!("lab_label{k}.ply"))).unwrap()).unwrap();
        assert_eq!(m.indices.len() as u64, per[k]["faces"].as_u64().unwrap());
        total += m.indices.len() as u64;
    }
    assert_eq!(total, faces);
    let text = std::fs::read_to_string(s.path("scene.toml")).unwrap();
    for key in ["[materials.label0]", "[materials.label1]", "mesh = \"lab_label0.ply\"", "type = \"projector\"", "type = \"environment\"", "calibration = \"calib.json\""] {
        assert!(text.contains(key), "{key} in {text}");
    }
    let scene = render::scene::Scene::load(&s.path("scene.toml")).unwrap();
    assert_eq!(scene.resolution(), (64, 48));
}

/// A mesh behind the camera, a photo of another size than the calibration's, and a file that is
/// not a mesh: one line each, exit ≠ 0.
#[test]
fn label_bad_input_is_one_line() {
    let i = inputs("label-bad");
    let s = &i.s;
    std::fs::write(s.path("behind.ply"), quad_ply(-10.0)).unwrap();
    let base = |mesh: &str, photo: &str| {
        vec!["scan".to_string(), "label".into(), s.arg(mesh), s.arg(photo), "--calibration".into(), s.arg("calib.json"), "--out".into(), s.arg("o.ply")]
    };
    let run = |a: Vec<String>| fails_on_one_line(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let e = run(base("behind.ply", "photo.png"));
    assert!(e.contains("outside the camera's view"), "{e}");
    write_image(&s.path("small.png"), &Image { width: 32, height: 24, rgb: vec![[0.5; 3]; 32 * 24] }, 0.0).unwrap();
    let e = run(base("mesh.ply", "small.png"));
    assert!(e.contains("small.png is 32x24") && e.contains("64x48"), "{e}");
    std::fs::write(s.path("junk.ply"), "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n").unwrap();
    let e = run(base("junk.ply", "photo.png"));
    assert!(e.contains("junk.ply"), "{e}");
    let e = run(base("missing.ply", "photo.png"));
    assert!(e.contains("missing.ply"), "{e}");
    assert!(!s.path("o.ply").exists());
    // An overlay shrunk to nothing is refused before any output is written (a good file stays).
    std::fs::write(s.path("o.ply"), "GOOD").unwrap();
    let mut a = base("mesh.ply", "photo.png");
    a.extend(["--overlay".to_string(), s.arg("ov.png"), "--overlay-scale".into(), "100000".into()]);
    let e = run(a);
    assert!(e.contains("--overlay-scale") && e.contains("64x48"), "{e}");
    assert_eq!(std::fs::read_to_string(s.path("o.ply")).unwrap(), "GOOD");
}

/// With `--board-capture 0` only the surface on that capture's board plane (z = 10) is
/// labelled, not a wall 1.5 behind it; `--scene-for-capture 1,…` writes the same labels with
/// the move from board pose 0 to board pose 1, which takes a board point to R₁X + t₁; the
/// label meshes (with `--surface-smoothing`) carry shading normals turned towards the camera. Bad board input is one line.
#[test]
fn label_keeps_the_board_plane_and_moves_it_to_another_capture() {
    let i = inputs("label-board");
    let s = &i.s;
    let mut calib = calibration(64, 48);
    let pose = |name: &str, rvec: [f64; 3], tvec: [f64; 3]| scan::calib::CapturePose { name: name.into(), rvec, tvec, rms_px: 0.0, projector_corners: 63 };
    calib.captures = vec![pose("c0", [0.0, 0.0, 0.0], [0.0, 0.0, 10.0]), pose("c1", [0.0, 0.3, 0.0], [1.0, 0.5, 12.0])];
    std::fs::write(s.path("calib.json"), serde_json::to_string(&calib).unwrap()).unwrap();
    // The board: the left half of the view at z = 10; the wall: the right half at z = 11.5.
    let (x, y) = (0.7 * 10.0, 0.5 * 10.0);
    let (xw, yw) = (0.7 * 11.5, 0.5 * 11.5);
    let ply = format!(
        "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n\
         {} {} 10\n0 {} 10\n0 {y} 10\n{} {y} 10\n0 {} 11.5\n{xw} {} 11.5\n{xw} {yw} 11.5\n0 {yw} 11.5\n3 0 1 2\n3 0 2 3\n3 4 5 6\n3 4 6 7\n",
        -x, -y, -y, -x, -yw, -yw
    );
    std::fs::write(s.path("mesh.ply"), ply).unwrap();
    let out = lucent()
        .args([
            "scan", "label", &s.arg("mesh.ply"), &s.arg("photo.png"), "--calibration", &s.arg("calib.json"), "--out", &s.arg("lab.ply"),
            "--scene", &s.arg("scene0.toml"), "--board-capture", "0", "--board-distance", "0.5", "--scene-for-capture", &format!("1,{}", s.arg("scene1.toml")), "--surface-smoothing", "100", "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["unlabelled"]["off_board"].as_u64().unwrap() > 1000, "{v}");
    assert_eq!(v["board_distance"].as_f64(), Some(0.5));
    let lab = parse_ply(&std::fs::read(s.path("lab.ply")).unwrap()).unwrap();
    let mut kept = 0;
    let bytes = std::fs::read(s.path("lab_label0.ply")).unwrap();
    let m = parse_ply(&bytes).unwrap();
    for p in &m.positions {
        assert!((p.z as f64 - 10.0).abs() < 1e-4, "a labelled vertex off the board: {p:?}");
        kept += 1;
    }
    assert!(kept > 0 && lab.indices.len() > m.indices.len());
    // Shading normals of the board face the camera: (0, 0, −1).
    let normals = m.normals.as_ref().expect("shading normals");
    assert_eq!(normals.len(), m.positions.len());
    for n in normals {
        assert!((n.z as f64 + 1.0).abs() < 1e-5, "{n:?}");
    }
    // Capture 1's scene: its transform takes the board point (0, 0, 0) (at t₀) to t₁ and the
    // board point X = (1, 0, 0) to R₁X + t₁ = (cos 0.3, 0, −sin 0.3) + t₁.
    let scene1 = render::scene::Scene::load(&s.path("scene1.toml")).unwrap();
    assert_eq!(scene1.resolution(), (64, 48));
    let text = std::fs::read_to_string(s.path("scene1.toml")).unwrap();
    let line = text.lines().find(|l| l.starts_with("transform = { matrix = ")).expect("a transform");
    let nums: Vec<f64> = line.trim_start_matches("transform = { matrix = ").trim_end_matches(" }").replace(['[', ']'], "").split(',').map(|t| t.trim().parse().unwrap()).collect();
    let mul = |p: [f64; 3]| -> [f64; 3] { std::array::from_fn(|r| nums[4 * r] * p[0] + nums[4 * r + 1] * p[1] + nums[4 * r + 2] * p[2] + nums[4 * r + 3]) };
    let (c, sn) = (0.3f64.cos(), 0.3f64.sin());
    for (p, want) in [([0.0, 0.0, 10.0], [1.0, 0.5, 12.0]), ([1.0, 0.0, 10.0], [1.0 + c, 0.5, 12.0 - sn])] {
        let got = mul(p);
        for k in 0..3 {
            assert!((got[k] - want[k]).abs() < 1e-12, "{p:?} → {got:?}, want {want:?}");
        }
    }
    assert!(!std::fs::read_to_string(s.path("scene0.toml")).unwrap().contains("transform"));
    // Bad board input.
    let base = vec!["scan".to_string(), "label".into(), s.arg("mesh.ply"), s.arg("photo.png"), "--calibration".into(), s.arg("calib.json"), "--out".into(), s.arg("o.ply")];
    let run = |extra: &[&str]| {
        let mut a = base.clone();
        a.extend(extra.iter().map(|t| t.to_string()));
        fails_on_one_line(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let e = run(&["--board-capture", "5"]);
    assert!(e.contains("--board-capture 5") && e.contains("2 board poses"), "{e}");
    let e = run(&["--scene-for-capture", "1,x.toml"]);
    assert!(e.contains("needs --board-capture"), "{e}");
    let e = run(&["--board-capture", "0", "--scene", &s.arg("z.toml"), "--scene-for-capture", "one"]);
    assert!(e.contains("J,SCENE.toml"), "{e}");
    assert!(!s.path("o.ply").exists());
}
