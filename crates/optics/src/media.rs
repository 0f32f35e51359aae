//! Bulk optical properties of a medium made of a host and particles, and the TOML recipe format
//! (documented in `docs/media.md`).
//!
//! Per wavelength λ (Frisvad, Christensen & Jensen 2007; tutorial "Bulk optical properties"):
//! σ_s = Σ_components Σ_i C_s(r_i) N_i, σ_t = Σ Σ C_t(r_i) N_i + 4π n″_host/λ, σ_a = σ_t − σ_s,
//! g = σ_s-weighted mean of the particles' g, phase function = σ_s-weighted mean of their phase functions.
//! Cross sections come from [`crate::mie`] with the host's complex index (absorbing host allowed).

use crate::mie::{self, MieWorkspace};
use crate::particles::{Bins, RadiusGrid, SizeDistribution, Spacing};
use anyhow::{anyhow, bail, Context, Result};
use num_complex::Complex64;
use rayon::prelude::*;
use serde::Deserialize;
use std::f64::consts::PI;
use std::path::Path;

/// A complex refractive index as a function of vacuum wavelength (nm).
#[derive(Clone, Debug, PartialEq)]
pub enum IndexSpectrum {
    /// The same index at every wavelength.
    Constant(Complex64),
    /// Piecewise linear in λ, held constant beyond the ends of the table.
    Tabulated {
        /// Wavelengths, nm, increasing.
        lambda_nm: Vec<f64>,
        /// Real parts n′.
        re: Vec<f64>,
        /// Imaginary parts n″ (≥ 0 absorbs).
        im: Vec<f64>,
    },
}

impl IndexSpectrum {
    /// Index at `lambda_nm`.
    pub fn eval(&self, lambda_nm: f64) -> Complex64 {
        match self {
            IndexSpectrum::Constant(c) => *c,
            IndexSpectrum::Tabulated { lambda_nm: l, re, im } => {
                let n = l.len();
                if lambda_nm <= l[0] {
                    return Complex64::new(re[0], im[0]);
                }
                if lambda_nm >= l[n - 1] {
                    return Complex64::new(re[n - 1], im[n - 1]);
                }
                let k = l.partition_point(|&x| x <= lambda_nm).clamp(1, n - 1);
                let f = (lambda_nm - l[k - 1]) / (l[k] - l[k - 1]);
                Complex64::new(re[k - 1] + f * (re[k] - re[k - 1]), im[k - 1] + f * (im[k] - im[k - 1]))
            }
        }
    }

    /// Check: finite values, n′ > 0, n″ ≥ 0, increasing wavelengths of equal-length columns.
    pub fn validate(&self) -> Result<()> {
        let check = |c: Complex64| -> Result<()> {
            if !(c.re.is_finite() && c.im.is_finite() && c.re > 0.0 && c.im >= 0.0) {
                bail!("refractive index {c} must be finite with real part > 0 and imaginary part ≥ 0");
            }
            Ok(())
        };
        match self {
            IndexSpectrum::Constant(c) => check(*c),
            IndexSpectrum::Tabulated { lambda_nm, re, im } => {
                if lambda_nm.is_empty() || lambda_nm.len() != re.len() || re.len() != im.len() {
                    bail!("index table needs lambda_nm, re and im of equal, non-zero length");
                }
                for i in 0..lambda_nm.len() {
                    if !(lambda_nm[i].is_finite() && lambda_nm[i] > 0.0) || (i > 0 && lambda_nm[i] <= lambda_nm[i - 1]) {
                        bail!("index table: lambda_nm[{i}] must be positive and increasing");
                    }
                    check(Complex64::new(re[i], im[i])).with_context(|| format!("index table row {i}"))?;
                }
                Ok(())
            }
        }
    }
}

/// One particle type: its index spectrum and discretised size distribution (already scaled).
#[derive(Clone, Debug)]
pub struct Component {
    /// Name, for reports.
    pub name: String,
    /// Complex refractive index of the particle material.
    pub index: IndexSpectrum,
    /// Radius bins with particle number per m³.
    pub bins: Bins,
}

