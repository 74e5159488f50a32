//! Small synthetic ROS bags, for tests, fuzzing seeds and examples: a ROS 1
//! serialiser and bag writer (format 2.0, one uncompressed chunk) and ROS 2 CDR in MCAP
//! files (through the `mcap` crate's writer). The content ([`drive`]) is a robot
//! driving through a rectangular room while a box crosses in front of it: laser scans
//! ray-cast from the true poses, drifting odometry, and the motion-capture pose tracks
//! of the robot and of the box.
//!
//! ```
//! use pgm_datasets::bag::synthetic::{drive, mcap_bag, ros1_bag};
//!
//! let records = drive(5);
//! assert!(ros1_bag(&records).starts_with(b"#ROSBAG V2.0"));
//! assert!(mcap_bag(&records, false, None).starts_with(mcap::MAGIC));
//! ```

use std::collections::BTreeMap;
use std::io::Cursor;

/// ROS 1 or ROS 2 CDR.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wire {
    /// ROS 1 serialisation.
    Ros1,
    /// ROS 2 CDR with its encapsulation header.
    Cdr {
        /// Big-endian (`00 00`) instead of little-endian (`00 01`).
        big_endian: bool,
    },
}

/// A serialiser for one message.
#[derive(Clone, Debug)]
pub struct Ser {
    /// The serialisation.
    pub wire: Wire,
    /// The bytes so far.
    pub bytes: Vec<u8>,
}

impl Ser {
    /// An empty message (with the CDR header for ROS 2).
    pub fn new(wire: Wire) -> Self {
        let bytes = match wire {
            Wire::Ros1 => Vec::new(),
            Wire::Cdr { big_endian: false } => vec![0, 1, 0, 0],
            Wire::Cdr { big_endian: true } => vec![0, 0, 0, 0],
        };
        Self { wire, bytes }
    }

    fn align(&mut self, n: usize) {
        if let Wire::Cdr { .. } = self.wire {
            while (self.bytes.len() - 4) % n != 0 {
                self.bytes.push(0);
            }
        }
    }

    fn raw<const N: usize>(&mut self, mut b: [u8; N]) {
        self.align(N);
        if self.wire == (Wire::Cdr { big_endian: true }) {
            b.reverse();
        }
        self.bytes.extend(b);
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) {
        self.raw(v.to_le_bytes());
    }
    /// An `int32`.
    pub fn i32(&mut self, v: i32) {
        self.raw(v.to_le_bytes());
    }
    /// A `float32`.
    pub fn f32(&mut self, v: f32) {
        self.raw(v.to_le_bytes());
    }
    /// A `float64`.
    pub fn f64(&mut self, v: f64) {
        self.raw(v.to_le_bytes());
    }
    /// A `string`.
    pub fn string(&mut self, s: &str) {
        match self.wire {
            Wire::Ros1 => {
                self.u32(s.len() as u32);
                self.bytes.extend(s.as_bytes());
            }
            Wire::Cdr { .. } => {
                self.u32(s.len() as u32 + 1);
                self.bytes.extend(s.as_bytes());
                self.bytes.push(0);
            }
        }
    }
    /// A header: ROS 1 has a sequence number and `time`; ROS 2 `builtin_interfaces/Time`.
    pub fn header(&mut self, seq: u32, stamp_ns: u64, frame: &str) {
        let (sec, nsec) = (
            (stamp_ns / 1_000_000_000) as u32,
            (stamp_ns % 1_000_000_000) as u32,
        );
        match self.wire {
            Wire::Ros1 => {
                self.u32(seq);
                self.u32(sec);
                self.u32(nsec);
            }
            Wire::Cdr { .. } => {
                self.i32(sec as i32);
                self.u32(nsec);
            }
        }
        self.string(frame);
    }
    /// A `geometry_msgs/Pose` in the plane.
    pub fn pose(&mut self, x: f64, y: f64, yaw: f64) {
        for v in [x, y, 0.0] {
            self.f64(v);
        }
        for v in [0.0, 0.0, (yaw / 2.0).sin(), (yaw / 2.0).cos()] {
            self.f64(v);
        }
    }
}

