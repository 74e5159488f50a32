//! The rounds of inference of a model built on the association chain
//! ([`crate::matching_features`]): CRF-Matching and the joint model run them alike.
//!
//! 1. The pair's [`AssociationProblem`] is built side by side with the model's motion
//!    hypotheses ([`problem_with_hypotheses`]).
//! 2. Each round chooses candidates under the current motions, starts every node at
//!    its last round's partner where that is still a candidate, else at the candidate
//!    nearest under its motion ([`AssociationTables::start_states`]), runs the chain
//!    solver, reads its MAP partners ([`AssociationTables::read_map`]), and ends the
//!    run when no motion moved by more than [`ROUND_TOLERANCE`] since its candidates
//!    were chosen ([`rounds_settled`], [`last_round`]).
//! 3. The ego-motion ends with ICP on the static returns with a partner
//!    ([`polish_ego`]), and every node's result goes to its beam
//!    ([`AssociationProblem::per_beam`], [`AssociationProblem::association`]).

use crate::matching_features::{
    AssociationBoosters, AssociationProblem, AssociationTables, StateSpace,
};
use crate::Result;
use pgm_core::hybrid::chain::{ChainUpdate, HybridChainParams, HybridChainResult};
use pgm_core::param::InvalidParameter;
use pgm_scan::association::{segment_motions, SegmentIcp, SegmentMotions};
use pgm_scan::registration::IcpStatus;
use pgm_scan::{Association, Pose2, ScanPair, SurfacePair};

/// A run of rounds stops when no motion moved by more than this since the round's
/// candidates were chosen (m and rad; 1 cm, 5 mrad): candidates chosen under the new
/// motions would hardly differ.
pub const ROUND_TOLERANCE: (f64, f64) = (0.01, 0.005);

/// First correspondence distance (m) of the final ego-motion ICP ([`polish_ego`]):
/// the CRF's estimate is already close.
pub const POLISH_DISTANCE: f64 = 0.3;

/// Checks the parameters of the rounds every model on the association chain has: at
/// most 64 candidates per return (and at least one), at least one sweep and one
/// round, a positive point-to-line weight.
///
/// # Errors
/// The first parameter out of range, named.
pub fn check_rounds(
    state_space: StateSpace,
    max_sweeps: usize,
    max_rounds: usize,
    point_to_line: Option<f64>,
) -> std::result::Result<(), InvalidParameter> {
    if let StateSpace::Pruned(k) = state_space {
        check_candidates(k)?;
    }
    if max_sweeps == 0 || max_rounds == 0 {
        return Err(InvalidParameter::new(
            "max_sweeps / max_rounds",
            (max_sweeps, max_rounds),
            "at least 1 each",
        ));
    }
    if let Some(w) = point_to_line {
        InvalidParameter::positive("point_to_line", w, "a positive weight")?;
    }
    Ok(())
}

/// Checks a number of candidates per return: 1..=64 (the states are allocated per
/// return).
///
/// # Errors
/// `candidates` outside 1..=64.
pub fn check_candidates(k: usize) -> std::result::Result<(), InvalidParameter> {
    if (1..=64).contains(&k) {
        Ok(())
    } else {
        Err(InvalidParameter::new("candidates", k, "1..=64 candidates"))
    }
}

/// The association problem of `pair` and, when the pair has a valid current return,
/// what `hypotheses` makes from their number, built side by side (rayon; one thread
/// builds them in turn): the problem (shape features, search structures) and a
/// model's motion hypotheses do not depend on each other. `None` without a valid
/// current return.
///
/// # Errors
/// The problem's ([`AssociationProblem::new`]).
pub fn problem_with_hypotheses<T: Send>(
    pair: &ScanPair,
    boosters: &AssociationBoosters,
    hypotheses: impl FnOnce(usize) -> T + Send,
) -> Result<(AssociationProblem, Option<T>)> {
    let n = pair.current.valid.iter().filter(|&&v| v).count();
    let (problem, hypotheses) = if n == 0 {
        (AssociationProblem::new(pair, boosters), None)
    } else {
        let (problem, hypotheses) =
            rayon::join(|| AssociationProblem::new(pair, boosters), || hypotheses(n));
        (problem, Some(hypotheses))
    };
    let problem = problem?;
    debug_assert_eq!(problem.len(), n, "one node per valid current return");
    Ok((problem, hypotheses))
}

/// Hypotheses given to a model's run in place of segment-wise ICP's (the
/// `…_with_hypotheses` entry points of CRF-Matching and the joint model): a copy of
/// `hypotheses` once they fit `pair`, as `given` for [`hypotheses_or_segment_icp`].
///
/// # Errors
/// [`pgm_scan::Error::BadPair`], naming the pair, when `hypotheses` do not fit it
/// ([`SegmentMotions::check_for`]).
pub fn given_hypotheses(
    pair: &ScanPair,
    hypotheses: &SegmentMotions,
) -> pgm_scan::Result<Option<SegmentMotions>> {
    hypotheses.check_for(pair)?;
    Ok(Some(hypotheses.clone()))
}

