//! `[camera]`: the pinhole (eye, look_at, up, vfov_deg, hfov_deg or camera_constant, resolution), the
//! OpenCV model (`model = "opencv"`: fx, fy, cx, cy, k1…k6, p1, p2, s1…s4, tau_x_rad, tau_y_rad or `dist`, R/rvec + t, pose,
//! or eye/look_at; or a `calibration` file), OpenCV's fisheye model (`model = "fisheye"`: the same
//! keys with k1…k4 of θ_d and `skew`, or a fisheye calibration file), and a thin lens (aperture_radius or f_number with
//! focal_length_mm, focus_distance), and the pixel filter (`filter`). Lengths are in the scene
//! unit.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::camera::{Camera, CameraModel, Distortion, Extrinsics, Fisheye, FisheyeLens, GaussianFilter, Intrinsics, OpenCv, PixelFilter, ThinLens};
use crate::load::calibration::{parse_calibration, Calibration, CalibrationNodes};
use crate::load::desc::{CameraDesc, SceneDesc};
use crate::load::object::{finite3, v3};
use crate::load::error::Cx;
use crate::load::{Build, SceneFiles};
use anyhow::{anyhow, Result};
use glam::Vec3;

/// The camera, positions converted to metres.
pub(crate) fn camera(ld: &mut Build, desc: &SceneDesc) -> Result<Camera> {
    let (cx, files, unit_m) = (ld.cx, ld.files, ld.unit_m);
    let hash = &mut ld.hash;
    camera_from(cx, files, unit_m, desc.camera.get_ref(), &desc.camera.span(), "camera", None, &mut |b| hash.write(b))
}

