//! The milk model of Frisvad, Christensen & Jensen (ACM TOG 26(3), 2007): bulk optical properties
//! of milk from its content declaration (fat and protein weight percent, homogenization pressure).
//!
//! Host: water (Hale & Querry 1973) with dissolved riboflavin (vitamin B2, 0.17 mg/100 g,
//! PhotochemCAD absorbance scaled to 33000 M⁻¹cm⁻¹ at 266.5 nm). Particles: milk-fat globules
//! (index of Michalski et al. 2001, log-normal sizes whose mean depends on fat content and
//! pressure) and casein micelles (n = 1.503, log-normal in r/(150 nm − r)).
//! Inputs and constants: `crates/optics/data/milk/` (README there). The inputs are tabulated at
//! 375–775 nm; outside that range the end values are held.

use crate::media::{bulk_properties, BulkOptions, BulkProperties, Component, IndexSpectrum};
use crate::particles::{Bins, SizeDistribution};
use anyhow::{bail, Context, Result};
use num_complex::Complex64;
use std::f64::consts::PI;

const INPUTS_CSV: &str = include_str!("../data/milk/frisvad2007_milk_inputs.csv");

/// Density of milk fat, g/mL.
pub const FAT_DENSITY_G_PER_ML: f64 = 0.915;
/// Density of casein, g/mL.
pub const CASEIN_DENSITY_G_PER_ML: f64 = 1.11;
/// Density of milk, g/mL.
pub const MILK_DENSITY_G_PER_ML: f64 = 1.030;
/// Fraction of the milk protein that is casein.
pub const CASEIN_FRACTION_OF_PROTEIN: f64 = 0.76;
/// Default protein content, wt-%.
pub const DEFAULT_PROTEIN_PERCENT: f64 = 3.4;
/// Riboflavin content, g per g of milk (0.17 mg / 100 g).
pub const RIBOFLAVIN_G_PER_G: f64 = 0.17e-3 / 100.0;
/// Molar mass of riboflavin C₁₇H₂₀N₄O₆, g/mol.
pub const RIBOFLAVIN_MOLAR_MASS_G_PER_MOL: f64 = 376.3682;
/// Casein micelles: volume-to-surface mean radius, m.
pub const CASEIN_R_VS_M: f64 = 43e-9;
/// Casein micelles: standard deviation in the transformed variable r/(r_max − r).
pub const CASEIN_C_S: f64 = 0.23;
/// Casein micelles: largest radius, m.
pub const CASEIN_R_MAX_M: f64 = 150e-9;

/// The spectral inputs of the model at their tabulated wavelengths.
#[derive(Clone, Debug, PartialEq)]
pub struct MilkInputs {
    /// Wavelengths, nm.
    pub lambda_nm: Vec<f64>,
    /// Water index (Hale & Querry 1973).
    pub water: Vec<Complex64>,
    /// Molar absorption coefficient of riboflavin, M⁻¹ m⁻¹.
    pub riboflavin_eps_per_molar_m: Vec<f64>,
    /// Milk-fat index (Michalski et al. 2001).
    pub fat: Vec<Complex64>,
    /// Casein index.
    pub casein: Vec<Complex64>,
}

/// Parse the embedded input table.
pub fn inputs() -> Result<MilkInputs> {
    let mut lines = INPUTS_CSV.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#'));
    let header: Vec<&str> = lines.next().context("milk inputs: empty table")?.split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).with_context(|| format!("milk inputs: no column {name}"));
    let (cl, cwr, cwi, ce, cfr, cfi, ccr, cci) = (
        col("wavelength_nm")?,
        col("water_n_real")?,
        col("water_n_imag")?,
        col("riboflavin_eps_M-1_m-1")?,
        col("fat_n_real")?,
        col("fat_n_imag")?,
        col("casein_n_real")?,
        col("casein_n_imag")?,
    );
    let mut out = MilkInputs { lambda_nm: vec![], water: vec![], riboflavin_eps_per_molar_m: vec![], fat: vec![], casein: vec![] };
    for (k, line) in lines.enumerate() {
        let v: Vec<f64> = line
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("milk inputs: row {k}"))?;
        out.lambda_nm.push(v[cl]);
        out.water.push(Complex64::new(v[cwr], v[cwi]));
        out.riboflavin_eps_per_molar_m.push(v[ce]);
        out.fat.push(Complex64::new(v[cfr], v[cfi]));
        out.casein.push(Complex64::new(v[ccr], v[cci]));
    }
    Ok(out)
}

