//! One evaluation loop for every method: a [`MotionClusterer`] scored against
//! ground-truth labels the way Table I of the CRF-Clustering paper does, and a
//! [`ScanMatcher`] scored against ground-truth ego-motions. The command-line tool,
//! the examples and the tests all run methods through these functions, so a new
//! model is evaluated by implementing a trait.
//!
//! **Clustering.** Homogeneity, completeness and V-measure (β = 1) per pair over the
//! current scan's labelled returns, then mean and standard deviation over pairs
//! ([`evaluate_clustering`]). A pair without a labelled return cannot be scored: it
//! is not a pair of the evaluation (see [`scorable_for_clustering`]), never a pair
//! with V = 1.
//!
//! **Motion error of found objects.** A true moving object (label > 0 with a known
//! motion) is *found* when some predicted moving cluster holds more than half of its
//! points and more than half of that cluster's points are the object's. Its error is
//! the distance between where the estimated and the true motion put the centroid of
//! the object's current points (m), and the rotation error (rad). Only methods that
//! estimate motions (CRF-Clustering, motion K-Means) have errors. For leigh-gtm1 the
//! true motion is the annotated displacement of the person's centre (with the
//! odometry's rotation), so only the centroid error is meaningful there.
//!
//! **Scan matching.** The translation and rotation error of the estimated ego-motion
//! ([`crate::metrics::motion_error`]) summarised by median and 90th percentile
//! ([`evaluate_matching`]); a pair the method cannot run on keeps the prior and, like
//! a pair where the method did not converge (too few correspondences), is counted.

use crate::error::{Error, Result};
use crate::metrics::{
    clustering_v_measure, motion_error, percentile, summarize_errors, ErrorSummary, MotionError,
    VMeasure,
};
use nalgebra::Point2;
use pgm_features::methods::{MotionClusterer, ScanMatcher};
use pgm_features::{Pose2, ScanPair};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};

/// The motion error of one found object.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ObjectMotionError {
    /// Distance (m) between where the estimated and the true motion put the object's
    /// centroid.
    pub centroid_error: f64,
    /// Rotation error (rad).
    pub rotation_error: f64,
}

/// The outcome of one clustering method on one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClusteringOutcome {
    /// The pair's name.
    pub name: String,
    /// Homogeneity, completeness and V-measure.
    pub score: VMeasure,
    /// Iterations the method reported.
    pub iterations: usize,
    /// Whether the method converged.
    pub converged: bool,
    /// Number of true moving objects (labels > 0 with a known motion).
    pub true_objects: usize,
    /// Motion errors of the found objects (methods that estimate motions).
    pub motion_errors: Vec<ObjectMotionError>,
    /// The predicted labels, per beam of the current scan.
    pub labels: Vec<Option<u32>>,
}

/// Mean and standard deviation over pairs (the `--json` object of
/// `pgm eval clustering`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ClusteringSummary {
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

/// The motion errors of the objects a method found, over all pairs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FoundObjects {
    /// Objects found.
    pub found: usize,
    /// True moving objects with a known motion.
    pub total: usize,
    /// Median centroid error (m) of the found objects, if any.
    pub centroid_error_median: Option<f64>,
    /// Median rotation error (rad) of the found objects, if any.
    pub rotation_error_median: Option<f64>,
}

/// Everything [`evaluate_clustering`] measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClusteringReport {
    /// The method's name.
    pub method: String,
    /// One outcome per pair, in the pairs' order.
    pub outcomes: Vec<ClusteringOutcome>,
    /// Mean and standard deviation over the pairs.
    pub summary: ClusteringSummary,
    /// Motion errors of the found objects.
    pub found_objects: FoundObjects,
}

/// Whether a pair can score a clustering: it has ground-truth labels with at least one
/// labelled return.
pub fn scorable_for_clustering(pair: &ScanPair) -> bool {
    pair.truth
        .as_ref()
        .and_then(|t| t.labels.as_ref())
        .is_some_and(|l| l.iter().any(Option::is_some))
}

/// Runs `method` on one pair and scores it.
///
/// # Errors
/// When the pair has no labelled return ([`scorable_for_clustering`]) or the method
/// fails; the error names the pair.
pub fn evaluate_clustering_pair(
    pair: &ScanPair,
    method: &dyn MotionClusterer,
) -> Result<ClusteringOutcome> {
    let truth = pair
        .truth
        .as_ref()
        .and_then(|t| t.labels.as_ref())
        .filter(|_| scorable_for_clustering(pair))
        .ok_or_else(|| Error::Unscorable {
            pair: pair.name.clone(),
            what: "no ground-truth label on any return of the current scan".into(),
        })?;
    let result = method.cluster(pair).map_err(|e| Error::Method {
        pair: pair.name.clone(),
        method: method.name(),
        source: Box::new(e),
    })?;
    let score =
        clustering_v_measure(truth, &result.labels, 1.0).map_err(|e| Error::Unscorable {
            pair: pair.name.clone(),
            what: e.to_string(),
        })?;
    let motions: HashMap<u32, Pose2> = result.motions.iter().map(|m| (m.label, m.motion)).collect();
    let (true_objects, motion_errors) = object_motion_errors(pair, truth, &result.labels, &motions);
    Ok(ClusteringOutcome {
        name: pair.name.clone(),
        score,
        iterations: result.iterations,
        converged: result.converged,
        true_objects,
        motion_errors,
        labels: result.labels,
    })
}

