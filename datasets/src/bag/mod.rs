//! ROS bags in: ROS 1 bags (the `rosbag` crate), ROS 2 bags stored as MCAP (the `mcap`
//! crate; a `.mcap` file or a bag directory), either one inside a `.zip` archive.
//!
//! # Big picture
//!
//! [`read_bag`] reads the topics a [`BagTopics`] names and returns a [`BagLog`]: the
//! laser scans (`sensor_msgs/LaserScan`), odometry (`nav_msgs/Odometry`), pose tracks
//! (`geometry_msgs/PoseStamped`, or any message with a `pose`), annotated people (the
//! `leg_tracker/Person` tracks of the leigh-gtm1 bags: a `pose` and an `id`, or an
//! array `people` of them) and the `/tf` and `/tf_static` edges (to find where the
//! laser is mounted). Messages are decoded from the message definitions the bag
//! carries ([`msgdef`], [`decode`]): ROS 1 serialisation or ROS 2 CDR, so the layout of
//! a message is never hard-coded, only the names of the fields read. `bag_pairs` in
//! [`pairs`] turns a log into scan pairs with ground truth.
//!
//! Conventions, the same as the text logs' ([`crate::beams`]): a beam is a return when
//! its range is finite and `range_min < r < range_max`; `-Inf`, `+Inf` and `NaN`
//! (REP 117) are beams without a return, another negative range is an error; beam `k`
//! lies at `angle_min + k · angle_increment`, and `angle_max` must agree with the last
//! beam's angle to within one increment (beyond that the message is refused; within
//! it the increment wins); a scan's time stamp is its header stamp, unless a topic's
//! header stamps are zero, repeated or go backwards, when every topic is placed by its
//! record times ([`crate::stamps`], [`BagTopics::clock`]); frame names lose
//! a leading `/`. `float32` values are widened through their shortest decimal form
//! ([`decode::widen_f32`]), so a bag and a text export of it give the same ranges.
//! Messages of each topic are ordered by record time (file order for equal times).
//!
//! Errors name the file, the topic, the message (its number on the topic, from 1, and
//! its record time) and the field ([`crate::Error::Bag`]); a malformed bag is an error,
//! never a panic, and no length read from a bag sizes an allocation before it is
//! checked against the bytes really there.
//!
//! ```no_run
//! use pgm_datasets::bag::{read_bag, BagTopics};
//!
//! # fn main() -> pgm_datasets::Result<()> {
//! let topics = BagTopics { odometry: Some("/odom".into()), ..BagTopics::new("/scan") };
//! let log = read_bag("general_tracking_moving_1.bag.zip".as_ref(), &topics)?;
//! println!("{} scans, {} odometry messages", log.scans.len(), log.odometry.len());
//! # Ok(())
//! # }
//! ```

pub mod container;
pub mod decode;
pub mod msgdef;
pub mod pairs;
pub mod synthetic;

use crate::error::{limits, Error, Result};
use crate::stamps::{self, StampClock};
use container::{read_container, BagFormat, RawMessage, ReadError, TopicInfo};
use decode::{Decoder, Value};
use msgdef::Definitions;
use nalgebra::Point2;
use pgm_scan::{Pose2, Scan};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The topics to read.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BagTopics {
    /// Laser scans (`sensor_msgs/LaserScan`).
    pub scan: String,
    /// Wheel odometry (`nav_msgs/Odometry`): the prior.
    pub odometry: Option<String>,
    /// Annotated people (leigh-gtm1's `leg_tracker/Person`).
    pub people: Option<String>,
    /// The true pose of the laser-carrying robot (motion capture,
    /// `geometry_msgs/PoseStamped`).
    pub ego_pose: Option<String>,
    /// The true pose of a moving object (motion capture, `geometry_msgs/PoseStamped`).
    pub object_pose: Option<String>,
    /// Which clock places the messages in time ([`crate::stamps`]): header stamps
    /// unless a topic's are zero, repeated or go backwards (the default).
    pub clock: StampClock,
}

impl BagTopics {
    /// Only the scan topic.
    pub fn new(scan: impl Into<String>) -> Self {
        Self {
            scan: scan.into(),
            ..Default::default()
        }
    }
}

