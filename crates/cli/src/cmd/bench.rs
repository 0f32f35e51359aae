//! `lucent bench` (rays and path tracing) and `lucent bench mie`.
//!
//! The ray benchmark loads a mesh (default: the bundled 48k-triangle dragon), builds the BVH and
//! times closest-hit queries for camera rays (a pinhole outside the bounding box looking at its
//! centre, one ray per pixel) and incoherent rays (origins uniform in the bounding box,
//! directions uniform on the sphere). Each figure is the best of several repetitions.
//! Both are timed one ray at a time (`Accel::intersect`) and in batches (`Accel::intersect_batch`,
//! several traversals interleaved so their memory accesses overlap; bit-identical hits); camera
//! rays also as packets of 4×4 pixels traversing the tree together (`Accel::intersect_packet`,
//! the same hits). The JSON keys `camera_mrays_per_s` / `incoherent_mrays_per_s` give the fastest
//! way and `*_single_mrays_per_s` / `*_batched_mrays_per_s` / `camera_packet_mrays_per_s` each one.
//! The `*_per_cpu_s` rates need at least 0.1 s of CPU time (the process clock ticks in 10 ms):
//! below that the text says "n/a" and the JSON holds `null`.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a < b)` is deliberate: it is true for NaN.

use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use super::bench_support::{bundled, cpu_seconds};
use render::bench::{incoherent_rays, BenchCamera};
use render::accel::Accel;
use render::shape::Shape;
use render::math::geometry::Ray;
use render::shape::mesh::TriangleMesh;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub which: Option<Which>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Mesh to trace (.ply, .obj, optionally .gz); default data/meshes/dragon-48k.ply.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Image side of the camera-ray benchmark, pixels.
    #[arg(long, default_value_t = 1024)]
    pub size: u32,
    /// Incoherent rays per repetition, millions.
    #[arg(long, default_value_t = 2.0)]
    pub mrays: f64,
    /// Repetitions of each ray benchmark (the best is reported).
    #[arg(long, default_value_t = 5)]
    pub reps: u32,
    /// Also time the Cornell box on one thread and report the speed-up of all threads over one.
    #[arg(long)]
    pub scaling: bool,
    /// Seconds of Cornell-box path tracing.
    #[arg(long, default_value_t = 3.0)]
    pub cornell_seconds: f64,
}

#[derive(clap::Subcommand, Debug)]
pub enum Which {
    /// Lorenz-Mie and milk-spectrum timings.
    Mie(super::bench_mie::Args),
    /// BSSRDF (point-cloud method) vs volumetric path tracing: CPU time to equal noise.
    Bssrdf(super::bench_bssrdf::Args),
}

pub fn run(args: Args) -> Result<()> {
    match args.which {
        Some(Which::Mie(a)) => super::bench_mie::run(a),
        Some(Which::Bssrdf(a)) => super::bench_bssrdf::run(a),
        None => run_rays(&args),
    }
}

/// The bundled default mesh.
fn default_mesh() -> Result<PathBuf> {
    bundled("data/meshes/dragon-48k.ply", "pass --mesh FILE")
}

fn run_rays(args: &Args) -> Result<()> {
    if args.threads == Some(0) {
        bail!("--threads: must be at least 1");
    }
    if args.reps == 0 || !(args.mrays > 0.0) || args.size == 0 {
        bail!("--reps, --mrays and --size must be positive");
    }
    if !(args.cornell_seconds >= 0.0) {
        bail!("--cornell-seconds: must be non-negative");
    }
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build().context("cannot start the thread pool")?;
    pool.install(|| bench_in_pool(args))
}

fn trace_camera(accel: &Accel, size: u32) -> u64 {
    let cam = BenchCamera::new(accel);
    (0..size)
        .into_par_iter()
        .map(|j| {
            let mut hits = 0u64;
            for i in 0..size {
                let ray = cam.ray(i, j, size);
                hits += accel.intersect(&ray).is_some() as u64;
            }
            hits
        })
        .sum()
}

