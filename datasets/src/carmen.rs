//! Reader for CARMEN logs (the `.clf` / `.log` text format of the CARMEN robot
//! toolkit, as used by the Kümmerle et al. SLAM benchmark and the FLIRT logs).
//!
//! Understood lines (whitespace-separated, one record a line):
//!
//! - `FLASER n r_1 … r_n x y theta odom_x odom_y odom_theta ipc_timestamp hostname logger_timestamp`:
//!   a front laser scan. FLASER carries no angles; they come from, in this order:
//!   the reader's options ([`CarmenOptions::front_laser_fov`],
//!   [`CarmenOptions::front_laser_resolution`], degrees); the log's own `PARAM` lines
//!   ([`FOV_PARAMS`], [`RESOLUTION_PARAMS`], degrees, as CARMEN's `carmen.ini` writes
//!   them); CARMEN's rule for the beam count ([`carmen_rule`]). The first beam points
//!   along −90° (the laser's right), as CARMEN's own log reader places every FLASER
//!   scan, unless [`CarmenOptions::front_laser_start`] says otherwise. A field of view
//!   and a resolution that disagree with `n` (CARMEN's lasers send `1 + fov/resolution`
//!   beams, or one less when the last is dropped) are an error
//!   naming the line. `x y theta` is the laser pose and `odom_*` the robot's odometry
//!   pose; the laser offset on the robot is `inverse(odom) ∘ laser`. FLASER has no
//!   maximum range: ranges at or above [`CarmenOptions::flaser_max_range`] (default
//!   80 m, the SICK LMS limit; the "no return" value in these logs is 81.91) are
//!   beams without a return.
//! - `ROBOTLASER1 type start_angle fov angular_res max_range accuracy remission_mode n r_1 … r_n
//!   n_rem rem_1 … rem_n_rem laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
//!   forward_safety side_safety turn_axis ipc_timestamp hostname logger_timestamp`:
//!   beam `k` at `start_angle + k·angular_res`; a return when `0 < r < max_range`.
//!   `fov` must agree with `(n − 1)·|angular_res|` to within one increment (intel-lab's
//!   180 beams at 1° state 180°: the last beam dropped); beyond that the line is an
//!   error, within it the resolution wins ([`crate::beams`]).
//!   The robot pose is stored as the scan's odometry, the laser offset is
//!   `inverse(robot) ∘ laser`.
//! - `ODOM x y theta tv rv accel ipc_timestamp hostname logger_timestamp`: odometry.
//! - `VERTEX2 id x y theta`: a (SLAM-corrected) robot pose; it belongs to the laser
//!   line that follows it (the convention of the FLIRT logs).
//!
//! - `PARAM name value …`: a parameter; kept in [`CarmenLog::params`] (the laser ones
//!   above set the FLASER geometry).
//!
//! Every other line (comments `#…`, `EDGE2`, `RAWLASER*`, `RLASER`, …) is skipped and
//! counted by its first word in [`CarmenLog::skipped`]; blank lines are ignored.
//!
//! Ranges: `nan`, `inf` and `-inf` (ROS REP 117's "too close", which a log converted
//! from a ROS bag carries) are beams without a return (stored as range 0, invalid), as
//! [`Scan`] and [`crate::beams`] document; another negative range is an error.
//!
//! A malformed line of an understood type is an [`Error`] naming the
//! file, the 1-based line, the field and its text: a field count that disagrees with
//! the declared number of beams (a declared count is never trusted beyond the line
//! that holds it), a scan with no beam, a non-numeric or non-finite pose or time, a
//! negative range, an angular resolution of 0 or a field of view beyond a full turn,
//! and values that parse but mean nothing (a position, range or time beyond
//! [`limits`], such as a pose of 1e300).
//!
//! # CARMEN's rule for the beam count
//!
//! Without options or `PARAM` lines, the angles follow CARMEN's own guess for logs
//! that do not state them, `carmen_laser_guess_fov` and
//! `carmen_laser_guess_angle_increment` in `src/logger/readlog.c` of CARMEN (for
//! example in the LCAD-UFES/carmen_lcad repository):
//!
//! | beams | field of view | resolution |
//! |---:|---:|---:|
//! | 181 | 180° | 1° |
//! | 180 | 179° (last beam dropped) | 1° |
//! | 361 | 180° | 0.5° |
//! | 360 | 179.5° (last beam dropped) | 0.5° |
//! | 401 | 100° | 0.25° |
//! | 400 | 99.75° (last beam dropped) | 0.25° |
//! | other `n` | 180° | 180°/(n−1) |
//!
//! and `readlog.c` starts every FLASER scan at −90° (`start_angle = -M_PI / 2`),
//! whatever its field of view: a 401-beam scan covers −90° to +10°. The same reader
//! applies here, so a log reads the same in CARMEN and in `pgm`; a laser mounted
//! otherwise is described with [`CarmenOptions::front_laser_start`].

