//! One error type for the whole crate, split the way png splits it: I/O, a malformed file, a
//! well-formed file this version cannot read, caller misuse, limits, and bad input data.

use std::fmt;
use std::path::PathBuf;

/// Where in a `.sbrdf` file something went wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// Byte offset from the start of the file.
    pub offset: u64,
    /// The four-letter type of the chunk, when inside one.
    pub chunk: Option<[u8; 4]>,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.chunk {
            Some(c) => write!(
                f,
                "byte {} (chunk '{}')",
                self.offset,
                String::from_utf8_lossy(&c).escape_default()
            ),
            None => write!(f, "byte {}", self.offset),
        }
    }
}

/// Every error this crate returns; see each variant for when.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "I/O".into()))]
    Io {
        /// The file concerned, when there is one.
        path: Option<PathBuf>,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The file is damaged or is not an sbrdf file.
    #[error("malformed sbrdf file at {at}: {message}")]
    Format {
        /// Where in the file.
        at: Location,
        /// What is wrong.
        message: String,
    },
    /// The file is well formed but needs a newer reader (newer major version, unknown critical
    /// chunk, unknown enumeration value).
    #[error("unsupported sbrdf file at {at}: {message}")]
    Unsupported {
        /// Where in the file.
        at: Location,
        /// What this version cannot read.
        message: String,
    },
    /// The caller asked for something invalid (options, query arguments).
    #[error("{0}")]
    Parameter(String),
    /// A count or size exceeds the configured limits.
    #[error("limit exceeded: {0}")]
    LimitsExceeded(String),
    /// Bad input samples (CSV, EXR): the message names the file and line.
    #[error("{0}")]
    Input(String),
}

impl Error {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: Some(path.into()),
            source,
        }
    }
}

/// `std::result::Result` with this crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
