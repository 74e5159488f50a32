//! The exact likelihood's fast path for instances whose cliques are all unary or
//! pairwise and whose graph is a forest (linear chains first of all): scaled
//! forward-backward in probability space, the way CRFsuite's `crf1d` does it.
//!
//! **Features, once.** When the objective is built, each clique's sparse features
//! (the non-zero `f_c(x_c)` of every joint state, as global weight indices and values)
//! are divided by their first non-zero value `α` and interned: cliques with the same
//! *pattern* up to that scale (CRFsuite's attribute × label features: one pattern per
//! attribute, `α` the attribute's value; one pattern for all transition cliques) share
//! it. A variable keeps the list of `(pattern, α)` of its unary cliques; the pairwise
//! cliques over one ordered pair of variables become one edge, and edges with the same
//! list share one *edge table*.
//!
//! **One pass** (objective and gradient), for weights `w`:
//! 1. every pattern state's score `s_p(x) = Σ_j w_j f_j` (once per pass);
//! 2. every edge table's log-potential `θ_t = Σ α s_p`, its maximum `M_t` and
//!    `ψ_t = exp(θ_t − M_t)` (once per pass: CRFsuite's `exp` of the transition
//!    scores);
//! 3. per instance, the node scores `θ_v = Σ α s_p`, `φ_v = exp(θ_v − max θ_v)`, then
//!    sum-product on the rooted forest in probability space: an upward (backward) pass
//!    `a_v = φ_v Π_{children c} m_{c→v}`, scaled to sum one by `s_v`, sending
//!    `m_{v→parent}(x_p) = Σ_{x_v} ψ(x_p, x_v) â_v(x_v)`; a downward (forward) pass
//!    giving each node's outside vector and the node and edge marginals, each
//!    normalised by its own sum. `log Z = Σ_v (log s_v + max θ_v) + Σ_e M_e`
//!    (the scaling factors of Rabiner's scaled forward-backward, as in Sutton &
//!    McCallum, "An Introduction to Conditional Random Fields", Found. Trends ML 4(4),
//!    2012, §4.1; CRFsuite, `crf1d_context.c`);
//! 4. the expected counts: node marginals times `α` accumulate per pattern state, edge
//!    marginals per edge table, and the gradient is `F(y) − Σ_p Σ_x E_p(x) f_p(x)`
//!    through the patterns' sparse features.
//!
//! Buffers are allocated when the objective is built and reused: a pass allocates
//! nothing but its result. Instances are split into one chunk per rayon thread, each
//! with its own accumulators.
//!
//! **Hard zeros and range.** Every node and edge is scaled by its maximum, so scores
//! of any magnitude stay in range, and a score of −∞ (a hard zero) is an exact zero
//! of `exp`. An instance whose scaling factor or edge normaliser underflows to zero
//! (two potentials whose supports meet only beyond `exp`'s range, as in a line
//! search's first long step) is swept again in log space, the same recursions with
//! log-sum-exp ([`ChainPath::instance_log`]); one whose scores are not finite even
//! there (+∞, NaN) is reported back and evaluated by the general path.

use super::model::LabelledInstance;
use crate::error::{Error, Result};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Mutex;

/// No parent (a root).
const NONE: u32 = u32::MAX;

/// One clique's use of a pattern: its offset among the pattern states and its scale.
#[derive(Clone, Copy, Debug)]
struct Ref {
    offset: u32,
    alpha: f64,
}

/// A variable of an instance, in the instance's breadth-first order.
#[derive(Clone, Copy, Debug)]
struct Node {
    k: u32,
    label: u32,
    /// Position of the parent in the instance's order, or [`NONE`].
    parent: u32,
    /// The edge table to the parent.
    table: u32,
    /// Whether the edge's scope is (parent, this node) rather than the reverse.
    parent_first: bool,
    first_child: u32,
    children: u32,
    refs_start: u32,
    refs_end: u32,
    /// Offset of the node's `k`-vectors in its instance's scratch.
    buf: u32,
    /// Offset of its message to the parent (`k_parent` entries).
    up: u32,
    /// Offset of its edge marginal (`k_parent × k` entries, in the table's order).
    edge: u32,
}

/// A distinct edge: rows × cols log-potentials, the sum of its cliques' `α s_p`.
#[derive(Clone, Copy, Debug)]
struct Table {
    offset: u32,
    rows: u32,
    cols: u32,
    refs_start: u32,
    refs_end: u32,
}

/// One instance on the fast path.
#[derive(Clone, Copy, Debug)]
struct Instance {
    /// Position in the training set.
    index: usize,
    nodes_start: u32,
    nodes_end: u32,
    states: u32,
    ups: u32,
    edges: u32,
    /// The number of states of every variable, when they all have the same; 0 if not.
    uniform: u32,
}

/// The per-pass scores shared by all chunks.
#[derive(Debug, Default)]
struct Shared {
    scores: Vec<f64>,
    theta: Vec<f64>,
    psi: Vec<f64>,
    max: Vec<f64>,
}

/// One instance's working vectors.
#[derive(Debug, Default)]
struct Scratch {
    phi: Vec<f64>,
    ahat: Vec<f64>,
    up: Vec<f64>,
    marginal: Vec<f64>,
    edge: Vec<f64>,
    excl: Vec<f64>,
    prefix: Vec<f64>,
    suffix: Vec<f64>,
}

/// A share of the instances with its own accumulators.
#[derive(Debug)]
struct Chunk {
    instances: std::ops::Range<usize>,
    expected: Vec<f64>,
    table_expected: Vec<f64>,
    log_likelihood: f64,
    /// Positions (in [`ChainPath::instances`]) handed back to the general path.
    fallbacks: Vec<usize>,
    scratch: Scratch,
}

/// The fast path over the instances it accepted (see the module docs).
#[derive(Debug)]
pub(super) struct ChainPath {
    /// Per pattern state `g`: its features are `pattern_entries[starts[g]..starts[g + 1]]`.
    pattern_starts: Vec<u32>,
    pattern_entries: Vec<(u32, f64)>,
    tables: Vec<Table>,
    table_refs: Vec<Ref>,
    nodes: Vec<Node>,
    node_refs: Vec<Ref>,
    instances: Vec<Instance>,
    /// `Σ F_i(y_i)` over the accepted instances.
    observed: Vec<f64>,
    chunks: Vec<Mutex<Chunk>>,
    shared: Mutex<Shared>,
}

