//! # pgm-baselines
//!
//! The motion-clustering methods the CRF-Clustering paper compares against,
//! implemented on the same scan types as the CRF models (`pgm-features`) so that
//! comparisons run on identical inputs, and behind the same interface
//! ([`MotionClusterer`](pgm_scan::MotionClusterer)). The scan-matching baseline,
//! ICP, is shared by every model and lives in
//! [`pgm_scan::registration`].
//!
//! - [`motion_kmeans`]: the motion K-Means of the CRF-Clustering paper (eq. 10).
//! - [`consistency`]: the consistency-based detector (CBD) of moving objects.
//!
//! ```
//! use pgm_baselines::consistency::ConsistencyParams;
//! use pgm_scan::{MotionClusterer, ParamGuard};
//!
//! let cbd = ConsistencyParams::default().check().unwrap();
//! assert_eq!(cbd.name(), "cbd");
//! ```

pub mod consistency;
pub mod motion_kmeans;

/// Errors of the baselines (invalid parameters, inputs they cannot work on): the
/// models' one error shape.
pub use pgm_features::{ModelError as Error, ModelResult as Result};
