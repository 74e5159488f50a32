//! CRF-Clustering of one scan pair, end to end, in six steps (each in its own file):
//!
//! 1. **Input** ([`crate::input`]): the valid points `s_i` of the current scan in beam
//!    order, each with its associated reference point `g_i` (or none), and the
//!    odometry prior if any.
//! 2. **Initial clusters** ([`crate::segmentation`]): gap segmentation capped at
//!    [`ClusteringParams::max_clusters`] (section V-A).
//! 3. **Inference** ([`crate::inference`], section IV-D): a chain CRF
//!    ([`crate::model`]) whose cluster motions are observed-continuous nodes; message
//!    passing alternates with closed-form motion solves (eq. 3).
//! 4. **Merging** ([`crate::inference`], section IV-E, eq. 8): clusters whose points
//!    have a high effective number of clusters are merged away, and inference runs
//!    again.
//! 5. **Ego-motion and moving objects** ([`crate::background`]): the cluster nearest
//!    to the odometry prior is the background; the other clusters that pass the
//!    tests of [`DetectionParams`](crate::DetectionParams) are moving objects. A
//!    background with fewer than [`MIN_BACKGROUND_SUPPORT`] associated points keeps
//!    the prior as its motion ([`BackgroundChoice::PriorKept`], not converged).
//! 6. **Clean-up** ([`crate::cleanup`]): points without a partner keep a label only
//!    their segment supports; moving clusters with gaps are split into objects.

use crate::background::{choose_background, cluster_sizes, free_space_evidence, moving_clusters};
use crate::cleanup::{reassign_unassociated, split_objects};
use crate::inference::{infer, Inferred};
use crate::input::ClusteringInput;
use crate::params::ClusteringParams;
use crate::segmentation::initial_clusters;
use crate::Result;
use pgm_core::ParamGuard;
use pgm_scan::methods::{ClusterWithAssociations, MotionClustering};
use pgm_scan::{ClusterMotion, PointAssociations, Pose2, RigidAlignment, ScanPair};
use serde::Serialize;

/// How the background cluster was chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BackgroundChoice {
    /// Nearest to the odometry prior (Mahalanobis).
    Odometry,
    /// The largest cluster (no odometry).
    LargestCluster,
    /// No point to cluster.
    Empty,
    /// The background cluster has fewer than [`MIN_BACKGROUND_SUPPORT`] points with a
    /// partner, too few for a rigid fit (eq. 3 on one association follows whatever it
    /// suggests): its motion is the odometry prior (the identity without one), and the
    /// result is not converged.
    PriorKept,
}

/// Fewest background points with a partner for the background motion to be solved
/// from them (as ICP's default [`pgm_scan::registration::IcpParams`]
/// `min_correspondences`); with fewer the prior is kept ([`BackgroundChoice::PriorKept`]).
pub const MIN_BACKGROUND_SUPPORT: usize = 10;

/// One cluster of the result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Cluster {
    /// Output label: 0 for the background, 1, 2, … for moving objects.
    pub label: u32,
    /// Estimated motion mapping current points of the cluster onto the reference scan.
    pub motion: Pose2,
    /// Number of points.
    pub points: usize,
    /// Mean distance (m) between where this motion and the background motion put the
    /// cluster's points (0 for the background).
    pub displacement: f64,
    /// True for the background cluster.
    pub background: bool,
}

/// The result of CRF-Clustering on one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Clustering {
    /// Per beam of the current scan: 0 background, 1, 2, … moving objects, `None` for
    /// beams without a return and points in the outlier state.
    pub labels: Vec<Option<u32>>,
    /// The clusters, background first.
    pub clusters: Vec<Cluster>,
    /// The background motion (ego-motion estimate).
    pub background_motion: Pose2,
    /// How the background was chosen.
    pub background_choice: BackgroundChoice,
    /// Total number of message-passing sweeps over all inference rounds.
    pub iterations: usize,
    /// Number of inference rounds (1 + number of merges).
    pub rounds: usize,
    /// Number of clusters after the initial segmentation.
    pub initial_clusters: usize,
    /// Number of clusters the inference ended with (before non-moving clusters joined
    /// the background).
    pub final_clusters: usize,
    /// Whether the last round's messages and motions converged.
    pub converged: bool,
}

/// CRF-Clustering with checked parameters (made by
/// [`ParamGuard::check`] on [`ClusteringParams`]).
#[derive(Clone, Debug)]
pub struct Clusterer {
    params: ClusteringParams,
}

impl Default for Clusterer {
    fn default() -> Self {
        ClusteringParams::default().check_unwrap()
    }
}

impl Clusterer {
    /// Wraps parameters that passed [`ParamGuard::check_ref`].
    pub(crate) fn from_checked(params: ClusteringParams) -> Self {
        Self { params }
    }

    /// The parameters.
    pub fn params(&self) -> &ClusteringParams {
        &self.params
    }

    /// Clusters `pair` with `associations` (one per current beam).
    pub fn cluster_pair(
        &self,
        pair: &ScanPair,
        associations: &PointAssociations,
    ) -> Result<Clustering> {
        let input = ClusteringInput::from_pair(pair, associations)?;
        self.cluster(&input)
    }

