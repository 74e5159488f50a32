//! CRF-Clustering of one scan pair, end to end: initial segmentation, hybrid
//! inference, merging by the effective number of clusters, ego-motion selection.
//!
//! 1. **Input** ([`ClusteringInput`]): the valid points `s_i` of the current scan in
//!    beam order, each with its associated reference point `g_i` (or none), and the
//!    odometry prior if any.
//! 2. **Initial clusters** ([`crate::segmentation`]): gap segmentation capped at
//!    [`ClusteringParams::max_clusters`] (section V-A).
//! 3. **Inference** (section IV-D): a chain CRF ([`crate::model`]) whose cluster
//!    motions are observed-continuous nodes; [`HybridInference`] alternates message
//!    passing with closed-form motion solves (eq. 3) until the motions and messages
//!    are stable. Messages are max-product (log space, no exponentials in the inner
//!    loop: about ten times faster than sum-product here); labels are the MAP
//!    assignment and the beliefs used for merging are the max-marginals normalised
//!    to sum to one. With [`UpdateSchedule::EverySweep`]
//!    (default) the motions are re-solved after every forward-backward sweep over the
//!    chain ([`Sequential::default`], exact on a chain for fixed motions); with
//!    [`UpdateSchedule::EveryVisit`] after every variable visit (Algorithm 1 of the
//!    joint-model paper). On the chain (no kNN edges) with `EverySweep` a dedicated
//!    solver ([`ClusteringParams::chain_solver`], `crate::chain`) runs the same
//!    algorithm as exact Viterbi passes without the generic factor graph.
//! 4. **Merging** (section IV-E, eq. 8): the effective number of clusters of a point
//!    is `N_eff = 1 / Σ_c p_c²` of its normalised max-marginal `p`; a cluster whose points have a mean
//!    `N_eff` above [`ClusteringParams::merge_threshold`] (1.7) is removed and its
//!    points go to their second-best cluster, then inference runs again; clusters
//!    left without points are dropped. One cluster (the worst) is removed per round;
//!    a round that emptied clusters only drops those (an empty twin of a kept cluster
//!    would make the kept one look redundant).
//! 5. **Ego-motion**: the cluster whose motion is nearest to the odometry prior in
//!    Mahalanobis distance (diagonal covariance from
//!    [`ClusteringParams::odometry_sigma`]) is the background; without odometry the
//!    largest cluster is. Every other cluster with at least
//!    [`ClusteringParams::min_object_points`] associated points is a moving object
//!    when (a) its motion moves its points on average at least
//!    [`ClusteringParams::min_object_displacement`] away from where the background
//!    motion would put them, and (b) the data agree: under the background motion its
//!    points lie on average at least that much farther from their partners than under
//!    their own motion. (b) rejects clusters whose own motion merely overfits the
//!    association noise of a static segment (any cluster's own fit is at least as good
//!    as the background's on its points), and (c) free space shows it moved (tested per
//!    object after the split of step 6): at least
//!    [`ClusteringParams::min_free_fraction`] of its points lie, under the ego-motion
//!    (the association source's ICP estimate [`ClusteringInput::ego_motion`], else the
//!    background motion), where the reference scan saw through, or their partners lie
//!    where the current scan sees through (needs [`ClusteringInput::scans`]). An optional
//!    likelihood-ratio test ([`ClusteringParams::min_object_chi2`], off by default)
//!    is also available. The rest join the background.
//! 6. **Clean-up**: points without a partner keep their label only when an
//!    associated point of their gap segment has it, else they take the label of the
//!    nearest associated point of the segment, or the background's
//!    ([`ClusteringParams::reassign_unassociated`]): a stretch of background revealed
//!    behind a moving car otherwise follows the car along the chain. A moving cluster
//!    whose points jump by more than [`ClusteringParams::object_gap`] (in beam order)
//!    is split into objects (two cars at the same velocity share one motion); pieces
//!    with fewer than [`ClusteringParams::min_object_points`] points join the
//!    background.

