//! Chessboard corners, circle grids and camera calibration from Python, as OpenCV's
//! `findChessboardCorners` (+ `cornerSubPix`), `findCirclesGrid` and `calibrateCamera` (the `scan`
//! crate's corner and disc finders, Zhang's closed form and Levenberg–Marquardt; docs/scanning.md).

use crate::errors::{value, OrPy};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use scan::calib::bundle::Free;
use scan::calib::camera::calibrate_camera_guided;
use scan::calib::chessboard::{find_chessboard, GrayImage};

/// The `cols` × `rows` inner corners (flat u, v, row-major from the corner nearest the image's
/// top-left) of a chessboard in a grey image of `width` × `height` levels (row-major), refined
/// to sub-pixel; None when no such lattice is found.
#[pyfunction]
pub fn find_chessboard_flat(py: Python<'_>, grey: PyReadonlyArray1<'_, f32>, width: usize, height: usize, cols: usize, rows: usize) -> PyResult<Option<Vec<f64>>> {
    let grey = grey.as_slice()?.to_vec();
    if grey.len() != width * height || width < 8 || height < 8 {
        return Err(value(format!("image: expected {width}×{height} grey levels (at least 8×8), got {}", grey.len())));
    }
    if cols < 3 || rows < 3 {
        return Err(value(format!("pattern_size: the board needs at least 3×3 inner corners, got {cols}×{rows}")));
    }
    let img = GrayImage { width, height, data: grey };
    Ok(py.allow_threads(|| find_chessboard(&img, cols, rows)).map(|c| c.into_iter().flatten().collect()))
}

/// The discs of a `cols` × `rows` circle grid (flat u, v in the order of OpenCV's object points,
/// `scan::markers::grid`) in a grey image of `width` × `height` 8-bit codes (row-major, taken as
/// they are); None when no such grid is found.
#[pyfunction]
pub fn find_circles_grid_flat(py: Python<'_>, grey: PyReadonlyArray1<'_, f32>, width: usize, height: usize, cols: usize, rows: usize, asymmetric: bool) -> PyResult<Option<Vec<f64>>> {
    use scan::markers::grid::{find_circles_grid, GridKind};
    let grey = grey.as_slice()?;
    if grey.len() != width * height || width < 8 || height < 8 {
        return Err(value(format!("image: expected {width}×{height} grey levels (at least 8×8), got {}", grey.len())));
    }
    if cols * rows < 4 {
        return Err(value(format!("pattern_size: the grid needs at least 4 discs, got {cols}×{rows}")));
    }
    // The codes as they are, as `scan calibrate-camera --pattern` reads photographs.
    let img = scan::markers::Image::new(width, height, grey.iter().map(|v| v / 255.0).collect()).or_py()?;
    let kind = if asymmetric { GridKind::Asymmetric } else { GridKind::Symmetric };
    Ok(py.allow_threads(|| find_circles_grid(&img, kind, cols, rows)).map(|c| c.into_iter().flatten().collect()))
}

/// Calibrate a camera from one planar target (flat x, y of its points, z = 0) seen in several
/// views (flat u, v per view, NaN for a point not seen): (RMS in pixels, [fx, fy, cx, cy],
/// distortion coefficients, per-view Rodrigues vectors, per-view translations). `held` is
/// [`Free::held`], `aspect_ratio` the held fx/fy, `guess` the start (row-major 3×3 matrix and
/// OpenCV distortion coefficients; OpenCV's `CALIB_USE_INTRINSIC_GUESS`).
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn calibrate_camera_flat(
    object_xy: Vec<f64>,
    image_points: Vec<Vec<f64>>,
    width: u32,
    height: u32,
    flags: (bool, bool, bool, bool, bool),
    held: u32,
    aspect_ratio: Option<f64>,
    guess: Option<Guess>,
) -> PyResult<(f64, [f64; 4], Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>)> {
    if object_xy.iter().any(|x| !x.is_finite()) {
        return Err(value("object_points: must be finite"));
    }
    let obj: Vec<[f64; 2]> = object_xy.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let views: Vec<(String, Vec<[f64; 2]>)> =
        image_points.iter().enumerate().map(|(i, v)| (format!("image_points[{i}]"), v.chunks_exact(2).map(|p| [p[0], p[1]]).collect())).collect();
    let (fix_k3, zero_tangent, rational, thin_prism, tilted) = flags;
    let free = Free { lenses: true, k3: !fix_k3, tangential: !zero_tangent, rational, thin_prism, tilted, held, aspect_ratio: [aspect_ratio, None], ..Default::default() };
    let start = guess.as_ref().map(|(k, d)| lens_of(k, d, "camera_matrix", "dist_coeffs")).transpose()?;
    let c = calibrate_camera_guided(&obj, &views, width, height, free, start.as_ref()).or_py()?;
    Ok((c.rms_px, [c.fx, c.fy, c.cx, c.cy], c.dist, c.views.iter().map(|v| v.rvec).collect(), c.views.iter().map(|v| v.tvec).collect()))
}

