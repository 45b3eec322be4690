//! Error type of the library: every failure a user can cause names what is wrong
//! (and, for files, the file and line).
//!
//! Callers can match on the kind of failure (an unsupported format, a memory budget, a
//! missing GPU feature or an exceeded GPU limit, ...); every variant prints the same one-line
//! message, fit to print after `error: `.

use std::path::PathBuf;

/// Errors of g1tess. Each message is one line, fit to print after `error: `.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {cause}")]
    Io {
        /// The file (or directory) that failed.
        path: PathBuf,
        /// Shown in the message itself (not as a separate cause, which would print twice).
        cause: std::io::Error,
    },
    /// A problem at a known line of an input file.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The input file.
        path: PathBuf,
        /// The line, counted from 1.
        line: usize,
        /// What is wrong on that line.
        message: String,
    },
    /// A problem with a mesh as a whole (empty, degenerate, ...).
    #[error("{name}: {message}")]
    Mesh {
        /// The mesh's name (its file or built-in spec).
        name: String,
        /// What is wrong with it.
        message: String,
    },
    /// A file or format the library cannot read or write: an unknown extension, an unknown
    /// PLY format, an unknown output format name, ...
    #[error("{name}: {what}")]
    UnsupportedFormat {
        /// The path or format name given (with `:LINE` where a file's header names the
        /// format).
        name: String,
        /// What is unsupported, with the formats that are (the rest of the message).
        what: String,
    },
    /// A bad argument (unknown scheme, bad built-in mesh spec, ...), where no more specific
    /// variant fits.
    #[error("{0}")]
    Invalid(String),
    /// A run that would need more memory than its budget allows.
    #[error("{message}")]
    OverBudget {
        /// What needs the memory (for example "the surface grid").
        what: String,
        /// Bytes the run needs.
        needed: u64,
        /// Bytes the budget allows.
        allowed: u64,
        /// The whole message (it also says how to get under the budget).
        message: String,
    },
    /// No GPU adapter could be opened (no Vulkan, Metal or DX12 driver).
    #[error("gpu: {message}")]
    NoAdapter {
        /// The driver's reason.
        detail: String,
        /// The whole message (it names the backends tried and the driver to install).
        message: String,
    },
    /// The GPU device lacks a feature the work needs.
    #[error("gpu: {message}")]
    MissingFeature {
        /// The wgpu feature's name, for example "SHADER_F64".
        feature: String,
        /// The whole message (it says what needs the feature and what works without it).
        message: String,
    },
    /// The work needs more than a limit of the GPU device allows.
    #[error("gpu: {message}")]
    LimitExceeded {
        /// The wgpu limit's name, for example "max_storage_buffer_binding_size".
        name: String,
        /// The value the work needs (bytes for sizes).
        needed: u64,
        /// The value the device allows.
        allowed: u64,
        /// The whole message (it names the work and the sizes in the units it reports).
        message: String,
    },
    /// The GPU device was lost (driver reset, device removed, out of memory, ...).
    #[error("gpu: {device}: device lost: {reason}")]
    DeviceLost {
        /// The adapter's name.
        device: String,
        /// The driver's reason.
        reason: String,
    },
    /// Any other GPU failure (a shader that does not compile, a failed mapping, validation
    /// errors reported by wgpu, ...).
    #[error("gpu: {0}")]
    Gpu(String),
}

/// The library's result: [`Error`] unless another error type is named.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An [`Error::Io`].
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            cause: source,
        }
    }
    /// An [`Error::Parse`].
    pub fn parse(path: impl Into<PathBuf>, line: usize, message: impl Into<String>) -> Self {
        Error::Parse {
            path: path.into(),
            line,
            message: message.into(),
        }
    }
    /// An [`Error::Mesh`].
    pub fn mesh(name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Mesh {
            name: name.into(),
            message: message.into(),
        }
    }
    /// An [`Error::UnsupportedFormat`]: prints "NAME: WHAT".
    pub fn unsupported(name: impl Into<String>, what: impl Into<String>) -> Self {
        Error::UnsupportedFormat {
            name: name.into(),
            what: what.into(),
        }
    }
    /// An [`Error::LimitExceeded`] of the GPU limit `name`; prints "gpu: MESSAGE".
    pub fn limit(
        name: impl Into<String>,
        needed: u64,
        allowed: u64,
        message: impl Into<String>,
    ) -> Self {
        Error::LimitExceeded {
            name: name.into(),
            needed,
            allowed,
            message: message.into(),
        }
    }
    /// An [`Error::MissingFeature`] of the GPU feature `feature`; prints "gpu: MESSAGE".
    pub fn missing_feature(feature: impl Into<String>, message: impl Into<String>) -> Self {
        Error::MissingFeature {
            feature: feature.into(),
            message: message.into(),
        }
    }
}