/// What [`ChainBuilder::add`] made of an instance.
pub(super) enum Added {
    /// On the fast path.
    Yes,
    /// A clique over more than two variables: the general path's.
    NotPairwise,
    /// Its graph has a cycle.
    Cycle,
}

type PatternKey = (Vec<u32>, Vec<(u32, u64)>);
type TableKey = (u32, u32, Vec<(u32, u64)>);

/// Builds a [`ChainPath`] instance by instance.
pub(super) struct ChainBuilder {
    pattern_starts: Vec<u32>,
    pattern_entries: Vec<(u32, f64)>,
    patterns: HashMap<PatternKey, u32>,
    tables: Vec<Table>,
    table_refs: Vec<Ref>,
    table_index: HashMap<TableKey, u32>,
    table_size: u32,
    nodes: Vec<Node>,
    node_refs: Vec<Ref>,
    instances: Vec<Instance>,
    observed: Vec<f64>,
}

impl ChainBuilder {
    pub(super) fn new(num_weights: usize) -> Self {
        Self {
            pattern_starts: vec![0],
            pattern_entries: Vec::new(),
            patterns: HashMap::new(),
            tables: Vec::new(),
            table_refs: Vec::new(),
            table_index: HashMap::new(),
            table_size: 0,
            nodes: Vec::new(),
            node_refs: Vec::new(),
            instances: Vec::new(),
            observed: vec![0.0; num_weights],
        }
    }

    /// Number of instances accepted so far.
    pub(super) fn len(&self) -> usize {
        self.instances.len()
    }

    /// Interns a clique's pattern: per joint state its non-zero (global weight, value)
    /// features, divided by `alpha`. Returns the pattern's first state.
    fn intern(&mut self, starts: &[u32], entries: &[(u32, f64)], alpha: f64) -> u32 {
        let key: PatternKey = (
            starts.to_vec(),
            entries
                .iter()
                .map(|&(j, v)| (j, (v / alpha).to_bits()))
                .collect(),
        );
        if let Some(&offset) = self.patterns.get(&key) {
            return offset;
        }
        let offset = (self.pattern_starts.len() - 1) as u32;
        let base = self.pattern_entries.len() as u32;
        self.pattern_entries
            .extend(entries.iter().map(|&(j, v)| (j, v / alpha)));
        self.pattern_starts
            .extend(starts[1..].iter().map(|&s| base + s));
        self.patterns.insert(key, offset);
        offset
    }

    /// Adds training instance `index` (whose labels and features were checked and
    /// whose observed totals are `observed`), or says why it does not fit.
    ///
    /// # Errors
    /// A non-finite feature: the error [`LogLinearModel::to_factor_graph`] gives.
    ///
    /// [`LogLinearModel::to_factor_graph`]: super::LogLinearModel::to_factor_graph
    pub(super) fn add(
        &mut self,
        index: usize,
        instance: &LabelledInstance,
        observed: &[f64],
    ) -> Result<Added> {
        let model = &instance.model;
        let cliques = model.cliques();
        if cliques
            .iter()
            .any(|c| !(1..=2).contains(&c.features.scope().len()))
        {
            return Ok(Added::NotPairwise);
        }
        let n = model.num_variables();
        let cards = model.cardinalities();
        // Per variable its unary refs; per ordered pair its edge's refs.
        let mut unary: Vec<Vec<Ref>> = vec![Vec::new(); n];
        let mut pairs: Vec<((usize, usize), Vec<Ref>)> = Vec::new();
        let mut pair_index: HashMap<(usize, usize), usize> = HashMap::new();
        let mut starts = Vec::new();
        let mut entries = Vec::new();
        let mut buffer = Vec::new();
        let mut states = Vec::new();
        for (c, clique) in cliques.iter().enumerate() {
            let shape = clique.features.shape();
            let size: usize = shape.iter().product();
            let offset = clique.weights.start as u32;
            starts.clear();
            entries.clear();
            states.clear();
            states.resize(shape.len(), 0usize);
            starts.push(0u32);
            for _ in 0..size {
                buffer.clear();
                buffer.resize(clique.weights.len(), 0.0);
                clique.features.features(&states, &mut buffer);
                if let Some(e) = model.bad_feature(c, &states, &buffer, None, None) {
                    return Err(e);
                }
                entries.extend(
                    buffer
                        .iter()
                        .enumerate()
                        .filter(|(_, v)| **v != 0.0)
                        .map(|(j, &v)| (offset + j as u32, v)),
                );
                starts.push(entries.len() as u32);
                crate::factor::increment(&mut states, shape);
            }
            let scope = clique.features.scope();
            let refs = if scope.len() == 1 {
                &mut unary[scope[0].0]
            } else {
                let key = (scope[0].0, scope[1].0);
                let p = *pair_index.entry(key).or_insert_with(|| {
                    pairs.push((key, Vec::new()));
                    pairs.len() - 1
                });
                &mut pairs[p].1
            };
            // A clique without features adds nothing (its edge still counts).
            if let Some(&(_, alpha)) = entries.first() {
                let offset = self.intern(&starts, &entries, alpha);
                refs.push(Ref { offset, alpha });
            }
        }
        // The forest check (as `FactorGraph::is_forest` on the merged graph) and the
        // adjacency.
        let mut root: Vec<usize> = (0..n).collect();
        fn find(p: &mut [usize], mut x: usize) -> usize {
            while p[x] != x {
                p[x] = p[p[x]];
                x = p[x];
            }
            x
        }
        let mut adjacent: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
        for (p, &((a, b), _)) in pairs.iter().enumerate() {
            let (ra, rb) = (find(&mut root, a), find(&mut root, b));
            if ra == rb {
                return Ok(Added::Cycle);
            }
            root[ra] = rb;
            adjacent[a].push((b, p));
            adjacent[b].push((a, p));
        }
        // Edge tables.
        let mut pair_table = Vec::with_capacity(pairs.len());
        for &((a, b), ref refs) in &pairs {
            let (rows, cols) = (cards[a] as u32, cards[b] as u32);
            let key: TableKey = (
                rows,
                cols,
                refs.iter().map(|r| (r.offset, r.alpha.to_bits())).collect(),
            );
            let t = match self.table_index.get(&key) {
                Some(&t) => t,
                None => {
                    let t = self.tables.len() as u32;
                    let refs_start = self.table_refs.len() as u32;
                    self.table_refs.extend_from_slice(refs);
                    self.tables.push(Table {
                        offset: self.table_size,
                        rows,
                        cols,
                        refs_start,
                        refs_end: self.table_refs.len() as u32,
                    });
                    self.table_size += rows * cols;
                    self.table_index.insert(key, t);
                    t
                }
            };
            pair_table.push(t);
        }
        // Breadth-first order, each component from its lowest variable: a node's
        // children are consecutive and after it.
        let mut order: Vec<usize> = Vec::with_capacity(n);
        let mut position = vec![NONE; n];
        let mut parent_of: Vec<(u32, u32, bool)> = vec![(NONE, 0, false); n];
        for start in 0..n {
            if position[start] != NONE {
                continue;
            }
            position[start] = order.len() as u32;
            order.push(start);
            let mut head = order.len() - 1;
            while head < order.len() {
                let v = order[head];
                for &(u, p) in &adjacent[v] {
                    if position[u] == NONE {
                        position[u] = order.len() as u32;
                        order.push(u);
                        parent_of[u] = (position[v], pair_table[p], pairs[p].0 .0 == v);
                    }
                }
                head += 1;
            }
        }
        let nodes_start = self.nodes.len() as u32;
        let (mut buf, mut up, mut edge) = (0u32, 0u32, 0u32);
        for &v in &order {
            let k = cards[v] as u32;
            let (parent, table, parent_first) = parent_of[v];
            let kp = if parent == NONE {
                0
            } else {
                cards[order[parent as usize]] as u32
            };
            let refs_start = self.node_refs.len() as u32;
            self.node_refs.extend_from_slice(&unary[v]);
            self.nodes.push(Node {
                k,
                label: instance.labels[v] as u32,
                parent,
                table,
                parent_first,
                first_child: 0,
                children: 0,
                refs_start,
                refs_end: self.node_refs.len() as u32,
                buf,
                up,
                edge,
            });
            buf += k;
            up += kp;
            edge += kp * k;
        }
        for i in 0..n {
            let parent = self.nodes[nodes_start as usize + i].parent;
            if parent != NONE {
                let p = &mut self.nodes[nodes_start as usize + parent as usize];
                if p.children == 0 {
                    p.first_child = i as u32;
                }
                p.children += 1;
            }
        }
        for (o, x) in self.observed.iter_mut().zip(observed) {
            *o += x;
        }
        let uniform = match order.first() {
            Some(&v) if order.iter().all(|&u| cards[u] == cards[v]) => cards[v] as u32,
            _ => 0,
        };
        self.instances.push(Instance {
            uniform,
            index,
            nodes_start,
            nodes_end: self.nodes.len() as u32,
            states: buf,
            ups: up,
            edges: edge,
        });
        Ok(Added::Yes)
    }

