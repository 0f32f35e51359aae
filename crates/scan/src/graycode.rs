//! The Gray-code patterns of OpenCV's `structured_light::GrayCodePattern` (Posdamer & Altschuler
//! 1982; Geng, "Structured-light 3D surface imaging: a tutorial", Adv. Opt. Photon. 3, 2011, §3.2).
//!
//! A projector of W × H pixels with step S codes ⌈W/S⌉ columns and ⌈H/S⌉ rows: projector pixel
//! (x, y) carries column code ⌊x/S⌋ and row code ⌊y/S⌋ (the codes start at 0 at the left and top
//! edges, no offset, as OpenCV's generator and the `gen_graycode_imgs.py` expansion of
//! kamino410/procam-calibration do). A code c is sent as the reflected binary Gray code
//! g = c ⊕ (c ≫ 1) in n = ⌈log₂(code count)⌉ bits; codes ≥ the count never occur.
//!
//! The sequence, frame by frame: for each column bit from the most significant, the pattern
//! (255 where the bit of g is 1, else 0) and then its inverse; the same for the row bits; then
//! an all-white and an all-black frame. For 1024 × 768 and S = 1 that is 10 + 10 bits, 40 bit
//! frames, 42 in all; in frame 0 the right half (columns 512…1023) is lit.

/// The reflected binary Gray code of `b`.
pub fn gray_encode(b: u32) -> u32 {
    b ^ (b >> 1)
}

/// The binary number whose Gray code is `g` (prefix XOR from the most significant bit).
pub fn gray_decode(g: u32) -> u32 {
    let mut b = g;
    let mut shift = 1;
    while shift < 32 {
        b ^= b >> shift;
        shift <<= 1;
    }
    b
}

/// Bits needed for `count` codes: ⌈log₂ count⌉ (0 for a single code).
pub fn bits_for(count: u32) -> u32 {
    if count <= 1 {
        0
    } else {
        32 - (count - 1).leading_zeros()
    }
}

/// What one frame of the sequence shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Frame {
    /// Bit `bit` of the column Gray code (`bit` counts from the least significant), lit where the
    /// bit is 1, or where it is 0 when `inverse`.
    Column { bit: u32, inverse: bool },
    /// Bit `bit` of the row Gray code, as for columns.
    Row { bit: u32, inverse: bool },
    /// Every pixel lit.
    White,
    /// Every pixel dark.
    Black,
}

/// The pattern sequence for one projector resolution and step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PatternSet {
    /// Projector width (pixels).
    pub width: u32,
    /// Projector height (pixels).
    pub height: u32,
    /// Projector pixels per code along each axis (1: every projector pixel has its own code).
    pub step: u32,
}

impl PatternSet {
    /// A sequence for a `width` × `height` projector; an error for a zero size or step.
    pub fn new(width: u32, height: u32, step: u32) -> anyhow::Result<PatternSet> {
        if width == 0 || height == 0 {
            anyhow::bail!("projector size must be at least 1x1, got {width}x{height}");
        }
        if step == 0 {
            anyhow::bail!("step must be at least 1 projector pixel");
        }
        Ok(PatternSet { width, height, step })
    }

    /// Number of column codes ⌈W/S⌉.
    pub fn column_codes(&self) -> u32 {
        (self.width - 1) / self.step + 1
    }

    /// Number of row codes ⌈H/S⌉.
    pub fn row_codes(&self) -> u32 {
        (self.height - 1) / self.step + 1
    }

    /// Bits of the column code.
    pub fn column_bits(&self) -> u32 {
        bits_for(self.column_codes())
    }

    /// Bits of the row code.
    pub fn row_bits(&self) -> u32 {
        bits_for(self.row_codes())
    }

    /// Frames in the sequence: 2 per column bit, 2 per row bit, white, black.
    pub fn len(&self) -> usize {
        2 * (self.column_bits() + self.row_bits()) as usize + 2
    }

    /// Never empty (white and black are always there).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Frame index of the pattern (not the inverse) of column bit `bit` (0 = least significant).
    pub fn column_frame(&self, bit: u32) -> usize {
        2 * (self.column_bits() - 1 - bit) as usize
    }

