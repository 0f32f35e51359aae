//! Product analysis: milk composition from optical property spectra, round trip through the
//! milk model of Frisvad et al. 2007 (optics::milk) with 1 % multiplicative noise.

use optics::fitting::{fit_milk, milk_model_spectra, MilkSpectra};

fn noise(seed: &mut u64) -> f64 {
    // SplitMix64 → uniform → approximately normal (sum of 12 uniforms − 6).
    let mut s = 0.0;
    for _ in 0..12 {
        *seed = seed.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = *seed;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        s += ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64;
    }
    s - 6.0
}

#[test]
fn fat_content_and_pressure_are_recovered_from_noisy_model_spectra() {
    let lambda: Vec<f64> = (0..8).map(|k| 400.0 + 50.0 * k as f64).collect();
    let mut seed = 42u64;
    // (fat wt-%, pressure MPa): skim, low-fat and whole milk, homogenized at typical pressures.
    for &(fat, p) in &[(0.1, 20.0), (1.5, 15.0), (3.5, 10.0)] {
        let (sp, sa) = milk_model_spectra(fat, 3.4, p, &lambda).unwrap();
        let spectra = MilkSpectra {
            lambda_nm: lambda.clone(),
            sigma_s_prime_per_mm: sp.iter().map(|v| v * (1.0 + 0.01 * noise(&mut seed))).collect(),
            sigma_a_per_mm: Some(sa.iter().map(|v| v * (1.0 + 0.01 * noise(&mut seed))).collect()),
        };
        let f = fit_milk(&spectra, 3.4).unwrap();
        eprintln!("fat {fat} p {p}: {f:?}");
        assert!((f.fat_percent - fat).abs() < 0.2, "fat {fat}: {f:?}");
        // The truth lies within 1.5 half-widths of the 95 % interval (≈ 3σ; intervals are in
        // fat and in ln pressure).
        let hf = 0.5 * (f.fat_percent_ci[1] - f.fat_percent_ci[0]);
        assert!((f.fat_percent - fat).abs() < 1.5 * hf, "fat {fat} far outside CI: {f:?}");
        let hp = 0.5 * (f.pressure_mpa_ci[1] / f.pressure_mpa_ci[0]).ln();
        assert!((f.pressure_mpa / p).ln().abs() < 1.5 * hp, "pressure {p} far outside CI: {f:?}");
        assert!(f.residual_rms < 0.02, "{f:?}");
    }
}

#[test]
fn noise_free_spectra_are_fitted_exactly() {
    let lambda: Vec<f64> = (0..6).map(|k| 425.0 + 60.0 * k as f64).collect();
    let (sp, _) = milk_model_spectra(2.7, 3.4, 25.0, &lambda).unwrap();
    let s = MilkSpectra { lambda_nm: lambda, sigma_s_prime_per_mm: sp, sigma_a_per_mm: None };
    let f = fit_milk(&s, 3.4).unwrap();
    assert!((f.fat_percent - 2.7).abs() < 1e-3 && (f.pressure_mpa / 25.0 - 1.0).abs() < 1e-3, "{f:?}");
    assert!(f.residual_rms < 1e-5, "{f:?}");
}

#[test]
fn too_few_wavelengths_are_refused() {
    let s = MilkSpectra { lambda_nm: vec![500.0, 600.0], sigma_s_prime_per_mm: vec![1.0, 0.9], sigma_a_per_mm: None };
    assert!(fit_milk(&s, 3.4).unwrap_err().to_string().contains("at least 3 wavelengths"));
}

#[test]
fn particle_radius_and_volume_fraction_are_recovered_from_a_recipe() {
    // Polystyrene beads in water (media/polystyrene-beads.toml: r_vs = 0.5 µm, φ = 0.1 %):
    // spectra at r_vs = 0.3 µm, φ = 0.2 % with 1 % noise, fitted from the recipe.
    use optics::fitting::fit_recipe_particle;
    use optics::media::Recipe;
    let text = include_str!("../../../../media/polystyrene-beads.toml");
    let recipe = Recipe::from_toml(text).unwrap();
    let lambda: Vec<f64> = (0..7).map(|k| 420.0 + 55.0 * k as f64).collect();
    let mut truth = recipe.clone();
    truth.particles[0].volume_fraction = Some(0.002);
    truth.particles[0].size = optics::media::SizeSpec::Lognormal { r_vs_um: 0.3, c_s_um: 0.006 };
    let b = truth.bulk_properties(Some(&lambda)).unwrap();
    let mut seed = 7u64;
    let sp: Vec<f64> = (0..lambda.len()).map(|i| b.sigma_s_per_m[i] * (1.0 - b.g[i]) * 1e-3 * (1.0 + 0.01 * noise(&mut seed))).collect();
    let s = MilkSpectra { lambda_nm: lambda, sigma_s_prime_per_mm: sp, sigma_a_per_mm: None };
    let f = fit_recipe_particle(&recipe, "polystyrene", &s).unwrap();
    eprintln!("{f:?}");
    assert!((f.radius_um / 0.3 - 1.0).abs() < 0.03, "{f:?}");
    assert!((f.volume_fraction / 0.002 - 1.0).abs() < 0.05, "{f:?}");
    assert!(f.radius_um_ci[0] < f.radius_um && f.radius_um < f.radius_um_ci[1]);
    assert!(fit_recipe_particle(&recipe, "nope", &s).unwrap_err().to_string().contains("polystyrene"));
}
