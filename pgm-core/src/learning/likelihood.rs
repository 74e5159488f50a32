//! The conditional likelihood of log-linear CRFs, exact on chains and trees and by the
//! Bethe approximation of loopy belief propagation on any graph.
//!
//! For an instance with features `F(x) = Σ_c f_c(x_c, z)` and labels `y`,
//! `log p(y | z; w) = w · F(y) − log Z(w)`, `Z(w) = Σ_x exp(w · F(x))`, and
//! `∂ log p / ∂w = F(y) − E_w[F]`, the expectation taken under the model's clique
//! marginals `p(x_c)` (Koller & Friedman, *Probabilistic Graphical Models*, §20.3;
//! CRFsuite's and UGM's maximum likelihood).
//!
//! Both quantities come from sum-product belief propagation on the instance's factor
//! graph: the clique beliefs `b_c(x_c) ∝ exp(θ_c(x_c)) Π_{v∈c} m_{v→c}(x_v)` and the
//! Bethe free energy
//!
//! `F_B = Σ_c Σ_{x_c} b_c (log b_c − θ_c) − Σ_v (d_v − 1) Σ_{x_v} b_v log b_v`,
//!
//! with `log Z ≈ −F_B` (Yedidia, Freeman & Weiss, "Constructing free-energy
//! approximations and generalized belief propagation algorithms", IEEE Trans. IT
//! 51(7), 2005). On a forest BP converges to the exact marginals and `−F_B = log Z`
//! exactly: that is [`LikelihoodKind::Exact`], which refuses a graph with a cycle
//! (cliques over the same variables in the same order share one factor first, so
//! several templates on one pair do not count as a cycle). On a
//! loopy graph ([`LikelihoodKind::Bethe`]) the beliefs are BP's fixed point and `−F_B`
//! its approximation of `log Z`; at a fixed point its gradient is exactly the beliefs'
//! expectation, so the objective and its gradient agree, but it is neither a bound nor
//! convex, and BP may not converge on strongly coupled models (an error naming the
//! instance; damping or pseudo-likelihood are the remedies).
//!
//! **The chain fast path.** For [`LikelihoodKind::Exact`], an instance whose cliques are
//! all unary or pairwise (a linear chain, or any forest of pairwise cliques) is not
//! run through the general path above but through scaled forward-backward in
//! probability space, the way CRFsuite's `crf1d` does it (Sutton & McCallum, "An
//! Introduction to Conditional Random Fields", Found. Trends ML 4(4), 2012, §4.1): its
//! features are interned once as sparse patterns shared by cliques (CRFsuite's
//! attribute × label features), each pass computes every pattern's scores and every
//! distinct edge's `exp(θ − max θ)` once, per variable `exp(θ_v − max θ_v)`, an upward
//! and a downward sweep scaled at every variable (`log Z` is the sum of the logs of the
//! scaling factors and maxima), and the expected counts through the patterns. It
//! reuses its buffers (no allocation per pass but the result) and splits the instances
//! into one chunk per rayon thread. The result is the same function as the general
//! path's to rounding (tests hold them within 1e-10 relative). A score of −∞ (a hard
//! zero) is exact in probability space; an instance whose potentials leave `exp`'s
//! range (a scaling factor or edge normaliser underflowing to zero) is swept in log
//! space instead, and one with a score of +∞ or NaN is handed back to the general
//! path for that evaluation, so extreme weights stay exact. The Bethe likelihood
//! always takes the general path.

use super::chain::{Added, ChainBuilder, ChainPath};
use super::model::{CliqueFeatures, FeatureSet, LabelledInstance};
use super::pseudo_likelihood::DEFAULT_FEATURE_CACHE_BYTES;
use crate::error::{Error, Result};
use crate::graph::{FactorGraph, FactorId, VariableId};
use crate::{BeliefPropagation, BpParams, Mode, ParamGuard, Sequential, TableFactor};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::{Arc, Mutex};

