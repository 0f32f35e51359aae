//! Integrators: ambient occlusion, direct lighting, path tracing with NEE + MIS.
//! (Interface fixed; bodies to be written by the tracer work.)

use crate::scene::Scene;

/// Which light-transport estimator to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IntegratorKind {
    Path,
    Direct,
    Ao,
}

/// Settings of an integrator (Mitsuba's defaults for `path`: 8 bounces, Russian roulette from the 5th).
#[derive(Clone, Debug)]
pub struct IntegratorSettings {
    pub kind: IntegratorKind,
    /// Longest path in bounces.
    pub max_depth: u32,
    /// Russian roulette starts at this depth.
    pub rr_depth: u32,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        IntegratorSettings { kind: IntegratorKind::Path, max_depth: 8, rr_depth: 5 }
    }
}

/// Render one sample per pixel for pass number `pass`, writing the CIE XYZ estimate of each pixel
/// (row-major, `width*height` entries, Y = 1 for spectral radiance 1) into `xyz_out`.
/// Deterministic in (`seed`, `pass`, pixel) whatever the thread count.
pub fn render_pass(_scene: &Scene, _settings: &IntegratorSettings, _seed: u64, _pass: u64, _xyz_out: &mut [[f32; 3]]) {
    unimplemented!("render_pass")
}

/// Samples per second (millions) of `path` on the built-in Cornell box at `width`×`height`,
/// max 8 bounces, Russian roulette from the 5th, measured over about `seconds` on the current rayon pool.
pub fn benchmark_cornell(_width: u32, _height: u32, _seconds: f64) -> anyhow::Result<f64> {
    anyhow::bail!("Cornell box benchmark is not implemented yet")
}
