//! Monte Carlo photon transport in a stack of plane-parallel layers (MCML-style reference).
//!
//! The algorithm follows Wang, Jacques & Zheng, "MCML — Monte Carlo modeling of light
//! transport in multi-layered tissues", Comput. Methods Programs Biomed. 47 (1995) 131–146:
//! a pencil beam enters at normal incidence at the origin; each photon packet carries a
//! weight; free paths are sampled with dimensionless optical depth −ln ξ, spent across
//! layers; at each interaction a fraction σ_a/σ_t of the weight is absorbed and the packet is
//! scattered with the Henyey–Greenstein phase function; at interfaces between different
//! refractive indices the packet is reflected or transmitted with the Fresnel probability
//! (all-or-none); packets below a weight threshold play Russian roulette. (MCML writes the
//! coefficients μa, μs; this project writes σ_a, σ_s, as in pbrt and the radiative-transfer
//! literature. The field names `mua_per_mm`, `mus_per_mm` keep MCML's spelling.)
//!
//! Termination: every walk ends with probability 1 except one, which [`validate`] refuses: a
//! semi-infinite layer that scatters but does not absorb (σ_a = 0, σ_s > 0). There a packet's
//! return to the surface is certain but its expected number of steps is infinite (the
//! first-return time of a random walk in a half-space has a tail ∝ n^(−1/2); Feller, *An
//! Introduction to Probability Theory and Its Applications* I, ch. III), so a run of N photons
//! needs of order N² steps. Tiny absorption has the same tail up to ~σ_t/σ_a steps, so each packet
//! is also held to [`SlabSettings::max_steps_per_photon`] free flights: a packet still alive then is
//! dropped and counted ([`SlabResult::photons_truncated`]), and its weight
//! ([`SlabResult::truncated_weight`]) is missing from R_d, the absorbed fraction and T_t, each of
//! which is therefore biased low by at most that amount (their sum by exactly that amount). The
//! default cap, 10⁶ steps, is not reached in practice in media of albedo up to 0.9999: a packet's
//! weight falls below the roulette threshold within ~10⁵ steps, and each further ~2·10⁴ steps
//! need a roulette survival of probability 1/10.
//!
//! Units: lengths in millimetres and coefficients in mm⁻¹ (the conventional units of tissue
//! optics, and those of the `lucent slab` command); every field names its unit.
//!
//! Validation (seed 1; see `tests/slab.rs` for the fast versions with 3σ tolerances):
//!
//! | case | published | lucent slab |
//! |---|---|---|
//! | n = 1, σ_a = 1, σ_s = 9 mm⁻¹, g = 0.75, d = 0.2 mm: R_d (van de Hulst, via MCML) | 0.09739 | 0.09748 ± 0.00007 (10⁷ photons) |
//! | same: T_t | 0.66096 | 0.66088 ± 0.00010 |
//! | semi-infinite, n = 1.5, albedo 0.9, g = 0: R_sp + R_d (Giovanelli 1955) | 0.2600 | 0.25995 ± 0.00013 (5·10⁶) |
//! | semi-infinite, n = 1, albedo 0.9, g = 0: 1 − H(1)√(1−a) (Chandrasekhar) | 0.41495 | 0.41488 ± 0.00035 (10⁶) |
//!
//! Geometry: z points down into the stack; layer 0 is on top, between the ambient medium
//! above (index `n_above`) and layer 1; the last layer may be semi-infinite.

use anyhow::{bail, Result};
use crate::fresnel::{cos_theta_transmitted, fresnel_dielectric};
use crate::phase::HenyeyGreenstein;
use rayon::prelude::*;
use std::time::Instant;

/// One plane-parallel layer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// Absorption coefficient σ_a in mm⁻¹ (≥ 0; MCML's μa).
    pub mua_per_mm: f64,
    /// Scattering coefficient σ_s in mm⁻¹ (≥ 0; MCML's μs).
    pub mus_per_mm: f64,
    /// Henyey–Greenstein asymmetry parameter, −1 < g < 1.
    pub g: f64,
    /// Refractive index (> 0).
    pub n: f64,
    /// Thickness in mm (> 0); `f64::INFINITY` for a semi-infinite last layer (which must absorb
    /// if it scatters: see the module notes on termination).
    pub thickness_mm: f64,
}

