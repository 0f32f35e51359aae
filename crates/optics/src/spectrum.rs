//! Spectra: tabulated (piecewise linear, zero outside their range), constant, blackbody
//! (Planck's law), RGB albedos uplifted to reflectance spectra that never exceed 1, and RGB
//! illuminants (2·max(rgb) × uplift of rgb/(2·max) × CIE D65). Wavelengths of spectra are in nanometres.
//!
//! The RGB uplift follows the idea of Jakob & Hanika, "A Low-Dimensional Function Space for
//! Efficient Spectral Upsampling", Computer Graphics Forum 38(2), 2019: a reflectance is the
//! logistic sigmoid of a quadratic polynomial in wavelength, s(λ) = ½ + x/(2√(1+x²)),
//! x = c₀t² + c₁t + c₂, which lies in (0, 1) for every real coefficient triple, so the bound
//! ρ(λ) ≤ 1 holds by construction. The coefficients are fitted here (not tabulated) by a damped
//! Gauss–Newton solve so that the reflectance lit by D65 reproduces the requested linear-sRGB
//! colour. Grey inputs (r = g = b) give exactly the constant spectrum r.

// NaN-rejecting comparisons (`!(x > 0.0)`) are deliberate.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use anyhow::{bail, Context, Result};
use std::sync::OnceLock;

pub use crate::color::{LAMBDA_MAX_NM, LAMBDA_MIN_NM, N_DENSE};
pub use crate::csv::read_csv_columns;

/// Planck constant h (J·s), exact since SI 2019.
pub const PLANCK_H: f64 = 6.626_070_15e-34;
/// Speed of light in vacuum c (m/s), exact.
pub const SPEED_OF_LIGHT: f64 = 299_792_458.0;
/// Boltzmann constant k_B (J/K), exact since SI 2019.
pub const BOLTZMANN_K: f64 = 1.380_649e-23;
/// Wien's displacement constant b (m·K), CODATA 2018: λ_max·T = b.
pub const WIEN_B_M_K: f64 = 2.897_771_955e-3;

/// A spectrum tabulated at increasing wavelengths, linearly interpolated, ZERO outside its range.
#[derive(Clone, Debug, PartialEq)]
pub struct Tabulated {
    lambda_nm: Vec<f64>,
    values: Vec<f64>,
}

impl Tabulated {
    /// Builds a tabulated spectrum; wavelengths must be finite and strictly increasing, values finite.
    pub fn new(lambda_nm: Vec<f64>, values: Vec<f64>) -> Result<Self> {
        if lambda_nm.len() != values.len() {
            bail!(
                "tabulated spectrum: {} wavelengths but {} values",
                lambda_nm.len(),
                values.len()
            );
        }
        if lambda_nm.is_empty() {
            bail!("tabulated spectrum: no samples");
        }
        for (i, (&l, &v)) in lambda_nm.iter().zip(&values).enumerate() {
            if !l.is_finite() || !v.is_finite() {
                bail!("tabulated spectrum: sample {i} is not finite (lambda_nm {l}, value {v})");
            }
            if l <= 0.0 {
                bail!("tabulated spectrum: sample {i}: wavelength {} nm is not positive", crate::numfmt::short(l));
            }
            if i > 0 && l <= lambda_nm[i - 1] {
                bail!(
                    "tabulated spectrum: wavelengths must increase strictly (sample {i}: {l} nm after {} nm)",
                    lambda_nm[i - 1]
                );
            }
        }
        Ok(Tabulated { lambda_nm, values })
    }

    /// Reads column `value_column` (name from the header row) against the first column (nm) of a CSV text.
    pub fn from_csv(text: &str, value_column: &str) -> Result<Self> {
        let (names, cols) = read_csv_columns(text)?;
        let idx = names
            .iter()
            .position(|n| n == value_column)
            .with_context(|| {
                format!(
                    "CSV has no column '{value_column}' (columns: {})",
                    names.join(", ")
                )
            })?;
        if idx == 0 {
            bail!("CSV column '{value_column}' is the wavelength column");
        }
        Tabulated::new(cols[0].clone(), cols[idx].clone())
    }

