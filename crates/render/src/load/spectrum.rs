//! Spectrum values in scene files: a number, a name from `[spectra]`, or a table (`constant`,
//! `blackbody`, `d65`, `rgb`, `csv` + `column`, inline `lambda_nm`/`values`; optional `scale`).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

use crate::load::error::{quote, quote_list, short, Cx};
use crate::load::SceneFiles;
use crate::math::hash::Fnv1a64;
use anyhow::Result;
use optics::spectrum::DenseSpectrum;
use std::collections::BTreeMap;
use std::ops::Range;
use toml::Spanned;

#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum SpectrumUse {
    /// Reflectance: values in [0, 1]; `rgb` uses the bounded reflectance uplift.
    Albedo,
    /// Emission: values ≥ 0; `rgb` uses the illuminant uplift.
    Emission,
    /// Coefficients (σ_a, σ_s): values ≥ 0; `rgb` is max(r,g,b) × the bounded reflectance uplift of rgb/max.
    Coefficient,
}

pub(crate) struct SpectrumCx<'a> {
    pub(crate) cx: &'a Cx<'a>,
    pub(crate) named: &'a BTreeMap<String, Spanned<toml::Value>>,
    pub(crate) files: &'a dyn SceneFiles,
    pub(crate) hash: std::cell::RefCell<Fnv1a64>,
}

pub(crate) const SPECTRUM_KEYS: &[&str] = &["constant", "blackbody", "d65", "rgb", "csv", "column", "lambda_nm", "values", "scale"];

