//! CRF-Clustering on leigh-gtm1 pairs 5 scans apart with the moving-person labels of
//! the data README (all annotated pairs; the weights were trained on simulated data
//! only). Skipped without the shared data folder, a failure under CI.
//!
//! The target is a mean V-measure of at least 0.6, above both baselines and
//! above the one-cluster labelling. The current model reaches 0.418 with the odometry
//! prior and 0.405 without it (one cluster 0.500, CBD 0.378 / 0.345, K-Means 0.079 /
//! 0.040; 19 of the 46 pairs with a labelled mover hold only people who stand, see
//! docs/decisions.md), so this test pins the level it reaches and that it beats both
//! baselines, with and without odometry; it does not (yet) meet the target.

use pgm_baselines::consistency::ConsistencyDetector;
use pgm_baselines::motion_kmeans::MotionKMeans;
use pgm_crf_clustering::Clusterer;
use pgm_datasets::builders::{leigh_pairs, LeighPairOptions};
use pgm_datasets::{leigh, testdata, ScanPair};
use pgm_eval::{evaluate_clustering, ClusteringSummary};
use pgm_scan::association::NearestAfterIcp;
use pgm_scan::methods::{Associated, MotionClusterer, OneCluster};
use std::sync::Arc;

/// The methods of the test: CRF-Clustering and K-Means with ICP associations, CBD
/// and one cluster.
fn methods() -> [Box<dyn MotionClusterer>; 4] {
    let icp = Arc::new(NearestAfterIcp::default());
    [
        Box::new(Associated::new(Clusterer::default(), icp.clone())),
        Box::new(Associated::new(MotionKMeans::default(), icp)),
        Box::new(ConsistencyDetector::default()),
        Box::new(OneCluster),
    ]
}

fn score(pairs: &[ScanPair], method: &dyn MotionClusterer) -> ClusteringSummary {
    evaluate_clustering(pairs, method)
        .expect("evaluates")
        .summary
}

#[test]
fn leigh_gtm1_k5() {
    let Some(dir) = testdata::shared_data_dir() else {
        return;
    };
    let base = dir.join("leigh-gtm1");
    let mut log = leigh::read_scans(base.join("scans.txt")).expect("scans");
    let odometry = base.join("odom_at_scan.txt");
    let odo = leigh::read_odometry(&odometry).expect("odometry");
    leigh::attach_odometry(&mut log, &odo, &odometry).expect("attach");
    let people = leigh::read_people(base.join("people_gt.txt")).expect("people");
    // The labels of the figures below: the displacement rule (issue 18 made the track
    // rule the default).
    let options = LeighPairOptions {
        rule: pgm_datasets::builders::LabelRule::Displacement,
        ..LeighPairOptions::default()
    };
    let pairs = leigh_pairs(&log, &people, &options).expect("pairs");
    assert!(pairs.len() >= 80, "{} pairs", pairs.len());
    let [crf_method, kmeans_method, cbd_method, one_method] = methods();
    // The labelling reproduces the independent figures: one cluster about
    // 0.50 (46 of 92 pairs have a moving person).
    let one = score(&pairs, one_method.as_ref());
    assert!(
        (one.v_measure_mean - 0.5).abs() < 0.03,
        "one cluster {:.3}",
        one.v_measure_mean
    );
    // Without odometry (the labels still come from it): the CRF picks the largest
    // cluster as background, ICP gives the ego-motion of the associations and CBD.
    let blind: Vec<ScanPair> = pairs
        .iter()
        .cloned()
        .map(|mut p| {
            p.odometry = None;
            p
        })
        .collect();
    // The regression floor of the current model holds with odometry (0.418 measured)
    // and without (0.405), above both baselines.
    for (condition, pairs) in [("", &pairs), (" without odometry", &blind)] {
        let crf = score(pairs, crf_method.as_ref());
        let cbd = score(pairs, cbd_method.as_ref());
        let kmeans = score(pairs, kmeans_method.as_ref());
        eprintln!(
            "leigh-gtm1 k=5{condition}: CRF V {:.3}, CBD {:.3}, K-Means {:.3}",
            crf.v_measure_mean, cbd.v_measure_mean, kmeans.v_measure_mean
        );
        if condition.is_empty() {
            // The figures with odometry: CBD about 0.31, K-Means about 0.10.
            assert!(
                (0.25..=0.45).contains(&cbd.v_measure_mean),
                "CBD {:.3}",
                cbd.v_measure_mean
            );
            assert!(
                (0.03..=0.17).contains(&kmeans.v_measure_mean),
                "K-Means {:.3}",
                kmeans.v_measure_mean
            );
        }
        assert!(
            crf.v_measure_mean >= 0.38,
            "CRF V-measure{condition} {:.3}",
            crf.v_measure_mean
        );
        assert!(crf.v_measure_mean > cbd.v_measure_mean);
        assert!(crf.v_measure_mean > kmeans.v_measure_mean + 0.2);
    }
}
