//! Exact max-product on a chain given as flat tables, with reusable buffers, dense or
//! sparse pairwise tables: [`FlatChain`] (the layout, the sparse messages and their
//! cost are documented there).

use super::PairPattern;
use crate::error::Result;
use crate::param::InvalidParameter;
use std::sync::Arc;

/// Buffers for exact max-product on a chain of `n` positions, with dense or sparse
/// ([`PairPattern`]) pairwise tables.
///
/// [`viterbi`](crate::exact::viterbi) works on a [`FactorGraph`](crate::FactorGraph) and
/// allocates per call. Models that alternate a chain MAP with a continuous update
/// (the hybrid motion nodes of CRF-Clustering, the association chain of CRF-Matching;
/// see [`crate::hybrid::chain`]) rebuild the tables and rerun the recursion many times
/// per problem: [`FlatChain`] keeps the messages between calls and reads the tables
/// from two flat slices. Position `i` has `s_i` states (the association chain of
/// CRF-Matching prunes each point to its own candidates, so the counts differ):
///
/// - `local[o_i + a]`: the unary log-potential of state `a` at position `i`, with
///   `o_i = s_0 + … + s_{i−1}` ([`FlatChain::local_offset`]);
/// - `pair[q_i + a · s_{i+1} + b]`: the pairwise log-potential of states `a` at `i` and
///   `b` at `i + 1` (row-major), with `q_i` the sum of the sizes of the tables before
///   ([`FlatChain::pair_offset`]); a dense table has `s_i · s_{i+1}` entries.
///
/// With `s` states everywhere ([`FlatChain::new`]) these are `i·s + a` and
/// `i·s² + a·s + b`.
///
/// **Sparse edges.** A table that is one default value everywhere except on a few
/// listed entries (a [`PairPattern`]; [`FlatChain::with_patterns`]) is stored as
/// `nnz + 1` values from `q_i`: `pair[q_i + p]` is the log-potential of the entry at
/// pattern position `p` (the listed entries in row-major order) and `pair[q_i + nnz]`
/// the default, the log-potential of every unlisted entry. Its max-messages are exact:
/// the forward message into state `b` is
///
/// ```text
/// m(b) = max( default + max_{a unlisted in column b} u(a),  max_{a listed in column b} u(a) + pair(a, b) )
/// ```
///
/// with `u(a)` the score of state `a` at the previous position. The second term runs
/// over the listed entries row by row (runs of consecutive columns as contiguous,
/// vectorised slices). The first term must exclude the listed entries (they may lie
/// below the default): the `d` states of largest `u` are selected and sorted once per
/// message, `d` the longest column that is not full plus one, and each column takes
/// the first of them it does not list (the best state, unless the column lists it;
/// then a walk of at most `|column| + 1` steps). A message costs
/// `O(s_i + s_{i+1} + nnz + d log d)` instead of `O(s_i · s_{i+1})`; backward messages
/// do the same by rows. For CRF-Matching's full state space (362 states, a band of 17
/// plus the outlier row and column: 6 787 of 131 044 entries) a forward-backward pass
/// over 361 positions takes about a sixth of the dense one's time (about 6 ms against
/// 35 ms of CPU time on a 2-core development machine; the dense pass is bound by
/// streaming its tables from memory) and holds 20 MB of tables instead of 377 MB
/// (`benches/sparse_chain.rs`).
///
/// The messages carry no back-pointers: [`FlatChain::viterbi`] decodes by
/// recomputing, from the stored forward messages, the one column of each pairwise
/// table that the path needs, so ties go to the lowest state on dense and sparse
/// edges alike and a sparse chain decodes exactly as its dense twin.
///
/// ```
/// use pgm_core::hybrid::{FlatChain, PairPattern};
/// use std::sync::Arc;
///
/// // Three positions of three states; both pairs reward staying (the diagonal, 1.0)
/// // and forbid every other move (the default, −∞).
/// let stay = Arc::new(PairPattern::from_fn(3, 3, |a, b| a == b));
/// let mut chain = FlatChain::with_patterns(&[3, 3, 3], vec![Some(Arc::clone(&stay)), Some(stay)]).unwrap();
/// assert_eq!((chain.pair_table_len(0), chain.pair_len()), (4, 8));
/// let local = [0.0, 0.5, 0.0, /**/ 0.0, 0.0, 0.2, /**/ 0.3, 0.0, 0.0];
/// let pair = [1.0, 1.0, 1.0, f64::NEG_INFINITY, /**/ 1.0, 1.0, 1.0, f64::NEG_INFINITY];
/// let mut labels = [0; 3];
/// chain.viterbi(&local, &pair, &mut labels);
/// assert_eq!(labels, [1, 1, 1]);
/// // The same chain written densely gives the same answer.
/// let mut dense = FlatChain::with_states(&[3, 3, 3]);
/// let mut dense_pair = vec![0.0; dense.pair_len()];
/// chain.dense_pair(&pair, 0, &mut dense_pair[..9]);
/// chain.dense_pair(&pair, 1, &mut dense_pair[9..]);
/// let mut dense_labels = [0; 3];
/// dense.viterbi(&local, &dense_pair, &mut dense_labels);
/// assert_eq!(dense_labels, labels);
/// ```
#[derive(Clone, Debug)]
pub struct FlatChain {
    states: Vec<usize>,
    local_offset: Vec<usize>,
    pair_offset: Vec<usize>,
    /// The pattern of each edge `(i, i + 1)`, `None` for a dense table.
    patterns: Vec<Option<Arc<PairPattern>>>,
    forward: Vec<f64>,
    backward: Vec<f64>,
    /// Scratch for one message or decoding step (as many entries as the largest state
    /// count): the scores of the sending position and one column of a pairwise
    /// table; and what the sparse messages need.
    score: Vec<f64>,
    column: Vec<f64>,
    sparse: SparseScratch,
}

