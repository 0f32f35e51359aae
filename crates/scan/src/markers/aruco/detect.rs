//! ArUco marker detection, with the steps and defaults of OpenCV's `ArucoDetector`
//! (Garrido-Jurado et al., "Automatic generation and detection of highly reliable fiducial
//! markers under occlusion", Pattern Recognition 47, 2014):
//!
//! 1. **Thresholds.** Adaptive mean thresholds with windows of 3, 13 and 23 pixels and a
//!    constant of 7 grey levels: a pixel is dark when it lies 7 levels below its window's mean.
//! 2. **Quadrilaterals.** The outer boundary of every 8-connected dark region (Moore tracing),
//!    approximated by Douglas–Peucker with a tolerance of 3 % of its length; four vertices,
//!    convex, a boundary of 3 %–400 % of the image's larger side, sides of at least 5 % of the
//!    boundary, vertices 3 pixels inside the image. Candidates whose corners lie within 12.5 %
//!    of the smaller boundary of each other (the same marker at several thresholds) are one,
//!    tried from the largest.
//! 3. **Bits.** The quadrilateral's homography samples each of the (n + 2)² cells at 4 × 4
//!    points inside a margin of 13 % of the cell; Otsu's threshold over the samples (or their
//!    mean level when their standard deviation is under 5 levels) makes a cell white when most
//!    of its samples are. At most 35 % of the border cells may be white.
//! 4. **Identification.** The closest code over the four quarter turns within
//!    ⌊0.6 · max correction bits⌋ bits; the corners turned so that corner 0 is the marker's top
//!    left, then top right, bottom right, bottom left (clockwise in the image).
//! 5. **Corners.** By default (OpenCV's `CORNER_REFINE_NONE`) the vertices of the polygon
//!    (pixel positions of the dark region's boundary); `refine` moves each to the intersection
//!    of the lines fitted to its two sides' boundary points, half a pixel out to the edge.
//!
//! Pixels follow OpenCV's convention (integer coordinates at pixel centres).

use super::dictionary::Dictionary;
use crate::calib::chessboard::GrayImage;
use crate::calib::homography::{apply, fit_homography, Point2};

/// The detector's settings (OpenCV's `DetectorParameters` names and defaults).
#[derive(Clone, Debug)]
pub struct ArucoSettings {
    /// Smallest, largest adaptive-threshold window and the step between them (pixels).
    pub thresh_win: (usize, usize, usize),
    /// Grey levels below the window's mean that make a pixel dark.
    pub thresh_constant: f32,
    /// Shortest and longest candidate boundary, in units of the image's larger side.
    pub perimeter_rate: (f64, f64),
    /// Douglas–Peucker tolerance, in units of the boundary's length (points).
    pub approx_rate: f64,
    /// Shortest side, in units of the boundary's length.
    pub min_corner_distance_rate: f64,
    /// Closest a vertex may come to the image's edge (pixels).
    pub min_distance_to_border: f64,
    /// Candidates whose corners are closer than this times the smaller boundary are one.
    pub min_marker_distance_rate: f64,
    /// Part of each cell's side left out on every side when reading it.
    pub cell_margin: f64,
    /// Largest share of white border cells.
    pub max_border_error_rate: f64,
    /// Share of the dictionary's correctable bits that are corrected.
    pub error_correction_rate: f64,
    /// Below this standard deviation (grey levels) of the samples a candidate is one colour.
    pub min_otsu_std: f64,
    /// Move the corners to the intersections of lines fitted to the sides.
    pub refine: bool,
}

impl Default for ArucoSettings {
    fn default() -> Self {
        ArucoSettings {
            thresh_win: (3, 23, 10),
            thresh_constant: 7.0,
            perimeter_rate: (0.03, 4.0),
            approx_rate: 0.03,
            min_corner_distance_rate: 0.05,
            min_distance_to_border: 3.0,
            min_marker_distance_rate: 0.125,
            cell_margin: 0.13,
            max_border_error_rate: 0.35,
            error_correction_rate: 0.6,
            min_otsu_std: 5.0,
            refine: false,
        }
    }
}

