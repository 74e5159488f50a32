//! The association chain of CRF-Matching and of the joint model (section IV-C.1-2 of
//! van de Ven, Ramos and Tipaldi): a chain over the current scan's returns in beam
//! order whose states are candidate partners in the reference scan plus an outlier
//! state, with its 18 named features written through the core's
//! [`FeatureSink`]. Both models compose it: in
//! CRF-Matching a return's motion is its motion group's, in the joint model its
//! cluster's.
//!
//! **States.** Node `i` (the `i`-th valid return of the current scan) has the states
//! `C_i ∪ {outlier}`: its candidate partners `C_i` (reference returns, by their index
//! among the reference scan's valid returns, sorted) and, last, the outlier state.
//! With [`StateSpace::Full`] every reference return is a candidate (the paper's `M +
//! 1` states); with [`StateSpace::Pruned`] only the `k` nearest to the point moved by
//! its current motion estimate (the paper's own proposal for speed).
//!
//! **Features** (weight indices in [`index`], relative to a base so that a model can
//! place them among its own; names in [`ASSOCIATION_TEMPLATES`]):
//!
//! | template | weights | feature (of states `a` at point `i`, `b` at point `i + 1`) |
//! |---|---|---|
//! | `data_boosting` | `score` | the data booster's margin `F_d(i, j)` on candidate states `j` |
//! | `outlier_boosting` | `score`, `bias` | the outlier booster's margin `F_o(i)`, and 1, on the outlier state |
//! | `registered_translation` | `squared`, `normalised` | `‖M s_i − g_j‖²` (m²) and the same over the association variance `σ_i²` |
//! | `sequence` | `same`, `next`, `skip`, `back`, `near`, `far` | inlier → inlier transitions by the reference index step `j' − j`: 0, 1, 2, −1, another step within the band, outside the band |
//! | `pairwise_outlier` | `leave`, `enter`, `stay` | inlier → outlier, outlier → inlier, outlier → outlier |
//! | `pairwise_distance` | `squared`, `normalised` | `(‖g_j' − g_j‖ − ‖s_{i+1} − s_i‖)²` within the band, and over `σ_i² + σ_{i+1}²` |
//! | `pairwise_translation` | `squared`, `normalised` | `‖(g_j' − g_j) − R(s_{i+1} − s_i)‖²` within the band, and over `σ_i² + σ_{i+1}²` |
//!
//! `M` is node `i`'s motion and `R` its rotation. Outside the band the two geometric
//! pairwise features are not evaluated (they would compare unrelated surfaces) and
//! `sequence.far` carries the transition: a pairwise table of the full state space is
//! then sparse in geometry ([`band_pattern`]), the same model in both state spaces.
//!
//! The outlier booster's margin is evaluated once, under the motions the tables are
//! built with ([`AssociationTables::new`]): its features (nearest return, visibility)
//! change little while inference refines the motions, and re-evaluating them every
//! sweep lets returns at the edge flip between partner and outlier as the motions
//! creep. The data booster's motion-dependent stumps (registered translation and
//! bearing) are re-evaluated whenever a node's motion changes.

use crate::boosting::{Booster, StepFunction, TrainingSet};
use crate::clustering_features::association_variance;
use crate::shape_features::{
    association_features, bearing_offset, outlier_features, ScanShape, ASSOCIATION_FEATURES,
    MOTION_FEATURES, OUTLIER_FEATURES,
};
use pgm_core::hybrid::chain::FeatureSink;
use pgm_core::hybrid::PairPattern;
use pgm_scan::registration::Icp;
use pgm_scan::{Association, Error, InvalidParameter, Pose2, Result, Scan, ScanPair};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::sync::Arc;

/// Index of each association weight, relative to the model's base index for them.
pub mod index {
    /// `data_boosting.score`.
    pub const DATA_SCORE: usize = 0;
    /// `outlier_boosting.score`.
    pub const OUTLIER_SCORE: usize = 1;
    /// `outlier_boosting.bias`.
    pub const OUTLIER_BIAS: usize = 2;
    /// `registered_translation.squared`.
    pub const REGISTERED_SQUARED: usize = 3;
    /// `registered_translation.normalised`.
    pub const REGISTERED_NORMALISED: usize = 4;
    /// `sequence.same`.
    pub const SEQUENCE_SAME: usize = 5;
    /// `sequence.next`.
    pub const SEQUENCE_NEXT: usize = 6;
    /// `sequence.skip`.
    pub const SEQUENCE_SKIP: usize = 7;
    /// `sequence.back`.
    pub const SEQUENCE_BACK: usize = 8;
    /// `sequence.near`.
    pub const SEQUENCE_NEAR: usize = 9;
    /// `sequence.far`.
    pub const SEQUENCE_FAR: usize = 10;
    /// `pairwise_outlier.leave`.
    pub const OUTLIER_LEAVE: usize = 11;
    /// `pairwise_outlier.enter`.
    pub const OUTLIER_ENTER: usize = 12;
    /// `pairwise_outlier.stay`.
    pub const OUTLIER_STAY: usize = 13;
    /// `pairwise_distance.squared`.
    pub const DISTANCE_SQUARED: usize = 14;
    /// `pairwise_distance.normalised`.
    pub const DISTANCE_NORMALISED: usize = 15;
    /// `pairwise_translation.squared`.
    pub const TRANSLATION_SQUARED: usize = 16;
    /// `pairwise_translation.normalised`.
    pub const TRANSLATION_NORMALISED: usize = 17;
}

