//! The interfaces through which evaluation runs a method on scan pairs, in the spirit
//! of linfa's `Predict`: a [`ScanMatcher`] estimates the ego-motion of a pair, a
//! [`MotionClusterer`] labels the current scan's returns with clusters of common
//! motion, a [`JointEstimator`] does both and associates the returns as well (the
//! joint model, and the two-step pipelines it is compared with: [`TwoSteps`]);
//! [`JointClusters`] and [`JointEgoMotion`] score a joint method's clusters and
//! ego-motion through the clustering and matching evaluations.
//! Evaluation (`pgm_eval`), the command-line tool, the
//! examples and the tests are generic over them, so adding a model means adding an
//! implementation, not a branch in the tool.
//!
//! ```
//! use pgm_scan::methods::{Odometry, ScanMatcher};
//! use pgm_scan::pair::ScanPair;
//! use pgm_scan::{Pose2, Scan};
//!
//! let scan = Scan::from_ranges(vec![0.0], vec![1.0], 10.0);
//! let pair = ScanPair { name: "p".into(), reference: scan.clone(), current: scan,
//!                       odometry: Some(Pose2::new(0.5, 0.0, 0.0)), truth: None };
//! let estimate = Odometry.estimate(&pair).unwrap();
//! assert_eq!(estimate.motion, Pose2::new(0.5, 0.0, 0.0));
//! ```

use crate::association::{AssociationSource, PointAssociations};
use crate::pair::{Association, ClusterMotion, ScanPair};
use crate::registration::{IcpMatcher, IcpStatus};
use crate::scan::{segment_by_gap, Scan};
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

impl MotionClustering {
    /// The labels above 0 (moving objects) that label a return, in increasing order,
    /// each once.
    pub fn moving_labels(&self) -> Vec<u32> {
        let mut labels: Vec<u32> = self
            .labels
            .iter()
            .flatten()
            .copied()
            .filter(|&l| l > 0)
            .collect();
        labels.sort_unstable();
        labels.dedup();
        labels
    }

    /// The estimated motion of the cluster `label`, when the method estimated one.
    pub fn motion_of(&self, label: u32) -> Option<Pose2> {
        self.motions
            .iter()
            .find(|m| m.label == label)
            .map(|m| m.motion)
    }
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

/// A return's cluster in a [`JointEstimate`]: a motion cluster or the outlier cluster
/// (returns whose surface the other scan does not show). Serialised as the cluster
/// index, `-1` for the outlier cluster.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JointCluster {
    /// A motion cluster: an index into [`JointEstimate::motions`].
    Object(usize),
    /// The outlier cluster.
    Outlier,
}

impl Serialize for JointCluster {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            JointCluster::Object(k) => s.serialize_u64(*k as u64),
            JointCluster::Outlier => s.serialize_i64(-1),
        }
    }
}

/// A method's point associations, clustering and motions of one pair, together (the
/// output of the joint model of van de Ven, Ramos and Tipaldi, and of the two-step
/// pipelines it is compared with).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointEstimate {
    /// Per beam of the current scan: its association (a reference beam or outlier),
    /// `None` for beams without a return.
    pub associations: Vec<Option<Association>>,
    /// Per beam of the current scan: its cluster, `None` for beams without a return.
    pub clusters: Vec<Option<JointCluster>>,
    /// The motion of every motion cluster (maps its current points onto the reference
    /// scan).
    pub motions: Vec<Pose2>,
    /// The static background: an index into `motions`.
    pub background: usize,
    /// The ego-motion estimate.
    pub ego_motion: Pose2,
    /// Iterations (message-passing sweeps, assignment rounds) the method reported.
    pub iterations: usize,
    /// Whether the method converged.
    pub converged: bool,
}

