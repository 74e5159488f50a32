//! ROS bags in (issue 18): bags the tests write themselves (ROS 1 and ROS 2 MCAP give
//! the same log and the same pairs; malformed bags are errors naming topic, message
//! and field), and the real bags of ../shared/data (the leigh-gtm1 bag gives the pairs
//! of its text export; the datmo bags give motion-capture truth that scan matching
//! agrees with). Real-data tests skip without the folder and fail under CI=true.

mod common;

use common::{content, drive_topics, refused, temp_dir, write};
use pgm_datasets::bag::container::check_ros1_bytes;
use pgm_datasets::bag::pairs::{bag_pairs, BagPairOptions};
use pgm_datasets::bag::synthetic::*;
use pgm_datasets::bag::{read_bag, BagLog, BagTopics};
use pgm_datasets::builders::{summarize_leigh_pairs, LabelRule, LeighPairOptions};
use pgm_datasets::mocap::{Footprint, MocapOptions};
use pgm_datasets::source::PairSource;
use pgm_datasets::testdata::shared_data_dir;
use pgm_datasets::ScanPair;
use pgm_scan::Pose2;
use std::path::{Path, PathBuf};

fn options(k: usize) -> BagPairOptions {
    BagPairOptions {
        k,
        laser_mount: Some(Pose2::new(MOUNT.0, MOUNT.1, MOUNT.2)),
        object_footprint: Some(Footprint {
            length: 2.0 * BOX_HALF.0,
            width: 2.0 * BOX_HALF.1,
            centre_x: 0.0,
            centre_y: 0.0,
        }),
        mocap: MocapOptions {
            label_margin: 0.02,
            ..MocapOptions::default()
        },
        name: Some("drive".into()),
        ..BagPairOptions::default()
    }
}

