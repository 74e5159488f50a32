//! CRF-Clustering inference on one simulated 361-beam pair (preset mixed, seed 1,
//! pair 0, true associations): initial segmentation, hybrid inference rounds with
//! merging, background selection — everything after the associations. Both motion
//! update policies are measured (motions re-solved after every sweep, the default, or
//! after every variable visit as in Algorithm 1 of the joint-model paper), both on the
//! core's exact chain solver (`pgm_core::hybrid::chain`), and the default policy on
//! the generic loopy engine (`generic_every_sweep`, `pgm_core::hybrid::HybridInference`)
//! for comparison.
//!
//! Run: `cargo bench --bench clustering`.

use criterion::{criterion_group, criterion_main, Criterion};
use pgm_crf_clustering::{ClusteringInput, ClusteringParams, UpdateSchedule};
use pgm_datasets::sim::{simulate_pair, SimConfig};
use pgm_scan::association::{AssociationSource, GroundTruthAssociations};
use pgm_scan::ParamGuard;
use std::time::Duration;

fn inference(c: &mut Criterion) {
    let pair = simulate_pair(&SimConfig::default().check().expect("valid"), 1, 0);
    let associations = GroundTruthAssociations
        .associate(&pair)
        .expect("simulated truth");
    let input = ClusteringInput::from_pair(&pair, &associations).expect("valid input");
    let mut group = c.benchmark_group("crf_clustering_361_beams");
    group
        .sample_size(50)
        .measurement_time(Duration::from_secs(5));
    for (name, update, chain_solver) in [
        ("every_sweep", UpdateSchedule::EverySweep, true),
        ("every_visit", UpdateSchedule::EveryVisit, true),
        ("generic_every_sweep", UpdateSchedule::EverySweep, false),
    ] {
        let clusterer = ClusteringParams {
            update,
            chain_solver,
            ..ClusteringParams::default()
        }
        .check()
        .expect("valid");
        group.bench_function(name, |b| {
            b.iter(|| std::hint::black_box(clusterer.cluster(&input).expect("clusters")))
        });
    }
    group.finish();
}

criterion_group!(benches, inference);
criterion_main!(benches);
