//! Image files: PNG (8-bit, sRGB transfer curve), OpenEXR and PFM (32-bit float, linear).
//!
//! Pixel values in memory are **linear** radiometric quantities in **sRGB primaries with the
//! D65 white point** (the pbrt-v4 / Mitsuba 3 convention). Rows are stored top to bottom,
//! pixels left to right: pixel (x, y) is `rgb[y * width + x]`, y = 0 the top row.
//!
//! Every writer goes through [`write_atomic`]: the bytes go to `<name>.tmp-<pid>` in the same
//! directory and are renamed over the target only once complete, so a failed or interrupted
//! write never leaves a partial image in place of an existing one.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};

/// A linear RGB image (sRGB primaries, D65 white), rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB, row-major, `width * height` entries, top row first.
    pub rgb: Vec<[f32; 3]>,
}

impl Image {
    /// A black image of the given size.
    pub fn new(width: u32, height: u32) -> Image {
        Image { width, height, rgb: vec![[0.0; 3]; width as usize * height as usize] }
    }

    /// Wraps pixel data, checking that it has `width * height` entries.
    pub fn from_rgb(width: u32, height: u32, rgb: Vec<[f32; 3]>) -> Result<Image> {
        if rgb.len() != width as usize * height as usize {
            bail!("image data has {} pixels, expected {}×{} = {}", rgb.len(), width, height, width as usize * height as usize);
        }
        Ok(Image { width, height, rgb })
    }

    /// Pixel (x, y), y = 0 the top row.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.rgb[y as usize * self.width as usize + x as usize]
    }

    /// Sets pixel (x, y), y = 0 the top row.
    pub fn set(&mut self, x: u32, y: u32, value: [f32; 3]) {
        let w = self.width as usize;
        self.rgb[y as usize * w + x as usize] = value;
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.rgb.len()
    }

    /// True for a 0-pixel image.
    pub fn is_empty(&self) -> bool {
        self.rgb.is_empty()
    }
}

/// The image file formats lucent reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// PNG, 8 bits per channel written (8 or 16 read), sRGB transfer curve.
    Png,
    /// OpenEXR, 32-bit float RGB, linear.
    Exr,
    /// Portable float map, 32-bit float RGB (or grey), linear.
    Pfm,
}

impl Format {
    /// The format named by a path's extension (case-insensitive); an error naming the file otherwise.
    pub fn from_path(path: &Path) -> Result<Format> {
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(Format::Png),
            Some("exr") => Ok(Format::Exr),
            Some("pfm") => Ok(Format::Pfm),
            Some(other) => bail!("{}: unknown image extension `.{other}` (expected .png, .exr or .pfm)", path.display()),
            None => bail!("{}: no image extension (expected .png, .exr or .pfm)", path.display()),
        }
    }
}

/// The sRGB transfer curve (IEC 61966-2-1) used for PNG, shared with the colour module.
pub use optics::color::{srgb_decode, srgb_encode};

/// Writes a file atomically: `write` is called with a temporary path `<name>.tmp-<pid>` in the
/// same directory; on success that file is renamed to `path`, on error it is removed and any
/// existing file at `path` is left untouched. The temporary file is synced to disk before the
/// rename. Two concurrent writes of the same path from one process would share the temporary name:
/// callers serialise them.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path)?;
    let result = write(&tmp).and_then(|()| {
        // Data on disk before the rename makes it visible, so a crash never leaves a torn file.
        File::open(&tmp)
            .and_then(|f| f.sync_all())
            .with_context(|| format!("flushing {}", tmp.display()))?;
        std::fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

fn temp_path(path: &Path) -> Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| anyhow!("{}: not a file name", path.display()))?
        .to_string_lossy()
        .into_owned();
    Ok(path.with_file_name(format!("{name}.tmp-{}", std::process::id())))
}

