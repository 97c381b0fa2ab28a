//! One error type for the whole crate. Every variant names what the user must fix:
//! the file, and the line or field where the problem is.

use std::path::PathBuf;

/// Errors radsplat reports to its users.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An input file could not be read (missing, unreadable).
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file was found but its content is wrong. `location` is "line N", "line N, column M",
    /// or a field path such as "camera.resolution".
    #[error("{path}: {location}: {message}")]
    Invalid {
        path: PathBuf,
        location: String,
        message: String,
    },
    /// An asset referenced from a scene could not be found along the search path.
    #[error("{scene}: {field}: cannot find '{name}' (looked in: {searched})")]
    AssetNotFound {
        scene: PathBuf,
        field: String,
        name: String,
        searched: String,
    },
    /// A request the device cannot satisfy (resolution, buffer sizes, missing features).
    #[error("device limit: {0}")]
    DeviceLimit(String),
    /// No usable GPU adapter, device creation failed, or the device was lost.
    #[error("GPU: {0}")]
    Gpu(String),
    /// Writing an output file failed (nothing partial is left behind).
    #[error("cannot write {path}: {message}")]
    Output { path: PathBuf, message: String },
    /// Bad command-line or API usage.
    #[error("{0}")]
    Usage(String),
}

/// Crate-wide result type.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Shorthand for [`Error::Invalid`].
    pub fn invalid(
        path: impl Into<PathBuf>,
        location: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Error::Invalid {
            path: path.into(),
            location: location.into(),
            message: message.into(),
        }
    }

    /// Shorthand for [`Error::Io`].
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}
