//! Scenes of the plane: the static background (walls, parked cars, poles, trees,
//! bushes) as world-frame primitives, moving objects as body-frame shapes on exactly
//! known trajectories, and the ego vehicle's trajectory.
//!
//! Everything the laser can hit is a [`Primitive`]: a line segment or a circle. A
//! [`Scene`] is built either by a preset ([`crate::sim::Preset::scene`]) or by hand
//! (tests use hand-made scenes to check occlusion), and turned into a scan pair with
//! ground truth by [`crate::sim::simulate_scene`].

use nalgebra::{Point2, Vector2};
use pgm_scan::Pose2;
use serde::{Deserialize, Serialize};

/// One surface element the laser can hit, in some frame (world or body).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Primitive {
    /// A line segment between two points (a wall, one side of a car).
    Segment {
        /// First end point.
        start: Point2<f64>,
        /// Second end point.
        end: Point2<f64>,
    },
    /// A circle (a pole, a tree trunk, a leg).
    Circle {
        /// Centre.
        center: Point2<f64>,
        /// Radius in metres.
        radius: f64,
    },
}

impl Primitive {
    /// The segment from `start` to `end`.
    pub fn segment(start: Point2<f64>, end: Point2<f64>) -> Self {
        Primitive::Segment { start, end }
    }

    /// The circle around `center` with `radius`.
    pub fn circle(center: Point2<f64>, radius: f64) -> Self {
        Primitive::Circle { center, radius }
    }

    /// The primitive moved by the rigid motion `pose` (`pose * p` for every point).
    pub fn transformed(&self, pose: &Pose2) -> Primitive {
        match *self {
            Primitive::Segment { start, end } => Primitive::Segment {
                start: pose.transform_point(&start),
                end: pose.transform_point(&end),
            },
            Primitive::Circle { center, radius } => Primitive::Circle {
                center: pose.transform_point(&center),
                radius,
            },
        }
    }
}

/// Closed polygon through `corners` (in order) as segments.
pub fn polygon(corners: &[Point2<f64>]) -> Vec<Primitive> {
    let n = corners.len();
    (0..n)
        .filter(|&i| n > 1 && (corners[(i + 1) % n] - corners[i]).norm() > 1e-9)
        .map(|i| Primitive::segment(corners[i], corners[(i + 1) % n]))
        .collect()
}

/// A `length` × `width` rectangle centred at the origin, length along x (a car seen
/// from above in its body frame: x forward, y left).
pub fn rectangle(length: f64, width: f64) -> Vec<Primitive> {
    let (a, b) = (length / 2.0, width / 2.0);
    polygon(&[
        Point2::new(a, b),
        Point2::new(-a, b),
        Point2::new(-a, -b),
        Point2::new(a, -b),
    ])
}

/// A pedestrian's legs at laser height: two circles of `radius`, `stride` apart along
/// the walking direction (x) and `0.18` m apart sideways. The legs do not swing: the
/// pair moves rigidly so that one rigid motion is the exact ground truth of the whole
/// pedestrian between the two scans.
pub fn leg_pair(stride: f64, radius: f64) -> Vec<Primitive> {
    vec![
        Primitive::circle(Point2::new(stride / 2.0, 0.09), radius),
        Primitive::circle(Point2::new(-stride / 2.0, -0.09), radius),
    ]
}

/// What a moving object is; its name goes into [`crate::ClusterMotion::kind`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ObjectKind {
    /// A car (rectangle of about 4.5 × 1.8 m).
    Car,
    /// A pedestrian (a rigid pair of legs).
    Pedestrian,
}

impl ObjectKind {
    /// The kind string used in ground truth: `"car"` or `"pedestrian"`.
    pub fn name(&self) -> &'static str {
        match self {
            ObjectKind::Car => "car",
            ObjectKind::Pedestrian => "pedestrian",
        }
    }
}

/// Motion at constant speed and constant turn rate (a unicycle), integrated exactly:
/// straight lines when `yaw_rate` is zero, circular arcs otherwise. A lateral speed
/// makes it any constant motion of the plane (a constant body twist), which is what
/// joins two arbitrary poses ([`Trajectory::between`]); the presets' objects have
/// none.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// Pose (body frame in world frame) at time 0, the reference scan's time.
    pub start: Pose2,
    /// Speed along the heading in m/s (negative drives backwards).
    pub speed: f64,
    /// Turn rate in rad/s (positive turns left, counter-clockwise).
    pub yaw_rate: f64,
    /// Speed across the heading in m/s, to the left (body y); 0 for a unicycle.
    #[serde(default)]
    pub lateral_speed: f64,
}

