//! Pixelwise comparison: CIEDE2000 against the published test data, closed forms for SSIM, the
//! statistics of known noise for RMSE/PSNR, recovery of a known colour matrix, masks, bad input.

use analysis::compare::{
    apply_color_matrix, compare, delta_e2000, error_image, fit_color_matrix, linear_srgb_to_lab, ssim, Mask,
    REL_MSE_EPSILON, SSIM_K1, SSIM_K2,
};
use render::image_io::Image;

/// Small deterministic generator (xorshift64*), uniform in [0, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn random_image(w: u32, h: u32, lo: f64, hi: f64, seed: u64) -> Image {
    let mut rng = Rng(seed);
    let mut img = Image::new(w, h);
    for p in img.rgb.iter_mut() {
        *p = std::array::from_fn(|_| (lo + (hi - lo) * rng.next()) as f32);
    }
    img
}

/// Table I of G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 color-difference formula:
/// implementation notes, supplementary test data, and mathematical observations",
/// Color Research & Application 30(1), 21–30 (2005): the 34 pairs (L1, a1, b1, L2, a2, b2, ΔE00).
const SHARMA_2005: [[f64; 7]; 34] = [
    [50.0, 2.6772, -79.7751, 50.0, 0.0, -82.7485, 2.0425],
    [50.0, 3.1571, -77.2803, 50.0, 0.0, -82.7485, 2.8615],
    [50.0, 2.8361, -74.0200, 50.0, 0.0, -82.7485, 3.4412],
    [50.0, -1.3802, -84.2814, 50.0, 0.0, -82.7485, 1.0000],
    [50.0, -1.1848, -84.8006, 50.0, 0.0, -82.7485, 1.0000],
    [50.0, -0.9009, -85.5211, 50.0, 0.0, -82.7485, 1.0000],
    [50.0, 0.0, 0.0, 50.0, -1.0, 2.0, 2.3669],
    [50.0, -1.0, 2.0, 50.0, 0.0, 0.0, 2.3669],
    [50.0, 2.49, -0.001, 50.0, -2.49, 0.0009, 7.1792],
    [50.0, 2.49, -0.001, 50.0, -2.49, 0.0010, 7.1792],
    [50.0, 2.49, -0.001, 50.0, -2.49, 0.0011, 7.2195],
    [50.0, 2.49, -0.001, 50.0, -2.49, 0.0012, 7.2195],
    [50.0, -0.001, 2.49, 50.0, 0.0009, -2.49, 4.8045],
    [50.0, -0.001, 2.49, 50.0, 0.0010, -2.49, 4.8045],
    [50.0, -0.001, 2.49, 50.0, 0.0011, -2.49, 4.7461],
    [50.0, 2.5, 0.0, 50.0, 0.0, -2.5, 4.3065],
    [50.0, 2.5, 0.0, 73.0, 25.0, -18.0, 27.1492],
    [50.0, 2.5, 0.0, 61.0, -5.0, 29.0, 22.8977],
    [50.0, 2.5, 0.0, 56.0, -27.0, -3.0, 31.9030],
    [50.0, 2.5, 0.0, 58.0, 24.0, 15.0, 19.4535],
    [50.0, 2.5, 0.0, 50.0, 3.1736, 0.5854, 1.0000],
    [50.0, 2.5, 0.0, 50.0, 3.2972, 0.0, 1.0000],
    [50.0, 2.5, 0.0, 50.0, 1.8634, 0.5757, 1.0000],
    [50.0, 2.5, 0.0, 50.0, 3.2592, 0.3350, 1.0000],
    [60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644],
    [63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630],
    [61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731],
    [35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645],
    [22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373],
    [36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146],
    [90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441],
    [90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381],
    [6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377],
    [2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082],
];

#[test]
fn ciede2000_matches_sharma_wu_dalal_table() {
    for (i, r) in SHARMA_2005.iter().enumerate() {
        let (a, b) = ([r[0], r[1], r[2]], [r[3], r[4], r[5]]);
        let d = delta_e2000(a, b);
        // The table gives four decimals: agreement to rounding.
        assert!((d - r[6]).abs() <= 5e-5 + 1e-9, "pair {}: {d:.6} vs {}", i + 1, r[6]);
        // The formula is symmetric for every pair of this table.
        assert!((delta_e2000(b, a) - d).abs() < 1e-12, "pair {} not symmetric", i + 1);
    }
    assert_eq!(delta_e2000([52.0, 10.0, -30.0], [52.0, 10.0, -30.0]), 0.0);
}