pub(crate) fn as_f64(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

pub(crate) fn as_f64_array(v: &toml::Value) -> Option<Vec<f64>> {
    v.as_array()?.iter().map(as_f64).collect()
}

impl SpectrumCx<'_> {
    /// Resolve a spectrum value (number, name, or table) to a function of wavelength in nm.
    pub(crate) fn resolve(&self, v: &Spanned<toml::Value>, field: &str, usage: SpectrumUse) -> Result<DenseSpectrum> {
        let span = v.span();
        let value = v.get_ref();
        if let toml::Value::String(name) = value {
            let Some(def) = self.named.get(name) else {
                let known: Vec<&str> = self.named.keys().map(|s| s.as_str()).collect();
                return Err(self.cx.err(&span, field, format!("unknown spectrum {} (defined: {})", quote(name), quote_list(&known))));
            };
            if def.get_ref().is_str() {
                return Err(self.cx.err(&def.span(), &format!("spectra.{name}"), "a named spectrum cannot refer to another name"));
            }
            return self.resolve(def, &format!("spectra.{name}"), usage);
        }
        let f: Box<dyn Fn(f64) -> f64> = self.function(value, &span, field, usage)?;
        // Check the range of values at 1-nm resolution.
        let mut max = 0.0f64;
        for i in 0..=470 {
            let l = 360.0 + i as f64;
            let x = f(l);
            if !x.is_finite() {
                return Err(self.cx.err(&span, field, format!("spectrum is not finite at {l} nm")));
            }
            if x < 0.0 {
                return Err(self.cx.err(&span, field, format!("spectrum is negative ({x}) at {l} nm")));
            }
            max = max.max(x);
        }
        if usage == SpectrumUse::Albedo && max > 1.0 + 1e-9 {
            return Err(self.cx.err(&span, field, format!("albedo exceeds 1 (maximum {max})")));
        }
        Ok(DenseSpectrum::from_fn(f))
    }

    pub(crate) fn function(&self, value: &toml::Value, span: &Range<usize>, field: &str, usage: SpectrumUse) -> Result<Box<dyn Fn(f64) -> f64>> {
        if let Some(x) = as_f64(value) {
            return Ok(Box::new(move |_| x));
        }
        let Some(t) = value.as_table() else {
            return Err(self.cx.err(span, field, "expected a number, a spectrum name or a table"));
        };
        for k in t.keys() {
            if !SPECTRUM_KEYS.contains(&k.as_str()) {
                return Err(self.cx.err(span, field, format!("unknown key {}, expected one of {SPECTRUM_KEYS:?}", quote(k))));
            }
        }
        let scale = match t.get("scale") {
            None => 1.0,
            Some(v) => as_f64(v).filter(|x| x.is_finite() && *x >= 0.0).ok_or_else(|| {
                self.cx.err(span, &format!("{field}.scale"), "must be a non-negative number")
            })?,
        };
        let kinds: Vec<&str> = ["constant", "blackbody", "d65", "rgb", "csv", "lambda_nm"].into_iter().filter(|k| t.contains_key(*k)).collect();
        if kinds.len() != 1 {
            return Err(self.cx.err(span, field, format!(
                "give exactly one of constant, blackbody, d65, rgb, csv, lambda_nm/values (got {kinds:?})")));
        }
        let kind = kinds[0];
        if kind != "csv" && t.contains_key("column") {
            return Err(self.cx.err(span, &format!("{field}.column"), "only allowed with csv"));
        }
        if kind != "lambda_nm" && t.contains_key("values") {
            return Err(self.cx.err(span, &format!("{field}.values"), "only allowed with lambda_nm"));
        }
        match kind {
            "constant" => {
                let x = as_f64(&t["constant"]).ok_or_else(|| self.cx.err(span, &format!("{field}.constant"), "must be a number"))?;
                Ok(Box::new(move |_| x * scale))
            }
            "blackbody" => {
                let temp = as_f64(&t["blackbody"])
                    .filter(|x| x.is_finite() && *x > 0.0)
                    .ok_or_else(|| self.cx.err(span, &format!("{field}.blackbody"), "must be a positive temperature in kelvin"))?;
                let s = optics::spectrum::Spectrum::Blackbody { temperature_k: temp, scale };
                Ok(Box::new(move |l| s.eval(l)))
            }
            "d65" => {
                // CIE D65 with luminance Y = the value (Mitsuba 3's `d65`; the emission of rgb = [v, v, v]).
                let y = as_f64(&t["d65"])
                    .filter(|x| x.is_finite() && *x >= 0.0)
                    .ok_or_else(|| self.cx.err(span, &format!("{field}.d65"), "must be a non-negative luminance"))?;
                Ok(Box::new(move |l| y * scale * optics::spectrum::d65_normalized(l)))
            }
            "rgb" => {
                let rgb = as_f64_array(&t["rgb"])
                    .filter(|a| a.len() == 3)
                    .ok_or_else(|| self.cx.err(span, &format!("{field}.rgb"), "must be an array of three numbers"))?;
                let rgb = [rgb[0], rgb[1], rgb[2]];
                if rgb.iter().any(|c| !c.is_finite() || *c < 0.0) {
                    return Err(self.cx.err(span, &format!("{field}.rgb"), "components must be non-negative"));
                }
                match usage {
                    SpectrumUse::Albedo => {
                        if rgb.iter().any(|c| *c > 1.0) {
                            return Err(self.cx.err(span, &format!("{field}.rgb"), "albedo components must be at most 1"));
                        }
                        let s = rgb_albedo(rgb).map_err(|e| self.cx.err(span, &format!("{field}.rgb"), e))?;
                        Ok(Box::new(move |l| s.eval(l) * scale))
                    }
                    SpectrumUse::Coefficient => {
                        let m = rgb.iter().cloned().fold(0.0f64, f64::max);
                        if m == 0.0 {
                            return Ok(Box::new(|_| 0.0));
                        }
                        let s = rgb_albedo([rgb[0] / m, rgb[1] / m, rgb[2] / m]).map_err(|e| self.cx.err(span, &format!("{field}.rgb"), e))?;
                        Ok(Box::new(move |l| s.eval(l) * m * scale))
                    }
                    SpectrumUse::Emission => {
                        let s = rgb_illuminant(rgb).map_err(|e| self.cx.err(span, &format!("{field}.rgb"), e))?;
                        Ok(Box::new(move |l| s.eval(l) * scale))
                    }
                }
            }
            "csv" => {
                let rel = t["csv"].as_str().ok_or_else(|| self.cx.err(span, &format!("{field}.csv"), "must be a file name"))?;
                let text = self.files.read_text(rel).map_err(|e| self.cx.err(span, &format!("{field}.csv"), format!("{e:#}")))?;
                self.hash.borrow_mut().write(text.as_bytes());
                let (names, cols) = optics::spectrum::read_csv_columns(&text)
                    .map_err(|e| self.cx.err(span, &format!("{field}.csv"), format!("{rel}: {e:#}")))?;
                if cols.len() < 2 {
                    return Err(self.cx.err(span, &format!("{field}.csv"), format!("{rel}: needs a wavelength column and a value column")));
                }
                let ci = match t.get("column") {
                    None if cols.len() == 2 => 1,
                    None => {
                        return Err(self.cx.err(span, &format!("{field}.column"),
                            format!("{rel} has several value columns {:?}: name one", &names[1..])))
                    }
                    Some(toml::Value::String(c)) => names.iter().position(|n| n == c).filter(|i| *i > 0).ok_or_else(|| {
                        self.cx.err(span, &format!("{field}.column"), format!("{} has no column {} (columns: {})", short(rel), quote(c), quote_list(&names[1..])))
                    })?,
                    Some(_) => return Err(self.cx.err(span, &format!("{field}.column"), "must be a column name")),
                };
                let tab = optics::spectrum::Tabulated::new(cols[0].clone(), cols[ci].clone())
                    .map_err(|e| self.cx.err(span, &format!("{field}.csv"), format!("{rel}: {e:#}")))?;
                Ok(Box::new(move |l| tab.eval(l) * scale))
            }
            "lambda_nm" => {
                let l = as_f64_array(&t["lambda_nm"]).ok_or_else(|| self.cx.err(span, &format!("{field}.lambda_nm"), "must be an array of numbers"))?;
                let v = t.get("values").and_then(as_f64_array)
                    .ok_or_else(|| self.cx.err(span, &format!("{field}.values"), "must be an array of numbers, as long as lambda_nm"))?;
                let tab = optics::spectrum::Tabulated::new(l, v).map_err(|e| self.cx.err(span, field, format!("{e:#}")))?;
                Ok(Box::new(move |x| tab.eval(x) * scale))
            }
            _ => unreachable!(),
        }
    }
}