/// Which likelihood [`Likelihood`] evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LikelihoodKind {
    /// The exact likelihood: every instance's factor graph must be a forest (chains and
    /// trees), where belief propagation is exact. Instances of unary and pairwise
    /// cliques take the scaled forward-backward fast path (module docs).
    Exact,
    /// The Bethe approximation from loopy belief propagation's fixed point, for any
    /// graph.
    Bethe,
}

impl LikelihoodKind {
    fn name(self) -> &'static str {
        match self {
            LikelihoodKind::Exact => "maximum likelihood",
            LikelihoodKind::Bethe => "Bethe likelihood",
        }
    }
}

/// The negative conditional log-likelihood of a training set with a Gaussian prior, and
/// its gradient (see the module docs).
///
/// ```
/// use std::sync::Arc;
/// use pgm_core::learning::{DenseFeatures, FeatureSet, LabelledInstance, Likelihood, LikelihoodKind, LogLinearModel};
/// use pgm_core::VariableId;
///
/// // One binary variable, one feature "x = 1", label 1: −log p = log(1 + e^w) − w.
/// let mut features = FeatureSet::new("coin", 1);
/// let bias = features.add_template("bias", &["one"]).unwrap();
/// let features = Arc::new(features);
/// let mut model = LogLinearModel::new(Arc::clone(&features), &[2]).unwrap();
/// model.add_clique(bias, DenseFeatures::new(vec![VariableId(0)], vec![2], 1, vec![0.0, 1.0]).unwrap()).unwrap();
/// let data = vec![LabelledInstance::new(model, vec![1])];
///
/// let objective = Likelihood::new(LikelihoodKind::Exact, features, &data, f64::INFINITY).unwrap();
/// let (value, gradient) = objective.value_and_gradient(&[0.0]).unwrap();
/// assert!((value - 2f64.ln()).abs() < 1e-12);
/// assert!((gradient[0] + 0.5).abs() < 1e-12);
/// ```
#[derive(Debug)]
pub struct Likelihood<'a> {
    kind: LikelihoodKind,
    features: Arc<FeatureSet>,
    instances: &'a [LabelledInstance],
    prior_variance: f64,
    bp: BeliefPropagation,
    /// `bp` limited to one iteration, for forests.
    one_pass: BeliefPropagation,
    /// The instances on the general path, each with its factor graph (tables refreshed
    /// at each evaluation), its observed feature totals and, within the cache limit,
    /// its sparse features.
    general: Vec<(usize, Mutex<InstanceState>)>,
    /// The exact likelihood's fast path over the instances of unary and pairwise
    /// cliques ([`super::chain`]).
    chain: Option<ChainPath>,
    /// Per instance of the fast path, its general-path state, built the first time the
    /// fast path hands the instance back.
    fallback: Vec<Mutex<Option<InstanceState>>>,
}

/// What an evaluation of one instance reuses.
#[derive(Debug)]
struct InstanceState {
    /// One factor per distinct clique scope ([`merged_graph`]).
    graph: FactorGraph,
    /// The cliques of each factor.
    groups: Vec<Vec<usize>>,
    observed: Vec<f64>,
    /// The nonzero features of every clique's joint states; `None` beyond the cache
    /// limit, where they are computed again at each evaluation.
    cache: Option<Vec<SparseClique>>,
}

/// The nonzero features of one clique: joint state `x`'s are
/// `entries[starts[x]..starts[x + 1]]`, (feature within the template, value).
#[derive(Debug)]
struct SparseClique {
    starts: Vec<u32>,
    entries: Vec<(u32, f64)>,
}

