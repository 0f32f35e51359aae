//! Robust colour correction: two renders of one scene need no correction, a known matrix or
//! affine transform is recovered despite outliers, saturated and non-finite pixels stay out.

use analysis::compare::{
    apply_color_matrix, apply_color_transform, compare, compare_with, fit_color, ColorFitOptions, ColorModel,
};
use analysis::scene_fit::render_image;
use render::image_io::Image;
use render::integrator::IntegratorSettings;
use render::scene::Scene;

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

/// The built-in Cornell box at `side`×`side` pixels, `spp` passes of `seed` (path tracer).
fn cornell(side: u32, spp: u64, seed: u64) -> Image {
    let mut s = Scene::cornell_box();
    s.set_resolution(side, side);
    render_image(&s, &IntegratorSettings::default(), seed, 0..spp)
}

/// Replaces a fraction `frac` of the pixels (chosen by `seed`) by random colours in [0, 0.9)³.
fn with_outliers(img: &Image, frac: f64, seed: u64) -> (Image, usize) {
    let mut rng = Rng(seed);
    let mut out = img.clone();
    let mut n = 0;
    for p in out.rgb.iter_mut() {
        if rng.next() < frac {
            *p = std::array::from_fn(|_| (0.9 * rng.next()) as f32);
            n += 1;
        }
    }
    (out, n)
}

