//! Layered-slab Monte Carlo photon transport (`lucent slab --json`): the same keys, arrays as
//! numpy arrays.

use crate::errors::{value, OrPy};
use crate::parallel::with_threads;
use anyhow::Context;
use numpy::PyArray1;
use optics::slab::{simulate, Layer, LineGrid, RadialGrid, SlabSettings};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Photon transport in `layers` (top first; each σ_a, σ_s in mm⁻¹, g, n, thickness in mm, `inf`
/// for a semi-infinite last layer).
#[pyfunction]
#[pyo3(signature = (layers, n_above, n_below, photons, seed, radial_bins, radial_max_mm, incidence_deg, line_bins, line_max_mm, max_steps_per_photon, threads))]
#[allow(clippy::too_many_arguments)]
pub fn slab<'py>(
    py: Python<'py>,
    layers: Vec<[f64; 5]>,
    n_above: f64,
    n_below: f64,
    photons: u64,
    seed: u64,
    radial_bins: Option<usize>,
    radial_max_mm: Option<f64>,
    incidence_deg: f64,
    line_bins: Option<usize>,
    line_max_mm: Option<f64>,
    max_steps_per_photon: u64,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    if layers.is_empty() {
        return Err(value("layers: at least one layer is needed"));
    }
    let count = layers.len();
    let mut stack = Vec::with_capacity(count);
    for (i, v) in layers.iter().enumerate() {
        let l = Layer { mua_per_mm: v[0], mus_per_mm: v[1], g: v[2], n: v[3], thickness_mm: v[4] };
        for (name, x) in [("SIGMA_A", v[0]), ("SIGMA_S", v[1]), ("G", v[2]), ("N", v[3])] {
            if !x.is_finite() {
                return Err(value(format!("layers[{i}]: {name} = {x} is not a finite number")));
            }
        }
        l.validate().with_context(|| format!("layers[{i}]")).or_py()?;
        if l.thickness_mm.is_infinite() && i + 1 != count {
            return Err(value(format!("layers[{i}]: only the last layer may be semi-infinite (thickness inf)")));
        }
        stack.push(l);
    }
    let default_max_mm = optics::slab::default_tally_max_mm(&stack);
    let radial = match (radial_bins, radial_max_mm) {
        (None, None) => None,
        (None, Some(_)) => return Err(value("radial_max_mm needs radial_bins")),
        (Some(bins), max) => Some(RadialGrid { bins, max_mm: max.unwrap_or(default_max_mm) }),
    };
    let line = match (line_bins, line_max_mm) {
        (None, None) => None,
        (None, Some(_)) => return Err(value("line_max_mm needs line_bins")),
        (Some(bins), max) => Some(LineGrid { bins, max_mm: max.unwrap_or(default_max_mm) }),
    };
    let settings = SlabSettings { layers: stack, n_above, n_below, photons, seed, radial, incidence_deg, line, max_steps_per_photon };
    optics::slab::validate(&settings).or_py()?;
    let r = py.allow_threads(|| with_threads(threads, || simulate(&settings)))?.or_py()?;
    let d = PyDict::new(py);
    d.set_item("specular", r.specular)?;
    d.set_item("rd", r.rd)?;
    d.set_item("rd_stderr", r.rd_stderr)?;
    d.set_item("absorbed", r.absorbed)?;
    d.set_item("absorbed_stderr", r.absorbed_stderr)?;
    d.set_item("absorbed_per_layer", PyArray1::from_slice(py, &r.absorbed_per_layer))?;
    d.set_item("tt", r.tt)?;
    d.set_item("tt_stderr", r.tt_stderr)?;
    d.set_item("roulette_gain", r.roulette_gain)?;
    d.set_item("photons_truncated", r.photons_truncated)?;
    d.set_item("truncated_weight", r.truncated_weight)?;
    d.set_item("max_steps_per_photon", settings.max_steps_per_photon)?;
    d.set_item("photons", r.photons)?;
    d.set_item("seed", settings.seed)?;
    d.set_item("incidence_deg", settings.incidence_deg)?;
    d.set_item("rd_centroid_x_mm", r.rd_centroid_x_mm)?;
    d.set_item("n_above", settings.n_above)?;
    d.set_item("n_below", settings.n_below)?;
    let ls = PyList::empty(py);
    for l in &settings.layers {
        let ld = PyDict::new(py);
        ld.set_item("mua_per_mm", l.mua_per_mm)?;
        ld.set_item("mus_per_mm", l.mus_per_mm)?;
        ld.set_item("g", l.g)?;
        ld.set_item("n", l.n)?;
        ld.set_item("thickness_mm", l.thickness_mm)?;
        ls.append(ld)?;
    }
    d.set_item("layers", ls)?;
    d.set_item("photon_steps", r.photon_steps)?;
    d.set_item("seconds", r.seconds)?;
    d.set_item("threads", r.threads)?;
    d.set_item("photon_steps_per_s", r.photon_steps_per_s())?;
    d.set_item("photon_steps_per_s_per_thread", r.photon_steps_per_s() / r.threads as f64)?;
    d.set_item("cpu_seconds", r.cpu_seconds)?;
    d.set_item("photon_steps_per_cpu_s", r.photon_steps_per_cpu_s())?;
    if let Some(rad) = &r.radial {
        let rd = PyDict::new(py);
        rd.set_item("r_mm", PyArray1::from_slice(py, &rad.r_mm))?;
        rd.set_item("rd_per_mm2", PyArray1::from_slice(py, &rad.rd_per_mm2))?;
        rd.set_item("rd_per_mm2_stderr", PyArray1::from_slice(py, &rad.rd_per_mm2_stderr))?;
        rd.set_item("dr_mm", rad.dr_mm)?;
        rd.set_item("rd_beyond_max", rad.rd_beyond_max)?;
        d.set_item("radial", rd)?;
    }
    if let Some(line) = &r.line {
        let ld = PyDict::new(py);
        ld.set_item("x_mm", PyArray1::from_slice(py, &line.x_mm))?;
        ld.set_item("rd_per_mm2", PyArray1::from_slice(py, &line.rd_per_mm2))?;
        ld.set_item("rd_per_mm2_stderr", PyArray1::from_slice(py, &line.rd_per_mm2_stderr))?;
        ld.set_item("dx_mm", line.dx_mm)?;
        d.set_item("line", ld)?;
    }
    Ok(d)
}
