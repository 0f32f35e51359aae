//! Nonlinear least squares for the inverse problems — Levenberg–Marquardt from the maintained
//! `levenberg-marquardt` crate (a port of MINPACK's LMDER: Moré, "The Levenberg–Marquardt
//! algorithm: implementation and theory", 1978), with Jacobians by central finite differences and
//! confidence intervals from the Jacobian at the solution — and the inference of milk composition
//! (fat content, homogenization pressure) from measured σ'_s(λ) and σ_a(λ) spectra through the Mie
//! milk model.
//!
//! The covariance of the estimate is s²(JᵀJ)⁻¹ with s² = Σr²/(m − n) (J recomputed at the
//! solution, JᵀJ formed here: the crate reports no covariance), and 95 % intervals use Student's
//! t with m − n degrees of freedom. Bounds are imposed by the callers' reparametrisations (log
//! parameters); where a residual function cannot be evaluated (outside its domain) it returns
//! `None`, which the solver sees as a huge cost, so that the step is rejected and shortened.

use anyhow::{bail, Result};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

/// Options of [`levenberg_marquardt`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmOptions {
    /// Most residual evaluations, per parameter plus one (MINPACK's `maxfev` = this × (n + 1)).
    pub max_iterations: usize,
    /// Stop when a step changes the sum of squares by less than this fraction (MINPACK's `ftol`).
    pub cost_tolerance: f64,
    /// Stop when a step changes the scaled parameter vector by less than this fraction (`xtol`).
    pub step_tolerance: f64,
    /// Finite-difference step for the Jacobian (absolute, in parameter units).
    pub fd_step: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions { max_iterations: 200, cost_tolerance: 1e-12, step_tolerance: 1e-10, fd_step: 1e-6 }
    }
}

/// Result of a least-squares fit.
#[derive(Clone, Debug, PartialEq)]
pub struct LmFit {
    /// Fitted parameters.
    pub params: Vec<f64>,
    /// Residuals at the fitted parameters.
    pub residuals: Vec<f64>,
    /// Root mean square of the residuals.
    pub residual_rms: f64,
    /// Covariance s²(JᵀJ)⁻¹ of the parameters; `None` when JᵀJ is singular (some combination of
    /// the parameters is not determined by the data).
    pub covariance: Option<Vec<Vec<f64>>>,
    /// Degrees of freedom m − n.
    pub dof: usize,
    /// Residual evaluations the solver made (Jacobian evaluations not counted).
    pub evaluations: usize,
}

impl LmFit {
    /// Standard error of parameter `i` (∞ when undetermined).
    pub fn std_error(&self, i: usize) -> f64 {
        match &self.covariance {
            Some(c) if c[i][i].is_finite() && c[i][i] >= 0.0 => c[i][i].sqrt(),
            _ => f64::INFINITY,
        }
    }

    /// Half width of the 95 % confidence interval of parameter `i` (∞ when undetermined).
    pub fn ci95_half_width(&self, i: usize) -> f64 {
        student_t_975(self.dof) * self.std_error(i)
    }
}

/// The 97.5 % quantile of Student's t distribution with `dof` degrees of freedom (two-sided
/// 95 %): exact table for 1–10, Cornish–Fisher expansion in 1/ν beyond (error < 1e-3).
pub fn student_t_975(dof: usize) -> f64 {
    const TABLE: [f64; 10] = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228];
    match dof {
        0 => f64::INFINITY,
        1..=10 => TABLE[dof - 1],
        _ => {
            let z: f64 = 1.959964;
            let v = dof as f64;
            let z3 = z.powi(3);
            let z5 = z.powi(5);
            let z7 = z.powi(7);
            z + (z3 + z) / (4.0 * v)
                + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * v * v)
                + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * v * v * v)
        }
    }
}

/// Jacobian of `f` at `p` by central differences with step `h` (rows: residuals); one-sided
/// where one of the two neighbours lies outside the model's domain.
pub fn jacobian(f: &dyn Fn(&[f64]) -> Option<Vec<f64>>, p: &[f64], h: f64) -> Option<Vec<Vec<f64>>> {
    let r0 = f(p)?;
    let m = r0.len();
    let mut jac = vec![vec![0.0; p.len()]; m];
    for j in 0..p.len() {
        let mut pp = p.to_vec();
        let mut pm = p.to_vec();
        pp[j] += h;
        pm[j] -= h;
        let (rp, rm, step) = match (f(&pp), f(&pm)) {
            (Some(a), Some(b)) => (a, b, 2.0 * h),
            (Some(a), None) => (a, r0.clone(), h),
            (None, Some(b)) => (r0.clone(), b, h),
            (None, None) => return None,
        };
        for i in 0..m {
            jac[i][j] = (rp[i] - rm[i]) / step;
        }
    }
    Some(jac)
}

