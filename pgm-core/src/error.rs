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
    /// A training instance has a different number of labels than variables.
    #[error("training instance {instance}: {labels} labels for {variables} variables")]
    LabelCount {
        /// Index of the instance in the training set.
        instance: usize,
        /// Number of labels given.
        labels: usize,
        /// Number of variables of the instance's model.
        variables: usize,
    },
    /// A training label is not a state of its variable.
    #[error("training instance {instance}, variable {variable}: label {label} is out of range (the variable has {cardinality} states)")]
    LabelOutOfRange {
        /// Index of the instance in the training set.
        instance: usize,
        /// The variable.
        variable: usize,
        /// The offending label.
        label: usize,
        /// Number of states of the variable.
        cardinality: usize,
    },
    /// A variable of a training instance is in no clique, so pseudo-likelihood learning
    /// has nothing to learn from it (usually a model-building mistake).
    #[error("training instance {instance}, variable {variable}: the variable is in no clique")]
    VariableWithoutFactors {
        /// Index of the instance in the training set.
        instance: usize,
        /// The variable.
        variable: usize,
    },
    /// A feature value is NaN or infinite.
    #[error("{}clique {clique} at states {states:?}: feature {feature:?} is {value}; features must be finite", feature_location(.instance, .variable))]
    BadFeature {
        /// Index of the instance in the training set, when known.
        instance: Option<usize>,
        /// The variable whose local conditional needed the feature, when known.
        variable: Option<usize>,
        /// Index of the clique in its model.
        clique: usize,
        /// The clique's joint state.
        states: Vec<usize>,
        /// Name of the feature (its weight's name).
        feature: String,
        /// The offending value.
        value: f64,
    },
    /// A weight is NaN, infinite or beyond ±[`crate::learning::MAX_ABS_WEIGHT`].
    #[error("weight {name:?} = {value:?}: weights must be finite and at most 1e12 in magnitude")]
    BadWeight {
        /// Name of the weight.
        name: String,
        /// The offending value.
        value: f64,
    },
    /// A weight vector's names do not match the model's feature set.
    #[error("weights for model {model:?} do not match its features: missing {missing:?}, unexpected {extra:?}")]
    WeightNames {
        /// The model.
        model: String,
        /// Features of the model that have no weight.
        missing: Vec<String>,
        /// Weights that name no feature of the model.
        extra: Vec<String>,
    },
    /// Weights or instances belong to a different model or model version.
    #[error("expected model {expected_model:?} version {expected_version}, found model {found_model:?} version {found_version}")]
    ModelMismatch {
        /// The model expected.
        expected_model: String,
        /// Its version.
        expected_version: u32,
        /// The model found.
        found_model: String,
        /// Its version.
        found_version: u32,
    },
    /// A result of probability 0 was refused: the model has no assignment of positive
    /// probability (`Z = 0`: no MAP assignment exists and marginals cannot be
    /// normalised; [`ZeroProbability::proof`](crate::support::ZeroProbability::proof)
    /// says why), or a method's assignment has probability 0 and the search for a
    /// positive one met its limit (`proof` is `None`). See [`crate::support`].
    #[error("{0}")]
    Infeasible(Box<crate::support::ZeroProbability>),
    /// The optimiser failed (not: stopped early; that is reported in its result).
    #[error("L-BFGS: {0}")]
    Optimiser(String),
}

fn feature_location(instance: &Option<usize>, variable: &Option<usize>) -> String {
    match (instance, variable) {
        (Some(n), Some(v)) => format!("training instance {n}, variable {v}: "),
        (Some(n), None) => format!("training instance {n}: "),
        (None, Some(v)) => format!("variable {v}: "),
        (None, None) => String::new(),
    }
}

/// Result type of `pgm-core`.
pub type Result<T, E = Error> = std::result::Result<T, E>;
