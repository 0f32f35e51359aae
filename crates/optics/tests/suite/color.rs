//! Colorimetry tests against published CIE / IEC values.

use optics::color::*;
use optics::spectrum::{d65_relative, read_csv_columns, LAMBDA_MIN_NM};

/// The constant CIE_Y_INTEGRAL is the 1-nm sum of ȳ (CIE 015:2004 table; the data README quotes 106.857).
#[test]
fn y_integral_matches_table() {
    let s: f64 = cie_1931_table().iter().map(|b| b[1]).sum();
    assert!((s - CIE_Y_INTEGRAL).abs() < 1e-6, "sum ybar = {s}");
    assert!((s - 106.857).abs() < 1e-3);
    // Equal-energy spectrum 1 has Y = 1 (pbrt-v4 / Mitsuba 3 convention).
    let xyz = spectrum_to_xyz(|_| 1.0);
    assert!((xyz[1] - 1.0).abs() < 1e-12);
}

/// ȳ peaks at 1.0 at 555 nm (photopic V(λ), CIE 015:2004); interpolation at half-nm is the mean.
#[test]
fn cmf_values_and_interpolation() {
    assert!((cie_1931_xyz_bar(555.0)[1] - 1.0).abs() < 1e-9);
    let a = cie_1931_xyz_bar(500.0);
    let b = cie_1931_xyz_bar(501.0);
    let m = cie_1931_xyz_bar(500.5);
    for k in 0..3 {
        assert!((m[k] - 0.5 * (a[k] + b[k])).abs() < 1e-12);
    }
    assert_eq!(cie_1931_xyz_bar(359.9), [0.0; 3]);
    assert_eq!(cie_1931_xyz_bar(830.1), [0.0; 3]);
    assert!(cie_1931_xyz_bar(830.0)[0] > 0.0);
    // x̄(600 nm) = 1.0622, ȳ = 0.631, z̄ = 0.0008 (CIE 1931 2° table, 5-nm rows).
    let c = cie_1931_xyz_bar(600.0);
    assert!(
        (c[0] - 1.0622).abs() < 1e-4 && (c[1] - 0.631).abs() < 1e-3 && (c[2] - 0.0008).abs() < 1e-4
    );
}

/// D65 → xy = (0.3127, 0.3290) (CIE 015:2004, Table T.3) to 1e-4.
#[test]
fn d65_chromaticity() {
    let xy = xyz_to_xy(spectrum_to_xyz(d65_relative));
    assert!((xy[0] - 0.3127).abs() < 1e-4, "x = {}", xy[0]);
    assert!((xy[1] - 0.3290).abs() < 1e-4, "y = {}", xy[1]);
}

/// Equal-energy illuminant E → (1/3, 1/3): the CMFs are normalised to equal areas (CIE 015:2004).
#[test]
fn equal_energy_chromaticity() {
    let xy = xyz_to_xy(spectrum_to_xyz(|_| 1.0));
    assert!((xy[0] - 1.0 / 3.0).abs() < 1e-4, "x = {}", xy[0]);
    assert!((xy[1] - 1.0 / 3.0).abs() < 1e-4, "y = {}", xy[1]);
}

/// Illuminant A (Planckian 2856 K by its CIE definition with c2 = 1.435e-2) → (0.44757, 0.40745) (CIE 015:2004).
#[test]
fn illuminant_a_chromaticity() {
    let a = |l: f64| {
        let c2: f64 = 1.435e7; // nm·K
        (560.0 / l).powi(5) * ((c2 / (2848.0 * 560.0)).exp() - 1.0)
            / ((c2 / (2848.0 * l)).exp() - 1.0)
    };
    let xy = xyz_to_xy(spectrum_to_xyz(a));
    assert!(
        (xy[0] - 0.44757).abs() < 1e-4 && (xy[1] - 0.40745).abs() < 1e-4,
        "{xy:?}"
    );
}