/// Number of association weights.
pub const ASSOCIATION_WEIGHTS: usize = 18;

/// The association feature templates and their features, in [`index`] order (for a
/// model's [`FeatureSet`](pgm_core::learning::FeatureSet)).
pub const ASSOCIATION_TEMPLATES: [(&str, &[&str]); 7] = [
    ("data_boosting", &["score"]),
    ("outlier_boosting", &["score", "bias"]),
    ("registered_translation", &["squared", "normalised"]),
    ("sequence", &["same", "next", "skip", "back", "near", "far"]),
    ("pairwise_outlier", &["leave", "enter", "stay"]),
    ("pairwise_distance", &["squared", "normalised"]),
    ("pairwise_translation", &["squared", "normalised"]),
];

/// The two boosters of the association chain's local features: the data booster over
/// [`ASSOCIATION_FEATURES`] values of a (return, candidate) pair and the outlier
/// booster over [`OUTLIER_FEATURES`] values of a return.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AssociationBoosters {
    /// The data booster ("is `j` the partner of `i`?").
    pub data: Booster,
    /// The outlier booster ("is `i` an outlier?").
    pub outlier: Booster,
}

impl AssociationBoosters {
    /// Boosters without stumps (every margin 0): the starting point of training.
    pub fn untrained() -> Self {
        let empty = |features| Booster {
            features,
            stumps: Vec::new(),
        };
        Self {
            data: empty(ASSOCIATION_FEATURES),
            outlier: empty(OUTLIER_FEATURES),
        }
    }

    /// Checks that each booster reads the right number of features and has finite
    /// stumps.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the booster.
    pub fn check_ref(&self) -> Result<()> {
        for (name, booster, features) in [
            ("data booster", &self.data, ASSOCIATION_FEATURES),
            ("outlier booster", &self.outlier, OUTLIER_FEATURES),
        ] {
            if booster.features != features
                || booster
                    .stumps
                    .iter()
                    .any(|s| s.feature >= features || !s.alpha.is_finite() || s.threshold.is_nan())
            {
                return Err(InvalidParameter::new(
                    name,
                    format!(
                        "{} features, {} stumps",
                        booster.features,
                        booster.stumps.len()
                    ),
                    "a booster over the model's features with finite stumps",
                )
                .into());
            }
        }
        Ok(())
    }
}

/// Which reference returns are states of a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StateSpace {
    /// Every reference return (`M + 1` states per node).
    Full,
    /// The `k` reference returns nearest to the point under its motion estimate (and,
    /// for a point whose motion is not the ego-motion, the `k / 2` nearest under the
    /// ego-motion).
    Pruned(usize),
}
/// Everything about a pair that does not change during inference: both scans' shapes,
/// the reference scan's search structure and the boosters split for fast refreshes.
pub struct AssociationProblem {
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

impl std::fmt::Debug for AssociationProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AssociationProblem")
            .field("current", &self.current.len())
            .field("reference", &self.reference.len())
            .finish()
    }
}