impl Layer {
    /// Check the values of one layer; the error names the field (SIGMA_A, SIGMA_S, G, N,
    /// THICKNESS_MM, as in `lucent slab --layer`).
    pub fn validate(&self) -> Result<()> {
        let l = self;
        if !(l.mua_per_mm.is_finite() && l.mua_per_mm >= 0.0) {
            bail!(
                "absorption coefficient SIGMA_A = {} must be finite and >= 0 (mm⁻¹)",
                l.mua_per_mm
            );
        }
        if !(l.mus_per_mm.is_finite() && l.mus_per_mm >= 0.0) {
            bail!(
                "scattering coefficient SIGMA_S = {} must be finite and >= 0 (mm⁻¹)",
                l.mus_per_mm
            );
        }
        if !(l.g > -1.0 && l.g < 1.0) {
            bail!("anisotropy G = {} must lie in (-1, 1)", l.g);
        }
        if !(l.n.is_finite() && l.n > 0.0) {
            bail!("refractive index N = {} must be finite and > 0", l.n);
        }
        if l.thickness_mm.is_nan() || l.thickness_mm <= 0.0 {
            bail!("THICKNESS_MM = {} must be > 0 (or inf)", l.thickness_mm);
        }
        Ok(())
    }
}

/// Histogram of the diffuse reflectance over the distance r from the entry point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadialGrid {
    /// Number of annular bins of equal width over [0, `max_mm`].
    pub bins: usize,
    /// Outer radius of the last bin in mm.
    pub max_mm: f64,
}

/// Reflectance along the x axis (the plane of incidence) in a strip |y| < Δx/2, for oblique
/// incidence reflectometry: bins of width Δx = 2·`max_mm`/`bins` over [−`max_mm`, `max_mm`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineGrid {
    /// Number of bins along x.
    pub bins: usize,
    /// Half length of the line in mm.
    pub max_mm: f64,
}

/// Default outer radius (or half length) of the resolved tallies in mm: ten transport mean free
/// paths 1/(σ_a + σ_s(1 − g)) of the top layer, 10 mm when that layer neither absorbs nor scatters.
pub fn default_tally_max_mm(layers: &[Layer]) -> f64 {
    let Some(l) = layers.first() else { return 10.0 };
    let mu_tr = l.mua_per_mm + l.mus_per_mm * (1.0 - l.g);
    if mu_tr > 0.0 {
        10.0 / mu_tr
    } else {
        10.0
    }
}

/// Everything a slab simulation needs.
#[derive(Clone, Debug)]
pub struct SlabSettings {
    /// Layers from top to bottom.
    pub layers: Vec<Layer>,
    /// Refractive index of the ambient medium above the stack.
    pub n_above: f64,
    /// Refractive index of the ambient medium below the stack.
    pub n_below: f64,
    /// Number of photon packets launched.
    pub photons: u64,
    /// Seed of the random sequence (results are identical for equal seeds and photon counts,
    /// whatever the number of threads).
    pub seed: u64,
    /// Radially resolved diffuse reflectance, if wanted.
    pub radial: Option<RadialGrid>,
    /// Angle of the incident beam from the normal in the ambient medium above, in degrees
    /// (0 = normal incidence; the beam travels towards +x), in [0, 90).
    pub incidence_deg: f64,
    /// Diffuse reflectance along the x axis, if wanted.
    pub line: Option<LineGrid>,
    /// Most free-flight steps one packet may take (≥ 1); a packet still alive after them is
    /// dropped and counted in [`SlabResult::photons_truncated`] (see the module notes).
    pub max_steps_per_photon: u64,
}

