//! Profiling aid: BVH work per ray (wide nodes visited, 4-triangle packets tested) for random
//! rays from random points inside the built-in Cornell box.
//! `cargo run --release -p render --example cornell_rays`
use render::math::geometry::Ray;
use render::math::sampling::Pcg32;
use render::scene::Scene;

fn main() {
    let scene = Scene::cornell_box();
    let b = scene.accel.bounds();
    let mut rng = Pcg32::for_pixel(1, 0, 0);
    let (mut nodes, mut packets, mut hits) = (0u64, 0u64, 0u64);
    let n = 200_000;
    for _ in 0..n {
        let o = b.min + (b.max - b.min) * glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let z = 2.0 * rng.next_f32() - 1.0;
        let phi = std::f32::consts::TAU * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let d = glam::Vec3::new(r * phi.cos(), r * phi.sin(), z);
        let ray = Ray { o, d, t_min: 0.0, t_max: f32::INFINITY };
        let (h, c) = scene.accel.intersect_counting(&ray);
        nodes += c[0] as u64;
        packets += c[1] as u64;
        hits += h.is_some() as u64;
    }
    println!("nodes {} packets {} per ray; hit fraction {:.3}; tree nodes {}", nodes as f64 / n as f64, packets as f64 / n as f64, hits as f64 / n as f64, scene.accel.node_count());
}
