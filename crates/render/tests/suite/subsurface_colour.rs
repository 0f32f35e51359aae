//! Wavelength sets of the point-cloud BSSRDF: with one set per pass every path of a pass shares
//! four hero wavelengths, so each pass tints the whole image; with K interleaved sets (pixels
//! choosing among them) the mean colour of a uniform backdrop varies between seeds only as much
//! as its pixel noise says, and the expected image is the same.

use crate::common;
use render::integrator::subsurface::SubsurfacePass;
use render::scene::Scene;

const W: u32 = 48;
const H: u32 = 32;

/// A marble-like translucent sphere in front of a grey wall, lit by a 3200 K blackbody area
/// light; `sets` wavelength sets per pass, 256 points per pass.
fn scene(sets: u32) -> Scene {
    let text = format!(
        r#"unit = "mm"
[camera]
eye = [0, 0, -300]
look_at = [0, 0, 0]
vfov_deg = 30
width = {W}
height = {H}

[integrator]
type = "path"
max_depth = 6

[spectra.lamp]
blackbody = 3200

[materials.marble]
type = "translucent"
ior = 1.5
subsurface = {{ model = "directional", sigma_s_per_mm = [2.2, 2.6, 3.0], sigma_a_per_mm = [0.002, 0.004, 0.007], points_per_pass = 256, wavelength_sets = {sets} }}

[materials.wall]
type = "lambertian"
albedo = 0.55

[materials.black]
type = "black"

[[objects]]
name = "sphere"
material = "marble"
sphere = {{ center = [25, 0, 0], radius = 25 }}

[[objects]]
name = "wall"
material = "wall"
quad = [[-400, -400, 60], [-400, 400, 60], [400, 400, 60], [400, -400, 60]]

[[objects]]
name = "softbox"
material = "black"
quad = [[-60, 150, -150], [60, 150, -150], [60, 150, -30], [-60, 150, -30]]

[[lights]]
type = "area"
object = "softbox"
radiance = "lamp"
scale = 4.0
"#
    );
    common::scene(&text)
}

/// Per seed, the mean XYZ of the backdrop region (the left third of the image, away from the
/// sphere) over `passes` passes, and the standard error of that mean from the pixel scatter.
fn backdrop_means(scene: &Scene, seeds: &[u64], passes: u64) -> Vec<([f64; 3], [f64; 3])> {
    let settings = scene.integrator.clone();
    let n = (W * H) as usize;
    seeds
        .iter()
        .map(|&seed| {
            let mut sum = vec![[0f64; 3]; n];
            let mut buf = vec![[0f32; 3]; n];
            for pass in 0..passes {
                render::integrator::render_pass(scene, &settings, seed, pass, &mut buf);
                for (s, b) in sum.iter_mut().zip(&buf) {
                    for c in 0..3 {
                        s[c] += b[c] as f64 / passes as f64;
                    }
                }
            }
            let region: Vec<[f64; 3]> = (0..H).flat_map(|j| (0..W / 3).map(move |i| (j * W + i) as usize)).map(|k| sum[k]).collect();
            let m = region.len() as f64;
            let mut mean = [0.0; 3];
            let mut se = [0.0; 3];
            for c in 0..3 {
                mean[c] = region.iter().map(|p| p[c]).sum::<f64>() / m;
                let var = region.iter().map(|p| (p[c] - mean[c]).powi(2)).sum::<f64>() / (m - 1.0);
                se[c] = (var / m).sqrt();
            }
            (mean, se)
        })
        .collect()
}

/// Between-seed standard deviation of the region means divided by the typical standard error of
/// one mean (pixel noise): about 1 when the seeds differ only by independent pixel noise.
fn spread_over_noise(r: &[([f64; 3], [f64; 3])]) -> [f64; 3] {
    let k = r.len() as f64;
    let mut out = [0.0; 3];
    for c in 0..3 {
        let m = r.iter().map(|x| x.0[c]).sum::<f64>() / k;
        let sd = (r.iter().map(|x| (x.0[c] - m).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
        let se = (r.iter().map(|x| x.1[c] * x.1[c]).sum::<f64>() / k).sqrt();
        out[c] = sd / se;
    }
    out
}

#[test]
fn wavelength_sets_remove_the_colour_cast_per_pass() {
    let seeds = [1, 2, 3, 4, 5];
    let one = backdrop_means(&scene(1), &seeds, 2);
    let four = backdrop_means(&scene(4), &seeds, 2);
    let r1 = spread_over_noise(&one);
    let r4 = spread_over_noise(&four);
    eprintln!("between-seed spread / standard error: 1 set {r1:?}, 4 sets {r4:?}");
    // With independent pixel noise only, the sample standard deviation of 5 means over their
    // standard error is χ₄/2-distributed: above 2.5 with probability 5·10⁻⁵. One set per pass
    // adds a shared tint per pass, far above the pixel noise.
    for c in 0..3 {
        assert!(r4[c] < 2.5, "channel {c}: between-seed spread {:.2} standard errors with 4 sets ({r4:?})", r4[c]);
        assert!(r1[c] > 2.5, "channel {c}: one set per pass should show the cast ({r1:?})");
    }
    // Same expected image: the means over seeds agree within their standard errors.
    for c in 0..3 {
        let m = |r: &[([f64; 3], [f64; 3])]| r.iter().map(|x| x.0[c]).sum::<f64>() / r.len() as f64;
        let sd = |r: &[([f64; 3], [f64; 3])]| {
            let mm = m(r);
            (r.iter().map(|x| (x.0[c] - mm).powi(2)).sum::<f64>() / (r.len() as f64 - 1.0) / r.len() as f64).sqrt()
        };
        let (a, b) = (m(&one), m(&four));
        let tol = 4.0 * (sd(&one).powi(2) + sd(&four).powi(2)).sqrt();
        assert!((a - b).abs() < tol, "channel {c}: mean {a} (1 set) vs {b} (4 sets), tolerance {tol}");
    }
}

#[test]
fn wavelength_sets_are_stratified_and_balanced() {
    // The 4K wavelengths of a pass are evenly spaced in the sampling CDF: set k's hero lies at
    // u + k/(4K); set 0 of 1 is the single-set pass wavelengths.
    let a = SubsurfacePass::set_wavelengths(9, 3, 0, 1);
    let b = SubsurfacePass::pass_wavelengths(9, 3);
    assert_eq!(a.lambda_nm, b.lambda_nm);
    let mut all: Vec<f32> = (0..4).flat_map(|k| SubsurfacePass::set_wavelengths(9, 3, k, 4).lambda_nm).collect();
    all.sort_by(f32::total_cmp);
    all.dedup();
    assert_eq!(all.len(), 16);
    // Every 2×2 block of pixels holds each of 4 sets once, whatever the pass's shift.
    for offset in 0..4 {
        for (i0, j0) in [(0, 0), (2, 0), (6, 4), (11, 7)] {
            let mut seen = [0; 4];
            for (i, j) in [(i0, j0), (i0 + 1, j0), (i0, j0 + 1), (i0 + 1, j0 + 1)] {
                seen[SubsurfacePass::set_of_pixel(i, j, offset, 4) as usize] += 1;
            }
            assert_eq!(seen, [1; 4], "offset {offset} block ({i0}, {j0})");
        }
    }
}