/// A marker found: its id in the dictionary and its corners (top left, top right, bottom right,
/// bottom left of the upright marker; pixels).
#[derive(Clone, Debug, PartialEq)]
pub struct ArucoMarker {
    pub id: usize,
    pub corners: [Point2; 4],
    /// Bits that differed from the code (corrected).
    pub bit_errors: u32,
    /// The corners at the intersections of lines fitted to the sides (sub-pixel; None where a
    /// side is too short to fit), in the same order; `corners` when `refine` is set.
    pub line_corners: Option<[Point2; 4]>,
}

/// A convex quadrilateral candidate: its vertices (clockwise in the image), the boundary points
/// between each vertex and the next, and the boundary's length (points).
struct Quad {
    corners: [Point2; 4],
    sides: [Vec<Point2>; 4],
    perimeter: usize,
}

/// The markers of `dict` in `img`, sorted by id (a marker whose id is found twice keeps both).
pub fn detect_markers(img: &GrayImage, dict: &Dictionary, s: &ArucoSettings) -> Vec<ArucoMarker> {
    let (w, h) = (img.width, img.height);
    if w < 8 || h < 8 {
        return vec![];
    }
    let integral = integral_image(img);
    let (lo, hi, step) = s.thresh_win;
    let mut windows = Vec::new();
    let mut win = lo.max(3) | 1;
    while win <= hi.max(lo) {
        windows.push(win);
        win += step.max(1);
        win |= 1;
    }
    // The thresholds are independent: in parallel, their candidates kept in window order.
    use rayon::prelude::*;
    let mut quads: Vec<Quad> = windows.par_iter().map(|&win| quads_in(&threshold(img, &integral, win, s.thresh_constant), w, h, s)).collect::<Vec<_>>().into_iter().flatten().collect();
    // One candidate per marker: groups of candidates with close corners, largest first.
    quads.sort_by(|a, b| b.perimeter.cmp(&a.perimeter));
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, q) in quads.iter().enumerate() {
        let found = groups.iter_mut().find(|g| {
            let r = &quads[g[0]];
            let lim = s.min_marker_distance_rate * q.perimeter.min(r.perimeter) as f64;
            mean_corner_distance(&q.corners, &r.corners) < lim
        });
        match found {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    let correctable = dict.correctable(s.error_correction_rate);
    let mut out = Vec::new();
    for g in groups {
        for &i in &g {
            let q = &quads[i];
            let Some(code) = read_bits(img, &q.corners, dict.size, s) else { continue };
            let Some((id, turn, dist)) = dict.closest(code) else { continue };
            if dist > correctable {
                continue;
            }
            // The cells read were the upright marker turned `turn` quarter turns clockwise, so
            // the marker's top left is the read square's corner `turn` steps on.
            let mut line_corners = refine_corners(img, q);
            if let Some(c) = line_corners.as_mut() {
                c.rotate_left(turn);
            }
            let mut corners = q.corners;
            corners.rotate_left(turn);
            if s.refine {
                corners = line_corners.unwrap_or(corners);
            }
            out.push(ArucoMarker { id, corners, bit_errors: dist, line_corners });
            break;
        }
    }
    out.sort_by(|a, b| a.id.cmp(&b.id).then(a.corners[0][0].total_cmp(&b.corners[0][0])));
    out
}

/// Sums of the image over [0, x) × [0, y), (w + 1) × (h + 1) entries.
fn integral_image(img: &GrayImage) -> Vec<f64> {
    let (w, h) = (img.width, img.height);
    let mut s = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            row += img.data[y * w + x] as f64;
            s[(y + 1) * (w + 1) + x + 1] = s[y * (w + 1) + x + 1] + row;
        }
    }
    s
}

