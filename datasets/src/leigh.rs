//! Readers for the text logs of the leigh-gtm1 data set (McGill smart wheelchair,
//! Hokuyo laser, hand-annotated people; A. Leigh, J. Pineau, N. Olmedo, H. Zhang,
//! "Person Tracking and Following with 2D Laser Scanners", ICRA 2015).
//!
//! - Scans (`scans.txt`): `SCAN idx stamp_header_s stamp_bag_s frame angle_min
//!   angle_increment range_min range_max n r_0 … r_{n-1}`. Beam `k` lies at
//!   `angle_min + k·angle_increment`; a beam is a return when
//!   `range_min < r < range_max` and finite. `nan`, `inf`, `-inf` (REP 117's "too
//!   close", [`crate::beams`]) and `0` mean no return (stored as range 0, invalid);
//!   another negative range is an error. The scan's time stamp
//!   is `stamp_header_s`; its laser offset is [`LASER_OFFSET`]. A scan needs at least
//!   one beam, `0 <= range_min < range_max`, a non-zero `angle_increment` (for more
//!   than one beam) and beams within a full turn.
//! - Odometry (`odom_at_scan.txt`): `ODOM idx stamp x y theta`, the wheel-odometry pose
//!   of the robot base at scan `idx`.
//! - People (`people_gt.txt`): `PERSON scan_idx person_id x y`, an annotated person
//!   centre in the laser frame of scan `scan_idx`.
//!
//! Lines starting with `#` and blank lines are skipped; lines of another record type
//! are skipped and counted. Scan indices must be unique, and so must
//! `(scan_idx, person_id)`. Values that parse but mean nothing are errors naming file,
//! line and field: positions, ranges and time stamps beyond
//! [`limits`], person centres farther than any laser reaches
//! ([`limits::MAX_RANGE`]). Read together with its scan log
//! ([`check_people_reach`]), an annotation must also lie within the reach its scan
//! declares: `range_max` plus [`PERSON_REACH_MARGIN`].

use crate::error::{limits, Error, Result};
use crate::stamps::{self, StampClock};
use crate::text::{read_text, Fields};
use nalgebra::Point2;
use pgm_scan::{Pose2, Scan};
use std::collections::BTreeMap;
use std::path::Path;

/// Pose of the laser on the wheelchair's base (x = 0.850326 m, y = 0.235214 m,
/// yaw = 0.734808 rad), the bag's `/tf` edge `base_link → left_laser` (quaternion z =
/// 0.35919389, w = 0.93326296). The data README rounds the yaw to 0.73480 rad, which
/// this constant used until the bag reader showed the 8 µrad difference.
pub const LASER_OFFSET: (f64, f64, f64) = (0.850326, 0.235214, 0.734808);

/// [`LASER_OFFSET`] as a pose.
pub fn laser_offset() -> Pose2 {
    Pose2::new(LASER_OFFSET.0, LASER_OFFSET.1, LASER_OFFSET.2)
}

/// One scan of the log with its index.
#[derive(Clone, Debug, PartialEq)]
pub struct IndexedScan {
    /// The log's scan index (`idx`).
    pub index: usize,
    /// The scan.
    pub scan: Scan,
    /// 1-based line number.
    pub line: usize,
    /// Record time (s): `stamp_bag_s` (a bag's record time for a bag read as a leigh
    /// log).
    pub record_time: f64,
}

/// A hand-annotated person centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PersonAnnotation {
    /// Index of the scan the annotation belongs to.
    pub scan: usize,
    /// Person identity (the same id in two scans is the same person).
    pub person: u32,
    /// Centre in the laser frame of that scan.
    pub centre: Point2<f64>,
    /// 1-based line number.
    pub line: usize,
}

/// The scans of a leigh-gtm1 scan log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LeighScans {
    /// Scans in file order (indices strictly increasing).
    pub scans: Vec<IndexedScan>,
    /// Number of skipped lines per first word.
    pub skipped: BTreeMap<String, usize>,
    /// The clock the scans' `timestamp`s are on: `stamp_header_s`
    /// ([`StampClock::Header`]) or `stamp_bag_s` ([`StampClock::Record`]), by the rule
    /// of [`crate::stamps`].
    pub clock: StampClock,
    /// Notes for the user (header stamps at fault), each naming the file.
    pub notes: Vec<String>,
}

impl LeighScans {
    /// The scan with log index `index`.
    pub fn get(&self, index: usize) -> Option<&IndexedScan> {
        self.scans
            .binary_search_by_key(&index, |s| s.index)
            .ok()
            .map(|k| &self.scans[k])
    }
}

