//! Motion-capture ground truth for scan pairs: pose tracks interpolated at scan
//! times, carried into the laser frame, and per-point labels from an object's
//! footprint (the datmo bags, `../shared/data/datmo/README.md`).
//!
//! For a pair (reference scan `i`, current scan `j`), with `E(t)` the robot's pose
//! track and `C(t)` the moving object's, both interpolated at the scan's header stamp
//! plus [`MocapOptions::pose_delay`] ([`PoseTrack::at`]), and `M` the laser's pose on
//! the robot (the mounting):
//!
//! - the laser's pose `L = E ∘ M`; the true ego-motion `inverse(L_i) ∘ L_j` carries the
//!   current scan's static returns onto the reference frame;
//! - the object's motion `inverse(L_i) ∘ C_i ∘ inverse(C_j) ∘ L_j` carries the object's
//!   current returns onto where they were in the reference frame (the project's
//!   convention `g ≈ R s + T` for every cluster);
//! - a return of a scan is the object (label 1) when it lies within
//!   [`MocapOptions::label_margin`] of the object's [`Footprint`] at that scan's time
//!   (a rectangle in the object's pose frame) and the object moves (its footprint's
//!   centre at least [`MocapOptions::object_min_speed`] between the two scans); every
//!   other return is static background (label 0), a standing object's included.
//!
//! ```
//! use pgm_datasets::mocap::{Footprint, PoseTrack};
//! use pgm_scan::Pose2;
//! use nalgebra::Point2;
//!
//! let track = PoseTrack::new(vec![(0.0, Pose2::new(0.0, 0.0, 3.1)), (1.0, Pose2::new(2.0, 0.0, -3.1))]);
//! let mid = track.at(0.5, f64::INFINITY).unwrap();
//! assert!((mid.x() - 1.0).abs() < 1e-12);
//! assert!((mid.theta().abs() - std::f64::consts::PI).abs() < 1e-9); // the short way round
//! let car = Footprint { length: 0.43, width: 0.187, centre_x: 0.057, centre_y: 0.028 };
//! assert!(car.contains(&Pose2::identity(), &Point2::new(0.25, 0.0), 0.0));
//! assert!(!car.contains(&Pose2::identity(), &Point2::new(0.35, 0.0), 0.05));
//! ```

use crate::pair::{ClusterMotion, GroundTruth, ScanPair};
use nalgebra::{Point2, Vector2};
use pgm_scan::{Pose2, Scan};
use std::f64::consts::PI;

/// A time series of planar poses, interpolated linearly (x, y, and the heading the
/// short way round).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseTrack {
    stamps: Vec<f64>,
    poses: Vec<Pose2>,
}

fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI {
        w - 2.0 * PI
    } else {
        w
    }
}

