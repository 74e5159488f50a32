//! Learning CRF-Matching from labelled pairs: the two boosters, then the 18 weights by
//! pseudo-likelihood (L-BFGS, [`pgm_core::learning`]).
//!
//! A labelled pair has ground-truth associations (and, for the motions, labels and
//! per-object motions; the simulator has all of them). The motions are observed
//! during learning, as the papers treat them: every point moves with the true motion
//! of its object (its label's motion, the ego-motion for the background).
//!
//! 1. **Boosters** (on the first half of the pairs): for every current return with a
//!    ground-truth association, the data booster sees its candidates under its true
//!    motion ([`StateSpace::Pruned`] with the given count, and its true partner
//!    always) as samples, positive for the true partner; the outlier booster sees the
//!    return itself, positive when it is an outlier.
//! 2. **Weights** (on the second half): each pair is a chain CRF whose features are
//!    written by the same code as at inference ([`MatchingModel`]) with the boosters
//!    of step 1, the candidates as in step 1 (the true partner added where the
//!    pruning missed it, so every label is a state), and the pseudo-likelihood of the
//!    true associations is maximised. Splitting the pairs keeps the boosters' margins
//!    on the second half as they will be on new pairs, not overconfident.

use crate::model::MatchingModel;
use crate::weights::{feature_set, MatchingWeights, WEIGHTS};
use crate::Result;
use pgm_core::hybrid::chain::chain_instance;
use pgm_core::learning::{LabelledInstance, LearnerParams, LearningObserver, LearningResult};
use pgm_core::param::InvalidParameter;
use pgm_core::ParamGuard;
use pgm_features::boosting::{Booster, BoosterParams, TrainingSet};
use pgm_features::matching_features::{AssociationBoosters, AssociationProblem, StateSpace};
use pgm_features::shape_features::{ASSOCIATION_FEATURES, OUTLIER_FEATURES};
use pgm_scan::{Pose2, ScanPair};
use rayon::prelude::*;

/// Options of [`train`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainingOptions {
    /// Candidates per return (pruned state space) for the booster samples and the CRF
    /// instances (6).
    pub candidates: usize,
    /// Candidate gate (m) as [`crate::MatchingParams::candidate_gate`] (1).
    pub candidate_gate: f64,
    /// Geometric band as [`crate::MatchingParams::band`] (8).
    pub band: usize,
    /// Stumps per booster (50, as the paper).
    pub stumps: usize,
    /// Variance of the Gaussian prior on each weight (10).
    pub prior_variance: f64,
}

impl Default for TrainingOptions {
    fn default() -> Self {
        Self {
            candidates: 6,
            candidate_gate: 1.0,
            band: 8,
            stumps: 50,
            prior_variance: 10.0,
        }
    }
}

/// What [`train`] learned and from what.
#[derive(Clone, Debug)]
pub struct TrainingReport {
    /// Pairs the boosters were trained on.
    pub booster_pairs: usize,
    /// Data-booster samples (positive ones).
    pub data_samples: (usize, usize),
    /// Outlier-booster samples (positive ones).
    pub outlier_samples: (usize, usize),
    /// Pairs the weights were learned from.
    pub weight_pairs: usize,
    /// The pseudo-likelihood optimisation.
    pub learning: LearningResult,
}

/// A pair's nodes under their true motions: candidates, the true state of each node,
/// its motion group and the groups' motions.
struct TrueStates {
    candidates: Vec<Vec<usize>>,
    states: Vec<usize>,
    group_of: Vec<usize>,
    motions: Vec<Pose2>,
}

/// Motion groups from labels: group 0 for label 0, one group per other label.
fn groups(labels: &[u32], motions: &[Pose2]) -> (Vec<usize>, Vec<Pose2>) {
    let mut ids: Vec<u32> = vec![0];
    let mut group_motions = vec![motions
        .iter()
        .zip(labels)
        .find(|(_, &l)| l == 0)
        .map_or(Pose2::identity(), |(m, _)| *m)];
    let group_of = labels
        .iter()
        .zip(motions)
        .map(|(&l, m)| match ids.iter().position(|&x| x == l) {
            Some(g) => g,
            None => {
                ids.push(l);
                group_motions.push(*m);
                ids.len() - 1
            }
        })
        .collect();
    (group_of, group_motions)
}

/// The candidates (reference indices, sorted) of every return of `pair` under its true
/// motion, with its true partner always included, and the true state of each.
fn true_candidates(
    problem: &AssociationProblem,
    pair: &ScanPair,
    options: &TrainingOptions,
) -> Result<TrueStates> {
    let truth = problem.node_truth(pair)?;
    let motions = truth.motions();
    let (group_of, group_motions) = groups(&truth.labels, &motions);
    let ego = vec![group_motions[0]; problem.len()];
    let mut candidates = problem.candidates(
        StateSpace::Pruned(options.candidates),
        &motions,
        &ego,
        options.candidate_gate,
    );
    let states = truth.true_states(&mut candidates);
    Ok(TrueStates {
        candidates,
        states,
        group_of,
        motions: group_motions,
    })
}

