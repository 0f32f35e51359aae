//! Pixelwise comparison of a render with a photograph (or any two images): RMSE, relative MSE,
//! PSNR, SSIM, mean CIEDE2000, a false-colour error image, and an optional least-squares 3×3
//! colour correction of the render applied before the metrics.
//!
//! Both images are linear RGB in sRGB primaries with the D65 white (what
//! [`read_image`](render::image_io::read_image) returns). The second image is the reference.
//! Only pixels inside the mask (all pixels without one) count.

use anyhow::{bail, Result};

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
    /// The fitted colour correction (rows), when it was requested.
    pub color_matrix: Option<[[f64; 3]; 3]>,
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
/// `color_correct`, the render is first multiplied by the least-squares 3×3 matrix
/// ([`fit_color_matrix`]). Errors on different sizes, an empty mask or non-finite pixels.
pub fn compare(render: &Image, photo: &Image, mask: Option<&Mask>, color_correct: bool) -> Result<Comparison> {
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
    let (render, color_matrix) = if color_correct {
        let m = fit_color_matrix(render, photo, Some(&mask))?;
        (apply_color_matrix(render, &m), Some(m))
    } else {
        (render.clone(), None)
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
        color_matrix,
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

/// Linear sRGB (D65) → CIE 1976 L*a*b* relative to the D65 white of Y = 1 (RGB (1,1,1) ↦ L* = 100).
pub fn linear_srgb_to_lab(rgb: [f64; 3]) -> [f64; 3] {
    let m = &LINEAR_SRGB_TO_XYZ;
    let xyz: [f64; 3] = std::array::from_fn(|r| m[r][0] * rgb[0] + m[r][1] * rgb[1] + m[r][2] * rgb[2]);
    let white: [f64; 3] = std::array::from_fn(|r| m[r][0] + m[r][1] + m[r][2]);
    xyz_to_lab(xyz, white)
}

/// CIE XYZ → CIE 1976 L*a*b* relative to `white_xyz` (CIE 15:2004 formulas).
pub fn xyz_to_lab(xyz: [f64; 3], white_xyz: [f64; 3]) -> [f64; 3] {
    const DELTA: f64 = 6.0 / 29.0;
    let f = |t: f64| {
        if t > DELTA * DELTA * DELTA {
            t.cbrt()
        } else {
            t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
        }
    };
    let fx = f(xyz[0] / white_xyz[0]);
    let fy = f(xyz[1] / white_xyz[1]);
    let fz = f(xyz[2] / white_xyz[2]);
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

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

/// Least-squares colour correction: the 3×3 matrix M (rows) minimising Σ‖M·render − photo‖²
/// over the masked pixels, from the normal equations M = (Σ p rᵀ)(Σ r rᵀ)⁻¹.
/// Errors when the render's colours do not span three dimensions (e.g. a grey image).
pub fn fit_color_matrix(render: &Image, photo: &Image, mask: Option<&Mask>) -> Result<[[f64; 3]; 3]> {
    if render.rgb.len() != photo.rgb.len() {
        bail!("render and photo differ in size");
    }
    let mut rr = [[0.0f64; 3]; 3]; // Σ r rᵀ
    let mut pr = [[0.0f64; 3]; 3]; // Σ p rᵀ
    for (i, (r, p)) in render.rgb.iter().zip(&photo.rgb).enumerate() {
        if mask.is_some_and(|m| !m.inside[i]) {
            continue;
        }
        let (r, p) = (to_f64(*r), to_f64(*p));
        for j in 0..3 {
            for k in 0..3 {
                rr[j][k] += r[j] * r[k];
                pr[j][k] += p[j] * r[k];
            }
        }
    }
    let inv = invert_3x3(&rr).ok_or_else(|| {
        anyhow::anyhow!("cannot fit a colour matrix: the render's colours are degenerate (fewer than three independent channels)")
    })?;
    Ok(mat_mul(&pr, &inv))
}

/// Multiplies every pixel by the 3×3 matrix `m` (rows).
pub fn apply_color_matrix(image: &Image, m: &[[f64; 3]; 3]) -> Image {
    let rgb = image
        .rgb
        .iter()
        .map(|p| {
            let v = to_f64(*p);
            std::array::from_fn(|r| (m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2]) as f32)
        })
        .collect();
    Image { width: image.width, height: image.height, rgb }
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn invert_3x3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let cof = |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let adj = [
        [cof(1, 2, 1, 2), -cof(0, 2, 1, 2), cof(0, 1, 1, 2)],
        [-cof(1, 2, 0, 2), cof(0, 2, 0, 2), -cof(0, 1, 0, 2)],
        [cof(1, 2, 0, 1), -cof(0, 2, 0, 1), cof(0, 1, 0, 1)],
    ];
    let det = m[0][0] * adj[0][0] + m[0][1] * adj[1][0] + m[0][2] * adj[2][0];
    // Relative test: det of a Gram matrix against the product of its diagonal (Hadamard bound).
    let scale = m[0][0] * m[1][1] * m[2][2];
    if !(det.is_finite() && scale > 0.0 && det > 1e-12 * scale) {
        return None;
    }
    Some(std::array::from_fn(|i| std::array::from_fn(|j| adj[i][j] / det)))
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

/// Separable Gaussian filter with zero outside the image.
fn blur(data: &[f64], w: usize, h: usize, k: &[f64]) -> Vec<f64> {
    let r = k.len() / 2;
    let mut tmp = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (j, kv) in k.iter().enumerate() {
                let xx = x as isize + j as isize - r as isize;
                if xx >= 0 && (xx as usize) < w {
                    s += kv * data[y * w + xx as usize];
                }
            }
            tmp[y * w + x] = s;
        }
    }
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (j, kv) in k.iter().enumerate() {
                let yy = y as isize + j as isize - r as isize;
                if yy >= 0 && (yy as usize) < h {
                    s += kv * tmp[yy as usize * w + x];
                }
            }
            out[y * w + x] = s;
        }
    }
    out
}

