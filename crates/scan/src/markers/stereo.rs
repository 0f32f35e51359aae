//! Two calibrated views of the markers: matching along epipolar lines, the perspective correction
//! of the centres, and triangulation.
//!
//! The views are the two devices of a [`ProcamCalibration`]: view A is its `camera`, view B its
//! `projector` entry, which for markers is a second camera (the same file format; a two-camera
//! rig is written with the second camera as `projector`). X_B = R·X_A + T, lengths in the
//! calibration's unit; points are returned in view A's coordinates.
//!
//! - **Epipolar distance.** Ellipse centres are undistorted to normalised coordinates x_A, x_B
//!   (Newton on OpenCV's model, as [`crate::triangulate`]); with the essential matrix
//!   E = [T]×R (the fundamental matrix of the undistorted images is K_B⁻ᵀ E K_A⁻¹), the distance
//!   of x_B from the line E·x_A times view B's focal length, and of x_A from Eᵀ·x_B times view A's,
//!   averaged, is the match's epipolar distance in pixels.
//! - **Matching.** A pair is a candidate when both markers have the same polarity, the epipolar
//!   distance is at most `max_epipolar_px`, the two rays meet in front of both views, and the
//!   physical radii implied by the two image radii and the triangulated depths agree within a
//!   factor 1.5. Candidates are taken in order of increasing epipolar distance, each marker at most
//!   once (a greedy minimum-cost assignment); every match reports how many other candidates its
//!   two markers had (`alternatives`), and markers left over are reported unmatched.
//! - **Centres.** Under perspective the centre of a circle does not image to the centre of its
//!   ellipse. Each matched marker's edge points are undistorted and fitted with a conic in
//!   normalised coordinates; each conic allows two plane normals ([`super::ellipse::circle_normals`]),
//!   and the pair of normals (one per view, B's turned into A's frame by Rᵀ) that agree best is
//!   taken. The image of the centre is then the pole of the plane's vanishing line,
//!   Q⁻¹n ([`super::ellipse::circle_centre_image`]), distorted back to pixels. These corrected
//!   centres are triangulated by the mid-point method of [`crate::triangulate::Rig`].

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use anyhow::{bail, Result};
use nalgebra::{Matrix3, Vector3};

use super::ellipse::{circle_centre_image, circle_normals, fit_conic};
use super::Marker;
use crate::calib::ProcamCalibration;
use crate::triangulate::Rig;

/// The two views of a calibration.
#[derive(Clone, Debug)]
pub struct TwoViews {
    rig: Rig,
    r: Matrix3<f64>,
    t: Vector3<f64>,
    /// Image sizes of views A and B (pixels).
    pub sizes: [(u32, u32); 2],
}

/// Settings of [`match_markers`].
#[derive(Clone, Copy, Debug)]
pub struct MatchSettings {
    /// Largest epipolar distance of a match (pixels).
    pub max_epipolar_px: f64,
}

impl Default for MatchSettings {
    fn default() -> Self {
        MatchSettings { max_epipolar_px: 2.0 }
    }
}

/// One marker seen in both views.
#[derive(Clone, Debug, PartialEq)]
pub struct Match {
    /// Index of the marker in view A's list.
    pub a: usize,
    /// Index in view B's list.
    pub b: usize,
    /// Epipolar distance of the two ellipse centres (pixels).
    pub epipolar_px: f64,
    /// Other candidate pairs involving either marker.
    pub alternatives: usize,
    /// Image of the marker's centre in view A (pixels, perspective-corrected).
    pub centre_a: [f64; 2],
    /// Image of the marker's centre in view B (pixels, perspective-corrected).
    pub centre_b: [f64; 2],
    /// Whether the perspective correction was applied (else the ellipse centres are used).
    pub corrected: bool,
    /// Unit normal of the marker's plane towards the views (view A coordinates); zero when not
    /// corrected.
    pub normal: [f64; 3],
    /// Angle between the two views' estimates of the normal (radians).
    pub normal_disagreement_rad: f64,
    /// The triangulated centre (view A coordinates, calibration units).
    pub point: [f64; 3],
    /// Distance between the two rays at their closest approach (calibration units).
    pub ray_gap: f64,
}