/// A lens from a row-major 3×3 camera matrix and OpenCV distortion coefficients.
fn lens_of(k: &[f64], d: &[f64], k_name: &str, d_name: &str) -> PyResult<scan::calib::model::Lens> {
    let (intr, _) = intrinsics_and_distortion(k, d, k_name, d_name)?;
    Ok(scan::calib::model::Lens::from_opencv(intr.fx, intr.fy, intr.cx, intr.cy, d))
}

/// One camera's start or held values for [`stereo_calibrate_flat`]: row-major 3×3 matrix and
/// OpenCV distortion coefficients.
type Guess = (Vec<f64>, Vec<f64>);

/// Two cameras from one planar target seen by both in each view (OpenCV's `stereoCalibrate`):
/// (RMS over both cameras in pixels, [fx, fy, cx, cy] and distortion of each camera, the
/// row-major rotation and the translation with X₂ = R X₁ + T). Without `guess` each camera starts
/// from its own calibration; with it (`use_guess`) the fit starts there, or (`fix_intrinsic`)
/// holds the cameras there and fits only the poses. `extrinsic` (OpenCV's
/// `CALIB_USE_EXTRINSIC_GUESS`: row-major R and T) starts the last fit's relative pose there.
#[pyfunction]
#[pyo3(signature = (object_xy, points1, points2, width, height, guess, fix_intrinsic, flags, held, aspect_ratio, same_focal, extrinsic=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn stereo_calibrate_flat(
    py: Python<'_>,
    object_xy: Vec<f64>,
    points1: Vec<Vec<f64>>,
    points2: Vec<Vec<f64>>,
    width: u32,
    height: u32,
    guess: Option<(Guess, Guess)>,
    fix_intrinsic: bool,
    flags: (bool, bool, bool, bool, bool),
    held: u32,
    aspect_ratio: (Option<f64>, Option<f64>),
    same_focal: bool,
    extrinsic: Option<([[f64; 3]; 3], [f64; 3])>,
) -> PyResult<(f64, [f64; 4], Vec<f64>, [f64; 4], Vec<f64>, [[f64; 3]; 3], [f64; 3])> {
    use scan::calib::{calibrate_planar, CaptureCorners, DeviceCalibration, Rig};
    if object_xy.iter().any(|x| !x.is_finite()) {
        return Err(value("object_points: must be finite"));
    }
    if let Some((r, t)) = &extrinsic {
        let m = nalgebra::Matrix3::from_fn(|i, j| r[i][j]);
        let orthonormal = (m.transpose() * m - nalgebra::Matrix3::identity()).abs().max() < 1e-6 && m.determinant() > 0.0;
        if !(orthonormal && r.iter().flatten().chain(t).all(|v| v.is_finite())) {
            return Err(value("R, T: CALIB_USE_EXTRINSIC_GUESS needs a rotation matrix R and a finite T"));
        }
    }
    if points1.len() != points2.len() {
        return Err(value(format!("image_points1 and image_points2: {} and {} views", points1.len(), points2.len())));
    }
    let obj: Vec<[f64; 2]> = object_xy.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let pts = |v: &[f64]| v.chunks_exact(2).map(|p| [p[0], p[1]]).collect::<Vec<_>>();
    let captures: Vec<CaptureCorners> = points1.iter().zip(&points2).enumerate().map(|(i, (a, b))| CaptureCorners { name: format!("view {i}"), cam: pts(a), proj: pts(b) }).collect();
    let (fix_k3, zero_tangent, rational, thin_prism, tilted) = flags;
    let free = Free { lenses: !fix_intrinsic, k3: !fix_k3, tangential: !zero_tangent, rational, thin_prism, tilted, held, aspect_ratio: [aspect_ratio.0, aspect_ratio.1], same_focal, ..Default::default() };
    let rig = Rig { cols: obj.len(), rows: 1, square: 1.0, camera: (width, height), projector: (width, height) };
    let devices = ["image_points1", "image_points2"];
    let c = py
        .allow_threads(|| -> anyhow::Result<scan::calib::ProcamCalibration> {
            // The stereo pose always starts from a joint fit from each camera's own calibration;
            // a guess then replaces the cameras, an extrinsic guess the relative pose, for the
            // last fit.
            let joint = calibrate_planar(&rig, &obj, &captures, None, Free { lenses: true, ..free }, devices)?;
            if guess.is_none() && extrinsic.is_none() {
                return Ok(joint);
            }
            let device = |k: &[f64], d: &[f64], like: &DeviceCalibration| DeviceCalibration { fx: k[0], fy: k[4], cx: k[2], cy: k[5], distortion: d.to_vec(), ..like.clone() };
            let mut init = joint.clone();
            if let Some(((k1, d1), (k2, d2))) = &guess {
                init.camera = device(k1, d1, &joint.camera);
                init.projector = device(k2, d2, &joint.projector);
            }
            if let Some((r, t)) = extrinsic {
                init.rotation = r;
                init.translation = t;
            }
            calibrate_planar(&rig, &obj, &captures, Some(&init), free, devices)
        })
        .or_py()?;
    let dev = |d: &DeviceCalibration| [d.fx, d.fy, d.cx, d.cy];
    Ok((c.rms_px, dev(&c.camera), c.camera.distortion.clone(), dev(&c.projector), c.projector.distortion.clone(), c.rotation, c.translation))
}

