//! The crate's error type.

/// Everything that can go wrong in CRF-Clustering: invalid parameters, inputs it
/// cannot work on, and errors of the crates it builds on.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter is outside its allowed range (the workspace's one shape).
    #[error("parameter `{name}` = {value}: expected {expected}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// The offending value, as written.
        value: String,
        /// What would have been accepted.
        expected: &'static str,
    },
    /// A scan pair the model cannot work on (the message names the pair and the problem).
    #[error("pair `{pair}`: {problem}")]
    BadPair {
        /// Name of the pair.
        pair: String,
        /// What is wrong.
        problem: String,
    },
    /// An error of the shared scan code (geometry, registration, associations).
    #[error(transparent)]
    Features(#[from] pgm_scan::Error),
    /// An error of the inference or learning core.
    #[error(transparent)]
    Core(#[from] pgm_core::Error),
}

impl From<pgm_core::InvalidParameter> for Error {
    fn from(e: pgm_core::InvalidParameter) -> Self {
        Error::InvalidParameter {
            name: e.name,
            value: e.value,
            expected: e.expected,
        }
    }
}

impl From<Error> for pgm_scan::Error {
    fn from(e: Error) -> Self {
        match e {
            Error::InvalidParameter {
                name,
                value,
                expected,
            } => pgm_scan::Error::InvalidParameter {
                name,
                value,
                expected,
            },
            Error::BadPair { pair, problem } => pgm_scan::Error::BadPair { pair, problem },
            Error::Features(e) => e,
            Error::Core(e) => pgm_scan::Error::Core(e),
        }
    }
}

/// Result type of `pgm-crf-clustering`.
pub type Result<T> = std::result::Result<T, Error>;
