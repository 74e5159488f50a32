//! The support of a factor graph: does some assignment have positive probability?
//!
//! A log-potential of −∞ is a hard zero. When every assignment hits one, the model
//! has `Z = 0`: there is no MAP assignment and no marginals (they cannot be
//! normalised). Local consistency does not reveal that on a loop — hard "not equal"
//! tables on a triangle with two colours are satisfiable one at a time and loopy
//! belief propagation converges happily to uniform beliefs — and loopy max-product can
//! also *decode* an assignment of probability 0 on a model that has positive ones.
//!
//! [`positive_assignment`] decides it: a depth-first search over the hard zeros that
//! maintains generalised arc consistency (every remaining state of every variable has
//! a supporting joint state of positive potential in each of its factors, computed by
//! [`Factor::message`](crate::Factor::message) in max-product form on 0/−∞ indicator
//! messages, so structured factors use their fast paths). Variables are branched on
//! in breadth-first order ([`FactorGraph::bfs_order`]), states in decreasing order of
//! a caller's preference (beliefs, reparametrised unaries), so on a feasible model the
//! first descent usually succeeds. The result is a witness ([`Support::Positive`]), a
//! proof that none exists ([`Support::Empty`]), or — the problem is NP-complete — no
//! verdict after a number of dead ends ([`Support::Undecided`]).
//!
//! Belief propagation ([`BpRun::run`](crate::BpRun::run)) and TRW-S
//! ([`Trws::run`](crate::Trws::run)) use it to refuse results of probability 0 with
//! [`Error::Infeasible`](crate::Error::Infeasible):
//!
//! ```
//! use pgm_core::support::{positive_assignment, Support, ZeroProof, DEFAULT_SEARCH_LIMIT};
//! use pgm_core::{BpParams, Error, FactorGraph, Mode, ParamGuard, PottsFactor, Sequential, VariableId};
//!
//! // Two colours on a triangle, neighbours must differ: Z = 0.
//! let mut g = FactorGraph::with_variables(&[2, 2, 2]).unwrap();
//! for (a, b) in [(0, 1), (1, 2), (0, 2)] {
//!     g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 2, f64::NEG_INFINITY, 0.0).unwrap()).unwrap();
//! }
//! assert!(matches!(
//!     positive_assignment(&g, None, DEFAULT_SEARCH_LIMIT),
//!     Support::Empty(ZeroProof::Search { .. })
//! ));
//! let marginals = BpParams::new(Mode::SumProduct).check_unwrap().run(&g, &mut Sequential::default());
//! let Err(Error::Infeasible(why)) = marginals else { panic!("normalised Z = 0") };
//! assert!(why.proof.is_some());
//! assert!(why.to_string().contains("cannot be normalised"));
//! ```

use crate::factor::{Incoming, Mode};
use crate::graph::{EdgeId, FactorGraph, FactorId, VariableId};
use std::collections::VecDeque;
use std::fmt;

/// Default number of dead ends [`positive_assignment`] may meet before it gives up
/// (what [`BpParams`](crate::BpParams) and [`TrwsParams`](crate::TrwsParams) use
/// unless told otherwise). Enough to prove `K_n` has no `(n−1)`-colouring up to
/// `n = 10`; a feasible model usually needs none.
pub const DEFAULT_SEARCH_LIMIT: u64 = 1 << 20;

/// Sweeps of [`improve_locally`] that belief propagation and TRW-S spend on a
/// fallback assignment.
pub const POLISH_SWEEPS: usize = 100;

/// A factor that is 0 (log-potential −∞) at an assignment.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Violation {
    /// Index of the factor in its graph.
    pub factor: usize,
    /// The factor's scope (variable indices).
    pub scope: Vec<usize>,
    /// The states of the scope in the assignment.
    pub states: Vec<usize>,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "factor {} (scope {:?}) is 0 at states {:?}",
            self.factor, self.scope, self.states
        )
    }
}

