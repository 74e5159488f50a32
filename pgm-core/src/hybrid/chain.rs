//! Hybrid inference on chains: exact max-product sweeps with observed-continuous
//! nodes, for models whose discrete part is one or several chains.
//!
//! The models of both CRF papers are chains over the points of a scan in beam order
//! (CRF-Clustering: cluster labels; CRF-Matching: associations; the joint model: both
//! chains, coupled through the per-cluster rigid motions and through features that
//! read the other chain's labels). For fixed continuous values one forward-backward
//! max-product sweep over a chain is exact, so a dedicated solver runs the alternation
//! of [`HybridInference`](super::HybridInference) on flat tables
//! ([`FlatChain`]) without the generic factor-graph machinery:
//!
//! - **Every sweep** ([`ChainUpdate::EverySweep`], the default): for each chain in
//!   turn, write its tables for the current continuous values and the other chains'
//!   current labels, take the exact MAP of the chain (Viterbi), feed the changed labels
//!   to the model and re-solve the continuous values. This is block coordinate ascent
//!   on the joint log-score when the tables are the conditionals of one (each chain's
//!   step is an exact maximisation, and so is the closed-form solve).
//! - **Every visit** ([`ChainUpdate::EveryVisit`], Algorithm 1 of van de Ven, Ramos
//!   and Tipaldi, "An Integrated Probabilistic Model for Scan-Matching, Moving Object
//!   Detection and Motion Estimation", lines 5-12): a forward then a backward pass over
//!   each chain; visiting position `i` recomputes the message into it from its
//!   neighbour with the tables written for the current values, takes the argmax of its
//!   max-marginal as its label, and re-solves the continuous values at once when the
//!   label changed, so the next position already sees them. After convergence the
//!   chains are decoded exactly once more against the final values (lines 16-21).
//!
//! A model implements [`HybridChainModel`]: it says how many chains and states it has,
//! writes the log-linear *features* of each table through a [`FeatureSink`] (once:
//! [`WeightedTable`] turns them into log-potentials `w · f` for inference,
//! [`FeatureTable`] records them for pseudo-likelihood learning, see
//! [`chain_instance`]), and keeps the sufficient statistics of its continuous nodes up
//! to date from label changes. Positions may have different numbers of states (pruned
//! association candidates), and a pairwise table may be *sparse*: one default entry
//! plus the entries a [`PairPattern`] lists ([`HybridChainModel::pair_pattern`]), for
//! large state spaces whose pairwise potential is constant almost everywhere (the full
//! association state space of CRF-Matching); its messages then cost at most
//! `O(s log s + nnz)` instead of `O(s_i · s_{i+1})` (see [`FlatChain`]).
//!
//! ```
//! use pgm_core::hybrid::chain::{ChainUpdate, FeatureSink, HybridChainModel, HybridChainParams};
//! use pgm_core::ParamGuard;
//!
//! /// Two cluster means over a sequence of numbers: local feature −(y − μ_l)², a
//! /// pairwise "same label" feature, and the means as continuous nodes.
//! struct Means { y: Vec<f64>, means: [f64; 2], sum: [f64; 2], count: [f64; 2] }
//!
//! impl HybridChainModel for Means {
//!     fn weights(&self) -> &[f64] { &[1.0, 2.0] }
//!     fn num_chains(&self) -> usize { 1 }
//!     fn chain_len(&self, _chain: usize) -> usize { self.y.len() }
//!     fn num_states(&self, _chain: usize, _i: usize) -> usize { 2 }
//!     fn write_local<S: FeatureSink>(&self, _chain: usize, i: usize, sink: &mut S) {
//!         for l in 0..2 { sink.add(l, 0, -(self.y[i] - self.means[l]).powi(2)); }
//!     }
//!     fn write_pair<S: FeatureSink>(&self, _chain: usize, _i: usize, sink: &mut S) {
//!         sink.add(0, 1, 1.0); // (0, 0)
//!         sink.add(3, 1, 1.0); // (1, 1)
//!     }
//!     fn set_label(&mut self, _chain: usize, i: usize, old: Option<usize>, new: usize) {
//!         if let Some(o) = old { self.sum[o] -= self.y[i]; self.count[o] -= 1.0; }
//!         self.sum[new] += self.y[i];
//!         self.count[new] += 1.0;
//!     }
//!     fn solve(&mut self) -> f64 {
//!         let mut change = 0.0f64;
//!         for l in 0..2 {
//!             if self.count[l] > 0.0 {
//!                 let m = self.sum[l] / self.count[l];
//!                 change = change.max((m - self.means[l]).abs());
//!                 self.means[l] = m;
//!             }
//!         }
//!         change
//!     }
//! }
//!
//! let y = vec![0.1, -0.2, 0.0, 0.2, 5.1, 4.9, 5.0, 5.2];
//! let mut model = Means { y, means: [0.0; 2], sum: [0.0; 2], count: [0.0; 2] };
//! let solver = HybridChainParams::default().update(ChainUpdate::EverySweep).check().unwrap();
//! // Start with the first half in cluster 0 and the rest in cluster 1, shifted by one.
//! let result = solver.run(&mut model, &[vec![0, 0, 0, 1, 1, 1, 1, 1]]).unwrap();
//! assert_eq!(result.labels[0], vec![0, 0, 0, 0, 1, 1, 1, 1]);
//! assert!((model.means[1] - 5.05).abs() < 1e-12);
//! assert!(result.converged);
//! ```

