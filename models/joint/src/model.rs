//! The joint CRF of one scan pair (section IV-A of van de Ven, Ramos and Tipaldi, Fig.
//! 1): two chains over the current scan's returns and the rigid motions that couple
//! them.
//!
//! - Chain 0, association (`x^a`): node `i` takes a candidate partner among the
//!   reference returns or the outlier state ([`AssociationTables`]).
//! - Chain 1, clustering (`x^c`): node `i` takes one of `D` clusters, the last one the
//!   outlier cluster ([`pgm_features::joint_clustering_features`]).
//! - `x^RT`: one rigid motion per motion cluster (`D − 1`), observed-continuous:
//!   re-solved in closed form (eq. 6, each pair weighted by `1 / σ_i²`) from the
//!   current associations of the cluster's returns.
//!
//! The chains are linked through the motions only, as the paper's Fig. 1 draws them
//! ("the x^a and x^c nodes are indirectly linked through the motion estimate node"):
//! a node's association features use the motion of its cluster (in the outlier
//! cluster: the motion cluster of the nearest return on the same surface, so that the
//! occluded end of a moving car is still associated under the car's motion and can
//! leave the outlier cluster; the background's when its surface has no return in a
//! motion cluster), and the clustering features read each return's
//! current association (its partner, or none for the outlier state) as the evidence
//! the motions were solved from. The clustering chain's `cluster_distance` and
//! `cluster_inlier` are local features of the clustering chain only. (Writing them
//! into the association chain's tables too, as factors shared by both chains, was
//! tried: pseudo-likelihood then learns `cluster_inlier` as a near-hard constraint
//! (weight 15.5) that leaves the association chain's outlier evidence unused, and the
//! alternation cannot move a return into the outlier state of either chain first.)

use crate::weights::{ASSOCIATION_BASE, CLUSTERING_BASE};
use pgm_core::hybrid::chain::{FeatureSink, HybridChainModel};
use pgm_core::hybrid::PairPattern;
use pgm_features::joint_clustering_features;
use pgm_features::matching_features::{AssociationProblem, AssociationTables};
use pgm_scan::alignment::{fit_trimmed, POINT_TO_POINT_WEIGHT};
use pgm_scan::scan::segment_by_gap;
use pgm_scan::{Pose2, RigidAlignment, SurfacePair, TrimmedFitParams};
use std::sync::Arc;

/// The association chain's index.
pub const ASSOCIATION_CHAIN: usize = 0;
/// The clustering chain's index.
pub const CLUSTERING_CHAIN: usize = 1;

/// Fewest associated returns a cluster's motion is solved from; fewer keep it.
pub const MIN_CLUSTER_POINTS: usize = 3;

/// Associations farther than this many association standard deviations from their
/// cluster's motion do not enter its solve (as CRF-Matching's groups).
pub const INLIER_SIGMAS: f64 = 2.0;

/// Most solve-and-trim iterations of one cluster's motion.
pub const TRIM_ITERATIONS: usize = 6;

/// Consecutive returns farther apart than this (m) lie on different surfaces for the
/// motion a return of the outlier cluster is associated under (0.5, segment-wise
/// ICP's gap; see [`JointModel`]).
pub const CARRIER_GAP: f64 = 0.5;

/// The joint CRF of one pair (see the module docs): a two-chain [`HybridChainModel`]
/// for the core's chain solver.
pub struct JointModel<'a> {
    tables: AssociationTables<'a>,
    weights: Vec<f64>,
    /// One motion per motion cluster (the outlier cluster has none).
    motions: Vec<Pose2>,
    /// The cluster whose motion the outlier cluster's returns are associated under
    /// when no return of their surface is in a motion cluster.
    background: usize,
    /// Surface (gap segment, [`CARRIER_GAP`]) of every node.
    surface: Vec<usize>,
    /// Each node's current association state and cluster.
    association: Vec<Option<usize>>,
    cluster: Vec<Option<usize>>,
    stats: RigidAlignment,
    /// Weight of the point-to-point term of the point-to-line refinement of the
    /// background cluster's motion solve (`None`: eq. 6 alone).
    point_to_line: Option<f64>,
}

impl std::fmt::Debug for JointModel<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JointModel")
            .field("tables", &self.tables)
            .field("motions", &self.motions)
            .finish()
    }
}

impl<'a> JointModel<'a> {
    /// The model over `problem` with `candidates` per node (reference indices,
    /// sorted), the motion clusters' starting `motions` (`D − 1` of them), the
    /// `background` cluster, the 30 `weights`, the geometric `band`, and each node's
    /// starting cluster `clusters` (for the outlier booster's motions; the solver is
    /// told the starting labels separately).
    ///
    /// # Panics
    /// If a starting cluster is out of range, or there are more than
    /// [`joint_clustering_features::MAX_MOTION_CLUSTERS`] motions.
    pub fn new(
        problem: &'a AssociationProblem,
        candidates: Vec<Vec<usize>>,
        motions: Vec<Pose2>,
        background: usize,
        weights: &[f64],
        band: usize,
        clusters: &[usize],
    ) -> Self {
        assert!(motions.len() <= joint_clustering_features::MAX_MOTION_CLUSTERS);
        let surface = segment_by_gap(&problem.current.points, CARRIER_GAP);
        let per_node = node_motions(problem, clusters, &motions, background);
        let tables = AssociationTables::new(problem, candidates, band, &per_node);
        let n = problem.len();
        Self {
            tables,
            weights: weights.to_vec(),
            motions,
            background,
            surface,
            association: vec![None; n],
            cluster: vec![None; n],
            stats: RigidAlignment::new(),
            point_to_line: Some(POINT_TO_POINT_WEIGHT),
        }
    }

