//! Segmentation of a photograph into regions and of the regions into K colour labels.
//!
//! 1. **Edges.** The image, sRGB-encoded (a roughly perceptual scale, so that an edge between two
//!    dark colours weighs like one between two light ones), is smoothed by a Gaussian of
//!    `smoothing_px`, and the gradient magnitude is the root sum of squares over the three
//!    channels of Scharr's 3 × 3 derivative (Scharr, "Optimal operators in digital image
//!    processing", PhD thesis, Heidelberg 2000; the kernel [3 10 3]ᵀ[1 0 −1]/32).
//! 2. **Markers.** Pixels whose gradient is below a threshold (by default a fraction of the
//!    gradient's 99th percentile) are flat; the flat mask is eroded by a square of half-size
//!    `erosion_px`, and its 4-connected components of at least `min_marker_px` pixels are the
//!    markers, one basin each.
//! 3. **Watershed.** Meyer's flooding ("Topographic distance and watershed lines", Signal
//!    Processing 38, 1994; as OpenCV's `cv::watershed`): the 4-neighbours of the markers enter a
//!    hierarchical queue keyed by their gradient (quantised to [`LEVELS`] levels, first in first out
//!    within a level); the pixel taken out joins the basin of its labelled neighbours if they all
//!    belong to one, or becomes a boundary pixel if they belong to two or more; a pixel that
//!    joined a basin puts its unqueued neighbours into the queue at the level max(own gradient,
//!    current level). Every pixel reachable from a marker without crossing a boundary is labelled.
//! 4. **Colour labels.** Each region's mean linear RGB (boundary pixels excluded) is turned into
//!    CIE L\*a\*b\* (D65), and the regions are grouped into K labels by k-means weighted by their
//!    pixel counts (Lloyd's iterations from a farthest-point start seeded by the largest region).
//!    Without a given K, the smallest K ≤ `max_labels` is taken whose weighted RMS distance of the
//!    regions to their label's centre is at most `spread_de` (ΔE\*ab).

use crate::raster::neighbours4;
use std::collections::VecDeque;

use anyhow::{bail, Result};
use rayon::prelude::*;

/// Levels of the hierarchical queue of the watershed.
pub const LEVELS: usize = 4096;

/// Region id of a watershed boundary pixel.
pub const BOUNDARY: i32 = -1;
/// Region id of a pixel no marker reached.
pub const UNREACHED: i32 = 0;

/// A linear RGB image (sRGB primaries), row-major, top row first.
#[derive(Clone, Debug)]
pub struct Photo {
    /// Width (pixels).
    pub width: usize,
    /// Height (pixels).
    pub height: usize,
    /// Linear RGB per pixel.
    pub rgb: Vec<[f32; 3]>,
}

/// Options of [`segment`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentOptions {
    /// Standard deviation of the Gaussian before the gradient (pixels).
    pub smoothing_px: f64,
    /// Marker threshold as a fraction of the 99th percentile of the gradient magnitude.
    pub marker_fraction: f64,
    /// Half-size of the square by which the flat mask is eroded (pixels).
    pub erosion_px: usize,
    /// Smallest marker kept (pixels).
    pub min_marker_px: usize,
    /// Number of colour labels; None chooses it (module documentation).
    pub labels: Option<usize>,
    /// Largest K tried when choosing.
    pub max_labels: usize,
    /// Largest weighted RMS colour spread within a label when K is chosen (ΔE*ab).
    pub spread_de: f64,
}

impl Default for SegmentOptions {
    fn default() -> Self {
        SegmentOptions { smoothing_px: 1.5, marker_fraction: 0.15, erosion_px: 1, min_marker_px: 4, labels: None, max_labels: 8, spread_de: 3.0 }
    }
}

/// The result of [`segment`].
#[derive(Clone, Debug)]
pub struct Segmentation {
    /// Width (pixels).
    pub width: usize,
    /// Height (pixels).
    pub height: usize,
    /// Per pixel: watershed region 1…`regions`, [`BOUNDARY`] or [`UNREACHED`].
    pub region: Vec<i32>,
    /// Number of watershed regions.
    pub regions: usize,
    /// Colour label of each region (index `region − 1`), 0…K−1.
    pub region_label: Vec<usize>,
    /// Pixel count of each region.
    pub region_pixels: Vec<usize>,
    /// Mean linear RGB of each region.
    pub region_rgb: Vec<[f64; 3]>,
    /// Number of colour labels K.
    pub labels: usize,
    /// Mean linear RGB of each label (pixel-weighted over its regions).
    pub label_rgb: Vec<[f64; 3]>,
    /// Pixels of each label (boundaries excluded).
    pub label_pixels: Vec<usize>,
    /// The threshold the markers were taken below (gradient units: sRGB-encoded value per pixel).
    pub marker_threshold: f64,
}