use super::{FlatChain, PairPattern};
use crate::error::{Error, Result};
use crate::graph::VariableId;
use crate::learning::{DenseFeatures, FeatureSet, LabelledInstance, LogLinearModel, TemplateId};
use crate::param::InvalidParameter;
use std::ops::ControlFlow;
use std::sync::Arc;

/// Receives the log-linear features of one table, entry by entry.
///
/// A table of position `i` has one entry per state (`a`). A dense table of the pair
/// `(i, i + 1)` has `s_i · s_{i+1}` entries in row-major order (`a · s_{i+1} + b`); a
/// sparse one (over the [`PairPattern`] `P` of [`HybridChainModel::pair_pattern`]) has
/// `P.len() + 1` entries: entry `p < P.len()` is the listed pair `P.entry(p)` (pattern
/// positions, row-major), entry `P.len()` ([`PairPattern::default_entry`]) is the
/// default, whose features every unlisted pair has. Features are indices into the
/// model's weight vector; an entry's log-potential is `Σ w[feature] · value` over
/// everything added to it.
pub trait FeatureSink {
    /// Adds `value` of feature `feature` to entry `entry`.
    fn add(&mut self, entry: usize, feature: usize, value: f64);

    /// Adds every `(feature, value)` of `features` to entry `entry`, in order: the
    /// same as calling [`FeatureSink::add`] for each in turn (to the last bit);
    /// sinks may do it faster (one read and write of the entry).
    #[inline]
    fn add_each<const N: usize>(&mut self, entry: usize, features: [(usize, f64); N])
    where
        Self: Sized,
    {
        for (feature, value) in features {
            self.add(entry, feature, value);
        }
    }

    /// In a pairwise table over one label space (`states × states` entries), adds
    /// `value` of feature `same` to the entries of equal states and of feature
    /// `different` to the others (the shape of Potts-like features such as eqs. 4 and
    /// 5 of CRF-Clustering). The same as calling [`FeatureSink::add`] per entry;
    /// sinks may do it faster. For dense tables only (it addresses entries
    /// `a · states + b`).
    fn add_agreement(&mut self, states: usize, same: usize, different: usize, value: f64) {
        for a in 0..states {
            for b in 0..states {
                self.add(a * states + b, if a == b { same } else { different }, value);
            }
        }
    }

    /// In a pairwise table with rows of `stride` entries, adds for every pair of
    /// states `a < rows`, `b < columns` the value `value(a, b)` of feature `same` when
    /// `a == b` and of feature `different` otherwise, to entry `a · stride + b` (the
    /// shape of eq. 6 of CRF-Clustering, split by whether the clusters agree). The
    /// same as calling [`FeatureSink::add`] per entry; sinks may do it faster. For
    /// dense tables only.
    fn add_agreement_with(
        &mut self,
        (rows, columns, stride): (usize, usize, usize),
        same: usize,
        different: usize,
        mut value: impl FnMut(usize, usize) -> f64,
    ) where
        Self: Sized,
    {
        for a in 0..rows {
            for b in 0..columns {
                let feature = if a == b { same } else { different };
                self.add(a * stride + b, feature, value(a, b));
            }
        }
    }
}

/// A [`FeatureSink`] that accumulates log-potentials `w · f` into a table (inference).
/// The table must be zeroed before a model writes into it.
#[derive(Debug)]
pub struct WeightedTable<'a> {
    weights: &'a [f64],
    table: &'a mut [f64],
}

impl<'a> WeightedTable<'a> {
    /// Accumulates into `table` with `weights`.
    pub fn new(weights: &'a [f64], table: &'a mut [f64]) -> Self {
        Self { weights, table }
    }
}

