//! The perspective-three-point problem (OpenCV's `SOLVEPNP_P3P` and `SOLVEPNP_AP3P`, which
//! differ in method, not in the solutions they find): every pose that puts three known points on
//! three given lines of sight, by Grunert's elimination (Haralick et al., "Review and analysis of
//! solutions of the three point perspective pose estimation problem", IJCV 13(3), 1994).
//!
//! With s₁, s₂ = u s₁, s₃ = v s₁ the points' distances from the centre and a, b, c the sides
//! opposite points 1, 2, 3, the law of cosines gives a² = s₁²(u² + v² − 2uv cos α),
//! b² = s₁²(1 + v² − 2v cos β), c² = s₁²(1 + u² − 2u cos γ) (α, β, γ the angles between the
//! lines of sight 2–3, 1–3, 1–2). Dividing out s₁² leaves two quadratics in u whose coefficients
//! are polynomials in v; their resultant is a quartic in v, solved here as the eigenvalues of its
//! companion matrix. Each real root gives u from the two quadratics' common root, the distances
//! (refined by Newton's method on the three equations), the points in the camera frame and
//! (R, t) by the absolute orientation of the three pairs.

use nalgebra::{DMatrix, Matrix3, Vector3};

use crate::calib::homography::Point2;

/// Every pose (R, t) that puts the object points `x` on the lines of sight of the normalised
/// coordinates `m` (three of each), with the points in front of the camera; at most four.
pub(super) fn p3p(x: &[Vector3<f64>; 3], m: &[Point2; 3]) -> Vec<(Matrix3<f64>, Vector3<f64>)> {
    let f: [Vector3<f64>; 3] = std::array::from_fn(|i| Vector3::new(m[i][0], m[i][1], 1.0).normalize());
    let (a2, b2, c2) = ((x[1] - x[2]).norm_squared(), (x[0] - x[2]).norm_squared(), (x[0] - x[1]).norm_squared());
    if !(a2 > 0.0 && b2 > 0.0 && c2 > 0.0) || (x[1] - x[0]).cross(&(x[2] - x[0])).norm() <= 1e-12 * (a2 + b2 + c2) {
        return Vec::new();
    }
    let (ca, cb, cg) = (f[1].dot(&f[2]), f[0].dot(&f[2]), f[0].dot(&f[1]));
    // p(u) = p2 u² + p1 u + p0 and q(u) = q2 u² + q1 u + q0, coefficients as polynomials in v.
    let p2 = vec![a2 - c2];
    let p1 = vec![-2.0 * a2 * cg, 2.0 * c2 * ca];
    let p0 = vec![a2, 0.0, -c2];
    let q2 = vec![b2];
    let q1 = vec![-2.0 * b2 * cg];
    let q0 = vec![b2 - c2, 2.0 * c2 * cb, -c2];
    let e = sub(&mul(&p2, &q0), &mul(&p0, &q2));
    let g = sub(&mul(&p2, &q1), &mul(&p1, &q2));
    let h = sub(&mul(&p1, &q0), &mul(&p0, &q1));
    let quartic = sub(&mul(&e, &e), &mul(&g, &h));

    let mut out = Vec::new();
    for v in real_roots(&quartic) {
        if !(v > 0.0) {
            continue;
        }
        // The common root of p and q: q2 p − p2 q = (q2 p1 − p2 q1) u + (q2 p0 − p2 q0) = 0.
        let den = -eval(&g, v);
        if den.abs() < 1e-14 * (a2 + b2 + c2) * (a2 + b2 + c2) {
            continue;
        }
        let u = eval(&e, v) / den;
        let d = 1.0 + v * v - 2.0 * v * cb;
        if !(u > 0.0 && d > 0.0) {
            continue;
        }
        let s1 = (b2 / d).sqrt();
        let Some(s) = polish([s1, u * s1, v * s1], [a2, b2, c2], [ca, cb, cg]) else { continue };
        let p: [Vector3<f64>; 3] = std::array::from_fn(|i| f[i] * s[i]);
        if let Some(rt) = absolute_orientation(x, &p) {
            // Roots that coincide give the same pose once.
            if !out.iter().any(|(r, t): &(Matrix3<f64>, Vector3<f64>)| (r - rt.0).norm() < 1e-9 && (t - rt.1).norm() < 1e-9 * (1.0 + t.norm())) {
                out.push(rt);
            }
        }
    }
    out
}

