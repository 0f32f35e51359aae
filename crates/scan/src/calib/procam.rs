//! Projector coordinates of the board corners by local homographies (D. Moreno, G. Taubin,
//! "Simple, accurate, and robust projector-camera calibration", 3DIMPVT 2012, §3.2): around each
//! camera corner, a homography camera → projector is fitted to the decoded pixels of a square
//! window (47 × 47 px in the paper), and the corner's projector position is that homography
//! applied to the camera corner. The board is locally planar, so a homography is exact up to lens
//! distortion across the window; it averages the decoding noise of many pixels and interpolates
//! across the corner, where the dark squares often leave no decoded pixels.
//!
//! The fit is robust: after a first normalised-DLT fit, pixels whose transfer error exceeds 3
//! robust standard deviations (1.4826 × median, floored at 0.5 projector px) are dropped and the
//! fit repeated (up to 3 rounds) — decoding errors at stripe boundaries are far off the plane's
//! homography and would otherwise pull it.
//!
//! A corner whose window holds too few decoded pixels (the board reaches beyond the projector's
//! throw, or a shadow falls on it) has no projector position; the calibration uses it for the
//! camera only.

use super::homography::{apply, fit_homography_robust, Point2};
use crate::decode::DecodeMap;
use anyhow::{bail, Result};

/// Window and validity rules of the local homographies.
#[derive(Clone, Copy, Debug)]
pub struct LocalHomography {
    /// Half-size of the square window (pixels): 23 gives Moreno & Taubin's 47 × 47.
    pub half_window: usize,
    /// Fewest decoded pixels in the window for a corner to be used.
    pub min_valid: usize,
}

impl Default for LocalHomography {
    fn default() -> Self {
        LocalHomography { half_window: 23, min_valid: 100 }
    }
}

/// Fewest corners of one capture that must have a projector position (a homography needs 4; the
/// calibration's projector views are better held with more).
pub const MIN_PROJECTOR_CORNERS: usize = 8;

/// The projector position (projector pixels, OpenCV convention) of every camera corner, or
/// `[NaN, NaN]` for a corner whose window holds too few decoded pixels (outside the projector's
/// throw or in its shadow), which the calibration then leaves out of the projector's equations,
/// as kamino410/procam-calibration's `calibrate.py` does. Errors, naming the capture
/// `name` and the first corner without a position, when fewer than [`MIN_PROJECTOR_CORNERS`] have
/// one.
pub fn projector_corners(map: &DecodeMap, corners: &[Point2], opts: &LocalHomography, name: &str) -> Result<Vec<Point2>> {
    let hw = opts.half_window as isize;
    let mut out = Vec::with_capacity(corners.len());
    let mut first_missing: Option<String> = None;
    for (k, c) in corners.iter().enumerate() {
        match corner_homography(map, *c, hw, opts.min_valid) {
            Ok(p) => out.push(p),
            Err(why) => {
                first_missing.get_or_insert_with(|| format!("too few valid pixels around corner {k} (capture {name}): {why}"));
                out.push([f64::NAN, f64::NAN]);
            }
        }
    }
    let found = out.iter().filter(|p| super::bundle::observed(**p)).count();
    if found < MIN_PROJECTOR_CORNERS.min(corners.len()) {
        bail!(
            "{}; {found} of {} corners have a projector position, need {}",
            first_missing.unwrap_or_default(),
            corners.len(),
            MIN_PROJECTOR_CORNERS
        );
    }
    Ok(out)
}

/// The projector position of camera corner `c` from the decoded pixels in its window, or why not.
fn corner_homography(map: &DecodeMap, c: Point2, hw: isize, min_valid: usize) -> std::result::Result<Point2, String> {
    let (cx, cy) = (c[0].round() as isize, c[1].round() as isize);
    let mut src = Vec::new();
    let mut dst = Vec::new();
    for y in (cy - hw).max(0)..=(cy + hw).min(map.height as isize - 1) {
        for x in (cx - hw).max(0)..=(cx + hw).min(map.width as isize - 1) {
            let i = y as usize * map.width + x as usize;
            let (u, v) = (map.col[i], map.row[i]);
            if u.is_finite() && v.is_finite() {
                src.push([x as f64, y as f64]);
                dst.push([u as f64, v as f64]);
            }
        }
    }
    if src.len() < min_valid {
        return Err(format!(
            "{} decoded in the {}×{} window at ({:.1}, {:.1}), need {min_valid}",
            src.len(),
            2 * hw + 1,
            2 * hw + 1,
            c[0],
            c[1]
        ));
    }
    let Some((h, inliers)) = fit_homography_robust(&src, &dst, 3, 3.0, 0.5) else {
        return Err("the decoded pixels do not determine a homography".into());
    };
    if inliers < min_valid {
        return Err(format!("{inliers} consistent decoded pixels, need {min_valid}"));
    }
    Ok(apply(&h, c))
}
