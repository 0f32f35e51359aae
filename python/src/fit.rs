//! Inverse problems on arrays: σ_a and σ'_s from a spatially resolved diffuse reflectance
//! profile (`lucent fit reflectance`) and a product's composition from σ'_s spectra
//! (`lucent fit particles`), with their 95 % intervals.

use crate::errors::{value, OrPy};
use anyhow::Context;
use optics::fitting::{fit_milk, MilkSpectra};
use optics::reflectometry::{self, Estimate, FitOptions, MonteCarloTable, ReflectanceProfile, ReflectanceModel};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

fn finite_nonnegative(name: &str, v: &[f64], what: &str) -> PyResult<()> {
    for (i, &x) in v.iter().enumerate() {
        if !x.is_finite() {
            return Err(value(format!("{name}[{i}]: {x} is not finite")));
        }
        if x < 0.0 {
            return Err(value(format!("{name}[{i}]: negative {what} {x}")));
        }
    }
    Ok(())
}

fn increasing(name: &str, v: &[f64]) -> PyResult<()> {
    for i in 1..v.len() {
        if v[i] <= v[i - 1] {
            return Err(value(format!("{name}[{i}]: {} does not increase (previous {})", v[i], v[i - 1])));
        }
    }
    Ok(())
}

fn est<'py>(d: &Bound<'py, PyDict>, key: &str, ci_key: &str, e: Option<Estimate>) -> PyResult<()> {
    match e {
        Some(e) => {
            d.set_item(key, e.value)?;
            d.set_item(ci_key, e.ci95.to_vec())?;
        }
        None => {
            d.set_item(key, d.py().None())?;
            d.set_item(ci_key, d.py().None())?;
        }
    }
    Ok(())
}

