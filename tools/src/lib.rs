//! # pgm-tools
//!
//! The experiments and diagnostics behind the measured results in the book: oracles
//! that bound what a model could reach (`association_bound`) and per-pair analyses of
//! CRF-Clustering (`analyse_clustering`, `analyse_leigh`). They are programs for the
//! developers, kept apart from `examples/` (which show how to use the library) so the
//! examples stay examples. Run one with `cargo run --release -p pgm-tools --bin NAME`.
