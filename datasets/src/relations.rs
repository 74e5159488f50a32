//! Reader for the relation files of the Kümmerle et al. SLAM benchmark
//! ("On measuring the accuracy of SLAM algorithms", Autonomous Robots 27(4), 2009).
//!
//! One relation a line: `t1 t2 x y z roll pitch yaw`, the true relative pose
//! `inverse(pose(t1)) ∘ pose(t2)` of the robot, expressed in the robot frame at `t1`;
//! `t1` and `t2` are laser time stamps of the log. Only `x`, `y` and `yaw` are used
//! (the other three must still be finite numbers). Blank lines and lines starting
//! with `#` are skipped. Time stamps, translations and angles beyond
//! [`limits`](crate::error::limits) are errors naming file, line and field.

use crate::error::{Error, Result};
use crate::text::{read_text, Fields};
use pgm_scan::Pose2;
use std::path::Path;

/// One ground-truth relation between two time stamps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relation {
    /// Time stamp of the first (reference) scan.
    pub t1: f64,
    /// Time stamp of the second (current) scan.
    pub t2: f64,
    /// `inverse(pose(t1)) ∘ pose(t2)` in the robot frame at `t1`.
    pub motion: Pose2,
    /// 1-based line number.
    pub line: usize,
}

const NAMES: [&str; 8] = ["t1", "t2", "x", "y", "z", "roll", "pitch", "yaw"];

/// Reads a `.relations` file.
pub fn read_relations(path: impl AsRef<Path>) -> Result<Vec<Relation>> {
    let path = path.as_ref();
    let text = read_text(path)?;
    parse_relations(path, &text)
}

/// Parses the text of a `.relations` file; `path` is only used in error messages.
pub fn parse_relations(path: &Path, text: &str) -> Result<Vec<Relation>> {
    let mut relations = Vec::new();
    for (index, line_text) in text.lines().enumerate() {
        let trimmed = line_text.trim_start();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let fields = Fields::new(path, index + 1, line_text);
        fields.expect_len(NAMES.len(), "a relation has 8 fields", |i| {
            NAMES.get(i).unwrap_or(&"?").to_string()
        })?;
        let mut values = [0.0; 8];
        for (k, name) in NAMES.iter().enumerate() {
            values[k] = match k {
                0 | 1 => fields.timestamp(k, name, NAMES.len())?,
                2..=4 => fields.position(k, name, NAMES.len())?,
                _ => fields.heading(k, name, NAMES.len())?,
            };
        }
        if (values[0] - values[1]).abs() < SAME_SCAN {
            return Err(Error::Invalid {
                path: path.to_path_buf(),
                field: format!("line {}: t2", fields.line),
                problem: format!(
                    "{} is t1 ({}): a relation between a scan and itself",
                    values[1], values[0]
                ),
            });
        }
        relations.push(Relation {
            t1: values[0],
            t2: values[1],
            motion: Pose2::new(values[2], values[3], values[7]),
            line: fields.line,
        });
    }
    Ok(relations)
}

/// Stamps closer than this (s) name the same scan (the data README's matching
/// tolerance).
const SAME_SCAN: f64 = 1e-4;

/// `relations` with each pair of scans once: a relation that repeats an earlier one
/// (both stamps within 1e-4 s) with the same motion (within 1e-9) is dropped, and its
/// line and the first one's are returned, so that it is not scored twice (mit-csail's
/// lines 1098 and 1099 are one relation written twice).
///
/// # Errors
/// [`Error::Invalid`] naming both lines when a repeated relation has another motion:
/// the file says two things of one pair of scans.
pub fn dedupe_relations(path: &Path, relations: Vec<Relation>) -> Result<Deduplicated> {
    let key = |t: f64| (t / SAME_SCAN).round() as i64;
    let mut seen: std::collections::HashMap<(i64, i64), usize> = std::collections::HashMap::new();
    let mut kept: Vec<Relation> = Vec::with_capacity(relations.len());
    let mut dropped = Vec::new();
    for r in relations {
        match seen.get(&(key(r.t1), key(r.t2))) {
            Some(&k) => {
                let first = &kept[k];
                let same = first.motion.translation_error(&r.motion) < 1e-9
                    && first.motion.rotation_error(&r.motion) < 1e-9;
                if !same {
                    return Err(Error::Invalid {
                        path: path.to_path_buf(),
                        field: format!("line {}", r.line),
                        problem: format!(
                            "the relation between {} and {} is also on line {} with another \
                             motion",
                            r.t1, r.t2, first.line
                        ),
                    });
                }
                dropped.push((first.line, r.line));
            }
            None => {
                seen.insert((key(r.t1), key(r.t2)), kept.len());
                kept.push(r);
            }
        }
    }
    Ok(Deduplicated {
        relations: kept,
        repeated: dropped,
    })
}

/// What [`dedupe_relations`] kept and dropped.
#[derive(Clone, Debug, PartialEq)]
pub struct Deduplicated {
    /// Each pair of scans once, in file order.
    pub relations: Vec<Relation>,
    /// `(first line, repeating line)` of each relation dropped.
    pub repeated: Vec<(usize, usize)>,
}
