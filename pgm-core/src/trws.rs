//! MAP with a certificate: sequential tree-reweighted max-product (TRW-S) and its
//! dual bound.
//!
//! **What it computes.** For a factor graph with log-score
//! `S(x) = Σ_i θ_i(x_i) + Σ_α θ_α(x_α)` (unary factors summed into `θ_i`, factors of
//! arity ≥ 2 as `θ_α`), TRW-S returns an assignment `x̂`, its log-score `S(x̂)`, and an
//! upper bound `U ≥ max_x S(x)`, so that `x̂` is at most the gap `U − S(x̂)` below the
//! optimum; a gap of 0 certifies `x̂` optimal. `U` is the value of the dual of the
//! local-polytope LP relaxation (Wainwright, Jaakkola and Willsky 2005, "MAP estimation
//! via agreement on trees: message-passing and linear programming") at the current
//! reparametrisation, and never increases from one iteration to the next.
//!
//! **The algorithm.** Kolmogorov 2006, "Convergent tree-reweighted message passing for
//! energy minimization" (IEEE TPAMI 28(10)), in max-sum form, generalised to
//! factors of any arity as in Kolmogorov 2015, "A new look at reweighted message
//! passing" (IEEE TPAMI 37(5), sequential reweighted message passing, SRMP), which
//! reduces to TRW-S on pairwise models. Variables are visited in a fixed order, forward
//! and then backward (one iteration). At variable `i` in the forward pass:
//!
//! 1. every factor `α ∋ i` that also holds a variable *earlier* in the order sends its
//!    message `m_{α→i}(x_i) = max_{x_α∖i} [θ_α(x_α) + Σ_{j ∈ α, j ≠ i} n_{j→α}(x_j)]`,
//!    normalised to maximum 0, with the reweighted variable-to-factor messages
//!    `n_{j→α} = γ_j θ̂_j − m_{α→j}` (Kolmogorov's pairwise update, with
//!    `γ = ρ_st / ρ_s`);
//! 2. its reparametrised unary `θ̂_i = θ_i + Σ_{α ∋ i} m_{α→i}` is recomputed;
//! 3. `x_i` is decoded as Kolmogorov 2006 extracts a labelling: the first maximiser of
//!    `θ_i(x_i) + Σ_α` (for factors with a variable already decoded in this pass:
//!    `θ_α` maximised over its undecoded variables with the decoded ones fixed; for
//!    the others: `m_{α→i}`).
//!
//! The backward pass is the same with the order reversed; it decodes too with
//! [`TrwsParams::decode_backward`]. Messages are computed by
//! [`Factor::message`](crate::Factor::message), so dense tables of any arity, the O(K)
//! [`PottsFactor`](crate::PottsFactor) and
//! [`ShiftedIdentityFactor`](crate::ShiftedIdentityFactor) and user factors all plug
//! in, structured ones through their fast paths.
//!
//! **Edge appearance probabilities.** The weights come from the cover of the graph by
//! *monotonic chains* of the order (Kolmogorov 2006): at every
//! variable `i`, the factors reaching back to earlier variables are paired with those
//! reaching forward, so `n_i = max(#backward factors, #forward factors)` chains pass
//! through `i`, and every factor of arity ≥ 2 lies on exactly one chain. With all
//! chains equally likely, a factor's appearance probability relative to its
//! variable's is `ρ_α / ρ_i = γ_i = 1 / n_i`. On a chain in its natural order every
//! `γ_i = 1` and one iteration is exact max-product; on a 4-connected grid in row-major
//! order the chains are the rows and the columns and interior variables have
//! `γ_i = 1/2`. The default order is the variables' index order; [`TrwsParams::order`]
//! chooses another.
//!
//! **The bound.** After a pass, the state is the SRMP reparametrisation
//! `θ̂^S_i = w_i θ̂_i` and `θ̂^S_α` with `max θ̂^S_α = c_α`, where `c_α` is the
//! normalising constant of the last message `α` sent in the pass and
//! `w_i = 1 − γ_i · #(factors of i reaching ahead in the pass)`. Its dual value
//! `U = Σ_i w_i max θ̂_i + Σ_α c_α + (constant factors)` is an upper bound on every
//! assignment's log-score, and no step of a pass increases it (receiving a message
//! moves a factor's max-marginal onto `θ̂_i`; the reweighted messages hand `γ_i θ̂_i`
//! to each factor reaching ahead, with `Σ γ_i ≤ 1`; Kolmogorov 2015), so it is
//! computed in O(Σ_i K_i) per pass. Hard zeros (−∞) are exact: a state that can only
//! score −∞ stays −∞ and never meets a subtraction, and a model whose relaxation
//! already excludes every state of some variable ends with bound −∞.
//!
//! **Hard zeros.** A run never returns an assignment of probability 0. When the best
//! decoded assignment scores −∞, a bound of −∞ proves that none scores better
//! ([`ZeroProof::DualBound`]); otherwise (the
//! bound of an odd cycle of hard "not equal" tables is finite: the relaxation is not
//! tight there) [`support::positive_assignment_conditioned`] searches for one of
//! positive probability, guided by the messages `m_{α→i}` and the unaries as the
//! decoding is, and [`support::improve_locally`] improves what it finds. A model without
//! one is refused with [`Error::Infeasible`] and the proof; a found one replaces the
//! decoding (recorded in [`TrwsResult::zero_decoding`]; the gap to the bound still
//! holds for it).
//!
//! ```
//! use pgm_core::trws::{TrwsParams, TrwsTermination};
//! use pgm_core::exact::brute_force;
//! use pgm_core::{FactorGraph, ParamGuard, PottsFactor, TableFactor, VariableId};
//!
//! // A 4-cycle with three labels: loopy, so max-product alone has no guarantee.
//! let mut g = FactorGraph::with_variables(&[3; 4]).unwrap();
//! for v in 0..4 {
//!     let t = vec![0.3 * v as f64, -0.2, 0.1 * (v % 2) as f64];
//!     g.add_factor(TableFactor::new(vec![VariableId(v)], vec![3], t).unwrap()).unwrap();
//! }
//! for (a, b) in [(0, 1), (1, 2), (2, 3), (0, 3)] {
//!     g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 3, 1.0, 0.0).unwrap()).unwrap();
//! }
//! let trws = TrwsParams::default().max_iterations(50).check().unwrap();
//! let result = trws.run(&g).unwrap();
//! let exact = brute_force(&g, Default::default()).unwrap();
//! // The bound is above the optimum and the assignment below it.
//! assert!(result.bound >= exact.map_log_score - 1e-9);
//! assert!(result.log_score <= exact.map_log_score + 1e-9);
//! // Here the relaxation is tight: the gap closes and certifies the optimum.
//! assert_eq!(result.termination, TrwsTermination::GapClosed);
//! assert_eq!(result.log_score, exact.map_log_score);
//! ```

