//! Bulk properties and medium recipes: two independent paths, closed forms, convergence, bad input.

#[allow(unused_imports)]
use crate::common::*;

use optics::media::{self, BulkOptions, Component, IndexSpectrum, Recipe};
use optics::mie;
use optics::milk;
use optics::particles::{RadiusGrid, SizeDistribution, Spacing};
use std::f64::consts::PI;



const SKIM: &str = include_str!("../../../../media/skim-milk.toml");

/// The generic recipe path (media/skim-milk.toml) reproduces the dedicated milk model.
#[test]
fn skim_milk_recipe_equals_milk_model() {
    let recipe = Recipe::from_toml(SKIM).unwrap();
    let l = recipe.wavelengths_nm().unwrap();
    assert_eq!(l.len(), 17);
    let a = recipe.bulk_properties(None).unwrap();
    let b = milk::milk_properties_with(0.1, 3.4, 20.0, &l, &BulkOptions::default()).unwrap();
    for i in 0..l.len() {
        assert!(rel(a.sigma_s_per_m[i], b.sigma_s_per_m[i]) < 1e-9, "σs at {}", l[i]);
        assert!(rel(a.sigma_t_per_m[i], b.sigma_t_per_m[i]) < 1e-9, "σt at {}", l[i]);
        assert!(rel(a.sigma_a_per_m[i], b.sigma_a_per_m[i]) < 1e-6, "σa at {}: {} vs {}", l[i], a.sigma_a_per_m[i], b.sigma_a_per_m[i]);
        assert!((a.g[i] - b.g[i]).abs() < 1e-10);
    }
}

/// One particle radius: σ_s = N·C_s and σ_t = N·C_t + 4πn″/λ with N = v / (4πr³/3).
#[test]
fn monodisperse_closed_form() {
    let r = 0.3e-6;
    let v = 0.01;
    let host = c(1.33, 1e-7);
    let np = c(1.5, 1e-4);
    let bins = SizeDistribution::Monodisperse { radius_m: r }.discretize(&media::linear_grid(0.0, 1.0, 1), v).unwrap();
    let comp = Component { name: "p".into(), index: IndexSpectrum::Constant(np), bins };
    let p = media::bulk_properties(&[500.0], &IndexSpectrum::Constant(host), &[comp], &BulkOptions::default()).unwrap();
    let n = v / (4.0 / 3.0 * PI * r * r * r);
    let s = mie::sphere(r, 500e-9, np, host);
    assert!(rel(p.sigma_s_per_m[0], n * s.c_sca_m2) < 1e-12);
    let host_abs = 4.0 * PI * host.im / 500e-9;
    assert!(rel(p.sigma_t_per_m[0], n * s.c_ext_m2 + host_abs) < 1e-12);
    assert!(rel(p.host_sigma_a_per_m[0], host_abs) < 1e-12);
    assert!((p.sigma_a_per_m[0] - (p.sigma_t_per_m[0] - p.sigma_s_per_m[0])).abs() < 1e-9 * p.sigma_t_per_m[0]);
    assert!((p.g[0] - s.eff.g).abs() < 1e-12);
}

/// Host only: σ_s = 0 and σ_a = 4πn″/λ.
#[test]
fn host_only_absorbs() {
    let p = media::bulk_properties(&[400.0, 700.0], &IndexSpectrum::Constant(c(1.33, 2e-8)), &[], &BulkOptions::default()).unwrap();
    for (i, l) in [400e-9, 700e-9].iter().enumerate() {
        assert_eq!(p.sigma_s_per_m[i], 0.0);
        assert!(rel(p.sigma_a_per_m[i], 4.0 * PI * 2e-8 / l) < 1e-12);
    }
}

/// Integration accurate to 0.1 %: refining the radius grid (400 → 3200 log-spaced bins) changes σ_s,
/// σ_t and g by less than 1e-3 for a broad log-normal of large particles (the hard case: resonances).
#[test]
fn radius_integration_converges() {
    let dist = SizeDistribution::LogNormal { r_vs_m: 1.5e-6, c_s_m: 0.9e-6 };
    let host = IndexSpectrum::Constant(c(1.333, 0.0));
    let index = IndexSpectrum::Constant(c(1.46, 1e-5));
    let run = |bins: usize| {
        let grid = dist.default_grid(bins);
        let comp = Component { name: "fat".into(), index: index.clone(), bins: dist.discretize(&grid, 0.03).unwrap() };
        media::bulk_properties(&[450.0, 650.0], &host, &[comp], &BulkOptions::default()).unwrap()
    };
    let coarse = run(400);
    let fine = run(3200);
    for i in 0..2 {
        assert!(rel(coarse.sigma_s_per_m[i], fine.sigma_s_per_m[i]) < 1e-3, "σs {} vs {}", coarse.sigma_s_per_m[i], fine.sigma_s_per_m[i]);
        assert!(rel(coarse.sigma_t_per_m[i], fine.sigma_t_per_m[i]) < 1e-3);
        assert!((coarse.g[i] - fine.g[i]).abs() < 1e-3);
    }
    // and the range ±7 β in ln r is wide enough: widening it changes nothing at 1e-6
    let g = dist.default_grid(800);
    let wide = RadiusGrid { r_min_m: g.r_min_m / 3.0, r_max_m: g.r_max_m * 3.0, bins: 1000, spacing: Spacing::Log };
    let comp = Component { name: "fat".into(), index: index.clone(), bins: dist.discretize(&wide, 0.03).unwrap() };
    let w = media::bulk_properties(&[450.0, 650.0], &host, &[comp], &BulkOptions::default()).unwrap();
    assert!(rel(w.sigma_s_per_m[0], fine.sigma_s_per_m[0]) < 1e-3);
}

