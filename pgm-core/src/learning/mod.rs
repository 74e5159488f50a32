//! Learning the weights of log-linear CRFs with L-BFGS: by maximum pseudo-likelihood,
//! as both papers do (CRF-Clustering, section III; joint model, section III-B), by
//! maximum likelihood with exact marginals on chains and trees, or by the Bethe
//! likelihood of loopy belief propagation ([`LearningObjective`]).
//!
//! **Big picture.** A [`FeatureSet`] names a model's weights, grouped into templates
//! shared by many cliques. A [`LogLinearModel`] is one instance (say, the CRF over one
//! scan pair): variables and cliques whose [`CliqueFeatures`] give the feature vector
//! `f_c(x_c, z)` of every joint state, so that the clique's log-potential is
//! `w · f_c`; [`LogLinearModel::to_factor_graph`] turns it into a
//! [`FactorGraph`](crate::FactorGraph) for inference. [`PseudoLikelihood`] is the
//! objective over [`LabelledInstance`]s with its analytic gradient, evaluated in
//! parallel; [`Likelihood`] is the conditional likelihood (exact on forests, Bethe on
//! loops) with its gradient `E[F] − F(y)`; a [`Learner`] (built from checked [`LearnerParams`]) minimises it with
//! argmin's L-BFGS and reports each iteration to a [`LearningObserver`]; learned
//! [`Weights`] save to and load from JSON by name.
//!
//! **Plugging in a paper's model.** A model crate defines its [`FeatureSet`] once
//! (CRF-Clustering: templates for the local distance feature and the neighbour,
//! weighted-neighbour and stiffness features, 12 weights; CRF-Matching: 18) and, per
//! training pair, a [`LogLinearModel`] whose cliques implement [`CliqueFeatures`] over
//! that pair's observations. Features that depend on continuous nodes (the cluster
//! motions R, T of both papers) are computed with those nodes at their values under
//! the true labels, the way the papers treat them as observed. Large cliques (362 ×
//! 362 association states) stay lazy: features are computed on demand, and
//! [`PseudoLikelihood`] caches per-variable conditionals only within a memory limit.
//! [`LogLinearModel::to_factor_graph`] builds dense tables, which suits small cliques;
//! models with structured factors build their own graphs from the learned weights.
//!
//! ```
//! use std::ops::ControlFlow;
//! use std::sync::Arc;
//! use pgm_core::learning::{DenseFeatures, FeatureSet, LabelledInstance, LearnerParams, LogLinearModel, Progress};
//! use pgm_core::{ParamGuard, VariableId};
//!
//! // A two-state chain: a unary feature pulls towards the observation, a pairwise one
//! // rewards agreeing neighbours.
//! let mut features = FeatureSet::new("toy-chain", 1);
//! let unary = features.add_template("observation", &["agrees"]).unwrap();
//! let pair = features.add_template("neighbour", &["same"]).unwrap();
//! let features = Arc::new(features);
//!
//! let build = |observed: &[usize], labels: &[usize]| {
//!     let mut model = LogLinearModel::new(Arc::clone(&features), &vec![2; observed.len()]).unwrap();
//!     for (i, &z) in observed.iter().enumerate() {
//!         let table = (0..2).map(|x| if x == z { 1.0 } else { 0.0 }).collect();
//!         model.add_clique(unary, DenseFeatures::new(vec![VariableId(i)], vec![2], 1, table).unwrap()).unwrap();
//!     }
//!     for i in 1..observed.len() {
//!         let same = DenseFeatures::new(vec![VariableId(i - 1), VariableId(i)], vec![2, 2], 1, vec![1.0, 0.0, 0.0, 1.0]).unwrap();
//!         model.add_clique(pair, same).unwrap();
//!     }
//!     LabelledInstance::new(model, labels.to_vec())
//! };
//! let data = vec![
//!     build(&[0, 0, 1, 1, 1], &[0, 0, 1, 1, 1]),
//!     build(&[1, 0, 1, 1, 0], &[1, 1, 1, 1, 0]),
//!     build(&[0, 1, 0, 0, 1], &[0, 0, 0, 0, 1]),
//! ];
//!
//! let learner = LearnerParams::default().prior_variance(10.0).check().unwrap();
//! let mut observer = |p: &Progress| {
//!     println!("iteration {}: objective {:.4}, |gradient| {:.2e}", p.iteration, p.objective, p.gradient_norm);
//!     ControlFlow::Continue(())
//! };
//! let result = learner.learn(&features, &data, &mut observer).unwrap();
//! assert!(result.converged);
//! assert!(result.weights.get("observation.agrees").unwrap() > 0.0);
//! println!("{}", result.weights);
//!
//! // Inference on the learned model.
//! let graph = data[0].model.to_factor_graph(result.weights.values()).unwrap();
//! let exact = pgm_core::exact::brute_force(&graph, Default::default()).unwrap();
//! assert_eq!(exact.map, vec![0, 0, 1, 1, 1]);
//! ```

mod chain;
mod likelihood;
mod model;
mod optimise;
mod pseudo_likelihood;
mod weights;

pub use likelihood::{Likelihood, LikelihoodKind};
pub use model::{
    CliqueFeatures, DenseFeatures, FeatureSet, FnFeatures, LabelledInstance, LogLinearModel,
    Template, TemplateId, MAX_ABS_WEIGHT,
};
pub use optimise::{
    Learner, LearnerParams, LearningObjective, LearningObserver, LearningResult, Objective,
    Progress,
};
pub use pseudo_likelihood::{PseudoLikelihood, DEFAULT_FEATURE_CACHE_BYTES};
pub use weights::Weights;
