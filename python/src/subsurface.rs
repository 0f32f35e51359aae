//! The dipole BSSRDF models (`lucent bssrdf`): total diffuse reflectance `rd` = π∫S_d dA of a
//! flat half-space under normal incidence, the standard dipole's closed form, and the radial
//! profile R_d(r) = π S_d(r) in mm⁻², over flat arrays of media.

use crate::errors::{value, OrPy};
use anyhow::Context;
use numpy::{IntoPyArray, PyReadonlyArray1};
use optics::bssrdf::{DipoleModel, DirectionalDipole, DirectionalLineDipole, OpticalProperties, StandardDipole};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

/// Largest distance of a profile (1000 km), as `lucent bssrdf --profile-mm` accepts.
const MAX_PROFILE_MM: f64 = 1e9;

struct Row {
    alpha_prime: f64,
    sigma_tr_per_mm: f64,
    d_mm: f64,
    a: f64,
    rd: f64,
    rd_closed_form: f64,
    profile: Vec<f64>,
}

fn evaluate(model: DipoleModel, props: &OpticalProperties, profile_mm: &[f64], want_rd: bool) -> anyhow::Result<Row> {
    let derived = props.derive().context("invalid medium (eta, sigma_s_per_mm, sigma_a_per_mm, g)")?;
    let standard = StandardDipole::new(props)?;
    let directional = DirectionalDipole::new(props)?;
    let line = DirectionalLineDipole::new(props)?;
    let profile_fn = |r_mm: f64| -> f64 {
        let r_m = r_mm * 1e-3;
        1e-6 * match model {
            DipoleModel::Standard => standard.rd_profile(r_m),
            DipoleModel::Directional => directional.rd_profile(r_m),
            DipoleModel::DirectionalCorrected => line.rd_profile(r_m),
        }
    };
    let rd = if want_rd {
        match model {
            DipoleModel::Standard => standard.rd_numerical(),
            DipoleModel::Directional => directional.rd_numerical(),
            DipoleModel::DirectionalCorrected => line.rd_numerical(),
        }
    } else {
        f64::NAN
    };
    let a = match model {
        DipoleModel::Standard => standard.a,
        DipoleModel::Directional | DipoleModel::DirectionalCorrected => directional.a,
    };
    Ok(Row {
        alpha_prime: derived.alpha_prime,
        sigma_tr_per_mm: derived.sigma_tr_per_m * 1e-3,
        d_mm: derived.d_m * 1e3,
        a,
        rd,
        rd_closed_form: standard.rd_closed_form(),
        profile: profile_mm.iter().map(|&r| profile_fn(r)).collect(),
    })
}

/// Dipole model numbers for media given as flat arrays of equal length (η, σ_s and σ_a in mm⁻¹,
/// g); `profile_mm` distances in mm (any number, the same for every medium).
#[pyfunction]
#[pyo3(signature = (model, eta, sigma_s_per_mm, sigma_a_per_mm, g, profile_mm, rd))]
#[allow(clippy::too_many_arguments)]
pub fn dipole_flat<'py>(
    py: Python<'py>,
    model: &str,
    eta: PyReadonlyArray1<'py, f64>,
    sigma_s_per_mm: PyReadonlyArray1<'py, f64>,
    sigma_a_per_mm: PyReadonlyArray1<'py, f64>,
    g: PyReadonlyArray1<'py, f64>,
    profile_mm: Option<PyReadonlyArray1<'py, f64>>,
    rd: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let kind: DipoleModel = model.parse::<DipoleModel>().context("model").or_py()?;
    let (eta, ss, sa, g) = (eta.as_slice()?.to_vec(), sigma_s_per_mm.as_slice()?.to_vec(), sigma_a_per_mm.as_slice()?.to_vec(), g.as_slice()?.to_vec());
    let n = eta.len();
    if ss.len() != n || sa.len() != n || g.len() != n {
        return Err(value("eta, sigma_s_per_mm, sigma_a_per_mm, g: arrays of different lengths after broadcasting"));
    }
    let profile: Vec<f64> = match &profile_mm {
        Some(p) => p.as_slice()?.to_vec(),
        None => Vec::new(),
    };
    for &r in &profile {
        if !r.is_finite() || r < 0.0 {
            return Err(value(format!("profile_mm: distance {r} must be finite and ≥ 0")));
        }
        if r > MAX_PROFILE_MM {
            return Err(value(format!("profile_mm: distance {r} is above the supported {MAX_PROFILE_MM:e} mm")));
        }
    }
    let props: Vec<OpticalProperties> = (0..n)
        .map(|i| OpticalProperties { eta: eta[i], sigma_s_per_m: ss[i] * 1e3, sigma_a_per_m: sa[i] * 1e3, g: g[i] })
        .collect();
    for (i, p) in props.iter().enumerate() {
        for (name, v) in [("eta", p.eta), ("sigma_s_per_mm", ss[i]), ("sigma_a_per_mm", sa[i]), ("g", p.g)] {
            if !v.is_finite() {
                return Err(value(format!("{name}: must be finite, got {v}")));
            }
        }
    }
    let want_rd = rd || profile_mm.is_none();
    let rows = py
        .allow_threads(|| props.par_iter().map(|p| evaluate(kind, p, &profile, want_rd)).collect::<anyhow::Result<Vec<Row>>>())
        .or_py()?;
    let d = PyDict::new(py);
    let col = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).collect::<Vec<f64>>().into_pyarray(py);
    d.set_item("model", model)?;
    d.set_item("eta", eta.into_pyarray(py))?;
    d.set_item("sigma_s_per_mm", ss.into_pyarray(py))?;
    d.set_item("sigma_a_per_mm", sa.into_pyarray(py))?;
    d.set_item("g", g.into_pyarray(py))?;
    d.set_item("alpha_prime", col(&|r| r.alpha_prime))?;
    d.set_item("sigma_tr_per_mm", col(&|r| r.sigma_tr_per_mm))?;
    d.set_item("d_mm", col(&|r| r.d_mm))?;
    d.set_item("a", col(&|r| r.a))?;
    if want_rd {
        d.set_item("rd", col(&|r| r.rd))?;
        d.set_item("rd_closed_form", col(&|r| r.rd_closed_form))?;
    }
    if profile_mm.is_some() {
        d.set_item("profile_mm", profile.clone().into_pyarray(py))?;
        let flat: Vec<f64> = rows.iter().flat_map(|r| r.profile.iter().copied()).collect();
        d.set_item("profile", flat.into_pyarray(py))?;
    }
    Ok(d)
}
