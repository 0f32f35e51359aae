//! `lucent fit photo SCENE.toml (--photo PHOTO [--pattern PATTERN] … | --capture DIR --patterns DIR)`:
//! the appearance fit on photographs (`analysis::photo_fit`): per-label Lambertian albedos, the
//! projector's scale and black level, the ambient light and the camera's response and colour
//! correction, from all photographs at once, by Levenberg–Marquardt on basis renders with common
//! random numbers, in the refinement steps response → albedo → light → joint; then a full render
//! per photograph with the fitted values checks the fit, and `--predict` renders other scenes
//! (other captures of the same materials) with it. Outputs and units: docs/digitization.md.

use std::path::{Path, PathBuf};
use std::time::Instant;

use analysis::compare::{compare, error_image, Mask};
use analysis::photo_fit::basis::{average, projector_size, render_basis, scene_labels};
use analysis::photo_fit::model::{self, Params};
use analysis::photo_fit::response::{complementary_pairs, gamma_from_pairs, PairGamma};
use analysis::photo_fit::{fit, frame_metrics, total, verify_renders, FitOptions, Frame, FrameMetrics, Metrics, PhotoFit};
use analysis::scene_fit::side_by_side;
use anyhow::{bail, Context, Result};
use render::image_io::{read_image, write_atomic, write_image, Image};
use render::light::projector::{read_projector_image, Response};
use render::scene::Scene;
use serde_json::{json, Value};

use super::render::{finite_f64, positive_u64};

/// Arguments of `lucent fit photo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scene (TOML) with the calibrated camera, objects whose materials are named `label*`
    /// (Lambertian, the starting albedos), a projector and/or a constant environment.
    #[arg(value_name = "SCENE.toml")]
    pub scene: PathBuf,
    /// A photograph (PNG/JPEG codes; repeatable). Its size must be the scene camera's.
    #[arg(long, value_name = "PHOTO")]
    pub photo: Vec<PathBuf>,
    /// The projector image shown for each --photo, in the same order (default: the scene's own).
    #[arg(long, value_name = "PATTERN")]
    pub pattern: Vec<PathBuf>,
    /// A second photograph of each --photo's frame (another exposure of the same scene and
    /// pattern), in the same order: their relative RMSE over the compared pixels is the noise
    /// floor that the check renders are measured against (fit.json `noise_floor`).
    #[arg(long, value_name = "PHOTO", requires = "photo")]
    pub repeat: Vec<PathBuf>,
    /// A capture folder of `graycode_NN.png` photographs (as `lucent scan decode` reads) …
    #[arg(long, value_name = "DIR", conflicts_with = "photo", requires = "patterns")]
    pub capture: Option<PathBuf>,
    /// … and the folder of the `pattern_NN.png` images shown (`lucent scan patterns`).
    #[arg(long, value_name = "DIR", requires = "capture")]
    pub patterns: Option<PathBuf>,
    /// Only these frame numbers of --capture, e.g. `0-39,40,41` [default: all].
    #[arg(long, value_name = "LIST", requires = "capture")]
    pub frames: Option<String>,
    /// Of those frames, only these enter the fit (the others are predicted and compared after
    /// each step) [default: all].
    #[arg(long, value_name = "LIST", requires = "capture")]
    pub fit_frames: Option<String>,
    /// Another scene and capture of the same materials to predict with the fit (not fitted):
    /// `SCENE.toml,CAPTURE_DIR`; repeatable; the capture's frames pair with --patterns.
    #[arg(long, value_name = "SCENE.toml,DIR", requires = "capture")]
    pub predict: Vec<String>,
    /// Render width in pixels; the photographs are box-averaged down to it [default: the camera's].
    #[arg(long, value_name = "W", allow_hyphen_values = true)]
    pub width: Option<String>,
    /// Render height in pixels [default: the camera's height × W / its width].
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub height: Option<String>,
    /// Samples per pixel of the check renders and of the basis (two halves of N/2) [default: 16].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub spp: Option<String>,
    /// Seed of the basis renders: two halves with seeds S and S + 1; the check renders use S + 2 [default: 0].
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub seed: Option<String>,
    /// Hold a parameter at its start: gain, black_level, gamma, projector, projector_black,
    /// ambient, color, vignetting, or a label's name; repeatable [default: projector, or ambient without one].
    #[arg(long, value_name = "NAME")]
    pub hold: Vec<String>,
    /// Fit a white-preserving 3×3 colour matrix in the response step.
    #[arg(long)]
    pub color_matrix: bool,
    /// Fit a radial vignetting V(r) = 1 + v2 r² + v4 r⁴ of the camera (r = 1 at the image
    /// corners) in the response and joint steps.
    #[arg(long)]
    pub vignetting: bool,
    /// Search the coating roughness α of the `plastic` labels (one α for all, by the least
    /// residual variance over 13 values of α in [0.02, 1], each a basis render and a fit;
    /// fit.json `roughness`); without it a glossy label keeps its scene's α.
    #[arg(long)]
    pub fit_roughness: bool,
    /// Starting camera gamma [default: 2.2].
    #[arg(long, value_name = "G", allow_hyphen_values = true)]
    pub gamma: Option<String>,
    /// Find the camera's gamma before any render from the frames of --capture whose patterns are
    /// complementary (a pattern and its inverse add up to the all-white frame's light; needs the
    /// all-white and all-black frames too), and hold it in the fit (fit.json `gamma_from_pairs`).
    #[arg(long, requires = "patterns", conflicts_with = "gamma")]
    pub gamma_from_pairs: bool,
    /// Starting (or, with --hold gain, known) camera gain [default: 1].
    #[arg(long, value_name = "G", allow_hyphen_values = true)]
    pub gain: Option<String>,
    /// Starting camera black level, in codes of full scale 1 [default: 0].
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    pub black_level: Option<String>,
    /// Most Levenberg–Marquardt steps per refinement step [default: 30].
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub max_iterations: Option<String>,
    /// Leave out pixels within N pixels of another label's region or of an unlabelled pixel (they
    /// mix labels in proportions known only to a fraction of a pixel) [default: 0].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub edge_px: Option<String>,
    /// Leave out pixels where more than this share (0–1) of the light the basis renders see
    /// comes from outside the labels: the environment seen through a hole of a scanned mesh, an
    /// object that is not a label; 1 keeps every pixel a label reaches [default: 0.001].
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    pub max_background: Option<String>,
    /// Fit on every S-th pixel of each row and column [default: 1].
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub stride: Option<String>,
    /// Folder for fit.json and the images [default: fit-photo]; created if missing.
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
    /// Print fit.json's summary (params, steps' totals, timing) on stdout.
    #[arg(long)]
    pub json: bool,
    /// No progress lines on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |tmp| std::fs::write(tmp, text).with_context(|| format!("cannot write {}", tmp.display())))
}

