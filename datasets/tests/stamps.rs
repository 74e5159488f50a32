//! Header stamps that are zero, repeat or go backwards while the record times increase
//! (issue 30): every reader with two clocks (ROS bags, leigh-gtm1 text exports, CARMEN
//! logs) follows the rule of `pgm_datasets::stamps`: by default the record times for
//! every stream, with a note; `header` refuses the log naming the message; `record`
//! always uses record times. A duplicate `VERTEX2` id is refused naming both lines.

use pgm_datasets::bag::pairs::{bag_pairs, BagPairOptions};
use pgm_datasets::bag::synthetic::{drive, mcap_bag, ros1_bag, Msg, Record};
use pgm_datasets::bag::{read_bag, BagTopics};
use pgm_datasets::carmen::{parse_carmen, CarmenOptions};
use pgm_datasets::leigh::parse_scans_with;
use pgm_datasets::stamps::StampClock;
use std::path::{Path, PathBuf};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pgm-stamps-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn topics(clock: StampClock) -> BagTopics {
    BagTopics {
        odometry: Some("/odom".into()),
        ego_pose: Some("/ego_pose".into()),
        clock,
        ..BagTopics::new("/scan")
    }
}

/// The drive with the header stamps of scans 10 (a repeat of scan 9's), 20 (zero) and
/// 25 (0.5 s back) broken; record times untouched.
fn broken_drive() -> Vec<Record> {
    let mut records = drive(30);
    let mut previous = 0;
    for (k, r) in records
        .iter_mut()
        .filter(|r| r.topic == "/scan")
        .enumerate()
    {
        if let Msg::Scan { stamp_ns, .. } = &mut r.msg {
            let original = *stamp_ns;
            match k {
                10 => *stamp_ns = previous,
                20 => *stamp_ns = 0,
                25 => *stamp_ns -= 500_000_000,
                _ => {}
            }
            previous = original;
        }
    }
    records
}

