//! Message schedules: which messages are recomputed in which order.
//!
//! A [`Schedule`] is the *solver* of argmin's split: the engine
//! ([`BeliefPropagation`](crate::BeliefPropagation)) owns the messages and the
//! convergence test, and calls [`Schedule::iteration`] once per outer iteration with a
//! [`MessagePasser`], the smallest view of message passing a schedule needs: update one
//! edge, one factor, visit one variable, flood all factors in parallel, or compute and
//! commit candidate messages (residual BP). Every update unit raises the
//! before/after-visit hook of [`UpdateHook`](crate::UpdateHook), so hybrid continuous
//! nodes can refresh potentials between updates.
//!
//! Built in: [`Flooding`] (parallel over factors with rayon), [`Sequential`] (a fixed
//! order of variable visits or factor updates, forward then backward) and [`Residual`]
//! (largest message change first). `examples/custom_schedule.rs` writes a new one.

mod flooding;
mod residual;
mod sequential;

pub use flooding::Flooding;
pub use residual::Residual;
pub use sequential::{two_pass_edges, Sequential, SequentialUnit};

use crate::error::Result;
use crate::graph::{EdgeId, FactorGraph, FactorId, VariableId};

/// One unit of message passing, as reported to hooks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Visit {
    /// A variable visit: its local (single-variable) factors are recomputed, then every
    /// other factor it touches sends messages to that factor's other variables
    /// (Algorithm 1, lines 3-9 of the joint-model paper).
    Variable(VariableId),
    /// All outgoing messages of one factor.
    Factor(FactorId),
    /// One factor-to-variable message.
    Edge(EdgeId),
    /// One synchronous (flooding) update of every factor.
    Flood,
}

/// What a schedule can do to the messages. Implemented by the engine.
pub trait MessagePasser {
    /// The graph messages are passed on.
    fn graph(&self) -> &FactorGraph;

    /// Visits a variable (see [`Visit::Variable`]).
    fn visit_variable(&mut self, v: VariableId);

    /// Recomputes all outgoing messages of a factor.
    fn update_factor(&mut self, a: FactorId);

    /// Recomputes one factor-to-variable message.
    fn update_edge(&mut self, e: EdgeId);

    /// Recomputes every factor's messages from the current messages at once (a
    /// synchronous, parallel update).
    fn flood(&mut self);

    /// Computes the message of edge `e` from the current messages without committing
    /// it, stores it as the edge's candidate and returns its residual (largest change
    /// against the current message).
    fn compute_candidate(&mut self, e: EdgeId) -> f64;

    /// Commits the stored candidate of edge `e` (damped), raising the edge hooks.
    fn commit_candidate(&mut self, e: EdgeId);

    /// Commits the stored candidate of edge `e` like
    /// [`commit_candidate`](Self::commit_candidate) and returns the change that is
    /// still pending on the edge: the distance between its candidate and the message
    /// now committed. Without damping that is 0; with damping λ the committed message
    /// moved only part of the way, and a schedule that forgot the rest would freeze
    /// short of the fixed point. The candidate stays valid after the commit (a
    /// message never reads itself). The default recomputes the candidate.
    fn commit_candidate_pending(&mut self, e: EdgeId) -> f64 {
        self.commit_candidate(e);
        self.compute_candidate(e)
    }

    /// True once the run's time budget is spent; long iterations should stop early.
    fn out_of_time(&self) -> bool;

    /// The run's convergence tolerance on message changes.
    fn tolerance(&self) -> f64;

    /// Asks the run's hook to update its continuous values now (see
    /// [`UpdateHook::continuous_update`](crate::UpdateHook::continuous_update)); a
    /// schedule uses this to interleave continuous updates with message updates as it
    /// likes, e.g. every second visit as in the joint-model paper. Without a hook it
    /// does nothing.
    fn update_continuous(&mut self);
}

/// A message schedule. Schedules are `Send` so a run can move into a thread pool.
///
/// ```
/// use pgm_core::{BeliefPropagation, BpParams, ParamGuard, FactorGraph, MessagePasser, Mode, PottsFactor, Schedule, VariableId};
///
/// /// Visits the variables in reverse index order, once per iteration.
/// struct Backwards;
///
/// impl Schedule for Backwards {
///     fn name(&self) -> &str {
///         "backwards"
///     }
///     fn iteration(&mut self, passer: &mut dyn MessagePasser) -> Option<f64> {
///         for v in (0..passer.graph().num_variables()).rev() {
///             passer.visit_variable(VariableId(v));
///         }
///         None // let the engine use the largest message change
///     }
/// }
///
/// let mut g = FactorGraph::with_variables(&[2, 2, 2]).unwrap();
/// g.add_factor(PottsFactor::new(VariableId(0), VariableId(1), 2, 1.0, 0.0).unwrap()).unwrap();
/// g.add_factor(PottsFactor::new(VariableId(1), VariableId(2), 2, 1.0, 0.0).unwrap()).unwrap();
/// let r = BpParams::new(Mode::SumProduct).check_unwrap().run(&g, &mut Backwards).unwrap();
/// assert!(r.converged);
/// ```
pub trait Schedule: Send {
    /// A short name for reports.
    fn name(&self) -> &str;

    /// Called once before the first iteration of a run.
    fn prepare(&mut self, graph: &FactorGraph) -> Result<()> {
        let _ = graph;
        Ok(())
    }

    /// Performs one iteration. Returns `Some(residual)` when the schedule knows the
    /// fixed-point residual better than the engine's default (the largest change of a
    /// message updated in this iteration), as residual BP does.
    fn iteration(&mut self, passer: &mut dyn MessagePasser) -> Option<f64>;
}

/// The schedules the CLI and benches can choose by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScheduleKind {
    /// [`Flooding`].
    Flooding,
    /// [`Sequential`] in the two-pass edge order (exact in one iteration on trees).
    Sequential,
    /// [`Residual`].
    Residual,
}

impl ScheduleKind {
    /// A boxed schedule of this kind with default settings.
    pub fn build(self) -> Box<dyn Schedule> {
        match self {
            ScheduleKind::Flooding => Box::new(Flooding),
            ScheduleKind::Sequential => Box::new(Sequential::default()),
            ScheduleKind::Residual => Box::new(Residual::default()),
        }
    }
}

impl std::str::FromStr for ScheduleKind {
    type Err = crate::Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "flooding" | "parallel" => Ok(ScheduleKind::Flooding),
            "sequential" => Ok(ScheduleKind::Sequential),
            "residual" => Ok(ScheduleKind::Residual),
            other => Err(crate::Error::InvalidParameter {
                name: "schedule",
                value: other.to_string(),
                expected: "one of flooding, sequential, residual",
            }),
        }
    }
}

impl<S: Schedule + ?Sized> Schedule for Box<S> {
    fn name(&self) -> &str {
        (**self).name()
    }
    fn prepare(&mut self, graph: &FactorGraph) -> Result<()> {
        (**self).prepare(graph)
    }
    fn iteration(&mut self, passer: &mut dyn MessagePasser) -> Option<f64> {
        (**self).iteration(passer)
    }
}
