//! The tutorial's pinhole camera: eye point e, view point p, up direction u, vertical field of
//! view φ or camera constant d, resolution W×H.
//!
//! The image plane lies at distance d in front of the eye along the viewing direction
//! (p − e)/|p − e|; its height is 1, its width W/H, so tan(φ/2) = 1/(2d). The ray through pixel
//! (i, j) (i to the right, j downwards, (0,0) the top-left pixel) passes through the point
//! ((i + uₓ)/W − ½)·(W/H) along the camera's right axis and (½ − (j + u_y)/H) along its up axis,
//! with (uₓ, u_y) uniform in [0,1)² for antialiasing (a box pixel filter).
//!
//! In OpenCV's terms this is the undistorted camera with fx = fy = d·H pixels, principal point
//! cx = W/2 − ½, cy = H/2 − ½ (pixel centres at integer coordinates), and world-to-camera rows
//! (right, −up, forward).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::{Vec2, Vec3};

/// Pinhole camera geometry (the resolution lives in [`super::Camera`]).
#[derive(Clone, Debug)]
pub struct Pinhole {
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
}

impl Pinhole {
    /// Pinhole at `eye` (m) looking at `look_at` (m) with approximate up direction `up` and camera
    /// constant `d`. Errors when the directions are degenerate or `d` is not positive.
    pub fn new(eye: Vec3, look_at: Vec3, up: Vec3, d: f32) -> anyhow::Result<Pinhole> {
        if !(d > 0.0 && d.is_finite()) {
            anyhow::bail!("camera constant must be positive, got {d}");
        }
        let (forward, right, up) = look_at_frame(eye, look_at, up)?;
        Ok(Pinhole { eye, forward, right, up, d })
    }

    /// Camera constant for a vertical field of view `vfov_deg` degrees in (0, 180).
    pub fn constant_for_vfov(vfov_deg: f32) -> anyhow::Result<f32> {
        if !(vfov_deg > 0.0 && vfov_deg < 180.0) {
            anyhow::bail!("vertical field of view must be in (0, 180) degrees, got {vfov_deg}");
        }
        Ok(0.5 / (0.5 * vfov_deg.to_radians()).tan())
    }

    /// Vertical field of view in degrees.
    pub fn vfov_deg(&self) -> f32 {
        (2.0 * (0.5 / self.d).atan()).to_degrees()
    }

    /// Unnormalised direction through film position (`i` + uₓ, `j` + u_y) of a `width`×`height` image.
    #[inline]
    pub fn direction(&self, i: u32, j: u32, u: Vec2, width: u32, height: u32) -> Vec3 {
        let aspect = width as f32 / height as f32;
        let x = ((i as f32 + u.x) / width as f32 - 0.5) * aspect;
        let y = 0.5 - (j as f32 + u.y) / height as f32;
        self.right * x + self.up * y + self.forward * self.d
    }

    /// Film position (continuous, x right, y down, pixel (i, j) covering [i, i+1) × [j, j+1))
    /// where direction `dir` from the eye meets the image plane, or None when it points away.
    pub fn project_direction(&self, dir: Vec3, width: u32, height: u32) -> Option<Vec2> {
        let z = dir.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let s = self.d / z;
        let x = dir.dot(self.right) * s;
        let y = dir.dot(self.up) * s;
        let aspect = width as f32 / height as f32;
        Some(Vec2::new((x / aspect + 0.5) * width as f32, (0.5 - y) * height as f32))
    }
}

/// Orthonormal (forward, right = forward × up, up) frame of a camera at `eye` looking at `look_at`.
pub(crate) fn look_at_frame(eye: Vec3, look_at: Vec3, up: Vec3) -> anyhow::Result<(Vec3, Vec3, Vec3)> {
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
    Ok((forward, right, up))
}

#[cfg(test)]
mod tests {
    use super::super::Camera;
    use glam::{Vec2, Vec3};

    #[test]
    fn centre_and_edges() {
        let c = Camera::look_at(Vec3::new(0.0, 0.0, -1.0), Vec3::ZERO, Vec3::Y, 90.0, 100, 100).unwrap();
        assert!((c.pinhole().unwrap().d - 0.5).abs() < 1e-6);
        let r = c.generate_ray(50, 50, Vec2::ZERO);
        assert!((r.d - Vec3::Z).length() < 1e-6);
        // Top edge of the image at 45° above the axis for a 90° vertical field of view.
        let top = c.generate_ray(50, 0, Vec2::new(0.0, 0.0));
        assert!((top.d.y / top.d.z - 1.0).abs() < 1e-5);
        // Camera right is forward × up = +z × +y = −x.
        let right = c.generate_ray(99, 50, Vec2::new(1.0, 0.0));
        assert!(right.d.x < 0.0 && (right.d.x / right.d.z + 1.0).abs() < 1e-5);
        let p = c.project(c.eye() + top.d).unwrap();
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
