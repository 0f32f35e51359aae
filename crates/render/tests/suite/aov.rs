//! AOVs and spectral bins on the film: first-hit albedo, normal, depth and position against
//! closed forms, the variance AOV against the spread between two seeds, the spectral bins
//! against the XYZ image of the same samples, and exact resume and merge of all of them.

use std::path::Path;

use render::checkpoint::{Checkpoint, RenderIdentity};
use render::film::{Film, FilmLayout};
use render::integrator::aov::Aov;
use render::integrator::{render_pass_samples, IntegratorKind, IntegratorSettings, PixelSample, SampleExtras};
use render::math::spectral::{cmf, SpectralBins};
use render::scene::Scene;

use crate::common::{scene, settings};

/// Passes `passes` of `seed` added to `film` with the extras its layout needs.
fn render(scene: &Scene, settings: &IntegratorSettings, film: &mut Film, seed: u64, passes: std::ops::Range<u64>) {
    let mut buf = film.pass_buffer();
    for p in passes {
        film.render_pass(scene, settings, seed, p, &mut buf);
    }
}

/// The extra channel named `name`, one value per pixel.
fn channel(film: &Film, name: &str) -> Vec<f32> {
    film.extra_channels().into_iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no channel {name}")).1
}

fn all_aovs() -> FilmLayout {
    FilmLayout::new(Aov::ALL.to_vec(), None)
}

fn tiny_box(w: u32, h: u32) -> Scene {
    let mut s = Scene::cornell_box();
    s.set_resolution(w, h);
    s
}

#[test]
fn albedo_of_a_textured_lambertian_quad_is_its_texture_and_its_image_under_white_light() {
    // The quad fills the view exactly (camera constant 2 at distance 2 sees 2 × 1), and a 2 × 2
    // checkerboard puts the square edges on pixel edges: each pixel shows one square only.
    let (w, h) = (8u32, 4u32);
    let text = format!(
        "[camera]\neye = [0, 0, 2]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\ncamera_constant = 2\nwidth = {w}\nheight = {h}\n\
         [materials.check]\ntype = \"lambertian\"\nalbedo = {{ checkerboard = {{ squares = 2, even = 0.2, odd = {{ rgb = [0.9, 0.3, 0.1] }} }} }}\n\
         [[objects]]\nmaterial = \"check\"\nquad = [[-1, -0.5, 0], [1, -0.5, 0], [1, 0.5, 0], [-1, 0.5, 0]]\n\
         [[lights]]\ntype = \"environment\"\nradiance = {{ rgb = [1, 1, 1] }}\n"
    );
    let s = scene(&text);
    let st = settings(IntegratorKind::Path, 2, 5);
    let n = (w * h) as usize;
    let passes = 256u64;
    let mut film = Film::with_layout(w, h, FilmLayout::new(vec![Aov::Albedo, Aov::Variance], None));
    // Per-sample spread of the albedo estimate, for its standard error.
    let (mut s1, mut s2) = (vec![[0.0f64; 3]; n], vec![[0.0f64; 3]; n]);
    let mut buf = vec![PixelSample::ZERO; n];
    let extras = film.layout().extras();
    for p in 0..passes {
        render_pass_samples(&s, &st, 3, p, extras, &mut buf);
        film.add_samples(&buf);
        for (k, smp) in buf.iter().enumerate() {
            for c in 0..3 {
                let a = smp.first_hit.albedo[c] as f64;
                s1[k][c] += a;
                s2[k][c] += a * a;
            }
        }
    }
    // Expected colours: the constant 0.2 lit by D65 (≈ grey 0.2), and the uplifted RGB, which
    // reproduces its colour to the solver's tolerance.
    let grey = optics::spectrum::reflectance_to_linear_srgb(|_| 0.2);
    let colours = [grey, [0.9, 0.3, 0.1]];
    let albedo: Vec<Vec<f32>> = ["albedo.R", "albedo.G", "albedo.B"].iter().map(|c| channel(&film, c)).collect();
    let variance: Vec<Vec<f32>> = ["variance.R", "variance.G", "variance.B"].iter().map(|c| channel(&film, c)).collect();
    let image = film.to_image();
    let mut seen = [0usize; 2];
    let mut worst_albedo_z = 0.0f64;
    let mut worst_image_z = 0.0f64;
    for k in 0..n {
        let a: [f64; 3] = std::array::from_fn(|c| albedo[c][k] as f64);
        let se: [f64; 3] = std::array::from_fn(|c| {
            let m = s1[k][c] / passes as f64;
            ((s2[k][c] / passes as f64 - m * m).max(0.0) / passes as f64).sqrt().max(1e-5)
        });
        // Which square: the nearer colour; then every channel within 5 σ (+ 2e-3 for the uplift).
        let d = |col: &[f64; 3]| (0..3).map(|c| (a[c] - col[c]).abs()).sum::<f64>();
        let which = if d(&colours[0]) < d(&colours[1]) { 0 } else { 1 };
        seen[which] += 1;
        for c in 0..3 {
            let z = (a[c] - colours[which][c]).abs() / (5.0 * se[c] + 2e-3);
            worst_albedo_z = worst_albedo_z.max(z);
            assert!(z < 1.0, "pixel {k} channel {c}: albedo {:.4} vs {:.4} (σ {:.5})", a[c], colours[which][c], se[c]);
            // Under a uniform environment of D65 with Y = 1 a Lambertian surface shows its albedo:
            // the image agrees with the AOV within the image's own standard error (the variance AOV).
            let img = image.rgb[k][c] as f64;
            let z_img = (img - a[c]).abs() / (variance[c][k] as f64 + se[c] * se[c]).sqrt();
            worst_image_z = worst_image_z.max(z_img);
            assert!(z_img < 5.0, "pixel {k} channel {c}: image {img:.4} vs albedo {:.4}", a[c]);
        }
    }
    assert_eq!(seen, [n / 2, n / 2], "both squares cover half the view");
    eprintln!("albedo: worst |Δ|/(5σ + 2e-3) {worst_albedo_z:.2}; image vs albedo worst z {worst_image_z:.2}");
}

