//! Hardening, second round: three kinds of bad input, each with the case files of
//! `../shared/cases` (skipped without the folder, fatal under CI=true) and inputs
//! written here.
//!
//! - MCAP CRCs (`mcap-bad-crc`): every CRC a file stores (chunk `uncompressed_crc`,
//!   data section, summary section, attachments) is checked; a mismatch is an error
//!   naming the file, the record's byte offset and both values; a CRC of 0 is one not
//!   written. A damaged zip entry is refused by its CRC too.
//! - Scan angle range (`scan-angle-range`): `angle_max` (and CARMEN's `ROBOTLASER1`
//!   `fov`) must agree with the beams to within one increment, the increment winning.
//! - REP 117 `-Inf` (`scan-minus-inf`): a beam without a return in every reader.

mod common;

use common::{content, drive_topics, refused, temp_dir, write};
use pgm_datasets::bag::synthetic::*;
use pgm_datasets::bag::{read_bag, BagTopics};
use pgm_datasets::carmen::{parse_carmen, CarmenOptions};
use pgm_datasets::leigh::parse_scans;
use pgm_datasets::testdata::shared_case_files;
use pgm_datasets::Error;
use std::path::Path;

/// The topics of the case bags.
fn case_topics() -> BagTopics {
    BagTopics {
        odometry: Some("/odom".into()),
        ego_pose: Some("/truth".into()),
        object_pose: Some("/object".into()),
        ..BagTopics::new("/scan")
    }
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

/// One top-level record of an MCAP file: opcode, byte, body byte.
#[derive(Clone, Copy, Debug)]
struct Rec {
    opcode: u8,
    at: usize,
    body: usize,
}

fn top_records(bytes: &[u8]) -> Vec<Rec> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() {
        let len = u64_at(bytes, at + 1) as usize;
        out.push(Rec {
            opcode: bytes[at],
            at,
            body: at + 9,
        });
        if bytes[at] == mcap::records::op::FOOTER {
            break;
        }
        at += 9 + len;
    }
    out
}

/// A chunk: its byte, the byte and length of its records, its CRC and compression.
struct ChunkAt {
    at: usize,
    records: usize,
    records_len: usize,
    crc: u32,
    crc_at: usize,
}

fn chunks(bytes: &[u8]) -> Vec<ChunkAt> {
    top_records(bytes)
        .into_iter()
        .filter(|r| r.opcode == mcap::records::op::CHUNK)
        .map(|r| {
            let c = u32_at(bytes, r.body + 28) as usize;
            ChunkAt {
                at: r.at,
                records: r.body + 40 + c,
                records_len: u64_at(bytes, r.body + 32 + c) as usize,
                crc: u32_at(bytes, r.body + 24),
                crc_at: r.body + 24,
            }
        })
        .collect()
}

// ---------------------------------------------------------------------------------
// MCAP CRCs

