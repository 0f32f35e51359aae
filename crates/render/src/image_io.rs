//! Image files: PNG (8-bit, sRGB transfer curve), OpenEXR and PFM (32-bit float, linear), and
//! Radiance RGBE `.hdr` (shared-exponent float, linear).
//!
//! Pixel values in memory are **linear** radiometric quantities in **sRGB primaries with the
//! D65 white point** (the pbrt-v4 / Mitsuba 3 convention). Rows are stored top to bottom,
//! pixels left to right: pixel (x, y) is `rgb[y * width + x]`, y = 0 the top row.
//!
//! Every writer goes through [`write_atomic`]: the bytes go to `<name>.tmp-<pid>` in the same
//! directory and are renamed over the target only once complete, so a failed or interrupted
//! write never leaves a partial image in place of an existing one.

use std::fs::File;
use std::io::{BufWriter, Write};
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
    /// Radiance RGBE (`.hdr`, `.pic`), 8-bit mantissas with a shared exponent, linear.
    Hdr,
}

impl Format {
    /// The format named by a path's extension (case-insensitive); an error naming the file otherwise.
    pub fn from_path(path: &Path) -> Result<Format> {
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(Format::Png),
            Some("exr") => Ok(Format::Exr),
            Some("pfm") => Ok(Format::Pfm),
            Some("hdr") | Some("pic") => Ok(Format::Hdr),
            Some(other) => bail!("{}: unknown image extension `.{other}` (expected .png, .exr, .pfm or .hdr)", path.display()),
            None => bail!("{}: no image extension (expected .png, .exr, .pfm or .hdr)", path.display()),
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

/// Checks before any work that [`write_atomic`] can write `path`: its temporary file is created
/// in the destination's folder and removed again, so that a command with several outputs does
/// not replace the first and then fail on a later one that cannot be written (a read-only
/// folder, /proc). The error names the path and the system's reason.
pub fn check_writable(path: &Path) -> Result<()> {
    let tmp = temp_path(path)?;
    match std::fs::OpenOptions::new().write(true).create(true).truncate(true).open(&tmp) {
        Ok(f) => {
            drop(f);
            let _ = std::fs::remove_file(&tmp);
            Ok(())
        }
        Err(e) => bail!("{}: cannot write there: {e}", path.display()),
    }
}

fn temp_path(path: &Path) -> Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| anyhow!("{}: not a file name", path.display()))?
        .to_string_lossy()
        .into_owned();
    Ok(path.with_file_name(format!("{name}.tmp-{}", std::process::id())))
}