impl Segmentation {
    /// Per pixel: the colour label, the label of the nearest labelled pixel (4-connected
    /// breadth-first order, i.e. city-block distance) for boundary and unreached pixels, or −1
    /// in an image without regions.
    pub fn label_map(&self) -> Vec<i32> {
        let (w, h) = (self.width, self.height);
        let mut map: Vec<i32> = self.region.iter().map(|&r| if r > 0 { self.region_label[r as usize - 1] as i32 } else { -1 }).collect();
        let mut queue: VecDeque<usize> = (0..w * h).filter(|&i| map[i] >= 0).collect();
        while let Some(i) = queue.pop_front() {
            let (x, y) = (i % w, i / w);
            let l = map[i];
            let mut visit = |j: usize| {
                if map[j] < 0 {
                    map[j] = l;
                    queue.push_back(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        map
    }
}

fn srgb_encode(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// A separable Gaussian of standard deviation `sigma` (pixels) over one channel, edges clamped.
fn blur(src: &[f32], w: usize, h: usize, sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 {
        return src.to_vec();
    }
    let r = (3.0 * sigma).ceil() as isize;
    let mut k: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32).collect();
    let s: f32 = k.iter().sum();
    k.iter_mut().for_each(|x| *x /= s);
    let mut tmp = vec![0f32; w * h];
    tmp.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let line = &src[y * w..(y + 1) * w];
        for (x, o) in row.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (t, kv) in k.iter().enumerate() {
                let xx = (x as isize + t as isize - r).clamp(0, w as isize - 1) as usize;
                acc += kv * line[xx];
            }
            *o = acc;
        }
    });
    let mut out = vec![0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (t, kv) in k.iter().enumerate() {
            let yy = (y as isize + t as isize - r).clamp(0, h as isize - 1) as usize;
            let line = &tmp[yy * w..(yy + 1) * w];
            for (o, v) in row.iter_mut().zip(line) {
                *o += kv * v;
            }
        }
    });
    out
}

/// Gradient magnitude of the smoothed, sRGB-encoded photo (module documentation, step 1), in
/// encoded value per pixel.
pub fn gradient(photo: &Photo, smoothing_px: f64) -> Vec<f32> {
    let (w, h) = (photo.width, photo.height);
    let channels: Vec<Vec<f32>> = (0..3)
        .into_par_iter()
        .map(|c| {
            let enc: Vec<f32> = photo.rgb.iter().map(|p| srgb_encode(p[c])).collect();
            blur(&enc, w, h, smoothing_px)
        })
        .collect();
    let mut g = vec![0f32; w * h];
    g.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let ym = y.saturating_sub(1);
        let yp = (y + 1).min(h - 1);
        for (x, o) in row.iter_mut().enumerate() {
            let xm = x.saturating_sub(1);
            let xp = (x + 1).min(w - 1);
            let mut s = 0.0f32;
            for ch in &channels {
                let v = |xx: usize, yy: usize| ch[yy * w + xx];
                let gx = 3.0 * (v(xp, ym) - v(xm, ym)) + 10.0 * (v(xp, y) - v(xm, y)) + 3.0 * (v(xp, yp) - v(xm, yp));
                let gy = 3.0 * (v(xm, yp) - v(xm, ym)) + 10.0 * (v(x, yp) - v(x, ym)) + 3.0 * (v(xp, yp) - v(xp, ym));
                s += (gx * gx + gy * gy) / (32.0 * 32.0);
            }
            *o = s.sqrt();
        }
    });
    g
}

/// Value at quantile `q` ∈ [0, 1] of `v` (nearest rank); 0 for an empty slice.
fn quantile(v: &[f32], q: f64) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    let k = ((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1);
    let (_, m, _) = s.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    *m
}

