//! `lucent scan calibrate-stereo --left IMAGE… --right IMAGE… --corners CxR --square S
//! [--pattern KIND] [--fix-k3] [--zero-tangent] [--rational] [--thin-prism] [--tilted]
//! [--fix-principal-point] [--aspect-ratio R] [--same-focal-length] [--fisheye] [--skip-missing] [--out CALIB.json] [--opencv-out CALIB.xml] [--json]`: two cameras and their
//! relative pose from simultaneous photographs of one target, as OpenCV's `calibrateCamera` per
//! camera followed by `stereoCalibrate` with free intrinsics (scan::calib::calibrate_planar;
//! docs/scanning.md, "Stereo cameras"), or with `--fisheye` as `fisheye::calibrate` and
//! `fisheye::stereoCalibrate` (scan::calib::fisheye::pair).

use std::path::PathBuf;

use anyhow::{bail, Result};
use scan::calib::{calibrate_planar, CaptureCorners, Rig};

use super::calibrate::{check_outputs, write_outputs, LensFlags};
use super::calibrate_camera::{Target, TargetArgs};

/// Arguments of `lucent scan calibrate-stereo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Photographs of the first camera (PNG, JPEG, …; one size), one target pose each.
    #[arg(long, required = true, num_args = 1.., value_name = "IMAGE")]
    pub left: Vec<PathBuf>,
    /// Photographs of the second camera taken at the same moments, in the same order.
    #[arg(long, required = true, num_args = 1.., value_name = "IMAGE")]
    pub right: Vec<PathBuf>,
    #[command(flatten)]
    pub target: TargetArgs,
    #[command(flatten)]
    pub lens: LensFlags,
    /// One focal length for both cameras: the right camera's fx and fy are the left's (OpenCV's
    /// CALIB_SAME_FOCAL_LENGTH).
    #[arg(long)]
    pub same_focal_length: bool,
    /// Fit OpenCV's fisheye model to both cameras (cv2.fisheye.stereoCalibrate with free
    /// intrinsics and CALIB_FIX_SKEW: fx, fy, cx, cy and k1…k4 of each); the JSON then has
    /// "model": "fisheye". Both cameras' photographs must share one size. Of the lens flags only
    /// --fix-principal-point applies.
    #[arg(long)]
    pub fisheye: bool,
    /// Leave out the pairs in which either camera does not see the whole target, instead of failing.
    #[arg(long)]
    pub skip_missing: bool,
    /// Write the calibration JSON here (the format of `scan calibrate`, the second camera in the
    /// `projector` entry, so that `scan markers --calibration` reads it; temporary name, then renamed).
    #[arg(long, value_name = "CALIB.json")]
    pub out: Option<PathBuf>,
    /// Also write OpenCV FileStorage (`.xml`, `.yml` or `.yaml`) with the node names of
    /// `scan calibrate --opencv-out` (the second camera as proj_int, proj_dist).
    #[arg(long, value_name = "CALIB.xml")]
    pub opencv_out: Option<PathBuf>,
    /// Print the calibration JSON on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let target = Target::from_args(&args.target)?;
    if args.left.len() != args.right.len() {
        bail!("--left has {} photographs and --right {}: they are taken in pairs", args.left.len(), args.right.len());
    }
    if args.fisheye {
        args.lens.check_fisheye(args.opencv_out.is_some())?;
        if args.same_focal_length {
            bail!("--same-focal-length: a flag of the pinhole fit; --fisheye fits each camera's focal lengths");
        }
    }
    let opencv_yaml = check_outputs(args.out.as_deref(), args.opencv_out.as_deref())?;
    let mut sizes: [Option<(u32, u32, String)>; 2] = [None, None];
    let mut found = [Vec::new(), Vec::new()];
    for (side, images) in [&args.left, &args.right].into_iter().enumerate() {
        for f in target.find_all(images) {
            let (name, (iw, ih), points) = f?;
            match &sizes[side] {
                None => sizes[side] = Some((iw as u32, ih as u32, name.clone())),
                Some((w, h, first)) if (*w, *h) != (iw as u32, ih as u32) => {
                    bail!("{name}: {iw}x{ih} pixels, but {first} is {w}x{h}: one camera's photographs share one size")
                }
                Some(_) => {}
            }
            found[side].push((name, points));
        }
    }
    let [left, right] = found;
    let mut captures = Vec::new();
    for ((ln, lp), (rn, rp)) in left.into_iter().zip(right) {
        match (lp, rp) {
            (Some(cam), Some(proj)) => captures.push(CaptureCorners { name: format!("{ln} + {rn}"), cam, proj }),
            (lp, _) => {
                let missing = if lp.is_none() { &ln } else { &rn };
                if !args.skip_missing {
                    return Err(target.missing(missing));
                }
                eprintln!("lucent: {missing}: no {}×{} {} found; the pair {ln} + {rn} is skipped", target.cols, target.rows, target.what());
            }
        }
    }
    let (Some((lw, lh, lname)), Some((rw, rh, rname))) = (&sizes[0], &sizes[1]) else { bail!("no photographs") };
    if args.fisheye {
        if (lw, lh) != (rw, rh) {
            bail!("{rname}: {rw}x{rh} pixels, but {lname} is {lw}x{lh}: a fisheye pair is calibrated at one image size (as cv2.fisheye.stereoCalibrate)");
        }
        let pairs: Vec<(String, Vec<_>, Vec<_>)> = captures.into_iter().map(|c| (c.name, c.cam, c.proj)).collect();
        let hold = scan::calib::fisheye::FisheyeHold { principal_point: args.lens.fix_principal_point, skew: true, ..Default::default() };
        let calib = scan::calib::fisheye::pair::calibrate_fisheye_pair(&target.object_points(args.target.square), &pairs, *lw, *lh, hold)?;
        let text = serde_json::to_string_pretty(&calib)?;
        let calib = calib.pair;
        warn_shared_centre(calib.translation, calib.captures.iter().map(|c| c.tvec));
        if write_outputs(&text, args.out.as_deref(), None, String::new, args.json)? {
            return Ok(());
        }
        for (what, d) in [("left ", &calib.camera), ("right", &calib.projector)] {
            let k = &d.distortion;
            println!("{what} {}x{} fisheye: fx {:.2} fy {:.2} cx {:.2} cy {:.2} px; k1 {:.5} k2 {:.5} k3 {:.5} k4 {:.5}; RMS {:.3} px", d.width, d.height, d.fx, d.fy, d.cx, d.cy, k[0], k[1], k[2], k[3], d.rms_px);
        }
        summary(calib.translation, calib.captures.len(), calib.rms_px, &args);
        return Ok(());
    }
    let rig = Rig { cols: target.cols, rows: target.rows, square: args.target.square, camera: (*lw, *lh), projector: (*rw, *rh) };
    let calib = calibrate_planar(&rig, &target.object_points(args.target.square), &captures, None, scan::calib::bundle::Free { same_focal: args.same_focal_length, ..args.lens.free() }, ["left camera", "right camera"])
        .map_err(|e| anyhow::anyhow!("{}", format!("{e:#}").replace("at least 3 captures", "at least 3 pairs of photographs")))?;
    warn_shared_centre(calib.translation, calib.captures.iter().map(|c| c.tvec));
    let text = serde_json::to_string_pretty(&calib)?;
    if write_outputs(&text, args.out.as_deref(), args.opencv_out.as_deref(), || calib.to_filestorage(opencv_yaml), args.json)? {
        return Ok(());
    }
    for (what, d) in [("left ", &calib.camera), ("right", &calib.projector)] {
        let k = &d.distortion;
        println!(
            "{what} {}x{}: fx {:.2} fy {:.2} cx {:.2} cy {:.2} px; k1 {:.4} k2 {:.4} p1 {:.5} p2 {:.5} k3 {:.4}; RMS {:.3} px",
            d.width, d.height, d.fx, d.fy, d.cx, d.cy, k[0], k[1], k[2], k[3], k[4], d.rms_px
        );
    }
    summary(calib.translation, calib.captures.len(), calib.rms_px, &args);
    Ok(())
}

