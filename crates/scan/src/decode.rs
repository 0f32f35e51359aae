//! Decoding a Gray-code capture into projector coordinates per camera pixel.
//!
//! A capture is a folder of camera frames `graycode_NN.png` (or `.jpg`), one per frame of the
//! [`PatternSet`] in its order. Per camera pixel:
//!
//! 1. **Lit**: white − black > the black threshold (8-bit grey levels; default 40), else invalid
//!    (shadow, or outside the projector's throw).
//! 2. **Bits**: for each bit, d = pattern − inverse; the bit is 1 where d > 0. A bit is decided
//!    only where |d| > the white threshold (default 5); one undecided bit makes the pixel invalid.
//!    The Gray codes of column and row are turned into codes; a code past the last projected one
//!    (a misread) makes the pixel invalid. A pixel is valid only with both coordinates.
//! 3. **Integer coordinate**: the centre of the projector pixels carrying the code, in OpenCV's
//!    convention (integer coordinates at pixel centres): code c with step S covers projector
//!    pixels cS … cS + S − 1 and sits at cS + (S − 1)/2.
//! 4. **Sub-pixel refinement from stripe edges** (in the spirit of Trobina, "Error model of a
//!    coded-light range sensor", ETH TR BIWI-TR-164, 1995, and Salvi et al., Pattern Recognition
//!    43, 2010, §3.1): between two neighbouring camera pixels (along a camera row or column)
//!    whose codes differ by exactly one, the projector boundary between those codes lies at
//!    projector coordinate B = max(c₀, c₁)·S − ½. Exactly one Gray bit flips there; its
//!    difference signal d = pattern − inverse changes sign between the two pixels, and the
//!    boundary's camera position is taken where d crosses zero, interpolated linearly:
//!    s = p₀ + d₀/(d₀ − d₁). A run of pixels with one code c bounded by the two boundaries of c
//!    (the codes on its two sides are c − 1 and c + 1, in either order) gets the projector
//!    coordinate interpolated linearly between its two edges (s_l, B_l) and (s_r, B_r). Each
//!    coordinate is refined along camera rows and along camera columns; the direction whose
//!    edges are closer (the one crossing the stripes more squarely) is used. Pixels without such
//!    a bracket (at a border of the valid region, in a run ending at a jump of more than one code
//!    where projector pixels are smaller than camera pixels, or at a fold) keep the integer
//!    coordinate. On ideal patterns seen 1:1 every bracketed pixel is exact (the zero crossing
//!    falls half-way between the pixels), which the test suite checks.
//!
//! OpenCV's `GrayCodePattern::getProjPixel` rejects a bit only where |d| < the white threshold
//! and accepts codes up to and including the projector size; this decoder uses |d| > threshold,
//! as the shadow mask does for the black threshold, and rejects codes ≥ the code count.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use rayon::prelude::*;

use crate::graycode::{gray_decode, gray_encode, PatternSet};

/// Projector coordinates per camera pixel, row-major over the camera image.
#[derive(Clone, Debug)]
pub struct DecodeMap {
    /// Camera image width (pixels).
    pub width: usize,
    /// Camera image height (pixels).
    pub height: usize,
    /// Projector column per camera pixel (projector pixels, OpenCV convention), NaN where invalid.
    pub col: Vec<f32>,
    /// Projector row per camera pixel (projector pixels, OpenCV convention), NaN where invalid.
    pub row: Vec<f32>,
    /// The all-white frame (8-bit grey levels as f32).
    pub white: Vec<f32>,
    /// The all-black frame (8-bit grey levels as f32).
    pub black: Vec<f32>,
}

impl DecodeMap {
    /// Whether camera pixel (x, y) has a decoded projector coordinate.
    pub fn is_valid(&self, x: usize, y: usize) -> bool {
        let i = y * self.width + x;
        self.col[i].is_finite() && self.row[i].is_finite()
    }

    /// Number of camera pixels with a decoded projector coordinate.
    pub fn valid_pixels(&self) -> usize {
        self.col.iter().zip(&self.row).filter(|(c, r)| c.is_finite() && r.is_finite()).count()
    }

    /// Valid pixels over all camera pixels (0…1).
    pub fn valid_fraction(&self) -> f64 {
        self.valid_pixels() as f64 / (self.width * self.height).max(1) as f64
    }
}

