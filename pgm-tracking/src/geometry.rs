//! The geometry the steps share: time order, the pair of two consecutive current
//! scans, and the gated shift that refines a track's predicted position.

#[allow(unused_imports)]
use super::*;
use nalgebra::{Point2, Vector2};
use pgm_scan::pair::ScanPair;
use pgm_scan::registration::{Icp, IcpParams};
use pgm_scan::Pose2;

/// The indices of `pairs` in the order the tracker takes them: by the time stamp of
/// their current scan (a stable sort: equal stamps keep their order).
pub fn time_order(pairs: &[ScanPair]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..pairs.len()).collect();
    order.sort_by(|&a, &b| {
        pairs[a]
            .current
            .timestamp
            .total_cmp(&pairs[b].current.timestamp)
    });
    order
}

/// The pair of two consecutive current scans (`before`'s as reference), with the
/// motion of the later in the frame of the earlier as its odometry: ICP (`icp`) from
/// their odometry difference (the identity without odometry), without the returns
/// labelled moving in `moving_before` (the earlier scan) and `moving_now` (the later);
/// the prior when ICP does not converge.
pub(crate) fn consecutive_pair(
    before: &ScanPair,
    now: &ScanPair,
    moving_before: Option<&[Option<u32>]>,
    moving_now: &[Option<u32>],
    icp: &IcpParams,
) -> ScanPair {
    let prior = match (
        before.current.laser_odometry(),
        now.current.laser_odometry(),
    ) {
        (Some(a), Some(b)) => a.between(&b),
        _ => Pose2::identity(),
    };
    let reference = without_moving(&before.current, moving_before);
    let current = without_moving(&now.current, Some(moving_now));
    let motion = Icp::new(&reference, *icp)
        .and_then(|icp| icp.align(&current, prior))
        .ok()
        .filter(|r| r.converged)
        .map_or(prior, |r| r.motion);
    ScanPair {
        name: format!("{} (after {})", now.name, before.name),
        reference: before.current.clone(),
        current: now.current.clone(),
        odometry: Some(motion),
        truth: None,
    }
}

/// `scan` without the returns labelled moving (label above 0) in `labels` (one per
/// beam), when given.
pub(crate) fn without_moving(
    scan: &pgm_scan::Scan,
    labels: Option<&[Option<u32>]>,
) -> pgm_scan::Scan {
    let mut kept = scan.clone();
    if let Some(labels) = labels {
        for (valid, label) in kept.valid.iter_mut().zip(labels) {
            if label.is_some_and(|l| l > 0) {
                *valid = false;
            }
        }
    }
    kept
}

/// A rigid motion scaled by `factor` (translation and angle; exact for pure
/// translations, first order in the angle otherwise).
pub(crate) fn scale(motion: &Pose2, factor: f64) -> Pose2 {
    Pose2::new(
        motion.x() * factor,
        motion.y() * factor,
        motion.theta() * factor,
    )
}

pub(crate) fn centroid(points: &[Point2<f64>]) -> Point2<f64> {
    let sum = points.iter().fold(Vector2::zeros(), |a, p| a + p.coords);
    Point2::from(sum / points.len().max(1) as f64)
}

/// Translation-only ICP of `predicted` onto the returns `candidates` (indices into
/// `points`): the shift that brings the predicted returns onto them (a small object's
/// rotation over one scan is not observable from its few returns; the velocity keeps
/// the rotation it was born with). The correspondence distance shrinks from `gate` to
/// `inlier`.
pub(crate) fn refine(
    predicted: &[Point2<f64>],
    points: &[Point2<f64>],
    candidates: &[usize],
    gate: f64,
    inlier: f64,
) -> Vector2<f64> {
    let mut shift = Vector2::zeros();
    let mut distance = gate;
    for _ in 0..30 {
        let mut sum = Vector2::zeros();
        let mut pairs = 0;
        for q in predicted {
            let q = q + shift;
            let nearest = candidates
                .iter()
                .map(|&k| points[k] - q)
                .min_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()));
            if let Some(d) = nearest.filter(|d| d.norm() <= distance) {
                sum += d;
                pairs += 1;
            }
        }
        if pairs == 0 {
            break;
        }
        let delta = sum / pairs as f64;
        shift += delta;
        if delta.norm() < 1e-4 && distance <= inlier {
            break;
        }
        distance = (distance * 0.7).max(inlier);
    }
    shift
}