/// Riboflavin molar concentration in milk, mol/L.
pub fn riboflavin_molar() -> f64 {
    // (mass per 100 g / molar mass) / (volume of 100 g of milk in L)
    (RIBOFLAVIN_G_PER_G * 100.0 / RIBOFLAVIN_MOLAR_MASS_G_PER_MOL) / (100.0 / MILK_DENSITY_G_PER_ML * 1e-3)
}

/// Host index: water plus riboflavin absorption, n″ = n″_water + σ_a,ribo λ/(4π), σ_a,ribo = ln10·c·ε.
pub fn host_index(inp: &MilkInputs) -> IndexSpectrum {
    let c = riboflavin_molar();
    let (mut re, mut im) = (vec![], vec![]);
    for i in 0..inp.lambda_nm.len() {
        let sigma_ribo = std::f64::consts::LN_10 * c * inp.riboflavin_eps_per_molar_m[i];
        re.push(inp.water[i].re);
        im.push(inp.water[i].im + sigma_ribo * inp.lambda_nm[i] * 1e-9 / (4.0 * PI));
    }
    IndexSpectrum::Tabulated { lambda_nm: inp.lambda_nm.clone(), re, im }
}

/// Volume fractions (fat, casein) from weight percent: φ = (w/ρ)/(100/ρ_milk), casein 76 % of protein.
pub fn volume_fractions(fat_percent: f64, protein_percent: f64) -> (f64, f64) {
    let per_volume = 100.0 / MILK_DENSITY_G_PER_ML;
    (
        (fat_percent / FAT_DENSITY_G_PER_ML) / per_volume,
        CASEIN_FRACTION_OF_PROTEIN * (protein_percent / CASEIN_DENSITY_G_PER_ML) / per_volume,
    )
}

/// Fat-globule size (r_vs, c_s) in metres for fat content (wt-%) and homogenization pressure (MPa; 0 = unhomogenized).
pub fn fat_size_m(fat_percent: f64, pressure_mpa: f64) -> (f64, f64) {
    let v = fat_percent;
    let r_p50 = 7.481403922e-4 * v * v + 3.203991829e-2 * v + 0.1162155667;
    let r_p0 = if v < 2.0 { -0.2528033794 * v * v + 1.418606759 * v } else { 1.456189142 * v.powf(0.36) };
    let r_um = if pressure_mpa > 0.0 {
        let beta = r_p0.log10();
        let alpha = (beta - r_p50.log10()) / 50f64.log10();
        10f64.powf(-alpha * pressure_mpa.log10() + beta)
    } else {
        r_p0
    };
    let cv = 0.6;
    let r_vs = r_um / (cv * cv + 1.0);
    (r_vs * 1e-6, cv * r_vs * 1e-6)
}

/// Wavelengths (nm) the milk model answers for: its data cover 375–775 nm and hold their end
/// values up to 75 nm below and 125 nm above (the renderer's 360–830 nm inside).
pub const WAVELENGTH_RANGE_NM: [f64; 2] = [300.0, 900.0];

/// Refuses wavelengths (nm) outside [`WAVELENGTH_RANGE_NM`].
pub fn check_wavelengths(lambda_nm: &[f64]) -> Result<()> {
    let [lo, hi] = WAVELENGTH_RANGE_NM;
    if let Some(&l) = lambda_nm.iter().find(|&&l| l.is_nan() || l < lo || l > hi) {
        bail!(
            "wavelength {} nm lies outside the milk model's {lo}–{hi} nm (its data cover 375–775 nm, end values held beyond)",
            crate::numfmt::short(l)
        );
    }
    Ok(())
}

/// Check the content declaration; errors name the argument.
pub fn validate(fat_percent: f64, protein_percent: f64, pressure_mpa: f64) -> Result<()> {
    if !(fat_percent.is_finite() && fat_percent > 0.0 && fat_percent <= 100.0) {
        bail!("--fat-percent must lie in (0, 100], got {fat_percent}");
    }
    if !(protein_percent.is_finite() && (0.0..=100.0).contains(&protein_percent)) {
        bail!("--protein-percent must lie in [0, 100], got {protein_percent}");
    }
    if fat_percent + protein_percent > 100.0 {
        bail!("--fat-percent plus --protein-percent exceed 100 %");
    }
    if !(pressure_mpa.is_finite() && pressure_mpa >= 0.0) {
        bail!("--pressure-mpa must be ≥ 0 (0 = unhomogenized), got {pressure_mpa}");
    }
    let (fat, casein) = volume_fractions(fat_percent, protein_percent);
    if fat + casein > 1.0 {
        bail!("fat and casein volume fractions exceed 1 ({fat:.3} + {casein:.3})");
    }
    Ok(())
}

