//! The joint model on one scan pair, end to end.
//!
//! 1. **Motion hypotheses** (`InitialiseRT`, Algorithm 1 line 1): the ego-motion and
//!    the motions of moving gap segments from segment-wise ICP
//!    ([`pgm_scan::association::segment_motions`], which starts from the
//!    odometry prior, a tight ICP schedule and a correlative search around the
//!    prior). Cluster 0 takes the ego-motion and each moving segment starts a motion
//!    cluster of its own, the largest first while there are motion clusters
//!    ([`Clusters`]); the rest start in the background. Segments of one object are
//!    not merged beforehand: the clustering chain joins them, or their clusters end
//!    with the same motion. (Merging segments whose motions moved their centroids
//!    within 0.3 m and 0.1 rad of each other was tried: on the `following` preset it
//!    merged objects that keep pace with each other, and cost 4.5 points of
//!    association accuracy and 4.6 of clustering accuracy; on no preset did it
//!    help, seed 3.)
//!    Every return starts in its segment's cluster, associated to its nearest
//!    candidate under that cluster's motion.
//! 2. **Rounds.** Candidates are chosen under each return's cluster motion
//!    ([`StateSpace`]); the two chains run on the core's hybrid chain solver
//!    ([`pgm_core::hybrid::chain`]), every cluster's motion re-solved after each
//!    chain's exact sweep ([`ChainUpdate::EverySweep`], the default) or after every
//!    node visit whose label changed ([`ChainUpdate::EveryVisit`], Algorithm 1's
//!    schedule), then the final decoding of lines 16-21; candidates are chosen again
//!    under the new motions and clusters until the motions settle
//!    ([`JointParams::max_rounds`]).
//! 3. **Output.** Vacuous clusters are discarded (section IV-A); the background is
//!    the cluster the ego-motion hypothesis started (cluster 0), or, if it emptied,
//!    the largest. (The paper picks the cluster nearest to the odometry in
//!    Mahalanobis distance; here the ego-motion hypothesis has already weighed the
//!    odometry against the scans, and a prior off by a metre would pick a mover.)
//!    The ego-motion ends with ICP from the background's motion on the background
//!    returns with a partner, as CRF-Matching's.

use crate::model::{node_motions, JointModel, ASSOCIATION_CHAIN, CLUSTERING_CHAIN};
use crate::weights::JointWeights;
use crate::{Error, Result};
use pgm_core::hybrid::chain::{ChainUpdate, Convergence};
use pgm_core::param::{InvalidParameter, ParamGuard};
use pgm_features::association_rounds::{
    check_rounds, given_hypotheses, hypotheses_or_segment_icp, last_round, polish_ego,
    problem_with_hypotheses, round_solver,
};
use pgm_features::joint_clustering_features::MAX_MOTION_CLUSTERS;
use pgm_features::matching_features::StateSpace;
use pgm_scan::association::{SegmentIcp, SegmentMotions, SegmentParams};
use pgm_scan::{Association, Pose2, ScanPair};
use serde::Serialize;

/// How many clusters the clustering chain has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Clusters {
    /// Exactly `D` cluster states (the last the outlier cluster; `D ≥ 2`), as the
    /// paper's experiments (`D = 5`). Moving hypotheses beyond the `D − 2` largest
    /// start in the background.
    Fixed(usize),
    /// One motion cluster for the background and one per group of moving segments,
    /// at most `max` cluster states in all (the outlier cluster included): the paper
    /// lets `D` be as large as needed and discards vacuous clusters.
    Adaptive {
        /// Most cluster states.
        max: usize,
    },
}