/// Frame numbers from `0-39,41`.
fn parse_frames(text: &str) -> Result<Vec<usize>> {
    let mut out = vec![];
    for part in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let num = |s: &str| s.trim().parse::<usize>().with_context(|| format!("--frames: `{s}` is not a frame number"));
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (num(a)?, num(b)?);
                if a > b {
                    bail!("--frames: range {part} runs backwards");
                }
                out.extend(a..=b);
            }
            None => out.push(num(part)?),
        }
    }
    if out.is_empty() {
        bail!("--frames: no frame given");
    }
    Ok(out)
}

/// `graycode_NN.png` (or .jpg) files of a capture folder by frame number; without any, the
/// folder's PNG/JPEG files in natural order.
fn capture_frames(dir: &Path) -> Result<Vec<(usize, PathBuf)>> {
    let rd = std::fs::read_dir(dir).with_context(|| format!("{}: cannot read the capture folder", dir.display()))?;
    let mut out = vec![];
    for e in rd {
        let p = e?.path();
        let Some(name) = p.file_name().and_then(|n| n.to_str()) else { continue };
        let Some(rest) = name.strip_prefix("graycode_") else { continue };
        let Some((num, ext)) = rest.split_once('.') else { continue };
        if !matches!(ext.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg") {
            continue;
        }
        if let Ok(n) = num.parse::<usize>() {
            if out.iter().any(|(m, _)| *m == n) {
                bail!("{}: two files for frame {n}", dir.display());
            }
            out.push((n, p));
        }
    }
    if out.is_empty() {
        // Frames named as other capture tools name them: every PNG/JPEG in natural order, frame
        // k being the k-th (as `lucent scan decode` reads such a folder).
        out = scan::decode::image_files_natural(dir)?.into_iter().enumerate().collect();
    }
    if out.is_empty() {
        bail!("{}: no graycode_NN.png frames and no other PNG/JPEG files", dir.display());
    }
    out.sort();
    // Frame k pairs with pattern k: a missing frame would shift nothing but silently leave its
    // pattern out, so the numbers must run 0, 1, 2, … without a gap.
    if let Some(k) = out.iter().enumerate().find(|(i, (n, _))| i != n).map(|(i, _)| i) {
        bail!("{}: frame {k} is missing (graycode_{k:02}.png); the frames must run 0, 1, 2, … without a gap", dir.display());
    }
    Ok(out)
}