impl SlabSettings {
    /// Settings for a normally incident beam in air above and below, 10⁶ photons, seed 1,
    /// no resolved tallies, [`DEFAULT_MAX_STEPS_PER_PHOTON`].
    pub fn new(layers: Vec<Layer>) -> Self {
        SlabSettings {
            layers,
            n_above: 1.0,
            n_below: 1.0,
            photons: 1_000_000,
            seed: 1,
            radial: None,
            incidence_deg: 0.0,
            line: None,
            max_steps_per_photon: DEFAULT_MAX_STEPS_PER_PHOTON,
        }
    }
}

/// Radially resolved diffuse reflectance R(r).
#[derive(Clone, Debug, PartialEq)]
pub struct RadialReflectance {
    /// Bin centres in mm (bin k spans [k·Δr, (k+1)·Δr]).
    pub r_mm: Vec<f64>,
    /// Bin width Δr in mm.
    pub dr_mm: f64,
    /// R(r): escaping weight per unit area per incident photon, in mm⁻².
    pub rd_per_mm2: Vec<f64>,
    /// Standard error of each bin in mm⁻².
    pub rd_per_mm2_stderr: Vec<f64>,
    /// Fraction of incident photons escaping on top beyond the last bin (dimensionless).
    pub rd_beyond_max: f64,
}

/// Diffuse reflectance along the x axis, R(x, y ≈ 0).
#[derive(Clone, Debug, PartialEq)]
pub struct LineReflectance {
    /// Bin centres in mm.
    pub x_mm: Vec<f64>,
    /// Bin width (and strip width) Δx in mm.
    pub dx_mm: f64,
    /// Escaping weight per unit area per incident photon in the bin's Δx × Δx cell, mm⁻².
    pub rd_per_mm2: Vec<f64>,
    /// Standard error of each bin in mm⁻².
    pub rd_per_mm2_stderr: Vec<f64>,
}

/// Result of a slab simulation: fractions of the incident power (dimensionless).
#[derive(Clone, Debug, PartialEq)]
pub struct SlabResult {
    /// Specular reflectance at the top surface (the part of the beam never entering).
    pub specular: f64,
    /// Diffuse reflectance R_d (all weight leaving through the top after entering).
    pub rd: f64,
    /// Standard error of `rd` (from the per-photon variance).
    pub rd_stderr: f64,
    /// Absorbed fraction, all layers.
    pub absorbed: f64,
    /// Standard error of `absorbed`.
    pub absorbed_stderr: f64,
    /// Absorbed fraction per layer.
    pub absorbed_per_layer: Vec<f64>,
    /// Total transmittance T_t (unscattered + diffuse) through the bottom.
    pub tt: f64,
    /// Standard error of `tt`.
    pub tt_stderr: f64,
    /// Net weight created by Russian roulette per photon (zero in expectation): the tallies
    /// satisfy specular + rd + absorbed + tt + truncated_weight − roulette_gain = 1 to rounding.
    pub roulette_gain: f64,
    /// Packets dropped alive at [`SlabSettings::max_steps_per_photon`] (0 in ordinary media).
    pub photons_truncated: u64,
    /// Their weight per incident photon (dimensionless): what R_d, absorbed and T_t together
    /// miss, so each is biased low by at most this much.
    pub truncated_weight: f64,
    /// R(r) when a radial grid was requested.
    pub radial: Option<RadialReflectance>,
    /// R(x, 0) when a line grid was requested.
    pub line: Option<LineReflectance>,
    /// Mean x of the diffusely reflected weight in mm (the "diffuse centre" shifts towards +x
    /// under oblique incidence).
    pub rd_centroid_x_mm: f64,
    /// Photon packets launched.
    pub photons: u64,
    /// Free-flight steps taken (to an interaction or to an interface).
    pub photon_steps: u64,
    /// Wall-clock time of the transport in seconds.
    pub seconds: f64,
    /// CPU time spent in transport, summed over threads, in seconds (Linux: from
    /// /proc/thread-self/schedstat; `None` elsewhere). Unlike `seconds` it does not grow when
    /// other processes compete for the cores.
    pub cpu_seconds: Option<f64>,
    /// Threads used.
    pub threads: usize,
}