impl Trajectory {
    /// A unicycle (no lateral speed) at `start` at time 0, driving at `speed` and
    /// turning at `yaw_rate`.
    pub fn unicycle(start: Pose2, speed: f64, yaw_rate: f64) -> Self {
        Trajectory {
            start,
            speed,
            yaw_rate,
            lateral_speed: 0.0,
        }
    }

    /// A body that stays at `pose`.
    pub fn stationary(pose: Pose2) -> Self {
        Trajectory::unicycle(pose, 0.0, 0.0)
    }

    /// The constant motion that is at `from` at time 0 and at `to` at time `duration`
    /// (the twist of `from⁻¹ · to` over `duration`; the rotation is taken the short
    /// way, within ±π). `duration` must be positive.
    pub fn between(from: Pose2, to: Pose2, duration: f64) -> Self {
        let d = from.between(&to);
        let (dx, dy, dtheta) = (d.x(), d.y(), d.theta());
        // The displacement of a constant twist (v, w, ω) over T is V(ωT) · (v, w) T
        // with V(θ) = [[a, −b], [b, a]], a = sin θ/θ, b = (1 − cos θ)/θ.
        let (a, b) = twist_factors(dtheta);
        let det = a * a + b * b;
        let (vx, vy) = ((a * dx + b * dy) / det, (a * dy - b * dx) / det);
        Trajectory {
            start: from,
            speed: vx / duration,
            yaw_rate: if dtheta.abs() < 1e-12 {
                0.0
            } else {
                dtheta / duration
            },
            lateral_speed: vy / duration,
        }
    }

    /// Speed of the body's origin over the ground (m/s).
    pub fn ground_speed(&self) -> f64 {
        self.speed.hypot(self.lateral_speed)
    }

    /// Pose of the body in the world frame at time `t` (seconds after the reference scan).
    pub fn pose_at(&self, t: f64) -> Pose2 {
        let (x0, y0, h0) = (self.start.x(), self.start.y(), self.start.theta());
        let h1 = h0 + self.yaw_rate * t;
        let w = self.lateral_speed;
        if (self.yaw_rate * t).abs() < 1e-12 {
            let d = self.speed * t;
            if w == 0.0 {
                Pose2::new(x0 + d * h0.cos(), y0 + d * h0.sin(), h0)
            } else {
                let e = w * t;
                let (s, c) = h0.sin_cos();
                Pose2::new(x0 + d * c - e * s, y0 + d * s + e * c, h1)
            }
        } else if w == 0.0 {
            let r = self.speed / self.yaw_rate;
            Pose2::new(
                x0 + r * (h1.sin() - h0.sin()),
                y0 - r * (h1.cos() - h0.cos()),
                h1,
            )
        } else {
            // V(θ) · (v, w) t in the start frame (see `between`), which stays exact
            // for small turns.
            let (a, b) = twist_factors(self.yaw_rate * t);
            let (u, v) = ((a * self.speed - b * w) * t, (b * self.speed + a * w) * t);
            let (s, c) = h0.sin_cos();
            Pose2::new(x0 + u * c - v * s, y0 + u * s + v * c, h1)
        }
    }
}

/// `(sin θ/θ, (1 − cos θ)/θ)`, exact for small `θ` too.
fn twist_factors(theta: f64) -> (f64, f64) {
    if theta.abs() < 1e-6 {
        (1.0 - theta * theta / 6.0, theta / 2.0)
    } else {
        let half = (theta / 2.0).sin();
        (theta.sin() / theta, 2.0 * half * half / theta)
    }
}

/// A motion made of [`Trajectory`] pieces one after the other: piece `i` holds from
/// `starts[i]` (s) to the next piece's start, the last one for ever, the first one also
/// before its start. Each piece's `start` is the pose at its own start time, so
/// [`Path::pose_at`] is exact wherever the pieces join as they should.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Path {
    /// When each piece starts (s), increasing.
    pub starts: Vec<f64>,
    /// The pieces, each with time measured from its own start.
    pub pieces: Vec<Trajectory>,
}

impl Path {
    /// A path of one piece from time 0.
    pub fn single(trajectory: Trajectory) -> Self {
        Path {
            starts: vec![0.0],
            pieces: vec![trajectory],
        }
    }

