//! Chessboard inner-corner detection with sub-pixel accuracy.
//!
//! 1. **Saddle response.** The image is smoothed by a Gaussian (σ = 2 px) and the negative Hessian
//!    determinant s = I_xy² − I_xx·I_yy is taken: an X-junction of a chessboard is a saddle of the
//!    smoothed intensity (s > 0), a straight edge has one zero curvature (s ≈ 0) and a blob has
//!    s < 0 (the Hessian saddle detector of Chen & Zhang, "Chessboard corner detection by the
//!    Hessian of the image", and of libcbdetect's corner prior). Local maxima of s in an 11 × 11
//!    neighbourhood above 2 % of the image's largest response are the candidates.
//! 2. **Ring test.** Around each candidate the smoothed intensity on a circle of radius 5 px
//!    (32 samples) must alternate bright/dark/bright/dark (4 transitions about the mid level), the
//!    two dark arcs must face each other (centres π ± 0.5 rad apart, as two straight lines through
//!    the corner make them), and the contrast must exceed 10 grey levels. The four transition
//!    angles are the directions of the four edges leaving the corner.
//! 3. **Lattice growth.** From a seed (strongest candidates first) its neighbours along two
//!    adjacent edges and the diagonal one give a 2 × 2 lattice; the lattice grows one ring at a
//!    time, each missing node predicted by a homography fitted to the assigned nodes within two
//!    steps of it and taken when a candidate lies within 0.3 of the local step. The board is found
//!    when the lattice spans exactly cols × rows (either way round) with at most 3 holes (filled by
//!    the prediction and then refined).
//! 4. **Ordering.** Row-major with `cols` corners per row, as OpenCV's `findChessboardCorners`,
//!    with OpenCV's handedness: (p[cols−1] − p[0]) × (p[cols] − p[cols−1]) > 0 in pixels (rows run
//!    left to right when the next row lies below, turned with the board), which every view of the
//!    board's front shares, so that two cameras label the same physical corners alike. Where the
//!    board's two ends differ in colour (an odd number of inner corners in all, e.g. 9 × 6),
//!    corner 0 is the end whose outer square is dark, as OpenCV's detector returns it on the
//!    photographs checked (sourishg/stereo-calibration, amoghesturi/Camera-Calibration, the
//!    13 1920 × 1080 views of docs/scanning.md: every one). A board with an even × even or
//!    odd × odd square count looks the same rotated by 180°, and there corner 0 is the end nearest
//!    the image's top-left (smallest x + y).
//! 5. **Refinement** as OpenCV's `cornerSubPix`: in a window around the estimate q every
//!    gradient g at p is orthogonal to q − p at the true corner, so q solves
//!    (Σ w g gᵀ) q = Σ w g gᵀ p (Gaussian weights w), iterated with bilinearly interpolated
//!    central-difference gradients of the image blurred by σ = 1 px until the step is below 10⁻³ px.
//!    An ideal X-junction is point-symmetric about its centre whatever the angle between its
//!    lines, so the fixed point is the centre up to interpolation error.
//! 6. **Scale.** The scales above are fixed in pixels (σ = 2, a ring of 5 px); where the image
//!    gives no board, its halves (2 × 2 means) are searched down to 160 px on the short side and
//!    the corners found there are refined in the full image (5-Mpixel photographs of squares of
//!    75–120 px, or a board enlarged twice, are found at a coarser level).
//! 7. **Check.** The refined corners must form a smooth lattice (each within a quarter of the
//!    half-spacing of its neighbours' midpoint along rows and columns, the end corners within 0.4
//!    of a spacing of the extrapolation from the next two); otherwise that level gives no board.
//!
//! Pixel convention: OpenCV's (integer coordinates at pixel centres).