/// A camera from its table `c` at `cspan`, errors naming `field`; `default_size` replaces the
/// 256×256 default (a projector's image size); `hash` receives the bytes of files read.
#[allow(clippy::too_many_arguments)]
pub(crate) fn camera_from(
    cx: &Cx,
    files: &dyn SceneFiles,
    unit_m: f64,
    c: &CameraDesc,
    cspan: &std::ops::Range<usize>,
    field: &str,
    default_size: Option<(u32, u32)>,
    hash: &mut dyn FnMut(&[u8]),
) -> Result<Camera> {
    let cspan = cspan.clone();
    let err = |key: &str, msg: &dyn std::fmt::Display| cx.err(&cspan, &format!("{field}.{key}"), msg);
    let to_m = |x: f64| (x * unit_m) as f32;
    for (key, p) in [("eye", &c.eye), ("look_at", &c.look_at), ("up", &c.up), ("t", &c.t), ("rvec", &c.rvec)] {
        if let Some(p) = p {
            if !finite3(p) {
                return Err(err(key, &"must be finite"));
            }
        }
    }
    let model = c.model.as_deref().unwrap_or(if c.calibration.is_some() { "opencv" } else { "pinhole" });
    let mut camera = match model {
        "pinhole" => {
            if let Some(k) = opencv_keys(c).first() {
                return Err(err(k, &"is an OpenCV camera key (set model = \"opencv\")"));
            }
            let (Some(e), Some(a)) = (c.eye, c.look_at) else {
                return Err(err(if c.eye.is_none() { "eye" } else { "look_at" }, &"missing"));
            };
            let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
            let (dw, dh) = default_size.unwrap_or((256, 256));
            let (w, h) = (c.width.unwrap_or(dw), c.height.unwrap_or(dh));
            let eye = Vec3::new(to_m(e[0]), to_m(e[1]), to_m(e[2]));
            let at = Vec3::new(to_m(a[0]), to_m(a[1]), to_m(a[2]));
            match (c.vfov_deg, c.hfov_deg, c.camera_constant) {
                (Some(f), None, None) => Camera::look_at(eye, at, v3(up), f as f32, w, h),
                (None, Some(f), None) => {
                    if !(f > 0.0 && f < 180.0) {
                        return Err(err("hfov_deg", &format!("must be in (0, 180) degrees, got {f}")));
                    }
                    // tan(hfov/2) = (w/h)/(2d) on the image plane of unit height.
                    let d = 0.5 * (w as f64 / h.max(1) as f64) / (0.5 * f.to_radians()).tan();
                    Camera::with_constant(eye, at, v3(up), d as f32, w, h)
                }
                (None, None, Some(d)) => Camera::with_constant(eye, at, v3(up), d as f32, w, h),
                (None, None, None) => return Err(err("vfov_deg", &"missing (or give hfov_deg or camera_constant)")),
                _ => return Err(cx.err(&cspan, field, "give one of vfov_deg, hfov_deg and camera_constant")),
            }
            .map_err(|e| cx.err(&cspan, field, e))?
        }
        "opencv" => opencv_camera(cx, files, unit_m, c, &cspan, field, default_size, false, hash)?,
        "fisheye" => opencv_camera(cx, files, unit_m, c, &cspan, field, default_size, true, hash)?,
        "orthographic" => {
            if default_size.is_some() {
                return Err(err("model", &"a projector is a pinhole or OpenCV camera, not orthographic"));
            }
            if let Some(k) = opencv_keys(c).first() {
                return Err(err(k, &"is an OpenCV camera key (the orthographic camera takes eye, look_at, up and view_width)"));
            }
            for (k, present) in [("vfov_deg", c.vfov_deg.is_some()), ("hfov_deg", c.hfov_deg.is_some()), ("camera_constant", c.camera_constant.is_some()), ("aperture_radius", c.aperture_radius.is_some())] {
                if present {
                    return Err(err(k, &"has no meaning for an orthographic camera (its view is view_width wide)"));
                }
            }
            let (Some(e), Some(a)) = (c.eye, c.look_at) else {
                return Err(err(if c.eye.is_none() { "eye" } else { "look_at" }, &"missing"));
            };
            let vw = c.view_width.ok_or_else(|| err("view_width", &"missing (the width of the view, in the scene's unit)"))?;
            if !(vw > 0.0 && vw.is_finite()) {
                return Err(err("view_width", &format!("must be positive, got {}", optics::numfmt::short(vw))));
            }
            let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
            let (w, h) = (c.width.unwrap_or(256), c.height.unwrap_or(256));
            let eye = Vec3::new(to_m(e[0]), to_m(e[1]), to_m(e[2]));
            let at = Vec3::new(to_m(a[0]), to_m(a[1]), to_m(a[2]));
            let o = crate::camera::Orthographic::new(eye, at, v3(up), to_m(vw)).map_err(|e| cx.err(&cspan, field, e))?;
            Camera::orthographic(o, w, h).map_err(|e| cx.err(&cspan, field, e))?
        }
        other => return Err(err("model", &format!("unknown camera model `{other}` (use pinhole, opencv, fisheye or orthographic)"))),
    };
    camera.lens = lens(c, unit_m).map_err(|(k, e)| err(k, &e))?;
    if let Some(f) = &c.filter {
        if default_size.is_some() {
            return Err(err("filter", &"a projector has no pixel filter (only the scene camera's samples are filtered)"));
        }
        camera.filter = filter(f).map_err(|(k, e)| err(&k, &e))?;
    }
    Ok(camera)
}

/// The pixel filter of `filter = "box" | "tent" | "gaussian"` or of a table
/// `{ type = …, stddev_px = …, radius_px = … }` (defaults as Mitsuba 3: tent radius 1, Gaussian
/// σ = 0.5 and radius 4σ); errors name the key under `filter`.
fn filter(v: &toml::Value) -> std::result::Result<PixelFilter, (String, String)> {
    let (kind, table) = match v {
        toml::Value::String(s) => (s.as_str(), None),
        toml::Value::Table(t) => match t.get("type") {
            Some(toml::Value::String(s)) => (s.as_str(), Some(t)),
            Some(_) => return Err(("filter.type".into(), "must be a string".into())),
            None => return Err(("filter.type".into(), "missing (box, tent or gaussian)".into())),
        },
        _ => return Err(("filter".into(), "must be a name (box, tent, gaussian) or a table with `type`".into())),
    };
    let allowed: &[&str] = match kind {
        "box" => &["type"],
        "tent" => &["type", "radius_px"],
        "gaussian" => &["type", "stddev_px", "radius_px"],
        other => return Err(("filter.type".into(), format!("unknown filter `{other}` (use box, tent or gaussian)"))),
    };
    let get = |key: &str| -> std::result::Result<Option<f64>, (String, String)> {
        let Some(t) = table else { return Ok(None) };
        match t.get(key) {
            None => Ok(None),
            Some(x) => {
                let v = x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
                match v {
                    Some(v) if v > 0.0 && v.is_finite() => Ok(Some(v)),
                    _ => Err((format!("filter.{key}"), "must be a positive number (pixels)".into())),
                }
            }
        }
    };
    if let Some(t) = table {
        if let Some(k) = t.keys().find(|k| !allowed.contains(&k.as_str())) {
            return Err((format!("filter.{k}"), format!("unknown key for the {kind} filter (allowed: {})", allowed.join(", "))));
        }
    }
    Ok(match kind {
        "box" => PixelFilter::Box,
        "tent" => PixelFilter::Tent { radius_px: get("radius_px")?.unwrap_or(1.0) },
        _ => {
            let stddev = get("stddev_px")?.unwrap_or(0.5);
            let radius = get("radius_px")?.unwrap_or(4.0 * stddev);
            PixelFilter::Gaussian(GaussianFilter::new(stddev, radius).map_err(|e| ("filter".to_string(), e.to_string()))?)
        }
    })
}

