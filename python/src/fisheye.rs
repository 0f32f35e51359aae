//! OpenCV's fisheye camera model for Python (`cv2.fisheye`'s `projectPoints`, `distortPoints`,
//! `undistortPoints`, `calibrate`, `stereoCalibrate`, `estimateNewCameraMatrixForUndistortRectify`,
//! `stereoRectify` and `solvePnP`) on flat arrays: `scan::calib::fisheye`.

use crate::errors::{value, OrPy};
use nalgebra::Vector3;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use scan::calib::fisheye::{calibrate_fisheye, FisheyeHold, FisheyeLens};
use scan::calib::model::Pose;

fn lens(k: [f64; 9], d: [f64; 4]) -> PyResult<FisheyeLens> {
    FisheyeLens::from_opencv(&k, &d).map_err(|e| value(format!("K, D: {e}")))
}

/// Pixels (flat u, v) of flat points (x, y, z) through the pose (Rodrigues vector, translation)
/// and the lens `k` (row-major 3×3, K₀₁ = skew·fx), `d` (k1…k4); NaN at or behind the camera.
#[pyfunction]
pub fn fisheye_project_flat<'py>(py: Python<'py>, points: PyReadonlyArray1<'py, f64>, rvec: [f64; 3], tvec: [f64; 3], k: [f64; 9], d: [f64; 4]) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let points = points.as_slice()?;
    let l = lens(k, d)?;
    if points.iter().chain(rvec.iter()).chain(tvec.iter()).any(|x| !x.is_finite()) {
        return Err(value("object_points, rvec, tvec: must be finite"));
    }
    let pose = Pose { rvec: Vector3::from(rvec), t: Vector3::from(tvec) };
    let uv: Vec<f64> = points
        .chunks_exact(3)
        .flat_map(|p| {
            let c = pose.apply(&Vector3::new(p[0], p[1], p[2]));
            l.project([c[0], c[1], c[2]])
        })
        .collect();
    Ok(uv.into_pyarray(py))
}

/// Pixels (flat u, v) of flat undistorted normalised coordinates (x/z, y/z).
#[pyfunction]
pub fn fisheye_distort_flat<'py>(py: Python<'py>, points: PyReadonlyArray1<'py, f64>, k: [f64; 9], d: [f64; 4]) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let l = lens(k, d)?;
    let uv: Vec<f64> = points
        .as_slice()?
        .chunks_exact(2)
        .flat_map(|p| {
            let (xd, yd) = l.distort(p[0], p[1]);
            l.to_pixel(xd, yd)
        })
        .collect();
    Ok(uv.into_pyarray(py))
}

/// Undistorted normalised coordinates (flat x/z, y/z) of flat pixels (u, v); NaN where the ray
/// would lie beyond the range over which θ_d increases.
#[pyfunction]
pub fn fisheye_undistort_flat<'py>(py: Python<'py>, pixels: PyReadonlyArray1<'py, f64>, k: [f64; 9], d: [f64; 4]) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let l = lens(k, d)?;
    let tm = l.theta_max();
    let xy: Vec<f64> = pixels
        .as_slice()?
        .chunks_exact(2)
        .flat_map(|q| {
            let (xd, yd) = l.normalise(q[0], q[1]);
            l.undistort(xd, yd, tm).map_or([f64::NAN; 2], |(x, y)| [x, y])
        })
        .collect();
    Ok(xy.into_pyarray(py))
}

