//! Integrators: what light a camera sample carries.
//!
//! Path lengths count segments as in Mitsuba 3: a path of depth 1 is a camera ray that sees an
//! emitter, depth 2 adds one bounce (direct lighting), and so on up to `max_depth`.
//!
//! - [`path`]: unidirectional path tracing; at every vertex one light sample and one BSDF sample,
//!   combined by multiple importance sampling with the power heuristic (Veach 1997); translucent
//!   materials through the point-cloud BSSRDF of [`subsurface`].
//! - [`volpath`]: volumetric path tracing through homogeneous media with spectral MIS.
//! - [`direct`]: emission plus direct lighting at the first hit, light and BSDF samples with MIS (Mitsuba 3's `direct`).
//! - [`ao`]: ambient occlusion.
//!
//! [`settings`] names them (the one table), [`nee`] is the next-event estimation they share, and
//! this module runs one pass over the image. A new integrator is a file here, a row in the
//! settings table and an arm in `trace_pixel`. The passes take each pixel's wavelength and film
//! numbers from [`PixelStrata`], stratified over the passes; the rest of a path from [`Pcg32`].

pub mod ao;
pub mod aov;
pub mod direct;
pub mod nee;
pub mod path;
pub mod settings;
pub mod subsurface;
pub mod volpath;

pub use settings::{IntegratorKind, IntegratorSettings};

use crate::math::sampling::{Pcg32, PixelStrata};
use crate::math::spectral::{SampledWavelengths, N_LAMBDA};
use crate::scene::Scene;
use rayon::prelude::*;
use subsurface::{SubsurfaceMode, SubsurfacePass};

/// Render one sample per pixel for pass number `pass`, writing the CIE XYZ estimate of each pixel
/// (row-major, `width*height` entries, Y = 1 for spectral radiance 1) into `xyz_out`.
/// Deterministic in (`seed`, `pass`, pixel) whatever the thread count.
pub fn render_pass(scene: &Scene, settings: &IntegratorSettings, seed: u64, pass: u64, xyz_out: &mut [[f32; 3]]) {
    let (w, h) = scene.resolution();
    let n = (w as usize) * (h as usize);
    assert!(xyz_out.len() >= n, "render_pass: output has {} entries, need {}×{}", xyz_out.len(), w, h);
    // Subsurface hook: with translucent objects and `path`, the pass's point clouds (one per
    // wavelength set) are built first; each pixel uses one set.
    let sss = if settings.kind == IntegratorKind::Path { path::subsurface_passes(scene, settings, seed, pass) } else { Vec::new() };
    let sets = sss.len() as u32;
    let offset = SubsurfacePass::set_offset(seed, pass);
    xyz_out[..n].par_chunks_mut(w as usize).enumerate().for_each(|(j, row)| {
        for (i, out) in row.iter_mut().enumerate() {
            let pixel = (j as u64) * (w as u64) + i as u64;
            let mut rng = Pcg32::for_pixel(seed, pass, pixel);
            let p = (sets > 0).then(|| &sss[SubsurfacePass::set_of_pixel(i as u32, j as u32, offset, sets) as usize]);
            let u = PixelStrata::for_pixel(seed, pixel).first(pass);
            *out = trace_pixel(scene, settings, i as u32, j as u32, u, &mut rng, p).0;
        }
    });
}

/// Everything one sample of a pixel gives beyond its XYZ estimate, for AOV and spectral films.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelSample {
    /// CIE XYZ estimate, as [`render_pass`] writes it (0 where not finite).
    pub xyz: [f32; 3],
    /// What the camera ray hit first (filled only when asked for, else [`aov::FirstHit::MISS`]).
    pub first_hit: aov::FirstHit,
    /// The carried wavelengths, nm.
    pub lambda_nm: [f32; N_LAMBDA],
    /// Integral weights L(λᵢ)/(p(λᵢ)·4) of the radiance at `lambda_nm`
    /// ([`SampledWavelengths::integral_weights`]; 0 where the estimate was not finite, and
    /// all 0 unless asked for).
    pub spectral_weight: [f32; N_LAMBDA],
}

impl PixelSample {
    /// A sample carrying nothing.
    pub const ZERO: PixelSample =
        PixelSample { xyz: [0.0; 3], first_hit: aov::FirstHit::MISS, lambda_nm: [0.0; N_LAMBDA], spectral_weight: [0.0; N_LAMBDA] };
}

/// Which parts of [`PixelSample`] a pass computes besides the XYZ estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleExtras {
    /// Trace the camera ray's first hit again for the geometric AOVs (the radiance estimate is
    /// unchanged: no random number is drawn for it).
    pub first_hit: bool,
    /// Keep the radiance per carried wavelength (spectral images).
    pub spectral: bool,
}

