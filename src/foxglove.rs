//! Results as MCAP files that Foxglove opens (`pgm track|match|cluster|joint --mcap
//! FILE`): per scan, the laser scan as `foxglove.LaserScan`, the sensor's pose as
//! `foxglove.FrameTransform`, and clusters, tracks and associations as
//! `foxglove.SceneUpdate` entities.
//!
//! Messages are JSON (MCAP message encoding `json`) under Foxglove's own JSON Schemas
//! (schema encoding `jsonschema`, schema names `foxglove.LaserScan`,
//! `foxglove.FrameTransform`, `foxglove.SceneUpdate`). The schemas are stored
//! unchanged from Foxglove's npm package `@foxglove/schemas` (version in
//! `src/foxglove/schemas/VERSION`, MIT, generated from
//! <https://github.com/foxglove/foxglove-sdk>; `tools/foxglove-schemas.sh` writes
//! them again). Why not Foxglove's SDK crate `foxglove`: its 0.30 release needs Rust
//! 1.88 (this workspace builds with 1.85) and brings its own protobuf stack, while
//! the `mcap` crate is already what the bag readers use; JSON keeps every message
//! readable with any JSON tool.
//!
//! Units: metres, radians, seconds (time stamps as `{sec, nsec}` since the log's
//! epoch). Frames: see [`track_recording`] and [`pair_recording`]. A beam without a
//! return has range 0 in the `LaserScan` (the scan's own convention; JSON has no
//! infinity): Foxglove draws those at the sensor's origin.
//!
//! The file is built in memory and returned as bytes, for the caller to write
//! atomically (`pgm_datasets::format::StagedFile`).

use crate::plot::{cluster_colour, PairPicture};
use nalgebra::Point2;
use pgm_scan::{Association, Pose2, Scan};
use pgm_tracking::online::{ScanReport, TrackState};
use plotters::style::RGBColor;
use serde::Serialize;
use std::collections::BTreeMap;

/// Foxglove's JSON Schema of `foxglove.LaserScan` (from `@foxglove/schemas`).
pub const LASER_SCAN_SCHEMA: &str = include_str!("foxglove/schemas/LaserScan.json");
/// Foxglove's JSON Schema of `foxglove.FrameTransform` (from `@foxglove/schemas`).
pub const FRAME_TRANSFORM_SCHEMA: &str = include_str!("foxglove/schemas/FrameTransform.json");
/// Foxglove's JSON Schema of `foxglove.SceneUpdate` (from `@foxglove/schemas`).
pub const SCENE_UPDATE_SCHEMA: &str = include_str!("foxglove/schemas/SceneUpdate.json");

/// Topics of a [`track_recording`].
pub mod topics {
    /// `foxglove.LaserScan`, frame [`super::SENSOR_FRAME`] (`pgm track`).
    pub const SCAN: &str = "/scan";
    /// `foxglove.FrameTransform`: the sensor in the fixed frame, one per scan.
    pub const TF: &str = "/tf";
    /// `foxglove.SceneUpdate`: the tracks of each scan (`pgm track`).
    pub const TRACKS: &str = "/tracks";
    /// `foxglove.SceneUpdate`: each track's path so far, in the fixed frame (`pgm
    /// track`).
    pub const TRACK_PATHS: &str = "/tracks/paths";
    /// `foxglove.LaserScan`, frame [`super::REFERENCE_FRAME`] (pair commands).
    pub const REFERENCE_SCAN: &str = "/reference/scan";
    /// `foxglove.LaserScan`, frame [`super::CURRENT_FRAME`] (pair commands).
    pub const CURRENT_SCAN: &str = "/current/scan";
    /// `foxglove.SceneUpdate`: the moving clusters of the pair.
    pub const CLUSTERS: &str = "/clusters";
    /// `foxglove.SceneUpdate`: one line per current return and its reference partner.
    pub const ASSOCIATIONS: &str = "/associations";
}

/// How many reported centres a track's path holds in a track recording (20 s at
/// 10 Hz): each scan's message repeats the path, so a longer one would make a long
/// log's file grow with the square of a track's age.
pub const PATH_LENGTH: usize = 200;

