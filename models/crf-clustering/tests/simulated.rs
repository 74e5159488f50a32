//! CRF-Clustering on held-out simulated pairs (seed 1; the shipped weights were
//! trained on seed 1000) against the baselines.
//!
//! The target for CRF with true associations is a mean V-measure of 0.95; the
//! current model reaches about 0.89 on 50 pairs (docs/decisions.md), so this test pins
//! what it does reach on a handful of pairs and that it beats both baselines. With
//! automatic associations the target is to beat both baselines: segment-wise ICP
//! associations do on simulated pairs (about 0.74 against CBD 0.66 on 50 pairs),
//! plain nearest neighbours after ICP do not (about 0.2).

use pgm_baselines::consistency::ConsistencyDetector;
use pgm_baselines::motion_kmeans::MotionKMeans;
use pgm_crf_clustering::learning::{learn, training_instances};
use pgm_crf_clustering::{Clusterer, ClusteringParams};
use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_datasets::ScanPair;
use pgm_eval::{evaluate_clustering, ClusteringSummary};
use pgm_scan::association::{
    AssociationSource, GroundTruthAssociations, NearestAfterIcp, SegmentIcp,
};
use pgm_scan::methods::{Associated, MotionClusterer};
use pgm_scan::ParamGuard;
use std::sync::Arc;

fn score(pairs: &[ScanPair], method: &dyn MotionClusterer) -> ClusteringSummary {
    evaluate_clustering(pairs, method)
        .expect("evaluates")
        .summary
}

fn crf(source: impl AssociationSource + 'static) -> Associated<Clusterer> {
    Associated::new(Clusterer::default(), Arc::new(source))
}

fn kmeans(source: impl AssociationSource + 'static) -> Associated<MotionKMeans> {
    Associated::new(MotionKMeans::default(), Arc::new(source))
}

#[test]
fn crf_with_true_associations_beats_the_baselines_on_held_out_pairs() {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1, 8);
    let crf = score(&pairs, &crf(GroundTruthAssociations));
    let cbd = score(&pairs, &ConsistencyDetector::default());
    let kmeans = score(&pairs, &kmeans(NearestAfterIcp::default()));
    eprintln!(
        "CRF-T V {:.3}, CBD {:.3}, K-Means (ICP) {:.3}",
        crf.v_measure_mean, cbd.v_measure_mean, kmeans.v_measure_mean
    );
    assert!(
        crf.v_measure_mean >= 0.85,
        "CRF-T V-measure {:.3}",
        crf.v_measure_mean
    );
    assert!(crf.v_measure_mean > cbd.v_measure_mean + 0.1);
    assert!(crf.v_measure_mean > kmeans.v_measure_mean + 0.1);
    assert!((2.0..=30.0).contains(&crf.iterations_mean));
}

#[test]
fn crf_with_segment_icp_associations_beats_the_baselines() {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1, 16);
    let crf_icp = score(&pairs, &crf(NearestAfterIcp::default()));
    let cbd = score(&pairs, &ConsistencyDetector::default());
    let kmeans = score(&pairs, &kmeans(SegmentIcp::default()));
    let crf = score(&pairs, &crf(SegmentIcp::default()));
    eprintln!(
        "CRF (segment-ICP) V {:.3}, CRF (ICP) {:.3}, CBD {:.3}, K-Means (segment-ICP) {:.3}",
        crf.v_measure_mean, crf_icp.v_measure_mean, cbd.v_measure_mean, kmeans.v_measure_mean
    );
    assert!(
        crf.v_measure_mean > cbd.v_measure_mean,
        "{crf:?} vs {cbd:?}"
    );
    assert!(crf.v_measure_mean > kmeans.v_measure_mean + 0.1);
    assert!(crf.v_measure_mean > crf_icp.v_measure_mean + 0.3);
}

