//! The size-invariant circle Hough transform of Atherton & Kerbyson (Image and Vision Computing
//! 17(11), 1999) with gradient voting: every edge pixel votes along its gradient line for centres
//! at each radius r of the range, into one 2-D accumulator, with the complex weight
//! e^{iφ(r)}/r where the phase φ(r) codes log r ("phase-coded annulus"). Votes of one circle add
//! coherently at its centre whatever its radius (the 1/r makes the peak of a full circle about
//! 2π for every size), the accumulator's phase there gives the radius back, and votes of unrelated
//! edges partly cancel. Two accumulators are kept, one for dark discs on a light ground (centre
//! against the gradient) and one for light discs (centre along it).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::Image;

/// Radius range and thresholds of the transform.
#[derive(Clone, Copy, Debug)]
pub struct HoughSettings {
    /// Smallest radius looked for (pixels, ≥ 2).
    pub radius_min_px: f64,
    /// Largest radius looked for (pixels).
    pub radius_max_px: f64,
    /// Minimum peak score (the coherent vote at the centre / 2π; a whole sharp circle scores about
    /// 1, noise and half circles less).
    pub min_score: f64,
    /// Most candidates returned (strongest first).
    pub max_candidates: usize,
    /// Only dark discs on a light ground (`Some(true)`), only light discs on a dark one
    /// (`Some(false)`), or both (`None`); one polarity costs half the votes.
    pub dark: Option<bool>,
}

impl Default for HoughSettings {
    fn default() -> Self {
        HoughSettings { radius_min_px: 3.0, radius_max_px: 60.0, min_score: 0.25, max_candidates: 400, dark: None }
    }
}

/// A circle candidate: centre to the accumulator cell (pixels), radius from the vote's phase.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Centre x (pixels, OpenCV convention).
    pub x: f64,
    /// Centre y (pixels).
    pub y: f64,
    /// Radius (pixels).
    pub radius_px: f64,
    /// A dark disc on a light ground (else light on dark).
    pub dark: bool,
    /// Peak score (see [`HoughSettings::min_score`]).
    pub score: f64,
}

/// Fraction of a full turn spanned by the phase code over the radius range (below 1, so that the
/// smallest and largest radii do not share a phase).
const PHASE_SPAN: f64 = 0.8 * std::f64::consts::TAU;

/// Image gradient: Sobel (÷ 8, per pixel) of the image smoothed by the binomial [1 2 1]/4 along
/// both axes. Zero on the one-pixel border.
pub fn gradient(img: &Image) -> (Vec<f32>, Vec<f32>) {
    let (w, h) = (img.width, img.height);
    let mut tmp = vec![0f32; w * h];
    let mut sm = vec![0f32; w * h];
    let at = |d: &[f32], x: usize, y: usize| d[y * w + x];
    for y in 0..h {
        for x in 0..w {
            let (l, r) = (x.saturating_sub(1), (x + 1).min(w - 1));
            tmp[y * w + x] = 0.25 * (at(&img.data, l, y) + 2.0 * at(&img.data, x, y) + at(&img.data, r, y));
        }
    }
    for y in 0..h {
        let (u, d) = (y.saturating_sub(1), (y + 1).min(h - 1));
        for x in 0..w {
            sm[y * w + x] = 0.25 * (at(&tmp, x, u) + 2.0 * at(&tmp, x, y) + at(&tmp, x, d));
        }
    }
    let mut gx = vec![0f32; w * h];
    let mut gy = vec![0f32; w * h];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w - 1 {
            let p = |dx: isize, dy: isize| sm[(y as isize + dy) as usize * w + (x as isize + dx) as usize];
            gx[y * w + x] = (p(1, -1) + 2.0 * p(1, 0) + p(1, 1) - p(-1, -1) - 2.0 * p(-1, 0) - p(-1, 1)) / 8.0;
            gy[y * w + x] = (p(-1, 1) + 2.0 * p(0, 1) + p(1, 1) - p(-1, -1) - 2.0 * p(0, -1) - p(1, -1)) / 8.0;
        }
    }
    (gx, gy)
}

