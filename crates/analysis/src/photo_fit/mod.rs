//! Appearance fit on photographs (`lucent fit photo`): per-label Lambertian albedos, the
//! projector's scale and black level, the ambient light and the camera's response (black level,
//! gain, gamma, a white-preserving 3×3 colour matrix) from one or more photographs at once, each
//! with the projector pattern it was taken under.
//!
//! Analysis by synthesis on basis renders: the scene is rendered once per label and light
//! ([`basis`], common random numbers, the `direct` integrator), every photograph is then predicted
//! by the closed-form model of [`model`], and the parameters are found by Levenberg–Marquardt
//! on the code values of all photographs ([`lm`], normal equations accumulated over pixels, so
//! millions of residuals cost no Jacobian storage). The refinement runs in the steps of the
//! tutorial's sequence of images (Stets et al. 2017; Frisvad, *Material appearance modelling*,
//! 3DV 2018): camera response and colour correction at the starting materials, then the per-label
//! albedos, then the lights, then all free parameters jointly, whose Jacobian gives the
//! uncertainties (covariance σ²(JᵀJ)⁻¹). After each step every photograph is compared with its
//! prediction, over the whole labelled image and per label region.

pub mod basis;
pub mod lm;
pub mod model;
pub mod response;

use std::time::Instant;

use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use basis::{Basis, Plane};
use lm::{levenberg_marquardt, standard_errors, LmResult, Normal};
use model::{camera_response, linear_render, radius2, Params, PixelBasis};

/// One photograph: code values (1 = full scale; an 8-bit code / 255) per pixel and channel, at
/// the basis' resolution.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Name in reports (the file's stem).
    pub name: String,
    /// Codes, row-major from the top row.
    pub codes: Vec<[f32; 3]>,
}

/// Options of [`fit`].
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Parameters held at their starting values: `gain`, `black_level`, `gamma`, `projector`,
    /// `projector_black`, `ambient`, `color`, `vignetting` or a label's name. Empty: hold the projector (the
    /// ambient light in a scene without one).
    pub hold: Vec<String>,
    /// Fit the colour matrix in the response step (else it stays the identity).
    pub color_matrix: bool,
    /// Fit the radial vignetting V(r) = 1 + v₂ r² + v₄ r⁴ in the response and joint steps (else
    /// it stays 1).
    pub vignetting: bool,
    /// Starting gamma of the camera response.
    pub gamma: f64,
    /// Starting black level (codes) and gain.
    pub black_level: f64,
    /// Starting gain.
    pub gain: f64,
    /// Most accepted LM steps per refinement step.
    pub max_iterations: usize,
    /// Photo pixels with any channel at or above this code are left out (saturation).
    pub saturation: f64,
    /// Only every `stride`-th pixel of each row and column enters the fit (1: all).
    pub stride: usize,
    /// Which frames enter the fit (None: all); every frame is evaluated after each step.
    pub fit_frames: Option<Vec<bool>>,
    /// Pixels within this many pixels (square neighbourhood) of another label's region or of an
    /// unlabelled pixel are left out of the fit and its errors ([`interior`]; 0: none).
    pub edge_px: usize,
    /// Pixels where more than this share of the light comes from outside the labels are left
    /// out ([`regions`]; default [`MAX_BACKGROUND`]).
    pub max_background: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions { hold: vec![], color_matrix: false, vignetting: false, gamma: 2.2, black_level: 0.0, gain: 1.0, max_iterations: 100, saturation: 0.99, stride: 1, fit_frames: None, edge_px: 0, max_background: MAX_BACKGROUND }
    }
}

/// Error metrics of predictions against photographs, in linear sRGB (codes decoded with the sRGB
/// curve, as `lucent compare` reads a PNG).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Metrics {
    /// Root-mean-square difference over pixels and channels (linear, 1 = full scale).
    pub rmse: f64,
    /// ‖prediction − photo‖ / ‖photo‖ over the pixels and channels.
    pub rel_rmse: f64,
    /// Mean CIEDE2000 (CIELAB with the D65 white, Y = 1 the reference white).
    pub delta_e2000: f64,
    /// Pixels compared.
    pub pixels: usize,
}

/// Sums from which [`Metrics`] are formed.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    se: f64,
    ref2: f64,
    de: f64,
    n: usize,
}

