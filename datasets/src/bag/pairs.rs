//! Scan pairs from a [`BagLog`]: what ground truth a pair gets depends on the topics
//! read.
//!
//! - **People topic** (leigh-gtm1 bags): the bag becomes a leigh-gtm1 log
//!   ([`to_leigh`]) and [`crate::builders::leigh_pairs`] builds the pairs, so a bag and
//!   its text export give the same pairs. Scans are numbered from 0 in record-time
//!   order (the text export's `idx`); an annotation belongs to the last scan recorded
//!   at or before it (the annotation tool publishes each annotation after the scan it
//!   annotates, half way to the next one); odometry comes from the odometry topic,
//!   interpolated at each scan's header stamp.
//! - **Ego and object pose topics** (motion capture, the datmo bags): pairs `k` scans
//!   apart with the true ego-motion, the object's true motion and per-point labels
//!   from the object's footprint ([`crate::mocap`]).
//! - **Ego pose topic only**: pairs `k` scans apart with the true ego-motion and no
//!   labels (for scan matching).
//! - **Neither**: pairs `k` scans apart without ground truth.
//!
//! The laser's mounting on the robot ([`BagPairOptions::laser_mount`]) is, when not
//! given, the bag's `/tf` (or `/tf_static`) edge from the odometry's child frame to
//! the scan's frame, else the identity (with a note). Odometry is interpolated
//! linearly at each scan's header stamp between the odometry messages' header stamps
//! (heading the short way round); a scan outside the odometry's time span has none.

use super::{BagLog, BagScan};
use crate::builders::{leigh_pairs, odometry_prior, LeighPairOptions};
use crate::error::{Error, Result};
use crate::leigh::{IndexedScan, LeighScans, PersonAnnotation};
use crate::mocap::{mocap_pair, Footprint, MocapOptions, PoseTrack, TrackedObject};
use crate::pair::ScanPair;
use pgm_scan::Pose2;
use std::collections::BTreeMap;

/// Options of [`bag_pairs`].
#[derive(Clone, Debug, PartialEq)]
pub struct BagPairOptions {
    /// Distance between the two scans of a pair, in scans (≥ 1).
    pub k: usize,
    /// The laser's pose on the robot (x, y, yaw), in the frame the odometry and the
    /// ego pose track follow; `None`: from the bag's tf, else the identity.
    pub laser_mount: Option<Pose2>,
    /// Motion capture: timing, label margin, largest gap in a pose track.
    pub mocap: MocapOptions,
    /// Motion capture: the tracked object's footprint (needed with an object pose
    /// topic).
    pub object_footprint: Option<Footprint>,
    /// People labels (leigh-gtm1 rule and thresholds; its `k` is replaced by
    /// [`BagPairOptions::k`], its `name` by the pair-name prefix).
    pub leigh: LeighPairOptions,
    /// Prefix of the pair names; default the bag's file stem.
    pub name: Option<String>,
}

impl Default for BagPairOptions {
    fn default() -> Self {
        Self {
            k: 1,
            laser_mount: None,
            mocap: MocapOptions::default(),
            object_footprint: None,
            leigh: LeighPairOptions::default(),
            name: None,
        }
    }
}

/// Pairs of a bag and the notes for the user ([`bag_pairs`]).
#[derive(Clone, Debug, PartialEq)]
pub struct BagPairs {
    /// The pairs.
    pub pairs: Vec<ScanPair>,
    /// What the builder decided or left out (the mounting's source, scans without
    /// ground truth, annotations before the first scan), each naming the bag.
    pub notes: Vec<String>,
}

fn mismatch(log: &BagLog, what: impl std::fmt::Display) -> Error {
    Error::Mismatch {
        what: format!("{}: {what}", log.path.display()),
    }
}

/// The bag's file name without `.zip`, `.bag` or `.mcap`.
pub fn bag_stem(log: &BagLog) -> String {
    let name = log
        .path
        .file_name()
        .map_or_else(|| "bag".into(), |s| s.to_string_lossy().into_owned());
    let mut stem = name.as_str();
    for ext in [".zip", ".bag", ".mcap"] {
        stem = stem.strip_suffix(ext).unwrap_or(stem);
    }
    stem.to_string()
}

