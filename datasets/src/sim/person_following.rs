//! The `person-following` preset ([`crate::sim::Preset::PersonFollowing`]): a small
//! robot following a walking person outdoors, modelled on the person-following logs
//! of the `leg_tracker` benchmark (a Hokuyo-class scanner: 10 Hz, 5.6 m, about 245
//! beams over 86° in front of the robot, no wheel odometry).
//!
//! # Motions
//!
//! The followed person (object 0, so body and tracking id 1) starts 1.1-1.4 m ahead of
//! the robot and walks at 0.4-0.8 m/s on gentle arcs (curvature within ±0.12 /m) for
//! 2-5 s, then slows down (0.4 s at half speed), stands for 1-3 s, turns on the spot
//! by 40-90° to either side at 0.8-1.3 rad/s, waits 0.2-0.8 s and walks on (0.4 s at
//! half speed, then at the walking speed within 10 %, still 0.4-0.8 m/s) for 3-7 s
//! before the next stop, and so on for as long as the sequence lasts.
//!
//! The robot follows under a 10 Hz controller (its [`Path`] is one unicycle piece per
//! scan period, so every scan time lies exactly on it): the person's velocity along
//! the robot's heading plus 0.8 /s times the distance error as forward speed (at most
//! 1 m/s, accelerating by at most 1.5 m/s², never backwards, and never closer than
//! 1.05 m to the person), 1.5 /s times the person's bearing as turn rate (at most
//! 1 rad/s), standing while the person is more than 1 rad off its heading. So it
//! drives at the person's speed at the chosen following distance, slows and stops
//! with the person, turns towards the person when the person walks off in a new
//! direction and catches up.
//!
//! Up to three other pedestrians per started 20 s of sequence (a uniform draw of
//! 0-3) pass by at 1-1.5 m/s: crossing the robot's way 2.5-5 m ahead of it, or walking
//! the other way 1-2.5 m to its side, each placed by rejection so that it never comes
//! within 1.2 m of the robot's laser nor within 0.8 m of the followed person or
//! another passer.
//!
//! # Background
//!
//! Outdoors and sparse: along the robot's way (and 3 m before its start, 7 m beyond
//! its end), stations 1.2-2.4 m apart carry on either side a tree trunk (radius
//! 0.1-0.3 m, probability 0.45, 1-5 m to the side), a post (radius 0.05-0.1 m,
//! probability 0.3, 0.8-4 m to the side) and rarely (probability 0.05) a wall
//! segment of 2-6 m parallel to the way 2.5-5 m off, or a building corner there
//! (two walls of 2-5 m at a right angle). Wherever the robot, at one of its poses
//! every 0.2 s, would have no obstacle within 5.2 m and 38° of its heading (and not
//! within 12° of the followed person's bearing, where the person hides it), a tree or
//! post is added 2-5 m ahead, 15-35° off its heading on either side, so that nearly
//! every scan sees some background. Nothing is placed within 0.5 m of any moving
//! body's path over the sequence (walls 0.8 m), nor overlapping another obstacle.
//! Most of the 5.6 m view is empty (no return): the followed person and the
//! background return about a third of the beams (from a fifth to a half, sequence by
//! sequence).
//!
//! # Pairs
//!
//! A pair of [`crate::sim::simulate_pair`] is a stretch of 3-8 scan periods
//! (0.3-0.8 s) of a 24 s script like a sequence's, from a random scan time: the
//! person may be walking, stopping, standing or turning in it.

use super::scene::{
    leg_pair, ObjectKind, Path, Primitive, Scene, Script, ScriptedObject, Trajectory,
};
use super::uniform;
use nalgebra::{Point2, Vector2};
use pgm_scan::Pose2;
use rand::Rng;
use std::f64::consts::PI;

/// Seconds between two scans of the preset's scanner (10 Hz).
pub const SCAN_PERIOD: f64 = 0.1;
/// Beams of the preset's scanner.
pub const BEAMS: usize = 245;
/// Field of view of the preset's scanner in degrees.
pub const FIELD_OF_VIEW_DEGREES: f64 = 86.0;
/// Maximum range of the preset's scanner in metres.
pub const MAX_RANGE: f64 = 5.6;