impl PoseTrack {
    /// A track from `(stamp, pose)` samples in any order; samples with a non-finite
    /// stamp are dropped, and of several samples with one stamp the first is kept.
    pub fn new(samples: impl IntoIterator<Item = (f64, Pose2)>) -> Self {
        let mut s: Vec<(f64, Pose2)> = samples
            .into_iter()
            .filter(|(t, p)| t.is_finite() && p.is_finite())
            .collect();
        s.sort_by(|a, b| a.0.total_cmp(&b.0));
        s.dedup_by(|b, a| a.0 == b.0);
        Self {
            stamps: s.iter().map(|x| x.0).collect(),
            poses: s.iter().map(|x| x.1).collect(),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.stamps.len()
    }

    /// True without samples.
    pub fn is_empty(&self) -> bool {
        self.stamps.is_empty()
    }

    /// First and last stamp.
    pub fn span(&self) -> Option<[f64; 2]> {
        Some([*self.stamps.first()?, *self.stamps.last()?])
    }

    /// The pose at time `t`: linear between the samples around `t` (x, y; heading by
    /// the shorter way round, wrapped to (−π, π]); `None` outside the track or when
    /// the samples around `t` are more than `max_gap` seconds apart.
    pub fn at(&self, t: f64, max_gap: f64) -> Option<Pose2> {
        if !t.is_finite() {
            return None;
        }
        let k = self.stamps.partition_point(|&s| s < t);
        if k < self.stamps.len() && self.stamps[k] == t {
            return Some(self.poses[k]);
        }
        if k == 0 || k >= self.stamps.len() {
            return None;
        }
        let (t0, t1) = (self.stamps[k - 1], self.stamps[k]);
        if t1 - t0 > max_gap {
            return None;
        }
        let (a, b) = (self.poses[k - 1], self.poses[k]);
        let w = (t - t0) / (t1 - t0);
        let x = a.x() + w * (b.x() - a.x());
        let y = a.y() + w * (b.y() - a.y());
        let theta = wrap(a.theta() + w * wrap(b.theta() - a.theta()));
        Some(Pose2::new(x, y, theta))
    }
}

/// An object's footprint: a rectangle in the object's pose frame (x forward, y left),
/// `length` along x and `width` along y, centred at (`centre_x`, `centre_y`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Footprint {
    /// Extent along the object's x axis (m).
    pub length: f64,
    /// Extent along the object's y axis (m).
    pub width: f64,
    /// Centre's x in the object's pose frame (m).
    pub centre_x: f64,
    /// Centre's y in the object's pose frame (m).
    pub centre_y: f64,
}

impl Footprint {
    /// Whether `point` (in the frame `object` is expressed in) lies within `margin` of
    /// the footprint of an object at pose `object` (the distance to the rectangle,
    /// 0 inside it).
    pub fn contains(&self, object: &Pose2, point: &Point2<f64>, margin: f64) -> bool {
        let q = object.inverse().transform_point(point);
        let d = Vector2::new(
            ((q.x - self.centre_x).abs() - self.length / 2.0).max(0.0),
            ((q.y - self.centre_y).abs() - self.width / 2.0).max(0.0),
        );
        d.norm() <= margin
    }

    /// Checks that the sizes are positive and every value finite.
    pub fn validate(&self) -> Result<(), String> {
        let v = [self.length, self.width, self.centre_x, self.centre_y];
        if v.iter().any(|x| !x.is_finite()) || self.length <= 0.0 || self.width <= 0.0 {
            return Err(format!(
                "footprint {},{},{},{}: length and width must be positive, all values finite",
                self.length, self.width, self.centre_x, self.centre_y
            ));
        }
        Ok(())
    }
}

/// Options of [`mocap_pair`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MocapOptions {
    /// The pose that matches a scan is read at the scan's header stamp plus this
    /// many seconds (the datmo README: 0.025 s).
    pub pose_delay: f64,
    /// A return within this distance (m) of the object's footprint is the object
    /// (datmo README: 0.05 m).
    pub label_margin: f64,
    /// Pose samples more than this many seconds apart are not interpolated between
    /// (the motion-capture track has a gap there): a scan that falls in such a gap has
    /// no ground truth.
    pub max_pose_gap: f64,
    /// The object is a mover in a pair only when its footprint's centre moves at
    /// least this fast (m/s) between the two scans; a standing object is static
    /// background, like a standing person in the leigh-gtm1 labels (default 0.5 m/s,
    /// the leigh-gtm1 walking speed; 0 labels the object whatever it does, the datmo
    /// README's literal rule).
    pub object_min_speed: f64,
}

impl Default for MocapOptions {
    fn default() -> Self {
        Self {
            pose_delay: 0.0,
            label_margin: 0.05,
            max_pose_gap: 0.1,
            object_min_speed: 0.5,
        }
    }
}

/// The moving object of [`mocap_pair`]: its pose track and footprint.
#[derive(Clone, Copy, Debug)]
pub struct TrackedObject<'a> {
    /// Pose track of the object (in the same frame as the robot's).
    pub track: &'a PoseTrack,
    /// Its footprint.
    pub footprint: Footprint,
    /// The kind written into the object's [`ClusterMotion`] (`"car"`).
    pub kind: &'a str,
}

