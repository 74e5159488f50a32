//! `pgm track` prints what `pgm_tracking::OnlineTracker::push` returns, scan by scan.
//! `pgm eval tracking`: CLEAR-MOT of the online tracker against tracking truth. On a
//! simulated sequence its counts equal the library's scoring of `pgm track`'s own
//! output (the streaming tracker and the command agree, and the command scores what
//! `pgm track` prints); bad options are refused naming the value; on the leigh-gtm1 bag
//! and the datmo bag (real data in `../shared/data`, or `$PGM_SHARED_DATA`; skipped
//! with a note when missing, a failure when `CI=true`) the truth has the benchmark's
//! counts (133 annotations inside the window, 52 of people who walk).

mod common;

use common::*;
use pgm_datasets::clear_mot::{ClearMot, ClearMotOptions, Protocol};
use pgm_datasets::testdata;
use pgm_datasets::tracking_truth::stored_objects;
use std::collections::HashMap;

/// A pedestrians sequence of `scans` scans (seed 11) at `dir/seq`.
fn sequence(dir: &std::path::Path, scans: usize) -> String {
    simulated_sequence(dir, "pedestrians", 11, scans)
}

#[test]
fn a_simulated_sequence_scores_as_the_library_scores_pgm_tracks_output() {
    let dir = temp_dir("eval-tracking-sim");
    let seq = sequence(&dir, 30);
    let method = ["--method", "crf", "--associations", "segment-icp"];
    let tracks = path(&dir, "tracks.json");
    ok(&[&["track", "--pairs", &seq, "--out", &tracks][..], &method].concat());
    let written = path(&dir, "eval.json");
    let report = ok_json(
        &[
            &[
                "eval", "tracking", "--pairs", &seq, "--json", "--out", &written,
            ][..],
            &method,
        ]
        .concat(),
    );
    assert_eq!(read_json(&written), report, "--out holds what is printed");
    // Every current scan of the 29 pairs is annotated.
    assert_eq!(report["frames"], 29);
    // Score pgm track's JSON with the library against the stored objects.
    let pairs = pgm::datasets::read_pairs(&seq).unwrap();
    let truth = stored_objects(&pairs);
    let tracked = read_json(&tracks);
    let by_scan: HashMap<String, Vec<(u64, f64, f64)>> = tracked["scans"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            let objects = s["objects"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|o| o["state"] != "tentative")
                .map(|o| {
                    (
                        o["track"].as_u64().unwrap(),
                        o["centre"][0].as_f64().unwrap(),
                        o["centre"][1].as_f64().unwrap(),
                    )
                })
                .collect();
            (s["scan"].as_str().unwrap().to_string(), objects)
        })
        .collect();
    let mut frames: Vec<(usize, &String)> = truth
        .scans
        .keys()
        .map(|name| (name.rsplit_once(':').unwrap().1.parse().unwrap(), name))
        .collect();
    frames.sort();
    for (protocol, key) in [
        (Protocol::Benchmark, "benchmark"),
        (Protocol::Standard, "standard"),
    ] {
        let mut scorer = ClearMot::new(ClearMotOptions {
            protocol,
            ..ClearMotOptions::default()
        })
        .unwrap();
        for (_, name) in &frames {
            let annotations: Vec<(u64, f64, f64)> = truth.scans[*name]
                .iter()
                .map(|o| (o.id, o.x, o.y))
                .collect();
            scorer.push_parts(&by_scan[*name], &annotations).unwrap();
        }
        let c = scorer.counts();
        let got = &report[key];
        assert!(c.truth > 0, "the sequence has objects to track");
        for (field, value) in [
            ("truth", c.truth),
            ("matches", c.matches),
            ("id_switches", c.id_switches),
            ("false_positives", c.false_positives),
            ("misses", c.misses),
        ] {
            assert_eq!(got[field], value, "{key} {field}: {got}");
        }
        let mota = 1.0 - (c.id_switches + c.false_positives + c.misses) as f64 / c.truth as f64;
        assert!(
            (got["mota"].as_f64().unwrap() - mota).abs() < 1e-12,
            "{got}"
        );
    }
    // Annotations that do not move are don't-care with --moving-only: fewer count.
    let moving = ok_json(
        &[
            &[
                "eval",
                "tracking",
                "--pairs",
                &seq,
                "--json",
                "--moving-only",
            ][..],
            &method,
        ]
        .concat(),
    );
    let (all, kept) = (
        report["benchmark"]["truth"].as_u64().unwrap(),
        moving["benchmark"]["truth"].as_u64().unwrap(),
    );
    assert_eq!(kept + moving["left_out"].as_u64().unwrap(), all, "{moving}");
}