impl AssociationProblem {
    /// The problem of `pair` with `boosters`.
    ///
    /// # Errors
    /// When the reference scan has no valid return (the error names the pair).
    pub fn new(pair: &ScanPair, boosters: &AssociationBoosters) -> Result<Self> {
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
        let (data_rest, data_steps) = boosters.data.split_by_features(&MOTION_FEATURES);
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
            outlier: boosters.outlier.clone(),
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

    /// The pair of current return `i` and reference return `j` (indices among the
    /// valid returns) for a motion solve ([`pgm_scan::alignment::fit_trimmed`]): their
    /// surface points, the partner's surface normal and the association variance of
    /// `i`.
    pub fn surface_pair(&self, i: usize, j: usize) -> pgm_scan::SurfacePair {
        pgm_scan::SurfacePair {
            source: self.current.surface[i],
            target: self.reference.surface[j],
            normal: self.reference.normals[j],
            variance: self.variances[i],
        }
    }

    /// The candidates of every node, sorted by reference index: with
    /// [`StateSpace::Pruned`]`(k)`, the `k` reference returns nearest to the point
    /// moved by `motions[i]` and, where `ego[i]` differs, the `k / 2` nearest under
    /// `ego[i]`, each within `gate` metres plus three beam spacings of the moved
    /// point. (Candidates found by shape alone, the data booster's margin without the
    /// motion-dependent features within the segment search radius, were tried for
    /// moving points: no accuracy figure moved, and they cost a quarter of the run
    /// time.)
    ///
    /// # Panics
    /// If `motions` or `ego` has fewer entries than the problem has nodes.
    pub fn candidates(
        &self,
        space: StateSpace,
        motions: &[Pose2],
        ego: &[Pose2],
        gate: f64,
    ) -> Vec<Vec<usize>> {
        let n = self.len();
        let m = self.reference.len();
        match space {
            StateSpace::Full => vec![(0..m).collect(); n],
            StateSpace::Pruned(k) => {
                let increment = self.reference_increment;
                let node = |found: &mut Vec<(usize, f64)>, i: usize| {
                    let s = self.current.points[i];
                    let mut c: Vec<usize> = Vec::with_capacity(2 * k);
                    let runs: &[(Pose2, usize)] = if motions[i] == ego[i] {
                        &[(motions[i], k)]
                    } else {
                        &[(motions[i], k), (ego[i], k / 2)]
                    };
                    for &(motion, count) in runs {
                        let q = motion.transform_point(&s);
                        let reach = gate + 3.0 * q.coords.norm() * increment;
                        self.search.k_nearest_references(&q, count, reach, found);
                        c.extend(found.iter().filter_map(|&(b, _)| self.reference_index[b]));
                    }
                    c.sort_unstable();
                    c.dedup();
                    c
                };
                // Node by node (side by side when rayon's pool has more than one
                // thread; see `parallel_nodes`).
                if parallel_nodes(n) {
                    (0..n)
                        .into_par_iter()
                        .with_min_len(PARALLEL_NODES)
                        .map_init(Vec::new, node)
                        .collect()
                } else {
                    let mut found = Vec::new();
                    (0..n).map(|i| node(&mut found, i)).collect()
                }
            }
        }
    }

    /// The ground truth of `pair`'s nodes, for learning: its ego-motion (ground truth,
    /// else the odometry prior), and per node its object label, its object's true
    /// motion and its true partner (see [`NodeTruth`]). `pair` must be the pair the
    /// problem was built from.
    ///
    /// # Errors
    /// [`Error::BadPair`] naming the pair when it has no ground truth, no true
    /// associations, or neither a true ego-motion nor odometry ("no ground-truth …
    /// to learn from").
    pub fn node_truth(&self, pair: &ScanPair) -> Result<NodeTruth> {
        let missing = |what: &str| Error::BadPair {
            pair: pair.name.clone(),
            problem: format!("no ground-truth {what} to learn from"),
        };
        let truth = pair.truth.as_ref().ok_or_else(|| missing("at all"))?;
        let associations = truth
            .associations
            .as_ref()
            .ok_or_else(|| missing("associations"))?;
        let ego = truth
            .ego_motion
            .or(pair.odometry)
            .ok_or_else(|| missing("ego-motion"))?;
        let beams = &self.current.beams;
        let labels: Vec<u32> = beams
            .iter()
            .map(|&b| {
                truth
                    .labels
                    .as_ref()
                    .and_then(|l| l.get(b).copied().flatten())
                    .unwrap_or(0)
            })
            .collect();
        let object_motions = labels
            .iter()
            .map(|&l| {
                truth
                    .motions
                    .iter()
                    .find(|m| m.label == l && l != 0)
                    .map(|m| m.motion)
            })
            .collect();
        let partners = beams
            .iter()
            .map(|&b| match associations.get(b).copied().flatten() {
                Some(Association::Point(r)) => self.reference_index.get(r).copied().flatten(),
                _ => None,
            })
            .collect();
        Ok(NodeTruth {
            ego,
            labels,
            object_motions,
            partners,
        })
    }

    /// The outlier booster's margin of node `i` under `motion`.
    pub fn outlier_score(&self, i: usize, motion: &Pose2) -> f64 {
        let mut f = [0.0; OUTLIER_FEATURES];
        outlier_features(
            &self.current,
            i,
            &self.reference_scan,
            self.reference_increment,
            &self.search,
            motion,
            &mut f,
        );
        self.outlier.score(&f)
    }

    /// The data-booster and outlier-booster samples of one labelled pair: node `i`
    /// under `motions[i]`, each of its `candidates[i]` a data sample (positive for
    /// state `states[i]`), and the node an outlier sample (positive when `states[i]`
    /// is the outlier state `candidates[i].len()`).
    ///
    /// # Errors
    /// Never with consistent inputs (the training sets' feature counts are fixed).
    pub fn booster_samples(
        &self,
        candidates: &[Vec<usize>],
        states: &[usize],
        motions: &[Pose2],
    ) -> Result<(TrainingSet, TrainingSet)> {
        let mut data = TrainingSet::new(ASSOCIATION_FEATURES);
        let mut outliers = TrainingSet::new(OUTLIER_FEATURES);
        let mut f = [0.0; ASSOCIATION_FEATURES];
        let mut o = [0.0; OUTLIER_FEATURES];
        for (i, c) in candidates.iter().enumerate() {
            for (k, &j) in c.iter().enumerate() {
                association_features(
                    &self.current,
                    i,
                    &self.reference,
                    j,
                    &motions[i],
                    self.reference_increment,
                    &mut f,
                );
                data.push(&f, k == states[i])?;
            }
            outlier_features(
                &self.current,
                i,
                &self.reference_scan,
                self.reference_increment,
                &self.search,
                &motions[i],
                &mut o,
            );
            outliers.push(&o, states[i] == c.len())?;
        }
        Ok((data, outliers))
    }
}

/// The pairwise pattern of the full state space over `m ≥ 1` reference returns:
/// states `0..m` (reference indices) and `m` (outlier); listed are the pairs `(j, k)`
/// with `|k − j − 1| ≤ band` (their geometric features are evaluated) and the outlier
/// row and column. Every other pair carries only `sequence.far`, the default entry.
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

/// The motion-dependent values of the local features, refreshed when a node's motion
/// changes.
#[derive(Clone, Debug, Default)]
struct LocalCache {
    /// The motion each node's values were computed for (`None`: never).
    motion: Vec<Option<Pose2>>,
    /// Registered distance `‖M s_i − g_j‖` per candidate (flat, by candidate offset).
    distance: Vec<f64>,
    /// The motion-dependent part of the data booster's margin per candidate.
    score: Vec<f64>,
}

/// The ground truth of a labelled pair's nodes ([`AssociationProblem::node_truth`]),
/// one entry per node (valid current return, beam order) in the per-node vectors.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeTruth {
    /// The pair's true ego-motion (the ground truth's, else the odometry prior).
    pub ego: Pose2,
    /// Each node's object label (0: the background, or no label).
    pub labels: Vec<u32>,
    /// Each node's object's true motion; `None` for the background and for a label
    /// the ground truth gives no motion.
    pub object_motions: Vec<Option<Pose2>>,
    /// Each node's true partner as a reference index (into the problem's reference
    /// returns); `None` for a true outlier (or a partner beam without a return).
    pub partners: Vec<Option<usize>>,
}

