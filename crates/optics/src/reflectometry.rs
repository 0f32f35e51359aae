//! Diffuse reflectance spectroscopy: forward models of the spatially resolved diffuse
//! reflectance R(r) of a turbid half-space under a narrow normally incident beam, and their
//! inversion (σ_a, σ'_s from measured R(r)); oblique incidence reflectometry (Wang & Jacques 1995).
//!
//! R(r) is the power leaving the surface per unit area at distance r from the point of incidence
//! per unit incident power, in mm⁻² (the unit of `lucent slab`'s radial tally). Lengths are in mm
//! and coefficients in mm⁻¹ here, as in tissue optics and `optics::slab`; every name says so.
//! All models include the Fresnel transmittance T₁₂ = 1 − R(0) of the incident beam, so that
//! they compare directly with Monte Carlo counted per incident photon.
//!
//! Models ([`ReflectanceModel`]):
//! - standard dipole, Farrell, Patterson & Wilson, Med. Phys. 19 (1992) 879, eq. (A7), with the
//!   boundary term A = (1 + F_dr)/(1 − F_dr) of Groenhuis et al. (F_dr = 2C₁(1/n) computed by
//!   [`crate::fresnel::fresnel_moment`]);
//! - directional dipole, Frisvad, Hachisuka & Kjeldsen, ACM TOG 34(1) 2014, specialised to a
//!   normally incident beam on a flat surface: radiant exitance
//!   M = (1/4π)[e^{−σ_tr d_r}/d_r³ (C_φ d_r²/D + 3D C_E(1 + σ_tr d_r)) − (virtual source term)];
//! - tabulated Monte Carlo ([`MonteCarloTable`]): R(r)/σ'_t² as a function of the reduced albedo
//!   α' = σ'_s/σ'_t and the scaled radius ρ = σ'_t r, from `lucent slab` runs (similarity: exact
//!   for the g the table was built with, approximate for others near the source).

use crate::fitting::{levenberg_marquardt, LmFit, LmOptions};
use crate::fresnel::{fresnel_dielectric, fresnel_moment};
use anyhow::{bail, Context, Result};
use std::f64::consts::PI;

/// Fresnel transmittance of a normally incident beam entering a medium of relative index `eta`.
pub fn t12_normal(eta: f64) -> f64 {
    1.0 - fresnel_dielectric(1.0, eta)
}

/// Boundary terms of the diffusion models for a medium of relative index η (light inside hits
/// the boundary with relative index 1/η): F_dr = 2C₁(1/η), A = (1 + F_dr)/(1 − F_dr) (standard
/// dipole), C_φ = (1 − 2C₁)/4, C_E = (1 − 3C₂)/2 and A = (1 − C_E)/(2C_φ) (directional dipole).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundaryTerms {
    /// Diffuse Fresnel reflectance of the inner side.
    pub fdr: f64,
    /// A of the standard dipole.
    pub a_standard: f64,
    /// C_φ.
    pub c_phi: f64,
    /// C_E.
    pub c_e: f64,
    /// A of the directional dipole.
    pub a_directional: f64,
}

/// [`BoundaryTerms`] for relative index `eta` (Fresnel moments by quadrature, cached per thread
/// for the last η asked for, since fits evaluate many radii at one η).
pub fn boundary_terms(eta: f64) -> BoundaryTerms {
    thread_local! {
        static LAST: std::cell::Cell<Option<(f64, BoundaryTerms)>> = const { std::cell::Cell::new(None) };
    }
    if let Some((e, b)) = LAST.with(|c| c.get()) {
        if e == eta {
            return b;
        }
    }
    let c1 = fresnel_moment(1, 1.0 / eta);
    let c2 = fresnel_moment(2, 1.0 / eta);
    let fdr = 2.0 * c1;
    let c_phi = 0.25 * (1.0 - 2.0 * c1);
    let c_e = 0.5 * (1.0 - 3.0 * c2);
    let b = BoundaryTerms { fdr, a_standard: (1.0 + fdr) / (1.0 - fdr), c_phi, c_e, a_directional: (1.0 - c_e) / (2.0 * c_phi) };
    LAST.with(|c| c.set(Some((eta, b))));
    b
}

/// Standard dipole R(r) in mm⁻² (Farrell, Patterson & Wilson 1992, times T₁₂):
/// T₁₂ α'/(4π) [z₀(μ_eff + 1/r₁)e^{−μ_eff r₁}/r₁² + (z₀ + 4AD)(μ_eff + 1/r₂)e^{−μ_eff r₂}/r₂²].
pub fn dipole_rd_per_mm2(r_mm: f64, sigma_a_per_mm: f64, sigma_s_prime_per_mm: f64, eta: f64) -> f64 {
    let mut_p = sigma_a_per_mm + sigma_s_prime_per_mm;
    let alpha_p = sigma_s_prime_per_mm / mut_p;
    let d = 1.0 / (3.0 * mut_p);
    let mu_eff = (sigma_a_per_mm / d).sqrt();
    let a = boundary_terms(eta).a_standard;
    let z0 = 1.0 / mut_p;
    let zv = z0 + 4.0 * a * d;
    let term = |z: f64| {
        let rr = (z * z + r_mm * r_mm).sqrt();
        z * (mu_eff + 1.0 / rr) * (-mu_eff * rr).exp() / (rr * rr)
    };
    t12_normal(eta) * alpha_p / (4.0 * PI) * (term(z0) + term(zv))
}

