//! Marker detection: Hough candidates ([`super::hough`]) refined to sub-pixel ellipses.
//!
//! Refinement of a candidate (centre c, radius r): rays from c at N angles (N ≈ 4πr, 48 … 360)
//! cross the disc's edge. Along each ray the edge is first placed at the strongest intensity step
//! of the candidate's polarity within [0.4 r, 1.7 r], then located to sub-pixel by the area
//! (first-moment) rule: with the inside level A and the outside level B (means over 1.5 px just
//! inside and outside a window of ± `edge_halfwidth_px` about the edge), the edge sits at
//! s₀ + ∫_{s₀}^{s₁} (I(s) − B)/(A − B) ds, exact for a straight step blurred by any normalised
//! kernel (the integral of a blurred step equals that of the step), and the profile is sampled by
//! bilinear interpolation every ¼ px. An ellipse is fitted to the edge points by Fitzgibbon's
//! direct least squares, points off it by more than 3 robust standard deviations dropped and the
//! fit repeated; then the rays are cast again from the fitted centre with windows about the fitted
//! ellipse, twice. A candidate is kept if at least `min_support` of its rays found an edge of the
//! right polarity and the RMS distance of the points from the ellipse is below `max_rms_px`.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::Matrix3;

use super::ellipse::{ellipse_of, fit_conic, radius_along, sampson_distance, Ellipse};
use super::hough::{candidates, Candidate, HoughSettings};
use super::{Image, Marker};

/// Settings of [`detect`].
#[derive(Clone, Copy, Debug)]
pub struct DetectSettings {
    /// The Hough transform's radius range and thresholds.
    pub hough: HoughSettings,
    /// Half-width of the window in which an edge is located along a ray (pixels): at least the
    /// blur radius of the edge plus one pixel.
    pub edge_halfwidth_px: f64,
    /// Fraction of rays that must find the edge.
    pub min_support: f64,
    /// Largest RMS distance of the edge points from the fitted ellipse (pixels).
    pub max_rms_px: f64,
    /// Smallest ratio of minor to major axis.
    pub min_axis_ratio: f64,
    /// Smallest |A − B| along a ray (image units; for linear 8-bit photographs about 2/255).
    pub min_contrast: f64,
}

impl Default for DetectSettings {
    fn default() -> Self {
        DetectSettings { hough: HoughSettings::default(), edge_halfwidth_px: 2.0, min_support: 0.75, max_rms_px: 0.5, min_axis_ratio: 0.3, min_contrast: 0.01 }
    }
}

/// Step along the rays (pixels).
const STEP: f64 = 0.25;
/// Length over which the levels inside and outside the window are averaged (pixels).
const LEVEL_PX: f64 = 1.5;

/// The detected markers of `img`, strongest Hough candidates first: refined radii within 5 % of the
/// radius range, duplicates (centres within a pixel and radii within 20 %) removed.
pub fn detect(img: &Image, s: &DetectSettings) -> Vec<Marker> {
    refine_all(img, &candidates(img, &s.hough), s)
}

/// Candidates refined to markers ([`refine`]), in the candidates' order: refined radii within 5 %
/// of the radius range, duplicates (centres within a pixel and radii within 20 %) removed.
pub fn refine_all(img: &Image, cands: &[Candidate], s: &DetectSettings) -> Vec<Marker> {
    let mut out: Vec<Marker> = Vec::new();
    for c in cands {
        let Some(m) = refine(img, c, s) else { continue };
        if m.radius_px < 0.95 * s.hough.radius_min_px || m.radius_px > 1.05 * s.hough.radius_max_px {
            continue;
        }
        let dup = out.iter().any(|o| o.dark == m.dark && (o.x - m.x).hypot(o.y - m.y) < 1.0 && (o.radius_px / m.radius_px - 1.0).abs() < 0.2);
        if !dup {
            out.push(m);
        }
    }
    out
}

/// Sub-pixel edge point along the ray c + s·u near `s_pred`; None if the window leaves the image,
/// the contrast is too low or of the wrong polarity, or the edge is not inside the window.
fn edge_on_ray(img: &Image, c: [f64; 2], u: [f64; 2], s_pred: f64, dark: bool, s: &DetectSettings) -> Option<f64> {
    let hw = s.edge_halfwidth_px;
    let mut s_c = s_pred;
    for _ in 0..3 {
        let (s0, s1) = (s_c - hw, s_c + hw);
        let at = |t: f64| img.bilinear(c[0] + t * u[0], c[1] + t * u[1]);
        let level = |from: f64| -> Option<f64> {
            let n = (LEVEL_PX / STEP).round() as usize;
            let mut sum = 0.0;
            for k in 0..=n {
                sum += at(from + k as f64 * STEP)?;
            }
            Some(sum / (n + 1) as f64)
        };
        let a = level(s0 - LEVEL_PX)?;
        let b = level(s1)?;
        let contrast = b - a;
        if (dark && contrast < s.min_contrast) || (!dark && -contrast < s.min_contrast) {
            return None;
        }
        let n = ((s1 - s0) / STEP).round() as usize;
        let mut integral = 0.0;
        let mut prev = (at(s0)? - b) / (a - b);
        for k in 1..=n {
            let v = (at(s0 + k as f64 * STEP)? - b) / (a - b);
            integral += 0.5 * (prev + v) * STEP;
            prev = v;
        }
        let e = s0 + integral;
        if (e - s_c).abs() <= 0.25 * hw {
            return (e > 0.5).then_some(e);
        }
        s_c = e;
    }
    None
}

