//! The joint model as a [`JointEstimator`], the interface through which evaluation,
//! the command-line tool and the examples run it next to the two-step pipelines
//! (`pgm_eval::evaluate_joint`, `pgm eval joint`).

use crate::Joint;
use pgm_scan::methods::{JointEstimate, JointEstimator};
use pgm_scan::ScanPair;

impl JointEstimator for Joint {
    /// `joint`, as typed on the command line.
    fn name(&self) -> &str {
        "joint"
    }

    /// [`Joint::estimate`] as a [`JointEstimate`]: the same associations, clusters,
    /// motions, background and ego-motion; `iterations` are the sweeps over all rounds
    /// (one sweep is a forward-backward pass over both chains). Errors name the pair.
    fn estimate(&self, pair: &ScanPair) -> pgm_scan::Result<JointEstimate> {
        let r = Joint::estimate(self, pair)?;
        Ok(JointEstimate {
            associations: r.associations,
            clusters: r.clusters,
            motions: r.motions,
            background: r.background,
            ego_motion: r.ego_motion,
            iterations: r.sweeps,
            converged: r.converged,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pgm_datasets::sim::{simulate_pair, SimConfig};
    use pgm_scan::ParamGuard;

    #[test]
    fn the_estimate_is_the_models_result() {
        let pair = simulate_pair(&SimConfig::default().check().unwrap(), 7, 1);
        let joint = Joint::default();
        let direct = joint.estimate(&pair).unwrap();
        let through: &dyn JointEstimator = &joint;
        assert_eq!(through.name(), "joint");
        let e = through.estimate(&pair).unwrap();
        assert_eq!(e.associations, direct.associations);
        assert_eq!(e.clusters, direct.clusters);
        assert_eq!(e.motions, direct.motions);
        assert_eq!(e.ego_motion, direct.ego_motion);
        assert_eq!(e.iterations, direct.sweeps);
        assert_eq!(e.converged, direct.converged);
    }
}