/// Directional dipole R(r) in mm⁻² under a normally incident beam (Frisvad et al. 2014, times
/// T₁₂): the radiant exitance 4C_φ(1/η)·π·S_d of the paper's S_d, clamped at 0.
pub fn directional_dipole_rd_per_mm2(r_mm: f64, sigma_a_per_mm: f64, sigma_s_prime_per_mm: f64, eta: f64) -> f64 {
    let mut_p = sigma_a_per_mm + sigma_s_prime_per_mm;
    let alpha_p = sigma_s_prime_per_mm / mut_p;
    if alpha_p <= 0.0 {
        return 0.0;
    }
    let d = 1.0 / (3.0 * mut_p);
    let s_tr = (sigma_a_per_mm / d).sqrt();
    let b = boundary_terms(eta);
    let (c_phi, c_e, a) = (b.c_phi, b.c_e, b.a_directional);
    let de = 2.131 * d / alpha_p.sqrt();
    // Real source at the point of incidence, direction straight down; corrected distance d_r.
    let r2 = r_mm * r_mm;
    let dr = (r2 + d * (d + 2.0 * de * r_mm / (r2 + de * de).sqrt())).sqrt();
    let f = |dist: f64, phi: f64, e: f64| (-s_tr * dist).exp() / dist.powi(3) * (phi - e);
    let str_r = 1.0 + s_tr * dr;
    let real = f(dr, c_phi * dr * dr / d, -3.0 * d * c_e * str_r);
    // Virtual source mirrored 2A·d_e above the surface, direction straight up; x = (r, 0, −2A d_e).
    let h = 2.0 * a * de;
    let dv = (r2 + h * h).sqrt();
    let str_v = 1.0 + s_tr * dv;
    let x_w = -h; // x·ω_v
    let x_n = -h; // x·n_o
    let phi_v = c_phi * (dv * dv / d + 3.0 * str_v * x_w);
    let e_v = c_e * (3.0 * d * str_v - (str_v + 3.0 * d * (3.0 * str_v + s_tr * s_tr * dv * dv) / (dv * dv) * x_w) * x_n);
    let virt = f(dv, phi_v, e_v);
    (t12_normal(eta) * (real - virt) / (4.0 * PI)).max(0.0)
}

/// Monte Carlo R(r) tabulated in similarity variables: T(α', ρ) = R(r)/σ'_t² (dimensionless) on a
/// grid of reduced albedos α' and scaled radii ρ = σ'_t r, for one refractive index and one
/// Henyey–Greenstein g. Interpolation is bilinear in (ln(1 − α'), ρ) on ln T; beyond the last
/// radius the standard dipole's shape continues the table.
#[derive(Clone, Debug, PartialEq)]
pub struct MonteCarloTable {
    /// Relative refractive index of the medium the table was built for.
    pub eta: f64,
    /// Henyey–Greenstein anisotropy of the simulations.
    pub g: f64,
    /// Reduced albedos α', strictly increasing, in (0, 1).
    pub albedo: Vec<f64>,
    /// Scaled radii ρ (bin centres, uniform spacing starting at Δρ/2).
    pub rho: Vec<f64>,
    /// T[albedo index][rho index] = R/σ'_t², > 0.
    pub r_scaled: Vec<Vec<f64>>,
}

