//! Reader tests on small hand-written logs, well-formed and malformed.

use pgm_datasets::carmen::{parse_carmen, CarmenOptions};
use pgm_datasets::leigh::{parse_odometry, parse_people, parse_scans};
use pgm_datasets::relations::parse_relations;
use pgm_datasets::Error;
use std::path::Path;

fn flaser(ranges: &[&str]) -> String {
    format!(
        "FLASER {} {} 1.0 2.0 0.1 1.0 2.0 0.1 1134864645.90321 host 0.5",
        ranges.len(),
        ranges.join(" ")
    )
}

fn carmen(text: &str) -> pgm_datasets::Result<pgm_datasets::carmen::CarmenLog> {
    parse_carmen(Path::new("test.clf"), text, CarmenOptions::default())
}

/// Asserts a field error with the given line, field and a problem containing `needle`.
fn assert_field_error(err: Error, line: usize, field: &str, needle: &str) {
    match &err {
        Error::Field {
            path,
            line: l,
            field: f,
            problem,
            ..
        } => {
            assert_eq!(*l, line, "{err}");
            assert_eq!(f, field, "{err}");
            assert!(problem.contains(needle), "{err}");
            assert!(!path.as_os_str().is_empty());
        }
        other => panic!("expected a field error, got {other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains(&format!(":{line}:")),
        "message names the line: {msg}"
    );
    assert!(msg.contains(field), "message names the field: {msg}");
}

#[test]
fn flaser_is_read_with_angles_odometry_and_validity() {
    let text = format!(
        "# comment\nPARAM robot_x 1\n\n{}\nODOM 1 2 0.5 0 0 0 10.0 host 1.0\nFOO bar\n",
        flaser(&["1.5", "81.91", "0", "2.0", "3.0"])
    );
    let log = carmen(&text).unwrap();
    assert_eq!(log.scans.len(), 1);
    let s = &log.scans[0];
    assert_eq!(s.line, 4);
    assert_eq!(s.scan.valid, vec![true, false, false, true, true]);
    assert!((s.scan.angles[0] + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert!((s.scan.angles[4] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert!((s.scan.timestamp - 1134864645.90321).abs() < 1e-6);
    assert!(s.scan.laser_offset.translation_error(&Default::default()) < 1e-12);
    assert_eq!(s.scan.validate(), Ok(()));
    assert_eq!(log.odometry.len(), 1);
    assert_eq!(log.skipped.get("#"), Some(&1));
    assert_eq!(
        log.params
            .get("robot_x")
            .map(|p| (p.value.as_str(), p.line)),
        Some(("1", 2))
    );
    assert_eq!(log.skipped.get("FOO"), Some(&1));
    assert_eq!(log.skipped_lines(), 2);
}

#[test]
fn robotlaser1_and_vertex2() {
    let text = "VERTEX2 7 1.0 2.0 0.5\nROBOTLASER1 0 -1.5 3.0 1.5 50.0 0.1 0 3 1.0 81.83 2.0 2 0.5 0.6 1.0 2.0 0.5 1.0 2.0 0.5 0 0 0 0 0 976053557.767368 x 700.43\nEDGE2 0 1 0 0 0 1 0 1 1 0 0\n";
    let log = carmen(text).unwrap();
    assert_eq!(log.scans.len(), 1);
    let s = &log.scans[0];
    assert_eq!(s.vertex.map(|v| v.id), Some(7));
    assert_eq!(s.scan.valid, vec![true, false, true]);
    assert_eq!(s.scan.max_range, 50.0);
    assert!((s.scan.angles[2] - 1.5).abs() < 1e-12);
    assert_eq!(log.skipped.get("EDGE2"), Some(&1));
}

#[test]
fn truncated_flaser_line() {
    let mut line = flaser(&["1.0", "2.0", "3.0"]);
    line.truncate(line.rfind(' ').unwrap());
    let err = carmen(&format!("\n{line}\n")).unwrap_err();
    match &err {
        Error::MissingField {
            line,
            field,
            found,
            expected,
            ..
        } => {
            assert_eq!(*line, 2);
            assert_eq!(field, "logger_timestamp");
            assert_eq!((*found, *expected), (13, 14));
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("test.clf:2"), "{err}");
}

#[test]
fn flaser_with_wrong_beam_count() {
    // Declares 4 ranges, has 3: the line is one field short.
    let line = flaser(&["1.0", "2.0", "3.0"]).replacen("FLASER 3", "FLASER 4", 1);
    assert!(matches!(
        carmen(&line).unwrap_err(),
        Error::MissingField { line: 1, .. }
    ));
    // Declares 2 ranges, has 3: one field too many.
    let line = flaser(&["1.0", "2.0", "3.0"]).replacen("FLASER 3", "FLASER 2", 1);
    match carmen(&line).unwrap_err() {
        Error::ExtraFields {
            line,
            found,
            expected,
            context,
            ..
        } => {
            assert_eq!((line, found, expected), (1, 14, 13));
            assert!(context.contains("n = 2"));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn flaser_with_non_numeric_nan_and_negative_ranges() {
    let err = carmen(&flaser(&["1.0", "abc", "3.0"])).unwrap_err();
    assert_field_error(err, 1, "range[1]", "not a number");
    // -inf is REP 117's "too close": a beam without a return, not a negative range.
    let log = carmen(&flaser(&["1.0", "2.0", "-inf"])).unwrap();
    assert_eq!(log.scans[0].scan.valid, vec![true, true, false]);
    let err = carmen(&flaser(&["1.0", "2.0", "-2.5"])).unwrap_err();
    assert_field_error(err, 1, "range[2]", "negative");
    let err = carmen(&flaser(&["-1.0", "2.0", "3.0"])).unwrap_err();
    assert_field_error(err, 1, "range[0]", "negative");
    let err = carmen("FLASER x 1 2").unwrap_err();
    assert_field_error(err, 1, "n", "integer");
    let bad_time = flaser(&["1.0"]).replace("1134864645.90321", "12:00");
    assert_field_error(
        carmen(&bad_time).unwrap_err(),
        1,
        "ipc_timestamp",
        "not a number",
    );
}

#[test]
fn robotlaser1_with_bad_remission_count() {
    let text = "ROBOTLASER1 0 -1.57 3.14 1.57 50.0 0.1 0 3 1.0 2.0 3.0 5 0.5 1.0 2.0 0.5 1.0 2.0 0.5 0 0 0 0 0 9.0 x 7.0";
    assert!(matches!(
        carmen(text).unwrap_err(),
        Error::MissingField { .. }
    ));
}

#[test]
fn vertex_and_odom_errors() {
    assert_field_error(carmen("VERTEX2 -3 1 2 3").unwrap_err(), 1, "id", "integer");
    assert!(matches!(
        carmen("VERTEX2 1 2 3").unwrap_err(),
        Error::MissingField { line: 1, ref field, .. } if field == "theta"
    ));
    assert_field_error(
        carmen("ODOM 1 2 inf 0 0 0 10.0 host 1.0").unwrap_err(),
        1,
        "theta",
        "finite",
    );
}

#[test]
fn relations_parse_and_fail() {
    let rels = parse_relations(
        Path::new("r.relations"),
        "1.0 2.0 0.3 0.1 0 0 0 0.2\n\n3.0 4.0 0 0 0 0 0 -0.1\n",
    )
    .unwrap();
    assert_eq!(rels.len(), 2);
    assert_eq!(rels[1].line, 3);
    assert!((rels[0].motion.theta() - 0.2).abs() < 1e-12);
    let err = parse_relations(Path::new("r.relations"), "1.0 2.0 0.3 0.1 0 0 0\n").unwrap_err();
    assert!(
        matches!(err, Error::MissingField { line: 1, ref field, .. } if field == "yaw"),
        "{err}"
    );
    let err = parse_relations(Path::new("r.relations"), "1.0 2.0 0.3 y 0 0 0 0\n").unwrap_err();
    assert_field_error(err, 1, "y", "not a number");
}

fn scan_line(idx: usize, n: usize, ranges: &[&str]) -> String {
    format!(
        "SCAN {idx} 100.5 100.6 left_laser -2.356194496 0.006135923 0.0300 11.0000 {n} {}",
        ranges.join(" ")
    )
}

#[test]
fn leigh_scans_nan_inf_zero_are_no_return() {
    let text = format!(
        "# header\n{}\n{}\n",
        scan_line(0, 5, &["0", "nan", "inf", "1.5", "12.0"]),
        scan_line(3, 2, &["0.01", "2.0"])
    );
    let scans = parse_scans(Path::new("scans.txt"), &text).unwrap();
    assert_eq!(scans.scans.len(), 2);
    let s = &scans.scans[0].scan;
    assert_eq!(s.valid, vec![false, false, false, true, false]);
    assert!(s.ranges.iter().all(|r| r.is_finite()));
    assert_eq!(s.validate(), Ok(()));
    // Below range_min (0.03) is no return.
    assert_eq!(scans.scans[1].scan.valid, vec![false, true]);
    assert_eq!(scans.get(3).map(|s| s.line), Some(3));
    assert!(scans.get(1).is_none());
}

#[test]
fn leigh_scan_errors() {
    let p = Path::new("scans.txt");
    let err = parse_scans(p, &scan_line(0, 3, &["1.0", "-2.0", "1.0"])).unwrap_err();
    assert_field_error(err, 1, "range[1]", "negative");
    let err = parse_scans(p, &scan_line(0, 3, &["1.0", "x", "1.0"])).unwrap_err();
    assert_field_error(err, 1, "range[1]", "not a number");
    // A count larger than the rest of the line is refused before anything is sized by it.
    let err = parse_scans(p, &scan_line(0, 4, &["1.0", "2.0", "1.0"])).unwrap_err();
    assert_field_error(err, 1, "n", "only 3 fields follow");
    let err = parse_scans(p, &scan_line(0, 2, &["1.0", "2.0", "1.0"])).unwrap_err();
    assert!(matches!(err, Error::ExtraFields { .. }), "{err}");
    let err = parse_scans(p, "SCAN 0 100.5").unwrap_err();
    assert!(
        matches!(err, Error::MissingField { ref field, .. } if field == "stamp_bag_s"),
        "{err}"
    );
    let text = format!(
        "{}\n{}",
        scan_line(4, 1, &["1.0"]),
        scan_line(4, 1, &["1.0"])
    );
    assert_field_error(parse_scans(p, &text).unwrap_err(), 2, "idx", "increase");
}

#[test]
fn leigh_odometry_and_people() {
    let odo = parse_odometry(
        Path::new("o.txt"),
        "# h\nODOM 0 1.0 2.0 3.0 0.5\nODOM 1 1.0 2.0 3.0 0.6\n",
    )
    .unwrap();
    assert_eq!(odo.len(), 2);
    let err = parse_odometry(Path::new("o.txt"), "ODOM 0 1.0 2.0 nan 0.5\n").unwrap_err();
    assert_field_error(err, 1, "y", "finite");
    let people = parse_people(
        Path::new("p.txt"),
        "PERSON 133 1 4.7 -2.8\nPERSON 133 2 1 1\n",
    )
    .unwrap();
    assert_eq!(people.len(), 2);
    assert_eq!(people[1].person, 2);
    let err = parse_people(
        Path::new("p.txt"),
        "PERSON 133 1 4.7 -2.8\nPERSON 133 1 1 1\n",
    )
    .unwrap_err();
    assert_field_error(err, 2, "person_id", "twice");
    let err = parse_people(Path::new("p.txt"), "PERSON 133 1 4.7\n").unwrap_err();
    assert!(
        matches!(err, Error::MissingField { ref field, .. } if field == "y"),
        "{err}"
    );
}

#[test]
fn missing_file_names_the_path() {
    let err = pgm_datasets::carmen::read_carmen("/nonexistent/dir/log.clf").unwrap_err();
    assert!(matches!(err, Error::Io { .. }));
    assert!(err.to_string().contains("/nonexistent/dir/log.clf"));
}

#[test]
fn leigh_tracks_tell_standing_from_walking_people() {
    use pgm_datasets::builders::leigh_track_displacements;
    use pgm_datasets::leigh::attach_odometry;
    let text = (0..=10)
        .map(|i| scan_line(i, 2, &["1.0", "2.0"]))
        .collect::<Vec<_>>()
        .join("\n");
    let mut scans = parse_scans(Path::new("scans.txt"), &text).unwrap();
    // The robot drives 0.1 m per scan along x and turns 0.02 rad per scan.
    let odometry = (0..=10)
        .map(|i| {
            (
                i,
                pgm_scan::Pose2::new(0.1 * i as f64, 0.0, 0.02 * i as f64),
            )
        })
        .collect();
    // Person 1 stands at (3, 1) in the odometry frame; person 2 walks 0.08 m per scan
    // along y from (2, -1). Annotations in each scan's laser frame.
    let annotations = |scans: &pgm_datasets::leigh::LeighScans| {
        let mut lines = String::new();
        for i in [0usize, 4, 10] {
            let laser = scans
                .get(i)
                .unwrap()
                .scan
                .laser_odometry()
                .unwrap()
                .inverse();
            for (person, p) in [
                (1, nalgebra::Point2::new(3.0, 1.0)),
                (2, nalgebra::Point2::new(2.0, -1.0 + 0.08 * i as f64)),
            ] {
                let q = laser.transform_point(&p);
                lines += &format!("PERSON {i} {person} {} {}\n", q.x, q.y);
            }
        }
        parse_people(Path::new("people.txt"), &lines).unwrap()
    };
    // Without odometry: an error naming the person, the scan and the line.
    let mut bare = scans.clone();
    for s in &mut bare.scans {
        s.scan.odometry = Some(pgm_scan::Pose2::identity());
    }
    let people = annotations(&bare);
    let err = leigh_track_displacements(&scans, &people, 5).unwrap_err();
    assert!(
        err.to_string().contains("scan 0") && err.to_string().contains("line 1"),
        "{err}"
    );
    attach_odometry(&mut scans, &odometry, Path::new("odom.txt")).unwrap();
    let people = annotations(&scans);
    let tracks = leigh_track_displacements(&scans, &people, 5).unwrap();
    assert_eq!(tracks[&1].annotations, 3);
    assert_eq!(tracks[&1].scans, [0, 10]);
    assert!(tracks[&1].per_k_scans < 1e-9, "{:?}", tracks[&1]);
    assert!(
        (tracks[&2].per_k_scans - 0.4).abs() < 1e-9,
        "{:?}",
        tracks[&2]
    );
}

#[test]
fn a_log_without_vertex2_gives_consecutive_pairs_without_ground_truth() {
    use pgm_datasets::builders::consecutive_pairs;
    // Four scans; the third has no valid return (every range at the maximum).
    let odometry =
        |x: f64, t: f64| format!("FLASER 3 1.0 2.0 3.0 {x} 0.0 0.0 {x} 0.0 0.0 {t} host {t}\n");
    let text = odometry(0.0, 10.0)
        + &odometry(0.1, 10.1)
        + "FLASER 3 80.0 80.0 80.0 0.2 0.0 0.0 0.2 0.0 0.0 10.2 host 10.2\n"
        + &odometry(0.3, 10.3);
    let log = carmen(&text).unwrap();
    assert!(log.vertices.is_empty());
    let built = consecutive_pairs(&log, "plain");
    assert!(built.without_ground_truth);
    assert_eq!(built.empty_scans, 1);
    let names: Vec<&str> = built.pairs.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["plain:0-1", "plain:1-3"]);
    for p in &built.pairs {
        assert!(p.truth.is_none(), "{}", p.name);
        assert!(p.current.timestamp > p.reference.timestamp);
    }
    // The odometry prior: the laser 0.1 m and 0.2 m ahead.
    let prior = |i: usize| {
        built.pairs[i]
            .odometry
            .expect("odometry on the laser lines")
    };
    assert!((prior(0).x() - 0.1).abs() < 1e-9, "{:?}", prior(0));
    assert!((prior(1).x() - 0.2).abs() < 1e-9, "{:?}", prior(1));
}

/// A relation between a scan and itself is an error naming its line; a relation
/// written twice is scored once (mit-csail lists one twice), and one repeated with
/// another motion is an error naming both lines.
#[test]
fn relations_to_itself_and_repeated_relations() {
    use pgm_datasets::relations::{dedupe_relations, parse_relations};
    let path = std::path::Path::new("r.relations");
    let err = parse_relations(path, "10.0 10.00001 0.1 0 0 0 0 0.01\n").unwrap_err();
    let text = err.to_string();
    assert!(text.contains("line 1") && text.contains("itself"), "{text}");
    let twice =
        "10.0 11.0 0.1 0 0 0 0 0.01\n12.0 13.0 0.2 0 0 0 0 0.0\n10.0 11.0 0.1 0 0 0 0 0.01\n";
    let once = dedupe_relations(path, parse_relations(path, twice).unwrap()).unwrap();
    assert_eq!(once.relations.len(), 2);
    assert_eq!(once.repeated, vec![(1, 3)]);
    let conflicting = "10.0 11.0 0.1 0 0 0 0 0.01\n10.0 11.0 0.3 0 0 0 0 0.01\n";
    let err = dedupe_relations(path, parse_relations(path, conflicting).unwrap()).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("line 2") && text.contains("line 1") && text.contains("another motion"),
        "{text}"
    );
}
