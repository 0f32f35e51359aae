//! The ray sets of the ray benchmarks, shared by `lucent bench` and `cargo bench` so both
//! measure the same work: camera rays from a pinhole outside the scene's bounding box looking
//! at its centre, and incoherent rays with origins uniform in the box and directions uniform
//! on the sphere (the distribution of Embree's published incoherent-ray benchmarks).

use crate::accel::Accel;
use crate::integrator::render_pass;
use crate::integrator::settings::{IntegratorKind, IntegratorSettings};
use crate::scene::Scene;
use crate::math::geometry::Ray;
use glam::Vec3;

/// Small deterministic generator (SplitMix64) for the ray sets.
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// `n` incoherent rays: origins uniform in the bounding box, directions uniform on the unit sphere.
pub fn incoherent_rays(accel: &Accel, n: usize, seed: u64) -> Vec<Ray> {
    let b = accel.bounds();
    let mut rng = SplitMix(seed);
    (0..n)
        .map(|_| {
            let o = b.min + b.extent() * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let z = 1.0 - 2.0 * rng.f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * rng.f32();
            Ray::new(o, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

/// Pinhole of the camera-ray benchmark: eye outside the bounding box looking at its centre, 40° field of view.
#[derive(Clone, Copy, Debug)]
pub struct BenchCamera {
    eye: Vec3,
    dir: Vec3,
    right: Vec3,
    up: Vec3,
}

impl BenchCamera {
    /// The benchmark camera for this scene.
    pub fn new(accel: &Accel) -> BenchCamera {
        let b = accel.bounds();
        let c = b.center();
        let radius = 0.5 * b.extent().length();
        let dir = Vec3::new(-0.4, -0.3, -1.0).normalize();
        let half = 20f32.to_radians();
        let eye = c - dir * (radius / half.sin()).max(radius * 1.01);
        let right = dir.cross(Vec3::Y).normalize();
        let up = right.cross(dir);
        BenchCamera { eye, dir, right: right * half.tan(), up: up * half.tan() }
    }

    /// The ray through the centre of pixel (`i`, `j`) of a `size`×`size` image.
    #[inline]
    pub fn ray(&self, i: u32, j: u32, size: u32) -> Ray {
        let inv = 1.0 / size as f32;
        let x = 2.0 * ((i as f32 + 0.5) * inv) - 1.0;
        let y = 1.0 - 2.0 * ((j as f32 + 0.5) * inv);
        Ray::new(self.eye, self.dir + x * self.right + y * self.up)
    }

    /// The 16 rays of the 4×4 pixel block whose top-left pixel is (`i`, `j`), ordered as four
    /// 2×2 quads (the SIMD groups of [`Accel::intersect_packet`]). The block must lie inside the image.
    pub fn block(&self, i: u32, j: u32, size: u32) -> [Ray; 16] {
        std::array::from_fn(|k| {
            let k = k as u32;
            self.ray(i + k % 2 + 2 * (k / 8), j + (k / 2) % 4, size)
        })
    }
}

/// Samples per second (millions) of `path` on the built-in Cornell box at `width`×`height`,
/// max 8 bounces, Russian roulette from the 5th, measured over about `seconds` on the current rayon pool.
pub fn benchmark_cornell(width: u32, height: u32, seconds: f64) -> anyhow::Result<f64> {
    benchmark_cornell_clocked(width, height, seconds, || 0.0).map(|r| r.0)
}

/// [`benchmark_cornell`], also reading `clock` (e.g. the process's CPU time, seconds) before and
/// after the timed passes (the warm-up pass excluded): (Msamples per wall second, Msamples per
/// `clock` second; NaN when the clock did not advance).
pub fn benchmark_cornell_clocked(width: u32, height: u32, seconds: f64, clock: impl Fn() -> f64) -> anyhow::Result<(f64, f64)> {
    if width == 0 || height == 0 {
        anyhow::bail!("benchmark resolution must be at least 1×1, got {width}×{height}");
    }
    if !(seconds > 0.0) || !seconds.is_finite() {
        anyhow::bail!("benchmark duration must be positive, got {seconds}");
    }
    let mut scene = Scene::cornell_box();
    scene.set_resolution(width, height);
    let settings = IntegratorSettings { kind: IntegratorKind::Path, max_depth: 8, rr_depth: 5 };
    let mut buf = vec![[0f32; 3]; (width as usize) * (height as usize)];
    render_pass(&scene, &settings, 0, 0, &mut buf); // warm-up
    let start = std::time::Instant::now();
    let c0 = clock();
    let mut passes = 0u64;
    loop {
        render_pass(&scene, &settings, 1, passes, &mut buf);
        passes += 1;
        if start.elapsed().as_secs_f64() >= seconds {
            break;
        }
    }
    let t = start.elapsed().as_secs_f64();
    let c = clock() - c0;
    let samples = passes as f64 * buf.len() as f64;
    Ok((samples / t / 1e6, if c > 0.0 { samples / c / 1e6 } else { f64::NAN }))
}