impl MonteCarloTable {
    /// Parse the CSV written by [`MonteCarloTable::to_csv`]: `# eta = …`, `# g = …` header
    /// comments and columns `albedo,rho,r_scaled` (rows grouped by albedo, ρ increasing).
    pub fn from_csv(text: &str, name: &str) -> Result<Self> {
        let (mut eta, mut g) = (None, None);
        let mut rows: Vec<(f64, f64, f64)> = vec![];
        let mut header_seen = false;
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            let lineno = i + 1;
            if let Some(c) = line.strip_prefix('#') {
                if let Some((k, v)) = c.split_once('=') {
                    let k = k.trim();
                    if k == "eta" || k == "g" {
                        let v: f64 = v.trim().parse().map_err(|_| anyhow::anyhow!("{name}: line {lineno}: {k}: bad number"))?;
                        if k == "eta" { eta = Some(v) } else { g = Some(v) }
                    }
                }
                continue;
            }
            if line.is_empty() {
                continue;
            }
            if !header_seen {
                if line.replace(' ', "") != "albedo,rho,r_scaled" {
                    bail!("{name}: line {lineno}: expected the header albedo,rho,r_scaled");
                }
                header_seen = true;
                continue;
            }
            let v: Vec<f64> = line
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| anyhow::anyhow!("{name}: line {lineno}: not three numbers"))?;
            if v.len() != 3 || !v.iter().all(|x| x.is_finite()) {
                bail!("{name}: line {lineno}: expected three finite numbers");
            }
            rows.push((v[0], v[1], v[2]));
        }
        let eta = eta.with_context(|| format!("{name}: missing '# eta = …'"))?;
        let g = g.with_context(|| format!("{name}: missing '# g = …'"))?;
        let mut albedo: Vec<f64> = vec![];
        let mut rho: Vec<f64> = vec![];
        let mut table: Vec<Vec<f64>> = vec![];
        for &(a, p, t) in &rows {
            if albedo.last() != Some(&a) {
                if let Some(&last) = albedo.last() {
                    if a <= last {
                        bail!("{name}: albedo values must increase");
                    }
                }
                albedo.push(a);
                table.push(vec![]);
            }
            let row = table.last_mut().unwrap();
            if albedo.len() == 1 {
                rho.push(p);
            } else if rho.get(row.len()).map_or(true, |&q| (q - p).abs() > 1e-9 * q.abs().max(1.0)) {
                bail!("{name}: albedo {a}: the rho grid differs from the first albedo's");
            }
            row.push(t);
        }
        let t = MonteCarloTable { eta, g, albedo, rho, r_scaled: table };
        t.validate().with_context(|| name.to_string())?;
        Ok(t)
    }

    /// Check the grid: ≥ 2 albedos in (0, 1) increasing, ≥ 2 radii uniformly spaced, positive values.
    pub fn validate(&self) -> Result<()> {
        if self.albedo.len() < 2 || self.rho.len() < 2 {
            bail!("a table needs at least 2 albedos and 2 radii");
        }
        if !self.albedo.iter().all(|&a| a > 0.0 && a < 1.0) || !self.albedo.windows(2).all(|w| w[0] < w[1]) {
            bail!("albedos must increase within (0, 1)");
        }
        let d = self.rho[1] - self.rho[0];
        if !(d > 0.0) || self.rho.windows(2).any(|w| ((w[1] - w[0]) - d).abs() > 1e-6 * d) {
            bail!("rho must be uniformly spaced and increasing");
        }
        if self.r_scaled.len() != self.albedo.len()
            || self.r_scaled.iter().any(|r| r.len() != self.rho.len() || r.iter().any(|&v| !(v > 0.0 && v.is_finite())))
        {
            bail!("each albedo needs one positive finite r_scaled per rho");
        }
        Ok(())
    }

    /// The table as CSV (`# eta`, `# g`, then `albedo,rho,r_scaled`).
    pub fn to_csv(&self) -> String {
        let mut s = format!(
            "# Monte Carlo R(r)/sigma_t'^2 vs reduced albedo and rho = sigma_t' r (lucent fit mc-table)\n# eta = {}\n# g = {}\nalbedo,rho,r_scaled\n",
            self.eta, self.g
        );
        for (a, row) in self.albedo.iter().zip(&self.r_scaled) {
            for (p, t) in self.rho.iter().zip(row) {
                s.push_str(&format!("{a},{p},{t:.6e}\n"));
            }
        }
        s
    }

    /// Replace each row beyond `rho_join` by the standard dipole's profile scaled to match the
    /// Monte Carlo over [ρ_join − 3, ρ_join] (mean of ln(MC/dipole)). Diffusion theory has the
    /// right shape there (MC/dipole is constant to ~1 % beyond 4 transport lengths), and the far
    /// tail of a Monte Carlo histogram is its noisiest part.
    pub fn join_diffusion_tail(&mut self, rho_join: f64) {
        for (a, row) in self.albedo.iter().zip(self.r_scaled.iter_mut()) {
            let dip = |p: f64| dipole_rd_per_mm2(p, 1.0 - a, *a, self.eta);
            let idx: Vec<usize> = (0..self.rho.len()).filter(|&k| self.rho[k] >= rho_join - 3.0 && self.rho[k] <= rho_join).collect();
            if idx.is_empty() {
                continue;
            }
            let ratio = idx.iter().map(|&k| (row[k] / dip(self.rho[k])).ln()).sum::<f64>() / idx.len() as f64;
            for k in 0..self.rho.len() {
                if self.rho[k] > rho_join {
                    row[k] = ratio.exp() * dip(self.rho[k]);
                }
            }
        }
    }

    /// T(α', ρ) = R/σ'_t²; `None` outside the albedo range of the table.
    pub fn eval_scaled(&self, albedo: f64, rho: f64) -> Option<f64> {
        let u = (1.0 - albedo).ln();
        let us: Vec<f64> = self.albedo.iter().map(|a| (1.0 - a).ln()).collect(); // decreasing
        let n = us.len();
        if !(u <= us[0] + 1e-12 && u >= us[n - 1] - 1e-12) {
            return None;
        }
        let mut k = 0;
        while k + 2 < n && u < us[k + 1] {
            k += 1;
        }
        let w = ((u - us[k]) / (us[k + 1] - us[k])).clamp(0.0, 1.0);
        let at = |row: usize| -> f64 {
            let rr = &self.r_scaled[row];
            let dp = self.rho[1] - self.rho[0];
            let last = self.rho.len() - 1;
            if rho >= self.rho[last] {
                // Continue with the dipole's shape (index-matched, α' of this row, σ'_t = 1).
                let a = self.albedo[row];
                let ratio = dipole_rd_per_mm2(rho, 1.0 - a, a, self.eta) / dipole_rd_per_mm2(self.rho[last], 1.0 - a, a, self.eta);
                return rr[last].ln() + ratio.ln();
            }
            let x = ((rho - self.rho[0]) / dp).max(0.0);
            let j = (x.floor() as usize).min(last - 1);
            let f = (x - j as f64).clamp(0.0, 1.0);
            rr[j].ln() * (1.0 - f) + rr[j + 1].ln() * f
        };
        Some(((1.0 - w) * at(k) + w * at(k + 1)).exp())
    }

    /// R(r) in mm⁻²; `None` outside the table's albedo range.
    pub fn rd_per_mm2(&self, r_mm: f64, sigma_a_per_mm: f64, sigma_s_prime_per_mm: f64) -> Option<f64> {
        let mut_p = sigma_a_per_mm + sigma_s_prime_per_mm;
        self.eval_scaled(sigma_s_prime_per_mm / mut_p, r_mm * mut_p).map(|t| t * mut_p * mut_p)
    }
}

