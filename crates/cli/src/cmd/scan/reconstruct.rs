//! `lucent scan reconstruct CAPTURE_DIR --calibration CALIB.json --out POINTS.ply [--mesh MESH.ply]
//! [--json]`: decodes a capture and triangulates every valid pixel (scan::triangulate,
//! scan::cloud; docs/scanning.md).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use scan::calib::ProcamCalibration;
use scan::cloud::DEFAULT_MAX_EDGE_PIXELS;
use scan::decode::{decode, read_capture, DecodeSettings};
use scan::graycode::PatternSet;
use scan::triangulate::{triangulate_map, Rig};

use super::{CaptureOrder, Progress};

/// Arguments of `lucent scan reconstruct`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Folder with graycode_00.png … or other frame names, as for `lucent scan decode` (the projector size comes from the calibration).
    pub capture: PathBuf,
    /// Calibration JSON as `lucent scan calibrate` writes it, or OpenCV FileStorage XML/YAML as
    /// procam-calibration's calibrate.py writes it (then with --projector).
    #[arg(long, value_name = "CALIB.json")]
    pub calibration: PathBuf,
    /// Projector resolution WIDTHxHEIGHT (pixels): needed with an OpenCV FileStorage
    /// calibration, which does not give it; checked against a JSON calibration.
    #[arg(long, value_name = "WxH", value_parser = super::parse_size)]
    pub projector: Option<(u32, u32)>,
    /// Point cloud output (binary PLY: position, normal, white-frame grey as colour).
    #[arg(long, value_name = "POINTS.ply")]
    pub out: PathBuf,
    /// Also write the range-image mesh here (PLY with faces).
    #[arg(long, value_name = "MESH.ply")]
    pub mesh: Option<PathBuf>,
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
    /// Neighbouring points are joined (normals, mesh) when closer than this many camera-pixel
    /// footprints at their depth.
    #[arg(long, default_value_t = DEFAULT_MAX_EDGE_PIXELS, value_name = "PIXELS")]
    pub max_edge: f64,
    /// Fill undecided pixels between decoded ones: a pixel whose (2R + 1)² window has decoded
    /// pixels in all four quadrants, at least a quarter of the window, takes the affine fit of
    /// their projector coordinates when it fits to 1 projector pixel RMS (scan::decode::fill_holes);
    /// 0: no filling.
    #[arg(long, default_value_t = 0, value_name = "R")]
    pub fill_holes: usize,
    /// Print a JSON summary on stdout (keys points, bbox {min, max}, median_ray_gap; triangles
    /// with --mesh; filled with --fill-holes).
    #[arg(long)]
    pub json: bool,
}

fn check_ply(path: &std::path::Path) -> Result<()> {
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ply")) {
        bail!("{}: point clouds and meshes are written as .ply", path.display());
    }
    render::image_io::check_writable(path)
}

pub fn run(args: Args) -> Result<()> {
    check_ply(&args.out)?;
    if let Some(m) = &args.mesh {
        check_ply(m)?;
    }
    if args.fill_holes > 64 {
        bail!("--fill-holes: at most 64 pixels (a hole's radius), got {}", args.fill_holes);
    }
    if !(args.max_edge > 0.0 && args.max_edge.is_finite()) {
        bail!("--max-edge must be a positive number of pixels, got {}", args.max_edge);
    }
    let calib = ProcamCalibration::read(&args.calibration, args.projector)?;
    for w in calib.lens_warnings() {
        eprintln!("lucent: warning: {}: {w}", args.calibration.display());
    }
    let rig = Rig::new(&calib).with_context(|| format!("{}", args.calibration.display()))?;
    let patterns = PatternSet::new(calib.projector.width, calib.projector.height, args.step).with_context(|| format!("{}: projector", args.calibration.display()))?;
    let settings = DecodeSettings { black_threshold: args.black_threshold, white_threshold: args.white_threshold, refine: !args.no_refine, white_black_first: args.order.first() };

    let progress = Progress::new(patterns.len() as u64, "images read");
    let capture = read_capture(&args.capture, &patterns, &|| progress.inc());
    let capture = capture?;
    if let Some(w) = capture.order_warning(args.order.first()) {
        progress.suspend(|| eprintln!("lucent: warning: {}: {w}", args.capture.display()));
    }
    progress.set_message("decoding");
    let (map, _) = decode(&capture, &patterns, &settings)?;
    let (map, filled) = if args.fill_holes > 0 { scan::decode::fill_holes(&map, args.fill_holes, 0.25, 1.0) } else { (map, 0) };
    progress.finish();
    let progress = Progress::new(map.height as u64, "rows triangulated");
    let range = triangulate_map(&map, &rig, &|| progress.inc()).with_context(|| format!("{} with {}", args.capture.display(), args.calibration.display()))?;
    progress.set_message("normals and mesh");
    let cloud = range.cloud(&map.white, args.max_edge, args.mesh.is_some());
    if cloud.points.is_empty() {
        bail!("{}: no pixel triangulated (nothing decoded, or the calibration does not fit the capture)", args.capture.display());
    }
    cloud.write_ply(&args.out, false)?;
    if let Some(m) = &args.mesh {
        cloud.write_ply(m, true)?;
    }
    progress.finish();
    let s = cloud.summary();
    if args.json {
        let mut v = serde_json::json!({
            "points": s.points,
            "bbox": { "min": s.bbox_min, "max": s.bbox_max },
            "median_ray_gap": s.median_ray_gap,
        });
        if args.mesh.is_some() {
            v["triangles"] = serde_json::json!(cloud.triangles.len());
        }
        if args.fill_holes > 0 {
            v["filled"] = serde_json::json!(filled);
        }
        println!("{v}");
    } else {
        println!(
            "{}: {} points, bbox [{:.2}, {:.2}, {:.2}] – [{:.2}, {:.2}, {:.2}] (square units, camera frame), median ray gap {:.4}",
            args.capture.display(),
            s.points,
            s.bbox_min[0],
            s.bbox_min[1],
            s.bbox_min[2],
            s.bbox_max[0],
            s.bbox_max[1],
            s.bbox_max[2],
            s.median_ray_gap
        );
        println!("wrote {}", args.out.display());
        if let Some(m) = &args.mesh {
            println!("wrote {} ({} triangles)", m.display(), cloud.triangles.len());
        }
    }
    Ok(())
}
