//! Flooding (synchronous, "parallel") schedule.

use super::{MessagePasser, Schedule};

/// Every factor recomputes all its messages from the previous iteration's messages at
/// once. Factors are processed in parallel on rayon's current thread pool (run inside
/// a one-thread pool for single-threaded use).
#[derive(Clone, Debug, Default)]
pub struct Flooding;

impl Schedule for Flooding {
    fn name(&self) -> &str {
        "flooding"
    }

    fn iteration(&mut self, passer: &mut dyn MessagePasser) -> Option<f64> {
        passer.flood();
        None
    }
}