/// Per-component share of the bulk properties.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ComponentProperties {
    /// Name of the component.
    pub name: String,
    /// Scattering coefficient of this component, m⁻¹, per wavelength.
    pub sigma_s_per_m: Vec<f64>,
    /// Extinction ΣC_t N of this component (without host absorption), m⁻¹, per wavelength.
    pub sigma_t_per_m: Vec<f64>,
    /// Asymmetry parameter of this component, per wavelength.
    pub g: Vec<f64>,
}

/// Tabulated bulk phase function.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhaseTable {
    /// Scattering angles θ, degrees, uniform from 0 to 180.
    pub theta_deg: Vec<f64>,
    /// cos θ at those angles (from 1 down to −1).
    pub cos_theta: Vec<f64>,
    /// Phase function per steradian, normalised to 1 over the sphere: `per_sr[wavelength][angle]`.
    pub per_sr: Vec<Vec<f64>>,
}

/// Bulk optical properties per wavelength.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BulkProperties {
    /// Vacuum wavelengths, nm.
    pub lambda_nm: Vec<f64>,
    /// Scattering coefficient σ_s, m⁻¹.
    pub sigma_s_per_m: Vec<f64>,
    /// Absorption coefficient σ_a = σ_t − σ_s, m⁻¹.
    pub sigma_a_per_m: Vec<f64>,
    /// Extinction coefficient σ_t, m⁻¹.
    pub sigma_t_per_m: Vec<f64>,
    /// Asymmetry parameter g (σ_s-weighted mean).
    pub g: Vec<f64>,
    /// Absorption of the host alone, 4πn″_host/λ, m⁻¹.
    pub host_sigma_a_per_m: Vec<f64>,
    /// Per-component breakdown.
    pub components: Vec<ComponentProperties>,
    /// Tabulated bulk phase function, if requested.
    pub phase: Option<PhaseTable>,
}

/// Largest number of angles of a tabulated phase function.
pub const MAX_PHASE_ANGLES: usize = 100_000;

/// Largest angular table of the phase function, series terms × angles (10⁷ entries, 160 MB).
pub const MAX_PHASE_TABLE: f64 = 1e7;

/// Largest estimated work of one [`bulk_properties`] call in recurrence steps: the sum over
/// wavelengths and radius bins of [`mie::work_estimate`], plus terms × angles per bin for the
/// phase function. 10¹⁰ steps are roughly a minute of one core; typical media (milk: 17
/// wavelengths, 800 bins, x ≲ 100) need about 10⁷.
pub const MAX_WORK: f64 = 1e10;

/// Options of [`bulk_properties`] (default: no phase table).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct BulkOptions {
    /// Number of scattering angles of the tabulated phase function (0: none). Uniform in θ over [0°, 180°].
    pub phase_angles: usize,
}


struct Accum {
    sigma_s: f64,
    sigma_t: f64,
    /// Σ C_abs N (exactly 0 for non-absorbing particles in a non-absorbing host).
    sigma_a: f64,
    g_sigma_s: f64,
    phase: Vec<f64>,
}

/// Angular functions π_n(μ_j), τ_n(μ_j) for n = 1..=terms, laid out `[n−1][j]`.
fn angular_table(mu: &[f64], terms: usize) -> (Vec<f64>, Vec<f64>) {
    let na = mu.len();
    let mut pi = vec![0.0; terms * na];
    let mut tau = vec![0.0; terms * na];
    for (j, &m) in mu.iter().enumerate() {
        let (mut p0, mut p1) = (0.0, 1.0);
        for k in 0..terms {
            let n = (k + 1) as f64;
            pi[k * na + j] = p1;
            tau[k * na + j] = n * m * p1 - (n + 1.0) * p0;
            let p2 = ((2.0 * n + 1.0) * m * p1 - (n + 1.0) * p0) / n;
            p0 = p1;
            p1 = p2;
        }
    }
    (pi, tau)
}