const SEPARATOR: &str =
    "================================================================================\n";

fn header_definition(ros1: bool) -> String {
    if ros1 {
        format!("{SEPARATOR}MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n")
    } else {
        format!(
            "{SEPARATOR}MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
             {SEPARATOR}MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
        )
    }
}

fn pose_definition() -> String {
    format!(
        "{SEPARATOR}MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n\
         {SEPARATOR}MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n\
         {SEPARATOR}MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"
    )
}

/// The message definition text of a type, as a bag of `ros1` or ROS 2 carries it.
pub fn definition(type_name: &str, ros1: bool) -> String {
    let header = if ros1 {
        "Header header"
    } else {
        "std_msgs/Header header"
    };
    match type_name {
        "sensor_msgs/LaserScan" => format!(
            "# Single scan from a planar laser range-finder\n{header}\n\
             float32 angle_min        # start angle [rad]\nfloat32 angle_max\nfloat32 angle_increment\n\
             float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n\
             float32[] ranges\nfloat32[] intensities\n{}",
            header_definition(ros1)
        ),
        "nav_msgs/Odometry" => format!(
            "{header}\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n\
             geometry_msgs/TwistWithCovariance twist\n{}\
             {SEPARATOR}MSG: geometry_msgs/PoseWithCovariance\nPose pose\nfloat64[36] covariance\n{}\
             {SEPARATOR}MSG: geometry_msgs/TwistWithCovariance\nTwist twist\nfloat64[36] covariance\n\
             {SEPARATOR}MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n\
             {SEPARATOR}MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n",
            header_definition(ros1),
            pose_definition()
        ),
        "geometry_msgs/PoseStamped" => format!(
            "{header}\ngeometry_msgs/Pose pose\n{}{}",
            header_definition(ros1),
            pose_definition()
        ),
        other => format!("# no definition written for {other}\n"),
    }
}

/// One synthetic message.
#[derive(Clone, Debug, PartialEq)]
pub enum Msg {
    /// A `sensor_msgs/LaserScan` of [`BEAMS`] beams from [`ANGLE_MIN`].
    Scan {
        /// Header stamp (ns).
        stamp_ns: u64,
        /// Ranges (m).
        ranges: Vec<f32>,
    },
    /// A `sensor_msgs/LaserScan` with the angles it states: `angle_min`, `angle_max`
    /// and `angle_increment` (rad), for scans whose fields disagree.
    ScanAngles {
        /// Header stamp (ns).
        stamp_ns: u64,
        /// `angle_min`, `angle_max`, `angle_increment` as written.
        angles: [f32; 3],
        /// Ranges (m).
        ranges: Vec<f32>,
    },
    /// A `nav_msgs/Odometry` (frame `odom`, child `base_link`).
    Odom {
        /// Header stamp (ns).
        stamp_ns: u64,
        /// x (m).
        x: f64,
        /// y (m).
        y: f64,
        /// Heading (rad).
        yaw: f64,
    },
    /// A `geometry_msgs/PoseStamped` (frame `map`).
    Pose {
        /// Header stamp (ns).
        stamp_ns: u64,
        /// x (m).
        x: f64,
        /// y (m).
        y: f64,
        /// Heading (rad).
        yaw: f64,
    },
}

/// A message on a topic at a record time.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// The topic.
    pub topic: &'static str,
    /// The message type (ROS 1 name).
    pub type_name: &'static str,
    /// Record time (ns).
    pub time_ns: u64,
    /// The message.
    pub msg: Msg,
}

/// First beam angle of the scans (rad).
pub const ANGLE_MIN: f32 = -1.5707964;
/// Angle between beams (rad).
pub const ANGLE_INCREMENT: f32 = 0.017453292;
/// Beams per scan.
pub const BEAMS: usize = 181;

