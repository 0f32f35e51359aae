//! `lucent render`: progressive spectral rendering with checkpoints, resume and several outputs.
//!
//! Numbers are taken as text and checked here, so that a bad value (`--spp -5`, `--time 0`)
//! gives a one-line error naming the option instead of a usage screen.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use render::checkpoint::{Checkpoint, RenderIdentity};
use render::film::{Film, FilmLayout};
use render::image_io::Image;
use render::integrator::aov::Aov;
use render::math::spectral::SpectralBins;
use render::integrator::{IntegratorKind, IntegratorSettings};
use render::progressive::{default_spp, CheckpointPolicy, Event, Job, PassStats, Stop};
use render::scene::Scene;

use crate::preview::{self, Preview};

/// Image written when no `--out` is given for the built-in scene; a scene file's render is written
/// to its name with `.png` in the current folder (`scenes/bunny.toml` → `bunny.png`).
pub const DEFAULT_OUT: &str = "lucent.png";

/// The integrator names as `--integrator` shows them: `path|volpath|direct|ao`.
pub(crate) static INTEGRATOR_VALUES: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| IntegratorKind::names("|"));
/// Exit status after Ctrl-C (128 + SIGINT), once the checkpoint and images are written.
pub const EXIT_INTERRUPTED: i32 = 130;

#[derive(clap::Args, Debug, Default)]
pub struct Args {
    /// Scene file (TOML, see docs/scene-format.md); the built-in measured Cornell box when omitted.
    #[arg(value_name = "SCENE.toml")]
    pub scene: Option<PathBuf>,
    /// Samples per pixel in total, including those of a resumed checkpoint [default: 2^24 samples / pixels, as a power of two: 64 at 512×512].
    #[arg(long, value_name = "N", allow_hyphen_values = true, conflicts_with = "time")]
    pub spp: Option<String>,
    /// Render for this many seconds of wall-clock time instead of a sample count.
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true)]
    pub time: Option<String>,
    /// Output image; .png (sRGB, for looking), .exr or .pfm (linear, for measuring). Repeatable [default: the scene file's name with .png, in the current folder; lucent.png for the built-in scene].
    #[arg(long, value_name = "FILE")]
    pub out: Vec<PathBuf>,
    /// Image width in pixels (the scene's when omitted; height follows the aspect ratio if only one is given).
    #[arg(long, value_name = "W", allow_hyphen_values = true)]
    pub width: Option<String>,
    /// Image height in pixels.
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub height: Option<String>,
    /// Worker threads [default: all cores].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub threads: Option<String>,
    /// Seed of the random sequence; independent runs to merge need different seeds [default: 0].
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub seed: Option<String>,
    /// Light-transport estimator [default: the scene's `[integrator]`, else path].
    #[arg(long, value_name = INTEGRATOR_VALUES.as_str())]
    pub integrator: Option<String>,
    /// Longest path in path segments (1 = emitters only, 2 = direct lighting) [default: the scene's, else 8].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub max_depth: Option<String>,
    /// Russian roulette starts at this path segment [default: the scene's, else 5].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub rr_depth: Option<String>,
    /// Write the accumulator here every few seconds, at the end and on Ctrl-C (atomically).
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Continue the render saved in this checkpoint (and keep checkpointing to it unless --checkpoint says otherwise).
    #[arg(long, value_name = "FILE")]
    pub resume: Option<PathBuf>,
    /// Seconds between checkpoint writes [default: 5].
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true)]
    pub checkpoint_interval: Option<String>,
    /// Exposure in stops for PNG outputs (EXR and PFM stay unscaled linear radiance) [default: 0].
    #[arg(long, value_name = "STOPS", allow_hyphen_values = true)]
    pub exposure: Option<String>,
    /// No progress bar and no summary line.
    #[arg(long, short)]
    pub quiet: bool,
    /// Stream the image as it converges to a tev viewer listening on HOST:PORT (tev's default: 127.0.0.1:14158).
    #[arg(long, value_name = "HOST:PORT")]
    pub display_server: Option<String>,
    /// Serve a preview page (image, spp, samples/s, time left, exposure, Stop) on PORT of 127.0.0.1, or on ADDR:PORT.
    #[arg(long, value_name = "[ADDR:]PORT")]
    pub serve: Option<String>,
    /// Calibrated camera replacing the scene's: lucent calibration JSON or OpenCV FileStorage YAML/XML (see docs/scene-format.md).
    #[arg(long, value_name = "CALIB")]
    pub camera: Option<PathBuf>,
    /// AOVs written as extra channels of every .exr output (comma-separated): albedo (albedo.R,G,B), normal (N.X,Y,Z), depth (depth.T, metres along the ray), position (P.X,Y,Z), object_id (object_id.I), variance (variance.R,G,B of the pixel mean).
    #[arg(long, value_name = "LIST")]
    pub aov: Option<String>,
    /// Spectral image written into every .exr output: mean spectral radiance per nm in bins START:END:WIDTH nm within 360–830 (e.g. 400:700:10), channels S0.<centre>nm.
    #[arg(long, value_name = "START:END:WIDTH")]
    pub spectral_bins: Option<String>,
    /// Denoise the image with Intel Open Image Denoise, albedo and normal AOVs as guides (cargo feature `denoise`; the library is loaded at run time, $LUCENT_OIDN_LIBRARY or the system's).
    #[arg(long)]
    pub denoise: bool,
    /// Camera-matrix node of a FileStorage calibration [default: camera_matrix].
    #[arg(long, value_name = "NAME", requires = "camera")]
    pub camera_matrix_node: Option<String>,
    /// Distortion node of a FileStorage calibration [default: distortion_coefficients].
    #[arg(long, value_name = "NAME", requires = "camera")]
    pub camera_dist_node: Option<String>,
}