fn component_at(ws: &mut MieWorkspace, comp: &Component, lambda_nm: f64, n_host: Complex64, mu: &[f64]) -> Accum {
    let lambda_m = lambda_nm * 1e-9;
    let n_p = comp.index.eval(lambda_nm);
    let mut acc = Accum { sigma_s: 0.0, sigma_t: 0.0, sigma_a: 0.0, g_sigma_s: 0.0, phase: vec![0.0; mu.len()] };
    let mut weights = Vec::with_capacity(comp.bins.radius_m.len());
    for (&r, &n) in comp.bins.radius_m.iter().zip(&comp.bins.number_per_m3) {
        let s = ws.sphere(r, lambda_m, n_p, n_host);
        acc.sigma_s += s.c_sca_m2 * n;
        acc.sigma_t += s.c_ext_m2 * n;
        acc.sigma_a += s.c_abs_m2 * n;
        acc.g_sigma_s += s.eff.g * s.c_sca_m2 * n;
        weights.push(s.c_sca_m2 * n);
    }
    if mu.is_empty() || acc.sigma_s.is_nan() || acc.sigma_s <= 0.0 {
        return acc;
    }
    // Phase function: σ_s-weighted sum over the bins that carry at least 1e-9 of this component's σ_s.
    let na = mu.len();
    let threshold = 1e-9 * acc.sigma_s;
    let k0 = 2.0 * PI / lambda_m;
    let max_terms = comp
        .bins
        .radius_m
        .iter()
        .zip(&weights)
        .filter(|(_, &w)| w >= threshold)
        .map(|(&r, _)| mie::number_of_terms((n_host * (k0 * r)).norm()))
        .max()
        .unwrap_or(1);
    let (pi, tau) = angular_table(mu, max_terms);
    let (mut s1r, mut s1i, mut s2r, mut s2i) = (vec![0.0; na], vec![0.0; na], vec![0.0; na], vec![0.0; na]);
    for ((&r, _), &w) in comp.bins.radius_m.iter().zip(&comp.bins.number_per_m3).zip(&weights) {
        if w < threshold {
            continue;
        }
        ws.sphere_keep_coefficients(r, lambda_m, n_p, n_host);
        let (a, b) = ws.last_coefficients();
        let den = 4.0 * PI * mie::scattering_sum(a, b);
        if den.is_nan() || den <= 0.0 {
            continue;
        }
        s1r.iter_mut().chain(s1i.iter_mut()).chain(s2r.iter_mut()).chain(s2i.iter_mut()).for_each(|v| *v = 0.0);
        for (k, (an, bn)) in a.iter().zip(b).enumerate() {
            let nf = (k + 1) as f64;
            let c = (2.0 * nf + 1.0) / (nf * (nf + 1.0));
            let (ar, ai, br, bi) = (c * an.re, c * an.im, c * bn.re, c * bn.im);
            let pk = &pi[k * na..(k + 1) * na];
            let tk = &tau[k * na..(k + 1) * na];
            for j in 0..na {
                let (p, t) = (pk[j], tk[j]);
                s1r[j] += ar * p + br * t;
                s1i[j] += ai * p + bi * t;
                s2r[j] += ar * t + br * p;
                s2i[j] += ai * t + bi * p;
            }
        }
        let scale = w / den;
        for j in 0..na {
            acc.phase[j] += scale * (s1r[j] * s1r[j] + s1i[j] * s1i[j] + s2r[j] * s2r[j] + s2i[j] * s2i[j]);
        }
    }
    acc
}

