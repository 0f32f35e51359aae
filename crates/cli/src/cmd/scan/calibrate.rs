//! `lucent scan calibrate CAPTURE_DIR… --projector WxH --corners CxR --square S [--out CALIB.json]
//! [--opencv-out CALIB.xml] [--json]`: projector–camera calibration from chessboard captures (scan::calib;
//! docs/scanning.md, "Calibration").

use std::path::PathBuf;

use anyhow::{bail, Result};
use scan::calib::procam::LocalHomography;
use scan::calib::{calibrate_dirs, CalibrateOptions, Rig};
use scan::decode::DecodeSettings;
use scan::graycode::PatternSet;

use super::{parse_size, CaptureOrder, Progress};

/// Parses an inner-corner count `COLSxROWS`, e.g. `9x7`.
pub(super) fn parse_corners(s: &str) -> Result<(u32, u32), String> {
    let (c, r) = parse_size(s).map_err(|_| format!("`{s}` is not a corner count COLSxROWS (e.g. 9x7)"))?;
    if c < 3 || r < 3 {
        return Err(format!("the board needs at least 3x3 inner corners, got {s}"));
    }
    Ok((c, r))
}

/// Arguments of `lucent scan calibrate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Capture folders (graycode_00.png … as for `lucent scan decode`), one per board pose; at least 3.
    #[arg(required = true, num_args = 1..)]
    pub captures: Vec<PathBuf>,
    /// Projector resolution WIDTHxHEIGHT (pixels).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub projector: (u32, u32),
    /// Inner corners of the chessboard COLSxROWS (corners per row first, as OpenCV's pattern size).
    #[arg(long, value_name = "CxR", value_parser = parse_corners)]
    pub corners: (u32, u32),
    /// Square size; the translation and board poses come out in this unit.
    #[arg(long, value_name = "S")]
    pub square: f64,
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
    /// Half-size of the local-homography window around each corner (camera pixels; 23 = 47×47).
    #[arg(long, default_value_t = 23, value_name = "PX")]
    pub half_window: usize,
    #[command(flatten)]
    pub lens: LensFlags,
    /// Write the calibration JSON here (written to a temporary name, then renamed).
    #[arg(long, value_name = "CALIB.json")]
    pub out: Option<PathBuf>,
    /// Also write the calibration as OpenCV FileStorage (`.xml`, or `.yml`/`.yaml`) with
    /// procam-calibration's node names (cam_int, cam_dist, proj_int, proj_dist, roration,
    /// translation, img_shape) and proj_shape, for cv::FileStorage and tools made for that file.
    #[arg(long, value_name = "CALIB.xml")]
    pub opencv_out: Option<PathBuf>,
    /// Print the calibration JSON on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
}

/// OpenCV's choice of distortion terms, shared by `scan calibrate` and `scan calibrate-camera`.
#[derive(clap::Args, Debug)]
pub struct LensFlags {
    /// Hold k3, the sixth-order radial term, at 0 (OpenCV's CALIB_FIX_K3), as for lenses whose
    /// field is too narrow to determine it.
    #[arg(long)]
    pub fix_k3: bool,
    /// Hold the tangential terms p1, p2 at 0 (OpenCV's CALIB_ZERO_TANGENT_DIST).
    #[arg(long)]
    pub zero_tangent: bool,
    /// Also fit k4, k5, k6, the denominator of OpenCV's rational model (CALIB_RATIONAL_MODEL),
    /// for wide-angle lenses; the distortion then lists eight coefficients.
    #[arg(long)]
    pub rational: bool,
    /// Also fit s1…s4, OpenCV's thin prism terms (CALIB_THIN_PRISM_MODEL); the distortion then
    /// lists twelve coefficients (k4…k6 are 0 unless --rational).
    #[arg(long)]
    pub thin_prism: bool,
    /// Also fit the sensor tilt τx, τy (OpenCV's CALIB_TILTED_MODEL); the distortion then lists
    /// fourteen coefficients.
    #[arg(long)]
    pub tilted: bool,
    /// Hold the principal point at the image centre, ((width − 1)/2, (height − 1)/2) (OpenCV's
    /// CALIB_FIX_PRINCIPAL_POINT), for views that do not determine it.
    #[arg(long)]
    pub fix_principal_point: bool,
    /// Hold fx/fy at this ratio and fit fy (OpenCV's CALIB_FIX_ASPECT_RATIO; its calibration
    /// sample's `-a`); 1 for square pixels.
    #[arg(long, value_name = "FX/FY", value_parser = positive_f64)]
    pub aspect_ratio: Option<f64>,
}

