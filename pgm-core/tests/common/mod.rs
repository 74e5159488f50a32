//! Fixtures shared by the integration tests of pgm-core (each test target includes
//! this module with `mod common;` and uses the items it needs).

use pgm_core::{Flooding, Residual, Schedule, Sequential};
use proptest::test_runner::{Config, FileFailurePersistence};

/// A proptest configuration of `cases` cases whose failing cases are saved in `path`
/// (relative to the crate) and replayed first: commit the file.
#[allow(dead_code)] // not every test target runs property tests
pub fn persisted(cases: u32, path: &'static str) -> Config {
    Config {
        cases,
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(path))),
        ..Config::default()
    }
}

/// The three message-passing schedules, by name.
#[allow(dead_code)] // not every test target runs belief propagation
pub fn schedules() -> Vec<(&'static str, Box<dyn Schedule>)> {
    vec![
        ("flooding", Box::new(Flooding)),
        ("sequential", Box::new(Sequential::default())),
        ("residual", Box::new(Residual::default())),
    ]
}
