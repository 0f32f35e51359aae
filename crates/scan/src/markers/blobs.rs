//! Disc candidates from thresholded regions, a fast alternative to the Hough transform
//! ([`super::hough`]) where the discs stand out from a fairly even ground (calibration targets),
//! after the blob detector OpenCV's `findCirclesGrid` uses: the image is cut at several grey levels
//! between its dark and light extremes, the connected regions on the disc's side of each level
//! are measured (area, centroid, second moments), and a region counts when it fills the ellipse
//! of its moments as a disc does, is not too elongated and does not touch the border. Regions of
//! several levels with nearly the same centre are one candidate. The candidates only seed
//! [`super::detect::refine`], which fits the disc's edge.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::hough::Candidate;
use crate::raster::neighbours4;
use super::Image;

/// Levels between the image's 2nd and 98th percentiles at which it is cut.
const LEVELS: [f64; 7] = [0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8];
/// Smallest region (pixels): a disc of radius 2.
const MIN_AREA: usize = 12;

/// Candidates for dark discs on a light ground (`dark`) or light on dark, strongest (seen at most
/// levels) first; radii from the regions' areas.
pub fn threshold_candidates(img: &Image, dark: bool) -> Vec<Candidate> {
    let (w, h) = (img.width, img.height);
    if w < 3 || h < 3 {
        return Vec::new();
    }
    let mut sorted: Vec<f32> = img.data.iter().copied().filter(|v| v.is_finite()).collect();
    if sorted.is_empty() {
        return Vec::new();
    }
    sorted.sort_by(f32::total_cmp);
    let q = |p: f64| sorted[((sorted.len() - 1) as f64 * p) as usize] as f64;
    let (lo, hi) = (q(0.02), q(0.98));
    if !(hi > lo) {
        return Vec::new();
    }
    let max_area = w * h / 30;
    // Sums of x, y and radius over the levels a region was seen at, and their number.
    let mut found: Vec<(f64, f64, f64, usize)> = Vec::new();
    let mut label = vec![u32::MAX; w * h];
    let mut stack = Vec::new();
    for t in LEVELS {
        let level = (lo + t * (hi - lo)) as f32;
        let inside = |i: usize| if dark { img.data[i] < level } else { img.data[i] > level };
        label.iter_mut().for_each(|l| *l = u32::MAX);
        let mut next = 0u32;
        for start in 0..w * h {
            if label[start] != u32::MAX || !inside(start) {
                continue;
            }
            // Flood fill (4-connected), accumulating the moments.
            let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0usize, 0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
            let mut border = false;
            label[start] = next;
            stack.push(start);
            while let Some(i) = stack.pop() {
                let (x, y) = (i % w, i / w);
                n += 1;
                let (xf, yf) = (x as f64, y as f64);
                sx += xf;
                sy += yf;
                sxx += xf * xf;
                syy += yf * yf;
                sxy += xf * yf;
                border |= x == 0 || y == 0 || x == w - 1 || y == h - 1;
                for j in neighbours4(i, w, h).into_iter().flatten() {
                    if label[j] == u32::MAX && inside(j) {
                        label[j] = next;
                        stack.push(j);
                    }
                }
            }
            next += 1;
            if border || n < MIN_AREA || n > max_area {
                continue;
            }
            let nf = n as f64;
            let (cx, cy) = (sx / nf, sy / nf);
            // Central second moments (a pixel is a unit square: + 1/12 each axis).
            let (mxx, myy, mxy) = (sxx / nf - cx * cx + 1.0 / 12.0, syy / nf - cy * cy + 1.0 / 12.0, sxy / nf - cx * cy);
            let tr = mxx + myy;
            let disc = ((mxx - myy).powi(2) + 4.0 * mxy * mxy).sqrt();
            let (l1, l2) = (0.5 * (tr + disc), 0.5 * (tr - disc));
            if !(l2 > 0.0) || l2 < 0.09 * l1 {
                continue; // an axis ratio below 0.3
            }
            // An ellipse of semi-axes a, b has moments a²/4, b²/4 and area πab.
            let ellipse_area = std::f64::consts::PI * 4.0 * (l1 * l2).sqrt();
            let fill = nf / ellipse_area;
            if !(0.85..=1.15).contains(&fill) {
                continue;
            }
            let r = (nf / std::f64::consts::PI).sqrt();
            // The same disc at another level: the centres and radii are averaged over the levels.
            match found.iter_mut().find(|f| (f.0 / f.3 as f64 - cx).hypot(f.1 / f.3 as f64 - cy) < 0.5 * (f.2 / f.3 as f64).min(r).max(1.0)) {
                Some(f) => {
                    (f.0, f.1, f.2, f.3) = (f.0 + cx, f.1 + cy, f.2 + r, f.3 + 1);
                }
                None => found.push((cx, cy, r, 1)),
            }
        }
    }
    found.sort_by_key(|f| std::cmp::Reverse(f.3));
    found
        .into_iter()
        .map(|(x, y, r, k)| {
            let n = k as f64;
            Candidate { x: x / n, y: y / n, radius_px: r / n, dark, score: n / LEVELS.len() as f64 }
        })
        .collect()
}
