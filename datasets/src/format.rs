//! The on-disk format of scan-pair data sets (specified in `datasets/FORMAT.md`).
//!
//! A data set is a **directory** holding one JSON file per pair plus an index:
//!
//! ```text
//! DIR/index.json       {"format": "pgm-scan-pairs", "version": 1,
//!                       "pairs": [{"name": "mit-csail:…", "file": "pair-00000.json"}, …]}
//! DIR/pair-00000.json  one ScanPair (serde JSON of pgm_datasets::ScanPair)
//! DIR/pair-00001.json  …
//! ```
//!
//! One file per pair keeps single pairs easy to inspect, diff and hand-edit, and
//! lets a tool read one pair without parsing the whole set; the index fixes the order
//! and is the only authority on which files belong to the set.
//!
//! [`read_pairs`] accepts any of: the directory, its `index.json` (or any index file
//! with the `"format": "pgm-scan-pairs"` header, pair files resolved relative to it),
//! or a single pair file. Every pair read is validated ([`ScanPair::validate`]:
//! scan invariants, label and association array lengths, association indices in
//! range; and [`check_limits`]: no value beyond the readers' plausibility
//! [`limits`]); errors name the file and the field.
//!
//! [`write_pairs`] never leaves a mix of two data sets, never deletes a file it did not
//! write, and writes nothing when it fails before the switch:
//!
//! - every pair is validated and serialised before anything touches the disk;
//! - a directory that does not exist (or is empty) is written as a temporary sibling
//!   directory (`.NAME.pgm-tmp-…`), flushed, and renamed into place: the directory
//!   then either does not exist or holds the whole data set;
//! - a directory that holds a data set (an index with this format's header) is
//!   replaced through its index: the new pair files are written under names the old
//!   index does not use (`pair-NNNNN.json` or `pair-gG-NNNNN.json`), each flushed and
//!   renamed into place, then the new `index.json` replaces the old one in one rename
//!   (the switch); only then are the old index's pair files removed. A reader sees the
//!   old data set or the new one at every instant, and a run killed before the switch
//!   leaves the old data set whole (plus unlisted new files, which no reader opens);
//! - any other non-empty directory is refused: its files are not ours to replace;
//! - files in the directory that no index lists are never removed, except the pair
//!   files of a replacement that was killed: it lists the files it writes and those it
//!   will remove in a journal ([`JOURNAL_FILE`]) before touching any, and the next
//!   replacement removes the listed files the index in place does not list.
//!
//! A directory cannot be swapped for another in one step (rename refuses a non-empty
//! target, and the exchanging rename of Linux needs an unsafe system call, which the
//! workspace forbids), hence the index switch for replacements.

use crate::error::{limits, Error, Result};
use crate::pair::{PairViolation, ScanPair};
use pgm_core::fsutil::{self, Ticket};
use pgm_scan::Pose2;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The `format` value of an index file.
pub const FORMAT_NAME: &str = "pgm-scan-pairs";
/// The format version this crate writes and reads.
pub const FORMAT_VERSION: u32 = 1;
/// File name of the index inside a data-set directory.
pub const INDEX_FILE: &str = "index.json";

/// The index of a data set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Index {
    /// Always [`FORMAT_NAME`].
    pub format: String,
    /// Format version ([`FORMAT_VERSION`]).
    pub version: u32,
    /// The pairs in order.
    pub pairs: Vec<IndexEntry>,
}

/// One pair of an [`Index`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexEntry {
    /// The pair's name (as in the pair file).
    pub name: String,
    /// The pair file, relative to the index's directory.
    pub file: String,
}

