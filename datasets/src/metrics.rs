//! Evaluation metrics of both papers.
//!
//! - Clustering (CRF-Clustering paper, Table I): homogeneity `H`, completeness `C` and
//!   the V-measure `V_β = (1 + β) H C / (β H + C)` (eq. 9, Rosenberg and Hirschberg
//!   2007), with scikit-learn's definitions and edge cases: natural logarithms; an
//!   empty labelling scores 1 on all three; `H = 1` when the classes have zero entropy
//!   (a single class), `C = 1` when the clusters have zero entropy (a single
//!   cluster); `V = 0` when `H + C = 0`. See [`homogeneity_completeness_v_measure`].
//! - Association (joint-model paper, Table I): accuracy, string edit distance (SED)
//!   and outlier figures ([`association_accuracy`], [`association_edit_distance`],
//!   [`outlier_stats`]); clustering accuracy and SED (Table II) with the outlier
//!   cluster ([`clustering_accuracy_matched`], [`clustering_sed`],
//!   [`cluster_outlier_stats`]; the older
//!   [`clustering_accuracy`] and [`clustering_edit_distance`] have no outlier
//!   cluster).
//! - Motion (Table III): rotation and translation error ([`motion_error`]), and the
//!   [`percentile`] used to summarise them.
//!
//! **String edit distance.** The paper cites SED without a definition. Here it is the
//! Levenshtein distance (unit-cost insertions, deletions and substitutions) between
//! the two label sequences in beam order, over the beams that have a ground-truth
//! label. Association sequences are compared as they are (a target beam index or
//! "outlier" per beam). Cluster ids are arbitrary names, so before comparing
//! clusterings both sequences are **renamed by order of first appearance** (the first
//! cluster met becomes 0, the next new one 1, …; "outlier"/no label is a symbol of
//! its own and never renamed); the distance is then invariant to renaming clusters
//! in either labelling. It is cheaper than the minimum over all label matchings and
//! equal to it whenever the first-appearance order of the clusters agrees.
//!
//! **Clustering accuracy with an outlier cluster** (Table II of the joint paper, which
//! calls it "the percentage of correctly clustered points"; [`clustering_accuracy_matched`]).
//! Both sides are per-beam [`JointCluster`]s: `Object(id)` or `Outlier`. The truth
//! comes from a pair's ground truth ([`joint_truth`]): every beam with a true label is
//! scored; it is `Outlier` when its true association is the outlier state (the
//! surface is not seen in the reference scan), otherwise `Object(label)` (label 0,
//! the background, is an object like the others). A scored beam is correct when
//! - its truth is `Outlier` and it is predicted in the outlier cluster (outliers must
//!   be outliers in both), or
//! - its truth is `Object(l)` and it is predicted in the cluster `Object(k)` that the
//!   matching maps to `l`.
//!
//! The matching is one to one between true objects and predicted clusters and
//! maximises the number of returns on which they agree (the returns with truth
//! `Object(l)` predicted `Object(k)`, summed over the matched pairs `(l, k)`); it is
//! found by the Hungarian method ([`maximum_weight_matching`]). A true object or a
//! predicted cluster left unmatched (there are more of one than of the other) has all
//! its returns wrong, and so do the returns predicted `Outlier` or not predicted at
//! all whose truth is an object. The accuracy is correct / scored beams.
//!
//! The clustering SED ([`clustering_sed`]) is [`clustering_edit_distance`] with the
//! outlier cluster on both sides as the one symbol that is never renamed.

use crate::error::{Error, Result};
use crate::pair::Association;
use pgm_scan::methods::JointCluster;
use pgm_scan::Pose2;
use std::collections::{BTreeMap, HashMap};
use std::hash::Hash;

/// Homogeneity, completeness and V-measure of one clustering.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct VMeasure {
    /// `H = 1 − H(class | cluster) / H(class)`: each cluster holds one class.
    pub homogeneity: f64,
    /// `C = 1 − H(cluster | class) / H(cluster)`: each class sits in one cluster.
    pub completeness: f64,
    /// `V_β = (1 + β) H C / (β H + C)` (eq. 9).
    pub v_measure: f64,
}

fn check_lengths(what: &str, truth: usize, predicted: usize) -> Result<()> {
    if truth != predicted {
        return Err(Error::Mismatch {
            what: format!("{what}: {truth} ground-truth entries but {predicted} predicted"),
        });
    }
    Ok(())
}

