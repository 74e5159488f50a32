//! Property tests of the closed-form weighted rigid alignment (eq. 3 of CRF-Clustering).

use nalgebra::Point2;
use pgm_scan::{Pose2, RigidAlignment};
use proptest::prelude::*;

type RawPair = ((f64, f64), (f64, f64), f64);
type PointPair = (Point2<f64>, Point2<f64>, f64);

fn to_points(v: &[RawPair]) -> Vec<PointPair> {
    v.iter()
        .map(|((a, b), (c, d), w)| (Point2::new(*a, *b), Point2::new(*c, *d), *w))
        .collect()
}

fn point() -> impl Strategy<Value = (f64, f64)> {
    (-30.0..30.0f64, -30.0..30.0f64)
}

fn motion() -> impl Strategy<Value = Pose2> {
    (-10.0..10.0f64, -10.0..10.0f64, -3.1..3.1f64).prop_map(|(x, y, t)| Pose2::new(x, y, t))
}

/// Points with a spread: at least two points at least 0.5 m apart.
fn spread_points() -> impl Strategy<Value = Vec<((f64, f64), f64)>> {
    prop::collection::vec((point(), 0.05..5.0f64), 2..60).prop_filter("points spread", |v| {
        let (a, _) = v[0];
        v.iter().any(|((x, y), _)| (x - a.0).hypot(y - a.1) > 0.5)
    })
}

proptest! {
    #[test]
    fn recovers_a_rigid_motion_from_noiseless_points(truth in motion(), pts in spread_points()) {
        let mut stats = RigidAlignment::new();
        for ((x, y), w) in &pts {
            let s = Point2::new(*x, *y);
            stats.add(&s, &truth.transform_point(&s), *w);
        }
        let a = stats.solve().expect("non-empty");
        prop_assert!(!a.degenerate);
        prop_assert!(a.motion.translation_error(&truth) < 1e-8, "{:?} vs {:?}", a.motion, truth);
        prop_assert!(a.motion.rotation_error(&truth) < 1e-10);
        prop_assert!(a.residual < 1e-6);
        prop_assert_eq!(a.count, pts.len());
    }

    #[test]
    fn add_then_remove_equals_never_added(
        truth in motion(),
        kept in spread_points(),
        extra in prop::collection::vec((point(), point(), 0.0..100.0f64), 1..30),
    ) {
        let mut reference = RigidAlignment::new();
        let mut churned = RigidAlignment::new();
        // Interleave: extra pairs (with arbitrary, inconsistent partners) go in first,
        // so they also define the internal origin of `churned`.
        for ((sx, sy), (gx, gy), w) in &extra {
            churned.add(&Point2::new(*sx, *sy), &Point2::new(*gx, *gy), *w);
        }
        for ((x, y), w) in &kept {
            let s = Point2::new(*x, *y);
            let g = truth.transform_point(&s);
            reference.add(&s, &g, *w);
            churned.add(&s, &g, *w);
        }
        for ((sx, sy), (gx, gy), w) in &extra {
            churned.remove(&Point2::new(*sx, *sy), &Point2::new(*gx, *gy), *w);
        }
        let a = reference.solve().expect("non-empty");
        let b = churned.solve().expect("non-empty");
        prop_assert_eq!(a.count, b.count);
        prop_assert!((a.weight - b.weight).abs() < 1e-9 * a.weight.max(1.0));
        prop_assert!(a.motion.translation_error(&b.motion) < 1e-6, "{:?} vs {:?}", a.motion, b.motion);
        prop_assert!(a.motion.rotation_error(&b.motion) < 1e-8);
        prop_assert!(b.motion.translation_error(&truth) < 1e-6);
    }

    #[test]
    fn merge_equals_adding_everything(
        first in prop::collection::vec((point(), point(), 0.1..3.0f64), 1..20),
        second in prop::collection::vec((point(), point(), 0.1..3.0f64), 1..20),
    ) {
        let (p1, p2) = (to_points(&first), to_points(&second));
        let mut all = RigidAlignment::from_pairs(p1.iter().chain(&p2).map(|(s, g, w)| (s, g, *w)));
        let mut merged = RigidAlignment::from_pairs(p1.iter().map(|(s, g, w)| (s, g, *w)));
        merged.merge(&RigidAlignment::from_pairs(p2.iter().map(|(s, g, w)| (s, g, *w))));
        let (a, b) = (all.solve().unwrap(), merged.solve().unwrap());
        prop_assert!(a.motion.translation_error(&b.motion) < 1e-7);
        prop_assert!(a.motion.rotation_error(&b.motion) < 1e-9);
        prop_assert!((a.residual - b.residual).abs() < 1e-6 * a.residual.max(1.0));
        all.clear();
        prop_assert!(all.is_empty());
    }
}

#[test]
fn residual_matches_direct_sum() {
    let pts = [
        (1.0, 0.5, 2.0, 0.0, 1.0),
        (-1.0, 2.0, 0.0, 2.5, 0.5),
        (3.0, -1.0, 3.5, -0.5, 2.0),
    ];
    let mut stats = RigidAlignment::new();
    for (sx, sy, gx, gy, w) in pts {
        stats.add(&Point2::new(sx, sy), &Point2::new(gx, gy), w);
    }
    let a = stats.solve().unwrap();
    let direct: f64 = pts
        .iter()
        .map(|(sx, sy, gx, gy, w)| {
            let p = a.motion.transform_point(&Point2::new(*sx, *sy));
            w * ((p.x - gx).powi(2) + (p.y - gy).powi(2))
        })
        .sum();
    assert!(
        (a.residual - direct).abs() < 1e-9,
        "{} vs {}",
        a.residual,
        direct
    );
    // Any other motion does worse.
    let other = Pose2::new(a.motion.x() + 0.01, a.motion.y(), a.motion.theta() + 0.01);
    let worse: f64 = pts
        .iter()
        .map(|(sx, sy, gx, gy, w)| {
            let p = other.transform_point(&Point2::new(*sx, *sy));
            w * ((p.x - gx).powi(2) + (p.y - gy).powi(2))
        })
        .sum();
    assert!(worse > direct);
}