#[test]
fn normals_are_unit_face_the_camera_and_match_the_sphere() {
    let (w, h) = (16u32, 16u32);
    let text = "[camera]\neye = [0, 0, 4]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\ncamera_constant = 1.5\nwidth = 16\nheight = 16\n\
         [materials.white]\ntype = \"lambertian\"\nalbedo = 0.5\n\
         [[objects]]\nmaterial = \"white\"\nsphere = { center = [0, 0, 0], radius = 1 }\n\
         [[lights]]\ntype = \"environment\"\nradiance = 1\n";
    let s = scene(text);
    let mut film = Film::with_layout(w, h, all_aovs());
    render(&s, &settings(IntegratorKind::Ao, 8, 5), &mut film, 1, 0..16);
    let nrm: Vec<Vec<f32>> = ["N.X", "N.Y", "N.Z"].iter().map(|c| channel(&film, c)).collect();
    let pos: Vec<Vec<f32>> = ["P.X", "P.Y", "P.Z"].iter().map(|c| channel(&film, c)).collect();
    let id = channel(&film, "object_id.I");
    let eye = glam::Vec3::new(0.0, 0.0, 4.0);
    let (mut covered, mut missed, mut worst_deg) = (0, 0, 0.0f32);
    for k in 0..(w * h) as usize {
        let nv = glam::Vec3::new(nrm[0][k], nrm[1][k], nrm[2][k]);
        let p = glam::Vec3::new(pos[0][k], pos[1][k], pos[2][k]);
        if id[k] == -1.0 {
            // Every sample escaped: no normal, no position.
            assert_eq!(nv, glam::Vec3::ZERO);
            missed += 1;
            continue;
        }
        if id[k] != 0.0 {
            continue; // an edge pixel, partly sphere and partly background
        }
        covered += 1;
        assert!((nv.length() - 1.0).abs() < 1e-5, "pixel {k}: |N| = {}", nv.length());
        assert!(nv.dot(eye - p) > 0.0, "pixel {k}: normal {nv} faces away from the camera");
        // The mean over the pixel of the exact normal p/|p| at the mean position.
        let exact = p.normalize();
        let deg = nv.dot(exact).clamp(-1.0, 1.0).acos().to_degrees();
        worst_deg = worst_deg.max(deg);
        assert!(deg < 2.0, "pixel {k}: normal {nv} vs sphere normal {exact} ({deg:.2}°)");
        assert!((p.length() - 1.0).abs() < 0.01, "pixel {k}: |P| = {}", p.length());
    }
    assert!(covered > 50 && missed > 20, "covered {covered}, missed {missed}");
    eprintln!("normals: {covered} covered pixels, worst angle to the sphere normal {worst_deg:.3}°");
}