use crate::bp::first_argmax;
use crate::error::{Error, Result};
use crate::factor::{Incoming, Mode};
use crate::graph::{EdgeId, FactorGraph, FactorId, VariableId};
use crate::observer::{Observe, TrwsProgress};
use crate::param::InvalidParameter;

use crate::support::{self, Method, Support, ZeroDecoding, ZeroProbability, ZeroProof};
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

/// Unchecked TRW-S settings; [`check`](crate::ParamGuard::check) turns them into a [`Trws`].
#[derive(Clone, Debug, PartialEq)]
pub struct TrwsParams {
    max_iterations: usize,
    tolerance: f64,
    time_budget: Option<Duration>,
    order: Option<Vec<VariableId>>,
    decode_backward: bool,
    search_limit: u64,
}

impl Default for TrwsParams {
    /// At most 100 iterations, tolerance 1e-9, no time budget, index order, decoding
    /// in the forward pass only, search limit [`support::DEFAULT_SEARCH_LIMIT`].
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-9,
            time_budget: None,
            order: None,
            decode_backward: false,
            search_limit: support::DEFAULT_SEARCH_LIMIT,
        }
    }
}

impl TrwsParams {
    /// Maximum number of iterations (forward plus backward pass each); at least 1.
    pub fn max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }

    /// Relative tolerance τ ≥ 0: the run stops when the gap is at most
    /// `τ · max(1, |bound|)` (the assignment is certified optimal to that precision) or
    /// when one iteration lowered the bound by at most that much (the bound settled).
    pub fn tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// Stop after the iteration during which this much wall-clock time was spent.
    pub fn time_budget(mut self, budget: Duration) -> Self {
        self.time_budget = Some(budget);
        self
    }

    /// The order in which variables are visited (a permutation of the graph's
    /// variables, checked when the run starts); it fixes the monotonic chains and so the
    /// edge appearance probabilities (see the module documentation).
    pub fn order(mut self, order: Vec<VariableId>) -> Self {
        self.order = Some(order);
        self
    }

    /// Whether the backward pass decodes an assignment too (in the reversed order), as
    /// the forward pass always does (Kolmogorov 2006 decodes in the forward pass
    /// only). Two candidates per iteration often find a better assignment and a
    /// smaller gap, for about a quarter more time per iteration.
    pub fn decode_backward(mut self, decode: bool) -> Self {
        self.decode_backward = decode;
        self
    }

    /// How many dead ends the search for an assignment of positive probability may
    /// meet when every decoded assignment scores −∞ (see the module documentation).
    pub fn search_limit(mut self, dead_ends: u64) -> Self {
        self.search_limit = dead_ends;
        self
    }
}

