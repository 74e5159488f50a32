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
use pgm_core::exact::PairPattern;
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
use std::sync::Arc;

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
    /// beam spacings of the moved point, sorted by reference index. (Candidates found
    /// by shape alone, the data booster's margin without the motion-dependent features
    /// within the segment search radius, were tried for the points of moving groups:
    /// no accuracy figure moved, and they cost a quarter of the run time.)
    pub fn candidates(
        &self,
        space: StateSpace,
        group_of: &[usize],
        motions: &[Pose2],
        gate: f64,
    ) -> Vec<Vec<usize>> {
        let n = self.len();
        let m = self.reference.len();
        match space {
            StateSpace::Full => vec![(0..m).collect(); n],
            StateSpace::Pruned(k) => {
                let increment = self.reference_increment;
                let mut found = Vec::new();
                (0..n)
                    .map(|i| {
                        let s = self.current.points[i];
                        let mut c: Vec<usize> = Vec::with_capacity(2 * k);
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
                        c.sort_unstable();
                        c.dedup();
                        c
                    })
                    .collect()
            }
        }
    }
}

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
    /// The pairwise sparsity pattern shared by every pair when every node has the
    /// same candidates `0..M` (the full state space): the band of reference steps
    /// with geometric features and the outlier row and column; `None`: dense tables.
    pattern: Option<Arc<PairPattern>>,
    /// Per entry of `pattern`: its transition feature and, within the band, the
    /// reference step `g_k − g_j` with its length.
    pattern_entries: Vec<PatternEntry>,
}

/// One listed entry of the full state space's pairwise pattern.
#[derive(Clone, Copy, Debug)]
struct PatternEntry {
    feature: usize,
    step: Option<(nalgebra::Vector2<f64>, f64)>,
}

impl std::fmt::Debug for MatchingModel<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MatchingModel")
            .field("nodes", &self.candidates.len())
            .field("motions", &self.motions)
            .finish()
    }
}

