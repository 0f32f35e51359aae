//! Refractive indices of the bundled materials: Sellmeier dispersion of glasses and measured
//! complex indices n = η + i·k of metals (tables in `crates/optics/data/ior/`, see its README).
//!
//! Wavelengths are vacuum wavelengths in nm; indices are dimensionless. The tables are compiled
//! into the library, so nothing is read from disk at run time.

use crate::spectrum::{read_csv_columns, Tabulated};
use anyhow::{bail, Context, Result};
pub use num_complex::Complex64;

const GLASS_CSV: &str = include_str!("../data/ior/glass_sellmeier.csv");
const METALS: &[(&str, &str, &str)] = &[
    ("au", "gold", include_str!("../data/ior/Au.csv")),
    ("ag", "silver", include_str!("../data/ior/Ag.csv")),
    ("cu", "copper", include_str!("../data/ior/Cu.csv")),
    ("al", "aluminium", include_str!("../data/ior/Al.csv")),
    ("cr", "chromium", include_str!("../data/ior/Cr.csv")),
];

/// Sellmeier dispersion n²(λ) = 1 + Σᵢ Bᵢ λ²/(λ² − Cᵢ), λ in µm, Cᵢ in µm².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sellmeier {
    /// Dimensionless oscillator strengths B₁..B₃.
    pub b: [f64; 3],
    /// Resonance wavelengths squared C₁..C₃, µm².
    pub c_um2: [f64; 3],
}

impl Sellmeier {
    /// Refractive index at the vacuum wavelength `lambda_nm` (nm).
    pub fn n(&self, lambda_nm: f64) -> f64 {
        let l2 = (lambda_nm * 1e-3).powi(2);
        let mut n2 = 1.0;
        for i in 0..3 {
            n2 += self.b[i] * l2 / (l2 - self.c_um2[i]);
        }
        n2.max(0.0).sqrt()
    }
}

/// Names accepted by [`glass`] (case-insensitive).
pub const GLASS_NAMES: &[&str] = &["bk7", "n-bk7", "fused_silica", "silica", "sio2"];

/// Sellmeier coefficients of a bundled glass: `bk7` (SCHOTT N-BK7) or `fused_silica` (Malitson 1965).
pub fn glass(name: &str) -> Result<Sellmeier> {
    let key = name.to_ascii_lowercase();
    let row_prefix = match key.as_str() {
        "bk7" | "n-bk7" | "nbk7" => "N-BK7",
        "fused_silica" | "fused-silica" | "silica" | "sio2" => "Fused silica",
        _ => bail!("unknown glass `{name}` (known: bk7, fused_silica)"),
    };
    let line = GLASS_CSV
        .lines()
        .find(|l| l.starts_with(row_prefix))
        .with_context(|| format!("glass table has no row `{row_prefix}`"))?;
    let fields: Vec<&str> = line.split(',').collect();
    let num = |i: usize| -> Result<f64> {
        fields
            .get(i)
            .and_then(|s| s.trim().parse::<f64>().ok())
            .with_context(|| format!("glass table row `{row_prefix}`: column {} is not a number", i + 1))
    };
    Ok(Sellmeier {
        b: [num(1)?, num(2)?, num(3)?],
        c_um2: [num(4)?, num(5)?, num(6)?],
    })
}

/// Measured complex refractive index n = η + i·k of a metal, linear in wavelength between samples.
#[derive(Clone, Debug)]
pub struct ComplexIor {
    eta: Tabulated,
    k: Tabulated,
}

impl ComplexIor {
    /// Builds the index from columns `wavelength_nm, eta, k` of a CSV text.
    pub fn from_csv(text: &str) -> Result<ComplexIor> {
        let (names, cols) = read_csv_columns(text)?;
        let col = |n: &str| {
            names
                .iter()
                .position(|x| x == n)
                .with_context(|| format!("CSV has no column `{n}`"))
        };
        let (ie, ik) = (col("eta")?, col("k")?);
        Ok(ComplexIor {
            eta: Tabulated::new(cols[0].clone(), cols[ie].clone())?,
            k: Tabulated::new(cols[0].clone(), cols[ik].clone())?,
        })
    }

    /// (η, k) at `lambda_nm`, clamped to the end values outside the tabulated range.
    pub fn eta_k(&self, lambda_nm: f64) -> (f64, f64) {
        let l = self.eta.lambda_nm();
        let x = lambda_nm.clamp(l[0], l[l.len() - 1]);
        (self.eta.eval(x), self.k.eval(x))
    }

    /// n = η + i·k at `lambda_nm`.
    pub fn at(&self, lambda_nm: f64) -> Complex64 {
        let (e, k) = self.eta_k(lambda_nm);
        Complex64::new(e, k)
    }

    /// Tabulated wavelengths, nm.
    pub fn lambda_nm(&self) -> &[f64] {
        self.eta.lambda_nm()
    }
}

/// Names accepted by [`metal`] (case-insensitive; chemical symbol or English name).
pub const METAL_NAMES: &[&str] = &["au", "ag", "cu", "al", "cr"];

/// Measured complex index of a bundled metal: `au`, `ag`, `cu`, `al`, `cr` (or `gold`, `silver`, …).
pub fn metal(name: &str) -> Result<ComplexIor> {
    let key = name.to_ascii_lowercase();
    let key = if key == "aluminum" {
        "aluminium".to_string()
    } else {
        key
    };
    for (sym, long, text) in METALS {
        if key == *sym || key == *long {
            return ComplexIor::from_csv(text).with_context(|| format!("bundled table for metal `{sym}`"));
        }
    }
    bail!("unknown metal `{name}` (known: au, ag, cu, al, cr)")
}

/// Unpolarised reflectance of a conductor with complex relative index η + i·k at incidence
/// cosine `cos_theta_i` (wrapper of [`crate::fresnel::fresnel_complex`] taking reals).
pub fn conductor_reflectance(cos_theta_i: f64, eta: f64, k: f64) -> f64 {
    crate::fresnel::fresnel_complex(cos_theta_i, Complex64::new(eta, k))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bk7_matches_catalogue() {
        // SCHOTT N-BK7: n_d(587.56 nm) = 1.5168, n_F(486.13) = 1.52238, n_C(656.27) = 1.51432 (catalogue values).
        let g = glass("BK7").unwrap();
        assert!((g.n(587.56) - 1.5168).abs() < 5e-5);
        assert!((g.n(486.13) - 1.52238).abs() < 5e-5);
        assert!((g.n(656.27) - 1.51432).abs() < 5e-5);
        assert!(glass("unobtainium").is_err());
    }

    #[test]
    fn metals_load_and_interpolate() {
        for m in METAL_NAMES {
            let t = metal(m).unwrap();
            for l in [360.0, 500.0, 650.0, 830.0] {
                let (e, k) = t.eta_k(l);
                assert!(e > 0.0 && k > 0.0, "{m} at {l}: {e} {k}");
            }
        }
        // A tabulated row of Au.csv is reproduced exactly: 298.757050 nm → 1.795, 1.920375.
        let au = metal("gold").unwrap();
        let (e, k) = au.eta_k(298.757050);
        assert!((e - 1.795).abs() < 1e-9 && (k - 1.920375).abs() < 1e-9);
        assert!(metal("xx").is_err());
    }
}
