//! A procedural checkerboard of two spectra, for calibration targets.

use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use glam::Vec2;
use optics::spectrum::DenseSpectrum;

/// `squares` × `squares` squares over the unit (u, v) square (repeating outside it); the square
/// at the origin, [0, 1/n)², and every square an even number of steps from it are `even`.
/// Point-sampled (no filtering), as Mitsuba 3's `checkerboard`.
#[derive(Clone, Debug)]
pub struct Checkerboard {
    /// Squares per side of the unit square.
    pub squares: u32,
    /// Spectrum of the even squares.
    pub even: DenseSpectrum,
    /// Spectrum of the odd squares.
    pub odd: DenseSpectrum,
}

impl Checkerboard {
    /// Whether `uv` lies in an even square.
    #[inline]
    pub fn is_even(&self, uv: Vec2) -> bool {
        let n = self.squares as f32;
        let (i, j) = ((uv.x * n).floor() as i64, (uv.y * n).floor() as i64);
        (i + j).rem_euclid(2) == 0
    }

    /// The spectrum at `uv`.
    #[inline]
    pub fn eval(&self, wl: &SampledWavelengths, uv: Vec2) -> SampledSpectrum {
        wl.eval(if self.is_even(uv) { &self.even } else { &self.odd })
    }
}
