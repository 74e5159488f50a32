//! Step 5: the ego-motion and the moving objects.
//!
//! The cluster whose motion is nearest to the odometry prior in Mahalanobis distance
//! (diagonal covariance from [`ClusteringParams::odometry_sigma`]) is the background,
//! the robot's own motion (section IV of the paper); without odometry the largest
//! cluster is. Every other cluster is a moving object when the tests of
//! [`DetectionParams`] (not in the paper, each can be switched off) accept it:
//!
//! (a) its motion moves its points on average at least
//!     [`DetectionParams::min_object_displacement`] away from where the background
//!     motion would put them, and it has at least
//!     [`DetectionParams::min_object_points`] associated points;
//! (b) the data agree: under the background motion its points lie on average at least
//!     that much farther from their partners than under their own motion (rejects
//!     clusters whose own motion merely fits the association noise of a static
//!     segment: any cluster's own fit is at least as good as the background's on its
//!     points), and the optional likelihood-ratio test
//!     ([`DetectionParams::min_object_chi2`]) passes;
//! (c) free space shows it moved ([`free_space_evidence`], tested per object after
//!     the split of step 6).
//!
//! The rest join the background.

use crate::input::ClusteringInput;
use crate::params::{ClusteringParams, DetectionParams};
use crate::BackgroundChoice;
use pgm_scan::{wrap_angle, Pose2};

/// Median of the χ² distribution with 2 degrees of freedom (`2 ln 2`).
const CHI2_2_MEDIAN: f64 = 2.0 * std::f64::consts::LN_2;

/// Number of points labelled with each of the `k` clusters.
pub fn cluster_sizes(labels: &[usize], k: usize) -> Vec<usize> {
    let mut count = vec![0usize; k];
    for &l in labels {
        if l < k {
            count[l] += 1;
        }
    }
    count
}

/// The background among the non-empty clusters (`count[l] > 0`): nearest to the
/// odometry prior in Mahalanobis distance, else the largest (lowest index on ties).
pub fn choose_background(
    params: &ClusteringParams,
    odometry: Option<Pose2>,
    motions: &[Pose2],
    count: &[usize],
) -> (usize, BackgroundChoice) {
    let candidates = (0..count.len()).filter(|&l| count[l] > 0);
    match odometry {
        Some(odo) => {
            let [sx, sy, st] = params.odometry_sigma;
            let d2 = |m: &Pose2| {
                ((m.x() - odo.x()) / sx).powi(2)
                    + ((m.y() - odo.y()) / sy).powi(2)
                    + (wrap_angle(m.theta() - odo.theta()) / st).powi(2)
            };
            let best = candidates.min_by(|&a, &b| d2(&motions[a]).total_cmp(&d2(&motions[b])));
            (best.unwrap_or(0), BackgroundChoice::Odometry)
        }
        None => {
            let best = candidates.max_by_key(|&l| (count[l], std::cmp::Reverse(l)));
            (best.unwrap_or(0), BackgroundChoice::LargestCluster)
        }
    }
}

/// Tests (a) and (b): which clusters move, and the mean displacement of each
/// cluster's points relative to the background motion (m).
pub fn moving_clusters(
    input: &ClusteringInput,
    detection: &DetectionParams,
    labels: &[usize],
    motions: &[Pose2],
    background: usize,
) -> (Vec<bool>, Vec<f64>) {
    let k = motions.len();
    let bg_motion = motions.get(background).copied().unwrap_or_default();
    let count = cluster_sizes(labels, k);
    let mut displacement = vec![0.0f64; k];
    for (i, &l) in labels.iter().enumerate() {
        if l < k {
            let s = &input.points[i];
            displacement[l] +=
                (motions[l].transform_point(s) - bg_motion.transform_point(s)).norm();
        }
    }
    // Evidence: how much farther from their partners the points are under the
    // background motion than under their own.
    let mut evidence = vec![0.0f64; k];
    let mut chi2 = vec![0.0f64; k];
    let mut associated = vec![0usize; k];
    for (i, &l) in labels.iter().enumerate() {
        if let (true, Some(g)) = (l < k, &input.partners[i]) {
            let s = &input.points[i];
            let bg = (bg_motion.transform_point(s) - g).norm();
            let own = (motions[l].transform_point(s) - g).norm();
            evidence[l] += bg - own;
            chi2[l] += (bg * bg - own * own) / input.variances[i];
            associated[l] += 1;
        }
    }
    let noise_scale = association_noise_scale(input, labels, &bg_motion, background);
    let mut moving = vec![false; k];
    for l in 0..k {
        if count[l] > 0 {
            displacement[l] /= count[l] as f64;
        }
        if associated[l] > 0 {
            evidence[l] /= associated[l] as f64;
        }
        moving[l] = l != background
            && associated[l] >= detection.min_object_points
            && displacement[l] >= detection.min_object_displacement
            && evidence[l] >= detection.min_object_displacement
            && chi2[l] >= detection.min_object_chi2 * noise_scale;
    }
    (moving, displacement)
}

/// The association noise scale of a pair: the median of `‖M_bg s_i − g_i‖² / σ_i²`
/// over the background's associated points against its expected value for a 2-D
/// Gaussian residual (the median of χ² with 2 degrees of freedom, 1.386), at least 1:
/// automatic associations are noisier than `σ_i` says.
fn association_noise_scale(
    input: &ClusteringInput,
    labels: &[usize],
    bg_motion: &Pose2,
    background: usize,
) -> f64 {
    let mut ratios: Vec<f64> = labels
        .iter()
        .enumerate()
        .filter_map(|(i, &l)| {
            let g = input.partners[i].as_ref()?;
            (l == background).then(|| {
                (bg_motion.transform_point(&input.points[i]) - g).norm_squared()
                    / input.variances[i]
            })
        })
        .collect();
    if ratios.is_empty() {
        return 1.0;
    }
    let mid = ratios.len() / 2;
    let median = *ratios.select_nth_unstable_by(mid, f64::total_cmp).1;
    (median / CHI2_2_MEDIAN).max(1.0)
}

/// Test (c), per point of a moving cluster (true elsewhere): moved by the ego-motion
/// (`ego`) the point lies where the reference scan saw free space, or its partner,
/// moved back into the current frame, lies where the current scan sees free space
/// (the object left). Without the scans (or with the test off) every point passes.
pub fn free_space_evidence(
    input: &ClusteringInput,
    detection: &DetectionParams,
    labels: &[usize],
    moving: &[bool],
    ego: Pose2,
) -> Vec<bool> {
    let k = moving.len();
    let mut free = vec![true; labels.len()];
    let (true, Some((reference, current))) = (detection.min_free_fraction > 0.0, &input.scans)
    else {
        return free;
    };
    let back = ego.inverse();
    let margin = detection.free_space_margin;
    for (i, &l) in labels.iter().enumerate() {
        if l >= k || !moving[l] {
            continue;
        }
        let forward = reference.in_free_space(&ego.transform_point(&input.points[i]), margin);
        let left = input.partners[i]
            .as_ref()
            .is_some_and(|g| current.in_free_space(&back.transform_point(g), margin));
        free[i] = forward || left;
    }
    free
}