use crate::error::{limits, Error, Result};
use crate::stamps::{self, StampClock};
use crate::text::{read_text, Fields};
use pgm_scan::{Pose2, Scan};
use std::collections::BTreeMap;
use std::path::Path;

/// Reader options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CarmenOptions {
    /// Maximum range for FLASER lines, which do not state one (metres).
    pub flaser_max_range: f64,
    /// Field of view of the front laser (FLASER lines) in degrees; overrides the log's
    /// `PARAM` lines and CARMEN's rule (module docs).
    pub front_laser_fov: Option<f64>,
    /// Angular resolution of the front laser (FLASER lines) in degrees; overrides the
    /// log's `PARAM` lines and CARMEN's rule (module docs).
    pub front_laser_resolution: Option<f64>,
    /// Angle of the first FLASER beam in degrees (default −90, CARMEN's).
    pub front_laser_start: Option<f64>,
    /// Which clock places the laser and `ODOM` lines in time ([`crate::stamps`]):
    /// `ipc_timestamp` is the header stamp, `logger_timestamp` the record time.
    pub clock: StampClock,
}

impl Default for CarmenOptions {
    fn default() -> Self {
        Self {
            flaser_max_range: 80.0,
            front_laser_fov: None,
            front_laser_resolution: None,
            front_laser_start: None,
            clock: StampClock::Auto,
        }
    }
}

/// `PARAM` names that give the front laser's field of view in degrees (CARMEN's
/// `laser_front_laser_fov`, the robot module's `robot_front_laser_fov`, and
/// `laser_laser1_fov` of the newer laser module, whose laser 1 is the front laser).
pub const FOV_PARAMS: [&str; 3] = [
    "laser_front_laser_fov",
    "robot_front_laser_fov",
    "laser_laser1_fov",
];

/// `PARAM` names that give the front laser's angular resolution in degrees.
pub const RESOLUTION_PARAMS: [&str; 3] = [
    "laser_front_laser_resolution",
    "robot_front_laser_resolution",
    "laser_laser1_resolution",
];

/// Where the beam angles of FLASER lines came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GeometrySource {
    /// [`CarmenOptions::front_laser_fov`] / [`CarmenOptions::front_laser_resolution`]
    /// (at least one of them).
    Options,
    /// The log's `PARAM` lines (at least one of them).
    Params,
    /// CARMEN's rule for the beam count (module docs).
    #[default]
    CarmenRule,
}

/// The beam layout of one scan: beam `k` at `start + k·increment` (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamGeometry {
    /// Angle of the first beam (rad).
    pub start: f64,
    /// Angle between consecutive beams (rad).
    pub increment: f64,
}

/// The angle of the first FLASER beam without an option: −90° (module docs).
pub const FLASER_START_DEGREES: f64 = -90.0;

/// CARMEN's rule for a FLASER line of `n` beams without stated geometry (module docs).
pub fn carmen_rule(n: usize) -> BeamGeometry {
    let deg = std::f64::consts::PI / 180.0;
    let resolution = match n {
        180 | 181 => 1.0,
        360 | 361 => 0.5,
        400 | 401 => 0.25,
        _ if n >= 2 => 180.0 / (n - 1) as f64,
        _ => 0.0,
    };
    BeamGeometry {
        start: FLASER_START_DEGREES * deg,
        increment: resolution * deg,
    }
}

