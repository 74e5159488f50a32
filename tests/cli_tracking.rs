//! `pgm eval clustering --track` (multi-scan tracking, `pgm_tracking`): its
//! options are checked, a simulated data set (independent scenes) scores exactly as
//! without tracking, and on the datmo `overtake_ego` bag (real data, a car driven
//! right behind and beside the robot) tracking finds the car in more pairs without
//! false alarms; `pgm track` also runs over a plain CARMEN log (mit-csail). The
//! real-data tests read `../shared/data` (or `$PGM_SHARED_DATA`); skipped with a note
//! when it is missing, a failure when `CI=true`.

mod common;

use common::*;
use pgm_datasets::testdata;

/// `pgm eval clustering --method crf --pairs PAIRS` followed by `rest`.
fn eval_crf<'a>(pairs: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
    eval(
        "clustering",
        "crf",
        &[&["--pairs", pairs][..], rest].concat(),
    )
}

/// `pgm track --method crf --pairs PAIRS` followed by `rest`.
fn track<'a>(pairs: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
    [&["track", "--method", "crf", "--pairs", pairs][..], rest].concat()
}

/// The datmo `overtake_ego` bag in ../shared/data (None: skipped, see `testdata`).
fn overtake_ego() -> Option<String> {
    let bag = testdata::shared_data_dir()?.join("datmo/overtake_ego.bag");
    Some(bag.to_str().unwrap().to_string())
}

/// The options that read the scans of the datmo bags (laser 0.164 m behind the
/// robot's centre).
const DATMO_SCANS: [&str; 3] = ["--scan-topic", "/scan", "--laser-mount=-0.164,0.027,0.005"];

#[test]
fn tracking_options_need_track_and_sense() {
    let dir = temp_dir("track-options");
    let (pairs, _) = simulated(&dir, "sim", 5, 2);
    refused_all(&[
        (
            eval_crf(&pairs, &["--track-min-speed", "1"]),
            vec!["--track"],
        ),
        (
            eval_crf(&pairs, &["--track", "--track-min-evidence", "0"]),
            vec!["--track-min-evidence 0"],
        ),
        (
            eval_crf(&pairs, &["--track", "--track-min-speed", "nan"]),
            vec!["--track-min-speed NaN"],
        ),
    ]);
}

#[test]
fn simulated_scenes_score_as_without_tracking() {
    let dir = temp_dir("track-sim");
    let (pairs, _) = simulated(&dir, "sim", 11, 6);
    let plain = ok_json(&eval_crf(&pairs, &["--json"]));
    let tracked = ok_json(&eval_crf(&pairs, &["--json", "--track"]));
    assert!(plain["tracking"].is_null());
    // Every simulated pair starts at time 0: each is a sequence of its own.
    assert_eq!(tracked["tracking"]["sequences"], 6);
    assert_eq!(tracked["tracking"]["tracked_objects"], 0);
    for field in [
        "v_measure_mean",
        "objects_detected",
        "false_alarms_per_pair",
    ] {
        assert_eq!(plain[field], tracked[field], "{field}");
    }
}

#[test]
fn datmo_overtake_ego_tracking_finds_the_car_in_more_pairs() {
    let Some(bag) = overtake_ego() else {
        return;
    };
    let head = eval(
        "clustering",
        "crf",
        &["--associations", "crf-matching", "--bag", &bag],
    );
    let truth = [
        "--ego-pose-topic",
        "/ego_pose",
        "--object-pose-topic",
        "/red_pose",
        "--pose-delay",
        "0.025",
        "--object-footprint",
        "0.430,0.187,0.057,0.028",
        "--label-margin",
        "0.05",
        "--k",
        "3",
        "--json",
    ];
    let base = [&head[..], &DATMO_SCANS, &truth].concat();
    let plain = ok_json(&base);
    let tracked = ok_json(&[&base[..], &["--track"]].concat());
    let forward = ok_json(&[&base[..], &["--track", "--track-forward-only"]].concat());
    assert_eq!(tracked["tracking"]["backward"], true);
    assert_eq!(forward["tracking"]["backward"], false);
    let recall = |r: &serde_json::Value| r["object_recall"].as_f64().unwrap();
    // Measured 2026-11-30: 23 of 76 without tracking, 55 of 76 tracked forward only,
    // 73 of 76 with the backward pass (the target is 90 %); 0.008 false alarms
    // per pair.
    assert!(recall(&forward) >= 0.6, "{forward}");
    assert!(
        recall(&forward) > recall(&plain) + 0.2,
        "{plain}\n{forward}"
    );
    assert!(recall(&tracked) >= 0.9, "{tracked}");
    assert!(
        tracked["tracking"]["backward_objects"].as_u64().unwrap() > 0,
        "{tracked}"
    );
    assert!(
        tracked["false_alarms_per_pair"].as_f64().unwrap() <= 0.02,
        "{tracked}"
    );
    assert!(tracked["tracking"]["tracked_objects"].as_u64().unwrap() > 0);
    // The motions of the tracked car stay accurate (measured 0.009 m at the centroid).
    assert!(tracked["object_translation_error_median"].as_f64().unwrap() <= 0.03);
}

