//! Detection metrics of `pgm_eval` (issue 18) on hand-made pairs and
//! labellings whose figures are worked out by hand.

use pgm_datasets::{ClusterMotion, GroundTruth, ScanPair};
use pgm_eval::{evaluate_clustering_with, DetectionOptions};
use pgm_scan::methods::{MotionClusterer, MotionClustering};
use pgm_scan::{Pose2, Scan};
use std::collections::HashMap;

/// A pair of `n` returns on a line, with the given true labels and true motions.
fn pair(name: &str, truth: Vec<Option<u32>>, motions: Vec<ClusterMotion>) -> ScanPair {
    let n = truth.len();
    let angles: Vec<f64> = (0..n).map(|k| -1.0 + 2.0 * k as f64 / n as f64).collect();
    let scan = Scan::from_ranges(angles, vec![5.0; n], 30.0);
    ScanPair {
        name: name.into(),
        reference: scan.clone(),
        current: scan,
        odometry: None,
        truth: Some(GroundTruth {
            labels: Some(truth),
            motions,
            ..Default::default()
        }),
    }
}

/// Returns the labelling stored for each pair name.
struct Fixed(HashMap<String, (Vec<Option<u32>>, Vec<ClusterMotion>)>);

impl MotionClusterer for Fixed {
    fn name(&self) -> String {
        "fixed".into()
    }
    fn cluster(&self, pair: &ScanPair) -> pgm_scan::Result<MotionClustering> {
        let (labels, motions) = self.0[&pair.name].clone();
        Ok(MotionClustering {
            labels,
            motions,
            ego_motion: None,
            iterations: 0,
            converged: true,
        })
    }
}

fn labels(spec: &str) -> Vec<Option<u32>> {
    spec.chars().map(|c| c.to_digit(10)).collect()
}

fn motion(label: u32, x: f64, theta: f64) -> ClusterMotion {
    ClusterMotion {
        label,
        motion: Pose2::new(x, 0.0, theta),
        kind: String::new(),
    }
}

