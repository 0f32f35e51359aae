//! Levenberg–Marquardt for least-squares problems whose parameters split into a few *global*
//! ones (lens intrinsics, the stereo pose) and many independent *blocks* of six (one board pose
//! per view), where each block's residuals depend only on the global parameters and its own
//! six (Triggs et al., "Bundle adjustment — a modern synthesis", 2000, §6.1; the arrowhead
//! normal equations of Hartley & Zisserman, 2nd ed., A6.3).
//!
//! Per iteration the Jacobian is formed block by block by central differences, the normal
//! equations are scaled to a unit diagonal (Marquardt's scaling, so the damping λ·I is
//! λ·diag(JᵀJ) in the parameters' own units) and solved by eliminating the blocks:
//! with U the global–global part, V_b the 6 × 6 part of block b and W_b their coupling,
//! (U + λI − Σ W_b (V_b + λI)⁻¹ W_bᵀ) δg = −g_g + Σ W_b (V_b + λI)⁻¹ g_b (the Schur complement),
//! then δ_b = (V_b + λI)⁻¹ (−g_b − W_bᵀ δg). The cost per iteration grows linearly with the
//! number of blocks instead of with its cube, as a dense solver's would. λ follows Nielsen's rule
//! (Madsen, Nielsen & Tingleff, *Methods for non-linear least squares problems*, 2004, §3.2).

use anyhow::{bail, Result};
use nalgebra::{Cholesky, DMatrix, DVector, Matrix6, Vector6};
use rayon::prelude::*;

/// The residuals of a block-structured problem, evaluated at a full parameter vector `x`.
pub trait Blocks: Sync {
    /// Number of blocks.
    fn n_blocks(&self) -> usize;
    /// Residual rows of each block.
    fn block_rows(&self) -> usize;
    /// Residual rows that depend on the global parameters only.
    fn global_rows(&self) -> usize;
    /// Residuals of block `b` into `out` (length [`Blocks::block_rows`]).
    fn block(&self, x: &[f64], b: usize, out: &mut [f64]);
    /// The global-only residuals into `out` (length [`Blocks::global_rows`]).
    fn global(&self, x: &[f64], out: &mut [f64]);
}

/// Which entries of `x` are free: the global ones, and six per block.
#[derive(Clone, Debug)]
pub struct Layout {
    /// Indices of the free global parameters.
    pub global: Vec<usize>,
    /// Indices of each block's six parameters.
    pub local: Vec<[usize; 6]>,
}

/// The normal equations JᵀJ δ = −Jᵀr at one point, in arrowhead form.
pub struct Normal {
    /// Global–global block of JᵀJ.
    pub u: DMatrix<f64>,
    /// Global–local coupling per block (global rows × 6).
    pub w: Vec<DMatrix<f64>>,
    /// Local–local block per block.
    pub v: Vec<Matrix6<f64>>,
    /// Jᵀr over the global parameters.
    pub gg: DVector<f64>,
    /// Jᵀr over each block's parameters.
    pub gl: Vec<Vector6<f64>>,
}

/// ½‖r‖² over all residuals. The blocks are evaluated in parallel and summed in their order, so
/// the same `x` gives the same bits on any number of threads (a parallel reduction would not,
/// and the minimiser's accept/reject decisions compare costs).
pub fn cost<P: Blocks>(p: &P, x: &[f64]) -> f64 {
    let mut r = vec![0.0; p.global_rows()];
    let per_block: Vec<f64> = (0..p.n_blocks())
        .into_par_iter()
        .map_init(|| vec![0.0; p.block_rows()], |r, b| {
            p.block(x, b, r);
            r.iter().map(|v| v * v).sum::<f64>()
        })
        .collect();
    let blocks: f64 = per_block.iter().sum();
    p.global(x, &mut r);
    0.5 * (blocks + r.iter().map(|v| v * v).sum::<f64>())
}

