//! Reader for CARMEN logs (the `.clf` / `.log` text format of the CARMEN robot
//! toolkit, as used by the Kümmerle et al. SLAM benchmark and the FLIRT logs).
//!
//! Understood lines (whitespace-separated, one record a line):
//!
//! - `FLASER n r_1 … r_n x y theta odom_x odom_y odom_theta ipc_timestamp hostname logger_timestamp`:
//!   a front laser scan. CARMEN's FLASER carries no angles: the beams span 180°
//!   starting at −90°, with `π/(n−1)` between beams for an odd `n` (361 beams at 0.5°,
//!   181 at 1°) and `π/n` for an even `n` (180 beams at 1°). `x y theta` is the laser
//!   pose and `odom_*` the robot's odometry pose; the laser offset on the robot is
//!   `inverse(odom) ∘ laser`. FLASER has no maximum range: ranges at or above
//!   [`CarmenOptions::flaser_max_range`] (default 80 m, the SICK LMS limit; the
//!   "no return" value in these logs is 81.91) are beams without a return.
//! - `ROBOTLASER1 type start_angle fov angular_res max_range accuracy remission_mode n r_1 … r_n
//!   n_rem rem_1 … rem_n_rem laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
//!   forward_safety side_safety turn_axis ipc_timestamp hostname logger_timestamp`:
//!   beam `k` at `start_angle + k·angular_res`; a return when `0 < r < max_range`.
//!   The robot pose is stored as the scan's odometry, the laser offset is
//!   `inverse(robot) ∘ laser`.
//! - `ODOM x y theta tv rv accel ipc_timestamp hostname logger_timestamp`: odometry.
//! - `VERTEX2 id x y theta`: a (SLAM-corrected) robot pose; it belongs to the laser
//!   line that follows it (the convention of the FLIRT logs).
//!
//! Every other line (comments `#…`, `PARAM`, `EDGE2`, `RAWLASER*`, …) is skipped and
//! counted by its first word in [`CarmenLog::skipped`]; blank lines are ignored.
//!
//! A malformed line of an understood type is an [`Error`](crate::Error) naming the file, the 1-based
//! line, the field and its text: a field count that disagrees with the declared
//! number of beams, a non-numeric or non-finite value (`nan` is an error here: CARMEN
//! writes no-returns as the maximum range), or a negative range.

use crate::error::Result;
use crate::text::{read_text, Fields};
use pgm_features::{Pose2, Scan};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

/// Reader options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CarmenOptions {
    /// Maximum range for FLASER lines, which do not state one (metres).
    pub flaser_max_range: f64,
}

impl Default for CarmenOptions {
    fn default() -> Self {
        Self {
            flaser_max_range: 80.0,
        }
    }
}

/// A laser scan of the log with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct LogScan {
    /// The scan (timestamp = `ipc_timestamp`).
    pub scan: Scan,
    /// 1-based line number of the laser line.
    pub line: usize,
    /// The `VERTEX2` line right before this scan, if any.
    pub vertex: Option<Vertex>,
}

/// A `VERTEX2` record: a robot pose of a pose graph.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex {
    /// Vertex id.
    pub id: u64,
    /// Robot pose.
    pub pose: Pose2,
    /// 1-based line number.
    pub line: usize,
}

/// An `ODOM` record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryRecord {
    /// `ipc_timestamp` in seconds.
    pub timestamp: f64,
    /// Odometry pose of the robot.
    pub pose: Pose2,
    /// 1-based line number.
    pub line: usize,
}

/// The contents of a CARMEN log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CarmenLog {
    /// Laser scans (FLASER and ROBOTLASER1) in file order.
    pub scans: Vec<LogScan>,
    /// ODOM records in file order.
    pub odometry: Vec<OdometryRecord>,
    /// VERTEX2 records in file order.
    pub vertices: Vec<Vertex>,
    /// Number of skipped lines per first word.
    pub skipped: BTreeMap<String, usize>,
}

impl CarmenLog {
    /// Total number of skipped lines.
    pub fn skipped_lines(&self) -> usize {
        self.skipped.values().sum()
    }
}

/// Reads a CARMEN log with default options.
pub fn read_carmen(path: impl AsRef<Path>) -> Result<CarmenLog> {
    read_carmen_with(path, CarmenOptions::default())
}

