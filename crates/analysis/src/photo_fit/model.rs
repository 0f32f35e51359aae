//! The image-formation model of `lucent fit photo`: how per-label albedos, the lights and the
//! camera's response turn basis renders into the code values of a photograph.
//!
//! For a Lambertian scene rendered with direct light only (the `direct` integrator), the linear
//! render is linear in every light's spectrum and in every label's albedo. With basis images
//! rendered once at albedo 1 (one label at a time, the others black; one light at a time):
//!
//! ```text
//! x_c(p) = Σ_k ρ_kc · [ P · ((1 − β) B^pat_kc(p) + β B^flood_kc(p)) + A · B^amb_kc(p) ]
//!          + P · ((1 − β) R^pat_c(p) + β R^flood_c(p)) + A · R^amb_c(p)
//! ```
//!
//! ρ_kc the albedo of label k in linear-sRGB channel c, P the projector's scale (1 = the scene's
//! intensity), β its black level (the fraction of full white a projector pixel of value 0 still
//! emits), A the ambient scale (1 = the scene's environment radiance), B^pat the basis under the
//! frame's pattern, B^flood under an all-white pattern, B^amb under the environment alone, and R
//! the rest of the scene (objects whose material is not a label, and the environment seen
//! directly) under the same lights. The per-channel product ρ_kc · B_kc is exact for grey albedos
//! and for the flat-spectrum lights of these scenes up to the RGB → spectrum uplift of coloured
//! albedos (Jakob & Hanika 2019), which reproduces an RGB under D65, not under every light.
//!
//! The camera then maps linear sRGB to codes in [0, 1] (code / 255 for 8 bits):
//!
//! ```text
//! V(r) = 1 + v₂ r² + v₄ r⁴,
//! u = V(r) · M x,   M = I + off-diagonal terms with each row summing to 1 (white is preserved),
//! y_c = b + g · max(u_c, 0)^(1/γ)
//! ```
//!
//! with black level b, gain g and gamma γ, and a radial vignetting V of the pixel's distance r
//! from the image centre (r = 1 at the corners, [`radius2`]): the smooth fall-off of a real lens
//! (and, over a flat target, of a projector's) that the renders do not have, as the even
//! polynomial of the usual radial vignetting models (e.g. Goldman, IEEE TPAMI 32(12), 2010). Scale is not observable from photographs alone:
//! multiplying every ρ by s and P, A by 1/s, or g by t^(1/γ) and P, A by 1/t, leaves every y
//! unchanged, so a fit holds either the projector's scale P or the gain together with one label's
//! albedo (a reference of known reflectance). With grey lights, M and the per-label RGB albedos
//! are likewise interchangeable (M ρ_k is what the photo shows), so the colour matrix is fitted
//! once at the starting albedos and then held.

/// Index of the projector scale P in the parameter vector (after the 3K albedos).
pub const PROJECTOR: usize = 0;
/// Index (after the albedos) of the projector black level β.
pub const PROJECTOR_BLACK: usize = 1;
/// Index (after the albedos) of the ambient scale A.
pub const AMBIENT: usize = 2;
/// Index (after the albedos) of the camera black level b (code units, 1 = full scale).
pub const BLACK_LEVEL: usize = 3;
/// Index (after the albedos) of the camera gain g (code units per linear unit^(1/γ)).
pub const GAIN: usize = 4;
/// Index (after the albedos) of the camera gamma γ.
pub const GAMMA: usize = 5;
/// Index (after the albedos) of the first of the six off-diagonal colour-matrix terms.
pub const COLOR: usize = 6;
/// Index (after the albedos) of the vignetting's r² coefficient v₂ (v₄ follows).
pub const VIGNETTING: usize = 12;
/// Number of parameters after the albedos.
pub const N_GLOBAL: usize = 14;

/// Names of the parameters after the albedos, in order.
pub const GLOBAL_NAMES: [&str; N_GLOBAL] =
    ["projector_scale", "projector_black", "ambient_scale", "black_level", "gain", "gamma", "m01", "m02", "m10", "m12", "m20", "m21", "vignetting_r2", "vignetting_r4"];