impl SparseClique {
    fn new(clique: &dyn CliqueFeatures, width: usize) -> Self {
        let size: usize = clique.shape().iter().product();
        let mut starts = Vec::with_capacity(size + 1);
        let mut entries = Vec::new();
        let mut states = vec![0usize; clique.shape().len()];
        let mut buffer = vec![0.0; width];
        starts.push(0);
        for _ in 0..size {
            buffer.iter_mut().for_each(|x| *x = 0.0);
            clique.features(&states, &mut buffer);
            entries.extend(
                buffer
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| **v != 0.0)
                    .map(|(j, v)| (j as u32, *v)),
            );
            starts.push(entries.len() as u32);
            crate::factor::increment(&mut states, clique.shape());
        }
        Self { starts, entries }
    }

    fn bytes(&self) -> usize {
        self.starts.len() * 4 + self.entries.len() * 16
    }

    fn state(&self, x: usize) -> &[(u32, f64)] {
        &self.entries[self.starts[x] as usize..self.starts[x + 1] as usize]
    }
}

/// One instance's log-likelihood and `F(y) − E[F]`.
struct Term {
    log_likelihood: f64,
    gradient: Vec<f64>,
}

impl<'a> Likelihood<'a> {
    /// The settings of the sum-product runs [`new`](Self::new) uses: sequential
    /// schedule, tolerance 1e-10 on the messages, at most 1,000 iterations, no damping.
    pub fn default_bp() -> BpParams {
        BpParams::new(Mode::SumProduct)
            .tolerance(1e-10)
            .max_iterations(1000)
    }

    /// The objective of `kind` over `instances`, whose models must all use `features`,
    /// with a Gaussian prior of variance `prior_variance` (σ² > 0; `f64::INFINITY` for
    /// none), belief propagation as [`default_bp`](Self::default_bp).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for an empty training set, a model over another
    /// feature set or a bad prior; labels that do not fit their model; for
    /// [`LikelihoodKind::Exact`], [`Error::NotApplicable`] naming the first instance
    /// whose factor graph has a cycle.
    pub fn new(
        kind: LikelihoodKind,
        features: Arc<FeatureSet>,
        instances: &'a [LabelledInstance],
        prior_variance: f64,
    ) -> Result<Self> {
        Self::with_bp(
            kind,
            features,
            instances,
            prior_variance,
            Self::default_bp(),
        )
    }

    /// [`new`](Self::new) with other belief-propagation settings (`bp` must be
    /// sum-product; damping helps BP converge on strongly coupled loopy models).
    ///
    /// # Errors
    /// As [`new`](Self::new), and the settings' own errors.
    pub fn with_bp(
        kind: LikelihoodKind,
        features: Arc<FeatureSet>,
        instances: &'a [LabelledInstance],
        prior_variance: f64,
        bp: BpParams,
    ) -> Result<Self> {
        Self::build(kind, features, instances, prior_variance, bp, true)
    }