/// Ordinary least squares by the normal equations over the pixels below `saturation`, the
/// estimator the robust fit must beat.
fn ordinary_least_squares(render: &Image, photo: &Image, saturation: f32) -> [[f64; 3]; 3] {
    let (mut rr, mut pr) = (nalgebra::Matrix3::<f64>::zeros(), nalgebra::Matrix3::<f64>::zeros());
    for (r, p) in render.rgb.iter().zip(&photo.rgb) {
        if r.iter().chain(p).any(|&c| c >= saturation) {
            continue;
        }
        let r = nalgebra::Vector3::new(r[0] as f64, r[1] as f64, r[2] as f64);
        let p = nalgebra::Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        rr += r * r.transpose();
        pr += p * r.transpose();
    }
    let m = pr * rr.try_inverse().unwrap();
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

fn max_abs_diff(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> f64 {
    (0..9).map(|k| (a[k / 3][k % 3] - b[k / 3][k % 3]).abs()).fold(0.0, f64::max)
}

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

#[test]
fn two_renders_of_one_scene_need_no_correction() {
    // Independent seeds: the renders differ only by Monte Carlo noise, so the right correction is
    // the identity. 1024 spp keeps the render's own noise (which shrinks any regression of the
    // photo on it towards 0, the errors-in-variables attenuation) well below the tolerance.
    let (a, b) = (cornell(32, 1024, 1), cornell(32, 1024, 2));
    let plain = compare(&a, &b, None, false).unwrap().metrics;
    let corrected = compare(&a, &b, None, true).unwrap().metrics;
    let fit = corrected.color_fit.clone().unwrap();
    let m = corrected.color_matrix.unwrap();
    eprintln!("M {m:?}, ΔE {} → {}, {fit:?}", plain.delta_e2000_mean, corrected.delta_e2000_mean);
    assert!(max_abs_diff(&m, &IDENTITY) < 0.02, "M = {m:?}");
    let rel = (corrected.delta_e2000_mean / plain.delta_e2000_mean - 1.0).abs();
    assert!(rel < 0.01, "ΔE2000 {} → {}", plain.delta_e2000_mean, corrected.delta_e2000_mean);
    // The light (values up to ~20) is left out as saturated; it alone drags a plain normal-
    // equation fit of all pixels far from the identity.
    assert!(fit.excluded_saturated > 0 && fit.pixels_used + fit.excluded_saturated == 32 * 32, "{fit:?}");
    assert!(max_abs_diff(&ordinary_least_squares(&a, &b, f32::INFINITY), &IDENTITY) > 0.1);
    // Affine: the offset is within noise of zero as well.
    let opts = ColorFitOptions { model: ColorModel::Affine, ..Default::default() };
    let affine = compare_with(&a, &b, None, Some(&opts)).unwrap().metrics.color_fit.unwrap();
    // (Looser for the matrix: with an offset to fit too, the blue column — barely constrained by a
    // scene without blue surfaces — wanders more.)
    assert!(max_abs_diff(&affine.matrix, &IDENTITY) < 0.05, "{affine:?}");
    assert!(affine.offset.iter().all(|o| o.abs() < 2e-3), "{affine:?}");
}

#[test]
fn known_matrix_is_recovered_despite_outliers() {
    let render = cornell(32, 64, 3);
    let m_true = [[0.9, 0.15, -0.05], [0.1, 0.8, 0.1], [-0.02, 0.2, 1.1]];
    let (photo, n_out) = with_outliers(&apply_color_matrix(&render, &m_true), 0.1, 17);
    assert!((80..=125).contains(&n_out), "{n_out} outliers");
    let fit = fit_color(&render, &photo, None, &ColorFitOptions::default()).unwrap();
    let err = max_abs_diff(&fit.matrix, &m_true);
    eprintln!("error {err:e} (OLS {:e}), {fit:?}", max_abs_diff(&ordinary_least_squares(&render, &photo, 1.0), &m_true));
    assert!(err < 1e-3, "M = {:?}", fit.matrix);
    // The outliers do move a plain least-squares fit of the same pixels.
    assert!(max_abs_diff(&ordinary_least_squares(&render, &photo, 1.0), &m_true) > 0.05);
    // The outliers end down-weighted; the inliers fit to the photo's f32 rounding, so the robust
    // scale is ~0.
    assert!(fit.downweighted >= n_out * 9 / 10, "{fit:?}");
    assert!(fit.robust_sigma < 1e-6, "{fit:?}");
    assert!(fit.rms_residual > 0.01, "the residual RMS counts the outliers: {fit:?}");
}

#[test]
fn known_affine_transform_is_recovered_despite_outliers() {
    let render = cornell(32, 64, 4);
    let m_true = [[0.85, 0.1, 0.02], [0.05, 0.9, -0.05], [0.0, 0.12, 0.95]];
    let o_true = [0.02, -0.01, 0.035];
    let (photo, _) = with_outliers(&apply_color_transform(&render, &m_true, &o_true), 0.1, 23);
    let opts = ColorFitOptions { model: ColorModel::Affine, ..Default::default() };
    let fit = fit_color(&render, &photo, None, &opts).unwrap();
    assert!(max_abs_diff(&fit.matrix, &m_true) < 1e-3, "{fit:?}");
    for (o, t) in fit.offset.iter().zip(o_true) {
        assert!((o - t).abs() < 1e-3, "{fit:?}");
    }
    // A 3×3 model cannot absorb the offset: its residual stays larger.
    let m3 = fit_color(&render, &photo, None, &ColorFitOptions::default()).unwrap();
    assert!(m3.robust_sigma > 10.0 * fit.robust_sigma.max(1e-6), "{m3:?} vs {fit:?}");
    // The corrected render matches the photo wherever the photo is not an outlier.
    let corrected = compare_with(&render, &photo, None, Some(&opts)).unwrap();
    let good = corrected.delta_e_map.iter().filter(|&&d| d < 1e-2).count();
    assert!(good >= 32 * 32 * 85 / 100, "{good} pixels match");
}

#[test]
fn saturated_and_non_finite_pixels_are_left_out() {
    // A photo that clips at 1, as an 8-bit camera does: an exposure 5 times the render's.
    let render = cornell(32, 64, 5);
    let m_true = [[4.8, 0.3, 0.0], [0.1, 5.1, 0.2], [0.0, 0.2, 4.9]];
    let mut photo = apply_color_matrix(&render, &m_true);
    for p in photo.rgb.iter_mut() {
        for c in p.iter_mut() {
            *c = c.min(1.0);
        }
    }
    let clipped = render.rgb.iter().zip(&photo.rgb).filter(|(r, p)| r.iter().chain(p.iter()).any(|&c| c >= 1.0)).count();
    assert!(clipped > 50, "{clipped} clipped pixels");
    let fit = fit_color(&render, &photo, None, &ColorFitOptions::default()).unwrap();
    assert_eq!(fit.excluded_saturated, clipped);
    assert_eq!(fit.pixels_used, 32 * 32 - clipped);
    assert!(max_abs_diff(&fit.matrix, &m_true) < 1e-6, "{fit:?}");
    // Keeping them biases the fit (the clipped pixels say the truth is darker than it is).
    let all = fit_color(&render, &photo, None, &ColorFitOptions { saturation: f64::INFINITY, ..Default::default() }).unwrap();
    assert_eq!(all.excluded_saturated, 0);
    assert!(max_abs_diff(&all.matrix, &m_true) > 1e-2, "{all:?}");

    // NaN and infinity: counted and left out (compare itself refuses such images).
    let mut bad = render.clone();
    bad.rgb[3][1] = f32::NAN;
    bad.rgb[40][0] = f32::INFINITY;
    let p2 = apply_color_matrix(&render, &IDENTITY);
    let fit = fit_color(&bad, &p2, None, &ColorFitOptions::default()).unwrap();
    assert_eq!(fit.excluded_nonfinite, 2);
    assert!(max_abs_diff(&fit.matrix, &IDENTITY) < 1e-6);

    // Nothing usable: a one-line error naming the cause.
    let white = Image { width: 4, height: 4, rgb: vec![[1.5; 3]; 16] };
    let e = format!("{:#}", fit_color(&white, &white, None, &ColorFitOptions::default()).unwrap_err());
    assert!(e.contains("16 with a channel ≥ the saturation level 1"), "{e}");
    let e = format!("{:#}", fit_color(&render, &photo, None, &ColorFitOptions { saturation: 0.0, ..Default::default() }).unwrap_err());
    assert!(e.contains("saturation"), "{e}");
}
