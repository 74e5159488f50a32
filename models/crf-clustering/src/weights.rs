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
//! The weights are kept in the workspace's one weight file
//! ([`pgm_features::weight_file`]: `model` `crf-clustering`, version 1, the 8 named
//! weights and nothing else). The default weights (`weights/default.json`, compiled in
//! with `include_str!`) were learned by pseudo-likelihood on simulated pairs; the
//! command that produced them is in the crate README.

use crate::Result;
use pgm_core::learning::{FeatureSet, Weights};
use pgm_core::param::InvalidParameter;
use pgm_features::weight_file::ModelWeights;
use std::sync::Arc;

/// Name of the model in weight files.
pub const MODEL_NAME: &str = "crf-clustering";
/// Version of the feature set (bump when features change meaning).
pub const MODEL_VERSION: u32 = 1;
/// The default weights as JSON (`weights/default.json`).
pub const DEFAULT_WEIGHTS_JSON: &str = include_str!("../weights/default.json");

/// Index of each weight in the weight vector of [`feature_set`] (the order of
/// [`ClusteringWeights::to_vec`]).
pub(crate) mod index {
    pub const DISTANCE_SQUARED: usize = 0;
    pub const DISTANCE_NORMALISED: usize = 1;
    pub const NEIGHBOUR_SAME: usize = 2;
    pub const NEIGHBOUR_DIFFERENT: usize = 3;
    pub const WEIGHTED_NEIGHBOUR_SAME: usize = 4;
    pub const WEIGHTED_NEIGHBOUR_DIFFERENT: usize = 5;
    pub const STIFFNESS_SAME: usize = 6;
    pub const STIFFNESS_DIFFERENT: usize = 7;
}

/// The feature set of CRF-Clustering (see the module table).
pub fn feature_set() -> Arc<FeatureSet> {
    let templates = [
        ("distance", &["squared", "normalised"][..]),
        ("neighbour", &["same", "different"][..]),
        ("weighted_neighbour", &["same", "different"][..]),
        ("stiffness", &["same", "different"][..]),
    ];
    pgm_features::weight_file::feature_set(MODEL_NAME, MODEL_VERSION, templates)
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
        Self::from_values(w.values())
    }

    /// From the 8 values in [`feature_set`] order.
    ///
    /// # Panics
    /// When there are fewer than 8.
    fn from_values(v: &[f64]) -> Self {
        Self {
            distance: [v[0], v[1]],
            neighbour: [v[2], v[3]],
            weighted_neighbour: [v[4], v[5]],
            stiffness: [v[6], v[7]],
        }
    }

    /// Checks that every weight is finite and that the distance weights penalise
    /// distance at every range: the coefficient `w_sq + w_norm / σ_i²` of eq. (2) is
    /// negative for every association variance `σ_i² ≥ σ0²`
    /// ([`pgm_features::clustering_features::ASSOCIATION_NOISE`]), that is `w_sq ≤ 0` and
    /// `w_sq + w_norm / σ0² < 0` (the coefficient is linear in `1/σ_i²`). Otherwise a
    /// far partner would attract a point to a cluster.
    pub fn check_ref(&self) -> Result<()> {
        if !self.to_vec().iter().all(|w| w.is_finite()) {
            return Err(InvalidParameter::new("weights", self, "finite weights").into());
        }
        let [d0, d1] = self.distance;
        let smallest = pgm_features::clustering_features::ASSOCIATION_NOISE.powi(2);
        if d0 > 0.0 || d0 + d1 / smallest >= 0.0 {
            return Err(InvalidParameter::new(
                "weights.distance",
                self.distance,
                "weights that penalise distance at every range (w_sq <= 0 and w_sq + w_norm / σ0² < 0)",
            )
            .into());
        }
        Ok(())
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
    ///
    /// # Errors
    /// When a weight is not finite.
    pub fn to_weights(&self) -> Result<Weights> {
        self.named()
    }
}

impl ModelWeights for ClusteringWeights {
    const TITLE: &'static str = "CRF-Clustering";
    type Parts = ();

    fn feature_set() -> Arc<FeatureSet> {
        feature_set()
    }

    fn from_file(weights: &[f64], _: ()) -> Self {
        Self::from_values(weights)
    }

    fn to_file(&self) -> (Vec<f64>, ()) {
        (self.to_vec(), ())
    }

    /// [`ClusteringWeights::check_ref`]: weights the model would reject are refused
    /// where the file is named.
    fn check_values(&self) -> Result<()> {
        self.check_ref()
    }
}

pgm_features::model_weights_api!(ClusteringWeights, DEFAULT_WEIGHTS_JSON);

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped file reads, and writing it back gives the same bytes.
    #[test]
    fn the_shipped_file_is_written_back_unchanged() {
        let w = ClusteringWeights::default();
        assert_eq!(w.to_json().unwrap(), DEFAULT_WEIGHTS_JSON);
        assert_eq!(w.to_weights().unwrap().to_json(), DEFAULT_WEIGHTS_JSON);
    }

    /// Errors name the source and the field.
    #[test]
    fn errors_name_the_source_and_the_field() {
        let e = |json: &str| {
            ClusteringWeights::from_json(json, "w.json")
                .unwrap_err()
                .to_string()
        };
        let without = |name: &str| {
            let mut v: serde_json::Value = serde_json::from_str(DEFAULT_WEIGHTS_JSON).unwrap();
            v["weights"].as_object_mut().unwrap().remove(name);
            v.to_string()
        };
        assert_eq!(
            e(&without("stiffness.same")),
            "w.json: field `weights.stiffness.same`: missing"
        );
        let extra = DEFAULT_WEIGHTS_JSON.replacen(
            "\"version\": 1,",
            "\"version\": 1, \"data_booster\": 1,",
            1,
        );
        assert_eq!(
            e(&extra),
            "w.json: field `data_booster`: not a field of a CRF-Clustering weight file"
        );
        let other = DEFAULT_WEIGHTS_JSON.replacen("crf-clustering", "crf-matching", 1);
        assert!(
            e(&other).starts_with(
                "w.json: not a CRF-Clustering weight file: field `model` is \"crf-matching\""
            ),
            "{}",
            e(&other)
        );
        assert!(e("[1, 2").starts_with("w.json: not a CRF-Clustering weight file: "));
        let positive = DEFAULT_WEIGHTS_JSON.replacen("-0.23814729538862026", "1.0", 1);
        assert!(
            e(&positive).starts_with("w.json: parameter `weights.distance`"),
            "{}",
            e(&positive)
        );
        let e = ClusteringWeights::load("/nonexistent/w.json").unwrap_err();
        assert!(matches!(
            e,
            crate::Error::WeightFile(pgm_features::WeightFileError::Io { .. })
        ));
    }
}
