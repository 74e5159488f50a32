//! Hybrid discrete/continuous inference: "observed-continuous" nodes.
//!
//! Both CRF papers couple the discrete labels to continuous variables (per-cluster
//! rigid motions `R`, `T`). The joint-model paper (van de Ven, Ramos and Tipaldi,
//! section IV-B, Algorithm 1, Fig. 2) treats such a node as *observed* while messages
//! pass, recomputes it in closed form from the current discrete state after node
//! visits, and recomputes every local feature that depends on it when its variable is
//! next visited. This module makes that a generic mechanism of the engine:
//!
//! - a [`ContinuousModel`] owns the continuous nodes: it receives every change of an
//!   attached variable's state (its current MAP label or its belief) as an O(1)
//!   incremental update of sufficient statistics, solves for its values in closed form,
//!   and refreshes the potentials of the factors that depend on them;
//! - [`HybridInference`] runs the loopy engine with a hook that refreshes stale
//!   dependent factors before each visit (so outgoing messages reflect the latest
//!   values, Fig. 2 right), feeds state changes to the model after each visit, and
//!   re-solves the continuous values by the [`UpdatePolicy`]: after every visit
//!   (Algorithm 1, line 10), after every sweep, every k visits, or never (frozen);
//! - convergence means stable messages *and* stable continuous values, and the final
//!   decoding re-solves the values once more, refreshes the potentials and decodes
//!   against them (Algorithm 1, lines 16-21).
//!
//! [`ClusterMeans`] is a small reference model (1-D cluster means) used in the docs and
//! tests; `examples/hybrid_motions.rs` couples a chain CRF to several rigid motions.

pub mod chain;
mod flat_chain;
mod means;
mod pair_pattern;

pub use flat_chain::FlatChain;
pub use means::ClusterMeans;
pub use pair_pattern::PairPattern;

use crate::bp::{decode_map, first_argmax, BeliefPropagation, BpResult, Messages};
use crate::error::Result;
use crate::factor::Mode;
use crate::graph::{FactorGraph, FactorId, VariableId};
use crate::hook::{Potentials, UpdateHook};
use crate::logspace;
use crate::schedule::{Schedule, Visit};

/// What summary of a discrete variable the continuous nodes are computed from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiscreteSummary {
    /// The variable's current MAP label (argmax of its belief; lowest index on ties).
    MapLabels,
    /// The variable's current belief (probabilities).
    Beliefs,
}

/// The state of one discrete variable as seen by the continuous nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VariableState<'a> {
    /// A hard label.
    Label(usize),
    /// A belief (probabilities summing to one).
    Belief(&'a [f64]),
}

/// When the continuous values are re-solved during message passing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdatePolicy {
    /// After every variable (or edge, or factor) visit: Algorithm 1, line 10.
    EveryVisit,
    /// After every `k` visits.
    EveryVisits(usize),
    /// After every iteration (sweep), from the consistently decoded MAP labels
    /// ([`decode_map`]) or the beliefs.
    EverySweep,
    /// Only when the schedule asks for it
    /// ([`MessagePasser::update_continuous`](crate::MessagePasser::update_continuous)),
    /// so a user-defined schedule interleaves continuous updates as it likes.
    OnRequest,
    /// Never during message passing: the values stay as they are (plain BP on the
    /// current potentials). The final decoding does not re-solve either.
    Frozen,
}

/// The continuous part of a hybrid model. Implement this for your continuous nodes.
pub trait ContinuousModel: Send {
    /// Which summary of the discrete variables the nodes are computed from.
    fn summary(&self) -> DiscreteSummary;

    /// The state of attached variable `v` changed from `old` (`None` the first time)
    /// to `new`. Update sufficient statistics here, in O(1) per affected node.
    /// Variables the model does not attach to may be ignored.
    fn update_variable(
        &mut self,
        v: VariableId,
        old: Option<VariableState<'_>>,
        new: VariableState<'_>,
    );

