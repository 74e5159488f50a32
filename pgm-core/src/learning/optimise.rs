//! Learning with L-BFGS (argmin's `LBFGS` with a Moré–Thuente line search), as both
//! papers do ("unconstrained L-BFGS [10]"), of the [`Objective`] the parameters name
//! ([`LearningObjective`]): maximum pseudo-likelihood (the papers' choice, and the
//! default), maximum likelihood on chains and trees, or the Bethe likelihood of loopy
//! belief propagation.
//!
//! Hyper-parameters are checked once ([`LearnerParams::check`] → [`Learner`]); a
//! [`LearningObserver`] sees `(iteration, objective, gradient norm)` after every
//! iteration (a CLI draws a progress bar with it, a library logs it) and may stop the
//! run. Stopping rules: the gradient norm falls below `gradient_tolerance`, the
//! objective changes by less than `cost_tolerance × max(1, |objective|)` between
//! iterations, the line search cannot improve any more, the iteration limit, or the
//! observer. Whichever fired is reported in [`LearningResult::termination`].

use super::likelihood::{Likelihood, LikelihoodKind};
use super::model::{FeatureSet, LabelledInstance};
use super::pseudo_likelihood::{PseudoLikelihood, DEFAULT_FEATURE_CACHE_BYTES};
use super::weights::Weights;
use crate::error::{Error, Result};

use argmin::core::{
    CostFunction, Executor, Gradient, IterState, Problem, Solver, State, TerminationReason,
    TerminationStatus, KV,
};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;
use ndarray::Array1;
use std::ops::ControlFlow;
use std::sync::{Arc, Mutex};

/// A learning objective to minimise: its value and gradient at any weights.
pub trait Objective: Sync {
    /// The feature set the weights belong to.
    fn feature_set(&self) -> &Arc<FeatureSet>;

    /// The value to minimise and its gradient (one entry per weight).
    ///
    /// # Errors
    /// The objective's own (bad weights, a non-finite feature, inference that failed).
    fn value_and_gradient(&self, weights: &[f64]) -> Result<(f64, Vec<f64>)>;

    /// Number of weights.
    fn num_weights(&self) -> usize {
        self.feature_set().num_weights()
    }
}

impl Objective for PseudoLikelihood<'_> {
    fn feature_set(&self) -> &Arc<FeatureSet> {
        PseudoLikelihood::feature_set(self)
    }

    fn value_and_gradient(&self, weights: &[f64]) -> Result<(f64, Vec<f64>)> {
        PseudoLikelihood::value_and_gradient(self, weights)
    }
}

impl Objective for Likelihood<'_> {
    fn feature_set(&self) -> &Arc<FeatureSet> {
        Likelihood::feature_set(self)
    }

    fn value_and_gradient(&self, weights: &[f64]) -> Result<(f64, Vec<f64>)> {
        Likelihood::value_and_gradient(self, weights)
    }
}

/// Which objective [`Learner::learn`] minimises.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LearningObjective {
    /// Maximum pseudo-likelihood ([`PseudoLikelihood`]): any graph, no inference.
    #[default]
    PseudoLikelihood,
    /// Maximum likelihood with exact marginals ([`LikelihoodKind::Exact`]): chains and
    /// trees only; a graph with a cycle is refused.
    Likelihood,
    /// The Bethe likelihood of loopy belief propagation ([`LikelihoodKind::Bethe`]):
    /// any graph, approximate on loops.
    Bethe,
}

impl LearningObjective {
    /// The short name: `pl`, `ml` or `bethe`.
    pub fn name(self) -> &'static str {
        match self {
            LearningObjective::PseudoLikelihood => "pl",
            LearningObjective::Likelihood => "ml",
            LearningObjective::Bethe => "bethe",
        }
    }
}

impl std::fmt::Display for LearningObjective {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for LearningObjective {
    type Err = String;

