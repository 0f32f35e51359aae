//! Lorenz–Mie theory over arrays: `lucent.mie` (size parameter and relative index) and
//! `lucent.mie_sphere` (radius, wavelength and the two indices, absorbing host allowed). The
//! Python wrapper broadcasts the arguments and passes them flat; results come back flat.
//!
//! Each element is computed as `lucent mie` computes one sphere: `MieWorkspace::efficiencies`
//! (real host) or `MieWorkspace::sphere` (any host) for the Q's and g, and the coefficients
//! a_n, b_n of `MieWorkspace::coefficients` for S1, S2 and the phase function.

use crate::errors::{value, OrPy};
use crate::parallel::with_threads;
use anyhow::Context;
use numpy::{IntoPyArray, PyReadonlyArray1};
use optics::mie::{self, Complex64, MieWorkspace};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

/// One sphere's numbers.
#[derive(Default)]
struct Row {
    x: Complex64,
    m: Complex64,
    terms: i64,
    qext: f64,
    qsca: f64,
    qabs: f64,
    qback: f64,
    g: f64,
    c: [f64; 3],
    s1: Vec<Complex64>,
    s2: Vec<Complex64>,
    phase: Vec<f64>,
}

/// " (element i)" when there is more than one element.
fn at(i: usize, n: usize) -> String {
    if n > 1 {
        format!(" (element {i} of the broadcast arrays)")
    } else {
        String::new()
    }
}

fn positive(name: &str, v: f64, i: usize, n: usize) -> PyResult<()> {
    if !v.is_finite() {
        return Err(value(format!("{name}: must be finite, got {v}{}", at(i, n))));
    }
    if v <= 0.0 {
        return Err(value(format!("{name}: must be positive, got {v}{}", at(i, n))));
    }
    Ok(())
}

fn index(name: &str, c: Complex64, i: usize, n: usize) -> PyResult<()> {
    if !(c.re.is_finite() && c.im.is_finite()) {
        return Err(value(format!("{name}: must be finite, got {c}{}", at(i, n))));
    }
    if c.re <= 0.0 {
        return Err(value(format!("{name}: real part must be positive, got {c}{}", at(i, n))));
    }
    if c.im < 0.0 {
        return Err(value(format!(
            "{name}: imaginary part must be ≥ 0 (time dependence e^(−iωt): a positive imaginary part absorbs), got {c}{}",
            at(i, n)
        )));
    }
    Ok(())
}

/// cos θ of the angles in degrees, each in [0, 180].
fn cosines(angles_deg: &[f64]) -> PyResult<Vec<f64>> {
    for &a in angles_deg {
        if !(0.0..=180.0).contains(&a) {
            return Err(value(format!("angles_deg: angles must lie in [0, 180], got {a}")));
        }
    }
    Ok(angles_deg.iter().map(|t| t.to_radians().cos()).collect())
}

/// S1, S2 and p(θ) at the cosines `mu` from the coefficients of (x, m).
fn angular(ws: &mut MieWorkspace, x: Complex64, m: Complex64, mu: &[f64], row: &mut Row) {
    if mu.is_empty() {
        return;
    }
    let (a, b) = ws.coefficients(x, m);
    for &u in mu {
        let (s1, s2) = mie::amplitudes(a, b, u);
        row.s1.push(s1);
        row.s2.push(s2);
        row.phase.push(mie::phase_function(a, b, u));
    }
}

fn angles_vec(angles_deg: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<Option<Vec<f64>>> {
    Ok(match angles_deg {
        Some(a) => Some(a.as_slice()?.to_vec()),
        None => None,
    })
}

/// Flat result arrays into a dict.
fn into_dict<'py>(py: Python<'py>, rows: Vec<Row>, angles: Option<Vec<f64>>, sphere: bool) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let col = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    if sphere {
        d.set_item("x", col(&|r| r.x.re).into_pyarray(py))?;
        d.set_item("x_im", col(&|r| r.x.im).into_pyarray(py))?;
    } else {
        d.set_item("x", col(&|r| r.x.re).into_pyarray(py))?;
    }
    d.set_item("m", rows.iter().map(|r| r.m).collect::<Vec<Complex64>>().into_pyarray(py))?;
    d.set_item("terms", rows.iter().map(|r| r.terms).collect::<Vec<i64>>().into_pyarray(py))?;
    d.set_item("qext", col(&|r| r.qext).into_pyarray(py))?;
    d.set_item("qsca", col(&|r| r.qsca).into_pyarray(py))?;
    d.set_item("qabs", col(&|r| r.qabs).into_pyarray(py))?;
    d.set_item("qback", col(&|r| r.qback).into_pyarray(py))?;
    d.set_item("g", col(&|r| r.g).into_pyarray(py))?;
    if sphere {
        d.set_item("c_ext_m2", col(&|r| r.c[0]).into_pyarray(py))?;
        d.set_item("c_sca_m2", col(&|r| r.c[1]).into_pyarray(py))?;
        d.set_item("c_abs_m2", col(&|r| r.c[2]).into_pyarray(py))?;
    }
    if let Some(theta) = angles {
        let s1: Vec<Complex64> = rows.iter().flat_map(|r| r.s1.iter().copied()).collect();
        let s2: Vec<Complex64> = rows.iter().flat_map(|r| r.s2.iter().copied()).collect();
        let p: Vec<f64> = rows.iter().flat_map(|r| r.phase.iter().copied()).collect();
        d.set_item("theta_deg", theta.into_pyarray(py))?;
        d.set_item("s1", s1.into_pyarray(py))?;
        d.set_item("s2", s2.into_pyarray(py))?;
        d.set_item("phase_per_sr", p.into_pyarray(py))?;
    }
    Ok(d)
}