/// Keys only the OpenCV model reads, present in `c`.
fn opencv_keys(c: &CameraDesc) -> Vec<&'static str> {
    let f = [
        ("fx", c.fx.is_some()),
        ("fy", c.fy.is_some()),
        ("cx", c.cx.is_some()),
        ("cy", c.cy.is_some()),
        ("k1", c.k1.is_some()),
        ("k2", c.k2.is_some()),
        ("k3", c.k3.is_some()),
        ("k4", c.k4.is_some()),
        ("k5", c.k5.is_some()),
        ("k6", c.k6.is_some()),
        ("p1", c.p1.is_some()),
        ("p2", c.p2.is_some()),
        ("s1", c.s1.is_some()),
        ("s2", c.s2.is_some()),
        ("s3", c.s3.is_some()),
        ("s4", c.s4.is_some()),
        ("tau_x_rad", c.tau_x_rad.is_some()),
        ("tau_y_rad", c.tau_y_rad.is_some()),
        ("dist", c.dist.is_some()),
        ("skew", c.skew.is_some()),
        ("R", c.r.is_some()),
        ("rvec", c.rvec.is_some()),
        ("t", c.t.is_some()),
        ("pose", c.pose.is_some()),
        ("calibration", c.calibration.is_some()),
        ("matrix_node", c.matrix_node.is_some()),
        ("dist_node", c.dist_node.is_some()),
    ];
    f.iter().filter(|(_, p)| *p).map(|(k, _)| *k).collect()
}

