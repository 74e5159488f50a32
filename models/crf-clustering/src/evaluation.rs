//! Scoring clustering methods against ground truth the way Table I of the
//! CRF-Clustering paper does: homogeneity, completeness and V-measure (β = 1) per
//! pair over the current scan's labelled returns, then mean and standard deviation
//! over pairs. Shared by `pgm eval clustering`, `examples/table1.rs` and the tests.
//!
//! Methods ([`Method`]): CRF-Clustering, the consistency-based detector (CBD), motion
//! K-Means (eq. 10) and the trivial one-cluster labelling. CRF-Clustering and K-Means
//! need point associations ([`AssociationSource`]); CBD and one-cluster do not.
//!
//! **Motion error of found objects** (CRF only): a true moving object (label > 0 with
//! a known motion) is *found* when some predicted moving cluster holds more than half
//! of its points and more than half of that cluster's points are the object's. Its
//! error is the distance between where the estimated and the true motion put the
//! centroid of the object's current points (m), and the rotation error (rad). For
//! leigh-gtm1 the true motion is the annotated displacement of the person's centre
//! (with the odometry's rotation), so only the centroid error is meaningful there.

use crate::associations::{AssociationProvider, AssociationSource};
use crate::clusterer::Clusterer;
use crate::{Error, Result};
use nalgebra::Point2;
use pgm_baselines::consistency::{consistency_detect, ConsistencyParams};
use pgm_baselines::motion_kmeans::{motion_kmeans, MotionKMeansParams};
use pgm_datasets::metrics::{clustering_v_measure, VMeasure};
use pgm_datasets::ScanPair;
use pgm_features::Pose2;
use serde::Serialize;
use std::collections::HashMap;

/// A clustering method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// CRF-Clustering.
    Crf,
    /// The consistency-based detector.
    Cbd,
    /// Motion K-Means.
    KMeans,
    /// Every point in one cluster.
    OneCluster,
}

impl Method {
    /// Whether the method needs point associations.
    pub fn needs_associations(&self) -> bool {
        matches!(self, Method::Crf | Method::KMeans)
    }
}

/// Everything a method needs besides the pair.
#[derive(Clone, Debug)]
pub struct EvaluationConfig {
    /// The method.
    pub method: Method,
    /// Where associations come from (CRF, K-Means).
    pub associations: AssociationSource,
    /// CRF-Clustering with its parameters.
    pub clusterer: Clusterer,
    /// Motion K-Means parameters (`k`).
    pub kmeans: MotionKMeansParams,
    /// CBD parameters.
    pub cbd: ConsistencyParams,
}

impl EvaluationConfig {
    /// The name of the association source.
    pub fn associations_name(&self) -> &str {
        self.associations.name()
    }
}

/// The motion error of one found object.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ObjectMotionError {
    /// Distance (m) between where the estimated and the true motion put the object's
    /// centroid.
    pub centroid_error: f64,
    /// Rotation error (rad).
    pub rotation_error: f64,
}

/// The outcome of one method on one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairOutcome {
    /// The pair's name.
    pub name: String,
    /// Homogeneity, completeness and V-measure.
    pub score: VMeasure,
    /// Iterations (CRF: message-passing sweeps; K-Means: assignment rounds; else 0).
    pub iterations: usize,
    /// Number of true moving objects (labels > 0 with a known motion).
    pub true_objects: usize,
    /// Motion errors of the found objects (CRF only).
    pub motion_errors: Vec<ObjectMotionError>,
    /// The predicted labels, per beam of the current scan.
    pub labels: Vec<Option<u32>>,
}

/// Runs the configured method on one pair with ground-truth labels and scores it.
pub fn evaluate_pair(pair: &ScanPair, config: &EvaluationConfig) -> Result<PairOutcome> {
    let truth = pair
        .truth
        .as_ref()
        .and_then(|t| t.labels.as_ref())
        .ok_or_else(|| Error::BadPair {
            pair: pair.name.clone(),
            problem: "no ground-truth labels to score against".into(),
        })?;
    let mut motions: HashMap<u32, Pose2> = HashMap::new();
    let (labels, iterations) = match config.method {
        Method::OneCluster => (
            (0..pair.current.len())
                .map(|k| pair.current.valid[k].then_some(0))
                .collect(),
            0,
        ),
        Method::Cbd => (consistency_detect(pair, &config.cbd)?.labels, 0),
        Method::KMeans => {
            let a = config.associations.associate(pair)?;
            let r = motion_kmeans(pair, &a.associations, &config.kmeans)?;
            (r.labels, r.iterations)
        }
        Method::Crf => {
            let a = config.associations.associate(pair)?;
            let r = config.clusterer.cluster_pair(pair, &a)?;
            for c in &r.clusters {
                motions.insert(c.label, c.motion);
            }
            (r.labels, r.iterations)
        }
    };
    let score = clustering_v_measure(truth, &labels, 1.0).map_err(|e| Error::BadPair {
        pair: pair.name.clone(),
        problem: e.to_string(),
    })?;
    let (true_objects, motion_errors) = object_motion_errors(pair, truth, &labels, &motions);
    Ok(PairOutcome {
        name: pair.name.clone(),
        score,
        iterations,
        true_objects,
        motion_errors,
        labels,
    })
}