/// clap value parser: a finite positive number.
pub(super) fn positive_f64(s: &str) -> std::result::Result<f64, String> {
    let v = crate::cmd::mie::finite_f64(s)?;
    if v > 0.0 { Ok(v) } else { Err(format!("{s:?} is not positive")) }
}

impl LensFlags {
    /// The parameters the fit may move.
    pub fn free(&self) -> scan::calib::bundle::Free {
        use scan::calib::bundle::{Free, HOLD_PRINCIPAL_POINT};
        let held = if self.fix_principal_point { HOLD_PRINCIPAL_POINT } else { 0 };
        Free { lenses: true, k3: !self.fix_k3, tangential: !self.zero_tangent, rational: self.rational, thin_prism: self.thin_prism, tilted: self.tilted, held, aspect_ratio: [self.aspect_ratio; 2], ..Default::default() }
    }

    /// With `--fisheye`: the flags of the pinhole model's terms are errors, and
    /// `--opencv-out` too (FileStorage has no node that names the fisheye model).
    pub fn check_fisheye(&self, opencv_out: bool) -> Result<()> {
        let pinhole = [(self.fix_k3, "--fix-k3"), (self.zero_tangent, "--zero-tangent"), (self.rational, "--rational"), (self.thin_prism, "--thin-prism"), (self.tilted, "--tilted"), (self.aspect_ratio.is_some(), "--aspect-ratio")];
        if let Some((_, flag)) = pinhole.iter().find(|(on, _)| *on) {
            bail!("{flag}: a term of the pinhole model; --fisheye fits k1…k4 of the fisheye model");
        }
        if opencv_out {
            bail!("--opencv-out: FileStorage has no node that names the fisheye model; lucent writes it as its JSON (--out)");
        }
        Ok(())
    }
}

/// Checks the outputs before any work: `opencv_out` must end in .xml, .yml or .yaml (returns
/// whether it is YAML), and every output's folder must exist.
pub(super) fn check_outputs(out: Option<&std::path::Path>, opencv_out: Option<&std::path::Path>) -> Result<bool> {
    let yaml = match opencv_out {
        None => false,
        Some(p) => match p.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).as_deref() {
            Some("xml") => false,
            Some("yml" | "yaml") => true,
            _ => bail!("--opencv-out {}: OpenCV FileStorage is written as .xml, .yml or .yaml", p.display()),
        },
    };
    for o in out.iter().chain(opencv_out.iter()) {
        let dir = o.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
        if !dir.is_dir() {
            bail!("{}: cannot write there: {} is not a folder", o.display(), dir.display());
        }
        render::image_io::check_writable(o)?;
    }
    Ok(yaml)
}

/// Writes `text` to `out` under a temporary name, then renames it (a failed run leaves a good file).
pub(super) fn write_text(out: &std::path::Path, text: &str) -> Result<()> {
    render::image_io::write_atomic(out, |tmp| std::fs::write(tmp, text).map_err(|e| anyhow::anyhow!("{}: cannot write ({e})", out.display())))
}

/// The outputs the calibration commands share: `filestorage()` to `opencv_out` and the JSON
/// `text` to `out` (each when given), and the JSON on stdout when `json`. Returns whether it
/// printed the JSON (the summary is then left out).
pub(super) fn write_outputs(text: &str, out: Option<&std::path::Path>, opencv_out: Option<&std::path::Path>, filestorage: impl FnOnce() -> String, json: bool) -> Result<bool> {
    if let Some(o) = opencv_out {
        write_text(o, &filestorage())?;
    }
    if let Some(o) = out {
        write_text(o, &format!("{text}\n"))?;
    }
    if json {
        println!("{text}");
    }
    Ok(json)
}

