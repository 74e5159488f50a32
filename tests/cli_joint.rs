//! `pgm joint`, `pgm eval joint` and `pgm eval clustering --method joint` from the
//! command line: the JSON contracts of issue 15, the SVG, and clear errors (status 2)
//! on bad input.

use std::path::{Path, PathBuf};
use std::process::Command;

fn pgm(args: &[&str]) -> (String, String, Option<i32>) {
    let out = Command::new(env!("CARGO_BIN_EXE_pgm"))
        .args(args)
        .output()
        .unwrap();
    (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
        out.status.code(),
    )
}

/// Three simulated pairs (seed 5) in a fresh directory.
fn simulated(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pgm-cli-joint-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (_, err, code) = pgm(&[
        "sim",
        "--pairs",
        "3",
        "--seed",
        "5",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    dir
}

fn json(out: &str) -> serde_json::Value {
    serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("{e}: {out}"))
}

#[test]
fn joint_prints_associations_clusters_and_motions_and_draws_them() {
    let dir = simulated("one");
    let svg = dir.join("joint.svg");
    let (out, err, code) = pgm(&[
        "joint",
        "--pairs",
        dir.to_str().unwrap(),
        "--pair",
        "1",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let v = json(&out);
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
    let dir = simulated("options");
    let (out, err, code) = pgm(&[
        "joint",
        "--pairs",
        dir.to_str().unwrap(),
        "--candidates",
        "3",
        "--clusters",
        "5",
    ]);
    assert_eq!(code, Some(0), "{err}");
    let v = json(&out);
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

fn eval_joint(dir: &Path, method: &str) -> serde_json::Value {
    let (out, err, code) = pgm(&[
        "eval",
        "joint",
        "--method",
        method,
        "--pairs",
        dir.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, Some(0), "{method}: {err}");
    json(&out)
}

#[test]
fn eval_joint_prints_every_field_in_range() {
    let dir = simulated("eval");
    for method in ["joint", "icp+kmeans", "crf-matching+kmeans", "separate"] {
        let v = eval_joint(&dir, method);
        assert_eq!(v["method"], method, "names as typed");
        assert_eq!(v["pair_sets"], serde_json::json!(["sim:mixed:5"]));
        assert!(v["data"].as_str().unwrap().contains(dir.to_str().unwrap()));
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
    let (out, err, code) = pgm(&["eval", "joint", "--pairs", dir.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("method joint: 3 pairs") && out.contains("sim:mixed:5"),
        "{out}"
    );
    assert!(out.contains("weights: shipped joint weights"), "{out}");
}

#[test]
fn eval_clustering_scores_the_joint_model_like_every_clusterer() {
    let dir = simulated("clustering");
    let (out, err, code) = pgm(&[
        "eval",
        "clustering",
        "--method",
        "joint",
        "--pairs",
        dir.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, Some(0), "{err}");
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
    let dir = simulated("bad");
    let cases: [(&[&str], &str); 6] = [
        (
            &["joint", "--pairs", "/nonexistent/pairs"],
            "/nonexistent/pairs",
        ),
        (
            &["joint", "--pairs", dir.to_str().unwrap(), "--pair", "7"],
            "among its 3 pairs",
        ),
        (
            &["joint", "--pairs", dir.to_str().unwrap(), "--clusters", "1"],
            "`1` is neither `auto`",
        ),
        (
            &[
                "joint",
                "--pairs",
                dir.to_str().unwrap(),
                "--candidates",
                "0",
            ],
            "`0` is neither `full`",
        ),
        (
            &[
                "eval",
                "joint",
                "--method",
                "kmeans",
                "--pairs",
                dir.to_str().unwrap(),
            ],
            "kmeans",
        ),
        (
            &[
                "joint",
                "--pairs",
                dir.to_str().unwrap(),
                "--weights",
                "/nonexistent/w.json",
            ],
            "/nonexistent/w.json",
        ),
    ];
    for (args, needle) in cases {
        let (_, err, code) = pgm(args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    // A pair without ground truth: nothing to score, said so.
    let text = std::fs::read_to_string(dir.join("pair-00000.json")).unwrap();
    let mut pair: serde_json::Value = serde_json::from_str(&text).unwrap();
    pair.as_object_mut().unwrap().remove("truth");
    let bare = dir.join("bare.json");
    std::fs::write(&bare, pair.to_string()).unwrap();
    let (_, err, code) = pgm(&["eval", "joint", "--pairs", bare.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("bare.json") && err.contains("none of the 1 pairs has a ground-truth"),
        "{err}"
    );
}

#[test]
fn joint_reads_a_carmen_log() {
    // Two FLASER scans of a square room (half side 4 m) 0.2 m apart, the robot pose
    // on each line (as tests/cli_clustering.rs).
    let scan = |x: f64| {
        let ranges: Vec<String> = (0..181)
            .map(|k| {
                let a = (-90.0 + k as f64).to_radians();
                let (c, s) = (a.cos(), a.sin());
                let front = if c > 1e-9 {
                    (4.0 - x) / c
                } else {
                    f64::INFINITY
                };
                let side = if s.abs() > 1e-9 {
                    4.0 / s.abs()
                } else {
                    f64::INFINITY
                };
                format!("{:.3}", front.min(side))
            })
            .collect();
        format!(
            "FLASER 181 {} {x} 0 0 {x} 0 0 {} host 0\n",
            ranges.join(" "),
            100.0 + x
        )
    };
    let dir = std::env::temp_dir().join(format!("pgm-cli-joint-carmen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("room.clf");
    std::fs::write(&log, format!("{}{}", scan(0.0), scan(0.2))).unwrap();
    let log = log.to_str().unwrap();
    let (out, err, code) = pgm(&[
        "joint",
        "--carmen",
        log,
        "--reference",
        "0",
        "--current",
        "1",
    ]);
    assert_eq!(code, Some(0), "{err}");
    let v = json(&out);
    assert_eq!(v["pair"], "room:0-1");
    assert_eq!(v["clusters"].as_array().unwrap().len(), 181);
    // Nothing moves: the ego-motion is the 0.2 m step.
    assert!(
        (v["ego_motion"]["x"].as_f64().unwrap() - 0.2).abs() < 0.02,
        "{out}"
    );
    let (_, err, code) = pgm(&[
        "joint",
        "--carmen",
        log,
        "--reference",
        "0",
        "--current",
        "2",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("scan 2: no such laser scan"), "{err}");
}

/// `pgm train joint --association-weights` takes the association part of a
/// CRF-Matching weight file and learns the clustering weights; a file of another
/// model is refused with status 2, naming it, and nothing is written.
#[test]
fn train_joint_takes_the_association_part_of_crf_matching() {
    let dir = std::env::temp_dir().join(format!("pgm-cli-joint-train-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let matching =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("models/crf-matching/weights/default.json");
    let out = dir.join("joint.json");
    let (stdout, stderr, code) = pgm(&[
        "train",
        "joint",
        "--simulate",
        "4",
        "--seed",
        "1000",
        "--association-weights",
        matching.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let v = json(&stdout);
    assert_eq!(v["booster_pairs"], 0);
    assert_eq!(v["association_weights"], matching.to_str().unwrap());
    let shipped: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&matching).unwrap()).unwrap();
    assert_eq!(
        v["weights"]["sequence.next"], shipped["weights"]["sequence.next"],
        "the association weights are CRF-Matching's"
    );
    // A joint-model file is not a CRF-Matching file.
    let bad_out = dir.join("bad.json");
    let (_, stderr, code) = pgm(&[
        "train",
        "joint",
        "--simulate",
        "2",
        "--association-weights",
        out.to_str().unwrap(),
        "--out",
        bad_out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("joint.json"), "{stderr}");
    assert!(!bad_out.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--motion-fit point-to-point` (eq. 6 alone, the paper's motion solve) reaches
/// CRF-Matching and the joint model; on these pairs the default point-to-line solves
/// associate more returns exactly (seed 5: 0.903 against 0.881 for CRF-Matching).
#[test]
fn the_motion_fit_reaches_crf_matching_and_the_joint_model() {
    let dir = simulated("motion-fit");
    let accuracy = |args: &[&str], field: &str| {
        let mut all = args.to_vec();
        all.extend(["--pairs", dir.to_str().unwrap(), "--json"]);
        let (out, err, code) = pgm(&all);
        assert_eq!(code, Some(0), "{args:?}: {err}");
        json(&out)[field].as_f64().unwrap()
    };
    let crf_m = ["eval", "association", "--method", "crf-matching"];
    let line = accuracy(&crf_m, "accuracy");
    let point = accuracy(
        &[&crf_m[..], &["--motion-fit", "point-to-point"]].concat(),
        "accuracy",
    );
    assert!(
        line > point + 0.01,
        "point-to-line {line}, point-to-point {point}"
    );
    let joint = ["eval", "joint", "--method", "joint"];
    let line = accuracy(&joint, "association_accuracy");
    let point = accuracy(
        &[&joint[..], &["--motion-fit", "point-to-point"]].concat(),
        "association_accuracy",
    );
    assert!(line > point, "point-to-line {line}, point-to-point {point}");
    // The outputs say which solve made them.
    for fit in ["point-to-line", "point-to-point"] {
        for command in ["joint", "match"] {
            let (out, err, code) = pgm(&[
                command,
                "--pairs",
                dir.to_str().unwrap(),
                "--motion-fit",
                fit,
            ]);
            assert_eq!(code, Some(0), "{command}: {err}");
            assert_eq!(json(&out)["motion_fit"], fit, "{command}");
        }
    }
    let (_, err, code) = pgm(&[
        "joint",
        "--pairs",
        dir.to_str().unwrap(),
        "--motion-fit",
        "icp",
    ]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--motion-fit"), "{err}");
}