    /// Re-solves every continuous value in closed form from the statistics; returns
    /// the largest change of any value (the continuous part's residual).
    fn solve(&mut self) -> f64;

    /// The factors whose potentials depend on the continuous values and that must be
    /// refreshed before variable `v` is visited.
    fn dependent_factors(&self, v: VariableId) -> &[FactorId];

    /// Recomputes the potentials of dependent factor `a` from the current values.
    fn refresh_factor(&self, a: FactorId, potentials: &mut Potentials<'_>) -> Result<()>;

    /// Every dependent factor (default: the union over variables; override when cheaper).
    fn all_dependent_factors(&self, graph: &FactorGraph) -> Vec<FactorId> {
        let mut all: Vec<FactorId> = (0..graph.num_variables())
            .flat_map(|v| self.dependent_factors(VariableId(v)).iter().copied())
            .collect();
        all.sort_unstable();
        all.dedup();
        all
    }
}

/// The outcome of hybrid inference.
#[derive(Clone, Debug)]
pub struct HybridResult {
    /// The discrete result, decoded against the final continuous values.
    pub discrete: BpResult,
    /// Whether the messages converged (within the engine's tolerance).
    pub messages_converged: bool,
    /// Whether the continuous values converged (last change within tolerance).
    pub continuous_converged: bool,
    /// The last change of the continuous values.
    pub continuous_change: f64,
    /// How many times the continuous values were solved.
    pub solves: usize,
    /// Joint log-score of the final assignment under the final continuous values.
    pub joint_log_score: f64,
    /// With [`HybridInference::trace_scores`] and [`UpdatePolicy::EverySweep`]: after
    /// each sweep, the joint log-score of the decoded labels under the values solved
    /// from them (coordinate ascent makes this non-decreasing on trees).
    pub sweep_scores: Vec<f64>,
}

/// Loopy BP with observed-continuous nodes. See the module documentation.
///
/// ```
/// use pgm_core::hybrid::{ClusterMeans, HybridInference, UpdatePolicy};
/// use pgm_core::{BpParams, Mode, ParamGuard, Sequential};
///
/// // Twelve observations from two clusters, a chain CRF that likes equal neighbours,
/// // and the two cluster means as continuous nodes initialised badly.
/// let y = [0.1, -0.2, 0.0, 0.2, 0.1, -0.1, 5.1, 4.9, 5.0, 5.2, 4.8, 5.0];
/// let (mut graph, mut means) = ClusterMeans::chain(&y, &[1.0, 2.0], 2.0, 1.0).unwrap();
/// let result = HybridInference::new(BpParams::new(Mode::MaxProduct).check().unwrap(), UpdatePolicy::EverySweep)
///     .run(&mut graph, &mut means, &mut Sequential::default(), None)
///     .unwrap();
/// assert_eq!(result.discrete.assignment, vec![0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1]);
/// assert!((means.means()[1] - 5.0).abs() < 1e-9);
/// assert!(result.continuous_converged);
/// ```
#[derive(Clone, Debug)]
pub struct HybridInference {
    bp: BeliefPropagation,
    policy: UpdatePolicy,
    continuous_tolerance: f64,
    trace: bool,
}

impl HybridInference {
    /// Hybrid inference with the given engine settings and update policy; the
    /// continuous tolerance defaults to 1e-9.
    pub fn new(bp: BeliefPropagation, policy: UpdatePolicy) -> Self {
        Self {
            bp,
            policy,
            continuous_tolerance: 1e-9,
            trace: false,
        }
    }

    /// Records the joint log-score after every sweep (costs a refresh of every dependent
    /// factor per sweep).
    pub fn trace_scores(mut self, trace: bool) -> Self {
        self.trace = trace;
        self
    }

    /// Largest change of the continuous values that still counts as converged.
    pub fn continuous_tolerance(mut self, tolerance: f64) -> Self {
        self.continuous_tolerance = tolerance;
        self
    }

