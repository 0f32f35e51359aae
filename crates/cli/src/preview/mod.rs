//! Live previews of a progressive render: the tev viewer over its TCP protocol (`tev.rs`) and a
//! page served over HTTP (`serve.rs`).
//!
//! The render thread never waits for a display: after a pass it copies the film at most a few
//! times a second into one latest-only [`Slot`] per display (skipping the copy when the display
//! is busy reading it), and each display converts, encodes and sends on its own thread. The
//! process's CPU time outside the render's worker threads since the render started (display
//! threads, the HTTP server's threads) plus the copies is kept within [`CPU_BUDGET`] of the
//! workers' own: a copy is made only when one more image at the last image's cost stays within
//! the budget, so a large image is refreshed less often rather than slowing the render,
//! however busy the machine is. A slow
//! viewer only sees fewer updates; a vanished one is warned about once and left behind.

pub mod serve;
pub mod tev;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, TryLockError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use render::film::Film;
use render::progressive::PassStats;

/// Shortest time between two copies of the film offered to the displays: at most 4 updates a
/// second, as pbrt-v4 refreshes tev (every 250 ms).
pub const UPDATE_INTERVAL: Duration = Duration::from_millis(250);
/// The displays' CPU time as a fraction of the render's, at most.
pub const CPU_BUDGET: f64 = 0.01;

/// CPU time used so far by this process (`process`) or the calling thread, where the system
/// says (`None` elsewhere).
pub fn cpu_time(process: bool) -> Option<Duration> {
    #[cfg(unix)]
    {
        let clock = if process { libc::CLOCK_PROCESS_CPUTIME_ID } else { libc::CLOCK_THREAD_CPUTIME_ID };
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: clock_gettime writes one timespec through a valid pointer.
        if unsafe { libc::clock_gettime(clock, &mut ts) } == 0 {
            return Some(Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32));
        }
        None
    }
    #[cfg(not(unix))]
    {
        let _ = process;
        None
    }
}

/// How a render ended, as a display shows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    /// The stop rule was met.
    Finished,
    /// The preview page's Stop button asked for it.
    Stopped,
    /// Ctrl-C.
    Interrupted,
}

impl End {
    /// The word the page shows.
    pub fn name(self) -> &'static str {
        match self {
            End::Finished => "finished",
            End::Stopped => "stopped",
            End::Interrupted => "interrupted",
        }
    }
}

/// A copy of the film after a pass, with how far the render has come.
pub struct Frame {
    /// The accumulated film (sums and count).
    pub film: Film,
    /// Samples per pixel, samples per second, time left.
    pub stats: PassStats,
    /// Set on the last frame of a render.
    pub end: Option<End>,
}

/// A latest-only mailbox between the render thread and one display: a new frame replaces an
/// unread one; every frame carries a version number that grows by one per frame.
#[derive(Default)]
pub struct Slot {
    state: Mutex<(u64, Option<Arc<Frame>>)>,
    changed: Condvar,
    /// CPU time the display's thread has used in all (nanoseconds).
    cpu_ns: AtomicU64,
    /// CPU time its last image cost (nanoseconds).
    last_ns: AtomicU64,
}

impl Slot {
    /// Replace the frame without waiting; `false` (frame dropped) if the display holds the lock.
    fn offer(&self, frame: &Arc<Frame>) -> bool {
        match self.state.try_lock() {
            Ok(mut s) => {
                s.0 += 1;
                s.1 = Some(frame.clone());
                self.changed.notify_all();
                true
            }
            Err(TryLockError::WouldBlock) => false,
            Err(TryLockError::Poisoned(_)) => false,
        }
    }

    /// Replace the frame, waiting for the lock (for the last frame).
    fn put(&self, frame: &Arc<Frame>) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        s.0 += 1;
        s.1 = Some(frame.clone());
        self.changed.notify_all();
    }

    /// The newest frame and its version (0 and `None` before the first).
    pub fn latest(&self) -> (u64, Option<Arc<Frame>>) {
        let s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        (s.0, s.1.clone())
    }

    /// Record the CPU time the display's thread has used in all (`total`), and what its last
    /// image cost it (`last`).
    pub fn report_cpu(&self, total: Duration, last: Duration) {
        self.cpu_ns.store(total.as_nanos() as u64, Ordering::Relaxed);
        self.last_ns.store(last.as_nanos() as u64, Ordering::Relaxed);
    }

    /// The CPU time reported in all, and for the last image.
    pub fn cpu(&self) -> (Duration, Duration) {
        (Duration::from_nanos(self.cpu_ns.load(Ordering::Relaxed)), Duration::from_nanos(self.last_ns.load(Ordering::Relaxed)))
    }

    /// Wait for a frame newer than version `seen`.
    pub fn wait_newer(&self, seen: u64) -> (u64, Arc<Frame>) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        loop {
            if s.0 > seen {
                if let Some(f) = &s.1 {
                    return (s.0, f.clone());
                }
            }
            s = self.changed.wait(s).unwrap_or_else(|p| p.into_inner());
        }
    }
}

