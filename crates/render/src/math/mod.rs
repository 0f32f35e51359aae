//! The leaf of the renderer: rays and boxes, random numbers and sampling warps, spectral
//! (hero-wavelength) sampling and colour matching. Depends on nothing else in the crate.

pub mod fastexp;
pub mod geometry;
pub mod hash;
pub mod sampling;
pub mod spectral;
pub mod uplift;