impl Args {
    /// What `lucent` with no arguments does: the built-in Cornell box to `lucent.png`.
    pub fn default_scene() -> Args {
        Args::default()
    }
}

/// Parse a whole number ≥ 1 given to `option`.
pub(crate) fn positive_u64(option: &str, text: &str) -> Result<u64> {
    match text.trim().parse::<i128>() {
        Ok(v) if v >= 1 && v <= u64::MAX as i128 => Ok(v as u64),
        Ok(v) => bail!("{option} must be a whole number ≥ 1, got {v}"),
        Err(_) => bail!("{option} must be a whole number ≥ 1, got `{text}`"),
    }
}

fn positive_u32(option: &str, text: &str) -> Result<u32> {
    let v = positive_u64(option, text)?;
    u32::try_from(v).with_context(|| format!("{option} is too large: {v}"))
}

fn any_u64(option: &str, text: &str) -> Result<u64> {
    text.trim().parse::<u64>().with_context(|| format!("{option} must be a whole number ≥ 0, got `{text}`"))
}

fn any_u32(option: &str, text: &str) -> Result<u32> {
    text.trim().parse::<u32>().with_context(|| format!("{option} must be a whole number ≥ 0, got `{text}`"))
}

/// Parse a finite real number given to `option`.
pub(crate) fn finite_f64(option: &str, text: &str) -> Result<f64> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => bail!("{option} must be a finite number, got `{text}`"),
    }
}

/// Parse the integrator name of `--integrator`.
pub(crate) fn integrator_kind(text: &str) -> Result<IntegratorKind> {
    match IntegratorKind::from_name(text.trim().to_ascii_lowercase().as_str()) {
        Some(kind) => Ok(kind),
        None => bail!("--integrator must be {}, got `{text}`", IntegratorKind::names_or()),
    }
}

