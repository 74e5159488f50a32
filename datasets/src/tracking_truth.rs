//! Tracking ground truth scan by scan: the objects to track in each annotated scan,
//! each with its identity and true centre in that scan's laser frame
//! ([`ObjectCentre`]), for CLEAR-MOT scoring ([`crate::clear_mot`]).
//!
//! | source | objects | centre | `moving` | `returns` |
//! |---|---|---|---|---|
//! | leigh-gtm1 people (text log or bag topic) | every annotated person, id = person id | the annotation (body centre) | the data README's track rule: a line fitted to the person's annotations in the odometry frame over scans `j − w … j + w` has a speed of at least the walking speed (`None` without odometry) | valid returns within the person radius |
//! | motion capture (datmo) | the tracked object, id 1 | its footprint's centre | its footprint centre moves at least the object's minimum speed (central difference over ±0.05 s) | valid returns inside the footprint widened by the label margin |
//! | stored pairs (`pgm sim`, `pgm data pairs`) | [`GroundTruth::objects`](pgm_scan::GroundTruth::objects) of each pair's current scan | as stored | as stored | as stored |
//!
//! Scans are named as the sequence built from consecutive pairs names them: `LOG:J`
//! for scan `J` of log `LOG` (a pair `LOG:I-J`, [`scan_names`]). A scan that is not in
//! the map is not annotated for tracking; one mapped to an empty list is annotated and
//! holds no object.

use crate::bag::pairs::{bag_stem, laser_mount, prepared_scans, to_leigh, BagPairOptions};
use crate::bag::BagLog;
use crate::builders::{
    leigh_annotations_in_odometry_frame, scan_period, track_fit, LabelRule, LeighPairOptions,
};
use crate::leigh::{LeighScans, PersonAnnotation};
use crate::mocap::{laser_pose, MocapOptions, PoseTrack, TrackedObject};
use crate::{Error, Result};
use nalgebra::Point2;
use pgm_scan::{ObjectCentre, Pose2, Scan, ScanPair};
use std::collections::BTreeMap;

/// Half the time span (s) over which a motion-capture object's speed is measured.
const SPEED_HALF_SPAN: f64 = 0.05;

/// The tracking id of a motion-captured object (a bag holds one).
pub const MOCAP_OBJECT_ID: u64 = 1;

/// The tracking truth of a source, scan by scan (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrackingTruth {
    /// Scan name (`LOG:J`) → the objects annotated in it.
    pub scans: BTreeMap<String, Vec<ObjectCentre>>,
    /// What the truth is, for a report (`"leigh-gtm1 people annotations, walking by the
    /// track rule at 0.5 m/s"`).
    pub what: String,
    /// Notes for the user (annotations left out, and why).
    pub notes: Vec<String>,
}

/// The log and the two scan indices of a pair named `LOG:I-J` (as every reader and
/// `pgm sim --sequence` name pairs); `None` for a name of another form.
pub fn scan_names(pair_name: &str) -> Option<(&str, usize, usize)> {
    let (log, ab) = pair_name.rsplit_once(':')?;
    let (a, b) = ab.split_once('-')?;
    Some((log, a.parse().ok()?, b.parse().ok()?))
}

/// The tracking truth stored in pairs: each pair's [`GroundTruth::objects`](pgm_scan::GroundTruth::objects) under the
/// name of its current scan (`LOG:J`, or the pair's name when it is not of the form
/// `LOG:I-J`). Pairs without objects add nothing; when two pairs share a current scan
/// the first one's objects are used.
pub fn stored_objects(pairs: &[ScanPair]) -> TrackingTruth {
    let mut scans = BTreeMap::new();
    for pair in pairs {
        let Some(objects) = pair.truth.as_ref().and_then(|t| t.objects.as_ref()) else {
            continue;
        };
        let name = match scan_names(&pair.name) {
            Some((log, _, j)) => format!("{log}:{j}"),
            None => pair.name.clone(),
        };
        scans.entry(name).or_insert_with(|| objects.clone());
    }
    TrackingTruth {
        scans,
        what: "the objects stored with the pairs' ground truth".into(),
        notes: Vec::new(),
    }
}

