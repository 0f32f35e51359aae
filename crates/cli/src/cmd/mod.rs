//! One file per subcommand.
pub mod bench;
pub mod bench_mie;
pub mod bench_bssrdf;
pub mod bench_support;
pub mod bssrdf;
pub mod compare;
pub mod fit;
pub mod fit_photo;
pub mod fit_scene;
pub mod format;
pub mod medium;
pub mod merge;
pub mod mie;
pub mod render;
pub mod scan;
pub mod slab;
