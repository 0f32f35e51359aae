//! Calibration of one camera from photographs of a chessboard (OpenCV's `calibrateCamera`):
//! Zhang's closed form from the board homographies, then Levenberg–Marquardt over all corners
//! ([`super::bundle`]), with OpenCV's choice of distortion terms.
//!
//! The result is lucent's camera JSON (`render::load::calibration`: `width`, `height`, `fx`, `fy`,
//! `cx`, `cy`, `dist`, plus `rms_px` and the board pose of each view), so that `lucent render
//! --camera` renders through it, and optionally OpenCV FileStorage with the node names of
//! OpenCV's calibration sample (`camera_matrix`, `distortion_coefficients`, `image_width`,
//! `image_height`, `avg_reprojection_error`).

use super::bundle::{self, refine, Free, State, ViewObs};
use super::homography::{self, Point2};
use super::{model, zhang, MAX_RMS_PX};
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

/// The board pose of one view (OpenCV's `rvecs`, `tvecs`: board → camera).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ViewPose {
    /// The image.
    pub name: String,
    /// Rodrigues rotation vector board → camera (radians).
    pub rvec: [f64; 3],
    /// Translation board → camera (square units).
    pub tvec: [f64; 3],
    /// RMS reprojection error of this view (pixels).
    pub rms_px: f64,
}

/// A camera calibration as `lucent scan calibrate-camera` writes it; the same JSON is a camera
/// for `lucent render --camera` (the camera at the origin).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct CameraCalibration {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels, OpenCV convention: integer coordinates at pixel centres).
    pub cx: f64,
    /// Principal point y (pixels).
    pub cy: f64,
    /// OpenCV's distortion coefficients: k1, k2, p1, p2, k3 (5), then k4…k6 (8), then s1…s4 (12),
    /// then τx, τy in radians (14).
    pub dist: Vec<f64>,
    /// RMS reprojection error over all corners (pixels).
    pub rms_px: f64,
    /// The board pose of each view.
    pub views: Vec<ViewPose>,
}

impl CameraCalibration {
    /// As OpenCV FileStorage (XML, or YAML when `yaml`) with the node names of OpenCV's
    /// calibration sample, which `lucent render --camera` also reads.
    pub fn to_filestorage(&self, yaml: bool) -> String {
        let k = vec![self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0];
        let nodes = [("camera_matrix", 3, 3, k), ("distortion_coefficients", self.dist.len(), 1, self.dist.clone())];
        let scalars = [("image_width", self.width as f64), ("image_height", self.height as f64), ("avg_reprojection_error", self.rms_px)];
        super::filestorage(yaml, &scalars, &nodes)
    }
}

/// Calibrate a `width` × `height` camera from the `cols` × `rows` inner corners of a chessboard of
/// square size `square` seen in each view (`(name, corners)`, row-major as
/// [`zhang::board_points`]), fitting the distortion terms `free` chooses. Needs 3 views; errors
/// are one line. With `free.rational` the fit starts from the five-coefficient solution and keeps
/// the model invertible over the image ([`bundle::Free`]), as `scan calibrate` does.
pub fn calibrate_camera(views: &[(String, Vec<Point2>)], width: u32, height: u32, cols: usize, rows: usize, square: f64, free: Free) -> Result<CameraCalibration> {
    let n = cols * rows;
    for (name, c) in views {
        if c.len() != n {
            bail!("{name}: {} corners, expected {n} ({cols}×{rows})", c.len());
        }
    }
    calibrate_camera_planar(&zhang::board_points(cols, rows, square), views, width, height, free)
}

/// [`calibrate_camera`] for any planar target: `obj` are the target's points in its plane (z = 0,
/// at least 4 not collinear), and each view gives their pixels in the same order (NaN for a point
/// not seen), as OpenCV's `calibrateCamera` takes one object-point set per view.
pub fn calibrate_camera_planar(obj: &[Point2], views: &[(String, Vec<Point2>)], width: u32, height: u32, free: Free) -> Result<CameraCalibration> {
    calibrate_camera_guided(obj, views, width, height, free, None)
}

