//! Scene presets: urban streets and intersections with the driving situations of the
//! papers' experiments (section V of the CRF-Clustering paper: "cars overtaking other
//! cars, crossing by and moving on the opposite lane"), and one outdoor scene of a
//! robot following a person (`person-following`, with a sensor of its own).
//!
//! World frame: the ego car starts at the origin driving along +x in the rightmost
//! lane (right-hand traffic), lanes are 3.3 m wide. The main street runs along x
//! from −40 m to 110 m; an intersection adds a cross street along y, 18-40 m ahead.
//! Building facades line both sides (lots of 6-20 m with random setbacks, some deep
//! courtyards); parked cars fill parking lanes; poles, trees and bushes stand on the
//! sidewalks. All of that is static background (label 0). Moving objects are placed
//! by rejection sampling so that no two bodies (ego included) overlap at the
//! reference time, the current time or halfway between.
//!
//! | preset | street | moving objects |
//! |---|---|---|
//! | `overtaking` | straight, 1-2 lanes per direction | 1-2 cars overtaking in the next lane, maybe a lead car, maybe one oncoming |
//! | `intersection` | cross street ahead | 1-2 cars crossing, maybe a turning car, 0-2 pedestrians on crosswalks, maybe a lead car |
//! | `oncoming` | straight | 1-3 cars on the opposite lane(s), maybe a lead car |
//! | `pedestrians` | straight or intersection | 2-4 pedestrians on sidewalks, 1-2 crossing, maybe a lead car |
//! | `mixed` (default) | straight or intersection | the above together: oncoming, overtaking, lead, crossing, turning cars and pedestrians (typically 3-6 objects) |
//! | `random` | any | 0-3 of every kind, random densities |
//! | `following` | straight, 2 lanes per direction | objects that keep pace with the ego vehicle: a lead car at the ego speed within 5 % and a car in the next lane at the ego speed (two scenes in three), or a person walking 1.5-4 m ahead of a slow robot (0.8-1.6 m/s) at its speed within 5 % |
//! | `person-following` | outdoors, sparse: tree trunks (r 0.1-0.3 m), posts (r 0.05-0.1 m), a few walls and building corners, most of the view empty | a robot (0.4-0.8 m/s, up to 1 m/s catching up; gentle turns) following a person 1.1-1.4 m ahead at the person's speed; the person stops, turns on the spot by 40-90° and walks on, again and again (the robot stops, turns and follows); 0-3 other pedestrians per 20 s crossing or walking the other way. Its own laser (10 Hz, 245 beams over 86°, 5.6 m; [`Preset::default_laser`]) and no wheel odometry ([`Preset::wheel_odometry`]); details in [`crate::sim::person_following`] |
//!
//! An object that keeps pace stays where it was in the sensor frame, so it looks
//! static to a method that compares the scans in the sensor frame and moving to one
//! that compares them in the world (after the ego-motion).
//!
//! The urban presets scan pairs 2-4 m of ego travel apart ([`SimConfig::pair_distance`]
//! over [`SimConfig::ego_speed`]) with the configured laser. `person-following` ignores
//! both ranges: its sequences are scanned at its scanner's 10 Hz whatever `k`
//! ([`Preset::scan_period`]), its pairs are 0.3-0.8 s (3-8 scans) of a 24 s walk, and
//! its pairs and scans carry no odometry at all (`None`: the data format's way of
//! saying there is none).
//!
//! [`SimConfig::pair_distance`]: crate::sim::SimConfig::pair_distance
//! [`SimConfig::ego_speed`]: crate::sim::SimConfig::ego_speed

use super::scene::{
    heading, polygon, rectangle, MovingObject, Primitive, Scene, Script, Trajectory,
};
use super::{person_following, uniform, SimError, ValidSimConfig};
use nalgebra::{Point2, Vector2};
use pgm_scan::Pose2;
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt;
use std::str::FromStr;

/// Lane width in metres.
pub const LANE_WIDTH: f64 = 3.3;
const X_START: f64 = -40.0;
const X_END: f64 = 110.0;
const CROSS_EXTENT: f64 = 80.0;
const PLACEMENT_ATTEMPTS: usize = 40;
const CLEARANCE: f64 = 0.3;

/// The kinds of scene the simulator builds (see the module docs for the table).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// Cars overtaking the ego car on a straight street.
    Overtaking,
    /// Cars crossing and turning at an intersection ahead.
    Intersection,
    /// Cars on the opposite lane.
    Oncoming,
    /// Pedestrians walking along and across the street.
    Pedestrians,
    /// All the papers' situations together (default).
    #[default]
    Mixed,
    /// Random layouts and random numbers of every kind of object.
    Random,
    /// Objects that keep pace with the ego vehicle (module docs).
    Following,
    /// A robot following a walking person outdoors, with its own laser and no
    /// odometry (module docs, [`crate::sim::person_following`]).
    #[serde(rename = "person-following")]
    PersonFollowing,
}

