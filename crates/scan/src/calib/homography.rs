//! Plane-to-image homographies by the normalised direct linear transform (Hartley & Zisserman,
//! "Multiple View Geometry", 2nd ed., algorithm 4.2): both point sets are moved to their centroid
//! and scaled to a mean distance of √2, the 2n × 9 system is solved for its null vector, and the
//! normalisation is undone.

use nalgebra::{Matrix3, SMatrix, SymmetricEigen, Vector3};

/// A point in a plane (pixels or board units).
pub type Point2 = [f64; 2];

/// Apply homography `h` to `p` (homogeneous division included).
pub fn apply(h: &Matrix3<f64>, p: Point2) -> Point2 {
    let v = h * Vector3::new(p[0], p[1], 1.0);
    [v[0] / v[2], v[1] / v[2]]
}

/// Similarity that moves `pts` (weights `w`) to their centroid and to a mean distance of √2.
fn normaliser(pts: &[Point2]) -> Option<Matrix3<f64>> {
    let n = pts.len() as f64;
    let (mx, my) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p[0], a.1 + p[1]));
    let (mx, my) = (mx / n, my / n);
    let d = pts.iter().map(|p| ((p[0] - mx).powi(2) + (p[1] - my).powi(2)).sqrt()).sum::<f64>() / n;
    if !(d > 0.0) || !d.is_finite() {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / d;
    Some(Matrix3::new(s, 0.0, -s * mx, 0.0, s, -s * my, 0.0, 0.0, 1.0))
}

/// The homography H with dst ≃ H·src from ≥ 4 correspondences (least squares on the algebraic
/// error of the normalised points), scaled so that H₃₃ = 1 where possible; None when the points are
/// degenerate (fewer than 4, collinear, or coincident).
pub fn fit_homography(src: &[Point2], dst: &[Point2]) -> Option<Matrix3<f64>> {
    fit_homography_weighted(src, dst, None)
}

/// [`fit_homography`] with a weight per correspondence (0 drops it).
pub fn fit_homography_weighted(src: &[Point2], dst: &[Point2], w: Option<&[f64]>) -> Option<Matrix3<f64>> {
    assert_eq!(src.len(), dst.len());
    let keep: Vec<usize> = (0..src.len()).filter(|&i| w.map_or(true, |w| w[i] > 0.0)).collect();
    if keep.len() < 4 {
        return None;
    }
    let s: Vec<Point2> = keep.iter().map(|&i| src[i]).collect();
    let d: Vec<Point2> = keep.iter().map(|&i| dst[i]).collect();
    let ts = normaliser(&s)?;
    let td = normaliser(&d)?;
    // Normal equations AᵀA of the 2n × 9 DLT system (9 × 9, symmetric): its eigenvector of the
    // smallest eigenvalue is the least-squares null vector.
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (k, &i) in keep.iter().enumerate() {
        let wi = w.map_or(1.0, |w| w[i]);
        let a = apply(&ts, s[k]);
        let b = apply(&td, d[k]);
        let r1 = [a[0], a[1], 1.0, 0.0, 0.0, 0.0, -b[0] * a[0], -b[0] * a[1], -b[0]];
        let r2 = [0.0, 0.0, 0.0, a[0], a[1], 1.0, -b[1] * a[0], -b[1] * a[1], -b[1]];
        for r in [r1, r2] {
            for p in 0..9 {
                for q in p..9 {
                    ata[(p, q)] += wi * r[p] * r[q];
                }
            }
        }
    }
    for p in 0..9 {
        for q in 0..p {
            ata[(p, q)] = ata[(q, p)];
        }
    }
    let eig = SymmetricEigen::new(ata);
    let (imin, _) = eig.eigenvalues.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
    // A second (near-)zero eigenvalue means the solution is not unique: degenerate points.
    let mut ev: Vec<f64> = eig.eigenvalues.iter().copied().collect();
    ev.sort_by(f64::total_cmp);
    if !(ev[1] > 1e-12 * ev[8]) {
        return None;
    }
    let h = eig.eigenvectors.column(imin);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let hm = td.try_inverse()? * hn * ts;
    let scale = if hm[(2, 2)].abs() > 1e-12 * hm.norm() { hm[(2, 2)] } else { hm.norm() };
    let hm = hm / scale;
    hm.iter().all(|x| x.is_finite()).then_some(hm)
}