/// Writes `image` to `path`, the format chosen by the extension (.png, .exr, .pfm, .hdr), atomically.
///
/// PNG: each channel is scaled by 2^`exposure_stops`, clamped to [0, 1] (NaN → 0), encoded with
/// the sRGB curve and quantised to 8 bits. EXR and PFM hold the linear values unchanged
/// (exposure is a display setting and is not applied to the measurement formats); HDR holds them
/// to its 8-bit shared-exponent precision (flat scanlines, relative error < 2⁻⁸).
pub fn write_image(path: &Path, image: &Image, exposure_stops: f32) -> Result<()> {
    let format = Format::from_path(path)?;
    if image.rgb.len() != image.width as usize * image.height as usize {
        bail!("{}: image data has {} pixels for {}×{}", path.display(), image.rgb.len(), image.width, image.height);
    }
    write_atomic(path, |tmp| match format {
        Format::Png => write_png(tmp, image, exposure_stops),
        Format::Exr => write_exr(tmp, image),
        Format::Pfm => write_pfm(tmp, image),
        Format::Hdr => write_hdr(tmp, image),
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Reads a PNG (decoded to linear with the sRGB curve; 8 or 16 bits; grey or colour; alpha
/// ignored), an OpenEXR (first layer with R, G, B channels), a PFM (either byte order) or a
/// Radiance RGBE `.hdr` (see [`decode_hdr`]).
///
/// JPEG (`.jpg`, `.jpeg`; photographs) is read as PNG is, 8-bit sRGB decoded to linear; lucent
/// never writes it (lossy), so it is not a [`Format`].
pub fn read_image(path: &Path) -> Result<Image> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    if matches!(ext.as_deref(), Some("jpg" | "jpeg")) {
        let result = std::fs::read(path).context("cannot open").and_then(|bytes| read_8bit(&bytes, image::ImageFormat::Jpeg, "JPEG"));
        return result.with_context(|| format!("reading {}", path.display()));
    }
    let format = Format::from_path(path).map_err(|_| match ext {
        Some(other) => anyhow!("{}: unknown image extension `.{other}` (expected .png, .jpg, .exr, .pfm or .hdr)", path.display()),
        None => anyhow!("{}: no image extension (expected .png, .jpg, .exr, .pfm or .hdr)", path.display()),
    })?;
    let result = std::fs::read(path).context("cannot open").and_then(|bytes| decode_image(&bytes, format));
    result.with_context(|| format!("reading {}", path.display()))
}

/// Decodes an image file held in memory, as [`read_image`] does for a file of that format
/// (errors do not name a file).
pub fn decode_image(bytes: &[u8], format: Format) -> Result<Image> {
    match format {
        Format::Png => read_png(bytes),
        Format::Exr => read_exr(bytes),
        Format::Pfm => read_pfm(bytes),
        Format::Hdr => decode_hdr(bytes),
    }
}

fn write_png(tmp: &Path, image: &Image, exposure_stops: f32) -> Result<()> {
    let file = File::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let mut writer = BufWriter::new(file);
    encode_png(&mut writer, image, exposure_stops, PngEffort::Small)?;
    writer.flush()?;
    Ok(())
}

/// How hard [`encode_png`] works at making the file small.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PngEffort {
    /// For files: each row gets the best of PNG's five filters.
    Small,
    /// For live previews: every row is differenced with its left neighbour (PNG's Sub filter),
    /// a few times faster, files somewhat larger.
    Quick,
}

/// Encodes `image` as the PNG [`write_image`] writes (exposure 2^`exposure_stops`, clamped,
/// sRGB curve, 8 bits) into `out`, e.g. a buffer to serve; `effort` changes the compression,
/// never the pixels.
pub fn encode_png(out: &mut impl Write, image: &Image, exposure_stops: f32, effort: PngEffort) -> Result<()> {
    let scale = 2f64.powf(exposure_stops as f64);
    let mut bytes = Vec::with_capacity(image.rgb.len() * 3);
    for px in &image.rgb {
        for &c in px {
            bytes.push(srgb8(c as f64 * scale));
        }
    }
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let filter = match effort {
        PngEffort::Small => FilterType::Adaptive,
        PngEffort::Quick => FilterType::Sub,
    };
    PngEncoder::new_with_quality(out, CompressionType::Fast, filter)
        .write_image(&bytes, image.width, image.height, image::ExtendedColorType::Rgb8)
        .map_err(|e| anyhow!("PNG encoder: {e}"))
}

/// The linear values halfway between successive 8-bit sRGB codes: code k + ½ decoded, k = 0…254.
static SRGB8_HALFWAY: std::sync::LazyLock<[f64; 255]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|k| srgb_decode((k as f64 + 0.5) / 255.0)));

/// The 8-bit sRGB code of a linear value, round(255·srgb_encode(v)) with v clamped to [0, 1]
/// and NaN as 0, found by binary search over [`SRGB8_HALFWAY`] instead of a power per value
/// (the curve is increasing, so the two agree except within rounding of a halfway value).
fn srgb8(linear: f64) -> u8 {
    if linear.is_nan() {
        return 0;
    }
    SRGB8_HALFWAY.partition_point(|&t| t <= linear) as u8
}

use image::ImageEncoder as _;

fn read_png(bytes: &[u8]) -> Result<Image> {
    read_8bit(bytes, image::ImageFormat::Png, "PNG")
}

