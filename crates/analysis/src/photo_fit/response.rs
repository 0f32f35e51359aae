//! The camera's gamma from complementary photographs, before any render.
//!
//! A pattern and its inverse light a scene with two images that add up to the all-white one, and
//! light adds, so at every pixel the irradiances of the four photographs obey
//! E(pattern) + E(inverse) − 2 E(black) = s (E(white) − E(black)), with s = 1 for a projector
//! whose output is additive: each side carries the ambient light and the projector's black level
//! twice. A projector may deliver a little less (or more) light for two complementary halves than
//! for the all-white image; s < 1 takes that up. Through the response of [`super::model`],
//! y = b + g · E^(1/γ), and with α = (y_a − b)/(y_w − b), κ = (y_c − b)/(y_w − b),
//! η = (y_k − b)/(y_w − b) (a, c the pair, w white, k black, b the camera's black level):
//!
//! ```text
//! r = α^γ + κ^γ − 2 η^γ − s (1 − η^γ) = 0        for any gain g
//! ```
//!
//! Pixels that one frame of the pair lights fully and the other not at all give
//! r = (1 − s)(1 − η^γ) and so fix s; the pixels in between (edges blurred by the lenses, stripes
//! finer than the camera resolves) fix γ, since a power law bends mid-level codes and not the
//! ends. For each γ the best s is linear least squares; γ minimises the remaining sum of squares,
//! by golden-section search on ln γ. At γ = 1 the law does not involve b (b only scales the
//! residuals), so b matters only for a camera that is not linear.

// `!(x > y)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use anyhow::{bail, Result};

/// Smallest γ searched.
pub const GAMMA_MIN: f64 = 0.3;
/// Largest γ searched.
pub const GAMMA_MAX: f64 = 5.0;
/// Pixels whose white code exceeds the black level by less than this (full scale 1) are left out.
pub const MIN_WHITE: f64 = 0.05;
/// Pixels with a code above this in the pair or the white frame are left out (clipped).
pub const MAX_CODE: f64 = 0.98;

/// What [`gamma_from_pairs`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct PairGamma {
    /// The camera's gamma γ of y = b + g · E^(1/γ).
    pub gamma: f64,
    /// The projector's additivity s: the light of a pattern and its inverse together over the
    /// all-white image's, both above the all-black image's (1: additive).
    pub additivity: f64,
    /// The camera's black level b it was measured with (code, full scale 1).
    pub black_level: f64,
    /// Root mean square of the residual r at that γ (in units of white's E).
    pub rms: f64,
    /// Pixels × pairs that entered.
    pub residuals: usize,
    /// Complementary pairs used.
    pub pairs: usize,
}

/// Normalised codes (α, κ, η) of every pixel that enters, over all pairs.
fn samples(pairs: &[(&[f32], &[f32])], white: &[f32], black: &[f32], black_level: f64, stride: usize) -> Vec<[f64; 3]> {
    let mut out = vec![];
    for (a, c) in pairs {
        for i in (0..white.len()).step_by(stride.max(1)) {
            let (ya, yc, yw, yk) = (a[i] as f64, c[i] as f64, white[i] as f64, black[i] as f64);
            let span = yw - black_level;
            if !(span > MIN_WHITE) || ya.max(yc).max(yw) > MAX_CODE || !(yk < yw) {
                continue;
            }
            let n = |y: f64| ((y - black_level) / span).max(0.0);
            out.push([n(ya), n(yc), n(yk)]);
        }
    }
    out
}

/// (sum of squared residuals, additivity s) at `gamma`, s chosen by least squares.
fn cost(samples: &[[f64; 3]], gamma: f64) -> (f64, f64) {
    let (mut aa, mut ab, mut bb) = (0.0, 0.0, 0.0);
    for &[a, c, k] in samples {
        let kg = k.powf(gamma);
        let x = a.powf(gamma) + c.powf(gamma) - 2.0 * kg;
        let y = 1.0 - kg;
        aa += x * x;
        ab += x * y;
        bb += y * y;
    }
    let s = if bb > 0.0 { ab / bb } else { 1.0 };
    ((aa - s * ab).max(0.0), s)
}

