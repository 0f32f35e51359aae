//! Image textures: PNG and JPEG (8 or 16 bits, sRGB-decoded unless `linear`), OpenEXR and PFM
//! (linear floats, read by [`crate::image_io`]), read bilinearly or from the nearest texel, with
//! repeat, clamp or mirror wrap.
//!
//! RGB texels are uplifted to spectra once, per texel, as pbrt-v4 and Mitsuba 3 do
//! ([`optics::uplift`], Jakob & Hanika 2019): a reflectance to the bounded sigmoid spectrum, an
//! emission to 2·max(rgb) × the sigmoid of rgb/(2·max) × D65. A lookup evaluates the four
//! neighbouring texels' spectra at the path's wavelengths and weights those (interpolating
//! spectra, not RGB).

// `!(x >= 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{footprint, Filter, Wrap};
use crate::image_io::{read_image, Image};
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use crate::math::uplift::{normalized_lambda, sigmoid_shape, uplift_colours};
use anyhow::{anyhow, bail, Context, Result};
use glam::{Vec2, Vec4};
use optics::spectrum::DenseSpectrum;
use optics::uplift::SigmoidSpectrum;
use std::path::Path;

/// How 8- and 16-bit texel values map to linear values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// The sRGB transfer curve (IEC 61966-2-1), the default for PNG and JPEG.
    Srgb,
    /// Value / maximum code, as stored.
    Linear,
}

/// Reads an image file into linear RGB: PNG and JPEG through `encoding`, EXR and PFM as stored
/// (the encoding does not apply to them). Refuses non-finite or negative texels, naming the
/// first one.
pub fn read_texture_image(path: &Path, encoding: Encoding) -> Result<Image> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default();
    let img = match ext.as_str() {
        "png" | "jpg" | "jpeg" => {
            let reader = ::image::ImageReader::open(path).with_context(|| format!("cannot open {}", path.display()))?;
            let reader = reader.with_guessed_format().with_context(|| format!("cannot read {}", path.display()))?;
            let decoded = reader.decode().map_err(|e| anyhow!("{}: {e}", path.display()))?;
            let (w, h) = (decoded.width(), decoded.height());
            let lut: Vec<f32> = (0..256).map(|i| optics::color::srgb_decode(i as f64 / 255.0) as f32).collect();
            let rgb: Vec<[f32; 3]> = match (decoded.color(), encoding) {
                (::image::ColorType::L8 | ::image::ColorType::La8 | ::image::ColorType::Rgb8 | ::image::ColorType::Rgba8, Encoding::Srgb) => {
                    decoded.to_rgb8().pixels().map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]]).collect()
                }
                (_, Encoding::Srgb) => decoded
                    .to_rgb32f()
                    .pixels()
                    .map(|p| [0, 1, 2].map(|k| optics::color::srgb_decode(p[k] as f64) as f32))
                    .collect(),
                (_, Encoding::Linear) => decoded.to_rgb32f().pixels().map(|p| [p[0], p[1], p[2]]).collect(),
            };
            Image::from_rgb(w, h, rgb)?
        }
        "exr" | "pfm" => read_image(path).map_err(|e| anyhow!("{e:#}"))?,
        _ => bail!("{}: unknown texture image extension `.{ext}` (expected .png, .jpg, .jpeg, .exr or .pfm)", path.display()),
    };
    if img.width == 0 || img.height == 0 {
        bail!("{}: image has no texels", path.display());
    }
    for (i, p) in img.rgb.iter().enumerate() {
        if p.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
            let (x, y) = (i % img.width as usize, i / img.width as usize);
            bail!("{}: texel ({x}, {y}) is {:?} (texels must be finite and non-negative)", path.display(), p);
        }
    }
    Ok(img)
}

/// What the RGB of a [`SpectralImage`] means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Uplift {
    /// Reflectance in [0, 1] (albedo): bounded sigmoid spectra.
    Reflectance,
    /// Emitted radiance (≥ 0): illuminant spectra, D65 for grey.
    Illuminant,
}

/// An RGB image uplifted to one spectrum per texel.
#[derive(Clone, Debug)]
pub struct SpectralImage {
    width: usize,
    height: usize,
    wrap: Wrap,
    filter: Filter,
    /// (u, v) multipliers applied before the lookup (tiling).
    uv_scale: Vec2,
    /// Per texel: sigmoid coefficients (c₀, c₁, c₂) and the scale.
    texels: Vec<[f32; 4]>,
    /// D65 for illuminants (relative, luminance 1), None for reflectances.
    d65: Option<DenseSpectrum>,
    /// Mean texel colour (linear sRGB), times the scale applied by [`SpectralImage::scaled`].
    mean_rgb: [f64; 3],
}

