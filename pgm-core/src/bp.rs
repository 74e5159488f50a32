//! The loopy belief-propagation engine, in log space, for max-product and sum-product.
//!
//! Messages are factor-to-variable log-vectors, normalised after every update (maximum
//! 0 for max-product, log-sum-exp 0 for sum-product). Variable-to-factor messages are
//! computed on demand as leave-one-out sums, so −∞ entries (hard zeros) never meet a
//! subtraction and never produce NaN. Damping mixes the new and the old message in log
//! space, `(1 − λ) new + λ old`; the convergence test uses the *undamped* change
//! `|new − old|`, the fixed-point residual, so a heavily damped run is not declared
//! converged merely because each step moves little.
//!
//! ```
//! use pgm_core::{BeliefPropagation, BpParams, ParamGuard, FactorGraph, Mode, PottsFactor, Sequential, TableFactor, VariableId};
//! let mut g = FactorGraph::with_variables(&[2, 2, 2]).unwrap();
//! g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, 2.0]).unwrap()).unwrap();
//! g.add_factor(PottsFactor::new(VariableId(0), VariableId(1), 2, 1.0, 0.0).unwrap()).unwrap();
//! g.add_factor(PottsFactor::new(VariableId(1), VariableId(2), 2, 1.0, 0.0).unwrap()).unwrap();
//! let result = BpParams::new(Mode::MaxProduct).check_unwrap().run(&g, &mut Sequential::default()).unwrap();
//! assert_eq!(result.assignment, vec![1, 1, 1]);
//! assert!(result.converged);
//! ```

use crate::error::{Error, Result};
use crate::factor::{Incoming, Mode};
use crate::graph::{EdgeId, FactorGraph, FactorId, VariableId};
use crate::hook::{Potentials, UpdateHook};
use crate::logspace::{self, Normalisation};
use crate::observer::{BpProgress, Observe};
use crate::param::{InvalidParameter, ParamGuard};
use crate::schedule::{MessagePasser, Schedule, Visit};
use crate::support::{self, Method, Support, ZeroDecoding, ZeroProbability};
use rayon::prelude::*;

mod plan;
use plan::FloodPlan;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

/// Factor-to-variable messages of one graph, normalised; the state of a run, returned
/// in its result and accepted back for a warm start.
#[derive(Clone, Debug, PartialEq)]
pub struct Messages {
    values: Vec<f64>,
    num_edges: usize,
}

impl Messages {
    /// Uniform messages for a graph.
    pub fn uniform(graph: &FactorGraph, mode: Mode) -> Self {
        let mut values = vec![0.0; graph.message_len()];
        if mode == Mode::SumProduct {
            for e in 0..graph.num_edges() {
                let r = graph.message_range(EdgeId(e));
                let u = -(r.len() as f64).ln();
                values[r].iter_mut().for_each(|x| *x = u);
            }
        }
        Self {
            values,
            num_edges: graph.num_edges(),
        }
    }

    fn check_layout(&self, graph: &FactorGraph) -> Result<()> {
        if self.values.len() != graph.message_len() || self.num_edges != graph.num_edges() {
            return Err(Error::InvalidParameter {
                name: "warm-start messages",
                value: format!("{} edges, {} entries", self.num_edges, self.values.len()),
                expected: "messages from a graph with the same structure",
            });
        }
        Ok(())
    }

    /// The message of edge `e` (factor to variable).
    pub fn message(&self, graph: &FactorGraph, e: EdgeId) -> &[f64] {
        &self.values[graph.message_range(e)]
    }

    /// The unnormalised log-belief of a variable: the sum of its incoming messages.
    pub fn log_belief(&self, graph: &FactorGraph, v: VariableId) -> Vec<f64> {
        let mut b = vec![0.0; graph.cardinality(v)];
        for &e in graph.variable_edges(v) {
            for (x, m) in b.iter_mut().zip(self.message(graph, e)) {
                *x += m;
            }
        }
        b
    }

    /// The belief of a variable as probabilities summing to one (uniform when its
    /// incoming messages contradict each other).
    pub fn belief(&self, graph: &FactorGraph, v: VariableId) -> Vec<f64> {
        logspace::to_probabilities(&self.log_belief(graph, v))
    }

    /// The state with the largest belief (lowest index among ties).
    pub fn argmax(&self, graph: &FactorGraph, v: VariableId) -> usize {
        first_argmax(&self.log_belief(graph, v))
    }

    /// Overwrites the message of edge `e` (which must be normalised).
    pub(crate) fn set_message(&mut self, graph: &FactorGraph, e: EdgeId, message: &[f64]) {
        self.values[graph.message_range(e)].copy_from_slice(message);
    }

    /// The raw buffer (for advanced users and tests).
    pub fn as_slice(&self) -> &[f64] {
        &self.values
    }
}

/// The outcome of a run.
#[derive(Clone, Debug)]
pub struct BpResult {
    /// The semiring used.
    pub mode: Mode,
    /// MAP assignment (max-product, decoded consistently: see [`decode_map`]) or the
    /// assignment of most probable states (sum-product). From [`BpRun::run`], a
    /// max-product assignment always has positive probability (see
    /// [`zero_decoding`](Self::zero_decoding)).
    pub assignment: Vec<usize>,
    /// Log-score of `assignment` (sum of log-potentials).
    pub log_score: f64,
    /// Normalised beliefs (probabilities) per variable: marginals (sum-product) or
    /// max-marginals rescaled to sum to one (max-product).
    pub beliefs: Vec<Vec<f64>>,
    /// Iterations performed.
    pub iterations: usize,
    /// True when the last iteration's residual was within tolerance (and the hook, if
    /// any, reported its state stable).
    pub converged: bool,
    /// The last iteration's fixed-point residual (largest undamped message change).
    pub residual: f64,
    /// True when the run stopped because its time budget was spent.
    pub out_of_time: bool,
    /// True when an observer stopped the run (see [`BpRun::observer`]).
    pub stopped_by_observer: bool,
    /// Number of message updates whose every entry was −∞ (contradictory evidence);
    /// such messages are replaced by uniform ones.
    pub contradictions: usize,
    /// The final messages, for a warm start.
    pub messages: Messages,
    /// Max-product only: `Some` when the consistent decoding ([`decode_map`]) had
    /// probability 0 although the model has assignments of positive probability
    /// (loopy max-product can decode one that violates a hard zero). Then
    /// `assignment` is not that decoding but the first assignment of positive
    /// probability found by [`support::positive_assignment_conditioned`] on the run's
    /// messages (states tried in the order the decoding would take them, conditioned
    /// on the variables already decided), then improved by
    /// [`support::improve_locally`]: a feasible fallback, with no claim of optimality
    /// (TRW-S gives one with a bound). This holds the refused decoding and a factor
    /// it violates. Always `None` from [`BeliefPropagation::finish`], which does not
    /// check.
    pub zero_decoding: Option<ZeroDecoding>,
    /// Sum-product only: true when the model has hard zeros and the search for an
    /// assignment of positive probability met its limit
    /// ([`BpParams::search_limit`]) without a verdict, so `Z > 0` (and so the meaning
    /// of `beliefs`) is unverified. False when `Z > 0` was verified (or not checked:
    /// [`BeliefPropagation::finish`]).
    pub support_undecided: bool,
}

