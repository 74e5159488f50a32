//! The crate's error type. Every variant carries the offending values, and parser
//! errors carry the file and line they come from.

use std::path::PathBuf;

/// Errors of `pgm-core`.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A variable was declared with cardinality zero.
    #[error("variable {variable}: cardinality must be at least 1, got 0")]
    ZeroCardinality {
        /// Index of the variable.
        variable: usize,
    },
    /// A factor names a variable the graph does not have.
    #[error("factor {factor}: scope names variable {variable}, but the graph has {num_variables} variables")]
    UnknownVariable {
        /// Index the factor would get.
        factor: usize,
        /// The unknown variable index.
        variable: usize,
        /// Number of variables in the graph.
        num_variables: usize,
    },
    /// A factor's shape disagrees with the cardinality of a variable in its scope.
    #[error("factor {factor}: scope position {position} (variable {variable}) has {factor_states} states in the factor but {variable_states} in the graph")]
    ShapeMismatch {
        /// Index the factor would get.
        factor: usize,
        /// Position in the scope.
        position: usize,
        /// The variable.
        variable: usize,
        /// States the factor assumes.
        factor_states: usize,
        /// States the graph declares.
        variable_states: usize,
    },
    /// A variable appears twice in one factor's scope.
    #[error("factor scope lists variable {variable} twice")]
    RepeatedVariable {
        /// The repeated variable.
        variable: usize,
    },
    /// A log-table has the wrong number of entries.
    #[error("log-table has {actual} entries, expected {expected} (product of the scope's cardinalities)")]
    TableSize {
        /// Expected size.
        expected: usize,
        /// Actual size.
        actual: usize,
    },
    /// A log-potential is NaN or +∞ (−∞ is allowed: it is a hard zero).
    #[error("log-potential at entry {index} is {value}: log-potentials must be finite or -inf")]
    BadLogPotential {
        /// Entry index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A parameter is out of its allowed range.
    #[error("{name} = {value}: {expected}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Offending value, printed.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// An assignment does not fit the graph.
    #[error("assignment: {0}")]
    BadAssignment(String),
    /// An exact method was asked for a graph it cannot handle.
    #[error("{method}: {reason}")]
    NotApplicable {
        /// The method.
        method: &'static str,
        /// Why not.
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A model, evidence or result file is malformed.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number (0 when the file ended early).
        line: usize,
        /// What was expected and what was found.
        message: String,
    },
    /// A learning problem is malformed (bad labels, features, weights).
    #[error("{0}")]
    Learning(String),
}

/// Result type of `pgm-core`.
pub type Result<T, E = Error> = std::result::Result<T, E>;
