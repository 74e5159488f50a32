//! The joint model's 30 named weights and its two boosters.
//!
//! Weights 0-17 are the association chain's
//! ([`pgm_features::matching_features`]: data and outlier boosting, registered
//! translation, sequence, pairwise outlier, pairwise distance, pairwise translation),
//! weights 18-29 the clustering chain's ([`pgm_features::joint_clustering_features`]: cluster
//! distance, cluster outlier, cluster inlier, cluster sequence, neighbour weight,
//! neighbour stiffness, neighbour distance, cluster pairwise outlier); the module
//! docs of those two name every weight. The paper counts 18 + 12 = 30 as well.
//!
//! The default weights and boosters (`weights/default.json`, compiled in with
//! `include_str!`) were learned from simulated pairs: the association part is
//! CRF-Matching's shipped one and the clustering weights were learned with it,
//! `pgm train joint --simulate 40 --seed 1000 --association-weights
//! models/crf-matching/weights/default.json --out models/joint/weights/default.json`
//! (see [`crate::learning::train_clustering`]).

use crate::{Error, Result};
use pgm_core::learning::{FeatureSet, Weights};
use pgm_core::param::InvalidParameter;
use pgm_features::joint_clustering_features::{CLUSTERING_TEMPLATES, CLUSTERING_WEIGHTS};
use pgm_features::matching_features::{
    read_boosted_weights, write_boosted_weights, AssociationBoosters, ASSOCIATION_TEMPLATES,
    ASSOCIATION_WEIGHTS,
};

use std::path::Path;
use std::sync::Arc;

/// Name of the model in weight files.
pub const MODEL_NAME: &str = "joint";
/// Version of the feature set (bump when features change meaning).
pub const MODEL_VERSION: u32 = 1;
/// The default weights and boosters as JSON (`weights/default.json`).
pub const DEFAULT_WEIGHTS_JSON: &str = include_str!("../weights/default.json");

/// Index of the first association weight.
pub const ASSOCIATION_BASE: usize = 0;
/// Index of the first clustering weight.
pub const CLUSTERING_BASE: usize = ASSOCIATION_WEIGHTS;
/// Number of weights.
pub const WEIGHTS: usize = ASSOCIATION_WEIGHTS + CLUSTERING_WEIGHTS;

/// The 30 named weights of the joint model.
pub fn feature_set() -> Arc<FeatureSet> {
    let mut f = FeatureSet::new(MODEL_NAME, MODEL_VERSION);
    for (name, features) in ASSOCIATION_TEMPLATES
        .into_iter()
        .chain(CLUSTERING_TEMPLATES)
    {
        f.add_template(name, features)
            .expect("fixed template names are valid and distinct");
    }
    Arc::new(f)
}

/// The learned parameters of the joint model: the 30 log-linear weights and the two
/// association boosters.
#[derive(Clone, Debug, PartialEq)]
pub struct JointWeights {
    /// The 30 weights in [`feature_set`] order.
    pub weights: Vec<f64>,
    /// The data and outlier boosters of the association chain.
    pub boosters: AssociationBoosters,
}

/// The association chain's learned parameters on their own: its 18 weights (in
/// [`ASSOCIATION_TEMPLATES`] order) and the two boosters. CRF-Matching learns exactly
/// these (the same features, boosters and pseudo-likelihood), so the joint model can
/// take them from a CRF-Matching weight file and learn only its clustering weights:
/// piecewise training (Sutton and McCallum 2005), which here loses nothing, because the
/// pseudo-likelihood of the two chains separates (see [`crate::learning`]).
#[derive(Clone, Debug, PartialEq)]
pub struct AssociationPart {
    /// The 18 association weights.
    pub weights: Vec<f64>,
    /// The data and outlier boosters.
    pub boosters: AssociationBoosters,
}

/// Model name and feature-set version of the CRF-Matching weight files
/// [`AssociationPart::from_matching_json`] reads.
pub const MATCHING_MODEL: (&str, u32) = ("crf-matching", 1);

