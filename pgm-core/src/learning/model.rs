//! Log-linear models: named weights grouped into templates, cliques that supply
//! feature vectors, and instances that turn into [`FactorGraph`]s for given weights.
//!
//! A clique `c` of a log-linear CRF has log-potential `w · f_c(x_c, z)` (eq. 1 of the
//! CRF-Clustering paper, `φ_c = exp(w_cᵀ f_c(z, x_c))`). The weight vector `w` is
//! global and named: a [`FeatureSet`] lists the model's weights, grouped into
//! *templates* (for CRF-Clustering: `distance`, `neighbour`, `weighted_neighbour`,
//! `stiffness`), and every clique of every instance uses exactly one template. A
//! clique therefore supplies only its template's slice of the feature vector (length =
//! the template's width, not the number of all weights): features are sparse by
//! construction and one clique's dot product costs its template's width.
//!
//! Observations `z` live inside the cliques: a [`CliqueFeatures`] implementation holds
//! whatever data it needs (distances, AdaBoost outputs, ...) and computes features on
//! demand, so a clique over 362 × 362 association states need not store a dense
//! table. [`DenseFeatures`] is the ready-made dense table for small cliques.

use crate::error::{Error, Result};
use crate::factor::TableFactor;
use crate::graph::{FactorGraph, VariableId};
use std::fmt;
use std::ops::Range;
use std::sync::Arc;

/// Largest magnitude of a log-linear weight ([`crate::Error::BadWeight`] beyond it).
/// A weight's potential is `w · f` summed over the cliques of a graph: with `|w|` up to
/// 1e12, features up to 1e12 and a million cliques the sums stay below 1e30, far from
/// overflow, while trained weights are of order one; a weight near ±1e308 turns the
/// first potential it touches into ±∞ and the next sum into NaN.
pub const MAX_ABS_WEIGHT: f64 = 1e12;

/// Index of a template in its [`FeatureSet`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TemplateId(pub usize);

/// A group of weights shared by many cliques (e.g. every neighbour clique of a chain).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Template {
    name: String,
    weights: Range<usize>,
}

impl Template {
    /// The template's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The template's slice of the global weight vector.
    pub fn weights(&self) -> Range<usize> {
        self.weights.clone()
    }

    /// Number of features (weights) of the template.
    pub fn width(&self) -> usize {
        self.weights.len()
    }
}

/// The named weights of a log-linear model, grouped into templates, plus the model's
/// name and version (saved with learned weights so that weights of one model are never
/// loaded into another).
///
/// Weight `j` of template `t` is named `"{t}.{feature}"`.
///
/// ```
/// use pgm_core::learning::FeatureSet;
/// let mut features = FeatureSet::new("toy", 1);
/// let unary = features.add_template("unary", &["bias", "slope"]).unwrap();
/// let pair = features.add_template("pair", &["same"]).unwrap();
/// assert_eq!(features.num_weights(), 3);
/// assert_eq!(features.template(pair).unwrap().weights(), 2..3);
/// assert_eq!(features.names()[1], "unary.slope");
/// assert!(features.add_template("unary", &["bias"]).is_err()); // duplicate name
/// # let _ = unary;
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FeatureSet {
    model: String,
    version: u32,
    names: Vec<String>,
    templates: Vec<Template>,
}

impl FeatureSet {
    /// An empty feature set for the model `model` at `version`.
    pub fn new(model: impl Into<String>, version: u32) -> Self {
        Self {
            model: model.into(),
            version,
            names: Vec::new(),
            templates: Vec::new(),
        }
    }

    /// Adds a template with one weight per entry of `features`; its weights are named
    /// `"{name}.{feature}"` and must be new.
    pub fn add_template(&mut self, name: &str, features: &[&str]) -> Result<TemplateId> {
        if features.is_empty() {
            return Err(Error::InvalidParameter {
                name: "template features",
                value: format!("template {name:?} with no features"),
                expected: "at least one feature per template",
            });
        }
        if self.templates.iter().any(|t| t.name == name) {
            return Err(Error::InvalidParameter {
                name: "template name",
                value: name.to_string(),
                expected: "a name not used by another template of the feature set",
            });
        }
        let new_names: Vec<String> = features.iter().map(|f| format!("{name}.{f}")).collect();
        for (j, n) in new_names.iter().enumerate() {
            if self.names.contains(n) || new_names[..j].contains(n) {
                return Err(Error::InvalidParameter {
                    name: "feature name",
                    value: n.clone(),
                    expected: "unique feature names",
                });
            }
        }
        let start = self.names.len();
        self.names.extend(new_names);
        self.templates.push(Template {
            name: name.to_string(),
            weights: start..self.names.len(),
        });
        Ok(TemplateId(self.templates.len() - 1))
    }

