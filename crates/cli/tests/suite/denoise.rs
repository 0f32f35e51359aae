//! `lucent render --denoise` (cargo feature `denoise`) with Intel Open Image Denoise loaded at
//! run time: a denoised low-sample render is closer to a converged one than the noisy render,
//! and keeps its mean level. Skipped, with the reason printed, where no OIDN library loads.

use render::image_io::read_exr_channels;

use crate::common::{run, Scratch};

fn channel<'a>(chans: &'a [(String, Vec<f32>)], name: &str) -> &'a [f32] {
    &chans.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no channel {name}")).1
}

/// RMSE over the pixels in `keep`.
fn rmse(a: &[&[f32]; 3], b: &[&[f32]; 3], keep: &[bool]) -> f64 {
    let mut s = 0.0;
    let mut n = 0usize;
    for c in 0..3 {
        for ((x, y), k) in a[c].iter().zip(b[c]).zip(keep) {
            if *k {
                s += ((*x - *y) as f64).powi(2);
                n += 1;
            }
        }
    }
    (s / n as f64).sqrt()
}

/// Mean over the pixels in `keep`.
fn mean(a: &[&[f32]; 3], keep: &[bool]) -> f64 {
    let mut s = 0.0;
    let mut n = 0usize;
    for c in a {
        for (v, k) in c.iter().zip(keep) {
            if *k {
                s += *v as f64;
                n += 1;
            }
        }
    }
    s / n as f64
}

#[test]
fn denoised_cornell_box_is_closer_to_the_converged_render() {
    let s = Scratch::new("denoise");
    let probe = run(&s.0, &["render", "--width", "8", "--height", "8", "--spp", "1", "--denoise", "--out", &s.arg("probe.png")]);
    if !probe.status.success() {
        let e = String::from_utf8_lossy(&probe.stderr);
        assert!(e.contains("Intel Open Image Denoise") && e.lines().count() == 1, "{e}");
        eprintln!("skipped: {}", e.trim());
        return;
    }
    let size = ["--width", "96", "--height", "96", "--threads", "2"];
    let noisy = run(&s.0, &[&["render"][..], &size, &["--spp", "4", "--seed", "3", "--denoise", "--out", &s.arg("d.exr")]].concat());
    assert!(noisy.status.success(), "{}", String::from_utf8_lossy(&noisy.stderr));
    let reference = run(&s.0, &[&["render"][..], &size, &["--spp", "512", "--seed", "9", "--out", &s.arg("ref.exr")]].concat());
    assert!(reference.status.success(), "{}", String::from_utf8_lossy(&reference.stderr));
    let d = read_exr_channels(&s.path("d.exr")).unwrap().2;
    let r = read_exr_channels(&s.path("ref.exr")).unwrap().2;
    let den = [channel(&d, "R"), channel(&d, "G"), channel(&d, "B")];
    let raw = [channel(&d, "noisy.R"), channel(&d, "noisy.G"), channel(&d, "noisy.B")];
    let reference = [channel(&r, "R"), channel(&r, "G"), channel(&r, "B")];
    // The lamp (reference above 1) is left out: its saturated pixels say nothing of noise.
    let keep: Vec<bool> = (0..reference[0].len()).map(|i| (0..3).all(|c| reference[c][i] < 1.0)).collect();
    let (e_raw, e_den) = (rmse(&raw, &reference, &keep), rmse(&den, &reference, &keep));
    eprintln!(
        "RMSE to 512 spp (lamp excluded): noisy {e_raw:.4}, denoised {e_den:.4}; means noisy {:.4} denoised {:.4} reference {:.4}",
        mean(&raw, &keep),
        mean(&den, &keep),
        mean(&reference, &keep)
    );
    assert!(e_den < 0.5 * e_raw, "denoised RMSE {e_den} not below half the noisy {e_raw}");
    let (m_den, m_ref) = (mean(&den, &keep), mean(&reference, &keep));
    assert!((m_den / m_ref - 1.0).abs() < 0.02, "mean level moved: {m_den} vs {m_ref}");
    // The guides are the film's own AOVs, written beside the image.
    for name in ["albedo.R", "N.X"] {
        channel(&d, name);
    }
}
