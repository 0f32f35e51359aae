//! Size distributions: scaling to a volume fraction and closed-form moments.

use optics::particles::{RadiusGrid, SizeDistribution, Spacing};
use std::f64::consts::PI;

/// N = N̂·v/v̂ makes (4π/3)Σr³N equal the requested volume fraction.
#[test]
fn scaled_to_volume_fraction() {
    for d in [
        SizeDistribution::LogNormal { r_vs_m: 0.3e-6, c_s_m: 0.18e-6 },
        SizeDistribution::BoundedLogNormal { r_vs_m: 43e-9, c_s_t: 0.23, r_max_m: 150e-9 },
        SizeDistribution::Tabulated { radius_m: vec![1e-7, 2e-7, 5e-7], number_density: vec![1.0, 3.0, 0.5] },
        SizeDistribution::Monodisperse { radius_m: 1e-6 },
    ] {
        let b = d.discretize(&d.default_grid(300), 0.037).unwrap();
        assert!((b.volume_fraction() - 0.037).abs() < 1e-14, "{d:?}");
    }
}

/// Frisvad et al. 2007 log-normal (volume weights p(r), mean r_vs, s.d. c_s): the volume-weighted
/// mean radius Σr⁴N/Σr³N is r_vs and the volume-weighted variance is c_s² (closed-form moments).
#[test]
fn lognormal_moments() {
    let (r_vs, c_s) = (0.3e-6, 0.18e-6);
    let d = SizeDistribution::LogNormal { r_vs_m: r_vs, c_s_m: c_s };
    let b = d.discretize(&d.default_grid(4000), 0.01).unwrap();
    let (mut v, mut m1, mut m2) = (0.0, 0.0, 0.0);
    for (r, n) in b.radius_m.iter().zip(&b.number_per_m3) {
        let w = r * r * r * n;
        v += w;
        m1 += w * r;
        m2 += w * r * r;
    }
    let mean = m1 / v;
    let sd = (m2 / v - mean * mean).sqrt();
    assert!(((mean - r_vs) / r_vs).abs() < 1e-6, "mean {mean}");
    assert!(((sd - c_s) / c_s).abs() < 1e-5, "sd {sd}");
}

/// Constant N̂ on [a, b]: total number = v / ((4π/3)(b⁴−a⁴)/(4(b−a))).
#[test]
fn tabulated_uniform_closed_form() {
    let (a, bb) = (1e-7, 4e-7);
    let d = SizeDistribution::Tabulated { radius_m: vec![a, bb], number_density: vec![2.0, 2.0] };
    let grid = RadiusGrid { r_min_m: a, r_max_m: bb, bins: 2000, spacing: Spacing::Linear };
    let bins = d.discretize(&grid, 0.01).unwrap();
    let total: f64 = bins.number_per_m3.iter().sum();
    let expect = 0.01 / (4.0 * PI / 3.0 * (bb.powi(4) - a.powi(4)) / (4.0 * (bb - a)));
    assert!(((total - expect) / expect).abs() < 1e-6, "{total} vs {expect}");
}

#[test]
fn bad_distributions_are_errors() {
    let g = RadiusGrid { r_min_m: 1e-8, r_max_m: 1e-5, bins: 10, spacing: Spacing::Log };
    for d in [
        SizeDistribution::LogNormal { r_vs_m: -1e-6, c_s_m: 1e-7 },
        SizeDistribution::LogNormal { r_vs_m: f64::NAN, c_s_m: 1e-7 },
        SizeDistribution::Monodisperse { radius_m: -1.0 },
        SizeDistribution::Tabulated { radius_m: vec![2e-7, 1e-7], number_density: vec![1.0, 1.0] },
        SizeDistribution::Tabulated { radius_m: vec![1e-7, 2e-7], number_density: vec![1.0, -1.0] },
        SizeDistribution::BoundedLogNormal { r_vs_m: 2e-7, c_s_t: 0.2, r_max_m: 1e-7 },
    ] {
        assert!(d.discretize(&g, 0.01).is_err(), "{d:?}");
    }
    let d = SizeDistribution::LogNormal { r_vs_m: 1e-6, c_s_m: 1e-7 };
    assert!(d.discretize(&g, 1.5).is_err());
    assert!(d.discretize(&RadiusGrid { r_min_m: 0.0, r_max_m: 1e-5, bins: 10, spacing: Spacing::Log }, 0.1).is_err());
}