#[test]
fn lab_of_white_and_primaries() {
    let w = linear_srgb_to_lab([1.0, 1.0, 1.0]);
    assert!((w[0] - 100.0).abs() < 1e-9 && w[1].abs() < 1e-9 && w[2].abs() < 1e-9, "{w:?}");
    // sRGB red in CIELAB (D65): L* 53.24, a* 80.09, b* 67.20 (e.g. B. Lindbloom's calculator and
    // IEC 61966-2-1 primaries); blue: 32.30, 79.19, −107.86.
    let r = linear_srgb_to_lab([1.0, 0.0, 0.0]);
    for (got, want) in r.iter().zip([53.24, 80.09, 67.20]) {
        assert!((got - want).abs() < 0.02, "red {r:?}");
    }
    let b = linear_srgb_to_lab([0.0, 0.0, 1.0]);
    for (got, want) in b.iter().zip([32.30, 79.19, -107.86]) {
        assert!((got - want).abs() < 0.02, "blue {b:?}");
    }
    // Mid grey of luminance 0.18 has L* = 116·0.18^(1/3) − 16 = 49.50.
    let g = linear_srgb_to_lab([0.18, 0.18, 0.18]);
    assert!((g[0] - (116.0 * 0.18f64.cbrt() - 16.0)).abs() < 1e-9);
    // Linear segment of L* below (6/29)³: L* = 903.3 Y.
    let d = linear_srgb_to_lab([0.001, 0.001, 0.001]);
    assert!((d[0] - 0.001 * 24389.0 / 27.0).abs() < 1e-9, "{d:?}");
}

#[test]
fn identical_images_are_perfect() {
    let img = random_image(40, 30, 0.0, 1.5, 7);
    let c = compare(&img, &img, None, false).unwrap();
    let m = &c.metrics;
    assert_eq!(m.rmse, 0.0);
    assert_eq!(m.rel_mse, 0.0);
    assert!(m.psnr_db.is_infinite() && m.psnr_db > 0.0);
    assert!((m.ssim - 1.0).abs() < 1e-12, "ssim {}", m.ssim);
    assert_eq!(m.delta_e2000_mean, 0.0);
    assert_eq!(m.pixels, 1200);
    assert!(m.color_matrix.is_none());
}

#[test]
fn known_noise_gives_expected_rmse_and_psnr() {
    // Additive uniform noise in [−a, a]: E[d²] = a²/3, Var[d²] = a⁴/5 − a⁴/9 = 4a⁴/45.
    let (w, h, a) = (256u32, 256u32, 0.05f64);
    let photo = random_image(w, h, 0.2, 0.8, 11);
    let mut rng = Rng(12345);
    let mut render = photo.clone();
    for p in render.rgb.iter_mut() {
        for c in p.iter_mut() {
            *c += (a * (2.0 * rng.next() - 1.0)) as f32;
        }
    }
    let m = compare(&render, &photo, None, false).unwrap().metrics;
    let n = (3 * w * h) as f64;
    let mse_expected = a * a / 3.0;
    let mse_se = (4.0 * a.powi(4) / 45.0 / n).sqrt();
    let mse = m.rmse * m.rmse;
    assert!((mse - mse_expected).abs() < 4.0 * mse_se, "mse {mse} vs {mse_expected} ± {mse_se}");
    // PSNR with peak 1: −10 log10(MSE); its standard error follows from the MSE's.
    let psnr_expected = -10.0 * mse_expected.log10();
    let psnr_se = 10.0 / std::f64::consts::LN_10 * mse_se / mse_expected;
    assert!((m.psnr_db - psnr_expected).abs() < 4.0 * psnr_se, "psnr {} vs {psnr_expected}", m.psnr_db);
    assert!((m.psnr_db + 10.0 * mse.log10()).abs() < 1e-9);
    // Relative MSE: E[d²/(b²+ε)] = a²/3 · E[1/(b²+ε)], b uniform on [0.2, 0.8]:
    // E[1/(b²+ε)] = (1/0.6)·(1/√ε)·[atan(b/√ε)] from 0.2 to 0.8.
    let se = REL_MSE_EPSILON.sqrt();
    let inv_mean = ((0.8 / se).atan() - (0.2 / se).atan()) / se / 0.6;
    let rel_expected = mse_expected * inv_mean;
    assert!((m.rel_mse - rel_expected).abs() < 0.02 * rel_expected, "rel_mse {} vs {rel_expected}", m.rel_mse);
    // Noise lowers SSIM; more noise lowers it more.
    assert!(m.ssim < 0.999);
    let mut worse = photo.clone();
    for (p, q) in worse.rgb.iter_mut().zip(&render.rgb) {
        for c in 0..3 {
            p[c] += 3.0 * (q[c] - p[c]);
        }
    }
    let m3 = compare(&worse, &photo, None, false).unwrap().metrics;
    assert!(m3.ssim < m.ssim && m3.delta_e2000_mean > m.delta_e2000_mean);
    assert!((m3.rmse / m.rmse - 3.0).abs() < 1e-3);
}