#[test]
fn mcap_bad_crc_case_is_refused_naming_the_chunk_and_both_crcs() {
    let Some([plain, bad]) =
        shared_case_files(["mcap-bad-crc/plain.mcap", "mcap-bad-crc/badcrc.mcap"])
    else {
        return;
    };
    let log = read_bag(&plain, &case_topics()).unwrap();
    assert_eq!(log.scans.len(), 12);
    refused(
        &bad,
        &case_topics(),
        &[
            "badcrc.mcap",
            "chunk at byte 18784",
            "uncompressed_crc 0x5a7e04fd",
            "0x280c6f30 computed",
            "damaged",
        ],
    );
    // A byte flipped anywhere inside any chunk's records of plain.mcap, copied here.
    let dir = temp_dir("cases", "plain-flips");
    let bytes = std::fs::read(&plain).unwrap();
    let found = chunks(&bytes);
    assert_eq!(found.len(), 9);
    for c in &found {
        for at in (c.records..c.records + c.records_len).step_by(331) {
            let mut damaged = bytes.clone();
            damaged[at] ^= 0x10;
            let p = write(&dir, "flipped.mcap", &damaged);
            refused(
                &p,
                &case_topics(),
                &[
                    &format!("chunk at byte {}", c.at),
                    &format!("uncompressed_crc {:#010x}", c.crc),
                ],
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn every_bit_flip_inside_an_uncompressed_chunk_is_refused() {
    let dir = temp_dir("cases", "flips");
    let records = drive(6);
    let bytes = mcap_bag(&records, false, None);
    let good = content(&read_bag(&write(&dir, "good.mcap", &bytes), &drive_topics()).unwrap());
    let found = chunks(&bytes);
    assert!(!found.is_empty());
    let mut tried = 0;
    for c in &found {
        assert_ne!(c.crc, 0, "the writer stores chunk CRCs");
        for at in (c.records..c.records + c.records_len).step_by(97) {
            for bit in [0, 3, 7] {
                let mut damaged = bytes.clone();
                damaged[at] ^= 1 << bit;
                let p = write(&dir, "flipped.mcap", &damaged);
                refused(
                    &p,
                    &drive_topics(),
                    &[
                        "flipped.mcap",
                        &format!("chunk at byte {}", c.at),
                        "do not match its CRC",
                        &format!("uncompressed_crc {:#010x}", c.crc),
                    ],
                );
                tried += 1;
            }
        }
    }
    assert!(tried > 100, "{tried}");
    // The untouched file still reads.
    let p = write(&dir, "again.mcap", &bytes);
    assert_eq!(content(&read_bag(&p, &drive_topics()).unwrap()), good);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn compressed_chunks_are_checked_after_decompression() {
    let dir = temp_dir("cases", "compressed");
    let records = drive(6);
    let plain = content(
        &read_bag(
            &write(&dir, "plain.mcap", &mcap_bag(&records, false, None)),
            &drive_topics(),
        )
        .unwrap(),
    );
    for (name, compression) in [
        ("zstd", mcap::Compression::Zstd),
        ("lz4", mcap::Compression::Lz4),
    ] {
        let bytes = mcap_bag(&records, false, Some(compression));
        let p = write(&dir, &format!("{name}.mcap"), &bytes);
        assert_eq!(content(&read_bag(&p, &drive_topics()).unwrap()), plain);
        // A stored CRC that the decompressed records do not give.
        let c = &chunks(&bytes)[0];
        let mut damaged = bytes.clone();
        damaged[c.crc_at] ^= 0x01;
        let p = write(&dir, &format!("{name}-crc.mcap"), &damaged);
        refused(
            &p,
            &drive_topics(),
            &[
                &format!("chunk at byte {}", c.at),
                &format!("uncompressed_crc {:#010x}", c.crc ^ 0x01),
                &format!("{:#010x} computed", c.crc),
                &format!("{name}-compressed"),
            ],
        );
        // Damaged compressed bytes: refused, naming the chunk (as a CRC mismatch or
        // as data that does not decompress).
        for at in (c.records + 16..c.records + c.records_len).step_by(211) {
            let mut damaged = bytes.clone();
            damaged[at] ^= 0x40;
            let p = write(&dir, &format!("{name}-data.mcap"), &damaged);
            refused(&p, &drive_topics(), &[&format!("chunk at byte {}", c.at)]);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_crc_of_zero_is_one_not_written() {
    let dir = temp_dir("cases", "zero-crc");
    let records = drive(4);
    let bytes = mcap_bag(&records, false, None);
    // Damaged records under a chunk CRC of 0 (the data section CRC rewritten to fit):
    // read as they are, as the specification says.
    let c = &chunks(&bytes)[0];
    let mut damaged = bytes.clone();
    damaged[c.crc_at..c.crc_at + 4].copy_from_slice(&[0; 4]);
    reseal_mcap(&mut damaged);
    let good = read_bag(&write(&dir, "zeroed.mcap", &damaged), &drive_topics()).unwrap();
    let name = b"base_link";
    let at = damaged[c.records..]
        .windows(name.len())
        .position(|w| w == name)
        .unwrap()
        + c.records;
    damaged[at] = b'B';
    reseal_mcap(&mut damaged);
    let log = read_bag(&write(&dir, "unchecked.mcap", &damaged), &drive_topics()).unwrap();
    assert_ne!(content(&log), content(&good));
    assert_eq!(log.odometry[0].child_frame, "Base_link");
    // A file written with no CRC at all reads as the one with them.
    let mut out = std::io::Cursor::new(Vec::new());
    {
        let mut w = mcap::WriteOptions::new()
            .profile("ros2")
            .calculate_chunk_crcs(false)
            .calculate_data_section_crc(false)
            .calculate_summary_section_crc(false)
            .create(&mut out)
            .unwrap();
        write_records(&mut w, &records);
        w.finish().unwrap();
    }
    let bytes = out.into_inner();
    assert!(chunks(&bytes).iter().all(|c| c.crc == 0));
    let p = write(&dir, "no-crc.mcap", &bytes);
    assert_eq!(
        content(&read_bag(&p, &drive_topics()).unwrap()),
        content(&good)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Writes `records` as ROS 2 CDR messages with the `mcap` crate's writer `w`.
fn write_records<W: std::io::Write + std::io::Seek>(w: &mut mcap::Writer<W>, records: &[Record]) {
    let mut channels = std::collections::BTreeMap::new();
    for (k, r) in records.iter().enumerate() {
        let channel = *channels
            .entry(r.topic)
            .or_insert_with(|| add_ros2_channel(w, r).unwrap());
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: channel,
                sequence: k as u32,
                log_time: r.time_ns,
                publish_time: r.time_ns,
            },
            &serialise(&r.msg, k as u32, Wire::Cdr { big_endian: false }),
        )
        .unwrap();
    }
}

#[test]
fn data_section_and_summary_crcs_are_checked() {
    let dir = temp_dir("cases", "sections");
    let bytes = mcap_bag(&drive(4), false, None);
    let recs = top_records(&bytes);
    let data_end = recs
        .iter()
        .find(|r| r.opcode == mcap::records::op::DATA_END)
        .unwrap();
    let footer = recs.last().unwrap();
    assert_eq!(footer.opcode, mcap::records::op::FOOTER);
    assert_ne!(u32_at(&bytes, data_end.body), 0, "the writer stores it");
    // The header record (outside every chunk) is covered by the data section CRC.
    let header = recs[0];
    assert_eq!(header.opcode, mcap::records::op::HEADER);
    let mut damaged = bytes.clone();
    damaged[header.body + 5] ^= 0x20;
    let p = write(&dir, "data.mcap", &damaged);
    refused(
        &p,
        &drive_topics(),
        &[
            "data.mcap",
            "data section does not match its CRC",
            &format!("data end record at byte {}", data_end.at),
            &format!("data_section_crc {:#010x}", u32_at(&bytes, data_end.body)),
        ],
    );
    // A summary record: the summary CRC in the footer.
    let summary = recs
        .iter()
        .find(|r| r.at > data_end.at && r.opcode == mcap::records::op::STATISTICS)
        .unwrap();
    let mut damaged = bytes.clone();
    damaged[summary.body] ^= 0x01;
    let p = write(&dir, "summary.mcap", &damaged);
    refused(
        &p,
        &drive_topics(),
        &[
            "summary section does not match its CRC",
            &format!("footer at byte {}", footer.at),
            &format!("summary_crc {:#010x}", u32_at(&bytes, footer.body + 16)),
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn attachment_crcs_are_checked() {
    let dir = temp_dir("cases", "attachment");
    let records = drive(3);
    let mut out = std::io::Cursor::new(Vec::new());
    {
        let mut w = mcap::WriteOptions::new()
            .profile("ros2")
            .create(&mut out)
            .unwrap();
        write_records(&mut w, &records);
        w.attach(&mcap::Attachment {
            log_time: 1,
            create_time: 2,
            name: "calibration.yaml".into(),
            media_type: "text/yaml".into(),
            data: std::borrow::Cow::Borrowed(b"laser: {x: 0.2}\n"),
        })
        .unwrap();
        w.finish().unwrap();
    }
    let bytes = out.into_inner();
    let p = write(&dir, "attached.mcap", &bytes);
    assert_eq!(read_bag(&p, &drive_topics()).unwrap().scans.len(), 3);
    let at = bytes.windows(6).position(|w| w == b"x: 0.2").unwrap();
    let mut damaged = bytes.clone();
    damaged[at + 3] = b'9';
    let p = write(&dir, "damaged.mcap", &damaged);
    let rec = top_records(&bytes)
        .into_iter()
        .find(|r| r.opcode == mcap::records::op::ATTACHMENT)
        .unwrap();
    refused(
        &p,
        &drive_topics(),
        &[
            "damaged.mcap",
            &format!("at byte {}", rec.at),
            "attachment \"calibration.yaml\"",
            "damaged",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_damaged_zip_entry_is_refused_by_its_crc() {
    let dir = temp_dir("cases", "zip");
    let bag = ros1_bag(&drive(3));
    let zipped = dir.join("drive.bag.zip");
    {
        let mut z = zip::ZipWriter::new(std::fs::File::create(&zipped).unwrap());
        z.start_file(
            "drive.bag",
            zip::write::SimpleFileOptions::default()
                .compression_method(zip::CompressionMethod::Stored),
        )
        .unwrap();
        std::io::Write::write_all(&mut z, &bag).unwrap();
        z.finish().unwrap();
    }
    assert_eq!(read_bag(&zipped, &drive_topics()).unwrap().scans.len(), 3);
    let mut bytes = std::fs::read(&zipped).unwrap();
    let at = bytes.windows(5).position(|w| w == b"laser").unwrap();
    bytes[at] = b'L';
    let p = write(&dir, "damaged.bag.zip", &bytes);
    refused(
        &p,
        &drive_topics(),
        &["damaged.bag.zip", "zip entry drive.bag"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

// ---------------------------------------------------------------------------------
// Scan angle range

#[test]
fn scan_angle_range_cases_fencepost_reads_as_consistent_half_increment_is_refused() {
    let Some([consistent, fencepost, half]) = shared_case_files([
        "scan-angle-range/consistent.bag",
        "scan-angle-range/fencepost.bag",
        "scan-angle-range/half_increment.bag",
    ]) else {
        return;
    };
    let a = read_bag(&consistent, &case_topics()).unwrap();
    let b = read_bag(&fencepost, &case_topics()).unwrap();
    assert_eq!(content(&a), content(&b));
    let first = &a.scans[0].scan;
    assert_eq!(first.len(), 181);
    assert!((first.angles[0] + 90f64.to_radians()).abs() < 1e-6);
    assert!((first.angles[180] - 90f64.to_radians()).abs() < 1e-6);
    refused(
        &half,
        &case_topics(),
        &[
            "half_increment.bag",
            "topic /scan",
            "message 1 ",
            "field `angle_max`",
            "angle_max 1.5707964 rad",
            "0.008726646",
            "do not fill",
        ],
    );
}

#[test]
fn angle_max_within_one_increment_reads_as_consistent_and_beyond_is_refused() {
    let dir = temp_dir("cases", "angles");
    let consistent =
        content(&read_bag(&write(&dir, "c.bag", &ros1_bag(&drive(5))), &drive_topics()).unwrap());
    let end = ANGLE_MIN + ANGLE_INCREMENT * (BEAMS - 1) as f32;
    // One increment too far (the driver off-by-one), one short, half of one: the
    // increment wins, the scans are the consistent ones, in both containers.
    for delta in [1.0f32, -1.0, 0.5, 0.999] {
        let records = drive_with_angles(5, |_| {
            [ANGLE_MIN, end + delta * ANGLE_INCREMENT, ANGLE_INCREMENT]
        });
        for (name, bytes) in [
            ("off.bag", ros1_bag(&records)),
            ("off.mcap", mcap_bag(&records, false, None)),
        ] {
            let log = read_bag(&write(&dir, name, &bytes), &drive_topics()).unwrap();
            assert_eq!(content(&log), consistent, "{name}, {delta} increments");
        }
    }
    // Beyond one increment: the third scan only, refused naming it and both values.
    let cases: [(&str, [f32; 3]); 4] = [
        (
            "1.5 increments",
            [ANGLE_MIN, end + 1.5 * ANGLE_INCREMENT, ANGLE_INCREMENT],
        ),
        (
            "2 short",
            [ANGLE_MIN, end - 2.0 * ANGLE_INCREMENT, ANGLE_INCREMENT],
        ),
        (
            "half the increment",
            [ANGLE_MIN, end, ANGLE_INCREMENT / 2.0],
        ),
        ("reversed", [ANGLE_MIN, -end, ANGLE_INCREMENT]),
    ];
    for (what, bad) in cases {
        let records = drive_with_angles(5, |k| {
            if k == 2 {
                bad
            } else {
                [ANGLE_MIN, end, ANGLE_INCREMENT]
            }
        });
        let last = f64::from(ANGLE_MIN) + 180.0 * f64::from(bad[2]);
        for (name, bytes) in [
            ("bad.bag", ros1_bag(&records)),
            ("bad.mcap", mcap_bag(&records, false, None)),
        ] {
            let p = write(&dir, name, &bytes);
            let text = refused(
                &p,
                &drive_topics(),
                &[
                    name,
                    "topic /scan",
                    "message 3 ",
                    "field `angle_max`",
                    &format!("angle_max {} rad", bad[1]),
                    "do not fill",
                ],
            );
            // The last beam's angle, to float32 precision.
            let stated = text
                .split(" rad (")
                .nth(1)
                .and_then(|t| t.split("= ").last())
                .and_then(|t| t.parse::<f64>().ok())
                .unwrap_or_else(|| panic!("{what}: no last beam angle in {text}"));
            assert!((stated - last).abs() < 1e-5, "{what}: {text}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn robotlaser1_fov_must_agree_with_its_beams() {
    let line = |fov: &str, res: &str| {
        format!(
            "ROBOTLASER1 0 -1.5 {fov} {res} 50.0 0.01 0 4 1 2 3 4 0 0 0 0 0 0 0 0 0 0 0 0 9.0 x 7.0"
        )
    };
    let carmen = |text: &str| parse_carmen(Path::new("log.clf"), text, CarmenOptions::default());
    // 4 beams at 1 rad: 3 rad, or 4 (the last beam dropped), or 2; the resolution wins.
    for fov in ["3.0", "4.0", "2.0", "3.5"] {
        let log = carmen(&line(fov, "1.0")).unwrap();
        assert_eq!(
            log.scans[0].scan.angles,
            vec![-1.5, -0.5, 0.5, 1.5],
            "{fov}"
        );
    }
    // Clockwise scans state a positive field of view.
    assert!(carmen(&line("3.0", "-1.0")).is_ok());
    for (fov, res) in [("1.5", "1.0"), ("3.0", "0.5"), ("5.5", "1.0")] {
        let err = carmen(&line(fov, res)).unwrap_err();
        let text = err.to_string();
        match err {
            Error::Field { line, field, .. } => assert_eq!((line, field.as_str()), (1, "fov")),
            other => panic!("{other:?}"),
        }
        assert!(text.starts_with("log.clf:1:"), "{text}");
        assert!(text.contains(fov) && text.contains(res), "{text}");
        assert!(text.contains("do not fill"), "{text}");
    }
}

// ---------------------------------------------------------------------------------
// REP 117: -Inf

#[test]
fn minus_inf_case_reads_as_plain_but_for_those_beams() {
    let Some([plain, minus]) =
        shared_case_files(["scan-minus-inf/plain.bag", "scan-minus-inf/minus_inf.bag"])
    else {
        return;
    };
    let a = read_bag(&plain, &case_topics()).unwrap();
    let b = read_bag(&minus, &case_topics()).unwrap();
    assert_eq!(a.scans.len(), b.scans.len());
    assert_eq!(
        (&a.odometry, &a.ego_poses, &a.object_poses),
        (&b.odometry, &b.ego_poses, &b.object_poses)
    );
    for (x, y) in a.scans.iter().zip(&b.scans) {
        assert_eq!((x.number, x.stamp), (y.number, y.stamp));
        assert_eq!(x.scan.angles, y.scan.angles);
        for k in 0..x.scan.len() {
            if (10..=12).contains(&k) {
                assert!(!y.scan.valid[k], "scan {} beam {k}", y.number);
                assert_eq!(y.scan.ranges[k], 0.0);
            } else {
                assert_eq!(x.scan.ranges[k], y.scan.ranges[k]);
                assert_eq!(x.scan.valid[k], y.scan.valid[k]);
            }
        }
    }
}

#[test]
fn rep117_special_ranges_are_beams_without_a_return_in_every_reader() {
    let dir = temp_dir("cases", "rep117");
    // ROS 1 and ROS 2: beams 3, 4, 5 of every scan -Inf, +Inf, NaN.
    let special = [f32::NEG_INFINITY, f32::INFINITY, f32::NAN];
    let mut records = drive(4);
    let plain = records.clone();
    for r in &mut records {
        if let Msg::Scan { ranges, .. } = &mut r.msg {
            ranges[3..6].copy_from_slice(&special);
        }
    }
    let reference = read_bag(
        &write(&dir, "plain.bag", &ros1_bag(&plain)),
        &drive_topics(),
    )
    .unwrap();
    for (name, bytes) in [
        ("special.bag", ros1_bag(&records)),
        ("special.mcap", mcap_bag(&records, false, None)),
        ("special-be.mcap", mcap_bag(&records, true, None)),
    ] {
        let log = read_bag(&write(&dir, name, &bytes), &drive_topics()).unwrap();
        for (x, y) in reference.scans.iter().zip(&log.scans) {
            for k in 0..BEAMS {
                if (3..6).contains(&k) {
                    assert!(
                        !y.scan.valid[k] && y.scan.ranges[k] == 0.0,
                        "{name} beam {k}"
                    );
                } else {
                    assert_eq!(
                        (x.scan.ranges[k], x.scan.valid[k]),
                        (y.scan.ranges[k], y.scan.valid[k])
                    );
                }
            }
        }
    }
    // A finite negative range is still an error, naming the message and beam.
    for r in &mut records {
        if let Msg::Scan { ranges, .. } = &mut r.msg {
            ranges[7] = -0.5;
        }
    }
    for (name, bytes) in [
        ("negative.bag", ros1_bag(&records)),
        ("negative.mcap", mcap_bag(&records, false, None)),
    ] {
        refused(
            &write(&dir, name, &bytes),
            &drive_topics(),
            &[
                name,
                "message 1 ",
                "field `ranges[7]`",
                "negative range -0.5",
            ],
        );
    }
    // leigh-gtm1 text logs.
    let scans = parse_scans(
        Path::new("scans.txt"),
        "SCAN 0 1.0 1.0 laser -1.0 0.5 0.1 10.0 5 1.0 -inf inf nan 2.0\n",
    )
    .unwrap();
    assert_eq!(
        scans.scans[0].scan.valid,
        vec![true, false, false, false, true]
    );
    assert_eq!(scans.scans[0].scan.ranges, vec![1.0, 0.0, 0.0, 0.0, 2.0]);
    let err = parse_scans(
        Path::new("scans.txt"),
        "SCAN 0 1.0 1.0 laser -1.0 0.5 0.1 10.0 2 1.0 -0.5\n",
    )
    .unwrap_err();
    assert!(
        matches!(&err, Error::Field { field, .. } if field == "range[1]"),
        "{err}"
    );
    // CARMEN: FLASER and ROBOTLASER1.
    let carmen = |text: &str| parse_carmen(Path::new("log.clf"), text, CarmenOptions::default());
    let log = carmen(
        "FLASER 4 1.0 -inf inf nan 0 0 0 0 0 0 1.0 host 1.0\n\
         ROBOTLASER1 0 -1.5 3.0 1.0 50.0 0.01 0 4 1.0 -inf inf nan 0 0 0 0 0 0 0 0 0 0 0 0 9.0 x 7.0\n",
    )
    .unwrap();
    for s in &log.scans {
        assert_eq!(s.scan.valid, vec![true, false, false, false]);
        assert_eq!(s.scan.ranges, vec![1.0, 0.0, 0.0, 0.0]);
    }
    assert!(carmen("FLASER 2 1.0 -0.5 0 0 0 0 0 0 1.0 host 1.0").is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}
