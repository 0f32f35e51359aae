//! `[camera]`: the pinhole camera (eye, look_at, up, vfov_deg or camera_constant, resolution).

use crate::camera::Camera;
use crate::load::desc::SceneDesc;
use crate::load::error::Cx;
use crate::load::object::{finite3, v3};
use anyhow::Result;
use glam::Vec3;

/// The camera, positions converted to metres (`unit_m` metres per scene unit).
pub(crate) fn camera(cx: &Cx, desc: &SceneDesc, unit_m: f64) -> Result<Camera> {
    let to_m = |x: f64| (x * unit_m) as f32;
    let cspan = desc.camera.span();
    let c = desc.camera.get_ref();
    for (key, p) in [("eye", &c.eye), ("look_at", &c.look_at)] {
        if !finite3(p) {
            return Err(cx.err(&cspan, &format!("camera.{key}"), "must be finite"));
        }
    }
    let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
    let (w, h) = (c.width.unwrap_or(256), c.height.unwrap_or(256));
    let eye = Vec3::new(to_m(c.eye[0]), to_m(c.eye[1]), to_m(c.eye[2]));
    let at = Vec3::new(to_m(c.look_at[0]), to_m(c.look_at[1]), to_m(c.look_at[2]));
    let camera = match (c.vfov_deg, c.camera_constant) {
        (Some(_), Some(_)) => return Err(cx.err(&cspan, "camera", "give vfov_deg or camera_constant, not both")),
        (Some(f), None) => Camera::look_at(eye, at, v3(up), f as f32, w, h),
        (None, Some(d)) => Camera::with_constant(eye, at, v3(up), d as f32, w, h),
        (None, None) => return Err(cx.err(&cspan, "camera.vfov_deg", "missing (or give camera_constant)")),
    }
    .map_err(|e| cx.err(&cspan, "camera", e))?;
    Ok(camera)
}
