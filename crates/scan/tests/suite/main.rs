//! Integration tests of the scan crate.
mod common;
mod decode;
mod graycode;
mod triangulate;