/// The camera's gamma from the photographs whose patterns are complementary
/// (`analysis::photo_fit::response`), at full resolution, every second pixel of every second row
/// being enough; with the camera's black level `black_level`, or else the 0.5th percentile of the
/// all-black frame's codes. Errors name what is missing: the all-white or all-black frame, or a
/// complementary pair.
fn gamma_from_frames(photos: &[PathBuf], patterns: &[Option<Vec<f32>>], black_level: Option<f64>) -> Result<PairGamma> {
    let views: Vec<Option<&[f32]>> = patterns.iter().map(|p| p.as_deref()).collect();
    let (iw, ik, pairs) = complementary_pairs(&views).map_err(|e| anyhow::anyhow!("--gamma-from-pairs: {e}"))?;
    // Codes (full scale 1): the file's values, which `read_image` decodes with the sRGB curve;
    // of a colour photograph the mean of its three channels' codes.
    let read = |p: &Path| -> Result<(u32, u32, Vec<f32>)> {
        let img = read_image(p)?;
        let code = |v: f32| optics::color::srgb_encode(v as f64) as f32;
        Ok((img.width, img.height, img.rgb.iter().map(|c| (code(c[0]) + code(c[1]) + code(c[2])) / 3.0).collect()))
    };
    let (w, h, white) = read(&photos[iw])?;
    let sub = |v: &[f32]| -> Vec<f32> { (0..h as usize).step_by(2).flat_map(|y| (0..w as usize).step_by(2).map(move |x| v[y * w as usize + x])).collect() };
    let frame = |i: usize| -> Result<Vec<f32>> {
        let (fw, fh, v) = read(&photos[i])?;
        if (fw, fh) != (w, h) {
            bail!("{}: {fw}×{fh} pixels, but {} is {w}×{h}", photos[i].display(), photos[iw].display());
        }
        Ok(sub(&v))
    };
    let (white, black) = (sub(&white), frame(ik)?);
    let b = match black_level {
        Some(b) => b,
        None => {
            let mut sorted = black.clone();
            sorted.sort_by(|a, b| a.total_cmp(b));
            sorted[sorted.len() / 200] as f64
        }
    };
    let frames: Vec<(Vec<f32>, Vec<f32>)> = pairs.iter().map(|&(i, j)| Ok((frame(i)?, frame(j)?))).collect::<Result<_>>()?;
    let views: Vec<(&[f32], &[f32])> = frames.iter().map(|(a, c)| (a.as_slice(), c.as_slice())).collect();
    gamma_from_pairs(&views, &white, &black, b, 1)
}

/// Pattern `pattern_NN.png` of frame `n` in `dir`.
fn pattern_path(dir: &Path, n: usize) -> Result<PathBuf> {
    for name in [format!("pattern_{n:02}.png"), format!("pattern_{n}.png")] {
        let p = dir.join(name);
        if p.exists() {
            return Ok(p);
        }
    }
    bail!("{}: no pattern_{n:02}.png for frame {n}", dir.display())
}

/// A photograph as codes (1 = full scale), box-averaged down to `w × h` (the photo must be the
/// camera's size `cam`, an integer multiple of `w × h`). The average is taken of the codes
/// decoded with the sRGB curve and re-encoded, so that a block straddling an edge averages light
/// (as a larger sensor pixel would) rather than codes, exactly when the camera's response is the
/// sRGB curve and approximately otherwise.
fn read_photo(path: &Path, cam: (u32, u32), w: u32, h: u32) -> Result<Frame> {
    let img = read_image(path)?;
    if (img.width, img.height) != cam {
        bail!("{}: photograph is {}×{} but the scene's camera is calibrated for {}×{}", path.display(), img.width, img.height, cam.0, cam.1);
    }
    if img.width % w != 0 || img.height % h != 0 || img.width / w != img.height / h {
        bail!("{}: photograph {}×{} is not an integer multiple of the render size {w}×{h}", path.display(), img.width, img.height);
    }
    let s = img.width / w;
    let mut codes = vec![[0.0f32; 3]; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let mut acc = [0.0f64; 3];
            for dy in 0..s {
                for dx in 0..s {
                    let p = img.get(x * s + dx, y * s + dy);
                    for c in 0..3 {
                        acc[c] += p[c] as f64;
                    }
                }
            }
            codes[(y * w + x) as usize] = acc.map(|v| optics::color::srgb_encode(v / (s * s) as f64) as f32);
        }
    }
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("photo").to_string();
    Ok(Frame { name, codes })
}

