//! Colorimetry: CIE 1931 2° colour-matching functions (1-nm table, 360–830 nm), spectrum → XYZ with
//! the pbrt-v4 / Mitsuba 3 normalisation XYZ = ∫S (x̄, ȳ, z̄) dλ / ∫ȳ dλ, XYZ ↔ linear sRGB (D65),
//! chromaticity xy and the sRGB transfer curve (IEC 61966-2-1).

// NaN-rejecting comparisons (`!(x > 0.0)`) are deliberate.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use std::sync::OnceLock;

/// Shortest wavelength of the visible range used for colour (nm), start of the CIE table.
pub const LAMBDA_MIN_NM: f64 = 360.0;
/// Longest wavelength of the visible range used for colour (nm), end of the CIE table.
pub const LAMBDA_MAX_NM: f64 = 830.0;
/// Number of 1-nm samples in [`LAMBDA_MIN_NM`], [`LAMBDA_MAX_NM`] inclusive.
pub const N_DENSE: usize = 471;

/// Σ ȳ(λ)·1 nm over the embedded CIE 1931 2° 1-nm table, 360–830 nm (nm); the test suite recomputes
/// it. (pbrt-v4 quotes 106.856895 for its copy of the table, 2e-7 relative lower.)
pub const CIE_Y_INTEGRAL: f64 = 106.856_917_101_172;

/// The embedded CIE 1931 2° table, parsed once: (x̄, ȳ, z̄) at 360 + i nm.
fn cmf_table() -> &'static [[f64; 3]] {
    static T: OnceLock<Vec<[f64; 3]>> = OnceLock::new();
    T.get_or_init(|| {
        let text = include_str!("../data/cie/cie1931_2deg_xyz_1nm.csv");
        let (_, cols) =
            crate::csv::read_csv_columns(text).expect("embedded CIE table is valid");
        assert_eq!(cols[0].len(), N_DENSE, "embedded CIE table has 471 rows");
        (0..N_DENSE)
            .map(|i| {
                debug_assert_eq!(cols[0][i], LAMBDA_MIN_NM + i as f64);
                [cols[1][i], cols[2][i], cols[3][i]]
            })
            .collect()
    })
}

/// CIE 1931 2° colour-matching functions (x̄, ȳ, z̄) at `lambda_nm`, linearly interpolated in the
/// 1-nm table; 0 outside 360–830 nm.
pub fn cie_1931_xyz_bar(lambda_nm: f64) -> [f64; 3] {
    let x = lambda_nm - LAMBDA_MIN_NM;
    if !(x >= 0.0 && x <= (N_DENSE - 1) as f64) {
        return [0.0; 3];
    }
    let t = cmf_table();
    let i = (x as usize).min(N_DENSE - 2);
    let f = x - i as f64;
    let (a, b) = (t[i], t[i + 1]);
    [0, 1, 2].map(|k| a[k] * (1.0 - f) + b[k] * f)
}

/// The 1-nm CMF table itself (index i ↔ 360 + i nm), for renderers that integrate by summation.
pub fn cie_1931_table() -> &'static [[f64; 3]] {
    cmf_table()
}

/// XYZ of a spectrum, ∫S(λ)(x̄, ȳ, z̄)(λ)dλ / ∫ȳ(λ)dλ, by summation at 1 nm over 360–830 nm.
/// A spectrum equal to 1 everywhere has Y = 1.
pub fn spectrum_to_xyz(f: impl Fn(f64) -> f64) -> [f64; 3] {
    let t = cmf_table();
    let mut xyz = [0.0; 3];
    for (i, bar) in t.iter().enumerate() {
        let s = f(LAMBDA_MIN_NM + i as f64);
        for k in 0..3 {
            xyz[k] += s * bar[k];
        }
    }
    xyz.map(|v| v / CIE_Y_INTEGRAL)
}

/// Chromaticity coordinates of the sRGB primaries (R, G, B) and of the D65 white, IEC 61966-2-1.
pub const SRGB_PRIMARIES_XY: [[f64; 2]; 3] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
/// D65 white point chromaticity as used by sRGB (IEC 61966-2-1).
pub const D65_WHITE_XY: [f64; 2] = [0.3127, 0.3290];

const fn xy_to_xyz_y1(xy: [f64; 2]) -> [f64; 3] {
    [xy[0] / xy[1], 1.0, (1.0 - xy[0] - xy[1]) / xy[1]]
}

