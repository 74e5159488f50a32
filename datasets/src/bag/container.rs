//! The bag containers: ROS 1 bags (format 2.0, read with the `rosbag` crate), MCAP
//! files (ROS 2 bags, read with the `mcap` crate), a ROS 2 bag directory (its `.mcap`
//! files in name order) and a `.zip` archive holding one bag.
//!
//! Each reader hands every message of a wanted topic, with its connection (topic,
//! type, definition text, serialisation) and its record time, to a callback, in file
//! order, and lists every topic of the file with its type and message count (for the
//! error that names the topics a bag does have).
//!
//! Malformed files are errors, never panics: the ROS 1 file header and every chunk
//! header are checked before the `rosbag` crate sees them (the index position must lie
//! inside the file, an uncompressed chunk must be as long as it says, a compressed
//! chunk may declare at most [`MAX_CHUNK_BYTES`] and, for LZ4, no more than the format
//! can expand its bytes to), and MCAP records are bounded by the file's length.
//!
//! Damaged files are errors too, wherever the format stores a check: every MCAP CRC
//! that is not 0 (a chunk's `uncompressed_crc` over its decompressed records, the
//! data section's and the summary section's CRCs, an attachment's `crc`; see
//! [`read_mcap`]) and the CRC of a zip entry. A mismatch names the record's byte
//! offset and both values. (ROS 1 bags store no checksum of their data.)

use super::msgdef::Dialect;
use std::collections::BTreeMap;
use std::fs;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Which container a bag is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BagFormat {
    /// A ROS 1 bag (format 2.0).
    Ros1,
    /// An MCAP file (ROS 2 bags; also ROS 1 messages in MCAP).
    Mcap,
}

/// One topic's connection: what its messages are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Connection {
    /// The topic.
    pub topic: String,
    /// The message type (`sensor_msgs/LaserScan`, `sensor_msgs/msg/LaserScan`).
    pub type_name: String,
    /// The message definition text the bag carries.
    pub definition: String,
    /// How messages are serialised.
    pub dialect: Dialect,
}

/// One message as stored.
pub struct RawMessage<'a> {
    /// Its connection.
    pub connection: &'a Connection,
    /// Record (log) time in nanoseconds.
    pub time: u64,
    /// 1-based position of the message among the messages of its topic, in file order.
    pub number: usize,
    /// The serialised message.
    pub data: &'a [u8],
}

/// A topic of a bag with its type and message count.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct TopicInfo {
    /// The topic.
    pub topic: String,
    /// Its message type.
    pub type_name: String,
    /// How many messages it has.
    pub messages: usize,
}

/// Why a read stopped: the callback's error, or a problem of the container itself
/// (not of a message's content).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ReadError<E> {
    /// The callback's error, as it returned it.
    Message(E),
    /// The container is malformed or cannot be read.
    Container(String),
    /// The container is malformed at a place the reader can name: the topic and the
    /// message (from 1) that a damaged record is or follows.
    Located {
        /// The topic.
        topic: String,
        /// The message's number on the topic, from 1.
        message: usize,
        /// Its record time (ns), when known.
        time_ns: Option<u64>,
        /// What is wrong, and where in the file.
        problem: String,
    },
}

fn container<E>(s: impl Into<String>) -> ReadError<E> {
    ReadError::Container(s.into())
}

fn prefixed<E>(prefix: &str, e: ReadError<E>) -> ReadError<E> {
    match e {
        ReadError::Container(c) => ReadError::Container(format!("{prefix}: {c}")),
        ReadError::Located {
            topic,
            message,
            time_ns,
            problem,
        } => ReadError::Located {
            topic,
            message,
            time_ns,
            problem: format!("{prefix}: {problem}"),
        },
        other => other,
    }
}

/// Largest uncompressed size a compressed ROS 1 chunk may declare (1 GiB; `rosbag`
/// writes chunks of 768 KiB by default).
pub const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// Largest file read (16 GiB).
pub const MAX_FILE_BYTES: u64 = 1 << 34;

type Callback<'c, E> = dyn FnMut(RawMessage<'_>) -> Result<(), E> + 'c;

/// What a container read produced besides the messages handed to the callback.
#[derive(Clone, Debug, Default)]
pub struct ContainerSummary {
    /// Every topic with its type and message count (sorted by topic).
    pub topics: Vec<TopicInfo>,
    /// The format.
    pub format: Option<BagFormat>,
}

impl ContainerSummary {
    /// The summary of a `format` file from its message counts by topic (type name
    /// and count).
    fn from_counts(counts: BTreeMap<String, (String, usize)>, format: BagFormat) -> Self {
        Self {
            topics: counts
                .into_iter()
                .map(|(topic, (type_name, messages))| TopicInfo {
                    topic,
                    type_name,
                    messages,
                })
                .collect(),
            format: Some(format),
        }
    }
}

