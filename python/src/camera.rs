//! OpenCV's point projection and its inverse with lucent's camera model (all 14 distortion
//! coefficients): `cv2.projectPoints` and `cv2.undistortPoints` (without R and P) on numpy arrays.

use crate::errors::{value, OrPy};
use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;

fn camera(rvec: [f64; 3], tvec: [f64; 3], k: [f64; 9], dist: &[f64]) -> PyResult<OpenCv> {
    let intr = Intrinsics::from_camera_matrix(&k).map_err(|e| value(format!("camera_matrix: {e}")))?;
    let d = Distortion::from_opencv(dist).map_err(|e| value(format!("dist_coeffs: {e}")))?;
    let e = Extrinsics::from_rvec(rvec, tvec).map_err(|e| value(format!("rvec, tvec: {e}")))?;
    OpenCv::unchecked(intr, d, e).or_py()
}

/// Pixel positions (flat u, v) of flat world points (x, y, z), as OpenCV's `projectPoints`;
/// NaN for a point at or behind the camera.
#[pyfunction]
pub fn project_points_flat<'py>(py: Python<'py>, points: PyReadonlyArray1<'py, f64>, rvec: [f64; 3], tvec: [f64; 3], camera_matrix: [f64; 9], dist_coeffs: Vec<f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let points = points.as_slice()?;
    let cam = camera(rvec, tvec, camera_matrix, &dist_coeffs)?;
    if points.iter().any(|x| !x.is_finite()) {
        return Err(value("object_points: must be finite"));
    }
    let uv: Vec<f64> = points.chunks_exact(3).flat_map(|p| cam.project_pixel([p[0], p[1], p[2]]).unwrap_or([f64::NAN; 2])).collect();
    Ok(uv.into_pyarray(py))
}

/// Normalised undistorted coordinates (flat x′, y′) of flat pixel positions (u, v), as OpenCV's
/// `undistortPoints` without R and P; NaN where the inverse does not converge.
#[pyfunction]
pub fn undistort_points_flat<'py>(py: Python<'py>, pixels: PyReadonlyArray1<'py, f64>, camera_matrix: [f64; 9], dist_coeffs: Vec<f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let pixels = pixels.as_slice()?;
    let cam = camera([0.0; 3], [0.0; 3], camera_matrix, &dist_coeffs)?;
    let k = cam.intrinsics;
    let xy: Vec<f64> = pixels
        .chunks_exact(2)
        .flat_map(|q| {
            let (x, y, ok) = cam.undistort((q[0] - k.cx) / k.fx, (q[1] - k.cy) / k.fy);
            if ok {
                [x, y]
            } else {
                [f64::NAN; 2]
            }
        })
        .collect();
    Ok(xy.into_pyarray(py))
}