/// The entries that have a ground truth, as (truth, prediction) sequences, after
/// [`check_lengths`] (`what` names the metric).
fn with_truth<T: Copy, P: Copy>(
    what: &str,
    truth: &[Option<T>],
    predicted: &[P],
) -> Result<(Vec<T>, Vec<P>)> {
    check_lengths(what, truth.len(), predicted.len())?;
    Ok(truth
        .iter()
        .zip(predicted)
        .filter_map(|(t, p)| t.map(|t| (t, *p)))
        .unzip())
}

/// Entropy (natural log) of a distribution given by counts summing to `n`.
fn entropy<'a>(counts: impl Iterator<Item = &'a usize>, n: f64) -> f64 {
    let mut h = 0.0;
    let mut classes = 0;
    for &c in counts {
        if c > 0 {
            classes += 1;
            let p = c as f64 / n;
            h -= p * p.ln();
        }
    }
    if classes <= 1 {
        0.0
    } else {
        h.max(0.0)
    }
}

/// Homogeneity, completeness and V-measure with blending factor `beta` (β = 1 in the
/// paper) of the clustering `predicted` against the classes `truth`, as
/// `sklearn.metrics.homogeneity_completeness_v_measure(truth, predicted, beta=beta)`.
/// Labels of any hashable type; an error when the lengths differ or `beta` is not a
/// non-negative finite number.
pub fn homogeneity_completeness_v_measure<A, B>(
    truth: &[A],
    predicted: &[B],
    beta: f64,
) -> Result<VMeasure>
where
    A: Eq + Hash,
    B: Eq + Hash,
{
    check_lengths("V-measure", truth.len(), predicted.len())?;
    if !(beta >= 0.0 && beta.is_finite()) {
        return Err(Error::Mismatch {
            what: format!("V-measure: beta {beta} must be finite and >= 0"),
        });
    }
    if truth.is_empty() {
        return Ok(VMeasure {
            homogeneity: 1.0,
            completeness: 1.0,
            v_measure: 1.0,
        });
    }
    let n = truth.len() as f64;
    let mut class_ids: HashMap<&A, usize> = HashMap::new();
    let mut cluster_ids: HashMap<&B, usize> = HashMap::new();
    let mut class_counts = Vec::new();
    let mut cluster_counts = Vec::new();
    let mut joint: HashMap<(usize, usize), usize> = HashMap::new();
    for (a, b) in truth.iter().zip(predicted) {
        let next = class_ids.len();
        let ca = *class_ids.entry(a).or_insert(next);
        if ca == class_counts.len() {
            class_counts.push(0);
        }
        class_counts[ca] += 1;
        let next = cluster_ids.len();
        let cb = *cluster_ids.entry(b).or_insert(next);
        if cb == cluster_counts.len() {
            cluster_counts.push(0);
        }
        cluster_counts[cb] += 1;
        *joint.entry((ca, cb)).or_insert(0) += 1;
    }
    let entropy_classes = entropy(class_counts.iter(), n);
    let entropy_clusters = entropy(cluster_counts.iter(), n);
    let mutual_information = if class_counts.len() == 1 || cluster_counts.len() == 1 {
        0.0
    } else {
        let mut mi = 0.0;
        for (&(a, b), &nij) in &joint {
            let nij = nij as f64;
            let term = nij / n
                * ((nij * n).ln()
                    - (class_counts[a] as f64).ln()
                    - (cluster_counts[b] as f64).ln());
            // scikit-learn zeroes terms below machine epsilon before summing.
            if term.abs() >= f64::EPSILON {
                mi += term;
            }
        }
        mi.max(0.0)
    };
    // Rounding can put the mutual information a few ulps above an entropy (a perfect
    // clustering scored 1.0000000000000009): both ratios lie in [0, 1] by definition.
    let homogeneity = if entropy_classes == 0.0 {
        1.0
    } else {
        (mutual_information / entropy_classes).clamp(0.0, 1.0)
    };
    let completeness = if entropy_clusters == 0.0 {
        1.0
    } else {
        (mutual_information / entropy_clusters).clamp(0.0, 1.0)
    };
    let v_measure = if homogeneity + completeness == 0.0 {
        0.0
    } else {
        (1.0 + beta) * homogeneity * completeness / (beta * homogeneity + completeness)
    };
    Ok(VMeasure {
        homogeneity,
        completeness,
        v_measure,
    })
}

