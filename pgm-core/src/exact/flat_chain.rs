//! Exact max-product on a chain given as flat tables, with reusable buffers.
//!
//! [`viterbi`](super::viterbi) works on a [`FactorGraph`](crate::FactorGraph) and
//! allocates per call. Models that alternate a chain MAP with a continuous update
//! (the hybrid motion nodes of CRF-Clustering, the association chain of CRF-Matching)
//! rebuild the tables and rerun the recursion many times per problem: [`FlatChain`]
//! keeps the messages between calls and reads the tables from two flat slices,
//! `local[i * s + a]` (unary log-potential of state `a` at position `i`) and
//! `pair[i * s * s + a * s + b]` (pairwise log-potential of states `a` at `i` and
//! `b` at `i + 1`), every position having the same `s` states.

/// Buffers for exact max-product on a chain of `n` positions with `s` states each.
#[derive(Clone, Debug)]
pub struct FlatChain {
    n: usize,
    s: usize,
    forward: Vec<f64>,
    backward: Vec<f64>,
    back: Vec<usize>,
}

impl FlatChain {
    /// Buffers for `n` positions with `states` states each.
    pub fn new(n: usize, states: usize) -> Self {
        Self {
            n,
            s: states,
            forward: vec![0.0; n * states],
            backward: vec![0.0; n * states],
            back: vec![0; n * states],
        }
    }

    /// Number of positions.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True for a chain without positions.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Number of states per position.
    pub fn states(&self) -> usize {
        self.s
    }

    /// Runs the forward and backward max-message recursions on `local` and `pair` and
    /// writes a MAP assignment into `labels` (ties go to the lowest state at each
    /// back-pointer, as in [`viterbi`](super::viterbi)). The messages are kept for
    /// [`FlatChain::max_marginals`]. Each message is shifted to a maximum of 0, so
    /// long chains do not drift.
    ///
    /// # Panics
    /// If a slice's length does not match the chain: `local` needs `n * s` entries,
    /// `pair` `(n - 1) * s * s` and `labels` `n`.
    pub fn viterbi(&mut self, local: &[f64], pair: &[f64], labels: &mut [usize]) {
        let (n, s) = (self.n, self.s);
        assert_eq!(local.len(), n * s, "local table of a {n}x{s} chain");
        assert_eq!(
            pair.len(),
            n.saturating_sub(1) * s * s,
            "pairwise tables of a {n}x{s} chain"
        );
        assert_eq!(labels.len(), n, "labels of a {n}-position chain");
        if n == 0 || s == 0 {
            return;
        }
        let (forward, backward, back) = (&mut self.forward, &mut self.backward, &mut self.back);
        forward[..s].fill(0.0);
        for i in 1..n {
            let (prev, cur) = forward.split_at_mut(i * s);
            let prev = &prev[(i - 1) * s..];
            let cur = &mut cur[..s];
            let p = &pair[(i - 1) * s * s..i * s * s];
            let l = &local[(i - 1) * s..i * s];
            let mut top = f64::NEG_INFINITY;
            for b in 0..s {
                let mut best = f64::NEG_INFINITY;
                let mut arg = 0;
                for a in 0..s {
                    let v = prev[a] + l[a] + p[a * s + b];
                    if v > best {
                        best = v;
                        arg = a;
                    }
                }
                cur[b] = best;
                back[i * s + b] = arg;
                top = top.max(best);
            }
            shift(cur, top);
        }
        backward[(n - 1) * s..].fill(0.0);
        for i in (0..n - 1).rev() {
            let (cur, nxt) = backward.split_at_mut((i + 1) * s);
            let cur = &mut cur[i * s..];
            let nxt = &nxt[..s];
            let p = &pair[i * s * s..(i + 1) * s * s];
            let l = &local[(i + 1) * s..(i + 2) * s];
            let mut top = f64::NEG_INFINITY;
            for a in 0..s {
                let row = &p[a * s..(a + 1) * s];
                let mut best = f64::NEG_INFINITY;
                for b in 0..s {
                    best = best.max(row[b] + l[b] + nxt[b]);
                }
                cur[a] = best;
                top = top.max(best);
            }
            shift(cur, top);
        }
        let last = (n - 1) * s;
        let mut best = f64::NEG_INFINITY;
        let mut arg = 0;
        for a in 0..s {
            let v = forward[last + a] + local[last + a];
            if v > best {
                best = v;
                arg = a;
            }
        }
        labels[n - 1] = arg;
        for i in (1..n).rev() {
            labels[i - 1] = back[i * s + labels[i]];
        }
    }