    /// The fast path over the accepted instances, split into `chunks` chunks of about
    /// equal numbers of variables.
    pub(super) fn finish(self, chunks: usize) -> ChainPath {
        let total: usize = self.nodes.len();
        let chunks = chunks.clamp(1, self.instances.len().max(1));
        let pattern_states = self.pattern_starts.len() - 1;
        let mut ranges = Vec::with_capacity(chunks);
        let mut begin = 0;
        let mut seen = 0usize;
        for (i, inst) in self.instances.iter().enumerate() {
            seen += (inst.nodes_end - inst.nodes_start) as usize;
            if seen * chunks >= total * (ranges.len() + 1) && ranges.len() + 1 < chunks {
                ranges.push(begin..i + 1);
                begin = i + 1;
            }
        }
        ranges.push(begin..self.instances.len());
        let chunks = ranges
            .into_iter()
            .map(|range| {
                let mut scratch = Scratch::default();
                let (mut states, mut ups, mut edges, mut k, mut children) = (0, 0, 0, 0, 0);
                for inst in &self.instances[range.clone()] {
                    states = states.max(inst.states as usize);
                    ups = ups.max(inst.ups as usize);
                    edges = edges.max(inst.edges as usize);
                    for node in &self.nodes[inst.nodes_start as usize..inst.nodes_end as usize] {
                        k = k.max(node.k as usize);
                        children = children.max(node.children as usize);
                    }
                }
                scratch.phi = vec![0.0; states];
                scratch.ahat = vec![0.0; states];
                scratch.marginal = vec![0.0; states];
                scratch.up = vec![0.0; ups];
                scratch.edge = vec![0.0; edges];
                scratch.excl = vec![0.0; k];
                scratch.prefix = vec![0.0; k];
                scratch.suffix = vec![0.0; (children + 1) * k];
                Mutex::new(Chunk {
                    instances: range,
                    expected: vec![0.0; pattern_states],
                    table_expected: vec![0.0; self.table_size as usize],
                    log_likelihood: 0.0,
                    fallbacks: Vec::new(),
                    scratch,
                })
            })
            .collect();
        let shared = Shared {
            scores: vec![0.0; pattern_states],
            theta: vec![0.0; self.table_size as usize],
            psi: vec![0.0; self.table_size as usize],
            max: vec![0.0; self.tables.len()],
        };
        ChainPath {
            pattern_starts: self.pattern_starts,
            pattern_entries: self.pattern_entries,
            tables: self.tables,
            table_refs: self.table_refs,
            nodes: self.nodes,
            node_refs: self.node_refs,
            instances: self.instances,
            observed: self.observed,
            chunks,
            shared: Mutex::new(shared),
        }
    }
}

fn poisoned() -> Error {
    Error::NotApplicable {
        method: "maximum likelihood",
        reason: "a previous evaluation panicked".into(),
    }
}