/// Fixed frame of a track recording: the sensor frame of the sequence's first scan.
pub const WORLD_FRAME: &str = "world";
/// The laser's frame in a track recording.
pub const SENSOR_FRAME: &str = "laser";
/// Fixed frame of a pair recording: the reference scan's sensor frame.
pub const REFERENCE_FRAME: &str = "reference";
/// The current scan's sensor frame in a pair recording.
pub const CURRENT_FRAME: &str = "current";

/// Why a recording could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// A value a Foxglove message cannot hold.
    #[error("{what}: {problem}")]
    Value {
        /// What it is (a scan's name and field).
        what: String,
        /// Why it cannot be written.
        problem: String,
    },
    /// The MCAP writer failed.
    #[error("writing MCAP: {0}")]
    Mcap(#[from] mcap::McapError),
    /// A message could not be encoded.
    #[error("encoding a message as JSON: {0}")]
    Json(#[from] serde_json::Error),
}

fn value_error(what: impl Into<String>, problem: impl Into<String>) -> RecordingError {
    RecordingError::Value {
        what: what.into(),
        problem: problem.into(),
    }
}

// ---------------------------------------------------------------------------
// Foxglove's message types, field for field as their JSON Schemas define them
// (every field is required there).

/// `time`: seconds and nanoseconds.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Time {
    /// Whole seconds (≥ 0).
    pub sec: u32,
    /// Nanoseconds (0 ..= 999 999 999).
    pub nsec: u32,
}

impl Time {
    /// The time `seconds` (finite, ≥ 0, below 2³² s), for the value named `what`.
    fn from_seconds(seconds: f64, what: &str) -> Result<Self, RecordingError> {
        if !(seconds.is_finite() && (0.0..4_294_967_296.0).contains(&seconds)) {
            return Err(value_error(
                what,
                format!(
                    "time stamp {seconds:?} s: a Foxglove time is a finite, non-negative \
                     number of seconds below 2^32"
                ),
            ));
        }
        let ns = (seconds * 1e9).round() as u64;
        Ok(Time {
            sec: (ns / 1_000_000_000) as u32,
            nsec: (ns % 1_000_000_000) as u32,
        })
    }

    fn nanoseconds(self) -> u64 {
        u64::from(self.sec) * 1_000_000_000 + u64::from(self.nsec)
    }
}

/// `duration`.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Duration {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds (0 ..= 999 999 999).
    pub nsec: u32,
}

/// `foxglove.Vector3` (also `foxglove.Point3`, which has the same fields).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Vector3 {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
}

/// `foxglove.Quaternion`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Quaternion {
    /// The rotation by `yaw` (rad) about z.
    pub fn yaw(yaw: f64) -> Self {
        let (s, c) = (yaw / 2.0).sin_cos();
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }
}

/// `foxglove.Pose`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Pose {
    /// Position (m).
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

impl Pose {
    /// At `(x, y, z)`, turned by `yaw` about z.
    pub fn planar(x: f64, y: f64, z: f64, yaw: f64) -> Self {
        Pose {
            position: Vector3 { x, y, z },
            orientation: Quaternion::yaw(yaw),
        }
    }

    fn identity() -> Self {
        Pose::planar(0.0, 0.0, 0.0, 0.0)
    }
}

/// `foxglove.Color` (each channel in [0, 1]).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Color {
    /// Red.
    pub r: f64,
    /// Green.
    pub g: f64,
    /// Blue.
    pub b: f64,
    /// Opacity.
    pub a: f64,
}

impl Color {
    /// The SVG pictures' colour `c` at opacity `a`.
    pub fn of(c: RGBColor, a: f64) -> Self {
        Color {
            r: f64::from(c.0) / 255.0,
            g: f64::from(c.1) / 255.0,
            b: f64::from(c.2) / 255.0,
            a,
        }
    }
}