/// Runs `method` on every pair (in parallel) and scores it (see the module docs).
///
/// # Errors
/// When `pairs` is empty or a pair fails ([`evaluate_clustering_pair`]).
pub fn evaluate_clustering(
    pairs: &[ScanPair],
    method: &dyn MotionClusterer,
) -> Result<ClusteringReport> {
    if pairs.is_empty() {
        return Err(Error::Unscorable {
            pair: "(none)".into(),
            what: "no pair to evaluate".into(),
        });
    }
    let outcomes: Vec<ClusteringOutcome> = pairs
        .par_iter()
        .map(|p| evaluate_clustering_pair(p, method))
        .collect::<Result<_>>()?;
    Ok(ClusteringReport {
        method: method.name(),
        summary: summarize_clustering(&outcomes),
        found_objects: found_objects(&outcomes),
        outcomes,
    })
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

/// Mean and standard deviation of the pair outcomes.
pub fn summarize_clustering(outcomes: &[ClusteringOutcome]) -> ClusteringSummary {
    let take =
        |f: fn(&ClusteringOutcome) -> f64| mean_std(&outcomes.iter().map(f).collect::<Vec<_>>());
    let (hm, hs) = take(|o| o.score.homogeneity);
    let (cm, cs) = take(|o| o.score.completeness);
    let (vm, vs) = take(|o| o.score.v_measure);
    let (im, _) = take(|o| o.iterations as f64);
    ClusteringSummary {
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

/// The motion errors of the found objects over all outcomes.
pub fn found_objects(outcomes: &[ClusteringOutcome]) -> FoundObjects {
    let errors: Vec<&ObjectMotionError> = outcomes.iter().flat_map(|o| &o.motion_errors).collect();
    let centroid: Vec<f64> = errors.iter().map(|e| e.centroid_error).collect();
    let rotation: Vec<f64> = errors.iter().map(|e| e.rotation_error).collect();
    FoundObjects {
        found: errors.len(),
        total: outcomes.iter().map(|o| o.true_objects).sum(),
        centroid_error_median: percentile(&centroid, 50.0),
        rotation_error_median: percentile(&rotation, 50.0),
    }
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

/// The outcome of a scan matcher on one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MatchingOutcome {
    /// The pair's name.
    pub name: String,
    /// The estimate's error against the true ego-motion.
    pub error: MotionError,
    /// Seconds between the two scans.
    pub time_gap: f64,
    /// Whether the method converged (false where it fell back to the prior).
    pub converged: bool,
    /// Why not, when the method said.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// Everything [`evaluate_matching`] measured (the `--json` object of
/// `pgm eval matching`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MatchingReport {
    /// The method's name.
    pub method: String,
    /// Errors over all pairs.
    #[serde(flatten)]
    pub all: ErrorSummary,
    /// Pairs where the method did not converge or could not run (its estimate there
    /// is its fallback, usually the prior).
    pub not_converged: usize,
    /// Subsets by time gap (`near`, `far`) when asked for.
    pub subsets: BTreeMap<String, ErrorSummary>,
    /// One outcome per pair.
    #[serde(skip)]
    pub outcomes: Vec<MatchingOutcome>,
}

/// Runs `matcher` on every pair with a ground-truth ego-motion (in parallel) and
/// summarises the errors; with `near_seconds`, also the subsets of pairs less than
/// (`near`) and at least (`far`) that many seconds apart. A pair the matcher fails
/// on is scored at its odometry prior (the identity without one) and counted as not
/// converged.
///
/// # Errors
/// When no pair has a ground-truth ego-motion.
pub fn evaluate_matching(
    pairs: &[ScanPair],
    matcher: &dyn ScanMatcher,
    near_seconds: Option<f64>,
) -> Result<MatchingReport> {
    let with_truth: Vec<(&ScanPair, Pose2)> = pairs
        .iter()
        .filter_map(|p| p.truth.as_ref()?.ego_motion.map(|e| (p, e)))
        .collect();
    if with_truth.is_empty() {
        return Err(Error::Unscorable {
            pair: format!("(all {} pairs)", pairs.len()),
            what: "no ground-truth ego-motion".into(),
        });
    }
    let outcomes: Vec<MatchingOutcome> = with_truth
        .par_iter()
        .map(|(pair, truth)| {
            let (estimate, converged, note) = match matcher.estimate(pair) {
                Ok(e) => (e.motion, e.converged, e.note),
                Err(e) => (
                    pair.odometry.unwrap_or_default(),
                    false,
                    Some(e.to_string()),
                ),
            };
            MatchingOutcome {
                name: pair.name.clone(),
                error: motion_error(&estimate, truth),
                time_gap: pair.time_gap().abs(),
                converged,
                note,
            }
        })
        .collect();
    let errors: Vec<MotionError> = outcomes.iter().map(|o| o.error).collect();
    let all = summarize_errors(&errors).ok_or_else(|| Error::Unscorable {
        pair: "(none)".into(),
        what: "no pair to score".into(),
    })?;
    let mut subsets = BTreeMap::new();
    if let Some(near) = near_seconds {
        for (name, keep) in [("near", true), ("far", false)] {
            let set: Vec<MotionError> = outcomes
                .iter()
                .filter(|o| (o.time_gap < near) == keep)
                .map(|o| o.error)
                .collect();
            if let Some(s) = summarize_errors(&set) {
                subsets.insert(name.to_string(), s);
            }
        }
    }
    Ok(MatchingReport {
        method: matcher.name().to_string(),
        all,
        not_converged: outcomes.iter().filter(|o| !o.converged).count(),
        subsets,
        outcomes,
    })
}
