//! `lucent.Scene`: a scene loaded from a TOML file or text (docs/scene-format.md), rendered by
//! the progressive renderer of `lucent render` (`render::progressive::Job`) into a float32
//! (H, W, 3) array of linear sRGB, equal bit for bit to the image `lucent render` writes to EXR
//! or PFM with the same seed, samples per pixel and size.
//!
//! The render runs on a worker thread without the GIL; the calling thread waits for passes,
//! calls the `progress` callback with the GIL after each one and checks for signals (Ctrl-C),
//! stopping the render between passes when one arrives or the callback asks for it.

use crate::errors::{value, OrPy};
use numpy::{IntoPyArray, PyArray3, PyArrayMethods};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use render::checkpoint::RenderIdentity;
use render::film::Film;
use render::integrator::{IntegratorKind, IntegratorSettings};
use render::progressive::{default_spp, Event, Job, Stop};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

/// A scene ready to render: camera, geometry, materials, lights and media.
#[pyclass(module = "lucent._lucent")]
pub struct Scene {
    inner: render::scene::Scene,
}

/// A whole number ≥ 1 for `name`.
fn at_least_one(name: &str, v: Option<u64>) -> PyResult<Option<u64>> {
    match v {
        Some(0) => Err(value(format!("{name} must be a whole number ≥ 1, got 0"))),
        v => Ok(v),
    }
}

fn to_u32(name: &str, v: Option<u64>) -> PyResult<Option<u32>> {
    at_least_one(name, v)?.map(|v| u32::try_from(v).map_err(|_| value(format!("{name} is too large: {v}")))).transpose()
}