fn lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().filter_map(|(i, l)| {
        let t = l.trim_start();
        (!t.is_empty() && !t.starts_with('#')).then_some((i + 1, l))
    })
}

/// The fields of the lines of `text` whose first field is `names[0]`, each of
/// exactly the fields `names` (`context` says so in the error); other lines are
/// passed over.
fn records<'a>(
    path: &'a Path,
    text: &'a str,
    names: &'a [&str],
    context: &'a str,
) -> impl Iterator<Item = Result<Fields<'a>>> {
    lines(text).filter_map(move |(line, line_text)| {
        let f = Fields::new(path, line, line_text);
        if f.tokens[0] != names[0] {
            return None;
        }
        Some(
            f.expect_len(names.len(), context, |i| names[i].to_string())
                .map(|()| f),
        )
    })
}

const SCAN_HEAD: [&str; 10] = [
    "SCAN",
    "idx",
    "stamp_header_s",
    "stamp_bag_s",
    "frame",
    "angle_min",
    "angle_increment",
    "range_min",
    "range_max",
    "n",
];

/// Reads a `scans.txt` log, its scans placed by [`StampClock::Auto`].
pub fn read_scans(path: impl AsRef<Path>) -> Result<LeighScans> {
    read_scans_with(path, StampClock::Auto)
}

/// Reads a `scans.txt` log, its scans placed by the clock `clock` chooses
/// ([`crate::stamps`]).
pub fn read_scans_with(path: impl AsRef<Path>, clock: StampClock) -> Result<LeighScans> {
    let path = path.as_ref();
    let text = read_text(path)?;
    parse_scans_with(path, &text, clock)
}

/// Parses the text of a `scans.txt` log ([`StampClock::Auto`]); `path` is only used
/// in error messages.
pub fn parse_scans(path: &Path, text: &str) -> Result<LeighScans> {
    parse_scans_with(path, text, StampClock::Auto)
}

/// Parses the text of a `scans.txt` log, the scans placed by the clock `clock`
/// chooses: `stamp_header_s` unless those are zero, repeated or go backwards in file
/// order, then `stamp_bag_s` when it does not go backwards ([`crate::stamps`]);
/// `path` is only used in messages.
///
/// # Errors
/// As [`parse_scans`]; under [`StampClock::Header`] a stamp at fault, naming its line.
pub fn parse_scans_with(path: &Path, text: &str, clock: StampClock) -> Result<LeighScans> {
    let mut out = parse_scan_lines(path, text)?;
    let faults = stamps::stamp_faults(out.scans.iter().map(|s| s.scan.timestamp));
    let record_usable = stamps::non_decreasing(out.scans.iter().map(|s| s.record_time));
    let used = stamps::chosen(clock, faults.is_some(), record_usable);
    if let Some(f) = faults {
        let at = &out.scans[f.first.at];
        let what = format!(
            "stamp_header_s: {} ({} of {} header stamps are zero, repeated or go backwards)",
            f.first, f.count, f.total
        );
        if clock == StampClock::Header {
            return Err(Error::Field {
                path: path.to_path_buf(),
                line: at.line,
                field: "stamp_header_s".into(),
                value: at.scan.timestamp.to_string(),
                problem: format!(
                    "{what}; with record times (clock `record` or `auto`) the log can be read"
                ),
            });
        }
        out.notes.push(format!(
            "{}: line {}: {what}: {}",
            path.display(),
            at.line,
            match (used, record_usable) {
                (StampClock::Record, _) => "every scan is placed by stamp_bag_s".to_string(),
                (_, false) => "stamp_bag_s goes backwards too: the header stamps are kept, \
                               in file order"
                    .to_string(),
                _ => "the header stamps are kept".to_string(),
            }
        ));
    }
    if used == StampClock::Record {
        for s in &mut out.scans {
            s.scan.timestamp = s.record_time;
        }
    }
    out.clock = used;
    Ok(out)
}

