//! Observers: a per-iteration callback that sees how a run progresses and may stop it,
//! in the spirit of argmin's `Observe` trait.
//!
//! Hooks ([`UpdateHook`](crate::UpdateHook)) sit *inside* an iteration, between single
//! message updates, and may change potentials; observers sit *between* iterations and
//! only look. Belief propagation reports a [`BpProgress`] (iteration, fixed-point
//! residual, contradictions, elapsed time) to an `Observe<BpProgress>` with every
//! schedule ([`BpRun::observer`](crate::BpRun::observer));
//! TRW-S reports a [`TrwsProgress`] (iteration, dual bound, primal log-score, gap) to an
//! `Observe<TrwsProgress>` ([`Trws::run_observed`](crate::trws::Trws::run_observed)).
//!
//! Closures `FnMut(&P) -> ControlFlow<()>` are observers, `()` observes nothing, and
//! [`History`] records every report.
//!
//! ```
//! use std::ops::ControlFlow;
//! use pgm_core::observer::BpProgress;
//! use pgm_core::{BeliefPropagation, BpParams, ParamGuard, FactorGraph, Flooding, Mode, PottsFactor, TableFactor, VariableId};
//!
//! // A frustrated triangle: flooding max-product keeps changing its messages.
//! let mut g = FactorGraph::with_variables(&[2, 2, 2]).unwrap();
//! g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, 0.1]).unwrap()).unwrap();
//! for (a, b) in [(0, 1), (1, 2), (0, 2)] {
//!     g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 2, 0.0, 1.0).unwrap()).unwrap();
//! }
//! let mut residuals = Vec::new();
//! // Stop after five iterations, whatever the residual.
//! let mut observer = |p: &BpProgress| {
//!     residuals.push(p.residual);
//!     if p.iteration == 5 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
//! };
//! let bp = BpParams::new(Mode::MaxProduct).max_iterations(100).check_unwrap();
//! let result = bp.on(&g).observer(&mut observer).run(&mut Flooding).unwrap();
//! assert_eq!(result.iterations, 5);
//! assert!(result.stopped_by_observer && !result.converged);
//! assert_eq!(residuals.len(), 5);
//! ```

use std::ops::ControlFlow;
use std::time::Duration;

/// Sees one report `P` after every iteration of a run; return
/// `ControlFlow::Break(())` to stop the run after this iteration (its result then
/// says [`stopped_by_observer`](crate::BpResult::stopped_by_observer)).
pub trait Observe<P> {
    /// Sees one iteration's report.
    fn observe(&mut self, progress: &P) -> ControlFlow<()>;
}

impl<P, F: FnMut(&P) -> ControlFlow<()>> Observe<P> for F {
    fn observe(&mut self, progress: &P) -> ControlFlow<()> {
        self(progress)
    }
}

impl<P> Observe<P> for () {
    fn observe(&mut self, _: &P) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

/// An observer that keeps every report and never stops a run.
///
/// ```
/// use pgm_core::observer::{BpProgress, History};
/// use pgm_core::{BeliefPropagation, BpParams, ParamGuard, FactorGraph, Mode, PottsFactor, Sequential, VariableId};
/// let mut g = FactorGraph::with_variables(&[3, 3]).unwrap();
/// g.add_factor(PottsFactor::new(VariableId(0), VariableId(1), 3, 1.0, 0.0).unwrap()).unwrap();
/// let mut history = History::<BpProgress>::default();
/// let r = BpParams::new(Mode::SumProduct).check_unwrap()
///     .on(&g).observer(&mut history).run(&mut Sequential::default())
///     .unwrap();
/// assert_eq!(history.0.len(), r.iterations);
/// assert_eq!(history.0.last().unwrap().residual, r.residual);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct History<P>(pub Vec<P>);

impl<P> Default for History<P> {
    fn default() -> Self {
        History(Vec::new())
    }
}

impl<P: Clone> Observe<P> for History<P> {
    fn observe(&mut self, progress: &P) -> ControlFlow<()> {
        self.0.push(progress.clone());
        ControlFlow::Continue(())
    }
}

/// What belief propagation reports after each iteration, with every schedule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BpProgress {
    /// Iterations completed (1 after the first).
    pub iteration: usize,
    /// The iteration's fixed-point residual: the largest *undamped* change
    /// `max |new − old|` (log space, normalised messages) of a message updated in it,
    /// or the schedule's own figure (residual BP: the largest pending change).
    pub residual: f64,
    /// Whether the residual is within the run's tolerance (and the hook, if any,
    /// reported its state stable): the run stops after this report.
    pub converged: bool,
    /// Message updates so far whose every entry was −∞ (contradictory evidence).
    pub contradictions: usize,
    /// Wall-clock time since the run started.
    pub elapsed: Duration,
}

/// What TRW-S reports after each iteration (one forward and one backward pass).
///
/// The scores are log-scores (sums of log-potentials, to be maximised): `bound` is an
/// upper bound on the best log-score of any assignment (the value of the LP dual at
/// the current reparametrisation), `log_score` the best score of an assignment found
/// so far, and `gap = bound − log_score ≥ 0`: the best assignment is at most `gap`
/// below the optimum. A gap of 0 certifies it optimal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrwsProgress {
    /// Iterations completed (1 after the first).
    pub iteration: usize,
    /// Upper bound on the best log-score after this iteration; never increases.
    pub bound: f64,
    /// Log-score of the assignment decoded in this iteration.
    pub iteration_log_score: f64,
    /// Best log-score found so far (the result's assignment).
    pub log_score: f64,
    /// `bound − log_score` (0 when both are −∞: the model has no feasible assignment).
    pub gap: f64,
    /// Wall-clock time since the run started.
    pub elapsed: Duration,
}
