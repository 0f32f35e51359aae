//! Library errors as Python exceptions: `OSError` when a file could not be read or written (an
//! `std::io::Error` anywhere in the cause chain), `ValueError` otherwise; the message is the
//! error and its causes on one line, as the `lucent` command prints it.

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::PyErr;

/// The one-line message of `e` with its causes (`outer: inner: …`), with the command line's
/// names of the shared checks (`--fat-percent`, `n-above`, …) given as the Python arguments'
/// (`fat_percent`, `n_above`, …).
pub fn one_line(e: &anyhow::Error) -> String {
    python_names(&format!("{e:#}").replace('\n', " "))
}

/// Flag names (`--word-word`) and the slab checks' bare names as Python argument names.
fn python_names(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len());
    let mut rest = msg;
    while let Some(i) = rest.find("--") {
        out.push_str(&rest[..i]);
        let after = &rest[i + 2..];
        let len = after.find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')).unwrap_or(after.len());
        if len > 0 && after.as_bytes()[0].is_ascii_lowercase() {
            out.push_str(&after[..len].replace('-', "_"));
        } else {
            out.push_str("--");
            out.push_str(&after[..len]);
        }
        rest = &after[len..];
    }
    out.push_str(rest);
    for bare in ["n-above", "n-below", "incidence-deg", "radial-bins", "radial-max-mm", "line-bins", "line-max-mm", "max-steps-per-photon"] {
        out = out.replace(bare, &bare.replace('-', "_"));
    }
    out
}

/// `OSError` for file errors, `ValueError` for everything else.
pub fn to_py(e: anyhow::Error) -> PyErr {
    let msg = one_line(&e);
    if e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some()) {
        PyOSError::new_err(msg)
    } else {
        PyValueError::new_err(msg)
    }
}

/// A `ValueError` with this message.
pub fn value(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// `Result` of the library into a Python result.
pub trait OrPy<T> {
    fn or_py(self) -> pyo3::PyResult<T>;
}

impl<T> OrPy<T> for anyhow::Result<T> {
    fn or_py(self) -> pyo3::PyResult<T> {
        self.map_err(to_py)
    }
}