use super::homography::{apply, fit_homography_fast, Point2};
use anyhow::{anyhow, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// A greyscale image, row-major, 8-bit grey levels as f32.
#[derive(Clone, Debug)]
pub struct GrayImage {
    /// Width (pixels).
    pub width: usize,
    /// Height (pixels).
    pub height: usize,
    /// Grey levels, row-major.
    pub data: Vec<f32>,
}

impl GrayImage {
    /// Read a PNG or JPEG as grey levels (colour with OpenCV's luma weights:
    /// [`crate::decode::read_grey`]).
    pub fn load(path: &Path) -> Result<GrayImage> {
        let (width, height, grey) = crate::decode::read_grey(path)?;
        Ok(GrayImage { width, height, data: grey.into_iter().map(f32::from).collect() })
    }

    #[inline]
    fn px(&self, x: isize, y: isize) -> f32 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// Bilinear interpolation at (x, y) (clamped at the border).
    pub fn bilinear(&self, x: f64, y: f64) -> f64 {
        let (fx, fy) = (x.floor(), y.floor());
        let (ax, ay) = (x - fx, y - fy);
        let (ix, iy) = (fx as isize, fy as isize);
        let a = self.px(ix, iy) as f64;
        let b = self.px(ix + 1, iy) as f64;
        let c = self.px(ix, iy + 1) as f64;
        let d = self.px(ix + 1, iy + 1) as f64;
        (a * (1.0 - ax) + b * ax) * (1.0 - ay) + (c * (1.0 - ax) + d * ax) * ay
    }

    /// The image at half the resolution: each pixel the mean of a 2 × 2 block (an odd last row or
    /// column is dropped).
    pub fn half(&self) -> GrayImage {
        let (w, h) = (self.width / 2, self.height / 2);
        let mut data = Vec::with_capacity(w * h);
        for y in 0..h {
            let (r0, r1) = (&self.data[2 * y * self.width..], &self.data[(2 * y + 1) * self.width..]);
            for x in 0..w {
                data.push(0.25 * (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1]));
            }
        }
        GrayImage { width: w, height: h, data }
    }

    /// The `width` × `height` pixels from (x0, y0) on, read with the image's clamped border (so a
    /// crop reaching beyond the image repeats its edge, as [`GrayImage::blur`] does).
    pub fn crop_clamped(&self, x0: isize, y0: isize, width: usize, height: usize) -> GrayImage {
        let mut data = Vec::with_capacity(width * height);
        if x0 >= 0 && y0 >= 0 && x0 as usize + width <= self.width && y0 as usize + height <= self.height {
            // Inside the image: row copies.
            for y in 0..height {
                let start = (y0 as usize + y) * self.width + x0 as usize;
                data.extend_from_slice(&self.data[start..start + width]);
            }
            return GrayImage { width, height, data };
        }
        for y in 0..height as isize {
            for x in 0..width as isize {
                data.push(self.px(x0 + x, y0 + y));
            }
        }
        GrayImage { width, height, data }
    }

    /// Gaussian blur of standard deviation `sigma` pixels (separable, kernel ±3σ, clamped border).
    pub fn blur(&self, sigma: f64) -> GrayImage {
        let r = (3.0 * sigma).ceil() as isize;
        let k: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32).collect();
        let sum: f32 = k.iter().sum();
        let k: Vec<f32> = k.iter().map(|v| v / sum).collect();
        let (w, h) = (self.width, self.height);
        // Horizontal pass: each pixel sums its taps (clamped at the borders); in the interior the
        // taps run in the outer loop, so that the inner one is a vectorisable multiply-add along
        // the row.
        let mut tmp = vec![0f32; w * h];
        let ri = r as usize;
        for (y, row_out) in tmp.chunks_exact_mut(w).enumerate() {
            let row = &self.data[y * w..(y + 1) * w];
            // The centre tap, then the pairs at ±d (the interior's order of operations).
            let clamped = |x: usize| -> f32 {
                let mut s = k[ri] * row[x];
                for d in 1..=ri {
                    s += k[ri + d] * (row[x.saturating_sub(d)] + row[(x + d).min(w - 1)]);
                }
                s
            };
            if w > 2 * ri {
                // The kernel is symmetric: the taps at ±d share one multiply.
                let n = w - 2 * ri;
                for (o, &v) in row_out[ri..w - ri].iter_mut().zip(&row[ri..ri + n]) {
                    *o = k[ri] * v;
                }
                for d in 1..=ri {
                    let (lo, hi) = (&row[ri - d..ri - d + n], &row[ri + d..ri + d + n]);
                    for ((o, &a), &b) in row_out[ri..w - ri].iter_mut().zip(lo).zip(hi) {
                        *o += k[ri + d] * (a + b);
                    }
                }
                for x in (0..ri).chain(w - ri..w) {
                    row_out[x] = clamped(x);
                }
            } else {
                for (x, o) in row_out.iter_mut().enumerate() {
                    *o = clamped(x);
                }
            }
        }
        // Vertical pass: the same taps, accumulated a row at a time.
        let mut out = vec![0f32; w * h];
        let row_at = |y: isize| -> &[f32] {
            let yy = y.clamp(0, h as isize - 1) as usize;
            &tmp[yy * w..(yy + 1) * w]
        };
        for (y, row_out) in out.chunks_exact_mut(w).enumerate() {
            let y = y as isize;
            for (o, &v) in row_out.iter_mut().zip(row_at(y)) {
                *o = k[ri] * v;
            }
            for d in 1..=r {
                let kv = k[ri + d as usize];
                for ((o, &a), &b) in row_out.iter_mut().zip(row_at(y - d)).zip(row_at(y + d)) {
                    *o += kv * (a + b);
                }
            }
        }
        GrayImage { width: w, height: h, data: out }
    }
}

/// A corner candidate.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    p: Point2,
    response: f32,
    /// Directions of the four edges leaving the corner (radians, increasing).
    edges: [f64; 4],
}

