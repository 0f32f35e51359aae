//! Running element-wise work on rayon: the global pool, or a pool of `threads` workers when the
//! caller asks (so that single-thread timings can be measured).

use crate::errors::value;
use pyo3::PyResult;

/// Run `f` on a pool of `threads` workers (`None`: rayon's global pool, all cores).
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(value("threads: must be at least 1")),
        Some(n) if n > 4096 => Err(value(format!("threads: must be at most 4096, got {n}"))),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| value(format!("threads: cannot start the thread pool: {e}")))?;
            Ok(pool.install(f))
        }
    }
}