    /// Runs hybrid inference. `initial_labels`, when given, initialise the continuous
    /// values (Algorithm 1, line 1: every variable is fed to the model as that label and
    /// the values are solved once); otherwise the model's current values are used.
    pub fn run<S: Schedule + ?Sized>(
        &self,
        graph: &mut FactorGraph,
        model: &mut dyn ContinuousModel,
        schedule: &mut S,
        initial_labels: Option<&[usize]>,
    ) -> Result<HybridResult> {
        if let UpdatePolicy::EveryVisits(0) = self.policy {
            return Err(crate::Error::InvalidParameter {
                name: "update policy",
                value: "EveryVisits(0)".into(),
                expected: "a visit count of at least 1",
            });
        }
        let summary = model.summary();
        let mut hook = HybridHook {
            model,
            policy: self.policy,
            mode: self.bp.mode(),
            summary,
            states: vec![None; graph.num_variables()],
            factor_version: vec![u64::MAX; graph.num_factors()],
            value_version: 0,
            visits: 0,
            solves: 0,
            last_change: 0.0,
            tolerance: self.continuous_tolerance,
            error: None,
            trace: self.trace,
            scores: Vec::new(),
            belief: Vec::new(),
        };
        if let Some(labels) = initial_labels {
            graph.check_assignment(labels)?;
            for (v, &l) in labels.iter().enumerate() {
                hook.set_state(VariableId(v), StoredState::Label(l));
            }
            hook.solve();
        }
        // Bring every dependent factor up to date with the starting values.
        let dependent = hook.model.all_dependent_factors(graph);
        {
            let mut p = Potentials::new(graph);
            for &a in &dependent {
                hook.refresh(a, &mut p);
            }
        }
        let mut propagation = self.bp.with_hook(graph, &mut hook).propagate(schedule)?;
        if let Some(e) = hook.error.take() {
            return Err(e);
        }
        let messages_converged = propagation.residual <= self.bp_tolerance();
        // Algorithm 1, lines 16-21: re-solve from the decoded state, refresh, decode.
        if self.policy != UpdatePolicy::Frozen {
            let _ = hook.sync_all(graph, &propagation.messages);
            hook.solve();
            let mut p = Potentials::new(graph);
            for &a in &dependent {
                hook.refresh(a, &mut p);
            }
            if let Some(e) = hook.error.take() {
                return Err(e);
            }
            propagation.messages =
                refresh_single_variable_messages(graph, propagation.messages, self.bp.mode());
        }
        let continuous_change = hook.last_change;
        let continuous_converged = continuous_change <= self.continuous_tolerance;
        let discrete = self.bp.finish(graph, propagation);
        let joint_log_score = discrete.log_score;
        Ok(HybridResult {
            discrete,
            messages_converged,
            continuous_converged,
            continuous_change,
            solves: hook.solves,
            joint_log_score,
            sweep_scores: hook.scores,
        })
    }

    fn bp_tolerance(&self) -> f64 {
        self.bp.params().tolerance_value()
    }
}

/// Recomputes the messages of single-variable factors (whose potentials may have been
/// refreshed) so decoding sees the refreshed local evidence.
fn refresh_single_variable_messages(
    graph: &FactorGraph,
    mut messages: Messages,
    mode: Mode,
) -> Messages {
    let how = match mode {
        Mode::MaxProduct => logspace::Normalisation::Max,
        Mode::SumProduct => logspace::Normalisation::Sum,
    };
    for a in 0..graph.num_factors() {
        let f = graph.factor(FactorId(a));
        if f.scope().len() != 1 {
            continue;
        }
        let e = crate::EdgeId(graph.factor_edges(FactorId(a)).start);
        let mut out = f.log_table();
        logspace::normalise(&mut out, how);
        messages.set_message(graph, e, &out);
    }
    messages
}

#[derive(Clone, Debug, PartialEq)]
enum StoredState {
    Label(usize),
    Belief(Vec<f64>),
}

impl StoredState {
    fn view(&self) -> VariableState<'_> {
        match self {
            StoredState::Label(l) => VariableState::Label(*l),
            StoredState::Belief(b) => VariableState::Belief(b),
        }
    }
}