/// The laser's mounting: the option, else the tf edge from the odometry's child frame
/// to the scan frame, else the identity; with a note saying which.
pub fn laser_mount(log: &BagLog, given: Option<Pose2>) -> (Pose2, String) {
    if let Some(m) = given {
        return (
            m,
            format!(
                "{}: laser mounting as given: {}",
                log.path.display(),
                show(&m)
            ),
        );
    }
    let scan_frame = &log.scans[0].frame;
    let robot = log.odometry.first().map(|o| o.child_frame.clone());
    if let Some(robot) = robot.filter(|r| !r.is_empty()) {
        if let Some(m) = log.transform(&robot, scan_frame) {
            return (
                m,
                format!(
                    "{}: laser mounting from tf {robot} → {scan_frame}: {}",
                    log.path.display(),
                    show(&m)
                ),
            );
        }
    }
    let why = if log.odometry.is_empty() {
        "no odometry topic to name the robot frame".to_string()
    } else {
        format!("no tf edge from the odometry's frame to the scan frame {scan_frame}")
    };
    (
        Pose2::identity(),
        format!(
            "{}: no --laser-mount and {why}: the laser is taken at the origin of the robot \
             frame",
            log.path.display()
        ),
    )
}

fn show(p: &Pose2) -> String {
    format!(
        "x {:.6} m, y {:.6} m, yaw {:.6} rad",
        p.x(),
        p.y(),
        p.theta()
    )
}

/// The odometry track of the bag (robot base in the odometry frame), if it has one.
pub fn odometry_track(log: &BagLog) -> Option<PoseTrack> {
    (!log.odometry.is_empty())
        .then(|| PoseTrack::new(log.odometry.iter().map(|o| (o.stamp, o.pose))))
}

/// The bag's scans with the mounting set and the odometry (when the bag has it)
/// interpolated at each scan's stamp (on the clock [`BagLog::clock`] chose); notes on
/// scans outside the odometry, after the reader's own ([`BagLog::notes`]).
pub fn prepared_scans(log: &BagLog, mount: &Pose2, notes: &mut Vec<String>) -> Vec<BagScan> {
    notes.extend(log.notes.iter().cloned());
    let track = odometry_track(log);
    let mut outside = 0;
    let scans = log
        .scans
        .iter()
        .map(|s| {
            let mut s = s.clone();
            s.scan.laser_offset = *mount;
            if let Some(track) = &track {
                s.scan.odometry = track.at(s.stamp, f64::INFINITY);
                outside += usize::from(s.scan.odometry.is_none());
            }
            s
        })
        .collect();
    if outside > 0 {
        notes.push(format!(
            "{}: {outside} scans lie outside the odometry's time span and have no odometry",
            log.path.display()
        ));
    }
    scans
}

/// The bag as a leigh-gtm1 log (module docs): scans numbered from 0 (the line of each
/// [`IndexedScan`] is its message number on the scan topic), annotations assigned to
/// the last scan recorded at or before them.
pub fn to_leigh(
    log: &BagLog,
    scans: &[BagScan],
    notes: &mut Vec<String>,
) -> (LeighScans, Vec<PersonAnnotation>) {
    let leigh = LeighScans {
        scans: scans
            .iter()
            .enumerate()
            .map(|(index, s)| IndexedScan {
                index,
                scan: s.scan.clone(),
                line: s.number,
                record_time: s.time,
            })
            .collect(),
        skipped: BTreeMap::new(),
        clock: log.clock,
        notes: Vec::new(),
    };
    let mut annotations: BTreeMap<(usize, u32), PersonAnnotation> = BTreeMap::new();
    let (mut before, mut replaced) = (0, 0);
    for p in &log.people {
        let at = scans.partition_point(|s| s.time <= p.time);
        let Some(scan) = at.checked_sub(1) else {
            before += 1;
            continue;
        };
        let a = PersonAnnotation {
            scan,
            person: p.id,
            centre: p.position,
            line: p.number,
        };
        replaced += usize::from(annotations.insert((scan, p.id), a).is_some());
    }
    if before > 0 {
        notes.push(format!(
            "{}: {before} people annotations were recorded before the first scan and are not used",
            log.path.display()
        ));
    }
    if replaced > 0 {
        notes.push(format!(
            "{}: {replaced} people annotations repeat a person already annotated for the same \
             scan; the later one is used",
            log.path.display()
        ));
    }
    let mut people: Vec<PersonAnnotation> = annotations.into_values().collect();
    people.sort_by_key(|a| a.line);
    (leigh, people)
}