impl TrwsParams {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for zero iterations or a tolerance that is negative or not finite.
    fn validate(&self) -> Result<()> {
        InvalidParameter::at_least_one("max_iterations", self.max_iterations)?;
        InvalidParameter::tolerance("tolerance", self.tolerance)?;
        Ok(())
    }
}

/// Why a TRW-S run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrwsTermination {
    /// The gap closed (within the tolerance): the assignment is optimal.
    GapClosed,
    /// One iteration lowered the bound by no more than the tolerance: the bound
    /// settled (the gap may stay open: the LP relaxation is not tight or TRW-S stopped
    /// at a weak tree agreement).
    BoundSettled,
    /// The iteration limit was reached first.
    IterationLimit,
    /// The time budget was spent.
    TimeBudget,
    /// An observer asked to stop.
    Observer,
}

/// The outcome of a TRW-S run.
#[derive(Clone, Debug, PartialEq)]
pub struct TrwsResult {
    /// The best assignment decoded in any decoding pass (one state per variable),
    /// or, when every decoding had probability 0, the assignment of positive
    /// probability the search found (see [`zero_decoding`](Self::zero_decoding)).
    pub assignment: Vec<usize>,
    /// Its log-score (sum of log-potentials; always finite).
    pub log_score: f64,
    /// The lowest upper bound on the best log-score seen in the run (raised to
    /// `log_score` should rounding ever put it a hair below).
    pub bound: f64,
    /// `bound − log_score`.
    pub gap: f64,
    /// Iterations performed (forward plus backward pass each).
    pub iterations: usize,
    /// True for [`TrwsTermination::GapClosed`] and [`TrwsTermination::BoundSettled`].
    pub converged: bool,
    /// Why the run stopped.
    pub termination: TrwsTermination,
    /// `Some` when every decoded assignment had probability 0 and `assignment` is the
    /// one of positive probability found by
    /// [`support::positive_assignment_conditioned`] (guided by the messages) and
    /// improved by [`support::improve_locally`]: the best decoding and a factor it
    /// violates.
    pub zero_decoding: Option<ZeroDecoding>,
}

crate::checked_params! {
    /// Sequential tree-reweighted max-product with checked settings (build with
    /// [`TrwsParams`]).
    #[derive(Clone, Debug, PartialEq)]
    pub struct Trws(TrwsParams) -> Error;
}

impl Trws {
    /// Runs TRW-S on `graph`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when the order is not a permutation of the graph's
    /// variables; [`Error::Infeasible`] when the model has no assignment of positive
    /// probability (with the proof), or when every decoding scored −∞ and the search
    /// for a positive assignment met [`TrwsParams::search_limit`].
    pub fn run(&self, graph: &FactorGraph) -> Result<TrwsResult> {
        self.run_observed(graph, &mut ())
    }