/// Bulk properties of `host` with particle `components` at the wavelengths `lambda_nm`
/// (parallel over wavelengths and components with rayon).
pub fn bulk_properties(lambda_nm: &[f64], host: &IndexSpectrum, components: &[Component], options: &BulkOptions) -> Result<BulkProperties> {
    host.validate().context("host index")?;
    for c in components {
        c.index.validate().with_context(|| format!("particle {:?} index", c.name))?;
        for (&r, &n) in c.bins.radius_m.iter().zip(&c.bins.number_per_m3) {
            if !(r.is_finite() && r > 0.0 && n.is_finite() && n >= 0.0) {
                bail!("particle {:?}: radius bins must be positive and finite", c.name);
            }
        }
    }
    let r_maxes: Vec<f64> = components.iter().map(|c| c.bins.radius_m.iter().cloned().fold(0.0, f64::max)).collect();
    for &l in lambda_nm {
        if !(l.is_finite() && l > 0.0) {
            bail!("wavelength {l} nm must be positive and finite");
        }
        for (c, &r_max) in components.iter().zip(&r_maxes) {
            let alpha = 4.0 * PI * r_max * host.eval(l).im / (l * 1e-9);
            if alpha > mie::MAX_HOST_ATTENUATION {
                bail!(
                    "particle {:?}: the host absorbs too strongly at {} nm for radius {:.3e} m (4πr·n″/λ = {} > {})",
                    c.name,
                    crate::numfmt::short(l),
                    r_max,
                    crate::numfmt::fixed(alpha, 3),
                    mie::MAX_HOST_ATTENUATION
                );
            }
        }
    }
    let na = options.phase_angles;
    if na > MAX_PHASE_ANGLES {
        bail!("phase_angles: at most {MAX_PHASE_ANGLES} angles are supported, got {na}");
    }
    check_work(lambda_nm, host, components, na)?;
    let theta_deg: Vec<f64> = (0..na).map(|j| if na == 1 { 0.0 } else { 180.0 * j as f64 / (na - 1) as f64 }).collect();
    let mu: Vec<f64> = theta_deg.iter().map(|t| t.to_radians().cos()).collect();
    let nc = components.len();
    // One task per (wavelength, component), each with a thread-local workspace.
    let tasks: Vec<(usize, usize)> = (0..lambda_nm.len()).flat_map(|w| (0..nc).map(move |c| (w, c))).collect();
    let results: Vec<Accum> = tasks
        .par_iter()
        .map_init(MieWorkspace::new, |ws, &(w, c)| {
            let l = lambda_nm[w];
            component_at(ws, &components[c], l, host.eval(l), &mu)
        })
        .collect();
    let mut out = BulkProperties {
        lambda_nm: lambda_nm.to_vec(),
        components: components
            .iter()
            .map(|c| ComponentProperties { name: c.name.clone(), ..Default::default() })
            .collect(),
        ..Default::default()
    };
    let mut phase = PhaseTable { theta_deg, cos_theta: mu.clone(), per_sr: Vec::new() };
    for (w, &l) in lambda_nm.iter().enumerate() {
        let lambda_m = l * 1e-9;
        let host_sa = 4.0 * PI * host.eval(l).im / lambda_m;
        let (mut ss, mut sa, mut gs) = (0.0, 0.0, 0.0);
        let mut p = vec![0.0; mu.len()];
        for c in 0..nc {
            let a = &results[w * nc + c];
            ss += a.sigma_s;
            sa += a.sigma_a;
            gs += a.g_sigma_s;
            for (pj, aj) in p.iter_mut().zip(&a.phase) {
                *pj += aj;
            }
            let cp = &mut out.components[c];
            cp.sigma_s_per_m.push(a.sigma_s);
            cp.sigma_t_per_m.push(a.sigma_t);
            cp.g.push(if a.sigma_s > 0.0 { a.g_sigma_s / a.sigma_s } else { 0.0 });
        }
        // σ_a from the absorption cross sections (so exactly 0 for a non-absorbing medium, not a
        // round-off difference of σ_t and σ_s); a negative round-off of σ_a is clamped to 0.
        sa += host_sa;
        if sa < 0.0 && -sa <= 1e-9 * (ss + sa.abs()) {
            sa = 0.0;
        }
        out.sigma_s_per_m.push(ss);
        out.sigma_t_per_m.push(ss + sa);
        out.sigma_a_per_m.push(sa);
        out.g.push(if ss > 0.0 { gs / ss } else { 0.0 });
        out.host_sigma_a_per_m.push(host_sa);
        if na > 0 {
            if ss > 0.0 {
                p.iter_mut().for_each(|v| *v /= ss);
            } else {
                p.iter_mut().for_each(|v| *v = 1.0 / (4.0 * PI));
            }
            phase.per_sr.push(p);
        }
    }
    if na > 0 {
        out.phase = Some(phase);
    }
    Ok(out)
}

