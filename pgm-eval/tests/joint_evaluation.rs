//! `evaluate_joint` and `evaluate_association` (joint paper, Tables I-III): an oracle
//! that returns the simulator's truth scores perfectly; hand-made pairs check the
//! object rules and the motion errors; nothing to score is `None`, never a perfect
//! score; errors name the pair.

use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_datasets::{Association, ClusterMotion, GroundTruth, ParamGuard, ScanPair};
use pgm_eval::{evaluate_association, evaluate_joint, scorable_for_joint, JointReport};
use pgm_scan::association::GroundTruthAssociations;
use pgm_scan::methods::{JointCluster, JointEstimate, JointEstimator};
use pgm_scan::{Pose2, Scan};

/// Returns the pair's ground truth as its estimate: true associations, one cluster per
/// true label (the background first), true outliers in the outlier cluster, true
/// motions and ego-motion.
struct Oracle;

impl JointEstimator for Oracle {
    fn name(&self) -> &str {
        "oracle"
    }

    fn estimate(&self, pair: &ScanPair) -> pgm_scan::Result<JointEstimate> {
        let truth = pair.truth.as_ref().expect("simulated pairs have truth");
        let labels = truth.labels.as_ref().expect("labels");
        let associations = truth.associations.clone().expect("associations");
        let ego = truth.ego_motion.expect("ego-motion");
        let mut ids: Vec<u32> = vec![0];
        let mut motions = vec![ego];
        let clusters = labels
            .iter()
            .zip(&associations)
            .map(|(l, a)| {
                let l = (*l)?;
                if *a == Some(Association::Outlier) {
                    return Some(JointCluster::Outlier);
                }
                let k = ids.iter().position(|&x| x == l).unwrap_or_else(|| {
                    ids.push(l);
                    motions.push(
                        truth
                            .motions
                            .iter()
                            .find(|m| m.label == l)
                            .map_or(ego, |m| m.motion),
                    );
                    ids.len() - 1
                });
                Some(JointCluster::Object(k))
            })
            .collect();
        Ok(JointEstimate {
            associations,
            clusters,
            motions,
            background: 0,
            ego_motion: ego,
            iterations: 3,
            converged: true,
        })
    }
}

fn simulated(n: usize) -> Vec<ScanPair> {
    simulate_pairs(&SimConfig::default().check().unwrap(), 5, n)
}

#[test]
fn the_truth_scores_perfectly() {
    let pairs = simulated(3);
    let report = evaluate_joint(&pairs, &Oracle).unwrap();
    let s = report.summary;
    assert_eq!(report.method, "oracle");
    assert_eq!(s.pairs, 3);
    assert_eq!(s.association_accuracy, Some(1.0));
    assert_eq!(s.association_accuracy_within_one, Some(1.0));
    assert_eq!(s.association_sed, Some(0.0));
    assert_eq!(s.clustering_accuracy, Some(1.0));
    assert_eq!(s.clustering_sed, Some(0.0));
    assert!((s.v_measure_mean.unwrap() - 1.0).abs() < 1e-12, "{s:?}");
    assert_eq!(s.outliers_predicted, s.outliers_true);
    assert!(s.outliers_true.unwrap() > 0.0);
    assert_eq!(s.outliers_found, Some(100.0));
    assert_eq!(s.ego_translation_error_median, Some(0.0));
    assert_eq!(s.ego_rotation_error_median, Some(0.0));
    assert_eq!(s.object_translation_error_median, Some(0.0));
    assert_eq!(s.object_rotation_error_median, Some(0.0));
    assert_eq!(s.iterations_mean, 3.0);
    assert!(report.objects_total > 0);
    assert_eq!(report.objects_correct, report.objects_total);
    assert_eq!(report.outcomes.len(), 3);
    assert_eq!(report.outcomes[1].name, pairs[1].name);
}

/// The oracle with every association moved one reference beam up and every return in
/// the background.
struct OffByOne;

impl JointEstimator for OffByOne {
    fn name(&self) -> &str {
        "off-by-one"
    }

    fn estimate(&self, pair: &ScanPair) -> pgm_scan::Result<JointEstimate> {
        let mut e = Oracle.estimate(pair)?;
        for a in e.associations.iter_mut().flatten() {
            if let Association::Point(b) = a {
                *b += 1;
            }
        }
        for c in e.clusters.iter_mut().flatten() {
            *c = JointCluster::Object(0);
        }
        e.motions.truncate(1);
        Ok(e)
    }
}

