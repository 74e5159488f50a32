//! The checks behind each fuzz target of `pgm`, one function per parser. Each takes
//! the raw fuzz input, runs the parser and what is built from its output, and panics
//! only when an invariant the parser promises is broken (a panic, abort or hang inside
//! the parser is a finding on its own). The same functions run every committed corpus
//! file in the workspace test `tests/fuzz_corpus.rs`, so CI keeps the corpus without
//! nightly.

use std::path::Path;

/// The input as text (the parsers read text files); `None` for invalid UTF-8, which
/// the file readers refuse before parsing.
fn text(data: &[u8]) -> Option<&str> {
    std::str::from_utf8(data).ok()
}

/// UAI model files: parse, convert to a factor graph, check for positive assignments,
/// and write back (the text round trip must give the same model).
pub fn uai_model(data: &[u8]) {
    use pgm_core::uai::{Evidence, UaiModel};
    let Some(text) = text(data) else { return };
    let Ok(model) = UaiModel::parse_str("fuzz.uai", text) else {
        return;
    };
    for (scope, table) in model.scopes.iter().zip(&model.tables) {
        let states: usize = scope.iter().map(|&v| model.cardinalities[v]).product();
        assert_eq!(states, table.len(), "table size checked against the scope");
    }
    let _ = model.to_factor_graph();
    let _ = model.check_positive(&Evidence::default());
    let again = UaiModel::parse_str("fuzz.uai", &model.to_uai_string())
        .expect("a model written by to_uai_string reads back");
    assert_eq!(again, model, "round trip");
}

/// UAI evidence files: the first byte picks the number of variables (1-6), the next
/// bytes their cardinalities (1-4), the rest is the evidence text.
pub fn uai_evidence(data: &[u8]) {
    use pgm_core::uai::Evidence;
    let Some((&first, rest)) = data.split_first() else {
        return;
    };
    let n = 1 + first as usize % 6;
    if rest.len() < n {
        return;
    }
    let cards: Vec<usize> = rest[..n].iter().map(|b| 1 + *b as usize % 4).collect();
    let Some(text) = text(&rest[n..]) else { return };
    let Ok(read) = Evidence::parse_samples_str("fuzz.evid", text, &cards) else {
        return;
    };
    assert!(!read.samples.is_empty());
    for sample in &read.samples {
        for &(v, x) in &sample.0 {
            assert!(v < n && x < cards[v], "observation ({v}, {x}) checked");
        }
    }
    let first = Evidence::parse_str("fuzz.evid", text, &cards).expect("same text");
    assert_eq!(first, read.samples[0]);
}

/// The clock rule of the text readers, on `(timestamp, record_time)` per scan read:
/// under the header clock no stamp fault passes, under the record clock every scan is
/// placed at its record time.
fn check_clock(
    clock: pgm_datasets::stamps::StampClock,
    mut stamps: impl Iterator<Item = (f64, f64)>,
) {
    use pgm_datasets::stamps::{stamp_faults, StampClock};
    match clock {
        StampClock::Header => assert!(
            stamp_faults(stamps.map(|s| s.0)).is_none(),
            "header clock refuses faults"
        ),
        _ => assert!(stamps.all(|(stamp, record)| stamp == record)),
    }
}

/// CARMEN logs: every scan read satisfies the `Scan` invariants, and the pair builders
/// give valid pairs.
pub fn carmen(data: &[u8]) {
    use pgm_datasets::builders::{carmen_scan_pair, consecutive_pairs};
    use pgm_datasets::carmen::{parse_carmen, CarmenOptions};
    use pgm_datasets::stamps::StampClock;
    let Some(text) = text(data) else { return };
    let path = Path::new("fuzz.clf");
    for clock in [StampClock::Header, StampClock::Record] {
        let options = CarmenOptions {
            clock,
            ..CarmenOptions::default()
        };
        if let Ok(read) = parse_carmen(path, text, options) {
            check_clock(
                clock,
                read.scans.iter().map(|s| (s.scan.timestamp, s.record_time)),
            );
        }
    }
    let Ok(log) = parse_carmen(path, text, CarmenOptions::default()) else {
        return;
    };
    for s in &log.scans {
        assert!(s.line >= 1);
        assert_eq!(s.scan.validate(), Ok(()), "line {}", s.line);
        assert!(!s.scan.is_empty());
    }
    for p in consecutive_pairs(&log, "fuzz").pairs {
        assert_eq!(p.validate(), Ok(()), "{}", p.name);
    }
    if !log.scans.is_empty() {
        if let Ok(p) = carmen_scan_pair(path, &log, 0, log.scans.len() - 1) {
            assert_eq!(p.validate(), Ok(()));
            assert!(p.reference.valid_count() > 0 && p.current.valid_count() > 0);
        }
    }
}

