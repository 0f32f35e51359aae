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

/// Best (smallest) batch time per call, in seconds: robust when other processes share the cores.
fn time_per_call(seconds: f64, mut f: impl FnMut()) -> f64 {
    // calibrate a batch of about 10 ms
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
    let mut samples = vec![];
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < seconds || samples.len() < 5 {
        let t = Instant::now();
        for _ in 0..batch {
            f();
        }
        samples.push(t.elapsed().as_secs_f64() / batch as f64);
    }
    samples.iter().cloned().fold(f64::INFINITY, f64::min)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !(args.seconds.is_finite() && args.seconds > 0.0 && args.seconds <= 600.0) {
        anyhow::bail!("--seconds must lie in (0, 600], got {}", args.seconds);
    }
    let m = Complex64::new(1.5, 0.01);
    let mut ws = MieWorkspace::new();
    let mut mie_us = vec![];
    for x in [10.0, 100.0, 1000.0] {
        let t = time_per_call(args.seconds, || {
            black_box(ws.efficiencies(black_box(x), black_box(m)));
        });
        mie_us.push(t * 1e6);
    }
    let lambda = media::parse_wavelengths_nm("375:775:25")?;
    let milk_t = time_per_call(args.seconds, || {
        black_box(milk::milk_properties_with(3.5, 3.4, 20.0, &lambda, &BulkOptions { phase_angles: 0 }).expect("milk"));
    });
    let milk_phase_t = time_per_call(args.seconds, || {
        black_box(milk::milk_properties_with(3.5, 3.4, 20.0, &lambda, &BulkOptions { phase_angles: 181 }).expect("milk"));
    });
    let threads = rayon::current_num_threads();
    if args.json {
        println!(
            "{}",
            json!({
                "mie_us_x10": mie_us[0],
                "mie_us_x100": mie_us[1],
                "mie_us_x1000": mie_us[2],
                "milk_spectrum_ms": milk_t * 1e3,
                "milk_spectrum_with_phase_ms": milk_phase_t * 1e3,
                "threads": threads,
                "m": [m.re, m.im],
            })
        );
    } else {
        println!("Lorenz-Mie, m = 1.5+0.01i, Q's and g, one thread:");
        for (x, t) in [10, 100, 1000].iter().zip(&mie_us) {
            println!("  x = {x:>5}: {t:>9.3} µs");
        }
        println!("milk spectrum (3.5 % fat, 3.4 % protein, 20 MPa, 17 wavelengths, {threads} threads):");
        println!("  sigma_s, sigma_a, g:          {:>8.3} ms", milk_t * 1e3);
        println!("  plus 181-angle phase tables:  {:>8.3} ms", milk_phase_t * 1e3);
    }
    Ok(())
}
