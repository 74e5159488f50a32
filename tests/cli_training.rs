//! Training and weight files from the command line (`pgm train`, every `--weights`
//! option): training on pairs without a mover is refused and writes nothing, weights
//! the model rejects are refused naming the file, every weights option names a missing
//! file once and a file of another model as such, and `pgm train joint` takes the
//! association part of a CRF-Matching weight file.

mod common;

use common::*;
use std::path::Path;

#[test]
fn training_on_pairs_without_a_mover_is_refused_and_writes_nothing() {
    // train-degenerate: every return labelled background.
    let dir = temp_dir("degenerate");
    let (_, pairs) = simulated(&dir, "sim", 13, 2);
    let still: Vec<serde_json::Value> = pairs
        .iter()
        .map(|p| {
            let mut v = to_json(p);
            for key in ["labels", "reference_labels"] {
                let labels: Vec<serde_json::Value> = v["truth"][key]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|l| if l.is_null() { l.clone() } else { 0.into() })
                    .collect();
                v["truth"][key] = labels.into();
            }
            v["truth"]["motions"] = serde_json::json!([]);
            v
        })
        .collect();
    let ds = write_raw(&dir, "still", &still);
    let weights = path(&dir, "w.json");
    for associations in ["true", "icp"] {
        refused(
            &[
                "train",
                "clustering",
                "--data",
                &ds,
                "--associations",
                associations,
                "--out",
                &weights,
            ],
            &["none with a moving object"],
        );
        assert!(
            !Path::new(&weights).exists(),
            "a refused training wrote weights"
        );
    }
    // Weights that the model rejects are refused where the file is named.
    let zero = write(
        &dir,
        "zero.json",
        r#"{"model": "crf-clustering", "version": 1, "weights": {
            "distance.squared": 0.0, "distance.normalised": 0.0,
            "neighbour.same": 0.0, "neighbour.different": 0.0,
            "weighted_neighbour.same": 0.0, "weighted_neighbour.different": 0.0,
            "stiffness.same": 0.0, "stiffness.different": 0.0}}"#,
    );
    refused(
        &["cluster", "--pairs", &ds, "--weights", &zero],
        &["zero.json", "weights.distance"],
    );
}

/// The shipped weight files: (model directory, the kind of file its errors name).
const KINDS: [(&str, &str); 3] = [
    ("crf-clustering", "CRF-Clustering"),
    ("crf-matching", "CRF-Matching"),
    ("joint", "joint-model"),
];

