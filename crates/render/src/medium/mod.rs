//! Participating media: spectral absorption and scattering coefficients and a phase function
//! (Henyey–Greenstein with a spectral g, or tabulated per wavelength from Mie theory), homogeneous
//! or scaled in space by a density grid ([`grid`]: σ(λ, x) = σ(λ) ρ(x)).
//!
//! Coefficients are stored per metre at 1-nm resolution ([`DenseSpectrum`]). A tabulated phase
//! function is kept at the wavelengths it was computed at (e.g. the Mie module's); at a wavelength
//! between two of them the phase function is the linear interpolation of the two neighbouring
//! tables, p(λ, μ) = (1 − t) p_k(μ) + t p_{k+1}(μ) (still normalised), held constant beyond the
//! ends. Sampling draws from the hero wavelength's (interpolated) phase function exactly — pick
//! table k or k+1 with probability 1 − t or t, then invert that table's CDF — and the integrator
//! weights the other wavelengths by p(λᵢ, μ)/p(λ₀, μ).
//!
//! Direction convention (as `optics::phase`): μ = cos θ between the propagation direction before
//! and after scattering.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod albedo;
pub mod convex;
pub mod grid;

use crate::math::sampling::Frame;
use crate::math::spectral::{SampledSpectrum, SampledWavelengths, N_LAMBDA};
use anyhow::{bail, Result};
use glam::{Vec2, Vec3, Vec4};
use optics::phase::TabulatedPhase;
use optics::spectrum::DenseSpectrum;
use std::f32::consts::PI;

/// The angular distribution of scattered light.
#[derive(Clone, Debug)]
pub enum PhaseModel {
    /// Henyey–Greenstein with asymmetry g(λ) ∈ (−1, 1).
    HenyeyGreenstein {
        /// Mean cosine per wavelength (dimensionless).
        g: DenseSpectrum,
    },
    /// Tabulated phase functions at a few wavelengths (strictly increasing), interpolated between them.
    Tabulated {
        /// Wavelengths of the tables, nm.
        lambda_nm: Vec<f32>,
        /// One normalised phase function per wavelength.
        tables: Vec<TabulatedPhase>,
        /// The tables' values on their common cos θ grid, when they share one (fast evaluation:
        /// one grid search for all wavelengths); `None` evaluates each table on its own.
        grid: Option<SharedGrid>,
    },
}

/// Phase-function tables sampled on one common, increasing grid of cos θ (values per sr, exactly
/// the tables' own piecewise-linear functions).
#[derive(Clone, Debug)]
pub struct SharedGrid {
    /// cos θ nodes, increasing from −1 to 1.
    mu: Vec<f32>,
    /// `values[k * mu.len() + j]`: table k at node j (sr⁻¹).
    values: Vec<f32>,
    /// `cdf[k * mu.len() + j]`: table k's probability of cos θ < mu[j] (0 at j = 0, 1 at the
    /// last node), accumulated in f64 from the piecewise-linear values.
    cdf: Vec<f32>,
    /// `guide[k * GUIDE + c]`: the last segment j of table k with cdf[j] ≤ c/GUIDE (the search
    /// for u ∈ [c/GUIDE, (c+1)/GUIDE) starts there).
    guide: Vec<u32>,
    /// `ends[k * mu.len() + j]`: segment j's end values scaled to mean 1, 2a/(a + b) and
    /// 2b/(a + b) (a, b: table k at nodes j and j + 1), for inverting the segment's linear
    /// density without divisions.
    ends: Vec<[f32; 2]>,
}

/// Cells of the guide table for inverting a shared-grid CDF.
const GUIDE: usize = 512;

impl PhaseModel {
    /// Tabulated model; `grid_mu` is the cos θ grid all tables were built on, if they share one.
    pub fn tabulated(lambda_nm: Vec<f32>, tables: Vec<TabulatedPhase>, grid_mu: Option<&[f64]>) -> PhaseModel {
        let grid = grid_mu.map(|mu| {
            let n = mu.len();
            let values: Vec<f32> = tables.iter().flat_map(|t| mu.iter().map(move |&m| t.eval(m) as f32)).collect();
            let mut cdf = Vec::with_capacity(values.len());
            let mut guide = Vec::with_capacity(tables.len() * GUIDE);
            for k in 0..tables.len() {
                let v = &values[k * n..(k + 1) * n];
                let mut acc = vec![0f64; n];
                for j in 1..n {
                    acc[j] = acc[j - 1] + 2.0 * std::f64::consts::PI * 0.5 * (v[j - 1] as f64 + v[j] as f64) * (mu[j] - mu[j - 1]);
                }
                let total = acc[n - 1];
                let c: Vec<f32> = acc.iter().enumerate().map(|(j, a)| if j + 1 == n { 1.0 } else { (a / total) as f32 }).collect();
                for cell in 0..GUIDE {
                    let u = cell as f32 / GUIDE as f32;
                    let j = c.partition_point(|&x| x <= u).saturating_sub(1).min(n - 2);
                    guide.push(j as u32);
                }
                cdf.extend_from_slice(&c);
            }
            let ends = values
                .iter()
                .enumerate()
                .map(|(i, &a)| {
                    let b = if (i + 1) % n == 0 { a } else { values[i + 1] };
                    [2.0 * a / (a + b), 2.0 * b / (a + b)]
                })
                .collect();
            SharedGrid { mu: mu.iter().map(|&m| m as f32).collect(), values, cdf, guide, ends }
        });
        PhaseModel::Tabulated { lambda_nm, tables, grid }
    }
}

/// A medium: σ_a(λ), σ_s(λ) and a phase function, the same everywhere or multiplied by a
/// density ρ(x) ([`grid::DensityGrid`]).
#[derive(Clone, Debug)]
pub struct Medium {
    /// Name for messages (the object or `medium`).
    pub name: String,
    /// Absorption coefficient σ_a, m⁻¹.
    pub sigma_a_per_m: DenseSpectrum,
    /// Scattering coefficient σ_s, m⁻¹.
    pub sigma_s_per_m: DenseSpectrum,
    /// Phase function.
    pub phase: PhaseModel,
    /// σ_s = 0 at every wavelength: transmittance is applied deterministically (Beer–Lambert).
    pub pure_absorber: bool,
    /// Density ρ(x) multiplying σ_a and σ_s (σ_a, σ_s above are at ρ = 1); `None`: homogeneous.
    pub density: Option<std::sync::Arc<grid::DensityGrid>>,
    /// With `density` only: a(x, λ) ∈ [0, 1] scaling the scattering, σ_s(x, λ) = a(x, λ) ρ(x)
    /// σ_s(λ), the rest of the extinction absorbed, σ_a(x, λ) = ρ(x) σ_t(λ) − σ_s(x, λ) (σ_t and
    /// the flights unchanged), grey or from RGB colours ([`albedo::AlbedoGrid`]); `None`: a = 1.
    pub albedo: Option<std::sync::Arc<albedo::AlbedoGrid>>,
}