impl Sums {
    fn add(&mut self, pred: [f64; 3], photo: [f64; 3]) {
        let a = pred.map(optics::color::srgb_decode);
        let b = photo.map(optics::color::srgb_decode);
        for c in 0..3 {
            self.se += (a[c] - b[c]) * (a[c] - b[c]);
            self.ref2 += b[c] * b[c];
        }
        let (la, lb) = (crate::compare::linear_srgb_to_lab(a), crate::compare::linear_srgb_to_lab(b));
        self.de += crate::compare::delta_e2000(la, lb);
        self.n += 1;
    }
    fn merge(&mut self, o: &Sums) {
        self.se += o.se;
        self.ref2 += o.ref2;
        self.de += o.de;
        self.n += o.n;
    }
    fn metrics(&self) -> Metrics {
        let n = self.n.max(1) as f64;
        Metrics {
            rmse: (self.se / (3.0 * n)).sqrt(),
            rel_rmse: (self.se / self.ref2.max(1e-300)).sqrt(),
            delta_e2000: self.de / n,
            pixels: self.n,
        }
    }
}

/// Errors of one photograph: over every labelled pixel, and per label region.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameMetrics {
    /// The frame's name.
    pub name: String,
    /// Over all labelled, unsaturated pixels.
    pub whole: Metrics,
    /// Per label (region = the label whose basis dominates the pixel).
    pub per_label: Vec<Metrics>,
}

/// One step of the refinement and the errors after it.
#[derive(Clone, Debug)]
pub struct Step {
    /// `initial`, `response`, `albedo`, `light` or `joint`.
    pub name: String,
    /// Names of the parameters it adjusted.
    pub fitted: Vec<String>,
    /// Parameters after the step.
    pub params: Params,
    /// LM steps taken.
    pub iterations: usize,
    /// Wall-clock seconds of the step.
    pub seconds: f64,
    /// Per frame, after the step.
    pub frames: Vec<FrameMetrics>,
    /// Over all frames together.
    pub total: Metrics,
}

/// Result of [`fit`].
#[derive(Clone, Debug)]
pub struct PhotoFit {
    /// The steps, `initial` first.
    pub steps: Vec<Step>,
    /// Final parameters.
    pub params: Params,
    /// Standard error of each parameter from the joint step (None: held, or not fixed by the data).
    pub std_errors: Vec<Option<f64>>,
    /// Names of the parameters, parallel to `params.x`.
    pub names: Vec<String>,
    /// Region of each pixel: the dominant label's index, −1 where no label is seen.
    pub regions: Vec<i32>,
    /// Σr² / (N − n) of the joint step, code units².
    pub residual_variance: f64,
    /// Wall-clock seconds of the whole fit (basis renders not included).
    pub seconds: f64,
}

/// Default of [`FitOptions::max_background`]: a pixel is compared only where no sample of its
/// basis renders left the labelled surfaces (the share of 10⁻³ tolerates rounding, not a sample).
pub const MAX_BACKGROUND: f64 = 1e-3;

/// Per-pixel region: the dominant label by the luminance of its white-projector and ambient
/// basis, or −1 where no label is seen or where more than `max_background` of the pixel's light
/// comes from the rest of the scene (objects that are not labels, the environment seen
/// directly). Such a pixel is only partly covered by the labels: through a hole of a scanned
/// mesh it shows the constant environment, which a photograph shows as whatever lies behind,
/// and the share the labels cover is known only to the micropolygons' accuracy. The share is
/// taken from the ambient basis when the scene has an environment (labels and a directly seen
/// environment are then of the same order), else from the projector basis; 1 (or more) keeps
/// every pixel a label reaches.
pub fn regions(basis: &Basis, max_background: f64) -> Vec<i32> {
    let n = basis.width as usize * basis.height as usize;
    let k = basis.labels.len();
    let y = |p: [f32; 3]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
    let share_of = |planes: &[Plane], i: usize| -> Option<f64> {
        let rest = y(planes[k][i]);
        let all: f64 = (0..k).map(|l| y(planes[l][i])).sum::<f64>() + rest;
        (all > 0.0).then(|| rest / all)
    };
    (0..n)
        .map(|i| {
            let mut best = (-1i32, 1e-12f64);
            for l in 0..k {
                let v = y(basis.flood[l][i]) + y(basis.ambient[l][i]);
                if v > best.1 {
                    best = (l as i32, v);
                }
            }
            if best.0 >= 0 && max_background < 1.0 {
                let share = share_of(&basis.ambient, i).or_else(|| share_of(&basis.flood, i)).unwrap_or(0.0);
                if share > max_background {
                    return -1;
                }
            }
            best.0
        })
        .collect()
}