/// Markers: 4-connected components (≥ `min_px` pixels) of `flat` eroded by a square of half-size
/// `erosion`; returns per pixel 0 or the marker id 1…n, and n.
pub fn markers(flat: &[bool], w: usize, h: usize, erosion: usize, min_px: usize) -> (Vec<i32>, usize) {
    // Erosion by a square = erosion by a row segment, then by a column segment.
    let erode_rows = |m: &[bool]| -> Vec<bool> {
        let mut out = vec![false; w * h];
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            let line = &m[y * w..(y + 1) * w];
            // Run length of flat pixels to the left and right.
            let mut left = vec![0usize; w];
            let mut run = 0;
            for x in 0..w {
                run = if line[x] { run + 1 } else { 0 };
                left[x] = run;
            }
            run = 0;
            for x in (0..w).rev() {
                run = if line[x] { run + 1 } else { 0 };
                row[x] = line[x] && left[x] > erosion.min(x) && run > erosion.min(w - 1 - x);
            }
        });
        out
    };
    let transpose = |m: &[bool], w: usize, h: usize| -> Vec<bool> {
        let mut t = vec![false; w * h];
        for y in 0..h {
            for x in 0..w {
                t[x * h + y] = m[y * w + x];
            }
        }
        t
    };
    let rows = erode_rows(flat);
    let eroded = if erosion > 0 {
        // Columns: transpose, erode rows (with the transposed sizes), transpose back.
        let t = transpose(&rows, w, h);
        let mut out = vec![false; w * h];
        out.par_chunks_mut(h).enumerate().for_each(|(x, col)| {
            let line = &t[x * h..(x + 1) * h];
            let mut up = vec![0usize; h];
            let mut run = 0;
            for y in 0..h {
                run = if line[y] { run + 1 } else { 0 };
                up[y] = run;
            }
            run = 0;
            for y in (0..h).rev() {
                run = if line[y] { run + 1 } else { 0 };
                col[y] = line[y] && up[y] > erosion.min(y) && run > erosion.min(h - 1 - y);
            }
        });
        transpose(&out, h, w)
    } else {
        rows
    };
    let mut id = vec![0i32; w * h];
    let mut n = 0i32;
    let mut stack = Vec::new();
    let mut members = Vec::new();
    for start in 0..w * h {
        if !eroded[start] || id[start] != 0 {
            continue;
        }
        n += 1;
        members.clear();
        id[start] = n;
        stack.push(start);
        while let Some(i) = stack.pop() {
            members.push(i);
            let (x, y) = (i % w, i / w);
            let mut go = |j: usize| {
                if eroded[j] && id[j] == 0 {
                    id[j] = n;
                    stack.push(j);
                }
            };
            if x > 0 {
                go(i - 1);
            }
            if x + 1 < w {
                go(i + 1);
            }
            if y > 0 {
                go(i - w);
            }
            if y + 1 < h {
                go(i + w);
            }
        }
        if members.len() < min_px {
            // Too small: mark as visited but not a marker (−2), and reuse the id.
            for &i in &members {
                id[i] = -2;
            }
            n -= 1;
        }
    }
    id.iter_mut().for_each(|v| {
        if *v < 0 {
            *v = 0
        }
    });
    (id, n as usize)
}