    /// Runs TRW-S and reports every iteration (bound, scores, gap) to `observer`, which
    /// may stop the run.
    ///
    /// # Errors
    /// As [`run`](Self::run).
    pub fn run_observed(
        &self,
        graph: &FactorGraph,
        observer: &mut dyn Observe<TrwsProgress>,
    ) -> Result<TrwsResult> {
        let started = Instant::now();
        let order = self.order(graph)?;
        let mut state = State::new(graph, order);
        let n = graph.num_variables();
        let mut best_assignment: Vec<usize> = vec![0; n];
        let mut best_score = f64::NEG_INFINITY;
        let mut decoded = false;
        let mut best_bound = f64::INFINITY;
        let mut previous_bound = f64::INFINITY;
        let mut iterations = 0;
        let mut termination = TrwsTermination::IterationLimit;
        let mut infeasible = false;
        let tolerance = self.params.tolerance;
        let deadline = self.params.time_budget.map(|b| started + b);
        while iterations < self.params.max_iterations {
            let mut iteration_score = f64::NEG_INFINITY;
            let mut bound = f64::INFINITY;
            for forward in [true, false] {
                let decode = forward || self.params.decode_backward;
                let pass = state.pass(graph, forward, decode);
                if decode {
                    iteration_score = iteration_score.max(pass.score);
                }
                // The first decoding is kept even at −∞ (it is what a refusal names).
                if decode && (pass.score > best_score || !decoded) {
                    decoded = true;
                    best_score = pass.score;
                    best_assignment.copy_from_slice(&state.assignment);
                }
                bound = pass.bound;
                best_bound = best_bound.min(pass.bound);
                if pass.infeasible {
                    break;
                }
            }
            iterations += 1;
            infeasible = best_bound == f64::NEG_INFINITY;
            let gap = gap(best_bound, best_score);
            let scale = best_bound.abs().max(1.0);
            let progress = TrwsProgress {
                iteration: iterations,
                bound,
                iteration_log_score: iteration_score,
                log_score: best_score,
                gap,
                elapsed: started.elapsed(),
            };
            let stop = observer.observe(&progress);
            if infeasible {
                break;
            }
            if gap <= tolerance * scale {
                termination = TrwsTermination::GapClosed;
                break;
            }
            if previous_bound.is_finite() && previous_bound - bound <= tolerance * scale {
                termination = TrwsTermination::BoundSettled;
                break;
            }
            if let ControlFlow::Break(()) = stop {
                termination = TrwsTermination::Observer;
                break;
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                termination = TrwsTermination::TimeBudget;
                break;
            }
            previous_bound = bound;
        }
        // Score the result exactly as the graph does (the passes sum in another order).
        let mut log_score = graph.log_score_unchecked(&best_assignment);
        let mut zero_decoding = None;
        if log_score == f64::NEG_INFINITY {
            let refuse = |proof, dead_ends| {
                Error::Infeasible(Box::new(ZeroProbability::new(
                    graph,
                    Method::Trws,
                    best_assignment.clone(),
                    proof,
                    dead_ends,
                )))
            };
            if infeasible {
                return Err(refuse(Some(ZeroProof::DualBound), 0));
            }
            let message = |e: EdgeId| state.messages[graph.message_range(e)].to_vec();
            match support::positive_assignment_conditioned(
                graph,
                &message,
                self.params.search_limit,
            ) {
                Support::Positive(mut witness) => {
                    support::improve_locally(graph, &mut witness, support::POLISH_SWEEPS);
                    let decoded = std::mem::replace(&mut best_assignment, witness);
                    log_score = graph.log_score_unchecked(&best_assignment);
                    zero_decoding =
                        support::first_violation(graph, &decoded).map(|violated| ZeroDecoding {
                            assignment: decoded,
                            violated,
                        });
                }
                Support::Empty(proof) => {
                    let dead_ends = match proof {
                        ZeroProof::Search { dead_ends } => dead_ends,
                        _ => 0,
                    };
                    return Err(refuse(Some(proof), dead_ends));
                }
                Support::Undecided { dead_ends } => return Err(refuse(None, dead_ends)),
            }
        }
        let bound = best_bound.max(log_score);
        Ok(TrwsResult {
            assignment: best_assignment,
            log_score,
            bound,
            gap: gap(bound, log_score),
            iterations,
            converged: matches!(
                termination,
                TrwsTermination::GapClosed | TrwsTermination::BoundSettled
            ),
            termination,
            zero_decoding,
        })
    }

    fn order(&self, graph: &FactorGraph) -> Result<Vec<usize>> {
        let n = graph.num_variables();
        match &self.params.order {
            None => Ok((0..n).collect()),
            Some(order) => {
                let mut seen = vec![false; n];
                let ok = order.len() == n
                    && order
                        .iter()
                        .all(|v| v.0 < n && !std::mem::replace(&mut seen[v.0], true));
                if !ok {
                    return Err(Error::InvalidParameter {
                        name: "TRW-S order",
                        value: format!("{} entries for {n} variables", order.len()),
                        expected: "each variable of the graph exactly once",
                    });
                }
                Ok(order.iter().map(|v| v.0).collect())
            }
        }
    }
}