#[test]
fn depth_of_a_plane_matches_its_analytic_distance_per_pixel() {
    // A tilted view of the plane z = 0: the distance along each ray is t = −o_z/d_z.
    let (w, h) = (12u32, 9u32);
    let text = "[camera]\neye = [0.4, -0.3, 2.5]\nlook_at = [0.1, 0.2, 0]\nup = [0, 1, 0]\ncamera_constant = 1.2\nwidth = 12\nheight = 9\n\
         [materials.white]\ntype = \"lambertian\"\nalbedo = 0.5\n\
         [[objects]]\nmaterial = \"white\"\nquad = [[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0]]\n\
         [[lights]]\ntype = \"environment\"\nradiance = 1\n";
    let s = scene(text);
    let mut film = Film::with_layout(w, h, FilmLayout::new(vec![Aov::Depth, Aov::Position], None));
    let spp = 64;
    render(&s, &settings(IntegratorKind::Ao, 8, 5), &mut film, 2, 0..spp);
    let depth = channel(&film, "depth.T");
    let pz = channel(&film, "P.Z");
    let mut worst = 0.0f64;
    for j in 0..h {
        for i in 0..w {
            // Mean of t over the pixel's footprint (32 × 32 film positions) and its spread.
            let m = 32;
            let (mut t1, mut t2) = (0.0f64, 0.0f64);
            for a in 0..m {
                for b in 0..m {
                    let u = glam::Vec2::new((a as f32 + 0.5) / m as f32, (b as f32 + 0.5) / m as f32);
                    let r = s.camera.generate_ray(i, j, u);
                    let t = (-r.o.z / r.d.z) as f64 * r.d.length() as f64;
                    t1 += t;
                    t2 += t * t;
                }
            }
            let mean = t1 / (m * m) as f64;
            let sd = (t2 / (m * m) as f64 - mean * mean).max(0.0).sqrt();
            let k = (j * w + i) as usize;
            let got = depth[k] as f64;
            // The film's mean over spp random positions: within 5 standard errors (+ f32 rounding).
            let tol = 5.0 * sd / (spp as f64).sqrt() + 1e-5 * mean;
            worst = worst.max((got - mean).abs() / tol);
            assert!((got - mean).abs() < tol, "pixel ({i}, {j}): depth {got:.6} m vs {mean:.6} m (tolerance {tol:.2e})");
            assert!(pz[k].abs() < 1e-4, "pixel ({i}, {j}): P.Z = {}", pz[k]);
        }
    }
    eprintln!("depth: worst |Δ|/tolerance {worst:.2}");
}

