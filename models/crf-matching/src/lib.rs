//! # pgm-crf-matching
//!
//! CRF-Matching (F. Ramos, D. Fox and H. Durrant-Whyte, "CRF-Matching: Conditional
//! Random Fields for Feature-Based Scan Matching", RSS 2007, as described in section
//! IV-C.1-2 of van de Ven, Ramos and Tipaldi, "An Integrated Probabilistic Model for
//! Scan-Matching, Moving Object Detection and Motion Estimation"): laser-point
//! association as a chain CRF over the current scan's returns whose states are the
//! reference scan's returns plus an outlier state, with local features from two
//! boosters over shape features, pairwise features that keep associations consistent
//! along the chain, and the motion as an observed-continuous node re-solved from the
//! MAP associations.
//!
//! **Big picture.** The association chain itself (candidates, the 18 features written
//! as CRF tables for inference and learning) lives in
//! [`pgm_features::matching_features`], shared with the joint model; [`model`] adds
//! the motion groups and makes it a model of the core's hybrid chain solver; [`matcher`] runs it on a pair (motion
//! hypotheses, rounds of candidates and exact chain sweeps on the core's hybrid chain
//! solver); [`weights`] names the 18 weights and holds the boosters; [`learning`]
//! trains both from labelled pairs. A [`Matcher`] is an
//! [`AssociationSource`](pgm_scan::AssociationSource) (it feeds CRF-Clustering) and
//! a [`ScanMatcher`](pgm_scan::ScanMatcher) (its ego-motion is evaluated like
//! ICP's).
//!
//! ```
//! use pgm_crf_matching::Matcher;
//! use pgm_datasets::sim::{simulate_pair, SimConfig};
//! use pgm_scan::ParamGuard;
//!
//! let pair = simulate_pair(&SimConfig::default().check().unwrap(), 1, 0);
//! let matching = Matcher::default().match_pair(&pair).unwrap();
//! assert_eq!(matching.associations.len(), pair.current.len());
//! println!("ego-motion {:?} after {} sweeps", matching.motion, matching.sweeps);
//! ```
//!
//! **Current state.** Model, inference, learning and the shipped weights are
//! complete; see the workspace README for measured accuracy and speed.

pub mod learning;
pub mod matcher;
pub mod model;
pub mod weights;

pub use matcher::{Matcher, Matching, MatchingParams};
pub use pgm_features::matching_features::StateSpace;
pub use pgm_features::{ModelError as Error, ModelResult as Result};
pub use pgm_scan::association::SegmentMotions;
pub use weights::MatchingWeights;