/// Dark pixels: at least `c` grey levels below the mean of the `win` × `win` window around
/// them (the window clamped to the image, as OpenCV's replicated border nearly does).
fn threshold(img: &GrayImage, integral: &[f64], win: usize, c: f32) -> Vec<bool> {
    let (w, h) = (img.width, img.height);
    let r = win / 2;
    let mut out = vec![false; w * h];
    let c = c as f64;
    for y in 0..h {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        let (top, bottom) = (&integral[y0 * (w + 1)..(y0 + 1) * (w + 1)], &integral[y1 * (w + 1)..(y1 + 1) * (w + 1)]);
        let row = &img.data[y * w..(y + 1) * w];
        let o = &mut out[y * w..(y + 1) * w];
        let rows = (y1 - y0) as f64;
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
            let sum = bottom[x1] - top[x1] - bottom[x0] + top[x0];
            // v ≤ sum/area − c, multiplied out: both sides are whole numbers for 8-bit images,
            // so the test is exact.
            o[x] = (row[x] as f64 + c) * ((x1 - x0) as f64 * rows) <= sum;
        }
    }
    out
}

/// The eight neighbours, clockwise in the image (x right, y down) from the east.
const DIRS: [(i32, i32); 8] = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)];

/// Candidate quadrilaterals: the outer boundaries of the 8-connected dark regions.
fn quads_in(dark: &[bool], w: usize, h: usize, s: &ArucoSettings) -> Vec<Quad> {
    let big = w.max(h) as f64;
    let (min_len, max_len) = ((s.perimeter_rate.0 * big).max(4.0), s.perimeter_rate.1 * big);
    let mut out = Vec::new();
    for region in regions(dark, w, h) {
        let (start, (x0, x1, y0, y1)) = (region.start, region.bbox);
        // A quadrilateral's boundary is at least about twice its bounding box's diagonal… and at
        // most its box's perimeter plus the diagonal steps; skip regions that cannot qualify.
        let (bw, bh) = ((x1 - x0 + 1) as f64, (y1 - y0 + 1) as f64);
        if 2.0 * (bw + bh) < min_len || (bw + bh) > 2.0 * max_len {
            continue;
        }
        // `start` is the region's first pixel in raster order: its west neighbour is light.
        let Some(contour) = trace(dark, w, h, start, max_len as usize + 1) else { continue };
        let n = contour.len();
        if (n as f64) < min_len || (n as f64) > max_len {
            continue;
        }
        if let Some(q) = quad_of(&contour, w, h, s) {
            out.push(q);
        }
    }
    out
}

/// An 8-connected region of dark pixels: its first pixel in raster order and its bounding box
/// (x0, x1, y0, y1, inclusive).
struct Region {
    start: usize,
    bbox: (usize, usize, usize, usize),
}

fn find_root(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        parent[i as usize] = parent[parent[i as usize] as usize];
        i = parent[i as usize];
    }
    i
}