    /// `pl` (or `pseudo-likelihood`), `ml` (`likelihood`) or `bethe`.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.trim() {
            "pl" | "pseudo-likelihood" => Ok(LearningObjective::PseudoLikelihood),
            "ml" | "likelihood" => Ok(LearningObjective::Likelihood),
            "bethe" => Ok(LearningObjective::Bethe),
            other => Err(format!(
                "{other:?}: expected pl (pseudo-likelihood), ml (maximum likelihood, chains \
                 and trees) or bethe (loopy belief propagation's likelihood)"
            )),
        }
    }
}

/// What an observer sees after each L-BFGS iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Iterations completed (1 after the first).
    pub iteration: u64,
    /// The objective `−PL(w) + ‖w‖²/(2σ²)` at the current weights.
    pub objective: f64,
    /// Euclidean norm of its gradient.
    pub gradient_norm: f64,
}

/// Called after every iteration; return `ControlFlow::Break(())` to stop learning
/// (the result then holds the current weights). Closures
/// `FnMut(&Progress) -> ControlFlow<()>` are observers, and `()` observes nothing.
pub trait LearningObserver {
    /// Sees one iteration's progress.
    fn observe(&mut self, progress: &Progress) -> ControlFlow<()>;
}

impl<F: FnMut(&Progress) -> ControlFlow<()>> LearningObserver for F {
    fn observe(&mut self, progress: &Progress) -> ControlFlow<()> {
        self(progress)
    }
}

impl LearningObserver for () {
    fn observe(&mut self, _: &Progress) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

/// Unchecked learning hyper-parameters; [`check`](crate::ParamGuard::check) turns them into a
/// [`Learner`].
#[derive(Clone, Debug, PartialEq)]
pub struct LearnerParams {
    prior_variance: f64,
    max_iterations: u64,
    gradient_tolerance: f64,
    cost_tolerance: f64,
    memory: usize,
    initial_weights: Option<Vec<f64>>,
    feature_cache_bytes: usize,
    objective: LearningObjective,
}

impl Default for LearnerParams {
    /// σ² = 10, 500 iterations, gradient tolerance 1e-6, relative cost tolerance
    /// 1e-12, L-BFGS memory 10, starting from zero weights, a feature cache of at most
    /// [`DEFAULT_FEATURE_CACHE_BYTES`], maximum pseudo-likelihood.
    fn default() -> Self {
        Self {
            prior_variance: 10.0,
            max_iterations: 500,
            gradient_tolerance: 1e-6,
            cost_tolerance: 1e-12,
            memory: 10,
            initial_weights: None,
            feature_cache_bytes: DEFAULT_FEATURE_CACHE_BYTES,
            objective: LearningObjective::PseudoLikelihood,
        }
    }
}

impl LearnerParams {
    /// Variance σ² of the Gaussian prior on each weight (`f64::INFINITY`: no prior).
    pub fn prior_variance(mut self, variance: f64) -> Self {
        self.prior_variance = variance;
        self
    }

    /// Iteration limit.
    pub fn max_iterations(mut self, iterations: u64) -> Self {
        self.max_iterations = iterations;
        self
    }

    /// Stop when the gradient's Euclidean norm is below this.
    pub fn gradient_tolerance(mut self, tolerance: f64) -> Self {
        self.gradient_tolerance = tolerance;
        self
    }

    /// Stop when an iteration changes the objective by less than this times
    /// `max(1, |objective|)`.
    pub fn cost_tolerance(mut self, tolerance: f64) -> Self {
        self.cost_tolerance = tolerance;
        self
    }

    /// Number of correction pairs L-BFGS keeps.
    pub fn memory(mut self, pairs: usize) -> Self {
        self.memory = pairs;
        self
    }

    /// Starting weights (default: all zero).
    pub fn initial_weights(mut self, weights: Vec<f64>) -> Self {
        self.initial_weights = Some(weights);
        self
    }

    /// Memory limit of the objective's feature cache (see [`PseudoLikelihood`]).
    pub fn feature_cache_bytes(mut self, bytes: usize) -> Self {
        self.feature_cache_bytes = bytes;
        self
    }