    /// The max-marginals of the last [`FlatChain::viterbi`] call on `local`,
    /// normalised to sum to one per position, into `out` (`n * s` entries): `out[i * s
    /// + a]` is proportional to the score of the best assignment with state `a` at `i`.
    ///
    /// # Panics
    /// If `local` or `out` does not have `n * s` entries.
    pub fn max_marginals(&self, local: &[f64], out: &mut [f64]) {
        let (n, s) = (self.n, self.s);
        assert_eq!(local.len(), n * s, "local table of a {n}x{s} chain");
        assert_eq!(out.len(), n * s, "max-marginals of a {n}x{s} chain");
        for i in 0..n {
            let row = &mut out[i * s..(i + 1) * s];
            let mut top = f64::NEG_INFINITY;
            for (a, x) in row.iter_mut().enumerate() {
                let k = i * s + a;
                *x = local[k] + self.forward[k] + self.backward[k];
                top = top.max(*x);
            }
            if top == f64::NEG_INFINITY {
                // Every state impossible: no preference.
                row.fill(1.0 / s as f64);
                continue;
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
    fn graph(n: usize, s: usize, local: &[f64], pair: &[f64]) -> FactorGraph {
        let mut g = FactorGraph::new();
        let v: Vec<_> = (0..n).map(|_| g.add_variable(s).unwrap()).collect();
        for i in 0..n {
            let table = local[i * s..(i + 1) * s].to_vec();
            g.add_factor(TableFactor::new(vec![v[i]], vec![s], table).unwrap())
                .unwrap();
        }
        for i in 0..n - 1 {
            let table = pair[i * s * s..(i + 1) * s * s].to_vec();
            g.add_factor(TableFactor::new(vec![v[i], v[i + 1]], vec![s, s], table).unwrap())
                .unwrap();
        }
        g
    }

    proptest! {
        #[test]
        fn agrees_with_brute_force(
            n in 1usize..6,
            s in 1usize..4,
            seed in proptest::collection::vec(-3.0f64..3.0, 6 * 4 + 5 * 16),
        ) {
            let local = seed[..n * s].to_vec();
            let pair = seed[n * s..n * s + (n - 1) * s * s].to_vec();
            let mut chain = FlatChain::new(n, s);
            let mut labels = vec![0; n];
            chain.viterbi(&local, &pair, &mut labels);
            let exact = brute_force(&graph(n, s, &local, &pair), BruteForceLimit::default()).unwrap();
            let score = |x: &[usize]| {
                (0..n).map(|i| local[i * s + x[i]]).sum::<f64>()
                    + (0..n - 1).map(|i| pair[i * s * s + x[i] * s + x[i + 1]]).sum::<f64>()
            };
            prop_assert!((score(&labels) - exact.map_log_score).abs() < 1e-9);
            // Max-marginal of each state = best score with that state, up to a constant.
            let mut mm = vec![0.0; n * s];
            chain.max_marginals(&local, &mut mm);
            for i in 0..n {
                prop_assert!((mm[i * s..(i + 1) * s].iter().sum::<f64>() - 1.0).abs() < 1e-9);
                prop_assert!((mm[i * s + labels[i]] - mm[i * s..(i + 1) * s].iter().cloned().fold(0.0, f64::max)).abs() < 1e-12);
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
}