/// The strongest step of the right polarity along the ray within [lo, hi] (pixels from c): the
/// largest difference of the samples 1 px beyond and 1 px before, sampled every ½ px (the edge is
/// then located to sub-pixel by [`edge_on_ray`]).
fn strongest_step(img: &Image, c: [f64; 2], u: [f64; 2], lo: f64, hi: f64, dark: bool) -> Option<f64> {
    const SEARCH: f64 = 0.5;
    let n = ((hi - lo) / SEARCH).ceil() as usize;
    let at = |k: usize| {
        let t = lo + (k as f64 - 2.0) * SEARCH;
        img.bilinear(c[0] + t * u[0], c[1] + t * u[1])
    };
    // The last five samples, k − 4 … k.
    let mut ring = [None; 5];
    let mut best: Option<(f64, f64)> = None;
    for k in 0..=n + 4 {
        ring[k % 5] = at(k);
        if k < 4 {
            continue;
        }
        let (Some(p), Some(q)) = (ring[(k - 4) % 5], ring[k % 5]) else { continue };
        let d = if dark { q - p } else { p - q };
        if d > 0.0 && best.is_none_or(|b| d > b.1) {
            best = Some((lo + (k as f64 - 4.0) * SEARCH, d));
        }
    }
    best.map(|b| b.0)
}

/// A fit: the conic, its ellipse, the points kept and their RMS distance from it.
type Fit = (Matrix3<f64>, Ellipse, Vec<[f64; 2]>, f64);

/// Fit with one round of outlier rejection.
fn robust_fit(points: &[[f64; 2]]) -> Option<Fit> {
    let q = fit_conic(points)?;
    let d: Vec<f64> = points.iter().map(|p| sampson_distance(&q, *p)).collect();
    let mut ad: Vec<f64> = d.iter().map(|x| x.abs()).collect();
    ad.sort_by(f64::total_cmp);
    let mad = 1.4826 * ad[ad.len() / 2];
    let lim = (3.0 * mad).max(0.05);
    let kept: Vec<[f64; 2]> = points.iter().zip(&d).filter(|(_, d)| d.abs() <= lim).map(|(p, _)| *p).collect();
    let q = fit_conic(&kept)?;
    let e = ellipse_of(&q)?;
    let rms = (kept.iter().map(|p| sampson_distance(&q, *p).powi(2)).sum::<f64>() / kept.len() as f64).sqrt();
    Some((q, e, kept, rms))
}

/// Refines one candidate to a marker (module documentation).
pub fn refine(img: &Image, cand: &Candidate, s: &DetectSettings) -> Option<Marker> {
    let r = cand.radius_px;
    let n_rays = ((4.0 * std::f64::consts::PI * r).ceil() as usize).clamp(48, 360);
    let dirs: Vec<[f64; 2]> = (0..n_rays).map(|k| (k as f64 + 0.5) / n_rays as f64 * std::f64::consts::TAU).map(|a| [a.cos(), a.sin()]).collect();
    let c0 = [cand.x, cand.y];
    // Most Hough candidates are not discs: 16 evenly spaced rays reject them first, when fewer
    // than half of those find an edge (a disc that passes the full test rarely fails this one).
    let probe = (0..16).filter(|k| {
        let u = dirs[k * n_rays / 16];
        strongest_step(img, c0, u, (0.4 * r).max(1.0), 1.7 * r, cand.dark).is_some_and(|s0| edge_on_ray(img, c0, u, s0, cand.dark, s).is_some())
    });
    if probe.count() < 8 {
        return None;
    }
    let mut pts = Vec::with_capacity(n_rays);
    for u in &dirs {
        let Some(s0) = strongest_step(img, c0, *u, (0.4 * r).max(1.0), 1.7 * r, cand.dark) else { continue };
        if let Some(e) = edge_on_ray(img, c0, *u, s0, cand.dark, s) {
            pts.push([c0[0] + e * u[0], c0[1] + e * u[1]]);
        }
    }
    if (pts.len() as f64) < s.min_support * n_rays as f64 {
        return None;
    }
    let (mut q, mut e, mut kept, mut rms) = robust_fit(&pts)?;
    let mut support = 0.0;
    for _ in 0..2 {
        let c = e.centre;
        let mut p2 = Vec::with_capacity(n_rays);
        for u in &dirs {
            let rho = radius_along(&q, &e, *u);
            if !rho.is_finite() {
                continue;
            }
            if let Some(t) = edge_on_ray(img, c, *u, rho, cand.dark, s) {
                p2.push([c[0] + t * u[0], c[1] + t * u[1]]);
            }
        }
        support = p2.len() as f64 / n_rays as f64;
        if support < s.min_support {
            return None;
        }
        (q, e, kept, rms) = robust_fit(&p2)?;
    }
    if rms > s.max_rms_px || e.semi_minor < s.min_axis_ratio * e.semi_major || (kept.len() as f64) < s.min_support * n_rays as f64 {
        return None;
    }
    Some(Marker {
        x: e.centre[0],
        y: e.centre[1],
        radius_px: (e.semi_major * e.semi_minor).sqrt(),
        ellipse: e,
        dark: cand.dark,
        support,
        rms_px: rms,
        score: cand.score,
        edge_points: kept,
    })
}
