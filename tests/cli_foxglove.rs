//! `--mcap FILE` on `pgm match`, `pgm cluster`, `pgm joint` and `pgm track`: the file
//! reads back with the `mcap` crate with every CRC checked, each topic carries the
//! Foxglove schema it should (Foxglove's own JSON Schemas, stored unchanged), and the
//! messages hold what the command printed: the scans' ranges, the estimated motion,
//! one entity per moving cluster or reported track, one line per association. Bad
//! input and impossible outputs write nothing. The datmo bag in ../shared/data (or
//! `$PGM_SHARED_DATA`) is skipped with a note when missing, a failure when
//! `CI=true`. (Every message is also validated against its schema by the Python
//! suite, python/tests/test_foxglove.py, with the `jsonschema` and `mcap` packages.)

mod common;

use common::*;
use pgm::foxglove::{FRAME_TRANSFORM_SCHEMA, LASER_SCAN_SCHEMA, SCENE_UPDATE_SCHEMA};
use serde_json::Value;
use std::collections::BTreeMap;

/// One message: topic, schema name, log time (ns), JSON.
struct Message {
    topic: String,
    schema: String,
    log_time: u64,
    json: Value,
}

/// Every message of the MCAP file at `path`, after checking every CRC it holds and
/// that each channel is JSON under one of Foxglove's schemas, stored verbatim.
fn read_recording(path: &str) -> Vec<Message> {
    let bytes = std::fs::read(path).unwrap();
    // The data-section and summary CRCs (the linear reader), then the chunks'.
    let mut reader = mcap::sans_io::LinearReader::new_with_options(
        mcap::sans_io::LinearReaderOptions::default()
            .with_validate_data_section_crc(true)
            .with_validate_summary_section_crc(true)
            .with_validate_chunk_crcs(true),
    );
    let mut fed = 0;
    while let Some(event) = reader.next_event() {
        match event.unwrap() {
            mcap::sans_io::LinearReadEvent::ReadRequest(n) => {
                let n = n.min(bytes.len() - fed);
                reader.insert(n).copy_from_slice(&bytes[fed..fed + n]);
                reader.notify_read(n);
                fed += n;
            }
            mcap::sans_io::LinearReadEvent::Record { .. } => {}
        }
    }
    assert_eq!(fed, bytes.len(), "{path}: the reader stopped early");
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("a summary section");
    let stats = summary.stats.as_ref().expect("statistics");
    let options = mcap::read::Options::ValidateChunkCrcs.into();
    let mut out = Vec::new();
    for m in mcap::MessageStream::new_with_options(&bytes, options).unwrap() {
        let m = m.unwrap();
        let schema = m
            .channel
            .schema
            .as_ref()
            .expect("every channel has a schema");
        assert_eq!(m.channel.message_encoding, "json");
        assert_eq!(schema.encoding, "jsonschema");
        let stored = match schema.name.as_str() {
            "foxglove.LaserScan" => LASER_SCAN_SCHEMA,
            "foxglove.FrameTransform" => FRAME_TRANSFORM_SCHEMA,
            "foxglove.SceneUpdate" => SCENE_UPDATE_SCHEMA,
            other => panic!("unexpected schema {other}"),
        };
        assert_eq!(&schema.data[..], stored.as_bytes());
        out.push(Message {
            topic: m.channel.topic.clone(),
            schema: schema.name.clone(),
            log_time: m.log_time,
            json: serde_json::from_slice(&m.data).unwrap(),
        });
    }
    assert_eq!(stats.message_count, out.len() as u64);
    out
}

/// How many messages each topic has.
fn per_topic(messages: &[Message]) -> BTreeMap<&str, usize> {
    let mut n = BTreeMap::new();
    for m in messages {
        *n.entry(m.topic.as_str()).or_default() += 1;
    }
    n
}