/// The pairwise pattern of the full state space over `m` reference returns: states
/// `0..m` (reference indices) and `m` (outlier); listed are the pairs `(j, k)` with
/// `|k − j − 1| ≤ band` (their geometric features are evaluated) and the outlier row
/// and column. Every other pair carries only `sequence.far`, the default entry.
pub fn band_pattern(m: usize, band: usize) -> PairPattern {
    let mut entries = Vec::with_capacity(m * (2 * band + 2) + m + 1);
    for j in 0..m {
        let lo = (j + 1).saturating_sub(band);
        let hi = (j + 1 + band).min(m - 1);
        entries.extend((lo..=hi).map(|k| (j, k)));
        entries.push((j, m));
    }
    entries.extend((0..=m).map(|k| (m, k)));
    PairPattern::new(m + 1, m + 1, &entries).expect("sorted entries within the table")
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
        let m = problem.reference.len();
        let full = candidates.iter().all(|c| c.len() == m);
        let pattern = full.then(|| Arc::new(band_pattern(m, band)));
        let pattern_entries = pattern.as_ref().map_or_else(Vec::new, |pattern| {
            let reference = &problem.reference.points;
            pattern
                .entries()
                .map(|(j, k)| {
                    if j == m || k == m {
                        let feature = match (j == m, k == m) {
                            (true, true) => index::OUTLIER_STAY,
                            (true, false) => index::OUTLIER_ENTER,
                            _ => index::OUTLIER_LEAVE,
                        };
                        return PatternEntry {
                            feature,
                            step: None,
                        };
                    }
                    let d = k as isize - j as isize;
                    let step = reference[k] - reference[j];
                    PatternEntry {
                        feature: sequence_feature(d, band as isize),
                        step: Some((step, step.norm())),
                    }
                })
                .collect()
        });
        Self {
            pattern_entries,
            problem,
            weights: weights.to_vec(),
            band,
            pattern,
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

    /// The same model with dense pairwise tables (no sparsity pattern): the reference
    /// the sparse full state space is tested against; `O(M²)` memory per pair.
    pub fn dense(mut self) -> Self {
        self.pattern = None;
        self.pattern_entries.clear();
        self
    }

    /// The pairwise sparsity pattern (the full state space), if any.
    pub fn pattern(&self) -> Option<&Arc<PairPattern>> {
        self.pattern.as_ref()
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

    /// Writes the features of the pair `(i, i + 1)`: entry `a · states(i + 1) + b` for
    /// states `a` and `b`, or, with a pairwise sparsity pattern
    /// ([`MatchingModel::pattern`], the full state space), the pattern's entries and
    /// then its default entry (the `sequence.far` transition of every unlisted pair;
    /// see [`HybridChainModel::write_pair`]).
    pub fn write_pair_features<S: FeatureSink>(&self, i: usize, sink: &mut S) {
        let p = self.problem;
        let (ci, cj) = (&self.candidates[i], &self.candidates[i + 1]);
        let (si, sj) = (p.current.points[i], p.current.points[i + 1]);
        let step = sj - si;
        let pair = PairGeometry {
            length: step.norm(),
            turned: self.motions[self.group_of[i]].isometry().rotation * step,
            inverse_variance: 1.0 / (p.variances[i] + p.variances[i + 1]),
            band: self.band as isize,
        };
        match &self.pattern {
            None => {
                let columns = cj.len() + 1;
                for a in 0..=ci.len() {
                    for b in 0..=cj.len() {
                        self.write_pair_entry(ci, cj, &pair, a, b, a * columns + b, sink);
                    }
                }
            }
            Some(pattern) => {
                // Every pair shares the pattern and its reference steps.
                for (entry, e) in self.pattern_entries.iter().enumerate() {
                    sink.add(entry, e.feature, 1.0);
                    if let Some((reference_step, norm)) = e.step {
                        let dd = (norm - pair.length).powi(2);
                        sink.add(entry, index::DISTANCE_SQUARED, dd);
                        sink.add(
                            entry,
                            index::DISTANCE_NORMALISED,
                            dd * pair.inverse_variance,
                        );
                        let dt = (reference_step - pair.turned).norm_squared();
                        sink.add(entry, index::TRANSLATION_SQUARED, dt);
                        sink.add(
                            entry,
                            index::TRANSLATION_NORMALISED,
                            dt * pair.inverse_variance,
                        );
                    }
                }
                sink.add(pattern.default_entry(), index::SEQUENCE_FAR, 1.0);
            }
        }
    }

    /// The features of states `a` (of `ci`, or the outlier state `ci.len()`) and `b`
    /// (of `cj`, or `cj.len()`) of a pair, into `entry`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn write_pair_entry<S: FeatureSink>(
        &self,
        ci: &[usize],
        cj: &[usize],
        pair: &PairGeometry,
        a: usize,
        b: usize,
        entry: usize,
        sink: &mut S,
    ) {
        let (outlier_a, outlier_b) = (a == ci.len(), b == cj.len());
        if outlier_a || outlier_b {
            let feature = match (outlier_a, outlier_b) {
                (true, true) => index::OUTLIER_STAY,
                (true, false) => index::OUTLIER_ENTER,
                _ => index::OUTLIER_LEAVE,
            };
            sink.add(entry, feature, 1.0);
            return;
        }
        let (j, k) = (ci[a], cj[b]);
        let d = k as isize - j as isize;
        sink.add(entry, sequence_feature(d, pair.band), 1.0);
        if (d - 1).abs() <= pair.band {
            let reference = &self.problem.reference.points;
            let reference_step = reference[k] - reference[j];
            let dd = (reference_step.norm() - pair.length).powi(2);
            sink.add(entry, index::DISTANCE_SQUARED, dd);
            sink.add(
                entry,
                index::DISTANCE_NORMALISED,
                dd * pair.inverse_variance,
            );
            let dt = (reference_step - pair.turned).norm_squared();
            sink.add(entry, index::TRANSLATION_SQUARED, dt);
            sink.add(
                entry,
                index::TRANSLATION_NORMALISED,
                dt * pair.inverse_variance,
            );
        }
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

/// The sequence feature of a reference index step `d = k − j` between consecutive
/// candidates.
fn sequence_feature(d: isize, band: isize) -> usize {
    match d {
        0 => index::SEQUENCE_SAME,
        1 => index::SEQUENCE_NEXT,
        2 => index::SEQUENCE_SKIP,
        -1 => index::SEQUENCE_BACK,
        _ if (d - 1).abs() <= band => index::SEQUENCE_NEAR,
        _ => index::SEQUENCE_FAR,
    }
}

/// What the features of one pair `(i, i + 1)` share.
struct PairGeometry {
    /// `‖s_{i+1} − s_i‖` (m).
    length: f64,
    /// `s_{i+1} − s_i` turned by the pair's motion.
    turned: nalgebra::Vector2<f64>,
    /// `1 / (σ_i² + σ_{i+1}²)`.
    inverse_variance: f64,
    /// [`MatchingModel`]'s band.
    band: isize,
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

    fn pair_pattern(&self, _chain: usize, _i: usize) -> Option<Arc<PairPattern>> {
        self.pattern.clone()
    }

    fn solve(&mut self) -> f64 {
        self.solve_motions()
    }
}
