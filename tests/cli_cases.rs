//! Hardening, second round, from the command line: the three cases of
//! `../shared/cases` (skipped without the folder, fatal under CI=true) with the
//! commands of their READMEs and every other command that reads a bag, and inputs of
//! the same kinds written here.
//!
//! - `mcap-bad-crc`: a chunk whose records do not match its CRC exits 2 naming the
//!   file, the chunk's byte offset and both CRCs; the plain file reads as before.
//! - `scan-angle-range`: `angle_max` more than one increment off exits 2 naming file,
//!   topic, message and both values; one increment off (the fencepost) gives exactly
//!   the consistent bag's results.
//! - `scan-minus-inf`: `-Inf` ranges are beams without a return (as `+Inf`) in bags and
//!   text logs; the results equal the plain bag's but for those beams.

mod common;

use common::logs::{flaser_line, room_ranges};
use common::*;
use pgm_datasets::bag::synthetic::{
    drive, drive_with_angles, mcap_bag, ros1_bag, Msg, Record, ANGLE_INCREMENT, ANGLE_MIN, BEAMS,
};
use pgm_datasets::testdata::shared_case_file;
use std::path::{Path, PathBuf};

/// The topics of a bag: scans, odometry, ego pose, object pose.
type Topics<'a> = [&'a str; 4];

const CASE_TOPICS: Topics = ["/scan", "/odom", "/truth", "/object"];
const DRIVE_TOPICS: Topics = ["/scan", "/odom", "/ego_pose", "/box_pose"];

/// Every command that reads a bag, on `bag` with `topics` (`out`: a directory
/// `pgm data pairs` may write).
fn bag_commands(bag: &str, topics: Topics, out: &str) -> Vec<Vec<String>> {
    let [scan, odom, ego, object] = topics;
    let pair = ["--reference", "1", "--current", "3"];
    let base = ["--bag", bag, "--scan-topic", scan, "--odom-topic", odom];
    let truth = [
        "--ego-pose-topic",
        ego,
        "--object-pose-topic",
        object,
        "--object-footprint",
        "0.6,0.4,0,0",
        "--k",
        "2",
    ];
    let table: Vec<Vec<&str>> = vec![
        [&["cluster"][..], &base, &pair].concat(),
        [&["match"][..], &base, &pair].concat(),
        [&["joint"][..], &base, &pair].concat(),
        [&["track", "--method", "crf"][..], &base].concat(),
        [&["eval", "matching", "--method", "icp"][..], &base, &truth].concat(),
        [
            &["eval", "clustering", "--method", "cbd"][..],
            &base,
            &truth,
        ]
        .concat(),
        [&["data", "pairs", "--out", out][..], &base, &truth].concat(),
    ];
    table
        .into_iter()
        .map(|args| args.into_iter().map(String::from).collect())
        .collect()
}

fn strs(args: &[String]) -> Vec<&str> {
    args.iter().map(String::as_str).collect()
}

/// `pgm eval matching --method icp` on a bag of the shared cases (scans `/scan`, ego
/// pose `/truth`, k = 3), JSON: the command of the cases' READMEs.
fn icp_matching(bag: &str) -> Vec<String> {
    [
        "eval",
        "matching",
        "--method",
        "icp",
        "--bag",
        bag,
        "--scan-topic",
        "/scan",
        "--ego-pose-topic",
        "/truth",
        "--k",
        "3",
        "--json",
    ]
    .map(String::from)
    .to_vec()
}

/// Every bag-reading command refuses `bag` with exit 2 and every needle.
fn refused_everywhere(bag: &str, topics: Topics, out: &str, needles: &[&str]) {
    for args in bag_commands(bag, topics, out) {
        refused(&strs(&args), needles);
        assert!(!Path::new(out).exists(), "{args:?} wrote {out}");
    }
}

/// The file stem of a path (the name a command gives its pairs).
fn stem(path: &str) -> String {
    let name = Path::new(path).file_name().unwrap().to_str().unwrap();
    name.split('.').next().unwrap().to_string()
}

