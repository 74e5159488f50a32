//! The simulator's commands (`pgm sim`, `pgm demo`) from the command line: an unknown
//! preset is a clear error, and the demo's help says what it runs and writes. (What
//! `pgm sim --out` writes is in `cli_output.rs`, its counts in `cli_options.rs`.)

mod common;

use common::*;

#[test]
fn an_unknown_preset_is_a_clear_error() {
    refused(
        &["sim", "--pairs", "1", "--preset", "motorway"],
        &["motorway"],
    );
}

/// Item 8 of the polish: the help of `pgm demo` says what it runs and writes.
#[test]
fn demo_help_names_the_joint_model_and_both_pictures() {
    for args in [&["--help"][..], &["demo", "--help"][..]] {
        let (out, _) = ok(args);
        let line = out
            .lines()
            .find(|l| l.contains("built-in simulator"))
            .unwrap_or_else(|| panic!("{args:?}:\n{out}"));
        for needle in ["joint model", "crf-clustering.svg", "joint.svg"] {
            assert!(
                line.contains(needle),
                "{args:?}: {needle:?} not in {line:?}"
            );
        }
    }
}
