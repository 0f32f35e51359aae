//! Decoding a Gray-code capture into projector coordinates per camera pixel.

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
}
