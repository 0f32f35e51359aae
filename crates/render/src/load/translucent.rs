//! The `subsurface = { … }` table of a `translucent` material.

use crate::material::translucent::Translucent;
use anyhow::{anyhow, bail, Context, Result};
use optics::bssrdf::DipoleModel;
use optics::spectrum::DenseSpectrum;

/// RGB triple of a measured medium (channels r, g, b) as a spectrum: piecewise linear through
/// (450 nm, b), (550 nm, g), (650 nm, r), constant beyond.
pub fn rgb_coefficients_to_spectrum(rgb: [f64; 3]) -> DenseSpectrum {
    DenseSpectrum::from_fn(move |l| {
        if l <= 450.0 {
            rgb[2]
        } else if l <= 550.0 {
            rgb[2] + (rgb[1] - rgb[2]) * (l - 450.0) / 100.0
        } else if l <= 650.0 {
            rgb[1] + (rgb[0] - rgb[1]) * (l - 550.0) / 100.0
        } else {
            rgb[0]
        }
    })
}

/// Parse the `subsurface = { … }` table of a `translucent` material (see docs/scene-format.md):
/// `model` ("standard" | "directional" | "directional-corrected", default directional), exactly
/// one of `preset` (a medium
/// of Jensen et al. 2001 or Narasimhan et al. 2006, by name), `milk = { fat_percent,
/// protein_percent, pressure_mpa }`, or `sigma_s_per_mm` + `sigma_a_per_mm` (number or
/// [r, g, b]) with optional `g`; optional `points_per_pass`, `rejection_control` and
/// `rejection_radius_mfp`.
/// `ior` is the material's index (a preset's own η is used when `ior` is absent); `roughness` the
/// material's boundary roughness r ∈ [0, 1] (α = r²; absent or 0: smooth).
/// Errors name the key (relative to the table).
pub fn translucent_from_toml(ior: Option<f64>, roughness: Option<f64>, table: &toml::Value) -> Result<Translucent> {
    const KEYS: &[&str] = &[
        "model",
        "from_medium",
        "preset",
        "milk",
        "sigma_s_per_mm",
        "sigma_a_per_mm",
        "g",
        "points_per_pass",
        "rejection_control",
        "rejection_radius_mfp",
        "bounces",
        "wavelength_sets",
    ];
    let t = table.as_table().ok_or_else(|| {
        anyhow!("subsurface: expected a table such as {{ model = \"directional\", preset = \"marble\" }}")
    })?;
    for k in t.keys() {
        if !KEYS.contains(&k.as_str()) {
            bail!("subsurface: unknown key {} (expected one of {KEYS:?})", crate::load::error::quote(k));
        }
    }
    let num = |v: &toml::Value| -> Option<f64> {
        v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
    };
    let model: DipoleModel = match t.get("model") {
        None => DipoleModel::Directional,
        Some(v) => v
            .as_str()
            .ok_or_else(|| anyhow!("subsurface.model: expected \"standard\", \"directional\" or \"directional-corrected\""))?
            .parse()
            .context("subsurface.model")?,
    };
    let kinds: Vec<&str> = ["from_medium", "preset", "milk", "sigma_s_per_mm"]
        .into_iter()
        .filter(|k| t.contains_key(*k))
        .collect();
    if kinds.len() != 1 {
        bail!("subsurface: give exactly one of from_medium, preset, milk, sigma_s_per_mm/sigma_a_per_mm/g (got {kinds:?})");
    }
    let eta_of = |default: f64| -> Result<f32> {
        let e = ior.unwrap_or(default);
        if !(e > 0.0) || !e.is_finite() {
            bail!("ior: must be positive, got {e}");
        }
        Ok(e as f32)
    };
    let mut mat = match kinds[0] {
        "from_medium" => {
            if t["from_medium"].as_bool() != Some(true) {
                bail!("subsurface.from_medium: must be true (leave it out otherwise)");
            }
            // Placeholder coefficients, replaced by the object's medium when the cloud is built.
            let mut m = Translucent::constant(eta_of(1.3)?, model, 1.0, 0.0, 0.0)?;
            m.from_medium = true;
            m
        }
        "preset" => {
            let name = t["preset"]
                .as_str()
                .ok_or_else(|| anyhow!("subsurface.preset: expected a name such as \"marble\""))?;
            let m = optics::bssrdf::find_medium(name).ok_or_else(|| anyhow!("subsurface.preset: unknown medium {} (see optics::bssrdf presets of Jensen 2001 / Narasimhan 2006)", crate::load::error::quote(name)))?;
            Translucent::new(
                eta_of(m.eta)?,
                model,
                rgb_coefficients_to_spectrum(m.sigma_s_per_m),
                rgb_coefficients_to_spectrum(m.sigma_a_per_m),
                rgb_coefficients_to_spectrum(m.g),
            )
            .context("subsurface.preset")?
        }
        "milk" => {
            let m = t["milk"].as_table().ok_or_else(|| {
                anyhow!(
                    "subsurface.milk: expected {{ fat_percent, protein_percent, pressure_mpa }}"
                )
            })?;
            let get = |k: &str, d: Option<f64>| -> Result<f64> {
                match m.get(k) {
                    Some(v) => {
                        num(v).ok_or_else(|| anyhow!("subsurface.milk.{k}: must be a number"))
                    }
                    None => d.ok_or_else(|| anyhow!("subsurface.milk.{k}: missing")),
                }
            };
            let fat = get("fat_percent", None)?;
            let protein = get("protein_percent", Some(3.4))?;
            let pressure = get("pressure_mpa", Some(20.0))?;
            let lambda: Vec<f64> = (0..17).map(|k| 375.0 + 25.0 * k as f64).collect();
            let b = optics::milk::milk_properties(fat, protein, pressure, &lambda)
                .context("subsurface.milk")?;
            let tab = |v: &[f64]| -> Result<DenseSpectrum> {
                let s = optics::spectrum::Tabulated::new(lambda.clone(), v.to_vec())?;
                let (lo, hi) = (v[0], v[v.len() - 1]);
                Ok(DenseSpectrum::from_fn(move |l| {
                    if l < 375.0 {
                        lo
                    } else if l > 775.0 {
                        hi
                    } else {
                        s.eval(l)
                    }
                }))
            };
            Translucent::new(
                eta_of(1.345)?,
                model,
                tab(&b.sigma_s_per_m)?,
                tab(&b.sigma_a_per_m)?,
                tab(&b.g)?,
            )
            .context("subsurface.milk")?
        }
        _ => {
            let coef = |k: &str, scale: f64, default: Option<f64>| -> Result<DenseSpectrum> {
                match t.get(k) {
                    None => default
                        .map(|d| DenseSpectrum::from_fn(move |_| d))
                        .ok_or_else(|| anyhow!("subsurface.{k}: missing")),
                    Some(v) => {
                        if let Some(x) = num(v) {
                            if !x.is_finite() {
                                bail!("subsurface.{k}: must be finite");
                            }
                            Ok(DenseSpectrum::from_fn(move |_| x * scale))
                        } else if let Some(a) = v.as_array() {
                            let xs: Vec<f64> = a.iter().filter_map(num).collect();
                            if xs.len() != 3 || a.len() != 3 || xs.iter().any(|x| !x.is_finite()) {
                                bail!("subsurface.{k}: expected a number or [r, g, b]");
                            }
                            Ok(rgb_coefficients_to_spectrum([
                                xs[0] * scale,
                                xs[1] * scale,
                                xs[2] * scale,
                            ]))
                        } else {
                            bail!("subsurface.{k}: expected a number or [r, g, b]")
                        }
                    }
                }
            };
            let ss = coef("sigma_s_per_mm", 1e3, None)?;
            let sa = coef("sigma_a_per_mm", 1e3, None)?;
            let g = coef("g", 1.0, Some(0.0))?;
            Translucent::new(eta_of(1.3)?, model, ss, sa, g).context("subsurface")?
        }
    };
    if let Some(v) = t.get("points_per_pass") {
        let n = v
            .as_integer()
            .filter(|n| *n >= 1 && *n <= 1 << 24)
            .ok_or_else(|| {
                anyhow!("subsurface.points_per_pass: expected an integer in 1..=16777216")
            })?;
        mat.points_per_pass = n as usize;
    }
    if let Some(v) = t.get("rejection_radius_mfp") {
        let r = num(v)
            .filter(|r| r.is_finite() && *r >= 0.0)
            .ok_or_else(|| anyhow!("subsurface.rejection_radius_mfp: expected a number >= 0"))?;
        mat.rejection_radius_mfp = r as f32;
    }
    if let Some(v) = t.get("rejection_control") {
        mat.rejection_control = v
            .as_bool()
            .ok_or_else(|| anyhow!("subsurface.rejection_control: expected true or false"))?;
    }
    if let Some(v) = t.get("bounces") {
        let n = v
            .as_integer()
            .filter(|n| (1..=8).contains(n))
            .ok_or_else(|| anyhow!("subsurface.bounces: expected an integer in 1..=8"))?;
        mat.bounces = n as u32;
    }
    if let Some(v) = t.get("wavelength_sets") {
        let n = v
            .as_integer()
            .filter(|n| (1..=64).contains(n))
            .ok_or_else(|| anyhow!("subsurface.wavelength_sets: expected an integer in 1..=64"))?;
        mat.wavelength_sets = n as u32;
    }
    if let Some(r) = roughness {
        mat.set_roughness(r)?;
    }
    Ok(mat)
}