/// `regions` (row-major, `width` wide) with every pixel set to −1 that has a pixel of another
/// region (or an unlabelled one) within `px` pixels in x and y. A pixel at a label boundary mixes
/// two labels in a proportion that the labelled micropolygons (about a pixel each) know only to
/// a fraction of a pixel, and a pixel at an object's outline depends on the registration to a
/// fraction of a pixel; leaving a band of `px` pixels out keeps those errors out of the fit.
pub fn interior(regions: &[i32], width: usize, height: usize, px: usize) -> Vec<i32> {
    if px == 0 {
        return regions.to_vec();
    }
    let r = px as isize;
    (0..regions.len())
        .map(|i| {
            let (x, y) = ((i % width) as isize, (i / width) as isize);
            let own = regions[i];
            let same = (-r..=r).all(|dy| {
                (-r..=r).all(|dx| {
                    let (u, v) = (x + dx, y + dy);
                    u < 0 || v < 0 || u >= width as isize || v >= height as isize || regions[(v * width as isize + u) as usize] == own
                })
            });
            if same {
                own
            } else {
                -1
            }
        })
        .collect()
}

/// The basis of pixel `i` of frame `f`, per label then the rest.
fn pixel_basis(basis: &Basis, f: usize, i: usize, out: &mut Vec<PixelBasis>) {
    out.clear();
    for t in 0..=basis.labels.len() {
        out.push(PixelBasis { pattern: basis.frames[f][t][i], flood: basis.flood[t][i], ambient: basis.ambient[t][i] });
    }
    // The glossy labels' coatings are lit like the rest of the scene and do not depend on any
    // albedo: they join the rest.
    if basis.specular {
        let s = basis.labels.len() + 1;
        let r = out.last_mut().expect("the rest");
        for c in 0..3 {
            r.pattern[c] += basis.frames[f][s][i][c];
            r.flood[c] += basis.flood[s][i][c];
            r.ambient[c] += basis.ambient[s][i][c];
        }
    }
}

/// Predicted codes of frame `f` under `params`, every pixel.
pub fn predict(basis: &Basis, params: &Params, f: usize) -> Vec<[f64; 3]> {
    let (w, h) = (basis.width as usize, basis.height as usize);
    let k = basis.labels.len();
    (0..w * h)
        .into_par_iter()
        .map_init(Vec::new, |buf, i| {
            pixel_basis(basis, f, i, buf);
            camera_response(params, linear_render(params, &buf[..k], &buf[k], None), radius2(i, w, h), None)
        })
        .collect()
}

/// Pixels per chunk of the error sums, and rows per chunk of the normal equations: fixed, so
/// that the parallel sums do not depend on the threads.
const SUM_CHUNK: usize = 1 << 14;
const ROW_CHUNK: usize = 16;

/// Whether pixel `i` of `frame` is compared: labelled and not saturated.
fn usable(regions: &[i32], frame: &Frame, i: usize, saturation: f64) -> bool {
    regions[i] >= 0 && frame.codes[i].iter().all(|&v| (v as f64) < saturation)
}

/// Errors of the predicted codes `pred` (every pixel) against `frame` over its usable pixels.
pub fn frame_metrics(pred: &[[f64; 3]], frame: &Frame, regions: &[i32], labels: usize, saturation: f64) -> FrameMetrics {
    let k = labels;
    // Fixed chunks summed in order: the same sums on any number of threads.
    let n = pred.len();
    let chunks: Vec<(Sums, Vec<Sums>)> = (0..n.div_ceil(SUM_CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut w, mut per) = (Sums::default(), vec![Sums::default(); k]);
            for i in c * SUM_CHUNK..((c + 1) * SUM_CHUNK).min(n) {
                if usable(regions, frame, i, saturation) {
                    let photo = frame.codes[i].map(|v| v as f64);
                    let p = pred[i].map(|v| v.clamp(0.0, 1.0));
                    w.add(p, photo);
                    per[regions[i] as usize].add(p, photo);
                }
            }
            (w, per)
        })
        .collect();
    let (mut whole, mut per) = (Sums::default(), vec![Sums::default(); k]);
    for (b, pb) in &chunks {
        whole.merge(b);
        for (x, y) in per.iter_mut().zip(pb) {
            x.merge(y);
        }
    }
    FrameMetrics { name: frame.name.clone(), whole: whole.metrics(), per_label: per.iter().map(Sums::metrics).collect() }
}

