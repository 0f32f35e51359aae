//! What the benchmarks share: files bundled with the repository and the process's CPU clock.

use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

/// A file bundled with the repository (`rel`, relative to its root), looked up from the current
/// directory, then from the source tree; `what` names the flag or argument that overrides it.
pub(crate) fn bundled(rel: &str, what: &str) -> Result<PathBuf> {
    let p = Path::new(rel);
    if p.exists() {
        return Ok(p.to_path_buf());
    }
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(rel);
    if src.exists() {
        return Ok(src);
    }
    bail!("default {rel} not found (run from the repository root or {what})")
}

/// CPU time (user + system) of this process so far, seconds, from /proc/self/stat (Linux; 0 elsewhere).
pub(crate) fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15 (1-based).
    let Some(rest) = stat.rfind(')').map(|i| &stat[i + 1..]) else { return 0.0 };
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}