/// A forward model of R(r).
#[derive(Clone, Debug, PartialEq)]
pub enum ReflectanceModel {
    /// Standard dipole (Farrell et al. 1992).
    Dipole,
    /// Directional dipole (Frisvad et al. 2014) at normal incidence.
    Directional,
    /// Tabulated Monte Carlo.
    MonteCarlo(MonteCarloTable),
}

impl ReflectanceModel {
    /// R(r) in mm⁻² for a medium of relative index `eta`; `None` where the model is undefined
    /// (outside a Monte Carlo table).
    pub fn rd_per_mm2(&self, r_mm: f64, sigma_a_per_mm: f64, sigma_s_prime_per_mm: f64, eta: f64) -> Option<f64> {
        let v = match self {
            ReflectanceModel::Dipole => dipole_rd_per_mm2(r_mm, sigma_a_per_mm, sigma_s_prime_per_mm, eta),
            ReflectanceModel::Directional => directional_dipole_rd_per_mm2(r_mm, sigma_a_per_mm, sigma_s_prime_per_mm, eta),
            ReflectanceModel::MonteCarlo(t) => t.rd_per_mm2(r_mm, sigma_a_per_mm, sigma_s_prime_per_mm)?,
        };
        v.is_finite().then_some(v)
    }

    /// Name as used on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            ReflectanceModel::Dipole => "dipole",
            ReflectanceModel::Directional => "directional",
            ReflectanceModel::MonteCarlo(_) => "montecarlo",
        }
    }
}

/// One measured profile R(r) (one wavelength).
#[derive(Clone, Debug, PartialEq)]
pub struct ReflectanceProfile {
    /// Wavelength in nm, when the data have a `wavelength_nm` column.
    pub lambda_nm: Option<f64>,
    /// Distances from the point of incidence, mm, strictly increasing.
    pub r_mm: Vec<f64>,
    /// R(r) in mm⁻² (absolute) or in arbitrary units (relative).
    pub value: Vec<f64>,
    /// Standard errors of `value`, if given.
    pub stderr: Option<Vec<f64>>,
    /// True when only the shape is known (`relative` column).
    pub relative: bool,
}

/// Split a CSV line into trimmed fields.
fn fields(line: &str) -> Vec<&str> {
    line.split(',').map(str::trim).collect()
}