/// What a path needs of a medium at its carried wavelengths, computed once when it enters the
/// medium (the wavelengths of a path never change): σ_s, σ_t and, per wavelength, the phase
/// function's parameters (HG g, or the two tables it interpolates and the weight of the second).
#[derive(Clone, Copy, Debug, Default)]
pub struct MediumLanes {
    /// Scattering coefficient σ_s per carried wavelength, m⁻¹.
    pub sigma_s: SampledSpectrum,
    /// Extinction coefficient σ_t per carried wavelength, m⁻¹.
    pub sigma_t: SampledSpectrum,
    /// Mean cosine g of the phase function per carried wavelength (dimensionless).
    pub g: SampledSpectrum,
    /// HG: g per wavelength; tables: the interpolation weight t of table k+1.
    phase_w: SampledSpectrum,
    /// Tables: index k of the lower table per wavelength.
    table: [u32; N_LAMBDA],
    /// Tables on a shared grid: where the lower table starts in [`SharedGrid::values`]
    /// (k · nodes).
    row: [u32; N_LAMBDA],
}

/// The direction at scattering cosine `mu` from `frame`'s normal (the incident direction), at
/// azimuth 2π `uy` around it.
#[inline]
pub fn scattered(frame: &Frame, mu: f32, uy: f32) -> Vec3 {
    let sin = (1.0 - mu * mu).max(0.0).sqrt();
    let (sp, cp) = (2.0 * PI * uy).sin_cos();
    frame.to_world(Vec3::new(sin * cp, sin * sp, mu)).normalize()
}

/// A direction sampled from a phase function.
#[derive(Clone, Copy, Debug)]
pub struct PhaseSample {
    /// New propagation direction (unit, world).
    pub wi: Vec3,
    /// Phase function at each carried wavelength divided by the hero's sampling density (p(λᵢ)/p(λ₀)).
    pub weight: SampledSpectrum,
    /// Density per steradian of `wi` (the hero wavelength's phase function).
    pub pdf: f32,
}

impl Medium {
    /// A medium from σ_a, σ_s (m⁻¹) and a phase function; errors on negative or non-finite
    /// coefficients and on |g| ≥ 1 (messages name the field).
    pub fn new(name: &str, sigma_a_per_m: DenseSpectrum, sigma_s_per_m: DenseSpectrum, phase: PhaseModel) -> Result<Self> {
        for (field, s) in [("sigma_a", &sigma_a_per_m), ("sigma_s", &sigma_s_per_m)] {
            if let Some((i, x)) = s.samples().iter().enumerate().find(|(_, x)| !(x.is_finite() && **x >= 0.0)) {
                bail!("{name}: {field} is negative or not finite ({x} at {} nm)", 360 + i);
            }
        }
        match &phase {
            PhaseModel::HenyeyGreenstein { g } => {
                if let Some((i, x)) = g.samples().iter().enumerate().find(|(_, x)| !(x.abs() < 1.0)) {
                    bail!("{name}: g must lie in (-1, 1), got {x} at {} nm", 360 + i);
                }
            }
            PhaseModel::Tabulated { lambda_nm, tables, .. } => {
                if lambda_nm.is_empty() || lambda_nm.len() != tables.len() {
                    bail!("{name}: tabulated phase function needs one table per wavelength");
                }
                if lambda_nm.windows(2).any(|w| !(w[1] > w[0])) {
                    bail!("{name}: phase-function wavelengths must increase strictly");
                }
            }
        }
        let pure_absorber = sigma_s_per_m.samples().iter().all(|&x| x == 0.0);
        Ok(Medium { name: name.to_string(), sigma_a_per_m, sigma_s_per_m, phase, pure_absorber, density: None, albedo: None })
    }

    /// σ_s, σ_t and the phase-function parameters at the carried wavelengths.
    #[inline]
    pub fn lanes(&self, wl: &SampledWavelengths) -> MediumLanes {
        let (sigma_s, sigma_t) = self.coefficients(wl);
        let mut w = [0f32; N_LAMBDA];
        let mut table = [0u32; N_LAMBDA];
        let mut g = [0f32; N_LAMBDA];
        for i in 0..N_LAMBDA {
            g[i] = self.g_at(wl.lambda_nm[i]);
            match &self.phase {
                PhaseModel::HenyeyGreenstein { g } => w[i] = g.eval(wl.lambda_nm[i]),
                PhaseModel::Tabulated { lambda_nm: ls, .. } => {
                    let (k, t) = bracket(ls, wl.lambda_nm[i]);
                    table[i] = k as u32;
                    w[i] = t;
                }
            }
        }
        let nodes = match &self.phase {
            PhaseModel::Tabulated { grid: Some(g), .. } => g.mu.len() as u32,
            _ => 0,
        };
        MediumLanes { sigma_s, sigma_t, g: Vec4::from_array(g), phase_w: Vec4::from_array(w), table, row: table.map(|k| k * nodes) }
    }

    /// (σ_s, σ_t) in m⁻¹ at the carried wavelengths.
    #[inline]
    pub fn coefficients(&self, wl: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let s = wl.eval(&self.sigma_s_per_m);
        (s, s + wl.eval(&self.sigma_a_per_m))
    }