use crate::associations::PointAssociations;
use crate::chain::run_chain;
use crate::model::{build_edges, ClusterMotionNodes, MAX_CLUSTERS};
use crate::segmentation::initial_clusters;
use crate::weights::ClusteringWeights;
use crate::{Error, Result};
use nalgebra::Point2;
use pgm_core::hybrid::{HybridInference, UpdatePolicy};
use pgm_core::{BeliefPropagation, Mode, Sequential, VariableId};
use pgm_datasets::{Association, ScanPair};
use pgm_features::clustering::association_variance;
use pgm_features::{wrap_angle, Pose2};

/// The median absolute difference between consecutive beam angles (0 for fewer than
/// two beams).
pub fn angle_increment(angles: &[f64]) -> f64 {
    let mut d: Vec<f64> = angles
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|x| x.is_finite())
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}
use serde::Serialize;

/// Median of the χ² distribution with 2 degrees of freedom (`2 ln 2`).
const CHI2_2_MEDIAN: f64 = 2.0 * std::f64::consts::LN_2;

/// When the cluster motions are re-solved during message passing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum UpdateSchedule {
    /// After every forward-backward sweep (default; see the module docs).
    #[default]
    EverySweep,
    /// After every variable visit (Algorithm 1 of the joint-model paper).
    EveryVisit,
}

/// Parameters of CRF-Clustering, unchecked; [`ClusteringParams::check`] turns them
/// into a [`Clusterer`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClusteringParams {
    /// Gap (m) between consecutive points that starts a new initial segment (0.5).
    pub segment_gap: f64,
    /// Largest number of clusters (initial segments are merged down to it; 8, at most 32).
    pub max_clusters: usize,
    /// Extra edges to each point's `knn` nearest neighbours besides the chain (0).
    pub knn: usize,
    /// Adds an outlier state whose local log-potential equals the distance feature of
    /// a partner this far away (m); `None` (default): no outlier state.
    pub outlier_distance: Option<f64>,
    /// Mean effective number of clusters above which a cluster is merged away (1.7).
    pub merge_threshold: f64,
    /// Largest number of sweeps per inference round (30).
    pub max_sweeps: usize,
    /// Motions count as converged when no parameter changes by more than this (1e-6).
    pub motion_tolerance: f64,
    /// When motions are re-solved.
    pub update: UpdateSchedule,
    /// Standard deviations (x m, y m, θ rad) of the odometry prior for the Mahalanobis
    /// distance that picks the background cluster ([0.3, 0.3, 0.1]).
    pub odometry_sigma: [f64; 3],
    /// Fewest points of a moving object (3).
    pub min_object_points: usize,
    /// Smallest mean displacement (m) of an object's points relative to the background
    /// motion for it to count as moving (0.15).
    pub min_object_displacement: f64,
    /// Smallest likelihood-ratio statistic of a moving object: the sum over its
    /// associated points of `(‖M_bg s_i − g_i‖² − ‖M_l s_i − g_i‖²) / σ_i²` (how
    /// much better its own motion `M_l` explains its partners than the background
    /// motion `M_bg` does, in units of the association variance `σ_i²`). Under the
    /// hypothesis that the cluster moves with the background this is about χ² with 3
    /// degrees of freedom (the 3 parameters of its own motion). The threshold is
    /// multiplied by the association noise scale of the pair: the median of
    /// `‖M_bg s_i − g_i‖² / σ_i²` over the background's associated points divided by
    /// its expected value 2 ln 2, at least 1 (automatic associations are noisier than
    /// `σ_i`). 0 keeps only the displacement tests.
    pub min_object_chi2: f64,
    /// Smallest fraction of a moving cluster's points that show it moved by free
    /// space (0.2; 0: no test): moved by the ego-motion ([`ClusteringInput::ego_motion`],
    /// else the background motion) into the reference frame they lie more than
    /// [`ClusteringParams::free_space_margin`] in front of the reference returns at
    /// their bearing (the reference saw through where they are
    /// now), or their partners, moved back into the current frame, lie that far in
    /// front of the current returns (the object left). A static surface merely seen
    /// differently (new view, wrong associations) fails both. Needs
    /// [`ClusteringInput::scans`].
    pub min_free_fraction: f64,
    /// Margin (m) of the free-space test (0.3).
    pub free_space_margin: f64,
    /// Largest distance (m) between consecutive points (in beam order) of one moving
    /// object: a moving cluster with a larger jump is split into several objects (4).
    pub object_gap: f64,
    /// Whether points without a partner are checked against the associated points of
    /// their gap segment after inference (true; see the module docs, step 6).
    pub reassign_unassociated: bool,
    /// Whether the chain CRF (`knn == 0`, [`UpdateSchedule::EverySweep`]) runs on the
    /// dedicated chain solver (true, default: one exact Viterbi pass per sweep, about
    /// three times faster) rather than on the generic `pgm_core` [`HybridInference`]
    /// (same algorithm; kept for checking). Ignored for other graphs and schedules.
    pub chain_solver: bool,
    /// The learned weights (default: the shipped ones).
    pub weights: ClusteringWeights,
}