/// Matches, and the markers of each view left unmatched.
#[derive(Clone, Debug, PartialEq)]
pub struct Stereo {
    /// The matches, in order of view A's marker index.
    pub matches: Vec<Match>,
    /// Indices of unmatched markers in views A and B.
    pub unmatched: [Vec<usize>; 2],
}

impl TwoViews {
    /// The views of `c`; an error naming the field for a bad calibration.
    pub fn new(c: &ProcamCalibration) -> Result<TwoViews> {
        let rig = Rig::new(c)?;
        let r = Matrix3::from_fn(|i, j| c.rotation[i][j]);
        let t = Vector3::from(c.translation);
        if !(t.norm() > 0.0) {
            bail!("translation: the two views share a centre (zero baseline); markers cannot be triangulated");
        }
        Ok(TwoViews { rig, r, t, sizes: [(c.camera.width, c.camera.height), (c.projector.width, c.projector.height)] })
    }

    /// An error unless an image of `size` fits view `view` (0 = A, 1 = B).
    pub fn check_size(&self, view: usize, size: (usize, usize), name: &str) -> Result<()> {
        let (w, h) = self.sizes[view];
        if (size.0 as u32, size.1 as u32) != (w, h) {
            let dev = ["camera", "projector"][view];
            bail!("{name}: the image is {}x{} pixels but the calibration's {dev} (view {}) is {w}x{h}", size.0, size.1, ["A", "B"][view]);
        }
        Ok(())
    }

    /// Normalised undistorted coordinates of pixel position `px` in view `view`.
    pub fn undistort(&self, view: usize, px: [f64; 2]) -> Option<[f64; 2]> {
        if view == 0 {
            self.rig.undistort_camera(px)
        } else {
            self.rig.undistort_projector(px)
        }
    }

    /// Pixel position of normalised coordinates `x` in view `view` (distortion applied).
    pub fn pixel(&self, view: usize, x: [f64; 2]) -> Option<[f64; 2]> {
        let p = [x[0], x[1], 1.0];
        if view == 0 {
            self.rig.project_camera(p)
        } else {
            self.rig.project_projector(p)
        }
    }

    fn focal(&self, view: usize) -> f64 {
        if view == 0 {
            self.rig.camera_focal_px()
        } else {
            self.rig.projector_focal_px()
        }
    }

    /// The essential matrix E = [T]×R (x_Bᵀ E x_A = 0 for normalised coordinates).
    pub fn essential(&self) -> Matrix3<f64> {
        self.t.cross_matrix() * self.r
    }

    /// Symmetric epipolar distance of pixel positions `a` (view A) and `b` (view B), in pixels;
    /// None where a position cannot be undistorted.
    pub fn epipolar_px(&self, a: [f64; 2], b: [f64; 2]) -> Option<f64> {
        let (xa, xb) = (self.undistort(0, a)?, self.undistort(1, b)?);
        let (xa, xb) = (Vector3::new(xa[0], xa[1], 1.0), Vector3::new(xb[0], xb[1], 1.0));
        let e = self.essential();
        let lb = e * xa;
        let la = e.transpose() * xb;
        let db = xb.dot(&lb).abs() / lb[0].hypot(lb[1]) * self.focal(1);
        let da = xa.dot(&la).abs() / la[0].hypot(la[1]) * self.focal(0);
        Some(0.5 * (da + db))
    }

    /// Triangulates pixel positions `a`, `b` (view A coordinates): the point and the ray gap.
    pub fn triangulate(&self, a: [f64; 2], b: [f64; 2]) -> Option<([f64; 3], f64)> {
        self.rig.triangulate(a, b).map(|t| (t.point, t.ray_gap))
    }

    /// View A coordinates of a point given in view B coordinates' rotation: Rᵀ·v.
    fn to_a(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.r.transpose() * v
    }

    /// Depth of a view-A point in view B.
    fn depth_b(&self, p: [f64; 3]) -> f64 {
        (self.r * Vector3::from(p) + self.t)[2]
    }

