//! Circular markers (docs/markers.md): detection with sub-pixel ellipse centres, matching across
//! two calibrated views along epipolar lines, triangulation of the matched centres, and the rigid
//! or similarity registration of a model carrying the same markers onto them.
//!
//! - [`hough`]: the size-invariant (phase-coded) circle Hough transform of Atherton & Kerbyson.
//! - [`blobs`]: disc candidates from thresholded regions (fast, for calibration targets).
//! - [`ellipse`]: Fitzgibbon's direct ellipse fit, and the image of a 3-D circle's centre.
//! - [`grid`]: symmetric and asymmetric circle grids as calibration targets.
//! - [`detect`]: candidates refined to ellipses from sub-pixel edge points.
//! - [`stereo`]: epipolar matching, the perspective correction of the centres, triangulation.
//! - [`register`]: Umeyama's closed form and RANSAC over correspondence triples.
//! - [`synth`]: a sphere carrying markers rendered by lucent through two calibrated cameras.
//!
//! - [`aruco`]: square ArUco markers and ChArUco boards (OpenCV's dictionaries and detector).
//!
//! Pixels follow OpenCV's convention (integer coordinates at pixel centres, x right, y down).

pub mod aruco;
pub mod blobs;
pub mod detect;
pub mod ellipse;
pub mod grid;
pub mod hough;
pub mod register;
pub mod stereo;
pub mod synth;

use anyhow::{bail, Result};
use std::path::Path;

pub use detect::{detect, DetectSettings};
pub use ellipse::Ellipse;

/// A single-channel image of linear values, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width (pixels).
    pub width: usize,
    /// Height (pixels).
    pub height: usize,
    /// Values, row-major (linear, e.g. 0 … 1).
    pub data: Vec<f32>,
}

impl Image {
    /// An image of `data` (row-major); an error if the sizes disagree.
    pub fn new(width: usize, height: usize, data: Vec<f32>) -> Result<Image> {
        if data.len() != width * height {
            bail!("image of {width}x{height} pixels needs {} values, got {}", width * height, data.len());
        }
        Ok(Image { width, height, data })
    }

    /// Reads a PNG, JPEG, EXR or PFM file as linear grey (the mean of the linear R, G, B; 8-bit
    /// files are sRGB-decoded).
    pub fn read(path: &Path) -> Result<Image> {
        let img = render::image_io::read_image(path)?;
        let data = img.rgb.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).collect();
        Image::new(img.width as usize, img.height as usize, data)
    }

    /// Bilinear interpolation at (x, y) (OpenCV pixel convention); None outside the pixel centres'
    /// hull.
    pub fn bilinear(&self, x: f64, y: f64) -> Option<f64> {
        if !(x >= 0.0 && y >= 0.0 && x <= (self.width - 1) as f64 && y <= (self.height - 1) as f64) {
            return None;
        }
        // x, y ≥ 0 here, so truncation is the floor (without a libm call on baseline x86-64).
        let (x0, y0) = ((x as usize).min(self.width.saturating_sub(2)), (y as usize).min(self.height.saturating_sub(2)));
        let (ax, ay) = (x - x0 as f64, y - y0 as f64);
        let i = y0 * self.width + x0;
        let (x1, y1) = (usize::from(self.width > 1), if self.height > 1 { self.width } else { 0 });
        // The two rows' pairs as slices: two bounds checks instead of four.
        let (r0, r1) = (&self.data[i..=i + x1], &self.data[i + y1..=i + y1 + x1]);
        let (p00, p10, p01, p11) = (r0[0] as f64, r0[x1] as f64, r1[0] as f64, r1[x1] as f64);
        Some((1.0 - ay) * ((1.0 - ax) * p00 + ax * p10) + ay * ((1.0 - ax) * p01 + ax * p11))
    }
}

/// One detected marker.
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// Centre x of the fitted ellipse (pixels). Under perspective this is not the image of the
    /// marker's centre; [`stereo`] corrects it where two calibrated views are given.
    pub x: f64,
    /// Centre y of the fitted ellipse (pixels).
    pub y: f64,
    /// Radius of the circle of equal area, √(ab) (pixels).
    pub radius_px: f64,
    /// The fitted ellipse (pixels).
    pub ellipse: Ellipse,
    /// A dark disc on a light ground (else light on dark).
    pub dark: bool,
    /// Fraction of the refinement's rays that found the edge.
    pub support: f64,
    /// RMS distance of the edge points from the ellipse (pixels).
    pub rms_px: f64,
    /// The Hough peak score of the candidate.
    pub score: f64,
    /// The sub-pixel edge points the ellipse was fitted to (pixels).
    pub edge_points: Vec<[f64; 2]>,
}
