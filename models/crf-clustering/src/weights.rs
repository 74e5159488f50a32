//! The model's named weights: the log-linear templates of CRF-Clustering and the
//! default weights shipped with the crate.
//!
//! | template | weights | feature |
//! |---|---|---|
//! | `distance` | `squared`, `normalised` | eq. (2), local; and eq. (2) over the point's association variance |
//! | `neighbour` | `same`, `different` | eq. (4) |
//! | `weighted_neighbour` | `same`, `different` | eq. (5) |
//! | `stiffness` | `same`, `different` | eq. (6), split by whether the clusters are equal |
//!
//! The default weights (`weights/default.json`, compiled in with `include_str!`) were
//! learned by pseudo-likelihood on simulated pairs; the command that produced them is
//! in the crate README.

use crate::Result;
use pgm_core::learning::{FeatureSet, Weights};
use std::path::Path;
use std::sync::Arc;

/// Name of the model in weight files.
pub const MODEL_NAME: &str = "crf-clustering";
/// Version of the feature set (bump when features change meaning).
pub const MODEL_VERSION: u32 = 1;
/// The default weights as JSON (`weights/default.json`).
pub const DEFAULT_WEIGHTS_JSON: &str = include_str!("../weights/default.json");

/// Template ids of the feature set, in the order they are added.
pub(crate) mod templates {
    use pgm_core::learning::TemplateId;
    pub const DISTANCE: TemplateId = TemplateId(0);
    pub const NEIGHBOUR: TemplateId = TemplateId(1);
    pub const WEIGHTED_NEIGHBOUR: TemplateId = TemplateId(2);
    pub const STIFFNESS: TemplateId = TemplateId(3);
}

/// The feature set of CRF-Clustering (see the module table).
pub fn feature_set() -> Arc<FeatureSet> {
    let mut f = FeatureSet::new(MODEL_NAME, MODEL_VERSION);
    // The names are fixed and distinct, so these cannot fail.
    for (name, features) in [
        ("distance", &["squared", "normalised"][..]),
        ("neighbour", &["same", "different"][..]),
        ("weighted_neighbour", &["same", "different"][..]),
        ("stiffness", &["same", "different"][..]),
    ] {
        f.add_template(name, features)
            .expect("fixed template names are valid");
    }
    Arc::new(f)
}

/// The weights as plain numbers, in the order the model uses them.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ClusteringWeights {
    /// Weights of the squared distance of eq. (2) and of the same distance over the
    /// point's association variance (negative: far is unlikely).
    pub distance: [f64; 2],
    /// Neighbour feature eq. (4): `[same, different]`.
    pub neighbour: [f64; 2],
    /// Weighted-neighbour feature eq. (5): `[same, different]`.
    pub weighted_neighbour: [f64; 2],
    /// Stiffness feature eq. (6): `[same cluster, different clusters]`.
    pub stiffness: [f64; 2],
}

impl ClusteringWeights {
    /// From learned or loaded [`Weights`] of [`feature_set`].
    pub fn from_weights(w: &Weights) -> Self {
        let v = w.values();
        Self {
            distance: [v[0], v[1]],
            neighbour: [v[2], v[3]],
            weighted_neighbour: [v[4], v[5]],
            stiffness: [v[6], v[7]],
        }
    }

    /// As a weight vector of [`feature_set`].
    pub fn to_vec(&self) -> Vec<f64> {
        vec![
            self.distance[0],
            self.distance[1],
            self.neighbour[0],
            self.neighbour[1],
            self.weighted_neighbour[0],
            self.weighted_neighbour[1],
            self.stiffness[0],
            self.stiffness[1],
        ]
    }

    /// As named [`Weights`].
    pub fn to_weights(&self) -> Result<Weights> {
        Ok(Weights::new(feature_set(), self.to_vec())?)
    }

    /// The shipped default weights.
    pub fn default_weights() -> Self {
        let w = Weights::from_json(feature_set(), DEFAULT_WEIGHTS_JSON)
            .expect("the shipped default weights match the feature set (checked by a test)");
        Self::from_weights(&w)
    }

    /// Loads weights from a JSON file written by `pgm train clustering`.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let w = Weights::load(feature_set(), path)?;
        Ok(Self::from_weights(&w))
    }
}

impl Default for ClusteringWeights {
    fn default() -> Self {
        Self::default_weights()
    }
}
