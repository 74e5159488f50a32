//! The feature functions of CRF-Matching (section IV-C.1-2 of van de Ven, Ramos and
//! Tipaldi, "An Integrated Probabilistic Model for Scan-Matching, Moving Object
//! Detection and Motion Estimation"; the original CRF-Matching paper of Ramos, Fox and
//! Durrant-Whyte is not available, so every choice the joint paper leaves open is
//! written down here).
//!
//! A point `i` of the current scan is compared with a candidate partner `j` of the
//! reference scan. Points are the scans' valid returns in beam order ([`ScanShape`]);
//! "the k-th neighbour" of a point is the k-th valid return before or after it.
//!
//! **Shape descriptors** of one point ([`ScanShape`], [`SHAPE_DESCRIPTORS`] values):
//! - *distance*: to the 1st, 3rd and 5th neighbour, before and after (6 values);
//! - *angle*: at the point, between its k-th neighbours on either side, k = 1, 3, 5
//!   (3 values, radians in `[0, π]`);
//! - *geodesic*: the length of the polyline to the 1st, 3rd and 5th neighbour, before
//!   and after (6 values; the 1st equals the distance, kept so the paper's list is
//!   complete);
//! - *radius*: the range (1 value).
//!
//! A neighbour that does not exist (a scan end) makes the descriptor missing (`NaN`).
//!
//! **Data-boosting features** of a pair `(i, j)` ([`association_features`],
//! [`ASSOCIATION_FEATURES`] values): the absolute differences of the shape descriptors
//! (the paper: "the resulting difference is an error metric"), then *translation*
//! `‖s_i − g_j‖` (as ICP, no motion), *registered translation* `‖M s_i − g_j‖`
//! under the point's current motion estimate `M` ([`REGISTERED_TRANSLATION`]), and,
//! last, *registered bearing* ([`REGISTERED_BEARING`]): the angle between the bearing
//! of `M s_i` and reference beam `j`, in beam spacings. The paper lists registered
//! translation only; its bearing part is added because the true partner is defined
//! by the surface point (the reference beam that hit nearest to it), and beam angles
//! carry no range noise: where beams are a few centimetres apart the Euclidean
//! distance mostly measures the 3 cm range noise, the bearing does not. The two
//! registered features are the only ones that depend on the motion, so a booster's
//! stumps on them are re-evaluated alone when the motion changes (see
//! [`Booster::split_by_features`](crate::boosting::Booster::split_by_features)).
//!
//! **Outlier-boosting features** of a point `i` ([`outlier_features`],
//! [`OUTLIER_FEATURES`] values): its range, the distance from `M s_i` to the nearest
//! reference return, that distance in units of the reference beam spacing at that
//! range, the *visibility margin* `|M s_i| − r(M s_i)` with `r` the range the
//! reference scan measured towards that bearing ([`Scan::range_towards`]; positive
//! behind the reference surface: occluded; negative: in front, where the reference saw
//! free space; missing outside the field of view), whether `M s_i` lies outside the
//! reference field of view, and the point's distances to its neighbours and angle
//! (points at depth discontinuities are often outliers). The paper lists no outlier
//! features; these are the evidence that decides whether the reference scan could
//! have seen the surface point.

use nalgebra::{Point2, Vector2};
use pgm_scan::pose::Pose2;
use pgm_scan::scan::Scan;

/// Neighbour orders of the shape descriptors (the paper's 1st, 3rd and 5th).
pub const NEIGHBOURS: [usize; 3] = [1, 3, 5];

/// Number of shape descriptors of one point.
pub const SHAPE_DESCRIPTORS: usize = 16;

/// Number of data-boosting features of a pair: the shape differences, translation,
/// registered translation and registered bearing.
pub const ASSOCIATION_FEATURES: usize = SHAPE_DESCRIPTORS + 3;

/// Index of the translation feature among the association features.
pub const TRANSLATION: usize = SHAPE_DESCRIPTORS;

/// Index of the registered-translation feature.
pub const REGISTERED_TRANSLATION: usize = SHAPE_DESCRIPTORS + 1;

/// Index of the registered-bearing feature (the last association feature).
pub const REGISTERED_BEARING: usize = SHAPE_DESCRIPTORS + 2;

/// The association features that depend on the motion estimate.
pub const MOTION_FEATURES: [usize; 2] = [REGISTERED_TRANSLATION, REGISTERED_BEARING];

/// Number of outlier-boosting features of a point.
pub const OUTLIER_FEATURES: usize = 8;

/// Names of the association features, in order (for reports).
pub const ASSOCIATION_FEATURE_NAMES: [&str; ASSOCIATION_FEATURES] = [
    "distance.before1",
    "distance.before3",
    "distance.before5",
    "distance.after1",
    "distance.after3",
    "distance.after5",
    "angle1",
    "angle3",
    "angle5",
    "geodesic.before1",
    "geodesic.before3",
    "geodesic.before5",
    "geodesic.after1",
    "geodesic.after3",
    "geodesic.after5",
    "radius",
    "translation",
    "registered_translation",
    "registered_bearing",
];

