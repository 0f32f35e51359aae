//! EPnP (Lepetit, Moreno-Noguer & Fua, "EPnP: an accurate O(n) solution to the PnP problem",
//! IJCV 81(2), 2009), the non-iterative solver behind OpenCV's `SOLVEPNP_EPNP`.
//!
//! Each object point is a barycentric combination of four control points: the centroid and the
//! centroid plus each principal axis scaled by the standard deviation along it. Each pixel gives
//! two linear equations in the control points' camera coordinates (12 unknowns, the rows scaled
//! by fx and fy as in pixels); their solution lies in the span of the four eigenvectors of MᵀM
//! with the smallest eigenvalues, and the weights β of one, two or three of them follow from the
//! six distances between the control points, which a rigid motion keeps (the paper's cases
//! N = 1, 2, 3; §3.3). Each case's β are refined by five Gauss–Newton steps on those six
//! distances (§3.4); the camera-frame points then give R and t by the closed-form absolute
//! orientation (Arun, Huang & Blostein 1987), and the case with the smallest mean reprojection
//! error in pixels wins.
//!
//! The control points' order (principal axes by decreasing variance) and signs (those of the
//! one-sided Jacobi SVD, [`principal_axes`]), the β's signs, the five steps and the choice by
//! mean pixel error follow the paper's reference code, which OpenCV uses, so that the poses agree
//! with OpenCV's to rounding; for points on a plane the fourth control point coincides with the
//! centroid, whose weights the pseudo-inverse then sets to 0 (OpenCV's `CV_SVD` inversion).

use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, SVector, Vector3, Vector4};

use crate::calib::homography::Point2;

/// The six pairs of control points whose distances fix the β's (the paper's order).
const PAIRS: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// The pose (R, t) of object points `x` seen at normalised undistorted coordinates `m`
/// ((u − cx)/fx, (v − cy)/fy), with `fx`, `fy` weighing the equations as pixels; None when the
/// points determine none (fewer than 4, or a degenerate configuration).
pub(super) fn epnp(x: &[Vector3<f64>], m: &[Point2], fx: f64, fy: f64) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let n = x.len();
    if n < 4 || m.len() != n {
        return None;
    }
    // Control points: the centroid, then centroid + √(λ_k / n) e_k over the principal axes.
    let c0 = x.iter().sum::<Vector3<f64>>() / n as f64;
    let mut cov = Matrix3::zeros();
    for p in x {
        let d = p - c0;
        cov += d * d.transpose();
    }
    let (sv, u) = principal_axes(&cov)?;
    let mut cw = [c0; 4];
    for k in 1..4 {
        cw[k] = c0 + u.column(k - 1) * (sv[k - 1] / n as f64).sqrt();
    }
    // Barycentric coordinates: X − c0 = Σ_k α_k (c_k − c0), α_0 = 1 − Σ α_k.
    let cc = Matrix3::from_columns(&[cw[1] - c0, cw[2] - c0, cw[3] - c0]);
    let cc_inv = cc.svd(true, true).pseudo_inverse(f64::EPSILON * 3.0 * cc.norm()).ok()?;
    let alphas: Vec<[f64; 4]> = x
        .iter()
        .map(|p| {
            let a = cc_inv * (p - c0);
            [1.0 - a[0] - a[1] - a[2], a[0], a[1], a[2]]
        })
        .collect();
    // M (2n × 12): fx Σ α_j (c_jx − x_i c_jz) = 0, fy Σ α_j (c_jy − y_i c_jz) = 0.
    let mut mm = DMatrix::<f64>::zeros(2 * n, 12);
    for (i, (a, q)) in alphas.iter().zip(m).enumerate() {
        for j in 0..4 {
            mm[(2 * i, 3 * j)] = a[j] * fx;
            mm[(2 * i, 3 * j + 2)] = -a[j] * fx * q[0];
            mm[(2 * i + 1, 3 * j + 1)] = a[j] * fy;
            mm[(2 * i + 1, 3 * j + 2)] = -a[j] * fy * q[1];
        }
    }
    let mtm = mm.transpose() * &mm;
    let eig = nalgebra::SymmetricEigen::new(mtm);
    let mut order: Vec<usize> = (0..12).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    // v[0] has the smallest eigenvalue, v[3] the fourth smallest.
    let v: [SVector<f64, 12>; 4] = std::array::from_fn(|k| SVector::<f64, 12>::from_iterator(eig.eigenvectors.column(order[k]).iter().copied()));
    let l = l_6x10(&v);
    let rho = SVector::<f64, 6>::from_fn(|r, _| {
        let (a, b) = PAIRS[r];
        (cw[a] - cw[b]).norm_squared()
    });

    let mut best: Option<(f64, Matrix3<f64>, Vector3<f64>)> = None;
    for case in 1..=3 {
        let Some(mut beta) = betas_approx(case, &l, &rho) else { continue };
        gauss_newton(&l, &rho, &mut beta);
        let Some((r, t)) = pose_from_betas(&v, &beta, &alphas, &cw) else { continue };
        let err = mean_pixel_error(x, m, fx, fy, &r, &t);
        // The later case wins only when strictly better, as the reference code.
        if best.as_ref().is_none_or(|b| err < b.0) {
            best = Some((err, r, t));
        }
    }
    best.map(|(_, r, t)| (r, t))
}