/// A `sensor_msgs/LaserScan` stating `angles` (`angle_min`, `angle_max`,
/// `angle_increment`).
fn laser_scan(s: &mut Ser, seq: u32, stamp_ns: u64, angles: [f32; 3], ranges: &[f32]) {
    s.header(seq, stamp_ns, "laser");
    for a in angles {
        s.f32(a);
    }
    s.f32(0.0);
    s.f32(0.1);
    s.f32(0.05);
    s.f32(30.0);
    s.u32(ranges.len() as u32);
    for r in ranges {
        s.f32(*r);
    }
    s.u32(0);
}

/// Serialises one message.
pub fn serialise(msg: &Msg, seq: u32, wire: Wire) -> Vec<u8> {
    let mut s = Ser::new(wire);
    match msg {
        Msg::Scan { stamp_ns, ranges } => {
            let end = ANGLE_MIN + ANGLE_INCREMENT * (BEAMS - 1) as f32;
            laser_scan(
                &mut s,
                seq,
                *stamp_ns,
                [ANGLE_MIN, end, ANGLE_INCREMENT],
                ranges,
            );
        }
        Msg::ScanAngles {
            stamp_ns,
            angles,
            ranges,
        } => laser_scan(&mut s, seq, *stamp_ns, *angles, ranges),
        Msg::Odom {
            stamp_ns,
            x,
            y,
            yaw,
        } => {
            s.header(seq, *stamp_ns, "odom");
            s.string("base_link");
            s.pose(*x, *y, *yaw);
            for _ in 0..36 {
                s.f64(0.0);
            }
            for _ in 0..6 {
                s.f64(0.0);
            }
            for _ in 0..36 {
                s.f64(0.0);
            }
        }
        Msg::Pose {
            stamp_ns,
            x,
            y,
            yaw,
        } => {
            s.header(seq, *stamp_ns, "map");
            s.pose(*x, *y, *yaw);
        }
    }
    s.bytes
}

/// Range of a ray from `origin` at world angle `a` to the walls of the room
/// `[-6, 6] × [-4, 4]` or to a box (centre, half sizes, yaw), whichever is nearer.
/// A box: centre, half sizes, yaw.
type Box2 = ((f64, f64), (f64, f64), f64);

fn ray(origin: (f64, f64), a: f64, boxes: &[Box2]) -> f64 {
    let (dx, dy) = (a.cos(), a.sin());
    let mut best = f64::INFINITY;
    for (wall, d, o) in [
        (6.0, dx, origin.0),
        (-6.0, dx, origin.0),
        (4.0, dy, origin.1),
        (-4.0, dy, origin.1),
    ] {
        if d.abs() > 1e-12 {
            let t = (wall - o) / d;
            if t > 0.0 {
                best = best.min(t);
            }
        }
    }
    for &((cx, cy), (hx, hy), yaw) in boxes {
        // Slab test in the box frame.
        let (c, s) = (yaw.cos(), yaw.sin());
        let (ox, oy) = (origin.0 - cx, origin.1 - cy);
        let (px, py) = (c * ox + s * oy, -s * ox + c * oy);
        let (qx, qy) = (c * dx + s * dy, -s * dx + c * dy);
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        let mut hit = true;
        for (p, q, h) in [(px, qx, hx), (py, qy, hy)] {
            if q.abs() < 1e-12 {
                if p.abs() > h {
                    hit = false;
                }
            } else {
                let (a1, a2) = ((-h - p) / q, (h - p) / q);
                t0 = t0.max(a1.min(a2));
                t1 = t1.min(a1.max(a2));
            }
        }
        if hit && t0 <= t1 && t0 > 0.0 {
            best = best.min(t0);
        }
    }
    best
}

/// The robot's true pose at time `t` (s after 100 s): it drives +x at 0.5 m/s, turning
/// slowly.
pub fn robot_pose(t: f64) -> (f64, f64, f64) {
    (-2.0 + 0.5 * t, -1.0, 0.05 * t)
}
/// The box's true pose at time `t` (s after 100 s).
pub fn box_pose(t: f64) -> (f64, f64, f64) {
    (1.5, -2.5 + 1.0 * t, std::f64::consts::FRAC_PI_2)
}
/// The laser's mounting on the robot.
pub const MOUNT: (f64, f64, f64) = (0.2, 0.0, 0.0);
/// The box: 0.6 × 0.4 m, centred on its pose.
pub const BOX_HALF: (f64, f64) = (0.3, 0.2);

