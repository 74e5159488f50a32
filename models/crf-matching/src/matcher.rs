//! CRF-Matching of one scan pair, end to end.
//!
//! 1. **Motion hypotheses.** The ego-motion starts from the pair's odometry prior (the
//!    identity without one), refined by ICP; segment-wise ICP
//!    ([`pgm_scan::association::segment_motions`]) proposes a motion for every gap
//!    segment of the current scan that does not follow the ego-motion and that free
//!    space shows moved. Each such segment is a motion group of its own (see
//!    [`crate::model`]).
//! 2. **Rounds.** Candidates are chosen under the current motions
//!    ([`StateSpace`]); the chain CRF runs on the core's hybrid chain solver
//!    ([`pgm_core::hybrid::chain`]), re-solving every group's motion (eq. 6) after
//!    every sweep or every visit ([`ChainUpdate`]) from the current MAP associations,
//!    with the motion-dependent features refreshed; then candidates are chosen again
//!    under the new motions, until they no longer change
//!    ([`MatchingParams::max_rounds`]).
//! 3. **Output.** Every current return's MAP association (a reference beam or
//!    outlier) with its max-marginal confidence, the ego-motion (group 0) and every
//!    group's motion.

use crate::model::MatchingModel;
use crate::weights::MatchingWeights;
use crate::{Error, Result};
use pgm_core::hybrid::chain::ChainUpdate;
use pgm_core::param::{InvalidParameter, ParamGuard};
use pgm_features::association_rounds::{
    check_rounds, given_hypotheses, hypotheses_or_segment_icp, last_round, polish_ego,
    problem_with_hypotheses, round_solver,
};
use pgm_features::matching_features::StateSpace;
use pgm_scan::association::{AssociationSource, SegmentIcp, SegmentMotions, SegmentParams};
use pgm_scan::methods::{EgoMotionEstimate, ScanMatcher};
use pgm_scan::{Association, PointAssociations, Pose2, ScanPair};
use serde::Serialize;

/// Parameters of CRF-Matching, unchecked; [`ParamGuard::check`] makes a [`Matcher`].
#[derive(Clone, Debug, PartialEq)]
pub struct MatchingParams {
    /// The states of a node (default: the 6 nearest candidates and the outlier state;
    /// see the README for the measurement behind the default).
    pub state_space: StateSpace,
    /// Candidates lie within this many metres, plus three beam spacings, of the point
    /// moved by its motion estimate (pruned state space; 1).
    pub candidate_gate: f64,
    /// Largest reference index step `|j' − j − 1|` between consecutive candidates for
    /// which the pairwise geometric features are evaluated (8).
    pub band: usize,
    /// Largest number of sweeps of one round (30).
    pub max_sweeps: usize,
    /// Motions count as converged when no parameter changes by more than this
    /// (1e-3: 1 mm, 1 mrad; a thirtieth of the range noise, and the final ICP of
    /// [`MatchingParams::polish_ego`] refines the ego-motion further). Measured on
    /// simulated pairs (seed 3, 30 per preset) against 1e-4: the same or higher
    /// accuracy on every preset (mixed 78.28 % both, oncoming 80.92 -> 81.75 %), 25 %
    /// fewer sweeps; mit-csail near pairs 0.0214 m / 0.00397 rad.
    pub tolerance: f64,
    /// When the motions are re-solved (every sweep, default, or every visit).
    pub update: ChainUpdate,
    /// Largest number of rounds (candidates chosen again under the new motions; 5).
    /// A round ends the run when no motion moved by more than
    /// [`ROUND_TOLERANCE`] since its candidates were chosen.
    pub max_rounds: usize,
    /// Whether moving segments get motion groups of their own (true; false: one
    /// motion, the ego-motion, as the paper's CRF-Matching).
    pub segment_motions: bool,
    /// Whether the ego-motion ends with ICP from the CRF's estimate on the returns the
    /// CRF associates under it (group 0, not outlier), first correspondence distance
    /// [`POLISH_DISTANCE`] (true). Eq. 6 on the MAP associations pins each return to
    /// one reference return, so the motion carries the scans' sampling; ICP's
    /// nearest neighbours re-chosen as the motion moves average it out, and the CRF
    /// has already decided which returns are static and seen. Measured with the
    /// shipped weights: mit-csail near pairs median 0.0230 m / 0.00413 rad without,
    /// 0.0213 m / 0.00401 rad with; intel-lab 0.0236 m / 0.00524 rad without, 0.0214 m
    /// / 0.00510 rad with (ICP: 0.0216 m / 0.00398 rad and 0.0223 m / 0.00557 rad).
    /// The associations are the CRF's either way. Since the motion solves end
    /// point-to-line ([`MatchingParams::point_to_line`]) the sampling no longer biases
    /// the CRF's estimate, and the polish helps less (measured 2026-11-30, without →
    /// with): mit-csail near 0.0216 / 0.00406 → 0.0213 / 0.00390, intel-lab 0.0210 /
    /// 0.00432 → 0.0207 / 0.00479, simulated dev seed 3 median 6.4-9.9 mm → 9.0-13.1
    /// mm per preset (docs/decisions.md, where a point-to-line polish is measured too).
    pub polish_ego: bool,
    /// Weight of the point-to-point term of the point-to-line refinement that ends
    /// every motion solve (`Some(0.1)`, [`pgm_scan::alignment::POINT_TO_POINT_WEIGHT`];
    /// `None`: eq. 6 alone, as the paper). See [`MatchingModel::solve_motions`]; on the
    /// design seed every weight from 0.01 to 0.3 gave the same mean exact accuracy
    /// within 0.11 point (docs/decisions.md).
    pub point_to_line: Option<f64>,
    /// Segment-wise ICP for the ego-motion and the motion hypotheses.
    pub segments: SegmentParams,
    /// The learned weights and boosters (default: the shipped ones).
    pub weights: MatchingWeights,
}