/// Calibrate a fisheye camera from one planar target (flat x, y, z = 0) in several views (flat
/// u, v per view, NaN where not seen): (RMS in pixels, K row-major, D, Rodrigues vectors,
/// translations). `hold`: focal lengths, principal point, skew, k1…k4; `guess`: the start.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn fisheye_calibrate_flat(
    object_xy: Vec<f64>,
    image_points: Vec<Vec<f64>>,
    width: u32,
    height: u32,
    hold: (bool, bool, bool, [bool; 4]),
    guess: Option<([f64; 9], [f64; 4])>,
) -> PyResult<(f64, [f64; 9], [f64; 4], Vec<[f64; 3]>, Vec<[f64; 3]>)> {
    let obj: Vec<[f64; 2]> = object_xy.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let views: Vec<Vec<[f64; 2]>> = image_points.iter().map(|v| v.chunks_exact(2).map(|p| [p[0], p[1]]).collect()).collect();
    let start = guess.map(|(k, d)| lens(k, d)).transpose()?;
    let (focal, principal_point, skew, k) = hold;
    let hold = FisheyeHold { focal, principal_point, skew, k };
    let fit = calibrate_fisheye(&obj, &views, width, height, hold, start, 10.0).or_py()?;
    let rv = fit.poses.iter().map(|p| [p.rvec[0], p.rvec[1], p.rvec[2]]).collect();
    let tv = fit.poses.iter().map(|p| [p.t[0], p.t[1], p.t[2]]).collect();
    Ok((fit.rms_px, fit.lens.camera_matrix(), fit.lens.k, rv, tv))
}

/// `image` (row-major, `channels` interleaved 8-bit values per pixel, `width` × `height`) sampled
/// bilinearly at the flat source positions `map` (x, y per output pixel; black outside or at NaN),
/// as `cv2.remap` with INTER_LINEAR and a black constant border (`scan::calib::undistort`).
#[pyfunction]
pub fn remap_flat(py: Python<'_>, image: &[u8], width: usize, height: usize, channels: usize, map: PyReadonlyArray1<'_, f64>) -> PyResult<Py<pyo3::types::PyBytes>> {
    let map = map.as_slice()?;
    if image.len() != width * height * channels || channels == 0 {
        return Err(value(format!("src: expected {width}×{height}×{channels} values, got {}", image.len())));
    }
    let m: Vec<[f64; 2]> = map.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let pixels = py.allow_threads(|| scan::calib::undistort::remap_bilinear(image, channels, width, height, &m));
    Ok(pyo3::types::PyBytes::new(py, &pixels).unbind())
}

/// Calibrate a fisheye pair from one planar target (flat x, y, z = 0) in the same views of both
/// cameras (flat u, v per view, NaN where not seen): (RMS in pixels, K1, D1, K2, D2 row-major,
/// R row-major, T, per-view Rodrigues vectors and translations of the target → first camera).
/// `hold` as [`fisheye_calibrate_flat`]; `fix_intrinsic` holds both lenses at `guess`.
#[pyfunction]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn fisheye_stereo_calibrate_flat(
    object_xy: Vec<f64>,
    image_points1: Vec<Vec<f64>>,
    image_points2: Vec<Vec<f64>>,
    width: u32,
    height: u32,
    hold: (bool, bool, bool, [bool; 4]),
    fix_intrinsic: bool,
    guess: (Option<([f64; 9], [f64; 4])>, Option<([f64; 9], [f64; 4])>),
) -> PyResult<(f64, [f64; 9], [f64; 4], [f64; 9], [f64; 4], [f64; 9], [f64; 3], Vec<[f64; 3]>, Vec<[f64; 3]>)> {
    use scan::calib::fisheye::stereo_calibrate_fisheye;
    let obj: Vec<[f64; 2]> = object_xy.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let pts = |v: &Vec<Vec<f64>>| -> Vec<Vec<[f64; 2]>> { v.iter().map(|p| p.chunks_exact(2).map(|q| [q[0], q[1]]).collect()).collect() };
    let (v1, v2) = (pts(&image_points1), pts(&image_points2));
    let g1 = guess.0.map(|(k, d)| lens(k, d)).transpose()?;
    let g2 = guess.1.map(|(k, d)| lens(k, d)).transpose()?;
    let (focal, principal_point, skew, k) = hold;
    let hold = FisheyeHold { focal, principal_point, skew, k };
    let fit = stereo_calibrate_fisheye(&obj, [&v1, &v2], width, height, hold, fix_intrinsic, [g1, g2], 10.0).or_py()?;
    let r = fit.stereo.r();
    let rm = [r[(0, 0)], r[(0, 1)], r[(0, 2)], r[(1, 0)], r[(1, 1)], r[(1, 2)], r[(2, 0)], r[(2, 1)], r[(2, 2)]];
    let rv = fit.poses.iter().map(|p| [p.rvec[0], p.rvec[1], p.rvec[2]]).collect();
    let tv = fit.poses.iter().map(|p| [p.t[0], p.t[1], p.t[2]]).collect();
    let [l1, l2] = fit.lens;
    Ok((fit.rms_px, l1.camera_matrix(), l1.k, l2.camera_matrix(), l2.k, rm, [fit.stereo.t[0], fit.stereo.t[1], fit.stereo.t[2]], rv, tv))
}