    /// [`with_bp`](Self::with_bp), with the fast path for instances of unary and
    /// pairwise cliques on forests ([`super::chain`]) used by [`LikelihoodKind::Exact`]
    /// when `chain_path` (the general path alone otherwise, for comparison).
    pub(crate) fn build(
        kind: LikelihoodKind,
        features: Arc<FeatureSet>,
        instances: &'a [LabelledInstance],
        prior_variance: f64,
        bp: BpParams,
        chain_path: bool,
    ) -> Result<Self> {
        let one_pass = bp.clone().max_iterations(1).check()?;
        let bp = bp.check()?;
        if bp.mode() != Mode::SumProduct {
            return Err(Error::InvalidParameter {
                name: "bp mode",
                value: format!("{:?}", bp.mode()),
                expected: "sum-product: the likelihood needs marginals",
            });
        }
        if instances.is_empty() {
            return Err(Error::InvalidParameter {
                name: "instances",
                value: "none".into(),
                expected: "at least one labelled instance",
            });
        }
        if prior_variance.is_nan() || prior_variance <= 0.0 {
            return Err(Error::InvalidParameter {
                name: "prior_variance",
                value: prior_variance.to_string(),
                expected: "σ² > 0, or infinity for no prior",
            });
        }
        let zeros = vec![0.0; features.num_weights()];
        let mut general = Vec::new();
        let mut chain = ChainBuilder::new(features.num_weights());
        let mut cached_bytes = 0usize;
        let cycle = |i: usize| Error::NotApplicable {
            method: "maximum likelihood (exact)",
            reason: format!(
                "instance {i}: its factor graph has a cycle (cliques over the \
                 same variables counted once), where belief propagation is not \
                 exact; use the Bethe likelihood or pseudo-likelihood"
            ),
        };
        for (i, instance) in instances.iter().enumerate() {
            instance.model.feature_set().check_same(&features)?;
            let observed = instance
                .model
                .feature_totals(&instance.labels)
                .map_err(|e| Error::InvalidParameter {
                    name: "labels",
                    value: format!("instance {i}: {e}"),
                    expected: "one state per variable of its model",
                })?;
            if chain_path && kind == LikelihoodKind::Exact {
                match chain.add(i, instance, &observed)? {
                    Added::Yes => continue,
                    Added::Cycle => return Err(cycle(i)),
                    Added::NotPairwise => {}
                }
            }
            // Checks the features and log-potentials at zero weights.
            instance.model.to_factor_graph(&zeros)?;
            let (graph, groups) = merged_graph(&instance.model)?;
            if kind == LikelihoodKind::Exact && !graph.is_forest() {
                return Err(cycle(i));
            }
            let mut cache = None;
            if cached_bytes < DEFAULT_FEATURE_CACHE_BYTES {
                let model = &instance.model;
                let cliques: Vec<SparseClique> = (0..model.num_cliques())
                    .map(|c| {
                        let clique = model.clique(c).expect("clique index in range");
                        SparseClique::new(clique, template_range(&features, model, c).len())
                    })
                    .collect();
                let bytes: usize = cliques.iter().map(SparseClique::bytes).sum();
                if cached_bytes + bytes <= DEFAULT_FEATURE_CACHE_BYTES {
                    cached_bytes += bytes;
                    cache = Some(cliques);
                }
            }
            general.push((
                i,
                Mutex::new(InstanceState {
                    graph,
                    groups,
                    observed,
                    cache,
                }),
            ));
        }
        let (chain, fallback) = if chain.len() > 0 {
            let fallback = (0..chain.len()).map(|_| Mutex::new(None)).collect();
            (Some(chain.finish(rayon::current_num_threads())), fallback)
        } else {
            (None, Vec::new())
        };
        Ok(Likelihood {
            kind,
            features,
            instances,
            prior_variance,
            bp,
            one_pass,
            general,
            chain,
            fallback,
        })
    }

    /// Number of instances on the fast path of unary and pairwise cliques on forests.
    #[cfg(test)]
    pub(crate) fn chain_instances(&self) -> usize {
        self.fallback.len()
    }

    /// How many instances the fast path hands back to the general path at `weights`.
    #[cfg(test)]
    pub(crate) fn chain_fallbacks(&self, weights: &[f64]) -> usize {
        let mut gradient = vec![0.0; weights.len()];
        self.chain.as_ref().map_or(0, |c| {
            c.evaluate(weights, &mut gradient)
                .expect("an evaluation")
                .1
                .len()
        })
    }

    /// Which likelihood.
    pub fn kind(&self) -> LikelihoodKind {
        self.kind
    }

    /// Number of weights.
    pub fn num_weights(&self) -> usize {
        self.features.num_weights()
    }

    /// The feature set.
    pub fn feature_set(&self) -> &Arc<FeatureSet> {
        &self.features
    }

    /// The log-likelihood `Σ_i log p(y_i | z_i; w)` (no prior, not negated).
    ///
    /// # Errors
    /// As [`value_and_gradient`](Self::value_and_gradient).
    pub fn log_likelihood(&self, weights: &[f64]) -> Result<f64> {
        Ok(self.terms(weights)?.0)
    }

