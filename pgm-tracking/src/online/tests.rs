//! The online tracker on synthetic scans: a ray-cast room with posts and a walker
//! (two legs), a free-space detector.

use super::*;
use pgm_scan::methods::MotionClustering;
use std::f64::consts::PI;

/// A circle (centre, radius) or a wall (two end points).
#[derive(Clone, Copy)]
enum Shape {
    Circle(Point2<f64>, f64),
    Wall(Point2<f64>, Point2<f64>),
}

/// The range along the ray from `origin` in direction `dir` (unit) to `shape`.
fn hit(origin: Point2<f64>, dir: Vector2<f64>, shape: &Shape) -> Option<f64> {
    match *shape {
        Shape::Circle(c, r) => {
            let oc = origin - c;
            let b = oc.dot(&dir);
            let disc = b * b - (oc.norm_squared() - r * r);
            (disc >= 0.0).then(|| -b - disc.sqrt()).filter(|&t| t > 0.0)
        }
        Shape::Wall(a, b) => {
            let e = b - a;
            let den = dir.x * (-e.y) - dir.y * (-e.x);
            if den.abs() < 1e-12 {
                return None;
            }
            let w = a - origin;
            let t = (w.x * (-e.y) - w.y * (-e.x)) / den;
            let u = (dir.x * w.y - dir.y * w.x) / den;
            (t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
        }
    }
}

/// The room: walls of a 24 × 16 m box around the origin and a row of posts.
fn room() -> Vec<Shape> {
    let c = |x, y| Point2::new(x, y);
    let mut out = vec![
        Shape::Wall(c(-4.0, -8.0), c(20.0, -8.0)),
        Shape::Wall(c(20.0, -8.0), c(20.0, 8.0)),
        Shape::Wall(c(20.0, 8.0), c(-4.0, 8.0)),
        Shape::Wall(c(-4.0, 8.0), c(-4.0, -8.0)),
    ];
    for k in 0..8 {
        let x = 1.0 + 2.3 * k as f64;
        out.push(Shape::Circle(c(x, 4.5), 0.15));
        out.push(Shape::Circle(c(x + 1.1, -4.0), 0.12));
    }
    out
}

/// A walker's legs at `centre` walking along `heading` (rad), mid-stride phase `phase`.
fn legs(centre: Point2<f64>, heading: f64, phase: f64) -> [Shape; 2] {
    let along = Vector2::new(heading.cos(), heading.sin());
    let across = Vector2::new(-along.y, along.x);
    let swing = 0.2 * phase.sin();
    [
        Shape::Circle(centre + across * 0.1 + along * swing, 0.06),
        Shape::Circle(centre - across * 0.1 - along * swing, 0.06),
    ]
}

/// A scan from sensor pose `pose` (world) at time `t`: 361 beams over 180°.
fn scan(pose: Pose2, t: f64, shapes: &[Shape]) -> Scan {
    let n = 361;
    let angles: Vec<f64> = (0..n)
        .map(|k| -PI / 2.0 + PI * k as f64 / (n - 1) as f64)
        .collect();
    let origin = Point2::new(pose.x(), pose.y());
    let ranges: Vec<f64> = angles
        .iter()
        .map(|a| {
            let th = a + pose.theta();
            let dir = Vector2::new(th.cos(), th.sin());
            shapes
                .iter()
                .filter_map(|s| hit(origin, dir, s))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let mut s = Scan::from_ranges(angles, ranges, 30.0);
    s.timestamp = t;
    s
}

/// A free-space detector: a current return lying more than 0.3 m in front of the
/// reference return along its bearing (the pair's odometry carrying it into the
/// reference frame) is moving; moving returns are labelled by gap segments.
struct FreeSpace;

impl MotionClusterer for FreeSpace {
    fn name(&self) -> String {
        "free space".into()
    }

    fn cluster(&self, pair: &ScanPair) -> Result<MotionClustering> {
        let ego = pair.odometry.unwrap_or_default();
        let mut labels: Vec<Option<u32>> = (0..pair.current.len())
            .map(|b| pair.current.valid[b].then_some(0))
            .collect();
        let mut label = 0;
        let mut last: Option<Point2<f64>> = None;
        for (b, l) in labels.iter_mut().enumerate() {
            if l.is_none() {
                continue;
            }
            let q = pair.current.beam_point(b);
            if pair.reference.in_free_space(&ego.transform_point(&q), 0.3) {
                if last.is_none_or(|p| (p - q).norm() > 0.3) {
                    label += 1;
                }
                *l = Some(label);
                last = Some(q);
            }
        }
        Ok(MotionClustering {
            labels,
            motions: Vec::new(),
            ego_motion: Some(ego),
            iterations: 0,
            converged: true,
        })
    }
}

/// Runs the tracker over `n` scans 0.1 s apart: the sensor at `sensor(t)`, the walker
/// at `walker(t)` (centre, heading), optional odometry.
fn run(
    n: usize,
    sensor: impl Fn(f64) -> Pose2,
    walker: impl Fn(f64) -> (Point2<f64>, f64),
    odometry: bool,
) -> (Vec<ScanReport>, Vec<Point2<f64>>) {
    let params = OnlineParams::default();
    let mut tracker = params.tracker(&FreeSpace).unwrap();
    let mut reports = Vec::new();
    let mut truth = Vec::new();
    for k in 0..n {
        let t = 0.1 * k as f64;
        let pose = sensor(t);
        let (c, heading) = walker(t);
        let mut shapes = room();
        shapes.extend(legs(c, heading, 2.0 * PI * t));
        let mut s = scan(pose, t, &shapes);
        if odometry {
            s.odometry = Some(pose);
        }
        truth.push(pose.inverse().transform_point(&c));
        reports.push(tracker.push(s).unwrap());
    }
    (reports, truth)
}

/// [`run`] for `n` scans of a static sensor (with odometry) while a walker crosses
/// 3 m ahead at 1 m/s.
fn crossing(n: usize) -> (Vec<ScanReport>, Vec<Point2<f64>>) {
    run(
        n,
        |_| Pose2::identity(),
        |t| (Point2::new(3.0, -2.0 + t), PI / 2.0),
        true,
    )
}

/// Every object id appears once per scan.
fn ids_unique(reports: &[ScanReport]) {
    for r in reports {
        let ids: HashSet<u64> = r.objects.iter().map(|o| o.track).collect();
        assert_eq!(ids.len(), r.objects.len(), "scan {}", r.index);
    }
}

/// The confirmed object nearest the truth in each scan (within 0.5 m): (track,
/// distance).
fn followed(reports: &[ScanReport], truth: &[Point2<f64>]) -> Vec<Option<(u64, f64)>> {
    reports
        .iter()
        .zip(truth)
        .map(|(r, g)| {
            r.objects
                .iter()
                .filter(|o| o.state != TrackState::Tentative)
                .map(|o| (o.track, (Point2::from(o.centre) - g).norm()))
                .filter(|(_, d)| *d < 0.5)
                .min_by(|a, b| a.1.total_cmp(&b.1))
        })
        .collect()
}

#[test]
fn a_walker_is_confirmed_and_followed_on_one_track() {
    // Static sensor; a walker crosses 3 m ahead at 1 m/s.
    let (reports, truth) = crossing(40);
    ids_unique(&reports);
    let f = followed(&reports, &truth);
    let first = f
        .iter()
        .position(|x| x.is_some())
        .expect("confirmed at some scan");
    assert!(first <= 8, "confirmed at scan {first}");
    let after = &f[first..];
    let found = after.iter().flatten().count();
    assert!(
        found as f64 >= 0.9 * after.len() as f64,
        "{found} of {}",
        after.len()
    );
    let ids: HashSet<u64> = after.iter().flatten().map(|x| x.0).collect();
    assert_eq!(ids.len(), 1, "one track: {ids:?}");
    let mut errors: Vec<f64> = after.iter().flatten().map(|x| x.1).collect();
    errors.sort_by(f64::total_cmp);
    // A walker's visible legs swing ±0.2 m about the body's centre here.
    assert!(
        errors[errors.len() / 2] < 0.12,
        "median centre error {}",
        errors[errors.len() / 2]
    );
    // Its velocity over the ground: (0, 1) m/s.
    let last = reports.last().unwrap();
    let o = last
        .objects
        .iter()
        .find(|o| ids.contains(&o.track))
        .expect("still tracked");
    assert!(
        (o.velocity[0]).abs() < 0.3 && (o.velocity[1] - 1.0).abs() < 0.3,
        "{:?}",
        o.velocity
    );
    assert!(o.score > 0.5 && o.score <= 1.0);
}

#[test]
fn a_walker_who_stops_stays_tracked_as_stopped() {
    let (reports, truth) = run(
        50,
        |_| Pose2::identity(),
        |t| (Point2::new(3.0, -2.0 + t.min(2.0)), PI / 2.0),
        true,
    );
    ids_unique(&reports);
    let f = followed(&reports, &truth);
    let late: Vec<_> = f[35..].iter().flatten().collect();
    assert!(
        late.len() >= 14,
        "followed in {} of the last 15 scans",
        late.len()
    );
    let id = late[0].0;
    assert!(late.iter().all(|x| x.0 == id));
    let last = reports.last().unwrap();
    let o = last.objects.iter().find(|o| o.track == id).unwrap();
    assert_eq!(o.state, TrackState::Stopped);
}

#[test]
fn a_new_track_starts_at_rest() {
    let (reports, _) = run(
        12,
        |_| Pose2::identity(),
        |t| (Point2::new(4.0, 3.0 - 1.5 * t), -PI / 2.0),
        true,
    );
    let mut seen = HashSet::new();
    for r in &reports {
        for o in &r.objects {
            if seen.insert(o.track) {
                assert_eq!(o.velocity, [0.0, 0.0], "track {} at its birth", o.track);
                assert_eq!(o.state, TrackState::Tentative);
            }
        }
    }
    assert!(!seen.is_empty());
}

#[test]
fn ego_motion_without_odometry_follows_the_world_not_the_person_ahead() {
    // The robot drives at 0.6 m/s; a person walks 1.2 m ahead of it at its speed.
    let (reports, _) = run(
        40,
        |t| Pose2::new(0.6 * t, 0.0, 0.0),
        |t| (Point2::new(1.2 + 0.6 * t, 0.0), 0.0),
        false,
    );
    let mut errors: Vec<(f64, f64)> = Vec::new();
    for w in reports.windows(2) {
        let ego = w[1].ego.expect("a step");
        let truth = Pose2::new(0.06, 0.0, 0.0);
        errors.push((
            ego.motion.translation_error(&truth),
            ego.motion.rotation_error(&truth),
        ));
    }
    let mut t: Vec<f64> = errors.iter().map(|e| e.0).collect();
    t.sort_by(f64::total_cmp);
    assert!(
        t[t.len() / 2] < 0.02,
        "median step error {} m",
        t[t.len() / 2]
    );
    assert!(errors.iter().all(|e| e.0 < 0.2 && e.1 < 0.1), "{errors:?}");
}

#[test]
fn smoothing_reports_a_confirmed_track_from_its_birth() {
    let (reports, _) = crossing(30);
    let smoothed = smooth(reports.clone(), 0.5);
    assert!(smoothed
        .iter()
        .flat_map(|r| &r.objects)
        .all(|o| o.state != TrackState::Tentative));
    let online: usize = reports
        .iter()
        .map(|r| {
            r.objects
                .iter()
                .filter(|o| o.state != TrackState::Tentative)
                .count()
        })
        .sum();
    let offline: usize = smoothed.iter().map(|r| r.objects.len()).sum();
    assert!(offline > online, "smoothed {offline}, online {online}");
}

#[test]
fn bad_scans_are_errors_naming_the_scan() {
    let params = OnlineParams::default();
    let mut tracker = params.tracker(&FreeSpace).unwrap();
    let mut s = scan(Pose2::identity(), 0.0, &room());
    s.timestamp = f64::NAN;
    let e = tracker.push(s).unwrap_err().to_string();
    assert!(e.contains("scan 0") && e.contains("NaN"), "{e}");
    let mut s = scan(Pose2::identity(), 0.0, &room());
    s.ranges.pop();
    let e = tracker.push(s).unwrap_err().to_string();
    assert!(e.contains("scan 0") && e.contains("360 ranges"), "{e}");
    let bad = OnlineParams {
        gate: -1.0,
        ..OnlineParams::default()
    };
    let e = bad.tracker(&FreeSpace).err().expect("refused").to_string();
    assert!(e.contains("gate"), "{e}");
}

/// A detector that calls a stretch of static surface moving in every pair (clutter a
/// real detector keeps reporting, e.g. a shadow edge on a wall): the returns within
/// 0.4 m of a world point that steps 0.35 m along x and back, scan by scan (0, 1, 2
/// steps), so the measured centre jumps by up to 0.7 m, as much as a walker moves.
struct Clutter {
    at: Point2<f64>,
}

impl MotionClusterer for Clutter {
    fn name(&self) -> String {
        "clutter".into()
    }

    fn cluster(&self, pair: &ScanPair) -> Result<MotionClustering> {
        let pose = pair
            .current
            .odometry
            .expect("the test's scans carry odometry");
        let step = (pair.current.timestamp * 10.0).round() as i64 % 3;
        let at = self.at + Vector2::new(0.35 * step as f64, 0.0);
        let labels = (0..pair.current.len())
            .map(|b| {
                pair.current.valid[b].then(|| {
                    let q = pose.transform_point(&pair.current.beam_point(b));
                    u32::from((q - at).norm() < 0.4)
                })
            })
            .collect();
        Ok(MotionClustering {
            labels,
            motions: Vec::new(),
            ego_motion: pair.odometry,
            iterations: 0,
            converged: true,
        })
    }
}

#[test]
fn static_clutter_detected_in_every_scan_is_never_confirmed() {
    // The sensor drives along the room; the detector flags a stretch of its south
    // wall (y = −8 m) in every scan.
    let detector = Clutter {
        at: Point2::new(6.0, -8.0),
    };
    let mut tracker = OnlineParams::default().tracker(&detector).unwrap();
    let mut tentative = 0;
    for k in 0..60 {
        let t = 0.1 * k as f64;
        let pose = Pose2::new(0.8 * t, 0.0, 0.0);
        let mut s = scan(pose, t, &room());
        s.odometry = Some(pose);
        let r = tracker.push(s).unwrap();
        for o in &r.objects {
            assert_eq!(
                o.state,
                TrackState::Tentative,
                "scan {k}: static clutter reported as {:?} (track {})",
                o.state,
                o.track
            );
            tentative += 1;
        }
    }
    assert!(
        tentative > 10,
        "the clutter was detected ({tentative} reports)"
    );
}