impl SlabResult {
    /// Throughput: photon steps per second of wall-clock time, all threads together.
    pub fn photon_steps_per_s(&self) -> f64 {
        self.photon_steps as f64 / self.seconds.max(1e-12)
    }

    /// Throughput per core: photon steps per second of CPU time (None if CPU time is unknown).
    pub fn photon_steps_per_cpu_s(&self) -> Option<f64> {
        self.cpu_seconds
            .map(|c| self.photon_steps as f64 / c.max(1e-12))
    }
}

/// Check the settings; errors name the layer (1-based) and the field.
pub fn validate(settings: &SlabSettings) -> Result<()> {
    if settings.layers.is_empty() {
        bail!("at least one layer is needed");
    }
    let last = settings.layers.len() - 1;
    for (i, l) in settings.layers.iter().enumerate() {
        l.validate()
            .map_err(|e| anyhow::anyhow!("layer {}: {e}", i + 1))?;
        if l.thickness_mm.is_infinite() && i != last {
            bail!(
                "layer {}: only the last layer may be semi-infinite (THICKNESS_MM = inf)",
                i + 1
            );
        }
        if l.thickness_mm.is_infinite() && l.mua_per_mm == 0.0 && l.mus_per_mm > 0.0 {
            bail!(
                "layer {}: a semi-infinite layer that scatters needs absorption SIGMA_A > 0 (got 0): \
                 without it a photon's walk has no bounded expected length and the run would not end; \
                 give SIGMA_A > 0 or a finite THICKNESS_MM",
                i + 1
            );
        }
    }
    for (name, n) in [("n-above", settings.n_above), ("n-below", settings.n_below)] {
        if !(n.is_finite() && n > 0.0) {
            bail!("{name} = {n} must be finite and > 0");
        }
    }
    if settings.photons == 0 {
        bail!("photons must be at least 1");
    }
    // 10^12 packets take days on a workstation; more is a mistyped count, not a simulation.
    if settings.photons > 1_000_000_000_000 {
        bail!("photons must be at most 10^12, got {}", settings.photons);
    }
    if settings.max_steps_per_photon == 0 {
        bail!("max-steps-per-photon must be at least 1");
    }
    if !(settings.incidence_deg >= 0.0 && settings.incidence_deg < 90.0) {
        bail!(
            "incidence-deg = {} must lie in [0, 90)",
            settings.incidence_deg
        );
    }
    if let Some(g) = settings.line {
        if g.bins == 0 || g.bins > MAX_BINS {
            bail!("line-bins = {} must be between 1 and {MAX_BINS}", g.bins);
        }
        if !(g.max_mm.is_finite() && g.max_mm > 0.0) {
            bail!("line-max-mm = {} must be finite and > 0", g.max_mm);
        }
    }
    if let Some(g) = settings.radial {
        if g.bins == 0 || g.bins > MAX_BINS {
            bail!("radial-bins = {} must be between 1 and {MAX_BINS}", g.bins);
        }
        if !(g.max_mm.is_finite() && g.max_mm > 0.0) {
            bail!("radial-max-mm = {} must be finite and > 0", g.max_mm);
        }
    }
    Ok(())
}

/// Photons per independently seeded chunk (the unit of parallel work).
const CHUNK: u64 = 1 << 13;
/// Chunks run in parallel before their tallies are summed.
const GROUP: u64 = 64;
/// Most bins a histogram may have.
pub const MAX_BINS: usize = 100_000;
/// Default of [`SlabSettings::max_steps_per_photon`]: ~0.05 s of one core per packet at worst.
pub const DEFAULT_MAX_STEPS_PER_PHOTON: u64 = 1_000_000;
/// Russian roulette: packets below this weight survive with probability 1/ROULETTE_M.
const WEIGHT_THRESHOLD: f64 = 1e-4;
const ROULETTE_M: f64 = 10.0;

