//! `lucent scan calibrate-camera IMAGE… --corners CxR --square S [--pattern KIND] [--fix-k3]
//! [--squares XxY --marker-length M --dictionary DICT [--legacy-pattern]]
//! [--zero-tangent] [--rational] [--thin-prism] [--tilted] [--fisheye] [--out CAMERA.json]
//! [--opencv-out CAMERA.yml] [--json]`: one camera from photographs of a chessboard or a circle
//! grid, as OpenCV's `findChessboardCorners` + `cornerSubPix` (or `findCirclesGrid`, or a
//! ChArUco board as `CharucoDetector::detectBoard`) +
//! `calibrateCamera`, or `fisheye::calibrate` with `--fisheye` (scan::calib::camera,
//! scan::calib::fisheye, scan::markers::grid; docs/scanning.md).

use std::path::PathBuf;

use anyhow::{bail, Result};
use scan::calib::camera::calibrate_camera_planar;
use scan::calib::chessboard::{find_chessboard, GrayImage};
use scan::calib::fisheye::{calibrate_fisheye_camera, FisheyeHold};
use scan::calib::zhang::board_points;
use scan::markers::aruco::{ArucoSettings, CharucoBoard, Dictionary};
use scan::markers::grid::{find_circles_grid, grid_points, GridKind};

use super::calibrate::{check_outputs, parse_corners, write_outputs, LensFlags};

/// The calibration target's flags, shared by `calibrate-camera` and `calibrate-stereo`.
#[derive(clap::Args, Debug)]
pub struct TargetArgs {
    /// Pattern size COLSxROWS, as OpenCV's patternSize: the chessboard's inner corners per row
    /// and rows, or a circle grid's discs per row and rows (not for `charuco`: see --squares).
    #[arg(long, value_name = "CxR", value_parser = parse_corners)]
    pub corners: Option<(u32, u32)>,
    /// A ChArUco board's squares per row and rows, as OpenCV's CharucoBoard((X, Y), …).
    #[arg(long, value_name = "XxY", value_parser = parse_squares)]
    pub squares: Option<(u32, u32)>,
    /// A ChArUco board's marker side, in the unit of --square.
    #[arg(long, value_name = "M")]
    pub marker_length: Option<f64>,
    /// A ChArUco board's ArUco dictionary: OpenCV's name (DICT_4X4_50, DICT_5X5_1000,
    /// DICT_6X6_250, DICT_ARUCO_ORIGINAL, …) or its cv2.aruco enum value.
    #[arg(long, value_name = "DICT")]
    pub dictionary: Option<String>,
    /// The ChArUco layout of OpenCV before 4.6 (setLegacyPattern(true)): with an even number of
    /// rows the top-left square is light and carries marker 0.
    #[arg(long)]
    pub legacy_pattern: bool,
    /// Square size; the board poses come out in this unit. For circle grids the spacing s of
    /// OpenCV's object points: neighbouring discs of a symmetric grid are s apart, those of one row
    /// of an asymmetric grid 2s.
    #[arg(long, value_name = "S")]
    pub square: f64,
    /// The target: `chessboard`, `circles` (a symmetric circle grid), `acircles` (an asymmetric
    /// one, OpenCV's CALIB_CB_ASYMMETRIC_GRID: rows of discs 2s apart, every second row shifted by
    /// s) or `charuco` (a ChArUco board: --squares, --marker-length, --dictionary; photographs
    /// may show part of it).
    #[arg(long, value_name = "KIND", default_value = "chessboard", value_parser = ["chessboard", "circles", "acircles", "charuco"])]
    pub pattern: String,
}

fn parse_squares(s: &str) -> Result<(u32, u32), String> {
    let (c, r) = super::parse_size(s).map_err(|_| format!("`{s}` is not a square count XxY (e.g. 7x5)"))?;
    if c < 2 || r < 2 {
        return Err(format!("a ChArUco board needs at least 2x2 squares, got {s}"));
    }
    Ok((c, r))
}

