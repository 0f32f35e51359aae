//! Levenberg–Marquardt on accumulated normal equations, for least-squares problems with millions
//! of residuals and a few dozen parameters (the residual Jacobian is never stored): each
//! evaluation returns the cost (½Σr², or an unbiased cross form of it), JᵀJ and Jᵀr over the
//! free parameters; the step solves
//! (JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr (Marquardt 1963's scaling), λ shrinks by 3 after a step that
//! lowers the cost and grows by 4 after one that does not; the parameters are clamped into their
//! box after each step (projected LM).

use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector};

/// What one evaluation returns: cost ½Σr², the number of residuals, and (when asked) JᵀJ and Jᵀr
/// over the free parameters.
pub struct Normal {
    /// ½ Σ r².
    pub cost: f64,
    /// Number of residuals summed.
    pub residuals: usize,
    /// JᵀJ (free × free) and Jᵀr (free), when the Jacobian was asked for.
    pub system: Option<(DMatrix<f64>, DVector<f64>)>,
}

/// Result of [`levenberg_marquardt`].
pub struct LmResult {
    /// The parameters at the minimum.
    pub x: Vec<f64>,
    /// ½ Σ r² there.
    pub cost: f64,
    /// Residuals summed.
    pub residuals: usize,
    /// Accepted steps.
    pub iterations: usize,
    /// JᵀJ at the minimum over the free parameters.
    pub jtj: DMatrix<f64>,
}

