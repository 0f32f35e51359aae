//! Thin-lens depth of field for any camera model, as pbrt-v4's `PerspectiveCamera` and
//! Mitsuba 3's `thinlens`: the pinhole ray through a film position fixes the point it meets on
//! the plane of focus (perpendicular to the optical axis at the focus distance); the lens ray
//! starts at a uniform point of the aperture disc (Shirley–Chiu concentric map) in the lens plane
//! through the camera centre and aims at that point.
//!
//! A point at depth z (along the axis) then images as a disc: the rays of one film position sweep,
//! at depth z, a disc of radius A·|z − z_f|/z_f about the pinhole ray, so the point is seen from
//! film positions whose pinhole rays pass within A·|z − z_f|/z_f of it, a disc of radius
//! A·|z − z_f|/(z·z_f) in normalised image coordinates, i.e. f_px·A·|z − z_f|/(z·z_f) pixels
//! (f_px the focal length in pixels). This is the thin-lens circle of confusion
//! c = 2A·|z − z_f|/z · f/(z_f − f) with the image distance f·z_f/(z_f − f) written as the film's
//! scale f_px (pbrt-v4 §5.2.3).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::math::sampling::concentric_disk;
use anyhow::{bail, Result};
use glam::{Vec2, Vec3};

/// A thin lens: aperture radius and focus distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    /// Aperture radius (m).
    pub aperture_radius_m: f32,
    /// Distance of the plane of focus from the lens along the optical axis (m).
    pub focus_distance_m: f32,
}

impl ThinLens {
    /// Lens of aperture radius `aperture_radius_m` focused at `focus_distance_m` (both positive).
    pub fn new(aperture_radius_m: f32, focus_distance_m: f32) -> Result<ThinLens> {
        if !(aperture_radius_m > 0.0 && aperture_radius_m.is_finite()) {
            bail!("aperture radius must be positive, got {aperture_radius_m} m");
        }
        if !(focus_distance_m > 0.0 && focus_distance_m.is_finite()) {
            bail!("focus distance must be positive, got {focus_distance_m} m");
        }
        Ok(ThinLens { aperture_radius_m, focus_distance_m })
    }

    /// Lens from an f-number N and focal length f: aperture radius f/(2N).
    pub fn from_f_number(f_number: f32, focal_length_m: f32, focus_distance_m: f32) -> Result<ThinLens> {
        if !(f_number > 0.0 && f_number.is_finite()) {
            bail!("f-number must be positive, got {f_number}");
        }
        if !(focal_length_m > 0.0 && focal_length_m.is_finite()) {
            bail!("focal length must be positive, got {focal_length_m} m");
        }
        ThinLens::new(focal_length_m / (2.0 * f_number), focus_distance_m)
    }

    /// The lens ray for the pinhole ray from `eye` along unit `dir`, with the camera's unit
    /// optical axis `axis` and lens-plane axes `ex`, `ey`, lens sample `u` ∈ [0,1)².
    #[inline]
    pub fn refocus(&self, eye: Vec3, dir: Vec3, axis: Vec3, ex: Vec3, ey: Vec3, u: Vec2) -> (Vec3, Vec3) {
        let p = concentric_disk(u) * self.aperture_radius_m;
        let focus = eye + dir * (self.focus_distance_m / dir.dot(axis));
        let o = eye + ex * p.x + ey * p.y;
        (o, (focus - o).normalize())
    }
}
