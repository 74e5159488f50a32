//! Named weight vectors and their JSON files.
//!
//! A weight file names its model and version and maps every feature name to its
//! weight, in the feature set's order:
//!
//! ```json
//! {
//!   "model": "crf-clustering",
//!   "version": 1,
//!   "weights": {
//!     "distance.cluster": -1.25,
//!     "neighbour.same": 0.5
//!   }
//! }
//! ```
//!
//! Loading checks the model, the version and the names against a [`FeatureSet`] and
//! lists missing and unexpected names; saving writes a temporary file next to the
//! target and renames it, so a crash never leaves a half-written file.

use super::model::FeatureSet;
use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::fmt;
use std::fs;
use std::path::Path;
use std::sync::Arc;

/// A weight vector with the feature set that names it.
///
/// ```
/// use std::sync::Arc;
/// use pgm_core::learning::{FeatureSet, Weights};
/// let mut features = FeatureSet::new("toy", 1);
/// features.add_template("pair", &["same", "different"]).unwrap();
/// let weights = Weights::new(Arc::new(features), vec![1.5, -0.25]).unwrap();
/// assert_eq!(weights.get("pair.different"), Some(-0.25));
/// let text = weights.to_json();
/// let back = Weights::from_json(Arc::clone(weights.feature_set()), &text).unwrap();
/// assert_eq!(back, weights);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Weights {
    features: Arc<FeatureSet>,
    values: Vec<f64>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct WeightFile {
    model: String,
    version: u32,
    weights: BTreeMap<String, f64>,
}

impl Weights {
    /// Weights with one finite value per feature of `features`, in its order.
    pub fn new(features: Arc<FeatureSet>, values: Vec<f64>) -> Result<Self> {
        features.check_weights(&values)?;
        Ok(Self { features, values })
    }

    /// All weights zero.
    pub fn zeros(features: Arc<FeatureSet>) -> Self {
        let values = vec![0.0; features.num_weights()];
        Self { features, values }
    }

    /// The feature set naming the weights.
    pub fn feature_set(&self) -> &Arc<FeatureSet> {
        &self.features
    }

    /// The values, in feature-set order.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The weight named `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.features.index_of(name).map(|j| self.values[j])
    }

    /// `(name, value)` pairs in feature-set order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> + '_ {
        self.features
            .names()
            .iter()
            .map(|n| n.as_str())
            .zip(self.values.iter().copied())
    }

    /// The JSON text of the weight file (pretty-printed, feature-set order).
    pub fn to_json(&self) -> String {
        let string = |s: &str| serde_json::to_string(s).unwrap_or_else(|_| format!("{s:?}"));
        let mut out = String::from("{\n");
        out += &format!("  \"model\": {},\n", string(self.features.model()));
        out += &format!("  \"version\": {},\n", self.features.version());
        out += "  \"weights\": {\n";
        for (j, (name, value)) in self.iter().enumerate() {
            let comma = if j + 1 < self.values.len() { "," } else { "" };
            // Finite by construction; `{:?}` prints the shortest round-trip form.
            out += &format!("    {}: {value:?}{comma}\n", string(name));
        }
        out += "  }\n}\n";
        out
    }

    /// Parses a weight file's text for `features` (`source` names it in errors).
    fn parse(features: Arc<FeatureSet>, text: &str, source: &Path) -> Result<Self> {
        let file: WeightFile = serde_json::from_str(text).map_err(|e| Error::Parse {
            path: source.to_path_buf(),
            line: e.line(),
            message: e.to_string(),
        })?;
        if file.model != features.model() || file.version != features.version() {
            return Err(Error::ModelMismatch {
                expected_model: features.model().to_string(),
                expected_version: features.version(),
                found_model: file.model,
                found_version: file.version,
            });
        }
        let found: Vec<String> = file.weights.keys().cloned().collect();
        let mut values = Vec::with_capacity(features.num_weights());
        for name in features.names() {
            match file.weights.get(name) {
                Some(&v) => values.push(v),
                None => return Err(features.name_mismatch(&found)),
            }
        }
        if found.len() != values.len() {
            return Err(features.name_mismatch(&found));
        }
        Self::new(features, values)
    }

    /// Reads weights for `features` from JSON text.
    pub fn from_json(features: Arc<FeatureSet>, text: &str) -> Result<Self> {
        Self::parse(features, text, Path::new("<weights>"))
    }

    /// Reads a weight file written by [`save`](Self::save) for `features`.
    pub fn load(features: Arc<FeatureSet>, path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(features, &text, path)
    }

    /// Writes the weight file atomically (temporary file in the same directory, then
    /// rename).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        crate::fsutil::write_atomically(path, self.to_json().as_bytes())
    }
}

impl fmt::Display for Weights {
    /// `{name: value, ...}` in feature-set order.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{{")?;
        for (j, (name, value)) in self.iter().enumerate() {
            if j > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{name}: {value}")?;
        }
        write!(f, "}}")
    }
}