/// Saddle-response local maxima that pass the ring test.
fn candidates(smooth: &GrayImage) -> Vec<Candidate> {
    let (w, h) = (smooth.width, smooth.height);
    let mut s = vec![0f32; w * h];
    let mut smax = 0f32;
    for y in 1..h.saturating_sub(1) {
        // Rows y − 1, y, y + 1 as slices, so that the loop runs without bounds checks.
        let d = &smooth.data;
        let (up, row, down) = (&d[(y - 1) * w..y * w], &d[y * w..(y + 1) * w], &d[(y + 1) * w..(y + 2) * w]);
        let out = &mut s[y * w..(y + 1) * w];
        for x in 1..w.saturating_sub(1) {
            let c = row[x];
            let ixx = row[x + 1] - 2.0 * c + row[x - 1];
            let iyy = down[x] - 2.0 * c + up[x];
            let ixy = 0.25 * (down[x + 1] - down[x - 1] - up[x + 1] + up[x - 1]);
            let v = ixy * ixy - ixx * iyy;
            out[x] = v;
            smax = smax.max(v);
        }
    }
    let thr = 0.02 * smax;
    let nms = 5isize;
    let mut out = Vec::new();
    for y in 6..h.saturating_sub(6) {
        'px: for x in 6..w.saturating_sub(6) {
            let v = s[y * w + x];
            if !(v > thr) {
                continue;
            }
            // The 3 × 3 neighbours first (most pixels above the threshold lie on a peak's flank
            // and fail there), then the whole window; the same test, in a cheaper order.
            for dy in -1..=1isize {
                for dx in -1..=1isize {
                    let j = (y as isize + dy) as usize * w + (x as isize + dx) as usize;
                    if s[j] > v || (s[j] == v && j < y * w + x) {
                        continue 'px;
                    }
                }
            }
            for dy in -nms..=nms {
                for dx in -nms..=nms {
                    let j = (y as isize + dy) as usize * w + (x as isize + dx) as usize;
                    if s[j] > v || (s[j] == v && j < y * w + x) {
                        continue 'px;
                    }
                }
            }
            if let Some(edges) = ring_test(smooth, x as f64, y as f64) {
                out.push(Candidate { p: [x as f64, y as f64], response: v, edges });
            }
        }
    }
    out
}

/// The X-junction test on a circle of radius 5 px; the four edge directions when it passes.
fn ring_test(img: &GrayImage, x: f64, y: f64) -> Option<[f64; 4]> {
    const N: usize = 32;
    const R: f64 = 5.0;
    let ang = |k: f64| k * std::f64::consts::TAU / N as f64;
    // The circle's offsets, computed once.
    static RING: std::sync::OnceLock<[(f64, f64); N]> = std::sync::OnceLock::new();
    let ring = RING.get_or_init(|| std::array::from_fn(|k| (R * ang(k as f64).cos(), R * ang(k as f64).sin())));
    let v: Vec<f64> = ring.iter().map(|&(dx, dy)| img.bilinear(x + dx, y + dy)).collect();
    let (lo, hi) = v.iter().fold((f64::MAX, f64::MIN), |a, &b| (a.0.min(b), a.1.max(b)));
    if !(hi - lo > 10.0) {
        return None;
    }
    let mid = 0.5 * (lo + hi);
    let b: Vec<bool> = v.iter().map(|&t| t > mid).collect();
    // Transitions k → k+1 and their interpolated angles.
    let mut tr = Vec::new();
    for k in 0..N {
        let k1 = (k + 1) % N;
        if b[k] != b[k1] {
            let f = (mid - v[k]) / (v[k1] - v[k]);
            tr.push((k, ang(k as f64 + f)));
        }
    }
    if tr.len() != 4 {
        return None;
    }
    // Arc lengths (samples) between transitions: each ≥ 3.
    for i in 0..4 {
        let a = tr[i].0;
        let b2 = tr[(i + 1) % 4].0;
        let len = (b2 + N - a) % N;
        if len < 3 {
            return None;
        }
    }
    // Dark arcs face each other: arc centres π apart.
    let mut centres = Vec::new();
    for i in 0..4 {
        let a0 = tr[i].1;
        let mut a1 = tr[(i + 1) % 4].1;
        if a1 < a0 {
            a1 += std::f64::consts::TAU;
        }
        let dark = !b[(tr[i].0 + 1) % N];
        centres.push((dark, 0.5 * (a0 + a1)));
    }
    let d: Vec<f64> = centres.iter().filter(|c| c.0).map(|c| c.1).collect();
    let b2: Vec<f64> = centres.iter().filter(|c| !c.0).map(|c| c.1).collect();
    for pair in [d, b2] {
        if pair.len() != 2 {
            return None;
        }
        let diff = (pair[1] - pair[0]).rem_euclid(std::f64::consts::TAU);
        if (diff - std::f64::consts::PI).abs() > 0.5 {
            return None;
        }
    }
    Some([tr[0].1, tr[1].1, tr[2].1, tr[3].1])
}

