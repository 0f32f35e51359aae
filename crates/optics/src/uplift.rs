//! RGB → spectrum for many colours at once (image textures): a table of sigmoid-polynomial
//! coefficients over the sRGB cube, computed here at first use, and per-colour refinement.
//!
//! The function space is that of Jakob & Hanika, "A Low-Dimensional Function Space for
//! Efficient Spectral Upsampling", Computer Graphics Forum 38(2), 2019, which pbrt-v4
//! (`RGBToSpectrumTable`, `RGBIlluminantSpectrum`) and Mitsuba 3 (`srgb` texture spectra) use:
//! a reflectance is s(c₀t² + c₁t + c₂) with s(x) = ½ + x/(2√(1+x²)) and t the normalised
//! wavelength (λ − 360 nm)/(470 nm); an illuminant is scale · s(c(rgb/scale)) · D65(λ) with
//! scale = 2·max(r, g, b), so its shape never needs a saturated reflectance.
//!
//! The table is laid out as in the paper (and pbrt-v4's `rgb2spec_opt`): for each choice of
//! the largest component l, a grid over z = rgb[l] (nodes crowded towards 0 and 1 by a double
//! smoothstep) and the ratios x = rgb[l+1]/z, y = rgb[l+2]/z. Each node is fitted by damped
//! Gauss–Newton against the CIE 1931 observer under D65 — the same weights as
//! [`crate::spectrum::reflectance_to_linear_srgb`] — warm-started from its neighbour along z.
//! A lookup interpolates the coefficients trilinearly and then refines them for the exact
//! colour, so the result reproduces the input to the solver's tolerance (not the table's
//! interpolation error) and equals [`crate::spectrum::RgbAlbedo`] up to that tolerance.

use crate::spectrum::{fit_sigmoid, refine_sigmoid, sigmoid_polynomial};
use std::sync::OnceLock;

/// Nodes per axis of the coefficient table.
pub const TABLE_RES: usize = 16;

/// Sigmoid-polynomial coefficients over the sRGB cube (see the module comment).
#[derive(Clone, Debug)]
pub struct CoefficientTable {
    /// z nodes (value of the largest component), increasing from 0 to 1.
    z: Vec<f64>,
    /// Coefficients at [l][zi][yi][xi], flattened.
    coeffs: Vec<[f64; 3]>,
}

/// Double smoothstep: crowds the z nodes towards 0 and 1, where the coefficients change fastest.
fn z_node(k: usize) -> f64 {
    let s = |x: f64| x * x * (3.0 - 2.0 * x);
    s(s(k as f64 / (TABLE_RES - 1) as f64))
}

impl CoefficientTable {
    /// The sRGB table, computed on first use (a fraction of a second) and kept.
    pub fn srgb() -> &'static CoefficientTable {
        static T: OnceLock<CoefficientTable> = OnceLock::new();
        T.get_or_init(CoefficientTable::build)
    }

    /// The linear-sRGB colour of node (l, zi, yi, xi).
    pub fn node_rgb(&self, l: usize, zi: usize, yi: usize, xi: usize) -> [f64; 3] {
        let z = self.z[zi];
        let n = (TABLE_RES - 1) as f64;
        let mut rgb = [0.0; 3];
        rgb[l] = z;
        rgb[(l + 1) % 3] = xi as f64 / n * z;
        rgb[(l + 2) % 3] = yi as f64 / n * z;
        rgb
    }

    /// The stored coefficients of node (l, zi, yi, xi).
    pub fn node_coeffs(&self, l: usize, zi: usize, yi: usize, xi: usize) -> [f64; 3] {
        self.coeffs[((l * TABLE_RES + zi) * TABLE_RES + yi) * TABLE_RES + xi]
    }

    /// Fits every node.
    pub fn build() -> CoefficientTable {
        use rayon::prelude::*;
        let r = TABLE_RES;
        let z: Vec<f64> = (0..r).map(z_node).collect();
        let shell = CoefficientTable { z: z.clone(), coeffs: Vec::new() };
        // One job per (l, yi, xi) column; along z, each node starts from the previous one,
        // sweeping up and then down from a start a fifth of the way up (as in rgb2spec_opt).
        let columns: Vec<Vec<[f64; 3]>> = (0..3 * r * r)
            .into_par_iter()
            .map(|job| {
                let (l, yi, xi) = (job / (r * r), (job / r) % r, job % r);
                let mut col = vec![[0.0; 3]; r];
                let start = r / 5;
                let first = fit_sigmoid(shell.node_rgb(l, start, yi, xi));
                col[start] = first;
                let mut c = first;
                for zi in start + 1..r {
                    c = refine_sigmoid(c, shell.node_rgb(l, zi, yi, xi));
                    col[zi] = c;
                }
                c = first;
                for zi in (0..start).rev() {
                    c = refine_sigmoid(c, shell.node_rgb(l, zi, yi, xi));
                    col[zi] = c;
                }
                col
            })
            .collect();
        let mut coeffs = vec![[0.0; 3]; 3 * r * r * r];
        for (job, col) in columns.into_iter().enumerate() {
            let (l, yi, xi) = (job / (r * r), (job / r) % r, job % r);
            for (zi, c) in col.into_iter().enumerate() {
                coeffs[((l * r + zi) * r + yi) * r + xi] = c;
            }
        }
        CoefficientTable { z, coeffs }
    }

    /// Trilinearly interpolated coefficients for `rgb` ∈ [0, 1]³ (a starting point; see
    /// [`reflectance_coeffs`] for the refined value).
    pub fn lookup(&self, rgb: [f64; 3]) -> [f64; 3] {
        let rgb = rgb.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) });
        let l = if rgb[0] >= rgb[1] && rgb[0] >= rgb[2] {
            0
        } else if rgb[1] >= rgb[2] {
            1
        } else {
            2
        };
        let zv = rgb[l];
        if zv <= 0.0 {
            return self.node_coeffs(l, 0, 0, 0);
        }
        let n = (TABLE_RES - 1) as f64;
        let x = rgb[(l + 1) % 3] / zv * n;
        let y = rgb[(l + 2) % 3] / zv * n;
        let zi = self.z.partition_point(|&s| s <= zv).clamp(1, TABLE_RES - 1) - 1;
        let fz = ((zv - self.z[zi]) / (self.z[zi + 1] - self.z[zi])).clamp(0.0, 1.0);
        let xi = (x.floor() as usize).min(TABLE_RES - 2);
        let yi = (y.floor() as usize).min(TABLE_RES - 2);
        let (fx, fy) = (x - xi as f64, y - yi as f64);
        let mut out = [0.0; 3];
        for (dz, wz) in [(0, 1.0 - fz), (1, fz)] {
            for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
                for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                    let c = self.node_coeffs(l, zi + dz, yi + dy, xi + dx);
                    let w = wz * wy * wx;
                    for k in 0..3 {
                        out[k] += w * c[k];
                    }
                }
            }
        }
        out
    }
}

