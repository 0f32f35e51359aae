//! BSDF tests: sampling matches evaluation (chi-square, as pbrt-v4's `bsdfs_test.cpp` does),
//! pdf/eval consistency, reciprocity, energy conservation (furnaces, a smooth dielectric slab)
//! and conductor reflectance from measured optical constants.

use glam::{Vec2, Vec3, Vec4};
use render::bsdf::{CoatedDiffuse, RoughConductor, RoughDielectric, SmoothConductor, SmoothDielectric};
use render::bsdf::Bsdf;
use render::material::Material;
use render::bsdf::microfacet::{Distribution, Microfacet};
use render::math::sampling::{uniform_sphere, Pcg32};
use render::math::spectral::SampledWavelengths;
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Chi-square machinery

/// Number of chi-square runs in this file, for the Šidák correction of the 1 % significance level.
const N_CHI2_RUNS: u32 = 60;
const THETA_RES: usize = 10;
const PHI_RES: usize = 20;
const N_SAMPLES: usize = 400_000;

/// Regularised upper incomplete gamma function Q(a, x) (series for x < a + 1, else Lentz's
/// continued fraction; Abramowitz & Stegun 6.5.29 and 6.5.31).
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let ln_pre = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{-x} x^a Σ x^n / Γ(a + n + 1)
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut ap = a;
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * ln_pre.exp()
    } else {
        // Q(a, x) = e^{-x} x^a · 1/(x + 1 − a − 1·(1 − a)/(x + 3 − a − …))
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        ln_pre.exp() * h
    }
}

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, n = 9).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

fn dir(theta: f64, phi: f64) -> Vec3 {
    Vec3::new(
        (theta.sin() * phi.cos()) as f32,
        (theta.sin() * phi.sin()) as f32,
        theta.cos() as f32,
    )
}

/// Integral of `pdf` over each (θ, φ) bin: composite 5-point Gauss–Legendre on 6×6 sub-cells.
fn integrate_bins(pdf: &dyn Fn(Vec3) -> f32) -> Vec<f64> {
    const X: [f64; 5] = [
        0.0,
        -0.538_469_310_105_683,
        0.538_469_310_105_683,
        -0.906_179_845_938_664,
        0.906_179_845_938_664,
    ];
    const W: [f64; 5] = [
        0.568_888_888_888_889,
        0.478_628_670_499_366,
        0.478_628_670_499_366,
        0.236_926_885_056_189,
        0.236_926_885_056_189,
    ];
    let sub = 6;
    let dth = PI / THETA_RES as f64;
    let dph = 2.0 * PI / PHI_RES as f64;
    let mut out = vec![0.0; THETA_RES * PHI_RES];
    for it in 0..THETA_RES {
        for ip in 0..PHI_RES {
            let mut s = 0.0;
            for a in 0..sub {
                for b in 0..sub {
                    let th0 = it as f64 * dth + a as f64 * dth / sub as f64;
                    let ph0 = ip as f64 * dph + b as f64 * dph / sub as f64;
                    let (hth, hph) = (0.5 * dth / sub as f64, 0.5 * dph / sub as f64);
                    for (xa, wa) in X.iter().zip(W) {
                        for (xb, wb) in X.iter().zip(W) {
                            let th = th0 + hth * (1.0 + xa);
                            let ph = ph0 + hph * (1.0 + xb);
                            s += wa * wb * hth * hph * pdf(dir(th, ph)) as f64 * th.sin();
                        }
                    }
                }
            }
            out[it * PHI_RES + ip] = s;
        }
    }
    out
}

fn bin_of(w: Vec3) -> usize {
    let th = (w.z as f64).clamp(-1.0, 1.0).acos();
    let mut ph = (w.y as f64).atan2(w.x as f64);
    if ph < 0.0 {
        ph += 2.0 * PI;
    }
    let it = ((th / PI * THETA_RES as f64) as usize).min(THETA_RES - 1);
    let ip = ((ph / (2.0 * PI) * PHI_RES as f64) as usize).min(PHI_RES - 1);
    it * PHI_RES + ip
}

/// Sample `bsdf` N times for `wo`, histogram the directions (delta samples in one extra bin whose
/// expected count is N × the reported discrete probability), and compare with the integrated pdf.
/// Returns the p-value; also checks that every non-delta sample's f and pdf equal eval and pdf.
fn chi2_pvalue(name: &str, bsdf: &Bsdf, wo: Vec3, seed: u64) -> f64 {
    let mut rng = Pcg32::new(seed, 17);
    let mut obs = vec![0.0f64; THETA_RES * PHI_RES + 1];
    let mut delta_prob: Option<f64> = None;
    for _ in 0..N_SAMPLES {
        let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) else {
            continue;
        };
        assert!(
            s.pdf > 0.0 && s.pdf.is_finite() && s.f.is_finite(),
            "{name}: bad sample {s:?}"
        );
        assert!((s.wi.length() - 1.0).abs() < 1e-3, "{name}: wi not unit {s:?}");
        if s.delta {
            let p = s.pdf as f64;
            if let Some(q) = delta_prob {
                assert!((p - q).abs() < 1e-6, "{name}: delta probability varies");
            }
            delta_prob = Some(p);
            obs[THETA_RES * PHI_RES] += 1.0;
            continue;
        }
        // pdf/eval consistency of the sampled value.
        let pe = bsdf.pdf(wo, s.wi);
        assert!(
            (pe - s.pdf).abs() <= 2e-3 * s.pdf.max(pe) + 1e-6,
            "{name}: sample pdf {} vs pdf() {pe} for {:?}",
            s.pdf,
            s.wi
        );
        let fe = bsdf.eval(wo, s.wi);
        assert!(
            (fe - s.f).abs().max_element() <= 2e-3 * s.f.max_element().max(fe.max_element()) + 1e-6,
            "{name}: f {:?} vs eval {fe:?}",
            s.f
        );
        assert_eq!(s.transmission, s.wi.z * wo.z < 0.0, "{name}: transmission flag");
        obs[bin_of(s.wi)] += 1.0;
    }
    let mut exp: Vec<f64> = integrate_bins(&|w| bsdf.pdf(wo, w))
        .into_iter()
        .map(|p| p * N_SAMPLES as f64)
        .collect();
    exp.push(delta_prob.unwrap_or(0.0) * N_SAMPLES as f64);
    let total_exp: f64 = exp.iter().sum();
    assert!(
        total_exp <= N_SAMPLES as f64 * 1.002,
        "{name}: pdf integrates to {} > 1",
        total_exp / N_SAMPLES as f64
    );
    // Pool bins with small expected counts (pbrt-v4: minimum expected frequency 5).
    let mut idx: Vec<usize> = (0..exp.len()).collect();
    idx.sort_by(|&a, &b| exp[a].partial_cmp(&exp[b]).unwrap());
    let (mut pooled_obs, mut pooled_exp, mut chsq, mut dof) = (0.0, 0.0, 0.0, 0i32);
    for &i in &idx {
        if exp[i] == 0.0 {
            // The quadrature resolves ~0.1° in θ: a sliver of support thinner than that reads as 0.
            // A gross mismatch (samples where the pdf vanishes) still fails here.
            assert!(
                obs[i] <= N_SAMPLES as f64 * 1e-4,
                "{name}: {} samples in bin {i} of zero expected frequency",
                obs[i]
            );
        }
        if exp[i] < 5.0 {
            pooled_obs += obs[i];
            pooled_exp += exp[i];
        } else if pooled_exp > 0.0 && pooled_exp < 5.0 {
            // Fold the pooled remainder into this bin.
            let (o, e) = (obs[i] + pooled_obs, exp[i] + pooled_exp);
            chsq += (o - e) * (o - e) / e;
            dof += 1;
            pooled_obs = 0.0;
            pooled_exp = 0.0;
        } else {
            chsq += (obs[i] - exp[i]) * (obs[i] - exp[i]) / exp[i];
            dof += 1;
        }
    }
    if pooled_exp > 0.0 {
        chsq += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        dof += 1;
    }
    dof -= 1;
    assert!(dof > 0, "{name}: too few bins");
    gamma_q(dof as f64 / 2.0, chsq / 2.0)
}

