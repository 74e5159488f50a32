//! Brute-force enumeration of every joint assignment.

use super::ExactSolution;
use crate::error::{Error, Result};
use crate::graph::FactorGraph;

/// The largest number of joint states [`brute_force`] accepts by default.
#[derive(Clone, Copy, Debug)]
pub struct BruteForceLimit(pub u64);

impl Default for BruteForceLimit {
    fn default() -> Self {
        BruteForceLimit(1 << 24)
    }
}

/// Exact MAP, log Z and marginals by depth-first enumeration in variable order: each
/// factor's log-potential is added once its highest-indexed variable is assigned, so
/// the cost is the number of search-tree nodes, not states × factors. Fails when the
/// number of joint states exceeds `limit`, or when every assignment has probability 0.
pub fn brute_force(graph: &FactorGraph, limit: BruteForceLimit) -> Result<ExactSolution> {
    let n = graph.num_variables();
    let mut states_count: u64 = 1;
    for &k in graph.cardinalities() {
        states_count = states_count.saturating_mul(k as u64);
    }
    if states_count > limit.0 {
        return Err(Error::NotApplicable {
            method: "brute force",
            reason: format!(
                "{states_count} joint states exceed the limit of {}",
                limit.0
            ),
        });
    }
    // Factors grouped by their highest variable.
    let mut closing: Vec<Vec<usize>> = vec![Vec::new(); n.max(1)];
    let mut constant = 0.0;
    for (a, f) in graph.factors().enumerate() {
        match f.scope().iter().map(|v| v.0).max() {
            Some(m) => closing[m].push(a),
            None => constant += f.log_potential(&[]),
        }
    }
    let factors: Vec<&dyn crate::Factor> = graph.factors().collect();
    let cards = graph.cardinalities();
    let mut assignment = vec![0usize; n];
    let mut partial = vec![0.0f64; n + 1];
    partial[0] = constant;
    let mut buf = Vec::new();
    // Pass 1: MAP. Pass 2: sums shifted by the MAP score.
    let mut best = f64::NEG_INFINITY;
    let mut best_assignment = vec![0usize; n];
    let mut marginals: Vec<Vec<f64>> = cards.iter().map(|&k| vec![0.0; k]).collect();
    let mut total = 0.0f64;
    for pass in 0..2 {
        let shift = best;
        if n == 0 {
            if pass == 0 {
                best = constant;
            } else if best.is_finite() {
                total = 1.0;
            }
            continue;
        }
        // Iterative DFS: depth d means variables < d are assigned.
        let mut depth = 0usize;
        assignment.iter_mut().for_each(|x| *x = 0);
        loop {
            // Assign variable `depth` its current value and extend the partial score.
            let mut s = partial[depth];
            for &a in &closing[depth] {
                let f = factors[a];
                buf.clear();
                buf.extend(f.scope().iter().map(|v| assignment[v.0]));
                s += f.log_potential(&buf);
            }
            partial[depth + 1] = s;
            if depth + 1 < n && s != f64::NEG_INFINITY {
                depth += 1;
                assignment[depth] = 0;
                continue;
            }
            if depth + 1 == n {
                if pass == 0 {
                    if s > best {
                        best = s;
                        best_assignment.copy_from_slice(&assignment);
                    }
                } else if s != f64::NEG_INFINITY {
                    let w = (s - shift).exp();
                    total += w;
                    for (m, &x) in marginals.iter_mut().zip(&assignment) {
                        m[x] += w;
                    }
                }
            }
            // Advance to the next assignment, backtracking as needed.
            loop {
                assignment[depth] += 1;
                if assignment[depth] < cards[depth] {
                    break;
                }
                if depth == 0 {
                    break;
                }
                depth -= 1;
            }
            if depth == 0 && assignment[0] >= cards[0] {
                break;
            }
        }
    }
    if best == f64::NEG_INFINITY {
        return Err(Error::NotApplicable {
            method: "brute force",
            reason: "every assignment has probability zero".into(),
        });
    }
    for m in &mut marginals {
        m.iter_mut().for_each(|x| *x /= total);
    }
    Ok(ExactSolution {
        map: best_assignment,
        map_log_score: best,
        log_partition: best + total.ln(),
        marginals,
    })
}