/// Refuses, before any allocation, sizes outside [`mie::check_size`] and jobs whose estimated
/// work exceeds [`MAX_WORK`] or whose phase table exceeds [`MAX_PHASE_TABLE`].
fn check_work(lambda_nm: &[f64], host: &IndexSpectrum, components: &[Component], na: usize) -> Result<()> {
    let mut work = 0.0;
    let size_error = |c: &Component, l: f64, r: f64, e: anyhow::Error| {
        anyhow!("particle {:?} at {l} nm, radius {:.4e} µm: {e}", c.name, r * 1e6)
    };
    let extremes: Vec<(f64, f64)> = components
        .iter()
        .map(|c| {
            let r = &c.bins.radius_m;
            (r.iter().cloned().fold(f64::INFINITY, f64::min), r.iter().cloned().fold(0.0, f64::max))
        })
        .collect();
    for &l in lambda_nm {
        let n_host = host.eval(l);
        let k0 = 2.0 * PI / (l * 1e-9);
        for (c, &(r_min, r_max)) in components.iter().zip(&extremes) {
            let m = c.index.eval(l) / n_host;
            if c.bins.radius_m.is_empty() {
                continue;
            }
            for r in [r_max, r_min] {
                mie::check_size(n_host * (k0 * r), m).map_err(|e| size_error(c, l, r, e))?;
            }
            let x_max = n_host * (k0 * r_max);
            let terms = (x_max.norm() + 4.3 * x_max.norm().cbrt() + 1.0).ceil();
            if terms * na as f64 > MAX_PHASE_TABLE {
                bail!(
                    "particle {:?} at {l} nm: a phase table of {na} angles × {terms} series terms exceeds the supported {MAX_PHASE_TABLE:e} entries (use fewer phase angles)",
                    c.name
                );
            }
            work += c.bins.radius_m.len() as f64 * (mie::work_estimate(x_max, m) + terms * na as f64);
        }
    }
    if work.is_nan() || work > MAX_WORK {
        bail!(
            "the medium needs about {work:.2e} recurrence steps ({} wavelengths × radius bins × series terms), above the supported {MAX_WORK:e}: use fewer wavelengths, bins or phase angles",
            lambda_nm.len()
        );
    }
    // Every bin (the unsupported sizes need not lie at the ends of the grid).
    for &l in lambda_nm {
        let n_host = host.eval(l);
        let k0 = 2.0 * PI / (l * 1e-9);
        for c in components {
            let m = c.index.eval(l) / n_host;
            for &r in &c.bins.radius_m {
                mie::check_size(n_host * (k0 * r), m).map_err(|e| size_error(c, l, r, e))?;
            }
        }
    }
    Ok(())
}