#[test]
fn bad_options_and_sources_without_truth_are_refused() {
    let dir = temp_dir("eval-tracking-refusals");
    let seq = sequence(&dir, 5);
    let head = ["eval", "tracking", "--method", "crf", "--pairs", &seq];
    // Pairs whose ground truth has no objects (as a data set of another tool).
    let (_, mut pairs) = simulated(&dir, "sim", 3, 2);
    for p in &mut pairs {
        p.truth.as_mut().unwrap().objects = None;
    }
    let plain = path(&dir, "plain");
    pgm::datasets::write_pairs(&plain, &pairs).unwrap();
    let log = write(
        &dir,
        "a.clf",
        "FLASER 3 1.0 1.0 1.0 0 0 0 0 0 0 1.0 h 0.0\nFLASER 3 1.0 1.0 1.0 0 0 0 0 0 0 2.0 h 0.0\n",
    );
    refused_all(&[
        (
            [&head[..], &["--threshold", "0"]].concat(),
            vec!["--threshold 0"],
        ),
        (
            [&head[..], &["--window=12,-80"]].concat(),
            vec!["\"12,-80\"", "LO <= HI"],
        ),
        (
            [&head[..], &["--window=-80"]].concat(),
            vec!["\"-80\"", "LO,HI"],
        ),
        (
            [&head[..], &["--min-score", "2"]].concat(),
            vec!["--min-score 2"],
        ),
        (
            vec!["eval", "tracking", "--method", "crf", "--log", &log],
            vec!["a.clf", "no tracking truth"],
        ),
        (
            vec!["eval", "tracking", "--method", "crf", "--pairs", &plain],
            vec!["no pair holds tracking truth"],
        ),
    ]);
}

/// The leigh-gtm1 bag in ../shared/data (None: skipped, see `testdata`).
fn leigh_bag() -> Option<String> {
    let bag = testdata::shared_data_dir()?.join("leigh-gtm1/general_tracking_moving_1.bag.zip");
    Some(bag.to_str().unwrap().to_string())
}

/// `pgm eval tracking --method crf --associations crf-matching --bag BAG REST… --json`.
fn crf_tracking(bag: &str, rest: &[&str]) -> serde_json::Value {
    let head = [
        "eval",
        "tracking",
        "--method",
        "crf",
        "--associations",
        "crf-matching",
        "--bag",
        bag,
    ];
    ok_json(&[&head[..], rest, &["--json"]].concat())
}

#[test]
fn leigh_gtm1_bag_has_the_benchmarks_annotations_and_people_are_matched() {
    let Some(bag) = leigh_bag() else {
        return;
    };
    let report = crf_tracking(
        &bag,
        &[&LEIGH_BAG_TOPICS[..], &["--window=-80,12"]].concat(),
    );
    let b = &report["benchmark"];
    // TRACKING.md: 133 annotations inside the window; the data README's track rule:
    // 52 of them of people who walk.
    assert_eq!(b["truth"], 133, "{b}");
    assert_eq!(report["moving"]["annotations"], 52, "{report}");
    assert_eq!(report["frames"], 123);
    // Measured 2026-12-02: 16 matches, 0 ID switches, 1 false positive, MOTP 0.232 m.
    assert!(b["matches"].as_u64().unwrap() >= 10, "{b}");
    assert!(b["false_positives"].as_u64().unwrap() <= 10, "{b}");
    assert!(b["motp_m"].as_f64().unwrap() <= 0.3, "{b}");
}

#[test]
fn datmo_overtake_ego_car_is_matched_while_it_moves() {
    let Some(dir) = testdata::shared_data_dir() else {
        return;
    };
    let bag = dir.join("datmo/overtake_ego.bag");
    let report = crf_tracking(
        bag.to_str().unwrap(),
        &[
            "--scan-topic",
            "/scan",
            "--laser-mount=-0.164,0.027,0.005",
            "--ego-pose-topic",
            "/ego_pose",
            "--object-pose-topic",
            "/red_pose",
            "--object-footprint",
            "0.43,0.187,0.057,0.028",
            "--pose-delay",
            "0.025",
            "--moving-only",
            "--min-returns",
            "5",
        ],
    );
    let b = &report["benchmark"];
    // 76 scans where the car moves with at least 5 returns; measured 2026-12-02: 56
    // matched, no ID switch, no false positive, MOTP 0.067 m.
    assert_eq!(b["truth"], 76, "{b}");
    assert!(b["matches"].as_u64().unwrap() >= 50, "{b}");
    assert_eq!(b["id_switches"], 0, "{b}");
    assert!(b["motp_m"].as_f64().unwrap() <= 0.1, "{b}");
}

