//! `pgm joint`, `pgm eval joint` and `pgm eval clustering --method joint` from the
//! command line: the JSON contracts of issue 15, the SVG, the motion fit, and clear
//! errors (status 2) on bad input.

mod common;

use common::logs::square_room;
use common::*;
use std::path::Path;

/// Three simulated pairs (seed 5) in a fresh directory for the test `name`.
fn simulated_3(name: &str) -> String {
    simulated(&temp_dir(name), "ds", 5, 3).0
}

#[test]
fn joint_prints_associations_clusters_and_motions_and_draws_them() {
    let dir = temp_dir("one");
    let (ds, _) = simulated(&dir, "ds", 5, 3);
    let svg = path(&dir, "joint.svg");
    let v = ok_json(&["joint", "--pairs", &ds, "--pair", "1", "--svg", &svg]);
    assert_eq!(v["pair"], "sim:mixed:5:1");
    assert_eq!(v["candidates"], "6");
    let beams = v["associations"].as_array().unwrap().len();
    assert_eq!(beams, 361);
    for key in ["confidence", "clusters"] {
        assert_eq!(v[key].as_array().unwrap().len(), beams, "{key}");
    }
    let motions = v["motions"].as_array().unwrap();
    assert!(!motions.is_empty());
    let background = v["background"].as_u64().unwrap() as usize;
    assert!(background < motions.len());
    for (k, (c, a)) in v["clusters"]
        .as_array()
        .unwrap()
        .iter()
        .zip(v["associations"].as_array().unwrap())
        .enumerate()
    {
        // A return has both a cluster and an association, a missing return neither.
        assert_eq!(c.is_null(), a.is_null(), "beam {k}");
        if let Some(c) = c.as_i64() {
            assert!(
                c == -1 || (0..motions.len() as i64).contains(&c),
                "beam {k}: {c}"
            );
        }
        if let Some(a) = a.as_i64() {
            assert!((-1..361).contains(&a), "beam {k}: {a}");
        }
    }
    for x in v["confidence"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|x| x.as_f64())
    {
        assert!(x > 0.0 && x <= 1.0 + 1e-9, "{x}");
    }
    // Per-cluster motions with their returns; the counts add up to the returns.
    let clusters = v["cluster_motions"].as_array().unwrap();
    assert_eq!(clusters.len(), motions.len());
    assert_eq!(
        clusters.iter().filter(|c| c["background"] == true).count(),
        1
    );
    let points: u64 = clusters.iter().map(|c| c["points"].as_u64().unwrap()).sum();
    let returns = v["clusters"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| !c.is_null())
        .count() as u64;
    assert_eq!(points + v["outliers"].as_u64().unwrap(), returns);
    assert_eq!(v["ego_motion"], motions[background]);
    assert!(v["sweeps"].as_u64().unwrap() >= 1 && v["rounds"].as_u64().unwrap() >= 1);
    assert!(v["converged"].is_boolean());
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert!(picture.contains("<svg") && picture.contains("joint model"));
    // Association lines (paths) and one circle per return of both scans.
    assert!(picture.matches("<polyline").count() + picture.matches("<path").count() > 100);
}

#[test]
fn joint_takes_the_state_space_and_the_clusters() {
    let ds = simulated_3("options");
    let v = ok_json(&[
        "joint",
        "--pairs",
        &ds,
        "--candidates",
        "3",
        "--clusters",
        "5",
    ]);
    assert_eq!(v["candidates"], "3");
    // D = 5 states: at most 4 motion clusters after the vacuous ones are dropped.
    assert!(v["motions"].as_array().unwrap().len() <= 4);
}

/// The fields of the issue's `pgm eval joint --json` object.
const FIELDS: [&str; 15] = [
    "pairs",
    "association_accuracy",
    "association_accuracy_within_one",
    "association_sed",
    "clustering_accuracy",
    "clustering_sed",
    "v_measure_mean",
    "outliers_predicted",
    "outliers_true",
    "outliers_found",
    "object_rotation_error_median",
    "object_translation_error_median",
    "ego_rotation_error_median",
    "ego_translation_error_median",
    "iterations_mean",
];

fn eval_joint(ds: &str, method: &str) -> serde_json::Value {
    ok_json(&eval("joint", method, &["--pairs", ds, "--json"]))
}

#[test]
fn eval_joint_prints_every_field_in_range() {
    let ds = simulated_3("eval");
    for method in ["joint", "icp+kmeans", "crf-matching+kmeans", "separate"] {
        let v = eval_joint(&ds, method);
        assert_eq!(v["method"], method, "names as typed");
        assert_eq!(v["pair_sets"], serde_json::json!(["sim:mixed:5"]));
        assert!(v["data"].as_str().unwrap().contains(&ds));
        assert!(v["weights"].is_string());
        let object = v.as_object().unwrap();
        for key in FIELDS {
            assert!(object.contains_key(key), "{method}: no `{key}`");
        }
        assert_eq!(v["pairs"], 3);
        let number = |key: &str| {
            v[key]
                .as_f64()
                .unwrap_or_else(|| panic!("{method}: {key} = {}", v[key]))
        };
        for key in [
            "association_accuracy",
            "association_accuracy_within_one",
            "clustering_accuracy",
            "v_measure_mean",
        ] {
            assert!((0.0..=1.0).contains(&number(key)), "{method}: {key}");
        }
        assert!(number("association_accuracy_within_one") >= number("association_accuracy"));
        for key in ["outliers_predicted", "outliers_true", "outliers_found"] {
            assert!((0.0..=100.0).contains(&number(key)), "{method}: {key}");
        }
        for key in [
            "association_sed",
            "clustering_sed",
            "ego_rotation_error_median",
            "ego_translation_error_median",
            "iterations_mean",
        ] {
            assert!(number(key) >= 0.0, "{method}: {key}");
        }
        // Simulated pairs: the ego-motion is found to within decimetres.
        assert!(number("ego_translation_error_median") < 0.2, "{method}");
        if method != "icp+kmeans" {
            // Learned associations beat nearest neighbours after ICP clearly.
            assert!(number("association_accuracy") > 0.7, "{method}: {v}");
            assert!(number("clustering_accuracy") > 0.7, "{method}: {v}");
            assert!(
                number("object_translation_error_median") < 0.5,
                "{method}: {v}"
            );
        }
        // Object errors are a number or null (no correctly clustered object).
        for key in [
            "object_rotation_error_median",
            "object_translation_error_median",
        ] {
            assert!(v[key].is_null() || number(key) >= 0.0, "{method}: {key}");
        }
    }
    // The text form names the data and the weights.
    let (out, _) = ok(&["eval", "joint", "--pairs", &ds]);
    assert!(
        out.contains("method joint: 3 pairs") && out.contains("sim:mixed:5"),
        "{out}"
    );
    assert!(out.contains("weights: shipped joint weights"), "{out}");
}

