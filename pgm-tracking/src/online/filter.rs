//! The constant-velocity Kalman filter of a track's centre (state `[x, y, vx, vy]` in
//! the sequence frame, m and m/s), with white-noise acceleration (Y. Bar-Shalom, X. R.
//! Li, T. Kirubarajan, "Estimation with Applications to Tracking and Navigation",
//! 2001, section 6.3.2: the discretised continuous white-noise acceleration model).

use nalgebra::{Matrix2, Matrix2x4, Matrix4, Point2, Vector2, Vector4};

/// A track's state estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstantVelocity {
    /// Mean `[x, y, vx, vy]`.
    pub mean: Vector4<f64>,
    /// Covariance (4 × 4).
    pub covariance: Matrix4<f64>,
}

fn observation() -> Matrix2x4<f64> {
    Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0)
}

impl ConstantVelocity {
    /// A new track at `centre`, at rest with velocity standard deviation `speed_sigma`
    /// (m/s) per axis and position standard deviation `position_sigma` (m): a new
    /// track's velocity comes from its own later measurements only.
    pub fn new(centre: Point2<f64>, position_sigma: f64, speed_sigma: f64) -> Self {
        let (p, v) = (position_sigma * position_sigma, speed_sigma * speed_sigma);
        Self {
            mean: Vector4::new(centre.x, centre.y, 0.0, 0.0),
            covariance: Matrix4::from_diagonal(&Vector4::new(p, p, v, v)),
        }
    }

    /// The centre (m).
    pub fn centre(&self) -> Point2<f64> {
        Point2::new(self.mean[0], self.mean[1])
    }

    /// The velocity (m/s).
    pub fn velocity(&self) -> Vector2<f64> {
        Vector2::new(self.mean[2], self.mean[3])
    }

    /// The velocity's covariance (2 × 2, m²/s²).
    pub fn velocity_covariance(&self) -> Matrix2<f64> {
        self.covariance.fixed_view::<2, 2>(2, 2).into_owned()
    }

    /// Whether the speed is at least `speed` (m/s) by two standard deviations: the
    /// velocity's norm minus twice the standard deviation along its largest axis of
    /// uncertainty is at least `speed`.
    pub fn moves_faster_than(&self, speed: f64) -> bool {
        let c = self.velocity_covariance();
        let largest = c.symmetric_eigenvalues().max().max(0.0);
        self.velocity().norm() - 2.0 * largest.sqrt() >= speed
    }

    /// The position's covariance (2 × 2, m²).
    pub fn position_covariance(&self) -> Matrix2<f64> {
        self.covariance.fixed_view::<2, 2>(0, 0).into_owned()
    }

    /// Moves the estimate `dt` seconds on, with acceleration noise of spectral density
    /// `q` (m²/s³).
    pub fn predict(&mut self, dt: f64, q: f64) {
        let mut f = Matrix4::identity();
        f[(0, 2)] = dt;
        f[(1, 3)] = dt;
        let (d2, d3) = (dt * dt / 2.0, dt * dt * dt / 3.0);
        let noise = Matrix4::new(
            d3, 0.0, d2, 0.0, //
            0.0, d3, 0.0, d2, //
            d2, 0.0, dt, 0.0, //
            0.0, d2, 0.0, dt,
        ) * q;
        self.mean = f * self.mean;
        self.covariance = f * self.covariance * f.transpose() + noise;
    }

    /// The innovation covariance of a centre measurement with standard deviation
    /// `sigma` (m) per axis.
    pub fn innovation_covariance(&self, sigma: f64) -> Matrix2<f64> {
        self.position_covariance() + Matrix2::identity() * (sigma * sigma)
    }

    /// Squared Mahalanobis distance of a measured centre `z` (standard deviation
    /// `sigma`).
    pub fn mahalanobis2(&self, z: &Point2<f64>, sigma: f64) -> f64 {
        let r = z - self.centre();
        self.innovation_covariance(sigma)
            .try_inverse()
            .map_or(f64::INFINITY, |s| (r.transpose() * s * r)[0])
    }

    /// Takes in a measured centre `z` with standard deviation `sigma` (m) per axis.
    pub fn update(&mut self, z: &Point2<f64>, sigma: f64) {
        let h = observation();
        let s = self.innovation_covariance(sigma);
        let Some(s_inv) = s.try_inverse() else {
            return;
        };
        let gain = self.covariance * h.transpose() * s_inv;
        let residual = z - self.centre();
        self.mean += gain * residual;
        // Joseph form keeps the covariance symmetric and positive.
        let ikh = Matrix4::identity() - gain * h;
        self.covariance = ikh * self.covariance * ikh.transpose()
            + gain * Matrix2::identity() * (sigma * sigma) * gain.transpose();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_steady_walker_is_learned_from_its_measurements() {
        let mut f = ConstantVelocity::new(Point2::new(0.0, 0.0), 0.05, 1.0);
        let dt = 0.1;
        for n in 1..=40 {
            f.predict(dt, 1.0);
            f.update(&Point2::new(1.2 * dt * n as f64, 0.0), 0.05);
        }
        assert!((f.velocity().x - 1.2).abs() < 0.05, "{}", f.velocity());
        assert!(f.velocity().y.abs() < 0.05);
        let c = f.velocity_covariance();
        assert!(c[(0, 0)] > 0.0 && c[(0, 0)] < 1.0);
    }

    #[test]
    fn a_new_track_is_at_rest_until_measured() {
        let f = ConstantVelocity::new(Point2::new(1.0, 2.0), 0.05, 2.0);
        assert_eq!(f.velocity(), Vector2::zeros());
        assert!((f.velocity_covariance()[(1, 1)] - 4.0).abs() < 1e-12);
    }
}