#[allow(clippy::too_many_arguments)]
fn opencv_camera(
    cx: &Cx,
    files: &dyn SceneFiles,
    unit_m: f64,
    c: &CameraDesc,
    cspan: &std::ops::Range<usize>,
    field: &str,
    default_size: Option<(u32, u32)>,
    fisheye_model: bool,
    hash: &mut dyn FnMut(&[u8]),
) -> Result<Camera> {
    let err = |key: &str, msg: &dyn std::fmt::Display| cx.err(cspan, &format!("{field}.{key}"), msg);
    for (k, p) in [("vfov_deg", c.vfov_deg.is_some()), ("hfov_deg", c.hfov_deg.is_some()), ("camera_constant", c.camera_constant.is_some())] {
        if p {
            return Err(err(k, &"is a pinhole key; the OpenCV model takes fx, fy, cx, cy"));
        }
    }
    let calib: Option<Calibration> = match &c.calibration {
        None => {
            if c.matrix_node.is_some() || c.dist_node.is_some() {
                return Err(err("matrix_node", &"needs a calibration file"));
            }
            None
        }
        Some(rel) => {
            let text = files.read_text(rel).map_err(|e| err("calibration", &format!("{e:#}")))?;
            hash(text.as_bytes());
            let mut nodes = CalibrationNodes::default();
            if let Some(m) = &c.matrix_node {
                nodes.matrix = m.clone();
            }
            if let Some(d) = &c.dist_node {
                nodes.dist = d.clone();
            }
            Some(parse_calibration(&text, rel, &nodes).map_err(|e| err("calibration", &e))?)
        }
    };
    let keys = opencv_keys(c);
    let intr_keys: Vec<&&str> = keys.iter().filter(|k| matches!(**k, "fx" | "fy" | "cx" | "cy" | "k1" | "k2" | "k3" | "k4" | "k5" | "k6" | "p1" | "p2" | "s1" | "s2" | "s3" | "s4" | "tau_x_rad" | "tau_y_rad" | "dist")).collect();
    if fisheye_model {
        if let Some(cal) = &calib {
            if cal.fisheye.is_none() {
                return Err(err("calibration", &"is OpenCV's pinhole model; model = \"fisheye\" needs a fisheye calibration (\"model\": \"fisheye\")"));
            }
        }
    } else if c.skew.is_some() {
        return Err(err("skew", &"is a key of the fisheye model (set model = \"fisheye\")"));
    }
    let mut fisheye = calib.as_ref().and_then(|cal| cal.fisheye);
    let (intrinsics, distortion, mut size) = match &calib {
        Some(cal) => {
            if let Some(k) = intr_keys.first().copied().or(c.skew.map(|_| &"skew")) {
                return Err(err(k, &"the calibration file gives the intrinsics; do not also set them here"));
            }
            (cal.intrinsics, cal.distortion, cal.width.zip(cal.height))
        }
        None if fisheye_model => {
            let need = |k: &str, v: Option<f64>| v.filter(|x| x.is_finite()).ok_or_else(|| err(k, &"missing or not finite"));
            let intr = Intrinsics { fx: need("fx", c.fx)?, fy: need("fy", c.fy)?, cx: need("cx", c.cx)?, cy: need("cy", c.cy)? };
            for (k, p) in [("k5", c.k5), ("k6", c.k6), ("p1", c.p1), ("p2", c.p2), ("s1", c.s1), ("s2", c.s2), ("s3", c.s3), ("s4", c.s4), ("tau_x_rad", c.tau_x_rad), ("tau_y_rad", c.tau_y_rad)] {
                if p.is_some() {
                    return Err(err(k, &"is a term of OpenCV's pinhole model; the fisheye model takes k1, k2, k3, k4 and skew"));
                }
            }
            let named = [c.k1, c.k2, c.k3, c.k4];
            let k = match &c.dist {
                Some(_) if named.iter().any(|k| k.is_some()) => return Err(err("dist", &"give dist or k1…k4, not both")),
                Some(d) => <[f64; 4]>::try_from(d.as_slice()).map_err(|_| err("dist", &format!("the fisheye model has 4 coefficients k1, k2, k3, k4, got {}", d.len())))?,
                None => named.map(|k| k.unwrap_or(0.0)),
            };
            let skew = c.skew.unwrap_or(0.0);
            let m = [intr.fx, skew * intr.fx, intr.cx, 0.0, intr.fy, intr.cy, 0.0, 0.0, 1.0];
            fisheye = Some(FisheyeLens::from_opencv(&m, &k).map_err(|e| err("fx", &e))?);
            (intr, Distortion::default(), None)
        }
        None => {
            let need = |k: &str, v: Option<f64>| v.filter(|x| x.is_finite()).ok_or_else(|| err(k, &"missing or not finite"));
            let intr = Intrinsics { fx: need("fx", c.fx)?, fy: need("fy", c.fy)?, cx: need("cx", c.cx)?, cy: need("cy", c.cy)? };
            // OpenCV's order: k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, τx, τy.
            let named = [c.k1, c.k2, c.p1, c.p2, c.k3, c.k4, c.k5, c.k6, c.s1, c.s2, c.s3, c.s4, c.tau_x_rad, c.tau_y_rad];
            let dist = match &c.dist {
                Some(d) => {
                    if named.iter().any(|k| k.is_some()) {
                        return Err(err("dist", &"give dist or the named coefficients (k1…k6, p1, p2, s1…s4, tau_x_rad, tau_y_rad), not both"));
                    }
                    Distortion::from_opencv(d).map_err(|e| err("dist", &e))?
                }
                None => {
                    let key = if c.tau_x_rad.is_some() || c.tau_y_rad.is_some() { "tau_x_rad" } else { "k1" };
                    Distortion::from_opencv(&named.map(|k| k.unwrap_or(0.0))).map_err(|e| err(key, &e))?
                }
            };
            (intr, dist, None)
        }
    };
    let scene_size = match (c.width, c.height) {
        (Some(w), Some(h)) => Some((w, h)),
        (None, None) => default_size,
        _ => return Err(err(if c.width.is_none() { "width" } else { "height" }, &"give both width and height")),
    };
    // The calibration's intrinsics belong to its image size; another size rescales them.
    let mut rescale = None;
    match (size, scene_size) {
        (Some(a), Some(b)) if a != b => rescale = Some(b),
        (None, Some(b)) => size = Some(b),
        _ => {}
    }
    let Some((w0, h0)) = size else { return Err(err("width", &"missing (the image size the intrinsics belong to)")) };
    // Extrinsics: exactly one way.
    let tm = c.t.map(|t| t.map(|x| x * unit_m));
    let mut ways: Vec<(&str, Result<Extrinsics>)> = Vec::new();
    match (c.r, c.rvec, tm) {
        (Some(_), Some(_), _) => return Err(err("rvec", &"give R or rvec, not both")),
        (Some(r), None, Some(t)) => ways.push(("R", Extrinsics::from_rt(r, t))),
        (None, Some(v), Some(t)) => ways.push(("rvec", Extrinsics::from_rvec(v, t))),
        (Some(_), None, None) | (None, Some(_), None) => return Err(err("t", &"missing (R and rvec need t)")),
        (None, None, Some(_)) => return Err(err("R", &"missing (t needs R or rvec)")),
        (None, None, None) => {}
    }
    if let Some(p) = &c.pose {
        ways.push(("pose", pose(p, unit_m)));
    }
    if let (Some(e), Some(a)) = (c.eye, c.look_at) {
        let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
        ways.push(("eye", Extrinsics::look_at(e.map(|x| x * unit_m), a.map(|x| x * unit_m), up)));
    } else if c.eye.is_some() || c.look_at.is_some() {
        return Err(err(if c.eye.is_none() { "eye" } else { "look_at" }, &"missing (eye and look_at go together)"));
    }
    if let Some(cal) = &calib {
        if let Some(e) = cal.extrinsics(unit_m).map_err(|e| err("calibration", &e)).transpose() {
            ways.push(("calibration", e));
        }
    }
    if ways.len() > 1 {
        let names: Vec<&str> = ways.iter().map(|w| w.0).collect();
        return Err(err(names[1], &format!("the camera pose is given twice ({})", names.join(", "))));
    }
    let (key, extr) = ways.pop().ok_or_else(|| err("R", &"missing pose: give R (or rvec) and t, pose, or eye and look_at"))?;
    let extrinsics = extr.map_err(|e| err(key, &e))?;
    let mut camera = calibrated_model(intrinsics, distortion, fisheye, extrinsics, w0, h0).map_err(|e| cx.err(cspan, field, e))?;
    if let Some((w, h)) = rescale {
        camera.set_resolution(w, h);
    }
    Ok(camera)
}

