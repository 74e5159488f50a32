//! Correlative scan matching as ICP's initialisation from a bad prior, on seeded
//! synthetic scans (this crate cannot use the simulator of `pgm-datasets`, which
//! depends on it): rooms with boxes and pillars, ray-cast from two poses 0.5-2 m and
//! up to 0.3 rad apart by 361 beams over 180 degrees with 1 cm range noise, and the
//! prior moved by up to 1 m and 30 degrees (100 pairs for the success rates). Also
//! every kind of bad input.

mod common;

use common::{first_hit, Segment};
use pgm_scan::correlative::{
    CorrelativeGrid, CorrelativeIcpMatcher, CorrelativeMatcher, CorrelativeParams,
};
use pgm_scan::methods::ScanMatcher;
use pgm_scan::registration::IcpMatcher;
use pgm_scan::{Error, ParamGuard, Pose2, Scan, ScanPair};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_6, TAU};

/// The four sides of the axis-aligned box from `(x0, y0)` to `(x1, y1)`.
fn rectangle(x0: f64, y0: f64, x1: f64, y1: f64) -> [Segment; 4] {
    [
        (x0, y0, x1, y0),
        (x1, y0, x1, y1),
        (x1, y1, x0, y1),
        (x0, y1, x0, y0),
    ]
}

/// A room `length` × `width` m around the origin (x along its length) with a few
/// boxes and pillars, seeded.
fn scene(rng: &mut ChaCha8Rng) -> Vec<Segment> {
    let length = rng.random_range(12.0..30.0);
    let width = rng.random_range(6.0..14.0);
    let mut segments: Vec<Segment> =
        rectangle(-length / 2.0, -width / 2.0, length / 2.0, width / 2.0).to_vec();
    for _ in 0..rng.random_range(4..9) {
        let (w, h) = (rng.random_range(0.2..1.5), rng.random_range(0.2..1.5));
        let x = rng.random_range(-length / 2.0 + 0.5..length / 2.0 - 0.5 - w);
        // Keep the corridor along y = 0 free, where the sensor drives.
        let y = if rng.random::<bool>() {
            rng.random_range(1.2..(width / 2.0 - 0.3 - h).max(1.3))
        } else {
            -rng.random_range(1.2..(width / 2.0 - 0.3).max(1.3)) - h
        };
        segments.extend(rectangle(x, y, x + w, y + h));
    }
    segments
}

/// The scan of `segments` from `pose`: 361 beams over 180 degrees, 30 m maximum
/// range, Gaussian range noise of about 1 cm (sum of uniforms).
fn ray_cast(segments: &[Segment], pose: &Pose2, rng: &mut ChaCha8Rng) -> Scan {
    let angles: Vec<f64> = (0..361)
        .map(|k| -FRAC_PI_2 + std::f64::consts::PI * k as f64 / 360.0)
        .collect();
    let ranges = angles
        .iter()
        .map(|a| {
            let hit = first_hit((pose.x(), pose.y()), pose.theta() + a, segments)
                .unwrap_or(f64::INFINITY);
            let noise: f64 = (0..6).map(|_| rng.random::<f64>() - 0.5).sum::<f64>() * 0.014;
            hit + noise
        })
        .collect();
    Scan::from_ranges(angles, ranges, 30.0)
}

/// `n` seeded pairs with their true motion and a prior moved by up to 1 m (uniform
/// in a disc) and 30 degrees (uniform).
fn pairs(n: usize, seed: u64) -> Vec<(ScanPair, Pose2)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|k| {
            let segments = scene(&mut rng);
            let from = Pose2::new(
                rng.random_range(-3.0..0.0),
                rng.random_range(-0.4..0.4),
                rng.random_range(-0.2..0.2),
            );
            let step = Pose2::new(
                rng.random_range(0.5..2.0),
                rng.random_range(-0.3..0.3),
                rng.random_range(-0.3..0.3),
            );
            let to = from.compose(&step);
            let truth = from.between(&to);
            let (r, a) = (rng.random::<f64>().sqrt(), TAU * rng.random::<f64>());
            let prior = Pose2::new(
                truth.x() + r * a.cos(),
                truth.y() + r * a.sin(),
                truth.theta() + FRAC_PI_6 * (2.0 * rng.random::<f64>() - 1.0),
            );
            let pair = ScanPair {
                name: format!("synthetic {k}"),
                reference: ray_cast(&segments, &from, &mut rng),
                current: ray_cast(&segments, &to, &mut rng),
                odometry: Some(prior),
                truth: None,
            };
            (pair, truth)
        })
        .collect()
}

fn within(estimate: &Pose2, truth: &Pose2) -> bool {
    estimate.translation_error(truth) <= 0.1 && estimate.rotation_error(truth) <= 0.02
}

