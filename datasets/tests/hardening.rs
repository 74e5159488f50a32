//! Issue 16: every malformed or meaningless input to the log readers and pair builders
//! is a typed error naming file, line and field (never a panic, a huge allocation or a
//! silent nonsense value), and scan geometry comes from the log itself. Each test
//! builds its own small input.

use pgm_datasets::builders::{carmen_scan_pair, leigh_pairs, leigh_scan_pair, LeighPairOptions};
use pgm_datasets::carmen::{
    beam_geometry, carmen_rule, parse_carmen, CarmenOptions, GeometrySource,
};
use pgm_datasets::leigh::{parse_people, parse_scans};
use pgm_datasets::relations::parse_relations;
use pgm_datasets::Error;
use std::f64::consts::PI;
use std::path::Path;

const DEG: f64 = PI / 180.0;

fn carmen(text: &str) -> pgm_datasets::Result<pgm_datasets::carmen::CarmenLog> {
    parse_carmen(Path::new("log.clf"), text, CarmenOptions::default())
}

fn leigh_scans(text: &str) -> pgm_datasets::Result<pgm_datasets::leigh::LeighScans> {
    parse_scans(Path::new("scans.txt"), text)
}

fn flaser(n: usize, range: &str, pose: &str) -> String {
    let ranges = vec![range; n].join(" ");
    format!("FLASER {n} {ranges} {pose} {pose} 10.0 host 10.0")
}

/// Asserts an [`Error::Field`] on `line` and `field` whose problem contains `needle`.
fn field_error(err: Error, line: usize, field: &str, needle: &str) {
    let msg = err.to_string();
    match err {
        Error::Field {
            line: l,
            field: f,
            problem,
            ..
        } => {
            assert_eq!((l, f.as_str()), (line, field), "{msg}");
            assert!(problem.contains(needle), "{msg}");
        }
        other => panic!("expected a field error, got {other:?}"),
    }
    assert!(msg.starts_with(&format!("log.clf:{line}:")) || msg.contains(&format!(":{line}:")));
}

#[test]
fn declared_beam_counts_are_not_trusted_beyond_the_line() {
    // carmen-n-overflow: 2 + n + 9 wraps to the token count in usize.
    let err = carmen("FLASER 18446744073709551615 1 2 3 4 5 6 7 8").unwrap_err();
    field_error(err, 1, "n", "only 8 fields follow");
    let err = carmen("FLASER 99999999999 1 2 3 4 5 6 7 8 9 10 11").unwrap_err();
    field_error(err, 1, "n", "only");
    // ROBOTLASER1: both the beam and the remission counts.
    let head = "ROBOTLASER1 0 -1.5 3.0 1.5 50.0 0.1 0";
    let tail = "0 0 0 0 0 0 0 0 0 0 0 9.0 x 7.0";
    let err = carmen(&format!("{head} 18446744073709551615 1 2 0 {tail}")).unwrap_err();
    field_error(err, 1, "n", "only");
    let err = carmen(&format!("{head} 2 1 2 18446744073709551615 {tail}")).unwrap_err();
    field_error(err, 1, "n_rem", "only");
    // leigh-gtm1 style.
    let err = leigh_scans("SCAN 0 1.0 1.0 laser -1.0 0.1 0.0 10.0 18446744073709551615 1.0 2.0")
        .unwrap_err();
    assert!(
        matches!(err, Error::Field { ref field, .. } if field == "n"),
        "{err}"
    );
}

#[test]
fn scans_without_beams_are_refused_where_they_are_read() {
    // carmen-zero-beam.
    let err = carmen("FLASER 0  0 0 0 0 0 0 1.0 host 1.0").unwrap_err();
    field_error(err, 1, "n", "at least one beam");
    let err = leigh_scans("SCAN 0 1.0 1.0 laser -1.0 0.1 0.0 10.0 0").unwrap_err();
    assert!(err.to_string().contains("at least one beam"), "{err}");
}

