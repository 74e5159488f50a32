//! Fixtures shared by the integration tests of pgm-core (each test target includes
//! this module with `mod common;` and uses the items it needs).

use pgm_core::exact::{brute_force, BruteForceLimit};
use pgm_core::learning::LabelledInstance;
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

/// `−Σ_i log p(y_i) + ‖w‖²/(2σ²)` by brute-force enumeration: the negative
/// log-likelihood of the labelled instances under `weights`, with a Gaussian prior of
/// variance `prior_variance` (none when infinite).
#[allow(dead_code)] // only the learning tests use it
pub fn brute_force_objective(
    data: &[LabelledInstance],
    weights: &[f64],
    prior_variance: f64,
) -> f64 {
    let mut value = 0.0;
    for instance in data {
        let graph = instance.model.to_factor_graph(weights).unwrap();
        let solution = brute_force(&graph, BruteForceLimit::default()).unwrap();
        value += solution.log_partition - graph.log_score(&instance.labels).unwrap();
    }
    if prior_variance.is_finite() {
        value += weights.iter().map(|w| w * w).sum::<f64>() / (2.0 * prior_variance);
    }
    value
}
