//! `lucent slab`: MCML-style Monte Carlo photon transport in a stack of plane-parallel layers.

use super::format::sig;
use anyhow::{bail, Context, Result};
use optics::slab::{simulate, Layer, LineGrid, RadialGrid, SlabResult, SlabSettings};
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// A layer, top first: absorption and scattering coefficients σ_a, σ_s in mm⁻¹ (MCML's
    /// μa, μs), HG anisotropy g, refractive index, thickness in mm (`inf` for a semi-infinite
    /// last layer, which must absorb if it scatters). Repeatable.
    #[arg(
        long = "layer",
        value_name = "SIGMA_A,SIGMA_S,G,N,THICKNESS_MM",
        required = true,
        allow_hyphen_values = true
    )]
    layer: Vec<String>,
    /// Refractive index of the ambient medium above the stack.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    n_above: f64,
    /// Refractive index of the ambient medium below the stack.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    n_below: f64,
    /// Number of photon packets.
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    /// Random seed (results are reproducible for a given seed and photon count).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Number of annular bins of the radially resolved diffuse reflectance R(r).
    #[arg(long)]
    radial_bins: Option<usize>,
    /// Outer radius of R(r) in mm (default: 10 transport mean free paths of the top layer).
    #[arg(long, allow_hyphen_values = true)]
    radial_max_mm: Option<f64>,
    /// Also write R(r) as CSV (`r_mm,rd_per_mm2,rd_per_mm2_stderr`) to this file.
    #[arg(long, value_name = "FILE")]
    radial_csv: Option<PathBuf>,
    /// Angle of the incident beam from the normal, in degrees, in the medium above (the beam
    /// travels towards +x). Default 0 (normal incidence).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    incidence_deg: f64,
    /// Number of bins of the reflectance along the x axis, R(x, y≈0) (oblique incidence reflectometry).
    #[arg(long)]
    line_bins: Option<usize>,
    /// Half length of the x line in mm (default: 10 transport mean free paths of the top layer).
    #[arg(long, allow_hyphen_values = true)]
    line_max_mm: Option<f64>,
    /// Most free-flight steps per photon packet; a packet still alive then is dropped and
    /// counted (`photons_truncated`; its weight `truncated_weight` is missing from R_d,
    /// absorbed and T_t, each biased low by at most that much).
    #[arg(long, default_value_t = optics::slab::DEFAULT_MAX_STEPS_PER_PHOTON)]
    max_steps_per_photon: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

/// Parse `SIGMA_A,SIGMA_S,G,N,THICKNESS_MM` (validation of the values is done by the library).
fn parse_layer(text: &str) -> Result<Layer> {
    let fields: Vec<&str> = text.split(',').map(str::trim).collect();
    if fields.len() != 5 {
        bail!(
            "expected 5 comma-separated values SIGMA_A,SIGMA_S,G,N,THICKNESS_MM, got {}",
            fields.len()
        );
    }
    let names = ["SIGMA_A", "SIGMA_S", "G", "N", "THICKNESS_MM"];
    let mut v = [0.0; 5];
    for (i, f) in fields.iter().enumerate() {
        v[i] = if i == 4 && f.eq_ignore_ascii_case("inf") {
            f64::INFINITY
        } else {
            let x: f64 = f
                .parse()
                .map_err(|_| anyhow::anyhow!("{} = {f:?} is not a number", names[i]))?;
            if !x.is_finite() {
                bail!("{} = {f:?} is not a finite number", names[i]);
            }
            x
        };
    }
    let layer = Layer {
        mua_per_mm: v[0],
        mus_per_mm: v[1],
        g: v[2],
        n: v[3],
        thickness_mm: v[4],
    };
    layer.validate()?;
    Ok(layer)
}