/// Writes `image` to `path`, the format chosen by the extension (.png, .exr, .pfm), atomically.
///
/// PNG: each channel is scaled by 2^`exposure_stops`, clamped to [0, 1] (NaN → 0), encoded with
/// the sRGB curve and quantised to 8 bits. EXR and PFM hold the linear values unchanged
/// (exposure is a display setting and is not applied to the measurement formats).
pub fn write_image(path: &Path, image: &Image, exposure_stops: f32) -> Result<()> {
    let format = Format::from_path(path)?;
    if image.rgb.len() != image.width as usize * image.height as usize {
        bail!("{}: image data has {} pixels for {}×{}", path.display(), image.rgb.len(), image.width, image.height);
    }
    write_atomic(path, |tmp| match format {
        Format::Png => write_png(tmp, image, exposure_stops),
        Format::Exr => write_exr(tmp, image),
        Format::Pfm => write_pfm(tmp, image),
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Reads a PNG (decoded to linear with the sRGB curve; 8 or 16 bits; grey or colour; alpha
/// ignored), an OpenEXR (first layer with R, G, B channels) or a PFM (either byte order).
pub fn read_image(path: &Path) -> Result<Image> {
    let format = Format::from_path(path)?;
    let result = match format {
        Format::Png => read_png(path),
        Format::Exr => read_exr(path),
        Format::Pfm => read_pfm(path),
    };
    result.with_context(|| format!("reading {}", path.display()))
}

fn write_png(tmp: &Path, image: &Image, exposure_stops: f32) -> Result<()> {
    let scale = 2f64.powf(exposure_stops as f64);
    let mut bytes = Vec::with_capacity(image.rgb.len() * 3);
    for px in &image.rgb {
        for &c in px {
            let v = c as f64 * scale;
            let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
            bytes.push((srgb_encode(v) * 255.0).round() as u8);
        }
    }
    let file = File::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let mut writer = BufWriter::new(file);
    image::codecs::png::PngEncoder::new(&mut writer)
        .write_image(&bytes, image.width, image.height, image::ExtendedColorType::Rgb8)
        .map_err(|e| anyhow!("PNG encoder: {e}"))?;
    writer.flush()?;
    Ok(())
}

use image::ImageEncoder as _;

fn read_png(path: &Path) -> Result<Image> {
    let file = File::open(path).context("cannot open")?;
    let decoded = image::load(BufReader::new(file), image::ImageFormat::Png).map_err(|e| anyhow!("PNG decoder: {e}"))?;
    let (width, height) = (decoded.width(), decoded.height());
    let rgb: Vec<[f32; 3]> = match decoded.color() {
        image::ColorType::L8 | image::ColorType::La8 | image::ColorType::Rgb8 | image::ColorType::Rgba8 => {
            let lut: Vec<f32> = (0..256).map(|i| srgb_decode(i as f64 / 255.0) as f32).collect();
            decoded.to_rgb8().pixels().map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]]).collect()
        }
        _ => decoded
            .to_rgb16()
            .pixels()
            .map(|p| {
                let f = |v: u16| srgb_decode(v as f64 / 65535.0) as f32;
                [f(p[0]), f(p[1]), f(p[2])]
            })
            .collect(),
    };
    Image::from_rgb(width, height, rgb)
}

fn write_exr(tmp: &Path, image: &Image) -> Result<()> {
    use exr::prelude::*;
    let w = image.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = image.rgb[y * w + x];
        (p[0], p[1], p[2])
    });
    let mut exr_image = exr::prelude::Image::from_channels((w, image.height as usize), channels);
    // Blocks in increasing order: the encoder compresses them in parallel, and with an
    // unspecified order writes them as they finish, so the same image gave different bytes.
    exr_image.layer_data.encoding.line_order = exr::meta::attribute::LineOrder::Increasing;
    exr_image.attributes.chromaticities = Some(exr::meta::attribute::Chromaticities {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    });
    let file = File::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
    exr_image.write().to_buffered(BufWriter::new(file)).map_err(|e| anyhow!("OpenEXR encoder: {e}"))?;
    Ok(())
}

struct ExrPixels {
    width: usize,
    rgb: Vec<[f32; 3]>,
}