/// `bound − score`, 0 when both are −∞ (nothing feasible: nothing to gain).
fn gap(bound: f64, score: f64) -> f64 {
    if bound == f64::NEG_INFINITY {
        0.0
    } else {
        bound - score
    }
}

/// What one pass produced.
struct PassOutcome {
    /// Dual bound after the pass.
    bound: f64,
    /// Log-score of the assignment decoded in the pass.
    score: f64,
    /// True when the pass proved that no assignment has a finite log-score.
    infeasible: bool,
}

/// One factor of arity ≥ 2 at one variable.
#[derive(Clone, Copy, Debug)]
struct Incidence {
    /// The factor and the variable's scope position in it.
    factor: usize,
    slot: usize,
    /// Where the edge's message starts in `messages`.
    message: usize,
    /// For a pairwise factor: the other variable and where the other edge's message
    /// starts; `usize::MAX` for higher arities.
    other_variable: usize,
    other_message: usize,
    /// The factor holds a variable earlier / later in the order.
    reaches_back: bool,
    reaches_ahead: bool,
}

impl Incidence {
    /// The factor sends to this variable in the pass (it reaches back against it).
    #[inline]
    fn receives(&self, forward: bool) -> bool {
        if forward {
            self.reaches_back
        } else {
            self.reaches_ahead
        }
    }

    /// The variable is the factor's last in the pass.
    #[inline]
    fn closes(&self, forward: bool) -> bool {
        if forward {
            !self.reaches_ahead
        } else {
            !self.reaches_back
        }
    }
}

/// Per-run structure and messages.
struct State {
    order: Vec<usize>,
    cardinality: Vec<usize>,
    /// Start of each variable's block in `theta` and `theta_hat`.
    variable_offset: Vec<usize>,
    /// Sum of the unary factors of each variable.
    theta: Vec<f64>,
    /// Reparametrised unaries `θ̂_i`, as of the variable's last visit.
    theta_hat: Vec<f64>,
    /// Sum of the log-potentials of factors with an empty scope.
    constant: f64,
    /// γ_i = 1 / max(#backward, #forward factors of arity ≥ 2).
    gamma: Vec<f64>,
    /// Weight of `max θ̂_i` in the bound after a forward / backward pass.
    weight_forward: Vec<f64>,
    weight_backward: Vec<f64>,
    /// The incidences of factors of arity ≥ 2 at each variable, contiguous per
    /// variable (CSR: `variable_edges_start`).
    variable_edges: Vec<Incidence>,
    variable_edges_start: Vec<usize>,
    /// Factors of arity ≥ 2.
    big_factors: Vec<usize>,
    /// Factor-to-variable messages `m_{α→i}`, normalised to maximum 0.
    messages: Vec<f64>,
    /// Per factor: the normalising constant of its last message in the current pass.
    factor_constant: Vec<f64>,
    /// Per factor: offsets of its scope positions in `incoming` (CSR: `factor_offsets_start`).
    factor_offsets: Vec<usize>,
    factor_offsets_start: Vec<usize>,
    /// Scratch: incoming messages of one factor, one message out, one decoding score.
    incoming: Vec<f64>,
    out: Vec<f64>,
    score: Vec<f64>,
    closing: Vec<f64>,
    /// Decoded states and the pass in which each variable was last decoded.
    assignment: Vec<usize>,
    decoded_in: Vec<usize>,
    passes: usize,
}

