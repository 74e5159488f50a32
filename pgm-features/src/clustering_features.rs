//! The feature functions of CRF-Clustering (G. D. Tipaldi and F. Ramos, "Motion
//! Clustering and Estimation with Conditional Random Fields", section IV-B and IV-C).
//!
//! The model labels every point `s_i` of the **current** scan with a cluster `x_i`;
//! each cluster `l` has a rigid motion `m_l = (R_l, T_l)` mapping current points onto
//! their associated **reference** points `g_i` (the project convention of
//! [`pgm_scan::pose`]). A clique's log-potential is `w · f` with learned weights `w`:
//!
//! - [`distance_feature`], eq. (2): `‖T_{x_i} + R_{x_i} s_i − g_i‖²`, the local
//!   feature;
//! - [`neighbour_feature`], eq. (4): `[1, 0]` when neighbours share a cluster, `[0, 1]`
//!   otherwise; the paper's parameters `λ1`, `λ2` are the two learned weights;
//! - [`weighted_neighbour_feature`], eq. (5): the same indicators divided by the
//!   distance `Δ = ‖s_i − s_j‖` between the neighbouring points (clamped below at
//!   [`MIN_NEIGHBOUR_DISTANCE`] so that coincident points give a finite feature);
//! - [`stiffness_feature`], eq. (6): `‖(s_i − s_j) − [(T_{x_i} + R_{x_i} s_i) −
//!   (T_{x_j} + R_{x_j} s_j)]‖²`, how much the vector between the two points changes
//!   when each is moved by its cluster's motion. Eq. (6) is used as printed (the
//!   vector, not only its length). Within one cluster it is `‖(I − R)(s_i − s_j)‖²`
//!   (small for nearby points), across clusters it grows with the difference of the
//!   two motions at the points. The model learns separate weights for the equal and
//!   the different case ([`stiffness_feature`] returns the value; the caller puts it
//!   in the slot of the case).
//!
//! Besides the paper's features, [`association_variance`] and
//! [`normalised_distance_feature`] express the distance of eq. (2) in units of the
//! spacing expected between a point and a correct partner: on a surface the partner
//! lies up to about one beam spacing `r·Δθ` away, so 0.3 m at 80 m is a good match
//! for a far point while it is a poor one for a point at 5 m. CRF-Clustering uses it
//! as a second local feature and weights eq. (3) by its inverse.
//!
//! ```
//! use nalgebra::Point2;
//! use pgm_features::clustering_features::{distance_feature, stiffness_feature};
//! use pgm_scan::Pose2;
//!
//! let motion = Pose2::new(1.0, 0.0, 0.0);
//! let s = Point2::new(2.0, 0.0);
//! assert_eq!(distance_feature(&motion, &s, &Point2::new(3.0, 1.0)), 1.0);
//! // Two points moved by the same translation keep their relative vector.
//! let t = Point2::new(2.0, 1.0);
//! assert_eq!(stiffness_feature(&motion, &motion, &s, &t), 0.0);
//! ```

use nalgebra::Point2;
use pgm_scan::pose::Pose2;

/// Distances between neighbouring points below this (metres) count as this in the
/// weighted-neighbour feature (eq. 5), keeping `1/Δ` finite.
pub const MIN_NEIGHBOUR_DISTANCE: f64 = 0.01;

/// Eq. (2): squared distance between the reference point `g` and the current point
/// `s` moved by the cluster's `motion`, `‖T + R s − g‖²` (m²).
pub fn distance_feature(motion: &Pose2, s: &Point2<f64>, g: &Point2<f64>) -> f64 {
    (motion.transform_point(s) - g).norm_squared()
}

/// Noise floor (m) of [`association_variance`]: range noise and surface roughness.
pub const ASSOCIATION_NOISE: f64 = 0.05;

/// Expected squared distance (m²) between a point at `range` (m) and a correct partner
/// in a scan with `angle_increment` (rad) between beams: `σ0² + (range·Δθ)²` with
/// `σ0 =` [`ASSOCIATION_NOISE`].
pub fn association_variance(range: f64, angle_increment: f64) -> f64 {
    ASSOCIATION_NOISE * ASSOCIATION_NOISE + (range * angle_increment).powi(2)
}

/// Eq. (2) divided by the point's [`association_variance`] `variance`.
pub fn normalised_distance_feature(
    motion: &Pose2,
    s: &Point2<f64>,
    g: &Point2<f64>,
    variance: f64,
) -> f64 {
    distance_feature(motion, s, g) / variance
}

/// Eq. (4): `[1, 0]` when the two neighbours share a cluster, `[0, 1]` otherwise.
pub fn neighbour_feature(same: bool) -> [f64; 2] {
    if same {
        [1.0, 0.0]
    } else {
        [0.0, 1.0]
    }
}

/// `1/Δ` for two neighbouring current points, `Δ = max(‖s_i − s_j‖,`
/// [`MIN_NEIGHBOUR_DISTANCE`]`)`.
pub fn inverse_neighbour_distance(s_i: &Point2<f64>, s_j: &Point2<f64>) -> f64 {
    1.0 / (s_i - s_j).norm().max(MIN_NEIGHBOUR_DISTANCE)
}

/// Eq. (5): the neighbour indicators of eq. (4) divided by the distance `Δ` between
/// the neighbouring current points (see [`inverse_neighbour_distance`]).
pub fn weighted_neighbour_feature(same: bool, s_i: &Point2<f64>, s_j: &Point2<f64>) -> [f64; 2] {
    let inverse = inverse_neighbour_distance(s_i, s_j);
    let [a, b] = neighbour_feature(same);
    [a * inverse, b * inverse]
}

/// Eq. (6): `‖(s_i − s_j) − [(T_i + R_i s_i) − (T_j + R_j s_j)]‖²` with `motion_i`,
/// `motion_j` the motions of the clusters of the two points (m²).
pub fn stiffness_feature(
    motion_i: &Pose2,
    motion_j: &Pose2,
    s_i: &Point2<f64>,
    s_j: &Point2<f64>,
) -> f64 {
    let before = s_i - s_j;
    let after = motion_i.transform_point(s_i) - motion_j.transform_point(s_j);
    (before - after).norm_squared()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_values() {
        // Rotation by 90° about the origin, then translation (1, 2).
        let m = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        let s = Point2::new(1.0, 0.0);
        // R s + T = (0, 1) + (1, 2) = (1, 3); g = (0, 0) -> 1 + 9.
        assert!((distance_feature(&m, &s, &Point2::new(0.0, 0.0)) - 10.0).abs() < 1e-12);
        let t = Point2::new(0.0, 1.0);
        // Same motion: before = (1, -1); after = R(1, -1) = (1, 1); diff (0, -2) -> 4.
        assert!((stiffness_feature(&m, &m, &s, &t) - 4.0).abs() < 1e-12);
        let id = Pose2::identity();
        // Different motions: after = m(s) - t = (1, 3) - (0, 1) = (1, 2); before (1, -1)
        // -> diff (0, -3) -> 9.
        assert!((stiffness_feature(&m, &id, &s, &t) - 9.0).abs() < 1e-12);
        let w = weighted_neighbour_feature(false, &s, &Point2::new(1.0, 0.5));
        assert_eq!(w, [0.0, 2.0]);
        let w = weighted_neighbour_feature(true, &s, &s);
        assert_eq!(w, [1.0 / MIN_NEIGHBOUR_DISTANCE, 0.0]);
    }
}
