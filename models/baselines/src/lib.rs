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

/// Errors of the baselines: invalid parameters and inputs they cannot work on.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter is outside its allowed range (the workspace's one shape).
    #[error("parameter `{name}` = {value}: expected {expected}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// The offending value, as written.
        value: String,
        /// What would have been accepted.
        expected: &'static str,
    },
    /// An error of the shared scan code (registration, geometry).
    #[error(transparent)]
    Features(#[from] pgm_scan::Error),
}

impl From<pgm_core::InvalidParameter> for Error {
    fn from(e: pgm_core::InvalidParameter) -> Self {
        Error::InvalidParameter {
            name: e.name,
            value: e.value,
            expected: e.expected,
        }
    }
}

impl From<Error> for pgm_scan::Error {
    fn from(e: Error) -> Self {
        match e {
            Error::InvalidParameter {
                name,
                value,
                expected,
            } => pgm_scan::Error::InvalidParameter {
                name,
                value,
                expected,
            },
            Error::Features(e) => e,
        }
    }
}

/// Result type of `pgm-baselines`.
pub type Result<T> = std::result::Result<T, Error>;
