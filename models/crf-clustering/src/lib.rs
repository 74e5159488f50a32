//! # pgm-crf-clustering
//!
//! CRF-Clustering (G. D. Tipaldi and F. Ramos, "Motion Clustering and Estimation with
//! Conditional Random Fields"): the points of the current scan of a pair are labelled
//! with clusters of common rigid motion by a chain CRF whose per-cluster motions are
//! hybrid continuous nodes solved in closed form; the cluster nearest to the odometry
//! is the background (the robot's own motion) and the others are moving objects with
//! their estimated motions.
//!
//! **Big picture.**
//! - [`associations`]: where each current point's partner in the reference scan comes
//!   from (ground truth, nearest neighbour after ICP, segment-wise ICP, or your own
//!   [`AssociationProvider`]).
//! - [`segmentation`]: the initial clusters (gap segmentation capped by motion-residual
//!   merging).
//! - [`model`]: the factor graph (features of `pgm_features::clustering`, eqs. 2, 4-6)
//!   and the rigid-motion [`ContinuousModel`](pgm_core::hybrid::ContinuousModel).
//! - [`clusterer`]: inference rounds (hybrid message passing, IV-D), merging by the
//!   effective number of clusters (eq. 8), background selection.
//! - [`weights`] and [`learning`]: named weights, the shipped defaults, and
//!   pseudo-likelihood training from labelled pairs.
//!
//! ```
//! use pgm_crf_clustering::{AssociationProvider, AssociationSource, Clusterer};
//! use pgm_datasets::sim::{simulate_pair, SimConfig};
//!
//! let pair = simulate_pair(&SimConfig::default().check().unwrap(), 1, 0);
//! let associations = AssociationSource::GroundTruth.associate(&pair).unwrap();
//! let result = Clusterer::default().cluster_pair(&pair, &associations).unwrap();
//! assert_eq!(result.labels.len(), pair.current.len());
//! assert!(result.clusters[0].background);
//! println!("{} moving objects after {} sweeps", result.clusters.len() - 1, result.iterations);
//! ```
//!
//! **Current state.** Model, inference, merging, learning and ICP associations are
//! complete; CRF-Matching associations plug in through [`AssociationProvider`].

pub mod associations;
mod chain;
pub mod clusterer;
mod error;
pub mod evaluation;
pub mod learning;
pub mod model;
pub mod segmentation;
pub mod weights;

pub use associations::{
    AssociationProvider, AssociationSource, NearestParams, PointAssociations, SegmentParams,
};
pub use clusterer::{
    BackgroundChoice, Cluster, Clusterer, Clustering, ClusteringInput, ClusteringParams,
    UpdateSchedule,
};
pub use error::{Error, Result};
pub use weights::ClusteringWeights;
