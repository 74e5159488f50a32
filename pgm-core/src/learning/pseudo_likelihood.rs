//! The pseudo-likelihood objective and its analytic gradient (CRF-Clustering paper,
//! section III; joint-model paper, section III-B).
//!
//! For labelled instances `(z⁽ⁿ⁾, x⁽ⁿ⁾)` the log pseudo-likelihood is
//!
//! `PL(w) = Σ_n Σ_i log p(x_i⁽ⁿ⁾ | x_MB(i)⁽ⁿ⁾, z⁽ⁿ⁾)`,
//!
//! where the local conditional of variable `i` only involves the cliques containing
//! `i`, with every other variable clamped to its label:
//!
//! `log p(x_i = s | ·) = Σ_{c ∋ i} w · f_c(x_c[i ← s]) − log Σ_{s'} exp(Σ_{c ∋ i} w · f_c(x_c[i ← s']))`.
//!
//! The objective to *minimise* is `−PL(w) + ‖w‖² / (2σ²)` (a Gaussian prior of
//! variance σ² on each weight; σ² = ∞ disables it). It is a sum over instances, not a
//! mean, so the prior weighs less as the training set grows, as a MAP estimate should.
//! Its gradient is `−Σ_n Σ_i (f_i(x_i) − E_{p(s | ·)}[f_i(s)]) + w / σ²` with
//! `f_i(s) = Σ_{c ∋ i} f_c(x_c[i ← s])`: empirical minus expected features under each
//! local conditional. No inference is needed, which is why the papers use it.
//!
//! Features do not depend on the weights, so building the objective computes, for
//! every variable and state, the sparse vector `f_i(s)` once (merged over the
//! variable's cliques, zeros dropped) and keeps it while the cache stays under a
//! memory limit ([`DEFAULT_FEATURE_CACHE_BYTES`]); an evaluation is then a sparse
//! dot product per state. Instances beyond the limit (e.g. CRF-Matching's 362 × 362
//! association cliques) are evaluated lazily through [`CliqueFeatures`] every time.
//! Every feature is checked for NaN / ±∞ once, when the objective is built.
//!
//! Evaluation runs in parallel over (instance, block of variables) work items with
//! rayon; the per-item results are summed in a fixed order, so the value is
//! deterministic.
//!
//! [`CliqueFeatures`]: super::CliqueFeatures

use super::model::{FeatureSet, LabelledInstance, LogLinearModel};
use crate::error::{Error, Result};
use crate::logspace::log_sum_exp;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

/// Variables per parallel work item.
const BLOCK: usize = 128;

/// The default memory limit of the feature cache of [`PseudoLikelihood`]: 512 MiB.
pub const DEFAULT_FEATURE_CACHE_BYTES: usize = 512 << 20;

/// The negative log pseudo-likelihood with a Gaussian prior over a validated training
/// set. Building it checks every instance (labels in range, every variable in some
/// clique, the instance's feature set, finite features); evaluation reports non-finite
/// weights, features or scores as errors instead of returning NaN.
///
/// ```
/// use std::sync::Arc;
/// use pgm_core::learning::{DenseFeatures, FeatureSet, LabelledInstance, LogLinearModel, PseudoLikelihood};
/// use pgm_core::VariableId;
///
/// let mut features = FeatureSet::new("coin", 1);
/// let bias = features.add_template("bias", &["heads"]).unwrap();
/// let features = Arc::new(features);
/// let mut model = LogLinearModel::new(Arc::clone(&features), &[2]).unwrap();
/// model.add_clique(bias, DenseFeatures::new(vec![VariableId(0)], vec![2], 1, vec![0.0, 1.0]).unwrap()).unwrap();
/// let data = vec![LabelledInstance::new(model, vec![1])];
///
/// let objective = PseudoLikelihood::new(features, &data, f64::INFINITY).unwrap();
/// let (value, gradient) = objective.value_and_gradient(&[0.0]).unwrap();
/// assert!((value - 2f64.ln()).abs() < 1e-12); // −log ½
/// assert!((gradient[0] + 0.5).abs() < 1e-12); // −(1 − ½)
/// ```
#[derive(Debug)]
pub struct PseudoLikelihood<'a> {
    features: Arc<FeatureSet>,
    instances: &'a [LabelledInstance],
    prior_variance: f64,
    work: Vec<(usize, Range<usize>)>,
    caches: Vec<Option<SparseConditionals>>,
}

