//! The one error type of `pgm-datasets`: every variant names where the problem is
//! (file, line, field) and the offending value.

use std::path::PathBuf;

/// Errors of the log readers, pair builders, the on-disk pair format and the metrics.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A field of a text log has a value that cannot be used.
    #[error("{}:{line}: field `{field}` = `{value}`: {problem}", path.display())]
    Field {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Name of the field (for example `range[17]` or `ipc_timestamp`).
        field: String,
        /// The offending text as it appears in the file.
        value: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A line ends before a field it must have.
    #[error("{}:{line}: line ends before field `{field}` ({found} fields, expected {expected})", path.display())]
    MissingField {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Name of the first missing field.
        field: String,
        /// Number of whitespace-separated fields on the line.
        found: usize,
        /// Number of fields the line must have.
        expected: usize,
    },
    /// A line has more fields than its record type declares.
    #[error("{}:{line}: {found} fields, expected {expected} ({context})", path.display())]
    ExtraFields {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Number of whitespace-separated fields on the line.
        found: usize,
        /// Number of fields the record declares.
        expected: usize,
        /// Which declared count the expectation comes from.
        context: String,
    },
    /// A file read as text holds bytes that are not UTF-8 (a binary or compressed
    /// file given as a log).
    #[error("{}:{line}: byte {offset} (0x{byte:02x}) is not UTF-8 text: not a text file (a binary or compressed file?)", path.display())]
    NotText {
        /// The file.
        path: PathBuf,
        /// 1-based line of the first byte that is not UTF-8.
        line: usize,
        /// Its offset in the file, from 0.
        offset: usize,
        /// Its value.
        byte: u8,
    },
    /// A JSON file does not parse as the expected structure.
    #[error("{}: {source}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The serde error (with line and column).
        source: serde_json::Error,
    },
    /// A stored scan pair (or other structured input) violates an invariant.
    #[error("{}: `{field}`: {problem}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Path of the offending field (for example `truth.labels` or `current`).
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A scan of a log cannot be used for what it was asked for (no such scan, or no
    /// valid return to work with).
    #[error("{}{}: scan {scan}: {problem}", path.display(), at_line(*line))]
    Scan {
        /// The log.
        path: PathBuf,
        /// 1-based line of the scan (0 when the scan does not exist: the message then
        /// names the file alone).
        line: usize,
        /// The scan's index as the caller gave it (laser line counted from 0 in a
        /// CARMEN log, the `idx` field in a leigh-gtm1 log).
        scan: usize,
        /// What is wrong.
        problem: String,
    },
    /// A bag (ROS 1, MCAP) that cannot be read as asked: the file, then where in it
    /// (topic, message number and record time, field) and what is wrong.
    #[error("{}{location}: {problem}", path.display())]
    Bag {
        /// The bag file.
        path: PathBuf,
        /// Where in the bag.
        location: crate::bag::BagLocation,
        /// What is wrong.
        problem: String,
    },
    /// Two inputs that must agree do not (for example odometry and scans, or the
    /// arguments of a metric).
    #[error("{what}")]
    Mismatch {
        /// Description naming both inputs and the disagreeing values.
        what: String,
    },
    /// A pair (or a set of pairs) that an evaluation cannot score.
    #[error("pair `{pair}`: cannot be scored: {what}")]
    Unscorable {
        /// The pair's name.
        pair: String,
        /// Why.
        what: String,
    },
    /// An evaluation with nothing to score: no pair, or no pair with the ground truth
    /// it needs (never a figure computed from nothing).
    #[error("nothing to score: {what}")]
    NothingToScore {
        /// Why.
        what: String,
    },
    /// A method failed on a pair during an evaluation.
    #[error("{method} on pair `{pair}`: {}", without_pair(source, pair))]
    Method {
        /// The pair's name.
        pair: String,
        /// The method's name.
        method: String,
        /// The method's error.
        source: Box<pgm_scan::Error>,
    },
}

/// Result type of `pgm-datasets`.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An [`Error::Io`] for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// The method error's message without a leading ``pair `NAME`: `` (the variant
/// names the pair already).
fn without_pair(source: &pgm_scan::Error, pair: &str) -> String {
    let message = source.to_string();
    message
        .strip_prefix(&format!("pair `{pair}`: "))
        .map_or_else(|| message.clone(), str::to_string)
}

/// `:LINE` for a 1-based line, nothing for 0 (no line: a scan that does not exist).
fn at_line(line: usize) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(":{line}")
    }
}

/// Plausibility limits of the log readers: a value that parses as a finite number but
/// lies beyond these means nothing for a 2D laser log (a typo, a unit mistake, a
/// corrupted file) and would only turn into `inf` or NaN further on, so the readers
/// refuse it with an [`Error::Field`] naming file, line and field.
pub mod limits {
    /// Largest magnitude of a position coordinate (m): poses, laser offsets, person
    /// centres and relation translations. 1e8 m is far beyond any map on Earth (UTM
    /// northings stay below 1e7 m) while keeping about 1e-8 m of resolution.
    pub const MAX_POSITION: f64 = 1e8;
    /// Largest range or maximum range of a laser (m). No 2D laser measures 100 km.
    pub const MAX_RANGE: f64 = 1e5;
    /// Largest magnitude of a heading (rad). Unwrapped odometry headings are accepted
    /// up to a million radians (sines and cosines keep about 1e-10 rad there).
    pub const MAX_HEADING: f64 = 1e6;
    /// Largest magnitude of a time stamp (s). Time stamps are seconds (1e11 s is the
    /// year 5138): a log in nanoseconds is refused rather than read as centuries.
    pub const MAX_TIMESTAMP: f64 = 1e11;
    /// Largest span of a scan's beam angles (rad), a full turn (with a margin for
    /// rounding in the log): more would put two beams on one ray.
    pub const MAX_SPAN: f64 = std::f64::consts::TAU + 1e-6;
}
