//! The `lucent._lucent` extension module: lucent's optics, reflectometry fits, renderer and image
//! comparison for Python (PyO3). The Python package `lucent` (python/lucent/__init__.py) wraps
//! these functions: it broadcasts numpy arguments, flattens them for the functions here and
//! reshapes the results. Each function calls the same library functions with the same defaults
//! as the `lucent` command, so the numbers equal its `--json` output.
//!
//! Errors: bad arguments raise `ValueError`, failures to read or write a file `OSError`, with the
//! library's one-line message; nothing here panics on user input.

mod aruco;
mod calib;
mod camera;
mod compare;
mod errors;
mod fisheye;
mod fit;
mod graycode;
mod media;
mod mie;
mod parallel;
mod scene;
mod slab;
mod subsurface;

use pyo3::prelude::*;

#[pymodule]
fn _lucent(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(mie::mie_flat, m)?)?;
    m.add_function(wrap_pyfunction!(mie::mie_sphere_flat, m)?)?;
    m.add_function(wrap_pyfunction!(media::milk, m)?)?;
    m.add_function(wrap_pyfunction!(media::medium_file, m)?)?;
    m.add_function(wrap_pyfunction!(media::medium_json, m)?)?;
    m.add_function(wrap_pyfunction!(subsurface::dipole_flat, m)?)?;
    m.add_function(wrap_pyfunction!(slab::slab, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit_reflectance, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit_particles, m)?)?;
    m.add_function(wrap_pyfunction!(compare::compare, m)?)?;
    m.add_function(wrap_pyfunction!(camera::project_points_flat, m)?)?;
    m.add_function(wrap_pyfunction!(camera::undistort_points_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::find_chessboard_flat, m)?)?;
    m.add_function(wrap_pyfunction!(aruco::detect_markers_flat, m)?)?;
    m.add_function(wrap_pyfunction!(aruco::charuco_board_flat, m)?)?;
    m.add_function(wrap_pyfunction!(aruco::detect_charuco_flat, m)?)?;
    m.add_function(wrap_pyfunction!(aruco::charuco_image_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::find_circles_grid_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::stereo_calibrate_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::undistort_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::optimal_new_camera_matrix_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::stereo_rectify_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::undistort_rectify_map_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::triangulate_points_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::solve_pnp_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::solve_pnp_generic_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::solve_pnp_ransac_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::calibrate_camera_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_project_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_distort_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_undistort_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_calibrate_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::remap_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_stereo_calibrate_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_new_camera_matrix_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_stereo_rectify_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_solve_pnp_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_solve_pnp_ransac_flat, m)?)?;
    m.add_function(wrap_pyfunction!(fisheye::fisheye_undistort_rectify_map_flat, m)?)?;
    m.add_function(wrap_pyfunction!(calib::calibrate_procam_json, m)?)?;
    m.add_function(wrap_pyfunction!(graycode::gray_code_patterns_flat, m)?)?;
    m.add_function(wrap_pyfunction!(graycode::decode_capture_dir, m)?)?;
    m.add_function(wrap_pyfunction!(graycode::decode_frames_flat, m)?)?;
    m.add_function(wrap_pyfunction!(graycode::reconstruct_capture_dir, m)?)?;
    m.add_class::<scene::Scene>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
