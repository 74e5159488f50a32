//! The CRF of one scan pair: a chain over the current scan's returns in beam order
//! whose states are candidate partners in the reference scan plus an outlier state,
//! its features (written once for inference and learning), and its rigid-motion
//! continuous nodes.
//!
//! **States.** Node `i` (the `i`-th valid return of the current scan) has the states
//! `C_i ∪ {outlier}`: its candidate partners `C_i` (reference returns, by their index
//! among the reference scan's valid returns) and, last, the outlier state. With
//! [`StateSpace::Full`] every reference return is a candidate (the paper's `M + 1`
//! states); with [`StateSpace::Pruned`] only the `k` nearest to the point moved by its
//! current motion estimate (the paper's own proposal for speed).
//!
//! **Motions (`x^RT`).** Every point belongs to a motion *group*: group 0 moves with the
//! ego-motion, and each further group is a rigid piece of the scene with its own
//! motion (at inference the gap segments that segment-wise ICP found moved; in
//! learning the ground-truth objects). Each group's motion is the closed-form
//! weighted fit (eq. 6 of the joint paper, each pair weighted by `1 / σ_i²`) of its
//! points' current MAP associations, re-solved as inference runs (a group with fewer
//! than three associated points keeps its motion). The paper's CRF-Matching has one
//! motion; moving objects then keep no partner under it, and "its motion estimate"
//! (the paper's words for registered translation) is read here as the motion of the
//! point's group.
//!
//! **Features** (see [`crate::weights`] for the 18 weights): local — the data
//! booster's margin and the registered translation on candidate states, the outlier
//! booster's margin and a bias on the outlier state; pairwise — the reference index
//! step `j' − j` between consecutive candidates (sequence: a shifted identity and its
//! neighbours), inlier/outlier transitions, and, for steps within the band
//! ([`MatchingParams::band`](crate::MatchingParams::band)), the pairwise distance and
//! pairwise translation comparisons. Outside the band the two geometric features are
//! not evaluated (they would compare unrelated surfaces) and `sequence.far` carries the
//! transition: this keeps a pairwise table of the full state space sparse in
//! geometry, and it is the same model in both state spaces.

use crate::weights::{index, MatchingWeights};
use crate::Result;
use pgm_core::hybrid::chain::{FeatureSink, HybridChainModel};
use pgm_features::boosting::{Booster, StepFunction};
use pgm_features::clustering::association_variance;
use pgm_features::matching::{
    association_features, bearing_offset, outlier_features, ScanShape, ASSOCIATION_FEATURES,
    MOTION_FEATURES, OUTLIER_FEATURES,
};
use pgm_features::registration::Icp;
use pgm_features::{Pose2, RigidAlignment, Scan, ScanPair};
use std::cell::RefCell;

/// Which reference returns are states of a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StateSpace {
    /// Every reference return (`M + 1` states per node).
    Full,
    /// The `k` reference returns nearest to the point under its motion estimate (and,
    /// for a point of a moving group, the `k / 2` nearest under the ego-motion).
    Pruned(usize),
}

/// Everything about a pair that does not change during inference: both scans' shapes,
/// the reference scan's search structure and the boosters split for fast refreshes.
pub struct MatchingProblem {
    /// The current scan's valid returns and shape descriptors.
    pub current: ScanShape,
    /// The reference scan's valid returns and shape descriptors.
    pub reference: ScanShape,
    /// The reference scan (for visibility in the outlier features).
    pub reference_scan: Scan,
    /// Nearest-neighbour search over the reference returns.
    pub search: Icp,
    /// Association variance `σ_i²` (m²) of every current return.
    pub variances: Vec<f64>,
    /// Valid-return index of every reference beam (`None` without a return).
    pub reference_index: Vec<Option<usize>>,
    /// The reference scan's angle between beams (rad).
    pub reference_increment: f64,
    data_rest: Booster,
    /// Step functions of the data booster on registered translation and bearing.
    data_steps: Vec<StepFunction>,
    outlier: Booster,
}

impl std::fmt::Debug for MatchingProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MatchingProblem")
            .field("current", &self.current.len())
            .field("reference", &self.reference.len())
            .finish()
    }
}

