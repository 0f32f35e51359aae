//! Gray-code structured light from Python: the patterns `lucent scan patterns` writes and the
//! decoding of `lucent scan decode` (the `scan` crate's `graycode` and `decode`; docs/scanning.md).

use crate::errors::{value, OrPy};
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use scan::decode::{decode, read_capture, Capture, DecodeMap, DecodeSettings, DecodeStats};
use scan::graycode::PatternSet;

/// The decode map as flat arrays: (width, height, column, row, white, black, valid pixels,
/// refined column pixels, refined row pixels).
type FlatMap = (usize, usize, Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>, usize, usize, usize);

fn flat((map, stats): (DecodeMap, DecodeStats)) -> FlatMap {
    (map.width, map.height, map.col, map.row, map.white, map.black, stats.valid_pixels, stats.refined_columns, stats.refined_rows)
}

fn patterns(projector: (u32, u32), step: u32) -> PyResult<PatternSet> {
    PatternSet::new(projector.0, projector.1, step).map_err(|e| value(format!("projector_size: {e:#}")))
}

fn settings(thresholds: (i32, i32), refine: bool, white_black_first: bool) -> PyResult<DecodeSettings> {
    for (name, t) in [("black_threshold", thresholds.0), ("white_threshold", thresholds.1)] {
        if !(0..=254).contains(&t) {
            return Err(value(format!("{name}: must be 0 … 254 grey levels, got {t}")));
        }
    }
    Ok(DecodeSettings { black_threshold: thresholds.0, white_threshold: thresholds.1, refine, white_black_first })
}

/// The frames of a projector's Gray-code sequence (OpenCV's `GrayCodePattern` order: column bits,
/// row bits, each with its inverse, then white and black), each a flat 8-bit image (row-major).
#[pyfunction]
pub fn gray_code_patterns_flat(projector: (u32, u32), step: u32) -> PyResult<Vec<Vec<u8>>> {
    let p = patterns(projector, step)?;
    Ok((0..p.len()).filter_map(|i| p.image(i)).collect())
}

/// `lucent scan decode` on a capture folder.
#[pyfunction]
pub fn decode_capture_dir(py: Python<'_>, dir: std::path::PathBuf, projector: (u32, u32), step: u32, thresholds: (i32, i32), refine: bool, white_black_first: bool) -> PyResult<FlatMap> {
    let p = patterns(projector, step)?;
    let s = settings(thresholds, refine, white_black_first)?;
    py.allow_threads(|| read_capture(&dir, &p, &|| {}).and_then(|c| decode(&c, &p, &s))).or_py().map(flat)
}

/// The same on frames in memory: `count` 8-bit grey images of `width` × `height`, stacked
/// (row-major, frame after frame), in capture order.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn decode_frames_flat(
    py: Python<'_>,
    stack: PyReadonlyArray1<'_, u8>,
    count: usize,
    width: usize,
    height: usize,
    projector: (u32, u32),
    step: u32,
    thresholds: (i32, i32),
    refine: bool,
    white_black_first: bool,
) -> PyResult<FlatMap> {
    let p = patterns(projector, step)?;
    let s = settings(thresholds, refine, white_black_first)?;
    if count != p.len() {
        return Err(value(format!("frames: {count} images, but the {}x{} step-{step} sequence has {}", projector.0, projector.1, p.len())));
    }
    let stack = stack.as_slice()?;
    if width == 0 || height == 0 || stack.len() != count * width * height {
        return Err(value(format!("frames: {} levels for {count} images of {width}×{height}", stack.len())));
    }
    let frames = stack.chunks_exact(width * height).map(<[u8]>::to_vec).collect();
    let capture = Capture { width, height, frames };
    py.allow_threads(|| decode(&capture, &p, &s)).or_py().map(flat)
}

/// A capture triangulated with a projector–camera calibration, as `lucent scan reconstruct`: per
/// camera pixel (row-major) the point, its unit normal (zero where no neighbour is joined) and
/// its ray gap (NaN where nothing was triangulated), with the command's summary (point count,
/// bounding box, median ray gap) and the number of pixels `fill_holes` filled.
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn reconstruct_capture_dir(
    py: Python<'_>,
    dir: std::path::PathBuf,
    calibration: std::path::PathBuf,
    projector: Option<(u32, u32)>,
    step: u32,
    thresholds: (i32, i32),
    refine: bool,
    white_black_first: bool,
    fill_holes: usize,
    max_edge_px: f64,
) -> PyResult<(usize, usize, Vec<f64>, Vec<f64>, Vec<f64>, usize, [f64; 3], [f64; 3], f64, usize)> {
    use anyhow::Context;
    let s = settings(thresholds, refine, white_black_first)?;
    if fill_holes > 64 {
        return Err(value(format!("fill_holes: at most 64 pixels (a hole's radius), got {fill_holes}")));
    }
    if !(max_edge_px > 0.0 && max_edge_px.is_finite()) {
        return Err(value(format!("max_edge_px: must be a positive number of pixels, got {max_edge_px}")));
    }
    let run = || -> anyhow::Result<_> {
        let calib = scan::calib::ProcamCalibration::read(&calibration, projector)?;
        let rig = scan::triangulate::Rig::new(&calib).with_context(|| format!("{}", calibration.display()))?;
        let p = PatternSet::new(calib.projector.width, calib.projector.height, step).with_context(|| format!("{}: projector", calibration.display()))?;
        let (map, _) = decode(&read_capture(&dir, &p, &|| {})?, &p, &s)?;
        let (map, filled) = if fill_holes > 0 { scan::decode::fill_holes(&map, fill_holes, 0.25, 1.0) } else { (map, 0) };
        let range = scan::triangulate::triangulate_map(&map, &rig, &|| {}).with_context(|| format!("{} with {}", dir.display(), calibration.display()))?;
        let cloud = range.cloud(&map.white, max_edge_px, false);
        let (w, h) = (map.width, map.height);
        let mut xyz = vec![f64::NAN; 3 * w * h];
        let mut normals = vec![f64::NAN; 3 * w * h];
        let mut gap = vec![f64::NAN; w * h];
        for (k, &(x, y)) in cloud.pixel.iter().enumerate() {
            let i = y as usize * w + x as usize;
            xyz[3 * i..3 * i + 3].copy_from_slice(&cloud.points[k]);
            normals[3 * i..3 * i + 3].copy_from_slice(&cloud.normals[k]);
            gap[i] = cloud.ray_gap[k];
        }
        let sm = cloud.summary();
        Ok((w, h, xyz, normals, gap, sm.points, sm.bbox_min, sm.bbox_max, sm.median_ray_gap, filled))
    };
    py.allow_threads(run).or_py()
}