/// `pgm eval ego-motion --method crf --associations segment-icp` on `source`, with
/// the wheel odometry withheld.
fn ego_without_odometry(source: &[&str]) -> serde_json::Value {
    ok_json(
        &[
            &[
                "eval",
                "ego-motion",
                "--method",
                "crf",
                "--associations",
                "segment-icp",
                "--no-odometry",
                "--json",
            ][..],
            source,
        ]
        .concat(),
    )
}

#[test]
fn ego_motion_without_odometry_is_close_to_icp_from_the_odometry_prior() {
    let Some(dir) = testdata::shared_data_dir() else {
        return;
    };
    let intel = dir.join("intel-lab/intel-lab.log");
    let (clf, relations) = (
        dir.join("mit-csail/mit-csail.clf"),
        dir.join("mit-csail/mit-csail.relations"),
    );
    for report in [
        ego_without_odometry(&["--log", intel.to_str().unwrap()]),
        ego_without_odometry(&[
            "--carmen",
            clf.to_str().unwrap(),
            "--relations",
            relations.to_str().unwrap(),
        ]),
    ] {
        // Issue 28's targets: the median translation error per step at most 10 %
        // above ICP's from the odometry prior, at most 0.5 % of the steps off by more
        // than 0.2 m or 0.1 rad. Measured 2026-12-02: intel-lab 0.0206 m against
        // 0.0214 m, 6 of 1760 off (0.34 %); mit-csail 0.0229 m against 0.0217 m, 5 of
        // 1044 off (0.48 %).
        let (tracked, icp) = (&report["tracked"], &report["icp_with_odometry_prior"]);
        assert_eq!(report["odometry"], false);
        assert!(tracked["pairs"].as_u64().unwrap() > 1000, "{report}");
        assert_eq!(tracked["pairs"], icp["pairs"]);
        let ratio = tracked["translation_median"].as_f64().unwrap()
            / icp["translation_median"].as_f64().unwrap();
        assert!(ratio <= 1.1, "{ratio}: {report}");
        assert!(tracked["off_share"].as_f64().unwrap() <= 0.005, "{report}");
    }
}

#[test]
fn pgm_track_prints_what_the_streaming_tracker_returns_scan_by_scan() {
    use pgm::methods::{association_source, clusterer, MethodOptions};
    use pgm_tracking::OnlineParams;
    let dir = temp_dir("eval-tracking-stream");
    let seq = sequence(&dir, 25);
    let tracks = path(&dir, "tracks.json");
    ok(&track_crf(
        "segment-icp",
        &["--pairs", &seq, "--out", &tracks],
    ));
    let printed = read_json(&tracks);
    let printed = printed["scans"].as_array().unwrap();
    // The same scans pushed one by one into the library's tracker.
    let mut pairs = pgm::datasets::read_pairs(&seq).unwrap();
    pairs.sort_by_key(|p| {
        let (_, a, _) = pgm_datasets::tracking_truth::scan_names(&p.name).unwrap();
        a
    });
    let mut scans = vec![pairs[0].reference.clone()];
    scans.extend(pairs.iter().map(|p| p.current.clone()));
    let options = MethodOptions::default();
    let source = association_source("segment-icp", &options).unwrap();
    let detector = clusterer("crf", source, &options).unwrap();
    let mut tracker = OnlineParams::default().tracker(detector.as_ref()).unwrap();
    assert_eq!(printed.len(), scans.len());
    let objects: usize = printed
        .iter()
        .map(|s| s["objects"].as_array().unwrap().len())
        .sum();
    assert!(objects > 0, "the sequence has tracks to compare");
    for (k, (scan, line)) in scans.into_iter().zip(printed).enumerate() {
        let report = serde_json::to_value(tracker.push(scan).unwrap()).unwrap();
        for field in [
            "index",
            "time",
            "sequence",
            "ego",
            "pose",
            "converged",
            "objects",
        ] {
            assert_eq!(report[field], line[field], "scan {k}, `{field}`");
        }
    }
}