impl<'a> PseudoLikelihood<'a> {
    /// The objective over `instances`, whose models must all use `features`, with a
    /// Gaussian prior of variance `prior_variance` (σ² > 0; `f64::INFINITY` for none)
    /// and a feature cache of at most [`DEFAULT_FEATURE_CACHE_BYTES`].
    pub fn new(
        features: Arc<FeatureSet>,
        instances: &'a [LabelledInstance],
        prior_variance: f64,
    ) -> Result<Self> {
        Self::with_feature_cache(
            features,
            instances,
            prior_variance,
            DEFAULT_FEATURE_CACHE_BYTES,
        )
    }

    /// [`new`](Self::new) with a feature cache of at most `cache_bytes` (instances are
    /// cached in order while a bound on their size fits; 0 caches nothing).
    pub fn with_feature_cache(
        features: Arc<FeatureSet>,
        instances: &'a [LabelledInstance],
        prior_variance: f64,
        cache_bytes: usize,
    ) -> Result<Self> {
        if prior_variance.is_nan() || prior_variance <= 0.0 {
            return Err(Error::InvalidParameter {
                name: "prior variance",
                value: prior_variance.to_string(),
                expected: "a positive number (or infinity for no prior)",
            });
        }
        if instances.is_empty() {
            return Err(Error::InvalidParameter {
                name: "training instances",
                value: "0".into(),
                expected: "at least one labelled instance",
            });
        }
        let mut work = Vec::new();
        let mut budget = cache_bytes;
        let mut cached = Vec::with_capacity(instances.len());
        for (n, instance) in instances.iter().enumerate() {
            features.check_same(instance.model.feature_set())?;
            let model = &instance.model;
            if instance.labels.len() != model.num_variables() {
                return Err(Error::LabelCount {
                    instance: n,
                    labels: instance.labels.len(),
                    variables: model.num_variables(),
                });
            }
            for (variable, (&label, &cardinality)) in instance
                .labels
                .iter()
                .zip(model.cardinalities())
                .enumerate()
            {
                if label >= cardinality {
                    return Err(Error::LabelOutOfRange {
                        instance: n,
                        variable,
                        label,
                        cardinality,
                    });
                }
                if model
                    .variable_cliques(crate::VariableId(variable))
                    .is_empty()
                {
                    return Err(Error::VariableWithoutFactors {
                        instance: n,
                        variable,
                    });
                }
            }
            let v = model.num_variables();
            work.extend(
                (0..v)
                    .step_by(BLOCK)
                    .map(|start| (n, start..(start + BLOCK).min(v))),
            );
            let bound = SparseConditionals::size_bound(model);
            let fits = bound <= budget && features.num_weights() <= u32::MAX as usize;
            if fits {
                budget -= bound;
            }
            cached.push(fits);
        }
        // Building a cache checks its features; uncached instances are checked below.
        let caches = instances
            .par_iter()
            .zip(&cached)
            .enumerate()
            .map(|(n, (instance, &cache))| {
                cache
                    .then(|| SparseConditionals::build(n, instance, features.num_weights()))
                    .transpose()
            })
            .collect::<Result<Vec<_>>>()?;
        let objective = Self {
            features,
            instances,
            prior_variance,
            work,
            caches,
        };
        // One pass at w = 0 checks every feature the lazy path will ever read.
        objective.value_and_gradient(&vec![0.0; objective.num_weights()])?;
        Ok(objective)
    }

    /// Number of instances whose conditional features are cached.
    pub fn cached_instances(&self) -> usize {
        self.caches.iter().filter(|c| c.is_some()).count()
    }

    /// Number of weights.
    pub fn num_weights(&self) -> usize {
        self.features.num_weights()
    }

    /// The feature set.
    pub fn feature_set(&self) -> &Arc<FeatureSet> {
        &self.features
    }

    /// The prior variance σ².
    pub fn prior_variance(&self) -> f64 {
        self.prior_variance
    }