/// The refinement of `inits` with `free` that ends at the lowest reprojection RMS; the first
/// error where none converges.
fn lowest_minimum(obj: &[Point2], obs: &[ViewObs], inits: Vec<State>, free: Free) -> Result<State> {
    let mut best: Option<(f64, State)> = None;
    let mut first_error = None;
    for init in inits {
        match refine(obj, obs, &init, free, MAX_RMS_PX).context("camera") {
            Ok(fit) => {
                let e = bundle::rms(obj, obs, &fit).all;
                if best.as_ref().is_none_or(|b| e < b.0) {
                    best = Some((e, fit));
                }
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    match (best, first_error) {
        (Some((_, fit)), _) => Ok(fit),
        (None, Some(e)) => Err(e),
        (None, None) => bail!("camera: no start"),
    }
}

/// [`calibrate_camera_planar`] from a start: with `guess` (OpenCV's `CALIB_USE_INTRINSIC_GUESS`)
/// the fit starts from that lens, and the terms `free.held` holds keep its values; without it,
/// from [`zhang::start`] (the held principal point at the image centre, held distortion terms
/// at 0) and from OpenCV's start (the principal point at the image centre, as
/// `initIntrinsicParams2D`), the lower of the two minima kept.
pub fn calibrate_camera_guided(obj: &[Point2], views: &[(String, Vec<Point2>)], width: u32, height: u32, free: Free, guess: Option<&model::Lens>) -> Result<CameraCalibration> {
    if views.len() < 3 {
        bail!("degenerate pose set: camera calibration needs at least 3 views of the board, got {}", views.len());
    }
    if width == 0 || height == 0 {
        bail!("the image size must be positive, got {width}x{height}");
    }
    for (name, c) in views {
        if c.len() != obj.len() {
            bail!("{name}: {} image points for {} object points", c.len(), obj.len());
        }
    }
    let obs: Vec<ViewObs> = views.iter().map(|(_, c)| ViewObs { cam: c.clone(), proj: vec![] }).collect();
    let fit = if free.rational {
        // A guess with a rational denominator is a start as a whole: its numerator alone, fitted
        // as a five-coefficient lens, can lie far from any minimum (k1 = −20 with k4 = −20 is a
        // fine lens, k1 = −20 alone is not). The five-coefficient fit then comes from lucent's
        // own start and gives the board poses, and the fit starts from the guess and (where no
        // term is held at the guess's value, nor the aspect ratio) from that fit, keeping the
        // lower minimum.
        let rational_guess = guess.filter(|g| g.rational != [0.0; 3]);
        let five = calibrate_camera_guided(obj, views, width, height, Free { rational: false, ..free }, if rational_guess.is_some() { None } else { guess })?;
        let corner_radius = [(-0.5, -0.5), (width as f64 - 0.5, -0.5), (-0.5, height as f64 - 0.5), (width as f64 - 0.5, height as f64 - 0.5)]
            .iter()
            .map(|&(u, v)| ((u - five.cx) / five.fx).hypot((v - five.cy) / five.fy))
            .fold(0.0f64, f64::max);
        // The five-coefficient fit (rational terms 0: a guess without them has none either).
        let lens = model::Lens::from_opencv(five.fx, five.fy, five.cx, five.cy, &five.dist);
        let poses: Vec<model::Pose> = five.views.iter().map(|v| model::Pose { rvec: v.rvec.into(), t: v.tvec.into() }).collect();
        let free_r = Free { rational_radius: [corner_radius, 0.0], ..free };
        let starts = match rational_guess {
            None => vec![lens],
            Some(g) if free.held == 0 && free.aspect_ratio == [None; 2] => vec![free.without_unmodelled(*g, 0), lens],
            Some(g) => vec![free.without_unmodelled(*g, 0)],
        };
        let inits = starts.into_iter().map(|cam| State { cam, proj: None, stereo: model::Pose::identity(), poses: poses.clone() }).collect();
        lowest_minimum(obj, &obs, inits, free_r)?
    } else {
        let mut hs = Vec::new();
        for (name, c) in views {
            let (o, q): (Vec<Point2>, Vec<Point2>) = obj.iter().zip(c).filter(|(_, q)| bundle::observed(**q)).map(|(o, q)| (*o, *q)).unzip();
            hs.push(homography::fit_homography(&o, &q).with_context(|| format!("{name}: the corners do not determine a homography"))?);
        }
        let starts = match guess {
            Some(g) => vec![free.without_unmodelled(*g, 0)],
            None => {
                let mut v = vec![zhang::start(&hs, width, height, &free).context("camera")?];
                // OpenCV's start as well (the principal point at the image centre, the focal
                // lengths for it): where the views fix the principal point poorly (a long lens,
                // views that tilt little), the two starts can end in different minima, and the
                // fit keeps the lower. On 10 photographs of an asymmetric circle grid at fx ≈ 3150
                // px in a 640 × 480 image, with k3 and the tangential terms held, Zhang's start
                // alone ended at 0.510 px RMS and OpenCV's at 0.490.
                if free.held & bundle::HOLD_PRINCIPAL_POINT != bundle::HOLD_PRINCIPAL_POINT {
                    let centred = Free { held: free.held | bundle::HOLD_PRINCIPAL_POINT, ..free };
                    if let Ok(l) = zhang::start(&hs, width, height, &centred) {
                        v.push(model::Lens { dist: v[0].dist, rational: v[0].rational, prism: v[0].prism, tilt: v[0].tilt, ..l });
                    }
                }
                v
            }
        };
        let mut inits = Vec::new();
        for lens in starts {
            let mut poses = Vec::new();
            for (h, (name, _)) in hs.iter().zip(views) {
                poses.push(zhang::pose_from_homography(h, &lens.k()).with_context(|| format!("{name}: no board pose"))?);
            }
            inits.push(State { cam: lens, proj: None, stereo: model::Pose::identity(), poses });
        }
        lowest_minimum(obj, &obs, inits, free)?
    };
    let e = bundle::rms(obj, &obs, &fit);
    let l = &fit.cam;
    let dist: Vec<f64> = l.dist.iter().chain(&l.rational).chain(&l.prism).chain(&l.tilt).copied().take(super::coefficient_count(free)).collect();
    if free.rational || free.tilted {
        super::usable(l.fx, l.fy, l.cx, l.cy, &dist, width, height, free)?;
    }
    Ok(CameraCalibration {
        width,
        height,
        fx: l.fx,
        fy: l.fy,
        cx: l.cx,
        cy: l.cy,
        dist,
        rms_px: e.all,
        views: views
            .iter()
            .zip(fit.poses.iter().zip(&e.per_view))
            .map(|((name, _), (p, &r))| ViewPose { name: name.clone(), rvec: [p.rvec[0], p.rvec[1], p.rvec[2]], tvec: [p.t[0], p.t[1], p.t[2]], rms_px: r })
            .collect(),
    })
}
