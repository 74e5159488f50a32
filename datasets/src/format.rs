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
//! range); errors name the file and the field.
//!
//! [`write_pairs`] writes every file to a temporary name in the target directory,
//! flushes it to disk and renames it into place, pair files first and the index last;
//! a crash or a full disk leaves either the previous index (and its files) or the new
//! one, never a truncated file under a final name. Pair files of an earlier write that
//! the new index does not list are removed after the index is in place.

use crate::error::{Error, Result};
use crate::pair::ScanPair;
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
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
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

fn pair_from_value(path: &Path, value: serde_json::Value) -> Result<ScanPair> {
    let pair: ScanPair = serde_json::from_value(value).map_err(|source| Error::Json {
        path: path.to_path_buf(),
        source,
    })?;
    pair.validate().map_err(|v| Error::Invalid {
        path: path.to_path_buf(),
        field: v.field,
        problem: v.problem,
    })?;
    Ok(pair)
}

/// Reads a data set: a directory, an index file or a single pair file (see the
/// module docs). Pairs come back in index order, each validated.
pub fn read_pairs(path: impl AsRef<Path>) -> Result<Vec<ScanPair>> {
    let path = path.as_ref();
    let index_path = if path.is_dir() {
        path.join(INDEX_FILE)
    } else {
        path.to_path_buf()
    };
    let value = read_json_value(&index_path)?;
    let is_index = value.get("format").is_some();
    if !is_index {
        return Ok(vec![pair_from_value(&index_path, value)?]);
    }
    let index: Index = serde_json::from_value(value).map_err(|source| Error::Json {
        path: index_path.clone(),
        source,
    })?;
    if index.format != FORMAT_NAME {
        return Err(Error::Invalid {
            path: index_path,
            field: "format".into(),
            problem: format!("`{}`, expected `{FORMAT_NAME}`", index.format),
        });
    }
    if index.version != FORMAT_VERSION {
        return Err(Error::Invalid {
            path: index_path,
            field: "version".into(),
            problem: format!(
                "{}, this reader understands {FORMAT_VERSION}",
                index.version
            ),
        });
    }
    let base = index_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let mut pairs = Vec::with_capacity(index.pairs.len());
    for (k, entry) in index.pairs.iter().enumerate() {
        let file = Path::new(&entry.file);
        if file.is_absolute()
            || file
                .components()
                .any(|c| c == std::path::Component::ParentDir)
        {
            return Err(Error::Invalid {
                path: index_path.clone(),
                field: format!("pairs[{k}].file"),
                problem: format!(
                    "`{}` must be a path inside the data-set directory",
                    entry.file
                ),
            });
        }
        let pair = read_pair(base.join(file))?;
        if pair.name != entry.name {
            return Err(Error::Invalid {
                path: base.join(file),
                field: "name".into(),
                problem: format!("`{}`, but the index lists `{}`", pair.name, entry.name),
            });
        }
        pairs.push(pair);
    }
    Ok(pairs)
}

/// Writes `bytes` to `path` through a temporary file in the same directory, flushed
/// to disk and renamed into place.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let tmp: PathBuf = dir.join(format!(".{file_name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    Ok(())
}

/// File name of pair number `k` in a data-set directory.
pub fn pair_file_name(k: usize) -> String {
    format!("pair-{k:05}.json")
}

/// Writes a data set into directory `dir` (created if missing; see the module docs).
/// Every pair is validated first; nothing is written if one is invalid.
pub fn write_pairs(dir: impl AsRef<Path>, pairs: &[ScanPair]) -> Result<()> {
    let dir = dir.as_ref();
    for (k, p) in pairs.iter().enumerate() {
        p.validate().map_err(|v| Error::Invalid {
            path: dir.join(pair_file_name(k)),
            field: v.field,
            problem: v.problem,
        })?;
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut index = Index {
        format: FORMAT_NAME.into(),
        version: FORMAT_VERSION,
        pairs: Vec::with_capacity(pairs.len()),
    };
    for (k, p) in pairs.iter().enumerate() {
        let file = pair_file_name(k);
        let path = dir.join(&file);
        let bytes = serde_json::to_vec(p).map_err(|source| Error::Json {
            path: path.clone(),
            source,
        })?;
        write_atomically(&path, &bytes)?;
        index.pairs.push(IndexEntry {
            name: p.name.clone(),
            file,
        });
    }
    let index_path = dir.join(INDEX_FILE);
    let bytes = serde_json::to_vec_pretty(&index).map_err(|source| Error::Json {
        path: index_path.clone(),
        source,
    })?;
    write_atomically(&index_path, &bytes)?;
    // Remove pair files of an earlier, larger data set.
    let listed: std::collections::HashSet<&str> =
        index.pairs.iter().map(|e| e.file.as_str()).collect();
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with("pair-") && name.ends_with(".json") && !listed.contains(name.as_str()) {
            std::fs::remove_file(entry.path()).map_err(|e| Error::io(entry.path(), e))?;
        }
    }
    Ok(())
}
