//! Sequential schedule: a fixed order, swept forward and then backward.

use super::{MessagePasser, Schedule};
use crate::error::{Error, Result};
use crate::graph::{FactorGraph, FactorId, VariableId};

/// What one step of a sequential order updates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SequentialUnit {
    /// Variable visits (see [`Visit::Variable`](super::Visit::Variable)).
    Variables(Vec<VariableId>),
    /// Factor updates.
    Factors(Vec<FactorId>),
}

/// Updates in a given order, then (by default) in the reverse order. On a chain in
/// variable order, or a tree in breadth-first order, one forward-backward iteration
/// gives exact messages. Without an explicit order, the reverse of the graph's breadth-first
/// variable order ([`FactorGraph::bfs_order`]) is used: leaves to roots, then back.
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

    /// Whether each iteration also sweeps the order backwards (default true).
    pub fn with_backward(mut self, backward: bool) -> Self {
        self.backward = backward;
        self
    }

    fn visit(passer: &mut dyn MessagePasser, unit: &SequentialUnit, k: usize) {
        match unit {
            SequentialUnit::Variables(o) => passer.visit_variable(o[k]),
            SequentialUnit::Factors(o) => passer.update_factor(o[k]),
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
                // Leaves first, so the forward sweep carries messages towards the roots
                // and the backward sweep carries them back out.
                let mut order = graph.bfs_order();
                order.reverse();
                self.order = Some(SequentialUnit::Variables(order));
            }
            Some(SequentialUnit::Variables(o)) => {
                if let Some(v) = o.iter().find(|v| v.0 >= graph.num_variables()) {
                    return Err(Error::InvalidParameter {
                        name: "sequential order",
                        value: v.0.to_string(),
                        expected: "variable indices of the graph",
                    });
                }
            }
            Some(SequentialUnit::Factors(o)) => {
                if let Some(a) = o.iter().find(|a| a.0 >= graph.num_factors()) {
                    return Err(Error::InvalidParameter {
                        name: "sequential order",
                        value: a.0.to_string(),
                        expected: "factor indices of the graph",
                    });
                }
            }
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
