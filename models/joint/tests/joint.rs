//! The joint model on simulated pairs (the shipped weights were trained on seed 1000;
//! these pairs are seed 7): outputs fit the pair, the weights round-trip, bad
//! parameters are refused, training runs and refuses unlabelled pairs.

use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_joint::learning::{train, TrainingOptions};
use pgm_joint::{ClusterLabel, Clusters, Joint, JointParams, JointWeights};
use pgm_scan::{Association, ParamGuard};

#[test]
fn outputs_fit_the_pair() {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 7, 2);
    for pair in &pairs {
        let r = Joint::default().estimate(pair).unwrap();
        assert_eq!(r.associations.len(), pair.current.len());
        assert_eq!(r.clusters.len(), pair.current.len());
        for k in 0..pair.current.len() {
            assert_eq!(r.associations[k].is_some(), pair.current.valid[k]);
            assert_eq!(r.clusters[k].is_some(), pair.current.valid[k]);
            if let Some(Association::Point(b)) = r.associations[k] {
                assert!(pair.reference.valid[b]);
            }
            if let Some(ClusterLabel::Object(c)) = r.clusters[k] {
                assert!(c < r.motions.len());
            }
        }
        // Every reported motion cluster holds a return (vacuous ones are discarded),
        // the background aside.
        for c in 1..r.motions.len() {
            assert!(
                r.clusters.contains(&Some(ClusterLabel::Object(c))),
                "cluster {c}"
            );
        }
        let truth = pair.truth.as_ref().unwrap().ego_motion.unwrap();
        assert!(
            r.ego_motion.translation_error(&truth) < 0.1,
            "{}",
            pair.name
        );
        assert_eq!(r.ego_motion, r.motions[r.background]);
    }
}

#[test]
fn weights_round_trip_and_bad_parameters_are_refused() {
    let w = JointWeights::default();
    assert_eq!(w.weights.len(), 30);
    let back = JointWeights::from_json(&w.to_json().unwrap(), "test").unwrap();
    assert_eq!(back, w);
    assert!(JointWeights::from_json("{}", "nonsense").is_err());
    for bad in [
        JointParams {
            clusters: Clusters::Fixed(1),
            ..JointParams::default()
        },
        JointParams {
            clusters: Clusters::Adaptive { max: 40 },
            ..JointParams::default()
        },
        JointParams {
            max_rounds: 0,
            ..JointParams::default()
        },
        JointParams {
            tolerance: f64::NAN,
            ..JointParams::default()
        },
        JointParams {
            point_to_line: Some(-0.1),
            ..JointParams::default()
        },
        JointParams {
            point_to_line: Some(f64::INFINITY),
            ..JointParams::default()
        },
    ] {
        let e = bad.check().unwrap_err().to_string();
        assert!(e.contains("expected"), "{e}");
    }
}

#[test]
fn training_learns_usable_weights_and_refuses_unlabelled_pairs() {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1001, 6);
    let (weights, report) = train(&pairs, &TrainingOptions::default(), &mut ()).unwrap();
    assert_eq!(weights.weights.len(), 30);
    assert!(report.data_samples.1 > 0 && report.outlier_samples.1 > 0);
    let joint = JointParams {
        weights,
        ..JointParams::default()
    }
    .check()
    .unwrap();
    joint.estimate(&pairs[0]).unwrap();
    let mut unlabelled = pairs[0].clone();
    unlabelled.truth = None;
    let e = train(&[unlabelled], &TrainingOptions::default(), &mut ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("ground-truth"), "{e}");
}

/// Training options are checked before anything is allocated.
#[test]
fn training_options_out_of_range_are_refused() {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 5, 1);
    for options in [
        TrainingOptions {
            candidates: usize::MAX,
            ..TrainingOptions::default()
        },
        TrainingOptions {
            candidates: 0,
            ..TrainingOptions::default()
        },
        TrainingOptions {
            candidate_gate: f64::NAN,
            ..TrainingOptions::default()
        },
        TrainingOptions {
            prior_variance: 0.0,
            ..TrainingOptions::default()
        },
        TrainingOptions {
            stumps: 0,
            ..TrainingOptions::default()
        },
    ] {
        let e = train(&pairs, &options, &mut ()).unwrap_err().to_string();
        assert!(e.contains("parameter"), "{e}");
    }
}

