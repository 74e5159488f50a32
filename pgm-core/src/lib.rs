//! # pgm-core
//!
//! Factor graphs over discrete variables and the inference engine every model of this
//! project stands on.
//!
//! ## Tutorial: a CRF from scratch
//!
//! Building a new conditional random field takes four steps: features, learning,
//! inference, evaluation. The example below denoises a small two-class image (a
//! bright square on a dark background, seen through uniform noise); the full version,
//! with three classes, Gaussian noise, contrast-sensitive features, marginals and a
//! printed evaluation, is `cargo run --release --example crf_tutorial` in the
//! workspace root.
//!
//! 1. **Features.** A [`FeatureSet`] names the weights in templates; a
//!    [`LogLinearModel`] per image holds one clique per
//!    pixel (`[x = c]` and `[x = c]·z` for each class `c`, where `z` is the noisy
//!    intensity) and one per pair of neighbours (`[x_i = x_j]`), so that every
//!    log-potential is `w · f(x, z)`.
//! 2. **Learning.** [`LearnerParams`] → [`Learner`] maximises the pseudo-likelihood of
//!    labelled images with L-BFGS.
//! 3. **Inference.** The learned model becomes a [`FactorGraph`]; loopy max-product
//!    [`BeliefPropagation`] gives a MAP labelling, and [`Trws`] gives one *with a
//!    certificate*: an upper bound on the best log-score, so the labelling is at most
//!    the gap below the optimum.
//! 4. **Evaluation.** Pixel accuracy against the truth, next to the pixel-wise
//!    classifier that ignores the neighbours.
//!
//! ```
//! use std::ops::ControlFlow;
//! use std::sync::Arc;
//! use pgm_core::learning::{DenseFeatures, FeatureSet, LabelledInstance, LearnerParams, LogLinearModel};
//! use pgm_core::{BeliefPropagation, BpParams, Mode, ParamGuard, Sequential, TrwsParams, VariableId};
//! use rand::{Rng, SeedableRng};
//!
//! const SIDE: usize = 16;
//! let mut rng = rand::rngs::StdRng::seed_from_u64(7);
//! // Bright blobs (class 1) on a dark background (class 0), seen through noise.
//! let mut image = || {
//!     let (a, b) = (rng.random_range(0.0..6.3), rng.random_range(0.0..6.3));
//!     let labels: Vec<usize> = (0..SIDE * SIDE)
//!         .map(|i| usize::from(((i / SIDE) as f64 * 0.5 + a).sin() + ((i % SIDE) as f64 * 0.4 + b).sin() > 0.6))
//!         .collect();
//!     let z: Vec<f64> = labels.iter().map(|&l| l as f64 + rng.random_range(-0.8..0.8) + rng.random_range(-0.8..0.8)).collect();
//!     (labels, z)
//! };
//!
//! // 1. Features.
//! let mut features = FeatureSet::new("denoise", 1);
//! let pixel = features.add_template("pixel", &["bias_0", "z_0", "bias_1", "z_1"]).unwrap();
//! let pair = features.add_template("neighbour", &["same"]).unwrap();
//! let features = Arc::new(features);
//! let crf = |z: &[f64]| {
//!     let mut model = LogLinearModel::new(Arc::clone(&features), &[2; SIDE * SIDE]).unwrap();
//!     for (i, &zi) in z.iter().enumerate() {
//!         // State 0: [1, z, 0, 0]; state 1: [0, 0, 1, z].
//!         let table = vec![1.0, zi, 0.0, 0.0, 0.0, 0.0, 1.0, zi];
//!         model.add_clique(pixel, DenseFeatures::new(vec![VariableId(i)], vec![2], 4, table).unwrap()).unwrap();
//!     }
//!     for i in 0..SIDE * SIDE {
//!         for j in [i + 1, i + SIDE] {
//!             if j < SIDE * SIDE && (j == i + SIDE || j % SIDE != 0) {
//!                 let same = DenseFeatures::new(vec![VariableId(i), VariableId(j)], vec![2, 2], 1, vec![1.0, 0.0, 0.0, 1.0]).unwrap();
//!                 model.add_clique(pair, same).unwrap();
//!             }
//!         }
//!     }
//!     model
//! };
//!
//! // 2. Learning from six labelled images.
//! let data: Vec<LabelledInstance> = (0..6)
//!     .map(|_| {
//!         let (labels, z) = image();
//!         LabelledInstance::new(crf(&z), labels)
//!     })
//!     .collect();
//! let learner = LearnerParams::default().prior_variance(10.0).check().unwrap();
//! let learned = learner.learn(&features, &data, &mut |_: &_| ControlFlow::Continue(())).unwrap();
//! println!("{}", learned.weights);
//! assert!(learned.weights.get("neighbour.same").unwrap() > 0.0); // neighbours agree
//!
//! // 3. Inference on a new image.
//! let (truth, z) = image();
//! let graph = crf(&z).to_factor_graph(learned.weights.values()).unwrap();
//! let bp = BpParams::new(Mode::MaxProduct).max_iterations(50).check_unwrap()
//!     .run(&graph, &mut Sequential::default()).unwrap();
//! let trws = TrwsParams::default().max_iterations(50).check().unwrap().run(&graph).unwrap();
//! assert!(trws.log_score <= trws.bound + 1e-9 * trws.bound.abs()); // the certificate
//! println!("TRW-S: log-score {:.3}, bound {:.3}, gap {:.2e}", trws.log_score, trws.bound, trws.gap);
//!
//! // 4. Evaluation against the truth and the pixel-wise classifier.
//! let accuracy = |x: &[usize]| x.iter().zip(&truth).filter(|(a, b)| a == b).count() as f64 / truth.len() as f64;
//! let w = learned.weights.values();
//! let pixelwise: Vec<usize> = z.iter().map(|&zi| usize::from(w[2] + w[3] * zi > w[0] + w[1] * zi)).collect();
//! println!("accuracy: pixel-wise {:.3}, BP {:.3}, TRW-S {:.3}", accuracy(&pixelwise), accuracy(&bp.assignment), accuracy(&trws.assignment));
//! assert!(accuracy(&trws.assignment) > accuracy(&pixelwise));
//! assert!(accuracy(&bp.assignment) > accuracy(&pixelwise));
//! ```
//!
//! ## The crate
//!
//! **Big picture.** A [`FactorGraph`] holds variables of any cardinality and factors of
//! any arity behind the [`Factor`] trait (dense [`TableFactor`]s, O(K) [`PottsFactor`]
//! and [`ShiftedIdentityFactor`], or your own). [`BeliefPropagation`] runs loopy
//! max-product or sum-product in log space, driven by a [`Schedule`] ([`Flooding`] in
//! parallel, [`Sequential`], [`Residual`], or yours), with damping, a tolerance, an
//! iteration limit, a time budget and warm starts; an [`Observe`]r sees every
//! iteration's residual and may stop the run. [`Trws`] (sequential tree-reweighted
//! max-product) gives MAP assignments with an upper bound on the best log-score. An
//! [`UpdateHook`] sees every update and may refresh potentials in between (the
//! mechanism hybrid continuous nodes use). [`hybrid`] couples discrete variables to
//! observed-continuous nodes solved in closed form, on any graph
//! ([`hybrid::HybridInference`]) or, exactly per sweep, on one or several chains
//! ([`hybrid::chain`], where a model writes its log-linear features once for inference
//! and for [`learning`]). [`exact`] holds independent references (brute force, chains,
//! trees), [`param`] the checked-parameters pattern every crate of the workspace
//! follows, and [`uai`] reads and writes the UAI competition formats. [`support`]
//! decides whether any assignment has positive probability: belief propagation and
//! TRW-S never return a MAP assignment of probability 0 nor marginals of a model with
//! `Z = 0` (they return [`Error::Infeasible`]).
//!
//! ```
//! use pgm_core::{BeliefPropagation, BpParams, ParamGuard, FactorGraph, Mode, PottsFactor, Residual, TableFactor, VariableId};
//! use pgm_core::exact::{brute_force, BruteForceLimit};
//!
//! // A triangle (a loop) of binary variables that like to agree.
//! let mut g = FactorGraph::with_variables(&[2, 2, 2]).unwrap();
//! g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.3, 0.0]).unwrap()).unwrap();
//! for (a, b) in [(0, 1), (1, 2), (0, 2)] {
//!     g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 2, 1.0, 0.0).unwrap()).unwrap();
//! }
//! let bp = BpParams::new(Mode::MaxProduct).tolerance(1e-10).check_unwrap();
//! let result = bp.run(&g, &mut Residual::default()).unwrap();
//! let exact = brute_force(&g, BruteForceLimit::default()).unwrap();
//! assert_eq!(result.log_score, exact.map_log_score);
//! assert!(result.converged);
//! ```
//!
//! **Current state.** Inference (belief propagation with every schedule, TRW-S with
//! its bound), observers, hooks, exact references and UAI I/O are complete; hybrid
//! continuous nodes and learning (pseudo-likelihood, maximum likelihood on forests,
//! the Bethe likelihood) build on them; the `testing` feature adds the conformance kit
//! (`pgm_core::testing`) for factors, schedules and continuous nodes of one's own.