/// Reads the bag at `path` (a ROS 1 bag, an MCAP file, a ROS 2 bag directory or a
/// `.zip` holding one of the files), calling `callback` for each message of the
/// topics in `wanted`. A callback error stops the read and is returned as it is
/// ([`ReadError::Message`]).
pub fn read_container<E>(
    path: &Path,
    wanted: &[&str],
    callback: &mut Callback<'_, E>,
) -> Result<ContainerSummary, ReadError<E>> {
    if path.is_dir() {
        return read_directory(path, wanted, callback);
    }
    let mut file = fs::File::open(path).map_err(|e| container(format!("cannot open: {e}")))?;
    let mut magic = [0u8; 13];
    let got =
        read_prefix(&mut file, &mut magic).map_err(|e| container(format!("cannot read: {e}")))?;
    let magic = &magic[..got];
    if magic.starts_with(b"#ROSBAG V2.0\n") {
        read_ros1(path, wanted, callback)
    } else if magic.starts_with(mcap::MAGIC) {
        let bytes = read_limited(path)?;
        read_mcap(&bytes, wanted, callback)
    } else if magic.starts_with(b"PK\x03\x04") {
        read_zip(path, wanted, callback)
    } else if magic.starts_with(b"#ROSBAG V") {
        Err(container(format!(
            "ROS bag format {:?} is not supported (only 2.0, written by ROS 1 since 2010)",
            String::from_utf8_lossy(magic).trim()
        )))
    } else {
        Err(container(
            "neither a ROS 1 bag (`#ROSBAG V2.0`), an MCAP file, a ROS 2 bag directory nor a zip archive",
        ))
    }
}

fn read_prefix(file: &mut fs::File, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        let n = file.read(&mut buf[got..])?;
        if n == 0 {
            break;
        }
        got += n;
    }
    Ok(got)
}

fn read_limited<E>(path: &Path) -> Result<Vec<u8>, ReadError<E>> {
    let len = fs::metadata(path)
        .map_err(|e| container(format!("cannot read: {e}")))?
        .len();
    if len > MAX_FILE_BYTES {
        return Err(container(format!(
            "{len} bytes: larger than the {MAX_FILE_BYTES} bytes read at most"
        )));
    }
    fs::read(path).map_err(|e| container(format!("cannot read: {e}")))
}

fn read_directory<E>(
    dir: &Path,
    wanted: &[&str],
    callback: &mut Callback<'_, E>,
) -> Result<ContainerSummary, ReadError<E>> {
    let mut files: Vec<PathBuf> = fs::read_dir(dir)
        .map_err(|e| container(format!("cannot list the directory: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    files.sort();
    if files.is_empty() {
        let has_db3 = fs::read_dir(dir)
            .map(|it| {
                it.filter_map(|e| e.ok())
                    .any(|e| e.path().extension().is_some_and(|x| x == "db3"))
            })
            .unwrap_or(false);
        return Err(container(if has_db3 {
            "a ROS 2 bag stored as SQLite (.db3); only MCAP storage is read \
             (`ros2 bag convert` writes MCAP)"
        } else {
            "a directory without .mcap files (expected a ROS 2 bag directory)"
        }));
    }
    // Message numbers continue across the split files of one bag.
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
    for file in &files {
        let bytes = read_limited(file).map_err(|e| prefixed(&file.display().to_string(), e))?;
        let mut renumber = |m: RawMessage<'_>| {
            let n = counts.entry(m.connection.topic.clone()).or_insert(0);
            *n += 1;
            callback(RawMessage { number: *n, ..m })
        };
        let summary = read_mcap(&bytes, wanted, &mut renumber)
            .map_err(|e| prefixed(&file.display().to_string(), e))?;
        for t in summary.topics {
            topics
                .entry(t.topic.clone())
                .and_modify(|x| x.messages += t.messages)
                .or_insert(t);
        }
    }
    Ok(ContainerSummary {
        topics: topics.into_values().collect(),
        format: Some(BagFormat::Mcap),
    })
}

/// A temporary file removed when dropped.
/// A temporary file, removed when dropped, and by a signal handler before then
/// ([`pgm_core::fsutil::remove_unfinished`]).
struct TempFile(PathBuf, #[allow(dead_code)] pgm_core::fsutil::Ticket);

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.0);
    }
}

