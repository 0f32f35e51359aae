//! `lucent fit scene SCENE.toml --reference PHOTO [--param PATH=MIN:MAX …]`: analysis by
//! synthesis. Named scene parameters (paths into the scene's TOML document, see
//! `render::load::template`) are adjusted by a box-bounded Nelder–Mead search to minimise the RMSE between
//! the render and the reference, optionally after a fitted 3×3 colour correction. Every
//! evaluation renders with the same seed and passes, so the Monte Carlo noise is the same
//! (common random numbers) and the objective is a smooth function of the parameters.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use analysis::compare::{compare, error_image, Comparison, Mask};
use render::image_io::{read_image, write_atomic, write_image, Image};
use analysis::scene_fit::{convergence_svg, cross_error, render_image, side_by_side};
use render::integrator::IntegratorSettings;
use analysis::minimize::nelder_mead_box;
use render::load::template::{get_param, ParamSpec, SceneTemplate};
use render::scene::Scene;
use serde_json::json;

/// XORed into `--seed` for the second half of `--unbiased` (any other seed is independent).
const SECOND_HALF_SEED: u64 = 0x5EC0_4D4A_1F5E_ED00;

use super::render::{finite_f64, integrator_kind, positive_u64};

/// Arguments of `lucent fit scene`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scene file (TOML, see docs/scene-format.md) at the starting parameter values.
    #[arg(value_name = "SCENE.toml")]
    pub scene: PathBuf,
    /// The reference image (PNG, EXR or PFM; linear sRGB primaries, PNG decoded with the sRGB curve).
    #[arg(long, value_name = "PHOTO")]
    pub reference: PathBuf,
    /// A parameter to fit and its bounds, PATH=MIN:MAX; repeatable. PATH walks the scene's
    /// tables: `lights.0.scale`, `spectra.white.scale`, `objects.milk_whole.medium.milk.fat_percent`.
    #[arg(long, value_name = "PATH=MIN:MAX", allow_hyphen_values = true)]
    pub param: Vec<String>,
    /// Samples per pixel of every evaluation [default: 4].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub spp: Option<String>,
    /// Render width in pixels [default: the reference's].
    #[arg(long, value_name = "W", allow_hyphen_values = true)]
    pub width: Option<String>,
    /// Render height in pixels [default: the reference's].
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub height: Option<String>,
    /// Most Nelder–Mead iterations [default: 60].
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub max_iterations: Option<String>,
    /// Folder for fit.json, convergence.svg, render.{png,exr}, reference.png, error.png and
    /// comparison.png (render | reference | error) [default: fit-scene]; created if missing.
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
    /// Only pixels where this image is white (mean channel > 0.5) count (as in `lucent compare`).
    #[arg(long, value_name = "MASK.png")]
    pub mask: Option<PathBuf>,
    /// Fit a 3×3 colour matrix (render → reference) at every evaluation before the error.
    #[arg(long)]
    pub color_correct: bool,
    /// Seed of the random sequence, the same for every evaluation [default: 0].
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub seed: Option<String>,
    /// Light-transport estimator [default: the scene's].
    #[arg(long, value_name = super::render::INTEGRATOR_VALUES.as_str())]
    pub integrator: Option<String>,
    /// Stop when the standard deviation of the simplex's errors falls below this (relative to the initial error) [default: 1e-6].
    #[arg(long, value_name = "TOL", allow_hyphen_values = true)]
    pub tolerance: Option<String>,
    /// Minimise an unbiased estimate of the noise-free squared error instead of the RMSE: the
    /// passes are split into two independent halves a and b (the second with a seed derived from
    /// --seed) and the objective is
    /// mean((a − ref)(b − ref)), whose expectation has no Monte Carlo variance term (a plain RMSE
    /// of a noisy render favours darker parameters, which have less noise). Reported errors stay RMSE.
    #[arg(long)]
    pub unbiased: bool,
    /// Print `params`, `initial_error`, `final_error` and `iterations` as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// No progress lines on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |tmp| std::fs::write(tmp, text).with_context(|| format!("cannot write {}", tmp.display())))
}

