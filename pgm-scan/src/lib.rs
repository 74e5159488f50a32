//! # pgm-scan
//!
//! The scan layer: everything about 2D laser scans that is not a CRF. A model crate
//! builds its factor graphs on `pgm-core` and the papers' CRF parts (`pgm-features`)
//! on top of this crate; the data readers (`pgm-datasets`), the tracker
//! (`pgm-tracking`) and the evaluation loops (`pgm-eval`) use it too. It needs nothing
//! of the inference core but the parameter guard ([`ParamGuard`]).
//!
//! **What it holds.**
//! - Geometry: SE(2) poses ([`pose`]), laser scans and their geometry as methods of
//!   [`Scan`] (bearing lookup in any monotone angle order, visibility, free space,
//!   gap segmentation; [`scan`]).
//! - Scan pairs and their ground truth ([`pair`]): the unit every model, metric and
//!   reader works on (readers and writers live in `pgm-datasets`).
//! - Rigid motions: the closed-form weighted alignment of eq. (3) of the
//!   CRF-Clustering paper with O(1) updates and its point-to-line refinement
//!   ([`alignment`]), registration by ICP ([`registration`]), and the global search
//!   that starts ICP from a bad prior, correlative scan matching with branch and bound
//!   ([`correlative`]).
//! - Correspondences: the [`association`] sources (ground truth, nearest neighbour
//!   after ICP, segment-wise ICP) behind one trait that CRF-Matching also implements.
//! - The interfaces evaluation runs methods through ([`methods`]: [`ScanMatcher`],
//!   [`MotionClusterer`], the joint estimator).
//!
//! ```
//! use nalgebra::Point2;
//! use pgm_scan::{Pose2, RigidAlignment};
//!
//! // The motion that maps three current points onto their partners (eq. 3).
//! let truth = Pose2::new(0.5, -0.2, 0.1);
//! let mut stats = RigidAlignment::new();
//! for s in [Point2::new(1.0, 0.0), Point2::new(0.0, 2.0), Point2::new(-1.0, 1.0)] {
//!     stats.add(&s, &truth.transform_point(&s), 1.0);
//! }
//! assert!(stats.solve().unwrap().motion.translation_error(&truth) < 1e-12);
//! ```

pub mod alignment;
pub mod association;
pub mod correlative;
mod error;
pub mod methods;
pub mod pair;
pub mod pose;
pub mod registration;
pub mod scan;
#[cfg(test)]
#[path = "../tests/common/mod.rs"]
mod test_scenes;

pub use alignment::{Alignment, RigidAlignment, SurfacePair, TrimmedFitParams};
pub use association::{AssociationSource, PointAssociations};
pub use correlative::{CorrelativeMatcher, CorrelativeParams, Hypothesis};
pub use error::{Error, Result};
pub use methods::{MotionClusterer, ScanMatcher};
pub use pair::{Association, ClusterMotion, GroundTruth, ObjectCentre, ScanPair};
pub use pgm_core::param::{InvalidParameter, ParamGuard};
pub use pose::{wrap_angle, Pose2};
pub use scan::Scan;