/// A synthetic drive: `n` scans at 10 Hz (stamps from 100 s), odometry at 50 Hz (the
/// true robot pose with a drift), both true pose tracks at 100 Hz; scans are recorded
/// 20 ms after their stamp.
pub fn drive(n: usize) -> Vec<Record> {
    let mut out = Vec::new();
    let t0 = 100_000_000_000u64;
    let span = (n as u64 + 1) * 100_000_000;
    let mut t = 0u64;
    while t <= span {
        let secs = t as f64 * 1e-9;
        let (x, y, yaw) = robot_pose(secs);
        if t % 20_000_000 == 0 {
            out.push(Record {
                topic: "/odom",
                type_name: "nav_msgs/Odometry",
                time_ns: t0 + t + 1_000_000,
                msg: Msg::Odom {
                    stamp_ns: t0 + t,
                    x: x * 1.02,
                    y,
                    yaw: yaw * 0.98,
                },
            });
        }
        out.push(Record {
            topic: "/ego_pose",
            type_name: "geometry_msgs/PoseStamped",
            time_ns: t0 + t + 500_000,
            msg: Msg::Pose {
                stamp_ns: t0 + t,
                x,
                y,
                yaw,
            },
        });
        let (bx, by, byaw) = box_pose(secs);
        out.push(Record {
            topic: "/box_pose",
            type_name: "geometry_msgs/PoseStamped",
            time_ns: t0 + t + 600_000,
            msg: Msg::Pose {
                stamp_ns: t0 + t,
                x: bx,
                y: by,
                yaw: byaw,
            },
        });
        t += 10_000_000;
    }
    for k in 0..n {
        let stamp = 50_000_000 + k as u64 * 100_000_000;
        let secs = stamp as f64 * 1e-9;
        let (x, y, yaw) = robot_pose(secs);
        let (lx, ly) = (x + MOUNT.0 * yaw.cos(), y + MOUNT.0 * yaw.sin());
        let (bx, by, byaw) = box_pose(secs);
        let boxes = [((bx, by), BOX_HALF, byaw)];
        let ranges: Vec<f32> = (0..BEAMS)
            .map(|b| {
                let a = (ANGLE_MIN + ANGLE_INCREMENT * b as f32) as f64 + yaw;
                let r = ray((lx, ly), a, &boxes);
                if b % 37 == 5 {
                    f32::INFINITY
                } else {
                    r as f32
                }
            })
            .collect();
        out.push(Record {
            topic: "/scan",
            type_name: "sensor_msgs/LaserScan",
            time_ns: t0 + stamp + 20_000_000,
            msg: Msg::Scan {
                stamp_ns: t0 + stamp,
                ranges,
            },
        });
    }
    out.sort_by_key(|r| r.time_ns);
    out
}

/// The [`drive`] with every scan stating `angles(k)` (`angle_min`, `angle_max`,
/// `angle_increment`) instead of the consistent ones, `k` counting scans from 0.
pub fn drive_with_angles(n: usize, angles: impl Fn(usize) -> [f32; 3]) -> Vec<Record> {
    let mut k = 0;
    drive(n)
        .into_iter()
        .map(|mut r| {
            if let Msg::Scan { stamp_ns, ranges } = &r.msg {
                r.msg = Msg::ScanAngles {
                    stamp_ns: *stamp_ns,
                    angles: angles(k),
                    ranges: ranges.clone(),
                };
                k += 1;
            }
            r
        })
        .collect()
}

fn ros1_field(name: &str, value: &[u8]) -> Vec<u8> {
    let mut f = Vec::new();
    f.extend(((name.len() + 1 + value.len()) as u32).to_le_bytes());
    f.extend(name.as_bytes());
    f.push(b'=');
    f.extend(value);
    f
}

fn ros1_record(header: &[Vec<u8>], data: &[u8]) -> Vec<u8> {
    let h: Vec<u8> = header.concat();
    let mut r = Vec::new();
    r.extend((h.len() as u32).to_le_bytes());
    r.extend(h);
    r.extend((data.len() as u32).to_le_bytes());
    r.extend(data);
    r
}

