//! Issue 18 from the command line: every command that reads a log reads a bag
//! (`pgm data pairs`, `pgm data summary`, `pgm eval clustering`, `pgm eval matching`,
//! `pgm cluster`), a malformed bag exits 2 naming topic, message and field, and
//! `pgm eval clustering --json` carries the detection metrics. Bags are written here;
//! the leigh-gtm1 bag of ../shared/data is checked against its text export.

use pgm_datasets::bag::synthetic::{drive, mcap_bag, ros1_bag};
use pgm_datasets::testdata::shared_data_dir;
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

fn ok(args: &[&str]) -> (String, String) {
    let (out, err, code) = pgm(args);
    assert_eq!(code, Some(0), "{args:?}\n{err}");
    (out, err)
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pgm-cli-bags-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p.to_str().unwrap().to_string()
}

const TRUTH: [&str; 10] = [
    "--scan-topic",
    "/scan",
    "--odom-topic",
    "/odom",
    "--ego-pose-topic",
    "/ego_pose",
    "--object-pose-topic",
    "/box_pose",
    "--laser-mount",
    "0.2,0,0",
];
const FOOTPRINT: [&str; 4] = [
    "--object-footprint",
    "0.6,0.4,0,0",
    "--label-margin",
    "0.02",
];

#[test]
fn bags_in_every_command() {
    let dir = temp_dir("commands");
    let records = drive(12);
    let ros1 = write(&dir, "drive.bag", &ros1_bag(&records));
    let ros2 = write(&dir, "drive.mcap", &mcap_bag(&records, false, None));
    // pgm data pairs: the same data set from both containers.
    let mut outs = Vec::new();
    for (bag, out) in [(&ros1, "ros1"), (&ros2, "ros2")] {
        let out = dir.join(out).to_str().unwrap().to_string();
        let mut args = vec!["data", "pairs", "--bag", bag.as_str()];
        args.extend(TRUTH);
        args.extend(FOOTPRINT);
        args.extend(["--k", "2", "--out", out.as_str()]);
        let (stdout, stderr) = ok(&args);
        assert!(stderr.contains("wrote 10 pairs of bag"), "{stderr}");
        assert!(
            stdout.is_empty(),
            "a data set is written, not printed: {stdout}"
        );
        outs.push(out);
    }
    let a = pgm_datasets::read_pairs(&outs[0]).unwrap();
    let b = pgm_datasets::read_pairs(&outs[1]).unwrap();
    assert_eq!(a, b);
    assert!(a
        .iter()
        .all(|p| p.truth.as_ref().unwrap().ego_motion.is_some()));
    // pgm eval matching on the bag: the ego-motion truth from the poses.
    let mut args = vec![
        "eval",
        "matching",
        "--method",
        "icp",
        "--bag",
        ros2.as_str(),
    ];
    args.extend(TRUTH);
    args.extend(FOOTPRINT);
    args.extend(["--k", "1", "--json"]);
    let (stdout, _) = ok(&args);
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["pairs"], 11);
    assert!(v["data"].as_str().unwrap().contains("drive.mcap"));
    assert!(v["translation_median"].as_f64().unwrap() < 0.05, "{v}");
    // pgm eval clustering --json: the detection fields, with the data named.
    let mut args = vec![
        "eval",
        "clustering",
        "--method",
        "one-cluster",
        "--bag",
        ros1.as_str(),
    ];
    args.extend(TRUTH);
    args.extend(FOOTPRINT);
    args.extend(["--k", "2", "--json"]);
    let (stdout, _) = ok(&args);
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    for field in [
        "v_measure_mean",
        "v_measure_mover_pairs",
        "object_recall",
        "false_alarms_per_pair",
        "false_alarm_pair_share",
        "moving_precision",
        "moving_recall",
        "object_translation_error_median",
        "object_rotation_error_median",
        "objects_found",
        "centroid_error_median",
    ] {
        assert!(v.get(field).is_some(), "{field} missing in {v}");
    }
    // One cluster reports nothing moving: no false alarm, no object found.
    assert_eq!(v["false_alarms_per_pair"], 0.0);
    assert_eq!(v["object_recall"], 0.0);
    assert!(v["moving_precision"].is_null());
    assert!(v["data"].as_str().unwrap().contains("drive.bag"));
    // pgm cluster on two scans of the bag.
    let (stdout, _) = ok(&[
        "cluster",
        "--bag",
        &ros2,
        "--scan-topic",
        "/scan",
        "--odom-topic",
        "/odom",
        "--reference",
        "2",
        "--current",
        "5",
    ]);
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["pair"], "drive:2-5");
    assert_eq!(v["labels"].as_array().unwrap().len(), 181);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn malformed_bags_and_options_exit_2() {
    let dir = temp_dir("malformed");
    let records = drive(4);
    let mut bytes = mcap_bag(&records, false, None);
    let good = write(&dir, "drive.mcap", &bytes);
    let refused = |args: &[&str], needles: &[&str]| {
        let (out, err, code) = pgm(args);
        assert_eq!(code, Some(2), "{args:?}\n{err}");
        assert!(out.is_empty(), "{out}");
        assert!(!err.contains("panicked"), "{err}");
        for n in needles {
            assert!(err.contains(n), "{args:?}: {n:?} not in\n{err}");
        }
    };
    refused(
        &[
            "data",
            "pairs",
            "--bag",
            &good,
            "--scan-topic",
            "/laser",
            "--out",
            "x",
        ],
        &[
            "drive.mcap",
            "topic /laser",
            "no such topic",
            "/scan (sensor_msgs/msg/LaserScan",
        ],
    );
    refused(
        &["data", "pairs", "--bag", &good, "--out", "x"],
        &["--bag needs --scan-topic"],
    );
    refused(
        &[
            "data",
            "pairs",
            "--bag",
            &good,
            "--scan-topic",
            "/scan",
            "--ego-pose-topic",
            "/ego_pose",
            "--object-pose-topic",
            "/box_pose",
            "--k",
            "1",
            "--out",
            "x",
        ],
        &["footprint"],
    );
    refused(
        &[
            "data",
            "pairs",
            "--bag",
            &good,
            "--scan-topic",
            "/scan",
            "--laser-mount",
            "1,2",
            "--out",
            "x",
        ],
        &["X,Y,YAW"],
    );
    // A scan message cut short inside its ranges.
    let scan = records.iter().find(|r| r.topic == "/scan").unwrap();
    let data = pgm_datasets::bag::synthetic::serialise(
        &scan.msg,
        1,
        pgm_datasets::bag::synthetic::Wire::Cdr { big_endian: false },
    );
    let at = bytes
        .windows(data.len())
        .position(|w| w == data.as_slice())
        .unwrap();
    // The ranges' length (after the header, 7 floats): claim a million.
    let len_at = at + data.len() - 4 * 181 - 8;
    bytes[len_at..len_at + 4].copy_from_slice(&1_000_000u32.to_le_bytes());
    let bad = write(&dir, "bad.mcap", &bytes);
    refused(
        &[
            "eval",
            "clustering",
            "--method",
            "cbd",
            "--bag",
            &bad,
            "--scan-topic",
            "/scan",
        ],
        &["bad.mcap", "topic /scan", "message 1", "field `ranges`"],
    );
    let junk = write(&dir, "junk.bag", b"#ROSBAG V2.0\n\x05\x00\x00\x00");
    refused(
        &[
            "cluster",
            "--bag",
            &junk,
            "--scan-topic",
            "/scan",
            "--reference",
            "0",
            "--current",
            "1",
        ],
        &["junk.bag", "ROS 1 bag"],
    );
    refused(
        &[
            "cluster",
            "--bag",
            &good,
            "--scan-topic",
            "/scan",
            "--reference",
            "0",
            "--current",
            "9",
        ],
        &["scan 9", "no such scan"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn leigh_bag_and_text_export_give_the_same_data_set() {
    let Some(data) = shared_data_dir() else {
        return;
    };
    let d = data.join("leigh-gtm1");
    let s = |p: &str| d.join(p).to_str().unwrap().to_string();
    let (bag, scans, people, odom) = (
        s("general_tracking_moving_1.bag.zip"),
        s("scans.txt"),
        s("people_gt.txt"),
        s("odom_at_scan.txt"),
    );
    let bag_args = [
        "--bag",
        bag.as_str(),
        "--scan-topic",
        "/scan",
        "--odom-topic",
        "/odom",
        "--people-topic",
        "/ground_truth_people_tracks",
    ];
    let text_args = [
        "--scans",
        scans.as_str(),
        "--people",
        people.as_str(),
        "--odometry",
        odom.as_str(),
    ];
    // Both rules, same summary.
    let summary = |source: &[&str]| {
        let mut args = vec!["data", "summary", "--json"];
        args.extend(source);
        ok(&args).0
    };
    let a = summary(&bag_args);
    assert_eq!(a, summary(&text_args));
    let rows: serde_json::Value = serde_json::from_str(&a).unwrap();
    let movers: Vec<(String, u64)> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["rule"].as_str().unwrap().to_string(),
                r["pairs_with_moving_person"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        movers,
        [
            ("track", 33),
            ("track", 30),
            ("track", 26),
            ("displacement", 34),
            ("displacement", 48),
            ("displacement", 46)
        ]
        .map(|(r, n)| (r.to_string(), n))
    );
    // The same evaluation figures from both.
    let eval = |source: &[&str]| {
        let mut args = vec![
            "eval",
            "clustering",
            "--method",
            "cbd",
            "--k",
            "3",
            "--json",
        ];
        args.extend(source);
        let v: serde_json::Value = serde_json::from_str(&ok(&args).0).unwrap();
        (
            v["v_measure_mean"].as_f64().unwrap(),
            v["object_recall"].as_f64(),
            v["false_alarms_per_pair"].as_f64().unwrap(),
        )
    };
    let (x, y) = (eval(&bag_args), eval(&text_args));
    assert!(
        (x.0 - y.0).abs() < 1e-9 && x.1 == y.1 && (x.2 - y.2).abs() < 1e-9,
        "{x:?} {y:?}"
    );
}