/// How a colour's sigmoid coefficients are found: refined from the trilinear [`CoefficientTable`]
/// lookup, or fitted from a grey start by the homotopy alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fit {
    Table,
    Direct,
}

/// A spectrum `scale · s(c₀t² + c₁t + c₂)`: a reflectance (in [0, 1]), or the shape of an
/// illuminant before its D65 factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigmoidSpectrum {
    /// Polynomial coefficients of the normalised wavelength t = (λ − 360 nm)/(470 nm).
    pub coeffs: [f64; 3],
    /// Multiplier (2g for a grey g, whose coefficients are 0 and s(0) = ½).
    pub scale: f64,
}

impl SigmoidSpectrum {
    /// The bounded reflectance with linear-sRGB colour `rgb` under D65 (components clamped to
    /// [0, 1], NaN → 0). Greys are exact constants.
    pub fn reflectance(rgb: [f64; 3]) -> SigmoidSpectrum {
        Self::reflectance_by(rgb, Fit::Table)
    }

    /// [`SigmoidSpectrum::reflectance`] or its untabulated fit (`Fit::Direct`: the homotopy of
    /// [`crate::spectrum::RgbAlbedo`], about a millisecond a colour, where building the table
    /// takes about a second of one core: the cheaper route for a few hundred colours). Both
    /// solve the same equations to the same tolerance.
    pub fn reflectance_by(rgb: [f64; 3], fit: Fit) -> SigmoidSpectrum {
        let c = rgb.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) });
        if c[0] == c[1] && c[1] == c[2] {
            return SigmoidSpectrum { coeffs: [0.0; 3], scale: 2.0 * c[0] };
        }
        let coeffs = match fit {
            Fit::Table => refine_sigmoid(CoefficientTable::srgb().lookup(c), c),
            Fit::Direct => fit_sigmoid(c),
        };
        SigmoidSpectrum { coeffs, scale: 1.0 }
    }

    /// The shape of the illuminant with linear-sRGB colour `rgb` (components ≥ 0; negatives and
    /// NaN → 0): scale = 2·max(rgb) times the reflectance of rgb/scale. Multiplied by
    /// [`crate::spectrum::d65_normalized`] it is the emission spectrum.
    pub fn illuminant(rgb: [f64; 3]) -> SigmoidSpectrum {
        Self::illuminant_by(rgb, Fit::Table)
    }

    /// [`SigmoidSpectrum::illuminant`] with the reflectance fitted as `fit` says
    /// ([`SigmoidSpectrum::reflectance_by`]).
    pub fn illuminant_by(rgb: [f64; 3], fit: Fit) -> SigmoidSpectrum {
        let c = rgb.map(|v| if v.is_nan() || v < 0.0 { 0.0 } else { v });
        let m = c[0].max(c[1]).max(c[2]);
        if !(m > 0.0) || !m.is_finite() {
            return SigmoidSpectrum { coeffs: [0.0; 3], scale: 0.0 };
        }
        let s = 2.0 * m;
        let r = SigmoidSpectrum::reflectance_by(c.map(|v| v / s), fit);
        SigmoidSpectrum { coeffs: r.coeffs, scale: s * r.scale }
    }

    /// Value at `lambda_nm`.
    #[inline]
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        self.scale * sigmoid_polynomial(self.coeffs, lambda_nm)
    }
}

/// Refined coefficients of the reflectance with colour `rgb` ∈ [0, 1]³ (non-grey), from the table.
pub fn reflectance_coeffs(rgb: [f64; 3]) -> [f64; 3] {
    refine_sigmoid(CoefficientTable::srgb().lookup(rgb), rgb)
}
