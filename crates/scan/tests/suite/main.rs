//! Integration tests of the scan crate.

mod eval;
mod synth;
