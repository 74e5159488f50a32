//! Locating the shared real-data folder for tests, benches and examples.
//!
//! The real logs are not part of the repository: they live in `../shared/data` beside
//! the workspace (CI has that folder next to its checkout), or wherever the
//! environment variable `PGM_SHARED_DATA` points. A test that needs them calls
//! [`shared_data_dir`]: when the folder is missing the test is skipped with a note on
//! stderr — except under CI (`CI=true`), where a missing folder is a failure so a
//! real-data check never silently vanishes.
//!
//! The small failing inputs of the hardening rounds live beside the data, in
//! `../shared/cases` (or `PGM_SHARED_CASES`; with only `PGM_SHARED_DATA` set, the
//! `cases` folder beside it), found by [`shared_cases_dir`] and [`shared_case_file`]
//! under the same rule.

use std::path::PathBuf;

/// Environment variable that overrides the location of the shared data folder.
pub const SHARED_DATA_ENV: &str = "PGM_SHARED_DATA";

/// The default location: `../shared/data` relative to the workspace root (fixed at
/// compile time from this crate's manifest directory).
pub fn default_shared_data_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data"))
}

/// The shared data folder, if it exists (`PGM_SHARED_DATA` or the default).
///
/// # Panics
///
/// When the folder is missing and the environment variable `CI` is `true`.
pub fn shared_data_dir() -> Option<PathBuf> {
    let dir = env_or(SHARED_DATA_ENV, default_shared_data_dir);
    if dir.is_dir() {
        return Some(dir);
    }
    if under_ci() {
        panic!(
            "shared real data not found at {} (set {SHARED_DATA_ENV}); CI=true, so this is an error",
            dir.display()
        );
    }
    eprintln!(
        "note: shared real data not found at {} (set {SHARED_DATA_ENV}); skipping",
        dir.display()
    );
    None
}

/// A file inside the shared data folder (for example `mit-csail/mit-csail.clf`), with
/// the same skip-or-fail rule as [`shared_data_dir`], which also applies when the
/// folder exists but the file does not.
pub fn shared_data_file(relative: &str) -> Option<PathBuf> {
    let path = shared_data_dir()?.join(relative);
    if path.is_file() {
        return Some(path);
    }
    missing("shared data file", &path)
}

/// Environment variable that overrides the location of the shared cases folder.
pub const SHARED_CASES_ENV: &str = "PGM_SHARED_CASES";

/// The default location of the cases: `cases` beside the shared data folder
/// (`../shared/cases`, or beside `PGM_SHARED_DATA` when only that is set).
pub fn default_shared_cases_dir() -> PathBuf {
    let data = env_or(SHARED_DATA_ENV, default_shared_data_dir);
    data.parent()
        .map_or_else(|| PathBuf::from("cases"), |p| p.join("cases"))
}

/// The path the environment variable `var` holds, or else `default()`.
fn env_or(var: &str, default: fn() -> PathBuf) -> PathBuf {
    std::env::var_os(var)
        .map(PathBuf::from)
        .unwrap_or_else(default)
}

/// Whether the tests run under CI (`CI=true`).
fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}

/// Skipped with a note, or a panic under `CI=true`: `what` is missing at `path`.
fn missing<T>(what: &str, path: &std::path::Path) -> Option<T> {
    if under_ci() {
        panic!(
            "{what} {} is missing; CI=true, so this is an error",
            path.display()
        );
    }
    eprintln!("note: {what} {} is missing; skipping", path.display());
    None
}

/// The shared cases folder (`PGM_SHARED_CASES` or [`default_shared_cases_dir`]), if
/// it exists; the skip-or-fail rule of [`shared_data_dir`].
///
/// # Panics
///
/// When the folder is missing and the environment variable `CI` is `true`.
pub fn shared_cases_dir() -> Option<PathBuf> {
    let dir = env_or(SHARED_CASES_ENV, default_shared_cases_dir);
    if dir.is_dir() {
        return Some(dir);
    }
    missing(
        &format!("the shared cases folder (set {SHARED_CASES_ENV})"),
        &dir,
    )
}

/// A file of a case (for example `mcap-bad-crc/badcrc.mcap`), with the rule of
/// [`shared_cases_dir`], which also applies when the folder exists but the file does
/// not.
///
/// # Panics
///
/// When the file is missing and the environment variable `CI` is `true`.
pub fn shared_case_file(relative: &str) -> Option<PathBuf> {
    let path = shared_cases_dir()?.join(relative);
    if path.is_file() {
        return Some(path);
    }
    missing("shared case file", &path)
}

/// Several files of a case at once ([`shared_case_file`] for each, every one looked
/// up): `None` when any is missing.
///
/// # Panics
///
/// When a file is missing and the environment variable `CI` is `true`.
pub fn shared_case_files<const N: usize>(relative: [&str; N]) -> Option<[PathBuf; N]> {
    let files = relative.map(shared_case_file);
    if files.iter().all(Option::is_some) {
        Some(files.map(Option::unwrap))
    } else {
        None
    }
}
