//! Particle size distributions and their discretisation into radius bins scaled to a volume fraction.
//!
//! Scaling as in the tutorial (Frisvad et al. 2007): for a representative number density N̂(r),
//! v̂ = (4π/3)∫r³N̂(r)dr and N = N̂·v/v̂ for the desired volume fraction v.
//! The log-normal distributions of Frisvad et al. 2007 give volume weights p(r) (their code
//! normalises p(r_i) over the bins and treats it as the volume fraction in each bin), i.e.
//! N̂(r) = p(r)/r³.

use anyhow::{bail, Result};
use std::f64::consts::PI;

/// A size distribution of spherical particles.
#[derive(Clone, Debug, PartialEq)]
pub enum SizeDistribution {
    /// Log-normal of Frisvad et al. 2007 given by the volume-to-surface mean radius `r_vs_m` and the
    /// standard deviation `c_s_m`: β² = ln(c_s²/r_vs² + 1), α = ln r_vs − β²/2,
    /// p(r) = exp(−(ln r − α)²/(2β²))/(rβ√(2π)), used as volume weights.
    LogNormal {
        /// Volume-to-surface mean radius, m.
        r_vs_m: f64,
        /// Standard deviation, m.
        c_s_m: f64,
    },
    /// Log-normal (as above, volume weights) in the transformed variable t = r/(r_max − r),
    /// used by Frisvad et al. 2007 for casein micelles (r_vs = 43 nm, c_s = 0.23 in t, r_max = 150 nm).
    BoundedLogNormal {
        /// Volume-to-surface mean radius, m (transformed to t before use).
        r_vs_m: f64,
        /// Standard deviation in the transformed (dimensionless) variable t.
        c_s_t: f64,
        /// Upper bound of the radius, m.
        r_max_m: f64,
    },
    /// Tabulated number density N̂(r) (any scale), piecewise linear in r, zero outside the table.
    Tabulated {
        /// Radii, m, increasing.
        radius_m: Vec<f64>,
        /// Relative number density at those radii (≥ 0).
        number_density: Vec<f64>,
    },
    /// All particles of one radius.
    Monodisperse {
        /// Radius, m.
        radius_m: f64,
    },
}

/// Spacing of radius bins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spacing {
    /// Equal widths in r (midpoint rule).
    Linear,
    /// Equal widths in ln r (midpoint rule in ln r).
    Log,
}

/// Radius interval [r_min, r_max] split into `bins` bins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusGrid {
    /// Smallest radius, m.
    pub r_min_m: f64,
    /// Largest radius, m.
    pub r_max_m: f64,
    /// Number of bins.
    pub bins: usize,
    /// Spacing of the bins.
    pub spacing: Spacing,
}

/// Discretised distribution: bin radii and the number of particles per unit volume in each bin.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bins {
    /// Bin radii, m.
    pub radius_m: Vec<f64>,
    /// N(r_i)·Δr_i: particles per m³ in bin i.
    pub number_per_m3: Vec<f64>,
}

impl Bins {
    /// Volume fraction (4π/3)Σr³N of these bins.
    pub fn volume_fraction(&self) -> f64 {
        self.radius_m.iter().zip(&self.number_per_m3).map(|(r, n)| 4.0 / 3.0 * PI * r * r * r * n).sum()
    }
    /// Volume-to-surface mean radius Σr³N/Σr²N, m.
    pub fn r_vs_m(&self) -> f64 {
        let (mut v, mut s) = (0.0, 0.0);
        for (r, n) in self.radius_m.iter().zip(&self.number_per_m3) {
            v += r * r * r * n;
            s += r * r * n;
        }
        v / s
    }
    /// Build bins from radii and relative *volume* weights (normalised here), scaled to `volume_fraction`.
    pub fn from_volume_weights(radius_m: &[f64], weights: &[f64], volume_fraction: f64) -> Result<Bins> {
        let total: f64 = weights.iter().sum();
        if total.is_nan() || total <= 0.0 || !total.is_finite() {
            bail!("size distribution has no weight in the radius range");
        }
        let mut out = Bins::default();
        for (&r, &w) in radius_m.iter().zip(weights) {
            if w > 0.0 {
                out.radius_m.push(r);
                out.number_per_m3.push(volume_fraction * (w / total) * 3.0 / (4.0 * PI * r * r * r));
            }
        }
        Ok(out)
    }
    /// Drop bins that carry less than `rel` of the total volume (their effect on σ is below `rel`).
    pub fn prune(&mut self, rel: f64) {
        let v = self.volume_fraction();
        let keep: Vec<bool> = self
            .radius_m
            .iter()
            .zip(&self.number_per_m3)
            .map(|(r, n)| 4.0 / 3.0 * PI * r * r * r * n >= rel * v)
            .collect();
        let mut k = keep.iter();
        self.radius_m.retain(|_| *k.next().unwrap());
        let mut k = keep.iter();
        self.number_per_m3.retain(|_| *k.next().unwrap());
    }
}

fn lognormal_params(r_vs: f64, c_s: f64) -> (f64, f64) {
    let beta2 = (c_s * c_s / (r_vs * r_vs) + 1.0).ln();
    let alpha = r_vs.ln() - beta2 / 2.0;
    (alpha, beta2.sqrt())
}

fn lognormal_pdf(r: f64, alpha: f64, beta: f64) -> f64 {
    if r <= 0.0 {
        return 0.0;
    }
    let u = (r.ln() - alpha) / beta;
    (-0.5 * u * u).exp() / (r * beta * (2.0 * PI).sqrt())
}