impl SpectralImage {
    /// Uplifts every texel of `img` (linear sRGB). Reflectances must lie in [0, 1]; the error
    /// names the first texel that does not.
    pub fn new(img: &Image, uplift: Uplift, wrap: Wrap, uv_scale: Vec2) -> Result<SpectralImage> {
        if uplift == Uplift::Reflectance {
            if let Some(i) = img.rgb.iter().position(|p| p.iter().any(|&c| !(c <= 1.0))) {
                let (x, y) = (i % img.width as usize, i / img.width as usize);
                bail!("texel ({x}, {y}) is {:?}: an albedo must lie in [0, 1]", img.rgb[i]);
            }
        }
        let texels = uplift_colours(&img.rgb, uplift == Uplift::Illuminant);
        let d65 = match uplift {
            Uplift::Reflectance => None,
            Uplift::Illuminant => Some(DenseSpectrum::from_fn(optics::spectrum::d65_normalized)),
        };
        let n = img.rgb.len().max(1) as f64;
        let mean_rgb = img.rgb.iter().fold([0.0f64; 3], |a, p| [0, 1, 2].map(|k| a[k] + p[k] as f64)).map(|v| v / n);
        Ok(SpectralImage { width: img.width as usize, height: img.height as usize, wrap, filter: Filter::Bilinear, uv_scale, texels, d65, mean_rgb })
    }

    /// The same image read with `filter`.
    pub fn with_filter(self, filter: Filter) -> SpectralImage {
        SpectralImage { filter, ..self }
    }

    /// This image with every texel spectrum multiplied by `k` (≥ 0).
    pub fn scaled(&self, k: f32) -> SpectralImage {
        let mut out = self.clone();
        for c in &mut out.texels {
            c[3] *= k;
        }
        out.mean_rgb = out.mean_rgb.map(|v| v * k as f64);
        out
    }

    /// The uplift of the mean texel colour (with D65 for illuminants): stands for the image as
    /// a whole where one spectrum is needed (light choice by power).
    pub fn representative(&self) -> DenseSpectrum {
        match &self.d65 {
            Some(d) => {
                let s = SigmoidSpectrum::illuminant(self.mean_rgb);
                DenseSpectrum::from_fn(|l| s.eval(l) * d.eval(l as f32) as f64)
            }
            None => {
                let s = SigmoidSpectrum::reflectance(self.mean_rgb);
                DenseSpectrum::from_fn(|l| s.eval(l))
            }
        }
    }

    /// An upper bound of every texel spectrum (with D65 for illuminants) at every wavelength.
    pub fn peak(&self) -> f64 {
        let scale = self.texels.iter().map(|c| c[3] as f64).fold(0.0, f64::max);
        let d = self.d65.as_ref().map_or(1.0, |d| (0..=470).map(|i| d.eval(360.0 + i as f32) as f64).fold(0.0, f64::max));
        scale * d
    }

    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The spectrum of texel (x, y) (y = 0 the top row) at `lambda_nm`, before any D65 factor.
    pub fn texel(&self, x: usize, y: usize, lambda_nm: f64) -> f64 {
        let c = self.texels[y * self.width + x];
        SigmoidSpectrum { coeffs: [c[0] as f64, c[1] as f64, c[2] as f64], scale: c[3] as f64 }.eval(lambda_nm)
    }

    /// The texel spectra at `uv` weighted by the filter, at the wavelengths `wl`.
    #[inline]
    pub fn eval(&self, wl: &SampledWavelengths, uv: Vec2) -> SampledSpectrum {
        let (idx, w) = footprint(uv, self.uv_scale, self.width, self.height, self.wrap, self.filter);
        let t = normalized_lambda(wl);
        let mut out = Vec4::ZERO;
        for k in 0..4 {
            if w[k] == 0.0 {
                continue;
            }
            let c = self.texels[idx[k]];
            out += w[k] * c[3] * sigmoid_shape(c, t);
        }
        match &self.d65 {
            Some(d) => out * wl.eval(d),
            None => out,
        }
    }
}

/// One channel of an image (the mean of R, G and B: the value itself for a greyscale image),
/// filtered bilinearly.
#[derive(Clone, Debug)]
pub struct FloatImage {
    width: usize,
    height: usize,
    wrap: Wrap,
    filter: Filter,
    uv_scale: Vec2,
    values: Vec<f32>,
}

impl FloatImage {
    /// The channel mean of every texel of `img`.
    pub fn new(img: &Image, wrap: Wrap, uv_scale: Vec2) -> FloatImage {
        let values = img.rgb.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).collect();
        FloatImage { width: img.width as usize, height: img.height as usize, wrap, filter: Filter::Bilinear, uv_scale, values }
    }

    /// The same image read with `filter`.
    pub fn with_filter(self, filter: Filter) -> FloatImage {
        FloatImage { filter, ..self }
    }

    /// Largest texel value.
    pub fn max_value(&self) -> f32 {
        self.values.iter().copied().fold(0.0, f32::max)
    }

    /// The value at `uv`, interpolated bilinearly or read from the nearest texel.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> f32 {
        let (idx, w) = footprint(uv, self.uv_scale, self.width, self.height, self.wrap, self.filter);
        (0..4).map(|k| w[k] * self.values[idx[k]]).sum()
    }
}