impl NodeTruth {
    /// Each node's true motion: its object's, else the ego-motion.
    pub fn motions(&self) -> Vec<Pose2> {
        self.object_motions
            .iter()
            .map(|m| m.unwrap_or(self.ego))
            .collect()
    }

    /// Inserts every node's true partner into its `candidates` (sorted reference
    /// indices, kept sorted) and returns each node's true state: the partner's
    /// position among the candidates, or the outlier state (the number of candidates)
    /// for a true outlier.
    ///
    /// # Panics
    /// If `candidates` does not have one entry per node.
    pub fn true_states(&self, candidates: &mut [Vec<usize>]) -> Vec<usize> {
        assert_eq!(candidates.len(), self.partners.len(), "candidates per node");
        candidates
            .iter_mut()
            .zip(&self.partners)
            .map(|(c, partner)| match partner {
                Some(j) => c.binary_search(j).unwrap_or_else(|at| {
                    c.insert(at, *j);
                    at
                }),
                None => c.len(),
            })
            .collect()
    }
}

/// Motion groups numbered by first appearance, as the learning of CRF-Matching and
/// of the joint model reads them from labels: group 0 is `first` (its key and
/// motion), and every other key becomes the next group where it first appears, with
/// the motion it appears with. Returns each item's group and every group's motion.
///
/// ```
/// use pgm_features::matching_features::groups_by_first_appearance;
/// use pgm_scan::Pose2;
///
/// let (a, b) = (Pose2::new(1.0, 0.0, 0.0), Pose2::new(2.0, 0.0, 0.0));
/// let (group_of, motions) = groups_by_first_appearance(
///     (0, Pose2::identity()),
///     [(5, a), (0, b), (5, b), (3, b)],
/// );
/// assert_eq!(group_of, [1, 0, 1, 2]);
/// assert_eq!(motions, [Pose2::identity(), a, b]);
/// ```
pub fn groups_by_first_appearance(
    first: (u32, Pose2),
    items: impl IntoIterator<Item = (u32, Pose2)>,
) -> (Vec<usize>, Vec<Pose2>) {
    let mut keys = vec![first.0];
    let mut motions = vec![first.1];
    let group_of = items
        .into_iter()
        .map(|(key, motion)| match keys.iter().position(|&k| k == key) {
            Some(g) => g,
            None => {
                keys.push(key);
                motions.push(motion);
                keys.len() - 1
            }
        })
        .collect();
    (group_of, motions)
}