impl JointEstimate {
    /// The estimate of a two-step method: `associations` from an association source,
    /// then `clustering` of a [`ClusterWithAssociations`] method on them. The clusters
    /// are the clustering's labels (label 0, the background, becomes motion cluster 0;
    /// the other labels follow in increasing order); a return the association source
    /// calls an outlier, or that the clustering leaves unlabelled, is in the outlier
    /// cluster. A label without a motion in `clustering.motions` takes the ego-motion.
    /// The ego-motion is the association source's when it has one, else the
    /// clustering's, else the background's motion; the iterations are the clustering's
    /// (an association source reports none).
    pub fn from_two_steps(
        associations: PointAssociations,
        clustering: MotionClustering,
    ) -> JointEstimate {
        let labels: Vec<u32> = std::iter::once(0)
            .chain(clustering.moving_labels())
            .collect();
        let ego_motion = associations
            .ego_motion
            .or(clustering.ego_motion)
            .or_else(|| clustering.motion_of(0))
            .unwrap_or_default();
        let motions = labels
            .iter()
            .map(|&l| clustering.motion_of(l).unwrap_or(ego_motion))
            .collect();
        let clusters = clustering
            .labels
            .iter()
            .zip(&associations.associations)
            .map(|(label, association)| match (label, association) {
                (_, Some(Association::Outlier)) | (None, Some(_)) => Some(JointCluster::Outlier),
                (Some(l), _) => Some(JointCluster::Object(
                    labels.binary_search(l).expect("every label was collected"),
                )),
                (None, None) => None,
            })
            .collect();
        JointEstimate {
            associations: associations.associations,
            clusters,
            motions,
            background: 0,
            ego_motion,
            iterations: clustering.iterations,
            converged: clustering.converged,
        }
    }

    /// The clusters as a [`MotionClustering`]: the background is label 0, the other
    /// motion clusters 1, 2, … in the order of `motions`; a return in the outlier
    /// cluster is labelled as `outliers` says (unlabelled, `None`, for pictures that
    /// show the outlier cluster apart; the background, for scoring as a motion
    /// clusterer, see [`JointClusters`]).
    pub fn to_motion_clustering(&self, outliers: OutlierReturns) -> MotionClustering {
        let outlier_label = match outliers {
            OutlierReturns::Unlabelled => None,
            OutlierReturns::Background => Some(0),
        };
        let label_of = |k: usize| -> u32 {
            if k == self.background {
                0
            } else if k < self.background {
                k as u32 + 1
            } else {
                k as u32
            }
        };
        MotionClustering {
            labels: self
                .clusters
                .iter()
                .map(|c| match c {
                    Some(JointCluster::Object(k)) => Some(label_of(*k)),
                    Some(JointCluster::Outlier) => outlier_label,
                    None => None,
                })
                .collect(),
            motions: self
                .motions
                .iter()
                .enumerate()
                .map(|(k, m)| ClusterMotion {
                    label: label_of(k),
                    motion: *m,
                    kind: if k == self.background {
                        "background"
                    } else {
                        "moving"
                    }
                    .into(),
                })
                .collect(),
            ego_motion: Some(self.ego_motion),
            iterations: self.iterations,
            converged: self.converged,
        }
    }
}

impl JointEstimate {
    /// [`JointEstimate::to_motion_clustering`] with every return of the outlier
    /// cluster given the label of the object it lies on: the nearest return (in beam
    /// order, the earlier one on a tie) on its surface — consecutive returns of
    /// `current` (the pair's current scan) no farther apart than `gap` metres — that
    /// is in a motion cluster other than the background; else the background. A
    /// return without a partner (a side of a car the reference scan did not see) has
    /// no motion of its own, and the joint model associates it under this same
    /// carrier's motion; CRF-Clustering's clean-up gives such returns their
    /// segment's label the same way.
    ///
    /// # Panics
    /// If `current` does not have one beam per entry of `clusters`.
    pub fn to_motion_clustering_on_surfaces(&self, current: &Scan, gap: f64) -> MotionClustering {
        assert_eq!(
            current.len(),
            self.clusters.len(),
            "one cluster entry per beam"
        );
        let mut clustering = self.to_motion_clustering(OutlierReturns::Background);
        let (points, beams) = current.points();
        let surface = segment_by_gap(&points, gap);
        let moving = |i: usize| match self.clusters[beams[i]] {
            Some(JointCluster::Object(k)) if k != self.background => clustering.labels[beams[i]],
            _ => None,
        };
        let mut labels = clustering.labels.clone();
        for i in 0..beams.len() {
            if self.clusters[beams[i]] != Some(JointCluster::Outlier) {
                continue;
            }
            for d in 1..beams.len() {
                let before = i.checked_sub(d).filter(|&k| surface[k] == surface[i]);
                let after = Some(i + d).filter(|&k| k < beams.len() && surface[k] == surface[i]);
                if before.is_none() && after.is_none() {
                    break;
                }
                if let Some(label) = before.and_then(moving).or_else(|| after.and_then(moving)) {
                    labels[beams[i]] = Some(label);
                    break;
                }
            }
        }
        clustering.labels = labels;
        clustering
    }
}