/// Valid returns of `scan` within `radius` of `centre` (laser frame).
pub(crate) fn returns_near(scan: &Scan, centre: &Point2<f64>, radius: f64) -> usize {
    (0..scan.len())
        .filter(|&k| scan.valid[k] && (scan.beam_point(k) - centre).norm() <= radius)
        .count()
}

/// Every annotated person of every annotated scan of a leigh-gtm1 log (module docs),
/// by scan index. `moving` follows `options`' track rule (walking speed and window)
/// when the scans have odometry, else it is `None` (and a note says so). Annotations
/// of a scan the log does not hold are left out, with a note.
pub fn leigh_objects(
    scans: &LeighScans,
    people: &[PersonAnnotation],
    options: &LeighPairOptions,
    notes: &mut Vec<String>,
) -> BTreeMap<usize, Vec<ObjectCentre>> {
    let world = match options.rule {
        LabelRule::Track if options.walking_speed > 0.0 => {
            match leigh_annotations_in_odometry_frame(scans, people) {
                Ok(w) => Some(w),
                Err(e) => {
                    notes.push(format!(
                        "who walks is not known ({e}): the annotations carry no `moving` flag"
                    ));
                    None
                }
            }
        }
        _ => None,
    };
    let period = scan_period(scans);
    let mut by_scan: BTreeMap<usize, BTreeMap<u32, Point2<f64>>> = BTreeMap::new();
    let absent: Vec<&PersonAnnotation> = people
        .iter()
        .filter(|a| scans.get(a.scan).is_none())
        .collect();
    if let Some(first) = absent.first() {
        notes.push(format!(
            "{} of {} annotations name a scan the log does not hold (first: line {}, scan \
             {}): they are left out of the tracking truth",
            absent.len(),
            people.len(),
            first.line,
            first.scan
        ));
    }
    for a in people.iter().filter(|a| scans.get(a.scan).is_some()) {
        by_scan
            .entry(a.scan)
            .or_default()
            .insert(a.person, a.centre);
    }
    by_scan
        .into_iter()
        .map(|(j, at)| {
            let scan = scans.get(j).map(|s| &s.scan);
            let objects = at
                .into_iter()
                .map(|(person, c)| {
                    let moving = world.as_ref().and_then(|w| {
                        let lo = j.saturating_sub(options.track_window);
                        let hi = j.saturating_add(options.track_window);
                        track_fit(w, person, lo, hi, period)
                            .map(|f| f.speed >= options.walking_speed)
                    });
                    ObjectCentre {
                        id: u64::from(person),
                        x: c.x,
                        y: c.y,
                        moving,
                        returns: scan.map(|s| returns_near(s, &c, options.person_radius)),
                    }
                })
                .collect();
            (j, objects)
        })
        .collect()
}

/// The motion-captured object in `scan` (module docs): its footprint centre in the
/// laser frame at the scan's stamp plus the pose delay, `None` when a track does not
/// cover that time; its id is [`MOCAP_OBJECT_ID`]. `mount` is the laser's pose in the ego pose frame.
pub fn mocap_object(
    scan: &Scan,
    ego: &PoseTrack,
    mount: &Pose2,
    object: &TrackedObject<'_>,
    options: &MocapOptions,
) -> Option<ObjectCentre> {
    let laser = laser_pose(ego, mount, scan, options)?;
    let t = scan.timestamp + options.pose_delay;
    let pose = object.track.at(t, options.max_pose_gap)?;
    let local = Point2::new(object.footprint.centre_x, object.footprint.centre_y);
    let centre_at = |p: &Pose2| p.transform_point(&local);
    let before = object.track.at(t - SPEED_HALF_SPAN, options.max_pose_gap);
    let after = object.track.at(t + SPEED_HALF_SPAN, options.max_pose_gap);
    let speed = match (before, after) {
        (Some(b), Some(a)) => {
            Some((centre_at(&a) - centre_at(&b)).norm() / (2.0 * SPEED_HALF_SPAN))
        }
        (Some(b), None) => Some((centre_at(&pose) - centre_at(&b)).norm() / SPEED_HALF_SPAN),
        (None, Some(a)) => Some((centre_at(&a) - centre_at(&pose)).norm() / SPEED_HALF_SPAN),
        (None, None) => None,
    };
    let c = laser.inverse().transform_point(&centre_at(&pose));
    let returns = crate::mocap::labels(
        scan,
        &laser,
        Some((&pose, &object.footprint)),
        options.label_margin,
    )
    .iter()
    .filter(|l| **l == Some(1))
    .count();
    Some(ObjectCentre {
        id: MOCAP_OBJECT_ID,
        x: c.x,
        y: c.y,
        moving: speed.map(|s| s >= options.object_min_speed),
        returns: Some(returns),
    })
}