/// Seconds of motion scripted for the scene of one pair ([`scene`]).
const PAIR_SCRIPT_SECONDS: f64 = 24.0;
/// The pairs of [`scene`] span this many scan periods, a uniform draw.
const PAIR_PERIODS: (usize, usize) = (3, 8);
/// The robot never comes closer than this to the followed person (m).
const MIN_DISTANCE: f64 = 1.05;
const MAX_ROBOT_SPEED: f64 = 1.0;
const MAX_ROBOT_ACCELERATION: f64 = 1.5;
const MAX_ROBOT_YAW_RATE: f64 = 1.0;
const DISTANCE_GAIN: f64 = 0.8;
const HEADING_GAIN: f64 = 1.5;
/// Bearing (rad) beyond which the robot turns on the spot.
const TURN_ON_THE_SPOT: f64 = 1.0;
/// Passers-by keep this far from the followed person and from each other (m)...
const PASSER_CLEARANCE: f64 = 0.8;
/// ... and this far from the robot's laser.
const PASSER_ROBOT_CLEARANCE: f64 = 1.2;
const OBSTACLE_CLEARANCE: f64 = 0.5;
/// A body farther than this from the robot (m) is never scanned, so clearances from it
/// do not matter then.
const SEEN_REACH: f64 = 10.0;
const PLACEMENT_ATTEMPTS: usize = 40;

/// The motion of the followed person, built piece by piece.
struct Plan {
    starts: Vec<f64>,
    pieces: Vec<Trajectory>,
    pose: Pose2,
    time: f64,
}

impl Plan {
    fn new(start: Pose2) -> Self {
        Plan {
            starts: Vec::new(),
            pieces: Vec::new(),
            pose: start,
            time: 0.0,
        }
    }

    fn push(&mut self, speed: f64, yaw_rate: f64, duration: f64) {
        let piece = Trajectory::unicycle(self.pose, speed, yaw_rate);
        self.starts.push(self.time);
        self.pieces.push(piece);
        self.pose = piece.pose_at(duration);
        self.time += duration;
    }

    fn into_path(self) -> Path {
        Path {
            starts: self.starts,
            pieces: self.pieces,
        }
    }
}

/// The followed person's walk over at least `duration` seconds (module docs); the
/// last piece, a walk, goes on for ever.
fn person_path<R: Rng>(rng: &mut R, start: Pose2, duration: f64) -> Path {
    let mut plan = Plan::new(start);
    let mut speed = uniform(rng, 0.4, 0.8);
    let mut walk = uniform(rng, 2.0, 5.0);
    loop {
        // One or two gentle arcs.
        let arcs = if rng.random_bool(0.5) { 1 } else { 2 };
        for _ in 0..arcs {
            let curvature = uniform(rng, -0.12, 0.12);
            plan.push(speed, curvature * speed, walk / arcs as f64);
        }
        if plan.time >= duration {
            break;
        }
        plan.push(speed / 2.0, 0.0, 0.4);
        plan.push(0.0, 0.0, uniform(rng, 1.0, 3.0));
        let angle = uniform(rng, 40f64.to_radians(), 90f64.to_radians());
        let rate = uniform(rng, 0.8, 1.3) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        plan.push(0.0, rate, angle / rate.abs());
        plan.push(0.0, 0.0, uniform(rng, 0.2, 0.8));
        speed = (speed * uniform(rng, 0.9, 1.1)).clamp(0.4, 0.8);
        plan.push(speed / 2.0, 0.0, 0.4);
        walk = uniform(rng, 3.0, 7.0);
    }
    plan.into_path()
}

/// The robot's path following `person` at `distance` for `steps` scan periods from
/// `start` (module docs): one unicycle piece per period.
fn robot_path(person: &Path, start: Pose2, distance: f64, steps: usize) -> Path {
    let mut pose = start;
    let mut speed = person.speed_before(SCAN_PERIOD);
    let mut starts = Vec::with_capacity(steps);
    let mut pieces = Vec::with_capacity(steps);
    for k in 0..steps {
        let t = k as f64 * SCAN_PERIOD;
        let p = person.pose_at(t);
        let ahead = person.pose_at(t + SCAN_PERIOD);
        let velocity = (ahead.translation() - p.translation()) / SCAN_PERIOD;
        let relative = pose
            .inverse()
            .transform_point(&Point2::from(p.translation()));
        let range = relative.coords.norm();
        let bearing = relative.y.atan2(relative.x);
        let heading = Vector2::new(pose.theta().cos(), pose.theta().sin());
        let mut command = velocity.dot(&heading) + DISTANCE_GAIN * (range - distance);
        if bearing.abs() > TURN_ON_THE_SPOT {
            command = 0.0;
        }
        let step = MAX_ROBOT_ACCELERATION * SCAN_PERIOD;
        command = command.clamp(speed - step, speed + step);
        // Never closer than MIN_DISTANCE to where the person will be (braking at once).
        let next = pose
            .inverse()
            .transform_point(&Point2::from(ahead.translation()));
        let room = (next.x - MIN_DISTANCE) / SCAN_PERIOD;
        command = command.min(room).clamp(0.0, MAX_ROBOT_SPEED);
        let yaw_rate = (HEADING_GAIN * bearing).clamp(-MAX_ROBOT_YAW_RATE, MAX_ROBOT_YAW_RATE);
        let piece = Trajectory::unicycle(pose, command, yaw_rate);
        starts.push(t);
        pieces.push(piece);
        pose = piece.pose_at(SCAN_PERIOD);
        speed = command;
    }
    Path { starts, pieces }
}