fn parse_scan_lines(path: &Path, text: &str) -> Result<LeighScans> {
    let mut out = LeighScans {
        clock: StampClock::Header,
        ..LeighScans::default()
    };
    for (line, line_text) in lines(text) {
        let f = Fields::new(path, line, line_text);
        if f.tokens[0] != "SCAN" {
            *out.skipped.entry(f.tokens[0].to_string()).or_insert(0) += 1;
            continue;
        }
        let head = SCAN_HEAD.len();
        let index = f.count(1, "idx", head)?;
        let timestamp = f.timestamp(2, "stamp_header_s", head)?;
        let record_time = f.timestamp(3, "stamp_bag_s", head)?;
        f.raw(4, "frame", head)?;
        let angle_min = f.angle(5, "angle_min", head)?;
        let increment = f.finite(6, "angle_increment", head)?;
        let range_min = f.finite(7, "range_min", head)?;
        if range_min < 0.0 {
            return Err(f.error(
                "range_min",
                f.tokens[7],
                "a negative minimum range would make no-return beams (0) returns at the sensor",
            ));
        }
        let range_max = f.finite(8, "range_max", head)?;
        if !(range_max > range_min && range_max <= limits::MAX_RANGE) {
            return Err(f.error(
                "range_max",
                f.tokens[8],
                format!(
                    "must be above range_min {range_min} and at most {:e} m",
                    limits::MAX_RANGE
                ),
            ));
        }
        let n = f.count_on_line(9, "n", head, 0)?;
        if n == 0 {
            return Err(f.error("n", f.tokens[9], "a laser scan needs at least one beam"));
        }
        if let Err(problem) = crate::beams::check_increment(n, increment) {
            return Err(f.error("angle_increment", f.tokens[6], problem));
        }
        f.expect_len(head + n, &format!("SCAN declares n = {n} ranges"), |i| {
            if i < head {
                SCAN_HEAD[i].to_string()
            } else {
                format!("range[{}]", i - head)
            }
        })?;
        // REP 117: -inf (too close), inf and nan are beams without a return.
        let (ranges, valid) = f.ranges(
            head..head + n,
            head + n,
            [range_min, range_max],
            "nan, inf, -inf or 0 mean no return",
        )?;
        if let Some(last) = out.scans.last() {
            if index <= last.index {
                return Err(f.error(
                    "idx",
                    f.tokens[1],
                    format!(
                        "scan indices must increase (previous {} on line {})",
                        last.index, last.line
                    ),
                ));
            }
        }
        out.scans.push(IndexedScan {
            index,
            scan: Scan {
                timestamp,
                angles: crate::beams::beam_angles(angle_min, increment, n),
                ranges,
                valid,
                max_range: range_max,
                odometry: None,
                laser_offset: laser_offset(),
            },
            line,
            record_time,
        });
    }
    Ok(out)
}

/// Reads an `odom_at_scan.txt` log: robot-base odometry pose per scan index.
pub fn read_odometry(path: impl AsRef<Path>) -> Result<BTreeMap<usize, Pose2>> {
    let path = path.as_ref();
    let text = read_text(path)?;
    parse_odometry(path, &text)
}

/// Parses the text of an `odom_at_scan.txt` log; `path` is only used in error messages.
pub fn parse_odometry(path: &Path, text: &str) -> Result<BTreeMap<usize, Pose2>> {
    const NAMES: [&str; 6] = ["ODOM", "idx", "stamp", "x", "y", "theta"];
    let mut out = BTreeMap::new();
    for f in records(path, text, &NAMES, "ODOM has 5 fields") {
        let f = f?;
        let index = f.count(1, "idx", 6)?;
        f.timestamp(2, "stamp", 6)?;
        let pose = Pose2::new(
            f.position(3, "x", 6)?,
            f.position(4, "y", 6)?,
            f.heading(5, "theta", 6)?,
        );
        if out.insert(index, pose).is_some() {
            return Err(f.error("idx", f.tokens[1], "second odometry record for this scan"));
        }
    }
    Ok(out)
}

/// Reads a `people_gt.txt` annotation file.
pub fn read_people(path: impl AsRef<Path>) -> Result<Vec<PersonAnnotation>> {
    let path = path.as_ref();
    let text = read_text(path)?;
    parse_people(path, &text)
}

/// Parses the text of a `people_gt.txt` file; `path` is only used in error messages.
pub fn parse_people(path: &Path, text: &str) -> Result<Vec<PersonAnnotation>> {
    const NAMES: [&str; 5] = ["PERSON", "scan_idx", "person_id", "x", "y"];
    let mut out: Vec<PersonAnnotation> = Vec::new();
    let mut seen: BTreeMap<(usize, u32), usize> = BTreeMap::new();
    for f in records(path, text, &NAMES, "PERSON has 4 fields") {
        let f = f?;
        let line = f.line;
        let scan = f.count(1, "scan_idx", 5)?;
        let person: u32 = f.parsed(2, "person_id", 5, "not a non-negative integer")?;
        // A centre in the laser frame, so within a laser's reach.
        let coordinate = |index, field| {
            f.bounded(
                index,
                field,
                5,
                limits::MAX_RANGE,
                "a person centre in the laser frame (m)",
            )
        };
        let centre = Point2::new(coordinate(3, "x")?, coordinate(4, "y")?);
        if let Some(first) = seen.insert((scan, person), line) {
            return Err(f.error(
                "person_id",
                f.tokens[2],
                format!("person annotated twice in scan {scan} (first on line {first})"),
            ));
        }
        out.push(PersonAnnotation {
            scan,
            person,
            centre,
            line,
        });
    }
    Ok(out)
}