/// Fit σ_a and σ'_s to R(r) (`lucent fit reflectance`, one profile).
#[pyfunction]
#[pyo3(signature = (r_mm, reflectance, eta, model, stderr, relative, r_min_mm, r_max_mm, noise, table))]
#[allow(clippy::too_many_arguments)]
pub fn fit_reflectance<'py>(
    py: Python<'py>,
    r_mm: Vec<f64>,
    reflectance: Vec<f64>,
    eta: f64,
    model: &str,
    stderr: Option<Vec<f64>>,
    relative: bool,
    r_min_mm: f64,
    r_max_mm: Option<f64>,
    noise: f64,
    table: Option<PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    if !(eta.is_finite() && eta > 0.0) {
        return Err(value(format!("eta must be finite and > 0, got {eta}")));
    }
    if !(noise.is_finite() && noise > 0.0) {
        return Err(value(format!("noise must be finite and > 0, got {noise}")));
    }
    if !(r_min_mm.is_finite() && r_min_mm >= 0.0) {
        return Err(value(format!("r_min_mm must be ≥ 0, got {r_min_mm}")));
    }
    if let Some(r) = r_max_mm {
        if r.is_nan() || r <= r_min_mm {
            return Err(value(format!("r_max_mm ({r}) must be greater than r_min_mm ({r_min_mm})")));
        }
    }
    if r_mm.is_empty() {
        return Err(value("r_mm: no data"));
    }
    if reflectance.len() != r_mm.len() {
        return Err(value(format!("reflectance: {} values for {} distances r_mm", reflectance.len(), r_mm.len())));
    }
    finite_nonnegative("r_mm", &r_mm, "distance")?;
    finite_nonnegative("reflectance", &reflectance, "reflectance")?;
    increasing("r_mm", &r_mm)?;
    if let Some(s) = &stderr {
        if s.len() != r_mm.len() {
            return Err(value(format!("stderr: {} values for {} distances r_mm", s.len(), r_mm.len())));
        }
        finite_nonnegative("stderr", s, "standard error")?;
    }
    let model = match model {
        "dipole" => ReflectanceModel::Dipole,
        "directional" => ReflectanceModel::Directional,
        "montecarlo" => {
            let t = match &table {
                Some(p) => {
                    let text = std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display())).or_py()?;
                    MonteCarloTable::from_csv(&text, &p.display().to_string()).or_py()?
                }
                None => reflectometry::bundled_table(eta).or_py()?.ok_or_else(|| {
                    value(format!(
                        "no bundled Monte Carlo table for eta {eta} (bundled: {}); build one with `lucent fit mc-table --eta {eta} --out TABLE.csv` and pass table=\"TABLE.csv\"",
                        reflectometry::BUNDLED_TABLE_ETAS.map(|e| e.to_string()).join(", ")
                    ))
                })?,
            };
            if (t.eta - eta).abs() > 1e-6 {
                return Err(value(format!("the Monte Carlo table was built for eta {} but eta is {eta}", t.eta)));
            }
            ReflectanceModel::MonteCarlo(t)
        }
        other => return Err(value(format!("model: '{other}' is not one of dipole, directional, montecarlo"))),
    };
    let bin = reflectometry::detect_bins(&r_mm);
    let profile = ReflectanceProfile { lambda_nm: None, r_mm, value: reflectance, stderr, relative };
    let options = FitOptions { r_min_mm, r_max_mm: r_max_mm.unwrap_or(f64::INFINITY), relative_noise: noise, bin_width_mm: bin };
    let mut f = py.allow_threads(|| reflectometry::fit_reflectance(&profile, &model, eta, &options)).or_py()?;
    if let Some(h) = bin {
        f.notes.push(format!("r_mm are centres of {} mm bins: the model is averaged over each annulus", sig(h, 6)));
    }
    let d = PyDict::new(py);
    d.set_item("model", model.name())?;
    d.set_item("eta", eta)?;
    d.set_item("relative", relative)?;
    est(&d, "sigma_a_per_mm", "sigma_a_ci_per_mm", f.sigma_a_per_mm)?;
    est(&d, "sigma_s_prime_per_mm", "sigma_s_prime_ci_per_mm", f.sigma_s_prime_per_mm)?;
    est(&d, "mu_eff_per_mm", "mu_eff_ci_per_mm", f.mu_eff_per_mm)?;
    est(&d, "sigma_s_prime_over_sigma_a", "sigma_s_prime_over_sigma_a_ci", f.sigma_s_prime_over_sigma_a)?;
    d.set_item("residual_rms", f.residual_rms)?;
    d.set_item("relative_rms", f.relative_rms)?;
    d.set_item("points", f.points)?;
    d.set_item("notes", f.notes)?;
    Ok(d)
}

/// `digits` significant digits, trailing zeros dropped (as the `lucent` command writes notes).
fn sig(v: f64, digits: usize) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let e = v.abs().log10().floor() as i32;
    if (-4..digits as i32).contains(&e) {
        let decimals = (digits as i32 - 1 - e).max(0) as usize;
        let t = format!("{v:.decimals$}");
        if t.contains('.') { t.trim_end_matches('0').trim_end_matches('.').to_string() } else { t }
    } else {
        let t = format!("{v:.*e}", digits - 1);
        match t.split_once('e') {
            Some((mant, exp)) if mant.contains('.') => format!("{}e{exp}", mant.trim_end_matches('0').trim_end_matches('.')),
            _ => t,
        }
    }
}

