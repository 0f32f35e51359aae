//! Integration tests of the scan crate.

mod calib;
mod common;
mod decode;
mod eval;
mod graycode;
mod synth;
mod triangulate;