/// Parse a wavelength list: `START:STOP:STEP` (inclusive) or comma-separated values, in nm.
pub fn parse_wavelengths_nm(s: &str) -> Result<Vec<f64>> {
    let bad = || anyhow!("malformed wavelength list {s:?} (expected START:STOP:STEP or a,b,c in nm)");
    let num = |v: &str| -> Result<f64> {
        let f: f64 = v.trim().parse().map_err(|_| bad())?;
        if !(f.is_finite() && f > 0.0) {
            bail!("wavelength {v:?} in {s:?} must be positive and finite");
        }
        Ok(f)
    };
    let out: Vec<f64> = if s.contains(':') {
        let p: Vec<&str> = s.split(':').collect();
        if p.len() != 3 {
            return Err(bad());
        }
        let (a, b, d) = (num(p[0])?, num(p[1])?, num(p[2])?);
        if b < a {
            return Err(bad());
        }
        let n = ((b - a) / d + 1e-9).floor() as usize;
        if n > 100_000 {
            bail!("wavelength list {s:?} has too many samples");
        }
        (0..=n).map(|i| a + i as f64 * d).collect()
    } else {
        s.split(',').map(num).collect::<Result<_>>()?
    };
    if out.is_empty() {
        return Err(bad());
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Recipe (TOML)

/// An index given in a recipe: a number, a complex string like "1.46+5e-6i", or a table.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum IndexSpec {
    /// Real constant.
    Real(f64),
    /// Complex constant, `RE+IMi`.
    Text(String),
    /// Table over wavelength.
    Table {
        /// Wavelengths, nm.
        lambda_nm: Vec<f64>,
        /// Real parts.
        re: Vec<f64>,
        /// Imaginary parts (default 0).
        #[serde(default)]
        im: Vec<f64>,
    },
}

impl IndexSpec {
    /// Convert to an [`IndexSpectrum`], validated.
    pub fn to_spectrum(&self) -> Result<IndexSpectrum> {
        let s = match self {
            IndexSpec::Real(v) => IndexSpectrum::Constant(Complex64::new(*v, 0.0)),
            IndexSpec::Text(t) => IndexSpectrum::Constant(mie::parse_complex(t)?),
            IndexSpec::Table { lambda_nm, re, im } => {
                let im = if im.is_empty() { vec![0.0; re.len()] } else { im.clone() };
                IndexSpectrum::Tabulated { lambda_nm: lambda_nm.clone(), re: re.clone(), im }
            }
        };
        s.validate()?;
        Ok(s)
    }
}

/// Size distribution in a recipe (radii in µm).
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "distribution", rename_all = "kebab-case")]
pub enum SizeSpec {
    /// Frisvad et al. 2007 log-normal (volume weights), r_vs and c_s in µm.
    Lognormal {
        /// Volume-to-surface mean radius, µm.
        r_vs_um: f64,
        /// Standard deviation, µm.
        c_s_um: f64,
    },
    /// Log-normal in t = r/(r_max − r); c_s in t.
    BoundedLognormal {
        /// Volume-to-surface mean radius, µm.
        r_vs_um: f64,
        /// Standard deviation in t (dimensionless).
        c_s: f64,
        /// Maximum radius, µm.
        r_max_um: f64,
    },
    /// Tabulated relative number density.
    Tabulated {
        /// Radii, µm.
        radius_um: Vec<f64>,
        /// Relative number densities.
        number_density: Vec<f64>,
    },
    /// One radius.
    Monodisperse {
        /// Radius, µm.
        radius_um: f64,
    },
}

/// Radius grid in a recipe (µm); every field optional.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Smallest radius, µm.
    pub r_min_um: Option<f64>,
    /// Largest radius, µm.
    pub r_max_um: Option<f64>,
    /// Number of bins (default 400).
    pub bins: Option<usize>,
    /// "linear" or "log" (default "log").
    pub spacing: Option<String>,
}

/// Host of a recipe.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostSpec {
    /// Complex index of the host (n″ ≥ 0 absorbs).
    pub index: IndexSpec,
}

/// One particle type of a recipe.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleSpec {
    /// Name.
    pub name: String,
    /// Complex index of the particle material.
    pub index: IndexSpec,
    /// Volume fraction (0..1); or give `weight_percent` and `density_g_per_ml`.
    pub volume_fraction: Option<f64>,
    /// Content in weight percent of the medium.
    pub weight_percent: Option<f64>,
    /// Density of the particle material, g/mL.
    pub density_g_per_ml: Option<f64>,
    /// Size distribution.
    pub size: SizeSpec,
    /// Radius grid.
    #[serde(default)]
    pub grid: GridSpec,
}