/// Runs every bag-reading command that `keep` selects (by its first word) on bags `a`
/// and `b`: both succeed and print the same, but for the bags' names.
fn same_results(a: &str, b: &str, topics: Topics, out: &str, keep: &[&str]) {
    for (x, y) in bag_commands(a, topics, out)
        .into_iter()
        .zip(bag_commands(b, topics, out))
        .filter(|(x, _)| keep.contains(&x[0].as_str()))
    {
        let (p, _) = ok(&strs(&x));
        let _ = std::fs::remove_dir_all(out);
        let (q, _) = ok(&strs(&y));
        let _ = std::fs::remove_dir_all(out);
        assert!(!p.is_empty() || x[0] == "data", "{x:?} printed nothing");
        let p = p.replace(a, "BAG").replace(&stem(a), "NAME");
        let q = q.replace(b, "BAG").replace(&stem(b), "NAME");
        assert_eq!(p, q, "{x:?} and {y:?}");
    }
}

/// The files `names` of the case `case` of `../shared/cases`; `None` (the test is
/// skipped) when one of them is missing.
fn case_files<const N: usize>(case: &str, names: [&str; N]) -> Option<[PathBuf; N]> {
    let files: Vec<PathBuf> = names
        .map(|name| shared_case_file(&format!("{case}/{name}")))
        .into_iter()
        .collect::<Option<_>>()?;
    files.try_into().ok()
}

/// Every command's first word.
const ALL: [&str; 6] = ["cluster", "match", "joint", "track", "eval", "data"];

/// A JSON result with the input's name (in `data`, `pair`, `pair_sets`) taken out.
fn without_names(mut v: serde_json::Value) -> serde_json::Value {
    if let Some(o) = v.as_object_mut() {
        for key in ["data", "pair", "pair_sets"] {
            o.remove(key);
        }
    }
    v
}

/// The chunks of an MCAP file: the byte of each chunk record and the range of its
/// records.
fn mcap_chunks(bytes: &[u8]) -> Vec<(usize, std::ops::Range<usize>)> {
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() && bytes[at] != 0x02 {
        let len = u64_at(at + 1);
        if bytes[at] == 0x06 {
            let body = at + 9;
            let c = u32::from_le_bytes(bytes[body + 28..body + 32].try_into().unwrap()) as usize;
            let start = body + 40 + c;
            out.push((at, start..start + u64_at(body + 32 + c)));
        }
        at += 9 + len;
    }
    out
}

// ---------------------------------------------------------------------------------
// mcap-bad-crc

#[test]
fn mcap_bad_crc_exits_2_in_every_command_and_the_plain_file_reads() {
    let Some([plain, bad]) = case_files("mcap-bad-crc", ["plain.mcap", "badcrc.mcap"]) else {
        return;
    };
    let (plain, bad) = (plain.to_str().unwrap(), bad.to_str().unwrap());
    let needles = [
        "badcrc.mcap",
        "chunk at byte 18784",
        "uncompressed_crc 0x5a7e04fd",
        "0x280c6f30 computed",
    ];
    // The README's two commands.
    let cluster = |bag: &str| -> Vec<String> {
        [
            "cluster",
            "--bag",
            bag,
            "--scan-topic",
            "/scan",
            "--odom-topic",
            "/odom",
            "--reference",
            "3",
            "--current",
            "6",
        ]
        .map(String::from)
        .to_vec()
    };
    refused(&strs(&cluster(bad)), &needles);
    refused(&strs(&icp_matching(bad)), &needles);
    // The plain file as today: two clusters (the object and the rest), nine pairs.
    let v = ok_json(&strs(&cluster(plain)));
    assert_eq!(v["clusters"].as_array().unwrap().len(), 2, "{v}");
    let v = ok_json(&strs(&icp_matching(plain)));
    assert_eq!(v["pairs"], 9);
    assert_eq!(v["not_converged"], 0);
    let dir = temp_dir("bad-crc");
    refused_everywhere(bad, CASE_TOPICS, &path(&dir, "out"), &needles);
    // One byte flipped inside a chunk of a copy of plain.mcap.
    let bytes = std::fs::read(plain).unwrap();
    let chunks = mcap_chunks(&bytes);
    assert_eq!(chunks.len(), 9);
    for (at, records) in [&chunks[1], &chunks[6]] {
        let mut damaged = bytes.clone();
        damaged[records.start + records.len() / 2] ^= 0x04;
        let copy = write_bytes(&dir, "flipped.mcap", &damaged);
        refused(
            &strs(&icp_matching(&copy)),
            &["flipped.mcap", &format!("chunk at byte {at}"), "damaged"],
        );
    }
}