#[test]
fn a_pair_of_log_scans_names_the_file_line_and_scan_that_cannot_be_used() {
    let text = format!(
        "{}\n{}\n",
        flaser(5, "2.0", "0 0 0"),
        flaser(5, "81.91", "0.1 0 0")
    );
    let log = carmen(&text).unwrap();
    let path = Path::new("log.clf");
    // A scan paired with itself is refused, as the pair builders refuse k = 0.
    let err = carmen_scan_pair(path, &log, 0, 0).unwrap_err();
    assert!(
        err.to_string()
            .contains("the two scans of a pair must differ"),
        "{err}"
    );
    let err = carmen_scan_pair(path, &log, 0, 1).unwrap_err();
    assert!(
        matches!(
            err,
            Error::Scan {
                line: 2,
                scan: 1,
                ..
            }
        ),
        "{err}"
    );
    assert!(
        err.to_string()
            .starts_with("log.clf:2: scan 1: no valid return"),
        "{err}"
    );
    let err = carmen_scan_pair(path, &log, 7, 0).unwrap_err();
    assert!(err.to_string().contains("scan 7") && err.to_string().contains("2 FLASER"));
    let scans = leigh_scans("SCAN 4 1.0 1.0 laser -1.0 0.1 0.0 10.0 2 1.0 2.0\nSCAN 5 1.0 1.0 laser -1.0 0.1 0.0 10.0 2 0 nan\n")
    .unwrap();
    let err = leigh_scan_pair(Path::new("scans.txt"), &scans, 4, 4).unwrap_err();
    assert!(err.to_string().contains("must differ"), "{err}");
    let err = leigh_scan_pair(Path::new("scans.txt"), &scans, 4, 5).unwrap_err();
    assert!(err.to_string().starts_with("scans.txt:2: scan 5"), "{err}");
}

#[test]
fn nan_and_inf_carmen_ranges_are_beams_without_a_return() {
    // -inf too (REP 117's "too close", pgm_datasets::beams); other negatives are errors.
    let log = carmen(&format!(
        "FLASER 4 1.5 nan inf NaN 0 0 0 0 0 0 10.0 host 10.0\n{}",
        flaser(1, "-inf", "0 0 0")
    ))
    .unwrap();
    assert_eq!(log.scans[1].scan.valid, vec![false]);
    assert_eq!(log.scans[1].scan.ranges, vec![0.0]);
    let err = carmen(&flaser(1, "-0.5", "0 0 0")).unwrap_err();
    field_error(err, 1, "range[0]", "negative");
    let log = carmen("FLASER 4 1.5 nan inf NaN 0 0 0 0 0 0 10.0 host 10.0").unwrap();
    let scan = &log.scans[0].scan;
    assert_eq!(scan.valid, vec![true, false, false, false]);
    assert_eq!(scan.validate(), Ok(()));
}

#[test]
fn flaser_angles_follow_carmens_rule_for_the_beam_count() {
    // (beams, resolution in degrees); the first beam always at -90 degrees.
    for (n, resolution) in [
        (181, 1.0),
        (180, 1.0),
        (361, 0.5),
        (360, 0.5),
        (401, 0.25),
        (400, 0.25),
        (91, 2.0),
        (768, 180.0 / 767.0),
    ] {
        let g = carmen_rule(n);
        assert!((g.start + 90.0 * DEG).abs() < 1e-12, "{n}");
        assert!((g.increment - resolution * DEG).abs() < 1e-12, "{n}");
        let log = carmen(&flaser(n, "2.0", "0 0 0")).unwrap();
        assert_eq!(log.flaser_geometry, GeometrySource::CarmenRule);
        let angles = &log.scans[0].scan.angles;
        assert!(
            (angles[1] - angles[0] - resolution * DEG).abs() < 1e-12,
            "{n}"
        );
    }
}

