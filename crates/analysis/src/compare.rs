//! Pixelwise comparison of a render with a photograph (or any two images): RMSE, relative MSE,
//! PSNR, SSIM, mean CIEDE2000, a false-colour error image, and an optional robust colour
//! correction of the render (3×3 matrix or 3×4 affine, fitted in linear RGB) applied before the
//! metrics.
//!
//! Both images are linear RGB in sRGB primaries with the D65 white (what
//! [`read_image`](render::image_io::read_image) returns). The second image is the reference.
//! Only pixels inside the mask (all pixels without one) count.

use anyhow::{bail, Result};
use nalgebra::DMatrix;

use render::image_io::{srgb_decode, Image};

/// ε of the relative MSE, mean of (a − b)² / (b² + ε): keeps near-black reference pixels from
/// dominating. This is the form of Rousselle, Knaus & Zwicker (SIGGRAPH Asia 2011) and of the
/// Monte Carlo denoising literature since, with their ε = 0.01; b is the reference (photo).
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// Peak value used by PSNR: 1, the diffuse white of linear data (display white for PNG input).
pub const PSNR_PEAK: f64 = 1.0;

/// SSIM constants (Wang, Bovik, Sheikh & Simoncelli 2004): K1, K2, dynamic range L, Gaussian σ
/// in pixels and window size.
pub const SSIM_K1: f64 = 0.01;
/// See [`SSIM_K1`].
pub const SSIM_K2: f64 = 0.03;
/// Dynamic range L of SSIM's stabilising constants C1 = (K1 L)², C2 = (K2 L)².
pub const SSIM_DYNAMIC_RANGE: f64 = 1.0;
/// Standard deviation of the Gaussian SSIM window, pixels.
pub const SSIM_SIGMA_PX: f64 = 1.5;
/// Side of the SSIM window, pixels (11×11).
pub const SSIM_WINDOW_PX: usize = 11;

/// Linear sRGB → CIE XYZ (IEC 61966-2-1 primaries, D65 white; Y of RGB (1,1,1) is 1).
pub const LINEAR_SRGB_TO_XYZ: [[f64; 3]; 3] = optics::color::SRGB_TO_XYZ;

/// Which pixels take part in a comparison: `true` = compared. Row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// One flag per pixel.
    pub inside: Vec<bool>,
}

impl Mask {
    /// A mask from an image: a pixel is inside where the mean of its linear channels exceeds 0.5
    /// (white = compared, black = ignored).
    pub fn from_image(image: &Image) -> Mask {
        let inside = image.rgb.iter().map(|p| (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0 > 0.5).collect();
        Mask { width: image.width, height: image.height, inside }
    }

    /// Every pixel inside.
    pub fn full(width: u32, height: u32) -> Mask {
        Mask { width, height, inside: vec![true; width as usize * height as usize] }
    }

    /// Number of pixels inside.
    pub fn count(&self) -> usize {
        self.inside.iter().filter(|&&b| b).count()
    }
}

/// The metrics `lucent compare` reports.
#[derive(Clone, Debug, PartialEq)]
pub struct Metrics {
    /// Root-mean-square difference over the compared pixels and the three channels (linear units).
    pub rmse: f64,
    /// Mean over pixels and channels of (a − b)² / (b² + [`REL_MSE_EPSILON`]), b the reference.
    pub rel_mse: f64,
    /// 10 log10(peak² / MSE), peak [`PSNR_PEAK`] = 1, in dB; +∞ for identical images.
    pub psnr_db: f64,
    /// Mean structural similarity of linear luminance Y (see [`ssim`]).
    pub ssim: f64,
    /// Mean CIEDE2000 colour difference (CIELAB with the D65 white, Y = 1 the reference white).
    pub delta_e2000_mean: f64,
    /// The fitted colour correction's matrix M (rows), when it was requested.
    pub color_matrix: Option<[[f64; 3]; 3]>,
    /// The whole colour fit (model, offset, residual, pixels used and excluded), when requested.
    pub color_fit: Option<ColorFit>,
    /// Number of pixels compared.
    pub pixels: usize,
}

/// Result of [`compare`]: metrics and the per-pixel CIEDE2000 map (0 outside the mask).
#[derive(Clone, Debug)]
pub struct Comparison {
    /// The scalar metrics.
    pub metrics: Metrics,
    /// Per-pixel CIEDE2000, row-major, top row first.
    pub delta_e_map: Vec<f64>,
    /// The mask used.
    pub mask: Mask,
}

fn check_finite(image: &Image, what: &str) -> Result<()> {
    if let Some(i) = image.rgb.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        let w = image.width.max(1) as usize;
        bail!("{what} has a non-finite value at pixel ({}, {})", i % w, i / w);
    }
    Ok(())
}