impl FeatureSink for WeightedTable<'_> {
    #[inline]
    fn add(&mut self, entry: usize, feature: usize, value: f64) {
        self.table[entry] += self.weights[feature] * value;
    }

    #[inline]
    fn add_each<const N: usize>(&mut self, entry: usize, features: [(usize, f64); N]) {
        // The same additions in the same order as `add` one by one, in a register.
        let slot = &mut self.table[entry];
        let mut sum = *slot;
        for (feature, value) in features {
            sum += self.weights[feature] * value;
        }
        *slot = sum;
    }

    #[inline]
    fn add_agreement(&mut self, states: usize, same: usize, different: usize, value: f64) {
        let (on, off) = (self.weights[same] * value, self.weights[different] * value);
        for (a, row) in self.table[..states * states]
            .chunks_exact_mut(states)
            .enumerate()
        {
            for x in row.iter_mut() {
                *x += off;
            }
            row[a] += on - off;
        }
    }

    #[inline]
    fn add_agreement_with(
        &mut self,
        (rows, columns, stride): (usize, usize, usize),
        same: usize,
        different: usize,
        mut value: impl FnMut(usize, usize) -> f64,
    ) {
        let (on, off) = (self.weights[same], self.weights[different]);
        for a in 0..rows {
            let row = &mut self.table[a * stride..a * stride + columns];
            for (b, x) in row.iter_mut().enumerate() {
                *x += if a == b { on } else { off } * value(a, b);
            }
        }
    }
}

/// A [`FeatureSink`] that records every entry's feature vector (learning):
/// `features[entry · width + feature] += value`, with `width` the number of weights.
#[derive(Debug)]
pub struct FeatureTable<'a> {
    width: usize,
    features: &'a mut [f64],
}

impl<'a> FeatureTable<'a> {
    /// Records into `features` (entries × `width`, zeroed by the caller).
    pub fn new(width: usize, features: &'a mut [f64]) -> Self {
        Self { width, features }
    }
}

impl FeatureSink for FeatureTable<'_> {
    #[inline]
    fn add(&mut self, entry: usize, feature: usize, value: f64) {
        self.features[entry * self.width + feature] += value;
    }
}

/// A model on one or more chains of discrete variables coupled to observed-continuous
/// nodes (see the module docs).
///
/// Contract: the features written for a table depend only on the current continuous
/// values and on the current labels of the *other* chains (as told by
/// [`HybridChainModel::set_label`]), never on the labels of the chain being written;
/// [`HybridChainModel::solve`] re-solves the continuous values from the labels told so
/// far.
pub trait HybridChainModel {
    /// The weight vector `w` the features are multiplied with.
    fn weights(&self) -> &[f64];

    /// Number of chains.
    fn num_chains(&self) -> usize;

    /// Number of positions of chain `chain`.
    fn chain_len(&self, chain: usize) -> usize;

    /// Number of states of position `i` of chain `chain` (at least 1).
    fn num_states(&self, chain: usize, i: usize) -> usize;

    /// Writes the local features of position `i` of `chain` (entry = state).
    fn write_local<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S);

    /// Writes the features of the pair `(i, i + 1)` of `chain`. Dense table
    /// ([`HybridChainModel::pair_pattern`] `None`): entry `a · s_{i+1} + b` for states
    /// `a` at `i` and `b` at `i + 1`. Sparse table over the pattern `P`: entry `p`
    /// (`p < P.len()`) for the listed pair `P.entry(p)`, whose features are all that
    /// pair gets (the default's are *not* added to it), and entry `P.len()` for the
    /// default, the features of every unlisted pair (see [`FeatureSink`]).
    fn write_pair<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S);

    /// The sparsity pattern of the pair `(i, i + 1)` of `chain`, or `None` (the
    /// default) for a dense table. With a pattern, [`HybridChainModel::write_pair`]
    /// writes `P.len() + 1` entries (the listed pairs in pattern order, then the
    /// default) and the solver's messages over the pair cost at most
    /// `O(s log s + P.len())` instead of `O(s_i · s_{i+1})` (see [`FlatChain`]). The pattern must have
    /// `num_states(chain, i)` rows and `num_states(chain, i + 1)` columns.
    ///
    /// Asked once per pair when [`HybridChain::run`] builds its buffers (so it must
    /// not change during a run; share one `Arc` between the pairs with the same
    /// pattern) and once per pair by [`chain_instance`], which expands sparse tables
    /// to dense ones (learning instances are dense: `s_i · s_{i+1}` feature vectors
    /// per pair).
    fn pair_pattern(&self, chain: usize, i: usize) -> Option<Arc<PairPattern>> {
        let _ = (chain, i);
        None
    }

    /// The label of position `i` of `chain` changed from `old` (`None` the first time)
    /// to `new`: update the sufficient statistics of the continuous nodes in O(1).
    fn set_label(&mut self, chain: usize, i: usize, old: Option<usize>, new: usize);

    /// Re-solves the continuous values in closed form from the labels; returns the
    /// largest change of a value (the continuous part's residual).
    fn solve(&mut self) -> f64;
}