#[test]
fn ssim_of_constant_images_has_closed_form() {
    // Zero variance: SSIM = (2 μx μy + C1) / (μx² + μy² + C1) at every pixel.
    let (mx, my) = (0.5f32, 0.3f32);
    let a = Image { width: 16, height: 12, rgb: vec![[mx; 3]; 192] };
    let b = Image { width: 16, height: 12, rgb: vec![[my; 3]; 192] };
    let c1 = SSIM_K1 * SSIM_K1;
    // Luminance of a grey is the grey value (the Y row of the matrix sums to 1).
    let (x, y) = (mx as f64, my as f64);
    let expected = (2.0 * x * y + c1) / (x * x + y * y + c1);
    let s = ssim(&a, &b, None).unwrap();
    assert!((s - expected).abs() < 1e-6, "{s} vs {expected}");
}

/// Direct (non-separable) SSIM, Wang et al.'s definition, over the full-window pixels.
fn ssim_brute_force(a: &Image, b: &Image) -> f64 {
    let (w, h) = (a.width as i64, a.height as i64);
    let lum = |p: [f32; 3]| 0.212_639_0 * p[0] as f64 + 0.715_168_7 * p[1] as f64 + 0.072_192_3 * p[2] as f64;
    let mut g = [[0.0f64; 11]; 11];
    let mut total = 0.0;
    for (i, row) in g.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            let (dx, dy) = (j as f64 - 5.0, i as f64 - 5.0);
            *v = (-(dx * dx + dy * dy) / (2.0 * 1.5 * 1.5)).exp();
            total += *v;
        }
    }
    let (c1, c2) = ((SSIM_K1).powi(2), (SSIM_K2).powi(2));
    let (mut sum, mut n) = (0.0, 0);
    for cy in 5..h - 5 {
        for cx in 5..w - 5 {
            let (mut mx, mut my) = (0.0, 0.0);
            for i in 0..11 {
                for j in 0..11 {
                    let k = ((cy + i - 5) * w + cx + j - 5) as usize;
                    let wt = g[i as usize][j as usize] / total;
                    mx += wt * lum(a.rgb[k]);
                    my += wt * lum(b.rgb[k]);
                }
            }
            let (mut vx, mut vy, mut cxy) = (0.0, 0.0, 0.0);
            for i in 0..11 {
                for j in 0..11 {
                    let k = ((cy + i - 5) * w + cx + j - 5) as usize;
                    let wt = g[i as usize][j as usize] / total;
                    let (dx, dy) = (lum(a.rgb[k]) - mx, lum(b.rgb[k]) - my);
                    vx += wt * dx * dx;
                    vy += wt * dy * dy;
                    cxy += wt * dx * dy;
                }
            }
            sum += (2.0 * mx * my + c1) * (2.0 * cxy + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2));
            n += 1;
        }
    }
    sum / n as f64
}

#[test]
fn ssim_separable_matches_direct_definition() {
    let a = random_image(29, 23, 0.0, 1.0, 3);
    let mut b = a.clone();
    let mut rng = Rng(99);
    for p in b.rgb.iter_mut() {
        for c in p.iter_mut() {
            *c = (*c * 0.8 + 0.3 * rng.next() as f32).max(0.0);
        }
    }
    let s = ssim(&a, &b, None).unwrap();
    let s_ref = ssim_brute_force(&a, &b);
    assert!((s - s_ref).abs() < 1e-9, "{s} vs {s_ref}");
    assert!(s < 0.99 && s > 0.0);
    // Symmetric in its arguments.
    assert!((ssim(&b, &a, None).unwrap() - s).abs() < 1e-12);
}