/// Compares `render` with the reference `photo` over `mask` (all pixels when `None`); with
/// `color_correct`, the render is first mapped by the robust 3×3 colour matrix of
/// [`fit_color`] with its default options. Errors on different sizes, an empty mask or
/// non-finite pixels.
pub fn compare(render: &Image, photo: &Image, mask: Option<&Mask>, color_correct: bool) -> Result<Comparison> {
    compare_with(render, photo, mask, color_correct.then(ColorFitOptions::default).as_ref())
}

/// [`compare`] with the colour correction's options: with `Some`, the render is first mapped by
/// the transform [`fit_color`] fits with them (over the masked pixels).
pub fn compare_with(render: &Image, photo: &Image, mask: Option<&Mask>, color: Option<&ColorFitOptions>) -> Result<Comparison> {
    if (render.width, render.height) != (photo.width, photo.height) {
        bail!("render is {}×{} but photo is {}×{}", render.width, render.height, photo.width, photo.height);
    }
    check_finite(render, "render")?;
    check_finite(photo, "photo")?;
    let mask = match mask {
        Some(m) => {
            if (m.width, m.height) != (photo.width, photo.height) {
                bail!("mask is {}×{} but the images are {}×{}", m.width, m.height, photo.width, photo.height);
            }
            m.clone()
        }
        None => Mask::full(photo.width, photo.height),
    };
    let pixels = mask.count();
    if pixels == 0 {
        bail!("the mask selects no pixels");
    }
    let (render, color_fit) = match color {
        Some(options) => {
            let fit = fit_color(render, photo, Some(&mask), options)?;
            (fit.apply(render), Some(fit))
        }
        None => (render.clone(), None),
    };

    let mut se = 0.0;
    let mut rel = 0.0;
    let mut delta_e_map = vec![0.0; photo.rgb.len()];
    let mut de_sum = 0.0;
    for (i, (a, b)) in render.rgb.iter().zip(&photo.rgb).enumerate() {
        if !mask.inside[i] {
            continue;
        }
        for c in 0..3 {
            let (x, y) = (a[c] as f64, b[c] as f64);
            let d2 = (x - y) * (x - y);
            se += d2;
            rel += d2 / (y * y + REL_MSE_EPSILON);
        }
        let de = delta_e2000(linear_srgb_to_lab(to_f64(*a)), linear_srgb_to_lab(to_f64(*b)));
        delta_e_map[i] = de;
        de_sum += de;
    }
    let n = (3 * pixels) as f64;
    let mse = se / n;
    let psnr_db = if mse > 0.0 { 10.0 * (PSNR_PEAK * PSNR_PEAK / mse).log10() } else { f64::INFINITY };
    let metrics = Metrics {
        rmse: mse.sqrt(),
        rel_mse: rel / n,
        psnr_db,
        ssim: ssim(&render, photo, Some(&mask))?,
        delta_e2000_mean: de_sum / pixels as f64,
        color_matrix: color_fit.as_ref().map(|f| f.matrix),
        color_fit,
        pixels,
    };
    Ok(Comparison { metrics, delta_e_map, mask })
}

fn to_f64(p: [f32; 3]) -> [f64; 3] {
    [p[0] as f64, p[1] as f64, p[2] as f64]
}

/// Linear luminance Y of a linear sRGB colour (Rec. 709 / sRGB weights).
pub fn luminance(rgb: [f64; 3]) -> f64 {
    LINEAR_SRGB_TO_XYZ[1][0] * rgb[0] + LINEAR_SRGB_TO_XYZ[1][1] * rgb[1] + LINEAR_SRGB_TO_XYZ[1][2] * rgb[2]
}

pub use optics::color::{linear_srgb_to_lab, xyz_to_lab};

