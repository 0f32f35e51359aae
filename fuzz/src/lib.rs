//! Fuzz targets of lucent: see `fuzz/README.md`. The library calls live in `calls.rs`, shared
//! with the corpus replay test `crates/render/tests/suite/fuzz_corpus.rs`.

#[path = "calls.rs"]
pub mod calls;

/// The repository root (the parent of this crate).
pub fn repo_root() -> &'static std::path::Path {
    std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}
