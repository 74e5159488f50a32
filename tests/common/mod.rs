//! Helpers shared by the command-line integration tests (`mod common;`): run the
//! binary with a time limit, assert success or a clean refusal, write small inputs.
#![allow(dead_code)] // each test crate uses its own subset

use pgm::datasets::sim::{simulate_pairs, SimConfig};
use pgm::datasets::{ParamGuard, ScanPair};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Runs `pgm args…`: stdout, stderr, exit code. A run longer than two minutes is
/// killed and fails the test (a hang is one of the faults).
pub fn pgm(args: &[&str]) -> (String, String, Option<i32>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_pgm"))
        .args(args)
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

/// Asserts success; returns stdout and stderr.
pub fn ok(args: &[&str]) -> (String, String) {
    let (out, err, code) = pgm(args);
    assert_eq!(code, Some(0), "{args:?}:\n{err}");
    assert!(!err.contains("panicked"), "{err}");
    (out, err)
}

/// Asserts exit status 2, no panic, nothing on stdout and `needles` in the message.
pub fn refused(args: &[&str], needles: &[&str]) -> String {
    let (out, err, code) = pgm(args);
    assert_eq!(code, Some(2), "{args:?}: status {code:?}\n{err}");
    assert!(out.is_empty(), "{args:?} printed a result:\n{out}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: expected {n:?} in\n{err}");
    }
    err
}

pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pgm-kinds-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

pub fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text.trim()).unwrap_or_else(|e| panic!("{e}: not JSON:\n{text}"))
}

/// Simulated pairs (preset mixed) written as a data set at `dir/name`.
pub fn simulated(dir: &Path, name: &str, seed: u64, n: usize) -> (String, Vec<ScanPair>) {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), seed, n);
    let path = dir.join(name);
    pgm::datasets::write_pairs(&path, &pairs).unwrap();
    (path.to_str().unwrap().to_string(), pairs)
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
