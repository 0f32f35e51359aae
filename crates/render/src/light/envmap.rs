//! Latitude–longitude environment map: spectral radiance from every direction, given by an RGB
//! image, rotated into the world and importance-sampled.
//!
//! Orientation and texel placement follow Mitsuba 3's `envmap` emitter (src/emitters/envmap.cpp)
//! so that the same image and transform light a scene the same way in both renderers:
//!
//! - In the map's own frame, +y is up. A direction d with polar angle θ from +y and azimuth φ is
//!   d = (sin φ sin θ, cos θ, −cos φ sin θ); the image coordinates are u = φ / 2π (across, left to
//!   right) and v = θ / π (down, top row at the zenith). u = 0 looks along −z, u = 1/4 along +x.
//! - Columns are texel-centred and periodic in φ: column i sits at u = (i + ½)/W.
//! - Rows are placed corner to corner in θ: row j sits at v = j/(H − 1), the top row at the
//!   zenith and the bottom row at the nadir.
//! - Radiance between texels is the bilinear interpolation of the texels' *spectra* (not of their
//!   RGB), times `scale`.
//! - The light's transform maps the map's frame to the world: a world direction w looks up the
//!   map at R⁻¹ w, R the transform's rotation (its translation has no effect).
//!
//! Each texel's RGB (linear sRGB primaries, D65 white) is turned into an illuminant spectrum by
//! [`texel_spectrum`], the one place that knows the uplift; texels are converted once when the map
//! is built and evaluated at a path's four wavelengths per lookup (four texels per lookup, so
//! fitting a spectrum per lookup would be far too slow, while the fitted shape costs one sigmoid
//! per wavelength).
//!
//! Sampling: a piecewise-constant density p(u′, v) on the grid whose cells are spanned by four
//! neighbouring texel centres (u′ = u − ½/W), each cell's value the mean luminance of its four
//! corners times the mean of sin θ over its band of rows, so that the density follows
//! luminance × sin θ and is positive wherever the interpolated radiance is. Rows are chosen from
//! a marginal CDF and columns from the row's conditional CDF, each by binary search (O(log W +
//! log H) per sample); the density per steradian is p(u, v) / (2π² sin θ) (pbrt-v4 §12.5,
//! Mitsuba 3's `envmap`).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::image_io::Image;
use crate::math::sampling::sample_cdf;
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use glam::{Mat3, Vec2, Vec3, Vec4};
use optics::spectrum::DenseSpectrum;
use optics::uplift::SigmoidSpectrum;
use rayon::prelude::*;
use std::collections::HashMap;
use std::f32::consts::PI;

/// Relative luminance Y of linear sRGB (ITU-R BT.709 primaries, D65 white).
#[inline]
pub fn luminance(rgb: [f32; 3]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// The emission spectrum of one texel without the D65 white: 2·max(rgb) · ρ(λ), ρ the bounded
/// reflectance of rgb / (2·max(rgb)) from the sRGB coefficient table (Jakob & Hanika 2019, as
/// pbrt-v4 and Mitsuba 3). The full spectral radiance is this times D65(λ)/Y(D65).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelSpectrum {
    s: SigmoidSpectrum,
}

impl TexelSpectrum {
    /// Value at the four wavelengths (without the D65 factor).
    #[inline]
    pub fn eval(&self, wl: &SampledWavelengths) -> Vec4 {
        if self.s.scale == 0.0 {
            return Vec4::ZERO;
        }
        let l = wl.lambda_nm;
        Vec4::new(self.s.eval(l[0] as f64) as f32, self.s.eval(l[1] as f64) as f32, self.s.eval(l[2] as f64) as f32, self.s.eval(l[3] as f64) as f32)
    }
}

/// RGB → illuminant uplift of one texel, the one image textures use
/// (`optics::uplift::SigmoidSpectrum::illuminant`). Components must be finite and ≥ 0.
pub fn texel_spectrum(rgb: [f32; 3]) -> TexelSpectrum {
    TexelSpectrum { s: SigmoidSpectrum::illuminant(rgb.map(|v| v.max(0.0) as f64)) }
}

