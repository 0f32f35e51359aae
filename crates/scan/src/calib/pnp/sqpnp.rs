//! The pose that minimises the object-space error globally (OpenCV's `SOLVEPNP_SQPNP`; Terzakis
//! & Lourakis, "A consistently fast and globally optimal solution to the perspective-n-point
//! problem", ECCV 2020).
//!
//! The error is Σᵢ ‖(I − Vᵢ)(R Xᵢ + t)‖², Vᵢ = vᵢvᵢᵀ/(vᵢᵀvᵢ) the projector onto the line of sight
//! vᵢ = (x, y, 1) (Lu, Hager & Mjolsness 2000). The best t for a given R is linear in r, R's nine
//! entries, so the error is a quadratic form rᵀΩr over the rotations. As SQPnP, the minimisation
//! starts from the nearest rotations to ±√3 eᵢ, eᵢ the eigenvectors of Ω with the smallest
//! eigenvalues (its null space when the data are exact; here the six smallest, and the caller's
//! closed-form pose as one more start, because for points on a plane the eigenvector starts
//! alone left 2 of 6 noisy boards in a local minimum 400× the global one, where OpenCV's
//! found the global one); each start is refined here by Newton's
//! method on the rotation manifold (R ← R exp([δ]ₓ), with the exact second-order term of the
//! parametrisation) instead of the paper's sequential quadratic programme. The local minimum with
//! every point in front of the camera and the smallest error wins; when none has all points in
//! front, the one with the most.

use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};

use crate::calib::homography::Point2;
use crate::calib::model::nearest_rotation;

type Vec9 = SVector<f64, 9>;
type Mat9 = SMatrix<f64, 9, 9>;

/// The pose (R, t) of object points `x` (at least 3) seen at normalised coordinates `m`; None when
/// the points determine none.
pub(super) fn sqpnp(x: &[Vector3<f64>], m: &[Point2], extra_start: Option<Matrix3<f64>>) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let n = x.len();
    if n < 3 || m.len() != n {
        return None;
    }
    // Qᵢ = I − Vᵢ; t(r) = P r with P = −(Σ Qᵢ)⁻¹ Σ Qᵢ Aᵢ, Aᵢ r = R Xᵢ.
    let q: Vec<Matrix3<f64>> = m
        .iter()
        .map(|p| {
            let v = Vector3::new(p[0], p[1], 1.0);
            Matrix3::identity() - v * v.transpose() / v.norm_squared()
        })
        .collect();
    let a = |i: usize| -> SMatrix<f64, 3, 9> {
        let mut a = SMatrix::<f64, 3, 9>::zeros();
        for row in 0..3 {
            for k in 0..3 {
                a[(row, 3 * row + k)] = x[i][k];
            }
        }
        a
    };
    let sum_q: Matrix3<f64> = q.iter().sum();
    let sum_qa: SMatrix<f64, 3, 9> = (0..n).map(|i| q[i] * a(i)).sum();
    let p = -(sum_q.try_inverse()? * sum_qa);
    let mut omega = Mat9::zeros();
    for (i, qi) in q.iter().enumerate() {
        let b = a(i) + p;
        omega += b.transpose() * qi * b;
    }
    omega = (omega + omega.transpose()) * 0.5;
    if omega.iter().any(|v| !v.is_finite()) {
        return None;
    }

    let eig = omega.symmetric_eigen();
    let mut order: Vec<usize> = (0..9).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let mut starts: Vec<Matrix3<f64>> = Vec::with_capacity(13);
    for &k in order.iter().take(6) {
        for sign in [1.0, -1.0] {
            let e = eig.eigenvectors.column(k) * (sign * 3f64.sqrt());
            starts.push(nearest_rotation(&Matrix3::from_row_slice(e.as_slice())));
        }
    }
    starts.extend(extra_start);
    let mut best: Option<(usize, f64, Matrix3<f64>)> = None;
    {
        for start in starts {
            let r = minimise(&omega, start);
            let rv = vec9(&r);
            let err = (rv.transpose() * omega * rv)[0];
            let t = p * rv;
            let front = x.iter().filter(|xi| (r * *xi + t)[2] > 0.0).count();
            let better = match &best {
                None => true,
                Some((f, e0, _)) => front > *f || (front == *f && err < *e0),
            };
            if better && err.is_finite() {
                best = Some((front, err, r));
            }
        }
    }
    let (_, _, r) = best?;
    Some((r, p * vec9(&r)))
}

/// R's entries row by row.
fn vec9(r: &Matrix3<f64>) -> Vec9 {
    Vec9::from_fn(|i, _| r[(i / 3, i % 3)])
}

/// Newton's method for rᵀΩr on the rotations from `r`: the step δ of R ← R exp([δ]ₓ) from the
/// gradient 2JᵀΩr and Hessian 2(JᵀΩJ + S), S = sym(WᵀR) − tr(WᵀR) I with W = mat(Ωr) (the
/// second-order term of exp), falling back to the Gauss–Newton step (JᵀΩJ) where the Hessian is
/// not positive definite or the step does not lower the error.
fn minimise(omega: &Mat9, mut r: Matrix3<f64>) -> Matrix3<f64> {
    let f = |r: &Matrix3<f64>| {
        let v = vec9(r);
        (v.transpose() * omega * v)[0]
    };
    let mut err = f(&r);
    for _ in 0..100 {
        let rv = vec9(&r);
        let mut j = SMatrix::<f64, 9, 3>::zeros();
        for k in 0..3 {
            let col = vec9(&(r * Vector3::ith(k, 1.0).cross_matrix()));
            j.set_column(k, &col);
        }
        let wv = omega * rv;
        let w = Matrix3::from_row_slice(wv.as_slice());
        let g = j.transpose() * wv;
        let jtj = j.transpose() * omega * j;
        let wr = w.transpose() * r;
        let s = (wr + wr.transpose()) * 0.5 - Matrix3::identity() * wr.trace();
        let mut steps = Vec::with_capacity(2);
        if let Some(d) = (jtj + s).cholesky().map(|c| c.solve(&(-g))) {
            steps.push(d);
        }
        if let Some(d) = (jtj + Matrix3::identity() * (1e-15 * jtj.trace().abs())).cholesky().map(|c| c.solve(&(-g))) {
            steps.push(d);
        }
        let mut moved = false;
        for d in steps {
            let mut scale = 1.0;
            for _ in 0..30 {
                let cand = r * Rotation3::new(d * scale).matrix();
                let e = f(&cand);
                if e < err {
                    let small = (d * scale).norm() < 1e-15;
                    r = cand;
                    err = e;
                    moved = !small;
                    break;
                }
                scale *= 0.5;
            }
            if moved {
                break;
            }
        }
        if !moved {
            break;
        }
    }
    r
}
