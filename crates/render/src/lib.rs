//! Spectral physically based rendering.
//!
//! Geometry is in the scene's length unit converted to metres at load time; radiometric
//! quantities are spectral (per nanometre of wavelength), accumulated to CIE XYZ on the film.

pub mod geometry;
pub mod mesh;
pub mod bvh;
pub mod bench_rays;
pub mod sampling;
pub mod spectral;
pub mod camera;
pub mod light;
pub mod material;
pub mod medium;
pub mod integrator;
pub mod film;
pub mod checkpoint;
pub mod scene;
pub mod image_io;
pub mod compare;
pub mod microfacet;
pub mod bxdf;
pub mod volpath;
pub mod subsurface;
pub mod line_dipole4;
pub mod noise_cost;
pub mod param;
