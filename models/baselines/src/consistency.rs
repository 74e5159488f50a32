//! The consistency-based detector (CBD) of Wang, Thorpe, Hebert, Thrun and
//! Durrant-Whyte (IJRR 2007), the first baseline of the CRF-Clustering paper (section
//! V-B): static objects are consistent about free space, moving ones are not.
//!
//! 1. The ego-motion comes from the odometry prior, or from ICP
//!    ([`pgm_scan::registration`], started at the identity) when the pair has no
//!    odometry.
//! 2. Every current return is moved into the reference sensor frame with the
//!    ego-motion; at its bearing the reference scan's beams within
//!    [`ConsistencyParams::window`] beams of the nearest one are read. If the point is
//!    closer to the sensor than the nearest of their valid returns by more than
//!    [`ConsistencyParams::margin`], the reference scan saw that space free: the point
//!    is **dynamic**. Beams without a return are ignored (no return may mean free
//!    space or just a missed return); a point outside the reference field of view or
//!    with no valid beam in the window is not dynamic.
//! 3. The current scan is cut into segments at gaps larger than
//!    [`ConsistencyParams::segment_gap`]; a segment with more than
//!    [`ConsistencyParams::dynamic_fraction`] dynamic points is a moving object, each
//!    one its own cluster `1, 2, …`; everything else is background `0`.

use crate::{Error, Result};
use pgm_core::param::{InvalidParameter, ParamGuard};
use pgm_scan::methods::{MotionClusterer, MotionClustering};
use pgm_scan::registration::IcpParams;
use pgm_scan::scan::{segment_by_gap, segment_ranges};
use pgm_scan::{Pose2, ScanPair};

/// Parameters of [`ConsistencyDetector`], unchecked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConsistencyParams {
    /// How much closer (m) than the reference return a point must be to be dynamic.
    pub margin: f64,
    /// Reference beams read on either side of the nearest one.
    pub window: usize,
    /// Gap (m) between consecutive points that starts a new segment.
    pub segment_gap: f64,
    /// Fraction of dynamic points above which a segment is a moving object.
    pub dynamic_fraction: f64,
    /// ICP parameters for the ego-motion when the pair has no odometry.
    pub icp: IcpParams,
}

impl Default for ConsistencyParams {
    fn default() -> Self {
        Self {
            margin: 0.3,
            window: 1,
            segment_gap: 0.5,
            dynamic_fraction: 0.5,
            icp: IcpParams::default(),
        }
    }
}

impl ConsistencyParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        InvalidParameter::non_negative("margin", self.margin, "a number of metres >= 0")?;
        InvalidParameter::non_negative("segment_gap", self.segment_gap, "a number of metres >= 0")?;
        if !(0.0..1.0).contains(&self.dynamic_fraction) {
            return Err(InvalidParameter::new(
                "dynamic_fraction",
                self.dynamic_fraction,
                "a fraction in [0, 1)",
            )
            .into());
        }
        self.icp.check_ref()?;
        Ok(())
    }
}

pgm_core::checked_params! {
    /// The consistency-based detector with checked parameters (see the module docs).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct ConsistencyDetector(ConsistencyParams) -> Error;
}

impl MotionClusterer for ConsistencyDetector {
    fn name(&self) -> String {
        "cbd".into()
    }

    fn cluster(&self, pair: &ScanPair) -> pgm_scan::Result<MotionClustering> {
        let r = self.detect(pair)?;
        Ok(MotionClustering {
            labels: r.labels,
            motions: Vec::new(),
            ego_motion: Some(r.ego_motion),
            iterations: 0,
            converged: true,
        })
    }
}

/// Where the ego-motion of [`ConsistencyDetector::detect`] came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EgoSource {
    /// The pair's odometry prior.
    Odometry,
    /// ICP from the identity.
    Icp,
}

/// The result of [`ConsistencyDetector::detect`].
#[derive(Clone, Debug, PartialEq)]
pub struct ConsistencyResult {
    /// Per beam of the current scan: 0 static, 1, 2, … moving segments, `None` without
    /// a return.
    pub labels: Vec<Option<u32>>,
    /// Per beam of the current scan: whether the point violates free space.
    pub dynamic: Vec<bool>,
    /// The ego-motion used.
    pub ego_motion: Pose2,
    /// Where it came from.
    pub ego_source: EgoSource,
}

impl ConsistencyDetector {
    /// Runs CBD on `pair`. Errors name the pair.
    pub fn detect(&self, pair: &ScanPair) -> Result<ConsistencyResult> {
        detect(pair, &self.params).map_err(|e| match e {
            Error::Features(f) => Error::Features(f.in_pair(&pair.name)),
            other => other,
        })
    }
}

fn detect(pair: &ScanPair, params: &ConsistencyParams) -> Result<ConsistencyResult> {
    let (ego_motion, ego_source) = match pair.odometry {
        Some(o) => (o, EgoSource::Odometry),
        None => {
            let icp = params.icp.check()?.reference(&pair.reference)?;
            (
                icp.align(&pair.current, Pose2::identity())?.motion,
                EgoSource::Icp,
            )
        }
    };
    let reference = &pair.reference;
    let m = reference.len();
    let current = &pair.current;
    let mut dynamic = vec![false; current.len()];
    for (k, d) in dynamic.iter_mut().enumerate() {
        if !current.valid[k] {
            continue;
        }
        let q = ego_motion.transform_point(&current.beam_point(k));
        // Nearest reference beam by bearing (any angle order, see `Scan`).
        let Some(nearest) = reference.beam_near_bearing(q.y.atan2(q.x)) else {
            continue;
        };
        let lo = nearest.saturating_sub(params.window);
        let hi = (nearest + params.window).min(m - 1);
        let closest = (lo..=hi)
            .filter(|&b| reference.valid[b])
            .map(|b| reference.ranges[b])
            .fold(f64::INFINITY, f64::min);
        if closest.is_finite() && q.coords.norm() < closest - params.margin {
            *d = true;
        }
    }
    let (points, beams) = current.points();
    let mut labels = vec![None; current.len()];
    let mut next = 1u32;
    for range in segment_ranges(&segment_by_gap(&points, params.segment_gap)) {
        let seg = &beams[range];
        let dyn_count = seg.iter().filter(|&&b| dynamic[b]).count();
        let label = if dyn_count as f64 > params.dynamic_fraction * seg.len() as f64 {
            next += 1;
            next - 1
        } else {
            0
        };
        for &b in seg {
            labels[b] = Some(label);
        }
    }
    Ok(ConsistencyResult {
        labels,
        dynamic,
        ego_motion,
        ego_source,
    })
}