/// Decoding thresholds (8-bit grey levels) and the refinement switch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecodeSettings {
    /// A pixel is lit where white − black exceeds this (grey levels).
    pub black_threshold: i32,
    /// A bit is decided where |pattern − inverse| exceeds this (grey levels).
    pub white_threshold: i32,
    /// Sub-pixel refinement from stripe edges (module documentation, step 4).
    pub refine: bool,
    /// The capture's white and black frames come first, before the patterns (as some capture
    /// tools write them), instead of last (OpenCV's `GrayCodePattern` order).
    pub white_black_first: bool,
}

impl Default for DecodeSettings {
    fn default() -> Self {
        DecodeSettings { black_threshold: 40, white_threshold: 5, refine: true, white_black_first: false }
    }
}

/// Counts from one decode.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DecodeStats {
    /// Valid pixels.
    pub valid_pixels: usize,
    /// Valid pixels whose column was refined from stripe edges.
    pub refined_columns: usize,
    /// Valid pixels whose row was refined from stripe edges.
    pub refined_rows: usize,
}

/// The camera frames of one capture: 8-bit grey, all the same size, in pattern order.
#[derive(Clone, Debug)]
pub struct Capture {
    /// Frame width (camera pixels).
    pub width: usize,
    /// Frame height (camera pixels).
    pub height: usize,
    /// One row-major grey image per frame of the pattern set.
    pub frames: Vec<Vec<u8>>,
}

impl Capture {
    /// A warning when the frame in the white frame's place is not the brightest: less than 0.8 of
    /// the mean level of the frame that would be white in the other order (`white_black_first`:
    /// the white frame first, else second to last), as when a capture's order is not the one
    /// named.
    pub fn order_warning(&self, white_black_first: bool) -> Option<String> {
        let n = self.frames.len();
        if n < 3 {
            return None;
        }
        let mean = |f: &Vec<u8>| f.iter().map(|&v| v as f64).sum::<f64>() / f.len().max(1) as f64;
        let (here, other) = if white_black_first { (0, n - 2) } else { (n - 2, 0) };
        let (white, alt) = (mean(&self.frames[here]), mean(&self.frames[other]));
        (white < 0.8 * alt).then(|| {
            let (now, then) = if white_black_first { ("first", "last (as OpenCV's GrayCodePattern makes them; the default)") } else { ("last, as OpenCV's GrayCodePattern makes them", "first (`--white-black first`)") };
            format!("frame {here} (the white frame's place) is darker than frame {other} (mean level {white:.1} against {alt:.1}): the frames may be in another order; the white and black frames were taken to come {now}; they may come {then}")
        })
    }
}

/// The frame files of a capture folder in pattern order: `graycode_NN.png`, `.jpg` or `.jpeg`
/// (any number of digits, case-insensitive extension); other files are ignored. An error naming
/// the file for a missing frame, a frame past the sequence, or two files for one frame.
///
/// A folder without any `graycode_` frame is read as other capture tools write theirs (`0001.png`,
/// `img_1.jpg`, `pattern-01.png` …): its PNG and JPEG files in natural order (digit runs compared
/// as numbers, so `img_2` comes before `img_10`), which must be exactly the sequence's frames.
pub fn capture_paths(dir: &Path, patterns: &PatternSet) -> Result<Vec<PathBuf>> {
    let n = patterns.len();
    let entries = std::fs::read_dir(dir).with_context(|| format!("{}: cannot read the capture folder", dir.display()))?;
    let mut slots: Vec<Option<PathBuf>> = vec![None; n];
    let mut others: Vec<PathBuf> = Vec::new();
    let sequence = || format!("the {}x{} step-{} sequence has {n} frames, graycode_00 … graycode_{:02}", patterns.width, patterns.height, patterns.step, n - 1);
    for entry in entries {
        let entry = entry.with_context(|| format!("{}: cannot read the capture folder", dir.display()))?;
        let path = entry.path();
        let Some(name) = path.file_name().and_then(|s| s.to_str()) else { continue };
        let Some(rest) = name.strip_prefix("graycode_") else {
            if is_frame_file(&path) {
                others.push(path);
            }
            continue;
        };
        let Some((digits, ext)) = rest.split_once('.') else { continue };
        if !matches!(ext.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg") {
            continue;
        }
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            bail!("{}: not a frame name (expected graycode_NN.png)", path.display());
        }
        let index: usize = digits.parse().map_err(|_| anyhow!("{}: frame number out of range", path.display()))?;
        if index >= n {
            bail!("{}: extra image ({})", path.display(), sequence());
        }
        if let Some(other) = &slots[index] {
            bail!("{}: a second file for frame {index} (also {})", path.display(), other.display());
        }
        slots[index] = Some(path);
    }
    if slots.iter().all(Option::is_none) && !others.is_empty() {
        sort_natural(&mut others);
        if others.len() != n {
            let name = |p: &PathBuf| p.file_name().map_or(String::new(), |f| f.to_string_lossy().into_owned());
            bail!(
                "{}: no graycode_NN frames, and {} PNG/JPEG files in natural order ({} … {}) where {}",
                dir.display(),
                others.len(),
                name(&others[0]),
                name(&others[others.len() - 1]),
                sequence()
            );
        }
        return Ok(others);
    }
    if slots.iter().all(Option::is_none) {
        bail!("{}: no frames in the folder (graycode_NN.png, or PNG/JPEG files in natural order: {})", dir.display(), sequence());
    }
    slots
        .into_iter()
        .enumerate()
        .map(|(i, p)| p.ok_or_else(|| anyhow!("{}: missing image ({})", dir.join(format!("graycode_{i:02}.png")).display(), sequence())))
        .collect()
}

