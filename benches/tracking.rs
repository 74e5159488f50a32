//! The online tracker (`pgm_tracking::online`): one step, and a whole real log.
//!
//! - `online_step_361_beams`: one `OnlineTracker::push` on a simulated 361-beam scan
//!   (preset pedestrians, seed 1, sequence 0, scan 20 of 30, scans 0.1 s apart;
//!   the tracker warmed up on scans 0-19, cloned per iteration), with CRF-Clustering
//!   on segment-ICP associations and with the joint model as the detector, with the
//!   scans' odometry and without it (the ego-motion then predicted from the previous
//!   steps).
//! - `track_leigh_gtm1_bag`: `pgm track`'s work on the leigh-gtm1 bag (873 scans,
//!   CRF-Clustering on segment-ICP associations, odometry prior), the bag read
//!   beforehand: throughput in scans per second. Skipped when ../shared/data is
//!   missing.
//!
//! Run: `cargo bench --bench tracking`.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use pgm::methods::{association_source, clusterer, MethodOptions};
use pgm_datasets::bag::pairs::{bag_pairs, BagPairOptions};
use pgm_datasets::bag::{read_bag, BagTopics};
use pgm_datasets::sim::{simulate_sequence, Preset, SimConfig};
use pgm_datasets::ParamGuard;
use pgm_scan::methods::MotionClusterer;
use pgm_scan::{Scan, ScanPair};
use pgm_tracking::OnlineParams;
use std::time::Duration;

/// The scans of consecutive pairs: the first pair's reference, then every current.
fn scans_of(pairs: &[ScanPair]) -> Vec<Scan> {
    let mut scans = vec![pairs[0].reference.clone()];
    scans.extend(pairs.iter().map(|p| p.current.clone()));
    scans
}

fn detector(name: &str) -> Box<dyn MotionClusterer> {
    let options = MethodOptions::default();
    let source = association_source("segment-icp", &options).expect("registered");
    clusterer(name, source, &options).expect("registered")
}

fn online_step(c: &mut Criterion) {
    let config = SimConfig {
        preset: Preset::Pedestrians,
        ..SimConfig::default()
    }
    .check()
    .expect("valid");
    let with_odometry = scans_of(&simulate_sequence(&config, 1, 0, 30, 1));
    let without_odometry: Vec<Scan> = with_odometry
        .iter()
        .map(|s| Scan {
            odometry: None,
            ..s.clone()
        })
        .collect();
    let mut group = c.benchmark_group("online_step_361_beams");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(10));
    for (method, name) in [("crf", "crf_segment_icp"), ("joint", "joint")] {
        let detector = detector(method);
        for (scans, odometry) in [
            (&with_odometry, "odometry"),
            (&without_odometry, "no_odometry"),
        ] {
            let mut warm = OnlineParams::default()
                .tracker(detector.as_ref())
                .expect("valid parameters");
            for s in &scans[..20] {
                warm.push(s.clone()).expect("tracked");
            }
            let next = &scans[20];
            group.bench_function(format!("{name}/{odometry}"), |b| {
                b.iter_batched(
                    || (warm.clone(), next.clone()),
                    |(mut tracker, scan)| {
                        std::hint::black_box(tracker.push(scan).expect("tracked"))
                    },
                    BatchSize::SmallInput,
                )
            });
        }
    }
    group.finish();
}

fn leigh_bag(c: &mut Criterion) {
    let Some(dir) = pgm_datasets::testdata::shared_data_dir() else {
        return;
    };
    let path = dir.join("leigh-gtm1/general_tracking_moving_1.bag.zip");
    let topics = BagTopics {
        odometry: Some("/odom".into()),
        ..BagTopics::new("/scan")
    };
    let log = read_bag(&path, &topics).expect("the leigh-gtm1 bag");
    let pairs = bag_pairs(&log, &BagPairOptions::default())
        .expect("pairs")
        .pairs;
    let scans = scans_of(&pairs);
    let detector = detector("crf");
    let params = OnlineParams::default();
    let mut group = c.benchmark_group("track_leigh_gtm1_bag");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(60))
        .throughput(Throughput::Elements(scans.len() as u64));
    group.bench_function("crf_segment_icp", |b| {
        b.iter(|| {
            let mut tracker = params.tracker(detector.as_ref()).expect("valid parameters");
            for s in &scans {
                std::hint::black_box(tracker.push(s.clone()).expect("tracked"));
            }
        })
    });
    group.finish();
}

criterion_group!(benches, online_step, leigh_bag);
criterion_main!(benches);