impl MatchingProblem {
    /// The problem of `pair` with the boosters of `weights`.
    ///
    /// # Errors
    /// When the reference scan has no valid return (the error names the pair).
    pub fn new(pair: &ScanPair, weights: &MatchingWeights) -> Result<Self> {
        let current = ScanShape::new(&pair.current);
        let reference = ScanShape::new(&pair.reference);
        let search =
            Icp::new(&pair.reference, Default::default()).map_err(|e| e.in_pair(&pair.name))?;
        let increment = pair.current.angle_increment();
        let variances = current
            .points
            .iter()
            .map(|p| association_variance(p.coords.norm(), increment))
            .collect();
        let mut reference_index = vec![None; pair.reference.len()];
        for (i, &b) in reference.beams.iter().enumerate() {
            reference_index[b] = Some(i);
        }
        let (data_rest, data_steps) = weights.data.split_by_features(&MOTION_FEATURES);
        Ok(Self {
            current,
            reference,
            reference_increment: pair.reference.angle_increment(),
            reference_scan: pair.reference.clone(),
            search,
            variances,
            reference_index,
            data_rest,
            data_steps,
            outlier: weights.outlier.clone(),
        })
    }

    /// Number of current returns (nodes).
    pub fn len(&self) -> usize {
        self.current.len()
    }

    /// True without current returns.
    pub fn is_empty(&self) -> bool {
        self.current.is_empty()
    }

    /// The candidates of every node under `motions` (group motions) and `group_of`
    /// (each node's group; group 0 is the ego-motion), within `gate` metres plus three
    /// beam spacings of the moved point, sorted by reference index. With `shape`
    /// `(radius, count)`, a node of a moving group (group ≠ 0) also gets the `count`
    /// reference returns within `radius` metres of where the ego-motion puts it whose
    /// shape matches best (the data booster's margin without the motion-dependent
    /// features): a moving object's partners are found by their shape even when its
    /// motion hypothesis is wrong.
    pub fn candidates(
        &self,
        space: StateSpace,
        group_of: &[usize],
        motions: &[Pose2],
        gate: f64,
        shape: Option<(f64, usize)>,
    ) -> Vec<Vec<usize>> {
        let n = self.len();
        let m = self.reference.len();
        match space {
            StateSpace::Full => vec![(0..m).collect(); n],
            StateSpace::Pruned(k) => {
                let increment = self.reference_increment;
                let mut found = Vec::new();
                let mut scored = Vec::new();
                let mut features = [0.0; ASSOCIATION_FEATURES];
                (0..n)
                    .map(|i| {
                        let s = self.current.points[i];
                        let mut c: Vec<usize> = Vec::with_capacity(3 * k);
                        let g = group_of[i];
                        for (motion, count) in [(motions[g], k), (motions[0], k / 2)] {
                            let q = motion.transform_point(&s);
                            let reach = gate + 3.0 * q.coords.norm() * increment;
                            self.search
                                .k_nearest_references(&q, count, reach, &mut found);
                            c.extend(found.iter().filter_map(|&(b, _)| self.reference_index[b]));
                            if g == 0 {
                                break;
                            }
                        }
                        if let (Some((radius, count)), true) = (shape, g != 0) {
                            let q = motions[0].transform_point(&s);
                            self.search.k_nearest_references(
                                &q,
                                SHAPE_SEARCH_LIMIT,
                                radius,
                                &mut found,
                            );
                            scored.clear();
                            for &(b, _) in &found {
                                let Some(j) = self.reference_index[b] else {
                                    continue;
                                };
                                association_features(
                                    &self.current,
                                    i,
                                    &self.reference,
                                    j,
                                    &Pose2::identity(),
                                    increment,
                                    &mut features,
                                );
                                scored.push((self.data_rest.score(&features), j));
                            }
                            let take = count.min(scored.len());
                            if take > 0 {
                                scored.select_nth_unstable_by(take - 1, |a, b| b.0.total_cmp(&a.0));
                                c.extend(scored[..take].iter().map(|x| x.1));
                            }
                        }
                        c.sort_unstable();
                        c.dedup();
                        c
                    })
                    .collect()
            }
        }
    }
}

/// Most reference returns a shape search of [`MatchingProblem::candidates`] scores.
pub const SHAPE_SEARCH_LIMIT: usize = 160;

