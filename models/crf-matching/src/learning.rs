//! Learning CRF-Matching from labelled pairs: the two boosters, then the 18 weights by
//! pseudo-likelihood (L-BFGS, [`pgm_core::learning`]), by the procedure it shares with
//! the joint model ([`pgm_features::matching_training`]); this module says what its
//! samples and instances are.
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
use crate::weights::{feature_set, MatchingWeights};
use crate::Result;
use pgm_core::hybrid::chain::chain_instance;
use pgm_core::learning::{LabelledInstance, LearningObserver};
use pgm_features::boosting::TrainingSet;
use pgm_features::matching_features::{groups_by_first_appearance, AssociationProblem, StateSpace};
use pgm_features::matching_training::{train_boosted, BoostedTraining, TrainingPair};
pub use pgm_features::matching_training::{TrainingOptions, TrainingReport};
use pgm_features::training::{ModelTrainer, Trained};
use pgm_scan::{Pose2, ScanPair};

/// A pair's nodes under their true motions: candidates, the true state of each node,
/// its motion group and the groups' motions.
struct TrueStates {
    candidates: Vec<Vec<usize>>,
    states: Vec<usize>,
    group_of: Vec<usize>,
    motions: Vec<Pose2>,
}

/// Motion groups from labels: group 0 for label 0 (the motion of its first node, the
/// identity without one), one group per other label
/// ([`groups_by_first_appearance`]).
fn groups(labels: &[u32], motions: &[Pose2]) -> (Vec<usize>, Vec<Pose2>) {
    let background = motions
        .iter()
        .zip(labels)
        .find(|(_, &l)| l == 0)
        .map_or(Pose2::identity(), |(m, _)| *m);
    groups_by_first_appearance(
        (0, background),
        labels.iter().copied().zip(motions.iter().copied()),
    )
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

impl BoostedTraining for MatchingWeights {
    /// Every return's candidates under its true motion (its true partner among them).
    fn booster_samples(at: &TrainingPair) -> Result<(TrainingSet, TrainingSet)> {
        let t = true_candidates(at.problem, at.pair, at.options)?;
        let per_node: Vec<Pose2> = t.group_of.iter().map(|&g| t.motions[g]).collect();
        Ok(at
            .problem
            .booster_samples(&t.candidates, &t.states, &per_node)?)
    }

    /// The chain at its true associations, with the candidates of the booster samples.
    fn training_instance(&self, at: &TrainingPair) -> Result<LabelledInstance> {
        let t = true_candidates(at.problem, at.pair, at.options)?;
        let model = MatchingModel::new(
            at.problem,
            t.candidates,
            t.group_of,
            t.motions,
            &self.weights,
            at.options.band,
        );
        Ok(chain_instance(&model, &feature_set(), &[t.states])?)
    }
}

/// Trains CRF-Matching on labelled `pairs`: boosters on the first half, weights on the
/// second (both on all pairs when there are fewer than two); the observer sees every
/// L-BFGS iteration (`&mut ()` for none).
///
/// # Errors
/// When a pair lacks ground truth (named), an option is out of range (candidates
/// outside 1..=64, a negative gate, a prior variance that is not positive, no stumps),
/// a booster cannot be trained (no outlier or no association among the samples), or
/// learning fails.
pub fn train(
    pairs: &[ScanPair],
    options: &TrainingOptions,
    observer: &mut dyn LearningObserver,
) -> Result<(MatchingWeights, TrainingReport)> {
    let (mut weights, report) = train_boosted::<MatchingWeights>(pairs, options, None, observer)?;
    weights.weights = report.learning.weights.values().to_vec();
    weights.check_ref()?;
    Ok((weights, report))
}

/// CRF-Matching's training with its options, in the shape every model's training has
/// ([`ModelTrainer`]; [`train`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MatchingTrainer {
    /// The training options.
    pub options: TrainingOptions,
}

impl ModelTrainer for MatchingTrainer {
    type Weights = MatchingWeights;

    fn train(
        &self,
        pairs: &[ScanPair],
        observer: &mut dyn LearningObserver,
    ) -> Result<Trained<MatchingWeights>> {
        let (weights, report) = train(pairs, &self.options, observer)?;
        Ok(report.into_trained(weights))
    }
}
