//! `lucent scan rectify LEFT RIGHT --calibration CALIB.json --out-left L.png --out-right R.png
//! [--alpha A | --balance B [--fov-scale S]] [--keep-disparity] [--json]`: a stereo pair of
//! photographs rectified, so that a point seen by both cameras lies on the same row of the two
//! images, as OpenCV's `stereoRectify` + `initUndistortRectifyMap` + `remap`
//! (scan::calib::rectify; docs/scanning.md), or for a fisheye pair (`scan calibrate-stereo
//! --fisheye`) as `fisheye::stereoRectify` + `fisheye::initUndistortRectifyMap` + `remap`
//! (scan::calib::fisheye::rectify).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use scan::calib::fisheye::pair::FisheyeStereoCalibration;
use scan::calib::fisheye::rectify::{stereo_rectify_fisheye, undistort_rectify_map_fisheye};
use scan::calib::rectify::{matrix_rows, rectify_calibration, undistort_rectify_map};
use scan::calib::ProcamCalibration;

/// Arguments of `lucent scan rectify`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The first camera's photograph (PNG or JPEG; the calibration's `camera`).
    pub left: PathBuf,
    /// The second camera's photograph, taken at the same moment (the calibration's `projector` entry).
    pub right: PathBuf,
    /// The pair's calibration: the JSON of `scan calibrate-stereo` (X_right = R·X_left + T).
    #[arg(long, value_name = "CALIB.json")]
    pub calibration: PathBuf,
    /// The rectified first photograph (PNG; temporary name, then renamed).
    #[arg(long, value_name = "L.png")]
    pub out_left: PathBuf,
    /// The rectified second photograph (PNG).
    #[arg(long, value_name = "R.png")]
    pub out_right: PathBuf,
    /// Free scaling of a pinhole pair, as OpenCV's: 0 shows only valid pixels, 1 keeps every
    /// source pixel; by default OpenCV's −1 (no scaling).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::cmd::mie::finite_f64)]
    pub alpha: Option<f64>,
    /// A fisheye pair's new focal length between the largest (0, the default: no edge midpoint
    /// of the image outside the rectified one) and the smallest (1: every one inside), as
    /// cv2.fisheye.stereoRectify's balance.
    #[arg(long, value_parser = crate::cmd::mie::finite_f64)]
    pub balance: Option<f64>,
    /// A fisheye pair's focal length divisor (cv2.fisheye.stereoRectify's fov_scale; default 1).
    #[arg(long, value_parser = crate::cmd::scan::calibrate::positive_f64)]
    pub fov_scale: Option<f64>,
    /// Give each image its own principal point along the baseline instead of a shared one
    /// (OpenCV's stereoRectify without CALIB_ZERO_DISPARITY).
    #[arg(long)]
    pub keep_disparity: bool,
    /// Print R1, R2, P1, P2, Q and the valid rectangles as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    for out in [&args.out_left, &args.out_right] {
        if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
            bail!("{}: the rectified images are written as PNG (.png)", out.display());
        }
        render::image_io::check_writable(out)?;
    }
    if args.out_left == args.out_right {
        bail!("--out-left, --out-right: both name {}; the two images need two files", args.out_left.display());
    }
    let text = std::fs::read_to_string(&args.calibration).with_context(|| format!("{}: cannot read", args.calibration.display()))?;
    if FisheyeStereoCalibration::is_fisheye(&text) {
        return run_fisheye(&args);
    }
    if args.balance.is_some() || args.fov_scale.is_some() {
        bail!("--balance, --fov-scale: options of a fisheye pair; {} is a pinhole pair (--alpha scales it)", args.calibration.display());
    }
    let c = ProcamCalibration::read(&args.calibration, None)?;
    for w in c.lens_warnings() {
        eprintln!("lucent: warning: {}: {w}", args.calibration.display());
    }
    let size = (c.camera.width, c.camera.height);
    let (rect, lenses) = rectify_calibration(&c, !args.keep_disparity, args.alpha.unwrap_or(-1.0)).with_context(|| args.calibration.display().to_string())?;
    for (i, (photo, out)) in [(&args.left, &args.out_left), (&args.right, &args.out_right)].into_iter().enumerate() {
        let (k, d) = &lenses[i];
        let p = rect.p[i].fixed_view::<3, 3>(0, 0).into_owned();
        scan::calib::undistort::remap_photo(photo, Some(size), out, |w, h| undistort_rectify_map(k, d, &rect.r[i], &p, w, h))?;
    }
    if args.json {
        let mut v = matrices_json(matrix_rows(&rect.r, &rect.p, &rect.q));
        v["roi1"] = serde_json::json!(rect.roi[0]);
        v["roi2"] = serde_json::json!(rect.roi[1]);
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        let p = &rect.p[0];
        println!("rectified: f {:.2} px, principal points ({:.2}, {:.2}) and ({:.2}, {:.2}); valid {:?} and {:?}", p[(0, 0)], p[(0, 2)], p[(1, 2)], rect.p[1][(0, 2)], rect.p[1][(1, 2)], rect.roi[0], rect.roi[1]);
        println!("wrote {} and {}", args.out_left.display(), args.out_right.display());
    }
    Ok(())
}

/// `scan rectify` of a fisheye pair.
fn run_fisheye(args: &Args) -> Result<()> {
    if args.alpha.is_some() {
        bail!("--alpha: the free scaling of a pinhole pair; {} is a fisheye pair (--balance and --fov-scale scale it)", args.calibration.display());
    }
    let c = FisheyeStereoCalibration::read(&args.calibration)?;
    let (lens, r, t) = c.parts()?;
    let c = c.pair;
    let size = (c.camera.width, c.camera.height);
    if size != (c.projector.width, c.projector.height) {
        bail!("{}: the two cameras are {}x{} and {}x{}; rectification takes two images of one size", args.calibration.display(), size.0, size.1, c.projector.width, c.projector.height);
    }
    let rect = stereo_rectify_fisheye([&lens[0], &lens[1]], size, &r, &t, !args.keep_disparity, (0, 0), args.balance.unwrap_or(0.0), args.fov_scale.unwrap_or(1.0)).with_context(|| args.calibration.display().to_string())?;
    for (i, (photo, out)) in [(&args.left, &args.out_left), (&args.right, &args.out_right)].into_iter().enumerate() {
        let p = rect.p[i].fixed_view::<3, 3>(0, 0).into_owned();
        scan::calib::undistort::remap_photo(photo, Some(size), out, |w, h| undistort_rectify_map_fisheye(&lens[i], &rect.r[i], &p, w, h))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&matrices_json(matrix_rows(&rect.r, &rect.p, &rect.q)))?);
    } else {
        let p = &rect.p[0];
        println!("rectified fisheye pair: f {:.2} px, principal points ({:.2}, {:.2}) and ({:.2}, {:.2})", p[(0, 0)], p[(0, 2)], p[(1, 2)], rect.p[1][(0, 2)], rect.p[1][(1, 2)]);
        println!("wrote {} and {}", args.out_left.display(), args.out_right.display());
    }
    Ok(())
}

/// R1, R2, P1, P2 and Q as JSON rows (`--json`).
fn matrices_json(named: [(&str, Vec<Vec<f64>>); 5]) -> serde_json::Value {
    serde_json::Value::Object(named.into_iter().map(|(k, v)| (k.to_string(), serde_json::json!(v))).collect())
}
