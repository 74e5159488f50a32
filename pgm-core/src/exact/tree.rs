//! Exact inference on factor-graph forests (factors of any arity) by two-pass
//! elimination: an upward pass from the leaves to each component's root, then MAP
//! back-tracking or a downward pass for marginals. Factors are enumerated through their
//! dense log-tables, independently of the loopy engine's message code.

use super::ExactSolution;
use crate::error::{Error, Result};
use crate::graph::{FactorGraph, VariableId};
use crate::logspace::{log_sum_exp, max};

#[derive(Clone, Copy, PartialEq)]
enum Agg {
    Max,
    Sum,
}

/// A rooted view of the forest: BFS order of variables and factors with parents.
struct Rooted {
    /// Variables in BFS order.
    var_order: Vec<usize>,
    /// Parent factor of each variable (None for roots).
    var_parent: Vec<Option<usize>>,
    /// Child factors of each variable.
    var_children: Vec<Vec<usize>>,
}

fn root(graph: &FactorGraph) -> Result<Rooted> {
    if !graph.is_forest() {
        return Err(Error::NotApplicable {
            method: "exact tree",
            reason: "the factor graph has a cycle".into(),
        });
    }
    let n = graph.num_variables();
    let var_order = graph.bfs_order();
    let mut seen = vec![false; n];
    let mut var_parent = vec![None; n];
    let mut factor_parent = vec![None; graph.num_factors()];
    let mut var_children = vec![Vec::new(); n];
    for v in &var_order {
        seen[v.0] = true;
        for &e in graph.variable_edges(*v) {
            let a = graph.edge_factor(e).0;
            if factor_parent[a].is_none() && var_parent[v.0] != Some(a) {
                factor_parent[a] = Some(v.0);
                var_children[v.0].push(a);
                for u in graph.factor(graph.edge_factor(e)).scope() {
                    if u != v && var_parent[u.0].is_none() && !seen[u.0] {
                        var_parent[u.0] = Some(a);
                    }
                }
            }
        }
    }
    Ok(Rooted {
        var_order: var_order.into_iter().map(|v| v.0).collect(),
        var_parent,
        var_children,
    })
}

/// Aggregates `table + Σ_j msgs[j][x_j]` over all positions but `target`.
fn factor_to_var(
    shape: &[usize],
    table: &[f64],
    msgs: &[Option<&[f64]>],
    target: usize,
    agg: Agg,
) -> Vec<f64> {
    let mut terms: Vec<Vec<f64>> = vec![Vec::new(); shape[target]];
    let mut states = vec![0usize; shape.len()];
    for &t in table {
        let mut v = t;
        for (j, m) in msgs.iter().enumerate() {
            if let (true, Some(m)) = (j != target, m) {
                v += m[states[j]];
            }
        }
        terms[states[target]].push(v);
        crate::factor::increment(&mut states, shape);
    }
    terms
        .iter()
        .map(|t| match agg {
            Agg::Max => max(t),
            Agg::Sum => log_sum_exp(t),
        })
        .collect()
}

/// Upward messages: `up_var[v]` (variable to its parent factor) and `up_factor[a]`
/// (factor to its parent variable).
fn upward(
    graph: &FactorGraph,
    r: &Rooted,
    agg: Agg,
    tables: &[Vec<f64>],
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mut up_var: Vec<Vec<f64>> = graph
        .cardinalities()
        .iter()
        .map(|&k| vec![0.0; k])
        .collect();
    let mut up_factor: Vec<Vec<f64>> = vec![Vec::new(); graph.num_factors()];
    for &v in r.var_order.iter().rev() {
        let mut m = vec![0.0; graph.cardinality(VariableId(v))];
        for &a in &r.var_children[v] {
            let f = graph.factor(crate::FactorId(a));
            let scope = f.scope();
            let target = scope.iter().position(|u| u.0 == v).unwrap_or(0);
            let msgs: Vec<Option<&[f64]>> = scope
                .iter()
                .map(|u| (u.0 != v).then(|| up_var[u.0].as_slice()))
                .collect();
            let msg = factor_to_var(f.shape(), &tables[a], &msgs, target, agg);
            for (x, y) in m.iter_mut().zip(&msg) {
                *x += y;
            }
            up_factor[a] = msg;
        }
        up_var[v] = m;
    }
    (up_var, up_factor)
}