/// Run the simulation on the current rayon pool.
pub fn simulate(settings: &SlabSettings) -> Result<SlabResult> {
    validate(settings)?;
    let layers = prepare(settings);
    let n0 = settings.n_above;
    let n1 = settings.layers[0].n;
    let theta_i = settings.incidence_deg.to_radians();
    let specular = fresnel_dielectric(theta_i.cos(), n1 / n0);
    // Refracted launch direction in the top layer (Snell), travelling towards +x.
    let sin_t = n0 / n1 * theta_i.sin();
    let launch = [sin_t, 0.0, (1.0 - sin_t * sin_t).sqrt()];
    let line_bins = settings.line.map(|g| g.bins).unwrap_or(0);
    let line_max_mm = settings.line.map(|g| g.max_mm).unwrap_or(1.0);
    let dx_mm = 2.0 * line_max_mm / line_bins.max(1) as f64;
    let bins = settings.radial.map(|g| g.bins).unwrap_or(0);
    let dr_mm = settings
        .radial
        .map(|g| g.max_mm / g.bins as f64)
        .unwrap_or(1.0);
    let ctx = Ctx {
        layers: &layers,
        w0: 1.0 - specular,
        launch,
        bins,
        inv_dr: 1.0 / dr_mm,
        line_bins,
        line_max_mm,
        inv_dx: 1.0 / dx_mm,
        max_steps: settings.max_steps_per_photon,
    };
    let chunks = settings.photons.div_ceil(CHUNK);
    let start = Instant::now();
    let run_chunk = |c: u64| {
        let n = CHUNK.min(settings.photons - c * CHUNK);
        let mut rng = Rng::new(settings.seed, c);
        let mut t = Tally::new(layers.len(), bins, line_bins);
        let cpu0 = thread_cpu_ns();
        for _ in 0..n {
            ctx.trace(&mut rng, &mut t);
        }
        t.cpu_ns = match (cpu0, thread_cpu_ns()) {
            (Some(a), Some(b)) => Some(b.saturating_sub(a)),
            _ => None,
        };
        t
    };
    // Chunks run in parallel in groups (bounded memory for the histograms) and are summed in
    // chunk order: the result is deterministic whatever the scheduling and thread count.
    let mut total = Tally::new(layers.len(), bins, line_bins);
    let mut first = 0;
    while first < chunks {
        let last = (first + GROUP).min(chunks);
        let parts: Vec<Tally> = (first..last).into_par_iter().map(run_chunk).collect();
        for p in &parts {
            total.add(p);
        }
        first = last;
    }
    let seconds = start.elapsed().as_secs_f64();
    let n = settings.photons as f64;
    let stderr = |s: f64, s2: f64| {
        if settings.photons < 2 {
            return f64::NAN;
        }
        let mean = s / n;
        ((s2 / n - mean * mean).max(0.0) / (n - 1.0)).sqrt()
    };
    let radial = settings.radial.map(|g| {
        let mut r_mm = Vec::with_capacity(g.bins);
        let mut rd = Vec::with_capacity(g.bins);
        let mut se = Vec::with_capacity(g.bins);
        for k in 0..g.bins {
            let (r0, r1) = (k as f64 * dr_mm, (k + 1) as f64 * dr_mm);
            let area = std::f64::consts::PI * (r1 * r1 - r0 * r0);
            r_mm.push(0.5 * (r0 + r1));
            rd.push(total.radial[k] / n / area);
            se.push(stderr(total.radial[k], total.radial_sq[k]) / area);
        }
        RadialReflectance {
            r_mm,
            dr_mm,
            rd_per_mm2: rd,
            rd_per_mm2_stderr: se,
            rd_beyond_max: total.rd_beyond / n,
        }
    });
    let line = settings.line.map(|g| {
        let area = dx_mm * dx_mm;
        LineReflectance {
            x_mm: (0..g.bins)
                .map(|k| -g.max_mm + (k as f64 + 0.5) * dx_mm)
                .collect(),
            dx_mm,
            rd_per_mm2: total.line.iter().map(|v| v / n / area).collect(),
            rd_per_mm2_stderr: total
                .line
                .iter()
                .zip(&total.line_sq)
                .map(|(v, v2)| stderr(*v, *v2) / area)
                .collect(),
        }
    });
    Ok(SlabResult {
        line,
        rd_centroid_x_mm: if total.rd > 0.0 {
            total.rd_x / total.rd
        } else {
            0.0
        },
        specular,
        rd: total.rd / n,
        rd_stderr: stderr(total.rd, total.rd_sq),
        absorbed: total.absorbed / n,
        absorbed_stderr: stderr(total.absorbed, total.absorbed_sq),
        absorbed_per_layer: total.absorbed_layer.iter().map(|a| a / n).collect(),
        tt: total.tt / n,
        tt_stderr: stderr(total.tt, total.tt_sq),
        roulette_gain: total.roulette_gain / n,
        photons_truncated: total.truncated,
        truncated_weight: total.truncated_weight / n,
        radial,
        photons: settings.photons,
        photon_steps: total.steps,
        seconds,
        cpu_seconds: total.cpu_ns.filter(|&ns| ns > 0).map(|ns| ns as f64 * 1e-9),
        threads: rayon::current_num_threads(),
    })
}

