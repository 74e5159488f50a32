//! CRF-Clustering on held-out simulated pairs (seed 1; the shipped weights were
//! trained on seed 1000) against the baselines.
//!
//! The target for CRF with true associations is a mean V-measure of 0.95; the
//! current model reaches about 0.89 on 50 pairs (notes/issue7.md), so this test pins
//! what it does reach on a handful of pairs and that it beats both baselines. With
//! automatic associations the target is to beat both baselines: segment-wise ICP
//! associations do on simulated pairs (about 0.74 against CBD 0.66 on 50 pairs),
//! plain nearest neighbours after ICP do not (about 0.2).

use pgm_crf_clustering::evaluation::{evaluate_pair, summarize, EvaluationConfig, Method, Summary};
use pgm_crf_clustering::learning::{learn, training_instance};
use pgm_crf_clustering::{
    AssociationProvider, AssociationSource, Clusterer, ClusteringParams, NearestParams,
};
use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_datasets::ScanPair;

fn score(pairs: &[ScanPair], method: Method, associations: AssociationSource) -> Summary {
    let config = EvaluationConfig {
        method,
        associations,
        clusterer: Clusterer::default(),
        kmeans: Default::default(),
        cbd: Default::default(),
    };
    summarize(
        &pairs
            .iter()
            .map(|p| evaluate_pair(p, &config).expect("evaluates"))
            .collect::<Vec<_>>(),
    )
}

#[test]
fn crf_with_true_associations_beats_the_baselines_on_held_out_pairs() {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1, 8);
    let icp = AssociationSource::NearestAfterIcp(NearestParams::default());
    let crf = score(&pairs, Method::Crf, AssociationSource::GroundTruth);
    let cbd = score(&pairs, Method::Cbd, icp);
    let kmeans = score(&pairs, Method::KMeans, icp);
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
    let icp = AssociationSource::NearestAfterIcp(NearestParams::default());
    let segment = AssociationSource::automatic();
    let crf = score(&pairs, Method::Crf, segment);
    let crf_icp = score(&pairs, Method::Crf, icp);
    let cbd = score(&pairs, Method::Cbd, icp);
    let kmeans = score(&pairs, Method::KMeans, segment);
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
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 1000, 6);
    let params = ClusteringParams::default();
    let instances: Vec<_> = pairs
        .iter()
        .filter_map(|p| {
            training_instance(
                p,
                &AssociationSource::GroundTruth.associate(p).unwrap(),
                &params,
            )
            .unwrap()
        })
        .collect();
    assert_eq!(instances.len(), 6);
    let (weights, result) = learn(&instances, 10.0).expect("learns");
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
    // The dedicated chain solver runs the same algorithm as pgm-core's
    // HybridInference on the chain graph: same labels on (nearly) every point.
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
        let a = AssociationSource::GroundTruth.associate(pair).unwrap();
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