fn read_json_value(path: &Path) -> Result<serde_json::Value> {
    let text = crate::text::read_text(path)?;
    serde_json::from_str(&text).map_err(|source| Error::Json {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads and validates one pair file.
pub fn read_pair(path: impl AsRef<Path>) -> Result<ScanPair> {
    let path = path.as_ref();
    let value = read_json_value(path)?;
    pair_from_value(path, value)
}

/// Parses and validates the text of one pair file; `path` is only used in errors.
pub fn parse_pair(path: &Path, text: &str) -> Result<ScanPair> {
    let value = serde_json::from_str(text).map_err(|source| Error::Json {
        path: path.to_path_buf(),
        source,
    })?;
    pair_from_value(path, value)
}

/// Parses and checks the text of an index file (header, version, member paths that
/// stay inside the data-set directory); `path` is only used in errors.
pub fn parse_index(path: &Path, text: &str) -> Result<Index> {
    let value = serde_json::from_str(text).map_err(|source| Error::Json {
        path: path.to_path_buf(),
        source,
    })?;
    index_from_value(path, value)
}

fn index_from_value(index_path: &Path, value: serde_json::Value) -> Result<Index> {
    let index: Index = serde_json::from_value(value).map_err(|source| Error::Json {
        path: index_path.to_path_buf(),
        source,
    })?;
    if index.format != FORMAT_NAME {
        return Err(Error::Invalid {
            path: index_path.to_path_buf(),
            field: "format".into(),
            problem: format!("`{}`, expected `{FORMAT_NAME}`", index.format),
        });
    }
    if index.version != FORMAT_VERSION {
        return Err(Error::Invalid {
            path: index_path.to_path_buf(),
            field: "version".into(),
            problem: format!(
                "{}, this reader understands {FORMAT_VERSION}",
                index.version
            ),
        });
    }
    for (k, entry) in index.pairs.iter().enumerate() {
        let file = Path::new(&entry.file);
        let inside = !entry.file.is_empty()
            && !file.is_absolute()
            && file.components().all(|c| {
                matches!(
                    c,
                    std::path::Component::Normal(_) | std::path::Component::CurDir
                )
            });
        if !inside {
            return Err(Error::Invalid {
                path: index_path.to_path_buf(),
                field: format!("pairs[{k}].file"),
                problem: format!(
                    "`{}` must be a path inside the data-set directory",
                    entry.file
                ),
            });
        }
    }
    // One entry per pair: a repeated name or file would be read, and scored, twice.
    let mut names = std::collections::HashMap::new();
    let mut files = std::collections::HashMap::new();
    for (k, entry) in index.pairs.iter().enumerate() {
        let file = Path::new(&entry.file)
            .components()
            .filter(|c| !matches!(c, std::path::Component::CurDir))
            .collect::<std::path::PathBuf>();
        for (seen, key, field, value) in [
            (
                &mut names,
                std::path::PathBuf::from(&entry.name),
                "name",
                &entry.name,
            ),
            (&mut files, file, "file", &entry.file),
        ] {
            if let Some(first) = seen.insert(key, k) {
                return Err(Error::Invalid {
                    path: index_path.to_path_buf(),
                    field: format!("pairs[{k}].{field}"),
                    problem: format!(
                        "`{value}` is already the {field} of pairs[{first}]: each pair is \
                         listed once"
                    ),
                });
            }
        }
    }
    Ok(index)
}

fn pair_from_value(path: &Path, value: serde_json::Value) -> Result<ScanPair> {
    let pair: ScanPair = serde_json::from_value(value).map_err(|source| Error::Json {
        path: path.to_path_buf(),
        source,
    })?;
    pair.validate()
        .and_then(|()| check_limits(&pair))
        .map_err(|v| Error::Invalid {
            path: path.to_path_buf(),
            field: v.field,
            problem: v.problem,
        })?;
    Ok(pair)
}

/// The plausibility limits of the log readers ([`limits`]) on a stored pair: values
/// that are finite (so [`ScanPair::validate`] accepts them) but mean nothing, such as
/// an odometry of 1e300 m, a maximum range of 1e300 m or a beam angle of 1e300 rad.
pub fn check_limits(pair: &ScanPair) -> std::result::Result<(), PairViolation> {
    let violation = |field: String, problem: String| PairViolation { field, problem };
    let pose = |field: &str, pose: &Pose2| {
        let t = pose.translation();
        if t.x.abs() > limits::MAX_POSITION || t.y.abs() > limits::MAX_POSITION {
            return Err(violation(
                field.to_string(),
                format!(
                    "translation ({:?}, {:?}) beyond {:e} m means nothing here",
                    t.x,
                    t.y,
                    limits::MAX_POSITION
                ),
            ));
        }
        Ok(())
    };
    for (name, scan) in [("reference", &pair.reference), ("current", &pair.current)] {
        if scan.max_range > limits::MAX_RANGE {
            return Err(violation(
                format!("{name}.max_range"),
                format!("{:?} m is beyond any laser's reach", scan.max_range),
            ));
        }
        if scan.timestamp.abs() > limits::MAX_TIMESTAMP {
            return Err(violation(
                format!("{name}.timestamp"),
                format!("{:?} s is not a time stamp in seconds", scan.timestamp),
            ));
        }
        if let Some(k) = scan
            .angles
            .iter()
            .position(|a| a.abs() > 2.0 * limits::MAX_SPAN)
        {
            return Err(violation(
                format!("{name}.angles[{k}]"),
                format!("{:?} rad is beyond two full turns", scan.angles[k]),
            ));
        }
        // One scanner's sweep: strictly increasing or strictly decreasing angles (any
        // monotone order, see `Scan`), over at most a full turn. Equal neighbours put
        // two beams on one ray (an angle increment of 0).
        if let [first, second, ..] = scan.angles[..] {
            let increasing = second > first;
            // Angles are finite here (`ScanPair::validate` ran first).
            if let Some(k) = scan.angles.windows(2).position(|w| {
                if increasing {
                    w[1] <= w[0]
                } else {
                    w[1] >= w[0]
                }
            }) {
                return Err(violation(
                    format!("{name}.angles[{}]", k + 1),
                    format!(
                        "{:?} rad after {:?} rad: beam angles must be strictly {} like the \
                         first two (one scanner's sweep, in either order)",
                        scan.angles[k + 1],
                        scan.angles[k],
                        if increasing {
                            "increasing"
                        } else {
                            "decreasing"
                        }
                    ),
                ));
            }
            let span = (scan.angles[scan.angles.len() - 1] - first).abs();
            if span > limits::MAX_SPAN {
                return Err(violation(
                    format!("{name}.angles"),
                    format!(
                        "the beams span {span:?} rad, more than a full turn: two beams would \
                         lie on one ray"
                    ),
                ));
            }
        }
        if let Some(k) = scan.ranges.iter().position(|r| r.abs() > limits::MAX_RANGE) {
            return Err(violation(
                format!("{name}.ranges[{k}]"),
                format!("{:?} m is beyond any laser's reach", scan.ranges[k]),
            ));
        }
        if let Some(o) = &scan.odometry {
            pose(&format!("{name}.odometry"), o)?;
        }
        pose(&format!("{name}.laser_offset"), &scan.laser_offset)?;
    }
    if let Some(o) = &pair.odometry {
        pose("odometry", o)?;
    }
    if let Some(truth) = &pair.truth {
        if let Some(e) = &truth.ego_motion {
            pose("truth.ego_motion", e)?;
        }
        for (k, m) in truth.motions.iter().enumerate() {
            pose(&format!("truth.motions[{k}].motion"), &m.motion)?;
        }
    }
    Ok(())
}

/// A data set opened at its index (or a single pair file), pairs not yet read.
enum Opened {
    /// A single pair file, already read.
    Single(Box<ScanPair>),
    /// An index and the directory its pair files are relative to.
    Indexed { base: PathBuf, index: Index },
}

fn open_data_set(path: &Path) -> Result<Opened> {
    let index_path = if path.is_dir() {
        path.join(INDEX_FILE)
    } else {
        path.to_path_buf()
    };
    let value = read_json_value(&index_path)?;
    let is_index = value.get("format").is_some();
    if !is_index {
        return Ok(Opened::Single(Box::new(pair_from_value(
            &index_path,
            value,
        )?)));
    }
    let index = index_from_value(&index_path, value)?;
    let base = index_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    Ok(Opened::Indexed { base, index })
}

/// Reads and validates the pair file of one index entry; its name must be the
/// index's.
fn read_entry(base: &Path, entry: &IndexEntry) -> Result<ScanPair> {
    let file = base.join(&entry.file);
    let pair = read_pair(&file)?;
    if pair.name != entry.name {
        return Err(Error::Invalid {
            path: file,
            field: "name".into(),
            problem: format!("`{}`, but the index lists `{}`", pair.name, entry.name),
        });
    }
    Ok(pair)
}

/// Reads a data set: a directory, an index file or a single pair file (see the
/// module docs). Pairs come back in index order, each validated.
pub fn read_pairs(path: impl AsRef<Path>) -> Result<Vec<ScanPair>> {
    match open_data_set(path.as_ref())? {
        Opened::Single(pair) => Ok(vec![*pair]),
        Opened::Indexed { base, index } => index
            .pairs
            .iter()
            .map(|entry| read_entry(&base, entry))
            .collect(),
    }
}

/// Reads the one pair of a data set (as [`read_pairs`] takes it) that `choose` picks
/// from the pairs' names in index order, and opens no other pair file: a damaged pair
/// file elsewhere in the set does not stop a command that needs one pair, and the
/// chosen pair is validated as [`read_pairs`] validates every pair. Returns the pair
/// (`None` when `choose` picks none or an index beyond the set) and the number of
/// pairs in the set.
///
/// # Errors
/// As [`read_pairs`], for the index and the chosen pair's file only.
pub fn read_chosen_pair(
    path: impl AsRef<Path>,
    choose: impl FnOnce(&[&str]) -> Option<usize>,
) -> Result<(Option<ScanPair>, usize)> {
    match open_data_set(path.as_ref())? {
        Opened::Single(pair) => {
            let chosen = choose(&[pair.name.as_str()]) == Some(0);
            Ok((chosen.then_some(*pair), 1))
        }
        Opened::Indexed { base, index } => {
            let names: Vec<&str> = index.pairs.iter().map(|e| e.name.as_str()).collect();
            let count = names.len();
            match choose(&names).and_then(|k| index.pairs.get(k)) {
                Some(entry) => Ok((Some(read_entry(&base, entry)?), count)),
                None => Ok((None, count)),
            }
        }
    }
}

/// Writes `bytes` to `path` through a temporary file in the same directory, flushed
/// to disk and renamed into place ([`pgm_core::fsutil::write_atomically`]: a process
/// stopped by a signal `pgm` handles leaves neither the temporary file nor a changed
/// `path`).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    pgm_core::fsutil::write_atomically(path, bytes).map_err(|e| core_io(path, e))
}

/// As [`write_atomically`], `path` registered as unfinished until the ticket is
/// dropped or finished ([`pgm_core::fsutil::write_unfinished`]).
fn write_unfinished(path: &Path, bytes: &[u8]) -> Result<Ticket> {
    fsutil::write_unfinished(path, bytes).map_err(|e| core_io(path, e))
}

/// The core's write error as this crate's, naming `path` when the core names none.
fn core_io(path: &Path, e: pgm_core::Error) -> Error {
    match e {
        pgm_core::Error::Io { path, source } => Error::io(path, source),
        other => Error::io(path, std::io::Error::other(other.to_string())),
    }
}

/// A file written under a temporary name beside its destination and renamed into place
/// by [`StagedFile::commit`]; dropped uncommitted, it is removed. Lets a command that
/// writes several outputs write none of them when one fails.
#[derive(Debug)]
pub struct StagedFile {
    tmp: PathBuf,
    path: PathBuf,
    committed: bool,
    // Keeps `tmp` registered as unfinished; dropped after `Drop::drop` removed it.
    _unfinished: Ticket,
}

impl StagedFile {
    /// Writes `bytes` (flushed to disk) to a temporary sibling of `path`.
    pub fn stage(path: impl AsRef<Path>, bytes: &[u8]) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "output".into());
        let tmp = fsutil::temporary_path(&dir.join(name)).map_err(|e| core_io(&path, e))?;
        match write_flushed(&tmp, bytes) {
            Ok(ticket) => Ok(Self {
                tmp,
                path,
                committed: false,
                _unfinished: ticket,
            }),
            Err(e) => {
                let _ = std::fs::remove_file(&tmp);
                Err(match e {
                    Error::Io { source, .. } => Error::io(&path, source),
                    other => other,
                })
            }
        }
    }

    /// Renames the file into place.
    pub fn commit(mut self) -> Result<()> {
        let mut list = fsutil::lock();
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))?;
        list.finish([&self._unfinished]);
        self.committed = true;
        Ok(())
    }
}