    /// The index of the piece that holds at `t`. With `before`, a start exactly at `t`
    /// belongs to the piece before it (the motion that arrives at `t`).
    fn piece(&self, t: f64, before: bool) -> usize {
        let n = if before {
            self.starts.partition_point(|&s| s < t)
        } else {
            self.starts.partition_point(|&s| s <= t)
        };
        n.saturating_sub(1)
    }

    /// Pose at time `t`.
    pub fn pose_at(&self, t: f64) -> Pose2 {
        let i = self.piece(t, false);
        self.pieces[i].pose_at(t - self.starts[i])
    }

    /// Speed over the ground of the motion that arrives at `t` (m/s).
    pub fn speed_before(&self, t: f64) -> f64 {
        self.pieces[self.piece(t, true)].ground_speed()
    }

    /// The motion from time `t0` over `duration`: the piece that holds there when both
    /// ends lie in one piece, else the constant motion between the two poses
    /// ([`Trajectory::between`]).
    pub fn from_time(&self, t0: f64, duration: f64) -> Trajectory {
        let i = self.piece(t0, false);
        if self.piece(t0 + duration, true) == i {
            let piece = self.pieces[i];
            Trajectory {
                start: piece.pose_at(t0 - self.starts[i]),
                ..piece
            }
        } else {
            Trajectory::between(self.pose_at(t0), self.pose_at(t0 + duration), duration)
        }
    }
}

/// An object that moves between the two scans (its points get a label `>= 1`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MovingObject {
    /// Car or pedestrian.
    pub kind: ObjectKind,
    /// Outline in the body frame.
    pub shape: Vec<Primitive>,
    /// Where the body is over time.
    pub trajectory: Trajectory,
}

impl MovingObject {
    /// A car of `length` × `width` on `trajectory`.
    pub fn car(length: f64, width: f64, trajectory: Trajectory) -> Self {
        MovingObject {
            kind: ObjectKind::Car,
            shape: rectangle(length, width),
            trajectory,
        }
    }

    /// A pedestrian (see [`leg_pair`]) on `trajectory`.
    pub fn pedestrian(stride: f64, leg_radius: f64, trajectory: Trajectory) -> Self {
        MovingObject {
            kind: ObjectKind::Pedestrian,
            shape: leg_pair(stride, leg_radius),
            trajectory,
        }
    }
}

/// A complete scene: background, moving objects, the ego vehicle and the time between
/// the reference scan (time 0) and the current scan (time `interval`).
///
/// The laser sits at the origin of the ego body frame (x forward, y left), so the ego
/// trajectory is also the sensor trajectory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// Static surfaces in the world frame; all of them form cluster 0.
    pub background: Vec<Primitive>,
    /// Moving objects, in scene order.
    pub objects: Vec<MovingObject>,
    /// The ego vehicle (and laser) trajectory.
    pub ego: Trajectory,
    /// Seconds between the reference scan and the current scan.
    pub interval: f64,
}

impl Scene {
    /// Pose of the laser in the world frame at the reference scan.
    pub fn reference_sensor(&self) -> Pose2 {
        self.ego.pose_at(0.0)
    }

    /// Pose of the laser in the world frame at the current scan.
    pub fn current_sensor(&self) -> Pose2 {
        self.ego.pose_at(self.interval)
    }

    /// Pose of body `body` (0 = background, `i + 1` = `objects[i]`) at time `t`.
    pub fn body_pose(&self, body: usize, t: f64) -> Pose2 {
        if body == 0 {
            Pose2::identity()
        } else {
            self.objects[body - 1].trajectory.pose_at(t)
        }
    }

    /// The true motion of body `body` in the project's convention: it maps a point of
    /// that body seen in the current sensor frame onto the same surface point in the
    /// reference sensor frame, `S_ref⁻¹ · B(0) · B(interval)⁻¹ · S_cur`. For the
    /// background (`B` constant) this is the ego-motion `S_ref⁻¹ · S_cur`.
    pub fn body_motion(&self, body: usize) -> Pose2 {
        let reference_sensor = self.reference_sensor();
        let current_sensor = self.current_sensor();
        let b0 = self.body_pose(body, 0.0);
        let b1 = self.body_pose(body, self.interval);
        reference_sensor
            .inverse()
            .compose(&b0)
            .compose(&b1.inverse())
            .compose(&current_sensor)
    }

