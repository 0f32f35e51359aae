//! Textures: quantities that vary over a surface with its texture coordinates (u, v).
//!
//! (u, v) run left to right and bottom to top of an image (the OBJ, pbrt-v4 and Mitsuba 3
//! convention; see [`crate::accel::SurfacePoint::uv`] for where they come from). A
//! [`SpectrumTexture`] gives a spectrum at the path's wavelengths — a constant spectrum, an image
//! whose RGB texels are uplifted to spectra per texel ([`image`]), or a procedural checkerboard
//! ([`checkerboard`]); a [`FloatTexture`] gives one number (a roughness); a
//! [`shading_map::ShadingMap`] tilts the shading normal (normal and bump maps).

pub mod checkerboard;
pub mod image;
pub mod shading_map;

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
    /// The image tiles the plane mirrored in every other tile (period 2 in u and v), so the
    /// texels repeat edge to edge without a seam (Mitsuba 3's `mirror`).
    Mirror,
}

impl Wrap {
    /// The wrap mode named `name` in scene files.
    pub fn from_name(name: &str) -> Option<Wrap> {
        match name {
            "repeat" => Some(Wrap::Repeat),
            "clamp" => Some(Wrap::Clamp),
            "mirror" => Some(Wrap::Mirror),
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
        self.eval_with(wl, || uv)
    }

    /// [`SpectrumTexture::eval`] with the texture coordinates computed by `uv` only when the
    /// value depends on them (a constant never calls it).
    #[inline(always)]
    pub fn eval_with(&self, wl: &SampledWavelengths, uv: impl FnOnce() -> Vec2) -> SampledSpectrum {
        match self {
            SpectrumTexture::Constant(s) => wl.eval(s),
            SpectrumTexture::Image(t) => t.eval(wl, uv()),
            SpectrumTexture::Checkerboard(c) => c.eval(wl, uv()),
        }
    }

    /// This texture times `k` (≥ 0).
    pub fn scaled(&self, k: f64) -> SpectrumTexture {
        let sc = |s: &DenseSpectrum| DenseSpectrum::from_fn(|x| s.eval(x as f32) as f64 * k);
        match self {
            SpectrumTexture::Constant(s) => SpectrumTexture::Constant(sc(s)),
            SpectrumTexture::Image(t) => SpectrumTexture::Image(Arc::new(t.scaled(k as f32))),
            SpectrumTexture::Checkerboard(c) => SpectrumTexture::Checkerboard(Arc::new(checkerboard::Checkerboard { squares: c.squares, even: sc(&c.even), odd: sc(&c.odd) })),
        }
    }

    /// A spectrum standing for the texture as a whole: the constant itself; for a checkerboard
    /// the mean of its two spectra; for an image the uplift of its mean texel colour (an
    /// approximation of the mean texel spectrum, used to choose lights by power and to scale
    /// to a `power_w`).
    pub fn representative(&self) -> DenseSpectrum {
        match self {
            SpectrumTexture::Constant(s) => s.clone(),
            SpectrumTexture::Image(t) => t.representative(),
            SpectrumTexture::Checkerboard(c) => DenseSpectrum::from_fn(|x| 0.5 * (c.even.eval(x as f32) + c.odd.eval(x as f32)) as f64),
        }
    }

    /// An upper bound of the texture's value over all (u, v) and wavelengths.
    pub fn peak(&self) -> f64 {
        let max = |s: &DenseSpectrum| (0..=470).map(|i| s.eval(360.0 + i as f32) as f64).fold(0.0, f64::max);
        match self {
            SpectrumTexture::Constant(s) => max(s),
            SpectrumTexture::Image(t) => t.peak(),
            SpectrumTexture::Checkerboard(c) => max(&c.even).max(max(&c.odd)),
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
        self.eval_with(|| uv)
    }

    /// [`FloatTexture::eval`] with the texture coordinates computed by `uv` only when needed.
    #[inline(always)]
    pub fn eval_with(&self, uv: impl FnOnce() -> Vec2) -> f32 {
        match self {
            FloatTexture::Constant(x) => *x,
            FloatTexture::Image(t) => t.eval(uv()),
        }
    }
}

/// How an image texture is read between texel centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Filter {
    /// The four nearest texels weighted bilinearly (the default; Mitsuba 3's `bilinear`).
    #[default]
    Bilinear,
    /// The texel whose square holds the point (Mitsuba 3's `nearest`).
    Nearest,
}

impl Filter {
    /// The filter named `name` in scene files: `"bilinear"` or `"nearest"`.
    pub fn from_name(name: &str) -> Option<Filter> {
        match name {
            "bilinear" => Some(Filter::Bilinear),
            "nearest" => Some(Filter::Nearest),
            _ => None,
        }
    }
}

/// Footprint of `uv` on a `w` × `h` grid of texels whose squares are [i/w, (i + 1)/w] ×
/// [1 − (j + 1)/h, 1 − j/h] (centres at ((i + ½)/w, 1 − (j + ½)/h), row j = 0 the top of the
/// image): four texel indices (row-major) and their weights. Bilinear: the four texels around
/// the point; nearest: the texel whose square holds it, with weight 1 (the others 0).
#[inline]
pub(crate) fn footprint(uv: Vec2, scale: Vec2, w: usize, h: usize, wrap: Wrap, filter: Filter) -> ([usize; 4], [f32; 4]) {
    let half = if filter == Filter::Nearest { 0.0 } else { 0.5 };
    let x = uv.x * scale.x * w as f32 - half;
    let y = (1.0 - uv.y * scale.y) * h as f32 - half;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = if filter == Filter::Nearest { (0.0, 0.0) } else { (x - x0, y - y0) };
    let idx = |i: f32, n: usize| -> usize {
        let n_i = n as i64;
        let i = if i.is_finite() { i as i64 } else { 0 };
        match wrap {
            Wrap::Repeat => i.rem_euclid(n_i) as usize,
            Wrap::Clamp => i.clamp(0, n_i - 1) as usize,
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n_i);
                (if m < n_i { m } else { 2 * n_i - 1 - m }) as usize
            }
        }
    };
    let (xa, xb, ya, yb) = (idx(x0, w), idx(x0 + 1.0, w), idx(y0, h), idx(y0 + 1.0, h));
    (
        [ya * w + xa, ya * w + xb, yb * w + xa, yb * w + xb],
        [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy],
    )
}