/// Parameters of the joint model, unchecked; [`ParamGuard::check`] makes a [`Joint`].
#[derive(Clone, Debug, PartialEq)]
pub struct JointParams {
    /// The association states of a return (default: its 6 nearest candidates under
    /// its cluster's motion, plus the outlier state).
    pub state_space: StateSpace,
    /// Candidates lie within this many metres, plus three beam spacings, of the
    /// return moved by its cluster's motion (1).
    pub candidate_gate: f64,
    /// Largest reference index step `|j' − j − 1|` with geometric pairwise features
    /// (8).
    pub band: usize,
    /// The cluster states (adaptive, at most 8).
    pub clusters: Clusters,
    /// Largest number of sweeps of one round (30).
    pub max_sweeps: usize,
    /// Motions count as converged when no parameter changes by more than this (1e-3:
    /// 1 mm, 1 mrad, as CRF-Matching).
    pub tolerance: f64,
    /// When the motions are re-solved.
    pub update: ChainUpdate,
    /// When a round has converged ([`Convergence::Continuous`]: when no motion changes
    /// by more than [`JointParams::tolerance`] in a sweep, whatever the labels do).
    /// With [`Convergence::Auto`] (no label may change either) a few returns that keep
    /// flipping between clusters let the motions drift along poorly observed
    /// directions (a street seen along its length): dev seed 3, every preset, it took
    /// 10.3 sweeps per pair instead of 6.0 and was 0.1-1.2 points less accurate on six of
    /// the seven presets (0.3 more on `random`).
    pub convergence: Convergence,
    /// Largest number of rounds (candidates chosen again under the new motions; 5).
    pub max_rounds: usize,
    /// Whether the ego-motion ends with ICP on the background's returns (true).
    pub polish_ego: bool,
    /// The reported motion of every cluster but the background is solved once more
    /// from the final associations with a prior on its rotation: the object's own
    /// turn between the two scans is small, so its motion in the sensor frame turns
    /// about as much as the background's, `θ ~ N(θ_background, σ²)`
    /// ([`pgm_scan::RigidAlignment::solve_with_rotation_prior`], closed form).
    /// `Some(σ)` in rad (default 0.05: a car turning at 0.5 rad/s seen 0.1 s apart);
    /// `None` reports eq. 6 alone. A few returns of a person's legs hardly observe
    /// their rotation (eq. 6 then follows the range noise); a car's side observes it
    /// and the prior barely moves it. Inference itself (associations, clusters, the
    /// ego-motion) is eq. 6 alone either way. Measured on simulated dev seed 3 (30
    /// pairs per preset), median rotation error of correctly clustered objects,
    /// without → σ = 0.1 / 0.05 / 0.03 rad: overtaking 0.0107 → 0.0068 / 0.0043 /
    /// 0.0031, intersection (cars turn) 0.0141 → 0.0121 / 0.0086 / 0.0046, oncoming
    /// 0.0201 → 0.0088 / 0.0046 / 0.0027, pedestrians 0.1748 → 0.0117 / 0.0039 /
    /// 0.0015, mixed 0.0167 → 0.0082 / 0.0046 / 0.0024, following 0.0151 → 0.0097 /
    /// 0.0061 / 0.0059; every other figure of `pgm eval joint` unchanged. The default is
    /// the physical figure, not the best of these.
    pub object_rotation_sigma: Option<f64>,
    /// Weight of the point-to-point term of the point-to-line refinement that ends
    /// the background cluster's motion solve (`Some(0.1)`,
    /// [`pgm_scan::alignment::POINT_TO_POINT_WEIGHT`]; `None`: eq. 6 alone, as the
    /// paper). As CRF-Matching's (`pgm_scan::alignment::refine_point_to_line`):
    /// eq. 6 on one-to-one partners carries the sampling of the surfaces. The other
    /// clusters keep eq. 6: their motions decide which returns join them, and along a
    /// small object's own straight side the point-to-line term leaves the motion to
    /// the weak point-to-point term. Measured on simulated dev seed 3 (30 pairs per
    /// preset, `pgm eval joint`), refining every cluster against the background only:
    /// mean exact association 84.6 against 84.5 %, V-measure lower on 5 of 6 presets
    /// (by up to 0.006); on datmo `overtake_ego` (k = 3) static returns beside the car
    /// joined its cluster in 6 of 132 pairs (moving precision 0.974 → 0.739, car
    /// found in 21 instead of 24 of 76 pairs). With the background only, the V-measure,
    /// recall and false alarms of `pgm eval clustering --method joint` on leigh-gtm1
    /// and datmo are as with eq. 6 alone; moving precision moved by at most 0.01 and
    /// the objects' motion errors by a few mrad and mm.
    pub point_to_line: Option<f64>,
    /// Segment-wise ICP for the motion hypotheses.
    pub segments: SegmentParams,
    /// The learned weights and boosters (default: the shipped ones).
    pub weights: JointWeights,
}