/// Positions of a body every scan period over `steps` periods.
fn samples(path: &Path, steps: usize) -> Vec<Point2<f64>> {
    (0..=steps)
        .map(|k| Point2::from(path.pose_at(k as f64 * SCAN_PERIOD).translation()))
        .collect()
}

/// A pedestrian passing the robot around a random time (module docs), or `None` when
/// the attempt comes too close to a body already placed.
fn passer<R: Rng>(
    rng: &mut R,
    robot: &Path,
    bodies: &[Vec<Point2<f64>>],
    steps: usize,
) -> Option<Path> {
    let duration = steps as f64 * SCAN_PERIOD;
    let when = uniform(rng, 1.0, (duration - 1.0).max(1.0));
    let r = robot.pose_at(when);
    let speed = uniform(rng, 1.0, 1.5);
    let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let (meet, heading) = if rng.random_bool(0.5) {
        // Crossing the robot's way ahead of it.
        let ahead = uniform(rng, 2.5, 5.0);
        let off = uniform(rng, -1.0, 1.0);
        let h = r.theta() + side * PI / 2.0 + uniform(rng, -0.3, 0.3);
        (Point2::new(ahead, off), h)
    } else {
        // Walking the other way beside it.
        let ahead = uniform(rng, 1.5, 4.5);
        let off = side * uniform(rng, 1.0, 2.5);
        let h = r.theta() + PI + uniform(rng, -0.15, 0.15);
        (Point2::new(ahead, off), h)
    };
    let meet = r.transform_point(&meet);
    let direction = Vector2::new(heading.cos(), heading.sin());
    let start = meet - direction * speed * when;
    let path = Path::single(Trajectory::unicycle(
        Pose2::new(start.x, start.y, heading),
        speed,
        0.0,
    ));
    let mine = samples(&path, steps);
    // Only where it can be seen matters: while it is within SEEN_REACH of the robot
    // (bodies[0]).
    let window = near_robot(&mine, &bodies[0]);
    let clear = bodies.iter().enumerate().all(|(i, other)| {
        let clearance = if i == 0 {
            PASSER_ROBOT_CLEARANCE
        } else {
            PASSER_CLEARANCE
        };
        window
            .clone()
            .all(|k| (mine[k] - other[k]).norm() >= clearance)
    });
    clear.then_some(path)
}

/// The scan indices from the first to the last at which a body at `positions` is
/// within [`SEEN_REACH`] of the robot at `robot` (empty when never).
fn near_robot(positions: &[Point2<f64>], robot: &[Point2<f64>]) -> std::ops::Range<usize> {
    let near = |k: &usize| (positions[*k] - robot[*k]).norm() < SEEN_REACH;
    let n = positions.len().min(robot.len());
    match (0..n).find(near) {
        Some(first) => first..(first..n).rfind(near).map_or(first, |last| last + 1),
        None => 0..0,
    }
}

/// Points in square cells, for queries of what lies near a point or a segment.
struct PointGrid {
    cells: std::collections::HashMap<(i64, i64), Vec<Point2<f64>>>,
}

/// Side of a [`PointGrid`] cell (m).
const GRID_CELL: f64 = 1.0;

impl PointGrid {
    fn new(points: impl IntoIterator<Item = Point2<f64>>) -> Self {
        let mut cells: std::collections::HashMap<(i64, i64), Vec<Point2<f64>>> = Default::default();
        for p in points {
            cells.entry(Self::cell(&p)).or_default().push(p);
        }
        PointGrid { cells }
    }