#[test]
fn training_recovers_weights_that_penalise_distance() {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1000, 20);
    let params = ClusteringParams::default();
    let instances = training_instances(&pairs, &[&GroundTruthAssociations], &params).unwrap();
    assert_eq!(instances.len(), 20);
    let (weights, result) = learn(&instances, 10.0, &mut ()).expect("learns");
    assert!(result.converged);
    // Far partners must be unlikely for near points and neighbours must like to agree.
    assert!(
        weights.distance[0] + weights.distance[1] / 0.0025 < 0.0,
        "{weights:?}"
    );
    assert!(weights.neighbour[0] > weights.neighbour[1], "{weights:?}");
    assert!(ClusteringParams {
        weights,
        ..ClusteringParams::default()
    }
    .check()
    .is_ok());
}

#[test]
fn chain_solver_agrees_with_the_generic_hybrid_inference() {
    // The core's chain solver runs the same algorithm as pgm-core's HybridInference
    // on the chain graph: same labels on (nearly) every point.
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1, 8);
    let fast = Clusterer::default();
    let generic = ClusteringParams {
        chain_solver: false,
        ..ClusteringParams::default()
    }
    .check()
    .unwrap();
    let (mut same, mut total) = (0usize, 0usize);
    for pair in &pairs {
        let a = GroundTruthAssociations.associate(pair).unwrap();
        let x = fast.cluster_pair(pair, &a).unwrap();
        let y = generic.cluster_pair(pair, &a).unwrap();
        assert_eq!(x.labels.len(), y.labels.len());
        total += x.labels.iter().filter(|l| l.is_some()).count();
        same += x
            .labels
            .iter()
            .zip(&y.labels)
            .filter(|(p, q)| p.is_some() && p == q)
            .count();
        assert!(x.background_motion.translation_error(&y.background_motion) < 1e-3);
        assert!(
            x.iterations <= y.iterations,
            "{} > {}",
            x.iterations,
            y.iterations
        );
    }
    assert!(
        same as f64 >= 0.99 * total as f64,
        "{same} of {total} labels agree"
    );
}

#[test]
fn training_without_a_moving_object_is_refused() {
    // Pairs whose labels hold only the background (a static log) teach nothing about
    // distance; learning must refuse them instead of writing weights the model
    // rejects.
    let mut pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1000, 3);
    for p in &mut pairs {
        let truth = p.truth.as_mut().unwrap();
        for l in truth.labels.as_mut().unwrap().iter_mut().flatten() {
            *l = 0;
        }
    }
    let params = ClusteringParams::default();
    let instances = training_instances(&pairs, &[&GroundTruthAssociations], &params).unwrap();
    assert_eq!(instances.len(), 3);
    let err = learn(&instances, 10.0, &mut ()).unwrap_err().to_string();
    assert!(err.contains("none with a moving object"), "{err}");
}

/// The rotation prior on the reported object motions changes no label, and on
/// pedestrians (a few returns of legs hardly observe a rotation) brings the median
/// rotation error of the objects found down (CRF-Matching's associations stand in
/// for any automatic source: here segment-wise ICP's).
#[test]
fn rotation_prior_changes_only_the_object_motions_and_helps_small_objects() {
    use pgm_datasets::sim::Preset;
    let config = SimConfig::for_preset(Preset::Pedestrians).check().unwrap();
    let pairs = simulate_pairs(&config, 1, 8);
    let with = Clusterer::default();
    assert_eq!(with.params().object_rotation_sigma, Some(0.05));
    let without = ClusteringParams {
        object_rotation_sigma: None,
        ..ClusteringParams::default()
    }
    .check()
    .unwrap();
    let method = |c: Clusterer| Associated::new(c, Arc::new(SegmentIcp::default()));
    let (a, b) = (
        evaluate_clustering(&pairs, &method(with)).unwrap(),
        evaluate_clustering(&pairs, &method(without)).unwrap(),
    );
    for (x, y) in a.outcomes.iter().zip(&b.outcomes) {
        assert_eq!(x.labels, y.labels, "{}", x.name);
    }
    let (prior, plain) = (
        a.detection
            .object_rotation_error_median
            .expect("objects found"),
        b.detection
            .object_rotation_error_median
            .expect("objects found"),
    );
    assert!(
        prior < plain,
        "with the prior {prior} rad, without {plain} rad"
    );
    assert!(ClusteringParams {
        object_rotation_sigma: Some(f64::NAN),
        ..ClusteringParams::default()
    }
    .check()
    .is_err());
}
