//! Camera calibration files: lucent's calibration JSON and OpenCV FileStorage YAML and XML.
//!
//! lucent's JSON (all keys but `width`…`cy` optional):
//! `{"width": 640, "height": 480, "fx": 530.0, "fy": 530.0, "cx": 319.5, "cy": 239.5,
//!   "dist": [k1, k2, p1, p2, k3, k4, k5, k6], "R": [[…], […], […]], "t": [tx, ty, tz], "unit": "mm"}`
//! — pixels for the intrinsics (OpenCV convention, integer coordinates at pixel centres), OpenCV's
//! coefficient order for `dist` (4, 5 or 8 entries), R and t world → camera; instead of R a
//! Rodrigues `"rvec"`. `t` is in `unit` (m, dm, cm, mm, um, km, in, ft), or the scene's unit when
//! `unit` is absent. `lucent scan calibrate-camera` writes this form, with `rms_px` and the
//! board pose of each view (`views`), which the renderer does not use. With `"model": "fisheye"`
//! the camera is OpenCV's fisheye model (`camera::fisheye`): `dist` holds its k1, k2, k3, k4 (0
//! or 4 entries) and `"skew"` its α (K₀₁/K₀₀, default 0), as `lucent scan calibrate-camera
//! --fisheye` writes it; `"model": "opencv"` (the default) is the pinhole model above.
//!
//! A projector–camera calibration as `lucent scan calibrate` writes it (`{"camera": {…},
//! "projector": {…}, "rotation": [[…]], "translation": […], …}`, each device `{width, height, fx,
//! fy, cx, cy, distortion: [k1, k2, p1, p2, k3], rms_px}`) is read as one of its two devices: the
//! camera by default, the projector when the matrix node is named `projector` (`matrix_node =
//! "projector"` in the scene, `--camera-matrix-node projector` on the command line). The camera sits
//! at the world origin with the world axes (R = I, t = 0); the projector has R = `rotation`,
//! t = `translation` (X_p = R·X_c + T), in the scene's unit (the board's square unit). A fisheye
//! pair's file (`lucent scan calibrate-stereo --fisheye`: the same layout with `"model":
//! "fisheye"` and `"skew": [α₁, α₂]`, each device's `distortion` holding k1…k4) gives either
//! camera as a fisheye camera.
//!
//! FileStorage (as `cv::FileStorage` and OpenCV's calibration sample write it): the camera matrix
//! and distortion nodes are `!!opencv-matrix` (YAML, `%YAML:1.0`) or `type_id="opencv-matrix"`
//! (XML, `<opencv_storage>`) with `rows`, `cols`, `dt`, `data`; their names default to
//! `camera_matrix` and `distortion_coefficients`. The resolution comes from `image_width` and
//! `image_height` (or `img_shape`, [rows, cols], as procam-calibration writes it; its
//! `calibration_result.xml` read with the nodes `cam_int`/`cam_dist` places the camera at the
//! origin, with `proj_int`/`proj_dist` the projector at `roration`, `translation`, as lucent's
//! JSON); optional extrinsics from a 3×3 `R` (or 3×1 `rvec`) and a 3×1 `t` (or `tvec`,
//! `T`), t in the scene's unit. The reader understands this subset of FileStorage: scalar nodes
//! and matrices, at any nesting depth, found by name.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::camera::{Distortion, Extrinsics, FisheyeLens, Intrinsics};
use anyhow::{anyhow, bail, Context, Result};
use std::path::Path;

/// Names of the FileStorage nodes to read.
#[derive(Clone, Debug)]
pub struct CalibrationNodes {
    /// Camera matrix node (default `camera_matrix`).
    pub matrix: String,
    /// Distortion coefficient node (default `distortion_coefficients`).
    pub dist: String,
}

impl Default for CalibrationNodes {
    fn default() -> Self {
        CalibrationNodes { matrix: "camera_matrix".into(), dist: "distortion_coefficients".into() }
    }
}