#[test]
fn errors_show_in_every_figure() {
    let pairs = simulated(2);
    let report = evaluate_joint(&pairs, &OffByOne).unwrap();
    let s = report.summary;
    // Only the outliers stay exact; within one beam everything is right.
    let outlier_share = s.outliers_true.unwrap() / 100.0;
    assert!(
        (s.association_accuracy.unwrap() - outlier_share).abs() < 0.05,
        "{s:?}"
    );
    assert_eq!(s.association_accuracy_within_one, Some(1.0));
    assert!(s.association_sed.unwrap() > 10.0);
    // One cluster: only the background is right, no moving object is.
    let c = s.clustering_accuracy.unwrap();
    assert!(c < 1.0 && c > 0.3, "{c}");
    // The outlier associations are kept, the outlier cluster is empty.
    assert_eq!(s.outliers_found, Some(100.0));
    assert_eq!(report.cluster_outliers[0], Some(0.0));
    assert_eq!(report.cluster_outliers[2], Some(0.0));
    assert_eq!(report.objects_correct, 0);
    assert_eq!(s.object_rotation_error_median, None);
    assert_eq!(s.object_translation_error_median, None);
    assert!(s.v_measure_mean.unwrap() < 0.9);
}

/// A pair of `n` returns on an arc 5 m away with the given labels, no associations,
/// and the given true motions and ego-motion.
fn hand_pair(labels: Vec<Option<u32>>, motions: Vec<ClusterMotion>) -> ScanPair {
    let n = labels.len();
    let angles: Vec<f64> = (0..n).map(|k| -1.0 + 2.0 * k as f64 / n as f64).collect();
    let scan = Scan::from_ranges(angles, vec![5.0; n], 30.0);
    ScanPair {
        name: "hand:0".into(),
        reference: scan.clone(),
        current: scan,
        odometry: None,
        truth: Some(GroundTruth {
            labels: Some(labels),
            motions,
            ego_motion: Some(Pose2::identity()),
            ..Default::default()
        }),
    }
}

/// Returns a fixed estimate.
struct Fixed(JointEstimate);

impl JointEstimator for Fixed {
    fn name(&self) -> &str {
        "fixed"
    }
    fn estimate(&self, _: &ScanPair) -> pgm_scan::Result<JointEstimate> {
        Ok(self.0.clone())
    }
}

fn fixed(clusters: &[usize], motions: Vec<Pose2>, ego: Pose2) -> Fixed {
    Fixed(JointEstimate {
        associations: vec![None; clusters.len()],
        clusters: clusters
            .iter()
            .map(|&k| Some(JointCluster::Object(k)))
            .collect(),
        motions,
        background: 0,
        ego_motion: ego,
        iterations: 1,
        converged: true,
    })
}

fn run(pair: &ScanPair, method: &Fixed) -> JointReport {
    evaluate_joint(std::slice::from_ref(pair), method).unwrap()
}

#[test]
fn objects_are_correct_with_more_than_half_their_returns_outside_the_background() {
    let truth_motion = Pose2::new(1.0, 0.0, 0.0);
    let labels = [0, 0, 0, 0, 1, 1, 1, 1].map(Some).to_vec();
    let pair = hand_pair(
        labels,
        vec![ClusterMotion {
            label: 1,
            motion: truth_motion,
            kind: "car".into(),
        }],
    );
    // 3 of the object's 4 returns in cluster 1, whose motion is 0.2 m and 0.1 rad off.
    let estimated = Pose2::new(1.2, 0.0, 0.1);
    let ego = Pose2::new(0.05, 0.0, 0.0);
    // The method's clusters per beam, the background (0) and the object's cluster (1)
    // with the estimated motion.
    let with_clusters = |clusters: &[usize]| {
        run(
            &pair,
            &fixed(clusters, vec![Pose2::identity(), estimated], ego),
        )
    };
    let r = with_clusters(&[0, 0, 0, 0, 1, 1, 1, 0]);
    assert_eq!((r.objects_correct, r.objects_total), (1, 1));
    let s = r.summary;
    assert!((s.object_rotation_error_median.unwrap() - 0.1).abs() < 1e-12);
    // The centroid error: where the two motions put the object's centroid.
    let centroid = {
        let p: Vec<_> = (4..8).map(|k| pair.current.beam_point(k)).collect();
        nalgebra::Point2::from(p.iter().map(|p| p.coords).sum::<nalgebra::Vector2<f64>>() / 4.0)
    };
    let expected =
        (estimated.transform_point(&centroid) - truth_motion.transform_point(&centroid)).norm();
    assert!((s.object_translation_error_median.unwrap() - expected).abs() < 1e-12);
    assert!((s.ego_translation_error_median.unwrap() - 0.05).abs() < 1e-12);
    assert_eq!(s.clustering_accuracy, Some(7.0 / 8.0));
    // No true associations: association figures are unknown, not perfect.
    assert_eq!(s.association_accuracy, None);
    assert_eq!(s.association_sed, None);
    assert_eq!(s.outliers_found, None);

    // Exactly half of the object's returns: not correctly clustered.
    let r = with_clusters(&[0, 0, 0, 0, 1, 1, 0, 0]);
    assert_eq!(r.objects_correct, 0);
    assert_eq!(r.summary.object_rotation_error_median, None);
    // The object in the background cluster (matched to it one to one, as the true
    // background is split off into cluster 1): not a detection.
    let r = with_clusters(&[1, 1, 1, 1, 0, 0, 0, 0]);
    assert_eq!(r.objects_correct, 0);
}