/// [`fit_homography`] with H₃₃ fixed at 1 in the normalised coordinates (8 unknowns: an 8 × 8
/// Cholesky solve instead of a 9 × 9 eigen-decomposition, several times cheaper), for the many
/// small local fits of a search. The same homography for exact correspondences; for noisy ones
/// a slightly different least-squares weighting, fine where the fit only predicts a position.
/// Falls back to [`fit_homography`] where the system is singular (H₃₃ near 0 in the normalised
/// frame, or degenerate points).
pub fn fit_homography_fast(src: &[Point2], dst: &[Point2]) -> Option<Matrix3<f64>> {
    assert_eq!(src.len(), dst.len());
    if src.len() < 4 {
        return None;
    }
    let ts = normaliser(src)?;
    let td = normaliser(dst)?;
    let mut ata = SMatrix::<f64, 8, 8>::zeros();
    let mut atb = SMatrix::<f64, 8, 1>::zeros();
    for (s, d) in src.iter().zip(dst) {
        let a = apply(&ts, *s);
        let b = apply(&td, *d);
        let rows = [([a[0], a[1], 1.0, 0.0, 0.0, 0.0, -b[0] * a[0], -b[0] * a[1]], b[0]), ([0.0, 0.0, 0.0, a[0], a[1], 1.0, -b[1] * a[0], -b[1] * a[1]], b[1])];
        for (r, rhs) in rows {
            for p in 0..8 {
                atb[p] += r[p] * rhs;
                for q in p..8 {
                    ata[(p, q)] += r[p] * r[q];
                }
            }
        }
    }
    for p in 0..8 {
        for q in 0..p {
            ata[(p, q)] = ata[(q, p)];
        }
    }
    let Some(ch) = ata.cholesky() else { return fit_homography(src, dst) };
    let h = ch.solve(&atb);
    // A nearly singular system solves to huge entries: let the eigen-decomposition judge it.
    let max_diag = (0..8).map(|i| ata[(i, i)]).fold(0.0, f64::max);
    let min_pivot = (0..8).map(|i| ch.l_dirty()[(i, i)].powi(2)).fold(f64::MAX, f64::min);
    if !(min_pivot > 1e-10 * max_diag) {
        return fit_homography(src, dst);
    }
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1.0);
    let hm = td.try_inverse()? * hn * ts;
    let scale = if hm[(2, 2)].abs() > 1e-12 * hm.norm() { hm[(2, 2)] } else { hm.norm() };
    let hm = hm / scale;
    if hm.iter().all(|x| x.is_finite()) {
        Some(hm)
    } else {
        fit_homography(src, dst)
    }
}

/// Robust local fit: [`fit_homography`], then refits without the correspondences whose transfer
/// error exceeds `k` robust standard deviations (1.4826 × median absolute residual, floored at
/// `floor` in dst units), `rounds` times. Returns the homography and the inlier count.
pub fn fit_homography_robust(src: &[Point2], dst: &[Point2], rounds: usize, k: f64, floor: f64) -> Option<(Matrix3<f64>, usize)> {
    let mut w = vec![1.0; src.len()];
    let mut h = fit_homography(src, dst)?;
    for _ in 0..rounds {
        let res: Vec<f64> = src.iter().zip(dst).map(|(s, d)| {
            let p = apply(&h, *s);
            ((p[0] - d[0]).powi(2) + (p[1] - d[1]).powi(2)).sqrt()
        }).collect();
        let mut sorted: Vec<f64> = res.iter().copied().filter(|r| r.is_finite()).collect();
        if sorted.is_empty() {
            return None;
        }
        sorted.sort_by(f64::total_cmp);
        let sigma = (1.4826 * sorted[sorted.len() / 2]).max(floor);
        let mut changed = false;
        for (wi, r) in w.iter_mut().zip(&res) {
            let keep = if *r <= k * sigma { 1.0 } else { 0.0 };
            changed |= keep != *wi;
            *wi = keep;
        }
        if !changed {
            break;
        }
        h = fit_homography_weighted(src, dst, Some(&w))?;
    }
    Some((h, w.iter().filter(|&&x| x > 0.0).count()))
}