/// A camera calibration as read from a file.
#[derive(Clone, Debug)]
pub struct Calibration {
    /// Image size the calibration belongs to (pixels), when the file gives it.
    pub width: Option<u32>,
    /// Image size (pixels).
    pub height: Option<u32>,
    /// Intrinsics (pixels).
    pub intrinsics: Intrinsics,
    /// Distortion coefficients (zero for a fisheye).
    pub distortion: Distortion,
    /// OpenCV's fisheye model instead of the pinhole's distortion, when the file names it (its
    /// fx, fy, cx, cy are `intrinsics`').
    pub fisheye: Option<FisheyeLens>,
    /// World-to-camera rotation, when the file gives one.
    pub r: Option<[[f64; 3]; 3]>,
    /// World-to-camera translation in `t_unit_m` metres per unit, when given.
    pub t: Option<[f64; 3]>,
    /// Metres per unit of `t` (None: the scene's unit).
    pub t_unit_m: Option<f64>,
}

impl Calibration {
    /// Extrinsics with t in metres (`scene_unit_m` metres per scene unit), when the file has both R and t.
    pub fn extrinsics(&self, scene_unit_m: f64) -> Result<Option<Extrinsics>> {
        match (self.r, self.t) {
            (Some(r), Some(t)) => {
                let s = self.t_unit_m.unwrap_or(scene_unit_m);
                Ok(Some(Extrinsics::from_rt(r, t.map(|x| x * s))?))
            }
            (None, None) => Ok(None),
            (Some(_), None) => bail!("the calibration has R but no t"),
            (None, Some(_)) => bail!("the calibration has t but no R"),
        }
    }
}

/// Read a calibration file (format from its content: JSON object, `%YAML`, or XML).
pub fn read_calibration(path: &Path, nodes: &CalibrationNodes) -> Result<Calibration> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read calibration", path.display()))?;
    parse_calibration(&text, &path.display().to_string(), nodes)
}

/// Parse calibration text; `name` labels errors.
pub fn parse_calibration(text: &str, name: &str, nodes: &CalibrationNodes) -> Result<Calibration> {
    let t = text.trim_start_matches('\u{feff}').trim_start();
    let r = if t.starts_with('{') {
        json(t, nodes)
    } else if t.starts_with("%YAML") {
        filestorage(&Yaml { text: t }, nodes)
    } else if t.starts_with("<?xml") || t.starts_with("<opencv_storage") {
        filestorage(&Xml { text: t }, nodes)
    } else {
        Err(anyhow!("not a calibration file (expected a JSON object, `%YAML:1.0` or `<opencv_storage>`)"))
    };
    r.map_err(|e| anyhow!("{name}: {}", one_line(&e)))
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonCalib {
    width: Option<u32>,
    height: Option<u32>,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    dist: Option<Vec<f64>>,
    /// `opencv` (the default) or `fisheye`.
    model: Option<String>,
    /// The fisheye model's skew α.
    skew: Option<f64>,
    #[serde(rename = "R")]
    r: Option<[[f64; 3]; 3]>,
    rvec: Option<[f64; 3]>,
    t: Option<[f64; 3]>,
    unit: Option<String>,
    /// What `lucent scan calibrate-camera` adds (not used here): the RMS reprojection error and
    /// the board pose of each view.
    #[allow(dead_code)]
    rms_px: Option<f64>,
    #[allow(dead_code)]
    views: Option<serde_json::Value>,
}

#[derive(serde::Deserialize)]
struct ProcamDevice {
    width: u32,
    height: u32,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    distortion: Vec<f64>,
}

#[derive(serde::Deserialize)]
struct Procam {
    /// `fisheye` for a fisheye pair (`scan calibrate-stereo --fisheye`), else absent.
    model: Option<String>,
    /// A fisheye pair's skews α of the first and the second camera.
    skew: Option<[f64; 2]>,
    camera: ProcamDevice,
    projector: ProcamDevice,
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
}

/// A `lucent scan calibrate` file, read as the device named by `nodes.matrix`.
fn procam(text: &str, nodes: &CalibrationNodes) -> Result<Calibration> {
    let j: Procam = serde_json::from_str(text).map_err(|e| anyhow!("{e}"))?;
    let (d, r, t, which) = match nodes.matrix.as_str() {
        "camera" | "camera_matrix" => (&j.camera, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3], 0),
        "projector" => (&j.projector, j.rotation, j.translation, 1),
        other => bail!("a projector–camera calibration holds the devices `camera` and `projector`, not `{other}`"),
    };
    let (distortion, fisheye) = match j.model.as_deref() {
        None => {
            if j.skew.is_some() {
                bail!("skew: only a fisheye pair (\"model\": \"fisheye\") has a skew");
            }
            (Distortion::from_opencv(&d.distortion).map_err(|e| anyhow!("distortion: {e}"))?, None)
        }
        Some("fisheye") => {
            let &[k1, k2, k3, k4] = d.distortion.as_slice() else { bail!("distortion: the fisheye model has 4 coefficients k1, k2, k3, k4, got {}", d.distortion.len()) };
            let kk = [d.fx, j.skew.map_or(0.0, |s| s[which]) * d.fx, d.cx, 0.0, d.fy, d.cy, 0.0, 0.0, 1.0];
            (Distortion::default(), Some(FisheyeLens::from_opencv(&kk, &[k1, k2, k3, k4])?))
        }
        Some(other) => bail!("model: `{other}` is not a camera model of a pair (fisheye, or absent for the pinhole model)"),
    };
    Ok(Calibration { width: Some(d.width), height: Some(d.height), intrinsics: Intrinsics { fx: d.fx, fy: d.fy, cx: d.cx, cy: d.cy }, distortion, fisheye, r: Some(r), t: Some(t), t_unit_m: None })
}