fn dist(a: Point2, b: Point2) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// The nearest candidate along direction `angle` from `c` (within 0.25 rad), at 4–(max) px.
fn along(cands: &[Candidate], c: usize, angle: f64) -> Option<usize> {
    let p = cands[c].p;
    let mut best: Option<(usize, f64)> = None;
    for (i, q) in cands.iter().enumerate() {
        if i == c {
            continue;
        }
        let (dx, dy) = (q.p[0] - p[0], q.p[1] - p[1]);
        let r = (dx * dx + dy * dy).sqrt();
        if r < 4.0 {
            continue;
        }
        let da = (dy.atan2(dx) - angle + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        if da.abs() < 0.25 && best.map_or(true, |b| r < b.1) {
            best = Some((i, r));
        }
    }
    best.map(|b| b.0)
}

fn nearest(cands: &[Candidate], p: Point2) -> Option<(usize, f64)> {
    cands.iter().enumerate().map(|(i, c)| (i, dist(c.p, p))).min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Grow a lattice from seed candidate `s`; lattice coordinates → position (candidate or predicted).
fn grow(cands: &[Candidate], s: usize, cols: usize, rows: usize) -> Option<BTreeMap<(i32, i32), Point2>> {
    let e = cands[s].edges;
    // Two extra rows and columns of room, so that a larger board is seen as larger and refused.
    let maxext = cols.max(rows) as i32 + 2;
    for k in 0..4 {
        let (Some(n1), Some(n2)) = (along(cands, s, e[k]), along(cands, s, e[(k + 1) % 4])) else { continue };
        let (p0, p1, p2) = (cands[s].p, cands[n1].p, cands[n2].p);
        let pd = [p1[0] + p2[0] - p0[0], p1[1] + p2[1] - p0[1]];
        let step = dist(p0, p1).min(dist(p0, p2));
        let Some((n3, d3)) = nearest(cands, pd) else { continue };
        if d3 > 0.3 * step {
            continue;
        }
        let mut at: BTreeMap<(i32, i32), usize> = BTreeMap::new();
        let mut used = vec![false; cands.len()];
        for (ij, c) in [((0, 0), s), ((1, 0), n1), ((0, 1), n2), ((1, 1), n3)] {
            at.insert(ij, c);
            used[c] = true;
        }
        loop {
            let (imin, imax, jmin, jmax) = extent(at.keys());
            let mut frontier: Vec<(i32, i32)> = Vec::new();
            for &(i, j) in at.keys() {
                for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                    let q = (i + di, j + dj);
                    let ni = imax.max(q.0) - imin.min(q.0) + 1;
                    let nj = jmax.max(q.1) - jmin.min(q.1) + 1;
                    if !at.contains_key(&q) && ni <= maxext && nj <= maxext && !frontier.contains(&q) {
                        frontier.push(q);
                    }
                }
            }
            // Each frontier node's nearest candidate to its prediction; where two nodes want one
            // candidate, the nearer prediction (relative to the local step) takes it.
            let mut claims: Vec<(f64, (i32, i32), usize)> = frontier
                .into_iter()
                .filter_map(|q| {
                    let (pred, step) = predict(cands, &at, q)?;
                    let (c, d) = nearest(cands, pred)?;
                    (d < 0.3 * step).then_some((d / step, q, c))
                })
                .collect();
            claims.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let mut added = 0;
            for (_, q, c) in claims {
                if !used[c] {
                    at.insert(q, c);
                    used[c] = true;
                    added += 1;
                }
            }
            if added == 0 {
                break;
            }
        }
        // The board is the cols × rows window (either way round) holding the most nodes; nodes
        // outside it (isolated X-like features in line with the lattice) are dropped.
        let (imin, imax, jmin, jmax) = extent(at.keys());
        let mut best: Option<(usize, i32, i32, usize, usize)> = None;
        for (wi, wj) in [(cols, rows), (rows, cols)] {
            for i0 in imin..=(imax - wi as i32 + 1) {
                for j0 in jmin..=(jmax - wj as i32 + 1) {
                    let n = at.keys().filter(|k| k.0 >= i0 && k.0 < i0 + wi as i32 && k.1 >= j0 && k.1 < j0 + wj as i32).count();
                    if best.map_or(true, |b| n > b.0) {
                        best = Some((n, i0, j0, wi, wj));
                    }
                }
            }
        }
        let Some((count, imin, jmin, ni, nj)) = best else { continue };
        // At most 3 holes inside the window and 3 stray nodes outside it (a larger board has a
        // whole row or column outside).
        if count + 3 < cols * rows || at.len() > count + 3 {
            continue;
        }
        at.retain(|k, _| k.0 >= imin && k.0 < imin + ni as i32 && k.1 >= jmin && k.1 < jmin + nj as i32);
        let mut out: BTreeMap<(i32, i32), Point2> = at.iter().map(|(&k, &c)| ((k.0 - imin, k.1 - jmin), cands[c].p)).collect();
        for i in 0..ni as i32 {
            for j in 0..nj as i32 {
                if !out.contains_key(&(i, j)) {
                    let (p, _) = predict(cands, &at, (i + imin, j + jmin))?;
                    out.insert((i, j), p);
                }
            }
        }
        return Some(out);
    }
    None
}

fn extent<'a>(keys: impl Iterator<Item = &'a (i32, i32)>) -> (i32, i32, i32, i32) {
    keys.fold((i32::MAX, i32::MIN, i32::MAX, i32::MIN), |a, k| (a.0.min(k.0), a.1.max(k.0), a.2.min(k.1), a.3.max(k.1)))
}

