//! Checking renders against references: pixelwise comparison with colour correction
//! ([`compare`]), the noise cost of an estimator ([`noise_cost`]) and the minimiser of analysis
//! by synthesis ([`minimize`]; scene parameters are addressed by `render::load::template`).

pub mod compare;
pub mod minimize;
pub mod noise_cost;
pub mod photo_fit;
pub mod scene_fit;