impl Default for ClusteringParams {
    fn default() -> Self {
        Self {
            segment_gap: 0.5,
            max_clusters: 8,
            knn: 0,
            outlier_distance: None,
            merge_threshold: 1.7,
            max_sweeps: 30,
            motion_tolerance: 1e-6,
            update: UpdateSchedule::EverySweep,
            odometry_sigma: [0.3, 0.3, 0.1],
            min_object_points: 3,
            min_object_displacement: 0.15,
            object_gap: 4.0,
            min_object_chi2: 0.0,
            min_free_fraction: 0.2,
            free_space_margin: 0.3,
            reassign_unassociated: true,
            chain_solver: true,
            weights: ClusteringWeights::default(),
        }
    }
}

fn invalid(name: &'static str, value: impl std::fmt::Debug, expected: &'static str) -> Error {
    Error::InvalidParameter {
        name,
        value: format!("{value:?}"),
        expected,
    }
}

impl ClusteringParams {
    /// Checks every value once.
    pub fn check(&self) -> Result<Clusterer> {
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if !positive(self.segment_gap) {
            return Err(invalid(
                "segment_gap",
                self.segment_gap,
                "a positive number of metres",
            ));
        }
        if !(1..=MAX_CLUSTERS).contains(&self.max_clusters) {
            return Err(invalid("max_clusters", self.max_clusters, "1..=32"));
        }
        if self.knn > 16 {
            return Err(invalid("knn", self.knn, "0..=16"));
        }
        if let Some(d) = self.outlier_distance {
            if !positive(d) {
                return Err(invalid(
                    "outlier_distance",
                    d,
                    "a positive number of metres",
                ));
            }
        }
        if !(self.merge_threshold.is_finite() && self.merge_threshold >= 1.0) {
            return Err(invalid(
                "merge_threshold",
                self.merge_threshold,
                "a number >= 1",
            ));
        }
        if self.max_sweeps == 0 {
            return Err(invalid("max_sweeps", self.max_sweeps, "at least 1"));
        }
        if !(self.motion_tolerance.is_finite() && self.motion_tolerance >= 0.0) {
            return Err(invalid(
                "motion_tolerance",
                self.motion_tolerance,
                "a number >= 0",
            ));
        }
        if !self.odometry_sigma.iter().all(|&s| positive(s)) {
            return Err(invalid(
                "odometry_sigma",
                self.odometry_sigma,
                "three positive standard deviations",
            ));
        }
        if !(self.min_object_displacement.is_finite() && self.min_object_displacement >= 0.0) {
            return Err(invalid(
                "min_object_displacement",
                self.min_object_displacement,
                "a number of metres >= 0",
            ));
        }
        if !(self.min_object_chi2.is_finite() && self.min_object_chi2 >= 0.0) {
            return Err(invalid(
                "min_object_chi2",
                self.min_object_chi2,
                "a number >= 0",
            ));
        }
        if !(0.0..=1.0).contains(&self.min_free_fraction) {
            return Err(invalid(
                "min_free_fraction",
                self.min_free_fraction,
                "a fraction in [0, 1]",
            ));
        }
        if !(self.free_space_margin.is_finite() && self.free_space_margin >= 0.0) {
            return Err(invalid(
                "free_space_margin",
                self.free_space_margin,
                "a number of metres >= 0",
            ));
        }
        if !positive(self.object_gap) {
            return Err(invalid(
                "object_gap",
                self.object_gap,
                "a positive number of metres",
            ));
        }
        if !self.weights.to_vec().iter().all(|w| w.is_finite()) {
            return Err(invalid("weights", self.weights, "finite weights"));
        }
        let [d0, d1] = self.weights.distance;
        let smallest = pgm_features::clustering::ASSOCIATION_NOISE.powi(2);
        if d0 + d1 / smallest >= 0.0 {
            return Err(invalid(
                "weights.distance",
                self.weights.distance,
                "weights that penalise distance at least for near points (w_sq + w_norm / σ0² < 0)",
            ));
        }
        Ok(Clusterer {
            params: self.clone(),
        })
    }
}