/// When the continuous values are re-solved (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ChainUpdate {
    /// After each chain's exact MAP sweep (block coordinate ascent).
    #[default]
    EverySweep,
    /// After every position visit whose label changed (Algorithm 1).
    EveryVisit,
}

/// When a run of [`HybridChain`] has converged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Convergence {
    /// No continuous value changed by more than the tolerance in a sweep and, with
    /// several chains or [`ChainUpdate::EveryVisit`], no label changed either.
    #[default]
    Auto,
    /// No continuous value changed by more than the tolerance in a sweep, whatever the
    /// labels did: for models whose chains see each other mainly through the
    /// continuous values, where a few labels that keep flipping without moving the
    /// continuous values would otherwise keep the run going (and a slow drift along
    /// a poorly observed direction of the continuous values with it).
    Continuous,
    /// No continuous value changed by more than the tolerance and no label changed.
    ContinuousAndLabels,
}

/// Parameters of [`HybridChain`], unchecked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HybridChainParams {
    /// Largest number of sweeps (30).
    pub max_sweeps: usize,
    /// The run has converged when no continuous value changed by more than this in a
    /// sweep (and, as [`HybridChainParams::convergence`] says, no label changed)
    /// (1e-6).
    pub tolerance: f64,
    /// When the continuous values are re-solved.
    pub update: ChainUpdate,
    /// Stop when a sweep ends with the labels of one of the last [`CYCLE_MEMORY`]
    /// sweeps (or the start) without having converged (true): the alternation is then
    /// in a limit cycle (a label flip moves the continuous values just enough to flip
    /// it back) and would otherwise run to `max_sweeps`. The result reports
    /// [`HybridChainResult::cycled`].
    pub stop_on_cycle: bool,
    /// When the run has converged ([`Convergence::Auto`]).
    pub convergence: Convergence,
}

/// How many past labellings [`HybridChainParams::stop_on_cycle`] remembers.
pub const CYCLE_MEMORY: usize = 4;

impl Default for HybridChainParams {
    fn default() -> Self {
        Self {
            max_sweeps: 30,
            tolerance: 1e-6,
            update: ChainUpdate::EverySweep,
            stop_on_cycle: true,
            convergence: Convergence::Auto,
        }
    }
}

impl HybridChainParams {
    /// Sets the largest number of sweeps.
    pub fn max_sweeps(mut self, sweeps: usize) -> Self {
        self.max_sweeps = sweeps;
        self
    }

    /// Sets the convergence tolerance of the continuous values.
    pub fn tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// Sets when the continuous values are re-solved.
    pub fn update(mut self, update: ChainUpdate) -> Self {
        self.update = update;
        self
    }

    /// Sets whether a run stops when its labels revisit a recent labelling.
    pub fn stop_on_cycle(mut self, stop: bool) -> Self {
        self.stop_on_cycle = stop;
        self
    }

    /// Sets when a run has converged.
    pub fn convergence(mut self, convergence: Convergence) -> Self {
        self.convergence = convergence;
        self
    }
}

impl HybridChainParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        InvalidParameter::at_least_one("max_sweeps", self.max_sweeps)?;
        InvalidParameter::tolerance("tolerance", self.tolerance)?;
        Ok(())
    }
}

/// What an observer of [`HybridChain::run_observed`] sees after each sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepReport {
    /// The sweep just finished (from 1).
    pub sweep: usize,
    /// The largest change of a continuous value in the sweep.
    pub continuous_change: f64,
    /// How many labels changed in the sweep (all chains).
    pub labels_changed: usize,
    /// Whether the labels after the sweep equal those after one of the last
    /// [`CYCLE_MEMORY`] sweeps (or the start) although some changed in the sweep.
    pub revisited: bool,
}