/// Column `i` of the Jacobian of `eval` at `xw` by central differences (step 10⁻⁶(|x| + 10⁻²)),
/// handed to `out(row, value)`; `rp` and `rm` are scratch of the residuals' length.
fn central_column(xw: &mut [f64], i: usize, rp: &mut [f64], rm: &mut [f64], eval: impl Fn(&[f64], &mut [f64]), mut out: impl FnMut(usize, f64)) {
    let x0 = xw[i];
    let h = 1e-6 * (x0.abs() + 1e-2);
    xw[i] = x0 + h;
    eval(xw, rp);
    xw[i] = x0 - h;
    eval(xw, rm);
    xw[i] = x0;
    for k in 0..rp.len() {
        out(k, (rp[k] - rm[k]) / (2.0 * h));
    }
}

/// One block's share of the normal equations: U_b, W_b, V_b, its part of Jᵀr over the global
/// parameters, and Jᵀr over its own.
type BlockNormal = (DMatrix<f64>, DMatrix<f64>, Matrix6<f64>, DVector<f64>, Vector6<f64>);

/// The normal equations at `x` (Jacobian by central differences, block by block).
pub fn normal_equations<P: Blocks>(p: &P, layout: &Layout, x: &[f64]) -> Normal {
    let ng = layout.global.len();
    let rows = p.block_rows();
    let per_block: Vec<BlockNormal> = layout
        .local
        .par_iter()
        .enumerate()
        .map_init(
            || (x.to_vec(), vec![0.0; rows], vec![0.0; rows]),
            |(xw, rp, rm), (b, loc)| {
                xw.copy_from_slice(x);
                let mut r0 = vec![0.0; rows];
                p.block(xw, b, &mut r0);
                let mut jg = DMatrix::zeros(rows, ng);
                let mut jl = DMatrix::zeros(rows, 6);
                let eval = |x: &[f64], r: &mut [f64]| p.block(x, b, r);
                for (c, &i) in layout.global.iter().enumerate() {
                    central_column(xw, i, rp, rm, eval, |k, v| jg[(k, c)] = v);
                }
                for (c, &i) in loc.iter().enumerate() {
                    central_column(xw, i, rp, rm, eval, |k, v| jl[(k, c)] = v);
                }
                let r = DVector::from_vec(r0);
                let u = jg.tr_mul(&jg);
                let w = jg.tr_mul(&jl);
                let v = Matrix6::from_iterator(jl.tr_mul(&jl).iter().copied());
                let gg = jg.tr_mul(&r);
                let gl = Vector6::from_iterator(jl.tr_mul(&r).iter().copied());
                (u, w, v, gg, gl)
            },
        )
        .collect();
    let mut u = DMatrix::zeros(ng, ng);
    let mut gg = DVector::zeros(ng);
    let (mut w, mut v, mut gl) = (Vec::new(), Vec::new(), Vec::new());
    for (ub, wb, vb, ggb, glb) in per_block {
        u += ub;
        gg += ggb;
        w.push(wb);
        v.push(vb);
        gl.push(glb);
    }
    // The global-only rows.
    let m = p.global_rows();
    if m > 0 && ng > 0 {
        let mut xw = x.to_vec();
        let (mut r0, mut rp, mut rm) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        p.global(&xw, &mut r0);
        let mut jg = DMatrix::zeros(m, ng);
        for (c, &i) in layout.global.iter().enumerate() {
            central_column(&mut xw, i, &mut rp, &mut rm, |x, r| p.global(x, r), |k, v| jg[(k, c)] = v);
        }
        u += jg.tr_mul(&jg);
        gg += jg.tr_mul(&DVector::from_vec(r0));
    }
    Normal { u, w, v, gg, gl }
}

impl Normal {
    /// The whole JᵀJ as a dense matrix, in the order global parameters, then each block's six.
    pub fn dense(&self) -> DMatrix<f64> {
        let ng = self.gg.len();
        let n = ng + 6 * self.v.len();
        let mut a = DMatrix::zeros(n, n);
        a.view_mut((0, 0), (ng, ng)).copy_from(&self.u);
        for (b, (w, v)) in self.w.iter().zip(&self.v).enumerate() {
            let o = ng + 6 * b;
            a.view_mut((0, o), (ng, 6)).copy_from(w);
            a.view_mut((o, 0), (6, ng)).copy_from(&w.transpose());
            a.view_mut((o, o), (6, 6)).copy_from(v);
        }
        a
    }
}

