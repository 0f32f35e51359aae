//! Physics of material appearance, independent of rendering.
//!
//! Units: SI inside (metres, m⁻¹, kelvin); wavelengths of spectra are in nanometres
//! (every function and field names its unit, e.g. `lambda_nm`, `radius_m`).

pub mod csv;
pub mod spectrum;
pub mod uplift;
pub mod color;
pub mod fresnel;
pub mod phase;
pub mod mie;
pub mod particles;
pub mod media;
pub mod milk;
pub mod bssrdf;
pub mod fitting;
pub mod reflectometry;
pub mod ior;
pub mod slab;
pub mod numfmt;