impl FlatChain {
    /// Buffers for `n` positions with `states` states each (dense tables).
    pub fn new(n: usize, states: usize) -> Self {
        Self::with_states(&vec![states; n])
    }

    /// Buffers for a chain whose position `i` has `states[i]` states (dense tables).
    pub fn with_states(states: &[usize]) -> Self {
        Self::build(states, vec![None; states.len().saturating_sub(1)])
    }

    /// Buffers for a chain whose position `i` has `states[i]` states and whose table
    /// between `i` and `i + 1` is dense for `patterns[i] == None` (`s_i · s_{i+1}`
    /// entries) or sparse over `patterns[i]` (`nnz + 1` entries: the listed entries in
    /// pattern order, then the default; see [`FlatChain`]). Edges with the
    /// same pattern may share one `Arc`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`](crate::Error::InvalidParameter) when `patterns` does
    /// not have `n − 1` entries (0 for `n ≤ 1`), or a pattern's shape is not
    /// `states[i] × states[i + 1]`.
    pub fn with_patterns(
        states: &[usize],
        patterns: Vec<Option<Arc<PairPattern>>>,
    ) -> Result<Self> {
        let edges = states.len().saturating_sub(1);
        if patterns.len() != edges {
            return Err(InvalidParameter::new(
                "pair patterns",
                format!("{} patterns for {} positions", patterns.len(), states.len()),
                "one pattern (or None) per pair of neighbouring positions",
            )
            .into());
        }
        for (i, pattern) in patterns.iter().enumerate() {
            if let Some(p) = pattern {
                if (p.rows(), p.columns()) != (states[i], states[i + 1]) {
                    return Err(InvalidParameter::new(
                        "pair patterns",
                        format!(
                            "a {} x {} pattern between positions {i} and {} with {} and {} states",
                            p.rows(),
                            p.columns(),
                            i + 1,
                            states[i],
                            states[i + 1]
                        ),
                        "a pattern with one row per state of the first position and one column per state of the second",
                    )
                    .into());
                }
            }
        }
        Ok(Self::build(states, patterns))
    }

    fn build(states: &[usize], patterns: Vec<Option<Arc<PairPattern>>>) -> Self {
        let n = states.len();
        let mut local_offset = Vec::with_capacity(n + 1);
        let mut pair_offset = Vec::with_capacity(n);
        let (mut lo, mut po) = (0, 0);
        for i in 0..n {
            local_offset.push(lo);
            lo += states[i];
            if i + 1 < n {
                pair_offset.push(po);
                po += match &patterns[i] {
                    None => states[i] * states[i + 1],
                    Some(p) => p.table_len(),
                };
            }
        }
        local_offset.push(lo);
        pair_offset.push(po);
        let widest = states.iter().copied().max().unwrap_or(0);
        Self {
            states: states.to_vec(),
            local_offset,
            pair_offset,
            patterns,
            forward: vec![0.0; lo],
            backward: vec![0.0; lo],
            score: vec![0.0; widest],
            column: vec![0.0; widest],
            sparse: SparseScratch {
                keys: Vec::with_capacity(widest),
                order: Vec::with_capacity(widest),
                mark: vec![0; widest],
                top: vec![0; widest],
                stamp: 0,
            },
        }
    }

    /// Number of positions.
    pub fn len(&self) -> usize {
        self.states.len()
    }

    /// True for a chain without positions.
    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// Number of states of each position.
    pub fn states(&self) -> &[usize] {
        &self.states
    }

    /// The pattern of the table between positions `i` and `i + 1`, `None` when it is
    /// dense.
    ///
    /// # Panics
    /// If `i + 1 >= len()`.
    pub fn pattern(&self, i: usize) -> Option<&Arc<PairPattern>> {
        self.patterns[i].as_ref()
    }

    /// Where position `i`'s entries start in `local` (`i == len()` gives the total
    /// length of `local`).
    pub fn local_offset(&self, i: usize) -> usize {
        self.local_offset[i]
    }

    /// Where the table between positions `i` and `i + 1` starts in `pair`
    /// (`i == len() − 1`, or 0 for an empty chain, gives the total length of `pair`).
    pub fn pair_offset(&self, i: usize) -> usize {
        self.pair_offset[i]
    }

    /// Number of entries of the table between positions `i` and `i + 1`:
    /// `s_i · s_{i+1}` when dense, `nnz + 1` when sparse.
    ///
    /// # Panics
    /// If `i + 1 >= len()`.
    pub fn pair_table_len(&self, i: usize) -> usize {
        assert!(
            i + 1 < self.len(),
            "table {i} of a {}-position chain",
            self.len()
        );
        self.pair_offset[i + 1] - self.pair_offset[i]
    }

    /// Total number of local entries (`Σ s_i`).
    pub fn local_len(&self) -> usize {
        self.local_offset[self.states.len()]
    }

    /// Total number of pairwise entries (the sum of
    /// [`FlatChain::pair_table_len`]; `Σ s_i s_{i+1}` when every table is dense).
    pub fn pair_len(&self) -> usize {
        *self.pair_offset.last().unwrap_or(&0)
    }

    /// The dense `s_i × s_{i+1}` table (row-major) between positions `i` and `i + 1`
    /// of `pair`, into `out` (a copy for a dense edge, the expansion of a sparse one).
    ///
    /// # Panics
    /// If `i + 1 >= len()`, `pair` does not have [`FlatChain::pair_len`] entries or
    /// `out` not `s_i · s_{i+1}`.
    pub fn dense_pair(&self, pair: &[f64], i: usize, out: &mut [f64]) {
        assert_eq!(
            pair.len(),
            self.pair_len(),
            "pairwise tables of a {}-position chain",
            self.len()
        );
        let table = &pair[self.pair_offset[i]..self.pair_offset[i] + self.pair_table_len(i)];
        match &self.patterns[i] {
            None => out.copy_from_slice(table),
            Some(p) => p.expand(table, 1, out),
        }
    }