    fn cell(p: &Point2<f64>) -> (i64, i64) {
        (
            (p.x / GRID_CELL).floor() as i64,
            (p.y / GRID_CELL).floor() as i64,
        )
    }

    /// Whether every point lies at least `clearance` from `primitive`.
    fn clear_of(&self, primitive: &Primitive, clearance: f64) -> bool {
        let (lo, hi) = match *primitive {
            Primitive::Circle { center, radius } => {
                let r = Vector2::new(radius, radius);
                (center - r, center + r)
            }
            Primitive::Segment { start, end } => (start.inf(&end), start.sup(&end)),
        };
        let pad = Vector2::new(clearance, clearance);
        let (a, b) = (Self::cell(&(lo - pad)), Self::cell(&(hi + pad)));
        (a.0..=b.0).all(|i| {
            (a.1..=b.1).all(|j| {
                self.cells.get(&(i, j)).is_none_or(|points| {
                    points
                        .iter()
                        .all(|p| super::scene::distance_to(primitive, p) >= clearance)
                })
            })
        })
    }
}

/// The static obstacles placed so far, for overlap checks.
struct Background<'a> {
    primitives: Vec<Primitive>,
    circles: Vec<(Point2<f64>, f64)>,
    /// The moving bodies' positions over the sequence (where they can be seen).
    bodies: &'a PointGrid,
}

impl Background<'_> {
    /// Whether a circle of `radius` at `centre` keeps clear of every path and obstacle.
    fn circle_fits(&self, centre: Point2<f64>, radius: f64) -> bool {
        self.bodies
            .clear_of(&Primitive::circle(centre, radius), OBSTACLE_CLEARANCE)
            && self
                .circles
                .iter()
                .all(|(c, r)| (c - centre).norm() >= r + radius + 0.2)
            && self.primitives.iter().all(|p| match p {
                Primitive::Segment { .. } => super::scene::distance_to(p, &centre) >= radius + 0.2,
                Primitive::Circle { .. } => true,
            })
    }

    fn segment_fits(&self, a: Point2<f64>, b: Point2<f64>) -> bool {
        let s = Primitive::segment(a, b);
        self.bodies.clear_of(&s, OBSTACLE_CLEARANCE + 0.3)
            && self
                .circles
                .iter()
                .all(|(c, r)| super::scene::distance_to(&s, c) >= r + 0.2)
    }

    fn add_circle(&mut self, centre: Point2<f64>, radius: f64) {
        if self.circle_fits(centre, radius) {
            self.primitives.push(Primitive::circle(centre, radius));
            self.circles.push((centre, radius));
        }
    }

    /// Adds the walls of `corners` (a polyline) when all of them fit.
    fn add_walls(&mut self, corners: &[Point2<f64>]) {
        if corners.windows(2).all(|w| self.segment_fits(w[0], w[1])) {
            for w in corners.windows(2) {
                self.primitives.push(Primitive::segment(w[0], w[1]));
            }
        }
    }
}

/// Stations along the robot's way `way` (positions every scan period), every
/// 1.2-2.4 m of arc length, from 3 m before its start to 7 m beyond its end: each a
/// point and the unit direction of the way there.
fn stations<R: Rng>(rng: &mut R, way: &[Point2<f64>]) -> Vec<(Point2<f64>, Vector2<f64>)> {
    // The way with the standstills left out.
    let mut points = vec![way[0]];
    for p in &way[1..] {
        if (p - points[points.len() - 1]).norm() > 0.02 {
            points.push(*p);
        }
    }
    let direction_at = |i: usize| -> Vector2<f64> {
        let (a, b) = if i + 1 < points.len() {
            (points[i], points[i + 1])
        } else {
            (points[i.saturating_sub(1)], points[i])
        };
        let d = b - a;
        if d.norm() > 1e-9 {
            d / d.norm()
        } else {
            Vector2::new(1.0, 0.0)
        }
    };
    let mut out = Vec::new();
    let first = direction_at(0);
    let mut s = -3.0 + uniform(rng, 0.0, 1.2);
    while s < 0.0 {
        out.push((points[0] + first * s, first));
        s += uniform(rng, 1.2, 2.4);
    }
    let mut travelled = 0.0;
    for i in 0..points.len().saturating_sub(1) {
        let d = direction_at(i);
        let length = (points[i + 1] - points[i]).norm();
        while s < travelled + length {
            out.push((points[i] + d * (s - travelled), d));
            s += uniform(rng, 1.2, 2.4);
        }
        travelled += length;
    }
    let last = direction_at(points.len() - 1);
    let end = points[points.len() - 1];
    while s < travelled + 7.0 {
        out.push((end + last * (s - travelled), last));
        s += uniform(rng, 1.2, 2.4);
    }
    out
}