fn mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut c = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            c[i + j] += x * y;
        }
    }
    c
}

fn sub(a: &[f64], b: &[f64]) -> Vec<f64> {
    (0..a.len().max(b.len())).map(|i| a.get(i).copied().unwrap_or(0.0) - b.get(i).copied().unwrap_or(0.0)).collect()
}

/// Value of the polynomial with coefficients `c` (ascending powers) at `x`.
fn eval(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, k| acc * x + k)
}

/// The real roots of a polynomial (ascending coefficients): the eigenvalues of its companion
/// matrix whose imaginary part is negligible, each refined by Newton's method.
fn real_roots(c: &[f64]) -> Vec<f64> {
    let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(scale > 0.0) || !scale.is_finite() {
        return Vec::new();
    }
    let mut deg = c.len() - 1;
    while deg > 0 && c[deg].abs() <= 1e-13 * scale {
        deg -= 1;
    }
    if deg == 0 {
        return Vec::new();
    }
    let lead = c[deg];
    let comp = DMatrix::from_fn(deg, deg, |i, j| if i == 0 { -c[deg - 1 - j] / lead } else if i == j + 1 { 1.0 } else { 0.0 });
    let dc: Vec<f64> = (1..=deg).map(|k| k as f64 * c[k]).collect();
    let mut roots = Vec::new();
    for z in comp.complex_eigenvalues().iter() {
        if z.im.abs() > 1e-6 * (1.0 + z.re.abs()) {
            continue;
        }
        let mut x = z.re;
        for _ in 0..8 {
            let d = eval(&dc[..deg], x);
            if d == 0.0 {
                break;
            }
            let step = eval(&c[..=deg], x) / d;
            if !step.is_finite() {
                break;
            }
            x -= step;
            if step.abs() <= 1e-16 * x.abs() {
                break;
            }
        }
        if x.is_finite() {
            roots.push(x);
        }
    }
    roots
}

/// Newton's method on the three laws of cosines in the distances s; None if it leaves them
/// non-positive.
fn polish(mut s: [f64; 3], sides2: [f64; 3], cosines: [f64; 3]) -> Option<[f64; 3]> {
    let [a2, b2, c2] = sides2;
    let [ca, cb, cg] = cosines;
    for _ in 0..4 {
        let [s1, s2, s3] = s;
        let r = Vector3::new(s2 * s2 + s3 * s3 - 2.0 * s2 * s3 * ca - a2, s1 * s1 + s3 * s3 - 2.0 * s1 * s3 * cb - b2, s1 * s1 + s2 * s2 - 2.0 * s1 * s2 * cg - c2);
        let j = Matrix3::new(
            0.0,
            2.0 * (s2 - s3 * ca),
            2.0 * (s3 - s2 * ca),
            2.0 * (s1 - s3 * cb),
            0.0,
            2.0 * (s3 - s1 * cb),
            2.0 * (s1 - s2 * cg),
            2.0 * (s2 - s1 * cg),
            0.0,
        );
        let Some(step) = j.lu().solve(&r) else { break };
        let next = [s1 - step[0], s2 - step[1], s3 - step[2]];
        if next.iter().any(|v| !v.is_finite()) {
            break;
        }
        s = next;
    }
    s.iter().all(|&v| v > 0.0).then_some(s)
}

/// The rotation and translation that map the object points `x` onto the camera-frame points
/// `p` in the least-squares sense (Arun et al. 1987, with the reflection excluded).
fn absolute_orientation(x: &[Vector3<f64>; 3], p: &[Vector3<f64>; 3]) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let xc = (x[0] + x[1] + x[2]) / 3.0;
    let pc = (p[0] + p[1] + p[2]) / 3.0;
    let mut h = Matrix3::zeros();
    for i in 0..3 {
        h += (p[i] - pc) * (x[i] - xc).transpose();
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut d = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = u * d * vt;
    let t = pc - r * xc;
    r.iter().chain(t.iter()).all(|v| v.is_finite()).then_some((r, t))
}
