//! Criterion benchmarks of the ray kernels on the bundled 48k-triangle dragon: BVH build,
//! camera rays (pinhole outside the box looking at its centre; one by one and in 4×4 packets), incoherent closest-hit rays
//! (origins uniform in the box, directions uniform on the sphere) and shadow (any-hit) rays.
//! `lucent bench` reports the same kernels as Mrays/s.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use render::bench_rays::{incoherent_rays, BenchCamera};
use render::bvh::{Accel, Shape};
use render::geometry::Ray;
use render::mesh::TriangleMesh;
use std::hint::black_box;
use std::path::Path;

fn dragon() -> Vec<Shape> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/dragon-48k.ply");
    TriangleMesh::load(&p).expect("bundled dragon").into_iter().map(|(_, m)| Shape::Mesh(m)).collect()
}

fn camera(accel: &Accel, size: u32) -> Vec<Ray> {
    let cam = BenchCamera::new(accel);
    (0..size).flat_map(|j| (0..size).map(move |i| cam.ray(i, j, size))).collect()
}

fn benches(c: &mut Criterion) {
    let shapes = dragon();
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    g.bench_function("build_dragon_48k", |b| b.iter_batched(|| shapes.clone(), |s| black_box(Accel::build(s)), BatchSize::LargeInput));
    let accel = Accel::build(shapes);

    let cam = camera(&accel, 256);
    g.throughput(Throughput::Elements(cam.len() as u64));
    g.bench_function("camera_rays_256x256", |b| b.iter(|| cam.iter().filter(|r| accel.intersect(r).is_some()).count()));
    let bc = BenchCamera::new(&accel);
    let blocks: Vec<[Ray; 16]> = (0..256).step_by(4).flat_map(|j| (0..256).step_by(4).map(move |i| bc.block(i, j, 256))).collect();
    let mut out = [None; 16];
    g.bench_function("camera_rays_256x256_packets_4x4", |b| {
        b.iter(|| {
            blocks
                .iter()
                .map(|rays| {
                    accel.intersect_packet(rays, &mut out);
                    out.iter().filter(|h| h.is_some()).count()
                })
                .sum::<usize>()
        })
    });

    let inc = incoherent_rays(&accel, 65536, 7);
    g.throughput(Throughput::Elements(inc.len() as u64));
    g.bench_function("incoherent_closest_64k", |b| b.iter(|| inc.iter().filter(|r| accel.intersect(r).is_some()).count()));
    let mut hits = vec![None; inc.len()];
    g.bench_function("incoherent_closest_batch_64k", |b| {
        b.iter(|| {
            accel.intersect_batch(&inc, &mut hits);
            hits.iter().filter(|h| h.is_some()).count()
        })
    });

    // Shadow rays: the same rays limited to a quarter of the box diagonal.
    let reach = 0.25 * accel.bounds().extent().length();
    let shadow: Vec<Ray> = inc.iter().map(|r| Ray { t_max: reach, ..*r }).collect();
    g.bench_function("incoherent_occluded_64k", |b| b.iter(|| shadow.iter().filter(|r| accel.occluded(r)).count()));
    g.finish();
}

criterion_group!(render_benches, benches);
criterion_main!(render_benches);
