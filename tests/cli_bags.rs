//! ROS bags from the command line (issue 18): every command that reads a log reads a
//! bag (`pgm data pairs`, `pgm data summary`, `pgm eval clustering`, `pgm eval
//! matching`, `pgm cluster`), a malformed bag or a damaged record exits 2 naming
//! topic, message and field, and `pgm eval clustering --json` carries the detection
//! metrics. Bags are written here; the leigh-gtm1 bag of ../shared/data is checked
//! against its text export.

mod common;

use common::*;
use pgm_datasets::bag::synthetic::{drive, mcap_bag, reseal_mcap, ros1_bag, serialise, Wire};
use pgm_datasets::testdata::shared_data_dir;

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
    let ros1 = write_bytes(&dir, "drive.bag", &ros1_bag(&records));
    let ros2 = write_bytes(&dir, "drive.mcap", &mcap_bag(&records, false, None));
    // The command, then the bag with its topics, the footprint, and `rest`.
    let with_truth = |command: &[&'static str], bag: &str, rest: &[&str]| -> Vec<String> {
        [command, &["--bag", bag], &TRUTH, &FOOTPRINT, rest]
            .concat()
            .into_iter()
            .map(String::from)
            .collect()
    };
    let run = |args: Vec<String>| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        ok(&args)
    };
    // pgm data pairs: the same data set from both containers.
    let mut outs = Vec::new();
    for (bag, out) in [(&ros1, "ros1"), (&ros2, "ros2")] {
        let out = path(&dir, out);
        let (stdout, stderr) = run(with_truth(
            &["data", "pairs"],
            bag,
            &["--k", "2", "--out", &out],
        ));
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
    let (stdout, _) = run(with_truth(
        &["eval", "matching", "--method", "icp"],
        &ros2,
        &["--k", "1", "--json"],
    ));
    let v = json(&stdout);
    assert_eq!(v["pairs"], 11);
    assert!(v["data"].as_str().unwrap().contains("drive.mcap"));
    assert!(v["translation_median"].as_f64().unwrap() < 0.05, "{v}");
    // pgm eval clustering --json: the detection fields, with the data named.
    let (stdout, _) = run(with_truth(
        &["eval", "clustering", "--method", "one-cluster"],
        &ros1,
        &["--k", "2", "--json"],
    ));
    let v = json(&stdout);
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
    let cluster = one_pair("cluster", "--bag", &ros2, "2", "5");
    let v = ok_json(
        &[
            &cluster[..],
            &["--scan-topic", "/scan", "--odom-topic", "/odom"],
        ]
        .concat(),
    );
    assert_eq!(v["pair"], "drive:2-5");
    assert_eq!(v["labels"].as_array().unwrap().len(), 181);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `pgm cluster` on scans 0 and `current` of `bag`, its scans on /scan.
fn cluster_bag<'a>(bag: &'a str, current: &'a str) -> Vec<&'a str> {
    [
        &one_pair("cluster", "--bag", bag, "0", current)[..],
        &["--scan-topic", "/scan"],
    ]
    .concat()
}

#[test]
fn malformed_bags_and_options_exit_2() {
    let dir = temp_dir("malformed");
    let records = drive(4);
    let mut bytes = mcap_bag(&records, false, None);
    let good = write_bytes(&dir, "drive.mcap", &bytes);
    // A scan message cut short inside its ranges.
    let scan = records.iter().find(|r| r.topic == "/scan").unwrap();
    let data = serialise(&scan.msg, 1, Wire::Cdr { big_endian: false });
    let at = bytes
        .windows(data.len())
        .position(|w| w == data.as_slice())
        .unwrap();
    // The ranges' length (after the header, 7 floats): claim a million.
    let len_at = at + data.len() - 4 * 181 - 8;
    bytes[len_at..len_at + 4].copy_from_slice(&1_000_000u32.to_le_bytes());
    // The CRCs rewritten to match, so the message decoder is what refuses it (a
    // damaged chunk is tests/cli_cases.rs).
    reseal_mcap(&mut bytes);
    let bad = write_bytes(&dir, "bad.mcap", &bytes);
    let junk = write_bytes(&dir, "junk.bag", b"#ROSBAG V2.0\n\x05\x00\x00\x00");
    let pairs = |options: &[&'static str]| {
        [
            &["data", "pairs", "--bag", &good][..],
            options,
            &["--out", "x"],
        ]
        .concat()
    };
    refused_all(&[
        (
            pairs(&["--scan-topic", "/laser"]),
            vec![
                "drive.mcap",
                "topic /laser",
                "no such topic",
                "/scan (sensor_msgs/msg/LaserScan",
            ],
        ),
        (pairs(&[]), vec!["--bag needs --scan-topic"]),
        (
            pairs(&[
                "--scan-topic",
                "/scan",
                "--ego-pose-topic",
                "/ego_pose",
                "--object-pose-topic",
                "/box_pose",
                "--k",
                "1",
            ]),
            vec!["footprint"],
        ),
        (
            pairs(&["--scan-topic", "/scan", "--laser-mount", "1,2"]),
            vec!["X,Y,YAW"],
        ),
        (
            eval(
                "clustering",
                "cbd",
                &["--bag", &bad, "--scan-topic", "/scan"],
            ),
            vec!["bad.mcap", "topic /scan", "message 1", "field `ranges`"],
        ),
        (cluster_bag(&junk, "1"), vec!["junk.bag", "ROS 1 bag"]),
        (cluster_bag(&good, "9"), vec!["scan 9", "no such scan"]),
    ]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Item 9 of the polish: a damaged record inside a ROS 1 chunk names the topic and
/// message it is (its header still names its connection) or follows (it does not),
/// and where it lies.
#[test]
fn damaged_bag_records_name_the_topic_and_message() {
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
    // `good` with the 4-byte length at `offset` claiming 2^31 - 1 bytes, as `name`.
    let garbled = |name: &str, offset: usize| {
        let mut bytes = good.clone();
        bytes[offset..offset + 4].copy_from_slice(&0x7fff_ffffu32.to_le_bytes());
        write_bytes(&dir, name, &bytes)
    };
    // The data length of the second scan message runs past the chunk: its header
    // still names the scan topic.
    let length = garbled("length.bag", at - 4);
    // The header length of the same record is garbled: the error names the message
    // before it.
    let header_len_at = at - 4 - 38 - 4;
    assert_eq!(
        &good[header_len_at..header_len_at + 4],
        &38u32.to_le_bytes()
    );
    let header = garbled("header.bag", header_len_at);
    let errors = refused_all(&[
        (
            cluster_bag(&length, "1"),
            vec![
                "topic /scan, message 2",
                "this message's record",
                "of the chunk at byte",
                "out of bounds",
            ],
        ),
        (
            cluster_bag(&header, "1"),
            vec![
                "topic /",
                ", message ",
                "the record after this message",
                "at byte",
            ],
        ),
    ]);
    assert!(!errors[1].contains("rosbag::Error"), "{}", errors[1]);
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
    let bag_args = [&["--bag", bag.as_str()][..], &LEIGH_BAG_TOPICS].concat();
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
    let rows = json(&a);
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
        let v = ok_json(&args);
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

/// The drive with the header stamps of scans 8 (a repeat of scan 7's) and 14 (0.5 s
/// back) broken, record times untouched.
fn drive_with_broken_stamps(n: usize) -> Vec<pgm_datasets::bag::synthetic::Record> {
    use pgm_datasets::bag::synthetic::Msg;
    let mut records = drive(n);
    let (mut previous, mut k) = (0, 0);
    for r in records.iter_mut().filter(|r| r.topic == "/scan") {
        if let Msg::Scan { stamp_ns, .. } = &mut r.msg {
            let original = *stamp_ns;
            match k {
                8 => *stamp_ns = previous,
                14 => *stamp_ns -= 500_000_000,
                _ => {}
            }
            previous = original;
        }
        k += 1;
    }
    records
}

#[test]
fn header_stamps_at_fault_are_noted_and_the_track_stays_one_sequence() {
    let dir = temp_dir("stamps");
    let bag = write_bytes(&dir, "broken.bag", &ros1_bag(&drive_with_broken_stamps(20)));
    let base = [
        "track",
        "--method",
        "cbd",
        "--bag",
        &bag,
        "--scan-topic",
        "/scan",
        "--odom-topic",
        "/odom",
    ];
    let (stdout, stderr) = ok(&base);
    assert!(
        stderr.contains("/scan message 9") && stderr.contains("record times"),
        "{stderr}"
    );
    let v = json(&stdout);
    let scans = v["scans"].as_array().unwrap();
    assert_eq!(scans.len(), 20);
    assert!(
        scans.iter().all(|s| s["sequence"] == 0),
        "a stamp at fault must not break the sequence: {stdout}"
    );
    let times: Vec<f64> = scans.iter().map(|s| s["time"].as_f64().unwrap()).collect();
    assert!(times.windows(2).all(|w| w[1] > w[0]), "{times:?}");
    // `--stamps header` refuses the bag naming the message; nonsense is refused too.
    refused(
        &[&base[..], &["--stamps", "header"]].concat(),
        &["/scan", "message 9", "header.stamp", "repeats"],
    );
    refused(
        &[&base[..], &["--stamps", "sensor"]].concat(),
        &["\"sensor\"", "auto, header, record"],
    );
    // `--stamps record`: the same scans as the default on this bag.
    let (record, _) = ok(&[&base[..], &["--stamps", "record"]].concat());
    assert_eq!(json(&record)["scans"], v["scans"]);
}
