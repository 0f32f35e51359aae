//! Spectral physically based rendering.
//!
//! Geometry is in the scene's length unit converted to metres at load time; radiometric
//! quantities are spectral (per nanometre of wavelength), accumulated to CIE XYZ on the film.
//! `docs/architecture.md` draws the layers; dependencies point down this list:
//!
//! - [`load`]: the TOML scene format (the only module that reads TOML);
//! - [`progressive`], [`checkpoint`], [`film`], [`image_io`]: the pass loop and its outputs;
//! - [`integrator`]: path, volpath, direct, ao and the point-cloud BSSRDF, with their shared
//!   next-event estimation;
//! - [`scene`], [`interaction`]: the scene and its queries, shading points;
//! - [`camera`], [`light`], [`material`], [`bsdf`], [`medium`]: what a scene is made of;
//! - [`accel`], [`shape`]: geometry and ray queries;
//! - [`math`]: rays and boxes, sampling, spectral sampling (the leaf).

pub mod accel;
pub mod bench;
pub mod bsdf;
pub mod camera;
pub mod checkpoint;
pub mod film;
pub mod image_io;
pub mod integrator;
pub mod interaction;
pub mod light;
pub mod load;
pub mod material;
pub mod math;
pub mod medium;
pub mod progressive;
pub mod scene;
pub mod shape;
pub mod texture;