    /// Clusters the points of `input` (the six steps of the module docs).
    pub fn cluster(&self, input: &ClusteringInput) -> Result<Clustering> {
        let p = &self.params;
        input.check()?;
        if input.is_empty() {
            return Ok(Clustering {
                labels: vec![None; input.beam_count],
                clusters: Vec::new(),
                background_motion: input.odometry.unwrap_or_default(),
                background_choice: BackgroundChoice::Empty,
                iterations: 0,
                rounds: 0,
                initial_clusters: 0,
                final_clusters: 0,
                converged: true,
            });
        }
        let (labels, k) = initial_clusters(
            &input.points,
            &input.partners,
            &input.variances,
            p.segment_gap,
            p.max_clusters,
        );
        let inferred = infer(p, input, labels, k)?;
        Ok(self.finish(input, inferred, k))
    }

    /// Steps 5 and 6 on the end state of inference.
    fn finish(
        &self,
        input: &ClusteringInput,
        mut inferred: Inferred,
        initial: usize,
    ) -> Clustering {
        let p = &self.params;
        let d = &p.detection;
        let k = inferred.clusters;
        let count = cluster_sizes(&inferred.labels, k);
        let final_clusters = count.iter().filter(|&&c| c > 0).count();
        let (background, mut choice) =
            choose_background(p, input.odometry, &inferred.motions, &count);
        let mut bg_motion = inferred
            .motions
            .get(background)
            .copied()
            .unwrap_or_default();
        // Too little data for a rigid fit keeps the prior, and says so.
        let support = inferred
            .labels
            .iter()
            .zip(&input.partners)
            .filter(|(&l, partner)| l == background && partner.is_some())
            .count();
        if support < MIN_BACKGROUND_SUPPORT {
            bg_motion = input.odometry.unwrap_or_default();
            if let Some(m) = inferred.motions.get_mut(background) {
                *m = bg_motion;
            }
            inferred.converged = false;
            choice = BackgroundChoice::PriorKept;
        }
        if d.reassign_unassociated {
            reassign_unassociated(input, &mut inferred.labels, k, background, p.segment_gap);
        }
        let (moving, displacement) =
            moving_clusters(input, d, &inferred.labels, &inferred.motions, background);
        let ego = input.ego_motion.unwrap_or(bg_motion);
        let free = free_space_evidence(input, d, &inferred.labels, &moving, ego);
        let reported = match p.object_rotation_sigma {
            Some(sigma) => {
                with_rotation_prior(input, &inferred, &moving, background, bg_motion, sigma)
            }
            None => inferred.motions.clone(),
        };
        let (point_labels, objects) = split_objects(
            input,
            p,
            &inferred.labels,
            &reported,
            &moving,
            &displacement,
            &free,
        );
        let mut labels = vec![None; input.beam_count];
        for (&beam, &label) in input.beams.iter().zip(&point_labels) {
            labels[beam] = label;
        }
        let bg_points = point_labels.iter().filter(|&&l| l == Some(0)).count();
        let mut clusters = vec![Cluster {
            label: 0,
            motion: bg_motion,
            points: bg_points,
            displacement: 0.0,
            background: true,
        }];
        clusters.extend(objects);
        Clustering {
            labels,
            clusters,
            background_motion: bg_motion,
            background_choice: choice,
            iterations: inferred.iterations,
            rounds: inferred.rounds,
            initial_clusters: initial,
            final_clusters,
            converged: inferred.converged,
        }
    }
}

/// The motions to report: each moving cluster's (not the background's) solved again
/// from its associated returns (eq. 3, weights `1/σ_i²`) with a rotation prior
/// centred on the background's rotation `bg_motion`, of standard deviation `sigma`
/// (rad; [`crate::ClusteringParams::object_rotation_sigma`]); the others as inferred.
fn with_rotation_prior(
    input: &ClusteringInput,
    inferred: &Inferred,
    moving: &[bool],
    background: usize,
    bg_motion: Pose2,
    sigma: f64,
) -> Vec<Pose2> {
    let mut stats = vec![RigidAlignment::new(); inferred.motions.len()];
    for (i, &l) in inferred.labels.iter().enumerate() {
        if let (Some(g), Some(stats)) = (input.partners[i], stats.get_mut(l)) {
            stats.add(&input.points[i], &g, 1.0 / input.variances[i]);
        }
    }
    let kappa = 1.0 / (sigma * sigma);
    inferred
        .motions
        .iter()
        .enumerate()
        .map(|(l, &m)| {
            if l == background || !moving.get(l).copied().unwrap_or(false) {
                return m;
            }
            stats[l]
                .solve_with_rotation_prior(bg_motion.theta(), kappa)
                .map_or(m, |a| a.motion)
        })
        .collect()
}

impl From<Clustering> for MotionClustering {
    fn from(c: Clustering) -> Self {
        MotionClustering {
            motions: c
                .clusters
                .iter()
                .map(|cl| ClusterMotion {
                    label: cl.label,
                    motion: cl.motion,
                    kind: if cl.background {
                        "background"
                    } else {
                        "moving"
                    }
                    .into(),
                })
                .collect(),
            ego_motion: (c.background_choice != BackgroundChoice::Empty)
                .then_some(c.background_motion),
            labels: c.labels,
            iterations: c.iterations,
            converged: c.converged,
        }
    }
}

impl ClusterWithAssociations for Clusterer {
    fn name(&self) -> &str {
        "crf"
    }

    fn cluster_with(
        &self,
        pair: &ScanPair,
        associations: &PointAssociations,
    ) -> pgm_scan::Result<MotionClustering> {
        Ok(self.cluster_pair(pair, associations)?.into())
    }
}