    /// The value at `lambda_nm` (linear interpolation), 0 outside the tabulated range.
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        let l = &self.lambda_nm;
        let n = l.len();
        if !(lambda_nm >= l[0] && lambda_nm <= l[n - 1]) {
            return 0.0;
        }
        if n == 1 {
            return self.values[0];
        }
        // First index with l[i] > lambda, clamped so that [i-1, i] is a valid interval.
        let i = l.partition_point(|&x| x <= lambda_nm).clamp(1, n - 1);
        let (l0, l1) = (l[i - 1], l[i]);
        let t = (lambda_nm - l0) / (l1 - l0);
        self.values[i - 1] * (1.0 - t) + self.values[i] * t
    }

    /// Tabulated wavelengths (nm).
    pub fn lambda_nm(&self) -> &[f64] {
        &self.lambda_nm
    }

    /// Tabulated values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }
}

/// Planck's law: spectral radiance of a blackbody, W·m⁻²·sr⁻¹·m⁻¹ (per metre of wavelength),
/// B(λ, T) = 2hc²/λ⁵ / (exp(hc/(λ k T)) − 1). Returns 0 for λ ≤ 0 or T ≤ 0.
pub fn planck_radiance(lambda_m: f64, temperature_k: f64) -> f64 {
    if !(lambda_m > 0.0) || !(temperature_k > 0.0) {
        return 0.0;
    }
    let c1 = 2.0 * PLANCK_H * SPEED_OF_LIGHT * SPEED_OF_LIGHT;
    let x = PLANCK_H * SPEED_OF_LIGHT / (lambda_m * BOLTZMANN_K * temperature_k);
    let l5 = lambda_m.powi(5);
    c1 / (l5 * x.exp_m1())
}

/// Blackbody spectral radiance normalised to 1 at its peak wavelength λ_max = b/T (Wien).
pub fn planck_normalized(lambda_nm: f64, temperature_k: f64) -> f64 {
    if !(temperature_k > 0.0) {
        return 0.0;
    }
    let peak = planck_radiance(WIEN_B_M_K / temperature_k, temperature_k);
    planck_radiance(lambda_nm * 1e-9, temperature_k) / peak
}

/// A spectrum in any of the forms the scenes and materials use.
#[derive(Clone, Debug)]
pub enum Spectrum {
    /// The same value at every wavelength.
    Constant(f64),
    /// Piecewise linear table, zero outside its range.
    Tabulated(Tabulated),
    /// Planck blackbody at `temperature_k`, normalised to peak 1, times `scale`.
    Blackbody {
        /// Temperature (K).
        temperature_k: f64,
        /// Multiplier of the peak-normalised spectrum.
        scale: f64,
    },
    /// Reflectance uplifted from linear sRGB; within [0, 1] at every wavelength.
    RgbAlbedo(RgbAlbedo),
    /// Emission uplifted from linear sRGB: reflectance-like shape × normalised D65 × scale.
    RgbIlluminant(RgbIlluminant),
}

impl Spectrum {
    /// Value at `lambda_nm`.
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::Tabulated(t) => t.eval(lambda_nm),
            Spectrum::Blackbody {
                temperature_k,
                scale,
            } => scale * planck_normalized(lambda_nm, *temperature_k),
            Spectrum::RgbAlbedo(a) => a.eval(lambda_nm),
            Spectrum::RgbIlluminant(i) => i.eval(lambda_nm),
        }
    }

    /// Samples the spectrum at 1 nm for fast lookups.
    pub fn to_dense(&self) -> DenseSpectrum {
        DenseSpectrum::from_fn(|l| self.eval(l))
    }
}

/// A spectrum sampled every 1 nm from 360 to 830 nm inclusive, as f32, for the renderer's inner loops.
#[derive(Clone, Debug, PartialEq)]
pub struct DenseSpectrum {
    samples: Box<[f32; N_DENSE]>,
}

impl DenseSpectrum {
    /// Samples `f(lambda_nm)` at 360, 361, …, 830 nm.
    pub fn from_fn(f: impl Fn(f64) -> f64) -> Self {
        let mut samples = Box::new([0.0f32; N_DENSE]);
        for (i, s) in samples.iter_mut().enumerate() {
            *s = f(LAMBDA_MIN_NM + i as f64) as f32;
        }
        DenseSpectrum { samples }
    }

