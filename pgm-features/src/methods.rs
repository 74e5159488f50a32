//! The interfaces through which evaluation runs a method on scan pairs, in the spirit
//! of linfa's `Predict`: a [`ScanMatcher`] estimates the ego-motion of a pair, a
//! [`MotionClusterer`] labels the current scan's returns with clusters of common
//! motion. Evaluation (`pgm_datasets::evaluation`), the command-line tool, the
//! examples and the tests are generic over them, so adding a model means adding an
//! implementation, not a branch in the tool.
//!
//! ```
//! use pgm_features::methods::{Odometry, ScanMatcher};
//! use pgm_features::pair::ScanPair;
//! use pgm_features::{Pose2, Scan};
//!
//! let scan = Scan::from_ranges(vec![0.0], vec![1.0], 10.0);
//! let pair = ScanPair { name: "p".into(), reference: scan.clone(), current: scan,
//!                       odometry: Some(Pose2::new(0.5, 0.0, 0.0)), truth: None };
//! let estimate = Odometry.estimate(&pair).unwrap();
//! assert_eq!(estimate.motion, Pose2::new(0.5, 0.0, 0.0));
//! ```

use crate::association::{AssociationSource, PointAssociations};
use crate::pair::{ClusterMotion, ScanPair};
use crate::registration::{IcpMatcher, IcpStatus};
use crate::{Pose2, Result};
use serde::Serialize;
use std::sync::Arc;

/// A method's estimate of the ego-motion of one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EgoMotionEstimate {
    /// The motion of the current sensor frame in the reference sensor frame (maps
    /// current points onto reference points).
    pub motion: Pose2,
    /// Whether the method converged. A method that fell back to the prior (too little
    /// data) reports `false`, and evaluation counts the pair as not converged.
    pub converged: bool,
    /// Iterations the method ran (0 for closed-form methods).
    pub iterations: usize,
    /// Why the method did not converge, when it knows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// Estimates the ego-motion of scan pairs.
pub trait ScanMatcher: Send + Sync {
    /// The method's name, as typed on the command line.
    fn name(&self) -> &str;

    /// The ego-motion of `pair`. Errors name the pair.
    fn estimate(&self, pair: &ScanPair) -> Result<EgoMotionEstimate>;
}

/// The pair's odometry prior as the estimate (the identity without one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Odometry;

impl ScanMatcher for Odometry {
    fn name(&self) -> &str {
        "odometry"
    }

    fn estimate(&self, pair: &ScanPair) -> Result<EgoMotionEstimate> {
        Ok(EgoMotionEstimate {
            motion: pair.odometry.unwrap_or_default(),
            converged: true,
            iterations: 0,
            note: None,
        })
    }
}

impl ScanMatcher for IcpMatcher {
    fn name(&self) -> &str {
        "icp"
    }

    fn estimate(&self, pair: &ScanPair) -> Result<EgoMotionEstimate> {
        let r = self.align_pair(pair)?;
        Ok(EgoMotionEstimate {
            motion: r.motion,
            converged: r.converged,
            iterations: r.iterations,
            note: match r.status {
                IcpStatus::Converged => None,
                IcpStatus::IterationLimit => Some("iteration limit".into()),
                IcpStatus::TooFewCorrespondences => Some(format!(
                    "{} correspondences, fewer than the {} a rigid fit needs: kept the prior",
                    r.inliers,
                    self.params().min_correspondences
                )),
            },
        })
    }
}

/// A method's clustering of the current scan of one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MotionClustering {
    /// Per beam of the current scan: 0 for the static background, 1, 2, … for moving
    /// objects, `None` for beams without a return (and points the method leaves
    /// unlabelled, such as outliers).
    pub labels: Vec<Option<u32>>,
    /// The estimated motion of each cluster the method estimates motions for (maps
    /// current points onto the reference scan), background included when known.
    pub motions: Vec<ClusterMotion>,
    /// The method's ego-motion estimate, if it has one.
    pub ego_motion: Option<Pose2>,
    /// Iterations (message-passing sweeps, assignment rounds; 0 for one-shot methods).
    pub iterations: usize,
    /// Whether the method converged.
    pub converged: bool,
}

/// Labels the returns of the current scan of a pair by common motion (moving-object
/// detection and motion estimation).
pub trait MotionClusterer: Send + Sync {
    /// The method's name, as typed on the command line (with its association source
    /// where it takes one, e.g. `crf (icp)`).
    fn name(&self) -> String;

    /// The clustering of `pair`'s current scan. Errors name the pair.
    fn cluster(&self, pair: &ScanPair) -> Result<MotionClustering>;
}

/// Every return in the background cluster: the trivial baseline that scores a
/// V-measure of 1 on pairs without a moving object.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OneCluster;

impl MotionClusterer for OneCluster {
    fn name(&self) -> String {
        "one-cluster".into()
    }

    fn cluster(&self, pair: &ScanPair) -> Result<MotionClustering> {
        Ok(MotionClustering {
            labels: (0..pair.current.len())
                .map(|k| pair.current.valid[k].then_some(0))
                .collect(),
            motions: Vec::new(),
            ego_motion: None,
            iterations: 0,
            converged: true,
        })
    }
}

/// A clusterer that works from given point associations (CRF-Clustering, motion
/// K-Means); [`Associated`] pairs it with an [`AssociationSource`] to make a
/// [`MotionClusterer`].
pub trait ClusterWithAssociations: Send + Sync {
    /// The method's name without its association source, as typed on the command line.
    fn name(&self) -> &str;

    /// The clustering of `pair`'s current scan given `associations` (one per current
    /// beam). Errors name the pair.
    fn cluster_with(
        &self,
        pair: &ScanPair,
        associations: &PointAssociations,
    ) -> Result<MotionClustering>;
}

/// A [`ClusterWithAssociations`] method fed by an association source: a
/// [`MotionClusterer`] named `method (source)`, for example `crf (icp)`.
pub struct Associated<C> {
    /// The clustering method.
    pub method: C,
    /// Where its associations come from.
    pub associations: Arc<dyn AssociationSource>,
    name: String,
}

impl<C: ClusterWithAssociations> Associated<C> {
    /// `method` with associations from `source`.
    pub fn new(method: C, source: Arc<dyn AssociationSource>) -> Self {
        let name = format!("{} ({})", method.name(), source.name());
        Self {
            method,
            associations: source,
            name,
        }
    }
}

impl<C: ClusterWithAssociations> MotionClusterer for Associated<C> {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn cluster(&self, pair: &ScanPair) -> Result<MotionClustering> {
        let associations = self.associations.associate(pair)?;
        self.method.cluster_with(pair, &associations)
    }
}