/// Errors of the predictions under `params` against every frame.
pub fn evaluate(basis: &Basis, frames: &[Frame], regions: &[i32], params: &Params, saturation: f64) -> Vec<FrameMetrics> {
    frames
        .iter()
        .enumerate()
        .map(|(f, frame)| frame_metrics(&predict(basis, params, f), frame, regions, basis.labels.len(), saturation))
        .collect()
}

/// The check by full renders: the scene rendered with the fitted albedos and lights (`direct`,
/// `spp` passes of `seed`, which should differ from the basis' seed) under each frame's pattern,
/// through the fitted camera; codes per frame and the seconds of each render. The scene is
/// restored afterwards.
pub fn verify_renders(
    scene: &mut render::scene::Scene,
    labels: &[basis::Label],
    params: &Params,
    patterns: &[Option<Vec<f32>>],
    spp: u64,
    seed: u64,
) -> Result<(Vec<Vec<[f64; 3]>>, Vec<f64>)> {
    let (w, h) = {
        let (w, h) = scene.resolution();
        (w as usize, h as usize)
    };
    let (lin, secs) = verify_linear(scene, labels, params, patterns, spp, seed)?;
    Ok((lin.iter().map(|l| codes(params, l, 1.0, w, h)).collect(), secs))
}

/// The renders of [`verify_renders`] before the camera: linear sRGB per frame.
pub fn verify_linear(
    scene: &mut render::scene::Scene,
    labels: &[basis::Label],
    params: &Params,
    patterns: &[Option<Vec<f32>>],
    spp: u64,
    seed: u64,
) -> Result<(Vec<Plane>, Vec<f64>)> {
    let saved = (scene.materials.clone(), scene.lights.clone());
    let albedo: Vec<[f64; 3]> = (0..labels.len()).map(|k| params.albedo(k)).collect();
    basis::apply_fit(scene, labels, &albedo, params.get(model::PROJECTOR), params.get(model::AMBIENT));
    let mut out = vec![];
    let mut secs = vec![];
    let mut result = Ok(());
    for pat in patterns {
        let t = Instant::now();
        match basis::render_frame(scene, pat.as_deref(), params.get(model::PROJECTOR_BLACK), spp, seed) {
            Ok(lin) => {
                secs.push(t.elapsed().as_secs_f64());
                out.push(lin);
            }
            Err(e) => {
                result = Err(e);
                break;
            }
        }
    }
    scene.materials = saved.0;
    scene.lights = saved.1;
    result.map(|_| (out, secs))
}

/// Codes of the linear render `lin` (`w × h`) scaled by `exposure` through the camera of `params`.
pub fn codes(params: &Params, lin: &Plane, exposure: f64, w: usize, h: usize) -> Vec<[f64; 3]> {
    lin.par_iter().enumerate().map(|(i, x)| camera_response(params, x.map(|v| exposure * v as f64), radius2(i, w, h), None)).collect()
}

/// The exposure factor s (linear radiance × s before the camera, in [1/8, 8]) that minimises the
/// relative RMSE of `lin`'s codes against `frames` over `regions`, by golden-section search in
/// ln s; with the metrics per frame at that s. A diagnostic of a prediction: how much of its
/// error one factor common to every pixel and frame (the camera's exposure, the light's output)
/// would take, which a fit on another capture cannot know.
#[allow(clippy::too_many_arguments)]
pub fn exposure_match(params: &Params, lin: &[Plane], frames: &[Frame], regions: &[i32], labels: usize, saturation: f64, w: usize, h: usize) -> (f64, Vec<FrameMetrics>) {
    let eval = |ln_s: f64| -> (f64, Vec<FrameMetrics>) {
        let m: Vec<FrameMetrics> = lin.iter().zip(frames).map(|(l, f)| frame_metrics(&codes(params, l, ln_s.exp(), w, h), f, regions, labels, saturation)).collect();
        (total(&m).rel_rmse, m)
    };
    let (mut a, mut b) = ((1.0f64 / 8.0).ln(), 8.0f64.ln());
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (eval(c).0, eval(d).0);
    while b - a > 1e-4 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = eval(c).0;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = eval(d).0;
        }
    }
    let ln_s = 0.5 * (a + b);
    (ln_s.exp(), eval(ln_s).1)
}