fn json(text: &str, nodes: &CalibrationNodes) -> Result<Calibration> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| anyhow!("{e}"))?;
    if v.get("camera").is_some() && v.get("projector").is_some() {
        return procam(text, nodes);
    }
    let j: JsonCalib = serde_json::from_str(text).map_err(|e| anyhow!("{e}"))?;
    let r = match (j.r, j.rvec) {
        (Some(_), Some(_)) => bail!("R, rvec: give one, not both"),
        (Some(r), None) => Some(r),
        (None, Some(v)) => Some(crate::camera::opencv::rodrigues(v)),
        (None, None) => None,
    };
    let t_unit_m = match &j.unit {
        None => None,
        Some(u) => Some(super::object::unit_in_metres(u).ok_or_else(|| anyhow!("unit: unknown length unit `{u}`"))?),
    };
    let intrinsics = Intrinsics { fx: j.fx, fy: j.fy, cx: j.cx, cy: j.cy };
    let (distortion, fisheye) = match j.model.as_deref().unwrap_or("opencv") {
        "opencv" => {
            if j.skew.is_some() {
                bail!("skew: only the fisheye model (\"model\": \"fisheye\") has a skew");
            }
            (Distortion::from_opencv(j.dist.as_deref().unwrap_or(&[])).map_err(|e| anyhow!("dist: {e}"))?, None)
        }
        "fisheye" => {
            let k = match j.dist.as_deref() {
                None | Some([]) => [0.0; 4],
                Some(&[k1, k2, k3, k4]) => [k1, k2, k3, k4],
                Some(d) => bail!("dist: the fisheye model has 4 coefficients k1, k2, k3, k4, got {}", d.len()),
            };
            let skew = j.skew.unwrap_or(0.0);
            let kk = [j.fx, skew * j.fx, j.cx, 0.0, j.fy, j.cy, 0.0, 0.0, 1.0];
            (Distortion::default(), Some(FisheyeLens::from_opencv(&kk, &k)?))
        }
        other => bail!("model: `{other}` is not a camera model (opencv or fisheye)"),
    };
    Ok(Calibration { width: j.width, height: j.height, intrinsics, distortion, fisheye, r, t: j.t, t_unit_m })
}

/// A FileStorage node: a matrix (rows, cols, row-major data) or a scalar.
/// A FileStorage node: a scalar or an `opencv-matrix` (rows, cols, row-major data).
#[derive(Clone, Debug, PartialEq)]
pub enum Node {
    /// `rows` × `cols` matrix, row-major.
    Matrix(usize, usize, Vec<f64>),
    /// A number.
    Scalar(f64),
}