    /// The objective [`Learner::learn`] minimises (default: pseudo-likelihood).
    pub fn objective(mut self, objective: LearningObjective) -> Self {
        self.objective = objective;
        self
    }
}

impl LearnerParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        let invalid = |name, value: f64, expected| Error::InvalidParameter {
            name,
            value: value.to_string(),
            expected,
        };
        if self.prior_variance.is_nan() || self.prior_variance <= 0.0 {
            return Err(invalid(
                "prior variance",
                self.prior_variance,
                "a positive number (or infinity)",
            ));
        }
        if !self.gradient_tolerance.is_finite() || self.gradient_tolerance < 0.0 {
            return Err(invalid(
                "gradient tolerance",
                self.gradient_tolerance,
                "a finite number >= 0",
            ));
        }
        if !self.cost_tolerance.is_finite() || self.cost_tolerance < 0.0 {
            return Err(invalid(
                "cost tolerance",
                self.cost_tolerance,
                "a finite number >= 0",
            ));
        }
        if self.memory == 0 {
            return Err(invalid("L-BFGS memory", 0.0, "at least 1 correction pair"));
        }
        if let Some(w) = &self.initial_weights {
            if let Some(&bad) = w.iter().find(|x| !x.is_finite()) {
                return Err(invalid("initial weight", bad, "finite initial weights"));
            }
        }
        Ok(())
    }
}

crate::checked_params! {
    /// Checked learning parameters: learns weights by maximum pseudo-likelihood (or the
    /// [`LearningObjective`] set).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use std::ops::ControlFlow;
    /// use pgm_core::learning::{DenseFeatures, FeatureSet, LabelledInstance, LearnerParams, LogLinearModel};
    /// use pgm_core::{ParamGuard, VariableId};
    ///
    /// // A biased coin seen 3 times heads, once tails: the MLE of the log-odds is ln 3.
    /// let mut features = FeatureSet::new("coin", 1);
    /// let bias = features.add_template("bias", &["heads"]).unwrap();
    /// let features = Arc::new(features);
    /// let data: Vec<LabelledInstance> = [1, 1, 1, 0]
    ///     .into_iter()
    ///     .map(|label| {
    ///         let mut model = LogLinearModel::new(Arc::clone(&features), &[2]).unwrap();
    ///         let table = DenseFeatures::new(vec![VariableId(0)], vec![2], 1, vec![0.0, 1.0]).unwrap();
    ///         model.add_clique(bias, table).unwrap();
    ///         LabelledInstance::new(model, vec![label])
    ///     })
    ///     .collect();
    ///
    /// let learner = LearnerParams::default().prior_variance(f64::INFINITY).check().unwrap();
    /// let mut log = Vec::new();
    /// let mut observer = |p: &pgm_core::learning::Progress| {
    ///     log.push(p.objective);
    ///     ControlFlow::Continue(())
    /// };
    /// let result = learner.learn(&features, &data, &mut observer).unwrap();
    /// assert!((result.weights.get("bias.heads").unwrap() - 3f64.ln()).abs() < 1e-5);
    /// assert!(!log.is_empty());
    /// println!("{}", result.weights); // {bias.heads: 1.0986...}
    /// ```
    #[derive(Clone, Debug, PartialEq)]
    pub struct Learner(LearnerParams) -> Error;
}

/// The outcome of [`Learner::learn`].
#[derive(Clone, Debug)]
pub struct LearningResult {
    /// The learned weights (the best seen).
    pub weights: Weights,
    /// The objective at those weights.
    pub objective: f64,
    /// Its gradient norm.
    pub gradient_norm: f64,
    /// L-BFGS iterations run.
    pub iterations: u64,
    /// Objective evaluations (each with its gradient).
    pub evaluations: u64,
    /// Why the optimiser stopped.
    pub termination: String,
    /// True when a tolerance was met (gradient or objective change), false when the
    /// iteration limit, the line search or the observer stopped it.
    pub converged: bool,
}

impl Learner {
    /// The objective the parameters name.
    pub fn objective(&self) -> LearningObjective {
        self.params.objective
    }