/// The singular values (descending) and left singular vectors (columns) of the symmetric 3 × 3
/// `a`, by the one-sided Jacobi method (Hestenes 1958; Demmel & Veselić 1992): the columns of `a`
/// are rotated pairwise, in the order (0, 1), (0, 2), (1, 2), until every pair is orthogonal to
/// 10 ε, each rotation the one that diagonalises the pair's 2 × 2 Gram matrix with c ≥ 0 when
/// the first column is the longer and s ≥ 0 otherwise; the columns' lengths are the singular
/// values, the normalised columns the vectors, sorted by decreasing value. With noisy points the
/// EPnP pose depends on the control points' signs by about the noise (a few milliradians), and
/// this is the method and the sign convention of OpenCV's SVD, with which the poses then agree
/// to 10⁻¹⁴ (`python/tests/test_calib.py`).
fn principal_axes(a: &Matrix3<f64>) -> Option<([f64; 3], Matrix3<f64>)> {
    // Rows of `at` are the columns of `a`.
    let mut at = [a.column(0).into_owned(), a.column(1).into_owned(), a.column(2).into_owned()];
    let mut w: [f64; 3] = std::array::from_fn(|i| at[i].norm_squared());
    let eps = 10.0 * f64::EPSILON;
    for _ in 0..30 {
        let mut changed = false;
        for (i, j) in [(0usize, 1usize), (0, 2), (1, 2)] {
            let (wa, wb) = (w[i], w[j]);
            let p = at[i].dot(&at[j]);
            if p.abs() <= eps * (wa * wb).sqrt() {
                continue;
            }
            let p2 = 2.0 * p;
            let beta = wa - wb;
            let gamma = p2.hypot(beta);
            let (c, s) = if beta < 0.0 {
                let s = ((gamma - beta) * 0.5 / gamma).sqrt();
                (p2 / (gamma * s * 2.0), s)
            } else {
                let c = ((gamma + beta) / (gamma * 2.0)).sqrt();
                (c, p2 / (gamma * c * 2.0))
            };
            let (ai, aj) = (at[i], at[j]);
            at[i] = ai * c + aj * s;
            at[j] = aj * c - ai * s;
            w[i] = at[i].norm_squared();
            w[j] = at[j].norm_squared();
            changed = true;
        }
        if !changed {
            break;
        }
    }
    let mut sv: [f64; 3] = std::array::from_fn(|i| at[i].norm());
    // Selection sort by decreasing value (the first of equal values stays first).
    for i in 0..2 {
        let mut j = i;
        for k in i + 1..3 {
            if sv[j] < sv[k] {
                j = k;
            }
        }
        if i != j {
            sv.swap(i, j);
            at.swap(i, j);
        }
    }
    let cols: Vec<Vector3<f64>> = (0..3).map(|i| if sv[i] > 0.0 { at[i] / sv[i] } else { Vector3::zeros() }).collect();
    let u = Matrix3::from_columns(&cols);
    u.iter().all(|v| v.is_finite()).then_some((sv, u))
}

