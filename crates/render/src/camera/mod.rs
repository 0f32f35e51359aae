//! Cameras: a model that maps film positions to rays and world points to film positions, an
//! optional thin lens, and the resolution.
//!
//! - [`pinhole`]: the tutorial's pinhole (eye, look-at, up, field of view or camera constant).
//! - [`opencv`]: OpenCV's calibrated model (intrinsics, radial/tangential distortion, R, t).
//! - [`fisheye`]: OpenCV's fisheye model (`cv::fisheye`: θ_d = θ(1 + k1θ² + … + k4θ⁸), skew, R, t).
//! - [`orthographic`]: parallel rays from a rectangle of the view plane (pbrt-v4's and Mitsuba 3's).
//! - [`thin_lens`]: depth of field for either model.
//! - [`filter`]: the pixel reconstruction filter, importance-sampled into the film position.
//!
//! Film coordinates: pixel (i, j) (i right, j down, (0, 0) top left) sampled at offset
//! u ∈ [0,1)² is the continuous position (i + uₓ, j + u_y), so pixel centres sit at half
//! integers; OpenCV's pixel coordinates are these minus ½ (see [`opencv`]).

pub mod filter;
pub mod fisheye;
pub mod opencv;
pub mod orthographic;
pub mod pinhole;
pub mod thin_lens;

pub use filter::{GaussianFilter, PixelFilter};
pub use fisheye::{Fisheye, FisheyeLens};
pub use opencv::{Distortion, Extrinsics, Intrinsics, OpenCv};
pub use orthographic::Orthographic;
pub use pinhole::Pinhole;
pub use thin_lens::ThinLens;

use crate::math::geometry::Ray;
use glam::{Vec2, Vec3};

/// A camera model.
#[derive(Clone, Debug)]
pub enum CameraModel {
    /// Ideal pinhole.
    Pinhole(Pinhole),
    /// OpenCV intrinsics, distortion and extrinsics.
    OpenCv(OpenCv),
    /// OpenCV's fisheye model and extrinsics.
    Fisheye(Fisheye),
    /// Parallel projection.
    Orthographic(Orthographic),
}

/// A camera: model, optional thin lens, resolution.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Projection model.
    pub model: CameraModel,
    /// Thin lens (None: every ray starts at the centre of projection).
    pub lens: Option<ThinLens>,
    /// Resolution in pixels.
    pub width: u32,
    /// Resolution in pixels.
    pub height: u32,
    /// Pixel reconstruction filter (box by default), applied by [`Camera::sample_ray`].
    pub filter: PixelFilter,
}

impl Camera {
    /// Pinhole camera at `eye` looking at `look_at` with approximate up direction `up` and vertical
    /// field of view `vfov_deg` degrees. Errors when the directions are degenerate or the angle is outside (0, 180).
    pub fn look_at(eye: Vec3, look_at: Vec3, up: Vec3, vfov_deg: f32, width: u32, height: u32) -> anyhow::Result<Camera> {
        let d = Pinhole::constant_for_vfov(vfov_deg)?;
        Camera::with_constant(eye, look_at, up, d, width, height)
    }

    /// Pinhole camera with camera constant `d` (distance of the unit-height image plane).
    pub fn with_constant(eye: Vec3, look_at: Vec3, up: Vec3, d: f32, width: u32, height: u32) -> anyhow::Result<Camera> {
        let p = Pinhole::new(eye, look_at, up, d)?;
        check_resolution(width, height)?;
        Ok(Camera { model: CameraModel::Pinhole(p), lens: None, width, height, filter: PixelFilter::Box })
    }

    /// OpenCV camera built for this resolution (see [`OpenCv::new`]).
    pub fn opencv(cam: OpenCv, width: u32, height: u32) -> anyhow::Result<Camera> {
        check_resolution(width, height)?;
        Ok(Camera { model: CameraModel::OpenCv(cam), lens: None, width, height, filter: PixelFilter::Box })
    }

