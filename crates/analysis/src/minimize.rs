//! A box-bounded Nelder–Mead minimiser for analysis by synthesis.
//!
//! The minimiser is the Nelder–Mead solver of the maintained `argmin` crate, run in coordinates
//! normalised to the parameters' box: a point outside the box is evaluated at its projection onto
//! the box plus a quadratic penalty on its distance, so the search stays inside and the scene
//! is only ever built with parameters within their bounds.

use anyhow::{bail, Context, Result};
use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{CostFunction, Executor, State, KV};
use argmin::solver::neldermead::NelderMead;
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

/// Result of [`nelder_mead_box`].
#[derive(Clone, Debug)]
pub struct Minimum {
    /// The best point found.
    pub x: Vec<f64>,
    /// Objective at `x`.
    pub value: f64,
    /// Nelder–Mead iterations made.
    pub iterations: usize,
    /// Best objective value after each iteration (index 0: the starting point).
    pub history: Vec<f64>,
    /// Objective evaluations made (distinct points: a point met again is not re-evaluated).
    pub evaluations: usize,
}

/// The objective as `argmin` sees it: unit-box coordinates, projection plus penalty outside the
/// box, a cache of the evaluated (projected) points, and the first error met.
struct BoxObjective<F> {
    f: RefCell<F>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    /// Weight of the squared distance outside the unit box.
    penalty: f64,
    cache: RefCell<HashMap<Vec<u64>, f64>>,
    error: Rc<RefCell<Option<anyhow::Error>>>,
}

impl<F: FnMut(&[f64]) -> Result<f64>> BoxObjective<F> {
    fn to_x(&self, u: &[f64]) -> Vec<f64> {
        (0..u.len()).map(|i| self.lo[i] + u[i].clamp(0.0, 1.0) * (self.hi[i] - self.lo[i])).collect()
    }

    /// f at the projection of `u` onto the box (NaN read as +∞), cached.
    fn inside(&self, u: &[f64]) -> Result<f64> {
        let x = self.to_x(u);
        let key: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
        if let Some(&v) = self.cache.borrow().get(&key) {
            return Ok(v);
        }
        let v = (self.f.borrow_mut())(&x)?;
        let v = if v.is_nan() { f64::INFINITY } else { v };
        self.cache.borrow_mut().insert(key, v);
        Ok(v)
    }
}

impl<F: FnMut(&[f64]) -> Result<f64>> CostFunction for BoxObjective<F> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, u: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        if self.error.borrow().is_some() {
            return Err(argmin::core::Error::msg("an earlier evaluation failed"));
        }
        match self.inside(u) {
            Ok(v) => {
                let d2: f64 = u.iter().map(|&c| (c - c.clamp(0.0, 1.0)).powi(2)).sum();
                Ok(v + self.penalty * d2)
            }
            Err(e) => {
                *self.error.borrow_mut() = Some(e);
                Err(argmin::core::Error::msg("evaluation failed"))
            }
        }
    }
}

/// Records the best objective value after each iteration.
struct History(Rc<RefCell<Vec<f64>>>);

impl<I: State<Float = f64>> Observe<I> for History {
    fn observe_iter(&mut self, state: &I, _kv: &KV) -> std::result::Result<(), argmin::core::Error> {
        self.0.borrow_mut().push(state.get_best_cost());
        Ok(())
    }
}