/// Kümmerle relation files.
pub fn relations(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let Ok(relations) = pgm_datasets::relations::parse_relations(Path::new("fuzz.rel"), text)
    else {
        return;
    };
    for r in &relations {
        assert!(r.t1.is_finite() && r.t2.is_finite() && r.motion.is_finite());
        assert!(r.line >= 1);
    }
    let read = relations.len();
    if let Ok(once) = pgm_datasets::relations::dedupe_relations(Path::new("fuzz.rel"), relations) {
        assert_eq!(
            once.relations.len() + once.repeated.len(),
            read,
            "every relation kept or dropped"
        );
        assert!(
            once.repeated.iter().all(|(a, b)| a < b),
            "a repeat names the earlier line first"
        );
        assert!(
            once.relations.windows(2).all(|w| w[0].line < w[1].line),
            "file order"
        );
    }
}

/// leigh-gtm1 style text logs: the input holds the scans, the odometry and the people
/// files separated by the byte 0x1E; the pairs built from them are valid.
pub fn leigh(data: &[u8]) {
    use pgm_datasets::builders::{leigh_pairs, summarize_leigh_pairs, LeighPairOptions};
    use pgm_datasets::leigh::{
        attach_odometry, parse_odometry, parse_people, parse_scans, parse_scans_with,
    };
    use pgm_datasets::stamps::StampClock;
    use pgm_datasets::tracking_truth::leigh_objects;
    let Some(text) = text(data) else { return };
    let mut parts = text.split('\u{1e}');
    let (scans, odometry, people) = (
        parts.next().unwrap_or(""),
        parts.next().unwrap_or(""),
        parts.next().unwrap_or(""),
    );
    for clock in [StampClock::Header, StampClock::Record] {
        if let Ok(read) = parse_scans_with(Path::new("scans.txt"), scans, clock) {
            check_clock(
                clock,
                read.scans.iter().map(|s| (s.scan.timestamp, s.record_time)),
            );
        }
    }
    let Ok(mut scans) = parse_scans(Path::new("scans.txt"), scans) else {
        return;
    };
    for s in &scans.scans {
        assert_eq!(s.scan.validate(), Ok(()), "line {}", s.line);
    }
    for w in scans.scans.windows(2) {
        assert!(w[0].index < w[1].index, "indices increase");
    }
    let with_odometry = match parse_odometry(Path::new("odom.txt"), odometry) {
        Ok(odo) => attach_odometry(&mut scans, &odo, Path::new("odom.txt")).is_ok(),
        Err(_) => false,
    };
    let Ok(people) = parse_people(Path::new("people.txt"), people) else {
        return;
    };
    for k in 1..=3 {
        let options = LeighPairOptions {
            k,
            moving_threshold: if with_odometry { 0.2 } else { 0.0 },
            ..Default::default()
        };
        if let Ok(pairs) = leigh_pairs(&scans, &people, &options) {
            for p in &pairs {
                assert_eq!(p.validate(), Ok(()), "{}", p.name);
            }
            let summary = summarize_leigh_pairs(k, &pairs);
            assert!(summary.returns_per_scan.is_none_or(f64::is_finite));
            assert_eq!(summary.returns_per_scan.is_none(), pairs.is_empty());
        }
        let objects = leigh_objects(&scans, &people, &options, &mut Vec::new());
        for (scan, seen) in &objects {
            assert!(
                scans.scans.iter().any(|s| s.index == *scan),
                "scan {scan} exists"
            );
            assert!(seen.iter().all(|o| o.x.is_finite() && o.y.is_finite()));
        }
    }
}

