//! ICP speed on real 361-beam pairs: the mit-csail relation pairs less than 1.5 s
//! apart, started from odometry. Skipped (with a note) when ../shared/data is missing.
//!
//! `icp/mit-csail-near` aligns a batch of pairs per iteration (k-d tree construction
//! on the reference scan included); criterion's throughput line gives pairs per
//! second, and time per pair = reported time / batch size.
//!
//! `icp-long/N` (no data needed): one ICP run (tree included) on two N-beam scans of
//! pseudo-random ranges 5-6 m over 180°, the second 0.1 m along, as the hardening
//! case carmen-long100000 writes them; N = 10 000, 30 000, 100 000 shows that the cost
//! grows near N log N (the case took more than 30 s at 100 000 beams before issue 16).

#[path = "../tests/common/fixtures.rs"]
mod fixtures;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fixtures::{long_ranges, mit_csail_near_pairs};
use pgm_datasets::ScanPair;
use pgm_scan::registration::{Icp, IcpParams};
use std::hint::black_box;

const BATCH: usize = 100;

fn near_pairs() -> Option<Vec<ScanPair>> {
    let near: Vec<ScanPair> = mit_csail_near_pairs()?.into_iter().take(BATCH).collect();
    (near.len() == BATCH).then_some(near)
}

fn bench_icp(c: &mut Criterion) {
    let Some(pairs) = near_pairs() else {
        eprintln!("note: mit-csail pairs unavailable; ICP bench skipped");
        return;
    };
    let params = IcpParams::default();
    let iterations: usize = pairs
        .iter()
        .map(|p| {
            let icp = Icp::new(&p.reference, params).expect("valid reference");
            icp.align(&p.current, p.odometry.unwrap_or_default())
                .expect("valid current")
                .iterations
        })
        .sum();
    eprintln!(
        "note: {} pairs, mean {:.1} ICP iterations per pair",
        pairs.len(),
        iterations as f64 / pairs.len() as f64
    );
    let mut group = c.benchmark_group("icp");
    group.throughput(Throughput::Elements(BATCH as u64));
    group.bench_function("mit-csail-near", |b| {
        b.iter(|| {
            for p in &pairs {
                let icp = Icp::new(&p.reference, params).expect("valid reference");
                let r = icp
                    .align(&p.current, p.odometry.unwrap_or_default())
                    .expect("valid current");
                black_box(r.motion);
            }
        })
    });
    let trees: Vec<Icp> = pairs
        .iter()
        .map(|p| Icp::new(&p.reference, params).expect("valid reference"))
        .collect();
    group.bench_function("mit-csail-near-align-only", |b| {
        b.iter(|| {
            for (icp, p) in trees.iter().zip(&pairs) {
                let r = icp
                    .align(&p.current, p.odometry.unwrap_or_default())
                    .expect("valid current");
                black_box(r.motion);
            }
        })
    });
    // One nearest-neighbour query per current return against one reference tree.
    let (queries, _) = pairs[0].current.points();
    let icp = Icp::new(&pairs[0].reference, params).expect("valid reference");
    group.throughput(Throughput::Elements(queries.len() as u64));
    group.bench_function("nearest-reference-one-scan", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for q in &queries {
                sum += icp.nearest_reference(q, 0.1).map_or(0.0, |x| x.1);
            }
            black_box(sum)
        })
    });
    group.finish();
}

/// Two `n`-beam scans as carmen-long100000 writes them: the same pseudo-random ranges
/// in 5-6 m over 180°, read from poses 0.1 m apart.
fn long_pair(n: usize) -> (pgm_scan::Scan, pgm_scan::Scan) {
    let ranges = long_ranges(n);
    let angles: Vec<f64> = (0..n)
        .map(|k| -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * k as f64 / (n - 1) as f64)
        .collect();
    let scan = pgm_scan::Scan::from_ranges(angles, ranges, 80.0);
    (scan.clone(), scan)
}

fn bench_long(c: &mut Criterion) {
    let mut group = c.benchmark_group("icp-long");
    group.sample_size(10);
    for n in [10_000, 30_000, 100_000] {
        let (reference, current) = long_pair(n);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(format!("{n}"), |b| {
            b.iter(|| {
                let icp = Icp::new(&reference, IcpParams::default()).expect("valid reference");
                let r = icp
                    .align(&current, pgm_scan::Pose2::new(0.1, 0.0, 0.0))
                    .expect("valid current");
                black_box(r.motion)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_icp, bench_long);
criterion_main!(benches);