/// One topic's messages in record order: (topic, number and record time of each
/// message, their header stamps).
type StampStream = (String, Vec<(usize, f64)>, Vec<f64>);

/// Checks each topic's header stamps in record order and places every message by the
/// clock `log.read.clock` chooses ([`crate::stamps`]): the first fault is an error
/// under [`StampClock::Header`], a note (and record times) under
/// [`StampClock::Auto`].
fn place_by_clock(path: &Path, log: &mut BagLog) -> Result<()> {
    let mut streams: Vec<StampStream> = vec![(
        log.read.scan.clone(),
        log.scans.iter().map(|s| (s.number, s.time)).collect(),
        log.scans.iter().map(|s| s.stamp).collect(),
    )];
    for (topic, track) in [
        (&log.read.odometry, &log.odometry),
        (&log.read.ego_pose, &log.ego_poses),
        (&log.read.object_pose, &log.object_poses),
    ] {
        if let Some(topic) = topic {
            streams.push((
                topic.clone(),
                track.iter().map(|p| (p.number, p.time)).collect(),
                track.iter().map(|p| p.stamp).collect(),
            ));
        }
    }
    let faults: Vec<(&str, (usize, f64), stamps::StampFaults)> = streams
        .iter()
        .filter_map(|(topic, at, stamps)| {
            stamps::stamp_faults(stamps.iter().copied())
                .map(|f| (topic.as_str(), at[f.first.at], f))
        })
        .collect();
    let clock = stamps::chosen(log.read.clock, !faults.is_empty(), true);
    if let Some((topic, (number, time), f)) = faults.first() {
        let what = format!(
            "header {} ({} of {} stamps of the topic are zero, repeated or go backwards in \
             record order)",
            f.first, f.count, f.total
        );
        if log.read.clock == StampClock::Header {
            return Err(bag_error(
                path,
                BagLocation {
                    topic: topic.to_string(),
                    message: *number,
                    time: Some(*time),
                    field: "header.stamp".into(),
                },
                format!("{what}; with record times (clock `record` or `auto`) the bag can be read"),
            ));
        }
        if clock == StampClock::Record {
            let others: Vec<String> = faults[1..]
                .iter()
                .map(|(t, _, f)| format!("{t} ({} of {})", f.count, f.total))
                .collect();
            log.notes.push(format!(
                "{}: {topic} message {number} (record time {time} s): {what}{}: every topic is \
                 placed by its record times",
                path.display(),
                if others.is_empty() {
                    String::new()
                } else {
                    format!("; also {}", others.join(", "))
                }
            ));
        }
    }
    if clock == StampClock::Record {
        for s in &mut log.scans {
            s.stamp = s.time;
            s.scan.timestamp = s.time;
        }
        for track in [&mut log.odometry, &mut log.ego_poses, &mut log.object_poses] {
            for p in track.iter_mut() {
                p.stamp = p.time;
            }
        }
    }
    log.clock = clock;
    Ok(())
}

/// The topics `/tf` and `/tf_static` are also read, for the laser's mounting.
pub const TF_TOPICS: [&str; 2] = ["/tf", "/tf_static"];

/// One laser scan of a bag.
#[derive(Clone, Debug, PartialEq)]
pub struct BagScan {
    /// The message's number on its topic (from 1, file order).
    pub number: usize,
    /// Record time (s).
    pub time: f64,
    /// Header stamp (s), also the scan's `timestamp`.
    pub stamp: f64,
    /// Header frame (without a leading `/`).
    pub frame: String,
    /// The scan (no odometry, the laser at the origin of the robot frame: the pair
    /// builders set both).
    pub scan: Scan,
}

/// A stamped planar pose (odometry or a pose track).
#[derive(Clone, Debug, PartialEq)]
pub struct StampedPose {
    /// The message's number on its topic (from 1).
    pub number: usize,
    /// Record time (s).
    pub time: f64,
    /// Header stamp (s).
    pub stamp: f64,
    /// The frame the pose is expressed in (header frame).
    pub frame: String,
    /// The frame that moves (`child_frame_id` of odometry; empty for pose messages).
    pub child_frame: String,
    /// x, y and yaw (from the quaternion) of the pose.
    pub pose: Pose2,
}