impl BpResult {
    /// Why the run stopped.
    pub fn termination(&self) -> Termination {
        Termination::of(self.converged, self.out_of_time, self.stopped_by_observer)
    }
}

/// Why a run of message passing stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// The fixed-point residual fell within the tolerance (and the hook was stable).
    Converged,
    /// The iteration limit was reached without convergence.
    IterationLimit,
    /// The time budget was spent.
    TimeBudget,
    /// An observer asked to stop.
    Observer,
}

impl Termination {
    fn of(converged: bool, out_of_time: bool, stopped_by_observer: bool) -> Self {
        if converged {
            Termination::Converged
        } else if stopped_by_observer {
            Termination::Observer
        } else if out_of_time {
            Termination::TimeBudget
        } else {
            Termination::IterationLimit
        }
    }
}

/// Unchecked settings of loopy belief propagation; [`ParamGuard::check`] turns them
/// into a [`BeliefPropagation`] (the workspace's checked-parameters pattern, as
/// [`TrwsParams`](crate::TrwsParams)).
///
/// ```
/// use pgm_core::{BpParams, Mode, ParamGuard};
///
/// let bp = BpParams::new(Mode::SumProduct).damping(0.5).max_iterations(200).check().unwrap();
/// assert_eq!(bp.params().mode(), Mode::SumProduct);
/// assert!(BpParams::new(Mode::MaxProduct).damping(1.0).check().is_err());
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct BpParams {
    mode: Mode,
    damping: f64,
    tolerance: f64,
    max_iterations: usize,
    time_budget: Option<Duration>,
    search_limit: u64,
}

impl BpParams {
    /// Defaults: no damping, tolerance 1e-9, at most 100 iterations, no time budget,
    /// search limit [`support::DEFAULT_SEARCH_LIMIT`].
    pub fn new(mode: Mode) -> Self {
        Self {
            mode,
            damping: 0.0,
            tolerance: 1e-9,
            max_iterations: 100,
            time_budget: None,
            search_limit: support::DEFAULT_SEARCH_LIMIT,
        }
    }

    /// How many dead ends the search for an assignment of positive probability may
    /// meet ([`support::positive_assignment`]; see [`BeliefPropagation::check_support`]).
    pub fn search_limit(mut self, dead_ends: u64) -> Self {
        self.search_limit = dead_ends;
        self
    }

    /// Damping λ in [0, 1): messages become `(1 − λ) new + λ old` (in log space).
    pub fn damping(mut self, damping: f64) -> Self {
        self.damping = damping;
        self
    }

    /// Convergence tolerance on the largest undamped message change (finite, ≥ 0).
    pub fn tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// Maximum number of iterations (≥ 1).
    pub fn max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }

    /// Stop after the iteration during which this much wall-clock time was spent.
    pub fn time_budget(mut self, budget: Duration) -> Self {
        self.time_budget = Some(budget);
        self
    }

    /// The semiring.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The convergence tolerance.
    pub fn tolerance_value(&self) -> f64 {
        self.tolerance
    }
}

impl ParamGuard for BpParams {
    type Checked = BeliefPropagation;
    type Error = Error;

    /// # Errors
    /// [`Error::InvalidParameter`] for a damping outside [0, 1), a tolerance that is
    /// negative or not finite, or zero iterations.
    fn check_ref(&self) -> Result<()> {
        if !(0.0..1.0).contains(&self.damping) {
            return Err(
                InvalidParameter::new("damping", self.damping, "a number in [0, 1)").into(),
            );
        }
        InvalidParameter::tolerance("tolerance", self.tolerance)?;
        InvalidParameter::at_least_one("max_iterations", self.max_iterations)?;
        Ok(())
    }

    fn check(self) -> Result<BeliefPropagation> {
        self.check_ref()?;
        Ok(BeliefPropagation { params: self })
    }
}

/// Loopy belief propagation with checked settings (build it with [`BpParams`]) and a
/// pluggable [`Schedule`].
///
/// One entry point: [`run`](Self::run) from uniform messages, or a [`BpRun`] for
/// everything else — [`on`](Self::on) a graph (with a warm start, an observer, or
/// without decoding) or [`with_hook`](Self::with_hook) (a hook between updates, which
/// may refresh potentials and so borrows the graph mutably).
#[derive(Clone, Debug, PartialEq)]
pub struct BeliefPropagation {
    params: BpParams,
}

impl BeliefPropagation {
    /// The settings.
    pub fn params(&self) -> &BpParams {
        &self.params
    }

    /// The semiring.
    pub fn mode(&self) -> Mode {
        self.params.mode
    }

    /// Runs from uniform messages on `graph` with `schedule` and decodes the result
    /// (checked as [`BpRun::run`] checks it).
    ///
    /// # Errors
    /// The schedule's errors ([`Schedule::prepare`]) and [`Error::Infeasible`] (see
    /// [`check_support`](Self::check_support)).
    pub fn run<S: Schedule + ?Sized>(
        &self,
        graph: &FactorGraph,
        schedule: &mut S,
    ) -> Result<BpResult> {
        self.on(graph).run(schedule)
    }

