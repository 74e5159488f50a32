//! Option validation from the command line: counts that would overflow an
//! allocation, options that parse but mean nothing, and every numeric option, also
//! where the chosen method does not use it, exit with status 2 and a message naming
//! the option and its value, before any data are read.

mod common;

use common::logs::sparse_log;
use common::*;

#[test]
fn counts_and_options_that_mean_nothing_exit_2() {
    let dir = temp_dir("options");
    let (ds, _) = simulated(&dir, "sim", 14, 2);
    let huge = "18446744073709551615";
    let w = path(&dir, "w.json");
    let svg = path(&dir, "p.svg");
    // Kind 1: counts that overflowed an allocation (capacity-overflow panics, then
    // aborts) or a zero count that printed statistics of nothing.
    let mut counts: Vec<Refusal> = vec![
        (vec!["sim", "--pairs", huge], vec!["pairs"]),
        (vec!["sim", "--pairs", "0"], vec!["pairs"]),
        (
            vec!["sim", "--pairs", "100000", "--beams", "1000"],
            vec!["beams in all"],
        ),
        (vec!["demo", "--pairs", huge], vec!["pairs"]),
        (
            vec!["train", "clustering", "--simulate", huge, "--out", &w],
            vec!["pairs"],
        ),
    ];
    for model in ["matching", "joint"] {
        counts.push((
            vec![
                "train",
                model,
                "--data",
                &ds,
                "--out",
                &w,
                "--candidates",
                huge,
            ],
            vec!["--candidates"],
        ));
    }
    // A view of ±1e308 m made the axis ticks run forever; a 10 km by 1 m view made a
    // picture millions of pixels high.
    for view in ["-1e308,1e308,-1e308,1e308", "0,1e4,0,1", "1e300,1e301,0,1"] {
        counts.push((
            vec!["plot", &ds, "--svg", &svg, "--view", view],
            vec!["--view"],
        ));
    }
    refused_all(&counts);
    // Options that parse but mean nothing, refused even when the chosen method would
    // not read them (they were silently ignored).
    let model = write(&dir, "m.uai", "MARKOV\n1\n2\n1\n1 0\n2\n0.4 0.6\n");
    let (log, _) = sparse_log(&dir, 30);
    let cluster = one_pair("cluster", "--carmen", &log, "0", "1");
    let meaningless: Vec<Refusal> = vec![
        (vec!["map", &model, "--tolerance", "inf"], vec!["tolerance"]),
        (
            eval(
                "matching",
                "icp",
                &["--pairs", &ds, "--near-seconds", "nan"],
            ),
            vec!["--near-seconds"],
        ),
        (
            eval("matching", "icp", &["--pairs", &ds, "--near-seconds=-1"]),
            vec!["--near-seconds"],
        ),
        (
            eval(
                "matching",
                "odometry",
                &["--pairs", &ds, "--icp-decay", "nan"],
            ),
            vec!["distance_decay"],
        ),
        (
            vec![
                "cluster",
                "--pairs",
                &ds,
                "--associations",
                "true",
                "--gate",
                "nan",
            ],
            vec!["gate"],
        ),
        (
            eval("clustering", "crf", &["--pairs", &ds, "--cbd-margin=-1"]),
            vec!["margin"],
        ),
        (
            eval("clustering", "cbd", &["--pairs", &ds, "--kmeans-k", "0"]),
            vec!["`k`"],
        ),
        (
            [&cluster[..], &["--laser-fov", "1e300"]].concat(),
            vec!["1e300"],
        ),
    ];
    for ((args, _), err) in meaningless.iter().zip(refused_all(&meaningless)) {
        // Values are printed as written, not as 300 digits.
        assert!(!err.contains("000000000000000000000"), "{args:?}: {err}");
    }
}

/// Item 1 of the polish: every numeric option is checked, also where the chosen
/// method (or source) does not use it, and before the data are read.
#[test]
fn unused_options_are_checked_in_every_evaluation() {
    let dir = temp_dir("unused-options");
    let (ds, _) = simulated(&dir, "ds", 5, 1);
    let mut cases: Vec<Refusal> = ["joint", "separate", "icp+kmeans"]
        .into_iter()
        .map(|method| {
            (
                eval("joint", method, &["--pairs", &ds, "--kmeans-k", "0"]),
                vec!["K-Means", "`k` = 0"],
            )
        })
        .collect();
    cases.extend([
        (
            vec!["eval", "joint", "--pairs", &ds, "--k", "0"],
            vec!["--k 0"],
        ),
        (
            vec!["eval", "joint", "--pairs", &ds, "--moving-threshold", "nan"],
            vec!["--moving-threshold"],
        ),
        (
            eval(
                "clustering",
                "cbd",
                &["--pairs", &ds, "--person-radius", "0"],
            ),
            vec!["--person-radius"],
        ),
        (
            eval("clustering", "cbd", &["--pairs", &ds, "--walking-speed=-1"]),
            vec!["--walking-speed"],
        ),
        (
            eval(
                "clustering",
                "cbd",
                &["--pairs", &ds, "--min-object-returns", "0"],
            ),
            vec!["--min-object-returns"],
        ),
        (
            eval("matching", "icp", &["--pairs", &ds, "--laser-fov", "0"]),
            vec!["--laser-fov"],
        ),
        // The options are checked before the data are read: a data set that does not
        // exist is not what the error is about.
        (
            vec![
                "eval",
                "joint",
                "--pairs",
                "/nonexistent-dir",
                "--kmeans-k",
                "0",
            ],
            vec!["`k` = 0"],
        ),
    ]);
    refused_all(&cases);
    // Sensible values still run.
    ok(&["eval", "joint", "--pairs", &ds, "--kmeans-k", "3", "--json"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A negative scan distance names its value in every command that takes `--k` (clap
/// read `--k -3` as the unknown option `-3`).
#[test]
fn a_negative_scan_distance_is_refused_naming_its_value() {
    let dir = temp_dir("negative-k");
    let (ds, _) = simulated(&dir, "ds", 5, 1);
    let negative = ["--pairs", &ds, "--k", "-3"];
    let mut cases: Vec<Refusal> = vec![(
        vec!["track", "--method", "crf", "--pairs", &ds, "--k", "-3"],
        vec!["'-3'", "--k", "not negative"],
    )];
    for (kind, method) in [
        ("tracking", "crf"),
        ("ego-motion", "crf"),
        ("matching", "icp"),
        ("clustering", "crf"),
    ] {
        cases.push((eval(kind, method, &negative), vec!["'-3'", "--k"]));
    }
    cases.extend([
        (
            vec![
                "data", "summary", "--scans", "a", "--people", "b", "--k", "1,-3",
            ],
            vec!["'-3'", "--k"],
        ),
        (
            vec!["sim", "--sequence", "5", "--k", "-1"],
            vec!["'-1'", "--k"],
        ),
        (
            vec!["track", "--method", "crf", "--pairs", &ds, "--k", "1.5"],
            vec!["'1.5'", "whole number"],
        ),
    ]);
    refused_all(&cases);
}