/// The image a render writes without `--out`: the scene file's name with `.png` in the current
/// folder, [`DEFAULT_OUT`] for the built-in scene.
pub(crate) fn default_out(scene: Option<&Path>) -> PathBuf {
    match scene.and_then(|p| p.file_stem()) {
        Some(stem) if !stem.is_empty() => {
            let mut name = stem.to_os_string();
            name.push(".png");
            PathBuf::from(name)
        }
        _ => PathBuf::from(DEFAULT_OUT),
    }
}

/// What the integrator `kind` leaves out of `scene`, one sentence each: media outside `volpath`,
/// subsurface scattering outside `path` (where `volpath` sees a translucent object with an
/// interior medium, it renders that medium instead).
pub(crate) fn ignored_by(scene: &Scene, kind: IntegratorKind) -> Vec<String> {
    let name = kind.name();
    let translucent = |o: &render::scene::ObjectInfo| scene.materials[o.material as usize].as_translucent().is_some();
    let list = |names: Vec<&str>| {
        let shown: Vec<&str> = names.iter().take(4).copied().collect();
        if names.len() > shown.len() { format!("{} and {} more", shown.join(", "), names.len() - shown.len()) } else { shown.join(", ") }
    };
    let mut out = Vec::new();
    let (media, subsurface): (Vec<&str>, Vec<&str>) = match kind {
        IntegratorKind::Volpath => {
            (Vec::new(), scene.objects.iter().filter(|o| translucent(o) && o.interior_medium.is_none()).map(|o| o.name.as_str()).collect())
        }
        IntegratorKind::Path => (scene.objects.iter().filter(|o| o.interior_medium.is_some() && !translucent(o)).map(|o| o.name.as_str()).collect(), Vec::new()),
        IntegratorKind::Direct | IntegratorKind::Ao => (
            scene.objects.iter().filter(|o| o.interior_medium.is_some() && !translucent(o)).map(|o| o.name.as_str()).collect(),
            scene.objects.iter().filter(|o| translucent(o)).map(|o| o.name.as_str()).collect(),
        ),
    };
    let global = scene.global_medium.is_some() && kind != IntegratorKind::Volpath;
    if global || !media.is_empty() {
        let what = match (global, media.is_empty()) {
            (true, true) => "the scene's medium".to_string(),
            (true, false) => format!("the scene's medium and the media of {}", list(media)),
            _ => format!("the media of {}", list(media)),
        };
        out.push(format!("the {name} integrator ignores {what} (they render as empty): use --integrator volpath"));
    }
    if !subsurface.is_empty() {
        let fix = if kind == IntegratorKind::Volpath { "give them a medium, or use --integrator path" } else { "use --integrator path" };
        out.push(format!(
            "the {name} integrator ignores the subsurface scattering of {} (rendered as their clear boundary): {fix}",
            list(subsurface)
        ));
    }
    out
}

/// Check before any rendering that every output can be written: known extension, existing folder.
pub(crate) fn check_outputs(outs: &[PathBuf]) -> Result<()> {
    for out in outs {
        render::image_io::Format::from_path(out).with_context(|| format!("--out {}", out.display()))?;
        check_parent_dir(out, "--out")?;
    }
    Ok(())
}

/// Parse `--aov` and `--spectral-bins` into what the film accumulates (`None` when neither is given).
pub(crate) fn film_layout(aov: Option<&str>, bins: Option<&str>) -> Result<Option<FilmLayout>> {
    if aov.is_none() && bins.is_none() {
        return Ok(None);
    }
    let aovs = match aov {
        Some(text) => Aov::parse_list(text).map_err(|e| anyhow::anyhow!("--aov: {e}"))?,
        None => Vec::new(),
    };
    let bins = match bins {
        Some(text) => Some(SpectralBins::parse(text).map_err(|e| anyhow::anyhow!("--spectral-bins: {e}"))?),
        None => None,
    };
    Ok(Some(FilmLayout::new(aovs, bins)))
}

