//! The integration tests of the renderer, one test binary (each file a module).

mod common;
mod bsdf;
mod bsdf_scene;
mod bvh;
mod checkpoint;
mod geometry;
mod golden_renders;
mod image_io;
mod integrator;
mod integrator_cornell;
mod light;
mod mesh;
mod pinned_physics;
mod scene;
mod subsurface;
mod texture;
mod volpath;