/// The points of one pair as the model sees them.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusteringInput {
    /// Beam index of each point in the current scan.
    pub beams: Vec<usize>,
    /// Number of beams of the current scan.
    pub beam_count: usize,
    /// The valid points `s_i` of the current scan, in beam order (sensor frame).
    pub points: Vec<Point2<f64>>,
    /// The associated reference point `g_i` of each point (reference sensor frame).
    pub partners: Vec<Option<Point2<f64>>>,
    /// Expected squared distance to a correct partner of each point
    /// ([`association_variance`] of its range and the scan's beam spacing).
    pub variances: Vec<f64>,
    /// Odometry prior on the ego-motion, if any.
    pub odometry: Option<Pose2>,
    /// The reference and current scans, for the free-space test of moving clusters
    /// ([`ClusteringParams::min_free_fraction`]); `None` skips the test.
    pub scans: Option<(pgm_features::Scan, pgm_features::Scan)>,
    /// The ego-motion the association source estimated from the whole scans (ICP), if
    /// any. The free-space test runs under it: fitted to every return, it is a steadier
    /// reference than the background cluster's motion, which rests on that cluster's
    /// nearest-neighbour partners only. `None`: the background cluster's motion.
    pub ego_motion: Option<Pose2>,
}

impl ClusteringInput {
    /// The input of `pair` with `associations` (one per current beam).
    pub fn from_pair(pair: &ScanPair, associations: &PointAssociations) -> Result<Self> {
        let a = &associations.associations;
        if a.len() != pair.current.len() {
            return Err(Error::AssociationCount {
                pair: pair.name.clone(),
                associations: a.len(),
                beams: pair.current.len(),
            });
        }
        let (points, beams) = pair.current.points();
        let increment = angle_increment(&pair.current.angles);
        let variances = beams
            .iter()
            .map(|&k| association_variance(pair.current.ranges[k], increment))
            .collect();
        let mut partners = Vec::with_capacity(points.len());
        for &k in &beams {
            partners.push(match a[k] {
                Some(Association::Point(r)) => {
                    if r >= pair.reference.len() || !pair.reference.valid[r] {
                        return Err(Error::BadPair {
                            pair: pair.name.clone(),
                            problem: format!("association of current beam {k} names reference beam {r}, which has no return"),
                        });
                    }
                    Some(pair.reference.beam_point(r))
                }
                _ => None,
            });
        }
        Ok(Self {
            beams,
            beam_count: pair.current.len(),
            points,
            partners,
            variances,
            odometry: pair.odometry,
            scans: Some((pair.reference.clone(), pair.current.clone())),
            ego_motion: associations.ego_motion,
        })
    }
}

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
}

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

