//! Geometry of scene objects: spheres and triangle meshes, their ray tests and mesh files; disks
//! and cylinders are triangle meshes ([`tessellate`]).
//!
//! A new kind of shape is a file here, a variant of [`Shape`] (every `match` on it must then
//! handle it: none has a catch-all arm), its intersection in [`crate::accel`] and its loader in
//! [`crate::load`].

pub mod mesh;
pub mod sphere;
pub mod tessellate;
pub mod triangle;

use crate::math::geometry::Aabb;
use mesh::TriangleMesh;
use sphere::Sphere;

/// A shape of the scene.
#[derive(Clone, Debug)]
pub enum Shape {
    /// A triangle mesh.
    Mesh(TriangleMesh),
    /// A sphere.
    Sphere(Sphere),
}

impl Shape {
    /// Number of primitives (triangles, or 1 for a sphere).
    pub fn primitive_count(&self) -> usize {
        match self {
            Shape::Mesh(m) => m.indices.len(),
            Shape::Sphere(_) => 1,
        }
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Mesh(m) => Aabb::from_points(&m.positions),
            Shape::Sphere(s) => s.bounds(),
        }
    }
}