/// Refuses a people topic without one annotation in the time of the scans (`people`
/// as [`to_leigh`] made them): it labels nothing.
///
/// # Errors
/// [`Error::Mismatch`] naming the bag and the topic.
pub fn require_people(log: &BagLog, people: &[PersonAnnotation]) -> Result<()> {
    if people.is_empty() {
        let topic = log.read.people.as_deref().unwrap_or("");
        return Err(mismatch(
            log,
            format!(
                "the people topic {topic} holds no annotation at or after the first scan \
                 ({} messages on it): it labels nothing",
                log.people.len()
            ),
        ));
    }
    Ok(())
}

/// Checks that every annotation of the bag's people topic lies within the reach of
/// its scan (`range_max` plus [`crate::leigh::PERSON_REACH_MARGIN`]); `scans` and
/// `people` as [`to_leigh`] made them.
///
/// # Errors
/// [`crate::Error::Bag`] naming the people topic, the message and the position.
pub fn check_people_reach(
    log: &BagLog,
    scans: &LeighScans,
    people: &[PersonAnnotation],
) -> Result<()> {
    let Some(far) = crate::leigh::people_out_of_reach(scans, people) else {
        return Ok(());
    };
    let a = far.annotation;
    Err(crate::bag::bag_error(
        &log.path,
        crate::bag::BagLocation {
            topic: log.read.people.clone().unwrap_or_default(),
            message: a.line,
            time: None,
            field: "position".into(),
        },
        format!(
            "person {} at ({}, {}) is {:.2} m from the laser, beyond its reach: scan {} \
             (message {} of {}) declares range_max {} m, and a centre may lie at most {} m \
             beyond it",
            a.person,
            a.centre.x,
            a.centre.y,
            far.distance,
            a.scan,
            far.scan.map_or(0, |s| s.line),
            log.read.scan,
            far.range_max,
            crate::leigh::PERSON_REACH_MARGIN
        ),
    ))
}