/// A preset's own laser ([`Preset::default_laser`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PresetLaser {
    /// Number of beams.
    pub beams: usize,
    /// Field of view in radians.
    pub field_of_view: f64,
    /// Maximum range in metres.
    pub max_range: f64,
}

impl Preset {
    /// Every preset, in the order of [`Preset::NAMES`].
    pub const ALL: [Preset; 8] = [
        Preset::Overtaking,
        Preset::Intersection,
        Preset::Oncoming,
        Preset::Pedestrians,
        Preset::Mixed,
        Preset::Random,
        Preset::Following,
        Preset::PersonFollowing,
    ];

    /// The urban street presets, the papers' situations scanned by the configured
    /// laser from a car (every preset but [`Preset::PersonFollowing`]), in the order
    /// of [`Preset::ALL`].
    pub const URBAN: [Preset; 7] = {
        // `Preset::ALL` but its last preset, `PersonFollowing`.
        let mut urban = [Preset::Overtaking; 7];
        let mut i = 0;
        while i < urban.len() {
            urban[i] = Preset::ALL[i];
            i += 1;
        }
        urban
    };

    /// The preset names accepted by [`Preset::from_str`].
    pub const NAMES: [&'static str; 8] = [
        "overtaking",
        "intersection",
        "oncoming",
        "pedestrians",
        "mixed",
        "random",
        "following",
        "person-following",
    ];

    /// The preset's name (lower case).
    pub fn name(&self) -> &'static str {
        let i = Preset::ALL.iter().position(|p| p == self).unwrap_or(0);
        Preset::NAMES[i]
    }

    /// The preset's own laser, when it models a sensor of its own: `person-following`
    /// has 245 beams over 86° and a 5.6 m range. `None` for the urban presets, which
    /// take [`SimConfig::default`](crate::sim::SimConfig::default)'s 361 beams over
    /// 180° and 80 m. [`SimConfig::for_preset`](crate::sim::SimConfig::for_preset)
    /// applies it; a configuration given otherwise keeps its own laser.
    pub fn default_laser(&self) -> Option<PresetLaser> {
        match self {
            Preset::PersonFollowing => Some(PresetLaser {
                beams: person_following::BEAMS,
                field_of_view: person_following::FIELD_OF_VIEW_DEGREES.to_radians(),
                max_range: person_following::MAX_RANGE,
            }),
            _ => None,
        }
    }

    /// Whether the simulated platform has wheel odometry: its pairs carry the noisy
    /// odometry prior and its scans their poses ([`crate::sim::simulate_scene`]).
    /// `false` for `person-following`, whose pairs' [`crate::ScanPair::odometry`] and
    /// scans' [`pgm_scan::Scan::odometry`] are `None` whatever the odometry noise.
    pub fn wheel_odometry(&self) -> bool {
        *self != Preset::PersonFollowing
    }

    /// The preset's own scan period (s), when its sensor has one: sequences of
    /// `person-following` are scanned every 0.1 s (10 Hz) whatever `k`. `None` for the
    /// urban presets, whose sequences take the pair's interval over `k`
    /// ([`Preset::script`]).
    pub fn scan_period(&self) -> Option<f64> {
        match self {
            Preset::PersonFollowing => Some(person_following::SCAN_PERIOD),
            _ => None,
        }
    }

    /// Builds one random scene of this preset, ego trajectory and scan interval
    /// included, from the laser-independent parts of `config` (pair distance and ego
    /// speed ranges; `person-following` uses neither, see the module docs).
    pub fn scene<R: Rng>(&self, config: &ValidSimConfig, rng: &mut R) -> Scene {
        if *self == Preset::Following {
            // Its own draw order, so the other presets' streams stay as they were.
            return following_scene(config, rng);
        }
        if *self == Preset::PersonFollowing {
            return person_following::scene(rng);
        }
        let c = config.params();
        let ego_speed = uniform(rng, c.ego_speed[0], c.ego_speed[1]);
        let (ego, interval) = ego_drive(rng, c.pair_distance, ego_speed, 0.004);
        let intersection = match self {
            Preset::Intersection => true,
            Preset::Overtaking | Preset::Oncoming => false,
            Preset::Pedestrians => rng.random_bool(0.4),
            Preset::Mixed | Preset::Random => rng.random_bool(0.5),
            Preset::Following | Preset::PersonFollowing => false,
        };
        let lanes = match self {
            Preset::Overtaking => {
                if rng.random_bool(0.7) {
                    2
                } else {
                    1
                }
            }
            _ => {
                if rng.random_bool(0.5) {
                    2
                } else {
                    1
                }
            }
        };
        let density = match self {
            Preset::Random => uniform(rng, 0.0, 1.0),
            _ => 0.65,
        };
        let layout = Layout::random(rng, lanes, intersection);
        let mut b = Builder::new(rng, layout, ego, interval, ego_speed);
        b.buildings();
        b.parked_cars(density);
        b.furniture(density);
        use Count::{Chance, Range};
        match self {
            Preset::Overtaking => b.populate(&[
                (Range(1, 2), Builder::overtaking_car),
                (Chance(0.5), Builder::lead_car),
                (Chance(0.3), Builder::oncoming_car),
            ]),
            Preset::Intersection => b.populate(&[
                (Range(1, 2), Builder::crossing_car),
                (Chance(0.5), Builder::turning_car),
                (Range(0, 2), Builder::crossing_pedestrian),
                (Chance(0.3), Builder::lead_car),
            ]),
            Preset::Oncoming => b.populate(&[
                (Range(1, 3), Builder::oncoming_car),
                (Chance(0.3), Builder::lead_car),
            ]),
            Preset::Pedestrians => b.populate(&[
                (Range(2, 4), Builder::sidewalk_pedestrian),
                (Range(1, 2), Builder::crossing_pedestrian),
                (Chance(0.2), Builder::lead_car),
            ]),
            Preset::Mixed => {
                b.populate(&[
                    (Range(1, 2), Builder::oncoming_car),
                    (Chance(0.6), Builder::overtaking_car),
                    (Chance(0.4), Builder::lead_car),
                ]);
                if intersection {
                    b.populate(&[
                        (Range(1, 2), Builder::crossing_car),
                        (Chance(0.3), Builder::turning_car),
                    ]);
                }
                b.populate(&[
                    (Range(0, 1), Builder::sidewalk_pedestrian),
                    (Range(0, 1), Builder::crossing_pedestrian),
                ]);
            }
            Preset::Following | Preset::PersonFollowing => {}
            Preset::Random => b.populate(&[
                (Range(0, 1), Builder::lead_car),
                (Range(0, 2), Builder::overtaking_car),
                (Range(0, 3), Builder::oncoming_car),
                (Range(0, 2), Builder::crossing_car),
                (Range(0, 1), Builder::turning_car),
                (Range(0, 3), Builder::sidewalk_pedestrian),
                (Range(0, 2), Builder::crossing_pedestrian),
            ]),
        }
        b.finish()
    }
}