/// Meyer's flooding of `gradient` from `markers` (0 = unlabelled, 1…n = basins): every pixel
/// gets its basin's id, [`BOUNDARY`] where basins meet, or stays [`UNREACHED`] (module
/// documentation, step 3).
pub fn watershed(gradient: &[f32], w: usize, h: usize, markers: &[i32]) -> Vec<i32> {
    assert_eq!(gradient.len(), w * h);
    assert_eq!(markers.len(), w * h);
    let gmax = gradient.iter().copied().fold(0f32, f32::max);
    let scale = if gmax > 0.0 { (LEVELS - 1) as f32 / gmax } else { 0.0 };
    let level = |i: usize| -> usize { ((gradient[i] * scale) as usize).min(LEVELS - 1) };
    let mut lab = markers.to_vec();
    let mut queued = vec![false; w * h];
    let mut queue: Vec<VecDeque<u32>> = vec![VecDeque::new(); LEVELS];
    let neighbours = |i: usize| neighbours4(i, w, h);
    let mut lowest = LEVELS;
    for i in 0..w * h {
        if lab[i] > 0 {
            for j in neighbours(i).into_iter().flatten() {
                if lab[j] == 0 && !queued[j] {
                    queued[j] = true;
                    let l = level(j);
                    queue[l].push_back(j as u32);
                    lowest = lowest.min(l);
                }
            }
        }
    }
    let mut current = lowest;
    while current < LEVELS {
        let Some(i) = queue[current].pop_front() else {
            current += 1;
            continue;
        };
        let i = i as usize;
        let mut l = 0;
        for j in neighbours(i).into_iter().flatten() {
            let m = lab[j];
            if m > 0 {
                if l == 0 {
                    l = m;
                } else if l != m {
                    l = BOUNDARY;
                }
            }
        }
        if l == 0 {
            // Queued from a neighbour that later became a boundary: nothing to join.
            continue;
        }
        lab[i] = l;
        if l == BOUNDARY {
            continue;
        }
        for j in neighbours(i).into_iter().flatten() {
            if lab[j] == 0 && !queued[j] {
                queued[j] = true;
                queue[level(j).max(current)].push_back(j as u32);
            }
        }
    }
    lab
}