    /// Speed over the ground (m/s) of each body (0 = background, then the objects).
    pub fn speeds(&self) -> Vec<f64> {
        std::iter::once(0.0)
            .chain(self.objects.iter().map(|o| o.trajectory.ground_speed()))
            .collect()
    }

    /// Every primitive of the scene at time `t` in the world frame, with its body index.
    pub fn world_primitives(&self, t: f64) -> Vec<(Primitive, usize)> {
        let mut out: Vec<(Primitive, usize)> = self.background.iter().map(|p| (*p, 0)).collect();
        for (i, object) in self.objects.iter().enumerate() {
            let pose = object.trajectory.pose_at(t);
            out.extend(object.shape.iter().map(|p| (p.transformed(&pose), i + 1)));
        }
        out
    }
}

/// A moving object over a whole sequence of scans (see [`Script`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScriptedObject {
    /// Car or pedestrian.
    pub kind: ObjectKind,
    /// Outline in the body frame.
    pub shape: Vec<Primitive>,
    /// Where the body is over time.
    pub path: Path,
}

/// A scene over a whole sequence of scans taken `period` seconds apart, from time 0:
/// the static background, the moving objects and the ego vehicle on [`Path`]s. Object
/// `i` is body `i + 1` in every pair's [`Scene`] ([`Script::scene_at`]), so its
/// identity is the same all along the sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Script {
    /// Static surfaces in the world frame.
    pub background: Vec<Primitive>,
    /// Moving objects, in scene order.
    pub objects: Vec<ScriptedObject>,
    /// The ego vehicle (and laser).
    pub ego: Path,
    /// Seconds between consecutive scans.
    pub period: f64,
}

impl Script {
    /// The script of a two-scan scene whose motions go on unchanged, scanned every
    /// `period` seconds.
    pub fn from_scene(scene: &Scene, period: f64) -> Self {
        Script {
            background: scene.background.clone(),
            objects: scene
                .objects
                .iter()
                .map(|o| ScriptedObject {
                    kind: o.kind,
                    shape: o.shape.clone(),
                    path: Path::single(o.trajectory),
                })
                .collect(),
            ego: Path::single(scene.ego),
            period,
        }
    }

    /// The two-scan scene from time `t0` over `interval` seconds: every body's motion
    /// over that time ([`Path::from_time`]), and the background surfaces that come
    /// within `reach` metres of the sensor at either time (all of them for an infinite
    /// `reach`; a surface farther away than the laser's maximum range is never hit, so
    /// leaving it out changes nothing).
    pub fn scene_at(&self, t0: f64, interval: f64, reach: f64) -> Scene {
        let ego = self.ego.from_time(t0, interval);
        let sensors =
            [ego.pose_at(0.0), ego.pose_at(interval)].map(|p| Point2::from(p.translation()));
        let background = self
            .background
            .iter()
            .filter(|p| reach.is_infinite() || sensors.iter().any(|s| distance_to(p, s) <= reach))
            .copied()
            .collect();
        Scene {
            background,
            objects: self
                .objects
                .iter()
                .map(|o| MovingObject {
                    kind: o.kind,
                    shape: o.shape.clone(),
                    trajectory: o.path.from_time(t0, interval),
                })
                .collect(),
            ego,
            interval,
        }
    }

    /// Speed over the ground (m/s) of each body (0 = background, then the objects)
    /// in the motion that arrives at time `t`.
    pub fn speeds_before(&self, t: f64) -> Vec<f64> {
        std::iter::once(0.0)
            .chain(self.objects.iter().map(|o| o.path.speed_before(t)))
            .collect()
    }
}