/// Fewest ChArUco corners for a view to count as found (a homography needs 4; 6 leave a check).
const MIN_CHARUCO_CORNERS: usize = 6;

/// Arguments of `lucent scan calibrate-camera`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Photographs of the chessboard (PNG, JPEG, …; all of one size), one board pose each; at least 3.
    #[arg(required = true, num_args = 1..)]
    pub images: Vec<PathBuf>,
    #[command(flatten)]
    pub target: TargetArgs,
    #[command(flatten)]
    pub lens: LensFlags,
    /// Fit OpenCV's fisheye model (cv2.fisheye.calibrate with CALIB_FIX_SKEW: fx, fy, cx, cy and
    /// k1…k4 of θ_d = θ(1 + k1θ² + … + k4θ⁸)) instead of the pinhole's distortion; the JSON then
    /// has "model": "fisheye". Of the lens flags only --fix-principal-point applies.
    #[arg(long)]
    pub fisheye: bool,
    /// Skip the images in which the board is not found (OpenCV's samples do) instead of failing.
    #[arg(long)]
    pub skip_missing: bool,
    /// Write the camera JSON here (also a camera for `lucent render --camera`; temporary name, then renamed).
    #[arg(long, value_name = "CAMERA.json")]
    pub out: Option<PathBuf>,
    /// Also write OpenCV FileStorage (`.xml`, `.yml` or `.yaml`) with the node names of OpenCV's
    /// calibration sample (camera_matrix, distortion_coefficients, image_width, image_height,
    /// avg_reprojection_error).
    #[arg(long, value_name = "CAMERA.yml")]
    pub opencv_out: Option<PathBuf>,
    /// Print the camera JSON on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
}

/// One photograph: its name, size (pixels) and the target's points if found.
type Found = (String, (usize, usize), Option<Vec<[f64; 2]>>);

/// The calibration target of `--pattern` and `--corners`.
#[derive(Clone, Debug)]
pub(super) struct Target {
    /// None: a chessboard (or a ChArUco board).
    pub grid: Option<GridKind>,
    /// A ChArUco board: its chessboard corners are the target's points.
    pub charuco: Option<CharucoBoard>,
    pub cols: usize,
    pub rows: usize,
}

impl Target {
    /// The target of the flags; an error for a square size that is not a positive length.
    pub fn from_args(a: &TargetArgs) -> Result<Target> {
        if !(a.square > 0.0 && a.square.is_finite()) {
            bail!("--square: must be a positive length, got {}", a.square);
        }
        let grid = match a.pattern.as_str() {
            "circles" => Some(GridKind::Symmetric),
            "acircles" => Some(GridKind::Asymmetric),
            _ => None,
        };
        if a.pattern == "charuco" {
            let Some((sx, sy)) = a.squares else { bail!("--pattern charuco: --squares XxY is required (the board's squares per row and rows)") };
            let Some(m) = a.marker_length else { bail!("--pattern charuco: --marker-length is required") };
            let Some(d) = a.dictionary.as_deref() else { bail!("--pattern charuco: --dictionary is required (e.g. DICT_4X4_50)") };
            if a.corners.is_some() {
                bail!("--corners: not for --pattern charuco (its corners follow from --squares)");
            }
            let board = CharucoBoard::new(sx as usize, sy as usize, a.square, m, Dictionary::predefined(d).map_err(|e| anyhow::anyhow!("--dictionary: {e}"))?, a.legacy_pattern)
                .map_err(|e| anyhow::anyhow!("--squares/--marker-length: {e}"))?;
            return Ok(Target { grid: None, charuco: Some(board), cols: sx as usize - 1, rows: sy as usize - 1 });
        }
        for (set, flag) in [(a.squares.is_some(), "--squares"), (a.marker_length.is_some(), "--marker-length"), (a.dictionary.is_some(), "--dictionary"), (a.legacy_pattern, "--legacy-pattern")] {
            if set {
                bail!("{flag}: only for --pattern charuco");
            }
        }
        let Some((cols, rows)) = a.corners else { bail!("--corners COLSxROWS is required for --pattern {}", a.pattern) };
        Ok(Target { grid, charuco: None, cols: cols as usize, rows: rows as usize })
    }