/// Squared distance of pixel `i` (row-major) of a `width` × `height` image from the image
/// centre, in units of the half-diagonal (0 at the centre, 1 at the corners; pixel centres at
/// half-integers), the r² of the vignetting V(r).
pub fn radius2(i: usize, width: usize, height: usize) -> f64 {
    let (x, y) = ((i % width) as f64 + 0.5, (i / width) as f64 + 0.5);
    let (hx, hy) = (0.5 * width as f64, 0.5 * height as f64);
    ((x - hx).powi(2) + (y - hy).powi(2)) / (hx * hx + hy * hy)
}

/// (row, column) of each off-diagonal colour-matrix term, in parameter order.
pub const OFFDIAG: [(usize, usize); 6] = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)];

/// Smallest linear value the response is evaluated at (its slope diverges at 0 for γ > 1).
pub const U_MIN: f64 = 1e-6;

/// The fitted quantities as one vector: 3 albedos per label, then [`N_GLOBAL`] global terms.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Number of labels K.
    pub labels: usize,
    /// The vector: ρ_00 ρ_01 ρ_02 ρ_10 … then P, β, A, b, g, γ, m01 … m21.
    pub x: Vec<f64>,
}

impl Params {
    /// Starting parameters: the given albedos, the scene's lights (P = A = 1, β = 0), the camera
    /// response y = u^(1/γ) with `gamma`, no colour correction and no vignetting.
    pub fn new(albedo: &[[f64; 3]], gamma: f64) -> Params {
        let mut x: Vec<f64> = albedo.iter().flat_map(|a| a.iter().cloned()).collect();
        x.extend_from_slice(&[1.0, 0.0, 1.0, 0.0, 1.0, gamma, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        Params { labels: albedo.len(), x }
    }

    /// Length of the vector.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no parameters (never: the globals are always there).
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Index of global term `g` (one of the constants above).
    pub fn global(&self, g: usize) -> usize {
        3 * self.labels + g
    }

    /// Value of global term `g`.
    pub fn get(&self, g: usize) -> f64 {
        self.x[self.global(g)]
    }

    /// Albedo (linear sRGB) of label `k`.
    pub fn albedo(&self, k: usize) -> [f64; 3] {
        [self.x[3 * k], self.x[3 * k + 1], self.x[3 * k + 2]]
    }

    /// Name of parameter `i`: `label<k>.albedo.r` … or a global name.
    pub fn name(&self, i: usize, label_names: &[String]) -> String {
        if i < 3 * self.labels {
            format!("{}.albedo.{}", label_names[i / 3], ["r", "g", "b"][i % 3])
        } else {
            GLOBAL_NAMES[i - 3 * self.labels].to_string()
        }
    }

    /// The vignetting V at squared radius `r2` ([`radius2`]).
    pub fn vignetting(&self, r2: f64) -> f64 {
        1.0 + self.get(VIGNETTING) * r2 + self.get(VIGNETTING + 1) * r2 * r2
    }

    /// The colour matrix M (rows), each row summing to 1.
    pub fn color_matrix(&self) -> [[f64; 3]; 3] {
        let mut m = [[0.0; 3]; 3];
        for (t, &(r, c)) in OFFDIAG.iter().enumerate() {
            m[r][c] = self.get(COLOR + t);
        }
        for r in 0..3 {
            m[r][r] = 1.0 - (0..3).filter(|&c| c != r).map(|c| m[r][c]).sum::<f64>();
        }
        m
    }

    /// Clamps every parameter into its physical range: albedos [0, 1], scales ≥ 0, β ∈ [0, 0.5],
    /// b ∈ [−0.5, 0.5], g ≥ 10⁻⁶, γ ∈ [0.3, 5], off-diagonal colour terms ∈ [−0.5, 0.5],
    /// vignetting v₂, v₄ ∈ [−1, 1] (V stays within [−1, 3] over the image).
    pub fn clamp(&mut self) {
        let k3 = 3 * self.labels;
        for v in &mut self.x[..k3] {
            *v = v.clamp(0.0, 1.0);
        }
        let bounds: [(f64, f64); N_GLOBAL] = [
            (1e-9, f64::INFINITY),
            (0.0, 0.5),
            (0.0, f64::INFINITY),
            (-0.5, 0.5),
            (1e-6, f64::INFINITY),
            (0.3, 5.0),
            (-0.5, 0.5),
            (-0.5, 0.5),
            (-0.5, 0.5),
            (-0.5, 0.5),
            (-0.5, 0.5),
            (-0.5, 0.5),
            (-1.0, 1.0),
            (-1.0, 1.0),
        ];
        for (g, (lo, hi)) in bounds.iter().enumerate() {
            let v = &mut self.x[k3 + g];
            *v = v.clamp(*lo, *hi);
        }
    }
}

/// The basis values one pixel of one frame contributes (linear sRGB per unit albedo / scale).
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelBasis {
    /// Under the frame's pattern.
    pub pattern: [f32; 3],
    /// Under an all-white pattern.
    pub flood: [f32; 3],
    /// Under the environment alone.
    pub ambient: [f32; 3],
}

/// Linear render x (before the camera) of one pixel and its derivatives: `dx[c][i]` = ∂x_c/∂θ_i
/// for the full parameter vector (zero where a parameter does not act). `labels[k]` is label k's
/// basis at the pixel, `rest` the rest of the scene's.
pub fn linear_render(p: &Params, labels: &[PixelBasis], rest: &PixelBasis, dx: Option<&mut [Vec<f64>; 3]>) -> [f64; 3] {
    let (pp, beta, a) = (p.get(PROJECTOR), p.get(PROJECTOR_BLACK), p.get(AMBIENT));
    let mut x = [0.0f64; 3];
    let mut d_p = [0.0f64; 3];
    let mut d_beta = [0.0f64; 3];
    let mut d_a = [0.0f64; 3];
    let light = |b: &PixelBasis, c: usize| -> (f64, f64, f64) {
        let (pat, flood, amb) = (b.pattern[c] as f64, b.flood[c] as f64, b.ambient[c] as f64);
        let proj = (1.0 - beta) * pat + beta * flood;
        (proj, flood - pat, amb)
    };
    let mut dx = dx;
    for c in 0..3 {
        for (k, b) in labels.iter().enumerate() {
            let (proj, dproj_dbeta, amb) = light(b, c);
            if proj == 0.0 && amb == 0.0 && dproj_dbeta == 0.0 {
                continue;
            }
            let rho = p.x[3 * k + c];
            let d = pp * proj + a * amb;
            x[c] += rho * d;
            d_p[c] += rho * proj;
            d_beta[c] += rho * pp * dproj_dbeta;
            d_a[c] += rho * amb;
            if let Some(dx) = dx.as_deref_mut() {
                dx[c][3 * k + c] = d;
            }
        }
        let (proj, dproj_dbeta, amb) = light(rest, c);
        x[c] += pp * proj + a * amb;
        d_p[c] += proj;
        d_beta[c] += pp * dproj_dbeta;
        d_a[c] += amb;
    }
    if let Some(dx) = dx {
        for c in 0..3 {
            dx[c][p.global(PROJECTOR)] = d_p[c];
            dx[c][p.global(PROJECTOR_BLACK)] = d_beta[c];
            dx[c][p.global(AMBIENT)] = d_a[c];
        }
    }
    x
}

/// The camera: codes y (1 = full scale) from linear sRGB `x` at a pixel of squared radius `r2`
/// ([`radius2`]), and with `jac` the derivatives `jac[c][i]` = ∂y_c/∂θ_i given `dx` = ∂x/∂θ
/// (from [`linear_render`]); `jac` is overwritten.
pub fn camera_response(p: &Params, x: [f64; 3], r2: f64, dx: Option<(&[Vec<f64>; 3], &mut [Vec<f64>; 3])>) -> [f64; 3] {
    let m = p.color_matrix();
    let (b, g, gamma) = (p.get(BLACK_LEVEL), p.get(GAIN), p.get(GAMMA));
    let v = p.vignetting(r2);
    let mut mx = [0.0f64; 3];
    let mut u = [0.0f64; 3];
    for r in 0..3 {
        mx[r] = m[r][0] * x[0] + m[r][1] * x[1] + m[r][2] * x[2];
        u[r] = v * mx[r];
    }
    let inv = 1.0 / gamma;
    let mut y = [0.0f64; 3];
    let mut dy_du = [0.0f64; 3];
    let mut pow = [0.0f64; 3];
    for c in 0..3 {
        let uc = u[c].max(U_MIN);
        pow[c] = uc.powf(inv);
        y[c] = b + g * pow[c];
        // Below U_MIN the curve is clamped flat; its slope there is taken at U_MIN instead of 0,
        // so that a label whose albedo a step pushed to 0 (its pixels then black) still has a
        // derivative that brings it back.
        dy_du[c] = g * inv * pow[c] / uc;
    }
    if let Some((dx, jac)) = dx {
        let n = p.len();
        for c in 0..3 {
            let row = &mut jac[c];
            for i in 0..n {
                let du = v * (m[c][0] * dx[0][i] + m[c][1] * dx[1][i] + m[c][2] * dx[2][i]);
                row[i] = dy_du[c] * du;
            }
            row[p.global(BLACK_LEVEL)] = 1.0;
            row[p.global(GAIN)] = pow[c];
            let uc = u[c].max(U_MIN);
            row[p.global(GAMMA)] = -g * pow[c] * uc.ln() * inv * inv;
            for (t, &(r, col)) in OFFDIAG.iter().enumerate() {
                // m[r][col] = θ, m[r][r] = 1 − Σ: ∂u_r/∂θ = x_col − x_r.
                row[p.global(COLOR + t)] = if r == c { dy_du[c] * v * (x[col] - x[r]) } else { 0.0 };
            }
            // u_c = V · (M x)_c with V = 1 + v₂ r² + v₄ r⁴.
            row[p.global(VIGNETTING)] = dy_du[c] * mx[c] * r2;
            row[p.global(VIGNETTING + 1)] = dy_du[c] * mx[c] * r2 * r2;
        }
    }
    y
}

/// Inverse of the camera response for display: linear sRGB that gives codes `y` at squared
/// radius `r2` (V and M inverted).
pub fn inverse_response(p: &Params, y: [f64; 3], r2: f64) -> [f64; 3] {
    let (b, g, gamma) = (p.get(BLACK_LEVEL), p.get(GAIN), p.get(GAMMA));
    let v = p.vignetting(r2);
    let u = y.map(|c| ((c - b) / g).max(0.0).powf(gamma) / v);
    let m = p.color_matrix();
    match invert3(&m) {
        Some(mi) => std::array::from_fn(|r| mi[r][0] * u[0] + mi[r][1] * u[1] + mi[r][2] * u[2]),
        None => u,
    }
}

/// Inverse of a 3×3 matrix, `None` when singular.
pub fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if !(det.abs() > 1e-12) {
        return None;
    }
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    Some([
        [c(1, 1, 2, 2) / det, -c(0, 1, 2, 2) / det, c(0, 1, 1, 2) / det],
        [-c(1, 0, 2, 2) / det, c(0, 0, 2, 2) / det, -c(0, 0, 1, 2) / det],
        [c(1, 0, 2, 1) / det, -c(0, 0, 2, 1) / det, c(0, 0, 1, 1) / det],
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pixel() -> (Vec<PixelBasis>, PixelBasis) {
        let labels = vec![
            PixelBasis { pattern: [0.3, 0.28, 0.25], flood: [0.6, 0.55, 0.5], ambient: [0.05, 0.06, 0.07] },
            PixelBasis { pattern: [0.1, 0.12, 0.09], flood: [0.2, 0.22, 0.21], ambient: [0.02, 0.02, 0.03] },
        ];
        (labels, PixelBasis { pattern: [0.0; 3], flood: [0.0; 3], ambient: [0.01, 0.012, 0.011] })
    }

    /// A label at albedo 0 in a pixel lit by nothing else: its codes' derivative in that albedo
    /// is the response's slope at U_MIN times its basis (positive, in the direction that raising
    /// the albedo moves the code), and raising the albedo from 0 by h raises the code by more
    /// than that slope times h (the curve is concave), so a fit step can bring the albedo back.
    #[test]
    fn albedo_at_zero_keeps_a_positive_derivative() {
        let (labels, _) = pixel();
        let rest = PixelBasis { pattern: [0.0; 3], flood: [0.0; 3], ambient: [0.0; 3] };
        let p = Params::new(&[[0.0; 3], [0.0; 3]], 2.2);
        let n = p.len();
        let mut dx: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let mut jy: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let x = linear_render(&p, &labels, &rest, Some(&mut dx));
        assert_eq!(x, [0.0; 3]);
        let y0 = camera_response(&p, x, 0.0, Some((&dx, &mut jy)));
        for c in 0..3 {
            let slope = (1.0 / 2.2) * U_MIN.powf(1.0 / 2.2 - 1.0);
            assert!((jy[c][c] - slope * dx[c][c]).abs() < 1e-9 * jy[c][c], "channel {c}: {} vs {}", jy[c][c], slope * dx[c][c]);
            assert!(jy[c][c] > 0.0);
            let h = 1e-3;
            let mut q = p.clone();
            q.x[c] = h;
            let y1 = camera_response(&q, linear_render(&q, &labels, &rest, None), 0.0, None);
            assert!(y1[c] - y0[c] > 0.0 && y1[c] - y0[c] < jy[c][c] * h, "channel {c}: code rises by {}", y1[c] - y0[c]);
        }
    }

    /// The analytic derivatives of the codes equal central differences for every parameter.
    #[test]
    fn jacobian_matches_central_differences() {
        let (labels, rest) = pixel();
        let mut p = Params::new(&[[0.4, 0.5, 0.6], [0.2, 0.25, 0.15]], 2.1);
        let g = 3 * 2;
        p.x[g + PROJECTOR] = 1.2;
        p.x[g + PROJECTOR_BLACK] = 0.05;
        p.x[g + AMBIENT] = 0.8;
        p.x[g + BLACK_LEVEL] = 0.02;
        p.x[g + GAIN] = 0.9;
        for t in 0..6 {
            p.x[g + COLOR + t] = 0.01 * (t as f64 + 1.0) * if t % 2 == 0 { 1.0 } else { -1.0 };
        }
        p.x[g + VIGNETTING] = -0.3;
        p.x[g + VIGNETTING + 1] = 0.08;
        // A pixel off centre, so that the vignetting acts (r² = 0.61).
        let r2 = 0.61;
        let n = p.len();
        let mut dx: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let mut jy: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let x = linear_render(&p, &labels, &rest, Some(&mut dx));
        camera_response(&p, x, r2, Some((&dx, &mut jy)));
        for i in 0..n {
            let h = 1e-6;
            let (mut a, mut b) = (p.clone(), p.clone());
            a.x[i] += h;
            b.x[i] -= h;
            let ya = camera_response(&a, linear_render(&a, &labels, &rest, None), r2, None);
            let yb = camera_response(&b, linear_render(&b, &labels, &rest, None), r2, None);
            for c in 0..3 {
                let fd = (ya[c] - yb[c]) / (2.0 * h);
                assert!((fd - jy[c][i]).abs() < 1e-7 * (1.0 + fd.abs()), "∂y{c}/∂{}: analytic {} vs {fd}", p.name(i, &["l0".into(), "l1".into()]), jy[c][i]);
            }
        }
    }

    /// The vignetting's r² is 0 at the image centre and 1 at the corners, and is symmetric.
    #[test]
    fn radius2_is_normalised_at_the_corners() {
        let (w, h) = (8usize, 6usize);
        // Pixel (0, 0) has its centre at (0.5, 0.5): (3.5² + 2.5²) / (4² + 3²).
        assert!((radius2(0, w, h) - (3.5f64.powi(2) + 2.5f64.powi(2)) / 25.0).abs() < 1e-15);
        assert_eq!(radius2(0, w, h), radius2(w * h - 1, w, h));
        assert_eq!(radius2(w - 1, w, h), radius2((h - 1) * w, w, h));
        assert!((radius2(3 * w + 3, w, h) - 0.5f64.powi(2) * 2.0 / 25.0).abs() < 1e-15);
    }

    /// The inverse response undoes the response.
    #[test]
    fn inverse_response_round_trips() {
        let mut p = Params::new(&[[0.5; 3]], 2.2);
        p.x[3 + BLACK_LEVEL] = 0.03;
        p.x[3 + GAIN] = 0.9;
        p.x[3 + COLOR] = 0.05;
        p.x[3 + COLOR + 3] = -0.04;
        p.x[3 + VIGNETTING] = -0.25;
        p.x[3 + VIGNETTING + 1] = 0.05;
        let x = [0.2, 0.3, 0.25];
        let y = camera_response(&p, x, 0.8, None);
        let back = inverse_response(&p, y, 0.8);
        for c in 0..3 {
            assert!((back[c] - x[c]).abs() < 1e-12, "{back:?} vs {x:?}");
        }
    }
}
