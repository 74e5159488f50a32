//! Fixes after a new user's report (branch `polish`): each problem has a test here
//! that fails without its fix. Helpers are shared with `cli_hardening_kinds.rs`
//! (`tests/common`).

mod common;

use common::*;
use std::path::Path;

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

/// The shipped weight file of `model` (crf-clustering, crf-matching, joint).
fn shipped(model: &str) -> String {
    format!(
        "{}/models/{model}/weights/default.json",
        env!("CARGO_MANIFEST_DIR")
    )
}

/// Item 3: every weights option names a missing file once, and a weight file of
/// another model as such.
#[test]
fn weight_file_errors_name_the_file_once_and_the_kind_of_file() {
    let dir = temp_dir("weights");
    let (ds, _) = simulated(&dir, "ds", 5, 1);
    let out = dir.join("w.json");
    let out = out.to_str().unwrap();
    // (arguments before the file, the kind the option wants)
    let options: [(Vec<&str>, &str); 7] = [
        (
            vec!["cluster", "--pairs", &ds, "--weights"],
            "CRF-Clustering",
        ),
        (
            vec![
                "eval",
                "clustering",
                "--method",
                "crf",
                "--pairs",
                &ds,
                "--weights",
            ],
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
                out,
                "--association-weights",
            ],
            "CRF-Matching",
        ),
        (vec!["joint", "--pairs", &ds, "--weights"], "joint-model"),
        (
            vec![
                "eval",
                "clustering",
                "--method",
                "joint",
                "--pairs",
                &ds,
                "--joint-weights",
            ],
            "joint-model",
        ),
    ];
    let missing = dir.join("nope.json");
    let missing = missing.to_str().unwrap();
    for (args, kind) in &options {
        let mut a = args.clone();
        a.push(missing);
        let err = refused(&a, &[missing, "No such file"]);
        assert_eq!(
            err.matches(missing).count(),
            1,
            "{a:?}: path repeated\n{err}"
        );
        for (model, title) in [
            ("crf-clustering", "CRF-Clustering"),
            ("crf-matching", "CRF-Matching"),
            ("joint", "joint-model"),
        ] {
            if title == *kind {
                continue;
            }
            let file = shipped(model);
            let mut a = args.clone();
            a.push(&file);
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
    assert!(!Path::new(out).exists(), "a refused training wrote {out}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Item 5: a `--view` too large is refused for its size, not called infinite.
#[test]
fn plot_view_errors_say_what_the_limit_is() {
    let dir = temp_dir("view");
    let (ds, _) = simulated(&dir, "ds", 5, 1);
    let svg = dir.join("p.svg");
    let svg = svg.to_str().unwrap();
    let err = refused(
        &["plot", &ds, "--svg", svg, "--view", "0,1e300,0,1"],
        &["1e300 m lies beyond 1e5 m of the sensor"],
    );
    assert!(!err.contains("not a finite"), "{err}");
    refused(
        &["plot", &ds, "--svg", svg, "--view", "0,inf,0,1"],
        &["inf is not a finite number"],
    );
    assert!(!Path::new(svg).exists());
    ok(&["plot", &ds, "--svg", svg, "--view=-5,5,-3,3"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Item 6: a pair of a scan with itself is refused by every one-pair command and
/// source, with the words of the pair builders' `k = 0`.
#[test]
fn a_scan_paired_with_itself_is_refused() {
    let dir = temp_dir("same-scan");
    let carmen = write(
        &dir,
        "log.clf",
        &(0..3)
            .map(|t| {
                let ranges = vec!["2.0"; 181].join(" ");
                format!("FLASER 181 {ranges} 0 0 0 0 0 0 {t}.0 host {t}.0\n")
            })
            .collect::<String>(),
    );
    for command in ["cluster", "match", "joint"] {
        refused(
            &[
                command,
                "--carmen",
                &carmen,
                "--reference",
                "1",
                "--current",
                "1",
            ],
            &[
                "--reference 1 --current 1",
                "the two scans of a pair must differ",
            ],
        );
    }
    let scans = write(
        &dir,
        "scans.txt",
        "SCAN 5 1.0 1.0 l -1.0 0.1 0.0 10.0 3 1.0 2.0 3.0\nSCAN 6 1.1 1.1 l -1.0 0.1 0.0 10.0 3 1.0 2.0 3.0\n",
    );
    refused(
        &[
            "cluster",
            "--scans",
            &scans,
            "--reference",
            "5",
            "--current",
            "5",
        ],
        &["the two scans of a pair must differ"],
    );
    // The same message as the pair builders' k = 0.
    refused(
        &[
            "data", "summary", "--scans", &scans, "--people", &scans, "--k", "0",
        ],
        &["the two scans of a pair must differ"],
    );
    ok(&[
        "cluster",
        "--carmen",
        &carmen,
        "--reference",
        "0",
        "--current",
        "1",
    ]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Item 8: the help of `pgm demo` says what it runs and writes.
#[test]
fn demo_help_names_the_joint_model_and_both_pictures() {
    for args in [&["--help"][..], &["demo", "--help"][..]] {
        let (out, _) = ok(args);
        let line = out
            .lines()
            .find(|l| l.contains("built-in simulator"))
            .unwrap_or_else(|| panic!("{args:?}:\n{out}"));
        for needle in ["joint model", "crf-clustering.svg", "joint.svg"] {
            assert!(
                line.contains(needle),
                "{args:?}: {needle:?} not in {line:?}"
            );
        }
    }
}

/// Item 10: the two object counts of `pgm eval clustering` say what they count, and
/// agree with the JSON fields (whose names stay).
#[test]
fn eval_clustering_text_says_what_each_object_count_counts() {
    let dir = temp_dir("counts");
    let (ds, _) = simulated(&dir, "ds", 7, 3);
    let args = ["eval", "clustering", "--method", "crf", "--pairs", &ds];
    let (text, _) = ok(&args);
    let (out, _) = ok(&[&args[..], &["--json"]].concat());
    let j = json(&out);
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

/// Item 4: a file that is not text, given where a text log (or a UAI model or a pair
/// file) is read, is refused naming the file, the line and the byte offset.
#[test]
fn binary_files_given_as_logs_name_the_line_and_byte() {
    let dir = temp_dir("binary");
    let path = dir.join("log.bin");
    let mut bytes = b"SCAN 0 1.0 1.0 l -1 0.1 0 10 2 1 2\n# note\n".to_vec();
    let offset = bytes.len() + 3;
    bytes.extend_from_slice(b"abc\xff\xfe\x00junk\n");
    std::fs::write(&path, &bytes).unwrap();
    let log = path.to_str().unwrap();
    let needles = [
        &format!("{log}:3: byte {offset} (0xff) is not UTF-8 text")[..],
        "binary or compressed",
    ];
    refused(
        &[
            "cluster",
            "--scans",
            log,
            "--reference",
            "0",
            "--current",
            "1",
        ],
        &needles,
    );
    refused(
        &[
            "cluster",
            "--carmen",
            log,
            "--reference",
            "0",
            "--current",
            "1",
        ],
        &needles,
    );
    refused(
        &["data", "summary", "--scans", log, "--people", log],
        &needles,
    );
    refused(&["plot", log, "--svg", &format!("{log}.svg")], &needles);
    refused(&["map", log], &[&format!("{log}:3: byte {offset}")]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Item 7: a command that reads one pair of a data set opens only that pair's file;
/// the damaged pair is still an error when it is the one asked for.
#[test]
fn one_damaged_pair_file_only_stops_the_commands_that_read_it() {
    let dir = temp_dir("damaged");
    let (ds, pairs) = simulated(&dir, "ds", 5, 3);
    let damaged = Path::new(&ds).join("pair-00001.json");
    let text = std::fs::read_to_string(&damaged).unwrap();
    std::fs::write(&damaged, &text[..text.len() / 2]).unwrap();
    let damaged = damaged.to_str().unwrap();
    let svg = dir.join("p.svg");
    let svg = svg.to_str().unwrap();
    ok(&["plot", &ds, "--pair", "2", "--svg", svg]);
    refused(
        &["plot", &ds, "--pair", "1", "--svg", svg],
        &[damaged, "EOF"],
    );
    refused(
        &["plot", &ds, "--pair", "3", "--svg", svg],
        &["--pair 3", "3 pairs"],
    );
    for command in ["cluster", "match", "joint"] {
        let (out, _) = ok(&[command, "--pairs", &ds, "--pair", "2"]);
        assert_eq!(json(&out)["pair"], pairs[2].name.as_str(), "{command}");
        ok(&[command, "--pairs", &ds, "--pair", &pairs[0].name]);
        refused(&[command, "--pairs", &ds, "--pair", "1"], &[damaged]);
        refused(
            &[command, "--pairs", &ds, "--pair", &pairs[1].name],
            &[damaged],
        );
    }
    // Commands that read every pair still refuse the data set.
    refused(
        &["eval", "clustering", "--method", "cbd", "--pairs", &ds],
        &[damaged],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Item 2: a person centre beyond the reach its scan declares (range_max + 1 m) is
/// refused naming the people file, line and value, and the scan line.
#[test]
fn person_centres_beyond_the_lasers_reach_are_refused() {
    let dir = temp_dir("reach");
    let scans: String = (0..4)
        .map(|i| {
            format!(
                "SCAN {} {}.0 {}.0 l -1.0 0.1 0.0 10.0 3 1.0 2.0 3.0\n",
                130 + i,
                i,
                i
            )
        })
        .collect();
    let scans = write(&dir, "scans.txt", &scans);
    let people = |far: &str| {
        write(
            &dir,
            "people.txt",
            &format!("PERSON 130 1 1.0 0.5\n# far\nPERSON 131 1 {far} -2.1637\n"),
        )
    };
    for far in ["50000", "11.5"] {
        let file = people(far);
        for args in [
            &[
                "data", "summary", "--scans", &scans, "--people", &file, "--k", "1",
            ][..],
            &[
                "eval",
                "clustering",
                "--method",
                "cbd",
                "--scans",
                &scans,
                "--people",
                &file,
                "--k",
                "1",
                "--labels",
                "displacement",
            ][..],
        ] {
            refused(
                args,
                &[
                    &format!("{file}:3: field `x y` = `{far} -2.1637`"),
                    "beyond its reach",
                    &format!("scan 131 ({scans}:2) declares range_max 10 m"),
                    "at most 1 m beyond",
                ],
            );
        }
    }
    // Within range_max + 1 m: accepted.
    let file = people("10.7");
    let args = ["--scans", &scans, "--people", &file, "--k", "1"];
    let without_odometry = ["--walking-speed", "0", "--moving-threshold", "0"];
    ok(&[&["data", "summary"][..], &args, &without_odometry].concat());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Item 9: a damaged record inside a ROS 1 chunk names the topic and message it is
/// (its header still names its connection) or follows (it does not), and where it lies.
#[test]
fn damaged_bag_records_name_the_topic_and_message() {
    use pgm::datasets::bag::synthetic::{drive, ros1_bag, serialise, Wire};
    let dir = temp_dir("bag-record");
    let records = drive(4);
    let good = ros1_bag(&records);
    let scan = records
        .iter()
        .filter(|r| r.topic == "/scan")
        .nth(1)
        .unwrap();
    let data = serialise(&scan.msg, 2, Wire::Ros1);
    let at = good
        .windows(data.len())
        .position(|w| w == data.as_slice())
        .unwrap();
    // The data length of the second scan message runs past the chunk: its header
    // still names the scan topic.
    let mut bytes = good.clone();
    bytes[at - 4..at].copy_from_slice(&0x7fff_ffffu32.to_le_bytes());
    let path = dir.join("length.bag");
    std::fs::write(&path, &bytes).unwrap();
    let bag = path.to_str().unwrap();
    let cluster = [
        "cluster",
        "--bag",
        bag,
        "--scan-topic",
        "/scan",
        "--reference",
        "0",
        "--current",
        "1",
    ];
    refused(
        &cluster,
        &[
            "topic /scan, message 2",
            "this message's record",
            "of the chunk at byte",
            "out of bounds",
        ],
    );
    // The header length of the same record is garbled: the error names the message
    // before it.
    let mut bytes = good.clone();
    let header_len_at = at - 4 - 38 - 4;
    assert_eq!(
        &bytes[header_len_at..header_len_at + 4],
        &38u32.to_le_bytes()
    );
    bytes[header_len_at..header_len_at + 4].copy_from_slice(&0x7fff_ffffu32.to_le_bytes());
    let path = dir.join("header.bag");
    std::fs::write(&path, &bytes).unwrap();
    let bag = path.to_str().unwrap();
    let cluster = [
        "cluster",
        "--bag",
        bag,
        "--scan-topic",
        "/scan",
        "--reference",
        "0",
        "--current",
        "1",
    ];
    let err = refused(
        &cluster,
        &[
            "topic /",
            ", message ",
            "the record after this message",
            "at byte",
        ],
    );
    assert!(!err.contains("rosbag::Error"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `pgm eval matching`: a time subset holding every pair (simulated pairs are all
/// less than 1.5 s apart) is named in one line, not printed as a copy of the `all`
/// row; the JSON keeps the subset.
#[test]
fn eval_matching_does_not_repeat_a_subset_that_holds_every_pair() {
    let dir = temp_dir("near-subset");
    let (ds, _) = simulated(&dir, "ds", 9, 3);
    let (text, _) = ok(&["eval", "matching", "--method", "icp", "--pairs", &ds]);
    assert!(
        text.contains("(every pair is near (< 1.5 s apart))"),
        "{text}"
    );
    assert!(!text.contains("\nnear ("), "{text}");
    let (out, _) = ok(&[
        "eval", "matching", "--method", "icp", "--pairs", &ds, "--json",
    ]);
    let report = json(&out);
    assert_eq!(report["subsets"]["near"]["pairs"], report["pairs"]);
}
