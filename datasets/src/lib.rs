//! # pgm-datasets
//!
//! Everything between raw laser data and the models: scan pairs with ground truth
//! ([`pair`]), the real-log readers ([`carmen`] for CARMEN logs, [`relations`] for
//! Kümmerle-style relation files, [`leigh`] for the leigh-gtm1 text logs, [`bag`] for
//! ROS 1 bags and ROS 2 MCAP bags), the builders that turn logs into pairs with ground
//! truth ([`builders`]; [`mocap`] for motion-capture truth), the on-disk
//! pair format ([`format`](mod@format), specified in `datasets/FORMAT.md`), pair
//! sources ([`source`]: a stored data set, a real log or a bag, loaded one way), the
//! evaluation metrics of both papers as pure functions ([`metrics`]), the urban laser
//! simulator ([`sim`]) and the shared-data lookup for real-data tests ([`testdata`]).
//! The scan-pair types themselves live in the scan layer `pgm-scan` (models depend on
//! them, not on this crate) and are re-exported here. The evaluation loops that run
//! methods over pairs and score them with these metrics are the `pgm-eval` crate.
//!
//! ```no_run
//! use pgm_datasets::{builders, carmen, relations};
//!
//! # fn main() -> pgm_datasets::Result<()> {
//! let log = carmen::read_carmen("mit-csail.clf")?;
//! let rels = relations::read_relations("mit-csail.relations")?;
//! let built = builders::relation_pairs(&log, &rels, &Default::default());
//! pgm_datasets::write_pairs("out/mit-csail", &built.pairs)?;
//! let again = pgm_datasets::read_pairs("out/mit-csail")?;
//! assert_eq!(again.len(), built.pairs.len());
//! # Ok(())
//! # }
//! ```

pub mod bag;
pub mod beams;
pub mod builders;
pub mod carmen;
pub mod clear_mot;
pub mod error;
pub mod format;
pub mod leigh;
pub mod metrics;
pub mod mocap;
pub mod pair;
pub mod relations;
pub mod sim;
pub mod source;
pub mod stamps;
pub mod testdata;
mod text;
pub mod tracking_truth;

pub use error::{Error, Result};
pub use format::{read_chosen_pair, read_pairs, write_pairs};
pub use pair::{Association, ClusterMotion, GroundTruth, PairViolation, ScanPair};
pub use pgm_scan::ParamGuard;