/// The node called `name` in OpenCV FileStorage text (YAML `%YAML:1.0` or XML
/// `<opencv_storage>`), None when absent; errors name the node.
pub fn filestorage_node(text: &str, name: &str) -> Result<Option<Node>> {
    let t = text.trim_start_matches('\u{feff}').trim_start();
    let r = if t.starts_with("%YAML") {
        Yaml { text: t }.node(name)
    } else if t.starts_with("<?xml") || t.starts_with("<opencv_storage") {
        Xml { text: t }.node(name)
    } else {
        bail!("not an OpenCV FileStorage file (expected `%YAML:1.0` or `<opencv_storage>`)")
    };
    r.map_err(|e| anyhow!("{name}: {}", one_line(&e)))
}

/// An error's message on one line, whatever file text it quotes (whitespace runs as one space).
fn one_line(e: &anyhow::Error) -> String {
    e.to_string().split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Whether `text` looks like OpenCV FileStorage (YAML or XML) rather than JSON.
pub fn is_filestorage(text: &str) -> bool {
    let t = text.trim_start_matches('\u{feff}').trim_start();
    t.starts_with("%YAML") || t.starts_with("<?xml") || t.starts_with("<opencv_storage")
}

trait Storage {
    /// The node called `name`, None when absent.
    fn node(&self, name: &str) -> Result<Option<Node>>;
}

fn filestorage(s: &dyn Storage, nodes: &CalibrationNodes) -> Result<Calibration> {
    let matrix = |name: &str| -> Result<Option<(usize, usize, Vec<f64>)>> {
        match s.node(name).map_err(|e| anyhow!("{name}: {e}"))? {
            None => Ok(None),
            Some(Node::Matrix(r, c, d)) => Ok(Some((r, c, d))),
            Some(Node::Scalar(_)) => bail!("{name}: is a scalar, expected an opencv-matrix"),
        }
    };
    let size = |name: &str| -> Result<Option<u32>> {
        match s.node(name).map_err(|e| anyhow!("{name}: {e}"))? {
            None => Ok(None),
            Some(Node::Scalar(x)) if x >= 1.0 && x.fract() == 0.0 && x <= u32::MAX as f64 => Ok(Some(x as u32)),
            Some(_) => bail!("{name}: must be a positive whole number of pixels"),
        }
    };
    let (r, c, k) = matrix(&nodes.matrix)?.ok_or_else(|| anyhow!("{}: no such node (name the camera matrix node)", nodes.matrix))?;
    if (r, c) != (3, 3) {
        bail!("{}: camera matrix is {r}×{c}, expected 3×3", nodes.matrix);
    }
    let intrinsics = Intrinsics::from_camera_matrix(&k).map_err(|e| anyhow!("{}: {e}", nodes.matrix))?;
    let dist = match matrix(&nodes.dist)? {
        None => bail!("{}: no such node (name the distortion node)", nodes.dist),
        Some((r, c, d)) if r == 1 || c == 1 => d,
        Some((r, c, _)) => bail!("{}: distortion is {r}×{c}, expected a vector", nodes.dist),
    };
    let distortion = Distortion::from_opencv(&dist).map_err(|e| anyhow!("{}: {e}", nodes.dist))?;
    let vec3 = |names: &[&str]| -> Result<Option<[f64; 3]>> {
        for n in names {
            if let Some((r, c, d)) = matrix(n)? {
                if r * c != 3 {
                    bail!("{n}: is {r}×{c}, expected 3 entries");
                }
                return Ok(Some([d[0], d[1], d[2]]));
            }
        }
        Ok(None)
    };
    let rot = match matrix("R")? {
        Some((3, 3, d)) => Some([[d[0], d[1], d[2]], [d[3], d[4], d[5]], [d[6], d[7], d[8]]]),
        Some((r, c, _)) => bail!("R: is {r}×{c}, expected 3×3"),
        None => vec3(&["rvec"])?.map(crate::camera::opencv::rodrigues),
    };
    let t = vec3(&["t", "tvec", "T"])?;
    // A projector–camera file of procam-calibration (cam_int, proj_int and the camera → projector
    // `roration` (sic) and `translation`): the camera sits at the origin, the projector at the
    // stereo pose, as for lucent's JSON.
    let (rot, t) = match (rot, t, nodes.matrix.as_str()) {
        (None, None, m @ ("cam_int" | "proj_int")) => match (matrix("roration")?.or(matrix("rotation")?), vec3(&["translation"])?) {
            (Some((3, 3, d)), Some(tr)) if m == "proj_int" => (Some([[d[0], d[1], d[2]], [d[3], d[4], d[5]], [d[6], d[7], d[8]]]), Some(tr)),
            (Some((3, 3, _)), Some(_)) => (Some([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), Some([0.0; 3])),
            (Some((r, c, _)), Some(_)) => bail!("roration: is {r}×{c}, expected 3×3"),
            _ => (None, None),
        },
        other => (other.0, other.1),
    };
    // The image size: image_width and image_height (OpenCV's calibration sample), or img_shape,
    // the [rows, cols] of procam-calibration's calibration_result.xml.
    // (For `proj_int`, the projector's: proj_shape, which lucent's --opencv-out adds.)
    let shape_node = if nodes.matrix == "proj_int" { "proj_shape" } else { "img_shape" };
    let (width, height) = match (size("image_width")?, size("image_height")?, matrix(shape_node)?) {
        (None, None, Some((r, c, d))) if r * c == 2 && d.iter().all(|x| *x >= 1.0 && x.fract() == 0.0 && *x <= u32::MAX as f64) => (Some(d[1] as u32), Some(d[0] as u32)),
        (None, None, Some(_)) => bail!("{shape_node}: expected the image's [rows, cols] in pixels"),
        (w, h, _) => (w, h),
    };
    Ok(Calibration {
        width,
        height,
        intrinsics,
        distortion,
        fisheye: None,
        r: rot,
        t,
        t_unit_m: None,
    })
}

/// File text quoted in a one-line error: whitespace runs as one space, at most 60 characters.
fn snippet(s: &str) -> String {
    let one_line = s.split_whitespace().collect::<Vec<_>>().join(" ");
    match one_line.char_indices().nth(60) {
        Some((i, _)) => format!("{}…", &one_line[..i]),
        None => one_line,
    }
}

fn numbers(s: &str, what: &str) -> Result<Vec<f64>> {
    s.split(|c: char| c.is_whitespace() || c == ',')
        .filter(|w| !w.is_empty())
        .map(|w| w.parse::<f64>().map_err(|_| anyhow!("{what}: `{}` is not a number", snippet(w))))
        .collect()
}

fn check_matrix(rows: f64, cols: f64, dt: &str, data: Vec<f64>) -> Result<Node> {
    if !matches!(dt, "d" | "f" | "i" | "u" | "s" | "w" | "c") {
        bail!("dt `{}`: expected a single-channel element type (d, f, i, …)", snippet(dt));
    }
    if !(rows >= 0.0 && cols >= 0.0 && rows.fract() == 0.0 && cols.fract() == 0.0) {
        bail!("rows, cols must be whole numbers");
    }
    let (r, c) = (rows as usize, cols as usize);
    if data.len() != r * c {
        bail!("data has {} entries, rows × cols = {r}×{c}", data.len());
    }
    if let Some(x) = data.iter().find(|x| !x.is_finite()) {
        bail!("data: {x} is not finite");
    }
    Ok(Node::Matrix(r, c, data))
}

/// OpenCV FileStorage YAML (`%YAML:1.0`).
struct Yaml<'a> {
    text: &'a str,
}

impl Yaml<'_> {
    /// Value text after `key:` on a line, at any indentation.
    fn key_line<'b>(lines: &[&'b str], key: &str) -> Option<(usize, usize, &'b str)> {
        lines.iter().enumerate().find_map(|(n, l)| {
            let indent = l.len() - l.trim_start().len();
            let rest = l.trim_start().strip_prefix(key)?.trim_start_matches(' ');
            let rest = rest.strip_prefix(':')?;
            if !(rest.is_empty() || rest.starts_with([' ', '\t'])) {
                return None;
            }
            Some((n, indent, rest.trim()))
        })
    }
}