impl Drop for StagedFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// File name of pair number `k` in a data-set directory written fresh.
pub fn pair_file_name(k: usize) -> String {
    format!("pair-{k:05}.json")
}

/// File name of pair number `k` in generation `g` (0 is [`pair_file_name`]): a data set
/// that replaces another uses a generation whose names do not exist yet.
pub fn generation_file_name(g: usize, k: usize) -> String {
    if g == 0 {
        pair_file_name(k)
    } else {
        format!("pair-g{g}-{k:05}.json")
    }
}

/// What a `--out` directory holds before a write.
enum Target {
    /// Nothing (missing or empty).
    Fresh,
    /// A data set with this index.
    DataSet(Index),
}

/// Classifies `dir`; a non-empty directory without a data set is an error.
fn classify(dir: &Path) -> Result<Target> {
    let meta = match std::fs::metadata(dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Target::Fresh),
        Err(e) => return Err(Error::io(dir, e)),
    };
    if !meta.is_dir() {
        return Err(Error::Invalid {
            path: dir.to_path_buf(),
            field: "output".into(),
            problem: "exists and is not a directory; a data set is a directory".into(),
        });
    }
    let mut entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let Some(first) = entries.next() else {
        return Ok(Target::Fresh);
    };
    let first = first
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .unwrap_or_default();
    let index_path = dir.join(INDEX_FILE);
    let index = std::fs::read_to_string(&index_path)
        .ok()
        .and_then(|text| serde_json::from_str::<Index>(&text).ok())
        .filter(|index| index.format == FORMAT_NAME);
    match index {
        Some(index) => Ok(Target::DataSet(index)),
        None => Err(Error::Invalid {
            path: dir.to_path_buf(),
            field: "output".into(),
            problem: format!(
                "the directory is not empty and holds no pgm data set (no readable {INDEX_FILE} \
                 with format `{FORMAT_NAME}`; it holds `{first}`, …); refusing to write into it: \
                 choose a new or empty directory"
            ),
        }),
    }
}

