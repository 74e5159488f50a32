//! Inputs that the tests and the benches share (the benches include this file with
//! `#[path = "../tests/common/fixtures.rs"]`): the mit-csail pairs less than 1.5 s
//! apart, priors moved as from a bad start, and the ranges of the hardening case
//! carmen-long100000.
#![allow(dead_code)] // each test and bench uses its own subset

use pgm_datasets::builders::{relation_pairs, RelationPairOptions};
use pgm_datasets::{carmen, relations, testdata, ScanPair};
use pgm_scan::Pose2;
use rand::Rng;

/// The mit-csail relation pairs whose scans are less than 1.5 s apart; `None`
/// without `../shared/data` (see `testdata::shared_data_dir`).
pub fn mit_csail_near_pairs() -> Option<Vec<ScanPair>> {
    let dir = testdata::shared_data_dir()?.join("mit-csail");
    let log = carmen::read_carmen(dir.join("mit-csail.clf")).expect("log");
    let rels = relations::read_relations(dir.join("mit-csail.relations")).expect("relations");
    let built = relation_pairs(&log, &rels, &RelationPairOptions::default());
    Some(
        built
            .pairs
            .into_iter()
            .filter(|p| p.time_gap().abs() < 1.5)
            .collect(),
    )
}

/// `prior` moved by up to 1 m (uniform in the disc) and 30 degrees (uniform in the
/// interval).
pub fn perturb(prior: Pose2, rng: &mut impl Rng) -> Pose2 {
    let r = rng.random::<f64>().sqrt();
    let a = std::f64::consts::TAU * rng.random::<f64>();
    let t = 30f64.to_radians() * (2.0 * rng.random::<f64>() - 1.0);
    Pose2::new(
        prior.x() + r * a.cos(),
        prior.y() + r * a.sin(),
        prior.theta() + t,
    )
}

/// `n` pseudo-random ranges in 5-6 m (a fixed xorshift sequence), as the hardening
/// case carmen-long100000 writes them.
pub fn long_ranges(n: usize) -> Vec<f64> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            5.0 + (state % 1000) as f64 / 1000.0
        })
        .collect()
}
