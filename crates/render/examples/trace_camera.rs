//! Profiling aid: trace the benchmark's camera rays on one thread, one way, so one traversal
//! kind can be timed or profiled alone.
//! `cargo run --release -p render --example trace_camera -- MESH single|4|16 [SIZE]`
use render::bench::BenchCamera;
use render::accel::Accel;
use render::shape::Shape;
use render::shape::mesh::TriangleMesh;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mesh = args.get(1).expect("usage: trace_camera MESH single|4|16 [SIZE]");
    let mode = args.get(2).map(String::as_str).unwrap_or("single");
    let size: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1024);
    let shapes: Vec<Shape> = TriangleMesh::load(std::path::Path::new(mesh)).expect("mesh").into_iter().map(|(_, m)| Shape::Mesh(m)).collect();
    let accel = Accel::build(shapes);
    let cam = BenchCamera::new(&accel);
    let t0 = std::time::Instant::now();
    let mut hits = 0u64;
    let mut out = [None; 16];
    for _ in 0..3 {
        for j in (0..size).step_by(4) {
            for i in (0..size).step_by(4) {
                let rays = cam.block(i, j, size);
                match mode {
                    "16" => accel.intersect_packet(&rays, &mut out),
                    "4" => {
                        for q in 0..4 {
                            accel.intersect_packet(&rays[4 * q..4 * q + 4], &mut out[4 * q..4 * q + 4]);
                        }
                    }
                    _ => {
                        for (r, h) in rays.iter().zip(out.iter_mut()) {
                            *h = accel.intersect(r);
                        }
                    }
                }
                hits += out.iter().filter(|h| h.is_some()).count() as u64;
            }
        }
    }
    let dt = t0.elapsed().as_secs_f64();
    println!("{mode}: {hits} hits, {:.2} Mrays/s (one thread, tracing only)", 3.0 * (size * size) as f64 / dt / 1e6);
}