/// How far (m) beyond its scan's `range_max` an annotated person centre may lie: the
/// centre is behind the returns on the person's near side by about a body radius
/// (returns within 0.35 m of a centre are the person's), and single annotations
/// jitter by up to about 0.5 m (data README), so 1 m. A centre farther away marks no
/// return the laser could have measured (a typo or a unit mistake: leigh-gtm1's
/// centres lie within 7.3 m of an 11 m laser).
pub const PERSON_REACH_MARGIN: f64 = 1.0;

/// An annotation beyond the laser's reach (see [`people_out_of_reach`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutOfReach<'a> {
    /// The annotation.
    pub annotation: &'a PersonAnnotation,
    /// Its distance from the laser (m).
    pub distance: f64,
    /// The `range_max` it was held against (m).
    pub range_max: f64,
    /// The scan that declares it (`None`: the annotation's scan is not in the log, and
    /// the log's largest `range_max` was used).
    pub scan: Option<&'a IndexedScan>,
}

/// The first annotation (in the order of `people`) whose centre lies farther from the
/// laser than its scan's `range_max` plus [`PERSON_REACH_MARGIN`] (an annotation of a
/// scan the log does not have: the log's largest `range_max`).
pub fn people_out_of_reach<'a>(
    scans: &'a LeighScans,
    people: &'a [PersonAnnotation],
) -> Option<OutOfReach<'a>> {
    let largest = scans
        .scans
        .iter()
        .map(|s| s.scan.max_range)
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))))?;
    people.iter().find_map(|a| {
        let scan = scans.get(a.scan);
        let range_max = scan.map_or(largest, |s| s.scan.max_range);
        let distance = a.centre.coords.norm();
        (distance > range_max + PERSON_REACH_MARGIN).then_some(OutOfReach {
            annotation: a,
            distance,
            range_max,
            scan,
        })
    })
}

/// Checks that every annotation of `people` (read from `people_path`) lies within the
/// reach of its scan in `scans` (read from `scans_path`): `range_max` plus
/// [`PERSON_REACH_MARGIN`].
///
/// # Errors
/// [`Error::Field`] naming the people file, the annotation's line, its centre and the
/// scan line whose `range_max` it exceeds.
pub fn check_people_reach(
    scans: &LeighScans,
    scans_path: &Path,
    people: &[PersonAnnotation],
    people_path: &Path,
) -> Result<()> {
    let Some(far) = people_out_of_reach(scans, people) else {
        return Ok(());
    };
    let a = far.annotation;
    let declared = match far.scan {
        Some(s) => format!(
            "scan {} ({}:{}) declares range_max {} m",
            a.scan,
            scans_path.display(),
            s.line,
            far.range_max
        ),
        None => format!(
            "scan {} is not in {}, whose largest range_max is {} m",
            a.scan,
            scans_path.display(),
            far.range_max
        ),
    };
    Err(Error::Field {
        path: people_path.to_path_buf(),
        line: a.line,
        field: "x y".into(),
        value: format!("{} {}", a.centre.x, a.centre.y),
        problem: format!(
            "a person centre {:.2} m from the laser, beyond its reach: {declared}, and a \
             centre may lie at most {PERSON_REACH_MARGIN} m beyond it",
            far.distance
        ),
    })
}

/// Sets each scan's odometry from `odometry` (by scan index). Every scan must have a
/// record; the error names the first scan without one.
pub fn attach_odometry(
    scans: &mut LeighScans,
    odometry: &BTreeMap<usize, Pose2>,
    odometry_path: &Path,
) -> Result<()> {
    for s in &mut scans.scans {
        match odometry.get(&s.index) {
            Some(p) => s.scan.odometry = Some(*p),
            None => {
                return Err(Error::Invalid {
                    path: odometry_path.to_path_buf(),
                    field: format!("ODOM {}", s.index),
                    problem: format!(
                        "no odometry record for scan {} (scan line {})",
                        s.index, s.line
                    ),
                })
            }
        }
    }
    Ok(())
}