fn on<'a>(messages: &'a [Message], topic: &str) -> Vec<&'a Message> {
    messages.iter().filter(|m| m.topic == topic).collect()
}

/// The ranges a scan should be recorded with: its valid ranges, 0 elsewhere.
fn recorded_ranges(scan: &pgm::scan::Scan) -> Vec<f64> {
    scan.ranges
        .iter()
        .zip(&scan.valid)
        .map(|(&r, &v)| if v { r } else { 0.0 })
        .collect()
}

fn as_f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The transform's planar pose (x, y, yaw).
fn planar(tf: &Value) -> (f64, f64, f64) {
    let t = &tf["translation"];
    let q = &tf["rotation"];
    let yaw = 2.0 * q["z"].as_f64().unwrap().atan2(q["w"].as_f64().unwrap());
    (t["x"].as_f64().unwrap(), t["y"].as_f64().unwrap(), yaw)
}

fn assert_pose(tf: &Value, pose: &Value) {
    let (x, y, yaw) = planar(tf);
    let (px, py, pt) = (
        pose["x"].as_f64().unwrap(),
        pose["y"].as_f64().unwrap(),
        pose["theta"].as_f64().unwrap(),
    );
    assert!(
        (x - px).abs() < 1e-12 && (y - py).abs() < 1e-12,
        "{tf} vs {pose}"
    );
    assert!(
        pgm::scan::wrap_angle(yaw - pt).abs() < 1e-12,
        "{tf} vs {pose}"
    );
}