/// A medium recipe: host, particles, optional wavelengths. See `docs/media.md`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    /// Name of the medium.
    #[serde(default)]
    pub name: String,
    /// Density of the whole medium, g/mL (needed for weight fractions).
    pub density_g_per_ml: Option<f64>,
    /// Wavelengths, nm: a list, or "START:STOP:STEP".
    pub wavelengths_nm: Option<WavelengthSpec>,
    /// Number of angles of the tabulated phase function (0 = none).
    #[serde(default)]
    pub phase_angles: usize,
    /// The host.
    pub host: HostSpec,
    /// Particle types.
    #[serde(default, rename = "particle")]
    pub particles: Vec<ParticleSpec>,
}

/// Wavelengths in a recipe.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum WavelengthSpec {
    /// Explicit list, nm.
    List(Vec<f64>),
    /// "START:STOP:STEP", nm.
    Range(String),
}

impl WavelengthSpec {
    /// The wavelengths in nm.
    pub fn to_vec(&self) -> Result<Vec<f64>> {
        match self {
            WavelengthSpec::List(v) => parse_wavelengths_nm(&v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(",")),
            WavelengthSpec::Range(s) => parse_wavelengths_nm(s),
        }
    }
}

fn um(v: f64, field: &str) -> Result<f64> {
    if !(v.is_finite() && v > 0.0) {
        bail!("{field} must be a positive finite number, got {v}");
    }
    Ok(v * 1e-6)
}

impl Recipe {
    /// Parse a recipe from TOML text (errors name the line and field).
    pub fn from_toml(text: &str) -> Result<Recipe> {
        let r: Recipe = toml::from_str(text).map_err(|e| {
            // "line L, column C (`the line`): message" on one line, not the multi-line snippet.
            let at = e.span().map(|s| {
                let start = s.start.min(text.len());
                let before = &text[..start];
                let line = before.matches('\n').count() + 1;
                let col = before.chars().rev().take_while(|&c| c != '\n').count() + 1;
                let from = before.rfind('\n').map_or(0, |i| i + 1);
                let src: String = text[from..].lines().next().unwrap_or("").trim().chars().take(80).collect();
                format!("line {line}, column {col} (`{src}`): ")
            });
            let msg: Vec<&str> = e.message().lines().map(str::trim).filter(|l| !l.is_empty()).collect();
            anyhow!("{}{}", at.unwrap_or_default(), msg.join("; "))
        })?;
        Ok(r)
    }

    /// Read a recipe file.
    pub fn load(path: &Path) -> Result<Recipe> {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read recipe {}", path.display()))?;
        Recipe::from_toml(&text).with_context(|| format!("recipe {}", path.display()))
    }

    /// The wavelengths of the recipe, or 375:775:25 nm.
    pub fn wavelengths_nm(&self) -> Result<Vec<f64>> {
        match &self.wavelengths_nm {
            Some(w) => w.to_vec().context("field wavelengths_nm"),
            None => parse_wavelengths_nm("375:775:25"),
        }
    }

