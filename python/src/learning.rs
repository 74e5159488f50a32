//! Learning log-linear weights from Python, through the same `FeatureSet` /
//! `LogLinearModel` / learner API as Rust: templates of named weights, cliques with a
//! dense feature table each, and maximum pseudo-likelihood with a Gaussian prior
//! (L-BFGS).

use crate::{count, counts, float_array, pgm_err, PgmError, PyFactorGraph};
use numpy::{PyArray1, PyUntypedArrayMethods};
use pgm_core::learning::{
    DenseFeatures, FeatureSet, LabelledInstance, LearnerParams, LearningObjective, LogLinearModel,
    TemplateId,
};
use pgm_core::{ParamGuard, VariableId};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::Arc;

/// Named weights, grouped in templates that cliques share.
///
/// `FeatureSet(model, version=1)`; `add_template(name, features)` adds one weight per
/// feature, named `"{name}.{feature}"`, and returns the template's id. Add every
/// template before the first `LogLinearModel` is made from the set.
#[pyclass(name = "FeatureSet", module = "pgm")]
pub struct PyFeatureSet {
    pub(crate) set: Arc<FeatureSet>,
}

#[pymethods]
impl PyFeatureSet {
    #[new]
    #[pyo3(signature = (model, version=1))]
    fn new(model: &str, version: u32) -> Self {
        Self {
            set: Arc::new(FeatureSet::new(model, version)),
        }
    }

    /// Adds a template with one weight per name in `features`; returns its id.
    fn add_template(&mut self, name: &str, features: Vec<String>) -> PyResult<usize> {
        let set = Arc::get_mut(&mut self.set).ok_or_else(|| {
            PgmError::new_err(format!(
                "add_template({name:?}): models were already made from this feature set; add every template first"
            ))
        })?;
        let features: Vec<&str> = features.iter().map(String::as_str).collect();
        let id = set
            .add_template(name, &features)
            .map_err(|e| pgm_err(None, e))?;
        Ok(id.0)
    }

    /// The weight names, in weight-vector order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.set.names().to_vec()
    }
}

/// One instance of a log-linear model: variables and cliques, each clique a template
/// and a dense feature table.
///
/// `LogLinearModel(feature_set, cardinalities)`; `add_clique(template, scope,
/// features)` with `features` of shape `[cardinality of v for v in scope] +
/// [number of features of the template]`: the feature vector of every joint state of
/// the clique (C order). A clique's log-potential at `x` is `w · features[x]`.
#[pyclass(name = "LogLinearModel", module = "pgm")]
pub struct PyLogLinearModel {
    features: Arc<FeatureSet>,
    cardinalities: Vec<usize>,
    cliques: Vec<(TemplateId, DenseFeatures)>,
    /// The same cliques in the engine's model, which checks each as it is added
    /// (`learn` takes models by value, so each run builds its own from `cliques`).
    checked: LogLinearModel,
}

impl PyLogLinearModel {
    fn build(&self) -> PyResult<LogLinearModel> {
        let mut model = LogLinearModel::new(Arc::clone(&self.features), &self.cardinalities)
            .map_err(|e| pgm_err(None, e))?;
        for (template, clique) in &self.cliques {
            model
                .add_clique(*template, clique.clone())
                .map_err(|e| pgm_err(None, e))?;
        }
        Ok(model)
    }
}

#[pymethods]
impl PyLogLinearModel {
    #[new]
    fn new(feature_set: &PyFeatureSet, cardinalities: Vec<i64>) -> PyResult<Self> {
        let cardinalities = counts("cardinalities", &cardinalities)?;
        let features = Arc::clone(&feature_set.set);
        // Checks the cardinalities now, with the engine's message.
        let checked = LogLinearModel::new(Arc::clone(&features), &cardinalities)
            .map_err(|e| pgm_err(None, e))?;
        Ok(Self {
            features,
            cardinalities,
            cliques: Vec::new(),
            checked,
        })
    }