/// V-measure of per-beam labellings as stored in a [`crate::GroundTruth`]: scored over
/// the beams that have a ground-truth label; a predicted `None` (outlier, unlabelled)
/// counts as a cluster of its own. No beam with a label is an error, not a V-measure
/// of 1 computed from nothing.
pub fn clustering_v_measure(
    truth: &[Option<u32>],
    predicted: &[Option<u32>],
    beta: f64,
) -> Result<VMeasure> {
    let (t, p) = with_truth("clustering V-measure", truth, predicted)?;
    if t.is_empty() {
        return Err(Error::NothingToScore {
            what: format!("none of the {} beams has a ground-truth label", truth.len()),
        });
    }
    homogeneity_completeness_v_measure(&t, &p, beta)
}

/// Levenshtein distance between two sequences (unit costs), O(|a|·|b|) time and
/// O(|b|) memory.
pub fn edit_distance<T: PartialEq>(a: &[T], b: &[T]) -> usize {
    let mut previous: Vec<usize> = (0..=b.len()).collect();
    let mut row = vec![0; b.len() + 1];
    for (i, x) in a.iter().enumerate() {
        row[0] = i + 1;
        for (j, y) in b.iter().enumerate() {
            let substitution = previous[j] + usize::from(x != y);
            row[j + 1] = substitution.min(previous[j + 1] + 1).min(row[j] + 1);
        }
        std::mem::swap(&mut previous, &mut row);
    }
    previous[b.len()]
}

/// Renames cluster ids by order of first appearance (`None` stays `None`).
pub fn rename_by_first_appearance<T: Eq + Hash>(labels: &[Option<T>]) -> Vec<Option<usize>> {
    let mut names: HashMap<&T, usize> = HashMap::new();
    labels
        .iter()
        .map(|l| {
            l.as_ref().map(|l| {
                let next = names.len();
                *names.entry(l).or_insert(next)
            })
        })
        .collect()
}

/// String edit distance between two clusterings of the same beams, over the beams
/// with a ground-truth label, invariant to renaming clusters (see the module docs).
pub fn clustering_edit_distance(truth: &[Option<u32>], predicted: &[Option<u32>]) -> Result<usize> {
    check_lengths("clustering edit distance", truth.len(), predicted.len())?;
    let (t, p) = labelled_renamed(truth, predicted, |c| *c);
    Ok(edit_distance(&t, &p))
}

/// The labels of the beams with a ground-truth label, `label` of the truth and of the
/// prediction, each labelling renamed by first appearance.
fn labelled_renamed<T, L: Eq + Hash>(
    truth: &[Option<T>],
    predicted: &[Option<T>],
    label: impl Fn(&Option<T>) -> Option<L>,
) -> (Vec<Option<usize>>, Vec<Option<usize>>) {
    let (t, p): (Vec<Option<L>>, Vec<Option<L>>) = truth
        .iter()
        .zip(predicted)
        .filter(|(t, _)| t.is_some())
        .map(|(t, p)| (label(t), label(p)))
        .unzip();
    (
        rename_by_first_appearance(&t),
        rename_by_first_appearance(&p),
    )
}

/// Share (0–1) of beams with a ground-truth label whose predicted cluster, after
/// renaming both labellings by first appearance, equals the true one; `None` when no
/// beam has a ground-truth label.
pub fn clustering_accuracy(
    truth: &[Option<u32>],
    predicted: &[Option<u32>],
) -> Result<Option<f64>> {
    check_lengths("clustering accuracy", truth.len(), predicted.len())?;
    let (t, p) = labelled_renamed(truth, predicted, |c| *c);
    if t.is_empty() {
        return Ok(None);
    }
    let hits = t.iter().zip(&p).filter(|(a, b)| a == b).count();
    Ok(Some(hits as f64 / t.len() as f64))
}