#[test]
fn the_search_brings_icp_home_from_a_bad_prior() {
    let pairs = pairs(100, 11);
    let matcher = CorrelativeMatcher::default();
    let refine = CorrelativeIcpMatcher::default();
    let plain_icp = IcpMatcher::default();
    let (mut top, mut aligned, mut icp_alone) = (0, 0, 0);
    for (pair, truth) in &pairs {
        let prior = pair.odometry.unwrap();
        let hypotheses = matcher
            .search(&pair.reference, &pair.current, prior)
            .unwrap();
        assert!(!hypotheses.is_empty(), "{}", pair.name);
        assert!(hypotheses.len() <= matcher.params().hypotheses);
        assert!(hypotheses.windows(2).all(|w| w[0].score >= w[1].score));
        // The best hypothesis refined by ICP.
        let from_best = refine
            .icp
            .reference(&pair.reference)
            .unwrap()
            .align(&pair.current, hypotheses[0].motion)
            .unwrap();
        top += usize::from(within(&from_best.motion, truth));
        // The convenience: every hypothesis refined, the best-scoring refinement.
        aligned += usize::from(within(&refine.estimate(pair).unwrap().motion, truth));
        icp_alone += usize::from(within(&plain_icp.estimate(pair).unwrap().motion, truth));
    }
    let share = |k: usize| k as f64 / pairs.len() as f64;
    eprintln!(
        "best hypothesis + ICP {:.2}, icp+csm {:.2}, ICP from the prior {:.2}",
        share(top),
        share(aligned),
        share(icp_alone)
    );
    assert!(share(top) >= 0.9, "best hypothesis + ICP: {}", share(top));
    assert!(share(aligned) >= 0.9, "icp+csm: {}", share(aligned));
    assert!(
        share(icp_alone) <= share(aligned) - 0.3,
        "ICP alone {} is not clearly below icp+csm {}",
        share(icp_alone),
        share(aligned)
    );
}

#[test]
fn a_good_prior_stays_good() {
    // The true motion as the prior: the search must not wander off.
    let (pair, truth) = pairs(1, 5).remove(0);
    let found = CorrelativeMatcher::default()
        .search(&pair.reference, &pair.current, truth)
        .unwrap();
    assert!(found[0].motion.translation_error(&truth) <= 0.15);
    assert!(found[0].motion.rotation_error(&truth) <= 0.02);
}

/// A scan of `beams` beams, none of them a return.
fn blank(beams: usize) -> Scan {
    Scan::from_ranges(vec![0.0; beams], vec![0.0; beams], 30.0)
}

#[test]
fn empty_scans_are_errors_not_panics() {
    let (pair, _) = pairs(1, 3).remove(0);
    let matcher = CorrelativeMatcher::default();
    for empty in [blank(0), blank(361)] {
        assert!(matches!(
            matcher.search(&empty, &pair.current, Pose2::identity()),
            Err(Error::EmptyScan { which: "reference" })
        ));
        assert!(matches!(
            matcher.search(&pair.reference, &empty, Pose2::identity()),
            Err(Error::EmptyScan { which: "current" })
        ));
        assert!(matches!(
            matcher.reference(&empty),
            Err(Error::EmptyScan { which: "reference" })
        ));
        let grid: CorrelativeGrid = matcher.reference(&pair.reference).unwrap();
        assert!(matches!(
            grid.score(&empty, Pose2::identity()),
            Err(Error::EmptyScan { which: "current" })
        ));
    }
    // Through the scan-matcher interface the error names the pair.
    let mut broken = pair.clone();
    broken.current = blank(361);
    let err = CorrelativeIcpMatcher::default()
        .estimate(&broken)
        .unwrap_err();
    assert!(err.to_string().contains(&pair.name), "{err}");
    // Returns beyond `max_range` do not count.
    let near_only = CorrelativeParams {
        max_range: 0.1,
        ..CorrelativeParams::default()
    }
    .check()
    .unwrap();
    assert!(matches!(
        near_only.reference(&pair.reference),
        Err(Error::EmptyScan { which: "reference" })
    ));
}

#[test]
fn non_finite_priors_and_motions_are_refused() {
    let (pair, _) = pairs(1, 4).remove(0);
    let matcher = CorrelativeMatcher::default();
    let nan = Pose2::new(f64::NAN, 0.0, 0.0);
    assert!(matches!(
        matcher.search(&pair.reference, &pair.current, nan),
        Err(Error::InvalidParameter { name: "prior", .. })
    ));
    assert!(matches!(
        matcher
            .reference(&pair.reference)
            .unwrap()
            .score(&pair.current, Pose2::new(0.0, f64::INFINITY, 0.0)),
        Err(Error::InvalidParameter { name: "motion", .. })
    ));
}

