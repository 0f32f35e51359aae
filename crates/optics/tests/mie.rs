//! Lorenz–Mie theory against published tables, closed forms and a second independent method.

use num_complex::Complex64;
use optics::mie::{self, MieWorkspace};

fn c(re: f64, im: f64) -> Complex64 {
    Complex64::new(re, im)
}

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// W. J. Wiscombe, "Mie scattering calculations: advances in technique and fast, vector-speed
/// computer codes", NCAR Technical Note NCAR/TN-140+STR (1979, revised 1996), test cases of MIEV0
/// (the table printed by its test driver). Columns: x, m, Q_ext, Q_sca, g·Q_sca.
/// Wiscombe writes m = n′ − i n″ (e^{+iωt}); here the same particles are n′ + i n″.
/// The values are printed with 7 significant digits.
const WISCOMBE: &[(f64, f64, f64, f64, f64, f64)] = &[
    (0.099, 0.75, 0.0, 7.417859e-06, 7.417859e-06, 1.074279e-08),
    (0.101, 0.75, 0.0, 8.033542e-06, 8.033542e-06, 1.211000e-08),
    (10.0, 0.75, 0.0, 2.232265e+00, 2.232265e+00, 2.001164e+00),
    (1000.0, 0.75, 0.0, 1.997908e+00, 1.997908e+00, 1.688121e+00),
    (1.0, 1.33, 1e-5, 9.395198e-02, 9.392330e-02, 1.733048e-02),
    (100.0, 1.33, 1e-5, 2.101321e+00, 2.096594e+00, 1.821854e+00),
    (10000.0, 1.33, 1e-5, 2.004089e+00, 1.723857e+00, 1.564987e+00),
    (0.055, 1.5, 1.0, 1.014910e-01, 1.131687e-05, 5.558541e-09),
    (0.056, 1.5, 1.0, 1.033467e-01, 1.216311e-05, 6.193255e-09),
    (1.0, 1.5, 1.0, 2.336321e+00, 6.634538e-01, 1.274736e-01),
    (100.0, 1.5, 1.0, 2.097502e+00, 1.283697e+00, 1.091466e+00),
    (10000.0, 1.5, 1.0, 2.004368e+00, 1.236574e+00, 1.046525e+00),
    (1.0, 10.0, 10.0, 2.532993e+00, 2.049405e+00, -2.267961e-01),
    (100.0, 10.0, 10.0, 2.071124e+00, 1.836785e+00, 1.021648e+00),
    (10000.0, 10.0, 10.0, 2.005914e+00, 1.795393e+00, 9.842238e-01),
];

#[test]
fn wiscombe_miev0_test_cases() {
    let mut w = MieWorkspace::new();
    for &(x, mr, mi, qext, qsca, gqsc) in WISCOMBE {
        let e = w.efficiencies(x, c(mr, mi));
        // 7 printed digits: half a unit in the last place is 5e-7 relative at worst 5e-6.
        let tol = 2e-6;
        assert!(rel(e.qext, qext) < tol, "x={x} m={mr}+{mi}i qext {} vs {qext}", e.qext);
        assert!(rel(e.qsca, qsca) < tol, "x={x} m={mr}+{mi}i qsca {} vs {qsca}", e.qsca);
        assert!(rel(e.g * e.qsca, gqsc) < 5e-6, "x={x} m={mr}+{mi}i g·qsca {} vs {gqsc}", e.g * e.qsca);
    }
}

/// Bohren & Huffman (1983), Appendix A, BHMIE example output: m = 1.55, λ = 0.6328 µm,
/// r = 0.525 µm (x = 5.213): Q_ext = Q_sca = 3.10543, Q_back = 2.92534, g = 0.63314.
#[test]
fn bohren_huffman_bhmie_example() {
    let x = 2.0 * std::f64::consts::PI * 0.525 / 0.6328;
    let e = mie::efficiencies(x, c(1.55, 0.0));
    assert!((e.qext - 3.10543).abs() < 6e-6, "qext {}", e.qext);
    assert!((e.qsca - 3.10543).abs() < 6e-6, "qsca {}", e.qsca);
    assert!((e.qback - 2.92534).abs() < 6e-6, "qback {}", e.qback);
    assert!((e.g - 0.63314).abs() < 6e-6, "g {}", e.g);
    assert!(e.qabs.abs() < 1e-12);
}

/// Rayleigh limit: Q_sca = 8/3 x⁴|K|², Q_abs = 4x Im K, K = (m²−1)/(m²+2), with O(x²) corrections.
#[test]
fn rayleigh_limit() {
    for m in [c(1.5, 0.0), c(1.33, 0.01), c(2.0, 1.0), c(0.75, 0.0)] {
        let x = 1e-3;
        let e = mie::efficiencies(x, m);
        let (qs, qa) = mie::rayleigh(x, m);
        assert!(rel(e.qsca, qs) < 1e-4, "m={m} qsca {} vs {qs}", e.qsca);
        if qa > 0.0 {
            assert!(rel(e.qabs, qa) < 1e-4, "m={m} qabs {} vs {qa}", e.qabs);
        }
        assert!(e.g.abs() < 1e-4, "g {}", e.g);
        // Rayleigh phase function: 3/(16π)(1+cos²θ)
        let mut w = MieWorkspace::new();
        let (a, b) = w.coefficients(c(x, 0.0), m);
        let (a, b) = (a.to_vec(), b.to_vec());
        for mu in [-1.0, -0.3, 0.0, 0.5, 1.0] {
            let p = mie::phase_function(&a, &b, mu);
            let pr = 3.0 / (16.0 * std::f64::consts::PI) * (1.0 + mu * mu);
            assert!(rel(p, pr) < 1e-4, "mu={mu} p {p} vs {pr}");
        }
    }
}