    /// Fisheye camera built for this resolution (see [`Fisheye::new`]).
    pub fn fisheye(cam: Fisheye, width: u32, height: u32) -> anyhow::Result<Camera> {
        check_resolution(width, height)?;
        Ok(Camera { model: CameraModel::Fisheye(cam), lens: None, width, height, filter: PixelFilter::Box })
    }

    /// Orthographic camera (see [`Orthographic::new`]).
    pub fn orthographic(cam: Orthographic, width: u32, height: u32) -> anyhow::Result<Camera> {
        check_resolution(width, height)?;
        Ok(Camera { model: CameraModel::Orthographic(cam), lens: None, width, height, filter: PixelFilter::Box })
    }

    /// The pinhole model, if this is one.
    pub fn pinhole(&self) -> Option<&Pinhole> {
        match &self.model {
            CameraModel::Pinhole(p) => Some(p),
            CameraModel::OpenCv(_) | CameraModel::Fisheye(_) | CameraModel::Orthographic(_) => None,
        }
    }

    /// Centre of projection (m); for the orthographic camera, the centre of its view rectangle.
    pub fn eye(&self) -> Vec3 {
        match &self.model {
            CameraModel::Pinhole(p) => p.eye,
            CameraModel::Orthographic(p) => p.eye,
            CameraModel::OpenCv(c) => v3(c.centre_m()),
            CameraModel::Fisheye(c) => v3(c.centre_m()),
        }
    }

    /// Unit optical axis and the lens-plane axes (image right, and image up for the pinhole or
    /// image down for OpenCV's models).
    pub fn axes(&self) -> (Vec3, Vec3, Vec3) {
        match &self.model {
            CameraModel::Pinhole(p) => (p.forward, p.right, p.up),
            CameraModel::Orthographic(p) => (p.forward, p.right, p.up),
            CameraModel::OpenCv(c) => {
                let r = &c.extrinsics.r;
                (v3(r[2]), v3(r[0]), v3(r[1]))
            }
            CameraModel::Fisheye(c) => {
                let r = &c.extrinsics.r;
                (v3(r[2]), v3(r[0]), v3(r[1]))
            }
        }
    }

    /// Unit optical axis.
    pub fn forward(&self) -> Vec3 {
        self.axes().0
    }

    /// Vertical field of view in degrees (of the undistorted model, about the principal point for
    /// OpenCV; for the fisheye, twice the angle off the axis at half the image height; 0 for
    /// the orthographic camera).
    pub fn vfov_deg(&self) -> f32 {
        match &self.model {
            CameraModel::Pinhole(p) => p.vfov_deg(),
            CameraModel::Orthographic(_) => 0.0,
            CameraModel::OpenCv(c) => (2.0 * (0.5 * self.height as f64 / c.intrinsics.fy).atan()).to_degrees() as f32,
            CameraModel::Fisheye(c) => {
                let l = &c.lens;
                let td = 0.5 * self.height as f64 / l.fy;
                (2.0 * l.solve_theta(td, l.theta_max()).unwrap_or(std::f64::consts::FRAC_PI_2)).to_degrees() as f32
            }
        }
    }

    /// Focal length in pixels along y (d·H for the pinhole, fy for OpenCV's models, infinite for
    /// the orthographic camera).
    pub fn focal_length_px(&self) -> f64 {
        match &self.model {
            CameraModel::Pinhole(p) => p.d as f64 * self.height as f64,
            CameraModel::Orthographic(_) => f64::INFINITY,
            CameraModel::OpenCv(c) => c.intrinsics.fy,
            CameraModel::Fisheye(c) => c.lens.fy,
        }
    }