/// AOVs and spectral bins go into the .exr outputs: refuse a layout with none among `outs`.
pub(crate) fn check_layout_outputs(layout: &FilmLayout, outs: &[PathBuf]) -> Result<()> {
    let is_exr = |p: &PathBuf| matches!(render::image_io::Format::from_path(p), Ok(render::image_io::Format::Exr));
    if !layout.is_empty() && !outs.iter().any(is_exr) {
        let list: Vec<String> = outs.iter().map(|p| p.display().to_string()).collect();
        bail!("{} are written as channels of an .exr output; give --out FILE.exr (outputs now: {})", layout.describe(), list.join(", "));
    }
    Ok(())
}

/// `--denoise`: with the `denoise` feature, check before rendering that Intel Open Image Denoise
/// loads; without it, the one line saying how to get it.
pub(crate) fn check_denoise(denoise: bool) -> Result<()> {
    if !denoise {
        return Ok(());
    }
    #[cfg(feature = "denoise")]
    {
        crate::denoise::library().map(|_| ())
    }
    #[cfg(not(feature = "denoise"))]
    {
        bail!(
            "--denoise needs a lucent built with the `denoise` cargo feature (`cargo build --release --features lucent/denoise`) and Intel Open Image Denoise 1.x or 2.x at run time (see docs/outputs.md)"
        )
    }
}

/// `--denoise` needs the albedo and normal AOVs as guides: the layout with them added.
pub(crate) fn with_denoise_guides(layout: Option<FilmLayout>) -> FilmLayout {
    let FilmLayout { mut aovs, bins } = layout.unwrap_or_default();
    aovs.extend([Aov::Albedo, Aov::Normal]);
    FilmLayout::new(aovs, bins)
}

/// The denoised image when `--denoise` is on (a build with the `denoise` feature).
fn denoised_image(denoise: bool, film: &Film) -> Result<Option<Image>> {
    if !denoise {
        return Ok(None);
    }
    #[cfg(feature = "denoise")]
    {
        crate::denoise::denoise(film).map(Some)
    }
    #[cfg(not(feature = "denoise"))]
    {
        let _ = film;
        check_denoise(true).map(|_| None)
    }
}

/// The folder a file will be written into must exist.
pub(crate) fn check_parent_dir(path: &Path, option: &str) -> Result<()> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        bail!("{option} {}: folder {} does not exist", path.display(), parent.display());
    }
    if path.is_dir() {
        bail!("{option} {}: is a folder", path.display());
    }
    render::image_io::check_writable(path).with_context(|| option.to_string())
}

/// Write the film's image to every output; returns their absolute paths and what each holds.
/// EXR outputs of a film with AOVs or spectral bins get them as extra channels.
pub(crate) fn write_outputs(film: &Film, outs: &[PathBuf], exposure_stops: f32) -> Result<Vec<(PathBuf, String)>> {
    write_outputs_with(film, None, outs, exposure_stops)
}

/// [`write_outputs`] with the image replaced by `denoised` where given: PNG/PFM outputs hold
/// it, EXR outputs hold it as R, G, B with the film's own image as `noisy.R`, `.G`, `.B`.
pub(crate) fn write_outputs_with(film: &Film, denoised: Option<&Image>, outs: &[PathBuf], exposure_stops: f32) -> Result<Vec<(PathBuf, String)>> {
    let image = match denoised {
        Some(d) => d.clone(),
        None => film.to_image(),
    };
    let mut written = Vec::with_capacity(outs.len());
    for out in outs {
        let format = render::image_io::Format::from_path(out)?;
        let what = if format == render::image_io::Format::Exr && denoised.is_some() {
            film.write_exr_with_rgb(out, &image, "noisy")?;
            format!("channels R, G, B (denoised), noisy.R, noisy.G, noisy.B, {}", describe_channels(&film.layout().channel_names()))
        } else if format == render::image_io::Format::Exr && !film.layout().is_empty() {
            film.write_exr(out)?;
            format!("channels R, G, B, {}", describe_channels(&film.layout().channel_names()))
        } else if denoised.is_some() {
            render::image_io::write_image(out, &image, exposure_stops)?;
            "RGB image (denoised)".to_string()
        } else {
            render::image_io::write_image(out, &image, exposure_stops)?;
            "RGB image".to_string()
        };
        written.push((std::path::absolute(out).unwrap_or_else(|_| out.clone()), what));
    }
    Ok(written)
}