    fn check(&self, local: usize, pair: usize) {
        let n = self.len();
        assert_eq!(
            local,
            self.local_len(),
            "local table of a {n}-position chain"
        );
        assert_eq!(
            pair,
            self.pair_len(),
            "pairwise tables of a {n}-position chain"
        );
    }

    /// Runs the forward and backward max-message recursions on `local` and `pair` and
    /// writes a MAP assignment into `labels`. The messages are kept for
    /// [`FlatChain::max_marginals`]. Each message is shifted to a maximum of 0, so
    /// long chains do not drift. O(s_i · s_{i+1}) per dense edge; a sparse edge costs
    /// O(s_i + s_{i+1} + nnz + d log d) per message, `d` its longest column (row) that
    /// is not full, plus one (see [`FlatChain`]).
    ///
    /// The messages carry no back-pointers: decoding walks back from the best last
    /// state and recomputes, for each position, the column of the pairwise table it
    /// needs (O(s_i + nnz of the column) per position). Ties go to the lowest state,
    /// as in [`viterbi`](crate::exact::viterbi), on dense and sparse edges alike: a sparse
    /// chain decodes exactly as its dense twin.
    ///
    /// # Panics
    /// If a slice's length does not match the chain: `local` needs
    /// [`FlatChain::local_len`] entries, `pair` [`FlatChain::pair_len`] and `labels`
    /// `n`.
    pub fn viterbi(&mut self, local: &[f64], pair: &[f64], labels: &mut [usize]) {
        self.viterbi_labels(local, pair, labels);
        self.backward_messages(local, pair);
    }

    /// [`FlatChain::viterbi`] without the backward messages: the same MAP assignment
    /// into `labels` and the same forward messages, the backward messages left as they
    /// were (for a solver that decodes many times and reads max-marginals once:
    /// [`FlatChain::backward_messages`] on the same tables then completes what
    /// [`FlatChain::viterbi`] would have kept). The backward recursion is half the
    /// cost of [`FlatChain::viterbi`] and the assignment does not read it.
    ///
    /// # Panics
    /// As [`FlatChain::viterbi`].
    pub fn viterbi_labels(&mut self, local: &[f64], pair: &[f64], labels: &mut [usize]) {
        let n = self.len();
        self.check(local.len(), pair.len());
        assert_eq!(labels.len(), n, "labels of a {n}-position chain");
        if n == 0 || self.states.contains(&0) {
            return;
        }
        self.forward_pass(local, pair, 0);
        let last = self.local_offset[n - 1];
        let mut best = f64::NEG_INFINITY;
        let mut arg = 0;
        for a in 0..self.states[n - 1] {
            let v = self.forward[last + a] + local[last + a];
            if v > best {
                best = v;
                arg = a;
            }
        }
        labels[n - 1] = arg;
        for i in (1..n).rev() {
            labels[i - 1] = self.best_predecessor(local, pair, i, labels[i]);
        }
    }

    /// The backward max-messages of `local` and `pair` into every position, as
    /// [`FlatChain::viterbi`] keeps them (see [`FlatChain::viterbi_labels`]).
    ///
    /// # Panics
    /// If a slice's length does not match the chain (as [`FlatChain::viterbi`]).
    pub fn backward_messages(&mut self, local: &[f64], pair: &[f64]) {
        let n = self.len();
        self.check(local.len(), pair.len());
        if n == 0 || self.states.contains(&0) {
            return;
        }
        self.backward_pass(local, pair, n - 1);
    }

    /// The lowest state `a` of position `i − 1` maximising
    /// `forward_{i−1}(a) + local_{i−1}(a) + pair_{i−1}(a, b)` (0 when all are `−∞`):
    /// the back-pointer of state `b` at `i`, from the stored forward message.
    fn best_predecessor(&mut self, local: &[f64], pair: &[f64], i: usize, b: usize) -> usize {
        let (sp, sc) = (self.states[i - 1], self.states[i]);
        let lp = self.local_offset[i - 1];
        let p = &pair[self.pair_offset[i - 1]..self.pair_offset[i]];
        let column = &mut self.column[..sp];
        match &self.patterns[i - 1] {
            None => {
                for (a, x) in column.iter_mut().enumerate() {
                    *x = p[a * sc + b];
                }
            }
            Some(pattern) => {
                column.fill(p[pattern.default_entry()]);
                for (&a, &q) in pattern
                    .column_rows(b)
                    .iter()
                    .zip(pattern.column_positions(b))
                {
                    column[a] = p[q];
                }
            }
        }
        let mut best = f64::NEG_INFINITY;
        let mut arg = 0;
        for (a, &x) in column.iter().enumerate() {
            // As the messages: (forward + local) + pair.
            let v = self.forward[lp + a] + local[lp + a] + x;
            if v > best {
                best = v;
                arg = a;
            }
        }
        arg
    }

    /// The forward max-message into every position `i ≥ from`: `forward_i(b) = max_a
    /// forward_{i−1}(a) + local_{i−1}(a) + pair_{i−1}(a, b)` (`forward_0 = 0`; for
    /// `from > 0` the message into `from` is computed from the stored message into
    /// `from − 1`).
    fn forward_pass(&mut self, local: &[f64], pair: &[f64], from: usize) {
        let n = self.len();
        if from == 0 {
            self.forward[..self.states[0]].fill(0.0);
        }
        for i in from.max(1)..n {
            self.forward_step(local, pair, i);
        }
    }

