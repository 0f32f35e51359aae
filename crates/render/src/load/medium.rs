//! Media in scene files: `sigma_a_per_mm` + `sigma_s_per_mm` + `g`, measured presets, milk by
//! content declaration, Mie recipes; `phase`, `similarity` and a `density` grid.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

use crate::load::error::{quote, Cx};
use crate::load::spectrum::{as_f64, SpectrumCx, SpectrumUse};
use crate::medium::albedo::AlbedoGrid;
use crate::medium::grid::DensityGrid;
use anyhow::Result;
use toml::Spanned;

pub(crate) const MEDIUM_KEYS: &[&str] = &["sigma_a_per_mm", "sigma_s_per_mm", "g", "milk", "recipe", "preset", "phase", "similarity", "density"];

/// Keys of `density = { … }`.
const DENSITY_KEYS: &[&str] = &["file", "resolution", "values", "min", "max", "scale", "albedo"];

/// Milk presets (fat wt-%, protein wt-%, homogenisation pressure MPa) for `medium = { preset = … }`.
pub const MILK_PRESETS: &[(&str, f64, f64, f64)] =
    &[("Skim Milk", 0.1, 3.4, 20.0), ("Low-fat Milk", 1.5, 3.4, 20.0), ("Whole Milk", 3.5, 3.4, 20.0)];

/// Wavelengths (nm) at which the renderer evaluates the milk model (those of its input tables).
pub fn milk_wavelengths_nm() -> Vec<f64> {
    (0..17).map(|k| 375.0 + 25.0 * k as f64).collect()
}

/// Parse a `medium = { … }` value (see docs/scene-format.md); errors name the field. With
/// `similarity = true` the medium is replaced by its similarity-relation equivalent (an
/// approximation, see [`crate::medium::Medium::similarity`]).
pub(crate) fn medium_desc(cx: &Cx, sp: &SpectrumCx, v: &Spanned<toml::Value>, field: &str, unit_m: f64) -> Result<crate::medium::Medium> {
    let similarity = match v.get_ref().as_table().and_then(|t| t.get("similarity")) {
        None => false,
        Some(toml::Value::Boolean(b)) => *b,
        Some(_) => return Err(cx.err(&v.span(), &format!("{field}.similarity"), "must be true or false")),
    };
    let mut m = medium_desc_exact(cx, sp, v, field, unit_m)?;
    if let Some(d) = v.get_ref().as_table().and_then(|t| t.get("density")) {
        let path = format!("{field}.density");
        let g = grid_desc(cx, sp, &v.span(), d, &path, unit_m)?;
        if g.channels != 1 {
            return Err(cx.err(&v.span(), &path, format!("a density grid has one value per cell, got {} (a 3-channel grid is an RGB albedo: density.albedo)", g.channels)));
        }
        let grid = DensityGrid::new(g.n, g.values, g.min_m, g.max_m).map_err(|e| cx.err(&v.span(), &path, format!("{e:#}")))?;
        m.density = Some(std::sync::Arc::new(grid));
        if let Some(a) = d.as_table().and_then(|t| t.get("albedo")) {
            let path = format!("{field}.density.albedo");
            let g = grid_desc(cx, sp, &v.span(), a, &path, unit_m)?;
            let albedo = if g.channels == 3 {
                let colours: Vec<[f32; 3]> = g.values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
                AlbedoGrid::rgb(g.n, &colours, g.min_m, g.max_m)
            } else {
                DensityGrid::new(g.n, g.values, g.min_m, g.max_m).and_then(AlbedoGrid::grey)
            };
            m.albedo = Some(std::sync::Arc::new(albedo.map_err(|e| cx.err(&v.span(), &path, format!("{e:#}")))?));
        }
    }
    if similarity {
        m.similarity().map_err(|e| cx.err(&v.span(), &format!("{field}.similarity"), format!("{e:#}")))
    } else {
        Ok(m)
    }
}