    /// Phase function (sr⁻¹) at each carried wavelength for scattering cosine `cos_theta`.
    #[inline]
    pub fn phase_eval(&self, wl: &SampledWavelengths, cos_theta: f32) -> SampledSpectrum {
        if let PhaseModel::Tabulated { lambda_nm: ls, grid: Some(g), .. } = &self.phase {
            // One search of the common cos θ grid for all four wavelengths.
            let n = g.mu.len();
            let x = cos_theta.clamp(-1.0, 1.0);
            let j = g.mu.partition_point(|&m| m <= x).saturating_sub(1).min(n - 2);
            let s = ((x - g.mu[j]) / (g.mu[j + 1] - g.mu[j])).clamp(0.0, 1.0);
            let at = |k: usize| {
                let v = &g.values[k * n + j..k * n + j + 2];
                v[0] + s * (v[1] - v[0])
            };
            let mut out = [0f32; N_LAMBDA];
            for (i, o) in out.iter_mut().enumerate() {
                let (k, t) = bracket(ls, wl.lambda_nm[i]);
                *o = if t > 0.0 { at(k) * (1.0 - t) + t * at(k + 1) } else { at(k) };
            }
            return Vec4::from_array(out);
        }
        let mut out = [0f32; N_LAMBDA];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.phase_at(wl.lambda_nm[i], cos_theta);
        }
        Vec4::from_array(out)
    }

    /// Phase function (sr⁻¹) at one wavelength.
    #[inline]
    pub fn phase_at(&self, lambda_nm: f32, cos_theta: f32) -> f32 {
        match &self.phase {
            PhaseModel::HenyeyGreenstein { g } => hg(g.eval(lambda_nm), cos_theta),
            PhaseModel::Tabulated { lambda_nm: ls, tables, .. } => {
                let (k, t) = bracket(ls, lambda_nm);
                let a = tables[k].eval(cos_theta as f64) as f32;
                if t > 0.0 {
                    a * (1.0 - t) + t * tables[k + 1].eval(cos_theta as f64) as f32
                } else {
                    a
                }
            }
        }
    }

    /// Sample a new direction after scattering a ray travelling along `d` (unit), from the hero
    /// wavelength's phase function; `u` uniform in [0,1)² and `uc` uniform for the table choice.
    #[inline]
    pub fn phase_sample(&self, wl: &SampledWavelengths, d: Vec3, uc: f32, u: Vec2) -> Option<PhaseSample> {
        self.phase_sample_lanes(&self.lanes(wl), None, d, uc, u)
    }

    /// The carried wavelengths' phase functions at the nodes of a shared cos θ grid, node j in
    /// `out[j]` (sr⁻¹ per lane): the interpolation between the wavelength tables done once, so
    /// that [`Self::phase_lanes_at`] is one interpolation in cos θ. `out` is resized to the
    /// number of nodes, and emptied when the phase function has no shared grid.
    pub fn lane_table(&self, lanes: &MediumLanes, out: &mut Vec<Vec4>) {
        out.clear();
        let PhaseModel::Tabulated { grid: Some(gr), .. } = &self.phase else { return };
        let n = gr.mu.len();
        out.resize(n, Vec4::ZERO);
        // Lane by lane over the two bracketing tables' contiguous rows (a path entering a milk
        // pays this once; 181 nodes).
        for i in 0..N_LAMBDA {
            let (r, t) = (lanes.row[i] as usize, lanes.phase_w[i]);
            let lo = &gr.values[r..r + n];
            if t > 0.0 {
                let hi = &gr.values[r + n..r + 2 * n];
                for ((o, &a), &b) in out.iter_mut().zip(lo).zip(hi) {
                    o[i] = a * (1.0 - t) + t * b;
                }
            } else {
                for (o, &a) in out.iter_mut().zip(lo) {
                    o[i] = a;
                }
            }
        }
    }

    /// [`Self::phase_sample`] with the medium's per-wavelength data already at hand. Tables on a
    /// shared grid are inverted with a guide table and evaluated at all four wavelengths in the
    /// segment the inversion found (no searches).
    #[inline]
    pub fn phase_sample_lanes(&self, lanes: &MediumLanes, table: Option<&[Vec4]>, d: Vec3, uc: f32, u: Vec2) -> Option<PhaseSample> {
        let (mu, seg) = self.phase_sample_cos(lanes, uc, u.x);
        let p = self.phase_lanes_at(lanes, table, mu, seg);
        let wi = scattered(&Frame::from_normal(d), mu, u.y);
        let pdf = p.x;
        if !(pdf > 0.0) {
            return None;
        }
        Some(PhaseSample { wi, weight: p / pdf, pdf })
    }

    /// The scattering cosine μ that [`Self::phase_sample_lanes`] draws from the hero
    /// wavelength's phase function with the same `uc` and `ux`, and, for tables on a shared
    /// grid, the grid segment and the position in it (for [`Self::phase_lanes_at`]).
    #[inline(always)]
    pub fn phase_sample_cos(&self, lanes: &MediumLanes, uc: f32, ux: f32) -> (f32, Option<(usize, f32)>) {
        match &self.phase {
            PhaseModel::HenyeyGreenstein { .. } => (hg_sample(lanes.phase_w.x, ux).clamp(-1.0, 1.0), None),
            PhaseModel::Tabulated { grid: Some(gr), .. } => {
                let n = gr.mu.len();
                let (k0, t0) = (lanes.table[0] as usize, lanes.phase_w.x);
                let kk = if t0 > 0.0 && uc < t0 { k0 + 1 } else { k0 };
                let cdf = &gr.cdf[kk * n..(kk + 1) * n];
                let x = ux.clamp(0.0, 1.0);
                let mut j = gr.guide[kk * GUIDE + ((x * GUIDE as f32) as usize).min(GUIDE - 1)] as usize;
                while j + 2 < n && cdf[j + 1] <= x {
                    j += 1;
                }
                let at = kk * n + j;
                let h = gr.mu[j + 1] - gr.mu[j];
                // Density in the segment q(s) ∝ a + (b − a) s, s ∈ [0, 1], scaled to mean 1 over the segment; `target` is the fraction of the segment's
                // probability below the sample (exactly consistent with the CDF).
                let (a, b) = (gr.values[at], gr.values[at + 1]);
                let mass = cdf[j + 1] - cdf[j];
                let s = if !(a + b > 0.0) || !(mass > 0.0) {
                    0.5
                } else if (b - a).abs() <= 1e-6 * (a + b) {
                    ((x - cdf[j]) / mass).clamp(0.0, 1.0)
                } else {
                    let [a, b] = gr.ends[at];
                    let target = ((x - cdf[j]) / mass).clamp(0.0, 1.0);
                    let disc = (a * a + 2.0 * (b - a) * target).max(0.0);
                    2.0 * target / (a + disc.sqrt())
                }
                .clamp(0.0, 1.0);
                ((gr.mu[j] + s * h).clamp(-1.0, 1.0), Some((j, s)))
            }
            PhaseModel::Tabulated { tables, .. } => {
                let (k0, t0) = (lanes.table[0] as usize, lanes.phase_w.x);
                let kk = if t0 > 0.0 && uc < t0 { k0 + 1 } else { k0 };
                ((tables[kk].sample_cos_theta(ux as f64) as f32).clamp(-1.0, 1.0), None)
            }
        }
    }

    /// Phase function (sr⁻¹) at each carried wavelength for the cosine `mu` drawn by
    /// [`Self::phase_sample_cos`] (`seg` as it returned it); `table` is this path's
    /// [`Self::lane_table`], if it has one.
    #[inline(always)]
    pub fn phase_lanes_at(&self, lanes: &MediumLanes, table: Option<&[Vec4]>, mu: f32, seg: Option<(usize, f32)>) -> SampledSpectrum {
        if let (Some(tab), Some((j, s))) = (table, seg) {
            let a = tab[j];
            return a + s * (tab[j + 1] - a);
        }
        match (&self.phase, seg) {
            (PhaseModel::HenyeyGreenstein { .. }, _) => {
                let g = lanes.phase_w;
                let dd = Vec4::ONE + g * g - 2.0 * g * mu;
                (Vec4::ONE - g * g) / (4.0 * PI * dd * dd.max(Vec4::splat(1e-12)).powf(0.5))
            }
            (PhaseModel::Tabulated { grid: Some(gr), .. }, Some((j, s))) => {
                let n = gr.mu.len();
                let v = &gr.values;
                let at = |r: usize| v[r] + s * (v[r + 1] - v[r]);
                let mut out = [0f32; N_LAMBDA];
                for (i, o) in out.iter_mut().enumerate() {
                    let (r, t) = (lanes.row[i] as usize + j, lanes.phase_w[i]);
                    *o = if t > 0.0 { at(r) * (1.0 - t) + t * at(r + n) } else { at(r) };
                }
                Vec4::from_array(out)
            }
            (PhaseModel::Tabulated { lambda_nm: ls, tables, .. }, _) => {
                let mut out = [0f32; N_LAMBDA];
                for (i, o) in out.iter_mut().enumerate() {
                    let (k, t) = (lanes.table[i] as usize, lanes.phase_w[i]);
                    let a = tables[k].eval(mu as f64) as f32;
                    *o = if t > 0.0 && k + 1 < ls.len() { a * (1.0 - t) + t * tables[k + 1].eval(mu as f64) as f32 } else { a };
                }
                Vec4::from_array(out)
            }
        }
    }

    /// The similarity-relation equivalent of this medium (an APPROXIMATION, opt-in with
    /// `similarity = true`): isotropic scattering with the reduced scattering coefficient
    /// σ_s′(λ) = σ_s(λ)(1 − g(λ)) and the same σ_a. It has the same diffusion-theory transport
    /// (same σ_tr, same albedo′ and D) as the original, so it agrees deep inside a thick,
    /// high-albedo medium after many scatterings, but not near boundaries or in thin or
    /// low-albedo media, nor in single-scattering angular detail; it needs about 1/(1 − g) times
    /// fewer scattering events (≈ 10× for milk).
    pub fn similarity(&self) -> Result<Medium> {
        let sigma_s = DenseSpectrum::from_fn(|l| (self.sigma_s_per_m.eval(l as f32) * (1.0 - self.g_at(l as f32))).max(0.0) as f64);
        let g = DenseSpectrum::from_fn(|_| 0.0);
        let mut m = Medium::new(&format!("{} (similarity relation)", self.name), self.sigma_a_per_m.clone(), sigma_s, PhaseModel::HenyeyGreenstein { g })?;
        m.density = self.density.clone();
        m.albedo = self.albedo.clone();
        Ok(m)
    }

    /// The density-weighted length ∫ρ ds (m) of the segment o + s·d, s ∈ [0, t] (m; `d` a unit
    /// vector): t itself in a homogeneous medium. The transmittance over the segment at each
    /// wavelength is e^{−σ_t(λ) · this}.
    #[inline]
    pub fn depth(&self, o: Vec3, d: Vec3, t: f32) -> f32 {
        match &self.density {
            None => t,
            Some(g) => g.depth(o, d, t),
        }
    }

    /// Mean cosine of the phase function at `lambda_nm`.
    pub fn g_at(&self, lambda_nm: f32) -> f32 {
        match &self.phase {
            PhaseModel::HenyeyGreenstein { g } => g.eval(lambda_nm),
            PhaseModel::Tabulated { lambda_nm: ls, tables, .. } => {
                let (k, t) = bracket(ls, lambda_nm);
                let a = tables[k].g() as f32;
                if t > 0.0 {
                    a * (1.0 - t) + t * tables[k + 1].g() as f32
                } else {
                    a
                }
            }
        }
    }
}