/// The geometry of `n` FLASER beams from a field of view and/or a resolution in
/// degrees (module docs), the first beam at `start` degrees (default −90°); `Err`
/// describes a disagreement.
pub fn beam_geometry(
    n: usize,
    fov: Option<f64>,
    resolution: Option<f64>,
    start: Option<f64>,
) -> std::result::Result<BeamGeometry, String> {
    let deg = std::f64::consts::PI / 180.0;
    for (name, value) in [("field of view", fov), ("resolution", resolution)] {
        if let Some(v) = value {
            if !(v.is_finite() && v > 0.0 && v <= 360.0) {
                return Err(format!("{name} {v:?}° is not in (0°, 360°]"));
            }
        }
    }
    if let Some(a) = start {
        if !(a.is_finite() && a.abs() <= 360.0) {
            return Err(format!("first beam angle {a:?}° is not in [−360°, 360°]"));
        }
    }
    let start = start.unwrap_or(FLASER_START_DEGREES) * deg;
    let increment = match (fov, resolution) {
        (None, None) => carmen_rule(n).increment,
        (Some(f), None) => {
            if n >= 2 {
                f / (n - 1) as f64 * deg
            } else {
                0.0
            }
        }
        (None, Some(r)) => r * deg,
        (Some(f), Some(r)) => {
            let beams = (f / r).round() + 1.0;
            if (f / r - (beams - 1.0)).abs() > 1e-6 * beams
                || !(beams == n as f64 || beams == n as f64 + 1.0)
            {
                return Err(format!(
                    "{n} beams, but a field of view of {f}° at a resolution of {r}° gives {beams} \
                     (CARMEN's lasers send 1 + fov/resolution beams, or one less when the last \
                     is dropped)"
                ));
            }
            r * deg
        }
    };
    if increment * n.saturating_sub(1) as f64 > limits::MAX_SPAN {
        return Err(format!(
            "{n} beams {}° apart span more than a full turn",
            increment / deg
        ));
    }
    Ok(BeamGeometry { start, increment })
}

/// A laser scan of the log with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct LogScan {
    /// The scan (timestamp = `ipc_timestamp`, or `logger_timestamp` when the clock
    /// rule chose record times: [`CarmenLog::clock`]).
    pub scan: Scan,
    /// 1-based line number of the laser line.
    pub line: usize,
    /// `logger_timestamp` (s).
    pub record_time: f64,
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
    /// `ipc_timestamp` in seconds (or `logger_timestamp`: [`CarmenLog::clock`]).
    pub timestamp: f64,
    /// `logger_timestamp` in seconds.
    pub record_time: f64,
    /// Odometry pose of the robot.
    pub pose: Pose2,
    /// 1-based line number.
    pub line: usize,
}

/// A `PARAM` line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Param {
    /// The value as written.
    pub value: String,
    /// 1-based line number.
    pub line: usize,
}

/// The contents of a CARMEN log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CarmenLog {
    /// `PARAM` lines by name (the last line of a name wins).
    pub params: BTreeMap<String, Param>,
    /// Where the FLASER beam angles came from.
    pub flaser_geometry: GeometrySource,
    /// Laser scans (FLASER and ROBOTLASER1) in file order.
    pub scans: Vec<LogScan>,
    /// ODOM records in file order.
    pub odometry: Vec<OdometryRecord>,
    /// VERTEX2 records in file order.
    pub vertices: Vec<Vertex>,
    /// Number of skipped lines per first word.
    pub skipped: BTreeMap<String, usize>,
    /// The clock the time stamps are on: `ipc_timestamp` ([`StampClock::Header`]) or
    /// `logger_timestamp` ([`StampClock::Record`]), by the rule of [`crate::stamps`].
    pub clock: StampClock,
    /// Notes for the user (time stamps at fault), each naming the file.
    pub notes: Vec<String>,
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

/// The front laser's field of view and resolution (degrees) from the options, else the
/// `PARAM` lines; each with the line it came from (0 for an option).
struct FrontLaser {
    fov: Option<(f64, usize)>,
    resolution: Option<(f64, usize)>,
    source: GeometrySource,
}