/// Reads a CARMEN log.
pub fn read_carmen_with(path: impl AsRef<Path>, options: CarmenOptions) -> Result<CarmenLog> {
    let path = path.as_ref();
    let text = read_text(path)?;
    parse_carmen(path, &text, options)
}

/// Parses the text of a CARMEN log; `path` is only used in error messages.
pub fn parse_carmen(path: &Path, text: &str, options: CarmenOptions) -> Result<CarmenLog> {
    let mut log = CarmenLog::default();
    let mut pending_vertex: Option<Vertex> = None;
    for (index, line_text) in text.lines().enumerate() {
        let fields = Fields::new(path, index + 1, line_text);
        let Some(kind) = fields.tokens.first().copied() else {
            continue;
        };
        match kind {
            "FLASER" => {
                let scan = parse_flaser(&fields, options)?;
                log.scans.push(LogScan {
                    scan,
                    line: fields.line,
                    vertex: pending_vertex.take(),
                });
            }
            "ROBOTLASER1" => {
                let scan = parse_robotlaser1(&fields)?;
                log.scans.push(LogScan {
                    scan,
                    line: fields.line,
                    vertex: pending_vertex.take(),
                });
            }
            "ODOM" => log.odometry.push(parse_odom(&fields)?),
            "VERTEX2" => {
                let vertex = parse_vertex(&fields)?;
                log.vertices.push(vertex);
                pending_vertex = Some(vertex);
            }
            other => *log.skipped.entry(other.to_string()).or_insert(0) += 1,
        }
    }
    Ok(log)
}

/// Parses `n` ranges starting at token `first`; a return when `0 < r < max_range`.
fn parse_ranges(
    fields: &Fields<'_>,
    first: usize,
    n: usize,
    max_range: f64,
    expected: usize,
) -> Result<(Vec<f64>, Vec<bool>)> {
    let mut ranges = Vec::with_capacity(n);
    let mut valid = Vec::with_capacity(n);
    for k in 0..n {
        let name = format!("range[{k}]");
        let r = fields.finite(first + k, &name, expected)?;
        if r < 0.0 {
            return Err(fields.error(&name, fields.tokens[first + k], "negative range"));
        }
        ranges.push(r);
        valid.push(r > 0.0 && r < max_range);
    }
    Ok((ranges, valid))
}

fn parse_pose(
    fields: &Fields<'_>,
    first: usize,
    names: [&str; 3],
    expected: usize,
) -> Result<Pose2> {
    Ok(Pose2::new(
        fields.finite(first, names[0], expected)?,
        fields.finite(first + 1, names[1], expected)?,
        fields.finite(first + 2, names[2], expected)?,
    ))
}

const FLASER_TAIL: [&str; 9] = [
    "x",
    "y",
    "theta",
    "odom_x",
    "odom_y",
    "odom_theta",
    "ipc_timestamp",
    "hostname",
    "logger_timestamp",
];

fn parse_flaser(fields: &Fields<'_>, options: CarmenOptions) -> Result<Scan> {
    let n = fields.count(1, "n", 2)?;
    let expected = 2 + n + FLASER_TAIL.len();
    fields.expect_len(expected, &format!("FLASER declares n = {n} ranges"), |i| {
        if i < 2 + n {
            format!("range[{}]", i - 2)
        } else {
            FLASER_TAIL[i - 2 - n].to_string()
        }
    })?;
    let (ranges, valid) = parse_ranges(fields, 2, n, options.flaser_max_range, expected)?;
    let t = 2 + n;
    let laser = parse_pose(fields, t, ["x", "y", "theta"], expected)?;
    let odometry = parse_pose(fields, t + 3, ["odom_x", "odom_y", "odom_theta"], expected)?;
    let timestamp = fields.finite(t + 6, "ipc_timestamp", expected)?;
    fields.finite(t + 8, "logger_timestamp", expected)?;
    let step = if n % 2 == 1 && n > 1 {
        PI / (n - 1) as f64
    } else {
        PI / n.max(1) as f64
    };
    let angles = (0..n).map(|k| -PI / 2.0 + k as f64 * step).collect();
    Ok(Scan {
        timestamp,
        angles,
        ranges,
        valid,
        max_range: options.flaser_max_range,
        odometry: Some(odometry),
        laser_offset: odometry.between(&laser),
    })
}

