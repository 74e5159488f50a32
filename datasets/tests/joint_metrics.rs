//! The joint paper's metrics (Table II clustering accuracy with the outlier cluster,
//! clustering SED, outlier-cluster figures; the one-to-one matching behind them) on
//! hand-made cases whose answers are known.

use pgm_datasets::metrics::*;
use pgm_datasets::Association;
use pgm_scan::methods::JointCluster::{self, Object, Outlier};

fn some(c: &[JointCluster]) -> Vec<Option<JointCluster>> {
    c.iter().copied().map(Some).collect()
}

/// Returns each in the motion cluster `Object(id)` of its id.
fn objects(ids: &[usize]) -> Vec<Option<JointCluster>> {
    ids.iter().map(|&id| Some(Object(id))).collect()
}

#[test]
fn matching_maximises_the_total_weight_not_the_largest_entry() {
    // Greedy (largest entry first) takes (0, 0) = 3 and then (1, 1) = 0: total 3. The
    // optimum is (0, 1) + (1, 0) = 2 + 3 = 5.
    let m = maximum_weight_matching(&[vec![3, 2], vec![3, 0]]).unwrap();
    assert_eq!(m, vec![Some(1), Some(0)]);
    // A permutation is recovered exactly.
    let m = maximum_weight_matching(&[vec![0, 0, 9], vec![7, 0, 0], vec![0, 5, 0]]).unwrap();
    assert_eq!(m, vec![Some(2), Some(0), Some(1)]);
}

#[test]
fn matching_leaves_the_surplus_rows_unmatched() {
    // More rows than columns: the best row takes the only column.
    let m = maximum_weight_matching(&[vec![5], vec![7], vec![1]]).unwrap();
    assert_eq!(m, vec![None, Some(0), None]);
    // More columns than rows: every row is matched.
    let m = maximum_weight_matching(&[vec![1, 8, 2]]).unwrap();
    assert_eq!(m, vec![Some(1)]);
    // Nothing to match.
    assert_eq!(
        maximum_weight_matching(&[]).unwrap(),
        Vec::<Option<usize>>::new()
    );
    assert_eq!(
        maximum_weight_matching(&[vec![], vec![]]).unwrap(),
        vec![None, None]
    );
}

#[test]
fn matching_refuses_ragged_rows() {
    let e = maximum_weight_matching(&[vec![1, 2], vec![3]]).unwrap_err();
    assert!(e.to_string().contains("row 1 has 1 weights"), "{e}");
}

#[test]
fn joint_truth_marks_true_outliers() {
    use Association::{Outlier as Out, Point};
    let labels = [Some(0), Some(1), None, Some(1), Some(0)];
    let associations = [Some(Point(0)), Some(Out), None, Some(Point(3)), None];
    assert_eq!(
        joint_truth(&labels, Some(&associations)).unwrap(),
        vec![
            Some(Object(0)),
            Some(Outlier),
            None,
            Some(Object(1)),
            Some(Object(0))
        ]
    );
    // Without true associations no return is a true outlier.
    assert_eq!(
        joint_truth(&labels, None).unwrap(),
        vec![
            Some(Object(0)),
            Some(Object(1)),
            None,
            Some(Object(1)),
            Some(Object(0))
        ]
    );
    assert!(joint_truth(&labels, Some(&associations[..2])).is_err());
}

#[test]
fn renamed_clusters_are_all_correct() {
    let truth = some(&[
        Object(0),
        Object(0),
        Object(0),
        Object(1),
        Object(1),
        Outlier,
    ]);
    let predicted = some(&[
        Object(5),
        Object(5),
        Object(5),
        Object(2),
        Object(2),
        Outlier,
    ]);
    let m = match_clusterings(&truth, &predicted).unwrap();
    assert_eq!(m.scored, 6);
    assert_eq!(m.correct, 6);
    assert_eq!(m.outliers_correct, 1);
    assert_eq!(m.matches, vec![(0, 5, 3), (1, 2, 2)]);
    assert_eq!(m.object_returns.get(&0), Some(&3));
    assert_eq!(m.object_returns.get(&1), Some(&2));
    assert_eq!(
        clustering_accuracy_matched(&truth, &predicted).unwrap(),
        Some(1.0)
    );
    assert_eq!(clustering_sed(&truth, &predicted).unwrap(), 0);
}

#[test]
fn one_to_one_matching_beats_majority_voting() {
    // Object 0 has 3 returns in cluster 7 and 2 in cluster 8; object 1 has 3 in
    // cluster 7. One to one, the best is 0 -> 8 and 1 -> 7: 5 of 8 correct (majority
    // voting would give both objects cluster 7).
    let truth = objects(&[0, 0, 0, 0, 0, 1, 1, 1]);
    let predicted = objects(&[7, 7, 7, 8, 8, 7, 7, 7]);
    let m = match_clusterings(&truth, &predicted).unwrap();
    assert_eq!(m.matches, vec![(0, 8, 2), (1, 7, 3)]);
    assert_eq!(m.accuracy(), Some(5.0 / 8.0));
}