/// Reflectance spectrum (≤ 1 everywhere) for a linear-sRGB albedo.
pub(crate) fn rgb_albedo(rgb: [f64; 3]) -> Result<optics::spectrum::Spectrum> {
    Ok(optics::spectrum::Spectrum::RgbAlbedo(optics::spectrum::RgbAlbedo::new(rgb)))
}

/// Emission spectrum for a linear-sRGB radiance (D65 white for equal components).
pub(crate) fn rgb_illuminant(rgb: [f64; 3]) -> Result<optics::spectrum::Spectrum> {
    Ok(optics::spectrum::Spectrum::RgbIlluminant(optics::spectrum::RgbIlluminant::new(rgb)))
}

/// Keys of an image texture table (`{ texture = "file.png", … }`).
pub(crate) const TEXTURE_KEYS: &[&str] = &["texture", "wrap", "scale", "encoding", "filter"];

/// Whether a value is a texture table rather than a spectrum.
pub(crate) fn is_texture(v: &toml::Value) -> bool {
    v.as_table().is_some_and(|t| t.contains_key("texture") || t.contains_key("checkerboard"))
}

impl SpectrumCx<'_> {
    /// A spectrum that may be textured: an image texture (`{ texture = "file", wrap, scale,
    /// encoding }`), a checkerboard (`{ checkerboard = { squares, even, odd } }`), or any
    /// spectrum value (constant over the surface).
    pub(crate) fn resolve_texture(&self, v: &Spanned<toml::Value>, field: &str, usage: SpectrumUse) -> Result<crate::texture::SpectrumTexture> {
        use crate::texture::{checkerboard::Checkerboard, image::SpectralImage, image::Uplift, SpectrumTexture};
        let span = v.span();
        let Some(t) = v.get_ref().as_table().filter(|_| is_texture(v.get_ref())) else {
            return Ok(SpectrumTexture::Constant(self.resolve(v, field, usage)?));
        };
        if let Some(cb) = t.get("checkerboard") {
            if t.len() != 1 {
                return Err(self.cx.err(&span, field, "a checkerboard table has only the key `checkerboard`"));
            }
            let f = format!("{field}.checkerboard");
            let Some(cbt) = cb.as_table() else {
                return Err(self.cx.err(&span, &f, "expected { squares = N, even = SPECTRUM, odd = SPECTRUM }"));
            };
            for k in cbt.keys() {
                if !["squares", "even", "odd"].contains(&k.as_str()) {
                    return Err(self.cx.err(&span, &f, format!("unknown key `{k}`, expected squares, even, odd")));
                }
            }
            let squares = cbt.get("squares").and_then(|x| x.as_integer()).filter(|n| (1..=1_000_000).contains(n)).ok_or_else(|| {
                self.cx.err(&span, &format!("{f}.squares"), "must be a positive integer (squares per side)")
            })?;
            let side = |name: &str| -> Result<DenseSpectrum> {
                let val = cbt.get(name).ok_or_else(|| self.cx.err(&span, &format!("{f}.{name}"), "missing (a spectrum)"))?;
                self.resolve(&Spanned::new(span.clone(), val.clone()), &format!("{f}.{name}"), usage)
            };
            let cb = Checkerboard { squares: squares as u32, even: side("even")?, odd: side("odd")? };
            return Ok(SpectrumTexture::Checkerboard(std::sync::Arc::new(cb)));
        }
        let (img, wrap, scale, filter) = self.texture_image(t, &span, field, crate::texture::image::Encoding::Srgb, &[])?;
        let uplift = match usage {
            SpectrumUse::Albedo => Uplift::Reflectance,
            SpectrumUse::Emission => Uplift::Illuminant,
            SpectrumUse::Coefficient => return Err(self.cx.err(&span, field, "cannot be a texture")),
        };
        let s = SpectralImage::new(&img, uplift, wrap, scale).map_err(|e| self.cx.err(&span, &format!("{field}.texture"), format!("{}: {e:#}", t["texture"].as_str().unwrap_or(""))))?.with_filter(filter);
        Ok(SpectrumTexture::Image(std::sync::Arc::new(s)))
    }

    /// A single-channel texture (`{ texture = "file", wrap, scale, encoding }`) with values in
    /// [lo, hi], or None when `v` is not a texture table.
    pub(crate) fn resolve_float_texture(&self, v: &Spanned<toml::Value>, field: &str, lo: f32, hi: f32) -> Result<Option<crate::texture::FloatTexture>> {
        use crate::texture::{image::FloatImage, FloatTexture};
        let span = v.span();
        let Some(t) = v.get_ref().as_table().filter(|_| is_texture(v.get_ref())) else {
            return Ok(None);
        };
        if t.contains_key("checkerboard") {
            return Err(self.cx.err(&span, field, "a checkerboard gives spectra, not a number (use an image texture)"));
        }
        let (img, wrap, scale, filter) = self.texture_image(t, &span, field, crate::texture::image::Encoding::Srgb, &[])?;
        let f = FloatImage::new(&img, wrap, scale).with_filter(filter);
        if let Some(i) = img.rgb.iter().position(|p| {
            let m = (p[0] + p[1] + p[2]) / 3.0;
            !(m >= lo && m <= hi)
        }) {
            let (x, y) = (i % img.width as usize, i / img.width as usize);
            return Err(self.cx.err(&span, &format!("{field}.texture"), format!("texel ({x}, {y}) is outside [{lo}, {hi}]")));
        }
        Ok(Some(FloatTexture::Image(std::sync::Arc::new(f))))
    }

    /// A normal map (`{ texture = "file", wrap, scale, filter, encoding }`, read linearly unless
    /// `encoding = "srgb"`) or a bump map (`{ texture = "file", height, wrap, scale, encoding }`,
    /// `height` the scene-unit height of a texel value of 1), as `kind` says ("normal_map" or
    /// "bump_map"), with its `shadowing` and `flip_invalid_normals` switches (both true unless
    /// given); `unit_m` is metres per scene unit.
    pub(crate) fn resolve_shading_map(&self, v: &Spanned<toml::Value>, field: &str, kind: &str, unit_m: f64) -> Result<(crate::texture::shading_map::ShadingMap, bool, bool)> {
        use crate::texture::image::Encoding;
        use crate::texture::shading_map::{BumpMap, NormalMap, ShadingMap};
        use crate::texture::Filter;
        let span = v.span();
        let t = v
            .get_ref()
            .as_table()
            .filter(|t| t.contains_key("texture"))
            .ok_or_else(|| self.cx.err(&span, field, "must be a table with an image file: { texture = \"file.png\", … }"))?;
        let switch = |key: &str| -> Result<bool> {
            match t.get(key) {
                None => Ok(true),
                Some(b) => b.as_bool().ok_or_else(|| self.cx.err(&span, &format!("{field}.{key}"), "must be true or false")),
            }
        };
        let (shadowing, flip) = (switch("shadowing")?, switch("flip_invalid_normals")?);
        if kind == "normal_map" {
            let (img, wrap, scale, filter) = self.texture_image(t, &span, field, Encoding::Linear, &["shadowing", "flip_invalid_normals"])?;
            return Ok((ShadingMap::Normal(NormalMap::new(&img, wrap, scale, filter)), shadowing, flip));
        }
        let height = t.get("height").ok_or_else(|| self.cx.err(&span, &format!("{field}.height"), "missing (the height of a texel value of 1, in the scene unit)"))?;
        let height = as_f64(height).filter(|h| h.is_finite()).ok_or_else(|| self.cx.err(&span, &format!("{field}.height"), "must be a finite number (scene unit)"))?;
        let (img, wrap, scale, filter) = self.texture_image(t, &span, field, Encoding::Srgb, &["height", "shadowing", "flip_invalid_normals"])?;
        if filter != Filter::Bilinear {
            return Err(self.cx.err(&span, &format!("{field}.filter"), "a bump map is read bilinearly (its slope is the interpolation's derivative)"));
        }
        Ok((ShadingMap::Bump(BumpMap::new(&img, wrap, scale, (height * unit_m) as f32)), shadowing, flip))
    }

    /// Reads the image of a texture table and its wrap mode and (u, v) scale; PNG and JPEG are
    /// decoded with `default_encoding` unless the table names one; `extra` are further keys the
    /// caller reads.
    fn texture_image(&self, t: &toml::value::Table, span: &Range<usize>, field: &str, default_encoding: crate::texture::image::Encoding, extra: &[&str]) -> Result<(crate::image_io::Image, crate::texture::Wrap, glam::Vec2, crate::texture::Filter)> {
        use crate::texture::{image::Encoding, Filter, Wrap};
        for k in t.keys() {
            if !TEXTURE_KEYS.contains(&k.as_str()) && !extra.contains(&k.as_str()) {
                let known: Vec<&str> = TEXTURE_KEYS.iter().chain(extra).copied().collect();
                return Err(self.cx.err(span, field, format!("unknown key `{k}`, expected one of {known:?}")));
            }
        }
        let rel = t["texture"].as_str().ok_or_else(|| self.cx.err(span, &format!("{field}.texture"), "must be an image file name"))?;
        let wrap = match t.get("wrap") {
            None => Wrap::Repeat,
            Some(w) => w.as_str().and_then(Wrap::from_name).ok_or_else(|| {
                self.cx.err(span, &format!("{field}.wrap"), format!("unknown wrap mode {w} (expected \"repeat\", \"clamp\" or \"mirror\")"))
            })?,
        };
        let scale = match t.get("scale") {
            None => glam::Vec2::ONE,
            Some(s) => {
                let a = as_f64(s).map(|x| vec![x, x]).or_else(|| as_f64_array(s)).filter(|a| a.len() == 2 && a.iter().all(|x| x.is_finite() && *x != 0.0));
                let a = a.ok_or_else(|| self.cx.err(span, &format!("{field}.scale"), "must be a non-zero number or [su, sv]"))?;
                glam::Vec2::new(a[0] as f32, a[1] as f32)
            }
        };
        let filter = match t.get("filter") {
            None => Filter::Bilinear,
            Some(x) => x.as_str().and_then(Filter::from_name).ok_or_else(|| {
                self.cx.err(span, &format!("{field}.filter"), format!("unknown filter {x} (expected \"bilinear\" or \"nearest\")"))
            })?,
        };
        let encoding = match t.get("encoding").map(|e| e.as_str()) {
            None => default_encoding,
            Some(Some("srgb")) => Encoding::Srgb,
            Some(Some("linear")) => Encoding::Linear,
            Some(_) => return Err(self.cx.err(span, &format!("{field}.encoding"), "must be \"srgb\" or \"linear\"")),
        };
        let (path, bytes) = self.files.image_path(rel).map_err(|e| self.cx.err(span, &format!("{field}.texture"), format!("{e:#}")))?;
        self.hash.borrow_mut().write(&bytes);
        let img = crate::texture::image::read_texture_image(&path, encoding).map_err(|e| self.cx.err(span, &format!("{field}.texture"), format!("{e:#}")))?;
        Ok((img, wrap, scale, filter))
    }
}