    /// Number of local conditionals (labelled variables over all instances).
    pub fn num_terms(&self) -> usize {
        self.instances.iter().map(|i| i.labels.len()).sum()
    }

    /// The log pseudo-likelihood `PL(w)` (no prior, not negated).
    pub fn log_pseudo_likelihood(&self, weights: &[f64]) -> Result<f64> {
        Ok(self.evaluate(weights, false)?.0)
    }

    /// The objective to minimise, `−PL(w) + ‖w‖² / (2σ²)`, and its gradient.
    pub fn value_and_gradient(&self, weights: &[f64]) -> Result<(f64, Vec<f64>)> {
        let (pl, mut gradient) = self.evaluate(weights, true)?;
        let mut value = -pl;
        for (g, &w) in gradient.iter_mut().zip(weights) {
            *g = -*g;
            if self.prior_variance.is_finite() {
                value += w * w / (2.0 * self.prior_variance);
                *g += w / self.prior_variance;
            }
        }
        Ok((value, gradient))
    }

    /// The objective to minimise, without its gradient.
    pub fn value(&self, weights: &[f64]) -> Result<f64> {
        let pl = self.evaluate(weights, false)?.0;
        let prior: f64 = if self.prior_variance.is_finite() {
            weights.iter().map(|w| w * w).sum::<f64>() / (2.0 * self.prior_variance)
        } else {
            0.0
        };
        Ok(-pl + prior)
    }

    /// `PL(w)` and, when `with_gradient`, its gradient (else an empty vector).
    fn evaluate(&self, weights: &[f64], with_gradient: bool) -> Result<(f64, Vec<f64>)> {
        self.features.check_weights(weights)?;
        let nw = if with_gradient { weights.len() } else { 0 };
        let parts: Vec<(f64, Vec<f64>)> = self
            .work
            .par_iter()
            .map_init(Scratch::default, |scratch, (n, variables)| {
                let mut gradient = vec![0.0; nw];
                let pl = self.dispatch(
                    *n,
                    variables.clone(),
                    weights,
                    scratch,
                    with_gradient.then_some(&mut gradient[..]),
                )?;
                Ok((pl, gradient))
            })
            .collect::<Result<_>>()?;
        let mut total = 0.0;
        let mut gradient = vec![0.0; nw];
        for (pl, g) in parts {
            total += pl;
            for (a, b) in gradient.iter_mut().zip(&g) {
                *a += b;
            }
        }
        Ok((total, gradient))
    }

    /// The log local conditionals of `variables` of instance `n`, adding their gradient
    /// to `gradient` when given, from the cache if the instance has one.
    fn dispatch(
        &self,
        n: usize,
        variables: Range<usize>,
        weights: &[f64],
        s: &mut Scratch,
        gradient: Option<&mut [f64]>,
    ) -> Result<f64> {
        match &self.caches[n] {
            Some(cache) => cache.block(
                &self.instances[n].labels,
                n,
                variables,
                weights,
                s,
                gradient,
            ),
            None => self.lazy_block(n, variables, weights, s, gradient),
        }
    }