    /// Change the resolution, keeping the view (the pinhole's vertical field of view; for OpenCV
    /// the intrinsics scale with the film, see [`OpenCv::rescaled`]; the orthographic camera's
    /// view width).
    pub fn set_resolution(&mut self, width: u32, height: u32) {
        let (width, height) = (width.max(1), height.max(1));
        match &mut self.model {
            CameraModel::Pinhole(_) | CameraModel::Orthographic(_) => {}
            CameraModel::OpenCv(c) => {
                *c = c.rescaled(width as f64 / self.width as f64, height as f64 / self.height as f64);
            }
            CameraModel::Fisheye(c) => {
                *c = c.rescaled(width as f64 / self.width as f64, height as f64 / self.height as f64);
            }
        }
        self.width = width;
        self.height = height;
    }

    /// Primary ray through pixel (`i`, `j`) at offset `u` ∈ [0,1)² from the centre of projection
    /// (the centre of the lens, if any); direction is unit.
    #[inline]
    pub fn generate_ray(&self, i: u32, j: u32, u: Vec2) -> Ray {
        match &self.model {
            CameraModel::Pinhole(p) => {
                let d = p.direction(i, j, u, self.width, self.height).normalize();
                Ray { o: p.eye, d, t_min: 0.0, t_max: f32::INFINITY }
            }
            CameraModel::Orthographic(p) => Ray { o: p.origin(i, j, u, self.width, self.height), d: p.forward, t_min: 0.0, t_max: f32::INFINITY },
            CameraModel::OpenCv(c) => {
                let (o, d) = c.ray_pixel(i as f64 + u.x as f64 - 0.5, j as f64 + u.y as f64 - 0.5);
                Ray { o: v3(o), d: v3(d), t_min: 0.0, t_max: f32::INFINITY }
            }
            CameraModel::Fisheye(c) => {
                let (o, d) = c.ray_pixel(i as f64 + u.x as f64 - 0.5, j as f64 + u.y as f64 - 0.5);
                Ray { o: v3(o), d: v3(d), t_min: 0.0, t_max: f32::INFINITY }
            }
        }
    }

    /// A camera sample's ray for pixel (`i`, `j`): `u` uniform in [0,1)² is placed by the pixel
    /// filter (for the box, the offset itself; [`filter`]); with a lens, `lens_u` is called once
    /// for the aperture sample (uniform in [0,1)²), without one it is not called.
    #[inline]
    pub fn sample_ray(&self, i: u32, j: u32, u: Vec2, lens_u: impl FnOnce() -> Vec2) -> Ray {
        let ray = self.generate_ray(i, j, self.filter.film_offset(u));
        match &self.lens {
            None => ray,
            Some(lens) => {
                let (axis, ex, ey) = self.axes();
                let (o, d) = lens.refocus(ray.o, ray.d, axis, ex, ey, lens_u());
                Ray { o, d, ..ray }
            }
        }
    }

    /// Film position (continuous, pixel (i, j) covering [i, i+1) × [j, j+1)) of world point
    /// `p` (m) through the centre of projection (along the viewing direction for the
    /// orthographic camera), or None when it is behind the camera.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        match &self.model {
            CameraModel::Pinhole(c) => c.project_direction(p - c.eye, self.width, self.height),
            CameraModel::Orthographic(c) => c.project(p, self.width, self.height),
            CameraModel::OpenCv(c) => {
                let q = c.project_pixel([p.x as f64, p.y as f64, p.z as f64])?;
                Some(Vec2::new((q[0] + 0.5) as f32, (q[1] + 0.5) as f32))
            }
            CameraModel::Fisheye(c) => {
                let q = c.project_pixel([p.x as f64, p.y as f64, p.z as f64])?;
                Some(Vec2::new((q[0] + 0.5) as f32, (q[1] + 0.5) as f32))
            }
        }
    }
}

fn check_resolution(width: u32, height: u32) -> anyhow::Result<()> {
    if width == 0 || height == 0 {
        anyhow::bail!("resolution must be at least 1×1, got {width}×{height}");
    }
    Ok(())
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}