/// Booster samples of one pair: (data samples, outlier samples).
fn booster_samples(
    pair: &ScanPair,
    boosters: &AssociationBoosters,
    options: &TrainingOptions,
) -> Result<(TrainingSet, TrainingSet)> {
    let problem = AssociationProblem::new(pair, boosters)?;
    let TrueStates {
        candidates,
        states,
        group_of,
        motions,
    } = true_candidates(&problem, pair, options)?;
    let per_node: Vec<Pose2> = group_of.iter().map(|&g| motions[g]).collect();
    Ok(problem.booster_samples(&candidates, &states, &per_node)?)
}

/// The two trained boosters and their sample counts.
#[derive(Clone, Debug)]
pub struct TrainedBoosters {
    /// The data booster.
    pub data: Booster,
    /// The outlier booster.
    pub outlier: Booster,
    /// Data-booster samples (all, positive).
    pub data_samples: (usize, usize),
    /// Outlier-booster samples (all, positive).
    pub outlier_samples: (usize, usize),
}

/// Trains the two boosters on `pairs` (see the module docs).
pub fn train_boosters(pairs: &[ScanPair], options: &TrainingOptions) -> Result<TrainedBoosters> {
    // The samples need only the problem's geometry, not boosters.
    let placeholder = AssociationBoosters::untrained();
    let sets: Vec<(TrainingSet, TrainingSet)> = pairs
        .par_iter()
        .map(|p| booster_samples(p, &placeholder, options))
        .collect::<Result<_>>()?;
    let mut data = TrainingSet::new(ASSOCIATION_FEATURES);
    let mut outliers = TrainingSet::new(OUTLIER_FEATURES);
    for (d, o) in &sets {
        data.extend(d)?;
        outliers.extend(o)?;
    }
    let boost = BoosterParams::default().stumps(options.stumps).check()?;
    let data_booster = boost.train(&data)?;
    let outlier_booster = boost.train(&outliers)?;
    Ok(TrainedBoosters {
        data: data_booster,
        outlier: outlier_booster,
        data_samples: (data.len(), data.positives()),
        outlier_samples: (outliers.len(), outliers.positives()),
    })
}

/// The pseudo-likelihood instance of one labelled pair with the boosters of
/// `weights` (see the module docs).
pub fn training_instance(
    pair: &ScanPair,
    weights: &MatchingWeights,
    options: &TrainingOptions,
) -> Result<Option<LabelledInstance>> {
    let problem = AssociationProblem::new(pair, &weights.boosters)?;
    if problem.len() < 2 {
        return Ok(None);
    }
    let TrueStates {
        candidates,
        states,
        group_of,
        motions,
    } = true_candidates(&problem, pair, options)?;
    let model = MatchingModel::new(
        &problem,
        candidates,
        group_of,
        motions,
        &weights.weights,
        options.band,
    );
    Ok(Some(chain_instance(&model, &feature_set(), &[states])?))
}

/// Trains CRF-Matching on labelled `pairs`: boosters on the first half, weights on the
/// second (both on all pairs when there are fewer than two); the observer sees every
/// L-BFGS iteration (`&mut ()` for none).
///
/// # Errors
/// When a pair lacks ground truth (named), an option is out of range (candidates
/// outside 1..=64, a negative gate), a booster cannot be trained (no outlier or no
/// association among the samples), or learning fails.
pub fn train(
    pairs: &[ScanPair],
    options: &TrainingOptions,
    observer: &mut dyn LearningObserver,
) -> Result<(MatchingWeights, TrainingReport)> {
    if pairs.is_empty() {
        return Err(InvalidParameter::new("pairs", 0, "at least one labelled pair").into());
    }
    // Checked before anything is allocated: a candidate count of 2^64 - 1 reserved
    // that many states per return (a capacity-overflow panic, then an abort).
    if !(1..=64).contains(&options.candidates) {
        return Err(
            InvalidParameter::new("candidates", options.candidates, "1..=64 candidates").into(),
        );
    }
    InvalidParameter::non_negative(
        "candidate_gate",
        options.candidate_gate,
        "a number of metres >= 0",
    )?;
    let half = if pairs.len() >= 2 { pairs.len() / 2 } else { 1 };
    let (booster_pairs, weight_pairs) = if pairs.len() >= 2 {
        (&pairs[..half], &pairs[half..])
    } else {
        (pairs, pairs)
    };
    let TrainedBoosters {
        data,
        outlier,
        data_samples,
        outlier_samples,
    } = train_boosters(booster_pairs, options)?;
    let mut weights = MatchingWeights {
        weights: vec![0.0; WEIGHTS],
        boosters: AssociationBoosters { data, outlier },
    };
    let instances: Vec<LabelledInstance> = weight_pairs
        .par_iter()
        .map(|p| training_instance(p, &weights, options))
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .flatten()
        .collect();
    let learner = LearnerParams::default()
        .prior_variance(options.prior_variance)
        .max_iterations(3000)
        .check()?;
    let learning = learner.learn(&feature_set(), &instances, observer)?;
    weights.weights = learning.weights.values().to_vec();
    weights.check_ref()?;
    Ok((
        weights,
        TrainingReport {
            booster_pairs: booster_pairs.len(),
            data_samples,
            outlier_samples,
            weight_pairs: weight_pairs.len(),
            learning,
        },
    ))
}