/// The outcome of [`HybridChain::run`].
#[derive(Clone, Debug, PartialEq)]
pub struct HybridChainResult {
    /// The MAP label of every position, per chain.
    pub labels: Vec<Vec<usize>>,
    /// The normalised max-marginals of every position, per chain, laid out flat: the
    /// entries of position `i` start at `offsets[chain][i]` and there are
    /// `offsets[chain][i + 1] − offsets[chain][i]` of them.
    pub max_marginals: Vec<Vec<f64>>,
    /// Where each position's max-marginals start, per chain (`n + 1` entries).
    pub offsets: Vec<Vec<usize>>,
    /// Sweeps performed.
    pub sweeps: usize,
    /// Whether the run converged (see [`HybridChainParams::tolerance`]).
    pub converged: bool,
    /// The largest change of a continuous value in the last sweep.
    pub continuous_change: f64,
    /// How many times the continuous values were solved.
    pub solves: usize,
    /// Whether the run stopped in a limit cycle (see
    /// [`HybridChainParams::stop_on_cycle`]).
    pub cycled: bool,
}

impl HybridChainResult {
    /// The max-marginals of position `i` of `chain`.
    pub fn max_marginal(&self, chain: usize, i: usize) -> &[f64] {
        let o = &self.offsets[chain];
        &self.max_marginals[chain][o[i]..o[i + 1]]
    }
}

/// Per-chain buffers: the chain recursion and its tables.
struct ChainBuffers {
    chain: FlatChain,
    local: Vec<f64>,
    pair: Vec<f64>,
    labels: Vec<usize>,
    next: Vec<usize>,
    /// Whether the chain's backward messages are older than its tables (the last
    /// decode was [`FlatChain::viterbi_labels`]).
    backward_stale: bool,
}

impl ChainBuffers {
    /// # Errors
    /// When a pair's pattern does not fit its states.
    fn new<M: HybridChainModel>(model: &M, c: usize) -> Result<Self> {
        let n = model.chain_len(c);
        let states: Vec<usize> = (0..n).map(|i| model.num_states(c, i)).collect();
        let patterns = (0..n.saturating_sub(1))
            .map(|i| checked_pattern(model, c, i))
            .collect::<Result<Vec<_>>>()?;
        let chain = FlatChain::with_patterns(&states, patterns)?;
        Ok(Self {
            local: vec![0.0; chain.local_len()],
            pair: vec![0.0; chain.pair_len()],
            chain,
            labels: vec![0; n],
            next: vec![0; n],
            backward_stale: false,
        })
    }

    fn write_local<M: HybridChainModel>(&mut self, model: &M, c: usize, i: usize) {
        let (o, e) = (self.chain.local_offset(i), self.chain.local_offset(i + 1));
        let table = &mut self.local[o..e];
        table.fill(0.0);
        model.write_local(c, i, &mut WeightedTable::new(model.weights(), table));
    }

    fn write_pair<M: HybridChainModel>(&mut self, model: &M, c: usize, i: usize) {
        let o = self.chain.pair_offset(i);
        let table = &mut self.pair[o..o + self.chain.pair_table_len(i)];
        table.fill(0.0);
        model.write_pair(c, i, &mut WeightedTable::new(model.weights(), table));
    }

    fn write_all<M: HybridChainModel>(&mut self, model: &M, c: usize) {
        let n = self.labels.len();
        for i in 0..n {
            self.write_local(model, c, i);
            if i + 1 < n {
                self.write_pair(model, c, i);
            }
        }
    }
}

crate::checked_params! {
    /// The checked hybrid chain solver (see the module docs).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct HybridChain(HybridChainParams) -> Error;
}

impl HybridChain {
    /// Runs the alternation from `initial[chain][i]`, the starting label of each
    /// position (Algorithm 1, line 1: the labels are fed to the model and the
    /// continuous values solved once before the first sweep).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `initial` does not have one label per position
    /// of every chain, a label is out of range, a position has no state, or a pair's
    /// [pattern](HybridChainModel::pair_pattern) does not have the shape of its
    /// states.
    pub fn run<M: HybridChainModel>(
        &self,
        model: &mut M,
        initial: &[Vec<usize>],
    ) -> Result<HybridChainResult> {
        self.run_observed(model, initial, &mut |_| ControlFlow::Continue(()))
    }