/// Index k and weight t of the table interval containing `x` (t = 0 at or beyond the ends).
#[inline]
fn bracket(ls: &[f32], x: f32) -> (usize, f32) {
    let n = ls.len();
    if n == 1 || !(x > ls[0]) {
        return (0, 0.0);
    }
    if x >= ls[n - 1] {
        return (n - 1, 0.0);
    }
    let k = ls.partition_point(|&l| l <= x) - 1;
    let t = (x - ls[k]) / (ls[k + 1] - ls[k]);
    (k, t.clamp(0.0, 1.0))
}

/// Henyey–Greenstein phase function (sr⁻¹).
#[inline]
pub fn hg(g: f32, cos_theta: f32) -> f32 {
    let d = 1.0 + g * g - 2.0 * g * cos_theta;
    (1.0 - g * g) / (4.0 * PI * d * d.max(1e-12).sqrt())
}

/// cos θ distributed as Henyey–Greenstein for uniform `u` (exact inverse CDF).
#[inline]
pub fn hg_sample(g: f32, u: f32) -> f32 {
    if g.abs() < 1e-3 {
        return 1.0 - 2.0 * u;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

/// Phase model from a Mie bulk phase table (`optics::media::PhaseTable`, cos θ from 1 to −1,
/// one row per wavelength).
pub fn tabulated_from_mie(lambda_nm: &[f64], table: &optics::media::PhaseTable) -> Result<PhaseModel> {
    if table.per_sr.len() != lambda_nm.len() {
        bail!("phase table has {} wavelengths, expected {}", table.per_sr.len(), lambda_nm.len());
    }
    let mut mu = table.cos_theta.clone();
    let reversed = mu.len() > 1 && mu[0] > mu[mu.len() - 1];
    if reversed {
        mu.reverse();
    }
    if let Some(m) = mu.first_mut() {
        *m = -1.0;
    }
    if let Some(m) = mu.last_mut() {
        *m = 1.0;
    }
    let mut tables = Vec::with_capacity(lambda_nm.len());
    for (row, l) in table.per_sr.iter().zip(lambda_nm) {
        let mut v = row.clone();
        if reversed {
            v.reverse();
        }
        tables.push(TabulatedPhase::new(mu.clone(), v).map_err(|e| anyhow::anyhow!("phase function at {l} nm: {e:#}"))?);
    }
    Ok(PhaseModel::tabulated(lambda_nm.iter().map(|&l| l as f32).collect(), tables, Some(&mu)))
}

/// Piecewise-linear interpolation of values given at increasing wavelengths, held constant beyond the ends.
pub fn interp_clamped(lambda_nm: &[f64], values: &[f64], x: f64) -> f64 {
    let n = lambda_nm.len();
    if n == 0 {
        return 0.0;
    }
    if !(x > lambda_nm[0]) {
        return values[0];
    }
    if x >= lambda_nm[n - 1] {
        return values[n - 1];
    }
    let k = lambda_nm.partition_point(|&l| l <= x) - 1;
    let t = (x - lambda_nm[k]) / (lambda_nm[k + 1] - lambda_nm[k]);
    values[k] * (1.0 - t) + values[k + 1] * t
}

/// Nodes of [`rayleigh_phase`]'s table, uniform in cos θ.
pub const RAYLEIGH_NODES: usize = 257;

/// The Rayleigh phase function p(μ) = 3 (1 + μ²) / (16π) (scattering by particles much smaller
/// than the wavelength, unpolarised light; the same at every wavelength; Mitsuba 3's `rayleigh`),
/// tabulated on [`RAYLEIGH_NODES`] nodes uniform in μ, so that `volpath` samples and evaluates it
/// with the tabulated phase functions' machinery. The piecewise-linear table lies within
/// h² max|p″| / 8 ≈ 1e-6 sr⁻¹ (2e-5 relative) of the closed form (test
/// `rayleigh_table_matches_the_closed_form`).
pub fn rayleigh_phase() -> PhaseModel {
    let table = TabulatedPhase::from_fn(RAYLEIGH_NODES, |mu| 3.0 * (1.0 + mu * mu) / (16.0 * std::f64::consts::PI)).expect("the Rayleigh table is valid");
    let mu: Vec<f64> = (0..RAYLEIGH_NODES).map(|i| -1.0 + 2.0 * i as f64 / (RAYLEIGH_NODES - 1) as f64).collect();
    PhaseModel::tabulated(vec![550.0], vec![table], Some(&mu))
}

/// A medium from per-wavelength bulk properties (the Mie module's output): σ_a, σ_s interpolated
/// linearly between its wavelengths and held constant beyond them; the tabulated phase function
/// when present (and `use_table`), else Henyey–Greenstein with the computed g(λ).
pub fn from_bulk(name: &str, b: &optics::media::BulkProperties, use_table: bool) -> Result<Medium> {
    let l = b.lambda_nm.clone();
    if l.is_empty() {
        bail!("{name}: no wavelengths in the medium's properties");
    }
    let (sa, ss, g) = (b.sigma_a_per_m.clone(), b.sigma_s_per_m.clone(), b.g.clone());
    // Tiny negative σ_a from rounding (σ_t − σ_s) is clamped to 0.
    let sigma_a = DenseSpectrum::from_fn(|x| interp_clamped(&l, &sa, x).max(0.0));
    let sigma_s = DenseSpectrum::from_fn(|x| interp_clamped(&l, &ss, x));
    let phase = match (&b.phase, use_table) {
        (Some(t), true) => tabulated_from_mie(&l, t)?,
        _ => PhaseModel::HenyeyGreenstein { g: DenseSpectrum::from_fn(|x| interp_clamped(&l, &g, x)) },
    };
    Medium::new(name, sigma_a, sigma_s, phase)
}


/// A lower bound on the distance from a point to the nearest surface of the scene, on a grid over
/// a medium's bounding box: inside it, a free flight shorter than the bound cannot reach a surface,
/// so `volpath` skips the ray cast (exactly: the result is the same, only cheaper).
///
/// Cells (size h) that any surface may touch are marked: every cell overlapping a triangle's
/// bounding box, and every cell whose centre lies within √3·h/2 of a sphere's surface. An exact
/// Euclidean distance transform (Felzenszwalb & Huttenlocher 2012) gives, per cell, the distance
/// d to the nearest marked cell centre; a point of the cell is then at least (d − √3)·h from any
/// surface point inside the grid, and at least its distance to the grid's faces from any surface
/// outside it.
#[derive(Clone, Debug)]
pub struct FreeFlightGrid {
    min: Vec3,
    max: Vec3,
    n: [usize; 3],
    /// 1 / the cells' side (m⁻¹) and the cell counts as floats, for the per-collision lookup.
    inv_cell: f32,
    n_f: Vec3,
    /// Per cell (x fastest), the bound in m (≤ 0: no guarantee).
    bound_m: Vec<f32>,
    /// The medium's boundary when it is one closed convex mesh with nothing inside: exact
    /// distances and exits by its face planes ([`convex::ConvexBoundary`]).
    convex: Option<convex::ConvexBoundary>,
}

impl FreeFlightGrid {
    /// The grid for the region `region` (m), about `cells` cells along its longest side, with the
    /// scene's shapes.
    pub fn build(region: &crate::math::geometry::Aabb, shapes: &[crate::shape::Shape], cells: usize) -> FreeFlightGrid {
        let ext = region.max - region.min;
        let h = (ext.max_element() / cells.max(1) as f32).max(1e-9);
        let min = region.min - Vec3::splat(2.0 * h);
        // At most cells + 5 cells an axis; the clamp only matters when the region's size is not
        // finite in f32 (then the grid below is the one that guarantees nothing).
        let n = [0, 1, 2].map(|a| (((ext[a] + 4.0 * h) / h).ceil() as usize).clamp(1, cells.max(1) + 5));
        let max = min + Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32) * h;
        if !(min.is_finite() && max.is_finite() && h.is_finite()) {
            return FreeFlightGrid { min: Vec3::ZERO, max: Vec3::ZERO, n: [1, 1, 1], inv_cell: 1.0, n_f: Vec3::ONE, bound_m: vec![0.0], convex: None };
        }
        let idx = |i: usize, j: usize, k: usize| (k * n[1] + j) * n[0] + i;
        let mut marked = vec![false; n[0] * n[1] * n[2]];
        let cell_range = |lo: Vec3, hi: Vec3| -> Option<[std::ops::Range<usize>; 3]> {
            let mut r: [std::ops::Range<usize>; 3] = [0..0, 0..0, 0..0];
            for a in 0..3 {
                if !(hi[a] >= min[a] && lo[a] <= max[a]) {
                    return None;
                }
                let a0 = (((lo[a] - min[a]) / h).floor().max(0.0) as usize).min(n[a] - 1);
                let a1 = (((hi[a] - min[a]) / h).floor().max(0.0) as usize).min(n[a] - 1);
                r[a] = a0..a1 + 1;
            }
            Some(r)
        };
        for shape in shapes {
            match shape {
                crate::shape::Shape::Mesh(m) => {
                    for t in &m.indices {
                        let [a, b, c] = t.map(|i| m.positions[i as usize]);
                        // A margin of 1e-3 h keeps triangles on a cell face marked on both sides.
                        let e = Vec3::splat(1e-3 * h);
                        let Some([ri, rj, rk]) = cell_range(a.min(b).min(c) - e, a.max(b).max(c) + e) else { continue };
                        for k in rk {
                            for j in rj.clone() {
                                for i in ri.clone() {
                                    marked[idx(i, j, k)] = true;
                                }
                            }
                        }
                    }
                }
                crate::shape::Shape::Sphere(sp) => {
                    let r = Vec3::splat(sp.radius + h);
                    let Some([ri, rj, rk]) = cell_range(sp.center - r, sp.center + r) else { continue };
                    for k in rk {
                        for j in rj.clone() {
                            for i in ri.clone() {
                                let c = min + (Vec3::new(i as f32, j as f32, k as f32) + Vec3::splat(0.5)) * h;
                                if ((c - sp.center).length() - sp.radius).abs() <= 0.87 * h {
                                    marked[idx(i, j, k)] = true;
                                }
                            }
                        }
                    }
                }
            }
        }
        // Squared distance (in cells) to the nearest marked cell centre, one axis at a time.
        let big = 1e20f32;
        let mut d2: Vec<f32> = marked.iter().map(|&m| if m { 0.0 } else { big }).collect();
        let mut line = Vec::new();
        let mut out = Vec::new();
        for axis in 0..3 {
            let (len, o1, o2) = match axis {
                0 => (n[0], n[1], n[2]),
                1 => (n[1], n[0], n[2]),
                _ => (n[2], n[0], n[1]),
            };
            for u in 0..o1 {
                for v in 0..o2 {
                    let at = |t: usize| match axis {
                        0 => idx(t, u, v),
                        1 => idx(u, t, v),
                        _ => idx(u, v, t),
                    };
                    line.clear();
                    line.extend((0..len).map(|t| d2[at(t)]));
                    edt_1d(&line, &mut out);
                    for t in 0..len {
                        d2[at(t)] = out[t];
                    }
                }
            }
        }
        let bound_m = d2.iter().map(|&q| if q >= big * 0.5 { f32::INFINITY } else { (q.sqrt() - 1.7321) * h }).collect();
        FreeFlightGrid { min, max, n, inv_cell: 1.0 / h, n_f: Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32), bound_m, convex: None }
    }

    /// This grid with the medium's convex boundary (see [`Self::convex`]).
    pub fn with_convex(mut self, convex: Option<convex::ConvexBoundary>) -> FreeFlightGrid {
        self.convex = convex;
        self
    }

    /// The medium's boundary, when it is one closed convex mesh with no other surface inside.
    #[inline]
    pub fn convex(&self) -> Option<&convex::ConvexBoundary> {
        self.convex.as_ref()
    }

    /// A distance (m) within which no surface lies around `p` (0 when unknown).
    #[inline]
    pub fn free_distance(&self, p: Vec3) -> f32 {
        let to_faces = (p - self.min).min(self.max - p).min_element();
        if !(to_faces > 0.0) {
            return 0.0;
        }
        // A point within rounding of a cell face may land in the neighbouring cell; the bounds
        // leave a margin of 5·10⁻⁵ cells for that (`build`).
        let c = (p - self.min) * self.inv_cell;
        // Also false for NaN: past this, 0 ≤ c < n on every axis.
        if !(c.cmpge(Vec3::ZERO).all() && c.cmplt(self.n_f).all()) {
            return 0.0;
        }
        // SAFETY: x is finite and in [0, n) with n a cell count (far below usize::MAX), checked
        // just above, so its integer part is representable.
        let cell = |x: f32| unsafe { x.to_int_unchecked::<usize>() };
        let (i, j, k) = (cell(c.x), cell(c.y), cell(c.z));
        self.bound_m[(k * self.n[1] + j) * self.n[0] + i].min(to_faces).max(0.0)
    }
}