/// How [`JointEstimate::to_motion_clustering`] labels the returns of the outlier
/// cluster.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutlierReturns {
    /// Unlabelled (`None`): a cluster of its own for the V-measure, not moving for the
    /// detection metrics.
    Unlabelled,
    /// The background (label 0).
    Background,
}

/// Estimates the point associations, the clusters of common motion and their motions
/// of scan pairs together (scan matching, moving-object detection and motion
/// estimation), as the joint model does.
///
/// ```
/// use pgm_scan::methods::{JointCluster, JointEstimate, JointEstimator, OutlierReturns};
/// use pgm_scan::{Association, Pose2, Result, Scan, ScanPair};
///
/// /// Every return associated to the same beam, all in the background.
/// struct Identity;
///
/// impl JointEstimator for Identity {
///     fn name(&self) -> &str {
///         "identity"
///     }
///
///     fn estimate(&self, pair: &ScanPair) -> Result<JointEstimate> {
///         let valid = &pair.current.valid;
///         Ok(JointEstimate {
///             associations: (0..valid.len()).map(|k| valid[k].then_some(Association::Point(k))).collect(),
///             clusters: valid.iter().map(|&v| v.then_some(JointCluster::Object(0))).collect(),
///             motions: vec![Pose2::identity()],
///             background: 0,
///             ego_motion: Pose2::identity(),
///             iterations: 0,
///             converged: true,
///         })
///     }
/// }
///
/// let scan = Scan::from_ranges(vec![0.0, 0.1], vec![1.0, 1.0], 10.0);
/// let pair = ScanPair { name: "p".into(), reference: scan.clone(), current: scan,
///                       odometry: None, truth: None };
/// let estimate = Identity.estimate(&pair).unwrap();
/// assert_eq!(estimate.to_motion_clustering(OutlierReturns::Background).labels, vec![Some(0), Some(0)]);
/// ```
pub trait JointEstimator: Send + Sync {
    /// The method's name, as typed on the command line.
    fn name(&self) -> &str;

    /// The associations, clusters and motions of `pair`. Errors name the pair.
    fn estimate(&self, pair: &ScanPair) -> Result<JointEstimate>;
}

impl<E: JointEstimator + ?Sized> JointEstimator for Box<E> {
    fn name(&self) -> &str {
        (**self).name()
    }

    fn estimate(&self, pair: &ScanPair) -> Result<JointEstimate> {
        (**self).estimate(pair)
    }
}

impl<E: JointEstimator + ?Sized> JointEstimator for Arc<E> {
    fn name(&self) -> &str {
        (**self).name()
    }

    fn estimate(&self, pair: &ScanPair) -> Result<JointEstimate> {
        (**self).estimate(pair)
    }
}

/// A [`ClusterWithAssociations`] method after an [`AssociationSource`], as one
/// [`JointEstimator`] (the two-step pipelines the joint model is compared with:
/// ICP or CRF-Matching, then motion K-Means or CRF-Clustering); see
/// [`JointEstimate::from_two_steps`].
pub struct TwoSteps<C> {
    /// The clustering method.
    pub method: C,
    /// Where its associations come from.
    pub associations: Arc<dyn AssociationSource>,
    name: String,
}

impl<C: ClusterWithAssociations> TwoSteps<C> {
    /// `method` after `source`, named `name`.
    pub fn new(name: impl Into<String>, method: C, source: Arc<dyn AssociationSource>) -> Self {
        Self {
            method,
            associations: source,
            name: name.into(),
        }
    }
}

impl<C: ClusterWithAssociations> JointEstimator for TwoSteps<C> {
    fn name(&self) -> &str {
        &self.name
    }

