//! Progressive film: per-pixel sums of CIE XYZ estimates over passes of one sample per pixel.
//!
//! The image is the running average L_{j+1} = (L_new + j·L_j)/(j+1). We keep the sums
//! S_j = Σ L_i in f64 and the count j instead of the average itself: the two are the same
//! estimator (L_j = S_j / j), but sums make resuming bit-exact (the same additions in the same
//! order) and merging independent runs trivial (sums and counts add, so each run is weighted
//! by its number of samples).
//!
//! A film can also accumulate AOVs ([`crate::integrator::aov`]) and a spectral image
//! ([`SpectralBins`]), chosen by its [`FilmLayout`]: per pixel, f64 sums of each channel over
//! the same samples as the image, so they resume and merge exactly as the image does.
//!
//! Spectral bins: a sample carries four wavelengths λᵢ, each distributed with density p(λ)
//! ([`crate::math::spectral`]), and integral weights wᵢ = L(λᵢ)/(4·p(λᵢ)). Bin b of width Δλ
//! adds Σ_{λᵢ ∈ b} wᵢ / Δλ, whose expectation is (1/Δλ) ∫_b L(λ) dλ because p > 0 on all of
//! 360–830 nm: the mean spectral radiance per nm over the bin, unbiased. Its integral against
//! the CIE functions gives the XYZ of the same samples (tested).
//!
//! Variance: per pixel and sRGB channel the sums S = Σx and Q = Σx² over the n samples give the
//! variance of the pixel mean, (Q − S²/n) / (n(n − 1)) (the unbiased sample variance over n):
//! exact for independent samples, an upper bound for the passes of one seed, whose wavelength and
//! film numbers are stratified ([`crate::math::sampling::PixelStrata`]).

use anyhow::{bail, Result};

use crate::image_io::Image;
use crate::integrator::aov::Aov;
use crate::integrator::settings::IntegratorSettings;
use crate::integrator::{render_pass, render_pass_samples, PixelSample, SampleExtras};
use crate::math::spectral::{SpectralBins, N_LAMBDA};
use crate::scene::Scene;

/// What a film accumulates besides the image: AOVs (sorted, no repeats) and spectral bins.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FilmLayout {
    /// AOVs, in the order of [`Aov::ALL`].
    pub aovs: Vec<Aov>,
    /// Wavelength bins of a spectral image.
    pub bins: Option<SpectralBins>,
}

impl FilmLayout {
    /// A layout of `aovs` (sorted and deduplicated here) and `bins`.
    pub fn new(mut aovs: Vec<Aov>, bins: Option<SpectralBins>) -> FilmLayout {
        aovs.sort();
        aovs.dedup();
        FilmLayout { aovs, bins }
    }

    /// True when the film holds the image only.
    pub fn is_empty(&self) -> bool {
        self.aovs.is_empty() && self.bins.is_none()
    }

    /// Sums kept per pixel besides the XYZ ones.
    pub fn extra_len(&self) -> usize {
        self.aovs.iter().map(|a| a.channels().len()).sum::<usize>() + self.bins.map_or(0, |b| b.count as usize)
    }

    /// What each pass must compute for this layout.
    pub fn extras(&self) -> SampleExtras {
        SampleExtras { first_hit: self.aovs.iter().any(|a| a.is_first_hit()), spectral: self.bins.is_some() }
    }

    /// For messages: `AOVs albedo,normal and spectral bins 400:700:10 nm`, or `no AOVs or
    /// spectral bins`.
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if !self.aovs.is_empty() {
            parts.push(format!("AOVs {}", self.aovs.iter().map(|a| a.name()).collect::<Vec<_>>().join(",")));
        }
        if let Some(b) = self.bins {
            parts.push(format!("spectral bins {}:{}:{} nm", b.start_nm, b.end_nm(), b.width_nm));
        }
        if parts.is_empty() {
            "no AOVs or spectral bins".to_string()
        } else {
            parts.join(" and ")
        }
    }

    /// The EXR channel names of the extras, in storage order.
    pub fn channel_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.aovs.iter().flat_map(|a| a.channels().iter().map(|c| c.to_string())).collect();
        if let Some(b) = self.bins {
            names.extend((0..b.count).map(|k| b.channel_name(k)));
        }
        names
    }
}