/// [`medium_desc`] without the similarity option.
pub(crate) fn medium_desc_exact(cx: &Cx, sp: &SpectrumCx, v: &Spanned<toml::Value>, field: &str, unit_m: f64) -> Result<crate::medium::Medium> {
    use crate::medium::{from_bulk, Medium, PhaseModel};
    let span = v.span();
    let t = v.get_ref().as_table().ok_or_else(|| cx.err(&span, field, "expected a table such as { sigma_a_per_mm = 0.01, sigma_s_per_mm = 1, g = 0 } or { milk = { ... } }"))?;
    for k in t.keys() {
        if !MEDIUM_KEYS.contains(&k.as_str()) {
            return Err(cx.err(&span, field, format!("unknown key {}, expected one of {MEDIUM_KEYS:?}", quote(k))));
        }
    }
    let f = |k: &str| format!("{field}.{k}");
    let kinds: Vec<&str> = ["sigma_a_per_mm", "milk", "recipe", "preset"].into_iter().filter(|k| t.contains_key(*k)).collect();
    if kinds.len() != 1 {
        return Err(cx.err(&span, field, format!("give exactly one of sigma_a_per_mm/sigma_s_per_mm/g, milk, recipe, preset (got {kinds:?})")));
    }
    let rayleigh = t.get("phase").and_then(|p| p.as_str()) == Some("rayleigh");
    let use_table = match t.get("phase") {
        None => true,
        Some(toml::Value::String(p)) if p == "mie" || p == "tabulated" => true,
        Some(toml::Value::String(p)) if p == "hg" || p == "rayleigh" => false,
        Some(_) => return Err(cx.err(&span, &f("phase"), "must be \"mie\" (tabulated, default), \"hg\" (Henyey–Greenstein with the Mie g) or \"rayleigh\" (with sigma_s_per_mm)")),
    };
    if rayleigh && !t.contains_key("sigma_a_per_mm") {
        return Err(cx.err(&span, &f("phase"), "\"rayleigh\" goes with sigma_a_per_mm and sigma_s_per_mm (milk, recipes and presets have their Mie phase function)"));
    }
    let num = |tab: &toml::value::Table, key: &str, path: &str| -> Result<f64> {
        let x = tab.get(key).ok_or_else(|| cx.err(&span, &format!("{path}.{key}"), "missing"))?;
        as_f64(x).filter(|x| x.is_finite()).ok_or_else(|| cx.err(&span, &format!("{path}.{key}"), "must be a number"))
    };
    let milk = |fat: f64, protein: f64, pressure: f64, path: &str| -> Result<Medium> {
        optics::milk::validate(fat, protein, pressure).map_err(|e| cx.err(&span, path, format!("{e:#}")))?;
        let l = milk_wavelengths_nm();
        let opts = optics::media::BulkOptions { phase_angles: if use_table { 181 } else { 0 } };
        let b = optics::milk::milk_properties_with(fat, protein, pressure, &l, &opts).map_err(|e| cx.err(&span, path, format!("{e:#}")))?;
        from_bulk(field, &b, use_table).map_err(|e| cx.err(&span, path, format!("{e:#}")))
    };
    match kinds[0] {
        "sigma_a_per_mm" => {
            if t.contains_key("phase") && !rayleigh {
                return Err(cx.err(&span, &f("phase"), "only \"rayleigh\" here (give g for Henyey–Greenstein; \"mie\" and \"hg\" go with milk, recipe or preset)"));
            }
            if rayleigh && t.contains_key("g") {
                return Err(cx.err(&span, &f("g"), "not allowed with phase = \"rayleigh\" (its g is 0)"));
            }
            let per_mm_to_per_m = 1000.0; // m⁻¹ per mm⁻¹ (coefficients are in mm⁻¹ whatever the scene unit)
            let _ = unit_m;
            let sigma = |key: &str| -> Result<optics::spectrum::DenseSpectrum> {
                let val = t.get(key).ok_or_else(|| cx.err(&span, &f(key), "missing"))?;
                let d = sp.resolve(&Spanned::new(span.clone(), val.clone()), &f(key), SpectrumUse::Coefficient)?;
                Ok(optics::spectrum::DenseSpectrum::from_fn(|l| d.eval(l as f32) as f64 * per_mm_to_per_m))
            };
            let sigma_a = sigma("sigma_a_per_mm")?;
            let sigma_s = sigma("sigma_s_per_mm")?;
            let g = match t.get("g") {
                None => 0.0,
                Some(x) => as_f64(x).ok_or_else(|| cx.err(&span, &f("g"), "must be a number"))?,
            };
            if !(g.abs() < 1.0) {
                return Err(cx.err(&span, &f("g"), format!("must lie in (-1, 1), got {g}")));
            }
            let phase = if rayleigh { crate::medium::rayleigh_phase() } else { PhaseModel::HenyeyGreenstein { g: optics::spectrum::DenseSpectrum::from_fn(|_| g) } };
            Medium::new(field, sigma_a, sigma_s, phase).map_err(|e| cx.err(&span, field, format!("{e:#}")))
        }
        "milk" => {
            for k in ["sigma_s_per_mm", "g"] {
                if t.contains_key(k) {
                    return Err(cx.err(&span, &f(k), "not allowed with milk"));
                }
            }
            let m = t["milk"].as_table().ok_or_else(|| cx.err(&span, &f("milk"), "expected { fat_percent = …, protein_percent = …, pressure_mpa = … }"))?;
            for k in m.keys() {
                if !["fat_percent", "protein_percent", "pressure_mpa"].contains(&k.as_str()) {
                    return Err(cx.err(&span, &f("milk"), format!("unknown key {} (fat_percent, protein_percent, pressure_mpa)", quote(k))));
                }
            }
            let path = f("milk");
            let fat = num(m, "fat_percent", &path)?;
            let protein = if m.contains_key("protein_percent") { num(m, "protein_percent", &path)? } else { 3.4 };
            let pressure = if m.contains_key("pressure_mpa") { num(m, "pressure_mpa", &path)? } else { 20.0 };
            // The ranges of optics::milk::validate, checked here so that errors name the scene's keys.
            if !(fat > 0.0 && fat <= 100.0) {
                return Err(cx.err(&span, &format!("{path}.fat_percent"), format!("must lie in (0, 100], got {fat}")));
            }
            if !(0.0..=100.0).contains(&protein) {
                return Err(cx.err(&span, &format!("{path}.protein_percent"), format!("must lie in [0, 100], got {protein}")));
            }
            if fat + protein > 100.0 {
                return Err(cx.err(&span, &path, format!("fat_percent + protein_percent = {} exceeds 100 %", fat + protein)));
            }
            if !(pressure >= 0.0) {
                return Err(cx.err(&span, &format!("{path}.pressure_mpa"), format!("must be ≥ 0 (0 = unhomogenized), got {pressure}")));
            }
            milk(fat, protein, pressure, &path)
        }
        "preset" => {
            let name = t["preset"].as_str().ok_or_else(|| cx.err(&span, &f("preset"), "must be a name"))?;
            if let Some(&(_, fat, protein, pressure)) = MILK_PRESETS.iter().find(|p| p.0.eq_ignore_ascii_case(name)) {
                return milk(fat, protein, pressure, &f("preset"));
            }
            // Measured media (Jensen et al. 2001, Narasimhan et al. 2006; RGB, as pbrt's named media).
            let Some(mm) = optics::bssrdf::find_medium(name) else {
                let known: Vec<&str> = MILK_PRESETS.iter().map(|p| p.0).collect();
                return Err(cx.err(&span, &f("preset"), format!(
                    "unknown preset {} (known: {known:?}, or a measured medium of Jensen et al. 2001 / Narasimhan et al. 2006 such as \"Regular Milk\", \"Ketchup\")", quote(name))));
            };
            let uplift = |rgb: [f64; 3]| -> optics::spectrum::DenseSpectrum {
                let m = rgb.iter().cloned().fold(0.0f64, f64::max);
                if !(m > 0.0) {
                    return optics::spectrum::DenseSpectrum::from_fn(|_| 0.0);
                }
                let sh = optics::spectrum::RgbAlbedo::new([rgb[0] / m, rgb[1] / m, rgb[2] / m]);
                optics::spectrum::DenseSpectrum::from_fn(move |l| sh.eval(l) * m)
            };
            let g = if mm.g.iter().all(|&x| x >= 0.0) { uplift(mm.g) } else {
                let mean = mm.g.iter().sum::<f64>() / 3.0;
                optics::spectrum::DenseSpectrum::from_fn(move |_| mean)
            };
            Medium::new(field, uplift(mm.sigma_a_per_m), uplift(mm.sigma_s_per_m), PhaseModel::HenyeyGreenstein { g })
                .map_err(|e| cx.err(&span, &f("preset"), format!("{e:#}")))
        }
        _ => {
            let rel = t["recipe"].as_str().ok_or_else(|| cx.err(&span, &f("recipe"), "must be a file name"))?;
            let text = sp.files.read_text(rel).map_err(|e| cx.err(&span, &f("recipe"), format!("{e:#}")))?;
            sp.hash.borrow_mut().write(text.as_bytes());
            let recipe = optics::media::Recipe::from_toml(&text).map_err(|e| cx.err(&span, &f("recipe"), format!("{rel}: {e:#}")))?;
            let mut recipe = recipe;
            if use_table && recipe.phase_angles == 0 {
                recipe.phase_angles = 181;
            }
            let b = recipe.bulk_properties(None).map_err(|e| cx.err(&span, &f("recipe"), format!("{rel}: {e:#}")))?;
            from_bulk(field, &b, use_table).map_err(|e| cx.err(&span, &f("recipe"), format!("{rel}: {e:#}")))
        }
    }
}

