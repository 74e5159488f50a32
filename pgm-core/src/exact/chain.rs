//! Exact inference on chains: Viterbi (MAP) and forward-backward (marginals, log Z).
//!
//! A chain here is a connected graph of unary and pairwise factors whose pairwise
//! structure is a simple path (several factors on the same pair are summed).

use super::ExactSolution;
use crate::error::{Error, Result};
use crate::graph::{FactorGraph, VariableId};
use crate::logspace::log_sum_exp;

/// The variables of a chain graph from one end to the other (starting at the end with
/// the lower index), or an error saying why the graph is not a chain.
pub fn chain_order(graph: &FactorGraph) -> Result<Vec<VariableId>> {
    let n = graph.num_variables();
    let not_chain = |reason: String| Error::NotApplicable {
        method: "exact chain",
        reason,
    };
    if n == 0 {
        return Ok(Vec::new());
    }
    let mut neighbours: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (a, f) in graph.factors().enumerate() {
        match f.scope() {
            [] | [_] => {}
            [u, v] => {
                if !neighbours[u.0].contains(&v.0) {
                    neighbours[u.0].push(v.0);
                    neighbours[v.0].push(u.0);
                }
            }
            s => return Err(not_chain(format!("factor {a} has arity {}", s.len()))),
        }
    }
    if let Some(v) = neighbours.iter().position(|nb| nb.len() > 2) {
        return Err(not_chain(format!(
            "variable {v} has {} neighbours",
            neighbours[v].len()
        )));
    }
    let start = (0..n)
        .find(|&v| neighbours[v].len() <= 1)
        .ok_or_else(|| not_chain("the pairwise factors form a cycle".into()))?;
    let mut order = vec![VariableId(start)];
    let mut prev = usize::MAX;
    let mut cur = start;
    while let Some(&next) = neighbours[cur].iter().find(|&&u| u != prev) {
        order.push(VariableId(next));
        prev = cur;
        cur = next;
        if order.len() > n {
            return Err(not_chain("the pairwise factors form a cycle".into()));
        }
    }
    if order.len() != n {
        return Err(not_chain(format!(
            "the graph is not connected: the path from variable {start} reaches {} of {n} variables",
            order.len()
        )));
    }
    Ok(order)
}

/// Unary log-potentials per chain position and pairwise tables between consecutive
/// positions (`pair[i][x * k_{i+1} + y]`), plus the constant of scope-less factors.
pub(crate) struct ChainTables {
    pub(crate) cards: Vec<usize>,
    pub(crate) unary: Vec<Vec<f64>>,
    pub(crate) pair: Vec<Vec<f64>>,
    pub(crate) constant: f64,
}

/// The chain's tables in the order `order` (which must come from [`chain_order`]).
pub(crate) fn tables(graph: &FactorGraph, order: &[VariableId]) -> ChainTables {
    let n = order.len();
    let mut position = vec![0usize; graph.num_variables()];
    for (i, v) in order.iter().enumerate() {
        position[v.0] = i;
    }
    let cards: Vec<usize> = order.iter().map(|&v| graph.cardinality(v)).collect();
    let mut unary: Vec<Vec<f64>> = cards.iter().map(|&k| vec![0.0; k]).collect();
    let mut pair: Vec<Vec<f64>> = (0..n.saturating_sub(1))
        .map(|i| vec![0.0; cards[i] * cards[i + 1]])
        .collect();
    let mut constant = 0.0;
    for f in graph.factors() {
        match f.scope() {
            [] => constant += f.log_potential(&[]),
            [v] => {
                let i = position[v.0];
                for (x, u) in unary[i].iter_mut().enumerate() {
                    *u += f.log_potential(&[x]);
                }
            }
            [u, v] => {
                let (pu, pv) = (position[u.0], position[v.0]);
                let (i, forward) = if pu < pv { (pu, true) } else { (pv, false) };
                let k1 = cards[i + 1];
                for x in 0..cards[i] {
                    for y in 0..k1 {
                        let s = if forward { [x, y] } else { [y, x] };
                        pair[i][x * k1 + y] += f.log_potential(&s);
                    }
                }
            }
            _ => unreachable!("chain_order rejects higher arities"),
        }
    }
    ChainTables {
        cards,
        unary,
        pair,
        constant,
    }
}