/// One annotated person position of a people topic.
#[derive(Clone, Debug, PartialEq)]
pub struct BagPerson {
    /// The message's number on its topic (from 1).
    pub number: usize,
    /// Record time (s): it decides which scan the annotation belongs to.
    pub time: f64,
    /// The person's identity.
    pub id: u32,
    /// The position (x, y) in the laser frame.
    pub position: Point2<f64>,
}

/// A transform edge of `/tf` or `/tf_static`.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameTransform {
    /// Parent frame.
    pub parent: String,
    /// Child frame.
    pub child: String,
    /// Pose of the child frame in the parent frame (x, y, yaw).
    pub pose: Pose2,
}

/// What [`read_bag`] read.
#[derive(Clone, Debug, PartialEq)]
pub struct BagLog {
    /// The bag.
    pub path: PathBuf,
    /// Its container format.
    pub format: BagFormat,
    /// Every topic of the bag with its type and message count.
    pub topics: Vec<TopicInfo>,
    /// The scans, by record time.
    pub scans: Vec<BagScan>,
    /// Odometry messages, by header stamp.
    pub odometry: Vec<StampedPose>,
    /// The ego pose track, by header stamp.
    pub ego_poses: Vec<StampedPose>,
    /// The object pose track, by header stamp.
    pub object_poses: Vec<StampedPose>,
    /// Annotated people, by record time.
    pub people: Vec<BagPerson>,
    /// The first value of each transform edge of `/tf` and `/tf_static`.
    pub transforms: Vec<FrameTransform>,
    /// The topics read.
    pub read: BagTopics,
    /// The clock the messages were placed by: [`StampClock::Header`] or
    /// [`StampClock::Record`] ([`crate::stamps`]); every `stamp` and every scan's
    /// `timestamp` is on it.
    pub clock: StampClock,
    /// Notes for the user (header stamps at fault), each naming the bag.
    pub notes: Vec<String>,
}

impl BagLog {
    /// The transform from `parent` to `child` if the bag's tf has that edge.
    pub fn transform(&self, parent: &str, child: &str) -> Option<Pose2> {
        let (p, c) = (frame_name(parent), frame_name(child));
        self.transforms
            .iter()
            .find(|t| t.parent == p && t.child == c)
            .map(|t| t.pose)
    }
}

/// A frame name without a leading `/`.
pub fn frame_name(name: &str) -> &str {
    name.strip_prefix('/').unwrap_or(name)
}

/// Where in a bag a problem is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BagLocation {
    /// The topic (empty: the file as a whole).
    pub topic: String,
    /// The message's number on its topic, from 1 (0: no message).
    pub message: usize,
    /// The message's record time (s).
    pub time: Option<f64>,
    /// The field.
    pub field: String,
}

impl std::fmt::Display for BagLocation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if !self.topic.is_empty() {
            write!(f, ": topic {}", self.topic)?;
        }
        if self.message > 0 {
            write!(f, ", message {}", self.message)?;
            if let Some(t) = self.time {
                write!(f, " (t = {t:.6} s)")?;
            }
        }
        if !self.field.is_empty() {
            write!(f, ", field `{}`", self.field)?;
        }
        Ok(())
    }
}

pub(crate) fn bag_error(path: &Path, location: BagLocation, problem: impl Into<String>) -> Error {
    Error::Bag {
        path: path.to_path_buf(),
        location,
        problem: problem.into(),
    }
}

/// What a topic is read as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Scan,
    Odometry,
    People,
    EgoPose,
    ObjectPose,
    Tf,
}

struct MessageContext<'a> {
    path: &'a Path,
    topic: &'a str,
    type_name: &'a str,
    number: usize,
    time: f64,
}

