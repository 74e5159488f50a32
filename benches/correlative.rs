//! Correlative scan matching (`pgm_scan::correlative`) on one simulated 361-beam
//! pair (preset mixed, seed 1, pair 0) from 16 priors perturbed by up to 1 m and 30
//! degrees (uniform in a disc and an interval, seeded), with the default parameters:
//! the full ±1 m, ±30° window.
//!
//! - `grid`: the lookup grid and its max-pooled copies of the reference scan;
//! - `search`: grid and branch-and-bound search, up to three distinct hypotheses;
//! - `search+icp`: search, then ICP (0.5 m first correspondence distance) from every
//!   hypothesis, the best refined motion (`CorrelativeIcpMatcher::default()`);
//! - `icp`: ICP alone (default parameters) from the perturbed prior, for scale;
//! - `mit-csail-near/search`: grid and search on the first 100 mit-csail pairs less
//!   than 1.5 s apart, priors perturbed the same way (skipped, with a note, without
//!   ../shared/data).
//!
//! Every group runs a batch per iteration; criterion's throughput line gives pairs
//! per second, and time per pair = reported time / batch size.
//!
//! Run: `cargo bench --bench correlative`.

#[path = "../tests/common/fixtures.rs"]
mod fixtures;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fixtures::{mit_csail_near_pairs, perturb};
use pgm_datasets::sim::{simulate_pair, SimConfig};
use pgm_datasets::ScanPair;
use pgm_scan::correlative::{CorrelativeIcpMatcher, CorrelativeMatcher};
use pgm_scan::registration::IcpMatcher;
use pgm_scan::{ParamGuard, Pose2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Duration;

fn near_pairs(n: usize) -> Option<Vec<ScanPair>> {
    let near: Vec<ScanPair> = mit_csail_near_pairs()?.into_iter().take(n).collect();
    (near.len() == n).then_some(near)
}

fn bench_correlative(c: &mut Criterion) {
    let pair = simulate_pair(&SimConfig::default().check().expect("valid"), 1, 0);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let odometry = pair.odometry.unwrap_or_default();
    let priors: Vec<Pose2> = (0..16).map(|_| perturb(odometry, &mut rng)).collect();
    let matcher = CorrelativeMatcher::default();
    let refine = CorrelativeIcpMatcher::default();
    let icp = IcpMatcher::default();
    let mut group = c.benchmark_group("correlative");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(5));
    group.throughput(Throughput::Elements(priors.len() as u64));
    group.bench_function("grid", |b| {
        b.iter(|| {
            for _ in &priors {
                black_box(matcher.reference(&pair.reference).expect("valid reference"));
            }
        })
    });
    group.bench_function("search", |b| {
        b.iter(|| {
            for prior in &priors {
                black_box(
                    matcher
                        .search(&pair.reference, &pair.current, *prior)
                        .expect("valid scans"),
                );
            }
        })
    });
    group.bench_function("search+icp", |b| {
        b.iter(|| {
            for prior in &priors {
                black_box(
                    matcher
                        .align(&pair.reference, &pair.current, *prior, &refine.icp)
                        .expect("valid scans"),
                );
            }
        })
    });
    group.bench_function("icp", |b| {
        b.iter(|| {
            for prior in &priors {
                let prepared = icp.reference(&pair.reference).expect("valid reference");
                black_box(prepared.align(&pair.current, *prior).expect("valid scan"));
            }
        })
    });
    if let Some(pairs) = near_pairs(100) {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let priors: Vec<Pose2> = pairs
            .iter()
            .map(|p| perturb(p.odometry.unwrap_or_default(), &mut rng))
            .collect();
        group.throughput(Throughput::Elements(pairs.len() as u64));
        group.bench_function("mit-csail-near/search", |b| {
            b.iter(|| {
                for (p, prior) in pairs.iter().zip(&priors) {
                    black_box(
                        matcher
                            .search(&p.reference, &p.current, *prior)
                            .expect("valid scans"),
                    );
                }
            })
        });
    } else {
        eprintln!("note: mit-csail pairs unavailable; mit-csail-near/search skipped");
    }
    group.finish();
}

criterion_group!(benches, bench_correlative);
criterion_main!(benches);
