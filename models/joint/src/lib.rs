//! # pgm-joint
//!
//! The joint model of J. van de Ven, F. Ramos and G. D. Tipaldi, "An Integrated
//! Probabilistic Model for Scan-Matching, Moving Object Detection and Motion
//! Estimation": scan matching (an association chain, CRF-Matching's), moving-object
//! detection (a clustering chain with an outlier cluster) and motion estimation (one
//! rigid motion per cluster, observed-continuous, re-solved in closed form from the
//! current associations and clusters) inferred together on one pair of 2D laser
//! scans.
//!
//! **Big picture.** The two chains' features come from `pgm-features`
//! ([`pgm_features::matching_features`], [`pgm_features::joint_clustering_features`]) and the
//! inference from the core's hybrid chain solver ([`pgm_core::hybrid::chain`]): this
//! crate composes them. [`model`] is the two-chain CRF and its motions, [`estimator`]
//! runs it on a pair (motion hypotheses, rounds of candidates and sweeps, vacuous
//! clusters, the ego-motion), [`weights`] names the 30 weights and holds the
//! boosters, [`learning`] trains both from labelled pairs.
//!
//! ```
//! use pgm_joint::Joint;
//! use pgm_datasets::sim::{simulate_pair, SimConfig};
//! use pgm_scan::ParamGuard;
//!
//! let pair = simulate_pair(&SimConfig::default().check().unwrap(), 1, 0);
//! let result = Joint::default().estimate(&pair).unwrap();
//! assert_eq!(result.clusters.len(), pair.current.len());
//! println!("{} clusters, ego-motion {:?}", result.motions.len(), result.ego_motion);
//! ```

pub mod estimator;
pub mod learning;
mod methods;
pub mod model;
pub mod weights;

pub use estimator::{ClusterLabel, Clusters, Joint, JointParams, JointResult};
pub use pgm_features::{ModelError as Error, ModelResult as Result};
pub use pgm_scan::association::SegmentMotions;
pub use weights::{AssociationPart, JointWeights};
