//! A projector: a point light whose intensity is an image seen through a camera model run
//! backwards (pbrt-v4's `ProjectionLight`; Mitsuba 3's `projector` in the irradiance profile,
//! below). A surface point p receives
//! from the projector at centre c the radiance of a delta light with intensity
//! I(p) = v(pixel of p)·I₀(λ) in the direction c → p, where the pixel is the film pixel that
//! contains the projection of p through the projector's camera (pinhole or OpenCV, the same
//! pixel convention as a rendering camera) and v its linear value; nothing outside the image. So
//! a camera with the projector's model and pose sees each projector pixel on its own pixel,
//! exactly, and a Lambertian surface of albedo ρ at distance r and incidence cosine cos θ
//! returns ρ/π · v · I₀ · cos θ / r².
//!
//! What the image means (`profile`):
//! * [`Profile::Intensity`] (the default; pbrt-v4's `ProjectionLight`): v·I₀ is the radiant
//!   intensity towards p, as above. A constant image lights a plane perpendicular to the optical
//!   axis at distance r with irradiance v·I₀·cos³θ_p / r², θ_p the angle between the axis and the
//!   direction to the point.
//! * [`Profile::Irradiance`] (Mitsuba 3's `projector`): v·I₀ is the irradiance on the virtual
//!   image plane at unit distance, and the intensity towards p is π·v·I₀ / cos³θ_p (Mitsuba 3's
//!   `src/emitters/projector.cpp` returns π·E / (z²·cos θ_p) with z = r cos θ_p, π included). A
//!   constant image then lights that perpendicular plane uniformly, with π·v·I₀ / r², as a real
//!   projector whose pixels all pass the same power does.
//!
//! Image values: an 8-bit image is decoded with its response (linear: v = code/255; sRGB: the
//! sRGB curve; gamma γ: (code/255)^γ); a float image (EXR, PFM) is linear. Colour images project
//! their luminance (Rec. 709 Y of the linear RGB) times the white spectrum I₀.

use crate::camera::Camera;
use glam::Vec3;
use optics::spectrum::DenseSpectrum;

/// What a projector's image values give: the radiant intensity, or the irradiance on the image
/// plane (module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Profile {
    /// v·I₀ is the radiant intensity (pbrt-v4).
    #[default]
    Intensity,
    /// v·I₀ is the irradiance on the image plane at unit distance; intensity π·v·I₀/cos³θ_p
    /// (Mitsuba 3).
    Irradiance,
}

impl Profile {
    /// The name the scene format uses.
    pub fn name(self) -> &'static str {
        match self {
            Profile::Intensity => "intensity",
            Profile::Irradiance => "irradiance",
        }
    }

    /// The profile named `name`.
    pub fn from_name(name: &str) -> Option<Profile> {
        [Profile::Intensity, Profile::Irradiance].into_iter().find(|p| p.name() == name)
    }

    /// Radiant intensity per unit v·I₀ in a direction whose cosine with the optical axis is
    /// `cos_axis` (0 behind the projector).
    #[inline]
    pub fn factor(self, cos_axis: f32) -> f32 {
        match self {
            Profile::Intensity => 1.0,
            Profile::Irradiance if cos_axis > 0.0 => std::f32::consts::PI / (cos_axis * cos_axis * cos_axis),
            Profile::Irradiance => 0.0,
        }
    }
}

/// A projector light.
#[derive(Clone, Debug)]
pub struct Projector {
    /// Projection model, pose and resolution (the image's).
    pub camera: Camera,
    /// Linear pixel values, row-major, top row first (`camera.width × camera.height`).
    pub image: Vec<f32>,
    /// Spectral intensity of a pixel of value 1 (W·sr⁻¹·nm⁻¹).
    pub intensity: DenseSpectrum,
    /// What the image values give (intensity or image-plane irradiance).
    pub profile: Profile,
    /// Solid angle the image covers weighted by its values and the profile's factor (sr):
    /// times ∫I₀ dλ, the projector's power (W).
    pub weighted_solid_angle_sr: f32,
}

impl Projector {
    /// Projector with `image` (linear values, `camera.width × camera.height`) and white
    /// `intensity`, in the [`Profile::Intensity`] profile.
    pub fn new(camera: Camera, image: Vec<f32>, intensity: DenseSpectrum) -> anyhow::Result<Projector> {
        let n = camera.width as usize * camera.height as usize;
        if image.len() != n {
            anyhow::bail!("image has {} pixels, the projector's camera {}×{}", image.len(), camera.width, camera.height);
        }
        if let Some(v) = image.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            anyhow::bail!("image value {v} is negative or not finite");
        }
        let weighted_solid_angle_sr = weighted_solid_angle(&camera, &image, Profile::Intensity);
        Ok(Projector { camera, image, intensity, profile: Profile::Intensity, weighted_solid_angle_sr })
    }

    /// The same projector with its image read in `profile`.
    pub fn with_profile(self, profile: Profile) -> Projector {
        let weighted_solid_angle_sr = weighted_solid_angle(&self.camera, &self.image, profile);
        Projector { profile, weighted_solid_angle_sr, ..self }
    }

    /// Centre of projection (m).
    pub fn position(&self) -> Vec3 {
        self.camera.eye()
    }

    /// Radiant intensity towards world point `p` (m) per unit I₀: the image value there times
    /// the profile's factor; 0 outside the image or behind the projector.
    #[inline]
    pub fn weight_at(&self, p: Vec3) -> f32 {
        let v = self.value_at(p);
        if self.profile == Profile::Intensity || !(v > 0.0) {
            return v;
        }
        let d = p - self.position();
        v * self.profile.factor(self.camera.forward().dot(d) / d.length())
    }

    /// Linear image value for world point `p` (m): 0 outside the image or behind the projector.
    #[inline]
    pub fn value_at(&self, p: Vec3) -> f32 {
        let Some(f) = self.camera.project(p) else { return 0.0 };
        if !(f.x >= 0.0 && f.y >= 0.0) {
            return 0.0;
        }
        let (i, j) = (f.x as u32, f.y as u32);
        if i >= self.camera.width || j >= self.camera.height {
            return 0.0;
        }
        self.image[j as usize * self.camera.width as usize + i as usize]
    }
}

