//! The factor graph: discrete variables of any cardinality and factors of any arity.
//!
//! Storage is laid out for message passing: every (factor, scope position) pair is an
//! *edge* with a stable [`EdgeId`] (the edges of one factor are consecutive), and the
//! factor-to-variable message of edge `e` occupies `message_range(e)` of one flat
//! buffer. That buffer is *variable-major*: all messages into one variable are one
//! contiguous slice ([`FactorGraph::variable_message_range`]). Gathering a
//! variable-to-factor message then reads one cache-friendly block, and the flooding
//! schedule can compute the messages into disjoint blocks of variables in parallel
//! without locks.

use crate::error::{Error, Result};
use crate::factor::Factor;
use std::fmt;
use std::ops::Range;
use std::sync::OnceLock;

/// Index of a variable in its graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct VariableId(pub usize);

/// Index of a factor in its graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FactorId(pub usize);

/// Index of an edge (a factor and one position of its scope).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct EdgeId(pub usize);

impl fmt::Display for VariableId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "x{}", self.0)
    }
}

impl fmt::Display for FactorId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "f{}", self.0)
    }
}

/// A factor graph over discrete variables.
///
/// ```
/// use pgm_core::{FactorGraph, TableFactor, PottsFactor};
/// let mut graph = FactorGraph::new();
/// let a = graph.add_variable(2).unwrap();
/// let b = graph.add_variable(2).unwrap();
/// graph.add_factor(TableFactor::new(vec![a], vec![2], vec![0.0, 1.0]).unwrap()).unwrap();
/// graph.add_factor(PottsFactor::new(a, b, 2, 0.5, 0.0).unwrap()).unwrap();
/// assert_eq!(graph.log_score(&[1, 1]).unwrap(), 1.5);
/// ```
#[derive(Debug, Default)]
pub struct FactorGraph {
    cardinalities: Vec<usize>,
    factors: Vec<Box<dyn Factor>>,
    /// First edge of each factor; `num_factors + 1` entries.
    factor_edge_start: Vec<usize>,
    edge_variable: Vec<VariableId>,
    edge_factor: Vec<FactorId>,
    variable_edges: Vec<Vec<EdgeId>>,
    /// Message layout, computed on first use after the last structural change.
    layout: OnceLock<Layout>,
}

/// Borrowed flat arrays of a graph's structure and message layout.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MessageIndex<'g> {
    pub(crate) edge_offset: &'g [usize],
    pub(crate) variable_start: &'g [usize],
    pub(crate) variable_end: &'g [usize],
    pub(crate) edge_variable: &'g [VariableId],
    pub(crate) cardinalities: &'g [usize],
    pub(crate) factor_edge_start: &'g [usize],
    pub(crate) edge_factor: &'g [FactorId],
}

/// For an edge of a pairwise factor, the message block of the factor's other variable:
/// `start..end` holds every message into that variable, `own` is where the message
/// from this factor sits (left out of the variable-to-factor sum). Unused (zero) for
/// edges of factors of other arities.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PairSource {
    pub(crate) start: u32,
    pub(crate) end: u32,
    pub(crate) own: u32,
    /// Number of states of the other variable.
    pub(crate) states: u32,
    /// Number of states of this edge's variable.
    pub(crate) target_states: u32,
    /// Where this edge's message starts in the buffer.
    pub(crate) target: u32,
    /// The factor.
    pub(crate) factor: u32,
    /// This edge's scope position (0 or 1).
    pub(crate) slot: u32,
}

/// Variable-major message layout.
#[derive(Debug, Default)]
struct Layout {
    /// Offset of each edge's message.
    edge_offset: Vec<usize>,
    /// Start of each variable's block.
    variable_start: Vec<usize>,
    /// End of each variable's block.
    variable_end: Vec<usize>,
    /// Variables in the order of their blocks.
    order: Vec<VariableId>,
    /// Total buffer length.
    total: usize,
    /// See [`FactorGraph::pair_sources`].
    pair_source: Vec<PairSource>,
}

impl FactorGraph {
    /// An empty graph.
    pub fn new() -> Self {
        Self {
            factor_edge_start: vec![0],
            ..Default::default()
        }
    }

    /// A graph with one variable per entry of `cardinalities`.
    pub fn with_variables(cardinalities: &[usize]) -> Result<Self> {
        let mut g = Self::new();
        for &k in cardinalities {
            g.add_variable(k)?;
        }
        Ok(g)
    }