pub fn run(args: Args) -> Result<()> {
    let mut layers = Vec::new();
    let count = args.layer.len();
    for (i, text) in args.layer.iter().enumerate() {
        let l = parse_layer(text).with_context(|| format!("--layer {} ({text:?})", i + 1))?;
        if l.thickness_mm.is_infinite() && i + 1 != count {
            bail!("--layer {} ({text:?}): only the last layer may be semi-infinite (THICKNESS_MM = inf)", i + 1);
        }
        layers.push(l);
    }
    let default_max_mm = optics::slab::default_tally_max_mm(&layers);
    let radial = match (args.radial_bins, args.radial_max_mm) {
        (None, None) => None,
        (None, Some(_)) => bail!("--radial-max-mm needs --radial-bins"),
        (Some(bins), max) => Some(RadialGrid {
            bins,
            max_mm: max.unwrap_or(default_max_mm),
        }),
    };
    let line = match (args.line_bins, args.line_max_mm) {
        (None, None) => None,
        (None, Some(_)) => bail!("--line-max-mm needs --line-bins"),
        (Some(bins), max) => Some(LineGrid {
            bins,
            max_mm: max.unwrap_or(default_max_mm),
        }),
    };
    if args.radial_csv.is_some() && radial.is_none() {
        bail!("--radial-csv needs --radial-bins");
    }
    let settings = SlabSettings {
        layers,
        n_above: args.n_above,
        n_below: args.n_below,
        photons: args.photons,
        seed: args.seed,
        radial,
        incidence_deg: args.incidence_deg,
        line,
        max_steps_per_photon: args.max_steps_per_photon,
    };
    // Validate before spawning threads so errors come first and name the argument.
    optics::slab::validate(&settings).map_err(|e| {
        let msg = e.to_string();
        let arg = if msg.starts_with("layer") {
            "--layer"
        } else if msg.starts_with("n-above") {
            "--n-above"
        } else if msg.starts_with("n-below") {
            "--n-below"
        } else if msg.starts_with("photons") {
            "--photons"
        } else if msg.starts_with("radial-bins") {
            "--radial-bins"
        } else if msg.starts_with("radial-max-mm") {
            "--radial-max-mm"
        } else if msg.starts_with("incidence-deg") {
            "--incidence-deg"
        } else if msg.starts_with("line-bins") {
            "--line-bins"
        } else if msg.starts_with("line-max-mm") {
            "--line-max-mm"
        } else if msg.starts_with("max-steps-per-photon") {
            "--max-steps-per-photon"
        } else {
            "--layer"
        };
        anyhow::anyhow!("{arg}: {msg}")
    })?;
    let result = match args.threads {
        Some(0) => bail!("--threads: must be at least 1"),
        Some(n) if n > 4096 => bail!("--threads: at most 4096, got {n}"),
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .context("--threads: cannot start the thread pool")?
            .install(|| simulate(&settings))?,
        None => simulate(&settings)?,
    };
    if result.photons_truncated > 0 {
        eprintln!(
            "warning: {} of {} photons reached --max-steps-per-photon {} and were dropped; their weight ({}) is missing from R_d, absorbed and T_t, each biased low by at most that",
            result.photons_truncated,
            result.photons,
            settings.max_steps_per_photon,
            sig(result.truncated_weight, 3)
        );
    }
    if let (Some(path), Some(r)) = (&args.radial_csv, &result.radial) {
        write_radial_csv(path, r).with_context(|| format!("--radial-csv {}", path.display()))?;
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&to_json(&settings, &result))?
        );
    } else {
        print_text(&result);
    }
    Ok(())
}

fn to_json(s: &SlabSettings, r: &SlabResult) -> serde_json::Value {
    let layers: Vec<_> = s
        .layers
        .iter()
        .map(|l| {
            serde_json::json!({
                "mua_per_mm": l.mua_per_mm, "mus_per_mm": l.mus_per_mm, "g": l.g, "n": l.n,
                "thickness_mm": if l.thickness_mm.is_finite() { serde_json::json!(l.thickness_mm) } else { serde_json::json!("inf") },
            })
        })
        .collect();
    let mut v = serde_json::json!({
        "specular": r.specular,
        "rd": r.rd,
        "rd_stderr": r.rd_stderr,
        "absorbed": r.absorbed,
        "absorbed_stderr": r.absorbed_stderr,
        "absorbed_per_layer": r.absorbed_per_layer,
        "tt": r.tt,
        "tt_stderr": r.tt_stderr,
        "roulette_gain": r.roulette_gain,
        "photons_truncated": r.photons_truncated,
        "truncated_weight": r.truncated_weight,
        "max_steps_per_photon": s.max_steps_per_photon,
        "photons": r.photons,
        "seed": s.seed,
        "incidence_deg": s.incidence_deg,
        "rd_centroid_x_mm": r.rd_centroid_x_mm,
        "n_above": s.n_above,
        "n_below": s.n_below,
        "layers": layers,
        "photon_steps": r.photon_steps,
        "seconds": r.seconds,
        "threads": r.threads,
        "photon_steps_per_s": r.photon_steps_per_s(),
        "photon_steps_per_s_per_thread": r.photon_steps_per_s() / r.threads as f64,
        "cpu_seconds": r.cpu_seconds,
        "photon_steps_per_cpu_s": r.photon_steps_per_cpu_s(),
    });
    if let Some(rad) = &r.radial {
        v["radial"] = serde_json::json!({
            "r_mm": rad.r_mm,
            "rd_per_mm2": rad.rd_per_mm2,
            "rd_per_mm2_stderr": rad.rd_per_mm2_stderr,
            "dr_mm": rad.dr_mm,
            "rd_beyond_max": rad.rd_beyond_max,
        });
    }
    if let Some(line) = &r.line {
        v["line"] = serde_json::json!({
            "x_mm": line.x_mm,
            "rd_per_mm2": line.rd_per_mm2,
            "rd_per_mm2_stderr": line.rd_per_mm2_stderr,
            "dx_mm": line.dx_mm,
        });
    }
    v
}