impl SizeDistribution {
    /// Check parameters: positive, finite radii and spreads; a valid table.
    pub fn validate(&self) -> Result<()> {
        let pos = |v: f64, what: &str| -> Result<()> {
            if !(v.is_finite() && v > 0.0) {
                bail!("{what} must be a positive finite number, got {v}");
            }
            Ok(())
        };
        match self {
            SizeDistribution::LogNormal { r_vs_m, c_s_m } => {
                pos(*r_vs_m, "r_vs")?;
                pos(*c_s_m, "c_s")
            }
            SizeDistribution::BoundedLogNormal { r_vs_m, c_s_t, r_max_m } => {
                pos(*r_vs_m, "r_vs")?;
                pos(*c_s_t, "c_s")?;
                pos(*r_max_m, "r_max")?;
                if r_vs_m >= r_max_m {
                    bail!("r_vs must be below r_max");
                }
                Ok(())
            }
            SizeDistribution::Monodisperse { radius_m } => pos(*radius_m, "radius"),
            SizeDistribution::Tabulated { radius_m, number_density } => {
                if radius_m.len() != number_density.len() || radius_m.len() < 2 {
                    bail!("tabulated distribution needs radius and number_density of equal length ≥ 2");
                }
                for (i, (&r, &n)) in radius_m.iter().zip(number_density).enumerate() {
                    pos(r, &format!("radius[{i}]"))?;
                    if !(n.is_finite() && n >= 0.0) {
                        bail!("number_density[{i}] must be finite and ≥ 0, got {n}");
                    }
                    if i > 0 && r <= radius_m[i - 1] {
                        bail!("radius[{i}] must increase");
                    }
                }
                Ok(())
            }
        }
    }

    /// A grid that covers the distribution (±7 standard deviations in ln r, or the table), `bins` log-spaced bins.
    pub fn default_grid(&self, bins: usize) -> RadiusGrid {
        let (lo, hi) = match self {
            SizeDistribution::LogNormal { r_vs_m, c_s_m } => {
                let (a, b) = lognormal_params(*r_vs_m, *c_s_m);
                ((a - 7.0 * b).exp(), (a + 7.0 * b).exp())
            }
            SizeDistribution::BoundedLogNormal { r_max_m, .. } => (r_max_m * 1e-4, *r_max_m),
            SizeDistribution::Tabulated { radius_m, .. } => (radius_m[0], radius_m[radius_m.len() - 1]),
            SizeDistribution::Monodisperse { radius_m } => (*radius_m, *radius_m),
        };
        RadiusGrid { r_min_m: lo, r_max_m: hi, bins, spacing: Spacing::Log }
    }

    /// Representative number density N̂(r) per unit radius (arbitrary scale).
    pub fn number_density(&self, r: f64) -> f64 {
        match self {
            SizeDistribution::LogNormal { r_vs_m, c_s_m } => {
                let (a, b) = lognormal_params(*r_vs_m, *c_s_m);
                lognormal_pdf(r, a, b) / (r * r * r)
            }
            SizeDistribution::BoundedLogNormal { r_vs_m, c_s_t, r_max_m } => {
                if r <= 0.0 || r >= *r_max_m {
                    return 0.0;
                }
                let t_vs = r_vs_m / (r_max_m - r_vs_m);
                let (a, b) = lognormal_params(t_vs, *c_s_t);
                lognormal_pdf(r / (r_max_m - r), a, b) / (r * r * r)
            }
            SizeDistribution::Tabulated { radius_m, number_density } => {
                if r < radius_m[0] || r > radius_m[radius_m.len() - 1] {
                    return 0.0;
                }
                let k = radius_m.partition_point(|&x| x <= r).clamp(1, radius_m.len() - 1);
                let (r0, r1) = (radius_m[k - 1], radius_m[k]);
                let f = (r - r0) / (r1 - r0);
                number_density[k - 1] * (1.0 - f) + number_density[k] * f
            }
            SizeDistribution::Monodisperse { .. } => 0.0,
        }
    }

    /// Discretise on `grid` (midpoint rule) and scale to `volume_fraction`: N = N̂·v/v̂.
    pub fn discretize(&self, grid: &RadiusGrid, volume_fraction: f64) -> Result<Bins> {
        self.validate()?;
        if !(volume_fraction.is_finite() && (0.0..=1.0).contains(&volume_fraction)) {
            bail!("volume fraction must lie in [0, 1], got {volume_fraction}");
        }
        if let SizeDistribution::Monodisperse { radius_m } = self {
            let r = *radius_m;
            return Ok(Bins { radius_m: vec![r], number_per_m3: vec![volume_fraction * 3.0 / (4.0 * PI * r * r * r)] });
        }
        if !(grid.r_min_m >= 0.0 && grid.r_max_m > grid.r_min_m && grid.bins > 0 && grid.r_max_m.is_finite()) {
            bail!("radius grid must have 0 ≤ r_min < r_max and at least one bin");
        }
        if grid.spacing == Spacing::Log && grid.r_min_m <= 0.0 {
            bail!("log-spaced radius grid needs r_min > 0");
        }
        let n = grid.bins;
        let mut radius = Vec::with_capacity(n);
        let mut weight = Vec::with_capacity(n);
        for i in 0..n {
            let (r, dr) = match grid.spacing {
                Spacing::Linear => {
                    let dr = (grid.r_max_m - grid.r_min_m) / n as f64;
                    (grid.r_min_m + (i as f64 + 0.5) * dr, dr)
                }
                Spacing::Log => {
                    let dl = (grid.r_max_m / grid.r_min_m).ln() / n as f64;
                    let r = grid.r_min_m * ((i as f64 + 0.5) * dl).exp();
                    (r, r * dl)
                }
            };
            radius.push(r);
            // volume weight of the bin: r³ N̂(r) Δr
            weight.push(r * r * r * self.number_density(r) * dr);
        }
        Bins::from_volume_weights(&radius, &weight, volume_fraction)
    }
}