    /// The conic of a marker's edge points in normalised coordinates of view `view`.
    fn normalised_conic(&self, view: usize, m: &Marker) -> Option<Matrix3<f64>> {
        let pts: Vec<[f64; 2]> = m.edge_points.iter().filter_map(|p| self.undistort(view, *p)).collect();
        if pts.len() < m.edge_points.len() * 9 / 10 {
            return None;
        }
        fit_conic(&pts)
    }
}

/// Matches markers of view A with markers of view B and triangulates them (module documentation).
pub fn match_markers(v: &TwoViews, a: &[Marker], b: &[Marker], s: &MatchSettings) -> Stereo {
    let mut cands: Vec<(f64, usize, usize)> = Vec::new();
    for (i, ma) in a.iter().enumerate() {
        for (j, mb) in b.iter().enumerate() {
            if ma.dark != mb.dark {
                continue;
            }
            let Some(d) = v.epipolar_px([ma.x, ma.y], [mb.x, mb.y]) else { continue };
            if !(d <= s.max_epipolar_px) {
                continue;
            }
            let Some((p, _)) = v.triangulate([ma.x, ma.y], [mb.x, mb.y]) else { continue };
            let ra = ma.radius_px * p[2] / v.focal(0);
            let rb = mb.radius_px * v.depth_b(p) / v.focal(1);
            if !((ra / rb).ln().abs() < 1.5f64.ln()) {
                continue;
            }
            cands.push((d, i, j));
        }
    }
    cands.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let (mut used_a, mut used_b) = (vec![false; a.len()], vec![false; b.len()]);
    let mut matches = Vec::new();
    for &(d, i, j) in &cands {
        if used_a[i] || used_b[j] {
            continue;
        }
        used_a[i] = true;
        used_b[j] = true;
        let alternatives = cands.iter().filter(|c| (c.1 == i) != (c.2 == j)).count();
        if let Some(m) = finish_match(v, &a[i], &b[j], i, j, d, alternatives) {
            matches.push(m);
        }
    }
    matches.sort_by_key(|m| m.a);
    let unmatched_a = (0..a.len()).filter(|&i| !matches.iter().any(|m| m.a == i)).collect();
    let unmatched_b = (0..b.len()).filter(|&j| !matches.iter().any(|m| m.b == j)).collect();
    Stereo { matches, unmatched: [unmatched_a, unmatched_b] }
}

/// The corrected centres and the triangulated point of one pair.
fn finish_match(v: &TwoViews, ma: &Marker, mb: &Marker, i: usize, j: usize, d: f64, alternatives: usize) -> Option<Match> {
    let corrected = (|| {
        let (qa, qb) = (v.normalised_conic(0, ma)?, v.normalised_conic(1, mb)?);
        let (na, nb) = (circle_normals(&qa)?, circle_normals(&qb)?);
        let mut best: Option<(f64, Vector3<f64>, Vector3<f64>)> = None;
        for x in &na {
            for y in &nb {
                let yb = v.to_a(y);
                let c = x.dot(&yb);
                if best.as_ref().is_none_or(|b| c > b.0) {
                    best = Some((c, *x, *y));
                }
            }
        }
        let (cos, n_a, n_b) = best?;
        let ca = v.pixel(0, circle_centre_image(&qa, &n_a)?)?;
        let cb = v.pixel(1, circle_centre_image(&qb, &n_b)?)?;
        let n = (n_a + v.to_a(&n_b)).normalize();
        Some((ca, cb, [n[0], n[1], n[2]], cos.clamp(-1.0, 1.0).acos()))
    })();
    let (centre_a, centre_b, normal, dis, ok) = match corrected {
        Some((ca, cb, n, dis)) => (ca, cb, n, dis, true),
        None => ([ma.x, ma.y], [mb.x, mb.y], [0.0; 3], f64::NAN, false),
    };
    let (point, ray_gap) = v.triangulate(centre_a, centre_b)?;
    Some(Match { a: i, b: j, epipolar_px: d, alternatives, centre_a, centre_b, corrected: ok, normal, normal_disagreement_rad: dis, point, ray_gap })
}