/// `foxglove.LaserScan`.
#[derive(Clone, Debug, Serialize)]
pub struct LaserScan {
    /// Time of the scan.
    pub timestamp: Time,
    /// Its frame.
    pub frame_id: String,
    /// Origin of the scan in that frame.
    pub pose: Pose,
    /// Bearing of the first beam (rad).
    pub start_angle: f64,
    /// Bearing of the last beam (rad).
    pub end_angle: f64,
    /// Ranges (m), at equally spaced bearings from `start_angle` to `end_angle`.
    pub ranges: Vec<f64>,
    /// Intensities (empty: the scans carry none).
    pub intensities: Vec<f64>,
}

/// `foxglove.FrameTransform`.
#[derive(Clone, Debug, Serialize)]
pub struct FrameTransform {
    /// Time of the transform.
    pub timestamp: Time,
    /// The parent frame.
    pub parent_frame_id: String,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's origin in the parent (m).
    pub translation: Vector3,
    /// The child's orientation in the parent.
    pub rotation: Quaternion,
}

/// `foxglove.SceneUpdate`.
#[derive(Clone, Debug, Serialize)]
pub struct SceneUpdate {
    /// Entities to remove first.
    pub deletions: Vec<SceneEntityDeletion>,
    /// Entities to add or replace.
    pub entities: Vec<SceneEntity>,
}

/// `foxglove.SceneEntityDeletion`.
#[derive(Clone, Debug, Serialize)]
pub struct SceneEntityDeletion {
    /// Entities older than this are removed.
    pub timestamp: Time,
    /// 0 = the entity `id`, 1 = all entities of the topic.
    #[serde(rename = "type")]
    pub kind: u8,
    /// The entity (for `kind` 0).
    pub id: String,
}

/// `foxglove.SceneEntity`.
#[derive(Clone, Debug, Serialize)]
pub struct SceneEntity {
    /// Time of the entity.
    pub timestamp: Time,
    /// Its frame.
    pub frame_id: String,
    /// Its identifier within the topic.
    pub id: String,
    /// How long it is shown (0: until replaced or deleted).
    pub lifetime: Duration,
    /// Whether it moves with its frame.
    pub frame_locked: bool,
    /// Key-value pairs Foxglove shows when the entity is selected.
    pub metadata: Vec<KeyValuePair>,
    /// Arrows.
    pub arrows: Vec<ArrowPrimitive>,
    /// Boxes.
    pub cubes: Vec<CubePrimitive>,
    /// Spheres (returns).
    pub spheres: Vec<CubePrimitive>,
    /// Cylinders (none written).
    pub cylinders: Vec<serde_json::Value>,
    /// Lines.
    pub lines: Vec<LinePrimitive>,
    /// Triangles (none written).
    pub triangles: Vec<serde_json::Value>,
    /// Text labels.
    pub texts: Vec<TextPrimitive>,
    /// Models (none written).
    pub models: Vec<serde_json::Value>,
}

impl SceneEntity {
    fn new(timestamp: Time, frame_id: &str, id: String) -> Self {
        SceneEntity {
            timestamp,
            frame_id: frame_id.to_string(),
            id,
            lifetime: Duration::default(),
            frame_locked: false,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: Vec::new(),
            spheres: Vec::new(),
            cylinders: Vec::new(),
            lines: Vec::new(),
            triangles: Vec::new(),
            texts: Vec::new(),
            models: Vec::new(),
        }
    }

    fn meta(&mut self, key: &str, value: impl ToString) {
        self.metadata.push(KeyValuePair {
            key: key.to_string(),
            value: value.to_string(),
        });
    }

    /// A sphere of diameter `size` (m) at every point.
    fn dots(&mut self, points: impl IntoIterator<Item = Point2<f64>>, size: f64, color: Color) {
        for p in points {
            self.spheres.push(CubePrimitive {
                pose: Pose::planar(p.x, p.y, 0.0, 0.0),
                size: Vector3 {
                    x: size,
                    y: size,
                    z: size,
                },
                color,
            });
        }
    }

