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
//! The weights and boosters are kept in the workspace's one weight file
//! ([`pgm_features::weight_file`]: `model` `joint`, version 1, the 30 named weights,
//! `data_booster` and `outlier_booster`). The default weights and boosters (`weights/default.json`, compiled in with
//! `include_str!`) were learned from simulated pairs: the association part is
//! CRF-Matching's shipped one and the clustering weights were learned with it,
//! `pgm train joint --simulate 40 --seed 1000 --association-weights
//! models/crf-matching/weights/default.json --out models/joint/weights/default.json`
//! (see [`crate::learning::train_clustering`]).

use crate::Result;
use pgm_core::learning::FeatureSet;
use pgm_core::param::InvalidParameter;
use pgm_features::joint_clustering_features::{CLUSTERING_TEMPLATES, CLUSTERING_WEIGHTS};
use pgm_features::matching_features::{
    check_association_weights, AssociationBoosters, ASSOCIATION_TEMPLATES, ASSOCIATION_WEIGHTS,
};
use pgm_features::weight_file::{self, ModelWeights};
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
    let templates = ASSOCIATION_TEMPLATES
        .into_iter()
        .chain(CLUSTERING_TEMPLATES);
    weight_file::feature_set(MODEL_NAME, MODEL_VERSION, templates)
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
    /// [`crate::Error::WeightFile`] naming `origin` when the text is not such a file, a
    /// weight is missing, extra or not finite, or a booster does not fit.
    pub fn from_matching_json(json: &str, origin: &str) -> Result<Self> {
        <Self as ModelWeights>::from_json(json, origin)
    }

    /// [`AssociationPart::from_matching_json`] of a file.
    ///
    /// # Errors
    /// As `from_matching_json`, and [`crate::Error::WeightFile`] (`Io`) when the file
    /// cannot be read.
    pub fn load_matching(path: impl AsRef<Path>) -> Result<Self> {
        <Self as ModelWeights>::load(path)
    }

    /// Checks the sizes: 18 finite weights, boosters over the right feature counts
    /// with finite stumps.
    ///
    /// # Errors
    /// [`crate::Error::Features`] naming what is wrong.
    pub fn check_ref(&self) -> Result<()> {
        check_association_weights(&self.weights)?;
        self.boosters.check_ref()?;
        Ok(())
    }
}

// A CRF-Matching weight file, read for its association part.
pgm_features::boosted_model_weights!(
    AssociationPart,
    "CRF-Matching",
    weight_file::feature_set(MATCHING_MODEL.0, MATCHING_MODEL.1, ASSOCIATION_TEMPLATES)
);

impl JointWeights {
    /// Checks the sizes: 30 finite weights, boosters over the right feature counts
    /// with finite stumps.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] naming what is wrong.
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
}

pgm_features::boosted_model_weights!(JointWeights, "joint-model", feature_set());

pgm_features::model_weights_api!(JointWeights, DEFAULT_WEIGHTS_JSON);