    /// The objective to minimise, `−Σ_i log p(y_i | z_i; w) + ‖w‖² / (2σ²)`, and its
    /// gradient `Σ_i (E_w[F_i] − F_i(y_i)) + w / σ²`.
    ///
    /// # Errors
    /// Weights of the wrong length or not finite; a non-finite feature; belief
    /// propagation that did not converge on an instance ([`Error::NotApplicable`]
    /// naming it, its iterations and residual).
    pub fn value_and_gradient(&self, weights: &[f64]) -> Result<(f64, Vec<f64>)> {
        let (ll, mut gradient) = self.terms(weights)?;
        let mut value = -ll;
        for (g, &w) in gradient.iter_mut().zip(weights) {
            *g = -*g;
            if self.prior_variance.is_finite() {
                value += w * w / (2.0 * self.prior_variance);
                *g += w / self.prior_variance;
            }
        }
        Ok((value, gradient))
    }

    /// The log-likelihood and its gradient `Σ_i (F_i(y_i) − E[F_i])`.
    fn terms(&self, weights: &[f64]) -> Result<(f64, Vec<f64>)> {
        self.features.check_weights(weights)?;
        let mut gradient = vec![0.0; weights.len()];
        let mut ll = 0.0;
        let poisoned = |i: usize| Error::NotApplicable {
            method: self.kind.name(),
            reason: format!("instance {i}: a previous evaluation panicked"),
        };
        if let Some(chain) = &self.chain {
            let (chain_ll, fallbacks) = chain.evaluate(weights, &mut gradient)?;
            ll += chain_ll;
            // The instances the fast path handed back, by the general path; their
            // observed totals are already in the gradient.
            let terms: Vec<Term> = fallbacks
                .par_iter()
                .map(|&position| {
                    let i = chain.instance_index(position);
                    let instance = &self.instances[i];
                    let mut slot = self.fallback[position].lock().map_err(|_| poisoned(i))?;
                    if slot.is_none() {
                        let (graph, groups) = merged_graph(&instance.model)?;
                        let observed = instance.model.feature_totals(&instance.labels)?;
                        *slot = Some(InstanceState {
                            graph,
                            groups,
                            observed,
                            cache: None,
                        });
                    }
                    let state = slot.as_mut().expect("built above");
                    let mut term = self.term(i, instance, state, weights)?;
                    for (g, o) in term.gradient.iter_mut().zip(&state.observed) {
                        *g -= o;
                    }
                    Ok(term)
                })
                .collect::<Result<_>>()?;
            for t in terms {
                ll += t.log_likelihood;
                for (g, x) in gradient.iter_mut().zip(&t.gradient) {
                    *g += x;
                }
            }
        }
        let terms: Vec<Term> = self
            .general
            .par_iter()
            .map(|(i, state)| {
                let mut state = state.lock().map_err(|_| poisoned(*i))?;
                self.term(*i, &self.instances[*i], &mut state, weights)
            })
            .collect::<Result<_>>()?;
        for t in terms {
            ll += t.log_likelihood;
            for (g, x) in gradient.iter_mut().zip(&t.gradient) {
                *g += x;
            }
        }
        Ok((ll, gradient))
    }

