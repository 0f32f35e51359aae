//! Criterion benchmarks of the ray kernels on the bundled 48k-triangle dragon: BVH build,
//! camera rays (pinhole outside the box looking at its centre; one by one and in 4×4 packets), incoherent closest-hit rays
//! (origins uniform in the box, directions uniform on the sphere) and shadow (any-hit) rays.
//! `lucent bench` reports the same kernels as Mrays/s.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use render::bench::{incoherent_rays, BenchCamera};
use render::accel::Accel;
use render::shape::Shape;
use render::math::geometry::Ray;
use render::shape::mesh::TriangleMesh;
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

/// S_d of the line-source directional dipole for four wavelengths (marble, Jensen et al. 2001,
/// at 450/500/550/650 nm-like coefficients) on exit points around an entry point on a plane:
/// the reference `optics` model (f64, one lane at a time) against the packed f32 evaluator the
/// point-cloud queries use.
fn subsurface(c: &mut Criterion) {
    use glam::Vec3;
    use optics::bssrdf::{DirectionalLineDipole, OpticalProperties};
    use render::integrator::subsurface::line_dipole4::{refract_in, LineDipole4};
    let lanes: Vec<DirectionalLineDipole> = [(3000.0, 7.1), (2800.0, 5.5), (2620.0, 4.1), (2190.0, 2.1)]
        .iter()
        .map(|&(s, a)| {
            DirectionalLineDipole::new(&OpticalProperties { eta: 1.5, sigma_s_per_m: s, sigma_a_per_m: a, g: 0.0 })
                .expect("marble")
        })
        .collect();
    let packed = LineDipole4::new([Some(&lanes[0]), Some(&lanes[1]), Some(&lanes[2]), Some(&lanes[3])]);
    let n = Vec3::Z;
    let w12 = refract_in(Vec3::new(0.3, 0.1, 0.95).normalize(), n, 1.5);
    let exits: Vec<Vec3> = (0..1024)
        .map(|i| {
            let r = 4e-3 * ((i as f32 + 0.5) / 1024.0).sqrt();
            let phi = i as f32 * 2.399_963;
            Vec3::new(r * phi.cos(), r * phi.sin(), 0.0)
        })
        .collect();
    let mut g = c.benchmark_group("subsurface");
    g.throughput(Throughput::Elements(exits.len() as u64));
    g.bench_function("sd_line_dipole_reference_4_lanes", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for xo in &exits {
                for m in &lanes {
                    s += m.sd_refracted([0.0; 3], [0.0, 0.0, 1.0], [w12.x as f64, w12.y as f64, w12.z as f64], [xo.x as f64, xo.y as f64, 0.0], [0.0, 0.0, 1.0]);
                }
            }
            black_box(s)
        })
    });
    g.bench_function("sd_line_dipole_packed_4_lanes", |b| {
        b.iter(|| exits.iter().map(|&xo| packed.sd_refracted(Vec3::ZERO, n, w12, xo, n)).sum::<glam::Vec4>())
    });
    g.finish();
}

criterion_group!(render_benches, benches, subsurface);
criterion_main!(render_benches);
