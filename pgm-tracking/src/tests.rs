//! Unit tests of the tracker's steps.

use super::*;
use nalgebra::{Point2, Vector2};
use pgm_core::ParamGuard;
use pgm_scan::methods::{MotionClusterer, MotionClustering};
use pgm_scan::pair::{ClusterMotion, ScanPair};
use pgm_scan::{Pose2, Result, Scan};
use std::collections::HashMap;

/// A scan at time `t` of 181 beams over ±90° seeing the segments `walls` (end
/// points in the sensor frame), 20 m maximum range.
fn scan(t: f64, walls: &[(Point2<f64>, Point2<f64>)]) -> Scan {
    let angles: Vec<f64> = (0..181).map(|k| (k as f64 - 90.0).to_radians()).collect();
    let ranges = angles
        .iter()
        .map(|&a| {
            let d = Vector2::new(a.cos(), a.sin());
            walls
                .iter()
                .filter_map(|(p, q)| {
                    // Ray r·d against the segment p + u (q − p).
                    let e = q - p;
                    let den = d.x * e.y - d.y * e.x;
                    if den.abs() < 1e-12 {
                        return None;
                    }
                    let r = (p.x * e.y - p.y * e.x) / den;
                    let u = (p.x * d.y - p.y * d.x) / den;
                    (r > 0.0 && (0.0..=1.0).contains(&u)).then_some(r)
                })
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let mut s = Scan::from_ranges(angles, ranges, 20.0);
    s.timestamp = t;
    s
}

/// The walls of the scene at time `t`: a static wall 6 m ahead and a 0.6 m wide
/// box front starting 3 m ahead at y = −1, moving towards the sensor and to the
/// left at `speed` m/s (0.6 and 0.8 of it). (An object that slides along its only
/// visible side shows its motion at its two ends alone; the evidence test of
/// [`Tracker`] weighs all its returns and may not see it.)
fn scene(t: f64, speed: f64) -> Vec<(Point2<f64>, Point2<f64>)> {
    let (x, y) = (3.0 - 0.6 * speed * t, -1.0 + 0.8 * speed * t);
    vec![
        (Point2::new(6.0, -8.0), Point2::new(6.0, 8.0)),
        (Point2::new(x, y - 0.3), Point2::new(x, y + 0.3)),
    ]
}

/// Pairs `(n − 1, n)` of a sequence of scans 0.1 s apart (static sensor).
fn sequence(n: usize, speed: f64) -> Vec<ScanPair> {
    (1..=n)
        .map(|j| {
            let (a, b) = ((j - 1) as f64 * 0.1, j as f64 * 0.1);
            ScanPair {
                name: format!("s:{}-{j}", j - 1),
                reference: scan(a, &scene(a, speed)),
                current: scan(b, &scene(b, speed)),
                odometry: Some(Pose2::identity()),
                truth: None,
            }
        })
        .collect()
}

/// Beams of `pair`'s current scan on the box (3 m ahead).
fn box_beams(pair: &ScanPair) -> Vec<usize> {
    (0..pair.current.len())
        .filter(|&k| pair.current.valid[k] && pair.current.ranges[k] < 4.0)
        .collect()
}

/// A detector that reports the given objects (beams and motion) on the named pairs
/// and the background elsewhere.
struct Scripted(HashMap<String, (Vec<usize>, Pose2)>);

impl Scripted {
    /// Reports each `(pair, beams, motion)`: those beams of that pair as one object
    /// with that motion.
    fn new<'a>(detections: impl IntoIterator<Item = (&'a ScanPair, Vec<usize>, Pose2)>) -> Self {
        Scripted(
            detections
                .into_iter()
                .map(|(pair, beams, motion)| (pair.name.clone(), (beams, motion)))
                .collect(),
        )
    }

    /// Reports the whole box ([`box_beams`]) with the given motion in each given pair.
    fn boxes<'a>(detections: impl IntoIterator<Item = (&'a ScanPair, Pose2)>) -> Self {
        Self::new(
            detections
                .into_iter()
                .map(|(pair, motion)| (pair, box_beams(pair), motion)),
        )
    }
}

impl MotionClusterer for Scripted {
    fn name(&self) -> String {
        "scripted".into()
    }