/// Position predicted for lattice node `q` by a homography of the assigned nodes within two
/// steps (all nodes when fewer than 6 are near), and the local step length (pixels).
fn predict(cands: &[Candidate], at: &BTreeMap<(i32, i32), usize>, q: (i32, i32)) -> Option<(Point2, f64)> {
    let mut near: Vec<(Point2, Point2)> = at.iter().filter(|(k, _)| (k.0 - q.0).abs() <= 2 && (k.1 - q.1).abs() <= 2).map(|(k, &c)| ([k.0 as f64, k.1 as f64], cands[c].p)).collect();
    if near.len() < 6 {
        near = at.iter().map(|(k, &c)| ([k.0 as f64, k.1 as f64], cands[c].p)).collect();
    }
    let (src, dst): (Vec<Point2>, Vec<Point2>) = near.into_iter().unzip();
    let h = fit_homography_fast(&src, &dst)?;
    let qf = [q.0 as f64, q.1 as f64];
    let p = apply(&h, qf);
    let px = apply(&h, [qf[0] + 1.0, qf[1]]);
    let py = apply(&h, [qf[0], qf[1] + 1.0]);
    let step = dist(p, px).min(dist(p, py));
    (p[0].is_finite() && p[1].is_finite()).then_some((p, step))
}

/// Row-major ordering with `cols` per row, OpenCV's handedness, and corner 0 by the module's
/// rule (step 4): the dark outer square where the board's colours tell its ends apart, otherwise
/// nearest the image's top-left. `smooth` is the image the colours are read from.
fn order(grid: &BTreeMap<(i32, i32), Point2>, cols: usize, rows: usize, smooth: &GrayImage) -> Vec<Point2> {
    let (_, imax, _, _) = extent(grid.keys());
    let ni = (imax + 1) as usize;
    let mut labelings: Vec<Vec<Point2>> = Vec::with_capacity(8);
    for transpose in [false, true] {
        if (ni == cols) == transpose && cols != rows {
            continue;
        }
        for flip_c in [false, true] {
            for flip_r in [false, true] {
                let mut v = Vec::with_capacity(cols * rows);
                for r in 0..rows {
                    for c in 0..cols {
                        let c2 = if flip_c { cols - 1 - c } else { c } as i32;
                        let r2 = if flip_r { rows - 1 - r } else { r } as i32;
                        v.push(grid[&if transpose { (r2, c2) } else { (c2, r2) }]);
                    }
                }
                labelings.push(v);
            }
        }
    }
    // OpenCV's handedness: (p[cols−1] − p[0]) × (p[cols] − p[cols−1]) > 0 (rows run left to right
    // when the next row lies below), the same for every view of the board's front.
    if rows > 1 && cols > 1 {
        let hand = |v: &Vec<Point2>| {
            let (p0, p1, p2) = (v[0], v[cols - 1], v[cols]);
            (p1[0] - p0[0]) * (p2[1] - p1[1]) - (p1[1] - p0[1]) * (p2[0] - p1[0])
        };
        // (A lattice with no labeling of either sign, degenerate, keeps them all.)
        if labelings.iter().any(|v| hand(v) > 0.0) {
            labelings.retain(|v| hand(v) > 0.0);
        }
    }
    // The colour of the square outside corner 0 where the board's ends differ in colour (cols +
    // rows odd) and the image shows it by more than half the board's contrast: the dark one first.
    // The square is read in its quarter next to the corner (centre a quarter diagonal out, a
    // quarter of its area): a board's outer squares are often cut short by its edge, and their
    // middle may be the margin (OpenCV's samples/data left07, left08, right08).
    if rows > 1 && cols > 1 && (cols + rows) % 2 == 1 {
        let outer = |v: &Vec<Point2>| {
            let (p0, a, d) = (v[0], sub(v[1], v[0]), sub(v[cols], v[0]));
            let (ha, hd) = ([0.5 * a[0], 0.5 * a[1]], [0.5 * d[0], 0.5 * d[1]]);
            square_level(smooth, [p0[0] - 0.25 * (a[0] + d[0]), p0[1] - 0.25 * (a[1] + d[1])], ha, hd)
        };
        let levels: Vec<Option<f64>> = labelings.iter().map(outer).collect();
        if let Some(levels) = levels.iter().copied().collect::<Option<Vec<f64>>>() {
            let (lo, hi) = levels.iter().fold((f64::MAX, f64::MIN), |(a, b), &l| (a.min(l), b.max(l)));
            let v = &labelings[0];
            let (a, d) = (sub(v[1], v[0]), sub(v[cols], v[0]));
            // Two adjacent inner squares give the board's contrast.
            let centre = |p: Point2| [p[0] + 0.5 * (a[0] + d[0]), p[1] + 0.5 * (a[1] + d[1])];
            let contrast = match (square_level(smooth, centre(v[0]), a, d), square_level(smooth, centre(v[1]), a, d)) {
                (Some(x), Some(y)) => (x - y).abs(),
                _ => 0.0,
            };
            if hi - lo > 0.5 * contrast && contrast > 0.0 {
                let mid = 0.5 * (lo + hi);
                let keep: Vec<bool> = levels.iter().map(|&l| l < mid).collect();
                let mut k = keep.iter();
                labelings.retain(|_| *k.next().unwrap());
            }
        }
    }
    // Of what is left, corner 0 nearest the image's top-left (smallest x + y).
    let mut best: Option<(f64, f64, Vec<Point2>)> = None;
    for v in labelings {
        let key = v[0][0] + v[0][1];
        let tie = v[1][1] - v[1][0];
        if best.as_ref().map_or(true, |b| key < b.0 - 1e-9 || (key < b.0 + 1e-9 && tie < b.1)) {
            best = Some((key, tie, v));
        }
    }
    best.expect("a lattice has a labeling of either handedness").2
}

