//! Projector–camera calibration: the result type and its JSON form.

pub mod bundle;
pub mod camera;
pub mod chessboard;
pub mod fisheye;
pub mod homography;
pub mod model;
pub mod pnp;
pub mod pnp_ransac;
pub mod procam;
pub mod rectify;
pub mod schur_lm;
pub mod undistort;
pub mod zhang;

use serde::{Deserialize, Serialize};

/// One device's intrinsics and distortion (OpenCV's model and pixel convention).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct DeviceCalibration {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels).
    pub cx: f64,
    /// Principal point y (pixels).
    pub cy: f64,
    /// OpenCV distortion coefficients [k1, k2, p1, p2, k3] (dimensionless).
    pub distortion: Vec<f64>,
    /// RMS reprojection error of this device (pixels).
    pub rms_px: f64,
}

/// The board pose of one capture in camera coordinates (OpenCV `rvec`, `tvec`: board → camera).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct CapturePose {
    /// The capture folder.
    pub name: String,
    /// Rodrigues rotation vector board → camera (radians).
    pub rvec: [f64; 3],
    /// Translation board → camera (square units).
    pub tvec: [f64; 3],
    /// RMS reprojection error over both devices for this capture (pixels).
    pub rms_px: f64,
    /// Corners with a projector position (the others are outside the projector's throw or
    /// shadowed, and count for the camera only); 0 in files written before this was recorded.
    #[serde(default)]
    pub projector_corners: usize,
}

/// A projector–camera calibration as `lucent scan calibrate` writes it.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ProcamCalibration {
    /// The camera.
    pub camera: DeviceCalibration,
    /// The projector (a camera run backwards).
    pub projector: DeviceCalibration,
    /// Rotation camera → projector, row-major (X_p = R X_c + T, as OpenCV's `stereoCalibrate`).
    pub rotation: [[f64; 3]; 3],
    /// Translation camera → projector (square units).
    pub translation: [f64; 3],
    /// RMS reprojection error over both devices (pixels).
    pub rms_px: f64,
    /// Per-capture board poses.
    pub captures: Vec<CapturePose>,
}

