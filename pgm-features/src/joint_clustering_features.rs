//! The clustering chain of the joint model (section IV-C.3-4 of van de Ven, Ramos and
//! Tipaldi): a chain over the current scan's returns in beam order whose states are
//! `D` clusters, the last one the outlier cluster, with its 12 named features written
//! through the core's [`FeatureSink`]. The other `D − 1` clusters each have a rigid
//! motion `M_c`; a return's partner `g_i` is the reference return its association
//! node currently takes (`None`: the association outlier state).
//!
//! | template | weights | feature (of cluster states `a` at return `i`, `b` at `i + 1`) |
//! |---|---|---|
//! | `cluster_distance` | `squared`, `normalised` | local, on a motion cluster `c` of a return with a partner: `‖M_c s_i − g_i‖²` (m², eq. 2 of the CRF-Clustering paper) and the same over the association variance `σ_i²` |
//! | `cluster_outlier` | `bias` | local, 1 on the outlier cluster: with the distance weights, the threshold beyond which a return is better an outlier |
//! | `cluster_inlier` | `agree` | local, 1 when the cluster state and the association agree on "outlier" (the outlier cluster with the association outlier state, a motion cluster with a partner) |
//! | `cluster_sequence` | `same` | 1 when both returns are in the same motion cluster (an identity matrix) |
//! | `neighbour_weight` | `same`, `different` | `1 / ‖s_i − s_{i+1}‖` on equal and on different motion clusters (eq. 5 of the CRF-Clustering paper) |
//! | `neighbour_stiffness` | `same` | on equal motion clusters of two returns with partners, `(‖s_{i+1} − s_i‖ − ‖g_{i+1} − g_i‖)²`: the associated pairs keep their distance |
//! | `neighbour_distance` | `same`, `different` | on motion clusters `a`, `b`, `‖(s_{i+1} − s_i) − (M_b s_{i+1} − M_a s_i)‖²`: the returns keep their relative position after transformation (eq. 6 of the CRF-Clustering paper) |
//! | `cluster_pairwise_outlier` | `switch`, `stay` | a transition between the outlier cluster and a motion cluster (either way), and outlier to outlier |
//!
//! The joint paper names the templates and counts 12 clustering weights without
//! defining them; the split into weights above is this crate's reading (the
//! CRF-Clustering paper's eqs. 2 and 4-6 for the geometry, indicators for the rest).
//! `cluster_distance` and `cluster_inlier` read the return's current association as
//! evidence (the chains are linked through the motions, as the paper's Fig. 1).

use crate::clustering_features::MIN_NEIGHBOUR_DISTANCE;
use nalgebra::Point2;
use pgm_core::hybrid::chain::FeatureSink;
use pgm_scan::Pose2;

/// Index of each clustering weight, relative to the model's base index for them.
pub mod index {
    /// `cluster_distance.squared`.
    pub const DISTANCE_SQUARED: usize = 0;
    /// `cluster_distance.normalised`.
    pub const DISTANCE_NORMALISED: usize = 1;
    /// `cluster_outlier.bias`.
    pub const OUTLIER_BIAS: usize = 2;
    /// `cluster_inlier.agree`.
    pub const INLIER_AGREE: usize = 3;
    /// `cluster_sequence.same`.
    pub const SEQUENCE_SAME: usize = 4;
    /// `neighbour_weight.same`.
    pub const WEIGHT_SAME: usize = 5;
    /// `neighbour_weight.different`.
    pub const WEIGHT_DIFFERENT: usize = 6;
    /// `neighbour_stiffness.same`.
    pub const STIFFNESS_SAME: usize = 7;
    /// `neighbour_distance.same`.
    pub const DISTANCE_PAIR_SAME: usize = 8;
    /// `neighbour_distance.different`.
    pub const DISTANCE_PAIR_DIFFERENT: usize = 9;
    /// `cluster_pairwise_outlier.switch`.
    pub const OUTLIER_SWITCH: usize = 10;
    /// `cluster_pairwise_outlier.stay`.
    pub const OUTLIER_STAY: usize = 11;
}

/// Number of clustering weights.
pub const CLUSTERING_WEIGHTS: usize = 12;