impl Default for MatchingParams {
    fn default() -> Self {
        Self {
            state_space: StateSpace::Pruned(6),
            candidate_gate: 1.0,
            band: 8,
            max_sweeps: 30,
            tolerance: 1e-3,
            update: ChainUpdate::EverySweep,
            max_rounds: 5,
            segment_motions: true,
            polish_ego: true,
            point_to_line: Some(pgm_scan::alignment::POINT_TO_POINT_WEIGHT),
            segments: SegmentParams::default(),
            weights: MatchingWeights::default(),
        }
    }
}

impl ParamGuard for MatchingParams {
    type Checked = Matcher;
    type Error = Error;

    fn check_ref(&self) -> Result<()> {
        check_rounds(
            self.state_space,
            self.max_sweeps,
            self.max_rounds,
            self.point_to_line,
        )?;
        InvalidParameter::non_negative(
            "candidate_gate",
            self.candidate_gate,
            "a number of metres >= 0",
        )?;
        InvalidParameter::non_negative("tolerance", self.tolerance, "a number >= 0")?;
        self.segments.check_ref()?;
        self.weights.check_ref()
    }

    fn check(self) -> Result<Matcher> {
        self.check_ref()?;
        let segment_icp = self.segments.check()?;
        Ok(Matcher {
            params: self,
            segment_icp,
        })
    }
}

pub use pgm_features::association_rounds::{POLISH_DISTANCE, ROUND_TOLERANCE};

/// CRF-Matching with checked parameters.
#[derive(Clone, Debug)]
pub struct Matcher {
    params: MatchingParams,
    segment_icp: SegmentIcp,
}

impl Default for Matcher {
    fn default() -> Self {
        MatchingParams::default().check_unwrap()
    }
}

