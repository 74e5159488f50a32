//! The simulator, `pgm eval clustering` and `pgm cluster` from the command line: the
//! JSON contracts of the issue and errors on bad input.

use std::path::PathBuf;
use std::process::Command;

fn pgm(args: &[&str]) -> (String, String, bool) {
    let out = Command::new(env!("CARGO_BIN_EXE_pgm"))
        .args(args)
        .output()
        .unwrap();
    (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
        out.status.success(),
    )
}

fn simulated(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pgm-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (_, err, ok) = pgm(&[
        "sim",
        "--pairs",
        "3",
        "--seed",
        "5",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    dir
}

/// `pgm eval clustering --method METHOD --pairs DIR EXTRA… --json` on the 3 simulated
/// pairs of `dir`: the parsed object (checked to count 3 pairs) and the raw output.
fn eval_json(dir: &std::path::Path, method: &str, extra: &[&str]) -> (serde_json::Value, String) {
    let mut args = vec![
        "eval",
        "clustering",
        "--method",
        method,
        "--pairs",
        dir.to_str().unwrap(),
        "--json",
    ];
    args.extend_from_slice(extra);
    let (out, err, ok) = pgm(&args);
    assert!(ok, "{method} {extra:?}: {err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["pairs"], 3, "{method} {extra:?}");
    (v, out)
}

#[test]
fn eval_clustering_prints_the_specified_json_object() {
    let dir = simulated("eval");
    for method in ["crf", "cbd", "kmeans", "one-cluster"] {
        let (v, out) = eval_json(&dir, method, &["--associations", "true"]);
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
        let (v, out) = eval_json(&dir, method, &["--associations", "icp", "--no-prior"]);
        let x = v["v_measure_mean"].as_f64().unwrap_or(f64::NAN);
        assert!((0.0..=1.0).contains(&x), "{method} --no-prior: {out}");
    }
}

#[test]
fn cluster_prints_clusters_motions_and_convergence() {
    let dir = simulated("cluster");
    let svg = dir.join("pair.svg");
    let (out, err, ok) = pgm(&[
        "cluster",
        "--pairs",
        dir.to_str().unwrap(),
        "--pair",
        "0",
        "--associations",
        "true",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
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
    let (_, err, ok) = pgm(&[
        "eval",
        "clustering",
        "--method",
        "crf",
        "--pairs",
        "/nonexistent/pairs",
    ]);
    assert!(!ok && err.contains("/nonexistent/pairs"), "{err}");
    let (_, err, ok) = pgm(&["sim", "--pairs", "1", "--preset", "motorway"]);
    assert!(!ok && err.contains("motorway"), "{err}");
}

#[test]
fn cluster_reads_a_carmen_log() {
    // Two FLASER scans of a square room (half side 4 m) 0.2 m apart, the robot pose
    // on each line.
    let scan = |x: f64| {
        let n = 181;
        let ranges: Vec<String> = (0..n)
            .map(|k| {
                let a = (-90.0 + k as f64).to_radians();
                let (c, s) = (a.cos(), a.sin());
                // Distance to the walls x = 4, y = ±4 from (x, 0).
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
            "FLASER {n} {} {x} 0 0 {x} 0 0 {} host 0\n",
            ranges.join(" "),
            100.0 + x
        )
    };
    let dir = std::env::temp_dir().join(format!("pgm-cli-carmen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("room.clf");
    std::fs::write(&log, format!("# a room\n{}{}", scan(0.0), scan(0.2))).unwrap();
    let log = log.to_str().unwrap();
    let (out, err, ok) = pgm(&[
        "cluster",
        "--carmen",
        log,
        "--reference",
        "0",
        "--current",
        "1",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["pair"], "room:0-1");
    assert_eq!(v["labels"].as_array().unwrap().len(), 181);
    // Nothing moves: one background cluster whose motion is the 0.2 m step.
    let clusters = v["clusters"].as_array().unwrap();
    assert_eq!(clusters.len(), 1, "{out}");
    assert!(
        (v["background_motion"]["x"].as_f64().unwrap() - 0.2).abs() < 0.02,
        "{out}"
    );
    let (_, err, ok) = pgm(&[
        "cluster",
        "--carmen",
        log,
        "--reference",
        "0",
        "--current",
        "2",
    ]);
    assert!(
        !ok && err.contains("scan 2: no such laser scan") && err.contains("2 FLASER"),
        "{err}"
    );
}
