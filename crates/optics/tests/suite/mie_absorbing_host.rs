//! Lorenz–Mie theory in an absorbing host at host absorption α = 4πr n″_med/λ of order 1–10,
//! where the factors e^{−α} and γ(α) of the scattering cross section are far from 1 (for milk,
//! α ≈ 1e-4, and an error in either is invisible).
//!
//! Reference: Frisvad, Christensen & Jensen, "Computing the scattering properties of participating
//! media using Lorenz-Mie theory", ACM TOG 26(3) 60 (2007), §4 (the formulation of Fu & Sun,
//! Appl. Opt. 40(9) 1354 (2001), with the mean incident intensity over the particle's front
//! surface): C_sca = λ² e^{−α} / (2π γ(α) |n_med|²) Σ(2n+1)(|a_n|²+|b_n|²),
//! C_ext = λ²/(2π) Re Σ(2n+1)(a_n+b_n)/n_med², γ(α) = 2(1 + (α−1)e^α)/α².
//! The same normalisation (f = γ/2, η = α) is used by the independent MATLAB code `mie_single.m`
//! of THzMHA/Monte-Carlo (Mätzler's Mie code adapted to an absorbing medium).
//!
//! No published table of absorbing-host efficiencies at these α could be obtained for this test,
//! so each quantity is recomputed by a second, independent method instead:
//! * γ from its definition, by quadrature (not from the closed form): the intensity of a plane
//!   wave in the host falls as e^{−4π n″ z/λ}, so on the front hemisphere at depth −r t before the
//!   centre it is e^{α t} times the intensity at the centre; averaged over the particle's projected
//!   disc (area element 2s ds with t = √(1−s²), i.e. 2t dt) γ(α) = ∫₀¹ 2t e^{αt} dt;
//! * a_n, b_n by the direct Bohren–Huffman formulas (B&H 1983 eq. 4.53) from spherical Bessel
//!   functions of complex argument — j_n by Miller's downward recurrence normalised to sin z/z,
//!   h_n^{(1)} by upward recurrence from its closed forms — instead of the library's logarithmic
//!   derivatives and ψ/ξ ratios; α from its definition, 4π r n″/λ.

#[allow(unused_imports)]
use crate::common::*;

use num_complex::Complex64;
use optics::mie;
use std::f64::consts::PI;



/// γ(α) = ∫₀¹ 2t e^{αt} dt by composite Simpson (4000 intervals: relative error < 1e-13 for α ≤ 10).
fn gamma_quadrature(alpha: f64) -> f64 {
    let n = 4000;
    let h = 1.0 / n as f64;
    let f = |t: f64| 2.0 * t * (alpha * t).exp();
    let mut s = f(0.0) + f(1.0);
    for k in 1..n {
        s += if k % 2 == 1 { 4.0 } else { 2.0 } * f(k as f64 * h);
    }
    s * h / 3.0
}

/// Spherical Bessel j_n(z), n = 0..=n_max, by Miller's downward recurrence normalised to j_0 = sin z / z.
fn sph_j(z: Complex64, n_max: usize) -> Vec<Complex64> {
    let start = n_max + 40 + 2 * z.norm() as usize;
    let mut j = vec![c(0.0, 0.0); start + 2];
    j[start] = c(1e-30, 0.0);
    for n in (1..=start).rev() {
        j[n - 1] = j[n] * ((2 * n + 1) as f64) / z - j[n + 1];
        if j[n - 1].norm() > 1e200 {
            for v in j.iter_mut() {
                *v *= 1e-200;
            }
        }
    }
    let scale = (z.sin() / z) / j[0];
    j.truncate(n_max + 1);
    j.iter().map(|v| v * scale).collect()
}

/// Spherical Hankel h_n^{(1)}(z) = j_n + i y_n, n = 0..=n_max, by upward recurrence from
/// h_0 = −i e^{iz}/z and h_1 = −(z + i) e^{iz}/z².
fn sph_h1(z: Complex64, n_max: usize) -> Vec<Complex64> {
    let i = c(0.0, 1.0);
    let e = (i * z).exp();
    let mut h = vec![-i * e / z, -(z + i) * e / (z * z)];
    for n in 1..n_max {
        let next = h[n] * ((2 * n + 1) as f64) / z - h[n - 1];
        h.push(next);
    }
    h.truncate(n_max + 1);
    h
}

/// a_n, b_n (n = 1..=N) by Bohren & Huffman eq. 4.53 with ψ_n(ρ) = ρ j_n(ρ), ξ_n(ρ) = ρ h_n^{(1)}(ρ)
/// and ψ_n′ = ψ_{n−1} − n ψ_n/ρ (likewise ξ_n′); x = k₀ r n_med (complex), m = n_p/n_med.
fn coefficients_direct(x: Complex64, m: Complex64) -> (Vec<Complex64>, Vec<Complex64>) {
    let n_max = (x.norm() + 4.0 * x.norm().cbrt() + 12.0) as usize;
    let mx = m * x;
    let jx = sph_j(x, n_max);
    let jmx = sph_j(mx, n_max);
    let hx = sph_h1(x, n_max);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for n in 1..=n_max {
        let nf = n as f64;
        let psi = x * jx[n];
        let dpsi = x * jx[n - 1] - psi * nf / x;
        let xi = x * hx[n];
        let dxi = x * hx[n - 1] - xi * nf / x;
        let psim = mx * jmx[n];
        let dpsim = mx * jmx[n - 1] - psim * nf / mx;
        a.push((m * psim * dpsi - psi * dpsim) / (m * psim * dxi - xi * dpsim));
        b.push((psim * dpsi - m * psi * dpsim) / (psim * dxi - m * xi * dpsim));
    }
    (a, b)
}