/// The D_n start matters: x = 100, m = 1.5 gives Q_sca ≈ 2.0944 (a start at M alone gives 2.146).
/// Cross-checked against the independent ratio formulation (two methods agree to 1e-9).
#[test]
fn large_index_start_of_downward_recurrence() {
    let mut w = MieWorkspace::new();
    let e = w.efficiencies(100.0, c(1.5, 0.0));
    assert!((e.qsca - 2.0944).abs() < 1e-4, "qsca {}", e.qsca);
    assert!((e.qext - e.qsca).abs() < 1e-12);
}

/// The absorbing-host path (Frisvad et al. 2007 with complex-argument ratios) must reduce to the
/// classical one when the host does not absorb: two independent code paths.
#[test]
fn ratio_formulation_agrees_with_classical() {
    let mut w = MieWorkspace::new();
    for &(x, mr, mi) in &[(0.5, 1.5, 0.0), (5.213, 1.55, 0.0), (30.0, 1.33, 1e-3), (100.0, 1.5, 0.0), (1000.0, 1.5, 0.01), (20.0, 10.0, 10.0)] {
        let e = w.efficiencies(x, c(mr, mi));
        let (a, b) = w.coefficients_ratio(c(x, 0.0), c(mr, mi));
        let (a, b) = (a.to_vec(), b.to_vec());
        let qsca = 2.0 / (x * x) * mie::scattering_sum(&a, &b);
        let qext: f64 = 2.0 / (x * x) * a.iter().zip(&b).enumerate().map(|(k, (an, bn))| (2 * k + 3) as f64 * (an + bn).re).sum::<f64>();
        assert!(rel(qsca, e.qsca) < 1e-9, "x={x} qsca {qsca} vs {}", e.qsca);
        assert!(rel(qext, e.qext) < 1e-9, "x={x} qext {qext} vs {}", e.qext);
        assert!((mie::asymmetry(&a, &b) - e.g).abs() < 1e-9);
        // Slightly absorbing host: continuous in n″ → 0.
        let lambda = 500e-9;
        let r = x * lambda / (2.0 * std::f64::consts::PI * 1.33);
        let s0 = w.sphere(r, lambda, c(mr * 1.33, mi * 1.33), c(1.33, 0.0));
        let s1 = w.sphere(r, lambda, c(mr * 1.33, mi * 1.33), c(1.33, 1e-12));
        assert!(rel(s1.c_sca_m2, s0.c_sca_m2) < 1e-7, "x={x} csca {} vs {}", s1.c_sca_m2, s0.c_sca_m2);
        assert!(rel(s1.c_ext_m2, s0.c_ext_m2) < 1e-7, "x={x} cext {} vs {}", s1.c_ext_m2, s0.c_ext_m2);
    }
}

/// Phase function: normalised to 1 over the sphere and its mean cosine equals g (numerical quadrature).
#[test]
fn phase_function_normalised_and_mean_cosine_is_g() {
    let mut w = MieWorkspace::new();
    for &(x, mr, mi) in &[(0.8, 1.5, 0.0), (5.213, 1.55, 0.0), (12.0, 1.33, 0.05)] {
        let e = w.efficiencies(x, c(mr, mi));
        let (a, b) = w.coefficients(c(x, 0.0), c(mr, mi));
        let (a, b) = (a.to_vec(), b.to_vec());
        // Composite Simpson over θ ∈ [0, π] of 2π p sin θ.
        let n = 20000;
        let h = std::f64::consts::PI / n as f64;
        let (mut norm, mut mean) = (0.0, 0.0);
        for k in 0..=n {
            let t = k as f64 * h;
            let wgt = if k == 0 || k == n { 1.0 } else if k % 2 == 1 { 4.0 } else { 2.0 };
            let p = mie::phase_function(&a, &b, t.cos());
            norm += wgt * p * t.sin();
            mean += wgt * p * t.sin() * t.cos();
        }
        norm *= 2.0 * std::f64::consts::PI * h / 3.0;
        mean *= 2.0 * std::f64::consts::PI * h / 3.0;
        assert!((norm - 1.0).abs() < 1e-7, "x={x} norm {norm}");
        assert!((mean - e.g).abs() < 1e-7, "x={x} mean cos {mean} vs g {}", e.g);
        // Optical theorem: Q_ext = 4/x² Re S(0)
        let (s1, s2) = mie::amplitudes(&a, &b, 1.0);
        assert!(rel(4.0 / (x * x) * s1.re, e.qext) < 1e-10);
        assert!((s1 - s2).norm() < 1e-10 * s1.norm());
        // Backscattering efficiency 4|S1(π)|²/x²
        let (sb, _) = mie::amplitudes(&a, &b, -1.0);
        assert!(rel(4.0 * sb.norm_sqr() / (x * x), e.qback) < 1e-9);
    }
}

