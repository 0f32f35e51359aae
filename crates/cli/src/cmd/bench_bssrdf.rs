//! `lucent bench bssrdf`: time to equal noise of the point-cloud BSSRDF against volumetric path
//! tracing of the same translucent object (the speed check of docs/validation.md, "Speed"; `analysis::noise_cost`).
//!
//! The scene (default `scenes/marble-bunny.toml`) is rendered twice with each estimator (two
//! seeds): `path`, which renders translucent materials with their dipole BSSRDF, and `volpath`,
//! which traces the same `medium` inside the same boundary. Each estimator's figure is σ²·CPU: its
//! per-pixel noise of luminance over a region of the frame (default the bunny's body) times its
//! CPU time per render; the ratio of the two is how many times less CPU time the BSSRDF needs to
//! reach the noise of volpath.

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use render::integrator::{IntegratorKind, IntegratorSettings};
use analysis::noise_cost::{noise_cost, NoiseCost};
use render::scene::Scene;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scene with translucent objects (default: scenes/marble-bunny.toml).
    pub scene: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Image width, pixels.
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Samples per pixel of each volpath render.
    #[arg(long, default_value_t = 64)]
    pub volpath_spp: u32,
    /// Samples per pixel of each BSSRDF render.
    #[arg(long, default_value_t = 16)]
    pub bssrdf_spp: u32,
    /// The two seeds, comma-separated.
    #[arg(long, default_value = "1,2", value_delimiter = ',')]
    pub seeds: Vec<u64>,
    /// Region x0,y0,x1,y1 as fractions of the frame (default: the marble bunny's body).
    #[arg(long, default_value = "0.3,0.2,0.7,0.85", value_delimiter = ',', allow_negative_numbers = true)]
    pub region: Vec<f32>,
    /// Longest volpath path, in path segments (1 = emitters only).
    #[arg(long, default_value_t = 100_000)]
    pub volpath_max_depth: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

pub fn run(args: Args) -> Result<()> {
    let path = match &args.scene {
        Some(p) => p.clone(),
        None => super::bench_support::bundled("scenes/marble-bunny.toml", "give a SCENE")?,
    };
    if args.width == 0 || args.height == 0 {
        bail!("--width and --height must be at least 1");
    }
    if args.volpath_spp == 0 || args.bssrdf_spp == 0 {
        bail!("--volpath-spp and --bssrdf-spp must be at least 1");
    }
    let [s0, s1] = args.seeds[..] else {
        bail!("--seeds: expected two comma-separated seeds, got {}", args.seeds.len());
    };
    let [x0, y0, x1, y1] = args.region[..] else {
        bail!("--region: expected x0,y0,x1,y1 (four fractions of the frame), got {} values", args.region.len());
    };
    if !(0.0 <= x0 && x0 < x1 && x1 <= 1.0 && 0.0 <= y0 && y0 < y1 && y1 <= 1.0) {
        bail!("--region: need 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1, got {x0},{y0},{x1},{y1}");
    }
    let mut scene = Scene::load(&path)?;
    if !render::integrator::subsurface::scene_has_translucent(&scene) {
        bail!("{}: no translucent object (nothing for the BSSRDF to render)", path.display());
    }
    scene.set_resolution(args.width, args.height);
    let seeds = [s0, s1];
    let region = [x0, y0, x1, y1];
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    let total = 2 * (args.volpath_spp + args.bssrdf_spp) as u64;
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template("{spinner} {elapsed_precise} [{bar:30}] {pos}/{len} passes  {msg}  {eta} left") {
        bar.set_style(style.progress_chars("=> "));
    }
    let measure = |kind: IntegratorKind, max_depth: u32, spp: u32, label: &str| -> Result<NoiseCost> {
        bar.set_message(label.to_string());
        let settings = IntegratorSettings { kind, max_depth, rr_depth: scene.integrator.rr_depth };
        pool.install(|| noise_cost(&scene, &settings, spp, seeds, region, &super::bench_support::cpu_seconds, &|| bar.inc(1)))
    };
    let bssrdf = measure(IntegratorKind::Path, scene.integrator.max_depth, args.bssrdf_spp, "BSSRDF (path)")?;
    let volpath = measure(IntegratorKind::Volpath, args.volpath_max_depth, args.volpath_spp, "volpath")?;
    bar.finish_and_clear();
    let speedup = volpath.sigma2_cpu_s() / bssrdf.sigma2_cpu_s();
    if args.json {
        let v = serde_json::json!({
            "scene": path.display().to_string(),
            "width": args.width,
            "height": args.height,
            "threads": pool.current_num_threads(),
            "region": region.map(|v| (v as f64 * 1e6).round() / 1e6),
            "seeds": seeds,
            "volpath_spp": volpath.spp,
            "volpath_cpu_s": volpath.cpu_s,
            "volpath_mean_y": volpath.mean_y,
            "volpath_sigma_y": volpath.sigma_y,
            "volpath_sigma2_cpu_s": volpath.sigma2_cpu_s(),
            "bssrdf_spp": bssrdf.spp,
            "bssrdf_cpu_s": bssrdf.cpu_s,
            "bssrdf_mean_y": bssrdf.mean_y,
            "bssrdf_sigma_y": bssrdf.sigma_y,
            "bssrdf_sigma2_cpu_s": bssrdf.sigma2_cpu_s(),
            "bssrdf_mean_rel_diff": bssrdf.mean_y / volpath.mean_y - 1.0,
            "bssrdf_speedup_vs_volpath": speedup,
        });
        println!("{v}");
    } else {
        println!("scene     {} at {}×{}, region {:?}, {} threads", path.display(), args.width, args.height, region, pool.current_num_threads());
        for (name, c) in [("volpath", &volpath), ("BSSRDF", &bssrdf)] {
            println!(
                "{name:8}  {:>4} spp  CPU {:7.1} s per render  mean Y {:.4}  σ {:.4}  σ²·CPU {:.4} s",
                c.spp,
                c.cpu_s,
                c.mean_y,
                c.sigma_y,
                c.sigma2_cpu_s()
            );
        }
        println!("BSSRDF mean {:+.1} % vs volpath", 100.0 * (bssrdf.mean_y / volpath.mean_y - 1.0));
        println!("speed-up  {speedup:.1}× less CPU time than volpath to equal per-pixel noise");
    }
    Ok(())
}