/// Pixel-count-weighted combination of frame metrics (RMSE and relative RMSE recombined from
/// their sums).
pub fn total(frames: &[FrameMetrics]) -> Metrics {
    let (mut se, mut ref2, mut de, mut n) = (0.0, 0.0, 0.0, 0usize);
    for f in frames {
        let m = &f.whole;
        let nn = m.pixels as f64;
        se += m.rmse * m.rmse * 3.0 * nn;
        ref2 += if m.rel_rmse > 0.0 { m.rmse * m.rmse * 3.0 * nn / (m.rel_rmse * m.rel_rmse) } else { 0.0 };
        de += m.delta_e2000 * nn;
        n += m.pixels;
    }
    let nf = n.max(1) as f64;
    Metrics { rmse: (se / (3.0 * nf)).sqrt(), rel_rmse: (se / ref2.max(1e-300)).sqrt(), delta_e2000: de / nf, pixels: n }
}

struct Acc {
    cost: f64,
    n: usize,
    jtj: Vec<f64>,
    jtr: Vec<f64>,
    buf: Vec<PixelBasis>,
    dx: [Vec<f64>; 3],
    jy: [Vec<f64>; 3],
    jy2: [Vec<f64>; 3],
}

/// Codes of pixel `i` of frame `f` and, with `jac`, their derivatives (into `a.jy` or `a.jy2`).
fn pixel_codes(basis: &Basis, f: usize, i: usize, params: &Params, a: &mut Acc, jac: bool, second: bool) -> [f64; 3] {
    let k = basis.labels.len();
    let r2 = radius2(i, basis.width as usize, basis.height as usize);
    pixel_basis(basis, f, i, &mut a.buf);
    if jac {
        for c in 0..3 {
            a.dx[c].iter_mut().for_each(|v| *v = 0.0);
        }
        let xl = linear_render(params, &a.buf[..k], &a.buf[k], Some(&mut a.dx));
        let out = if second { &mut a.jy2 } else { &mut a.jy };
        camera_response(params, xl, r2, Some((&a.dx, out)))
    } else {
        camera_response(params, linear_render(params, &a.buf[..k], &a.buf[k], None), r2, None)
    }
}