impl Default for JointParams {
    fn default() -> Self {
        Self {
            state_space: StateSpace::Pruned(6),
            candidate_gate: 1.0,
            band: 8,
            clusters: Clusters::Adaptive { max: 8 },
            max_sweeps: 30,
            tolerance: 1e-3,
            update: ChainUpdate::EverySweep,
            convergence: Convergence::Continuous,
            max_rounds: 5,
            polish_ego: true,
            object_rotation_sigma: Some(0.05),
            point_to_line: Some(pgm_scan::alignment::POINT_TO_POINT_WEIGHT),
            segments: SegmentParams::default(),
            weights: JointWeights::default(),
        }
    }
}

impl ParamGuard for JointParams {
    type Checked = Joint;
    type Error = Error;

    fn check_ref(&self) -> Result<()> {
        check_rounds(
            self.state_space,
            self.max_sweeps,
            self.max_rounds,
            self.point_to_line,
        )?;
        let d = match self.clusters {
            Clusters::Fixed(d) => d,
            Clusters::Adaptive { max } => max,
        };
        if !(2..=MAX_MOTION_CLUSTERS + 1).contains(&d) {
            return Err(InvalidParameter::new(
                "clusters",
                d,
                "2..=32 cluster states (the outlier cluster included)",
            )
            .into());
        }
        for (name, value) in [
            ("candidate_gate", self.candidate_gate),
            ("tolerance", self.tolerance),
        ] {
            InvalidParameter::non_negative(name, value, "a number >= 0")?;
        }
        if let Some(sigma) = self.object_rotation_sigma {
            InvalidParameter::positive(
                "object_rotation_sigma",
                sigma,
                "a standard deviation in rad > 0",
            )?;
        }
        self.segments.check_ref()?;
        self.weights.check_ref()
    }

    fn check(self) -> Result<Joint> {
        self.check_ref()?;
        let segment_icp = self.segments.check()?;
        Ok(Joint {
            params: self,
            segment_icp,
        })
    }
}

/// The joint model with checked parameters.
#[derive(Clone, Debug)]
pub struct Joint {
    params: JointParams,
    segment_icp: SegmentIcp,
}

impl Default for Joint {
    fn default() -> Self {
        JointParams::default().check_unwrap()
    }
}

/// A return's cluster in a [`JointResult`]: a motion cluster (an index into
/// [`JointResult::motions`]) or the outlier cluster; serialised as the index, `-1` for
/// the outlier cluster.
pub use pgm_scan::methods::JointCluster as ClusterLabel;

/// The result of the joint model on one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointResult {
    /// Per beam of the current scan: the MAP association (a reference beam or
    /// outlier), `None` for beams without a return.
    pub associations: Vec<Option<Association>>,
    /// Per beam: the normalised max-marginal of the MAP association (in (0, 1]).
    pub confidence: Vec<Option<f64>>,
    /// Per beam: the MAP cluster (serialised as the cluster index, `-1` for the
    /// outlier cluster), `None` for beams without a return.
    pub clusters: Vec<Option<ClusterLabel>>,
    /// The motion of every non-vacuous motion cluster (maps its current points onto
    /// the reference scan).
    pub motions: Vec<Pose2>,
    /// The background cluster (index into `motions`).
    pub background: usize,
    /// The ego-motion (the background's motion, refined).
    pub ego_motion: Pose2,
    /// Sweeps over all rounds.
    pub sweeps: usize,
    /// Rounds run.
    pub rounds: usize,
    /// Whether the last round converged.
    pub converged: bool,
}