/// Whether `path` is a frame file: a PNG or JPEG (case-insensitive extension), not hidden.
fn is_frame_file(path: &Path) -> bool {
    let name = path.file_name().and_then(|s| s.to_str()).unwrap_or("");
    !name.starts_with('.') && path.is_file() && name.rsplit_once('.').is_some_and(|(_, e)| matches!(e.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg"))
}

/// The PNG and JPEG files of a folder in natural order of their names ([`natural_cmp`]): the
/// frames of a capture whose tool does not name them `graycode_NN`.
pub fn image_files_natural(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("{}: cannot read the capture folder", dir.display()))? {
        let path = entry.with_context(|| format!("{}: cannot read the capture folder", dir.display()))?.path();
        if is_frame_file(&path) {
            files.push(path);
        }
    }
    sort_natural(&mut files);
    Ok(files)
}

/// Sorts paths by their file names in natural order ([`natural_cmp`]).
fn sort_natural(files: &mut [PathBuf]) {
    files.sort_by(|a, b| natural_cmp(&a.file_name().unwrap_or_default().to_string_lossy(), &b.file_name().unwrap_or_default().to_string_lossy()));
}

/// Natural order of file names: runs of ASCII digits compare as numbers (`img_2` < `img_10`,
/// leading zeros ignored, then fewer zeros first), everything else byte by byte.
pub fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    use std::cmp::Ordering;
    let (a, b) = (a.as_bytes(), b.as_bytes());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if a[i].is_ascii_digit() && b[j].is_ascii_digit() {
            let (si, sj) = (i, j);
            while i < a.len() && a[i].is_ascii_digit() {
                i += 1;
            }
            while j < b.len() && b[j].is_ascii_digit() {
                j += 1;
            }
            let (da, db) = (&a[si..i], &b[sj..j]);
            let (ta, tb) = (trim_zeros(da), trim_zeros(db));
            let ord = ta.len().cmp(&tb.len()).then_with(|| ta.cmp(tb)).then_with(|| da.len().cmp(&db.len()));
            if ord != Ordering::Equal {
                return ord;
            }
        } else {
            if a[i] != b[j] {
                return a[i].cmp(&b[j]);
            }
            i += 1;
            j += 1;
        }
    }
    (a.len() - i).cmp(&(b.len() - j))
}

fn trim_zeros(d: &[u8]) -> &[u8] {
    let k = d.iter().position(|&c| c != b'0').unwrap_or(d.len());
    &d[k..]
}

/// Reads one camera frame as 8-bit grey: a grey image as it is (16-bit scaled to 8), a colour one
/// converted with OpenCV's `cvtColor` luma, (4899 R + 9617 G + 1868 B + 2¹³) >> 14 (BT.601
/// weights in 14-bit fixed point), so that thresholds mean what they mean in OpenCV.
pub fn read_grey(path: &Path) -> Result<(usize, usize, Vec<u8>)> {
    // A file error keeps its io::Error in the chain (Python's OSError); a decoding error is one
    // cause (the image crate's error repeats its message as its own source).
    let img = image::open(path).map_err(|e| match e {
        image::ImageError::IoError(io) => anyhow::Error::new(io).context(format!("{}: cannot read the image", path.display())),
        e => anyhow::anyhow!("{}: cannot read the image ({e})", path.display()),
    })?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    Ok((w, h, grey_opencv(img)))
}