/// Cost and, with `jacobian`, normal equations over `free`, summed over the usable pixels of all
/// frames. With one basis: ½Σr² and JᵀJ, Jᵀr. With two independent bases a and b (`second`), the
/// unbiased form: ½Σ r_a r_b, whose expectation has no term from the bases' Monte Carlo noise (a
/// plain Σr² over a noisy basis is lowest for parameters that damp that noise: errors in the
/// variables), with the symmetrised ½Σ(J_aᵀJ_b + J_bᵀJ_a) and ½Σ(J_aᵀ r_b + J_bᵀ r_a).
#[allow(clippy::too_many_arguments)]
fn normal_equations(
    basis: &Basis,
    second: Option<&Basis>,
    frames: &[Frame],
    regions: &[i32],
    params: &Params,
    free: &[usize],
    jacobian: bool,
    opts: &FitOptions,
) -> Normal {
    let (w, h) = (basis.width as usize, basis.height as usize);
    let k = basis.labels.len();
    let np = params.len();
    let nf = free.len();
    let stride = opts.stride.max(1);
    let fitted = |f: usize| opts.fit_frames.as_ref().map_or(true, |v| v.get(f).copied().unwrap_or(false));
    let rows: Vec<(usize, usize)> = (0..frames.len()).filter(|&f| fitted(f)).flat_map(|f| (0..h).step_by(stride).map(move |y| (f, y))).collect();
    let new_acc = || Acc {
        cost: 0.0,
        n: 0,
        jtj: vec![0.0; nf * nf],
        jtr: vec![0.0; nf],
        buf: Vec::with_capacity(k + 1),
        dx: std::array::from_fn(|_| vec![0.0; np]),
        jy: std::array::from_fn(|_| vec![0.0; np]),
        jy2: std::array::from_fn(|_| vec![0.0; np]),
    };
    // Fixed chunks of rows summed in order, so that the cost and the normal equations (whose
    // comparisons steer the minimiser) are the same bits on any number of threads.
    let partial: Vec<Acc> = rows
        .par_chunks(ROW_CHUNK)
        .map(|chunk| chunk.iter().fold(new_acc(), |mut a, &(f, y)| {
            let frame = &frames[f];
            for x in (0..w).step_by(stride) {
                let i = y * w + x;
                if !usable(regions, frame, i, opts.saturation) {
                    continue;
                }
                let ya = pixel_codes(basis, f, i, params, &mut a, jacobian, false);
                let yb = match second {
                    Some(b2) => pixel_codes(b2, f, i, params, &mut a, jacobian, true),
                    None => ya,
                };
                for c in 0..3 {
                    let ra = ya[c] - frame.codes[i][c] as f64;
                    let rb = yb[c] - frame.codes[i][c] as f64;
                    a.cost += 0.5 * ra * rb;
                    a.n += 1;
                    if !jacobian {
                        continue;
                    }
                    let (ja, jb) = (&a.jy[c], if second.is_some() { &a.jy2[c] } else { &a.jy[c] });
                    for (p, &ip) in free.iter().enumerate() {
                        let (jap, jbp) = (ja[ip], jb[ip]);
                        if jap == 0.0 && jbp == 0.0 {
                            continue;
                        }
                        a.jtr[p] += 0.5 * (jap * rb + jbp * ra);
                        for (q, &iq) in free.iter().enumerate().skip(p) {
                            a.jtj[p * nf + q] += 0.5 * (jap * jb[iq] + jbp * ja[iq]);
                        }
                    }
                }
            }
            a
        }))
        .collect();
    let acc = partial.into_iter().fold(new_acc(), |mut a, b| {
        a.cost += b.cost;
        a.n += b.n;
        for (x, y) in a.jtj.iter_mut().zip(&b.jtj) {
            *x += y;
        }
        for (x, y) in a.jtr.iter_mut().zip(&b.jtr) {
            *x += y;
        }
        a
    });
    let system = jacobian.then(|| {
        let m = DMatrix::from_fn(nf, nf, |p, q| if q >= p { acc.jtj[p * nf + q] } else { acc.jtj[q * nf + p] });
        (m, DVector::from_vec(acc.jtr.clone()))
    });
    Normal { cost: acc.cost, residuals: acc.n, system }
}

/// Names a `--hold` may take besides the labels.
pub const HOLD_NAMES: [&str; 8] = ["gain", "black_level", "gamma", "projector", "projector_black", "ambient", "color", "vignetting"];