/// A group of moving segments that start as one cluster.
struct Group {
    motion: Pose2,
    size: usize,
    segments: Vec<usize>,
}

impl Joint {
    /// The parameters.
    pub fn params(&self) -> &JointParams {
        &self.params
    }

    /// The starting motions (cluster 0: the ego-motion) and each return's starting
    /// cluster (see the module docs, step 1).
    fn initial_clusters(
        &self,
        pair: &ScanPair,
        n: usize,
        given: Option<SegmentMotions>,
    ) -> Result<(Vec<Pose2>, Vec<usize>)> {
        let p = &self.params;
        let h = hypotheses_or_segment_icp(pair, given, &self.segment_icp)?;
        let mut size = vec![0usize; h.moved.len()];
        let mut motion = vec![h.ego; h.moved.len()];
        for i in 0..n {
            let s = h.segment_of[i];
            size[s] += 1;
            motion[s] = h.motion_of[i];
        }
        // One group per moving segment (see the module docs on merging).
        // A segment marked moved without a return is no group ([`SegmentMotions`]).
        let mut groups: Vec<Group> = (0..h.moved.len())
            .filter(|&s| h.moved[s] && size[s] > 0)
            .map(|s| Group {
                motion: motion[s],
                size: size[s],
                segments: vec![s],
            })
            .collect();
        groups.sort_by_key(|g| std::cmp::Reverse(g.size));
        let moving = match p.clusters {
            Clusters::Fixed(d) => d.saturating_sub(2),
            Clusters::Adaptive { max } => groups.len().min(max.saturating_sub(2)),
        };
        let mut motions = vec![h.ego];
        let mut cluster_of_segment = vec![0usize; h.moved.len()];
        for (k, g) in groups.iter().take(moving).enumerate() {
            motions.push(g.motion);
            for &s in &g.segments {
                cluster_of_segment[s] = k + 1;
            }
        }
        // A fixed D keeps its empty motion clusters (at the ego-motion): they are
        // discarded as vacuous at the end unless returns join them.
        if let Clusters::Fixed(d) = p.clusters {
            motions.resize(d - 1, h.ego);
        }
        let clusters = (0..n)
            .map(|i| cluster_of_segment[h.segment_of[i]])
            .collect();
        Ok((motions, clusters))
    }

    /// Runs the joint model on `pair` (see the module docs). Errors name the pair.
    pub fn estimate(&self, pair: &ScanPair) -> Result<JointResult> {
        self.run(pair, None)
    }

    /// [`Joint::estimate`] with the motion hypotheses of step 1 given instead of found
    /// by segment-wise ICP: the ego-motion, and per valid current return (beam order)
    /// its segment and motion, with the segments that moved (each starts a motion
    /// cluster, the largest first, as step 1 says; read as [`SegmentMotions`] says).
    /// For hypotheses a pair alone cannot give: a tracker's predictions from earlier
    /// scans, or an oracle's (the tool `association_bound` starts the joint model
    /// from the true motions this way). Only the number of valid returns ties the
    /// hypotheses to `pair`.
    ///
    /// # Errors
    /// [`Error::Features`] (`BadPair`, naming the pair) when `hypotheses` do not fit
    /// the pair ([`SegmentMotions::check_for`]), and the errors of
    /// [`Joint::estimate`].
    pub fn estimate_with_hypotheses(
        &self,
        pair: &ScanPair,
        hypotheses: &SegmentMotions,
    ) -> Result<JointResult> {
        self.run(pair, given_hypotheses(pair, hypotheses)?)
    }