/// Channel names for a message: AOV channels listed, a run of spectral channels shortened to
/// its ends (`S0.405nm … S0.695nm (30 bins)`).
fn describe_channels(names: &[String]) -> String {
    let (spectral, other): (Vec<&String>, Vec<&String>) = names.iter().partition(|n| n.starts_with("S0."));
    let mut parts: Vec<String> = other.iter().map(|s| s.to_string()).collect();
    match spectral.as_slice() {
        [] => {}
        [one] => parts.push(one.to_string()),
        [first, .., last] => parts.push(format!("{first} … {last} ({} bins)", spectral.len())),
    }
    parts.join(", ")
}

/// Print what `write_outputs` wrote: `wrote PATH` on stdout (one per line, for scripts) and what
/// each file holds on stderr unless `quiet`.
pub(crate) fn report_written(written: &[(PathBuf, String)], quiet: bool) {
    for (path, what) in written {
        if !quiet {
            eprintln!("lucent: {}: {what}", path.display());
        }
        println!("wrote {}", path.display());
    }
}

pub fn run(args: Args) -> Result<()> {
    // ---- Parse and check everything before rendering anything. ----
    let stop_arg = match (&args.spp, &args.time) {
        (Some(s), _) => Some(Stop::Spp(positive_u64("--spp", s)?)),
        (None, Some(t)) => {
            let secs = finite_f64("--time", t)?;
            if secs <= 0.0 || secs > 1e9 {
                bail!("--time must be a number of seconds > 0, got `{t}`");
            }
            Some(Stop::Time(Duration::from_secs_f64(secs)))
        }
        (None, None) => None,
    };
    let width_arg = args.width.as_deref().map(|w| positive_u32("--width", w)).transpose()?;
    let height_arg = args.height.as_deref().map(|h| positive_u32("--height", h)).transpose()?;
    let threads = args.threads.as_deref().map(|t| positive_u64("--threads", t)).transpose()?;
    if let Some(t) = threads {
        if t > 4096 {
            bail!("--threads must be at most 4096, got {t}");
        }
    }
    let seed_arg = args.seed.as_deref().map(|s| any_u64("--seed", s)).transpose()?;
    let kind_arg = args.integrator.as_deref().map(integrator_kind).transpose()?;
    let max_depth_arg = args.max_depth.as_deref().map(|d| positive_u32("--max-depth", d)).transpose()?;
    let rr_depth_arg = args.rr_depth.as_deref().map(|d| any_u32("--rr-depth", d)).transpose()?;
    let exposure = match args.exposure.as_deref() {
        Some(e) => {
            let v = finite_f64("--exposure", e)?;
            if v.abs() > 64.0 {
                bail!("--exposure must be between -64 and 64 stops, got {}", optics::numfmt::short(v));
            }
            v as f32
        }
        None => 0.0,
    };
    let interval = match args.checkpoint_interval.as_deref() {
        Some(s) => {
            let v = finite_f64("--checkpoint-interval", s)?;
            if v <= 0.0 || v > 1e9 {
                bail!("--checkpoint-interval must be a number of seconds > 0, got `{s}`");
            }
            Duration::from_secs_f64(v)
        }
        None => Duration::from_secs(5),
    };
    let outs = if args.out.is_empty() { vec![default_out(args.scene.as_deref())] } else { args.out.clone() };
    check_outputs(&outs)?;
    // Displays: the viewer's address is resolved and the page's port bound before any work.
    let display_server = args.display_server.as_deref().map(preview::tev::Target::parse).transpose()?;
    let serve = args.serve.as_deref().map(preview::serve::bind).transpose()?;
    let layout_arg = film_layout(args.aov.as_deref(), args.spectral_bins.as_deref())?;
    if let Some(layout) = &layout_arg {
        check_layout_outputs(layout, &outs)?;
    }
    check_denoise(args.denoise)?;
    let layout_arg = if args.denoise { Some(with_denoise_guides(layout_arg)) } else { layout_arg };
    let checkpoint_path = args.checkpoint.clone().or_else(|| args.resume.clone());
    if let Some(c) = &checkpoint_path {
        check_parent_dir(c, "--checkpoint")?;
        if outs.iter().any(|o| o == c) {
            bail!("--checkpoint {} is also given as --out", c.display());
        }
    }

    // The checkpoint to resume, read first: it supplies defaults (resolution, integrator).
    let resumed = match &args.resume {
        Some(p) => Some(Checkpoint::read(p)?),
        None => None,
    };

    // ---- The scene and the render's identity. ----
    let mut scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::cornell_box(),
    };
    if let Some(calib) = &args.camera {
        let mut nodes = render::load::calibration::CalibrationNodes::default();
        nodes.matrix = args.camera_matrix_node.clone().unwrap_or(nodes.matrix);
        nodes.dist = args.camera_dist_node.clone().unwrap_or(nodes.dist);
        scene.use_calibration(calib, &nodes)?;
    }
    let scene_name = match &args.scene {
        Some(path) => path.display().to_string(),
        None => "built-in Cornell box".to_string(),
    };
    let (w0, h0) = scene.resolution();
    let (width, height) = match (width_arg, height_arg, &resumed) {
        (Some(w), Some(h), _) => (w, h),
        (Some(w), None, _) => (w, ((w as f64 * h0 as f64 / w0 as f64).round() as u32).max(1)),
        (None, Some(h), _) => (((h as f64 * w0 as f64 / h0 as f64).round() as u32).max(1), h),
        (None, None, Some(c)) => (c.identity.width, c.identity.height),
        (None, None, None) => (w0, h0),
    };
    if width as u64 * height as u64 > 1 << 28 {
        let from = match (width_arg, height_arg, &resumed) {
            (None, None, Some(_)) => "the resumed checkpoint's".to_string(),
            (None, None, None) => format!("{scene_name}: [camera] width × height ="),
            _ => "--width × --height =".to_string(),
        };
        bail!("{from} {width}×{height} pixels is too large (at most 2^28 pixels)");
    }
    scene.set_resolution(width, height);
    // Integrator: the flags, else the checkpoint being resumed, else the scene file's.
    let base = match &resumed {
        Some(c) => c.identity.settings.clone(),
        None => scene.integrator.clone(),
    };
    let settings = IntegratorSettings {
        kind: kind_arg.unwrap_or(base.kind),
        max_depth: max_depth_arg.unwrap_or(base.max_depth),
        rr_depth: rr_depth_arg.unwrap_or(base.rr_depth),
    };
    // Said even with --quiet: the image would otherwise look plausible and be wrong.
    for w in ignored_by(&scene, settings.kind) {
        eprintln!("lucent: warning: {w}");
    }
    let mut identity = RenderIdentity::of_scene(&scene, &settings);
    identity.scene_name = scene_name.clone();

    // ---- Starting point: fresh, or where the checkpoint stopped. ----
    let (seed, first_pass, film, stored_target) = match (&args.resume, resumed) {
        (Some(path), Some(c)) => {
            c.check_matches(path, &identity)?;
            let (seed, next_pass) = c.resume_point(path)?;
            if let Some(s) = seed_arg {
                if s != seed {
                    bail!("{}: checkpoint was rendered with --seed {seed}, not {s}", path.display());
                }
            }
            // The AOVs and bins go on as they began (an exact resume needs all of them).
            if let Some(layout) = &layout_arg {
                c.check_layout(path, layout)?;
            }
            check_layout_outputs(c.film.layout(), &outs).with_context(|| format!("{}: resuming", path.display()))?;
            (seed, next_pass, c.film, c.target_spp)
        }
        _ => (seed_arg.unwrap_or(0), 0, Film::with_layout(width, height, layout_arg.clone().unwrap_or_default()), None),
    };
    let stop = match (stop_arg, stored_target) {
        (Some(s), _) => s,
        (None, Some(t)) => Stop::Spp(t),
        (None, None) if args.resume.is_some() => {
            bail!("{}: checkpoint of a --time run: give --spp or --time to continue", args.resume.as_ref().unwrap().display())
        }
        (None, None) => Stop::Spp(default_spp(width as u64 * height as u64)),
    };

    // ---- Ctrl-C: finish the pass, save, exit 130. A second Ctrl-C quits at once. The preview
    // page's Stop button sets the same flag. ----
    let interrupted = Arc::new(AtomicBool::new(false));
    let ctrl_c = Arc::new(AtomicBool::new(false));
    {
        let (flag, pressed) = (interrupted.clone(), ctrl_c.clone());
        // Failing to install the handler (already installed, e.g. in tests) only loses the nicety.
        let _ = ctrlc::set_handler(move || {
            if pressed.swap(true, Ordering::SeqCst) {
                std::process::exit(EXIT_INTERRUPTED);
            }
            flag.store(true, Ordering::SeqCst);
        });
    }

    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(t) = threads {
            b = b.num_threads(t as usize);
        }
        b.build().context("cannot start worker threads")?
    };
    let n_threads = pool.current_num_threads();

    // ---- Render. ----
    let job = Job {
        scene: &scene,
        settings: &settings,
        identity: &identity,
        seed,
        first_pass,
        stop,
        checkpoint: checkpoint_path.clone().map(|path| CheckpointPolicy { path, interval }),
    };
    let start = Instant::now();
    let start_spp = film.samples_per_pixel();
    let pixels = width as u64 * height as u64;
    let progress = Progress::new(stop, start_spp, args.quiet);
    let mut preview = match (display_server, serve) {
        (None, None) => Preview::none(),
        (tev, page) => {
            if let Some(p) = &page {
                // Said even with --quiet: there is no other way to find the page.
                eprintln!("lucent: preview at {}", p.url());
            }
            let bar = progress.bar.clone();
            let warn: preview::Warn = Arc::new(move |m: &str| bar.suspend(|| eprintln!("lucent: warning: {m}")));
            let title = format!("{} ({})", outs[0].display(), std::process::id());
            let ckpt = checkpoint_path.as_ref().map(|c| std::path::absolute(c).unwrap_or_else(|_| c.clone()).display().to_string());
            Preview::start(tev, page, &title, interrupted.clone(), ckpt, warn)?
        }
    };
    let outcome = pool.install(|| {
        job.run(film, &interrupted, |event| match event {
            Event::Pass { film, stats } => {
                progress.update(film, start, start_spp, pixels);
                preview.on_pass(film, stats);
            }
            Event::SaveFailed(e) => progress.suspend(|| eprintln!("lucent: warning: {e:#}")),
        })
    });
    progress.finish();
    let elapsed = outcome.elapsed.as_secs_f64();
    let was_interrupted = outcome.interrupted;
    let film = outcome.film;

    // ---- Save: checkpoint first (the work, written by the job), then the images, even if the
    // checkpoint failed. ----
    let denoised = denoised_image(args.denoise, &film);
    let written = denoised.and_then(|d| write_outputs_with(&film, d.as_ref(), &outs, exposure));
    let stopped_by_page = preview.stop_requested() && !ctrl_c.load(Ordering::SeqCst);
    let end = match (was_interrupted, stopped_by_page) {
        (false, _) => preview::End::Finished,
        (true, true) => preview::End::Stopped,
        (true, false) => preview::End::Interrupted,
    };
    preview.finish(&film, PassStats::of(stop, &film, start_spp, outcome.elapsed), end);
    outcome.saved?;
    let written = written?;
    if !args.quiet {
        let new_samples = (film.samples_per_pixel() - start_spp) as f64 * pixels as f64;
        let rate = if elapsed > 0.0 { new_samples / elapsed / 1e6 } else { 0.0 };
        eprintln!(
            "lucent: {} at {width}×{height}, {} spp ({}, seed {seed}) in {elapsed:.1} s: {rate:.2} Msamples/s on {n_threads} threads",
            scene_name,
            film.samples_per_pixel(),
            settings.kind.name(),
        );
        if film.rejected_samples() > 0 {
            eprintln!("lucent: warning: {} non-finite samples were counted as zero", film.rejected_samples());
        }
    }
    // Every file written, one `wrote PATH` line each on stdout (as `lucent merge` says it).
    if let Some(c) = &checkpoint_path {
        println!("wrote {}", std::path::absolute(c).unwrap_or_else(|_| c.clone()).display());
    }
    report_written(&written, args.quiet);
    if stopped_by_page {
        eprintln!("lucent: stopped from the preview page; continue with --resume {}", match &checkpoint_path {
            Some(c) => c.display().to_string(),
            None => "(no --checkpoint given: progress not saved)".to_string(),
        });
        return Ok(());
    }
    if was_interrupted {
        eprintln!("lucent: interrupted; continue with --resume {}", match &checkpoint_path {
            Some(c) => c.display().to_string(),
            None => "(no --checkpoint given: progress not saved)".to_string(),
        });
        std::process::exit(EXIT_INTERRUPTED);
    }
    Ok(())
}

