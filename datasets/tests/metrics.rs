//! Metrics against reference values.
//!
//! The V-measure expectations were computed with scikit-learn 1.9.1,
//! `sklearn.metrics.homogeneity_completeness_v_measure(labels_true, labels_pred, beta=β)`,
//! printed with 17 significant digits.

// The reference values are kept exactly as scikit-learn printed them.
#![allow(clippy::excessive_precision)]

use pgm_datasets::metrics::*;
use pgm_datasets::{Association, Error};
use pgm_scan::Pose2;

fn check(truth: &[u32], predicted: &[u32], beta: f64, expected: [f64; 3]) {
    let v = homogeneity_completeness_v_measure(truth, predicted, beta).unwrap();
    let got = [v.homogeneity, v.completeness, v.v_measure];
    for k in 0..3 {
        assert!(
            (got[k] - expected[k]).abs() < 1e-12,
            "{truth:?} vs {predicted:?} (beta {beta}): got {got:?}, sklearn {expected:?}"
        );
    }
}

#[test]
fn v_measure_matches_scikit_learn() {
    check(&[0, 0, 1, 1], &[0, 0, 1, 1], 1.0, [1.0, 1.0, 1.0]);
    check(&[0, 0, 1, 1], &[1, 1, 0, 0], 1.0, [1.0, 1.0, 1.0]);
    // Swapping truth and prediction swaps homogeneity and completeness.
    let (h, c, v) = (
        0.66666666666666663,
        0.99999999999999989,
        0.79999999999999993,
    );
    check(&[0, 0, 1, 2], &[0, 0, 1, 1], 1.0, [h, c, v]);
    check(&[0, 0, 1, 1], &[0, 0, 1, 2], 1.0, [c, h, v]);
    check(&[0, 0, 1, 1], &[0, 1, 0, 1], 1.0, [0.0, 0.0, 0.0]);
    check(
        &[0, 0, 0, 1, 1, 1, 2, 2, 2, 2],
        &[0, 0, 1, 1, 1, 2, 2, 2, 0, 0],
        1.0,
        [
            0.39464837163589422,
            0.39464837163589422,
            0.39464837163589428,
        ],
    );
    let t = [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 2, 2];
    let p = [0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 0];
    // β weighs completeness against homogeneity in the V-measure only.
    let (h, c) = (0.56234782117743953, 0.60582221782512558);
    for (beta, v) in [
        (1.0, 0.58327605201334132),
        (2.0, 0.59060263760480314),
        (0.5, 0.57612901562050223),
    ] {
        check(&t, &p, beta, [h, c, v]);
    }
    check(
        &[0, 0, 0, 1, 1, 2],
        &[3, 3, 7, 7, 7, 7],
        1.0,
        [0.31466852103841358, 0.50000000000000022, 0.3862534428571302],
    );
}

#[test]
fn v_measure_edge_cases_match_scikit_learn() {
    // Single cluster: completeness 1, homogeneity 0.
    check(&[0, 1, 2, 3], &[0, 0, 0, 0], 1.0, [0.0, 1.0, 0.0]);
    // Single class: homogeneity 1, completeness 0.
    check(&[0, 0, 0, 0], &[0, 1, 2, 3], 1.0, [1.0, 0.0, 0.0]);
    // Single class and single cluster.
    check(&[0, 0, 0, 0], &[0, 0, 0, 0], 1.0, [1.0, 1.0, 1.0]);
    // Empty and one element.
    check(&[], &[], 1.0, [1.0, 1.0, 1.0]);
    check(&[0], &[5], 1.0, [1.0, 1.0, 1.0]);
}

#[test]
fn v_measure_rejects_bad_input() {
    assert!(matches!(
        homogeneity_completeness_v_measure(&[0u32, 1], &[0u32], 1.0),
        Err(Error::Mismatch { .. })
    ));
    assert!(homogeneity_completeness_v_measure(&[0u32], &[0u32], f64::NAN).is_err());
}

#[test]
fn clustering_v_measure_skips_unlabelled_beams_and_scores_outliers() {
    let truth = [Some(0), None, Some(1), Some(1), Some(0)];
    let predicted = [Some(4), Some(9), Some(2), Some(2), Some(4)];
    let v = clustering_v_measure(&truth, &predicted, 1.0).unwrap();
    assert!((v.v_measure - 1.0).abs() < 1e-12);
    // A predicted outlier (None) is a cluster of its own: splits class 1.
    let predicted = [Some(4), Some(9), None, Some(2), Some(4)];
    let v = clustering_v_measure(&truth, &predicted, 1.0).unwrap();
    assert!((v.homogeneity - 1.0).abs() < 1e-12);
    assert!(v.completeness < 0.9);
    // json-labels-all-null: no labelled beam is nothing to score, never V = 1.
    let err = clustering_v_measure(&[None, None], &[Some(0), Some(0)], 1.0).unwrap_err();
    assert!(matches!(err, Error::NothingToScore { .. }), "{err}");
}

