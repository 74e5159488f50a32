//! Training a model built on the association chain ([`crate::matching_features`]):
//! CRF-Matching, and the joint model, which learns the same two boosters by the same
//! procedure. One set of options, one report and one procedure ([`train_boosted`]);
//! each model says what its booster samples and its training instances are
//! ([`BoostedTraining`]).
//!
//! 1. **Boosters** on the first half of the pairs (all of them when there are fewer
//!    than two): the data booster sees every return's candidates under its true motion
//!    as samples, positive for its true partner; the outlier booster sees the return,
//!    positive when it is an outlier.
//! 2. **Weights** on the second half: the pseudo-likelihood of each pair's true states
//!    under the model's CRF with the boosters of step 1 is maximised (L-BFGS, at most
//!    3000 iterations, a Gaussian prior on each weight), or the objective
//!    [`TrainingOptions::objective`] names: the likelihood with exact chain marginals
//!    (the association chain is a chain) or the Bethe likelihood.

use crate::boosting::{Booster, BoosterParams, TrainingSet};
use crate::matching_features::{AssociationBoosters, AssociationProblem};
use crate::shape_features::{ASSOCIATION_FEATURES, OUTLIER_FEATURES};
use crate::weight_file::ModelWeights;
use crate::ModelResult;
use pgm_core::learning::{
    LabelledInstance, LearnerParams, LearningObjective, LearningObserver, LearningResult,
};
use pgm_core::param::InvalidParameter;
use pgm_core::ParamGuard;
use pgm_scan::ScanPair;
use rayon::prelude::*;

/// Options of the training of a model with an association chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainingOptions {
    /// Candidates per return (pruned state space) for the booster samples and the CRF
    /// instances (6).
    pub candidates: usize,
    /// Candidate gate (m), as the model's `candidate_gate` (1).
    pub candidate_gate: f64,
    /// Geometric band, as the model's `band` (8).
    pub band: usize,
    /// Stumps per booster (50, as the paper).
    pub stumps: usize,
    /// Variance of the Gaussian prior on each weight (10).
    pub prior_variance: f64,
    /// What the weights maximise (pseudo-likelihood, as the papers).
    pub objective: LearningObjective,
}

impl TrainingOptions {
    /// Checks the options before anything is allocated (a candidate count of 2^64 − 1
    /// would reserve that many states per return).
    ///
    /// # Errors
    /// [`crate::ModelError::InvalidParameter`] naming the option: candidates outside
    /// 1..=64, a negative or non-finite gate or prior variance (the variance must be
    /// positive), no stumps.
    pub fn check(&self) -> ModelResult<()> {
        crate::association_rounds::check_candidates(self.candidates)?;
        InvalidParameter::non_negative(
            "candidate_gate",
            self.candidate_gate,
            "a number of metres >= 0",
        )?;
        InvalidParameter::positive(
            "prior_variance",
            self.prior_variance,
            "a finite variance > 0",
        )?;
        if self.stumps == 0 {
            return Err(InvalidParameter::new("stumps", 0, "at least 1 stump").into());
        }
        Ok(())
    }
}

impl Default for TrainingOptions {
    fn default() -> Self {
        Self {
            candidates: 6,
            candidate_gate: 1.0,
            band: 8,
            stumps: 50,
            prior_variance: 10.0,
            objective: LearningObjective::PseudoLikelihood,
        }
    }
}

/// What a training run learned and from what.
#[derive(Clone, Debug)]
pub struct TrainingReport {
    /// Pairs the boosters were trained on (0 when they were given).
    pub booster_pairs: usize,
    /// Data-booster samples (all, positive).
    pub data_samples: (usize, usize),
    /// Outlier-booster samples (all, positive).
    pub outlier_samples: (usize, usize),
    /// Pairs the weights were learned from.
    pub weight_pairs: usize,
    /// The pseudo-likelihood optimisation (its weights are the learned ones).
    pub learning: LearningResult,
}

impl TrainingReport {
    /// The counts of the report by name, as [`crate::training::Trained::counts`]
    /// gives them.
    pub fn counts(&self) -> Vec<(&'static str, usize)> {
        vec![
            ("booster_pairs", self.booster_pairs),
            ("data_samples", self.data_samples.0),
            ("data_positives", self.data_samples.1),
            ("outlier_samples", self.outlier_samples.0),
            ("outlier_positives", self.outlier_samples.1),
            ("weight_pairs", self.weight_pairs),
        ]
    }

    /// `weights` with this report's counts and optimisation, as
    /// [`crate::training::ModelTrainer::train`] returns them.
    pub fn into_trained<W>(self, weights: W) -> crate::training::Trained<W> {
        crate::training::Trained {
            weights,
            counts: self.counts(),
            learning: self.learning,
        }
    }
}

/// The two trained boosters and their sample counts.
#[derive(Clone, Debug)]
pub struct TrainedBoosters {
    /// The data and outlier boosters.
    pub boosters: AssociationBoosters,
    /// Data-booster samples (all, positive).
    pub data_samples: (usize, usize),
    /// Outlier-booster samples (all, positive).
    pub outlier_samples: (usize, usize),
}

