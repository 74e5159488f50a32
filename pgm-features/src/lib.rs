//! # pgm-features
//!
//! 2D laser-scan geometry and the feature functions of the papers this project
//! implements: SE(2) poses ([`pose`]), scans and their points ([`scan`]), and the
//! closed-form weighted rigid alignment of eq. (3) of the CRF-Clustering paper with
//! O(1) updates ([`alignment`]), and per-cluster rigid motions as hybrid continuous
//! nodes of the inference core ([`motion_nodes`]).
//!
//! Clustering features and matching features are added
//! by the issues that need them; see the workspace README for the current state.

pub mod alignment;
pub mod clustering;
pub mod motion_nodes;
pub mod pose;
pub mod scan;

pub use alignment::{Alignment, RigidAlignment};
pub use motion_nodes::RigidMotionNodes;
pub use pose::{wrap_angle, Pose2};
pub use scan::Scan;
