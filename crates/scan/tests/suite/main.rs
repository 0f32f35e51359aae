//! Integration tests of the scan crate.