/// An environment map built from an image (see the module documentation for the conventions).
pub struct EnvMap {
    width: usize,
    /// Rows after padding (a one-row image is repeated to two rows).
    height: usize,
    /// Per texel, row-major from the top row.
    texels: Vec<TexelSpectrum>,
    /// Normalised D65 (luminance 1), the white of every texel.
    d65: DenseSpectrum,
    /// Radiance scale factor.
    scale: f32,
    /// Map frame → world (a rotation) and its inverse (transpose).
    to_world: Mat3,
    to_local: Mat3,
    /// Marginal CDF over the H − 1 bands of cells (inclusive partial sums).
    marginal: Vec<f32>,
    /// Conditional CDF per band over its W cells, band after band.
    conditional: Vec<f32>,
    /// Density p(u′, v) on the unit square of each cell (mean 1), band after band.
    cell_pdf: Vec<f32>,
    /// ∫ Y(ω) dω over the sphere of the map's luminance, before `scale` (sr).
    luminance_integral_sr: f64,
    /// A constant radiance added in every direction (a constant environment beside the map,
    /// W·m⁻²·sr⁻¹·nm⁻¹), and the probability with which [`EnvMap::sample`] draws a direction
    /// uniformly over the sphere for it (its share of the luminance integral).
    ambient: Option<(DenseSpectrum, f32)>,
}

impl std::fmt::Debug for EnvMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EnvMap")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("scale", &self.scale)
            .field("to_world", &self.to_world)
            .finish_non_exhaustive()
    }
}

impl EnvMap {
    /// Build from a linear-RGB image, a radiance `scale` and the rotation `to_world` (map frame →
    /// world). Errors on an empty image, non-finite or negative texels, a non-finite or negative
    /// scale, or a `to_world` that is not a rotation (orthonormal within 1e-4).
    pub fn new(image: &Image, scale: f32, to_world: Mat3) -> anyhow::Result<EnvMap> {
        let (w, h0) = (image.width as usize, image.height as usize);
        if w == 0 || h0 == 0 {
            anyhow::bail!("environment map has no pixels ({w}×{h0})");
        }
        if let Some(i) = image.rgb.iter().position(|p| p.iter().any(|c| !c.is_finite() || *c < 0.0)) {
            let p = image.rgb[i];
            anyhow::bail!("texel ({}, {}) is {:?}: must be finite and non-negative", i % w, i / w, p);
        }
        if !(scale >= 0.0) || !scale.is_finite() {
            anyhow::bail!("scale must be finite and non-negative, got {scale}");
        }
        let g = to_world.transpose() * to_world;
        if !to_world.is_finite() || (g - Mat3::IDENTITY).to_cols_array().iter().any(|x| x.abs() > 1e-4) {
            anyhow::bail!("transform must be a rotation (no scaling or shear)");
        }
        // A one-row image is constant in θ: repeat it so rows can sit at both poles.
        let rgb: Vec<[f32; 3]> = if h0 == 1 { image.rgb.iter().chain(image.rgb.iter()).copied().collect() } else { image.rgb.clone() };
        let h = h0.max(2);

        // Uplift each distinct chromaticity once (the fit dominates the build time).
        let mut keys: Vec<[u32; 3]> = rgb.iter().map(|p| p.map(f32::to_bits)).collect();
        keys.sort_unstable();
        keys.dedup();
        let fitted: Vec<TexelSpectrum> = keys.par_iter().map(|k| texel_spectrum(k.map(f32::from_bits))).collect();
        let index: HashMap<[u32; 3], usize> = keys.iter().enumerate().map(|(i, k)| (*k, i)).collect();
        let texels: Vec<TexelSpectrum> = rgb.iter().map(|p| fitted[index[&p.map(f32::to_bits)]]).collect();

        // Cell values: mean corner luminance × mean sin θ over the band.
        let lum: Vec<f64> = rgb.iter().map(|p| luminance(*p) as f64).collect();
        let bands = h - 1;
        let dtheta = std::f64::consts::PI / bands as f64;
        let mut f = vec![0.0f64; w * bands];
        for j in 0..bands {
            let mean_sin = ((j as f64 * dtheta).cos() - ((j + 1) as f64 * dtheta).cos()) / dtheta;
            for i in 0..w {
                let i1 = (i + 1) % w;
                let corners = lum[j * w + i] + lum[j * w + i1] + lum[(j + 1) * w + i] + lum[(j + 1) * w + i1];
                f[j * w + i] = 0.25 * corners * mean_sin;
            }
        }
        let total: f64 = f.iter().sum();
        let mean = total / f.len() as f64;
        let mut marginal = Vec::with_capacity(bands);
        let mut conditional = Vec::with_capacity(w * bands);
        let mut acc_rows = 0.0f64;
        for j in 0..bands {
            let mut acc = 0.0f64;
            for i in 0..w {
                acc += f[j * w + i];
                conditional.push(acc as f32);
            }
            acc_rows += acc;
            marginal.push(acc_rows as f32);
        }
        let cell_pdf = if mean > 0.0 { f.iter().map(|x| (x / mean) as f32).collect() } else { vec![0.0; f.len()] };
        // ∫ Y dω = 2π² ∫∫ Y sin θ du dv ≈ 2π² × mean cell value.
        let luminance_integral_sr = 2.0 * std::f64::consts::PI * std::f64::consts::PI * mean;
        Ok(EnvMap {
            width: w,
            height: h,
            texels,
            d65: DenseSpectrum::from_fn(optics::spectrum::d65_normalized),
            scale,
            to_world,
            to_local: to_world.transpose(),
            marginal,
            conditional,
            cell_pdf,
            luminance_integral_sr,
            ambient: None,
        })
    }