    fn term(
        &self,
        index: usize,
        instance: &LabelledInstance,
        state: &mut InstanceState,
        weights: &[f64],
    ) -> Result<Term> {
        let model = &instance.model;
        let InstanceState {
            graph,
            groups,
            observed,
            cache,
        } = state;
        // Each factor's log-potentials: the sum of its cliques' θ_c = w · f_c, written
        // into the graph's table and kept (flat, factor after factor) for the beliefs.
        let mut buffer = Vec::new();
        let mut all_thetas = Vec::new();
        let mut theta_start = Vec::with_capacity(groups.len() + 1);
        for (f, group) in groups.iter().enumerate() {
            theta_start.push(all_thetas.len());
            let table = graph
                .factor_mut(FactorId(f))
                .as_any_mut()
                .and_then(|f| f.downcast_mut::<TableFactor>())
                .expect("a TableFactor per group of cliques")
                .table_mut();
            table.iter_mut().for_each(|t| *t = 0.0);
            for &c in group {
                let w = &weights[template_range(&self.features, model, c)];
                match cache {
                    Some(cliques) => {
                        for (x, theta) in table.iter_mut().enumerate() {
                            *theta += cliques[c]
                                .state(x)
                                .iter()
                                .map(|&(j, v)| w[j as usize] * v)
                                .sum::<f64>();
                        }
                    }
                    None => {
                        let clique = model.clique(c).expect("clique index in range");
                        let shape = clique.shape();
                        let mut states = vec![0usize; shape.len()];
                        for theta in table.iter_mut() {
                            buffer.clear();
                            buffer.resize(w.len(), 0.0);
                            clique.features(&states, &mut buffer);
                            if let Some(e) =
                                model.bad_feature(c, &states, &buffer, Some(index), None)
                            {
                                return Err(e);
                            }
                            *theta += w.iter().zip(&buffer).map(|(a, b)| a * b).sum::<f64>();
                            crate::factor::increment(&mut states, shape);
                        }
                    }
                }
            }
            all_thetas.extend_from_slice(table);
        }
        theta_start.push(all_thetas.len());
        let graph = &*graph;
        let run = match self.kind {
            // On a forest the two-pass order is exact in one iteration: the second one
            // BP would run to see the messages settle is skipped.
            LikelihoodKind::Exact => self
                .one_pass
                .on(graph)
                .propagate(&mut Sequential::default())?,
            LikelihoodKind::Bethe => self.bp.on(graph).propagate(&mut Sequential::default())?,
        };
        if self.kind == LikelihoodKind::Bethe && !run.converged {
            return Err(Error::NotApplicable {
                method: self.kind.name(),
                reason: format!(
                    "instance {index}: sum-product belief propagation did not converge in \
                     {} iterations (residual {:.3e}); damping, more iterations or \
                     pseudo-likelihood",
                    run.iterations, run.residual
                ),
            });
        }
        let log_beliefs: Vec<Vec<f64>> = (0..graph.num_variables())
            .map(|v| normalised(&run.messages.log_belief(graph, VariableId(v))))
            .collect();
        // A single-variable factor's belief is its variable's.
        let beliefs: Vec<Vec<f64>> = log_beliefs
            .iter()
            .map(|lb| lb.iter().map(|l| l.exp()).collect())
            .collect();
        let mut gradient = observed.clone();
        // −F_B, accumulated: Σ_a Σ b_a (θ_a − log b_a) + Σ_v (d_v − 1) Σ b_v log b_v.
        let mut log_partition = 0.0;
        for (v, lb) in log_beliefs.iter().enumerate() {
            let degree = graph.variable_edges(VariableId(v)).len() as f64;
            log_partition += (degree - 1.0) * entropy_term(lb);
        }
        let mut states = Vec::new();
        let mut log_b = Vec::new();
        let mut pair_b;
        let mut probabilities = Vec::new();
        for (f, group) in groups.iter().enumerate() {
            let factor = graph.factor(FactorId(f));
            let shape = factor.shape();
            let thetas = &all_thetas[theta_start[f]..theta_start[f + 1]];
            let edges = graph.factor_edges(FactorId(f));
            // log b_a(x) = θ_a(x) + Σ_j (log b_{v_j}(x_j) − log m_{a→v_j}(x_j)) + const;
            // a single-variable factor's is its variable's.
            let single = (edges.len() == 1)
                .then(|| graph.edge_variable(crate::graph::EdgeId(edges.start)).0);
            let lb: &[f64] = match single {
                Some(v) => &log_beliefs[v],
                None => {
                    log_b.clear();
                    states.clear();
                    states.resize(shape.len(), 0);
                    for &theta in thetas {
                        let mut value = theta;
                        for (j, e) in edges.clone().enumerate() {
                            let e = crate::graph::EdgeId(e);
                            let v = graph.edge_variable(e).0;
                            value += log_beliefs[v][states[j]]
                                - run.messages.message(graph, e)[states[j]];
                        }
                        log_b.push(value);
                        crate::factor::increment(&mut states, shape);
                    }
                    pair_b = normalised(&log_b);
                    &pair_b
                }
            };
            // The factor's part of −F_B, and its probabilities.
            probabilities.clear();
            for (x, &l) in lb.iter().enumerate() {
                if l > f64::NEG_INFINITY {
                    let p = match single {
                        Some(v) => beliefs[v][x],
                        None => l.exp(),
                    };
                    log_partition += p * (thetas[x] - l);
                    probabilities.push(p);
                } else {
                    probabilities.push(0.0);
                }
            }
            // E[f_c] of each of its cliques.
            for &c in group {
                let range = template_range(&self.features, model, c);
                let width = range.len();
                let gradient = &mut gradient[range];
                match cache {
                    Some(cliques) => {
                        for (x, &p) in probabilities.iter().enumerate() {
                            for &(j, v) in cliques[c].state(x) {
                                gradient[j as usize] -= p * v;
                            }
                        }
                    }
                    None => {
                        let clique = model.clique(c).expect("clique index in range");
                        states.clear();
                        states.resize(shape.len(), 0);
                        for &p in &probabilities {
                            if p > 0.0 {
                                buffer.clear();
                                buffer.resize(width, 0.0);
                                clique.features(&states, &mut buffer);
                                for (g, f) in gradient.iter_mut().zip(&buffer) {
                                    *g -= p * f;
                                }
                            }
                            crate::factor::increment(&mut states, shape);
                        }
                    }
                }
            }
        }
        let score: f64 = observed.iter().zip(weights).map(|(f, w)| f * w).sum();
        Ok(Term {
            log_likelihood: score - log_partition,
            gradient,
        })
    }
}