/// A scene of [`Preset::Following`]: cars that keep pace on a two-lane street, or a
/// person walking just ahead of a slow robot.
fn following_scene<R: Rng>(config: &ValidSimConfig, rng: &mut R) -> Scene {
    let c = config.params();
    let person = rng.random_bool(1.0 / 3.0);
    let ego_speed = if person {
        uniform(rng, 0.8, 1.6)
    } else {
        uniform(rng, c.ego_speed[0], c.ego_speed[1])
    };
    let (ego, interval) = ego_drive(rng, c.pair_distance, ego_speed, 0.002);
    let layout = Layout::random(rng, 2, false);
    let mut b = Builder::new(rng, layout, ego, interval, ego_speed);
    b.buildings();
    b.parked_cars(0.65);
    b.furniture(0.65);
    if person {
        b.repeat(1, Builder::pacing_pedestrian);
    } else {
        b.repeat(1, Builder::pacing_lead_car);
        b.repeat(1, Builder::pacing_next_lane_car);
    }
    b.finish()
}

impl Preset {
    /// The scene of a sequence of `scans` scans whose pairs are `k` scans apart
    /// ([`crate::sim::simulate_sequence`]): for the urban presets one scene of
    /// [`Preset::scene`] whose motions go on unchanged, scanned `interval / k` seconds
    /// apart, however many scans there are; for `person-following` a walk with its
    /// stops and turns scripted for `scans` scans (so the scene depends on `scans`),
    /// scanned every 0.1 s whatever `k`.
    pub fn script<R: Rng>(
        &self,
        config: &ValidSimConfig,
        rng: &mut R,
        scans: usize,
        k: usize,
    ) -> Script {
        if *self == Preset::PersonFollowing {
            return person_following::script(rng, scans);
        }
        let scene = self.scene(config, rng);
        Script::from_scene(&scene, scene.interval / k as f64)
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Preset {
    type Err = SimError;

    fn from_str(s: &str) -> Result<Self, SimError> {
        Preset::NAMES
            .iter()
            .position(|n| n.eq_ignore_ascii_case(s.trim()))
            .map(|i| Preset::ALL[i])
            .ok_or_else(|| SimError::UnknownPreset {
                name: s.to_string(),
            })
    }
}

/// The cross street of an intersection (running along y).
#[derive(Clone, Copy, Debug)]
struct Cross {
    /// x of its centre line.
    x: f64,
    /// Lanes per direction.
    lanes: usize,
    /// Half the width of its roadway.
    half_width: f64,
    /// Width of its sidewalks.
    sidewalk: f64,
}

/// Where the streets, sidewalks and building lines are.
#[derive(Clone, Copy, Debug)]
struct Layout {
    lanes: usize,
    right_edge: f64,
    left_edge: f64,
    right_facade: f64,
    left_facade: f64,
    right_parking: bool,
    left_parking: bool,
    cross: Option<Cross>,
}

impl Layout {
    fn random<R: Rng>(rng: &mut R, lanes: usize, intersection: bool) -> Self {
        let right_parking = rng.random_bool(0.7);
        let left_parking = rng.random_bool(0.6);
        let right_edge = -LANE_WIDTH / 2.0 - if right_parking { 2.2 } else { 0.4 };
        let left_edge =
            (2.0 * lanes as f64 - 0.5) * LANE_WIDTH + if left_parking { 2.2 } else { 0.4 };
        let right_facade = right_edge - uniform(rng, 2.5, 5.0);
        let left_facade = left_edge + uniform(rng, 2.5, 5.0);
        let cross = intersection.then(|| {
            let cross_lanes = if rng.random_bool(0.5) { 2 } else { 1 };
            Cross {
                x: uniform(rng, 18.0, 40.0),
                lanes: cross_lanes,
                half_width: cross_lanes as f64 * LANE_WIDTH + 0.4,
                sidewalk: uniform(rng, 2.5, 4.5),
            }
        });
        Layout {
            lanes,
            right_edge,
            left_edge,
            right_facade,
            left_facade,
            right_parking,
            left_parking,
            cross,
        }
    }

    /// y of the main street's centre line.
    fn centre(&self) -> f64 {
        (self.lanes as f64 - 0.5) * LANE_WIDTH
    }

    /// Whether x lies on the cross street's roadway, widened by `margin`.
    fn on_cross_street(&self, x: f64, margin: f64) -> bool {
        self.cross
            .is_some_and(|c| (x - c.x).abs() < c.half_width + margin)
    }
}

/// A body's footprint for collision checks: circles in its body frame, on a trajectory.
#[derive(Clone, Debug)]
struct Footprint {
    trajectory: Trajectory,
    circles: Vec<(Point2<f64>, f64)>,
}

/// A moving object proposed by a placement function, with its footprint.
struct Candidate {
    object: MovingObject,
    footprint: Footprint,
}

impl Candidate {
    /// `object` with the footprint `circles` (body frame) along its trajectory.
    fn new(object: MovingObject, circles: Vec<(Point2<f64>, f64)>) -> Self {
        let trajectory = object.trajectory;
        Candidate {
            object,
            footprint: Footprint {
                trajectory,
                circles,
            },
        }
    }
}

/// The ego vehicle's drive at `ego_speed` over a random distance within
/// `pair_distance` (m), near y = 0 and heading along x, on a curve of random curvature
/// within ±`max_curvature` (1/m): its trajectory and the time it takes.
fn ego_drive<R: Rng>(
    rng: &mut R,
    pair_distance: [f64; 2],
    ego_speed: f64,
    max_curvature: f64,
) -> (Trajectory, f64) {
    let distance = uniform(rng, pair_distance[0], pair_distance[1]);
    let interval = distance / ego_speed;
    let curvature = uniform(rng, -max_curvature, max_curvature);
    let ego = Trajectory::unicycle(
        Pose2::new(0.0, uniform(rng, -0.3, 0.3), uniform(rng, -0.02, 0.02)),
        ego_speed,
        curvature * ego_speed,
    );
    (ego, interval)
}

/// A straight drive from (`x`, `y`) heading `h` at `speed`.
fn straight(x: f64, y: f64, h: f64, speed: f64) -> Trajectory {
    Trajectory::unicycle(Pose2::new(x, y, h), speed, 0.0)
}

fn car_circles(length: f64, width: f64) -> Vec<(Point2<f64>, f64)> {
    let r = ((length / 4.0).powi(2) + (width / 2.0).powi(2)).sqrt();
    vec![
        (Point2::new(length / 4.0, 0.0), r),
        (Point2::new(-length / 4.0, 0.0), r),
    ]
}

/// How many objects of one kind a preset places: a uniform draw from `low..=high`,
/// or one with probability `p`.
#[derive(Clone, Copy)]
enum Count {
    Range(usize, usize),
    Chance(f64),
}

/// A placement routine of [`Builder`]: proposes one object, or `None` when it cannot.
type Place<'a, R> = fn(&mut Builder<'a, R>) -> Option<Candidate>;

struct Builder<'a, R> {
    rng: &'a mut R,
    layout: Layout,
    background: Vec<Primitive>,
    objects: Vec<MovingObject>,
    occupied: Vec<Footprint>,
    ego: Trajectory,
    interval: f64,
    ego_speed: f64,
}

