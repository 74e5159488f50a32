//! Every committed fuzz input (`fuzz/corpus/TARGET/*` and the hand-written
//! `fuzz/seeds/TARGET/*`) through the same checks as its cargo-fuzz target, on stable
//! Rust, so CI keeps every input that once found new code paths (see fuzz/README.md).

#[path = "../fuzz/src/lib.rs"]
mod harness;

use std::path::Path;

/// Runs `check` on every file of the corpus and seeds of `target`; returns how many.
fn run(target: &str, check: fn(&[u8])) -> usize {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut count = 0;
    for kind in ["corpus", "seeds"] {
        let dir = root.join(kind).join(target);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries {
            let path = entry.unwrap().path();
            let data = std::fs::read(&path).unwrap();
            let outcome = std::panic::catch_unwind(|| check(&data));
            assert!(outcome.is_ok(), "{} fails its fuzz check", path.display());
            count += 1;
        }
    }
    assert!(count > 0, "no corpus for {target}");
    count
}

#[test]
fn uai_model_corpus() {
    run("uai_model", harness::uai_model);
}

#[test]
fn uai_evidence_corpus() {
    run("uai_evidence", harness::uai_evidence);
}

#[test]
fn carmen_corpus() {
    run("carmen", harness::carmen);
}

#[test]
fn relations_corpus() {
    run("relations", harness::relations);
}

#[test]
fn leigh_corpus() {
    run("leigh", harness::leigh);
}

#[test]
fn pair_json_corpus() {
    run("pair_json", harness::pair_json);
}

#[test]
fn index_json_corpus() {
    run("index_json", harness::index_json);
}

#[test]
fn weights_json_corpus() {
    run("weights_json", harness::weights_json);
}

#[test]
fn bag_corpus() {
    run("bag", harness::bag);
}

#[test]
fn ros_message_corpus() {
    run("ros_message", harness::ros_message);
}

#[test]
fn mcap_corpus() {
    run("mcap", harness::mcap);
}

#[test]
fn clear_mot_corpus() {
    run("clear_mot", harness::clear_mot);
}