    fn estimate(&self, pair: &ScanPair) -> Result<JointEstimate> {
        let associations = self.associations.associate(pair)?;
        let clustering = self.method.cluster_with(pair, &associations)?;
        Ok(JointEstimate::from_two_steps(associations, clustering))
    }
}

/// A [`JointEstimator`]'s clusters as a [`MotionClusterer`], so the clustering
/// evaluation scores a joint method like every other clusterer: a motion clusterer
/// labels every return. A return of the outlier cluster takes the label of the
/// moving cluster on its surface, else the background
/// ([`JointEstimate::to_motion_clustering_on_surfaces`], surfaces split at
/// [`SURFACE_GAP`]), as CRF-Clustering's clean-up gives a return without a partner
/// its segment's label. (Left unlabelled, the outlier cluster would be a cluster of
/// its own, and on a pair without a moving object any return in it would score the
/// V-measure 0, whatever the clustering; all given to the background, the unseen
/// sides of every car count as static.) Measured with the joint model, dev seed 3,
/// V-measure all-background → by surface: overtaking 0.764 → 0.881, intersection
/// 0.628 → 0.648, oncoming 0.911 → 0.916, pedestrians 0.366 → 0.375, mixed 0.836 →
/// 0.873, following 0.849 → 0.855 (object recall the same or higher, false alarms
/// the same); leigh-gtm1 track labels k = 1 / 3 / 5: V 0.482 / 0.357 / 0.369 →
/// 0.482 / 0.365 / 0.377, recall 9 → 10 of 31 at k = 1 and 8 → 9 of 27 at k = 5,
/// false alarms the same; datmo intersection k = 3 V 0.737 → 0.755, overtake_ego
/// 0.176 → 0.180. `pgm eval joint` scores the outlier cluster itself
/// (`pgm_eval::evaluate_joint`).
pub struct JointClusters<E>(pub E);

impl<E: JointEstimator> MotionClusterer for JointClusters<E> {
    fn name(&self) -> String {
        self.0.name().to_string()
    }

    fn cluster(&self, pair: &ScanPair) -> Result<MotionClustering> {
        let estimate = self.0.estimate(pair)?;
        if estimate.clusters.len() != pair.current.len() {
            return Err(crate::Error::BadPair {
                pair: pair.name.clone(),
                problem: format!(
                    "{} gave {} cluster entries for the {} beams of the current scan",
                    self.0.name(),
                    estimate.clusters.len(),
                    pair.current.len()
                ),
            });
        }
        Ok(estimate.to_motion_clustering_on_surfaces(&pair.current, SURFACE_GAP))
    }
}

/// Consecutive returns farther apart than this (m) lie on different surfaces for
/// [`JointClusters`] (segment-wise ICP's default segment gap and the joint model's
/// carrier gap).
pub const SURFACE_GAP: f64 = 0.5;

/// A [`JointEstimator`]'s ego-motion as a [`ScanMatcher`], so the scan-matching
/// evaluation scores a joint method like every other matcher. A run that did not
/// converge (the sweep limit) still has an estimate; it is reported with
/// `converged: false` and a note.
pub struct JointEgoMotion<E>(pub E);

impl<E: JointEstimator> ScanMatcher for JointEgoMotion<E> {
    fn name(&self) -> &str {
        self.0.name()
    }