/// A warning printer shared with the display threads (prints one line on stderr).
pub type Warn = Arc<dyn Fn(&str) + Send + Sync>;

/// The displays attached to one render.
pub struct Preview {
    slots: Vec<Arc<Slot>>,
    tev: Option<JoinHandle<()>>,
    server: Option<serve::Server>,
    last_offer: Option<Instant>,
    /// CPU time the render thread spent copying films for the displays, and the last copy's.
    copies_cpu: Duration,
    last_copy_cpu: Duration,
    /// Process and render-worker CPU time at the first copy.
    baseline: Option<(Duration, Duration)>,
}

impl Preview {
    /// No display: [`Preview::on_pass`] and [`Preview::finish`] do nothing.
    pub fn none() -> Preview {
        Preview { slots: Vec::new(), tev: None, server: None, last_offer: None, copies_cpu: Duration::ZERO, last_copy_cpu: Duration::ZERO, baseline: None }
    }

    /// Start the displays asked for: a tev connection to `tev` (made on its own thread, so an
    /// absent viewer delays nothing) under the image name `title`, and the page on `serve`,
    /// whose Stop button sets `cancel`.
    pub fn start(
        tev: Option<tev::Target>,
        serve: Option<serve::Bound>,
        title: &str,
        cancel: Arc<AtomicBool>,
        checkpoint: Option<String>,
        warn: Warn,
    ) -> anyhow::Result<Preview> {
        let mut p = Preview::none();
        if let Some(target) = tev {
            let slot = Arc::new(Slot::default());
            p.slots.push(slot.clone());
            p.tev = Some(tev::spawn(target, title.to_string(), slot, warn.clone())?);
        }
        if let Some(bound) = serve {
            let slot = Arc::new(Slot::default());
            p.slots.push(slot.clone());
            p.server = Some(serve::Server::start(bound, slot, title.to_string(), cancel, checkpoint)?);
        }
        Ok(p)
    }

    /// Whether one more image keeps the displays within [`CPU_BUDGET`] of the render, given
    /// the CPU time since the first copy of the whole process (`process`) and of the render's
    /// worker threads (`workers`): what ran outside the workers plus the copies, and one more
    /// image at the last image's cost, against the workers' time less the copies.
    pub fn within_budget(&self, process: Duration, workers: Duration) -> bool {
        let used = process.saturating_sub(workers) + self.copies_cpu;
        let next = self.last_copy_cpu + self.slots.iter().map(|s| s.cpu().1).sum::<Duration>();
        (used + next).as_secs_f64() <= CPU_BUDGET * workers.saturating_sub(self.copies_cpu).as_secs_f64()
    }

    /// CPU time of this process and of the worker threads of the current rayon pool.
    fn cpu_now() -> Option<(Duration, Duration)> {
        let process = cpu_time(true)?;
        let workers: Option<Vec<Duration>> = rayon::broadcast(|_| cpu_time(false)).into_iter().collect();
        Some((process, workers?.into_iter().sum()))
    }

    /// After a pass: offer a copy of `film` if the last offer is [`UPDATE_INTERVAL`] old and
    /// the copy is [within budget](Preview::within_budget) (the first is always made). Never
    /// waits: a display busy reading its slot misses this frame and gets the next.
    pub fn on_pass(&mut self, film: &Film, stats: PassStats) {
        if self.slots.is_empty() || self.last_offer.is_some_and(|t| t.elapsed() < UPDATE_INTERVAL) {
            return;
        }
        match (self.baseline, Preview::cpu_now()) {
            (Some((p0, w0)), Some((p, w))) => {
                if !self.within_budget(p.saturating_sub(p0), w.saturating_sub(w0)) {
                    return;
                }
            }
            (None, now) => self.baseline = now,
            (Some(_), None) => {}
        }
        let t0 = cpu_time(false);
        let frame = Arc::new(Frame { film: film.clone(), stats, end: None });
        if let (Some(a), Some(b)) = (t0, cpu_time(false)) {
            self.last_copy_cpu = b.saturating_sub(a);
            self.copies_cpu += self.last_copy_cpu;
        }
        let mut taken = true;
        for slot in &self.slots {
            taken &= slot.offer(&frame);
        }
        if taken {
            self.last_offer = Some(Instant::now());
        }
    }