/// Σ d² / Σ (v_A + v_B) over all pixels and channels of two films, with its standard error
/// (delta method, from the same pixels): d the difference of their pixel means, v their variance AOVs.
fn spread_over_variance(a: &Film, b: &Film) -> (f64, f64) {
    let (ia, ib) = (a.to_image(), b.to_image());
    let names = ["variance.R", "variance.G", "variance.B"];
    let (va, vb): (Vec<Vec<f32>>, Vec<Vec<f32>>) = (names.iter().map(|c| channel(a, c)).collect(), names.iter().map(|c| channel(b, c)).collect());
    let (mut d2, mut v) = (Vec::new(), Vec::new());
    for k in 0..ia.rgb.len() {
        for c in 0..3 {
            let d = ia.rgb[k][c] as f64 - ib.rgb[k][c] as f64;
            d2.push(d * d);
            v.push(va[c][k] as f64 + vb[c][k] as f64);
        }
    }
    let n = d2.len() as f64;
    let (sd2, sv) = (d2.iter().sum::<f64>(), v.iter().sum::<f64>());
    assert!(sv > 0.0);
    let ratio = sd2 / sv;
    let resid: Vec<f64> = d2.iter().zip(&v).map(|(d, v)| d - ratio * v).collect();
    let var_resid = resid.iter().map(|r| r * r).sum::<f64>() / (n - 1.0);
    (ratio, (var_resid / n).sqrt() / (sv / n))
}

#[test]
fn variance_matches_the_spread_between_two_seeds() {
    // Two independent runs of n samples: the difference of their pixel means has variance
    // Var_A + Var_B, which the variance AOVs estimate from the samples' second moments. That is
    // exact for independent samples: here every pass of a film gets a seed of its own, so no two
    // samples of a pixel share the stratification of the wavelength and film numbers, and the
    // ratio Σ d² / Σ (v_A + v_B) is 1 within its standard error. The passes of one seed are
    // stratified against each other (`PixelStrata`), which lowers the real variance, so for an
    // ordinary render the AOV is an upper bound: the ratio is below 1.
    // A sphere on a floor under a uniform sky: bounded radiance (light-tailed noise), with
    // occlusion, two bounces and coloured spectra.
    let (w, h) = (20u32, 20u32);
    let text = "[camera]\neye = [0, 1.2, 3]\nlook_at = [0, 0.4, 0]\nup = [0, 1, 0]\ncamera_constant = 1.2\nwidth = 20\nheight = 20\n\
         [materials.red]\ntype = \"lambertian\"\nalbedo = { rgb = [0.8, 0.3, 0.2] }\n\
         [materials.grey]\ntype = \"lambertian\"\nalbedo = 0.6\n\
         [[objects]]\nmaterial = \"red\"\nsphere = { center = [0, 0.5, 0], radius = 0.5 }\n\
         [[objects]]\nmaterial = \"grey\"\nquad = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\n\
         [[lights]]\ntype = \"environment\"\nradiance = { rgb = [1, 1, 1] }\n";
    let s = scene(text);
    let st = settings(IntegratorKind::Path, 3, 5);
    let layout = FilmLayout::new(vec![Aov::Variance], None);
    // Independent samples: pass 0 of 32 seeds per film.
    let mut a = Film::with_layout(w, h, layout.clone());
    let mut b = Film::with_layout(w, h, layout.clone());
    for k in 0..32u64 {
        render(&s, &st, &mut a, 1000 + k, 0..1);
        render(&s, &st, &mut b, 2000 + k, 0..1);
    }
    let (ratio, se) = spread_over_variance(&a, &b);
    eprintln!("variance, independent samples: Σd²/Σ(vA+vB) = {ratio:.3} ± {se:.3}");
    assert!((ratio - 1.0).abs() < 4.0 * se, "ratio {ratio:.3} ± {se:.3}");
    assert!(se < 0.15, "the test should be able to tell: se {se:.3}");
    // Passes 0..32 of one seed per film: the AOV bounds the variance from above.
    let mut a = Film::with_layout(w, h, layout.clone());
    let mut b = Film::with_layout(w, h, layout);
    render(&s, &st, &mut a, 1, 0..32);
    render(&s, &st, &mut b, 2, 0..32);
    let (ratio_s, se_s) = spread_over_variance(&a, &b);
    eprintln!("variance, stratified passes: Σd²/Σ(vA+vB) = {ratio_s:.3} ± {se_s:.3}");
    assert!(ratio_s < 1.0 - 4.0 * se_s, "stratified passes: ratio {ratio_s:.3} ± {se_s:.3}, expected below 1");
}

