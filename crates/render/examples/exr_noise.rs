//! Noise of a render from its `variance` AOV (`lucent render --aov variance --out x.exr`):
//! per pixel the relative standard error of the luminance, √Var(Ȳ)/Ȳ with
//! Y = 0.2126 R + 0.7152 G + 0.0722 B and Var(Ȳ) from the per-channel variances of the pixel
//! mean (channel covariances ignored), over pixels with Ȳ above 1 % of the image mean.
//!
//! usage: cargo run --release -p render --example exr_noise -- RENDER.exr
//! prints the median and the 90th percentile of that relative error, and the image mean.

fn main() {
    let path = std::env::args().nth(1).expect("usage: exr_noise RENDER.exr");
    let (_, _, channels, _) = render::image_io::read_exr_channels(std::path::Path::new(&path)).unwrap_or_else(|e| {
        eprintln!("exr_noise: {e:#}");
        std::process::exit(1)
    });
    let get = |name: &str| -> &Vec<f32> {
        &channels.iter().find(|(n, _)| n == name).unwrap_or_else(|| {
            eprintln!("exr_noise: {path} has no channel {name} (render with --aov variance)");
            std::process::exit(1)
        }).1
    };
    let (r, g, b) = (get("R"), get("G"), get("B"));
    let (vr, vg, vb) = (get("variance.R"), get("variance.G"), get("variance.B"));
    let w = [0.2126f64, 0.7152, 0.0722];
    let y: Vec<f64> = (0..r.len()).map(|i| w[0] * r[i] as f64 + w[1] * g[i] as f64 + w[2] * b[i] as f64).collect();
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let mut rel: Vec<f64> = (0..r.len())
        .filter(|&i| y[i] > 0.01 * mean)
        .map(|i| (w[0] * w[0] * vr[i] as f64 + w[1] * w[1] * vg[i] as f64 + w[2] * w[2] * vb[i] as f64).sqrt() / y[i])
        .collect();
    rel.sort_by(f64::total_cmp);
    let q = |p: f64| rel[((rel.len() - 1) as f64 * p).round() as usize];
    println!("{path}: relative standard error of the pixel luminance: median {:.2} %, 90th percentile {:.2} % ({} pixels); image mean Y {:.4}", 100.0 * q(0.5), 100.0 * q(0.9), rel.len(), mean);
}
