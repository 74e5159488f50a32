//! Fixes after a new user's report (branch `polish`): each problem has a test here
//! that fails without its fix. Helpers are shared with `cli_hardening_kinds.rs`
//! (`tests/common`).

mod common;

use common::*;

/// Item 1: every numeric option is checked, also where the chosen method (or source)
/// does not use it, and before the data are read.
#[test]
fn unused_options_are_checked_in_every_evaluation() {
    let dir = temp_dir("unused-options");
    let (ds, _) = simulated(&dir, "ds", 5, 1);
    for method in ["joint", "separate", "icp+kmeans"] {
        refused(
            &[
                "eval",
                "joint",
                "--pairs",
                &ds,
                "--method",
                method,
                "--kmeans-k",
                "0",
            ],
            &["K-Means", "`k` = 0"],
        );
    }
    let cases: [(&[&str], &str); 6] = [
        (&["eval", "joint", "--pairs", &ds, "--k", "0"], "--k 0"),
        (
            &["eval", "joint", "--pairs", &ds, "--moving-threshold", "nan"],
            "--moving-threshold",
        ),
        (
            &[
                "eval",
                "clustering",
                "--method",
                "cbd",
                "--pairs",
                &ds,
                "--person-radius",
                "0",
            ],
            "--person-radius",
        ),
        (
            &[
                "eval",
                "clustering",
                "--method",
                "cbd",
                "--pairs",
                &ds,
                "--walking-speed=-1",
            ],
            "--walking-speed",
        ),
        (
            &[
                "eval",
                "clustering",
                "--method",
                "cbd",
                "--pairs",
                &ds,
                "--min-object-returns",
                "0",
            ],
            "--min-object-returns",
        ),
        (
            &[
                "eval",
                "matching",
                "--method",
                "icp",
                "--pairs",
                &ds,
                "--laser-fov",
                "0",
            ],
            "--laser-fov",
        ),
    ];
    for (args, needle) in cases {
        refused(args, &[needle]);
    }
    // The options are checked before the data are read: a data set that does not
    // exist is not what the error is about.
    refused(
        &[
            "eval",
            "joint",
            "--pairs",
            "/nonexistent-dir",
            "--kmeans-k",
            "0",
        ],
        &["`k` = 0"],
    );
    // Sensible values still run.
    ok(&["eval", "joint", "--pairs", &ds, "--kmeans-k", "3", "--json"]);
    std::fs::remove_dir_all(&dir).unwrap();
}
