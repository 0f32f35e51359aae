//! Fresnel reflectance and transmittance of a smooth interface, for dielectrics and for
//! complex refractive indices (conductors, absorbing media), and hemispherical moments
//! of the Fresnel reflectance.
//!
//! Conventions used throughout:
//! * `cos_theta_i` is the cosine of the angle between the incident direction and the
//!   surface normal on the incident side (dimensionless, in [0, 1]).
//! * `eta` is the *relative* index n_transmitted / n_incident (dimensionless). For a
//!   complex index, η = n' + i·n'' with n'' ≥ 0 meaning absorption in the transmitting
//!   medium (fields ∝ e^{i(kz − ωt)}).
//! * "s" is the polarisation perpendicular to the plane of incidence (TE), "p" parallel (TM).
//!   Unpolarised reflectance is (R_s + R_p)/2.
//!
//! The formulas are the Fresnel equations written with w = η·cos θ_t = √(η² − sin²θ_i):
//! r_s = (cos θ_i − w)/(cos θ_i + w),  r_p = (η² cos θ_i − w)/(η² cos θ_i + w),
//! which covers total internal reflection (w purely imaginary, |r| = 1) and absorbing media
//! (branch of the square root with Im w ≥ 0, the wave decaying into the medium).

use num_complex::Complex64;

/// Cosine of the refraction angle for a dielectric interface (Snell's law), or `None` under
/// total internal reflection. `cos_theta_i` in [0, 1], `eta` = n_t / n_i.
pub fn cos_theta_transmitted(cos_theta_i: f64, eta: f64) -> Option<f64> {
    let sin2_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        None
    } else {
        Some((1.0 - sin2_t).sqrt())
    }
}

/// Fresnel reflectances (R_s, R_p) of a dielectric interface, `eta` = n_t / n_i > 0.
/// A negative `cos_theta_i` means incidence from the other side (η is then inverted).
/// Total internal reflection gives (1, 1).
pub fn fresnel_dielectric_sp(cos_theta_i: f64, eta: f64) -> (f64, f64) {
    let (cos_i, eta) = if cos_theta_i < 0.0 {
        (-cos_theta_i, 1.0 / eta)
    } else {
        (cos_theta_i, eta)
    };
    let cos_i = cos_i.min(1.0);
    let Some(cos_t) = cos_theta_transmitted(cos_i, eta) else {
        return (1.0, 1.0);
    };
    // r_s = (n_i cos_i − n_t cos_t)/(n_i cos_i + n_t cos_t), r_p = (n_t cos_i − n_i cos_t)/(n_t cos_i + n_i cos_t)
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (r_s * r_s, r_p * r_p)
}

/// Unpolarised Fresnel reflectance of a dielectric interface; `eta` = n_t / n_i.
/// Total internal reflection gives 1. A negative `cos_theta_i` means incidence from the
/// other side of the interface (as in pbrt-v4): η is inverted and |cos θ_i| used.
pub fn fresnel_dielectric(cos_theta_i: f64, eta: f64) -> f64 {
    let (rs, rp) = fresnel_dielectric_sp(cos_theta_i, eta);
    0.5 * (rs + rp)
}

/// Unpolarised Fresnel transmittance of a dielectric interface, T = 1 − R (the fraction of
/// incident power crossing the interface); `eta` = n_t / n_i.
pub fn fresnel_dielectric_transmittance(cos_theta_i: f64, eta: f64) -> f64 {
    1.0 - fresnel_dielectric(cos_theta_i, eta)
}

/// Fresnel reflectances (R_s, R_p) for a complex relative index η = n' + i·n'' (n'' ≥ 0):
/// conductors and absorbing media. `cos_theta_i` is clamped to [0, 1].
pub fn fresnel_complex_sp(cos_theta_i: f64, eta: Complex64) -> (f64, f64) {
    let cos_i = cos_theta_i.clamp(0.0, 1.0);
    let sin2_i = 1.0 - cos_i * cos_i;
    let eta2 = eta * eta;
    // Principal square root: for Re η > 0, Im η ≥ 0 it has Im w ≥ 0 (decaying wave).
    let w = (eta2 - sin2_i).sqrt();
    let ci = Complex64::new(cos_i, 0.0);
    let r_s = (ci - w) / (ci + w);
    let r_p = (eta2 * cos_i - w) / (eta2 * cos_i + w);
    let rs = r_s.norm_sqr();
    let rp = r_p.norm_sqr();
    // At grazing incidence on an index-matched interface both numerator and denominator vanish.
    (if rs.is_finite() { rs } else { 1.0 }, if rp.is_finite() { rp } else { 1.0 })
}