    /// A run on `graph`: set a warm start or an observer, then
    /// [`run`](BpRun::run) or [`propagate`](BpRun::propagate).
    pub fn on<'r>(&'r self, graph: &'r FactorGraph) -> BpRun<'r> {
        BpRun {
            bp: self,
            graph: GraphRef::Shared(graph),
            hook: None,
            start: None,
            observer: None,
        }
    }

    /// A run on `graph` with `hook` called between updates (see [`UpdateHook`]).
    pub fn with_hook<'r>(
        &'r self,
        graph: &'r mut FactorGraph,
        hook: &'r mut dyn UpdateHook,
    ) -> BpRun<'r> {
        BpRun {
            bp: self,
            graph: GraphRef::Exclusive(graph),
            hook: Some(hook),
            start: None,
            observer: None,
        }
    }

    fn drive_messages<'g, S: Schedule + ?Sized>(
        &self,
        graph: GraphRef<'g>,
        hook: Option<&mut dyn UpdateHook>,
        schedule: &mut S,
        messages: Messages,
        mut observer: Option<&mut dyn Observe<BpProgress>>,
    ) -> Result<(Propagation, GraphRef<'g>)> {
        messages.check_layout(graph.get())?;
        schedule.prepare(graph.get())?;
        let start = Instant::now();
        let scratch = Scratch::for_graph(graph.get());
        let potentials_fixed = hook.is_none();
        let mut passer = Passer {
            graph,
            hook,
            state: PassState {
                mode: self.params.mode,
                normalisation: match self.params.mode {
                    Mode::MaxProduct => Normalisation::Max,
                    Mode::SumProduct => Normalisation::Sum,
                },
                damping: self.params.damping,
                messages,
                candidates: Vec::new(),
                flood_buffer: Vec::new(),
                flood_plan: None,
                potentials_fixed,
                scratch,
                residual: 0.0,
                contradictions: 0,
            },
            tolerance: self.params.tolerance,
            deadline: self.params.time_budget.map(|b| start + b),
        };
        let mut iterations = 0;
        let mut converged = false;
        let mut residual = f64::INFINITY;
        let mut out_of_time = false;
        let mut stopped_by_observer = false;
        while iterations < self.params.max_iterations {
            passer.state.residual = 0.0;
            let reported = schedule.iteration(&mut passer);
            iterations += 1;
            residual = reported.unwrap_or(passer.state.residual);
            let hook_stable = passer.after_iteration(iterations);
            converged = residual <= self.params.tolerance && hook_stable;
            if let Some(observer) = observer.as_deref_mut() {
                let progress = BpProgress {
                    iteration: iterations,
                    residual,
                    converged,
                    contradictions: passer.state.contradictions,
                    elapsed: start.elapsed(),
                };
                if let ControlFlow::Break(()) = observer.observe(&progress) {
                    stopped_by_observer = !converged;
                    break;
                }
            }
            if converged {
                break;
            }
            if passer.out_of_time() {
                out_of_time = true;
                break;
            }
        }
        let propagation = Propagation {
            messages: passer.state.messages,
            iterations,
            converged,
            residual,
            out_of_time,
            stopped_by_observer,
            contradictions: passer.state.contradictions,
        };
        Ok((propagation, passer.graph))
    }

    /// Decodes the assignment and beliefs of a finished propagation, without checking
    /// them against the model's hard zeros ([`check_support`](Self::check_support)
    /// does; [`BpRun::run`] does both).
    pub fn finish(&self, graph: &FactorGraph, p: Propagation) -> BpResult {
        let messages = p.messages;
        let assignment = match self.params.mode {
            Mode::MaxProduct => decode_map(graph, &messages),
            Mode::SumProduct => (0..graph.num_variables())
                .map(|v| messages.argmax(graph, VariableId(v)))
                .collect(),
        };
        let beliefs = (0..graph.num_variables())
            .map(|v| messages.belief(graph, VariableId(v)))
            .collect();
        BpResult {
            mode: self.params.mode,
            log_score: graph.log_score_unchecked(&assignment),
            assignment,
            beliefs,
            iterations: p.iterations,
            converged: p.converged,
            residual: p.residual,
            out_of_time: p.out_of_time,
            stopped_by_observer: p.stopped_by_observer,
            contradictions: p.contradictions,
            messages,
            zero_decoding: None,
            support_undecided: false,
        }
    }

    /// Checks a decoded result against the model's hard zeros, as [`BpRun::run`] does
    /// (for callers of [`finish`](Self::finish)); `graph` is the graph the result was
    /// decoded on.
    ///
    /// * Max-product: a decoding of positive probability passes unchanged. One of
    ///   probability 0 is replaced by the first assignment of positive probability
    ///   found by [`support::positive_assignment_conditioned`] on the run's messages
    ///   (its first descent is [`decode_map`] until that hits a hard zero) and
    ///   improved by [`support::improve_locally`], recorded in
    ///   [`BpResult::zero_decoding`].
    /// * Sum-product: without hard zeros, or when the most probable states have
    ///   positive probability, `Z > 0` and the result passes; otherwise the search
    ///   decides. Undecided: the result passes with [`BpResult::support_undecided`].
    ///
    /// # Errors
    /// [`Error::Infeasible`] when the model has no assignment of positive probability
    /// (`Z = 0`: no MAP assignment, marginals that cannot be normalised; the error
    /// holds the proof and a factor the result's assignment violates), and, for
    /// max-product, when the decoding has probability 0 and the search met
    /// [`BpParams::search_limit`] without finding a positive assignment.
    pub fn check_support(&self, graph: &FactorGraph, mut result: BpResult) -> Result<BpResult> {
        if result.log_score > f64::NEG_INFINITY {
            return Ok(result);
        }
        let method = match self.params.mode {
            Mode::MaxProduct => Method::MaxProduct,
            Mode::SumProduct => {
                if !support::has_hard_zeros(graph) {
                    return Ok(result);
                }
                Method::SumProduct
            }
        };
        let messages = &result.messages;
        let message = |e: EdgeId| messages.message(graph, e).to_vec();
        let found =
            support::positive_assignment_conditioned(graph, &message, self.params.search_limit);
        let refuse = |proof, dead_ends| {
            Error::Infeasible(Box::new(ZeroProbability::new(
                graph,
                method,
                result.assignment.clone(),
                proof,
                dead_ends,
            )))
        };
        match (found, method) {
            (Support::Positive(_), Method::SumProduct) => Ok(result),
            (Support::Positive(mut witness), _) => {
                support::improve_locally(graph, &mut witness, support::POLISH_SWEEPS);
                let decoded = std::mem::replace(&mut result.assignment, witness);
                result.log_score = graph.log_score_unchecked(&result.assignment);
                result.zero_decoding =
                    support::first_violation(graph, &decoded).map(|violated| ZeroDecoding {
                        assignment: decoded,
                        violated,
                    });
                Ok(result)
            }
            (Support::Empty(proof), _) => {
                let dead_ends = match proof {
                    support::ZeroProof::Search { dead_ends } => dead_ends,
                    _ => 0,
                };
                Err(refuse(Some(proof), dead_ends))
            }
            (Support::Undecided { .. }, Method::SumProduct) => {
                result.support_undecided = true;
                Ok(result)
            }
            (Support::Undecided { dead_ends }, _) => Err(refuse(None, dead_ends)),
        }
    }
}

