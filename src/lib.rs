//! # pgm
//!
//! Conditional random fields and hybrid discrete/continuous factor graphs for 2D laser
//! data, as one facade over the workspace crates:
//!
//! - [`core`] (`pgm-core`): factor graphs, loopy max-product / sum-product belief
//!   propagation with pluggable schedules, exact references, hybrid
//!   observed-continuous nodes and the hybrid chain solver, pseudo-likelihood
//!   learning, checked parameters, UAI I/O;
//! - [`scan`] (`pgm-scan`): poses, scans and their geometry, scan pairs, rigid
//!   alignment, registration (ICP, correlative search), association sources, and the
//!   interfaces methods are evaluated through;
//! - [`features`] (`pgm-features`): the papers' CRF parts: feature functions,
//!   boosting, the association and clustering chains, rigid-motion nodes;
//! - [`tracking`] (`pgm-tracking`): moving objects followed over a sequence of scans;
//! - [`datasets`] (`pgm-datasets`): log readers, pair sources, the on-disk format,
//!   the urban simulator and the metrics;
//! - [`eval`] (`pgm-eval`): the evaluation loops every method runs through;
//! - [`baselines`] (`pgm-baselines`): motion K-Means, consistency-based detection;
//! - [`crf_clustering`] (`pgm-crf-clustering`): the CRF-Clustering model;
//! - [`crf_matching`] (`pgm-crf-matching`): the CRF-Matching model;
//! - [`joint`] (`pgm-joint`): the joint model of scan matching, moving-object
//!   detection and motion estimation;
//! - [`methods`]: every method by the name the command line uses;
//! - [`plot`]: SVG pictures of scan pairs and clusterings;
//! - [`foxglove`]: results as MCAP files under Foxglove's schemas.
//!
//! The whole pipeline on simulated pairs: simulate, cluster the current scans' points
//! by motion with the ground-truth associations, and score the result.
//!
//! ```
//! use pgm::eval::evaluate_clustering;
//! use pgm::datasets::sim::{simulate_pairs, SimConfig};
//! use pgm::scan::ParamGuard;
//! use pgm::methods::{association_source, clusterer, MethodOptions};
//!
//! let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1, 2);
//! let options = MethodOptions::default();
//! let crf = clusterer("crf", association_source("true", &options).unwrap(), &options).unwrap();
//! let report = evaluate_clustering(&pairs, crf.as_ref()).unwrap();
//! assert!(report.summary.v_measure_mean > 0.5, "{:?}", report.summary);
//! println!("{}: V-measure {:.3}", report.method, report.summary.v_measure_mean);
//! ```

pub use pgm_baselines as baselines;
pub use pgm_core as core;
pub use pgm_crf_clustering as crf_clustering;
pub use pgm_crf_matching as crf_matching;
pub use pgm_datasets as datasets;
pub use pgm_eval as eval;
pub use pgm_features as features;
pub use pgm_joint as joint;
pub use pgm_scan as scan;
pub use pgm_tracking as tracking;

pub mod foxglove;
pub mod methods;
pub mod plot;