#[test]
fn eval_clustering_scores_the_joint_model_like_every_clusterer() {
    let ds = simulated_3("clustering");
    let (out, _) = ok(&eval("clustering", "joint", &["--pairs", &ds, "--json"]));
    let v = json(&out);
    assert_eq!(v["method"], "joint");
    assert_eq!(v["pairs"], 3);
    let vm = v["v_measure_mean"].as_f64().unwrap();
    assert!(vm > 0.3 && vm <= 1.0, "{out}");
    assert!(v["objects_detected"].as_u64().unwrap() > 0, "{out}");
    assert!(v["weights"].as_str().unwrap().contains("joint"), "{out}");
}

#[test]
fn bad_input_is_a_clear_error_with_status_2() {
    let dir = temp_dir("bad");
    let (ds, _) = simulated(&dir, "ds", 5, 3);
    let joint = |options: &[&'static str]| [&["joint", "--pairs", &ds][..], options].concat();
    // A pair without ground truth: nothing to score, said so.
    let mut pair = read_json(Path::new(&ds).join("pair-00000.json"));
    pair.as_object_mut().unwrap().remove("truth");
    let bare = write(&dir, "bare.json", &pair.to_string());
    refused_all(&[
        (
            vec!["joint", "--pairs", "/nonexistent/pairs"],
            vec!["/nonexistent/pairs"],
        ),
        (joint(&["--pair", "7"]), vec!["among its 3 pairs"]),
        (joint(&["--clusters", "1"]), vec!["`1` is neither `auto`"]),
        (joint(&["--candidates", "0"]), vec!["`0` is neither `full`"]),
        (eval("joint", "kmeans", &["--pairs", &ds]), vec!["kmeans"]),
        (
            joint(&["--weights", "/nonexistent/w.json"]),
            vec!["/nonexistent/w.json"],
        ),
        (
            vec!["eval", "joint", "--pairs", &bare],
            vec!["bare.json", "none of the 1 pairs has a ground-truth"],
        ),
    ]);
}

#[test]
fn joint_reads_a_carmen_log() {
    // The square room of `cli_clustering.rs`: two scans 0.2 m apart.
    let log = square_room(&temp_dir("carmen"), "");
    let (out, _) = ok(&one_pair("joint", "--carmen", &log, "0", "1"));
    let v = json(&out);
    assert_eq!(v["pair"], "room:0-1");
    assert_eq!(v["clusters"].as_array().unwrap().len(), 181);
    // Nothing moves: the ego-motion is the 0.2 m step.
    assert!(
        (v["ego_motion"]["x"].as_f64().unwrap() - 0.2).abs() < 0.02,
        "{out}"
    );
    refused(
        &one_pair("joint", "--carmen", &log, "0", "2"),
        &["scan 2: no such laser scan"],
    );
}

/// `--motion-fit point-to-point` (eq. 6 alone, the paper's motion solve) reaches
/// CRF-Matching and the joint model; on these pairs the default point-to-line solves
/// associate more returns exactly (seed 5: 0.903 against 0.881 for CRF-Matching).
#[test]
fn the_motion_fit_reaches_crf_matching_and_the_joint_model() {
    let ds = simulated_3("motion-fit");
    let accuracy = |args: &[&str], field: &str| {
        ok_json(&[args, &["--pairs", &ds, "--json"]].concat())[field]
            .as_f64()
            .unwrap()
    };
    let point_to_point = ["--motion-fit", "point-to-point"];
    for (command, field, by) in [
        (eval("association", "crf-matching", &[]), "accuracy", 0.01),
        (eval("joint", "joint", &[]), "association_accuracy", 0.0),
    ] {
        let line = accuracy(&command, field);
        let point = accuracy(&[&command[..], &point_to_point].concat(), field);
        assert!(
            line > point + by,
            "{command:?}: point-to-line {line}, point-to-point {point}"
        );
    }
    // The outputs say which solve made them.
    for fit in ["point-to-line", "point-to-point"] {
        for command in ["joint", "match"] {
            let v = ok_json(&[command, "--pairs", &ds, "--motion-fit", fit]);
            assert_eq!(v["motion_fit"], fit, "{command}");
        }
    }
    refused(
        &["joint", "--pairs", &ds, "--motion-fit", "icp"],
        &["--motion-fit"],
    );
}
