//! Criterion benchmarks of the ray kernels on the bundled 48k-triangle dragon: BVH build,
//! camera rays (pinhole outside the box looking at its centre), incoherent closest-hit rays
//! (origins uniform in the box, directions uniform on the sphere) and shadow (any-hit) rays.
//! `lucent bench` reports the same kernels as Mrays/s.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use glam::Vec3;
use render::bvh::{Accel, Shape};
use render::geometry::Ray;
use render::mesh::TriangleMesh;
use std::hint::black_box;
use std::path::Path;

fn dragon() -> Vec<Shape> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/dragon-48k.ply");
    TriangleMesh::load(&p).expect("bundled dragon").into_iter().map(|(_, m)| Shape::Mesh(m)).collect()
}

struct Rng(u64);
impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn incoherent(accel: &Accel, n: usize) -> Vec<Ray> {
    let b = accel.bounds();
    let mut rng = Rng(7);
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

fn camera(accel: &Accel, size: u32) -> Vec<Ray> {
    let b = accel.bounds();
    let c = b.center();
    let radius = 0.5 * b.extent().length();
    let dir = Vec3::new(-0.4, -0.3, -1.0).normalize();
    let half = 20f32.to_radians();
    let eye = c - dir * (radius / half.sin());
    let right = dir.cross(Vec3::Y).normalize() * half.tan();
    let up = right.cross(dir).normalize() * half.tan();
    let mut rays = Vec::with_capacity((size * size) as usize);
    for j in 0..size {
        for i in 0..size {
            let x = 2.0 * ((i as f32 + 0.5) / size as f32) - 1.0;
            let y = 1.0 - 2.0 * ((j as f32 + 0.5) / size as f32);
            rays.push(Ray::new(eye, dir + x * right + y * up));
        }
    }
    rays
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

    let inc = incoherent(&accel, 65536);
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
