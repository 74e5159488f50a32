//! # pgm
//!
//! Facade crate: re-exports the workspace crates under one name.

pub use pgm_baselines as baselines;
pub use pgm_core as core;
pub use pgm_datasets as datasets;
pub use pgm_features as features;

pub mod plot;