/// The valid returns of one scan in beam order with their shape descriptors.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanShape {
    /// The valid returns (sensor frame).
    pub points: Vec<Point2<f64>>,
    /// The valid returns with their range noise reduced
    /// ([`surface_points`](pgm_scan::scan::surface_points)): the positions the registered
    /// features, the pairwise geometry and the motion fits use.
    pub surface: Vec<Point2<f64>>,
    /// Unit normal of each surface point's line, `None` where the return keeps its
    /// measured position ([`surface_model`](pgm_scan::scan::surface_model)): the
    /// point-to-line terms of the motion fits
    /// ([`refine_point_to_line`](pgm_scan::alignment::refine_point_to_line)).
    pub normals: Vec<Option<Vector2<f64>>>,
    /// Beam index of each return.
    pub beams: Vec<usize>,
    /// Beam angle of each return (rad).
    pub angles: Vec<f64>,
    /// [`SHAPE_DESCRIPTORS`] values per return (row-major).
    pub descriptors: Vec<f64>,
}

impl ScanShape {
    /// The descriptors of every valid return of `scan`.
    pub fn new(scan: &Scan) -> Self {
        let (points, beams) = scan.points();
        let n = points.len();
        let mut descriptors = Vec::with_capacity(n * SHAPE_DESCRIPTORS);
        // Cumulative polyline length, for geodesic distances in O(1).
        let mut along = Vec::with_capacity(n);
        let mut total = 0.0;
        for i in 0..n {
            if i > 0 {
                total += (points[i] - points[i - 1]).norm();
            }
            along.push(total);
        }
        let at = |i: usize, k: usize, after: bool| -> Option<usize> {
            if after {
                (i + k < n).then_some(i + k)
            } else {
                i.checked_sub(k)
            }
        };
        for i in 0..n {
            let p = points[i];
            for after in [false, true] {
                for k in NEIGHBOURS {
                    descriptors.push(at(i, k, after).map_or(f64::NAN, |j| (points[j] - p).norm()));
                }
            }
            for k in NEIGHBOURS {
                descriptors.push(match (at(i, k, false), at(i, k, true)) {
                    (Some(a), Some(b)) => {
                        let (u, v) = (points[a] - p, points[b] - p);
                        let (nu, nv) = (u.norm(), v.norm());
                        if nu > 0.0 && nv > 0.0 {
                            (u.dot(&v) / (nu * nv)).clamp(-1.0, 1.0).acos()
                        } else {
                            f64::NAN
                        }
                    }
                    _ => f64::NAN,
                });
            }
            for after in [false, true] {
                for k in NEIGHBOURS {
                    descriptors
                        .push(at(i, k, after).map_or(f64::NAN, |j| (along[j] - along[i]).abs()));
                }
            }
            descriptors.push(p.coords.norm());
        }
        let angles = beams.iter().map(|&b| scan.angles[b]).collect();
        let (surface, normals) = pgm_scan::scan::surface_model(&points, scan.angle_increment())
            .into_iter()
            .map(|s| (s.point, s.normal))
            .unzip();
        Self {
            surface,
            normals,
            points,
            beams,
            angles,
            descriptors,
        }
    }

    /// Number of returns.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True without returns.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The descriptors of return `i`.
    pub fn descriptor(&self, i: usize) -> &[f64] {
        &self.descriptors[i * SHAPE_DESCRIPTORS..(i + 1) * SHAPE_DESCRIPTORS]
    }
}

/// The data-boosting features of current return `i` (of `current`) and reference
/// return `j` (of `reference`, whose beams are `increment` radians apart) under the
/// motion estimate `motion` of `i`, into `out` ([`ASSOCIATION_FEATURES`] values; see
/// the module docs).
pub fn association_features(
    current: &ScanShape,
    i: usize,
    reference: &ScanShape,
    j: usize,
    motion: &Pose2,
    increment: f64,
    out: &mut [f64],
) {
    let (a, b) = (current.descriptor(i), reference.descriptor(j));
    for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
        *o = (x - y).abs();
    }
    let (s, g) = (current.surface[i], reference.surface[j]);
    out[TRANSLATION] = (s - g).norm();
    let q = motion.transform_point(&s);
    out[REGISTERED_TRANSLATION] = (q - g).norm();
    out[REGISTERED_BEARING] = registered_bearing(&q, reference.angles[j], increment);
}

/// The angle between the bearing of `q` (reference frame) and the reference beam at
/// `angle`, in units of the beam spacing `increment` (rad; a spacing of 0 gives the
/// angle in radians).
#[inline]
pub fn registered_bearing(q: &Point2<f64>, angle: f64, increment: f64) -> f64 {
    bearing_offset(q.y.atan2(q.x), angle, increment)
}

