//! The on-disk pair format: round trips, accepted paths, validation errors.

use pgm_datasets::format::{read_pair, INDEX_FILE};
use pgm_datasets::{
    read_pairs, write_pairs, Association, ClusterMotion, Error, GroundTruth, ScanPair,
};
use pgm_scan::{ObjectCentre, Pose2, Scan};
use std::path::PathBuf;

fn temp_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("pgm-datasets-format-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn scan(n: usize, t: f64) -> Scan {
    Scan {
        timestamp: t,
        angles: (0..n).map(|k| -1.0 + k as f64 * 0.1).collect(),
        ranges: (0..n)
            .map(|k| {
                if k == 1 {
                    0.0
                } else {
                    1.0 + 0.123456789 * k as f64
                }
            })
            .collect(),
        valid: (0..n).map(|k| k != 1).collect(),
        max_range: 30.0,
        odometry: Some(Pose2::new(1.0, 2.0, 0.3)),
        laser_offset: Pose2::new(0.85, 0.23, 0.73),
    }
}

fn pair(name: &str) -> ScanPair {
    let reference = scan(5, 10.0);
    let current = scan(5, 10.5);
    ScanPair {
        name: name.into(),
        odometry: Some(Pose2::new(0.1, -0.2, 0.03)),
        truth: Some(GroundTruth {
            ego_motion: Some(Pose2::new(0.11, -0.19, 0.031)),
            labels: Some(vec![Some(0), None, Some(1), Some(1), Some(0)]),
            reference_labels: Some(vec![Some(0), None, Some(0), Some(1), Some(1)]),
            associations: Some(vec![
                Some(Association::Point(0)),
                None,
                Some(Association::Outlier),
                Some(Association::Point(4)),
                Some(Association::Point(3)),
            ]),
            motions: vec![ClusterMotion {
                label: 1,
                motion: Pose2::new(0.5, 0.0, 0.031),
                kind: "person 3".into(),
            }],
            objects: Some(vec![ObjectCentre {
                id: 3,
                x: 2.5,
                y: -0.75,
                moving: Some(true),
                returns: Some(7),
            }]),
        }),
        reference,
        current,
    }
}

