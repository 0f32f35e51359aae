//! Integration tests of the scan crate.

mod calib;
mod common;
mod decode;
mod graycode;
