//! Pieces of analysis by synthesis (`lucent fit scene`): a render of a scene as an image, the
//! unbiased squared-error estimate from two independent halves, the convergence plot and the
//! render | reference | error panel.

use crate::compare::Mask;
use render::film::Film;
use render::image_io::Image;
use render::integrator::{render_pass, IntegratorSettings};
use render::scene::Scene;

/// Renders `scene` at its resolution with passes `passes` of `seed`; linear sRGB.
pub fn render_image(scene: &Scene, settings: &IntegratorSettings, seed: u64, passes: std::ops::Range<u64>) -> Image {
    let (w, h) = scene.resolution();
    let mut film = Film::new(w, h);
    let mut buf = vec![[0.0f32; 3]; w as usize * h as usize];
    for pass in passes {
        render_pass(scene, settings, seed, pass, &mut buf);
        film.add_pass(&buf);
    }
    film.to_image()
}

/// mean over pixels and channels of (a − r)(b − r), `a` and `b` first multiplied by `m` if given.
pub fn cross_error(a: &Image, b: &Image, r: &Image, m: Option<&[[f64; 3]; 3]>, mask: &Mask) -> f64 {
    let (a, b) = match m {
        Some(m) => (crate::compare::apply_color_matrix(a, m), crate::compare::apply_color_matrix(b, m)),
        None => (a.clone(), b.clone()),
    };
    let mut sum = 0.0;
    for (((pa, pb), pr), _) in a.rgb.iter().zip(&b.rgb).zip(&r.rgb).zip(&mask.inside).filter(|(_, &inside)| inside) {
        for c in 0..3 {
            sum += (pa[c] as f64 - pr[c] as f64) * (pb[c] as f64 - pr[c] as f64);
        }
    }
    sum / (3 * mask.count().max(1)) as f64
}

/// Convergence plot: best objective value (named `label`) against iteration, a small hand-written SVG.
pub fn convergence_svg(history: &[f64], label: &str) -> String {
    let (w, h, ml, mr, mt, mb) = (640.0, 400.0, 80.0, 20.0, 30.0, 50.0);
    let finite: Vec<f64> = history.iter().cloned().filter(|v| v.is_finite()).collect();
    let ymax = finite.iter().cloned().fold(0.0f64, f64::max).max(1e-300);
    let ymin = finite.iter().cloned().fold(0.0f64, f64::min);
    let n = history.len().max(2) - 1;
    let px = |i: usize| ml + (w - ml - mr) * i as f64 / n as f64;
    let py = |v: f64| mt + (h - mt - mb) * (1.0 - ((v - ymin) / (ymax - ymin)).clamp(0.0, 1.0));
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{}\" y=\"20\" font-family=\"sans-serif\" font-size=\"14\" text-anchor=\"middle\">lucent fit scene: {label} against iteration</text>\n",
        w / 2.0
    );
    // Axes with ticks at 0, 1/4, …, 1 of the ranges.
    s += &format!(
        "<line x1=\"{ml}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"black\"/>\n<line x1=\"{ml}\" y1=\"{mt}\" x2=\"{ml}\" y2=\"{}\" stroke=\"black\"/>\n",
        h - mb,
        w - mr,
        h - mb,
        h - mb
    );
    for k in 0..=4 {
        let v = ymin + (ymax - ymin) * k as f64 / 4.0;
        let y = py(v);
        s += &format!(
            "<line x1=\"{}\" y1=\"{y:.1}\" x2=\"{ml}\" y2=\"{y:.1}\" stroke=\"black\"/><text x=\"{}\" y=\"{:.1}\" font-family=\"sans-serif\" font-size=\"11\" text-anchor=\"end\">{v:.3e}</text>\n",
            ml - 4.0,
            ml - 6.0,
            y + 4.0
        );
        let i = (n as f64 * k as f64 / 4.0).round() as usize;
        let x = px(i);
        s += &format!(
            "<line x1=\"{x:.1}\" y1=\"{}\" x2=\"{x:.1}\" y2=\"{}\" stroke=\"black\"/><text x=\"{x:.1}\" y=\"{}\" font-family=\"sans-serif\" font-size=\"11\" text-anchor=\"middle\">{i}</text>\n",
            h - mb,
            h - mb + 4.0,
            h - mb + 17.0
        );
    }
    s += &format!(
        "<text x=\"{}\" y=\"{}\" font-family=\"sans-serif\" font-size=\"12\" text-anchor=\"middle\">iteration</text>\n\
         <text x=\"16\" y=\"{}\" font-family=\"sans-serif\" font-size=\"12\" text-anchor=\"middle\" transform=\"rotate(-90 16 {})\">{label}</text>\n",
        (ml + w - mr) / 2.0,
        h - 10.0,
        (mt + h - mb) / 2.0,
        (mt + h - mb) / 2.0
    );
    let points: Vec<String> = history
        .iter()
        .enumerate()
        .filter(|(_, v)| v.is_finite())
        .map(|(i, &v)| format!("{:.1},{:.1}", px(i), py(v)))
        .collect();
    s += &format!("<polyline fill=\"none\" stroke=\"#1f77b4\" stroke-width=\"2\" points=\"{}\"/>\n</svg>\n", points.join(" "));
    s
}

/// Images side by side (same height), for the render | reference | error panel.
pub fn side_by_side(images: &[&Image]) -> Image {
    let h = images.iter().map(|i| i.height).max().unwrap_or(0);
    let w: u32 = images.iter().map(|i| i.width).sum();
    let mut out = Image::new(w, h);
    let mut x0 = 0;
    for img in images {
        for y in 0..img.height {
            for x in 0..img.width {
                out.set(x0 + x, y, img.get(x, y));
            }
        }
        x0 += img.width;
    }
    out
}
