//! Phase functions: normalisation over the sphere, mean cosine g (closed form and by
//! sampling), and that sampling follows the evaluated density (binned chi-square-like check).

use optics::phase::{HenyeyGreenstein, TabulatedPhase};
use std::f64::consts::PI;

/// Tiny deterministic generator for the tests (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// 2π ∫_{-1}^{1} f(μ) μ^k dμ by composite Simpson with many panels.
fn sphere_moment(f: impl Fn(f64) -> f64, k: i32) -> f64 {
    let n = 200_000;
    let h = 2.0 / n as f64;
    let mut s = 0.0;
    for i in 0..=n {
        let x = -1.0 + i as f64 * h;
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        s += w * f(x) * x.powi(k);
    }
    2.0 * PI * s * h / 3.0
}

#[test]
fn hg_is_normalised_and_has_mean_cosine_g() {
    for &g in &[-0.9, -0.3, 0.0, 0.5, 0.75, 0.9] {
        let hg = HenyeyGreenstein { g };
        assert!(
            (sphere_moment(|m| hg.eval(m), 0) - 1.0).abs() < 1e-6,
            "g {g}"
        );
        assert!((sphere_moment(|m| hg.eval(m), 1) - g).abs() < 1e-6, "g {g}");
    }
    // Isotropic: 1/(4π).
    assert!((HenyeyGreenstein { g: 0.0 }.eval(0.3) - 1.0 / (4.0 * PI)).abs() < 1e-15);
}

#[test]
fn hg_sampling_matches_g_and_second_moment() {
    // ⟨cos θ⟩ = g and ⟨cos²θ⟩ = (1 + 2g²)/3 for HG; tolerance 4 standard errors.
    let n = 400_000;
    for &g in &[-0.7, 0.0, 0.3, 0.75, 0.95] {
        let hg = HenyeyGreenstein { g };
        let mut rng = Rng(12345 + (g * 100.0) as u64);
        let (mut s1, mut s2, mut s4) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let c = hg.sample_cos_theta(rng.next());
            assert!((-1.0..=1.0).contains(&c));
            s1 += c;
            s2 += c * c;
            s4 += c * c * c * c;
        }
        let m1 = s1 / n as f64;
        let m2 = s2 / n as f64;
        let se1 = ((m2 - m1 * m1) / n as f64).sqrt();
        let se2 = ((s4 / n as f64 - m2 * m2) / n as f64).sqrt();
        assert!(
            (m1 - g).abs() < 4.0 * se1 + 1e-12,
            "g {g}: mean {m1} ± {se1}"
        );
        let expect2 = (1.0 + 2.0 * g * g) / 3.0;
        assert!(
            (m2 - expect2).abs() < 4.0 * se2 + 1e-12,
            "g {g}: ⟨μ²⟩ {m2} vs {expect2} ± {se2}"
        );
    }
}

#[test]
fn hg_inverse_cdf_is_exact() {
    // The CDF of μ is ∫_{-1}^{μ} 2π p dμ'; check F(sample(u)) = u on a grid.
    for &g in &[-0.5, 0.2, 0.8, 0.99] {
        let hg = HenyeyGreenstein { g };
        let cdf = |mu: f64| {
            // closed form: (1 − g²)/(2g) [ (1 + g² − 2gμ)^{-1/2} − 1/(1 + g) ]
            (1.0 - g * g) / (2.0 * g)
                * (1.0 / (1.0 + g * g - 2.0 * g * mu).sqrt() - 1.0 / (1.0 + g))
        };
        for k in 0..=20 {
            let u = k as f64 / 20.0;
            let mu = hg.sample_cos_theta(u);
            assert!((cdf(mu) - u).abs() < 1e-9, "g {g} u {u}: F = {}", cdf(mu));
        }
    }
}

