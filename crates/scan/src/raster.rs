//! Row-major pixel grids: the 4-connected neighbours of a pixel.

/// The 4-connected neighbours of pixel `i` of a `w` × `h` row-major grid, in the order left, up,
/// right, down; None past the border.
#[inline]
pub fn neighbours4(i: usize, w: usize, h: usize) -> [Option<usize>; 4] {
    let (x, y) = (i % w, i / w);
    [(x > 0).then(|| i - 1), (y > 0).then(|| i - w), (x + 1 < w).then(|| i + 1), (y + 1 < h).then(|| i + w)]
}