/// An 8-bit image (`width` × `height` × `channels`, row-major, interleaved) with its lens
/// distortion removed (OpenCV's `undistort`, `scan::calib::undistort`): the camera is the row-major
/// 3×3 `k` with OpenCV's distortion `dist`, the output the pinhole camera `k_new` (or `k`).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn undistort_flat(py: Python<'_>, image: &[u8], width: usize, height: usize, channels: usize, k: Vec<f64>, dist: Vec<f64>, k_new: Option<Vec<f64>>) -> PyResult<Py<pyo3::types::PyBytes>> {
    use render::camera::{Distortion, Intrinsics};
    use scan::calib::undistort::{remap_bilinear, undistort_map};
    if image.len() != width * height * channels || channels == 0 {
        return Err(value(format!("src: expected {width}×{height}×{channels} values, got {}", image.len())));
    }
    let intr = |m: &[f64], name: &str| Intrinsics::from_camera_matrix(m).map_err(|e| value(format!("{name}: {e}")));
    let kk = intr(&k, "camera_matrix")?;
    let out = match &k_new {
        Some(m) => intr(m, "new_camera_matrix")?,
        None => kk,
    };
    let d = Distortion::from_opencv(&dist).map_err(|e| value(format!("dist_coeffs: {e}")))?;
    let pixels = py.allow_threads(|| remap_bilinear(image, channels, width, height, &undistort_map(&kk, &d, &out, width, height)));
    Ok(pyo3::types::PyBytes::new(py, &pixels).unbind())
}