impl<'a, R: Rng> Builder<'a, R> {
    fn new(rng: &'a mut R, layout: Layout, ego: Trajectory, interval: f64, ego_speed: f64) -> Self {
        // The laser sits on the ego car's front bumper; the car body lies behind it.
        let ego_footprint = Footprint {
            trajectory: ego,
            circles: vec![
                (Point2::new(-1.1, 0.0), 1.45),
                (Point2::new(-3.4, 0.0), 1.45),
            ],
        };
        Builder {
            rng,
            layout,
            background: Vec::new(),
            objects: Vec::new(),
            occupied: vec![ego_footprint],
            ego,
            interval,
            ego_speed,
        }
    }

    /// Draws each entry's number of objects and places them, in the order given (the
    /// order of the random draws).
    fn populate(&mut self, plan: &[(Count, Place<'a, R>)]) {
        for &(count, place) in plan {
            let n = match count {
                Count::Range(low, high) => self.rng.random_range(low..=high),
                Count::Chance(p) => usize::from(self.rng.random_bool(p)),
            };
            self.repeat(n, place);
        }
    }

    fn finish(self) -> Scene {
        Scene {
            background: self.background,
            objects: self.objects,
            ego: self.ego,
            interval: self.interval,
        }
    }

    fn collides(&self, f: &Footprint) -> bool {
        let times = [0.0, self.interval / 2.0, self.interval];
        times.iter().any(|&t| {
            let pose = f.trajectory.pose_at(t);
            self.occupied.iter().any(|o| {
                let other = o.trajectory.pose_at(t);
                f.circles.iter().any(|(c, r)| {
                    let p = pose.transform_point(c);
                    o.circles
                        .iter()
                        .any(|(oc, or)| (other.transform_point(oc) - p).norm() < r + or + CLEARANCE)
                })
            })
        })
    }

    /// Adds a static obstacle unless it overlaps something already placed.
    fn add_static(&mut self, shape: Vec<Primitive>, pose: Pose2, circles: Vec<(Point2<f64>, f64)>) {
        let footprint = Footprint {
            trajectory: Trajectory::stationary(pose),
            circles,
        };
        if self.collides(&footprint) {
            return;
        }
        self.background
            .extend(shape.iter().map(|p| p.transformed(&pose)));
        self.occupied.push(footprint);
    }

    /// Places `n` objects proposed by `place`, each with up to 40 attempts.
    fn repeat(&mut self, n: usize, place: Place<'a, R>) {
        for _ in 0..n {
            for _ in 0..PLACEMENT_ATTEMPTS {
                let Some(candidate) = place(self) else {
                    break;
                };
                if !self.collides(&candidate.footprint) {
                    self.occupied.push(candidate.footprint);
                    self.objects.push(candidate.object);
                    break;
                }
            }
        }
    }

    // ----- static background -------------------------------------------------------

    fn buildings(&mut self) {
        let l = self.layout;
        let (rf, lf) = (l.right_facade, l.left_facade);
        let down = Vector2::new(0.0, -1.0);
        let up = Vector2::new(0.0, 1.0);
        match l.cross {
            None => {
                self.facade(Point2::new(X_START, rf), Point2::new(X_END, rf), down);
                self.facade(Point2::new(X_START, lf), Point2::new(X_END, lf), up);
            }
            Some(c) => {
                let near = c.x - c.half_width - c.sidewalk;
                let far = c.x + c.half_width + c.sidewalk;
                let back = Vector2::new(-1.0, 0.0);
                let ahead = Vector2::new(1.0, 0.0);
                self.facade(Point2::new(X_START, rf), Point2::new(near, rf), down);
                self.facade(
                    Point2::new(near, rf),
                    Point2::new(near, -CROSS_EXTENT),
                    back,
                );
                self.facade(Point2::new(far, -CROSS_EXTENT), Point2::new(far, rf), ahead);
                self.facade(Point2::new(far, rf), Point2::new(X_END, rf), down);
                self.facade(Point2::new(X_START, lf), Point2::new(near, lf), up);
                self.facade(Point2::new(near, lf), Point2::new(near, CROSS_EXTENT), back);
                self.facade(Point2::new(far, CROSS_EXTENT), Point2::new(far, lf), ahead);
                self.facade(Point2::new(far, lf), Point2::new(X_END, lf), up);
            }
        }
    }

    /// A building line from `a` to `b` made of lots 6-20 m long, each set back from
    /// the line by 0 m (60 %), 0.3-1.5 m (28 %) or 5-12 m (12 %, courtyards and
    /// driveways) in direction `outward`, joined by perpendicular walls.
    fn facade(&mut self, a: Point2<f64>, b: Point2<f64>, outward: Vector2<f64>) {
        let length = (b - a).norm();
        if length < 1e-6 {
            return;
        }
        let u = (b - a) / length;
        let mut points = vec![a];
        let mut s = 0.0;
        while s < length {
            let e = (s + uniform(self.rng, 6.0, 20.0)).min(length);
            let roll: f64 = self.rng.random();
            let setback = if roll < 0.6 {
                0.0
            } else if roll < 0.88 {
                uniform(self.rng, 0.3, 1.5)
            } else {
                uniform(self.rng, 5.0, 12.0)
            };
            points.push(a + u * s + outward * setback);
            points.push(a + u * e + outward * setback);
            s = e;
        }
        points.push(b);
        for w in points.windows(2) {
            if (w[1] - w[0]).norm() > 1e-9 {
                self.background.push(Primitive::segment(w[0], w[1]));
            }
        }
    }

    /// Parked cars in the parking lanes, each slot taken with probability `density`,
    /// none within 4 m of the cross street's sidewalks.
    fn parked_cars(&mut self, density: f64) {
        let l = self.layout;
        let mut sides = Vec::new();
        if l.right_parking {
            sides.push((-LANE_WIDTH / 2.0 - 1.1, 0.0));
        }
        if l.left_parking {
            sides.push((l.left_edge - 1.1, PI));
        }
        for (y, heading) in sides {
            let mut x = X_START + uniform(self.rng, 0.0, 4.0);
            while x < 90.0 {
                let slot = uniform(self.rng, 5.2, 6.8);
                let taken = self.rng.random_bool(density);
                let length = uniform(self.rng, 4.2, 4.9);
                let width = uniform(self.rng, 1.7, 1.95);
                let jitter_y = uniform(self.rng, -0.12, 0.12);
                let jitter_heading = uniform(self.rng, -0.03, 0.03);
                let centre = x + slot / 2.0;
                let margin = l.cross.map_or(0.0, |c| c.sidewalk) + 4.0 + slot / 2.0;
                if taken && !l.on_cross_street(centre, margin) {
                    let pose = Pose2::new(centre, y + jitter_y, heading + jitter_heading);
                    self.add_static(rectangle(length, width), pose, car_circles(length, width));
                }
                x += slot;
            }
        }
    }

    /// Poles and trees near the curbs, bushes near the facades, traffic-light poles
    /// at intersection corners and poles along the cross street.
    fn furniture(&mut self, density: f64) {
        let l = self.layout;
        // (curb y, facade y, direction from the curb into the sidewalk)
        let sides = [
            (l.right_edge, l.right_facade, -1.0),
            (l.left_edge, l.left_facade, 1.0),
        ];
        for (curb, facade, into) in sides {
            let mut x = X_START + uniform(self.rng, 0.0, 10.0);
            while x < 95.0 {
                let r = uniform(self.rng, 0.06, 0.12);
                if !l.on_cross_street(x, 0.5) {
                    self.add_circle(Point2::new(x, curb + into * 0.5), r);
                }
                x += uniform(self.rng, 15.0, 35.0);
            }
            let mut x = X_START + uniform(self.rng, 0.0, 8.0);
            while x < 95.0 {
                let r = uniform(self.rng, 0.12, 0.3);
                if self.rng.random_bool(0.7 * density) && !l.on_cross_street(x, 1.0) {
                    self.add_circle(Point2::new(x, curb + into * 1.2), r);
                }
                x += uniform(self.rng, 6.0, 14.0);
            }
            let mut x = X_START + uniform(self.rng, 0.0, 8.0);
            while x < 95.0 {
                let radius = uniform(self.rng, 0.4, 0.8);
                let offset = uniform(self.rng, 0.7, 1.1);
                if self.rng.random_bool(0.5 * density) && !l.on_cross_street(x, radius + 0.5) {
                    self.add_bush(Point2::new(x, facade - into * offset), radius);
                }
                x += uniform(self.rng, 5.0, 15.0);
            }
        }
        if let Some(c) = l.cross {
            for sx in [-1.0, 1.0] {
                let x = c.x + sx * (c.half_width + 0.5);
                let r = uniform(self.rng, 0.1, 0.15);
                self.add_circle(Point2::new(x, l.right_edge - 0.5), r);
                let r = uniform(self.rng, 0.1, 0.15);
                self.add_circle(Point2::new(x, l.left_edge + 0.5), r);
                for (start, dir) in [(l.right_edge - 6.0, -1.0), (l.left_edge + 6.0, 1.0)] {
                    let mut y = start;
                    while y.abs() < 60.0 {
                        let r = uniform(self.rng, 0.06, 0.3);
                        self.add_circle(Point2::new(x + sx * 0.6, y), r);
                        y += dir * uniform(self.rng, 8.0, 25.0);
                    }
                }
            }
        }
    }

    fn add_circle(&mut self, centre: Point2<f64>, radius: f64) {
        self.add_static(
            vec![Primitive::circle(Point2::origin(), radius)],
            Pose2::new(centre.x, centre.y, 0.0),
            vec![(Point2::origin(), radius)],
        );
    }

    /// An irregular heptagon of about `radius` (a bush or hedge block).
    fn add_bush(&mut self, centre: Point2<f64>, radius: f64) {
        let corners: Vec<Point2<f64>> = (0..7)
            .map(|i| {
                let a = i as f64 * 2.0 * PI / 7.0;
                Point2::from(heading(a) * radius * uniform(self.rng, 0.6, 1.0))
            })
            .collect();
        self.add_static(
            polygon(&corners),
            Pose2::new(centre.x, centre.y, 0.0),
            vec![(Point2::origin(), radius)],
        );
    }

    // ----- moving objects ----------------------------------------------------------

    /// A unicycle at (`x`, `y`) heading `h` at `speed`, turning at the ego's rate.
    fn with_ego_turn(&self, x: f64, y: f64, h: f64, speed: f64) -> Trajectory {
        Trajectory::unicycle(Pose2::new(x, y, h), speed, self.ego.yaw_rate)
    }

    fn car(&mut self, trajectory: Trajectory) -> Candidate {
        let length = uniform(self.rng, 4.2, 4.9);
        let width = uniform(self.rng, 1.7, 1.95);
        Candidate::new(
            MovingObject::car(length, width, trajectory),
            car_circles(length, width),
        )
    }

    fn pedestrian(&mut self, trajectory: Trajectory) -> Candidate {
        let stride = uniform(self.rng, 0.0, 0.35);
        let leg = uniform(self.rng, 0.06, 0.08);
        Candidate::new(
            MovingObject::pedestrian(stride, leg, trajectory),
            vec![(Point2::origin(), 0.35)],
        )
    }

    /// A car ahead in the ego lane, 8-35 m away, at 0.5-1.3 times the ego speed.
    fn lead_car(&mut self) -> Option<Candidate> {
        let x = uniform(self.rng, 8.0, 35.0);
        let y = uniform(self.rng, -0.2, 0.2);
        let speed = (self.ego_speed * uniform(self.rng, 0.5, 1.3)).clamp(5.0, 15.0);
        let h = uniform(self.rng, -0.02, 0.02);
        Some(self.car(straight(x, y, h, speed)))
    }

    /// A car ahead in the ego lane, 8-35 m away, at the ego speed within 5 %.
    fn pacing_lead_car(&mut self) -> Option<Candidate> {
        let x = uniform(self.rng, 8.0, 35.0);
        let y = self.ego.start.y() + uniform(self.rng, -0.2, 0.2);
        let speed = self.ego_speed * uniform(self.rng, 0.95, 1.05);
        let h = self.ego.start.theta() + uniform(self.rng, -0.01, 0.01);
        Some(self.car(self.with_ego_turn(x, y, h, speed)))
    }

    /// A car in the next lane to the left, from 3 m behind to 15 m ahead, at the ego
    /// speed (and turn rate).
    fn pacing_next_lane_car(&mut self) -> Option<Candidate> {
        let x = uniform(self.rng, -3.0, 15.0);
        let y = LANE_WIDTH + uniform(self.rng, -0.2, 0.2);
        let h = self.ego.start.theta();
        Some(self.car(self.with_ego_turn(x, y, h, self.ego_speed)))
    }

    /// A person walking 1.5-4 m ahead of the (slow) ego vehicle, at its speed within 5 %.
    fn pacing_pedestrian(&mut self) -> Option<Candidate> {
        let x = uniform(self.rng, 1.5, 4.0);
        let y = self.ego.start.y() + uniform(self.rng, -0.4, 0.4);
        let h = self.ego.start.theta() + uniform(self.rng, -0.05, 0.05);
        let speed = self.ego_speed * uniform(self.rng, 0.95, 1.05);
        Some(self.pedestrian(self.with_ego_turn(x, y, h, speed)))
    }

    /// A car in the next lane to the left (the opposite lane on a one-lane street),
    /// from alongside to 18 m ahead, 2.5-6 m/s faster than the ego car.
    fn overtaking_car(&mut self) -> Option<Candidate> {
        let x = uniform(self.rng, -1.0, 18.0);
        let y = LANE_WIDTH + uniform(self.rng, -0.2, 0.2);
        let speed = (self.ego_speed + uniform(self.rng, 2.5, 6.0)).min(18.0);
        let h = uniform(self.rng, -0.02, 0.02);
        Some(self.car(straight(x, y, h, speed)))
    }

    /// A car on one of the opposite lanes, 6-60 m ahead, at 6-14 m/s.
    fn oncoming_car(&mut self) -> Option<Candidate> {
        let lane = self.rng.random_range(0..self.layout.lanes);
        let y = (self.layout.lanes + lane) as f64 * LANE_WIDTH + uniform(self.rng, -0.2, 0.2);
        let x = uniform(self.rng, 6.0, 60.0);
        let speed = uniform(self.rng, 6.0, 14.0);
        let h = PI + uniform(self.rng, -0.02, 0.02);
        Some(self.car(straight(x, y, h, speed)))
    }

    /// A car driving along the cross street through the intersection, at 5-13 m/s,
    /// within 25 m of the main street's centre line.
    fn crossing_car(&mut self) -> Option<Candidate> {
        let c = self.layout.cross?;
        let lane = self.rng.random_range(0..c.lanes) as f64 + 0.5;
        let leftwards = self.rng.random_bool(0.5);
        let (x, h) = if leftwards {
            (c.x + lane * LANE_WIDTH, FRAC_PI_2)
        } else {
            (c.x - lane * LANE_WIDTH, -FRAC_PI_2)
        };
        let y = self.layout.centre() + uniform(self.rng, -25.0, 25.0);
        let speed = uniform(self.rng, 5.0, 13.0);
        let h = h + uniform(self.rng, -0.02, 0.02);
        Some(self.car(straight(x, y, h, speed)))
    }

    /// A car turning at the intersection at 3-7 m/s: either an oncoming car turning
    /// left into the cross street, or a car from the right turning right into the
    /// ego's direction. It is somewhere on its quarter-circle at both scans.
    fn turning_car(&mut self) -> Option<Candidate> {
        let c = self.layout.cross?;
        let speed = uniform(self.rng, 3.0, 7.0);
        let (arc_start, radius, yaw_sign) = if self.rng.random_bool(0.5) {
            // Oncoming, inner lane, turns left (counter-clockwise) into the cross
            // street's −y lane at x = c.x − lane/2.
            let radius = c.half_width + LANE_WIDTH / 2.0;
            let y = self.layout.lanes as f64 * LANE_WIDTH;
            (Pose2::new(c.x + c.half_width, y, PI), radius, 1.0)
        } else {
            // From the right on the cross street's +y lane, turns right (clockwise)
            // into the ego lane (y = 0).
            let radius = uniform(self.rng, (-self.layout.right_edge + 0.5).max(4.5), 9.0);
            (
                Pose2::new(c.x + LANE_WIDTH / 2.0, -radius, FRAC_PI_2),
                radius,
                -1.0,
            )
        };
        let arc = Trajectory::unicycle(arc_start, speed, yaw_sign * speed / radius);
        let duration = FRAC_PI_2 * radius / speed;
        let offset = uniform(self.rng, 0.0, (duration - self.interval).max(0.0));
        Some(self.car(Trajectory {
            start: arc.pose_at(offset),
            ..arc
        }))
    }

    /// A pedestrian walking along one of the sidewalks, 2-35 m ahead, at 1-1.8 m/s.
    fn sidewalk_pedestrian(&mut self) -> Option<Candidate> {
        let l = self.layout;
        let y = if self.rng.random_bool(0.5) {
            (l.right_edge + l.right_facade) / 2.0
        } else {
            (l.left_edge + l.left_facade) / 2.0
        } + uniform(self.rng, -0.4, 0.4);
        let x = uniform(self.rng, 2.0, 35.0);
        let h = if self.rng.random_bool(0.5) { 0.0 } else { PI } + uniform(self.rng, -0.1, 0.1);
        let speed = uniform(self.rng, 1.0, 1.8);
        Some(self.pedestrian(straight(x, y, h, speed)))
    }

    /// A pedestrian crossing the main street: on a crosswalk next to the intersection,
    /// or mid-block 10-30 m ahead, at 1-1.8 m/s.
    fn crossing_pedestrian(&mut self) -> Option<Candidate> {
        let l = self.layout;
        let x = match l.cross {
            Some(c) => {
                let side = if self.rng.random_bool(0.5) { -1.0 } else { 1.0 };
                c.x + side * (c.half_width + uniform(self.rng, 1.0, 2.5))
            }
            None => uniform(self.rng, 10.0, 30.0),
        };
        let y = uniform(self.rng, l.right_edge, l.left_edge);
        let h = if self.rng.random_bool(0.5) {
            FRAC_PI_2
        } else {
            -FRAC_PI_2
        } + uniform(self.rng, -0.1, 0.1);
        let speed = uniform(self.rng, 1.0, 1.8);
        Some(self.pedestrian(straight(x, y, h, speed)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{pair_rng, SimConfig};
    use pgm_scan::ParamGuard;

    #[test]
    fn names_round_trip() {
        for p in Preset::ALL {
            assert_eq!(p.name().parse::<Preset>().unwrap(), p);
            assert_eq!(p.to_string(), p.name());
        }
        let err = "highway".parse::<Preset>().unwrap_err();
        assert!(err.to_string().contains("highway"), "{err}");
        assert!(err.to_string().contains("overtaking"), "{err}");
    }

    #[test]
    fn moving_objects_do_not_overlap_anything() {
        let config = SimConfig::default().check().unwrap();
        for preset in Preset::ALL {
            for i in 0..10 {
                let mut rng = pair_rng(3, i);
                let scene = preset.scene(&config, &mut rng);
                let interval = scene.interval;
                assert!(interval > 0.0);
                for (k, o) in scene.objects.iter().enumerate() {
                    for t in [0.0, interval] {
                        let centre = o.trajectory.pose_at(t).translation();
                        let ego = scene.ego.pose_at(t).translation();
                        assert!(
                            (centre - ego).norm() > 1.0,
                            "{preset} scene {i}: object {k} on the ego car"
                        );
                    }
                }
            }
        }
    }
}
