//! Helpers shared by the command-line integration tests (`mod common;` in each
//! `tests/cli_*.rs`): run the binary with a time limit, assert success or a clean
//! refusal (status 2 and a message naming the value), temporary directories, small
//! input files, simulated pairs written by `pgm sim`, and JSON output. The inputs the
//! tests build (CARMEN lines, reordered pairs) are in [`logs`] and [`pairs`], those
//! they share with the benches (real pairs, bad priors, long scans) in [`fixtures`].
#![allow(dead_code)] // each test crate uses its own subset

pub mod fixtures;
pub mod logs;
pub mod pairs;

use pgm::datasets::ScanPair;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The `pgm` binary with `args`, not yet started (for tests that spawn, kill or
/// redirect it themselves).
pub fn command<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_pgm"));
    command.args(args);
    command
}

/// Runs `pgm args…`: stdout, stderr, exit code. A run longer than two minutes is
/// killed and fails the test (a hang is one of the faults).
pub fn pgm(args: &[&str]) -> (String, String, Option<i32>) {
    let mut child = command(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Drain both pipes on threads so a large output cannot block the child.
    let mut stdout = child.stdout.take().unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let out = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stdout, &mut s).unwrap();
        s
    });
    let err = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut s).unwrap();
        s
    });
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("pgm {args:?} ran for more than two minutes (a hang)");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    (out.join().unwrap(), err.join().unwrap(), status.code())
}

/// Asserts success (status 0, no panic); returns stdout and stderr.
pub fn ok(args: &[&str]) -> (String, String) {
    let (out, err, code) = pgm(args);
    assert_eq!(code, Some(0), "{args:?}:\n{err}");
    assert!(!err.contains("panicked"), "{args:?}:\n{err}");
    (out, err)
}

/// Asserts success and parses stdout as one JSON value.
pub fn ok_json(args: &[&str]) -> serde_json::Value {
    json(&ok(args).0)
}

/// Asserts exit status 2, no panic, nothing on stdout and every one of `needles` in
/// the message; returns the message.
pub fn refused(args: &[&str], needles: &[&str]) -> String {
    let (out, err, code) = pgm(args);
    assert_eq!(code, Some(2), "{args:?}: status {code:?}\n{err}");
    assert!(out.is_empty(), "{args:?} printed a result:\n{out}");
    assert!(!err.contains("panicked"), "{args:?}:\n{err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: expected {n:?} in\n{err}");
    }
    err
}

/// One refusal case of a table: the arguments, and what the message must name.
pub type Refusal<'a> = (Vec<&'a str>, Vec<&'a str>);

/// [`refused`] for every case of a table (a failure names the case by its arguments);
/// returns the messages in order.
pub fn refused_all(cases: &[Refusal]) -> Vec<String> {
    cases
        .iter()
        .map(|(args, needles)| refused(args, needles))
        .collect()
}

/// A fresh, empty directory for one test: unique per test binary (the crate name),
/// run (the process id) and `name`.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "pgm-{}-{name}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `dir/name` as a string argument (the file need not exist).
pub fn path(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().unwrap().to_string()
}

/// Writes `text` to `dir/name`; returns the path as a string.
pub fn write(dir: &Path, name: &str, text: &str) -> String {
    write_bytes(dir, name, text.as_bytes())
}

/// Writes `bytes` to `dir/name`; returns the path as a string.
pub fn write_bytes(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path.to_str().unwrap().to_string()
}

/// `text` parsed as one JSON value (surrounding white space ignored).
pub fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text.trim()).unwrap_or_else(|e| panic!("{e}: not JSON:\n{text}"))
}

/// The file at `path` parsed as JSON.
pub fn read_json(path: impl AsRef<Path>) -> serde_json::Value {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    json(&text)
}

/// `n` simulated pairs (preset mixed, `seed`) written by `pgm sim` as a data set at
/// `dir/name`: its path, and the pairs read back.
pub fn simulated(dir: &Path, name: &str, seed: u64, n: usize) -> (String, Vec<ScanPair>) {
    let path = path(dir, name);
    let (seed, n) = (seed.to_string(), n.to_string());
    ok(&["sim", "--pairs", &n, "--seed", &seed, "--out", &path]);
    let pairs = pgm::datasets::read_pairs(&path).unwrap();
    (path, pairs)
}

/// `pgm track --method crf --associations ASSOCIATIONS` followed by `rest`.
pub fn track_crf<'a>(associations: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
    [
        &["track", "--method", "crf", "--associations", associations][..],
        rest,
    ]
    .concat()
}

/// One simulated sequence of `scans` scans (`pgm sim --preset PRESET --seed SEED
/// --pairs 1 --sequence SCANS`) written as a data set at `dir/seq`: its path.
pub fn simulated_sequence(dir: &Path, preset: &str, seed: u64, scans: usize) -> String {
    let out = path(dir, "seq");
    let (seed, scans) = (seed.to_string(), scans.to_string());
    ok(&[
        "sim",
        "--preset",
        preset,
        "--seed",
        &seed,
        "--pairs",
        "1",
        "--sequence",
        &scans,
        "--out",
        &out,
    ]);
    out
}

/// `pairs` written as a data set at `dir/name` without the writer's checks (the
/// readers must refuse what the writer would).
pub fn write_raw(dir: &Path, name: &str, pairs: &[serde_json::Value]) -> String {
    let ds = dir.join(name);
    std::fs::create_dir_all(&ds).unwrap();
    let mut entries = Vec::new();
    for (k, p) in pairs.iter().enumerate() {
        let file = format!("pair-{k:05}.json");
        std::fs::write(ds.join(&file), p.to_string()).unwrap();
        entries.push(serde_json::json!({"name": p["name"], "file": file}));
    }
    let index = serde_json::json!({"format": "pgm-scan-pairs", "version": 1, "pairs": entries});
    std::fs::write(ds.join("index.json"), index.to_string()).unwrap();
    ds.to_str().unwrap().to_string()
}

/// The pair as a JSON value, to damage before [`write_raw`].
pub fn to_json(pair: &ScanPair) -> serde_json::Value {
    serde_json::to_value(pair).unwrap()
}

/// The arguments of a one-pair command (`cluster`, `match`, `joint`) on scans
/// `reference` and `current` of a log: `COMMAND SOURCE LOG --reference R --current C`
/// (`source` is `--carmen`, `--scans`, `--log`, `--bag`).
pub fn one_pair<'a>(
    command: &'a str,
    source: &'a str,
    log: &'a str,
    reference: &'a str,
    current: &'a str,
) -> Vec<&'a str> {
    vec![
        command,
        source,
        log,
        "--reference",
        reference,
        "--current",
        current,
    ]
}

/// `eval KIND --method METHOD` followed by `rest`.
pub fn eval<'a>(kind: &'a str, method: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
    [&["eval", kind, "--method", method][..], rest].concat()
}

/// The topics of the leigh-gtm1 bag in `../shared/data` as arguments: laser scans,
/// wheel odometry and the annotated people.
pub const LEIGH_BAG_TOPICS: [&str; 6] = [
    "--scan-topic",
    "/scan",
    "--odom-topic",
    "/odom",
    "--people-topic",
    "/ground_truth_people_tracks",
];

/// The shipped weight file of `model` (crf-clustering, crf-matching, joint).
pub fn shipped(model: &str) -> String {
    format!(
        "{}/models/{model}/weights/default.json",
        env!("CARGO_MANIFEST_DIR")
    )
}