    /// [`dispatch`](Self::dispatch) through [`CliqueFeatures`](super::CliqueFeatures).
    fn lazy_block(
        &self,
        n: usize,
        variables: Range<usize>,
        weights: &[f64],
        s: &mut Scratch,
        mut gradient: Option<&mut [f64]>,
    ) -> Result<f64> {
        let instance = &self.instances[n];
        let model = &instance.model;
        let cliques = model.cliques();
        let mut total = 0.0;
        for i in variables {
            let k = model.cardinalities()[i];
            let members = model.variable_cliques(crate::VariableId(i));
            let width = conditional_features(instance, n, i, s)?;
            // Scores of every state of i with its Markov blanket clamped.
            s.scores.clear();
            for state in 0..k {
                let row = &s.features[state * width..(state + 1) * width];
                let mut score = 0.0;
                for (&(c, _), &offset) in members.iter().zip(&s.offsets) {
                    let range = cliques[c].weights.clone();
                    let f = &row[offset..offset + range.len()];
                    score += weights[range]
                        .iter()
                        .zip(f)
                        .map(|(a, b)| a * b)
                        .sum::<f64>();
                }
                s.scores.push(check_score(score, n, i, state)?);
            }
            let truth = instance.labels[i];
            let log_normaliser = log_sum_exp(&s.scores);
            total += s.scores[truth] - log_normaliser;
            let Some(gradient) = gradient.as_deref_mut() else {
                continue;
            };
            // Empirical minus expected features under the local conditional.
            s.expected.clear();
            s.expected.resize(width, 0.0);
            for state in 0..k {
                let p = (s.scores[state] - log_normaliser).exp();
                let row = &s.features[state * width..(state + 1) * width];
                for (e, f) in s.expected.iter_mut().zip(row) {
                    *e += p * f;
                }
            }
            let empirical = &s.features[truth * width..(truth + 1) * width];
            for (&(c, _), &offset) in members.iter().zip(&s.offsets) {
                let range = cliques[c].weights.clone();
                let len = range.len();
                for ((g, f), e) in gradient[range]
                    .iter_mut()
                    .zip(&empirical[offset..offset + len])
                    .zip(&s.expected[offset..offset + len])
                {
                    *g += f - e;
                }
            }
        }
        Ok(total)
    }
}

/// A finite score, or the error naming where it overflowed.
fn check_score(score: f64, n: usize, i: usize, state: usize) -> Result<f64> {
    if score.is_finite() {
        Ok(score)
    } else {
        Err(Error::Learning(format!(
            "training instance {n}, variable {i}: the score of state {state} is {score} \
             (weights too large for the features)"
        )))
    }
}

/// Fills `s.features` with variable `i`'s features for each of its states, its Markov
/// blanket clamped to the labels: row `state` holds the concatenated feature slices of
/// `i`'s cliques, clique `j`'s at `s.offsets[j]`. Returns the row width. Errors on a
/// non-finite feature.
fn conditional_features(
    instance: &LabelledInstance,
    n: usize,
    i: usize,
    s: &mut Scratch,
) -> Result<usize> {
    let model = &instance.model;
    let cliques = model.cliques();
    let k = model.cardinalities()[i];
    let members = model.variable_cliques(crate::VariableId(i));
    s.offsets.clear();
    let mut width = 0;
    for &(c, _) in members {
        s.offsets.push(width);
        width += cliques[c].weights.len();
    }
    s.features.clear();
    s.features.resize(k * width, 0.0);
    for (&(c, slot), &offset) in members.iter().zip(&s.offsets) {
        let clique = &cliques[c];
        let len = clique.weights.len();
        s.states.clear();
        s.states
            .extend(clique.features.scope().iter().map(|v| instance.labels[v.0]));
        for state in 0..k {
            s.states[slot] = state;
            let out = &mut s.features[state * width + offset..state * width + offset + len];
            clique.features.features(&s.states, out);
            if let Some(e) = model.bad_feature(c, &s.states, out, Some(n), Some(i)) {
                return Err(e);
            }
        }
    }
    Ok(width)
}

/// The conditional feature vectors `f_i(s)` of one instance, sparse: the entries of
/// variable `i` in state `s` are `entries[state_start[first_state[i] + s]..][..]`
/// (up to `state_start[first_state[i] + s + 1]`), as (weight index, value) pairs with
/// duplicates merged and zeros dropped.
#[derive(Debug)]
struct SparseConditionals {
    first_state: Vec<usize>,
    state_start: Vec<usize>,
    index: Vec<u32>,
    value: Vec<f64>,
}

impl SparseConditionals {
    /// An upper bound on the bytes a cache of `model` takes.
    fn size_bound(model: &LogLinearModel) -> usize {
        let cliques = model.cliques();
        let mut entries = 0usize;
        let mut states = 0usize;
        for (i, &k) in model.cardinalities().iter().enumerate() {
            let width: usize = model
                .variable_cliques(crate::VariableId(i))
                .iter()
                .map(|&(c, _)| cliques[c].weights.len())
                .sum();
            entries = entries.saturating_add(k.saturating_mul(width));
            states = states.saturating_add(k);
        }
        let index_bytes = std::mem::size_of::<usize>();
        let entry_bytes = std::mem::size_of::<u32>() + std::mem::size_of::<f64>();
        entries
            .saturating_mul(entry_bytes)
            .saturating_add((states + model.num_variables() + 2).saturating_mul(index_bytes))
    }

