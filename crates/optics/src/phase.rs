//! Phase functions of participating media: Henyey–Greenstein and tabulated (e.g. from Mie
//! theory), with evaluation per steradian and exact importance sampling.
//!
//! Convention: θ is the scattering angle between the propagation direction *before* and
//! *after* scattering, so cos θ = 1 is forward scattering and the mean cosine is g.
//! Phase functions are normalised over the sphere: ∫ p dω = 2π ∫₋₁¹ p(μ) dμ = 1 (unit sr⁻¹).

use anyhow::{bail, Result};
use std::f64::consts::PI;

/// Henyey–Greenstein phase function with asymmetry parameter `g` in (−1, 1) (dimensionless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    /// Mean cosine of the scattering angle, −1 < g < 1.
    pub g: f64,
}

impl HenyeyGreenstein {
    /// Phase function value in sr⁻¹: (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}).
    pub fn eval(&self, cos_theta: f64) -> f64 {
        let g = self.g;
        let denom = 1.0 + g * g - 2.0 * g * cos_theta;
        (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
    }

    /// Exact inverse of the cumulative distribution of cos θ: maps `u` uniform in [0, 1]
    /// to cos θ in [−1, 1] distributed with density 2π·p(cos θ). Monotonically increasing in u.
    pub fn sample_cos_theta(&self, u: f64) -> f64 {
        let g = self.g;
        if g.abs() < 1e-4 {
            // Isotropic limit (the general formula loses precision as g → 0).
            return (2.0 * u - 1.0).clamp(-1.0, 1.0);
        }
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    }
}

/// A phase function tabulated on a grid of cos θ, piecewise linear in cos θ between the
/// samples, renormalised so that 2π∫p dμ = 1; importance sampled exactly by inverting its
/// piecewise-quadratic cumulative distribution.
#[derive(Clone, Debug)]
pub struct TabulatedPhase {
    /// Strictly increasing grid of cos θ from −1 to 1 (dimensionless).
    cos_theta: Vec<f64>,
    /// Normalised phase function at the grid points (sr⁻¹).
    value_per_sr: Vec<f64>,
    /// Cumulative distribution of cos θ at the grid points (0 … 1).
    cdf: Vec<f64>,
    /// Mean cosine of the tabulated function (dimensionless).
    g: f64,
}

impl TabulatedPhase {
    /// Build from samples `value` (any positive scale; renormalised) at `cos_theta`, which must
    /// be strictly increasing, start at −1 and end at 1. Errors name the offending entry.
    pub fn new(cos_theta: Vec<f64>, value: Vec<f64>) -> Result<Self> {
        if cos_theta.len() != value.len() {
            bail!("tabulated phase function: {} angles but {} values", cos_theta.len(), value.len());
        }
        if cos_theta.len() < 2 {
            bail!("tabulated phase function: needs at least 2 samples");
        }
        if (cos_theta[0] + 1.0).abs() > 1e-9 || (cos_theta[cos_theta.len() - 1] - 1.0).abs() > 1e-9 {
            bail!("tabulated phase function: cos_theta must run from -1 to 1");
        }
        for (i, w) in cos_theta.windows(2).enumerate() {
            if !(w[1] > w[0]) {
                bail!("tabulated phase function: cos_theta not strictly increasing at entry {}", i + 1);
            }
        }
        for (i, v) in value.iter().enumerate() {
            if !v.is_finite() || *v < 0.0 {
                bail!("tabulated phase function: value {} at entry {i} is negative or not finite", v);
            }
        }
        // Trapezoid integral of the piecewise-linear function (exact for it).
        let mut cdf = Vec::with_capacity(value.len());
        cdf.push(0.0);
        let mut total = 0.0;
        let mut first_moment = 0.0;
        for i in 0..value.len() - 1 {
            let (x0, x1) = (cos_theta[i], cos_theta[i + 1]);
            let (y0, y1) = (value[i], value[i + 1]);
            let h = x1 - x0;
            total += 0.5 * h * (y0 + y1);
            // ∫ x·(linear) dx over the segment, exactly.
            first_moment += h * (y0 * (2.0 * x0 + x1) + y1 * (x0 + 2.0 * x1)) / 6.0;
            cdf.push(total);
        }
        if !(total > 0.0) {
            bail!("tabulated phase function: integrates to zero");
        }
        for c in cdf.iter_mut() {
            *c /= total;
        }
        let scale = 1.0 / (2.0 * PI * total);
        Ok(Self {
            value_per_sr: value.iter().map(|v| v * scale).collect(),
            cos_theta,
            cdf,
            g: first_moment / total,
        })
    }

    /// Tabulate any phase function `p(cos θ)` on `n` points uniformly spaced in cos θ.
    pub fn from_fn(n: usize, p: impl Fn(f64) -> f64) -> Result<Self> {
        let n = n.max(2);
        let mu: Vec<f64> = (0..n).map(|i| -1.0 + 2.0 * i as f64 / (n - 1) as f64).collect();
        let v = mu.iter().map(|&m| p(m)).collect();
        Self::new(mu, v)
    }

    /// Mean cosine ⟨cos θ⟩ of the (piecewise-linear) tabulated function.
    pub fn g(&self) -> f64 {
        self.g
    }

    /// Phase function value in sr⁻¹ (linear interpolation in cos θ).
    pub fn eval(&self, cos_theta: f64) -> f64 {
        let x = cos_theta.clamp(-1.0, 1.0);
        let i = self.segment(x);
        let (x0, x1) = (self.cos_theta[i], self.cos_theta[i + 1]);
        let t = (x - x0) / (x1 - x0);
        self.value_per_sr[i] * (1.0 - t) + self.value_per_sr[i + 1] * t
    }

    /// Sample cos θ from `u` uniform in [0, 1] with density 2π·p(cos θ) (exact inverse CDF).
    pub fn sample_cos_theta(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        // Segment i with cdf[i] ≤ u < cdf[i+1].
        let i = match self.cdf.partition_point(|&c| c <= u) {
            0 => 0,
            k => (k - 1).min(self.cdf.len() - 2),
        };
        let (x0, x1) = (self.cos_theta[i], self.cos_theta[i + 1]);
        let h = x1 - x0;
        // Density in this segment, normalised to the whole: q(t) = a + (b − a) t, t ∈ [0, 1].
        let norm = 2.0 * PI;
        let a = self.value_per_sr[i] * norm * h;
        let b = self.value_per_sr[i + 1] * norm * h;
        let target = u - self.cdf[i]; // = a t + (b − a) t²/2
        let t = if (b - a).abs() < 1e-12 * (a + b).max(1e-300) {
            if a > 0.0 { target / a } else { 0.5 }
        } else {
            // Solve (b−a)/2 t² + a t − target = 0, numerically stable root.
            let qa = 0.5 * (b - a);
            let disc = (a * a + 4.0 * qa * target).max(0.0);
            2.0 * target / (a + disc.sqrt())
        };
        (x0 + t.clamp(0.0, 1.0) * h).clamp(-1.0, 1.0)
    }

    fn segment(&self, x: f64) -> usize {
        let k = self.cos_theta.partition_point(|&c| c <= x);
        k.saturating_sub(1).min(self.cos_theta.len() - 2)
    }
}
