//! The consistency-based detector (CBD) of Wang, Thorpe, Hebert, Thrun and
//! Durrant-Whyte (IJRR 2007), the first baseline of the CRF-Clustering paper (section
//! V-B): static objects are consistent about free space, moving ones are not.
//!
//! 1. The ego-motion comes from the odometry prior, or from ICP
//!    ([`crate::icp`], started at the identity) when the pair has no odometry.
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

use crate::icp::{Icp, IcpParams};
use crate::{Error, Result};
use pgm_datasets::ScanPair;
use pgm_features::Pose2;

/// Parameters of [`consistency_detect`].
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

/// Where the ego-motion of [`consistency_detect`] came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EgoSource {
    /// The pair's odometry prior.
    Odometry,
    /// ICP from the identity.
    Icp,
}

/// The result of [`consistency_detect`].
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

/// Runs CBD on `pair`.
pub fn consistency_detect(
    pair: &ScanPair,
    params: &ConsistencyParams,
) -> Result<ConsistencyResult> {
    for (name, value) in [
        ("margin", params.margin),
        ("segment_gap", params.segment_gap),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(Error::InvalidParameter {
                name,
                value,
                reason: "must be a number of metres >= 0",
            });
        }
    }
    if !(0.0..1.0).contains(&params.dynamic_fraction) {
        return Err(Error::InvalidParameter {
            name: "dynamic_fraction",
            value: params.dynamic_fraction,
            reason: "must be in [0, 1)",
        });
    }
    let (ego_motion, ego_source) = match pair.odometry {
        Some(o) => (o, EgoSource::Odometry),
        None => {
            let icp = Icp::new(&pair.reference, params.icp)?;
            (
                icp.align(&pair.current, Pose2::identity())?.motion,
                EgoSource::Icp,
            )
        }
    };
    let reference = &pair.reference;
    let angles = &reference.angles;
    let m = angles.len();
    let half_step = if m > 1 {
        (angles[m - 1] - angles[0]).abs() / (m - 1) as f64 / 2.0
    } else {
        0.0
    };
    let current = &pair.current;
    let mut dynamic = vec![false; current.len()];
    for (k, d) in dynamic.iter_mut().enumerate() {
        if !current.valid[k] || m == 0 {
            continue;
        }
        let q = ego_motion.transform_point(&current.beam_point(k));
        let range = q.coords.norm();
        let bearing = q.y.atan2(q.x);
        if bearing < angles[0] - half_step || bearing > angles[m - 1] + half_step {
            continue;
        }
        // Nearest reference beam by angle (angles increase with the beam index).
        let p = angles.partition_point(|&a| a < bearing);
        let nearest = if p == 0 {
            0
        } else if p >= m || (bearing - angles[p - 1]) <= (angles[p] - bearing) {
            p.min(m) - 1
        } else {
            p
        };
        let lo = nearest.saturating_sub(params.window);
        let hi = (nearest + params.window).min(m - 1);
        let closest = (lo..=hi)
            .filter(|&b| reference.valid[b])
            .map(|b| reference.ranges[b])
            .fold(f64::INFINITY, f64::min);
        if closest.is_finite() && range < closest - params.margin {
            *d = true;
        }
    }
    let (points, beams) = current.points();
    let mut labels = vec![None; current.len()];
    let mut start = 0;
    let mut next = 1u32;
    for i in 0..=points.len() {
        let end_here = i == points.len()
            || (i > start && (points[i] - points[i - 1]).norm() > params.segment_gap);
        if !end_here || i == start {
            continue;
        }
        let seg = &beams[start..i];
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
        start = i;
    }
    Ok(ConsistencyResult {
        labels,
        dynamic,
        ego_motion,
        ego_source,
    })
}