/// A calibrated camera of OpenCV's pinhole model, or of its fisheye model when `fisheye` is given
/// (whose fx, fy, cx, cy are then the intrinsics').
fn calibrated_model(intrinsics: Intrinsics, distortion: Distortion, fisheye: Option<FisheyeLens>, extrinsics: Extrinsics, w: u32, h: u32) -> Result<Camera> {
    match fisheye {
        Some(lens) => Camera::fisheye(Fisheye::new(lens, extrinsics, w, h)?, w, h),
        None => Camera::opencv(OpenCv::new(intrinsics, distortion, extrinsics, w, h)?, w, h),
    }
}

/// Camera-to-world pose: 3 or 4 rows [r00, r01, r02, cx] … (columns: the camera's x right,
/// y down, z forward axes in world coordinates; last column the centre in the scene unit).
fn pose(rows: &[[f64; 4]], unit_m: f64) -> Result<Extrinsics> {
    if !(rows.len() == 3 || rows.len() == 4) {
        return Err(anyhow!("expected 3 or 4 rows of 4 numbers, got {} rows", rows.len()));
    }
    if rows.len() == 4 && rows[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(anyhow!("the last row of a 4×4 pose must be [0, 0, 0, 1]"));
    }
    let r = [0, 1, 2].map(|a| [rows[a][0], rows[a][1], rows[a][2]]);
    let c = [0, 1, 2].map(|a| rows[a][3] * unit_m);
    Extrinsics::from_pose(r, c)
}