/// The pose of object points (flat x, y, z) seen at pixels (flat u, v) by the camera `k`
/// (row-major 3×3) with OpenCV's distortion `dist` (OpenCV's `solvePnP`, `scan::calib::pnp`),
/// refined from `guess` (Rodrigues vector, translation) when given: (Rodrigues vector,
/// translation, RMS reprojection error in pixels).
#[pyfunction]
#[pyo3(signature = (object, pixels, k, dist, guess=None))]
pub fn solve_pnp_flat(object: Vec<f64>, pixels: Vec<f64>, k: Vec<f64>, dist: Vec<f64>, guess: Option<([f64; 3], [f64; 3])>) -> PyResult<([f64; 3], [f64; 3], f64)> {
    let lens = lens_of(&k, &dist, "camera_matrix", "dist_coeffs")?;
    let obj: Vec<[f64; 3]> = object.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let px: Vec<[f64; 2]> = pixels.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let guess = guess.map(|(r, t)| scan::calib::model::Pose { rvec: r.into(), t: t.into() });
    let (pose, rms) = scan::calib::pnp::solve_pnp_from(&obj, &px, &lens, guess).map_err(|e| value(format!("{e:#}")))?;
    Ok(([pose.rvec[0], pose.rvec[1], pose.rvec[2]], [pose.t[0], pose.t[1], pose.t[2]], rms))
}

/// `cv2.solvePnPGeneric`: the poses of OpenCV's method `flag` (`scan::calib::pnp::Method`), best
/// first, each as (Rodrigues vector, translation, RMS reprojection error in pixels); `guess` is
/// used by `SOLVEPNP_ITERATIVE` only.
#[pyfunction]
#[pyo3(signature = (object, pixels, k, dist, flag, guess=None))]
#[allow(clippy::type_complexity)]
pub fn solve_pnp_generic_flat(object: Vec<f64>, pixels: Vec<f64>, k: Vec<f64>, dist: Vec<f64>, flag: i64, guess: Option<([f64; 3], [f64; 3])>) -> PyResult<Vec<([f64; 3], [f64; 3], f64)>> {
    let lens = lens_of(&k, &dist, "camera_matrix", "dist_coeffs")?;
    let method = scan::calib::pnp::Method::from_opencv(flag).ok_or_else(|| value(format!("flags: {flag} is none of OpenCV 5's SOLVEPNP_* methods (0-6)")))?;
    let obj: Vec<[f64; 3]> = object.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let px: Vec<[f64; 2]> = pixels.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let guess = guess.map(|(r, t)| scan::calib::model::Pose { rvec: r.into(), t: t.into() });
    let poses = scan::calib::pnp::solve_pnp_generic(&obj, &px, &lens, method, guess).map_err(|e| value(format!("{e:#}")))?;
    Ok(poses.into_iter().map(|(p, rms)| ([p.rvec[0], p.rvec[1], p.rvec[2]], [p.t[0], p.t[1], p.t[2]], rms)).collect())
}

/// `lucent scan calibrate` on capture folders: the calibration JSON it writes.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn calibrate_procam_json(
    py: Python<'_>,
    captures: Vec<std::path::PathBuf>,
    projector: (u32, u32),
    cols: usize,
    rows: usize,
    square: f64,
    flags: (bool, bool, bool, bool, bool),
    step: u32,
    thresholds: (i32, i32),
    white_black_first: bool,
) -> PyResult<String> {
    if !(square > 0.0 && square.is_finite()) {
        return Err(value(format!("square: must be a positive length, got {square}")));
    }
    if cols < 3 || rows < 3 {
        return Err(value(format!("pattern_size: the board needs at least 3×3 inner corners, got {cols}×{rows}")));
    }
    if projector.0 == 0 || projector.1 == 0 {
        return Err(value("projector_size: must be positive"));
    }
    let (fix_k3, zero_tangent, rational, thin_prism, tilted) = flags;
    let rig = scan::calib::Rig { cols, rows, square, camera: (0, 0), projector };
    let opts = scan::calib::CalibrateOptions {
        decode: scan::decode::DecodeSettings { black_threshold: thresholds.0, white_threshold: thresholds.1, refine: true, white_black_first },
        step,
        free: Free { lenses: true, k3: !fix_k3, tangential: !zero_tangent, rational, thin_prism, tilted, ..Default::default() },
        ..Default::default()
    };
    let (calib, _) = py.allow_threads(|| scan::calib::calibrate_dirs(&captures, &rig, &opts, &|| {})).or_py()?;
    serde_json::to_string(&calib).map_err(|e| value(e.to_string()))
}