/// Writes `bytes` to `path` (a new file), flushed to disk.
/// Writes `bytes` to the new file `path`, flushed to disk, registered as unfinished
/// under the returned ticket (the caller removes the file on failure).
fn write_flushed(path: &Path, bytes: &[u8]) -> Result<Ticket> {
    let (ticket, ()) = fsutil::create_unfinished(path, false, || {
        let mut f = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
        f.write_all(bytes).map_err(|e| Error::io(path, e))?;
        f.sync_all().map_err(|e| Error::io(path, e))
    })?;
    Ok(ticket)
}

/// Flushes a directory's entries (renames) to disk; a no-op where directories cannot
/// be opened as files.
fn sync_dir(dir: &Path) {
    if let Ok(f) = std::fs::File::open(dir) {
        let _ = f.sync_all();
    }
}

/// Writes a data set into directory `dir` (see the module docs: fresh directories are
/// written as a temporary sibling and renamed into place, existing data sets are
/// replaced through their index, other non-empty directories are refused). Every pair
/// is validated and serialised first; nothing is written if one is invalid.
pub fn write_pairs(dir: impl AsRef<Path>, pairs: &[ScanPair]) -> Result<()> {
    let dir = dir.as_ref();
    let mut contents = Vec::with_capacity(pairs.len());
    for (k, p) in pairs.iter().enumerate() {
        let path = dir.join(pair_file_name(k));
        p.validate()
            .and_then(|()| check_limits(p))
            .map_err(|v| Error::Invalid {
                path: path.clone(),
                field: v.field,
                problem: v.problem,
            })?;
        contents.push(serde_json::to_vec(p).map_err(|source| Error::Json { path, source })?);
    }
    match classify(dir)? {
        Target::Fresh => write_fresh(dir, pairs, &contents),
        Target::DataSet(old) => replace_data_set(dir, &old, pairs, &contents),
    }
}

