//! Error type of the library: every failure a user can cause names what is wrong
//! (and, for files, the file and line).

use std::path::PathBuf;

/// Errors of g1tess. Each message is one line, fit to print after `error: `.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {cause}")]
    Io {
        path: PathBuf,
        /// Shown in the message itself (not as a separate cause, which would print twice).
        cause: std::io::Error,
    },
    /// A problem at a known line of an input file.
    #[error("{path}:{line}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// A problem with a mesh as a whole (empty, degenerate, ...).
    #[error("{name}: {message}")]
    Mesh { name: String, message: String },
    /// A bad argument (unknown scheme, bad built-in mesh spec, ...).
    #[error("{0}")]
    Invalid(String),
    /// The GPU backend could not run.
    #[error("gpu: {0}")]
    Gpu(String),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            cause: source,
        }
    }
    pub fn parse(path: impl Into<PathBuf>, line: usize, message: impl Into<String>) -> Self {
        Error::Parse {
            path: path.into(),
            line,
            message: message.into(),
        }
    }
    pub fn mesh(name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Mesh {
            name: name.into(),
            message: message.into(),
        }
    }
}