/// Unpolarised Fresnel reflectance for a complex relative index η = n' + i·n''
/// (conductors: η = (eta + i k) / n_ambient from measured optical constants).
pub fn fresnel_complex(cos_theta_i: f64, eta: Complex64) -> f64 {
    let (rs, rp) = fresnel_complex_sp(cos_theta_i, eta);
    0.5 * (rs + rp)
}

/// Unpolarised transmittance 1 − R into an absorbing medium of complex relative index η
/// (the fraction of incident power that crosses the interface and is then absorbed there).
pub fn fresnel_complex_transmittance(cos_theta_i: f64, eta: Complex64) -> f64 {
    1.0 - fresnel_complex(cos_theta_i, eta)
}

/// Hemispherical moment of the dielectric Fresnel reflectance (dimensionless):
///
/// C_order(η) = ∫₀¹ R(μ; η) μ^order dμ,
///
/// with R the unpolarised [`fresnel_dielectric`] reflectance for light incident from the
/// medium of index n_i at cos θ_i = μ and η = n_t / n_i. Computed by numerical quadrature
/// (composite Gauss–Legendre, with the total-internal-reflection part integrated exactly
/// and the square-root kink at the critical angle removed by a change of variable),
/// accurate to about 1e-12.
///
/// Consequences: the diffuse (cosine-weighted hemispherical) Fresnel reflectance is
/// F_dr(η) = 2·C_1(η); the boundary terms of the dipole models are C_φ = (1 − 2C_1)/4 and
/// C_E = (1 − 3C_2)/2. For a medium of relative index n = n_medium/n_outside, light inside
/// hitting the boundary has η = 1/n (e.g. Jensen et al. 2001's F_dr(n) ≈ 2·C_1(1/n), the
/// Egan–Hilgeman fit), and light arriving from outside has η = n.
pub fn fresnel_moment(order: u32, eta: f64) -> f64 {
    assert!(eta > 0.0, "fresnel_moment: eta must be positive");
    let p = order as i32;
    let f = |mu: f64| fresnel_dielectric(mu, eta) * mu.powi(p);
    if eta < 1.0 {
        // TIR for μ < μ_c: R = 1 exactly.
        let mu_c = (1.0 - eta * eta).sqrt();
        let tir = mu_c.powi(p + 1) / (p as f64 + 1.0);
        // μ = μ_c + (1 − μ_c) s², dμ = 2 (1 − μ_c) s ds: smooth in s across the kink.
        let span = 1.0 - mu_c;
        tir + gauss_legendre(0.0, 1.0, 64, |s| f(mu_c + span * s * s) * 2.0 * span * s)
    } else {
        gauss_legendre(0.0, 1.0, 64, f)
    }
}

/// Diffuse Fresnel reflectance F_dr(η) = 2·C_1(η) = ∫ R cos θ dω / π (dimensionless),
/// η = n_t / n_i as in [`fresnel_moment`].
pub fn fresnel_diffuse_reflectance(eta: f64) -> f64 {
    2.0 * fresnel_moment(1, eta)
}

/// Measured optical constants n = η + i·k of a material (conductor) versus vacuum wavelength,
/// linearly interpolated; constant beyond the ends of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct ComplexIor {
    lambda_nm: Vec<f64>,
    eta: Vec<f64>,
    k: Vec<f64>,
}