#[test]
fn ros1_and_ros2_bags_written_here_read_back_identically() {
    let dir = temp_dir("bags", "round-trip");
    let records = drive(12);
    let ros1 = write(&dir, "drive.bag", &ros1_bag(&records));
    let ros2 = write(&dir, "drive.mcap", &mcap_bag(&records, false, None));
    let a = read_bag(&ros1, &drive_topics()).unwrap();
    let b = read_bag(&ros2, &drive_topics()).unwrap();
    assert_eq!(content(&a), content(&b));
    // What was written is what is read: stamps to the nanosecond, float32 ranges through
    // their shortest decimal form, infinite ranges as no return.
    assert_eq!(a.scans.len(), 12);
    let Msg::Scan { stamp_ns, ranges } = &records.iter().find(|r| r.topic == "/scan").unwrap().msg
    else {
        unreachable!()
    };
    let first = &b.scans[0];
    let (sec, nsec) = (stamp_ns / 1_000_000_000, stamp_ns % 1_000_000_000);
    assert_eq!(first.stamp, sec as f64 + nsec as f64 * 1e-9);
    assert_eq!(first.frame, "laser");
    assert_eq!(first.number, 1);
    assert_eq!(first.scan.len(), BEAMS);
    for (k, r) in ranges.iter().enumerate() {
        if r.is_finite() && (*r as f64) < 30.0 {
            assert!(first.scan.valid[k]);
            assert_eq!(first.scan.ranges[k], r.to_string().parse::<f64>().unwrap());
        } else {
            assert!(!first.scan.valid[k], "beam {k}");
        }
    }
    assert_eq!(first.scan.angles[0], -1.5707964);
    assert_eq!(b.odometry[0].child_frame, "base_link");
    let (x, y, yaw) = robot_pose(0.5);
    let e = b
        .ego_poses
        .iter()
        .find(|p| (p.stamp - 100.5).abs() < 1e-9)
        .unwrap();
    assert!((e.pose.x() - x).abs() < 1e-12 && (e.pose.y() - y).abs() < 1e-12);
    assert!((e.pose.theta() - yaw).abs() < 1e-12);
    // The same pairs from both, for every kind of ground truth.
    for k in [1, 3] {
        let pa = bag_pairs(&a, &options(k)).unwrap().pairs;
        let pb = bag_pairs(&b, &options(k)).unwrap().pairs;
        assert_eq!(pa, pb);
        assert_eq!(pa.len(), 12 - k);
    }
    // Big-endian CDR and compressed chunks give the same log.
    for (name, big, compression) in [
        ("be.mcap", true, None),
        ("zstd.mcap", false, Some(mcap::Compression::Zstd)),
        ("lz4.mcap", false, Some(mcap::Compression::Lz4)),
    ] {
        let p = write(&dir, name, &mcap_bag(&records, big, compression));
        assert_eq!(
            content(&read_bag(&p, &drive_topics()).unwrap()),
            content(&a),
            "{name}"
        );
    }
    // ROS 1 chunks compressed with bz2 and lz4 (rosbag record --bz2, --lz4).
    let bz2 = |chunk: &[u8]| {
        let mut out = Vec::new();
        let mut e = bzip2::read::BzEncoder::new(chunk, bzip2::Compression::best());
        std::io::Read::read_to_end(&mut e, &mut out).unwrap();
        out
    };
    let lz4 = |chunk: &[u8]| {
        let mut e = lz4::EncoderBuilder::new().build(Vec::new()).unwrap();
        std::io::Write::write_all(&mut e, chunk).unwrap();
        let (out, result) = e.finish();
        result.unwrap();
        out
    };
    for (name, compression, compress) in [
        ("bz2.bag", "bz2", &bz2 as &dyn Fn(&[u8]) -> Vec<u8>),
        ("lz4.bag", "lz4", &lz4),
    ] {
        let bytes = ros1_bag_compressed(&records, compression, compress);
        assert!(bytes.len() < ros1_bag(&records).len(), "{name} compressed");
        let p = write(&dir, name, &bytes);
        assert_eq!(
            content(&read_bag(&p, &drive_topics()).unwrap()),
            content(&a),
            "{name}"
        );
    }
    // A ROS 2 bag directory (split into two files) and a zipped bag.
    let bagdir = dir.join("rosbag2_drive");
    std::fs::create_dir_all(&bagdir).unwrap();
    let half = records.len() / 2;
    write(
        &bagdir,
        "rosbag2_drive_0.mcap",
        &mcap_bag(&records[..half], false, None),
    );
    write(
        &bagdir,
        "rosbag2_drive_1.mcap",
        &mcap_bag(&records[half..], false, None),
    );
    write(
        &bagdir,
        "metadata.yaml",
        b"rosbag2_bagfile_information: {}\n",
    );
    assert_eq!(
        content(&read_bag(&bagdir, &drive_topics()).unwrap()),
        content(&a)
    );
    let zipped = dir.join("drive.bag.zip");
    {
        let mut z = zip::ZipWriter::new(std::fs::File::create(&zipped).unwrap());
        z.start_file("drive.bag", zip::write::SimpleFileOptions::default())
            .unwrap();
        std::io::Write::write_all(&mut z, &ros1_bag(&records)).unwrap();
        z.finish().unwrap();
    }
    assert_eq!(
        content(&read_bag(&zipped, &drive_topics()).unwrap()),
        content(&a)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The synthetic drive of `scans` scans written to `drive.mcap` in `dir`: its path and
/// the log read back.
fn drive_mcap(dir: &Path, scans: usize) -> (PathBuf, BagLog) {
    let path = write(dir, "drive.mcap", &mcap_bag(&drive(scans), false, None));
    let log = read_bag(&path, &drive_topics()).unwrap();
    (path, log)
}

#[test]
fn motion_capture_truth_of_the_written_drive() {
    let dir = temp_dir("bags", "truth");
    let (path, log) = drive_mcap(&dir, 10);
    let pairs = bag_pairs(&log, &options(2)).unwrap().pairs;
    let mut box_returns = 0;
    for p in &pairs {
        assert_eq!(p.validate(), Ok(()));
        let truth = p.truth.as_ref().unwrap();
        let (t_i, t_j) = (p.reference.timestamp - 100.0, p.current.timestamp - 100.0);
        // Ego-motion: inverse(L_i) ∘ L_j from the true robot poses and the mount.
        let laser = |t: f64| {
            let (x, y, yaw) = robot_pose(t);
            Pose2::new(x, y, yaw).compose(&Pose2::new(MOUNT.0, MOUNT.1, MOUNT.2))
        };
        let ego = laser(t_i).between(&laser(t_j));
        let got = truth.ego_motion.unwrap();
        assert!(got.translation_error(&ego) < 1e-6 && got.rotation_error(&ego) < 1e-6);
        // Box returns carried by the box's motion land on the box at the reference time;
        // background returns carried by the ego-motion land where they were seen.
        let labels = truth.labels.as_ref().unwrap();
        let box_motion = truth.motions.iter().find(|m| m.label == 1).unwrap().motion;
        let (bx, by, byaw) = box_pose(t_i);
        let box_i = Pose2::new(bx, by, byaw);
        for (k, l) in labels.iter().enumerate() {
            let Some(l) = l else { continue };
            let q = p.current.beam_point(k);
            if *l == 1 {
                box_returns += 1;
                let world = laser(t_i).transform_point(&box_motion.transform_point(&q));
                let local = box_i.inverse().transform_point(&world);
                assert!(
                    local.x.abs() <= BOX_HALF.0 + 1e-3 && local.y.abs() <= BOX_HALF.1 + 1e-3,
                    "{}: beam {k} lands at {local:?} in the box frame",
                    p.name
                );
            }
        }
        // The odometry (drifting) gives the prior, not the truth.
        assert!(p.odometry.is_some());
    }
    assert!(box_returns > 20, "{box_returns} box returns");
    // A standing object is background: with an object speed threshold above the box's
    // 1 m/s, nothing is labelled moving.
    let mut standing = options(2);
    standing.mocap.object_min_speed = 2.0;
    let pairs = bag_pairs(&log, &standing).unwrap().pairs;
    assert!(pairs.iter().all(|p| p
        .truth
        .as_ref()
        .unwrap()
        .labels
        .as_ref()
        .unwrap()
        .iter()
        .all(|l| *l != Some(1))));
    // Without an object topic: the ego-motion only, no labels.
    let ego_only = read_bag(
        &path,
        &BagTopics {
            ego_pose: Some("/ego_pose".into()),
            ..BagTopics::new("/scan")
        },
    )
    .unwrap();
    let pairs = bag_pairs(&ego_only, &options(1)).unwrap().pairs;
    assert!(pairs.iter().all(|p| {
        let t = p.truth.as_ref().unwrap();
        t.ego_motion.is_some() && t.labels.is_none()
    }));
    // Without a mount: the identity, said in a note.
    let built = bag_pairs(
        &log,
        &BagPairOptions {
            laser_mount: None,
            ..options(1)
        },
    )
    .unwrap();
    assert!(built
        .notes
        .iter()
        .any(|n| n.contains("origin of the robot frame")));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Reads every `step`-th truncation of `bytes`, written to `name` in `dir`: each must
/// be an error or have the content of `full`. Returns the number of errors.
fn truncation_errors(dir: &Path, name: &str, bytes: &[u8], step: usize, full: &BagLog) -> usize {
    let mut errors = 0;
    for cut in (0..bytes.len()).step_by(step) {
        let p = write(dir, name, &bytes[..cut]);
        match read_bag(&p, &drive_topics()) {
            Err(_) => errors += 1,
            Ok(log) => assert_eq!(content(&log), content(full), "cut at {cut}"),
        }
    }
    errors
}

#[test]
fn malformed_bags_are_errors_naming_topic_message_and_field() {
    let dir = temp_dir("bags", "malformed");
    let records = drive(3);
    let good = ros1_bag(&records);
    // Not a bag, an old format, a missing topic (the error lists the bag's topics).
    let p = write(&dir, "text.bag", b"hello");
    refused(&p, &drive_topics(), &["text.bag", "neither a ROS 1 bag"]);
    let p = write(&dir, "old.bag", b"#ROSBAG V1.2\n0000000000000000");
    refused(&p, &drive_topics(), &["not supported"]);
    let p = write(&dir, "good.bag", &good);
    refused(
        &p,
        &BagTopics::new("/nope"),
        &["topic /nope", "/scan (sensor_msgs/LaserScan, 3)"],
    );
    // A topic read as the wrong type names the field it lacks.
    refused(
        &p,
        &BagTopics::new("/odom"),
        &[
            "topic /odom",
            "message 1",
            "field `angle_min`",
            "nav_msgs/Odometry",
        ],
    );
    // Every truncation of the file is an error or, when only the index section after
    // the chunks is cut, the whole content; never a panic.
    let full = read_bag(&p, &drive_topics()).unwrap();
    let errors = truncation_errors(&dir, "cut.bag", &good, 97, &full);
    assert!(errors * 10 > good.len() / 97 * 9, "{errors} errors");
    // index_pos beyond the file, a chunk declaring a huge size.
    let mut bad = good.clone();
    let at = bad.windows(10).position(|w| w == b"index_pos=").unwrap() + 10;
    bad[at..at + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let p = write(&dir, "index.bag", &bad);
    refused(&p, &drive_topics(), &["index_pos", "outside the file"]);
    assert!(check_ros1_bytes(&bad).is_err());
    let mut bad = good.clone();
    let at = bad.windows(5).position(|w| w == b"size=").unwrap() + 5;
    bad[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let p = write(&dir, "size.bag", &bad);
    refused(
        &p,
        &drive_topics(),
        &["declares 4294967295 uncompressed bytes"],
    );
    // A scan whose ranges array claims more elements than the message holds.
    let mut scan_records: Vec<Record> = records.clone();
    for r in &mut scan_records {
        if let Msg::Scan { ranges, .. } = &mut r.msg {
            ranges.truncate(0);
        }
    }
    let mut bytes = ros1_bag(&scan_records);
    // The empty ranges array: patch its length (the u32 before the empty intensities).
    let scan_data = serialise(
        &scan_records
            .iter()
            .find(|r| r.topic == "/scan")
            .unwrap()
            .msg,
        1,
        Wire::Ros1,
    );
    let at = bytes
        .windows(scan_data.len())
        .position(|w| w == scan_data.as_slice())
        .unwrap();
    let len_at = at + scan_data.len() - 8;
    bytes[len_at..len_at + 4].copy_from_slice(&1_000_000u32.to_le_bytes());
    let p = write(&dir, "ranges.bag", &bytes);
    refused(
        &p,
        &drive_topics(),
        &[
            "topic /scan",
            "message 1",
            "field `ranges`",
            "length 1000000",
        ],
    );
    // An empty scan is refused by the scan reader.
    let mcap = write(&dir, "empty.mcap", &mcap_bag(&scan_records, false, None));
    refused(
        &mcap,
        &drive_topics(),
        &[
            "topic /scan",
            "message 1",
            "field `ranges`",
            "at least one beam",
        ],
    );
    // Every truncation of an MCAP file too (a cut in the summary after the data
    // section leaves the messages whole).
    let good_mcap = mcap_bag(&records, false, None);
    let errors = truncation_errors(&dir, "cut.mcap", &good_mcap, 101, &full);
    assert!(errors * 10 > good_mcap.len() / 101 * 8, "{errors} errors");
    // A schema whose name claims 4 GB (found by fuzzing: the mcap crate's record parser
    // reserved it): an error naming the record and field, nothing that large allocated.
    let mut bytes = mcap_bag(&records, false, None);
    let name = b"sensor_msgs/msg/LaserScan";
    let at = bytes.windows(name.len()).position(|w| w == name).unwrap();
    bytes[at - 4..at].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
    // The CRCs rewritten, so the record parser is what refuses it.
    reseal_mcap(&mut bytes);
    let p = write(&dir, "schema.mcap", &bytes);
    refused(
        &p,
        &drive_topics(),
        &[
            "schema.mcap",
            "schema record",
            "field name needs 4294967280 bytes",
        ],
    );
    // A definition that names a type it does not define.
    let mut bytes = good.clone();
    let needle = b"MSG: geometry_msgs/Point";
    while let Some(at) = bytes.windows(needle.len()).position(|w| w == needle) {
        bytes[at..at + needle.len()].copy_from_slice(b"MSG: geometry_msgs/Pxint");
    }
    let p = write(&dir, "definition.bag", &bytes);
    refused(
        &p,
        &drive_topics(),
        &[
            "topic /ego_pose",
            "message 1",
            "has type Point",
            "does not define",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bag_pair_options_are_checked() {
    let dir = temp_dir("bags", "options");
    let (_, log) = drive_mcap(&dir, 4);
    for k in [0, 4, 99] {
        let e = bag_pairs(&log, &options(k)).unwrap_err().to_string();
        assert!(e.contains(&format!("k = {k}")), "{e}");
    }
    let e = bag_pairs(
        &log,
        &BagPairOptions {
            object_footprint: None,
            ..options(1)
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("footprint"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

// ---------------------------------------------------------------------------------
// Real bags

fn leigh_topics() -> BagTopics {
    BagTopics {
        odometry: Some("/odom".into()),
        people: Some("/ground_truth_people_tracks".into()),
        ..BagTopics::new("/scan")
    }
}

#[test]
fn leigh_bag_gives_the_pairs_of_its_text_export() {
    let Some(data) = shared_data_dir() else {
        return;
    };
    let d = data.join("leigh-gtm1");
    let log = read_bag(
        &d.join("general_tracking_moving_1.bag.zip"),
        &leigh_topics(),
    )
    .unwrap();
    assert_eq!(log.scans.len(), 873);
    assert_eq!(log.people.len(), 153);
    let expected = [(1, 106, 33, 34), (3, 97, 30, 48), (5, 92, 26, 46)];
    for (k, pairs_expected, track_movers, displacement_movers) in expected {
        for rule in [LabelRule::Track, LabelRule::Displacement] {
            let leigh = LeighPairOptions {
                k,
                rule,
                ..Default::default()
            };
            let text = PairSource::Leigh {
                scans: d.join("scans.txt"),
                people: d.join("people_gt.txt"),
                odometry: Some(d.join("odom_at_scan.txt")),
                options: leigh.clone(),
                clock: Default::default(),
            }
            .load()
            .unwrap()
            .pairs;
            let bag = bag_pairs(
                &log,
                &BagPairOptions {
                    k,
                    leigh,
                    name: Some("leigh-gtm1".into()),
                    ..Default::default()
                },
            )
            .unwrap()
            .pairs;
            assert_eq!(text.len(), pairs_expected);
            let movers = summarize_leigh_pairs(k, &text).pairs_with_moving_person;
            match rule {
                LabelRule::Track => assert_eq!(movers, track_movers),
                LabelRule::Displacement => assert_eq!(movers, displacement_movers),
            }
            assert_same_pairs(&text, &bag);
        }
    }
}

/// Identical up to the text export's printed precision: names, beam validity, ranges
/// and labels exactly; angles, stamps (µs), odometry (6 decimals) and person motions
/// (centres to 0.1 mm) within what that rounding allows.
fn assert_same_pairs(text: &[ScanPair], bag: &[ScanPair]) {
    assert_eq!(text.len(), bag.len());
    for (a, b) in text.iter().zip(bag) {
        assert_eq!(a.name, b.name);
        for (s, t) in [(&a.reference, &b.reference), (&a.current, &b.current)] {
            assert_eq!(s.valid, t.valid, "{}", a.name);
            assert_eq!(s.ranges, t.ranges, "{}", a.name);
            assert_eq!(s.max_range, t.max_range);
            assert!((s.timestamp - t.timestamp).abs() < 1e-6, "{}", a.name);
            assert!(s
                .angles
                .iter()
                .zip(&t.angles)
                .all(|(x, y)| (x - y).abs() < 1e-6));
            let (o, p) = (s.odometry.unwrap(), t.odometry.unwrap());
            assert!(
                o.translation_error(&p) < 2e-6 && o.rotation_error(&p) < 2e-6,
                "{}",
                a.name
            );
            assert_eq!(s.laser_offset, t.laser_offset);
        }
        let (ta, tb) = (a.truth.as_ref().unwrap(), b.truth.as_ref().unwrap());
        assert_eq!(ta.labels, tb.labels, "{}", a.name);
        assert_eq!(ta.reference_labels, tb.reference_labels, "{}", a.name);
        assert_eq!(ta.motions.len(), tb.motions.len(), "{}", a.name);
        for (m, n) in ta.motions.iter().zip(&tb.motions) {
            assert_eq!((m.label, &m.kind), (n.label, &n.kind));
            assert!(m.motion.translation_error(&n.motion) < 5e-4, "{}", a.name);
        }
        let (o, p) = (a.odometry.unwrap(), b.odometry.unwrap());
        assert!(
            o.translation_error(&p) < 1e-5 && o.rotation_error(&p) < 5e-6,
            "{}",
            a.name
        );
    }
}

fn datmo_options(k: usize) -> BagPairOptions {
    BagPairOptions {
        k,
        laser_mount: Some(Pose2::new(-0.164, 0.027, 0.005)),
        object_footprint: Some(Footprint {
            length: 0.430,
            width: 0.187,
            centre_x: 0.057,
            centre_y: 0.028,
        }),
        mocap: MocapOptions {
            pose_delay: 0.025,
            ..MocapOptions::default()
        },
        ..BagPairOptions::default()
    }
}

#[test]
fn datmo_bags_give_motion_capture_truth_that_scan_matching_agrees_with() {
    let Some(data) = shared_data_dir() else {
        return;
    };
    let topics = BagTopics {
        ego_pose: Some("/ego_pose".into()),
        object_pose: Some("/red_pose".into()),
        ..BagTopics::new("/scan")
    };
    let matcher = pgm_scan::registration::IcpParams::default();
    let matcher = pgm_scan::ParamGuard::check(matcher).unwrap();
    for (bag, scans, pairs_k3, mover_pairs_at_least) in
        [("intersection", 85, 81, 30), ("overtake_ego", 135, 132, 70)]
    {
        let log = read_bag(&data.join(format!("datmo/{bag}.bag")), &topics).unwrap();
        assert_eq!(log.scans.len(), scans);
        assert_eq!(log.scans[0].scan.len(), 360);
        let built = bag_pairs(&log, &datmo_options(3)).unwrap();
        assert_eq!(built.pairs.len(), pairs_k3, "{bag}");
        let movers = built
            .pairs
            .iter()
            .filter(|p| {
                p.truth
                    .as_ref()
                    .unwrap()
                    .labels
                    .as_ref()
                    .unwrap()
                    .contains(&Some(1))
            })
            .count();
        assert!(
            movers >= mover_pairs_at_least,
            "{bag}: {movers} pairs with the car moving"
        );
        eprintln!("{bag}: {movers} of {pairs_k3} pairs at k = 3 with the car moving");
        // Consecutive scans: ICP from the identity agrees with the motion-capture
        // ego-motion to about a centimetre (the data README: 7 mm, 3.5 mrad median).
        let consecutive = bag_pairs(&log, &datmo_options(1)).unwrap().pairs;
        let mut t = Vec::new();
        let mut r = Vec::new();
        for p in &consecutive {
            let e = matcher.align_pair(p).unwrap().motion;
            let truth = p.truth.as_ref().unwrap().ego_motion.unwrap();
            t.push(e.translation_error(&truth));
            r.push(e.rotation_error(&truth));
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let (mt, mr) = (median(&mut t), median(&mut r));
        assert!(
            mt < 0.015 && mr < 0.006,
            "{bag}: ICP vs truth {mt} m, {mr} rad"
        );
    }
}
