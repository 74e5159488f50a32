//! A dedicated solver for the chain CRF (no kNN edges) with motions re-solved after
//! every sweep: the same algorithm as `HybridInference` with
//! `UpdatePolicy::EverySweep` and `Sequential::default()` on the chain graph, without
//! the generic factor-graph machinery.
//!
//! On a chain one forward-backward max-product sweep is exact for fixed motions, so
//! each sweep is a Viterbi pass (`pgm_core::exact::FlatChain`): forward and backward
//! max-messages, max-marginals `local + forward + backward`, and the MAP labels by
//! back-tracking (ties to the lowest state). After each sweep the motion statistics follow the changed labels
//! and the motions are re-solved (eq. 3); the run stops when no motion parameter
//! changes by more than the tolerance (then the messages, which depend only on the
//! motions, are stable too) or after `max_sweeps` sweeps.

use crate::model::ClusterMotionNodes;
use pgm_core::exact::FlatChain;
use pgm_core::hybrid::{ContinuousModel, VariableState};
use pgm_core::VariableId;

/// The outcome of [`run_chain`].
pub(crate) struct ChainResult {
    /// MAP label of each point.
    pub labels: Vec<usize>,
    /// Normalised max-marginals, `states` entries per point (row-major).
    pub beliefs: Vec<f64>,
    /// Number of states per point.
    pub states: usize,
    /// Sweeps performed.
    pub sweeps: usize,
    /// Whether the motions converged.
    pub converged: bool,
}

/// Runs sweeps on the chain over all points of `nodes` (its edges must be the chain
/// `(e, e + 1)`, edge `e` joining points `e` and `e + 1`), starting from `labels`.
pub(crate) fn run_chain(
    nodes: &mut ClusterMotionNodes,
    initial: &[usize],
    max_sweeps: usize,
    tolerance: f64,
) -> ChainResult {
    let n = initial.len();
    let s = nodes.states();
    for (i, &l) in initial.iter().enumerate() {
        nodes.update_variable(VariableId(i), None, VariableState::Label(l));
    }
    nodes.solve();
    let mut labels = initial.to_vec();
    let mut local = vec![0.0; n * s];
    let mut pair = vec![0.0; n.saturating_sub(1) * s * s];
    let mut chain = FlatChain::new(n, s);
    let mut beliefs = vec![0.0; n * s];
    let mut sweeps = 0;
    let mut converged = false;
    let mut next = vec![0usize; n];
    let mut moved = Vec::with_capacity(n * nodes.clusters());
    while sweeps < max_sweeps {
        sweeps += 1;
        nodes.write_tables(&mut moved, &mut local, &mut pair);
        chain.viterbi(&local, &pair, &mut next);
        for (i, (&old, &new)) in labels.iter().zip(&next).enumerate() {
            if old != new {
                nodes.update_variable(
                    VariableId(i),
                    Some(VariableState::Label(old)),
                    VariableState::Label(new),
                );
            }
        }
        std::mem::swap(&mut labels, &mut next);
        let change = nodes.solve();
        if change <= tolerance {
            converged = true;
            break;
        }
    }
    // Max-marginals of the last sweep (the buffers still hold it).
    chain.max_marginals(&local, &mut beliefs);
    ChainResult {
        labels,
        beliefs,
        states: s,
        sweeps,
        converged,
    }
}