/// Runs `lucent fit scene`.
pub fn run(args: Args) -> Result<()> {
    let spp = match &args.spp {
        Some(t) => positive_u64("--spp", t)?,
        None => 4,
    };
    let max_iterations = match &args.max_iterations {
        Some(t) => positive_u64("--max-iterations", t)? as usize,
        None => 60,
    };
    let seed = match &args.seed {
        Some(t) => t.trim().parse::<u64>().with_context(|| format!("--seed must be a whole number ≥ 0, got `{t}`"))?,
        None => 0,
    };
    let tolerance = match &args.tolerance {
        Some(t) => {
            let v = finite_f64("--tolerance", t)?;
            if !(v >= 0.0) {
                bail!("--tolerance must be ≥ 0, got {v}");
            }
            v
        }
        None => 1e-6,
    };
    let kind = args.integrator.as_deref().map(integrator_kind).transpose()?;
    if args.param.is_empty() {
        bail!("no --param PATH=MIN:MAX given: nothing to fit");
    }
    let specs: Vec<ParamSpec> = args.param.iter().map(|p| ParamSpec::parse(p)).collect::<Result<_>>()?;
    for (i, s) in specs.iter().enumerate() {
        if specs[..i].iter().any(|o| o.path == s.path) {
            bail!("--param {} is given twice", s.path);
        }
    }

    let template = SceneTemplate::load(&args.scene)?;
    let mut x0 = Vec::with_capacity(specs.len());
    for s in &specs {
        let v = get_param(&template.doc, &s.path).with_context(|| args.scene.display().to_string())?;
        if !(v >= s.min && v <= s.max) {
            bail!("{}: parameter {} starts at {v}, outside its bounds [{}, {}]", args.scene.display(), s.path, s.min, s.max);
        }
        x0.push(v);
    }
    let reference = read_image(&args.reference)?;
    let dim = |opt: &Option<String>, name: &str, dflt: u32| -> Result<u32> {
        match opt {
            Some(t) => u32::try_from(positive_u64(name, t)?).with_context(|| format!("{name} is too large")),
            None => Ok(dflt),
        }
    };
    let width = dim(&args.width, "--width", reference.width)?;
    let height = dim(&args.height, "--height", reference.height)?;
    if (width, height) != (reference.width, reference.height) {
        bail!(
            "{}: reference is {}×{} but the render would be {width}×{height}",
            args.reference.display(),
            reference.width,
            reference.height
        );
    }
    let mask = match &args.mask {
        Some(p) => Some(Mask::from_image(&read_image(p)?)),
        None => None,
    };
    let out_dir = args.out_dir.clone().unwrap_or_else(|| PathBuf::from("fit-scene"));
    std::fs::create_dir_all(&out_dir).with_context(|| format!("--out-dir {}: cannot create", out_dir.display()))?;

    let paths: Vec<&str> = specs.iter().map(|s| s.path.as_str()).collect();
    let build = |x: &[f64]| -> Result<Scene> {
        let values: Vec<(&str, f64)> = paths.iter().cloned().zip(x.iter().cloned()).collect();
        let mut scene = template.build(&values)?;
        scene.set_resolution(width, height);
        Ok(scene)
    };
    let settings_of = |scene: &Scene| IntegratorSettings { kind: kind.unwrap_or(scene.integrator.kind), ..scene.integrator.clone() };
    if args.unbiased && spp < 2 {
        bail!("--unbiased needs --spp ≥ 2 (two independent halves)");
    }
    // Returns the render, its comparison and the objective (RMSE, or the unbiased cross error).
    let evaluate_full = |x: &[f64]| -> Result<(Image, Comparison, f64)> {
        let scene = build(x)?;
        let settings = settings_of(&scene);
        let (img, halves) = if args.unbiased {
            // The passes of one seed are stratified against each other (the wavelength and
            // film numbers, `render::math::sampling::PixelStrata`), so the second half takes a
            // second seed: the halves must be independent for the cross error to be unbiased.
            let half = spp / 2;
            let a = render_image(&scene, &settings, seed, 0..half);
            let b = render_image(&scene, &settings, seed ^ SECOND_HALF_SEED, 0..spp - half);
            let (na, nb) = (half as f32, (spp - half) as f32);
            let rgb = a.rgb.iter().zip(&b.rgb).map(|(p, q)| std::array::from_fn(|c| (na * p[c] + nb * q[c]) / (na + nb))).collect();
            (Image { width: a.width, height: a.height, rgb }, Some((a, b)))
        } else {
            (render_image(&scene, &settings, seed, 0..spp), None)
        };
        let cmp = compare(&img, &reference, mask.as_ref(), args.color_correct)
            .with_context(|| format!("comparing with {}", args.reference.display()))?;
        let objective = match &halves {
            Some((a, b)) => cross_error(a, b, &reference, cmp.metrics.color_matrix.as_ref(), &cmp.mask),
            None => cmp.metrics.rmse,
        };
        Ok((img, cmp, objective))
    };
    let evaluate = |x: &[f64]| -> Result<(Image, Comparison)> { evaluate_full(x).map(|(i, c, _)| (i, c)) };

    let (_, c0) = evaluate(&x0)?;
    let initial_error = c0.metrics.rmse;
    let mut evals = 0usize;
    let quiet = args.quiet;
    let objective = |x: &[f64]| -> Result<f64> {
        evals += 1;
        let (_, c, obj) = evaluate_full(x)?;
        if !quiet {
            let shown: Vec<String> = paths.iter().zip(x).map(|(p, v)| format!("{p}={v:.6}")).collect();
            eprintln!("lucent: evaluation {evals}: rmse {:.6e} objective {obj:.6e}  {}", c.metrics.rmse, shown.join(" "));
        }
        Ok(obj)
    };
    let f_tol = tolerance * if args.unbiased { initial_error * initial_error } else { initial_error }.max(1e-300);
    let best = nelder_mead_box(
        objective,
        &x0,
        &specs.iter().map(|s| s.min).collect::<Vec<_>>(),
        &specs.iter().map(|s| s.max).collect::<Vec<_>>(),
        max_iterations,
        f_tol,
    )?;

    // Final render and outputs.
    let (final_img, final_cmp) = evaluate(&best.x)?;
    let final_error = final_cmp.metrics.rmse;
    let err_img = error_image(&final_cmp, 10.0);
    let shown_render = match &final_cmp.metrics.color_matrix {
        Some(m) => analysis::compare::apply_color_matrix(&final_img, m),
        None => final_img.clone(),
    };
    write_image(&out_dir.join("render.exr"), &final_img, 0.0)?;
    write_image(&out_dir.join("render.png"), &shown_render, 0.0)?;
    write_image(&out_dir.join("reference.png"), &reference, 0.0)?;
    write_image(&out_dir.join("error.png"), &err_img, 0.0)?;
    write_image(&out_dir.join("comparison.png"), &side_by_side(&[&shown_render, &reference, &err_img]), 0.0)?;
    write_text(&out_dir.join("convergence.svg"), &convergence_svg(&best.history, if args.unbiased { "mean (a − ref)(b − ref)" } else { "RMSE (linear sRGB)" }))?;

    let mut params = serde_json::Map::new();
    for (p, v) in paths.iter().zip(&best.x) {
        params.insert(p.to_string(), json!(v));
    }
    let summary = json!({
        "params": params,
        "initial_error": initial_error,
        "final_error": final_error,
        "iterations": best.iterations,
    });
    let mut full = summary.clone();
    full["initial_params"] = json!(paths.iter().zip(&x0).map(|(p, v)| (p.to_string(), json!(v))).collect::<serde_json::Map<_, _>>());
    full["evaluations"] = json!(best.evaluations + 2);
    full["history"] = json!(best.history);
    full["spp"] = json!(spp);
    full["seed"] = json!(seed);
    if let Some(m) = final_cmp.metrics.color_matrix {
        full["color_matrix"] = json!(m);
    }
    write_text(&out_dir.join("fit.json"), &(serde_json::to_string_pretty(&full)? + "\n"))?;

    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        for ((p, v0), v) in paths.iter().zip(&x0).zip(&best.x) {
            println!("{p}: {v0} -> {v:.6}");
        }
        println!(
            "rmse {initial_error:.6e} -> {final_error:.6e} in {} iterations ({} renders); outputs in {}",
            best.iterations,
            best.evaluations + 2,
            out_dir.display()
        );
    }
    Ok(())
}