impl Storage for Yaml<'_> {
    fn node(&self, name: &str) -> Result<Option<Node>> {
        let lines: Vec<&str> = self.text.lines().map(|l| l.split(" #").next().unwrap_or(l)).collect();
        let Some((n, indent, value)) = Yaml::key_line(&lines, name) else { return Ok(None) };
        if !value.starts_with("!!opencv-matrix") {
            let v = value.trim_matches('"');
            return match v.parse::<f64>() {
                Ok(x) => Ok(Some(Node::Scalar(x))),
                Err(_) => bail!("`{}` is neither a number nor an !!opencv-matrix", snippet(value)),
            };
        }
        // The matrix's fields: the following lines indented deeper than the key.
        let mut body = Vec::new();
        for l in &lines[n + 1..] {
            let ind = l.len() - l.trim_start().len();
            if !l.trim().is_empty() && ind <= indent {
                break;
            }
            body.push(*l);
        }
        let field = |k: &str| Yaml::key_line(&body, k).map(|(m, _, v)| (m, v));
        let num = |k: &str| -> Result<f64> {
            let (_, v) = field(k).ok_or_else(|| anyhow!("missing `{k}`"))?;
            v.parse::<f64>().map_err(|_| anyhow!("{k}: `{}` is not a number", snippet(v)))
        };
        let (rows, cols) = (num("rows")?, num("cols")?);
        let dt = field("dt").ok_or_else(|| anyhow!("missing `dt`"))?.1.trim_matches('"');
        let (m, first) = field("data").ok_or_else(|| anyhow!("missing `data`"))?;
        let mut data = first.to_string();
        let mut k = m + 1;
        while !data.contains(']') && k < body.len() {
            data.push(' ');
            data.push_str(body[k]);
            k += 1;
        }
        let inner = data.trim().strip_prefix('[').and_then(|s| s.split(']').next()).ok_or_else(|| anyhow!("data: expected [ … ]"))?;
        check_matrix(rows, cols, dt, numbers(inner, "data")?).map(Some)
    }
}