/// Fits `frames` (one per basis frame, in order) from `start`. Errors on an unknown hold, on
/// frames of another size, when no pixel is usable, and when the held parameters leave the
/// scale free.
///
/// With `second`, a basis of the same scene and frames from an independent seed, the fit
/// minimises the unbiased cross error (see `normal_equations`) and the reported errors use the
/// mean of the two bases (pass [`basis::average`] of the two as `basis` then, and the halves as
/// `halves`).
pub fn fit(basis: &Basis, halves: Option<(&Basis, &Basis)>, frames: &[Frame], start: &Params, opts: &FitOptions) -> Result<PhotoFit> {
    let t0 = Instant::now();
    let k = basis.labels.len();
    let n_px = basis.width as usize * basis.height as usize;
    if frames.len() != basis.frames.len() {
        bail!("{} photographs but {} basis frames", frames.len(), basis.frames.len());
    }
    for f in frames {
        if f.codes.len() != n_px {
            bail!("{}: {} pixels, the render {}×{}", f.name, f.codes.len(), basis.width, basis.height);
        }
    }
    let label_names: Vec<String> = basis.labels.iter().map(|l| l.name.clone()).collect();
    let has_projector = basis.flood.iter().any(|p| p.iter().any(|v| v.iter().any(|&c| c != 0.0)));
    let has_ambient = basis.ambient.iter().any(|p| p.iter().any(|v| v.iter().any(|&c| c != 0.0)));
    let default_hold = if has_projector { "projector" } else { "ambient" };
    let mut hold = if opts.hold.is_empty() { vec![default_hold.to_string()] } else { opts.hold.clone() };
    hold.dedup();
    for hname in &hold {
        if !HOLD_NAMES.contains(&hname.as_str()) && !label_names.contains(hname) {
            bail!("--hold {hname}: unknown (use {} or a label: {})", HOLD_NAMES.join(", "), label_names.join(", "));
        }
    }
    let held = |name: &str| hold.iter().any(|h| h == name);
    // ρ → sρ with P, A → P/s, A/s, and g → g t^(1/γ) with P, A → P/t, A/t leave the codes as they
    // are: holding a light that is there, or the gain and a label, fixes both.
    let scale_fixed = (has_projector && held("projector")) || (has_ambient && held("ambient")) || (held("gain") && label_names.iter().any(|l| held(l)));
    if !scale_fixed {
        bail!(
            "the fit needs a scale: hold the {default_hold} (--hold {default_hold}) or the gain and a reference label (--hold gain --hold {})",
            label_names[0]
        );
    }
    let regions = interior(&regions(basis, opts.max_background), basis.width as usize, basis.height as usize, opts.edge_px);
    let usable_px: usize = frames.iter().map(|f| (0..n_px).filter(|&i| usable(&regions, f, i, opts.saturation)).count()).sum();
    if usable_px == 0 {
        bail!("no photograph pixel sees a label without saturating");
    }
    let g = |i: usize| 3 * k + i;
    let mut resp: Vec<usize> = vec![];
    for (name, idx) in [("black_level", model::BLACK_LEVEL), ("gain", model::GAIN), ("gamma", model::GAMMA)] {
        if !held(name) {
            resp.push(g(idx));
        }
    }
    if opts.color_matrix && !held("color") {
        resp.extend((0..6).map(|t| g(model::COLOR + t)));
    }
    let albedo: Vec<usize> = (0..k).filter(|&l| !held(&label_names[l])).flat_map(|l| 3 * l..3 * l + 3).collect();
    let mut light: Vec<usize> = vec![];
    if has_projector && !held("projector") {
        light.push(g(model::PROJECTOR));
    }
    if has_projector && !held("projector_black") {
        light.push(g(model::PROJECTOR_BLACK));
    }
    if has_ambient && !held("ambient") {
        light.push(g(model::AMBIENT));
    }
    let vignetting: Vec<usize> = if opts.vignetting && !held("vignetting") { vec![g(model::VIGNETTING), g(model::VIGNETTING + 1)] } else { vec![] };
    resp.extend(&vignetting);
    let mut joint: Vec<usize> = albedo.iter().chain(&light).cloned().collect();
    joint.extend(resp.iter().cloned().filter(|&i| i < g(model::COLOR) || vignetting.contains(&i)));
    joint.sort();

    let names: Vec<String> = (0..start.len()).map(|i| start.name(i, &label_names)).collect();
    let mut params = start.clone();
    params.clamp();
    let mut steps = vec![];
    let record = |name: &str, fitted: &[usize], params: &Params, iterations: usize, seconds: f64| -> Step {
        let fm = evaluate(basis, frames, &regions, params, opts.saturation);
        Step {
            name: name.to_string(),
            fitted: fitted.iter().map(|&i| names[i].clone()).collect(),
            params: params.clone(),
            iterations,
            seconds,
            total: total(&fm),
            frames: fm,
        }
    };
    steps.push(record("initial", &[], &params, 0, 0.0));
    let run = |params: &Params, free: &[usize]| -> Result<LmResult> {
        let labels = params.labels;
        levenberg_marquardt(
            |x, jac| {
                let p = Params { labels, x: x.to_vec() };
                Ok(match halves {
                    Some((a, b)) => normal_equations(a, Some(b), frames, &regions, &p, free, jac, opts),
                    None => normal_equations(basis, None, frames, &regions, &p, free, jac, opts),
                })
            },
            |x| {
                let mut p = Params { labels, x: std::mem::take(x) };
                p.clamp();
                *x = p.x;
            },
            &params.x,
            free,
            opts.max_iterations,
            1e-7,
        )
    };
    let mut last: Option<LmResult> = None;
    for (name, free) in [("response", &resp), ("albedo", &albedo), ("light", &light), ("joint", &joint)] {
        let t = Instant::now();
        let r = run(&params, free)?;
        params.x = r.x.clone();
        let secs = t.elapsed().as_secs_f64();
        steps.push(record(name, free, &params, r.iterations, secs));
        if name == "joint" {
            last = Some(r);
        }
    }
    let r = last.expect("the joint step ran");
    let se = standard_errors(&r);
    let mut std_errors = vec![None; params.len()];
    for (j, &i) in joint.iter().enumerate() {
        std_errors[i] = se[j];
    }
    let residual_variance = 2.0 * r.cost / (r.residuals.saturating_sub(joint.len()).max(1)) as f64;
    Ok(PhotoFit { steps, params, std_errors, names, regions, residual_variance, seconds: t0.elapsed().as_secs_f64() })
}