impl ProcamCalibration {
    /// Read a projector–camera calibration: lucent's JSON (what `lucent scan calibrate` writes),
    /// or OpenCV FileStorage XML or YAML as kamino410/procam-calibration's `calibrate.py` writes it
    /// (`calibration_result.xml`: `img_shape` [rows, cols], `rms`, `cam_int`, `cam_dist`,
    /// `proj_int`, `proj_dist`, the camera → projector rotation `roration` (sic; `rotation` or `R`
    /// also read) and `translation` (or `T`), from OpenCV's `stereoCalibrate`). FileStorage does
    /// not give the projector's resolution: `projector` (pixels) must then be given; for JSON it
    /// must agree with the file when given. No board poses come from FileStorage. Errors are one
    /// line naming the file.
    pub fn read(path: &std::path::Path, projector: Option<(u32, u32)>) -> anyhow::Result<ProcamCalibration> {
        use anyhow::{anyhow, bail, Context};
        let name = path.display();
        let text = std::fs::read_to_string(path).with_context(|| format!("{name}: cannot read"))?;
        if !render::load::calibration::is_filestorage(&text) {
            if fisheye::pair::FisheyeStereoCalibration::is_fisheye(&text) {
                bail!("{name}: a fisheye pair's calibration (\"model\": \"fisheye\"); this command takes OpenCV's pinhole model (scan rectify and lucent render take fisheye pairs)");
            }
            let c: ProcamCalibration = serde_json::from_str(&text).map_err(|e| anyhow!("{name}: not a calibration: {e}"))?;
            if let Some((w, h)) = projector {
                if (w, h) != (c.projector.width, c.projector.height) {
                    bail!("{name}: the projector is {}x{} in the calibration, {w}x{h} given", c.projector.width, c.projector.height);
                }
            }
            c.check().map_err(|e| anyhow!("{name}: {e}"))?;
            return Ok(c);
        }
        use render::load::calibration::{filestorage_node, Node};
        let node = |n: &str| filestorage_node(&text, n).map_err(|e| anyhow!("{name}: {e}"));
        let matrix = |names: &[&str], rows: usize, cols: usize| -> anyhow::Result<Vec<f64>> {
            for n in names {
                match node(n)? {
                    None => continue,
                    Some(Node::Matrix(r, c, d)) if r * c == rows * cols && (r == rows || rows == 1 || cols == 1) => return Ok(d),
                    Some(Node::Matrix(r, c, _)) => bail!("{name}: {n} is {r}×{c}, expected {rows}×{cols}"),
                    Some(Node::Scalar(_)) => bail!("{name}: {n} is a scalar, expected a {rows}×{cols} opencv-matrix"),
                }
            }
            bail!("{name}: no node {} (a procam-calibration file has cam_int, cam_dist, proj_int, proj_dist, roration, translation)", names.join(" or "))
        };
        let dist = |n: &str| -> anyhow::Result<Vec<f64>> {
            match node(n)? {
                Some(Node::Matrix(r, c, d)) if r == 1 || c == 1 => {
                    render::camera::Distortion::from_opencv(&d).map_err(|e| anyhow!("{name}: {n}: {e}"))?;
                    Ok(d)
                }
                Some(_) => bail!("{name}: {n} must be a vector of 4, 5, 8, 12 or 14 coefficients"),
                None => bail!("{name}: no node {n}"),
            }
        };
        let device = |k: &[f64], d: Vec<f64>, (w, h): (u32, u32), n: &str, rms: f64| -> anyhow::Result<DeviceCalibration> {
            let i = render::camera::Intrinsics::from_camera_matrix(k).map_err(|e| anyhow!("{name}: {n}: {e}"))?;
            Ok(DeviceCalibration { width: w, height: h, fx: i.fx, fy: i.fy, cx: i.cx, cy: i.cy, distortion: d, rms_px: rms })
        };
        let camera_size = match node("img_shape")? {
            Some(Node::Matrix(r, c, d)) if r * c == 2 && d.iter().all(|x| *x >= 1.0 && x.fract() == 0.0) => (d[1] as u32, d[0] as u32),
            Some(_) => bail!("{name}: img_shape must be the camera's [rows, cols] in pixels"),
            None => match (node("image_width")?, node("image_height")?) {
                (Some(Node::Scalar(w)), Some(Node::Scalar(h))) if w >= 1.0 && h >= 1.0 => (w as u32, h as u32),
                _ => bail!("{name}: no camera size (img_shape, or image_width and image_height)"),
            },
        };
        // lucent's own FileStorage output adds proj_shape; procam-calibration's file lacks it.
        let stored = match node("proj_shape")? {
            Some(Node::Matrix(r, c, d)) if r * c == 2 && d.iter().all(|x| *x >= 1.0 && x.fract() == 0.0) => Some((d[1] as u32, d[0] as u32)),
            Some(_) => bail!("{name}: proj_shape must be the projector's [rows, cols] in pixels"),
            None => None,
        };
        let projector = match (projector, stored) {
            (Some(given), Some(s)) if given != s => bail!("{name}: the projector is {}x{} in the calibration, {}x{} given", s.0, s.1, given.0, given.1),
            (Some(p), _) | (None, Some(p)) => p,
            (None, None) => bail!("{name}: an OpenCV FileStorage calibration without proj_shape does not give the projector's resolution: pass --projector WxH"),
        };
        let rms = match node("rms")? {
            Some(Node::Scalar(x)) if x >= 0.0 => x,
            _ => f64::NAN,
        };
        let r = matrix(&["roration", "rotation", "R"], 3, 3)?;
        let t = matrix(&["translation", "T"], 3, 1)?;
        let rotation = [[r[0], r[1], r[2]], [r[3], r[4], r[5]], [r[6], r[7], r[8]]];
        render::camera::Extrinsics::from_rt(rotation, [t[0], t[1], t[2]]).map_err(|e| anyhow!("{name}: roration: {e}"))?;
        let c = ProcamCalibration {
            camera: device(&matrix(&["cam_int"], 3, 3)?, dist("cam_dist")?, camera_size, "cam_int", rms)?,
            projector: device(&matrix(&["proj_int"], 3, 3)?, dist("proj_dist")?, projector, "proj_int", rms)?,
            rotation,
            translation: [t[0], t[1], t[2]],
            rms_px: rms,
            captures: Vec::new(),
        };
        c.check().map_err(|e| anyhow!("{name}: {e}"))?;
        Ok(c)
    }