/// Minimises ½Σr² over the parameters `free` (indices into `x0`), starting at `x0`.
/// `eval(x, jacobian)` evaluates; `clamp` projects a trial vector into the box. Stops after
/// `max_iterations` accepted steps, when the relative decrease of the cost falls below
/// `tolerance`, or when λ exceeds 10¹⁰ (no descent direction left).
pub fn levenberg_marquardt(
    mut eval: impl FnMut(&[f64], bool) -> Result<Normal>,
    clamp: impl Fn(&mut Vec<f64>),
    x0: &[f64],
    free: &[usize],
    max_iterations: usize,
    tolerance: f64,
) -> Result<LmResult> {
    let mut x = x0.to_vec();
    clamp(&mut x);
    let mut cur = eval(&x, true)?;
    if !cur.cost.is_finite() {
        bail!("the starting parameters give a non-finite error");
    }
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let n = free.len();
    while iterations < max_iterations && n > 0 {
        let (jtj, jtr) = cur.system.as_ref().expect("evaluated with the Jacobian");
        let mut accepted = false;
        while lambda < 1e10 {
            let mut a = jtj.clone();
            for i in 0..n {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(delta) = a.cholesky().map(|c| c.solve(&(-jtr))) else {
                lambda *= 4.0;
                continue;
            };
            let mut trial = x.clone();
            for (j, &i) in free.iter().enumerate() {
                trial[i] += delta[j];
            }
            clamp(&mut trial);
            let t = eval(&trial, false)?;
            if t.cost.is_finite() && t.cost < cur.cost {
                let decrease = (cur.cost - t.cost) / cur.cost.abs().max(1e-300);
                x = trial;
                cur = eval(&x, true)?;
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                iterations += 1;
                if decrease < tolerance {
                    return finish(x, cur, iterations, n);
                }
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            break;
        }
    }
    finish(x, cur, iterations, n)
}

fn finish(x: Vec<f64>, cur: Normal, iterations: usize, n: usize) -> Result<LmResult> {
    let jtj = cur.system.map(|(a, _)| a).unwrap_or_else(|| DMatrix::zeros(n, n));
    Ok(LmResult { x, cost: cur.cost, residuals: cur.residuals, iterations, jtj })
}

/// Standard errors of the free parameters from the Gauss–Newton covariance σ²(JᵀJ)⁻¹ with
/// σ² = Σr² / (N − r), r the rank of JᵀJ (the number of parameters when all are fixed). `None`
/// for a parameter the data do not fix: one whose column of J is zero, or one that takes part in
/// a combination of parameters with no effect on the residuals (a null
/// direction of JᵀJ, e.g. the camera gain against a common scale of every albedo when the
/// projector is held). The other parameters get their error in the identifiable subspace: the
/// diagonal of σ² (JᵀJ)⁺, which equals the marginal variance for a parameter orthogonal to every
/// null direction (the same number as if the undetermined combination were held at any value).
pub fn standard_errors(result: &LmResult) -> Vec<Option<f64>> {
    let n = result.jtj.nrows();
    let mut out = vec![None; n];
    // Scale to unit diagonal before the decomposition, so that parameters of very different sizes
    // do not make a well-posed system look singular; parameters without any effect are left out.
    let d: Vec<f64> = (0..n).map(|i| result.jtj[(i, i)].max(0.0).sqrt()).collect();
    let keep: Vec<usize> = (0..n).filter(|&i| d[i] > 0.0 && d[i].is_finite()).collect();
    let m = keep.len();
    if m == 0 {
        return out;
    }
    let scaled = DMatrix::from_fn(m, m, |a, b| result.jtj[(keep[a], keep[b])] / (d[keep[a]] * d[keep[b]]));
    if scaled.iter().any(|v| !v.is_finite()) {
        return out;
    }
    let eig = scaled.symmetric_eigen();
    let max = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    if !(max > 0.0) {
        return out;
    }
    // Relative size below which an eigenvalue counts as a null direction: the scaled matrix has a
    // unit diagonal, so exact degeneracies come out at rounding level (~1e-15).
    const NULL: f64 = 1e-10;
    let rank = eig.eigenvalues.iter().filter(|&&l| l > NULL * max).count();
    let dof = result.residuals.saturating_sub(rank).max(1) as f64;
    let sigma2 = 2.0 * result.cost / dof;
    if !sigma2.is_finite() {
        return out;
    }
    for (a, &i) in keep.iter().enumerate() {
        let mut in_null = 0.0;
        let mut var = 0.0;
        for k in 0..m {
            let v = eig.eigenvectors[(a, k)];
            let lam = eig.eigenvalues[k];
            if lam <= NULL * max {
                in_null += v * v;
            } else {
                var += v * v / lam;
            }
        }
        if in_null < 1e-8 {
            out[i] = Some((sigma2 * var).max(0.0).sqrt() / d[i]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight line y = a + b x fitted to 20 noisy points: ½Σr² at the fit, and the closed-form
    /// standard errors of a and b, σ √((XᵀX)⁻¹)ᵢᵢ with σ² = Σr²/(N − 2) (any least-squares text,
    /// e.g. Press et al., Numerical Recipes, 3rd ed., § 15.2).
    struct Line {
        xs: Vec<f64>,
        cost: f64,
        se_a: f64,
        se_b: f64,
    }

    fn line() -> Line {
        let xs: Vec<f64> = (0..20).map(|i| i as f64 * 0.5 - 3.0).collect();
        let noise = [0.3, -0.1, 0.2, -0.4, 0.1, 0.0, -0.2, 0.5, -0.3, 0.1, 0.2, -0.1, -0.2, 0.3, 0.0, -0.5, 0.4, -0.1, 0.1, -0.2];
        let ys: Vec<f64> = xs.iter().zip(noise).map(|(x, e)| 1.5 + 0.7 * x + e).collect();
        let n = xs.len() as f64;
        let (sx, sy) = (xs.iter().sum::<f64>(), ys.iter().sum::<f64>());
        let sxx: f64 = xs.iter().map(|x| x * x).sum();
        let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| x * y).sum();
        let det = n * sxx - sx * sx;
        let b = (n * sxy - sx * sy) / det;
        let a = (sy - b * sx) / n;
        let ss: f64 = xs.iter().zip(&ys).map(|(x, y)| (y - a - b * x).powi(2)).sum();
        let s2 = ss / (n - 2.0);
        Line { cost: 0.5 * ss, se_a: (s2 * sxx / det).sqrt(), se_b: (s2 * n / det).sqrt(), xs }
    }

    /// The LM result at the line's minimum with Jacobian columns `columns`.
    fn result(columns: &[Vec<f64>], l: &Line) -> LmResult {
        let k = columns.len();
        let jtj = DMatrix::from_fn(k, k, |i, j| columns[i].iter().zip(&columns[j]).map(|(u, v)| u * v).sum());
        LmResult { x: vec![0.0; k], cost: l.cost, residuals: l.xs.len(), iterations: 1, jtj }
    }

    #[test]
    fn standard_errors_match_the_straight_line_closed_form() {
        let l = line();
        let ones = vec![1.0; l.xs.len()];
        let se = standard_errors(&result(&[ones, l.xs.clone()], &l));
        assert!((se[0].unwrap() / l.se_a - 1.0).abs() < 1e-12, "{:?} vs {}", se[0], l.se_a);
        assert!((se[1].unwrap() / l.se_b - 1.0).abs() < 1e-12, "{:?} vs {}", se[1], l.se_b);
    }

    /// y = a + (b + c) x: b and c are fixed only as a sum (a null direction of JᵀJ), so they get
    /// none, while a keeps the two-parameter line's error; a parameter without effect (zero
    /// column) gets none and changes nothing for the others.
    #[test]
    fn degenerate_and_idle_parameters_get_none_and_leave_the_others_exact() {
        let l = line();
        let ones = vec![1.0; l.xs.len()];
        let zero = vec![0.0; l.xs.len()];
        let se = standard_errors(&result(&[ones, l.xs.clone(), l.xs.clone(), zero], &l));
        // Rank 2: the residual degrees of freedom are N − 2, as for the line.
        assert!((se[0].unwrap() / l.se_a - 1.0).abs() < 1e-9, "{:?} vs {}", se[0], l.se_a);
        assert_eq!(se[1], None);
        assert_eq!(se[2], None);
        assert_eq!(se[3], None);
    }
}