    /// Host index and scaled particle components.
    pub fn components(&self) -> Result<(IndexSpectrum, Vec<Component>)> {
        let host = self.host.index.to_spectrum().context("field host.index")?;
        let mut comps = Vec::new();
        for (i, p) in self.particles.iter().enumerate() {
            let ctx = || format!("particle[{i}] ({})", p.name);
            let index = p.index.to_spectrum().with_context(|| format!("{}: field index", ctx()))?;
            let vf = match (p.volume_fraction, p.weight_percent) {
                (Some(v), None) => v,
                (None, Some(w)) => {
                    let rho_p = p.density_g_per_ml.ok_or_else(|| anyhow!("{}: weight_percent needs density_g_per_ml", ctx()))?;
                    let rho_m = self.density_g_per_ml.ok_or_else(|| anyhow!("{}: weight_percent needs the medium's density_g_per_ml", ctx()))?;
                    if !(w.is_finite() && (0.0..=100.0).contains(&w)) {
                        bail!("{}: weight_percent must lie in [0, 100], got {w}", ctx());
                    }
                    if !(rho_p.is_finite() && rho_p > 0.0 && rho_m.is_finite() && rho_m > 0.0) {
                        bail!("{}: densities must be positive", ctx());
                    }
                    (w / rho_p) / (100.0 / rho_m)
                }
                _ => bail!("{}: give exactly one of volume_fraction or weight_percent", ctx()),
            };
            if !(vf.is_finite() && (0.0..=1.0).contains(&vf)) {
                bail!("{}: volume fraction must lie in [0, 1], got {vf}", ctx());
            }
            let dist = match &p.size {
                SizeSpec::Lognormal { r_vs_um, c_s_um } => SizeDistribution::LogNormal { r_vs_m: um(*r_vs_um, "size.r_vs_um")?, c_s_m: um(*c_s_um, "size.c_s_um")? },
                SizeSpec::BoundedLognormal { r_vs_um, c_s, r_max_um } => SizeDistribution::BoundedLogNormal {
                    r_vs_m: um(*r_vs_um, "size.r_vs_um")?,
                    c_s_t: *c_s,
                    r_max_m: um(*r_max_um, "size.r_max_um")?,
                },
                SizeSpec::Tabulated { radius_um, number_density } => SizeDistribution::Tabulated {
                    radius_m: radius_um.iter().map(|r| r * 1e-6).collect(),
                    number_density: number_density.clone(),
                },
                SizeSpec::Monodisperse { radius_um } => SizeDistribution::Monodisperse { radius_m: um(*radius_um, "size.radius_um")? },
            };
            dist.validate().with_context(|| format!("{}: field size", ctx()))?;
            let bins_n = p.grid.bins.unwrap_or(400);
            let mut grid = dist.default_grid(bins_n);
            if let Some(v) = p.grid.r_min_um {
                grid.r_min_m = v * 1e-6;
            }
            if let Some(v) = p.grid.r_max_um {
                grid.r_max_m = v * 1e-6;
            }
            grid.spacing = match p.grid.spacing.as_deref() {
                None | Some("log") => Spacing::Log,
                Some("linear") => Spacing::Linear,
                Some(o) => bail!("{}: grid.spacing must be \"linear\" or \"log\", got {o:?}", ctx()),
            };
            if bins_n == 0 || bins_n > 1_000_000 {
                bail!("{}: grid.bins must lie in 1..=1000000", ctx());
            }
            let bins = dist.discretize(&grid, vf).with_context(|| format!("{}: fields size/grid", ctx()))?;
            comps.push(Component { name: p.name.clone(), index, bins });
        }
        Ok((host, comps))
    }

    /// Bulk properties at `lambda_nm` (or the recipe's wavelengths when `None`).
    pub fn bulk_properties(&self, lambda_nm: Option<&[f64]>) -> Result<BulkProperties> {
        let (host, comps) = self.components()?;
        let l = match lambda_nm {
            Some(l) => l.to_vec(),
            None => self.wavelengths_nm()?,
        };
        if self.phase_angles > MAX_PHASE_ANGLES {
            bail!("field phase_angles: at most {MAX_PHASE_ANGLES}, got {}", self.phase_angles);
        }
        bulk_properties(&l, &host, &comps, &BulkOptions { phase_angles: self.phase_angles })
    }
}

/// A grid of radii with linear spacing, convenience for callers.
pub fn linear_grid(r_min_m: f64, r_max_m: f64, bins: usize) -> RadiusGrid {
    RadiusGrid { r_min_m, r_max_m, bins, spacing: Spacing::Linear }
}