/// The clustering feature templates and their features, in [`index`] order.
pub const CLUSTERING_TEMPLATES: [(&str, &[&str]); 8] = [
    ("cluster_distance", &["squared", "normalised"]),
    ("cluster_outlier", &["bias"]),
    ("cluster_inlier", &["agree"]),
    ("cluster_sequence", &["same"]),
    ("neighbour_weight", &["same", "different"]),
    ("neighbour_stiffness", &["same"]),
    ("neighbour_distance", &["same", "different"]),
    ("cluster_pairwise_outlier", &["switch", "stay"]),
];

/// Writes the local features of return `i` (point `s`, association variance
/// `variance` in m², partner `partner`) into a clustering table of `motions.len() +
/// 1` states (entry = cluster; the last is the outlier cluster), weight indices
/// `base + index::…`.
pub fn write_local<S: FeatureSink>(
    s: &Point2<f64>,
    variance: f64,
    partner: Option<&Point2<f64>>,
    motions: &[Pose2],
    base: usize,
    sink: &mut S,
) {
    let outlier = motions.len();
    if let Some(g) = partner {
        let inverse_variance = 1.0 / variance;
        for (c, m) in motions.iter().enumerate() {
            let d = (m.transform_point(s) - g).norm_squared();
            sink.add(c, base + index::DISTANCE_SQUARED, d);
            sink.add(c, base + index::DISTANCE_NORMALISED, d * inverse_variance);
            sink.add(c, base + index::INLIER_AGREE, 1.0);
        }
    } else {
        sink.add(outlier, base + index::INLIER_AGREE, 1.0);
    }
    sink.add(outlier, base + index::OUTLIER_BIAS, 1.0);
}

/// Writes the features of the pair of returns `(i, i + 1)` at `s` (two points), with
/// partners `partners` (each `None` for the association outlier state), into a
/// dense `D × D` clustering table (`D = motions.len() + 1`; entry `a · D + b`).
///
/// # Panics
/// With more than [`MAX_MOTION_CLUSTERS`] motions.
pub fn write_pair<S: FeatureSink>(
    s: [&Point2<f64>; 2],
    partners: [Option<&Point2<f64>>; 2],
    motions: &[Pose2],
    base: usize,
    sink: &mut S,
) {
    let k = motions.len();
    assert!(
        k <= MAX_MOTION_CLUSTERS,
        "{k} motion clusters (at most {MAX_MOTION_CLUSTERS})"
    );
    let states = k + 1;
    let before = s[1] - s[0];
    let inverse_distance = 1.0 / before.norm().max(MIN_NEIGHBOUR_DISTANCE);
    let stiffness = match partners {
        [Some(g0), Some(g1)] => Some((before.norm() - (g1 - g0).norm()).powi(2)),
        _ => None,
    };
    // Each return moved by each motion cluster.
    let mut moved = [[Point2::origin(); 2]; MAX_MOTION_CLUSTERS];
    for (c, m) in motions.iter().enumerate() {
        moved[c] = [m.transform_point(s[0]), m.transform_point(s[1])];
    }
    for a in 0..states {
        for b in 0..states {
            let entry = a * states + b;
            if a == k || b == k {
                let feature = if a == b {
                    index::OUTLIER_STAY
                } else {
                    index::OUTLIER_SWITCH
                };
                sink.add(entry, base + feature, 1.0);
                continue;
            }
            let shape = (before - (moved[b][1] - moved[a][0])).norm_squared();
            if a == b {
                sink.add(entry, base + index::SEQUENCE_SAME, 1.0);
                sink.add(entry, base + index::WEIGHT_SAME, inverse_distance);
                if let Some(x) = stiffness {
                    sink.add(entry, base + index::STIFFNESS_SAME, x);
                }
                sink.add(entry, base + index::DISTANCE_PAIR_SAME, shape);
            } else {
                sink.add(entry, base + index::WEIGHT_DIFFERENT, inverse_distance);
                sink.add(entry, base + index::DISTANCE_PAIR_DIFFERENT, shape);
            }
        }
    }
}

/// Most motion clusters [`write_pair`] handles (the outlier cluster not counted).
pub const MAX_MOTION_CLUSTERS: usize = 31;
