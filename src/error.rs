//! The library's error type: every variant names the file (and where possible the line) at fault,
//! so the CLI can print one clear sentence and exit non-zero.

use std::path::PathBuf;

/// All recoverable failures of the library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An operating-system I/O failure on a named file.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A problem in a scene description, with the 1-based line of the offending element.
    #[error("{file}:{line}: {msg}")]
    Scene {
        file: PathBuf,
        line: u32,
        msg: String,
    },
    /// A file whose content is malformed, truncated, corrupt or unsupported.
    #[error("{path}: {msg}")]
    Format { path: PathBuf, msg: String },
    /// An invalid argument or setting that is not tied to a file.
    #[error("{0}")]
    Invalid(String),
    /// Work stopped on request (Ctrl-C, SIGTERM, SIGHUP) after saving what can be resumed; the
    /// message says what was kept and how to continue.
    #[error("{0}")]
    Interrupted(String),
}

/// Shorthand used throughout the library.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Wraps an I/O error with the path it happened on.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// A format error on `path`.
    pub fn format(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Error::Format {
            path: path.into(),
            msg: msg.into(),
        }
    }
}