/// CRF-Clustering with checked parameters.
#[derive(Clone, Debug)]
pub struct Clusterer {
    params: ClusteringParams,
}

impl Default for Clusterer {
    fn default() -> Self {
        ClusteringParams::default()
            .check()
            .expect("default parameters are valid")
    }
}

/// The end state of the inference rounds.
struct Inferred {
    labels: Vec<usize>,
    motions: Vec<Pose2>,
    clusters: usize,
    iterations: usize,
    rounds: usize,
    converged: bool,
}

impl Clusterer {
    /// The parameters.
    pub fn params(&self) -> &ClusteringParams {
        &self.params
    }

    /// Clusters `pair` with `associations`.
    pub fn cluster_pair(
        &self,
        pair: &ScanPair,
        associations: &PointAssociations,
    ) -> Result<Clustering> {
        let input = ClusteringInput::from_pair(pair, associations)?;
        self.cluster(&input)
    }

    /// Clusters the points of `input` (see the module docs).
    pub fn cluster(&self, input: &ClusteringInput) -> Result<Clustering> {
        let p = &self.params;
        let n = input.points.len();
        if input.partners.len() != n
            || input.beams.len() != n
            || input.variances.len() != n
            || input.variances.iter().any(|v| !(v.is_finite() && *v > 0.0))
            || input.beams.iter().any(|&b| b >= input.beam_count)
        {
            return Err(Error::InvalidParameter {
                name: "clustering input",
                value: format!(
                    "{} points, {} partners, {} beam indices for {} beams",
                    n,
                    input.partners.len(),
                    input.beams.len(),
                    input.beam_count
                ),
                expected:
                    "one partner, one positive variance and one beam index (< beam count) per point",
            });
        }
        if n == 0 {
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
        let inferred = self.infer(input, labels, k)?;
        Ok(self.finish(input, inferred, k))
    }

    /// Inference rounds with merging by the effective number of clusters.
    fn infer(
        &self,
        input: &ClusteringInput,
        mut labels: Vec<usize>,
        mut k: usize,
    ) -> Result<Inferred> {
        let p = &self.params;
        let n = input.points.len();
        let edges = build_edges(&input.points, p.knn);
        let outlier = p.outlier_distance.is_some();
        let mut motions = vec![input.odometry.unwrap_or_default(); k];
        let bp = BeliefPropagation::new(Mode::MaxProduct)
            .max_iterations(p.max_sweeps)
            .tolerance(1e-6);
        let policy = match p.update {
            UpdateSchedule::EverySweep => UpdatePolicy::EverySweep,
            UpdateSchedule::EveryVisit => UpdatePolicy::EveryVisit,
        };
        let hybrid = HybridInference::new(bp, policy).continuous_tolerance(p.motion_tolerance);
        // The chain needs no generic factor graph (see `crate::chain`).
        let chain = p.chain_solver && p.knn == 0 && p.update == UpdateSchedule::EverySweep;
        let mut iterations = 0;
        let mut rounds = 0;
        loop {
            rounds += 1;
            let (next, beliefs, states, sweeps, converged) = if chain {
                let mut nodes = ClusterMotionNodes::without_graph(
                    &input.points,
                    &input.partners,
                    &input.variances,
                    &edges,
                    motions,
                    p.weights,
                    p.outlier_distance,
                )?;
                let r = run_chain(&mut nodes, &labels, p.max_sweeps, p.motion_tolerance);
                motions = nodes.motions().to_vec();
                (r.labels, r.beliefs, r.states, r.sweeps, r.converged)
            } else {
                let (mut graph, mut nodes) = ClusterMotionNodes::build(
                    &input.points,
                    &input.partners,
                    &input.variances,
                    &edges,
                    motions,
                    p.weights,
                    p.outlier_distance,
                )?;
                let result = match p.update {
                    UpdateSchedule::EverySweep => hybrid.run(
                        &mut graph,
                        &mut nodes,
                        &mut Sequential::default(),
                        Some(&labels),
                    )?,
                    UpdateSchedule::EveryVisit => {
                        let order = (0..n).map(VariableId).collect();
                        hybrid.run(
                            &mut graph,
                            &mut nodes,
                            &mut Sequential::variables(order),
                            Some(&labels),
                        )?
                    }
                };
                motions = nodes.motions().to_vec();
                let states = nodes.states();
                let beliefs: Vec<f64> = result.discrete.beliefs.concat();
                (
                    result.discrete.assignment,
                    beliefs,
                    states,
                    result.discrete.iterations,
                    result.messages_converged && result.continuous_converged,
                )
            };
            iterations += sweeps;
            labels = next;
            // Eq. (8): mean effective number of clusters per cluster.
            let mut count = vec![0usize; k];
            let mut neff = vec![0.0f64; k];
            for (i, &l) in labels.iter().enumerate() {
                if l < k {
                    let b = &beliefs[i * states..(i + 1) * states];
                    let sq: f64 = b.iter().map(|x| x * x).sum();
                    count[l] += 1;
                    neff[l] += if sq > 0.0 { 1.0 / sq } else { 1.0 };
                }
            }
            let mut drop: Vec<bool> = count.iter().map(|&c| c == 0).collect();
            let nonempty = count.iter().filter(|&&c| c > 0).count();
            // A round that emptied clusters only drops them: an empty cluster whose
            // motion equals a kept one's makes that one look redundant (high N_eff),
            // and merging it too would send its points to a wrong cluster.
            if nonempty >= 2 && nonempty == k {
                let worst = (0..k)
                    .filter(|&l| count[l] > 0)
                    .map(|l| (neff[l] / count[l] as f64, l))
                    .filter(|(m, _)| *m > p.merge_threshold)
                    .max_by(|a, b| a.0.total_cmp(&b.0));
                if let Some((_, l)) = worst {
                    drop[l] = true;
                }
            }
            if !drop.iter().any(|d| *d) || rounds > MAX_CLUSTERS + 1 {
                return Ok(Inferred {
                    labels,
                    motions,
                    clusters: k,
                    iterations,
                    rounds,
                    converged,
                });
            }
            // Remove the dropped states: points of a removed cluster go to their best
            // remaining state (the second best overall).
            let mut map = vec![usize::MAX; k + usize::from(outlier)];
            let mut next = 0;
            for l in 0..k {
                if !drop[l] {
                    map[l] = next;
                    next += 1;
                }
            }
            if outlier {
                map[k] = next;
            }
            for (i, l) in labels.iter_mut().enumerate() {
                if map[*l] == usize::MAX {
                    let b = &beliefs[i * states..(i + 1) * states];
                    let best = (0..b.len())
                        .filter(|&s| map[s] != usize::MAX)
                        .max_by(|&x, &y| b[x].total_cmp(&b[y]))
                        .unwrap_or(0);
                    *l = best;
                }
                *l = map[*l];
            }
            motions = (0..k).filter(|&l| !drop[l]).map(|l| motions[l]).collect();
            k = next;
        }
    }

    fn finish(
        &self,
        input: &ClusteringInput,
        mut inferred: Inferred,
        initial: usize,
    ) -> Clustering {
        let p = &self.params;
        let k = inferred.clusters;
        let mut count = vec![0usize; k];
        for &l in &inferred.labels {
            if l < k {
                count[l] += 1;
            }
        }
        let candidates: Vec<usize> = (0..k).filter(|&l| count[l] > 0).collect();
        let (background, choice) = match input.odometry {
            Some(odo) => {
                let [sx, sy, st] = p.odometry_sigma;
                let d2 = |m: &Pose2| {
                    ((m.x() - odo.x()) / sx).powi(2)
                        + ((m.y() - odo.y()) / sy).powi(2)
                        + (wrap_angle(m.theta() - odo.theta()) / st).powi(2)
                };
                let best = candidates
                    .iter()
                    .copied()
                    .min_by(|&a, &b| d2(&inferred.motions[a]).total_cmp(&d2(&inferred.motions[b])));
                (best.unwrap_or(0), BackgroundChoice::Odometry)
            }
            None => {
                let best = candidates
                    .iter()
                    .copied()
                    .max_by_key(|&l| (count[l], std::cmp::Reverse(l)));
                (best.unwrap_or(0), BackgroundChoice::LargestCluster)
            }
        };
        let bg_motion = inferred
            .motions
            .get(background)
            .copied()
            .unwrap_or_default();
        if p.reassign_unassociated {
            reassign_unassociated(input, &mut inferred.labels, k, background, p.segment_gap);
            count.fill(0);
            for &l in &inferred.labels {
                if l < k {
                    count[l] += 1;
                }
            }
        }
        // Displacement of each cluster's points relative to the background motion.
        let mut displacement = vec![0.0f64; k];
        for (i, &l) in inferred.labels.iter().enumerate() {
            if l < k {
                let s = &input.points[i];
                displacement[l] +=
                    (inferred.motions[l].transform_point(s) - bg_motion.transform_point(s)).norm();
            }
        }
        // Evidence: how much farther from their partners the points are under the
        // background motion than under their own.
        let mut evidence = vec![0.0f64; k];
        let mut chi2 = vec![0.0f64; k];
        let mut associated = vec![0usize; k];
        for (i, &l) in inferred.labels.iter().enumerate() {
            if let (true, Some(g)) = (l < k, &input.partners[i]) {
                let s = &input.points[i];
                let bg = (bg_motion.transform_point(s) - g).norm();
                let own = (inferred.motions[l].transform_point(s) - g).norm();
                evidence[l] += bg - own;
                chi2[l] += (bg * bg - own * own) / input.variances[i];
                associated[l] += 1;
            }
        }
        // Association noise scale: the median of `‖M_bg s_i − g_i‖² / σ_i²` over the
        // background's associated points against its expected value for a 2-D
        // Gaussian residual (the median of χ² with 2 degrees of freedom, 1.386), at
        // least 1: automatic associations are noisier than `σ_i` says.
        let mut ratios: Vec<f64> = inferred
            .labels
            .iter()
            .enumerate()
            .filter_map(|(i, &l)| {
                let g = input.partners[i].as_ref()?;
                (l == background).then(|| {
                    (bg_motion.transform_point(&input.points[i]) - g).norm_squared()
                        / input.variances[i]
                })
            })
            .collect();
        let noise_scale = if ratios.is_empty() {
            1.0
        } else {
            let mid = ratios.len() / 2;
            let median = *ratios.select_nth_unstable_by(mid, f64::total_cmp).1;
            (median / CHI2_2_MEDIAN).max(1.0)
        };
        let mut moving = vec![false; k];
        for l in 0..k {
            if count[l] > 0 {
                displacement[l] /= count[l] as f64;
            }
            if associated[l] > 0 {
                evidence[l] /= associated[l] as f64;
            }
            moving[l] = l != background
                && associated[l] >= p.min_object_points
                && displacement[l] >= p.min_object_displacement
                && evidence[l] >= p.min_object_displacement
                && chi2[l] >= p.min_object_chi2 * noise_scale;
        }
        // Free-space evidence per point of a moving cluster; tested per object below.
        let mut free_point = vec![true; inferred.labels.len()];
        if let (true, Some((reference, current))) = (p.min_free_fraction > 0.0, &input.scans) {
            let ego = input.ego_motion.unwrap_or(bg_motion);
            let back = ego.inverse();
            for (i, &l) in inferred.labels.iter().enumerate() {
                if l >= k || !moving[l] {
                    continue;
                }
                let forward = crate::associations::in_free_space(
                    reference,
                    &ego.transform_point(&input.points[i]),
                    p.free_space_margin,
                );
                let left = input.partners[i].as_ref().is_some_and(|g| {
                    crate::associations::in_free_space(
                        current,
                        &back.transform_point(g),
                        p.free_space_margin,
                    )
                });
                free_point[i] = forward || left;
            }
        }
        // Number moving objects by first appearance; a moving cluster whose points
        // (in beam order) jump by more than `object_gap` is several objects that
        // happen to move alike (two cars at the same velocity).
        let mut current = vec![0u32; k];
        let mut last: Vec<Option<usize>> = vec![None; k];
        let mut next = 1u32;
        let mut point_labels = vec![0u32; inferred.labels.len()];
        let mut objects: Vec<Cluster> = Vec::new();
        let mut object_free: Vec<usize> = Vec::new();
        for (i, &l) in inferred.labels.iter().enumerate() {
            if l >= k || !moving[l] {
                continue;
            }
            let jump =
                last[l].is_none_or(|j| (input.points[i] - input.points[j]).norm() > p.object_gap);
            if jump {
                current[l] = next;
                next += 1;
                objects.push(Cluster {
                    label: current[l],
                    motion: inferred.motions[l],
                    points: 0,
                    displacement: displacement[l],
                    background: false,
                });
                object_free.push(0);
            }
            last[l] = Some(i);
            point_labels[i] = current[l];
            objects[current[l] as usize - 1].points += 1;
            object_free[current[l] as usize - 1] += usize::from(free_point[i]);
        }
        // Pieces too small to be objects on their own, or without free-space evidence
        // of motion, join the background; the rest are renumbered.
        let keep: Vec<bool> = objects
            .iter()
            .zip(&object_free)
            .map(|(o, &free)| {
                o.points >= p.min_object_points
                    && (free as f64) >= p.min_free_fraction * o.points as f64
            })
            .collect();
        let mut renumber = vec![0u32; objects.len() + 1];
        let mut kept = 0u32;
        for (o, &keep) in objects.iter().zip(&keep) {
            if keep {
                kept += 1;
                renumber[o.label as usize] = kept;
            }
        }
        objects.retain(|o| renumber[o.label as usize] != 0);
        for o in &mut objects {
            o.label = renumber[o.label as usize];
        }
        let mut labels = vec![None; input.beam_count];
        let mut bg_points = 0;
        for (i, &l) in inferred.labels.iter().enumerate() {
            if l < k {
                let out = renumber[point_labels[i] as usize];
                bg_points += usize::from(out == 0);
                labels[input.beams[i]] = Some(out);
            }
        }
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
            final_clusters: candidates.len(),
            converged: inferred.converged,
        }
    }
}