/// The one-to-one matching of rows to columns that maximises the summed weight
/// (the assignment problem, solved by the Hungarian method of Kuhn and Munkres,
/// `pathfinding::kuhn_munkres`, O(n³)). `weights` is a rectangular matrix (every row as
/// long as the first); the result gives each row its column, `None` for the rows left
/// over when there are more rows than columns. With non-negative weights every row
/// (or every column, whichever are fewer) is matched, some possibly with weight 0.
///
/// # Errors
/// When the rows differ in length.
pub fn maximum_weight_matching(weights: &[Vec<i64>]) -> Result<Vec<Option<usize>>> {
    let rows = weights.len();
    let cols = weights.first().map_or(0, Vec::len);
    if let Some((r, row)) = weights.iter().enumerate().find(|(_, w)| w.len() != cols) {
        return Err(Error::Mismatch {
            what: format!(
                "matching: row {r} has {} weights, row 0 has {cols}",
                row.len()
            ),
        });
    }
    if rows == 0 || cols == 0 {
        return Ok(vec![None; rows]);
    }
    let matrix = pathfinding::matrix::Matrix::from_rows(weights.iter().cloned()).map_err(|e| {
        Error::Mismatch {
            what: format!("matching: {e}"),
        }
    })?;
    // kuhn_munkres assigns every row a column and needs rows <= columns.
    let mut matched = vec![None; rows];
    if rows <= cols {
        let (_, column_of_row) = pathfinding::kuhn_munkres::kuhn_munkres(&matrix);
        for (r, c) in column_of_row.into_iter().enumerate() {
            matched[r] = Some(c);
        }
    } else {
        let (_, row_of_column) = pathfinding::kuhn_munkres::kuhn_munkres(&matrix.transposed());
        for (c, r) in row_of_column.into_iter().enumerate() {
            matched[r] = Some(c);
        }
    }
    Ok(matched)
}

/// The ground truth of a pair as [`JointCluster`]s, one per beam of the current scan
/// (see the module docs): `None` where there is no true label, `Outlier` where the true
/// association is the outlier state, else `Object(label)`. Without true associations
/// (`associations = None`) no beam is a true outlier.
///
/// # Errors
/// When the lengths differ.
pub fn joint_truth(
    labels: &[Option<u32>],
    associations: Option<&[Option<Association>]>,
) -> Result<Vec<Option<JointCluster>>> {
    if let Some(a) = associations {
        check_lengths("joint truth (labels, associations)", labels.len(), a.len())?;
    }
    Ok(labels
        .iter()
        .enumerate()
        .map(|(k, label)| {
            let label = (*label)?;
            let outlier = associations.is_some_and(|a| a[k] == Some(Association::Outlier));
            Some(if outlier {
                JointCluster::Outlier
            } else {
                JointCluster::Object(label as usize)
            })
        })
        .collect())
}

/// How a predicted clustering with an outlier cluster matches the truth (see the
/// module docs and [`match_clusterings`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ClusterMatching {
    /// Beams with a ground-truth cluster.
    pub scored: usize,
    /// Of those, the correct ones (module docs).
    pub correct: usize,
    /// Of those, true outliers predicted in the outlier cluster.
    pub outliers_correct: usize,
    /// The matched pairs `(true object id, predicted cluster, returns in both)`, in
    /// increasing order of the true id; pairs that share no return are left out.
    pub matches: Vec<(usize, usize, usize)>,
    /// Returns of every true object (beams whose truth is `Object(id)`), by id.
    pub object_returns: BTreeMap<usize, usize>,
}

impl ClusterMatching {
    /// `correct / scored`, `None` without a scored beam.
    pub fn accuracy(&self) -> Option<f64> {
        (self.scored > 0).then(|| self.correct as f64 / self.scored as f64)
    }
}

/// Matches the predicted clusters to the true objects one to one, maximising the
/// returns on which they agree, and counts the correct beams (module docs).
///
/// # Errors
/// When the lengths differ.
pub fn match_clusterings(
    truth: &[Option<JointCluster>],
    predicted: &[Option<JointCluster>],
) -> Result<ClusterMatching> {
    check_lengths("clustering accuracy", truth.len(), predicted.len())?;
    let mut out = ClusterMatching::default();
    let mut overlap: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    let mut clusters: Vec<usize> = Vec::new();
    for (t, p) in truth.iter().zip(predicted) {
        let Some(t) = t else { continue };
        out.scored += 1;
        match (t, p) {
            (JointCluster::Outlier, Some(JointCluster::Outlier)) => out.outliers_correct += 1,
            (JointCluster::Object(l), p) => {
                *out.object_returns.entry(*l).or_default() += 1;
                if let Some(JointCluster::Object(k)) = p {
                    *overlap.entry((*l, *k)).or_default() += 1;
                    clusters.push(*k);
                }
            }
            _ => {}
        }
    }
    clusters.sort_unstable();
    clusters.dedup();
    let objects: Vec<usize> = out.object_returns.keys().copied().collect();
    let weights: Vec<Vec<i64>> = objects
        .iter()
        .map(|l| {
            clusters
                .iter()
                .map(|k| overlap.get(&(*l, *k)).map_or(0, |&n| n as i64))
                .collect()
        })
        .collect();
    let matched = maximum_weight_matching(&weights)?;
    for (row, column) in matched.iter().enumerate() {
        let Some(column) = *column else { continue };
        let (l, k) = (objects[row], clusters[column]);
        let n = overlap.get(&(l, k)).copied().unwrap_or(0);
        if n > 0 {
            out.matches.push((l, k, n));
        }
    }
    out.correct = out.outliers_correct + out.matches.iter().map(|m| m.2).sum::<usize>();
    Ok(out)
}