/// Fewest nodes one rayon task takes in the node-wise loops (candidates, the data
/// booster's and the outlier booster's margins): smaller tasks cost more in
/// scheduling than they compute.
const PARALLEL_NODES: usize = 32;

/// Whether the node-wise loops over `n` nodes run on rayon's pool: only when it has
/// more than one thread and there are at least two tasks' worth of nodes. Handing a
/// loop to a pool of one thread costs a thread switch each time and gains nothing
/// (measured: the joint model's pruned bench 4.7 ms sequential, 5.1-5.3 ms through a
/// one-thread pool).
fn parallel_nodes(n: usize) -> bool {
    n >= 2 * PARALLEL_NODES && rayon::current_num_threads() > 1
}

/// The previous round's tables as [`AssociationTables::next_round`] reads them.
#[derive(Clone, Copy)]
struct Earlier<'s> {
    candidates: &'s [Vec<usize>],
    offsets: &'s [usize],
    margins: &'s [f64],
}

/// What the table build fills for one node: its index, its slice of the booster
/// margins and its outlier margin, and its candidates.
type NodeSlots<'s> = (usize, ((&'s mut [f64], &'s mut f64), &'s Vec<usize>));

/// One listed entry of the full state space's pairwise pattern.
#[derive(Clone, Copy, Debug)]
struct PatternEntry {
    feature: usize,
    step: Option<(nalgebra::Vector2<f64>, f64)>,
}

/// The association chain's tables over one [`AssociationProblem`] with fixed
/// candidates: writes every node's local features and every pair's features for the
/// motions a model gives it (see the module docs).
pub struct AssociationTables<'a> {
    problem: &'a AssociationProblem,
    band: usize,
    candidates: Vec<Vec<usize>>,
    /// Where each node's candidates start in the flat per-candidate arrays.
    offsets: Vec<usize>,
    /// Motion-independent part of the data booster's margin, per candidate.
    data_rest: Vec<f64>,
    /// Outlier booster margin per node (under the motions at construction).
    outlier: Vec<f64>,
    cache: RefCell<LocalCache>,
    /// The pairwise sparsity pattern shared by every pair when every node has the
    /// same candidates `0..M` (the full state space); `None`: dense tables.
    pattern: Option<Arc<PairPattern>>,
    /// Per entry of `pattern`: its transition feature and, within the band, the
    /// reference step `g_k − g_j` with its length.
    pattern_entries: Vec<PatternEntry>,
    /// Every reference step within the band, `g_k − g_j` with its length, at
    /// `j · (2·band + 1) + (k − j − 1 + band)` (they depend on the reference scan
    /// alone: computed once per problem and band, and handed on from round to round;
    /// unused slots past the scan's ends are zero).
    band_steps: Arc<Vec<(nalgebra::Vector2<f64>, f64)>>,
}

impl std::fmt::Debug for AssociationTables<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AssociationTables")
            .field("nodes", &self.candidates.len())
            .field("sparse", &self.pattern.is_some())
            .finish()
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
    /// The band.
    band: isize,
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

/// The pairwise-outlier feature of a transition touching the outlier state.
fn outlier_transition(from_outlier: bool, to_outlier: bool) -> usize {
    match (from_outlier, to_outlier) {
        (true, true) => index::OUTLIER_STAY,
        (true, false) => index::OUTLIER_ENTER,
        _ => index::OUTLIER_LEAVE,
    }
}

impl<'a> AssociationTables<'a> {
    /// The tables over `problem` with `candidates` per node (reference indices,
    /// sorted), the geometric `band`, and the outlier booster's margins evaluated
    /// under `outlier_motions` (one per node).
    ///
    /// # Panics
    /// If `candidates` or `outlier_motions` does not have one entry per node.
    pub fn new(
        problem: &'a AssociationProblem,
        candidates: Vec<Vec<usize>>,
        band: usize,
        outlier_motions: &[Pose2],
    ) -> Self {
        Self::build(problem, candidates, band, outlier_motions, None)
    }