/// Two cameras at one centre (the same photographs twice, or a rotating camera) calibrate, but
/// nothing can be triangulated from them: a warning when the baseline is below 10⁻³ of the
/// median target distance.
fn warn_shared_centre(t: [f64; 3], board: impl Iterator<Item = [f64; 3]>) {
    let baseline = t.iter().map(|t| t * t).sum::<f64>().sqrt();
    let mut dist: Vec<f64> = board.map(|b| b.iter().map(|t| t * t).sum::<f64>().sqrt()).collect();
    dist.sort_by(f64::total_cmp);
    if let Some(&d) = dist.get(dist.len() / 2) {
        if baseline < 1e-3 * d {
            eprintln!("lucent: warning: the two cameras share a centre (baseline {baseline:.3e} units, the target {d:.1} units away): nothing can be triangulated from this rig");
        }
    }
}

/// The pair's pose and error, and the files written.
fn summary(t: [f64; 3], pairs: usize, rms_px: f64, args: &Args) {
    println!("right = R·left + T: T ({:.3}, {:.3}, {:.3}), baseline {:.3} units; {pairs} pairs, RMS {rms_px:.3} px", t[0], t[1], t[2], (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt());
    for out in args.out.iter().chain(args.opencv_out.iter()) {
        println!("wrote {}", out.display());
    }
}