/// Piecewise training keeps the given association part and learns the clustering
/// weights; a CRF-Matching weight file reads as an association part, anything else is
/// refused naming the source.
#[test]
fn piecewise_training_keeps_the_association_part() {
    use pgm_joint::AssociationPart;
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 11, 4);
    let shipped = JointWeights::default();
    let part = AssociationPart {
        weights: shipped.weights[..18].to_vec(),
        boosters: shipped.boosters.clone(),
    };
    let (w, report) =
        pgm_joint::learning::train_clustering(&pairs, &TrainingOptions::default(), &part, &mut ())
            .unwrap();
    assert_eq!(&w.weights[..18], &part.weights[..]);
    assert_eq!(w.boosters, part.boosters);
    assert_eq!(report.booster_pairs, 0);
    assert!(w.weights[18..].iter().any(|&x| x != 0.0));
    let matching = include_str!("../../crf-matching/weights/default.json");
    let read = AssociationPart::from_matching_json(matching, "matching.json").unwrap();
    assert_eq!(read.weights.len(), 18);
    let joint_file = shipped.to_json().unwrap();
    let e = AssociationPart::from_matching_json(&joint_file, "joint.json")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("joint.json"), "{e}");
}

/// The rotation prior on the reported object motions changes nothing but those
/// motions, and on pedestrians (a few returns of legs hardly observe a rotation) it
/// brings the median rotation error of correctly clustered objects down.
#[test]
fn rotation_prior_changes_only_the_object_motions_and_helps_small_objects() {
    use pgm_datasets::sim::Preset;
    use pgm_eval::evaluate_joint;
    let config = SimConfig::for_preset(Preset::Pedestrians).check().unwrap();
    let pairs = simulate_pairs(&config, 7, 8);
    let with = Joint::default();
    assert_eq!(with.params().object_rotation_sigma, Some(0.05));
    let without = JointParams {
        object_rotation_sigma: None,
        ..JointParams::default()
    }
    .check()
    .unwrap();
    for pair in &pairs {
        let (a, b) = (
            with.estimate(pair).unwrap(),
            without.estimate(pair).unwrap(),
        );
        assert_eq!(a.associations, b.associations, "{}", pair.name);
        assert_eq!(a.clusters, b.clusters);
        assert_eq!(a.ego_motion, b.ego_motion);
    }
    let rotation = |joint: &Joint| {
        evaluate_joint(&pairs, joint)
            .unwrap()
            .summary
            .object_rotation_error_median
            .expect("objects found")
    };
    let (prior, plain) = (rotation(&with), rotation(&without));
    assert!(
        prior < plain,
        "with the prior {prior} rad, without {plain} rad"
    );
    assert!(JointParams {
        object_rotation_sigma: Some(0.0),
        ..JointParams::default()
    }
    .check()
    .is_err());
}

/// The hypotheses segment-wise ICP makes, given back, give the same estimate; other
/// hypotheses give another; a segment marked moved without a return changes nothing;
/// bad ones are refused with the pair named.
#[test]
fn given_hypotheses_are_the_ones_used_and_bad_ones_are_refused() {
    use pgm_datasets::sim::Preset;
    use pgm_scan::association::segment_motions;
    use pgm_scan::Pose2;
    let config = SimConfig::for_preset(Preset::Overtaking).check().unwrap();
    let pairs = simulate_pairs(&config, 7, 3);
    let joint = Joint::default();
    let segments = joint.params().segments.check().unwrap();
    for pair in &pairs {
        let h = segment_motions(pair, &segments).unwrap();
        let found = joint.estimate(pair).unwrap();
        assert_eq!(joint.estimate_with_hypotheses(pair, &h).unwrap(), found);
        let shifted = h.map_moved(|m| Pose2::new(m.x() + 1.0, m.y(), m.theta()));
        let moved = joint.estimate_with_hypotheses(pair, &shifted).unwrap();
        assert_ne!(moved.associations, found.associations, "{}", pair.name);
        let mut empty = h.clone();
        empty.moved.extend([true, true]);
        assert_eq!(joint.estimate_with_hypotheses(pair, &empty).unwrap(), found);
    }
    let pair = &pairs[0];
    let mut h = segment_motions(pair, &segments).unwrap();
    h.segment_of.pop();
    let e = joint
        .estimate_with_hypotheses(pair, &h)
        .unwrap_err()
        .to_string();
    assert!(e.contains(&pair.name) && e.contains("valid returns"), "{e}");
}