    /// Learns the weights of `features` from `instances` by the parameters'
    /// [`LearningObjective`], reporting to `observer`.
    ///
    /// # Errors
    /// The objective's (see [`PseudoLikelihood::new`], [`Likelihood::new`]: maximum
    /// likelihood refuses an instance whose graph has a cycle) and the optimiser's.
    pub fn learn(
        &self,
        features: &Arc<FeatureSet>,
        instances: &[LabelledInstance],
        observer: &mut dyn LearningObserver,
    ) -> Result<LearningResult> {
        let prior = self.params.prior_variance;
        match self.params.objective {
            LearningObjective::PseudoLikelihood => {
                let objective = PseudoLikelihood::with_feature_cache(
                    Arc::clone(features),
                    instances,
                    prior,
                    self.params.feature_cache_bytes,
                )?;
                self.minimise(&objective, observer)
            }
            LearningObjective::Likelihood | LearningObjective::Bethe => {
                let kind = if self.params.objective == LearningObjective::Likelihood {
                    LikelihoodKind::Exact
                } else {
                    LikelihoodKind::Bethe
                };
                let objective = Likelihood::new(kind, Arc::clone(features), instances, prior)?;
                self.minimise(&objective, observer)
            }
        }
    }

    /// Minimises an already built objective.
    pub fn minimise(
        &self,
        objective: &dyn Objective,
        observer: &mut dyn LearningObserver,
    ) -> Result<LearningResult> {
        let n = objective.num_weights();
        let initial = match &self.params.initial_weights {
            Some(w) if w.len() != n => {
                return Err(Error::InvalidParameter {
                    name: "initial weights",
                    value: format!("{} values", w.len()),
                    expected: "one value per weight of the feature set",
                })
            }
            Some(w) => Array1::from(w.clone()),
            None => Array1::zeros(n),
        };
        let error = Mutex::new(None);
        let evaluations = Mutex::new(0u64);
        let problem = ArgminProblem {
            objective,
            cache: Mutex::new(None),
            error: &error,
            evaluations: &evaluations,
        };
        let optimiser_error = |e: argmin::core::Error| Error::Optimiser(e.to_string());
        // argmin's own tolerances are off: `Observed` applies ours.
        let lbfgs = LBFGS::new(MoreThuenteLineSearch::new(), self.params.memory)
            .with_tolerance_grad(0.0)
            .map_err(optimiser_error)?
            .with_tolerance_cost(0.0)
            .map_err(optimiser_error)?;
        let solver = Observed {
            inner: lbfgs,
            observer,
            gradient_tolerance: self.params.gradient_tolerance,
            cost_tolerance: self.params.cost_tolerance,
            stopped: false,
        };
        let max_iterations = self.params.max_iterations;
        let run = Executor::new(problem, solver)
            .configure(|state| state.param(initial).max_iters(max_iterations))
            .ctrlc(false)
            .timer(false)
            .run();
        // The objective's own typed error wins over argmin's report of it (the line
        // search turns evaluation errors into a silent stop, so check it either way).
        if let Some(e) = error.lock().ok().and_then(|mut slot| slot.take()) {
            return Err(e);
        }
        let result = run.map_err(optimiser_error)?;
        let evaluations = evaluations.lock().map_or(0, |count| *count);
        let state = result.state;
        let iterations = state.get_iter();
        let termination = state
            .get_termination_reason()
            .map_or_else(|| "not terminated".to_string(), |r| r.text().to_string());
        let converged = matches!(
            state.get_termination_reason(),
            Some(TerminationReason::SolverConverged)
        );
        let best = state
            .get_best_param()
            .or(state.get_param())
            .cloned()
            .ok_or_else(|| Error::Optimiser("no parameter vector in the final state".into()))?;
        let (value, gradient) = objective.value_and_gradient(&best.to_vec())?;
        let weights = Weights::new(Arc::clone(objective.feature_set()), best.to_vec())?;
        Ok(LearningResult {
            weights,
            objective: value,
            gradient_norm: norm(&gradient),
            iterations,
            evaluations,
            termination,
            converged,
        })
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

type Cached = (Array1<f64>, f64, Array1<f64>);

/// The objective as an argmin problem. argmin asks for the cost and the gradient
/// separately, at the same point; one evaluation computes both and is cached.
struct ArgminProblem<'a> {
    objective: &'a dyn Objective,
    cache: Mutex<Option<Cached>>,
    /// Where an evaluation error is kept for `minimise` to return.
    error: &'a Mutex<Option<Error>>,
    evaluations: &'a Mutex<u64>,
}

impl ArgminProblem<'_> {
    fn evaluate(
        &self,
        w: &Array1<f64>,
    ) -> std::result::Result<(f64, Array1<f64>), argmin::core::Error> {
        let mut cache = self
            .cache
            .lock()
            .map_err(|_| anyhow_error("poisoned cache"))?;
        if let Some((x, value, gradient)) = cache.as_ref() {
            if x == w {
                return Ok((*value, gradient.clone()));
            }
        }
        let slice = w.to_vec();
        match self.objective.value_and_gradient(&slice) {
            Ok((value, gradient)) => {
                if let Ok(mut count) = self.evaluations.lock() {
                    *count += 1;
                }
                let gradient = Array1::from(gradient);
                *cache = Some((w.clone(), value, gradient.clone()));
                Ok((value, gradient))
            }
            Err(e) => {
                let message = e.to_string();
                if let Ok(mut slot) = self.error.lock() {
                    *slot = Some(e);
                }
                Err(anyhow_error(&message))
            }
        }
    }
}

