//! Spectrum tests: tabulated spectra, CSV reading, Planck's law, dense lookup, RGB uplift.

use optics::color::{spectrum_to_xyz, xyz_to_linear_srgb};
use optics::spectrum::*;

#[test]
fn tabulated_is_piecewise_linear_and_zero_outside() {
    let t = Tabulated::new(vec![400.0, 500.0, 700.0], vec![1.0, 3.0, 2.0]).unwrap();
    assert_eq!(t.eval(400.0), 1.0);
    assert_eq!(t.eval(450.0), 2.0);
    assert_eq!(t.eval(500.0), 3.0);
    assert_eq!(t.eval(600.0), 2.5);
    assert_eq!(t.eval(700.0), 2.0);
    assert_eq!(t.eval(399.999), 0.0);
    assert_eq!(t.eval(700.001), 0.0);
    assert_eq!(t.eval(f64::NAN), 0.0);
    assert!(Tabulated::new(vec![400.0, 400.0], vec![1.0, 1.0]).is_err());
    assert!(Tabulated::new(vec![400.0, 500.0], vec![1.0]).is_err());
    assert!(Tabulated::new(vec![400.0, 500.0], vec![1.0, f64::NAN]).is_err());
    assert!(Tabulated::new(vec![], vec![]).is_err());
}

#[test]
fn csv_reader() {
    let text = "# comment\n\nwavelength_nm, value ,other\n400,0.5,1\n# mid comment\n500,0.25,2\n";
    let (names, cols) = read_csv_columns(text).unwrap();
    assert_eq!(names, ["wavelength_nm", "value", "other"]);
    assert_eq!(
        cols,
        vec![vec![400.0, 500.0], vec![0.5, 0.25], vec![1.0, 2.0]]
    );
    let t = Tabulated::from_csv(text, "value").unwrap();
    assert_eq!(t.eval(450.0), 0.375);
    let err = read_csv_columns("a,b\n1,x\n").unwrap_err().to_string();
    assert!(err.contains("line 2") && err.contains("'b'"), "{err}");
    let err = read_csv_columns("a,b\n1,2,3\n").unwrap_err().to_string();
    assert!(err.contains("line 2"), "{err}");
    assert!(read_csv_columns("# only\n").is_err());
    assert!(Tabulated::from_csv(text, "missing").is_err());
}

/// Stefan–Boltzmann: ∫B(λ,T)dλ = σT⁴/π, σ = 5.670374419e-8 W·m⁻²·K⁻⁴ (CODATA 2018).
#[test]
fn planck_integrates_to_stefan_boltzmann() {
    const SIGMA: f64 = 5.670_374_419e-8;
    for &t in &[300.0, 2856.0, 5778.0, 10000.0] {
        // Integrate in u = ln λ (λ from 1e-8·b/T to 1e4·b/T), composite Simpson.
        let lmin: f64 = (WIEN_B_M_K / t * 1e-2).ln();
        let lmax: f64 = (WIEN_B_M_K / t * 1e4).ln();
        let n = 20000;
        let h = (lmax - lmin) / n as f64;
        let mut s = 0.0;
        for i in 0..=n {
            let u = lmin + i as f64 * h;
            let l = u.exp();
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            s += w * planck_radiance(l, t) * l;
        }
        s *= h / 3.0;
        let expect = SIGMA * t.powi(4) / std::f64::consts::PI;
        assert!((s / expect - 1.0).abs() < 1e-6, "T={t}: {s} vs {expect}");
    }
}

/// Wien's displacement law: λ_max T = b = 2.897771955e-3 m·K (CODATA 2018).
#[test]
fn wien_displacement() {
    for &t in &[1000.0, 3000.0, 5778.0, 6500.0] {
        // Golden-section search for the maximum of B(λ, T).
        let (mut a, mut b) = (0.2 * WIEN_B_M_K / t, 5.0 * WIEN_B_M_K / t);
        let gr = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..200 {
            let c = b - gr * (b - a);
            let d = a + gr * (b - a);
            if planck_radiance(c, t) > planck_radiance(d, t) {
                b = d;
            } else {
                a = c;
            }
        }
        let lmax = 0.5 * (a + b);
        assert!(
            (lmax * t / 2.897_771_955e-3 - 1.0).abs() < 1e-7,
            "T={t}: {}",
            lmax * t
        );
        // Normalised blackbody: 1 at the peak, below elsewhere.
        assert!((planck_normalized(lmax * 1e9, t) - 1.0).abs() < 1e-9);
        assert!(planck_normalized(550.0, t) <= 1.0);
    }
}