fn read_zip<E>(
    path: &Path,
    wanted: &[&str],
    callback: &mut Callback<'_, E>,
) -> Result<ContainerSummary, ReadError<E>> {
    let zerr = |e: zip::result::ZipError| container::<E>(format!("zip archive: {e}"));
    let file = fs::File::open(path).map_err(|e| container(format!("cannot open: {e}")))?;
    let mut archive = zip::ZipArchive::new(file).map_err(zerr)?;
    let mut found: Vec<(usize, String)> = Vec::new();
    for k in 0..archive.len() {
        let entry = archive.by_index_raw(k).map_err(zerr)?;
        let name = entry.name().to_string();
        if entry.is_file() && (name.ends_with(".bag") || name.ends_with(".mcap")) {
            found.push((k, name));
        }
    }
    let [(index, name)] = found.as_slice() else {
        return Err(container(format!(
            "zip archive with {} .bag / .mcap files; expected exactly one",
            found.len()
        )));
    };
    let mut entry = archive.by_index(*index).map_err(zerr)?;
    let declared = entry.size();
    if declared > MAX_FILE_BYTES {
        return Err(container(format!(
            "zip entry {name}: {declared} bytes, more than the {MAX_FILE_BYTES} read at most"
        )));
    }
    let stem = Path::new(name.as_str())
        .file_name()
        .map_or_else(|| "bag".into(), |s| s.to_string_lossy().into_owned());
    let temp_path = std::env::temp_dir().join(format!(
        "pgm-{}-{}-{stem}",
        std::process::id(),
        unique_counter()
    ));
    let (ticket, mut out) =
        pgm_core::fsutil::create_unfinished(&temp_path, false, || fs::File::create(&temp_path))
            .map_err(|e| {
                container(format!(
                    "cannot write the temporary file {}: {e}",
                    temp_path.display()
                ))
            })?;
    let temp = TempFile(temp_path, ticket);
    {
        // Never more than the entry declares.
        let mut limited = (&mut entry).take(declared);
        std::io::copy(&mut limited, &mut out)
            .map_err(|e| container(format!("zip entry {name}: cannot extract: {e}")))?;
        // The zip reader checks the entry's CRC when it reaches the end of the entry,
        // which a read of exactly the declared size never asks for: ask.
        let mut probe = [0u8; 1];
        match entry.read(&mut probe) {
            Ok(0) => {}
            Ok(_) => {
                return Err(container(format!(
                    "zip entry {name}: longer than the {declared} bytes it declares"
                )))
            }
            Err(e) => {
                return Err(container(format!(
                    "zip entry {name}: cannot extract: {e} (the entry is damaged)"
                )))
            }
        }
    }
    read_container(&temp.0, wanted, callback).map_err(|e| prefixed(&format!("zip entry {name}"), e))
}

fn unique_counter() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

// ---------------------------------------------------------------------------------
// ROS 1