/// Residual of every component where the model cannot be evaluated (squares to 1e200: any step
/// there is rejected by the trust region).
const OUTSIDE_DOMAIN_RESIDUAL: f64 = 1e100;

/// The crate's view of a residual function: parameters, residuals, Jacobian.
struct Problem<'a> {
    f: &'a dyn Fn(&[f64]) -> Option<Vec<f64>>,
    p: DVector<f64>,
    m: usize,
    fd_step: f64,
}

impl Problem<'_> {
    fn eval(&self, p: &[f64]) -> Option<Vec<f64>> {
        (self.f)(p).filter(|r| r.len() == self.m && r.iter().all(|v| v.is_finite()))
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.p.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.p.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(match self.eval(self.p.as_slice()) {
            Some(r) => DVector::from_vec(r),
            None => DVector::from_element(self.m, OUTSIDE_DOMAIN_RESIDUAL),
        })
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let f = |p: &[f64]| self.eval(p);
        let jac = jacobian(&f, self.p.as_slice(), self.fd_step)?;
        Some(DMatrix::from_fn(self.m, self.p.len(), |i, j| jac[i][j]))
    }
}

/// Minimise Σ rᵢ(p)² from `p0` by Levenberg–Marquardt (the `levenberg-marquardt` crate).
/// `residuals` returns `None` where the model cannot be evaluated (such steps are rejected).
pub fn levenberg_marquardt(
    residuals: &dyn Fn(&[f64]) -> Option<Vec<f64>>,
    p0: &[f64],
    options: &LmOptions,
) -> Result<LmFit> {
    let n = p0.len();
    let Some(r0) = residuals(p0).filter(|r| r.iter().all(|v| v.is_finite())) else {
        bail!("the model cannot be evaluated at the starting point");
    };
    let m = r0.len();
    if n == 0 || m < n {
        bail!("{m} data points cannot determine {n} parameters");
    }
    let problem = Problem { f: residuals, p: DVector::from_column_slice(p0), m, fd_step: options.fd_step };
    let (problem, report) = LevenbergMarquardt::new()
        .with_ftol(options.cost_tolerance)
        .with_xtol(options.step_tolerance)
        .with_patience(options.max_iterations)
        .minimize(problem);
    match report.termination {
        TerminationReason::User(what) => bail!("the model cannot be differentiated during the fit ({what})"),
        TerminationReason::Numerical(what) => bail!("the fit met a non-finite {what}"),
        TerminationReason::WrongDimensions(what) => bail!("the model changed its number of residuals ({what})"),
        _ => {}
    }
    let p: Vec<f64> = problem.p.iter().copied().collect();
    let Some(r) = problem.eval(&p) else { bail!("the fit ended outside the model's domain") };
    let c: f64 = r.iter().map(|v| v * v).sum();
    let dof = m - n;
    let s2 = if dof > 0 { c / dof as f64 } else { f64::NAN };
    let covariance = problem.jacobian().and_then(|j| {
        let jtj = j.transpose() * &j;
        // Singular (or nearly: eigenvalue ratio below 1e-13) when a combination of the
        // parameters does not change the residuals.
        let eig = jtj.clone().symmetric_eigen().eigenvalues;
        let (lo, hi) = (eig.min(), eig.max());
        if !(hi > 0.0 && lo > 1e-13 * hi) {
            return None;
        }
        let inv = jtj.try_inverse()?;
        Some((0..n).map(|a| (0..n).map(|b| inv[(a, b)] * s2).collect()).collect())
    });
    Ok(LmFit {
        params: p,
        residual_rms: (c / m as f64).sqrt(),
        residuals: r,
        covariance,
        dof,
        evaluations: report.number_of_evaluations,
    })
}

/// Measured spectra of a milk for [`fit_milk`].
#[derive(Clone, Debug, PartialEq)]
pub struct MilkSpectra {
    /// Wavelengths, nm.
    pub lambda_nm: Vec<f64>,
    /// Reduced scattering coefficient σ'_s(λ), mm⁻¹.
    pub sigma_s_prime_per_mm: Vec<f64>,
    /// Absorption coefficient σ_a(λ), mm⁻¹, if measured.
    pub sigma_a_per_mm: Option<Vec<f64>>,
}

/// Result of [`fit_milk`].
#[derive(Clone, Debug, PartialEq)]
pub struct MilkFit {
    /// Fat content, wt-%.
    pub fat_percent: f64,
    /// 95 % interval of the fat content.
    pub fat_percent_ci: [f64; 2],
    /// Homogenization pressure, MPa.
    pub pressure_mpa: f64,
    /// 95 % interval of the pressure.
    pub pressure_mpa_ci: [f64; 2],
    /// RMS of the relative residuals (model − data)/data.
    pub residual_rms: f64,
    /// Volume-to-surface mean radius of the fat globules at the fit, µm.
    pub fat_r_vs_um: f64,
    /// Fat volume fraction at the fit.
    pub fat_volume_fraction: f64,
}