    /// Checks what the commands that read a calibration rely on: each device's size, focal
    /// lengths (> 0) and principal point (within 10 image widths), its distortion one of OpenCV's
    /// lengths and invertible over at least half of its image (a lens fitted to a board in the
    /// image's centre may fold beyond it; the commands skip those pixels, and
    /// [`ProcamCalibration::lens_warnings`] says so), the rotation a rotation
    /// (orthonormal within 10⁻⁶, determinant +1) and the translation finite and not zero (two
    /// devices at one centre triangulate and rectify nothing). The error names the field.
    pub fn check(&self) -> anyhow::Result<()> {
        use anyhow::{anyhow, bail};
        use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};
        let identity = Extrinsics::identity();
        for (field, d) in [("camera", &self.camera), ("projector", &self.projector)] {
            if d.width == 0 || d.height == 0 {
                bail!("{field}: size {}x{} has no pixels", d.width, d.height);
            }
            if !(d.fx > 0.0 && d.fy > 0.0 && d.fx.is_finite() && d.fy.is_finite()) {
                bail!("{field}: fx, fy must be positive focal lengths in pixels, got {}, {}", d.fx, d.fy);
            }
            let dist = Distortion::from_opencv(&d.distortion).map_err(|e| anyhow!("{field}.distortion: {e}"))?;
            let cam = OpenCv::with_size(Intrinsics { fx: d.fx, fy: d.fy, cx: d.cx, cy: d.cy }, dist, identity, d.width, d.height).map_err(|e| anyhow!("{field}: {e}"))?;
            if let Err(e) = cam.check_invertible(d.width, d.height) {
                let share = ray_share(&cam, d.width, d.height);
                if share < 0.5 {
                    bail!("{field}: {e:#}; only {:.0} % of its pixels have a ray", 100.0 * share);
                }
            }
        }
        Extrinsics::from_rt(self.rotation, self.translation).map_err(|e| anyhow!("rotation: {e}"))?;
        let t = self.translation;
        let norm = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
        if !norm.is_finite() {
            bail!("translation {t:?}: its length is not a finite number");
        }
        if norm == 0.0 {
            bail!("translation is zero: the two devices share a centre, which leaves nothing to triangulate or rectify");
        }
        Ok(())
    }
}

/// The share of a 33 × 33 grid of pixel positions over the image (its edges included) whose
/// undistortion converges on the lens's unfolded branch (`OpenCv::undistort`).
fn ray_share(cam: &render::camera::OpenCv, width: u32, height: u32) -> f64 {
    let k = cam.intrinsics;
    let n = 32;
    let mut ok = 0;
    for a in 0..=n {
        for b in 0..=n {
            let u = -0.5 + width as f64 * a as f64 / n as f64;
            let v = -0.5 + height as f64 * b as f64 / n as f64;
            ok += cam.undistort((u - k.cx) / k.fx, (v - k.cy) / k.fy).2 as usize;
        }
    }
    ok as f64 / ((n + 1) * (n + 1)) as f64
}

impl ProcamCalibration {
    /// One line per device whose distortion does not map a ray to every pixel of its image
    /// (`render::camera::OpenCv::check_invertible`): pixels beyond the fold have no ray, and
    /// triangulation, rectification and labelling skip them. Empty for a usable calibration.
    pub fn lens_warnings(&self) -> Vec<String> {
        use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};
        let mut out = Vec::new();
        for (field, d) in [("camera", &self.camera), ("projector", &self.projector)] {
            let Ok(dist) = Distortion::from_opencv(&d.distortion) else { continue };
            let Ok(cam) = OpenCv::with_size(Intrinsics { fx: d.fx, fy: d.fy, cx: d.cx, cy: d.cy }, dist, Extrinsics::identity(), d.width, d.height) else { continue };
            if let Err(e) = cam.check_invertible(d.width, d.height) {
                out.push(format!("{field}: {e:#}; the pixels beyond it have no ray and are skipped (the views the lens was fitted to do not reach there)"));
            }
        }
        out
    }

    /// This calibration as OpenCV FileStorage (XML, or YAML when `yaml`), with procam-calibration's
    /// node names so that tools written for its `calibration_result.xml` read it: `img_shape`,
    /// `rms`, `cam_int`, `cam_dist`, `proj_int`, `proj_dist`, `roration` (its spelling),
    /// `translation`; and `proj_shape` ([rows, cols] of the projector), which that file lacks.
    /// Numbers are written with 17 significant digits, so [`ProcamCalibration::read`] gives back
    /// the same values.
    pub fn to_filestorage(&self, yaml: bool) -> String {
        let k = |d: &DeviceCalibration| vec![d.fx, 0.0, d.cx, 0.0, d.fy, d.cy, 0.0, 0.0, 1.0];
        let rot: Vec<f64> = self.rotation.iter().flatten().copied().collect();
        let shape = |d: &DeviceCalibration| vec![d.height as f64, d.width as f64];
        let nodes: [(&str, usize, usize, Vec<f64>); 8] = [
            ("img_shape", 2, 1, shape(&self.camera)),
            ("proj_shape", 2, 1, shape(&self.projector)),
            ("cam_int", 3, 3, k(&self.camera)),
            ("cam_dist", 1, self.camera.distortion.len(), self.camera.distortion.clone()),
            ("proj_int", 3, 3, k(&self.projector)),
            ("proj_dist", 1, self.projector.distortion.len(), self.projector.distortion.clone()),
            ("roration", 3, 3, rot),
            ("translation", 3, 1, self.translation.to_vec()),
        ];
        filestorage(yaml, &[("rms", self.rms_px)], &nodes)
    }
}

