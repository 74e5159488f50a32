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
//! the workspace README. Written back, the shipped file holds the same weights and
//! boosters:
//!
//! ```
//! use pgm_crf_matching::weights::DEFAULT_WEIGHTS_JSON;
//! use pgm_crf_matching::MatchingWeights;
//!
//! let written = MatchingWeights::default().to_json().unwrap();
//! let json = |text: &str| serde_json::from_str::<serde_json::Value>(text).unwrap();
//! assert_eq!(json(&written), json(DEFAULT_WEIGHTS_JSON));
//! assert_eq!(MatchingWeights::from_json(&written, "again").unwrap(), MatchingWeights::default());
//! ```

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
}

pgm_features::boosted_model_weights!(MatchingWeights, "CRF-Matching", feature_set());

pgm_features::model_weights_api!(MatchingWeights, DEFAULT_WEIGHTS_JSON);
