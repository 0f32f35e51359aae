//! Driver for profiling Lorenz–Mie (`valgrind --tool=callgrind`, or wall time):
//! `cargo run --release -p optics --example mie_time -- X REPS` evaluates Q's and g for
//! m = 1.5+0.01i at size parameter X, REPS times, and prints the result and the time per call
//! (the best of 200 batches of REPS/200 calls, robust when other processes share the cores).

use optics::mie::{Complex64, MieWorkspace};
use std::hint::black_box;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let x: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1000.0);
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let m = Complex64::new(1.5, 0.01);
    let mut ws = MieWorkspace::new();
    let mut e = ws.efficiencies(x, m);
    let batch = (reps / 200).max(1);
    let mut best = f64::INFINITY;
    for _ in 0..200 {
        let t = Instant::now();
        for _ in 0..batch {
            e = ws.efficiencies(black_box(x), black_box(m));
        }
        best = best.min(t.elapsed().as_secs_f64() / batch as f64);
    }
    let us = best * 1e6;
    println!("x = {x}: qext {:.15e} qsca {:.15e} qback {:.15e} g {:.15e}; {us:.3} µs per call", e.qext, e.qsca, e.qback, e.g);
}