impl MessageContext<'_> {
    fn error(&self, field: &str, problem: impl Into<String>) -> Error {
        bag_error(
            self.path,
            BagLocation {
                topic: self.topic.to_string(),
                message: self.number,
                time: Some(self.time),
                field: field.to_string(),
            },
            problem,
        )
    }

    fn value<'v>(&self, root: &'v Value, field: &str) -> Result<&'v Value> {
        root.at(field).ok_or_else(|| {
            self.error(
                field,
                format!("no such field in a message of type {}", self.type_name),
            )
        })
    }

    fn number(&self, root: &Value, field: &str) -> Result<f64> {
        let v = self.value(root, field)?;
        v.as_f64()
            .ok_or_else(|| self.error(field, format!("{v:?} is not a number")))
    }

    fn finite(&self, root: &Value, field: &str, limit: f64, what: &str) -> Result<f64> {
        let x = self.number(root, field)?;
        if !x.is_finite() || x.abs() > limit {
            return Err(self.error(
                field,
                format!("{x} is not {what} (finite, magnitude at most {limit:e})"),
            ));
        }
        Ok(x)
    }

    fn stamp(&self, root: &Value, field: &str) -> Result<f64> {
        let v = self.value(root, field)?;
        let t = v
            .as_seconds()
            .ok_or_else(|| self.error(field, "not a time stamp (sec, nanosec)"))?;
        if !(t.is_finite() && t.abs() <= limits::MAX_TIMESTAMP) {
            return Err(self.error(field, format!("time stamp {t} s is out of range")));
        }
        Ok(t)
    }

    fn string(&self, root: &Value, field: &str) -> Result<String> {
        let v = self.value(root, field)?;
        v.as_str()
            .map(|s| frame_name(s).to_string())
            .ok_or_else(|| self.error(field, "not a string"))
    }

    /// x, y and yaw of a `position` / `orientation` pair under `prefix`.
    fn pose(&self, root: &Value, position: &str, orientation: &str) -> Result<Pose2> {
        let x = self.finite(
            root,
            &format!("{position}.x"),
            limits::MAX_POSITION,
            "a position (m)",
        )?;
        let y = self.finite(
            root,
            &format!("{position}.y"),
            limits::MAX_POSITION,
            "a position (m)",
        )?;
        let q: Vec<f64> = ["x", "y", "z", "w"]
            .iter()
            .map(|c| {
                self.finite(
                    root,
                    &format!("{orientation}.{c}"),
                    1e6,
                    "a quaternion component",
                )
            })
            .collect::<Result<_>>()?;
        let (qx, qy, qz, qw) = (q[0], q[1], q[2], q[3]);
        let norm = qx * qx + qy * qy + qz * qz + qw * qw;
        if norm < 1e-12 {
            return Err(self.error(orientation, "a zero quaternion has no orientation"));
        }
        // Yaw of the rotation, whatever the quaternion's scale.
        let yaw = (2.0 * (qw * qz + qx * qy)).atan2(qw * qw + qx * qx - qy * qy - qz * qz);
        Ok(Pose2::new(x, y, yaw))
    }

    /// The pose of a message: `pose.pose` (odometry, pose with covariance), `pose`
    /// (pose stamped) or `transform` (transform stamped).
    fn any_pose(&self, root: &Value) -> Result<Pose2> {
        if root.at("pose.pose.position").is_some() {
            self.pose(root, "pose.pose.position", "pose.pose.orientation")
        } else if root.at("pose.position").is_some() {
            self.pose(root, "pose.position", "pose.orientation")
        } else if root.at("transform.translation").is_some() {
            self.pose(root, "transform.translation", "transform.rotation")
        } else {
            Err(self.error(
                "pose",
                format!(
                    "a message of type {} has no pose (pose.pose.position, pose.position or \
                     transform.translation)",
                    self.type_name
                ),
            ))
        }
    }
}

