//! e^x in single precision, for four lanes at once ([`exp4`]) and for one value ([`exp1`]):
//! the BSSRDF's monopoles and the volumetric transmittances evaluate four wavelengths at every
//! step, and four calls of libm's `expf` take about twice the instructions (callgrind, whole-milk
//! close-up; docs/milk-glass.md).

use glam::Vec4;

const LOG2E: f32 = std::f32::consts::LOG2_E;
/// ln 2 split in a high part exact in f32 products with small integers and the remainder.
const LN2_HI: f32 = 0.693_145_75;
const LN2_LO: f32 = 1.428_606_8e-6;
/// 1.5·2²³: adding and subtracting it rounds to the nearest integer (round-to-nearest mode).
const ROUND: f32 = 12_582_912.0;

/// e^x for four lanes (x ≤ 88; below −87 the result is 0). Cody–Waite reduction x = n ln 2 + r,
/// |r| ≤ ln 2/2, and the degree-6 Taylor polynomial of e^r (truncation error ≤ |r|⁷/7! ≈ 1.2e-7
/// relative); 2ⁿ is built in the exponent bits.
#[inline(always)]
pub fn exp4(x: Vec4) -> Vec4 {
    let xc = x.clamp(Vec4::splat(-87.0), Vec4::splat(88.0));
    let n = (xc * LOG2E + Vec4::splat(ROUND)) - Vec4::splat(ROUND);
    let r = xc - n * LN2_HI - n * LN2_LO;
    let mut p = Vec4::splat(1.0 / 720.0);
    p = p * r + Vec4::splat(1.0 / 120.0);
    p = p * r + Vec4::splat(1.0 / 24.0);
    p = p * r + Vec4::splat(1.0 / 6.0);
    p = p * r + Vec4::splat(0.5);
    p = p * r + Vec4::splat(1.0);
    p = p * r + Vec4::splat(1.0);
    let e = p * pow2(n);
    Vec4::select(x.cmplt(Vec4::splat(-87.0)), Vec4::ZERO, e)
}

/// 2ⁿ per lane for integral n in [−126, 127], built in the exponent bits.
#[inline(always)]
fn pow2(n: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86_64; these only convert and shift register lanes (the
        // conversion is exact: n is integral).
        unsafe { _mm_castsi128_ps(_mm_slli_epi32::<23>(_mm_add_epi32(_mm_cvtps_epi32(n.into()), _mm_set1_epi32(127)))).into() }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let scale: glam::IVec4 = (n.as_ivec4() + glam::IVec4::splat(127)) << glam::IVec4::splat(23);
        Vec4::from_array(scale.to_array().map(|b| f32::from_bits(b as u32)))
    }
}

/// e^x for one value, the same approximation as [`exp4`] (x ≤ 88; below −87 the result is 0).
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x >= −87)` also sends NaN to 0.
pub fn exp1(x: f32) -> f32 {
    if !(x >= -87.0) {
        return 0.0;
    }
    let xc = x.min(88.0);
    let n = (xc * LOG2E + ROUND) - ROUND;
    let r = xc - n * LN2_HI - n * LN2_LO;
    let p = ((((((1.0 / 720.0) * r + 1.0 / 120.0) * r + 1.0 / 24.0) * r + 1.0 / 6.0) * r + 0.5)
        * r
        + 1.0)
        * r
        + 1.0;
    p * f32::from_bits(((n as i32 + 127) << 23) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp4_matches_libm() {
        let mut worst = 0f64;
        let mut x = -87.0f32;
        while x < 80.0 {
            let e = exp4(Vec4::new(x, x + 0.013, x + 0.37, x + 0.71));
            for (k, dx) in [0.0f32, 0.013, 0.37, 0.71].iter().enumerate() {
                let xe = (x + dx) as f64;
                let rel = (e[k] as f64 / xe.exp() - 1.0).abs();
                worst = worst.max(rel);
            }
            x += 0.0917;
        }
        assert!(worst < 4e-7, "worst relative error {worst}");
        let mut worst1 = 0f64;
        let mut x = -87.0f32;
        while x < 80.0 {
            worst1 = worst1.max((exp1(x) as f64 / (x as f64).exp() - 1.0).abs());
            x += 0.0371;
        }
        assert!(worst1 < 4e-7, "worst relative error of exp1 {worst1}");
        assert_eq!(
            [exp1(-88.0), exp1(f32::NEG_INFINITY), exp1(f32::NAN), exp1(0.0)],
            [0.0, 0.0, 0.0, 1.0]
        );
        let e = exp4(Vec4::new(-88.0, -1000.0, 0.0, f32::NEG_INFINITY));
        assert_eq!(e, Vec4::new(0.0, 0.0, 1.0, 0.0));
    }
}