/// Mean SSIM (Wang, Bovik, Sheikh & Simoncelli, IEEE TIP 13(4), 2004) of the linear luminance of
/// `a` and `b`: Gaussian 11×11 window with σ = 1.5 px, K1 = 0.01, K2 = 0.03, dynamic range 1.
///
/// Local statistics use only masked pixels (the window weights are multiplied by the mask and
/// renormalised). The mean runs over masked pixels whose whole window lies inside the image, as in
/// the authors' implementation; for images smaller than the window, over all masked pixels.
pub fn ssim(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<f64> {
    if (a.width, a.height) != (b.width, b.height) {
        bail!("SSIM: images differ in size");
    }
    let (w, h) = (a.width as usize, a.height as usize);
    let inside = |i: usize| mask.is_none_or(|m| m.inside[i]);
    let m: Vec<f64> = (0..w * h).map(|i| if inside(i) { 1.0 } else { 0.0 }).collect();
    let x: Vec<f64> = a.rgb.iter().map(|p| luminance(to_f64(*p))).collect();
    let y: Vec<f64> = b.rgb.iter().map(|p| luminance(to_f64(*p))).collect();
    let prod = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { (0..w * h).map(|i| m[i] * f(i)).collect() };
    let k = gaussian_kernel();
    let sm = blur(&m, w, h, &k);
    let sx = blur(&prod(&|i| x[i]), w, h, &k);
    let sy = blur(&prod(&|i| y[i]), w, h, &k);
    let sxx = blur(&prod(&|i| x[i] * x[i]), w, h, &k);
    let syy = blur(&prod(&|i| y[i] * y[i]), w, h, &k);
    let sxy = blur(&prod(&|i| x[i] * y[i]), w, h, &k);
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
        let n = sm[i];
        let mx = sx[i] / n;
        let my = sy[i] / n;
        let vx = (sxx[i] / n - mx * mx).max(0.0);
        let vy = (syy[i] / n - my * my).max(0.0);
        // E[xy] − E[x]E[y] loses every digit when the means are large (3·10³⁸: the difference is
        // rounding noise of either sign); the covariance obeys |cov| ≤ σx σy (Cauchy–Schwarz),
        // which keeps each term within [−1, 1] and identical images at exactly 1.
        let sd = (vx * vy).sqrt();
        let cxy = (sxy[i] / n - mx * my).clamp(-sd, sd);
        sum += ((2.0 * mx * my + c1) * (2.0 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
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
