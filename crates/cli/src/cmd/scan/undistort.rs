//! `lucent scan undistort IMAGE --camera CAMERA.json --out OUT.png`: a photograph with its lens
//! distortion removed, as OpenCV's `undistort` (scan::calib::undistort; docs/scanning.md).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use render::load::calibration::{read_calibration, CalibrationNodes};

/// Arguments of `lucent scan undistort`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The photograph (PNG or JPEG, 8-bit grey or colour).
    pub image: PathBuf,
    /// The camera: the JSON of `scan calibrate-camera`, or OpenCV FileStorage with camera_matrix
    /// and distortion_coefficients (as `render --camera` reads it).
    #[arg(long, value_name = "CAMERA.json")]
    pub camera: PathBuf,
    /// The undistorted image (PNG; grey or colour as the photograph; temporary name, then renamed).
    #[arg(long, value_name = "OUT.png")]
    pub out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    if !args.out.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        bail!("--out {}: the undistorted image is written as PNG (.png)", args.out.display());
    }
    let calib = read_calibration(&args.camera, &CalibrationNodes::default())?;
    if calib.fisheye.is_some() {
        bail!("{}: a fisheye camera; scan undistort takes OpenCV's pinhole model (lucent.fisheye.init_undistort_rectify_map gives the fisheye's maps)", args.camera.display());
    }
    render::image_io::check_writable(&args.out).context("--out")?;
    let size = calib.width.zip(calib.height);
    let (k, d) = (calib.intrinsics, calib.distortion);
    scan::calib::undistort::remap_photo(&args.image, size, &args.out, |w, h| {
        // The lens must be one whose distortion inverts over the whole photograph.
        let identity = render::camera::Extrinsics::identity();
        render::camera::OpenCv::new(k, d, identity, w as u32, h as u32).with_context(|| format!("camera {}", args.camera.display()))?;
        Ok(scan::calib::undistort::undistort_map(&k, &d, &k, w, h))
    })?;
    println!("wrote {}", args.out.display());
    Ok(())
}