/// Dilute small particles: the bulk scattering is N·C_Rayleigh with the Rayleigh phase function.
#[test]
fn dilute_rayleigh_medium() {
    // x ≈ 0.015: Rayleigh holds to O(x²) ≈ 2e-4.
    let r = 1e-9;
    let nh = 1.33;
    let np = c(1.6, 0.0);
    let l = 550e-9;
    let bins = SizeDistribution::Monodisperse { radius_m: r }.discretize(&media::linear_grid(0.0, 1.0, 1), 1e-4).unwrap();
    let comp = Component { name: "tiny".into(), index: IndexSpectrum::Constant(np), bins };
    let p = media::bulk_properties(&[550.0], &IndexSpectrum::Constant(c(nh, 0.0)), &[comp], &BulkOptions { phase_angles: 7 }).unwrap();
    let x = 2.0 * PI * r * nh / l;
    let (qs, _) = mie::rayleigh(x, np / nh);
    let n = 1e-4 / (4.0 / 3.0 * PI * r * r * r);
    assert!(rel(p.sigma_s_per_m[0], n * qs * PI * r * r) < 1e-3, "{} vs {}", p.sigma_s_per_m[0], n * qs * PI * r * r);
    let t = p.phase.unwrap();
    for (j, &mu) in t.cos_theta.iter().enumerate() {
        let pr = 3.0 / (16.0 * PI) * (1.0 + mu * mu);
        assert!(rel(t.per_sr[0][j], pr) < 1e-3);
    }
}

#[test]
fn wavelength_lists() {
    assert_eq!(media::parse_wavelengths_nm("375:775:25").unwrap().len(), 17);
    assert_eq!(media::parse_wavelengths_nm("450,550,650").unwrap(), vec![450.0, 550.0, 650.0]);
    for bad in ["", "a:b:c", "400:300:10", "1:2", "450,-1", "450,nan", "375:775:0"] {
        assert!(media::parse_wavelengths_nm(bad).is_err(), "{bad:?} accepted");
    }
}

fn recipe_error(text: &str) -> String {
    match Recipe::from_toml(text).and_then(|r| r.bulk_properties(Some(&[550.0]))) {
        Ok(_) => panic!("accepted: {text}"),
        Err(e) => format!("{e:#}"),
    }
}

/// Bad recipes give one-line errors naming the field.
#[test]
fn bad_recipes_name_the_field() {
    let base = |particle: &str| format!("[host]\nindex = 1.33\n[[particle]]\nname = \"p\"\n{particle}\n");
    let cases = [
        (base("index = \"1.5+i\"\nvolume_fraction = 0.01\nsize = { distribution = \"monodisperse\", radius_um = 1 }"), "index"),
        (base("index = 1.5\nvolume_fraction = 0.01\nsize = { distribution = \"monodisperse\", radius_um = -1 }"), "radius_um"),
        (base("index = 1.5\nvolume_fraction = 0.01\nsize = { distribution = \"lognormal\", r_vs_um = 0.3, c_s_um = nan }"), "c_s"),
        (base("index = 1.5\nvolume_fraction = 1.5\nsize = { distribution = \"monodisperse\", radius_um = 1 }"), "volume fraction"),
        (base("index = 1.5\nweight_percent = 3\nsize = { distribution = \"monodisperse\", radius_um = 1 }"), "density_g_per_ml"),
        (base("index = 1.5\nvolume_fraction = 0.01\ncolour = 3\nsize = { distribution = \"monodisperse\", radius_um = 1 }"), "colour"),
        (base("index = 1.5\nvolume_fraction = 0.01\nsize = { distribution = \"gamma\", radius_um = 1 }"), "gamma"),
        (base("index = -1.5\nvolume_fraction = 0.01\nsize = { distribution = \"monodisperse\", radius_um = 1 }"), "index"),
        ("[host]\nindex = \"1.33-0.1i\"\n".to_string(), "host.index"),
        ("[host\nindex = 1.33\n".to_string(), "line 1"),
    ];
    for (text, needle) in cases {
        let e = recipe_error(&text);
        assert!(!e.contains('\n'), "multi-line error: {e}");
        assert!(e.contains(needle), "error {e:?} does not name {needle:?}");
    }
    let e = Recipe::load(std::path::Path::new("/nonexistent/recipe.toml")).unwrap_err();
    assert!(format!("{e:#}").contains("/nonexistent/recipe.toml"));
}