/// Spot values of Planck's law: B(500 nm, 5000 K) = 1.2107e13 W·m⁻²·sr⁻¹·m⁻¹ (hand evaluation:
/// 2hc²/λ⁵ = 3.8145e15, x = hc/λkT = 5.7550, 1/(eˣ−1) = 3.1740e-3).
#[test]
fn planck_spot_value() {
    let b = planck_radiance(500e-9, 5000.0);
    assert!((b / 1.2107e13 - 1.0).abs() < 1e-3, "{b}");
    assert_eq!(planck_radiance(-1.0, 5000.0), 0.0);
    assert_eq!(planck_radiance(500e-9, 0.0), 0.0);
    let s = Spectrum::Blackbody {
        temperature_k: 5000.0,
        scale: 2.0,
    };
    assert!((s.eval(500.0) - 2.0 * planck_normalized(500.0, 5000.0)).abs() < 1e-15);
}

#[test]
fn dense_spectrum_matches_source() {
    let f = |l: f64| 0.5 + 0.4 * (l / 37.0).sin();
    let d = DenseSpectrum::from_fn(f);
    assert_eq!(d.samples().len(), 471);
    for i in 0..=4700 {
        let l = 360.0 + i as f64 * 0.1;
        let v = d.eval(l as f32) as f64;
        // Linear interpolation error ≤ h²/8·max|f''| = 1/8·0.4/37² ≈ 3.7e-5.
        assert!((v - f(l)).abs() < 5e-5, "{l}: {v} vs {}", f(l));
    }
    assert_eq!(d.eval(359.5), 0.0);
    assert_eq!(d.eval(830.5), 0.0);
    assert_eq!(d.eval(f32::NAN), 0.0);
    assert_eq!(d.eval(830.0), f(830.0) as f32);
}

/// Deterministic xorshift for the random-colour tests.
fn rng(seed: &mut u64) -> f64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// Uplift: white → exactly 1 everywhere, grey → exactly the grey.
#[test]
fn uplift_white_and_grey_are_exact() {
    for g in [0.0, 0.18, 0.5, 1.0] {
        let a = RgbAlbedo::new([g, g, g]);
        for l in (360..=830).step_by(7) {
            assert_eq!(a.eval(l as f64), g);
        }
    }
    // White under the RGB illuminant is D65 with Y = 1 and linear sRGB (1, 1, 1).
    let w = RgbIlluminant::new([1.0, 1.0, 1.0]);
    let rgb = xyz_to_linear_srgb(spectrum_to_xyz(|l| w.eval(l)));
    for c in rgb {
        assert!((c - 1.0).abs() < 2e-3, "{rgb:?}");
    }
    assert!((spectrum_to_xyz(|l| w.eval(l))[1] - 1.0).abs() < 1e-12);
}

/// Many random RGB in [0,1]³: reflectance in [0, 1] at every wavelength, and the sRGB of the
/// reflectance lit by D65 reproduces the input (max abs error over 2000 colours reported).
#[test]
fn uplift_random_colours_bounded_and_round_trip() {
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut worst = 0.0f64;
    let mut sum = 0.0f64;
    let n = 2000;
    for _ in 0..n {
        let rgb = [rng(&mut seed), rng(&mut seed), rng(&mut seed)];
        let a = RgbAlbedo::new(rgb);
        for i in 0..=940 {
            let v = a.eval(360.0 + i as f64 * 0.5);
            assert!(
                (0.0..=1.0).contains(&v),
                "{rgb:?} at {} nm: {v}",
                360.0 + i as f64 * 0.5
            );
        }
        let back = a.linear_srgb();
        let e = (0..3).map(|k| (back[k] - rgb[k]).abs()).fold(0.0, f64::max);
        worst = worst.max(e);
        sum += e;
    }
    eprintln!(
        "uplift round trip: mean max-abs error {:.2e}, worst {:.2e}",
        sum / n as f64,
        worst
    );
    let mean = sum / n as f64;
    assert!(mean < 1e-6, "mean error {mean}");
    assert!(worst < 1e-4, "worst error {worst}");
}

/// Saturated and extreme colours still stay in [0, 1] and come close.
#[test]
fn uplift_corners() {
    for rgb in [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 1.0],
        [1.0, 0.0, 1.0],
        [1e-3, 0.0, 0.0],
        [0.999, 1.0, 1.0],
    ] {
        let a = RgbAlbedo::new(rgb);
        for i in 0..=470 {
            let v = a.eval(360.0 + i as f64);
            assert!((0.0..=1.0).contains(&v));
        }
        let back = a.linear_srgb();
        eprintln!("{rgb:?} -> {back:?}");
        // sRGB primaries and secondaries lie inside the object-colour solid under D65, so the
        // sigmoid family reaches them closely (Jakob & Hanika 2019, Fig. 6).
        for k in 0..3 {
            assert!((back[k] - rgb[k]).abs() < 1e-3, "{rgb:?} -> {back:?}");
        }
    }
    // Out-of-range input is clamped, never giving reflectance above 1.
    let a = RgbAlbedo::new([2.0, -1.0, f64::NAN]);
    assert!((360..=830).all(|l| (0.0..=1.0).contains(&a.eval(l as f64))));
}

