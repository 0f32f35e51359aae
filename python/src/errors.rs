//! Library errors as Python exceptions: `OSError` when a file could not be read or written (an
//! `std::io::Error` anywhere in the cause chain), `ValueError` otherwise; the message is the
//! error and its causes on one line, as the `lucent` command prints it.

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::PyErr;

/// The one-line message of `e` with its causes (`outer: inner: …`).
pub fn one_line(e: &anyhow::Error) -> String {
    format!("{e:#}").replace('\n', " ")
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