struct HybridHook<'m> {
    model: &'m mut dyn ContinuousModel,
    policy: UpdatePolicy,
    mode: Mode,
    summary: DiscreteSummary,
    states: Vec<Option<StoredState>>,
    factor_version: Vec<u64>,
    value_version: u64,
    visits: usize,
    solves: usize,
    last_change: f64,
    tolerance: f64,
    error: Option<crate::Error>,
    trace: bool,
    scores: Vec<f64>,
    /// Scratch buffer for beliefs.
    belief: Vec<f64>,
}

impl HybridHook<'_> {
    fn set_state(&mut self, v: VariableId, new: StoredState) {
        let old = self.states[v.0].take();
        if old.as_ref() != Some(&new) {
            self.model
                .update_variable(v, old.as_ref().map(|o| o.view()), new.view());
        }
        self.states[v.0] = Some(new);
    }

    fn current_state(
        &self,
        graph: &FactorGraph,
        messages: &Messages,
        v: VariableId,
    ) -> StoredState {
        match self.summary {
            DiscreteSummary::MapLabels => {
                StoredState::Label(first_argmax(&messages.log_belief(graph, v)))
            }
            DiscreteSummary::Beliefs => StoredState::Belief(messages.belief(graph, v)),
        }
    }

    /// Feeds every variable's decoded state to the model; returns the decoded labels.
    fn sync_all(&mut self, graph: &FactorGraph, messages: &Messages) -> Vec<usize> {
        let labels: Vec<usize> = match self.mode {
            Mode::MaxProduct => decode_map(graph, messages),
            Mode::SumProduct => (0..graph.num_variables())
                .map(|v| messages.argmax(graph, VariableId(v)))
                .collect(),
        };
        match self.summary {
            DiscreteSummary::MapLabels => {
                for (v, &l) in labels.iter().enumerate() {
                    self.set_state(VariableId(v), StoredState::Label(l));
                }
            }
            DiscreteSummary::Beliefs => {
                for v in 0..graph.num_variables() {
                    let s = self.current_state(graph, messages, VariableId(v));
                    self.set_state(VariableId(v), s);
                }
            }
        }
        labels
    }

    fn solve(&mut self) {
        self.last_change = self.model.solve();
        self.solves += 1;
        if self.last_change != 0.0 {
            self.value_version += 1;
        }
    }

    fn refresh(&mut self, a: FactorId, potentials: &mut Potentials<'_>) {
        if self.factor_version[a.0] == self.value_version {
            return;
        }
        if let Err(e) = self.model.refresh_factor(a, potentials) {
            self.error.get_or_insert(e);
        }
        self.factor_version[a.0] = self.value_version;
    }

    fn refresh_for(&mut self, visit: Visit, potentials: &mut Potentials<'_>) {
        match visit {
            Visit::Variable(v) => {
                for i in 0..self.model.dependent_factors(v).len() {
                    let a = self.model.dependent_factors(v)[i];
                    self.refresh(a, potentials);
                }
            }
            Visit::Factor(a) => self.refresh_if_dependent(a, potentials),
            Visit::Edge(e) => {
                let a = potentials.graph().edge_factor(e);
                self.refresh_if_dependent(a, potentials);
            }
            Visit::Flood => {
                let all = self.model.all_dependent_factors(potentials.graph());
                for a in all {
                    self.refresh(a, potentials);
                }
            }
        }
    }

    fn refresh_if_dependent(&mut self, a: FactorId, potentials: &mut Potentials<'_>) {
        let scope: Vec<VariableId> = potentials.graph().factor(a).scope().to_vec();
        if scope
            .iter()
            .any(|&v| self.model.dependent_factors(v).contains(&a))
        {
            self.refresh(a, potentials);
        }
    }

    /// Feeds the variables whose beliefs a visit changed to the model (a variable may
    /// be seen twice; unchanged states cost a comparison).
    fn update_touched(&mut self, visit: Visit, graph: &FactorGraph, messages: &Messages) {
        match visit {
            Visit::Variable(v) => {
                for &e in graph.variable_edges(v) {
                    for &u in graph.factor(graph.edge_factor(e)).scope() {
                        self.update_one(graph, messages, u);
                    }
                }
                self.update_one(graph, messages, v);
            }
            Visit::Factor(a) => {
                for &u in graph.factor(a).scope() {
                    self.update_one(graph, messages, u);
                }
            }
            Visit::Edge(e) => self.update_one(graph, messages, graph.edge_variable(e)),
            Visit::Flood => {}
        }
    }

    fn update_one(&mut self, graph: &FactorGraph, messages: &Messages, v: VariableId) {
        match self.summary {
            DiscreteSummary::MapLabels => {
                // Argmax of the belief without allocating.
                self.belief.clear();
                self.belief.resize(graph.cardinality(v), 0.0);
                for &e in graph.variable_edges(v) {
                    for (b, m) in self.belief.iter_mut().zip(messages.message(graph, e)) {
                        *b += m;
                    }
                }
                let label = first_argmax(&self.belief);
                if self.states[v.0] != Some(StoredState::Label(label)) {
                    self.set_state(v, StoredState::Label(label));
                }
            }
            DiscreteSummary::Beliefs => {
                let s = self.current_state(graph, messages, v);
                self.set_state(v, s);
            }
        }
    }
}