pub fn run(args: Args) -> Result<()> {
    if !(args.square > 0.0 && args.square.is_finite()) {
        bail!("--square: must be a positive length, got {}", args.square);
    }
    if args.captures.len() < 3 {
        bail!("degenerate pose set: calibration needs at least 3 captures (board poses), got {}", args.captures.len());
    }
    let (w, h) = args.projector;
    let patterns = PatternSet::new(w, h, args.step)?;
    let rig = Rig { cols: args.corners.0 as usize, rows: args.corners.1 as usize, square: args.square, camera: (0, 0), projector: (w, h) };
    let opts = CalibrateOptions {
        decode: DecodeSettings { black_threshold: args.black_threshold, white_threshold: args.white_threshold, refine: true, white_black_first: args.order.first() },
        local: LocalHomography { half_window: args.half_window, ..Default::default() },
        step: args.step,
        free: args.lens.free(),
    };
    let opencv_yaml = check_outputs(args.out.as_deref(), args.opencv_out.as_deref())?;
    let progress = Progress::new((patterns.len() * args.captures.len()) as u64, "images read and decoded");
    let result = calibrate_dirs(&args.captures, &rig, &opts, &|| progress.inc());
    progress.finish();
    let (calib, _) = result?;
    for w in calib.lens_warnings() {
        eprintln!("lucent: warning: {w}");
    }
    let text = serde_json::to_string_pretty(&calib)?;
    if write_outputs(&text, args.out.as_deref(), args.opencv_out.as_deref(), || calib.to_filestorage(opencv_yaml), args.json)? {
        return Ok(());
    }
    let dev = |name: &str, d: &scan::calib::DeviceCalibration| {
        println!(
            "{name:9} {}x{}: fx {:.2} fy {:.2} cx {:.2} cy {:.2} px; k1 {:.4} k2 {:.4} p1 {:.5} p2 {:.5} k3 {:.4}; RMS {:.3} px",
            d.width, d.height, d.fx, d.fy, d.cx, d.cy, d.distortion[0], d.distortion[1], d.distortion[2], d.distortion[3], d.distortion[4], d.rms_px
        );
        let extra = &d.distortion[5..];
        if let [k4, k5, k6, ..] = *extra {
            if [k4, k5, k6].iter().any(|&k| k != 0.0) {
                println!("{:9} rational denominator k4 {k4:.4} k5 {k5:.4} k6 {k6:.4}", "");
            }
        }
        if let [_, _, _, s1, s2, s3, s4, ..] = *extra {
            println!("{:9} thin prism s1 {s1:.5} s2 {s2:.5} s3 {s3:.5} s4 {s4:.5}", "");
        }
        if let [.., tx, ty] = *extra {
            if extra.len() == 9 {
                println!("{:9} sensor tilt τx {tx:.6} τy {ty:.6} rad", "");
            }
        }
    };
    dev("camera", &calib.camera);
    dev("projector", &calib.projector);
    let t = calib.translation;
    let r = &calib.rotation;
    let angle = ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees();
    println!("camera → projector: rotation {angle:.3}°, T ({:.3}, {:.3}, {:.3}), |T| {:.3} (in the unit of --square)", t[0], t[1], t[2], (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt());
    for c in &calib.captures {
        let n = (args.corners.0 * args.corners.1) as usize;
        let partial = if c.projector_corners < n { format!(", {} of {n} corners lit by the projector", c.projector_corners) } else { String::new() };
        println!("  {}: board at {:.1} units, RMS {:.3} px{partial}", c.name, (c.tvec[0].powi(2) + c.tvec[1].powi(2) + c.tvec[2].powi(2)).sqrt(), c.rms_px);
    }
    println!("stereo RMS {:.3} px", calib.rms_px);
    if let Some(out) = &args.out {
        println!("wrote {}", out.display());
    }
    Ok(())
}
