//! Point associations: which reference point each current point corresponds to.
//!
//! CRF-Clustering takes the associations as an input (section IV-B: the distance
//! feature compares a current point, moved by its cluster's motion, with its
//! *associated* reference point). The paper runs it with the true, hand-made
//! associations (CRF-T) and with associations from CRF-Matching (CRF-M). Here a source
//! is anything implementing [`AssociationProvider`]; [`AssociationSource`] gives the
//! two built-in ones:
//!
//! - [`AssociationSource::GroundTruth`]: the pair's `truth.associations` (the
//!   simulator has them; real logs do not);
//! - [`AssociationSource::NearestAfterIcp`]: point-to-point ICP
//!   ([`pgm_baselines::icp`]) estimates the ego-motion from the odometry prior (the
//!   identity without odometry), then every current point, moved by that ego-motion,
//!   takes its nearest reference return within a gate ([`NearestParams::gate`]) as
//!   partner, or is an outlier. Static points then get a partner on the same surface,
//!   and points of an object that moved by less than the gate usually get a partner
//!   on the object's earlier position, so its motion shows in the distance feature.
//!   A point the reference scan cannot have seen is an outlier whatever its nearest
//!   neighbour: moved into the reference frame it lies outside the reference field of
//!   view, where the reference beams near its bearing have no return, or more than
//!   [`NearestParams::occlusion_margin`] behind the nearest of their returns (an
//!   occluded, newly revealed surface). Without this check such surfaces take a far
//!   partner and look like moving objects.
//!
//! A third source (CRF-Matching) plugs in by implementing [`AssociationProvider`].
//!
//! **Points without a partner** (outliers, or `None` entries) stay variables of the
//! chain: their distance feature is zero for every cluster (no evidence), so their
//! neighbours decide their cluster; with the optional outlier state
//! ([`crate::ClusteringParams::outlier_distance`]) they prefer that state instead.

use crate::{Error, Result};
use pgm_baselines::icp::{Icp, IcpParams};
use pgm_datasets::{Association, ScanPair};
use pgm_features::Pose2;

/// The associations of one pair and, when the source estimated one, its ego-motion.
#[derive(Clone, Debug, PartialEq)]
pub struct PointAssociations {
    /// One entry per beam of the current scan: `None` for beams without a return (or
    /// unknown), otherwise a reference beam or [`Association::Outlier`].
    pub associations: Vec<Option<Association>>,
    /// The ego-motion the source estimated on the way (ICP), if any.
    pub ego_motion: Option<Pose2>,
}

/// A source of point associations for scan pairs.
pub trait AssociationProvider: Send + Sync {
    /// A short name for reports (`true`, `icp`, …).
    fn name(&self) -> &str;

    /// The associations of `pair`'s current scan into its reference scan.
    fn associate(&self, pair: &ScanPair) -> Result<PointAssociations>;
}

/// Parameters of [`AssociationSource::NearestAfterIcp`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearestParams {
    /// ICP parameters for the ego-motion.
    pub icp: IcpParams,
    /// Largest distance (m) between a current point moved by the ego-motion and its
    /// nearest reference return for the two to be associated (default 1 m).
    pub gate: f64,
    /// How far (m) behind the reference returns near its bearing a point may lie and
    /// still count as seen by the reference scan (default 0.3 m).
    pub occlusion_margin: f64,
}

impl Default for NearestParams {
    fn default() -> Self {
        Self {
            icp: IcpParams::default(),
            gate: 1.0,
            occlusion_margin: 0.3,
        }
    }
}

/// The built-in association sources.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AssociationSource {
    /// The pair's ground-truth associations (error when the pair has none).
    GroundTruth,
    /// Nearest reference return within a gate after ICP (see the module docs).
    NearestAfterIcp(NearestParams),
}

impl AssociationProvider for AssociationSource {
    fn name(&self) -> &str {
        match self {
            AssociationSource::GroundTruth => "true",
            AssociationSource::NearestAfterIcp(_) => "icp",
        }
    }

    fn associate(&self, pair: &ScanPair) -> Result<PointAssociations> {
        match self {
            AssociationSource::GroundTruth => {
                let truth = pair
                    .truth
                    .as_ref()
                    .and_then(|t| t.associations.clone())
                    .ok_or_else(|| Error::BadPair {
                        pair: pair.name.clone(),
                        problem: "no ground-truth associations (use ICP associations)".into(),
                    })?;
                if truth.len() != pair.current.len() {
                    return Err(Error::AssociationCount {
                        pair: pair.name.clone(),
                        associations: truth.len(),
                        beams: pair.current.len(),
                    });
                }
                Ok(PointAssociations {
                    associations: truth,
                    ego_motion: None,
                })
            }
            AssociationSource::NearestAfterIcp(params) => nearest_after_icp(pair, params),
        }
    }
}

/// Whether a point `q` in the frame of `scan` can have been seen by it: inside the
/// field of view, some return among the beams next to its bearing (±1), and not more
/// than `margin` behind the nearest of them.
pub fn seen_by(scan: &pgm_features::Scan, q: &nalgebra::Point2<f64>, margin: f64) -> bool {
    let angles = &scan.angles;
    let m = angles.len();
    if m == 0 {
        return false;
    }
    let half_step = if m > 1 {
        (angles[m - 1] - angles[0]).abs() / (m - 1) as f64 / 2.0
    } else {
        0.0
    };
    let bearing = q.y.atan2(q.x);
    if bearing < angles[0] - half_step || bearing > angles[m - 1] + half_step {
        return false;
    }
    let p = angles.partition_point(|&a| a < bearing);
    let nearest = if p == 0 {
        0
    } else if p >= m || (bearing - angles[p - 1]) <= (angles[p] - bearing) {
        p.min(m) - 1
    } else {
        p
    };
    let closest = (nearest.saturating_sub(1)..=(nearest + 1).min(m - 1))
        .filter(|&b| scan.valid[b])
        .map(|b| scan.ranges[b])
        .fold(f64::INFINITY, f64::min);
    closest.is_finite() && q.coords.norm() <= closest + margin
}

/// [`AssociationSource::NearestAfterIcp`] on one pair.
pub fn nearest_after_icp(pair: &ScanPair, params: &NearestParams) -> Result<PointAssociations> {
    if !(params.occlusion_margin.is_finite() && params.occlusion_margin >= 0.0) {
        return Err(Error::InvalidParameter {
            name: "occlusion margin",
            value: params.occlusion_margin.to_string(),
            expected: "a number of metres >= 0",
        });
    }
    if !(params.gate.is_finite() && params.gate > 0.0) {
        return Err(Error::InvalidParameter {
            name: "association gate",
            value: params.gate.to_string(),
            expected: "a positive number of metres",
        });
    }
    let icp = Icp::new(&pair.reference, params.icp)?;
    let ego = icp
        .align(&pair.current, pair.odometry.unwrap_or_default())?
        .motion;
    let associations = (0..pair.current.len())
        .map(|k| {
            if !pair.current.valid[k] {
                return None;
            }
            let q = ego.transform_point(&pair.current.beam_point(k));
            if !seen_by(&pair.reference, &q, params.occlusion_margin) {
                return Some(Association::Outlier);
            }
            Some(match icp.nearest_reference(&q, params.gate) {
                Some((beam, _)) => Association::Point(beam),
                None => Association::Outlier,
            })
        })
        .collect();
    Ok(PointAssociations {
        associations,
        ego_motion: Some(ego),
    })
}