    fn cluster(&self, pair: &ScanPair) -> Result<MotionClustering> {
        let mut labels: Vec<Option<u32>> =
            pair.current.valid.iter().map(|&v| v.then_some(0)).collect();
        let mut motions = vec![ClusterMotion {
            label: 0,
            motion: Pose2::identity(),
            kind: "background".into(),
        }];
        if let Some((beams, motion)) = self.0.get(&pair.name) {
            for &b in beams {
                labels[b] = Some(1);
            }
            motions.push(ClusterMotion {
                label: 1,
                motion: *motion,
                kind: "moving".into(),
            });
        }
        Ok(MotionClustering {
            labels,
            motions,
            ego_motion: Some(Pose2::identity()),
            iterations: 0,
            converged: true,
        })
    }
}

#[test]
fn an_object_detected_once_is_followed_while_it_moves() {
    let pairs = sequence(8, 1.0);
    // Detected in the second pair only, with its true motion over the pair (maps
    // current returns back 6 cm away and 8 cm to the right).
    let second = &pairs[1];
    let detector = Scripted::boxes([(second, Pose2::new(0.06, -0.08, 0.0))]);
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    assert_eq!(tracked.counts.tracks, 1);
    assert_eq!(tracked.counts.dropped, 0);
    for (j, (pair, c)) in pairs.iter().zip(&tracked.clusterings).enumerate().skip(1) {
        let on_box = box_beams(pair);
        let object = c.labels[on_box[0]].expect("a return");
        assert!(object > 0, "pair {j}: the box is not reported moving");
        assert!(
            on_box.iter().all(|&b| c.labels[b] == Some(object)),
            "pair {j}"
        );
        let motion = c.motion_of(object).unwrap();
        assert!(
            motion.translation_error(&Pose2::new(0.06, -0.08, 0.0)) < 0.03,
            "pair {j}: {motion:?}"
        );
        // The wall stays background.
        assert!((0..pair.current.len())
            .filter(|&k| pair.current.valid[k] && pair.current.ranges[k] > 5.0)
            .all(|k| c.labels[k] == Some(0)));
    }
    assert!(tracked.counts.tracked_objects >= 6);
}

#[test]
fn a_confirmed_track_is_followed_back_to_the_scans_before_its_first_detection() {
    let pairs = sequence(8, 1.0);
    // First detected in the sixth pair; it moved all along.
    let sixth = &pairs[5];
    let detector = Scripted::boxes([(sixth, Pose2::new(0.06, -0.08, 0.0))]);
    let moving_box = |c: &MotionClustering, pair: &ScanPair| {
        let on_box = box_beams(pair);
        let object = c.labels[on_box[0]].expect("a return");
        object > 0 && on_box.iter().all(|&b| c.labels[b] == Some(object))
    };
    let forward = TrackingParams {
        backward: false,
        ..TrackingParams::default()
    }
    .check()
    .unwrap()
    .track(&pairs, &detector)
    .unwrap();
    assert_eq!(forward.counts.backward_objects, 0);
    assert!((0..5).all(|j| !moving_box(&forward.clusterings[j], &pairs[j])));
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    assert_eq!(tracked.counts.tracks, 1);
    // Every pair before the detection now reports the box, on the same track, with
    // its motion over the pair; but the first, whose current scan starts the
    // sequence (no step shows the box moving into it).
    assert_eq!(tracked.counts.backward_objects, 4, "{:?}", tracked.counts);
    assert!(!moving_box(&tracked.clusterings[0], &pairs[0]));
    for (j, (pair, c)) in pairs
        .iter()
        .zip(&tracked.clusterings)
        .enumerate()
        .take(5)
        .skip(1)
    {
        assert!(
            moving_box(c, pair),
            "pair {j}: the box is not reported moving"
        );
        let object = c.labels[box_beams(pair)[0]].unwrap();
        let motion = c.motion_of(object).unwrap();
        assert!(
            motion.translation_error(&Pose2::new(0.06, -0.08, 0.0)) < 0.03,
            "pair {j}: {motion:?}"
        );
        let reported = &tracked.objects[j];
        assert_eq!(reported.len(), 1, "pair {j}");
        assert_eq!(reported[0].track, tracked.objects[5][0].track);
        assert!(!reported[0].detected);
        // Its velocity forward in time: 0.6 m/s towards the sensor, 0.8 to the left.
        let v = Vector2::from(reported[0].velocity.expect("a track's velocity"));
        assert!(
            (v - Vector2::new(-0.6, 0.8)).norm() < 0.2,
            "pair {j}: {v:?}"
        );
        // The wall stays background.
        assert!((0..pair.current.len())
            .filter(|&k| pair.current.valid[k] && pair.current.ranges[k] > 5.0)
            .all(|k| c.labels[k] == Some(0)));
    }
    // From the sixth pair on, as without the backward pass.
    assert_eq!(tracked.clusterings[5..], forward.clusterings[5..]);
}