    /// The model's name.
    pub fn model(&self) -> &str {
        &self.model
    }

    /// The model's version.
    pub fn version(&self) -> u32 {
        self.version
    }

    /// Total number of weights.
    pub fn num_weights(&self) -> usize {
        self.names.len()
    }

    /// Weight names in weight-vector order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Position of a weight in the weight vector.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// A template, if `id` belongs to this set.
    pub fn template(&self, id: TemplateId) -> Option<&Template> {
        self.templates.get(id.0)
    }

    /// All templates, in the order they were added.
    pub fn templates(&self) -> &[Template] {
        &self.templates
    }

    /// Checks that `other` is the same model, version and feature list.
    pub(crate) fn check_same(&self, other: &FeatureSet) -> Result<()> {
        if self.model != other.model || self.version != other.version {
            return Err(Error::ModelMismatch {
                expected_model: self.model.clone(),
                expected_version: self.version,
                found_model: other.model.clone(),
                found_version: other.version,
            });
        }
        if self.names != other.names {
            return Err(self.name_mismatch(&other.names));
        }
        Ok(())
    }

    /// The error listing names missing from / extra in `found` compared with this set.
    pub(crate) fn name_mismatch(&self, found: &[String]) -> Error {
        Error::WeightNames {
            model: self.model.clone(),
            missing: self
                .names
                .iter()
                .filter(|n| !found.contains(n))
                .cloned()
                .collect(),
            extra: found
                .iter()
                .filter(|n| !self.names.contains(n))
                .cloned()
                .collect(),
        }
    }

    /// Checks that a weight vector has one finite value per weight.
    pub(crate) fn check_weights(&self, weights: &[f64]) -> Result<()> {
        if weights.len() != self.names.len() {
            return Err(Error::InvalidParameter {
                name: "weights",
                value: format!("{} values", weights.len()),
                expected: "one value per weight of the feature set",
            });
        }
        for (name, &value) in self.names.iter().zip(weights) {
            if !value.is_finite() || value.abs() > MAX_ABS_WEIGHT {
                return Err(Error::BadWeight {
                    name: name.clone(),
                    value,
                });
            }
        }
        Ok(())
    }
}

/// The feature vector of one clique, for every joint state of its scope.
///
/// `features` is called with a joint state (`states[j]` is the state of `scope()[j]`)
/// and an `out` slice of the clique's template width, which is **zero on entry**, so a
/// sparse feature only writes its non-zero entries. Features must be finite; the
/// learner and [`LogLinearModel::to_factor_graph`] report NaN or infinite values as
/// [`Error::BadFeature`]. Observations are held by the implementation.
///
/// ```
/// use pgm_core::learning::CliqueFeatures;
/// use pgm_core::VariableId;
///
/// /// Neighbour feature of a chain: `[1, d]` when both points share a cluster, where
/// /// `d` is the distance between the points (CRF-Clustering eqs. 4-5).
/// struct SameCluster { scope: [VariableId; 2], shape: [usize; 2], distance: f64 }
///
/// impl CliqueFeatures for SameCluster {
///     fn scope(&self) -> &[VariableId] { &self.scope }
///     fn shape(&self) -> &[usize] { &self.shape }
///     fn features(&self, states: &[usize], out: &mut [f64]) {
///         if states[0] == states[1] {
///             out[0] = 1.0;
///             out[1] = self.distance;
///         }
///     }
/// }
/// ```
pub trait CliqueFeatures: Send + Sync {
    /// The variables of the clique.
    fn scope(&self) -> &[VariableId];

    /// The number of states of each scope variable.
    fn shape(&self) -> &[usize];

    /// Writes the feature vector at a joint state into `out` (zero on entry; its
    /// length is the template's number of features).
    fn features(&self, states: &[usize], out: &mut [f64]);

    /// The number of features the clique writes per joint state, when it is fixed by
    /// the clique's data (a [`DenseFeatures`] table): [`LogLinearModel::add_clique`]
    /// then refuses a clique whose width is not its template's. `None` (the default)
    /// for cliques that write whatever `out` holds.
    fn width(&self) -> Option<usize> {
        None
    }
}

