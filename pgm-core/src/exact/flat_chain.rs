//! Exact max-product on a chain given as flat tables, with reusable buffers.
//!
//! [`viterbi`](super::viterbi) works on a [`FactorGraph`](crate::FactorGraph) and
//! allocates per call. Models that alternate a chain MAP with a continuous update
//! (the hybrid motion nodes of CRF-Clustering, the association chain of CRF-Matching;
//! see [`crate::hybrid::chain`]) rebuild the tables and rerun the recursion many times
//! per problem: [`FlatChain`] keeps the messages between calls and reads the tables
//! from two flat slices. Position `i` has `s_i` states (the association chain of
//! CRF-Matching prunes each point to its own candidates, so the counts differ):
//!
//! - `local[o_i + a]`: the unary log-potential of state `a` at position `i`, with
//!   `o_i = s_0 + … + s_{i−1}` ([`FlatChain::local_offset`]);
//! - `pair[q_i + a · s_{i+1} + b]`: the pairwise log-potential of states `a` at `i` and
//!   `b` at `i + 1` (row-major), with `q_i = Σ_{j<i} s_j s_{j+1}`
//!   ([`FlatChain::pair_offset`]).
//!
//! With `s` states everywhere ([`FlatChain::new`]) these are `i·s + a` and
//! `i·s² + a·s + b`.

/// Buffers for exact max-product on a chain of `n` positions.
#[derive(Clone, Debug)]
pub struct FlatChain {
    states: Vec<usize>,
    local_offset: Vec<usize>,
    pair_offset: Vec<usize>,
    forward: Vec<f64>,
    backward: Vec<f64>,
    back: Vec<usize>,
}

impl FlatChain {
    /// Buffers for `n` positions with `states` states each.
    pub fn new(n: usize, states: usize) -> Self {
        Self::with_states(&vec![states; n])
    }

    /// Buffers for a chain whose position `i` has `states[i]` states.
    pub fn with_states(states: &[usize]) -> Self {
        let n = states.len();
        let mut local_offset = Vec::with_capacity(n + 1);
        let mut pair_offset = Vec::with_capacity(n);
        let (mut lo, mut po) = (0, 0);
        for i in 0..n {
            local_offset.push(lo);
            lo += states[i];
            if i + 1 < n {
                pair_offset.push(po);
                po += states[i] * states[i + 1];
            }
        }
        local_offset.push(lo);
        pair_offset.push(po);
        Self {
            states: states.to_vec(),
            local_offset,
            pair_offset,
            forward: vec![0.0; lo],
            backward: vec![0.0; lo],
            back: vec![0; lo],
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

    /// Total number of local entries (`Σ s_i`).
    pub fn local_len(&self) -> usize {
        self.local_offset[self.states.len()]
    }

    /// Total number of pairwise entries (`Σ s_i s_{i+1}`).
    pub fn pair_len(&self) -> usize {
        *self.pair_offset.last().unwrap_or(&0)
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
    /// writes a MAP assignment into `labels` (ties go to the lowest state at each
    /// back-pointer, as in [`viterbi`](super::viterbi)). The messages are kept for
    /// [`FlatChain::max_marginals`]. Each message is shifted to a maximum of 0, so
    /// long chains do not drift.
    ///
    /// # Panics
    /// If a slice's length does not match the chain: `local` needs
    /// [`FlatChain::local_len`] entries, `pair` [`FlatChain::pair_len`] and `labels`
    /// `n`.
    pub fn viterbi(&mut self, local: &[f64], pair: &[f64], labels: &mut [usize]) {
        let n = self.len();
        self.check(local.len(), pair.len());
        assert_eq!(labels.len(), n, "labels of a {n}-position chain");
        if n == 0 || self.states.contains(&0) {
            return;
        }
        self.forward_pass(local, pair, 0);
        self.backward_pass(local, pair, n - 1);
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
            labels[i - 1] = self.back[self.local_offset[i] + labels[i]];
        }
    }

    /// The forward max-message into every position `i ≥ from`: `forward_i(b) = max_a
    /// forward_{i−1}(a) + local_{i−1}(a) + pair_{i−1}(a, b)` (`forward_0 = 0`; for
    /// `from > 0` the message into `from` is computed from the stored message into
    /// `from − 1`), with back-pointers.
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
        let p = &pair[self.pair_offset[i - 1]..self.pair_offset[i - 1] + sp * sc];
        let l = &local[lp..lc];
        let back = &mut self.back[lc..lc + sc];
        let mut top = f64::NEG_INFINITY;
        for b in 0..sc {
            let mut best = f64::NEG_INFINITY;
            let mut arg = 0;
            for a in 0..sp {
                let v = prev[a] + l[a] + p[a * sc + b];
                if v > best {
                    best = v;
                    arg = a;
                }
            }
            cur[b] = best;
            back[b] = arg;
            top = top.max(best);
        }
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
    /// `i + 1`.
    fn backward_step(&mut self, local: &[f64], pair: &[f64], i: usize) {
        let (sc, sn) = (self.states[i], self.states[i + 1]);
        let (lc, ln) = (self.local_offset[i], self.local_offset[i + 1]);
        let (cur, nxt) = self.backward.split_at_mut(ln);
        let cur = &mut cur[lc..];
        let nxt = &nxt[..sn];
        let p = &pair[self.pair_offset[i]..self.pair_offset[i] + sc * sn];
        let l = &local[ln..ln + sn];
        let mut top = f64::NEG_INFINITY;
        for a in 0..sc {
            let row = &p[a * sn..(a + 1) * sn];
            let mut best = f64::NEG_INFINITY;
            for b in 0..sn {
                best = best.max(row[b] + l[b] + nxt[b]);
            }
            cur[a] = best;
            top = top.max(best);
        }
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
    /// the last call).
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