#[test]
fn spectral_bins_integrate_against_the_cie_curves_to_the_xyz_image() {
    // Bins covering 360–830 nm: Σ_b B_b·∫_b(x̄, ȳ, z̄)dλ / ∫ȳ is the XYZ of the bins, which must
    // agree with the film's XYZ from the same samples. The two differ per sample only through
    // the variation of the colour-matching functions inside a bin.
    let (w, h) = (10u32, 10u32);
    let s = tiny_box(w, h);
    let st = IntegratorSettings::default();
    let bins = SpectralBins::parse("360:830:5").unwrap();
    let mut film = Film::with_layout(w, h, FilmLayout::new(Vec::new(), Some(bins)));
    let passes = 32u64;
    // Bin integrals of the colour-matching functions (0.1-nm midpoint rule), over ∫ȳ.
    let cmf_bins: Vec<[f64; 3]> = (0..bins.count)
        .map(|k| {
            let (lo, _) = bins.edges_nm(k);
            let steps = 50;
            let dl = bins.width_nm as f64 / steps as f64;
            let mut acc = [0.0; 3];
            for q in 0..steps {
                let c = cmf(lo + ((q as f64 + 0.5) * dl) as f32);
                for i in 0..3 {
                    acc[i] += c[i] as f64 * dl / optics::color::CIE_Y_INTEGRAL;
                }
            }
            acc
        })
        .collect();
    // Per sample, the XYZ of its bin contributions minus its XYZ estimate: the spread of that
    // difference gives the noise within which the two images must agree.
    let n = (w * h) as usize;
    let (mut d1, mut d2) = (vec![[0.0f64; 3]; n], vec![[0.0f64; 3]; n]);
    let mut buf = vec![PixelSample::ZERO; n];
    let extras = SampleExtras { first_hit: false, spectral: true };
    for p in 0..passes {
        render_pass_samples(&s, &st, 5, p, extras, &mut buf);
        film.add_samples(&buf);
        for (k, smp) in buf.iter().enumerate() {
            let mut xyz = [0.0f64; 3];
            for l in 0..4 {
                if let Some(b) = bins.index_of(smp.lambda_nm[l]) {
                    for i in 0..3 {
                        xyz[i] += smp.spectral_weight[l] as f64 / bins.width_nm as f64 * cmf_bins[b][i];
                    }
                }
            }
            for i in 0..3 {
                let d = xyz[i] - smp.xyz[i] as f64;
                d1[k][i] += d;
                d2[k][i] += d * d;
            }
        }
    }
    let channels = film.extra_channels();
    assert_eq!(channels.len(), 94);
    assert_eq!(channels[0].0, "S0.362,5nm");
    let (mut num, mut den, mut worst) = (0.0f64, 0.0f64, 0.0f64);
    let (mut total_d, mut total_var) = ([0.0f64; 3], [0.0f64; 3]);
    for k in 0..n {
        let mut xyz = [0.0f64; 3];
        for (b, (_, values)) in channels.iter().enumerate() {
            for i in 0..3 {
                xyz[i] += values[k] as f64 * cmf_bins[b][i];
            }
        }
        let reference = film.mean_xyz(k);
        for i in 0..3 {
            let m = d1[k][i] / passes as f64;
            let se = ((d2[k][i] / passes as f64 - m * m).max(0.0) / passes as f64).sqrt();
            total_d[i] += xyz[i] - reference[i];
            total_var[i] += se * se;
            let d = (xyz[i] - reference[i]).abs();
            num += d;
            den += reference[i].abs();
            // Within 5 standard errors of the difference, + 1e-3 relative for the variation of
            // the spectra inside a bin and f32 rounding.
            let z = d / (5.0 * se + 1e-3 * reference[i].abs() + 1e-7);
            worst = worst.max(z);
            assert!(z < 1.0, "pixel {k} component {i}: bins {:.5} vs image {:.5} (σ of the difference {se:.2e})", xyz[i], reference[i]);
        }
    }
    // Summed over the image, the difference is noise too: no bias beyond 4 of its σ.
    let z_total: Vec<f64> = (0..3).map(|i| total_d[i] / total_var[i].sqrt()).collect();
    eprintln!(
        "spectral bins vs XYZ: mean relative difference per pixel {:.2e}, worst |Δ|/(5σ + 1e-3) {worst:.2}, image sums z = {z_total:.2?}",
        num / den
    );
    for (i, z) in z_total.iter().enumerate() {
        assert!(z.abs() < 4.0, "component {i}: image-wide difference {:.3e} is {z:.1} σ", total_d[i]);
    }
}

