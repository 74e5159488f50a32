//! Clustering from the command line (`pgm cluster`, `pgm eval clustering`): the JSON
//! contracts of the issue, the text report's object counts, a CARMEN log, and errors
//! on bad input.

mod common;

use common::logs::square_room;
use common::*;

/// `pgm eval clustering --method METHOD --pairs DS EXTRA… --json` on the 3 simulated
/// pairs of `ds`: the parsed object (checked to count 3 pairs) and the raw output.
fn eval_json(ds: &str, method: &str, extra: &[&str]) -> (serde_json::Value, String) {
    let args = eval(
        "clustering",
        method,
        &[&["--pairs", ds, "--json"][..], extra].concat(),
    );
    let (out, _) = ok(&args);
    let v = json(&out);
    assert_eq!(v["pairs"], 3, "{method} {extra:?}");
    (v, out)
}

#[test]
fn eval_clustering_prints_the_specified_json_object() {
    let (ds, _) = simulated(&temp_dir("eval"), "ds", 5, 3);
    for method in ["crf", "cbd", "kmeans", "one-cluster"] {
        let (v, out) = eval_json(&ds, method, &["--associations", "true"]);
        for key in [
            "homogeneity_mean",
            "homogeneity_std",
            "completeness_mean",
            "completeness_std",
            "v_measure_mean",
            "v_measure_std",
            "iterations_mean",
        ] {
            let x = v[key].as_f64().unwrap_or(f64::NAN);
            assert!(x.is_finite() && x >= 0.0, "{method}: {key} = {}", v[key]);
        }
        if method == "crf" {
            assert!(v["v_measure_mean"].as_f64().unwrap() > 0.5, "{out}");
        }
        if method == "one-cluster" {
            assert_eq!(v["completeness_mean"].as_f64().unwrap(), 1.0);
        }
    }
    // As on a log without odometry: ICP from the identity, background by size.
    for method in ["crf", "cbd", "kmeans"] {
        let (v, out) = eval_json(&ds, method, &["--associations", "icp", "--no-prior"]);
        let x = v["v_measure_mean"].as_f64().unwrap_or(f64::NAN);
        assert!((0.0..=1.0).contains(&x), "{method} --no-prior: {out}");
    }
}

#[test]
fn cluster_prints_clusters_motions_and_convergence() {
    let dir = temp_dir("cluster");
    let (ds, _) = simulated(&dir, "ds", 5, 3);
    let svg = path(&dir, "pair.svg");
    let v = ok_json(&[
        "cluster",
        "--pairs",
        &ds,
        "--pair",
        "0",
        "--associations",
        "true",
        "--svg",
        &svg,
    ]);
    let clusters = v["clusters"].as_array().unwrap();
    assert!(!clusters.is_empty());
    assert_eq!(
        clusters.iter().filter(|c| c["background"] == true).count(),
        1
    );
    for c in clusters {
        assert!(
            c["points"].as_u64().is_some() && c["motion"]["theta"].as_f64().is_some(),
            "{c}"
        );
    }
    assert!(v["converged"].is_boolean() && v["labels"].is_array());
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert!(picture.starts_with("<svg") || picture.contains("<svg"));
}

#[test]
fn bad_input_is_a_clear_error() {
    refused(
        &eval("clustering", "crf", &["--pairs", "/nonexistent/pairs"]),
        &["/nonexistent/pairs"],
    );
}

#[test]
fn cluster_reads_a_carmen_log() {
    let log = square_room(&temp_dir("carmen"), "# a room\n");
    let (out, _) = ok(&one_pair("cluster", "--carmen", &log, "0", "1"));
    let v = json(&out);
    assert_eq!(v["pair"], "room:0-1");
    assert_eq!(v["labels"].as_array().unwrap().len(), 181);
    // Nothing moves: one background cluster whose motion is the 0.2 m step.
    let clusters = v["clusters"].as_array().unwrap();
    assert_eq!(clusters.len(), 1, "{out}");
    assert!(
        (v["background_motion"]["x"].as_f64().unwrap() - 0.2).abs() < 0.02,
        "{out}"
    );
    refused(
        &one_pair("cluster", "--carmen", &log, "0", "2"),
        &["scan 2: no such laser scan", "2 FLASER"],
    );
}

/// Item 10 of the polish: the two object counts of `pgm eval clustering` say what
/// they count, and agree with the JSON fields (whose names stay).
#[test]
fn eval_clustering_text_says_what_each_object_count_counts() {
    let dir = temp_dir("counts");
    let (ds, _) = simulated(&dir, "ds", 7, 3);
    let args = eval("clustering", "crf", &["--pairs", &ds]);
    let (text, _) = ok(&args);
    let j = ok_json(&[&args[..], &["--json"]].concat());
    let n = |f: &str| j[f].as_u64().unwrap_or_else(|| panic!("{f} in {j}"));
    let detection = format!(
        "detection (true movers with >= {} returns in the current scan): {} of {} detected",
        n("min_object_returns"),
        n("objects_detected"),
        n("objects_counted")
    );
    let motion = format!(
        "motion errors (every true mover with a known motion, any number of returns): {} of {} found",
        n("objects_found"),
        n("objects_total")
    );
    for line in [detection, motion] {
        assert!(text.contains(&line), "{line:?} not in\n{text}");
    }
    assert!(!text.contains("moving objects found"), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}