/// [`registered_bearing`] from the bearing of `q` (rad), for callers that compare one
/// point with many beams.
#[inline]
pub fn bearing_offset(bearing: f64, angle: f64, increment: f64) -> f64 {
    let d = pgm_scan::pose::wrap_angle(bearing - angle).abs();
    if increment > 0.0 {
        d / increment
    } else {
        d
    }
}

/// The context the outlier features of a scan's points need: the reference scan and
/// its nearest-neighbour search.
pub trait NearestReference {
    /// The reference return nearest to `q` (reference frame) within `max_distance`:
    /// its distance (m).
    fn nearest_distance(&self, q: &Point2<f64>, max_distance: f64) -> Option<f64>;
}

impl NearestReference for pgm_scan::registration::Icp {
    fn nearest_distance(&self, q: &Point2<f64>, max_distance: f64) -> Option<f64> {
        self.nearest_reference(q, max_distance)
            .map(|(_, d2)| d2.sqrt())
    }
}

/// How far (m) the outlier features look for a nearest reference return; farther
/// counts as this far.
pub const OUTLIER_SEARCH_RADIUS: f64 = 2.0;

/// The outlier-boosting features of current return `i` under `motion`, into `out`
/// ([`OUTLIER_FEATURES`] values; see the module docs). `reference` is the reference
/// scan with its [`Scan::angle_increment`] `increment` (rad, computed once by the
/// caller), `nearest` its nearest-neighbour search.
pub fn outlier_features(
    current: &ScanShape,
    i: usize,
    reference: &Scan,
    increment: f64,
    nearest: &dyn NearestReference,
    motion: &Pose2,
    out: &mut [f64],
) {
    let s = current.points[i];
    let q = motion.transform_point(&s);
    let range = q.coords.norm();
    let near = nearest
        .nearest_distance(&q, OUTLIER_SEARCH_RADIUS)
        .unwrap_or(OUTLIER_SEARCH_RADIUS);
    let spacing = (range * increment).max(1e-3);
    let d = current.descriptor(i);
    out[0] = s.coords.norm();
    out[1] = near;
    out[2] = near / spacing;
    let measured = reference.range_towards(&q);
    out[3] = measured.map_or(f64::NAN, |r| range - r);
    out[4] = if reference.beam_near_bearing(q.y.atan2(q.x)).is_some() {
        0.0
    } else {
        1.0
    };
    out[5] = d[0];
    out[6] = d[3];
    out[7] = d[6];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptors_of_a_straight_wall() {
        // Returns on the line x = 2, 0.1 m apart: neighbour distances 0.1 k, angle π.
        let angles: Vec<f64> = (0..11)
            .map(|k| ((k as f64 - 5.0) * 0.1 / 2.0).atan())
            .collect();
        let ranges: Vec<f64> = angles.iter().map(|a| 2.0 / a.cos()).collect();
        let shape = ScanShape::new(&Scan::from_ranges(angles, ranges, 30.0));
        let d = shape.descriptor(5);
        for (m, k) in NEIGHBOURS.iter().enumerate() {
            assert!((d[m] - 0.1 * *k as f64).abs() < 1e-9, "before {k}");
            assert!((d[3 + m] - 0.1 * *k as f64).abs() < 1e-9, "after {k}");
            assert!((d[6 + m] - std::f64::consts::PI).abs() < 1e-6, "angle {k}");
            assert!((d[9 + m] - 0.1 * *k as f64).abs() < 1e-9, "geodesic {k}");
        }
        assert!((d[15] - 2.0).abs() < 1e-12);
        // The first return has no neighbour before it.
        assert!(shape.descriptor(0)[0].is_nan());
        assert!(shape.descriptor(0)[6].is_nan());
        // A return compared with itself differs only in registered translation.
        let mut f = [0.0; ASSOCIATION_FEATURES];
        association_features(
            &shape,
            4,
            &shape,
            4,
            &Pose2::new(0.5, 0.0, 0.0),
            0.05,
            &mut f,
        );
        assert!(f[..TRANSLATION].iter().all(|x| *x == 0.0 || x.is_nan()));
        assert_eq!(f[TRANSLATION], 0.0);
        assert!((f[REGISTERED_TRANSLATION] - 0.5).abs() < 1e-12);
        // Moved 0.5 m forward, the return at 2 m, 0.1 m left of the axis, is seen at
        // atan(0.1 / 2.5) instead of atan(0.1 / 2).
        let expected = ((0.1f64 / 2.0).atan() - (0.1f64 / 2.5).atan()) / 0.05;
        assert!(
            (f[REGISTERED_BEARING] - expected).abs() < 1e-9,
            "{}",
            f[REGISTERED_BEARING]
        );
    }
}
