//! Learning the weights by pseudo-likelihood (section III of the CRF-Clustering paper)
//! with the core's [`Learner`](pgm_core::learning::Learner) (L-BFGS).
//!
//! A training instance is one labelled pair: the CRF over its current scan's valid
//! points (the same chain and edges as at inference time) whose states are the pair's
//! **true clusters** (every distinct ground-truth label, background = label 0, in
//! increasing label order). The motions, observed during learning as the papers treat
//! them, are solved in closed form (eq. 3) from the points of each true cluster with
//! their associations; a cluster without associated points takes its ground-truth
//! motion when the pair has one, else the odometry prior. The features of every clique
//! are then fixed numbers, written by the same code that writes them at inference time
//! ([`ClusteringModel`]), and the pseudo-likelihood of the true labels is maximised.
//! The optional outlier state is not trained (its potential is derived from the
//! distance weight).
//!
//! Learning needs pairs with a moving object: with every point in one true cluster
//! every feature of "different clusters" is unseen and the distance weights are not
//! identifiable, so [`learn`] refuses such a training set, and it refuses weights
//! that the model would reject ([`ClusteringWeights::check_ref`]).

use crate::input::ClusteringInput;
use crate::model::{build_edges, ClusteringModel, MAX_CLUSTERS};
use crate::params::ClusteringParams;
use crate::weights::{feature_set, ClusteringWeights};
use crate::{Error, Result};
use pgm_core::hybrid::chain::{add_feature_cliques, chain_instance, FeatureTable};
use pgm_core::learning::{
    LabelledInstance, LearnerParams, LearningObjective, LearningObserver, LearningResult,
};
use pgm_core::{ParamGuard, VariableId};
use pgm_features::training::{ModelTrainer, Trained};
use pgm_scan::{AssociationSource, PointAssociations, Pose2, ScanPair};
use rayon::prelude::*;
use std::sync::Arc;

/// The labelled instance of one pair, or `None` when the pair has no ground-truth
/// labels or no valid point. `params` gives the edges (`knn`).
pub fn training_instance(
    pair: &ScanPair,
    associations: &PointAssociations,
    params: &ClusteringParams,
) -> Result<Option<LabelledInstance>> {
    let Some(truth_labels) = pair.truth.as_ref().and_then(|t| t.labels.as_ref()) else {
        return Ok(None);
    };
    if truth_labels.len() != pair.current.len() {
        return Err(Error::BadPair {
            pair: pair.name.clone(),
            problem: format!(
                "{} ground-truth labels for {} beams",
                truth_labels.len(),
                pair.current.len()
            ),
        });
    }
    let input = ClusteringInput::from_pair(pair, associations)?;
    let n = input.points.len();
    if n == 0 {
        return Ok(None);
    }
    let point_labels: Vec<u32> = input
        .beams
        .iter()
        .map(|&b| truth_labels[b].unwrap_or(0))
        .collect();
    let mut classes: Vec<u32> = point_labels.clone();
    classes.sort_unstable();
    classes.dedup();
    let k = classes.len();
    if k > MAX_CLUSTERS {
        return Err(Error::BadPair {
            pair: pair.name.clone(),
            problem: format!("{k} true clusters; the model supports at most {MAX_CLUSTERS}"),
        });
    }
    let states: Vec<usize> = point_labels
        .iter()
        .map(|l| classes.binary_search(l).unwrap_or(0))
        .collect();
    // Each true cluster's motion: solved from its associated points (eq. 3), else
    // its ground-truth motion, else the odometry prior.
    let fallback = pair.odometry.unwrap_or_default();
    let motions: Vec<Pose2> = classes
        .iter()
        .map(|&label| {
            pair.truth
                .as_ref()
                .and_then(|t| t.motions.iter().find(|m| m.label == label))
                .map_or(fallback, |m| m.motion)
        })
        .collect();
    let edges = build_edges(&input.points, params.knn);
    let mut model = ClusteringModel::new(
        &input.points,
        &input.partners,
        &input.variances,
        &edges,
        motions,
        &params.weights,
        None,
    )?;
    for (i, &s) in states.iter().enumerate() {
        model.relabel(i, None, Some(s));
    }
    model.solve_motions();
    let features = feature_set();
    let mut instance = chain_instance(&model, &features, &[states])?;
    // Edges beyond the chain (k nearest neighbours), written by the same code.
    let width = features.num_weights();
    let mut buffer = vec![0.0; k * k * width];
    for (e, edge) in edges.iter().enumerate().skip(n - 1) {
        buffer.fill(0.0);
        model.write_edge_features(e, &mut FeatureTable::new(width, &mut buffer));
        add_feature_cliques(
            &mut instance.model,
            vec![VariableId(edge.i), VariableId(edge.j)],
            vec![k, k],
            &buffer,
        )?;
    }
    Ok(Some(instance))
}