/// The tracking truth of a bag (module docs): its people topic's annotations, or its
/// motion-captured object (which needs `options.object_footprint`), scan by scan,
/// scans numbered as [`crate::bag::pairs::bag_pairs`] numbers them and named
/// `NAME:J` (`options.name`, else the bag's stem).
///
/// # Errors
/// [`Error::Mismatch`] naming the bag when it has neither a people topic nor an object
/// pose topic, or an object pose topic without a footprint.
pub fn bag_objects(log: &BagLog, options: &BagPairOptions) -> Result<TrackingTruth> {
    let name = options.name.clone().unwrap_or_else(|| bag_stem(log));
    let mut notes = Vec::new();
    let (mount, mount_note) = laser_mount(log, options.laser_mount);
    notes.push(mount_note);
    let scans = prepared_scans(log, &mount, &mut notes);
    let mismatch = |what: String| Error::Mismatch {
        what: format!("{}: {what}", log.path.display()),
    };
    if log.read.people.is_some() {
        let (leigh, people) = to_leigh(log, &scans, &mut notes);
        let objects = leigh_objects(&leigh, &people, &options.leigh, &mut notes);
        return Ok(TrackingTruth {
            scans: objects
                .into_iter()
                .map(|(j, o)| (format!("{name}:{j}"), o))
                .collect(),
            what: leigh_what(&options.leigh),
            notes,
        });
    }
    if log.read.object_pose.is_none() || log.read.ego_pose.is_none() {
        return Err(mismatch(
            "tracking truth needs a people topic (annotated people) or an ego pose topic \
             with an object pose topic (motion capture)"
                .into(),
        ));
    }
    let Some(footprint) = options.object_footprint else {
        return Err(mismatch(
            "the object pose topic needs the object's footprint to place its centre \
             (--object-footprint LENGTH,WIDTH,CENTRE_X,CENTRE_Y)"
                .into(),
        ));
    };
    footprint.validate().map_err(mismatch)?;
    let ego = PoseTrack::new(log.ego_poses.iter().map(|p| (p.stamp, p.pose)));
    let track = PoseTrack::new(log.object_poses.iter().map(|p| (p.stamp, p.pose)));
    let object = TrackedObject {
        track: &track,
        footprint,
        kind: "object",
    };
    let mut uncovered = 0;
    let mut out = BTreeMap::new();
    for (j, s) in scans.iter().enumerate() {
        match mocap_object(&s.scan, &ego, &mount, &object, &options.mocap) {
            Some(o) => {
                out.insert(format!("{name}:{j}"), vec![o]);
            }
            None => uncovered += 1,
        }
    }
    if uncovered > 0 {
        notes.push(format!(
            "{}: {uncovered} of {} scans fall outside the pose tracks (at the header stamp + \
             {} s, no gap over {} s) and are not scored",
            log.path.display(),
            scans.len(),
            options.mocap.pose_delay,
            options.mocap.max_pose_gap
        ));
    }
    Ok(TrackingTruth {
        scans: out,
        what: format!(
            "the motion-captured object's footprint centre (id 1), moving at {} m/s or more",
            options.mocap.object_min_speed
        ),
        notes,
    })
}

