//! `lucent medium milk|RECIPE.toml`: bulk optical properties (σ_s, σ_a, σ_t in mm⁻¹ and g per
//! wavelength) of milk from its content declaration, or of a medium recipe (docs/media.md).

use super::format::sig;
use super::mie::{number, spectra_svg, write_svg};
use anyhow::{bail, Context, Result};
use optics::media::{self, BulkOptions, BulkProperties, Recipe};
use optics::milk;
use serde_json::{json, Value};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// `milk`, or the path of a medium recipe (.toml, see docs/media.md).
    pub medium: String,
    /// Milk: fat content in weight percent.
    #[arg(long = "fat-percent", allow_hyphen_values = true)]
    pub fat_percent: Option<String>,
    /// Milk: protein content in weight percent (default 3.4).
    #[arg(long = "protein-percent", allow_hyphen_values = true)]
    pub protein_percent: Option<String>,
    /// Milk: homogenization pressure in MPa (default 20; 0 = unhomogenized).
    #[arg(long = "pressure-mpa", allow_hyphen_values = true)]
    pub pressure_mpa: Option<String>,
    /// Wavelengths in nm: START:STOP:STEP or a,b,c (default 375:775:25, or the recipe's).
    #[arg(long = "wavelengths-nm", alias = "wavelength-nm", alias = "lambda-nm", allow_hyphen_values = true)]
    pub wavelengths_nm: Option<String>,
    /// Also tabulate the bulk phase function at this many angles from 0° to 180° (JSON keys theta_deg, phase_per_sr).
    #[arg(long = "phase-angles")]
    pub phase_angles: Option<usize>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Draw the spectra (σ_s, σ_a, σ_t and g) to this SVG file.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let lambda = match &args.wavelengths_nm {
        Some(s) => Some(media::parse_wavelengths_nm(s).map_err(|e| anyhow::anyhow!("--wavelengths-nm: {e}"))?),
        None => None,
    };
    if let Some(n) = args.phase_angles {
        if n > media::MAX_PHASE_ANGLES {
            bail!("--phase-angles: at most {}, got {n}", media::MAX_PHASE_ANGLES);
        }
    }
    let (props, title): (BulkProperties, String) = if args.medium == "milk" {
        let fat = number("--fat-percent", args.fat_percent.as_deref().ok_or_else(|| anyhow::anyhow!("--fat-percent is required for milk"))?)?;
        let protein = match &args.protein_percent {
            Some(s) => number("--protein-percent", s)?,
            None => milk::DEFAULT_PROTEIN_PERCENT,
        };
        let pressure = match &args.pressure_mpa {
            Some(s) => number("--pressure-mpa", s)?,
            None => 20.0,
        };
        milk::validate(fat, protein, pressure)?;
        let l = lambda.unwrap_or_else(|| media::parse_wavelengths_nm("375:775:25").expect("default wavelengths"));
        milk::check_wavelengths(&l).context("--wavelengths-nm")?;
        let opts = BulkOptions { phase_angles: args.phase_angles.unwrap_or(0) };
        let p = milk::milk_properties_with(fat, protein, pressure, &l, &opts)
            .with_context(|| format!("milk of --fat-percent {}, --protein-percent {}", optics::numfmt::short(fat), optics::numfmt::short(protein)))?;
        (p, format!("milk: {fat} % fat, {protein} % protein, {pressure} MPa"))
    } else {
        for (flag, v) in [("--fat-percent", &args.fat_percent), ("--protein-percent", &args.protein_percent), ("--pressure-mpa", &args.pressure_mpa)] {
            if v.is_some() {
                bail!("{flag} applies to `lucent medium milk` only, not to a recipe file");
            }
        }
        let path = PathBuf::from(&args.medium);
        let mut recipe = Recipe::load(&path)?;
        if let Some(n) = args.phase_angles {
            recipe.phase_angles = n;
        }
        let p = recipe.bulk_properties(lambda.as_deref()).map_err(|e| anyhow::anyhow!("recipe {}: {e:#}", path.display()))?;
        let name = if recipe.name.is_empty() { path.display().to_string() } else { recipe.name.clone() };
        (p, name)
    };
    let mm = |v: &[f64]| v.iter().map(|x| x * 1e-3).collect::<Vec<f64>>();
    if let Some(path) = &args.plot {
        let svg = spectra_svg(
            &props.lambda_nm,
            &[
                ("coefficient [mm⁻¹]", true, vec![("σs", mm(&props.sigma_s_per_m)), ("σa", mm(&props.sigma_a_per_m)), ("σt", mm(&props.sigma_t_per_m))]),
                ("asymmetry g", false, vec![("g", props.g.clone())]),
            ],
            &title,
        );
        write_svg(path, &svg)?;
    }
    if args.json {
        let mut o = serde_json::Map::new();
        o.insert("wavelength_nm".into(), json!(props.lambda_nm));
        o.insert("sigma_s_per_mm".into(), json!(mm(&props.sigma_s_per_m)));
        o.insert("sigma_a_per_mm".into(), json!(mm(&props.sigma_a_per_m)));
        o.insert("sigma_t_per_mm".into(), json!(mm(&props.sigma_t_per_m)));
        o.insert("g".into(), json!(props.g));
        o.insert("name".into(), json!(title));
        o.insert("host_sigma_a_per_mm".into(), json!(mm(&props.host_sigma_a_per_m)));
        let comps: Vec<Value> = props
            .components
            .iter()
            .map(|c| json!({"name": c.name, "sigma_s_per_mm": mm(&c.sigma_s_per_m), "sigma_t_per_mm": mm(&c.sigma_t_per_m), "g": c.g}))
            .collect();
        o.insert("components".into(), Value::Array(comps));
        if let Some(t) = &props.phase {
            o.insert("theta_deg".into(), json!(t.theta_deg));
            o.insert("phase_per_sr".into(), json!(t.per_sr));
        }
        println!("{}", Value::Object(o));
    } else {
        println!("# {title}");
        println!("# sigma_* in mm⁻¹ (sigma_s_prime = sigma_s (1 − g)); g dimensionless");
        println!(
            "{:>13} {:>14} {:>14} {:>14} {:>9} {:>20}",
            "wavelength_nm", "sigma_s_per_mm", "sigma_a_per_mm", "sigma_t_per_mm", "g", "sigma_s_prime_per_mm"
        );
        for i in 0..props.lambda_nm.len() {
            let s = props.sigma_s_per_m[i] * 1e-3;
            println!(
                "{:>13} {:>14} {:>14} {:>14} {:>9} {:>20}",
                sig(props.lambda_nm[i], 6),
                sig(s, 6),
                sig(props.sigma_a_per_m[i] * 1e-3, 6),
                sig(props.sigma_t_per_m[i] * 1e-3, 6),
                sig(props.g[i], 5),
                sig(s * (1.0 - props.g[i]), 6)
            );
        }
    }
    Ok(())
}
