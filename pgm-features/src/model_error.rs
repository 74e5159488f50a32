//! The one error shape of the model crates (CRF-Clustering, CRF-Matching, the joint
//! model, the baselines): each re-exports [`ModelError`] as its `Error`. It wraps the
//! errors of the crates below with `#[from]` (the scan layer's, which the feature code
//! shares, the core's, a weight file's) and never turns them into strings; through the
//! method traits it travels as [`pgm_scan::Error::Method`], from which a caller
//! downcasts it back.
//!
//! ```
//! use pgm_features::{ModelError, WeightFileError};
//!
//! let e = ModelError::from(WeightFileError::Field {
//!     origin: "w.json".into(),
//!     field: "model".into(),
//!     problem: "missing".into(),
//! });
//! let through_a_trait = pgm_scan::Error::from(e);
//! assert_eq!(through_a_trait.to_string(), "w.json: field `model`: missing");
//! assert!(matches!(
//!     through_a_trait.downcast_method::<ModelError>(),
//!     Some(ModelError::WeightFile(WeightFileError::Field { .. }))
//! ));
//! ```

use crate::weight_file::WeightFileError;

/// Everything that can go wrong in a model: invalid parameters, inputs it cannot work
/// on, weight files, and errors of the crates it builds on.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
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
    /// A weight file that cannot be read, written or used (the message names the file).
    #[error(transparent)]
    WeightFile(#[from] WeightFileError),
    /// An error of the scan layer and the feature code that shares its error
    /// (geometry, registration, associations, boosters).
    #[error(transparent)]
    Features(#[from] pgm_scan::Error),
    /// An error of the inference or learning core.
    #[error(transparent)]
    Core(#[from] pgm_core::Error),
}

impl ModelError {
    /// This error as the reason the weights of `origin` (a file, or another source)
    /// are refused: [`WeightFileError::Rejected`], which names `origin` first.
    pub fn in_weight_file(self, origin: &str) -> Self {
        ModelError::WeightFile(WeightFileError::Rejected {
            origin: origin.to_string(),
            source: Box::new(self),
        })
    }
}

impl From<pgm_core::InvalidParameter> for ModelError {
    fn from(e: pgm_core::InvalidParameter) -> Self {
        ModelError::InvalidParameter {
            name: e.name,
            value: e.value,
            expected: e.expected,
        }
    }
}

/// A model's error through the method traits: an error of the scan layer stays itself,
/// anything else is the model's own, carried whole ([`pgm_scan::Error::Method`]).
impl From<ModelError> for pgm_scan::Error {
    fn from(e: ModelError) -> Self {
        match e {
            ModelError::Features(e) => e,
            other => pgm_scan::Error::method(other),
        }
    }
}

/// Result type of the model crates.
pub type ModelResult<T> = std::result::Result<T, ModelError>;