/// CIEDE2000 colour difference ΔE00 of two L*a*b* colours with kL = kC = kH = 1
/// (CIE 142-2001; implementation notes of Sharma, Wu & Dalal, Color Res. Appl. 30, 21–30, 2005:
/// hue angles in [0°, 360°), mean hue by their rule for |Δh| > 180°, h = 0 for zero chroma).
pub fn delta_e2000(lab1: [f64; 3], lab2: [f64; 3]) -> f64 {
    let [l1, a1, b1] = lab1;
    let [l2, a2, b2] = lab2;
    let c1 = a1.hypot(b1);
    let c2 = a2.hypot(b2);
    let c_bar = 0.5 * (c1 + c2);
    let c_bar7 = c_bar.powi(7);
    let g = 0.5 * (1.0 - (c_bar7 / (c_bar7 + 25f64.powi(7))).sqrt());
    let a1p = (1.0 + g) * a1;
    let a2p = (1.0 + g) * a2;
    let c1p = a1p.hypot(b1);
    let c2p = a2p.hypot(b2);
    let hue = |b: f64, ap: f64| {
        if b == 0.0 && ap == 0.0 {
            0.0
        } else {
            let h = b.atan2(ap).to_degrees();
            if h < 0.0 {
                h + 360.0
            } else {
                h
            }
        }
    };
    let h1p = hue(b1, a1p);
    let h2p = hue(b2, a2p);

    let dl = l2 - l1;
    let dc = c2p - c1p;
    let dh_angle = if c1p * c2p == 0.0 {
        0.0
    } else {
        let d = h2p - h1p;
        if d > 180.0 {
            d - 360.0
        } else if d < -180.0 {
            d + 360.0
        } else {
            d
        }
    };
    let dh = 2.0 * (c1p * c2p).sqrt() * (0.5 * dh_angle).to_radians().sin();

    let l_bar = 0.5 * (l1 + l2);
    let cp_bar = 0.5 * (c1p + c2p);
    let hp_bar = if c1p * c2p == 0.0 {
        h1p + h2p
    } else if (h1p - h2p).abs() <= 180.0 {
        0.5 * (h1p + h2p)
    } else if h1p + h2p < 360.0 {
        0.5 * (h1p + h2p + 360.0)
    } else {
        0.5 * (h1p + h2p - 360.0)
    };
    let t = 1.0 - 0.17 * (hp_bar - 30.0).to_radians().cos()
        + 0.24 * (2.0 * hp_bar).to_radians().cos()
        + 0.32 * (3.0 * hp_bar + 6.0).to_radians().cos()
        - 0.20 * (4.0 * hp_bar - 63.0).to_radians().cos();
    let d_theta = 30.0 * (-((hp_bar - 275.0) / 25.0).powi(2)).exp();
    let cp_bar7 = cp_bar.powi(7);
    let r_c = 2.0 * (cp_bar7 / (cp_bar7 + 25f64.powi(7))).sqrt();
    let l50 = (l_bar - 50.0) * (l_bar - 50.0);
    let s_l = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let s_c = 1.0 + 0.045 * cp_bar;
    let s_h = 1.0 + 0.015 * cp_bar * t;
    let r_t = -(2.0 * d_theta).to_radians().sin() * r_c;

    let tl = dl / s_l;
    let tc = dc / s_c;
    let th = dh / s_h;
    (tl * tl + tc * tc + th * th + r_t * tc * th).sqrt()
}

/// The colour transform `compare` fits from the render to the reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorModel {
    /// photo ≈ M · render with a 3×3 matrix M (white balance and channel mixing; black stays black).
    Matrix,
    /// photo ≈ M · render + o: a 3×4 affine transform (adds an offset o, e.g. a black level or
    /// flare).
    Affine,
}

impl ColorModel {
    /// Both models, in the order of their names.
    pub const ALL: [ColorModel; 2] = [ColorModel::Matrix, ColorModel::Affine];

    /// The name used on the command line and in JSON (`matrix`, `affine`).
    pub fn name(self) -> &'static str {
        match self {
            ColorModel::Matrix => "matrix",
            ColorModel::Affine => "affine",
        }
    }

    /// The model of a name given by [`ColorModel::name`].
    pub fn from_name(name: &str) -> Option<ColorModel> {
        ColorModel::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Number of fitted coefficients per output channel (3 or 4).
    fn columns(self) -> usize {
        match self {
            ColorModel::Matrix => 3,
            ColorModel::Affine => 4,
        }
    }
}