const ROBOTLASER1_TAIL: [&str; 14] = [
    "laser_x",
    "laser_y",
    "laser_theta",
    "robot_x",
    "robot_y",
    "robot_theta",
    "tv",
    "rv",
    "forward_safety",
    "side_safety",
    "turn_axis",
    "ipc_timestamp",
    "hostname",
    "logger_timestamp",
];

fn parse_robotlaser1(fields: &Fields<'_>) -> Result<Scan> {
    let head = 9;
    let start_angle = fields.finite(2, "start_angle", head)?;
    fields.finite(3, "fov", head)?;
    let resolution = fields.finite(4, "angular_res", head)?;
    let max_range = fields.finite(5, "max_range", head)?;
    if max_range <= 0.0 {
        return Err(fields.error("max_range", fields.tokens[5], "must be positive"));
    }
    let n = fields.count(8, "n", head)?;
    let n_rem = fields.count(9 + n, "n_rem", 10 + n)?;
    let expected = 10 + n + n_rem + ROBOTLASER1_TAIL.len();
    fields.expect_len(
        expected,
        &format!("ROBOTLASER1 declares n = {n} ranges and n_rem = {n_rem} remissions"),
        |i| {
            if i < 10 + n + n_rem {
                format!("remission[{}]", i - 10 - n)
            } else {
                ROBOTLASER1_TAIL[i - 10 - n - n_rem].to_string()
            }
        },
    )?;
    let (ranges, valid) = parse_ranges(fields, 9, n, max_range, expected)?;
    for k in 0..n_rem {
        fields.finite(10 + n + k, &format!("remission[{k}]"), expected)?;
    }
    let t = 10 + n + n_rem;
    let laser = parse_pose(fields, t, ["laser_x", "laser_y", "laser_theta"], expected)?;
    let robot = parse_pose(
        fields,
        t + 3,
        ["robot_x", "robot_y", "robot_theta"],
        expected,
    )?;
    for (k, name) in ROBOTLASER1_TAIL.iter().enumerate().take(11).skip(6) {
        fields.finite(t + k, name, expected)?;
    }
    let timestamp = fields.finite(t + 11, "ipc_timestamp", expected)?;
    fields.finite(t + 13, "logger_timestamp", expected)?;
    let angles = (0..n)
        .map(|k| start_angle + k as f64 * resolution)
        .collect();
    Ok(Scan {
        timestamp,
        angles,
        ranges,
        valid,
        max_range,
        odometry: Some(robot),
        laser_offset: robot.between(&laser),
    })
}

fn parse_odom(fields: &Fields<'_>) -> Result<OdometryRecord> {
    const NAMES: [&str; 10] = [
        "ODOM",
        "x",
        "y",
        "theta",
        "tv",
        "rv",
        "accel",
        "ipc_timestamp",
        "hostname",
        "logger_timestamp",
    ];
    fields.expect_len(NAMES.len(), "ODOM has 9 fields", |i| NAMES[i].to_string())?;
    let pose = parse_pose(fields, 1, ["x", "y", "theta"], NAMES.len())?;
    for (k, name) in NAMES.iter().enumerate().take(7).skip(4) {
        fields.finite(k, name, NAMES.len())?;
    }
    let timestamp = fields.finite(7, "ipc_timestamp", NAMES.len())?;
    fields.finite(9, "logger_timestamp", NAMES.len())?;
    Ok(OdometryRecord {
        timestamp,
        pose,
        line: fields.line,
    })
}

fn parse_vertex(fields: &Fields<'_>) -> Result<Vertex> {
    const NAMES: [&str; 5] = ["VERTEX2", "id", "x", "y", "theta"];
    fields.expect_len(NAMES.len(), "VERTEX2 has 4 fields", |i| {
        NAMES[i].to_string()
    })?;
    let raw = fields.tokens[1];
    let id: u64 = raw
        .parse()
        .map_err(|_| fields.error("id", raw, "not a non-negative integer"))?;
    Ok(Vertex {
        id,
        pose: parse_pose(fields, 2, ["x", "y", "theta"], NAMES.len())?,
        line: fields.line,
    })
}