/// The 6 × 10 matrix L with L β̄ = ρ, β̄ = (β₁², β₁β₂, β₂², β₁β₃, β₂β₃, β₃², β₁β₄, β₂β₄, β₃β₄, β₄²)
/// (the paper's eq. 13 in its reference code's column order).
fn l_6x10(v: &[SVector<f64, 12>; 4]) -> SMatrix<f64, 6, 10> {
    let mut l = SMatrix::<f64, 6, 10>::zeros();
    for (r, &(a, b)) in PAIRS.iter().enumerate() {
        let dv: [Vector3<f64>; 4] = std::array::from_fn(|k| {
            Vector3::new(v[k][3 * a] - v[k][3 * b], v[k][3 * a + 1] - v[k][3 * b + 1], v[k][3 * a + 2] - v[k][3 * b + 2])
        });
        let d = |i: usize, j: usize| dv[i].dot(&dv[j]);
        let row = [d(0, 0), 2.0 * d(0, 1), d(1, 1), 2.0 * d(0, 2), 2.0 * d(1, 2), d(2, 2), 2.0 * d(0, 3), 2.0 * d(1, 3), 2.0 * d(2, 3), d(3, 3)];
        for (c, val) in row.into_iter().enumerate() {
            l[(r, c)] = val;
        }
    }
    l
}

/// Least squares of the columns `cols` of L against ρ (minimum norm).
fn solve_columns(l: &SMatrix<f64, 6, 10>, rho: &SVector<f64, 6>, cols: &[usize]) -> Option<DVector<f64>> {
    let a = DMatrix::from_fn(6, cols.len(), |r, c| l[(r, cols[c])]);
    let b = DVector::from_iterator(6, rho.iter().copied());
    let svd = a.svd(true, true);
    let eps = f64::EPSILON * 6.0 * svd.singular_values.max();
    svd.solve(&b, eps).ok()
}

/// The starting β of case N = 1, 2, 3 (the reference code's linearisations).
fn betas_approx(case: usize, l: &SMatrix<f64, 6, 10>, rho: &SVector<f64, 6>) -> Option<Vector4<f64>> {
    let mut beta = Vector4::zeros();
    match case {
        1 => {
            // β₁², β₁β₂, β₁β₃, β₁β₄.
            let b = solve_columns(l, rho, &[0, 1, 3, 6])?;
            let s = b[0].abs().sqrt();
            if s == 0.0 {
                return None;
            }
            let sign = if b[0] < 0.0 { -1.0 } else { 1.0 };
            beta = Vector4::new(s, sign * b[1] / s, sign * b[2] / s, sign * b[3] / s);
        }
        2 | 3 => {
            // β₁², β₁β₂, β₂² (and β₁β₃, β₂β₃ in case 3).
            let cols: &[usize] = if case == 2 { &[0, 1, 2] } else { &[0, 1, 2, 3, 4] };
            let b = solve_columns(l, rho, cols)?;
            if b[0] < 0.0 {
                beta[0] = (-b[0]).sqrt();
                beta[1] = if b[2] < 0.0 { (-b[2]).sqrt() } else { 0.0 };
            } else {
                beta[0] = b[0].sqrt();
                beta[1] = if b[2] > 0.0 { b[2].sqrt() } else { 0.0 };
            }
            if b[1] < 0.0 {
                beta[0] = -beta[0];
            }
            if case == 3 {
                if beta[0] == 0.0 {
                    return None;
                }
                beta[2] = b[3] / beta[0];
            }
        }
        _ => return None,
    }
    beta.iter().all(|b| b.is_finite()).then_some(beta)
}