    /// Linear interpolation between the 1-nm samples; 0 outside [360, 830] nm.
    #[inline]
    pub fn eval(&self, lambda_nm: f32) -> f32 {
        let x = lambda_nm - LAMBDA_MIN_NM as f32;
        if !(x >= 0.0 && x <= (N_DENSE - 1) as f32) {
            return 0.0;
        }
        let i = (x as usize).min(N_DENSE - 2);
        let t = x - i as f32;
        self.samples[i] * (1.0 - t) + self.samples[i + 1] * t
    }

    /// The 1-nm samples (index i ↔ 360 + i nm).
    pub fn samples(&self) -> &[f32] {
        &self.samples[..]
    }

    /// Largest sample.
    pub fn max_value(&self) -> f32 {
        self.samples
            .iter()
            .copied()
            .fold(f32::NEG_INFINITY, f32::max)
    }
}

// ---------------------------------------------------------------------------------------------
// RGB uplift
// ---------------------------------------------------------------------------------------------

/// Sigmoid s(x) = ½ + x / (2√(1 + x²)), strictly inside (0, 1) for every finite x.
#[inline]
fn sigmoid(x: f64) -> f64 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// Normalised wavelength t ∈ [0, 1] over the visible range used by the polynomial.
#[inline]
fn t_of(lambda_nm: f64) -> f64 {
    (lambda_nm - LAMBDA_MIN_NM) / (LAMBDA_MAX_NM - LAMBDA_MIN_NM)
}

/// A reflectance spectrum from linear sRGB (D65 white) with ρ(λ) ∈ [0, 1] at every wavelength.
/// Either a constant (grey input) or `sigmoid(c0 t² + c1 t + c2)`, t = (λ − 360)/(830 − 360).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbAlbedo {
    /// Polynomial coefficients (c0, c1, c2) of the sigmoid argument; unused when `constant` is Some.
    coeffs: [f64; 3],
    /// Exact constant for grey inputs.
    constant: Option<f64>,
}

impl RgbAlbedo {
    /// Fits the reflectance to linear sRGB `rgb`; components are clamped to [0, 1] (NaN → 0).
    pub fn new(rgb: [f64; 3]) -> Self {
        let c = rgb.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) });
        if c[0] == c[1] && c[1] == c[2] {
            return RgbAlbedo {
                coeffs: [0.0; 3],
                constant: Some(c[0]),
            };
        }
        RgbAlbedo {
            coeffs: fit_sigmoid(c),
            constant: None,
        }
    }

    /// Reflectance at `lambda_nm`, in [0, 1].
    #[inline]
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        if let Some(c) = self.constant {
            return c;
        }
        let t = t_of(lambda_nm);
        let [c0, c1, c2] = self.coeffs;
        sigmoid((c0 * t + c1) * t + c2)
    }

    /// The linear sRGB colour of this reflectance lit by (normalised) D65, as the renderer will see it.
    pub fn linear_srgb(&self) -> [f64; 3] {
        reflectance_to_linear_srgb(|l| self.eval(l))
    }
}

/// An emission spectrum from linear sRGB: `scale · ρ(λ) · D65(λ)/Y(D65)`, where ρ is the uplift of
/// rgb / scale, scale = 2·max(r, g, b), as pbrt-v4's `RGBIlluminantSpectrum` and Mitsuba 3's
/// emitter spectra do it (Jakob & Hanika 2019): the shape's largest component is ½, far from the
/// saturated reflectances whose spectra are nearly boxes. RGB (1, 1, 1) is exactly D65 with
/// luminance Y = 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbIlluminant {
    shape: RgbAlbedo,
    scale: f64,
}

impl RgbIlluminant {
    /// Emission with linear-sRGB colour `rgb` (components ≥ 0; negatives and NaN become 0).
    pub fn new(rgb: [f64; 3]) -> Self {
        let c = rgb.map(|v| if v.is_nan() || v < 0.0 { 0.0 } else { v });
        let scale = 2.0 * c[0].max(c[1]).max(c[2]);
        if !(scale > 0.0) || !scale.is_finite() {
            return RgbIlluminant {
                shape: RgbAlbedo::new([0.0; 3]),
                scale: 0.0,
            };
        }
        RgbIlluminant {
            shape: RgbAlbedo::new(c.map(|v| v / scale)),
            scale,
        }
    }