    /// [`AssociationTables::new`] over the same problem and band as `self` (the
    /// tables of the previous round), with new `candidates` and `outlier_motions`:
    /// the motion-independent part of the data booster's margin is taken from `self`
    /// for every candidate both rounds share (it depends on the two returns alone),
    /// so a round costs only its new candidates. The tables are those
    /// [`AssociationTables::new`] builds, value for value.
    ///
    /// # Panics
    /// As [`AssociationTables::new`].
    pub fn next_round(self, candidates: Vec<Vec<usize>>, outlier_motions: &[Pose2]) -> Self {
        let (problem, band) = (self.problem, self.band);
        Self::build(problem, candidates, band, outlier_motions, Some(&self))
    }

    /// The reference steps within `band` of every reference return (see
    /// `band_steps`).
    fn band_steps(problem: &AssociationProblem, band: usize) -> Vec<(nalgebra::Vector2<f64>, f64)> {
        let reference = &problem.reference.surface;
        let m = reference.len();
        let width = 2 * band + 1;
        let mut steps = vec![(nalgebra::Vector2::zeros(), 0.0); m * width];
        for j in 0..m {
            for slot in 0..width {
                // k − j − 1 + band = slot.
                let Some(k) = (j + 1 + slot).checked_sub(band).filter(|&k| k < m) else {
                    continue;
                };
                let step = reference[k] - reference[j];
                steps[j * width + slot] = (step, step.norm());
            }
        }
        steps
    }

    fn build(
        problem: &'a AssociationProblem,
        candidates: Vec<Vec<usize>>,
        band: usize,
        outlier_motions: &[Pose2],
        previous: Option<&Self>,
    ) -> Self {
        let n = problem.len();
        assert_eq!(candidates.len(), n, "candidates of {n} nodes");
        assert_eq!(outlier_motions.len(), n, "outlier motions of {n} nodes");
        let mut offsets = Vec::with_capacity(n + 1);
        let mut total = 0;
        for c in &candidates {
            offsets.push(total);
            total += c.len();
        }
        offsets.push(total);
        // The previous round's tables, to take the margins of shared candidates from:
        // each node's candidates, where they start in the flat arrays, and the margins.
        let earlier = previous.map(|p| Earlier {
            candidates: &p.candidates,
            offsets: &p.offsets,
            margins: &p.data_rest,
        });
        // Every node's margins into its own slice of the flat array, and its outlier
        // margin (the nodes are independent: side by side on rayon's pool when it has
        // more than one thread; see `parallel_nodes`).
        let mut data_rest = vec![0.0; total];
        let mut outlier = vec![0.0; n];
        let mut slices: Vec<&mut [f64]> = Vec::with_capacity(n);
        let mut rest = &mut data_rest[..];
        for c in &candidates {
            let (node, tail) = rest.split_at_mut(c.len());
            slices.push(node);
            rest = tail;
        }
        let fill = |(i, ((margins, outlier), c)): NodeSlots| {
            *outlier = problem.outlier_score(i, &outlier_motions[i]);
            let mut features = [0.0; ASSOCIATION_FEATURES];
            // The previous round's candidates of node `i` (sorted, as these).
            let mut known = earlier.map_or(&[][..], |p| &p.candidates[i][..]);
            let known_offset = earlier.map_or(0, |p| p.offsets[i]);
            let mut skipped = 0;
            for (slot, &j) in margins.iter_mut().zip(c) {
                // Both lists are sorted: walk the previous one along.
                while let Some((&first, rest)) = known.split_first() {
                    if first >= j {
                        break;
                    }
                    known = rest;
                    skipped += 1;
                }
                if let (Some(&first), Some(p)) = (known.first(), earlier) {
                    if first == j {
                        *slot = p.margins[known_offset + skipped];
                        continue;
                    }
                }
                // The registered features are scored by the step functions later.
                association_features(
                    &problem.current,
                    i,
                    &problem.reference,
                    j,
                    &Pose2::identity(),
                    problem.reference_increment,
                    &mut features,
                );
                *slot = problem.data_rest.score(&features);
            }
        };
        if parallel_nodes(n) {
            slices
                .into_par_iter()
                .zip(outlier.par_iter_mut())
                .zip(candidates.par_iter())
                .enumerate()
                .with_min_len(PARALLEL_NODES)
                .for_each(fill);
        } else {
            slices
                .into_iter()
                .zip(outlier.iter_mut())
                .zip(candidates.iter())
                .enumerate()
                .for_each(fill);
        }
        let m = problem.reference.len();
        let full = m > 0 && candidates.iter().all(|c| c.len() == m);
        let pattern = full.then(|| Arc::new(band_pattern(m, band)));
        let pattern_entries = pattern.as_ref().map_or_else(Vec::new, |pattern| {
            let reference = &problem.reference.surface;
            pattern
                .entries()
                .map(|(j, k)| {
                    if j == m || k == m {
                        return PatternEntry {
                            feature: outlier_transition(j == m, k == m),
                            step: None,
                        };
                    }
                    let step = reference[k] - reference[j];
                    PatternEntry {
                        feature: sequence_feature(k as isize - j as isize, band as isize),
                        step: Some((step, step.norm())),
                    }
                })
                .collect()
        });
        let band_steps = match previous {
            Some(p) => Arc::clone(&p.band_steps),
            None => Arc::new(Self::band_steps(problem, band)),
        };
        Self {
            problem,
            band,
            offsets,
            data_rest,
            band_steps,
            outlier,
            cache: RefCell::new(LocalCache {
                motion: vec![None; n],
                distance: vec![0.0; total],
                score: vec![0.0; total],
            }),
            pattern,
            pattern_entries,
            candidates,
        }
    }

