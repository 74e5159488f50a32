//! One evaluation loop for every method: a [`MotionClusterer`] scored against
//! ground-truth labels the way Table I of the CRF-Clustering paper does, a
//! [`ScanMatcher`] scored against ground-truth ego-motions, an [`AssociationSource`]
//! and a [`JointEstimator`] scored the way Tables I-III of the joint paper do. The command-line tool,
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
//! **Detection** (issue 18; [`DetectionSummary`], computed over the labelled returns of
//! each pair's current scan). A true moving object is a label > 0 with at least one
//! return. It is *detected* when one reported moving cluster (predicted label > 0)
//! holds at least half of the object's returns and at least half of that cluster's
//! returns are the object's. Objects with fewer than
//! [`DetectionOptions::min_object_returns`] returns (default 5) are left out of the
//! recall (`object_recall` = detected / counted objects). A reported moving cluster is
//! a *false alarm* when fewer than half of its returns belong to any true moving object
//! (so a cluster on a small object left out of the recall is not one);
//! `false_alarms_per_pair` is their number over all pairs divided by the pairs, and
//! `false_alarm_pair_share` the share of the pairs without a labelled mover in which
//! something is reported moving. `moving_precision` and `moving_recall` are point-level,
//! pooled over all pairs: returns predicted moving that are moving, over those predicted
//! moving, and over those moving. The motion error of the detected (and counted)
//! objects with a known true motion is summarised by its median:
//! `object_translation_error_median` is the distance between where the estimated and
//! the true motion put the object's centroid (m), `object_rotation_error_median` the
//! rotation error (rad). `v_measure_mean` is the mean V-measure over all pairs and
//! `v_measure_mover_pairs` over the pairs with a labelled mover only: on a pair without
//! a mover the V-measure is all or nothing (1 for one cluster, 0 for any split).
//!
//! **Associations** (Table I of the joint paper; [`evaluate_association`]): exact
//! accuracy, accuracy within one beam, string edit distance and outlier percentages
//! per pair ([`score_associations`]), then means over the pairs.
//!
//! **Joint methods** (Tables I-III of the joint paper; [`evaluate_joint`]): a
//! [`JointEstimator`]'s associations, clusters with the outlier cluster, object
//! motions and ego-motion, scored together; see [`evaluate_joint`] for the rules.
//!
//! **Scan matching.** The translation and rotation error of the estimated ego-motion
//! ([`pgm_datasets::metrics::motion_error`]) summarised by median and 90th percentile
//! ([`evaluate_matching`]); a pair the method cannot run on keeps the prior and, like
//! a pair where the method did not converge (too few correspondences), is counted.

use nalgebra::Point2;
use pgm_datasets::error::{Error, Result};
use pgm_datasets::metrics::{
    association_accuracy_within, association_edit_distance, cluster_outlier_stats, clustering_sed,
    clustering_v_measure, homogeneity_completeness_v_measure, joint_truth, match_clusterings,
    motion_error, outlier_stats, percentile, summarize_errors, ClusterMatching, ErrorSummary,
    MotionError, OutlierStats, VMeasure,
};
use pgm_scan::association::AssociationSource;
use pgm_scan::methods::{
    JointCluster, JointEstimate, JointEstimator, MotionClusterer, ScanMatcher,
};
use pgm_scan::{Association, Pose2, ScanPair};
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
    /// Detection of each true moving object (module docs).
    pub objects: Vec<ObjectDetection>,
    /// Reported moving clusters that are false alarms.
    pub false_alarms: usize,
    /// Whether the pair has a labelled mover (a return with a true label > 0).
    pub has_mover: bool,
    /// Whether the method reported something moving (a labelled return with a
    /// predicted label > 0).
    pub reported_moving: bool,
    /// Point-level counts over the labelled returns.
    pub moving_points: MovingPoints,
}

/// Options of the detection metrics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct DetectionOptions {
    /// Objects with fewer returns in the current scan are left out of the recall.
    pub min_object_returns: usize,
}

impl Default for DetectionOptions {
    fn default() -> Self {
        Self {
            min_object_returns: 5,
        }
    }
}

/// How one true moving object fared.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ObjectDetection {
    /// Its true label.
    pub label: u32,
    /// Its returns in the current scan.
    pub returns: usize,
    /// Whether it counts for the recall (at least the minimum number of returns).
    pub counted: bool,
    /// Whether a reported moving cluster found it (module docs).
    pub detected: bool,
    /// The motion error, when detected, with a known true motion and a motion estimate
    /// for the cluster.
    pub error: Option<ObjectMotionError>,
}

/// Point-level counts over the labelled returns of one pair.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct MovingPoints {
    /// Returns predicted moving that are moving.
    pub true_positive: usize,
    /// Returns predicted moving.
    pub predicted: usize,
    /// Returns that are moving.
    pub actual: usize,
}