/// One run of a [`BeliefPropagation`] (see [`BeliefPropagation::on`] and
/// [`BeliefPropagation::with_hook`]): options, then [`run`](Self::run) or
/// [`propagate`](Self::propagate) with a schedule.
pub struct BpRun<'r> {
    bp: &'r BeliefPropagation,
    graph: GraphRef<'r>,
    hook: Option<&'r mut dyn UpdateHook>,
    start: Option<Messages>,
    observer: Option<&'r mut dyn Observe<BpProgress>>,
}

impl<'r> BpRun<'r> {
    /// Starts from `messages` instead of uniform ones (a warm start, e.g. a previous
    /// result's `messages`).
    pub fn warm_start(mut self, messages: Messages) -> Self {
        self.start = Some(messages);
        self
    }

    /// Starts from `messages` when given, else from uniform ones.
    pub fn start(mut self, messages: Option<Messages>) -> Self {
        self.start = messages;
        self
    }

    /// Reports every iteration to `observer`, which may stop the run (see [`Observe`]).
    pub fn observer(mut self, observer: &'r mut dyn Observe<BpProgress>) -> Self {
        self.observer = Some(observer);
        self
    }

    /// Passes messages with `schedule`, decodes the assignment and beliefs, and
    /// checks them against the model's hard zeros
    /// ([`BeliefPropagation::check_support`]): a max-product assignment of probability
    /// 0 is never returned, nor are marginals of a model with `Z = 0`.
    ///
    /// # Errors
    /// Messages whose layout does not fit the graph, the schedule's errors, and
    /// [`Error::Infeasible`] (see [`BeliefPropagation::check_support`]).
    pub fn run<S: Schedule + ?Sized>(self, schedule: &mut S) -> Result<BpResult> {
        let bp = self.bp;
        let (p, graph) = self.drive(schedule)?;
        let result = bp.finish(graph.get(), p);
        bp.check_support(graph.get(), result)
    }

    /// Passes messages with `schedule` without decoding: for callers that decode
    /// themselves ([`BeliefPropagation::finish`]) or continue later, and for
    /// benchmarks of the iterations alone.
    ///
    /// # Errors
    /// As [`run`](Self::run).
    pub fn propagate<S: Schedule + ?Sized>(self, schedule: &mut S) -> Result<Propagation> {
        self.drive(schedule).map(|(p, _)| p)
    }

    fn drive<S: Schedule + ?Sized>(self, schedule: &mut S) -> Result<(Propagation, GraphRef<'r>)> {
        let BpRun {
            bp,
            graph,
            hook,
            start,
            observer,
        } = self;
        let messages = start.unwrap_or_else(|| Messages::uniform(graph.get(), bp.params.mode));
        bp.drive_messages(graph, hook, schedule, messages, observer)
    }
}

/// The outcome of message passing before decoding.
#[derive(Clone, Debug)]
pub struct Propagation {
    /// The final messages.
    pub messages: Messages,
    /// Iterations performed.
    pub iterations: usize,
    /// Whether the run converged (see [`BpResult::converged`]).
    pub converged: bool,
    /// The last iteration's fixed-point residual.
    pub residual: f64,
    /// Whether the time budget stopped the run.
    pub out_of_time: bool,
    /// Whether an observer stopped the run.
    pub stopped_by_observer: bool,
    /// Number of all-zero message updates.
    pub contradictions: usize,
}

enum GraphRef<'a> {
    Shared(&'a FactorGraph),
    Exclusive(&'a mut FactorGraph),
}

impl GraphRef<'_> {
    fn get(&self) -> &FactorGraph {
        match self {
            GraphRef::Shared(g) => g,
            GraphRef::Exclusive(g) => g,
        }
    }
}

/// Per-run buffers for gathering incoming messages of one factor.
#[derive(Default)]
struct Scratch {
    incoming: Vec<f64>,
    offsets: Vec<usize>,
    out: Vec<f64>,
}

impl Scratch {
    /// Buffers large enough for every message of `graph` (so the inner loops never
    /// grow them): the largest sum of a factor's scope cardinalities, the largest
    /// cardinality.
    fn for_graph(graph: &FactorGraph) -> Self {
        let ix = graph.index();
        let widest = ix
            .factor_edge_start
            .windows(2)
            .map(|w| {
                (w[0]..w[1])
                    .map(|e| ix.cardinalities[ix.edge_variable[e].0])
                    .sum::<usize>()
            })
            .max()
            .unwrap_or(0);
        let largest = ix.cardinalities.iter().copied().max().unwrap_or(0);
        Scratch::with_sizes(widest, largest)
    }

    fn with_sizes(incoming: usize, out: usize) -> Self {
        Scratch {
            incoming: vec![0.0; incoming],
            offsets: Vec::new(),
            out: vec![0.0; out],
        }
    }
}