    /// The same model with the point-to-line refinement of the background cluster's
    /// motion solve weighted `point_weight` (see [`crate::JointParams::point_to_line`];
    /// `None`: eq. 6 alone, as the paper).
    pub fn with_point_to_line(mut self, point_weight: Option<f64>) -> Self {
        self.point_to_line = point_weight;
        self
    }

    /// The model of the next round (new `candidates` and `motions`; the same problem,
    /// background, weights and band): the same model [`JointModel::new`] builds for
    /// the starting clusters whose [`node_motions`] are `per_node` (the caller has
    /// them already: it chose the candidates under them), with the data scores of the
    /// candidates both rounds share taken from this one
    /// ([`AssociationTables::next_round`]).
    ///
    /// # Panics
    /// As [`JointModel::new`], or if `per_node` does not have one motion per node.
    pub fn next_round(
        self,
        candidates: Vec<Vec<usize>>,
        motions: Vec<Pose2>,
        per_node: &[Pose2],
    ) -> Self {
        assert!(motions.len() <= joint_clustering_features::MAX_MOTION_CLUSTERS);
        let n = self.cluster.len();
        Self {
            tables: self.tables.next_round(candidates, per_node),
            weights: self.weights,
            motions,
            background: self.background,
            surface: self.surface,
            association: vec![None; n],
            cluster: vec![None; n],
            stats: RigidAlignment::new(),
            point_to_line: self.point_to_line,
        }
    }

    /// The motion cluster whose motion node `i`'s association features use (see
    /// [`JointModel`]'s docs on the outlier cluster).
    pub fn carrier_of(&self, i: usize) -> usize {
        carrier(
            &self.cluster,
            &self.surface,
            self.motions.len(),
            self.background,
            i,
        )
    }

    /// The same model with dense association pairwise tables.
    pub fn dense(mut self) -> Self {
        self.tables = self.tables.dense();
        self
    }

    /// The association tables.
    pub fn tables(&self) -> &AssociationTables<'a> {
        &self.tables
    }

    /// The motion clusters' current motions.
    pub fn motions(&self) -> &[Pose2] {
        &self.motions
    }

    /// Number of cluster states `D` (the motion clusters and the outlier cluster).
    pub fn clusters(&self) -> usize {
        self.motions.len() + 1
    }

    /// The motion node `i`'s association features use: its cluster's; for the
    /// outlier cluster (and before a cluster is known) the cluster of the nearest
    /// return on the same surface that is in a motion cluster, else the background's.
    fn node_motion(&self, i: usize) -> &Pose2 {
        &self.motions[self.carrier_of(i)]
    }

    /// Node `i`'s current partner (a reference point), if its association is not the
    /// outlier state.
    fn partner(&self, i: usize) -> Option<&nalgebra::Point2<f64>> {
        let j = self.association[i].and_then(|a| self.tables.partner(i, a))?;
        Some(&self.tables.problem().reference.surface[j])
    }

    /// Re-solves every motion cluster's motion from its returns' current associations
    /// (trimmed as CRF-Matching's groups); returns the largest change.
    pub fn solve_motions(&mut self) -> f64 {
        let mut change = 0.0f64;
        let mut pairs = Vec::new();
        for c in 0..self.motions.len() {
            let motion = self.fit_cluster(c, &mut pairs, None);
            let m = &mut self.motions[c];
            change = change
                .max(motion.translation_error(m))
                .max(motion.rotation_error(m));
            *m = motion;
        }
        change
    }

    /// Every motion cluster's motion solved once more from its returns' current
    /// associations, those of the clusters other than the background with a von
    /// Mises prior on the rotation centred on the background's rotation, of
    /// concentration `1/σ²` for `sigma` (rad; see [`RigidAlignment::solve_with_rotation_prior`]
    /// and [`crate::JointParams::object_rotation_sigma`]); the background's motion as it is.
    /// The model's motions are left unchanged.
    pub fn object_motions_with_prior(&mut self, sigma: f64) -> Vec<Pose2> {
        let prior = (self.motions[self.background].theta(), 1.0 / (sigma * sigma));
        let mut pairs = Vec::new();
        (0..self.motions.len())
            .map(|c| {
                if c == self.background {
                    self.motions[c]
                } else {
                    self.fit_cluster(c, &mut pairs, Some(prior))
                }
            })
            .collect()
    }

    /// Cluster `c`'s motion from its returns with a partner, trimmed: from its current
    /// motion, pairs farther than [`INLIER_SIGMAS`] association standard deviations
    /// leave and the rest are solved again (eq. 6, weights `1/σ²`), at most
    /// [`TRIM_ITERATIONS`] times; fewer than [`MIN_CLUSTER_POINTS`] pairs keep the
    /// motion; then, for the background cluster, the point-to-line refinement on the
    /// kept pairs ([`pgm_scan::alignment::fit_trimmed`]). `prior`: `(θ₀, κ)` of a
    /// rotation prior. `pairs` is scratch space.
    fn fit_cluster(
        &mut self,
        c: usize,
        pairs: &mut Vec<SurfacePair>,
        prior: Option<(f64, f64)>,
    ) -> Pose2 {
        let cluster = &self.cluster;
        self.tables
            .member_pairs(&self.association, |i| cluster[i] == Some(c), pairs);
        let limits = TrimmedFitParams {
            inlier_sigmas: INLIER_SIGMAS,
            iterations: TRIM_ITERATIONS,
            min_pairs: MIN_CLUSTER_POINTS,
            // The background's motion only (see `JointParams::point_to_line`).
            point_to_line: self.point_to_line.filter(|_| c == self.background),
        };
        fit_trimmed(pairs, self.motions[c], &limits, prior, &mut self.stats)
    }
}

