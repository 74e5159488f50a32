//! Sequential schedule: a fixed order, swept forward and then backward.

use super::{MessagePasser, Schedule};
use crate::error::{Error, Result};
use crate::graph::{EdgeId, FactorGraph, FactorId, VariableId};

/// What one step of a sequential order updates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SequentialUnit {
    /// Variable visits (see [`Visit::Variable`](super::Visit::Variable)).
    Variables(Vec<VariableId>),
    /// Factor updates.
    Factors(Vec<FactorId>),
    /// Single factor-to-variable message updates.
    Edges(Vec<EdgeId>),
}

/// Updates in a given order, then (for variable and factor orders, by default) in the
/// reverse order.
///
/// Without an explicit order ([`Sequential::default`]) the schedule is the two-pass
/// edge order of [`two_pass_edges`]: every factor-to-variable message is computed once
/// per iteration, leaves to roots and then back, so on a forest (a chain in particular:
/// a forward-backward sweep) the first iteration is exact and the second confirms it.
/// On loopy graphs the same order, taken from a breadth-first spanning structure, is a
/// good fixed order.
#[derive(Clone, Debug)]
pub struct Sequential {
    order: Option<SequentialUnit>,
    backward: bool,
}

impl Default for Sequential {
    fn default() -> Self {
        Self {
            order: None,
            backward: true,
        }
    }
}

impl Sequential {
    /// Visits variables in this order (then backwards).
    pub fn variables(order: Vec<VariableId>) -> Self {
        Self {
            order: Some(SequentialUnit::Variables(order)),
            backward: true,
        }
    }

    /// Updates factors in this order (then backwards).
    pub fn factors(order: Vec<FactorId>) -> Self {
        Self {
            order: Some(SequentialUnit::Factors(order)),
            backward: true,
        }
    }

    /// Updates single messages in this order (no automatic backward sweep).
    pub fn edges(order: Vec<EdgeId>) -> Self {
        Self {
            order: Some(SequentialUnit::Edges(order)),
            backward: false,
        }
    }

    /// Whether each iteration also sweeps the order backwards (default true for
    /// variable and factor orders, false for edge orders).
    pub fn with_backward(mut self, backward: bool) -> Self {
        self.backward = backward;
        self
    }

    fn visit(passer: &mut dyn MessagePasser, unit: &SequentialUnit, k: usize) {
        match unit {
            SequentialUnit::Variables(o) => passer.visit_variable(o[k]),
            SequentialUnit::Factors(o) => passer.update_factor(o[k]),
            SequentialUnit::Edges(o) => passer.update_edge(o[k]),
        }
    }
}

impl Schedule for Sequential {
    fn name(&self) -> &str {
        "sequential"
    }

    fn prepare(&mut self, graph: &FactorGraph) -> Result<()> {
        match &self.order {
            None => {
                self.order = Some(SequentialUnit::Edges(two_pass_edges(graph)));
                self.backward = false;
            }
            Some(SequentialUnit::Variables(o)) => check_order(
                o.iter().map(|v| v.0),
                graph.num_variables(),
                "variable indices of the graph",
            )?,
            Some(SequentialUnit::Factors(o)) => check_order(
                o.iter().map(|a| a.0),
                graph.num_factors(),
                "factor indices of the graph",
            )?,
            Some(SequentialUnit::Edges(o)) => check_order(
                o.iter().map(|e| e.0),
                graph.num_edges(),
                "edge indices of the graph",
            )?,
        }
        Ok(())
    }

    fn iteration(&mut self, passer: &mut dyn MessagePasser) -> Option<f64> {
        let Some(unit) = &self.order else {
            return None;
        };
        let n = match unit {
            SequentialUnit::Variables(o) => o.len(),
            SequentialUnit::Factors(o) => o.len(),
            SequentialUnit::Edges(o) => o.len(),
        };
        for k in 0..n {
            Self::visit(passer, unit, k);
        }
        if self.backward {
            for k in (0..n).rev() {
                Self::visit(passer, unit, k);
            }
        }
        None
    }
}

/// Fails on the first index of a sequential order that is not below `count`, the
/// number of graph items it indexes (`expected` says which).
fn check_order(
    mut indices: impl Iterator<Item = usize>,
    count: usize,
    expected: &'static str,
) -> Result<()> {
    match indices.find(|&i| i >= count) {
        Some(i) => Err(Error::InvalidParameter {
            name: "sequential order",
            value: i.to_string(),
            expected,
        }),
        None => Ok(()),
    }
}

/// The two-pass message order of a graph: root every connected component at its first
/// variable in breadth-first order ([`FactorGraph::bfs_order`]) and give every factor
/// the scope variable that comes first in that order as its parent. The upward pass
/// (variables in reverse breadth-first order) sends each factor's message to its
/// parent; the downward pass (breadth-first order) sends each factor's messages to its
/// other variables. Every edge appears exactly once.
pub fn two_pass_edges(graph: &FactorGraph) -> Vec<EdgeId> {
    let order = graph.bfs_order();
    let mut position = vec![0usize; graph.num_variables()];
    for (i, v) in order.iter().enumerate() {
        position[v.0] = i;
    }
    let parent = |a: FactorId| -> Option<VariableId> {
        graph
            .factor(a)
            .scope()
            .iter()
            .copied()
            .min_by_key(|v| position[v.0])
    };
    let mut edges = Vec::with_capacity(graph.num_edges());
    for &v in order.iter().rev() {
        for &e in graph.variable_edges(v) {
            if parent(graph.edge_factor(e)) == Some(v) {
                edges.push(e);
            }
        }
    }
    for &v in &order {
        for &e in graph.variable_edges(v) {
            let a = graph.edge_factor(e);
            if parent(a) == Some(v) {
                edges.extend(graph.factor_edges(a).map(EdgeId).filter(|&e2| e2 != e));
            }
        }
    }
    edges
}
