//! # pgm
//!
//! Conditional random fields and hybrid discrete/continuous factor graphs for 2D laser
//! data, as one facade over the workspace crates:
//!
//! - [`core`] (`pgm-core`): factor graphs, loopy max-product / sum-product belief
//!   propagation with pluggable schedules, exact references, hybrid
//!   observed-continuous nodes, pseudo-likelihood learning, UAI I/O;
//! - [`features`] (`pgm-features`): poses, scans, rigid alignment, feature functions;
//! - [`datasets`] (`pgm-datasets`): log readers, scan pairs, the urban simulator,
//!   metrics;
//! - [`baselines`] (`pgm-baselines`): ICP, motion K-Means, consistency-based detection;
//! - [`crf_clustering`] (`pgm-crf-clustering`): the CRF-Clustering model;
//! - [`plot`]: SVG pictures of scan pairs and clusterings.
//!
//! The whole pipeline on one simulated pair: simulate, cluster the current scan's
//! points by motion with the ground-truth associations, and score the result.
//!
//! ```
//! use pgm::crf_clustering::{AssociationProvider, AssociationSource, Clusterer};
//! use pgm::datasets::metrics::clustering_v_measure;
//! use pgm::datasets::sim::{simulate_pairs, SimConfig};
//!
//! let config = SimConfig::default().check().unwrap();
//! let pair = &simulate_pairs(&config, 1, 1)[0];
//! let associations = AssociationSource::GroundTruth.associate(pair).unwrap();
//! let clustering = Clusterer::default().cluster_pair(pair, &associations).unwrap();
//! let truth = pair.truth.as_ref().and_then(|t| t.labels.as_ref()).unwrap();
//! let score = clustering_v_measure(truth, &clustering.labels, 1.0).unwrap();
//! assert!(score.v_measure > 0.5, "{score:?}");
//! println!("{} clusters, V-measure {:.3}", clustering.clusters.len(), score.v_measure);
//! ```

pub use pgm_baselines as baselines;
pub use pgm_core as core;
pub use pgm_crf_clustering as crf_clustering;
pub use pgm_datasets as datasets;
pub use pgm_features as features;

pub mod plot;