/// The motion-dependent values of the local features, refreshed when the motions
/// change (see [`MatchingModel`]).
#[derive(Clone, Debug, Default)]
struct LocalCache {
    /// Motion version each node's values were computed for.
    version: Vec<u64>,
    /// Registered distance `‖M s_i − g_j‖` per candidate (flat, by candidate offset).
    distance: Vec<f64>,
    /// The motion-dependent part of the data booster's margin per candidate.
    score: Vec<f64>,
    /// Outlier booster margin per node.
    outlier: Vec<f64>,
}

/// The CRF of one pair with its motion groups (see the module docs): a
/// [`HybridChainModel`] for the core's chain solver.
pub struct MatchingModel<'a> {
    problem: &'a MatchingProblem,
    weights: Vec<f64>,
    band: usize,
    candidates: Vec<Vec<usize>>,
    /// Where each node's candidates start in the flat per-candidate arrays.
    offsets: Vec<usize>,
    /// Motion-independent part of the data booster's margin, per candidate.
    data_rest: Vec<f64>,
    group_of: Vec<usize>,
    motions: Vec<Pose2>,
    stats: Vec<RigidAlignment>,
    /// Each node's current state (as the solver last told).
    labels: Vec<Option<usize>>,
    version: u64,
    cache: RefCell<LocalCache>,
}

impl std::fmt::Debug for MatchingModel<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MatchingModel")
            .field("nodes", &self.candidates.len())
            .field("motions", &self.motions)
            .finish()
    }
}

/// Fewest associated points a motion group is solved from; fewer keep its motion.
pub const MIN_GROUP_POINTS: usize = 3;

impl<'a> MatchingModel<'a> {
    /// The model over `problem` with `candidates` per node (reference indices),
    /// `group_of` each node's motion group, the groups' starting `motions`, the 18
    /// `weights` and the geometric `band`.
    pub fn new(
        problem: &'a MatchingProblem,
        candidates: Vec<Vec<usize>>,
        group_of: Vec<usize>,
        motions: Vec<Pose2>,
        weights: &[f64],
        band: usize,
    ) -> Self {
        let mut offsets = Vec::with_capacity(candidates.len() + 1);
        let mut total = 0;
        for c in &candidates {
            offsets.push(total);
            total += c.len();
        }
        offsets.push(total);
        let mut data_rest = Vec::with_capacity(total);
        let mut features = [0.0; ASSOCIATION_FEATURES];
        for (i, c) in candidates.iter().enumerate() {
            for &j in c {
                // The registered translation is scored by the step function later.
                association_features(
                    &problem.current,
                    i,
                    &problem.reference,
                    j,
                    &Pose2::identity(),
                    problem.reference_increment,
                    &mut features,
                );
                data_rest.push(problem.data_rest.score(&features));
            }
        }
        let n = candidates.len();
        // The outlier features under the round's starting motions (see
        // `write_local_features`).
        let mut f = [0.0; OUTLIER_FEATURES];
        let outlier: Vec<f64> = (0..n)
            .map(|i| {
                outlier_features(
                    &problem.current,
                    i,
                    &problem.reference_scan,
                    problem.reference_increment,
                    &problem.search,
                    &motions[group_of[i]],
                    &mut f,
                );
                problem.outlier.score(&f)
            })
            .collect();
        Self {
            problem,
            weights: weights.to_vec(),
            band,
            candidates,
            offsets,
            data_rest,
            group_of,
            stats: vec![RigidAlignment::new(); motions.len()],
            labels: vec![None; n],
            motions,
            version: 1,
            cache: RefCell::new(LocalCache {
                version: vec![0; n],
                distance: vec![0.0; total],
                score: vec![0.0; total],
                outlier,
            }),
        }
    }

    /// The current motion of every group (group 0: the ego-motion).
    pub fn motions(&self) -> &[Pose2] {
        &self.motions
    }

    /// The candidates of every node.
    pub fn candidates(&self) -> &[Vec<usize>] {
        &self.candidates
    }

    /// Number of states of node `i` (its candidates and the outlier state).
    pub fn states(&self, i: usize) -> usize {
        self.candidates[i].len() + 1
    }

