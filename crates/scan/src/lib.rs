//! Structured-light digitization (Stets et al., Applied Optics 56(27), 2017, §2): the Gray-code
//! patterns of OpenCV's `structured_light::GrayCodePattern`, their decoding to projector
//! coordinates per camera pixel, projector–camera calibration from chessboard captures
//! (Zhang 2000; Moreno & Taubin, 3DIMPVT 2012), and triangulation to point clouds and meshes.
//! [`synth`] renders captures with known truth through lucent's renderer, and [`eval`] compares
//! results with a truth (calibration errors, sphere fit, distances to a mesh). [`markers`] finds
//! circular markers, triangulates them from two calibrated views and registers a model onto them.
//!
//! Conventions (see `docs/scanning.md`): OpenCV's pixel convention (integer coordinates at
//! pixel centres, x right, y down), camera coordinates x right, y down, z forward; lengths of
//! the calibration and the reconstruction in chessboard square units.

pub mod calib;
pub mod cloud;
pub mod decode;
pub mod eval;
pub mod graycode;
pub mod markers;
pub mod label;
pub mod raster;
pub mod synth;
pub mod triangulate;