fn check_chi2(name: &str, bsdf: &Bsdf, wos: &[Vec3], seed: u64) {
    let alpha = 1.0 - (1.0 - 0.01f64).powf(1.0 / N_CHI2_RUNS as f64);
    for (k, &wo) in wos.iter().enumerate() {
        let p = chi2_pvalue(name, bsdf, wo.normalize(), seed + k as u64);
        eprintln!("chi2 {name}, wo = {wo}: p = {p:.3e}");
        assert!(
            p > alpha,
            "{name}, wo = {wo}: chi-square p-value {p:.3e} below the Šidák-corrected level {alpha:.3e}"
        );
    }
}

fn wos_upper() -> Vec<Vec3> {
    vec![
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.5, 0.2, 0.8),
        Vec3::new(0.9, -0.3, 0.2),
    ]
}

fn gtr(ax: f32, ay: f32) -> Microfacet {
    Microfacet {
        alpha_x: ax,
        alpha_y: ay,
        ..Microfacet::isotropic(0.0)
    }
}

fn gold() -> (Vec4, Vec4, [f32; 4]) {
    let au = optics::ior::metal("au").unwrap();
    let l = [450.0f32, 550.0, 650.0, 750.0];
    let mut e = [0f32; 4];
    let mut k = [0f32; 4];
    for i in 0..4 {
        let (a, b) = au.eta_k(l[i] as f64);
        e[i] = a as f32;
        k[i] = b as f32;
    }
    (Vec4::from_array(e), Vec4::from_array(k), l)
}

#[test]
fn test_gamma_q_known_values() {
    // Q(1, x) = e^{-x}; Q(1/2, x) = erfc(√x); χ² with 10 dof at 23.209 has p = 0.01 (tables).
    assert!((gamma_q(1.0, 2.0) - (-2.0f64).exp()).abs() < 1e-12);
    assert!((gamma_q(0.5, 1.0) - 0.157_299_207_050_285_1).abs() < 1e-10);
    assert!((gamma_q(5.0, 23.209 / 2.0) - 0.01).abs() < 1e-4);
    assert!((gamma_q(30.0, 5.0) - 1.0).abs() < 1e-9);
}

#[test]
fn chi2_rough_conductor() {
    let (eta, k, _) = gold();
    // 9 runs: isotropic rough, smoother, anisotropic.
    for (i, d) in [gtr(0.5, 0.5), gtr(0.15, 0.15), gtr(0.1, 0.4)].into_iter().enumerate() {
        let b = Bsdf::RoughConductor(RoughConductor { distrib: d, eta, k });
        check_chi2(&format!("rough conductor {d:?}"), &b, &wos_upper(), 100 + 10 * i as u64);
    }
}

#[test]
fn chi2_rough_dielectric() {
    // 18 + 3 runs: from outside (η = 1.5) and from inside (η = 1/1.5), two roughnesses, three angles.
    for (i, (alpha, eta)) in [
        (0.5f32, 1.5f32),
        (0.2, 1.5),
        (0.5, 1.0 / 1.5),
        (0.2, 1.0 / 1.5),
        (0.3, 1.33),
        (0.3, 1.0 / 1.33),
    ]
    .into_iter()
    .enumerate()
    {
        let b = Bsdf::RoughDielectric {
            lobe: RoughDielectric {
                distrib: gtr(alpha, alpha),
                eta,
            },
            dispersive: false,
        };
        check_chi2(
            &format!("rough dielectric α={alpha} η={eta}"),
            &b,
            &wos_upper(),
            200 + 10 * i as u64,
        );
    }
    // 3 runs: anisotropic.
    let b = Bsdf::RoughDielectric {
        lobe: RoughDielectric {
            distrib: gtr(0.1, 0.5),
            eta: 1.5,
        },
        dispersive: false,
    };
    check_chi2("rough dielectric α=(0.1, 0.5) η=1.5", &b, &wos_upper(), 290);
}