    /// The state of node `i` that is candidate `j` (a reference index), if any.
    pub fn state_of(&self, i: usize, j: usize) -> Option<usize> {
        self.candidates[i].binary_search(&j).ok()
    }

    /// Brings node `i`'s motion-dependent values up to date.
    fn refresh(&self, i: usize) {
        let mut cache = self.cache.borrow_mut();
        if cache.version[i] == self.version {
            return;
        }
        cache.version[i] = self.version;
        let p = self.problem;
        let motion = self.motions[self.group_of[i]];
        let q = motion.transform_point(&p.current.points[i]);
        let o = self.offsets[i];
        let q_bearing = q.y.atan2(q.x);
        for (k, &j) in self.candidates[i].iter().enumerate() {
            let d = (q - p.reference.points[j]).norm();
            let bearing = bearing_offset(q_bearing, p.reference.angles[j], p.reference_increment);
            cache.distance[o + k] = d;
            cache.score[o + k] = p.data_steps[0].eval(d) + p.data_steps[1].eval(bearing);
        }
    }

    /// Writes the local features of node `i` (see the module docs). The outlier
    /// booster's margin is the one under the motions the model was built with (a
    /// round's starting motions; [`crate::Matcher`] builds a new model each round):
    /// its features (nearest return, visibility) change little while a round refines
    /// the motions, and re-evaluating them every sweep lets returns at the edge flip
    /// between partner and outlier as the motions creep.
    pub fn write_local_features<S: FeatureSink>(&self, i: usize, sink: &mut S) {
        self.refresh(i);
        let cache = self.cache.borrow();
        let o = self.offsets[i];
        let inverse_variance = 1.0 / self.problem.variances[i];
        for k in 0..self.candidates[i].len() {
            let d = cache.distance[o + k];
            let score = self.data_rest[o + k] + cache.score[o + k];
            sink.add(k, index::DATA_SCORE, score);
            let d2 = d * d;
            sink.add(k, index::REGISTERED_SQUARED, d2);
            sink.add(k, index::REGISTERED_NORMALISED, d2 * inverse_variance);
        }
        let out = self.candidates[i].len();
        sink.add(out, index::OUTLIER_SCORE, cache.outlier[i]);
        sink.add(out, index::OUTLIER_BIAS, 1.0);
    }

    /// Writes the features of the pair `(i, i + 1)` (entry `a · states(i + 1) + b`).
    pub fn write_pair_features<S: FeatureSink>(&self, i: usize, sink: &mut S) {
        let p = self.problem;
        let (ci, cj) = (&self.candidates[i], &self.candidates[i + 1]);
        let columns = cj.len() + 1;
        let (si, sj) = (p.current.points[i], p.current.points[i + 1]);
        let step = sj - si;
        let length = step.norm();
        let rotation = self.motions[self.group_of[i]].isometry().rotation;
        let turned = rotation * step;
        let inverse_variance = 1.0 / (p.variances[i] + p.variances[i + 1]);
        let band = self.band as isize;
        for (a, &j) in ci.iter().enumerate() {
            let gj = p.reference.points[j];
            let row = a * columns;
            for (b, &k) in cj.iter().enumerate() {
                let d = k as isize - j as isize;
                let feature = match d {
                    0 => index::SEQUENCE_SAME,
                    1 => index::SEQUENCE_NEXT,
                    2 => index::SEQUENCE_SKIP,
                    -1 => index::SEQUENCE_BACK,
                    _ if (d - 1).abs() <= band => index::SEQUENCE_NEAR,
                    _ => index::SEQUENCE_FAR,
                };
                sink.add(row + b, feature, 1.0);
                if (d - 1).abs() <= band {
                    let gk = p.reference.points[k];
                    let reference_step = gk - gj;
                    let dd = (reference_step.norm() - length).powi(2);
                    sink.add(row + b, index::DISTANCE_SQUARED, dd);
                    sink.add(row + b, index::DISTANCE_NORMALISED, dd * inverse_variance);
                    let dt = (reference_step - turned).norm_squared();
                    sink.add(row + b, index::TRANSLATION_SQUARED, dt);
                    sink.add(
                        row + b,
                        index::TRANSLATION_NORMALISED,
                        dt * inverse_variance,
                    );
                }
            }
            sink.add(row + cj.len(), index::OUTLIER_LEAVE, 1.0);
        }
        let row = ci.len() * columns;
        for b in 0..cj.len() {
            sink.add(row + b, index::OUTLIER_ENTER, 1.0);
        }
        sink.add(row + cj.len(), index::OUTLIER_STAY, 1.0);
    }

