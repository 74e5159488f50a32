//! The joint model on one simulated 361-beam pair (preset mixed, seed 1, pair 0) with
//! the shipped weights: motion hypotheses, candidates, rounds of exact sweeps over the
//! association and clustering chains with the cluster motions re-solved, vacuous
//! clusters, the ego-motion — everything from the pair to the associations, clusters
//! and motions. `pruned` is the default state space (6 candidates and the outlier
//! state per return), `full` every reference return and the outlier state (sparse
//! pairwise tables); both re-solve the motions after every sweep (the default).
//! `pruned_every_visit` re-solves them after every node visit whose label changed
//! (Algorithm 1's schedule). `pruned_eq6` and `pruned_every_visit_eq6` are those two
//! with the background's motion solved by eq. 6 alone (`JointParams::point_to_line`
//! off), beside them in the same run. The targets: at most 5 ms pruned, 200 ms full.
//!
//! Run: `cargo bench --bench joint`.

use criterion::{criterion_group, criterion_main, Criterion};
use pgm_core::hybrid::chain::ChainUpdate;
use pgm_datasets::sim::{simulate_pair, SimConfig};
use pgm_features::matching_features::StateSpace;
use pgm_joint::JointParams;
use pgm_scan::ParamGuard;
use std::time::Duration;

fn joint(c: &mut Criterion) {
    let pair = simulate_pair(&SimConfig::default().check().expect("valid"), 1, 0);
    assert_eq!(pair.current.len(), 361, "a 361-beam pair");
    let mut group = c.benchmark_group("joint_361_beams");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(8));
    for (name, space, update, point_to_line) in [
        (
            "pruned",
            StateSpace::Pruned(6),
            ChainUpdate::EverySweep,
            true,
        ),
        ("full", StateSpace::Full, ChainUpdate::EverySweep, true),
        (
            "pruned_every_visit",
            StateSpace::Pruned(6),
            ChainUpdate::EveryVisit,
            true,
        ),
        (
            "pruned_eq6",
            StateSpace::Pruned(6),
            ChainUpdate::EverySweep,
            false,
        ),
        (
            "pruned_every_visit_eq6",
            StateSpace::Pruned(6),
            ChainUpdate::EveryVisit,
            false,
        ),
    ] {
        let defaults = JointParams::default();
        let joint = JointParams {
            state_space: space,
            update,
            point_to_line: defaults.point_to_line.filter(|_| point_to_line),
            ..defaults
        }
        .check()
        .expect("valid");
        let sweeps = joint.estimate(&pair).expect("runs").sweeps;
        eprintln!("joint {name}: {sweeps} sweeps on {}", pair.name);
        group.bench_function(name, |b| {
            b.iter(|| std::hint::black_box(joint.estimate(&pair).expect("runs")))
        });
    }
    group.finish();
}

criterion_group!(benches, joint);
criterion_main!(benches);
