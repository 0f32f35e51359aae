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
/// σ² = Σr² / (N − n); `None` for each parameter when JᵀJ is singular (the data do not fix it).
pub fn standard_errors(result: &LmResult) -> Vec<Option<f64>> {
    let n = result.jtj.nrows();
    let dof = result.residuals.saturating_sub(n).max(1) as f64;
    let sigma2 = 2.0 * result.cost / dof;
    // Scale to unit diagonal before inverting, so that parameters of very different sizes do not
    // make a well-posed system look singular.
    let d: Vec<f64> = (0..n).map(|i| result.jtj[(i, i)].max(0.0).sqrt()).collect();
    if d.iter().any(|&v| !(v > 0.0)) {
        return vec![None; n];
    }
    let scaled = DMatrix::from_fn(n, n, |i, j| result.jtj[(i, j)] / (d[i] * d[j]));
    let eig = scaled.clone().symmetric_eigen();
    let min = eig.eigenvalues.iter().cloned().fold(f64::INFINITY, f64::min);
    let max = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    if !(min > 1e-12 * max) {
        return vec![None; n];
    }
    match scaled.try_inverse() {
        Some(inv) => (0..n).map(|i| Some((sigma2 * inv[(i, i)]).max(0.0).sqrt() / d[i])).collect(),
        None => vec![None; n],
    }
}
