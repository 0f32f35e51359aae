//! The pattern sequence of OpenCV's `structured_light::GrayCodePattern`, for the synthetic
//! captures: column bits, then row bits, most significant first, each bit as a pattern (white
//! where that bit of the pixel's reflected-binary Gray code g = n ⊕ (n ≫ 1) is 1) followed by its
//! inverse; then all-white and all-black. bits = ⌈log₂ size⌉ per axis.
//!
//! Kept private to the generator: the product's own pattern generator (in the decoding module)
//! makes the same images and can replace this one.

/// Number of bits for `n` codes: ⌈log₂ n⌉ (0 for n ≤ 1).
pub(crate) fn bits_for(n: u32) -> u32 {
    if n <= 1 {
        0
    } else {
        32 - (n - 1).leading_zeros()
    }
}

/// Number of images in the sequence for a `width` × `height` projector.
pub(crate) fn image_count(width: u32, height: u32) -> usize {
    2 * (bits_for(width) + bits_for(height)) as usize + 2
}

/// Image `index` of the sequence as linear projector values (0 or 1), row-major from the top row.
pub(crate) fn pattern(width: u32, height: u32, index: usize) -> Vec<f32> {
    let (bx, by) = (bits_for(width) as usize, bits_for(height) as usize);
    let n = width as usize * height as usize;
    let ncode = 2 * (bx + by);
    if index == ncode {
        return vec![1.0; n];
    }
    if index == ncode + 1 {
        return vec![0.0; n];
    }
    assert!(index < ncode, "pattern index {index} beyond the {} images", ncode + 2);
    let inverse = index % 2 == 1;
    let bit = index / 2;
    let (columns, shift) = if bit < bx { (true, bx - 1 - bit) } else { (false, by - 1 - (bit - bx)) };
    let mut img = vec![0.0f32; n];
    for y in 0..height as usize {
        for x in 0..width as usize {
            let c = if columns { x } else { y };
            let g = c ^ (c >> 1);
            let on = ((g >> shift) & 1 == 1) != inverse;
            img[y * width as usize + x] = if on { 1.0 } else { 0.0 };
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bit_counts() {
        assert_eq!(bits_for(1024), 10);
        assert_eq!(bits_for(768), 10);
        assert_eq!(bits_for(256), 8);
        assert_eq!(bits_for(192), 8);
        assert_eq!(bits_for(257), 9);
        assert_eq!(image_count(1024, 768), 42);
    }

    /// The first image lights the right half (as in the shared real captures); pattern and inverse
    /// sum to white; reading the bits back MSB first and undoing the Gray code gives every column
    /// and row.
    #[test]
    fn sequence_decodes_to_every_pixel() {
        let (w, h) = (20u32, 12u32);
        let imgs: Vec<Vec<f32>> = (0..image_count(w, h)).map(|k| pattern(w, h, k)).collect();
        assert!((0..w as usize).all(|x| imgs[0][x] == if x >= 16 { 1.0 } else { 0.0 }));
        let (bx, by) = (bits_for(w) as usize, bits_for(h) as usize);
        for y in 0..h as usize {
            for x in 0..w as usize {
                let i = y * w as usize + x;
                let read = |first: usize, nb: usize| {
                    let mut g = 0usize;
                    for b in 0..nb {
                        let (p, q) = (imgs[2 * (first + b)][i], imgs[2 * (first + b) + 1][i]);
                        assert_eq!(p + q, 1.0);
                        g = (g << 1) | (p > q) as usize;
                    }
                    let mut n = g;
                    let mut s = g >> 1;
                    while s != 0 {
                        n ^= s;
                        s >>= 1;
                    }
                    n
                };
                assert_eq!((read(0, bx), read(bx, by)), (x, y));
            }
        }
    }
}