/// Bohren & Huffman (1983) Appendix A example: S11 normalised, |S1|²,... at θ = 0 and 90° are printed;
/// here we check the symmetry |S1(θ)|² and |S2(θ)|² are equal at θ = 0 and π.
#[test]
fn amplitudes_equal_forward_and_backward() {
    let mut w = MieWorkspace::new();
    let (a, b) = w.coefficients(c(5.213, 0.0), c(1.55, 0.0));
    let (s1, s2) = mie::amplitudes(a, b, -1.0);
    assert!((s1 + s2).norm() < 1e-10 * s1.norm(), "S2(π) = −S1(π)");
}

/// Absorbing host: for a particle identical to the host there is no scattering and C_ext = 0.
#[test]
fn particle_matching_absorbing_host_is_invisible() {
    let n = c(1.4, 0.02);
    let s = mie::sphere(1e-6, 500e-9, n, n);
    assert!(s.c_sca_m2.abs() < 1e-25, "{:?}", s);
    assert!(s.c_ext_m2.abs() < 1e-25, "{:?}", s);
}

#[test]
fn parse_complex_numbers() {
    assert_eq!(mie::parse_complex("1.33").unwrap(), c(1.33, 0.0));
    assert_eq!(mie::parse_complex("1.33+1e-05i").unwrap(), c(1.33, 1e-5));
    assert_eq!(mie::parse_complex("1.5-0.1i").unwrap(), c(1.5, -0.1));
    assert_eq!(mie::parse_complex("1e0+1E+1i").unwrap(), c(1.0, 10.0));
    for bad in ["1.5+i", "", "abc", "1.5+0.1", "1.5++1i", "nan", "1.5+1ii", "inf"] {
        assert!(mie::parse_complex(bad).is_err(), "{bad:?} accepted");
    }
}

/// For a complex host size parameter the two ways of building the coefficients (upward ψ_n, ξ_n and
/// the ratio formulation) agree, including the absorption C_ext − C_sca, up to |Im x| = 1.
#[test]
fn upward_and_ratio_agree_for_complex_x() {
    let mut w = MieWorkspace::new();
    for &xr in &[0.3, 3.0, 30.0, 300.0, 2000.0] {
        for &xi in &[1e-9, 1e-6, 1e-3, 0.1, 1.0] {
            for &m in &[c(1.1, 3e-6), c(1.5, 0.0), c(0.8, 0.1), c(3.0, 2.0)] {
                let x = c(xr, xi);
                let (a1, b1) = w.coefficients_upward(x, m);
                let (a1, b1) = (a1.to_vec(), b1.to_vec());
                let (a2, b2) = w.coefficients_ratio(x, m);
                let (a2, b2) = (a2.to_vec(), b2.to_vec());
                let big = a2.iter().chain(&b2).map(|v| v.norm()).fold(0.0, f64::max);
                for k in 0..a1.len() {
                    assert!((a1[k] - a2[k]).norm() < 1e-10 * big, "x={x} m={m} n={} a {} vs {}", k + 1, a1[k], a2[k]);
                    assert!((b1[k] - b2[k]).norm() < 1e-10 * big, "x={x} m={m} n={} b {} vs {}", k + 1, b1[k], b2[k]);
                }
            }
        }
    }
}

/// Fat globule (m ≈ 1.1 + 3e-6 i) in water: absorption C_abs, a difference of two numbers 10⁴ times
/// larger, agrees between the classical fused path and the stored-coefficient path to 1e-8.
#[test]
fn weak_absorption_agrees_between_paths() {
    let mut w = MieWorkspace::new();
    for r in [0.1e-6, 0.5e-6, 2e-6, 9e-6] {
        let np = c(1.463, 4.6e-6);
        let nh = c(1.333, 0.0);
        let s1 = w.sphere(r, 550e-9, np, nh);
        let s2 = w.sphere_keep_coefficients(r, 550e-9, np, nh);
        assert!(rel(s1.c_abs_m2, s2.c_abs_m2) < 1e-8, "r {r}: {} vs {}", s1.c_abs_m2, s2.c_abs_m2);
        let x = c(2.0 * std::f64::consts::PI * r * 1.333 / 550e-9, 0.0);
        let (a, b) = w.coefficients_ratio(x, np / nh);
        let (a, b) = (a.to_vec(), b.to_vec());
        let abs: f64 = a.iter().zip(&b).enumerate().map(|(k, (an, bn))| (2 * k + 3) as f64 * ((an + bn).re - an.norm_sqr() - bn.norm_sqr())).sum();
        let cabs = abs * (550e-9f64).powi(2) / (2.0 * std::f64::consts::PI * 1.333 * 1.333);
        assert!(rel(cabs, s1.c_abs_m2) < 1e-8, "r {r}: {} vs {}", cabs, s1.c_abs_m2);
    }
}