fn front_laser(
    path: &Path,
    params: &BTreeMap<String, Param>,
    options: CarmenOptions,
) -> Result<FrontLaser> {
    let option = |name: &str, v: Option<f64>| -> Result<Option<(f64, usize)>> {
        match v {
            Some(v) if !(v.is_finite() && v > 0.0 && v <= 360.0) => Err(Error::Invalid {
                path: path.to_path_buf(),
                field: name.to_string(),
                problem: format!(
                    "option (--{}) {v:?}° is not in (0°, 360°]",
                    name.trim_start_matches("front_").replace('_', "-")
                ),
            }),
            other => Ok(other.map(|v| (v, 0))),
        }
    };
    let fov = option("front_laser_fov", options.front_laser_fov)?;
    let resolution = option("front_laser_resolution", options.front_laser_resolution)?;
    if let Some(a) = options.front_laser_start {
        if !(a.is_finite() && a.abs() <= 360.0) {
            return Err(Error::Invalid {
                path: path.to_path_buf(),
                field: "front_laser_start".into(),
                problem: format!("option (--laser-start) {a:?}° is not in [−360°, 360°]"),
            });
        }
    }
    if fov.is_some() || resolution.is_some() {
        return Ok(FrontLaser {
            fov,
            resolution,
            source: GeometrySource::Options,
        });
    }
    let from_params = |names: &[&str]| -> Result<Option<(f64, usize)>> {
        let mut found: Option<(f64, usize, &str)> = None;
        for name in names {
            let Some(p) = params.get(*name) else { continue };
            let v: f64 = p.value.parse().unwrap_or(f64::NAN);
            if !(v.is_finite() && v > 0.0 && v <= 360.0) {
                return Err(Error::Field {
                    path: path.to_path_buf(),
                    line: p.line,
                    field: name.to_string(),
                    value: p.value.clone(),
                    problem: "expected degrees in (0, 360]".into(),
                });
            }
            if let Some((w, line, other)) = found {
                if (w - v).abs() > 1e-9 {
                    return Err(Error::Field {
                        path: path.to_path_buf(),
                        line: p.line,
                        field: name.to_string(),
                        value: p.value.clone(),
                        problem: format!("disagrees with `{other}` = {w} on line {line}"),
                    });
                }
            }
            found = Some((v, p.line, name));
        }
        Ok(found.map(|(v, line, _)| (v, line)))
    };
    let fov = from_params(&FOV_PARAMS)?;
    let resolution = from_params(&RESOLUTION_PARAMS)?;
    let source = if fov.is_some() || resolution.is_some() {
        GeometrySource::Params
    } else {
        GeometrySource::CarmenRule
    };
    Ok(FrontLaser {
        fov,
        resolution,
        source,
    })
}

/// Parses the text of a CARMEN log; `path` is only used in error messages.
pub fn parse_carmen(path: &Path, text: &str, options: CarmenOptions) -> Result<CarmenLog> {
    if !(options.flaser_max_range > 0.0 && options.flaser_max_range <= limits::MAX_RANGE) {
        return Err(Error::Invalid {
            path: path.to_path_buf(),
            field: "flaser_max_range".into(),
            problem: format!(
                "option {} m is not in (0, {:e}] m",
                options.flaser_max_range,
                limits::MAX_RANGE
            ),
        });
    }
    let mut log = CarmenLog::default();
    // PARAM lines first: they describe the whole log wherever they stand.
    for (index, line_text) in text.lines().enumerate() {
        let mut tokens = line_text.split_whitespace();
        if tokens.next() == Some("PARAM") {
            let fields = Fields::new(path, index + 1, line_text);
            let name = fields.raw(1, "name", 3)?;
            let value = fields.raw(2, "value", 3)?;
            log.params.insert(
                name.to_string(),
                Param {
                    value: value.to_string(),
                    line: index + 1,
                },
            );
        }
    }
    let front = front_laser(path, &log.params, options)?;
    log.flaser_geometry = front.source;
    let mut pending_vertex: Option<Vertex> = None;
    let mut vertex_lines: BTreeMap<u64, usize> = BTreeMap::new();
    for (index, line_text) in text.lines().enumerate() {
        let fields = Fields::new(path, index + 1, line_text);
        let Some(kind) = fields.tokens.first().copied() else {
            continue;
        };
        match kind {
            "PARAM" => {}
            "FLASER" | "ROBOTLASER1" => {
                let (scan, record_time) = if kind == "FLASER" {
                    parse_flaser(&fields, options, &front)?
                } else {
                    parse_robotlaser1(&fields)?
                };
                log.scans.push(LogScan {
                    scan,
                    line: fields.line,
                    record_time,
                    vertex: pending_vertex.take(),
                });
            }
            "ODOM" => log.odometry.push(parse_odom(&fields)?),
            "VERTEX2" => {
                let vertex = parse_vertex(&fields)?;
                if let Some(&first) = vertex_lines.get(&vertex.id) {
                    return Err(fields.error(
                        "id",
                        fields.tokens[1],
                        format!(
                            "vertex {} is already defined on line {first} (a pose graph's \
                             vertex ids are unique)",
                            vertex.id
                        ),
                    ));
                }
                vertex_lines.insert(vertex.id, vertex.line);
                log.vertices.push(vertex);
                pending_vertex = Some(vertex);
            }
            other => *log.skipped.entry(other.to_string()).or_insert(0) += 1,
        }
    }
    place_by_clock(path, &mut log, options.clock)?;
    Ok(log)
}