fn print_text(r: &SlabResult) {
    println!("specular reflectance  {:.6}", r.specular);
    println!("diffuse reflectance   {:.6} ± {:.6}", r.rd, r.rd_stderr);
    println!(
        "absorbed              {:.6} ± {:.6}",
        r.absorbed, r.absorbed_stderr
    );
    println!("total transmittance   {:.6} ± {:.6}", r.tt, r.tt_stderr);
    if r.photons_truncated > 0 {
        println!(
            "truncated             {:.6} ({} photons dropped at the step cap)",
            r.truncated_weight, r.photons_truncated
        );
    }
    println!(
        "{} photons, {} steps in {:.3} s on {} threads: {:.2} M steps/s ({:.2} M per thread)",
        r.photons,
        r.photon_steps,
        r.seconds,
        r.threads,
        r.photon_steps_per_s() / 1e6,
        r.photon_steps_per_s() / 1e6 / r.threads as f64
    );
    if let Some(per_cpu) = r.photon_steps_per_cpu_s() {
        println!("per core (CPU time): {:.2} M steps/s", per_cpu / 1e6);
    }
    println!("diffuse centre x       {:.6} mm", r.rd_centroid_x_mm);
    if let Some(line) = &r.line {
        println!("x_mm,rd_per_mm2,rd_per_mm2_stderr");
        for k in 0..line.x_mm.len() {
            println!(
                "{},{},{}",
                line.x_mm[k], line.rd_per_mm2[k], line.rd_per_mm2_stderr[k]
            );
        }
    }
    if let Some(rad) = &r.radial {
        println!("r_mm,rd_per_mm2,rd_per_mm2_stderr");
        for k in 0..rad.r_mm.len() {
            println!(
                "{},{},{}",
                rad.r_mm[k], rad.rd_per_mm2[k], rad.rd_per_mm2_stderr[k]
            );
        }
    }
}

/// Write R(r) as CSV to a temporary name, then rename (never a half-written file).
fn write_radial_csv(path: &Path, r: &optics::slab::RadialReflectance) -> Result<()> {
    let tmp = path.with_file_name(format!(
        "{}.tmp-{}",
        path.file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default(),
        std::process::id()
    ));
    let write = || -> Result<()> {
        let mut f = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        writeln!(f, "r_mm,rd_per_mm2,rd_per_mm2_stderr")?;
        for k in 0..r.r_mm.len() {
            writeln!(
                f,
                "{},{},{}",
                r.r_mm[k], r.rd_per_mm2[k], r.rd_per_mm2_stderr[k]
            )?;
        }
        f.flush()?;
        Ok(())
    };
    if let Err(e) = write() {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, path)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_strings_parse_and_errors_name_the_field() {
        let l = parse_layer("1, 9, 0.75, 1.0, 0.2").unwrap();
        assert_eq!(
            l,
            Layer {
                mua_per_mm: 1.0,
                mus_per_mm: 9.0,
                g: 0.75,
                n: 1.0,
                thickness_mm: 0.2
            }
        );
        assert!(parse_layer("0.1,0.9,0,1.5,inf")
            .unwrap()
            .thickness_mm
            .is_infinite());
        assert!(parse_layer("0.1,0.9,0,1.5,INF")
            .unwrap()
            .thickness_mm
            .is_infinite());
        for (text, field) in [
            ("1,9,0.75,1", "5 comma-separated"),
            ("1,9,0.75,1,0.2,3", "5 comma-separated"),
            ("x,9,0.75,1,0.2", "SIGMA_A"),
            ("-1,9,0.75,1,0.2", "SIGMA_A"),
            ("1,-9,0.75,1,0.2", "SIGMA_S"),
            ("1,9,1.0,1,0.2", "G"),
            ("1,9,-1.5,1,0.2", "G"),
            ("1,9,0.75,0,0.2", "N"),
            ("1,9,0.75,1,0", "THICKNESS_MM"),
            ("1,9,0.75,1,nan", "THICKNESS_MM"),
            ("1,inf,0.75,1,1", "SIGMA_S"),
        ] {
            let e = format!("{:#}", parse_layer(text).unwrap_err());
            assert!(e.contains(field), "{text}: {e}");
            assert!(!e.contains('\n'), "one line: {e}");
        }
    }

    #[test]
    fn json_has_the_contract_keys() {
        let settings = SlabSettings {
            photons: 2000,
            radial: Some(RadialGrid {
                bins: 10,
                max_mm: 2.0,
            }),
            ..SlabSettings::new(vec![parse_layer("1,9,0.75,1.4,0.2").unwrap()])
        };
        let r = simulate(&settings).unwrap();
        let v = to_json(&settings, &r);
        for key in [
            "specular",
            "rd",
            "rd_stderr",
            "absorbed",
            "tt",
            "tt_stderr",
            "photon_steps_per_s",
            "photons_truncated",
            "truncated_weight",
            "max_steps_per_photon",
        ] {
            assert!(v[key].is_number(), "{key} missing: {v}");
        }
        assert_eq!(v["radial"]["r_mm"].as_array().unwrap().len(), 10);
        assert_eq!(v["radial"]["rd_per_mm2"].as_array().unwrap().len(), 10);
        let plain = SlabSettings {
            radial: None,
            ..settings
        };
        let v = to_json(&plain, &simulate(&plain).unwrap());
        assert!(v.get("radial").is_none());
    }

}