/// Why [`minimize`] stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// A step changed the cost or the scaled parameters by less than 10⁻¹⁵ relative.
    Converged,
    /// No damping, however strong, lowered the cost any more: the minimum to rounding.
    NoImprovement,
    /// The iteration limit was reached first.
    Iterations,
}

/// What [`minimize`] did.
#[derive(Clone, Copy, Debug)]
pub struct Report {
    /// Why it stopped.
    pub stop: Stop,
    /// Normal equations formed.
    pub iterations: usize,
    /// ½‖r‖² at the end.
    pub cost: f64,
}

/// Column scales: the running maximum of √(JᵀJ)_jj per parameter (MINPACK's `diag`), 1 for a
/// parameter no residual has yet depended on.
struct Scales {
    g: DVector<f64>,
    l: Vec<Vector6<f64>>,
}

impl Scales {
    fn update(&mut self, n: &Normal) {
        for i in 0..self.g.len() {
            self.g[i] = self.g[i].max(n.u[(i, i)].sqrt());
        }
        for (s, v) in self.l.iter_mut().zip(&n.v) {
            for i in 0..6 {
                s[i] = s[i].max(v[(i, i)].sqrt());
            }
        }
    }

    fn of(s: f64) -> f64 {
        if s > 0.0 { s } else { 1.0 }
    }
}

/// A damped step in parameter units (global, per block) and the reduction of ½‖r‖² the linear
/// model predicts for it; None when the damped system is not positive definite.
fn solve(n: &Normal, sc: &Scales, lambda: f64) -> Option<(DVector<f64>, Vec<Vector6<f64>>, f64)> {
    let ng = n.gg.len();
    let dg = sc.g.map(Scales::of);
    // The scaled system: Ã = D⁻¹AD⁻¹, g̃ = D⁻¹g.
    let mut s = DMatrix::from_fn(ng, ng, |i, j| n.u[(i, j)] / (dg[i] * dg[j]));
    for i in 0..ng {
        s[(i, i)] += lambda;
    }
    let gg = DVector::from_fn(ng, |i, _| n.gg[i] / dg[i]);
    let mut rhs = -&gg;
    let mut parts = Vec::with_capacity(n.v.len());
    for b in 0..n.v.len() {
        let dl = sc.l[b].map(Scales::of);
        let mut v = Matrix6::from_fn(|i, j| n.v[b][(i, j)] / (dl[i] * dl[j]));
        for i in 0..6 {
            v[(i, i)] += lambda;
        }
        let w = DMatrix::from_fn(ng, 6, |i, j| n.w[b][(i, j)] / (dg[i] * dl[j]));
        let gl = n.gl[b].component_div(&dl);
        let vc = Cholesky::new(v)?;
        // Y = W V*⁻¹ (global × 6).
        let y = vc.solve(&w.transpose()).transpose();
        s -= &y * w.transpose();
        rhs += &y * DVector::from_column_slice(gl.as_slice());
        parts.push((vc, w, gl, dl));
    }
    let delta_g = if ng > 0 { Cholesky::new(s)?.solve(&rhs) } else { DVector::zeros(0) };
    let mut pred = 0.5 * delta_g.dot(&(lambda * &delta_g - &gg));
    let mut out_l = Vec::with_capacity(parts.len());
    for (vc, w, gl, dl) in parts {
        let wt_dg = Vector6::from_iterator((w.transpose() * &delta_g).iter().copied());
        let d = vc.solve(&(-gl - wt_dg));
        pred += 0.5 * d.dot(&(lambda * d - gl));
        out_l.push(d.component_div(&dl));
    }
    Some((delta_g.component_div(&dg), out_l, pred))
}

