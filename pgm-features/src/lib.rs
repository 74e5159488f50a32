//! # pgm-features
//!
//! The papers' CRF parts: the feature functions and chain tables that the model
//! crates compose into their factor graphs. It sits on `pgm-core` (factor tables,
//! hybrid chains, learning) and the scan layer `pgm-scan` (scans, alignment,
//! registration); a model crate depends on these three and never on the data readers
//! or on another model.
//!
//! **What it holds, by paper.**
//! - CRF-Clustering (Tipaldi & Ramos): its pairwise and unary features
//!   ([`clustering_features`]) and the per-cluster rigid motions as
//!   observed-continuous nodes ([`motion_nodes`], eq. 3 solved in closed form).
//! - CRF-Matching (Ramos, Fox & Durrant-Whyte): the shape, translation and outlier
//!   feature functions ([`shape_features`]), the AdaBoost booster over decision stumps
//!   that turns them into CRF features ([`boosting`]), and the association chain with
//!   its candidates and its 18 features written as CRF tables ([`matching_features`]);
//!   the joint model shares this chain.
//! - The joint matching + clustering + motion model: its clustering chain and 12
//!   features ([`joint_clustering_features`]).
//!
//! **What the models share.** One weight file ([`weight_file`]: the kind tag, the
//! named weights, the model's other learned parts), the training of a model with an
//! association chain ([`matching_training`]: CRF-Matching's, which the joint model
//! shares; every model's training has one shape, [`training`]), the rounds of inference on that chain
//! ([`association_rounds`]: the problem built beside the motion hypotheses, starting
//! states, when rounds settle, the ego-motion's final ICP, per-beam output), and one
//! error shape ([`ModelError`], each model crate's `Error`).
//!
//! Errors of the feature code are the scan layer's ([`Error`]): the features fail only
//! on geometry they cannot work on and on errors of the core.

pub mod association_rounds;
pub mod boosting;
pub mod clustering_features;
pub mod joint_clustering_features;
pub mod matching_features;
pub mod matching_training;
mod model_error;
pub mod motion_nodes;
pub mod shape_features;
pub mod training;
pub mod weight_file;

pub use model_error::{ModelError, ModelResult};
pub use motion_nodes::{ClusterMotions, RigidMotionNodes};
pub use pgm_scan::{Error, Result};
pub use weight_file::{ModelWeights, WeightFile, WeightFileError};