    /// Frame index of the pattern (not the inverse) of row bit `bit` (0 = least significant).
    pub fn row_frame(&self, bit: u32) -> usize {
        2 * (self.column_bits() + self.row_bits() - 1 - bit) as usize
    }

    /// What frame `index` shows; None past the end.
    pub fn frame(&self, index: usize) -> Option<Frame> {
        let (nc, nr) = (self.column_bits() as usize, self.row_bits() as usize);
        let inverse = index % 2 == 1;
        if index < 2 * nc {
            Some(Frame::Column { bit: (nc - 1 - index / 2) as u32, inverse })
        } else if index < 2 * (nc + nr) {
            Some(Frame::Row { bit: (nr - 1 - (index - 2 * nc) / 2) as u32, inverse })
        } else if index == 2 * (nc + nr) {
            Some(Frame::White)
        } else if index == 2 * (nc + nr) + 1 {
            Some(Frame::Black)
        } else {
            None
        }
    }

    /// Whether projector pixel (x, y) is lit in frame `frame`.
    pub fn lit(&self, frame: Frame, x: u32, y: u32) -> bool {
        match frame {
            Frame::Column { bit, inverse } => ((gray_encode(x / self.step) >> bit) & 1 == 1) != inverse,
            Frame::Row { bit, inverse } => ((gray_encode(y / self.step) >> bit) & 1 == 1) != inverse,
            Frame::White => true,
            Frame::Black => false,
        }
    }

    /// Frame `index` as an 8-bit grey image, row-major, 255 lit and 0 dark; None past the end.
    pub fn image(&self, index: usize) -> Option<Vec<u8>> {
        let frame = self.frame(index)?;
        let (w, h) = (self.width as usize, self.height as usize);
        let mut out = vec![0u8; w * h];
        match frame {
            Frame::Column { .. } => {
                let row: Vec<u8> = (0..self.width).map(|x| if self.lit(frame, x, 0) { 255 } else { 0 }).collect();
                for line in out.chunks_exact_mut(w) {
                    line.copy_from_slice(&row);
                }
            }
            Frame::Row { .. } => {
                for (y, line) in out.chunks_exact_mut(w).enumerate() {
                    line.fill(if self.lit(frame, 0, y as u32) { 255 } else { 0 });
                }
            }
            Frame::White => out.fill(255),
            Frame::Black => {}
        }
        Some(out)
    }

    /// Projector coordinate (pixels, OpenCV convention: integers at pixel centres) of the centre of
    /// the pixels carrying column code `code`: the block ⌊code·S⌋ … min(code·S + S, W) − 1.
    pub fn column_centre(&self, code: u32) -> f64 {
        block_centre(code, self.step, self.width)
    }

    /// As [`column_centre`](Self::column_centre), for row codes.
    pub fn row_centre(&self, code: u32) -> f64 {
        block_centre(code, self.step, self.height)
    }
}

pub(crate) fn block_centre(code: u32, step: u32, size: u32) -> f64 {
    let first = code as f64 * step as f64;
    let last = ((code as u64 + 1) * step as u64).min(size as u64) as f64 - 1.0;
    0.5 * (first + last)
}

/// Writes every frame of `patterns` as an 8-bit grey PNG `pattern_NN.png` in `dir` (created if
/// missing), each atomically; `progress` is called once per file. Returns the paths in order.
pub fn write_patterns(dir: &std::path::Path, patterns: &PatternSet, progress: &(dyn Fn() + Sync)) -> anyhow::Result<Vec<std::path::PathBuf>> {
    use anyhow::Context;
    use rayon::prelude::*;
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create the folder", dir.display()))?;
    (0..patterns.len())
        .into_par_iter()
        .map(|i| {
            let path = dir.join(format!("pattern_{i:02}.png"));
            let pixels = patterns.image(i).expect("index within the sequence");
            render::image_io::write_atomic(&path, |tmp| {
                image::save_buffer_with_format(tmp, &pixels, patterns.width, patterns.height, image::ColorType::L8, image::ImageFormat::Png)
                    .with_context(|| format!("{}: cannot write", tmp.display()))
            })
            .with_context(|| format!("writing {}", path.display()))?;
            progress();
            Ok(path)
        })
        .collect()
}