#[test]
fn color_correction_recovers_a_known_matrix() {
    let render = random_image(64, 48, 0.0, 1.0, 5);
    let m_true = [[0.9, 0.15, -0.05], [0.1, 0.8, 0.1], [-0.02, 0.2, 1.1]];
    let photo = apply_color_matrix(&render, &m_true);
    let m = fit_color_matrix(&render, &photo, None).unwrap();
    for i in 0..3 {
        for j in 0..3 {
            assert!((m[i][j] - m_true[i][j]).abs() < 1e-5, "M[{i}][{j}] = {} vs {}", m[i][j], m_true[i][j]);
        }
    }
    let uncorrected = compare(&render, &photo, None, false).unwrap().metrics;
    let corrected = compare(&render, &photo, None, true).unwrap().metrics;
    assert!(uncorrected.rmse > 0.05);
    assert!(corrected.rmse < 1e-6, "rmse after correction {}", corrected.rmse);
    assert!(corrected.delta_e2000_mean < 1e-3);
    assert!((corrected.ssim - 1.0).abs() < 1e-6);
    let cm = corrected.color_matrix.unwrap();
    assert!((cm[2][2] - 1.1).abs() < 1e-5);

    // With noise on the photo, the robust fit is still unbiased: recovered within a few
    // standard errors (σ_M ≈ σ / √(N E[r²]) ≈ 0.01 / √(3072 · 1/3) ≈ 3e-4).
    let mut noisy = photo.clone();
    let mut rng = Rng(77);
    for p in noisy.rgb.iter_mut() {
        for c in p.iter_mut() {
            *c += (0.01 * 3f64.sqrt() * (2.0 * rng.next() - 1.0)) as f32;
        }
    }
    let m = fit_color_matrix(&render, &noisy, None).unwrap();
    for i in 0..3 {
        for j in 0..3 {
            assert!((m[i][j] - m_true[i][j]).abs() < 5e-3, "noisy M[{i}][{j}] = {}", m[i][j]);
        }
    }
}

#[test]
fn color_correction_of_grey_render_is_refused() {
    let grey = Image { width: 4, height: 4, rgb: (0..16).map(|i| [i as f32 / 16.0; 3]).collect() };
    let photo = random_image(4, 4, 0.0, 1.0, 1);
    let e = format!("{:#}", compare(&grey, &photo, None, true).unwrap_err());
    assert!(e.contains("degenerate"), "{e}");
}

#[test]
fn mask_restricts_every_metric() {
    let photo = random_image(32, 32, 0.1, 0.9, 21);
    let mut render = photo.clone();
    let mut mask = Mask::full(32, 32);
    // Outside the mask (the left half), the render is garbage.
    for y in 0..32 {
        for x in 0..16 {
            mask.inside[y * 32 + x] = false;
            render.set(x as u32, y as u32, [50.0, 0.0, 7.0]);
        }
    }
    let c = compare(&render, &photo, Some(&mask), false).unwrap();
    assert_eq!(c.metrics.pixels, 32 * 16);
    assert_eq!(c.metrics.rmse, 0.0);
    assert_eq!(c.metrics.delta_e2000_mean, 0.0);
    assert!((c.metrics.ssim - 1.0).abs() < 1e-12);
    assert!(compare(&render, &photo, None, false).unwrap().metrics.rmse > 1.0);
    // Mask from an image: white inside, black outside.
    let mut mimg = Image::new(32, 32);
    for (i, p) in mimg.rgb.iter_mut().enumerate() {
        if mask.inside[i] {
            *p = [1.0; 3];
        }
    }
    assert_eq!(Mask::from_image(&mimg), mask);
    // The error image is black outside the mask and the colour map's zero inside.
    let err = error_image(&c, 10.0);
    assert_eq!(err.get(0, 0), [0.0; 3]);
    let zero = err.get(20, 5);
    assert!(zero[2] > zero[1] && zero[0] > zero[1], "colour map at 0 is dark violet: {zero:?}");
}