fn read_exr(path: &Path) -> Result<Image> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |size: Vec2<usize>, _channels: &RgbaChannels| ExrPixels { width: size.0, rgb: vec![[0.0; 3]; size.0 * size.1] },
        |px: &mut ExrPixels, pos: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
            px.rgb[pos.1 * px.width + pos.0] = [r, g, b];
        },
    )
    .map_err(|e| anyhow!("OpenEXR decoder: {e}"))?;
    let size = image.layer_data.size;
    self::Image::from_rgb(size.0 as u32, size.1 as u32, image.layer_data.channel_data.pixels.rgb)
}

fn write_pfm(tmp: &Path, image: &Image) -> Result<()> {
    let file = File::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let mut out = BufWriter::new(file);
    // Negative scale = little-endian samples.
    write!(out, "PF\n{} {}\n-1.0\n", image.width, image.height)?;
    let w = image.width as usize;
    let mut row = Vec::with_capacity(w * 12);
    // PFM stores rows bottom to top.
    for y in (0..image.height as usize).rev() {
        row.clear();
        for p in &image.rgb[y * w..(y + 1) * w] {
            for c in p {
                row.extend_from_slice(&c.to_le_bytes());
            }
        }
        out.write_all(&row)?;
    }
    out.flush()?;
    Ok(())
}

fn read_pfm(path: &Path) -> Result<Image> {
    let mut bytes = Vec::new();
    File::open(path).context("cannot open")?.read_to_end(&mut bytes)?;
    // Header: three whitespace-separated tokens, then exactly one whitespace byte before data.
    let mut pos = 0usize;
    let mut tokens = Vec::new();
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos || pos - start > 32 {
            bail!("malformed PFM header");
        }
        tokens.push(std::str::from_utf8(&bytes[start..pos]).map_err(|_| anyhow!("malformed PFM header"))?.to_string());
    }
    pos += 1; // the single whitespace byte after the scale
    let channels = match tokens[0].as_str() {
        "PF" => 3,
        "Pf" => 1,
        other => bail!("not a PFM file (magic `{other}`, expected `PF` or `Pf`)"),
    };
    let width: u32 = tokens[1].parse().map_err(|_| anyhow!("PFM header: bad width `{}`", tokens[1]))?;
    let height: u32 = tokens[2].parse().map_err(|_| anyhow!("PFM header: bad height `{}`", tokens[2]))?;
    let scale: f64 = tokens[3].parse().map_err(|_| anyhow!("PFM header: bad scale `{}`", tokens[3]))?;
    if !scale.is_finite() || scale == 0.0 {
        bail!("PFM header: scale must be finite and non-zero, got {scale}");
    }
    let little = scale < 0.0;
    let n = width as usize * height as usize;
    let need = n.checked_mul(channels * 4).ok_or_else(|| anyhow!("PFM header: image too large"))?;
    let data = bytes.get(pos..).unwrap_or(&[]);
    if data.len() < need {
        bail!("PFM data truncated: {} bytes for {}×{}×{} floats", data.len(), width, height, channels);
    }
    let sample = |i: usize| {
        let b = [data[4 * i], data[4 * i + 1], data[4 * i + 2], data[4 * i + 3]];
        if little {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let w = width as usize;
    let mut rgb = vec![[0.0f32; 3]; n];
    for file_row in 0..height as usize {
        let y = height as usize - 1 - file_row;
        for x in 0..w {
            let i = (file_row * w + x) * channels;
            rgb[y * w + x] = if channels == 3 { [sample(i), sample(i + 1), sample(i + 2)] } else { [sample(i); 3] };
        }
    }
    Image::from_rgb(width, height, rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_inverts_and_is_continuous() {
        for i in 0..=1000 {
            let v = i as f64 / 1000.0;
            assert!((srgb_decode(srgb_encode(v)) - v).abs() < 1e-12);
        }
        // Continuity at the breakpoint (IEC 61966-2-1 constants join to ~1e-7).
        let a = 0.003_130_8;
        assert!((12.92 * a - (1.055 * f64::powf(a, 1.0 / 2.4) - 0.055)).abs() < 1e-6);
        assert!((srgb_encode(0.5) - 0.735_356_983_052_449_4).abs() < 1e-9);
    }
}