    /// An arrow from `from` to `to` (m), its head 0.15 m long; nothing when the two are
    /// closer than a centimetre.
    fn arrow(&mut self, from: Point2<f64>, to: Point2<f64>, color: Color) {
        let d = to - from;
        let length = d.norm();
        if length < 0.01 {
            return;
        }
        let head = 0.15f64.min(0.5 * length);
        self.arrows.push(ArrowPrimitive {
            pose: Pose::planar(from.x, from.y, 0.05, d.y.atan2(d.x)),
            shaft_length: length - head,
            shaft_diameter: 0.04,
            head_length: head,
            head_diameter: 0.12,
            color,
        });
    }

    fn label(&mut self, at: Point2<f64>, text: String, color: Color) {
        self.texts.push(TextPrimitive {
            pose: Pose::planar(at.x, at.y, 0.6, 0.0),
            billboard: true,
            font_size: 14.0,
            scale_invariant: true,
            color,
            text,
        });
    }
}

/// `foxglove.KeyValuePair`.
#[derive(Clone, Debug, Serialize)]
pub struct KeyValuePair {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `foxglove.ArrowPrimitive`: along +x of `pose`.
#[derive(Clone, Debug, Serialize)]
pub struct ArrowPrimitive {
    /// Tail and direction.
    pub pose: Pose,
    /// Shaft length (m).
    pub shaft_length: f64,
    /// Shaft diameter (m).
    pub shaft_diameter: f64,
    /// Head length (m).
    pub head_length: f64,
    /// Head diameter (m).
    pub head_diameter: f64,
    /// Colour.
    pub color: Color,
}

/// `foxglove.CubePrimitive` (and `foxglove.SpherePrimitive`, same fields).
#[derive(Clone, Debug, Serialize)]
pub struct CubePrimitive {
    /// Centre and orientation.
    pub pose: Pose,
    /// Size along each axis (m).
    pub size: Vector3,
    /// Colour.
    pub color: Color,
}

/// `foxglove.LinePrimitive`.
#[derive(Clone, Debug, Serialize)]
pub struct LinePrimitive {
    /// 0 = strip, 1 = loop, 2 = list of segments.
    #[serde(rename = "type")]
    pub kind: u8,
    /// Origin of the points.
    pub pose: Pose,
    /// Thickness (pixels when `scale_invariant`).
    pub thickness: f64,
    /// Whether `thickness` is in pixels.
    pub scale_invariant: bool,
    /// The points (m).
    pub points: Vec<Vector3>,
    /// Colour of every segment.
    pub color: Color,
    /// Per-point colours (empty).
    pub colors: Vec<Color>,
    /// Indices into `points` (empty: all in order).
    pub indices: Vec<u32>,
}

/// `foxglove.TextPrimitive`.
#[derive(Clone, Debug, Serialize)]
pub struct TextPrimitive {
    /// Where.
    pub pose: Pose,
    /// Always facing the camera.
    pub billboard: bool,
    /// Font size (pixels when `scale_invariant`).
    pub font_size: f64,
    /// Whether `font_size` is in pixels.
    pub scale_invariant: bool,
    /// Colour.
    pub color: Color,
    /// The text.
    pub text: String,
}

// ---------------------------------------------------------------------------

/// An MCAP file being written in memory: channels under Foxglove's schemas, JSON
/// messages, zstd-compressed chunks with CRCs.
pub struct Recording {
    writer: mcap::Writer<std::io::Cursor<Vec<u8>>>,
    channels: BTreeMap<&'static str, (u16, u32)>,
    schemas: BTreeMap<&'static str, u16>,
}

impl std::fmt::Debug for Recording {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recording")
            .field("channels", &self.channels)
            .finish_non_exhaustive()
    }
}