const fn det3(m: [[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

const fn inverse3(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let d = det3(m);
    [
        [
            (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / d,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / d,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / d,
        ],
        [
            (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / d,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / d,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / d,
        ],
        [
            (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / d,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / d,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / d,
        ],
    ]
}

const fn mul3(m: [[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// Builds the linear-sRGB → XYZ matrix from the primaries and white point (columns: XYZ of R, G, B
/// scaled so that RGB (1, 1, 1) is the D65 white with Y = 1).
const fn srgb_to_xyz_matrix() -> [[f64; 3]; 3] {
    let r = xy_to_xyz_y1(SRGB_PRIMARIES_XY[0]);
    let g = xy_to_xyz_y1(SRGB_PRIMARIES_XY[1]);
    let b = xy_to_xyz_y1(SRGB_PRIMARIES_XY[2]);
    let p = [[r[0], g[0], b[0]], [r[1], g[1], b[1]], [r[2], g[2], b[2]]];
    let s = mul3(inverse3(p), xy_to_xyz_y1(D65_WHITE_XY));
    [
        [p[0][0] * s[0], p[0][1] * s[1], p[0][2] * s[2]],
        [p[1][0] * s[0], p[1][1] * s[1], p[1][2] * s[2]],
        [p[2][0] * s[0], p[2][1] * s[1], p[2][2] * s[2]],
    ]
}

/// Linear sRGB (D65) → CIE XYZ, derived from the IEC 61966-2-1 primaries at compile time.
pub const SRGB_TO_XYZ: [[f64; 3]; 3] = srgb_to_xyz_matrix();
/// CIE XYZ → linear sRGB (D65), the exact inverse of [`SRGB_TO_XYZ`].
pub const XYZ_TO_SRGB: [[f64; 3]; 3] = inverse3(SRGB_TO_XYZ);

/// CIE XYZ → linear sRGB primaries, D65 white (no clamping: out-of-gamut colours go negative).
#[inline]
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    mul3(XYZ_TO_SRGB, xyz)
}

/// Linear sRGB (D65) → CIE XYZ.
#[inline]
pub fn linear_srgb_to_xyz(rgb: [f64; 3]) -> [f64; 3] {
    mul3(SRGB_TO_XYZ, rgb)
}

/// Linear sRGB (D65) → CIE 1976 L*a*b* relative to the D65 white of Y = 1 (RGB (1,1,1) ↦ L* = 100).
pub fn linear_srgb_to_lab(rgb: [f64; 3]) -> [f64; 3] {
    let m = &SRGB_TO_XYZ;
    let xyz: [f64; 3] = std::array::from_fn(|r| m[r][0] * rgb[0] + m[r][1] * rgb[1] + m[r][2] * rgb[2]);
    let white: [f64; 3] = std::array::from_fn(|r| m[r][0] + m[r][1] + m[r][2]);
    xyz_to_lab(xyz, white)
}

/// CIE XYZ → CIE 1976 L*a*b* relative to `white_xyz` (CIE 15:2004 formulas).
pub fn xyz_to_lab(xyz: [f64; 3], white_xyz: [f64; 3]) -> [f64; 3] {
    const DELTA: f64 = 6.0 / 29.0;
    let f = |t: f64| {
        if t > DELTA * DELTA * DELTA {
            t.cbrt()
        } else {
            t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
        }
    };
    let fx = f(xyz[0] / white_xyz[0]);
    let fy = f(xyz[1] / white_xyz[1]);
    let fz = f(xyz[2] / white_xyz[2]);
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// Chromaticity (x, y) = (X, Y)/(X + Y + Z); (0, 0) for black.
pub fn xyz_to_xy(xyz: [f64; 3]) -> [f64; 2] {
    let s = xyz[0] + xyz[1] + xyz[2];
    if s == 0.0 || !s.is_finite() {
        return [0.0, 0.0];
    }
    [xyz[0] / s, xyz[1] / s]
}

/// sRGB transfer curve (IEC 61966-2-1): linear [0, 1] → encoded [0, 1]; input clamped to [0, 1].
pub fn srgb_encode(linear: f64) -> f64 {
    let v = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse sRGB transfer curve: encoded [0, 1] → linear [0, 1]; input clamped to [0, 1].
pub fn srgb_decode(encoded: f64) -> f64 {
    let v = if encoded.is_nan() {
        0.0
    } else {
        encoded.clamp(0.0, 1.0)
    };
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}