#[test]
fn detection_figures_worked_out_by_hand() {
    // Pair a: object 1 (6 returns) found by cluster 2 (6 of its 7 returns are it, it
    // holds all 6); object 2 (4 returns, under the minimum of 5) half in cluster 3,
    // which is all object 2; cluster 4 on background (a false alarm).
    let a_truth = labels("000111111000022220000");
    let a_pred = labels("002222222000033004400");
    // Pair b: no mover; the method reports one moving cluster (a false alarm, and a
    // pair without a mover where something is reported moving).
    let b_truth = labels("0000000000");
    let b_pred = labels("0000011000");
    // Pair c: no mover, nothing reported (one return unlabelled). Pair d: object 1 (5
    // returns) split 2 + 3 across clusters 5 and 2, both all object: cluster 2 holds
    // 3 of 5, so the object is found, and neither cluster is a false alarm.
    let c_truth = labels("00000-0000");
    let c_pred = labels("00000-0000");
    let d_truth = labels("0011111000");
    let d_pred = labels("0055222000");
    let pairs = vec![
        pair(
            "a",
            a_truth,
            vec![
                motion(0, 0.0, 0.0),
                motion(1, 1.0, 0.1),
                motion(2, -1.0, 0.0),
            ],
        ),
        pair("b", b_truth, vec![]),
        pair("c", c_truth, vec![]),
        pair("d", d_truth, vec![motion(1, 2.0, 0.0)]),
    ];
    let method = Fixed(
        [
            (
                "a".to_string(),
                (a_pred, vec![motion(2, 1.1, 0.12), motion(3, 0.0, 0.0)]),
            ),
            ("b".to_string(), (b_pred, vec![])),
            ("c".to_string(), (c_pred, vec![])),
            ("d".to_string(), (d_pred, vec![motion(2, 2.0, 0.03)])),
        ]
        .into_iter()
        .collect(),
    );
    let report = evaluate_clustering_with(&pairs, &method, &DetectionOptions::default()).unwrap();
    let d = report.detection;
    assert_eq!(d.min_object_returns, 5);
    // Counted objects: a/1 (6 returns) and d/1 (5); a/2 has 4. Both found.
    assert_eq!((d.objects_counted, d.objects_detected), (2, 2));
    assert_eq!(d.object_recall, Some(1.0));
    // False alarms: a/4 (background), b/1; cluster a/3 is half object 2 (not a false
    // alarm); d/5 is all object (not a false alarm). 2 over 4 pairs.
    assert_eq!(d.false_alarms_per_pair, 0.5);
    // Pairs without a mover: b and c; b reports something moving.
    assert_eq!(d.pairs_without_mover, 2);
    assert_eq!(d.false_alarm_pair_share, Some(0.5));
    // Points: predicted moving a 11 (7+2+2), b 2, d 5 = 18; moving a 10, d 5 = 15;
    // both: a 6 + 2 = 8, d 5 = 13.
    assert_eq!(d.moving_precision, Some(13.0 / 18.0));
    assert_eq!(d.moving_recall, Some(13.0 / 15.0));
    // Motion errors of the counted found objects: a/1 rotation 0.02, d/1 0.03 ->
    // median (percentile 50 of two) between them; translation errors positive.
    let rot = d.object_rotation_error_median.unwrap();
    assert!((0.02 - 1e-9..=0.03 + 1e-9).contains(&rot), "{rot}");
    assert!(d.object_translation_error_median.unwrap() > 0.0);
    // V over all pairs and over the mover pairs (a and d).
    let v: Vec<f64> = report.outcomes.iter().map(|o| o.score.v_measure).collect();
    assert_eq!(d.mover_pairs, 2);
    assert!((d.v_measure_mover_pairs.unwrap() - (v[0] + v[3]) / 2.0).abs() < 1e-12);
    assert!((d.v_measure_mean - v.iter().sum::<f64>() / 4.0).abs() < 1e-12);
    assert_eq!(v[2], 1.0);
    assert_eq!(v[1], 0.0);
    // Per pair.
    let a = &report.outcomes[0];
    assert_eq!(a.false_alarms, 1);
    assert_eq!(a.objects.len(), 2);
    assert!(a.objects[0].detected && a.objects[0].counted);
    assert!(!a.objects[1].counted);
    // With a minimum of 3 returns object a/2 counts: cluster 3 holds 2 of its 4
    // returns and is half it: detected (at least half both ways).
    let report = evaluate_clustering_with(
        &pairs,
        &method,
        &DetectionOptions {
            min_object_returns: 3,
        },
    )
    .unwrap();
    assert_eq!(report.detection.objects_counted, 3);
    assert_eq!(report.detection.objects_detected, 3);
}

#[test]
fn a_split_object_is_not_detected_and_nothing_reported_is_no_alarm() {
    // Object of 6 returns split 2 + 2 + 2: no cluster holds half of it.
    let truth = labels("0001111110");
    let pred = labels("0001122330");
    let pairs = vec![pair("s", truth, vec![])];
    let method = Fixed([("s".to_string(), (pred, vec![]))].into_iter().collect());
    let r = evaluate_clustering_with(&pairs, &method, &DetectionOptions::default()).unwrap();
    let d = r.detection;
    assert_eq!((d.objects_counted, d.objects_detected), (1, 0));
    assert_eq!(d.object_recall, Some(0.0));
    assert_eq!(d.false_alarms_per_pair, 0.0);
    assert_eq!(d.false_alarm_pair_share, None);
    assert_eq!(d.moving_precision, Some(1.0));
    assert_eq!(d.object_translation_error_median, None);
    // One cluster: nothing predicted moving.
    let one = Fixed(
        [("s".to_string(), (labels("0000000000"), vec![]))]
            .into_iter()
            .collect(),
    );
    let d = evaluate_clustering_with(&pairs, &one, &DetectionOptions::default())
        .unwrap()
        .detection;
    assert_eq!(d.moving_precision, None);
    assert_eq!(d.moving_recall, Some(0.0));
    assert_eq!(d.object_recall, Some(0.0));
}