fn le_u32(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// The `name=value` fields of a ROS 1 record header.
fn header_fields(mut h: &[u8]) -> Option<BTreeMap<&[u8], &[u8]>> {
    let mut out = BTreeMap::new();
    while !h.is_empty() {
        let n = le_u32(h, 0)? as usize;
        let field = h.get(4..4usize.checked_add(n)?)?;
        let eq = field.iter().position(|&b| b == b'=')?;
        out.insert(&field[..eq], &field[eq + 1..]);
        h = &h[4 + n..];
    }
    Some(out)
}

fn read_exact_at<R: Read + Seek>(r: &mut R, at: u64, n: usize) -> Result<Vec<u8>, String> {
    r.seek(SeekFrom::Start(at))
        .map_err(|e| format!("cannot seek to byte {at}: {e}"))?;
    let mut buf = vec![0u8; n];
    r.read_exact(&mut buf)
        .map_err(|e| format!("cannot read {n} bytes at byte {at}: {e}"))?;
    Ok(buf)
}

/// Record headers are small (a chunk's has four fields); a longer one is refused.
const MAX_RECORD_HEADER: u64 = 1 << 20;

/// One record of a ROS 1 bag's chunk section, where [`check_ros1_layout`] found it.
#[derive(Clone, Copy, Debug)]
struct SectionRecord {
    /// Byte of the record in the file.
    at: u64,
    /// Byte of its data (after the data length).
    data_at: u64,
    /// Its data length.
    data_len: u64,
    /// Whether it is a chunk stored uncompressed (its records can be walked in the
    /// file).
    plain_chunk: bool,
}

/// Checks what the `rosbag` crate trusts: the index position and every chunk's sizes.
/// Only record headers are read (`len` is the file's length). Returns the records of
/// the chunk section in file order, for naming where a later error lies.
fn check_ros1_layout<R: Read + Seek>(r: &mut R, len: u64) -> Result<Vec<SectionRecord>, String> {
    let u32_at = |r: &mut R, at: u64, what: &str| -> Result<u64, String> {
        if at + 4 > len {
            return Err(format!("{what} at byte {at}: the file ends"));
        }
        let b = read_exact_at(r, at, 4)?;
        Ok(u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
    };
    let header_at = |r: &mut R, at: u64, what: &str| -> Result<(Vec<u8>, u64), String> {
        let hlen = u32_at(r, at, what)?;
        if hlen > MAX_RECORD_HEADER || at + 4 + hlen > len {
            return Err(format!(
                "{what} at byte {at}: a header of {hlen} bytes runs past the end of the file"
            ));
        }
        Ok((read_exact_at(r, at + 4, hlen as usize)?, at + 4 + hlen))
    };
    let (header, data_at) = header_at(r, 13, "bag header")?;
    let fields = header_fields(&header).ok_or("bag header fields are malformed")?;
    let index_pos = match fields.get(&b"index_pos"[..]) {
        Some(v) if v.len() == 8 => {
            let mut b = [0u8; 8];
            b.copy_from_slice(v);
            u64::from_le_bytes(b)
        }
        _ => return Err("bag header without an 8-byte index_pos".into()),
    };
    let dlen = u32_at(r, data_at, "bag header")?;
    let mut pos = data_at + 4 + dlen;
    if pos > len {
        return Err("bag header padding runs past the end of the file".into());
    }
    if index_pos < pos || index_pos > len {
        return Err(format!(
            "index_pos {index_pos} lies outside the file ({pos}..={len} bytes); \
             the bag was not closed properly (`rosbag reindex` repairs it)"
        ));
    }
    let end = index_pos;
    let mut records = Vec::new();
    while pos < end {
        let at = pos;
        let (header, dpos) = header_at(r, pos, "record")?;
        let fields =
            header_fields(&header).ok_or(format!("record at byte {at}: malformed header"))?;
        let dlen = u32_at(r, dpos, "record")?;
        if dpos + 4 + dlen > end {
            return Err(format!(
                "record at byte {at}: {dlen} data bytes run past the chunk section (ends at {end})"
            ));
        }
        let is_chunk = fields.get(&b"op"[..]) == Some(&&[5u8][..]);
        records.push(SectionRecord {
            at,
            data_at: dpos + 4,
            data_len: dlen,
            plain_chunk: is_chunk && fields.get(&b"compression"[..]) == Some(&&b"none"[..]),
        });
        if is_chunk {
            let size = match fields.get(&b"size"[..]) {
                Some(v) if v.len() == 4 => u64::from(u32::from_le_bytes([v[0], v[1], v[2], v[3]])),
                _ => return Err(format!("chunk at byte {at}: no 4-byte size")),
            };
            let compression = fields.get(&b"compression"[..]).copied().unwrap_or(b"");
            let ok = match compression {
                b"none" => size == dlen,
                b"lz4" => size <= MAX_CHUNK_BYTES && size <= dlen.saturating_mul(255) + 64,
                b"bz2" => size <= MAX_CHUNK_BYTES,
                other => {
                    return Err(format!(
                        "chunk at byte {at}: compression {:?} is not none, lz4 or bz2",
                        String::from_utf8_lossy(other)
                    ))
                }
            };
            if !ok {
                return Err(format!(
                    "chunk at byte {at}: declares {size} uncompressed bytes for {dlen} stored \
                     {} bytes",
                    String::from_utf8_lossy(compression)
                ));
            }
        }
        pos = dpos + 4 + dlen;
    }
    Ok(records)
}

/// Where record `m` of the uncompressed chunk `chunk` lies in the file, and the
/// connection its header names, if the records before it and its header can be read
/// (error messages only: the `rosbag` crate does not say where it stopped).
fn locate_chunk_record(path: &Path, chunk: &SectionRecord, m: usize) -> Option<(u64, Option<u32>)> {
    if !chunk.plain_chunk {
        return None;
    }
    let mut file = fs::File::open(path).ok()?;
    let data = read_exact_at(
        &mut file,
        chunk.data_at,
        usize::try_from(chunk.data_len).ok()?,
    )
    .ok()?;
    let mut pos = 0usize;
    for _ in 0..m {
        let hlen = le_u32(&data, pos)? as usize;
        let dlen = le_u32(&data, pos.checked_add(4)?.checked_add(hlen)?)? as usize;
        pos = pos.checked_add(8)?.checked_add(hlen)?.checked_add(dlen)?;
    }
    let at = chunk.data_at + pos as u64;
    let conn = le_u32(&data, pos)
        .and_then(|hlen| data.get(pos + 4..(pos + 4).checked_add(hlen as usize)?))
        .and_then(header_fields)
        .and_then(|f| f.get(&b"conn"[..]).copied())
        .filter(|v| v.len() == 4)
        .map(|v| u32::from_le_bytes([v[0], v[1], v[2], v[3]]));
    Some((at, conn))
}

fn read_ros1<E>(
    path: &Path,
    wanted: &[&str],
    callback: &mut Callback<'_, E>,
) -> Result<ContainerSummary, ReadError<E>> {
    let cerr = |s: String| container::<E>(s);
    let layout = {
        let mut file = fs::File::open(path).map_err(|e| cerr(format!("cannot open: {e}")))?;
        let len = file
            .metadata()
            .map_err(|e| cerr(format!("cannot read: {e}")))?
            .len();
        check_ros1_layout(&mut file, len).map_err(|e| cerr(format!("ROS 1 bag: {e}")))?
    };
    let bag = rosbag::RosBag::new(path).map_err(|e| cerr(format!("ROS 1 bag: {e}")))?;
    let mut connections: BTreeMap<u32, Connection> = BTreeMap::new();
    let mut counts: BTreeMap<String, (String, usize)> = BTreeMap::new();
    for (k, record) in bag.chunk_records().enumerate() {
        let record =
            record.map_err(|e| cerr(format!("ROS 1 bag, chunk section record {k}: {e}")))?;
        let rosbag::ChunkRecord::Chunk(chunk) = record else {
            continue;
        };
        // The last message read from this chunk: (topic, number, time), for naming
        // where a damaged record lies.
        let mut last: Option<(String, usize, u64)> = None;
        for (m, item) in chunk.messages().enumerate() {
            let item = match item {
                Ok(item) => item,
                Err(e) => {
                    let e = e.to_string();
                    let e = e.strip_prefix("rosbag::Error: ").unwrap_or(&e);
                    let located = layout
                        .get(k)
                        .and_then(|c| locate_chunk_record(path, c, m).map(|l| (c.at, l)));
                    let at = match located {
                        Some((chunk_at, (record_at, _))) => format!(
                            "record {m} of the chunk at byte {chunk_at}, at byte {record_at}"
                        ),
                        None => format!("record {m} of chunk section record {k}"),
                    };
                    let own = located
                        .and_then(|(_, (_, conn))| conn)
                        .and_then(|c| connections.get(&c))
                        .map(|c| c.topic.clone());
                    return Err(match (own, &last) {
                        // The record's own header names its topic: the next message.
                        (Some(topic), _) => {
                            let message = counts.get(&topic).map_or(0, |(_, n)| *n) + 1;
                            ReadError::Located {
                                topic,
                                message,
                                time_ns: None,
                                problem: format!(
                                    "ROS 1 bag: this message's record ({at}) cannot be read: {e}"
                                ),
                            }
                        }
                        (None, Some((topic, number, time))) => ReadError::Located {
                            topic: topic.clone(),
                            message: *number,
                            time_ns: Some(*time),
                            problem: format!(
                                "ROS 1 bag: the record after this message ({at}; its header names \
                                 no known connection) cannot be read: {e}"
                            ),
                        },
                        (None, None) => cerr(format!("ROS 1 bag, {at}: {e}")),
                    });
                }
            };
            match item {
                rosbag::MessageRecord::Connection(c) => {
                    connections.entry(c.id).or_insert_with(|| Connection {
                        topic: c.topic.to_string(),
                        type_name: c.tp.to_string(),
                        definition: c.message_definition.to_string(),
                        dialect: Dialect::Ros1,
                    });
                    counts
                        .entry(c.topic.to_string())
                        .or_insert_with(|| (c.tp.to_string(), 0));
                }
                rosbag::MessageRecord::MessageData(d) => {
                    let Some(connection) = connections.get(&d.conn_id) else {
                        return Err(cerr(format!(
                            "ROS 1 bag, chunk section record {k}: a message on connection {} \
                             before that connection's record",
                            d.conn_id
                        )));
                    };
                    let entry = counts
                        .entry(connection.topic.clone())
                        .or_insert_with(|| (connection.type_name.clone(), 0));
                    entry.1 += 1;
                    last = Some((connection.topic.clone(), entry.1, d.time));
                    if wanted.contains(&connection.topic.as_str()) {
                        callback(RawMessage {
                            connection,
                            time: d.time,
                            number: entry.1,
                            data: d.data,
                        })
                        .map_err(ReadError::Message)?;
                    }
                }
            }
        }
    }
    Ok(ContainerSummary::from_counts(counts, BagFormat::Ros1))
}

// ---------------------------------------------------------------------------------
// MCAP

/// A little-endian reader over one MCAP record's body, every length checked against
/// the bytes left.
struct Body<'a> {
    data: &'a [u8],
    pos: usize,
    what: &'static str,
}

impl<'a> Body<'a> {
    /// The body `data` of a `what` record, read from its start.
    fn new(data: &'a [u8], what: &'static str) -> Self {
        Body { data, pos: 0, what }
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], String> {
        let left = self.data.len() - self.pos;
        if n > left {
            return Err(format!(
                "{} record: field {field} needs {n} bytes, {left} left in the record",
                self.what
            ));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u16(&mut self, field: &str) -> Result<u16, String> {
        let b = self.take(2, field)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }
    fn u32(&mut self, field: &str) -> Result<u32, String> {
        let b = self.take(4, field)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self, field: &str) -> Result<u64, String> {
        let b = self.take(8, field)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }
    fn bytes(&mut self, field: &str) -> Result<&'a [u8], String> {
        let n = self.u32(field)? as usize;
        self.take(n, field)
    }
    fn string(&mut self, field: &str) -> Result<String, String> {
        let b = self.bytes(field)?;
        String::from_utf8(b.to_vec())
            .map_err(|_| format!("{} record: field {field} is not UTF-8", self.what))
    }
    fn rest(&mut self) -> &'a [u8] {
        let s = &self.data[self.pos..];
        self.pos = self.data.len();
        s
    }
}

/// A schema record: name, encoding, definition.
struct SchemaRecord {
    name: String,
    encoding: String,
    data: String,
}

/// Where an MCAP record lies, for naming it in an error.
#[derive(Clone, Copy, Debug)]
enum Place {
    /// A record of the file itself, at this byte.
    File(usize),
    /// A record inside the chunk record at this byte.
    Chunk(usize),
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Place::File(at) => write!(f, "at byte {at}"),
            Place::Chunk(at) => write!(f, "in the chunk at byte {at}"),
        }
    }
}