/// The 8-connected regions of dark pixels, from runs along the rows joined by union–find (a run
/// joins those of the row above that overlap it or touch it diagonally), in the raster order of
/// their first pixels.
fn regions(dark: &[bool], w: usize, h: usize) -> Vec<Region> {
    // Runs as (y, x0, x1 exclusive), row by row.
    let mut runs: Vec<(u32, u32, u32)> = Vec::new();
    let mut parent: Vec<u32> = Vec::new();
    let mut prev = 0..0;
    for y in 0..h {
        let row = &dark[y * w..(y + 1) * w];
        let first = runs.len();
        let mut above = prev.start;
        let mut x = 0;
        while x < w {
            if !row[x] {
                x += 1;
                continue;
            }
            let x0 = x;
            while x < w && row[x] {
                x += 1;
            }
            let id = runs.len() as u32;
            runs.push((y as u32, x0 as u32, x as u32));
            parent.push(id);
            // Runs above with x1 > x0 − 1 and x0 < x + 1 touch this one (8-connectivity); both
            // rows' runs are sorted, so those ending left of this one are passed for good.
            while above < prev.end && (runs[above].2 as usize) + 1 <= x0 {
                above += 1;
            }
            let mut k = above;
            while k < prev.end && (runs[k].1 as usize) < x + 1 {
                let (ra, rb) = (find_root(&mut parent, k as u32), find_root(&mut parent, id));
                if ra != rb {
                    // The smaller index (earlier in raster order) stays the root.
                    let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
                    parent[hi as usize] = lo;
                }
                k += 1;
            }
        }
        prev = first..runs.len();
    }
    let mut slot = vec![u32::MAX; runs.len()];
    let mut out: Vec<Region> = Vec::new();
    for k in 0..runs.len() {
        let r = find_root(&mut parent, k as u32) as usize;
        let (y, x0, x1) = (runs[k].0 as usize, runs[k].1 as usize, runs[k].2 as usize - 1);
        if slot[r] == u32::MAX {
            // Roots are the earliest run of their region, so regions appear in raster order.
            slot[r] = out.len() as u32;
            out.push(Region { start: y * w + x0, bbox: (x0, x1, y, y) });
        } else {
            let b = &mut out[slot[r] as usize].bbox;
            b.0 = b.0.min(x0);
            b.1 = b.1.max(x1);
            b.3 = b.3.max(y);
        }
    }
    out
}

/// The outer boundary of the region containing `start` (its first pixel in raster order), by
/// Moore-neighbour tracing, as pixel positions in order (clockwise in the image); None when it
/// is longer than `limit`.
fn trace(dark: &[bool], w: usize, h: usize, start: usize, limit: usize) -> Option<Vec<[i32; 2]>> {
    let is_dark = |x: i32, y: i32| x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h && dark[y as usize * w + x as usize];
    let s = [(start % w) as i32, (start / w) as i32];
    let mut out = vec![s];
    // Where the search around the current pixel starts: the direction of the light neighbour
    // last passed (west of the start pixel, which scanning order makes light).
    let mut p = s;
    let mut back = 4usize;
    let mut first_step: Option<([i32; 2], usize)> = None;
    loop {
        let mut found = None;
        for k in 1..=8 {
            let d = (back + k) % 8;
            let (x, y) = (p[0] + DIRS[d].0, p[1] + DIRS[d].1);
            if is_dark(x, y) {
                found = Some(([x, y], d));
                break;
            }
        }
        let Some((q, d)) = found else { return Some(out) }; // a single pixel
        // Stop on leaving the start pixel the way the trace first left it (Jacob's criterion).
        if p == s {
            match first_step {
                None => first_step = Some((q, d)),
                Some(f) if f == (q, d) => {
                    out.pop();
                    return Some(out);
                }
                _ => {}
            }
        }
        out.push(q);
        if out.len() > limit + 1 {
            return None;
        }
        // The search around q starts after the neighbour of q that the search around p passed
        // last (the light one just before q): direction from q to it.
        back = (d + 5) % 8;
        p = q;
    }
}