struct PassState {
    mode: Mode,
    normalisation: Normalisation,
    damping: f64,
    messages: Messages,
    candidates: Vec<f64>,
    flood_buffer: Vec<f64>,
    /// Flooding's compiled plan: `None` until the first flood, then the plan if the
    /// graph has one. Runs whose potentials may change (with a hook) never build one.
    flood_plan: Option<Option<FloodPlan>>,
    /// Whether the potentials stay fixed for the whole run (no hook), so that a plan
    /// may copy them.
    potentials_fixed: bool,
    scratch: Scratch,
    /// Largest undamped change of a message committed in this iteration.
    residual: f64,
    contradictions: usize,
}

struct Passer<'g, 'h> {
    graph: GraphRef<'g>,
    hook: Option<&'h mut dyn UpdateHook>,
    state: PassState,
    tolerance: f64,
    deadline: Option<Instant>,
}

impl Passer<'_, '_> {
    fn before(&mut self, visit: Visit) {
        if let (Some(hook), GraphRef::Exclusive(g)) = (self.hook.as_deref_mut(), &mut self.graph) {
            hook.before_visit(visit, &mut Potentials::new(g), &self.state.messages);
        }
    }

    fn after(&mut self, visit: Visit) {
        if let (Some(hook), GraphRef::Exclusive(g)) = (self.hook.as_deref_mut(), &mut self.graph) {
            hook.after_visit(visit, &mut Potentials::new(g), &self.state.messages);
        }
    }

    fn after_iteration(&mut self, iteration: usize) -> bool {
        if let (Some(hook), GraphRef::Exclusive(g)) = (self.hook.as_deref_mut(), &mut self.graph) {
            hook.after_iteration(iteration, &mut Potentials::new(g), &self.state.messages)
        } else {
            true
        }
    }
}

/// Fills `scratch.incoming` with the variable-to-factor messages into factor `a`, for
/// every scope position except `skip`: `q_{j→a} = Σ_{b ∋ j, b ≠ a} r_{b→j}`, read from
/// the variable's contiguous block of incoming messages. A single-variable factor's
/// message ignores its input, so nothing is gathered for it.
#[inline]
fn gather(
    graph: &FactorGraph,
    messages: &[f64],
    a: FactorId,
    skip: Option<usize>,
    scratch: &mut Scratch,
) {
    let ix = graph.index();
    let (first_edge, end_edge) = (ix.factor_edge_start[a.0], ix.factor_edge_start[a.0 + 1]);
    scratch.offsets.clear();
    scratch.offsets.push(0);
    let mut total = 0;
    for e in first_edge..end_edge {
        total += ix.cardinalities[ix.edge_variable[e].0];
        scratch.offsets.push(total);
    }
    // Every gathered position is overwritten below; the skipped one is never read.
    if scratch.incoming.len() < total {
        scratch.incoming.resize(total, 0.0);
    }
    if end_edge - first_edge == 1 {
        return;
    }
    for (slot, e) in (first_edge..end_edge).enumerate() {
        if Some(slot) == skip {
            continue;
        }
        let lo = scratch.offsets[slot];
        let v = ix.edge_variable[e].0;
        let k = ix.cardinalities[v];
        let own = ix.edge_offset[e];
        let dst = &mut scratch.incoming[lo..lo + k];
        let block = &messages[ix.variable_start[v]..ix.variable_end[v]];
        let own = own - ix.variable_start[v];
        let mut first = true;
        let mut start = 0;
        while start < block.len() {
            if start != own {
                let src = &block[start..start + k];
                if first {
                    // `+ 0.0` keeps the compiler from turning this short copy into a
                    // library memcpy call (it cannot drop the add: −0.0 + 0.0 = +0.0).
                    for (d, s) in dst.iter_mut().zip(src) {
                        *d = *s + 0.0;
                    }
                    first = false;
                } else {
                    for (d, s) in dst.iter_mut().zip(src) {
                        *d += s;
                    }
                }
            }
            start += k;
        }
        if first {
            // The factor is the variable's only one: the incoming message is uniform.
            dst.iter_mut().for_each(|d| *d = 0.0);
        }
    }
}

/// Computes the unnormalised message of edge `e` from `messages` into
/// `scratch.out[..k]`; returns `k` (the states of the edge's variable) and where the
/// edge's message starts in the buffer.
///
/// Pairwise factors take the fast path: the one incoming variable-to-factor message
/// is a leave-one-out sum over the other variable's contiguous block
/// ([`leave_one_out`]), written straight where [`Incoming`] expects it. Other arities
/// gather every position ([`gather`]). Both give bit-identical sums. `scratch` must
/// be sized for the graph ([`Scratch::for_graph`]).
#[inline]
fn raw_message(
    graph: &FactorGraph,
    messages: &[f64],
    e: usize,
    mode: Mode,
    scratch: &mut Scratch,
) -> (usize, usize) {
    if let Some(p) = graph.pair_sources().get(e).filter(|p| p.target_states > 0) {
        let k = p.target_states as usize;
        let other = p.states as usize;
        let total = k + other;
        let slot = p.slot as usize;
        let (offsets, at) = if slot == 0 {
            ([0, k, total], k)
        } else {
            ([0, other, total], 0)
        };
        let (start, end, own) = (p.start as usize, p.end as usize, p.own as usize);
        leave_one_out(
            &messages[start..end],
            own - start,
            other,
            &mut scratch.incoming[at..at + other],
        );
        let incoming = Incoming::new(&scratch.incoming[..total], &offsets);
        graph.factor(FactorId(p.factor as usize)).message(
            slot,
            &incoming,
            mode,
            &mut scratch.out[..k],
        );
        return (k, p.target as usize);
    }
    let ix = graph.index();
    let a = ix.edge_factor[e];
    let slot = e - ix.factor_edge_start[a.0];
    let k = ix.cardinalities[ix.edge_variable[e].0];
    if scratch.out.len() < k {
        scratch.out.resize(k, 0.0);
    }
    gather(graph, messages, a, Some(slot), scratch);
    let incoming = Incoming::new(&scratch.incoming, &scratch.offsets);
    graph
        .factor(a)
        .message(slot, &incoming, mode, &mut scratch.out[..k]);
    (k, ix.edge_offset[e])
}