    /// Whether the page's Stop button ended the render.
    pub fn stop_requested(&self) -> bool {
        self.server.as_ref().is_some_and(|s| s.stop_requested())
    }

    /// Send the final film, let the displays finish (tev gets its last tiles; the page is kept
    /// up until it has shown the final image, at most a few seconds) and close them.
    pub fn finish(self, film: &Film, stats: PassStats, end: End) {
        if self.slots.is_empty() {
            return;
        }
        let frame = Arc::new(Frame { film: film.clone(), stats, end: Some(end) });
        for slot in &self.slots {
            slot.put(&frame);
        }
        if let Some(t) = self.tev {
            let _ = t.join();
        }
        if let Some(s) = self.server {
            s.close();
        }
    }
}

/// Set `flag`; for the displays' stop requests.
pub(crate) fn request_stop(flag: &AtomicBool) {
    flag.store(true, Ordering::SeqCst);
}

/// A duration as the page and messages show it: "42 s", "3 min 05 s", "2 h 07 min".
pub fn format_duration(d: Duration) -> String {
    let s = d.as_secs_f64().round() as u64;
    match s {
        0..=59 => format!("{s} s"),
        60..=3599 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(spp: u64) -> Arc<Frame> {
        let mut film = Film::new(1, 1);
        for _ in 0..spp {
            film.add_pass(&[[1.0; 3]]);
        }
        let stats = PassStats::of(render::progressive::Stop::Spp(10), &film, 0, Duration::from_secs(1));
        Arc::new(Frame { film, stats, end: None })
    }

    #[test]
    fn slot_keeps_only_the_latest_frame() {
        let slot = Slot::default();
        assert_eq!(slot.latest().0, 0);
        assert!(slot.offer(&frame(1)));
        assert!(slot.offer(&frame(2)));
        let (v, f) = slot.wait_newer(0);
        assert_eq!((v, f.film.samples_per_pixel()), (2, 2));
        // While a display holds the lock, an offer is dropped instead of waiting.
        let guard = slot.state.lock().unwrap();
        assert!(!slot.offer(&frame(3)));
        drop(guard);
        assert_eq!(slot.latest().0, 2);
    }

    #[test]
    fn slot_wakes_a_waiting_display() {
        let slot = Arc::new(Slot::default());
        let s2 = slot.clone();
        let waiter = std::thread::spawn(move || s2.wait_newer(0).1.film.samples_per_pixel());
        std::thread::sleep(Duration::from_millis(20));
        slot.put(&frame(5));
        assert_eq!(waiter.join().unwrap(), 5);
    }

    #[test]
    fn images_are_sent_only_within_the_cpu_budget() {
        // 10 ms outside the workers and 1 ms of copies so far, 1 + 2 ms for the displays' last
        // images and 1 ms for the last copy: 15 ms with one more image, which is 1 % of 1.5 s
        // of render, so the workers need 1.501 s (their copies included).
        let (a, b) = (Arc::new(Slot::default()), Arc::new(Slot::default()));
        let mut p = Preview::none();
        p.slots = vec![a.clone(), b.clone()];
        a.report_cpu(Duration::from_millis(8), Duration::from_millis(1));
        b.report_cpu(Duration::from_millis(2), Duration::from_millis(2));
        p.copies_cpu = Duration::from_millis(1);
        p.last_copy_cpu = Duration::from_millis(1);
        let ms = Duration::from_millis;
        assert!(!p.within_budget(ms(1500 + 10), ms(1500)));
        assert!(p.within_budget(ms(1501 + 10), ms(1501)));
        // Within the update interval the film is not copied again.
        let f = frame(1);
        p.on_pass(&f.film, f.stats);
        p.on_pass(&f.film, f.stats);
        assert_eq!((a.latest().0, b.latest().0), (1, 1));
    }

    #[test]
    fn durations_read_as_people_write_them() {
        assert_eq!(format_duration(Duration::from_secs_f64(41.6)), "42 s");
        assert_eq!(format_duration(Duration::from_secs(185)), "3 min 05 s");
        assert_eq!(format_duration(Duration::from_secs(7620)), "2 h 07 min");
    }
}