/// An sRGB-encoded file (PNG or JPEG, 8 or 16 bits) decoded to linear RGB.
fn read_8bit(bytes: &[u8], format: image::ImageFormat, name: &str) -> Result<Image> {
    let decoded = image::load_from_memory_with_format(bytes, format).map_err(|e| anyhow!("{name} decoder: {e}"))?;
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

/// A named channel of a multi-channel EXR: one f32 per pixel, row-major, top row first.
pub type ExrChannel = (String, Vec<f32>);

/// Writes a single-part OpenEXR of `width`×`height` with the given f32 channels (names such as
/// `R`, `albedo.R`, `S0.405nm`; the file lists them sorted by name, as OpenEXR requires) and
/// string attributes, atomically ([`write_atomic`]). sRGB/D65 chromaticities are recorded for
/// the colour channels.
pub fn write_exr_channels(path: &Path, width: u32, height: u32, channels: &[ExrChannel], attributes: &[(&str, &str)]) -> Result<()> {
    use exr::prelude::*;
    let n = width as usize * height as usize;
    if let Some((name, v)) = channels.iter().find(|(_, v)| v.len() != n) {
        bail!("{}: channel {name} has {} values for {width}×{height} pixels", path.display(), v.len());
    }
    let mut names: Vec<&str> = channels.iter().map(|(name, _)| name.as_str()).collect();
    names.sort();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        bail!("{}: channel {} is given twice", path.display(), w[0]);
    }
    write_atomic(path, |tmp| {
        let list: SmallVec<[AnyChannel<FlatSamples>; 4]> =
            channels.iter().map(|(name, v)| AnyChannel::new(name.as_str(), FlatSamples::F32(v.clone()))).collect();
        let mut attrs = LayerAttributes::default();
        for (k, v) in attributes {
            attrs.other.insert(Text::from(*k), exr::meta::attribute::AttributeValue::Text(Text::from(*v)));
        }
        let mut encoding = Encoding::FAST_LOSSLESS;
        // Blocks in increasing order, so the same data always gives the same bytes.
        encoding.line_order = exr::meta::attribute::LineOrder::Increasing;
        let layer = Layer::new((width as usize, height as usize), attrs, encoding, AnyChannels::sort(list));
        let mut image = exr::prelude::Image::from_layer(layer);
        image.attributes.chromaticities = Some(exr::meta::attribute::Chromaticities {
            red: Vec2(0.64, 0.33),
            green: Vec2(0.30, 0.60),
            blue: Vec2(0.15, 0.06),
            white: Vec2(0.3127, 0.3290),
        });
        let file = File::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
        image.write().to_buffered(BufWriter::new(file)).map_err(|e| anyhow!("OpenEXR encoder: {e}"))?;
        Ok(())
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Reads every channel of the first layer of an OpenEXR (as f32, row-major) and its string
/// attributes; the channels come sorted by name.
pub fn read_exr_channels(path: &Path) -> Result<(u32, u32, Vec<ExrChannel>, Vec<(String, String)>)> {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| anyhow!("{}: OpenEXR decoder: {e}", path.display()))?;
    let size = image.layer_data.size;
    let channels = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    let attributes = image
        .layer_data
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            exr::meta::attribute::AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    Ok((size.0 as u32, size.1 as u32, channels, attributes))
}

struct ExrPixels {
    width: usize,
    rgb: Vec<[f32; 3]>,
}

fn read_exr(bytes: &[u8]) -> Result<Image> {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
        |size: Vec2<usize>, _channels: &RgbaChannels| ExrPixels { width: size.0, rgb: vec![[0.0; 3]; size.0 * size.1] },
        |px: &mut ExrPixels, pos: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
            px.rgb[pos.1 * px.width + pos.0] = [r, g, b];
        },
    )
    .first_valid_layer()
    .all_attributes()
    .from_buffered(std::io::Cursor::new(bytes))
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

fn read_pfm(bytes: &[u8]) -> Result<Image> {
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

/// Decodes a Radiance RGBE picture (Ward, "Real Pixels", Graphics Gems II, 1991; the file
/// format of Radiance's `color.c`): a `#?RADIANCE` or `#?RGBE` header whose `FORMAT`, if given,
/// is `32-bit_rle_rgbe`, an empty line, the resolution `-Y H +X W` (rows top to bottom) or
/// `+Y H +X W` (bottom to top), then per scanline either the adaptive run-length encoding (bytes
/// 2, 2, W >> 8, W & 255, then each of the four channels as runs: a count c > 128 repeats the next
/// byte c − 128 times, a count 1 ≤ c ≤ 128 is followed by c literal bytes) or W flat 4-byte
/// pixels. A pixel (r, g, b, e) is (r, g, b) · 2^(e − 136), 0 when e = 0 (as Bruce Walter's
/// reader, which Mitsuba 3 and pbrt-v4 follow; `EXPOSURE` lines are ignored, as they do).
pub fn decode_hdr(bytes: &[u8]) -> Result<Image> {
    let mut pos = 0usize;
    let line = |pos: &mut usize| -> Result<String> {
        let start = *pos;
        while *pos < bytes.len() && bytes[*pos] != b'\n' {
            *pos += 1;
            if *pos - start > 4096 {
                bail!("HDR header line longer than 4096 bytes");
            }
        }
        if *pos >= bytes.len() {
            bail!("HDR header truncated (no resolution line)");
        }
        let s = String::from_utf8_lossy(&bytes[start..*pos]).trim_end_matches('\r').to_string();
        *pos += 1;
        Ok(s)
    };
    let magic = line(&mut pos)?;
    if !magic.starts_with("#?") {
        bail!("not a Radiance HDR file (first line `{}`, expected `#?RADIANCE`)", magic.chars().take(40).collect::<String>());
    }
    loop {
        let l = line(&mut pos)?;
        if l.is_empty() {
            break;
        }
        if let Some(f) = l.strip_prefix("FORMAT=") {
            if f.trim() != "32-bit_rle_rgbe" {
                bail!("HDR FORMAT `{}` is not supported (only 32-bit_rle_rgbe)", f.trim());
            }
        }
    }
    let res = line(&mut pos)?;
    let t: Vec<&str> = res.split_whitespace().collect();
    let bad_res = || anyhow!("HDR resolution line `{res}` is not `-Y H +X W` or `+Y H +X W`");
    if t.len() != 4 || t[2] != "+X" {
        return Err(bad_res());
    }
    let top_down = match t[0] {
        "-Y" => true,
        "+Y" => false,
        _ => return Err(bad_res()),
    };
    let height: u32 = t[1].parse().map_err(|_| bad_res())?;
    let width: u32 = t[3].parse().map_err(|_| bad_res())?;
    if width == 0 || height == 0 || width as u64 * height as u64 > 1 << 28 {
        bail!("HDR resolution {width}×{height} is empty or too large");
    }
    let w = width as usize;
    let mut rgb = vec![[0.0f32; 3]; w * height as usize];
    let mut scan = vec![0u8; 4 * w];
    let decode = |p: &[u8]| -> [f32; 3] {
        if p[3] == 0 {
            return [0.0; 3];
        }
        let f = (2.0f64).powi(p[3] as i32 - 136) as f32;
        [p[0] as f32 * f, p[1] as f32 * f, p[2] as f32 * f]
    };
    let data = &bytes[pos..];
    let mut at = 0usize;
    let truncated = |row: usize| anyhow!("HDR data truncated in scanline {row} of {height}");
    for row in 0..height as usize {
        let rle = (8..=0x7fff).contains(&w)
            && data.len() >= at + 4
            && data[at] == 2
            && data[at + 1] == 2
            && data[at + 2] & 0x80 == 0;
        if rle {
            let n = ((data[at + 2] as usize) << 8) | data[at + 3] as usize;
            if n != w {
                bail!("HDR scanline {row} has length {n}, expected {w}");
            }
            at += 4;
            // Channel c of pixel x goes to scan[4x + c].
            for c in 0..4 {
                let mut x = 0usize;
                while x < w {
                    let count = *data.get(at).ok_or_else(|| truncated(row))? as usize;
                    at += 1;
                    if count > 128 {
                        let run = count - 128;
                        let v = *data.get(at).ok_or_else(|| truncated(row))?;
                        at += 1;
                        if x + run > w {
                            bail!("HDR scanline {row}: run overflows the scanline");
                        }
                        for k in 0..run {
                            scan[4 * (x + k) + c] = v;
                        }
                        x += run;
                    } else {
                        if count == 0 || x + count > w {
                            bail!("HDR scanline {row}: bad run length {count}");
                        }
                        let src = data.get(at..at + count).ok_or_else(|| truncated(row))?;
                        for (k, v) in src.iter().enumerate() {
                            scan[4 * (x + k) + c] = *v;
                        }
                        at += count;
                        x += count;
                    }
                }
            }
        } else {
            let src = data.get(at..at + 4 * w).ok_or_else(|| truncated(row))?;
            scan.copy_from_slice(src);
            at += 4 * w;
        }
        let y = if top_down { row } else { height as usize - 1 - row };
        for x in 0..w {
            rgb[y * w + x] = decode(&scan[4 * x..4 * x + 4]);
        }
    }
    Image::from_rgb(width, height, rgb)
}

/// One RGBE pixel for linear RGB (negative and NaN components become 0).
fn rgbe_of(p: [f32; 3]) -> [u8; 4] {
    let c = p.map(|v| if v > 0.0 { v } else { 0.0 });
    let m = c[0].max(c[1]).max(c[2]);
    if m < 1e-32 {
        return [0; 4];
    }
    let m = m.min(f32::MAX);
    // m = f · 2^e with f ∈ [0.5, 1).
    let e = m.log2().floor() as i32 + 1;
    let e = if (m / 2f32.powi(e)) >= 1.0 { e + 1 } else { e }.clamp(-128, 127);
    let k = 256.0 / 2f32.powi(e);
    [(c[0] * k).min(255.0) as u8, (c[1] * k).min(255.0) as u8, (c[2] * k).min(255.0) as u8, (e + 128) as u8]
}

/// Run-length encodes one channel of a scanline (runs of ≥ 3 equal bytes, literals otherwise).
fn rle_channel(v: &[u8], out: &mut Vec<u8>) {
    let mut x = 0usize;
    while x < v.len() {
        // Length of the run starting at x (at most 127).
        let run = v[x..].iter().take(127).take_while(|b| **b == v[x]).count();
        if run >= 3 {
            out.push(128 + run as u8);
            out.push(v[x]);
            x += run;
            continue;
        }
        // Literals up to the next run of ≥ 3 (at most 128).
        let start = x;
        while x < v.len() && x - start < 128 {
            if x + 2 < v.len() && v[x] == v[x + 1] && v[x] == v[x + 2] {
                break;
            }
            x += 1;
        }
        out.push((x - start) as u8);
        out.extend_from_slice(&v[start..x]);
    }
}

/// Writes RGBE with run-length encoded scanlines (flat ones for widths outside 8..=32767, where
/// the encoding is undefined).
fn write_hdr(tmp: &Path, image: &Image) -> Result<()> {
    let file = File::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let mut out = BufWriter::new(file);
    write!(out, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {} +X {}\n", image.height, image.width)?;
    let w = image.width as usize;
    let mut bytes = Vec::new();
    for row in image.rgb.chunks(w.max(1)) {
        let px: Vec<[u8; 4]> = row.iter().map(|p| rgbe_of(*p)).collect();
        if (8..=0x7fff).contains(&w) {
            bytes.extend_from_slice(&[2, 2, (w >> 8) as u8, (w & 255) as u8]);
            for c in 0..4 {
                let ch: Vec<u8> = px.iter().map(|p| p[c]).collect();
                rle_channel(&ch, &mut bytes);
            }
        } else {
            bytes.extend(px.iter().flatten());
        }
    }
    out.write_all(&bytes)?;
    out.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb8_by_search_equals_rounding_the_curve() {
        // Every 8-bit code agrees with round(255·srgb_encode(v)) on a fine grid of [0, 1] (with
        // values past both ends and NaN), except within 1e-9 of a halfway value, where the two
        // roundings may legitimately differ.
        let n = 1_000_000;
        for i in 0..=n + 10 {
            let v = i as f64 / n as f64 - 5e-6;
            let exact = srgb_encode(v) * 255.0;
            if (exact - exact.floor() - 0.5).abs() < 1e-9 {
                continue;
            }
            assert_eq!(srgb8(v), exact.round() as u8, "v = {v}");
        }
        assert_eq!((srgb8(f64::NAN), srgb8(-1.0), srgb8(7.0)), (0, 0, 255));
    }

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