/// The description of leigh-gtm1 truth under `options`.
pub fn leigh_what(options: &LeighPairOptions) -> String {
    match options.rule {
        LabelRule::Track if options.walking_speed > 0.0 => format!(
            "leigh-gtm1 people annotations; walking (moving) by the track rule: a line fitted \
             over ±{} scans at {} m/s or more",
            options.track_window, options.walking_speed
        ),
        _ => "leigh-gtm1 people annotations".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mocap::Footprint;

    #[test]
    fn annotations_of_scans_not_in_the_log_are_left_out_with_a_note() {
        use crate::leigh::{parse_people, parse_scans};
        use std::path::Path;
        let line = |i: usize| format!("SCAN {i} {i}.0 {i}.0 laser -1.0 0.5 0.1 10.0 5 1 2 3 2 1\n");
        let scans = parse_scans(Path::new("scans.txt"), &(line(0) + &line(1))).unwrap();
        let people = parse_people(
            Path::new("people.txt"),
            "PERSON 0 1 1.0 0.5\nPERSON 1 1 1.1 0.5\nPERSON 7 1 1.2 0.5\n",
        )
        .unwrap();
        let mut notes = Vec::new();
        let truth = leigh_objects(&scans, &people, &LeighPairOptions::default(), &mut notes);
        assert_eq!(truth.keys().copied().collect::<Vec<_>>(), vec![0, 1]);
        assert!(
            notes
                .iter()
                .any(|n| n.contains("1 of 3 annotations") && n.contains("line 3, scan 7")),
            "{notes:?}"
        );
    }

    #[test]
    fn pair_names_split_into_log_and_scans() {
        assert_eq!(
            scan_names("leigh-gtm1:133-134"),
            Some(("leigh-gtm1", 133, 134))
        );
        assert_eq!(
            scan_names("sim:mixed:1:0:4-5"),
            Some(("sim:mixed:1:0", 4, 5))
        );
        assert_eq!(scan_names("sim:mixed:1:7"), None);
        assert_eq!(scan_names("plain"), None);
    }

    #[test]
    fn mocap_object_centre_speed_and_returns() {
        // The ego stands at the origin; the object drives along +y at 1 m/s, 3 m ahead.
        let ego = PoseTrack::new(vec![
            (0.0, Pose2::new(0.0, 0.0, 0.0)),
            (2.0, Pose2::new(0.0, 0.0, 0.0)),
        ]);
        let car = PoseTrack::new(vec![
            (0.0, Pose2::new(3.0, -1.0, 0.0)),
            (2.0, Pose2::new(3.0, 1.0, 0.0)),
        ]);
        let footprint = Footprint {
            length: 0.4,
            width: 0.2,
            centre_x: 0.1,
            centre_y: 0.0,
        };
        let object = TrackedObject {
            track: &car,
            footprint,
            kind: "car",
        };
        let options = MocapOptions {
            max_pose_gap: 5.0,
            ..MocapOptions::default()
        };
        // At t = 1 the car is at (3, 0): its footprint centre at (3.1, 0). One beam hits
        // its back face, one misses.
        let mut scan = Scan::from_ranges(vec![0.0, 1.0], vec![2.9, 3.0], 20.0);
        scan.timestamp = 1.0;
        let o = mocap_object(&scan, &ego, &Pose2::identity(), &object, &options).unwrap();
        assert!((o.x - 3.1).abs() < 1e-9 && o.y.abs() < 1e-9, "{o:?}");
        assert_eq!(o.moving, Some(true));
        assert_eq!(o.returns, Some(1));
        // A slow object is not moving at the default 0.5 m/s.
        let slow = PoseTrack::new(vec![
            (0.0, Pose2::new(3.0, 0.0, 0.0)),
            (2.0, Pose2::new(3.0, 0.4, 0.0)),
        ]);
        let object = TrackedObject {
            track: &slow,
            ..object
        };
        let o = mocap_object(&scan, &ego, &Pose2::identity(), &object, &options).unwrap();
        assert_eq!(o.moving, Some(false));
        // Outside the tracks: nothing.
        scan.timestamp = 3.0;
        assert!(mocap_object(&scan, &ego, &Pose2::identity(), &object, &options).is_none());
    }
}
