//! `lucent scan decode CAPTURE_DIR --projector WxH [--step S] [--black-threshold 40]
//! [--white-threshold 5] [--out MAP.exr] [--json]`: projector column and row per camera pixel
//! (scan::decode; docs/scanning.md).

use std::path::PathBuf;

use anyhow::Result;
use scan::decode::{decode, read_capture, write_map, DecodeSettings};
use scan::graycode::PatternSet;

use super::{parse_size, CaptureOrder, Progress};

/// Arguments of `lucent scan decode`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Folder with graycode_00.png … in pattern order (the last two: white, black, unless `--white-black first`); without them, its PNG/JPEG files in natural order.
    pub capture: PathBuf,
    /// Projector resolution WIDTHxHEIGHT (pixels).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub projector: (u32, u32),
    /// Projector pixels per code, as the patterns were made.
    #[arg(long, default_value_t = 1, value_name = "S")]
    pub step: u32,
    /// A pixel is lit where white − black exceeds this (8-bit grey levels).
    #[arg(long, default_value_t = 40, value_name = "LEVELS", value_parser = clap::value_parser!(i32).range(0..=254))]
    pub black_threshold: i32,
    /// A bit is decided where |pattern − inverse| exceeds this (8-bit grey levels).
    #[arg(long, default_value_t = 5, value_name = "LEVELS", value_parser = clap::value_parser!(i32).range(0..=254))]
    pub white_threshold: i32,
    #[command(flatten)]
    pub order: CaptureOrder,
    /// Integer decoding only (block centres), no sub-pixel refinement from stripe edges.
    #[arg(long)]
    pub no_refine: bool,
    /// Write the map here (.exr or .pfm): R = projector column, G = projector row (NaN where
    /// invalid), B = white frame / 255.
    #[arg(long, value_name = "MAP.exr")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout (keys width, height, valid_pixels, valid_fraction,
    /// refined_column_pixels, refined_row_pixels).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let (w, h) = args.projector;
    let patterns = PatternSet::new(w, h, args.step)?;
    if let Some(out) = &args.out {
        // Refuse a bad output name before the work.
        match render::image_io::Format::from_path(out)? {
            render::image_io::Format::Exr | render::image_io::Format::Pfm => {}
            _ => anyhow::bail!("{}: a decode map is written as .exr or .pfm (float channels)", out.display()),
        }
    }
    let settings = DecodeSettings { black_threshold: args.black_threshold, white_threshold: args.white_threshold, refine: !args.no_refine, white_black_first: args.order.first() };
    let progress = Progress::new(patterns.len() as u64, "images read");
    let capture = read_capture(&args.capture, &patterns, &|| progress.inc());
    progress.set_message("decoding");
    let capture = capture?;
    if let Some(w) = capture.order_warning(args.order.first()) {
        progress.suspend(|| eprintln!("lucent: warning: {}: {w}", args.capture.display()));
    }
    let (map, stats) = decode(&capture, &patterns, &settings)?;
    if let Some(out) = &args.out {
        write_map(out, &map)?;
    }
    progress.finish();
    let n = map.width * map.height;
    if args.json {
        let v = serde_json::json!({
            "width": map.width,
            "height": map.height,
            "valid_pixels": stats.valid_pixels,
            "valid_fraction": map.valid_fraction(),
            "refined_column_pixels": stats.refined_columns,
            "refined_row_pixels": stats.refined_rows,
        });
        println!("{v}");
    } else {
        let pct = |k: usize, of: usize| 100.0 * k as f64 / of.max(1) as f64;
        println!(
            "{}: {}x{} camera pixels, {} valid ({:.1} %); refined from stripe edges: columns {:.1} %, rows {:.1} % of valid",
            args.capture.display(),
            map.width,
            map.height,
            stats.valid_pixels,
            pct(stats.valid_pixels, n),
            pct(stats.refined_columns, stats.valid_pixels),
            pct(stats.refined_rows, stats.valid_pixels)
        );
        if let Some(out) = &args.out {
            println!("wrote {}", out.display());
        }
    }
    Ok(())
}