    /// The forward max-message into position `i ≥ 1` from the stored message into
    /// `i − 1`.
    fn forward_step(&mut self, local: &[f64], pair: &[f64], i: usize) {
        let (sp, sc) = (self.states[i - 1], self.states[i]);
        let (lp, lc) = (self.local_offset[i - 1], self.local_offset[i]);
        let (prev, cur) = self.forward.split_at_mut(lc);
        let prev = &prev[lp..];
        let cur = &mut cur[..sc];
        let p = &pair[self.pair_offset[i - 1]..self.pair_offset[i]];
        let l = &local[lp..lc];
        let u = &mut self.score[..sp];
        for ((x, &f), &l) in u.iter_mut().zip(prev).zip(l) {
            *x = f + l;
        }
        match &self.patterns[i - 1] {
            None => dense_forward(u, p, cur),
            Some(pattern) => sparse_forward(pattern, u, p, cur, &mut self.sparse),
        }
        let top = cur.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        shift(cur, top);
    }

    /// The backward max-message into every position `i ≤ from` (`backward_{n−1} = 0`).
    fn backward_pass(&mut self, local: &[f64], pair: &[f64], from: usize) {
        let n = self.len();
        if from == n - 1 {
            let last = self.local_offset[n - 1];
            self.backward[last..].fill(0.0);
        }
        for i in (0..from.min(n - 1)).rev() {
            self.backward_step(local, pair, i);
        }
    }

    /// The backward max-message into position `i < n − 1` from the stored message into
    /// `i + 1`: `backward_i(a) = max_b pair_i(a, b) + (local_{i+1}(b) + backward_{i+1}(b))`.
    fn backward_step(&mut self, local: &[f64], pair: &[f64], i: usize) {
        let sn = self.states[i + 1];
        let (lc, ln) = (self.local_offset[i], self.local_offset[i + 1]);
        let (cur, nxt) = self.backward.split_at_mut(ln);
        let cur = &mut cur[lc..];
        let nxt = &nxt[..sn];
        let p = &pair[self.pair_offset[i]..self.pair_offset[i + 1]];
        let l = &local[ln..ln + sn];
        let w = &mut self.score[..sn];
        for ((x, &l), &b) in w.iter_mut().zip(l).zip(nxt) {
            *x = l + b;
        }
        match &self.patterns[i] {
            None => dense_backward(w, p, cur),
            Some(pattern) => sparse_backward(pattern, w, p, cur, &mut self.sparse),
        }
        let top = cur.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        shift(cur, top);
    }

    /// Position `i`'s max-marginal scores `local + forward + backward` from the stored
    /// messages, into `out` (`s_i` entries, not normalised).
    pub fn max_marginal_scores(&self, local: &[f64], i: usize, out: &mut [f64]) {
        let o = self.local_offset[i];
        for (a, x) in out.iter_mut().enumerate().take(self.states[i]) {
            *x = local[o + a] + self.forward[o + a] + self.backward[o + a];
        }
    }

    /// Recomputes the forward message into position `i` (`i ≥ 1`) from the stored
    /// message into `i − 1` and the current tables: the step of a forward sweep that
    /// visits positions one at a time (the tables of `i − 1` may have changed since
    /// the last call). Costs one message (see [`FlatChain::viterbi`]).
    pub fn update_forward(&mut self, local: &[f64], pair: &[f64], i: usize) {
        self.check(local.len(), pair.len());
        if i == 0 {
            self.forward[..self.states[0]].fill(0.0);
        } else {
            self.forward_step(local, pair, i);
        }
    }

    /// Recomputes the backward message into position `i` (`i ≤ n − 2`) from the stored
    /// message into `i + 1` and the current tables (see [`FlatChain::update_forward`]).
    pub fn update_backward(&mut self, local: &[f64], pair: &[f64], i: usize) {
        self.check(local.len(), pair.len());
        let n = self.len();
        if i + 1 >= n {
            let last = self.local_offset[n - 1];
            self.backward[last..].fill(0.0);
        } else {
            self.backward_step(local, pair, i);
        }
    }

    /// Resets every stored message to 0 (no information).
    pub fn reset_messages(&mut self) {
        self.forward.fill(0.0);
        self.backward.fill(0.0);
    }

    /// The max-marginals of the stored messages on `local`, normalised to sum to one
    /// per position, into `out` ([`FlatChain::local_len`] entries, laid out as
    /// `local`): `out[o_i + a]` is proportional to the score of the best assignment
    /// with state `a` at `i` (after [`FlatChain::viterbi`]). A position whose states
    /// are all impossible gets the uniform distribution.
    ///
    /// # Panics
    /// If `local` or `out` does not have [`FlatChain::local_len`] entries.
    pub fn max_marginals(&self, local: &[f64], out: &mut [f64]) {
        let n = self.len();
        assert_eq!(
            local.len(),
            self.local_len(),
            "local table of a {n}-position chain"
        );
        assert_eq!(
            out.len(),
            self.local_len(),
            "max-marginals of a {n}-position chain"
        );
        for i in 0..n {
            let (o, s) = (self.local_offset[i], self.states[i]);
            let row = &mut out[o..o + s];
            self.max_marginal_scores(local, i, row);
            normalise_max_marginal(row);
        }
    }
}

/// `cur[b] = max_a u[a] + p[a · s + b]`, row by row over the dense table.
fn dense_forward(u: &[f64], p: &[f64], cur: &mut [f64]) {
    cur.fill(f64::NEG_INFINITY);
    if cur.is_empty() {
        return;
    }
    for (row, &ua) in p.chunks_exact(cur.len()).zip(u) {
        if ua == f64::NEG_INFINITY {
            // Nothing in this row can beat −∞ (log-potentials are never +∞).
            continue;
        }
        for (c, &x) in cur.iter_mut().zip(row) {
            *c = larger(*c, ua + x);
        }
    }
}

/// The larger of `current` and `candidate` (`current` when they tie or `candidate`
/// is NaN); compiles to one `max` instruction, so the loops above vectorise.
#[inline(always)]
fn larger(current: f64, candidate: f64) -> f64 {
    if candidate > current {
        candidate
    } else {
        current
    }
}