/// Exact 1-D squared-distance transform of `f` (0 at marked cells, huge elsewhere):
/// out[q] = min_p (q − p)² + f[p] (lower envelope of parabolas).
fn edt_1d(f: &[f32], out: &mut Vec<f32>) {
    let n = f.len();
    out.clear();
    out.resize(n, 0.0);
    let mut v = vec![0usize; n];
    let mut z = vec![0f32; n + 1];
    let mut k = 0usize;
    z[0] = f32::NEG_INFINITY;
    z[1] = f32::INFINITY;
    let cross = |q: usize, p: usize| ((f[q] + (q * q) as f32) - (f[p] + (p * p) as f32)) / (2.0 * (q as f32 - p as f32));
    for q in 1..n {
        let mut s = cross(q, v[k]);
        while k > 0 && s <= z[k] {
            k -= 1;
            s = cross(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f32::INFINITY;
    }
    k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f32 {
            k += 1;
        }
        let d = q as f32 - v[k] as f32;
        *o = d * d + f[v[k]];
    }
}

/// Signed volume (m³, positive when the triangles' normals point outwards) of a closed
/// triangle mesh. Vertices are welded by exact position; every edge must be shared by exactly two
/// triangles traversing it in opposite directions (closed and consistently oriented), else the
/// error names the first offending edge.
pub fn closed_mesh_volume(mesh: &crate::shape::mesh::TriangleMesh) -> Result<f64> {
    use std::collections::HashMap;
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut weld = Vec::with_capacity(mesh.positions.len());
    for p in &mesh.positions {
        let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
        let n = ids.len() as u32;
        weld.push(*ids.entry(key).or_insert(n));
    }
    // Directed edge → number of uses.
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    let mut volume = 0.0f64;
    for t in &mesh.indices {
        let v = [weld[t[0] as usize], weld[t[1] as usize], weld[t[2] as usize]];
        if v[0] == v[1] || v[1] == v[2] || v[0] == v[2] {
            continue; // degenerate triangle: no area, no edges
        }
        for k in 0..3 {
            *edges.entry((v[k], v[(k + 1) % 3])).or_insert(0) += 1;
        }
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.positions[i as usize].as_dvec3());
        volume += a.dot(b.cross(c)) / 6.0;
    }
    let pos = |i: u32| {
        let k = ids.iter().find(|(_, v)| **v == i).map(|(k, _)| *k).unwrap_or([0; 3]);
        Vec3::new(f32::from_bits(k[0]), f32::from_bits(k[1]), f32::from_bits(k[2]))
    };
    for (&(a, b), &n) in &edges {
        let back = edges.get(&(b, a)).copied().unwrap_or(0);
        if n != 1 || back != 1 {
            let what = if back == 0 && n == 1 {
                "is used by only one triangle (open boundary)"
            } else if n > 1 {
                "is traversed twice in the same direction (inconsistent orientation or more than two triangles)"
            } else {
                "is shared by more than two triangles"
            };
            bail!("edge {:?}–{:?} (m) {what}", pos(a), pos(b));
        }
    }
    if edges.is_empty() {
        bail!("mesh has no non-degenerate triangles");
    }
    Ok(volume)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Pcg32;

    fn wl() -> SampledWavelengths {
        SampledWavelengths::fixed([450.0, 520.0, 610.0, 700.0])
    }

    #[test]
    fn rejects_bad_coefficients() {
        let ok = DenseSpectrum::from_fn(|_| 1.0);
        let neg = DenseSpectrum::from_fn(|l| if l > 600.0 { -1.0 } else { 1.0 });
        let hg = |g: f64| PhaseModel::HenyeyGreenstein { g: DenseSpectrum::from_fn(move |_| g) };
        assert!(Medium::new("m", ok.clone(), ok.clone(), hg(0.5)).is_ok());
        let e = Medium::new("m", neg.clone(), ok.clone(), hg(0.0)).unwrap_err().to_string();
        assert!(e.contains("sigma_a"), "{e}");
        assert!(Medium::new("m", ok.clone(), neg, hg(0.0)).unwrap_err().to_string().contains("sigma_s"));
        assert!(Medium::new("m", ok.clone(), ok.clone(), hg(1.0)).unwrap_err().to_string().contains("g must"));
        assert!(Medium::new("m", ok.clone(), ok, hg(-1.2)).is_err());
    }

    #[test]
    fn closed_mesh_check() {
        use crate::shape::mesh::TriangleMesh;
        // Unit cube from six quads (separate vertices per quad: welding makes it closed).
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let faces = [
            [c(0., 0., 0.), c(0., 1., 0.), c(1., 1., 0.), c(1., 0., 0.)],
            [c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)],
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)],
            [c(0., 1., 0.), c(0., 1., 1.), c(1., 1., 1.), c(1., 1., 0.)],
            [c(0., 0., 0.), c(0., 0., 1.), c(0., 1., 1.), c(0., 1., 0.)],
            [c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)],
        ];
        let mut m = TriangleMesh { positions: vec![], normals: None, uvs: None, indices: vec![] };
        for f in &faces {
            let q = TriangleMesh::quad(*f);
            let off = m.positions.len() as u32;
            m.indices.extend(q.indices.iter().map(|t| [t[0] + off, t[1] + off, t[2] + off]));
            m.positions.extend_from_slice(&q.positions);
        }
        let v = closed_mesh_volume(&m).unwrap();
        assert!((v.abs() - 1.0).abs() < 1e-6, "{v}");
        // Reversed winding: volume changes sign.
        let mut r = m.clone();
        r.indices.iter_mut().for_each(|t| t.swap(1, 2));
        assert!((closed_mesh_volume(&r).unwrap() + v).abs() < 1e-9);
        // Open: drop one quad.
        let mut open = m.clone();
        open.indices.truncate(10);
        assert!(closed_mesh_volume(&open).unwrap_err().to_string().contains("only one triangle"));
        // One face flipped: inconsistent orientation.
        let mut bad = m.clone();
        bad.indices[0].swap(1, 2);
        bad.indices[1].swap(1, 2);
        assert!(closed_mesh_volume(&bad).is_err());
    }

    /// Sampling matches evaluation: E[f(μ)·weight] over hero samples equals ∫ f p_i dω per
    /// lane, checked with f = 1 (normalisation: weight averages to 1 in every lane) and f = μ (mean
    /// cosine g(λᵢ) of each lane's own phase function), for HG with spectral g and for tables.
    #[test]
    fn phase_sampling_is_consistent_per_wavelength() {
        let g_spec = DenseSpectrum::from_fn(|l| 0.2 + 0.7 * (l - 360.0) / 470.0);
        let hgm = Medium::new("hg", DenseSpectrum::from_fn(|_| 0.0), DenseSpectrum::from_fn(|_| 1.0), PhaseModel::HenyeyGreenstein { g: g_spec }).unwrap();
        // Two tables: HG 0.3 at 400 nm and a forward lobe (HG 0.8 tabulated finely) at 700 nm.
        let t1 = TabulatedPhase::from_fn(2001, |m| hg(0.3, m as f32) as f64).unwrap();
        let t2 = TabulatedPhase::from_fn(4001, |m| hg(0.8, m as f32) as f64).unwrap();
        let (g1, g2) = (t1.g() as f32, t2.g() as f32);
        let tab = Medium::new(
            "tab",
            DenseSpectrum::from_fn(|_| 0.0),
            DenseSpectrum::from_fn(|_| 1.0),
            PhaseModel::tabulated(vec![400.0, 700.0], vec![t1, t2], None),
        )
        .unwrap();
        // The same two phase functions on one shared grid (the fast path used for Mie tables).
        let mu: Vec<f64> = (0..3001).map(|k| -1.0 + 2.0 * k as f64 / 3000.0).collect();
        let s1 = TabulatedPhase::new(mu.clone(), mu.iter().map(|&m| hg(0.3, m as f32) as f64).collect()).unwrap();
        let s2 = TabulatedPhase::new(mu.clone(), mu.iter().map(|&m| hg(0.8, m as f32) as f64).collect()).unwrap();
        let shared = Medium::new(
            "shared",
            DenseSpectrum::from_fn(|_| 0.0),
            DenseSpectrum::from_fn(|_| 1.0),
            PhaseModel::tabulated(vec![400.0, 700.0], vec![s1, s2], Some(&mu)),
        )
        .unwrap();
        // Fast and generic evaluation agree.
        for k in 0..200 {
            let c = -1.0 + 2.0 * k as f32 / 199.0;
            let fast = shared.phase_eval(&wl(), c);
            for i in 0..4 {
                let slow = shared.phase_at(wl().lambda_nm[i], c);
                assert!((fast[i] - slow).abs() < 1e-4 * slow.max(1.0), "{c}: {} vs {slow}", fast[i]);
            }
        }
        for m in [&hgm, &tab, &shared] {
            let wl = wl();
            let mut rng = Pcg32::new(3, 4);
            let d = Vec3::new(0.3, -0.5, 0.8).normalize();
            let n = 200_000;
            let (mut s1, mut s2, mut sq) = (Vec4::ZERO, Vec4::ZERO, Vec4::ZERO);
            for _ in 0..n {
                let s = m.phase_sample(&wl, d, rng.next_f32(), rng.next_2d()).unwrap();
                let mu = s.wi.dot(d);
                assert!((s.pdf - m.phase_at(wl.lambda_nm[0], mu)).abs() < 1e-3 * s.pdf.max(1.0));
                s1 += s.weight;
                s2 += s.weight * mu;
                sq += s.weight * s.weight;
            }
            let nf = n as f32;
            let mean1 = s1 / nf;
            let se1 = ((sq / nf - mean1 * mean1).max(Vec4::ZERO) / nf).powf(0.5);
            for i in 0..4 {
                assert!((mean1[i] - 1.0).abs() < 4.0 * se1[i] + 2e-3, "{}: lane {i}: {} (se {})", m.name, mean1[i], se1[i]);
                let g = m.g_at(wl.lambda_nm[i]);
                assert!((s2[i] / nf - g).abs() < 4.0 * se1[i] + 3e-3, "{}: lane {i}: mean cos {} vs g {g}", m.name, s2[i] / nf);
            }
        }
        // A path's lane table (the wavelength interpolation done once) gives the phase values
        // of the per-event evaluation, the same sampled directions and pdfs; tables without a
        // shared grid get none.
        let lanes = shared.lanes(&wl());
        let mut buf = vec![Vec4::ONE; 5];
        tab.lane_table(&tab.lanes(&wl()), &mut buf);
        assert!(buf.is_empty());
        shared.lane_table(&lanes, &mut buf);
        assert_eq!(buf.len(), 3001);
        let mut rng = Pcg32::new(5, 6);
        let d = Vec3::new(0.3, -0.5, 0.8).normalize();
        for _ in 0..20_000 {
            let (uc, u) = (rng.next_f32(), rng.next_2d());
            let (a, b) = (shared.phase_sample_lanes(&lanes, None, d, uc, u).unwrap(), shared.phase_sample_lanes(&lanes, Some(&buf), d, uc, u).unwrap());
            assert_eq!(a.wi, b.wi);
            assert!((a.pdf - b.pdf).abs() <= 2e-6 * a.pdf, "{} vs {}", a.pdf, b.pdf);
            for i in 0..4 {
                assert!((a.weight[i] - b.weight[i]).abs() <= 2e-6 * a.weight[i].max(1e-3), "{} vs {}", a.weight, b.weight);
            }
        }
        // Interpolated g at 550 nm is the midpoint of the two tables' g.
        assert!((tab.g_at(550.0) - 0.5 * (g1 + g2)).abs() < 1e-5);
        assert!((tab.g_at(300.0) - g1).abs() < 1e-6 && (tab.g_at(800.0) - g2).abs() < 1e-6);
    }

    #[test]
    fn rayleigh_table_matches_the_closed_form() {
        // Values against 3(1 + μ²)/(16π); the table's mean cosine 0; sampled cosines against the
        // closed-form CDF F(μ) = (μ³ + 3μ + 4)/8 by a χ² test over 20 bins of equal probability
        // (bin edges solve F = k/20 by Cardano's formula), 200 000 samples, fixed seed.
        let m = Medium::new("air", DenseSpectrum::from_fn(|_| 0.0), DenseSpectrum::from_fn(|_| 1.0), rayleigh_phase()).unwrap();
        let exact = |mu: f64| 3.0 * (1.0 + mu * mu) / (16.0 * std::f64::consts::PI);
        for k in 0..=1000 {
            let mu = -1.0 + 2.0 * k as f64 / 1000.0;
            for l in [380.0f32, 550.0, 780.0] {
                let v = m.phase_at(l, mu as f32) as f64;
                assert!((v / exact(mu) - 1.0).abs() < 3e-5, "μ {mu} at {l} nm: {v} vs {}", exact(mu));
            }
        }
        assert!(m.g_at(550.0).abs() < 1e-6);
        let edge = |p: f64| {
            let z = 4.0 * p - 2.0;
            let r = (z * z + 1.0).sqrt();
            (z + r).cbrt() + (z - r).cbrt()
        };
        let bins = 20;
        let edges: Vec<f64> = (0..=bins).map(|k| edge(k as f64 / bins as f64)).collect();
        assert!((edges[0] + 1.0).abs() < 1e-9 && (edges[bins] - 1.0).abs() < 1e-9);
        let mut counts = vec![0usize; bins];
        let mut rng = Pcg32::new(7, 11);
        let n = 200_000;
        let wl = wl();
        let lanes = m.lanes(&wl);
        let mut table = Vec::new();
        m.lane_table(&lanes, &mut table);
        let d = Vec3::new(0.3, -0.4, 0.866).normalize();
        for _ in 0..n {
            let uc = rng.next_f32();
            let s = m.phase_sample_lanes(&lanes, Some(&table), d, uc, rng.next_2d()).unwrap();
            let mu = s.wi.dot(d) as f64;
            assert!((s.pdf as f64 / exact(mu) - 1.0).abs() < 1e-3, "pdf {} at μ {mu}", s.pdf);
            assert!((s.weight - Vec4::ONE).abs().max_element() < 1e-5);
            let b = edges.partition_point(|&e| e <= mu).clamp(1, bins) - 1;
            counts[b] += 1;
        }
        let expect = n as f64 / bins as f64;
        let chi2: f64 = counts.iter().map(|&c| (c as f64 - expect).powi(2) / expect).sum();
        // 19 degrees of freedom: P(χ² > 43.8) = 0.001.
        assert!(chi2 < 43.8, "χ² {chi2}: {counts:?}");
    }

    #[test]
    fn hg_normalised() {
        // 2π ∫ p dμ = 1 by the midpoint rule.
        for g in [-0.7f32, 0.0, 0.5, 0.95] {
            let n = 200_000;
            let s: f64 = (0..n).map(|k| hg(g, -1.0 + 2.0 * (k as f32 + 0.5) / n as f32) as f64).sum::<f64>() * 2.0 / n as f64;
            assert!((2.0 * std::f64::consts::PI * s - 1.0).abs() < 2e-3, "g {g}: {s}");
        }
    }
}