/// The per-pass buffer a film's layout needs: XYZ estimates only, or whole samples.
#[derive(Clone, Debug)]
pub enum PassBuffer {
    /// One XYZ estimate per pixel.
    Xyz(Vec<[f32; 3]>),
    /// One [`PixelSample`] per pixel, with these extras computed.
    Samples(Vec<PixelSample>, SampleExtras),
}

/// Accumulator of XYZ samples: `width*height` pixels, row-major, all with the same sample count.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    /// Σ of the XYZ estimates of each pixel (Y = 1 for unit spectral radiance).
    sum_xyz: Vec<[f64; 3]>,
    /// AOVs and spectral bins accumulated besides the image.
    layout: FilmLayout,
    /// Σ of each extra channel, `layout.extra_len()` per pixel, pixel-major.
    sum_extra: Vec<f64>,
    /// Number of passes added, i.e. samples per pixel.
    samples_per_pixel: u64,
    /// Samples that were NaN or infinite and were counted as zero.
    rejected_samples: u64,
}

impl Film {
    /// An empty film of `width`×`height` pixels.
    pub fn new(width: u32, height: u32) -> Film {
        Film::with_layout(width, height, FilmLayout::default())
    }

    /// An empty film of `width`×`height` pixels that also accumulates what `layout` asks for.
    pub fn with_layout(width: u32, height: u32, layout: FilmLayout) -> Film {
        let n = width as usize * height as usize;
        let sum_extra = vec![0.0; n * layout.extra_len()];
        Film { width, height, sum_xyz: vec![[0.0; 3]; n], layout, sum_extra, samples_per_pixel: 0, rejected_samples: 0 }
    }

    /// A film from stored sums with extras (as read from a checkpoint); checks sizes and values.
    pub fn from_parts(
        width: u32,
        height: u32,
        layout: FilmLayout,
        sum_xyz: Vec<[f64; 3]>,
        sum_extra: Vec<f64>,
        samples_per_pixel: u64,
        rejected_samples: u64,
    ) -> Result<Film> {
        let mut film = Film::from_sums(width, height, sum_xyz, samples_per_pixel, rejected_samples)?;
        let need = film.pixel_count() * layout.extra_len();
        if sum_extra.len() != need {
            bail!("film of {width}×{height} pixels with {} needs {need} extra sums, got {}", layout.describe(), sum_extra.len());
        }
        if let Some(i) = sum_extra.iter().position(|v| !v.is_finite()) {
            bail!("extra sum {i} of the film is not finite");
        }
        film.layout = layout;
        film.sum_extra = sum_extra;
        Ok(film)
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
        Ok(Film { width, height, sum_xyz, layout: FilmLayout::default(), sum_extra: Vec::new(), samples_per_pixel, rejected_samples })
    }

    /// What the film accumulates besides the image.
    pub fn layout(&self) -> &FilmLayout {
        &self.layout
    }

    /// The per-pixel sums of the extra channels, `layout().extra_len()` per pixel, pixel-major.
    pub fn extra_sums(&self) -> &[f64] {
        &self.sum_extra
    }

    /// A buffer for one pass of this film's layout.
    pub fn pass_buffer(&self) -> PassBuffer {
        if self.layout.is_empty() {
            PassBuffer::Xyz(vec![[0.0; 3]; self.pixel_count()])
        } else {
            PassBuffer::Samples(vec![PixelSample::ZERO; self.pixel_count()], self.layout.extras())
        }
    }

