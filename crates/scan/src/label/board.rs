//! The calibration board's plane as a cue for labelling a chessboard capture, and the rigid move
//! that carries what lies on it from one capture's board pose to another's.
//!
//! `lucent scan calibrate` stores each capture's board pose (`captures[i].rvec`, `tvec`: board →
//! camera, OpenCV's convention). The board's plane is z = 0 in board coordinates, so a camera-
//! frame point p lies at the signed distance n · (p − t) from it, n = R e_z the board's normal
//! (pointing away from the camera for a board facing it). A print taped to a plate (as in the
//! shared captures) moves with the plate from capture to capture while the wall behind stays:
//! the surfaces within a small distance of the plane are the board's, and the camera-frame map
//! X ↦ T_j T_i⁻¹ X (T = [R | t]) carries them from capture i's pose to capture j's.

use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3};

use super::Labelled;
use crate::calib::CapturePose;

/// A board pose: board → camera, X_c = R X_b + t (the calibration's length unit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardPose {
    /// Rotation board → camera.
    pub r: Matrix3<f64>,
    /// Translation board → camera (the board origin in the camera frame).
    pub t: Vector3<f64>,
}

impl BoardPose {
    /// From a calibration's capture pose (Rodrigues vector in radians, translation).
    pub fn from_capture(c: &CapturePose) -> BoardPose {
        BoardPose { r: *Rotation3::new(Vector3::from(c.rvec)).matrix(), t: Vector3::from(c.tvec) }
    }

    /// Signed distance of camera-frame point `p` from the board's plane (positive behind it,
    /// along the board's z axis).
    pub fn plane_distance(&self, p: [f64; 3]) -> f64 {
        let n = self.r.column(2);
        n.dot(&(Vector3::from(p) - self.t))
    }

    /// The 4 × 4 camera-frame transform (column vectors, translation in the last column) that
    /// moves a point fixed to the board from this pose to `to`: T_to T_self⁻¹.
    pub fn move_to(&self, to: &BoardPose) -> Matrix4<f64> {
        let r = to.r * self.r.transpose();
        let t = to.t - r * self.t;
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&t);
        m
    }
}

/// Unlabels (label −1) the micropolygons whose centroid lies farther than `max_distance` (the
/// calibration's length unit) from the board's plane, their vertices taken from `positions`
/// (e.g. a smoothed copy of `l.mesh.positions`) or from the mesh; returns how many labelled ones
/// it took.
pub fn keep_near_plane(l: &mut Labelled, positions: Option<&[[f64; 3]]>, pose: &BoardPose, max_distance: f64) -> usize {
    let mut removed = 0;
    let pos = positions.unwrap_or(&l.mesh.positions);
    for (t, lab) in l.mesh.triangles.iter().zip(l.face_label.iter_mut()) {
        if *lab < 0 {
            continue;
        }
        let mut c = [0.0; 3];
        for &v in t {
            let p = pos[v as usize];
            for k in 0..3 {
                c[k] += p[k] / 3.0;
            }
        }
        if pose.plane_distance(c).abs() > max_distance {
            *lab = -1;
            removed += 1;
        }
    }
    removed
}
