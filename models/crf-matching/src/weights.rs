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
//! The weights and boosters are kept in the workspace's one weight file
//! ([`pgm_features::weight_file`]: `model` `crf-matching`, version 1, the 18 named
//! weights, `data_booster` and `outlier_booster`). The default weights and boosters
//! (`weights/default.json`, compiled in with `include_str!`) were learned from
//! simulated pairs; the command that produced them is in the crate's README section of
//! the workspace README.

use crate::Result;
use pgm_core::learning::FeatureSet;
use pgm_features::matching_features::{
    check_association_weights, AssociationBoosters, ASSOCIATION_TEMPLATES, ASSOCIATION_WEIGHTS,
};
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
    pgm_features::weight_file::feature_set(MODEL_NAME, MODEL_VERSION, ASSOCIATION_TEMPLATES)
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
    ///
    /// # Errors
    /// [`crate::Error::Features`] naming what is wrong.
    pub fn check_ref(&self) -> Result<()> {
        check_association_weights(&self.weights)?;
        self.boosters.check_ref()?;
        Ok(())
    }

    /// All-zero weights and boosters without stumps (scores 0): the starting point of
    /// training, not a usable model.
    pub fn untrained() -> Self {
        Self {
            weights: vec![0.0; WEIGHTS],
            boosters: AssociationBoosters::untrained(),
        }
    }
}

pgm_features::boosted_model_weights!(MatchingWeights, "CRF-Matching", feature_set());

pgm_features::model_weights_api!(MatchingWeights, DEFAULT_WEIGHTS_JSON);

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped file reads; written back, it holds the same weights and the same
    /// boosters, byte for byte.
    #[test]
    fn the_shipped_file_is_written_back_with_the_same_content() {
        let w = MatchingWeights::default();
        let shipped: serde_json::Value = serde_json::from_str(DEFAULT_WEIGHTS_JSON).unwrap();
        let written: serde_json::Value = serde_json::from_str(&w.to_json().unwrap()).unwrap();
        assert_eq!(written, shipped);
        assert_eq!(
            MatchingWeights::from_json(&w.to_json().unwrap(), "again").unwrap(),
            w
        );
    }

    /// A model's error keeps its type through the method traits.
    #[test]
    fn weight_file_errors_travel_whole() {
        let e = MatchingWeights::from_json("{}", "w.json").unwrap_err();
        let message = e.to_string();
        assert_eq!(message, "w.json: field `model`: missing");
        let through = pgm_scan::Error::from(e);
        assert_eq!(through.to_string(), message);
        assert!(matches!(
            through.downcast_method::<crate::Error>(),
            Some(crate::Error::WeightFile(
                pgm_features::WeightFileError::Field { .. }
            ))
        ));
    }
}