/// The laser's pose in the pose track's frame at `scan`'s time, if the track covers it.
pub fn laser_pose(
    track: &PoseTrack,
    mount: &Pose2,
    scan: &Scan,
    options: &MocapOptions,
) -> Option<Pose2> {
    track
        .at(scan.timestamp + options.pose_delay, options.max_pose_gap)
        .map(|e| e.compose(mount))
}

pub(crate) fn labels(
    scan: &Scan,
    laser: &Pose2,
    object: Option<(&Pose2, &Footprint)>,
    margin: f64,
) -> Vec<Option<u32>> {
    (0..scan.len())
        .map(|k| {
            if !scan.valid[k] {
                return None;
            }
            let hit = object.is_some_and(|(pose, footprint)| {
                footprint.contains(pose, &laser.transform_point(&scan.beam_point(k)), margin)
            });
            Some(u32::from(hit))
        })
        .collect()
}

/// The pair (reference, current) with motion-capture ground truth (module docs), named
/// `name`; `None` when a track does not cover a scan's time. The scans' `laser_offset`
/// is set to `mount`; their odometry (if any) is kept and gives the prior. Without an
/// object, the labels are `None` (nothing says what moves) and only the ego-motion is
/// known.
pub fn mocap_pair(
    name: String,
    reference: &Scan,
    current: &Scan,
    ego_track: &PoseTrack,
    mount: &Pose2,
    object: Option<TrackedObject<'_>>,
    options: &MocapOptions,
) -> Option<ScanPair> {
    let l_i = laser_pose(ego_track, mount, reference, options)?;
    let l_j = laser_pose(ego_track, mount, current, options)?;
    let ego = l_i.between(&l_j);
    let mut motions = vec![ClusterMotion {
        label: 0,
        motion: ego,
        kind: "background".into(),
    }];
    let (labels_j, labels_i) = match object {
        Some(o) => {
            let c_i = o.track.at(
                reference.timestamp + options.pose_delay,
                options.max_pose_gap,
            )?;
            let c_j = o
                .track
                .at(current.timestamp + options.pose_delay, options.max_pose_gap)?;
            let centre = Point2::new(o.footprint.centre_x, o.footprint.centre_y);
            let moved = (c_j.transform_point(&centre) - c_i.transform_point(&centre)).norm();
            let gap = (current.timestamp - reference.timestamp).abs();
            let moving = moved >= options.object_min_speed * gap;
            motions.push(ClusterMotion {
                label: 1,
                motion: l_i
                    .inverse()
                    .compose(&c_i)
                    .compose(&c_j.inverse())
                    .compose(&l_j),
                kind: if moving {
                    o.kind.to_string()
                } else {
                    format!("{} (standing: background)", o.kind)
                },
            });
            let object_j = moving.then_some((&c_j, &o.footprint));
            let object_i = moving.then_some((&c_i, &o.footprint));
            (
                Some(labels(current, &l_j, object_j, options.label_margin)),
                Some(labels(reference, &l_i, object_i, options.label_margin)),
            )
        }
        None => (None, None),
    };
    let objects = object.and_then(|o| {
        crate::tracking_truth::mocap_object(current, ego_track, mount, &o, options).map(|c| vec![c])
    });
    let mut reference = reference.clone();
    let mut current = current.clone();
    reference.laser_offset = *mount;
    current.laser_offset = *mount;
    Some(ScanPair {
        name,
        odometry: crate::builders::odometry_prior(&reference, &current),
        reference,
        current,
        truth: Some(GroundTruth {
            ego_motion: Some(ego),
            labels: labels_j,
            reference_labels: labels_i,
            associations: None,
            motions,
            objects,
        }),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_gaps_and_ends() {
        let t = PoseTrack::new(vec![
            (1.0, Pose2::new(0.0, 0.0, 0.0)),
            (0.0, Pose2::new(-1.0, 0.0, 0.0)),
            (3.0, Pose2::new(4.0, 0.0, 0.0)),
        ]);
        assert_eq!(t.span(), Some([0.0, 3.0]));
        assert_eq!(t.at(0.0, 0.5), Some(Pose2::new(-1.0, 0.0, 0.0)));
        assert!((t.at(0.25, 1.0).unwrap().x() + 0.75).abs() < 1e-12);
        assert!(
            t.at(2.0, 1.0).is_none(),
            "a 2 s gap is not bridged with max_gap 1"
        );
        assert!(t.at(2.0, 2.0).is_some());
        assert!(t.at(-0.1, 1.0).is_none() && t.at(3.1, 9.0).is_none());
    }

    #[test]
    fn object_motion_maps_current_object_points_onto_reference() {
        // Robot drives +x, object drives +y; laser mounted with an offset.
        let ego = PoseTrack::new(vec![
            (0.0, Pose2::new(0.0, 0.0, 0.1)),
            (1.0, Pose2::new(1.0, 0.0, 0.2)),
        ]);
        let car = PoseTrack::new(vec![
            (0.0, Pose2::new(5.0, 0.0, 1.5)),
            (1.0, Pose2::new(5.0, 1.0, 1.6)),
        ]);
        let mount = Pose2::new(-0.164, 0.027, 0.005);
        let footprint = Footprint {
            length: 0.43,
            width: 0.187,
            centre_x: 0.057,
            centre_y: 0.028,
        };
        // A current scan with one beam on the car's centre (the tracks here have one
        // sample a second).
        let options = MocapOptions {
            max_pose_gap: 2.0,
            ..MocapOptions::default()
        };
        let (t_i, t_j) = (0.2, 0.8);
        let l_j = ego.at(t_j, 1.0).unwrap().compose(&mount);
        let c_j = car.at(t_j, 1.0).unwrap();
        let centre_world = c_j.transform_point(&Point2::new(0.057, 0.028));
        let p = l_j.inverse().transform_point(&centre_world);
        let mut current = Scan::from_ranges(
            vec![p.y.atan2(p.x), p.y.atan2(p.x) + 0.5],
            vec![p.coords.norm(), 3.0],
            20.0,
        );
        current.timestamp = t_j;
        let mut reference = current.clone();
        reference.timestamp = t_i;
        let object = TrackedObject {
            track: &car,
            footprint,
            kind: "car",
        };
        let pair = mocap_pair(
            "p".into(),
            &reference,
            &current,
            &ego,
            &mount,
            Some(object),
            &options,
        )
        .unwrap();
        let truth = pair.truth.unwrap();
        assert_eq!(truth.labels.as_ref().unwrap(), &vec![Some(1), Some(0)]);
        // Where the car's centre was at t_i, in the reference laser frame.
        let l_i = ego.at(t_i, 1.0).unwrap().compose(&mount);
        let c_i = car.at(t_i, 1.0).unwrap();
        let expected = l_i
            .inverse()
            .transform_point(&c_i.transform_point(&Point2::new(0.057, 0.028)));
        let got = truth.motions[1]
            .motion
            .transform_point(&current.beam_point(0));
        assert!((got - expected).norm() < 1e-9, "{got:?} vs {expected:?}");
        // The background motion is the ego-motion between the laser poses.
        let ego_motion = truth.ego_motion.unwrap();
        assert!(ego_motion.translation_error(&l_i.between(&l_j)) < 1e-12);
        assert!(pair.odometry.is_none());
        // Outside the tracks: no pair.
        let mut late = current.clone();
        late.timestamp = 1.5;
        assert!(mocap_pair(
            "q".into(),
            &reference,
            &late,
            &ego,
            &mount,
            Some(object),
            &options
        )
        .is_none());
    }
}