    /// Spectral radiance (relative) at `lambda_nm`.
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        if self.scale == 0.0 {
            return 0.0;
        }
        self.scale * self.shape.eval(lambda_nm) * d65_normalized(lambda_nm)
    }
}

/// CIE standard illuminant D65 (relative SPD, 300–780 nm, 5 nm; 0 outside), scaled so its
/// luminance Y (pbrt/Mitsuba convention, ∫S ȳ dλ / ∫ȳ dλ) is exactly 1.
pub fn d65_normalized(lambda_nm: f64) -> f64 {
    let (t, y) = d65_table();
    t.eval(lambda_nm) / y
}

/// CIE D65 relative SPD as tabulated by the CIE (100 at 560 nm), 0 outside 300–780 nm.
pub fn d65_relative(lambda_nm: f64) -> f64 {
    d65_table().0.eval(lambda_nm)
}

fn d65_table() -> &'static (Tabulated, f64) {
    static D65: OnceLock<(Tabulated, f64)> = OnceLock::new();
    D65.get_or_init(|| {
        let text = include_str!("../data/cie/cie_illuminant_d65_5nm.csv");
        let t = Tabulated::from_csv(text, "relative_power").expect("embedded D65 table is valid");
        let y = crate::color::spectrum_to_xyz(|l| t.eval(l))[1];
        (t, y)
    })
}

/// Linear sRGB of a reflectance lit by normalised D65 (so the constant 1 gives ≈ (1, 1, 1)).
pub fn reflectance_to_linear_srgb(rho: impl Fn(f64) -> f64) -> [f64; 3] {
    let w = rgb_weights();
    let mut rgb = [0.0; 3];
    for (i, wi) in w.iter().enumerate() {
        let r = rho(LAMBDA_MIN_NM + i as f64);
        for k in 0..3 {
            rgb[k] += wi[k] * r;
        }
    }
    rgb
}

/// Per-nm weights: linear-sRGB contribution of a unit reflectance at 360 + i nm under normalised D65.
fn rgb_weights() -> &'static [[f64; 3]] {
    static W: OnceLock<Vec<[f64; 3]>> = OnceLock::new();
    W.get_or_init(|| {
        (0..N_DENSE)
            .map(|i| {
                let l = LAMBDA_MIN_NM + i as f64;
                let bar = crate::color::cie_1931_xyz_bar(l);
                let s = d65_normalized(l) / crate::color::CIE_Y_INTEGRAL;
                crate::color::xyz_to_linear_srgb([bar[0] * s, bar[1] * s, bar[2] * s])
            })
            .collect()
    })
}

/// Normalised wavelengths t of the 1-nm grid 360…830 nm.
fn t_grid() -> &'static [f64] {
    static T: OnceLock<Vec<f64>> = OnceLock::new();
    T.get_or_init(|| (0..N_DENSE).map(|i| t_of(LAMBDA_MIN_NM + i as f64)).collect())
}

/// Residual rgb(c) − target of the sigmoid polynomial with coefficients `c` under D65, and its
/// Jacobian ∂rgb/∂c.
fn sigmoid_residual(c: [f64; 3], tgt: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let w = rgb_weights();
    let mut f = [0.0; 3];
    let mut j = [[0.0; 3]; 3];
    for (wi, &t) in w.iter().zip(t_grid()) {
        let x = (c[0] * t + c[1]) * t + c[2];
        let q = 1.0 + x * x;
        let s = 0.5 + x / (2.0 * q.sqrt());
        let ds = 0.5 / (q * q.sqrt()); // ds/dx
        let basis = [t * t, t, 1.0];
        for k in 0..3 {
            f[k] += wi[k] * s;
            for m in 0..3 {
                j[k][m] += wi[k] * ds * basis[m];
            }
        }
    }
    for k in 0..3 {
        f[k] -= tgt[k];
    }
    (f, j)
}