impl UpdateHook for HybridHook<'_> {
    fn before_visit(
        &mut self,
        visit: Visit,
        potentials: &mut Potentials<'_>,
        _messages: &Messages,
    ) {
        if self.policy != UpdatePolicy::Frozen {
            self.refresh_for(visit, potentials);
        }
    }

    fn after_visit(&mut self, visit: Visit, potentials: &mut Potentials<'_>, messages: &Messages) {
        let k = match self.policy {
            UpdatePolicy::EveryVisit => 1,
            UpdatePolicy::EveryVisits(k) => k,
            // Track state changes so the statistics are current when the schedule asks.
            UpdatePolicy::OnRequest => usize::MAX,
            UpdatePolicy::EverySweep | UpdatePolicy::Frozen => return,
        };
        self.update_touched(visit, potentials.graph(), messages);
        if visit == Visit::Flood {
            let _ = self.sync_all(potentials.graph(), messages);
        }
        self.visits += 1;
        if self.visits % k == 0 {
            self.solve();
        }
    }

    fn continuous_update(&mut self, _potentials: &mut Potentials<'_>, _messages: &Messages) {
        if self.policy != UpdatePolicy::Frozen {
            self.solve();
        }
    }

    fn after_iteration(
        &mut self,
        _iteration: usize,
        potentials: &mut Potentials<'_>,
        messages: &Messages,
    ) -> bool {
        match self.policy {
            UpdatePolicy::Frozen => true,
            UpdatePolicy::OnRequest => self.last_change <= self.tolerance,
            UpdatePolicy::EverySweep => {
                let labels = self.sync_all(potentials.graph(), messages);
                self.solve();
                if self.trace {
                    let all = self.model.all_dependent_factors(potentials.graph());
                    for a in all {
                        self.refresh(a, potentials);
                    }
                    self.scores
                        .push(potentials.graph().log_score_unchecked(&labels));
                }
                self.last_change <= self.tolerance
            }
            UpdatePolicy::EveryVisit | UpdatePolicy::EveryVisits(_) => {
                // Judge stability by one more solve from the current state.
                self.solve();
                self.last_change <= self.tolerance
            }
        }
    }
}