/// Fat-globule bins as in Frisvad's code: p(r) at r = 0.005, 0.055, …, < 10 µm (dr = 0.05 µm), volume weights.
pub fn fat_bins(fat_percent: f64, pressure_mpa: f64) -> Result<Bins> {
    let (r_vs, c_s) = fat_size_m(fat_percent, pressure_mpa);
    let dist = SizeDistribution::LogNormal { r_vs_m: r_vs, c_s_m: c_s };
    let (phi, _) = volume_fractions(fat_percent, 0.0);
    let (mut radius, mut weight) = (vec![], vec![]);
    let n = 200;
    for i in 0..n {
        let r = (0.005 + 0.025 + 0.05 * i as f64) * 1e-6;
        radius.push(r);
        weight.push(r * r * r * dist.number_density(r));
    }
    let mut bins = Bins::from_volume_weights(&radius, &weight, phi)?;
    // Bins with less than 1e-13 of the volume change σ by less than that: skip them (speed).
    bins.prune(1e-13);
    Ok(bins)
}

/// Casein-micelle bins: r = 0.5, 1.5, …, 149.5 nm, log-normal in t = r/(150 nm − r), volume weights.
pub fn casein_bins(protein_percent: f64) -> Result<Bins> {
    let dist = SizeDistribution::BoundedLogNormal { r_vs_m: CASEIN_R_VS_M, c_s_t: CASEIN_C_S, r_max_m: CASEIN_R_MAX_M };
    let (_, phi) = volume_fractions(0.0, protein_percent);
    let (mut radius, mut weight) = (vec![], vec![]);
    for i in 0..150 {
        let r = (i as f64 + 0.5) * 1e-9;
        radius.push(r);
        weight.push(r * r * r * dist.number_density(r));
    }
    let mut bins = Bins::from_volume_weights(&radius, &weight, phi)?;
    bins.prune(1e-13);
    Ok(bins)
}

/// Host index and the two particle components of a milk.
pub fn milk_components(fat_percent: f64, protein_percent: f64, pressure_mpa: f64) -> Result<(IndexSpectrum, Vec<Component>)> {
    validate(fat_percent, protein_percent, pressure_mpa)?;
    let inp = inputs()?;
    let host = host_index(&inp);
    let table = |v: &[Complex64]| IndexSpectrum::Tabulated {
        lambda_nm: inp.lambda_nm.clone(),
        re: v.iter().map(|c| c.re).collect(),
        im: v.iter().map(|c| c.im).collect(),
    };
    let mut comps = vec![Component { name: "fat".into(), index: table(&inp.fat), bins: fat_bins(fat_percent, pressure_mpa)? }];
    if protein_percent > 0.0 {
        comps.push(Component { name: "casein".into(), index: table(&inp.casein), bins: casein_bins(protein_percent)? });
    }
    Ok((host, comps))
}

/// Bulk properties of milk (σ_s, σ_a, σ_t in m⁻¹, g, and a 181-angle tabulated phase function)
/// at `lambda_nm`, from fat and protein content (wt-%) and homogenization pressure (MPa, 0 = unhomogenized).
pub fn milk_properties(fat_percent: f64, protein_percent: f64, pressure_mpa: f64, lambda_nm: &[f64]) -> Result<BulkProperties> {
    milk_properties_with(fat_percent, protein_percent, pressure_mpa, lambda_nm, &BulkOptions { phase_angles: 181 })
}

/// As [`milk_properties`] with explicit options (e.g. no phase table: `phase_angles: 0`).
pub fn milk_properties_with(
    fat_percent: f64,
    protein_percent: f64,
    pressure_mpa: f64,
    lambda_nm: &[f64],
    options: &BulkOptions,
) -> Result<BulkProperties> {
    let (host, comps) = milk_components(fat_percent, protein_percent, pressure_mpa)?;
    bulk_properties(lambda_nm, &host, &comps, options)
}
