//! `lucent bench mie`: Lorenz–Mie timings (one thread) and the 17-wavelength milk spectrum (all threads).

use optics::media::{self, BulkOptions};
use optics::mie::{Complex64, MieWorkspace};
use optics::milk;
use serde_json::json;
use std::hint::black_box;
use std::time::{Duration, Instant};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Seconds spent on each measurement (default 0.5).
    #[arg(long, default_value_t = 0.5)]
    pub seconds: f64,
}

/// CPU time of the calling thread, seconds (Linux `/proc/thread-self/schedstat`), if available.
fn thread_cpu_s() -> Option<f64> {
    let t = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(t.split_whitespace().next()?.parse::<f64>().ok()? * 1e-9)
}

/// CPU time (user + system) of the whole process, seconds (Linux `/proc/self/stat`, 100 Hz ticks).
fn process_cpu_s() -> Option<f64> {
    let t = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &t[t.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

struct Timing {
    /// Smallest wall-clock time per call over batches, s.
    wall_s: f64,
    /// CPU time per call (thread or process, as asked), s, when the OS reports it.
    cpu_s: Option<f64>,
}

/// Time `f` for about `seconds`: batches of ≥ 2 ms; best wall time per call, and CPU time per call
/// over the whole run (robust when other processes share the cores).
fn time_per_call(seconds: f64, thread_only: bool, mut f: impl FnMut()) -> Timing {
    let cpu = || if thread_only { thread_cpu_s() } else { process_cpu_s() };
    let mut batch = 1usize;
    loop {
        let t = Instant::now();
        for _ in 0..batch {
            f();
        }
        if t.elapsed() > Duration::from_millis(2) || batch > 1 << 30 {
            break;
        }
        batch *= 2;
    }
    let mut best = f64::INFINITY;
    let mut calls = 0usize;
    let c0 = cpu();
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < seconds || calls < 5 * batch {
        let t = Instant::now();
        for _ in 0..batch {
            f();
        }
        best = best.min(t.elapsed().as_secs_f64() / batch as f64);
        calls += batch;
    }
    let cpu_s = match (c0, cpu()) {
        (Some(a), Some(b)) if b > a => Some((b - a) / calls as f64),
        _ => None,
    };
    Timing { wall_s: best, cpu_s }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !(args.seconds.is_finite() && args.seconds > 0.0 && args.seconds <= 600.0) {
        anyhow::bail!("--seconds must lie in (0, 600], got {}", args.seconds);
    }
    let m = Complex64::new(1.5, 0.01);
    let mut ws = MieWorkspace::new();
    let mut mie_us = vec![];
    let mut mie_wall_us = vec![];
    for x in [10.0, 100.0, 1000.0] {
        let t = time_per_call(args.seconds, true, || {
            black_box(ws.efficiencies(black_box(x), black_box(m)));
        });
        // One thread: its CPU time per call is the cost, whatever else runs on the machine.
        mie_us.push(t.cpu_s.unwrap_or(t.wall_s).min(t.wall_s) * 1e6);
        mie_wall_us.push(t.wall_s * 1e6);
    }
    let lambda = media::parse_wavelengths_nm("375:775:25")?;
    let milk = time_per_call(args.seconds, false, || {
        black_box(milk::milk_properties_with(3.5, 3.4, 20.0, &lambda, &BulkOptions { phase_angles: 0 }).expect("milk"));
    });
    let milk_phase = time_per_call(args.seconds, false, || {
        black_box(milk::milk_properties_with(3.5, 3.4, 20.0, &lambda, &BulkOptions { phase_angles: 181 }).expect("milk"));
    });
    let threads = rayon::current_num_threads();
    let milk_t = milk.wall_s;
    let milk_phase_t = milk_phase.wall_s;
    let milk_cpu_ms = milk.cpu_s.map(|c| c * 1e3);
    if args.json {
        println!(
            "{}",
            json!({
                "mie_us_x10": mie_us[0],
                "mie_us_x100": mie_us[1],
                "mie_us_x1000": mie_us[2],
                "milk_spectrum_ms": milk_t * 1e3,
                "milk_spectrum_with_phase_ms": milk_phase_t * 1e3,
                "milk_spectrum_cpu_ms": milk_cpu_ms,
                "mie_wall_us": mie_wall_us,
                "threads": threads,
                "m": [m.re, m.im],
            })
        );
    } else {
        println!("Lorenz-Mie, m = 1.5+0.01i, Q's and g, one thread (thread CPU time per call):");
        for (x, t) in [10, 100, 1000].iter().zip(&mie_us) {
            println!("  x = {x:>5}: {t:>9.3} µs");
        }
        println!("milk spectrum (3.5 % fat, 3.4 % protein, 20 MPa, 17 wavelengths, {threads} threads):");
        println!("  sigma_s, sigma_a, g:          {:>8.3} ms", milk_t * 1e3);
        println!("  plus 181-angle phase tables:  {:>8.3} ms", milk_phase_t * 1e3);
        if let Some(c) = milk_cpu_ms {
            println!("  CPU time, all threads:        {c:>8.3} ms");
        }
    }
    Ok(())
}