/// Whether some obstacle of `primitives` has a point well inside the view of a
/// sensor at `sensor` and not behind the followed person at `person` (world frame):
/// within 5.2 m and 38° of the sensor's heading, 12° or more off the person's bearing
/// (surface points of segments every 0.2 m, circles by their centre).
fn something_in_view(primitives: &[Primitive], sensor: &Pose2, person: &Point2<f64>) -> bool {
    let to_sensor = sensor.inverse();
    let p = to_sensor.transform_point(person);
    let person_bearing = p.y.atan2(p.x);
    let inside = |w: Point2<f64>| {
        let q = to_sensor.transform_point(&w);
        let range = q.coords.norm();
        let bearing = q.y.atan2(q.x);
        range > 0.5
            && range < MAX_RANGE - 0.4
            && bearing.abs() < 38f64.to_radians()
            && (bearing - person_bearing).abs() >= 12f64.to_radians()
    };
    primitives.iter().any(|p| match *p {
        Primitive::Circle { center, .. } => inside(center),
        Primitive::Segment { start, end } => {
            let n = ((end - start).norm() / 0.2).ceil().max(1.0) as usize;
            (0..=n).any(|i| inside(start + (end - start) * (i as f64 / n as f64)))
        }
    })
}

/// The sparse outdoor background along the robot's way (module docs); `views` are
/// the robot's poses and the followed person's positions every 0.2 s, each of which
/// gets something in view.
fn background<R: Rng>(
    rng: &mut R,
    way: &[Point2<f64>],
    bodies: &PointGrid,
    views: &[(Pose2, Point2<f64>)],
) -> Vec<Primitive> {
    let mut bg = Background {
        primitives: Vec::new(),
        circles: Vec::new(),
        bodies,
    };
    for (at, along) in stations(rng, way) {
        let left = Vector2::new(-along.y, along.x);
        for side in [1.0, -1.0] {
            let out = left * side;
            if rng.random_bool(0.45) {
                let r = uniform(rng, 0.1, 0.3);
                let c = at + out * uniform(rng, 1.0, 5.0) + along * uniform(rng, -0.6, 0.6);
                bg.add_circle(c, r);
            }
            if rng.random_bool(0.3) {
                let r = uniform(rng, 0.05, 0.1);
                let c = at + out * uniform(rng, 0.8, 4.0) + along * uniform(rng, -0.6, 0.6);
                bg.add_circle(c, r);
            }
            if rng.random_bool(0.05) {
                let corner = at + out * uniform(rng, 2.5, 5.0);
                let length = uniform(rng, 2.0, 6.0);
                if rng.random_bool(0.5) {
                    let shift = uniform(rng, -0.5, 0.5) * length;
                    bg.add_walls(&[
                        corner + along * (shift - length / 2.0),
                        corner + along * (shift + length / 2.0),
                    ]);
                } else {
                    // A building corner: one wall along the way (backwards or
                    // forwards), one away from it.
                    let back = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                    let away = uniform(rng, 2.0, 5.0);
                    let along_length = length.min(5.0);
                    bg.add_walls(&[
                        corner + along * (back * along_length),
                        corner,
                        corner + out * away,
                    ]);
                }
            }
        }
    }
    // Where the view would be empty, a tree or a post somewhere in it.
    for (sensor, person) in views {
        if something_in_view(&bg.primitives, sensor, person) {
            continue;
        }
        for _ in 0..PLACEMENT_ATTEMPTS {
            let range = uniform(rng, 2.0, 5.0);
            let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let bearing = side * uniform(rng, 15f64.to_radians(), 35f64.to_radians());
            let r = if rng.random_bool(0.6) {
                uniform(rng, 0.1, 0.3)
            } else {
                uniform(rng, 0.05, 0.1)
            };
            let c =
                sensor.transform_point(&Point2::new(range * bearing.cos(), range * bearing.sin()));
            if bg.circle_fits(c, r) && something_in_view(&[Primitive::circle(c, r)], sensor, person)
            {
                bg.add_circle(c, r);
                break;
            }
        }
    }
    bg.primitives
}