    /// Computes (and checks) every conditional feature vector of instance `n`.
    fn build(n: usize, instance: &LabelledInstance, num_weights: usize) -> Result<Self> {
        let model = &instance.model;
        let cliques = model.cliques();
        let mut s = Scratch::default();
        let mut merged = vec![0.0; num_weights];
        let mut touched_flag = vec![false; num_weights];
        let mut touched: Vec<usize> = Vec::new();
        let mut cache = Self {
            first_state: Vec::with_capacity(model.num_variables() + 1),
            state_start: vec![0],
            index: Vec::new(),
            value: Vec::new(),
        };
        for i in 0..model.num_variables() {
            cache.first_state.push(cache.state_start.len() - 1);
            let width = conditional_features(instance, n, i, &mut s)?;
            let members = model.variable_cliques(crate::VariableId(i));
            for state in 0..model.cardinalities()[i] {
                let row = &s.features[state * width..(state + 1) * width];
                for (&(c, _), &offset) in members.iter().zip(&s.offsets) {
                    let range = cliques[c].weights.clone();
                    for (j, &f) in range.clone().zip(&row[offset..offset + range.len()]) {
                        merged[j] += f;
                        if !touched_flag[j] {
                            touched_flag[j] = true;
                            touched.push(j);
                        }
                    }
                }
                touched.sort_unstable();
                for &j in &touched {
                    if merged[j] != 0.0 {
                        // `num_weights <= u32::MAX` is checked before caching.
                        cache.index.push(j as u32);
                        cache.value.push(merged[j]);
                    }
                    merged[j] = 0.0;
                    touched_flag[j] = false;
                }
                touched.clear();
                cache.state_start.push(cache.index.len());
            }
        }
        cache.first_state.push(cache.state_start.len() - 1);
        cache.index.shrink_to_fit();
        cache.value.shrink_to_fit();
        Ok(cache)
    }

    /// The entries of variable-state number `vs` (`first_state[i] + s`).
    #[inline]
    fn entries(&self, vs: usize) -> (&[u32], &[f64]) {
        let range = self.state_start[vs]..self.state_start[vs + 1];
        (&self.index[range.clone()], &self.value[range])
    }

    /// [`PseudoLikelihood::dispatch`] from the cache.
    fn block(
        &self,
        labels: &[usize],
        n: usize,
        variables: Range<usize>,
        weights: &[f64],
        s: &mut Scratch,
        mut gradient: Option<&mut [f64]>,
    ) -> Result<f64> {
        let mut total = 0.0;
        for i in variables {
            let (first, end) = (self.first_state[i], self.first_state[i + 1]);
            s.scores.clear();
            for vs in first..end {
                let (index, value) = self.entries(vs);
                let score: f64 = index
                    .iter()
                    .zip(value)
                    .map(|(&j, &f)| weights[j as usize] * f)
                    .sum();
                s.scores.push(check_score(score, n, i, vs - first)?);
            }
            let truth = labels[i];
            let log_normaliser = log_sum_exp(&s.scores);
            total += s.scores[truth] - log_normaliser;
            let Some(gradient) = gradient.as_deref_mut() else {
                continue;
            };
            // Empirical minus expected features: each state's features weighted by
            // [state = label] − p(state | blanket).
            for (state, vs) in (first..end).enumerate() {
                let p = (s.scores[state] - log_normaliser).exp();
                let coefficient = if state == truth { 1.0 - p } else { -p };
                let (index, value) = self.entries(vs);
                for (&j, &f) in index.iter().zip(value) {
                    gradient[j as usize] += coefficient * f;
                }
            }
        }
        Ok(total)
    }
}
/// Reused buffers of one worker.
#[derive(Default)]
struct Scratch {
    offsets: Vec<usize>,
    features: Vec<f64>,
    states: Vec<usize>,
    scores: Vec<f64>,
    expected: Vec<f64>,
}
