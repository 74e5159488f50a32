//! One shape for the training of every model: a model's trainer holds its training
//! options ([`ModelTrainer`]); labelled pairs go in, the learned weights (the model's
//! weight file, [`ModelWeights`]) and a report of what they were learned from come
//! out ([`Trained`]). `pgm train` runs every model through it.
//!
//! ```
//! use pgm_features::training::{ModelTrainer, Trained};
//! use pgm_features::ModelResult;
//! use pgm_core::learning::LearningObserver;
//!
//! /// Trains any model on `pairs` and says what from.
//! fn train_and_report<T: ModelTrainer>(
//!     trainer: &T,
//!     pairs: &[pgm_scan::ScanPair],
//! ) -> ModelResult<Trained<T::Weights>> {
//!     let trained = trainer.train(pairs, &mut ())?;
//!     for (what, count) in &trained.counts {
//!         println!("{what}: {count}");
//!     }
//!     Ok(trained)
//! }
//! ```

use crate::weight_file::ModelWeights;
use crate::ModelResult;
use pgm_core::learning::{LearningObserver, LearningResult};
use pgm_scan::ScanPair;

/// A model's training with its options: [`ModelTrainer::train`] learns the model's
/// weights from labelled pairs.
pub trait ModelTrainer {
    /// The weights it learns (written as the model's weight file).
    type Weights: ModelWeights;

    /// Learns the weights from labelled `pairs`; the observer sees every L-BFGS
    /// iteration (`&mut ()` for none).
    ///
    /// # Errors
    /// The model's: no usable labelled pair, an option out of range, a pair that lacks
    /// the ground truth the model needs (named), learning that fails, weights the
    /// model would refuse.
    fn train(
        &self,
        pairs: &[ScanPair],
        observer: &mut dyn LearningObserver,
    ) -> ModelResult<Trained<Self::Weights>>;
}

/// What a [`ModelTrainer`] learned and from what.
#[derive(Clone, Debug)]
pub struct Trained<W> {
    /// The learned weights.
    pub weights: W,
    /// What they were learned from, by name (pairs, instances, booster samples, in the
    /// model's terms), for reports.
    pub counts: Vec<(&'static str, usize)>,
    /// The pseudo-likelihood optimisation.
    pub learning: LearningResult,
}