/// What [`fit_roughness`] found.
pub struct RoughnessFit {
    /// The coating roughness α of the glossy labels with the least residual variance.
    pub alpha: f64,
    /// (α, residual variance of the joint step) of every roughness tried, in the order tried.
    pub profile: Vec<(f64, f64)>,
    /// The fit at `alpha`.
    pub fit: PhotoFit,
    /// Its basis (the mean of the two halves) and the two halves.
    pub basis: Basis,
    /// The two halves of the basis (seeds `seed` and `seed + 1`).
    pub halves: (Basis, Basis),
}

/// The glossy labels' coating roughness by a profile search: for each α tried, every glossy
/// label's roughness is set to α, the basis is rendered (two halves of `spp / 2` samples, seeds
/// `seed` and `seed + 1`, the same for every α: common random numbers) and the fit run from
/// `start`; the α whose joint step leaves the least residual variance Σr²/(N − n) wins. The
/// search takes 7 values of ln α spaced evenly over [ln 0.02, ln 1], then 6 golden-section steps
/// in ln α between the neighbours of the best. The scene is left with the best α.
/// Errors when no label is glossy, or as [`fit`] does.
#[allow(clippy::too_many_arguments)]
pub fn fit_roughness(
    scene: &mut render::scene::Scene,
    patterns: &[Option<Vec<f32>>],
    frames: &[Frame],
    start: &Params,
    opts: &FitOptions,
    spp: u64,
    seed: u64,
    progress: &dyn Fn(f64, f64),
) -> Result<RoughnessFit> {
    let mut labels = basis::scene_labels(scene)?;
    if !labels.iter().any(|l| l.gloss.is_some()) {
        bail!("no glossy label: a roughness needs a label of type `plastic`");
    }
    let half = (spp / 2).max(1);
    let mut profile: Vec<(f64, f64)> = vec![];
    let mut best: Option<RoughnessFit> = None;
    let mut eval = |ln_a: f64, labels: &mut Vec<basis::Label>, scene: &mut render::scene::Scene| -> Result<f64> {
        let a = ln_a.exp();
        basis::set_roughness(scene, labels, a as f32);
        let ha = basis::render_basis(scene, patterns, half, seed)?;
        let hb = basis::render_basis(scene, patterns, half, seed + 1)?;
        let b = basis::average(&ha, &hb);
        let r = fit(&b, Some((&ha, &hb)), frames, start, opts)?;
        let v = r.residual_variance;
        progress(a, v);
        profile.push((a, v));
        if best.as_ref().is_none_or(|x| v < x.fit.residual_variance) {
            best = Some(RoughnessFit { alpha: a, profile: vec![], fit: r, basis: b, halves: (ha, hb) });
        }
        Ok(v)
    };
    let (lo, hi) = (0.02f64.ln(), 1.0f64.ln());
    let grid: Vec<f64> = (0..7).map(|i| lo + (hi - lo) * i as f64 / 6.0).collect();
    let mut values = vec![];
    for &g in &grid {
        values.push(eval(g, &mut labels, scene)?);
    }
    let i = (0..grid.len()).min_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap_or(0);
    let (mut a, mut b) = (grid[i.saturating_sub(1)], grid[(i + 1).min(grid.len() - 1)]);
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - phi * (b - a), a + phi * (b - a));
    let (mut fc, mut fd) = (eval(c, &mut labels, scene)?, eval(d, &mut labels, scene)?);
    for _ in 0..4 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - phi * (b - a);
            fc = eval(c, &mut labels, scene)?;
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + phi * (b - a);
            fd = eval(d, &mut labels, scene)?;
        }
    }
    let mut out = best.expect("at least one roughness evaluated");
    basis::set_roughness(scene, &mut labels, out.alpha as f32);
    out.profile = profile;
    Ok(out)
}