/// `dst = Σ` of the `k`-long messages of `block` except the one starting at `own`
/// (all zeros when `own` is the only one): a variable-to-factor message, computed
/// without subtraction. Small `k` get loops the compiler unrolls.
#[inline]
fn leave_one_out(block: &[f64], own: usize, k: usize, dst: &mut [f64]) {
    with_small_states!(
        k,
        K => leave_one_out_fixed::<K>(block, own, dst),
        leave_one_out_any(block, own, k, dst),
    )
}

/// [`leave_one_out`] for any `k`.
fn leave_one_out_any(block: &[f64], own: usize, k: usize, dst: &mut [f64]) {
    dst.iter_mut().for_each(|d| *d = 0.0);
    let mut start = 0;
    for chunk in block.chunks_exact(k.max(1)) {
        if start != own {
            for (d, c) in dst.iter_mut().zip(chunk) {
                *d += c;
            }
        }
        start += k;
    }
}

#[inline(always)]
fn leave_one_out_fixed<const K: usize>(block: &[f64], own: usize, dst: &mut [f64]) {
    // Starting from +0.0 gives the same sums as starting from the first message
    // (x + 0.0 = x for every x but −0.0, and −0.0 and +0.0 are the same log-value).
    let mut acc = [0.0f64; K];
    let mut start = 0;
    for chunk in block.chunks_exact(K) {
        if start != own {
            for x in 0..K {
                acc[x] += chunk[x];
            }
        }
        start += K;
    }
    dst[..K].copy_from_slice(&acc);
}

/// Computes the normalised message of scope position `slot` of factor `a` into
/// `scratch.out`, assuming `gather` was called. Returns false on a contradiction.
fn compute(
    graph: &FactorGraph,
    a: FactorId,
    slot: usize,
    mode: Mode,
    how: Normalisation,
    scratch: &mut Scratch,
) -> bool {
    let factor = graph.factor(a);
    let k = scratch.offsets[slot + 1] - scratch.offsets[slot];
    // `Factor::message` writes every entry, so the buffer is not cleared.
    scratch.out.resize(k, 0.0);
    scratch.out.truncate(k);
    let incoming = Incoming::new(&scratch.incoming, &scratch.offsets);
    factor.message(slot, &incoming, mode, &mut scratch.out);
    logspace::normalise(&mut scratch.out, how)
}

/// Computes the unnormalised message of scope position `slot` of factor `a` into
/// `scratch.out`, assuming `gather` was called.
#[inline]
fn compute_raw(graph: &FactorGraph, a: FactorId, slot: usize, mode: Mode, scratch: &mut Scratch) {
    let factor = graph.factor(a);
    let k = scratch.offsets[slot + 1] - scratch.offsets[slot];
    scratch.out.resize(k, 0.0);
    scratch.out.truncate(k);
    let incoming = Incoming::new(&scratch.incoming, &scratch.offsets);
    factor.message(slot, &incoming, mode, &mut scratch.out);
}

/// Normalises the raw message `raw` and writes it over `old` with damping; returns the
/// undamped change and whether the message was not a contradiction. Undamped
/// max-product messages take one fused pass.
#[inline]
fn commit_raw(old: &mut [f64], raw: &mut [f64], damping: f64, how: Normalisation) -> (f64, bool) {
    if damping == 0.0 && how == Normalisation::Max {
        let m = logspace::max(raw);
        if m.is_finite() {
            if raw.len() <= 16 {
                // One fused scalar pass: shift, compare, store.
                let mut d = 0.0f64;
                for (o, &x) in old.iter_mut().zip(raw.iter()) {
                    let n = x - m;
                    let diff = (n - *o).abs();
                    d = if diff > d { diff } else { d };
                    *o = n;
                }
                return (d, true);
            }
            raw.iter_mut().for_each(|x| *x -= m);
            let d = logspace::distance(raw, old);
            old.copy_from_slice(raw);
            return (d, true);
        }
    }
    let ok = logspace::normalise(raw, how);
    (commit(old, raw, damping, how), ok)
}

/// [`commit_raw`] for flooding: the message moves from `old` (the previous
/// iteration's buffer) to `dst` (the next one's).
#[inline(always)]
fn commit_raw_into(
    old: &[f64],
    dst: &mut [f64],
    raw: &mut [f64],
    damping: f64,
    how: Normalisation,
) -> (f64, bool) {
    if damping == 0.0 && how == Normalisation::Max && raw.len() <= 16 {
        let m = logspace::max(raw);
        if m.is_finite() {
            let mut d = 0.0f64;
            for ((o, n), &x) in old.iter().zip(dst.iter_mut()).zip(raw.iter()) {
                let v = x - m;
                let diff = (v - *o).abs();
                d = if diff > d { diff } else { d };
                *n = v;
            }
            return (d, true);
        }
    }
    dst.copy_from_slice(old);
    commit_raw(dst, raw, damping, how)
}

/// [`commit_raw_into`] for one message of a flood: the raw message `(k, start)` in
/// `scratch.out` moves from `old` (the whole previous buffer) into `out`, the part of the
/// next buffer that starts at offset `base`.
#[inline(always)]
fn flood_commit(
    old: &[f64],
    out: &mut [f64],
    base: usize,
    (k, start): (usize, usize),
    scratch: &mut Scratch,
    damping: f64,
    how: Normalisation,
) -> (f64, bool) {
    commit_raw_into(
        &old[start..start + k],
        &mut out[start - base..start - base + k],
        &mut scratch.out[..k],
        damping,
        how,
    )
}

/// Writes `new` over `old` with damping; returns the undamped change.
fn commit(old: &mut [f64], new: &[f64], damping: f64, how: Normalisation) -> f64 {
    let residual = logspace::distance(new, old);
    if damping == 0.0 {
        old.copy_from_slice(new);
    } else {
        for (o, &n) in old.iter_mut().zip(new) {
            *o = if o.is_finite() && n.is_finite() {
                (1.0 - damping) * n + damping * *o
            } else {
                n
            };
        }
        logspace::normalise(old, how);
    }
    residual
}

impl PassState {
    /// Builds the run's message plan on first use (see [`FloodPlan`]).
    #[inline(always)]
    fn prepare_plan(&mut self, graph: &FactorGraph) {
        if self.flood_plan.is_none() {
            self.build_plan(graph);
        }
    }