/// A rotation from 9 row-major values, refused unless finite and a proper rotation.
fn rotation(r: &[f64], name: &str) -> PyResult<nalgebra::Matrix3<f64>> {
    if r.len() != 9 || !r.iter().all(|v| v.is_finite()) {
        return Err(value(format!("{name}: expected a finite 3×3 rotation")));
    }
    let m = nalgebra::Matrix3::from_row_slice(r);
    if (m * m.transpose() - nalgebra::Matrix3::identity()).norm() > 1e-6 || m.determinant() < 0.0 {
        return Err(value(format!("{name}: not a rotation matrix")));
    }
    Ok(m)
}

/// `cv2.fisheye.estimateNewCameraMatrixForUndistortRectify`: [fx, fy, cx, cy] of the new pinhole
/// camera (`scan::calib::fisheye::rectify::new_camera_matrix`).
#[pyfunction]
pub fn fisheye_new_camera_matrix_flat(
    k: [f64; 9],
    d: [f64; 4],
    size: (u32, u32),
    r: Vec<f64>,
    balance: f64,
    new_size: (u32, u32),
    fov_scale: f64,
) -> PyResult<[f64; 4]> {
    let l = lens(k, d)?;
    let m = rotation(&r, "R")?;
    let n = scan::calib::fisheye::rectify::new_camera_matrix(
        &l, size, &m, balance, new_size, fov_scale,
    )
    .map_err(|e| value(format!("K, D: {e:#}")))?;
    Ok([n.fx, n.fy, n.cx, n.cy])
}

/// `cv2.fisheye.stereoRectify`: R1, R2 (row-major 3×3), P1, P2 (row-major 3×4), Q (row-major 4×4)
/// (`scan::calib::fisheye::rectify::stereo_rectify_fisheye`).
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn fisheye_stereo_rectify_flat(
    k1: [f64; 9],
    d1: [f64; 4],
    k2: [f64; 9],
    d2: [f64; 4],
    size: (u32, u32),
    r: Vec<f64>,
    t: [f64; 3],
    zero_disparity: bool,
    new_size: (u32, u32),
    balance: f64,
    fov_scale: f64,
) -> PyResult<(Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>)> {
    let (a, b) = (lens(k1, d1)?, lens(k2, d2)?);
    let m = rotation(&r, "R")?;
    if !t.iter().all(|v| v.is_finite()) {
        return Err(value("tvec: must be finite"));
    }
    let rect = scan::calib::fisheye::rectify::stereo_rectify_fisheye(
        [&a, &b],
        size,
        &m,
        &Vector3::from(t),
        zero_disparity,
        new_size,
        balance,
        fov_scale,
    )
    .map_err(|e| value(format!("{e:#}")))?;
    let rows3 = |m: &nalgebra::Matrix3<f64>| m.transpose().iter().copied().collect::<Vec<_>>();
    let rows34 = |m: &nalgebra::Matrix3x4<f64>| m.transpose().iter().copied().collect::<Vec<_>>();
    Ok((
        rows3(&rect.r[0]),
        rows3(&rect.r[1]),
        rows34(&rect.p[0]),
        rows34(&rect.p[1]),
        rect.q.transpose().iter().copied().collect(),
    ))
}