/// Read `r_mm` and `reflectance` (or `relative`; `rd_per_mm2` as written by `lucent slab` is
/// taken as `reflectance`) with optional `wavelength_nm` and `stderr` (or `rd_per_mm2_stderr`)
/// columns. Rows are grouped by wavelength in order of appearance; within each, r must strictly
/// increase. Errors name `file` and the line or column.
pub fn read_reflectance_csv(text: &str, file: &str) -> Result<Vec<ReflectanceProfile>> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((_, header)) = lines.next() else {
        bail!("{file}: empty file (expected a header r_mm,reflectance or r_mm,relative)");
    };
    let names = fields(header);
    let col = |opts: &[&str]| names.iter().position(|n| opts.contains(n));
    let r_col = col(&["r_mm"]).with_context(|| format!("{file}: missing column r_mm (header: {header})"))?;
    let (v_col, relative) = match (col(&["reflectance", "rd_per_mm2"]), col(&["relative"])) {
        (Some(c), None) => (c, false),
        (None, Some(c)) => (c, true),
        (Some(_), Some(_)) => bail!("{file}: give either a reflectance or a relative column, not both"),
        (None, None) => bail!("{file}: missing column reflectance (or relative) (header: {header})"),
    };
    let l_col = col(&["wavelength_nm"]);
    let s_col = col(&["stderr", "rd_per_mm2_stderr", "reflectance_stderr"]);
    let mut out: Vec<ReflectanceProfile> = vec![];
    for (i, line) in lines {
        let lineno = i + 1;
        let f = fields(line);
        let get = |c: usize, what: &str| -> Result<f64> {
            let s = f.get(c).with_context(|| format!("{file}: line {lineno}: missing column {what}"))?;
            let v: f64 = s.parse().map_err(|_| anyhow::anyhow!("{file}: line {lineno}: column {what}: {s:?} is not a number"))?;
            if !v.is_finite() {
                bail!("{file}: line {lineno}: column {what}: {s:?} is not finite");
            }
            Ok(v)
        };
        let r = get(r_col, "r_mm")?;
        let v = get(v_col, names[v_col])?;
        if r < 0.0 {
            bail!("{file}: line {lineno}: column r_mm: negative distance {r}");
        }
        if v < 0.0 {
            bail!("{file}: line {lineno}: column {}: negative reflectance {v}", names[v_col]);
        }
        let lambda = l_col.map(|c| get(c, "wavelength_nm")).transpose()?;
        let se = s_col.map(|c| get(c, names[c])).transpose()?;
        if let Some(s) = se {
            if s < 0.0 {
                bail!("{file}: line {lineno}: column {}: negative standard error {s}", names[s_col.unwrap()]);
            }
        }
        let idx = match out.iter().position(|p| p.lambda_nm == lambda) {
            Some(k) => k,
            None => {
                out.push(ReflectanceProfile {
                    lambda_nm: lambda,
                    r_mm: vec![],
                    value: vec![],
                    stderr: s_col.map(|_| vec![]),
                    relative,
                });
                out.len() - 1
            }
        };
        let p = &mut out[idx];
        if let Some(&last) = p.r_mm.last() {
            if r <= last {
                bail!("{file}: line {lineno}: column r_mm: {r} does not increase (previous {last}{})",
                    lambda.map(|l| format!(" at wavelength_nm {l}")).unwrap_or_default());
            }
        }
        p.r_mm.push(r);
        p.value.push(v);
        if let (Some(s), Some(se)) = (p.stderr.as_mut(), se) {
            s.push(se);
        }
    }
    if out.is_empty() {
        bail!("{file}: no data rows (column r_mm is empty)");
    }
    Ok(out)
}

/// Options of [`fit_reflectance`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// Ignore data closer than this to the source, mm.
    pub r_min_mm: f64,
    /// Ignore data farther than this, mm.
    pub r_max_mm: f64,
    /// Relative noise assumed for every point (added in quadrature to the given standard errors).
    pub relative_noise: f64,
    /// When the data are histogram bins (annuli of this width centred on each r, as written by
    /// `lucent slab`), the model is averaged over each annulus (4-point Gauss–Legendre in r,
    /// weighted by r); `None` compares point values.
    pub bin_width_mm: Option<f64>,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions { r_min_mm: 0.0, r_max_mm: f64::INFINITY, relative_noise: 0.01, bin_width_mm: None }
    }
}

/// A fitted value with its 95 % confidence interval; `None` fields when not determined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Best estimate.
    pub value: f64,
    /// 95 % confidence interval [low, high].
    pub ci95: [f64; 2],
}

/// Result of [`fit_reflectance`] for one profile.
#[derive(Clone, Debug, PartialEq)]
pub struct ReflectanceFit {
    /// Wavelength in nm, if known.
    pub lambda_nm: Option<f64>,
    /// σ_a in mm⁻¹ (`None` if the data do not determine it).
    pub sigma_a_per_mm: Option<Estimate>,
    /// σ'_s in mm⁻¹ (`None` if not determined).
    pub sigma_s_prime_per_mm: Option<Estimate>,
    /// Effective attenuation μ_eff = √(3σ_a(σ_a + σ'_s)) in mm⁻¹.
    pub mu_eff_per_mm: Option<Estimate>,
    /// Ratio σ'_s/σ_a.
    pub sigma_s_prime_over_sigma_a: Option<Estimate>,
    /// RMS of the weighted log residuals (≈ 1 when the assumed noise is right).
    pub residual_rms: f64,
    /// RMS of ln(data/model) (relative misfit).
    pub relative_rms: f64,
    /// Points used.
    pub points: usize,
    /// Messages about what could not be determined and why.
    pub notes: Vec<String>,
}

/// Mean of f over the annulus r0 ≤ r ≤ r1 (area weighted), by 4-point Gauss–Legendre in r.
pub fn annulus_average(f: impl Fn(f64) -> Option<f64>, r0: f64, r1: f64) -> Option<f64> {
    const X: [f64; 4] = [-0.861_136_311_594_052_6, -0.339_981_043_584_856_3, 0.339_981_043_584_856_3, 0.861_136_311_594_052_6];
    const W: [f64; 4] = [0.347_854_845_137_453_9, 0.652_145_154_862_546_1, 0.652_145_154_862_546_1, 0.347_854_845_137_453_9];
    let (c, h) = (0.5 * (r0 + r1), 0.5 * (r1 - r0));
    let mut num = 0.0;
    let mut den = 0.0;
    for k in 0..4 {
        let r = c + h * X[k];
        num += W[k] * r * f(r)?;
        den += W[k] * r;
    }
    Some(num / den)
}

