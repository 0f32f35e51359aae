//! Progressive rendering: passes of one sample per pixel added to a film until a stop rule is
//! met or the caller asks to stop, with the accumulator saved to a checkpoint every few seconds
//! and at the end. Interfaces (the command line, the Python package, a preview) drive it and
//! only choose what to print.

use crate::checkpoint::{Checkpoint, RenderIdentity};
use crate::film::Film;
use crate::integrator::settings::IntegratorSettings;
use crate::scene::Scene;
use anyhow::Result;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Samples per image aimed at when no stop rule is given: 2^24 ≈ 16.8 million, i.e. 64 spp at
/// 512×512.
pub const DEFAULT_SAMPLES_PER_IMAGE: u64 = 1 << 24;

/// Default samples per pixel for an image of `pixels` pixels: the power of two nearest below
/// [`DEFAULT_SAMPLES_PER_IMAGE`] / pixels, at least 1.
pub fn default_spp(pixels: u64) -> u64 {
    let spp = (DEFAULT_SAMPLES_PER_IMAGE / pixels.max(1)).max(1);
    1 << (63 - spp.leading_zeros())
}

/// When a render stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stop {
    /// After this many samples per pixel in total (those of a resumed checkpoint included).
    Spp(u64),
    /// After this much wall-clock time in this run.
    Time(Duration),
}

impl Stop {
    /// The total samples per pixel aimed at (`None` for a time limit).
    pub fn target_spp(self) -> Option<u64> {
        match self {
            Stop::Spp(n) => Some(n),
            Stop::Time(_) => None,
        }
    }
}

/// Where the accumulator is saved, and how often.
#[derive(Clone, Debug)]
pub struct CheckpointPolicy {
    /// The checkpoint file (written atomically).
    pub path: PathBuf,
    /// Time between periodic writes.
    pub interval: Duration,
}

/// One progressive render: the scene, its settings and identity, the random sequence and where
/// it starts (pass `first_pass`, the film of a resumed checkpoint or an empty one).
pub struct Job<'a> {
    /// The scene, at the render's resolution.
    pub scene: &'a Scene,
    /// The integrator settings.
    pub settings: &'a IntegratorSettings,
    /// What checkpoints record the render as.
    pub identity: &'a RenderIdentity,
    /// Seed of the random sequence.
    pub seed: u64,
    /// The first pass to render (a resumed render continues its sequence).
    pub first_pass: u64,
    /// The stop rule.
    pub stop: Stop,
    /// Periodic and final checkpoints, if any.
    pub checkpoint: Option<CheckpointPolicy>,
}

/// What happened during a render, for the caller to show.
pub enum Event<'a> {
    /// A pass was added; `elapsed` since this run started.
    Pass { film: &'a Film, elapsed: Duration },
    /// A periodic checkpoint write failed (the render goes on and tries again later).
    SaveFailed(&'a anyhow::Error),
}

/// The end of a render.
pub struct Outcome {
    /// The accumulated film.
    pub film: Film,
    /// Whether it stopped because `cancel` was set (not by its stop rule).
    pub interrupted: bool,
    /// Wall-clock time of this run.
    pub elapsed: Duration,
    /// The final checkpoint write (Ok when there is no checkpoint).
    pub saved: Result<()>,
}

impl Job<'_> {
    /// Write `film` to the checkpoint, if there is one.
    pub fn save(&self, film: &Film) -> Result<()> {
        match &self.checkpoint {
            Some(c) => Checkpoint::write_single_run(&c.path, self.identity, self.seed, self.stop.target_spp(), film),
            None => Ok(()),
        }
    }

    /// Render passes into `film` until the stop rule is met or `cancel` is set (checked between
    /// passes, so a pass is never cut), on the current rayon pool; then save the checkpoint.
    /// A failed periodic save is reported once through `on_event` and does not end the render.
    pub fn run(&self, mut film: Film, cancel: &AtomicBool, mut on_event: impl FnMut(Event)) -> Outcome {
        let start = Instant::now();
        let mut buffer = film.pass_buffer();
        let mut last_save = Instant::now();
        let mut save_warned = false;
        let mut pass = self.first_pass;
        loop {
            let done = match self.stop {
                Stop::Spp(n) => film.samples_per_pixel() >= n,
                Stop::Time(t) => start.elapsed() >= t,
            };
            if done || cancel.load(Ordering::SeqCst) {
                break;
            }
            film.render_pass(self.scene, self.settings, self.seed, pass, &mut buffer);
            pass += 1;
            on_event(Event::Pass { film: &film, elapsed: start.elapsed() });
            if let Some(c) = &self.checkpoint {
                if last_save.elapsed() >= c.interval {
                    // A failed periodic save (full disk, lost mount) must not end the render:
                    // report once, keep rendering, and try again at the next interval and at the end.
                    if let Err(e) = self.save(&film) {
                        if !save_warned {
                            on_event(Event::SaveFailed(&e));
                            save_warned = true;
                        }
                    }
                    last_save = Instant::now();
                }
            }
        }
        let elapsed = start.elapsed();
        let interrupted = cancel.load(Ordering::SeqCst);
        let saved = self.save(&film);
        Outcome { film, interrupted, elapsed, saved }
    }
}