/// The thin lens, or None; errors name the key.
fn lens(c: &CameraDesc, unit_m: f64) -> std::result::Result<Option<ThinLens>, (&'static str, anyhow::Error)> {
    let focus = c.focus_distance.map(|x| (x * unit_m) as f32);
    let l = match (c.aperture_radius, c.f_number, c.focal_length_mm) {
        (None, None, None) => {
            return match focus {
                None => Ok(None),
                Some(_) => Err(("focus_distance", anyhow!("needs aperture_radius, or f_number and focal_length_mm"))),
            }
        }
        (Some(_), Some(_), _) => return Err(("f_number", anyhow!("give aperture_radius or f_number, not both"))),
        (Some(a), None, None) => {
            let f = focus.ok_or(("focus_distance", anyhow!("missing (the lens needs it)")))?;
            ThinLens::new((a * unit_m) as f32, f).map_err(|e| ("aperture_radius", e))?
        }
        (None, Some(n), Some(fl)) => {
            let f = focus.ok_or(("focus_distance", anyhow!("missing (the lens needs it)")))?;
            ThinLens::from_f_number(n as f32, (fl * 1e-3) as f32, f).map_err(|e| ("f_number", e))?
        }
        (Some(_), None, Some(_)) => return Err(("focal_length_mm", anyhow!("only used with f_number"))),
        (None, Some(_), None) => return Err(("focal_length_mm", anyhow!("missing (f_number needs it)"))),
        (None, None, Some(_)) => return Err(("f_number", anyhow!("missing (focal_length_mm needs it)"))),
    };
    Ok(Some(l))
}

/// A calibrated camera replacing `base`: the calibration's intrinsics and distortion at its image
/// size (or `base`'s, when the file gives none; rescaled when `base`'s size differs), its
/// extrinsics (t in the calibration's unit, else `scene_unit_m` metres per unit) or else
/// `base`'s pose; `base`'s lens is kept.
pub fn calibrated_camera(cal: &Calibration, base: &Camera, scene_unit_m: f64) -> Result<Camera> {
    let extrinsics = match cal.extrinsics(scene_unit_m)? {
        Some(e) => e,
        None => match &base.model {
            CameraModel::OpenCv(c) => c.extrinsics,
            CameraModel::Fisheye(c) => c.extrinsics,
            CameraModel::Pinhole(_) | CameraModel::Orthographic(_) => {
                let row = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
                let (forward, right, up) = base.axes();
                let r = [row(right), row(-up), row(forward)];
                let e = row(base.eye());
                let re = crate::camera::opencv::mat_vec(&r, e);
                Extrinsics::from_rt(r, [-re[0], -re[1], -re[2]])?
            }
        },
    };
    let (w, h) = cal.width.zip(cal.height).unwrap_or((base.width, base.height));
    let mut camera = calibrated_model(cal.intrinsics, cal.distortion, cal.fisheye, extrinsics, w, h)?;
    camera.lens = base.lens;
    camera.filter = base.filter.clone();
    Ok(camera)
}

impl crate::scene::Scene {
    /// Replace the camera by the calibration in `path` (see [`calibrated_camera`]); the file's
    /// bytes join the scene's content hash. Errors are one line naming the file.
    pub fn use_calibration(&mut self, path: &std::path::Path, nodes: &CalibrationNodes) -> Result<()> {
        let text = std::fs::read_to_string(path).map_err(|e| anyhow!("{}: cannot read calibration: {e}", path.display()))?;
        let cal = parse_calibration(&text, &path.display().to_string(), nodes)?;
        self.camera = calibrated_camera(&cal, &self.camera, self.unit_m).map_err(|e| anyhow!("{}: {e}", path.display()))?;
        let mut h = crate::math::hash::Fnv1a64::new();
        h.write(&self.content_hash.to_le_bytes());
        h.write(text.as_bytes());
        self.content_hash = h.finish();
        Ok(())
    }
}