    /// [`HybridChain::run`] with an observer that sees every sweep and may stop the
    /// run (the result then reports `converged: false` unless the stopping sweep
    /// converged).
    pub fn run_observed<M: HybridChainModel>(
        &self,
        model: &mut M,
        initial: &[Vec<usize>],
        observer: &mut dyn FnMut(&SweepReport) -> ControlFlow<()>,
    ) -> Result<HybridChainResult> {
        let chains = model.num_chains();
        check_label_count("initial labels", initial, chains, None)?;
        let mut buffers = Vec::with_capacity(chains);
        for (c, start) in initial.iter().enumerate() {
            let n = model.chain_len(c);
            check_label_count("initial labels", start, n, Some(c))?;
            for (i, &l) in start.iter().enumerate() {
                let s = model.num_states(c, i);
                if l >= s {
                    return Err(InvalidParameter::new(
                        "initial labels",
                        format!("label {l} at position {i} of chain {c}, which has {s} states"),
                        "a label below the position's number of states",
                    )
                    .into());
                }
            }
            let mut b = ChainBuffers::new(model, c)?;
            b.labels.copy_from_slice(start);
            buffers.push(b);
        }
        for (c, start) in initial.iter().enumerate() {
            for (i, &l) in start.iter().enumerate() {
                model.set_label(c, i, None, l);
            }
        }
        model.solve();
        let mut solves = 1;
        let mut sweeps = 0;
        let mut converged = false;
        let mut change = 0.0;
        let strict = match self.params.convergence {
            Convergence::Auto => chains > 1 || self.params.update == ChainUpdate::EveryVisit,
            Convergence::Continuous => false,
            Convergence::ContinuousAndLabels => true,
        };
        let mut recent = std::collections::VecDeque::with_capacity(CYCLE_MEMORY + 1);
        recent.push_back(labelling_hash(&buffers));
        let mut cycled = false;
        while sweeps < self.params.max_sweeps {
            sweeps += 1;
            change = 0.0f64;
            let mut changed = 0;
            for (c, b) in buffers.iter_mut().enumerate() {
                let (ch, n, s) = match self.params.update {
                    ChainUpdate::EverySweep => sweep_exact(model, c, b),
                    ChainUpdate::EveryVisit => sweep_visits(model, c, b),
                };
                change = change.max(ch);
                changed += n;
                solves += s;
            }
            converged = change <= self.params.tolerance && (!strict || changed == 0);
            let hash = labelling_hash(&buffers);
            let revisited = !converged && changed > 0 && recent.contains(&hash);
            if recent.len() == CYCLE_MEMORY + 1 {
                recent.pop_front();
            }
            recent.push_back(hash);
            let report = SweepReport {
                sweep: sweeps,
                continuous_change: change,
                labels_changed: changed,
                revisited,
            };
            if revisited && self.params.stop_on_cycle {
                cycled = true;
                let _ = observer(&report);
                break;
            }
            if converged || observer(&report).is_break() {
                if converged {
                    // The observer sees the converged sweep too.
                    let _ = observer(&report);
                }
                break;
            }
        }
        if self.params.update == ChainUpdate::EveryVisit {
            // Algorithm 1, lines 16-21: decode every chain exactly against the final
            // values (the max-marginals below come from this pass).
            for (c, b) in buffers.iter_mut().enumerate() {
                let (ch, _, s) = sweep_exact(model, c, b);
                change = change.max(ch);
                solves += s;
            }
        }
        let mut result = HybridChainResult {
            labels: Vec::with_capacity(chains),
            max_marginals: Vec::with_capacity(chains),
            offsets: Vec::with_capacity(chains),
            sweeps,
            converged,
            continuous_change: change,
            solves,
            cycled,
        };
        for mut b in buffers {
            if b.backward_stale {
                b.chain.backward_messages(&b.local, &b.pair);
            }
            let mut mm = vec![0.0; b.chain.local_len()];
            b.chain.max_marginals(&b.local, &mut mm);
            result.offsets.push(
                (0..=b.labels.len())
                    .map(|i| b.chain.local_offset(i))
                    .collect(),
            );
            result.max_marginals.push(mm);
            result.labels.push(b.labels);
        }
        Ok(result)
    }
}

/// A hash of every chain's labels (for [`HybridChainParams::stop_on_cycle`]).
fn labelling_hash(buffers: &[ChainBuffers]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for b in buffers {
        b.labels.hash(&mut h);
    }
    h.finish()
}