/// Minimise ½‖r(x)‖² over the free entries of `x` (updated in place), from `x`, for at most
/// `max_iter` Jacobians.
pub fn minimize<P: Blocks>(p: &P, layout: &Layout, x: &mut [f64], max_iter: usize) -> Result<Report> {
    let mut c = cost(p, x);
    if !c.is_finite() {
        bail!("the residuals are not finite at the start");
    }
    let mut sc = Scales { g: DVector::zeros(layout.global.len()), l: vec![Vector6::zeros(); layout.local.len()] };
    let (mut lambda, mut nu) = (1e-3, 2.0);
    let mut trial = x.to_vec();
    for it in 1..=max_iter {
        let n = normal_equations(p, layout, x);
        sc.update(&n);
        loop {
            let step = solve(&n, &sc, lambda);
            let mut accepted = None;
            if let Some((dg, dl, pred)) = step {
                trial.copy_from_slice(x);
                for (k, &i) in layout.global.iter().enumerate() {
                    trial[i] += dg[k];
                }
                for (b, loc) in layout.local.iter().enumerate() {
                    for (k, &i) in loc.iter().enumerate() {
                        trial[i] += dl[b][k];
                    }
                }
                let ct = cost(p, &trial);
                if ct.is_finite() && ct < c && pred > 0.0 {
                    accepted = Some((ct, pred, scaled_norms(&sc, layout, x, &dg, &dl)));
                }
            }
            match accepted {
                Some((ct, pred, (step_norm, x_norm))) => {
                    let rho = (c - ct) / pred;
                    let small = c - ct <= 1e-15 * c || step_norm <= 1e-15 * x_norm;
                    x.copy_from_slice(&trial);
                    c = ct;
                    lambda *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                    nu = 2.0;
                    if small {
                        return Ok(Report { stop: Stop::Converged, iterations: it, cost: c });
                    }
                    break;
                }
                None => {
                    lambda *= nu;
                    nu *= 2.0;
                    if lambda > 1e16 {
                        return Ok(Report { stop: Stop::NoImprovement, iterations: it, cost: c });
                    }
                }
            }
        }
    }
    Ok(Report { stop: Stop::Iterations, iterations: max_iter, cost: c })
}