/// The number of states of a variable with `k`: `K`, known when compiling, when it
/// is not 0.
#[inline(always)]
fn states<const K: usize>(k: u32) -> usize {
    if K == 0 {
        k as usize
    } else {
        debug_assert_eq!(k as usize, K);
        K
    }
}

/// `log Σ_x exp(a_x)` (−∞ for no finite entry).
fn log_sum_exp(a: &[f64]) -> f64 {
    log_sum_over(a.len(), |x| a[x])
}

/// `log Σ_{x < n} exp(f(x))`, two passes (−∞ when every term is −∞).
#[inline]
fn log_sum_over(n: usize, f: impl Fn(usize) -> f64) -> f64 {
    let m = (0..n).map(&f).fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY || !m.is_finite() {
        return m;
    }
    m + (0..n).map(|x| (f(x) - m).exp()).sum::<f64>().ln()
}

/// Entry `(x_v, x_c)` of an edge's table between a variable `v` of `kv` states and
/// its neighbour `c` of `kc` states: the table is `(v, c)` row-major when
/// `v_first`, `(c, v)` otherwise.
#[inline(always)]
fn edge_entry(table: &[f64], v_first: bool, kc: usize, kv: usize, xv: usize, xc: usize) -> f64 {
    if v_first {
        table[xv * kc + xc]
    } else {
        table[xc * kv + xv]
    }
}

/// The largest entry, NaN ignored (−∞ for an empty or all-NaN slice).
fn max_of(x: &[f64]) -> f64 {
    x.iter()
        .fold(f64::NEG_INFINITY, |m, &v| if v > m { v } else { m })
}

impl ChainPath {
    /// Training-set position of accepted instance `position`.
    pub(super) fn instance_index(&self, position: usize) -> usize {
        self.instances[position].index
    }

    /// `Σ_i log p(y_i | z_i; w)` over the accepted instances the fast path could
    /// evaluate, with `F(y) − E_w[F]` of all accepted instances' observed totals and
    /// those instances' expectations added into `gradient`; and the positions of the
    /// instances handed back (their observed totals are in `gradient`, their
    /// expectations and log-likelihoods are not).
    pub(super) fn evaluate(
        &self,
        weights: &[f64],
        gradient: &mut [f64],
    ) -> Result<(f64, Vec<usize>)> {
        let mut shared = self.shared.lock().map_err(|_| poisoned())?;
        {
            let Shared {
                scores,
                theta,
                psi,
                max,
            } = &mut *shared;
            for (g, s) in scores.iter_mut().enumerate() {
                let range = self.pattern_starts[g] as usize..self.pattern_starts[g + 1] as usize;
                *s = self.pattern_entries[range]
                    .iter()
                    .map(|&(j, v)| weights[j as usize] * v)
                    .sum();
            }
            for (t, table) in self.tables.iter().enumerate() {
                let size = (table.rows * table.cols) as usize;
                let offset = table.offset as usize;
                let th = &mut theta[offset..offset + size];
                th.iter_mut().for_each(|x| *x = 0.0);
                for r in &self.table_refs[table.refs_start as usize..table.refs_end as usize] {
                    let s = &scores[r.offset as usize..r.offset as usize + size];
                    for (x, s) in th.iter_mut().zip(s) {
                        *x += r.alpha * s;
                    }
                }
                let m = max_of(th);
                max[t] = m;
                for (p, x) in psi[offset..offset + size].iter_mut().zip(th.iter()) {
                    *p = (x - m).exp();
                }
            }
        }
        let shared = &*shared;
        self.chunks.par_iter().try_for_each(|chunk| {
            let mut chunk = chunk.lock().map_err(|_| poisoned())?;
            self.run_chunk(&mut chunk, shared);
            Ok::<(), Error>(())
        })?;
        let mut first = self.chunks[0].lock().map_err(|_| poisoned())?;
        let mut fallbacks = std::mem::take(&mut first.fallbacks);
        let mut log_likelihood = first.log_likelihood;
        for other in &self.chunks[1..] {
            let other = other.lock().map_err(|_| poisoned())?;
            log_likelihood += other.log_likelihood;
            fallbacks.extend_from_slice(&other.fallbacks);
            for (a, b) in first.expected.iter_mut().zip(&other.expected) {
                *a += b;
            }
            for (a, b) in first.table_expected.iter_mut().zip(&other.table_expected) {
                *a += b;
            }
        }
        let Chunk {
            expected,
            table_expected,
            ..
        } = &mut *first;
        for table in &self.tables {
            let size = (table.rows * table.cols) as usize;
            let te = &table_expected[table.offset as usize..table.offset as usize + size];
            for r in &self.table_refs[table.refs_start as usize..table.refs_end as usize] {
                let e = &mut expected[r.offset as usize..r.offset as usize + size];
                for (e, t) in e.iter_mut().zip(te) {
                    *e += r.alpha * t;
                }
            }
        }
        for (g, o) in gradient.iter_mut().zip(&self.observed) {
            *g += o;
        }
        for (g, &e) in expected.iter().enumerate() {
            if e != 0.0 {
                let range = self.pattern_starts[g] as usize..self.pattern_starts[g + 1] as usize;
                for &(j, v) in &self.pattern_entries[range] {
                    gradient[j as usize] -= e * v;
                }
            }
        }
        Ok((log_likelihood, fallbacks))
    }

    fn run_chunk(&self, chunk: &mut Chunk, shared: &Shared) {
        let Chunk {
            instances,
            expected,
            table_expected,
            log_likelihood,
            fallbacks,
            scratch,
        } = chunk;
        expected.iter_mut().for_each(|x| *x = 0.0);
        table_expected.iter_mut().for_each(|x| *x = 0.0);
        *log_likelihood = 0.0;
        fallbacks.clear();
        for i in instances.clone() {
            let inst = &self.instances[i];
            // Instances whose variables all have K states get loops of K iterations
            // the compiler unrolls; K = 0 reads each variable's own number.
            macro_rules! run {
                ($k:literal) => {{
                    let ll = self
                        .instance::<$k>(inst, shared, scratch)
                        .or_else(|| self.instance_log(inst, shared, scratch));
                    match ll {
                        Some(ll) => {
                            *log_likelihood += ll;
                            self.accumulate::<$k>(inst, scratch, expected, table_expected);
                        }
                        None => fallbacks.push(i),
                    }
                }};
            }
            match inst.uniform {
                2 => run!(2),
                3 => run!(3),
                4 => run!(4),
                5 => run!(5),
                6 => run!(6),
                7 => run!(7),
                8 => run!(8),
                _ => run!(0),
            }
        }
    }