/// Circle candidates of `img`, strongest first, at most one per polarity within half the smaller
/// radius of a stronger one.
pub fn candidates(img: &Image, s: &HoughSettings) -> Vec<Candidate> {
    let (w, h) = (img.width, img.height);
    if w < 3 || h < 3 {
        return Vec::new();
    }
    let (gx, gy) = gradient(img);
    let mag: Vec<f32> = gx.iter().zip(&gy).map(|(a, b)| a.hypot(*b)).collect();
    // Edge pixels: above 6× the median magnitude (the noise of flat regions) and 5 % of the
    // strongest edge.
    let mut sorted = mag.clone();
    let mid = sorted.len() / 2;
    let median = *sorted.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    let max = mag.iter().cloned().fold(0f32, f32::max);
    if !(max > 0.0) {
        return Vec::new();
    }
    let thr = (6.0 * median).max(0.05 * max);
    let (r0, r1) = (s.radius_min_px.max(2.0), s.radius_max_px.max(s.radius_min_px.max(2.0) + 1.0));
    let log_span = (r1 / r0).ln();
    let steps = ((r1 - r0) / 0.5).ceil() as usize + 1;
    let radii: Vec<(f64, f64, f64)> = (0..steps)
        .map(|k| {
            let r = r0 + (r1 - r0) * k as f64 / (steps - 1).max(1) as f64;
            let phi = PHASE_SPAN * (r / r0).ln() / log_span;
            (r, phi.cos() / r, phi.sin() / r)
        })
        .collect();
    // Accumulators (re, im) for dark and light discs, bilinear splatting; only the polarities
    // asked for are allocated.
    let wanted = |pol: usize| !s.dark.is_some_and(|d| d != (pol == 0));
    let mut acc = [if wanted(0) { vec![[0f64; 2]; w * h] } else { Vec::new() }, if wanted(1) { vec![[0f64; 2]; w * h] } else { Vec::new() }];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            if mag[i] <= thr {
                continue;
            }
            let (dx, dy) = (gx[i] as f64 / mag[i] as f64, gy[i] as f64 / mag[i] as f64);
            for (pol, sign) in [(0usize, -1.0), (1, 1.0)] {
                if !wanted(pol) {
                    continue;
                }
                for &(r, c, sn) in &radii {
                    let (cx, cy) = (x as f64 + sign * r * dx, y as f64 + sign * r * dy);
                    // Truncation is the floor for cx, cy ≥ 0 (no libm call on baseline x86-64);
                    // NaN fails the first test.
                    if !(cx >= 0.0 && cy >= 0.0) {
                        continue;
                    }
                    let (ix, iy) = (cx as usize, cy as usize);
                    if ix >= w - 1 || iy >= h - 1 {
                        continue;
                    }
                    let (fx, fy) = (ix as f64, iy as f64);
                    let (ax, ay) = (cx - fx, cy - fy);
                    let j = iy * w + ix;
                    for (k, wt) in [(j, (1.0 - ax) * (1.0 - ay)), (j + 1, ax * (1.0 - ay)), (j + w, (1.0 - ax) * ay), (j + w + 1, ax * ay)] {
                        acc[pol][k][0] += wt * c;
                        acc[pol][k][1] += wt * sn;
                    }
                }
            }
        }
    }
    let mut out = Vec::new();
    for (pol, a) in acc.iter().enumerate() {
        if !wanted(pol) {
            continue;
        }
        // Coherent 3×3 sums.
        let mut s3 = vec![[0f64; 2]; w * h];
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let mut z = [0.0, 0.0];
                for dy in 0..3 {
                    for dx in 0..3 {
                        let v = a[(y + dy - 1) * w + x + dx - 1];
                        z[0] += v[0];
                        z[1] += v[1];
                    }
                }
                s3[y * w + x] = z;
            }
        }
        let m: Vec<f64> = s3.iter().map(|z| z[0].hypot(z[1]) / std::f64::consts::TAU).collect();
        for y in 2..h.saturating_sub(2) {
            for x in 2..w - 2 {
                let v = m[y * w + x];
                if v < s.min_score {
                    continue;
                }
                // Local maximum over 5×5 (ties broken by raster order).
                let mut is_max = true;
                'n: for dy in -2isize..=2 {
                    for dx in -2isize..=2 {
                        if dx == 0 && dy == 0 {
                            continue;
                        }
                        let j = ((y as isize + dy) as usize) * w + (x as isize + dx) as usize;
                        let before = dy < 0 || (dy == 0 && dx < 0);
                        if m[j] > v || (m[j] == v && before) {
                            is_max = false;
                            break 'n;
                        }
                    }
                }
                if !is_max {
                    continue;
                }
                let z = s3[y * w + x];
                let mut phi = z[1].atan2(z[0]);
                if phi < 0.0 {
                    phi += std::f64::consts::TAU;
                }
                // Phases beyond the span belong to the nearer end of the range.
                let gap = std::f64::consts::TAU - PHASE_SPAN;
                if phi > PHASE_SPAN {
                    phi = if phi < PHASE_SPAN + 0.5 * gap { PHASE_SPAN } else { 0.0 };
                }
                let r = r0 * (phi / PHASE_SPAN * log_span).exp();
                out.push(Candidate { x: x as f64, y: y as f64, radius_px: r, dark: pol == 0, score: v });
            }
        }
    }
    out.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut kept: Vec<Candidate> = Vec::new();
    for c in out {
        if kept.len() >= s.max_candidates {
            break;
        }
        let near = kept.iter().any(|k| k.dark == c.dark && (k.x - c.x).hypot(k.y - c.y) < 0.5 * k.radius_px.min(c.radius_px).max(2.0));
        if !near {
            kept.push(c);
        }
    }
    kept
}
