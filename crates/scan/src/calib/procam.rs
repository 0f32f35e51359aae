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

/// The projector position (projector pixels, OpenCV convention) of every camera corner.
/// `name` labels errors ("too few valid pixels around corner K (capture NAME) …").
pub fn projector_corners(map: &DecodeMap, corners: &[Point2], opts: &LocalHomography, name: &str) -> Result<Vec<Point2>> {
    let hw = opts.half_window as isize;
    let mut out = Vec::with_capacity(corners.len());
    for (k, c) in corners.iter().enumerate() {
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
        if src.len() < opts.min_valid {
            bail!(
                "too few valid pixels around corner {k} (capture {name}): {} decoded in the {}×{} window at ({:.1}, {:.1}), need {}",
                src.len(), 2 * hw + 1, 2 * hw + 1, c[0], c[1], opts.min_valid
            );
        }
        let Some((h, inliers)) = fit_homography_robust(&src, &dst, 3, 3.0, 0.5) else {
            bail!("too few valid pixels around corner {k} (capture {name}): the decoded pixels do not determine a homography");
        };
        if inliers < opts.min_valid {
            bail!("too few valid pixels around corner {k} (capture {name}): {inliers} consistent decoded pixels, need {}", opts.min_valid);
        }
        out.push(apply(&h, *c));
    }
    Ok(out)
}