/// The clustering accuracy of the joint paper's Table II (0–1): clusters mapped to
/// true objects one to one by the matching that maximises agreement, outliers correct
/// only when outliers in both (module docs); `None` when no beam has a ground-truth
/// cluster. Build `truth` with [`joint_truth`].
///
/// # Errors
/// When the lengths differ.
pub fn clustering_accuracy_matched(
    truth: &[Option<JointCluster>],
    predicted: &[Option<JointCluster>],
) -> Result<Option<f64>> {
    Ok(match_clusterings(truth, predicted)?.accuracy())
}

/// The clustering string edit distance of the joint paper's Table II: the Levenshtein
/// distance between the two cluster sequences over the beams with a ground-truth
/// cluster, each renamed by first appearance as in [`clustering_edit_distance`], with
/// the outlier cluster (and a beam without a prediction) as the one symbol that is
/// never renamed. Without outliers it equals [`clustering_edit_distance`] of the
/// labels.
///
/// # Errors
/// When the lengths differ.
pub fn clustering_sed(
    truth: &[Option<JointCluster>],
    predicted: &[Option<JointCluster>],
) -> Result<usize> {
    check_lengths("clustering edit distance", truth.len(), predicted.len())?;
    let object = |c: &Option<JointCluster>| match c {
        Some(JointCluster::Object(k)) => Some(*k),
        _ => None,
    };
    let (t, p) = labelled_renamed(truth, predicted, object);
    Ok(edit_distance(&t, &p))
}

/// Share (0–1) of beams with a ground-truth association whose predicted association
/// is the same (same reference beam, or both outlier); a missing prediction counts
/// as wrong. `None` when no beam has a ground-truth association.
pub fn association_accuracy(
    truth: &[Option<Association>],
    predicted: &[Option<Association>],
) -> Result<Option<f64>> {
    // Within 0 beams: the same beam, or both outlier.
    association_accuracy_within(truth, predicted, 0)
}

/// Fraction of the beams with a ground-truth association whose predicted association
/// is within `beams` reference beams of it (`beams = 0`: the same beam), or an outlier
/// where the truth is one; `None` when no beam has a ground-truth association. A
/// missing prediction counts as wrong.
pub fn association_accuracy_within(
    truth: &[Option<Association>],
    predicted: &[Option<Association>],
    beams: usize,
) -> Result<Option<f64>> {
    check_lengths("association accuracy", truth.len(), predicted.len())?;
    let mut scored = 0usize;
    let mut hits = 0usize;
    for (t, p) in truth.iter().zip(predicted) {
        if let Some(t) = t {
            scored += 1;
            hits += usize::from(match (t, p) {
                (Association::Outlier, Some(Association::Outlier)) => true,
                (Association::Point(a), Some(Association::Point(b))) => a.abs_diff(*b) <= beams,
                _ => false,
            });
        }
    }
    Ok((scored > 0).then(|| hits as f64 / scored as f64))
}

/// String edit distance between association sequences over the beams with a
/// ground-truth association (see the module docs).
pub fn association_edit_distance(
    truth: &[Option<Association>],
    predicted: &[Option<Association>],
) -> Result<usize> {
    let (t, p) = with_truth("association edit distance", truth, predicted)?;
    let t: Vec<Option<Association>> = t.into_iter().map(Some).collect();
    Ok(edit_distance(&t, &p))
}

/// The outlier figures of the joint-model paper's Table I, as percentages over the
/// beams with a ground-truth association.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct OutlierStats {
    /// Percentage of beams predicted as outliers.
    pub predicted_percentage: f64,
    /// Percentage of beams that truly are outliers.
    pub true_percentage: f64,
    /// Percentage of the true outliers that were predicted as outliers; `None` when
    /// there is no true outlier (nothing to find: not a score of 100).
    pub found_percentage: Option<f64>,
}