/// The detection metrics over all pairs (module docs; the field names are those of
/// the `pgm eval clustering --json` object).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DetectionSummary {
    /// Objects with fewer returns were left out of the recall.
    pub min_object_returns: usize,
    /// True moving objects counted for the recall.
    pub objects_counted: usize,
    /// Of those, detected.
    pub objects_detected: usize,
    /// `objects_detected / objects_counted` (`None` without a counted object).
    pub object_recall: Option<f64>,
    /// False alarms over all pairs divided by the number of pairs.
    pub false_alarms_per_pair: f64,
    /// Pairs without a labelled mover.
    pub pairs_without_mover: usize,
    /// Share of the pairs without a labelled mover in which something is reported
    /// moving (`None` without such pairs).
    pub false_alarm_pair_share: Option<f64>,
    /// Point-level precision of "moving" (`None` when nothing is predicted moving).
    pub moving_precision: Option<f64>,
    /// Point-level recall of "moving" (`None` when nothing moves).
    pub moving_recall: Option<f64>,
    /// Median centroid error (m) of the detected objects with motions.
    pub object_translation_error_median: Option<f64>,
    /// Median rotation error (rad) of the detected objects with motions.
    pub object_rotation_error_median: Option<f64>,
    /// Mean V-measure over all pairs.
    pub v_measure_mean: f64,
    /// Pairs with a labelled mover.
    pub mover_pairs: usize,
    /// Mean V-measure over the pairs with a labelled mover (`None` without such pairs).
    pub v_measure_mover_pairs: Option<f64>,
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
    /// The detection metrics.
    pub detection: DetectionSummary,
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
/// When the pair has no labelled return ([`scorable_for_clustering`]), a scan
/// without a valid return, or the method fails; the error names the pair (and the
/// scan).
pub fn evaluate_clustering_pair(
    pair: &ScanPair,
    method: &dyn MotionClusterer,
) -> Result<ClusteringOutcome> {
    evaluate_clustering_pair_with(pair, method, &DetectionOptions::default())
}

