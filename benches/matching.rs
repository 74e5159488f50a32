//! CRF-Matching of one simulated 361-beam pair (preset mixed, seed 1, pair 0) with the
//! shipped weights: motion hypotheses, candidates, rounds of exact chain sweeps with
//! motion re-solves, everything from the pair to the associations. `pruned` uses the
//! default state space (6 candidates and the outlier state per point), `full` every
//! reference return and the outlier state (sparse pairwise tables: the band and the
//! outlier row and column, see `pgm_crf_matching::model::band_pattern`).
//! `pruned_eq6` is `pruned` with the motion solves by eq. 6 alone
//! (`MatchingParams::point_to_line` off), beside it in the same run.
//!
//! Run: `cargo bench --bench matching`.

use criterion::{criterion_group, criterion_main, Criterion};
use pgm_crf_matching::{MatchingParams, StateSpace};
use pgm_datasets::sim::{simulate_pair, SimConfig};
use pgm_scan::ParamGuard;
use std::time::Duration;

fn matching(c: &mut Criterion) {
    let pair = simulate_pair(&SimConfig::default().check().expect("valid"), 1, 0);
    let mut group = c.benchmark_group("crf_matching_361_beams");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(8));
    for (name, space, point_to_line) in [
        ("pruned", StateSpace::Pruned(6), true),
        ("full", StateSpace::Full, true),
        ("pruned_eq6", StateSpace::Pruned(6), false),
    ] {
        let defaults = MatchingParams::default();
        let matcher = MatchingParams {
            state_space: space,
            point_to_line: defaults.point_to_line.filter(|_| point_to_line),
            ..defaults
        }
        .check()
        .expect("valid");
        let m = matcher.match_pair(&pair).expect("matches");
        eprintln!(
            "crf-matching {name}: {} sweeps, {} rounds on {}",
            m.sweeps, m.rounds, pair.name
        );
        group.bench_function(name, |b| {
            b.iter(|| std::hint::black_box(matcher.match_pair(&pair).expect("matches")))
        });
    }
    group.finish();
}

criterion_group!(benches, matching);
criterion_main!(benches);