/// Beckmann lobes (Mitsuba 3's default distribution): sampling matches evaluation (15 runs), a
/// white-based Beckmann plastic returns all the light, and a white conductor's albedo by sampling
/// and by quadrature agree and stay ≤ 1 (their reciprocity is in `reciprocity`).
#[test]
fn beckmann_lobes_sample_their_density_and_conserve_energy() {
    let beck = |ax: f32, ay: f32| gtr(ax, ay).with_distribution(Distribution::Beckmann);
    let (eta, k, _) = gold();
    for (i, d) in [beck(0.3, 0.3), beck(0.1, 0.4)].into_iter().enumerate() {
        let b = Bsdf::RoughConductor(RoughConductor { distrib: d, eta, k });
        check_chi2(&format!("Beckmann rough conductor {d:?}"), &b, &wos_upper(), 400 + 10 * i as u64);
    }
    for (i, eta) in [1.5f32, 1.0 / 1.5].into_iter().enumerate() {
        let b = Bsdf::RoughDielectric { lobe: RoughDielectric { distrib: beck(0.3, 0.3), eta }, dispersive: false };
        check_chi2(&format!("Beckmann rough dielectric η={eta}"), &b, &wos_upper(), 420 + 10 * i as u64);
    }
    // A Beckmann coating over a white base returns all the light (the diffuse term's
    // normalisation 1 − E_avg uses the coating's own albedo table); its sampling matches.
    let coated = CoatedDiffuse::new(Vec4::new(0.2, 0.5, 0.8, 0.9), 1.5, 0.3).with_distribution(Distribution::Beckmann);
    check_chi2("Beckmann-coated diffuse α=0.3", &Bsdf::Coated(coated), &wos_upper(), 440);
    let white = Bsdf::Coated(CoatedDiffuse::new(Vec4::ONE, 1.5, 0.3).with_distribution(Distribution::Beckmann));
    for mu in [1.0f32, 0.6, 0.2] {
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let (m, se) = albedo(&white, wo, 60_000, 29, 1.0);
        assert!((m - 1.0).abs() < 4.0 * se + 1e-3, "white Beckmann plastic μ {mu}: {m} ± {se}");
    }
    // η + ik = 0 + 1i: a perfect mirror on every facet; only masking and shadowing lose light.
    for alpha in [0.1f32, 0.3, 0.6] {
        let b = Bsdf::RoughConductor(RoughConductor { distrib: beck(alpha, alpha), eta: Vec4::ZERO, k: Vec4::ONE });
        for mu in [1.0f32, 0.7, 0.4] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let (m, se) = albedo(&b, wo, 50_000, 23, 1.0);
            assert!(m <= 1.0 + 1e-5, "α {alpha} μ {mu}: {m}");
            // Beckmann's short tails: a smooth lobe loses almost nothing away from grazing
            // (GGX at α = 0.1 loses up to 3 %, its tails reaching past the horizon).
            if alpha == 0.1 {
                assert!(m > 0.99, "α {alpha} μ {mu}: {m}");
            }
            if alpha >= 0.3 {
                let q = albedo_quadrature(&b, wo);
                assert!((q - m).abs() < 4.0 * se + 3e-3, "α {alpha} μ {mu}: quadrature {q} vs sampling {m} ± {se}");
            }
        }
    }
}

/// Mitsuba 3's diffuse coupling (`coupling = "mitsuba"`): on a smooth coating it is lucent's own
/// term (1 − F_dr,out = η²(1 − F_dr,in)); its rough transmittance t(μ) equals the transmitted
/// albedo of the rough dielectric lobe with separable masking, integrated over directions (an
/// independent quadrature of `eval`, times η² to undo the radiance compression); a white base
/// then reflects less than all the light, more so for rougher coatings; sampling still matches.
#[test]
fn mitsuba_coupling_of_a_plastic_coating() {
    use render::bsdf::microfacet::Masking;
    use render::bsdf::MitsubaCoupling;
    let rho = Vec4::new(0.2, 0.5, 0.8, 1.0);
    let mut rng = Pcg32::new(41, 3);
    for nonlinear in [true, false] {
        let lucent = CoatedDiffuse { nonlinear, ..CoatedDiffuse::new(rho, 1.5, 0.0) };
        let mts = lucent.with_mitsuba_coupling();
        for _ in 0..2000 {
            let (wo, wi) = (uniform_sphere(rng.next_2d()), uniform_sphere(rng.next_2d()));
            let (a, b) = (Bsdf::Coated(lucent).eval(wo, wi), Bsdf::Coated(mts).eval(wo, wi));
            assert!((a - b).abs().max_element() <= 2e-4 * a.max_element().max(1e-3), "smooth, nonlinear {nonlinear}: {a} vs {b}");
        }
    }
    for (alpha, distribution) in [(0.1f32, Distribution::Ggx), (0.3, Distribution::Beckmann), (0.5, Distribution::Ggx)] {
        let c = MitsubaCoupling::get(alpha, 1.5, distribution);
        let lobe = Bsdf::RoughDielectric {
            lobe: RoughDielectric { distrib: gtr(alpha, alpha).with_distribution(distribution).with_masking(Masking::Separable), eta: 1.5 },
            dispersive: false,
        };
        for mu in [0.95f32, 0.6, 0.3] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            // ∫ f_t |cos θi| dωi over the lower hemisphere, in t = tan θ (dense near the refracted peak).
            let (nt, np) = (1200, 360);
            let mut sum = 0.0f64;
            for i in 0..nt {
                let s = (i as f64 + 0.5) / nt as f64;
                let tmax = 60.0f64;
                let t = tmax * s * s;
                let dth = tmax * 2.0 * s / nt as f64 / (1.0 + t * t);
                let th = t.atan();
                for j in 0..np {
                    let ph = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                    let wi = Vec3::new((th.sin() * ph.cos()) as f32, (th.sin() * ph.sin()) as f32, -(th.cos() as f32));
                    sum += lobe.eval(wo, wi).x as f64 * th.cos() * th.sin() * dth * 2.0 * PI / np as f64;
                }
            }
            let quad = sum * 1.5 * 1.5;
            let t = c.t(mu) as f64;
            assert!((t - quad).abs() < 4e-3, "α {alpha} {distribution:?} μ {mu}: table t {t} vs quadrature {quad}");
        }
        let white = Bsdf::Coated(CoatedDiffuse::new(Vec4::ONE, 1.5, alpha).with_distribution(distribution).with_mitsuba_coupling());
        let (m, se) = albedo(&white, Vec3::new(0.6, 0.0, 0.8), 60_000, 43, 1.0);
        eprintln!("white base under a Mitsuba-coupled coating, α {alpha} {distribution:?}: albedo {m:.4} ± {se:.4}");
        assert!(m < 1.0 - 4.0 * se && m > 0.4, "white base, α {alpha}: {m} ± {se}");
    }
    let b = Bsdf::Coated(CoatedDiffuse::new(Vec4::new(0.2, 0.5, 0.8, 0.9), 1.5, 0.3).with_mitsuba_coupling());
    check_chi2("coated diffuse α=0.3, Mitsuba coupling", &b, &wos_upper(), 460);
}

#[test]
fn chi2_coated_diffuse() {
    // 9 runs: smooth coating (delta bin + diffuse), rough coatings.
    for (i, alpha) in [0.0f32, 0.3, 0.6].into_iter().enumerate() {
        let b = Bsdf::Coated(CoatedDiffuse::new(Vec4::new(0.2, 0.5, 0.8, 0.9), 1.5, alpha));
        check_chi2(
            &format!("coated diffuse α={alpha}"),
            &b,
            &wos_upper(),
            300 + 10 * i as u64,
        );
    }
}