#[test]
fn pair_commands_record_scans_poses_clusters_and_associations() {
    let dir = temp_dir("mcap-pairs");
    let (ds, pairs) = simulated(&dir, "sim", 11, 1);
    let pair = &pairs[0];
    for command in ["match", "cluster", "joint"] {
        let file = path(&dir, &format!("{command}.mcap"));
        let printed = ok_json(&[command, "--pairs", &ds, "--mcap", &file]);
        let messages = read_recording(&file);
        let topics = per_topic(&messages);
        assert_eq!(topics["/reference/scan"], 1, "{command}");
        assert_eq!(topics["/current/scan"], 1, "{command}");
        assert_eq!(topics["/tf"], 2, "{command}");
        assert_eq!(topics.contains_key("/clusters"), command != "match");
        assert_eq!(topics.contains_key("/associations"), command != "cluster");
        for m in &messages {
            let expected = match m.topic.as_str() {
                "/reference/scan" | "/current/scan" => "foxglove.LaserScan",
                "/tf" => "foxglove.FrameTransform",
                _ => "foxglove.SceneUpdate",
            };
            assert_eq!(m.schema, expected, "{command} {}", m.topic);
        }
        for (topic, scan) in [
            ("/reference/scan", &pair.reference),
            ("/current/scan", &pair.current),
        ] {
            let s = &on(&messages, topic)[0];
            assert_eq!(as_f64s(&s.json["ranges"]), recorded_ranges(scan));
            assert_eq!(s.json["start_angle"].as_f64(), scan.angles.first().copied());
            assert_eq!(s.json["end_angle"].as_f64(), scan.angles.last().copied());
            assert_eq!(s.log_time, (scan.timestamp * 1e9).round() as u64);
        }
        // The current sensor in the reference frame: the estimated ego-motion.
        let motion = match command {
            "match" => &printed["motion"],
            "cluster" => &printed["background_motion"],
            _ => &printed["ego_motion"],
        };
        for tf in on(&messages, "/tf") {
            assert_eq!(tf.json["parent_frame_id"], "reference");
            assert_eq!(tf.json["child_frame_id"], "current");
            assert_pose(&tf.json, motion);
        }
        if command != "match" {
            let scene = &on(&messages, "/clusters")[0].json;
            let clusters: Vec<&Value> = scene["entities"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|e| e["id"].as_str().unwrap().starts_with("cluster "))
                .collect();
            let moving = match command {
                "cluster" => printed["clusters"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .filter(|c| c["background"] == false)
                    .count(),
                _ => printed["cluster_motions"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .filter(|c| c["background"] == false && c["points"].as_u64() > Some(0))
                    .count(),
            };
            assert!(moving > 0, "{command}: the simulated pair has movers");
            assert_eq!(clusters.len(), moving, "{command}: {scene}");
            for c in clusters {
                assert_eq!(c["frame_id"], "reference");
                assert_eq!(c["cubes"].as_array().unwrap().len(), 1);
                assert!(!c["spheres"].as_array().unwrap().is_empty());
                assert_eq!(c["texts"].as_array().unwrap().len(), 1);
            }
        }
        if command != "cluster" {
            let scene = &on(&messages, "/associations")[0].json;
            let lines = &scene["entities"][0]["lines"][0];
            assert_eq!(lines["type"], 2, "a list of segments");
            let associated = printed["associations"]
                .as_array()
                .unwrap()
                .iter()
                .zip(&pair.current.valid)
                .filter(|(a, &valid)| valid && a.as_i64().is_some_and(|j| j >= 0))
                .count();
            assert!(associated > 0);
            assert_eq!(lines["points"].as_array().unwrap().len(), 2 * associated);
        }
    }
}

#[test]
fn track_records_every_scan_and_every_reported_track() {
    let dir = temp_dir("mcap-track");
    let seq = simulated_sequence(&dir, "overtaking", 3, 20);
    let file = path(&dir, "track.mcap");
    let out = path(&dir, "track.json");
    ok(&track_crf(
        "segment-icp",
        &["--pairs", &seq, "--out", &out, "--mcap", &file],
    ));
    let reported = check_track_recording(&read_recording(&file), &read_json(&out));
    assert!(reported > 0, "the overtaking car is tracked");
}

/// The recording of `pgm track` holds, per scan of its JSON `report`: the scan, the
/// sensor's pose and one entity per reported (not tentative) object; returns how many
/// objects.
fn check_track_recording(messages: &[Message], report: &Value) -> usize {
    let scans = report["scans"].as_array().unwrap();
    let topics = per_topic(messages);
    assert_eq!(topics["/scan"], scans.len());
    assert_eq!(topics["/tf"], scans.len());
    assert_eq!(topics["/tracks"], scans.len());
    assert_eq!(topics["/tracks/paths"], scans.len());
    let (mut objects, mut entities) = (0, 0);
    // Each track's reported centres so far, in the fixed frame.
    let mut centres: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for (((tf, tracks), paths), scan) in on(messages, "/tf")
        .iter()
        .zip(on(messages, "/tracks"))
        .zip(on(messages, "/tracks/paths"))
        .zip(scans)
    {
        assert_eq!(tf.json["parent_frame_id"], "world");
        assert_eq!(tf.json["child_frame_id"], "laser");
        assert_pose(&tf.json, &scan["pose"]);
        assert_eq!(
            tracks.log_time,
            (scan["time"].as_f64().unwrap() * 1e9).round() as u64
        );
        let shown: Vec<String> = scan["objects"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|o| o["state"] != "tentative")
            .map(|o| format!("track {}", o["track"]))
            .collect();
        let ids: Vec<String> = tracks.json["entities"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["id"].as_str().unwrap().to_string())
            .collect();
        assert_eq!(ids, shown);
        // Each scan replaces the last one's tracks.
        assert_eq!(tracks.json["deletions"][0]["type"], 1);
        // The paths: the same tracks, each ending at its centre moved into the fixed
        // frame by the sensor's pose (one sequence here).
        let (x, y, yaw) = planar(&tf.json);
        let path_entities = paths.json["entities"].as_array().unwrap();
        assert_eq!(path_entities.len(), shown.len());
        for (o, e) in scan["objects"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|o| o["state"] != "tentative")
            .zip(path_entities)
        {
            assert_eq!(e["frame_id"], "world");
            let (cx, cy) = (
                o["centre"][0].as_f64().unwrap(),
                o["centre"][1].as_f64().unwrap(),
            );
            let at = (
                x + yaw.cos() * cx - yaw.sin() * cy,
                y + yaw.sin() * cx + yaw.cos() * cy,
            );
            let path = centres
                .entry(e["id"].as_str().unwrap().to_string())
                .or_default();
            path.push(at);
            if path.len() > pgm::foxglove::PATH_LENGTH {
                path.remove(0);
            }
            let points = e["lines"][0]["points"].as_array().unwrap();
            assert_eq!(points.len(), path.len());
            for (p, q) in points.iter().zip(path.iter()) {
                assert!((p["x"].as_f64().unwrap() - q.0).abs() < 1e-9);
                assert!((p["y"].as_f64().unwrap() - q.1).abs() < 1e-9);
            }
        }
        objects += shown.len();
        entities += ids.len();
    }
    assert_eq!(objects, entities);
    entities
}

#[test]
fn the_datmo_car_is_recorded_track_by_track() {
    let Some(dir) = pgm_datasets::testdata::shared_data_dir() else {
        return;
    };
    let bag = dir.join("datmo/overtake_ego.bag");
    let bag = bag.to_str().unwrap();
    let tmp = temp_dir("mcap-datmo");
    let (file, out) = (path(&tmp, "car.mcap"), path(&tmp, "car.json"));
    ok(&track_crf(
        "crf-matching",
        &[
            "--bag",
            bag,
            "--scan-topic",
            "/scan",
            "--out",
            &out,
            "--mcap",
            &file,
        ],
    ));
    let messages = read_recording(&file);
    let report = read_json(&out);
    let entities = check_track_recording(&messages, &report);
    assert!(
        entities > 50,
        "the car beside the robot: {entities} reports"
    );
}

#[test]
fn what_foxglove_cannot_hold_is_refused_and_nothing_is_written() {
    let dir = temp_dir("mcap-refused");
    let (_, pairs) = simulated(&dir, "sim", 12, 1);
    // Beams not equally spaced: foxglove.LaserScan has no angle per beam.
    let mut uneven = to_json(&pairs[0]);
    let a = uneven["current"]["angles"][10].as_f64().unwrap();
    uneven["current"]["angles"][10] = serde_json::json!(a + 0.002);
    let uneven = write_raw(&dir, "uneven", &[uneven]);
    // A negative time stamp: a Foxglove time is unsigned.
    let mut early = to_json(&pairs[0]);
    early["reference"]["timestamp"] = serde_json::json!(-1.5);
    early["current"]["timestamp"] = serde_json::json!(-1.4);
    let early = write_raw(&dir, "early", &[early]);
    let (svg, mcap, out) = (
        path(&dir, "x.svg"),
        path(&dir, "x.mcap"),
        path(&dir, "x.json"),
    );
    let name = pairs[0].name.clone();
    refused_all(&[
        (
            vec![
                "cluster", "--pairs", &uneven, "--svg", &svg, "--mcap", &mcap,
            ],
            vec![&name, "current scan", "angles", "not equally spaced"],
        ),
        (
            vec!["match", "--pairs", &early, "--svg", &svg, "--mcap", &mcap],
            vec!["reference scan", "time stamp -1.5"],
        ),
        (
            vec![
                "track", "--method", "crf", "--pairs", &early, "--out", &out, "--svg", &svg,
                "--mcap", &mcap,
            ],
            vec!["--mcap", "time stamp -1.5"],
        ),
        (
            vec!["joint", "--pairs", &uneven, "--svg", &svg, "--mcap", &svg],
            vec!["--svg", "--mcap", "are the same file"],
        ),
    ]);
    for f in [&svg, &mcap, &out] {
        assert!(!std::path::Path::new(f).exists(), "{f} was written");
    }
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        3,
        "only the three data sets"
    );
}