fn laser_scan(cx: &MessageContext<'_>, m: &Value) -> Result<BagScan> {
    let stamp = cx.stamp(m, "header.stamp")?;
    let frame = cx.string(m, "header.frame_id")?;
    let angle_min = cx.finite(m, "angle_min", 2.0 * limits::MAX_SPAN, "an angle (rad)")?;
    let angle_max = cx.finite(m, "angle_max", 2.0 * limits::MAX_SPAN, "an angle (rad)")?;
    let increment = cx.finite(m, "angle_increment", limits::MAX_SPAN, "an angle (rad)")?;
    let range_min = cx.finite(m, "range_min", limits::MAX_RANGE, "a range (m)")?;
    let range_max = cx.finite(m, "range_max", limits::MAX_RANGE, "a range (m)")?;
    if range_min < 0.0 {
        return Err(cx.error("range_min", format!("{range_min} is negative")));
    }
    if range_max <= range_min {
        return Err(cx.error(
            "range_max",
            format!("{range_max} is not above range_min {range_min}"),
        ));
    }
    let raw = cx.value(m, "ranges")?;
    let ranges_in = raw
        .as_numbers()
        .ok_or_else(|| cx.error("ranges", "not an array of numbers"))?;
    let n = ranges_in.len();
    if n == 0 {
        return Err(cx.error("ranges", "a laser scan needs at least one beam"));
    }
    if let Err(problem) = crate::beams::check_increment(n, increment) {
        return Err(cx.error("angle_increment", problem));
    }
    // The ranges must fill angle_min..angle_max to within one increment; within that
    // the increment wins (crate::beams).
    if let Err(given) = crate::beams::check_span(angle_max - angle_min, n, increment) {
        let last = angle_min + given;
        return Err(cx.error(
            "angle_max",
            format!(
                "angle_max {angle_max} rad ({:.4}°) disagrees by more than one increment with \
                 the last beam's angle angle_min + (n - 1) · angle_increment = {angle_min} + \
                 {} · {increment} = {last:.7} rad ({:.4}°): the {n} ranges do not fill \
                 angle_min..angle_max",
                angle_max.to_degrees(),
                n - 1,
                last.to_degrees()
            ),
        ));
    }
    let mut ranges = Vec::with_capacity(n);
    let mut valid = Vec::with_capacity(n);
    for (k, &r) in ranges_in.iter().enumerate() {
        // REP 117: -Inf (too close), +Inf (nothing in range) and NaN are beams
        // without a usable return (crate::beams); other negative ranges mean nothing.
        if r < 0.0 && !crate::beams::is_special_range(r) {
            return Err(cx.error(&format!("ranges[{k}]"), format!("negative range {r}")));
        }
        if r.is_finite() && r > limits::MAX_RANGE {
            return Err(cx.error(
                &format!("ranges[{k}]"),
                format!("a range of {r} m means nothing here"),
            ));
        }
        let (range, ok) = crate::beams::stored_beam(r, range_min, range_max);
        ranges.push(range);
        valid.push(ok);
    }
    Ok(BagScan {
        number: cx.number,
        time: cx.time,
        stamp,
        frame,
        scan: Scan {
            timestamp: stamp,
            angles: crate::beams::beam_angles(angle_min, increment, n),
            ranges,
            valid,
            max_range: range_max,
            odometry: None,
            laser_offset: Pose2::identity(),
        },
    })
}

fn stamped_pose(cx: &MessageContext<'_>, m: &Value) -> Result<StampedPose> {
    Ok(StampedPose {
        number: cx.number,
        time: cx.time,
        stamp: cx.stamp(m, "header.stamp")?,
        frame: cx.string(m, "header.frame_id")?,
        child_frame: if m.get("child_frame_id").is_some() {
            cx.string(m, "child_frame_id")?
        } else {
            String::new()
        },
        pose: cx.any_pose(m)?,
    })
}

fn person(cx: &MessageContext<'_>, m: &Value, prefix: &str) -> Result<BagPerson> {
    let field = |f: &str| {
        if prefix.is_empty() {
            f.to_string()
        } else {
            format!("{prefix}.{f}")
        }
    };
    let element = if prefix.is_empty() {
        m
    } else {
        cx.value(m, prefix)?
    };
    let id_field = field("id");
    let id = cx.number(element, "id").map_err(|_| {
        cx.error(
            &id_field,
            format!("no person id in a message of type {}", cx.type_name),
        )
    })?;
    if !(id >= 0.0 && id <= f64::from(u32::MAX) && id.fract() == 0.0) {
        return Err(cx.error(&id_field, format!("{id} is not a person id (0..2^32)")));
    }
    // A person's orientation means nothing (the leigh-gtm1 tracks leave it zero):
    // only the position is read.
    let position = ["pose.pose.position", "pose.position", "position"]
        .into_iter()
        .find(|p| element.at(p).is_some())
        .ok_or_else(|| {
            cx.error(
                &field("pose.position"),
                format!("no person position in a message of type {}", cx.type_name),
            )
        })?;
    let mut xy = [0.0; 2];
    for (k, c) in ["x", "y"].into_iter().enumerate() {
        let name = format!("{position}.{c}");
        xy[k] = cx
            .finite(
                element,
                &name,
                limits::MAX_RANGE,
                "a person position within a laser's reach",
            )
            .map_err(|_| {
                cx.error(
                    &field(&name),
                    "not a finite person position within a laser's reach",
                )
            })?;
    }
    let pose = Pose2::new(xy[0], xy[1], 0.0);
    Ok(BagPerson {
        number: cx.number,
        time: cx.time,
        id: id as u32,
        position: Point2::new(pose.x(), pose.y()),
    })
}