    /// One instance's `log p(y)`, its node marginals in `scratch.marginal` and edge
    /// marginals in `scratch.edge`; `None` where the general path must take over.
    fn instance<const K: usize>(
        &self,
        inst: &Instance,
        shared: &Shared,
        s: &mut Scratch,
    ) -> Option<f64> {
        let nodes = &self.nodes[inst.nodes_start as usize..inst.nodes_end as usize];
        let Scratch {
            phi,
            ahat,
            up,
            marginal,
            edge,
            excl,
            prefix,
            suffix,
        } = s;
        let mut log_z = 0.0;
        // The product of the scaling factors not yet taken into `log_z`.
        let mut scale = 1.0f64;
        let mut score = 0.0;
        // Node potentials.
        for node in nodes {
            let (b, k) = (node.buf as usize, states::<K>(node.k));
            let theta = &mut phi[b..b + k];
            theta.iter_mut().for_each(|x| *x = 0.0);
            for r in &self.node_refs[node.refs_start as usize..node.refs_end as usize] {
                let sc = &shared.scores[r.offset as usize..r.offset as usize + k];
                for (x, s) in theta.iter_mut().zip(sc) {
                    *x += r.alpha * s;
                }
            }
            score += theta[node.label as usize];
            let m = max_of(theta);
            log_z += m;
            for (t, a) in theta.iter_mut().zip(&mut ahat[b..b + k]) {
                *t = (*t - m).exp();
                *a = *t;
            }
            if node.parent != NONE {
                let table = &self.tables[node.table as usize];
                let yp = nodes[node.parent as usize].label as usize;
                let y = node.label as usize;
                let x = if node.parent_first {
                    yp * table.cols as usize + y
                } else {
                    y * table.cols as usize + yp
                };
                score += shared.theta[table.offset as usize + x];
                log_z += shared.max[node.table as usize];
            }
        }
        // Upward: a_v = φ_v Π m_{c→v}, scaled; m_{v→parent}.
        for node in nodes.iter().rev() {
            let (b, k) = (node.buf as usize, states::<K>(node.k));
            let a = &mut ahat[b..b + k];
            let sum: f64 = a.iter().sum();
            if !(sum > 0.0 && sum.is_finite()) {
                return None;
            }
            let inv = 1.0 / sum;
            a.iter_mut().for_each(|x| *x *= inv);
            if (1e-100..=1e100).contains(&sum) {
                scale *= sum;
                if !(1e-200..=1e200).contains(&scale) {
                    log_z += scale.ln();
                    scale = 1.0;
                }
            } else {
                log_z += sum.ln();
            }
            if node.parent == NONE {
                continue;
            }
            let parent = &nodes[node.parent as usize];
            let (pb, kp) = (parent.buf as usize, states::<K>(parent.k));
            let table = &self.tables[node.table as usize];
            let psi = &shared.psi
                [table.offset as usize..(table.offset + table.rows * table.cols) as usize];
            let (left, right) = ahat.split_at_mut(b);
            let a = &right[..k];
            let m = &mut up[node.up as usize..node.up as usize + kp];
            if node.parent_first {
                for (mx, row) in m.iter_mut().zip(psi.chunks_exact(k)) {
                    *mx = row.iter().zip(a).map(|(p, a)| p * a).sum();
                }
            } else {
                m.iter_mut().for_each(|x| *x = 0.0);
                for (row, &ax) in psi.chunks_exact(kp).zip(a) {
                    for (mx, p) in m.iter_mut().zip(row) {
                        *mx += ax * p;
                    }
                }
            }
            for (pa, mx) in left[pb..pb + kp].iter_mut().zip(m.iter()) {
                *pa *= mx;
            }
        }
        log_z += scale.ln();
        if !(log_z.is_finite() && score.is_finite()) {
            return None;
        }
        // Downward: outside vectors (in `phi`: φ_v times the parent's message), node
        // and edge marginals.
        for node in nodes {
            let (b, k) = (node.buf as usize, states::<K>(node.k));
            if node.parent == NONE {
                marginal[b..b + k].copy_from_slice(&ahat[b..b + k]);
            }
            let m = node.children as usize;
            if m == 0 {
                continue;
            }
            if m > 1 {
                // suffix[i] = Π_{j ≥ i} m_{c_j→v}, suffix[m] = 1.
                suffix[m * k..(m + 1) * k].iter_mut().for_each(|x| *x = 1.0);
                for i in (0..m).rev() {
                    let c = &nodes[node.first_child as usize + i];
                    let (head, tail) = suffix.split_at_mut((i + 1) * k);
                    for ((s, t), u) in head[i * k..]
                        .iter_mut()
                        .zip(&tail[..k])
                        .zip(&up[c.up as usize..c.up as usize + k])
                    {
                        *s = t * u;
                    }
                }
                prefix[..k].copy_from_slice(&phi[b..b + k]);
            }
            for i in 0..m {
                let c = &nodes[node.first_child as usize + i];
                let (cb, kc) = (c.buf as usize, states::<K>(c.k));
                let (phi_left, phi_right) = phi.split_at_mut(cb);
                // The parent's outside vector times its other children's messages.
                let ex: &[f64] = if m == 1 {
                    &phi_left[b..b + k]
                } else {
                    for ((e, p), s) in excl[..k]
                        .iter_mut()
                        .zip(&prefix[..k])
                        .zip(&suffix[(i + 1) * k..(i + 2) * k])
                    {
                        *e = p * s;
                    }
                    for (p, u) in prefix[..k]
                        .iter_mut()
                        .zip(&up[c.up as usize..c.up as usize + k])
                    {
                        *p *= u;
                    }
                    &excl[..k]
                };
                let table = &self.tables[c.table as usize];
                let psi = &shared.psi
                    [table.offset as usize..(table.offset + table.rows * table.cols) as usize];
                // down(x_c) = Σ_{x_v} ex(x_v) ψ(x_v, x_c), into the child's marginal.
                let down = &mut marginal[cb..cb + kc];
                if c.parent_first {
                    down.iter_mut().for_each(|x| *x = 0.0);
                    for (row, &e) in psi.chunks_exact(kc).zip(ex) {
                        for (d, p) in down.iter_mut().zip(row) {
                            *d += e * p;
                        }
                    }
                } else {
                    for (d, row) in down.iter_mut().zip(psi.chunks_exact(k)) {
                        *d = row.iter().zip(ex).map(|(p, e)| p * e).sum();
                    }
                }
                let ac = &ahat[cb..cb + kc];
                let z: f64 = down.iter().zip(ac).map(|(d, a)| d * a).sum();
                if !(z > 0.0 && z.is_finite()) {
                    return None;
                }
                let inv = 1.0 / z;
                let em = &mut edge[c.edge as usize..c.edge as usize + k * kc];
                if c.parent_first {
                    for ((row, erow), &e) in
                        psi.chunks_exact(kc).zip(em.chunks_exact_mut(kc)).zip(ex)
                    {
                        let e = e * inv;
                        for ((o, p), a) in erow.iter_mut().zip(row).zip(ac) {
                            *o = e * p * a;
                        }
                    }
                } else {
                    for ((row, erow), &a) in psi.chunks_exact(k).zip(em.chunks_exact_mut(k)).zip(ac)
                    {
                        let a = a * inv;
                        for ((o, p), e) in erow.iter_mut().zip(row).zip(ex) {
                            *o = a * p * e;
                        }
                    }
                }
                // The child's outside vector φ_c · down, scaled, then its marginal.
                let pc = &mut phi_right[..kc];
                let mut total = 0.0;
                for (p, d) in pc.iter_mut().zip(down.iter()) {
                    *p *= d;
                    total += *p;
                }
                if c.children > 0 && total > 0.0 && total.is_finite() {
                    let t = 1.0 / total;
                    pc.iter_mut().for_each(|p| *p *= t);
                }
                for (d, a) in down.iter_mut().zip(ac) {
                    *d *= a * inv;
                }
            }
        }
        Some(score - log_z)
    }