#[test]
fn nothing_good_enough_is_an_empty_result() {
    // No motion explains every return perfectly: with `min_score` 1 the search finds
    // nothing, and the convenience falls back to ICP from the prior.
    let (pair, _) = pairs(1, 6).remove(0);
    let strict = CorrelativeParams {
        min_score: 1.0,
        ..CorrelativeParams::default()
    }
    .check()
    .unwrap();
    let prior = pair.odometry.unwrap();
    assert!(strict
        .search(&pair.reference, &pair.current, prior)
        .unwrap()
        .is_empty());
    let aligned = strict
        .align(
            &pair.reference,
            &pair.current,
            prior,
            &IcpMatcher::default(),
        )
        .unwrap();
    assert!(aligned.start.is_none() && aligned.hypotheses.is_empty());
    let from_prior = IcpMatcher::default()
        .reference(&pair.reference)
        .unwrap()
        .align(&pair.current, prior)
        .unwrap();
    assert_eq!(aligned.icp.motion, from_prior.motion);
}

#[test]
fn invalid_parameters_are_named() {
    let base = CorrelativeParams::default();
    let cases: Vec<(&str, CorrelativeParams)> = vec![
        (
            "translation_window",
            CorrelativeParams {
                translation_window: -1.0,
                ..base
            },
        ),
        (
            "translation_window",
            CorrelativeParams {
                translation_window: f64::NAN,
                ..base
            },
        ),
        (
            "rotation_window",
            CorrelativeParams {
                rotation_window: 4.0,
                ..base
            },
        ),
        (
            "rotation_window",
            CorrelativeParams {
                rotation_window: f64::NAN,
                ..base
            },
        ),
        (
            "resolution",
            CorrelativeParams {
                resolution: 0.0,
                ..base
            },
        ),
        (
            // A grid far too large to allocate: refused, not attempted.
            "resolution",
            CorrelativeParams {
                resolution: 1e-4,
                ..base
            },
        ),
        (
            "max_range",
            CorrelativeParams {
                max_range: f64::INFINITY,
                ..base
            },
        ),
        (
            "angular_step",
            CorrelativeParams {
                angular_step: Some(0.0),
                ..base
            },
        ),
        (
            "angular_step",
            CorrelativeParams {
                angular_step: Some(1e-12),
                ..base
            },
        ),
        (
            "kernel_sigma",
            CorrelativeParams {
                kernel_sigma: -0.1,
                ..base
            },
        ),
        (
            "kernel_sigma",
            CorrelativeParams {
                kernel_sigma: 100.0,
                ..base
            },
        ),
        (
            "point_spacing",
            CorrelativeParams {
                point_spacing: f64::NAN,
                ..base
            },
        ),
        (
            "hypotheses",
            CorrelativeParams {
                hypotheses: 0,
                ..base
            },
        ),
        (
            "suppression_translation",
            CorrelativeParams {
                suppression_translation: -0.1,
                ..base
            },
        ),
        (
            "suppression_rotation",
            CorrelativeParams {
                suppression_rotation: f64::INFINITY,
                ..base
            },
        ),
        (
            "min_score",
            CorrelativeParams {
                min_score: 1.5,
                ..base
            },
        ),
        (
            "min_relative_score",
            CorrelativeParams {
                min_relative_score: -0.5,
                ..base
            },
        ),
    ];
    for (expected, params) in cases {
        match params.check() {
            Err(Error::InvalidParameter { name, value, .. }) => {
                assert_eq!(name, expected, "{params:?}");
                assert!(!value.is_empty());
            }
            other => panic!("{expected}: {other:?}"),
        }
    }
    // The boundary values are accepted.
    for params in [
        CorrelativeParams {
            translation_window: 0.0,
            rotation_window: 0.0,
            point_spacing: 0.0,
            min_score: 0.0,
            ..base
        },
        CorrelativeParams {
            rotation_window: std::f64::consts::PI,
            min_score: 1.0,
            min_relative_score: 1.0,
            ..base
        },
    ] {
        assert!(params.check().is_ok(), "{params:?}");
    }
}

#[test]
fn a_full_turn_window_finds_a_turned_scan() {
    // ±π: the search is global in rotation too.
    let (pair, truth) = pairs(1, 9).remove(0);
    let matcher = CorrelativeParams {
        rotation_window: std::f64::consts::PI,
        ..CorrelativeParams::default()
    }
    .check()
    .unwrap();
    let prior = Pose2::new(truth.x() + 0.5, truth.y() - 0.5, truth.theta() + 2.5);
    let found = matcher
        .search(&pair.reference, &pair.current, prior)
        .unwrap();
    assert!(
        found[0].motion.translation_error(&truth) <= 0.15,
        "{found:?}"
    );
    assert!(found[0].motion.rotation_error(&truth) <= 0.02, "{found:?}");
}
