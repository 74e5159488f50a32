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
//! (eqs. 2, 4-6) are then fixed numbers and the pseudo-likelihood of the true labels
//! is maximised. The optional outlier state is not trained (its potential is derived
//! from the distance weight).

use crate::associations::PointAssociations;
use crate::clusterer::{ClusteringInput, ClusteringParams};
use crate::model::{build_edges, MAX_CLUSTERS};
use crate::weights::{feature_set, templates, ClusteringWeights};
use crate::{Error, Result};
use pgm_core::learning::{
    DenseFeatures, LabelledInstance, LearnerParams, LearningResult, LogLinearModel,
};
use pgm_core::VariableId;
use pgm_datasets::ScanPair;
use pgm_features::clustering::{distance_feature, stiffness_feature};
use pgm_features::{Pose2, RigidAlignment};

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
    let fallback = pair.odometry.unwrap_or_default();
    let motions: Vec<Pose2> = classes
        .iter()
        .enumerate()
        .map(|(c, &label)| {
            let mut stats = RigidAlignment::new();
            for (i, _) in states.iter().enumerate().filter(|(_, &s)| s == c) {
                if let Some(g) = &input.partners[i] {
                    stats.add(&input.points[i], g, 1.0 / input.variances[i]);
                }
            }
            stats.solve().map(|a| a.motion).unwrap_or_else(|| {
                pair.truth
                    .as_ref()
                    .and_then(|t| t.motions.iter().find(|m| m.label == label))
                    .map_or(fallback, |m| m.motion)
            })
        })
        .collect();
    let features = feature_set();
    let mut model = LogLinearModel::new(features, &vec![k; n])?;
    for i in 0..n {
        let table = match &input.partners[i] {
            Some(g) => motions
                .iter()
                .flat_map(|m| {
                    let d = distance_feature(m, &input.points[i], g);
                    [d, d / input.variances[i]]
                })
                .collect(),
            None => vec![0.0; 2 * k],
        };
        model.add_clique(
            templates::DISTANCE,
            DenseFeatures::new(vec![VariableId(i)], vec![k], 2, table)?,
        )?;
    }
    for edge in build_edges(&input.points, params.knn) {
        let scope = vec![VariableId(edge.i), VariableId(edge.j)];
        let mut neighbour = Vec::with_capacity(2 * k * k);
        let mut weighted = Vec::with_capacity(2 * k * k);
        let mut stiffness = Vec::with_capacity(2 * k * k);
        for a in 0..k {
            for b in 0..k {
                let same = a == b;
                let f = stiffness_feature(
                    &motions[a],
                    &motions[b],
                    &input.points[edge.i],
                    &input.points[edge.j],
                );
                let (x, y) = if same { (1.0, 0.0) } else { (0.0, 1.0) };
                neighbour.extend([x, y]);
                weighted.extend([x * edge.inverse_distance, y * edge.inverse_distance]);
                stiffness.extend([x * f, y * f]);
            }
        }
        model.add_clique(
            templates::NEIGHBOUR,
            DenseFeatures::new(scope.clone(), vec![k, k], 2, neighbour)?,
        )?;
        model.add_clique(
            templates::WEIGHTED_NEIGHBOUR,
            DenseFeatures::new(scope.clone(), vec![k, k], 2, weighted)?,
        )?;
        model.add_clique(
            templates::STIFFNESS,
            DenseFeatures::new(scope, vec![k, k], 2, stiffness)?,
        )?;
    }
    Ok(Some(LabelledInstance::new(model, states)))
}

/// Learns the weights from labelled instances by pseudo-likelihood with a Gaussian
/// prior of variance `prior_variance` on each weight.
pub fn learn(
    instances: &[LabelledInstance],
    prior_variance: f64,
) -> Result<(ClusteringWeights, LearningResult)> {
    let features = feature_set();
    let learner = LearnerParams::default()
        .prior_variance(prior_variance)
        .max_iterations(500)
        .check()?;
    let result = learner.learn(&features, instances, &mut ())?;
    Ok((ClusteringWeights::from_weights(&result.weights), result))
}

/// [`learn`] with an observer that sees every L-BFGS iteration (for progress bars or
/// logs) and may stop learning early.
pub fn learn_with_observer(
    instances: &[LabelledInstance],
    prior_variance: f64,
    observer: &mut dyn pgm_core::learning::LearningObserver,
) -> Result<(ClusteringWeights, LearningResult)> {
    let features = feature_set();
    let learner = LearnerParams::default()
        .prior_variance(prior_variance)
        .max_iterations(500)
        .check()?;
    let result = learner.learn(&features, instances, observer)?;
    Ok((ClusteringWeights::from_weights(&result.weights), result))
}
