//! The crate's error type.

/// Everything that can go wrong in CRF-Clustering: invalid parameters, inputs it
/// cannot work on, and errors of the crates it builds on.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter is outside its allowed range.
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
    /// An error of a baseline (ICP while computing associations).
    #[error(transparent)]
    Baseline(#[from] pgm_baselines::Error),
}

/// Result type of `pgm-crf-clustering`.
pub type Result<T> = std::result::Result<T, Error>;
