//! Hooks between message updates: the extension point for hybrid continuous nodes.
//!
//! [`BeliefPropagation::with_hook`](crate::BeliefPropagation::with_hook) calls
//! an [`UpdateHook`] before and after every update unit a schedule performs (variable
//! visit, factor update, edge update, flood) and after every iteration. The hook may
//! refresh factor potentials through [`Potentials`] (same scope and shape only, so the
//! message layout stays valid) and read the current messages and beliefs.

use crate::bp::Messages;
use crate::error::Result;
use crate::factor::Factor;
use crate::graph::{FactorGraph, FactorId};
use crate::schedule::Visit;

/// Mutable access to a graph's potentials, but not to its structure.
#[derive(Debug)]
pub struct Potentials<'a> {
    graph: &'a mut FactorGraph,
}

impl<'a> Potentials<'a> {
    pub(crate) fn new(graph: &'a mut FactorGraph) -> Self {
        Self { graph }
    }

    /// The graph, read-only.
    pub fn graph(&self) -> &FactorGraph {
        self.graph
    }

    /// Replaces a factor by one with the same scope and shape.
    pub fn replace(&mut self, id: FactorId, factor: Box<dyn Factor>) -> Result<()> {
        self.graph.replace_factor(id, factor)
    }

    /// Mutable access to a factor for in-place refreshes (downcast with
    /// [`Factor::as_any_mut`]). Scope and shape must not change.
    pub fn factor_mut(&mut self, id: FactorId) -> &mut dyn Factor {
        self.graph.factor_mut(id)
    }
}

/// Called by the engine between updates. All methods default to doing nothing.
///
/// ```
/// use pgm_core::{BeliefPropagation, BpParams, ParamGuard, FactorGraph, Messages, Mode, Potentials, Sequential, TableFactor, UpdateHook, VariableId, Visit};
///
/// /// Counts the variable visits of a run.
/// #[derive(Default)]
/// struct CountVisits(usize);
///
/// impl UpdateHook for CountVisits {
///     fn after_visit(&mut self, visit: Visit, _: &mut Potentials<'_>, _: &Messages) {
///         if let Visit::Variable(_) = visit {
///             self.0 += 1;
///         }
///     }
/// }
///
/// let mut g = FactorGraph::with_variables(&[2, 2]).unwrap();
/// g.add_factor(TableFactor::new(vec![VariableId(0), VariableId(1)], vec![2, 2], vec![0.0, 1.0, 1.0, 0.0]).unwrap()).unwrap();
/// let mut hook = CountVisits::default();
/// let mut schedule = Sequential::variables(vec![VariableId(0), VariableId(1)]);
/// let r = BpParams::new(Mode::MaxProduct).check_unwrap().with_hook(&mut g, &mut hook).run(&mut schedule).unwrap();
/// // Forward and backward over two variables, once per iteration.
/// assert_eq!(hook.0, 4 * r.iterations);
/// ```
pub trait UpdateHook {
    /// Before an update unit.
    fn before_visit(&mut self, visit: Visit, potentials: &mut Potentials<'_>, messages: &Messages) {
        let _ = (visit, potentials, messages);
    }

    /// After an update unit.
    fn after_visit(&mut self, visit: Visit, potentials: &mut Potentials<'_>, messages: &Messages) {
        let _ = (visit, potentials, messages);
    }

    /// The schedule asked for a continuous update between two visits
    /// ([`MessagePasser::update_continuous`](crate::MessagePasser::update_continuous)).
    fn continuous_update(&mut self, potentials: &mut Potentials<'_>, messages: &Messages) {
        let _ = (potentials, messages);
    }

    /// After every iteration. Returns whether the hook's own state (for example the
    /// continuous values it maintains) is stable; the run converges only when both the
    /// messages and the hook are stable.
    fn after_iteration(
        &mut self,
        iteration: usize,
        potentials: &mut Potentials<'_>,
        messages: &Messages,
    ) -> bool {
        let _ = (iteration, potentials, messages);
        true
    }
}
