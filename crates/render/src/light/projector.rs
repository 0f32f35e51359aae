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
//! sRGB curve; gamma γ: (code/255)^γ); a float image (EXR, PFM) is linear. A grey image projects
//! v·I₀. A colour image projects each pixel's linear RGB uplifted to an emission spectrum as
//! lucent's emitting textures are (Jakob & Hanika 2019: s(λ) = 2·max(rgb) times the sigmoid
//! reflectance of rgb/(2·max), [`crate::math::uplift`]) times I₀(λ), so white (1, 1, 1) gives
//! I₀ and a grey pixel v gives v·I₀, as in a grey image; with I₀ = D65 (`intensity = { rgb = [1,
//! 1, 1] }`) a pixel of colour rgb lights a white Lambertian surface in that colour, as pbrt-v4's
//! `ProjectionLight` (`RGBIlluminantSpectrum`, with the colour space's illuminant) does. Mitsuba
//! 3's spectral `projector` upsamples its bitmap without a D65 factor: its white is lucent's
//! I₀ = 1 (docs/scene-format.md, "Projectors").

use crate::camera::Camera;
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use crate::math::uplift::{normalized_lambda, sigmoid_shape, uplift_colours};
use glam::{Vec3, Vec4};
use optics::spectrum::DenseSpectrum;
use std::sync::Arc;

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
    /// Linear pixel values, row-major, top row first (`camera.width × camera.height`); for a
    /// colour image (`colour`) each pixel's spectrum averaged with the weight I₀(λ),
    /// ∫ s I₀ dλ / ∫ I₀ dλ (its share of the power).
    pub image: Vec<f32>,
    /// A colour image's emission spectra per pixel (`[c₀, c₁, c₂, scale]`, [`uplift_colours`]),
    /// which replace `image` as the factor on I₀; `None` for a grey image. Code that sets `image`
    /// to a grey pattern clears it.
    pub colour: Option<Arc<Vec<[f32; 4]>>>,
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
        Ok(Projector { camera, image, colour: None, intensity, profile: Profile::Intensity, weighted_solid_angle_sr })
    }

    /// Projector with a colour image (linear RGB per pixel, `camera.width × camera.height`, each
    /// component finite and ≥ 0) and white `intensity`; an image whose pixels are all grey is the
    /// grey image of [`Projector::new`].
    pub fn with_colours(camera: Camera, rgb: &[[f32; 3]], intensity: DenseSpectrum) -> anyhow::Result<Projector> {
        if let Some(c) = rgb.iter().find(|c| c.iter().any(|v| !(v.is_finite() && *v >= 0.0))) {
            anyhow::bail!("image value {c:?} is negative or not finite");
        }
        if rgb.iter().all(|c| c[0] == c[1] && c[1] == c[2]) {
            return Projector::new(camera, rgb.iter().map(|c| c[0]).collect(), intensity);
        }
        let spectra = uplift_colours(rgb, true);
        // Each pixel's value for the power and the light choice: ∫ s(λ) I₀(λ) dλ / ∫ I₀ dλ,
        // once per distinct spectrum.
        let i0: Vec<f64> = (0..=470).map(|k| intensity.eval(360.0 + k as f32) as f64).collect();
        let total: f64 = i0.iter().sum();
        let mut distinct: Vec<[u32; 4]> = spectra.iter().map(|c| c.map(f32::to_bits)).collect();
        distinct.sort_unstable();
        distinct.dedup();
        let mean = |c: [f32; 4]| -> f32 {
            if !(total > 0.0) {
                return 0.0;
            }
            let s = optics::uplift::SigmoidSpectrum { coeffs: [c[0] as f64, c[1] as f64, c[2] as f64], scale: c[3] as f64 };
            ((0..=470).map(|k| s.eval(360.0 + k as f64) * i0[k]).sum::<f64>() / total) as f32
        };
        let means: Vec<f32> = distinct.iter().map(|b| mean(b.map(f32::from_bits))).collect();
        let image = spectra.iter().map(|c| means[distinct.binary_search(&c.map(f32::to_bits)).expect("every spectrum is listed")]).collect();
        let p = Projector::new(camera, image, intensity)?;
        Ok(Projector { colour: Some(Arc::new(spectra)), ..p })
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
        self.pixel_at(p).map_or(0.0, |k| self.image[k])
    }

    /// The radiant intensity towards world point `p` (m) at the carried wavelengths, per unit
    /// I₀: [`Self::weight_at`] for a grey image, the pixel's spectrum times the profile's factor
    /// for a colour one.
    #[inline]
    pub fn spectrum_at(&self, p: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        let Some(colour) = &self.colour else { return Vec4::splat(self.weight_at(p)) };
        let Some(k) = self.pixel_at(p) else { return Vec4::ZERO };
        let c = colour[k];
        let v = c[3] * sigmoid_shape(c, normalized_lambda(wl));
        if self.profile == Profile::Intensity {
            return v;
        }
        let d = p - self.position();
        v * self.profile.factor(self.camera.forward().dot(d) / d.length())
    }

    /// Index of the image pixel that world point `p` (m) projects into; `None` outside the image
    /// or behind the projector.
    #[inline]
    fn pixel_at(&self, p: Vec3) -> Option<usize> {
        let f = self.camera.project(p)?;
        if !(f.x >= 0.0 && f.y >= 0.0) {
            return None;
        }
        let (i, j) = (f.x as u32, f.y as u32);
        if i >= self.camera.width || j >= self.camera.height {
            return None;
        }
        Some(j as usize * self.camera.width as usize + i as usize)
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

/// Linear RGB per pixel, row-major from the top row, and the size, of an image file: PNG or JPEG
/// codes through `response`, EXR or PFM as stored (linear).
pub fn read_projector_image(path: &std::path::Path, response: Response) -> anyhow::Result<(u32, u32, Vec<[f32; 3]>)> {
    use anyhow::{anyhow, Context};
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    match ext.as_str() {
        "exr" | "pfm" => {
            let img = crate::image_io::read_image(path)?;
            Ok((img.width, img.height, img.rgb))
        }
        "png" | "jpg" | "jpeg" => {
            let dec = image::open(path).map_err(|e| anyhow!("{e}")).with_context(|| format!("reading {}", path.display()))?;
            let lin = |c: f64| match response {
                Response::Linear => c,
                Response::Srgb => optics::color::srgb_decode(c),
                Response::Gamma(g) => c.powf(g),
            };
            let v = dec.to_rgb16().pixels().map(|p| [0, 1, 2].map(|k| lin(p[k] as f64 / 65535.0) as f32)).collect();
            Ok((dec.width(), dec.height(), v))
        }
        _ => anyhow::bail!("{}: unknown image type (use .png, .jpg, .exr or .pfm)", path.display()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 40.0, 20, 10).unwrap()
    }

    /// An image of greys is the grey projector, value for value; a colour image keeps its spectra.
    #[test]
    fn grey_rgb_images_are_grey_projectors() {
        let i0 = DenseSpectrum::from_fn(|l| 1.0 + l / 1000.0);
        let rgb: Vec<[f32; 3]> = (0..200).map(|k| [k as f32 / 100.0; 3]).collect();
        let p = Projector::with_colours(camera(), &rgb, i0.clone()).unwrap();
        let g = Projector::new(camera(), rgb.iter().map(|c| c[0]).collect(), i0.clone()).unwrap();
        assert!(p.colour.is_none());
        assert_eq!((p.image, p.weighted_solid_angle_sr), (g.image, g.weighted_solid_angle_sr));
        let mut rgb = rgb;
        rgb[7] = [0.9, 0.1, 0.3];
        assert!(Projector::with_colours(camera(), &rgb, i0.clone()).unwrap().colour.is_some());
        rgb[8] = [-0.1, 0.1, 0.3];
        assert!(Projector::with_colours(camera(), &rgb, i0).is_err());
    }

    /// The power of a colour image of one colour is its solid angle times ∫ s(λ) I₀(λ) dλ, s the
    /// colour's emission spectrum (the optics crate's uplift, summed here independently).
    #[test]
    fn colour_power_is_the_spectrum_weighted_by_the_white() {
        let i0 = DenseSpectrum::from_fn(|l| 0.5 + (l - 360.0) / 470.0);
        let colour = [1.3f32, 0.4, 0.2];
        let p = Projector::with_colours(camera(), &vec![colour; 200], i0.clone()).unwrap();
        let white = Projector::new(camera(), vec![1.0; 200], i0.clone()).unwrap();
        let s = optics::uplift::SigmoidSpectrum::illuminant_by(colour.map(|v| v as f64), optics::uplift::Fit::Direct);
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for k in 0..=470 {
            let l = 360.0 + k as f64;
            num += s.eval(l) * i0.eval(l as f32) as f64;
            den += i0.eval(l as f32) as f64;
        }
        let want = white.weighted_solid_angle_sr as f64 * num / den;
        let got = p.weighted_solid_angle_sr as f64;
        assert!((got / want - 1.0).abs() < 1e-4, "{got} against {want}");
    }
}
