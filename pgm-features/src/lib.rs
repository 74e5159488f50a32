//! # pgm-features
//!
//! Everything the scan models share below the models themselves, the way `linfa-nn`
//! sits under linfa's algorithm crates: a model crate depends on `pgm-core` and on
//! this crate, never on the data readers or on another model.
//!
//! **Big picture.**
//! - Geometry: SE(2) poses ([`pose`]), laser scans and their geometry as methods of
//!   [`Scan`] (bearing lookup in any monotone angle order, visibility, free space,
//!   gap segmentation; [`scan`]).
//! - Scan pairs and their ground truth ([`pair`]): the unit every model, metric and
//!   reader works on (readers and writers live in `pgm-datasets`).
//! - Rigid motions: the closed-form weighted alignment of eq. (3) of the
//!   CRF-Clustering paper with O(1) updates ([`alignment`]), per-cluster motions as
//!   observed-continuous nodes ([`motion_nodes`]), registration by ICP
//!   ([`registration`]), and the global search that starts ICP from a bad prior,
//!   correlative scan matching with branch and bound ([`correlative`]).
//! - Correspondences: the [`association`] sources (ground truth, nearest neighbour
//!   after ICP, segment-wise ICP) behind one trait that CRF-Matching also implements.
//! - The papers' feature functions: CRF-Clustering's ([`clustering`]) and
//!   CRF-Matching's shape, translation and outlier features ([`matching`]), with the
//!   AdaBoost booster over decision stumps that turns them into CRF features
//!   ([`boosting`]), and the association chain that CRF-Matching and the joint model
//!   share, its candidates and its 18 features written as CRF tables
//!   ([`association_chain`]), and the joint model's clustering chain with its 12
//!   features ([`clustering_chain`]).
//! - The interfaces evaluation runs methods through ([`methods`]: [`ScanMatcher`],
//!   [`MotionClusterer`]).
//!
//! ```
//! use nalgebra::Point2;
//! use pgm_features::{Pose2, RigidAlignment};
//!
//! // The motion that maps three current points onto their partners (eq. 3).
//! let truth = Pose2::new(0.5, -0.2, 0.1);
//! let mut stats = RigidAlignment::new();
//! for s in [Point2::new(1.0, 0.0), Point2::new(0.0, 2.0), Point2::new(-1.0, 1.0)] {
//!     stats.add(&s, &truth.transform_point(&s), 1.0);
//! }
//! assert!(stats.solve().unwrap().motion.translation_error(&truth) < 1e-12);
//! ```
//!
//! **Current state.** Geometry, pairs, registration (ICP and its correlative
//! initialisation), association sources, and the features of CRF-Clustering and
//! CRF-Matching are complete.

pub mod alignment;
pub mod association;
pub mod association_chain;
pub mod boosting;
pub mod clustering;
pub mod clustering_chain;
pub mod correlative;
mod error;
pub mod matching;
pub mod methods;
pub mod motion_nodes;
pub mod pair;
pub mod pose;
pub mod registration;
pub mod scan;
pub mod tracking;

pub use alignment::{Alignment, RigidAlignment, SurfacePair, TrimmedFitParams};
pub use association::{AssociationSource, PointAssociations};
pub use correlative::{CorrelativeMatcher, CorrelativeParams, Hypothesis};
pub use error::{Error, Result};
pub use methods::{MotionClusterer, ScanMatcher};
pub use motion_nodes::{ClusterMotions, RigidMotionNodes};
pub use pair::{Association, ClusterMotion, GroundTruth, ScanPair};
pub use pgm_core::param::{InvalidParameter, ParamGuard};
pub use pose::{wrap_angle, Pose2};
pub use scan::Scan;