    #[cold]
    #[inline(never)]
    fn build_plan(&mut self, graph: &FactorGraph) {
        self.flood_plan = Some(
            self.potentials_fixed
                .then(|| FloodPlan::build(graph, self.mode))
                .flatten(),
        );
    }

    /// The unnormalised message of edge `e` from the current messages, by the plan
    /// when the run has one.
    #[inline(always)]
    fn raw_message(&mut self, graph: &FactorGraph, e: EdgeId) -> (usize, usize) {
        self.prepare_plan(graph);
        match self.flood_plan.as_ref().and_then(Option::as_ref) {
            Some(plan) => plan.raw_message(
                graph,
                &self.messages.values,
                e.0,
                self.mode,
                &mut self.scratch,
            ),
            None => raw_message(
                graph,
                &self.messages.values,
                e.0,
                self.mode,
                &mut self.scratch,
            ),
        }
    }

    /// Updates the messages of factor `a` to every scope position except `except`.
    fn update_factor_except(&mut self, graph: &FactorGraph, a: FactorId, except: Option<usize>) {
        if graph.factor_edges(a).len() == 2 {
            for (slot, e) in graph.factor_edges(a).enumerate() {
                if Some(slot) != except {
                    self.update_edge(graph, EdgeId(e));
                }
            }
            return;
        }
        let skip = match (except, graph.factor(a).scope().len()) {
            // A single-target update only needs the other positions' messages.
            (_, 1) => Some(0),
            _ => None,
        };
        gather(graph, &self.messages.values, a, skip, &mut self.scratch);
        for (slot, e) in graph.factor_edges(a).enumerate() {
            if Some(slot) != except {
                self.send(graph, a, slot, EdgeId(e));
            }
        }
    }

    fn update_edge(&mut self, graph: &FactorGraph, e: EdgeId) {
        let (k, start) = self.raw_message(graph, e);
        let (r, ok) = commit_raw(
            &mut self.messages.values[start..start + k],
            &mut self.scratch.out[..k],
            self.damping,
            self.normalisation,
        );
        self.contradictions += usize::from(!ok);
        self.residual = self.residual.max(r);
    }

    /// Computes the message of edge `e` (scope position `slot` of factor `a`) from the
    /// gathered incoming messages and commits it.
    fn send(&mut self, graph: &FactorGraph, a: FactorId, slot: usize, e: EdgeId) {
        compute_raw(graph, a, slot, self.mode, &mut self.scratch);
        let range = graph.message_range(e);
        let (r, ok) = commit_raw(
            &mut self.messages.values[range],
            &mut self.scratch.out,
            self.damping,
            self.normalisation,
        );
        self.contradictions += usize::from(!ok);
        self.residual = self.residual.max(r);
    }

    fn visit_variable(&mut self, graph: &FactorGraph, v: VariableId) {
        for i in 0..graph.variable_edges(v).len() {
            let e = graph.variable_edges(v)[i];
            let a = graph.edge_factor(e);
            if graph.factor(a).scope().len() == 1 {
                self.update_factor_except(graph, a, None);
            } else {
                self.update_factor_except(graph, a, Some(graph.edge_slot(e)));
            }
        }
    }

    fn compute_candidate(&mut self, graph: &FactorGraph, e: EdgeId) -> f64 {
        if self.candidates.len() != self.messages.values.len() {
            self.candidates = self.messages.values.clone();
        }
        let (k, start) = self.raw_message(graph, e);
        let out = &mut self.scratch.out[..k];
        let current = &self.messages.values[start..start + k];
        let candidate = &mut self.candidates[start..start + k];
        if self.normalisation == Normalisation::Max && k <= 16 {
            // One fused pass: normalise, compare, store.
            let m = logspace::max(out);
            if m.is_finite() {
                let mut d = 0.0f64;
                for ((c, &x), &o) in candidate.iter_mut().zip(out.iter()).zip(current) {
                    let v = x - m;
                    let diff = (v - o).abs();
                    d = if diff > d { diff } else { d };
                    *c = v;
                }
                return d;
            }
        }
        if !logspace::normalise(out, self.normalisation) {
            self.contradictions += 1;
        }
        candidate.copy_from_slice(out);
        logspace::distance(out, current)
    }

    /// Commits the candidate of `e`; returns the change still pending (candidate
    /// against the committed message, 0 without damping).
    fn commit_candidate(&mut self, graph: &FactorGraph, e: EdgeId) -> f64 {
        if self.candidates.len() != self.messages.values.len() {
            return 0.0;
        }
        let range = graph.message_range(e);
        if self.damping == 0.0 {
            // Undamped: copy and measure in one pass.
            let mut d = 0.0f64;
            for (o, &c) in self.messages.values[range.clone()]
                .iter_mut()
                .zip(&self.candidates[range])
            {
                let diff = (c - *o).abs();
                d = if diff > d { diff } else { d };
                *o = c;
            }
            self.residual = self.residual.max(d);
            return 0.0;
        }
        let r = commit(
            &mut self.messages.values[range.clone()],
            &self.candidates[range.clone()],
            self.damping,
            self.normalisation,
        );
        self.residual = self.residual.max(r);
        if self.damping == 0.0 {
            0.0
        } else {
            logspace::distance(
                &self.candidates[range.clone()],
                &self.messages.values[range],
            )
        }
    }