/// `cur[a] = max_b p[a · s + b] + w[b]` over the dense table.
fn dense_backward(w: &[f64], p: &[f64], cur: &mut [f64]) {
    if w.is_empty() {
        cur.fill(f64::NEG_INFINITY);
        return;
    }
    for (c, row) in cur.iter_mut().zip(p.chunks_exact(w.len())) {
        *c = max_sum(row, w);
    }
}

/// Scratch of the sparse messages.
#[derive(Clone, Debug, Default)]
struct SparseScratch {
    /// One sort key per state of the sending position (see [`SparseScratch::select`]).
    keys: Vec<u128>,
    /// The first `depth` states of the sending position by decreasing score, ties by
    /// increasing index (`−0.0` and `0.0` tie).
    order: Vec<usize>,
    /// `mark[x] == stamp`: state `x` is listed in the column (row) being computed (as
    /// many entries as the largest state count).
    mark: Vec<usize>,
    /// `top[x] == stamp`: the column (row) `x` lists the best state `order[0]` (as
    /// many entries as the largest state count).
    top: Vec<usize>,
    stamp: usize,
}

impl SparseScratch {
    /// Fills `order` with the `depth` states of largest score, sorted: O(s) to select
    /// them, O(depth log depth) to sort them. Each state's key packs its score (in an
    /// order-preserving integer form, complemented so that larger scores come first)
    /// above its index, so plain integer comparisons order by decreasing score, then
    /// increasing index.
    fn select(&mut self, scores: &[f64], depth: usize) {
        self.order.clear();
        let depth = depth.min(scores.len());
        if depth == 0 {
            return;
        }
        self.keys.clear();
        self.keys.extend(scores.iter().enumerate().map(|(x, &v)| {
            let bits = (v + 0.0).to_bits();
            // The IEEE total order as an unsigned integer order.
            let ordered = if bits >> 63 == 1 {
                !bits
            } else {
                bits | 1 << 63
            };
            (u128::from(!ordered) << 64) | x as u128
        }));
        if depth < self.keys.len() {
            self.keys.select_nth_unstable(depth - 1);
            self.keys.truncate(depth);
        }
        self.keys.sort_unstable();
        self.order
            .extend(self.keys.iter().map(|&k| (k as u64) as usize));
    }

    /// Marks the columns (rows) `listing` that list the best state; returns the
    /// stamp [`SparseScratch::first_unlisted`] compares with.
    fn mark_top(&mut self, listing: &[usize]) -> usize {
        self.stamp += 1;
        for &x in listing {
            self.top[x] = self.stamp;
        }
        self.stamp
    }

    /// The first state of `order` not in `listed`, the states listed in column (row)
    /// `x`: `order[0]` unless [`SparseScratch::mark_top`] (with stamp `top`) marked
    /// `x`; otherwise marks `listed` and walks (at most `listed.len() + 1` steps).
    /// `None` when every state of `order` is listed.
    fn first_unlisted(&mut self, x: usize, top: usize, listed: &[usize]) -> Option<usize> {
        let &first = self.order.first()?;
        if self.top[x] != top {
            return Some(first);
        }
        self.stamp += 1;
        for &y in listed {
            self.mark[y] = self.stamp;
        }
        let stamp = self.stamp;
        let mark = &self.mark;
        self.order[1..].iter().copied().find(|&y| mark[y] != stamp)
    }

    /// The unlisted entries of a sparse table in a message: raises each `cur[y]` to
    /// `from[x] + default` for the best score `from[x]` of a state `x` that the
    /// pattern does not list with `y` (`listed(y)` lists those it does;
    /// `listed_with(x)` the states listed with `x`). `depth` is the longest listing
    /// that is not full, plus one (0: every listing is full).
    fn add_unlisted<'p>(
        &mut self,
        from: &[f64],
        cur: &mut [f64],
        default: f64,
        depth: usize,
        listed_with: impl Fn(usize) -> &'p [usize],
        listed: impl Fn(usize) -> &'p [usize],
    ) {
        if default == f64::NEG_INFINITY || depth == 0 {
            return;
        }
        self.select(from, depth);
        let top = self.mark_top(listed_with(self.order[0]));
        for (y, c) in cur.iter_mut().enumerate() {
            let xs = listed(y);
            if xs.len() == from.len() {
                continue;
            }
            if let Some(x) = self.first_unlisted(y, top, xs) {
                *c = larger(*c, from[x] + default);
            }
        }
    }
}

/// The forward message over a sparse table (`p`: listed values then the default):
/// `cur[b] = max(default + max_{a ∉ column b} u[a], max_{a ∈ column b} u[a] + p(a, b))`.
/// O(s_i + depth log depth + s_{i+1} + nnz), `depth` the longest column that is not
/// full plus one.
fn sparse_forward(
    pattern: &PairPattern,
    u: &[f64],
    p: &[f64],
    cur: &mut [f64],
    scratch: &mut SparseScratch,
) {
    cur.fill(f64::NEG_INFINITY);
    // The listed entries, row by row, a run of consecutive columns at a time.
    for (a, &ua) in u.iter().enumerate() {
        if ua == f64::NEG_INFINITY {
            continue;
        }
        for &(b, q, length) in pattern.row_runs(a) {
            for (c, &x) in cur[b..b + length].iter_mut().zip(&p[q..q + length]) {
                *c = larger(*c, ua + x);
            }
        }
    }
    // The unlisted entries, column by column.
    scratch.add_unlisted(
        u,
        cur,
        p[pattern.default_entry()],
        pattern.column_depth(),
        |a| pattern.row_columns(a),
        |b| pattern.column_rows(b),
    );
}

