//! One 2D laser scan, whatever log it came from, and its conversion to points.
//!
//! Beams are kept in beam order (the chain order of both papers' CRFs); beams without a
//! return stay in the scan, marked invalid, so beam indices are stable identifiers of
//! points across readers, ground truth and models.

use crate::pose::Pose2;
use nalgebra::Point2;
use serde::{Deserialize, Serialize};

/// A 2D laser scan in its own sensor frame (x forward, y left).
///
/// Invariants (checked by [`Scan::validate`], guaranteed by every reader in
/// `pgm-datasets`): `angles`, `ranges` and `valid` have the same length; every valid
/// beam has a finite range in `(0, max_range)`; ranges of invalid beams are finite
/// (readers store `0.0` for `nan`/`inf` raw values) and carry no meaning.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scan {
    /// Time stamp in seconds (the log's own clock).
    pub timestamp: f64,
    /// Beam angles in radians, in the sensor frame, one per beam.
    pub angles: Vec<f64>,
    /// Measured ranges in metres, one per beam.
    pub ranges: Vec<f64>,
    /// Whether each beam is a valid return.
    pub valid: Vec<bool>,
    /// Maximum range of the sensor in metres.
    pub max_range: f64,
    /// Odometry pose of the robot base in the odometry frame at this scan, if the log has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub odometry: Option<Pose2>,
    /// Pose of the laser on the robot base (identity when the laser sits at the base origin).
    #[serde(default)]
    pub laser_offset: Pose2,
}

impl Scan {
    /// Number of beams (valid or not).
    pub fn len(&self) -> usize {
        self.ranges.len()
    }

    /// True when the scan has no beams.
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// Number of valid returns.
    pub fn valid_count(&self) -> usize {
        self.valid.iter().filter(|v| **v).count()
    }

    /// The endpoint of beam `k` in the sensor frame (whether or not it is valid).
    pub fn beam_point(&self, k: usize) -> Point2<f64> {
        let (s, c) = self.angles[k].sin_cos();
        Point2::new(self.ranges[k] * c, self.ranges[k] * s)
    }

    /// Endpoints of the valid beams, in beam order, with their beam indices.
    pub fn points(&self) -> (Vec<Point2<f64>>, Vec<usize>) {
        let mut pts = Vec::with_capacity(self.len());
        let mut idx = Vec::with_capacity(self.len());
        for k in 0..self.len() {
            if self.valid[k] {
                pts.push(self.beam_point(k));
                idx.push(k);
            }
        }
        (pts, idx)
    }

    /// Pose of the laser in the odometry frame (`odometry ∘ laser_offset`), if odometry exists.
    pub fn laser_odometry(&self) -> Option<Pose2> {
        self.odometry.map(|o| o.compose(&self.laser_offset))
    }

    /// Checks the invariants above; returns a description of the first violation.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.ranges.len();
        if self.angles.len() != n || self.valid.len() != n {
            return Err(format!(
                "beam arrays differ in length: {} angles, {} ranges, {} validity flags",
                self.angles.len(),
                n,
                self.valid.len()
            ));
        }
        if !(self.max_range.is_finite() && self.max_range > 0.0) {
            return Err(format!(
                "max_range {} is not a positive finite number",
                self.max_range
            ));
        }
        if !self.timestamp.is_finite() {
            return Err(format!("timestamp {} is not finite", self.timestamp));
        }
        for k in 0..n {
            if !self.angles[k].is_finite() {
                return Err(format!("beam {k}: angle {} is not finite", self.angles[k]));
            }
            if !self.ranges[k].is_finite() {
                return Err(format!("beam {k}: range {} is not finite", self.ranges[k]));
            }
            if self.valid[k] && !(self.ranges[k] > 0.0 && self.ranges[k] < self.max_range) {
                return Err(format!(
                    "beam {k}: valid return with range {} outside (0, {})",
                    self.ranges[k], self.max_range
                ));
            }
        }
        if let Some(o) = &self.odometry {
            if !o.is_finite() {
                return Err("odometry pose is not finite".into());
            }
        }
        Ok(())
    }
}