/// A product's composition from σ'_s spectra (`lucent fit particles`): milk's fat content and
/// homogenization pressure, or a recipe particle's mean radius and volume fraction.
#[pyfunction]
#[pyo3(signature = (wavelength_nm, sigma_s_prime_per_mm, sigma_a_per_mm, medium, particle, protein_percent))]
pub fn fit_particles<'py>(
    py: Python<'py>,
    wavelength_nm: Vec<f64>,
    sigma_s_prime_per_mm: Vec<f64>,
    sigma_a_per_mm: Option<Vec<f64>>,
    medium: &str,
    particle: Option<String>,
    protein_percent: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if wavelength_nm.is_empty() {
        return Err(value("wavelength_nm: no data"));
    }
    let n = wavelength_nm.len();
    if sigma_s_prime_per_mm.len() != n {
        return Err(value(format!("sigma_s_prime_per_mm: {} values for {n} wavelengths", sigma_s_prime_per_mm.len())));
    }
    finite_nonnegative("wavelength_nm", &wavelength_nm, "wavelength")?;
    increasing("wavelength_nm", &wavelength_nm)?;
    finite_nonnegative("sigma_s_prime_per_mm", &sigma_s_prime_per_mm, "coefficient")?;
    if let Some(i) = sigma_s_prime_per_mm.iter().position(|&v| v <= 0.0) {
        return Err(value(format!("sigma_s_prime_per_mm[{i}]: must be > 0")));
    }
    if let Some(a) = &sigma_a_per_mm {
        if a.len() != n {
            return Err(value(format!("sigma_a_per_mm: {} values for {n} wavelengths", a.len())));
        }
        finite_nonnegative("sigma_a_per_mm", a, "coefficient")?;
    }
    if !(protein_percent.is_finite() && (0.0..100.0).contains(&protein_percent)) {
        return Err(value(format!("protein_percent must lie in [0, 100), got {protein_percent}")));
    }
    let spectra = MilkSpectra { lambda_nm: wavelength_nm, sigma_s_prime_per_mm, sigma_a_per_mm };
    let d = PyDict::new(py);
    if medium != "milk" {
        let path = PathBuf::from(medium);
        let recipe = optics::media::Recipe::load(&path).with_context(|| format!("medium {}", path.display())).or_py()?;
        let particle = particle.ok_or_else(|| value("particle=NAME is needed with a recipe medium"))?;
        if !recipe.particles.iter().any(|p| p.name == particle) {
            let names: Vec<String> = recipe.particles.iter().map(|p| format!("{:?}", p.name)).collect();
            return Err(value(format!(
                "particle: recipe {} has no particle named {particle:?} (it has: {})",
                path.display(),
                if names.is_empty() { "none".into() } else { names.join(", ") }
            )));
        }
        recipe
            .bulk_properties(Some(&spectra.lambda_nm))
            .with_context(|| format!("medium {} at the wavelengths given", path.display()))
            .or_py()?;
        let f = py
            .allow_threads(|| optics::fitting::fit_recipe_particle(&recipe, &particle, &spectra))
            .with_context(|| format!("fitting particle {particle:?} of {}", path.display()))
            .or_py()?;
        d.set_item("medium", medium)?;
        d.set_item("particle", particle)?;
        d.set_item("radius_um", f.radius_um)?;
        d.set_item("radius_um_ci", f.radius_um_ci.to_vec())?;
        d.set_item("volume_fraction", f.volume_fraction)?;
        d.set_item("volume_fraction_ci", f.volume_fraction_ci.to_vec())?;
        d.set_item("residual_rms", f.residual_rms)?;
        return Ok(d);
    }
    if particle.is_some() {
        return Err(value("particle applies to a recipe medium only, not to milk"));
    }
    let f = py.allow_threads(|| fit_milk(&spectra, protein_percent)).or_py()?;
    d.set_item("medium", "milk")?;
    d.set_item("protein_percent", protein_percent)?;
    d.set_item("fat_percent", f.fat_percent)?;
    d.set_item("fat_percent_ci", f.fat_percent_ci.to_vec())?;
    d.set_item("pressure_mpa", f.pressure_mpa)?;
    d.set_item("pressure_mpa_ci", f.pressure_mpa_ci.to_vec())?;
    d.set_item("residual_rms", f.residual_rms)?;
    d.set_item("fat_r_vs_um", f.fat_r_vs_um)?;
    d.set_item("fat_volume_fraction", f.fat_volume_fraction)?;
    Ok(d)
}