fn histogram_matches(sample: impl Fn(f64) -> f64, eval: impl Fn(f64) -> f64, seed: u64) {
    let bins = 50;
    let n = 500_000;
    let mut counts = vec![0u64; bins];
    let mut rng = Rng(seed);
    for _ in 0..n {
        let c = sample(rng.next());
        let b = (((c + 1.0) * 0.5 * bins as f64) as usize).min(bins - 1);
        counts[b] += 1;
    }
    let mut chi2 = 0.0;
    for (b, &c) in counts.iter().enumerate() {
        let lo = -1.0 + 2.0 * b as f64 / bins as f64;
        let hi = lo + 2.0 / bins as f64;
        // Expected probability: Simpson over the bin of 2π p.
        let m = 64;
        let h = (hi - lo) / m as f64;
        let mut p = 0.0;
        for i in 0..=m {
            let w = if i == 0 || i == m {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            p += w * 2.0 * PI * eval(lo + i as f64 * h);
        }
        let expect = p * h / 3.0 * n as f64;
        chi2 += (c as f64 - expect).powi(2) / expect;
    }
    // 49 degrees of freedom: the 99.9 % quantile is 85.4.
    assert!(chi2 < 85.4, "chi-square {chi2} with 49 dof");
}

#[test]
fn hg_sampling_histogram_matches_eval() {
    for (i, &g) in [-0.4, 0.0, 0.6].iter().enumerate() {
        let hg = HenyeyGreenstein { g };
        histogram_matches(|u| hg.sample_cos_theta(u), |m| hg.eval(m), 7 + i as u64);
    }
}

#[test]
fn tabulated_phase_reproduces_hg() {
    // Two independent representations: the tabulated HG on 2001 points against the closed form.
    let g = 0.6;
    let hg = HenyeyGreenstein { g };
    let tab = TabulatedPhase::from_fn(2001, |m| hg.eval(m)).unwrap();
    assert!((tab.g() - g).abs() < 1e-4, "tabulated g {}", tab.g());
    assert!((sphere_moment(|m| tab.eval(m), 0) - 1.0).abs() < 1e-6);
    for k in 0..=10 {
        let mu = -1.0 + 0.2 * k as f64;
        assert!((tab.eval(mu) - hg.eval(mu)).abs() / hg.eval(mu) < 1e-3);
    }
    histogram_matches(|u| tab.sample_cos_theta(u), |m| tab.eval(m), 99);
}

#[test]
fn tabulated_phase_sampling_is_its_inverse_cdf() {
    // A strongly peaked, unnormalised table (Rayleigh-like times a forward lobe).
    let mu: Vec<f64> = (0..=100).map(|i| -1.0 + 0.02 * i as f64).collect();
    let v: Vec<f64> = mu
        .iter()
        .map(|m| (1.0 + m * m) * (1.0 + 20.0 * m.max(0.0).powi(8)))
        .collect();
    let tab = TabulatedPhase::new(mu.clone(), v).unwrap();
    // Mean cosine by sampling vs the exact piecewise-linear moment.
    let mut rng = Rng(5);
    let n = 400_000;
    let (mut s1, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let c = tab.sample_cos_theta(rng.next());
        s1 += c;
        s2 += c * c;
    }
    let m1 = s1 / n as f64;
    let se = ((s2 / n as f64 - m1 * m1) / n as f64).sqrt();
    assert!(
        (m1 - tab.g()).abs() < 4.0 * se,
        "{m1} vs {} ± {se}",
        tab.g()
    );
    // Monotone and hitting the ends.
    assert!((tab.sample_cos_theta(0.0) + 1.0).abs() < 1e-12);
    assert!((tab.sample_cos_theta(1.0) - 1.0).abs() < 1e-12);
    let mut prev = -1.0;
    for k in 0..=1000 {
        let c = tab.sample_cos_theta(k as f64 / 1000.0);
        assert!(c >= prev - 1e-15);
        prev = c;
    }
}

#[test]
fn tabulated_phase_rejects_bad_tables() {
    assert!(TabulatedPhase::new(vec![-1.0, 0.0, 1.0], vec![1.0, 1.0]).is_err());
    assert!(TabulatedPhase::new(vec![-1.0, 0.5, 0.5, 1.0], vec![1.0; 4]).is_err());
    assert!(TabulatedPhase::new(vec![-1.0, 1.0], vec![1.0, -1.0]).is_err());
    assert!(TabulatedPhase::new(vec![-1.0, 1.0], vec![0.0, 0.0]).is_err());
    assert!(TabulatedPhase::new(vec![-0.9, 1.0], vec![1.0, 1.0]).is_err());
    assert!(TabulatedPhase::new(vec![-1.0, 1.0], vec![1.0, f64::NAN]).is_err());
}

#[test]
fn sampled_directions_are_unit_with_mean_cosine_g() {
    use optics::phase::scatter_direction;
    let mut rng = Rng(77);
    for &dir in &[
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [0.6, 0.0, 0.8],
        [0.2, -0.3, (1.0f64 - 0.13).sqrt()],
    ] {
        let g = 0.7;
        let hg = HenyeyGreenstein { g };
        let n = 200_000;
        let (mut s1, mut s2) = (0.0, 0.0);
        let mut perp = [0.0f64; 3];
        for _ in 0..n {
            let d = hg.sample_direction(dir, rng.next(), rng.next());
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-12);
            let c = d[0] * dir[0] + d[1] * dir[1] + d[2] * dir[2];
            s1 += c;
            s2 += c * c;
            for k in 0..3 {
                perp[k] += d[k] - c * dir[k];
            }
        }
        let m = s1 / n as f64;
        let se = ((s2 / n as f64 - m * m) / n as f64).sqrt();
        assert!((m - g).abs() < 4.0 * se, "dir {dir:?}: {m} ± {se}");
        // Azimuthal symmetry: the perpendicular components average to zero (σ < 0.002 each).
        for p in perp {
            assert!((p / n as f64).abs() < 0.008, "dir {dir:?}: {perp:?}");
        }
    }
    // Explicit geometry: θ = 90°, φ = 0 and φ = 90° give two orthogonal unit vectors ⟂ dir.
    let dir = [0.6, 0.0, 0.8];
    let a = scatter_direction(dir, 0.0, 0.0);
    let b = scatter_direction(dir, 0.0, PI / 2.0);
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    assert!(dot(a, dir).abs() < 1e-12 && dot(b, dir).abs() < 1e-12 && dot(a, b).abs() < 1e-12);
}

