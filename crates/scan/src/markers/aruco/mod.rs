//! Square fiducial markers: ArUco dictionaries ([`dictionary`]), their detection ([`detect`],
//! OpenCV's `ArucoDetector`) and ChArUco boards ([`charuco`], OpenCV's `CharucoBoard` and
//! `CharucoDetector`) as calibration targets that may be partly hidden or outside the frame.

pub mod charuco;
pub mod detect;
pub mod dictionary;

pub use charuco::{CharucoBoard, CharucoDetection};
pub use detect::{detect_markers, ArucoMarker, ArucoSettings};
pub use dictionary::Dictionary;