/// Progress bar on stderr, shown once a render has run for a second (hidden when stderr is not a terminal).
struct Progress {
    bar: ProgressBar,
    stop: Stop,
    shown: AtomicBool,
    quiet: bool,
}

impl Progress {
    fn new(stop: Stop, start_spp: u64, quiet: bool) -> Progress {
        let (len, template) = match stop {
            Stop::Spp(n) => (n, "{spinner} {elapsed_precise} [{bar:30}] {pos}/{len} spp  {msg}  {eta} left"),
            Stop::Time(t) => (t.as_millis() as u64, "{spinner} {elapsed_precise} [{bar:30}] {msg}  {eta} left"),
        };
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template(template) {
            bar.set_style(style.progress_chars("=> "));
        }
        if let Stop::Spp(_) = stop {
            bar.set_position(start_spp);
            bar.reset_eta();
        }
        Progress { bar, stop, shown: AtomicBool::new(false), quiet }
    }

    fn update(&self, film: &Film, start: Instant, start_spp: u64, pixels: u64) {
        let elapsed = start.elapsed();
        if !self.quiet && !self.shown.load(Ordering::Relaxed) && elapsed >= Duration::from_secs(1) {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
            self.shown.store(true, Ordering::Relaxed);
        }
        let spp = film.samples_per_pixel();
        let rate = (spp - start_spp) as f64 * pixels as f64 / elapsed.as_secs_f64().max(1e-9);
        match self.stop {
            Stop::Spp(_) => {
                self.bar.set_message(format!("{:.2} Msamples/s", rate / 1e6));
                self.bar.set_position(spp);
            }
            Stop::Time(_) => {
                self.bar.set_message(format!("{spp} spp  {:.2} Msamples/s", rate / 1e6));
                self.bar.set_position(elapsed.as_millis() as u64);
            }
        }
    }

    /// Run `f` (which prints) with the bar cleared.
    fn suspend(&self, f: impl FnOnce()) {
        self.bar.suspend(f)
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