    /// This map with the constant radiance `radiance` added in every direction (a constant
    /// environment and a map together, as two emitters at infinity add): sampled uniformly over
    /// the sphere with probability Y(radiance)·4π / (Y(radiance)·4π + scale·∫Y_map dω), the
    /// map's own distribution otherwise (one-sample MIS: the density is the mixture). A black
    /// constant changes nothing.
    pub fn with_ambient(mut self, radiance: DenseSpectrum) -> EnvMap {
        let y = crate::math::spectral::xyz_of(|l| radiance.eval(l))[1].max(0.0);
        if !(y > 0.0) {
            return self;
        }
        let ambient = 4.0 * std::f64::consts::PI * y;
        let map = self.scale as f64 * self.luminance_integral_sr;
        self.ambient = Some((radiance, (ambient / (ambient + map)) as f32));
        self
    }

    /// The constant radiance added to the map, if any ([`EnvMap::with_ambient`]).
    pub fn ambient(&self) -> Option<&DenseSpectrum> {
        self.ambient.as_ref().map(|a| &a.0)
    }

    /// Resolution (width, height) in texels, after padding a one-row image to two rows.
    pub fn resolution(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Image coordinates (u, v) ∈ [0, 1)×[0, 1] of a direction in the map's frame.
    #[inline]
    pub fn direction_to_uv(d: Vec3) -> Vec2 {
        let u = d.x.atan2(-d.z) * (0.5 / PI);
        let u = if u < 0.0 { u + 1.0 } else { u };
        Vec2::new(if u >= 1.0 { 0.0 } else { u }, d.y.clamp(-1.0, 1.0).acos() * (1.0 / PI))
    }

    /// Unit direction in the map's frame at image coordinates (u, v), and sin θ.
    #[inline]
    pub fn uv_to_direction(uv: Vec2) -> (Vec3, f32) {
        let (sin_t, cos_t) = (uv.y * PI).sin_cos();
        let (sin_p, cos_p) = (uv.x * 2.0 * PI).sin_cos();
        (Vec3::new(sin_p * sin_t, cos_t, -cos_p * sin_t), sin_t)
    }

    /// Spectral radiance (W·m⁻²·sr⁻¹·nm⁻¹) arriving from world direction `wi` (unit, pointing
    /// from the scene towards the map).
    #[inline]
    pub fn radiance(&self, wi: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        let uv = Self::direction_to_uv(self.to_local * wi);
        self.radiance_uv(uv, wl)
    }

    /// Spectral radiance at image coordinates (u, v): bilinear in the texels' spectra, plus the
    /// constant radiance, if any.
    #[inline]
    pub fn radiance_uv(&self, uv: Vec2, wl: &SampledWavelengths) -> SampledSpectrum {
        let map = self.map_radiance_uv(uv, wl);
        match &self.ambient {
            None => map,
            Some((a, _)) => map + wl.eval(a),
        }
    }

    /// The image's part of [`EnvMap::radiance_uv`].
    #[inline]
    fn map_radiance_uv(&self, uv: Vec2, wl: &SampledWavelengths) -> SampledSpectrum {
        let (w, h) = (self.width, self.height);
        let x = uv.x * w as f32 - 0.5;
        let xf = x.floor();
        let fx = x - xf;
        let i0 = (xf as i64).rem_euclid(w as i64) as usize;
        let i1 = (i0 + 1) % w;
        let y = (uv.y.clamp(0.0, 1.0) * (h - 1) as f32).min((h - 1) as f32);
        let j0 = (y as usize).min(h - 2);
        let fy = (y - j0 as f32).clamp(0.0, 1.0);
        let t = |i: usize, j: usize| self.texels[j * w + i].eval(wl);
        let top = t(i0, j0) * (1.0 - fx) + t(i1, j0) * fx;
        let bottom = t(i0, j0 + 1) * (1.0 - fx) + t(i1, j0 + 1) * fx;
        (top * (1.0 - fy) + bottom * fy) * wl.eval(&self.d65) * self.scale
    }

    /// Sample a world direction towards the map with `u` uniform in [0, 1)²: (direction, density
    /// per steradian). `None` for a black map or a sample at a pole.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let Some((_, q)) = self.ambient else { return self.sample_map(u) };
        // One of the two distributions, by the first number, rescaled to [0, 1) for the choice.
        let d = if u.x < q {
            crate::math::sampling::uniform_sphere(Vec2::new(u.x / q, u.y))
        } else {
            self.sample_map(Vec2::new(((u.x - q) / (1.0 - q)).min(1.0 - f32::EPSILON), u.y))?.0
        };
        let pdf = self.pdf(d);
        (pdf > 0.0).then_some((d, pdf))
    }

