//! Progressive film: per-pixel sums of CIE XYZ estimates over passes of one sample per pixel.
//!
//! The image is the running average L_{j+1} = (L_new + j·L_j)/(j+1). We keep the sums
//! S_j = Σ L_i in f64 and the count j instead of the average itself: the two are the same
//! estimator (L_j = S_j / j), but sums make resuming bit-exact (the same additions in the same
//! order) and merging independent runs trivial (sums and counts add, so each run is weighted
//! by its number of samples).

use anyhow::{bail, Result};

use crate::image_io::Image;

/// Accumulator of XYZ samples: `width*height` pixels, row-major, all with the same sample count.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    /// Σ of the XYZ estimates of each pixel (Y = 1 for unit spectral radiance).
    sum_xyz: Vec<[f64; 3]>,
    /// Number of passes added, i.e. samples per pixel.
    samples_per_pixel: u64,
    /// Samples that were NaN or infinite and were counted as zero.
    rejected_samples: u64,
}

impl Film {
    /// An empty film of `width`×`height` pixels.
    pub fn new(width: u32, height: u32) -> Film {
        let n = width as usize * height as usize;
        Film { width, height, sum_xyz: vec![[0.0; 3]; n], samples_per_pixel: 0, rejected_samples: 0 }
    }

    /// A film from stored sums (as read from a checkpoint); checks the sizes and values agree.
    pub fn from_sums(
        width: u32,
        height: u32,
        sum_xyz: Vec<[f64; 3]>,
        samples_per_pixel: u64,
        rejected_samples: u64,
    ) -> Result<Film> {
        let n = width as usize * height as usize;
        if sum_xyz.len() != n {
            bail!("film of {width}×{height} pixels needs {n} sums, got {}", sum_xyz.len());
        }
        if let Some(i) = sum_xyz.iter().position(|s| !s.iter().all(|v| v.is_finite())) {
            bail!("film sum of pixel {i} is not finite");
        }
        Ok(Film { width, height, sum_xyz, samples_per_pixel, rejected_samples })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Number of pixels, `width*height`.
    pub fn pixel_count(&self) -> usize {
        self.sum_xyz.len()
    }

    /// Samples accumulated in every pixel (one per pass).
    pub fn samples_per_pixel(&self) -> u64 {
        self.samples_per_pixel
    }

    /// Samples that were not finite (NaN, ±∞) and were added as zero instead.
    pub fn rejected_samples(&self) -> u64 {
        self.rejected_samples
    }

    /// The per-pixel sums of XYZ estimates, row-major.
    pub fn sums(&self) -> &[[f64; 3]] {
        &self.sum_xyz
    }

    /// Add one pass: one XYZ estimate per pixel, row-major, as written by
    /// [`crate::integrator::render_pass`]. Non-finite estimates are added as zero and counted.
    ///
    /// Panics if `xyz` does not have one entry per pixel (a programming error, not user input).
    pub fn add_pass(&mut self, xyz: &[[f32; 3]]) {
        assert_eq!(xyz.len(), self.sum_xyz.len(), "pass has {} pixels, film {}", xyz.len(), self.sum_xyz.len());
        let mut rejected = 0u64;
        for (s, x) in self.sum_xyz.iter_mut().zip(xyz) {
            if x.iter().all(|v| v.is_finite()) {
                s[0] += x[0] as f64;
                s[1] += x[1] as f64;
                s[2] += x[2] as f64;
            } else {
                rejected += 1;
            }
        }
        self.rejected_samples += rejected;
        self.samples_per_pixel += 1;
    }

    /// Add another film of the same size: sums and counts add, so the mean of the result is the
    /// sample-count-weighted mean of the two.
    pub fn add_film(&mut self, other: &Film) -> Result<()> {
        if (self.width, self.height) != (other.width, other.height) {
            bail!(
                "cannot add a {}×{} film to a {}×{} one",
                other.width,
                other.height,
                self.width,
                self.height
            );
        }
        let (Some(spp), Some(rejected)) = (
            self.samples_per_pixel.checked_add(other.samples_per_pixel),
            self.rejected_samples.checked_add(other.rejected_samples),
        ) else {
            bail!(
                "sample counts overflow: {} + {} samples per pixel ({} + {} rejected)",
                self.samples_per_pixel,
                other.samples_per_pixel,
                self.rejected_samples,
                other.rejected_samples
            );
        };
        for (s, o) in self.sum_xyz.iter_mut().zip(&other.sum_xyz) {
            s[0] += o[0];
            s[1] += o[1];
            s[2] += o[2];
        }
        self.samples_per_pixel = spp;
        self.rejected_samples = rejected;
        Ok(())
    }

    /// Mean XYZ of pixel `index` (row-major); zero before the first pass.
    pub fn mean_xyz(&self, index: usize) -> [f64; 3] {
        if self.samples_per_pixel == 0 {
            return [0.0; 3];
        }
        let n = self.samples_per_pixel as f64;
        let s = self.sum_xyz[index];
        [s[0] / n, s[1] / n, s[2] / n]
    }

    /// The averaged image in linear sRGB primaries with D65 white (Y = 1 for unit radiance).
    pub fn to_image(&self) -> Image {
        let rgb = (0..self.pixel_count())
            .map(|i| {
                let c = optics::color::xyz_to_linear_srgb(self.mean_xyz(i));
                [c[0] as f32, c[1] as f32, c[2] as f32]
            })
            .collect();
        Image { width: self.width, height: self.height, rgb }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic synthetic pass: pixel i of pass p gets a value depending on both.
    fn synthetic_pass(n: usize, pass: u64) -> Vec<[f32; 3]> {
        (0..n).map(|i| {
            let v = ((i as u64 * 7 + pass * 13) % 17) as f32 * 0.25;
            [v, 2.0 * v, 0.5 + v]
        }).collect()
    }

    #[test]
    fn sums_equal_the_running_average() {
        // L_{j+1} = (L_new + j L_j)/(j+1) computed directly must match sums / count.
        let n = 12;
        let mut film = Film::new(4, 3);
        let mut running = vec![[0.0f64; 3]; n];
        for pass in 0..9u64 {
            let xyz = synthetic_pass(n, pass);
            film.add_pass(&xyz);
            let j = pass as f64;
            for (l, x) in running.iter_mut().zip(&xyz) {
                for c in 0..3 {
                    l[c] = (x[c] as f64 + j * l[c]) / (j + 1.0);
                }
            }
        }
        assert_eq!(film.samples_per_pixel(), 9);
        for i in 0..n {
            let m = film.mean_xyz(i);
            for c in 0..3 {
                assert!((m[c] - running[i][c]).abs() < 1e-12, "pixel {i} channel {c}: {} vs {}", m[c], running[i][c]);
            }
        }
    }

    #[test]
    fn non_finite_samples_are_counted_not_accumulated() {
        let mut film = Film::new(2, 1);
        film.add_pass(&[[1.0, 1.0, 1.0], [f32::NAN, 0.0, 0.0]]);
        film.add_pass(&[[3.0, 3.0, 3.0], [f32::INFINITY, 1.0, 1.0]]);
        assert_eq!(film.rejected_samples(), 2);
        assert_eq!(film.mean_xyz(0), [2.0, 2.0, 2.0]);
        assert_eq!(film.mean_xyz(1), [0.0, 0.0, 0.0]);
    }

    #[test]
    fn adding_films_weights_by_sample_count() {
        // Run A: 3 samples of value 1, run B: 1 sample of value 5 → mean (3·1 + 5)/4 = 2,
        // not the unweighted (1 + 5)/2 = 3.
        let mut a = Film::new(1, 1);
        for _ in 0..3 {
            a.add_pass(&[[1.0, 1.0, 1.0]]);
        }
        let mut b = Film::new(1, 1);
        b.add_pass(&[[5.0, 5.0, 5.0]]);
        a.add_film(&b).unwrap();
        assert_eq!(a.samples_per_pixel(), 4);
        assert_eq!(a.mean_xyz(0), [2.0, 2.0, 2.0]);
        assert!(a.add_film(&Film::new(2, 1)).is_err());
    }

    #[test]
    fn to_image_converts_the_mean_xyz_to_linear_srgb() {
        // D65 white with Y = 1 (XYZ 0.95047, 1, 1.08883, from the CIE 1931 2° whitepoint) is
        // linear sRGB (1, 1, 1). Two passes at 1.5× and 0.5× average to it; the other pixel
        // is black, and pixel order is kept (row-major in both).
        let d65 = [0.95047f32, 1.0, 1.08883];
        let mut film = Film::new(2, 1);
        film.add_pass(&[[1.5 * d65[0], 1.5 * d65[1], 1.5 * d65[2]], [0.0; 3]]);
        film.add_pass(&[[0.5 * d65[0], 0.5 * d65[1], 0.5 * d65[2]], [0.0; 3]]);
        let img = film.to_image();
        assert_eq!((img.width, img.height), (2, 1));
        for c in 0..3 {
            assert!((img.rgb[0][c] - 1.0).abs() < 2e-3, "white channel {c}: {}", img.rgb[0][c]);
            assert_eq!(img.rgb[1][c], 0.0);
        }
        // Before any pass the image is black, not NaN.
        assert!(Film::new(1, 1).to_image().rgb[0].iter().all(|&v| v == 0.0));
    }

    #[test]
    fn from_sums_checks_sizes() {
        assert!(Film::from_sums(2, 2, vec![[0.0; 3]; 3], 1, 0).is_err());
        assert!(Film::from_sums(2, 2, vec![[f64::NAN, 0.0, 0.0]; 4], 1, 0).is_err());
        assert!(Film::from_sums(2, 2, vec![[0.0; 3]; 4], 1, 0).is_ok());
    }
}
