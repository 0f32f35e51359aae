//! Albedo grids of media: a factor a(x, λ) ∈ [0, 1] on the scattering coefficient of a medium
//! with a density grid, σ_s(x, λ) = a(x, λ) ρ(x) σ_s(λ), with σ_t(x, λ) = ρ(x) σ_t(λ)
//! unchanged (what a(x) takes from the scattering is absorbed). It is Mitsuba 3's `albedo`
//! volume of its `heterogeneous` medium as a factor on the medium's own single-scattering albedo.
//!
//! A grid holds one grey value per cell, or an RGB colour (linear sRGB) per cell. Each colour is
//! uplifted once to the bounded reflectance spectrum of Jakob & Hanika (2019)
//! ([`crate::math::uplift`], as lucent's image textures), and the trilinear interpolation
//! blends the eight neighbouring cells' spectra at the path's wavelengths (spectra, not RGB).
//! Mitsuba 3's spectral variants upsample a three-channel volume as an emitter instead
//! (2·max(rgb) times the sigmoid of rgb/(2·max), interpolated as spectrum and scale separately),
//! which gives the same colour per cell but can exceed 1 at some wavelengths for saturated
//! colours; here an albedo never does.

use super::grid::DensityGrid;
use crate::math::spectral::SampledWavelengths;
use crate::math::uplift::{normalized_lambda, sigmoid_shape, uplift_colours};
use anyhow::{bail, Result};
use glam::{Vec3, Vec4};

/// The albedo factor of a medium with a density grid.
#[derive(Clone, Debug)]
pub enum AlbedoGrid {
    /// One value in [0, 1] per cell, the same at every wavelength.
    Grey(DensityGrid),
    /// One colour per cell: `cells` places them (its own values are the colours' largest
    /// components), `spectra` holds each cell's uplifted spectrum (`[c₀, c₁, c₂, scale]`).
    Rgb { cells: DensityGrid, spectra: Vec<[f32; 4]> },
}

impl AlbedoGrid {
    /// A grey grid; values must lie in [0, 1].
    pub fn grey(grid: DensityGrid) -> Result<AlbedoGrid> {
        let m = grid.max_density();
        if m > 1.0 {
            bail!("albedo scales lie in [0, 1], got {m}");
        }
        Ok(AlbedoGrid::Grey(grid))
    }

    /// An RGB grid of `n` cells (colours x fastest, linear sRGB, each component in [0, 1]) over
    /// the box `min_m`–`max_m` (metres).
    pub fn rgb(n: [usize; 3], colours: &[[f32; 3]], min_m: [f64; 3], max_m: [f64; 3]) -> Result<AlbedoGrid> {
        if let Some((i, c)) = colours.iter().enumerate().find(|(_, c)| c.iter().any(|v| !(v.is_finite() && (0.0..=1.0).contains(v)))) {
            bail!("albedo {c:?} at cell {i} (x fastest): RGB albedos lie in [0, 1]");
        }
        let largest = colours.iter().map(|c| c[0].max(c[1]).max(c[2])).collect();
        let cells = DensityGrid::new(n, largest, min_m, max_m)?;
        Ok(AlbedoGrid::Rgb { cells, spectra: uplift_colours(colours, false) })
    }