/// What the records of an MCAP file read so far define, and the messages counted.
#[derive(Default)]
struct McapState {
    counts: BTreeMap<String, (String, usize)>,
    schemas: BTreeMap<u16, SchemaRecord>,
    connections: BTreeMap<u16, Option<Connection>>,
    /// Channels whose messages are not read (no ROS schema): their topics, for counting.
    unread_topics: BTreeMap<u16, String>,
    /// Records handled so far (those inside chunks included, chunk records not).
    record_number: usize,
}

impl McapState {
    /// Handles one record (not a chunk record): schemas, channels and messages are
    /// parsed, attachments have their CRC checked, other records are skipped.
    fn record<E>(
        &mut self,
        opcode: u8,
        data: &[u8],
        place: Place,
        wanted: &[&str],
        callback: &mut Callback<'_, E>,
    ) -> Result<(), ReadError<E>> {
        use mcap::records::op;
        self.record_number += 1;
        let number = self.record_number;
        let at = |e: String| container::<E>(format!("MCAP, record {number} ({place}): {e}"));
        match opcode {
            op::SCHEMA => {
                let mut b = Body::new(data, "schema");
                let id = b.u16("id").map_err(at)?;
                let name = b.string("name").map_err(at)?;
                let encoding = b.string("encoding").map_err(at)?;
                let data = String::from_utf8_lossy(b.bytes("data").map_err(at)?).into_owned();
                self.schemas.entry(id).or_insert(SchemaRecord {
                    name,
                    encoding,
                    data,
                });
            }
            op::CHANNEL => {
                let mut b = Body::new(data, "channel");
                let id = b.u16("id").map_err(at)?;
                let schema_id = b.u16("schema_id").map_err(at)?;
                let topic = b.string("topic").map_err(at)?;
                let message_encoding = b.string("message_encoding").map_err(at)?;
                if self.connections.contains_key(&id) {
                    return Ok(());
                }
                let schema = self.schemas.get(&schema_id);
                if schema_id != 0 && schema.is_none() {
                    return Err(at(format!(
                        "channel {id} (topic {topic}) names schema {schema_id}, which no earlier \
                         record defines"
                    )));
                }
                let dialect =
                    schema.and_then(|s| match (s.encoding.as_str(), message_encoding.as_str()) {
                        ("ros2msg", "cdr") => Some(Dialect::Ros2),
                        ("ros1msg", "ros1") => Some(Dialect::Ros1),
                        _ => None,
                    });
                let type_name = schema.map_or(String::new(), |s| s.name.clone());
                self.counts
                    .entry(topic.clone())
                    .or_insert_with(|| (type_name.clone(), 0));
                match dialect {
                    Some(dialect) => {
                        let definition = schema.map_or(String::new(), |s| s.data.clone());
                        self.connections.insert(
                            id,
                            Some(Connection {
                                topic,
                                type_name,
                                definition,
                                dialect,
                            }),
                        );
                    }
                    None if wanted.contains(&topic.as_str()) => {
                        let what = schema.map_or("no schema".to_string(), |s| {
                            format!("schema encoding {:?}", s.encoding)
                        });
                        return Err(container(format!(
                            "topic {topic}: message encoding {message_encoding:?} with {what}; \
                             only ROS 2 CDR with ros2msg schemas and ROS 1 messages with \
                             ros1msg schemas are read"
                        )));
                    }
                    None => {
                        self.unread_topics.insert(id, topic);
                        self.connections.insert(id, None);
                    }
                }
            }
            op::MESSAGE => {
                let mut b = Body::new(data, "message");
                let channel = b.u16("channel_id").map_err(at)?;
                b.u32("sequence").map_err(at)?;
                let log_time = b.u64("log_time").map_err(at)?;
                b.u64("publish_time").map_err(at)?;
                let payload = b.rest();
                let Some(known) = self.connections.get(&channel) else {
                    return Err(at(format!(
                        "a message on channel {channel} before that channel's record"
                    )));
                };
                let Some(connection) = known else {
                    if let Some(entry) = self
                        .unread_topics
                        .get(&channel)
                        .and_then(|t| self.counts.get_mut(t))
                    {
                        entry.1 += 1;
                    }
                    return Ok(());
                };
                let entry = self
                    .counts
                    .entry(connection.topic.clone())
                    .or_insert_with(|| (connection.type_name.clone(), 0));
                entry.1 += 1;
                if wanted.contains(&connection.topic.as_str()) {
                    callback(RawMessage {
                        connection,
                        time: log_time,
                        number: entry.1,
                        data: payload,
                    })
                    .map_err(ReadError::Message)?;
                }
            }
            op::ATTACHMENT => check_attachment(data).map_err(at)?,
            _ => {}
        }
        Ok(())
    }
}