/// The gamma (and the projector's additivity) that make complementary frames add up (module
/// documentation). `pairs` are the codes
/// (full scale 1) of a pattern and its inverse, `white` and `black` those of the all-white and
/// all-black frames, all of one size; `black_level` is the camera's code for no light; every
/// `stride`-th pixel enters. Errors when no pair is given or no pixel qualifies.
pub fn gamma_from_pairs(pairs: &[(&[f32], &[f32])], white: &[f32], black: &[f32], black_level: f64, stride: usize) -> Result<PairGamma> {
    if pairs.is_empty() {
        bail!("no complementary pair of frames (a pattern and its inverse) among the photographs");
    }
    let n = white.len();
    if black.len() != n || pairs.iter().any(|(a, c)| a.len() != n || c.len() != n) {
        bail!("complementary frames of different sizes");
    }
    let s = samples(pairs, white, black, black_level, stride);
    if s.is_empty() {
        bail!("no pixel where the white frame is more than {MIN_WHITE} of full scale above the black level {black_level} and unclipped");
    }
    // Golden-section search on ln γ.
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = (GAMMA_MIN.ln(), GAMMA_MAX.ln());
    let mut x1 = hi - phi * (hi - lo);
    let mut x2 = lo + phi * (hi - lo);
    let (mut f1, mut f2) = (cost(&s, x1.exp()).0, cost(&s, x2.exp()).0);
    for _ in 0..80 {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - phi * (hi - lo);
            f1 = cost(&s, x1.exp()).0;
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + phi * (hi - lo);
            f2 = cost(&s, x2.exp()).0;
        }
    }
    let gamma = (0.5 * (lo + hi)).exp();
    let (sum, additivity) = cost(&s, gamma);
    let rms = (sum / s.len() as f64).sqrt();
    Ok(PairGamma { gamma, additivity, black_level, rms, residuals: s.len(), pairs: pairs.len() })
}

/// Indices of the all-white frame, the all-black frame and the complementary pairs.
pub type FrameRoles = (usize, usize, Vec<(usize, usize)>);

/// The frames among `patterns` (the projector image of each photograph, values 0–1; `None` where
/// unknown) that are all-white and all-black, and the pairs that are a pattern and its inverse
/// (the two add up to 1 at every projector pixel, to 1e-3), each frame in at most one pair, in
/// order of the first. Errors name what is missing.
pub fn complementary_pairs(patterns: &[Option<&[f32]>]) -> Result<FrameRoles> {
    let constant = |v: f32| patterns.iter().position(|p| p.is_some_and(|p| !p.is_empty() && p.iter().all(|&x| (x - v).abs() <= 1e-3)));
    let Some(white) = constant(1.0) else { bail!("no all-white frame among the photographs (a pattern that is 1 everywhere)") };
    let Some(black) = constant(0.0) else { bail!("no all-black frame among the photographs (a pattern that is 0 everywhere)") };
    let mut used = vec![false; patterns.len()];
    used[white] = true;
    used[black] = true;
    let mut pairs = vec![];
    for i in 0..patterns.len() {
        let Some(pi) = patterns[i].filter(|_| !used[i]) else { continue };
        for j in i + 1..patterns.len() {
            let Some(pj) = patterns[j].filter(|p| !used[j] && p.len() == pi.len()) else { continue };
            if pi.iter().zip(pj).all(|(a, b)| (a + b - 1.0).abs() <= 1e-3) {
                pairs.push((i, j));
                used[i] = true;
                used[j] = true;
                break;
            }
        }
    }
    if pairs.is_empty() {
        bail!("no two photographs with complementary patterns (a pattern and its inverse)");
    }
    Ok((white, black, pairs))
}