/// Five Gauss–Newton steps on ρ − L β̄(β) (the paper's §3.4).
fn gauss_newton(l: &SMatrix<f64, 6, 10>, rho: &SVector<f64, 6>, beta: &mut Vector4<f64>) {
    for _ in 0..5 {
        let b = *beta;
        let mut a = SMatrix::<f64, 6, 4>::zeros();
        let mut r = SVector::<f64, 6>::zeros();
        for i in 0..6 {
            let li = |c: usize| l[(i, c)];
            a[(i, 0)] = 2.0 * li(0) * b[0] + li(1) * b[1] + li(3) * b[2] + li(6) * b[3];
            a[(i, 1)] = li(1) * b[0] + 2.0 * li(2) * b[1] + li(4) * b[2] + li(7) * b[3];
            a[(i, 2)] = li(3) * b[0] + li(4) * b[1] + 2.0 * li(5) * b[2] + li(8) * b[3];
            a[(i, 3)] = li(6) * b[0] + li(7) * b[1] + li(8) * b[2] + 2.0 * li(9) * b[3];
            let model = li(0) * b[0] * b[0]
                + li(1) * b[0] * b[1]
                + li(2) * b[1] * b[1]
                + li(3) * b[0] * b[2]
                + li(4) * b[1] * b[2]
                + li(5) * b[2] * b[2]
                + li(6) * b[0] * b[3]
                + li(7) * b[1] * b[3]
                + li(8) * b[2] * b[3]
                + li(9) * b[3] * b[3];
            r[i] = rho[i] - model;
        }
        // Least squares by Householder QR (thin Q: 6 × 4, R: 4 × 4).
        let qr = a.qr();
        let Some(dx) = qr.r().solve_upper_triangular(&(qr.q().transpose() * r)) else { return };
        if dx.iter().any(|v| !v.is_finite()) {
            return;
        }
        *beta += dx;
    }
}

/// The control points' camera coordinates Σ β_k v_k, the points' camera coordinates from them,
/// and the absolute orientation (R, t) mapping the object points onto those.
fn pose_from_betas(v: &[SVector<f64, 12>; 4], beta: &Vector4<f64>, alphas: &[[f64; 4]], cw: &[Vector3<f64>; 4]) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let mut ccs = [Vector3::zeros(); 4];
    for (j, c) in ccs.iter_mut().enumerate() {
        for k in 0..4 {
            *c += Vector3::new(v[k][3 * j], v[k][3 * j + 1], v[k][3 * j + 2]) * beta[k];
        }
    }
    let mut pcs: Vec<Vector3<f64>> = alphas.iter().map(|a| (0..4).map(|j| ccs[j] * a[j]).sum()).collect();
    // The sign: the first point in front of the camera.
    if pcs[0][2] < 0.0 {
        for p in pcs.iter_mut() {
            *p = -*p;
        }
    }
    let pw: Vec<Vector3<f64>> = alphas.iter().map(|a| (0..4).map(|j| cw[j] * a[j]).sum()).collect();
    let n = pcs.len() as f64;
    let pc0 = pcs.iter().sum::<Vector3<f64>>() / n;
    let pw0 = pw.iter().sum::<Vector3<f64>>() / n;
    let mut abt = Matrix3::zeros();
    for (c, w) in pcs.iter().zip(&pw) {
        abt += (c - pc0) * (w - pw0).transpose();
    }
    let svd = abt.svd(true, true);
    let mut r = svd.u? * svd.v_t?;
    if r.determinant() < 0.0 {
        // The reference code's reflection fix: the third row negated.
        for c in 0..3 {
            r[(2, c)] = -r[(2, c)];
        }
    }
    let t = pc0 - r * pw0;
    (r.iter().chain(t.iter()).all(|v| v.is_finite())).then_some((r, t))
}

/// Mean pixel distance between the points' projections and their pixels.
fn mean_pixel_error(x: &[Vector3<f64>], m: &[Point2], fx: f64, fy: f64, r: &Matrix3<f64>, t: &Vector3<f64>) -> f64 {
    let sum: f64 = x
        .iter()
        .zip(m)
        .map(|(p, q)| {
            let c = r * p + t;
            let (du, dv) = (fx * (c[0] / c[2] - q[0]), fy * (c[1] / c[2] - q[1]));
            (du * du + dv * dv).sqrt()
        })
        .sum();
    let e = sum / x.len() as f64;
    if e.is_nan() {
        f64::INFINITY
    } else {
        e
    }
}
