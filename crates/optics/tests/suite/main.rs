//! The integration tests of the optics crate, one test binary (each file a module).

mod common;
mod bssrdf;
mod color;
mod fresnel;
mod media;
mod mie;
mod mie_absorbing_host;
mod milk;
mod particles;
mod phase;
mod reflectometry;
mod reflectometry_milk;
mod robustness;
mod slab;
mod spectrum;