#[test]
fn flaser_angles_come_from_the_logs_param_lines_and_the_options() {
    // L01: a 401-beam scanner at 100 degrees / 0.25 degrees, said by PARAM lines.
    let text = format!(
        "PARAM laser_front_laser_fov 100\nPARAM laser_front_laser_resolution 0.25\n{}\n",
        flaser(401, "3.0", "0 0 0")
    );
    let log = carmen(&text).unwrap();
    assert_eq!(log.flaser_geometry, GeometrySource::Params);
    let a = &log.scans[0].scan.angles;
    assert!((a[0] + 90.0 * DEG).abs() < 1e-12);
    assert!((a[400] - 10.0 * DEG).abs() < 1e-9);
    // PARAM lines anywhere in the log describe every scan.
    let later = format!(
        "{}\nPARAM robot_front_laser_resolution 0.5\n",
        flaser(3, "3.0", "0 0 0")
    );
    let a = &carmen(&later).unwrap().scans[0].scan.angles;
    assert!((a[1] - a[0] - 0.5 * DEG).abs() < 1e-12);
    // Options override the log.
    let options = CarmenOptions {
        front_laser_fov: Some(100.0),
        front_laser_start: Some(-50.0),
        ..Default::default()
    };
    let log = parse_carmen(Path::new("log.clf"), &text, options).unwrap();
    assert_eq!(log.flaser_geometry, GeometrySource::Options);
    let a = &log.scans[0].scan.angles;
    assert!((a[0] + 50.0 * DEG).abs() < 1e-12 && (a[400] - 50.0 * DEG).abs() < 1e-9);
    // A field of view and resolution that disagree with the beam count.
    let wrong = text
        .replace("FLASER 401", "FLASER 181")
        .replace(&vec!["3.0"; 401].join(" "), &vec!["3.0"; 181].join(" "));
    let err = carmen(&wrong).unwrap_err();
    field_error(err, 3, "n", "gives 401");
    assert!(beam_geometry(400, Some(100.0), Some(0.25), None).is_ok());
    assert!(beam_geometry(10, None, Some(45.0), None).is_err());
    // Two PARAM lines that disagree, and one that is not a number of degrees.
    let err = carmen(
        "PARAM laser_front_laser_fov 100\nPARAM robot_front_laser_fov 180\nFLASER 1 1.0 0 0 0 0 0 0 1.0 h 1.0",
    )
    .unwrap_err();
    assert!(err.to_string().contains("disagrees"), "{err}");
    let err = carmen("PARAM laser_front_laser_resolution 0\nFLASER 1 1.0 0 0 0 0 0 0 1.0 h 1.0")
        .unwrap_err();
    assert!(matches!(err, Error::Field { line: 1, .. }), "{err}");
    // Options out of range.
    let options = CarmenOptions {
        front_laser_resolution: Some(-1.0),
        ..Default::default()
    };
    assert!(parse_carmen(Path::new("log.clf"), &text, options).is_err());
}

#[test]
fn values_that_parse_but_mean_nothing_are_refused() {
    // carmen-huge-pose: a pose of 1e300.
    let err = carmen(&flaser(3, "2.0", "1e300 0 0")).unwrap_err();
    field_error(err, 1, "x", "position");
    let err = carmen(&flaser(3, "2.0", "0 0 1e300")).unwrap_err();
    field_error(err, 1, "theta", "heading");
    let err = carmen(&flaser(3, "1e300", "0 0 0")).unwrap_err();
    field_error(err, 1, "range[0]", "range");
    let err = carmen(&flaser(3, "2.0", "0 0 0").replace("10.0 host", "1e300 host")).unwrap_err();
    field_error(err, 1, "ipc_timestamp", "time stamp");
    let err = carmen("ODOM 1e300 0 0 0 0 0 1.0 host 1.0").unwrap_err();
    field_error(err, 1, "x", "position");
    let err = carmen("VERTEX2 1 0 -1e300 0").unwrap_err();
    field_error(err, 1, "y", "position");
    // rl-res-zero: 180 beams on one ray; and more than a full turn.
    let rl = |res: &str, max: &str| {
        format!(
            "ROBOTLASER1 0 -1.57 0.02 {res} {max} 0.01 0 3 1 2 3 0 0 0 0 0 0 0 0 0 0 0 0 9.0 x 7.0"
        )
    };
    field_error(
        carmen(&rl("0.0", "80")).unwrap_err(),
        1,
        "angular_res",
        "one ray",
    );
    field_error(
        carmen(&rl("4.0", "80")).unwrap_err(),
        1,
        "angular_res",
        "full turn",
    );
    field_error(
        carmen(&rl("0.01", "1e300")).unwrap_err(),
        1,
        "max_range",
        "at most",
    );
    assert!(
        carmen(&rl("-0.01", "80")).is_ok(),
        "decreasing angles are a scanner's right"
    );
    // leigh-gtm1: negative range_min (leigh-rmin-neg), zero increment, a person at 1e300
    // (people-huge).
    let scans = |head: &str| leigh_scans(&format!("SCAN 0 1.0 1.0 l {head} 3 0 1.0 2.0"));
    let err = scans("-1.0 0.1 -5 10.0").unwrap_err();
    assert!(
        matches!(err, Error::Field { ref field, .. } if field == "range_min"),
        "{err}"
    );
    let err = scans("-1.0 0.0 0.0 10.0").unwrap_err();
    assert!(err.to_string().contains("one ray"), "{err}");
    let err = scans("-1.0 0.1 0.0 1e300").unwrap_err();
    assert!(
        matches!(err, Error::Field { ref field, .. } if field == "range_max"),
        "{err}"
    );
    let err = scans("1e300 0.1 0.0 10.0").unwrap_err();
    assert!(
        matches!(err, Error::Field { ref field, .. } if field == "angle_min"),
        "{err}"
    );
    let ok = scans("-1.0 0.1 0.0 10.0").unwrap();
    assert_eq!(ok.scans[0].scan.valid, vec![false, true, true]);
    let err = parse_people(
        Path::new("people.txt"),
        "PERSON 1 2 3.0 1.0\nPERSON 1 3 1e300 1.0\n",
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("people.txt:2: field `x` = `1e300`"),
        "{err}"
    );
    // Relations.
    let err = parse_relations(Path::new("r.relations"), "1 2 1e300 0 0 0 0 0\n").unwrap_err();
    assert!(
        err.to_string().starts_with("r.relations:1: field `x`"),
        "{err}"
    );
    let err = parse_relations(Path::new("r.relations"), "1e300 2 0 0 0 0 0 0\n").unwrap_err();
    assert!(
        err.to_string().starts_with("r.relations:1: field `t1`"),
        "{err}"
    );
}