/// Σ over 16×16-pixel blocks of the block's mean value × its measure under the profile: for
/// [`Profile::Intensity`] its solid angle, the spherical quadrilateral of the rays through its
/// corners (two spherical triangles, Van Oosterom & Strackee 1983); for [`Profile::Irradiance`]
/// π × the area its corner rays cut from the plane at unit distance along the axis (∫π/cos³θ dω
/// over the block). Both are exact for a pinhole, whose block edges are great circles.
fn weighted_solid_angle(camera: &Camera, image: &[f32], profile: Profile) -> f32 {
    let (w, h) = (camera.width, camera.height);
    let b = 16u32;
    let forward = camera.forward().as_dvec3();
    let dir = |x: u32, y: u32| {
        let (i, j) = (x.min(w - 1), y.min(h - 1));
        let u = glam::Vec2::new((x - i) as f32, (y - j) as f32);
        camera.generate_ray(i, j, u).d.as_dvec3().normalize()
    };
    let triangle = |a: glam::DVec3, b: glam::DVec3, c: glam::DVec3| {
        let num = a.dot(b.cross(c)).abs();
        let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
        2.0 * num.atan2(den)
    };
    let mut total = 0.0f64;
    for by in (0..h).step_by(b as usize) {
        for bx in (0..w).step_by(b as usize) {
            let (x1, y1) = ((bx + b).min(w), (by + b).min(h));
            let (mut s, mut n) = (0.0f64, 0u32);
            for y in by..y1 {
                for x in bx..x1 {
                    s += image[(y * w + x) as usize] as f64;
                    n += 1;
                }
            }
            let (a, c, e, d) = (dir(bx, by), dir(x1, by), dir(x1, y1), dir(bx, y1));
            let measure = match profile {
                Profile::Intensity => triangle(a, c, e) + triangle(a, e, d),
                Profile::Irradiance => {
                    // Corner rays on the plane at unit distance along the axis (0 behind it).
                    let on = |v: glam::DVec3| if v.dot(forward) > 0.0 { v / v.dot(forward) } else { glam::DVec3::ZERO };
                    let (pa, pc, pe, pd) = (on(a), on(c), on(e), on(d));
                    std::f64::consts::PI * 0.5 * ((pc - pa).cross(pe - pa).length() + (pe - pa).cross(pd - pa).length())
                }
            };
            total += s / n as f64 * measure;
        }
    }
    total as f32
}

/// How 8-bit (or 16-bit) codes become linear values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Response {
    /// v = code / max.
    Linear,
    /// The sRGB transfer curve (IEC 61966-2-1).
    Srgb,
    /// v = (code / max)^γ.
    Gamma(f64),
}

/// Linear luminance (Rec. 709 Y of linear RGB) per pixel, row-major from the top row, and the
/// size, of an image file: PNG or JPEG codes through `response`, EXR or PFM as stored (linear).
pub fn read_projector_image(path: &std::path::Path, response: Response) -> anyhow::Result<(u32, u32, Vec<f32>)> {
    use anyhow::{anyhow, Context};
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let y = |c: [f64; 3]| (0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]) as f32;
    match ext.as_str() {
        "exr" | "pfm" => {
            let img = crate::image_io::read_image(path)?;
            let v = img.rgb.iter().map(|p| y([p[0] as f64, p[1] as f64, p[2] as f64])).collect();
            Ok((img.width, img.height, v))
        }
        "png" | "jpg" | "jpeg" => {
            let dec = image::open(path).map_err(|e| anyhow!("{e}")).with_context(|| format!("reading {}", path.display()))?;
            let lin = |c: f64| match response {
                Response::Linear => c,
                Response::Srgb => optics::color::srgb_decode(c),
                Response::Gamma(g) => c.powf(g),
            };
            let v = dec.to_rgb16().pixels().map(|p| y([0, 1, 2].map(|k| lin(p[k] as f64 / 65535.0)))).collect();
            Ok((dec.width(), dec.height(), v))
        }
        _ => anyhow::bail!("{}: unknown image type (use .png, .jpg, .exr or .pfm)", path.display()),
    }
}