    /// The problem.
    pub fn problem(&self) -> &'a AssociationProblem {
        self.problem
    }

    /// The same tables with dense pairwise tables (no sparsity pattern): the
    /// reference the sparse full state space is tested against; `O(M²)` memory per
    /// pair.
    pub fn dense(mut self) -> Self {
        self.pattern = None;
        self.pattern_entries.clear();
        self
    }

    /// The pairwise sparsity pattern (the full state space), if any.
    pub fn pattern(&self) -> Option<&Arc<PairPattern>> {
        self.pattern.as_ref()
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

    /// The reference index of state `state` of node `i` (`None`: the outlier state).
    pub fn partner(&self, i: usize, state: usize) -> Option<usize> {
        self.candidates[i].get(state).copied()
    }

    /// The state of node `i` whose candidate lies nearest to the point moved by
    /// `motion` (the outlier state without candidates).
    pub fn nearest_state(&self, i: usize, motion: &Pose2) -> usize {
        let p = self.problem;
        let q = motion.transform_point(&p.current.surface[i]);
        self.candidates[i]
            .iter()
            .enumerate()
            .min_by(|a, b| {
                let da = (p.reference.surface[*a.1] - q).norm_squared();
                let db = (p.reference.surface[*b.1] - q).norm_squared();
                da.total_cmp(&db)
            })
            .map_or(self.candidates[i].len(), |(k, _)| k)
    }

    /// Brings node `i`'s motion-dependent values up to date for `motion`.
    fn refresh(&self, i: usize, motion: &Pose2) {
        let mut cache = self.cache.borrow_mut();
        if cache.motion[i] == Some(*motion) {
            return;
        }
        cache.motion[i] = Some(*motion);
        let p = self.problem;
        let q = motion.transform_point(&p.current.surface[i]);
        let o = self.offsets[i];
        let q_bearing = q.y.atan2(q.x);
        for (k, &j) in self.candidates[i].iter().enumerate() {
            let d = (q - p.reference.surface[j]).norm();
            let bearing = bearing_offset(q_bearing, p.reference.angles[j], p.reference_increment);
            cache.distance[o + k] = d;
            cache.score[o + k] = p.data_steps[0].eval(d) + p.data_steps[1].eval(bearing);
        }
    }

    /// Writes the local features of node `i` under its `motion` (entry = state),
    /// weight indices `base + index::…`.
    pub fn write_local<S: FeatureSink>(&self, i: usize, motion: &Pose2, base: usize, sink: &mut S) {
        self.refresh(i, motion);
        let cache = self.cache.borrow();
        let o = self.offsets[i];
        let inverse_variance = 1.0 / self.problem.variances[i];
        for k in 0..self.candidates[i].len() {
            let d = cache.distance[o + k];
            let score = self.data_rest[o + k] + cache.score[o + k];
            let d2 = d * d;
            sink.add_each(
                k,
                [
                    (base + index::DATA_SCORE, score),
                    (base + index::REGISTERED_SQUARED, d2),
                    (base + index::REGISTERED_NORMALISED, d2 * inverse_variance),
                ],
            );
        }
        let out = self.candidates[i].len();
        sink.add_each(
            out,
            [
                (base + index::OUTLIER_SCORE, self.outlier[i]),
                (base + index::OUTLIER_BIAS, 1.0),
            ],
        );
    }

    /// Writes the features of the pair `(i, i + 1)` under node `i`'s `motion` (its
    /// rotation turns the current step): entry `a · states(i + 1) + b` for states `a`
    /// and `b`, or, with the sparsity pattern ([`AssociationTables::pattern`]), the
    /// pattern's entries and then its default entry (see
    /// [`HybridChainModel::write_pair`](pgm_core::hybrid::chain::HybridChainModel::write_pair)).
    pub fn write_pair<S: FeatureSink>(&self, i: usize, motion: &Pose2, base: usize, sink: &mut S) {
        let p = self.problem;
        let (ci, cj) = (&self.candidates[i], &self.candidates[i + 1]);
        let step = p.current.surface[i + 1] - p.current.surface[i];
        let pair = PairGeometry {
            length: step.norm(),
            turned: motion.isometry().rotation * step,
            inverse_variance: 1.0 / (p.variances[i] + p.variances[i + 1]),
            band: self.band as isize,
        };
        match &self.pattern {
            None => {
                // Row by row, each candidate's reference steps looked up once.
                let columns = cj.len() + 1;
                let width = 2 * self.band + 1;
                let leave = base + outlier_transition(false, true);
                for (a, &j) in ci.iter().enumerate() {
                    let row = a * columns;
                    let steps = &self.band_steps[j * width..(j + 1) * width];
                    for (b, &k) in cj.iter().enumerate() {
                        let d = k as isize - j as isize;
                        let sequence = base + sequence_feature(d, pair.band);
                        if (d - 1).abs() <= pair.band {
                            let (reference_step, norm) = steps[(d - 1 + pair.band) as usize];
                            write_geometry(
                                &pair,
                                reference_step,
                                norm,
                                row + b,
                                sequence,
                                base,
                                sink,
                            );
                        } else {
                            sink.add(row + b, sequence, 1.0);
                        }
                    }
                    sink.add(row + cj.len(), leave, 1.0);
                }
                let row = ci.len() * columns;
                for b in 0..=cj.len() {
                    sink.add(row + b, base + outlier_transition(true, b == cj.len()), 1.0);
                }
            }
            Some(pattern) => {
                // Every pair shares the pattern and its reference steps.
                for (entry, e) in self.pattern_entries.iter().enumerate() {
                    match e.step {
                        Some((reference_step, norm)) => write_geometry(
                            &pair,
                            reference_step,
                            norm,
                            entry,
                            base + e.feature,
                            base,
                            sink,
                        ),
                        None => sink.add(entry, base + e.feature, 1.0),
                    }
                }
                sink.add(pattern.default_entry(), base + index::SEQUENCE_FAR, 1.0);
            }
        }
    }
}