fn index_bytes(path: &Path, index: &Index) -> Result<Vec<u8>> {
    serde_json::to_vec_pretty(index).map_err(|source| Error::Json {
        path: path.to_path_buf(),
        source,
    })
}

/// A missing or empty `dir`: write a temporary sibling directory, rename it into place.
fn write_fresh(dir: &Path, pairs: &[ScanPair], contents: &[Vec<u8>]) -> Result<()> {
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).map_err(|e| Error::io(&parent, e))?;
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "pairs".into());
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let tmp = parent.join(format!(".{name}.pgm-tmp-{}-{stamp}", std::process::id()));
    let (tmp_ticket, ()) = fsutil::create_unfinished(&tmp, true, || {
        std::fs::create_dir(&tmp).map_err(|e| Error::io(&tmp, e))
    })?;
    let mut tickets = vec![tmp_ticket];
    let written = (|| {
        let mut index = Index {
            format: FORMAT_NAME.into(),
            version: FORMAT_VERSION,
            pairs: Vec::with_capacity(pairs.len()),
        };
        for (k, (p, bytes)) in pairs.iter().zip(contents).enumerate() {
            let file = pair_file_name(k);
            tickets.push(write_flushed(&tmp.join(&file), bytes)?);
            index.pairs.push(IndexEntry {
                name: p.name.clone(),
                file,
            });
        }
        let index_path = tmp.join(INDEX_FILE);
        tickets.push(write_flushed(
            &index_path,
            &index_bytes(&index_path, &index)?,
        )?);
        sync_dir(&tmp);
        {
            // The rename finishes every file at once.
            let mut list = fsutil::lock();
            // Renaming onto an empty directory replaces it (POSIX); elsewhere remove it
            // first.
            if std::fs::rename(&tmp, dir).is_err() {
                let _ = std::fs::remove_dir(dir);
                std::fs::rename(&tmp, dir).map_err(|e| Error::io(dir, e))?;
            }
            list.finish(&tickets);
        }
        sync_dir(&parent);
        Ok(())
    })();
    if written.is_err() {
        // Only what this call created: the temporary directory and its files.
        if let Ok(entries) = std::fs::read_dir(&tmp) {
            for entry in entries.flatten() {
                let _ = std::fs::remove_file(entry.path());
            }
        }
        let _ = std::fs::remove_dir(&tmp);
    }
    written
}

