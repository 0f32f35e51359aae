//! The integration tests of the renderer, one test binary (each file a module).

mod common;
mod aov;
mod bsdf;
mod bsdf_scene;
mod bvh;
mod camera;
mod checkpoint;
mod envmap;
mod fuzz_corpus;
mod geometry;
mod golden_renders;
mod image_io;
mod integrator;
mod integrator_cornell;
mod light;
mod mesh;
mod pinned_physics;
mod projector;
mod robustness;
mod scene;
mod shading_map;
mod shapes;
mod subsurface;
mod subsurface_colour;
mod texture;
mod volpath;