/// [`render_pass`] writing whole [`PixelSample`]s (the extras that `extras` asks for) into
/// `out` (row-major, `width*height` entries). The XYZ estimates are bit for bit those of
/// [`render_pass`].
pub fn render_pass_samples(scene: &Scene, settings: &IntegratorSettings, seed: u64, pass: u64, extras: SampleExtras, out: &mut [PixelSample]) {
    let (w, h) = scene.resolution();
    let n = (w as usize) * (h as usize);
    assert!(out.len() >= n, "render_pass_samples: output has {} entries, need {}×{}", out.len(), w, h);
    let sss = if settings.kind == IntegratorKind::Path { path::subsurface_pass(scene, settings, seed, pass) } else { None };
    out[..n].par_chunks_mut(w as usize).enumerate().for_each(|(j, row)| {
        for (i, o) in row.iter_mut().enumerate() {
            let pixel = (j as u64) * (w as u64) + i as u64;
            let mut rng = Pcg32::for_pixel(seed, pass, pixel);
            let u = PixelStrata::for_pixel(seed, pixel).first(pass);
            let (xyz, ray, u_lambda, wl, l) = trace_pixel(scene, settings, i as u32, j as u32, u, &mut rng, sss.as_ref());
            let mut sample = PixelSample { xyz, ..PixelSample::ZERO };
            if extras.first_hit {
                sample.first_hit = aov::first_hit(scene, &ray, u_lambda);
            }
            if extras.spectral {
                sample.lambda_nm = wl.lambda_nm;
                // A sample whose XYZ was rejected (not finite) has l = 0: no spectrum either.
                let weights = wl.integral_weights(l);
                if weights.iter().all(|v| v.is_finite()) {
                    sample.spectral_weight = weights;
                }
            }
            *o = sample;
        }
    });
}

/// One sample of pixel (`i`, `j`), its wavelength and film numbers drawn from `rng` too (the
/// passes of [`render_pass`] take them from [`PixelStrata`] instead): XYZ estimate; non-finite
/// estimates are replaced by 0.
#[inline]
pub fn sample_pixel(scene: &Scene, settings: &IntegratorSettings, i: u32, j: u32, rng: &mut Pcg32) -> [f32; 3] {
    let u = (rng.next_f32(), rng.next_2d());
    trace_pixel(scene, settings, i, j, u, rng, None).0
}

/// One sample of pixel (`i`, `j`): its XYZ estimate (0 where not finite), the camera ray, the
/// wavelength number `u_lambda` (with `u_film`, the position in the pixel: stratified over the
/// passes by [`PixelStrata`]), the wavelengths as the path left them and the radiance at them (for `ao`,
/// the visibility at every wavelength).
#[inline(always)]
fn trace_pixel(
    scene: &Scene,
    settings: &IntegratorSettings,
    i: u32,
    j: u32,
    (u_lambda, u_film): (f32, glam::Vec2),
    rng: &mut Pcg32,
    sss: Option<&SubsurfacePass>,
) -> ([f32; 3], crate::math::geometry::Ray, f32, SampledWavelengths, crate::math::spectral::SampledSpectrum) {
    let ray = scene.camera.sample_ray(i, j, u_film, || rng.next_2d());
    let mut wl = match sss {
        Some(p) => p.wl,
        None => SampledWavelengths::sample(u_lambda),
    };
    let (xyz, l) = match settings.kind {
        IntegratorKind::Ao => {
            // Visibility is wavelength-independent: report it as equal-energy white with Y = v.
            let v = ao::ao_visibility(scene, ray, rng);
            let w = ao::equal_energy_white();
            ([w[0] * v, w[1] * v, w[2] * v], glam::Vec4::splat(v * ao::equal_energy_radiance()))
        }
        IntegratorKind::Path => {
            let l = match sss {
                Some(p) => path::li_path_mode(scene, settings, ray, &mut wl, rng, SubsurfaceMode::Bssrdf(p), 0.0),
                None => path::li_path(scene, settings, ray, &mut wl, rng),
            };
            (wl.to_xyz(l), l)
        }
        IntegratorKind::Volpath => {
            let l = volpath::li_volpath(scene, settings, ray, &mut wl, rng);
            (wl.to_xyz(l), l)
        }
        IntegratorKind::Direct => {
            let l = direct::li_direct(scene, ray, &mut wl, rng);
            (wl.to_xyz(l), l)
        }
    };
    if xyz.iter().all(|c| c.is_finite()) {
        (xyz, ray, u_lambda, wl, l)
    } else {
        ([0.0; 3], ray, u_lambda, wl, glam::Vec4::ZERO)
    }
}