fn people(cx: &MessageContext<'_>, m: &Value) -> Result<Vec<BagPerson>> {
    if let Some(list) = m.get("people") {
        let items = list
            .as_array()
            .ok_or_else(|| cx.error("people", "not an array of people"))?;
        let mut out = Vec::with_capacity(items.len());
        for (k, item) in items.iter().enumerate() {
            let wrapped = Value::Message(vec![(format!("people[{k}]"), item.clone())]);
            out.push(person(cx, &wrapped, &format!("people[{k}]"))?);
        }
        return Ok(out);
    }
    Ok(vec![person(cx, m, "")?])
}

fn transforms(cx: &MessageContext<'_>, m: &Value) -> Result<Vec<FrameTransform>> {
    let list = cx
        .value(m, "transforms")?
        .as_array()
        .ok_or_else(|| cx.error("transforms", "not an array of transforms"))?;
    let mut out = Vec::with_capacity(list.len());
    for (k, t) in list.iter().enumerate() {
        let wrapped = Value::Message(vec![("t".into(), t.clone())]);
        let prefix = format!("transforms[{k}]");
        let rename = |e: Error| match e {
            Error::Bag {
                location, problem, ..
            } => cx.error(&location.field.replacen('t', &prefix, 1), problem),
            other => other,
        };
        out.push(FrameTransform {
            parent: cx.string(&wrapped, "t.header.frame_id").map_err(rename)?,
            child: cx.string(&wrapped, "t.child_frame_id").map_err(rename)?,
            pose: cx
                .pose(&wrapped, "t.transform.translation", "t.transform.rotation")
                .map_err(rename)?,
        });
    }
    Ok(out)
}