/// Levenberg–Marquardt iterations from `c` towards `tgt` until the squared residual is below
/// `tol` or `iters` steps are done; returns the coefficients and their squared residual.
fn sigmoid_lm(mut c: [f64; 3], tgt: [f64; 3], iters: usize, tol: f64) -> ([f64; 3], f64) {
    let mut lambda = 1e-3;
    let (mut f, mut j) = sigmoid_residual(c, tgt);
    let mut err = f.iter().map(|v| v * v).sum::<f64>();
    for _ in 0..iters {
        if err < tol {
            break;
        }
        // Levenberg–Marquardt step: (JᵀJ + λ diag) δ = −Jᵀf.
        let mut jtj = [[0.0; 3]; 3];
        let mut jtf = [0.0; 3];
        for m in 0..3 {
            for n in 0..3 {
                jtj[m][n] = (0..3).map(|k| j[k][m] * j[k][n]).sum();
            }
            jtf[m] = (0..3).map(|k| j[k][m] * f[k]).sum();
        }
        let mut accepted = false;
        for _ in 0..12 {
            let mut a_m = jtj;
            for m in 0..3 {
                a_m[m][m] *= 1.0 + lambda;
                a_m[m][m] += 1e-12;
            }
            let Some(delta) = solve3(a_m, jtf.map(|v| -v)) else {
                lambda *= 10.0;
                continue;
            };
            let cn = [c[0] + delta[0], c[1] + delta[1], c[2] + delta[2]];
            let (fnew, jnew) = sigmoid_residual(cn, tgt);
            let en = fnew.iter().map(|v| v * v).sum::<f64>();
            if en.is_finite() && en < err {
                c = cn;
                f = fnew;
                j = jnew;
                err = en;
                lambda = (lambda * 0.3).max(1e-9);
                accepted = true;
                break;
            }
            lambda *= 10.0;
        }
        if !accepted {
            break;
        }
    }
    (c, err)
}

/// Damped Gauss–Newton fit of sigmoid-polynomial coefficients so the reflectance's linear sRGB
/// under D65 equals `target`. Starts from a grey of the mean and continues towards the target
/// in steps (homotopy), which keeps each solve in its basin of convergence.
pub(crate) fn fit_sigmoid(target: [f64; 3]) -> [f64; 3] {
    let mean = (target[0] + target[1] + target[2]) / 3.0;
    let mean = mean.clamp(1e-4, 1.0 - 1e-4);
    // Grey start: sigmoid(c2) = mean ⇒ c2 = (2m − 1)/(2√(m(1−m))).
    let mut c = [
        0.0,
        0.0,
        (2.0 * mean - 1.0) / (2.0 * (mean * (1.0 - mean)).sqrt()),
    ];
    let grey = [mean; 3];
    const STEPS: usize = 8;
    for step in 1..=STEPS {
        let a = step as f64 / STEPS as f64;
        let tgt = [0, 1, 2].map(|k| grey[k] + a * (target[k] - grey[k]));
        let iters = if step == STEPS { 60 } else { 15 };
        let tol = if step == STEPS { 1e-24 } else { 1e-10 };
        c = sigmoid_lm(c, tgt, iters, tol).0;
    }
    c
}

/// Refines coefficients `start` (e.g. from a table) to reproduce `target`; falls back to the
/// homotopy fit [`fit_sigmoid`] when the refinement does not converge.
pub(crate) fn refine_sigmoid(start: [f64; 3], target: [f64; 3]) -> [f64; 3] {
    let (c, err) = sigmoid_lm(start, target, 30, 1e-20);
    if err < 1e-14 {
        return c;
    }
    let c2 = fit_sigmoid(target);
    let e2 = sigmoid_residual(c2, target).0.iter().map(|v| v * v).sum::<f64>();
    if e2 < err {
        c2
    } else {
        c
    }
}

/// The sigmoid polynomial of Jakob & Hanika (2019) at `lambda_nm` for coefficients `c` of the
/// normalised wavelength t = (λ − 360 nm)/(830 nm − 360 nm): s(c₀t² + c₁t + c₂), in [0, 1].
#[inline]
pub fn sigmoid_polynomial(c: [f64; 3], lambda_nm: f64) -> f64 {
    let t = t_of(lambda_nm);
    sigmoid((c[0] * t + c[1]) * t + c[2])
}

/// Solves a 3×3 linear system by Cramer's rule; None when singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if !(d.abs() > 1e-300) || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for col in 0..3 {
        let mut m = a;
        for row in 0..3 {
            m[row][col] = b[row];
        }
        x[col] = det(m) / d;
    }
    if x.iter().all(|v| v.is_finite()) {
        Some(x)
    } else {
        None
    }
}
