//! Scenes: the TOML scene format and the built-in measured Cornell box.
//! (Interface fixed; body to be written by the tracer work.)

use std::path::Path;

/// Everything a render needs: camera, geometry with its acceleration structure, materials, lights.
pub struct Scene {
    width: u32,
    height: u32,
}

impl Scene {
    /// Load a TOML scene; errors name the file and the field or line.
    pub fn load(path: &Path) -> anyhow::Result<Scene> {
        anyhow::bail!("{}: scene loading is not implemented yet", path.display())
    }

    /// The built-in default scene: the measured Cornell box (same as `scenes/cornell-box.toml`).
    pub fn cornell_box() -> Scene {
        Scene { width: 256, height: 256 }
    }

    /// Override the camera resolution in pixels.
    pub fn set_resolution(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
    }

    /// Camera resolution (width, height) in pixels.
    pub fn resolution(&self) -> (u32, u32) {
        (self.width, self.height)
    }
}