/// Forward log-messages `alpha[i][x] = log Σ_{x_<i} exp(score of positions ≤ i)`,
/// unary terms included.
pub(crate) fn forward(t: &ChainTables) -> Vec<Vec<f64>> {
    let n = t.cards.len();
    let mut alpha: Vec<Vec<f64>> = Vec::with_capacity(n);
    if n == 0 {
        return alpha;
    }
    alpha.push(t.unary[0].clone());
    for i in 1..n {
        let (k0, k1) = (t.cards[i - 1], t.cards[i]);
        let mut next = vec![0.0; k1];
        let mut terms = vec![0.0; k0];
        for (y, value) in next.iter_mut().enumerate() {
            for (x, term) in terms.iter_mut().enumerate() {
                *term = alpha[i - 1][x] + t.pair[i - 1][x * k1 + y];
            }
            *value = log_sum_exp(&terms) + t.unary[i][y];
        }
        alpha.push(next);
    }
    alpha
}

fn first_argmax(v: &[f64]) -> usize {
    crate::bp::first_argmax(v)
}

/// Exact MAP of a chain by the Viterbi recursion (ties to the lowest state at each
/// back-pointer). Returns the assignment in model variable order and its log-score.
pub fn viterbi(graph: &FactorGraph) -> Result<(Vec<usize>, f64)> {
    let order = chain_order(graph)?;
    let t = tables(graph, &order);
    let n = order.len();
    if n == 0 {
        return Ok((Vec::new(), t.constant));
    }
    let mut delta = t.unary[0].clone();
    let mut back: Vec<Vec<usize>> = Vec::with_capacity(n);
    back.push(Vec::new());
    for i in 1..n {
        let k1 = t.cards[i];
        let mut next = vec![f64::NEG_INFINITY; k1];
        let mut ptr = vec![0usize; k1];
        for (y, (best, back_y)) in next.iter_mut().zip(ptr.iter_mut()).enumerate() {
            for (x, d) in delta.iter().enumerate() {
                let s = d + t.pair[i - 1][x * k1 + y];
                if s > *best {
                    *best = s;
                    *back_y = x;
                }
            }
            *best += t.unary[i][y];
        }
        delta = next;
        back.push(ptr);
    }
    let mut x = first_argmax(&delta);
    let best = delta[x] + t.constant;
    if best == f64::NEG_INFINITY {
        return Err(Error::NotApplicable {
            method: "viterbi",
            reason: "every assignment has probability zero".into(),
        });
    }
    let mut assignment = vec![0usize; graph.num_variables()];
    for i in (0..n).rev() {
        assignment[order[i].0] = x;
        if i > 0 {
            x = back[i][x];
        }
    }
    Ok((assignment, best))
}

/// Exact marginals and log Z of a chain by forward-backward in log space. The MAP
/// fields of the result come from [`viterbi`].
pub fn forward_backward(graph: &FactorGraph) -> Result<ExactSolution> {
    let (map, map_log_score) = viterbi(graph)?;
    let order = chain_order(graph)?;
    let t = tables(graph, &order);
    let n = order.len();
    if n == 0 {
        return Ok(ExactSolution {
            map,
            map_log_score,
            log_partition: t.constant,
            marginals: Vec::new(),
        });
    }
    let alpha = forward(&t);
    let mut beta: Vec<Vec<f64>> = t.cards.iter().map(|&k| vec![0.0; k]).collect();
    for i in (0..n.saturating_sub(1)).rev() {
        let (k0, k1) = (t.cards[i], t.cards[i + 1]);
        let mut terms = vec![0.0; k1];
        for x in 0..k0 {
            for y in 0..k1 {
                terms[y] = t.pair[i][x * k1 + y] + t.unary[i + 1][y] + beta[i + 1][y];
            }
            beta[i][x] = log_sum_exp(&terms);
        }
    }
    let log_partition = log_sum_exp(&alpha[n - 1]) + t.constant;
    let mut marginals: Vec<Vec<f64>> = graph
        .cardinalities()
        .iter()
        .map(|&k| vec![0.0; k])
        .collect();
    for i in 0..n {
        let joint: Vec<f64> = alpha[i].iter().zip(&beta[i]).map(|(a, b)| a + b).collect();
        let z = log_sum_exp(&joint);
        marginals[order[i].0] = joint.iter().map(|j| (j - z).exp()).collect();
    }
    Ok(ExactSolution {
        map,
        map_log_score,
        log_partition,
        marginals,
    })
}