#[test]
fn a_scan_offset_k_never_wraps() {
    // leigh-k-wrap: i + k wrapped to i - 1 and built reversed pairs.
    let scans = (0..4)
        .map(|i| format!("SCAN {} 1.0 1.0 l -1.0 0.1 0.0 10.0 2 1.0 2.0", 10 + i))
        .collect::<Vec<_>>()
        .join("\n");
    let scans = leigh_scans(&scans).unwrap();
    let people = parse_people(
        Path::new("people.txt"),
        "PERSON 10 1 1.0 0.5\nPERSON 11 1 1.0 0.5\nPERSON 13 1 1.0 0.5\n",
    )
    .unwrap();
    let options = |k| LeighPairOptions {
        k,
        moving_threshold: 0.0,
        rule: pgm_datasets::builders::LabelRule::Displacement,
        ..Default::default()
    };
    for k in [usize::MAX, usize::MAX - 9, 4] {
        let err = leigh_pairs(&scans, &people, &options(k)).unwrap_err();
        assert!(err.to_string().contains("that far apart"), "{k}: {err}");
    }
    let pairs = leigh_pairs(&scans, &people, &options(3)).unwrap();
    assert_eq!(
        pairs.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(),
        ["leigh-gtm1:10-13"]
    );
    let pairs = leigh_pairs(&scans, &people, &options(1)).unwrap();
    assert_eq!(
        pairs.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(),
        ["leigh-gtm1:10-11"]
    );
}

#[test]
fn one_pair_builders_refuse_a_scan_paired_with_itself() {
    let scans = leigh_scans("SCAN 5 1.0 1.0 l -1.0 0.1 0.0 10.0 2 1.0 2.0\nSCAN 6 1.1 1.1 l -1.0 0.1 0.0 10.0 2 1.0 2.0\n")
    .unwrap();
    let err = leigh_scan_pair(Path::new("scans.txt"), &scans, 5, 5).unwrap_err();
    assert!(
        err.to_string().contains(
            "scan 5: reference and current are the same scan: the two scans of a pair must differ"
        ),
        "{err}"
    );
    assert!(leigh_scan_pair(Path::new("scans.txt"), &scans, 5, 6).is_ok());
}

#[test]
fn person_centres_are_held_against_their_scans_reach() {
    use pgm_datasets::leigh::{check_people_reach, people_out_of_reach, PERSON_REACH_MARGIN};
    let scans = leigh_scans("SCAN 5 1.0 1.0 l -1.0 0.1 0.0 10.0 2 1.0 2.0\nSCAN 6 1.1 1.1 l -1.0 0.1 0.0 4.0 2 1.0 2.0\n")
    .unwrap();
    let people = |text: &str| parse_people(Path::new("people.txt"), text).unwrap();
    // Scan 5 reaches 10 m + margin, scan 6 only 4 m + margin; scan 9 is not in the
    // log: the log's largest range_max.
    let near = people("PERSON 5 1 10.5 0.0\nPERSON 6 1 4.9 0.0\nPERSON 9 1 10.9 0.0\n");
    assert!(people_out_of_reach(&scans, &near).is_none());
    for (text, line, range_max) in [
        ("PERSON 5 1 1.0 0.0\nPERSON 6 1 5.2 0.0\n", 2, 4.0),
        ("PERSON 9 1 0.0 -11.2\n", 1, 10.0),
    ] {
        let far = people(text);
        let out = people_out_of_reach(&scans, &far).unwrap();
        assert_eq!((out.annotation.line, out.range_max), (line, range_max));
        assert!(out.distance > range_max + PERSON_REACH_MARGIN);
        let err = check_people_reach(
            &scans,
            Path::new("scans.txt"),
            &far,
            Path::new("people.txt"),
        )
        .unwrap_err();
        assert!(
            err.to_string()
                .starts_with(&format!("people.txt:{line}: field `x y`")),
            "{err}"
        );
    }
}
