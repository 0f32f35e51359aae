//! `lucent bench` (rays and path tracing) and `lucent bench mie`.
//!
//! The ray benchmark loads a mesh (default: the bundled 48k-triangle dragon), builds the BVH and
//! times closest-hit queries for camera rays (a pinhole outside the bounding box looking at its
//! centre, one ray per pixel) and incoherent rays (origins uniform in the bounding box,
//! directions uniform on the sphere). Each figure is the best of several repetitions.

use anyhow::{bail, Context, Result};
use glam::Vec3;
use rayon::prelude::*;
use render::bvh::{Accel, Shape};
use render::geometry::Ray;
use render::mesh::TriangleMesh;
use std::path::{Path, PathBuf};
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
    /// Seconds of Cornell-box path tracing.
    #[arg(long, default_value_t = 3.0)]
    pub cornell_seconds: f64,
}

#[derive(clap::Subcommand, Debug)]
pub enum Which {
    /// Lorenz-Mie and milk-spectrum timings.
    Mie(super::bench_mie::Args),
}

pub fn run(args: Args) -> Result<()> {
    match args.which {
        Some(Which::Mie(a)) => super::bench_mie::run(a),
        None => run_rays(&args),
    }
}

/// The bundled default mesh, looked up from the current directory, then from the source tree.
fn default_mesh() -> Result<PathBuf> {
    let rel = Path::new("data/meshes/dragon-48k.ply");
    if rel.exists() {
        return Ok(rel.to_path_buf());
    }
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/dragon-48k.ply");
    if src.exists() {
        return Ok(src);
    }
    bail!("default mesh data/meshes/dragon-48k.ply not found (run from the repository root or pass --mesh FILE)")
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

/// Small deterministic generator (SplitMix64) for the ray sets.
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// Incoherent rays: origins uniform in the box, directions uniform on the unit sphere.
pub fn incoherent_rays(accel: &Accel, n: usize, seed: u64) -> Vec<Ray> {
    let b = accel.bounds();
    let mut rng = SplitMix(seed);
    (0..n)
        .map(|_| {
            let o = b.min + b.extent() * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let z = 1.0 - 2.0 * rng.f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * rng.f32();
            Ray::new(o, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

/// Camera of the camera-ray benchmark: eye outside the box looking at its centre, 40° field of view.
fn camera(accel: &Accel) -> (Vec3, Vec3, Vec3, Vec3) {
    let b = accel.bounds();
    let c = b.center();
    let radius = 0.5 * b.extent().length();
    let dir = Vec3::new(-0.4, -0.3, -1.0).normalize();
    let half = 20f32.to_radians();
    let eye = c - dir * (radius / half.sin()).max(radius * 1.01);
    let right = dir.cross(Vec3::Y).normalize();
    let up = right.cross(dir);
    (eye, dir, right * half.tan(), up * half.tan())
}

fn trace_camera(accel: &Accel, size: u32) -> u64 {
    let (eye, dir, right, up) = camera(accel);
    let inv = 1.0 / size as f32;
    (0..size)
        .into_par_iter()
        .map(|j| {
            let mut hits = 0u64;
            for i in 0..size {
                let x = 2.0 * ((i as f32 + 0.5) * inv) - 1.0;
                let y = 1.0 - 2.0 * ((j as f32 + 0.5) * inv);
                let ray = Ray::new(eye, dir + x * right + y * up);
                hits += accel.intersect(&ray).is_some() as u64;
            }
            hits
        })
        .sum()
}

fn trace_all(accel: &Accel, rays: &[Ray]) -> u64 {
    rays.par_chunks(1024).map(|ch| ch.iter().filter(|r| accel.intersect(r).is_some()).count() as u64).sum()
}

/// CPU time (user + system) of this process so far, seconds, from /proc/self/stat (Linux; 0 elsewhere).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15 (1-based).
    let Some(rest) = stat.rfind(')').map(|i| &stat[i + 1..]) else { return 0.0 };
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
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

    let camera_cpu = (size as f64 * size as f64 * args.reps as f64) / (cpu_seconds() - cpu0) / 1e6;
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

    let incoherent_cpu = (rays.len() as f64 * args.reps as f64) / (cpu_seconds() - cpu0) / 1e6;
    let cornell = if args.cornell_seconds > 0.0 {
        match render::integrator::benchmark_cornell(256, 256, args.cornell_seconds) {
            Ok(v) => Some(v),
            Err(e) => {
                if !args.json {
                    eprintln!("lucent: note: Cornell box benchmark unavailable: {e:#}");
                }
                None
            }
        }
    } else {
        None
    };

    if args.json {
        let v = serde_json::json!({
            "bvh_build_s": build_s,
            "camera_mrays_per_s": camera_best,
            "incoherent_mrays_per_s": incoherent_best,
            "cornell_msamples_per_s": cornell,
            "threads": threads,
            "mesh": path.display().to_string(),
            "triangles": triangles,
            "bvh_nodes": accel.node_count(),
            "camera_hit_fraction": camera_hits as f64 / (size as f64 * size as f64),
            "incoherent_hit_fraction": incoherent_hits as f64 / rays.len() as f64,
            "camera_mrays_per_cpu_s": camera_cpu,
            "incoherent_mrays_per_cpu_s": incoherent_cpu,
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
        println!("per CPU second  camera {camera_cpu:.2}, incoherent {incoherent_cpu:.2} Mrays/s (mean, /proc/self/stat)");
        match cornell {
            Some(v) => println!("Cornell box     {v:.3} Msamples/s (path, 256×256)"),
            None => println!("Cornell box     n/a"),
        }
    }
    Ok(())
}
