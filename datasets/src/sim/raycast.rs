//! Exact ray casting against segments and circles, from the sensor origin.
//!
//! The scene is moved into the sensor frame once per scan; every primitive keeps the
//! interval of bearings it subtends, so a ray only tests the few primitives whose
//! interval contains its bearing.

use super::scene::{Primitive, Scene};
use nalgebra::{Point2, Vector2};
use pgm_scan::Pose2;
use std::f64::consts::{PI, TAU};

/// The first surface a ray meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Hit {
    /// Distance from the sensor in metres.
    pub range: f64,
    /// Body index (0 = background, `i + 1` = scene object `i`).
    pub body: usize,
    /// `|cos|` of the angle between the ray and the surface normal (1 = head-on).
    pub incidence_cos: f64,
}

#[derive(Clone, Copy, Debug)]
struct Entry {
    primitive: Primitive,
    body: usize,
    lo: f64,
    hi: f64,
}

/// All primitives of a scene at one time, in one sensor frame.
#[derive(Clone, Debug)]
pub(crate) struct Raycaster {
    entries: Vec<Entry>,
}

fn cross(a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

fn bearing(p: &Point2<f64>) -> f64 {
    p.y.atan2(p.x)
}

impl Raycaster {
    /// The scene at time `t` seen from a sensor at world pose `sensor`.
    pub fn new(scene: &Scene, sensor: &Pose2, t: f64) -> Self {
        let to_sensor = sensor.inverse();
        let entries = scene
            .world_primitives(t)
            .into_iter()
            .map(|(p, body)| {
                let primitive = p.transformed(&to_sensor);
                let (lo, hi) = bearing_interval(&primitive);
                Entry {
                    primitive,
                    body,
                    lo,
                    hi,
                }
            })
            .collect();
        Raycaster { entries }
    }

    /// The first hit along the ray at bearing `angle` (radians, sensor frame) closer
    /// than `max_range`, if any.
    pub fn cast(&self, angle: f64, max_range: f64) -> Option<Hit> {
        let (s, c) = angle.sin_cos();
        let dir = Vector2::new(c, s);
        let mut best: Option<Hit> = None;
        let mut best_range = max_range;
        for e in &self.entries {
            let inside = (angle >= e.lo && angle <= e.hi)
                || (angle + TAU >= e.lo && angle + TAU <= e.hi)
                || (angle - TAU >= e.lo && angle - TAU <= e.hi);
            if !inside {
                continue;
            }
            if let Some((range, incidence_cos)) = intersect(&e.primitive, dir) {
                if range < best_range {
                    best_range = range;
                    best = Some(Hit {
                        range,
                        body: e.body,
                        incidence_cos,
                    });
                }
            }
        }
        best
    }
}

/// Bearings (unwrapped interval `lo <= hi`, `hi - lo <= 2π`) covered by a primitive,
/// padded by a micro-radian so rays through end points are not lost.
fn bearing_interval(p: &Primitive) -> (f64, f64) {
    const PAD: f64 = 1e-6;
    match *p {
        Primitive::Segment { start, end } => {
            let a0 = bearing(&start);
            let a1 = bearing(&end);
            let mut d = (a1 - a0) % TAU;
            if d > PI {
                d -= TAU;
            } else if d < -PI {
                d += TAU;
            }
            // A segment through the origin would span π; treat it as seen everywhere.
            if cross(start.coords, end.coords).abs() < 1e-12 && start.coords.dot(&end.coords) <= 0.0
            {
                return (-PI - PAD, PI + PAD);
            }
            let (lo, hi) = if d >= 0.0 { (a0, a0 + d) } else { (a0 + d, a0) };
            (lo - PAD, hi + PAD)
        }
        Primitive::Circle { center, radius } => {
            let dist = center.coords.norm();
            if dist <= radius {
                return (-PI - PAD, PI + PAD);
            }
            let half = (radius / dist).asin();
            let a = bearing(&center);
            (a - half - PAD, a + half + PAD)
        }
    }
}

/// Range and `|cos incidence|` of the ray from the origin along unit `dir`.
fn intersect(p: &Primitive, dir: Vector2<f64>) -> Option<(f64, f64)> {
    const MIN_RANGE: f64 = 1e-9;
    match *p {
        Primitive::Segment { start, end } => {
            let e = end - start;
            let denom = cross(dir, e);
            if denom.abs() < 1e-15 {
                return None;
            }
            let t = cross(start.coords, e) / denom;
            let u = cross(start.coords, dir) / denom;
            if t > MIN_RANGE && (0.0..=1.0).contains(&u) {
                Some((t, (denom / e.norm()).abs()))
            } else {
                None
            }
        }
        Primitive::Circle { center, radius } => {
            let b = dir.dot(&center.coords);
            let disc = b * b - (center.coords.norm_squared() - radius * radius);
            if disc < 0.0 {
                return None;
            }
            let root = disc.sqrt();
            let t = if b - root > MIN_RANGE {
                b - root
            } else if b + root > MIN_RANGE {
                b + root
            } else {
                return None;
            };
            let normal = (dir * t - center.coords) / radius;
            Some((t, dir.dot(&normal).abs().min(1.0)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scene::Trajectory;

    fn scene_with(background: Vec<Primitive>) -> Scene {
        Scene {
            background,
            objects: vec![],
            ego: Trajectory::stationary(Pose2::identity()),
            interval: 0.1,
        }
    }

    #[test]
    fn wall_hits_at_the_right_range_and_incidence() {
        let scene = scene_with(vec![Primitive::segment(
            Point2::new(10.0, -50.0),
            Point2::new(10.0, 50.0),
        )]);
        let caster = Raycaster::new(&scene, &Pose2::identity(), 0.0);
        let hit = caster.cast(0.0, 80.0).unwrap();
        assert!((hit.range - 10.0).abs() < 1e-12);
        assert!((hit.incidence_cos - 1.0).abs() < 1e-12);
        let a = 60f64.to_radians();
        let hit = caster.cast(a, 80.0).unwrap();
        assert!((hit.range - 20.0).abs() < 1e-9);
        assert!((hit.incidence_cos - 0.5).abs() < 1e-9);
        // Beyond the maximum range there is no return.
        assert!(caster.cast(a, 15.0).is_none());
        // Behind the sensor there is nothing.
        assert!(caster.cast(PI, 80.0).is_none());
    }

    #[test]
    fn nearest_surface_wins_and_wrapped_intervals_work() {
        let scene = scene_with(vec![
            Primitive::segment(Point2::new(10.0, -5.0), Point2::new(10.0, 5.0)),
            Primitive::circle(Point2::new(5.0, 0.0), 0.5),
            // A wall alongside the sensor on the right, from behind to the front: its
            // bearing interval crosses ±π.
            Primitive::segment(Point2::new(-30.0, -3.0), Point2::new(30.0, -3.0)),
        ]);
        let caster = Raycaster::new(&scene, &Pose2::identity(), 0.0);
        let hit = caster.cast(0.0, 80.0).unwrap();
        assert!((hit.range - 4.5).abs() < 1e-12);
        let hit = caster.cast(-PI / 2.0, 80.0).unwrap();
        assert!((hit.range - 3.0).abs() < 1e-12);
        let hit = caster.cast(-PI / 4.0, 80.0).unwrap();
        assert!((hit.range - 3.0 * 2f64.sqrt()).abs() < 1e-9);
    }
}