/// Default saturation level, linear: a pixel with any channel at or above it in either image is
/// left out of the colour fit. 1 is the white of display-referred input (an 8-bit photo clips
/// there); HDR references with another clipping level set their own.
pub const DEFAULT_SATURATION: f64 = 1.0;

/// Huber cut-off of the colour fit in units of the robust residual scale σ: √χ²₃(0.95) = 2.7955,
/// the 95 % quantile of the length of a 3-D Gaussian residual, so that 95 % of inlier pixels keep
/// full weight (Huber weights on a residual vector's length, as in the multivariate M-estimators
/// of Maronna, Martin & Yohai, *Robust Statistics: Theory and Methods*, 2006).
pub const HUBER_CUTOFF_SIGMA: f64 = 2.795_483;

/// MAD → standard deviation of a Gaussian, 1/Φ⁻¹(3/4).
pub const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// Most iteratively reweighted least-squares steps of the colour fit.
pub const COLOR_FIT_MAX_ITERATIONS: usize = 200;

/// Smallest reciprocal condition number (σ_min/σ_max of the column-equilibrated design) accepted
/// by the colour fit; below it the render's colours do not determine the transform.
pub const COLOR_FIT_MIN_RCOND: f64 = 1e-8;

/// How `compare` fits the colour transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColorFitOptions {
    /// 3×3 matrix or 3×4 affine.
    pub model: ColorModel,
    /// Saturation level (linear): pixels with a channel ≥ it in either image are excluded;
    /// `f64::INFINITY` keeps them all. Must be positive.
    pub saturation: f64,
}

impl Default for ColorFitOptions {
    fn default() -> Self {
        ColorFitOptions { model: ColorModel::Matrix, saturation: DEFAULT_SATURATION }
    }
}

/// A fitted colour transform, photo ≈ `matrix` · render + `offset`, and how well it fits.
#[derive(Clone, Debug, PartialEq)]
pub struct ColorFit {
    /// The model fitted.
    pub model: ColorModel,
    /// M (rows: output channel), dimensionless.
    pub matrix: [[f64; 3]; 3],
    /// o, linear units of the photo; zero for [`ColorModel::Matrix`].
    pub offset: [f64; 3],
    /// Root-mean-square residual of the transformed render against the photo over the pixels
    /// used and the three channels, linear RGB, unweighted (outliers included).
    pub rms_residual: f64,
    /// Robust residual scale σ = 1.4826 · MAD of the final residuals (all channels), linear RGB.
    pub robust_sigma: f64,
    /// Pixels that entered the fit (inside the mask, finite, unsaturated).
    pub pixels_used: usize,
    /// Pixels inside the mask left out because a channel reached the saturation level.
    pub excluded_saturated: usize,
    /// Pixels inside the mask left out because a channel is NaN or infinite.
    pub excluded_nonfinite: usize,
    /// Used pixels whose final Huber weight is below 1 (residual beyond the cut-off).
    pub downweighted: usize,
    /// Reweighting iterations run.
    pub iterations: usize,
}

impl ColorFit {
    /// The transform of one linear RGB colour.
    pub fn apply_rgb(&self, v: [f64; 3]) -> [f64; 3] {
        let m = &self.matrix;
        std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2] + self.offset[r])
    }

    /// The transform applied to every pixel.
    pub fn apply(&self, image: &Image) -> Image {
        apply_color_transform(image, &self.matrix, &self.offset)
    }
}

/// Robust 3×3 colour matrix (defaults of [`fit_color`]): the M of photo ≈ M · render.
/// Errors when the render's colours do not span three dimensions (e.g. a grey image) or too few
/// pixels are usable.
pub fn fit_color_matrix(render: &Image, photo: &Image, mask: Option<&Mask>) -> Result<[[f64; 3]; 3]> {
    Ok(fit_color(render, photo, mask, &ColorFitOptions::default())?.matrix)
}

/// Rows of the (equilibrated, weighted) design that are reduced together in one QR.
const QR_CHUNK_ROWS: usize = 1024;