#[test]
fn chi2_smooth_lobes_and_lambertian() {
    // 3 runs (Lambertian); the smooth conductor's single delta has probability 1 and the mirror direction.
    let (eta, k, _) = gold();
    let c = Bsdf::SmoothConductor(SmoothConductor { eta, k });
    for wo in wos_upper() {
        let wo = wo.normalize();
        let s = c.sample(wo, 0.3, Vec2::new(0.1, 0.9)).unwrap();
        assert!(s.delta && s.pdf == 1.0 && (s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
        assert_eq!(c.pdf(wo, s.wi), 0.0);
    }
    let l = Bsdf::Diffuse { r: Vec4::splat(0.7) };
    check_chi2("lambertian", &l, &wos_upper(), 410);
    // Smooth dielectric: the reflection and refraction deltas are two discrete outcomes with
    // probabilities R and 1 − R; binomial test at 5 standard errors.
    for (eta, wo) in [
        (1.5f32, Vec3::new(0.6, 0.0, 0.8)),
        (1.0 / 1.5, Vec3::new(0.3, 0.0, 0.95)),
        (1.5, Vec3::new(0.99, 0.0, 0.05)),
    ] {
        let wo = wo.normalize();
        let b = Bsdf::SmoothDielectric {
            lobe: SmoothDielectric { eta },
            dispersive: false,
        };
        let r = optics::fresnel::fresnel_dielectric(wo.z as f64, eta as f64);
        let mut rng = Pcg32::new(5, 5);
        let n = 200_000;
        let mut nr = 0usize;
        for _ in 0..n {
            let s = b.sample(wo, rng.next_f32(), rng.next_2d()).unwrap();
            assert!(s.delta);
            let p = if s.transmission {
                1.0 - r
            } else {
                nr += 1;
                r
            };
            assert!((s.pdf as f64 - p).abs() < 1e-5, "discrete probability {} vs {p}", s.pdf);
        }
        let f = nr as f64 / n as f64;
        assert!(
            (f - r).abs() < 5.0 * (r * (1.0 - r) / n as f64).sqrt() + 1e-9,
            "η {eta}: reflected fraction {f} vs R {r}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Reciprocity

#[test]
fn reciprocity() {
    let (eta, k, _) = gold();
    let reflectors = [
        Bsdf::RoughConductor(RoughConductor {
            distrib: gtr(0.3, 0.3),
            eta,
            k,
        }),
        Bsdf::RoughConductor(RoughConductor {
            distrib: gtr(0.1, 0.5),
            eta,
            k,
        }),
        Bsdf::RoughConductor(RoughConductor {
            distrib: gtr(0.1, 0.5).with_distribution(Distribution::Beckmann),
            eta,
            k,
        }),
        Bsdf::Coated(CoatedDiffuse::new(Vec4::new(0.2, 0.5, 0.8, 0.9), 1.5, 0.0)),
        Bsdf::Coated(CoatedDiffuse::new(Vec4::new(0.2, 0.5, 0.8, 0.9), 1.5, 0.4)),
    ];
    let mut rng = Pcg32::new(9, 9);
    let mut nonzero = 0;
    for b in &reflectors {
        for _ in 0..5000 {
            let wo = uniform_sphere(rng.next_2d());
            let mut wi = uniform_sphere(rng.next_2d());
            if wi.z * wo.z < 0.0 {
                wi.z = -wi.z;
            }
            let (f1, f2) = (b.eval(wo, wi), b.eval(wi, wo));
            assert!(
                (f1 - f2).abs().max_element() <= 1e-4 * f1.max_element().max(1e-3),
                "{b:?}: f(wo,wi) {f1} ≠ f(wi,wo) {f2}"
            );
            if f1.max_element() > 0.0 {
                nonzero += 1;
            }
        }
    }
    assert!(nonzero > 15_000);
    // Rough dielectric, radiance transport: f(wo, wi)/n(wo side)² = f(wi, wo)/n(wi side)² (Veach 1997 eq. 5.14).
    for (eta, distrib) in [(1.5f32, gtr(0.3, 0.3)), (1.0 / 1.33, gtr(0.3, 0.3)), (1.5, gtr(0.3, 0.3).with_distribution(Distribution::Beckmann))] {
        let b = Bsdf::RoughDielectric {
            lobe: RoughDielectric {
                distrib,
                eta,
            },
            dispersive: false,
        };
        let n = |w: Vec3| if w.z > 0.0 { 1.0 } else { eta };
        let mut checked = 0;
        for _ in 0..20_000 {
            let wo = uniform_sphere(rng.next_2d());
            let wi = uniform_sphere(rng.next_2d());
            let a = b.eval(wo, wi).x / (n(wo) * n(wo));
            let c = b.eval(wi, wo).x / (n(wi) * n(wi));
            // (absolute slack for f32 rounding near the critical angle, where 1 − F has infinite slope)
            assert!(
                (a - c).abs() <= 2e-3 * a.abs().max(c.abs()) + 1e-5,
                "η {eta}, wo {wo} wi {wi}: {a} vs {c}"
            );
            if a > 1e-3 && wo.z * wi.z < 0.0 {
                checked += 1;
            }
        }
        assert!(checked > 500, "{checked}"); // (Beckmann's short tails leave fewer large transmission values)
    }
}

// ---------------------------------------------------------------------------------------------
// Energy

/// Monte Carlo albedo ∫ f cos θi dωi (with the transmission weighted by `t_weight`) by sampling,
/// with its standard error.
fn albedo(b: &Bsdf, wo: Vec3, n: usize, seed: u64, t_weight: f32) -> (f64, f64) {
    let mut rng = Pcg32::new(seed, 3);
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        if let Some(x) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
            let w = x.f.x * x.wi.z.abs() / x.pdf * if x.transmission { t_weight } else { 1.0 };
            s += w as f64;
            s2 += (w as f64).powi(2);
        }
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m) / n as f64).sqrt())
}

/// The same albedo by quadrature of eval over the sphere (independent of sampling).
fn albedo_quadrature(b: &Bsdf, wo: Vec3) -> f64 {
    let (nt, np) = (400, 200);
    let mut s = 0.0;
    for i in 0..nt {
        // μ = cos θ over [-1, 1] with a μ = ±(1 − t²)-style refinement near the poles is not
        // needed: lobes tested here have α ≥ 0.2.
        let mu = -1.0 + 2.0 * (i as f64 + 0.5) / nt as f64;
        let st = (1.0 - mu * mu).sqrt();
        for j in 0..np {
            let ph = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            let wi = Vec3::new((st * ph.cos()) as f32, (st * ph.sin()) as f32, mu as f32);
            s += b.eval(wo, wi).x as f64 * mu.abs();
        }
    }
    s * (2.0 / nt as f64) * (2.0 * PI / np as f64)
}

#[test]
fn separable_masking_is_g1_times_g1_and_darker_than_the_height_correlated_form() {
    use render::bsdf::microfacet::Masking;
    // The term itself: G1(ωo) G1(ωi) ≤ 1/(1 + Λo + Λi), since (1 + Λo)(1 + Λi) ≥ 1 + Λo + Λi.
    let mut rng = Pcg32::new(21, 5);
    let hc = gtr(0.3, 0.3);
    let sep = hc.with_masking(Masking::Separable);
    for _ in 0..1000 {
        let a = dir((rng.next_f32() as f64) * 0.5 * PI, (rng.next_f32() as f64) * 2.0 * PI);
        let b = dir((rng.next_f32() as f64) * 0.5 * PI, (rng.next_f32() as f64) * 2.0 * PI);
        let (gs, gh) = (sep.g(a, b), hc.g(a, b));
        assert!((gs - hc.g1(a) * hc.g1(b)).abs() <= 1e-6 && gs <= gh + 1e-7, "{a} {b}: separable {gs}, correlated {gh}");
    }
    // The white rough mirror and the rough dielectric with separable masking: sampling and
    // quadrature of eval agree (the sampling weights use the same G), and the albedo is lower
    // than with the height-correlated term, by more at grazing angles.
    let white = (Vec4::ZERO, Vec4::ONE);
    for mu in [0.4f32, 0.15] {
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let mut albedos = Vec::new();
        for masking in [Masking::HeightCorrelated, Masking::Separable] {
            let conductor = Bsdf::RoughConductor(RoughConductor { distrib: gtr(0.5, 0.5).with_masking(masking), eta: white.0, k: white.1 });
            let glass = Bsdf::RoughDielectric {
                lobe: RoughDielectric { distrib: gtr(0.5, 0.5).with_masking(masking), eta: 1.5 },
                dispersive: false,
            };
            for (name, b) in [("white rough conductor", &conductor), ("rough glass", &glass)] {
                let (m, se) = albedo(b, wo, 50_000, 9, 1.0);
                let q = albedo_quadrature(b, wo);
                assert!((q - m).abs() < 4.0 * se + 3e-3, "{name} {masking:?} μ {mu}: quadrature {q} vs sampling {m} ± {se}");
                albedos.push(m);
            }
        }
        // [conductor hc, glass hc, conductor sep, glass sep]
        eprintln!("μ {mu}: albedos (height-correlated, separable) {albedos:?}");
        assert!(albedos[2] < albedos[0] - 0.005 && albedos[3] < albedos[1] - 0.005, "μ {mu}: {albedos:?}");
    }
}

#[test]
fn furnace_white_rough_conductor_never_exceeds_one() {
    // η + ik = 0 + 1i gives |r_s| = |r_p| = 1 at every angle: a perfect (white) mirror.
    let white = (Vec4::ZERO, Vec4::ONE);
    for alpha in [0.02f32, 0.1, 0.3, 0.6, 1.0] {
        let b = Bsdf::RoughConductor(RoughConductor {
            distrib: gtr(alpha, alpha),
            eta: white.0,
            k: white.1,
        });
        for mu in [1.0f32, 0.7, 0.4, 0.15, 0.03] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let (m, se) = albedo(&b, wo, 50_000, 7, 1.0);
            eprintln!("white rough conductor α {alpha} μ {mu}: albedo {m:.4} ± {se:.4}");
            // Every sample weight is G2/G1 ≤ 1, so the estimate is bounded by 1 sample by sample.
            assert!(m <= 1.0 + 1e-5, "α {alpha} μ {mu}: albedo {m} ± {se}");
            // Single scattering loses energy with roughness and grazing angle, but not much for smooth ones.
            // (GGX has heavy tails: at α = 0.1, 6 % of normals tilt beyond tan θm = 0.4, so a few
            // percent of the light is shadowed or sent below the horizon.)
            if alpha <= 0.02 && mu >= 0.4 {
                assert!(m > 0.995, "α {alpha} μ {mu}: albedo {m}");
            }
            if alpha <= 0.1 && mu >= 0.7 {
                assert!(m > 0.97, "α {alpha} μ {mu}: albedo {m}");
            }
            if alpha == 1.0 && mu == 0.15 {
                assert!(
                    m < 0.8,
                    "α {alpha} μ {mu}: albedo {m}: single-scattering GGX must lose energy at grazing"
                );
            }
            if alpha >= 0.3 && mu >= 0.4 {
                // Two independent estimates (sampling vs quadrature of eval) agree.
                let q = albedo_quadrature(&b, wo);
                assert!(
                    (q - m).abs() < 4.0 * se + 3e-3,
                    "α {alpha} μ {mu}: quadrature {q} vs sampling {m} ± {se}"
                );
            }
        }
    }
}