/// The training set of `pairs`: each pair once per association source (the pair
/// index and source index of each instance are kept for error messages). Pairs
/// without ground-truth labels or without a valid point give no instance.
///
/// # Errors
/// The first association or instance error, naming its pair.
pub fn training_instances(
    pairs: &[ScanPair],
    sources: &[&dyn AssociationSource],
    params: &ClusteringParams,
) -> Result<Vec<LabelledInstance>> {
    let built: Vec<Option<LabelledInstance>> = pairs
        .par_iter()
        .flat_map_iter(|p| sources.iter().map(move |s| (p, *s)))
        .map(|(p, s)| {
            let a = s.associate(p)?;
            training_instance(p, &a, params)
        })
        .collect::<Result<_>>()?;
    Ok(built.into_iter().flatten().collect())
}

/// Learns the weights from labelled instances by pseudo-likelihood with a Gaussian
/// prior of variance `prior_variance` on each weight; the observer sees every L-BFGS
/// iteration (for progress bars or logs) and may stop learning early (`&mut ()` for
/// none).
///
/// # Errors
/// When no instance has a moving object (more than one true cluster), when learning
/// fails, or when the learned weights are not usable by the model
/// ([`ClusteringWeights::check_ref`]: weights that do not penalise distance).
pub fn learn(
    instances: &[LabelledInstance],
    prior_variance: f64,
    observer: &mut dyn LearningObserver,
) -> Result<(ClusteringWeights, LearningResult)> {
    learn_with(
        instances,
        prior_variance,
        LearningObjective::PseudoLikelihood,
        observer,
    )
}

/// [`learn`] by `objective`: pseudo-likelihood, the likelihood with exact marginals
/// (only when every instance is a chain or tree: with `knn` > 1 the neighbour edges
/// close cycles, and it is refused), or the Bethe likelihood.
///
/// # Errors
/// As [`learn`], and the objective's (a cycle for maximum likelihood, belief
/// propagation that does not converge for Bethe).
pub fn learn_with(
    instances: &[LabelledInstance],
    prior_variance: f64,
    objective: LearningObjective,
    observer: &mut dyn LearningObserver,
) -> Result<(ClusteringWeights, LearningResult)> {
    let moving = instances
        .iter()
        .filter(|i| i.labels.iter().any(|&l| l != i.labels[0]))
        .count();
    if moving == 0 {
        return Err(Error::InvalidParameter {
            name: "training set",
            value: format!(
                "{} labelled pairs, none with a moving object",
                instances.len()
            ),
            expected: "pairs whose labels hold at least one moving object besides the background",
        });
    }
    let features = feature_set();
    let learner = LearnerParams::default()
        .prior_variance(prior_variance)
        .max_iterations(500)
        .objective(objective)
        .check()?;
    let result = learner.learn(&features, instances, observer)?;
    let weights = ClusteringWeights::from_weights(&result.weights);
    weights.check_ref().map_err(|e| Error::InvalidParameter {
        name: "learned weights",
        value: format!("{e}"),
        expected:
            "weights the model accepts; the training pairs do not teach it to penalise distance",
    })?;
    Ok((weights, result))
}

/// CRF-Clustering's training with its options, in the shape every model's training
/// has ([`ModelTrainer`]): the instances of every pair with each association source
/// ([`training_instances`]), then [`learn`].
#[derive(Clone)]
pub struct ClusteringTrainer {
    /// The model's parameters (the edges, `knn`, come from them).
    pub params: ClusteringParams,
    /// The association sources the training features use: each pair once per source.
    pub sources: Vec<Arc<dyn AssociationSource>>,
    /// Variance of the Gaussian prior on each weight.
    pub prior_variance: f64,
    /// What the weights maximise (pseudo-likelihood, as the paper).
    pub objective: LearningObjective,
}

impl ModelTrainer for ClusteringTrainer {
    type Weights = ClusteringWeights;

    /// Counts `instances` (labelled pairs times sources) and `pairs`.
    ///
    /// # Errors
    /// As [`training_instances`] and [`learn`], and when no pair has ground-truth
    /// labels.
    fn train(
        &self,
        pairs: &[ScanPair],
        observer: &mut dyn LearningObserver,
    ) -> Result<Trained<ClusteringWeights>> {
        self.params.check_ref()?;
        let sources: Vec<&dyn AssociationSource> =
            self.sources.iter().map(|s| s.as_ref()).collect();
        let instances = training_instances(pairs, &sources, &self.params)?;
        if instances.is_empty() {
            return Err(Error::InvalidParameter {
                name: "training set",
                value: format!("{} pairs, none with ground-truth labels", pairs.len()),
                expected: "pairs whose returns have ground-truth labels",
            });
        }
        let (weights, learning) =
            learn_with(&instances, self.prior_variance, self.objective, observer)?;
        Ok(Trained {
            weights,
            counts: vec![("instances", instances.len()), ("pairs", pairs.len())],
            learning,
        })
    }
}