    /// Both entry points: `given` hypotheses, else segment-wise ICP's.
    fn run(&self, pair: &ScanPair, given: Option<SegmentMotions>) -> Result<JointResult> {
        let p = &self.params;
        let (problem, initial) = problem_with_hypotheses(pair, &p.weights.boosters, |n| {
            self.initial_clusters(pair, n, given)
        })?;
        let n = problem.len();
        let beams = pair.current.len();
        let Some(initial) = initial else {
            let ego = pair.odometry.unwrap_or_default();
            return Ok(JointResult {
                associations: vec![None; beams],
                confidence: vec![None; beams],
                clusters: vec![None; beams],
                motions: vec![ego],
                background: 0,
                ego_motion: ego,
                sweeps: 0,
                rounds: 0,
                converged: true,
            });
        };
        let (mut motions, mut clusters) = initial?;
        let outlier_cluster = motions.len();
        let background = 0;
        let solver = round_solver(p.max_sweeps, p.tolerance, p.update)
            .convergence(p.convergence)
            .check()?;
        let mut chosen: Vec<Option<usize>> = vec![None; n];
        let mut previous: Option<JointModel> = None;
        let (mut sweeps, mut rounds) = (0, 0);
        let (mut confidence, mut converged);
        loop {
            rounds += 1;
            let chosen_under = motions.clone();
            let own = node_motions(&problem, &clusters, &motions, background);
            let ego = vec![motions[background]; n];
            let candidates = problem.candidates(p.state_space, &own, &ego, p.candidate_gate);
            let mut model = match previous.take() {
                Some(last) => last.next_round(candidates, motions.clone(), &own),
                None => JointModel::new(
                    &problem,
                    candidates,
                    motions.clone(),
                    background,
                    &p.weights.weights,
                    p.band,
                    &clusters,
                )
                .with_point_to_line(p.point_to_line),
            };
            let start_association = model.tables().start_states(&chosen, &own);
            let result = solver.run(&mut model, &[start_association, clusters.clone()])?;
            sweeps += result.sweeps;
            converged = result.converged;
            confidence = model
                .tables()
                .read_map(&result, ASSOCIATION_CHAIN, &mut chosen);
            clusters.clone_from(&result.labels[CLUSTERING_CHAIN]);
            motions = model.motions().to_vec();
            if last_round(p.state_space, rounds, p.max_rounds, &chosen_under, &motions) {
                if let Some(sigma) = p.object_rotation_sigma {
                    motions = model.object_motions_with_prior(sigma);
                }
                break;
            }
            previous = Some(model);
        }
        // Discard vacuous clusters; the background is cluster 0 unless it emptied.
        let mut count = vec![0usize; outlier_cluster];
        for &c in &clusters {
            if c < outlier_cluster {
                count[c] += 1;
            }
        }
        let background = if count[background] > 0 {
            background
        } else {
            (0..outlier_cluster).max_by_key(|&c| count[c]).unwrap_or(0)
        };
        let mut renumber = vec![None; outlier_cluster];
        let mut kept = Vec::new();
        for c in
            std::iter::once(background).chain((0..outlier_cluster).filter(|&c| c != background))
        {
            if count[c] > 0 || c == background {
                renumber[c] = Some(kept.len());
                kept.push(motions[c]);
            }
        }
        let mut ego = motions[background];
        if p.polish_ego {
            ego = polish_ego(&problem, pair, ego, |i| {
                clusters[i] == background && chosen[i].is_some()
            });
        }
        kept[0] = ego;
        Ok(JointResult {
            associations: problem.per_beam(beams, |i| problem.association(chosen[i])),
            confidence: problem.per_beam(beams, |i| confidence[i]),
            clusters: problem.per_beam(beams, |i| {
                match renumber.get(clusters[i]).copied().flatten() {
                    Some(k) => ClusterLabel::Object(k),
                    None => ClusterLabel::Outlier,
                }
            }),
            motions: kept,
            background: 0,
            ego_motion: ego,
            sweeps,
            rounds,
            converged,
        })
    }
}

/// First correspondence distance (m) of the final ego-motion ICP (as CRF-Matching's).
pub use pgm_features::association_rounds::POLISH_DISTANCE;