    /// Records node `i`'s new state (the statistics are rebuilt at each solve).
    fn relabel(&mut self, i: usize, new: usize) {
        self.labels[i] = Some(new);
    }

    /// Re-solves every group's motion (eq. 6) from its nodes' current associations,
    /// each pair weighted by `1 / σ_i²`, keeping only the pairs that lie within
    /// [`INLIER_SIGMAS`] association standard deviations of the group's motion (trim
    /// and solve until no pair is dropped, at most [`TRIM_ITERATIONS`] times; a
    /// dropped pair is not re-admitted within one solve, so the iteration cannot
    /// cycle), like ICP's shrinking correspondence distance: a MAP
    /// association the CRF prefers to the outlier state but that the motion cannot
    /// explain (an unmodelled mover, a wrong partner) does not pull the motion. A
    /// group with fewer than [`MIN_GROUP_POINTS`] kept pairs keeps its motion. Returns
    /// the largest change.
    pub fn solve_motions(&mut self) -> f64 {
        let p = self.problem;
        let mut change = 0.0f64;
        let mut pairs = Vec::new();
        for g in 0..self.motions.len() {
            // The group's associated pairs (current point, reference point, σ²).
            pairs.clear();
            for i in 0..self.labels.len() {
                if self.group_of[i] != g {
                    continue;
                }
                if let Some(j) = self.labels[i].and_then(|l| self.candidates[i].get(l)) {
                    pairs.push((p.current.points[i], p.reference.points[*j], p.variances[i]));
                }
            }
            let mut motion = self.motions[g];
            for round in 0..TRIM_ITERATIONS {
                // Trim: drop the pairs the motion cannot explain (never re-admitted, so
                // the iteration cannot cycle).
                let before = pairs.len();
                pairs.retain(|(s, gp, var)| {
                    (motion.transform_point(s) - gp).norm_squared()
                        <= INLIER_SIGMAS * INLIER_SIGMAS * var
                });
                if pairs.len() < MIN_GROUP_POINTS || (round > 0 && pairs.len() == before) {
                    break;
                }
                let stats = &mut self.stats[g];
                stats.clear();
                for (s, gp, var) in &pairs {
                    stats.add(s, gp, 1.0 / var);
                }
                if let Some(a) = stats.solve() {
                    motion = a.motion;
                }
            }
            let m = &mut self.motions[g];
            change = change
                .max(motion.translation_error(m))
                .max(motion.rotation_error(m));
            *m = motion;
        }
        if change != 0.0 {
            self.version += 1;
        }
        change
    }
}

/// Associations farther than this many association standard deviations `σ_i` from
/// their group's motion do not enter its solve (see [`MatchingModel::solve_motions`]).
pub const INLIER_SIGMAS: f64 = 2.0;

/// Most solve-and-trim iterations of one group's motion in
/// [`MatchingModel::solve_motions`]; they stop earlier once no pair is dropped.
pub const TRIM_ITERATIONS: usize = 6;

impl HybridChainModel for MatchingModel<'_> {
    fn weights(&self) -> &[f64] {
        &self.weights
    }

    fn num_chains(&self) -> usize {
        1
    }

    fn chain_len(&self, _chain: usize) -> usize {
        self.candidates.len()
    }

    fn num_states(&self, _chain: usize, i: usize) -> usize {
        self.states(i)
    }

    fn write_local<S: FeatureSink>(&self, _chain: usize, i: usize, sink: &mut S) {
        self.write_local_features(i, sink);
    }

    fn write_pair<S: FeatureSink>(&self, _chain: usize, i: usize, sink: &mut S) {
        self.write_pair_features(i, sink);
    }

    fn set_label(&mut self, _chain: usize, i: usize, _old: Option<usize>, new: usize) {
        self.relabel(i, new);
    }

    fn solve(&mut self) -> f64 {
        self.solve_motions()
    }
}