/// The factor graph of `model` with one zero [`TableFactor`] per distinct scope (the
/// cliques over the same variables in the same order share it, so that several
/// templates on one pair of variables do not close a cycle), and each factor's cliques.
fn merged_graph(model: &super::LogLinearModel) -> Result<(FactorGraph, Vec<Vec<usize>>)> {
    let mut graph = FactorGraph::with_variables(model.cardinalities())?;
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut by_scope: std::collections::HashMap<Vec<VariableId>, usize> =
        std::collections::HashMap::new();
    for c in 0..model.num_cliques() {
        let clique = model.clique(c).expect("clique index in range");
        let scope = clique.scope().to_vec();
        match by_scope.get(&scope) {
            Some(&f) => groups[f].push(c),
            None => {
                let shape = clique.shape().to_vec();
                let size = shape.iter().product();
                graph.add_factor(TableFactor::new(scope.clone(), shape, vec![0.0; size])?)?;
                by_scope.insert(scope, groups.len());
                groups.push(vec![c]);
            }
        }
    }
    Ok((graph, groups))
}

/// The weights (indices into the weight vector) of clique `c`'s template.
fn template_range(features: &FeatureSet, model: &super::LogLinearModel, c: usize) -> Range<usize> {
    let template = model.clique_template(c).expect("clique index in range");
    features
        .template(template)
        .expect("the model's own template")
        .weights()
}

/// `x − log Σ exp(x)`.
fn normalised(x: &[f64]) -> Vec<f64> {
    let z = crate::logspace::log_sum_exp(x);
    x.iter().map(|v| v - z).collect()
}

/// `Σ p log p` of a normalised log-distribution (0 log 0 = 0).
fn entropy_term(log_p: &[f64]) -> f64 {
    log_p
        .iter()
        .filter(|l| **l > f64::NEG_INFINITY)
        .map(|l| l.exp() * l)
        .sum()
}