/// Points without a partner carry no motion evidence: the chain gives them the label
/// of a neighbour, which can drag a newly revealed stretch of background (seen only
/// in the current scan, behind an object that moved) into the object's cluster.
/// Each such point keeps its label only when an associated point of its gap segment
/// has that label; otherwise it takes the label of the nearest associated point of
/// its segment (in beam order), or the background's when its segment has none.
fn reassign_unassociated(
    input: &ClusteringInput,
    labels: &mut [usize],
    k: usize,
    background: usize,
    gap: f64,
) {
    let n = labels.len();
    let segments = crate::segmentation::segment_by_gap(&input.points, gap);
    let mut start = 0;
    while start < n {
        let mut end = start + 1;
        while end < n && segments[end] == segments[start] {
            end += 1;
        }
        let associated: Vec<usize> = (start..end)
            .filter(|&i| input.partners[i].is_some() && labels[i] < k)
            .collect();
        for i in start..end {
            if input.partners[i].is_some() || labels[i] >= k {
                continue;
            }
            if associated.iter().any(|&j| labels[j] == labels[i]) {
                continue;
            }
            labels[i] = associated
                .iter()
                .min_by_key(|&&j| j.abs_diff(i))
                .map_or(background, |&j| labels[j]);
        }
        start = end;
    }
}