/// γ(α), the mean incident intensity over the particle's front surface relative to its centre:
/// γ(0) = 1 (no host absorption), γ(1) = 2 and γ(2) = (1 + e²)/2 exactly from the closed form,
/// the series 1 + 2α/3 + α²/4 + α³/15 for small α, and the quadrature of its definition
/// ∫₀¹ 2t e^{αt} dt for α from 10⁻³ to 10 (both sides of the switch from series to closed form at 0.5).
#[test]
fn absorbing_host_gamma_matches_its_definition_and_known_points() {
    assert!((mie::absorbing_host_gamma(0.0) - 1.0).abs() < 1e-15);
    assert!((mie::absorbing_host_gamma(1e-9) - 1.0).abs() < 1e-8);
    assert!(rel(mie::absorbing_host_gamma(1.0), 2.0) < 1e-14, "γ(1) = {}", mie::absorbing_host_gamma(1.0));
    let e2 = 2f64.exp();
    assert!(rel(mie::absorbing_host_gamma(2.0), (1.0 + e2) / 2.0) < 1e-14, "γ(2) = {}", mie::absorbing_host_gamma(2.0));
    for a in [1e-3, 1e-2, 0.05] {
        let series = 1.0 + 2.0 * a / 3.0 + a * a / 4.0 + a * a * a / 15.0;
        assert!(rel(mie::absorbing_host_gamma(a), series) < 1e-6, "α {a}: γ {} vs series {series}", mie::absorbing_host_gamma(a));
    }
    for a in [1e-3, 0.1, 0.3, 0.4999, 0.5, 0.5001, 0.7, 1.0, 1.5, 2.0, 3.0, 5.0, 7.5, 10.0] {
        let g = mie::absorbing_host_gamma(a);
        let q = gamma_quadrature(a);
        assert!(rel(g, q) < 1e-11, "α {a}: γ {g} vs quadrature of ∫₀¹ 2t e^(αt) dt = {q}");
    }
}

/// C_sca and C_ext of spheres in a strongly absorbing host, α = 4πr n″/λ = 1, 3 and 10 (Im x =
/// α/2 = 0.5, 1.5, 5: both the library's upward and ratio paths), host size parameters Re x = 1,
/// 3 and 8, for a glass-like particle, an absorbing particle and a bubble, against the direct
/// Bohren–Huffman series with α and γ from their definitions (see the file's comment).
/// Relative agreement 1e-8. A factor 2 in α multiplies C_sca by e^{−α}γ(α)/γ(2α) (0.18 at α = 1).
#[test]
fn absorbing_host_cross_sections_match_a_direct_series_with_alpha_and_gamma_from_definitions() {
    let lambda = 500e-9;
    let k0 = 2.0 * PI / lambda;
    let n_re = 1.33;
    for &xr in &[1.0, 3.0, 8.0] {
        let r = xr / (k0 * n_re);
        for &alpha in &[1.0, 3.0, 10.0] {
            // α = 4π r n″/λ = 2 k₀ r n″: the intensity attenuation (4π n″/λ per metre) over one radius.
            let n_im = alpha * lambda / (4.0 * PI * r);
            let n_med = c(n_re, n_im);
            for &n_p in &[c(1.55, 0.0), c(1.6, 0.3), c(1.0, 0.0)] {
                let s = mie::sphere(r, lambda, n_p, n_med);
                let x = n_med * (k0 * r);
                assert!((2.0 * x.im - alpha).abs() < 1e-12 * alpha);
                let (a, b) = coefficients_direct(x, n_p / n_med);
                let sum_sca: f64 = a.iter().zip(&b).enumerate().map(|(k, (an, bn))| (2 * k + 3) as f64 * (an.norm_sqr() + bn.norm_sqr())).sum();
                let sum_ext: Complex64 = a.iter().zip(&b).enumerate().map(|(k, (an, bn))| (an + bn) * (2 * k + 3) as f64).sum();
                let alpha_def = 4.0 * PI * r * n_med.im / lambda;
                let c_sca = lambda * lambda * (-alpha_def).exp() / (2.0 * PI * gamma_quadrature(alpha_def) * n_med.norm_sqr()) * sum_sca;
                let c_ext = lambda * lambda / (2.0 * PI) * (sum_ext / (n_med * n_med)).re;
                let what = format!("x = {x:.4}, n_p = {n_p}");
                assert!(rel(s.c_sca_m2, c_sca) < 1e-8, "{what}: C_sca {} vs direct series {c_sca} (ratio {})", s.c_sca_m2, s.c_sca_m2 / c_sca);
                assert!(rel(s.c_ext_m2, c_ext) < 1e-8, "{what}: C_ext {} vs direct series {c_ext}", s.c_ext_m2);
                let area = PI * r * r;
                assert!(rel(s.eff.qsca, c_sca / area) < 1e-8, "{what}: Q_sca {} vs {}", s.eff.qsca, c_sca / area);
                assert!((s.c_abs_m2 - (c_ext - c_sca)).abs() < 1e-8 * c_ext.abs().max(c_sca), "{what}: C_abs {} vs {}", s.c_abs_m2, c_ext - c_sca);
            }
        }
    }
}