#[test]
fn bad_pairs_and_failing_methods_are_named_errors() {
    let mut pairs = simulated(2);
    pairs[1].truth = None;
    assert!(scorable_for_joint(&pairs[0]) && !scorable_for_joint(&pairs[1]));
    let e = evaluate_joint(&pairs, &Oracle).unwrap_err().to_string();
    assert!(e.contains(&pairs[1].name), "{e}");
    assert!(evaluate_joint(&[], &Oracle).is_err());

    struct Failing;
    impl JointEstimator for Failing {
        fn name(&self) -> &str {
            "failing"
        }
        fn estimate(&self, pair: &ScanPair) -> pgm_scan::Result<JointEstimate> {
            Err(pgm_scan::Error::BadPair {
                pair: pair.name.clone(),
                problem: "no luck".into(),
            })
        }
    }
    let e = evaluate_joint(&pairs[..1], &Failing)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("failing") && e.contains(&pairs[0].name) && e.contains("no luck"),
        "{e}"
    );

    // An estimate that does not fit the pair is refused, naming it.
    let short = fixed(&[0, 0], vec![Pose2::identity()], Pose2::identity());
    let e = evaluate_joint(&pairs[..1], &short).unwrap_err().to_string();
    assert!(
        e.contains(&pairs[0].name) && e.contains("2 associations"),
        "{e}"
    );
    let n = pairs[0].current.len();
    let beyond = fixed(&vec![3; n], vec![Pose2::identity()], Pose2::identity());
    let e = evaluate_joint(&pairs[..1], &beyond)
        .unwrap_err()
        .to_string();
    assert!(e.contains("beyond its 1 motions"), "{e}");
}

#[test]
fn true_associations_score_perfectly_as_a_source() {
    let pairs = simulated(2);
    let r = evaluate_association(&pairs, &GroundTruthAssociations).unwrap();
    assert_eq!(r.method, "true");
    assert_eq!(r.summary.pairs, 2);
    assert_eq!(r.summary.accuracy, 1.0);
    assert_eq!(r.summary.sed_mean, 0.0);
    assert_eq!(r.summary.outliers_found, Some(100.0));
    // The truth source estimates no ego-motion.
    assert_eq!(r.ego, None);
    let mut unlabelled = pairs.clone();
    unlabelled[0].truth = None;
    let e = evaluate_association(&unlabelled, &GroundTruthAssociations)
        .unwrap_err()
        .to_string();
    assert!(e.contains(&pairs[0].name), "{e}");
}

#[test]
fn without_true_associations_the_outlier_cluster_counts_as_background() {
    // No true associations (as on real data): a background return put in the outlier
    // cluster is scored as background, not as a wrong cluster of its own.
    let labels = vec![Some(0), Some(0), Some(0), Some(0), Some(1), Some(1)];
    let pair = hand_pair(labels, Vec::new());
    let mut estimate = fixed(
        &[0, 0, 0, 0, 1, 1],
        vec![Pose2::identity(); 2],
        Pose2::identity(),
    )
    .0;
    estimate.clusters[1] = Some(JointCluster::Outlier);
    let r = run(&pair, &Fixed(estimate.clone()));
    assert_eq!(r.summary.clustering_accuracy, Some(1.0));
    assert_eq!(r.summary.clustering_sed, Some(0.0));
    assert!((r.summary.v_measure_mean.unwrap() - 1.0).abs() < 1e-12);
    // Its share of the returns is still reported.
    let expected = 100.0 / 6.0;
    assert!((r.cluster_outliers[0].unwrap() - expected).abs() < 1e-9);
    assert_eq!(r.cluster_outliers[2], None, "no true outlier to find");
    // With true associations saying it is no outlier, it is wrong.
    let mut with_truth = pair.clone();
    with_truth.truth.as_mut().unwrap().associations =
        Some((0..6).map(|k| Some(Association::Point(k))).collect());
    estimate.associations = (0..6).map(|k| Some(Association::Point(k))).collect();
    let r = run(&with_truth, &Fixed(estimate));
    assert_eq!(r.summary.clustering_accuracy, Some(5.0 / 6.0));
}