/// Tables bundled from `data/ior/` (see its README for their sources): name, CSV text.
const BUNDLED_IOR: [(&str, &str); 6] = [
    ("Au", include_str!("../data/ior/Au.csv")),
    ("Ag", include_str!("../data/ior/Ag.csv")),
    ("Cu", include_str!("../data/ior/Cu.csv")),
    ("Al", include_str!("../data/ior/Al.csv")),
    ("Cr", include_str!("../data/ior/Cr.csv")),
    ("Cu_palik", include_str!("../data/ior/Cu_palik.csv")),
];

impl ComplexIor {
    /// Build from a strictly increasing wavelength grid (nm) and the real (η) and imaginary (k)
    /// parts of the index, all finite, k ≥ 0, η > 0.
    pub fn new(lambda_nm: Vec<f64>, eta: Vec<f64>, k: Vec<f64>) -> anyhow::Result<Self> {
        if lambda_nm.is_empty() || lambda_nm.len() != eta.len() || eta.len() != k.len() {
            anyhow::bail!(
                "optical constants: {} wavelengths, {} eta and {} k values (need equal, non-zero counts)",
                lambda_nm.len(),
                eta.len(),
                k.len()
            );
        }
        for i in 0..lambda_nm.len() {
            if !(lambda_nm[i].is_finite() && eta[i].is_finite() && k[i].is_finite() && eta[i] > 0.0 && k[i] >= 0.0) {
                anyhow::bail!("optical constants: row {} (wavelength {} nm): need finite eta > 0 and k >= 0", i + 1, lambda_nm[i]);
            }
            if i > 0 && lambda_nm[i] <= lambda_nm[i - 1] {
                anyhow::bail!("optical constants: wavelengths not increasing at row {}", i + 1);
            }
        }
        Ok(Self { lambda_nm, eta, k })
    }

    /// Parse CSV text with columns `wavelength_nm, eta, k` ('#' comment lines, one header row).
    /// `source` names the file in error messages.
    pub fn parse_csv(text: &str, source: &str) -> anyhow::Result<Self> {
        let (mut l, mut e, mut k) = (Vec::new(), Vec::new(), Vec::new());
        let mut header_seen = false;
        for (no, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            if !header_seen {
                header_seen = true;
                if line.starts_with(|c: char| c.is_ascii_alphabetic()) {
                    continue;
                }
            }
            let v: Vec<&str> = line.split(',').map(str::trim).collect();
            if v.len() < 3 {
                anyhow::bail!("{source}: line {}: expected 3 columns wavelength_nm,eta,k", no + 1);
            }
            let num = |s: &str, what: &str| -> anyhow::Result<f64> {
                s.parse::<f64>().map_err(|_| anyhow::anyhow!("{source}: line {}: {what} {s:?} is not a number", no + 1))
            };
            l.push(num(v[0], "wavelength_nm")?);
            e.push(num(v[1], "eta")?);
            k.push(num(v[2], "k")?);
        }
        Self::new(l, e, k).map_err(|err| anyhow::anyhow!("{source}: {err}"))
    }

    /// A bundled table by name: `Au`, `Ag`, `Cu`, `Al`, `Cr`, `Cu_palik` (case-insensitive;
    /// also `gold`, `silver`, `copper`, `aluminium`/`aluminum`, `chromium`).
    pub fn named(name: &str) -> anyhow::Result<Self> {
        let key = match name.to_ascii_lowercase().as_str() {
            "gold" => "au".to_string(),
            "silver" => "ag".to_string(),
            "copper" => "cu".to_string(),
            "aluminium" | "aluminum" => "al".to_string(),
            "chromium" => "cr".to_string(),
            other => other.to_string(),
        };
        let (file, text) = BUNDLED_IOR
            .iter()
            .find(|(n, _)| n.to_ascii_lowercase() == key)
            .ok_or_else(|| anyhow::anyhow!("unknown conductor {name:?} (known: Au, Ag, Cu, Al, Cr, Cu_palik)"))?;
        Self::parse_csv(text, &format!("data/ior/{file}.csv"))
    }

    /// Wavelength range of the table in nm.
    pub fn range_nm(&self) -> (f64, f64) {
        (self.lambda_nm[0], self.lambda_nm[self.lambda_nm.len() - 1])
    }