impl AssociationPart {
    /// The association part of a CRF-Matching weight file (`pgm train matching`):
    /// `{"model": "crf-matching", "version": 1, "weights": {18 named weights},
    /// "data_booster", "outlier_booster"}`; `origin` names the source in errors.
    ///
    /// # Errors
    /// [`Error::WeightFile`] naming `origin` when the text is not such a file, a weight
    /// is missing, extra or not finite, or a booster does not fit.
    pub fn from_matching_json(json: &str, origin: &str) -> Result<Self> {
        let in_file = |problem: String| Error::WeightFile {
            origin: origin.to_string(),
            problem,
        };
        let mut features = FeatureSet::new(MATCHING_MODEL.0, MATCHING_MODEL.1);
        for (name, names) in ASSOCIATION_TEMPLATES {
            features
                .add_template(name, names)
                .expect("fixed template names are valid and distinct");
        }
        let (weights, boosters) =
            read_boosted_weights(Arc::new(features), json, "a CRF-Matching weight file")
                .map_err(in_file)?;
        let part = Self { weights, boosters };
        pgm_features::matching_features::check_association_weights(&part.weights)
            .map_err(|e| in_file(e.to_string()))?;
        part.boosters
            .check_ref()
            .map_err(|e| in_file(e.to_string()))?;
        Ok(part)
    }

    /// [`AssociationPart::from_matching_json`] of a file.
    ///
    /// # Errors
    /// As `from_matching_json`, and [`Error::Io`] when the file cannot be read.
    pub fn load_matching(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_matching_json(&text, &path.display().to_string())
    }
}

impl JointWeights {
    /// Checks the sizes: 30 finite weights, boosters over the right feature counts
    /// with finite stumps.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming what is wrong.
    pub fn check_ref(&self) -> Result<()> {
        if self.weights.len() != WEIGHTS || !self.weights.iter().all(|w| w.is_finite()) {
            return Err(InvalidParameter::new(
                "weights",
                format!("{} weights", self.weights.len()),
                "30 finite weights",
            )
            .into());
        }
        self.boosters.check_ref()?;
        Ok(())
    }

    /// The weights as named [`Weights`].
    ///
    /// # Errors
    /// When the count does not match the feature set.
    pub fn named(&self) -> Result<Weights> {
        Ok(Weights::new(feature_set(), self.weights.clone())?)
    }

    /// Parses the JSON written by [`JointWeights::to_json`]; `origin` names the source
    /// in errors.
    ///
    /// # Errors
    /// When the text is not a joint-model weight file or its values are invalid.
    pub fn from_json(json: &str, origin: &str) -> Result<Self> {
        let in_file = |problem: String| Error::WeightFile {
            origin: origin.to_string(),
            problem,
        };
        let (weights, boosters) =
            read_boosted_weights(feature_set(), json, "a joint-model weight file")
                .map_err(in_file)?;
        let weights = Self { weights, boosters };
        weights.check_ref().map_err(|e| in_file(e.to_string()))?;
        Ok(weights)
    }

    /// The JSON form (named weights and the boosters' stumps).
    ///
    /// # Errors
    /// When the weights do not fit the feature set.
    pub fn to_json(&self) -> Result<String> {
        Ok(write_boosted_weights(&self.named()?, &self.boosters))
    }

    /// Loads weights written by `pgm train joint`.
    ///
    /// # Errors
    /// When the file cannot be read or is not a valid weight file (both named).
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_json(&text, &path.display().to_string())
    }

    /// Writes the weights atomically ([`pgm_core::fsutil::write_atomically`]).
    ///
    /// # Errors
    /// When the file cannot be written (named).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let json = self.to_json()?;
        pgm_core::fsutil::write_atomically(path, json.as_bytes()).map_err(|e| match e {
            pgm_core::Error::Io { path, source } => Error::Io { path, source },
            other => Error::Core(other),
        })
    }

    /// All-zero weights and boosters without stumps: the starting point of training,
    /// not a usable model.
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

impl Default for JointWeights {
    fn default() -> Self {
        Self::default_weights()
    }
}