fn anyhow_error(message: &str) -> argmin::core::Error {
    argmin::core::Error::msg(message.to_string())
}

impl CostFunction for ArgminProblem<'_> {
    type Param = Array1<f64>;
    type Output = f64;

    fn cost(&self, param: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        Ok(self.evaluate(param)?.0)
    }
}

impl Gradient for ArgminProblem<'_> {
    type Param = Array1<f64>;
    type Gradient = Array1<f64>;

    fn gradient(
        &self,
        param: &Self::Param,
    ) -> std::result::Result<Array1<f64>, argmin::core::Error> {
        Ok(self.evaluate(param)?.1)
    }
}

type LbfgsState = IterState<Array1<f64>, Array1<f64>, (), (), (), f64>;

/// Wraps a solver to apply our stopping rules and call the observer after every
/// iteration (argmin's own observers must be `'static`; this one may borrow).
struct Observed<'o, S> {
    inner: S,
    observer: &'o mut dyn LearningObserver,
    gradient_tolerance: f64,
    cost_tolerance: f64,
    stopped: bool,
}

impl<O, S: Solver<O, LbfgsState>> Solver<O, LbfgsState> for Observed<'_, S> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: LbfgsState,
    ) -> std::result::Result<(LbfgsState, Option<KV>), argmin::core::Error> {
        self.inner.init(problem, state)
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        state: LbfgsState,
    ) -> std::result::Result<(LbfgsState, Option<KV>), argmin::core::Error> {
        let (state, kv) = self.inner.next_iter(problem, state)?;
        let progress = Progress {
            iteration: state.get_iter() + 1,
            objective: state.get_cost(),
            gradient_norm: state.get_gradient().map_or(f64::NAN, |g| g.dot(g).sqrt()),
        };
        if self.observer.observe(&progress).is_break() {
            self.stopped = true;
        }
        Ok((state, kv))
    }

    fn terminate(&mut self, state: &LbfgsState) -> TerminationStatus {
        if let Some(g) = state.get_gradient() {
            if g.dot(g).sqrt() <= self.gradient_tolerance {
                return TerminationStatus::Terminated(TerminationReason::SolverConverged);
            }
        }
        let (previous, current) = (state.get_prev_cost(), state.get_cost());
        if previous.is_finite()
            && (previous - current).abs() <= self.cost_tolerance * current.abs().max(1.0)
        {
            return TerminationStatus::Terminated(TerminationReason::SolverConverged);
        }
        if self.stopped {
            return TerminationStatus::Terminated(TerminationReason::SolverExit(
                "stopped by the observer".into(),
            ));
        }
        self.inner.terminate(state)
    }
}