/// A clique over a fixed number `N` of variables whose features a function computes:
/// [`CliqueFeatures`] for a scope, a shape and a closure holding the observations,
/// without a type of its own.
///
/// ```
/// use pgm_core::learning::{CliqueFeatures, FnFeatures};
/// use pgm_core::VariableId;
///
/// // `[1, d]` when both points share a cluster, `d` the distance between the points.
/// let distance = 0.5;
/// let same_cluster = FnFeatures::new([VariableId(0), VariableId(1)], [3, 3], move |states, out| {
///     if states[0] == states[1] {
///         out[0] = 1.0;
///         out[1] = distance;
///     }
/// });
/// assert_eq!(same_cluster.shape(), &[3, 3]);
/// let mut out = [0.0; 2];
/// same_cluster.features(&[2, 2], &mut out);
/// assert_eq!(out, [1.0, 0.5]);
/// ```
#[derive(Clone)]
pub struct FnFeatures<F, const N: usize> {
    scope: [VariableId; N],
    shape: [usize; N],
    features: F,
}

impl<F, const N: usize> FnFeatures<F, N>
where
    F: Fn(&[usize], &mut [f64]) + Send + Sync,
{
    /// The clique over `scope` (`shape[j]` states for `scope[j]`) whose feature vector
    /// at a joint state `features(states, out)` writes into `out` (zero on entry, as
    /// in [`CliqueFeatures::features`]).
    pub fn new(scope: [VariableId; N], shape: [usize; N], features: F) -> Self {
        Self {
            scope,
            shape,
            features,
        }
    }
}

impl<F, const N: usize> CliqueFeatures for FnFeatures<F, N>
where
    F: Fn(&[usize], &mut [f64]) + Send + Sync,
{
    fn scope(&self) -> &[VariableId] {
        &self.scope
    }

    fn shape(&self) -> &[usize] {
        &self.shape
    }

    fn features(&self, states: &[usize], out: &mut [f64]) {
        (self.features)(states, out)
    }
}

/// A dense feature table: for every joint state (row-major, last scope position
/// fastest, the order of [`TableFactor`]) a contiguous feature vector of `width`
/// entries.
#[derive(Clone, Debug, PartialEq)]
pub struct DenseFeatures {
    scope: Vec<VariableId>,
    shape: Vec<usize>,
    strides: Vec<usize>,
    width: usize,
    table: Vec<f64>,
}

impl DenseFeatures {
    /// A dense table; `table.len()` must be `Π shape × width`.
    pub fn new(
        scope: Vec<VariableId>,
        shape: Vec<usize>,
        width: usize,
        table: Vec<f64>,
    ) -> Result<Self> {
        let states = crate::factor::check_scope_shape(&scope, &shape, "dense features shape")?;
        let expected = states * width;
        if table.len() != expected {
            return Err(Error::TableSize {
                expected,
                actual: table.len(),
            });
        }
        let strides = crate::factor::row_major_strides(&shape, width);
        Ok(Self {
            scope,
            shape,
            strides,
            width,
            table,
        })
    }

    /// Number of features per joint state.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The table, row-major by joint state, `width` features per state.
    pub fn table(&self) -> &[f64] {
        &self.table
    }
}

impl CliqueFeatures for DenseFeatures {
    fn scope(&self) -> &[VariableId] {
        &self.scope
    }

    fn shape(&self) -> &[usize] {
        &self.shape
    }

    #[inline]
    fn features(&self, states: &[usize], out: &mut [f64]) {
        let start = crate::factor::strided_index(states, &self.strides);
        out.copy_from_slice(&self.table[start..start + self.width]);
    }

    fn width(&self) -> Option<usize> {
        Some(self.width)
    }
}

/// One clique of a [`LogLinearModel`].
pub(crate) struct Clique {
    pub(crate) template: TemplateId,
    pub(crate) weights: Range<usize>,
    pub(crate) features: Box<dyn CliqueFeatures>,
}