/// A model with an association chain, as [`train_boosted`] trains it: the weight type
/// says what its samples and instances are (the instances are written with
/// [`ModelWeights::untrained`] weights and the trained boosters).
pub trait BoostedTraining: ModelWeights<Parts = AssociationBoosters> + Sync {
    /// The (data, outlier) booster samples of one labelled pair (its problem has
    /// untrained boosters).
    ///
    /// # Errors
    /// When the pair lacks ground truth (named).
    fn booster_samples(at: &TrainingPair) -> ModelResult<(TrainingSet, TrainingSet)>;

    /// The pseudo-likelihood instance of one labelled pair of at least two returns,
    /// written with these weights' boosters (its problem has them).
    ///
    /// # Errors
    /// When the pair lacks ground truth (named).
    fn training_instance(&self, at: &TrainingPair) -> ModelResult<LabelledInstance>;
}

/// A labelled pair as a model's training sees it.
#[derive(Clone, Copy)]
pub struct TrainingPair<'a> {
    /// The pair, with its ground truth.
    pub pair: &'a ScanPair,
    /// Its association problem (with the boosters of the step).
    pub problem: &'a AssociationProblem,
    /// The training options.
    pub options: &'a TrainingOptions,
}

/// Trains the two boosters of `W` on `pairs` (step 1 of the module docs).
///
/// # Errors
/// When an option is out of range, a pair lacks ground truth, or a booster cannot be
/// trained (no outlier or no association among the samples).
pub fn train_boosters<W: BoostedTraining>(
    pairs: &[ScanPair],
    options: &TrainingOptions,
) -> ModelResult<TrainedBoosters> {
    options.check()?;
    // The samples need only the problem's geometry, not boosters.
    let placeholder = AssociationBoosters::untrained();
    let sets: Vec<(TrainingSet, TrainingSet)> = pairs
        .par_iter()
        .map(|pair| {
            let problem = AssociationProblem::new(pair, &placeholder)?;
            W::booster_samples(&TrainingPair {
                pair,
                problem: &problem,
                options,
            })
        })
        .collect::<ModelResult<_>>()?;
    let mut data = TrainingSet::new(ASSOCIATION_FEATURES);
    let mut outliers = TrainingSet::new(OUTLIER_FEATURES);
    for (d, o) in &sets {
        data.extend(d)?;
        outliers.extend(o)?;
    }
    let boost = BoosterParams::default().stumps(options.stumps).check()?;
    let train = |set: &TrainingSet| -> ModelResult<Booster> { Ok(boost.train(set)?) };
    Ok(TrainedBoosters {
        boosters: AssociationBoosters {
            data: train(&data)?,
            outlier: train(&outliers)?,
        },
        data_samples: (data.len(), data.positives()),
        outlier_samples: (outliers.len(), outliers.positives()),
    })
}

/// Trains `W` on labelled `pairs` (see the module docs), with its boosters `given`
/// (then no booster is trained, and the weights are still learned on the second half)
/// or trained; the observer sees every L-BFGS iteration (`&mut ()` for none). Returns
/// the untrained weights with the boosters, and the report, whose
/// `learning.weights` the model takes as its weights.
///
/// # Errors
/// When there is no pair, an option is out of range, a pair lacks ground truth
/// (named), a booster cannot be trained, or learning fails.
pub fn train_boosted<W: BoostedTraining>(
    pairs: &[ScanPair],
    options: &TrainingOptions,
    given: Option<&AssociationBoosters>,
    observer: &mut dyn LearningObserver,
) -> ModelResult<(W, TrainingReport)> {
    if pairs.is_empty() {
        return Err(InvalidParameter::new("pairs", 0, "at least one labelled pair").into());
    }
    options.check()?;
    let (booster_pairs, weight_pairs) = if pairs.len() >= 2 {
        pairs.split_at(pairs.len() / 2)
    } else {
        (pairs, pairs)
    };
    let (trained, booster_pairs) = match given {
        Some(boosters) => (
            TrainedBoosters {
                boosters: boosters.clone(),
                data_samples: (0, 0),
                outlier_samples: (0, 0),
            },
            0,
        ),
        None => (
            train_boosters::<W>(booster_pairs, options)?,
            booster_pairs.len(),
        ),
    };
    let weights = W::untrained(trained.boosters.clone());
    let instance = |pair: &ScanPair| -> ModelResult<Option<LabelledInstance>> {
        let problem = AssociationProblem::new(pair, &trained.boosters)?;
        if problem.len() < 2 {
            return Ok(None);
        }
        let at = TrainingPair {
            pair,
            problem: &problem,
            options,
        };
        Ok(Some(weights.training_instance(&at)?))
    };
    let instances: Vec<LabelledInstance> = weight_pairs
        .par_iter()
        .map(instance)
        .collect::<ModelResult<Vec<_>>>()?
        .into_iter()
        .flatten()
        .collect();
    let learner = LearnerParams::default()
        .prior_variance(options.prior_variance)
        .max_iterations(3000)
        .objective(options.objective)
        .check()?;
    let learning = learner.learn(&W::feature_set(), &instances, observer)?;
    Ok((
        weights,
        TrainingReport {
            booster_pairs,
            data_samples: trained.data_samples,
            outlier_samples: trained.outlier_samples,
            weight_pairs: weight_pairs.len(),
            learning,
        },
    ))
}