/// The backward message over a sparse table:
/// `cur[a] = max(default + max_{b ∉ row a} w[b], max_{b ∈ row a} p(a, b) + w[b])`.
/// O(s_{i+1} + depth log depth + s_i + nnz), `depth` the longest row that is not full
/// plus one.
fn sparse_backward(
    pattern: &PairPattern,
    w: &[f64],
    p: &[f64],
    cur: &mut [f64],
    scratch: &mut SparseScratch,
) {
    for (a, c) in cur.iter_mut().enumerate() {
        let mut best = f64::NEG_INFINITY;
        for &(b, q, length) in pattern.row_runs(a) {
            best = larger(best, max_sum(&p[q..q + length], &w[b..b + length]));
        }
        *c = best;
    }
    scratch.add_unlisted(
        w,
        cur,
        p[pattern.default_entry()],
        pattern.row_depth(),
        |b| pattern.column_rows(b),
        |a| pattern.row_columns(a),
    );
}

/// `max_k x[k] + y[k]` (`−∞` for empty slices), in four independent lanes so that it
/// vectorises (the maximum does not depend on the order: the same value as a
/// sequential scan, up to the sign of a zero).
fn max_sum(x: &[f64], y: &[f64]) -> f64 {
    let mut lanes = [f64::NEG_INFINITY; 4];
    let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (x4, y4) in xc.zip(yc) {
        for k in 0..4 {
            lanes[k] = larger(lanes[k], x4[k] + y4[k]);
        }
    }
    let mut best = larger(larger(lanes[0], lanes[1]), larger(lanes[2], lanes[3]));
    for (&a, &b) in xr.iter().zip(yr) {
        best = larger(best, a + b);
    }
    best
}

/// Turns max-marginal log-scores into probabilities summing to one (`exp(x − max)`,
/// normalised); all `−∞` gives the uniform distribution.
pub(crate) fn normalise_max_marginal(row: &mut [f64]) {
    let top = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if top == f64::NEG_INFINITY {
        // Every state impossible: no preference.
        let u = 1.0 / row.len() as f64;
        row.fill(u);
        return;
    }
    let mut sum = 0.0;
    for x in row.iter_mut() {
        *x = (*x - top).exp();
        sum += *x;
    }
    for x in row.iter_mut() {
        *x /= sum;
    }
}