/// `dir` holds the data set `old`: new pair files under unused names, then the index
/// switch, then the old pair files go.
fn replace_data_set(
    dir: &Path,
    old: &Index,
    pairs: &[ScanPair],
    contents: &[Vec<u8>],
) -> Result<()> {
    let journal = dir.join(JOURNAL_FILE);
    clear_interrupted_write(dir, &journal, old)?;
    let generation = (0..)
        .find(|&g| {
            (0..pairs.len()).all(|k| {
                let name = generation_file_name(g, k);
                !dir.join(&name).exists() && old.pairs.iter().all(|e| e.file != name)
            })
        })
        .unwrap_or(0);
    let mut index = Index {
        format: FORMAT_NAME.into(),
        version: FORMAT_VERSION,
        pairs: Vec::with_capacity(pairs.len()),
    };
    // The journal lists every file this replacement writes or will remove: after a kill
    // at any point, the files it lists that the index in place does not list are the
    // losing side (the new files before the switch, the old ones after it).
    let mut journal_files: Vec<String> = (0..pairs.len())
        .map(|k| generation_file_name(generation, k))
        .collect();
    journal_files.extend(
        old.pairs
            .iter()
            .filter(|e| is_pair_file_name(&e.file))
            .map(|e| e.file.clone()),
    );
    let journal_bytes = serde_json::to_vec(&Journal {
        files: journal_files,
    })
    .map_err(|source| Error::Json {
        path: journal.clone(),
        source,
    })?;
    // Until the journal is removed, a signal removes it (the replacement is then
    // undone or completed).
    let _journal_ticket = write_unfinished(&journal, &journal_bytes)?;
    let mut created: Vec<(PathBuf, Ticket)> = Vec::new();
    // The old data set's own pair files that the new index does not list (never
    // anything else).
    let listed: std::collections::HashSet<String> = (0..pairs.len())
        .map(|k| generation_file_name(generation, k))
        .collect();
    let stale: Vec<PathBuf> = old
        .pairs
        .iter()
        .map(|e| e.file.as_str())
        .filter(|name| is_pair_file_name(name) && !listed.contains(*name))
        .map(|name| dir.join(name))
        .collect();
    let switched = (|| {
        for (k, (p, bytes)) in pairs.iter().zip(contents).enumerate() {
            let file = generation_file_name(generation, k);
            let path = dir.join(&file);
            let ticket = write_unfinished(&path, bytes)?;
            created.push((path, ticket));
            index.pairs.push(IndexEntry {
                name: p.name.clone(),
                file,
            });
        }
        sync_dir(dir);
        let index_path = dir.join(INDEX_FILE);
        let index_ticket =
            write_unfinished_temporary(&index_path, &index_bytes(&index_path, &index)?)?;
        // The switch: from here a signal completes the replacement (removes the old
        // pair files) instead of undoing it.
        let mut list = fsutil::lock();
        let temporary = fsutil::temporary_path(&index_path).map_err(|e| core_io(&index_path, e))?;
        if let Err(e) = std::fs::rename(&temporary, &index_path) {
            let _ = std::fs::remove_file(&temporary);
            return Err(Error::io(&index_path, e));
        }
        list.finish(created.iter().map(|(_, t)| t).chain([&index_ticket]));
        let old_files: Vec<Ticket> = stale.iter().map(|p| list.register(p, false)).collect();
        drop(list);
        sync_dir(dir);
        Ok(old_files)
    })();
    let old_files = match switched {
        Ok(t) => t,
        Err(e) => {
            for (path, _) in &created {
                let _ = std::fs::remove_file(path);
            }
            let _ = std::fs::remove_file(&journal);
            return Err(e);
        }
    };
    for path in &stale {
        match std::fs::remove_file(path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(Error::io(path, e)),
        }
    }
    drop(old_files);
    std::fs::remove_file(&journal).map_err(|e| Error::io(&journal, e))?;
    sync_dir(dir);
    Ok(())
}

