//! A dedicated solver for the chain CRF (no kNN edges) with motions re-solved after
//! every sweep: the same algorithm as `HybridInference` with
//! `UpdatePolicy::EverySweep` and `Sequential::default()` on the chain graph, without
//! the generic factor-graph machinery.
//!
//! On a chain one forward-backward max-product sweep is exact for fixed motions, so
//! each sweep is a Viterbi pass: forward and backward max-messages, max-marginals
//! `local + forward + backward`, and the MAP labels by back-tracking (ties to the
//! lowest state). After each sweep the motion statistics follow the changed labels
//! and the motions are re-solved (eq. 3); the run stops when no motion parameter
//! changes by more than the tolerance (then the messages, which depend only on the
//! motions, are stable too) or after `max_sweeps` sweeps.

use crate::model::ClusterMotionNodes;
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
    let mut forward = vec![0.0; n * s];
    let mut backward = vec![0.0; n * s];
    let mut back = vec![0usize; n * s];
    let mut beliefs = vec![0.0; n * s];
    let mut sweeps = 0;
    let mut converged = false;
    let mut next = vec![0usize; n];
    let mut moved = Vec::with_capacity(n * nodes.clusters());
    while sweeps < max_sweeps {
        sweeps += 1;
        nodes.write_tables(&mut moved, &mut local, &mut pair);
        viterbi(
            n,
            s,
            &local,
            &pair,
            &mut forward,
            &mut backward,
            &mut back,
            &mut next,
        );
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
    for i in 0..n {
        let row = &mut beliefs[i * s..(i + 1) * s];
        let mut top = f64::NEG_INFINITY;
        for a in 0..s {
            row[a] = local[i * s + a] + forward[i * s + a] + backward[i * s + a];
            top = top.max(row[a]);
        }
        let mut sum = 0.0;
        for x in row.iter_mut() {
            *x = (*x - top).exp();
            sum += *x;
        }
        for x in row.iter_mut() {
            *x /= sum;
        }
    }
    ChainResult {
        labels,
        beliefs,
        states: s,
        sweeps,
        converged,
    }
}

/// Forward and backward max-messages (each shifted to a maximum of 0) and the MAP
/// labels into `labels`.
#[allow(clippy::too_many_arguments)]
fn viterbi(
    n: usize,
    s: usize,
    local: &[f64],
    pair: &[f64],
    forward: &mut [f64],
    backward: &mut [f64],
    back: &mut [usize],
    labels: &mut [usize],
) {
    if n == 0 {
        return;
    }
    forward[..s].fill(0.0);
    for i in 1..n {
        let (prev, cur) = forward.split_at_mut(i * s);
        let prev = &prev[(i - 1) * s..];
        let cur = &mut cur[..s];
        let p = &pair[(i - 1) * s * s..i * s * s];
        let l = &local[(i - 1) * s..i * s];
        let mut top = f64::NEG_INFINITY;
        for b in 0..s {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0;
            for a in 0..s {
                let v = prev[a] + l[a] + p[a * s + b];
                if v > best {
                    best = v;
                    arg = a;
                }
            }
            cur[b] = best;
            back[i * s + b] = arg;
            top = top.max(best);
        }
        for x in cur.iter_mut() {
            *x -= top;
        }
    }
    backward[(n - 1) * s..].fill(0.0);
    for i in (0..n - 1).rev() {
        let (cur, nxt) = backward.split_at_mut((i + 1) * s);
        let cur = &mut cur[i * s..];
        let nxt = &nxt[..s];
        let p = &pair[i * s * s..(i + 1) * s * s];
        let l = &local[(i + 1) * s..(i + 2) * s];
        let mut top = f64::NEG_INFINITY;
        for a in 0..s {
            let row = &p[a * s..(a + 1) * s];
            let mut best = f64::NEG_INFINITY;
            for b in 0..s {
                best = best.max(row[b] + l[b] + nxt[b]);
            }
            cur[a] = best;
            top = top.max(best);
        }
        for x in cur.iter_mut() {
            *x -= top;
        }
    }
    let last = (n - 1) * s;
    let mut best = f64::NEG_INFINITY;
    let mut arg = 0;
    for a in 0..s {
        let v = forward[last + a] + local[last + a];
        if v > best {
            best = v;
            arg = a;
        }
    }
    labels[n - 1] = arg;
    for i in (1..n).rev() {
        labels[i - 1] = back[i * s + labels[i]];
    }
}