/// Per-layer constants of the transport loop.
#[derive(Clone, Copy, Debug)]
struct LayerData {
    z0_mm: f64,
    z1_mm: f64,
    mut_per_mm: f64,
    inv_mut_mm: f64,
    absorb_fraction: f64,
    hg: HenyeyGreenstein,
    n: f64,
    /// Index above and below this layer (neighbour layer or ambient).
    n_up: f64,
    n_down: f64,
}

fn prepare(s: &SlabSettings) -> Vec<LayerData> {
    let mut z = 0.0;
    let count = s.layers.len();
    s.layers
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let mu_t = l.mua_per_mm + l.mus_per_mm;
            let d = LayerData {
                z0_mm: z,
                z1_mm: z + l.thickness_mm,
                mut_per_mm: mu_t,
                inv_mut_mm: if mu_t > 0.0 {
                    1.0 / mu_t
                } else {
                    f64::INFINITY
                },
                absorb_fraction: if mu_t > 0.0 { l.mua_per_mm / mu_t } else { 0.0 },
                hg: HenyeyGreenstein { g: l.g },
                n: l.n,
                n_up: if i == 0 { s.n_above } else { s.layers[i - 1].n },
                n_down: if i + 1 == count {
                    s.n_below
                } else {
                    s.layers[i + 1].n
                },
            };
            z += l.thickness_mm;
            d
        })
        .collect()
}

/// Sums over the photons of one chunk (value and square for standard errors).
#[derive(Clone, Debug)]
struct Tally {
    rd: f64,
    rd_sq: f64,
    tt: f64,
    tt_sq: f64,
    absorbed: f64,
    absorbed_sq: f64,
    absorbed_layer: Vec<f64>,
    roulette_gain: f64,
    radial: Vec<f64>,
    radial_sq: Vec<f64>,
    rd_beyond: f64,
    line: Vec<f64>,
    line_sq: Vec<f64>,
    rd_x: f64,
    steps: u64,
    truncated: u64,
    truncated_weight: f64,
    /// CPU time of the thread that ran the chunk, when the platform tells it.
    cpu_ns: Option<u64>,
}

impl Tally {
    fn new(layers: usize, bins: usize, line_bins: usize) -> Self {
        Tally {
            rd: 0.0,
            rd_sq: 0.0,
            tt: 0.0,
            tt_sq: 0.0,
            absorbed: 0.0,
            absorbed_sq: 0.0,
            absorbed_layer: vec![0.0; layers],
            roulette_gain: 0.0,
            radial: vec![0.0; bins],
            radial_sq: vec![0.0; bins],
            rd_beyond: 0.0,
            line: vec![0.0; line_bins],
            line_sq: vec![0.0; line_bins],
            rd_x: 0.0,
            steps: 0,
            truncated: 0,
            truncated_weight: 0.0,
            cpu_ns: Some(0),
        }
    }