/// One instance of a log-linear model (e.g. the CRF over one scan pair): variables
/// with their cardinalities, and cliques, each using one template of a shared
/// [`FeatureSet`] and supplying its features through [`CliqueFeatures`].
///
/// ```
/// use std::sync::Arc;
/// use pgm_core::learning::{DenseFeatures, FeatureSet, LogLinearModel};
/// use pgm_core::VariableId;
///
/// let mut features = FeatureSet::new("toy", 1);
/// let unary = features.add_template("unary", &["bias"]).unwrap();
/// let pair = features.add_template("pair", &["same"]).unwrap();
/// let features = Arc::new(features);
///
/// let mut model = LogLinearModel::new(Arc::clone(&features), &[2, 2]).unwrap();
/// // Unary: feature 1 in state 1, 0 in state 0.
/// model.add_clique(unary, DenseFeatures::new(vec![VariableId(0)], vec![2], 1, vec![0.0, 1.0]).unwrap()).unwrap();
/// // Pairwise: feature 1 when both agree.
/// let same = DenseFeatures::new(vec![VariableId(0), VariableId(1)], vec![2, 2], 1, vec![1.0, 0.0, 0.0, 1.0]).unwrap();
/// model.add_clique(pair, same).unwrap();
///
/// let graph = model.to_factor_graph(&[0.5, 2.0]).unwrap();
/// assert_eq!(graph.log_score(&[1, 1]).unwrap(), 2.5);
/// ```
pub struct LogLinearModel {
    features: Arc<FeatureSet>,
    cardinalities: Vec<usize>,
    cliques: Vec<Clique>,
    /// For each variable, its cliques and its position in each clique's scope.
    variable_cliques: Vec<Vec<(usize, usize)>>,
}

impl fmt::Debug for LogLinearModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LogLinearModel")
            .field("model", &self.features.model())
            .field("variables", &self.cardinalities.len())
            .field("cliques", &self.cliques.len())
            .finish()
    }
}

impl LogLinearModel {
    /// A model with one variable per entry of `cardinalities` and no cliques yet.
    pub fn new(features: Arc<FeatureSet>, cardinalities: &[usize]) -> Result<Self> {
        if let Some(variable) = cardinalities.iter().position(|&k| k == 0) {
            return Err(Error::ZeroCardinality { variable });
        }
        Ok(Self {
            features,
            cardinalities: cardinalities.to_vec(),
            cliques: Vec::new(),
            variable_cliques: vec![Vec::new(); cardinalities.len()],
        })
    }

