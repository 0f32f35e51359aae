//! `lucent scan patterns --projector WxH [--step S] --out DIR [--json]`: the Gray-code pattern
//! images `pattern_00.png …` (scan::graycode; docs/scanning.md).

use std::path::PathBuf;

use anyhow::Result;
use scan::graycode::{write_patterns, PatternSet};

use super::{parse_size, Progress};

/// Arguments of `lucent scan patterns`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Projector resolution WIDTHxHEIGHT (pixels).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub projector: (u32, u32),
    /// Projector pixels per code along each axis (increase when moiré appears).
    #[arg(long, default_value_t = 1, value_name = "S")]
    pub step: u32,
    /// Folder for pattern_00.png … (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Print a JSON summary on stdout (keys width, height, step, column_bits, row_bits, images, files).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let (w, h) = args.projector;
    let patterns = PatternSet::new(w, h, args.step)?;
    let progress = Progress::new(patterns.len() as u64, "patterns");
    let paths = write_patterns(&args.out, &patterns, &|| progress.inc())?;
    progress.finish();
    if args.json {
        let files: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
        let v = serde_json::json!({
            "width": w, "height": h, "step": args.step,
            "column_bits": patterns.column_bits(), "row_bits": patterns.row_bits(),
            "images": paths.len(), "files": files,
        });
        println!("{v}");
    } else {
        println!(
            "wrote {} patterns for {w}x{h} (step {}: {} column bits, {} row bits, then white and black) to {}",
            paths.len(),
            args.step,
            patterns.column_bits(),
            patterns.row_bits(),
            args.out.display()
        );
    }
    Ok(())
}