#[test]
fn aovs_and_bins_leave_the_image_bit_for_bit_unchanged() {
    let s = tiny_box(9, 7);
    let st = IntegratorSettings::default();
    let mut plain = Film::new(9, 7);
    render(&s, &st, &mut plain, 3, 0..3);
    let mut rich = Film::with_layout(9, 7, FilmLayout::new(Aov::ALL.to_vec(), Some(SpectralBins::parse("400:700:10").unwrap())));
    render(&s, &st, &mut rich, 3, 0..3);
    assert_eq!(plain.sums(), rich.sums());
    assert_eq!(plain.rejected_samples(), rich.rejected_samples());
}

fn rich_layout() -> FilmLayout {
    FilmLayout::new(Aov::ALL.to_vec(), Some(SpectralBins::parse("400:700:20").unwrap()))
}

#[test]
fn resume_carries_aovs_and_bins_bit_exactly() {
    let s = tiny_box(8, 6);
    let st = IntegratorSettings::default();
    let id = RenderIdentity::of_scene(&s, &st);
    let mut straight = Film::with_layout(8, 6, rich_layout());
    render(&s, &st, &mut straight, 9, 0..5);
    let mut first = Film::with_layout(8, 6, rich_layout());
    render(&s, &st, &mut first, 9, 0..2);
    let bytes = Checkpoint::single_run(id.clone(), 9, Some(5), first).to_bytes();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 2, "a film with extras is a version-2 checkpoint");
    let back = Checkpoint::from_bytes(&bytes).unwrap();
    back.check_matches(Path::new("t.ckpt"), &id).unwrap();
    back.check_layout(Path::new("t.ckpt"), &rich_layout()).unwrap();
    let err = back.check_layout(Path::new("t.ckpt"), &FilmLayout::new(vec![Aov::Albedo], None)).unwrap_err().to_string();
    assert!(err.contains("t.ckpt") && err.contains("albedo"), "{err}");
    let (seed, next) = back.resume_point(Path::new("t.ckpt")).unwrap();
    let mut resumed = back.film;
    render(&s, &st, &mut resumed, seed, next..5);
    assert_eq!(resumed, straight, "resumed film (image, AOVs, bins) differs from the uninterrupted one");
    assert!(straight.extra_sums().iter().any(|&v| v != 0.0));
    // Corrupting one extra sum is caught by the checksum.
    let mut bad = Checkpoint::single_run(id, 9, Some(5), straight).to_bytes();
    let k = bad.len() - 20;
    bad[k] ^= 0x40;
    assert!(Checkpoint::from_bytes(&bad).is_err());
}