/// Model spectra (σ'_s, σ_a in mm⁻¹) of the milk model at the given composition.
pub fn milk_model_spectra(fat_percent: f64, protein_percent: f64, pressure_mpa: f64, lambda_nm: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
    let opts = crate::media::BulkOptions { phase_angles: 0 };
    let b = crate::milk::milk_properties_with(fat_percent, protein_percent, pressure_mpa, lambda_nm, &opts)?;
    let sp = (0..lambda_nm.len()).map(|i| b.sigma_s_per_m[i] * (1.0 - b.g[i]) * 1e-3).collect();
    let sa = b.sigma_a_per_m.iter().map(|v| v * 1e-3).collect();
    Ok((sp, sa))
}

/// Infer fat content (wt-%) and homogenization pressure (MPa) of a milk with the given protein
/// content from σ'_s(λ) (and σ_a(λ) when given) through the milk model of Frisvad et al. 2007
/// ([`crate::milk`]): least squares on relative residuals over (fat, ln pressure), pressure in
/// [0.1, 200] MPa, started from a grid search; 95 % intervals from the Jacobian.
pub fn fit_milk(spectra: &MilkSpectra, protein_percent: f64) -> Result<MilkFit> {
    let n = spectra.lambda_nm.len();
    if n < 3 {
        bail!("at least 3 wavelengths are needed to fit fat content and pressure, got {n}");
    }
    let lam = &spectra.lambda_nm;
    let residuals = |p: &[f64]| -> Option<Vec<f64>> {
        let (fat, lp) = (p[0], p[1]);
        if !(fat > 0.0 && fat < 60.0 && lp > (0.1f64).ln() && lp < (200.0f64).ln()) {
            return None;
        }
        let (sp, sa) = milk_model_spectra(fat, protein_percent, lp.exp(), lam).ok()?;
        let mut r: Vec<f64> = sp.iter().zip(&spectra.sigma_s_prime_per_mm).map(|(m, d)| (m - d) / d).collect();
        if let Some(a) = &spectra.sigma_a_per_mm {
            r.extend(sa.iter().zip(a).map(|(m, d)| (m - d) / d.abs().max(1e-12)));
        }
        r.iter().all(|v| v.is_finite()).then_some(r)
    };
    let mut best = (f64::INFINITY, vec![]);
    for &fat in &[0.1, 0.3, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.5, 6.0, 10.0, 20.0, 35.0] {
        for &p in &[0.2, 1.0, 3.0, 7.0, 15.0, 30.0, 60.0, 120.0] {
            let q = [fat, f64::ln(p)];
            if let Some(r) = residuals(&q) {
                let c: f64 = r.iter().map(|v| v * v).sum();
                if c < best.0 {
                    best = (c, q.to_vec());
                }
            }
        }
    }
    if best.1.is_empty() {
        bail!("the milk model cannot be evaluated for these data");
    }
    let fit = levenberg_marquardt(&residuals, &best.1, &LmOptions { fd_step: 1e-5, ..LmOptions::default() })?;
    let (fat, lp) = (fit.params[0], fit.params[1]);
    let (hf, hp) = (fit.ci95_half_width(0), fit.ci95_half_width(1));
    let (r_vs, _) = crate::milk::fat_size_m(fat, lp.exp());
    Ok(MilkFit {
        fat_percent: fat,
        fat_percent_ci: [fat - hf, fat + hf],
        pressure_mpa: lp.exp(),
        pressure_mpa_ci: [(lp - hp).exp(), (lp + hp).exp()],
        residual_rms: fit.residual_rms,
        fat_r_vs_um: r_vs * 1e6,
        fat_volume_fraction: crate::milk::volume_fractions(fat, 0.0).0,
    })
}

/// Result of [`fit_recipe_particle`].
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleFit {
    /// Mean radius of the chosen particle type, µm (r_vs for log-normal sizes, else the radius).
    pub radius_um: f64,
    /// 95 % interval of the radius.
    pub radius_um_ci: [f64; 2],
    /// Volume fraction of the chosen particle type.
    pub volume_fraction: f64,
    /// 95 % interval of the volume fraction.
    pub volume_fraction_ci: [f64; 2],
    /// RMS of the relative residuals.
    pub residual_rms: f64,
}