/// Douglas–Peucker approximation of a closed contour; the candidate if it is a convex
/// quadrilateral that passes the size checks.
fn quad_of(contour: &[[i32; 2]], w: usize, h: usize, s: &ArucoSettings) -> Option<Quad> {
    let n = contour.len();
    let eps = s.approx_rate * n as f64;
    let pt = |i: usize| -> Point2 { [contour[i % n][0] as f64, contour[i % n][1] as f64] };
    // Two far-apart points split the closed curve into two open chains.
    let far = |from: Point2| (0..n).max_by(|&a, &b| d2(pt(a), from).total_cmp(&d2(pt(b), from))).unwrap_or(0);
    let a = far(pt(0));
    let b = far(pt(a));
    if a == b {
        return None;
    }
    let (a, b) = (a.min(b), a.max(b));
    let mut keep = vec![a, b];
    simplify(&pt, a, b, eps, &mut keep);
    simplify(&pt, b, a + n, eps, &mut keep);
    if keep.len() != 4 {
        return None;
    }
    let mut idx: Vec<usize> = keep.iter().map(|&i| i % n).collect();
    idx.sort_unstable();
    let mut corners = [pt(idx[0]), pt(idx[1]), pt(idx[2]), pt(idx[3])];
    // Convex: every turn the same way.
    let cross = |o: Point2, a: Point2, b: Point2| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let turns: Vec<f64> = (0..4).map(|k| cross(corners[k], corners[(k + 1) % 4], corners[(k + 2) % 4])).collect();
    if !(turns.iter().all(|&t| t > 0.0) || turns.iter().all(|&t| t < 0.0)) {
        return None;
    }
    let min_side = (0..4).map(|k| d2(corners[k], corners[(k + 1) % 4])).fold(f64::INFINITY, f64::min);
    if min_side < (n as f64 * s.min_corner_distance_rate).powi(2) {
        return None;
    }
    let m = s.min_distance_to_border;
    if corners.iter().any(|c| c[0] < m || c[1] < m || c[0] > w as f64 - 1.0 - m || c[1] > h as f64 - 1.0 - m) {
        return None;
    }
    let mut sides: [Vec<Point2>; 4] = Default::default();
    for k in 0..4 {
        let (i0, i1) = (idx[k], if k == 3 { idx[0] + n } else { idx[k + 1] });
        sides[k] = (i0..=i1).map(pt).collect();
    }
    // Clockwise in the image (x right, y down): the second vertex turns right of the first side.
    if turns[0] < 0.0 {
        corners.swap(1, 3);
        sides = [
            sides[3].iter().rev().copied().collect(),
            sides[2].iter().rev().copied().collect(),
            sides[1].iter().rev().copied().collect(),
            sides[0].iter().rev().copied().collect(),
        ];
    }
    Some(Quad { corners, sides, perimeter: n })
}