    /// The albedo factor at `p` (m) at each carried wavelength.
    #[inline]
    pub fn at(&self, p: Vec3, wl: &SampledWavelengths) -> Vec4 {
        match self {
            AlbedoGrid::Grey(g) => Vec4::splat(g.density(p)),
            AlbedoGrid::Rgb { cells, spectra } => {
                let (idx, w) = cells.corners(p);
                let t = normalized_lambda(wl);
                let mut out = Vec4::ZERO;
                for k in 0..8 {
                    if w[k] != 0.0 {
                        let c = spectra[idx[k]];
                        out += w[k] * c[3] * sigmoid_shape(c, t);
                    }
                }
                out.min(Vec4::ONE)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Pcg32;
    use optics::uplift::SigmoidSpectrum;

    fn wavelengths(u: f32) -> SampledWavelengths {
        SampledWavelengths::sample(u)
    }

    /// Greys are exact constants; a grid of one grey everywhere is the grey grid of that value.
    #[test]
    fn a_grey_rgb_grid_is_the_grey_grid() {
        let n = [3, 2, 2];
        let rgb = AlbedoGrid::rgb(n, &vec![[0.35; 3]; 12], [0.0; 3], [1.0; 3]).unwrap();
        let grey = AlbedoGrid::grey(DensityGrid::new(n, vec![0.35; 12], [0.0; 3], [1.0; 3]).unwrap()).unwrap();
        let mut rng = Pcg32::new(3, 1);
        for _ in 0..100 {
            let p = Vec3::new(rng.next_f32() * 1.4 - 0.2, rng.next_f32(), rng.next_f32());
            let wl = wavelengths(rng.next_f32());
            let (a, b) = (rgb.at(p, &wl), grey.at(p, &wl));
            assert!((a - b).abs().max_element() < 1e-6, "{a} against {b}");
        }
    }

    /// At a cell centre the albedo is that cell's uplifted reflectance; between two centres along
    /// x it is the blend of the two spectra with the trilinear weights; beyond the outer
    /// centres it is clamped.
    #[test]
    fn rgb_albedo_interpolates_the_cells_spectra() {
        let colours = [[0.9, 0.4, 0.1], [0.1, 0.5, 0.8]];
        let g = AlbedoGrid::rgb([2, 1, 1], &colours, [0.0; 3], [2.0, 1.0, 1.0]).unwrap();
        let spectra = colours.map(|c| SigmoidSpectrum::reflectance_by(c.map(|v| v as f64), optics::uplift::Fit::Direct));
        let mut rng = Pcg32::new(9, 2);
        for _ in 0..50 {
            let wl = wavelengths(rng.next_f32());
            for (x, w1) in [(0.5f32, 0.0f64), (1.5, 1.0), (1.0, 0.5), (0.8, 0.3), (0.1, 0.0), (1.9, 1.0)] {
                let a = g.at(Vec3::new(x, 0.5, 0.5), &wl);
                for (i, &l) in wl.lambda_nm.iter().enumerate() {
                    let want = (1.0 - w1) * spectra[0].eval(l as f64) + w1 * spectra[1].eval(l as f64);
                    assert!((a[i] as f64 - want).abs() < 2e-4, "x {x}, λ {l}: {} against {want}", a[i]);
                }
            }
        }
    }

    /// The colour a cell's spectrum reflects under D65 is the cell's RGB.
    #[test]
    fn each_cell_reflects_its_colour() {
        let colours = [[0.8, 0.3, 0.2], [0.2, 0.6, 0.3], [0.5, 0.5, 0.9], [0.0, 0.0, 0.0]];
        let g = AlbedoGrid::rgb([4, 1, 1], &colours, [0.0; 3], [4.0, 1.0, 1.0]).unwrap();
        for (k, c) in colours.iter().enumerate() {
            let AlbedoGrid::Rgb { spectra, .. } = &g else { unreachable!() };
            let s = spectra[k];
            let refl = |l: f64| {
                let t = ((l - 360.0) / 470.0) as f32;
                (s[3] * sigmoid_shape(s, Vec4::splat(t)).x) as f64
            };
            let rgb = optics::spectrum::reflectance_to_linear_srgb(refl);
            for i in 0..3 {
                assert!((rgb[i] - c[i] as f64).abs() < 2e-3, "cell {k}: {rgb:?} against {c:?}");
            }
        }
    }

    #[test]
    fn albedos_outside_zero_one_are_refused() {
        assert!(AlbedoGrid::rgb([1, 1, 1], &[[1.2, 0.5, 0.5]], [0.0; 3], [1.0; 3]).is_err());
        assert!(AlbedoGrid::rgb([1, 1, 1], &[[f32::NAN, 0.5, 0.5]], [0.0; 3], [1.0; 3]).is_err());
        assert!(AlbedoGrid::grey(DensityGrid::new([1, 1, 1], vec![1.5], [0.0; 3], [1.0; 3]).unwrap()).is_err());
    }
}