/// `cv2.fisheye.solvePnP` (`SOLVEPNP_ITERATIVE`): the Rodrigues vector and translation of the
/// object → camera pose, and the RMS reprojection error (pixels).
#[pyfunction]
pub fn fisheye_solve_pnp_flat(
    object: Vec<f64>,
    pixels: Vec<f64>,
    k: [f64; 9],
    d: [f64; 4],
    guess: Option<([f64; 3], [f64; 3])>,
) -> PyResult<([f64; 3], [f64; 3], f64)> {
    let l = lens(k, d)?;
    let obj: Vec<[f64; 3]> = object.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let px: Vec<[f64; 2]> = pixels.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let guess = guess.map(|(r, t)| Pose {
        rvec: r.into(),
        t: t.into(),
    });
    let (pose, rms) = scan::calib::fisheye::pnp::solve_pnp_fisheye(&obj, &px, &l, guess)
        .map_err(|e| value(format!("{e:#}")))?;
    Ok((
        [pose.rvec[0], pose.rvec[1], pose.rvec[2]],
        [pose.t[0], pose.t[1], pose.t[2]],
        rms,
    ))
}

/// `cv2.fisheye.solvePnPRansac` (`SOLVEPNP_ITERATIVE`): as `solve_pnp_ransac_flat`, through the
/// fisheye lens `k`, `d`.
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn fisheye_solve_pnp_ransac_flat(object: Vec<f64>, pixels: Vec<f64>, k: [f64; 9], d: [f64; 4], guess: Option<([f64; 3], [f64; 3])>, iterations: usize, threshold_px: f64, confidence: f64) -> PyResult<Option<([f64; 3], [f64; 3], Vec<usize>, f64)>> {
    let l = lens(k, d)?;
    let obj: Vec<[f64; 3]> = object.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let px: Vec<[f64; 2]> = pixels.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let guess = guess.map(|(r, t)| Pose { rvec: r.into(), t: t.into() });
    let settings = scan::calib::pnp_ransac::RansacSettings { iterations, threshold_px, confidence };
    let r = scan::calib::fisheye::pnp::solve_pnp_ransac_fisheye(&obj, &px, &l, guess, &settings, 0).map_err(|e| value(format!("{e:#}")))?;
    Ok(r.map(|r| ([r.pose.rvec[0], r.pose.rvec[1], r.pose.rvec[2]], [r.pose.t[0], r.pose.t[1], r.pose.t[2]], r.inliers, r.rms_px)))
}

/// `cv2.fisheye.initUndistortRectifyMap`'s float maps, flat (x, y per pixel of the `w` × `h`
/// output, row-major): the pinhole `p` (3×3, row-major) turned by `r` (3×3, row-major) from the
/// fisheye lens `k`, `d`; NaN where a pixel's ray lies at or behind the camera's plane
/// (`scan::calib::fisheye::rectify::undistort_rectify_map_fisheye`).
#[pyfunction]
pub fn fisheye_undistort_rectify_map_flat<'py>(py: Python<'py>, k: [f64; 9], d: [f64; 4], r: [f64; 9], p: [f64; 9], w: usize, h: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let l = lens(k, d)?;
    if !r.iter().chain(p.iter()).all(|v| v.is_finite()) {
        return Err(value("R, P: must be finite"));
    }
    let (rm, pm) = (nalgebra::Matrix3::from_row_slice(&r), nalgebra::Matrix3::from_row_slice(&p));
    let map = py.allow_threads(|| scan::calib::fisheye::rectify::undistort_rectify_map_fisheye(&l, &rm, &pm, w, h)).map_err(|e| value(format!("R, P: {e:#}")))?;
    Ok(map.into_iter().flatten().collect::<Vec<f64>>().into_pyarray(py))
}