/// One exact sweep of chain `c`: tables for the current values, Viterbi, label
/// changes to the model, one solve. Returns (continuous change, labels changed, solves).
fn sweep_exact<M: HybridChainModel>(
    model: &mut M,
    c: usize,
    b: &mut ChainBuffers,
) -> (f64, usize, usize) {
    b.write_all(model, c);
    // The labels alone: the backward messages are only read by the max-marginals
    // at the end of the run (`HybridChain::run_observed`), which computes them once
    // on the final tables, as a full Viterbi pass on them would have left them.
    b.chain.viterbi_labels(&b.local, &b.pair, &mut b.next);
    b.backward_stale = true;
    let mut changed = 0;
    for (i, (&old, &new)) in b.labels.iter().zip(&b.next).enumerate() {
        if old != new {
            model.set_label(c, i, Some(old), new);
            changed += 1;
        }
    }
    std::mem::swap(&mut b.labels, &mut b.next);
    (model.solve(), changed, 1)
}

/// One forward-backward pass over chain `c` visiting every position (Algorithm 1):
/// the message into the visited position is recomputed from its neighbour's tables
/// written for the current values, its label is the argmax of its max-marginal, and
/// the values are re-solved right after a label change. Returns (largest continuous
/// change, labels changed, solves).
fn sweep_visits<M: HybridChainModel>(
    model: &mut M,
    c: usize,
    b: &mut ChainBuffers,
) -> (f64, usize, usize) {
    if b.backward_stale {
        // The visits read the backward messages of the previous pass.
        b.chain.backward_messages(&b.local, &b.pair);
        b.backward_stale = false;
    }
    let n = b.labels.len();
    let mut change = 0.0f64;
    let mut changed = 0;
    let mut solves = 0;
    let mut scores = Vec::new();
    let mut visit = |model: &mut M, b: &mut ChainBuffers, i: usize| {
        b.write_local(model, c, i);
        let s = b.chain.states()[i];
        scores.resize(s, 0.0);
        b.chain.max_marginal_scores(&b.local, i, &mut scores);
        let mut best = 0;
        for a in 1..s {
            if scores[a] > scores[best] {
                best = a;
            }
        }
        if best != b.labels[i] {
            model.set_label(c, i, Some(b.labels[i]), best);
            b.labels[i] = best;
            changed += 1;
            change = change.max(model.solve());
            solves += 1;
        }
    };
    for i in 0..n {
        if i > 0 {
            b.write_local(model, c, i - 1);
            b.write_pair(model, c, i - 1);
        }
        b.chain.update_forward(&b.local, &b.pair, i);
        visit(model, b, i);
    }
    for i in (0..n.saturating_sub(1)).rev() {
        b.write_local(model, c, i + 1);
        b.write_pair(model, c, i);
        b.chain.update_backward(&b.local, &b.pair, i);
        visit(model, b, i);
    }
    (change, changed, solves)
}

/// The pseudo-likelihood training instance of a [`HybridChainModel`] at its current
/// continuous values and labels: every position of every chain is a variable
/// (chain after chain), with the features the model writes for the true `labels`
/// (`labels[chain][i]`). The model's continuous values must already be solved from
/// the true labels (set them with [`HybridChainModel::set_label`] and
/// [`HybridChainModel::solve`]; the papers treat the continuous nodes as observed
/// during learning). Features of templates that a table never uses are left out.
///
/// Local tables are written with the other chains at their true labels (the
/// contract of [`HybridChainModel`]), so chains coupled through their labels are
/// learned with the coupling fixed at the truth, as pseudo-likelihood conditions on the
/// Markov blanket.
///
/// A sparse pair ([`HybridChainModel::pair_pattern`]) is expanded to its dense
/// table: every unlisted pair gets the default entry's features, so the instance is
/// the one of the equivalent dense model (and takes `s_i · s_{i+1}` feature vectors
/// per pair: meant for learning-size state spaces).
///
/// # Errors
/// When `labels` does not fit the chains, a pair's pattern does not have the shape of
/// its states, or the feature set disagrees with the model's weight count.
pub fn chain_instance<M: HybridChainModel>(
    model: &M,
    features: &Arc<FeatureSet>,
    labels: &[Vec<usize>],
) -> Result<LabelledInstance> {
    let width = features.num_weights();
    if width != model.weights().len() {
        return Err(InvalidParameter::new(
            "feature set",
            format!(
                "{width} weights in the feature set, {} in the model",
                model.weights().len()
            ),
            "the feature set of the model",
        )
        .into());
    }
    let chains = model.num_chains();
    check_label_count("labels", labels, chains, None)?;
    let mut first = Vec::with_capacity(chains);
    let mut cardinalities = Vec::new();
    let mut all_labels = Vec::new();
    for (c, l) in labels.iter().enumerate() {
        let n = model.chain_len(c);
        check_label_count("labels", l, n, Some(c))?;
        first.push(cardinalities.len());
        for i in 0..n {
            cardinalities.push(model.num_states(c, i));
        }
        all_labels.extend_from_slice(l);
    }
    let mut model_out = LogLinearModel::new(Arc::clone(features), &cardinalities)?;
    let mut buffer = Vec::new();
    let mut sparse = Vec::new();
    for (c, &base) in first.iter().enumerate() {
        let n = model.chain_len(c);
        for i in 0..n {
            let s = model.num_states(c, i);
            buffer.clear();
            buffer.resize(s * width, 0.0);
            model.write_local(c, i, &mut FeatureTable::new(width, &mut buffer));
            add_feature_cliques(&mut model_out, vec![VariableId(base + i)], vec![s], &buffer)?;
            if i + 1 < n {
                let t = model.num_states(c, i + 1);
                buffer.clear();
                buffer.resize(s * t * width, 0.0);
                match checked_pattern(model, c, i)? {
                    None => model.write_pair(c, i, &mut FeatureTable::new(width, &mut buffer)),
                    Some(pattern) => {
                        sparse.clear();
                        sparse.resize(pattern.table_len() * width, 0.0);
                        model.write_pair(c, i, &mut FeatureTable::new(width, &mut sparse));
                        pattern.expand(&sparse, width, &mut buffer);
                    }
                }
                add_feature_cliques(
                    &mut model_out,
                    vec![VariableId(base + i), VariableId(base + i + 1)],
                    vec![s, t],
                    &buffer,
                )?;
            }
        }
    }
    Ok(LabelledInstance::new(model_out, all_labels))
}