/// The recipe with particle `index` given mean radius `radius_um` (log-normal: r_vs, with c_s
/// scaled in proportion; monodisperse: the radius) and volume fraction `phi`.
fn recipe_with(recipe: &crate::media::Recipe, index: usize, radius_um: f64, phi: f64) -> Result<crate::media::Recipe> {
    use crate::media::SizeSpec;
    let mut r = recipe.clone();
    let p = &mut r.particles[index];
    p.volume_fraction = Some(phi);
    p.weight_percent = None;
    p.size = match &p.size {
        SizeSpec::Lognormal { r_vs_um, c_s_um } => SizeSpec::Lognormal { r_vs_um: radius_um, c_s_um: c_s_um * radius_um / r_vs_um },
        SizeSpec::Monodisperse { .. } => SizeSpec::Monodisperse { radius_um },
        _ => bail!("particle '{}': only log-normal or monodisperse sizes can be fitted", p.name),
    };
    Ok(r)
}

/// Mean radius (µm) and volume fraction of one particle type of a medium recipe
/// ([`crate::media::Recipe`]) from σ'_s(λ) (and σ_a(λ) when given), all other ingredients held
/// at the recipe's values: least squares on relative residuals in (ln r, ln φ), started from a
/// grid over r ∈ [0.01, 10] µm with φ scaled to the data; 95 % intervals from the Jacobian.
pub fn fit_recipe_particle(recipe: &crate::media::Recipe, particle: &str, spectra: &MilkSpectra) -> Result<ParticleFit> {
    let index = recipe
        .particles
        .iter()
        .position(|p| p.name == particle)
        .ok_or_else(|| anyhow::anyhow!("the recipe has no particle named '{particle}' (has: {})",
            recipe.particles.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", ")))?;
    let n = spectra.lambda_nm.len();
    if n < 3 {
        bail!("at least 3 wavelengths are needed to fit a radius and a volume fraction, got {n}");
    }
    let model = |lr: f64, lphi: f64| -> Option<(Vec<f64>, Vec<f64>)> {
        if !(lr > (1e-3f64).ln() && lr < (100.0f64).ln() && lphi < 0.0) {
            return None;
        }
        let rec = recipe_with(recipe, index, lr.exp(), lphi.exp()).ok()?;
        let b = rec.bulk_properties(Some(&spectra.lambda_nm)).ok()?;
        let sp = (0..n).map(|i| b.sigma_s_per_m[i] * (1.0 - b.g[i]) * 1e-3).collect();
        let sa = b.sigma_a_per_m.iter().map(|v| v * 1e-3).collect();
        Some((sp, sa))
    };
    let residuals = |p: &[f64]| -> Option<Vec<f64>> {
        let (sp, sa) = model(p[0], p[1])?;
        let mut r: Vec<f64> = sp.iter().zip(&spectra.sigma_s_prime_per_mm).map(|(m, d)| (m - d) / d).collect();
        if let Some(a) = &spectra.sigma_a_per_mm {
            r.extend(sa.iter().zip(a).map(|(m, d)| (m - d) / d.abs().max(1e-12)));
        }
        r.iter().all(|v| v.is_finite()).then_some(r)
    };
    let phi0 = 1e-3f64;
    let mut best = (f64::INFINITY, vec![]);
    for i in 0..=24 {
        let lr = (0.01f64).ln() + i as f64 * (1000.0f64).ln() / 24.0;
        let Some((sp, _)) = model(lr, phi0.ln()) else { continue };
        // σ'_s is proportional to φ for dilute media: scale φ to the data's median ratio.
        let mut ratios: Vec<f64> = sp.iter().zip(&spectra.sigma_s_prime_per_mm).map(|(m, d)| d / m).collect();
        ratios.sort_by(f64::total_cmp);
        let lphi = (phi0 * ratios[ratios.len() / 2]).min(0.5).ln();
        if let Some(r) = residuals(&[lr, lphi]) {
            let c: f64 = r.iter().map(|v| v * v).sum();
            if c < best.0 {
                best = (c, vec![lr, lphi]);
            }
        }
    }
    if best.1.is_empty() {
        bail!("the recipe cannot be evaluated for these data");
    }
    let fit = levenberg_marquardt(&residuals, &best.1, &LmOptions { fd_step: 1e-5, ..LmOptions::default() })?;
    let (hr, hp) = (fit.ci95_half_width(0), fit.ci95_half_width(1));
    let (lr, lp) = (fit.params[0], fit.params[1]);
    Ok(ParticleFit {
        radius_um: lr.exp(),
        radius_um_ci: [(lr - hr).exp(), (lr + hr).exp()],
        volume_fraction: lp.exp(),
        volume_fraction_ci: [(lp - hp).exp(), (lp + hp).exp()],
        residual_rms: fit.residual_rms,
    })
}