/// Minimises `f` over the box `[lo, hi]` from `x0` by Nelder–Mead (`argmin`'s
/// `NelderMead`: reflection 1, expansion 2, contraction ½, shrink ½) in coordinates normalised to
/// the unit box; outside the box the objective is f at the projection onto the box plus
/// (|f(x0)| + 1e-300)·d², d the distance outside in unit coordinates. The initial simplex steps
/// 25 % of each range from `x0` (towards the interior). Stops after `max_iterations`, or when the
/// standard deviation of the simplex's values falls below `f_tol` (absolute).
pub fn nelder_mead_box(
    f: impl FnMut(&[f64]) -> Result<f64>,
    x0: &[f64],
    lo: &[f64],
    hi: &[f64],
    max_iterations: usize,
    f_tol: f64,
) -> Result<Minimum> {
    let n = x0.len();
    if n == 0 {
        bail!("nothing to fit: no parameters");
    }
    let mut problem = BoxObjective {
        f: RefCell::new(f),
        lo: lo.to_vec(),
        hi: hi.to_vec(),
        penalty: 0.0,
        cache: RefCell::new(HashMap::new()),
        error: Rc::new(RefCell::new(None)),
    };
    let u0: Vec<f64> = (0..n).map(|i| ((x0[i] - lo[i]) / (hi[i] - lo[i])).clamp(0.0, 1.0)).collect();
    let mut simplex = vec![u0.clone()];
    for i in 0..n {
        let mut u = u0.clone();
        u[i] += if u[i] + 0.25 <= 1.0 { 0.25 } else { -0.25 };
        simplex.push(u);
    }
    // Evaluate the simplex here (argmin's initialisation cannot report an error); the cache
    // serves these values to the solver.
    let mut f0 = f64::NAN;
    for u in &simplex {
        let v = problem.inside(u)?;
        if f0.is_nan() {
            f0 = v;
        }
    }
    problem.penalty = if f0.is_finite() { f0.abs().max(1e-300) } else { 1.0 };
    let history = Rc::new(RefCell::new(vec![f0]));
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(f_tol.max(0.0))
        .map_err(|e| anyhow::anyhow!("Nelder–Mead: {e}"))?;
    // The first evaluation error, kept outside the executor, which drops the problem when it
    // stops on an error.
    let first_error = problem.error.clone();
    let run = Executor::new(problem, solver)
        .configure(|state| state.max_iters(max_iterations as u64))
        .add_observer(History(history.clone()), ObserverMode::Always)
        .run();
    let result = match run {
        Ok(r) => r,
        Err(e) => match first_error.borrow_mut().take() {
            Some(cause) => return Err(cause),
            None => bail!("Nelder–Mead: {e}"),
        },
    };
    let problem = result.problem.problem.as_ref().context("Nelder–Mead lost its problem")?;
    if let Some(e) = problem.error.borrow_mut().take() {
        return Err(e);
    }
    let state = result.state();
    let u = state.get_best_param().context("Nelder–Mead found no point")?.clone();
    let value = problem.inside(&u)?;
    let evaluations = problem.cache.borrow().len();
    let history = history.borrow().clone();
    Ok(Minimum { x: problem.to_x(&u), value, iterations: state.get_iter() as usize, history, evaluations })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rosenbrock's function in a box containing its minimum (1, 1): Nelder–Mead reaches it.
    #[test]
    fn nelder_mead_finds_rosenbrock_minimum() {
        let f = |x: &[f64]| Ok((1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2));
        let m = nelder_mead_box(f, &[-1.0, 2.0], &[-2.0, -1.0], &[2.0, 3.0], 2000, 1e-14).unwrap();
        assert!((m.x[0] - 1.0).abs() < 1e-3 && (m.x[1] - 1.0).abs() < 1e-3, "{:?}", m.x);
        assert!(m.history.windows(2).all(|w| w[1] <= w[0]));
    }

    /// A minimum outside the box: the result lies on the bound nearest to it.
    #[test]
    fn nelder_mead_respects_bounds() {
        let f = |x: &[f64]| Ok((x[0] - 5.0).powi(2) + (x[1] + 1.0).powi(2));
        let m = nelder_mead_box(f, &[0.5, 0.5], &[0.0, 0.0], &[1.0, 1.0], 500, 1e-14).unwrap();
        assert!((m.x[0] - 1.0).abs() < 1e-6 && m.x[1].abs() < 1e-6, "{:?}", m.x);
    }
}
