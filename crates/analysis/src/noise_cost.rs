//! Cost of an estimator at equal noise: the figure of merit `lucent bench bssrdf` compares the
//! point-cloud BSSRDF with volumetric path tracing by.
//!
//! A Monte Carlo render's per-pixel variance falls as 1/time, so the time one estimator needs to
//! reach a given per-pixel noise is proportional to σ²·T, σ being its per-pixel standard deviation
//! after the CPU time T. Two independent renders A, B (different seeds) of the same image give
//! σ² = mean((A − B)²)/2 over a region without a reference image; the ratio of two estimators'
//! σ²·T is how many times less time one needs than the other to reach equal noise.

use render::integrator::{render_pass, IntegratorSettings};
use render::scene::Scene;
use anyhow::{bail, Result};

/// Noise and cost of one estimator on one scene.
#[derive(Clone, Copy, Debug)]
pub struct NoiseCost {
    /// Samples per pixel of each render.
    pub spp: u32,
    /// CPU time (s) of one render, the mean of the two (as reported by the caller's clock).
    pub cpu_s: f64,
    /// Mean luminance Y over the region (CIE Y, 1 for unit spectral radiance), both renders.
    pub mean_y: f64,
    /// Per-pixel standard deviation of Y of one render, √(mean((A − B)²)/2) over the region.
    pub sigma_y: f64,
}

impl NoiseCost {
    /// σ²·CPU (s): proportional to the time to any fixed per-pixel noise.
    pub fn sigma2_cpu_s(&self) -> f64 {
        self.sigma_y * self.sigma_y * self.cpu_s
    }
}

/// Renders `scene` twice, `spp` passes each with the two `seeds`, and measures the per-pixel noise
/// of Y over `region` = (x0, y0, x1, y1) as fractions of the frame and the CPU time read from
/// `clock` (seconds, e.g. the process's user + system time). `on_pass` is called after every
/// pass (for a progress bar).
pub fn noise_cost(
    scene: &Scene,
    settings: &IntegratorSettings,
    spp: u32,
    seeds: [u64; 2],
    region: [f32; 4],
    clock: &dyn Fn() -> f64,
    on_pass: &dyn Fn(),
) -> Result<NoiseCost> {
    if spp == 0 {
        bail!("samples per pixel must be at least 1");
    }
    if seeds[0] == seeds[1] {
        bail!("the two renders need different seeds, got {} twice", seeds[0]);
    }
    let [x0, y0, x1, y1] = region;
    if !(0.0 <= x0 && x0 < x1 && x1 <= 1.0 && 0.0 <= y0 && y0 < y1 && y1 <= 1.0) {
        bail!("region must satisfy 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1, got {region:?}");
    }
    let (w, h) = scene.resolution();
    let n = (w as usize) * (h as usize);
    let (i0, i1) = ((x0 * w as f32) as usize, ((x1 * w as f32) as usize).max((x0 * w as f32) as usize + 1));
    let (j0, j1) = ((y0 * h as f32) as usize, ((y1 * h as f32) as usize).max((y0 * h as f32) as usize + 1));
    let mut pass_buf = vec![[0f32; 3]; n];
    let mut images = [vec![0f64; n], vec![0f64; n]];
    let c0 = clock();
    for (img, &seed) in images.iter_mut().zip(&seeds) {
        for pass in 0..spp as u64 {
            render_pass(scene, settings, seed, pass, &mut pass_buf);
            for (acc, xyz) in img.iter_mut().zip(&pass_buf) {
                *acc += xyz[1] as f64;
            }
            on_pass();
        }
        img.iter_mut().for_each(|v| *v /= spp as f64);
    }
    let cpu_s = (clock() - c0) / 2.0;
    let (mut sum, mut sum_d2, mut count) = (0.0, 0.0, 0usize);
    for j in j0..j1.min(h as usize) {
        for i in i0..i1.min(w as usize) {
            let k = j * w as usize + i;
            let (a, b) = (images[0][k], images[1][k]);
            sum += a + b;
            sum_d2 += (a - b) * (a - b);
            count += 1;
        }
    }
    if count == 0 {
        bail!("region {region:?} holds no pixel at {w}×{h}");
    }
    Ok(NoiseCost {
        spp,
        cpu_s,
        mean_y: sum / (2 * count) as f64,
        sigma_y: (sum_d2 / count as f64 / 2.0).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use render::integrator::IntegratorKind;

    /// The noise estimate follows the 1/√spp law of an unbiased estimator (Cornell box, `path`):
    /// four times the samples halve σ (within the estimate's own scatter), and the mean agrees.
    #[test]
    fn sigma_falls_as_one_over_root_spp() {
        let mut scene = Scene::cornell_box();
        scene.set_resolution(48, 48);
        let settings = IntegratorSettings { kind: IntegratorKind::Path, max_depth: 8, rr_depth: 5 };
        let region = [0.1, 0.3, 0.9, 0.9];
        let clock = || 0.0;
        let a = noise_cost(&scene, &settings, 8, [1, 2], region, &clock, &|| {}).unwrap();
        let b = noise_cost(&scene, &settings, 32, [3, 4], region, &clock, &|| {}).unwrap();
        let ratio = a.sigma_y / b.sigma_y;
        assert!((ratio - 2.0).abs() < 0.3, "σ(8 spp)/σ(32 spp) = {ratio}, expected 2");
        // Means agree within a few standard errors of the region mean (1369 pixels).
        let se = (a.sigma_y * a.sigma_y / 2.0 + b.sigma_y * b.sigma_y / 2.0).sqrt() / (1369f64).sqrt();
        assert!((a.mean_y - b.mean_y).abs() < 5.0 * se, "{} vs {} (se {se})", a.mean_y, b.mean_y);
        assert!(noise_cost(&scene, &settings, 4, [1, 1], region, &clock, &|| {}).is_err());
        assert!(noise_cost(&scene, &settings, 4, [1, 2], [0.5, 0.1, 0.4, 0.9], &clock, &|| {}).is_err());
    }
}