impl HybridChainModel for JointModel<'_> {
    fn weights(&self) -> &[f64] {
        &self.weights
    }

    fn num_chains(&self) -> usize {
        2
    }

    fn chain_len(&self, _chain: usize) -> usize {
        self.cluster.len()
    }

    fn num_states(&self, chain: usize, i: usize) -> usize {
        if chain == ASSOCIATION_CHAIN {
            self.tables.states(i)
        } else {
            self.clusters()
        }
    }

    fn write_local<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S) {
        let p = self.tables.problem();
        if chain == ASSOCIATION_CHAIN {
            self.tables
                .write_local(i, self.node_motion(i), ASSOCIATION_BASE, sink);
        } else {
            joint_clustering_features::write_local(
                &p.current.surface[i],
                p.variances[i],
                self.partner(i),
                &self.motions,
                CLUSTERING_BASE,
                sink,
            );
        }
    }

    fn write_pair<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S) {
        if chain == ASSOCIATION_CHAIN {
            self.tables
                .write_pair(i, self.node_motion(i), ASSOCIATION_BASE, sink);
        } else {
            let p = self.tables.problem();
            joint_clustering_features::write_pair(
                [&p.current.surface[i], &p.current.surface[i + 1]],
                [self.partner(i), self.partner(i + 1)],
                &self.motions,
                CLUSTERING_BASE,
                sink,
            );
        }
    }

    fn set_label(&mut self, chain: usize, i: usize, _old: Option<usize>, new: usize) {
        if chain == ASSOCIATION_CHAIN {
            self.association[i] = Some(new);
        } else {
            self.cluster[i] = Some(new);
        }
    }

    fn pair_pattern(&self, chain: usize, _i: usize) -> Option<Arc<PairPattern>> {
        (chain == ASSOCIATION_CHAIN)
            .then(|| self.tables.pattern().cloned())
            .flatten()
    }

    fn solve(&mut self) -> f64 {
        self.solve_motions()
    }
}

/// The motion every node's association features use when the nodes are in
/// `clusters` (cluster indices; `motions.len()` or more is the outlier cluster): see
/// [`JointModel`] (a node of the outlier cluster takes the motion of the nearest
/// node on its surface in a motion cluster, else the `background`'s).
pub fn node_motions(
    problem: &AssociationProblem,
    clusters: &[usize],
    motions: &[Pose2],
    background: usize,
) -> Vec<Pose2> {
    let surface = segment_by_gap(&problem.current.points, CARRIER_GAP);
    let cluster: Vec<Option<usize>> = clusters.iter().map(|&c| Some(c)).collect();
    (0..clusters.len())
        .map(|i| motions[carrier(&cluster, &surface, motions.len(), background, i)])
        .collect()
}

/// The motion cluster node `i` is associated under: its own when it is a motion
/// cluster (index below `motions`), else that of the nearest node (by chain position,
/// the earlier one on a tie) on the same `surface` in a motion cluster, else
/// `background`.
fn carrier(
    cluster: &[Option<usize>],
    surface: &[usize],
    motions: usize,
    background: usize,
    i: usize,
) -> usize {
    let motion_cluster = |k: usize| cluster[k].filter(|&c| c < motions);
    if let Some(c) = motion_cluster(i) {
        return c;
    }
    let n = cluster.len();
    for d in 1..n {
        let before = i.checked_sub(d).filter(|&k| surface[k] == surface[i]);
        let after = Some(i + d).filter(|&k| k < n && surface[k] == surface[i]);
        if before.is_none() && after.is_none() {
            break;
        }
        if let Some(c) = before
            .and_then(motion_cluster)
            .or_else(|| after.and_then(motion_cluster))
        {
            return c;
        }
    }
    background
}