    /// [`instance`](Self::instance) in log space, for an instance whose potentials
    /// leave `exp`'s range: the same sweeps on log-potentials with log-sum-exp, `exp`
    /// taken only of normalised marginals. `None` where even that fails (every state
    /// of some variable impossible, or a non-finite score): the general path's.
    fn instance_log(&self, inst: &Instance, shared: &Shared, s: &mut Scratch) -> Option<f64> {
        let nodes = &self.nodes[inst.nodes_start as usize..inst.nodes_end as usize];
        let Scratch {
            phi,
            ahat,
            up,
            marginal,
            edge,
            excl,
            prefix,
            suffix,
        } = s;
        let mut log_z = 0.0;
        let mut score = 0.0;
        // θ_v in `phi` (later the outside log-vectors) and in `ahat`.
        for node in nodes {
            let (b, k) = (node.buf as usize, node.k as usize);
            let theta = &mut phi[b..b + k];
            theta.iter_mut().for_each(|x| *x = 0.0);
            for r in &self.node_refs[node.refs_start as usize..node.refs_end as usize] {
                let sc = &shared.scores[r.offset as usize..r.offset as usize + k];
                for (x, s) in theta.iter_mut().zip(sc) {
                    *x += r.alpha * s;
                }
            }
            score += theta[node.label as usize];
            ahat[b..b + k].copy_from_slice(theta);
            if node.parent != NONE {
                let table = &self.tables[node.table as usize];
                let yp = nodes[node.parent as usize].label as usize;
                let y = node.label as usize;
                let x = if node.parent_first {
                    yp * table.cols as usize + y
                } else {
                    y * table.cols as usize + yp
                };
                score += shared.theta[table.offset as usize + x];
            }
        }
        if !score.is_finite() {
            return None;
        }
        // Upward: log a_v = θ_v + Σ log m_{c→v}, normalised; log m_{v→parent}.
        for node in nodes.iter().rev() {
            let (b, k) = (node.buf as usize, node.k as usize);
            let a = &mut ahat[b..b + k];
            let l = log_sum_exp(a);
            if !l.is_finite() {
                return None;
            }
            a.iter_mut().for_each(|x| *x -= l);
            log_z += l;
            if node.parent == NONE {
                continue;
            }
            let parent = &nodes[node.parent as usize];
            let (pb, kp) = (parent.buf as usize, parent.k as usize);
            let table = &self.tables[node.table as usize];
            let theta = &shared.theta
                [table.offset as usize..(table.offset + table.rows * table.cols) as usize];
            let (left, right) = ahat.split_at_mut(b);
            let a = &right[..k];
            let m = &mut up[node.up as usize..node.up as usize + kp];
            for (xp, mx) in m.iter_mut().enumerate() {
                *mx = log_sum_over(k, |x| {
                    a[x] + edge_entry(theta, node.parent_first, k, kp, xp, x)
                });
            }
            for (pa, mx) in left[pb..pb + kp].iter_mut().zip(m.iter()) {
                *pa += mx;
            }
        }
        // Downward: outside log-vectors in `phi`, marginals.
        for node in nodes {
            let (b, k) = (node.buf as usize, node.k as usize);
            if node.parent == NONE {
                for (p, a) in marginal[b..b + k].iter_mut().zip(&ahat[b..b + k]) {
                    *p = a.exp();
                }
            }
            let m = node.children as usize;
            if m == 0 {
                continue;
            }
            if m > 1 {
                suffix[m * k..(m + 1) * k].iter_mut().for_each(|x| *x = 0.0);
                for i in (0..m).rev() {
                    let c = &nodes[node.first_child as usize + i];
                    let (head, tail) = suffix.split_at_mut((i + 1) * k);
                    for ((s, t), u) in head[i * k..]
                        .iter_mut()
                        .zip(&tail[..k])
                        .zip(&up[c.up as usize..c.up as usize + k])
                    {
                        *s = t + u;
                    }
                }
                prefix[..k].copy_from_slice(&phi[b..b + k]);
            }
            for i in 0..m {
                let c = &nodes[node.first_child as usize + i];
                let (cb, kc) = (c.buf as usize, c.k as usize);
                let (phi_left, phi_right) = phi.split_at_mut(cb);
                let ex: &[f64] = if m == 1 {
                    &phi_left[b..b + k]
                } else {
                    for ((e, p), s) in excl[..k]
                        .iter_mut()
                        .zip(&prefix[..k])
                        .zip(&suffix[(i + 1) * k..(i + 2) * k])
                    {
                        *e = p + s;
                    }
                    for (p, u) in prefix[..k]
                        .iter_mut()
                        .zip(&up[c.up as usize..c.up as usize + k])
                    {
                        *p += u;
                    }
                    &excl[..k]
                };
                let table = &self.tables[c.table as usize];
                let theta = &shared.theta
                    [table.offset as usize..(table.offset + table.rows * table.cols) as usize];
                let down = &mut marginal[cb..cb + kc];
                for (xc, d) in down.iter_mut().enumerate() {
                    *d = log_sum_over(k, |xv| {
                        ex[xv] + edge_entry(theta, c.parent_first, kc, k, xv, xc)
                    });
                }
                let ac = &ahat[cb..cb + kc];
                let lz = log_sum_over(kc, |xc| down[xc] + ac[xc]);
                if !lz.is_finite() {
                    return None;
                }
                let em = &mut edge[c.edge as usize..c.edge as usize + k * kc];
                for (x, o) in em.iter_mut().enumerate() {
                    let (xv, xc) = if c.parent_first {
                        (x / kc, x % kc)
                    } else {
                        (x % k, x / k)
                    };
                    *o = (ex[xv] + theta[x] + ac[xc] - lz).exp();
                }
                for ((p, d), a) in phi_right[..kc].iter_mut().zip(down.iter_mut()).zip(ac) {
                    *p += *d;
                    *d = (*d + a - lz).exp();
                }
            }
        }
        Some(score - log_z)
    }