/// A grid as a scene file gives it: cells, values per cell, the values (channels fastest, then
/// x) and the box in metres.
struct GridDesc {
    n: [usize; 3],
    channels: usize,
    values: Vec<f32>,
    min_m: [f64; 3],
    max_m: [f64; 3],
}

/// Parse `density = { file = "x.vol" | resolution = [nx, ny, nz], values = […], min = […],
/// max = […], scale = s }` or its `albedo` (docs/scene-format.md, "Density grids"): the grid's
/// box in scene units (from the file when a file gives it and `min`/`max` are left out), its
/// values times `scale`. Inline values are numbers (one channel) or [r, g, b] triples.
fn grid_desc(cx: &Cx, sp: &SpectrumCx, span: &std::ops::Range<usize>, v: &toml::Value, field: &str, unit_m: f64) -> Result<GridDesc> {
    let t = v.as_table().ok_or_else(|| cx.err(span, field, "expected a table such as { file = \"smoke.vol\" } or { resolution = [2, 1, 1], values = [0, 1], min = [0, 0, 0], max = [1, 1, 1] }"))?;
    for k in t.keys() {
        if !DENSITY_KEYS.contains(&k.as_str()) || (k == "albedo" && field.ends_with(".albedo")) {
            return Err(cx.err(span, field, format!("unknown key {}, expected one of {DENSITY_KEYS:?}", quote(k))));
        }
    }
    let f = |k: &str| format!("{field}.{k}");
    let vec3 = |k: &str| -> Result<Option<[f64; 3]>> {
        let Some(x) = t.get(k) else { return Ok(None) };
        let a = x.as_array().filter(|a| a.len() == 3).ok_or_else(|| cx.err(span, &f(k), "must be [x, y, z]"))?;
        let mut out = [0.0; 3];
        for (o, e) in out.iter_mut().zip(a) {
            *o = as_f64(e).filter(|x| x.is_finite()).ok_or_else(|| cx.err(span, &f(k), "must be three numbers"))?;
        }
        Ok(Some(out))
    };
    let (n, channels, values, file_box) = match (t.get("file"), t.get("resolution")) {
        (Some(file), None) => {
            if t.contains_key("values") {
                return Err(cx.err(span, &f("values"), "not allowed with file"));
            }
            let rel = file.as_str().ok_or_else(|| cx.err(span, &f("file"), "must be a file name"))?;
            let path = sp.files.path(rel).map_err(|e| cx.err(span, &f("file"), format!("{e:#}")))?;
            let bytes = std::fs::read(&path).map_err(|e| cx.err(span, &f("file"), format!("cannot read {}: {e}", path.display())))?;
            sp.hash.borrow_mut().write(&bytes);
            let v = DensityGrid::read_vol(&bytes).map_err(|e| cx.err(span, &f("file"), format!("{rel}: {e:#}")))?;
            (v.n, v.channels, v.values, Some((v.min, v.max)))
        }
        (None, Some(res)) => {
            let r = res.as_array().filter(|a| a.len() == 3).ok_or_else(|| cx.err(span, &f("resolution"), "must be [nx, ny, nz]"))?;
            let mut n = [0usize; 3];
            for (o, e) in n.iter_mut().zip(r) {
                *o = e.as_integer().filter(|&k| k >= 1).ok_or_else(|| cx.err(span, &f("resolution"), "must be three whole numbers ≥ 1"))? as usize;
            }
            let vals = t.get("values").ok_or_else(|| cx.err(span, &f("values"), "missing (one value per cell, x fastest)"))?;
            let a = vals.as_array().ok_or_else(|| cx.err(span, &f("values"), "must be an array of numbers or of [r, g, b]"))?;
            let triples = a.first().is_some_and(|e| e.is_array());
            let (channels, values) = if triples {
                let rgb = |e: &toml::Value| -> Option<Vec<f32>> {
                    let c = e.as_array().filter(|c| c.len() == 3)?;
                    c.iter().map(|x| as_f64(x).map(|x| x as f32)).collect()
                };
                let v = a.iter().map(rgb).collect::<Option<Vec<Vec<f32>>>>().ok_or_else(|| cx.err(span, &f("values"), "must be all numbers or all [r, g, b]"))?;
                (3, v.concat())
            } else {
                (1, a.iter().map(|e| as_f64(e).map(|x| x as f32)).collect::<Option<Vec<f32>>>().ok_or_else(|| cx.err(span, &f("values"), "must be an array of numbers or of [r, g, b]"))?)
            };
            let cells = n[0].checked_mul(n[1]).and_then(|c| c.checked_mul(n[2])).ok_or_else(|| cx.err(span, &f("resolution"), "too many cells"))?;
            if values.len() != cells.saturating_mul(channels) {
                return Err(cx.err(span, &f("values"), format!("{}×{}×{} cells need {cells} values, got {}", n[0], n[1], n[2], values.len() / channels)));
            }
            (n, channels, values, None)
        }
        _ => return Err(cx.err(span, field, "give exactly one of file (a Mitsuba .vol grid) or resolution with values")),
    };
    let (min, max) = match (vec3("min")?, vec3("max")?, file_box) {
        (Some(a), Some(b), _) => (a, b),
        (None, None, Some(b)) => b,
        (None, None, None) => return Err(cx.err(span, &f("min"), "missing: an inline grid needs its box, min = [x, y, z] and max = [x, y, z] in scene units")),
        _ => return Err(cx.err(span, field, "give both min and max, or neither (the file's box)")),
    };
    let scale = match t.get("scale") {
        None => 1.0,
        Some(x) => as_f64(x).filter(|x| x.is_finite() && *x >= 0.0).ok_or_else(|| cx.err(span, &f("scale"), "must be a number ≥ 0"))?,
    };
    let values = values.into_iter().map(|x| (x as f64 * scale) as f32).collect();
    let to_m = |a: [f64; 3]| a.map(|x| x * unit_m);
    Ok(GridDesc { n, channels, values, min_m: to_m(min), max_m: to_m(max) })
}