/// Weighted linear least squares min Σ wᵢ ‖Xᵀaᵢ − pᵢ‖² for k ≤ 4 columns and 3 right-hand sides,
/// by Householder QR of the rows taken a chunk at a time (the triangular factor of the rows so
/// far is stacked on the next chunk and refactored, a tall-skinny QR), so the Gram matrix and its
/// squared condition number never appear. Returns X (k×3), or `None` when the design's
/// reciprocal condition number is below [`COLOR_FIT_MIN_RCOND`].
fn weighted_least_squares(a: &[[f64; 4]], p: &[[f64; 3]], w: &[f64], k: usize) -> Option<DMatrix<f64>> {
    let cols = k + 3;
    let mut r: Option<DMatrix<f64>> = None; // cols × cols upper-triangular factor so far
    let mut start = 0;
    while start < a.len() {
        let end = (start + QR_CHUNK_ROWS).min(a.len());
        let prev = r.as_ref().map_or(0, |m| m.nrows());
        let mut block = DMatrix::<f64>::zeros(prev + end - start, cols);
        if let Some(m) = &r {
            block.view_mut((0, 0), (prev, cols)).copy_from(m);
        }
        for (row, i) in (start..end).enumerate() {
            let s = w[i].sqrt();
            for j in 0..k {
                block[(prev + row, j)] = s * a[i][j];
            }
            for c in 0..3 {
                block[(prev + row, k + c)] = s * p[i][c];
            }
        }
        r = Some(block.qr().r());
        start = end;
    }
    let r = r?;
    if r.nrows() < k {
        return None;
    }
    let ra = r.view((0, 0), (k, k)).into_owned();
    let qtb = r.view((0, k), (k, 3)).into_owned();
    let sv = ra.clone().svd(false, false).singular_values;
    let (smax, smin) = (sv.max(), sv.min());
    if !(smax > 0.0 && smin.is_finite() && smin >= COLOR_FIT_MIN_RCOND * smax) {
        return None;
    }
    ra.solve_upper_triangular(&qtb)
}

/// Median of `v` (reordered in place); `v` must not be empty.
fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    let (_, &mut hi, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        hi
    } else {
        let lo = v[..n / 2].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    }
}