impl Recording {
    /// An empty recording.
    ///
    /// # Errors
    /// The MCAP writer's.
    pub fn new() -> Result<Self, RecordingError> {
        let writer = mcap::WriteOptions::new()
            .profile("")
            .library(concat!("pgm ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .create(std::io::Cursor::new(Vec::new()))?;
        Ok(Recording {
            writer,
            channels: BTreeMap::new(),
            schemas: BTreeMap::new(),
        })
    }

    fn channel(
        &mut self,
        topic: &'static str,
        schema: &'static str,
    ) -> Result<(u16, u32), RecordingError> {
        if let Some(&c) = self.channels.get(topic) {
            return Ok(c);
        }
        let data = match schema {
            "foxglove.LaserScan" => LASER_SCAN_SCHEMA,
            "foxglove.FrameTransform" => FRAME_TRANSFORM_SCHEMA,
            _ => SCENE_UPDATE_SCHEMA,
        };
        let schema_id = match self.schemas.get(schema) {
            Some(&id) => id,
            None => {
                let id = self
                    .writer
                    .add_schema(schema, "jsonschema", data.as_bytes())?;
                self.schemas.insert(schema, id);
                id
            }
        };
        let id = self
            .writer
            .add_channel(schema_id, topic, "json", &BTreeMap::new())?;
        self.channels.insert(topic, (id, 0));
        Ok((id, 0))
    }

    fn write(
        &mut self,
        topic: &'static str,
        schema: &'static str,
        time: Time,
        message: &impl Serialize,
    ) -> Result<(), RecordingError> {
        let (id, sequence) = self.channel(topic, schema)?;
        let data = serde_json::to_vec(message)?;
        self.writer.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: id,
                sequence,
                log_time: time.nanoseconds(),
                publish_time: time.nanoseconds(),
            },
            &data,
        )?;
        self.channels.insert(topic, (id, sequence + 1));
        Ok(())
    }

    /// Writes `scan` (named `name` in errors) on `topic` in `frame`.
    ///
    /// # Errors
    /// [`RecordingError::Value`] when its time stamp is negative or not finite, or its
    /// beams are not equally spaced in bearing (within 1 % of a step), which
    /// `foxglove.LaserScan` cannot hold.
    pub fn laser_scan(
        &mut self,
        topic: &'static str,
        frame: &str,
        scan: &Scan,
        name: &str,
    ) -> Result<Time, RecordingError> {
        let timestamp = Time::from_seconds(scan.timestamp, &format!("{name}: timestamp"))?;
        let n = scan.angles.len();
        let (start, end) = match (scan.angles.first(), scan.angles.last()) {
            (Some(&a), Some(&b)) => (a, b),
            _ => (0.0, 0.0),
        };
        if n > 2 {
            let step = (end - start) / (n - 1) as f64;
            let worst = scan
                .angles
                .iter()
                .enumerate()
                .map(|(k, a)| (a - (start + k as f64 * step)).abs())
                .fold(0.0, f64::max);
            if worst.is_nan() || worst > 0.01 * step.abs() {
                return Err(value_error(
                    format!("{name}: angles"),
                    format!(
                        "the beams are not equally spaced in bearing (a beam lies {worst:.3e} \
                         rad off the even step of {step:.3e} rad), which foxglove.LaserScan \
                         cannot hold"
                    ),
                ));
            }
        }
        let ranges = scan
            .ranges
            .iter()
            .zip(&scan.valid)
            .map(|(&r, &v)| if v && r.is_finite() { r } else { 0.0 })
            .collect();
        let message = LaserScan {
            timestamp,
            frame_id: frame.to_string(),
            pose: Pose::identity(),
            start_angle: start,
            end_angle: end,
            ranges,
            intensities: Vec::new(),
        };
        self.write(topic, "foxglove.LaserScan", timestamp, &message)?;
        Ok(timestamp)
    }

    /// Writes the pose of `child` in `parent` at `time` on [`topics::TF`].
    ///
    /// # Errors
    /// The writer's.
    pub fn frame_transform(
        &mut self,
        time: Time,
        parent: &str,
        child: &str,
        pose: &Pose2,
    ) -> Result<(), RecordingError> {
        let message = FrameTransform {
            timestamp: time,
            parent_frame_id: parent.to_string(),
            child_frame_id: child.to_string(),
            translation: Vector3 {
                x: pose.x(),
                y: pose.y(),
                z: 0.0,
            },
            rotation: Quaternion::yaw(pose.theta()),
        };
        self.write(topics::TF, "foxglove.FrameTransform", time, &message)
    }