    /// Complex index η + i·k at `lambda_nm` (linear interpolation; clamped beyond the table).
    pub fn eval(&self, lambda_nm: f64) -> Complex64 {
        let n = self.lambda_nm.len();
        if n == 1 || lambda_nm <= self.lambda_nm[0] {
            return Complex64::new(self.eta[0], self.k[0]);
        }
        if lambda_nm >= self.lambda_nm[n - 1] {
            return Complex64::new(self.eta[n - 1], self.k[n - 1]);
        }
        let i = self.lambda_nm.partition_point(|&x| x <= lambda_nm) - 1;
        let t = (lambda_nm - self.lambda_nm[i]) / (self.lambda_nm[i + 1] - self.lambda_nm[i]);
        Complex64::new(
            self.eta[i] + t * (self.eta[i + 1] - self.eta[i]),
            self.k[i] + t * (self.k[i + 1] - self.k[i]),
        )
    }
}

/// Sellmeier dispersion of a transparent glass: n²(λ) = 1 + Σᵢ Bᵢ λ² / (λ² − Cᵢ), λ in µm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sellmeier {
    /// Dimensionless coefficients B₁, B₂, B₃.
    pub b: [f64; 3],
    /// Resonance coefficients C₁, C₂, C₃ in µm².
    pub c_um2: [f64; 3],
}

impl Sellmeier {
    /// SCHOTT N-BK7 (data sheet coefficients; n_d = 1.5168, V_d = 64.17).
    pub const N_BK7: Sellmeier = Sellmeier {
        b: [1.039_612_12, 0.231_792_344, 1.010_469_45],
        c_um2: [0.006_000_698_67, 0.020_017_914_4, 103.560_653],
    };
    /// Fused silica (Malitson 1965, J. Opt. Soc. Am. 55:1205; n_d = 1.45846).
    pub const FUSED_SILICA: Sellmeier = Sellmeier {
        b: [0.696_166_3, 0.407_942_6, 0.897_479_4],
        c_um2: [0.068_404_3 * 0.068_404_3, 0.116_241_4 * 0.116_241_4, 9.896_161 * 9.896_161],
    };

    /// A bundled glass by name: `N-BK7`/`BK7`, `fused-silica`/`SiO2` (case-insensitive).
    pub fn named(name: &str) -> anyhow::Result<Self> {
        match name.to_ascii_lowercase().replace(['_', ' '], "-").as_str() {
            "n-bk7" | "bk7" => Ok(Self::N_BK7),
            "fused-silica" | "sio2" | "silica" => Ok(Self::FUSED_SILICA),
            _ => anyhow::bail!("unknown glass {name:?} (known: N-BK7, fused-silica)"),
        }
    }

    /// Refractive index (dimensionless) at the vacuum wavelength `lambda_nm`.
    pub fn index(&self, lambda_nm: f64) -> f64 {
        let l2 = (lambda_nm * 1e-3).powi(2);
        let mut n2 = 1.0;
        for i in 0..3 {
            n2 += self.b[i] * l2 / (l2 - self.c_um2[i]);
        }
        n2.sqrt()
    }
}

/// Composite 8-point Gauss–Legendre quadrature of `f` over [a, b] with `panels` panels.
fn gauss_legendre(a: f64, b: f64, panels: usize, f: impl Fn(f64) -> f64) -> f64 {
    // Nodes and weights of the 8-point rule on [−1, 1] (Abramowitz & Stegun 25.4.30).
    const X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];
    let h = (b - a) / panels as f64;
    let mut sum = 0.0;
    for k in 0..panels {
        let mid = a + (k as f64 + 0.5) * h;
        let half = 0.5 * h;
        for j in 0..4 {
            sum += W[j] * (f(mid - half * X[j]) + f(mid + half * X[j])) * half;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadrature_integrates_polynomials_exactly() {
        // ∫0^1 x^7 dx = 1/8; an 8-point rule is exact to degree 15.
        let v = gauss_legendre(0.0, 1.0, 1, |x| x.powi(15));
        assert!((v - 1.0 / 16.0).abs() < 1e-14, "{v}");
    }
}
