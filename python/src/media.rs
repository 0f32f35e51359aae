//! Bulk optical properties of media: `lucent.milk` (content declaration) and `lucent.medium`
//! (a recipe file or a dict with the recipe's keys), as `lucent medium … --json` reports them.

use crate::errors::{value, OrPy};
use numpy::{IntoPyArray, PyArrayMethods};
use numpy::PyArray1;
use optics::media::{self, BulkOptions, BulkProperties, Recipe};
use optics::milk as milk_model;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// Wavelengths in nm through the same parser as `--wavelengths-nm` (each written exactly).
fn wavelengths(v: Option<Vec<f64>>) -> PyResult<Option<Vec<f64>>> {
    match v {
        None => Ok(None),
        Some(v) if v.is_empty() => Err(value("wavelengths_nm: no wavelengths given")),
        Some(v) => {
            let text = v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(",");
            media::parse_wavelengths_nm(&text).map(Some).map_err(|e| value(format!("wavelengths_nm: {}", crate::errors::one_line(&e))))
        }
    }
}

fn check_phase_angles(n: Option<usize>) -> PyResult<()> {
    if let Some(n) = n {
        if n > media::MAX_PHASE_ANGLES {
            return Err(value(format!("phase_angles: at most {}, got {n}", media::MAX_PHASE_ANGLES)));
        }
    }
    Ok(())
}

/// The keys of `lucent medium --json`, coefficients in mm⁻¹, arrays as numpy arrays.
fn to_dict<'py>(py: Python<'py>, p: &BulkProperties, name: &str) -> PyResult<Bound<'py, PyDict>> {
    let mm = |v: &[f64]| v.iter().map(|x| x * 1e-3).collect::<Vec<f64>>().into_pyarray(py);
    let d = PyDict::new(py);
    d.set_item("wavelength_nm", PyArray1::from_slice(py, &p.lambda_nm))?;
    d.set_item("sigma_s_per_mm", mm(&p.sigma_s_per_m))?;
    d.set_item("sigma_a_per_mm", mm(&p.sigma_a_per_m))?;
    d.set_item("sigma_t_per_mm", mm(&p.sigma_t_per_m))?;
    d.set_item("g", PyArray1::from_slice(py, &p.g))?;
    d.set_item("name", name)?;
    d.set_item("host_sigma_a_per_mm", mm(&p.host_sigma_a_per_m))?;
    let comps = PyList::empty(py);
    for c in &p.components {
        let cd = PyDict::new(py);
        cd.set_item("name", &c.name)?;
        cd.set_item("sigma_s_per_mm", mm(&c.sigma_s_per_m))?;
        cd.set_item("sigma_t_per_mm", mm(&c.sigma_t_per_m))?;
        cd.set_item("g", PyArray1::from_slice(py, &c.g))?;
        comps.append(cd)?;
    }
    d.set_item("components", comps)?;
    if let Some(t) = &p.phase {
        d.set_item("theta_deg", PyArray1::from_slice(py, &t.theta_deg))?;
        let flat: Vec<f64> = t.per_sr.iter().flatten().copied().collect();
        let arr = flat.into_pyarray(py).reshape([t.per_sr.len(), t.theta_deg.len()])?;
        d.set_item("phase_per_sr", arr)?;
    }
    Ok(d)
}

/// Milk from its content declaration (`lucent medium milk`).
#[pyfunction]
#[pyo3(signature = (fat_percent, protein_percent, pressure_mpa, wavelengths_nm, phase_angles))]
pub fn milk<'py>(
    py: Python<'py>,
    fat_percent: f64,
    protein_percent: f64,
    pressure_mpa: f64,
    wavelengths_nm: Option<Vec<f64>>,
    phase_angles: usize,
) -> PyResult<Bound<'py, PyDict>> {
    for (name, v) in [("fat_percent", fat_percent), ("protein_percent", protein_percent), ("pressure_mpa", pressure_mpa)] {
        if !v.is_finite() {
            return Err(value(format!("{name}: must be finite, got {v}")));
        }
    }
    check_phase_angles(Some(phase_angles))?;
    milk_model::validate(fat_percent, protein_percent, pressure_mpa).or_py()?;
    let l = match wavelengths(wavelengths_nm)? {
        Some(l) => l,
        None => media::parse_wavelengths_nm("375:775:25").or_py()?,
    };
    let opts = BulkOptions { phase_angles };
    let p = py.allow_threads(|| milk_model::milk_properties_with(fat_percent, protein_percent, pressure_mpa, &l, &opts)).or_py()?;
    to_dict(py, &p, &format!("milk: {fat_percent} % fat, {protein_percent} % protein, {pressure_mpa} MPa"))
}

fn recipe_properties<'py>(
    py: Python<'py>,
    mut recipe: Recipe,
    label: String,
    wavelengths_nm: Option<Vec<f64>>,
    phase_angles: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    check_phase_angles(phase_angles)?;
    let lambda = wavelengths(wavelengths_nm)?;
    if let Some(n) = phase_angles {
        recipe.phase_angles = n;
    }
    let p = py
        .allow_threads(|| recipe.bulk_properties(lambda.as_deref()))
        .map_err(|e| anyhow::anyhow!("recipe {label}: {e:#}"))
        .or_py()?;
    let name = if recipe.name.is_empty() { label } else { recipe.name.clone() };
    to_dict(py, &p, &name)
}

/// A medium recipe file (`lucent medium RECIPE.toml`).
#[pyfunction]
#[pyo3(signature = (path, wavelengths_nm, phase_angles))]
pub fn medium_file<'py>(py: Python<'py>, path: PathBuf, wavelengths_nm: Option<Vec<f64>>, phase_angles: Option<usize>) -> PyResult<Bound<'py, PyDict>> {
    let recipe = Recipe::load(&path).or_py()?;
    recipe_properties(py, recipe, path.display().to_string(), wavelengths_nm, phase_angles)
}

/// A medium recipe given as JSON text (a Python dict with the recipe's keys, `json.dumps`ed).
#[pyfunction]
#[pyo3(signature = (text, wavelengths_nm, phase_angles))]
pub fn medium_json<'py>(py: Python<'py>, text: &str, wavelengths_nm: Option<Vec<f64>>, phase_angles: Option<usize>) -> PyResult<Bound<'py, PyDict>> {
    let recipe: Recipe = serde_json::from_str(text).map_err(|e| value(format!("recipe: {e}")))?;
    recipe_properties(py, recipe, "<dict>".to_string(), wavelengths_nm, phase_angles)
}
