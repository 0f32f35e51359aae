//! Textures: quantities that vary over a surface with its texture coordinates (u, v).
//!
//! (u, v) run left to right and bottom to top of an image (the OBJ, pbrt-v4 and Mitsuba 3
//! convention; see [`crate::accel::SurfacePoint::uv`] for where they come from). A
//! [`SpectrumTexture`] gives a spectrum at the path's wavelengths — a constant spectrum, an image
//! whose RGB texels are uplifted to spectra per texel ([`image`]), or a procedural checkerboard
//! ([`checkerboard`]); a [`FloatTexture`] gives one number (a roughness).

pub mod checkerboard;
pub mod image;

use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use glam::Vec2;
use optics::spectrum::DenseSpectrum;
use std::sync::Arc;

/// What a lookup outside [0, 1]² does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles the plane (u and v taken modulo 1).
    Repeat,
    /// Coordinates are clamped to the image's edge texels.
    Clamp,
}

impl Wrap {
    /// The wrap mode named `name` in scene files.
    pub fn from_name(name: &str) -> Option<Wrap> {
        match name {
            "repeat" => Some(Wrap::Repeat),
            "clamp" => Some(Wrap::Clamp),
            _ => None,
        }
    }
}

/// A spectrum that may vary over the surface.
#[derive(Clone, Debug)]
pub enum SpectrumTexture {
    /// The same spectrum everywhere.
    Constant(DenseSpectrum),
    /// An RGB image, uplifted per texel and filtered bilinearly.
    Image(Arc<image::SpectralImage>),
    /// A checkerboard of two spectra.
    Checkerboard(Arc<checkerboard::Checkerboard>),
}

impl SpectrumTexture {
    /// The spectrum at texture coordinates `uv`, at the wavelengths `wl`.
    #[inline(always)]
    pub fn eval(&self, wl: &SampledWavelengths, uv: Vec2) -> SampledSpectrum {
        match self {
            SpectrumTexture::Constant(s) => wl.eval(s),
            SpectrumTexture::Image(t) => t.eval(wl, uv),
            SpectrumTexture::Checkerboard(c) => c.eval(wl, uv),
        }
    }

    /// The spectrum if it is the same everywhere.
    pub fn as_constant(&self) -> Option<&DenseSpectrum> {
        match self {
            SpectrumTexture::Constant(s) => Some(s),
            SpectrumTexture::Image(_) | SpectrumTexture::Checkerboard(_) => None,
        }
    }

    /// Whether the value depends on (u, v) (the surface then needs texture coordinates).
    pub fn is_textured(&self) -> bool {
        self.as_constant().is_none()
    }
}

impl From<DenseSpectrum> for SpectrumTexture {
    fn from(s: DenseSpectrum) -> Self {
        SpectrumTexture::Constant(s)
    }
}

/// A number that may vary over the surface.
#[derive(Clone, Debug)]
pub enum FloatTexture {
    /// The same value everywhere.
    Constant(f32),
    /// One channel of an image, filtered bilinearly.
    Image(Arc<image::FloatImage>),
}

impl FloatTexture {
    /// The value at texture coordinates `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> f32 {
        match self {
            FloatTexture::Constant(x) => *x,
            FloatTexture::Image(t) => t.eval(uv),
        }
    }
}

/// Bilinear footprint of `uv` on a `w` × `h` grid of texels whose centres sit at
/// ((i + ½)/w, 1 − (j + ½)/h), row j = 0 the top of the image: the four texel indices
/// (row-major) and their weights.
#[inline]
pub(crate) fn bilinear(uv: Vec2, scale: Vec2, w: usize, h: usize, wrap: Wrap) -> ([usize; 4], [f32; 4]) {
    let x = uv.x * scale.x * w as f32 - 0.5;
    let y = (1.0 - uv.y * scale.y) * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let idx = |i: f32, n: usize| -> usize {
        let n_i = n as i64;
        let i = if i.is_finite() { i as i64 } else { 0 };
        match wrap {
            Wrap::Repeat => i.rem_euclid(n_i) as usize,
            Wrap::Clamp => i.clamp(0, n_i - 1) as usize,
        }
    };
    let (xa, xb, ya, yb) = (idx(x0, w), idx(x0 + 1.0, w), idx(y0, h), idx(y0 + 1.0, h));
    (
        [ya * w + xa, ya * w + xb, yb * w + xa, yb * w + xb],
        [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy],
    )
}