#[pymethods]
impl Scene {
    /// Load a scene file (TOML; relative file names resolve against its folder).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
        let inner = py.allow_threads(|| render::scene::Scene::load(&path)).or_py()?;
        Ok(Scene { inner })
    }

    /// Parse a scene held in a string; `name` labels error messages and relative file names
    /// resolve against `base_dir` (default: the current folder).
    #[staticmethod]
    #[pyo3(signature = (text, name="<string>", base_dir=None))]
    fn from_toml(py: Python<'_>, text: &str, name: &str, base_dir: Option<PathBuf>) -> PyResult<Scene> {
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        let inner = py.allow_threads(|| render::scene::Scene::from_toml_str(text, name, &base)).or_py()?;
        Ok(Scene { inner })
    }

    /// The built-in measured Cornell box (what `lucent render` renders without a scene file).
    #[staticmethod]
    fn cornell_box() -> Scene {
        Scene { inner: render::scene::Scene::cornell_box() }
    }

    /// The scene's own resolution (width, height) in pixels.
    #[getter]
    fn resolution(&self) -> (u32, u32) {
        self.inner.resolution()
    }

    /// Where the scene came from (its file name, or the built-in scene's).
    #[getter]
    fn source(&self) -> String {
        self.inner.source.clone()
    }

    /// The scene's integrator settings: (name, max_depth, rr_depth).
    #[getter]
    fn integrator(&self) -> (String, u32, u32) {
        let s = &self.inner.integrator;
        (s.kind.name().to_string(), s.max_depth, s.rr_depth)
    }

    fn __repr__(&self) -> String {
        let (w, h) = self.inner.resolution();
        format!("Scene({:?}, {w}×{h}, {} objects, {} lights)", self.inner.source, self.inner.objects.len(), self.inner.lights.len())
    }

    /// Render the scene and return the image as a float32 array of shape (height, width, 3) in
    /// linear sRGB primaries with a D65 white (spectral radiance 1 at every wavelength gives
    /// Y = 1), equal bit for bit to what `lucent render` writes to EXR or PFM with the same
    /// arguments.
    ///
    /// spp: samples per pixel (default 2^24 / pixels as a power of two, 64 at 512×512), or
    /// time_s: seconds of wall-clock time instead; seed: of the random sequence (default 0);
    /// integrator: "path", "volpath", "direct" or "ao" (default: the scene's); width, height:
    /// pixels (default: the scene's; one alone keeps the aspect ratio); max_depth, rr_depth:
    /// path segments (default: the scene's); threads: worker threads (default: all cores);
    /// progress: called as progress(spp_done, spp_target or None, elapsed_s) after each pass,
    /// before the next one starts; returning False stops the render there.
    ///
    /// The GIL is released while rendering. Ctrl-C (KeyboardInterrupt) and an exception raised
    /// by `progress` stop the render at the end of the current pass and propagate.
    #[pyo3(signature = (spp=None, seed=0, integrator=None, width=None, height=None, max_depth=None, rr_depth=None, threads=None, time_s=None, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &mut self,
        py: Python<'py>,
        spp: Option<i64>,
        seed: u64,
        integrator: Option<&str>,
        width: Option<i64>,
        height: Option<i64>,
        max_depth: Option<i64>,
        rr_depth: Option<i64>,
        threads: Option<i64>,
        time_s: Option<f64>,
        progress: Option<PyObject>,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        // ---- Arguments, checked as `lucent render` checks its flags. ----
        // Counts arrive as signed integers, so that a negative one is refused by name.
        let whole = |name: &str, v: Option<i64>| -> PyResult<Option<u64>> {
            match v {
                Some(x) if x < 0 => Err(value(format!("{name} must be a whole number ≥ 0, got {x}"))),
                Some(x) => Ok(Some(x as u64)),
                None => Ok(None),
            }
        };
        let (spp, width, height, max_depth, threads) = (whole("spp", spp)?, whole("width", width)?, whole("height", height)?, whole("max_depth", max_depth)?, whole("threads", threads)?);
        let rr_depth = match whole("rr_depth", rr_depth)? {
            Some(x) => Some(u32::try_from(x).map_err(|_| value(format!("rr_depth must be at most {}, got {x}", u32::MAX)))?),
            None => None,
        };
        let spp = at_least_one("spp", spp)?;
        if spp.is_some() && time_s.is_some() {
            return Err(value("give spp or time_s, not both"));
        }
        let width_arg = to_u32("width", width)?;
        let height_arg = to_u32("height", height)?;
        let max_depth = to_u32("max_depth", max_depth)?;
        let threads = at_least_one("threads", threads)?;
        if let Some(t) = threads {
            if t > 4096 {
                return Err(value(format!("threads must be at most 4096, got {t}")));
            }
        }
        let kind = match integrator {
            Some(name) => Some(
                IntegratorKind::from_name(name.trim().to_ascii_lowercase().as_str())
                    .ok_or_else(|| value(format!("integrator must be {}, got `{name}`", IntegratorKind::names_or())))?,
            ),
            None => None,
        };
        let stop_time = match time_s {
            Some(t) if !(t.is_finite() && t > 0.0 && t <= 1e9) => return Err(value(format!("time_s must be a number of seconds > 0, got {t}"))),
            Some(t) => Some(Stop::Time(Duration::from_secs_f64(t))),
            None => None,
        };
        let (w0, h0) = self.inner.resolution();
        let (w, h) = match (width_arg, height_arg) {
            (Some(w), Some(h)) => (w, h),
            (Some(w), None) => (w, ((w as f64 * h0 as f64 / w0 as f64).round() as u32).max(1)),
            (None, Some(h)) => (((h as f64 * w0 as f64 / h0 as f64).round() as u32).max(1), h),
            (None, None) => (w0, h0),
        };
        if w as u64 * h as u64 > 1 << 28 {
            return Err(value(format!("width × height = {w}×{h} pixels is too large")));
        }
        let base = self.inner.integrator.clone();
        let settings = IntegratorSettings {
            kind: kind.unwrap_or(base.kind),
            max_depth: max_depth.unwrap_or(base.max_depth),
            rr_depth: rr_depth.unwrap_or(base.rr_depth),
        };
        let stop = match (spp, stop_time) {
            (Some(n), _) => Stop::Spp(n),
            (None, Some(t)) => t,
            (None, None) => Stop::Spp(default_spp(w as u64 * h as u64)),
        };
        let pool = match threads {
            Some(t) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(t as usize)
                    .build()
                    .map_err(|e| value(format!("threads: cannot start worker threads: {e}")))?,
            ),
            None => None,
        };

        // ---- Render at the requested size, the scene's camera restored afterwards. ----
        let camera = self.inner.camera.clone();
        self.inner.set_resolution(w, h);
        let scene = &self.inner;
        let identity = RenderIdentity::of_scene(scene, &settings);
        let job = Job { scene, settings: &settings, identity: &identity, seed, first_pass: 0, stop, checkpoint: None };
        let cancel = AtomicBool::new(false);
        let (tx, rx) = mpsc::channel::<(u64, f64)>();
        // Receiver is not Sync; the wait without the GIL needs a shared reference to it.
        let rx = std::sync::Mutex::new(rx);
        // With a progress callback the worker waits after each pass until the callback has run,
        // so that what it returns (or raises) takes effect before the next pass.
        let (ack_tx, ack_rx) = mpsc::channel::<()>();
        let ack_rx = progress.as_ref().map(|_| std::sync::Mutex::new(ack_rx));
        let mut pending: Option<PyErr> = None;
        let target = stop.target_spp();
        let joined = std::thread::scope(|s| {
            let (job, cancel, pool) = (&job, &cancel, pool.as_ref());
            let worker = s.spawn(move || {
                let run = || {
                    job.run(Film::new(w, h), cancel, |event| {
                        if let Event::Pass { film, stats } = event {
                            let _ = tx.send((film.samples_per_pixel(), stats.elapsed.as_secs_f64()));
                            if let Some(Ok(ack)) = ack_rx.as_ref().map(|a| a.lock()) {
                                let _ = ack.recv();
                            }
                        }
                    })
                };
                match pool {
                    Some(p) => p.install(run),
                    None => run(),
                }
            });
            loop {
                let msg = py.allow_threads(|| match rx.lock() {
                    Ok(r) => r.recv_timeout(Duration::from_millis(50)),
                    Err(_) => Err(mpsc::RecvTimeoutError::Disconnected),
                });
                let got_pass = msg.is_ok();
                match msg {
                    Ok((done, elapsed)) => {
                        if let (Some(cb), None) = (&progress, &pending) {
                            match cb.call1(py, (done, target, elapsed)) {
                                Ok(r) => {
                                    if r.bind(py).extract::<bool>().ok() == Some(false) {
                                        cancel.store(true, Ordering::SeqCst);
                                    }
                                }
                                Err(e) => {
                                    cancel.store(true, Ordering::SeqCst);
                                    pending = Some(e);
                                }
                            }
                        }
                    }
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                    Err(mpsc::RecvTimeoutError::Disconnected) => break,
                }
                if pending.is_none() {
                    if let Err(e) = py.check_signals() {
                        cancel.store(true, Ordering::SeqCst);
                        pending = Some(e);
                    }
                }
                if got_pass && progress.is_some() {
                    let _ = ack_tx.send(());
                }
            }
            worker.join()
        });
        self.inner.camera = camera;
        let outcome = joined.map_err(|_| PyRuntimeError::new_err("the render failed (internal error); please report it with the scene"))?;
        if let Some(e) = pending {
            return Err(e);
        }
        outcome.saved.or_py()?;
        let image = outcome.film.to_image();
        let flat: Vec<f32> = image.rgb.iter().flatten().copied().collect();
        flat.into_pyarray(py).reshape([h as usize, w as usize, 3])
    }
}