fn sub(a: Point2, b: Point2) -> Point2 {
    [a[0] - b[0], a[1] - b[1]]
}

/// The mean grey level over the middle of the square centred at `c` with edge vectors `a`, `d`
/// (a 5 × 5 grid over its central half); None when that part leaves the image.
fn square_level(img: &GrayImage, c: Point2, a: Point2, d: Point2) -> Option<f64> {
    let mut sum = 0.0;
    for i in -2..=2 {
        for j in -2..=2 {
            let (u, v) = (i as f64 / 8.0, j as f64 / 8.0);
            let (x, y) = (c[0] + u * a[0] + v * d[0], c[1] + u * a[1] + v * d[1]);
            if !(x >= 0.0 && y >= 0.0 && x <= (img.width - 1) as f64 && y <= (img.height - 1) as f64) {
                return None;
            }
            sum += img.bilinear(x, y);
        }
    }
    Some(sum / 25.0)
}

/// Sub-pixel refinement of `corners` (OpenCV `cornerSubPix`) on the image blurred by σ = 1 px
/// (which makes the bilinearly interpolated gradients nearly isotropic: on the synthetic board of
/// the `chessboard` tests the worst error drops from 0.087 to 0.034 px): window half-size `half` pixels,
/// until the step is below `eps` px or after `iterations` steps. A corner that would leave its
/// window keeps its start position, as does one whose iterate strays more than 2 `half` from it.
///
/// The blurred image and its gradients are needed only near the corners: where the corners'
/// windows cover less than the image, each corner is refined in a crop around it wide enough
/// that every value an iterate within 2 `half` of its start reads equals the whole image's
/// (`corner_subpix_in_crops_is_exact`).
pub fn corner_subpix(img: &GrayImage, corners: &mut [Point2], half: usize, iterations: usize, eps: f64) {
    corner_subpix_blurred(img, corners, half, iterations, eps, 1.0);
}

/// [`corner_subpix`] on the image blurred by a Gaussian of `sigma` pixels (0: the image as it
/// is, as OpenCV's `cornerSubPix` reads it). Where other edges lie within a few pixels of the
/// corner (the markers of a ChArUco board with small squares), the blur would carry them into
/// the window.
pub fn corner_subpix_blurred(img: &GrayImage, corners: &mut [Point2], half: usize, iterations: usize, eps: f64, sigma: f64) {
    corner_subpix_masked(img, corners, half, iterations, eps, sigma, &|_, _| true);
}