/// Checks the length of `labels`, the parameter `what`: one label sequence for each
/// of the `expected` chains (`chain` is `None`), or one label for each of the
/// `expected` positions of chain `chain`.
fn check_label_count<T>(
    what: &'static str,
    labels: &[T],
    expected: usize,
    chain: Option<usize>,
) -> Result<()> {
    if labels.len() == expected {
        return Ok(());
    }
    let found = labels.len();
    let (value, expectation) = match chain {
        None => (
            format!("{found} chains of labels for {expected} chains"),
            "one label sequence per chain",
        ),
        Some(c) => (
            format!("{found} labels for the {expected} positions of chain {c}"),
            "one label per position",
        ),
    };
    Err(InvalidParameter::new(what, value, expectation).into())
}

/// The pattern of the pair `(i, i + 1)` of chain `c`, checked against the states.
fn checked_pattern<M: HybridChainModel>(
    model: &M,
    c: usize,
    i: usize,
) -> Result<Option<Arc<PairPattern>>> {
    let pattern = model.pair_pattern(c, i);
    if let Some(p) = &pattern {
        let (s, t) = (model.num_states(c, i), model.num_states(c, i + 1));
        if (p.rows(), p.columns()) != (s, t) {
            return Err(InvalidParameter::new(
                "pair pattern",
                format!(
                    "a {} x {} pattern for positions {i} and {} of chain {c}, which have {s} and {t} states",
                    p.rows(),
                    p.columns(),
                    i + 1
                ),
                "one row per state of the first position and one column per state of the second",
            )
            .into());
        }
    }
    Ok(pattern)
}

/// Adds to `model` the cliques over `scope` (with `shape`) whose features were
/// recorded in `features` by a [`FeatureTable`] (entries × all weights of the model's
/// feature set): one [`DenseFeatures`] clique per template that some entry uses
/// (templates whose features are all zero are left out).
///
/// # Errors
/// When `features` does not hold `Π shape × num_weights` values, or the learning
/// model refuses the clique (scope, shape).
pub fn add_feature_cliques(
    model: &mut LogLinearModel,
    scope: Vec<VariableId>,
    shape: Vec<usize>,
    features: &[f64],
) -> Result<()> {
    let set = Arc::clone(model.feature_set());
    let width = set.num_weights();
    let entries: usize = shape.iter().product();
    if features.len() != entries * width {
        return Err(Error::TableSize {
            expected: entries * width,
            actual: features.len(),
        });
    }
    for (t, template) in set.templates().iter().enumerate() {
        let range = template.weights();
        let row = |e: usize| &features[e * width + range.start..e * width + range.end];
        if !(0..entries).any(|e| row(e).iter().any(|&x| x != 0.0)) {
            continue;
        }
        let mut table = Vec::with_capacity(entries * range.len());
        for e in 0..entries {
            table.extend_from_slice(row(e));
        }
        model.add_clique(
            TemplateId(t),
            DenseFeatures::new(scope.clone(), shape.clone(), range.len(), table)?,
        )?;
    }
    Ok(())
}
