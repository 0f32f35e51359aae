//! The milk model (Frisvad, Christensen & Jensen 2007) against the output of the authors' code and
//! against measured milk (Jensen et al. 2001).

use optics::media::BulkOptions;
use optics::milk;

const REFERENCE: &str = include_str!("../../data/milk/frisvad2007_model_reference_output.csv");

struct Row {
    fat: f64,
    protein: f64,
    pressure: f64,
    r_vs_um: f64,
    fat_vf: f64,
    casein_vf: f64,
    lambda: f64,
    sigma_t: f64,
    sigma_s: f64,
    sigma_a: f64,
    g: f64,
    fat_sigma_s: f64,
    casein_sigma_s: f64,
    fat_g: f64,
    casein_g: f64,
    host_sigma_a: f64,
}

fn reference() -> Vec<Row> {
    let mut lines = REFERENCE.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|s| s.parse().unwrap()).collect();
            Row {
                fat: v[col("fat_wt_pct")],
                protein: v[col("protein_wt_pct")],
                pressure: v[col("pressure_MPa")],
                r_vs_um: v[col("fat_r_vs_um")],
                fat_vf: v[col("fat_volume_fraction")],
                casein_vf: v[col("casein_volume_fraction")],
                lambda: v[col("wavelength_nm")],
                sigma_t: v[col("sigma_t")],
                sigma_s: v[col("sigma_s")],
                sigma_a: v[col("sigma_a")],
                g: v[col("g")],
                fat_sigma_s: v[col("fat_sigma_s")],
                casein_sigma_s: v[col("casein_sigma_s")],
                fat_g: v[col("fat_g")],
                casein_g: v[col("casein_g")],
                host_sigma_a: v[col("host_sigma_a")],
            }
        })
        .collect()
}

fn close(a: f64, b: f64, rel: f64, abs: f64) -> bool {
    (a - b).abs() <= rel * b.abs() + abs
}

/// Regression against Frisvad's own milk code (compiled and run for this project; see the data README).
/// Its values are printed with 5–6 significant digits (g with 4 decimals for the components).
#[test]
fn matches_frisvad_reference_output() {
    let rows = reference();
    assert_eq!(rows.len(), 68);
    let mut worst = [0.0f64; 4];
    for case in rows.chunks(17) {
        let r0 = &case[0];
        let (rvs, _) = milk::fat_size_m(r0.fat, r0.pressure);
        assert!(close(rvs * 1e6, r0.r_vs_um, 0.0, 6e-5), "r_vs {} vs {}", rvs * 1e6, r0.r_vs_um);
        let (vf, vc) = milk::volume_fractions(r0.fat, r0.protein);
        assert!(close(vf, r0.fat_vf, 0.0, 6e-6) && close(vc, r0.casein_vf, 0.0, 6e-6));
        let lambda: Vec<f64> = case.iter().map(|r| r.lambda).collect();
        let p = milk::milk_properties_with(r0.fat, r0.protein, r0.pressure, &lambda, &BulkOptions::default()).unwrap();
        for (i, r) in case.iter().enumerate() {
            let mm = |v: f64| v * 1e-3; // m⁻¹ → mm⁻¹
            let what = format!("fat {} p {} λ {}", r.fat, r.pressure, r.lambda);
            let e = |a: f64, b: f64| ((a - b) / b).abs();
            worst[0] = worst[0].max(e(mm(p.sigma_s_per_m[i]), r.sigma_s));
            worst[1] = worst[1].max(e(mm(p.sigma_t_per_m[i]), r.sigma_t));
            worst[2] = worst[2].max((p.g[i] - r.g).abs());
            worst[3] = worst[3].max(e(mm(p.sigma_a_per_m[i]), r.sigma_a));
            assert!(close(mm(p.host_sigma_a_per_m[i]), r.host_sigma_a, 1e-3, 1e-6), "{what}: host σa {} vs {}", mm(p.host_sigma_a_per_m[i]), r.host_sigma_a);
            assert!(close(mm(p.sigma_s_per_m[i]), r.sigma_s, 1e-4, 1e-5), "{what}: σs {} vs {}", mm(p.sigma_s_per_m[i]), r.sigma_s);
            assert!(close(mm(p.sigma_t_per_m[i]), r.sigma_t, 1e-4, 1e-5), "{what}: σt {} vs {}", mm(p.sigma_t_per_m[i]), r.sigma_t);
            // σ_a = σ_t − σ_s is a difference of numbers ~10⁴ times larger: the reference code's own
            // Mie error (its README: a D_n start-index issue, 6th digit of σ_t) dominates. Our absorption is
            // checked independently in tests/media.rs (two Mie paths agree on C_abs to 1e-9).
            assert!((mm(p.sigma_a_per_m[i]) - r.sigma_a).abs() <= 2e-5 * r.sigma_t + 2e-6, "{what}: σa {} vs {}", mm(p.sigma_a_per_m[i]), r.sigma_a);
            assert!(close(p.g[i], r.g, 0.0, 2e-5), "{what}: g {} vs {}", p.g[i], r.g);
            let fat = &p.components[0];
            let cas = &p.components[1];
            assert!(close(mm(fat.sigma_s_per_m[i]), r.fat_sigma_s, 1e-4, 1e-5), "{what}: fat σs {} vs {}", mm(fat.sigma_s_per_m[i]), r.fat_sigma_s);
            assert!(close(mm(cas.sigma_s_per_m[i]), r.casein_sigma_s, 1e-4, 1e-5), "{what}: casein σs {} vs {}", mm(cas.sigma_s_per_m[i]), r.casein_sigma_s);
            assert!(close(fat.g[i], r.fat_g, 0.0, 6e-5), "{what}: fat g {} vs {}", fat.g[i], r.fat_g);
            assert!(close(cas.g[i], r.casein_g, 0.0, 6e-5), "{what}: casein g {} vs {}", cas.g[i], r.casein_g);
        }
    }
    eprintln!("worst relative error: σs {:.2e}, σt {:.2e}, σa {:.2e}; worst |Δg| {:.2e}", worst[0], worst[1], worst[3], worst[2]);
}

