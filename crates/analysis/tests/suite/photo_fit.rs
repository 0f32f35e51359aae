//! `analysis::photo_fit` against a synthetic round trip with known truth: a board of three
//! Lambertian albedos and a reference sphere of known albedo, lit by a calibrated (OpenCV-model)
//! projector and a constant environment, seen by a calibrated camera; "photographs" rendered by
//! lucent under five patterns with the true albedos and lights, Gaussian sensor noise, a camera
//! response b + g·x^(1/γ) and 8-bit quantisation.

use analysis::photo_fit::basis::{render_basis, scene_labels};
use analysis::photo_fit::model::{self, camera_response, Params};
use analysis::photo_fit::{fit, frame_metrics, verify_renders, FitOptions, Frame};
use render::image_io::{write_image, Image};
use render::math::sampling::Pcg32;
use render::scene::Scene;

const PW: u32 = 64;
const PH: u32 = 48;

/// Truth of the round trip.
const ALBEDO: [f64; 4] = [0.15, 0.45, 0.8, 0.6];
const PROJECTOR_SCALE: f64 = 1.25;
const AMBIENT_SCALE: f64 = 1.3;
/// The synthetic projector is ideal (black level 0, held in the fit): with it free, at 16 samples
/// per pixel, the darkest albedo came out −3.2 % and the projector scale −3.1 % (β and the
/// ambient light light the board alike but for the cos θ / r² falloff).
const PROJECTOR_BLACK: f64 = 0.0;
/// Samples per pixel of the photographs, of the basis (two halves of SPP / 2) and of the check.
/// The render noise sets the spread of the fitted darkest albedo: at 32 it was 1.5 % (standard
/// deviation over 14 seed sets, 4 of them beyond the 2 % asked for); at 128 the five seed sets
/// tried gave every albedo, the projector scale and gamma within 0.6 %.
const SPP: u64 = 128;
const BLACK_LEVEL: f64 = 0.03;
const GAIN: f64 = 0.92;
const GAMMA: f64 = 2.2;
const SENSOR_SIGMA: f64 = 0.002;

fn scene_text() -> String {
    let mut s = String::from(
        r#"
[camera]
model = "opencv"
width = 96
height = 72
fx = 105
fy = 105
cx = 47.5
cy = 35.5
k1 = -0.05
R = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
t = [0, 0, 0]

[integrator]
type = "direct"

[[lights]]
type = "projector"
image = "white.pfm"
intensity = 1.6
camera = { model = "opencv", fx = 55, fy = 55, cx = 31.5, cy = 23.5, k1 = -0.02, eye = [-0.25, 0.02, 0], look_at = [0, 0, 1] }

[[lights]]
type = "environment"
radiance = 0.05

[[objects]]
name = "ball"
material = "label3"
sphere = { center = [0.05, 0.08, 0.85], radius = 0.12 }
"#,
    );
    for (k, (x0, x1)) in [(-0.7, -0.15), (-0.15, 0.15), (0.15, 0.7)].iter().enumerate() {
        s += &format!("\n[[objects]]\nname = \"board{k}\"\nmaterial = \"label{k}\"\nquad = [[{x0}, -0.5, 1.0], [{x1}, -0.5, 1.0], [{x1}, 0.5, 1.0], [{x0}, 0.5, 1.0]]\n");
    }
    // Starting albedos: 0.5 for the board (wrong), the sphere at its known value.
    for (k, a) in [0.5, 0.5, 0.5, ALBEDO[3]].iter().enumerate() {
        s += &format!("\n[materials.label{k}]\ntype = \"lambertian\"\nalbedo = {a}\n");
    }
    s
}