/// The sRGB matrix maps D65 white (Y = 1) to (1, 1, 1), matches IEC 61966-2-1's published matrices,
/// and its inverse is exact.
#[test]
fn srgb_matrix() {
    let w = D65_WHITE_XY;
    let d65 = [w[0] / w[1], 1.0, (1.0 - w[0] - w[1]) / w[1]];
    let rgb = xyz_to_linear_srgb(d65);
    for c in rgb {
        assert!((c - 1.0).abs() < 1e-12, "{rgb:?}");
    }
    // Tabulated D65 spectrum, normalised to Y = 1 → within 1e-3 of white.
    let xyz = spectrum_to_xyz(d65_relative);
    let rgb = xyz_to_linear_srgb(xyz.map(|v| v / xyz[1]));
    for c in rgb {
        assert!((c - 1.0).abs() < 2e-3, "{rgb:?}");
    }
    // IEC 61966-2-1:1999 publishes both matrices to 4 decimals (derived from the same primaries
    // and the D65 xy; Lindbloom's 7-digit matrix differs in the 4th digit because it uses the
    // XYZ white (0.95047, 1, 1.08883) instead of xy (0.3127, 0.3290)).
    let published = [
        [0.4124, 0.3576, 0.1805],
        [0.2126, 0.7152, 0.0722],
        [0.0193, 0.1192, 0.9505],
    ];
    for i in 0..3 {
        for j in 0..3 {
            assert!(
                (SRGB_TO_XYZ[i][j] - published[i][j]).abs() < 1e-4,
                "{i},{j}: {}",
                SRGB_TO_XYZ[i][j]
            );
        }
    }
    let published_inv = [
        [3.2406, -1.5372, -0.4986],
        [-0.9689, 1.8758, 0.0415],
        [0.0557, -0.2040, 1.0570],
    ];
    for i in 0..3 {
        for j in 0..3 {
            assert!(
                (XYZ_TO_SRGB[i][j] - published_inv[i][j]).abs() < 5e-4,
                "{i},{j}: {}",
                XYZ_TO_SRGB[i][j]
            );
        }
    }
    let v = [0.3, 0.7, 0.1];
    let back = linear_srgb_to_xyz(xyz_to_linear_srgb(v));
    for k in 0..3 {
        assert!((back[k] - v[k]).abs() < 1e-14);
    }
    // Luminance row: Y = 0.2126 R + 0.7152 G + 0.0722 B (ITU-R BT.709).
    assert!((SRGB_TO_XYZ[1][0] - 0.2126).abs() < 1e-4 && (SRGB_TO_XYZ[1][1] - 0.7152).abs() < 1e-4);
}

/// sRGB transfer curve (IEC 61966-2-1): fixed points, continuity at the knee, inverse.
#[test]
fn srgb_transfer_curve() {
    assert_eq!(srgb_encode(0.0), 0.0);
    assert!((srgb_encode(1.0) - 1.0).abs() < 1e-12);
    assert!((srgb_encode(2.0) - 1.0).abs() < 1e-12);
    // 18 % grey encodes to ≈ 0.4613 (118/255).
    assert!((srgb_encode(0.18) - 0.46135).abs() < 1e-4);
    // The two pieces meet at the knee to within 1e-7 (the standard's rounding).
    let k = 0.0031308;
    assert!((12.92 * k - (1.055 * f64::powf(k, 1.0 / 2.4) - 0.055)).abs() < 1e-7);
    for i in 0..=1000 {
        let x = i as f64 / 1000.0;
        assert!((srgb_decode(srgb_encode(x)) - x).abs() < 1e-6, "{x}");
    }
    assert_eq!(srgb_encode(f64::NAN), 0.0);
}

#[test]
fn cie_table_is_complete() {
    let (names, cols) =
        read_csv_columns(include_str!("../../data/cie/cie1931_2deg_xyz_1nm.csv")).unwrap();
    assert_eq!(names, ["wavelength_nm", "xbar", "ybar", "zbar"]);
    assert_eq!(cols[0].len(), 471);
    assert_eq!(cols[0][0], LAMBDA_MIN_NM);
    assert_eq!(*cols[0].last().unwrap(), 830.0);
}