fn object_motion_errors(
    pair: &ScanPair,
    truth: &[Option<u32>],
    labels: &[Option<u32>],
    motions: &HashMap<u32, Pose2>,
) -> (usize, Vec<ObjectMotionError>) {
    let Some(gt) = pair.truth.as_ref() else {
        return (0, Vec::new());
    };
    let mut errors = Vec::new();
    let mut objects = 0;
    for m in gt.motions.iter().filter(|m| m.label > 0) {
        let members: Vec<usize> = (0..truth.len())
            .filter(|&k| truth[k] == Some(m.label))
            .collect();
        if members.is_empty() {
            continue;
        }
        objects += 1;
        if motions.is_empty() {
            continue;
        }
        let mut votes: HashMap<u32, usize> = HashMap::new();
        for &k in &members {
            if let Some(l) = labels[k].filter(|&l| l > 0) {
                *votes.entry(l).or_insert(0) += 1;
            }
        }
        let Some((&cluster, &overlap)) = votes
            .iter()
            .max_by_key(|(l, c)| (**c, std::cmp::Reverse(**l)))
        else {
            continue;
        };
        let cluster_size = labels.iter().filter(|&&l| l == Some(cluster)).count();
        if 2 * overlap <= members.len() || 2 * overlap <= cluster_size {
            continue;
        }
        let Some(estimate) = motions.get(&cluster) else {
            continue;
        };
        let centroid = members
            .iter()
            .fold(Point2::origin(), |acc: Point2<f64>, &k| {
                acc + pair.current.beam_point(k).coords / members.len() as f64
            });
        errors.push(ObjectMotionError {
            centroid_error: (estimate.transform_point(&centroid)
                - m.motion.transform_point(&centroid))
            .norm(),
            rotation_error: estimate.rotation_error(&m.motion),
        });
    }
    (objects, errors)
}

/// Mean and standard deviation over pairs (the `--json` object of
/// `pgm eval clustering`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Number of pairs.
    pub pairs: usize,
    /// Mean homogeneity.
    pub homogeneity_mean: f64,
    /// Standard deviation of homogeneity.
    pub homogeneity_std: f64,
    /// Mean completeness.
    pub completeness_mean: f64,
    /// Standard deviation of completeness.
    pub completeness_std: f64,
    /// Mean V-measure.
    pub v_measure_mean: f64,
    /// Standard deviation of the V-measure.
    pub v_measure_std: f64,
    /// Mean iterations.
    pub iterations_mean: f64,
}

/// Population mean and standard deviation (0, 0 for no values).
pub fn mean_std(values: &[f64]) -> (f64, f64) {
    if values.is_empty() {
        return (0.0, 0.0);
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
}

/// Summarises pair outcomes.
pub fn summarize(outcomes: &[PairOutcome]) -> Summary {
    let take = |f: fn(&PairOutcome) -> f64| mean_std(&outcomes.iter().map(f).collect::<Vec<_>>());
    let (hm, hs) = take(|o| o.score.homogeneity);
    let (cm, cs) = take(|o| o.score.completeness);
    let (vm, vs) = take(|o| o.score.v_measure);
    let (im, _) = take(|o| o.iterations as f64);
    Summary {
        pairs: outcomes.len(),
        homogeneity_mean: hm,
        homogeneity_std: hs,
        completeness_mean: cm,
        completeness_std: cs,
        v_measure_mean: vm,
        v_measure_std: vs,
        iterations_mean: im,
    }
}

/// Summary of the motion errors of found objects: (found, true objects, median
/// centroid error, median rotation error).
pub fn motion_error_summary(outcomes: &[PairOutcome]) -> (usize, usize, Option<f64>, Option<f64>) {
    let errors: Vec<&ObjectMotionError> = outcomes.iter().flat_map(|o| &o.motion_errors).collect();
    let total: usize = outcomes.iter().map(|o| o.true_objects).sum();
    let centroid: Vec<f64> = errors.iter().map(|e| e.centroid_error).collect();
    let rotation: Vec<f64> = errors.iter().map(|e| e.rotation_error).collect();
    (
        errors.len(),
        total,
        pgm_datasets::metrics::percentile(&centroid, 50.0),
        pgm_datasets::metrics::percentile(&rotation, 50.0),
    )
}
