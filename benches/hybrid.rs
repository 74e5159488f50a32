//! Per-visit cost of hybrid inference as the number of variables attached to the
//! continuous nodes grows (100, 1,000, 10,000): one forward-backward sweep of variable
//! visits over a chain with three rigid-motion nodes, re-solved after *every* visit
//! (Algorithm 1). With O(1) sufficient statistics the time per visit stays flat.
//!
//! Run: `cargo bench --bench hybrid`; criterion's throughput line gives visits per
//! second (each sweep visits every variable twice).

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use nalgebra::Point2;
use pgm_core::hybrid::{HybridInference, UpdatePolicy};
use pgm_core::{
    BpParams, FactorGraph, Mode, ParamGuard, PottsFactor, Sequential, TableFactor, VariableId,
};
use pgm_features::RigidMotionNodes;
use pgm_scan::Pose2;
use std::time::Duration;

fn problem(n: usize) -> (FactorGraph, RigidMotionNodes, Vec<usize>) {
    let k = 3;
    let truth = [
        Pose2::new(0.5, 0.1, 0.05),
        Pose2::new(-1.2, 0.4, -0.2),
        Pose2::new(0.3, -0.9, 0.35),
    ];
    let labels: Vec<usize> = (0..n).map(|i| (i * k) / n).collect();
    let pairs = (0..n)
        .map(|i| {
            let t = i as f64 * 6.0 / n as f64;
            let s = Point2::new(6.0 * t.cos(), 6.0 * t.sin());
            (s, truth[labels[i]].transform_point(&s))
        })
        .collect();
    let mut graph = FactorGraph::with_variables(&vec![k; n]).unwrap();
    let local = (0..n)
        .map(|i| {
            graph
                .add_factor(TableFactor::new(vec![VariableId(i)], vec![k], vec![0.0; k]).unwrap())
                .unwrap()
        })
        .collect();
    for i in 1..n {
        graph
            .add_factor(PottsFactor::new(VariableId(i - 1), VariableId(i), k, 2.0, 0.0).unwrap())
            .unwrap();
    }
    let nodes = RigidMotionNodes::new(pairs, local, truth.to_vec(), 50.0, Vec::new()).unwrap();
    // Start every fourth label wrong so the sweep moves points between clusters.
    let initial = labels
        .iter()
        .enumerate()
        .map(|(i, &l)| if i % 4 == 0 { (l + 1) % k } else { l })
        .collect();
    (graph, nodes, initial)
}

fn per_visit(c: &mut Criterion) {
    let mut group = c.benchmark_group("hybrid_sweep_every_visit");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(5));
    for n in [100usize, 1_000, 10_000] {
        group.throughput(Throughput::Elements(2 * n as u64));
        group.bench_function(format!("{n}_variables"), |b| {
            b.iter_batched(
                || problem(n),
                |(mut graph, mut nodes, initial)| {
                    let order = (0..n).map(VariableId).collect();
                    let r = HybridInference::new(
                        BpParams::new(Mode::MaxProduct)
                            .max_iterations(1)
                            .check_unwrap(),
                        UpdatePolicy::EveryVisit,
                    )
                    .run(
                        &mut graph,
                        &mut nodes,
                        &mut Sequential::variables(order),
                        Some(&initial),
                    )
                    .unwrap();
                    std::hint::black_box(r.solves)
                },
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, per_visit);
criterion_main!(benches);
