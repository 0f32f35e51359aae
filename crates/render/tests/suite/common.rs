//! Helpers shared by the render tests.

use render::integrator::{IntegratorKind, IntegratorSettings};
use render::scene::Scene;
use std::path::{Path, PathBuf};

#[allow(dead_code)]
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[allow(dead_code)]
pub fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, "test.toml", Path::new(".")).unwrap_or_else(|e| panic!("{e:#}"))
}

#[allow(dead_code)]
pub fn settings(kind: IntegratorKind, max_depth: u32, rr_depth: u32) -> IntegratorSettings {
    IntegratorSettings { kind, max_depth, rr_depth }
}

/// Y of an equal-energy spectrum of value 1 as the renderer's colour tables give it (≈ 1).
#[allow(dead_code)]
pub fn y_of_one() -> f64 {
    render::math::spectral::xyz_of(|_| 1.0)[1]
}

/// Form factor from a differential area to a parallel rectangle [0, a]×[0, b] at distance c with a
/// corner straight above it (Howell, A Catalog of Radiation Heat Transfer Configuration Factors,
/// case B-3). Odd in a and in b, so signed sides give the corner decomposition of any rectangle.
#[allow(dead_code)]
pub fn form_factor_corner(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// Asserts that loading a scene failed with a one-line error mentioning every string in `needles`.
pub fn assert_one_line_error(loaded: anyhow::Result<Scene>, needles: &[&str]) {
    let e = match loaded {
        Ok(_) => panic!("expected an error mentioning {needles:?}"),
        Err(e) => format!("{e:#}"),
    };
    assert!(!e.contains('\n'), "error is not one line: {e}");
    for n in needles {
        assert!(e.contains(n), "error `{e}` does not mention `{n}`");
    }
}