    /// Adds a clique of `template` over `scope` with its feature table; returns the
    /// clique's index (its factor's index in `to_factor_graph`).
    fn add_clique(
        &mut self,
        template: i64,
        scope: Vec<i64>,
        features: &Bound<'_, PyAny>,
    ) -> PyResult<usize> {
        let template = TemplateId(count("template", template)?);
        let scope = counts("scope", &scope)?;
        let table = float_array(features, "features")?;
        let shape = table.shape().to_vec();
        if shape.len() != scope.len() + 1 {
            return Err(PgmError::new_err(format!(
                "features: {} axes for a scope of {} variables: one axis per scope variable, then one for the features",
                shape.len(),
                scope.len()
            )));
        }
        let width = shape[scope.len()];
        // The engine refuses it too; checked here first to name the template.
        let wanted = self
            .features
            .template(template)
            .map(|t| t.width())
            .ok_or_else(|| {
                PgmError::new_err(format!(
                    "template = {}: the feature set has {} templates",
                    template.0,
                    self.features.templates().len()
                ))
            })?;
        if width != wanted {
            return Err(PgmError::new_err(format!(
                "features: {width} features per joint state, but template {} has {wanted}",
                template.0
            )));
        }
        let values: Vec<f64> = table.as_array().iter().copied().collect();
        let ids: Vec<VariableId> = scope.iter().map(|&v| VariableId(v)).collect();
        let clique = DenseFeatures::new(ids, shape[..scope.len()].to_vec(), width, values)
            .map_err(|e| pgm_err(None, e))?;
        // Checked against the variables and the template by the engine.
        let index = self
            .checked
            .add_clique(template, clique.clone())
            .map_err(|e| pgm_err(None, e))?;
        self.cliques.push((template, clique));
        Ok(index)
    }

    /// The factor graph of this instance under `weights` (a vector in the feature
    /// set's order, as `learn` returns in `weight_vector`).
    fn to_factor_graph(&self, weights: &Bound<'_, PyAny>) -> PyResult<PyFactorGraph> {
        let weights = float_array(weights, "weights")?;
        let weights: Vec<f64> = weights.as_array().iter().copied().collect();
        let graph = self
            .build()?
            .to_factor_graph(&weights)
            .map_err(|e| pgm_err(None, e))?;
        Ok(PyFactorGraph::from_graph(graph))
    }
}

/// Learns the weights of `feature_set` from `instances`, a list of `(model, labels)`
/// pairs (`labels`: the true state of every variable), by the `objective`: `"pl"`
/// (maximum pseudo-likelihood, any graph), `"ml"` (maximum likelihood with exact
/// marginals: chains and trees; a model with a cycle is refused) or `"bethe"` (the
/// Bethe likelihood of loopy belief propagation, any graph), with a Gaussian prior of
/// variance `prior_variance` on each weight (`inf`: none), minimised by L-BFGS.
///
/// Returns `weights` (a dict name -> value), `weight_vector` (the same, in the feature
/// set's order), `objective`, `gradient_norm`, `iterations`, `evaluations`,
/// `converged`, `termination` and `objective_name`.
#[pyfunction]
#[pyo3(signature = (feature_set, instances, prior_variance=10.0, max_iterations=200, gradient_tolerance=1e-6, objective="pl"))]
pub fn learn<'py>(
    py: Python<'py>,
    feature_set: &PyFeatureSet,
    instances: &Bound<'py, PyList>,
    prior_variance: f64,
    max_iterations: i64,
    gradient_tolerance: f64,
    objective: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let kind: LearningObjective = objective
        .parse()
        .map_err(|e: String| PgmError::new_err(format!("objective: {e}")))?;
    let mut data = Vec::with_capacity(instances.len());
    for (i, item) in instances.iter().enumerate() {
        let (model, labels): (PyRef<'_, PyLogLinearModel>, Vec<i64>) =
            item.extract().map_err(|e| {
                PgmError::new_err(format!(
                    "instances[{i}]: {e} (expected (LogLinearModel, labels))"
                ))
            })?;
        if !Arc::ptr_eq(&model.features, &feature_set.set) {
            return Err(PgmError::new_err(format!(
                "instances[{i}]: its model was made from another feature set"
            )));
        }
        let labels = counts(&format!("instances[{i}].labels"), &labels)?;
        data.push(LabelledInstance::new(model.build()?, labels));
    }
    let learner = LearnerParams::default()
        .prior_variance(prior_variance)
        .max_iterations(count("max_iterations", max_iterations)? as u64)
        .gradient_tolerance(gradient_tolerance)
        .objective(kind)
        .check()
        .map_err(|e| pgm_err(None, e))?;
    let set = Arc::clone(&feature_set.set);
    let result = py
        .detach(|| learner.learn(&set, &data, &mut ()))
        .map_err(|e| pgm_err(None, e))?;
    let d = PyDict::new(py);
    let weights = PyDict::new(py);
    for (name, value) in result.weights.iter() {
        weights.set_item(name, value)?;
    }
    d.set_item("weights", weights)?;
    d.set_item(
        "weight_vector",
        PyArray1::from_slice(py, result.weights.values()),
    )?;
    d.set_item("objective", result.objective)?;
    d.set_item("gradient_norm", result.gradient_norm)?;
    d.set_item("iterations", result.iterations)?;
    d.set_item("evaluations", result.evaluations)?;
    d.set_item("converged", result.converged)?;
    d.set_item("termination", result.termination.clone())?;
    d.set_item("objective_name", kind.name())?;
    Ok(d)
}