#[test]
fn bag_header_stamps_at_fault_place_every_topic_by_record_time() {
    let dir = temp_dir("bag");
    for (name, bytes) in [
        ("broken.bag", ros1_bag(&broken_drive())),
        ("broken.mcap", mcap_bag(&broken_drive(), false, None)),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let log = read_bag(&path, &topics(StampClock::Auto)).unwrap();
        assert_eq!(log.clock, StampClock::Record);
        assert!(log
            .scans
            .iter()
            .all(|s| s.stamp == s.time && s.scan.timestamp == s.time));
        assert!(log.odometry.iter().all(|o| o.stamp == o.time));
        assert!(log.scans.windows(2).all(|w| w[1].stamp > w[0].stamp));
        assert_eq!(log.notes.len(), 1, "{:?}", log.notes);
        let note = &log.notes[0];
        for part in [
            name,
            "/scan message 11",
            "repeats the previous one",
            "3 of 30 stamps",
            "every topic is placed by its record times",
        ] {
            assert!(note.contains(part), "{part:?} in {note}");
        }
        // The notes reach the pair builder's, and the pairs are one increasing sequence.
        let built = bag_pairs(
            &log,
            &BagPairOptions {
                k: 1,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(built.notes.iter().any(|n| n == note));
        assert_eq!(built.pairs.len(), 29);
        assert!(built
            .pairs
            .iter()
            .all(|p| p.current.timestamp - p.reference.timestamp > 0.05));
        // `header` refuses, naming the topic, the message, its record time and field.
        let e = read_bag(&path, &topics(StampClock::Header))
            .unwrap_err()
            .to_string();
        for part in [
            "/scan",
            "message 11",
            "header.stamp",
            "repeats the previous one",
            "record",
        ] {
            assert!(e.contains(part), "{part:?} in {e}");
        }
        // `record` on a clean bag: record times, no note.
        let clean = dir.join(format!("clean-{name}"));
        std::fs::write(&clean, ros1_bag(&drive(12))).unwrap();
        let record = read_bag(&clean, &topics(StampClock::Record)).unwrap();
        assert_eq!(record.clock, StampClock::Record);
        assert!(record.scans.iter().all(|s| s.scan.timestamp == s.time));
        let auto = read_bag(&clean, &topics(StampClock::Auto)).unwrap();
        assert_eq!((auto.clock, auto.notes.len()), (StampClock::Header, 0));
        assert!(auto.scans.iter().all(|s| s.scan.timestamp == s.stamp));
        assert!(auto.scans.iter().all(|s| s.stamp < s.time));
    }
}

#[test]
fn an_odometry_topic_with_a_zero_stamp_places_the_bag_by_record_time() {
    let mut records = drive(12);
    let odom = records
        .iter_mut()
        .filter(|r| r.topic == "/odom")
        .nth(7)
        .unwrap();
    if let Msg::Odom { stamp_ns, .. } = &mut odom.msg {
        *stamp_ns = 0;
    }
    let dir = temp_dir("odom");
    let path = dir.join("zero-odom.bag");
    std::fs::write(&path, ros1_bag(&records)).unwrap();
    let log = read_bag(&path, &topics(StampClock::Auto)).unwrap();
    assert_eq!(log.clock, StampClock::Record);
    assert!(
        log.notes[0].contains("/odom message 8") && log.notes[0].contains("unset"),
        "{:?}",
        log.notes
    );
    let e = read_bag(&path, &topics(StampClock::Header))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/odom") && e.contains("message 8"), "{e}");
}

fn scan_line(idx: usize, header: f64, bag: f64) -> String {
    format!("SCAN {idx} {header} {bag} laser -0.5 0.5 0.0 10.0 3 1.0 2.0 3.0\n")
}

#[test]
fn leigh_text_logs_follow_the_same_rule() {
    let p = Path::new("scans.txt");
    let text: String = [(0, 10.0, 10.02), (1, 10.1, 10.12), (2, 10.05, 10.22)]
        .iter()
        .map(|&(i, h, b)| scan_line(i, h, b))
        .collect();
    let auto = parse_scans_with(p, &text, StampClock::Auto).unwrap();
    assert_eq!(auto.clock, StampClock::Record);
    let t: Vec<f64> = auto.scans.iter().map(|s| s.scan.timestamp).collect();
    assert_eq!(t, [10.02, 10.12, 10.22]);
    assert!(
        auto.notes[0].contains("line 3") && auto.notes[0].contains("goes back"),
        "{:?}",
        auto.notes
    );
    let e = parse_scans_with(p, &text, StampClock::Header)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("scans.txt:3") && e.contains("stamp_header_s"),
        "{e}"
    );
    // Both clocks going backwards: the header stamps are kept, in file order, noted.
    let both: String = [(0, 10.0, 10.02), (1, 9.0, 9.02)]
        .iter()
        .map(|&(i, h, b)| scan_line(i, h, b))
        .collect();
    let kept = parse_scans_with(p, &both, StampClock::Auto).unwrap();
    assert_eq!(kept.clock, StampClock::Header);
    assert_eq!(kept.scans[1].scan.timestamp, 9.0);
    assert!(kept.notes[0].contains("stamp_bag_s goes backwards too"));
    // A clean log: header stamps, no note.
    let clean = parse_scans_with(p, &scan_line(0, 1.0, 1.5), StampClock::Auto).unwrap();
    assert_eq!((clean.clock, clean.notes.len()), (StampClock::Header, 0));
    assert_eq!(clean.scans[0].scan.timestamp, 1.0);
}

fn odom_line(ipc: f64, logger: f64) -> String {
    format!("ODOM 0 0 0 0 0 0 {ipc} host {logger}\n")
}

#[test]
fn carmen_logs_follow_the_same_rule() {
    let p = Path::new("log.clf");
    let options = |clock| CarmenOptions {
        clock,
        ..Default::default()
    };
    let text = [
        odom_line(5.0, 5.1),
        odom_line(5.0, 5.2),
        odom_line(5.3, 5.4),
    ]
    .concat();
    let log = parse_carmen(p, &text, options(StampClock::Auto)).unwrap();
    assert_eq!(log.clock, StampClock::Record);
    let t: Vec<f64> = log.odometry.iter().map(|o| o.timestamp).collect();
    assert_eq!(t, [5.1, 5.2, 5.4]);
    assert!(
        log.notes[0].contains("line 2") && log.notes[0].contains("logger_timestamp"),
        "{:?}",
        log.notes
    );
    let e = parse_carmen(p, &text, options(StampClock::Header))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("log.clf:2") && e.contains("ipc_timestamp"),
        "{e}"
    );
    // intel-lab's case: both clocks go backwards; the ipc stamps are kept and noted.
    let both = [odom_line(5.0, 5.1), odom_line(4.0, 4.1)].concat();
    let kept = parse_carmen(p, &both, options(StampClock::Auto)).unwrap();
    assert_eq!(kept.clock, StampClock::Header);
    assert_eq!(kept.odometry[1].timestamp, 4.0);
    assert!(kept.notes[0].contains("logger_timestamp goes backwards too"));
    let record = parse_carmen(p, &both, options(StampClock::Record)).unwrap();
    assert_eq!(record.odometry[1].timestamp, 4.1);
    let clean = parse_carmen(p, &odom_line(1.0, 1.1), options(StampClock::Auto)).unwrap();
    assert_eq!((clean.clock, clean.notes.len()), (StampClock::Header, 0));
}

#[test]
fn a_duplicate_vertex_id_is_refused_naming_both_lines() {
    let text = "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nVERTEX2 0 2 0 0\n";
    let e = parse_carmen(Path::new("g.log"), text, CarmenOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("g.log:3") && e.contains("already defined on line 1"),
        "{e}"
    );
}