/// The motion hypotheses a model's run starts from: `given` ones
/// ([`given_hypotheses`]), else segment-wise ICP's on `pair` with `icp`.
///
/// # Errors
/// Segment-wise ICP's ([`segment_motions`]), naming the pair.
pub fn hypotheses_or_segment_icp(
    pair: &ScanPair,
    given: Option<SegmentMotions>,
    icp: &SegmentIcp,
) -> pgm_scan::Result<SegmentMotions> {
    match given {
        Some(given) => Ok(given),
        None => segment_motions(pair, icp),
    }
}

/// The chain solver of a model's rounds with its sweep limit, motion tolerance and
/// update schedule (unchecked, for a model to set more before checking).
pub fn round_solver(max_sweeps: usize, tolerance: f64, update: ChainUpdate) -> HybridChainParams {
    HybridChainParams::default()
        .max_sweeps(max_sweeps)
        .tolerance(tolerance)
        .update(update)
}

/// Whether a round has settled: no motion of `after` moved by more than
/// [`ROUND_TOLERANCE`] from its value in `before` (the motions the round's candidates
/// were chosen under).
pub fn rounds_settled(before: &[Pose2], after: &[Pose2]) -> bool {
    before.iter().zip(after).all(|(a, b)| {
        a.translation_error(b) <= ROUND_TOLERANCE.0 && a.rotation_error(b) <= ROUND_TOLERANCE.1
    })
}

/// Whether a run of rounds ends with its `rounds`-th round, which chose its candidates
/// under the motions `before` and ended at `after`: the round settled
/// ([`rounds_settled`]), `max_rounds` rounds have run, or the candidates are the full
/// state space (another round would choose them again).
pub fn last_round(
    state_space: StateSpace,
    rounds: usize,
    max_rounds: usize,
    before: &[Pose2],
    after: &[Pose2],
) -> bool {
    rounds_settled(before, after) || rounds >= max_rounds || matches!(state_space, StateSpace::Full)
}

/// The ego-motion `ego` refined by ICP from itself (first correspondence distance
/// [`POLISH_DISTANCE`]) on the current returns that `is_static` (a node index) keeps,
/// against the reference scan; `ego` itself when ICP fails or finds too few
/// correspondences.
pub fn polish_ego(
    problem: &AssociationProblem,
    pair: &ScanPair,
    ego: Pose2,
    is_static: impl Fn(usize) -> bool,
) -> Pose2 {
    let mut seen = pair.current.clone();
    seen.valid.fill(false);
    for i in (0..problem.len()).filter(|&i| is_static(i)) {
        seen.valid[problem.current.beams[i]] = true;
    }
    match problem.search.align_best(&seen, &[(ego, POLISH_DISTANCE)]) {
        Ok(r) if r.status != IcpStatus::TooFewCorrespondences => r.motion,
        _ => ego,
    }
}

impl AssociationProblem {
    /// The association of a node whose partner is `partner` (an index among the
    /// reference scan's valid returns; `None`: the outlier state).
    pub fn association(&self, partner: Option<usize>) -> Association {
        match partner {
            Some(j) => Association::Point(self.reference.beams[j]),
            None => Association::Outlier,
        }
    }

    /// Per beam of a current scan of `beams` beams: `value` of the beam's node
    /// (`None` for beams without a return).
    pub fn per_beam<T>(&self, beams: usize, mut value: impl FnMut(usize) -> T) -> Vec<Option<T>> {
        let mut out: Vec<Option<T>> = (0..beams).map(|_| None).collect();
        for (i, &beam) in self.current.beams.iter().enumerate() {
            out[beam] = Some(value(i));
        }
        out
    }
}

impl AssociationTables<'_> {
    /// Fills `pairs` with the [`AssociationProblem::surface_pair`] of every node that
    /// `member` keeps (a node index) and whose current state `labels` is not the
    /// outlier state: the pairs a motion of those nodes is solved from.
    pub fn member_pairs(
        &self,
        labels: &[Option<usize>],
        member: impl Fn(usize) -> bool,
        pairs: &mut Vec<SurfacePair>,
    ) {
        pairs.clear();
        for (i, label) in labels.iter().enumerate() {
            if !member(i) {
                continue;
            }
            if let Some(j) = label.and_then(|l| self.partner(i, l)) {
                pairs.push(self.problem().surface_pair(i, j));
            }
        }
    }

    /// Reads the MAP states of the association chain `chain` of `result`: every
    /// node's partner (a reference index, `None` for the outlier state) into `chosen`,
    /// and every node's normalised max-marginal of its MAP state, returned.
    pub fn read_map(
        &self,
        result: &HybridChainResult,
        chain: usize,
        chosen: &mut [Option<usize>],
    ) -> Vec<f64> {
        let labels = &result.labels[chain];
        for (i, &l) in labels.iter().enumerate() {
            chosen[i] = self.partner(i, l);
        }
        (0..labels.len())
            .map(|i| result.max_marginal(chain, i)[labels[i]])
            .collect()
    }

    /// The starting state of every node: its `chosen` partner of the last round (a
    /// reference index) where that is still a candidate, else the candidate nearest
    /// to the node moved by its `motions` entry.
    pub fn start_states(&self, chosen: &[Option<usize>], motions: &[Pose2]) -> Vec<usize> {
        chosen
            .iter()
            .zip(motions)
            .enumerate()
            .map(|(i, (partner, motion))| {
                partner
                    .and_then(|j| self.state_of(i, j))
                    .unwrap_or_else(|| self.nearest_state(i, motion))
            })
            .collect()
    }
}
