//! e^x for four lanes at once: the transmittances of the four carried wavelengths are computed
//! at every free flight, and four calls of the scalar `expf` take about twice the instructions
//! (callgrind, whole-milk close-up; docs/milk-glass.md).
//!
//! Cody–Waite range reduction x = n ln 2 + r, |r| ≤ ln 2 / 2 (ln 2 split in two parts, so r is
//! exact to a few ulp), then the degree-7 Taylor-like minimax polynomial of Cephes' `expf`
//! (Moshier 1989) for e^r, and the scaling by 2^n through the exponent bits. Relative error
//! 7.7e-8 at most against the f64 exponential on a dense grid over [−87, 88.5] (the test allows
//! 2.5e-7); exactly 0 below x = −87.3 (where `f32::exp` gives denormals or 0), +∞ above 88.7,
//! NaN for NaN.

use glam::Vec4;

const LOG2E: f32 = std::f32::consts::LOG2_E;
const LN2_HI: f32 = 0.693_359_4;
const LN2_LO: f32 = -2.121_944_4e-4;
/// Below this e^x is under the smallest normal f32 (and returned as 0).
const MIN_X: f32 = -87.336_54;
/// Above this e^x overflows f32.
const MAX_X: f32 = 88.722_83;

/// e^x per lane (see the module documentation for the accuracy).
#[inline]
pub fn exp4(x: Vec4) -> Vec4 {
    let xc = x.clamp(Vec4::splat(MIN_X), Vec4::splat(MAX_X));
    let (n, scale) = round_and_pow2(xc * LOG2E);
    let r = xc - n * LN2_HI - n * LN2_LO;
    let r2 = r * r;
    let p = ((((Vec4::splat(1.987_569_1e-4) * r + 1.398_199_9e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2) * r + 1.666_666_5e-1) * r + 5.000_000_1e-1;
    let y = p * r2 + r + Vec4::ONE;
    let out = y * scale[0] * scale[1];
    let out = Vec4::select(x.cmplt(Vec4::splat(MIN_X)), Vec4::ZERO, out);
    let out = Vec4::select(x.cmpgt(Vec4::splat(MAX_X)), Vec4::INFINITY, out);
    // NaN in, NaN out (the clamp would have turned it into a number).
    Vec4::select(x.cmpeq(x), out, x)
}

/// n = round(y) per lane (|y| ≤ 128) and 2^n as two normal factors 2^⌊n/2⌋ · 2^(n − ⌊n/2⌋),
/// each built from its exponent bits.
#[cfg(target_arch = "x86_64")]
#[inline]
fn round_and_pow2(y: Vec4) -> (Vec4, [Vec4; 2]) {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of x86_64; these intrinsics only move and convert register lanes.
    unsafe {
        let k = _mm_cvtps_epi32(y.into());
        let n = _mm_cvtepi32_ps(k);
        let k1 = _mm_srai_epi32::<1>(k);
        let k2 = _mm_sub_epi32(k, k1);
        let bias = _mm_set1_epi32(127);
        let p1 = _mm_castsi128_ps(_mm_slli_epi32::<23>(_mm_add_epi32(k1, bias)));
        let p2 = _mm_castsi128_ps(_mm_slli_epi32::<23>(_mm_add_epi32(k2, bias)));
        (n.into(), [p1.into(), p2.into()])
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline]
fn round_and_pow2(y: Vec4) -> (Vec4, [Vec4; 2]) {
    let n = y.round();
    let pow2 = |k: i32| f32::from_bits(((k + 127) as u32) << 23);
    let k = n.to_array().map(|v| v as i32);
    (n, [Vec4::from_array(k.map(|k| pow2(k >> 1))), Vec4::from_array(k.map(|k| pow2(k - (k >> 1))))])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against `f32::exp` (computed in f64 as the reference) on a dense grid over the normal
    /// range, at the ends and for special values.
    #[test]
    fn matches_exp_to_a_few_ulp() {
        let mut worst = 0f64;
        let mut x = -87.0f32;
        while x < 88.5 {
            let xs = Vec4::new(x, x * 0.5, -x * 0.25, x + 1e-3);
            let got = exp4(xs).to_array();
            for (g, xi) in got.iter().zip(xs.to_array()) {
                let want = (xi as f64).exp();
                worst = worst.max(((*g as f64) - want).abs() / want);
            }
            x += 0.0137;
        }
        assert!(worst < 2.5e-7, "worst relative error {worst:e}");
        let s = exp4(Vec4::new(0.0, -100.0, 100.0, f32::NAN)).to_array();
        assert_eq!(s[0], 1.0);
        assert_eq!(s[1], 0.0);
        assert_eq!(s[2], f32::INFINITY);
        assert!(s[3].is_nan());
        assert_eq!(exp4(Vec4::splat(f32::NEG_INFINITY)), Vec4::ZERO);
        assert_eq!(exp4(Vec4::splat(f32::INFINITY)), Vec4::INFINITY);
    }
}