/// Subtracts `top` from every entry unless it is infinite (all states impossible).
fn shift(v: &mut [f64], top: f64) {
    if top.is_finite() {
        for x in v.iter_mut() {
            *x -= top;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::{brute_force, BruteForceLimit};
    use crate::{FactorGraph, TableFactor};
    use proptest::prelude::*;

    /// The chain of `local`/`pair` as a factor graph.
    fn graph(chain: &FlatChain, local: &[f64], pair: &[f64]) -> FactorGraph {
        let s = chain.states();
        let mut g = FactorGraph::new();
        let v: Vec<_> = s.iter().map(|&k| g.add_variable(k).unwrap()).collect();
        for i in 0..s.len() {
            let o = chain.local_offset(i);
            let table = local[o..o + s[i]].to_vec();
            g.add_factor(TableFactor::new(vec![v[i]], vec![s[i]], table).unwrap())
                .unwrap();
        }
        for i in 0..s.len().saturating_sub(1) {
            let o = chain.pair_offset(i);
            let table = pair[o..o + s[i] * s[i + 1]].to_vec();
            g.add_factor(
                TableFactor::new(vec![v[i], v[i + 1]], vec![s[i], s[i + 1]], table).unwrap(),
            )
            .unwrap();
        }
        g
    }

    fn score(chain: &FlatChain, local: &[f64], pair: &[f64], x: &[usize]) -> f64 {
        let s = chain.states();
        (0..s.len())
            .map(|i| local[chain.local_offset(i) + x[i]])
            .sum::<f64>()
            + (0..s.len().saturating_sub(1))
                .map(|i| pair[chain.pair_offset(i) + x[i] * s[i + 1] + x[i + 1]])
                .sum::<f64>()
    }

    proptest! {
        #[test]
        fn agrees_with_brute_force(
            states in proptest::collection::vec(1usize..4, 1..6),
            uniform in any::<bool>(),
            seed in proptest::collection::vec(-3.0f64..3.0, 6 * 4 + 5 * 16),
        ) {
            let states = if uniform { vec![states[0]; states.len()] } else { states };
            let mut chain = FlatChain::with_states(&states);
            let n = states.len();
            let local = seed[..chain.local_len()].to_vec();
            let pair = seed[chain.local_len()..chain.local_len() + chain.pair_len()].to_vec();
            let mut labels = vec![0; n];
            chain.viterbi(&local, &pair, &mut labels);
            let exact = brute_force(&graph(&chain, &local, &pair), BruteForceLimit::default()).unwrap();
            prop_assert!((score(&chain, &local, &pair, &labels) - exact.map_log_score).abs() < 1e-9);
            // Max-marginal of each state = best score with that state, up to a constant.
            let mut mm = vec![0.0; chain.local_len()];
            chain.max_marginals(&local, &mut mm);
            for i in 0..n {
                let row = &mm[chain.local_offset(i)..chain.local_offset(i + 1)];
                prop_assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9);
                let top = row.iter().cloned().fold(0.0, f64::max);
                prop_assert!((row[labels[i]] - top).abs() < 1e-12);
            }
        }
    }

    /// A random chain with dense and sparse edges, and its dense twin.
    struct Twin {
        sparse: FlatChain,
        dense: FlatChain,
        local: Vec<f64>,
        sparse_pair: Vec<f64>,
        dense_pair: Vec<f64>,
    }

    /// Builds a [`Twin`] from `seed`: 1 to `max_n` positions of 1 to `max_s` states;
    /// each edge dense, or sparse over an empty, a full or a random pattern; values
    /// small integers (`integer`, so sums are exact and ties frequent) or reals, some
    /// `−∞`; the default above, below or among the listed values, or `−∞`.
    fn twin(seed: u64, max_n: usize, max_s: usize, integer: bool) -> Twin {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let n = rng.random_range(1..=max_n);
        let uniform = rng.random_bool(0.3);
        let s0 = rng.random_range(1..=max_s);
        let states: Vec<usize> = (0..n)
            .map(|_| {
                if uniform {
                    s0
                } else {
                    rng.random_range(1..=max_s)
                }
            })
            .collect();
        let impossible = if rng.random_bool(0.5) { 0.0 } else { 0.15 };
        let value = |rng: &mut rand_chacha::ChaCha8Rng| {
            if rng.random_bool(impossible) {
                f64::NEG_INFINITY
            } else if integer {
                rng.random_range(-2..=2) as f64
            } else {
                rng.random_range(-3.0..3.0)
            }
        };
        let local: Vec<f64> = (0..states.iter().sum::<usize>())
            .map(|_| value(&mut rng))
            .collect();
        let mut patterns = Vec::new();
        let mut sparse_tables = Vec::new();
        for i in 0..n.saturating_sub(1) {
            let (s, t) = (states[i], states[i + 1]);
            let pattern = match rng.random_range(0..6) {
                0 => None,
                1 => Some(PairPattern::from_fn(s, t, |_, _| false)),
                2 => Some(PairPattern::from_fn(s, t, |_, _| true)),
                3 => {
                    // CRF-Matching's shape: a band around the next state, the last
                    // row and column (the outlier state), a few random extras.
                    let band = rng.random_range(0..4);
                    let extra: Vec<bool> = (0..s * t).map(|_| rng.random_bool(0.03)).collect();
                    Some(PairPattern::from_fn(s, t, |a, b| {
                        (b as isize - a as isize - 1).unsigned_abs() <= band
                            || a + 1 == s
                            || b + 1 == t
                            || extra[a * t + b]
                    }))
                }
                _ => {
                    let density = rng.random_range(0.05..0.95);
                    let mask: Vec<bool> = (0..s * t).map(|_| rng.random_bool(density)).collect();
                    Some(PairPattern::from_fn(s, t, |a, b| mask[a * t + b]))
                }
            };
            let entries = pattern.as_ref().map_or(s * t, |p| p.len());
            let mut table: Vec<f64> = (0..entries).map(|_| value(&mut rng)).collect();
            if pattern.is_some() {
                table.push(match rng.random_range(0..4) {
                    0 => 4.0,
                    1 => -4.0,
                    2 => value(&mut rng),
                    _ => f64::NEG_INFINITY,
                });
            }
            patterns.push(pattern.map(Arc::new));
            sparse_tables.push(table);
        }
        let sparse = FlatChain::with_patterns(&states, patterns).unwrap();
        let dense = FlatChain::with_states(&states);
        let sparse_pair: Vec<f64> = sparse_tables.concat();
        let mut dense_pair = vec![0.0; dense.pair_len()];
        for i in 0..n.saturating_sub(1) {
            let o = dense.pair_offset(i);
            sparse.dense_pair(
                &sparse_pair,
                i,
                &mut dense_pair[o..o + states[i] * states[i + 1]],
            );
        }
        Twin {
            sparse,
            dense,
            local,
            sparse_pair,
            dense_pair,
        }
    }

    /// Every position's max-marginal scores from the stored messages.
    fn all_scores(chain: &FlatChain, local: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; chain.local_len()];
        for i in 0..chain.len() {
            let (o, e) = (chain.local_offset(i), chain.local_offset(i + 1));
            chain.max_marginal_scores(local, i, &mut out[o..e]);
        }
        out
    }

    /// Equal as numbers (`−∞ == −∞`, `−0 == 0`).
    fn same(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x == y)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2048))]

        /// A chain with sparse edges computes exactly the messages of its dense twin:
        /// the same max-marginal scores (bit for bit up to the sign of zero), the same
        /// MAP labels (also with integer values, where ties are frequent and sums
        /// exact), and the same after visit-by-visit updates. `wide` chains (up to 40
        /// states) exercise the shallow top-state selection of the sparse messages.
        #[test]
        fn sparse_edges_agree_with_dense(seed in any::<u64>(), integer in any::<bool>(), wide in any::<bool>()) {
            let Twin { mut sparse, mut dense, local, sparse_pair, dense_pair } =
                twin(seed, 8, if wide { 40 } else { 7 }, integer);
            let n = sparse.len();
            let mut labels = vec![0; n];
            let mut dense_labels = vec![0; n];
            sparse.viterbi(&local, &sparse_pair, &mut labels);
            dense.viterbi(&local, &dense_pair, &mut dense_labels);
            let ours = score(&dense, &local, &dense_pair, &labels);
            let theirs = score(&dense, &local, &dense_pair, &dense_labels);
            prop_assert!(ours == theirs || (ours - theirs).abs() < 1e-9, "{ours} vs {theirs}");
            prop_assert_eq!(&labels, &dense_labels);
            let scores = all_scores(&sparse, &local);
            prop_assert!(same(&scores, &all_scores(&dense, &local)), "{:?} vs {:?}", scores, all_scores(&dense, &local));
            let (mut mm, mut dense_mm) = (vec![0.0; sparse.local_len()], vec![0.0; dense.local_len()]);
            sparse.max_marginals(&local, &mut mm);
            dense.max_marginals(&local, &mut dense_mm);
            prop_assert!(same(&mm, &dense_mm));
            // Visit by visit, as `ChainUpdate::EveryVisit` does.
            sparse.reset_messages();
            dense.reset_messages();
            for i in 0..n {
                sparse.update_forward(&local, &sparse_pair, i);
                dense.update_forward(&local, &dense_pair, i);
            }
            for i in (0..n).rev() {
                sparse.update_backward(&local, &sparse_pair, i);
                dense.update_backward(&local, &dense_pair, i);
            }
            prop_assert!(same(&all_scores(&sparse, &local), &all_scores(&dense, &local)));
        }

        /// On tiny chains with sparse edges the MAP scores as brute force does, and
        /// every max-marginal score is the best score with that state.
        #[test]
        fn sparse_edges_agree_with_brute_force(seed in any::<u64>(), integer in any::<bool>()) {
            let Twin { mut sparse, dense, local, sparse_pair, dense_pair } = twin(seed, 5, 4, integer);
            let n = sparse.len();
            let mut labels = vec![0; n];
            sparse.viterbi(&local, &sparse_pair, &mut labels);
            let ours = score(&dense, &local, &dense_pair, &labels);
            let g = graph(&dense, &local, &dense_pair);
            match brute_force(&g, BruteForceLimit::default()) {
                Ok(exact) => {
                    prop_assert!((ours - exact.map_log_score).abs() < 1e-9, "{ours} vs {}", exact.map_log_score);
                    // Max-marginal scores are the best score with the state fixed,
                    // shifted by one constant per position (the messages' shifts).
                    let scores = all_scores(&sparse, &local);
                    for i in 0..n {
                        let o = sparse.local_offset(i);
                        let top = scores[o..o + sparse.states()[i]].iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                        for a in 0..sparse.states()[i] {
                            let best = best_with(&dense, &local, &dense_pair, i, a);
                            prop_assert_eq!(best == f64::NEG_INFINITY, scores[o + a] == f64::NEG_INFINITY);
                            if best > f64::NEG_INFINITY {
                                prop_assert!(((scores[o + a] - top) - (best - exact.map_log_score)).abs() < 1e-9);
                            }
                        }
                    }
                }
                // Every assignment impossible.
                Err(_) => prop_assert_eq!(ours, f64::NEG_INFINITY),
            }
        }
    }

    /// The best score of an assignment with state `a` at position `i`, by enumeration.
    fn best_with(chain: &FlatChain, local: &[f64], pair: &[f64], i: usize, a: usize) -> f64 {
        let s = chain.states();
        let mut x = vec![0; s.len()];
        x[i] = a;
        let mut best = f64::NEG_INFINITY;
        loop {
            best = best.max(score(chain, local, pair, &x));
            // Next assignment with x[i] fixed.
            let mut k = 0;
            loop {
                if k == s.len() {
                    return best;
                }
                if k == i {
                    k += 1;
                    continue;
                }
                x[k] += 1;
                if x[k] < s[k] {
                    break;
                }
                x[k] = 0;
                k += 1;
            }
        }
    }

    #[test]
    fn patterns_are_checked_and_laid_out() {
        let diagonal = Arc::new(PairPattern::from_fn(2, 2, |a, b| a == b));
        assert!(FlatChain::with_patterns(&[2, 2], vec![]).is_err());
        assert!(FlatChain::with_patterns(&[2], vec![]).is_ok());
        assert!(FlatChain::with_patterns(&[], vec![]).is_ok());
        assert!(FlatChain::with_patterns(&[2], vec![None]).is_err());
        assert!(FlatChain::with_patterns(&[2, 3], vec![Some(Arc::clone(&diagonal))]).is_err());
        let chain =
            FlatChain::with_patterns(&[2, 2, 2, 3], vec![Some(Arc::clone(&diagonal)), None, None])
                .unwrap();
        assert_eq!(
            (0..3).map(|i| chain.pair_table_len(i)).collect::<Vec<_>>(),
            [3, 4, 6]
        );
        assert_eq!(
            (chain.pair_offset(1), chain.pair_offset(2), chain.pair_len()),
            (3, 7, 13)
        );
        assert!(chain.pattern(0).is_some() && chain.pattern(1).is_none());
        let mut dense = [0.0; 4];
        let pair = [
            1.0, 2.0, -5.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ];
        chain.dense_pair(&pair, 0, &mut dense);
        assert_eq!(dense, [1.0, -5.0, -5.0, 2.0]);
    }

    #[test]
    fn listed_entries_below_the_default_are_excluded() {
        // Two states; the default 0 everywhere except (0, 0) and (1, 1) at −10: the
        // message into each state must come from the other state, not from the best
        // previous state paired with the (excluded) default.
        let pattern = Arc::new(PairPattern::from_fn(2, 2, |a, b| a == b));
        let mut chain = FlatChain::with_patterns(&[2, 2], vec![Some(pattern)]).unwrap();
        let local = [1.0, 0.0, 0.5, 0.0];
        let pair = [-10.0, -10.0, 0.0];
        let mut labels = [9; 2];
        chain.viterbi(&local, &pair, &mut labels);
        assert_eq!(labels, [0, 1]);
        let mut scores = [0.0; 2];
        chain.max_marginal_scores(&local, 1, &mut scores);
        // Into 0: from state 1 (0.0 + 0); into 1: from state 0 (1.0 + 0).
        assert_eq!(scores[0] - scores[1], (0.5 + 0.0) - (0.0 + 1.0));
    }

    #[test]
    fn impossible_states_stay_finite() {
        let (n, s) = (3, 2);
        let local = vec![f64::NEG_INFINITY, 0.0, 0.0, f64::NEG_INFINITY, 0.0, 0.0];
        let pair = vec![0.0; 2 * s * s];
        let mut chain = FlatChain::new(n, s);
        let mut labels = vec![9; n];
        chain.viterbi(&local, &pair, &mut labels);
        assert_eq!(labels, vec![1, 0, 0]);
        let mut mm = vec![0.0; n * s];
        chain.max_marginals(&local, &mut mm);
        assert!(mm.iter().all(|x| x.is_finite()));
        assert_eq!(mm[0], 0.0);
    }

    #[test]
    fn offsets_of_varying_states() {
        let chain = FlatChain::with_states(&[2, 3, 1]);
        assert_eq!(
            (
                chain.local_offset(1),
                chain.local_offset(2),
                chain.local_len()
            ),
            (2, 5, 6)
        );
        assert_eq!((chain.pair_offset(1), chain.pair_len()), (6, 9));
        assert_eq!(FlatChain::with_states(&[]).pair_len(), 0);
        assert_eq!(FlatChain::with_states(&[4]).pair_len(), 0);
    }
}
