//! Pixelwise comparison of two images (`lucent compare --json`): RMSE, relMSE, PSNR, SSIM, mean
//! ΔE2000, after an optional robust colour fit; the same keys, and the per-pixel ΔE2000 map.

use crate::errors::{value, OrPy};
use analysis::compare::{compare_with, ColorFitOptions, ColorModel, Mask};
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use render::image_io::Image;

fn image(name: &str, flat: &[f32], width: u32, height: u32) -> PyResult<Image> {
    let rgb: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Image::from_rgb(width, height, rgb).map_err(|e| value(format!("{name}: {}", crate::errors::one_line(&e))))
}

/// Compare `render` with the reference `photo`, both flat linear RGB (row-major, top row first)
/// of `width`×`height` pixels; `mask_image` (flat RGB: inside where the channel mean > 0.5) or
/// `mask_flags` (one flag per pixel) limits the pixels compared.
#[pyfunction]
#[pyo3(signature = (render, photo, width, height, mask_image, mask_flags, color_correct, saturation))]
#[allow(clippy::too_many_arguments)]
pub fn compare<'py>(
    py: Python<'py>,
    render: PyReadonlyArray1<'py, f32>,
    photo: PyReadonlyArray1<'py, f32>,
    width: u32,
    height: u32,
    mask_image: Option<PyReadonlyArray1<'py, f32>>,
    mask_flags: Option<Vec<bool>>,
    color_correct: Option<&str>,
    saturation: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if !(saturation > 0.0) {
        return Err(value(format!("saturation: must be a positive level (or inf), got {saturation}")));
    }
    let a = image("a", render.as_slice()?, width, height)?;
    let b = image("b", photo.as_slice()?, width, height)?;
    let mask = match (mask_image, mask_flags) {
        (Some(m), _) => Some(Mask::from_image(&image("mask", m.as_slice()?, width, height)?)),
        (None, Some(inside)) => {
            if inside.len() != (width as usize) * (height as usize) {
                return Err(value("mask: its shape differs from the images'"));
            }
            Some(Mask { width, height, inside })
        }
        (None, None) => None,
    };
    if let Some(m) = &mask {
        if m.count() == 0 {
            return Err(value("mask: selects no pixels"));
        }
    }
    let color = match color_correct {
        None => None,
        Some(name) => {
            let model = ColorModel::from_name(name).ok_or_else(|| value(format!("color_correct: unknown colour model `{name}` (expected matrix or affine)")))?;
            Some(ColorFitOptions { model, saturation })
        }
    };
    let c = py.allow_threads(|| compare_with(&a, &b, mask.as_ref(), color.as_ref())).or_py()?;
    let m = &c.metrics;
    let d = PyDict::new(py);
    d.set_item("rmse", m.rmse)?;
    d.set_item("rel_mse", m.rel_mse)?;
    if m.psnr_db.is_finite() {
        d.set_item("psnr_db", m.psnr_db)?;
    } else {
        d.set_item("psnr_db", py.None())?;
    }
    d.set_item("ssim", m.ssim)?;
    d.set_item("delta_e2000_mean", m.delta_e2000_mean)?;
    d.set_item("pixels", m.pixels)?;
    if let Some(cm) = m.color_matrix {
        d.set_item("color_matrix", cm.iter().map(|r| r.to_vec()).collect::<Vec<_>>())?;
    }
    if let Some(f) = &m.color_fit {
        d.set_item("color_model", f.model.name())?;
        d.set_item("color_offset", f.offset.to_vec())?;
        d.set_item("color_residual_rms", f.rms_residual)?;
        d.set_item("color_robust_sigma", f.robust_sigma)?;
        d.set_item("color_pixels_used", f.pixels_used)?;
        d.set_item("color_pixels_saturated", f.excluded_saturated)?;
        d.set_item("color_pixels_nonfinite", f.excluded_nonfinite)?;
        d.set_item("color_pixels_downweighted", f.downweighted)?;
        d.set_item("color_iterations", f.iterations)?;
    }
    let map = c.delta_e_map.clone().into_pyarray(py).reshape([height as usize, width as usize])?;
    d.set_item("delta_e2000_map", map)?;
    Ok(d)
}