    /// Adds a variable with `cardinality` states.
    pub fn add_variable(&mut self, cardinality: usize) -> Result<VariableId> {
        if cardinality == 0 {
            return Err(Error::ZeroCardinality {
                variable: self.cardinalities.len(),
            });
        }
        self.cardinalities.push(cardinality);
        self.variable_edges.push(Vec::new());
        self.layout = OnceLock::new();
        Ok(VariableId(self.cardinalities.len() - 1))
    }

    /// Adds a factor after checking its scope and shape against the variables.
    pub fn add_factor<F: Factor + 'static>(&mut self, factor: F) -> Result<FactorId> {
        self.add_boxed_factor(Box::new(factor))
    }

    /// Adds a boxed factor after checking its scope and shape against the variables.
    pub fn add_boxed_factor(&mut self, factor: Box<dyn Factor>) -> Result<FactorId> {
        let id = FactorId(self.factors.len());
        self.check_factor(id.0, factor.as_ref())?;
        let first_edge = self.edge_variable.len();
        for (slot, &v) in factor.scope().iter().enumerate() {
            let e = EdgeId(first_edge + slot);
            self.edge_variable.push(v);
            self.edge_factor.push(id);
            self.variable_edges[v.0].push(e);
        }
        self.layout = OnceLock::new();
        self.factor_edge_start.push(self.edge_variable.len());
        self.factors.push(factor);
        Ok(id)
    }

    /// Replaces a factor by one with the same scope and shape (used by hooks that
    /// refresh potentials, e.g. factors that depend on continuous nodes).
    pub fn replace_factor(&mut self, id: FactorId, factor: Box<dyn Factor>) -> Result<()> {
        let old = self
            .factors
            .get(id.0)
            .ok_or_else(|| Error::InvalidParameter {
                name: "factor id",
                value: id.0.to_string(),
                expected: "an existing factor",
            })?;
        if old.scope() != factor.scope() || old.shape() != factor.shape() {
            return Err(Error::InvalidParameter {
                name: "replacement factor",
                value: format!("scope {:?} shape {:?}", factor.scope(), factor.shape()),
                expected: "the same scope and shape as the factor it replaces",
            });
        }
        self.factors[id.0] = factor;
        Ok(())
    }

    fn check_factor(&self, index: usize, factor: &dyn Factor) -> Result<()> {
        crate::factor::check_scope_against(
            index,
            factor.scope(),
            factor.shape(),
            &self.cardinalities,
            "factor shape",
        )
    }

    /// Number of variables.
    pub fn num_variables(&self) -> usize {
        self.cardinalities.len()
    }

    /// Number of factors.
    pub fn num_factors(&self) -> usize {
        self.factors.len()
    }

    /// Number of edges (sum of factor arities).
    pub fn num_edges(&self) -> usize {
        self.edge_variable.len()
    }

    /// Cardinality of a variable.
    pub fn cardinality(&self, v: VariableId) -> usize {
        self.cardinalities[v.0]
    }

    /// All cardinalities, in variable order.
    pub fn cardinalities(&self) -> &[usize] {
        &self.cardinalities
    }

    /// A factor.
    pub fn factor(&self, a: FactorId) -> &dyn Factor {
        self.factors[a.0].as_ref()
    }

    /// Mutable access to a factor (crate-internal: hooks go through `Potentials`).
    pub(crate) fn factor_mut(&mut self, a: FactorId) -> &mut dyn Factor {
        self.factors[a.0].as_mut()
    }

    /// All factors, in factor order.
    pub fn factors(&self) -> impl ExactSizeIterator<Item = &dyn Factor> + '_ {
        self.factors.iter().map(|f| f.as_ref())
    }

    /// The edges of a factor, one per scope position, in scope order.
    pub fn factor_edges(&self, a: FactorId) -> Range<usize> {
        self.factor_edge_start[a.0]..self.factor_edge_start[a.0 + 1]
    }

    /// The edges incident to a variable, in the order their factors were added.
    pub fn variable_edges(&self, v: VariableId) -> &[EdgeId] {
        &self.variable_edges[v.0]
    }

    /// The variable at an edge.
    pub fn edge_variable(&self, e: EdgeId) -> VariableId {
        self.edge_variable[e.0]
    }

    /// The factor at an edge.
    pub fn edge_factor(&self, e: EdgeId) -> FactorId {
        self.edge_factor[e.0]
    }

    /// The scope position of an edge within its factor.
    pub fn edge_slot(&self, e: EdgeId) -> usize {
        e.0 - self.factor_edge_start[self.edge_factor[e.0].0]
    }

    /// Per edge of a pairwise factor: where the *other* scope position's incoming
    /// messages live (see [`PairSource`]); empty when the buffer is too large for
    /// 32-bit offsets (the engine then takes its general path).
    #[inline]
    pub(crate) fn pair_sources(&self) -> &[PairSource] {
        &self.layout().pair_source
    }

    /// Flat views of the structure for the message-passing inner loops.
    #[inline]
    pub(crate) fn index(&self) -> MessageIndex<'_> {
        let layout = self.layout();
        MessageIndex {
            edge_offset: &layout.edge_offset,
            variable_start: &layout.variable_start,
            variable_end: &layout.variable_end,
            edge_variable: &self.edge_variable,
            cardinalities: &self.cardinalities,
            factor_edge_start: &self.factor_edge_start,
            edge_factor: &self.edge_factor,
        }
    }

    fn layout(&self) -> &Layout {
        self.layout.get_or_init(|| {
            // Blocks follow the breadth-first order, the order the default sequential
            // schedule sweeps in, so its reads and writes stay local in memory.
            let order = self.bfs_order();
            let mut edge_offset = vec![0; self.num_edges()];
            let mut variable_start = vec![0; self.num_variables()];
            let mut variable_end = vec![0; self.num_variables()];
            let mut next = 0;
            for &v in &order {
                variable_start[v.0] = next;
                for e in &self.variable_edges[v.0] {
                    edge_offset[e.0] = next;
                    next += self.cardinalities[v.0];
                }
                variable_end[v.0] = next;
            }
            let mut pair_source = Vec::new();
            if u32::try_from(next).is_ok() && u32::try_from(self.num_factors()).is_ok() {
                pair_source = vec![PairSource::default(); self.num_edges()];
                for w in self.factor_edge_start.windows(2) {
                    if w[1] - w[0] != 2 {
                        continue;
                    }
                    for (slot, (e, other)) in
                        [(w[0], w[0] + 1), (w[0] + 1, w[0])].into_iter().enumerate()
                    {
                        let u = self.edge_variable[other].0;
                        let v = self.edge_variable[e].0;
                        // Offsets and state counts are at most `next`, which fits in
                        // 32 bits; so does the factor index when the edges fit.
                        let narrow = |x: usize| x as u32;
                        pair_source[e] = PairSource {
                            start: narrow(variable_start[u]),
                            end: narrow(variable_end[u]),
                            own: narrow(edge_offset[other]),
                            states: narrow(self.cardinalities[u]),
                            target_states: narrow(self.cardinalities[v]),
                            target: narrow(edge_offset[e]),
                            factor: narrow(self.edge_factor[e].0),
                            slot: narrow(slot),
                        };
                    }
                }
            }
            Layout {
                edge_offset,
                variable_start,
                variable_end,
                order,
                total: next,
                pair_source,
            }
        })
    }

    /// Where the message of edge `e` lives in a message buffer.
    #[inline]
    pub fn message_range(&self, e: EdgeId) -> Range<usize> {
        let start = self.layout().edge_offset[e.0];
        start..start + self.cardinalities[self.edge_variable[e.0].0]
    }

    /// Where all messages into variable `v` live: one contiguous block holding the
    /// messages of `variable_edges(v)` in that order.
    #[inline]
    pub fn variable_message_range(&self, v: VariableId) -> Range<usize> {
        let l = self.layout();
        l.variable_start[v.0]..l.variable_end[v.0]
    }

    /// Total length of a message buffer.
    pub fn message_len(&self) -> usize {
        self.layout().total
    }

    /// The variables in the order their message blocks are laid out (breadth-first);
    /// consecutive variables of this order own consecutive blocks.
    pub fn layout_order(&self) -> &[VariableId] {
        &self.layout().order
    }

    /// Replaces every pairwise dense table whose log-table is a Potts table (both
    /// variables with the same `K ≥ 2` states, one value on the diagonal, one off it:
    /// what UAI files hold for Potts models) by the equivalent
    /// [`PottsFactor`](crate::PottsFactor), whose messages cost O(K) instead of
    /// O(K²). Scores are unchanged; max-product messages are the same numbers;
    /// sum-product messages agree to rounding. Returns how many factors were replaced.
    ///
    /// ```
    /// use pgm_core::{FactorGraph, TableFactor, VariableId};
    /// let mut g = FactorGraph::with_variables(&[3, 3, 2]).unwrap();
    /// let (a, b, c) = (VariableId(0), VariableId(1), VariableId(2));
    /// let potts = vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// g.add_factor(TableFactor::new(vec![a, b], vec![3, 3], potts).unwrap()).unwrap();
    /// g.add_factor(TableFactor::new(vec![b, c], vec![3, 2], vec![0.0; 6]).unwrap()).unwrap();
    /// assert_eq!(g.specialise_factors(), 1);
    /// assert_eq!(g.factor(pgm_core::FactorId(0)).kind(), "potts");
    /// assert_eq!(g.log_score(&[2, 2, 0]).unwrap(), 1.0);
    /// ```
    pub fn specialise_factors(&mut self) -> usize {
        let mut replaced = 0;
        for a in 0..self.factors.len() {
            let factor = self.factors[a].as_ref();
            let shape = factor.shape();
            if factor.kind() != "table" || shape.len() != 2 || shape[0] != shape[1] || shape[0] < 2
            {
                continue;
            }
            let k = shape[0];
            let table = factor.log_table();
            let (same, different) = (table[0], table[1]);
            let is_potts = table.iter().enumerate().all(|(i, &x)| {
                let expected = if i / k == i % k { same } else { different };
                x.to_bits() == expected.to_bits()
            });
            if !is_potts {
                continue;
            }
            let scope = factor.scope();
            if let Ok(potts) = crate::PottsFactor::new(scope[0], scope[1], k, same, different) {
                self.factors[a] = Box::new(potts);
                replaced += 1;
            }
        }
        replaced
    }

    /// Checks that an assignment has one in-range state per variable.
    pub fn check_assignment(&self, assignment: &[usize]) -> Result<()> {
        check_assignment(&self.cardinalities, assignment)
    }

    /// Sum of all factors' log-potentials at a joint assignment (−∞ if any factor is a
    /// hard zero there).
    pub fn log_score(&self, assignment: &[usize]) -> Result<f64> {
        self.check_assignment(assignment)?;
        Ok(self.log_score_unchecked(assignment))
    }

    /// [`log_score`](Self::log_score) without the range checks (panics on bad input).
    pub fn log_score_unchecked(&self, assignment: &[usize]) -> f64 {
        let mut states = Vec::new();
        let mut total = 0.0;
        for f in &self.factors {
            states.clear();
            states.extend(f.scope().iter().map(|v| assignment[v.0]));
            total += f.log_potential(&states);
        }
        total
    }

    /// Variables adjacent to `v` through some factor (without `v`), sorted, unique.
    pub fn neighbours(&self, v: VariableId) -> Vec<VariableId> {
        let mut out: Vec<VariableId> = self.variable_edges[v.0]
            .iter()
            .flat_map(|&e| self.factor(self.edge_factor(e)).scope().iter().copied())
            .filter(|&u| u != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// True when the bipartite variable–factor graph has no cycle (a forest).
    pub fn is_forest(&self) -> bool {
        // Union-find over variables and factors as nodes; an edge closing a cycle fails.
        let n = self.num_variables() + self.num_factors();
        let mut parent: Vec<usize> = (0..n).collect();
        fn find(p: &mut [usize], mut x: usize) -> usize {
            while p[x] != x {
                p[x] = p[p[x]];
                x = p[x];
            }
            x
        }
        for e in 0..self.num_edges() {
            let v = self.edge_variable[e].0;
            let a = self.num_variables() + self.edge_factor[e].0;
            let (rv, ra) = (find(&mut parent, v), find(&mut parent, a));
            if rv == ra {
                return false;
            }
            parent[rv] = ra;
        }
        true
    }

    /// Variables in breadth-first order over the factor graph, each connected component
    /// started from its lowest-indexed variable. Used for deterministic decoding and as
    /// the default sequential order (leaves last, so the reverse sweeps towards roots).
    pub fn bfs_order(&self) -> Vec<VariableId> {
        let n = self.num_variables();
        let mut seen = vec![false; n];
        let mut order = Vec::with_capacity(n);
        let mut head = 0;
        for root in 0..n {
            if seen[root] {
                continue;
            }
            seen[root] = true;
            order.push(VariableId(root));
            while head < order.len() {
                let v = order[head];
                head += 1;
                for &e in &self.variable_edges[v.0] {
                    for &u in self.factors[self.edge_factor[e.0].0].scope() {
                        if !seen[u.0] {
                            seen[u.0] = true;
                            order.push(u);
                        }
                    }
                }
            }
        }
        order
    }
}

/// Checks that `assignment` has one state per variable of `cardinalities`, each in
/// range.
pub(crate) fn check_assignment(cardinalities: &[usize], assignment: &[usize]) -> Result<()> {
    if assignment.len() != cardinalities.len() {
        return Err(Error::BadAssignment(format!(
            "{} values for {} variables",
            assignment.len(),
            cardinalities.len()
        )));
    }
    for (i, (&x, &k)) in assignment.iter().zip(cardinalities).enumerate() {
        if x >= k {
            return Err(Error::BadAssignment(format!(
                "variable {i} has state {x}, but only {k} states"
            )));
        }
    }
    Ok(())
}