impl State {
    fn new(graph: &FactorGraph, order: Vec<usize>) -> Self {
        let n = graph.num_variables();
        let mut position = vec![0; n];
        for (p, &v) in order.iter().enumerate() {
            position[v] = p;
        }
        let cardinality = graph.cardinalities().to_vec();
        let mut variable_offset = Vec::with_capacity(n + 1);
        let mut total = 0;
        for &k in &cardinality {
            variable_offset.push(total);
            total += k;
        }
        variable_offset.push(total);
        let mut theta = vec![0.0; total];
        let mut constant = 0.0;
        let mut factor_offsets = Vec::new();
        let mut factor_offsets_start = Vec::with_capacity(graph.num_factors() + 1);
        let mut first_position = vec![usize::MAX; graph.num_factors()];
        let mut last_position = vec![0; graph.num_factors()];
        let mut largest_scope = 0;
        for (a, factor) in graph.factors().enumerate() {
            factor_offsets_start.push(factor_offsets.len());
            let scope = factor.scope();
            match scope.len() {
                0 => constant += factor.log_potential(&[]),
                1 => {
                    let v = scope[0].0;
                    let t = &mut theta[variable_offset[v]..variable_offset[v + 1]];
                    for (x, value) in t.iter_mut().zip(factor.log_table()) {
                        *x += value;
                    }
                }
                _ => {
                    let mut offset = 0;
                    factor_offsets.push(0);
                    for v in scope {
                        offset += cardinality[v.0];
                        factor_offsets.push(offset);
                        first_position[a] = first_position[a].min(position[v.0]);
                        last_position[a] = last_position[a].max(position[v.0]);
                    }
                    largest_scope = largest_scope.max(offset);
                }
            }
        }
        factor_offsets_start.push(factor_offsets.len());
        let mut variable_edges = Vec::new();
        let mut variable_edges_start = Vec::with_capacity(n + 1);
        let mut gamma = vec![1.0; n];
        let mut weight_forward = vec![1.0; n];
        let mut weight_backward = vec![1.0; n];
        for v in 0..n {
            variable_edges_start.push(variable_edges.len());
            let (mut back, mut ahead) = (0usize, 0usize);
            for &e in graph.variable_edges(VariableId(v)) {
                let a = graph.edge_factor(e).0;
                let edges = graph.factor_edges(FactorId(a));
                if edges.len() < 2 {
                    continue;
                }
                let (other_variable, other_message) = if edges.len() == 2 {
                    let other = EdgeId(edges.start + edges.end - 1 - e.0);
                    (
                        graph.edge_variable(other).0,
                        graph.message_range(other).start,
                    )
                } else {
                    (usize::MAX, usize::MAX)
                };
                let incidence = Incidence {
                    factor: a,
                    slot: graph.edge_slot(e),
                    message: graph.message_range(e).start,
                    other_variable,
                    other_message,
                    reaches_back: first_position[a] < position[v],
                    reaches_ahead: last_position[a] > position[v],
                };
                back += usize::from(incidence.reaches_back);
                ahead += usize::from(incidence.reaches_ahead);
                variable_edges.push(incidence);
            }
            let chains = back.max(ahead);
            if chains > 0 {
                gamma[v] = 1.0 / chains as f64;
                weight_forward[v] = (chains - ahead) as f64 / chains as f64;
                weight_backward[v] = (chains - back) as f64 / chains as f64;
            }
        }
        variable_edges_start.push(variable_edges.len());
        let max_card = cardinality.iter().copied().max().unwrap_or(0);
        Self {
            order,
            theta_hat: theta.clone(),
            theta,
            constant,
            gamma,
            weight_forward,
            weight_backward,
            variable_edges,
            variable_edges_start,
            big_factors: (0..graph.num_factors())
                .filter(|&a| graph.factor_edges(FactorId(a)).len() >= 2)
                .collect(),
            messages: vec![0.0; graph.message_len()],
            factor_constant: vec![0.0; graph.num_factors()],
            factor_offsets,
            factor_offsets_start,
            incoming: vec![0.0; largest_scope],
            out: vec![0.0; max_card],
            score: vec![0.0; max_card],
            closing: vec![0.0; max_card],
            assignment: vec![0; n],
            decoded_in: vec![usize::MAX; n],
            passes: 0,
            variable_offset,
            cardinality,
        }
    }

    /// Fills `incoming` for the factor of `at` towards its variable: variables decoded
    /// in this pass (with `decode`) as indicators, the others as the reweighted
    /// variable-to-factor messages `n_{j→α} = γ_j θ̂_j − m_{α→j}`.
    fn fill_incoming(&mut self, graph: &FactorGraph, at: Incidence, decode: bool) {
        let a = at.factor;
        let offsets = self.factor_offsets_start[a];
        if at.other_variable != usize::MAX {
            let slot = 1 - at.slot;
            let offset = self.factor_offsets[offsets + slot];
            self.fill_variable(offset, at.other_variable, at.other_message, decode);
            return;
        }
        for (slot, e) in graph.factor_edges(FactorId(a)).enumerate() {
            if slot == at.slot {
                continue;
            }
            let u = graph.edge_variable(EdgeId(e)).0;
            let message = graph.message_range(EdgeId(e)).start;
            let offset = self.factor_offsets[offsets + slot];
            self.fill_variable(offset, u, message, decode);
        }
    }

