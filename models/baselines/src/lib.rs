//! # pgm-baselines
//!
//! The methods the papers compare against, implemented on the same scan types as the
//! CRF models so comparisons run on identical inputs.
//!
//! - [`icp`]: point-to-point ICP with a k-d tree and a shrinking outlier distance.
//! - [`motion_kmeans`]: the motion K-Means of the CRF-Clustering paper (eq. 10).
//! - [`consistency`]: the consistency-based detector (CBD) of moving objects.

pub mod consistency;
pub mod icp;
pub mod motion_kmeans;

pub use icp::{Icp, IcpParams, IcpResult};

/// Errors of the baselines: invalid parameters and inputs they cannot work on.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter is outside its allowed range.
    #[error("parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// What the value must satisfy.
        reason: &'static str,
    },
    /// A scan has no valid return.
    #[error("the {which} scan has no valid return")]
    EmptyScan {
        /// Which scan (`reference` or `current`).
        which: &'static str,
    },
}

/// Result type of `pgm-baselines`.
pub type Result<T> = std::result::Result<T, Error>;
