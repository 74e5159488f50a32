//! Exact samples from a chain's distribution by forward filtering, backward sampling:
//! the forward messages `α_i(x) = log Σ p̃(x_1..x_i = x)` are computed once, then each
//! sample draws the last variable from `α_n` and every earlier one from
//! `p(x_i | x_{i+1}) ∝ exp(α_i(x_i) + log φ(x_i, x_{i+1}))`. Used to make labelled
//! data with known weights for learning tests.

use super::chain::{chain_order, forward, tables};
use crate::error::{Error, Result};
use crate::graph::{FactorGraph, VariableId};
use crate::logspace::log_sum_exp;
use rand::Rng;

/// A sampler for a chain graph (the graphs [`chain_order`] accepts): forward messages
/// are computed once, each [`sample`](Self::sample) costs O(n K).
///
/// ```
/// use pgm_core::exact::ChainSampler;
/// use pgm_core::{FactorGraph, PottsFactor, TableFactor, VariableId};
/// use rand::SeedableRng;
///
/// let mut g = FactorGraph::with_variables(&[2, 2]).unwrap();
/// g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, 2.0]).unwrap()).unwrap();
/// g.add_factor(PottsFactor::new(VariableId(0), VariableId(1), 2, 3.0, 0.0).unwrap()).unwrap();
/// let sampler = ChainSampler::new(&g).unwrap();
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
/// let ones = (0..1000).filter(|_| sampler.sample(&mut rng)[1] == 1).count();
/// assert!(ones > 700); // p(x1 = 1) ≈ 0.83
/// ```
#[derive(Clone, Debug)]
pub struct ChainSampler {
    order: Vec<VariableId>,
    cards: Vec<usize>,
    /// Pairwise log-tables between consecutive positions, `pair[i][x * k_{i+1} + y]`.
    pair: Vec<Vec<f64>>,
    /// Forward log-messages, unary terms included.
    alpha: Vec<Vec<f64>>,
    num_variables: usize,
}

impl ChainSampler {
    /// Prepares sampling from `graph`; fails when it is not a chain or every
    /// assignment has probability zero.
    pub fn new(graph: &FactorGraph) -> Result<Self> {
        let order = chain_order(graph)?;
        let t = tables(graph, &order);
        let alpha = forward(&t);
        if let Some(last) = alpha.last() {
            let z = log_sum_exp(last);
            if !z.is_finite() {
                return Err(Error::NotApplicable {
                    method: "chain sampler",
                    reason: format!("the log partition function is {z}"),
                });
            }
        }
        Ok(Self {
            order,
            cards: t.cards,
            pair: t.pair,
            alpha,
            num_variables: graph.num_variables(),
        })
    }

    /// One exact sample, in model variable order.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Vec<usize> {
        let n = self.order.len();
        let mut assignment = vec![0usize; self.num_variables];
        if n == 0 {
            return assignment;
        }
        let mut terms = Vec::new();
        let mut x = draw(&self.alpha[n - 1], rng);
        assignment[self.order[n - 1].0] = x;
        for i in (0..n - 1).rev() {
            let k1 = self.cards[i + 1];
            terms.clear();
            terms.extend((0..self.cards[i]).map(|s| self.alpha[i][s] + self.pair[i][s * k1 + x]));
            x = draw(&terms, rng);
            assignment[self.order[i].0] = x;
        }
        assignment
    }
}

/// Draws an index with probability proportional to `exp(log_weights)`.
fn draw<R: Rng + ?Sized>(log_weights: &[f64], rng: &mut R) -> usize {
    let max = crate::logspace::max(log_weights);
    let total: f64 = log_weights.iter().map(|w| (w - max).exp()).sum();
    let mut u = rng.random::<f64>() * total;
    let mut last_possible = 0;
    for (s, w) in log_weights.iter().enumerate() {
        let p = (w - max).exp();
        if p > 0.0 {
            last_possible = s;
            if u < p {
                return s;
            }
            u -= p;
        }
    }
    // Rounding left u ≥ 0 after the last term: the last state with mass.
    last_possible
}

/// One exact sample from a chain graph (see [`ChainSampler`] to draw many).
pub fn sample_chain<R: Rng + ?Sized>(graph: &FactorGraph, rng: &mut R) -> Result<Vec<usize>> {
    Ok(ChainSampler::new(graph)?.sample(rng))
}