fn trace_camera_batched(accel: &Accel, size: u32) -> u64 {
    let cam = BenchCamera::new(accel);
    (0..size)
        .into_par_iter()
        .map(|j| {
            let rays: Vec<Ray> = (0..size).map(|i| cam.ray(i, j, size)).collect();
            let mut hits = vec![None; rays.len()];
            accel.intersect_batch(&rays, &mut hits);
            hits.iter().filter(|h| h.is_some()).count() as u64
        })
        .sum()
}

/// Camera rays traced as packets of 4×4 pixels (`Accel::intersect_packet`, four SIMD groups of
/// 2×2); pixels of a partial block at the right or bottom edge one by one.
fn trace_camera_packets(accel: &Accel, size: u32) -> u64 {
    let cam = BenchCamera::new(accel);
    (0..size.div_ceil(4))
        .into_par_iter()
        .map(|jb| {
            let j = 4 * jb;
            let mut hits = 0u64;
            let mut out = [None; 16];
            for i in (0..size).step_by(4) {
                if i + 4 <= size && j + 4 <= size {
                    accel.intersect_packet(&cam.block(i, j, size), &mut out);
                    hits += out.iter().filter(|h| h.is_some()).count() as u64;
                } else {
                    for y in j..(j + 4).min(size) {
                        for x in i..(i + 4).min(size) {
                            hits += accel.intersect(&cam.ray(x, y, size)).is_some() as u64;
                        }
                    }
                }
            }
            hits
        })
        .sum()
}

fn trace_all(accel: &Accel, rays: &[Ray]) -> u64 {
    rays.par_chunks(1024).map(|ch| ch.iter().filter(|r| accel.intersect(r).is_some()).count() as u64).sum()
}

fn trace_all_batched(accel: &Accel, rays: &[Ray]) -> u64 {
    rays.par_chunks(1024)
        .map(|ch| {
            let mut hits = vec![None; ch.len()];
            accel.intersect_batch(ch, &mut hits);
            hits.iter().filter(|h| h.is_some()).count() as u64
        })
        .sum()
}

/// Shortest CPU time (s) a per-CPU-second rate is computed from: the clock of /proc/self/stat
/// ticks in 10 ms, so 0.1 s keeps its resolution error within 10 %. Shorter runs report no rate.
const MIN_CPU_S: f64 = 0.1;

/// Millions of `work` items per CPU second, or `None` when `cpu_s` is too short to measure.
fn per_cpu_second(work: f64, cpu_s: f64) -> Option<f64> {
    (cpu_s >= MIN_CPU_S).then(|| work / cpu_s / 1e6)
}

/// A rate with `digits` decimals, or "n/a" when it was not measured.
fn fmt_rate(rate: Option<f64>, digits: usize) -> String {
    match rate {
        Some(r) if r.is_finite() => format!("{r:.digits$}"),
        _ => "n/a".to_string(),
    }
}

