//! `lucent merge`: combine checkpoints of independent runs of one render (different seeds),
//! weighting each by its number of samples, into images and optionally a merged checkpoint.

use std::path::PathBuf;

use anyhow::{bail, Result};

use render::checkpoint::{Checkpoint, Merger};

use super::render::{check_layout_outputs, check_outputs, check_parent_dir, finite_f64, report_written, write_outputs};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Checkpoints written by `lucent render --checkpoint` with different `--seed`s.
    #[arg(value_name = "CKPT", required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output image (.png, .exr or .pfm); repeatable.
    #[arg(long, value_name = "FILE")]
    pub out: Vec<PathBuf>,
    /// Also write the merged accumulator as a checkpoint (it can be merged again).
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Exposure in stops for PNG outputs (EXR and PFM stay unscaled linear radiance) [default: 0].
    #[arg(long, value_name = "STOPS", allow_hyphen_values = true)]
    pub exposure: Option<String>,
}

pub fn run(args: Args) -> Result<()> {
    if args.out.is_empty() && args.checkpoint.is_none() {
        bail!("nothing to write: give --out FILE (and/or --checkpoint FILE)");
    }
    let exposure = match args.exposure.as_deref() {
        Some(e) => finite_f64("--exposure", e)? as f32,
        None => 0.0,
    };
    check_outputs(&args.out)?;
    if let Some(c) = &args.checkpoint {
        check_parent_dir(c, "--checkpoint")?;
        if args.inputs.contains(c) {
            // Allowed (written atomically after reading), but almost certainly a slip.
            eprintln!("lucent: warning: --checkpoint {} replaces one of the inputs", c.display());
        }
    }
    // One checkpoint in memory at a time: a merge of thousands of large parts stays small.
    let mut merger = Merger::new();
    for path in &args.inputs {
        merger.add(path, Checkpoint::read(path)?)?;
    }
    let merged = merger.finish()?;
    if !args.out.is_empty() {
        check_layout_outputs(merged.film.layout(), &args.out)?;
    }
    if let Some(c) = &args.checkpoint {
        merged.write(c)?;
    }
    let written = write_outputs(&merged.film, &args.out, exposure)?;
    let seeds: Vec<String> = merged.runs.iter().map(|r| r.seed.to_string()).collect();
    eprintln!(
        "lucent: merged {} checkpoints of {} ({}×{}): {} spp in total from seeds {}",
        args.inputs.len(),
        merged.identity.scene_name,
        merged.identity.width,
        merged.identity.height,
        merged.film.samples_per_pixel(),
        seeds.join(", ")
    );
    if let Some(c) = &args.checkpoint {
        println!("wrote {}", std::path::absolute(c).unwrap_or_else(|_| c.clone()).display());
    }
    report_written(&written, false);
    Ok(())
}