/// The first factor (in index order) that is 0 at `assignment`; `None` when the
/// assignment has positive probability. Panics when the assignment does not fit the
/// graph.
pub fn first_violation(graph: &FactorGraph, assignment: &[usize]) -> Option<Violation> {
    let mut states = Vec::new();
    for (a, factor) in graph.factors().enumerate() {
        states.clear();
        states.extend(factor.scope().iter().map(|v| assignment[v.0]));
        if factor.log_potential(&states) == f64::NEG_INFINITY {
            return Some(Violation {
                factor: a,
                scope: factor.scope().iter().map(|v| v.0).collect(),
                states: states.clone(),
            });
        }
    }
    None
}

/// Why no assignment has positive probability.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ZeroProof {
    /// A factor of empty scope is the constant 0.
    ConstantZero {
        /// The factor.
        factor: usize,
    },
    /// Arc consistency alone (no branching) removed every state of a variable.
    Propagation {
        /// The variable left without states.
        variable: usize,
        /// The factor that removed its last state.
        factor: usize,
    },
    /// A complete search: every branch ended with a variable without states.
    Search {
        /// Dead ends met.
        dead_ends: u64,
    },
    /// TRW-S's upper bound on the best log-score is −∞ (every state of some variable
    /// is excluded by the reparametrised model).
    DualBound,
}

impl fmt::Display for ZeroProof {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ZeroProof::ConstantZero { factor } => {
                write!(f, "factor {factor} is the constant 0")
            }
            ZeroProof::Propagation { variable, factor } => write!(
                f,
                "propagating the hard zeros leaves variable {variable} no state (factor {factor} \
                 is 0 at every remaining one)"
            ),
            ZeroProof::Search { dead_ends } => write!(
                f,
                "a complete search over the hard zeros ({dead_ends} dead end{}) finds every \
                 assignment zero in some factor",
                if *dead_ends == 1 { "" } else { "s" }
            ),
            ZeroProof::DualBound => write!(f, "the TRW-S upper bound on the log-score is -inf"),
        }
    }
}

/// What [`positive_assignment`] found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Support {
    /// An assignment of positive probability (finite log-score).
    Positive(Vec<usize>),
    /// No assignment has positive probability (`Z = 0`), and why.
    Empty(ZeroProof),
    /// The search met its limit of dead ends without a verdict.
    Undecided {
        /// Dead ends met.
        dead_ends: u64,
    },
}

/// The inference whose result was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Max-product belief propagation (MAP).
    MaxProduct,
    /// Sum-product belief propagation (marginals).
    SumProduct,
    /// TRW-S (MAP with a bound).
    Trws,
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Method::MaxProduct => "max-product belief propagation",
            Method::SumProduct => "sum-product belief propagation",
            Method::Trws => "TRW-S",
        })
    }
}

/// A result of probability 0, refused with [`Error::Infeasible`](crate::Error::Infeasible):
/// either the model has no assignment of positive probability (`proof` says why), or
/// the method's assignment has probability 0 and the search for a positive one gave
/// up (`proof` is `None`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ZeroProbability {
    /// The method.
    pub method: Method,
    /// Its assignment (the decoding; for sum-product the most probable states).
    pub assignment: Vec<usize>,
    /// A factor that is 0 at `assignment` (`None` only when the assignment has
    /// positive probability, which cannot happen with a proof).
    pub violated: Option<Violation>,
    /// Why `Z = 0`; `None` when the search met its limit without a verdict.
    pub proof: Option<ZeroProof>,
    /// Dead ends the search met.
    pub dead_ends: u64,
}

impl fmt::Display for ZeroProbability {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.method {
            Method::SumProduct => "assignment of most probable states",
            _ => "decoded assignment",
        };
        let violated = match &self.violated {
            Some(v) => format!(": {v}"),
            None => String::new(),
        };
        match &self.proof {
            Some(proof) => write!(
                f,
                "{}: no assignment has positive probability (Z = 0), so {}: {proof}; its {what} \
                 {:?} has probability 0{violated}",
                self.method,
                match self.method {
                    Method::SumProduct => "the marginals cannot be normalised",
                    _ => "there is no MAP assignment",
                },
                self.assignment,
            ),
            None => write!(
                f,
                "{}: its {what} {:?} has probability 0{violated}; the search for an assignment \
                 of positive probability gave up after {} dead ends, so the model may have none \
                 (a larger search limit decides it)",
                self.method, self.assignment, self.dead_ends,
            ),
        }
    }
}