fn d2(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

/// Weighted k-means of `points` into `k` clusters: (assignment, weighted RMS distance to the
/// centres). Deterministic: farthest-point start from the heaviest point, each further centre
/// the point farthest from those chosen whose cluster (the points nearer to it than to them)
/// weighs at least 1 % of the heaviest point.
pub fn kmeans(points: &[[f64; 3]], weights: &[f64], k: usize) -> (Vec<usize>, f64) {
    let n = points.len();
    if n == 0 || k == 0 {
        return (vec![0; n], 0.0);
    }
    let k = k.min(n);
    let heaviest = (0..n).max_by(|&a, &b| weights[a].total_cmp(&weights[b]).then(b.cmp(&a))).unwrap_or(0);
    let mut centres = vec![points[heaviest]];
    let mut near: Vec<f64> = points.iter().map(|&p| d2(p, centres[0])).collect();
    while centres.len() < k {
        // The farthest point whose cluster would have some weight: the points nearer to it than
        // to every centre so far must weigh at least 1 % of the heaviest point. A colour shown by
        // several small regions (printed markers) gets a centre of its own; a lone speck does not.
        let wmin = 0.01 * weights[heaviest];
        let mut order: Vec<usize> = (0..n).filter(|&i| near[i] > 0.0).collect();
        order.sort_by(|&a, &b| near[b].total_cmp(&near[a]).then(a.cmp(&b)));
        let cell = |i: usize| -> f64 { (0..n).filter(|&j| d2(points[j], points[i]) < near[j]).map(|j| weights[j]).sum() };
        let Some(next) = order.into_iter().find(|&i| weights[i] >= wmin || cell(i) >= wmin) else { break };
        centres.push(points[next]);
        for (d, &p) in near.iter_mut().zip(points) {
            *d = d.min(d2(p, points[next]));
        }
    }
    let mut assign = vec![0usize; n];
    for _ in 0..100 {
        let mut changed = false;
        for (a, &p) in assign.iter_mut().zip(points) {
            let best = (0..centres.len()).min_by(|&i, &j| d2(p, centres[i]).total_cmp(&d2(p, centres[j]))).unwrap_or(0);
            if best != *a {
                *a = best;
                changed = true;
            }
        }
        let mut sum = vec![[0.0; 3]; centres.len()];
        let mut wsum = vec![0.0; centres.len()];
        for ((&a, p), &wt) in assign.iter().zip(points).zip(weights) {
            for c in 0..3 {
                sum[a][c] += wt * p[c];
            }
            wsum[a] += wt;
        }
        for c in 0..centres.len() {
            if wsum[c] > 0.0 {
                centres[c] = sum[c].map(|s| s / wsum[c]);
            }
        }
        if !changed {
            break;
        }
    }
    // Drop empty clusters and renumber by first appearance in weight order (largest first).
    let mut cw = vec![0.0; centres.len()];
    for (&a, &wt) in assign.iter().zip(weights) {
        cw[a] += wt;
    }
    let mut order: Vec<usize> = (0..centres.len()).filter(|&c| cw[c] > 0.0).collect();
    order.sort_by(|&a, &b| cw[b].total_cmp(&cw[a]).then(a.cmp(&b)));
    let mut renumber = vec![usize::MAX; centres.len()];
    for (new, &old) in order.iter().enumerate() {
        renumber[old] = new;
    }
    let wt: f64 = weights.iter().sum();
    let ss: f64 = assign.iter().zip(points).zip(weights).map(|((&a, &p), &w)| w * d2(p, centres[a])).sum();
    let rms = if wt > 0.0 { (ss / wt).sqrt() } else { 0.0 };
    (assign.iter().map(|&a| renumber[a]).collect(), rms)
}

/// Segments `photo` into watershed regions and K colour labels (module documentation).
pub fn segment(photo: &Photo, opts: &SegmentOptions) -> Result<Segmentation> {
    segment_with_barriers(photo, opts, None)
}

/// [`segment`], with `barrier` pixels (e.g. occlusion edges of a mesh seen by the camera) raised
/// to the largest gradient and kept out of the markers, so that watershed lines pass through them.
pub fn segment_with_barriers(photo: &Photo, opts: &SegmentOptions, barrier: Option<&[bool]>) -> Result<Segmentation> {
    let (w, h) = (photo.width, photo.height);
    if w < 3 || h < 3 || photo.rgb.len() != w * h {
        bail!("the photo must be at least 3x3 pixels with one colour per pixel");
    }
    if let Some(k) = opts.labels {
        if k == 0 {
            bail!("--labels must be at least 1");
        }
    }
    let mut g = gradient(photo, opts.smoothing_px);
    let threshold = opts.marker_fraction as f32 * quantile(&g, 0.99);
    if let Some(b) = barrier {
        if b.len() != w * h {
            bail!("the barrier mask has {} pixels, the photo {}", b.len(), w * h);
        }
        let top = g.iter().copied().fold(0f32, f32::max).max(f32::MIN_POSITIVE);
        for (v, &on) in g.iter_mut().zip(b) {
            if on {
                *v = top;
            }
        }
    }
    let flat: Vec<bool> = g.iter().map(|&v| v <= threshold).collect();
    let (mk, n) = markers(&flat, w, h, opts.erosion_px, opts.min_marker_px);
    if n == 0 {
        bail!("no flat region of at least {} pixels in the photo: nothing to label", opts.min_marker_px);
    }
    let region = watershed(&g, w, h, &mk);
    let mut sum = vec![[0.0f64; 3]; n];
    let mut count = vec![0usize; n];
    for (&r, p) in region.iter().zip(&photo.rgb) {
        if r > 0 {
            let k = r as usize - 1;
            for c in 0..3 {
                sum[k][c] += p[c] as f64;
            }
            count[k] += 1;
        }
    }
    let mean: Vec<[f64; 3]> = sum.iter().zip(&count).map(|(s, &c)| s.map(|v| v / c.max(1) as f64)).collect();
    let points: Vec<[f64; 3]> = mean.iter().map(|&m| optics::color::linear_srgb_to_lab(m)).collect();
    let weights: Vec<f64> = count.iter().map(|&c| c as f64).collect();
    let assign = match opts.labels {
        Some(k) => kmeans(&points, &weights, k).0,
        None => {
            let mut chosen = None;
            for k in 1..=opts.max_labels.max(1) {
                let (a, rms) = kmeans(&points, &weights, k);
                if rms <= opts.spread_de || k == opts.max_labels.max(1) {
                    chosen = Some(a);
                    break;
                }
            }
            chosen.unwrap_or_else(|| vec![0; n])
        }
    };
    let labels = assign.iter().copied().max().map_or(0, |m| m + 1);
    let mut lsum = vec![[0.0f64; 3]; labels];
    let mut lpix = vec![0usize; labels];
    for (k, &a) in assign.iter().enumerate() {
        for c in 0..3 {
            lsum[a][c] += sum[k][c];
        }
        lpix[a] += count[k];
    }
    let label_rgb = lsum.iter().zip(&lpix).map(|(s, &c)| s.map(|v| v / c.max(1) as f64)).collect();
    Ok(Segmentation {
        width: w,
        height: h,
        region,
        regions: n,
        region_label: assign,
        region_pixels: count,
        region_rgb: mean,
        labels,
        label_rgb,
        label_pixels: lpix,
        marker_threshold: threshold as f64,
    })
}