#[test]
fn surplus_predicted_clusters_and_missed_objects_are_wrong() {
    // More predicted clusters than true objects: the background split in two, only one
    // part can be matched.
    let truth = objects(&[0, 0, 0, 0, 1, 1]);
    let predicted = objects(&[0, 0, 3, 3, 1, 1]);
    assert_eq!(
        clustering_accuracy_matched(&truth, &predicted).unwrap(),
        Some(4.0 / 6.0)
    );
    // More true objects than predicted clusters: one cluster for everything matches
    // one object only.
    let truth = objects(&[0, 0, 1, 1, 2, 2]);
    let predicted = some(&[Object(0); 6]);
    let m = match_clusterings(&truth, &predicted).unwrap();
    assert_eq!(m.matches.len(), 1);
    assert_eq!(m.accuracy(), Some(2.0 / 6.0));
}

#[test]
fn outliers_must_be_outliers_in_both() {
    let truth = some(&[Outlier, Outlier, Object(0), Object(0)]);
    // A true outlier in a motion cluster is wrong, a true object in the outlier
    // cluster is wrong: 1 outlier + 1 background return correct.
    let predicted = some(&[Outlier, Object(0), Outlier, Object(0)]);
    let m = match_clusterings(&truth, &predicted).unwrap();
    assert_eq!(m.outliers_correct, 1);
    assert_eq!(m.correct, 2);
    assert_eq!(m.accuracy(), Some(0.5));
    // A return without a prediction is wrong whatever its truth.
    let mut unpredicted = predicted.clone();
    unpredicted[0] = None;
    unpredicted[3] = None;
    assert_eq!(
        clustering_accuracy_matched(&truth, &unpredicted).unwrap(),
        Some(0.0)
    );
    let o = cluster_outlier_stats(&truth, &predicted).unwrap().unwrap();
    assert_eq!(o.predicted_percentage, 50.0);
    assert_eq!(o.true_percentage, 50.0);
    assert_eq!(o.found_percentage, Some(50.0));
    // No true outlier: nothing to find.
    let clean = some(&[Object(0), Object(0)]);
    let o = cluster_outlier_stats(&clean, &some(&[Outlier, Object(1)]))
        .unwrap()
        .unwrap();
    assert_eq!((o.predicted_percentage, o.found_percentage), (50.0, None));
}

#[test]
fn nothing_to_score_is_none_not_a_perfect_score() {
    assert_eq!(clustering_accuracy_matched(&[], &[]).unwrap(), None);
    assert_eq!(
        clustering_accuracy_matched(&[None, None], &some(&[Object(0), Outlier])).unwrap(),
        None
    );
    assert_eq!(
        cluster_outlier_stats(&[None], &[Some(Outlier)]).unwrap(),
        None
    );
    assert_eq!(clustering_sed(&[], &[]).unwrap(), 0);
    // Unlabelled beams are not scored at all.
    let truth = vec![None, Some(Object(0)), None];
    let predicted = some(&[Object(4), Object(9), Outlier]);
    assert_eq!(
        clustering_accuracy_matched(&truth, &predicted).unwrap(),
        Some(1.0)
    );
}

#[test]
fn lengths_must_agree() {
    let truth = some(&[Object(0), Object(0)]);
    assert!(match_clusterings(&truth, &truth[..1]).is_err());
    assert!(clustering_sed(&truth, &truth[..1]).is_err());
    assert!(cluster_outlier_stats(&truth, &truth[..1]).is_err());
}

#[test]
fn clustering_sed_renames_clusters_but_not_the_outlier_cluster() {
    let truth = some(&[Object(0), Outlier, Object(1), Object(1)]);
    assert_eq!(
        clustering_sed(&truth, &some(&[Object(7), Outlier, Object(3), Object(3)])).unwrap(),
        0
    );
    // An outlier predicted as a cluster: one substitution.
    assert_eq!(
        clustering_sed(&truth, &some(&[Object(7), Object(7), Object(3), Object(3)])).unwrap(),
        1
    );
    // Two clusters merged: renamed, [0, -, 1, 1] against [0, -, 0, 0], two
    // substitutions.
    assert_eq!(
        clustering_sed(&truth, &some(&[Object(2), Outlier, Object(2), Object(2)])).unwrap(),
        2
    );
    // Without outliers it is the label edit distance.
    let labels_truth = [Some(0u32), Some(0), Some(1)];
    let labels_predicted = [Some(4u32), Some(5), Some(5)];
    let as_joint = |l: &[Option<u32>]| -> Vec<Option<JointCluster>> {
        l.iter().map(|x| x.map(|x| Object(x as usize))).collect()
    };
    assert_eq!(
        clustering_sed(&as_joint(&labels_truth), &as_joint(&labels_predicted)).unwrap(),
        clustering_edit_distance(&labels_truth, &labels_predicted).unwrap()
    );
}