    /// Writes `entities` on `topic` at `time`, after deleting every entity the topic
    /// showed before.
    ///
    /// # Errors
    /// The writer's.
    pub fn scene(
        &mut self,
        topic: &'static str,
        time: Time,
        entities: Vec<SceneEntity>,
    ) -> Result<(), RecordingError> {
        let message = SceneUpdate {
            deletions: vec![SceneEntityDeletion {
                timestamp: time,
                kind: 1,
                id: String::new(),
            }],
            entities,
        };
        self.write(topic, "foxglove.SceneUpdate", time, &message)
    }

    /// Finishes the file (summary, indexes, CRCs) and returns its bytes.
    ///
    /// # Errors
    /// The writer's.
    pub fn finish(mut self) -> Result<Vec<u8>, RecordingError> {
        self.writer.finish()?;
        Ok(self.writer.into_inner().into_inner())
    }
}

/// The state's name as `pgm track` prints it.
fn state_name(state: TrackState) -> &'static str {
    match state {
        TrackState::Tentative => "tentative",
        TrackState::Confirmed => "confirmed",
        TrackState::Coasting => "coasting",
        TrackState::Stopped => "stopped",
    }
}

/// The MCAP file of a tracked sequence (`pgm track --mcap`): for every
/// `(name, scan, report)` of `scans` (the name is for errors), on
/// - [`topics::SCAN`]: the scan in frame [`SENSOR_FRAME`];
/// - [`topics::TF`]: the sensor's pose ([`ScanReport::pose`]) in [`WORLD_FRAME`], the
///   sensor frame of its sequence's first scan (each sequence starts there again);
/// - [`topics::TRACKS`]: one entity per track the report shows (confirmed, stopped or
///   coasting; tentative tracks are left out, as in the JSON's counts and the SVG):
///   a box of the track's extent turned along its velocity (translucent when
///   coasting), its number (the JSON's `track`), its velocity as an arrow of where it
///   will be in one second, its returns as dots, and its state, score and speed as
///   metadata; colours as in `pgm track --svg`;
/// - [`topics::TRACK_PATHS`]: for the same tracks, the path of their last
///   [`PATH_LENGTH`] reported centres (this scan's included), a line in
///   [`WORLD_FRAME`] (a sequence's paths start again with it).
///
/// # Errors
/// [`RecordingError::Value`] naming the scan and field a message cannot hold (see
/// [`Recording::laser_scan`]); the writer's.
pub fn track_recording<'a>(
    scans: impl IntoIterator<Item = (&'a str, &'a Scan, &'a ScanReport)>,
) -> Result<Vec<u8>, RecordingError> {
    let mut rec = Recording::new()?;
    // Each track's reported centres so far (fixed frame), for the current sequence.
    let mut paths: BTreeMap<u64, Vec<Vector3>> = BTreeMap::new();
    let mut sequence = None;
    for (name, scan, report) in scans {
        let time = rec.laser_scan(topics::SCAN, SENSOR_FRAME, scan, name)?;
        rec.frame_transform(time, WORLD_FRAME, SENSOR_FRAME, &report.pose)?;
        if sequence != Some(report.sequence) {
            paths.clear();
            sequence = Some(report.sequence);
        }
        let mut entities = Vec::new();
        let mut lines = Vec::new();
        for o in report
            .objects
            .iter()
            .filter(|o| o.state != TrackState::Tentative)
        {
            let colour = cluster_colour(o.track as u32 + 1);
            let coasting = o.state == TrackState::Coasting;
            let mut e = SceneEntity::new(time, SENSOR_FRAME, format!("track {}", o.track));
            let centre = Point2::new(o.centre[0], o.centre[1]);
            let v = nalgebra::Vector2::new(o.velocity[0], o.velocity[1]);
            let heading = if v.norm() > 1e-9 { v.y.atan2(v.x) } else { 0.0 };
            e.cubes.push(CubePrimitive {
                pose: Pose::planar(centre.x, centre.y, 0.15, heading),
                size: Vector3 {
                    x: o.extent[0].max(0.1),
                    y: o.extent[1].max(0.1),
                    z: 0.3,
                },
                color: Color::of(colour, if coasting { 0.15 } else { 0.4 }),
            });
            e.arrow(centre, centre + v, Color::of(colour, 1.0));
            e.label(centre, o.track.to_string(), Color::of(colour, 1.0));
            e.dots(
                o.beams.iter().map(|&k| scan.beam_point(k)),
                0.06,
                Color::of(colour, 1.0),
            );
            e.meta("track", o.track);
            e.meta("state", state_name(o.state));
            e.meta("score", format!("{:.3}", o.score));
            e.meta("speed (m/s)", format!("{:.3}", v.norm()));
            e.meta("detected", o.detected);
            entities.push(e);
            let at = report.pose.transform_point(&centre);
            let path = paths.entry(o.track).or_default();
            if path.len() == PATH_LENGTH {
                path.remove(0);
            }
            path.push(Vector3 {
                x: at.x,
                y: at.y,
                z: 0.0,
            });
            let mut line = SceneEntity::new(time, WORLD_FRAME, format!("track {}", o.track));
            line.meta("track", o.track);
            line.meta("reported centres", path.len());
            line.lines.push(LinePrimitive {
                kind: 0,
                pose: Pose::identity(),
                thickness: 2.0,
                scale_invariant: true,
                points: path.clone(),
                color: Color::of(colour, 1.0),
                colors: Vec::new(),
                indices: Vec::new(),
            });
            lines.push(line);
        }
        rec.scene(topics::TRACKS, time, entities)?;
        rec.scene(topics::TRACK_PATHS, time, lines)?;
    }
    rec.finish()
}

