//! `lucent scan markers`: the command-line contract (flags, JSON keys) on two rendered photographs
//! of a sphere carrying four markers, and bad input (no markers, another resolution, too few
//! matches, collinear model markers).

use scan::markers::synth::MarkerScene;

use crate::common::{fails_on_one_line, ok_json, Scratch};

/// The scene's two photographs, calibration and model in `s`.
fn write_inputs(s: &Scratch, sc: &MarkerScene) {
    for v in 0..2 {
        let px = sc.photograph(v, 16, 7, 0.002).unwrap();
        sc.write_png(v, &px, &s.path(&format!("view{v}.png"))).unwrap();
    }
    std::fs::write(s.path("calib.json"), serde_json::to_string_pretty(&sc.calibration()).unwrap()).unwrap();
    std::fs::write(s.path("model.json"), serde_json::json!({ "markers": sc.model_markers() }).to_string()).unwrap();
}

#[test]
fn markers_detect_match_triangulate_and_register() {
    let s = Scratch::new("markers-cli");
    let sc = MarkerScene::standard();
    write_inputs(&s, &sc);
    let (a, b) = (s.arg("view0.png"), s.arg("view1.png"));
    // Detection alone, on any number of images.
    let v = ok_json(&["scan", "markers", "--radius-px", "3:40", &a, &b, "--json"]);
    let imgs = v["images"].as_array().unwrap();
    assert_eq!(imgs.len(), 2);
    for img in imgs {
        let ms = img["markers"].as_array().unwrap();
        assert_eq!(ms.len(), 4, "{img}");
        for m in ms {
            for k in ["x", "y", "radius_px"] {
                assert!(m[k].as_f64().is_some(), "{m}");
            }
            assert_eq!(m["ellipse"]["semi_axes_px"].as_array().map(|a| a.len()), Some(2), "{m}");
            assert_eq!(m["polarity"], "dark");
        }
    }
    assert!(v.get("matches").is_none());
    // Matching, triangulation and registration.
    let v = ok_json(&["scan", "markers", "--radius-px", "3:40", &a, &b, "--calibration", &s.arg("calib.json"), "--model", &s.arg("model.json"), "--json"]);
    assert_eq!(v["matches"].as_array().unwrap().len(), 4, "{v}");
    assert_eq!(v["points"].as_array().unwrap().len(), 4);
    assert_eq!(v["unmatched"]["a"].as_array().unwrap().len(), 0);
    let t = &v["transform"];
    assert_eq!(t["scale"].as_f64(), Some(1.0));
    let tr: Vec<f64> = t["translation"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let c = sc.sphere_centre_mm;
    let err = ((tr[0] - c[0]).powi(2) + (tr[1] - c[1]).powi(2) + (tr[2] - c[2]).powi(2)).sqrt();
    assert!(err < 1e-3 * 2.0 * sc.sphere_radius_mm, "sphere centre off by {err} mm");
    let rot = t["rotation"].as_array().unwrap();
    for (i, (row, truth)) in rot.iter().zip(&sc.model_rotation).enumerate() {
        for (j, (x, t)) in row.as_array().unwrap().iter().zip(truth).enumerate() {
            let x = x.as_f64().unwrap();
            assert!((x - t).abs() < 2e-3, "rotation[{i}][{j}] = {x}");
        }
    }
    assert!(v["rms"].as_f64().unwrap() < 0.2, "{}", v["rms"]);
    // The model's mesh moved by the registration: a mesh through three model markers and the
    // model's origin lands on the true markers and the sphere's centre.
    let mm = sc.model_markers();
    let verts = [mm[0], mm[1], mm[2], [0.0; 3]];
    scan::label::io::write_ply(&s.path("model_mesh.ply"), &verts, &[[0, 1, 2], [0, 2, 3]], None).unwrap();
    let v = ok_json(&["scan", "markers", "--radius-px", "3:40", &a, &b, "--calibration", &s.arg("calib.json"), "--model", &s.arg("model.json"), "--model-mesh", &s.arg("model_mesh.ply"), "--registered", &s.arg("registered.ply"), "--json"]);
    assert_eq!(v["registered"]["faces"].as_u64(), Some(2), "{v}");
    let moved = scan::label::io::read_mesh(&s.path("registered.ply")).unwrap();
    let truth = [sc.discs[0].centre_mm, sc.discs[1].centre_mm, sc.discs[2].centre_mm, sc.sphere_centre_mm];
    for (p, t) in moved.positions.iter().zip(&truth) {
        let e = ((p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2) + (p[2] - t[2]).powi(2)).sqrt();
        assert!(e < 1e-3 * 2.0 * sc.sphere_radius_mm, "registered vertex {p:?} is {e} mm from {t:?}");
    }
    let e = fails_on_one_line(&["scan", "markers", "--radius-px", "3:40", &a, &b, "--calibration", &s.arg("calib.json"), "--model", &s.arg("model.json"), "--model-mesh", &s.arg("model_mesh.ply"), "--registered", &s.arg("registered.obj")]);
    assert!(e.contains("registered.obj") && e.contains("PLY"), "{e}");
    // A similarity: the model given in centimetres comes back with scale 10.
    let cm: Vec<[f64; 3]> = sc.model_markers().iter().map(|p| p.map(|x| x / 10.0)).collect();
    std::fs::write(s.path("model_cm.json"), serde_json::json!({ "markers": cm }).to_string()).unwrap();
    let v = ok_json(&["scan", "markers", "--radius-px", "3:40", &a, &b, "--calibration", &s.arg("calib.json"), "--model", &s.arg("model_cm.json"), "--scale", "--json"]);
    let k = v["transform"]["scale"].as_f64().unwrap();
    assert!((k - 10.0).abs() < 0.01, "scale {k}");

    // Bad input: one line each, exit ≠ 0.
    image::GrayImage::from_pixel(400, 320, image::Luma([128])).save(s.path("blank.png")).unwrap();
    let e = fails_on_one_line(&["scan", "markers", &s.arg("blank.png")]);
    assert!(e.contains("blank.png") && e.contains("no markers found"), "{e}");
    image::GrayImage::from_pixel(200, 160, image::Luma([128])).save(s.path("small.png")).unwrap();
    let e = fails_on_one_line(&["scan", "markers", &a, &s.arg("small.png"), "--calibration", &s.arg("calib.json")]);
    assert!(e.contains("small.png") && e.contains("400x320"), "{e}");
    let e = fails_on_one_line(&["scan", "markers", &a, "--calibration", &s.arg("calib.json")]);
    assert!(e.contains("exactly two images"), "{e}");
    // Two of the four markers painted over in view B (the sphere's grey level): 2 matches.
    let mut img = image::open(s.path("view1.png")).unwrap().to_luma8();
    for c in &sc.projected_centres(1)[..2] {
        for y in (c[1] as u32 - 15)..(c[1] as u32 + 15) {
            for x in (c[0] as u32 - 15)..(c[0] as u32 + 15) {
                img.put_pixel(x, y, image::Luma([188]));
            }
        }
    }
    img.save(s.path("two.png")).unwrap();
    let e = fails_on_one_line(&["scan", "markers", "--radius-px", "3:40", &a, &s.arg("two.png"), "--calibration", &s.arg("calib.json"), "--model", &s.arg("model.json")]);
    assert!(e.contains("too few matches"), "{e}");
    std::fs::write(s.path("line.json"), r#"{"markers": [[0, 0, 0], [10, 0, 0], [20, 0, 0], [35, 0, 0]]}"#).unwrap();
    let e = fails_on_one_line(&["scan", "markers", "--radius-px", "3:40", &a, &b, "--calibration", &s.arg("calib.json"), "--model", &s.arg("line.json")]);
    assert!(e.contains("collinear"), "{e}");
    std::fs::write(s.path("bad.json"), r#"{"points": []}"#).unwrap();
    let e = fails_on_one_line(&["scan", "markers", "--radius-px", "3:40", &a, &b, "--calibration", &s.arg("calib.json"), "--model", &s.arg("bad.json")]);
    assert!(e.contains("bad.json") && e.contains("markers"), "{e}");
}