/// ‖D δ‖ and ‖D x‖ over the free parameters (D the column scales).
fn scaled_norms(sc: &Scales, layout: &Layout, x: &[f64], dg: &DVector<f64>, dl: &[Vector6<f64>]) -> (f64, f64) {
    let (mut s, mut xn) = (0.0, 0.0);
    for (k, &i) in layout.global.iter().enumerate() {
        let d = Scales::of(sc.g[k]);
        s += (d * dg[k]).powi(2);
        xn += (d * x[i]).powi(2);
    }
    for (b, loc) in layout.local.iter().enumerate() {
        for (k, &i) in loc.iter().enumerate() {
            let d = Scales::of(sc.l[b][k]);
            s += (d * dl[b][k]).powi(2);
            xn += (d * x[i]).powi(2);
        }
    }
    (s.sqrt(), xn.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks b = 0…B−1 with residuals y_bk − (a + c·t_k + e^{p_b0} t_k² + p_b1 … ): a global
    /// offset and slope, six local terms per block; a zero-residual problem whose exact solution
    /// is known, and a least-squares one checked against the dense normal equations.
    struct Poly {
        t: Vec<f64>,
        y: Vec<Vec<f64>>,
    }

    fn model(g: &[f64], l: &[f64], t: f64) -> f64 {
        g[0] + g[1] * t + l[0].exp() * t * t + l[1] * (2.0 * t).sin() + l[2] * t.powi(3) + l[3] * (l[4] * t).cos() + l[5] * g[1] * t.powi(4)
    }

    impl Blocks for Poly {
        fn n_blocks(&self) -> usize {
            self.y.len()
        }
        fn block_rows(&self) -> usize {
            self.t.len()
        }
        fn global_rows(&self) -> usize {
            1
        }
        fn block(&self, x: &[f64], b: usize, out: &mut [f64]) {
            let l = &x[2 + 6 * b..8 + 6 * b];
            for (k, &t) in self.t.iter().enumerate() {
                out[k] = model(&x[..2], l, t) - self.y[b][k];
            }
        }
        fn global(&self, x: &[f64], out: &mut [f64]) {
            out[0] = 0.1 * (x[0] - 0.25);
        }
    }

    fn problem(noise: f64) -> (Poly, Vec<f64>, Layout) {
        let t: Vec<f64> = (0..40).map(|k| -1.0 + 2.0 * k as f64 / 39.0).collect();
        let nb = 7;
        let mut truth = vec![0.25, -0.7];
        for b in 0..nb {
            let f = b as f64;
            truth.extend([0.1 * f - 0.3, 0.5 - 0.1 * f, 0.05 * f, 0.3, 1.0 + 0.2 * f, -0.2]);
        }
        let y = (0..nb)
            .map(|b| t.iter().enumerate().map(|(k, &tk)| model(&truth[..2], &truth[2 + 6 * b..8 + 6 * b], tk) + noise * ((k * 7 + b * 13) as f64).sin()).collect())
            .collect();
        let layout = Layout { global: vec![0, 1], local: (0..nb).map(|b| std::array::from_fn(|k| 2 + 6 * b + k)).collect() };
        (Poly { t, y }, truth, layout)
    }

    #[test]
    fn recovers_an_exact_solution() {
        let (p, truth, layout) = problem(0.0);
        let mut x: Vec<f64> = truth.iter().enumerate().map(|(i, v)| v + 0.05 * ((i as f64) * 1.7).cos()).collect();
        let rep = minimize(&p, &layout, &mut x, 200).unwrap();
        assert_ne!(rep.stop, Stop::Iterations);
        for (a, b) in x.iter().zip(&truth) {
            assert!((a - b).abs() < 1e-8, "{a} vs {b}");
        }
    }

    /// At the least-squares minimum the gradient Jᵀr vanishes, and the Schur solve of one step
    /// equals the dense solve of the same damped system.
    #[test]
    fn schur_step_equals_the_dense_step_and_the_minimum_is_stationary() {
        let (p, truth, layout) = problem(0.01);
        let mut x = truth.clone();
        let n = normal_equations(&p, &layout, &x);
        let mut sc = Scales { g: DVector::zeros(2), l: vec![Vector6::zeros(); layout.local.len()] };
        sc.update(&n);
        let lambda = 0.37;
        let (dg, dl, _) = solve(&n, &sc, lambda).unwrap();
        // Dense: (A + λ D²) δ = −g.
        let a = n.dense();
        let mut d = DVector::zeros(a.nrows());
        let mut g = DVector::zeros(a.nrows());
        for i in 0..2 {
            d[i] = Scales::of(sc.g[i]);
            g[i] = n.gg[i];
        }
        for b in 0..layout.local.len() {
            for k in 0..6 {
                d[2 + 6 * b + k] = Scales::of(sc.l[b][k]);
                g[2 + 6 * b + k] = n.gl[b][k];
            }
        }
        let damped = &a + DMatrix::from_diagonal(&d.map(|s| lambda * s * s));
        let dense = damped.lu().solve(&(-&g)).unwrap();
        let mut schur = vec![dg[0], dg[1]];
        for v in &dl {
            schur.extend(v.iter());
        }
        for (a, b) in schur.iter().zip(dense.iter()) {
            assert!((a - b).abs() <= 1e-10 * (1.0 + b.abs()), "{a} vs {b}");
        }
        minimize(&p, &layout, &mut x, 200).unwrap();
        let n = normal_equations(&p, &layout, &x);
        let gnorm = n.gg.amax().max(n.gl.iter().map(|v| v.amax()).fold(0.0, f64::max));
        assert!(gnorm < 1e-9, "gradient {gnorm}");
        assert!(cost(&p, &x) < cost(&p, &truth));
    }
}
