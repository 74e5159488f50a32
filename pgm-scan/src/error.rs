//! The crate's error type: bad parameters, pairs and scans the geometry cannot work
//! on, errors of the inference core, and a method's own error carried whole through the
//! method traits ([`Error::Method`]). Every variant names the offending value and,
//! where there is one, the pair.

/// Errors of the scan layer (and of `pgm-features`, which uses them), and the
/// error of the method traits.
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
    /// A method's own error, carried whole through the method traits
    /// ([`ScanMatcher`](crate::ScanMatcher), [`MotionClusterer`](crate::MotionClusterer),
    /// [`JointEstimator`](crate::methods::JointEstimator),
    /// [`AssociationSource`](crate::AssociationSource)): a model's error (its weight
    /// file, its parameters) keeps its type and its message. [`Error::method`] wraps
    /// one, [`Error::downcast_method`] gives it back.
    #[error(transparent)]
    Method(Box<dyn std::error::Error + Send + Sync + 'static>),
}

impl Error {
    /// `error`, a method's own, carried whole ([`Error::Method`]).
    pub fn method(error: impl std::error::Error + Send + Sync + 'static) -> Self {
        Error::Method(Box::new(error))
    }

    /// The method's own error of type `E` this error carries, if it is one
    /// ([`Error::Method`] holding an `E`).
    ///
    /// ```
    /// use pgm_scan::Error;
    /// let e = Error::method(std::fmt::Error);
    /// assert!(e.downcast_method::<std::fmt::Error>().is_some());
    /// assert_eq!(e.to_string(), std::fmt::Error.to_string());
    /// ```
    pub fn downcast_method<E: std::error::Error + 'static>(&self) -> Option<&E> {
        match self {
            Error::Method(e) => e.downcast_ref::<E>(),
            _ => None,
        }
    }

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
