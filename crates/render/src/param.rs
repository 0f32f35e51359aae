//! Scene parameters addressed by path, and a box-bounded Nelder–Mead minimiser, for analysis by
//! synthesis (`lucent fit scene`).
//!
//! A parameter path is a dot-separated walk through the scene's TOML document, following the
//! scene format's own tables (docs/scene-format.md): table keys by name, array entries by index
//! or, for `[[objects]]` and `[[lights]]`, by the entry's `name`. Examples:
//! `spectra.light.scale`, `lights.0.scale`, `materials.wall.albedo`,
//! `objects.milk_whole.medium.milk.fat_percent`. The leaf must be a number, except that a missing
//! `scale` key (whose default is 1 for every spectrum and light) may be addressed and is then
//! inserted. Each evaluation edits the parsed document, re-serialises it and builds the scene
//! with [`Scene::from_toml_str`] resolving relative files against the original scene's folder.
//!
//! The minimiser is the Nelder–Mead solver of the maintained `argmin` crate, run in coordinates
//! normalised to the parameters' box: a point outside the box is evaluated at its projection onto
//! the box plus a quadratic penalty on its distance, so the search stays inside and the scene
//! is only ever built with parameters within their bounds.

use crate::scene::Scene;
use anyhow::{bail, Context, Result};
use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{CostFunction, Executor, State, KV};
use argmin::solver::neldermead::NelderMead;
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// One fitted parameter: its path in the scene document and its box bounds (inclusive).
#[derive(Clone, Debug, PartialEq)]
pub struct ParamSpec {
    /// Dot-separated path into the scene's TOML document.
    pub path: String,
    /// Lower bound (same unit as the scene field).
    pub min: f64,
    /// Upper bound (same unit as the scene field).
    pub max: f64,
}

impl ParamSpec {
    /// Parse `PATH=MIN:MAX` (as given to `--param`).
    pub fn parse(text: &str) -> Result<ParamSpec> {
        let (path, range) = text
            .split_once('=')
            .with_context(|| format!("--param `{text}`: expected PATH=MIN:MAX"))?;
        let (lo, hi) = range
            .split_once(':')
            .with_context(|| format!("--param `{text}`: expected PATH=MIN:MAX"))?;
        let num = |s: &str| -> Result<f64> {
            match s.trim().parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => bail!("--param `{text}`: bound `{s}` is not a finite number"),
            }
        };
        let (min, max) = (num(lo)?, num(hi)?);
        let path = path.trim().to_string();
        if path.is_empty() || path.split('.').any(|s| s.is_empty()) {
            bail!("--param `{text}`: empty path or path segment");
        }
        if !(min < max) {
            bail!("--param {path}: MIN {min} must be below MAX {max}");
        }
        Ok(ParamSpec { path, min, max })
    }
}

/// Finds the child of `v` named by `seg`: a table key, an array index, or the array entry whose
/// `name` is `seg`.
fn child<'a>(v: &'a mut toml::Value, seg: &str) -> Option<&'a mut toml::Value> {
    match v {
        toml::Value::Table(t) => t.get_mut(seg),
        toml::Value::Array(a) => {
            if let Ok(i) = seg.parse::<usize>() {
                a.get_mut(i)
            } else {
                a.iter_mut().find(|e| e.get("name").and_then(|n| n.as_str()) == Some(seg))
            }
        }
        _ => None,
    }
}

/// The number at `path` (a missing `scale` leaf reads as its default, 1).
pub fn get_param(doc: &toml::Value, path: &str) -> Result<f64> {
    let mut copy = doc.clone();
    let slot = resolve(&mut copy, path, false)?;
    Ok(slot.map(|v| number(v, path)).transpose()?.unwrap_or(1.0))
}

/// Sets the number at `path` (inserting a missing `scale` leaf).
pub fn set_param(doc: &mut toml::Value, path: &str, value: f64) -> Result<()> {
    let slot = resolve(doc, path, true)?.expect("resolve inserts when asked");
    number(slot, path)?;
    *slot = toml::Value::Float(value);
    Ok(())
}

fn number(v: &toml::Value, path: &str) -> Result<f64> {
    match v {
        toml::Value::Float(x) => Ok(*x),
        toml::Value::Integer(i) => Ok(*i as f64),
        other => bail!("parameter {path} is a {}, not a number", other.type_str()),
    }
}