/// [`evaluate_clustering_pair`] with the given detection options.
///
/// # Errors
/// As [`evaluate_clustering_pair`].
pub fn evaluate_clustering_pair_with(
    pair: &ScanPair,
    method: &dyn MotionClusterer,
    detection: &DetectionOptions,
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
    // Every method gets the same verdict: a scan without a return leaves nothing to
    // compare (CRF-Clustering refused such a pair while CBD scored it as all static).
    for (which, scan) in [("reference", &pair.reference), ("current", &pair.current)] {
        if !scan.valid.iter().any(|&v| v) {
            return Err(Error::Unscorable {
                pair: pair.name.clone(),
                what: format!(
                    "the {which} scan has no valid return among its {} beams",
                    scan.len()
                ),
            });
        }
    }
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
    if result.labels.len() != truth.len() {
        return Err(Error::Unscorable {
            pair: pair.name.clone(),
            what: format!(
                "{} predicted labels for {} beams",
                result.labels.len(),
                truth.len()
            ),
        });
    }
    let (true_objects, motion_errors) = object_motion_errors(pair, truth, &result.labels, &motions);
    let scored = detect(pair, truth, &result.labels, &motions, detection);
    Ok(ClusteringOutcome {
        name: pair.name.clone(),
        score,
        iterations: result.iterations,
        converged: result.converged,
        true_objects,
        motion_errors,
        labels: result.labels,
        objects: scored.objects,
        false_alarms: scored.false_alarms,
        has_mover: scored.has_mover,
        reported_moving: scored.reported_moving,
        moving_points: scored.moving_points,
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
    evaluate_clustering_with(pairs, method, &DetectionOptions::default())
}

/// [`evaluate_clustering`] with the given detection options.
///
/// # Errors
/// As [`evaluate_clustering`].
pub fn evaluate_clustering_with(
    pairs: &[ScanPair],
    method: &dyn MotionClusterer,
    detection: &DetectionOptions,
) -> Result<ClusteringReport> {
    if pairs.is_empty() {
        return Err(Error::NothingToScore {
            what: "no pair to evaluate".into(),
        });
    }
    let outcomes: Vec<ClusteringOutcome> = pairs
        .par_iter()
        .map(|p| evaluate_clustering_pair_with(p, method, detection))
        .collect::<Result<_>>()?;
    Ok(ClusteringReport {
        method: method.name(),
        summary: summarize_clustering(&outcomes),
        found_objects: found_objects(&outcomes),
        detection: summarize_detection(&outcomes, detection),
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

struct PairDetection {
    objects: Vec<ObjectDetection>,
    false_alarms: usize,
    has_mover: bool,
    reported_moving: bool,
    moving_points: MovingPoints,
}

/// The detection figures of one pair (module docs); `truth` and `labels` have one
/// entry per beam of the current scan.
fn detect(
    pair: &ScanPair,
    truth: &[Option<u32>],
    labels: &[Option<u32>],
    motions: &HashMap<u32, Pose2>,
    options: &DetectionOptions,
) -> PairDetection {
    // Overlap counts over the labelled returns: (true label, predicted label) -> returns.
    let mut overlap: BTreeMap<(u32, u32), usize> = BTreeMap::new();
    let mut object_size: BTreeMap<u32, usize> = BTreeMap::new();
    let mut cluster_size: BTreeMap<u32, usize> = BTreeMap::new();
    let mut cluster_moving: BTreeMap<u32, usize> = BTreeMap::new();
    let mut points = MovingPoints::default();
    for (t, p) in truth.iter().zip(labels) {
        let Some(t) = *t else {
            continue;
        };
        let p = p.unwrap_or(0);
        let (moving, predicted) = (t > 0, p > 0);
        points.actual += usize::from(moving);
        points.predicted += usize::from(predicted);
        points.true_positive += usize::from(moving && predicted);
        if moving {
            *object_size.entry(t).or_default() += 1;
        }
        if predicted {
            *cluster_size.entry(p).or_default() += 1;
            *cluster_moving.entry(p).or_default() += usize::from(moving);
            if moving {
                *overlap.entry((t, p)).or_default() += 1;
            }
        }
    }
    let true_motions: HashMap<u32, Pose2> = pair
        .truth
        .as_ref()
        .map(|gt| gt.motions.iter().map(|m| (m.label, m.motion)).collect())
        .unwrap_or_default();
    let objects = object_size
        .iter()
        .map(|(&label, &returns)| {
            let matched = overlap
                .range((label, 0)..=(label, u32::MAX))
                .map(|(&(_, p), &n)| (p, n))
                .find(|&(p, n)| 2 * n >= returns && 2 * n >= cluster_size[&p]);
            let counted = returns >= options.min_object_returns;
            let error = matched.and_then(|(cluster, _)| {
                let truth_motion = true_motions.get(&label)?;
                let estimate = motions.get(&cluster)?;
                let members: Vec<usize> = (0..truth.len())
                    .filter(|&k| truth[k] == Some(label))
                    .collect();
                let centroid = members
                    .iter()
                    .fold(Point2::origin(), |acc: Point2<f64>, &k| {
                        acc + pair.current.beam_point(k).coords / members.len() as f64
                    });
                Some(ObjectMotionError {
                    centroid_error: (estimate.transform_point(&centroid)
                        - truth_motion.transform_point(&centroid))
                    .norm(),
                    rotation_error: estimate.rotation_error(truth_motion),
                })
            });
            ObjectDetection {
                label,
                returns,
                counted,
                detected: matched.is_some(),
                error,
            }
        })
        .collect();
    let false_alarms = cluster_size
        .iter()
        .filter(|(p, &n)| 2 * cluster_moving[*p] < n)
        .count();
    PairDetection {
        objects,
        false_alarms,
        has_mover: points.actual > 0,
        reported_moving: points.predicted > 0,
        moving_points: points,
    }
}

/// The detection metrics over all outcomes (module docs).
pub fn summarize_detection(
    outcomes: &[ClusteringOutcome],
    options: &DetectionOptions,
) -> DetectionSummary {
    let ratio = |a: usize, b: usize| (b > 0).then(|| a as f64 / b as f64);
    let counted: Vec<&ObjectDetection> = outcomes
        .iter()
        .flat_map(|o| &o.objects)
        .filter(|d| d.counted)
        .collect();
    let detected = counted.iter().filter(|d| d.detected).count();
    let errors: Vec<&ObjectMotionError> = counted.iter().filter_map(|d| d.error.as_ref()).collect();
    let translation: Vec<f64> = errors.iter().map(|e| e.centroid_error).collect();
    let rotation: Vec<f64> = errors.iter().map(|e| e.rotation_error).collect();
    let without: Vec<&ClusteringOutcome> = outcomes.iter().filter(|o| !o.has_mover).collect();
    let with: Vec<f64> = outcomes
        .iter()
        .filter(|o| o.has_mover)
        .map(|o| o.score.v_measure)
        .collect();
    let sum = |f: fn(&MovingPoints) -> usize| -> usize {
        outcomes.iter().map(|o| f(&o.moving_points)).sum()
    };
    let (tp, predicted, actual) = (
        sum(|m| m.true_positive),
        sum(|m| m.predicted),
        sum(|m| m.actual),
    );
    DetectionSummary {
        min_object_returns: options.min_object_returns,
        objects_counted: counted.len(),
        objects_detected: detected,
        object_recall: ratio(detected, counted.len()),
        false_alarms_per_pair: ratio(
            outcomes.iter().map(|o| o.false_alarms).sum(),
            outcomes.len(),
        )
        .unwrap_or(0.0),
        pairs_without_mover: without.len(),
        false_alarm_pair_share: ratio(
            without.iter().filter(|o| o.reported_moving).count(),
            without.len(),
        ),
        moving_precision: ratio(tp, predicted),
        moving_recall: ratio(tp, actual),
        object_translation_error_median: percentile(&translation, 50.0),
        object_rotation_error_median: percentile(&rotation, 50.0),
        v_measure_mean: mean_std(
            &outcomes
                .iter()
                .map(|o| o.score.v_measure)
                .collect::<Vec<_>>(),
        )
        .0,
        mover_pairs: with.len(),
        v_measure_mover_pairs: (!with.is_empty()).then(|| mean_std(&with).0),
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
        return Err(Error::NothingToScore {
            what: if pairs.is_empty() {
                "the data hold no pair".into()
            } else {
                format!(
                    "none of the {} pairs has a ground-truth ego-motion",
                    pairs.len()
                )
            },
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
    let all = summarize_errors(&errors).ok_or_else(|| Error::NothingToScore {
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

/// The association scores of one pair (Table I of the joint paper; see
/// [`score_associations`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AssociationScore {
    /// Returns with a ground-truth association.
    pub scored: usize,
    /// Exact accuracy (0–1): the same reference beam, or both outlier.
    pub accuracy: f64,
    /// Accuracy within one reference beam (0–1).
    pub accuracy_within_one: f64,
    /// String edit distance between the predicted and true association sequences.
    pub sed: usize,
    /// Outlier percentages.
    pub outliers: OutlierStats,
}

/// Scores `predicted` associations against `truth` (one entry per beam of the current
/// scan): [`association_accuracy_within`] with 0 and 1 beams,
/// [`association_edit_distance`] and [`outlier_stats`]. `None` when no beam has a
/// ground-truth association.
///
/// # Errors
/// When the lengths differ; the error names `pair`.
pub fn score_associations(
    pair: &str,
    truth: &[Option<Association>],
    predicted: &[Option<Association>],
) -> Result<Option<AssociationScore>> {
    let named = |e: Error| Error::Unscorable {
        pair: pair.to_string(),
        what: e.to_string(),
    };
    let exact = association_accuracy_within(truth, predicted, 0).map_err(named)?;
    let within = association_accuracy_within(truth, predicted, 1).map_err(named)?;
    let sed = association_edit_distance(truth, predicted).map_err(named)?;
    let outliers = outlier_stats(truth, predicted).map_err(named)?;
    Ok(match (exact, within, outliers) {
        (Some(accuracy), Some(accuracy_within_one), Some(outliers)) => Some(AssociationScore {
            scored: truth.iter().filter(|t| t.is_some()).count(),
            accuracy,
            accuracy_within_one,
            sed,
            outliers,
        }),
        _ => None,
    })
}

/// The mean of the values that exist; `None` when none does.
fn mean_of(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let v: Vec<f64> = values.flatten().collect();
    (!v.is_empty()).then(|| mean_std(&v).0)
}

/// The outcome of an association source on one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AssociationOutcome {
    /// The pair's name.
    pub name: String,
    /// The association scores.
    pub score: AssociationScore,
    /// The error of the source's ego-motion estimate, when it has one and the pair a
    /// true ego-motion.
    pub ego_error: Option<MotionError>,
}

/// The association metrics over all pairs, each the mean of the per-pair figures
/// (the `--json` object of `pgm eval association`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AssociationSummary {
    /// Pairs scored.
    pub pairs: usize,
    /// Mean exact accuracy (0–1).
    pub accuracy: f64,
    /// Mean accuracy within one reference beam (0–1).
    pub accuracy_within_one: f64,
    /// Mean string edit distance per pair.
    pub sed_mean: f64,
    /// Mean percentage of the scored returns predicted as outliers.
    pub outliers_predicted: f64,
    /// Mean percentage of the scored returns that truly are outliers.
    pub outliers_true: f64,
    /// Mean percentage of the true outliers predicted as outliers, over the pairs
    /// with a true outlier (`None` without such a pair).
    pub outliers_found: Option<f64>,
}

/// Everything [`evaluate_association`] measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AssociationReport {
    /// The source's name.
    pub method: String,
    /// Mean figures over the pairs.
    pub summary: AssociationSummary,
    /// Median and 90th percentile of the ego-motion error over the pairs where the
    /// source estimated one and the truth is known (`None` otherwise).
    pub ego: Option<ErrorSummary>,
    /// One outcome per pair, in the pairs' order.
    pub outcomes: Vec<AssociationOutcome>,
}

/// Runs the association `source` on every pair (in parallel) and scores it against
/// the true associations ([`score_associations`]; Table I of the joint paper).
///
/// # Errors
/// When `pairs` is empty, a pair has no ground-truth association, or the source fails
/// on a pair (each error names the pair).
pub fn evaluate_association(
    pairs: &[ScanPair],
    source: &dyn AssociationSource,
) -> Result<AssociationReport> {
    if pairs.is_empty() {
        return Err(Error::Unscorable {
            pair: "(none)".into(),
            what: "no pair to evaluate".into(),
        });
    }
    let outcomes: Vec<AssociationOutcome> = pairs
        .par_iter()
        .map(|pair| -> Result<AssociationOutcome> {
            let no_truth = || Error::Unscorable {
                pair: pair.name.clone(),
                what: "no ground-truth association on any return of the current scan".into(),
            };
            let truth = pair
                .truth
                .as_ref()
                .and_then(|t| t.associations.as_ref())
                .ok_or_else(no_truth)?;
            let predicted = source.associate(pair).map_err(|e| Error::Method {
                pair: pair.name.clone(),
                method: source.name().to_string(),
                source: Box::new(e),
            })?;
            let score = score_associations(&pair.name, truth, &predicted.associations)?
                .ok_or_else(no_truth)?;
            let ego_error = predicted
                .ego_motion
                .zip(pair.truth.as_ref().and_then(|t| t.ego_motion))
                .map(|(e, t)| motion_error(&e, &t));
            Ok(AssociationOutcome {
                name: pair.name.clone(),
                score,
                ego_error,
            })
        })
        .collect::<Result<_>>()?;
    Ok(summarize_association(source.name(), outcomes))
}

/// The report of association outcomes (see [`evaluate_association`]); `outcomes`
/// must not be empty for the means to be numbers.
pub fn summarize_association(method: &str, outcomes: Vec<AssociationOutcome>) -> AssociationReport {
    let mean = |f: fn(&AssociationScore) -> f64| {
        mean_std(&outcomes.iter().map(|o| f(&o.score)).collect::<Vec<_>>()).0
    };
    let summary = AssociationSummary {
        pairs: outcomes.len(),
        accuracy: mean(|s| s.accuracy),
        accuracy_within_one: mean(|s| s.accuracy_within_one),
        sed_mean: mean(|s| s.sed as f64),
        outliers_predicted: mean(|s| s.outliers.predicted_percentage),
        outliers_true: mean(|s| s.outliers.true_percentage),
        outliers_found: mean_of(outcomes.iter().map(|o| o.score.outliers.found_percentage)),
    };
    let ego_errors: Vec<MotionError> = outcomes.iter().filter_map(|o| o.ego_error).collect();
    AssociationReport {
        method: method.to_string(),
        summary,
        ego: summarize_errors(&ego_errors),
        outcomes,
    }
}

/// The clustering scores of one pair of a joint method (Table II of the joint paper;
/// see [`evaluate_joint`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct JointClusteringScore {
    /// Returns with a ground-truth cluster.
    pub scored: usize,
    /// Clustering accuracy with the outlier cluster (0–1,
    /// [`pgm_datasets::metrics::clustering_accuracy_matched`]).
    pub accuracy: f64,
    /// Clustering string edit distance ([`pgm_datasets::metrics::clustering_sed`]).
    pub sed: usize,
    /// Homogeneity, completeness and V-measure of the predicted clusters against the
    /// true ones of [`joint_truth`] (the true outliers a class of their own, the
    /// outlier cluster a cluster of its own).
    pub v_measure: VMeasure,
    /// Outlier-cluster percentages ([`pgm_datasets::metrics::cluster_outlier_stats`]).
    pub outliers: OutlierStats,
}

/// How one true moving object fared under a joint method.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct JointObject {
    /// Its true label.
    pub label: u32,
    /// Its returns whose truth is the object (not true outliers).
    pub returns: usize,
    /// The predicted motion cluster the one-to-one matching gave it, if any.
    pub cluster: Option<usize>,
    /// Of its returns, those in that cluster.
    pub overlap: usize,
    /// Whether it is correctly clustered (see [`evaluate_joint`]).
    pub correct: bool,
    /// The motion error, when correctly clustered with a known true motion.
    pub error: Option<ObjectMotionError>,
}

/// The outcome of a joint method on one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointOutcome {
    /// The pair's name.
    pub name: String,
    /// The association scores (`None` without ground-truth associations).
    pub association: Option<AssociationScore>,
    /// The clustering scores (`None` without ground-truth labels).
    pub clustering: Option<JointClusteringScore>,
    /// Every true moving object (label > 0) with a return.
    pub objects: Vec<JointObject>,
    /// The error of the ego-motion estimate (`None` without a true ego-motion).
    pub ego_error: Option<MotionError>,
    /// Iterations the method reported.
    pub iterations: usize,
    /// Whether the method converged.
    pub converged: bool,
}

/// The summary of [`evaluate_joint`]: exactly the fields of the `pgm eval joint
/// --json` object of issue 15. Every mean is over the pairs that have the figure's
/// ground truth, every median over the objects or pairs that have it; a figure with
/// nothing to be computed from is `None` (`null` in JSON), never a made-up score.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct JointSummary {
    /// Pairs evaluated.
    pub pairs: usize,
    /// Mean exact association accuracy (0–1).
    pub association_accuracy: Option<f64>,
    /// Mean association accuracy within one reference beam (0–1).
    pub association_accuracy_within_one: Option<f64>,
    /// Mean association string edit distance per pair.
    pub association_sed: Option<f64>,
    /// Mean clustering accuracy with the outlier cluster (0–1).
    pub clustering_accuracy: Option<f64>,
    /// Mean clustering string edit distance per pair.
    pub clustering_sed: Option<f64>,
    /// Mean V-measure.
    pub v_measure_mean: Option<f64>,
    /// Mean percentage of the scored returns associated to the outlier state.
    pub outliers_predicted: Option<f64>,
    /// Mean percentage of the scored returns whose true association is the outlier
    /// state.
    pub outliers_true: Option<f64>,
    /// Mean percentage of the true outliers associated to the outlier state, over the
    /// pairs with a true outlier.
    pub outliers_found: Option<f64>,
    /// Median rotation error (rad) of the correctly clustered moving objects.
    pub object_rotation_error_median: Option<f64>,
    /// Median translation error (m) of the correctly clustered moving objects: the
    /// distance between where the estimated and the true motion put the object's
    /// centroid.
    pub object_translation_error_median: Option<f64>,
    /// Median rotation error (rad) of the ego-motion.
    pub ego_rotation_error_median: Option<f64>,
    /// Median translation error (m) of the ego-motion.
    pub ego_translation_error_median: Option<f64>,
    /// Mean iterations the method reported.
    pub iterations_mean: f64,
}

/// Everything [`evaluate_joint`] measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointReport {
    /// The method's name.
    pub method: String,
    /// The figures over all pairs.
    pub summary: JointSummary,
    /// True moving objects with a return, over all pairs.
    pub objects_total: usize,
    /// Of those, correctly clustered.
    pub objects_correct: usize,
    /// Mean outlier-cluster percentages over the pairs with labels (Table II's outlier
    /// column: predicted, true, and found over the pairs with a true outlier).
    pub cluster_outliers: [Option<f64>; 3],
    /// One outcome per pair, in the pairs' order.
    pub outcomes: Vec<JointOutcome>,
}

/// Whether a pair can score a joint method: it has ground-truth labels or
/// associations on some return, or a true ego-motion.
pub fn scorable_for_joint(pair: &ScanPair) -> bool {
    pair.truth.as_ref().is_some_and(|t| {
        t.ego_motion.is_some()
            || t.labels
                .as_ref()
                .is_some_and(|l| l.iter().any(Option::is_some))
            || t.associations
                .as_ref()
                .is_some_and(|a| a.iter().any(Option::is_some))
    })
}

/// Runs the joint `method` on one pair and scores it (see [`evaluate_joint`]).
///
/// # Errors
/// When the pair has nothing to score ([`scorable_for_joint`]), the method fails, or
/// its output does not fit the pair; the error names the pair.
pub fn evaluate_joint_pair(pair: &ScanPair, method: &dyn JointEstimator) -> Result<JointOutcome> {
    let unscorable = |what: String| Error::Unscorable {
        pair: pair.name.clone(),
        what,
    };
    let truth = pair
        .truth
        .as_ref()
        .filter(|_| scorable_for_joint(pair))
        .ok_or_else(|| {
            unscorable("no ground-truth label, association or ego-motion to score against".into())
        })?;
    let estimate = method.estimate(pair).map_err(|e| Error::Method {
        pair: pair.name.clone(),
        method: method.name().to_string(),
        source: Box::new(e),
    })?;
    let beams = pair.current.len();
    for (what, n) in [
        ("associations", estimate.associations.len()),
        ("clusters", estimate.clusters.len()),
    ] {
        if n != beams {
            return Err(unscorable(format!(
                "{} returned {n} {what} for the {beams} beams of the current scan",
                method.name()
            )));
        }
    }
    let cluster_count = estimate.motions.len();
    if estimate.background >= cluster_count
        || estimate
            .clusters
            .iter()
            .any(|c| matches!(c, Some(JointCluster::Object(k)) if *k >= cluster_count))
    {
        return Err(unscorable(format!(
            "{} returned a cluster or background index beyond its {cluster_count} motions",
            method.name()
        )));
    }
    let association = match truth.associations.as_ref() {
        Some(t) => score_associations(&pair.name, t, &estimate.associations)?,
        None => None,
    };
    let labels = truth
        .labels
        .as_ref()
        .filter(|l| l.iter().any(Option::is_some));
    let mut objects = Vec::new();
    let clustering = match labels {
        None => None,
        Some(labels) => {
            let named = |e: Error| unscorable(e.to_string());
            let joint = joint_truth(labels, truth.associations.as_deref()).map_err(named)?;
            // Without true associations no return is known to be an outlier: the
            // outlier cluster is scored as the background (see `evaluate_joint`).
            let predicted: Vec<Option<JointCluster>> = match truth.associations {
                Some(_) => estimate.clusters.clone(),
                None => estimate
                    .clusters
                    .iter()
                    .map(|c| match c {
                        Some(JointCluster::Outlier) => {
                            Some(JointCluster::Object(estimate.background))
                        }
                        other => *other,
                    })
                    .collect(),
            };
            let matching = match_clusterings(&joint, &predicted).map_err(named)?;
            let (classes, clusters): (Vec<JointCluster>, Vec<Option<JointCluster>>) = joint
                .iter()
                .zip(&predicted)
                .filter_map(|(t, p)| t.map(|t| (t, *p)))
                .unzip();
            let v_measure =
                homogeneity_completeness_v_measure(&classes, &clusters, 1.0).map_err(named)?;
            let sed = clustering_sed(&joint, &predicted).map_err(named)?;
            let outliers = cluster_outlier_stats(&joint, &estimate.clusters)
                .map_err(named)?
                .ok_or_else(|| unscorable("no return with a ground-truth cluster".into()))?;
            objects = joint_objects(pair, labels, &matching, &estimate);
            let accuracy = matching
                .accuracy()
                .ok_or_else(|| unscorable("no return with a ground-truth cluster".into()))?;
            Some(JointClusteringScore {
                scored: matching.scored,
                accuracy,
                sed,
                v_measure,
                outliers,
            })
        }
    };
    Ok(JointOutcome {
        name: pair.name.clone(),
        association,
        clustering,
        objects,
        ego_error: truth
            .ego_motion
            .map(|t| motion_error(&estimate.ego_motion, &t)),
        iterations: estimate.iterations,
        converged: estimate.converged,
    })
}

/// The true moving objects of a pair and how the matching clustered them (see
/// [`evaluate_joint`]).
fn joint_objects(
    pair: &ScanPair,
    labels: &[Option<u32>],
    matching: &ClusterMatching,
    estimate: &JointEstimate,
) -> Vec<JointObject> {
    let true_motions: HashMap<u32, Pose2> = pair
        .truth
        .as_ref()
        .map(|gt| gt.motions.iter().map(|m| (m.label, m.motion)).collect())
        .unwrap_or_default();
    matching
        .object_returns
        .iter()
        .filter(|(&l, _)| l > 0)
        .map(|(&l, &returns)| {
            let label = l as u32;
            let matched = matching.matches.iter().find(|m| m.0 == l);
            let (cluster, overlap) = matched.map_or((None, 0), |m| (Some(m.1), m.2));
            let correct =
                cluster.is_some_and(|k| k != estimate.background) && 2 * overlap > returns;
            let error = cluster
                .filter(|_| correct)
                .and_then(|k| Some((true_motions.get(&label)?, estimate.motions[k])))
                .map(|(truth_motion, estimated)| {
                    let members: Vec<usize> = (0..labels.len())
                        .filter(|&k| labels[k] == Some(label))
                        .collect();
                    let centroid = members
                        .iter()
                        .fold(Point2::origin(), |acc: Point2<f64>, &k| {
                            acc + pair.current.beam_point(k).coords / members.len() as f64
                        });
                    ObjectMotionError {
                        centroid_error: (estimated.transform_point(&centroid)
                            - truth_motion.transform_point(&centroid))
                        .norm(),
                        rotation_error: estimated.rotation_error(truth_motion),
                    }
                });
            JointObject {
                label,
                returns,
                cluster,
                overlap,
                correct,
                error,
            }
        })
        .collect()
}

/// Runs the joint `method` on every pair (in parallel) and scores its associations,
/// clusters and motions the way Tables I-III of the joint paper do.
///
/// - **Associations** (pairs with true associations): [`score_associations`].
/// - **Clusters** (pairs with labels): the clustering accuracy with the outlier
///   cluster and its string edit distance against [`joint_truth`] (a return whose
///   true association is the outlier state must be in the outlier cluster), and the
///   V-measure against the same truth (the true outliers a class of their own, the
///   outlier cluster a cluster of its own; `pgm eval clustering --method joint`
///   scores the clusters against the labels alone, like every other clusterer).
/// - **Objects**: a true moving object (label > 0) is *correctly clustered* when the
///   one-to-one matching of [`match_clusterings`] gives it a predicted motion cluster
///   other than the background that holds more than half of its returns; its error
///   is that cluster's motion against its true motion (rotation in rad; translation
///   as the distance between where the two motions put the object's centroid, m),
///   Table III.
/// - **Ego-motion** (pairs with a true ego-motion): [`motion_error`].
///
/// Summaries in [`JointSummary`]. On pairs without true associations (real data)
/// the association figures are `None`, no return is known to be an outlier, and the
/// returns of the predicted outlier cluster are scored as the background's (as
/// `pgm eval clustering` scores them, [`pgm_scan::methods::JointClusters`]): the
/// truth cannot tell whether they are outliers, so they are neither rewarded nor
/// counted as a cluster of their own. The outlier-cluster percentages
/// ([`JointClusteringScore::outliers`]) still report how many returns the method
/// put there.
///
/// # Errors
/// When `pairs` is empty or a pair fails ([`evaluate_joint_pair`]; the error names
/// the pair).
pub fn evaluate_joint(pairs: &[ScanPair], method: &dyn JointEstimator) -> Result<JointReport> {
    if pairs.is_empty() {
        return Err(Error::Unscorable {
            pair: "(none)".into(),
            what: "no pair to evaluate".into(),
        });
    }
    let outcomes: Vec<JointOutcome> = pairs
        .par_iter()
        .map(|p| evaluate_joint_pair(p, method))
        .collect::<Result<_>>()?;
    Ok(summarize_joint(method.name(), outcomes))
}

/// The report of joint outcomes (see [`evaluate_joint`]).
pub fn summarize_joint(method: &str, outcomes: Vec<JointOutcome>) -> JointReport {
    let association = |f: fn(&AssociationScore) -> Option<f64>| {
        mean_of(outcomes.iter().map(|o| o.association.as_ref().and_then(f)))
    };
    let clustering = |f: fn(&JointClusteringScore) -> Option<f64>| {
        mean_of(outcomes.iter().map(|o| o.clustering.as_ref().and_then(f)))
    };
    let errors: Vec<&ObjectMotionError> = outcomes
        .iter()
        .flat_map(|o| &o.objects)
        .filter_map(|o| o.error.as_ref())
        .collect();
    let ego: Vec<MotionError> = outcomes.iter().filter_map(|o| o.ego_error).collect();
    let median = |v: Vec<f64>| percentile(&v, 50.0);
    let summary = JointSummary {
        pairs: outcomes.len(),
        association_accuracy: association(|s| Some(s.accuracy)),
        association_accuracy_within_one: association(|s| Some(s.accuracy_within_one)),
        association_sed: association(|s| Some(s.sed as f64)),
        clustering_accuracy: clustering(|s| Some(s.accuracy)),
        clustering_sed: clustering(|s| Some(s.sed as f64)),
        v_measure_mean: clustering(|s| Some(s.v_measure.v_measure)),
        outliers_predicted: association(|s| Some(s.outliers.predicted_percentage)),
        outliers_true: association(|s| Some(s.outliers.true_percentage)),
        outliers_found: association(|s| s.outliers.found_percentage),
        object_rotation_error_median: median(errors.iter().map(|e| e.rotation_error).collect()),
        object_translation_error_median: median(errors.iter().map(|e| e.centroid_error).collect()),
        ego_rotation_error_median: median(ego.iter().map(|e| e.rotation).collect()),
        ego_translation_error_median: median(ego.iter().map(|e| e.translation).collect()),
        iterations_mean: mean_std(
            &outcomes
                .iter()
                .map(|o| o.iterations as f64)
                .collect::<Vec<_>>(),
        )
        .0,
    };
    let objects: Vec<&JointObject> = outcomes.iter().flat_map(|o| &o.objects).collect();
    JointReport {
        method: method.to_string(),
        summary,
        objects_total: objects.len(),
        objects_correct: objects.iter().filter(|o| o.correct).count(),
        cluster_outliers: [
            clustering(|s| Some(s.outliers.predicted_percentage)),
            clustering(|s| Some(s.outliers.true_percentage)),
            clustering(|s| s.outliers.found_percentage),
        ],
        outcomes,
    }
}
