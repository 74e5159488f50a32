//! # pgm-core
//!
//! Factor graphs over discrete variables and the inference engine every model of this
//! project stands on.
//!
//! **Big picture.** A [`FactorGraph`] holds variables of any cardinality and factors of
//! any arity behind the [`Factor`] trait (dense [`TableFactor`]s, O(K) [`PottsFactor`]
//! and [`ShiftedIdentityFactor`], or your own). [`BeliefPropagation`] runs loopy
//! max-product or sum-product in log space, driven by a [`Schedule`] ([`Flooding`] in
//! parallel, [`Sequential`], [`Residual`], or yours), with damping, a tolerance, an
//! iteration limit, a time budget and warm starts. An [`UpdateHook`] sees every update
//! and may refresh potentials in between (the mechanism hybrid continuous nodes use).
//! [`exact`] holds independent references (brute force, chains, trees) and [`uai`]
//! reads and writes the UAI competition formats.
//!
//! ```
//! use pgm_core::{BeliefPropagation, FactorGraph, Mode, PottsFactor, Residual, TableFactor, VariableId};
//! use pgm_core::exact::{brute_force, BruteForceLimit};
//!
//! // A triangle (a loop) of binary variables that like to agree.
//! let mut g = FactorGraph::with_variables(&[2, 2, 2]).unwrap();
//! g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.3, 0.0]).unwrap()).unwrap();
//! for (a, b) in [(0, 1), (1, 2), (0, 2)] {
//!     g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 2, 1.0, 0.0).unwrap()).unwrap();
//! }
//! let bp = BeliefPropagation::new(Mode::MaxProduct).tolerance(1e-10);
//! let result = bp.run(&g, &mut Residual::default()).unwrap();
//! let exact = brute_force(&g, BruteForceLimit::default()).unwrap();
//! assert_eq!(result.log_score, exact.map_log_score);
//! assert!(result.converged);
//! ```
//!
//! **Current state.** Inference, schedules, hooks, exact references and UAI I/O are
//! complete; hybrid continuous nodes and pseudo-likelihood learning build on them.

pub mod bp;
pub mod error;
pub mod exact;
pub mod factor;
pub mod graph;
pub mod hook;
pub mod hybrid;
pub mod learning;
pub mod logspace;
pub mod observer;
pub mod schedule;
#[cfg(feature = "proptest-strategies")]
pub mod strategies;
pub mod trws;
pub mod uai;

pub use bp::{decode_map, BeliefPropagation, BpResult, Messages, Propagation, Termination};
pub use error::{Error, Result};
pub use factor::{Factor, Incoming, Mode, PottsFactor, ShiftedIdentityFactor, TableFactor};
pub use graph::{EdgeId, FactorGraph, FactorId, VariableId};
pub use hook::{Potentials, UpdateHook};
pub use learning::{FeatureSet, Learner, LearnerParams, LogLinearModel, PseudoLikelihood, Weights};
pub use observer::{BpProgress, History, Observe, TrwsProgress};
pub use schedule::{
    Flooding, MessagePasser, Residual, Schedule, ScheduleKind, Sequential, SequentialUnit, Visit,
};
pub use trws::{Trws, TrwsParams, TrwsResult, TrwsTermination};
