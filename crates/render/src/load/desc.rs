//! The scene file's structure as serde reads it: every table and its keys (unknown keys are
//! refused). Each kind's file in [`crate::load`] checks and builds its part.

use serde::Deserialize;
use std::collections::BTreeMap;
use toml::Spanned;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneDesc {
    pub(crate) unit: Option<Spanned<String>>,
    pub(crate) camera: Spanned<CameraDesc>,
    pub(crate) integrator: Option<Spanned<IntegratorDesc>>,
    #[serde(default)]
    pub(crate) spectra: BTreeMap<String, Spanned<toml::Value>>,
    #[serde(default)]
    pub(crate) materials: BTreeMap<String, Spanned<MaterialDesc>>,
    #[serde(default)]
    pub(crate) objects: Vec<Spanned<ObjectDesc>>,
    #[serde(default)]
    pub(crate) lights: Vec<Spanned<LightDesc>>,
    /// Global medium (see `medium_desc`).
    pub(crate) medium: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraDesc {
    /// `pinhole` (default) or `opencv` (see `load::camera`).
    pub(crate) model: Option<String>,
    pub(crate) eye: Option<[f64; 3]>,
    pub(crate) look_at: Option<[f64; 3]>,
    pub(crate) up: Option<[f64; 3]>,
    pub(crate) vfov_deg: Option<f64>,
    /// Horizontal field of view (degrees) at the file's resolution: Mitsuba 3's `fov` with its
    /// default `fov_axis = "x"`.
    pub(crate) hfov_deg: Option<f64>,
    pub(crate) camera_constant: Option<f64>,
    /// Width of an orthographic camera's view (scene units).
    pub(crate) view_width: Option<f64>,
    pub(crate) width: Option<u32>,
    pub(crate) height: Option<u32>,
    // OpenCV intrinsics (pixels), distortion, extrinsics.
    pub(crate) fx: Option<f64>,
    pub(crate) fy: Option<f64>,
    pub(crate) cx: Option<f64>,
    pub(crate) cy: Option<f64>,
    pub(crate) k1: Option<f64>,
    pub(crate) k2: Option<f64>,
    pub(crate) k3: Option<f64>,
    pub(crate) k4: Option<f64>,
    pub(crate) k5: Option<f64>,
    pub(crate) k6: Option<f64>,
    pub(crate) p1: Option<f64>,
    pub(crate) p2: Option<f64>,
    pub(crate) s1: Option<f64>,
    pub(crate) s2: Option<f64>,
    pub(crate) s3: Option<f64>,
    pub(crate) s4: Option<f64>,
    pub(crate) tau_x_rad: Option<f64>,
    pub(crate) tau_y_rad: Option<f64>,
    pub(crate) dist: Option<Vec<f64>>,
    /// The fisheye model's skew α (K₀₁/K₀₀; `model = "fisheye"` only).
    pub(crate) skew: Option<f64>,
    #[serde(rename = "R")]
    pub(crate) r: Option<[[f64; 3]; 3]>,
    pub(crate) rvec: Option<[f64; 3]>,
    pub(crate) t: Option<[f64; 3]>,
    pub(crate) pose: Option<Vec<[f64; 4]>>,
    /// Calibration file (JSON or OpenCV FileStorage) and its node names.
    pub(crate) calibration: Option<String>,
    pub(crate) matrix_node: Option<String>,
    pub(crate) dist_node: Option<String>,
    // Thin lens.
    pub(crate) aperture_radius: Option<f64>,
    pub(crate) f_number: Option<f64>,
    pub(crate) focal_length_mm: Option<f64>,
    pub(crate) focus_distance: Option<f64>,
    /// Pixel reconstruction filter: a name or a table (see `load::camera::filter`).
    pub(crate) filter: Option<toml::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct IntegratorDesc {
    #[serde(rename = "type")]
    pub(crate) kind: Option<String>,
    pub(crate) max_depth: Option<u32>,
    pub(crate) rr_depth: Option<u32>,
    pub(crate) ao_distance: Option<f64>,
    pub(crate) refraction_guiding: Option<f64>,
    pub(crate) refraction_splits: Option<f64>,
    pub(crate) emitter_samples: Option<u32>,
    pub(crate) bsdf_samples: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MaterialDesc {
    #[serde(rename = "type")]
    pub(crate) kind: String,
    pub(crate) albedo: Option<Spanned<toml::Value>>,
    /// `diffuse_transmitter`: its diffuse transmittance.
    pub(crate) transmittance: Option<Spanned<toml::Value>>,
    // Dielectrics, conductors, plastic (see `bsdf_material`).
    pub(crate) ior: Option<Spanned<toml::Value>>,
    pub(crate) metal: Option<Spanned<String>>,
    pub(crate) eta: Option<Spanned<toml::Value>>,
    pub(crate) k: Option<Spanned<toml::Value>>,
    pub(crate) roughness: Option<Spanned<toml::Value>>,
    pub(crate) alpha: Option<Spanned<toml::Value>>,
    pub(crate) nonlinear: Option<bool>,
    pub(crate) masking: Option<Spanned<String>>,
    pub(crate) distribution: Option<Spanned<String>>,
    pub(crate) coupling: Option<Spanned<String>>,
    pub(crate) two_sided: Option<bool>,
    /// `{ texture = "file", … }`: tangent-space normals (see `SpectrumCx::resolve_shading_map`).
    pub(crate) normal_map: Option<Spanned<toml::Value>>,
    /// `{ texture = "file", height, … }`: a height field.
    pub(crate) bump_map: Option<Spanned<toml::Value>>,
    /// `blend`: the names of its two materials, and the weight of the second.
    pub(crate) materials: Option<Spanned<Vec<String>>>,
    pub(crate) weight: Option<Spanned<toml::Value>>,
    /// `mask`: the material it masks, and its opacity.
    pub(crate) material: Option<Spanned<String>>,
    pub(crate) opacity: Option<Spanned<toml::Value>>,
    /// Interior of a `translucent` material (see `subsurface::translucent_from_toml`).
    pub(crate) subsurface: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SphereDesc {
    pub(crate) center: [f64; 3],
    pub(crate) radius: f64,
}

/// `disk = { center, normal, radius }` (see `shape::tessellate`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct DiskDesc {
    pub(crate) center: Option<[f64; 3]>,
    pub(crate) normal: Option<[f64; 3]>,
    pub(crate) radius: Option<f64>,
}

/// `cylinder = { p0, p1, radius }`: an open tube (see `shape::tessellate`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CylinderDesc {
    pub(crate) p0: Option<[f64; 3]>,
    pub(crate) p1: Option<[f64; 3]>,
    pub(crate) radius: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TransformDesc {
    pub(crate) scale: Option<toml::Value>,
    pub(crate) rotate: Option<[f64; 4]>,
    pub(crate) translate: Option<[f64; 3]>,
    pub(crate) matrix: Option<[[f64; 4]; 4]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ObjectDesc {
    pub(crate) name: Option<String>,
    pub(crate) material: String,
    pub(crate) mesh: Option<String>,
    pub(crate) group: Option<String>,
    pub(crate) quad: Option<[[f64; 3]; 4]>,
    pub(crate) quads: Option<Vec<[[f64; 3]; 4]>>,
    pub(crate) sphere: Option<SphereDesc>,
    pub(crate) disk: Option<DiskDesc>,
    pub(crate) cylinder: Option<CylinderDesc>,
    pub(crate) transform: Option<TransformDesc>,
    /// Medium inside the object (its mesh must be closed).
    pub(crate) medium: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LightDesc {
    #[serde(rename = "type")]
    pub(crate) kind: String,
    pub(crate) object: Option<String>,
    pub(crate) position: Option<[f64; 3]>,
    pub(crate) direction: Option<[f64; 3]>,
    pub(crate) look_at: Option<[f64; 3]>,
    pub(crate) cone_deg: Option<f64>,
    pub(crate) falloff_start_deg: Option<f64>,
    pub(crate) radiance: Option<Spanned<toml::Value>>,
    pub(crate) intensity: Option<Spanned<toml::Value>>,
    pub(crate) irradiance: Option<Spanned<toml::Value>>,
    pub(crate) scale: Option<f64>,
    pub(crate) power_w: Option<f64>,
    pub(crate) two_sided: Option<bool>,
    /// Spot: the falloff's shape.
    pub(crate) falloff: Option<String>,
    /// Projector: image file, its response, and the camera model it projects through.
    pub(crate) image: Option<String>,
    pub(crate) response: Option<toml::Value>,
    pub(crate) profile: Option<String>,
    pub(crate) camera: Option<Spanned<CameraDesc>>,
    /// Image of an `envmap` light (relative to the scene file).
    pub(crate) file: Option<String>,
    /// Rotation of an `envmap` light (map frame → world).
    pub(crate) transform: Option<TransformDesc>,
}
