//! RGB colours as spectra at the carried wavelengths: many colours uplifted at once to the
//! sigmoid-polynomial spectra of [`optics::uplift`] (Jakob & Hanika 2019, as pbrt-v4 and
//! Mitsuba 3 do), stored as `[c₀, c₁, c₂, scale]` in f32, and evaluated four wavelengths at a
//! time. Image textures and RGB albedo grids of media share them.

use crate::math::spectral::SampledWavelengths;
use glam::Vec4;
use optics::spectrum::{LAMBDA_MAX_NM, LAMBDA_MIN_NM};
use optics::uplift::{Fit, SigmoidSpectrum};

/// The sigmoid spectra of `rgb` (linear sRGB): the bounded reflectance uplift (components in
/// [0, 1], the caller checks), or with `illuminant` the emission shape 2·max(rgb) × the
/// reflectance of rgb/(2·max) (without D65). Each distinct colour is fitted once.
pub fn uplift_colours(rgb: &[[f32; 3]], illuminant: bool) -> Vec<[f32; 4]> {
    use rayon::prelude::*;
    // Photographs and grids repeat colours: fit each distinct colour once.
    let mut unique: Vec<[u32; 3]> = rgb.iter().map(|p| p.map(f32::to_bits)).collect();
    unique.sort_unstable();
    unique.dedup();
    // The coefficient table costs about a second of one core to build, a direct fit about a
    // millisecond a colour: few colours are fitted directly.
    let fit = if unique.len() <= 500 { Fit::Direct } else { Fit::Table };
    let fitted: Vec<[f32; 4]> = unique
        .par_iter()
        .map(|b| {
            let c = b.map(|x| f32::from_bits(x) as f64);
            let s = if illuminant { SigmoidSpectrum::illuminant_by(c, fit) } else { SigmoidSpectrum::reflectance_by(c, fit) };
            [s.coeffs[0] as f32, s.coeffs[1] as f32, s.coeffs[2] as f32, s.scale as f32]
        })
        .collect();
    rgb.iter()
        .map(|p| {
            let k = unique.binary_search(&p.map(f32::to_bits)).expect("every colour was fitted");
            fitted[k]
        })
        .collect()
}

/// The normalised wavelengths t = (λ − 360 nm)/(470 nm) of the carried wavelengths, the
/// argument of [`sigmoid_shape`].
#[inline]
pub fn normalized_lambda(wl: &SampledWavelengths) -> Vec4 {
    let span = (LAMBDA_MAX_NM - LAMBDA_MIN_NM) as f32;
    Vec4::from_array(wl.lambda_nm.map(|l| (l - LAMBDA_MIN_NM as f32) / span))
}

/// The sigmoid of the spectrum `c` (as [`uplift_colours`] stores it) at the normalised
/// wavelengths `t`, before its scale `c[3]`.
#[inline]
pub fn sigmoid_shape(c: [f32; 4], t: Vec4) -> Vec4 {
    let x = (c[0] * t + Vec4::splat(c[1])) * t + Vec4::splat(c[2]);
    Vec4::from_array(x.to_array().map(|x| 0.5 + x / (2.0 * (1.0 + x * x).sqrt())))
}