    fn estimate(&self, pair: &ScanPair) -> Result<EgoMotionEstimate> {
        let e = self.0.estimate(pair)?;
        Ok(EgoMotionEstimate {
            motion: e.ego_motion,
            converged: e.converged,
            iterations: e.iterations,
            note: (!e.converged)
                .then(|| format!("stopped unconverged after {} iterations", e.iterations)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn motion(label: u32, x: f64) -> ClusterMotion {
        ClusterMotion {
            label,
            motion: Pose2::new(x, 0.0, 0.0),
            kind: String::new(),
        }
    }

    /// Five beams: background, object 2 (no motion reported), outlier association,
    /// no return, object 5; the clustering's labels skip numbers.
    fn two_steps() -> JointEstimate {
        let associations = PointAssociations {
            associations: vec![
                Some(Association::Point(0)),
                Some(Association::Point(1)),
                Some(Association::Outlier),
                None,
                Some(Association::Point(4)),
            ],
            ego_motion: Some(Pose2::new(0.5, 0.0, 0.0)),
        };
        let clustering = MotionClustering {
            labels: vec![Some(0), Some(2), Some(2), None, Some(5)],
            motions: vec![motion(0, 0.4), motion(5, 2.0)],
            ego_motion: Some(Pose2::new(0.4, 0.0, 0.0)),
            iterations: 7,
            converged: false,
        };
        JointEstimate::from_two_steps(associations, clustering)
    }

    #[test]
    fn two_steps_number_the_clusters_and_send_outliers_to_the_outlier_cluster() {
        let e = two_steps();
        assert_eq!(
            e.clusters,
            vec![
                Some(JointCluster::Object(0)),
                Some(JointCluster::Object(1)),
                Some(JointCluster::Outlier),
                None,
                Some(JointCluster::Object(2)),
            ]
        );
        // Label 2 has no motion: it takes the ego-motion, the association source's.
        assert_eq!(
            e.motions,
            vec![
                Pose2::new(0.4, 0.0, 0.0),
                Pose2::new(0.5, 0.0, 0.0),
                Pose2::new(2.0, 0.0, 0.0)
            ]
        );
        assert_eq!(e.ego_motion, Pose2::new(0.5, 0.0, 0.0));
        assert_eq!((e.background, e.iterations, e.converged), (0, 7, false));
    }

    #[test]
    fn motion_clusterings_put_the_background_first_and_label_outliers_as_asked() {
        let mut e = two_steps();
        // Make cluster 1 the background: it becomes label 0, cluster 0 label 1.
        e.background = 1;
        let unlabelled = e.to_motion_clustering(OutlierReturns::Unlabelled);
        assert_eq!(
            unlabelled.labels,
            vec![Some(1), Some(0), None, None, Some(2)]
        );
        let background = e.to_motion_clustering(OutlierReturns::Background);
        assert_eq!(
            background.labels,
            vec![Some(1), Some(0), Some(0), None, Some(2)]
        );
        let kinds: Vec<(u32, &str)> = background
            .motions
            .iter()
            .map(|m| (m.label, m.kind.as_str()))
            .collect();
        assert_eq!(kinds, vec![(1, "moving"), (0, "background"), (2, "moving")]);
        assert_eq!(background.ego_motion, Some(e.ego_motion));
    }

    /// Outlier-cluster returns take the moving cluster of their surface (nearest in
    /// beam order, the earlier on a tie), never across a gap, and the background when
    /// their surface has no moving return.
    #[test]
    fn outlier_returns_join_the_moving_cluster_of_their_surface() {
        use crate::Scan;
        // Beams 0-3 one surface (1 m apart at most), a 3 m gap, beams 4-7 another; the
        // angles are 0 so each return lies at its range along x.
        let ranges = vec![1.0, 1.3, 1.6, 1.9, 5.0, 5.2, 5.4, 5.6];
        let scan = Scan::from_ranges(vec![0.0; 8], ranges, 30.0);
        let (o, b, m) = (
            Some(JointCluster::Outlier),
            Some(JointCluster::Object(0)),
            Some(JointCluster::Object(1)),
        );
        let e = JointEstimate {
            associations: vec![None; 8],
            clusters: vec![o, m, o, o, o, b, o, o],
            motions: vec![Pose2::identity(), Pose2::new(1.0, 0.0, 0.0)],
            background: 0,
            ego_motion: Pose2::identity(),
            iterations: 1,
            converged: true,
        };
        let labels = e.to_motion_clustering_on_surfaces(&scan, 0.5).labels;
        assert_eq!(
            labels,
            vec![
                Some(1),
                Some(1),
                Some(1),
                Some(1),
                Some(0),
                Some(0),
                Some(0),
                Some(0)
            ]
        );
        // Split every surface at every return: nothing to carry.
        let alone = e.to_motion_clustering_on_surfaces(&scan, 0.1).labels;
        assert_eq!(
            alone,
            e.to_motion_clustering(OutlierReturns::Background).labels
        );
    }
}