fn constant(graph: &FactorGraph) -> f64 {
    graph
        .factors()
        .filter(|f| f.scope().is_empty())
        .map(|f| f.log_potential(&[]))
        .sum()
}

/// Exact MAP on a forest: the assignment and its log-score.
pub fn tree_map(graph: &FactorGraph) -> Result<(Vec<usize>, f64)> {
    let r = root(graph)?;
    let tables: Vec<Vec<f64>> = graph.factors().map(|f| f.log_table()).collect();
    let (up_var, _) = upward(graph, &r, Agg::Max, &tables);
    let n = graph.num_variables();
    let mut assignment: Vec<Option<usize>> = vec![None; n];
    for &v in &r.var_order {
        if assignment[v].is_none() {
            // A root: its upward message is its exact max-marginal.
            assignment[v] = Some(crate::bp::first_argmax(&up_var[v]));
        }
        let xv = assignment[v].unwrap_or(0);
        for &a in &r.var_children[v] {
            // Choose the best joint state of the child variables given x_v.
            let f = graph.factor(crate::FactorId(a));
            let scope = f.scope();
            let mut states = vec![0usize; scope.len()];
            let mut best = f64::NEG_INFINITY;
            let mut best_states: Option<Vec<usize>> = None;
            for &t in &tables[a] {
                let ok = scope.iter().zip(&states).all(|(u, &s)| u.0 != v || s == xv);
                if ok {
                    let mut s = t;
                    for (u, &x) in scope.iter().zip(&states) {
                        if u.0 != v {
                            s += up_var[u.0][x];
                        }
                    }
                    if s > best || best_states.is_none() {
                        best = s;
                        best_states = Some(states.clone());
                    }
                }
                crate::factor::increment(&mut states, f.shape());
            }
            if let Some(bs) = best_states {
                for (u, x) in scope.iter().zip(bs) {
                    if u.0 != v {
                        assignment[u.0] = Some(x);
                    }
                }
            }
        }
    }
    let assignment: Vec<usize> = assignment.into_iter().map(|x| x.unwrap_or(0)).collect();
    let score = graph.log_score_unchecked(&assignment);
    if score == f64::NEG_INFINITY {
        return Err(Error::NotApplicable {
            method: "exact tree",
            reason: "every assignment has probability zero".into(),
        });
    }
    Ok((assignment, score))
}

/// Exact marginals, log Z and MAP on a forest.
pub fn tree_marginals(graph: &FactorGraph) -> Result<ExactSolution> {
    let (map, map_log_score) = tree_map(graph)?;
    let r = root(graph)?;
    let tables: Vec<Vec<f64>> = graph.factors().map(|f| f.log_table()).collect();
    let (up_var, up_factor) = upward(graph, &r, Agg::Sum, &tables);
    let n = graph.num_variables();
    // down_var[v]: message into v from its parent factor (0 for roots).
    let mut down_var: Vec<Vec<f64>> = graph
        .cardinalities()
        .iter()
        .map(|&k| vec![0.0; k])
        .collect();
    let mut log_partition = constant(graph);
    for &v in &r.var_order {
        if r.var_parent[v].is_none() {
            log_partition += log_sum_exp(&up_var[v]);
        }
        for &a in &r.var_children[v] {
            // Message from v into child factor a: everything v hears except from a.
            let mut into_a = down_var[v].clone();
            for &c in &r.var_children[v] {
                if c != a {
                    for (o, m) in into_a.iter_mut().zip(&up_factor[c]) {
                        *o += m;
                    }
                }
            }
            let f = graph.factor(crate::FactorId(a));
            let scope = f.scope();
            for (target, u) in scope.iter().enumerate() {
                if u.0 == v {
                    continue;
                }
                let msgs: Vec<Option<&[f64]>> = scope
                    .iter()
                    .map(|w| {
                        if w.0 == v {
                            Some(into_a.as_slice())
                        } else {
                            Some(up_var[w.0].as_slice())
                        }
                    })
                    .collect();
                down_var[u.0] = factor_to_var(f.shape(), &tables[a], &msgs, target, Agg::Sum);
            }
        }
    }
    let marginals = (0..n)
        .map(|v| {
            let b: Vec<f64> = down_var[v]
                .iter()
                .zip(&up_var[v])
                .map(|(d, u)| d + u)
                .collect();
            crate::logspace::to_probabilities(&b)
        })
        .collect();
    Ok(ExactSolution {
        map,
        map_log_score,
        log_partition,
        marginals,
    })
}
