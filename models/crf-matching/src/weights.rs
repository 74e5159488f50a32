//! The model's named weights (the paper's 18), its two boosters, and the shipped
//! defaults.
//!
//! | template | weights | feature (of states `a` at point `i`, `b` at point `i + 1`) |
//! |---|---|---|
//! | `data_boosting` | `score` | the data booster's margin `F_d(i, j)` on candidate states `j` |
//! | `outlier_boosting` | `score`, `bias` | the outlier booster's margin `F_o(i)`, and 1, on the outlier state |
//! | `registered_translation` | `squared`, `normalised` | `‖M s_i − g_j‖²` (m²) and the same over the association variance `σ_i²` |
//! | `sequence` | `same`, `next`, `skip`, `back`, `near`, `far` | inlier → inlier transitions by the reference index step `j' − j`: 0, 1, 2, −1, another step within the band, outside the band |
//! | `pairwise_outlier` | `leave`, `enter`, `stay` | inlier → outlier, outlier → inlier, outlier → outlier |
//! | `pairwise_distance` | `squared`, `normalised` | `(‖g_j' − g_j‖ − ‖s_{i+1} − s_i‖)²` within the band, and over `σ_i² + σ_{i+1}²` |
//! | `pairwise_translation` | `squared`, `normalised` | `‖(g_j' − g_j) − R(s_{i+1} − s_i)‖²` within the band, and over `σ_i² + σ_{i+1}²` |
//!
//! The default weights and boosters (`weights/default.json`, compiled in with
//! `include_str!`) were learned from simulated pairs; the command that produced them
//! is in the crate's README section of the workspace README.

use crate::{Error, Result};
use pgm_core::learning::{FeatureSet, Weights};
use pgm_features::matching_features::{
    check_association_weights, read_boosted_weights, write_boosted_weights, AssociationBoosters,
    ASSOCIATION_TEMPLATES, ASSOCIATION_WEIGHTS,
};

use std::path::Path;
use std::sync::Arc;

/// Name of the model in weight files.
pub const MODEL_NAME: &str = "crf-matching";
/// Version of the feature set (bump when features change meaning).
pub const MODEL_VERSION: u32 = 1;
/// The default weights and boosters as JSON (`weights/default.json`).
pub const DEFAULT_WEIGHTS_JSON: &str = include_str!("../weights/default.json");

/// Number of weights.
pub const WEIGHTS: usize = ASSOCIATION_WEIGHTS;

/// The 18 named weights of CRF-Matching (see the module table and
/// [`ASSOCIATION_TEMPLATES`]).
pub fn feature_set() -> Arc<FeatureSet> {
    let mut f = FeatureSet::new(MODEL_NAME, MODEL_VERSION);
    for (name, features) in ASSOCIATION_TEMPLATES {
        f.add_template(name, features)
            .expect("fixed template names are valid");
    }
    Arc::new(f)
}

/// The learned parameters of CRF-Matching: the log-linear weights and the two
/// boosters that make its local features.
#[derive(Clone, Debug, PartialEq)]
pub struct MatchingWeights {
    /// The 18 weights in [`feature_set`] order.
    pub weights: Vec<f64>,
    /// The data and outlier boosters.
    pub boosters: AssociationBoosters,
}

impl MatchingWeights {
    /// Checks the sizes: 18 finite weights, boosters over the right feature counts
    /// with finite stumps.
    pub fn check_ref(&self) -> Result<()> {
        check_association_weights(&self.weights)?;
        self.boosters.check_ref()?;
        Ok(())
    }

    /// The weights as named [`Weights`].
    pub fn named(&self) -> Result<Weights> {
        Ok(Weights::new(feature_set(), self.weights.clone())?)
    }

    /// Parses the JSON written by [`MatchingWeights::to_json`]; `origin` names the
    /// source in errors.
    pub fn from_json(json: &str, origin: &str) -> Result<Self> {
        let in_file = |problem: String| Error::WeightFile {
            origin: origin.to_string(),
            problem,
        };
        let (weights, boosters) =
            read_boosted_weights(feature_set(), json, "a CRF-Matching weight file")
                .map_err(in_file)?;
        let weights = Self { weights, boosters };
        weights.check_ref().map_err(|e| in_file(e.to_string()))?;
        Ok(weights)
    }

    /// The JSON form (named weights and the boosters' stumps).
    pub fn to_json(&self) -> Result<String> {
        Ok(write_boosted_weights(&self.named()?, &self.boosters))
    }

    /// Loads weights written by `pgm train matching`.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_json(&text, &path.display().to_string())
    }

    /// Writes the weights atomically: a temporary sibling `.NAME.PID.tmp`, flushed to
    /// disk and renamed into place (removed when anything fails), so `path` holds the
    /// old file or the new one, never a part, and no other file is touched.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let json = self.to_json()?;
        pgm_core::fsutil::write_atomically(path, json.as_bytes()).map_err(|e| match e {
            pgm_core::Error::Io { path, source } => Error::Io { path, source },
            other => Error::Core(other),
        })
    }

    /// All-zero weights and boosters without stumps (scores 0): the starting point of
    /// training, not a usable model.
    pub fn untrained() -> Self {
        Self {
            weights: vec![0.0; WEIGHTS],
            boosters: AssociationBoosters::untrained(),
        }
    }

    /// The shipped default weights.
    pub fn default_weights() -> Self {
        Self::from_json(DEFAULT_WEIGHTS_JSON, "the shipped default weights")
            .expect("the shipped default weights are valid (checked by a test)")
    }
}

impl Default for MatchingWeights {
    fn default() -> Self {
        Self::default_weights()
    }
}