#[test]
fn a_damaged_chunk_of_a_bag_written_here_exits_2_in_every_command() {
    let dir = temp_dir("own-crc");
    let bytes = mcap_bag(&drive(6), false, None);
    let good = write_bytes(&dir, "good.mcap", &bytes);
    for args in bag_commands(&good, DRIVE_TOPICS, &path(&dir, "out")) {
        ok(&strs(&args));
        let _ = std::fs::remove_dir_all(dir.join("out"));
    }
    let (at, records) = mcap_chunks(&bytes)[0].clone();
    for offset in [0, records.len() / 3, records.len() - 1] {
        let mut damaged = bytes.clone();
        damaged[records.start + offset] ^= 0x80;
        let bad = write_bytes(&dir, "bad.mcap", &damaged);
        refused_everywhere(
            &bad,
            DRIVE_TOPICS,
            &path(&dir, "out"),
            &[
                "bad.mcap",
                &format!("chunk at byte {at}"),
                "do not match its CRC",
            ],
        );
    }
}

// ---------------------------------------------------------------------------------
// scan-angle-range

#[test]
fn scan_angle_range_half_increment_exits_2_and_the_fencepost_reads_as_consistent() {
    let Some([consistent, fencepost, half]) = case_files(
        "scan-angle-range",
        ["consistent.bag", "fencepost.bag", "half_increment.bag"],
    ) else {
        return;
    };
    let clustering = |bag: &Path| -> Vec<String> {
        [
            "eval",
            "clustering",
            "--method",
            "cbd",
            "--bag",
            bag.to_str().unwrap(),
            "--scan-topic",
            "/scan",
            "--odom-topic",
            "/odom",
            "--ego-pose-topic",
            "/truth",
            "--object-pose-topic",
            "/object",
            "--object-footprint",
            "0.6,0.4,0,0",
            "--k",
            "3",
            "--json",
        ]
        .map(String::from)
        .to_vec()
    };
    let needles = [
        "half_increment.bag",
        "topic /scan",
        "message 1 ",
        "field `angle_max`",
        "angle_max 1.5707964 rad",
        "180 · 0.008726646",
        "do not fill",
    ];
    refused(&strs(&clustering(&half)), &needles);
    let a = ok_json(&strs(&clustering(&consistent)));
    let b = ok_json(&strs(&clustering(&fencepost)));
    assert!(a["v_measure_mean"].as_f64().unwrap() > 0.99, "{a}");
    assert_eq!(without_names(a), without_names(b));
    let dir = temp_dir("angle-range");
    let out = path(&dir, "out");
    refused_everywhere(half.to_str().unwrap(), CASE_TOPICS, &out, &needles);
    // Every command: the fencepost bag gives what the consistent one gives.
    same_results(
        consistent.to_str().unwrap(),
        fencepost.to_str().unwrap(),
        CASE_TOPICS,
        &out,
        &ALL,
    );
}