/// An image's 8-bit grey levels as [`read_grey`] makes them.
pub fn grey_opencv(img: image::DynamicImage) -> Vec<u8> {
    if !img.color().has_color() {
        return img.into_luma8().into_raw();
    }
    img.into_rgb8().into_raw().chunks_exact(3).map(|p| ((4899 * p[0] as u32 + 9617 * p[1] as u32 + 1868 * p[2] as u32 + (1 << 13)) >> 14) as u8).collect()
}

/// Reads a capture folder (frames decoded in parallel); `progress` is called once per frame read.
/// An error naming the file for a bad name set (see [`capture_paths`]), an unreadable image, or
/// a frame whose size differs from the first.
pub fn read_capture(dir: &Path, patterns: &PatternSet, progress: &(dyn Fn() + Sync)) -> Result<Capture> {
    let paths = capture_paths(dir, patterns)?;
    let frames: Vec<(usize, usize, Vec<u8>)> = paths
        .par_iter()
        .map(|p| {
            let r = read_grey(p);
            progress();
            r
        })
        .collect::<Result<_>>()?;
    let (width, height) = (frames[0].0, frames[0].1);
    for (path, f) in paths.iter().zip(&frames) {
        if (f.0, f.1) != (width, height) {
            bail!("{}: {}x{} pixels, but {} is {width}x{height}", path.display(), f.0, f.1, paths[0].display());
        }
    }
    Ok(Capture { width, height, frames: frames.into_iter().map(|f| f.2).collect() })
}

/// Reads and decodes a capture folder.
pub fn decode_dir(dir: &Path, patterns: &PatternSet, settings: &DecodeSettings, progress: &(dyn Fn() + Sync)) -> Result<(DecodeMap, DecodeStats)> {
    let capture = read_capture(dir, patterns, progress)?;
    decode(&capture, patterns, settings)
}

/// Decodes a capture (module documentation).
pub fn decode(capture: &Capture, patterns: &PatternSet, settings: &DecodeSettings) -> Result<(DecodeMap, DecodeStats)> {
    let (w, h) = (capture.width, capture.height);
    if capture.frames.len() != patterns.len() {
        bail!("capture has {} frames, the {}x{} step-{} sequence {}", capture.frames.len(), patterns.width, patterns.height, patterns.step, patterns.len());
    }
    if let Some(i) = capture.frames.iter().position(|f| f.len() != w * h) {
        bail!("capture frame {i} has {} pixels for {w}x{h}", capture.frames[i].len());
    }
    let (nc, nr) = (patterns.column_bits() as usize, patterns.row_bits() as usize);
    // `f`: the pattern frames (column bits, then row bits, each followed by its inverse).
    let (f, white, black) = if settings.white_black_first {
        (&capture.frames[2..], &capture.frames[0], &capture.frames[1])
    } else {
        let f = &capture.frames;
        (&f[..], &f[2 * (nc + nr)], &f[2 * (nc + nr) + 1])
    };
    let (cc, rc) = (patterns.column_codes(), patterns.row_codes());
    let (bt, wt) = (settings.black_threshold, settings.white_threshold);

    // Integer codes, −1 where invalid.
    let mut col_code = vec![-1i32; w * h];
    let mut row_code = vec![-1i32; w * h];
    let rows_per_chunk = 16;
    col_code
        .par_chunks_mut(w * rows_per_chunk)
        .zip(row_code.par_chunks_mut(w * rows_per_chunk))
        .enumerate()
        .for_each(|(chunk, (cols, rows))| {
            let start = chunk * w * rows_per_chunk;
            for j in 0..cols.len() {
                let i = start + j;
                if white[i] as i32 - black[i] as i32 <= bt {
                    continue;
                }
                let read = |first: usize, bits: usize| -> Option<u32> {
                    let mut g = 0u32;
                    for k in 0..bits {
                        let d = f[first + 2 * k][i] as i32 - f[first + 2 * k + 1][i] as i32;
                        if d.abs() <= wt {
                            return None;
                        }
                        g = (g << 1) | (d > 0) as u32;
                    }
                    Some(gray_decode(g))
                };
                let (Some(c), Some(r)) = (read(0, nc), read(2 * nc, nr)) else { continue };
                if c < cc && r < rc {
                    cols[j] = c as i32;
                    rows[j] = r as i32;
                }
            }
        });

    let step = patterns.step;
    let mut col = vec![f32::NAN; w * h];
    let mut row = vec![f32::NAN; w * h];
    let mut stats = DecodeStats::default();
    let axes = [
        (&col_code, &mut col, 0usize, patterns.width, &mut stats.refined_columns),
        (&row_code, &mut row, 2 * nc, patterns.height, &mut stats.refined_rows),
    ];
    for (codes, out, first_frame, size, refined) in axes {
        let n_bits = if first_frame == 0 { nc } else { nr };
        // Difference pattern − inverse of Gray bit `bit` (0 = least significant) at pixel i.
        let diff = |i: usize, bit: u32| -> i32 {
            let k = first_frame + 2 * (n_bits - 1 - bit as usize);
            f[k][i] as i32 - f[k + 1][i] as i32
        };
        let mut best = vec![(f32::NAN, f32::INFINITY); w * h];
        if settings.refine {
            // Along camera rows.
            best.par_chunks_mut(w).enumerate().for_each(|(y, line)| {
                refine_line(&codes[y * w..(y + 1) * w], |p, bit| diff(y * w + p, bit), step, line);
            });
            // Along camera columns.
            let columns: Vec<Vec<(f32, f32)>> = (0..w)
                .into_par_iter()
                .map(|x| {
                    let line_codes: Vec<i32> = (0..h).map(|y| codes[y * w + x]).collect();
                    let mut line = vec![(f32::NAN, f32::INFINITY); h];
                    refine_line(&line_codes, |p, bit| diff(p * w + x, bit), step, &mut line);
                    line
                })
                .collect();
            for (x, line) in columns.iter().enumerate() {
                for (y, &(v, len)) in line.iter().enumerate() {
                    let b = &mut best[y * w + x];
                    if len < b.1 {
                        *b = (v, len);
                    }
                }
            }
        }
        for i in 0..w * h {
            if col_code[i] < 0 || row_code[i] < 0 {
                continue;
            }
            let (v, len) = best[i];
            out[i] = if len.is_finite() {
                *refined += 1;
                v
            } else {
                crate::graycode::block_centre(codes[i] as u32, step, size) as f32
            };
        }
    }
    stats.valid_pixels = col.iter().filter(|c| c.is_finite()).count();
    let to_f32 = |v: &Vec<u8>| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let map = DecodeMap { width: w, height: h, col, row, white: to_f32(white), black: to_f32(black) };
    Ok((map, stats))
}