#[test]
fn the_backward_pass_stops_where_the_object_stood() {
    // The box stands until t = 0.35 s, then moves at 1 m/s; first detected in the
    // seventh pair (scans at 0.6 and 0.7 s).
    let at = |t: f64| scene((t - 0.35).max(0.0), 1.0);
    let pairs: Vec<ScanPair> = (1..=9)
        .map(|j| {
            let (a, b) = ((j - 1) as f64 * 0.1, j as f64 * 0.1);
            ScanPair {
                name: format!("s:{}-{j}", j - 1),
                reference: scan(a, &at(a)),
                current: scan(b, &at(b)),
                odometry: Some(Pose2::identity()),
                truth: None,
            }
        })
        .collect();
    let seventh = &pairs[6];
    let detector = Scripted::boxes([(seventh, Pose2::new(0.06, -0.08, 0.0))]);
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    let moving = |j: usize| {
        tracked.clusterings[j]
            .labels
            .iter()
            .flatten()
            .any(|&l| l > 0)
    };
    // Moving over the pairs ending at 0.5 and 0.6 s (0.15 and 0.25 s of motion),
    // not where the box stood over the whole step (current scans up to 0.3 s).
    assert!(moving(4) && moving(5), "{:?}", tracked.counts);
    for j in 0..3 {
        assert!(!moving(j), "pair {j}: the standing box is reported moving");
    }
}

#[test]
fn a_track_lost_at_its_first_step_is_continued_by_the_next_detection() {
    let pairs = sequence(6, 1.0);
    // The first pair starts the sequence: no previous scan to measure the box's
    // velocity against, and the detector's motion is ten times too large, so the
    // track looks for the box in the wrong place in the next scan. The detector
    // sees it there again with its true motion.
    let detector = Scripted::boxes([
        (&pairs[0], Pose2::new(0.6, -0.8, 0.0)),
        (&pairs[1], Pose2::new(0.06, -0.08, 0.0)),
    ]);
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    assert_eq!(tracked.counts.tracks, 1, "{:?}", tracked.counts);
    let first = tracked.objects[0][0].track;
    assert!(first.is_some());
    for (j, objects) in tracked.objects.iter().enumerate() {
        assert_eq!(objects.len(), 1, "pair {j}");
        assert_eq!(objects[0].track, first, "pair {j}");
    }
    // From the second pair on, the track's velocity is the box's (0.6 m/s towards
    // the sensor, 0.8 to the left).
    for (j, objects) in tracked.objects.iter().enumerate().skip(2) {
        let v = Vector2::from(objects[0].velocity.expect("a track's velocity"));
        assert!(
            (v - Vector2::new(-0.6, 0.8)).norm() < 0.2,
            "pair {j}: {v:?}"
        );
    }
}

#[test]
fn a_track_is_continued_across_uneven_scan_gaps() {
    // Scans at uneven times (two dropped after 0.2 s), the box at 2 m/s.
    let times = [0.0, 0.1, 0.2, 0.5, 0.6, 0.7];
    let pairs: Vec<ScanPair> = times
        .windows(2)
        .map(|w| ScanPair {
            name: format!("u:{}-{}", w[0], w[1]),
            reference: scan(w[0], &scene(w[0], 2.0)),
            current: scan(w[1], &scene(w[1], 2.0)),
            odometry: Some(Pose2::identity()),
            truth: None,
        })
        .collect();
    // The box's motion over a pair of `g` seconds maps its returns back by 2 m/s.
    let over = |g: f64| Pose2::new(1.2 * g, -1.6 * g, 0.0);
    let detector = Scripted::boxes([
        // Birth without a previous scan, the detector's motion ten times too large.
        (&pairs[0], over(1.0)),
        // Found again after the gap with its true motion over the pair.
        (&pairs[2], over(0.3)),
    ]);
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    assert_eq!(tracked.counts.tracks, 1, "{:?}", tracked.counts);
    assert_eq!(tracked.counts.dropped, 0, "{:?}", tracked.counts);
    let first = tracked.objects[0].first().and_then(|o| o.track);
    assert!(first.is_some(), "the first detection is kept");
    assert_eq!(tracked.objects[2][0].track, first);
}