#[test]
fn round_trip_is_exact_through_any_path() {
    let dir = temp_dir("roundtrip");
    let pairs = vec![pair("a"), pair("b"), pair("c")];
    write_pairs(&dir, &pairs).unwrap();
    assert_eq!(read_pairs(&dir).unwrap(), pairs);
    assert_eq!(read_pairs(dir.join(INDEX_FILE)).unwrap(), pairs);
    assert_eq!(
        read_pairs(dir.join("pair-00001.json")).unwrap(),
        vec![pairs[1].clone()]
    );
    assert_eq!(read_pair(dir.join("pair-00002.json")).unwrap(), pairs[2]);
    // Rewriting with fewer pairs writes the new pair files under unused names, switches
    // the index, then removes the old pair files; no temporary files remain.
    write_pairs(&dir, &pairs[..1]).unwrap();
    assert_eq!(read_pairs(&dir).unwrap(), pairs[..1].to_vec());
    assert_eq!(names_in(&dir), vec!["index.json", "pair-g1-00000.json"]);
    // The next rewrite goes back to the first generation's names.
    write_pairs(&dir, &pairs[1..]).unwrap();
    assert_eq!(read_pairs(&dir).unwrap(), pairs[1..].to_vec());
    assert_eq!(
        names_in(&dir),
        vec!["index.json", "pair-00000.json", "pair-00001.json"]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

fn names_in(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_directory_without_a_data_set_is_never_written_into() {
    // Kind 9 (out-stale-delete): a user's file that looks like a pair file survives.
    let dir = temp_dir("foreign");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("pair-notes.json"), "x\n").unwrap();
    let err = write_pairs(&dir, &[pair("a")]).unwrap_err();
    assert!(
        matches!(err, Error::Invalid { ref problem, .. } if problem.contains("no pgm data set")),
        "{err}"
    );
    assert_eq!(names_in(&dir), vec!["pair-notes.json"]);
    assert_eq!(
        std::fs::read_to_string(dir.join("pair-notes.json")).unwrap(),
        "x\n"
    );
    // An empty directory is fine; so is a file path's parent that does not exist yet.
    let empty = temp_dir("empty");
    std::fs::create_dir_all(&empty).unwrap();
    write_pairs(&empty, &[pair("a")]).unwrap();
    assert_eq!(names_in(&empty), vec!["index.json", "pair-00000.json"]);
    let nested = temp_dir("nested").join("a/b");
    write_pairs(&nested, &[pair("a")]).unwrap();
    assert_eq!(read_pairs(&nested).unwrap().len(), 1);
    // A file where the directory should be is an error, and is left alone.
    let file = temp_dir("file");
    std::fs::write(&file, "mine").unwrap();
    assert!(write_pairs(&file, &[pair("a")]).is_err());
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
    for d in [&dir, &empty, &temp_dir("nested")] {
        let _ = std::fs::remove_dir_all(d);
    }
    let _ = std::fs::remove_file(&file);
}

#[test]
fn replacing_a_data_set_keeps_files_it_did_not_write() {
    let dir = temp_dir("keep-notes");
    write_pairs(&dir, &[pair("a"), pair("b")]).unwrap();
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    std::fs::write(dir.join("pair-extra.json"), "mine too").unwrap();
    write_pairs(&dir, &[pair("c")]).unwrap();
    assert_eq!(read_pairs(&dir).unwrap(), vec![pair("c")]);
    assert_eq!(
        names_in(&dir),
        vec![
            "index.json",
            "notes.txt",
            "pair-extra.json",
            "pair-g1-00000.json"
        ]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_killed_replacement_leaves_the_old_data_set_and_is_cleaned_up_next_time() {
    use pgm_datasets::format::JOURNAL_FILE;
    let dir = temp_dir("killed");
    write_pairs(&dir, &[pair("old")]).unwrap();
    // What a replacement killed before its index switch leaves: its journal, a new
    // pair file and a temporary file, all unlisted.
    std::fs::write(
        dir.join(JOURNAL_FILE),
        r#"{"files": ["pair-g1-00000.json", "pair-g1-00001.json"]}"#,
    )
    .unwrap();
    std::fs::write(dir.join("pair-g1-00000.json"), "{}").unwrap();
    std::fs::write(dir.join(".pair-g1-00001.json.1.tmp"), "{").unwrap();
    assert_eq!(read_pairs(&dir).unwrap(), vec![pair("old")]);
    write_pairs(&dir, &[pair("new")]).unwrap();
    assert_eq!(read_pairs(&dir).unwrap(), vec![pair("new")]);
    assert_eq!(names_in(&dir), vec!["index.json", "pair-g1-00000.json"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_failed_write_leaves_the_old_data_set_untouched() {
    let dir = temp_dir("failed");
    write_pairs(&dir, &[pair("old")]).unwrap();
    let before = names_in(&dir);
    let mut bad = pair("bad");
    bad.current.ranges[0] = f64::NAN;
    assert!(write_pairs(&dir, &[pair("fine"), bad]).is_err());
    assert_eq!(names_in(&dir), before);
    assert_eq!(read_pairs(&dir).unwrap(), vec![pair("old")]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn invalid_pairs_are_not_written() {
    let dir = temp_dir("invalid-write");
    let mut p = pair("bad");
    p.truth.as_mut().unwrap().labels.as_mut().unwrap().pop();
    let err = write_pairs(&dir, &[p]).unwrap_err();
    assert_eq!(invalid_field(&err), Some("truth.labels"), "{err}");
    assert!(!dir.join(INDEX_FILE).exists());
}

/// The field an [`Error::Invalid`] names (`None` for another error).
fn invalid_field(err: &Error) -> Option<&str> {
    match err {
        Error::Invalid { field, .. } => Some(field),
        _ => None,
    }
}

fn write_and_corrupt(name: &str, corrupt: impl Fn(&mut serde_json::Value)) -> Error {
    let dir = temp_dir(name);
    write_pairs(&dir, &[pair("x")]).unwrap();
    let file = dir.join("pair-00000.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    corrupt(&mut v);
    std::fs::write(&file, serde_json::to_string(&v).unwrap()).unwrap();
    let err = read_pairs(&dir).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("pair-00000.json"),
        "error names the file: {msg}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
    err
}

#[test]
fn validation_on_read_names_file_and_field() {
    let err = write_and_corrupt("labels", |v| {
        v["truth"]["labels"].as_array_mut().unwrap().pop();
    });
    assert_eq!(invalid_field(&err), Some("truth.labels"), "{err}");

    let err = write_and_corrupt("assoc-range", |v| {
        v["truth"]["associations"][0] = serde_json::json!(99);
    });
    assert!(
        matches!(err, Error::Invalid { ref field, ref problem, .. }
        if field == "truth.associations[0]" && problem.contains("out of range")),
        "{err}"
    );

    let err = write_and_corrupt("assoc-negative", |v| {
        v["truth"]["associations"][0] = serde_json::json!(-5);
    });
    assert!(matches!(err, Error::Json { .. }), "{err}");

    let err = write_and_corrupt("scan", |v| {
        v["current"]["valid"].as_array_mut().unwrap().pop();
    });
    assert_eq!(invalid_field(&err), Some("current"), "{err}");

    let err = write_and_corrupt("label-on-invalid", |v| {
        v["truth"]["labels"][1] = serde_json::json!(0);
    });
    assert_eq!(invalid_field(&err), Some("truth.labels[1]"), "{err}");

    let err = write_and_corrupt("range", |v| {
        v["reference"]["ranges"][0] = serde_json::json!(-1.0);
    });
    assert_eq!(invalid_field(&err), Some("reference"), "{err}");
}

#[test]
fn bad_index_is_reported() {
    let dir = temp_dir("index");
    write_pairs(&dir, &[pair("x")]).unwrap();
    let index = dir.join(INDEX_FILE);
    std::fs::write(
        &index,
        r#"{"format": "pgm-scan-pairs", "version": 9, "pairs": []}"#,
    )
    .unwrap();
    let err = read_pairs(&dir).unwrap_err();
    assert_eq!(invalid_field(&err), Some("version"), "{err}");
    std::fs::write(
        &index,
        r#"{"format": "pgm-scan-pairs", "version": 1, "pairs": [{"name": "x", "file": "../x.json"}]}"#,
    )
    .unwrap();
    let err = read_pairs(&dir).unwrap_err();
    assert_eq!(invalid_field(&err), Some("pairs[0].file"), "{err}");
    std::fs::write(
        &index,
        r#"{"format": "pgm-scan-pairs", "version": 1, "pairs": [{"name": "y", "file": "pair-00000.json"}]}"#,
    )
    .unwrap();
    let err = read_pairs(&dir).unwrap_err();
    assert_eq!(invalid_field(&err), Some("name"), "{err}");
    std::fs::write(&index, "{ not json").unwrap();
    assert!(matches!(read_pairs(&dir).unwrap_err(), Error::Json { .. }));
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(matches!(read_pairs(&dir).unwrap_err(), Error::Io { .. }));
}

#[test]
fn numbers_read_from_a_file_round_trip_exactly() {
    // Found by the pair_json fuzz target: without serde_json's `float_roundtrip` a
    // literal such as 9.557496377594046 read as a neighbouring f64, and the
    // shortest-representation writer then gave a file that read back differently.
    let literal = "9.557496377594046";
    let exact: f64 = literal.parse().unwrap();
    let mut value = serde_json::to_value(pair("x")).unwrap();
    value["reference"]["ranges"][0] = serde_json::Value::Null;
    let text = serde_json::to_string(&value).unwrap().replacen(
        "\"ranges\":[null",
        &format!("\"ranges\":[{literal}"),
        1,
    );
    let read = pgm_datasets::format::parse_pair(std::path::Path::new("p.json"), &text).unwrap();
    assert_eq!(read.reference.ranges[0].to_bits(), exact.to_bits());
    let dir = temp_dir("float-roundtrip");
    write_pairs(&dir, std::slice::from_ref(&read)).unwrap();
    assert_eq!(read_pairs(&dir).unwrap(), vec![read]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn values_that_mean_nothing_are_refused_on_read_and_write() {
    // Kind 7 of issue 16 in stored pairs: finite, so `validate` accepts them.
    let err = write_and_corrupt("huge-odometry", |v| v["odometry"]["x"] = 1e300.into());
    assert_eq!(invalid_field(&err), Some("odometry"), "{err}");
    let err = write_and_corrupt("huge-range", |v| {
        v["current"]["max_range"] = 1e300.into();
    });
    assert_eq!(invalid_field(&err), Some("current.max_range"), "{err}");
    let err = write_and_corrupt("huge-angle", |v| {
        v["reference"]["angles"][2] = 1e300.into();
    });
    assert_eq!(invalid_field(&err), Some("reference.angles[2]"), "{err}");
    let mut p = pair("x");
    p.truth.as_mut().unwrap().motions[0].motion = Pose2::new(1e300, 0.0, 0.0);
    let dir = temp_dir("huge-write");
    assert!(write_pairs(&dir, &[p]).is_err());
    assert!(!dir.exists());
}