/// Walks `path`; `Ok(None)` for a missing `scale` leaf in an existing table (inserted when `insert`).
fn resolve<'a>(doc: &'a mut toml::Value, path: &str, insert: bool) -> Result<Option<&'a mut toml::Value>> {
    let segs: Vec<&str> = path.split('.').collect();
    let mut cur = doc;
    for (k, seg) in segs.iter().enumerate() {
        let last = k + 1 == segs.len();
        if last && *seg == "scale" && cur.is_table() && cur.get("scale").is_none() {
            if !insert {
                return Ok(None);
            }
            let t = cur.as_table_mut().expect("checked table");
            t.insert("scale".into(), toml::Value::Float(1.0));
            return Ok(t.get_mut("scale"));
        }
        let prefix = segs[..=k].join(".");
        cur = match child(cur, seg) {
            Some(c) => c,
            None => bail!("parameter path {path} does not exist in the scene (no `{prefix}`)"),
        };
    }
    Ok(Some(cur))
}

/// A parsed scene document from which scenes with changed parameters are built.
#[derive(Clone, Debug)]
pub struct SceneTemplate {
    /// The parsed TOML document.
    pub doc: toml::Value,
    /// Name for error messages (the file name).
    pub name: String,
    /// Folder against which the scene's relative file names resolve.
    pub base_dir: PathBuf,
}

impl SceneTemplate {
    /// Reads and parses a scene file (checking that it builds as is).
    pub fn load(path: &Path) -> Result<SceneTemplate> {
        Scene::load(path)?;
        let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read scene", path.display()))?;
        let doc: toml::Value = toml::from_str(&text).with_context(|| format!("{}: invalid TOML", path.display()))?;
        let base_dir = path.parent().map(|p| p.to_path_buf()).unwrap_or_default();
        Ok(SceneTemplate { doc, name: path.display().to_string(), base_dir })
    }

    /// The scene with each `(path, value)` set.
    pub fn build(&self, values: &[(&str, f64)]) -> Result<Scene> {
        let mut doc = self.doc.clone();
        for (p, v) in values {
            set_param(&mut doc, p, *v)?;
        }
        let text = to_inline_toml(&doc)?;
        let label = format!("{} (with fitted parameters)", self.name);
        Scene::from_toml_str(&text, &label, &self.base_dir)
    }
}

/// Serialises a document as one `key = value` line per top-level key, every nested table inline.
/// (`toml::to_string` writes nested tables as `[objects.medium.milk]` headers, which the scene
/// parser's span-tracking values do not accept back.)
pub fn to_inline_toml(doc: &toml::Value) -> Result<String> {
    let Some(table) = doc.as_table() else { bail!("scene document is not a table") };
    let mut s = String::new();
    for (k, v) in table {
        let key = if !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
            k.clone()
        } else {
            toml::Value::String(k.clone()).to_string()
        };
        s += &format!("{key} = {v}\n");
    }
    Ok(s)
}

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
    error: RefCell<Option<anyhow::Error>>,
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
        error: RefCell::new(None),
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
    let run = Executor::new(problem, solver)
        .configure(|state| state.max_iters(max_iterations as u64))
        .add_observer(History(history.clone()), ObserverMode::Always)
        .run();
    let result = match run {
        Ok(r) => r,
        Err(e) => bail!("Nelder–Mead: {e}"),
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

    #[test]
    fn paths_resolve_by_key_index_and_name() {
        let mut doc: toml::Value = toml::from_str(
            "[spectra.w]\nconstant = 0.5\n[[objects]]\nname = \"milk\"\nmedium = { milk = { fat_percent = 3 } }\n",
        )
        .unwrap();
        assert_eq!(get_param(&doc, "objects.milk.medium.milk.fat_percent").unwrap(), 3.0);
        assert_eq!(get_param(&doc, "objects.0.medium.milk.fat_percent").unwrap(), 3.0);
        assert_eq!(get_param(&doc, "spectra.w.scale").unwrap(), 1.0);
        set_param(&mut doc, "spectra.w.scale", 0.7).unwrap();
        assert_eq!(get_param(&doc, "spectra.w.scale").unwrap(), 0.7);
        let e = get_param(&doc, "objects.milk.medium.milk.fat").unwrap_err().to_string();
        assert!(e.contains("objects.milk.medium.milk.fat"), "{e}");
        assert!(get_param(&doc, "objects.2.name").is_err());
        assert!(get_param(&doc, "objects.milk.name").is_err()); // a string, not a number
        let back: toml::Value = toml::from_str(&to_inline_toml(&doc).unwrap()).unwrap();
        assert_eq!(back, doc);
    }

    #[test]
    fn param_spec_parses_and_rejects() {
        let p = ParamSpec::parse("lights.0.scale=0.5:2").unwrap();
        assert_eq!((p.path.as_str(), p.min, p.max), ("lights.0.scale", 0.5, 2.0));
        assert!(ParamSpec::parse("a.b=2:1").is_err());
        assert!(ParamSpec::parse("a.b=nan:1").is_err());
        assert!(ParamSpec::parse("a.b").is_err());
        assert!(ParamSpec::parse("a..b=0:1").is_err());
    }

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