/// RGB illuminant: linear in its scale, round-trips its colour.
#[test]
fn rgb_illuminant_round_trip() {
    let mut seed = 42u64;
    for _ in 0..200 {
        let rgb = [
            rng(&mut seed) * 5.0,
            rng(&mut seed) * 5.0,
            rng(&mut seed) * 5.0,
        ];
        let s = RgbIlluminant::new(rgb);
        let back = xyz_to_linear_srgb(spectrum_to_xyz(|l| s.eval(l)));
        let m = rgb[0].max(rgb[1]).max(rgb[2]);
        for k in 0..3 {
            assert!((back[k] - rgb[k]).abs() < 0.02 * m, "{rgb:?} -> {back:?}");
        }
    }
    assert_eq!(RgbIlluminant::new([0.0, 0.0, 0.0]).eval(550.0), 0.0);
}

/// Near-grey, near-white and near-black colours (where the sigmoid must approach 0 or 1 closely)
/// round-trip to within 1e-3.
#[test]
fn uplift_near_degenerate_colours() {
    for rgb in [[0.5, 0.5, 0.5000001], [1.0, 1.0, 0.999], [1e-9, 0.0, 0.0], [0.0, 1e-4, 1.0], [1.0, 1e-6, 1.0]] {
        let back = RgbAlbedo::new(rgb).linear_srgb();
        for k in 0..3 {
            assert!((back[k] - rgb[k]).abs() < 1e-3, "{rgb:?} -> {back:?}");
        }
    }
}

/// The two routes of the texture uplift, the coefficient table refined and the direct homotopy
/// fit, give reflectances whose linear sRGB under D65 is the target to 1e-9 (saturated corners,
/// near-greys and dark colours included), and the same spectra to 1e-6; an illuminant's scale
/// and shape likewise.
#[test]
fn uplift_table_and_direct_fit_agree() {
    use optics::spectrum::reflectance_to_linear_srgb;
    use optics::uplift::{Fit, SigmoidSpectrum};
    let colours = [[0.8, 0.2, 0.1], [0.05, 0.9, 0.3], [0.5, 0.5, 0.51], [0.01, 0.02, 0.015], [0.95, 0.96, 0.2], [0.3, 0.1, 0.7], [1.0, 0.0, 0.0]];
    for rgb in colours {
        let (a, b) = (SigmoidSpectrum::reflectance_by(rgb, Fit::Table), SigmoidSpectrum::reflectance_by(rgb, Fit::Direct));
        for s in [a, b] {
            let got = reflectance_to_linear_srgb(|l| s.eval(l));
            if rgb != [1.0, 0.0, 0.0] {
                assert!((0..3).all(|k| (got[k] - rgb[k]).abs() < 1e-9), "{rgb:?}: {got:?}");
            }
        }
        for l in (360..=830).step_by(10) {
            let (x, y) = (a.eval(l as f64), b.eval(l as f64));
            assert!((x - y).abs() < 1e-6, "{rgb:?} at {l} nm: table {x}, direct {y}");
        }
    }
    let (a, b) = (SigmoidSpectrum::illuminant_by([3.0, 1.0, 0.5], Fit::Table), SigmoidSpectrum::illuminant_by([3.0, 1.0, 0.5], Fit::Direct));
    assert_eq!(a.scale, b.scale);
    assert!((a.eval(550.0) - b.eval(550.0)).abs() < 1e-6);
}

/// A header naming a column twice, and a wavelength that is not positive, are refused on one line
/// naming the line or sample.
#[test]
fn duplicate_columns_and_non_positive_wavelengths_are_refused() {
    let e = read_csv_columns("wavelength_nm,v,v\n400,0.5,0.4\n").unwrap_err().to_string();
    assert!(e.contains("line 1") && e.contains("'v'") && e.contains("twice"), "{e}");
    let e = optics::spectrum::Tabulated::from_csv("wavelength_nm,v\n-400,0.5\n600,0.5\n", "v").unwrap_err().to_string();
    assert!(e.contains("sample 0") && e.contains("-400") && !e.contains('\n'), "{e}");
    assert!(optics::spectrum::Tabulated::from_csv("wavelength_nm,v\n0,0.5\n600,0.5\n", "v").is_err());
}
