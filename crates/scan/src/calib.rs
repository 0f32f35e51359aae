//! Projector–camera calibration: the result type and its JSON form.

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