/// Refines one line of integer codes (−1 invalid) from its stripe edges (module documentation,
/// step 4). `diff(p, bit)` is pattern − inverse of Gray bit `bit` at position `p` of the line.
/// Writes (projector coordinate, edge spacing in camera pixels) into `out` where a bracketed run
/// gives a spacing shorter than the one already there.
fn refine_line(codes: &[i32], diff: impl Fn(usize, u32) -> i32, step: u32, out: &mut [(f32, f32)]) {
    let n = codes.len();
    if n < 3 {
        return;
    }
    // Edge between p and p + 1: (camera position, projector boundary).
    let edge = |p: usize| -> Option<(f64, f64)> {
        let (c0, c1) = (codes[p], codes[p + 1]);
        if c0 < 0 || c1 < 0 || (c0 - c1).abs() != 1 {
            return None;
        }
        let bit = (gray_encode(c0 as u32) ^ gray_encode(c1 as u32)).trailing_zeros();
        let (d0, d1) = (diff(p, bit) as f64, diff(p + 1, bit) as f64);
        // The bit differs between the two pixels and both are decided, so d0 and d1 have opposite
        // signs and t lies in (0, 1).
        let t = d0 / (d0 - d1);
        Some((p as f64 + t, c0.max(c1) as f64 * step as f64 - 0.5))
    };
    let mut a = 0;
    while a < n {
        let c = codes[a];
        let mut b = a;
        while b + 1 < n && codes[b + 1] == c {
            b += 1;
        }
        if c >= 0 && a > 0 && b + 1 < n {
            if let (Some((sl, bl)), Some((sr, br))) = (edge(a - 1), edge(b)) {
                if bl != br {
                    let len = sr - sl;
                    for (x, o) in out.iter_mut().enumerate().take(b + 1).skip(a) {
                        if (len as f32) < o.1 {
                            let v = bl + (x as f64 - sl) * (br - bl) / len;
                            *o = (v as f32, len as f32);
                        }
                    }
                }
            }
        }
        a = b + 1;
    }
}