    /// A direction from the image's luminance distribution alone, and its density.
    #[inline]
    fn sample_map(&self, u: Vec2) -> Option<(Vec3, f32)> {
        if !(self.luminance_integral_sr > 0.0) {
            return None;
        }
        let w = self.width;
        let (j, ry) = sample_cdf(&self.marginal, u.y);
        let (i, rx) = sample_cdf(&self.conditional[j * w..(j + 1) * w], u.x);
        let p = self.cell_pdf[j * w + i];
        if !(p > 0.0) {
            return None;
        }
        let mut uu = (i as f32 + rx + 0.5) / w as f32;
        if uu >= 1.0 {
            uu -= 1.0;
        }
        let vv = (j as f32 + ry) / (self.height - 1) as f32;
        let (d, sin_t) = Self::uv_to_direction(Vec2::new(uu, vv));
        if !(sin_t > 0.0) {
            return None;
        }
        Some(((self.to_world * d).normalize(), p / (2.0 * PI * PI * sin_t)))
    }

    /// Density per steradian with which [`EnvMap::sample`] returns world direction `wi`.
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        match self.ambient {
            None => self.pdf_map(wi),
            Some((_, q)) => q / (4.0 * PI) + (1.0 - q) * self.pdf_map(wi),
        }
    }

    /// The image's distribution's density alone.
    #[inline]
    fn pdf_map(&self, wi: Vec3) -> f32 {
        if !(self.luminance_integral_sr > 0.0) {
            return 0.0;
        }
        let d = self.to_local * wi;
        let sin_t = (d.x * d.x + d.z * d.z).sqrt();
        if !(sin_t > 0.0) {
            return 0.0;
        }
        let uv = Self::direction_to_uv(d);
        let (w, bands) = (self.width, self.height - 1);
        let mut up = uv.x - 0.5 / w as f32;
        if up < 0.0 {
            up += 1.0;
        }
        let i = ((up * w as f32) as usize).min(w - 1);
        let j = ((uv.y * bands as f32) as usize).min(bands - 1);
        self.cell_pdf[j * w + i] / (2.0 * PI * PI * sin_t)
    }

    /// Approximate power in W (∫ over 360–830 nm) that the map sends through a disk of radius
    /// `scene_radius_m`: π r² ∫ L dω dλ, L taken as luminance × normalised D65.
    pub fn power_w(&self, scene_radius_m: f32) -> f32 {
        let d65: f64 = (0..=470).map(|i| self.d65.eval(360.0 + i as f32) as f64).sum();
        let ambient: f64 = self.ambient.as_ref().map_or(0.0, |(a, _)| 4.0 * std::f64::consts::PI * (0..=470).map(|i| a.eval(360.0 + i as f32) as f64).sum::<f64>());
        (std::f64::consts::PI * (scene_radius_m as f64).powi(2) * (self.luminance_integral_sr * d65 * self.scale as f64 + ambient)) as f32
    }
}