    /// Adds an evaluated instance's marginals to the expected counts.
    fn accumulate<const K: usize>(
        &self,
        inst: &Instance,
        s: &Scratch,
        expected: &mut [f64],
        table_expected: &mut [f64],
    ) {
        let nodes = &self.nodes[inst.nodes_start as usize..inst.nodes_end as usize];
        for node in nodes {
            let (b, k) = (node.buf as usize, states::<K>(node.k));
            let p = &s.marginal[b..b + k];
            for r in &self.node_refs[node.refs_start as usize..node.refs_end as usize] {
                let e = &mut expected[r.offset as usize..r.offset as usize + k];
                for (e, p) in e.iter_mut().zip(p) {
                    *e += r.alpha * p;
                }
            }
            if node.parent != NONE {
                let table = &self.tables[node.table as usize];
                let size = (table.rows * table.cols) as usize;
                let te = &mut table_expected[table.offset as usize..table.offset as usize + size];
                for (t, x) in te
                    .iter_mut()
                    .zip(&s.edge[node.edge as usize..node.edge as usize + size])
                {
                    *t += x;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{
        DenseFeatures, FeatureSet, LabelledInstance, Likelihood, LikelihoodKind, LogLinearModel,
        TemplateId,
    };
    use crate::VariableId;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::sync::Arc;

    /// A random forest instance: `n` variables of 1-4 states, each variable but the
    /// first joined to an earlier one (the previous one when `chain`), in either scope
    /// order, by 1-2 pairwise cliques; 0-3 unary cliques per variable; sparse features
    /// (about half zero), some cliques sharing one table; weights of scale `scale`.
    fn random_set(
        rng: &mut ChaCha8Rng,
        instances: usize,
        chain: bool,
    ) -> (Arc<FeatureSet>, Vec<LabelledInstance>) {
        let mut features = FeatureSet::new("random-forest", 1);
        let widths = [1usize, 2, 3, 5];
        for (t, w) in widths.iter().enumerate() {
            let names: Vec<String> = (0..*w).map(|j| format!("f{j}")).collect();
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            features.add_template(&format!("t{t}"), &names).unwrap();
        }
        let features = Arc::new(features);
        let cards: Vec<usize> = (0..6).map(|_| rng.random_range(1..=4)).collect();
        let mut shared: Vec<(usize, Vec<usize>, Vec<f64>)> = Vec::new();
        let mut table = |rng: &mut ChaCha8Rng, shape: Vec<usize>| -> (usize, Vec<f64>) {
            if let Some((t, _, v)) = shared.iter().find(|(_, s, _)| *s == shape) {
                if rng.random_bool(0.5) {
                    return (*t, v.clone());
                }
            }
            let t = rng.random_range(0..widths.len());
            let size: usize = shape.iter().product::<usize>() * widths[t];
            let v: Vec<f64> = (0..size)
                .map(|_| {
                    if rng.random_bool(0.5) {
                        0.0
                    } else {
                        rng.random_range(-2.0..2.0)
                    }
                })
                .collect();
            shared.push((t, shape, v.clone()));
            (t, v)
        };
        let data = (0..instances)
            .map(|_| {
                let n = rng.random_range(1..=cards.len());
                let mut model = LogLinearModel::new(Arc::clone(&features), &cards[..n]).unwrap();
                for v in 0..n {
                    for _ in 0..rng.random_range(0..=3) {
                        let (t, values) = table(rng, vec![cards[v]]);
                        let clique = DenseFeatures::new(
                            vec![VariableId(v)],
                            vec![cards[v]],
                            widths[t],
                            values,
                        )
                        .unwrap();
                        model.add_clique(TemplateId(t), clique).unwrap();
                    }
                    if v > 0 {
                        let p = if chain { v - 1 } else { rng.random_range(0..v) };
                        let scope = if rng.random_bool(0.5) { [p, v] } else { [v, p] };
                        for _ in 0..rng.random_range(1..=2) {
                            let shape = vec![cards[scope[0]], cards[scope[1]]];
                            let (t, values) = table(rng, shape.clone());
                            let clique = DenseFeatures::new(
                                vec![VariableId(scope[0]), VariableId(scope[1])],
                                shape,
                                widths[t],
                                values,
                            )
                            .unwrap();
                            model.add_clique(TemplateId(t), clique).unwrap();
                        }
                    }
                }
                let labels = (0..n).map(|v| rng.random_range(0..cards[v])).collect();
                LabelledInstance::new(model, labels)
            })
            .collect();
        (features, data)
    }

    fn relative(a: f64, b: f64) -> f64 {
        (a - b).abs() / a.abs().max(b.abs()).max(1.0)
    }

    /// The fast path's objective and gradient equal the general path's to 1e-10
    /// relative on random chains and trees, at weights of order 1 and of order 30
    /// (where scaling matters).
    #[test]
    fn fast_path_equals_general_path() {
        let mut rng = ChaCha8Rng::seed_from_u64(32);
        for round in 0..200 {
            let chain = round % 2 == 0;
            let count = rng.random_range(1..=4);
            let (features, data) = random_set(&mut rng, count, chain);
            let scale = if round % 5 == 4 { 30.0 } else { 1.5 };
            let weights: Vec<f64> = (0..features.num_weights())
                .map(|_| rng.random_range(-scale..scale))
                .collect();
            let prior = if round % 3 == 0 { f64::INFINITY } else { 2.0 };
            let build = |fast: bool| {
                Likelihood::build(
                    LikelihoodKind::Exact,
                    Arc::clone(&features),
                    &data,
                    prior,
                    Likelihood::default_bp(),
                    fast,
                )
                .unwrap()
            };
            let (fast, general) = (build(true), build(false));
            assert_eq!(
                (fast.chain_instances(), general.chain_instances()),
                (data.len(), 0)
            );
            if scale < 2.0 {
                assert_eq!(fast.chain_fallbacks(&weights), 0, "round {round}");
            }
            let (value, gradient) = fast.value_and_gradient(&weights).unwrap();
            let (expected, expected_gradient) = general.value_and_gradient(&weights).unwrap();
            assert!(
                relative(value, expected) < 1e-10,
                "round {round}: {value} vs {expected}"
            );
            for (j, (g, e)) in gradient.iter().zip(&expected_gradient).enumerate() {
                assert!(
                    relative(*g, *e) < 1e-10,
                    "round {round}, weight {j}: {g} vs {e}"
                );
            }
        }
    }

    /// Potentials whose supports meet only 800 nats below their maxima underflow in
    /// probability space: the log-space sweep takes the instance, exactly; a score of
    /// −∞ (a hard zero) is exact in probability space; one of +∞ hands the instance
    /// back to the general path.
    #[test]
    fn out_of_range_instances_go_to_log_space_or_back() {
        let mut features = FeatureSet::new("far", 1);
        let unary = features.add_template("unary", &["low"]).unwrap();
        let pair = features.add_template("pair", &["low"]).unwrap();
        let features = Arc::new(features);
        let build = |low: f64| {
            let mut model = LogLinearModel::new(Arc::clone(&features), &[2, 2]).unwrap();
            let unary_table = vec![0.0, low];
            let node = DenseFeatures::new(vec![VariableId(1)], vec![2], 1, unary_table).unwrap();
            model.add_clique(unary, node).unwrap();
            let table = vec![low, 0.0, low, 0.0];
            let edge = DenseFeatures::new(vec![VariableId(0), VariableId(1)], vec![2, 2], 1, table)
                .unwrap();
            model.add_clique(pair, edge).unwrap();
            vec![LabelledInstance::new(model, vec![0, 0])]
        };
        let data = build(-800.0);
        let objective = |fast: bool| {
            Likelihood::build(
                LikelihoodKind::Exact,
                Arc::clone(&features),
                &data,
                f64::INFINITY,
                Likelihood::default_bp(),
                fast,
            )
            .unwrap()
        };
        let (fast, general) = (objective(true), objective(false));
        assert_eq!(fast.chain_instances(), 1);
        assert_eq!(fast.chain_fallbacks(&[1.0, 1.0]), 0);
        // Every joint state scores −800: −log p = log 4.
        let (value, gradient) = fast.value_and_gradient(&[1.0, 1.0]).unwrap();
        assert!((value - 4f64.ln()).abs() < 1e-12, "{value}");
        // E[f] = (−400, −400), F(y) = (0, −800).
        assert!((gradient[0] + 400.0).abs() < 1e-9, "{gradient:?}");
        assert!((gradient[1] - 400.0).abs() < 1e-9, "{gradient:?}");
        // The general path sums terms of ±800 (−F_B = Σ b (θ − log b)): 1e-9 absolute.
        let (expected, expected_gradient) = general.value_and_gradient(&[1.0, 1.0]).unwrap();
        assert!((value - expected).abs() < 1e-9, "{value} vs {expected}");
        for (g, e) in gradient.iter().zip(&expected_gradient) {
            assert!((g - e).abs() < 1e-9, "{g} vs {e}");
        }
        let data = build(-1e300);
        let huge =
            Likelihood::new(LikelihoodKind::Exact, Arc::clone(&features), &data, 1.0).unwrap();
        // θ_1 = (0, −∞): a hard zero, exact in probability space (x_1 = 0, x_0 uniform).
        assert_eq!(huge.chain_fallbacks(&[1e12, 0.0]), 0);
        let log_likelihood = huge.log_likelihood(&[1e12, 0.0]).unwrap();
        assert!(
            (log_likelihood + 2f64.ln()).abs() < 1e-12,
            "{log_likelihood}"
        );
        let (_, gradient) = huge.value_and_gradient(&[1e12, 0.0]).unwrap();
        assert_eq!(gradient, vec![1e12, 0.0]); // the prior's w / σ² alone
                                               // θ_1 = (0, +∞): handed back.
        assert_eq!(huge.chain_fallbacks(&[-1e12, 0.0]), 1);
    }
}