    /// Adds a clique using `template`, after checking its scope and shape against the
    /// variables. Returns the clique's index.
    pub fn add_clique<C: CliqueFeatures + 'static>(
        &mut self,
        template: TemplateId,
        clique: C,
    ) -> Result<usize> {
        self.add_boxed_clique(template, Box::new(clique))
    }

    /// [`add_clique`](Self::add_clique) for a boxed clique.
    pub fn add_boxed_clique(
        &mut self,
        template: TemplateId,
        clique: Box<dyn CliqueFeatures>,
    ) -> Result<usize> {
        let index = self.cliques.len();
        let weights = self
            .features
            .template(template)
            .ok_or_else(|| Error::InvalidParameter {
                name: "template",
                value: template.0.to_string(),
                expected: "a template of the model's feature set",
            })?
            .weights();
        if let Some(width) = clique.width() {
            if width != weights.len() {
                return Err(Error::InvalidParameter {
                    name: "clique features",
                    value: format!("{width} per joint state (clique {index})"),
                    expected: "the template's number of features",
                });
            }
        }
        let (scope, shape) = (clique.scope(), clique.shape());
        crate::factor::check_scope_against(
            index,
            scope,
            shape,
            &self.cardinalities,
            "clique shape",
        )?;
        for (slot, &v) in scope.iter().enumerate() {
            self.variable_cliques[v.0].push((index, slot));
        }
        self.cliques.push(Clique {
            template,
            weights,
            features: clique,
        });
        Ok(index)
    }

    /// The model's feature set.
    pub fn feature_set(&self) -> &Arc<FeatureSet> {
        &self.features
    }

    /// Number of variables.
    pub fn num_variables(&self) -> usize {
        self.cardinalities.len()
    }

    /// Number of cliques.
    pub fn num_cliques(&self) -> usize {
        self.cliques.len()
    }

    /// All cardinalities, in variable order.
    pub fn cardinalities(&self) -> &[usize] {
        &self.cardinalities
    }

    /// The template a clique uses.
    pub fn clique_template(&self, clique: usize) -> Option<TemplateId> {
        self.cliques.get(clique).map(|c| c.template)
    }

    /// A clique's features.
    pub fn clique(&self, clique: usize) -> Option<&dyn CliqueFeatures> {
        self.cliques.get(clique).map(|c| c.features.as_ref())
    }

    /// The cliques containing a variable, as (clique index, position in its scope).
    pub fn variable_cliques(&self, variable: VariableId) -> &[(usize, usize)] {
        &self.variable_cliques[variable.0]
    }

    pub(crate) fn cliques(&self) -> &[Clique] {
        &self.cliques
    }

    /// The error for a non-finite feature found in `clique` at `states`.
    pub(crate) fn bad_feature(
        &self,
        clique: usize,
        states: &[usize],
        values: &[f64],
        instance: Option<usize>,
        variable: Option<usize>,
    ) -> Option<Error> {
        let c = &self.cliques[clique];
        let j = values.iter().position(|x| !x.is_finite())?;
        Some(Error::BadFeature {
            instance,
            variable,
            clique,
            states: states.to_vec(),
            feature: self.features.names()[c.weights.start + j].clone(),
            value: values[j],
        })
    }

    /// Sum of the feature vectors of all cliques at a joint assignment (the sufficient
    /// statistics: `log_score = w · feature_totals`), one entry per weight.
    pub fn feature_totals(&self, assignment: &[usize]) -> Result<Vec<f64>> {
        self.check_assignment(assignment)?;
        let mut totals = vec![0.0; self.features.num_weights()];
        let mut states = Vec::new();
        let mut buffer = Vec::new();
        for (index, c) in self.cliques.iter().enumerate() {
            states.clear();
            states.extend(c.features.scope().iter().map(|v| assignment[v.0]));
            buffer.clear();
            buffer.resize(c.weights.len(), 0.0);
            c.features.features(&states, &mut buffer);
            if let Some(e) = self.bad_feature(index, &states, &buffer, None, None) {
                return Err(e);
            }
            for (t, f) in totals[c.weights.clone()].iter_mut().zip(&buffer) {
                *t += f;
            }
        }
        Ok(totals)
    }

    fn check_assignment(&self, assignment: &[usize]) -> Result<()> {
        crate::graph::check_assignment(&self.cardinalities, assignment)
    }

    /// The factor graph of this instance for `weights`: one [`TableFactor`] per clique
    /// with log-table `w · f_c(x_c)` over all joint states of the clique, so inference
    /// ([`BeliefPropagation`](crate::BeliefPropagation), [`exact`](crate::exact)) runs
    /// on the learned model. Cliques keep their order: clique `c` becomes factor `c`.
    pub fn to_factor_graph(&self, weights: &[f64]) -> Result<FactorGraph> {
        self.features.check_weights(weights)?;
        let mut graph = FactorGraph::with_variables(&self.cardinalities)?;
        let mut buffer = Vec::new();
        for (index, c) in self.cliques.iter().enumerate() {
            let scope = c.features.scope().to_vec();
            let shape = c.features.shape().to_vec();
            let size: usize = shape.iter().product();
            let w = &weights[c.weights.clone()];
            let mut table = Vec::with_capacity(size);
            let mut states = vec![0usize; shape.len()];
            for _ in 0..size {
                buffer.clear();
                buffer.resize(w.len(), 0.0);
                c.features.features(&states, &mut buffer);
                if let Some(e) = self.bad_feature(index, &states, &buffer, None, None) {
                    return Err(e);
                }
                let value: f64 = w.iter().zip(&buffer).map(|(a, b)| a * b).sum();
                if !value.is_finite() {
                    return Err(Error::BadLogPotential {
                        index: table.len(),
                        value,
                    });
                }
                table.push(value);
                crate::factor::increment(&mut states, &shape);
            }
            graph.add_factor(TableFactor::new(scope, shape, table)?)?;
        }
        Ok(graph)
    }
}

/// A training example: a model instance (whose cliques carry the observations `z`)
/// and the true assignment `x` of all its variables.
#[derive(Debug)]
pub struct LabelledInstance {
    /// The instance.
    pub model: LogLinearModel,
    /// The true state of every variable, in variable order.
    pub labels: Vec<usize>,
}

impl LabelledInstance {
    /// Pairs an instance with its labels (checked when the training set is built, so
    /// that errors can name the instance's position in it).
    pub fn new(model: LogLinearModel, labels: Vec<usize>) -> Self {
        Self { model, labels }
    }
}