fn d2(a: Point2, b: Point2) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Douglas–Peucker on the chain of indices i0..=i1 (taken modulo the contour's length).
fn simplify(pt: &dyn Fn(usize) -> Point2, i0: usize, i1: usize, eps: f64, keep: &mut Vec<usize>) {
    if i1 <= i0 + 1 {
        return;
    }
    let (a, b) = (pt(i0), pt(i1));
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = (dx * dx + dy * dy).sqrt();
    let mut best = (0.0, i0);
    for i in i0 + 1..i1 {
        let p = pt(i);
        let d = if len > 0.0 { ((p[0] - a[0]) * dy - (p[1] - a[1]) * dx).abs() / len } else { d2(p, a).sqrt() };
        if d > best.0 {
            best = (d, i);
        }
    }
    if best.0 > eps {
        keep.push(best.1);
        simplify(pt, i0, best.1, eps, keep);
        simplify(pt, best.1, i1, eps, keep);
    }
}

/// Mean distance between corresponding corners, over the four cyclic pairings.
fn mean_corner_distance(a: &[Point2; 4], b: &[Point2; 4]) -> f64 {
    (0..4)
        .map(|r| (0..4).map(|k| d2(a[k], b[(k + r) % 4]).sqrt()).sum::<f64>() / 4.0)
        .fold(f64::INFINITY, f64::min)
}

/// Samples per cell side when reading the bits (OpenCV's `perspectiveRemovePixelPerCell`).
const SAMPLES: usize = 4;

/// The inner cells' code of a candidate (None when its border is not dark enough): the square's
/// corner 0 at the code's top left, the cells row by row.
fn read_bits(img: &GrayImage, corners: &[Point2; 4], size: usize, s: &ArucoSettings) -> Option<u64> {
    let cells = size + 2;
    let c = cells as f64;
    let hm = fit_homography(&[[0.0, 0.0], [c, 0.0], [c, c], [0.0, c]], corners)?;
    let mut samples = vec![0.0f64; cells * cells * SAMPLES * SAMPLES];
    let span = 1.0 - 2.0 * s.cell_margin;
    for r in 0..cells {
        for col in 0..cells {
            for i in 0..SAMPLES {
                for j in 0..SAMPLES {
                    let u = col as f64 + s.cell_margin + span * (j as f64 + 0.5) / SAMPLES as f64;
                    let v = r as f64 + s.cell_margin + span * (i as f64 + 0.5) / SAMPLES as f64;
                    let p = apply(&hm, [u, v]);
                    samples[((r * cells + col) * SAMPLES + i) * SAMPLES + j] = img.bilinear(p[0], p[1]);
                }
            }
        }
    }
    let n = samples.len() as f64;
    let mean = samples.iter().sum::<f64>() / n;
    let sd = (samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let t = if sd < s.min_otsu_std { if mean > 127.0 { -1.0 } else { 256.0 } } else { otsu(&samples) };
    let per = SAMPLES * SAMPLES;
    let white = |r: usize, col: usize| {
        let at = (r * cells + col) * per;
        samples[at..at + per].iter().filter(|&&v| v > t).count() * 2 > per
    };
    let mut border_white = 0;
    for r in 0..cells {
        for col in 0..cells {
            if (r == 0 || col == 0 || r == cells - 1 || col == cells - 1) && white(r, col) {
                border_white += 1;
            }
        }
    }
    let border_cells = cells * cells - size * size;
    if border_white as f64 > s.max_border_error_rate * border_cells as f64 {
        return None;
    }
    let mut code = 0u64;
    for r in 1..=size {
        for col in 1..=size {
            code = (code << 1) | u64::from(white(r, col));
        }
    }
    Some(code)
}

/// Otsu's threshold of grey levels (0–255): the level between the classes that maximises the
/// between-class variance, on a 256-bin histogram; a sample above it is light.
pub fn otsu(v: &[f64]) -> f64 {
    let mut hist = [0usize; 256];
    for &x in v {
        hist[x.round().clamp(0.0, 255.0) as usize] += 1;
    }
    let total = v.len() as f64;
    let sum_all: f64 = hist.iter().enumerate().map(|(i, &c)| i as f64 * c as f64).sum();
    let (mut w0, mut sum0) = (0.0, 0.0);
    let (mut best, mut level) = (-1.0, 0usize);
    for (i, &c) in hist.iter().enumerate() {
        w0 += c as f64;
        sum0 += i as f64 * c as f64;
        let w1 = total - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let (m0, m1) = (sum0 / w0, (sum_all - sum0) / w1);
        let between = w0 * w1 * (m0 - m1).powi(2);
        if between > best {
            best = between;
            level = i;
        }
    }
    level as f64 + 0.5
}

/// Total-least-squares line through `pts`: (unit normal pointing away from `centre`, offset),
/// the line being n·p = offset.
fn fit_line(pts: &[Point2], centre: Point2) -> Option<(f64, f64, f64)> {
    if pts.len() < 3 {
        return None;
    }
    let k_n = pts.len() as f64;
    let mx = pts.iter().map(|p| p[0]).sum::<f64>() / k_n;
    let my = pts.iter().map(|p| p[1]).sum::<f64>() / k_n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in pts {
        let (dx, dy) = (p[0] - mx, p[1] - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    // The normal is the eigenvector of the smaller eigenvalue of the scatter matrix.
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (mut nx, mut ny) = (-theta.sin(), theta.cos());
    if (mx - centre[0]) * nx + (my - centre[1]) * ny < 0.0 {
        nx = -nx;
        ny = -ny;
    }
    Some((nx, ny, nx * mx + ny * my))
}

/// The four corners where consecutive lines n·p = c meet (vertex k joins line k − 1 and line k);
/// None where two are parallel or a corner lies more than `max_px` from `near`'s.
pub(super) fn intersections(lines: &[(f64, f64, f64); 4], near: &[Point2; 4], max_px: f64) -> Option<[Point2; 4]> {
    let mut out = [[0.0; 2]; 4];
    for k in 0..4 {
        let (a, b) = (lines[(k + 3) % 4], lines[k]);
        let det = a.0 * b.1 - a.1 * b.0;
        if det.abs() < 1e-9 {
            return None;
        }
        let p = [(a.2 * b.1 - a.1 * b.2) / det, (a.0 * b.2 - a.2 * b.0) / det];
        if d2(p, near[k]) > max_px * max_px {
            return None;
        }
        out[k] = p;
    }
    Some(out)
}

/// Sub-pixel corners: the lines of [`contour_corners`], then each side's edge located along its
/// normal in the image (where the grey level crosses halfway between the dark and light ends of
/// its profile across the edge, within ±2.5 px) at every pixel of the
/// side's middle 70 %, those edge points fitted by a line again, and the lines intersected.
fn refine_corners(img: &GrayImage, q: &Quad) -> Option<[Point2; 4]> {
    let first = contour_corners(q)?;
    let centre = [first.iter().map(|c| c[0]).sum::<f64>() / 4.0, first.iter().map(|c| c[1]).sum::<f64>() / 4.0];
    let mut lines = [(0.0, 0.0, 0.0); 4];
    for k in 0..4 {
        let (a, b) = (first[k], first[(k + 1) % 4]);
        let len = d2(a, b).sqrt();
        let (tx, ty) = ((b[0] - a[0]) / len, (b[1] - a[1]) / len);
        // Outward normal: the side runs clockwise in the image, so outwards is to its left.
        let (mut nx, mut ny) = (ty, -tx);
        let mid = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
        if (mid[0] - centre[0]) * nx + (mid[1] - centre[1]) * ny < 0.0 {
            nx = -nx;
            ny = -ny;
        }
        let steps = len.floor() as usize;
        let mut pts = Vec::with_capacity(steps);
        const H: f64 = 0.25;
        const N: usize = 21; // samples from −2.5 to +2.5 px
        for i in 0..=steps {
            let t = i as f64 / steps.max(1) as f64;
            if !(0.15..=0.85).contains(&t) {
                continue;
            }
            let p = [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];
            let level: Vec<f64> = (0..N).map(|j| {
                let s = (j as f64 - (N / 2) as f64) * H;
                img.bilinear(p[0] + nx * s, p[1] + ny * s)
            }).collect();
            // Light outside, dark inside: the level rises along the outward normal. The edge is
            // where it crosses halfway between the profile's dark and light ends, next to its
            // steepest rise: a pixel whose centre lies on a straight edge is half covered at any
            // angle, so the crossing is unbiased where a derivative's peak is not (bilinear
            // interpolation makes it lopsided for oblique edges).
            let grad: Vec<f64> = (1..N - 1).map(|j| level[j + 1] - level[j - 1]).collect();
            let Some((jg, &g)) = grad.iter().enumerate().max_by(|x, y| x.1.total_cmp(y.1)) else { continue };
            let j = jg + 1;
            if !(g > 0.0) {
                continue;
            }
            let dark = level[..j].iter().copied().fold(f64::INFINITY, f64::min);
            let light = level[j..].iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let mid = 0.5 * (dark + light);
            // The crossing nearest the steepest rise.
            let Some(c) = (0..N - 1)
                .filter(|&c| level[c] < mid && level[c + 1] >= mid)
                .min_by_key(|&c| (c as i64 - j as i64).abs())
            else {
                continue;
            };
            let f = (mid - level[c]) / (level[c + 1] - level[c]);
            let s = (c as f64 + f - (N / 2) as f64) * H;
            pts.push([p[0] + nx * s, p[1] + ny * s]);
        }
        lines[k] = fit_line(&pts, centre)?;
    }
    intersections(&lines, &first, 3.0)
}

/// Corners at the intersections of lines fitted (total least squares) to the boundary points of
/// each side, leaving out the points near the vertices; the boundary points are the centres of
/// the dark region's edge pixels, so each line is moved half a pixel outwards.
fn contour_corners(q: &Quad) -> Option<[Point2; 4]> {
    let mut lines = [(0.0, 0.0, 0.0); 4];
    let centre = [q.corners.iter().map(|c| c[0]).sum::<f64>() / 4.0, q.corners.iter().map(|c| c[1]).sum::<f64>() / 4.0];
    for k in 0..4 {
        let pts = &q.sides[k];
        let m = pts.len();
        let cut = (m / 8).max(1);
        if m < 2 * cut + 3 {
            return None;
        }
        let (nx, ny, c) = fit_line(&pts[cut..m - cut], centre)?;
        lines[k] = (nx, ny, c + 0.5);
    }
    intersections(&lines, &q.corners, 3.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The regions of a flood fill over the eight neighbours, in raster order of first pixels.
    fn flood(dark: &[bool], w: usize, h: usize) -> Vec<(usize, (usize, usize, usize, usize))> {
        let mut seen = vec![false; w * h];
        let mut out = Vec::new();
        for start in 0..w * h {
            if !dark[start] || seen[start] {
                continue;
            }
            let mut b = (start % w, start % w, start / w, start / w);
            let mut stack = vec![start];
            seen[start] = true;
            while let Some(i) = stack.pop() {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                b = (b.0.min(x as usize), b.1.max(x as usize), b.2.min(y as usize), b.3.max(y as usize));
                for (dx, dy) in DIRS {
                    let (nx, ny) = (x + dx as i64, y + dy as i64);
                    if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
                        let j = ny as usize * w + nx as usize;
                        if dark[j] && !seen[j] {
                            seen[j] = true;
                            stack.push(j);
                        }
                    }
                }
            }
            out.push((start, b));
        }
        out
    }

    #[test]
    fn run_regions_equal_a_flood_fill() {
        let mut state = 99u64;
        for (w, h, density) in [(37, 23, 0.3), (64, 48, 0.5), (50, 50, 0.62), (1, 9, 0.5), (9, 1, 0.5)] {
            let dark: Vec<bool> = (0..w * h)
                .map(|_| {
                    state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    ((state >> 33) as f64 / (1u64 << 31) as f64) < density
                })
                .collect();
            let got: Vec<_> = regions(&dark, w, h).into_iter().map(|r| (r.start, r.bbox)).collect();
            assert_eq!(got, flood(&dark, w, h), "{w}×{h} at {density}");
        }
    }

    #[test]
    fn random_images_give_valid_markers_or_none() {
        // Blocky random images of many sizes (the shapes a threshold turns into quadrilaterals,
        // slivers and single pixels): no panic, and whatever is found is a valid marker.
        let mut state = 7u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as usize
        };
        let dicts: Vec<Dictionary> = ["DICT_4X4_50", "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5"].iter().map(|n| Dictionary::predefined(n).unwrap()).collect();
        for _ in 0..150 {
            let (w, h) = (8 + next() % 90, 8 + next() % 90);
            let block = 1 + next() % 9;
            let data = (0..w * h).map(|i| if (next() ^ (i % w / block) ^ (i / w / block)) % 3 == 0 { 20.0 } else { 230.0 }).collect();
            let img = GrayImage { width: w, height: h, data };
            for d in &dicts {
                for m in detect_markers(&img, d, &ArucoSettings { refine: next() % 2 == 0, ..Default::default() }) {
                    assert!(m.id < d.codes.len());
                    assert!(m.corners.iter().flatten().all(|v| v.is_finite()));
                }
            }
        }
        assert!(detect_markers(&GrayImage { width: 4, height: 100, data: vec![0.0; 400] }, &dicts[0], &ArucoSettings::default()).is_empty());
    }
}