/// Item 3 of the polish: every weights option names a missing file once, and a weight
/// file of another model as such.
#[test]
fn weight_file_errors_name_the_file_once_and_the_kind_of_file() {
    let dir = temp_dir("weights");
    let (ds, _) = simulated(&dir, "ds", 5, 1);
    let out = path(&dir, "w.json");
    // (arguments before the file, the kind the option wants)
    let options: [(Vec<&str>, &str); 7] = [
        (
            vec!["cluster", "--pairs", &ds, "--weights"],
            "CRF-Clustering",
        ),
        (
            eval("clustering", "crf", &["--pairs", &ds, "--weights"]),
            "CRF-Clustering",
        ),
        (
            vec!["eval", "joint", "--pairs", &ds, "--crf-weights"],
            "CRF-Clustering",
        ),
        (
            vec!["match", "--pairs", &ds, "--matching-weights"],
            "CRF-Matching",
        ),
        (
            vec![
                "train",
                "joint",
                "--simulate",
                "2",
                "--out",
                &out,
                "--association-weights",
            ],
            "CRF-Matching",
        ),
        (vec!["joint", "--pairs", &ds, "--weights"], "joint-model"),
        (
            eval("clustering", "joint", &["--pairs", &ds, "--joint-weights"]),
            "joint-model",
        ),
    ];
    let missing = path(&dir, "nope.json");
    for (args, kind) in &options {
        let a = [&args[..], &[missing.as_str()]].concat();
        let err = refused(&a, &[&missing, "No such file"]);
        assert_eq!(
            err.matches(missing.as_str()).count(),
            1,
            "{a:?}: path repeated\n{err}"
        );
        for (model, title) in KINDS {
            if title == *kind {
                continue;
            }
            let file = shipped(model);
            let a = [&args[..], &[file.as_str()]].concat();
            let err = refused(
                &a,
                &[
                    &format!("not a {kind} weight file"),
                    &format!("it is a {title} weight file"),
                ],
            );
            assert_eq!(err.matches(file.as_str()).count(), 1, "{a:?}\n{err}");
        }
    }
    assert!(!Path::new(&out).exists(), "a refused training wrote {out}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `pgm train joint --association-weights` takes the association part of a
/// CRF-Matching weight file and learns the clustering weights; a file of another
/// model is refused with status 2, naming it, and nothing is written.
#[test]
fn train_joint_takes_the_association_part_of_crf_matching() {
    let dir = temp_dir("train-joint");
    let matching = shipped("crf-matching");
    let out = path(&dir, "joint.json");
    let v = ok_json(&[
        "train",
        "joint",
        "--simulate",
        "4",
        "--seed",
        "1000",
        "--association-weights",
        &matching,
        "--out",
        &out,
    ]);
    assert_eq!(v["booster_pairs"], 0);
    assert_eq!(v["association_weights"], matching.as_str());
    let shipped = read_json(&matching);
    assert_eq!(
        v["weights"]["sequence.next"], shipped["weights"]["sequence.next"],
        "the association weights are CRF-Matching's"
    );
    // A joint-model file is not a CRF-Matching file.
    let bad_out = path(&dir, "bad.json");
    refused(
        &[
            "train",
            "joint",
            "--simulate",
            "2",
            "--association-weights",
            &out,
            "--out",
            &bad_out,
        ],
        &["joint.json"],
    );
    assert!(!Path::new(&bad_out).exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A weight file whose weights are finite but huge (±1e308 overflowed the first
/// potential into ±∞ and then NaN) is refused by every model's loader, naming the
/// file, the weight and its value; 1e11 still loads.
#[test]
fn huge_weights_are_refused_by_every_loader() {
    let dir = temp_dir("huge-weights");
    let (ds, _) = simulated(&dir, "ds", 3, 1);
    let cases = [
        (
            "crf-clustering",
            vec!["cluster", "--pairs", ds.as_str(), "--weights"],
        ),
        (
            "crf-matching",
            vec!["match", "--pairs", ds.as_str(), "--matching-weights"],
        ),
        ("joint", vec!["joint", "--pairs", ds.as_str(), "--weights"]),
    ];
    for (model, args) in &cases {
        let text = std::fs::read_to_string(shipped(model)).unwrap();
        let mut file: serde_json::Value = serde_json::from_str(&text).unwrap();
        let (name, original) = file["weights"]
            .as_object()
            .unwrap()
            .iter()
            .next()
            .map(|(k, v)| (k.clone(), v.as_f64().unwrap()))
            .unwrap();
        // The accepted value keeps the shipped weight's sign (models constrain signs).
        let sign = if original < 0.0 { -1.0 } else { 1.0 };
        for (value, accepted) in [(-1e308, false), (sign * 1e13, false), (sign * 1e11, true)] {
            file["weights"][&name] = serde_json::json!(value);
            let w = write(&dir, &format!("{model}-{value:e}.json"), &file.to_string());
            let a = [&args[..], &[w.as_str()]].concat();
            if accepted {
                ok(&a);
            } else {
                refused(&a, &[&w, &name, &format!("{value:?}"), "at most 1e12"]);
            }
        }
    }
}

/// `--objective`: CRF-Matching learns by maximum likelihood on its chains (the JSON
/// says which objective, and the weights differ from pseudo-likelihood's); a loopy
/// CRF-Clustering (`--knn 2`) is refused by `ml` with the reason; an unknown objective
/// is refused naming it; nothing is written by a refused run.
#[test]
fn every_trainer_takes_an_objective() {
    let dir = temp_dir("train-objective");
    let (pl_out, ml_out) = (path(&dir, "pl.json"), path(&dir, "ml.json"));
    let train = |objective: &str, out: &str| {
        ok_json(&[
            "train",
            "matching",
            "--simulate",
            "6",
            "--seed",
            "1000",
            "--stumps",
            "10",
            "--objective",
            objective,
            "--out",
            out,
        ])
    };
    let pl = train("pl", &pl_out);
    let ml = train("ml", &ml_out);
    assert_eq!(pl["learning_objective"], "pl");
    assert_eq!(ml["learning_objective"], "ml");
    assert_eq!(ml["converged"], true);
    assert_ne!(
        pl["weights"]["sequence.next"],
        ml["weights"]["sequence.next"]
    );
    let loopy = path(&dir, "loopy.json");
    refused(
        &[
            "train",
            "clustering",
            "--simulate",
            "4",
            "--knn",
            "2",
            "--objective",
            "ml",
            "--out",
            &loopy,
        ],
        &["maximum likelihood", "cycle", "Bethe"],
    );
    refused(
        &[
            "train",
            "joint",
            "--simulate",
            "2",
            "--objective",
            "exact",
            "--out",
            &loopy,
        ],
        &["--objective", "\"exact\"", "pl", "bethe"],
    );
    assert!(!Path::new(&loopy).exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
