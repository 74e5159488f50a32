//! Rigid motions of the plane, SE(2), on top of [`nalgebra::Isometry2`].
//!
//! Convention used everywhere in this project: a motion `m` of a cluster (the paper's
//! rotation `R` and translation `T`, eq. 2-3 of the CRF-Clustering paper) maps a point
//! of the **current** scan `s_i` onto its partner in the **reference** scan `g_i`:
//! `g_i ≈ R s_i + T = m * s_i`. For the static background that motion is the pose of
//! the current sensor frame expressed in the reference sensor frame, the ego-motion.

use nalgebra::{Isometry2, Point2, Vector2};
use serde::{Deserialize, Serialize};

/// A rigid motion of the plane (rotation `theta` in radians, then translation `x`, `y`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "PoseRecord", into = "PoseRecord")]
pub struct Pose2 {
    iso: Isometry2<f64>,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseRecord {
    x: f64,
    y: f64,
    theta: f64,
}

/// Largest magnitude of a heading read from a file (rad), as the log readers'
/// `pgm_datasets::error::limits::MAX_HEADING`: a stored heading of 1e300 rad would be
/// normalised into some angle in (−π, π] that means nothing.
pub const MAX_STORED_HEADING: f64 = 1e6;

impl TryFrom<PoseRecord> for Pose2 {
    type Error = String;

    fn try_from(r: PoseRecord) -> Result<Self, String> {
        if !(r.x.is_finite() && r.y.is_finite() && r.theta.is_finite()) {
            return Err(format!(
                "pose ({:?}, {:?}, {:?}) is not finite",
                r.x, r.y, r.theta
            ));
        }
        if r.theta.abs() > MAX_STORED_HEADING {
            return Err(format!(
                "heading `theta` = {:?} rad: a heading of magnitude above {MAX_STORED_HEADING:e} \
                 rad means nothing here",
                r.theta
            ));
        }
        Ok(Pose2::new(r.x, r.y, r.theta))
    }
}

impl From<Pose2> for PoseRecord {
    fn from(p: Pose2) -> Self {
        PoseRecord {
            x: p.x(),
            y: p.y(),
            theta: p.theta(),
        }
    }
}

impl Default for Pose2 {
    fn default() -> Self {
        Self::identity()
    }
}

impl Pose2 {
    /// The pose with translation `(x, y)` and heading `theta` (radians).
    pub fn new(x: f64, y: f64, theta: f64) -> Self {
        Self {
            iso: Isometry2::new(Vector2::new(x, y), theta),
        }
    }

    /// The identity motion.
    pub fn identity() -> Self {
        Self {
            iso: Isometry2::identity(),
        }
    }

    /// Wraps an [`Isometry2`], renormalising its rotation when its length has
    /// drifted from 1 by more than 1e-12 (an isometry built with
    /// `UnitComplex::new_unchecked`, or accumulated over a long chain). Within that
    /// the rotation is kept to the bit, so results do not change with it.
    pub fn from_isometry(mut iso: Isometry2<f64>) -> Self {
        if (iso.rotation.complex().norm_sqr() - 1.0).abs() > 1e-12 {
            iso.rotation.renormalize();
        }
        Self { iso }
    }

    /// The underlying [`Isometry2`].
    pub fn isometry(&self) -> &Isometry2<f64> {
        &self.iso
    }

    /// Translation along x.
    pub fn x(&self) -> f64 {
        self.iso.translation.vector.x
    }

    /// Translation along y.
    pub fn y(&self) -> f64 {
        self.iso.translation.vector.y
    }

    /// Rotation angle in radians, in (-π, π].
    pub fn theta(&self) -> f64 {
        self.iso.rotation.angle()
    }

    /// The translation as a vector (the paper's `T`).
    pub fn translation(&self) -> Vector2<f64> {
        self.iso.translation.vector
    }

    /// Composition `self ∘ other` (apply `other` first). The rotation is
    /// renormalised, so that a long chain of compositions (odometry integrated over a
    /// log, a track's motion over a sequence) stays a rotation.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        Pose2::from_isometry(self.iso * other.iso)
    }

    /// The inverse motion.
    pub fn inverse(&self) -> Pose2 {
        Pose2 {
            iso: self.iso.inverse(),
        }
    }

    /// `inverse(self) ∘ other`: `other` expressed in the frame of `self`.
    pub fn between(&self, other: &Pose2) -> Pose2 {
        self.inverse().compose(other)
    }

    /// Applies the motion to a point (`R p + T`).
    pub fn transform_point(&self, p: &Point2<f64>) -> Point2<f64> {
        self.iso.transform_point(p)
    }

    /// Euclidean norm of the translation difference to `other`, in metres.
    pub fn translation_error(&self, other: &Pose2) -> f64 {
        (self.translation() - other.translation()).norm()
    }

    /// Absolute rotation difference to `other`, wrapped to [0, π].
    pub fn rotation_error(&self, other: &Pose2) -> f64 {
        wrap_angle(self.theta() - other.theta()).abs()
    }

    /// True when all three parameters are finite.
    pub fn is_finite(&self) -> bool {
        self.x().is_finite() && self.y().is_finite() && self.theta().is_finite()
    }
}

/// Wraps an angle to (-π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut r = a % two_pi;
    if r <= -std::f64::consts::PI {
        r += two_pi;
    } else if r > std::f64::consts::PI {
        r -= two_pi;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_chain_of_compositions_stays_a_rotation() {
        let step = Pose2::new(0.01, -0.002, 0.0123);
        let mut pose = Pose2::identity();
        for _ in 0..1_000_000 {
            pose = pose.compose(&step);
        }
        let norm = pose.isometry().rotation.complex().norm();
        assert!((norm - 1.0).abs() < 1e-12, "|rotation| = {norm}");
        let expected = (0.0123f64 * 1e6).sin().atan2((0.0123f64 * 1e6).cos());
        assert!(
            (pose.theta() - expected).abs() < 1e-6,
            "{} vs {expected}",
            pose.theta()
        );
        let stretched = Isometry2::from_parts(
            nalgebra::Translation2::new(1.0, 2.0),
            nalgebra::UnitComplex::new_unchecked(nalgebra::Complex::new(3.0, 4.0)),
        );
        let p = Pose2::from_isometry(stretched);
        assert!((p.isometry().rotation.complex().norm() - 1.0).abs() < 1e-15);
        assert!((p.theta() - 4f64.atan2(3.0)).abs() < 1e-15);
    }

    #[test]
    fn compose_then_inverse_is_identity() {
        let a = Pose2::new(1.0, -2.0, 0.7);
        let b = Pose2::new(-0.3, 0.5, -2.9);
        let c = a.compose(&b);
        let back = a.between(&c);
        assert!(back.translation_error(&b) < 1e-12);
        assert!(back.rotation_error(&b) < 1e-12);
    }

    #[test]
    fn wrap_angle_range() {
        assert!((wrap_angle(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
        assert!((wrap_angle(-0.5) + 0.5).abs() < 1e-15);
    }
}