/// A decoding of probability 0 that a result replaced (see
/// [`BpResult::zero_decoding`](crate::BpResult::zero_decoding) and
/// [`TrwsResult::zero_decoding`](crate::TrwsResult::zero_decoding)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ZeroDecoding {
    /// The assignment the method decoded.
    pub assignment: Vec<usize>,
    /// A factor that is 0 there.
    pub violated: Violation,
}

impl ZeroProbability {
    /// The refusal of `assignment` by `method`, with the search's verdict.
    pub(crate) fn new(
        graph: &FactorGraph,
        method: Method,
        assignment: Vec<usize>,
        proof: Option<ZeroProof>,
        dead_ends: u64,
    ) -> Self {
        Self {
            method,
            violated: first_violation(graph, &assignment),
            assignment,
            proof,
            dead_ends,
        }
    }
}

/// True when some factor has a log-potential of −∞ somewhere (without any, every
/// assignment has positive probability).
pub fn has_hard_zeros(graph: &FactorGraph) -> bool {
    graph.factors().any(|f| f.has_hard_zeros())
}

/// Searches for an assignment of positive probability (see the module
/// documentation). `preference(v)`, when given, scores the states of `v` (higher is
/// tried first; e.g. log-beliefs); without it states are tried in index order. The
/// search gives up after `max_dead_ends` dead ends ([`Support::Undecided`]). On a graph
/// without hard zeros it returns the preferred state of every variable at once.
pub fn positive_assignment(
    graph: &FactorGraph,
    preference: Option<&dyn Fn(VariableId) -> Vec<f64>>,
    max_dead_ends: u64,
) -> Support {
    let scores = |v: VariableId, _: &dyn Fn(VariableId) -> Option<usize>| match preference {
        Some(p) => p(v),
        None => Vec::new(),
    };
    search(graph, &scores, max_dead_ends)
}

/// [`positive_assignment`] guided by factor-to-variable messages, conditioned on the
/// variables already decided, as [`decode_map`](crate::decode_map) decodes: when the
/// search branches on `v`, state `x` scores the sum over `v`'s factors of the factor's
/// log-potential at `x` and the decided states when every other variable of the
/// factor is decided (so unary factors always count with their table), and of
/// `message(e)[x]` (the factor's message to `v` on edge `e`) otherwise. With
/// max-product messages the first descent follows the max-product decoding until it
/// would hit a hard zero.
pub fn positive_assignment_conditioned(
    graph: &FactorGraph,
    message: &dyn Fn(EdgeId) -> Vec<f64>,
    max_dead_ends: u64,
) -> Support {
    let scores = |v: VariableId, decided: &dyn Fn(VariableId) -> Option<usize>| {
        let mut score = vec![0.0; graph.cardinality(v)];
        let mut states = Vec::new();
        for &e in graph.variable_edges(v) {
            let factor = graph.factor(graph.edge_factor(e));
            let slot = graph.edge_slot(e);
            states.clear();
            let mut all = true;
            for (j, u) in factor.scope().iter().enumerate() {
                match decided(*u) {
                    Some(x) if j != slot => states.push(x),
                    _ if j == slot => states.push(0),
                    _ => {
                        all = false;
                        break;
                    }
                }
            }
            if all {
                for (x, s) in score.iter_mut().enumerate() {
                    states[slot] = x;
                    *s += factor.log_potential(&states);
                }
            } else {
                for (s, m) in score.iter_mut().zip(message(e)) {
                    *s += m;
                }
            }
        }
        score
    };
    search(graph, &scores, max_dead_ends)
}