/// The pairs of a bag (module docs).
///
/// # Errors
/// `k = 0` or larger than the number of scans; an object pose topic without a
/// footprint; the leigh builder's errors.
pub fn bag_pairs(log: &BagLog, options: &BagPairOptions) -> Result<BagPairs> {
    let mut notes = Vec::new();
    let k = options.k;
    if k == 0 || k >= log.scans.len() {
        return Err(mismatch(
            log,
            format!(
                "k = {k}: pairs need 1 <= k < the number of scans ({})",
                log.scans.len()
            ),
        ));
    }
    let name = options.name.clone().unwrap_or_else(|| bag_stem(log));
    let (mount, mount_note) = laser_mount(log, options.laser_mount);
    notes.push(mount_note);
    let scans = prepared_scans(log, &mount, &mut notes);
    if log.read.people.is_some() {
        let (leigh, people) = to_leigh(log, &scans, &mut notes);
        require_people(log, &people)?;
        check_people_reach(log, &leigh, &people)?;
        let leigh_options = LeighPairOptions {
            k,
            name,
            ..options.leigh.clone()
        };
        let pairs = leigh_pairs(&leigh, &people, &leigh_options).map_err(|e| mismatch(log, e))?;
        return Ok(BagPairs { pairs, notes });
    }
    let mut pairs = Vec::new();
    if log.read.ego_pose.is_some() {
        let ego = PoseTrack::new(log.ego_poses.iter().map(|p| (p.stamp, p.pose)));
        let object_track = log
            .read
            .object_pose
            .as_ref()
            .map(|_| PoseTrack::new(log.object_poses.iter().map(|p| (p.stamp, p.pose))));
        let footprint = match (&object_track, options.object_footprint) {
            (Some(_), None) => {
                return Err(mismatch(
                    log,
                    "an object pose topic needs the object's footprint to label returns \
                     (--object-footprint LENGTH,WIDTH,CENTRE_X,CENTRE_Y)",
                ))
            }
            (_, Some(f)) => {
                f.validate().map_err(|e| mismatch(log, e))?;
                Some(f)
            }
            (None, None) => None,
        };
        let mut without = 0;
        for i in 0..scans.len() - k {
            let (a, b) = (&scans[i], &scans[i + k]);
            let object = object_track
                .as_ref()
                .zip(footprint)
                .map(|(track, footprint)| TrackedObject {
                    track,
                    footprint,
                    kind: "object",
                });
            match mocap_pair(
                format!("{name}:{i}-{}", i + k),
                &a.scan,
                &b.scan,
                &ego,
                &mount,
                object,
                &options.mocap,
            ) {
                Some(p) => pairs.push(p),
                None => without += 1,
            }
        }
        if without > 0 {
            notes.push(format!(
                "{}: {without} of {} pairs have a scan the pose tracks do not cover (at the \
                 header stamp + {} s, no gap over {} s) and are left out",
                log.path.display(),
                scans.len() - k,
                options.mocap.pose_delay,
                options.mocap.max_pose_gap
            ));
        }
        return Ok(BagPairs { pairs, notes });
    }
    for i in 0..scans.len() - k {
        let (a, b) = (&scans[i].scan, &scans[i + k].scan);
        pairs.push(ScanPair {
            name: format!("{name}:{i}-{}", i + k),
            odometry: odometry_prior(a, b),
            reference: a.clone(),
            current: b.clone(),
            truth: None,
        });
    }
    Ok(BagPairs { pairs, notes })
}

/// Scans `i` (reference) and `j` (current) of a bag (numbered from 0 in record-time
/// order), without ground truth, with the odometry prior when the bag has odometry
/// (`pgm cluster`, `pgm match`).
///
/// # Errors
/// A scan that does not exist or has no valid return ([`Error::Scan`], naming the
/// bag and the scan's message number); `i == j` (the two scans of a pair must differ).
pub fn bag_scan_pair(
    log: &BagLog,
    i: usize,
    j: usize,
    laser_mount: Option<Pose2>,
    notes: &mut Vec<String>,
) -> Result<ScanPair> {
    crate::builders::distinct_scans(&log.path, i, j)?;
    let (mount, note) = self::laser_mount(log, laser_mount);
    notes.push(note);
    let scans = prepared_scans(log, &mount, notes);
    let get = |k: usize| {
        let s = scans.get(k).ok_or_else(|| Error::Scan {
            path: log.path.clone(),
            line: 0,
            scan: k,
            problem: format!(
                "no such scan on {} (it has {}, numbered from 0)",
                log.read.scan,
                scans.len()
            ),
        })?;
        if s.scan.valid_count() == 0 {
            return Err(Error::Scan {
                path: log.path.clone(),
                line: s.number,
                scan: k,
                problem: format!(
                    "message {} of {} has no valid return among its {} beams",
                    s.number,
                    log.read.scan,
                    s.scan.len()
                ),
            });
        }
        Ok(&s.scan)
    };
    let (a, b) = (get(i)?, get(j)?);
    Ok(ScanPair {
        name: format!("{}:{i}-{j}", bag_stem(log)),
        odometry: odometry_prior(a, b),
        reference: a.clone(),
        current: b.clone(),
        truth: None,
    })
}