/// A lens from a row-major 3×3 matrix and OpenCV coefficients, for the rectification functions.
fn intrinsics_and_distortion(k: &[f64], d: &[f64], k_name: &str, d_name: &str) -> PyResult<(render::camera::Intrinsics, render::camera::Distortion)> {
    let intr = render::camera::Intrinsics::from_camera_matrix(k).map_err(|e| value(format!("{k_name}: {e}")))?;
    let dist = render::camera::Distortion::from_opencv(d).map_err(|e| value(format!("{d_name}: {e}")))?;
    Ok((intr, dist))
}

/// OpenCV's `getOptimalNewCameraMatrix` (`scan::calib::rectify`): ([fx, fy, cx, cy], roi).
#[pyfunction]
pub fn optimal_new_camera_matrix_flat(k: Vec<f64>, d: Vec<f64>, size: (u32, u32), alpha: f64, new_size: (u32, u32)) -> PyResult<([f64; 4], [i32; 4])> {
    let (intr, dist) = intrinsics_and_distortion(&k, &d, "camera_matrix", "dist_coeffs")?;
    if !alpha.is_finite() {
        return Err(value(format!("alpha: must be finite, got {alpha}")));
    }
    let (m, roi) = scan::calib::rectify::optimal_new_camera_matrix(&intr, &dist, size, alpha, new_size).map_err(|e| value(format!("{e:#}")))?;
    Ok(([m.fx, m.fy, m.cx, m.cy], roi))
}

/// OpenCV's `stereoRectify` (`scan::calib::rectify`): (R1, R2 row-major 3×3, P1, P2 row-major
/// 3×4, Q row-major 4×4, roi1, roi2).
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn stereo_rectify_flat(
    k1: Vec<f64>,
    d1: Vec<f64>,
    k2: Vec<f64>,
    d2: Vec<f64>,
    size: (u32, u32),
    r: Vec<f64>,
    t: Vec<f64>,
    zero_disparity: bool,
    alpha: f64,
    new_size: (u32, u32),
) -> PyResult<(Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, [i32; 4], [i32; 4])> {
    let (a, da) = intrinsics_and_distortion(&k1, &d1, "camera_matrix1", "dist_coeffs1")?;
    let (b, db) = intrinsics_and_distortion(&k2, &d2, "camera_matrix2", "dist_coeffs2")?;
    if r.len() != 9 || t.len() != 3 || !r.iter().chain(&t).all(|v| v.is_finite()) {
        return Err(value("R, T: expected a finite 3×3 rotation and 3-vector"));
    }
    let rm = nalgebra::Matrix3::from_row_slice(&r);
    if (rm * rm.transpose() - nalgebra::Matrix3::identity()).norm() > 1e-6 || rm.determinant() < 0.0 {
        return Err(value("R: not a rotation matrix"));
    }
    let rect = scan::calib::rectify::stereo_rectify([&a, &b], [&da, &db], size, &rm, &nalgebra::Vector3::from_column_slice(&t), zero_disparity, alpha, new_size)
        .map_err(|e| value(format!("{e:#}")))?;
    let rows3 = |m: &nalgebra::Matrix3<f64>| m.transpose().iter().copied().collect::<Vec<_>>();
    let rows34 = |m: &nalgebra::Matrix3x4<f64>| m.transpose().iter().copied().collect::<Vec<_>>();
    Ok((rows3(&rect.r[0]), rows3(&rect.r[1]), rows34(&rect.p[0]), rows34(&rect.p[1]), rect.q.transpose().iter().copied().collect(), rect.roi[0], rect.roi[1]))
}