/// Scan-pair JSON files: a pair that reads is valid and survives a write/read round
/// trip: every number exactly, except pose angles, which are stored as a rotation
/// and written as an angle in (−π, π] (equal up to rounding there).
pub fn pair_json(data: &[u8]) {
    use pgm_datasets::format::parse_pair;
    let Some(text) = text(data) else { return };
    let Ok(pair) = parse_pair(Path::new("pair.json"), text) else {
        return;
    };
    assert_eq!(pair.validate(), Ok(()));
    let written = serde_json::to_string(&pair).expect("a valid pair serialises");
    let again = parse_pair(Path::new("pair.json"), &written).expect("written pair reads");
    let same_pose = |a: &pgm_scan::Pose2, b: &pgm_scan::Pose2| {
        a.translation() == b.translation() && a.rotation_error(b) <= 1e-15
    };
    let same_scan = |a: &pgm_scan::Scan, b: &pgm_scan::Scan| {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        a.timestamp.to_bits() == b.timestamp.to_bits()
            && bits(&a.angles) == bits(&b.angles)
            && bits(&a.ranges) == bits(&b.ranges)
            && a.valid == b.valid
            && a.max_range.to_bits() == b.max_range.to_bits()
            && a.odometry.is_some() == b.odometry.is_some()
            && a.odometry
                .zip(b.odometry)
                .is_none_or(|(x, y)| same_pose(&x, &y))
            && same_pose(&a.laser_offset, &b.laser_offset)
    };
    assert_eq!(again.name, pair.name);
    assert!(
        same_scan(&again.reference, &pair.reference),
        "reference scan"
    );
    assert!(same_scan(&again.current, &pair.current), "current scan");
    assert_eq!(again.odometry.is_some(), pair.odometry.is_some());
    if let (Some(a), Some(b)) = (again.odometry, pair.odometry) {
        assert!(same_pose(&a, &b), "odometry");
    }
    match (&again.truth, &pair.truth) {
        (Some(a), Some(b)) => {
            assert_eq!(a.labels, b.labels);
            assert_eq!(a.reference_labels, b.reference_labels);
            assert_eq!(a.associations, b.associations);
            assert_eq!(a.motions.len(), b.motions.len());
            for (x, y) in a.motions.iter().zip(&b.motions) {
                assert_eq!((x.label, &x.kind), (y.label, &y.kind));
                assert!(same_pose(&x.motion, &y.motion), "motion");
            }
            assert_eq!(a.ego_motion.is_some(), b.ego_motion.is_some());
            if let (Some(x), Some(y)) = (a.ego_motion, b.ego_motion) {
                assert!(same_pose(&x, &y), "ego-motion");
            }
        }
        (None, None) => {}
        _ => panic!("truth lost or invented"),
    }
}

/// Index files of a data set.
pub fn index_json(data: &[u8]) {
    use pgm_datasets::format::parse_index;
    let Some(text) = text(data) else { return };
    if let Ok(index) = parse_index(Path::new("index.json"), text) {
        for entry in &index.pairs {
            let file = Path::new(&entry.file);
            assert!(!file.is_absolute());
            assert!(file
                .components()
                .all(|c| !matches!(c, std::path::Component::ParentDir)));
        }
    }
}

/// CRF-Clustering weight files (`pgm train clustering --out`, `--weights`).
pub fn weights_json(data: &[u8]) {
    use pgm_core::ParamGuard;
    use pgm_crf_clustering::weights::feature_set;
    use pgm_crf_clustering::{ClusteringParams, ClusteringWeights};
    let Some(text) = text(data) else { return };
    let Ok(w) = pgm_core::Weights::from_json(feature_set(), text) else {
        return;
    };
    assert!(
        w.values().iter().all(|v| v.is_finite()),
        "weights read are finite"
    );
    let weights = ClusteringWeights::from_weights(&w);
    let _ = ClusteringParams {
        weights,
        ..ClusteringParams::default()
    }
    .check();
}