/// Robust colour correction in linear RGB: the transform photo ≈ M · render (+ o for
/// [`ColorModel::Affine`]) over the masked pixels.
///
/// Pixels with a non-finite channel, or a channel at or above `options.saturation` in either
/// image, are left out (a clipped photo pixel says only that the truth is brighter). The rest are
/// fitted by iteratively reweighted least squares with Huber weights on the length of each
/// pixel's RGB residual: weight 1 up to [`HUBER_CUTOFF_SIGMA`]·σ, c σ/‖e‖ beyond, σ re-estimated
/// each step as 1.4826 · MAD of the residuals (Huber, *Robust Statistics*, 1981; Holland & Welsch,
/// Commun. Stat. 6, 813, 1977), starting from ordinary least squares. Each step solves its
/// weighted problem by QR of the column-equilibrated design, not by the normal equations.
/// Errors when fewer usable pixels than coefficients remain or when the render's colours do not
/// determine the transform (e.g. a grey image).
pub fn fit_color(render: &Image, photo: &Image, mask: Option<&Mask>, options: &ColorFitOptions) -> Result<ColorFit> {
    if render.rgb.len() != photo.rgb.len() {
        bail!("render and photo differ in size");
    }
    if mask.is_some_and(|m| m.inside.len() != photo.rgb.len()) {
        bail!("the mask differs in size from the images");
    }
    if !(options.saturation > 0.0) {
        bail!("the saturation level must be positive (or infinite), got {}", options.saturation);
    }
    let k = options.model.columns();
    let (mut a, mut p) = (Vec::new(), Vec::new());
    let (mut nonfinite, mut saturated) = (0usize, 0usize);
    for (i, (rv, pv)) in render.rgb.iter().zip(&photo.rgb).enumerate() {
        if mask.is_some_and(|m| !m.inside[i]) {
            continue;
        }
        let (rv, pv) = (to_f64(*rv), to_f64(*pv));
        if rv.iter().chain(&pv).any(|c| !c.is_finite()) {
            nonfinite += 1;
        } else if rv.iter().chain(&pv).any(|&c| c >= options.saturation) {
            saturated += 1;
        } else {
            a.push([rv[0], rv[1], rv[2], 1.0]);
            p.push(pv);
        }
    }
    let n = a.len();
    if n < k {
        bail!(
            "cannot fit a colour {}: only {n} usable pixels ({saturated} with a channel ≥ the saturation level {}, {nonfinite} non-finite)",
            options.model.name(),
            options.saturation
        );
    }
    // Equilibrate the columns (RMS 1) so the conditioning test and the QR see colours, not units.
    let mut col_scale = [1.0f64; 4];
    for (j, s) in col_scale.iter_mut().enumerate().take(k) {
        let ms = a.iter().map(|r| r[j] * r[j]).sum::<f64>() / n as f64;
        *s = if ms > 0.0 { ms.sqrt() } else { 0.0 };
    }
    let degenerate = || {
        anyhow::anyhow!(
            "cannot fit a colour {}: the render's colours are degenerate (fewer than three independent channels among the {n} usable pixels)",
            options.model.name()
        )
    };
    if col_scale[..k].contains(&0.0) {
        return Err(degenerate());
    }
    let scaled: Vec<[f64; 4]> = a.iter().map(|r| std::array::from_fn(|j| if j < k { r[j] / col_scale[j] } else { 0.0 })).collect();
    let photo_rms = (p.iter().flat_map(|v| v.iter()).map(|c| c * c).sum::<f64>() / (3 * n) as f64).sqrt();
    let sigma_floor = 1e-12 * photo_rms + f64::MIN_POSITIVE;

    let residuals = |x: &DMatrix<f64>, e: &mut Vec<[f64; 3]>| {
        e.clear();
        e.extend(scaled.iter().zip(&p).map(|(r, pv)| {
            std::array::from_fn(|c| pv[c] - (0..k).map(|j| x[(j, c)] * r[j]).sum::<f64>())
        }));
    };
    let robust_sigma = |e: &[[f64; 3]]| {
        let mut flat: Vec<f64> = e.iter().flat_map(|v| v.iter().copied()).collect();
        let med = median(&mut flat);
        for v in flat.iter_mut() {
            *v = (*v - med).abs();
        }
        MAD_TO_SIGMA * median(&mut flat)
    };

    let mut w = vec![1.0f64; n];
    let mut e = Vec::with_capacity(n);
    let mut x = weighted_least_squares(&scaled, &p, &w, k).ok_or_else(degenerate)?;
    let mut iterations = 0;
    let mut sigma = 0.0;
    while iterations < COLOR_FIT_MAX_ITERATIONS {
        residuals(&x, &mut e);
        sigma = robust_sigma(&e).max(sigma_floor);
        let cut = HUBER_CUTOFF_SIGMA * sigma;
        for (wi, ei) in w.iter_mut().zip(&e) {
            let len = (ei[0] * ei[0] + ei[1] * ei[1] + ei[2] * ei[2]).sqrt();
            *wi = if len <= cut { 1.0 } else { cut / len };
        }
        let next = weighted_least_squares(&scaled, &p, &w, k).ok_or_else(degenerate)?;
        iterations += 1;
        let step = (&next - &x).amax();
        let size = next.amax().max(photo_rms);
        x = next;
        if step <= 1e-12 * size {
            break;
        }
    }
    residuals(&x, &mut e);
    let sigma_final = robust_sigma(&e);
    let cut = HUBER_CUTOFF_SIGMA * sigma.max(sigma_floor);
    let mut sq = 0.0;
    let mut downweighted = 0;
    for ei in &e {
        let l2 = ei[0] * ei[0] + ei[1] * ei[1] + ei[2] * ei[2];
        sq += l2;
        if l2.sqrt() > cut {
            downweighted += 1;
        }
    }
    let mut matrix = [[0.0; 3]; 3];
    let mut offset = [0.0; 3];
    for c in 0..3 {
        for j in 0..3 {
            matrix[c][j] = x[(j, c)] / col_scale[j];
        }
        if k == 4 {
            offset[c] = x[(3, c)] / col_scale[3];
        }
    }
    Ok(ColorFit {
        model: options.model,
        matrix,
        offset,
        rms_residual: (sq / (3 * n) as f64).sqrt(),
        robust_sigma: sigma_final,
        pixels_used: n,
        excluded_saturated: saturated,
        excluded_nonfinite: nonfinite,
        downweighted,
        iterations,
    })
}

/// Multiplies every pixel by the 3×3 matrix `m` (rows).
pub fn apply_color_matrix(image: &Image, m: &[[f64; 3]; 3]) -> Image {
    apply_color_transform(image, m, &[0.0; 3])
}