fn lambdas() -> Vec<f64> {
    (0..17).map(|i| 375.0 + 25.0 * i as f64).collect()
}

/// Scattering rises with fat content (homogenized and unhomogenized), at every wavelength.
#[test]
fn scattering_rises_with_fat() {
    let l = lambdas();
    for pressure in [0.0, 20.0] {
        let mut prev: Option<Vec<f64>> = None;
        for fat in [0.1, 0.5, 1.0, 2.0, 3.5, 5.0, 10.0] {
            let p = milk::milk_properties_with(fat, 3.4, pressure, &l, &BulkOptions::default()).unwrap();
            if let Some(q) = &prev {
                for i in 0..l.len() {
                    assert!(p.sigma_s_per_m[i] > q[i], "fat {fat} p {pressure} λ {}", l[i]);
                }
            }
            prev = Some(p.sigma_s_per_m.clone());
        }
    }
}

/// Homogenization (smaller globules) lowers g and raises the reduced scattering σ_s(1−g) per unit fat.
#[test]
fn homogenization_lowers_g_and_raises_reduced_scattering() {
    let l = lambdas();
    for fat in [1.5, 3.5] {
        let raw = milk::milk_properties_with(fat, 3.4, 0.0, &l, &BulkOptions::default()).unwrap();
        let hom = milk::milk_properties_with(fat, 3.4, 20.0, &l, &BulkOptions::default()).unwrap();
        for i in 0..l.len() {
            assert!(hom.g[i] < raw.g[i], "fat {fat} λ {}: g {} vs {}", l[i], hom.g[i], raw.g[i]);
            let red = |p: &optics::media::BulkProperties| p.components[0].sigma_s_per_m[i] * (1.0 - p.components[0].g[i]) / fat;
            assert!(red(&hom) > red(&raw), "fat {fat} λ {}", l[i]);
        }
    }
}

/// Skim milk: σ_s(1−g) within 30 % of Jensen et al. 2001's measured skim milk
/// (H. W. Jensen, S. R. Marschner, M. Levoy, P. Hanrahan, "A practical model for subsurface light
/// transport", SIGGRAPH 2001, Table: skim milk σ_s′ = 0.70, 1.22, 1.90 mm⁻¹ for R, G, B).
#[test]
fn skim_milk_reduced_scattering_near_jensen_2001() {
    let l = [450.0, 550.0, 650.0];
    let measured = [1.90, 1.22, 0.70];
    let p = milk::milk_properties_with(0.1, 3.4, 20.0, &l, &BulkOptions::default()).unwrap();
    for i in 0..3 {
        let red_mm = p.sigma_s_per_m[i] * (1.0 - p.g[i]) * 1e-3;
        let err = (red_mm - measured[i]).abs() / measured[i];
        eprintln!("λ {}: σs' {red_mm:.3} mm⁻¹ vs {} ({:.0} %)", l[i], measured[i], err * 100.0);
        assert!(err < 0.30, "λ {}: σs' {red_mm} vs {}", l[i], measured[i]);
    }
}

/// The tabulated bulk phase function is normalised and its mean cosine is the bulk g.
#[test]
fn milk_phase_table_normalised_with_mean_cosine_g() {
    let p = milk::milk_properties(0.1, 3.4, 20.0, &[450.0, 650.0]).unwrap();
    let t = p.phase.as_ref().unwrap();
    assert_eq!(t.cos_theta.len(), 181);
    for (w, row) in t.per_sr.iter().enumerate() {
        let (mut norm, mut mean) = (0.0, 0.0);
        for j in 0..row.len() - 1 {
            // trapezoid in θ of 2π p sin θ
            let (t0, t1) = (t.theta_deg[j].to_radians(), t.theta_deg[j + 1].to_radians());
            let f0 = row[j] * t0.sin();
            let f1 = row[j + 1] * t1.sin();
            norm += 0.5 * (f0 + f1) * (t1 - t0) * 2.0 * std::f64::consts::PI;
            mean += 0.5 * (f0 * t0.cos() + f1 * t1.cos()) * (t1 - t0) * 2.0 * std::f64::consts::PI;
        }
        assert!((norm - 1.0).abs() < 1e-3, "norm {norm}");
        assert!((mean - p.g[w]).abs() < 2e-3, "mean {mean} vs g {}", p.g[w]);
    }
}

#[test]
fn bad_content_declaration_is_an_error() {
    let l = [550.0];
    for (f, pr, h) in [(101.0, 3.4, 20.0), (-1.0, 3.4, 20.0), (f64::NAN, 3.4, 20.0), (3.5, -1.0, 20.0), (3.5, 3.4, -5.0), (3.5, 3.4, f64::INFINITY), (60.0, 50.0, 0.0)] {
        let e = milk::milk_properties(f, pr, h, &l);
        assert!(e.is_err(), "fat {f} protein {pr} pressure {h} accepted");
    }
}