/// Runs code generic over a small state count fixed at compile time, so that its short
/// loops over states unroll: `with_small_states!(k, K => fixed, other)` evaluates
/// `fixed` with the constant `K` equal to `k` when `k` is 2 to 8, and `other`
/// otherwise.
macro_rules! with_small_states {
    ($k:expr, $K:ident => $fixed:expr, $other:expr $(,)?) => {
        with_small_states!(@sizes [2 3 4 5 6 7 8] $k, $K => $fixed, $other)
    };
    (@sizes [$($n:literal)*] $k:expr, $K:ident => $fixed:expr, $other:expr) => {
        match $k {
            $($n => {
                const $K: usize = $n;
                $fixed
            })*
            _ => $other,
        }
    };
}

pub mod bp;
pub mod error;
pub mod exact;
pub mod factor;
pub mod fsutil;
pub mod graph;
pub mod hook;
pub mod hybrid;
pub mod learning;
pub mod logspace;
pub mod observer;
pub mod param;
pub mod schedule;
#[cfg(feature = "proptest-strategies")]
pub mod strategies;
pub mod support;
#[cfg(feature = "testing")]
pub mod testing;
pub mod trws;
pub mod uai;

pub use bp::{
    decode_map, BeliefPropagation, BpParams, BpResult, BpRun, Messages, Propagation, Termination,
};
pub use error::{Error, Result};
pub use factor::{
    Factor, Incoming, MessageKernel, Mode, PottsFactor, ShiftedIdentityFactor, TableFactor,
};
pub use graph::{EdgeId, FactorGraph, FactorId, VariableId};
pub use hook::{Potentials, UpdateHook};
pub use learning::{FeatureSet, Learner, LearnerParams, LogLinearModel, PseudoLikelihood, Weights};
pub use observer::{BpProgress, History, Observe, TrwsProgress};
pub use param::{InvalidParameter, ParamGuard};
pub use schedule::{
    Flooding, MessagePasser, Residual, Schedule, ScheduleKind, Sequential, SequentialUnit, Visit,
};
pub use trws::{Trws, TrwsParams, TrwsResult, TrwsTermination};