#[test]
fn furnace_rough_dielectric_and_plastic() {
    // Rough dielectric: reflected + transmitted power (radiance weights × η'² undo the 1/η'²
    // radiance compression) ≤ 1 from both sides.
    for alpha in [0.1f32, 0.4, 0.8] {
        for eta in [1.5f32, 1.0 / 1.5] {
            let b = Bsdf::RoughDielectric {
                lobe: RoughDielectric {
                    distrib: gtr(alpha, alpha),
                    eta,
                },
                dispersive: false,
            };
            for mu in [0.9f32, 0.5, 0.1] {
                let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let (m, se) = albedo(&b, wo, 40_000, 11, eta * eta);
                assert!(
                    m <= 1.0 + 4.0 * se,
                    "rough dielectric α {alpha} η {eta} μ {mu}: {m} ± {se}"
                );
                if alpha == 0.1 && mu >= 0.5 {
                    assert!(m > 0.95, "rough dielectric α {alpha} η {eta} μ {mu}: {m}");
                }
            }
        }
    }
    // Plastic: a white base (ρ = 1) conserves energy exactly, for a smooth or rough coating;
    // a grey base gives E + (1 − E) ρ_eff < 1.
    for alpha in [0.0f32, 0.2, 0.5] {
        let b = Bsdf::Coated(CoatedDiffuse::new(Vec4::ONE, 1.5, alpha));
        for mu in [1.0f32, 0.6, 0.2] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let (m, se) = albedo(&b, wo, 60_000, 13, 1.0);
            assert!(
                (m - 1.0).abs() < 4.0 * se + 1e-3,
                "white plastic α {alpha} μ {mu}: {m} ± {se}"
            );
        }
        let g = Bsdf::Coated(CoatedDiffuse::new(Vec4::splat(0.5), 1.5, alpha));
        let (m, se) = albedo(&g, Vec3::Z, 60_000, 14, 1.0);
        // Smooth coating at normal incidence: R0 = 0.04, ρ_eff = 0.5(1 − F_in)/(1 − 0.5 F_in), F_in = F_dr(1/1.5).
        let fin = optics::fresnel::fresnel_diffuse_reflectance(1.0 / 1.5);
        let expect = 0.04 + 0.96 * 0.5 * (1.0 - fin) / (1.0 - 0.5 * fin);
        if alpha == 0.0 {
            assert!((m - expect).abs() < 4.0 * se + 1e-4, "grey plastic: {m} vs {expect}");
        }
        assert!(m < 0.6, "grey plastic α {alpha}: {m}");
        // `nonlinear = false` (Mitsuba 3's default): the albedo is the effective one, so the
        // directional albedo is E(μ) + (1 − E(μ)) ρ: at normal incidence on a smooth coating
        // 0.04 + 0.96 · 0.5. A white base is unchanged.
        let lin = Bsdf::Coated(CoatedDiffuse { nonlinear: false, ..CoatedDiffuse::new(Vec4::splat(0.5), 1.5, alpha) });
        let (m, se) = albedo(&lin, Vec3::Z, 60_000, 15, 1.0);
        if alpha == 0.0 {
            let expect = 0.04 + 0.96 * 0.5;
            assert!((m - expect).abs() < 4.0 * se + 1e-4, "linear grey plastic: {m} vs {expect}");
        }
        let white = Bsdf::Coated(CoatedDiffuse { nonlinear: false, ..CoatedDiffuse::new(Vec4::ONE, 1.5, alpha) });
        let (m, se) = albedo(&white, Vec3::new(0.6, 0.0, 0.8), 60_000, 16, 1.0);
        assert!((m - 1.0).abs() < 4.0 * se + 1e-3, "linear white plastic α {alpha}: {m} ± {se}");
    }
}

