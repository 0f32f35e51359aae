//! A fisheye stereo pair's calibration file, as `lucent scan calibrate-stereo --fisheye` writes
//! it: the pinhole pair's file (`ProcamCalibration`: the first camera in `camera`, the second in
//! `projector`, X₂ = R·X₁ + T in `rotation` and `translation`, the board pose per pair of
//! photographs in `captures`) with each device's `distortion` holding k1…k4 of OpenCV's fisheye
//! model, and at the top `"model": "fisheye"` and `"skew": [α₁, α₂]`. Readers of the pinhole
//! file refuse it by its `model` (`ProcamCalibration::read`); `render::load::calibration` reads
//! either camera of it as a fisheye camera.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use anyhow::{anyhow, bail, Context, Result};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::{rms, stereo_calibrate_fisheye, FisheyeHold, FisheyeLens};
use crate::calib::bundle::observed;
use crate::calib::homography::Point2;
use crate::calib::{CapturePose, DeviceCalibration, ProcamCalibration};

/// A fisheye stereo calibration file (module documentation): the pinhole pair's fields, each
/// device's `distortion` holding k1…k4, with the model's name and the two skews.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FisheyeStereoCalibration {
    /// Always `fisheye`.
    pub model: String,
    /// The skew α of the first and of the second camera (dimensionless; K₀₁ = α fx).
    pub skew: [f64; 2],
    /// The devices (the second camera in `projector`), their relative pose and the board poses.
    #[serde(flatten)]
    pub pair: ProcamCalibration,
}

impl FisheyeStereoCalibration {
    /// Whether calibration text (JSON) names the fisheye model at its top level.
    pub fn is_fisheye(text: &str) -> bool {
        serde_json::from_str::<serde_json::Value>(text).ok().and_then(|v| v.get("model").and_then(|m| m.as_str().map(|s| s == "fisheye"))).unwrap_or(false)
    }

    /// Read a fisheye pair's file; errors are one line naming the file.
    pub fn read(path: &std::path::Path) -> Result<FisheyeStereoCalibration> {
        let name = path.display();
        let text = std::fs::read_to_string(path).with_context(|| format!("{name}: cannot read"))?;
        let c: FisheyeStereoCalibration = serde_json::from_str(&text).map_err(|e| anyhow!("{name}: not a fisheye pair's calibration: {e}"))?;
        if c.model != "fisheye" {
            bail!("{name}: model: expected \"fisheye\", got \"{}\"", c.model);
        }
        c.lenses().map_err(|e| anyhow!("{name}: {e}"))?;
        let r = Matrix3::from_fn(|i, j| c.pair.rotation[i][j]);
        if !r.iter().chain(c.pair.translation.iter()).all(|v| v.is_finite()) || (r * r.transpose() - Matrix3::identity()).norm() > 1e-6 || r.determinant() < 0.0 {
            bail!("{name}: rotation: not a finite rotation matrix");
        }
        Ok(c)
    }

    /// The two lenses.
    pub fn lenses(&self) -> Result<[FisheyeLens; 2]> {
        let lens = |d: &DeviceCalibration, skew: f64, what: &str| -> Result<FisheyeLens> {
            let &[k1, k2, k3, k4] = d.distortion.as_slice() else { bail!("{what}: distortion: the fisheye model has 4 coefficients k1, k2, k3, k4, got {}", d.distortion.len()) };
            FisheyeLens::from_opencv(&[d.fx, skew * d.fx, d.cx, 0.0, d.fy, d.cy, 0.0, 0.0, 1.0], &[k1, k2, k3, k4]).map_err(|e| anyhow!("{what}: {e}"))
        };
        Ok([lens(&self.pair.camera, self.skew[0], "camera")?, lens(&self.pair.projector, self.skew[1], "projector")?])
    }

    /// The two lenses, the rotation and the translation.
    pub fn parts(&self) -> Result<([FisheyeLens; 2], Matrix3<f64>, Vector3<f64>)> {
        Ok((self.lenses()?, Matrix3::from_fn(|i, j| self.pair.rotation[i][j]), Vector3::from(self.pair.translation)))
    }
}