/// Checks the `ipc_timestamp`s of the laser lines and of the `ODOM` lines in file order
/// and places both by the clock `rule` chooses ([`crate::stamps`]): the
/// `logger_timestamp`s when the ipc stamps are at fault and the logger's are not
/// going backwards; an error under [`StampClock::Header`].
fn place_by_clock(path: &Path, log: &mut CarmenLog, rule: StampClock) -> Result<()> {
    let streams = [
        (
            "laser lines",
            log.scans
                .iter()
                .map(|s| (s.line, s.scan.timestamp, s.record_time))
                .collect::<Vec<_>>(),
        ),
        (
            "ODOM lines",
            log.odometry
                .iter()
                .map(|o| (o.line, o.timestamp, o.record_time))
                .collect(),
        ),
    ];
    let faults: Vec<(&str, usize, crate::stamps::StampFaults)> = streams
        .iter()
        .filter_map(|(what, s)| {
            stamps::stamp_faults(s.iter().map(|x| x.1)).map(|f| (*what, s[f.first.at].0, f))
        })
        .collect();
    let record_usable = streams
        .iter()
        .all(|(_, s)| stamps::non_decreasing(s.iter().map(|x| x.2)));
    let clock = stamps::chosen(rule, !faults.is_empty(), record_usable);
    for (k, (what, line, f)) in faults.iter().enumerate() {
        let problem = format!(
            "ipc_timestamp: {} ({} of the {} {what} have a time stamp that is zero, repeated or \
             goes backwards in file order)",
            f.first, f.count, f.total
        );
        if rule == StampClock::Header {
            return Err(Error::Field {
                path: path.to_path_buf(),
                line: *line,
                field: "ipc_timestamp".into(),
                value: f.first.stamp.to_string(),
                problem: format!(
                    "{problem}; with record times (clock `record` or `auto`) the log can be read"
                ),
            });
        }
        if k == 0 || clock != StampClock::Header {
            log.notes.push(format!(
                "{}: line {line}: {problem}: {}",
                path.display(),
                match clock {
                    StampClock::Record => "every line is placed by its logger_timestamp",
                    _ if record_usable => "the ipc stamps are kept",
                    _ =>
                        "logger_timestamp goes backwards too: the ipc stamps are kept, in file \
                          order",
                }
            ));
        }
    }
    if clock == StampClock::Record {
        for s in &mut log.scans {
            s.scan.timestamp = s.record_time;
        }
        for o in &mut log.odometry {
            o.timestamp = o.record_time;
        }
    }
    log.clock = clock;
    Ok(())
}

/// Parses `n` ranges starting at token `first`; a return when `0 < r < max_range`;
/// `nan`, `inf` and `-inf` are beams without a return (range 0).
fn parse_ranges(
    fields: &Fields<'_>,
    first: usize,
    n: usize,
    max_range: f64,
    expected: usize,
) -> Result<(Vec<f64>, Vec<bool>)> {
    fields.ranges(
        first..first + n,
        expected,
        [0.0, max_range],
        "write nan, inf or the maximum range for no return",
    )
}

/// A scan with beams at `angles` and (`ranges`, `valid`) taken at `timestamp` by the
/// laser at pose `laser` of a robot at odometry pose `robot` (both in the odometry
/// frame).
fn robot_scan(
    timestamp: f64,
    angles: Vec<f64>,
    (ranges, valid): (Vec<f64>, Vec<bool>),
    max_range: f64,
    robot: Pose2,
    laser: Pose2,
) -> Scan {
    Scan {
        timestamp,
        angles,
        ranges,
        valid,
        max_range,
        odometry: Some(robot),
        laser_offset: robot.between(&laser),
    }
}

fn parse_pose(
    fields: &Fields<'_>,
    first: usize,
    names: [&str; 3],
    expected: usize,
) -> Result<Pose2> {
    Ok(Pose2::new(
        fields.position(first, names[0], expected)?,
        fields.position(first + 1, names[1], expected)?,
        fields.heading(first + 2, names[2], expected)?,
    ))
}