/// Checks an attachment record's `crc` (of every field before it; 0: not written).
fn check_attachment(data: &[u8]) -> Result<(), String> {
    let mut b = Body::new(data, "attachment");
    b.u64("log_time")?;
    b.u64("create_time")?;
    let name = b.string("name")?;
    b.string("media_type")?;
    let len = b.u64("data")?;
    let len = usize::try_from(len).map_err(|_| {
        format!("attachment record: field data declares {len} bytes, more than the record holds")
    })?;
    b.take(len, "data")?;
    let covered = b.pos;
    let saved = b.u32("crc")?;
    let calculated = crc32fast::hash(&data[..covered]);
    if saved != 0 && saved != calculated {
        return Err(format!(
            "attachment {name:?}: crc {saved:#010x} in the record, {calculated:#010x} computed \
             over its {covered} bytes before it; the file is damaged"
        ));
    }
    Ok(())
}

/// A record time in nanoseconds as seconds (for messages).
fn seconds(ns: u64) -> String {
    format!("{:.6} s", ns as f64 * 1e-9)
}

/// What a reader error of the file (outside chunks) means, at the record at byte `at`.
fn mcap_file_error(e: mcap::McapError, at: usize, record_number: usize) -> String {
    match e {
        mcap::McapError::BadDataCrc { saved, calculated } => format!(
            "MCAP: the data section does not match its CRC: the data end record at byte {at} \
             says data_section_crc {saved:#010x}, bytes 0..{at} give {calculated:#010x}; the \
             file is damaged"
        ),
        mcap::McapError::BadSummaryCrc { saved, calculated } => format!(
            "MCAP: the summary section does not match its CRC: the footer at byte {at} says \
             summary_crc {saved:#010x}, the summary section gives {calculated:#010x}; the file \
             is damaged"
        ),
        other => format!("MCAP, the record at byte {at} (after record {record_number}): {other}"),
    }
}

