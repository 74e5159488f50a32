//! Exact references: brute-force enumeration for small graphs, Viterbi and
//! forward-backward on chains, and two-pass elimination on trees. They share no code
//! with the loopy engine or with the hybrid chain solver
//! ([`FlatChain`](crate::hybrid::FlatChain)), so tests can hold both to them.

mod brute_force;
mod chain;
mod sample;
mod tree;

pub use brute_force::{brute_force, BruteForceLimit};
pub use chain::{chain_order, forward_backward, viterbi};
pub use sample::{sample_chain, ChainSampler};
pub use tree::{tree_map, tree_marginals};

/// An exact answer.
#[derive(Clone, Debug, PartialEq)]
pub struct ExactSolution {
    /// A MAP assignment (the first in enumeration order among ties for brute force).
    pub map: Vec<usize>,
    /// Its log-score.
    pub map_log_score: f64,
    /// Natural log of the partition function.
    pub log_partition: f64,
    /// Marginal probabilities per variable.
    pub marginals: Vec<Vec<f64>>,
}