/// OpenCV FileStorage XML (`<opencv_storage>`).
struct Xml<'a> {
    text: &'a str,
}

/// Content of the first element `<tag …>…</tag>` in `s`, with its attribute text.
fn element<'b>(s: &'b str, tag: &str) -> Option<(&'b str, &'b str)> {
    let open = format!("<{tag}");
    let mut from = 0;
    while let Some(p) = s[from..].find(&open) {
        let start = from + p + open.len();
        let rest = &s[start..];
        if rest.starts_with(['>', ' ', '\t', '\n', '\r', '/']) {
            let gt = rest.find('>')?;
            let attrs = &rest[..gt];
            if attrs.ends_with('/') {
                return Some((attrs, ""));
            }
            let body = &rest[gt + 1..];
            let end = body.find(&format!("</{tag}>"))?;
            return Some((attrs, &body[..end]));
        }
        from = start;
    }
    None
}

impl Storage for Xml<'_> {
    fn node(&self, name: &str) -> Result<Option<Node>> {
        let Some((attrs, body)) = element(self.text, name) else { return Ok(None) };
        if !attrs.contains("opencv-matrix") {
            let v = body.trim().trim_matches('"');
            return match v.parse::<f64>() {
                Ok(x) => Ok(Some(Node::Scalar(x))),
                Err(_) => bail!("`{}` is neither a number nor an opencv-matrix", snippet(v)),
            };
        }
        let field = |k: &str| element(body, k).map(|(_, v)| v.trim()).ok_or_else(|| anyhow!("missing <{k}>"));
        let num = |k: &str| -> Result<f64> {
            let v = field(k)?;
            v.parse::<f64>().map_err(|_| anyhow!("{k}: `{}` is not a number", snippet(v)))
        };
        let (rows, cols) = (num("rows")?, num("cols")?);
        check_matrix(rows, cols, field("dt")?, numbers(field("data")?, "data")?).map(Some)
    }
}