/// Reads the chunk record `record` (opcode, length and body) found at byte `at`: its
/// records are handed to `state` as they are decompressed, and its `uncompressed_crc`
/// (when not 0) is checked over all of them: for records stored uncompressed before
/// any is read, for compressed ones as they are decompressed. A CRC mismatch or a
/// chunk that cannot be read to its end is the chunk's error even when one of its
/// records failed first (that failure is then a consequence of the damage); nothing
/// of the chunk is handed on after a failure.
fn read_chunk<E>(
    record: &[u8],
    at: usize,
    limit: usize,
    state: &mut McapState,
    wanted: &[&str],
    callback: &mut Callback<'_, E>,
) -> Result<(), ReadError<E>> {
    use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
    let here = |e: String| container::<E>(format!("MCAP, the chunk at byte {at}: {e}"));
    let mut header = Body::new(record.get(9..).unwrap_or_default(), "chunk");
    let start = header.u64("message_start_time").map_err(here)?;
    let end = header.u64("message_end_time").map_err(here)?;
    let size = header.u64("uncompressed_size").map_err(here)?;
    let crc = header.u32("uncompressed_crc").map_err(here)?;
    let compression = header.string("compression").map_err(here)?;
    let mismatch = |saved: u32, calculated: u32, bytes: u64| {
        let stored = if compression.is_empty() {
            "uncompressed".to_string()
        } else {
            format!("{compression}-compressed")
        };
        here(format!(
            "its records do not match its CRC: uncompressed_crc {saved:#010x} in the chunk \
             header, {calculated:#010x} computed over its {bytes} bytes of records (stored \
             {stored}; messages recorded {} to {}); the file is damaged",
            seconds(start),
            seconds(end)
        ))
    };
    // Records stored as they are are checked before any is read, so a damaged length
    // inside the chunk is named as the damage it is.
    if compression.is_empty() && crc != 0 {
        let n = header.u64("records").map_err(here)?;
        let records = usize::try_from(n)
            .ok()
            .and_then(|n| header.take(n, "records").ok())
            .ok_or_else(|| {
                here(format!(
                    "field records declares {n} bytes, {} left in the record",
                    header.data.len() - header.pos
                ))
            })?;
        let calculated = crc32fast::hash(records);
        if calculated != crc {
            return Err(mismatch(crc, calculated, records.len() as u64));
        }
    }
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_validate_chunk_crcs(true)
            .with_record_length_limit(limit),
    );
    let mut fed = 0usize;
    let mut failed: Option<ReadError<E>> = None;
    while let Some(event) = reader.next_event() {
        match event {
            Err(mcap::McapError::BadChunkCrc { saved, calculated }) => {
                return Err(mismatch(saved, calculated, size));
            }
            // The chunk's own damage is the cause of anything its records did before.
            Err(e) => return Err(here(e.to_string())),
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = need.min(record.len() - fed);
                let buffer = reader.insert(n);
                buffer[..n].copy_from_slice(&record[fed..fed + n]);
                reader.notify_read(n);
                fed += n;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                if failed.is_none() {
                    if let Err(e) = state.record(opcode, data, Place::Chunk(at), wanted, callback) {
                        failed = Some(e);
                    }
                }
            }
        }
    }
    failed.map_or(Ok(()), Err)
}