/// Patterns: white, black, vertical stripes (period 16 projector pixels), their complement,
/// horizontal stripes, a horizontal ramp from 0 to 1 and a uniform grey of 0.35: the ramp and the
/// grey give the response more than two light levels per label.
fn patterns() -> Vec<Vec<f32>> {
    let n = (PW * PH) as usize;
    let f = |g: &dyn Fn(u32, u32) -> bool| (0..n).map(|i| if g(i as u32 % PW, i as u32 / PW) { 1.0 } else { 0.0 }).collect::<Vec<f32>>();
    let ramp: Vec<f32> = (0..n).map(|i| (i as u32 % PW) as f32 / (PW - 1) as f32).collect();
    let grey = vec![0.35f32; n];
    vec![f(&|_, _| true), f(&|_, _| false), f(&|x, _| (x / 8) % 2 == 0), f(&|x, _| (x / 8) % 2 == 1), f(&|_, y| (y / 6) % 2 == 0), ramp, grey]
}

fn setup() -> (tempdir::Dir, Scene) {
    let dir = tempdir::Dir::new("photo_fit");
    let white = Image { width: PW, height: PH, rgb: vec![[1.0; 3]; (PW * PH) as usize] };
    write_image(&dir.0.join("white.pfm"), &white, 0.0).unwrap();
    let path = dir.0.join("scene.toml");
    std::fs::write(&path, scene_text()).unwrap();
    let scene = Scene::load(&path).unwrap();
    (dir, scene)
}