/// The sequence feature `sequence` (an absolute weight index, value 1) and then
/// the pairwise distance and translation features of one entry (a pair of candidates
/// whose reference step is `reference_step`, of length `norm`), added in that order in one go
/// ([`FeatureSink::add_each`]).
#[inline]
fn write_geometry<S: FeatureSink>(
    pair: &PairGeometry,
    reference_step: nalgebra::Vector2<f64>,
    norm: f64,
    entry: usize,
    sequence: usize,
    base: usize,
    sink: &mut S,
) {
    let dd = (norm - pair.length).powi(2);
    let dt = (reference_step - pair.turned).norm_squared();
    sink.add_each(
        entry,
        [
            (sequence, 1.0),
            (base + index::DISTANCE_SQUARED, dd),
            (
                base + index::DISTANCE_NORMALISED,
                dd * pair.inverse_variance,
            ),
            (base + index::TRANSLATION_SQUARED, dt),
            (
                base + index::TRANSLATION_NORMALISED,
                dt * pair.inverse_variance,
            ),
        ],
    );
}

/// Checks an association weight slice: [`ASSOCIATION_WEIGHTS`] finite values.
///
/// # Errors
/// [`Error::InvalidParameter`] naming the count.
pub fn check_association_weights(weights: &[f64]) -> Result<()> {
    if weights.len() != ASSOCIATION_WEIGHTS || !weights.iter().all(|w| w.is_finite()) {
        return Err(Error::from(InvalidParameter::new(
            "association weights",
            format!("{} weights", weights.len()),
            "18 finite weights",
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A true partner missing from a node's candidates is inserted in order; a true
    /// outlier's state is its number of candidates; true motions fall back to the
    /// ego-motion.
    #[test]
    fn true_states_insert_partners_and_name_the_outlier_state() {
        let ego = Pose2::new(1.0, 0.0, 0.0);
        let object = Pose2::new(0.0, 2.0, 0.1);
        let truth = NodeTruth {
            ego,
            labels: vec![0, 3, 3],
            object_motions: vec![None, Some(object), Some(object)],
            partners: vec![Some(5), Some(2), None],
        };
        let mut candidates = vec![vec![1, 4, 7], vec![1, 2, 3], vec![8, 9]];
        let states = truth.true_states(&mut candidates);
        assert_eq!(
            candidates,
            vec![vec![1, 4, 5, 7], vec![1, 2, 3], vec![8, 9]]
        );
        assert_eq!(states, vec![2, 1, 2]);
        assert_eq!(truth.motions(), vec![ego, object, object]);
    }
}
