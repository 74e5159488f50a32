//! The crate's error type: bad parameters, pairs and scans the geometry cannot work
//! on, and errors of the inference core. Every variant names the offending value and,
//! where there is one, the pair.

/// Errors of `pgm-features`.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter is outside its allowed range (the workspace's one shape, see
    /// [`pgm_core::param`]).
    #[error("parameter `{name}` = {value}: expected {expected}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// The offending value, as written.
        value: String,
        /// What would have been accepted.
        expected: &'static str,
    },
    /// A scan has no valid return (before the pair is known; see [`Error::in_pair`]).
    #[error("the {which} scan has no valid return")]
    EmptyScan {
        /// Which scan (`reference` or `current`).
        which: &'static str,
    },
    /// A scan pair a method cannot work on (the message names the pair and the problem).
    #[error("pair `{pair}`: {problem}")]
    BadPair {
        /// Name of the pair.
        pair: String,
        /// What is wrong.
        problem: String,
    },
    /// Associations do not fit the pair's current scan.
    #[error(
        "pair `{pair}`: {associations} associations for the {beams} beams of the current scan"
    )]
    AssociationCount {
        /// Name of the pair.
        pair: String,
        /// Number of associations given.
        associations: usize,
        /// Number of beams of the current scan.
        beams: usize,
    },
    /// An error of the inference or learning core.
    #[error(transparent)]
    Core(#[from] pgm_core::Error),
}

impl Error {
    /// The error with the pair named: an error about a scan or a parameter becomes
    /// [`Error::BadPair`] of `pair`; errors that already name a pair stay as they are.
    pub fn in_pair(self, pair: &str) -> Self {
        match self {
            Error::EmptyScan { .. } | Error::InvalidParameter { .. } | Error::Core(_) => {
                Error::BadPair {
                    pair: pair.to_string(),
                    problem: self.to_string(),
                }
            }
            other => other,
        }
    }
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

/// Result type of `pgm-features`.
pub type Result<T> = std::result::Result<T, Error>;