    /// Writes variable `u`'s part of `incoming`, from `offset`: its indicator when it
    /// was decoded in this pass (with `decode`), else its reweighted
    /// variable-to-factor message, whose factor-to-variable message starts at
    /// `message`.
    #[inline]
    fn fill_variable(&mut self, offset: usize, u: usize, message: usize, decode: bool) {
        let k = self.cardinality[u];
        let dst = &mut self.incoming[offset..offset + k];
        if decode && self.decoded_in[u] == self.passes {
            indicator(dst, self.assignment[u]);
        } else {
            let start = self.variable_offset[u];
            reweighted(
                dst,
                &self.theta_hat[start..start + k],
                &self.messages[message..message + k],
                self.gamma[u],
            );
        }
    }

    /// Computes the message of the factor of `at` to its variable into `out[..k]`.
    #[inline]
    fn factor_message(&mut self, graph: &FactorGraph, at: Incidence, k: usize) {
        let a = at.factor;
        let offsets =
            &self.factor_offsets[self.factor_offsets_start[a]..self.factor_offsets_start[a + 1]];
        let incoming = Incoming::new(&self.incoming, offsets);
        graph
            .factor(FactorId(a))
            .message(at.slot, &incoming, Mode::MaxProduct, &mut self.out[..k]);
    }

    /// One forward or backward pass; with `decode`, decodes an assignment into
    /// `self.assignment` and returns its log-score.
    fn pass(&mut self, graph: &FactorGraph, forward: bool, decode: bool) -> PassOutcome {
        self.passes += 1;
        let n = self.order.len();
        let mut outcome = PassOutcome {
            bound: self.constant,
            score: self.constant,
            infeasible: false,
        };
        for step in 0..n {
            let i = if forward {
                self.order[step]
            } else {
                self.order[n - 1 - step]
            };
            // Few states: the same code with the state count fixed at compile time,
            // so the many short loops over states unroll.
            with_small_states!(
                self.cardinality[i],
                K => self.visit::<K>(graph, i, forward, decode, &mut outcome),
                self.visit::<0>(graph, i, forward, decode, &mut outcome),
            )
        }
        let PassOutcome {
            mut bound,
            score,
            infeasible,
        } = outcome;
        if infeasible {
            bound = f64::NEG_INFINITY;
        } else {
            for &a in &self.big_factors {
                bound += self.factor_constant[a];
            }
        }
        PassOutcome {
            bound,
            score,
            infeasible,
        }
    }

    /// Computes the message of the factor of `at` to its variable (`k` states) into
    /// `out[..k]`, from the reweighted messages of the factor's other variables (or,
    /// with `decode`, indicators of those decoded in this pass). Pairwise factors whose
    /// other variable has `STATES` states get loops of fixed length.
    #[inline(always)]
    fn incoming_message<const STATES: usize>(
        &mut self,
        graph: &FactorGraph,
        at: Incidence,
        k: usize,
        decode: bool,
    ) {
        if at.other_variable == usize::MAX {
            self.fill_incoming(graph, at, decode);
            self.factor_message(graph, at, k);
            return;
        }
        let u = at.other_variable;
        let other = self.cardinality[u];
        let total = k + other;
        let (offsets, position) = if at.slot == 0 {
            ([0, k, total], k)
        } else {
            ([0, other, total], 0)
        };
        let dst = &mut self.incoming[position..position + other];
        if decode && self.decoded_in[u] == self.passes {
            indicator(dst, self.assignment[u]);
        } else {
            let start = self.variable_offset[u];
            let theta_hat = &self.theta_hat[start..start + other];
            let message = &self.messages[at.other_message..at.other_message + other];
            if STATES != 0 && other == STATES {
                reweighted(
                    &mut dst[..STATES],
                    &theta_hat[..STATES],
                    &message[..STATES],
                    self.gamma[u],
                );
            } else {
                reweighted(dst, theta_hat, message, self.gamma[u]);
            }
        }
        let incoming = Incoming::new(&self.incoming[..total], &offsets);
        graph.factor(FactorId(at.factor)).message(
            at.slot,
            &incoming,
            Mode::MaxProduct,
            &mut self.out[..k],
        );
    }