/// Improves an assignment by iterated conditional modes: variables in breadth-first
/// order take, one at a time, the state of highest log-score given the others, until
/// a sweep changes nothing (at most `max_sweeps` sweeps). The log-score never
/// decreases, so an assignment of positive probability stays positive. Returns the
/// number of changes.
pub fn improve_locally(graph: &FactorGraph, assignment: &mut [usize], max_sweeps: usize) -> usize {
    let order = graph.bfs_order();
    let mut states = Vec::new();
    let mut changes = 0;
    for _ in 0..max_sweeps {
        let mut changed = false;
        for &v in &order {
            let k = graph.cardinality(v);
            if k < 2 {
                continue;
            }
            let mut score = vec![0.0; k];
            for &e in graph.variable_edges(v) {
                let factor = graph.factor(graph.edge_factor(e));
                let slot = graph.edge_slot(e);
                states.clear();
                states.extend(factor.scope().iter().map(|u| assignment[u.0]));
                for (x, s) in score.iter_mut().enumerate() {
                    states[slot] = x;
                    *s += factor.log_potential(&states);
                }
            }
            let current = assignment[v.0];
            let best = crate::bp::first_argmax(&score);
            // Strictly better only (by more than rounding), so sweeps terminate.
            let margin = 1e-12 * score[current].abs().max(1.0);
            if score[best] > score[current] + margin {
                assignment[v.0] = best;
                changes += 1;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    changes
}

/// Scores of the states of a variable, given the decided state of every variable.
type Scores<'a> = dyn Fn(VariableId, &dyn Fn(VariableId) -> Option<usize>) -> Vec<f64> + 'a;

fn search(graph: &FactorGraph, scores: &Scores<'_>, max_dead_ends: u64) -> Support {
    if !has_hard_zeros(graph) {
        // Every assignment is positive: the preferred state of each variable, decided
        // in breadth-first order.
        let mut decided: Vec<Option<usize>> = vec![None; graph.num_variables()];
        for v in graph.bfs_order() {
            let x = ordered_states(graph, v, scores, &|u: VariableId| decided[u.0])[0];
            decided[v.0] = Some(x);
        }
        return Support::Positive(decided.into_iter().map(|x| x.unwrap_or(0)).collect());
    }
    Search::new(graph).run(scores, max_dead_ends)
}

/// The states of `v` by decreasing score (ties and missing scores in index order,
/// NaN last).
fn ordered_states(
    graph: &FactorGraph,
    v: VariableId,
    scores: &Scores<'_>,
    decided: &dyn Fn(VariableId) -> Option<usize>,
) -> Vec<usize> {
    let mut states: Vec<usize> = (0..graph.cardinality(v)).collect();
    let s = scores(v, decided);
    if !s.is_empty() {
        let key = |x: usize| {
            s.get(x)
                .copied()
                .filter(|z| !z.is_nan())
                .unwrap_or(f64::NEG_INFINITY)
        };
        // Stable: ties keep the lower index first.
        states.sort_by(|&a, &b| key(b).total_cmp(&key(a)));
    }
    states
}

/// How the search of one component ended.
enum Outcome {
    Solved,
    Exhausted,
    GaveUp,
}

/// The connected components of the graph, each in breadth-first order from its
/// lowest-indexed variable (together: [`FactorGraph::bfs_order`]).
fn components(graph: &FactorGraph) -> Vec<Vec<usize>> {
    let n = graph.num_variables();
    let mut seen = vec![false; n];
    let mut out = Vec::new();
    for root in 0..n {
        if seen[root] {
            continue;
        }
        seen[root] = true;
        let mut order = vec![root];
        let mut head = 0;
        while head < order.len() {
            let v = order[head];
            head += 1;
            for &e in graph.variable_edges(VariableId(v)) {
                for u in graph.factor(graph.edge_factor(e)).scope() {
                    if !seen[u.0] {
                        seen[u.0] = true;
                        order.push(u.0);
                    }
                }
            }
        }
        out.push(order);
    }
    out
}

/// One branching decision of the search.
struct Frame {
    /// Position of the variable in the branching order.
    position: usize,
    /// Its candidate states: `candidates[start..end]`, the next one at `next`.
    start: usize,
    next: usize,
    end: usize,
    /// Length of the trail when the frame was entered.
    trail: usize,
}

struct Search<'g> {
    graph: &'g FactorGraph,
    /// Start of each variable's states in `alive`.
    offset: Vec<usize>,
    alive: Vec<bool>,
    count: Vec<usize>,
    /// The remaining state of each variable with exactly one, else `usize::MAX`.
    decided: Vec<usize>,
    /// Removed states (variable, index into `alive`), undone on backtracking.
    trail: Vec<(usize, usize)>,
    queue: VecDeque<usize>,
    queued: Vec<bool>,
    incoming: Vec<f64>,
    offsets: Vec<usize>,
    out: Vec<f64>,
    states: Vec<usize>,
}

impl<'g> Search<'g> {
    fn new(graph: &'g FactorGraph) -> Self {
        let mut offset = Vec::with_capacity(graph.num_variables() + 1);
        let mut total = 0;
        for &k in graph.cardinalities() {
            offset.push(total);
            total += k;
        }
        offset.push(total);
        Self {
            graph,
            offset,
            alive: vec![true; total],
            count: graph.cardinalities().to_vec(),
            decided: graph
                .cardinalities()
                .iter()
                .map(|&k| if k == 1 { 0 } else { usize::MAX })
                .collect(),
            trail: Vec::new(),
            queue: VecDeque::new(),
            queued: vec![false; graph.num_factors()],
            incoming: Vec::new(),
            offsets: Vec::new(),
            out: Vec::new(),
            states: Vec::new(),
        }
    }

    fn run(mut self, scores: &Scores<'_>, max_dead_ends: u64) -> Support {
        let graph = self.graph;
        for a in 0..graph.num_factors() {
            if graph.factor(FactorId(a)).scope().is_empty()
                && graph.factor(FactorId(a)).log_potential(&[]) == f64::NEG_INFINITY
            {
                return Support::Empty(ZeroProof::ConstantZero { factor: a });
            }
            self.enqueue(a);
        }
        if let Err((variable, factor)) = self.propagate() {
            return Support::Empty(ZeroProof::Propagation { variable, factor });
        }
        // Connected components are independent: each is searched on its own (so one
        // without positive assignments is proved so without backtracking into others).
        let mut dead_ends = 0u64;
        for component in components(graph) {
            match self.solve(&component, scores, max_dead_ends, &mut dead_ends) {
                Outcome::Solved => {}
                Outcome::Exhausted => return Support::Empty(ZeroProof::Search { dead_ends }),
                Outcome::GaveUp => return Support::Undecided { dead_ends },
            }
        }
        // Every variable has exactly one state left.
        Support::Positive(self.decided)
    }

    /// Depth-first search over the variables of one component (in `branching` order)
    /// with arc consistency maintained; on success the component's domains are left
    /// decided.
    fn solve(
        &mut self,
        branching: &[usize],
        scores: &Scores<'_>,
        max_dead_ends: u64,
        dead_ends: &mut u64,
    ) -> Outcome {
        let graph = self.graph;
        let n = branching.len();
        let mut candidates: Vec<usize> = Vec::new();
        let mut stack: Vec<Frame> = Vec::new();
        let mut position = 0;
        loop {
            // Descend: the next variable with a choice left.
            while position < n && self.count[branching[position]] == 1 {
                position += 1;
            }
            if position == n {
                return Outcome::Solved;
            }
            let v = branching[position];
            let start = candidates.len();
            let decided = |u: VariableId| Some(self.decided[u.0]).filter(|&x| x != usize::MAX);
            let ordered = ordered_states(graph, VariableId(v), scores, &decided);
            candidates.extend(
                ordered
                    .into_iter()
                    .filter(|&x| self.alive[self.offset[v] + x]),
            );
            stack.push(Frame {
                position,
                start,
                next: start,
                end: candidates.len(),
                trail: self.trail.len(),
            });
            // Try candidates, backtracking through exhausted frames.
            loop {
                let Some(frame) = stack.last_mut() else {
                    return Outcome::Exhausted;
                };
                let trail = frame.trail;
                let (at, end, frame_position) = (frame.next, frame.end, frame.position);
                frame.next += 1;
                self.undo(trail);
                if at == end {
                    candidates.truncate(stack.pop().map_or(0, |f| f.start));
                    continue;
                }
                let v = branching[frame_position];
                let x = candidates[at];
                for y in 0..graph.cardinality(VariableId(v)) {
                    if y != x {
                        self.remove(v, y);
                    }
                }
                for &e in graph.variable_edges(VariableId(v)) {
                    self.enqueue(graph.edge_factor(e).0);
                }
                if self.propagate().is_ok() {
                    position = frame_position + 1;
                    break;
                }
                *dead_ends += 1;
                if *dead_ends > max_dead_ends {
                    return Outcome::GaveUp;
                }
            }
        }
    }

    fn enqueue(&mut self, a: usize) {
        if !self.queued[a] {
            self.queued[a] = true;
            self.queue.push_back(a);
        }
    }

    fn remove(&mut self, v: usize, x: usize) {
        let i = self.offset[v] + x;
        if self.alive[i] {
            self.alive[i] = false;
            self.count[v] -= 1;
            self.trail.push((v, i));
            if self.count[v] == 1 {
                let states = &self.alive[self.offset[v]..self.offset[v + 1]];
                self.decided[v] = states.iter().position(|&a| a).unwrap_or(usize::MAX);
            } else {
                self.decided[v] = usize::MAX;
            }
        }
    }

    /// Restores the states removed since the trail had length `length`.
    fn undo(&mut self, length: usize) {
        while self.trail.len() > length {
            let Some((v, i)) = self.trail.pop() else {
                break;
            };
            self.alive[i] = true;
            self.count[v] += 1;
            self.decided[v] = if self.count[v] == 1 {
                i - self.offset[v]
            } else {
                usize::MAX
            };
        }
    }

    /// Revises queued factors until none changes; `Err((variable, factor))` when a
    /// variable loses its last state (the queue is cleared).
    fn propagate(&mut self) -> Result<(), (usize, usize)> {
        while let Some(a) = self.queue.pop_front() {
            self.queued[a] = false;
            if let Err(v) = self.revise(a) {
                while let Some(b) = self.queue.pop_front() {
                    self.queued[b] = false;
                }
                return Err((v, a));
            }
        }
        Ok(())
    }

    /// Removes the states of factor `a`'s variables that have no supporting joint
    /// state of positive potential among the remaining states of the others.
    fn revise(&mut self, a: usize) -> Result<(), usize> {
        let graph = self.graph;
        let factor = graph.factor(FactorId(a));
        let scope = factor.scope();
        if scope.is_empty() {
            return Ok(());
        }
        self.offsets.clear();
        self.offsets.push(0);
        self.incoming.clear();
        for u in scope {
            for x in 0..graph.cardinality(*u) {
                self.incoming.push(if self.alive[self.offset[u.0] + x] {
                    0.0
                } else {
                    f64::NEG_INFINITY
                });
            }
            self.offsets.push(self.incoming.len());
        }
        for (slot, u) in scope.iter().enumerate() {
            let k = graph.cardinality(*u);
            self.out.clear();
            self.out.resize(k, f64::NEG_INFINITY);
            let incoming = Incoming::new(&self.incoming, &self.offsets);
            factor.message(slot, &incoming, Mode::MaxProduct, &mut self.out);
            let mut changed = false;
            self.states.clear();
            for x in 0..k {
                // NaN (a misbehaving custom factor) counts as unsupported, like −∞.
                let supported = self.out[x] > f64::NEG_INFINITY;
                if self.alive[self.offset[u.0] + x] && !supported {
                    self.states.push(x);
                }
            }
            for i in 0..self.states.len() {
                let x = self.states[i];
                self.remove(u.0, x);
                self.incoming[self.offsets[slot] + x] = f64::NEG_INFINITY;
                changed = true;
            }
            if self.count[u.0] == 0 {
                return Err(u.0);
            }
            if changed {
                for &e in graph.variable_edges(*u) {
                    let b = graph.edge_factor(e).0;
                    if b != a {
                        self.enqueue(b);
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PottsFactor;

    /// The search (tested through the public API in `tests/support.rs`) takes the
    /// components in the graph's breadth-first order.
    #[test]
    fn components_follow_the_bfs_order() {
        // A long even cycle and then a triangle.
        let mut g = FactorGraph::with_variables(&[2; 43]).unwrap();
        let ring = (0..40).map(|i| (i, (i + 1) % 40));
        for (a, b) in ring.chain([(40, 41), (41, 42), (40, 42)]) {
            let potts = PottsFactor::new(VariableId(a), VariableId(b), 2, f64::NEG_INFINITY, 0.0);
            g.add_factor(potts.unwrap()).unwrap();
        }
        let order: Vec<usize> = components(&g).concat();
        let bfs: Vec<usize> = g.bfs_order().iter().map(|v| v.0).collect();
        assert_eq!(order, bfs);
    }
}