/// OpenCV FileStorage text (YAML `%YAML:1.0` or XML) holding `scalars` and `opencv-matrix`
/// nodes (name, rows, cols, row-major data), each number with 17 significant digits.
pub(crate) fn filestorage(yaml: bool, scalars: &[(&str, f64)], nodes: &[(&str, usize, usize, Vec<f64>)]) -> String {
    let num = |x: &f64| format!("{x:.16e}");
    let mut out = String::new();
    if yaml {
        out.push_str("%YAML:1.0\n---\n");
        for (n, v) in scalars {
            out.push_str(&format!("{n}: {}\n", num(v)));
        }
        for (n, r, c, d) in nodes {
            let data: Vec<String> = d.iter().map(num).collect();
            out.push_str(&format!("{n}: !!opencv-matrix\n   rows: {r}\n   cols: {c}\n   dt: d\n   data: [ {} ]\n", data.join(", ")));
        }
    } else {
        out.push_str("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
        for (n, v) in scalars {
            out.push_str(&format!("<{n}>{}</{n}>\n", num(v)));
        }
        for (n, r, c, d) in nodes {
            let data: Vec<String> = d.iter().map(num).collect();
            out.push_str(&format!("<{n} type_id=\"opencv-matrix\">\n  <rows>{r}</rows>\n  <cols>{c}</cols>\n  <dt>d</dt>\n  <data>\n    {}</data></{n}>\n", data.join(" ")));
        }
        out.push_str("</opencv_storage>\n");
    }
    out
}

/// One capture's corners: in the camera image and in the projector image (pixels, OpenCV
/// convention), both in the board's row-major order; a corner without a projector position
/// (see [`procam::projector_corners`]) is NaN in `proj`.
#[derive(Clone, Debug)]
pub struct CaptureCorners {
    /// The capture's name (its folder).
    pub name: String,
    /// Camera corners.
    pub cam: Vec<homography::Point2>,
    /// Projector corners.
    pub proj: Vec<homography::Point2>,
}

/// Sizes of the board and the devices.
#[derive(Clone, Copy, Debug)]
pub struct Rig {
    /// Inner corners per board row.
    pub cols: usize,
    /// Inner corner rows.
    pub rows: usize,
    /// Square size (the unit of all lengths in the result).
    pub square: f64,
    /// Camera image size (pixels).
    pub camera: (u32, u32),
    /// Projector image size (pixels).
    pub projector: (u32, u32),
}

/// A reprojection RMS above which the fit counts as not converged (pixels).
pub const MAX_RMS_PX: f64 = 10.0;

/// Calibrate camera, projector and their relative pose from the corners of ≥ 3 captures:
/// Zhang's closed form per device (from normalised-DLT homographies), the board poses from
/// the homographies, Levenberg–Marquardt per device, the stereo pose as the rotation average
/// (nearest rotation to ΣR_p,iR_c,iᵀ) and mean translation over the captures, then one joint
/// Levenberg–Marquardt over all reprojection errors of both devices.
pub fn calibrate_corners(rig: &Rig, captures: &[CaptureCorners]) -> anyhow::Result<ProcamCalibration> {
    calibrate_corners_from(rig, captures, None)
}

/// [`calibrate_corners`], or, with `init`, only the joint Levenberg–Marquardt started from `init`'s
/// lenses and stereo pose (board poses from the homographies); this works from 2 captures and is
/// how the leave-one-out spread of the intrinsics is measured.
pub fn calibrate_corners_from(rig: &Rig, captures: &[CaptureCorners], init: Option<&ProcamCalibration>) -> anyhow::Result<ProcamCalibration> {
    calibrate_corners_with(rig, captures, init, bundle::Free::default())
}

/// [`calibrate_corners_from`] with a choice of the distortion terms both devices fit: `free.k3`
/// false holds k3 at 0 (OpenCV's `CALIB_FIX_K3`), `free.tangential` false holds p1 = p2 = 0
/// (`CALIB_ZERO_TANGENT_DIST`), `free.rational` fits k4…k6 (`CALIB_RATIONAL_MODEL`) and
/// `free.thin_prism` s1…s4 (`CALIB_THIN_PRISM_MODEL`) and `free.tilted` τx, τy
/// (`CALIB_TILTED_MODEL`).
pub fn calibrate_corners_with(rig: &Rig, captures: &[CaptureCorners], init: Option<&ProcamCalibration>, free: bundle::Free) -> anyhow::Result<ProcamCalibration> {
    calibrate_planar(rig, &zhang::board_points(rig.cols, rig.rows, rig.square), captures, init, free, ["camera", "projector"])
}

/// [`calibrate_corners_with`] for any planar target seen by two devices: `obj` are its points
/// (z = 0, in the unit of the result), each capture's `cam` and `proj` their pixels in the two
/// devices in the same order (NaN where not seen). Two cameras calibrate this way as OpenCV's
/// `stereoCalibrate` does, the second in the place of the projector (`rig.projector` its size).
/// `devices` names the two in errors.
pub fn calibrate_planar(rig: &Rig, obj: &[homography::Point2], captures: &[CaptureCorners], init: Option<&ProcamCalibration>, free: bundle::Free, devices: [&str; 2]) -> anyhow::Result<ProcamCalibration> {
    use anyhow::{bail, Context};
    use bundle::{refine, State, ViewObs};
    // The rational model's denominator trades against the numerator over a board's field, so
    // its fit starts from the five-coefficient solution rather than from Zhang's closed form.
    if free.rational && init.is_none() {
        let five = calibrate_planar(rig, obj, captures, None, bundle::Free { rational: false, ..free }, devices)?;
        // The normalised radius of each device's image corners, for the fit's barrier.
        let corner_radius = |d: &DeviceCalibration| {
            let (w, h) = (d.width as f64 - 0.5, d.height as f64 - 0.5);
            [(-0.5, -0.5), (w, -0.5), (-0.5, h), (w, h)].iter().map(|&(u, v)| ((u - d.cx) / d.fx).hypot((v - d.cy) / d.fy)).fold(0.0f64, f64::max)
        };
        let free = bundle::Free { rational_radius: [corner_radius(&five.camera), corner_radius(&five.projector)], ..free };
        return calibrate_planar(rig, obj, captures, Some(&five), free, devices);
    }
    let n = obj.len();
    if captures.len() < if init.is_some() { 2 } else { 3 } {
        bail!("degenerate pose set: calibration needs at least 3 captures, got {}", captures.len());
    }
    for c in captures {
        if c.cam.len() != n || c.proj.len() != n {
            bail!("capture {}: {} {} and {} {} points, expected {n}", c.name, c.cam.len(), devices[0], c.proj.len(), devices[1]);
        }
    }
    let mono = |pts: &dyn Fn(&CaptureCorners) -> &Vec<homography::Point2>, size: (u32, u32), what: &str| -> anyhow::Result<State> {
        let mut hs = Vec::new();
        for c in captures {
            // The corners this device observed (a projector may miss some: NaN).
            let (o, q): (Vec<_>, Vec<_>) = obj.iter().zip(pts(c)).filter(|(_, q)| bundle::observed(**q)).map(|(o, q)| (*o, *q)).unzip();
            hs.push(homography::fit_homography(&o, &q).with_context(|| format!("{what}, capture {}: the corners do not determine a homography", c.name))?);
        }
        let free = free.for_device(usize::from(what == devices[1]));
        let lens = zhang::start(&hs, size.0, size.1, &free).with_context(|| what.to_string())?;
        let mut poses = Vec::new();
        for (h, c) in hs.iter().zip(captures) {
            poses.push(zhang::pose_from_homography(h, &lens.k()).with_context(|| format!("{what}, capture {}: no board pose", c.name))?);
        }
        let views: Vec<ViewObs> = captures.iter().map(|c| ViewObs { cam: pts(c).clone(), proj: vec![] }).collect();
        let init = State { cam: lens, proj: None, stereo: model::Pose::identity(), poses };
        refine(obj, &views, &init, free, MAX_RMS_PX).with_context(|| what.to_string())
    };
    let views: Vec<ViewObs> = captures.iter().map(|c| ViewObs { cam: c.cam.clone(), proj: c.proj.clone() }).collect();
    let mut outliers = Vec::new();
    let start = match init {
        Some(c) => {
            // Terms the model leaves out start (and stay) at 0.
            let lens = |d: &DeviceCalibration, i: usize| free.without_unmodelled(model::Lens::from_opencv(d.fx, d.fy, d.cx, d.cy, &d.distortion), i);
            let cam = lens(&c.camera, 0);
            let mut poses = Vec::new();
            for cap in captures {
                let h = homography::fit_homography(obj, &cap.cam).with_context(|| format!("{}, capture {}: the corners do not determine a homography", devices[0], cap.name))?;
                poses.push(zhang::pose_from_homography(&h, &cam.k()).with_context(|| format!("capture {}: no board pose", cap.name))?);
            }
            let r = nalgebra::Matrix3::from_fn(|i, j| c.rotation[i][j]);
            State { cam, proj: Some(lens(&c.projector, 1)), stereo: model::Pose::from_rt(&r, nalgebra::Vector3::from(c.translation)), poses }
        }
        None => {
            let (state, out) = stereo_start(captures, rig, &mono, devices)?;
            outliers = out;
            state
        }
    };
    let mut start = start;
    if let (true, true, Some(p)) = (free.same_focal, free.lenses, start.proj.as_mut()) {
        // One focal length starts, as in OpenCV's stereoCalibrate, from the mean of the two
        // devices' (and so do the principal points, which stay free).
        let c = &mut start.cam;
        for (a, b) in [(&mut c.fx, &mut p.fx), (&mut c.fy, &mut p.fy), (&mut c.cx, &mut p.cx), (&mut c.cy, &mut p.cy)] {
            (*a, *b) = ((*a + *b) / 2.0, (*a + *b) / 2.0);
        }
    }
    let fit = match refine(obj, &views, &start, free, MAX_RMS_PX) {
        Ok(fit) => fit,
        Err(e) if !outliers.is_empty() => bail!("stereo: {e:#}; {}", disagreement_clause(&|i| captures[i].name.clone(), &outliers, devices)),
        Err(e) => return Err(e).context("stereo"),
    };
    let c = finish(rig, captures, obj, &views, &fit, coefficient_count(free))?;
    // A capture whose relative pose disagrees and that the joint fit leaves above 1 px: the two
    // devices did not see the target in one pose (photographs paired out of order, a board moved
    // during a capture). The joint fit spreads such a capture's error over all the others, so
    // its own RMS need not stand out; the separate fits' relative poses do (a rigid pair's agree
    // to about a degree: 0.7–0.8° on the shared projector–camera captures).
    let bad: Vec<(usize, f64)> = outliers.iter().copied().filter(|&(i, _)| c.captures[i].rms_px > 1.0).collect();
    if !bad.is_empty() {
        let worst = c.captures.iter().map(|p| p.rms_px).fold(0.0, f64::max);
        bail!("stereo: reprojection RMS {:.3} px over all captures, {worst:.3} px at the worst; {}", c.rms_px, disagreement_clause(&|i| captures[i].name.clone(), &bad, devices));
    }
    // A rational denominator that reaches 0, or a tilt that turns part of the image beyond the
    // horizon, fits the corners but maps no ray there (render::camera::OpenCv's check, which
    // triangulation and rendering rely on).
    if free.rational || free.tilted {
        for (name, d) in [(devices[0], &c.camera), (devices[1], &c.projector)] {
            usable(d.fx, d.fy, d.cx, d.cy, &d.distortion, d.width, d.height, free).with_context(|| name.to_string())?;
        }
    }
    Ok(c)
}

/// Whether a fitted lens maps a ray to every pixel of its `width` × `height` image; the error
/// names the flags whose terms these views do not determine.
#[allow(clippy::too_many_arguments)]
pub(crate) fn usable(fx: f64, fy: f64, cx: f64, cy: f64, dist: &[f64], width: u32, height: u32, free: bundle::Free) -> anyhow::Result<()> {
    let what = match (free.rational, free.tilted) {
        (true, true) => "--rational (k4, k5, k6) and --tilted (τx, τy)",
        (true, false) => "--rational (k4, k5, k6)",
        _ => "--tilted (τx, τy)",
    };
    let check = || -> anyhow::Result<()> {
        let d = render::camera::Distortion::from_opencv(dist)?;
        let id = render::camera::Extrinsics::identity();
        render::camera::OpenCv::new(render::camera::Intrinsics { fx, fy, cx, cy }, d, id, width, height)?;
        Ok(())
    };
    check().map_err(|e| anyhow::anyhow!("the fitted model is not usable ({e}); these views do not determine {what}: calibrate without it"))
}

type MonoFit<'a> = dyn Fn(&dyn Fn(&CaptureCorners) -> &Vec<homography::Point2>, (u32, u32), &str) -> anyhow::Result<bundle::State> + 'a;

/// Per-device fits and the stereo pose averaged over the captures, with the captures whose
/// relative pose disagrees with the others' ([`pose_outliers`]).
fn stereo_start(captures: &[CaptureCorners], rig: &Rig, mono: &MonoFit, devices: [&str; 2]) -> anyhow::Result<(bundle::State, Vec<(usize, f64)>)> {
    let cam = mono(&|c| &c.cam, rig.camera, devices[0])?;
    let proj = mono(&|c| &c.proj, rig.projector, devices[1])?;
    let mut rsum = nalgebra::Matrix3::zeros();
    let mut tsum = nalgebra::Vector3::zeros();
    let mut rel = Vec::new();
    for (pc, pp) in cam.poses.iter().zip(&proj.poses) {
        let r = pp.r() * pc.r().transpose();
        rsum += r;
        tsum += pp.t - r * pc.t;
        rel.push(r);
    }
    let r = model::nearest_rotation(&rsum);
    let t = tsum / captures.len() as f64;
    let stereo = model::Pose::from_rt(&r, t);
    Ok((bundle::State { cam: cam.cam, proj: Some(proj.cam), stereo, poses: cam.poses.clone() }, pose_outliers(&rel)))
}

/// Above this angle (degrees) a capture's relative rotation of the two devices, from their
/// separate fits, counts as disagreeing with the others'.
const PAIR_DISAGREEMENT_DEG: f64 = 3.0;

/// The captures whose relative rotation R_p,i R_c,iᵀ (from the two devices' separate fits) lies
/// more than [`PAIR_DISAGREEMENT_DEG`] from the lower median of its angles to the other captures'
/// relative rotations, with that median (degrees). A rigid pair gives every capture the same
/// relative pose up to the fits' noise (tenths of a degree); photographs paired out of order give
/// the paired captures the rotation between their two board poses.
pub(crate) fn pose_outliers(rel: &[nalgebra::Matrix3<f64>]) -> Vec<(usize, f64)> {
    let angle = |a: &nalgebra::Matrix3<f64>, b: &nalgebra::Matrix3<f64>| (((a * b.transpose()).trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees();
    let mut out = Vec::new();
    for (i, a) in rel.iter().enumerate() {
        let mut d: Vec<f64> = rel.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, b)| angle(a, b)).collect();
        d.sort_by(f64::total_cmp);
        // The lower median: a capture agreeing with half of the others is not an outlier.
        if let Some(&m) = d.get(d.len().saturating_sub(1) / 2) {
            if m > PAIR_DISAGREEMENT_DEG {
                out.push((i, m));
            }
        }
    }
    out
}

/// One clause naming the captures of [`pose_outliers`] (`name` of a capture's index), for an error.
pub(crate) fn disagreement_clause(name: &dyn Fn(usize) -> String, outliers: &[(usize, f64)], devices: [&str; 2]) -> String {
    let names: Vec<String> = outliers.iter().map(|&(i, deg)| format!("{} ({deg:.1}°)", name(i))).collect();
    format!(
        "the {} and {} of {} are turned against each other differently than in the other captures: {}; were they taken at the same moment?",
        devices[0],
        devices[1],
        if outliers.len() == 1 { "this capture" } else { "these captures" },
        names.join(", ")
    )
}

/// How many of OpenCV's distortion coefficients a fit with `free` writes, as OpenCV does: 14 with
/// the tilted model, 12 with the thin prism model, 8 with the rational model, else 5 (terms in
/// between that were not fitted are 0).
pub fn coefficient_count(free: bundle::Free) -> usize {
    if free.tilted {
        14
    } else if free.thin_prism {
        12
    } else if free.rational {
        8
    } else {
        5
    }
}

/// The result of a fit, its distortion as OpenCV's first `coefficients` ([`coefficient_count`]).
fn finish(rig: &Rig, captures: &[CaptureCorners], obj: &[homography::Point2], views: &[bundle::ViewObs], fit: &bundle::State, coefficients: usize) -> anyhow::Result<ProcamCalibration> {
    let e = bundle::rms(obj, views, fit);
    let device = |l: &model::Lens, size: (u32, u32), rms_px: f64| DeviceCalibration {
        width: size.0,
        height: size.1,
        fx: l.fx,
        fy: l.fy,
        cx: l.cx,
        cy: l.cy,
        distortion: l.dist.iter().chain(&l.rational).chain(&l.prism).chain(&l.tilt).copied().take(coefficients).collect(),
        rms_px,
    };
    let rm = fit.stereo.r();
    Ok(ProcamCalibration {
        camera: device(&fit.cam, rig.camera, e.cam),
        projector: device(fit.proj.as_ref().unwrap(), rig.projector, e.proj),
        rotation: [[rm[(0, 0)], rm[(0, 1)], rm[(0, 2)]], [rm[(1, 0)], rm[(1, 1)], rm[(1, 2)]], [rm[(2, 0)], rm[(2, 1)], rm[(2, 2)]]],
        translation: [fit.stereo.t[0], fit.stereo.t[1], fit.stereo.t[2]],
        rms_px: e.all,
        captures: captures
            .iter()
            .zip(fit.poses.iter().zip(&e.per_view))
            .map(|(c, (p, &r))| CapturePose {
                name: c.name.clone(),
                rvec: [p.rvec[0], p.rvec[1], p.rvec[2]],
                tvec: [p.t[0], p.t[1], p.t[2]],
                rms_px: r,
                projector_corners: c.proj.iter().filter(|q| bundle::observed(**q)).count(),
            })
            .collect(),
    })
}

/// Options of [`calibrate_dirs`].
#[derive(Clone, Copy, Debug)]
pub struct CalibrateOptions {
    /// Decoding thresholds.
    pub decode: crate::decode::DecodeSettings,
    /// Local homography window.
    pub local: procam::LocalHomography,
    /// Projector pixels per Gray code, as the patterns were made.
    pub step: u32,
    /// Which distortion terms the fit moves (default: k1, k2, p1, p2, k3, as OpenCV's default).
    pub free: bundle::Free,
}

impl Default for CalibrateOptions {
    fn default() -> Self {
        CalibrateOptions { decode: Default::default(), local: Default::default(), step: 1, free: Default::default() }
    }
}

/// The corners of one capture folder: decode it, find the board in its white frame, and take each
/// corner's projector position from a local homography. `progress` is called once per frame read.
pub fn capture_corners(dir: &std::path::Path, rig: &Rig, opts: &CalibrateOptions, progress: &(dyn Fn() + Sync)) -> anyhow::Result<CaptureCorners> {
    capture_corners_sized(dir, rig, opts, progress).map(|c| c.0)
}

fn capture_corners_sized(dir: &std::path::Path, rig: &Rig, opts: &CalibrateOptions, progress: &(dyn Fn() + Sync)) -> anyhow::Result<(CaptureCorners, (u32, u32))> {
    use anyhow::bail;
    let name = dir.display().to_string();
    let patterns = crate::graycode::PatternSet::new(rig.projector.0, rig.projector.1, opts.step)?;
    let capture = crate::decode::read_capture(dir, &patterns, progress)?;
    // A capture whose frames seem to be in the other order: a failure below says so.
    let order = capture.order_warning(opts.decode.white_black_first);
    let (map, _) = crate::decode::decode(&capture, &patterns, &opts.decode)?;
    drop(capture);
    if (map.width as u32, map.height as u32) != rig.camera && rig.camera != (0, 0) {
        bail!("{name}: camera images are {}x{}, the other captures {}x{}", map.width, map.height, rig.camera.0, rig.camera.1);
    }
    let corners = || -> anyhow::Result<_> {
        let img = chessboard::GrayImage { width: map.width, height: map.height, data: map.white.clone() };
        let cam = chessboard::find_chessboard_named(&img, rig.cols, rig.rows, &name)?;
        let proj = procam::projector_corners(&map, &cam, &opts.local, &name)?;
        Ok((cam, proj))
    };
    let (cam, proj) = match (corners(), order) {
        (Ok(c), _) => c,
        (Err(e), Some(w)) => return Err(e.context(format!("{name}: {w}"))),
        (Err(e), None) => return Err(e),
    };
    Ok((CaptureCorners { name, cam, proj }, (map.width as u32, map.height as u32)))
}

/// Calibrate from capture folders (each as [`capture_corners`]); the camera size is taken from the
/// first capture. `progress` is called once per frame read.
pub fn calibrate_dirs(dirs: &[std::path::PathBuf], rig: &Rig, opts: &CalibrateOptions, progress: &(dyn Fn() + Sync)) -> anyhow::Result<(ProcamCalibration, Vec<CaptureCorners>)> {
    let mut rig = *rig;
    let mut caps = Vec::new();
    for d in dirs {
        let (c, size) = capture_corners_sized(d, &rig, opts, progress)?;
        rig.camera = size;
        caps.push(c);
    }
    Ok((calibrate_corners_with(&rig, &caps, None, opts.free)?, caps))
}