    /// What the target is, for messages.
    pub fn what(&self) -> &'static str {
        if self.charuco.is_some() {
            return "ChArUco board";
        }
        match self.grid {
            None => "chessboard",
            Some(GridKind::Symmetric) => "symmetric circle grid",
            Some(GridKind::Asymmetric) => "asymmetric circle grid",
        }
    }

    /// Its points (z = 0) in the unit of `square`, in the order the finders return them.
    pub fn object_points(&self, square: f64) -> Vec<[f64; 2]> {
        if let Some(b) = &self.charuco {
            return b.chessboard_corners();
        }
        match self.grid {
            None => board_points(self.cols, self.rows, square),
            Some(kind) => grid_points(kind, self.cols, self.rows, square),
        }
    }

    /// Each photograph read and searched on its own (in parallel), in the order given.
    pub fn find_all(&self, images: &[PathBuf]) -> Vec<Result<Found>> {
        use rayon::prelude::*;
        images
            .par_iter()
            .map(|path| {
                let name = path.display().to_string();
                let img = GrayImage::load(path)?;
                if let Some(b) = &self.charuco {
                    // Partial views: the corners not found are NaN (the calibrations skip them).
                    let d = b.detect(&img, &ArucoSettings::default());
                    if d.corners.len() < MIN_CHARUCO_CORNERS && d.markers.len() >= 2 {
                        // Markers but no corners: the other layout (OpenCV before or after 4.6)?
                        let other = CharucoBoard { legacy: !b.legacy, ..b.clone() };
                        if other.marker_squares() != b.marker_squares() && other.detect(&img, &ArucoSettings::default()).corners.len() >= MIN_CHARUCO_CORNERS {
                            let flag = if b.legacy { "without --legacy-pattern" } else { "with --legacy-pattern" };
                            anyhow::bail!("{name}: {} of the board's markers found, but its corners only {flag} (the ChArUco layout of OpenCV {})", d.markers.len(), if b.legacy { "4.6 and later" } else { "before 4.6" });
                        }
                    }
                    let found = (d.corners.len() >= MIN_CHARUCO_CORNERS).then(|| b.full_view(&d));
                    return Ok((name, (img.width, img.height), found));
                }
                let found = match self.grid {
                    None => find_chessboard(&img, self.cols, self.rows),
                    Some(kind) => {
                        // The discs' edges are located on the photograph's codes as they are (as
                        // OpenCV's blob detector thresholds them): docs/scanning.md, "Circle grids".
                        let grey = scan::markers::Image::new(img.width, img.height, img.data.iter().map(|v| v / 255.0).collect())?;
                        find_circles_grid(&grey, kind, self.cols, self.rows)
                    }
                };
                Ok((name, (img.width, img.height), found))
            })
            .collect()
    }

    /// The error for a photograph in which the target is not found.
    pub fn missing(&self, name: &str) -> anyhow::Error {
        let (cols, rows) = (self.cols, self.rows);
        if self.charuco.is_some() {
            return anyhow::anyhow!("{name}: fewer than {MIN_CHARUCO_CORNERS} ChArUco corners found (--skip-missing leaves such images out)");
        }
        match self.grid {
            None => anyhow::anyhow!("{name}: no {cols}×{rows} lattice of chessboard corners found (--skip-missing leaves such images out)"),
            Some(_) => anyhow::anyhow!("{name}: no {cols}×{rows} {} found (--skip-missing leaves such images out)", self.what()),
        }
    }
}

