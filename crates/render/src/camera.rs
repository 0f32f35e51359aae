//! The tutorial's pinhole camera: eye point e, view point p, up direction u, vertical field of
//! view φ or camera constant d, resolution W×H.
//!
//! The image plane lies at distance d in front of the eye along the viewing direction
//! (p − e)/|p − e|; its height is 1, its width W/H, so tan(φ/2) = 1/(2d). The ray through pixel
//! (i, j) (i to the right, j downwards, (0,0) the top-left pixel) passes through the point
//! ((i + uₓ)/W − ½)·(W/H) along the camera's right axis and (½ − (j + u_y)/H) along its up axis,
//! with (uₓ, u_y) uniform in [0,1)² for antialiasing (a box pixel filter).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::math::geometry::Ray;
use glam::{Vec2, Vec3};

/// Pinhole camera.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Eye point (m).
    pub eye: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit right axis of the image (forward × up).
    pub right: Vec3,
    /// Unit up axis of the image.
    pub up: Vec3,
    /// Camera constant: distance of the unit-height image plane from the eye.
    pub d: f32,
    /// Resolution in pixels.
    pub width: u32,
    /// Resolution in pixels.
    pub height: u32,
}

impl Camera {
    /// Camera at `eye` looking at `look_at` with approximate up direction `up` and vertical field of
    /// view `vfov_deg` degrees. Errors when the directions are degenerate or the angle is outside (0, 180).
    pub fn look_at(eye: Vec3, look_at: Vec3, up: Vec3, vfov_deg: f32, width: u32, height: u32) -> anyhow::Result<Camera> {
        if !(vfov_deg > 0.0 && vfov_deg < 180.0) {
            anyhow::bail!("vertical field of view must be in (0, 180) degrees, got {vfov_deg}");
        }
        let d = 0.5 / (0.5 * vfov_deg.to_radians()).tan();
        Camera::with_constant(eye, look_at, up, d, width, height)
    }

    /// Camera with camera constant `d` (distance of the unit-height image plane).
    pub fn with_constant(eye: Vec3, look_at: Vec3, up: Vec3, d: f32, width: u32, height: u32) -> anyhow::Result<Camera> {
        if !(d > 0.0 && d.is_finite()) {
            anyhow::bail!("camera constant must be positive, got {d}");
        }
        if width == 0 || height == 0 {
            anyhow::bail!("resolution must be at least 1×1, got {width}×{height}");
        }
        let f = look_at - eye;
        if !(f.length() > 0.0) || !f.is_finite() || !eye.is_finite() {
            anyhow::bail!("eye and look-at point must be distinct finite points");
        }
        let forward = f.normalize();
        let r = forward.cross(up);
        if !(r.length() > 1e-6 * up.length()) || !r.is_finite() {
            anyhow::bail!("up direction must not be parallel to the viewing direction");
        }
        let right = r.normalize();
        let up = right.cross(forward);
        Ok(Camera { eye, forward, right, up, d, width, height })
    }

    /// Vertical field of view in degrees.
    pub fn vfov_deg(&self) -> f32 {
        (2.0 * (0.5 / self.d).atan()).to_degrees()
    }

    /// Change the resolution, keeping the vertical field of view.
    pub fn set_resolution(&mut self, width: u32, height: u32) {
        self.width = width.max(1);
        self.height = height.max(1);
    }

    /// Primary ray through pixel (`i`, `j`) at offset `u` ∈ [0,1)² inside it; direction is unit.
    #[inline]
    pub fn generate_ray(&self, i: u32, j: u32, u: Vec2) -> Ray {
        let aspect = self.width as f32 / self.height as f32;
        let x = ((i as f32 + u.x) / self.width as f32 - 0.5) * aspect;
        let y = 0.5 - (j as f32 + u.y) / self.height as f32;
        let d = (self.right * x + self.up * y + self.forward * self.d).normalize();
        Ray { o: self.eye, d, t_min: 0.0, t_max: f32::INFINITY }
    }

    /// Pixel coordinates (continuous, x right, y down) where direction `dir` from the eye meets the
    /// image plane, or None when it points away from it.
    pub fn project(&self, dir: Vec3) -> Option<Vec2> {
        let z = dir.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let s = self.d / z;
        let x = dir.dot(self.right) * s;
        let y = dir.dot(self.up) * s;
        let aspect = self.width as f32 / self.height as f32;
        Some(Vec2::new((x / aspect + 0.5) * self.width as f32, (0.5 - y) * self.height as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_and_edges() {
        let c = Camera::look_at(Vec3::new(0.0, 0.0, -1.0), Vec3::ZERO, Vec3::Y, 90.0, 100, 100).unwrap();
        assert!((c.d - 0.5).abs() < 1e-6);
        let r = c.generate_ray(50, 50, Vec2::ZERO);
        assert!((r.d - Vec3::Z).length() < 1e-6);
        // Top edge of the image at 45° above the axis for a 90° vertical field of view.
        let top = c.generate_ray(50, 0, Vec2::new(0.0, 0.0));
        assert!((top.d.y / top.d.z - 1.0).abs() < 1e-5);
        // Camera right is forward × up = +z × +y = −x.
        let right = c.generate_ray(99, 50, Vec2::new(1.0, 0.0));
        assert!(right.d.x < 0.0 && (right.d.x / right.d.z + 1.0).abs() < 1e-5);
        let p = c.project(top.d).unwrap();
        assert!((p.y).abs() < 1e-3 && (p.x - 50.0).abs() < 1e-3);
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        assert!(Camera::look_at(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 40.0, 8, 8).is_err());
        assert!(Camera::look_at(Vec3::ZERO, Vec3::Y, Vec3::Y, 40.0, 8, 8).is_err());
        assert!(Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 0.0, 8, 8).is_err());
        assert!(Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 40.0, 0, 8).is_err());
    }
}