    fn add(&mut self, o: &Tally) {
        self.rd += o.rd;
        self.rd_sq += o.rd_sq;
        self.tt += o.tt;
        self.tt_sq += o.tt_sq;
        self.absorbed += o.absorbed;
        self.absorbed_sq += o.absorbed_sq;
        for (a, b) in self.absorbed_layer.iter_mut().zip(&o.absorbed_layer) {
            *a += b;
        }
        self.roulette_gain += o.roulette_gain;
        for (a, b) in self.radial.iter_mut().zip(&o.radial) {
            *a += b;
        }
        for (a, b) in self.radial_sq.iter_mut().zip(&o.radial_sq) {
            *a += b;
        }
        self.rd_beyond += o.rd_beyond;
        for (a, b) in self.line.iter_mut().zip(&o.line) {
            *a += b;
        }
        for (a, b) in self.line_sq.iter_mut().zip(&o.line_sq) {
            *a += b;
        }
        self.rd_x += o.rd_x;
        self.steps += o.steps;
        self.truncated += o.truncated;
        self.truncated_weight += o.truncated_weight;
        self.cpu_ns = match (self.cpu_ns, o.cpu_ns) {
            (Some(a), Some(b)) => Some(a + b),
            _ => None,
        };
    }
}

struct Ctx<'a> {
    layers: &'a [LayerData],
    w0: f64,
    launch: [f64; 3],
    bins: usize,
    inv_dr: f64,
    line_bins: usize,
    line_max_mm: f64,
    inv_dx: f64,
    max_steps: u64,
}

impl Ctx<'_> {
    /// Transport one photon packet from launch to its end, adding to `t`.
    #[inline]
    fn trace(&self, rng: &mut Rng, t: &mut Tally) {
        let (mut x, mut y, mut z) = (0.0f64, 0.0f64, 0.0f64);
        let [mut ux, mut uy, mut uz] = self.launch;
        let mut w = self.w0;
        let mut layer = 0usize;
        let mut tau = 0.0f64; // remaining dimensionless optical depth of the current free path
        let mut absorbed = 0.0f64;
        let mut steps = 0u64;
        loop {
            if steps == self.max_steps {
                // Still alive at the cap: drop the packet and account for its weight.
                t.truncated += 1;
                t.truncated_weight += w;
                break;
            }
            steps += 1;
            let l = &self.layers[layer];
            if tau == 0.0 {
                tau = -(1.0 - rng.uniform()).ln(); // 1 − ξ ∈ (0, 1]
            }
            let s = tau * l.inv_mut_mm;
            let db = if uz > 0.0 {
                (l.z1_mm - z) / uz
            } else if uz < 0.0 {
                (l.z0_mm - z) / uz
            } else {
                f64::INFINITY
            };
            if s < db {
                // Interaction inside the layer.
                x += s * ux;
                y += s * uy;
                z += s * uz;
                tau = 0.0;
                let dw = w * l.absorb_fraction;
                w -= dw;
                absorbed += dw;
                t.absorbed_layer[layer] += dw;
                // Scatter (the same sampling code as the renderer's media).
                [ux, uy, uz] =
                    l.hg.sample_direction([ux, uy, uz], rng.uniform(), rng.uniform());
                if w < WEIGHT_THRESHOLD {
                    if rng.uniform() * ROULETTE_M < 1.0 {
                        t.roulette_gain += w * (ROULETTE_M - 1.0);
                        w *= ROULETTE_M;
                    } else {
                        t.roulette_gain -= w;
                        break;
                    }
                }
                continue;
            }
            if db == f64::INFINITY {
                // A clear semi-infinite layer: the packet leaves downwards for good.
                self.exit_bottom(w, t);
                break;
            }
            // Move to the interface, keeping the unspent optical depth.
            x += db * ux;
            y += db * uy;
            tau = if l.mut_per_mm > 0.0 {
                (tau - db * l.mut_per_mm).max(0.0)
            } else {
                tau
            };
            let up = uz < 0.0;
            z = if up { l.z0_mm } else { l.z1_mm };
            let n_t = if up { l.n_up } else { l.n_down };
            let cos_i = uz.abs();
            let (reflect, cos_tr) = if n_t == l.n {
                (false, cos_i)
            } else {
                let eta = n_t / l.n;
                match cos_theta_transmitted(cos_i, eta) {
                    None => (true, 0.0),
                    Some(ct) => (rng.uniform() < fresnel_dielectric(cos_i, eta), ct),
                }
            };
            if reflect {
                uz = -uz;
                continue;
            }
            if up && layer == 0 {
                // Escapes into the ambient medium above: diffuse reflectance.
                t.rd += w;
                t.rd_sq += w * w;
                t.rd_x += w * x;
                if self.line_bins > 0 && (y * self.inv_dx).abs() < 0.5 {
                    let k = (x + self.line_max_mm) * self.inv_dx;
                    if k >= 0.0 && (k as usize) < self.line_bins {
                        t.line[k as usize] += w;
                        t.line_sq[k as usize] += w * w;
                    }
                }
                if self.bins > 0 {
                    let k = ((x * x + y * y).sqrt() * self.inv_dr) as usize;
                    if k < self.bins {
                        t.radial[k] += w;
                        t.radial_sq[k] += w * w;
                    } else {
                        t.rd_beyond += w;
                    }
                }
                break;
            }
            if !up && layer + 1 == self.layers.len() {
                self.exit_bottom(w, t);
                break;
            }
            // Refract into the neighbouring layer (Snell: tangential part scales by n_i/n_t).
            let ratio = l.n / n_t;
            ux *= ratio;
            uy *= ratio;
            uz = if up { -cos_tr } else { cos_tr };
            layer = if up { layer - 1 } else { layer + 1 };
        }
        t.absorbed += absorbed;
        t.absorbed_sq += absorbed * absorbed;
        t.steps += steps;
    }

    #[inline]
    fn exit_bottom(&self, w: f64, t: &mut Tally) {
        t.tt += w;
        t.tt_sq += w * w;
    }
}

