//! # pgm-crf-clustering
//!
//! CRF-Clustering (G. D. Tipaldi and F. Ramos, "Motion Clustering and Estimation with
//! Conditional Random Fields"): the points of the current scan of a pair are labelled
//! with clusters of common rigid motion by a chain CRF whose per-cluster motions are
//! hybrid continuous nodes solved in closed form; the cluster nearest to the odometry
//! is the background (the robot's own motion) and the others are moving objects with
//! their estimated motions.
//!
//! **Big picture.** The crate depends on `pgm-core` (the hybrid chain solver, loopy
//! BP, learning) and `pgm-features` (scans, pairs, association sources, the features
//! of eqs. 2 and 4-6); [`Clusterer`] runs six steps, one file each:
//! [`input`], [`segmentation`], [`inference`] (inference rounds and merging by eq. 8),
//! [`background`] and [`cleanup`], orchestrated by [`clusterer`]; [`model`] is the CRF
//! (its features written once for inference and learning), [`params`] the checked
//! parameters (the paper's, and the moving-object thresholds it does not have), and
//! [`weights`] and [`learning`] the named weights, the shipped defaults and
//! pseudo-likelihood training. With an association source a [`Clusterer`] is a
//! [`MotionClusterer`](pgm_scan::MotionClusterer)
//! ([`Associated`](pgm_scan::methods::Associated)), the interface evaluation uses.
//!
//! ```
//! use pgm_crf_clustering::Clusterer;
//! use pgm_scan::association::{AssociationSource, GroundTruthAssociations};
//! use pgm_datasets::sim::{simulate_pair, SimConfig};
//! use pgm_scan::ParamGuard;
//!
//! let pair = simulate_pair(&SimConfig::default().check().unwrap(), 1, 0);
//! let associations = GroundTruthAssociations.associate(&pair).unwrap();
//! let result = Clusterer::default().cluster_pair(&pair, &associations).unwrap();
//! assert_eq!(result.labels.len(), pair.current.len());
//! assert!(result.clusters[0].background);
//! println!("{} moving objects after {} sweeps", result.clusters.len() - 1, result.iterations);
//! ```
//!
//! **Current state.** Model, inference, merging and learning are complete; any
//! [`AssociationSource`](pgm_scan::AssociationSource) feeds it (ground truth,
//! nearest neighbour after ICP, segment-wise ICP, CRF-Matching).

pub mod background;
pub mod cleanup;
pub mod clusterer;
pub mod inference;
pub mod input;
pub mod learning;
pub mod model;
pub mod params;
pub mod segmentation;
pub mod weights;

pub use clusterer::{BackgroundChoice, Cluster, Clusterer, Clustering};
pub use input::ClusteringInput;
pub use params::{ClusteringParams, DetectionParams, UpdateSchedule};
pub use pgm_features::{ModelError as Error, ModelResult as Result};
pub use weights::ClusteringWeights;