/// Writes a decode map as a float image (`.exr` or `.pfm`), atomically: R = projector column,
/// G = projector row (projector pixels, OpenCV convention, NaN where invalid), B = the white
/// frame's grey level / 255.
pub fn write_map(path: &Path, map: &DecodeMap) -> Result<()> {
    use render::image_io::{write_image, Format, Image};
    match Format::from_path(path)? {
        Format::Exr | Format::Pfm => {}
        _ => bail!("{}: a decode map is written as .exr or .pfm (float channels)", path.display()),
    }
    let rgb = (0..map.width * map.height).map(|i| [map.col[i], map.row[i], map.white[i] / 255.0]).collect();
    let image = Image::from_rgb(map.width as u32, map.height as u32, rgb)?;
    write_image(path, &image, 0.0)
}

/// Fills the undecided pixels of `map` inside a decoded surface: a pixel without a code whose
/// (2·`radius` + 1)² window holds decoded pixels in all four quadrants around it (so it lies
/// between them, not beyond an outline), at least `min_fraction` of the window, takes the
/// column and row of the least-squares affine fit (col, row = a + b x + c y) to them, provided
/// that fit's RMS residual is at most `max_rms_px` projector pixels (a smooth surface, not a
/// depth step where the projector coordinate jumps). The projector coordinate is smooth over a
/// surface, so an affine fit over a few pixels is exact to its curvature; the filled pixels then
/// triangulate on their own camera rays. Returns the map and the number of pixels filled. Only
/// pixels decoded in `map` enter the fits (one pass).
pub fn fill_holes(map: &DecodeMap, radius: usize, min_fraction: f64, max_rms_px: f64) -> (DecodeMap, usize) {
    let (w, h) = (map.width, map.height);
    let r = radius as i64;
    let fills: Vec<Option<(f32, f32)>> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            if map.col[i].is_finite() && map.row[i].is_finite() {
                return None;
            }
            let (x0, y0) = ((i % w) as i64, (i / w) as i64);
            // Sums for the normal equations of a + b dx + c dy (dx, dy relative to the pixel).
            let mut s = [0.0f64; 6]; // n, Σdx, Σdy, Σdx², Σdxdy, Σdy²
            let mut sc = [0.0f64; 3];
            let mut sr = [0.0f64; 3];
            let mut quad = [false; 4];
            let mut vals = Vec::new();
            for dy in -r..=r {
                for dx in -r..=r {
                    let (x, y) = (x0 + dx, y0 + dy);
                    if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                        continue;
                    }
                    let j = y as usize * w + x as usize;
                    let (c, rw) = (map.col[j], map.row[j]);
                    if !(c.is_finite() && rw.is_finite()) {
                        continue;
                    }
                    let (fx, fy) = (dx as f64, dy as f64);
                    s[0] += 1.0;
                    s[1] += fx;
                    s[2] += fy;
                    s[3] += fx * fx;
                    s[4] += fx * fy;
                    s[5] += fy * fy;
                    for (acc, v) in [(&mut sc, c as f64), (&mut sr, rw as f64)] {
                        acc[0] += v;
                        acc[1] += v * fx;
                        acc[2] += v * fy;
                    }
                    quad[usize::from(dx >= 0) + 2 * usize::from(dy >= 0)] |= dx != 0 || dy != 0;
                    vals.push((fx, fy, c as f64, rw as f64));
                }
            }
            let window = ((2 * r + 1) * (2 * r + 1)) as f64;
            if !quad.iter().all(|&q| q) || s[0] < min_fraction * window || s[0] < 3.0 {
                return None;
            }
            let m = nalgebra::Matrix3::new(s[0], s[1], s[2], s[1], s[3], s[4], s[2], s[4], s[5]);
            let inv = m.try_inverse()?;
            let ac = inv * nalgebra::Vector3::from(sc);
            let ar = inv * nalgebra::Vector3::from(sr);
            let mut se = 0.0;
            for &(fx, fy, c, rw) in &vals {
                se += (ac[0] + ac[1] * fx + ac[2] * fy - c).powi(2) + (ar[0] + ar[1] * fx + ar[2] * fy - rw).powi(2);
            }
            if (se / (2.0 * vals.len() as f64)).sqrt() > max_rms_px {
                return None;
            }
            Some((ac[0] as f32, ar[0] as f32))
        })
        .collect();
    let mut out = map.clone();
    let mut n = 0;
    for (i, f) in fills.iter().enumerate() {
        if let Some((c, r)) = f {
            out.col[i] = *c;
            out.row[i] = *r;
            n += 1;
        }
    }
    (out, n)
}