/// xoshiro256++ generator (Blackman & Vigna 2018), seeded per chunk through SplitMix64.
/// Private to the slab code; the renderer has its own sampler in `render::sampling`.
struct Rng {
    s: [u64; 4],
}

impl Rng {
    fn new(seed: u64, stream: u64) -> Self {
        let mut sm = seed ^ stream.wrapping_mul(0xD1B5_4A32_D192_ED03);
        let mut next = || {
            sm = sm.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = sm;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        Rng {
            s: [next(), next(), next(), next()],
        }
    }

    #[inline(always)]
    fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = (s[0].wrapping_add(s[3])).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in [0, 1) with 53 random bits.
    #[inline(always)]
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// CPU time consumed so far by the calling thread in ns (Linux), or `None`.
fn thread_cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// Benchmark for `lucent bench`: single-thread throughput in photon steps per second on
/// Giovanelli's semi-infinite medium (n = 1.5, albedo 0.9, isotropic; ≈ 46 steps per photon),
/// per second of CPU time where known (robust to other load), else of wall-clock time.
pub fn benchmark_steps_per_s(photons: u64) -> Result<f64> {
    let settings = SlabSettings {
        photons: photons.max(1),
        ..SlabSettings::new(vec![Layer {
            mua_per_mm: 0.1,
            mus_per_mm: 0.9,
            g: 0.0,
            n: 1.5,
            thickness_mm: f64::INFINITY,
        }])
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let r = pool.install(|| simulate(&settings))?;
    Ok(r.photon_steps_per_cpu_s()
        .unwrap_or_else(|| r.photon_steps_per_s()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_is_uniform_and_streams_differ() {
        let mut a = Rng::new(1, 0);
        let mut b = Rng::new(1, 1);
        let n = 100_000;
        let mut mean = 0.0;
        let mut same = 0;
        for _ in 0..n {
            let u = a.uniform();
            assert!((0.0..1.0).contains(&u));
            mean += u;
            if (u - b.uniform()).abs() < 1e-12 {
                same += 1;
            }
        }
        mean /= n as f64;
        // σ of the mean: 1/√(12 n) ≈ 0.0009.
        assert!((mean - 0.5).abs() < 0.004, "{mean}");
        assert_eq!(same, 0);
    }
}