/// A ROS 1 bag (format 2.0, one uncompressed chunk) holding `records`.
pub fn ros1_bag(records: &[Record]) -> Vec<u8> {
    ros1_bag_compressed(records, "none", &|chunk| chunk.to_vec())
}

/// A ROS 1 bag whose one chunk is stored as `compress` makes it and declared as
/// `compression` (`none`, `bz2` or `lz4`: the caller brings the compressor).
pub fn ros1_bag_compressed(
    records: &[Record],
    compression: &str,
    compress: &dyn Fn(&[u8]) -> Vec<u8>,
) -> Vec<u8> {
    let mut conns: BTreeMap<&str, (u32, &str)> = BTreeMap::new();
    for r in records {
        let n = conns.len() as u32;
        conns.entry(r.topic).or_insert((n, r.type_name));
    }
    let conn_record = |topic: &str, id: u32, type_name: &str| {
        let data = [
            ros1_field("topic", topic.as_bytes()),
            ros1_field("type", type_name.as_bytes()),
            ros1_field("md5sum", b"0123456789abcdef0123456789abcdef"),
            ros1_field("message_definition", definition(type_name, true).as_bytes()),
        ]
        .concat();
        ros1_record(
            &[
                ros1_field("op", &[7]),
                ros1_field("conn", &id.to_le_bytes()),
                ros1_field("topic", topic.as_bytes()),
            ],
            &data,
        )
    };
    let mut chunk = Vec::new();
    for (topic, (id, type_name)) in &conns {
        chunk.extend(conn_record(topic, *id, type_name));
    }
    let mut seq: BTreeMap<&str, u32> = BTreeMap::new();
    for r in records {
        let s = seq.entry(r.topic).or_insert(0);
        *s += 1;
        let (sec, nsec) = (
            (r.time_ns / 1_000_000_000) as u32,
            (r.time_ns % 1_000_000_000) as u32,
        );
        let time = [sec.to_le_bytes(), nsec.to_le_bytes()].concat();
        chunk.extend(ros1_record(
            &[
                ros1_field("op", &[2]),
                ros1_field("conn", &conns[r.topic].0.to_le_bytes()),
                ros1_field("time", &time),
            ],
            &serialise(&r.msg, *s, Wire::Ros1),
        ));
    }
    let chunk_record = ros1_record(
        &[
            ros1_field("op", &[5]),
            ros1_field("compression", compression.as_bytes()),
            ros1_field("size", &(chunk.len() as u32).to_le_bytes()),
        ],
        &compress(&chunk),
    );
    let mut index = Vec::new();
    for (topic, (id, type_name)) in &conns {
        index.extend(conn_record(topic, *id, type_name));
    }
    let header_len = 4096usize;
    let index_pos = (13 + header_len + chunk_record.len()) as u64;
    let header_fields = [
        ros1_field("op", &[3]),
        ros1_field("index_pos", &index_pos.to_le_bytes()),
        ros1_field("conn_count", &(conns.len() as u32).to_le_bytes()),
        ros1_field("chunk_count", &1u32.to_le_bytes()),
    ]
    .concat();
    let padding = header_len - 8 - header_fields.len();
    let mut bag = b"#ROSBAG V2.0\n".to_vec();
    bag.extend((header_fields.len() as u32).to_le_bytes());
    bag.extend(&header_fields);
    bag.extend((padding as u32).to_le_bytes());
    bag.extend(vec![b' '; padding]);
    bag.extend(chunk_record);
    bag.extend(index);
    bag
}

/// Adds to the MCAP writer `w` the ROS 2 schema (`ros2msg`) of `record`'s message
/// type and a CDR channel on its topic; returns the channel's id.
pub fn add_ros2_channel<W: std::io::Write + std::io::Seek>(
    w: &mut mcap::Writer<W>,
    record: &Record,
) -> mcap::McapResult<u16> {
    let ros2_name = record.type_name.replacen('/', "/msg/", 1);
    let schema = w.add_schema(
        &ros2_name,
        "ros2msg",
        definition(record.type_name, false).as_bytes(),
    )?;
    w.add_channel(schema, record.topic, "cdr", &BTreeMap::new())
}

