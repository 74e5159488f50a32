//! How long the simulator takes to generate pairs (the README promises 100 pairs of
//! the default `mixed` preset in well under a second in release mode).

use criterion::{criterion_group, criterion_main, Criterion};
use pgm_datasets::sim::{simulate_pairs, Preset, SimConfig};
use pgm_datasets::ParamGuard;
use std::hint::black_box;

fn bench_simulate(c: &mut Criterion) {
    let mut group = c.benchmark_group("sim");
    group.sample_size(20);
    for preset in [Preset::Mixed, Preset::Intersection] {
        let config = SimConfig {
            preset,
            ..SimConfig::default()
        }
        .check()
        .expect("default configuration is valid");
        group.bench_function(format!("simulate_pairs_{preset}_100"), |b| {
            b.iter(|| black_box(simulate_pairs(&config, black_box(1), 100)))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_simulate);
criterion_main!(benches);