fn read_pattern(path: &Path, size: Option<(u32, u32)>) -> Result<Vec<f32>> {
    let Some((pw, ph)) = size else { bail!("{}: a pattern was given but the scene has no projector", path.display()) };
    let (w, h, v) = read_projector_image(path, Response::Srgb)?;
    if (w, h) != (pw, ph) {
        bail!("{}: pattern is {w}×{h} but the scene's projector is {pw}×{ph}", path.display());
    }
    // Patterns are grey: the luminance (Rec. 709 Y) of each pixel.
    Ok(v.iter().map(|c| (0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64) as f32).collect())
}

fn metrics_json(m: &Metrics) -> Value {
    json!({"rmse": m.rmse, "rel_rmse": m.rel_rmse, "delta_e2000": m.delta_e2000, "pixels": m.pixels})
}

fn frames_json(frames: &[FrameMetrics], labels: &[String]) -> Value {
    Value::Array(
        frames
            .iter()
            .map(|f| {
                let per: serde_json::Map<String, Value> = labels.iter().zip(&f.per_label).map(|(l, m)| (l.clone(), metrics_json(m))).collect();
                json!({"name": f.name, "whole": metrics_json(&f.whole), "per_label": per})
            })
            .collect(),
    )
}

fn codes_to_image(w: u32, h: u32, codes: impl Iterator<Item = [f64; 3]>) -> Image {
    let rgb = codes.map(|c| c.map(|v| optics::color::srgb_decode(v.clamp(0.0, 1.0)) as f32)).collect();
    Image { width: w, height: h, rgb }
}

fn params_json(p: &Params, fit: &PhotoFit, labels: &[String]) -> Value {
    let se = |i: usize| fit.std_errors[i].map(Value::from).unwrap_or(Value::Null);
    let mut albedo = serde_json::Map::new();
    for (k, l) in labels.iter().enumerate() {
        albedo.insert(l.clone(), json!({"rgb": p.albedo(k), "std_error": [se(3 * k), se(3 * k + 1), se(3 * k + 2)]}));
    }
    let g = |i: usize| json!({"value": p.get(i), "std_error": se(p.global(i))});
    json!({
        "albedo": albedo,
        "projector_scale": g(model::PROJECTOR),
        "projector_black": g(model::PROJECTOR_BLACK),
        "ambient_scale": g(model::AMBIENT),
        "black_level": g(model::BLACK_LEVEL),
        "gain": g(model::GAIN),
        "gamma": g(model::GAMMA),
        "color_matrix": p.color_matrix(),
        "vignetting_r2": g(model::VIGNETTING),
        "vignetting_r4": g(model::VIGNETTING + 1),
    })
}