    fn flood(&mut self, graph: &FactorGraph) {
        let len = self.messages.values.len();
        let mut next = std::mem::take(&mut self.flood_buffer);
        next.resize(len, 0.0);
        // Chunks of consecutive variables of the layout order own consecutive blocks.
        let order = graph.layout_order();
        let n = order.len();
        let per_chunk = (n / (8 * rayon::current_num_threads().max(1))).clamp(32, 4096);
        let mut chunks: Vec<(std::ops::Range<usize>, &mut [f64])> = Vec::new();
        let mut rest: &mut [f64] = &mut next;
        let mut first = 0;
        while first < n {
            let last = (first + per_chunk).min(n);
            let begin = graph.variable_message_range(order[first]).start;
            let end = graph.variable_message_range(order[last - 1]).end;
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(end - begin);
            chunks.push((first..last, head));
            rest = tail;
            first = last;
        }
        self.prepare_plan(graph);
        let old = &self.messages.values;
        let (mode, how, damping) = (self.mode, self.normalisation, self.damping);
        let sizes = (self.scratch.incoming.len(), self.scratch.out.len());
        let plan = self.flood_plan.as_ref().and_then(Option::as_ref);
        let (residual, contradictions) = chunks
            .into_par_iter()
            .map(|(variables, out)| {
                let mut scratch = Scratch::with_sizes(sizes.0, sizes.1);
                let base = graph.variable_message_range(order[variables.start]).start;
                if let Some(plan) = plan {
                    return plan.flood(
                        graph,
                        variables,
                        old,
                        out,
                        base,
                        (mode, how, damping),
                        &mut scratch,
                    );
                }
                let mut residual = 0.0f64;
                let mut contradictions = 0usize;
                for &v in &order[variables] {
                    for &e in graph.variable_edges(v) {
                        let message = raw_message(graph, old, e.0, mode, &mut scratch);
                        let (r, ok) =
                            flood_commit(old, out, base, message, &mut scratch, damping, how);
                        contradictions += usize::from(!ok);
                        residual = residual.max(r);
                    }
                }
                (residual, contradictions)
            })
            .reduce(|| (0.0, 0), |x, y| (x.0.max(y.0), x.1 + y.1));
        self.residual = self.residual.max(residual);
        self.contradictions += contradictions;
        self.flood_buffer = std::mem::replace(&mut self.messages.values, next);
    }
}

impl MessagePasser for Passer<'_, '_> {
    fn graph(&self) -> &FactorGraph {
        self.graph.get()
    }

    fn visit_variable(&mut self, v: VariableId) {
        self.before(Visit::Variable(v));
        self.state.visit_variable(self.graph.get(), v);
        self.after(Visit::Variable(v));
    }

    fn update_factor(&mut self, a: FactorId) {
        self.before(Visit::Factor(a));
        self.state.update_factor_except(self.graph.get(), a, None);
        self.after(Visit::Factor(a));
    }

    fn update_edge(&mut self, e: EdgeId) {
        self.before(Visit::Edge(e));
        self.state.update_edge(self.graph.get(), e);
        self.after(Visit::Edge(e));
    }

    fn flood(&mut self) {
        self.before(Visit::Flood);
        self.state.flood(self.graph.get());
        self.after(Visit::Flood);
    }

    fn compute_candidate(&mut self, e: EdgeId) -> f64 {
        self.state.compute_candidate(self.graph.get(), e)
    }

    fn commit_candidate(&mut self, e: EdgeId) {
        self.commit_candidate_pending(e);
    }

    fn commit_candidate_pending(&mut self, e: EdgeId) -> f64 {
        self.before(Visit::Edge(e));
        let pending = self.state.commit_candidate(self.graph.get(), e);
        self.after(Visit::Edge(e));
        pending
    }

    fn out_of_time(&self) -> bool {
        self.deadline.is_some_and(|d| Instant::now() >= d)
    }

    fn tolerance(&self) -> f64 {
        self.tolerance
    }

    fn update_continuous(&mut self) {
        if let (Some(hook), GraphRef::Exclusive(g)) = (self.hook.as_deref_mut(), &mut self.graph) {
            hook.continuous_update(&mut Potentials::new(g), &self.state.messages);
        }
    }
}

/// Index of the first maximum (lowest index among ties); 0 for an empty or all-NaN slice.
pub fn first_argmax(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        if x > v[best] {
            best = i;
        }
    }
    best
}

/// Decodes a MAP assignment from max-product messages consistently.
///
/// Variables are fixed one at a time in breadth-first order ([`FactorGraph::bfs_order`]);
/// each takes the first maximiser of its max-marginal *conditioned on the variables
/// already fixed*: a factor with no fixed neighbour contributes its current message, a
/// factor whose other variables are all fixed contributes its log-potential at their
/// states, and a partially fixed factor recomputes its message with the fixed
/// variables' incoming messages replaced by indicators. On a tree at convergence this
/// returns an exact MAP assignment even when several exist (independent per-variable
/// argmaxes can mix two different optima); ties go to the lowest state index.
pub fn decode_map(graph: &FactorGraph, messages: &Messages) -> Vec<usize> {
    let n = graph.num_variables();
    let mut assigned: Vec<Option<usize>> = vec![None; n];
    let mut scratch = Scratch::default();
    let mut states = Vec::new();
    for v in graph.bfs_order() {
        let k = graph.cardinality(v);
        let mut score = vec![0.0; k];
        for &e in graph.variable_edges(v) {
            let a = graph.edge_factor(e);
            let factor = graph.factor(a);
            let slot = graph.edge_slot(e);
            let scope = factor.scope();
            let fixed = scope
                .iter()
                .enumerate()
                .filter(|&(j, u)| j != slot && assigned[u.0].is_some())
                .count();
            if fixed == 0 {
                for (s, m) in score.iter_mut().zip(messages.message(graph, e)) {
                    *s += m;
                }
            } else if fixed == scope.len() - 1 {
                states.clear();
                states.extend(scope.iter().map(|u| assigned[u.0].unwrap_or(0)));
                for (x, s) in score.iter_mut().enumerate() {
                    states[slot] = x;
                    *s += factor.log_potential(&states);
                }
            } else {
                gather(graph, &messages.values, a, Some(slot), &mut scratch);
                for (j, u) in scope.iter().enumerate() {
                    if let (true, Some(x)) = (j != slot, assigned[u.0]) {
                        let dst = &mut scratch.incoming[scratch.offsets[j]..scratch.offsets[j + 1]];
                        dst.iter_mut().for_each(|d| *d = f64::NEG_INFINITY);
                        dst[x] = 0.0;
                    }
                }
                compute(
                    graph,
                    a,
                    slot,
                    Mode::MaxProduct,
                    Normalisation::Max,
                    &mut scratch,
                );
                for (s, m) in score.iter_mut().zip(&scratch.out) {
                    *s += m;
                }
            }
        }
        assigned[v.0] = Some(first_argmax(&score));
    }
    assigned.into_iter().map(|x| x.unwrap_or(0)).collect()
}
