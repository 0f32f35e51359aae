//! ArUco markers and ChArUco boards from Python, as OpenCV's `ArucoDetector.detectMarkers` and
//! `CharucoDetector.detectBoard` (the `scan` crate's detector; docs/scanning.md, "ChArUco boards").

use crate::errors::value;
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use scan::calib::chessboard::GrayImage;
use scan::markers::aruco::{detect_markers, ArucoSettings, CharucoBoard, Dictionary};

fn grey_image(grey: PyReadonlyArray1<'_, f32>, width: usize, height: usize) -> PyResult<GrayImage> {
    let data = grey.as_slice()?.to_vec();
    if data.len() != width * height || width < 8 || height < 8 {
        return Err(value(format!("image: expected {width}×{height} grey levels (at least 8×8), got {}", data.len())));
    }
    Ok(GrayImage { width, height, data })
}

fn dictionary(name: &str) -> PyResult<Dictionary> {
    Dictionary::predefined(name).map_err(|e| value(format!("dictionary: {e}")))
}

fn board(squares: (usize, usize), square: f64, marker: f64, dict: &str, legacy: bool) -> PyResult<CharucoBoard> {
    CharucoBoard::new(squares.0, squares.1, square, marker, dictionary(dict)?, legacy).map_err(|e| value(format!("board: {e}")))
}

/// The markers of a dictionary in a grey image: (ids, flat corners: 8 numbers per marker, its
/// top-left, top-right, bottom-right, bottom-left corners).
#[pyfunction]
#[pyo3(signature = (grey, width, height, dict, refine=false))]
pub fn detect_markers_flat(py: Python<'_>, grey: PyReadonlyArray1<'_, f32>, width: usize, height: usize, dict: &str, refine: bool) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let img = grey_image(grey, width, height)?;
    let d = dictionary(dict)?;
    let s = ArucoSettings { refine, ..Default::default() };
    let found = py.allow_threads(|| detect_markers(&img, &d, &s));
    Ok((found.iter().map(|m| m.id).collect(), found.iter().flat_map(|m| m.corners.into_iter().flatten()).collect()))
}

/// A ChArUco board's chessboard corners (flat x, y by id), its markers' corners (flat, 8 per
/// marker, board order) and ids.
#[pyfunction]
pub fn charuco_board_flat(squares: (usize, usize), square: f64, marker: f64, dict: &str, legacy: bool) -> PyResult<(Vec<f64>, Vec<f64>, Vec<usize>)> {
    let b = board(squares, square, marker, dict, legacy)?;
    let markers = (0..b.ids.len()).flat_map(|k| b.marker_corners(k).into_iter().flatten()).collect();
    Ok((b.chessboard_corners().into_iter().flatten().collect(), markers, b.ids.clone()))
}

/// A ChArUco board's corners in a grey image: (corner ids, flat corner pixels, marker ids, flat
/// marker corners).
#[pyfunction]
pub fn detect_charuco_flat(
    py: Python<'_>,
    grey: PyReadonlyArray1<'_, f32>,
    width: usize,
    height: usize,
    squares: (usize, usize),
    square: f64,
    marker: f64,
    dict: &str,
    legacy: bool,
) -> PyResult<(Vec<usize>, Vec<f64>, Vec<usize>, Vec<f64>)> {
    let img = grey_image(grey, width, height)?;
    let b = board(squares, square, marker, dict, legacy)?;
    let d = py.allow_threads(|| b.detect(&img, &ArucoSettings::default()));
    Ok((
        d.corners.iter().map(|c| c.0).collect(),
        d.corners.iter().flat_map(|c| c.1).collect(),
        d.markers.iter().map(|m| m.id).collect(),
        d.markers.iter().flat_map(|m| m.corners.into_iter().flatten()).collect(),
    ))
}

/// A ChArUco board drawn upright into a `width` × `height` image with `margin` pixels of light
/// paper at least on every side (OpenCV's `CharucoBoard.generateImage`): 8-bit codes, dark 0 and
/// light 255, each pixel the mean of 4 × 4 samples.
#[pyfunction]
pub fn charuco_image_flat(squares: (usize, usize), square: f64, marker: f64, dict: &str, legacy: bool, width: usize, height: usize, margin: usize) -> PyResult<Vec<u8>> {
    let b = board(squares, square, marker, dict, legacy)?;
    if width <= 2 * margin || height <= 2 * margin {
        return Err(value(format!("out_size: {width}×{height} leaves no room inside a margin of {margin} px")));
    }
    let (bw, bh) = (squares.0 as f64 * square, squares.1 as f64 * square);
    let k = ((width - 2 * margin) as f64 / bw).min((height - 2 * margin) as f64 / bh);
    // Pixel centres at integers: the board's edge at −0.5 + offset.
    let (ox, oy) = ((width as f64 - k * bw) / 2.0 - 0.5, (height as f64 - k * bh) / 2.0 - 0.5);
    let h = nalgebra::Matrix3::new(k, 0.0, ox, 0.0, k, oy, 0.0, 0.0, 1.0);
    let img = b.render(&h, width, height);
    // render's levels 30 and 220 stretched to 0 and 255.
    Ok(img.data.iter().map(|&v| (((v - 30.0) / 190.0) * 255.0).round().clamp(0.0, 255.0) as u8).collect())
}
