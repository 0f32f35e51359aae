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
    let mut values: Vec<f32> = img.data.iter().copied().filter(|v| v.is_finite()).collect();
    if values.is_empty() {
        return Vec::new();
    }
    let mut q = |p: f64| {
        let k = ((values.len() - 1) as f64 * p) as usize;
        *values.select_nth_unstable_by(k, f32::total_cmp).1 as f64
    };
    let (lo, hi) = (q(0.02), q(0.98));
    if !(hi > lo) {
        return Vec::new();
    }
    let max_area = w * h / 30;
    // Sums of x, y and radius over the levels a region was seen at, and their number.
    let mut found: Vec<(f64, f64, f64, usize)> = Vec::new();
    let mut cc = Components::default();
    for t in LEVELS {
        let level = (lo + t * (hi - lo)) as f32;
        cc.label(img, |v| if dark { v < level } else { v > level });
        for m in cc.regions() {
            if m.border || m.n < MIN_AREA || m.n > max_area {
                continue;
            }
            let nf = m.n as f64;
            let (cx, cy) = (m.sx / nf, m.sy / nf);
            // Central second moments (a pixel is a unit square: + 1/12 each axis).
            let (mxx, myy, mxy) = (m.sxx / nf - cx * cx + 1.0 / 12.0, m.syy / nf - cy * cy + 1.0 / 12.0, m.sxy / nf - cx * cy);
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

/// Area, raw moments (pixel centres at integer coordinates) and whether it touches the image
/// border, of one 4-connected region.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Moments {
    n: usize,
    sx: f64,
    sy: f64,
    sxx: f64,
    syy: f64,
    sxy: f64,
    border: bool,
}

/// 4-connected components of a thresholded image by runs: each row's runs of pixels inside are
/// joined to the overlapping runs of the row above (union–find whose root is always the first
/// run in raster order), and each run adds its moments in closed form. The regions come out in
/// the raster order of their first pixel, as a flood fill started at every unlabelled pixel finds
/// them, with the same moments: all sums are of integers, exact in f64.
#[derive(Default)]
struct Components {
    /// Runs (row, first x, one past the last x), in raster order.
    runs: Vec<(u32, u32, u32)>,
    parent: Vec<u32>,
    moments: Vec<Moments>,
    width: usize,
    height: usize,
}

impl Components {
    fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let p = self.parent[i as usize];
            self.parent[i as usize] = self.parent[p as usize];
            i = p;
        }
        i
    }

    fn label(&mut self, img: &Image, inside: impl Fn(f32) -> bool) {
        let (w, h) = (img.width, img.height);
        (self.width, self.height) = (w, h);
        self.runs.clear();
        self.parent.clear();
        let mut prev = 0..0;
        for y in 0..h {
            let row = &img.data[y * w..(y + 1) * w];
            let first = self.runs.len();
            let mut x = 0;
            while x < w {
                if !inside(row[x]) {
                    x += 1;
                    continue;
                }
                let x0 = x;
                while x < w && inside(row[x]) {
                    x += 1;
                }
                let k = self.runs.len() as u32;
                self.runs.push((y as u32, x0 as u32, x as u32));
                self.parent.push(k);
                // Runs of the row above that share a column with this one.
                for p in prev.clone() {
                    let (_, a0, a1) = self.runs[p];
                    if a1 as usize <= x0 {
                        continue;
                    }
                    if a0 as usize >= x {
                        break;
                    }
                    let (ra, rb) = (self.find(p as u32), self.find(k));
                    if ra != rb {
                        let (lo, hi) = (ra.min(rb), ra.max(rb));
                        self.parent[hi as usize] = lo;
                    }
                }
            }
            prev = first..self.runs.len();
        }
    }

    /// The regions of the last [`Components::label`], in the raster order of their first pixel.
    fn regions(&mut self) -> Vec<Moments> {
        let (w, h) = (self.width as u32, self.height as u32);
        let mut index = vec![u32::MAX; self.runs.len()];
        self.moments.clear();
        let sum = |a: f64, b: f64| (a + b - 1.0) * (b - a) / 2.0;
        let sum2 = |n: f64| n * (n + 1.0) * (2.0 * n + 1.0) / 6.0;
        for k in 0..self.runs.len() {
            let root = self.find(k as u32) as usize;
            if index[root] == u32::MAX {
                index[root] = self.moments.len() as u32;
                self.moments.push(Moments::default());
            }
            let (y, x0, x1) = self.runs[k];
            let m = &mut self.moments[index[root] as usize];
            let (yf, a, b) = (y as f64, x0 as f64, x1 as f64);
            let len = b - a;
            let sx = sum(a, b);
            m.n += (x1 - x0) as usize;
            m.sx += sx;
            m.sy += yf * len;
            m.sxx += sum2(b - 1.0) - if x0 > 0 { sum2(a - 1.0) } else { 0.0 };
            m.syy += yf * yf * len;
            m.sxy += yf * sx;
            m.border |= y == 0 || y == h - 1 || x0 == 0 || x1 == w;
        }
        self.moments.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::neighbours4;

    /// The regions by a flood fill from every unlabelled pixel in raster order.
    fn flood(img: &Image, inside: impl Fn(f32) -> bool) -> Vec<Moments> {
        let (w, h) = (img.width, img.height);
        let mut label = vec![false; w * h];
        let mut out = Vec::new();
        for start in 0..w * h {
            if label[start] || !inside(img.data[start]) {
                continue;
            }
            let mut m = Moments::default();
            let mut stack = vec![start];
            label[start] = true;
            while let Some(i) = stack.pop() {
                let (x, y) = (i % w, i / w);
                let (xf, yf) = (x as f64, y as f64);
                m.n += 1;
                m.sx += xf;
                m.sy += yf;
                m.sxx += xf * xf;
                m.syy += yf * yf;
                m.sxy += xf * yf;
                m.border |= x == 0 || y == 0 || x == w - 1 || y == h - 1;
                for j in neighbours4(i, w, h).into_iter().flatten() {
                    if !label[j] && inside(img.data[j]) {
                        label[j] = true;
                        stack.push(j);
                    }
                }
            }
            out.push(m);
        }
        out
    }

    /// Runs and flood fill give the same regions in the same order, on random images whose
    /// regions have every shape (U shapes joined late, spirals of noise, regions at the border).
    #[test]
    fn runs_find_the_regions_a_flood_fill_finds() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut compared = 0;
        for (w, h) in [(3, 3), (17, 5), (40, 33), (64, 64)] {
            // Smoothed noise, so regions of many sizes appear at each level.
            let raw: Vec<f32> = (0..w * h).map(|_| rnd()).collect();
            let data: Vec<f32> = (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    let mut s = 0.0;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        s += raw[((y + dy) % h) * w + (x + dx) % w];
                    }
                    s / 4.0
                })
                .collect();
            let img = Image { width: w, height: h, data };
            for level in [0.3f32, 0.45, 0.5, 0.55, 0.7] {
                let mut cc = Components::default();
                cc.label(&img, |v| v < level);
                let runs = cc.regions();
                let fill = flood(&img, |v| v < level);
                compared += fill.len();
                assert_eq!(runs, fill, "{w}×{h} at {level}");
            }
        }
        assert!(compared > 200, "only {compared} regions");
    }
}