    /// Render pass `pass` of `seed` (on the current rayon pool) into `buffer` (from
    /// [`Film::pass_buffer`]) and add it. The scene must be at the film's resolution.
    pub fn render_pass(&mut self, scene: &Scene, settings: &IntegratorSettings, seed: u64, pass: u64, buffer: &mut PassBuffer) {
        match buffer {
            PassBuffer::Xyz(xyz) => {
                render_pass(scene, settings, seed, pass, xyz);
                self.add_pass(xyz);
            }
            PassBuffer::Samples(samples, extras) => {
                render_pass_samples(scene, settings, seed, pass, *extras, samples);
                self.add_samples(samples);
            }
        }
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
    /// Panics if `xyz` does not have one entry per pixel, or if the film accumulates AOVs or
    /// spectral bins (use [`Film::add_samples`]): programming errors, not user input.
    pub fn add_pass(&mut self, xyz: &[[f32; 3]]) {
        assert_eq!(xyz.len(), self.sum_xyz.len(), "pass has {} pixels, film {}", xyz.len(), self.sum_xyz.len());
        assert!(self.layout.is_empty(), "add_pass on a film with {}: use add_samples", self.layout.describe());
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

    /// Add one pass of whole samples (one per pixel, row-major, as written by
    /// [`render_pass_samples`]): the image as [`Film::add_pass`] adds it, and each extra channel
    /// of the layout. A sample whose XYZ is not finite is counted as rejected and adds zero
    /// radiance (to the image, the variance and the bins); its first-hit AOVs are still added.
    ///
    /// Panics if `samples` does not have one entry per pixel (a programming error).
    pub fn add_samples(&mut self, samples: &[PixelSample]) {
        assert_eq!(samples.len(), self.sum_xyz.len(), "pass has {} pixels, film {}", samples.len(), self.sum_xyz.len());
        let k = self.layout.extra_len();
        let mut rejected = 0u64;
        for (i, smp) in samples.iter().enumerate() {
            let x = smp.xyz;
            let finite = x.iter().all(|v| v.is_finite());
            if finite {
                let s = &mut self.sum_xyz[i];
                s[0] += x[0] as f64;
                s[1] += x[1] as f64;
                s[2] += x[2] as f64;
            } else {
                rejected += 1;
            }
            if k == 0 {
                continue;
            }
            let extra = &mut self.sum_extra[i * k..(i + 1) * k];
            let mut c = 0;
            for &aov in &self.layout.aovs {
                match smp.first_hit.values(aov) {
                    Some(values) => {
                        for &v in values {
                            if v.is_finite() {
                                extra[c] += v as f64;
                            }
                            c += 1;
                        }
                    }
                    None => {
                        // Variance: second moments of the sample's linear sRGB.
                        let rgb = if finite { optics::color::xyz_to_linear_srgb([x[0] as f64, x[1] as f64, x[2] as f64]) } else { [0.0; 3] };
                        for v in rgb {
                            extra[c] += v * v;
                            c += 1;
                        }
                    }
                }
            }
            if let Some(bins) = self.layout.bins {
                if finite {
                    let inv_width = 1.0 / bins.width_nm as f64;
                    for l in 0..N_LAMBDA {
                        let w = smp.spectral_weight[l];
                        if w != 0.0 {
                            if let Some(b) = bins.index_of(smp.lambda_nm[l]) {
                                extra[c + b] += w as f64 * inv_width;
                            }
                        }
                    }
                }
            }
        }
        self.rejected_samples += rejected;
        self.samples_per_pixel += 1;
    }

    /// Mean of extra channel `channel` (see [`FilmLayout::channel_names`]) of pixel `index`,
    /// before the per-AOV finishing of [`Film::extra_channels`] (raw second moments for the
    /// variance); zero before the first pass.
    pub fn mean_extra(&self, index: usize, channel: usize) -> f64 {
        if self.samples_per_pixel == 0 {
            return 0.0;
        }
        self.sum_extra[index * self.layout.extra_len() + channel] / self.samples_per_pixel as f64
    }

    /// The extra channels as written to an EXR: (name, one value per pixel, row-major), in the
    /// order of [`FilmLayout::channel_names`]. Means over the samples, except: the normal is the
    /// mean normal scaled to unit length (0 where no sample hit), and the variance is that of
    /// the pixel mean (see the module documentation; 0 below two samples).
    pub fn extra_channels(&self) -> Vec<(String, Vec<f32>)> {
        let names = self.layout.channel_names();
        let k = self.layout.extra_len();
        let n_px = self.pixel_count();
        let n = self.samples_per_pixel as f64;
        let mut out: Vec<(String, Vec<f32>)> = names.into_iter().map(|name| (name, vec![0.0f32; n_px])).collect();
        if self.samples_per_pixel == 0 {
            return out;
        }
        for i in 0..n_px {
            let sums = &self.sum_extra[i * k..(i + 1) * k];
            let mut c = 0;
            for &aov in &self.layout.aovs {
                let width = aov.channels().len();
                match aov {
                    Aov::Normal => {
                        let v = [sums[c], sums[c + 1], sums[c + 2]];
                        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                        for d in 0..3 {
                            out[c + d].1[i] = if len > 0.0 { (v[d] / len) as f32 } else { 0.0 };
                        }
                    }
                    Aov::Variance => {
                        let m = optics::color::xyz_to_linear_srgb(self.mean_xyz(i));
                        for d in 0..3 {
                            let v = if self.samples_per_pixel >= 2 { ((sums[c + d] - n * m[d] * m[d]) / (n * (n - 1.0))).max(0.0) } else { 0.0 };
                            out[c + d].1[i] = v as f32;
                        }
                    }
                    Aov::Albedo | Aov::Depth | Aov::Position | Aov::ObjectId => {
                        for d in 0..width {
                            out[c + d].1[i] = (sums[c + d] / n) as f32;
                        }
                    }
                }
                c += width;
            }
            for b in c..k {
                out[b].1[i] = (sums[b] / n) as f32;
            }
        }
        out
    }

    /// Every channel of the film's EXR: `R`, `G`, `B` (linear sRGB, as [`Film::to_image`]) and
    /// the extras of [`Film::extra_channels`].
    pub fn exr_channels(&self) -> Vec<crate::image_io::ExrChannel> {
        let image = self.to_image();
        let mut out: Vec<crate::image_io::ExrChannel> =
            ["R", "G", "B"].iter().enumerate().map(|(c, name)| (name.to_string(), image.rgb.iter().map(|p| p[c]).collect())).collect();
        out.extend(self.extra_channels());
        out
    }

    /// Write the image with its AOVs and spectral bins as one multi-channel EXR, atomically.
    /// With spectral bins the header carries `spectralLayoutVersion` = `1.0` and
    /// `emissiveUnits` = `W.m^-2.sr^-1` (the spectral layout of Fichet et al. 2021, as pbrt-v4
    /// writes it); each `S0.` channel holds the bin's mean spectral radiance per nm.
    pub fn write_exr(&self, path: &std::path::Path) -> Result<()> {
        let attributes: &[(&str, &str)] =
            if self.layout.bins.is_some() { &[("spectralLayoutVersion", "1.0"), ("emissiveUnits", "W.m^-2.sr^-1")] } else { &[] };
        crate::image_io::write_exr_channels(path, self.width, self.height, &self.exr_channels(), attributes)
    }

    /// As [`Film::write_exr`], with `R`, `G`, `B` taken from `image` (e.g. a denoised image of
    /// the same size) and the film's own image kept as `<kept_as>.R`, `.G`, `.B`.
    pub fn write_exr_with_rgb(&self, path: &std::path::Path, image: &Image, kept_as: &str) -> Result<()> {
        if (image.width, image.height) != (self.width, self.height) {
            bail!("{}: a {}×{} image for a {}×{} film", path.display(), image.width, image.height, self.width, self.height);
        }
        let mut channels = self.exr_channels();
        let own: Vec<crate::image_io::ExrChannel> = channels.drain(..3).collect();
        let mut out: Vec<crate::image_io::ExrChannel> =
            ["R", "G", "B"].iter().enumerate().map(|(c, name)| (name.to_string(), image.rgb.iter().map(|p| p[c]).collect())).collect();
        out.extend(own.into_iter().map(|(name, v)| (format!("{kept_as}.{name}"), v)));
        out.extend(channels);
        let attributes: &[(&str, &str)] =
            if self.layout.bins.is_some() { &[("spectralLayoutVersion", "1.0"), ("emissiveUnits", "W.m^-2.sr^-1")] } else { &[] };
        crate::image_io::write_exr_channels(path, self.width, self.height, &out, attributes)
    }

    /// Add another film of the same size: sums and counts add, so the mean of the result is the
    /// sample-count-weighted mean of the two.
    pub fn add_film(&mut self, other: &Film) -> Result<()> {
        if self.layout != other.layout {
            bail!("cannot add a film with {} to one with {}", other.layout.describe(), self.layout.describe());
        }
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
        for (s, o) in self.sum_extra.iter_mut().zip(&other.sum_extra) {
            *s += o;
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