pub fn run(args: Args) -> Result<()> {
    let target = Target::from_args(&args.target)?;
    if args.fisheye {
        args.lens.check_fisheye(args.opencv_out.is_some())?;
    }
    let opencv_yaml = check_outputs(args.out.as_deref(), args.opencv_out.as_deref())?;
    // Sizes, skips and errors are taken in the order given.
    let mut size = None;
    let mut views = Vec::new();
    for f in target.find_all(&args.images) {
        let (name, (iw, ih), corners) = f?;
        match size {
            None => size = Some((iw as u32, ih as u32, name.clone())),
            Some((w, h, ref first)) if (w, h) != (iw as u32, ih as u32) => {
                bail!("{name}: {iw}x{ih} pixels, but {first} is {w}x{h}: one camera's photographs share one size")
            }
            Some(_) => {}
        }
        match corners {
            Some(c) => views.push((name, c)),
            None if args.skip_missing => eprintln!("lucent: {}; skipped", target.missing(&name).to_string().split(" (--skip-missing").next().unwrap_or_default()),
            None => return Err(target.missing(&name)),
        }
    }
    let (w, h, _) = size.expect("clap requires one image");
    if args.fisheye {
        let hold = FisheyeHold { principal_point: args.lens.fix_principal_point, skew: true, ..Default::default() };
        let calib = calibrate_fisheye_camera(&target.object_points(args.target.square), &views, w, h, hold)?;
        let text = serde_json::to_string_pretty(&calib)?;
        if write_outputs(&text, args.out.as_deref(), None, String::new, args.json)? {
            return Ok(());
        }
        let k = &calib.dist;
        println!(
            "fisheye camera {}x{} from {} views: fx {:.2} fy {:.2} cx {:.2} cy {:.2} px; k1 {:.5} k2 {:.5} k3 {:.5} k4 {:.5}; RMS {:.3} px",
            calib.width, calib.height, calib.views.len(), calib.fx, calib.fy, calib.cx, calib.cy, k[0], k[1], k[2], k[3], calib.rms_px
        );
        for v in &calib.views {
            println!("  {}: board at {:.1} units, RMS {:.3} px", v.name, (v.tvec[0].powi(2) + v.tvec[1].powi(2) + v.tvec[2].powi(2)).sqrt(), v.rms_px);
        }
        if let Some(out) = &args.out {
            println!("wrote {}", out.display());
        }
        return Ok(());
    }
    let calib = calibrate_camera_planar(&target.object_points(args.target.square), &views, w, h, args.lens.free())?;
    let text = serde_json::to_string_pretty(&calib)?;
    if write_outputs(&text, args.out.as_deref(), args.opencv_out.as_deref(), || calib.to_filestorage(opencv_yaml), args.json)? {
        return Ok(());
    }
    let d = &calib.dist;
    println!(
        "camera {}x{} from {} views: fx {:.2} fy {:.2} cx {:.2} cy {:.2} px; k1 {:.4} k2 {:.4} p1 {:.5} p2 {:.5} k3 {:.4}; RMS {:.3} px",
        calib.width, calib.height, calib.views.len(), calib.fx, calib.fy, calib.cx, calib.cy, d[0], d[1], d[2], d[3], d[4], calib.rms_px
    );
    if let [k4, k5, k6, ..] = d[5..] {
        if [k4, k5, k6].iter().any(|&k| k != 0.0) {
            println!("       rational denominator k4 {k4:.4} k5 {k5:.4} k6 {k6:.4}");
        }
    }
    if let [_, _, _, s1, s2, s3, s4, ..] = d[5..] {
        println!("       thin prism s1 {s1:.5} s2 {s2:.5} s3 {s3:.5} s4 {s4:.5}");
    }
    if let [_, _, _, _, _, _, _, tx, ty] = d[5..] {
        println!("       sensor tilt τx {tx:.6} τy {ty:.6} rad");
    }
    for v in &calib.views {
        println!("  {}: board at {:.1} units, RMS {:.3} px", v.name, (v.tvec[0].powi(2) + v.tvec[1].powi(2) + v.tvec[2].powi(2)).sqrt(), v.rms_px);
    }
    for out in args.out.iter().chain(args.opencv_out.iter()) {
        println!("wrote {}", out.display());
    }
    Ok(())
}