/// The MCAP file of one pair as `picture` shows it (`pgm match|cluster|joint --mcap`):
/// - [`topics::REFERENCE_SCAN`] at the reference scan's time, frame
///   [`REFERENCE_FRAME`]; [`topics::CURRENT_SCAN`] at the current scan's, frame
///   [`CURRENT_FRAME`];
/// - [`topics::TF`]: [`CURRENT_FRAME`] in [`REFERENCE_FRAME`] by the picture's
///   alignment (the estimated ego-motion), at both times;
/// - [`topics::CLUSTERS`] (when the picture has labels), at the current time, in the
///   reference frame: per moving cluster, its returns as dots, their bounding box,
///   its number and kind (the SVG's numbers and colours), and its motion as an arrow
///   from where its centre was at the reference time to where it is; returns in no
///   cluster (the joint model's outlier cluster) as black dots;
/// - [`topics::ASSOCIATIONS`] (when the picture has associations), at the current
///   time, in the reference frame: a line from every aligned current return to its
///   reference partner.
///
/// # Errors
/// As [`track_recording`]; [`RecordingError::Value`] when the labels or associations
/// do not match the current scan.
pub fn pair_recording(picture: &PairPicture<'_>) -> Result<Vec<u8>, RecordingError> {
    let pair = picture.pair;
    let mut rec = Recording::new()?;
    let name = |which: &str| format!("{} ({which} scan)", pair.name);
    let t0 = rec.laser_scan(
        topics::REFERENCE_SCAN,
        REFERENCE_FRAME,
        &pair.reference,
        &name("reference"),
    )?;
    rec.frame_transform(t0, REFERENCE_FRAME, CURRENT_FRAME, &picture.alignment)?;
    let t1 = rec.laser_scan(
        topics::CURRENT_SCAN,
        CURRENT_FRAME,
        &pair.current,
        &name("current"),
    )?;
    rec.frame_transform(t1, REFERENCE_FRAME, CURRENT_FRAME, &picture.alignment)?;
    if let Some(labels) = picture.labels {
        let clusters = picture
            .moving_clusters()
            .map_err(|e| value_error(format!("{}: labels", pair.name), e.to_string()))?;
        let mut entities = Vec::new();
        for c in &clusters {
            let colour = Color::of(c.colour, 1.0);
            let mut e = SceneEntity::new(t1, REFERENCE_FRAME, format!("cluster {}", c.number));
            let (lo, hi) = c.points.iter().fold(
                (
                    Point2::new(f64::INFINITY, f64::INFINITY),
                    Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
                ),
                |(lo, hi), p| {
                    (
                        Point2::new(lo.x.min(p.x), lo.y.min(p.y)),
                        Point2::new(hi.x.max(p.x), hi.y.max(p.y)),
                    )
                },
            );
            let mid = nalgebra::center(&lo, &hi);
            e.cubes.push(CubePrimitive {
                pose: Pose::planar(mid.x, mid.y, 0.15, 0.0),
                size: Vector3 {
                    x: (hi.x - lo.x).max(0.1),
                    y: (hi.y - lo.y).max(0.1),
                    z: 0.3,
                },
                color: Color::of(c.colour, 0.25),
            });
            e.dots(c.points.iter().copied(), 0.06, colour);
            if let Some((from, to)) = c.arrow {
                e.arrow(from, to, colour);
            }
            e.label(mid, format!("{} {}", c.number, c.kind), colour);
            e.meta("cluster", c.number);
            e.meta("label", c.label);
            e.meta("kind", &c.kind);
            e.meta("returns", c.points.len());
            if let Some(m) = picture.motions.iter().find(|m| m.label == c.label) {
                e.meta(
                    "motion (x m, y m, theta rad)",
                    format!(
                        "{:.3}, {:.3}, {:.4}",
                        m.motion.x(),
                        m.motion.y(),
                        m.motion.theta()
                    ),
                );
            }
            entities.push(e);
        }
        let unlabelled: Vec<Point2<f64>> = (0..pair.current.len())
            .filter(|&k| pair.current.valid[k] && labels[k].is_none())
            .map(|k| {
                picture
                    .alignment
                    .transform_point(&pair.current.beam_point(k))
            })
            .collect();
        if !unlabelled.is_empty() {
            let mut e = SceneEntity::new(t1, REFERENCE_FRAME, "in no cluster".into());
            e.meta(
                "what",
                picture
                    .unlabelled
                    .as_deref()
                    .unwrap_or("return in no cluster"),
            );
            e.meta("returns", unlabelled.len());
            e.dots(unlabelled, 0.06, Color::of(RGBColor(0, 0, 0), 1.0));
            entities.push(e);
        }
        rec.scene(topics::CLUSTERS, t1, entities)?;
    }
    if let Some(associations) = picture.associations {
        if associations.len() != pair.current.len() {
            return Err(value_error(
                format!("{}: associations", pair.name),
                format!(
                    "{} associations for the {} beams of the current scan",
                    associations.len(),
                    pair.current.len()
                ),
            ));
        }
        let mut points = Vec::new();
        let (mut lines, mut outliers) = (0usize, 0usize);
        for (k, a) in associations.iter().enumerate() {
            match a {
                Some(Association::Point(j)) if pair.current.valid[k] => {
                    let Some(true) = pair.reference.valid.get(*j) else {
                        continue;
                    };
                    let from = picture
                        .alignment
                        .transform_point(&pair.current.beam_point(k));
                    let to = pair.reference.beam_point(*j);
                    points.extend([from, to].map(|p| Vector3 {
                        x: p.x,
                        y: p.y,
                        z: 0.0,
                    }));
                    lines += 1;
                }
                Some(Association::Outlier) => outliers += 1,
                _ => {}
            }
        }
        let mut e = SceneEntity::new(t1, REFERENCE_FRAME, "associations".into());
        e.meta("associated returns", lines);
        e.meta("outliers", outliers);
        e.lines.push(LinePrimitive {
            kind: 2,
            pose: Pose::identity(),
            thickness: 1.0,
            scale_invariant: true,
            points,
            color: Color::of(RGBColor(150, 200, 150), 1.0),
            colors: Vec::new(),
            indices: Vec::new(),
        });
        rec.scene(topics::ASSOCIATIONS, t1, vec![e])?;
    }
    rec.finish()
}