#[test]
fn smooth_dielectric_slab_conserves_energy() {
    // A plane-parallel slab of index n between vacuum, no absorption: photons bounce between the
    // two interfaces until they leave. Incoherent sum: R_slab = R + T²R/(1 − R²) = 2R/(1 + R) with
    // R the single-interface Fresnel reflectance at the incidence angle (the internal angle sees
    // the same R by Snell/Stokes), T_slab = 1 − R_slab.
    for (n, mu) in [(1.5f32, 0.9f32), (1.5, 0.3), (2.4, 0.6), (1.33, 0.05)] {
        let top = Bsdf::SmoothDielectric {
            lobe: SmoothDielectric { eta: n },
            dispersive: false,
        };
        let r = optics::fresnel::fresnel_dielectric(mu as f64, n as f64);
        let r_slab = 2.0 * r / (1.0 + r);
        let mut rng = Pcg32::new(21, 1);
        let photons = 100_000;
        let (mut wr, mut wt) = (0.0f64, 0.0f64);
        for _ in 0..photons {
            // Travel direction d (world), starting downwards onto the top face.
            let mut d = Vec3::new(-(1.0 - mu * mu).sqrt(), 0.0, -mu);
            let mut beta = 1.0f32;
            let mut at_top = true;
            let mut bounces = 0;
            loop {
                // Local frame of the face: z = outward normal (+z at the top, −z at the bottom).
                let s = if at_top { 1.0 } else { -1.0 };
                let wo = Vec3::new(-d.x, -d.y, -d.z * s);
                let smp = top.sample(wo, rng.next_f32(), rng.next_2d()).unwrap();
                beta *= smp.f.x * smp.wi.z.abs() / smp.pdf;
                let wi = Vec3::new(smp.wi.x, smp.wi.y, smp.wi.z * s);
                d = wi;
                if smp.wi.z > 0.0 {
                    // Leaving to the outside of this face.
                    if at_top {
                        wr += beta as f64;
                    } else {
                        wt += beta as f64;
                    }
                    break;
                }
                at_top = !at_top;
                bounces += 1;
                assert!(bounces < 10_000);
            }
        }
        let (rm, tm) = (wr / photons as f64, wt / photons as f64);
        eprintln!(
            "slab n {n} μ {mu}: R {rm:.5} (analytic {r_slab:.5}), R + T = {}",
            rm + tm
        );
        // Each escaping photon carries weight exactly 1 (the 1/η'² factors cancel in and out).
        assert!((rm + tm - 1.0).abs() < 1e-4, "n {n} μ {mu}: R + T = {}", rm + tm);
        let se = (r_slab * (1.0 - r_slab) / photons as f64).sqrt();
        assert!(
            (rm - r_slab).abs() < 4.0 * se + 1e-6,
            "n {n} μ {mu}: R {rm} vs analytic {r_slab} (se {se})"
        );
    }
}