/// An MCAP file (ROS 2: `ros2msg` schemas, CDR messages) holding `records`.
pub fn mcap_bag(
    records: &[Record],
    big_endian: bool,
    compression: Option<mcap::Compression>,
) -> Vec<u8> {
    let mut out = Cursor::new(Vec::new());
    {
        let mut w = mcap::WriteOptions::new()
            .compression(compression)
            .profile("ros2")
            .create(&mut out)
            .expect("mcap writer");
        let mut channels: BTreeMap<&str, u16> = BTreeMap::new();
        let mut seq: BTreeMap<&str, u32> = BTreeMap::new();
        for r in records {
            if !channels.contains_key(r.topic) {
                let channel = add_ros2_channel(&mut w, r).expect("schema and channel");
                channels.insert(r.topic, channel);
            }
            let s = seq.entry(r.topic).or_insert(0);
            *s += 1;
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channels[r.topic],
                    sequence: *s,
                    log_time: r.time_ns,
                    publish_time: r.time_ns,
                },
                &serialise(&r.msg, *s, Wire::Cdr { big_endian }),
            )
            .expect("message");
        }
        w.finish().expect("finish");
    }
    out.into_inner()
}

/// Rewrites every CRC an MCAP file held in memory stores (those not 0: the chunks'
/// `uncompressed_crc` of uncompressed chunks, the data end record's
/// `data_section_crc`, the footer's `summary_crc`) to match its bytes, so a test that
/// edits a record inside a chunk reaches the check it is about rather than the CRC
/// check. Compressed chunks keep their CRC. Stops quietly at the first record that
/// does not fit the file.
pub fn reseal_mcap(bytes: &mut [u8]) {
    let u64_at = |b: &[u8], at: usize| -> Option<u64> {
        let s = b.get(at..at.checked_add(8)?)?;
        Some(u64::from_le_bytes(s.try_into().ok()?))
    };
    let mut at = mcap::MAGIC.len();
    let mut summary_start = None;
    while at + 9 <= bytes.len() {
        let opcode = bytes[at];
        let Some(len) = u64_at(bytes, at + 1).and_then(|l| usize::try_from(l).ok()) else {
            return;
        };
        let body = at + 9;
        let Some(end) = body.checked_add(len).filter(|&e| e <= bytes.len()) else {
            return;
        };
        match opcode {
            mcap::records::op::CHUNK if len >= 40 => {
                let compression_len =
                    u32::from_le_bytes(bytes[body + 28..body + 32].try_into().unwrap()) as usize;
                let records_at = body + 40 + compression_len;
                let records_len = u64_at(bytes, body + 32 + compression_len)
                    .and_then(|l| usize::try_from(l).ok());
                let crc = u32::from_le_bytes(bytes[body + 24..body + 28].try_into().unwrap());
                if let Some(records) = records_len
                    .and_then(|l| bytes.get(records_at..records_at.checked_add(l)?))
                    .filter(|_| compression_len == 0 && crc != 0)
                {
                    let crc = crc32fast::hash(records);
                    bytes[body + 24..body + 28].copy_from_slice(&crc.to_le_bytes());
                }
            }
            mcap::records::op::DATA_END if len >= 4 => {
                if bytes[body..body + 4] != [0; 4] {
                    let crc = crc32fast::hash(&bytes[..at]);
                    bytes[body..body + 4].copy_from_slice(&crc.to_le_bytes());
                }
                summary_start = Some(end);
            }
            mcap::records::op::FOOTER if len >= 20 => {
                if let Some(start) = summary_start.filter(|_| bytes[body + 16..body + 20] != [0; 4])
                {
                    let crc = crc32fast::hash(&bytes[start..body + 16]);
                    bytes[body + 16..body + 20].copy_from_slice(&crc.to_le_bytes());
                }
                return;
            }
            _ => {}
        }
        at = end;
    }
}
