//! `ao`: at the first hit, one cosine-weighted direction about the shading normal; the value is
//! 1 when that direction is not blocked within the scene's `ao_distance`, else 0, written as
//! equal-energy white with Y = value (an unoccluded point shows Y = 1 exactly). Rays that miss
//! everything give 0.

use crate::interaction::Shading;
use crate::math::geometry::Ray;
use crate::math::sampling::{cosine_hemisphere, Pcg32};
use crate::scene::Scene;

/// Ambient occlusion: 1 if a cosine-distributed direction at the first hit escapes within the
/// scene's AO distance, else 0 (0 also when the camera ray misses everything).
pub fn ao_visibility(scene: &Scene, ray: Ray, rng: &mut Pcg32) -> f32 {
    let Some(hit) = scene.intersect(&ray) else { return 0.0 };
    let s = Shading::at(scene, &ray, &hit);
    let d = s.frame.to_world(cosine_hemisphere(rng.next_2d()));
    if d.dot(s.ng) <= 0.0 {
        return 0.0;
    }
    let mut r = s.spawn(scene, d);
    r.t_max = scene.ao_distance_m;
    if scene.occluded(&r) {
        0.0
    } else {
        1.0
    }
}

/// CIE XYZ of the equal-energy spectrum normalised to Y = 1 (the colour `ao` reports).
pub fn equal_energy_white() -> [f32; 3] {
    static W: std::sync::OnceLock<[f32; 3]> = std::sync::OnceLock::new();
    *W.get_or_init(|| {
        let x = crate::math::spectral::xyz_of(|_| 1.0);
        [(x[0] / x[1]) as f32, 1.0, (x[2] / x[1]) as f32]
    })
}

/// Spectral radiance, the same at every wavelength, whose XYZ is [`equal_energy_white`] (Y = 1):
/// what an `ao` sample of visibility 1 carries per wavelength in spectral images.
pub fn equal_energy_radiance() -> f32 {
    static R: std::sync::OnceLock<f32> = std::sync::OnceLock::new();
    *R.get_or_init(|| (1.0 / crate::math::spectral::xyz_of(|_| 1.0)[1]) as f32)
}