#[test]
fn tabulated_phase_accepts_a_grid_uniform_in_theta_from_forward_to_back() {
    // The layout of Mie tables (θ uniform over 0°…180°, cos θ decreasing from 1 to −1),
    // for a strongly forward-peaked HG (g = 0.9): mean cosine and normalisation are kept.
    let hg = HenyeyGreenstein { g: 0.9 };
    let n = 1801;
    let mu: Vec<f64> = (0..n)
        .map(|i| (PI * i as f64 / (n - 1) as f64).cos())
        .collect();
    let v: Vec<f64> = mu.iter().map(|&m| hg.eval(m)).collect();
    let tab = TabulatedPhase::new(mu, v).unwrap();
    assert!((tab.g() - 0.9).abs() < 2e-3, "g {}", tab.g());
    assert!((sphere_moment(|m| tab.eval(m), 0) - 1.0).abs() < 1e-4);
    assert!((tab.eval(1.0) - hg.eval(1.0)).abs() / hg.eval(1.0) < 2e-3);
    histogram_matches(|u| tab.sample_cos_theta(u), |m| tab.eval(m), 101);
}

#[test]
fn phase_function_enum_dispatches_to_both_kinds() {
    use optics::phase::PhaseFunction;
    let hg = HenyeyGreenstein { g: 0.4 };
    let a = PhaseFunction::HenyeyGreenstein(hg);
    let b = PhaseFunction::Tabulated(TabulatedPhase::from_fn(4001, |m| hg.eval(m)).unwrap());
    assert!((a.g() - b.g()).abs() < 1e-4);
    for k in 0..=10 {
        let mu = -1.0 + 0.2 * k as f64;
        assert!((a.eval(mu) - b.eval(mu)).abs() < 1e-4 * a.eval(mu));
        let u = k as f64 / 10.0;
        assert!(
            (a.sample_cos_theta(u) - b.sample_cos_theta(u)).abs() < 1e-3,
            "u {u}"
        );
    }
    let d = b.sample_direction([0.0, 1.0, 0.0], 0.3, 0.7);
    assert!(((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - 1.0).abs() < 1e-12);
}
