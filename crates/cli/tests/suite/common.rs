//! Helpers shared by the `lucent` command tests.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicU32, Ordering};

/// The `lucent` binary under test.
pub fn lucent() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lucent"))
}

/// A scratch folder, unique to the process and the call, removed at the end of the test.
pub struct Scratch(pub PathBuf);

impl Scratch {
    pub fn new(name: &str) -> Scratch {
        static N: AtomicU32 = AtomicU32::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("lucent-cli-{name}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
    pub fn path(&self, file: &str) -> PathBuf {
        self.0.join(file)
    }
    pub fn arg(&self, file: &str) -> String {
        self.path(file).display().to_string()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `lucent ARGS` run in `dir`.
pub fn run(dir: &Path, args: &[&str]) -> Output {
    lucent().current_dir(dir).args(args).output().expect("cannot start lucent")
}

/// `lucent ARGS` must succeed; its stdout parsed as JSON.
pub fn ok_json(args: &[&str]) -> serde_json::Value {
    let out = lucent().args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{args:?}: {e}: {}", String::from_utf8_lossy(&out.stdout)))
}

/// `lucent ARGS` must fail with exit ≠ 0, one line on stderr and no panic; returns that line.
pub fn fails_on_one_line(args: &[&str]) -> String {
    let out = lucent().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} succeeded");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}