    /// Visits variable `i` in a pass: receives, recomputes `θ̂_i`, adds to the bound,
    /// decodes. `STATES` is the variable's state count when fixed at compile time, 0
    /// when read at run time.
    #[inline(always)]
    fn visit<const STATES: usize>(
        &mut self,
        graph: &FactorGraph,
        i: usize,
        forward: bool,
        decode: bool,
        outcome: &mut PassOutcome,
    ) {
        let k = if STATES == 0 {
            self.cardinality[i]
        } else {
            STATES
        };
        let (start, end) = (
            self.variable_edges_start[i],
            self.variable_edges_start[i + 1],
        );
        // 1. Messages from the factors that reach back in this pass.
        for index in start..end {
            let at = self.variable_edges[index];
            if !at.receives(forward) {
                continue;
            }
            self.incoming_message::<STATES>(graph, at, k, false);
            let out = &self.out[..k];
            let c = crate::logspace::max(out);
            let m = &mut self.messages[at.message..at.message + k];
            if c.is_finite() {
                for (m, &o) in m.iter_mut().zip(out) {
                    *m = o - c;
                }
            } else {
                // No state of the variable is feasible for this factor.
                outcome.infeasible = true;
                m.iter_mut().for_each(|m| *m = f64::NEG_INFINITY);
            }
            if at.closes(forward) {
                self.factor_constant[at.factor] = c;
            }
        }
        // 2. The reparametrised unary.
        let block = self.variable_offset[i]..self.variable_offset[i + 1];
        {
            let theta_hat = &mut self.theta_hat[block.clone()];
            theta_hat.copy_from_slice(&self.theta[block.clone()]);
            for at in &self.variable_edges[start..end] {
                let m = &self.messages[at.message..at.message + k];
                for (t, &m) in theta_hat.iter_mut().zip(m) {
                    *t += m;
                }
            }
        }
        let best = crate::logspace::max(&self.theta_hat[block.clone()]);
        if best == f64::NEG_INFINITY {
            outcome.infeasible = true;
        } else {
            let w = if forward {
                self.weight_forward[i]
            } else {
                self.weight_backward[i]
            };
            outcome.bound += w * best;
        }
        if !decode {
            return;
        }
        // 3. Decoding, conditioned on the variables decoded earlier in this pass.
        self.score[..k].copy_from_slice(&self.theta[block.clone()]);
        self.closing[..k].copy_from_slice(&self.theta[block.clone()]);
        for index in start..end {
            let at = self.variable_edges[index];
            if at.receives(forward) {
                self.incoming_message::<STATES>(graph, at, k, true);
                for (s, &o) in self.score[..k].iter_mut().zip(&self.out[..k]) {
                    *s += o;
                }
                if at.closes(forward) {
                    // Every other variable of the factor is decoded: `out` is θ_α
                    // at their states, a term of the assignment's log-score.
                    for (s, &o) in self.closing[..k].iter_mut().zip(&self.out[..k]) {
                        *s += o;
                    }
                }
            } else {
                let m = &self.messages[at.message..at.message + k];
                for (s, &m) in self.score[..k].iter_mut().zip(m) {
                    *s += m;
                }
            }
        }
        let x = first_argmax(&self.score[..k]);
        self.assignment[i] = x;
        self.decoded_in[i] = self.passes;
        outcome.score += self.closing[x];
    }
}

/// An indicator log-vector: 0 at `state`, −∞ elsewhere.
#[inline(always)]
fn indicator(dst: &mut [f64], state: usize) {
    dst.iter_mut().for_each(|d| *d = f64::NEG_INFINITY);
    dst[state] = 0.0;
}

/// `dst = γ θ̂ − m`, −∞ where `θ̂` is −∞ (an infeasible state; `m` is finite wherever
/// `θ̂` is, as `θ̂` includes `m`).
#[inline(always)]
fn reweighted(dst: &mut [f64], theta_hat: &[f64], message: &[f64], gamma: f64) {
    for ((d, &t), &m) in dst.iter_mut().zip(theta_hat).zip(message) {
        *d = if t == f64::NEG_INFINITY {
            f64::NEG_INFINITY
        } else {
            gamma * t - m
        };
    }
}