/// The result of CRF-Matching on one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Matching {
    /// Per beam of the current scan: the MAP association (a reference beam or
    /// outlier), `None` for beams without a return.
    pub associations: Vec<Option<Association>>,
    /// Per beam of the current scan: the normalised max-marginal of the MAP state
    /// (the association's confidence, in (0, 1]); `None` without a return.
    pub confidence: Vec<Option<f64>>,
    /// The ego-motion (the motion of group 0): maps current points onto the reference
    /// scan.
    pub motion: Pose2,
    /// Every motion group's motion, group 0 first.
    pub group_motions: Vec<Pose2>,
    /// Per beam of the current scan: the motion group of its return (an index into
    /// `group_motions`; 0: the ego-motion), `None` for beams without a return.
    pub groups: Vec<Option<usize>>,
    /// Sweeps over all rounds.
    pub sweeps: usize,
    /// Rounds run.
    pub rounds: usize,
    /// Whether the last round converged; false also when the ego-motion is the prior
    /// for want of data (see `note`).
    pub converged: bool,
    /// Why the result is not converged, when that is not the sweep limit: too few
    /// returns associated under the ego-motion for a rigid fit, so the ego-motion is
    /// the prior (the pair's odometry, else the identity).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl Matcher {
    /// The parameters.
    pub fn params(&self) -> &MatchingParams {
        &self.params
    }

    /// Matches the current scan of `pair` to its reference scan (see the module docs).
    /// Errors name the pair.
    pub fn match_pair(&self, pair: &ScanPair) -> Result<Matching> {
        self.run(pair, None)
    }

    /// [`Matcher::match_pair`] with the motion hypotheses given instead of found by
    /// segment-wise ICP (step 1 of the module docs): the ego-motion to start from, and
    /// per valid current return (beam order) its segment and the motion its segment
    /// starts from, with the segments that moved (read as [`SegmentMotions`] says);
    /// each moved segment is a motion group of its own (with
    /// [`MatchingParams::segment_motions`]). For hypotheses a pair alone cannot give: a
    /// tracker's predictions from earlier scans, or an oracle's (the example
    /// `association_bound` starts CRF-Matching from the true motions this way). Only
    /// the number of valid returns ties the hypotheses to `pair`.
    ///
    /// ```
    /// use pgm_crf_matching::Matcher;
    /// use pgm_datasets::sim::{simulate_pair, SimConfig};
    /// use pgm_scan::association::segment_motions;
    /// use pgm_scan::{ParamGuard, Pose2};
    ///
    /// let pair = simulate_pair(&SimConfig::default().check()?, 1, 0);
    /// let matcher = Matcher::default();
    /// // Segment-wise ICP's hypotheses, as `match_pair` finds them ...
    /// let hypotheses = segment_motions(&pair, &matcher.params().segments.check()?)?;
    /// let found = matcher.match_pair_with_hypotheses(&pair, &hypotheses)?;
    /// assert_eq!(found, matcher.match_pair(&pair)?);
    /// // ... or with every moving segment started from a motion of your own (here a
    /// // prediction 0.1 m further along x).
    /// let predicted = hypotheses.map_moved(|m| Pose2::new(m.x() + 0.1, m.y(), m.theta()));
    /// let predicted = matcher.match_pair_with_hypotheses(&pair, &predicted)?;
    /// assert_eq!(predicted.associations.len(), pair.current.len());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::Features`] (`BadPair`, naming the pair) when `hypotheses` do not fit
    /// the pair ([`SegmentMotions::check_for`]), and the errors of
    /// [`Matcher::match_pair`].
    pub fn match_pair_with_hypotheses(
        &self,
        pair: &ScanPair,
        hypotheses: &SegmentMotions,
    ) -> Result<Matching> {
        self.run(pair, given_hypotheses(pair, hypotheses)?)
    }

    /// Both entry points: `given` hypotheses, else segment-wise ICP's.
    fn run(&self, pair: &ScanPair, given: Option<SegmentMotions>) -> Result<Matching> {
        let p = &self.params;
        let (problem, hypotheses) = problem_with_hypotheses(pair, &p.weights.boosters, |_| {
            hypotheses_or_segment_icp(pair, given, &self.segment_icp)
        })?;
        let n = problem.len();
        let beams = pair.current.len();
        let Some(hypotheses) = hypotheses else {
            return Ok(Matching {
                associations: vec![None; beams],
                confidence: vec![None; beams],
                motion: pair.odometry.unwrap_or_default(),
                group_motions: vec![pair.odometry.unwrap_or_default()],
                groups: vec![None; beams],
                sweeps: 0,
                rounds: 0,
                converged: false,
                note: Some("no return to associate: kept the prior".into()),
            });
        };
        // Motion groups: 0 for the ego-motion, one per moved segment.
        let hypotheses = hypotheses?;
        let mut motions = vec![hypotheses.ego];
        let mut group_of = vec![0usize; n];
        if p.segment_motions {
            let mut group_of_segment = vec![None; hypotheses.moved.len()];
            for (i, group) in group_of.iter_mut().enumerate() {
                let s = hypotheses.segment_of[i];
                if hypotheses.moved[s] {
                    let g = *group_of_segment[s].get_or_insert_with(|| {
                        motions.push(hypotheses.motion_of[i]);
                        motions.len() - 1
                    });
                    *group = g;
                }
            }
        }
        let solver = round_solver(p.max_sweeps, p.tolerance, p.update).check()?;
        // MAP reference index of every node (None: outlier) carried between rounds.
        let mut chosen: Vec<Option<usize>> = vec![None; n];
        let mut sweeps = 0;
        let mut rounds = 0;
        let (mut max_marginals, mut converged);
        let mut previous: Option<MatchingModel> = None;
        loop {
            rounds += 1;
            let chosen_under = motions.clone();
            let own: Vec<Pose2> = group_of.iter().map(|&g| motions[g]).collect();
            let ego = vec![motions[0]; n];
            let candidates = problem.candidates(p.state_space, &own, &ego, p.candidate_gate);
            let mut model = match previous.take() {
                Some(last) => last.next_round(candidates, group_of.clone(), motions.clone()),
                None => MatchingModel::new(
                    &problem,
                    candidates,
                    group_of.clone(),
                    motions.clone(),
                    &p.weights.weights,
                    p.band,
                )
                .with_point_to_line(p.point_to_line),
            };
            let initial = model.tables().start_states(&chosen, &own);
            let result = solver.run(&mut model, &[initial])?;
            sweeps += result.sweeps;
            converged = result.converged;
            max_marginals = model.tables().read_map(&result, 0, &mut chosen);
            motions = model.motions().to_vec();
            if last_round(p.state_space, rounds, p.max_rounds, &chosen_under, &motions) {
                break;
            }
            previous = Some(model);
        }
        if p.polish_ego {
            // The static returns the CRF associates decide the ego-motion's final ICP
            // (see `MatchingParams::polish_ego`).
            motions[0] = polish_ego(&problem, pair, motions[0], |i| {
                group_of[i] == 0 && chosen[i].is_some()
            });
        }
        // Too little data for a rigid fit (eq. 6 on one or two associations follows
        // whatever they suggest): the ego-motion keeps the prior, and says so.
        let support = (0..n)
            .filter(|&i| group_of[i] == 0 && chosen[i].is_some())
            .count();
        let needed = p.segments.nearest.icp.min_correspondences.max(2);
        let mut note = None;
        if support < needed {
            motions[0] = pair.odometry.unwrap_or_default();
            converged = false;
            note = Some(format!(
                "{support} returns associated under the ego-motion, fewer than the {needed} a \
                 rigid fit needs: kept the prior"
            ));
        }
        Ok(Matching {
            associations: problem.per_beam(beams, |i| problem.association(chosen[i])),
            confidence: problem.per_beam(beams, |i| max_marginals[i]),
            motion: motions[0],
            group_motions: motions,
            groups: problem.per_beam(beams, |i| group_of[i]),
            sweeps,
            rounds,
            converged,
            note,
        })
    }
}

impl AssociationSource for Matcher {
    fn name(&self) -> &str {
        "crf-matching"
    }

    fn associate(&self, pair: &ScanPair) -> pgm_scan::Result<PointAssociations> {
        let m = self.match_pair(pair)?;
        Ok(PointAssociations {
            associations: m.associations,
            ego_motion: Some(m.motion),
        })
    }
}

impl ScanMatcher for Matcher {
    fn name(&self) -> &str {
        "crf-matching"
    }

    fn estimate(&self, pair: &ScanPair) -> pgm_scan::Result<EgoMotionEstimate> {
        let m = self.match_pair(pair)?;
        Ok(EgoMotionEstimate {
            motion: m.motion,
            converged: m.converged,
            iterations: m.sweeps,
            note: m
                .note
                .or_else(|| (!m.converged).then(|| "sweep limit".to_string())),
        })
    }
}
