//! Step 1: the points of one pair as the model sees them.

use crate::{Error, Result};
use nalgebra::Point2;
use pgm_core::param::InvalidParameter;
use pgm_features::clustering_features::association_variance;
use pgm_scan::{Association, PointAssociations, Pose2, Scan, ScanPair};

/// The points of one pair as the model sees them.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusteringInput {
    /// Beam index of each point in the current scan.
    pub beams: Vec<usize>,
    /// Number of beams of the current scan.
    pub beam_count: usize,
    /// The valid points `s_i` of the current scan, in beam order (sensor frame).
    pub points: Vec<Point2<f64>>,
    /// The associated reference point `g_i` of each point (reference sensor frame).
    pub partners: Vec<Option<Point2<f64>>>,
    /// Expected squared distance to a correct partner of each point
    /// ([`association_variance`] of its range and the scan's beam spacing).
    pub variances: Vec<f64>,
    /// Odometry prior on the ego-motion, if any.
    pub odometry: Option<Pose2>,
    /// The reference and current scans, for the free-space test of moving clusters
    /// ([`crate::DetectionParams::min_free_fraction`]); `None` skips the test.
    pub scans: Option<(Scan, Scan)>,
    /// The ego-motion the association source estimated from the whole scans (ICP), if
    /// any. The free-space test runs under it: fitted to every return, it is a steadier
    /// reference than the background cluster's motion, which rests on that cluster's
    /// nearest-neighbour partners only. `None`: the background cluster's motion.
    pub ego_motion: Option<Pose2>,
}

impl ClusteringInput {
    /// The input of `pair` with `associations` (one per current beam).
    ///
    /// # Errors
    /// When the associations do not fit the current scan or name a reference beam
    /// without a return; the error names the pair.
    pub fn from_pair(pair: &ScanPair, associations: &PointAssociations) -> Result<Self> {
        let a = &associations.associations;
        if a.len() != pair.current.len() {
            return Err(Error::Features(pgm_scan::Error::AssociationCount {
                pair: pair.name.clone(),
                associations: a.len(),
                beams: pair.current.len(),
            }));
        }
        let (points, beams) = pair.current.points();
        let increment = pair.current.angle_increment();
        let variances = beams
            .iter()
            .map(|&k| association_variance(pair.current.ranges[k], increment))
            .collect();
        let mut partners = Vec::with_capacity(points.len());
        for &k in &beams {
            partners.push(match a[k] {
                Some(Association::Point(r)) => {
                    if r >= pair.reference.len() || !pair.reference.valid[r] {
                        return Err(Error::BadPair {
                            pair: pair.name.clone(),
                            problem: format!(
                                "association of current beam {k} names reference beam {r}, \
                                 which has no return"
                            ),
                        });
                    }
                    Some(pair.reference.beam_point(r))
                }
                _ => None,
            });
        }
        Ok(Self {
            beams,
            beam_count: pair.current.len(),
            points,
            partners,
            variances,
            odometry: pair.odometry,
            scans: Some((pair.reference.clone(), pair.current.clone())),
            ego_motion: associations.ego_motion,
        })
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Checks that the arrays agree: one partner, one positive finite variance and one
    /// beam index (below the beam count) per point.
    pub fn check(&self) -> Result<()> {
        let n = self.points.len();
        if self.partners.len() != n
            || self.beams.len() != n
            || self.variances.len() != n
            || self.variances.iter().any(|v| !(v.is_finite() && *v > 0.0))
            || self.beams.iter().any(|&b| b >= self.beam_count)
        {
            return Err(InvalidParameter::new(
                "clustering input",
                format!(
                    "{} points, {} partners, {} variances, {} beam indices for {} beams",
                    n,
                    self.partners.len(),
                    self.variances.len(),
                    self.beams.len(),
                    self.beam_count
                ),
                "one partner, one positive variance and one beam index (< beam count) per point",
            )
            .into());
        }
        Ok(())
    }
}