/// Bin width when `r_mm` looks like histogram bin centres (uniform spacing Δ, first centre Δ/2,
/// as `lucent slab --radial-csv` writes them), else `None`.
pub fn detect_bins(r_mm: &[f64]) -> Option<f64> {
    if r_mm.len() < 3 {
        return None;
    }
    let d = r_mm[1] - r_mm[0];
    let uniform = r_mm.windows(2).all(|w| ((w[1] - w[0]) - d).abs() < 1e-6 * d.abs().max(1e-12));
    (uniform && d > 0.0 && (r_mm[0] - 0.5 * d).abs() < 1e-6 * d).then_some(d)
}

/// Largest 95 % half width of ln(parameter) for which a parameter is reported (a factor of 2).
pub const MAX_LOG_HALF_WIDTH: f64 = std::f64::consts::LN_2;

fn estimate_log(lnv: f64, half: f64) -> Option<Estimate> {
    (half.is_finite() && half <= MAX_LOG_HALF_WIDTH).then(|| Estimate { value: lnv.exp(), ci95: [(lnv - half).exp(), (lnv + half).exp()] })
}

/// Fit σ_a and σ'_s (in log space) to one profile by Levenberg–Marquardt on the weighted log
/// residuals (ln data − ln model)/σ_rel, σ_rel² = noise² + (stderr/value)²; for relative data a
/// free log-scale is fitted too. A coarse grid search over (σ_a, σ'_s) gives the start.
pub fn fit_reflectance(profile: &ReflectanceProfile, model: &ReflectanceModel, eta: f64, options: &FitOptions) -> Result<ReflectanceFit> {
    if !(eta.is_finite() && eta > 0.0) {
        bail!("--eta must be finite and > 0, got {eta}");
    }
    let mut r = vec![];
    let mut y = vec![];
    let mut w = vec![];
    let mut skipped_zero = 0;
    for k in 0..profile.r_mm.len() {
        let (rk, vk) = (profile.r_mm[k], profile.value[k]);
        if rk < options.r_min_mm || rk > options.r_max_mm {
            continue;
        }
        if vk <= 0.0 {
            skipped_zero += 1;
            continue;
        }
        let rel_se = profile.stderr.as_ref().map_or(0.0, |s| s[k] / vk);
        let sigma = (options.relative_noise.powi(2) + rel_se * rel_se).sqrt().max(1e-6);
        r.push(rk);
        y.push(vk.ln());
        w.push(1.0 / sigma);
    }
    let rel = profile.relative;
    let npar = if rel { 3 } else { 2 };
    if r.len() <= npar {
        bail!("{} positive data points in range: too few to fit {npar} parameters", r.len());
    }
    let bin = options.bin_width_mm.filter(|h| *h > 0.0);
    let log_model = |p: &[f64]| -> Option<Vec<f64>> {
        let (mua, musp) = (p[0].exp(), p[1].exp());
        r.iter()
            .map(|&rk| {
                let v = match bin {
                    None => model.rd_per_mm2(rk, mua, musp, eta)?,
                    Some(h) => annulus_average(|x| model.rd_per_mm2(x, mua, musp, eta), (rk - 0.5 * h).max(0.0), rk + 0.5 * h)?,
                };
                (v > 0.0).then(|| v.ln())
            })
            .collect()
    };
    // Grid search for a start (the scale of relative data is profiled out).
    let mut best = (f64::INFINITY, vec![0.0; npar]);
    for i in 0..41 {
        for j in 0..31 {
            let lmua = (1e-5f64).ln() + i as f64 * (1e5f64).ln() / 40.0; // 1e-5 … 1 mm⁻¹
            let lmus = (1e-2f64).ln() + j as f64 * (1e4f64).ln() / 30.0; // 0.01 … 100 mm⁻¹
            let Some(m) = log_model(&[lmua, lmus]) else { continue };
            let c = if rel {
                let sw: f64 = w.iter().map(|v| v * v).sum();
                y.iter().zip(&m).zip(&w).map(|((a, b), wk)| (a - b) * wk * wk).sum::<f64>() / sw
            } else {
                0.0
            };
            let cost: f64 = y.iter().zip(&m).zip(&w).map(|((a, b), wk)| ((a - b - c) * wk).powi(2)).sum();
            if cost < best.0 {
                let mut p = vec![lmua, lmus];
                if rel {
                    p.push(c);
                }
                best = (cost, p);
            }
        }
    }
    if !best.0.is_finite() {
        bail!("the {} model cannot be evaluated for these data", model.name());
    }
    let residuals = |p: &[f64]| -> Option<Vec<f64>> {
        let m = log_model(p)?;
        let c = if rel { p[2] } else { 0.0 };
        Some(y.iter().zip(&m).zip(&w).map(|((a, b), wk)| (a - b - c) * wk).collect())
    };
    let fit: LmFit = levenberg_marquardt(&residuals, &best.1, &LmOptions::default())?;
    let t = crate::fitting::student_t_975(fit.dof);
    let cov = fit.covariance.clone();
    let var = |a: &[f64]| -> f64 {
        match &cov {
            Some(c) => {
                let mut s = 0.0;
                for i in 0..npar {
                    for j in 0..npar {
                        s += a[i] * c[i][j] * a[j];
                    }
                }
                s
            }
            None => f64::INFINITY,
        }
    };
    let (lmua, lmus) = (fit.params[0], fit.params[1]);
    let mut notes = vec![];
    if skipped_zero > 0 {
        notes.push(format!("{skipped_zero} zero-valued points skipped"));
    }
    let pad = |v: Vec<f64>| -> Vec<f64> { let mut v = v; v.resize(npar, 0.0); v };
    let sa = estimate_log(lmua, t * var(&pad(vec![1.0, 0.0])).sqrt());
    let ss = estimate_log(lmus, t * var(&pad(vec![0.0, 1.0])).sqrt());
    // ln μ_eff = ½(ln 3 + ln σ_a + ln(σ_a + σ'_s)).
    let (mua, musp) = (lmua.exp(), lmus.exp());
    let f = mua / (mua + musp);
    let grad = pad(vec![0.5 * (1.0 + f), 0.5 * (1.0 - f)]);
    let lmeff = 0.5 * ((3.0f64).ln() + lmua + (mua + musp).ln());
    let meff = estimate_log(lmeff, t * var(&grad).sqrt());
    let ratio = estimate_log(lmus - lmua, t * var(&pad(vec![-1.0, 1.0])).sqrt());
    if rel {
        notes.push(
            "relative data: no absolute scale, so only the profile's shape constrains the fit — μ_eff and σ'_s/σ_a are the identifiable combinations; σ_a and σ'_s separately only from the curvature near the source".into(),
        );
    }
    if sa.is_none() {
        notes.push("sigma_a_per_mm not determined by these data (95 % interval wider than a factor 2)".into());
    }
    if ss.is_none() {
        notes.push("sigma_s_prime_per_mm not determined by these data (95 % interval wider than a factor 2)".into());
    }
    let relative_rms = (fit.residuals.iter().zip(&w).map(|(ri, wk)| (ri / wk).powi(2)).sum::<f64>() / r.len() as f64).sqrt();
    Ok(ReflectanceFit {
        lambda_nm: profile.lambda_nm,
        sigma_a_per_mm: sa,
        sigma_s_prime_per_mm: ss,
        mu_eff_per_mm: meff,
        sigma_s_prime_over_sigma_a: ratio,
        residual_rms: fit.residual_rms,
        relative_rms,
        points: r.len(),
        notes,
    })
}