/// Reads the topics of `topics` from the bag at `path` (see the module docs).
///
/// # Errors
/// [`Error::Bag`] naming the file, topic, message and field: a file that is no bag, a
/// topic the bag does not have (the error lists those it has), a message that does
/// not decode by its definition or lacks a field a reader needs, values out of range.
pub fn read_bag(path: &Path, topics: &BagTopics) -> Result<BagLog> {
    let mut roles: Vec<(&str, Role)> = vec![(topics.scan.as_str(), Role::Scan)];
    for (t, role) in [
        (&topics.odometry, Role::Odometry),
        (&topics.people, Role::People),
        (&topics.ego_pose, Role::EgoPose),
        (&topics.object_pose, Role::ObjectPose),
    ] {
        if let Some(t) = t {
            if roles.iter().any(|(r, _)| r == t) {
                return Err(bag_error(
                    path,
                    BagLocation {
                        topic: t.clone(),
                        ..Default::default()
                    },
                    "the same topic is given for two roles",
                ));
            }
            roles.push((t.as_str(), role));
        }
    }
    for tf in TF_TOPICS {
        if !roles.iter().any(|(r, _)| *r == tf) {
            roles.push((tf, Role::Tf));
        }
    }
    let wanted: Vec<&str> = roles.iter().map(|(t, _)| *t).collect();
    let mut log = BagLog {
        path: path.to_path_buf(),
        format: BagFormat::Ros1,
        topics: Vec::new(),
        scans: Vec::new(),
        odometry: Vec::new(),
        ego_poses: Vec::new(),
        object_poses: Vec::new(),
        people: Vec::new(),
        transforms: Vec::new(),
        read: topics.clone(),
        clock: StampClock::Header,
        notes: Vec::new(),
    };
    let mut decoders: BTreeMap<(String, String, String), Decoder> = BTreeMap::new();
    let mut callback = |m: RawMessage<'_>| -> Result<()> {
        let c = m.connection;
        let role = roles
            .iter()
            .find(|(t, _)| *t == c.topic)
            .map(|(_, r)| *r)
            .ok_or_else(|| {
                bag_error(
                    path,
                    BagLocation::default(),
                    format!("unexpected topic {}", c.topic),
                )
            })?;
        let time = m.time as f64 * 1e-9;
        let cx = MessageContext {
            path,
            topic: &c.topic,
            type_name: &c.type_name,
            number: m.number,
            time,
        };
        let key = (c.topic.clone(), c.type_name.clone(), c.definition.clone());
        if !decoders.contains_key(&key) {
            let defs = Definitions::parse(&c.type_name, &c.definition, c.dialect)
                .map_err(|e| cx.error("", e.to_string()))?;
            decoders.insert(key.clone(), Decoder::new(defs));
        }
        let value = decoders[&key]
            .decode(m.data)
            .map_err(|e| cx.error(&e.field, format!("{} (byte {})", e.problem, e.offset)))?;
        let outcome = match role {
            Role::Scan => laser_scan(&cx, &value).map(|s| log.scans.push(s)),
            Role::Odometry => stamped_pose(&cx, &value).map(|p| log.odometry.push(p)),
            Role::EgoPose => stamped_pose(&cx, &value).map(|p| log.ego_poses.push(p)),
            Role::ObjectPose => stamped_pose(&cx, &value).map(|p| log.object_poses.push(p)),
            Role::People => people(&cx, &value).map(|p| log.people.extend(p)),
            Role::Tf => transforms(&cx, &value).map(|list| {
                for t in list {
                    if !log
                        .transforms
                        .iter()
                        .any(|x| x.parent == t.parent && x.child == t.child)
                    {
                        log.transforms.push(t);
                    }
                }
            }),
        };
        outcome
    };
    let summary = match read_container(path, &wanted, &mut callback) {
        Ok(s) => s,
        Err(ReadError::Message(e)) => return Err(e),
        Err(ReadError::Container(problem)) => {
            return Err(bag_error(path, BagLocation::default(), problem));
        }
        Err(ReadError::Located {
            topic,
            message,
            time_ns,
            problem,
        }) => {
            let location = BagLocation {
                topic,
                message,
                time: time_ns.map(|t| t as f64 * 1e-9),
                field: String::new(),
            };
            return Err(bag_error(path, location, problem));
        }
    };
    log.format = summary.format.unwrap_or(BagFormat::Ros1);
    log.topics = summary.topics;
    for (topic, _) in roles.iter().filter(|(_, r)| *r != Role::Tf) {
        if !log.topics.iter().any(|t| t.topic == *topic) {
            let known: Vec<String> = log
                .topics
                .iter()
                .map(|t| format!("{} ({}, {})", t.topic, t.type_name, t.messages))
                .collect();
            return Err(bag_error(
                path,
                BagLocation {
                    topic: topic.to_string(),
                    ..Default::default()
                },
                format!("no such topic in the bag; it has: {}", known.join(", ")),
            ));
        }
    }
    let by_time = |a: f64, b: f64| a.total_cmp(&b);
    log.scans.sort_by(|a, b| by_time(a.time, b.time));
    log.people.sort_by(|a, b| by_time(a.time, b.time));
    for track in [&mut log.odometry, &mut log.ego_poses, &mut log.object_poses] {
        track.sort_by(|a, b| by_time(a.time, b.time));
    }
    place_by_clock(path, &mut log)?;
    for track in [&mut log.odometry, &mut log.ego_poses, &mut log.object_poses] {
        track.sort_by(|a, b| by_time(a.stamp, b.stamp));
    }
    if log.scans.is_empty() {
        return Err(bag_error(
            path,
            BagLocation {
                topic: topics.scan.clone(),
                ..Default::default()
            },
            "the topic has no message",
        ));
    }
    Ok(log)
}
