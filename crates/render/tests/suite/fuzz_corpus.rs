//! Replays the fuzz corpus and the fuzz reproducers through the library on every `cargo test`.
//!
//! Every file under `fuzz/corpus/<target>/` and `fuzz/regressions/<target>/` goes through the
//! same calls as the fuzz target of that name (`fuzz/src/calls.rs`, included below): a panic
//! fails the test. Reproducers of crashes not fixed yet are listed in
//! `fuzz/regressions/KNOWN_FAILURES.txt` and skipped (with a note on stderr) until fixed: remove
//! a file's line once it passes. See `fuzz/README.md`.

use std::path::{Path, PathBuf};

#[path = "../../../../fuzz/src/calls.rs"]
mod calls;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Paths relative to `fuzz/regressions/` of the reproducers that still crash.
fn known_failures() -> Vec<String> {
    let list = repo().join("fuzz/regressions/KNOWN_FAILURES.txt");
    let text = std::fs::read_to_string(&list).unwrap_or_default();
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty())
        .map(str::to_string)
        .collect()
}

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(rd) => rd.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.is_file() && !p.file_name().unwrap().to_string_lossy().starts_with('.')).collect(),
        Err(_) => Vec::new(),
    };
    out.sort();
    out
}

fn replay(folder: &str) -> usize {
    let repo = repo();
    let skip = known_failures();
    let mut count = 0;
    for target in calls::TARGETS {
        for path in files(&repo.join("fuzz").join(folder).join(target)) {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if folder == "regressions" && skip.contains(&format!("{target}/{name}")) {
                eprintln!("skipped (listed in fuzz/regressions/KNOWN_FAILURES.txt): {target}/{name}");
                continue;
            }
            let data = std::fs::read(&path).unwrap();
            eprintln!("{folder}/{target}/{name}");
            calls::run(target, &data, &repo);
            count += 1;
        }
    }
    count
}

#[test]
fn corpus_replays_without_panic() {
    let n = replay("corpus");
    assert!(n >= calls::TARGETS.len(), "only {n} corpus files found under fuzz/corpus/");
}

#[test]
fn regressions_replay_without_panic() {
    replay("regressions");
}

#[test]
fn known_failures_exist() {
    // A stale line (file renamed or removed) would skip nothing and hide nothing: refuse it.
    for entry in known_failures() {
        let path = repo().join("fuzz/regressions").join(&entry);
        assert!(path.is_file(), "fuzz/regressions/KNOWN_FAILURES.txt names {entry}, which does not exist");
    }
}