#[test]
fn merge_carries_aovs_and_bins_as_it_carries_the_image() {
    let s = tiny_box(8, 6);
    let st = IntegratorSettings::default();
    let id = RenderIdentity::of_scene(&s, &st);
    let mut a = Film::with_layout(8, 6, rich_layout());
    render(&s, &st, &mut a, 1, 0..3);
    let mut b = Film::with_layout(8, 6, rich_layout());
    render(&s, &st, &mut b, 2, 0..2);
    let mut expected = a.clone();
    expected.add_film(&b).unwrap();
    let ca = Checkpoint::from_bytes(&Checkpoint::single_run(id.clone(), 1, None, a).to_bytes()).unwrap();
    let cb = Checkpoint::from_bytes(&Checkpoint::single_run(id.clone(), 2, None, b).to_bytes()).unwrap();
    let m = Checkpoint::merge(&[("a".into(), ca.clone()), ("b".into(), cb)]).unwrap();
    assert_eq!(m.film, expected);
    assert_eq!(m.film.samples_per_pixel(), 5);
    let back = Checkpoint::from_bytes(&m.to_bytes()).unwrap();
    assert_eq!(back.film, expected);
    // A part with other AOVs is refused, naming both files.
    let mut other = Film::with_layout(8, 6, FilmLayout::new(vec![Aov::Depth], None));
    render(&s, &st, &mut other, 3, 0..1);
    let co = Checkpoint::single_run(id, 3, None, other);
    let err = format!("{:#}", Checkpoint::merge(&[("a.ckpt".into(), ca), ("o.ckpt".into(), co)]).unwrap_err());
    assert!(err.contains("o.ckpt") && err.contains("a.ckpt") && err.contains("depth"), "{err}");
}

#[test]
fn films_of_the_image_only_still_write_version_1_checkpoints() {
    let s = tiny_box(4, 3);
    let st = IntegratorSettings::default();
    let mut f = Film::new(4, 3);
    render(&s, &st, &mut f, 1, 0..2);
    let bytes = Checkpoint::single_run(RenderIdentity::of_scene(&s, &st), 1, None, f.clone()).to_bytes();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 1);
    let back = Checkpoint::from_bytes(&bytes).unwrap();
    assert_eq!(back.film, f);
    assert!(back.film.layout().is_empty());
    // A version this build does not know is refused with a clear line.
    let mut future = bytes.clone();
    future[8..12].copy_from_slice(&3u32.to_le_bytes());
    let err = Checkpoint::from_bytes(&future).unwrap_err().to_string();
    assert!(err.contains("version 3"), "{err}");
}

#[test]
fn aov_names_and_bins_are_checked() {
    assert_eq!(Aov::parse_list("normal, albedo,normal").unwrap(), vec![Aov::Albedo, Aov::Normal]);
    let err = Aov::parse_list("albedo,emission").unwrap_err();
    assert!(err.contains("emission") && err.contains("albedo, normal, depth, position, object_id, variance"), "{err}");
    for a in Aov::ALL {
        assert_eq!(Aov::from_code(a.code()), Some(a));
        assert_eq!(Aov::from_name(a.name()), Some(a));
    }
    let b = SpectralBins::parse("400:700:10").unwrap();
    assert_eq!((b.count, b.end_nm()), (30, 700.0));
    assert_eq!(b.channel_name(0), "S0.405nm");
    assert_eq!(b.index_of(400.0), Some(0));
    assert_eq!(b.index_of(699.9), Some(29));
    assert_eq!(b.index_of(700.0), None);
    assert_eq!(SpectralBins::parse("360:830:470").unwrap().count, 1);
    for bad in ["300:700:10", "400:900:10", "400:700:0", "400:700:-5", "700:400:10", "400:700:7", "400-700-10", "400:700", "a:b:c", "400:700:nan"] {
        assert!(SpectralBins::parse(bad).is_err(), "{bad} should be refused");
    }
    assert!(SpectralBins::parse("400:700:0").unwrap_err().contains("width"));
    assert!(SpectralBins::parse("300:700:10").unwrap_err().contains("360"));
}