/// Result of oblique incidence reflectometry.
#[derive(Clone, Debug, PartialEq)]
pub struct ObliqueFit {
    /// Shift Δx of the diffuse centre from the point of incidence, mm.
    pub delta_x_mm: Estimate,
    /// Effective attenuation from the profile's slope, mm⁻¹.
    pub mu_eff_per_mm: Estimate,
    /// Diffusion coefficient D = Δx/(3 sin θ_t), mm.
    pub diffusion_mm: Estimate,
    /// σ_a = μ_eff² D, mm⁻¹.
    pub sigma_a_per_mm: Estimate,
    /// σ'_s = 1/(3D) − 0.35 σ_a, mm⁻¹.
    pub sigma_s_prime_per_mm: Estimate,
    /// RMS of the weighted log residuals.
    pub residual_rms: f64,
    /// Points used.
    pub points: usize,
}

/// Oblique incidence reflectometry (Wang & Jacques, Appl. Opt. 34 (1995) 2362; the absorption
/// revision of Lin et al., Appl. Opt. 36 (1997) 136): the diffuse reflectance far from an obliquely
/// incident beam is centred at Δx = 3D sin θ_t, D = 1/(3(0.35σ_a + σ'_s)), θ_t the refraction
/// angle, and decays with μ_eff = √(σ_a/D). The centre and μ_eff come from a fit of the shape
/// of the dipole profile R(|x − x_c|) (free scale) to the line profile R(x, 0), excluding
/// |x − x_peak| < `exclude_mm` around the peak, where diffusion fails.
/// `stderr` (same units as `value`) weights the points, with 1 % relative noise added in quadrature.
pub fn fit_oblique(x_mm: &[f64], value: &[f64], stderr: Option<&[f64]>, incidence_deg: f64, eta: f64, exclude_mm: f64) -> Result<ObliqueFit> {
    if !(incidence_deg > 0.0 && incidence_deg < 90.0) {
        bail!("--incidence-deg must lie in (0, 90), got {incidence_deg}");
    }
    if !(eta.is_finite() && eta > 0.0) {
        bail!("--eta must be finite and > 0, got {eta}");
    }
    let sin_t = incidence_deg.to_radians().sin() / eta;
    let k_peak = (0..value.len()).max_by(|&a, &b| value[a].total_cmp(&value[b])).context("empty profile")?;
    let x_peak = x_mm[k_peak];
    let mut xs = vec![];
    let mut ys = vec![];
    let mut ws = vec![];
    for k in 0..x_mm.len() {
        if (x_mm[k] - x_peak).abs() >= exclude_mm && value[k] > 0.0 {
            let rel = stderr.map_or(0.0, |s| s[k] / value[k]);
            xs.push(x_mm[k]);
            ys.push(value[k].ln());
            ws.push(1.0 / (1e-4 + rel * rel).sqrt());
        }
    }
    if xs.len() < 6 {
        bail!("only {} positive points outside ±{exclude_mm} mm of the peak: too few", xs.len());
    }
    // Parameters (x_c, ln μ_eff, c): the dipole profile R(|x − x_c|) with the properties that
    // the OIR relations give for this centre and slope (D = x_c/(3 sin θ_t), σ_a = μ_eff² D,
    // σ'_s = 1/(3D) − 0.35σ_a), free log scale c; 1 % relative noise assumed.
    let model = |p: &[f64]| -> Option<Vec<f64>> {
        let (xc, meff) = (p[0], p[1].exp());
        if !(xc > 0.0) {
            return None;
        }
        let d = xc / (3.0 * sin_t);
        let mua = meff * meff * d;
        let musp = 1.0 / (3.0 * d) - 0.35 * mua;
        if !(musp > 0.0) {
            return None;
        }
        xs.iter().zip(&ys).zip(&ws).map(|((&x, &y), &w)| {
            let v = dipole_rd_per_mm2((x - xc).abs(), mua, musp, eta);
            (v > 0.0 && v.is_finite()).then(|| (y - v.ln() - p[2]) * w)
        }).collect()
    };
    let mut best = (f64::INFINITY, vec![]);
    let span = x_mm[x_mm.len() - 1] - x_mm[0];
    for i in 1..=40 {
        let xc = span * 0.25 * i as f64 / 40.0;
        for j in 0..=30 {
            let lm = (1e-3f64).ln() + j as f64 * (1e4f64).ln() / 30.0;
            let mut p = vec![xc, lm, 0.0];
            let Some(res0) = model(&p) else { continue };
            let sw: f64 = ws.iter().map(|w| w * w).sum();
            p[2] = res0.iter().zip(&ws).map(|(r, w)| r * w).sum::<f64>() / sw;
            let Some(res) = model(&p) else { continue };
            let c: f64 = res.iter().map(|v| v * v).sum();
            if c < best.0 {
                best = (c, p);
            }
        }
    }
    if best.1.is_empty() {
        bail!("the dipole profile cannot be evaluated for these data (is the centre shifted along +x?)");
    }
    let fit = levenberg_marquardt(&model, &best.1, &LmOptions::default())?;
    let t = crate::fitting::student_t_975(fit.dof);
    let cov = fit.covariance.clone().context("the profile does not determine the centre and the slope (singular fit)")?;
    let dx = fit.params[0];
    let sdx = cov[0][0].max(0.0).sqrt();
    let lmeff = fit.params[1];
    let slm = cov[1][1].max(0.0).sqrt();
    if !(dx > 0.0) {
        bail!("the diffuse centre ({dx:.4} mm) is not shifted along the beam: cannot apply oblique incidence reflectometry");
    }
    let d = dx / (3.0 * sin_t);
    let meff = lmeff.exp();
    let mua = meff * meff * d;
    let musp = 1.0 / (3.0 * d) - 0.35 * mua;
    // Relative errors: D ∝ Δx; σ_a ∝ μ_eff² Δx; σ'_s ≈ 1/(3D) ∝ 1/Δx (Δx and μ_eff treated as uncorrelated).
    let rdx = sdx / dx;
    let rmua = (rdx * rdx + 4.0 * slm * slm).sqrt();
    let iv = |v: f64, rel: f64| Estimate { value: v, ci95: [v * (-t * rel).exp(), v * (t * rel).exp()] };
    Ok(ObliqueFit {
        delta_x_mm: Estimate { value: dx, ci95: [dx - t * sdx, dx + t * sdx] },
        mu_eff_per_mm: iv(meff, slm),
        diffusion_mm: iv(d, rdx),
        sigma_a_per_mm: iv(mua, rmua),
        sigma_s_prime_per_mm: iv(musp, rdx),
        residual_rms: fit.residual_rms,
        points: xs.len(),
    })
}

/// Refractive indices (relative) of the bundled Monte Carlo tables (g = 0; built by
/// `lucent fit mc-table`, see `crates/optics/data/reflectometry/README.md`).
pub const BUNDLED_TABLE_ETAS: [f64; 3] = [1.0, 1.3, 1.5];
const BUNDLED_TABLES: [&str; 3] = [
    include_str!("../data/reflectometry/mc_eta1.0.csv"),
    include_str!("../data/reflectometry/mc_eta1.3.csv"),
    include_str!("../data/reflectometry/mc_eta1.5.csv"),
];

/// The bundled Monte Carlo table for `eta` (to 1e-6), if there is one.
pub fn bundled_table(eta: f64) -> Result<Option<MonteCarloTable>> {
    for (e, text) in BUNDLED_TABLE_ETAS.iter().zip(BUNDLED_TABLES) {
        if (e - eta).abs() < 1e-6 {
            return MonteCarloTable::from_csv(text, &format!("bundled table eta {e}")).map(Some);
        }
    }
    Ok(None)
}