/// Runs `lucent fit photo`.
pub fn run(args: Args) -> Result<()> {
    let t_all = Instant::now();
    let spp = args.spp.as_deref().map(|t| positive_u64("--spp", t)).transpose()?.unwrap_or(16);
    let seed = match &args.seed {
        Some(t) => t.trim().parse::<u64>().with_context(|| format!("--seed must be a whole number ≥ 0, got `{t}`"))?,
        None => 0,
    };
    let max_iterations = args.max_iterations.as_deref().map(|t| positive_u64("--max-iterations", t)).transpose()?.unwrap_or(30) as usize;
    let stride = args.stride.as_deref().map(|t| positive_u64("--stride", t)).transpose()?.unwrap_or(1) as usize;
    let edge_px = match &args.edge_px {
        Some(t) => t.trim().parse::<usize>().ok().filter(|&n| n <= 1000).with_context(|| format!("--edge-px must be a whole number of pixels from 0 to 1000, got `{t}`"))?,
        None => 0,
    };
    let num = |name: &str, v: &Option<String>, d: f64| -> Result<f64> { v.as_deref().map(|t| finite_f64(name, t)).transpose().map(|o| o.unwrap_or(d)) };
    let max_background = num("--max-background", &args.max_background, analysis::photo_fit::MAX_BACKGROUND)?;
    if !(0.0..=1.0).contains(&max_background) {
        bail!("--max-background must lie in [0, 1], got {max_background}");
    }
    let mut gamma = num("--gamma", &args.gamma, 2.2)?;
    if !(0.3..=5.0).contains(&gamma) {
        bail!("--gamma must lie in [0.3, 5], got {gamma}");
    }
    let gain = num("--gain", &args.gain, 1.0)?;
    if !(gain > 0.0) {
        bail!("--gain must be > 0, got {gain}");
    }
    let black_level = num("--black-level", &args.black_level, 0.0)?;
    if !(-0.5..=0.5).contains(&black_level) {
        bail!("--black-level must lie in [-0.5, 0.5], got {black_level}");
    }
    let quiet = args.quiet;
    let say = |s: String| {
        if !quiet {
            eprintln!("lucent: {s}");
        }
    };

    let mut scene = Scene::load(&args.scene)?;
    let mut labels = scene_labels(&scene)?;
    if args.fit_roughness && !labels.iter().any(|l| l.gloss.is_some()) {
        bail!("--fit-roughness: no label is `plastic` (a glossy label has a coating roughness to find)");
    }
    let label_names: Vec<String> = labels.iter().map(|l| l.name.clone()).collect();
    let cam = scene.resolution();
    let width = match &args.width {
        Some(t) => u32::try_from(positive_u64("--width", t)?).context("--width is too large")?,
        None => cam.0,
    };
    let height = match &args.height {
        Some(t) => u32::try_from(positive_u64("--height", t)?).context("--height is too large")?,
        None => ((cam.1 as u64 * width as u64 + cam.0 as u64 / 2) / cam.0 as u64).max(1) as u32,
    };
    let psize = projector_size(&scene);

    // Photographs and their patterns.
    let mut photo_paths: Vec<PathBuf> = vec![];
    let mut pattern_paths: Vec<Option<PathBuf>> = vec![];
    let mut frame_numbers: Vec<usize> = vec![];
    if let Some(dir) = &args.capture {
        let all = capture_frames(dir)?;
        let chosen: Vec<(usize, PathBuf)> = match &args.frames {
            Some(t) => parse_frames(t)?
                .into_iter()
                .map(|n| all.iter().find(|(m, _)| *m == n).cloned().with_context(|| format!("{}: no frame {n}", dir.display())))
                .collect::<Result<_>>()?,
            None => all,
        };
        for (n, p) in chosen {
            pattern_paths.push(args.patterns.as_ref().map(|pd| pattern_path(pd, n)).transpose()?);
            photo_paths.push(p);
            frame_numbers.push(n);
        }
    } else {
        if args.photo.is_empty() {
            bail!("no photograph: give --photo PHOTO … or --capture DIR --patterns DIR");
        }
        if !args.pattern.is_empty() && args.pattern.len() != args.photo.len() {
            bail!("{} --pattern for {} --photo: give one pattern per photograph, or none", args.pattern.len(), args.photo.len());
        }
        if !args.repeat.is_empty() && args.repeat.len() != args.photo.len() {
            bail!("{} --repeat for {} --photo: give one repeat per photograph, or none", args.repeat.len(), args.photo.len());
        }
        photo_paths = args.photo.clone();
        pattern_paths = (0..photo_paths.len()).map(|i| args.pattern.get(i).cloned()).collect();
    }
    let patterns: Vec<Option<Vec<f32>>> = pattern_paths.iter().map(|p| p.as_deref().map(|p| read_pattern(p, psize)).transpose()).collect::<Result<_>>()?;
    let frames: Vec<Frame> = photo_paths.iter().map(|p| read_photo(p, cam, width, height)).collect::<Result<_>>()?;
    let repeats: Vec<Frame> = args.repeat.iter().map(|p| read_photo(p, cam, width, height)).collect::<Result<_>>()?;
    // Scenes to predict, checked before any rendering.
    let mut predictions: Vec<(PathBuf, Scene, Vec<Frame>)> = vec![];
    for spec in &args.predict {
        let Some((s, d)) = spec.split_once(',') else { bail!("--predict {spec}: expected SCENE.toml,CAPTURE_DIR") };
        let ps = Scene::load(Path::new(s))?;
        let pl: Vec<String> = scene_labels(&ps)?.iter().map(|l| l.name.clone()).collect();
        if pl != label_names {
            bail!("--predict {s}: labels {pl:?} differ from the fitted scene's {label_names:?}");
        }
        if projector_size(&ps) != psize {
            bail!("--predict {s}: its projector differs in size from the fitted scene's");
        }
        let all = capture_frames(Path::new(d))?;
        let pf: Vec<Frame> = frame_numbers
            .iter()
            .map(|n| {
                let p = all.iter().find(|(m, _)| m == n).map(|(_, p)| p.clone()).with_context(|| format!("--predict {d}: no frame {n}"))?;
                read_photo(&p, ps.resolution(), width, height)
            })
            .collect::<Result<_>>()?;
        predictions.push((PathBuf::from(d), ps, pf));
    }
    // The camera's gamma from complementary frames (before any render), then held.
    let mut hold = args.hold.clone();
    // What the fit holds when --hold names nothing (as `photo_fit::fit` chooses it).
    let default_hold = || vec![if psize.is_some() { "projector" } else { "ambient" }.to_string()];
    let mut pair_gamma = None;
    if args.gamma_from_pairs {
        let b = args.black_level.as_ref().map(|_| black_level);
        let r = gamma_from_frames(&photo_paths, &patterns, b)?;
        say(format!(
            "gamma from {} complementary pairs: {:.4}, projector additivity {:.4} (black level {:.4}, rms residual {:.4} over {} pixels)",
            r.pairs, r.gamma, r.additivity, r.black_level, r.rms, r.residuals
        ));
        gamma = r.gamma;
        if hold.is_empty() {
            hold = default_hold();
        }
        if !hold.iter().any(|h| h == "gamma") {
            hold.push("gamma".to_string());
        }
        pair_gamma = Some(json!({"gamma": r.gamma, "additivity": r.additivity, "black_level": r.black_level, "rms": r.rms, "residuals": r.residuals, "pairs": r.pairs}));
    }
    let out_dir = args.out_dir.clone().unwrap_or_else(|| PathBuf::from("fit-photo"));
    std::fs::create_dir_all(&out_dir).with_context(|| format!("--out-dir {}: cannot create", out_dir.display()))?;

    // Basis renders.
    scene.set_resolution(width, height);
    let t = Instant::now();
    say(format!("rendering the basis: {} labels, {} frames, {width}×{height}, {spp} spp", labels.len(), frames.len()));
    let mut start = Params::new(&labels.iter().map(|l| l.albedo).collect::<Vec<_>>(), gamma);
    let (ig, ib) = (start.global(model::GAIN), start.global(model::BLACK_LEVEL));
    start.x[ig] = gain;
    start.x[ib] = black_level;
    let fit_frames = match &args.fit_frames {
        Some(t) => {
            let list = parse_frames(t)?;
            if let Some(n) = list.iter().find(|n| !frame_numbers.contains(n)) {
                bail!("--fit-frames: frame {n} is not among the frames read");
            }
            Some(frame_numbers.iter().map(|n| list.contains(n)).collect())
        }
        None => None,
    };
    let opts = FitOptions {
        hold: hold.clone(),
        color_matrix: args.color_matrix,
        vignetting: args.vignetting,
        gamma,
        black_level,
        gain,
        max_iterations,
        stride,
        fit_frames,
        edge_px,
        max_background,
        ..FitOptions::default()
    };
    // Two independent halves (seeds S and S + 1, spp / 2 each) for the unbiased cross error;
    // with --fit-roughness, those of the roughness found, and its fit.
    let half = (spp / 2).max(1);
    let mut roughness = None;
    let (half_a, half_b, basis, found) = if args.fit_roughness {
        let r = analysis::photo_fit::fit_roughness(&mut scene, &patterns, &frames, &start, &opts, spp, seed, &|a, v| {
            say(format!("  roughness α {a:.4}: residual variance {v:.5e}"))
        })?;
        say(format!("roughness of the plastic labels: α {:.4}", r.alpha));
        labels = scene_labels(&scene)?;
        for (_, ps, _) in predictions.iter_mut() {
            let mut pl = scene_labels(ps)?;
            analysis::photo_fit::basis::set_roughness(ps, &mut pl, r.alpha as f32);
        }
        roughness = Some(json!({"alpha": r.alpha, "profile": r.profile.iter().map(|(a, v)| json!([a, v])).collect::<Vec<_>>()}));
        (r.halves.0, r.halves.1, r.basis, Some(r.fit))
    } else {
        let half_a = render_basis(&mut scene, &patterns, half, seed)?;
        let half_b = render_basis(&mut scene, &patterns, half, seed + 1)?;
        let basis = average(&half_a, &half_b);
        (half_a, half_b, basis, None)
    };
    let basis_seconds = t.elapsed().as_secs_f64();
    say(format!("{} basis renders in {basis_seconds:.2} s", basis.render_seconds.len()));

    let result = match found {
        Some(r) => r,
        None => fit(&basis, Some((&half_a, &half_b)), &frames, &start, &opts)?,
    };
    drop((half_a, half_b));
    for s in &result.steps {
        say(format!(
            "step {:8}: rel. RMSE {:.5}, RMSE {:.5}, ΔE2000 {:.3} ({} LM steps, {:.2} s)",
            s.name, s.total.rel_rmse, s.total.rmse, s.total.delta_e2000, s.iterations, s.seconds
        ));
    }
    let p = &result.params;

    // Check: full renders with the fitted values.
    let t = Instant::now();
    let (verify, verify_secs) = verify_renders(&mut scene, &labels, p, &patterns, spp, seed + 2)?;
    let verify_seconds = t.elapsed().as_secs_f64();
    let verify_metrics: Vec<FrameMetrics> =
        verify.iter().zip(&frames).map(|(v, f)| frame_metrics(v, f, &result.regions, labels.len(), opts.saturation)).collect();
    let verify_total = total(&verify_metrics);
    say(format!("full renders with the fit: rel. RMSE {:.5}, ΔE2000 {:.3} ({:.2} s)", verify_total.rel_rmse, verify_total.delta_e2000, verify_seconds));
    // The noise floor: each repeat photograph against its photograph, over the same pixels.
    let floor_metrics: Vec<FrameMetrics> = repeats
        .iter()
        .zip(&frames)
        .map(|(r, f)| {
            let codes: Vec<[f64; 3]> = r.codes.iter().map(|c| c.map(|v| v as f64)).collect();
            frame_metrics(&codes, f, &result.regions, labels.len(), opts.saturation)
        })
        .collect();
    let floor_total = (!floor_metrics.is_empty()).then(|| total(&floor_metrics));
    if let Some(t) = &floor_total {
        say(format!("noise floor (repeat photographs): rel. RMSE {:.5}; the full renders are at {:.3}× it", t.rel_rmse, verify_total.rel_rmse / t.rel_rmse));
    }

    // Images: per frame render | photo | error, and the steps of the first frame.
    let k = labels.len();
    for (f, frame) in frames.iter().enumerate() {
        let render = codes_to_image(width, height, verify[f].iter().cloned());
        let photo = codes_to_image(width, height, frame.codes.iter().map(|c| c.map(|v| v as f64)));
        let mask = Mask {
            width,
            height,
            inside: (0..frame.codes.len()).map(|i| result.regions[i] >= 0 && frame.codes[i].iter().all(|&v| (v as f64) < opts.saturation)).collect(),
        };
        let err = match compare(&render, &photo, Some(&mask), false) {
            Ok(c) => error_image(&c, 10.0),
            Err(_) => Image::new(width, height),
        };
        write_image(&out_dir.join(format!("{}_render.png", frame.name)), &render, 0.0)?;
        write_image(&out_dir.join(format!("{}_photo.png", frame.name)), &photo, 0.0)?;
        write_image(&out_dir.join(format!("{}_error.png", frame.name)), &err, 0.0)?;
        write_image(&out_dir.join(format!("{}_panel.png", frame.name)), &side_by_side(&[&photo, &render, &err]), 0.0)?;
    }
    if let Some(frame) = frames.first() {
        let mut row: Vec<Image> = result
            .steps
            .iter()
            .map(|s| codes_to_image(width, height, analysis::photo_fit::predict(&basis, &s.params, 0).into_iter()))
            .collect();
        row.push(codes_to_image(width, height, frame.codes.iter().map(|c| c.map(|v| v as f64))));
        write_image(&out_dir.join(format!("{}_steps.png", frame.name)), &side_by_side(&row.iter().collect::<Vec<_>>()), 0.0)?;
    }

    // Predictions of other captures.
    let mut predicted = vec![];
    for (dir, ps, pf) in predictions.iter_mut() {
        ps.set_resolution(width, height);
        let pl = scene_labels(ps)?;
        let t = Instant::now();
        let (lin, _) = analysis::photo_fit::verify_linear(ps, &pl, p, &patterns, spp, seed + 2)?;
        let (w, h) = (width as usize, height as usize);
        let pred: Vec<Vec<[f64; 3]>> = lin.iter().map(|l| analysis::photo_fit::codes(p, l, 1.0, w, h)).collect();
        // Regions of that scene: from a basis-free rule, the pixels a label's surface covers.
        let pbasis = render_basis(ps, &[], 1, seed)?;
        let regions = analysis::photo_fit::regions(&pbasis, max_background);
        let m: Vec<FrameMetrics> = pred.iter().zip(pf.iter()).map(|(v, f)| frame_metrics(v, f, &regions, k, opts.saturation)).collect();
        let tot = total(&m);
        say(format!("predicted {}: rel. RMSE {:.5}, ΔE2000 {:.3} ({:.2} s)", dir.display(), tot.rel_rmse, tot.delta_e2000, t.elapsed().as_secs_f64()));
        // Diagnostic, not part of the prediction: the error left after one exposure factor.
        let (s, em) = analysis::photo_fit::exposure_match(p, &lin, pf, &regions, k, opts.saturation, w, h);
        let etot = total(&em);
        say(format!("  with one exposure factor {s:.4} matched to it: rel. RMSE {:.5}, ΔE2000 {:.3}", etot.rel_rmse, etot.delta_e2000));
        let stem = dir.file_name().and_then(|s| s.to_str()).unwrap_or("predict").to_string();
        if let Some(f0) = pf.first() {
            let render = codes_to_image(width, height, pred[0].iter().cloned());
            let photo = codes_to_image(width, height, f0.codes.iter().map(|c| c.map(|v| v as f64)));
            write_image(&out_dir.join(format!("predict_{stem}_{}_panel.png", f0.name)), &side_by_side(&[&photo, &render]), 0.0)?;
        }
        predicted.push(json!({
            "capture": dir.display().to_string(), "total": metrics_json(&tot), "frames": frames_json(&m, &label_names),
            "exposure_matched": {"scale": s, "total": metrics_json(&etot), "frames": frames_json(&em, &label_names)},
        }));
    }

    let steps: Vec<Value> = result
        .steps
        .iter()
        .map(|s| {
            json!({
                "name": s.name, "fitted": s.fitted, "iterations": s.iterations, "seconds": s.seconds,
                "total": metrics_json(&s.total), "frames": frames_json(&s.frames, &label_names),
                "params": params_json(&s.params, &result, &label_names),
            })
        })
        .collect();
    let timing = json!({
        "basis_renders": basis.render_seconds.len(),
        "basis_render_seconds": basis.render_seconds,
        "basis_seconds": basis_seconds,
        "fit_seconds": result.seconds,
        "verify_render_seconds": verify_secs,
        "total_seconds": t_all.elapsed().as_secs_f64(),
    });
    let summary = json!({
        "params": params_json(p, &result, &label_names),
        "steps": result.steps.iter().map(|s| json!({"name": s.name, "total": metrics_json(&s.total)})).collect::<Vec<_>>(),
        "verify": metrics_json(&verify_total),
        "noise_floor": floor_total.as_ref().map(metrics_json),
        "predict": predicted
            .iter()
            .map(|v| json!({"capture": v["capture"], "total": v["total"], "exposure_matched": {"scale": v["exposure_matched"]["scale"], "total": v["exposure_matched"]["total"]}}))
            .collect::<Vec<_>>(),
        "timing": timing,
    });
    let full = json!({
        "scene": args.scene.display().to_string(),
        "width": width, "height": height, "spp": spp, "seed": seed,
        "labels": label_names,
        "hold": if hold.is_empty() { default_hold() } else { hold.clone() },
        "gamma_from_pairs": pair_gamma,
        "roughness": roughness,
        "residual_variance": result.residual_variance,
        "params": summary["params"], "steps": steps,
        "verify": {"total": metrics_json(&verify_total), "frames": frames_json(&verify_metrics, &label_names)},
        "noise_floor": floor_total.as_ref().map(|t| json!({"total": metrics_json(t), "frames": frames_json(&floor_metrics, &label_names)})),
        "edge_px": edge_px,
        "max_background": max_background,
        "predict": predicted, "timing": summary["timing"],
    });
    write_text(&out_dir.join("fit.json"), &(serde_json::to_string_pretty(&full)? + "\n"))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        for (k, l) in label_names.iter().enumerate() {
            let a = p.albedo(k);
            println!("{l}: albedo {:.4} {:.4} {:.4}", a[0], a[1], a[2]);
        }
        for g in [model::PROJECTOR, model::PROJECTOR_BLACK, model::AMBIENT, model::BLACK_LEVEL, model::GAIN, model::GAMMA] {
            println!("{}: {:.5}", model::GLOBAL_NAMES[g], p.get(g));
        }
        println!("rel. RMSE {:.5} -> {:.5}; outputs in {}", result.steps[0].total.rel_rmse, verify_total.rel_rmse, out_dir.display());
    }
    Ok(())
}