fn bench_in_pool(args: &Args) -> Result<()> {
    let path = match &args.mesh {
        Some(p) => p.clone(),
        None => default_mesh()?,
    };
    let meshes = TriangleMesh::load(&path)?;
    let shapes: Vec<Shape> = meshes.into_iter().map(|(_, m)| Shape::Mesh(m)).collect();
    let triangles: usize = shapes.iter().map(Shape::primitive_count).sum();
    let threads = rayon::current_num_threads();

    let mut build_s = f64::INFINITY;
    let mut accel = None;
    for _ in 0..3 {
        let s = shapes.clone();
        let t0 = Instant::now();
        let a = Accel::build(s);
        build_s = build_s.min(t0.elapsed().as_secs_f64());
        accel = Some(a);
    }
    let accel = accel.expect("built at least once");

    let size = args.size;
    trace_camera(&accel, size.min(256)); // warm-up
    let mut camera_best = 0.0f64;
    let mut camera_hits = 0;
    let cpu0 = cpu_seconds();
    for _ in 0..args.reps {
        let t0 = Instant::now();
        camera_hits = trace_camera(&accel, size);
        let mr = (size as f64 * size as f64) / t0.elapsed().as_secs_f64() / 1e6;
        camera_best = camera_best.max(mr);
    }

    let camera_cpu = per_cpu_second(size as f64 * size as f64 * args.reps as f64, cpu_seconds() - cpu0);
    let mut camera_batched = 0.0f64;
    let cpu0 = cpu_seconds();
    for _ in 0..args.reps {
        let t0 = Instant::now();
        let h = trace_camera_batched(&accel, size);
        camera_batched = camera_batched.max((size as f64 * size as f64) / t0.elapsed().as_secs_f64() / 1e6);
        if h != camera_hits {
            bail!("internal error: batched traversal found {h} hits, single-ray {camera_hits}");
        }
    }
    let camera_batched_cpu = per_cpu_second(size as f64 * size as f64 * args.reps as f64, cpu_seconds() - cpu0);
    let mut camera_packet = 0.0f64;
    let cpu0 = cpu_seconds();
    for _ in 0..args.reps {
        let t0 = Instant::now();
        let h = trace_camera_packets(&accel, size);
        camera_packet = camera_packet.max((size as f64 * size as f64) / t0.elapsed().as_secs_f64() / 1e6);
        if h != camera_hits {
            bail!("internal error: packet traversal found {h} hits, single-ray {camera_hits}");
        }
    }
    let camera_packet_cpu = per_cpu_second(size as f64 * size as f64 * args.reps as f64, cpu_seconds() - cpu0);
    let n = (args.mrays * 1e6) as usize;
    let rays = incoherent_rays(&accel, n.max(1), 0x5EED);
    trace_all(&accel, &rays[..rays.len().min(65536)]); // warm-up
    let mut incoherent_best = 0.0f64;
    let mut incoherent_hits = 0;
    let cpu0 = cpu_seconds();
    for _ in 0..args.reps {
        let t0 = Instant::now();
        incoherent_hits = trace_all(&accel, &rays);
        let mr = rays.len() as f64 / t0.elapsed().as_secs_f64() / 1e6;
        incoherent_best = incoherent_best.max(mr);
    }

    let incoherent_cpu = per_cpu_second(rays.len() as f64 * args.reps as f64, cpu_seconds() - cpu0);
    let mut batched_best = 0.0f64;
    let cpu0 = cpu_seconds();
    for _ in 0..args.reps {
        let t0 = Instant::now();
        let h = trace_all_batched(&accel, &rays);
        let mr = rays.len() as f64 / t0.elapsed().as_secs_f64() / 1e6;
        batched_best = batched_best.max(mr);
        if h != incoherent_hits {
            bail!("internal error: batched traversal found {h} hits, single-ray {incoherent_hits}");
        }
    }
    let batched_cpu = per_cpu_second(rays.len() as f64 * args.reps as f64, cpu_seconds() - cpu0);
    let cornell_run = |seconds: f64| -> Option<(f64, Option<f64>)> {
        match render::bench::benchmark_cornell_clocked(256, 256, seconds, cpu_seconds) {
            // A per-CPU-second rate over too short a CPU time is not a measurement (NaN from the library).
            Ok((wall, cpu)) => Some((wall, cpu.is_finite().then_some(cpu))),
            Err(e) => {
                if !args.json {
                    eprintln!("lucent: note: Cornell box benchmark unavailable: {e:#}");
                }
                None
            }
        }
    };
    let cornell = if args.cornell_seconds > 0.0 { cornell_run(args.cornell_seconds) } else { None };
    // Thread scaling: the same Cornell benchmark on one thread, in this run.
    let cornell_1 = if args.scaling && args.cornell_seconds > 0.0 && threads > 1 {
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().context("cannot start a one-thread pool")?;
        one.install(|| cornell_run(args.cornell_seconds))
    } else {
        None
    };
    let speedup = match (cornell, cornell_1) {
        (Some((n, _)), Some((one, _))) => Some(n / one),
        _ => None,
    };

    if args.json {
        let v = serde_json::json!({
            "bvh_build_s": build_s,
            "camera_mrays_per_s": camera_best.max(camera_batched).max(camera_packet),
            "camera_packet_mrays_per_s": camera_packet,
            "camera_packet_mrays_per_cpu_s": camera_packet_cpu,
            "incoherent_mrays_per_s": incoherent_best.max(batched_best),
            "camera_single_mrays_per_s": camera_best,
            "incoherent_single_mrays_per_s": incoherent_best,
            "cornell_msamples_per_s": cornell.map(|c| c.0),
            "cornell_msamples_per_cpu_s": cornell.and_then(|c| c.1),
            "cornell_msamples_per_s_1_thread": cornell_1.map(|c| c.0),
            "cornell_thread_speedup": speedup,
            "threads": threads,
            "mesh": path.display().to_string(),
            "triangles": triangles,
            "bvh_nodes": accel.node_count(),
            "camera_hit_fraction": camera_hits as f64 / (size as f64 * size as f64),
            "incoherent_hit_fraction": incoherent_hits as f64 / rays.len() as f64,
            "camera_mrays_per_cpu_s": camera_cpu,
            "incoherent_batched_mrays_per_s": batched_best,
            "camera_batched_mrays_per_s": camera_batched,
            "incoherent_mrays_per_cpu_s": incoherent_cpu,
            "camera_batched_mrays_per_cpu_s": camera_batched_cpu,
            "incoherent_batched_mrays_per_cpu_s": batched_cpu,
        });
        println!("{v}");
    } else {
        println!("mesh            {} ({} triangles, {} BVH nodes)", path.display(), triangles, accel.node_count());
        println!("threads         {threads}");
        println!("BVH build       {:.3} s (best of 3)", build_s);
        println!(
            "camera rays     {:.2} Mrays/s ({}×{}, {:.1}% hit, best of {})",
            camera_best,
            size,
            size,
            100.0 * camera_hits as f64 / (size as f64 * size as f64),
            args.reps
        );
        println!(
            "incoherent rays {:.2} Mrays/s ({} rays, {:.1}% hit, best of {})",
            incoherent_best,
            rays.len(),
            100.0 * incoherent_hits as f64 / rays.len() as f64,
            args.reps
        );
        println!("camera rays     {camera_batched:.2} Mrays/s batched (Accel::intersect_batch, 8 rays interleaved)");
        println!("incoherent rays {batched_best:.2} Mrays/s batched (Accel::intersect_batch, 8 rays interleaved)");
        println!("camera rays     {camera_packet:.2} Mrays/s in 4×4 packets (Accel::intersect_packet), {} per CPU second", fmt_rate(camera_packet_cpu, 2));
        println!(
            "per CPU second  camera {}, incoherent {} Mrays/s single; {}, {} batched (mean, /proc/self/stat)",
            fmt_rate(camera_cpu, 2),
            fmt_rate(incoherent_cpu, 2),
            fmt_rate(camera_batched_cpu, 2),
            fmt_rate(batched_cpu, 2)
        );
        match cornell {
            Some((v, c)) => println!("Cornell box     {v:.3} Msamples/s (path, 256×256), {} per CPU second", fmt_rate(c, 3)),
            None => println!("Cornell box     n/a"),
        }
        if let (Some((one, _)), Some(x)) = (cornell_1, speedup) {
            println!("Cornell box     {one:.3} Msamples/s on 1 thread: speed-up {x:.2}× on {threads} threads");
        }
    }
    Ok(())
}