mod tempdir {
    /// A folder under the system temp dir, removed on drop.
    pub struct Dir(pub std::path::PathBuf);
    impl Dir {
        pub fn new(tag: &str) -> Dir {
            let p = std::env::temp_dir().join(format!("lucent-{tag}-{}", std::process::id()));
            std::fs::create_dir_all(&p).unwrap();
            Dir(p)
        }
    }
    impl Drop for Dir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

fn truth_params(labels: usize) -> Params {
    let mut p = Params::new(&ALBEDO[..labels].iter().map(|&a| [a; 3]).collect::<Vec<_>>(), GAMMA);
    let g = |i| 3 * labels + i;
    p.x[g(model::PROJECTOR)] = PROJECTOR_SCALE;
    p.x[g(model::AMBIENT)] = AMBIENT_SCALE;
    p.x[g(model::PROJECTOR_BLACK)] = PROJECTOR_BLACK;
    p.x[g(model::BLACK_LEVEL)] = BLACK_LEVEL;
    p.x[g(model::GAIN)] = GAIN;
    p
}

/// "Photographs": full renders with the true parameters (seed `seed`), sensor noise (stream
/// `seed`), the true response and 8-bit codes.
fn photographs(scene: &mut Scene, truth: &Params, pats: &[Option<Vec<f32>>], seed: u64) -> Vec<Frame> {
    let labels = scene_labels(scene).unwrap();
    // Renders without the camera: verify_renders applies the response, so give it an identity
    // camera and apply the true one after the noise.
    let mut linear_camera = truth.clone();
    let g = 3 * truth.labels;
    linear_camera.x[g + model::BLACK_LEVEL] = 0.0;
    linear_camera.x[g + model::GAIN] = 1.0;
    linear_camera.x[g + model::GAMMA] = 1.0;
    let (lin, _) = verify_renders(scene, &labels, &linear_camera, pats, SPP, seed).unwrap();
    let mut rng = Pcg32::new(seed, 77);
    let mut gauss = || {
        let (u1, u2) = (rng.next_f32().max(1e-7) as f64, rng.next_f32() as f64);
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    };
    lin.iter()
        .enumerate()
        .map(|(f, img)| Frame {
            name: format!("frame{f}"),
            codes: img
                .iter()
                .map(|x| {
                    let noisy = x.map(|v| (v + SENSOR_SIGMA * gauss()).max(0.0));
                    camera_response(truth, noisy, 0.0, None).map(|y| ((y.clamp(0.0, 1.0) * 255.0).round() / 255.0) as f32)
                })
                .collect(),
        })
        .collect()
}

#[test]
fn synthetic_round_trip_recovers_albedos_light_and_gamma_and_reaches_the_noise_floor() {
    let (_dir, mut scene) = setup();
    let pats: Vec<Option<Vec<f32>>> = patterns().into_iter().map(Some).collect();
    let labels = scene_labels(&scene).unwrap();
    assert_eq!(labels.iter().map(|l| l.name.as_str()).collect::<Vec<_>>(), ["label0", "label1", "label2", "label3"]);
    let truth = truth_params(labels.len());
    let photos = photographs(&mut scene, &truth, &pats, 101);
    let photos_b = photographs(&mut scene, &truth, &pats, 202);

    let bspp = SPP;
    // Two independent halves of the basis (the unbiased cross error) and their mean.
    let half_a = render_basis(&mut scene, &pats, bspp / 2, 7).unwrap();
    let half_b = render_basis(&mut scene, &pats, bspp / 2, 8).unwrap();
    let basis = analysis::photo_fit::basis::average(&half_a, &half_b);
    let halves = Some((&half_a, &half_b));
    // White, black, the grey and a complement are not rendered: 4 labels + rest ambient, 4
    // floods, 3 patterns × 4.
    assert_eq!(half_a.render_seconds.len(), 5 + 4 + 3 * 4, "renders made");
    let start = Params::new(&labels.iter().map(|l| l.albedo).collect::<Vec<_>>(), 1.8);
    let opts = FitOptions { hold: ["gain", "label3", "projector_black"].map(String::from).to_vec(), gain: GAIN, ..FitOptions::default() };
    let mut start = start;
    start.x[3 * labels.len() + model::GAIN] = GAIN;
    let result = fit(&basis, halves, &photos, &start, &opts).unwrap();
    let p = &result.params;
    for s in &result.steps {
        eprintln!("step {:8}: rel. RMSE {:.5}  ΔE2000 {:.3}  {} LM steps {:.2} s  {:?}", s.name, s.total.rel_rmse, s.total.delta_e2000, s.iterations, s.seconds, s.params.x);
    }
    for k in 0..3 {
        for c in 0..3 {
            let e = p.albedo(k)[c] / ALBEDO[k] - 1.0;
            assert!(e.abs() < 0.02, "label{k} channel {c}: albedo {} vs {} ({:+.2} %)", p.albedo(k)[c], ALBEDO[k], 100.0 * e);
        }
    }
    let ep = p.get(model::PROJECTOR) / PROJECTOR_SCALE - 1.0;
    assert!(ep.abs() < 0.02, "projector scale {} vs {PROJECTOR_SCALE}", p.get(model::PROJECTOR));
    let eg = p.get(model::GAMMA) / GAMMA - 1.0;
    assert!(eg.abs() < 0.02, "gamma {} vs {GAMMA}", p.get(model::GAMMA));
    // Each step lowers (or keeps) the total error.
    for w in result.steps.windows(2) {
        assert!(w[1].total.rmse <= w[0].total.rmse * (1.0 + 1e-9), "{} → {}: {} → {}", w[0].name, w[1].name, w[0].total.rmse, w[1].total.rmse);
    }
    // Standard errors exist for the joint parameters and are small against the 2 % tolerance.
    let ip = 3 * labels.len() + model::PROJECTOR;
    let se_p = result.std_errors[ip].expect("projector scale has an uncertainty");
    assert!(se_p > 0.0 && se_p < 0.01 * PROJECTOR_SCALE, "σ(P) = {se_p}");

    // Final full render (another seed) through the fitted camera against the photographs, and the
    // noise floor: two photographs of the truth with different seeds.
    let (pred, _) = verify_renders(&mut scene, &labels, p, &pats, SPP, 303).unwrap();
    let k = labels.len();
    let mut worst = 0.0f64;
    for (f, photo) in photos.iter().enumerate() {
        let fit_err = frame_metrics(&pred[f], photo, &result.regions, k, opts.saturation).whole.rel_rmse;
        let floor_pred: Vec<[f64; 3]> = photos_b[f].codes.iter().map(|c| c.map(|v| v as f64)).collect();
        let floor = frame_metrics(&floor_pred, photo, &result.regions, k, opts.saturation).whole.rel_rmse;
        eprintln!("frame {f}: final render rel. RMSE {fit_err:.5}, noise floor {floor:.5}, ratio {:.3}", fit_err / floor);
        worst = worst.max(fit_err / floor);
    }
    assert!(worst <= 1.5, "final render's relative RMSE is {worst:.3}× the noise floor");
}

/// `interior` on a 9 × 6 map of two regions split at x = 4 with one unlabelled pixel: with a band
/// of 1 pixel every pixel next to the split or to the hole is left out, every other keeps its
/// region (predicted pixel by pixel); a band of 0 changes nothing.
#[test]
fn interior_leaves_out_a_band_at_region_boundaries() {
    let (w, h) = (9usize, 6usize);
    let mut r: Vec<i32> = (0..w * h).map(|i| if i % w < 4 { 0 } else { 1 }).collect();
    let hole = (1, 7);
    r[hole.0 * w + hole.1] = -1;
    assert_eq!(analysis::photo_fit::interior(&r, w, h, 0), r);
    let out = analysis::photo_fit::interior(&r, w, h, 1);
    for y in 0..h {
        for x in 0..w {
            let near_split = x == 3 || x == 4;
            let near_hole = y.abs_diff(hole.0) <= 1 && x.abs_diff(hole.1) <= 1;
            let want = if near_split || near_hole { -1 } else { r[y * w + x] };
            assert_eq!(out[y * w + x], want, "pixel ({x}, {y})");
        }
    }
}

/// `regions` on a hand-made basis of two labels and four pixels: a pixel that only labels light
/// keeps the brighter label; one where the rest of the scene (the environment seen through a
/// hole) brings 1/3 of the ambient light, or brings all of it, is left out; a share of 10⁻⁴ (below
/// the default 10⁻³) is kept; with a limit of 1 every pixel a label reaches is kept.
#[test]
fn regions_leave_out_pixels_that_see_the_background() {
    use analysis::photo_fit::basis::{Basis, Label};
    let label = |k: usize| Label { name: format!("label{k}"), material: k, albedo: [0.5; 3], gloss: None };
    let g = |v: f32| [v; 3];
    // Per label, then the rest; pixels 0..4.
    let ambient = vec![vec![g(1.0), g(0.0), g(1.0), g(0.0)], vec![g(0.2), g(1.0), g(0.0), g(0.0)], vec![g(0.0), g(0.5), g(1e-4), g(1.0)]];
    let flood = vec![vec![g(2.0), g(0.0), g(2.0), g(0.0)], vec![g(0.5), g(2.0), g(0.0), g(0.0)], vec![g(0.0); 4]];
    let basis = Basis { width: 4, height: 1, labels: vec![label(0), label(1)], ambient, flood, frames: vec![], specular: false, render_seconds: vec![] };
    assert_eq!(analysis::photo_fit::regions(&basis, analysis::photo_fit::MAX_BACKGROUND), vec![0, -1, 0, -1]);
    assert_eq!(analysis::photo_fit::regions(&basis, 1.0), vec![0, 1, 0, -1]);
}

/// `exposure_match` on "photographs" made from a render through a known camera at exposure 0.8:
/// it finds 0.8 and leaves no error.
#[test]
fn exposure_match_recovers_a_known_exposure() {
    let (w, h) = (16usize, 8usize);
    let mut p = Params::new(&[[0.5; 3]], 1.8);
    p.x[3 + model::BLACK_LEVEL] = 0.02;
    p.x[3 + model::GAIN] = 0.9;
    let lin: Vec<Vec<[f32; 3]>> = (0..2).map(|f| (0..w * h).map(|i| [0.05 + 0.6 * ((i * 7 + f * 3) % 11) as f32 / 11.0, 0.3, 0.1 + 0.002 * i as f32]).collect()).collect();
    let frames: Vec<Frame> = lin
        .iter()
        .enumerate()
        .map(|(f, l)| Frame { name: format!("f{f}"), codes: analysis::photo_fit::codes(&p, l, 0.8, w, h).iter().map(|c| c.map(|v| v as f32)).collect() })
        .collect();
    let regions = vec![0i32; w * h];
    let (s, m) = analysis::photo_fit::exposure_match(&p, &lin, &frames, &regions, 1, 0.99, w, h);
    assert!((s - 0.8).abs() < 1e-3, "exposure {s}");
    let tot = analysis::photo_fit::total(&m);
    assert!(tot.rel_rmse < 5e-4, "rel. RMSE {}", tot.rel_rmse);
}

/// Codes of a pattern pair, white and black through y = b + g E^(1/γ): per pixel a direct
/// irradiance D, a pattern value m (0–1: lit, dark, or a blurred edge in between), ambient A and
/// projector black level β, with E(pattern) = A + D (β + (1 − β) m), E(inverse) the same with
/// 1 − m, E(white) = A + D, E(black) = A + β D.
fn pair_codes(gamma: f64, b: f64, g: f64, pairs: usize, n: usize, quantise: bool, noise: f64, seed: u64) -> (Vec<Vec<f32>>, Vec<f32>, Vec<f32>) {
    pair_codes_s(gamma, 1.0, b, g, pairs, n, quantise, noise, seed)
}

/// [`pair_codes`] with a projector whose complementary halves together give `s` times the
/// all-white image's light above the black image's (s = 1: additive).
#[allow(clippy::too_many_arguments)]
fn pair_codes_s(gamma: f64, s: f64, b: f64, g: f64, pairs: usize, n: usize, quantise: bool, noise: f64, seed: u64) -> (Vec<Vec<f32>>, Vec<f32>, Vec<f32>) {
    let mut rng = Pcg32::new(seed, 1);
    let (amb, beta) = (0.01, 0.004);
    let d: Vec<f64> = (0..n).map(|_| 0.2 + 0.6 * rng.next_f32() as f64).collect();
    let code = |e: f64, rng: &mut Pcg32| {
        // Box–Muller for the sensor noise (codes of full scale 1).
        let z = (-2.0 * (1.0 - rng.next_f32() as f64).ln()).sqrt() * (std::f64::consts::TAU * rng.next_f32() as f64).cos();
        let y = b + g * e.powf(1.0 / gamma) + noise * z;
        (if quantise { (y * 255.0).round() / 255.0 } else { y }).clamp(0.0, 1.0) as f32
    };
    let white: Vec<f32> = d.iter().map(|&di| code(amb + di, &mut rng)).collect();
    let black: Vec<f32> = d.iter().map(|&di| code(amb + beta * di, &mut rng)).collect();
    let mut frames = vec![];
    for _ in 0..pairs {
        // A third of the pixels on a blurred edge (m uniform), the rest fully lit or dark.
        let m: Vec<f64> = (0..n)
            .map(|_| {
                let u = rng.next_f32() as f64;
                if u < 1.0 / 3.0 { 3.0 * u } else if u < 2.0 / 3.0 { 0.0 } else { 1.0 }
            })
            .collect();
        let pattern = d.iter().zip(&m).map(|(&di, &mi)| code(amb + di * (beta + s * (1.0 - beta) * mi), &mut rng)).collect();
        let inverse = d.iter().zip(&m).map(|(&di, &mi)| code(amb + di * (beta + s * (1.0 - beta) * (1.0 - mi)), &mut rng)).collect();
        frames.push(pattern);
        frames.push(inverse);
    }
    (frames, white, black)
}

#[test]
fn gamma_from_complementary_pairs_is_exact_on_exact_codes() {
    use analysis::photo_fit::response::gamma_from_pairs;
    // Noise-free codes: the sums of complementary frames hold exactly only at the true γ, for
    // any gain; the black level is given.
    for (gamma, g) in [(0.7, 0.9), (1.0, 1.3), (1.8, 0.8), (2.2, 1.0), (3.0, 0.95)] {
        let b = 0.02;
        let (frames, white, black) = pair_codes(gamma, b, g, 4, 20_000, false, 0.0, 7);
        let pairs: Vec<(&[f32], &[f32])> = frames.chunks(2).map(|p| (p[0].as_slice(), p[1].as_slice())).collect();
        let r = gamma_from_pairs(&pairs, &white, &black, b, 1).unwrap();
        // f32 codes carry ~6e-8 relative rounding: γ to 1e-4.
        assert!((r.gamma / gamma - 1.0).abs() < 1e-4, "γ {gamma}: found {}", r.gamma);
        assert!(r.rms < 1e-5, "γ {gamma}: rms {}", r.rms);
        assert!((r.additivity - 1.0).abs() < 1e-5, "γ {gamma}: additivity {}", r.additivity);
        assert_eq!(r.pairs, 4);
    }
}

#[test]
fn gamma_from_complementary_pairs_holds_with_8_bit_codes_and_noise() {
    use analysis::photo_fit::response::gamma_from_pairs;
    // 8-bit quantisation and sensor noise of 1 code (σ = 1/255): the residual has a noise floor
    // (rms about 0.02), and noise raised to the power γ biases the estimate a little (0.4 % at
    // this seed for both γ); 1.5 % bounds it.
    for gamma in [1.0, 2.2] {
        let b = 6.0 / 255.0;
        let (frames, white, black) = pair_codes(gamma, b, 1.0, 6, 40_000, true, 1.0 / 255.0, 11);
        let pairs: Vec<(&[f32], &[f32])> = frames.chunks(2).map(|p| (p[0].as_slice(), p[1].as_slice())).collect();
        let r = gamma_from_pairs(&pairs, &white, &black, b, 1).unwrap();
        assert!((r.gamma / gamma - 1.0).abs() < 0.015, "γ {gamma}: found {}", r.gamma);
    }
}

#[test]
fn gamma_from_pairs_separates_a_non_additive_projector_from_the_camera() {
    use analysis::photo_fit::response::gamma_from_pairs;
    // A projector whose complementary halves give 97 % of the all-white light: a flat deficit at
    // every level, which a power law cannot make; both are recovered from exact codes.
    for gamma in [1.0, 2.2] {
        let b = 0.02;
        let (frames, white, black) = pair_codes_s(gamma, 0.97, b, 1.0, 4, 20_000, false, 0.0, 5);
        let pairs: Vec<(&[f32], &[f32])> = frames.chunks(2).map(|p| (p[0].as_slice(), p[1].as_slice())).collect();
        let r = gamma_from_pairs(&pairs, &white, &black, b, 1).unwrap();
        assert!((r.gamma / gamma - 1.0).abs() < 1e-4, "γ {gamma}: found {}", r.gamma);
        assert!((r.additivity - 0.97).abs() < 1e-5, "γ {gamma}: additivity {}", r.additivity);
    }
}

#[test]
fn gamma_from_pairs_refuses_empty_input() {
    use analysis::photo_fit::response::gamma_from_pairs;
    let white = vec![0.5f32; 10];
    let black = vec![0.0f32; 10];
    assert!(gamma_from_pairs(&[], &white, &black, 0.0, 1).unwrap_err().to_string().contains("complementary"));
    // A white frame no brighter than the black level: no pixel qualifies.
    let dark = vec![0.01f32; 10];
    let pairs: Vec<(&[f32], &[f32])> = vec![(&dark, &dark)];
    assert!(gamma_from_pairs(&pairs, &dark, &black, 0.0, 1).unwrap_err().to_string().contains("no pixel"));
}

#[test]
fn complementary_pairs_are_found_from_the_gray_code_patterns() {
    use analysis::photo_fit::response::complementary_pairs;
    // The layout of OpenCV's Gray-code sequence on a 16 × 4 projector: 4 column bits, 2 row bits,
    // each followed by its inverse, then white and black.
    let (w, h) = (16usize, 4usize);
    let mut pats: Vec<Vec<f32>> = vec![];
    for bit in 0..4 {
        let p: Vec<f32> = (0..w * h).map(|i| (((i % w) >> (3 - bit)) & 1) as f32).collect();
        pats.push(p.clone());
        pats.push(p.iter().map(|v| 1.0 - v).collect());
    }
    for bit in 0..2 {
        let p: Vec<f32> = (0..w * h).map(|i| (((i / w) >> (1 - bit)) & 1) as f32).collect();
        pats.push(p.clone());
        pats.push(p.iter().map(|v| 1.0 - v).collect());
    }
    pats.push(vec![1.0; w * h]);
    pats.push(vec![0.0; w * h]);
    let views: Vec<Option<&[f32]>> = pats.iter().map(|p| Some(p.as_slice())).collect();
    let (white, black, pairs) = complementary_pairs(&views).unwrap();
    assert_eq!((white, black), (12, 13));
    assert_eq!(pairs, (0..6).map(|k| (2 * k, 2 * k + 1)).collect::<Vec<_>>());
    // Without the black frame, or with only one frame of each pair: a message naming what is missing.
    let no_black: Vec<Option<&[f32]>> = views[..13].to_vec();
    assert!(complementary_pairs(&no_black).unwrap_err().to_string().contains("all-black"));
    let halves: Vec<Option<&[f32]>> = views.iter().enumerate().filter(|(i, _)| i % 2 == 0 || *i >= 12).map(|(_, v)| *v).collect();
    assert!(complementary_pairs(&halves).unwrap_err().to_string().contains("complementary"));
}

/// A glossy label's roughness and its albedo under the coating, from photographs with known
/// truth: the middle strip of the round trip's board is `plastic` (n = 1.5, α = 0.15, albedo
/// under the coating 0.45), where the projector's highlight falls; the fit starts at α = 0.5 and
/// albedo 0.5 and finds α within 10 % and every albedo within 2 %, and the residual variance at
/// the found α is below that at the grid's ends (the profile is not flat).
#[test]
fn glossy_label_roughness_and_albedo_from_photographs() {
    use analysis::photo_fit::basis::set_roughness;
    use analysis::photo_fit::fit_roughness;
    let (dir, _) = setup();
    let text = scene_text().replace(
        "[materials.label1]\ntype = \"lambertian\"\nalbedo = 0.5\n",
        "[materials.label1]\ntype = \"plastic\"\nalbedo = 0.5\nior = 1.5\nalpha = 0.5\nnonlinear = false\n",
    );
    assert!(text.contains("type = \"plastic\""));
    let path = dir.0.join("gloss.toml");
    std::fs::write(&path, text).unwrap();
    let mut scene = Scene::load(&path).unwrap();
    let pats: Vec<Option<Vec<f32>>> = patterns().into_iter().map(Some).collect();
    let mut labels = scene_labels(&scene).unwrap();
    assert!(labels[1].gloss.is_some() && labels[0].gloss.is_none());
    let truth = truth_params(labels.len());
    const ALPHA: f32 = 0.15;
    set_roughness(&mut scene, &mut labels, ALPHA);
    let photos = photographs(&mut scene, &truth, &pats, 404);
    set_roughness(&mut scene, &mut labels, 0.5);
    // 13 roughness values are each a basis render and a fit: 32 samples per pixel keep the test
    // short.

    let mut start = Params::new(&labels.iter().map(|l| l.albedo).collect::<Vec<_>>(), 1.8);
    start.x[3 * labels.len() + model::GAIN] = GAIN;
    let opts = FitOptions { hold: ["gain", "label3", "projector_black"].map(String::from).to_vec(), gain: GAIN, ..FitOptions::default() };
    let r = fit_roughness(&mut scene, &pats, &photos, &start, &opts, 32, 9, &|a, v| eprintln!("α {a:.4}: residual variance {v:.4e}")).unwrap();
    eprintln!("found α {:.4} (truth {ALPHA})", r.alpha);
    assert!((r.alpha / ALPHA as f64 - 1.0).abs() < 0.10, "α {} against {ALPHA}", r.alpha);
    let p = &r.fit.params;
    for k in 0..3 {
        for c in 0..3 {
            let e = p.albedo(k)[c] / ALBEDO[k] - 1.0;
            assert!(e.abs() < 0.02, "label{k} channel {c}: albedo {} vs {} ({:+.2} %)", p.albedo(k)[c], ALBEDO[k], 100.0 * e);
        }
    }
    let v_best = r.fit.residual_variance;
    let (first, last) = (r.profile[0].1, r.profile[6].1);
    assert!(v_best < 0.5 * first.min(last), "profile {:?}", r.profile);
    // The scene is left at the found roughness.
    let l = scene_labels(&scene).unwrap();
    assert!((l[1].gloss.unwrap().alpha as f64 - r.alpha).abs() < 1e-6);
}