/// Reads an MCAP file held in memory (the fuzz target's entry point too).
///
/// The records are read with the `mcap` crate's sans-io reader (record framing, chunk
/// decompression, every record at most as long as the file), and the three records
/// the bag reader needs (schema, channel, message) are parsed here with every length
/// checked against the record; other records are skipped. (The crate's own record
/// parser reserves a string's declared length before reading it, up to 4 GiB.)
///
/// Every CRC the file holds is checked, as the MCAP specification intends them (a
/// CRC of 0 is one not written): each chunk's `uncompressed_crc` over its records
/// after decompression, the data end record's `data_section_crc` over the file up to
/// it, the footer's `summary_crc` over the summary section, and each attachment's
/// `crc`. A mismatch is an error naming the record's byte offset and both values.
pub fn read_mcap<E>(
    bytes: &[u8],
    wanted: &[&str],
    callback: &mut Callback<'_, E>,
) -> Result<ContainerSummary, ReadError<E>> {
    use mcap::records::op;
    use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
    // Chunks are yielded whole and read by `read_chunk`, so an error can name the
    // chunk's byte offset.
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_record_length_limit(bytes.len())
            .with_emit_chunks(true)
            .with_validate_data_section_crc(true)
            .with_validate_summary_section_crc(true),
    );
    let mut fed = 0usize;
    let mut state = McapState::default();
    // The byte of the record being read: records follow the 8-byte magic, each an
    // opcode, a u64 length and that many bytes.
    let mut at = mcap::MAGIC.len();
    while let Some(event) = reader.next_event() {
        let event = event.map_err(|e| container(mcap_file_error(e, at, state.record_number)))?;
        let (opcode, len) = match event {
            LinearReadEvent::ReadRequest(need) => {
                let n = need.min(bytes.len() - fed);
                let buffer = reader.insert(n);
                buffer[..n].copy_from_slice(&bytes[fed..fed + n]);
                reader.notify_read(n);
                fed += n;
                continue;
            }
            LinearReadEvent::Record { opcode, data } => {
                if opcode != op::CHUNK {
                    state.record(opcode, data, Place::File(at), wanted, callback)?;
                }
                (opcode, data.len())
            }
        };
        let end = at.saturating_add(9).saturating_add(len);
        if opcode == op::CHUNK {
            let record = bytes
                .get(at..end)
                .filter(|r| r.first() == Some(&op::CHUNK))
                .ok_or_else(|| {
                    container(format!(
                        "MCAP: the chunk record yielded at byte {at} is not there (a reader fault)"
                    ))
                })?;
            read_chunk(record, at, bytes.len(), &mut state, wanted, callback)?;
        }
        at = end;
    }
    Ok(ContainerSummary::from_counts(state.counts, BagFormat::Mcap))
}

/// Checks the layout of a ROS 1 bag held in memory the way [`read_container`] does
/// before handing the file to the `rosbag` crate (for the fuzz target and tests).
pub fn check_ros1_bytes(data: &[u8]) -> Result<(), String> {
    if !data.starts_with(b"#ROSBAG V2.0\n") {
        return Err("not a ROS 1 bag 2.0".into());
    }
    check_ros1_layout(&mut std::io::Cursor::new(data), data.len() as u64).map(|_| ())
}