/// [`corner_subpix_blurred`] reading only the window's samples at which `keep(x, y)` (image
/// pixels) holds: other edges near the corner (a ChArUco board's markers) are left out of the
/// window instead of shrinking it.
pub fn corner_subpix_masked<F: Fn(f64, f64) -> bool>(img: &GrayImage, corners: &mut [Point2], half: usize, iterations: usize, eps: f64, sigma: f64, keep: &F) {
    let smooth = |g: &GrayImage| if sigma > 0.0 { g.blur(sigma) } else { g.clone() };
    // Reads reach 2·half (the iterate) + half (the window) + 1 (bilinear) + 1 (central difference)
    // + 3 (the blur's support) + 1 (rounding of the crop's centre) from a corner's start.
    let margin = 3 * half + 3 + 3 * (sigma.ceil() as usize).max(1);
    let side = 2 * margin + 1;
    if corners.len() * side * side >= img.width * img.height {
        corner_subpix_inner(&smooth(img), corners, half, iterations, eps, keep);
        return;
    }
    for c in corners.iter_mut() {
        if !(c[0].is_finite() && c[1].is_finite()) {
            continue;
        }
        let (x0, y0) = (c[0].round() as isize - margin as isize, c[1].round() as isize - margin as isize);
        let crop = img.crop_clamped(x0, y0, side, side);
        let mut local = [[c[0] - x0 as f64, c[1] - y0 as f64]];
        let (ox, oy) = (x0 as f64, y0 as f64);
        corner_subpix_inner(&smooth(&crop), &mut local, half, iterations, eps, &|x, y| keep(x + ox, y + oy));
        *c = [local[0][0] + x0 as f64, local[0][1] + y0 as f64];
    }
}

fn corner_subpix_inner<F: Fn(f64, f64) -> bool>(img: &GrayImage, corners: &mut [Point2], half: usize, iterations: usize, eps: f64, keep: &F) {
    let (w, h) = (img.width, img.height);
    let mut gx = GrayImage { width: w, height: h, data: vec![0.0; w * h] };
    let mut gy = gx.clone();
    // Central differences, the border's with the clamped neighbour.
    for y in 0..h {
        let (up, down) = (y.saturating_sub(1), (y + 1).min(h - 1));
        let (row, rup, rdown) = (&img.data[y * w..(y + 1) * w], &img.data[up * w..(up + 1) * w], &img.data[down * w..(down + 1) * w]);
        let (ox, oy) = (&mut gx.data[y * w..(y + 1) * w], &mut gy.data[y * w..(y + 1) * w]);
        for x in 0..w {
            let (l, r) = (x.saturating_sub(1), (x + 1).min(w - 1));
            ox[x] = 0.5 * (row[r] - row[l]);
            oy[x] = 0.5 * (rdown[x] - rup[x]);
        }
    }
    let hw = half as isize;
    let sig2 = (half as f64 * 0.5).powi(2).max(1.0);
    // The window's Gaussian weights, row-major over (dy, dx).
    let weights: Vec<f64> = (-hw..=hw).flat_map(|dy| (-hw..=hw).map(move |dx| (-((dx * dx + dy * dy) as f64) / (2.0 * sig2)).exp())).collect();
    for c in corners.iter_mut() {
        let start = *c;
        let mut q = *c;
        let stray = 2.0 * half as f64;
        for _ in 0..iterations {
            if (q[0] - start[0]).abs() > stray || (q[1] - start[1]).abs() > stray {
                break;
            }
            let (mut a, mut b, mut d, mut bx, mut by) = (0.0, 0.0, 0.0, 0.0, 0.0);
            let (fx, fy) = (q[0].floor(), q[1].floor());
            let (ix, iy) = (fx as isize, fy as isize);
            let mut acc = |wt: f64, px: f64, py: f64, u: f64, v: f64| {
                let (guu, guv, gvv) = (wt * u * u, wt * u * v, wt * v * v);
                a += guu;
                b += guv;
                d += gvv;
                bx += guu * px + guv * py;
                by += guv * px + gvv * py;
            };
            if ix - hw >= 0 && iy - hw >= 0 && ix + hw + 1 < w as isize && iy + hw + 1 < h as isize {
                // The whole window inside: every sample shares q's fractional offset, so the
                // bilinear weights are the same for all (no clamping, no floor per sample).
                let (ax, ay) = (q[0] - fx, q[1] - fy);
                let mut k = 0;
                for dy in -hw..=hw {
                    let i0 = (iy + dy) as usize * w;
                    for dx in -hw..=hw {
                        let i = i0 + (ix + dx) as usize;
                        let bil = |g: &[f32]| {
                            let (p00, p10, p01, p11) = (g[i] as f64, g[i + 1] as f64, g[i + w] as f64, g[i + w + 1] as f64);
                            (p00 * (1.0 - ax) + p10 * ax) * (1.0 - ay) + (p01 * (1.0 - ax) + p11 * ax) * ay
                        };
                        let (px, py) = (q[0] + dx as f64, q[1] + dy as f64);
                        if keep(px, py) {
                            acc(weights[k], px, py, bil(&gx.data), bil(&gy.data));
                        }
                        k += 1;
                    }
                }
            } else {
                let mut k = 0;
                for dy in -hw..=hw {
                    for dx in -hw..=hw {
                        let (px, py) = (q[0] + dx as f64, q[1] + dy as f64);
                        if keep(px, py) {
                            acc(weights[k], px, py, gx.bilinear(px, py), gy.bilinear(px, py));
                        }
                        k += 1;
                    }
                }
            }
            let det = a * d - b * b;
            if !(det.abs() > 1e-12 * (a * d).abs().max(1e-300)) {
                break;
            }
            let nq = [(d * bx - b * by) / det, (a * by - b * bx) / det];
            let step = dist(nq, q);
            q = nq;
            if step < eps {
                break;
            }
        }
        if dist(q, start) <= half as f64 && q[0].is_finite() && q[1].is_finite() {
            *c = q;
        }
    }
}