/// The thin dielectric lobe against the slab traced face by face: a plane-parallel slab of
/// index n whose two faces are the smooth dielectric lobe, photons followed until they leave,
/// gives the thin sheet's reflected share; the lobe's own estimate, per lane (four indices) and
/// sample by sample, must agree with it and with 2R/(1 + R), and its transmission must be unbent.
#[test]
fn thin_dielectric_is_the_slab_traced_face_by_face() {
    use render::bsdf::ThinDielectric;
    for (n, mu) in [(1.5f32, 0.9f32), (1.5, 0.3), (2.4, 0.6), (1.33, 0.05)] {
        let etas = Vec4::new(n, 1.1 * n, 1.3 * n, 0.9 * n + 0.1);
        let thin = Bsdf::ThinDielectric(ThinDielectric { eta: etas });
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let mut rng = Pcg32::new(31, 2);
        let samples = 100_000;
        let mut r_thin = Vec4::ZERO;
        for _ in 0..samples {
            let smp = thin.sample(wo, rng.next_f32(), rng.next_2d()).unwrap();
            let w = smp.f * smp.wi.z.abs() / smp.pdf;
            assert!(smp.delta && smp.eta == 1.0);
            if smp.transmission {
                assert!((smp.wi + wo).length() < 1e-6, "transmission bends: {}", smp.wi);
            } else {
                assert!((smp.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                r_thin += w;
            }
        }
        let r_thin = r_thin / samples as f32;
        // Reflection and transmission share the light: R′ + T′ = 1 per lane, sample weights aside.
        let smp = |uc: f32| thin.sample(wo, uc, Vec2::ZERO).unwrap();
        let (a, b) = (smp(0.0), smp(0.999_999));
        let (pa, pb) = (a.f * a.wi.z.abs(), b.f * b.wi.z.abs());
        assert!((pa + pb - Vec4::ONE).abs().max_element() < 1e-6, "R′ + T′ = {}", pa + pb);
        // The slab, face by face, for each lane's index.
        for lane in 0..4 {
            let eta = etas[lane];
            let face = Bsdf::SmoothDielectric { lobe: SmoothDielectric { eta }, dispersive: false };
            let photons = 100_000;
            let mut wr = 0.0f64;
            for _ in 0..photons {
                let mut d = Vec3::new(-(1.0 - mu * mu).sqrt(), 0.0, -mu);
                let mut at_top = true;
                loop {
                    let s = if at_top { 1.0 } else { -1.0 };
                    let wo = Vec3::new(-d.x, -d.y, -d.z * s);
                    let smp = face.sample(wo, rng.next_f32(), rng.next_2d()).unwrap();
                    d = Vec3::new(smp.wi.x, smp.wi.y, smp.wi.z * s);
                    if smp.wi.z > 0.0 {
                        if at_top {
                            wr += 1.0;
                        }
                        break;
                    }
                    at_top = !at_top;
                }
            }
            let r_slab = wr / photons as f64;
            let r = optics::fresnel::fresnel_dielectric(mu as f64, eta as f64);
            let exact = 2.0 * r / (1.0 + r);
            let se = (exact * (1.0 - exact) / photons as f64).sqrt();
            assert!((r_slab - exact).abs() < 4.0 * se + 1e-6, "slab n {eta} μ {mu}: {r_slab} vs {exact}");
            // The lobe's estimate: its sampling noise is that of choosing reflection with the lanes'
            // mean probability, at most the same binomial spread again.
            assert!((r_thin[lane] as f64 - r_slab).abs() < 6.0 * se + 1e-4, "lane {lane}, n {eta} μ {mu}: thin {} vs slab {r_slab}", r_thin[lane]);
        }
    }
}

#[test]
fn smooth_dielectric_total_internal_reflection_and_index_matching() {
    // From inside glass (η = 1/1.5) beyond the critical angle (sin θc = 1/1.5): always reflects with weight 1.
    let b = Bsdf::SmoothDielectric {
        lobe: SmoothDielectric { eta: 1.0 / 1.5 },
        dispersive: false,
    };
    let wo = Vec3::new(0.8, 0.0, 0.6);
    let mut rng = Pcg32::new(2, 2);
    for _ in 0..1000 {
        let s = b.sample(wo, rng.next_f32(), rng.next_2d()).unwrap();
        assert!(!s.transmission && (s.f.x * s.wi.z / s.pdf - 1.0).abs() < 1e-6);
    }
    // η = 1: everything passes straight through with weight 1.
    let b = Bsdf::SmoothDielectric {
        lobe: SmoothDielectric { eta: 1.0 },
        dispersive: false,
    };
    let s = b.sample(wo, 0.3, Vec2::ZERO).unwrap();
    assert!(s.transmission && (s.wi + wo).length() < 1e-6 && (s.f.x * s.wi.z.abs() / s.pdf - 1.0).abs() < 1e-6);
    // Hit from inside through the material: from_inside inverts η; refraction obeys Snell both ways.
    let glass = Material::dielectric(
        optics::spectrum::DenseSpectrum::from_fn(|_| 1.5),
        Microfacet::isotropic(0.0),
    );
    let wl = SampledWavelengths::fixed([500.0, 550.0, 600.0, 650.0]);
    let front = glass.bsdf(&wl, glam::Vec2::ZERO);
    let back = front.from_inside();
    let wo = Vec3::new(0.5, 0.0, (0.75f32).sqrt());
    let sf = front.sample(wo, 0.999, Vec2::ZERO).unwrap();
    let sb = back.sample(wo, 0.999, Vec2::ZERO).unwrap();
    assert!(sf.transmission && sb.transmission);
    assert!((sf.wi.x.abs() - 0.5 / 1.5).abs() < 1e-5 && (sf.eta - 1.5).abs() < 1e-6);
    assert!((sb.wi.x.abs() - 0.75).abs() < 1e-5 && (sb.eta - 1.0 / 1.5).abs() < 1e-6);
    assert!(!front.terminates_secondary());
}

#[test]
fn dispersive_glass_terminates_secondary_wavelengths() {
    let bk7 = optics::ior::glass("bk7").unwrap();
    let glass = Material::dielectric(
        optics::spectrum::DenseSpectrum::from_fn(|l| bk7.n(l)),
        Microfacet::isotropic(0.0),
    );
    let wl = SampledWavelengths::fixed([450.0, 550.0, 650.0, 750.0]);
    let b = glass.bsdf(&wl, glam::Vec2::ZERO);
    assert!(b.terminates_secondary());
    // The lobe uses the hero wavelength's index: n(450 nm) of N-BK7 = 1.5253 (Sellmeier).
    let wo = Vec3::new(0.6, 0.0, 0.8);
    let s = b.sample(wo, 0.999, Vec2::ZERO).unwrap();
    assert!(
        (s.eta as f64 - bk7.n(450.0)).abs() < 2e-3 && (s.eta - 1.5253).abs() < 1e-3,
        "{}",
        s.eta
    );
    assert!(
        s.terminate_secondary,
        "the sample must tell the integrator to drop the secondary wavelengths"
    );
    let plain = Material::dielectric(
        optics::spectrum::DenseSpectrum::from_fn(|_| 1.5),
        Microfacet::isotropic(0.2),
    );
    assert!(
        !plain
            .bsdf(&wl, glam::Vec2::ZERO)
            .sample(wo, 0.999, Vec2::new(0.3, 0.3))
            .unwrap()
            .terminate_secondary
    );
    // After termination the material no longer asks for it.
    let mut wl2 = wl;
    wl2.terminate_secondary();
    assert!(!glass.bsdf(&wl2, glam::Vec2::ZERO).terminates_secondary());
}

#[test]
fn gold_normal_incidence_reflectance() {
    // At normal incidence the Fresnel reflectance of a metal is ((n − 1)² + k²)/((n + 1)² + k²).
    let au = optics::ior::metal("au").unwrap();
    let eta = optics::spectrum::DenseSpectrum::from_fn(|l| au.eta_k(l).0);
    let k = optics::spectrum::DenseSpectrum::from_fn(|l| au.eta_k(l).1);
    let m = Material::conductor(eta, k, Microfacet::isotropic(0.0));
    let l = [450.0f32, 550.0, 650.0, 750.0];
    let b = m.bsdf(&SampledWavelengths::fixed(l), glam::Vec2::ZERO);
    let s = b.sample(Vec3::Z, 0.5, Vec2::new(0.5, 0.5)).unwrap();
    assert!(s.delta && s.pdf == 1.0);
    let r = s.f * s.wi.z / s.pdf;
    for i in 0..4 {
        let (n, kk) = au.eta_k(l[i] as f64);
        let expect = ((n - 1.0).powi(2) + kk * kk) / ((n + 1.0).powi(2) + kk * kk);
        assert!((r[i] as f64 - expect).abs() < 2e-3, "λ {}: {} vs {expect}", l[i], r[i]);
    }
    // Gold is yellow: reflects little blue, most red (Au near 450 nm R ≈ 0.37, at 650 nm ≈ 0.95).
    assert!(r.x < 0.45 && r.z > 0.9, "{r}");
    // The rough version tends to the smooth one as α → 0 at normal incidence (albedo → R).
    let rough = Bsdf::RoughConductor(RoughConductor {
        distrib: gtr(0.01, 0.01),
        eta: Vec4::from_array(l.map(|x| au.eta_k(x as f64).0 as f32)),
        k: Vec4::from_array(l.map(|x| au.eta_k(x as f64).1 as f32)),
    });
    let mut rng = Pcg32::new(1, 2);
    let mut acc = Vec4::ZERO;
    let n = 2000;
    for _ in 0..n {
        let s = rough.sample(Vec3::Z, rng.next_f32(), rng.next_2d()).unwrap();
        acc += s.f * s.wi.z / s.pdf;
    }
    acc /= n as f32;
    assert!((acc - r).abs().max_element() < 5e-3, "{acc} vs {r}");
}

/// Follows a path through a unit sphere of `material` (centred at the origin) under a uniform
/// environment of radiance 1, using `Material::bsdf_at` with the front/back-face convention the
/// integrators use (shading z on the side of wo). Returns (throughput at escape, wavelengths).
fn trace_sphere(material: &Material, mut o: Vec3, mut d: Vec3, rng: &mut Pcg32) -> (Vec4, SampledWavelengths) {
    let mut wl = SampledWavelengths::sample(rng.next_f32());
    let mut beta = Vec4::ONE;
    for _ in 0..1000 {
        // Ray–sphere: |o + t d|² = 1, nearest t > ε.
        let b = o.dot(d);
        let c = o.length_squared() - 1.0;
        let disc = b * b - c;
        if disc <= 0.0 {
            return (beta, wl);
        }
        let sq = disc.sqrt();
        let t = if -b - sq > 1e-4 { -b - sq } else { -b + sq };
        if t <= 1e-4 {
            return (beta, wl);
        }
        let p = o + t * d;
        let ng = p.normalize();
        let front = d.dot(ng) < 0.0;
        let n = if front { ng } else { -ng };
        let frame = render::math::sampling::Frame::from_normal(n);
        let bsdf = material.bsdf_at(&mut wl, front, || glam::Vec2::ZERO);
        let wo = frame.to_local(-d);
        let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) else {
            return (Vec4::ZERO, wl);
        };
        beta *= s.f * s.wi.z.abs() / s.pdf;
        d = frame.to_world(s.wi).normalize();
        o = p;
    }
    (Vec4::ZERO, wl)
}

#[test]
fn glass_sphere_furnace_through_material_interface() {
    // A non-absorbing smooth glass sphere under a uniform environment of radiance 1 is invisible:
    // every path that escapes carries weight exactly 1 (the 1/η² radiance compression on the way
    // in is undone on the way out; TIR reflections have weight 1). Without the back-face η → 1/η
    // (`from_inside`) the weight would be 1/η⁴ after two crossings. For dispersive BK7 the
    // secondary wavelengths are terminated and the hero keeps weight 1.
    let mut rng = Pcg32::new(31, 7);
    for (name, ior) in [("1.5", None), ("bk7", Some(optics::ior::glass("bk7").unwrap()))] {
        let spectrum = match ior {
            None => optics::spectrum::DenseSpectrum::from_fn(|_| 1.5),
            Some(g) => optics::spectrum::DenseSpectrum::from_fn(move |l| g.n(l)),
        };
        let m = Material::dielectric(spectrum, Microfacet::isotropic(0.0));
        let mut crossed = 0;
        for k in 0..5000 {
            // Rays from z = −3 towards random points of the unit disk's cross-section.
            let r = (k as f32 + 0.5) / 5000.0;
            let target = Vec3::new(r.sqrt() * 0.999, 0.0, 0.0);
            let o = Vec3::new(0.0, 0.0, -3.0);
            let (beta, wl) = trace_sphere(&m, o, (target - o).normalize(), &mut rng);
            assert!((beta.x - 1.0).abs() < 1e-3, "{name}: hero weight {}", beta.x);
            if name == "1.5" {
                assert!((beta - Vec4::ONE).abs().max_element() < 1e-3, "{name}: {beta}");
                assert!(!wl.secondary_terminated());
            } else {
                assert!(
                    wl.secondary_terminated(),
                    "a BK7 hit must terminate the secondary wavelengths"
                );
                crossed += 1;
            }
        }
        assert!(name == "1.5" || crossed == 5000);
    }
}

#[test]
fn conductor_fresnel_real_form_matches_complex_arithmetic() {
    // Two independent implementations: the renderer's 4-lane real formula and optics' complex one.
    for metal in optics::ior::METAL_NAMES {
        let t = optics::ior::metal(metal).unwrap();
        let l = [380.0f32, 500.0, 620.0, 800.0];
        let eta = Vec4::from_array(l.map(|x| t.eta_k(x as f64).0 as f32));
        let k = Vec4::from_array(l.map(|x| t.eta_k(x as f64).1 as f32));
        for i in 0..=50 {
            let c = i as f32 / 50.0;
            let r = render::bsdf::fresnel::fresnel_conductor(c, eta, k);
            for j in 0..4 {
                let z = complex_index(eta[j] as f64, k[j] as f64);
                let e = optics::fresnel::fresnel_complex(c as f64, z);
                assert!(
                    (r[j] as f64 - e).abs() < 2e-5,
                    "{metal} λ {} cos {c}: {} vs {e}",
                    l[j],
                    r[j]
                );
            }
        }
    }
    // A dielectric is the k = 0 limit: equals the dielectric Fresnel formula.
    for i in 0..=20 {
        let c = i as f32 / 20.0;
        let r = render::bsdf::fresnel::fresnel_conductor(c, Vec4::splat(1.5), Vec4::ZERO).x as f64;
        let e = optics::fresnel::fresnel_dielectric(c as f64, 1.5);
        assert!((r - e).abs() < 2e-5, "cos {c}: {r} vs {e}");
    }
}

/// η + ik as the complex type `optics::fresnel` takes (re-exported through `optics::ior`).
fn complex_index(eta: f64, k: f64) -> optics::ior::Complex64 {
    optics::ior::Complex64::new(eta, k)
}

#[test]
fn rough_dielectric_tends_to_the_smooth_fresnel_split() {
    // As α → 0 the reflected power fraction of the rough interface tends to the Fresnel reflectance
    // of the smooth one (an independent formula), and transmitted power (× η'² to undo the radiance
    // compression) to 1 − R; beyond the critical angle from inside everything reflects.
    for (eta, mu) in [(1.5f32, 0.8f32), (1.5, 0.3), (1.0 / 1.5, 0.9), (1.0 / 1.5, 0.5)] {
        let b = Bsdf::RoughDielectric { lobe: RoughDielectric { distrib: gtr(0.005, 0.005), eta }, dispersive: false };
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let mut rng = Pcg32::new(4, 4);
        let n = 20_000;
        let (mut r, mut t) = (0.0f64, 0.0f64);
        for _ in 0..n {
            if let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
                let w = (s.f.x * s.wi.z.abs() / s.pdf) as f64;
                if s.transmission {
                    t += w * (s.eta as f64).powi(2);
                } else {
                    r += w;
                }
            }
        }
        let (r, t) = (r / n as f64, t / n as f64);
        let f = optics::fresnel::fresnel_dielectric(mu as f64, eta as f64);
        assert!((r - f).abs() < 0.01 && (t - (1.0 - f)).abs() < 0.01, "η {eta} μ {mu}: R {r} T {t} vs Fresnel {f}");
    }
}
