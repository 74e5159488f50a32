//! Scan pairs and their ground truth, re-exported from [`pgm_scan::pair`] where
//! they live (models depend on `pgm-features`, not on this crate): readers, builders,
//! the simulator and the metrics of this crate produce and consume them.

pub use pgm_scan::pair::*;