#[test]
fn track_refuses_bad_options_and_writes_its_output_whole() {
    let dir = temp_dir("track-cli");
    let (pairs, _) = simulated(&dir, "sim", 7, 3);
    let index = format!("{pairs}/index.json");
    let missing = path(&dir, "missing/x.json");
    refused_all(&[
        (track(&pairs, &["--min-speed=-1"]), vec!["min_speed", "-1"]),
        (track(&pairs, &["--max-speed", "0"]), vec!["max_speed", "0"]),
        (
            track(&pairs, &["--max-yaw-rate", "nan"]),
            vec!["max_yaw_rate", "NaN"],
        ),
        (
            track(&pairs, &["--min-evidence", "2"]),
            vec!["--min-evidence", "unexpected argument"],
        ),
        (
            track(&pairs, &["--out", dir.to_str().unwrap()]),
            vec!["is a directory"],
        ),
        // Options that mean nothing here, and outputs that would destroy the input.
        (track(&pairs, &["--k", "0"]), vec!["k", "at least 1"]),
        (
            track(&pairs, &["--k", "3", "--reference-gap", "0.5"]),
            vec!["--reference-gap"],
        ),
        (
            track(&pairs, &["--annotated-sector"]),
            vec!["--annotated-sector", "unexpected argument"],
        ),
        (
            track(&pairs, &["--out", &index]),
            vec!["refusing to write over the data being read"],
        ),
        (track(&pairs, &["--out", &missing]), vec!["does not exist"]),
    ]);
    assert!(std::path::Path::new(&index).is_file());
    let out = path(&dir, "tracks.json");
    let (stdout, stderr) = ok(&track(&pairs, &["--out", &out]));
    assert!(stdout.is_empty());
    assert!(stderr.contains("written to"), "{stderr}");
    let written = read_json(&out);
    let svg = path(&dir, "tracks.svg");
    ok(&track(&pairs, &["--svg", &svg]));
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert!(picture.starts_with("<svg") && picture.contains("first scan&apos;s frame"));
    // Three independent simulated scenes: three sequences of two scans each, online.
    assert_eq!(written["mode"], "online");
    assert_eq!(written["tracking"]["sequences"], 3);
    assert_eq!(written["scans"].as_array().unwrap().len(), 6);
    let smoothed = ok_json(&track(&pairs, &["--smooth"]));
    assert_eq!(smoothed["mode"], "smoothed");
}

#[test]
fn datmo_overtake_ego_track_follows_the_car_as_one_track() {
    let Some(bag) = overtake_ego() else {
        return;
    };
    let head = track_crf("crf-matching", &["--bag", &bag]);
    let out = ok_json(&[&head[..], &DATMO_SCANS, &["--k", "3"]].concat());
    assert_eq!(out["mode"], "online");
    assert_eq!(out["tracking"]["k"], 3);
    let scans = out["scans"].as_array().unwrap();
    assert_eq!(scans.len(), 135);
    // Reports per track (confirmed, stopped or coasting), ids unique within a scan,
    // and the car's speeds (it drives at 0.7-1.1 m/s).
    let mut per_track = std::collections::HashMap::<u64, usize>::new();
    let mut speeds = Vec::new();
    for s in scans {
        let objects = s["objects"].as_array().unwrap();
        let ids: std::collections::HashSet<u64> = objects
            .iter()
            .map(|o| o["track"].as_u64().unwrap())
            .collect();
        assert_eq!(ids.len(), objects.len(), "{s}");
        for o in objects {
            let score = o["score"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&score), "{o}");
            if o["state"] == "tentative" {
                continue;
            }
            *per_track.entry(o["track"].as_u64().unwrap()).or_default() += 1;
            let v = o["velocity"].as_array().unwrap();
            speeds.push(v[0].as_f64().unwrap().hypot(v[1].as_f64().unwrap()));
        }
    }
    // Measured 2026-12-02, online: 79 reports, all on one track (the offline tracker
    // before it: 74).
    let longest = per_track.values().copied().max().unwrap_or(0);
    assert!(longest >= 70, "{per_track:?}");
    assert_eq!(per_track.len(), 1, "{per_track:?}");
    speeds.sort_by(f64::total_cmp);
    let median = speeds[speeds.len() / 2];
    assert!((0.6..=1.2).contains(&median), "median speed {median} m/s");
}

#[test]
fn simulated_sequences_are_tracked_as_sequences() {
    let dir = temp_dir("track-seq");
    let out = path(&dir, "seq");
    refused(
        &[
            "sim",
            "--preset",
            "following",
            "--pairs",
            "2",
            "--sequence",
            "4",
            "--k",
            "4",
        ],
        &["--sequence 4 --k 4"],
    );
    ok(&[
        "sim",
        "--preset",
        "overtaking",
        "--seed",
        "3",
        "--pairs",
        "2",
        "--sequence",
        "7",
        "--k",
        "3",
        "--out",
        &out,
    ]);
    let report = ok_json(&eval_crf(
        &out,
        &["--associations", "segment-icp", "--track", "--json"],
    ));
    assert_eq!(report["pairs"], 8);
    // Two sequences of four pairs each (their stamps are 1000 s apart).
    assert_eq!(report["tracking"]["sequences"], 2);
}

#[test]
fn a_plain_carmen_log_is_tracked_over_its_consecutive_scans() {
    let Some(data) = testdata::shared_data_dir() else {
        return;
    };
    // mit-csail's log has laser lines with odometry and no VERTEX2 pose.
    let log = data.join("mit-csail").join("mit-csail.clf");
    let (out, err) = ok(&[
        "track",
        "--method",
        "crf",
        "--associations",
        "icp",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert!(err.contains("no VERTEX2 poses"), "{err}");
    let out = json(&out);
    let scans = out["scans"].as_array().unwrap();
    assert_eq!(scans.len(), 1988);
    let times: Vec<f64> = scans.iter().map(|s| s["time"].as_f64().unwrap()).collect();
    assert!(times.windows(2).all(|w| w[0] < w[1]));
    assert_eq!(out["tracking"]["sequences"], 1);
    // The scan-to-scan motions come from the log's odometry refined by ICP: every
    // scan but the first has one.
    assert!(scans[1..]
        .iter()
        .all(|s| s["ego"]["source"] == "odometry" || s["ego"]["source"] == "predicted"));
}