/// Writes `bytes` to the temporary sibling of `path` ([`fsutil::temporary_path`]),
/// flushed, registered as unfinished; the caller renames it.
fn write_unfinished_temporary(path: &Path, bytes: &[u8]) -> Result<Ticket> {
    let temporary = fsutil::temporary_path(path).map_err(|e| core_io(path, e))?;
    write_flushed(&temporary, bytes).inspect_err(|_| {
        let _ = std::fs::remove_file(&temporary);
    })
}

/// File in a data-set directory that lists the pair files a replacement is about to
/// write and those it will remove, itself removed once the replacement is complete. A
/// journal left behind by a killed run names files of the two data sets it was
/// switching between; the next write removes those the index in place does not list.
pub const JOURNAL_FILE: &str = ".pgm-write-journal.json";

#[derive(Serialize, Deserialize)]
struct Journal {
    files: Vec<String>,
}

/// A plain pair-file name in the data-set directory (`pair-….json`, no path).
fn is_pair_file_name(name: &str) -> bool {
    !name.contains(['/', '\\']) && name.starts_with("pair-") && name.ends_with(".json")
}

/// Removes what a killed replacement left (as its journal says): the listed files the
/// index in place does not list, and temporary files.
fn clear_interrupted_write(dir: &Path, journal: &Path, current: &Index) -> Result<()> {
    // A journal that never reached its name (killed while writing it).
    if let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries.flatten() {
            if fsutil::is_temporary_of(&entry.file_name().to_string_lossy(), JOURNAL_FILE) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    let Ok(text) = std::fs::read_to_string(journal) else {
        return Ok(());
    };
    if let Ok(j) = serde_json::from_str::<Journal>(&text) {
        // Temporary files of the listed files and of the index ([`write_atomically`]).
        let owners: Vec<&str> = j
            .files
            .iter()
            .map(String::as_str)
            .chain([INDEX_FILE])
            .collect();
        if let Ok(entries) = std::fs::read_dir(dir) {
            for entry in entries.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if owners.iter().any(|o| fsutil::is_temporary_of(&name, o)) {
                    let _ = std::fs::remove_file(entry.path());
                }
            }
        }
        for name in &j.files {
            if is_pair_file_name(name) && current.pairs.iter().all(|e| &e.file != name) {
                let path = dir.join(name);
                match std::fs::remove_file(&path) {
                    Ok(()) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                    Err(e) => return Err(Error::io(path, e)),
                }
            }
        }
    }
    std::fs::remove_file(journal).map_err(|e| Error::io(journal, e))
}