/// Find the `cols` × `rows` inner corners of a chessboard, row-major, refined to sub-pixel
/// accuracy; None when no such lattice is found. Where the image itself gives none, its halves
/// are searched in turn (2 × 2 means, down to 160 pixels on the short side: the detector's
/// scales are fixed in pixels, so large or soft squares are found at a coarser level) and the
/// corners found there are refined again in the full image.
pub fn find_chessboard(img: &GrayImage, cols: usize, rows: usize) -> Option<Vec<Point2>> {
    if let Some(c) = find_at_scale(img, cols, rows) {
        return Some(c);
    }
    let mut level = img.clone();
    let mut scale = 1.0;
    while level.width.min(level.height) >= 320 {
        level = level.half();
        scale *= 2.0;
        if let Some(c) = find_at_scale(&level, cols, rows) {
            // A pixel centre x of the half image lies at 2x + 0.5 in the full one.
            let mut corners: Vec<Point2> = c.iter().map(|p| [scale * p[0] + 0.5 * (scale - 1.0), scale * p[1] + 0.5 * (scale - 1.0)]).collect();
            refine(img, &mut corners, cols, rows);
            if smooth_lattice(&corners, cols, rows) {
                return Some(corners);
            }
        }
    }
    None
}

/// [`find_chessboard`] at the image's own scale.
fn find_at_scale(img: &GrayImage, cols: usize, rows: usize) -> Option<Vec<Point2>> {
    let smooth = img.blur(2.0);
    let mut cands = candidates(&smooth);
    cands.sort_by(|a, b| b.response.total_cmp(&a.response));
    let grid = cands.iter().take(40).enumerate().find_map(|(s, _)| grow(&cands, s, cols, rows))?;
    let mut corners = order(&grid, cols, rows, &smooth);
    refine(img, &mut corners, cols, rows);
    smooth_lattice(&corners, cols, rows).then_some(corners)
}

/// Whether the refined corners form a smooth lattice: each corner with neighbours on both sides
/// along a row or column lies within a quarter of their half-distance of their midpoint, and each
/// end corner within 0.4 of a spacing of the extrapolation from the next two. Perspective and
/// lens distortion bend a board's rows by a few per cent of a spacing per corner; corners refined
/// onto the wrong place (a board defocused beyond what the corner finder's scales resolve, where
/// OpenCV's finder finds no board) do not pass.
fn smooth_lattice(c: &[Point2], cols: usize, rows: usize) -> bool {
    let at = |r: usize, k: usize| c[r * cols + k];
    let off = |p: Point2, q: Point2| dist(p, q);
    let mut lines: Vec<Vec<Point2>> = (0..rows).map(|r| (0..cols).map(|k| at(r, k)).collect()).collect();
    lines.extend((0..cols).map(|k| (0..rows).map(|r| at(r, k)).collect::<Vec<_>>()));
    for l in &lines {
        let n = l.len();
        if n < 3 {
            continue;
        }
        for i in 1..n - 1 {
            let (a, b) = (l[i - 1], l[i + 1]);
            let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
            if !(off(l[i], mid) <= 0.25 * 0.5 * off(a, b)) {
                return false;
            }
        }
        for (e, p1, p2) in [(l[0], l[1], l[2]), (l[n - 1], l[n - 2], l[n - 3])] {
            let x = [2.0 * p1[0] - p2[0], 2.0 * p1[1] - p2[1]];
            if !(off(e, x) <= 0.4 * off(p1, p2)) {
                return false;
            }
        }
    }
    true
}

/// Sub-pixel refinement with a window of a third of the smallest corner spacing, 3…11 px.
fn refine(img: &GrayImage, corners: &mut [Point2], cols: usize, rows: usize) {
    let mut spacing = f64::MAX;
    for r in 0..rows {
        for c in 0..cols {
            let p = corners[r * cols + c];
            if c + 1 < cols {
                spacing = spacing.min(dist(p, corners[r * cols + c + 1]));
            }
            if r + 1 < rows {
                spacing = spacing.min(dist(p, corners[(r + 1) * cols + c]));
            }
        }
    }
    let half = ((spacing / 3.0).floor() as usize).clamp(3, 11);
    corner_subpix(img, corners, half, 40, 1e-3);
}

/// [`find_chessboard`] with the error "board not found (capture NAME)".
pub fn find_chessboard_named(img: &GrayImage, cols: usize, rows: usize, name: &str) -> Result<Vec<Point2>> {
    find_chessboard(img, cols, rows).ok_or_else(|| anyhow!("board not found (capture {name}): no {cols}×{rows} lattice of chessboard corners in the white frame"))
}