/// Maps every pixel v to `m` · v + `offset` (`m` by rows).
pub fn apply_color_transform(image: &Image, m: &[[f64; 3]; 3], offset: &[f64; 3]) -> Image {
    let rgb = image
        .rgb
        .iter()
        .map(|p| {
            let v = to_f64(*p);
            std::array::from_fn(|r| (m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2] + offset[r]) as f32)
        })
        .collect();
    Image { width: image.width, height: image.height, rgb }
}

/// Normalised 1-D Gaussian of the SSIM window.
fn gaussian_kernel() -> Vec<f64> {
    let half = (SSIM_WINDOW_PX / 2) as f64;
    let k: Vec<f64> = (0..SSIM_WINDOW_PX)
        .map(|i| {
            let x = i as f64 - half;
            (-x * x / (2.0 * SSIM_SIGMA_PX * SSIM_SIGMA_PX)).exp()
        })
        .collect();
    let s: f64 = k.iter().sum();
    k.into_iter().map(|v| v / s).collect()
}

/// Weighted local statistics of two signals over a window: total weight, means, and the sums of
/// weighted squared / crossed deviations from the means (not divided by the weight).
#[derive(Clone, Copy, Default)]
struct Moments {
    weight: f64,
    mean_x: f64,
    mean_y: f64,
    m2_x: f64,
    m2_y: f64,
    m_xy: f64,
}

/// Combines partial windows `parts` (statistics, each with an extra weight) into one window by
/// the weighted law of total variance (the pairwise update of Chan, Golub & LeVeque, Am. Stat.
/// 37, 242, 1983), the mean taken as an offset from the first part with weight so that a
/// constant signal has exactly zero variance. Only differences of nearby values are squared:
/// there is no cancellation between large sums of squares.
fn combine(parts: impl Iterator<Item = (f64, Moments)> + Clone) -> Moments {
    let Some((_, first)) = parts.clone().find(|(w, m)| w * m.weight > 0.0) else {
        return Moments::default();
    };
    let (rx, ry) = (first.mean_x, first.mean_y);
    let (mut weight, mut dx, mut dy) = (0.0, 0.0, 0.0);
    for (w, m) in parts.clone() {
        let wm = w * m.weight;
        if wm > 0.0 {
            weight += wm;
            dx += wm * (m.mean_x - rx);
            dy += wm * (m.mean_y - ry);
        }
    }
    let mean_x = rx + dx / weight;
    let mean_y = ry + dy / weight;
    let (mut m2_x, mut m2_y, mut m_xy) = (0.0, 0.0, 0.0);
    for (w, m) in parts {
        let wm = w * m.weight;
        if wm > 0.0 {
            let (ex, ey) = (m.mean_x - mean_x, m.mean_y - mean_y);
            m2_x += w * m.m2_x + wm * ex * ex;
            m2_y += w * m.m2_y + wm * ey * ey;
            m_xy += w * m.m_xy + wm * ex * ey;
        }
    }
    Moments { weight, mean_x, mean_y, m2_x, m2_y, m_xy }
}

/// The window's taps along an axis of `len` pixels centred at `c`: (index, weight), clipped to
/// the image.
fn taps(k: &[f64], c: usize, len: usize) -> impl Iterator<Item = (usize, f64)> + Clone + '_ {
    let r = k.len() / 2;
    let lo = c.saturating_sub(r);
    let hi = (c + r).min(len - 1);
    (lo..=hi).map(move |t| (t, k[t + r - c]))
}

/// Masked statistics of `x` and `y` under the 1-D window `k` along each row, at every pixel.
fn row_moments(x: &[f64], y: &[f64], m: &[f64], w: usize, h: usize, k: &[f64]) -> Vec<Moments> {
    let mut rows = vec![Moments::default(); w * h];
    for py in 0..h {
        for px in 0..w {
            let point = |(t, g): (usize, f64)| {
                let i = py * w + t;
                (g, Moments { weight: m[i], mean_x: x[i], mean_y: y[i], ..Moments::default() })
            };
            rows[py * w + px] = combine(taps(k, px, w).map(point));
        }
    }
    rows
}

/// Statistics under the separable 2-D window at (`px`, `py`) from the row statistics: the
/// column pass (exact for the product kernel); nothing outside the image.
fn window_moments(rows: &[Moments], px: usize, py: usize, w: usize, h: usize, k: &[f64]) -> Moments {
    combine(taps(k, py, h).map(|(t, g)| (g, rows[t * w + px])))
}