/// ROS bags (ROS 1, MCAP, zip; `pgm_datasets::bag::read_bag` reads a file, so the input
/// is written to a temporary file): the first byte picks the optional topics read
/// besides `/scan` (bit 0 `/odom`, bit 1 `/ego_pose`, bit 2 `/box_pose` with it, bit 3
/// `/people` instead), the rest is the file. Scans read are valid; every pair built
/// (k = 1, 2) passes `ScanPair::validate`.
pub fn bag(data: &[u8]) {
    let Some((&select, file)) = data.split_first() else {
        return;
    };
    bag_file(select, file);
}

/// MCAP files whose CRCs are rewritten to match their bytes before reading
/// ([`pgm_datasets::bag::synthetic::reseal_mcap`]), so a mutation inside a chunk reaches
/// the record and message parsers behind the CRC check; the input is laid out and
/// checked as [`bag`]'s. An input whose CRCs are not rewritten (an MCAP file without
/// them, or a compressed chunk) goes through the CRC check as it is.
pub fn mcap(data: &[u8]) {
    let Some((&select, file)) = data.split_first() else {
        return;
    };
    let mut file = file.to_vec();
    pgm_datasets::bag::synthetic::reseal_mcap(&mut file);
    bag_file(select, &file);
}

/// The checks of [`bag`] and [`mcap`]: `select` picks the topics (bits 0-3) and the
/// clock (bit 4 `header`, bit 5 `record`, else `auto`).
fn bag_file(select: u8, file: &[u8]) {
    use pgm_datasets::bag::pairs::{bag_pairs, BagPairOptions};
    use pgm_datasets::bag::{read_bag, BagTopics};
    use pgm_datasets::mocap::Footprint;
    use pgm_datasets::stamps::{stamp_faults, StampClock};
    let clock = match (select >> 4) & 3 {
        1 => StampClock::Header,
        2 => StampClock::Record,
        _ => StampClock::Auto,
    };
    let topic = |bit: u8, name: &str| (select & bit != 0).then(|| name.to_string());
    let topics = BagTopics {
        odometry: topic(1, "/odom"),
        ego_pose: topic(2, "/ego_pose"),
        object_pose: topic(2, "/ego_pose").and(topic(4, "/box_pose")),
        people: topic(8, "/people"),
        clock,
        ..BagTopics::new("/scan")
    };
    let path = std::env::temp_dir().join(format!(
        "pgm-fuzz-bag-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    if std::fs::write(&path, file).is_err() {
        return;
    }
    let read = read_bag(&path, &topics);
    let _ = std::fs::remove_file(&path);
    let Ok(log) = read else { return };
    assert!(!log.scans.is_empty(), "a log has scans");
    for s in &log.scans {
        assert_eq!(s.scan.validate(), Ok(()), "scan {} valid", s.number);
        assert!(s.stamp.is_finite() && s.time.is_finite());
    }
    for track in [&log.odometry, &log.ego_poses, &log.object_poses] {
        assert!(track
            .iter()
            .all(|p| p.pose.is_finite() && p.stamp.is_finite()));
        assert!(track.windows(2).all(|w| w[0].stamp <= w[1].stamp), "sorted");
    }
    match clock {
        StampClock::Header => assert!(
            stamp_faults(log.scans.iter().map(|s| s.stamp)).is_none(),
            "the header clock refuses stamps at fault"
        ),
        StampClock::Record => assert!(log.scans.iter().all(|s| s.stamp == s.time)),
        StampClock::Auto => {}
    }
    for k in 1..=2 {
        let options = BagPairOptions {
            k,
            object_footprint: Some(Footprint {
                length: 0.6,
                width: 0.4,
                centre_x: 0.0,
                centre_y: 0.0,
            }),
            ..BagPairOptions::default()
        };
        if let Ok(built) = bag_pairs(&log, &options) {
            for p in &built.pairs {
                assert_eq!(p.validate(), Ok(()), "{}", p.name);
            }
        }
        if let Ok(truth) = pgm_datasets::tracking_truth::bag_objects(&log, &options) {
            for seen in truth.scans.values() {
                assert!(seen.iter().all(|o| o.x.is_finite() && o.y.is_finite()));
            }
        }
    }
}

/// CLEAR-MOT scoring of arbitrary frames: 1 byte of options (protocol, bearing window,
/// false positives counted), then frames of 1 byte `(estimates << 4) | annotations`
/// followed by 3 bytes per object (id, x, y on a 0.25 m grid around the sensor). The
/// streaming scorer equals the batch scorer, every annotation is a match or a miss,
/// every estimate a match or a false positive, MOTA is at most 1 and MOTP within the
/// threshold.
pub fn clear_mot(data: &[u8]) {
    use pgm_datasets::clear_mot::{
        score, score_frames, BearingWindow, ClearMotOptions, Frame, Protocol,
    };
    let Some((&select, mut rest)) = data.split_first() else {
        return;
    };
    let opts = ClearMotOptions {
        protocol: if select & 1 == 0 {
            Protocol::Benchmark
        } else {
            Protocol::Standard
        },
        bearing_window: (select & 2 != 0).then(BearingWindow::general_tracking),
        count_false_positives: select & 4 == 0,
        threshold_m: [0.75, 0.5, 1.0, 0.25][(select >> 3) as usize & 3],
    };
    let mut frames = Vec::new();
    while let Some((&head, tail)) = rest.split_first() {
        let (ne, nt) = ((head >> 4) as usize, (head & 15) as usize);
        let need = 3 * (ne + nt);
        if tail.len() < need {
            break;
        }
        let object = |b: &[u8]| {
            (
                b[0] as u64,
                (b[1] as i8) as f64 * 0.25,
                (b[2] as i8) as f64 * 0.25,
            )
        };
        frames.push(Frame {
            estimates: tail[..3 * ne].chunks(3).map(object).collect(),
            truth: tail[3 * ne..need].chunks(3).map(object).collect(),
        });
        rest = &tail[need..];
    }
    let Ok((summary, detail)) = score_frames(&frames, &opts) else {
        return;
    };
    assert_eq!(score(&frames, &opts).ok(), Some(summary), "stream = batch");
    assert_eq!(detail.len(), frames.len());
    let c = summary.counts;
    assert_eq!(
        c.matches + c.misses,
        c.truth,
        "each annotation matched or missed"
    );
    if c.false_positives_counted {
        assert_eq!(
            c.matches + c.false_positives,
            c.estimates,
            "each estimate matched or not"
        );
    } else {
        assert_eq!(c.false_positives, 0);
    }
    assert!(c.id_switches <= c.matches);
    assert!(summary.mota.is_none_or(|m| m <= 1.0 && m.is_finite()));
    assert!(summary
        .motp_m
        .is_none_or(|m| (0.0..opts.threshold_m).contains(&m)));
}

/// One ROS message and its definition: the first byte picks the serialisation (bit 0:
/// ROS 2 CDR, else ROS 1), the bytes up to the first 0 are the definition text of type
/// `fuzz/Msg`, the rest is the message. A definition that parses describes only
/// defined types; decoding never reads past the message.
pub fn ros_message(data: &[u8]) {
    use pgm_datasets::bag::decode::{Decoder, Value};
    use pgm_datasets::bag::msgdef::{Definitions, Dialect, FieldType};
    let Some((&select, rest)) = data.split_first() else {
        return;
    };
    let dialect = if select & 1 == 1 {
        Dialect::Ros2
    } else {
        Dialect::Ros1
    };
    let split = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
    let Some(text) = text(&rest[..split]) else {
        return;
    };
    let message = rest.get(split + 1..).unwrap_or(&[]);
    let Ok(definitions) = Definitions::parse("fuzz/Msg", text, dialect) else {
        return;
    };
    for t in definitions.types.values() {
        for f in &t.fields {
            if let FieldType::Message(m) = &f.ty {
                assert!(definitions.types.contains_key(m), "{m} resolved");
            }
        }
    }
    if let Ok(value) = Decoder::new(definitions).decode(message) {
        assert!(matches!(value, Value::Message(_)));
    }
}