#[test]
fn the_backward_pass_reports_no_object_twice() {
    let pairs = sequence(8, 1.0);
    // The box detected in the sixth pair, and as two returns only in the third
    // (too few for a track: reported as detected).
    let third = &pairs[2];
    let sixth = &pairs[5];
    let detector = Scripted::new([
        (
            third,
            box_beams(third)[..2].to_vec(),
            Pose2::new(0.06, -0.08, 0.0),
        ),
        (sixth, box_beams(sixth), Pose2::new(0.06, -0.08, 0.0)),
    ]);
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    // Followed back into the fifth and fourth pairs; in the third the box is
    // reported already: once.
    let track = tracked.objects[5][0].track;
    assert_eq!(tracked.objects[4][0].track, track);
    assert_eq!(tracked.objects[3][0].track, track);
    assert_eq!(tracked.objects[2].len(), 1, "{:?}", tracked.objects[2]);
    assert_eq!(tracked.objects[2][0].track, None);
    // The detection there takes the box's other returns.
    assert_eq!(tracked.objects[2][0].beams, box_beams(third));
    let label = tracked.objects[2][0].label;
    assert!(box_beams(third)
        .iter()
        .all(|&b| tracked.clusterings[2].labels[b] == Some(label)));
    // And back on into the second pair (the first starts the sequence).
    assert_eq!(tracked.objects[1].len(), 1);
    assert_eq!(tracked.objects[1][0].track, track);
    assert!(tracked.objects[0].is_empty());
}

#[test]
fn a_detection_too_small_for_a_track_is_reported_as_detected() {
    let pairs = sequence(4, 1.0);
    let third = &pairs[2];
    let two = box_beams(third)[..2].to_vec();
    let detector = Scripted::new([(third, two.clone(), Pose2::new(0.06, -0.08, 0.0))]);
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    assert_eq!(tracked.counts.tracks, 0);
    assert_eq!(tracked.clusterings[2], detector.cluster(third).unwrap());
    let reported = &tracked.objects[2];
    assert_eq!(reported.len(), 1);
    assert_eq!(reported[0].track, None);
    assert_eq!(reported[0].velocity, None);
    assert_eq!(reported[0].beams, two);
    assert!(reported[0].detected);
}

#[test]
fn a_detection_that_does_not_move_on_is_dropped() {
    // The box stands still; the detector calls it moving in one pair.
    let pairs = sequence(6, 0.0);
    let third = &pairs[2];
    let detector = Scripted::boxes([(third, Pose2::new(0.0, -0.1, 0.0))]);
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    assert_eq!(tracked.counts.dropped, 1);
    assert_eq!(tracked.counts.tracked_objects, 0);
    for c in &tracked.clusterings {
        assert!(c.labels.iter().flatten().all(|&l| l == 0));
    }
    // Also dropped when one step of evidence would do: measured against the
    // previous scan the box does not move. Kept when nothing is dropped (one step,
    // any speed).
    let once = TrackingParams {
        min_evidence: 1,
        ..TrackingParams::default()
    }
    .check()
    .unwrap()
    .track(&pairs, &detector)
    .unwrap();
    assert_eq!(once.counts.dropped, 1);
    let once = TrackingParams {
        min_evidence: 1,
        min_speed: 0.0,
        ..TrackingParams::default()
    }
    .check()
    .unwrap()
    .track(&pairs, &detector)
    .unwrap();
    assert_eq!(once.counts.dropped, 0);
    assert!(once.clusterings[2].labels.iter().flatten().any(|&l| l > 0));
}

#[test]
fn independent_pairs_get_the_detector_output() {
    // Every pair starts at time 0 (a simulated data set): no sequence.
    let mut pairs = sequence(4, 1.0);
    for p in &mut pairs {
        p.reference.timestamp = 0.0;
    }
    // The box's motion over each pair, at its speed (1 m/s, 0.6 and 0.8 of it along
    // x and y) over the pair's time gap.
    let detector = Scripted::boxes(pairs.iter().map(|p| {
        let gap = p.current.timestamp - p.reference.timestamp;
        (p, Pose2::new(0.6 * gap, -0.8 * gap, 0.0))
    }));
    let tracked = Tracker::default().track(&pairs, &detector).unwrap();
    assert_eq!(tracked.counts.sequences, 4);
    for (p, c) in pairs.iter().zip(&tracked.clusterings) {
        assert_eq!(c, &detector.cluster(p).unwrap());
    }
}

#[test]
fn bad_parameters_are_refused() {
    for bad in [
        TrackingParams {
            min_speed: f64::NAN,
            ..TrackingParams::default()
        },
        TrackingParams {
            gate: 0.0,
            ..TrackingParams::default()
        },
        TrackingParams {
            min_evidence: 0,
            ..TrackingParams::default()
        },
        TrackingParams {
            smoothing: 1.5,
            ..TrackingParams::default()
        },
        TrackingParams {
            min_returns: 1,
            ..TrackingParams::default()
        },
    ] {
        assert!(bad.check().is_err(), "{bad:?}");
    }
}