/// Mean SSIM (Wang, Bovik, Sheikh & Simoncelli, IEEE TIP 13(4), 2004) of the linear luminance of
/// `a` and `b`: Gaussian 11×11 window with σ = 1.5 px, K1 = 0.01, K2 = 0.03, dynamic range 1.
///
/// Local statistics use only masked pixels (the window weights are multiplied by the mask and
/// renormalised). The mean runs over masked pixels whose whole window lies inside the image, as in
/// the authors' implementation; for images smaller than the window, over all masked pixels.
/// The local means, variances and covariance are accumulated as deviations from running means
/// (never as E[x²] − E[x]²), so they keep their precision at any brightness, and an image
/// compared with itself scores exactly 1 at any scale.
pub fn ssim(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<f64> {
    if (a.width, a.height) != (b.width, b.height) {
        bail!("SSIM: images differ in size");
    }
    let (w, h) = (a.width as usize, a.height as usize);
    let inside = |i: usize| mask.is_none_or(|m| m.inside[i]);
    let m: Vec<f64> = (0..w * h).map(|i| if inside(i) { 1.0 } else { 0.0 }).collect();
    let x: Vec<f64> = a.rgb.iter().map(|p| luminance(to_f64(*p))).collect();
    let y: Vec<f64> = b.rgb.iter().map(|p| luminance(to_f64(*p))).collect();
    let k = gaussian_kernel();
    let rows = row_moments(&x, &y, &m, w, h, &k);
    let c1 = (SSIM_K1 * SSIM_DYNAMIC_RANGE).powi(2);
    let c2 = (SSIM_K2 * SSIM_DYNAMIC_RANGE).powi(2);
    let r = SSIM_WINDOW_PX / 2;
    let full_window = |i: usize| {
        let (px, py) = (i % w, i / w);
        px >= r && py >= r && px + r < w && py + r < h
    };
    let any_full = (0..w * h).any(|i| inside(i) && full_window(i));
    let mut sum = 0.0;
    let mut count = 0usize;
    for i in 0..w * h {
        if !inside(i) || (any_full && !full_window(i)) {
            continue;
        }
        let s = window_moments(&rows, i % w, i / w, w, h, &k);
        let (mx, my) = (s.mean_x, s.mean_y);
        let (vx, vy, cxy) = (s.m2_x / s.weight, s.m2_y / s.weight, s.m_xy / s.weight);
        // The luminance and contrast-structure factors separately, each in [−1, 1]: their
        // product's numerator and denominator cannot overflow for bright images, and for x = y
        // each is one number over itself, exactly 1.
        let lum = (2.0 * mx * my + c1) / (mx * mx + my * my + c1);
        let cs = (2.0 * cxy + c2) / (vx + vy + c2);
        sum += lum * cs;
        count += 1;
    }
    if count == 0 {
        bail!("SSIM: no pixels to compare");
    }
    Ok(sum / count as f64)
}

/// Perceptually uniform colour map from dark blue-violet (0) through teal to yellow (1),
/// anchors of matplotlib's viridis (CC0); returns display-encoded sRGB in [0, 1].
pub fn colormap_encoded(t: f64) -> [f64; 3] {
    const ANCHORS: [[f64; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) } * (ANCHORS.len() - 1) as f64;
    let i = (t.floor() as usize).min(ANCHORS.len() - 2);
    let f = t - i as f64;
    std::array::from_fn(|c| ((1.0 - f) * ANCHORS[i][c] + f * ANCHORS[i + 1][c]) / 255.0)
}

/// The false-colour error image: per-pixel ΔE00 / `delta_e_max` through [`colormap_encoded`]
/// (0 dark violet, ≥ `delta_e_max` yellow), pixels outside the mask black. Linear values, ready
/// for [`write_image`](render::image_io::write_image) with exposure 0.
pub fn error_image(comparison: &Comparison, delta_e_max: f64) -> Image {
    let m = &comparison.mask;
    let rgb = comparison
        .delta_e_map
        .iter()
        .zip(&m.inside)
        .map(|(&de, &inside)| {
            if inside {
                colormap_encoded(de / delta_e_max).map(|c| srgb_decode(c) as f32)
            } else {
                [0.0; 3]
            }
        })
        .collect();
    Image { width: m.width, height: m.height, rgb }
}
