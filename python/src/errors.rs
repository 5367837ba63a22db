//! btfpt's errors as Python exceptions (`btfpt.errors`, defined in Python so that each one also
//! derives from the matching built-in: `MissingFileError` is a `FileNotFoundError`, the format
//! and argument errors are `ValueError`s). The message is the library error's own text, which
//! is what the CLI prints.

use pyo3::prelude::*;
use pyo3::types::PyType;

/// The `btfpt.errors` class named `name`, instantiated with `msg`.
fn raise(py: Python<'_>, name: &str, msg: String) -> PyErr {
    let class = py
        .import("btfpt.errors")
        .and_then(|m| m.getattr(name))
        .and_then(|c| Ok(c.cast_into::<PyType>()?));
    match class {
        Ok(c) => PyErr::from_type(c, msg),
        Err(e) => e,
    }
}

/// A library error as the matching `btfpt.errors` exception.
pub fn to_py(e: btfpt::Error) -> PyErr {
    Python::attach(|py| {
        let msg = e.to_string();
        let missing = |p: &std::path::Path| !p.as_os_str().is_empty() && !p.exists();
        match &e {
            btfpt::Error::Io { path, source } => {
                if source.kind() == std::io::ErrorKind::NotFound || missing(path) {
                    raise(py, "MissingFileError", msg)
                } else {
                    raise(py, "IoError", msg)
                }
            }
            btfpt::Error::Format { path, .. } if missing(path) => {
                raise(py, "MissingFileError", msg)
            }
            btfpt::Error::Format { .. } => raise(py, "FormatError", msg),
            btfpt::Error::Scene { .. } => raise(py, "SceneError", msg),
            btfpt::Error::Invalid(_) => raise(py, "InvalidArgumentError", msg),
            btfpt::Error::Interrupted(_) => raise(py, "Interrupted", msg),
        }
    })
}

/// `btfpt.errors.InvalidArgumentError(msg)`.
pub fn invalid(msg: impl Into<String>) -> PyErr {
    Python::attach(|py| raise(py, "InvalidArgumentError", msg.into()))
}

/// `btfpt.errors.MissingFileError(msg)`.
pub fn missing(msg: impl Into<String>) -> PyErr {
    Python::attach(|py| raise(py, "MissingFileError", msg.into()))
}

/// `Result<T, btfpt::Error>` → `PyResult<T>`.
pub trait IntoPy<T> {
    /// The error as its Python exception.
    fn py_err(self) -> PyResult<T>;
}

impl<T> IntoPy<T> for btfpt::Result<T> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(to_py)
    }
}