#[test]
fn error_image_maps_delta_e_through_the_colour_map() {
    let photo = Image { width: 3, height: 1, rgb: vec![[0.2; 3]; 3] };
    let render = Image { width: 3, height: 1, rgb: vec![[0.2; 3], [0.21, 0.2, 0.2], [0.9, 0.1, 0.1]] };
    let c = compare(&render, &photo, None, false).unwrap();
    assert_eq!(c.delta_e_map[0], 0.0);
    assert!(c.delta_e_map[1] > 0.0 && c.delta_e_map[1] < c.delta_e_map[2]);
    let img = error_image(&c, 5.0);
    // Saturated pixel is the map's top (yellow: red and green high, blue low).
    let top = img.get(2, 0);
    assert!(top[0] > 0.9 && top[1] > 0.75 && top[2] < 0.05, "{top:?}");
    let mean = (c.delta_e_map.iter().sum::<f64>()) / 3.0;
    assert!((c.metrics.delta_e2000_mean - mean).abs() < 1e-12);
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let a = random_image(8, 8, 0.0, 1.0, 1);
    let b = random_image(8, 9, 0.0, 1.0, 2);
    let e = format!("{:#}", compare(&a, &b, None, false).unwrap_err());
    assert!(e.contains("8×8") && e.contains("8×9"), "{e}");
    let m = Mask::full(9, 8);
    assert!(compare(&a, &a, Some(&m), false).is_err());
    let empty = Mask { width: 8, height: 8, inside: vec![false; 64] };
    assert!(compare(&a, &a, Some(&empty), false).is_err());
    let mut nan = a.clone();
    nan.rgb[10][1] = f32::NAN;
    let e = format!("{:#}", compare(&nan, &a, None, false).unwrap_err());
    assert!(e.contains("(2, 1)"), "{e}");
    // Images smaller than the SSIM window still work (truncated windows).
    let tiny = random_image(3, 2, 0.0, 1.0, 4);
    let s = compare(&tiny, &tiny, None, false).unwrap().metrics.ssim;
    assert!((s - 1.0).abs() < 1e-12);
}

#[test]
fn ssim_of_an_image_with_itself_is_exactly_one_at_any_scale() {
    // Including the brightest finite f32 pixels: local means near 3e38 and squares near 1e77,
    // where E[x²] − E[x]² would have lost every digit.
    let base = random_image(24, 20, 0.0, 1.0, 31);
    for scale in [1e-30f32, 1e-3, 1.0, 1e3, 1e20, 1e30, 3e38] {
        let mut img = base.clone();
        for p in img.rgb.iter_mut() {
            for c in p.iter_mut() {
                *c = (*c * scale).min(3e38);
            }
        }
        assert_eq!(ssim(&img, &img, None).unwrap(), 1.0, "scale {scale:e}");
        assert_eq!(compare(&img, &img, None, false).unwrap().metrics.ssim, 1.0, "scale {scale:e}");
    }
    let flat = Image { width: 16, height: 16, rgb: vec![[3e38; 3]; 256] };
    assert_eq!(ssim(&flat, &flat, None).unwrap(), 1.0);
    // Through a PFM file, as `lucent compare` reads it.
    let path = std::env::temp_dir().join(format!("lucent-ssim-flat-{}.pfm", std::process::id()));
    render::image_io::write_image(&path, &flat, 0.0).unwrap();
    let back = render::image_io::read_image(&path).unwrap();
    std::fs::remove_file(&path).ok();
    let m = compare(&back, &back, None, false).unwrap().metrics;
    assert_eq!(m.ssim, 1.0);
    assert_eq!(m.rmse, 0.0);
}

#[test]
fn ssim_keeps_precision_for_bright_images() {
    // Constant images: the variances are exactly zero, leaving the closed form of the luminance
    // term even at 1e30 (where the stabilising constants no longer matter).
    for (x, y) in [(3e38f32, 1.5e38f32), (1e30, 4e29), (0.5, 0.3)] {
        let a = Image { width: 16, height: 12, rgb: vec![[x; 3]; 192] };
        let b = Image { width: 16, height: 12, rgb: vec![[y; 3]; 192] };
        let (x, y, c1) = (x as f64, y as f64, SSIM_K1 * SSIM_K1);
        let expected = (2.0 * x * y + c1) / (x * x + y * y + c1);
        let s = ssim(&a, &b, None).unwrap();
        assert!((s - expected).abs() < 1e-12, "{s} vs {expected}");
    }
    // Structured images far above the dynamic range: the direct two-pass definition agrees.
    let a = random_image(27, 21, 0.0, 1.0, 41);
    let mut b = a.clone();
    let mut rng = Rng(43);
    for p in b.rgb.iter_mut() {
        for c in p.iter_mut() {
            *c = (*c * 0.7 + 0.4 * rng.next() as f32).max(0.0);
        }
    }
    for scale in [1e6f32, 1e15, 1e30] {
        let scaled = |img: &Image| Image { rgb: img.rgb.iter().map(|p| p.map(|c| c * scale)).collect(), ..img.clone() };
        let (sa, sb) = (scaled(&a), scaled(&b));
        let s = ssim(&sa, &sb, None).unwrap();
        let s_ref = ssim_brute_force(&sa, &sb);
        assert!((s - s_ref).abs() < 1e-9 && s > 0.0 && s < 1.0, "scale {scale:e}: {s} vs {s_ref}");
    }
}
