//! The integration tests of the `lucent` command, one test binary (each file a module).

mod camera_cli;
mod common;
mod aov_cli;
#[cfg(feature = "denoise")]
mod denoise;
mod distributed_examples;
mod fit_cli;
mod fit_roundtrip;
mod fit_scene;
mod fit_photo_cli;
mod preview;
mod render_cli;
mod robustness_optics;
mod robustness_render;
mod scan_cli;
mod markers_cli;
mod scan_label_cli;
mod reassembly_cli;
