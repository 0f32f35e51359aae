//! Criterion benchmarks of Lorenz–Mie theory and the milk spectrum (`cargo bench -p optics --bench mie`).
//! Targets (README "Performance"): Q's and g at m = 1.5+0.01i in 1.5 µs (x = 10), 3.5 µs (x = 100), 30 µs (x = 1000)
//! on one core; the 17-wavelength milk spectrum in under 10 ms on 2 cores.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use optics::media::{self, BulkOptions};
use optics::mie::{Complex64, MieWorkspace};
use optics::milk;

fn mie_efficiencies(c: &mut Criterion) {
    let mut g = c.benchmark_group("mie_efficiencies");
    let m = Complex64::new(1.5, 0.01);
    let mut ws = MieWorkspace::new();
    for x in [10.0, 100.0, 1000.0, 10000.0] {
        g.bench_with_input(BenchmarkId::from_parameter(x), &x, |b, &x| b.iter(|| ws.efficiencies(black_box(x), black_box(m))));
    }
    g.finish();
}

fn mie_absorbing_host(c: &mut Criterion) {
    let mut g = c.benchmark_group("mie_absorbing_host");
    let mut ws = MieWorkspace::new();
    let np = Complex64::new(1.46, 1e-5);
    for (name, nh) in [("weak", Complex64::new(1.33, 1e-7)), ("strong", Complex64::new(1.33, 0.05))] {
        g.bench_function(name, |b| b.iter(|| ws.sphere(black_box(2e-6), black_box(500e-9), np, nh)));
    }
    g.finish();
}

fn milk_spectrum(c: &mut Criterion) {
    let lambda = media::parse_wavelengths_nm("375:775:25").unwrap();
    let mut g = c.benchmark_group("milk_spectrum");
    g.sample_size(20);
    g.bench_function("17_wavelengths", |b| {
        b.iter(|| milk::milk_properties_with(3.5, 3.4, 20.0, black_box(&lambda), &BulkOptions { phase_angles: 0 }).unwrap())
    });
    g.bench_function("17_wavelengths_with_phase", |b| {
        b.iter(|| milk::milk_properties_with(3.5, 3.4, 20.0, black_box(&lambda), &BulkOptions { phase_angles: 181 }).unwrap())
    });
    g.finish();
}

criterion_group!(benches, mie_efficiencies, mie_absorbing_host, milk_spectrum);
criterion_main!(benches);
