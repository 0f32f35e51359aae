//! `lucent scan …`: structured-light scanning with Gray-code patterns (the `scan` crate;
//! docs/scanning.md). One file per subcommand; this file owns the subcommand list and the
//! helpers they share (projector size parsing, progress bars).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

pub mod decode;
pub mod patterns;
pub mod calibrate;
pub mod calibrate_camera;
pub mod calibrate_stereo;
pub mod undistort;
pub mod rectify;
pub mod reconstruct;
pub mod markers;
pub mod label;

/// Arguments of `lucent scan`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

/// The `lucent scan` subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Write the Gray-code pattern images (OpenCV GrayCodePattern order) for a projector.
    Patterns(patterns::Args),
    /// Decode a capture folder into projector column and row per camera pixel.
    Decode(decode::Args),
    /// Calibrate projector and camera from chessboard captures (local homographies, Zhang, LM).
    Calibrate(calibrate::Args),
    /// Calibrate one camera from photographs of a chessboard or circle grid (OpenCV's calibrateCamera).
    CalibrateCamera(calibrate_camera::Args),
    /// Calibrate two cameras and their relative pose from simultaneous photographs (OpenCV's stereoCalibrate).
    CalibrateStereo(calibrate_stereo::Args),
    /// Remove a photograph's lens distortion with a camera calibration (OpenCV's undistort).
    Undistort(undistort::Args),
    /// Rectify a stereo pair of photographs: matching points on one row (OpenCV's stereoRectify).
    Rectify(rectify::Args),
    /// Triangulate a capture with a calibration into a point cloud (and a range-image mesh).
    Reconstruct(reconstruct::Args),
    /// Find circular markers; match and triangulate them in two calibrated views; register a model.
    Markers(markers::Args),
    /// Label a scanned mesh's micropolygons with the colour regions of a photograph (watershed).
    Label(label::Args),
}

/// Runs one `lucent scan` subcommand.
pub fn run(args: Args) -> Result<()> {
    match args.command {
        Command::Patterns(a) => patterns::run(a),
        Command::Decode(a) => decode::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::CalibrateCamera(a) => calibrate_camera::run(a),
        Command::CalibrateStereo(a) => calibrate_stereo::run(a),
        Command::Undistort(a) => undistort::run(a),
        Command::Rectify(a) => rectify::run(a),
        Command::Reconstruct(a) => reconstruct::run(a),
        Command::Markers(a) => markers::run(a),
        Command::Label(a) => label::run(a),
    }
}

/// Where a capture's white and black frames are: after the patterns (OpenCV's `GrayCodePattern`
/// order, lucent's `scan patterns`) or before them.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum WhiteBlack {
    /// The last two frames: white, then black.
    #[default]
    Last,
    /// The first two frames: white, then black.
    First,
}

impl WhiteBlack {
    /// Whether they come first ([`scan::decode::DecodeSettings::white_black_first`]).
    pub fn first(self) -> bool {
        self == WhiteBlack::First
    }
}

/// The frame-order flag of the commands that read a capture (`decode`, `calibrate`, `reconstruct`).
#[derive(clap::Args, Clone, Copy, Debug)]
pub struct CaptureOrder {
    /// Where the capture's white and black frames are: `last` (after the patterns, as OpenCV's
    /// GrayCodePattern and `scan patterns` order them) or `first` (white, black, then the patterns).
    #[arg(long, value_enum, default_value_t = WhiteBlack::Last, value_name = "WHERE")]
    pub white_black: WhiteBlack,
}

impl CaptureOrder {
    /// Whether the white and black frames come first.
    pub fn first(self) -> bool {
        self.white_black.first()
    }
}

/// Parses a projector size `WIDTHxHEIGHT` (pixels), e.g. `1024x768`.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not a size WIDTHxHEIGHT in pixels (e.g. 1024x768)");
    let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 {
        return Err(format!("projector size must be at least 1x1, got {s}"));
    }
    // Gray codes of more than 2^14 columns or rows would be 15-bit; no projector has them.
    if w > 16384 || h > 16384 {
        return Err(format!("projector size {s} is beyond 16384x16384 pixels"));
    }
    Ok((w, h))
}

/// A progress bar on stderr that appears only once its task has run for a second (indicatif
/// hides it when stderr is not a terminal).
pub struct Progress {
    bar: ProgressBar,
    start: Instant,
    shown: AtomicBool,
}

impl Progress {
    /// A bar of `len` steps labelled `what`.
    pub fn new(len: u64, what: &str) -> Progress {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template("{spinner} {elapsed_precise} [{bar:30}] {pos}/{len} {msg}") {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_message(what.to_string());
        Progress { bar, start: Instant::now(), shown: AtomicBool::new(false) }
    }

    /// One step done.
    pub fn inc(&self) {
        self.show_if_slow();
        self.bar.inc(1);
    }

    /// A new label (a new phase of the same task).
    pub fn set_message(&self, what: &str) {
        self.show_if_slow();
        self.bar.set_message(what.to_string());
    }

    fn show_if_slow(&self) {
        if !self.shown.load(Ordering::Relaxed) && self.start.elapsed() >= Duration::from_secs(1) {
            self.shown.store(true, Ordering::Relaxed);
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
        }
    }

    /// Runs `f` (which prints) with the bar hidden.
    pub fn suspend(&self, f: impl FnOnce()) {
        self.bar.suspend(f);
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