/// Distance (m) from `point` to the nearest point of `primitive` (0 inside a circle).
pub fn distance_to(primitive: &Primitive, point: &Point2<f64>) -> f64 {
    match *primitive {
        Primitive::Segment { start, end } => {
            let e = end - start;
            let length2 = e.norm_squared();
            let u = if length2 > 0.0 {
                ((point - start).dot(&e) / length2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (start + e * u - point).norm()
        }
        Primitive::Circle { center, radius } => ((center - point).norm() - radius).max(0.0),
    }
}

/// Unit vector at heading `angle`.
pub(crate) fn heading(angle: f64) -> Vector2<f64> {
    Vector2::new(angle.cos(), angle.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_and_arc_trajectories() {
        let straight = Trajectory {
            start: Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2),
            speed: 2.0,
            yaw_rate: 0.0,
            lateral_speed: 0.0,
        };
        let p = straight.pose_at(1.5);
        assert!((p.x() - 1.0).abs() < 1e-12 && (p.y() - 5.0).abs() < 1e-12);

        // A quarter circle of radius 4 to the left from the origin heading +x ends at (4, 4).
        let arc = Trajectory {
            start: Pose2::identity(),
            speed: 4.0,
            yaw_rate: 1.0,
            lateral_speed: 0.0,
        };
        let q = arc.pose_at(std::f64::consts::FRAC_PI_2);
        assert!((q.x() - 4.0).abs() < 1e-12, "{q:?}");
        assert!((q.y() - 4.0).abs() < 1e-12, "{q:?}");
        assert!((q.theta() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn between_joins_any_two_poses_and_paths_are_continuous() {
        let from = Pose2::new(1.0, -2.0, 0.7);
        for to in [
            Pose2::new(1.3, -1.1, 2.9),
            Pose2::new(0.2, -2.0, 0.7),
            Pose2::new(1.0, -2.0, -1.0),
            Pose2::new(1.0 + 1e-3, -2.0, 0.7 + 1e-11),
        ] {
            let t = Trajectory::between(from, to, 0.3);
            let end = t.pose_at(0.3);
            assert!(end.translation_error(&to) < 1e-12, "{end:?} vs {to:?}");
            assert!(end.rotation_error(&to) < 1e-12, "{end:?} vs {to:?}");
        }
        // A unicycle's own end pose gives it back, without lateral speed.
        let arc = Trajectory {
            start: from,
            speed: 0.8,
            yaw_rate: 0.4,
            lateral_speed: 0.0,
        };
        let again = Trajectory::between(from, arc.pose_at(0.5), 0.5);
        assert!((again.speed - 0.8).abs() < 1e-12 && again.lateral_speed.abs() < 1e-12);
        assert!((again.yaw_rate - 0.4).abs() < 1e-12);
        // A path of two pieces: within one piece its motion is that piece; across the
        // joint it meets both ends.
        let second = Trajectory {
            start: arc.pose_at(1.0),
            speed: 0.0,
            yaw_rate: -1.0,
            lateral_speed: 0.0,
        };
        let path = Path {
            starts: vec![0.0, 1.0],
            pieces: vec![arc, second],
        };
        assert_eq!(path.from_time(0.2, 0.8).speed, 0.8);
        assert_eq!(path.speed_before(1.0), 0.8);
        assert_eq!(path.speed_before(1.1), 0.0);
        let across = path.from_time(0.5, 1.0);
        let end = across.pose_at(1.0);
        assert!(end.translation_error(&path.pose_at(1.5)) < 1e-12);
        assert!(end.rotation_error(&path.pose_at(1.5)) < 1e-12);
    }

    #[test]
    fn background_motion_is_ego_motion() {
        let scene = Scene {
            background: vec![],
            objects: vec![MovingObject::car(
                4.5,
                1.8,
                Trajectory {
                    start: Pose2::new(10.0, 3.0, 0.0),
                    speed: 10.0,
                    yaw_rate: 0.0,
                    lateral_speed: 0.0,
                },
            )],
            ego: Trajectory {
                start: Pose2::new(0.0, 0.0, 0.1),
                speed: 10.0,
                yaw_rate: 0.05,
                lateral_speed: 0.0,
            },
            interval: 0.3,
        };
        let ego = scene.reference_sensor().between(&scene.current_sensor());
        assert!(scene.body_motion(0).translation_error(&ego) < 1e-12);
        // A car driving exactly like the ego along a parallel line keeps its place in
        // the sensor frame only when headings agree; here it must move by 3 m in world.
        let m = scene.body_motion(1);
        let p_cur_world = scene.body_pose(1, 0.3).transform_point(&Point2::origin());
        let p_cur_sensor = scene
            .current_sensor()
            .inverse()
            .transform_point(&p_cur_world);
        let p_ref_world = scene.body_pose(1, 0.0).transform_point(&Point2::origin());
        let p_ref_sensor = scene
            .reference_sensor()
            .inverse()
            .transform_point(&p_ref_world);
        assert!((m.transform_point(&p_cur_sensor) - p_ref_sensor).norm() < 1e-12);
    }
}
