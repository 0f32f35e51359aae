//! Orthographic camera (pbrt-v4's and Mitsuba 3's `orthographic`): parallel rays along the
//! viewing direction, one per point of a rectangle of the view plane through the eye.
//!
//! The rectangle is centred on the eye, `view_width_m` wide along the camera's right axis and
//! `view_width_m`·H/W high along its up axis (square pixels). The ray of film position
//! (i + uₓ, j + u_y) (i to the right, j downwards) starts at
//! eye + ((i + uₓ)/W − ½)·w·right + (½ − (j + u_y)/H)·h·up and runs along the viewing direction;
//! only what lies in front of that plane is seen. A pixel measures radiance, as with the pinhole.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::pinhole::look_at_frame;
use glam::{Vec2, Vec3};

/// Orthographic camera geometry (the resolution lives in [`super::Camera`]).
#[derive(Clone, Debug)]
pub struct Orthographic {
    /// Centre of the view rectangle (m).
    pub eye: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit right axis of the image.
    pub right: Vec3,
    /// Unit up axis of the image.
    pub up: Vec3,
    /// Width of the view rectangle (m).
    pub view_width_m: f32,
}

impl Orthographic {
    /// Orthographic camera at `eye` (m) looking towards `look_at` (m) with approximate up
    /// direction `up`, its view `view_width_m` metres wide. Errors when the directions are
    /// degenerate or the width is not positive.
    pub fn new(eye: Vec3, look_at: Vec3, up: Vec3, view_width_m: f32) -> anyhow::Result<Orthographic> {
        if !(view_width_m > 0.0 && view_width_m.is_finite()) {
            anyhow::bail!("view width must be positive, got {view_width_m} m");
        }
        let (forward, right, up) = look_at_frame(eye, look_at, up)?;
        Ok(Orthographic { eye, forward, right, up, view_width_m })
    }

    /// Origin of the ray through film position (`i` + uₓ, `j` + u_y) of a `width`×`height` image.
    #[inline]
    pub fn origin(&self, i: u32, j: u32, u: Vec2, width: u32, height: u32) -> Vec3 {
        let w = self.view_width_m;
        let h = w * height as f32 / width as f32;
        let x = ((i as f32 + u.x) / width as f32 - 0.5) * w;
        let y = (0.5 - (j as f32 + u.y) / height as f32) * h;
        self.eye + self.right * x + self.up * y
    }

    /// Film position of world point `p` (m), or None when it lies behind the view plane.
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<Vec2> {
        let q = p - self.eye;
        if !(q.dot(self.forward) > 0.0) {
            return None;
        }
        let w = self.view_width_m;
        let h = w * height as f32 / width as f32;
        Some(Vec2::new((q.dot(self.right) / w + 0.5) * width as f32, (0.5 - q.dot(self.up) / h) * height as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays are parallel, start on the view rectangle, and project back to their film positions.
    #[test]
    fn rays_start_on_the_view_rectangle_and_project_back() {
        let c = Orthographic::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(1.0, 2.0, -5.0), Vec3::Y, 4.0).unwrap();
        let (w, h) = (64, 32);
        // The corners of the film are the corners of a 4 × 2 rectangle around the eye.
        let tl = c.origin(0, 0, Vec2::ZERO, w, h);
        let br = c.origin(w - 1, h - 1, Vec2::ONE, w, h);
        assert!((tl - Vec3::new(-1.0, 3.0, 3.0)).length() < 1e-5, "{tl}");
        assert!((br - Vec3::new(3.0, 1.0, 3.0)).length() < 1e-5, "{br}");
        for (i, j, u) in [(0, 0, Vec2::new(0.5, 0.5)), (17, 9, Vec2::new(0.25, 0.75)), (63, 31, Vec2::new(0.9, 0.1))] {
            let p = c.origin(i, j, u, w, h) + c.forward * 7.5;
            let f = c.project(p, w, h).unwrap();
            assert!((f - Vec2::new(i as f32 + u.x, j as f32 + u.y)).length() < 1e-4, "{f}");
        }
        assert!(c.project(c.eye - c.forward, w, h).is_none());
        assert!(Orthographic::new(Vec3::ZERO, Vec3::Z, Vec3::Y, 0.0).is_err());
    }
}
