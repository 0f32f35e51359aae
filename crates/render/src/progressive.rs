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

/// How far a render has come after a pass, for progress displays (a bar, a preview).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassStats {
    /// Samples per pixel in the film (those of a resumed checkpoint included).
    pub spp: u64,
    /// Samples per pixel aimed at (`None` for a time limit).
    pub target_spp: Option<u64>,
    /// Camera samples per second of wall-clock time, over this run.
    pub samples_per_s: f64,
    /// Wall-clock time of this run.
    pub elapsed: Duration,
    /// Estimated wall-clock time to the stop rule: the passes still to render at this run's
    /// mean time per pass, or what is left of a time limit; `None` before this run's first pass.
    pub time_left: Option<Duration>,
}

impl PassStats {
    /// The stats of `film` after `elapsed` of a run that stops by `stop` and started at
    /// `start_spp` samples per pixel.
    pub fn of(stop: Stop, film: &Film, start_spp: u64, elapsed: Duration) -> PassStats {
        let spp = film.samples_per_pixel();
        let done = spp.saturating_sub(start_spp);
        let secs = elapsed.as_secs_f64();
        let samples_per_s = if secs > 0.0 { done as f64 * film.pixel_count() as f64 / secs } else { 0.0 };
        let time_left = match stop {
            Stop::Spp(n) if done > 0 => Some(elapsed.mul_f64(n.saturating_sub(spp) as f64 / done as f64)),
            Stop::Spp(_) => None,
            Stop::Time(t) => Some(t.saturating_sub(elapsed)),
        };
        PassStats { spp, target_spp: stop.target_spp(), samples_per_s, elapsed, time_left }
    }
}

/// What happened during a render, for the caller to show.
pub enum Event<'a> {
    /// A pass was added to `film`; `stats` say how far the render has come.
    Pass { film: &'a Film, stats: PassStats },
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

    /// Render passes into `film` until the stop rule is met or `cancel` is set (by a Ctrl-C
    /// handler, a preview's Stop button; checked between passes, so a pass is never cut), on the
    /// current rayon pool; then save the checkpoint.
    /// A failed periodic save is reported once through `on_event` and does not end the render.
    pub fn run(&self, mut film: Film, cancel: &AtomicBool, mut on_event: impl FnMut(Event)) -> Outcome {
        let start = Instant::now();
        let mut buffer = film.pass_buffer();
        let mut last_save = Instant::now();
        let mut save_warned = false;
        let mut pass = self.first_pass;
        let start_spp = film.samples_per_pixel();
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
            on_event(Event::Pass { film: &film, stats: PassStats::of(self.stop, &film, start_spp, start.elapsed()) });
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_stats_extrapolate_the_mean_pass_time() {
        // A 4×2 film resumed at 20 spp, now at 60 after 8 s: 40 passes of 8 pixels in 8 s is
        // 40 samples/s, and the 40 passes left to 100 spp take another 8 s.
        let mut film = Film::new(4, 2);
        for _ in 0..60 {
            film.add_pass(&[[0.0; 3]; 8]);
        }
        let s = PassStats::of(Stop::Spp(100), &film, 20, Duration::from_secs(8));
        assert_eq!((s.spp, s.target_spp), (60, Some(100)));
        assert!((s.samples_per_s - 40.0).abs() < 1e-9, "{}", s.samples_per_s);
        assert_eq!(s.time_left, Some(Duration::from_secs(8)));
        // Past the target nothing is left; before this run's first pass nothing is known.
        assert_eq!(PassStats::of(Stop::Spp(50), &film, 20, Duration::from_secs(8)).time_left, Some(Duration::ZERO));
        assert_eq!(PassStats::of(Stop::Spp(100), &film, 60, Duration::from_secs(1)).time_left, None);
        // A time limit: what is left of it.
        let t = PassStats::of(Stop::Time(Duration::from_secs(10)), &film, 20, Duration::from_secs(8));
        assert_eq!((t.target_spp, t.time_left), (None, Some(Duration::from_secs(2))));
    }
}