/// The records `a` and `b` written in each bag format: the file extension, `a`'s bytes
/// and `b`'s.
fn in_both_formats(a: &[Record], b: &[Record]) -> [(&'static str, Vec<u8>, Vec<u8>); 2] {
    [
        ("bag", ros1_bag(a), ros1_bag(b)),
        ("mcap", mcap_bag(a, false, None), mcap_bag(b, false, None)),
    ]
}

#[test]
fn angle_max_of_bags_written_here_one_increment_off_reads_more_exits_2() {
    let dir = temp_dir("own-angles");
    let out = path(&dir, "out");
    let end = ANGLE_MIN + ANGLE_INCREMENT * (BEAMS - 1) as f32;
    let consistent = write_bytes(&dir, "consistent.bag", &ros1_bag(&drive(6)));
    let off = drive_with_angles(6, |_| [ANGLE_MIN, end + ANGLE_INCREMENT, ANGLE_INCREMENT]);
    let bad = drive_with_angles(6, |k| {
        if k == 3 {
            [ANGLE_MIN, end, ANGLE_INCREMENT * 0.5]
        } else {
            [ANGLE_MIN, end, ANGLE_INCREMENT]
        }
    });
    for (name, off_bytes, bad_bytes) in in_both_formats(&off, &bad) {
        let fencepost = write_bytes(&dir, &format!("fencepost.{name}"), &off_bytes);
        same_results(&consistent, &fencepost, DRIVE_TOPICS, &out, &ALL);
        let file = format!("bad.{name}");
        let bad = write_bytes(&dir, &file, &bad_bytes);
        refused_everywhere(
            &bad,
            DRIVE_TOPICS,
            &out,
            &[
                &file,
                "topic /scan",
                "message 4 ",
                "field `angle_max`",
                &format!("angle_max {end} rad"),
                "do not fill",
            ],
        );
    }
}

// ---------------------------------------------------------------------------------
// scan-minus-inf

#[test]
fn minus_inf_bag_reads_as_plain_but_for_those_beams() {
    let Some([plain, minus]) = case_files("scan-minus-inf", ["plain.bag", "minus_inf.bag"]) else {
        return;
    };
    // The same bag with +Inf where minus_inf.bag has -Inf (a ROS 1 bag has no CRC).
    let dir = temp_dir("minus-inf");
    let mut bytes = std::fs::read(&minus).unwrap();
    let neg = f32::NEG_INFINITY.to_le_bytes();
    let mut patched = 0;
    for at in 0..bytes.len() - 3 {
        if bytes[at..at + 4] == neg {
            bytes[at..at + 4].copy_from_slice(&f32::INFINITY.to_le_bytes());
            patched += 1;
        }
    }
    assert_eq!(patched, 12 * 3, "beams 10-12 of 12 scans");
    let plus = write_bytes(&dir, "plus_inf.bag", &bytes);
    let matching = |bag: &str| without_names(ok_json(&strs(&icp_matching(bag))));
    let m = matching(minus.to_str().unwrap());
    let p = matching(plain.to_str().unwrap());
    // -Inf is exactly a beam without a return, as +Inf is.
    assert_eq!(m, matching(&plus));
    // And the plain bag's result but for those three beams of 181.
    assert_eq!(m["pairs"], p["pairs"]);
    assert_eq!(m["pairs"], 9);
    assert_eq!(m["not_converged"], p["not_converged"]);
    for (key, tolerance) in [
        ("translation_median", 0.01),
        ("translation_p90", 0.01),
        ("rotation_median", 0.005),
        ("rotation_p90", 0.01),
    ] {
        let (a, b) = (m[key].as_f64().unwrap(), p[key].as_f64().unwrap());
        assert!((a - b).abs() < tolerance, "{key}: {a} vs {b}");
    }
    // Every command reads it, as it reads the +Inf bag.
    same_results(
        minus.to_str().unwrap(),
        &plus,
        CASE_TOPICS,
        &path(&dir, "out"),
        &ALL,
    );
}

#[test]
fn minus_inf_in_bags_and_text_logs_written_here_is_a_beam_without_a_return() {
    let dir = temp_dir("own-minus-inf");
    let out = path(&dir, "out");
    // Bags: beams 20-24 of every scan -Inf, or +Inf: the same results everywhere.
    let with = |value: f32| -> Vec<Record> {
        let mut records = drive(6);
        for r in &mut records {
            if let Msg::Scan { ranges, .. } = &mut r.msg {
                ranges[20..25].fill(value);
            }
        }
        records
    };
    let (minus, plus) = (with(f32::NEG_INFINITY), with(f32::INFINITY));
    for (name, m, p) in in_both_formats(&minus, &plus) {
        let m = write_bytes(&dir, &format!("minus.{name}"), &m);
        let p = write_bytes(&dir, &format!("plus.{name}"), &p);
        same_results(&m, &p, DRIVE_TOPICS, &out, &ALL);
    }
    // CARMEN: two FLASER scans of a room, beams 30-32 -inf or inf.
    let deg = std::f64::consts::PI / 180.0;
    let room = [f64::NEG_INFINITY, 4.0, -4.0, 4.0];
    let carmen = |special: &str| {
        let mut text = String::new();
        for x in [0.0, 0.2] {
            let ranges = room_ranges(room, (x, 0.0, 0.0), 181, -90.0 * deg, deg);
            let line = flaser_line(&ranges, (x, 0.0, 0.0), 100.0 + x);
            let mut tokens: Vec<String> = line.split(' ').map(String::from).collect();
            for k in 30..33 {
                tokens[2 + k] = special.to_string();
            }
            text += &(tokens.join(" ") + "\n");
        }
        write(&dir, &format!("room{special}.clf"), &text)
    };
    let (m, p) = (carmen("-inf"), carmen("inf"));
    let a = without_names(ok_json(&one_pair("cluster", "--carmen", &m, "0", "1")));
    let b = without_names(ok_json(&one_pair("cluster", "--carmen", &p, "0", "1")));
    assert_eq!(a, b);
    assert_eq!(a["clusters"].as_array().unwrap().len(), 1, "{a}");
    let negative = carmen("-0.5");
    refused(
        &one_pair("cluster", "--carmen", &negative, "0", "1"),
        &["room-0.5.clf:1:", "range[30]", "negative"],
    );
    // leigh-gtm1 text logs (scans and odometry): beams 5-7 of every scan -inf or inf.
    let leigh = |special: &str| -> Vec<String> {
        let (mut scans, mut odometry) = (String::new(), String::new());
        for i in 0..6 {
            let t = 10.0 + 0.1 * i as f64;
            let ranges: Vec<String> = (0..60)
                .map(|k| {
                    if (5..8).contains(&k) {
                        special.to_string()
                    } else {
                        format!("{:.3}", 4.0 + 0.01 * k as f64)
                    }
                })
                .collect();
            scans += &format!(
                "SCAN {i} {t} {t} laser -1.0 0.0333 0.05 20.0 60 {}\n",
                ranges.join(" ")
            );
            odometry += &format!("ODOM {i} {t} {} 0 0\n", 0.05 * i as f64);
        }
        let sub = dir.join(format!("leigh{special}"));
        std::fs::create_dir_all(&sub).unwrap();
        vec![
            write(&sub, "scans.txt", &scans),
            write(&sub, "odom.txt", &odometry),
        ]
    };
    let run = |files: &[String]| {
        without_names(ok_json(&[
            "cluster",
            "--scans",
            &files[0],
            "--odometry",
            &files[1],
            "--reference",
            "1",
            "--current",
            "3",
        ]))
    };
    let (m, p) = (leigh("-inf"), leigh("inf"));
    assert_eq!(run(&m), run(&p));
    let negative = leigh("-1.5");
    refused(
        &[
            "cluster",
            "--scans",
            &negative[0],
            "--odometry",
            &negative[1],
            "--reference",
            "1",
            "--current",
            "3",
        ],
        &["scans.txt:1:", "range[5]", "negative"],
    );
}