/// Mie efficiencies (and amplitudes at `angles_deg`) of spheres of size parameter `x` and
/// relative index `m` in a non-absorbing host; flat arrays of equal length.
#[pyfunction]
#[pyo3(signature = (x, m, angles_deg=None, threads=None))]
pub fn mie_flat<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    m: PyReadonlyArray1<'py, Complex64>,
    angles_deg: Option<PyReadonlyArray1<'py, f64>>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let x = x.as_slice()?.to_vec();
    let m = m.as_slice()?.to_vec();
    if x.len() != m.len() {
        return Err(value(format!("x and m: {} and {} elements after broadcasting", x.len(), m.len())));
    }
    let n = x.len();
    // The first element that fails any check is the one reported. The size check runs inside
    // `efficiencies` (which returns no terms where it fails), so it is repeated here only for the
    // elements before the first other failure, or after the computation for the first element
    // without terms.
    let size_check = |i: usize| mie::check_size(Complex64::new(x[i], 0.0), m[i]).with_context(|| format!("x, m{}", at(i, n))).or_py();
    if let Some(j) = (0..n).find(|&i| positive("x", x[i], i, n).is_err() || index("m", m[i], i, n).is_err()) {
        for i in 0..j {
            size_check(i)?;
        }
        positive("x", x[j], j, n)?;
        index("m", m[j], j, n)?;
    }
    let angles = angles_vec(angles_deg)?;
    let mu = cosines(angles.as_deref().unwrap_or(&[]))?;
    let rows = py.allow_threads(|| {
        with_threads(threads, || {
            (0..n)
                .into_par_iter()
                .with_min_len(8)
                .map_init(MieWorkspace::new, |ws, i| {
                    let e = ws.efficiencies(x[i], m[i]);
                    let mut row = Row {
                        x: Complex64::new(x[i], 0.0),
                        m: m[i],
                        terms: e.terms as i64,
                        qext: e.qext,
                        qsca: e.qsca,
                        qabs: e.qabs,
                        qback: e.qback,
                        g: e.g,
                        ..Row::default()
                    };
                    if row.terms > 0 {
                        angular(ws, row.x, m[i], &mu, &mut row);
                    }
                    row
                })
                .collect::<Vec<Row>>()
        })
    })?;
    if let Some(i) = rows.iter().position(|r| r.terms == 0) {
        size_check(i)?;
    }
    into_dict(py, rows, angles, false)
}

/// Mie cross sections of spheres of radius `radius_m` at vacuum wavelength `wavelength_m`, index
/// `n_particle` in a host of index `n_medium` (absorbing when its imaginary part is > 0); flat
/// arrays of equal length.
#[pyfunction]
#[pyo3(signature = (radius_m, wavelength_m, n_particle, n_medium, angles_deg=None, threads=None))]
pub fn mie_sphere_flat<'py>(
    py: Python<'py>,
    radius_m: PyReadonlyArray1<'py, f64>,
    wavelength_m: PyReadonlyArray1<'py, f64>,
    n_particle: PyReadonlyArray1<'py, Complex64>,
    n_medium: PyReadonlyArray1<'py, Complex64>,
    angles_deg: Option<PyReadonlyArray1<'py, f64>>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let r = radius_m.as_slice()?.to_vec();
    let l = wavelength_m.as_slice()?.to_vec();
    let np = n_particle.as_slice()?.to_vec();
    let nm = n_medium.as_slice()?.to_vec();
    let n = r.len();
    if l.len() != n || np.len() != n || nm.len() != n {
        return Err(value("radius_m, wavelength_m, n_particle, n_medium: arrays of different lengths after broadcasting"));
    }
    for i in 0..n {
        positive("radius_m", r[i], i, n)?;
        positive("wavelength_m", l[i], i, n)?;
        index("n_particle", np[i], i, n)?;
        index("n_medium", nm[i], i, n)?;
        let x = mie::size_parameter(r[i], l[i], nm[i]);
        mie::check_size(x, np[i] / nm[i]).with_context(|| format!("radius_m, wavelength_m, n_particle, n_medium{}", at(i, n))).or_py()?;
        let alpha = 2.0 * x.im;
        if alpha > mie::MAX_HOST_ATTENUATION {
            return Err(value(format!(
                "n_medium: the host absorbs too strongly for this sphere (4πr·n″/λ = {alpha:.3} > {}): the light dies out inside one diameter{}",
                mie::MAX_HOST_ATTENUATION,
                at(i, n)
            )));
        }
    }
    let angles = angles_vec(angles_deg)?;
    let mu = cosines(angles.as_deref().unwrap_or(&[]))?;
    let rows = py.allow_threads(|| {
        with_threads(threads, || {
            (0..n)
                .into_par_iter()
                .with_min_len(8)
                .map_init(MieWorkspace::new, |ws, i| {
                    let s = ws.sphere(r[i], l[i], np[i], nm[i]);
                    let x = mie::size_parameter(r[i], l[i], nm[i]);
                    let m = np[i] / nm[i];
                    let mut row = Row {
                        x,
                        m,
                        terms: s.eff.terms as i64,
                        qext: s.eff.qext,
                        qsca: s.eff.qsca,
                        qabs: s.eff.qabs,
                        qback: s.eff.qback,
                        g: s.eff.g,
                        c: [s.c_ext_m2, s.c_sca_m2, s.c_abs_m2],
                        ..Row::default()
                    };
                    angular(ws, x, m, &mu, &mut row);
                    row
                })
                .collect::<Vec<Row>>()
        })
    })?;
    into_dict(py, rows, angles, true)
}