/// Calibrate a pair of `width` × `height` fisheye cameras from named pairs of photographs of one
/// planar target (its points `obj`, z = 0; per pair the first and the second camera's pixels,
/// NaN where not seen): [`stereo_calibrate_fisheye`] with the intrinsics free (held as `hold`
/// says). At least 3 pairs; errors on one line naming the pair where one is at fault.
pub fn calibrate_fisheye_pair(obj: &[Point2], pairs: &[(String, Vec<Point2>, Vec<Point2>)], width: u32, height: u32, hold: FisheyeHold) -> Result<FisheyeStereoCalibration> {
    if pairs.len() < 3 {
        bail!("degenerate pose set: a stereo calibration needs at least 3 pairs of photographs, got {}", pairs.len());
    }
    let v1: Vec<Vec<Point2>> = pairs.iter().map(|p| p.1.clone()).collect();
    let v2: Vec<Vec<Point2>> = pairs.iter().map(|p| p.2.clone()).collect();
    let fit = stereo_calibrate_fisheye(obj, [&v1, &v2], width, height, hold, false, [None, None], crate::calib::MAX_RMS_PX).map_err(|e| {
        let msg = e.to_string();
        if msg.contains("turned against each other") {
            // The views of a disagreement named by their photograph pairs (higher indices first,
            // so that "view 1" does not match inside "view 12").
            return anyhow!("{}", (0..pairs.len()).rev().fold(msg, |m, i| m.replace(&format!("view {i} ("), &format!("{} (", pairs[i].0))));
        }
        // "camera d: view i …" names the photograph pair.
        match (0..pairs.len()).find(|i| msg.contains(&format!("view {i} ")) || msg.contains(&format!("view {i}:"))) {
            Some(i) => anyhow!("{}: {msg}", pairs[i].0),
            None => e,
        }
    })?;
    let obj3: Vec<Vector3<f64>> = obj.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let poses2: Vec<_> = fit.poses.iter().map(|p| fit.stereo.after(p)).collect();
    let device = |l: &FisheyeLens, views: &[Vec<Point2>], poses: &[crate::calib::model::Pose]| DeviceCalibration {
        width,
        height,
        fx: l.fx,
        fy: l.fy,
        cx: l.cx,
        cy: l.cy,
        distortion: l.k.to_vec(),
        rms_px: rms(l, &obj3, views, poses),
    };
    let captures: Vec<CapturePose> = pairs
        .iter()
        .enumerate()
        .map(|(i, (name, a, b))| {
            let (e1, e2) = (rms(&fit.lens[0], &obj3, std::slice::from_ref(a), std::slice::from_ref(&fit.poses[i])), rms(&fit.lens[1], &obj3, std::slice::from_ref(b), std::slice::from_ref(&poses2[i])));
            let (n1, n2) = (a.iter().filter(|q| observed(**q)).count() as f64, b.iter().filter(|q| observed(**q)).count() as f64);
            let p = &fit.poses[i];
            CapturePose {
                name: name.clone(),
                rvec: [p.rvec[0], p.rvec[1], p.rvec[2]],
                tvec: [p.t[0], p.t[1], p.t[2]],
                rms_px: ((e1 * e1 * n1 + e2 * e2 * n2) / (n1 + n2).max(1.0)).sqrt(),
                projector_corners: n2 as usize,
            }
        })
        .collect();
    // As for pinhole pairs (`calib::calibrate_planar`): a pair whose relative pose disagrees and
    // that the joint fit leaves above 1 px was not taken at one moment.
    let bad: Vec<(usize, f64)> = fit.disagreeing.iter().copied().filter(|&(i, _)| captures[i].rms_px > 1.0).collect();
    if !bad.is_empty() {
        let worst = captures.iter().map(|c| c.rms_px).fold(0.0, f64::max);
        bail!("reprojection RMS {:.3} px over all pairs, {worst:.3} px at the worst; {}", fit.rms_px, crate::calib::disagreement_clause(&|i| pairs[i].0.clone(), &bad, ["left camera", "right camera"]));
    }
    let r = fit.stereo.r();
    Ok(FisheyeStereoCalibration {
        model: "fisheye".into(),
        skew: [fit.lens[0].skew, fit.lens[1].skew],
        pair: ProcamCalibration {
            camera: device(&fit.lens[0], &v1, &fit.poses),
            projector: device(&fit.lens[1], &v2, &poses2),
            rotation: [[r[(0, 0)], r[(0, 1)], r[(0, 2)]], [r[(1, 0)], r[(1, 1)], r[(1, 2)]], [r[(2, 0)], r[(2, 1)], r[(2, 2)]]],
            translation: [fit.stereo.t[0], fit.stereo.t[1], fit.stereo.t[2]],
            rms_px: fit.rms_px,
            captures,
        },
    })
}