#[test]
fn v_measure_never_leaves_zero_to_one() {
    // Class and cluster sizes whose entropies round below the mutual information of a
    // perfect match (found on the L03 pair: 1.0000000000000009).
    for n in 1..40usize {
        let truth: Vec<u32> = (0..3 * n + 7).map(|k| u32::from(k % 7 < 2)).collect();
        let predicted: Vec<u32> = truth.iter().map(|t| 5 - t).collect();
        let v = homogeneity_completeness_v_measure(&truth, &predicted, 1.0).unwrap();
        for x in [v.homogeneity, v.completeness, v.v_measure] {
            assert!((0.0..=1.0).contains(&x), "{x} for n = {n}");
            assert!((x - 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn edit_distance_is_levenshtein() {
    assert_eq!(edit_distance(b"kitten", b"sitting"), 3);
    assert_eq!(edit_distance(b"", b"abc"), 3);
    assert_eq!(edit_distance(b"abc", b""), 3);
    assert_eq!(edit_distance(b"flaw", b"lawn"), 2);
    assert_eq!(edit_distance::<u8>(&[], &[]), 0);
}

#[test]
fn clustering_edit_distance_ignores_cluster_names() {
    let truth = [Some(0), Some(0), Some(1), Some(1), Some(0)];
    let renamed = [Some(7), Some(7), Some(3), Some(3), Some(7)];
    assert_eq!(clustering_edit_distance(&truth, &renamed).unwrap(), 0);
    assert_eq!(clustering_accuracy(&truth, &renamed).unwrap(), Some(1.0));
    let one_wrong = [Some(7), Some(7), Some(3), Some(7), Some(7)];
    assert_eq!(clustering_edit_distance(&truth, &one_wrong).unwrap(), 1);
    assert_eq!(clustering_accuracy(&truth, &one_wrong).unwrap(), Some(0.8));
    // Outliers are not renamed: an outlier never matches a cluster.
    let with_outlier = [Some(7), Some(7), None, Some(3), Some(7)];
    assert_eq!(clustering_edit_distance(&truth, &with_outlier).unwrap(), 1);
    // Beams without ground truth are skipped.
    let truth = [None, Some(0), Some(1)];
    let predicted = [Some(5), Some(1), Some(2)];
    assert_eq!(clustering_edit_distance(&truth, &predicted).unwrap(), 0);
    assert_eq!(clustering_accuracy(&[None], &[Some(1)]).unwrap(), None);
}

#[test]
fn association_metrics() {
    use Association::*;
    let truth = [
        Some(Point(0)),
        Some(Point(1)),
        Some(Outlier),
        None,
        Some(Outlier),
    ];
    let predicted = [
        Some(Point(0)),
        Some(Point(2)),
        Some(Outlier),
        Some(Point(3)),
        Some(Point(4)),
    ];
    assert_eq!(association_accuracy(&truth, &predicted).unwrap(), Some(0.5));
    assert_eq!(association_edit_distance(&truth, &predicted).unwrap(), 2);
    let o = outlier_stats(&truth, &predicted).unwrap().unwrap();
    assert_eq!(o.predicted_percentage, 25.0);
    assert_eq!(o.true_percentage, 50.0);
    assert_eq!(o.found_percentage, Some(50.0));
    // No true outlier: nothing to find, not 100 % found.
    let clean = [Some(Point(0)), Some(Point(1))];
    let o = outlier_stats(&clean, &[Some(Outlier), Some(Point(1))])
        .unwrap()
        .unwrap();
    assert_eq!(o.predicted_percentage, 50.0);
    assert_eq!(o.true_percentage, 0.0);
    assert_eq!(o.found_percentage, None);
    assert_eq!(association_accuracy(&[None], &[None]).unwrap(), None);
    assert!(association_accuracy(&truth, &predicted[..2]).is_err());
}

#[test]
fn motion_errors_and_percentiles() {
    let e = motion_error(&Pose2::new(1.0, 1.0, 3.1), &Pose2::new(1.0, 0.0, -3.1));
    assert!((e.translation - 1.0).abs() < 1e-12);
    assert!((e.rotation - (2.0 * std::f64::consts::PI - 6.2)).abs() < 1e-12);
    // numpy.percentile([1, 2, 3, 4], [50, 90]) = [2.5, 3.7]
    assert_eq!(percentile(&[4.0, 1.0, 3.0, 2.0], 50.0), Some(2.5));
    assert!((percentile(&[4.0, 1.0, 3.0, 2.0], 90.0).unwrap() - 3.7).abs() < 1e-12);
    assert_eq!(percentile(&[], 50.0), None);
    assert_eq!(percentile(&[1.0], 101.0), None);
    let s = summarize_errors(&[e, e]).unwrap();
    assert_eq!(s.pairs, 2);
    assert!(summarize_errors(&[]).is_none());
}