/// Outlier figures (see [`OutlierStats`]); `None` when no beam has a ground-truth
/// association. A missing prediction counts as not-outlier.
pub fn outlier_stats(
    truth: &[Option<Association>],
    predicted: &[Option<Association>],
) -> Result<Option<OutlierStats>> {
    check_lengths("outlier statistics", truth.len(), predicted.len())?;
    let mut scored = 0usize;
    let mut predicted_outliers = 0usize;
    let mut true_outliers = 0usize;
    let mut found = 0usize;
    for (t, p) in truth.iter().zip(predicted) {
        let Some(t) = t else { continue };
        scored += 1;
        let p_out = *p == Some(Association::Outlier);
        let t_out = *t == Association::Outlier;
        predicted_outliers += usize::from(p_out);
        true_outliers += usize::from(t_out);
        found += usize::from(p_out && t_out);
    }
    if scored == 0 {
        return Ok(None);
    }
    let pct = |x: usize, of: usize| 100.0 * x as f64 / of as f64;
    Ok(Some(OutlierStats {
        predicted_percentage: pct(predicted_outliers, scored),
        true_percentage: pct(true_outliers, scored),
        found_percentage: (true_outliers > 0).then(|| pct(found, true_outliers)),
    }))
}

/// The outlier figures of the joint paper's Table II: [`OutlierStats`] of the
/// outlier *cluster*, as percentages over the beams with a ground-truth cluster (build
/// `truth` with [`joint_truth`]); a beam without a prediction counts as not in the
/// outlier cluster. `None` when no beam has a ground-truth cluster.
///
/// # Errors
/// When the lengths differ.
pub fn cluster_outlier_stats(
    truth: &[Option<JointCluster>],
    predicted: &[Option<JointCluster>],
) -> Result<Option<OutlierStats>> {
    check_lengths("cluster outlier statistics", truth.len(), predicted.len())?;
    let as_association = |c: &Option<JointCluster>| match c {
        Some(JointCluster::Outlier) => Some(Association::Outlier),
        Some(JointCluster::Object(_)) => Some(Association::Point(0)),
        None => None,
    };
    let t: Vec<Option<Association>> = truth.iter().map(as_association).collect();
    let p: Vec<Option<Association>> = predicted.iter().map(as_association).collect();
    outlier_stats(&t, &p)
}

/// Translation (m) and rotation (rad) error of a motion estimate.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct MotionError {
    /// `‖T_est − T_true‖` in metres.
    pub translation: f64,
    /// `|wrap(θ_est − θ_true)|` in radians, in [0, π].
    pub rotation: f64,
}

/// Error of `estimate` against `truth` (both in the same convention and frame).
pub fn motion_error(estimate: &Pose2, truth: &Pose2) -> MotionError {
    MotionError {
        translation: estimate.translation_error(truth),
        rotation: estimate.rotation_error(truth),
    }
}

/// The `q`-th percentile (0–100) of `values` with linear interpolation between order
/// statistics (numpy's default); `None` for no values or a `q` outside 0–100.
/// Non-finite values sort last (NaN after +∞).
pub fn percentile(values: &[f64], q: f64) -> Option<f64> {
    if values.is_empty() || !(0.0..=100.0).contains(&q) {
        return None;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let position = q / 100.0 * (sorted.len() - 1) as f64;
    let lower = position.floor() as usize;
    let upper = position.ceil() as usize;
    let fraction = position - lower as f64;
    Some(sorted[lower] + (sorted[upper] - sorted[lower]) * fraction)
}

/// Median and 90th percentile of motion errors.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ErrorSummary {
    /// Number of pairs.
    pub pairs: usize,
    /// Median translation error (m).
    pub translation_median: f64,
    /// 90th-percentile translation error (m).
    pub translation_p90: f64,
    /// Median rotation error (rad).
    pub rotation_median: f64,
    /// 90th-percentile rotation error (rad).
    pub rotation_p90: f64,
}

/// Summarises motion errors; `None` when there are none.
pub fn summarize_errors(errors: &[MotionError]) -> Option<ErrorSummary> {
    let t: Vec<f64> = errors.iter().map(|e| e.translation).collect();
    let r: Vec<f64> = errors.iter().map(|e| e.rotation).collect();
    Some(ErrorSummary {
        pairs: errors.len(),
        translation_median: percentile(&t, 50.0)?,
        translation_p90: percentile(&t, 90.0)?,
        rotation_median: percentile(&r, 50.0)?,
        rotation_p90: percentile(&r, 90.0)?,
    })
}