/// Fails for a scan without beams.
fn require_beams(fields: &Fields<'_>, index: usize, n: usize) -> Result<()> {
    if n == 0 {
        return Err(fields.error(
            "n",
            fields.tokens[index],
            "a laser scan needs at least one beam",
        ));
    }
    Ok(())
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

fn parse_flaser(
    fields: &Fields<'_>,
    options: CarmenOptions,
    front: &FrontLaser,
) -> Result<(Scan, f64)> {
    let n = fields.count_on_line(1, "n", 2, FLASER_TAIL.len())?;
    require_beams(fields, 1, n)?;
    let expected = 2 + n + FLASER_TAIL.len();
    fields.expect_len(expected, &format!("FLASER declares n = {n} ranges"), |i| {
        if i < 2 + n {
            format!("range[{}]", i - 2)
        } else {
            FLASER_TAIL[i - 2 - n].to_string()
        }
    })?;
    let beams = parse_ranges(fields, 2, n, options.flaser_max_range, expected)?;
    let t = 2 + n;
    let laser = parse_pose(fields, t, ["x", "y", "theta"], expected)?;
    let odometry = parse_pose(fields, t + 3, ["odom_x", "odom_y", "odom_theta"], expected)?;
    let timestamp = fields.timestamp(t + 6, "ipc_timestamp", expected)?;
    let record_time = fields.timestamp(t + 8, "logger_timestamp", expected)?;
    let geometry = beam_geometry(
        n,
        front.fov.map(|f| f.0),
        front.resolution.map(|r| r.0),
        options.front_laser_start,
    )
    .map_err(|problem| {
        let origin = match front.source {
            GeometrySource::Options => "the reader's options".to_string(),
            GeometrySource::Params => {
                let lines: Vec<String> = [front.fov, front.resolution]
                    .iter()
                    .flatten()
                    .map(|(_, line)| line.to_string())
                    .collect();
                format!("PARAM line {}", lines.join(" and "))
            }
            GeometrySource::CarmenRule => "CARMEN's rule".to_string(),
        };
        fields.error(
            "n",
            fields.tokens[1],
            format!("{problem} (geometry from {origin})"),
        )
    })?;
    let angles = crate::beams::beam_angles(geometry.start, geometry.increment, n);
    let scan = robot_scan(
        timestamp,
        angles,
        beams,
        options.flaser_max_range,
        odometry,
        laser,
    );
    Ok((scan, record_time))
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

fn parse_robotlaser1(fields: &Fields<'_>) -> Result<(Scan, f64)> {
    let head = 9;
    let start_angle = fields.angle(2, "start_angle", head)?;
    let fov = fields.finite(3, "fov", head)?;
    let resolution = fields.finite(4, "angular_res", head)?;
    let max_range = fields.finite(5, "max_range", head)?;
    if !(max_range > 0.0 && max_range <= limits::MAX_RANGE) {
        return Err(fields.error(
            "max_range",
            fields.tokens[5],
            format!("must be positive and at most {:e} m", limits::MAX_RANGE),
        ));
    }
    // n ranges, then n_rem and the remissions, then the tail.
    let n = fields.count_on_line(8, "n", head, 1 + ROBOTLASER1_TAIL.len())?;
    require_beams(fields, 8, n)?;
    let n_rem = fields.count_on_line(9 + n, "n_rem", 10 + n, ROBOTLASER1_TAIL.len())?;
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
    if let Err(problem) = crate::beams::check_increment(n, resolution) {
        return Err(fields.error("angular_res", fields.tokens[4], problem));
    }
    // The field of view must agree with the beams to within one increment (CARMEN's
    // lasers that drop the last beam state one more); within that the resolution
    // wins (crate::beams).
    if let Err(given) = crate::beams::check_span(fov, n, resolution.abs()) {
        return Err(fields.error(
            "fov",
            fields.tokens[3],
            format!(
                "disagrees by more than one increment with the {n} beams at angular_res \
                 {} rad, which span (n - 1) · |angular_res| = {given} rad ({:.4}°): the \
                 ranges do not fill the field of view",
                fields.tokens[4],
                given.to_degrees()
            ),
        ));
    }
    let beams = parse_ranges(fields, 9, n, max_range, expected)?;
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
    let timestamp = fields.timestamp(t + 11, "ipc_timestamp", expected)?;
    let record_time = fields.timestamp(t + 13, "logger_timestamp", expected)?;
    let angles = crate::beams::beam_angles(start_angle, resolution, n);
    let scan = robot_scan(timestamp, angles, beams, max_range, robot, laser);
    Ok((scan, record_time))
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
    let timestamp = fields.timestamp(7, "ipc_timestamp", NAMES.len())?;
    let record_time = fields.timestamp(9, "logger_timestamp", NAMES.len())?;
    Ok(OdometryRecord {
        timestamp,
        record_time,
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
