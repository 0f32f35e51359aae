//! The integration tests of the analysis crate, one test binary (each file a module).

mod compare;
mod color_correct;
mod photo_fit;