/// OpenCV's `initUndistortRectifyMap` with float maps: the source x and y of each output pixel
/// (row-major), as float32 bytes.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn undistort_rectify_map_flat(py: Python<'_>, k: Vec<f64>, d: Vec<f64>, r: Vec<f64>, p: Vec<f64>, width: usize, height: usize) -> PyResult<(Py<pyo3::types::PyBytes>, Py<pyo3::types::PyBytes>)> {
    let (intr, dist) = intrinsics_and_distortion(&k, &d, "camera_matrix", "dist_coeffs")?;
    if r.len() != 9 || p.len() != 9 || !r.iter().chain(&p).all(|v| v.is_finite()) {
        return Err(value("R, newCameraMatrix: expected finite 3×3 matrices"));
    }
    let map = py
        .allow_threads(|| scan::calib::rectify::undistort_rectify_map(&intr, &dist, &nalgebra::Matrix3::from_row_slice(&r), &nalgebra::Matrix3::from_row_slice(&p), width, height))
        .map_err(|e| value(format!("{e:#}")))?;
    let xs: Vec<u8> = map.iter().flat_map(|m| (m[0] as f32).to_ne_bytes()).collect();
    let ys: Vec<u8> = map.iter().flat_map(|m| (m[1] as f32).to_ne_bytes()).collect();
    Ok((pyo3::types::PyBytes::new(py, &xs).unbind(), pyo3::types::PyBytes::new(py, &ys).unbind()))
}

/// OpenCV's `triangulatePoints` (`scan::triangulate::triangulate_dlt`): for row-major 3×4
/// projection matrices and the points' pixels in the two views (flat u, v), each point's
/// homogeneous coordinates (flat x, y, z, w; unit length, w ≥ 0).
#[pyfunction]
pub fn triangulate_points_flat<'py>(py: Python<'py>, p1: Vec<f64>, p2: Vec<f64>, a: PyReadonlyArray1<'py, f64>, b: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (a, b) = (a.as_slice()?, b.as_slice()?);
    if p1.len() != 12 || p2.len() != 12 || !p1.iter().chain(&p2).all(|v| v.is_finite()) {
        return Err(value("projMatr1, projMatr2: expected finite 3×4 matrices"));
    }
    if a.len() != b.len() || a.len() % 2 != 0 {
        return Err(value(format!("projPoints1, projPoints2: {} and {} points", a.len() / 2, b.len() / 2)));
    }
    let (m1, m2) = (nalgebra::Matrix3x4::from_row_slice(&p1), nalgebra::Matrix3x4::from_row_slice(&p2));
    let xyzw: Vec<f64> = a.chunks_exact(2).zip(b.chunks_exact(2)).flat_map(|(x, y)| scan::triangulate::triangulate_dlt(&m1, &m2, [x[0], x[1]], [y[0], y[1]])).collect();
    Ok(xyzw.into_pyarray(py))
}

/// `cv2.solvePnPRansac` (`SOLVEPNP_ITERATIVE`): the Rodrigues vector, the translation, the inlier
/// indices and the RMS over them (pixels); None when no pose has a minimal set of inliers.
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn solve_pnp_ransac_flat(object: Vec<f64>, pixels: Vec<f64>, k: Vec<f64>, dist: Vec<f64>, guess: Option<([f64; 3], [f64; 3])>, iterations: usize, threshold_px: f64, confidence: f64) -> PyResult<Option<([f64; 3], [f64; 3], Vec<usize>, f64)>> {
    let lens = lens_of(&k, &dist, "camera_matrix", "dist_coeffs")?;
    let obj: Vec<[f64; 3]> = object.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let px: Vec<[f64; 2]> = pixels.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let guess = guess.map(|(r, t)| scan::calib::model::Pose { rvec: r.into(), t: t.into() });
    let settings = scan::calib::pnp_ransac::RansacSettings { iterations, threshold_px, confidence };
    let r = scan::calib::pnp_ransac::solve_pnp_ransac(&obj, &px, &lens, guess, &settings, 0).map_err(|e| value(format!("{e:#}")))?;
    Ok(r.map(|r| ([r.pose.rvec[0], r.pose.rvec[1], r.pose.rvec[2]], [r.pose.t[0], r.pose.t[1], r.pose.t[2]], r.inliers, r.rms_px)))
}