/// The script of the preset over `scans` scans (module docs), scanned every
/// [`SCAN_PERIOD`]: the followed person is object 0 (body and tracking id 1), the
/// passers-by follow.
pub(crate) fn script<R: Rng>(rng: &mut R, scans: usize) -> Script {
    // One second more than the sequence, for the objects' clearances.
    let steps = scans + 10;
    let duration = steps as f64 * SCAN_PERIOD;
    let distance = uniform(rng, 1.1, 1.4);
    let person_start = Pose2::new(distance, uniform(rng, -0.1, 0.1), uniform(rng, -0.05, 0.05));
    let person = person_path(rng, person_start, duration);
    let stride = uniform(rng, 0.1, 0.3);
    let leg = uniform(rng, 0.06, 0.08);
    let robot = robot_path(&person, Pose2::identity(), distance, steps);
    let mut bodies = vec![samples(&robot, steps), samples(&person, steps)];
    let mut objects = vec![ScriptedObject {
        kind: ObjectKind::Pedestrian,
        shape: leg_pair(stride, leg),
        path: person,
    }];
    let blocks = scans.div_ceil(200).max(1);
    for _ in 0..blocks {
        let n = rng.random_range(0..=3);
        for _ in 0..n {
            for _ in 0..PLACEMENT_ATTEMPTS {
                let Some(path) = passer(rng, &robot, &bodies, steps) else {
                    continue;
                };
                let stride = uniform(rng, 0.0, 0.35);
                let leg = uniform(rng, 0.06, 0.08);
                bodies.push(samples(&path, steps));
                objects.push(ScriptedObject {
                    kind: ObjectKind::Pedestrian,
                    shape: leg_pair(stride, leg),
                    path,
                });
                break;
            }
        }
    }
    // The robot and the person everywhere, the passers-by where they can be seen.
    let seen = bodies.iter().enumerate().flat_map(|(i, b)| {
        let window = if i < 2 {
            0..b.len()
        } else {
            near_robot(b, &bodies[0])
        };
        b[window].iter().copied()
    });
    let all = PointGrid::new(seen);
    let views: Vec<(Pose2, Point2<f64>)> = (0..=steps)
        .step_by(2)
        .map(|k| (robot.pose_at(k as f64 * SCAN_PERIOD), bodies[1][k]))
        .collect();
    let background = background(rng, &bodies[0], &all, &views);
    Script {
        background,
        objects,
        ego: robot,
        period: SCAN_PERIOD,
    }
}

/// The scene of one pair: a stretch of 3-8 scan periods (0.3-0.8 s) of a 24 s script,
/// starting at a random scan time.
pub(crate) fn scene<R: Rng>(rng: &mut R) -> Scene {
    let scans = (PAIR_SCRIPT_SECONDS / SCAN_PERIOD).round() as usize;
    let script = script(rng, scans);
    let periods = rng.random_range(PAIR_PERIODS.0..=PAIR_PERIODS.1);
    let first = rng.random_range(0..=scans - periods);
    script.scene_at(
        first as f64 * SCAN_PERIOD,
        periods as f64 * SCAN_PERIOD,
        f64::INFINITY,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::pair_rng;

    #[test]
    fn the_robot_keeps_its_distance_and_the_person_in_view() {
        let half_view = (FIELD_OF_VIEW_DEGREES / 2.0).to_radians();
        for i in 0..30 {
            let mut rng = pair_rng(9, i);
            let script = script(&mut rng, 300);
            let person = &script.objects[0].path;
            let (mut low, mut high, mut outside) = (f64::INFINITY, 0.0f64, 0);
            for k in 0..300 {
                let t = k as f64 * SCAN_PERIOD;
                let robot = script.ego.pose_at(t);
                let p = robot
                    .inverse()
                    .transform_point(&Point2::from(person.pose_at(t).translation()));
                let d = p.coords.norm();
                low = low.min(d);
                high = high.max(d);
                outside += usize::from(p.y.atan2(p.x).abs() > half_view - 0.1);
                assert!(script.ego.speed_before(t + 0.05) <= MAX_ROBOT_SPEED + 1e-12);
            }
            assert!(low >= MIN_DISTANCE - 0.05, "script {i}: {low} m");
            assert!(high <= 2.0, "script {i}: {high} m");
            assert!(outside <= 3, "script {i}: {outside} scans off the view");
        }
    }
}
