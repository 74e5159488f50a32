//! Tracking moving objects over a sequence of scans: a pair-wise detector (any
//! [`MotionClusterer`]) on every requested pair, constant-velocity tracks across the
//! pairs' current scans, and each pair answered from the tracks, so that an object
//! keeps being reported while a single pair cannot show that it moves, and a detection
//! that no later scan shows moving is dropped.
//!
//! **Why.** Two scans alone cannot separate every mover from the background: an object
//! that keeps pace with the sensor (a car driven right behind or beside the robot, a
//! person walking just ahead of it) leaves no free space behind and its returns lie
//! close to where a static surface would be, so pair-wise detectors (CRF-Clustering's
//! free-space test, segment-wise ICP's static test) label it static; and wrong
//! associations make static clutter look moving in one pair. Over a sequence the
//! object was seen moving before, its track predicts where its returns are now, and
//! the fit there says whether it still moves; clutter does not move on. This is the
//! tracking half of detection and tracking of moving objects (C.-C. Wang, C. Thorpe
//! and S. Thrun, "Online simultaneous localization and mapping with detection and
//! tracking of moving objects", ICRA 2003), with nearest-neighbour data association,
//! a constant-velocity model smoothed as an alpha-beta filter, and M-of-N
//! confirmation.
//!
//! **The sequence.** The requested pairs are ordered by the time stamp of their
//! current scan. A pair continues the sequence of the previous one when both its scans
//! are later than the previous pair's and its current scan is
//! [`TrackingParams::min_step`] to [`TrackingParams::max_gap`] seconds after the
//! previous current scan; otherwise it starts a new sequence (the pairs of a set of
//! independent simulated scenes, `pgm sim` without `--sequence`, all start at time 0:
//! each is a sequence of its own, and its output is the detector's). Two pairs with
//! the same name are refused.
//!
//! **One step** (current scan `j`, previous current scan `j'`, `Δt` seconds apart):
//! 1. The motion `E` of scan `j` in the frame of `j'`: ICP from their odometry
//!    difference (the identity without odometry), without the returns reported moving
//!    in `j'` and detected moving in `j` (a car beside the robot would pull it along).
//! 2. Each track predicts its returns in scan `j`: its last returns moved by its
//!    velocity over `Δt`, then into the frame of `j`. The current returns within
//!    [`TrackingParams::gate`] of a predicted return, not taken by an earlier track,
//!    are its candidates; a translation-only ICP of the predicted returns onto them
//!    measures the motion, blended into the velocity with weight
//!    [`TrackingParams::smoothing`]. Found: at least
//!    [`TrackingParams::min_inlier_fraction`] of the track's returns have a candidate
//!    within [`TrackingParams::inlier_distance`]. A track not found for more than
//!    [`TrackingParams::max_coast`] scans ends.
//! 3. Evidence of motion at this step: the velocity moves the object at least
//!    [`TrackingParams::min_speed`]; so does its displacement since the track started,
//!    averaged over the time since (an unstable surface jitters in place); and the
//!    measured motion explains the returns clearly better (truncated cost
//!    `Σ min(d², τ²)`, `τ` the inlier distance, below [`TrackingParams::improvement`]
//!    times) than both static explanations: the track's returns still where they were,
//!    and its new returns already there in the previous scan. A track that slides
//!    along a static surface fits both.
//! 4. The detector's moving objects continue the track they share at least half their
//!    returns with, or a lost track whose predicted centre lies within the gate of
//!    theirs (a detection is evidence of motion), or start one: its velocity measured
//!    against the previous scan (the better fit of "static" and "as the detector's
//!    motion over the pair says", refined by a translation-only fit), else the
//!    detector's motion over the pair. A detection the previous scan shows slower than
//!    the speed that counts is no evidence. A track that was never found after its
//!    birth (its velocity rests on one measurement, or only on the detector's motion
//!    over the pair, and may be far off) is also continued by a detection whose own
//!    velocity, measured against the previous scan and at least that speed, moves it
//!    back to within the gate of where the track was born; the track then takes that
//!    velocity. Only when the two detections are independent evidence: the new pair
//!    starts no earlier than the scan the track was born in (with `k > 1`, the pairs
//!    of consecutive scans share `k − 1` scan intervals, and clutter the detector
//!    calls moving in one it tends to call moving in the next).
//! 5. Tracks found moving that the detector missed become objects too. Every object
//!    of the requested pair `(i, j)` continuing a track gets its motion over the pair
//!    from the track: the velocity scaled to the pair's time gap, shifted onto the
//!    reference scan's returns (a new track keeps the detector's motion).
//!
//! After the sequence, the objects of a track with fewer than
//! [`TrackingParams::min_evidence`] steps of evidence are dropped from every pair when
//! the track could be followed at least once, or when the previous scan showed its
//! detection slow (M-of-N confirmation over the whole sequence: the first detection of
//! a confirmed object is kept).
//!
//! **Backward** ([`TrackingParams::backward`], on by default). A detector often sees
//! an object only some scans after it started moving (a car driven just ahead of the
//! robot at nearly its speed moves too little against the background over one pair),
//! and a forward tracker cannot start before the first detection. So every confirmed
//! track is also followed back in time from the scan it was born in, by the same step
//! (2 and 3 above) on the consecutive scans taken in reverse, its velocity reversed.
//! A step from scan `j` back into `j'` that shows it moving shows it moving over
//! `j`'s step, so the pair of `j` reports it (on the returns the track was found on
//! there that no reported object holds), with its motion over the pair from the
//! track's velocity; the pair whose current scan starts the sequence is never
//! reported this way. It goes back only while every step shows it moving: the first
//! step that loses it or finds it still ends it (it stood before, or it is clutter
//! the detector took for a mover). This is the smoothing half of a forward-backward tracker: a track's
//! object is reported as the forward pass left it from its first detection on.
//! Measured on every real set (README, "Tracking over a sequence"): going on through
//! steps without evidence (coasting as the forward pass does, or up to
//! [`TrackingParams::max_coast`] such steps) found the same cars and more false
//! walkers on leigh-gtm1.
//!
//! Errors name the pair. [`Tracked`] follows the input order.

use crate::methods::{MotionClusterer, MotionClustering};
use crate::pair::{ClusterMotion, ScanPair};
use crate::registration::{Icp, IcpParams};
use crate::{Error, Pose2, Result};
use nalgebra::{Point2, Vector2};
use pgm_core::{InvalidParameter, ParamGuard};
use rayon::prelude::*;
use std::collections::HashMap;

/// Parameters of the [`Tracker`] (checked by [`ParamGuard::check`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackingParams {
    /// Slowest speed (m/s) that counts as moving (0.5: the walking-speed threshold by
    /// which the leigh-gtm1 and datmo labels call a person or a car moving).
    pub min_speed: f64,
    /// Largest distance (m) from a predicted return to a current return that the track
    /// may take (0.3).
    pub gate: f64,
    /// Inlier distance (m) of the measured motion, and truncation of its costs (0.1,
    /// ICP's final correspondence distance).
    pub inlier_distance: f64,
    /// Smallest fraction of a track's returns that must have an inlier for it to be
    /// found (0.5).
    pub min_inlier_fraction: f64,
    /// The measured motion must bring the truncated cost below this fraction of each
    /// static explanation's cost to count as evidence of motion (0.5, segment-wise
    /// ICP's `improvement`).
    pub improvement: f64,
    /// Fewest returns of a track (3, CRF-Clustering's smallest object).
    pub min_returns: usize,
    /// Scans a track survives without being found (3).
    pub max_coast: usize,
    /// Longest gap (s) between consecutive current scans of one sequence (1).
    pub max_gap: f64,
    /// Shortest gap (s) between consecutive current scans of one sequence (0.01: two
    /// sweeps of a 2D laser are at least 13 ms apart even at 75 Hz, so closer stamps
    /// are a log's artefact, over which no speed can be measured; such a scan starts a
    /// new sequence).
    pub min_step: f64,
    /// Steps with evidence of motion (a detection, or the track found moving) that a
    /// track needs for its objects to be reported, once it could be followed at
    /// least once (2: an object that no later scan shows moving is dropped from every
    /// pair; a track that ends with the sequence before it could be followed keeps
    /// its objects; 1 drops only the detections that the previous scan shows slower
    /// than [`TrackingParams::min_speed`]).
    pub min_evidence: usize,
    /// Weight of a step's measured motion in the track's velocity (the beta of an
    /// alpha-beta filter; 1 keeps the last measurement only) (0.5).
    pub smoothing: f64,
    /// Follow every confirmed track backward in time from its first detection, over
    /// the scans before the detector saw it, and report it where a step shows it
    /// moving (true; see the module docs).
    pub backward: bool,
    /// ICP between consecutive current scans, and of each requested pair for its
    /// ego-motion when the detection ran on the consecutive pair.
    pub ego: IcpParams,
}

impl Default for TrackingParams {
    fn default() -> Self {
        Self {
            min_speed: 0.5,
            gate: 0.3,
            inlier_distance: 0.1,
            min_inlier_fraction: 0.5,
            improvement: 0.5,
            min_returns: 3,
            max_coast: 3,
            max_gap: 1.0,
            min_step: 0.01,
            min_evidence: 2,
            smoothing: 0.5,
            backward: true,
            ego: IcpParams::default(),
        }
    }
}

impl ParamGuard for TrackingParams {
    type Checked = Tracker;
    type Error = Error;

    fn check_ref(&self) -> Result<()> {
        if !(self.min_speed >= 0.0 && self.min_speed.is_finite()) {
            return Err(InvalidParameter::new(
                "min_speed",
                self.min_speed,
                "a finite speed in m/s >= 0",
            )
            .into());
        }
        InvalidParameter::positive("gate", self.gate, "a distance in metres > 0")?;
        InvalidParameter::positive(
            "inlier_distance",
            self.inlier_distance,
            "a distance in metres > 0",
        )?;
        InvalidParameter::fraction("min_inlier_fraction", self.min_inlier_fraction)?;
        if !(self.improvement > 0.0 && self.improvement <= 1.0) {
            return Err(InvalidParameter::new(
                "improvement",
                self.improvement,
                "a factor in (0, 1]",
            )
            .into());
        }
        if self.min_returns < 2 {
            return Err(InvalidParameter::new(
                "min_returns",
                self.min_returns,
                "at least 2 (a rigid fit needs two points)",
            )
            .into());
        }
        InvalidParameter::positive("max_gap", self.max_gap, "a time in seconds > 0")?;
        if !(self.min_step >= 0.0 && self.min_step < self.max_gap) {
            return Err(InvalidParameter::new(
                "min_step",
                self.min_step,
                "a time in seconds >= 0 and below max_gap",
            )
            .into());
        }
        if self.min_evidence == 0 {
            return Err(InvalidParameter::new("min_evidence", 0, "at least 1").into());
        }
        if !(self.smoothing > 0.0 && self.smoothing <= 1.0) {
            return Err(
                InvalidParameter::new("smoothing", self.smoothing, "a weight in (0, 1]").into(),
            );
        }
        self.ego.check_ref()
    }

    fn check(self) -> Result<Tracker> {
        self.check_ref()?;
        Ok(Tracker { params: self })
    }
}

/// Multi-scan tracking with checked parameters (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tracker {
    params: TrackingParams,
}

/// What tracking changed in the detector's output, summed over the pairs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TrackingCounts {
    /// Sequences (runs of consecutive current scans).
    pub sequences: usize,
    /// Tracks started (one per detected object that no track continues).
    pub tracks: usize,
    /// Objects reported from a track where the detector reported none.
    pub tracked_objects: usize,
    /// Detected objects dropped: their track was followed but showed motion in fewer
    /// than [`TrackingParams::min_evidence`] steps.
    pub dropped: usize,
    /// Objects reported by following a confirmed track backward in time, in scans
    /// before its first detection ([`TrackingParams::backward`]).
    pub backward_objects: usize,
}

/// A moving object reported in one pair, with its track.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TrackedObject {
    /// Its label in the pair's clustering.
    pub label: u32,
    /// The track it belongs to (numbered from 0 in the order tracks start; the same
    /// number in two pairs is the same object); `None` for a detection that could not
    /// start a track (fewer than [`TrackingParams::min_returns`] returns, a pair whose
    /// scans are closer than [`TrackingParams::min_step`] in time, or no motion to
    /// measure a velocity from), reported as the detector made it.
    pub track: Option<usize>,
    /// Whether the detector reported it in this pair (else the track did).
    pub detected: bool,
    /// The number of its returns in the current scan.
    pub returns: usize,
    /// The beams of its returns in the current scan (indices from 0).
    pub beams: Vec<usize>,
    /// The centre of its returns in the current sensor frame (m).
    pub centre: [f64; 2],
    /// Its velocity in the current sensor frame (m/s), over the ground: the track's
    /// (smoothed) motion over its last step; `None` without a track.
    pub velocity: Option<[f64; 2]>,
}

/// The tracker's output: one clustering per requested pair (input order) and its
/// counts.
#[derive(Clone, Debug, PartialEq)]
pub struct Tracked {
    /// One clustering per pair, in the order the pairs were given.
    pub clusterings: Vec<MotionClustering>,
    /// The moving objects of each pair, with their tracks (same order).
    pub objects: Vec<Vec<TrackedObject>>,
    /// The sequence of each pair (numbered from 0 in time order; see the module docs).
    pub sequences: Vec<usize>,
    /// The pose of each pair's current sensor frame in the frame of the first current
    /// scan of its sequence (maps its points there; the scan-to-scan ICP motions
    /// composed).
    pub poses: Vec<Pose2>,
    /// What tracking changed.
    pub counts: TrackingCounts,
}

impl Tracked {
    /// The clusterings as a [`MotionClusterer`] named `name` that answers each of
    /// `pairs` (the pairs they were tracked on, same order) by its name, for the
    /// evaluations that run a method pair by pair.
    ///
    /// # Errors
    /// [`Error::BadPair`] when the counts differ or two pairs share a name.
    pub fn into_clusterer(self, pairs: &[ScanPair], name: String) -> Result<TrackedClusterer> {
        if pairs.len() != self.clusterings.len() {
            return Err(Error::BadPair {
                pair: pairs.first().map_or_else(String::new, |p| p.name.clone()),
                problem: format!(
                    "{} clusterings for {} pairs",
                    self.clusterings.len(),
                    pairs.len()
                ),
            });
        }
        let mut by_name = HashMap::with_capacity(pairs.len());
        for (p, c) in pairs.iter().zip(self.clusterings) {
            if by_name.insert(p.name.clone(), c).is_some() {
                return Err(Error::BadPair {
                    pair: p.name.clone(),
                    problem: "two pairs have this name; tracking answers pairs by name".into(),
                });
            }
        }
        Ok(TrackedClusterer { name, by_name })
    }
}

/// Clusterings made by [`Tracker::track`], answered pair by pair by name
/// ([`Tracked::into_clusterer`]).
#[derive(Clone, Debug)]
pub struct TrackedClusterer {
    name: String,
    by_name: HashMap<String, MotionClustering>,
}

impl MotionClusterer for TrackedClusterer {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn cluster(&self, pair: &ScanPair) -> Result<MotionClustering> {
        self.by_name
            .get(&pair.name)
            .cloned()
            .ok_or_else(|| Error::BadPair {
                pair: pair.name.clone(),
                problem: "not among the pairs that were tracked".into(),
            })
    }
}

/// One object followed over the current scans.
#[derive(Clone, Debug)]
struct Track {
    /// Index into the evidence of every track of the run.
    id: usize,
    /// Its returns in the frame of the last current scan.
    points: Vec<Point2<f64>>,
    /// Its motion over `step` seconds, in that frame (maps its returns at the earlier
    /// time onto where they are at the later).
    velocity: Pose2,
    /// Seconds `velocity` spans.
    step: f64,
    /// Scans since it was last found.
    coast: usize,
    /// The centre of its returns where it was last found or detected, in the frame
    /// of the last current scan (carried along by the ego-motion alone).
    seen: Point2<f64>,
    /// Where it started (centre of its returns, in the frame of the first scan of the
    /// sequence) and when (s).
    origin: Point2<f64>,
    born: f64,
}

/// What the run learned about a track, kept after it ends.
#[derive(Clone, Copy, Debug, Default)]
struct Evidence {
    /// Steps with evidence of motion.
    steps: usize,
    /// Times it was looked for in a later scan.
    followed: usize,
}

/// A track found in one scan.
struct Found {
    /// Position in the list of live tracks.
    track: usize,
    /// Beams of the current scan it takes.
    beams: Vec<usize>,
    /// Whether this step shows it moving.
    moving: bool,
}

/// A requested pair's clustering, and the label and track id of each of its moving
/// objects.
type Reported = (MotionClustering, Vec<TrackedObject>);

/// One requested pair's place in the run.
struct Step {
    /// The requested pair (index into the input).
    pair: usize,
    /// The previous current scan's pair and the seconds since it, when the sequence
    /// goes on.
    previous: Option<(usize, f64)>,
}

impl Tracker {
    /// The parameters.
    pub fn params(&self) -> &TrackingParams {
        &self.params
    }

    /// Tracks the moving objects that `detector` finds on consecutive current scans of
    /// `pairs` and answers every pair from the tracks (see the module docs).
    ///
    /// # Errors
    /// The detector's errors, and ICP's, naming the pair.
    pub fn track(&self, pairs: &[ScanPair], detector: &dyn MotionClusterer) -> Result<Tracked> {
        let p = &self.params;
        let mut names = std::collections::HashSet::with_capacity(pairs.len());
        if let Some(twice) = pairs.iter().find(|q| !names.insert(q.name.as_str())) {
            return Err(Error::BadPair {
                pair: twice.name.clone(),
                problem: "two pairs have this name: a sequence holds each pair once".into(),
            });
        }
        let order = time_order(pairs);
        let steps: Vec<Step> = order
            .iter()
            .enumerate()
            .map(|(n, &i)| Step {
                pair: i,
                previous: n.checked_sub(1).map(|m| order[m]).and_then(|j| {
                    let dt = pairs[i].current.timestamp - pairs[j].current.timestamp;
                    let later = pairs[i].reference.timestamp > pairs[j].reference.timestamp;
                    (later && dt > 0.0 && dt >= p.min_step && dt <= p.max_gap).then_some((j, dt))
                }),
            })
            .collect();
        // Detection on every requested pair, in parallel.
        let detections: Vec<MotionClustering> = steps
            .par_iter()
            .map(|s| detector.cluster(&pairs[s.pair]))
            .collect::<Result<_>>()?;
        for (detection, s) in detections.iter().zip(&steps) {
            let beams = pairs[s.pair].current.len();
            if detection.labels.len() != beams {
                return Err(Error::BadPair {
                    pair: pairs[s.pair].name.clone(),
                    problem: format!(
                        "the detector gave {} labels for the {beams} beams of the current scan",
                        detection.labels.len()
                    ),
                });
            }
        }
        let mut out: Vec<Option<Reported>> = vec![None; pairs.len()];
        let mut tracks: Vec<Track> = Vec::new();
        let mut evidence: Vec<Evidence> = Vec::new();
        let mut counts = TrackingCounts::default();
        let mut sequences = vec![0; pairs.len()];
        let mut poses = vec![Pose2::identity(); pairs.len()];
        let mut pose = Pose2::identity();
        // For the backward pass: each step's consecutive pair, and every track as it
        // was born (with the step it was born at).
        let mut consecutives: Vec<Option<Pose2>> = Vec::with_capacity(steps.len());
        let mut births: Vec<(usize, Track)> = Vec::new();
        for (n, (s, detection)) in steps.iter().zip(detections).enumerate() {
            let pair = &pairs[s.pair];
            // The pair of the previous current scan and this one, with the motion
            // between them by ICP without the returns of the objects reported moving
            // in the previous scan and detected in this one (a car beside the robot
            // would pull it along).
            let consecutive = s.previous.map(|(j, _)| {
                let moving_before = out[j].as_ref().map(|(c, _)| c.labels.as_slice());
                consecutive_pair(&pairs[j], pair, moving_before, &detection.labels, &p.ego)
            });
            let found = match (s.previous, &consecutive) {
                (Some((_, dt)), Some(c)) => {
                    let ego = c.odometry.unwrap_or_default();
                    pose = pose.compose(&ego);
                    for t in &tracks {
                        evidence[t.id].followed += 1;
                    }
                    self.follow(&mut tracks, c, ego, dt, pose)
                }
                _ => {
                    counts.sequences += 1;
                    pose = Pose2::identity();
                    tracks.clear();
                    Vec::new()
                }
            };
            sequences[s.pair] = counts.sequences - 1;
            let first_new = evidence.len();
            poses[s.pair] = pose;
            out[s.pair] = Some(self.report(
                pair,
                consecutive.as_ref(),
                pose,
                detection,
                &mut tracks,
                &mut evidence,
                found,
                &mut counts,
            ));
            births.extend(
                tracks
                    .iter()
                    .filter(|t| t.id >= first_new)
                    .map(|t| (n, t.clone())),
            );
            consecutives.push(consecutive.and_then(|c| c.odometry));
        }
        let confirmed =
            |e: &Evidence| e.steps >= p.min_evidence || (e.followed == 0 && e.steps > 0);
        // Objects of tracks that were followed but showed too little motion.
        let (mut clusterings, mut objects): (Vec<MotionClustering>, Vec<Vec<TrackedObject>>) = out
            .into_iter()
            .map(|o| {
                let (mut clustering, mut objects) = o.expect("every pair");
                objects.retain(|object| {
                    // Unconfirmed: followed without showing motion often enough, or
                    // never moving at the speed that counts (even if it could not
                    // be followed).
                    let confirmed = object.track.is_none_or(|t| confirmed(&evidence[t]));
                    if !confirmed {
                        for l in clustering.labels.iter_mut() {
                            if *l == Some(object.label) {
                                *l = Some(0);
                            }
                        }
                        clustering.motions.retain(|m| m.label != object.label);
                        counts.dropped += 1;
                    }
                    confirmed
                });
                (clustering, objects)
            })
            .unzip();
        if p.backward {
            births.retain(|(_, t)| confirmed(&evidence[t.id]));
            self.backward(
                pairs,
                &steps,
                &consecutives,
                births,
                &poses,
                &mut clusterings,
                &mut objects,
                &mut counts,
            );
        }
        Ok(Tracked {
            clusterings,
            objects,
            sequences,
            poses,
            counts,
        })
    }

    /// The backward pass (see the module docs): every confirmed track is followed
    /// from the scan it was born in (`births`: step and track as born) back through
    /// the earlier scans of its sequence, and a step that shows it moving reports it
    /// in that pair on the returns no reported object holds.
    #[allow(clippy::too_many_arguments)]
    fn backward(
        &self,
        pairs: &[ScanPair],
        steps: &[Step],
        consecutives: &[Option<Pose2>],
        births: Vec<(usize, Track)>,
        poses: &[Pose2],
        clusterings: &mut [MotionClustering],
        objects: &mut [Vec<TrackedObject>],
        counts: &mut TrackingCounts,
    ) {
        let mut tracks: Vec<Track> = Vec::new();
        // The beams each backward track was found on in the later scan (none at its
        // birth, where the forward pass reported it).
        let mut seen: HashMap<usize, Vec<usize>> = HashMap::new();
        let mut births = births.into_iter().rev().peekable();
        for n in (0..steps.len()).rev() {
            let i = steps[n].pair;
            // From the later scan of the sequence into this one.
            let later = consecutives
                .get(n + 1)
                .copied()
                .flatten()
                .zip(steps.get(n + 1).and_then(|s| s.previous));
            match later {
                Some((motion, (_, dt))) if !tracks.is_empty() => {
                    // The consecutive pair taken in reverse: the later scan as
                    // reference, this one as current, the inverse motion.
                    let ego = motion.inverse();
                    let later_pair = steps[n + 1].pair;
                    let later_scan = &pairs[later_pair];
                    let reversed = ScanPair {
                        name: format!("{} (before {})", pairs[i].name, later_scan.name),
                        reference: later_scan.current.clone(),
                        current: pairs[i].current.clone(),
                        odometry: Some(ego),
                        truth: None,
                    };
                    let found = self.follow(&mut tracks, &reversed, ego, dt, poses[i]);
                    // A step that shows the track moving shows it moving over the
                    // later scan's step: the object is reported in the later pair, on
                    // the returns the previous step found it on.
                    for f in &found {
                        let beams = seen.insert(tracks[f.track].id, f.beams.clone());
                        if let Some(beams) = beams.filter(|b| f.moving && !b.is_empty()) {
                            // Its velocity forward in time, in the later scan's frame.
                            let forward = Track {
                                velocity: ego
                                    .compose(&tracks[f.track].velocity)
                                    .compose(&ego.inverse())
                                    .inverse(),
                                ..tracks[f.track].clone()
                            };
                            if self.report_backward(
                                &pairs[later_pair],
                                &beams,
                                &forward,
                                &mut clusterings[later_pair],
                                &mut objects[later_pair],
                            ) {
                                counts.backward_objects += 1;
                            }
                        }
                    }
                    // Back only while every step shows it moving: before that it
                    // stood, or was something else.
                    let mut moving = vec![false; tracks.len()];
                    for f in &found {
                        moving[f.track] = f.moving;
                    }
                    let mut t = 0;
                    tracks.retain(|_| {
                        t += 1;
                        moving[t - 1]
                    });
                }
                Some(_) => {}
                None => tracks.clear(),
            }
            // Tracks born here start backward, their velocity reversed.
            while let Some((_, born)) = births.next_if(|(m, _)| *m == n) {
                seen.insert(born.id, Vec::new());
                tracks.push(Track {
                    velocity: born.velocity.inverse(),
                    coast: 0,
                    ..born
                });
            }
        }
    }

    /// Reports the object of `track` (velocity forward in time) in `pair` on `beams`
    /// of its current scan; true when it adds an object. Not when a reported object
    /// holds any of them (no second object on the same returns; a reported object with
    /// at least half of its returns among them is the track's object, seen from its
    /// side as the forward pass continues a track, and takes the track's other
    /// returns that are background), with fewer than [`TrackingParams::min_returns`]
    /// free returns, or in a pair without time between its scans.
    fn report_backward(
        &self,
        pair: &ScanPair,
        beams: &[usize],
        track: &Track,
        clustering: &mut MotionClustering,
        objects: &mut Vec<TrackedObject>,
    ) -> bool {
        let mut held: HashMap<u32, usize> = HashMap::new();
        for &b in beams {
            if let Some(l) = clustering.labels[b].filter(|&l| l > 0) {
                *held.entry(l).or_insert(0) += 1;
            }
        }
        if let Some(l) = held
            .iter()
            .filter(|&(&l, &n)| {
                2 * n >= clustering.labels.iter().filter(|&&x| x == Some(l)).count()
            })
            .map(|(&l, _)| l)
            .min()
        {
            // The object is there already: it takes the track's other returns.
            for &b in beams {
                if clustering.labels[b] == Some(0) {
                    clustering.labels[b] = Some(l);
                }
            }
            if let Some(object) = objects.iter_mut().find(|o| o.label == l) {
                let grown = untracked_object(pair, &clustering.labels, l);
                object.beams = grown.beams;
                object.returns = grown.returns;
                object.centre = grown.centre;
            }
            return false;
        }
        if !held.is_empty() {
            return false;
        }
        let free: Vec<usize> = beams
            .iter()
            .copied()
            .filter(|&b| matches!(clustering.labels[b], None | Some(0)))
            .collect();
        let gap = pair.current.timestamp - pair.reference.timestamp;
        if free.len() < self.params.min_returns || gap <= 0.0 {
            return false;
        }
        let label = clustering
            .labels
            .iter()
            .flatten()
            .copied()
            .max()
            .unwrap_or(0)
            + 1;
        for &b in &free {
            clustering.labels[b] = Some(label);
        }
        let ego_pair = clustering.ego_motion.or(pair.odometry).unwrap_or_default();
        let motion = self.pair_motion(pair, &clustering.labels, label, track, ego_pair);
        clustering.motions.push(ClusterMotion {
            label,
            motion,
            kind: "tracked".into(),
        });
        objects.push(tracked_object(
            pair,
            &clustering.labels,
            label,
            track,
            false,
        ));
        true
    }

    /// Steps 2 and 3 of the module docs on the consecutive pair `step` (previous
    /// current scan as reference; `ego` the motion of its current scan in the frame of
    /// its reference, `dt` seconds later). Moves every track into the current frame,
    /// ends the lost ones and returns the found ones.
    fn follow(
        &self,
        tracks: &mut Vec<Track>,
        step: &ScanPair,
        ego: Pose2,
        dt: f64,
        pose: Pose2,
    ) -> Vec<Found> {
        let p = &self.params;
        let (points, beams) = step.current.points();
        let (Ok(now), Ok(earlier)) = (
            Icp::new(&step.current, p.ego),
            Icp::new(&step.reference, p.ego),
        ) else {
            tracks.clear();
            return Vec::new();
        };
        let back = ego.inverse();
        let tau = p.inlier_distance;
        // Truncated cost of points against the returns of one of the two scans.
        let cost = |icp: &Icp, moved: &[Point2<f64>]| -> f64 {
            moved
                .iter()
                .map(|q| {
                    icp.nearest_reference(q, tau)
                        .map_or(tau * tau, |(_, d2)| d2)
                })
                .sum()
        };
        let mut taken = vec![false; points.len()];
        let mut found = Vec::new();
        let mut keep = vec![true; tracks.len()];
        for (t, track) in tracks.iter_mut().enumerate() {
            track.seen = back.transform_point(&track.seen);
            // The velocity over `dt` in this frame, and the returns where it puts them.
            let velocity = scale(
                &back.compose(&track.velocity).compose(&ego),
                dt / track.step,
            );
            let before: Vec<Point2<f64>> = track
                .points
                .iter()
                .map(|q| back.transform_point(q))
                .collect();
            let predicted: Vec<Point2<f64>> =
                before.iter().map(|q| velocity.transform_point(q)).collect();
            let candidates: Vec<usize> = (0..points.len())
                .filter(|&k| {
                    !taken[k]
                        && predicted
                            .iter()
                            .any(|q| (q - points[k]).norm_squared() <= p.gate * p.gate)
                })
                .collect();
            let shift = refine(&predicted, &points, &candidates, p.gate, tau);
            let shifted: Vec<Point2<f64>> = predicted.iter().map(|q| q + shift).collect();
            let inliers: Vec<usize> = candidates
                .iter()
                .copied()
                .filter(|&k| shifted.iter().any(|q| (q - points[k]).norm() <= tau))
                .collect();
            let supported = shifted
                .iter()
                .filter(|q| inliers.iter().any(|&k| (*q - points[k]).norm() <= tau))
                .count();
            track.step = dt;
            if inliers.len() < p.min_returns
                || (supported as f64) < p.min_inlier_fraction * predicted.len() as f64
            {
                track.coast += 1;
                if track.coast > p.max_coast {
                    keep[t] = false;
                } else {
                    // Carried along unseen, as predicted.
                    track.points = predicted;
                    track.velocity = velocity;
                }
                continue;
            }
            // The measured motion (the prediction shifted), blended into the velocity;
            // the speed at the object's centre.
            let b = p.smoothing;
            let smoothed = Pose2::new(
                velocity.x() + b * shift.x,
                velocity.y() + b * shift.y,
                velocity.theta(),
            );
            let centre = centroid(&before);
            let speed = (smoothed.transform_point(&centre) - centre).norm() / dt;
            let measured = cost(&now, &shifted);
            let still_there = cost(&now, &before);
            let arrived: Vec<Point2<f64>> = inliers
                .iter()
                .map(|&k| ego.transform_point(&points[k]))
                .collect();
            let already_there =
                cost(&earlier, &arrived) * shifted.len() as f64 / arrived.len() as f64;
            // Over the whole track, not just this step: an unstable surface (mixed
            // returns at a corner) jitters back and forth and goes nowhere.
            let net = (pose.transform_point(&centroid(
                &inliers.iter().map(|&k| points[k]).collect::<Vec<_>>(),
            )) - track.origin)
                .norm()
                / (step.current.timestamp - track.born).abs().max(dt);
            let moving = speed >= p.min_speed
                && net >= p.min_speed
                && measured < p.improvement * still_there
                && measured < p.improvement * already_there;

            for &k in &inliers {
                taken[k] = true;
            }
            track.points = inliers.iter().map(|&k| points[k]).collect();
            track.seen = centroid(&track.points);
            track.velocity = smoothed;
            track.coast = 0;
            found.push(Found {
                track: t,
                beams: inliers.iter().map(|&k| beams[k]).collect(),
                moving,
            });
        }
        // Drop the lost tracks, renumbering the found ones.
        let mut new_index = vec![usize::MAX; tracks.len()];
        let mut n = 0;
        for (t, &k) in keep.iter().enumerate() {
            if k {
                new_index[t] = n;
                n += 1;
            }
        }
        let mut t = 0;
        tracks.retain(|_| {
            t += 1;
            keep[t - 1]
        });
        for f in &mut found {
            f.track = new_index[f.track];
        }
        found
    }

    /// Steps 4 and 5 of the module docs: the requested pair's clustering, and the
    /// object label and track id of each moving object in it. `consecutive` is the
    /// pair of the previous current scan and this one, when the sequence goes on.
    #[allow(clippy::too_many_arguments)]
    fn report(
        &self,
        pair: &ScanPair,
        consecutive: Option<&ScanPair>,
        pose: Pose2,
        mut detection: MotionClustering,
        tracks: &mut Vec<Track>,
        evidence: &mut Vec<Evidence>,
        found: Vec<Found>,
        counts: &mut TrackingCounts,
    ) -> Reported {
        let p = &self.params;
        let mut track_of_beam = vec![usize::MAX; pair.current.len()];
        for f in &found {
            for &b in &f.beams {
                track_of_beam[b] = f.track;
            }
        }
        let gap = pair.current.timestamp - pair.reference.timestamp;
        let ego_pair = detection.ego_motion.or(pair.odometry).unwrap_or_default();
        let mut labels_seen: Vec<u32> = detection
            .labels
            .iter()
            .flatten()
            .copied()
            .filter(|&l| l > 0)
            .collect();
        labels_seen.sort_unstable();
        labels_seen.dedup();
        // Detected objects: continue the track they share most returns with (at least
        // half of theirs), or start one.
        let mut objects: Vec<TrackedObject> = Vec::new();
        let mut detected = vec![false; tracks.len()];
        for &label in &labels_seen {
            let members: Vec<usize> = (0..detection.labels.len())
                .filter(|&b| detection.labels[b] == Some(label))
                .collect();
            let mut votes: HashMap<usize, usize> = HashMap::new();
            for &b in &members {
                if track_of_beam[b] != usize::MAX {
                    *votes.entry(track_of_beam[b]).or_insert(0) += 1;
                }
            }
            let points: Vec<Point2<f64>> = members
                .iter()
                .map(|&b| pair.current.beam_point(b))
                .collect();
            let centre = centroid(&points);
            let mut continued = votes
                .into_iter()
                .max_by_key(|&(t, c)| (c, std::cmp::Reverse(t)))
                .filter(|&(_, c)| 2 * c >= members.len())
                .map(|(t, _)| t)
                .or_else(|| {
                    // A track lost in this scan (carried along as predicted) whose
                    // predicted centre lies within the gate of the object's: the
                    // detector found it again where the point-wise search did not (a
                    // walker's legs move unlike one rigid body).
                    (0..tracks.len())
                        .filter(|&t| !detected[t] && tracks[t].coast > 0)
                        .map(|t| (t, (centroid(&tracks[t].points) - centre).norm()))
                        .filter(|&(_, d)| d <= p.gate)
                        .min_by(|a, b| a.1.total_cmp(&b.1))
                        .map(|(t, _)| t)
                });
            // A detection that continues no track: its motion over the pair, forward in
            // time, in the current frame (none from a detector without motions, such as
            // CBD); better, over the last step, measured against the previous scan. A
            // pair closer in time than a laser's sweep (a log's artefact) gives no
            // velocity to start a track with.
            let startable =
                members.len() >= p.min_returns && gap >= p.min_step.max(f64::MIN_POSITIVE);
            let over_pair = detection
                .motions
                .iter()
                .find(|m| m.label == label)
                .map(|m| m.motion.inverse().compose(&ego_pair));
            let measured = if continued.is_none() && startable {
                consecutive.and_then(|c| {
                    self.velocity_from_previous(c, &points, &over_pair.unwrap_or_default(), gap)
                })
            } else {
                None
            };
            // A detection that the previous scan shows slower than the speed that counts
            // as moving is no evidence of motion (a detector's displacement threshold
            // over a pair lets slow objects and jitter through).
            let slow = measured.is_some_and(|(v, step)| {
                (v.transform_point(&centre) - centre).norm() / step < p.min_speed
            });
            // The velocity of a detection that continues a track lost at its first step.
            let relinked = measured.filter(|_| !slow).and_then(|(velocity, step)| {
                let t = self
                    .newborn_continued(tracks, evidence, &detected, pair, centre, velocity, step)?;
                continued = Some(t);
                Some((velocity, step))
            });
            if let Some(t) = continued {
                // The detection's returns are the object as seen now: the track takes
                // them (a passing car shows other parts of itself scan after scan; the
                // returns the track found near its prediction alone would shrink).
                tracks[t].points = points;
                tracks[t].seen = centre;
                tracks[t].coast = 0;
                if let Some((velocity, step)) = relinked {
                    // Its birth velocity was off; the detection's own replaces it.
                    tracks[t].velocity = velocity;
                    tracks[t].step = step;
                }
                if !detected[t] {
                    detected[t] = true;
                    evidence[tracks[t].id].steps += 1;
                }
                // Its motion over the pair from the track (the velocity smoothed over
                // the scans it was followed in) rather than from this pair alone.
                let motion = self.pair_motion(pair, &detection.labels, label, &tracks[t], ego_pair);
                match detection.motions.iter_mut().find(|m| m.label == label) {
                    Some(m) => m.motion = motion,
                    None => detection.motions.push(ClusterMotion {
                        label,
                        motion,
                        kind: "moving".into(),
                    }),
                }
                objects.push(tracked_object(
                    pair,
                    &detection.labels,
                    label,
                    &tracks[t],
                    true,
                ));
                continue;
            }
            let velocity = measured.or(over_pair.map(|v| (v, gap)));
            let Some((velocity, step)) = velocity.filter(|_| startable) else {
                objects.push(untracked_object(pair, &detection.labels, label));
                continue;
            };
            let id = evidence.len();
            // Without a previous scan the detection stands as the detector made it.
            evidence.push(Evidence {
                steps: usize::from(!slow),
                followed: 0,
            });
            tracks.push(Track {
                id,
                origin: pose.transform_point(&centre),
                born: pair.current.timestamp,
                points,
                velocity,
                step,
                coast: 0,
                seen: centre,
            });
            detected.push(true);
            objects.push(tracked_object(
                pair,
                &detection.labels,
                label,
                tracks.last().expect("just pushed"),
                true,
            ));
            counts.tracks += 1;
        }
        // Tracks found moving where the detector reported nothing: one more object
        // each, on the returns no detected object holds, with the motion over the
        // pair that its velocity gives, shifted onto the reference scan.
        let mut next = labels_seen.last().copied().unwrap_or(0) + 1;
        for f in &found {
            if detected[f.track] || !f.moving || gap <= 0.0 {
                continue;
            }
            let free: Vec<usize> = f
                .beams
                .iter()
                .copied()
                .filter(|&b| matches!(detection.labels[b], None | Some(0)))
                .collect();
            if free.len() < p.min_returns {
                continue;
            }
            let track = &tracks[f.track];
            evidence[track.id].steps += 1;
            for &b in &free {
                detection.labels[b] = Some(next);
            }
            let motion = self.pair_motion(pair, &detection.labels, next, track, ego_pair);
            detection.motions.push(ClusterMotion {
                label: next,
                motion,
                kind: "tracked".into(),
            });
            objects.push(tracked_object(pair, &detection.labels, next, track, false));
            next += 1;
            counts.tracked_objects += 1;
        }
        (detection, objects)
    }

    /// The track that a detection centred at `centre` (current frame) continues when
    /// it continues none by its returns or its predicted centre: one never found since
    /// its birth (its velocity rests on one measurement, or only on the detector's
    /// motion over a pair, and may be far off), lost now, born no later than the scan
    /// this pair starts at (the two detections are independent evidence; with `k > 1`
    /// the pairs of consecutive scans share `k − 1` scan intervals, and clutter the
    /// detector calls moving in one it tends to call moving in the next), whose birth
    /// place the detection's own `velocity` (over `step` seconds) moves it back to
    /// within the gate of; the nearest.
    #[allow(clippy::too_many_arguments)]
    fn newborn_continued(
        &self,
        tracks: &[Track],
        evidence: &[Evidence],
        detected: &[bool],
        pair: &ScanPair,
        centre: Point2<f64>,
        velocity: Pose2,
        step: f64,
    ) -> Option<usize> {
        (0..tracks.len())
            .filter(|&t| {
                let track = &tracks[t];
                !detected[t]
                    && track.coast > 0
                    && evidence[track.id].followed == track.coast
                    && pair.reference.timestamp >= track.born
            })
            .map(|t| {
                // Back over the time since the track's birth.
                let since = pair.current.timestamp - tracks[t].born;
                let back = scale(&velocity, since / step).inverse();
                (t, (back.transform_point(&centre) - tracks[t].seen).norm())
            })
            .filter(|&(_, d)| d <= self.params.gate)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(t, _)| t)
    }

    /// A new object's velocity measured against the previous current scan (the
    /// reference of `consecutive`, `E` its odometry): its returns `points` (current
    /// frame) moved back as if static and as `over_pair` (its motion over the
    /// requested pair, `gap` seconds) says, each refined by a translation-only fit onto
    /// the previous scan's returns; the better supported gives the motion over the
    /// step. `None` when neither finds the object there.
    fn velocity_from_previous(
        &self,
        consecutive: &ScanPair,
        points: &[Point2<f64>],
        over_pair: &Pose2,
        gap: f64,
    ) -> Option<(Pose2, f64)> {
        let p = &self.params;
        let dt = consecutive.current.timestamp - consecutive.reference.timestamp;
        let ego = consecutive.odometry.unwrap_or_default();
        let (previous, _) = consecutive.reference.points();
        let all: Vec<usize> = (0..previous.len()).collect();
        let tau = p.inlier_distance;
        let mut best: Option<(f64, Vector2<f64>)> = None;
        for forward in [Pose2::identity(), scale(over_pair, dt / gap)] {
            // Where the returns were one step earlier, in the previous frame.
            let back_in_time = forward.inverse();
            let earlier: Vec<Point2<f64>> = points
                .iter()
                .map(|q| ego.transform_point(&back_in_time.transform_point(q)))
                .collect();
            let candidates: Vec<usize> = all
                .iter()
                .copied()
                .filter(|&k| {
                    earlier
                        .iter()
                        .any(|q| (q - previous[k]).norm_squared() <= p.gate * p.gate)
                })
                .collect();
            let shift = refine(&earlier, &previous, &candidates, p.gate, tau);
            // Squared distance of each moved return to its nearest candidate.
            let d2: Vec<f64> = earlier
                .iter()
                .map(|q| {
                    candidates
                        .iter()
                        .map(|&k| (*q + shift - previous[k]).norm_squared())
                        .fold(f64::INFINITY, f64::min)
                })
                .collect();
            let supported = d2.iter().filter(|&&d| d <= tau * tau).count();
            let cost: f64 = d2.iter().map(|&d| d.min(tau * tau)).sum();
            if (supported as f64) >= p.min_inlier_fraction * points.len() as f64
                && best.is_none_or(|(c, _)| cost < c)
            {
                // The object's displacement over the step, in the current frame.
                let now: Vector2<f64> = centroid(points).coords;
                let was = ego
                    .inverse()
                    .transform_point(&(centroid(&earlier) + shift))
                    .coords;
                best = Some((cost, now - was));
            }
        }
        best.map(|(_, d)| (Pose2::new(d.x, d.y, 0.0), dt))
    }

    /// The motion over `pair` of the object labelled `label`: back in time over the
    /// pair with `track`'s velocity, into the reference frame by `ego_pair`, then
    /// shifted onto the reference scan's returns (a translation-only fit, as when the
    /// track is followed: the few returns of a walker do not fix a rotation).
    fn pair_motion(
        &self,
        pair: &ScanPair,
        labels: &[Option<u32>],
        label: u32,
        track: &Track,
        ego_pair: Pose2,
    ) -> Pose2 {
        let p = &self.params;
        let gap = pair.current.timestamp - pair.reference.timestamp;
        let start = ego_pair.compose(&scale(&track.velocity, gap / track.step).inverse());
        let moved: Vec<Point2<f64>> = (0..pair.current.len())
            .filter(|&b| pair.current.valid[b] && labels[b] == Some(label))
            .map(|b| start.transform_point(&pair.current.beam_point(b)))
            .collect();
        let (reference, _) = pair.reference.points();
        let candidates: Vec<usize> = (0..reference.len())
            .filter(|&k| {
                moved
                    .iter()
                    .any(|q| (q - reference[k]).norm_squared() <= p.gate * p.gate)
            })
            .collect();
        let shift = refine(&moved, &reference, &candidates, p.gate, p.inlier_distance);
        Pose2::new(shift.x, shift.y, 0.0).compose(&start)
    }
}

/// The report of the object labelled `label` in `pair`, followed by `track`.
fn tracked_object(
    pair: &ScanPair,
    labels: &[Option<u32>],
    label: u32,
    track: &Track,
    detected: bool,
) -> TrackedObject {
    let mut object = untracked_object(pair, labels, label);
    let centre = Point2::new(object.centre[0], object.centre[1]);
    let velocity = (track.velocity.transform_point(&centre) - centre) / track.step;
    object.track = Some(track.id);
    object.detected = detected;
    object.velocity = Some([velocity.x, velocity.y]);
    object
}

/// The report of a detected object labelled `label` in `pair` that starts no track.
fn untracked_object(pair: &ScanPair, labels: &[Option<u32>], label: u32) -> TrackedObject {
    let beams: Vec<usize> = (0..pair.current.len())
        .filter(|&b| pair.current.valid[b] && labels[b] == Some(label))
        .collect();
    let returns: Vec<Point2<f64>> = beams.iter().map(|&b| pair.current.beam_point(b)).collect();
    let centre = centroid(&returns);
    TrackedObject {
        label,
        track: None,
        detected: true,
        returns: returns.len(),
        beams,
        centre: [centre.x, centre.y],
        velocity: None,
    }
}

/// The indices of `pairs` in the order the tracker takes them: by the time stamp of
/// their current scan (a stable sort: equal stamps keep their order).
pub fn time_order(pairs: &[ScanPair]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..pairs.len()).collect();
    order.sort_by(|&a, &b| {
        pairs[a]
            .current
            .timestamp
            .total_cmp(&pairs[b].current.timestamp)
    });
    order
}

/// The pair of two consecutive current scans (`before`'s as reference), with the
/// motion of the later in the frame of the earlier as its odometry: ICP (`icp`) from
/// their odometry difference (the identity without odometry), without the returns
/// labelled moving in `moving_before` (the earlier scan) and `moving_now` (the later);
/// the prior when ICP does not converge.
fn consecutive_pair(
    before: &ScanPair,
    now: &ScanPair,
    moving_before: Option<&[Option<u32>]>,
    moving_now: &[Option<u32>],
    icp: &IcpParams,
) -> ScanPair {
    let prior = match (
        before.current.laser_odometry(),
        now.current.laser_odometry(),
    ) {
        (Some(a), Some(b)) => a.between(&b),
        _ => Pose2::identity(),
    };
    let reference = without_moving(&before.current, moving_before);
    let current = without_moving(&now.current, Some(moving_now));
    let motion = Icp::new(&reference, *icp)
        .and_then(|icp| icp.align(&current, prior))
        .ok()
        .filter(|r| r.converged)
        .map_or(prior, |r| r.motion);
    ScanPair {
        name: format!("{} (after {})", now.name, before.name),
        reference: before.current.clone(),
        current: now.current.clone(),
        odometry: Some(motion),
        truth: None,
    }
}

/// `scan` without the returns labelled moving (label above 0) in `labels` (one per
/// beam), when given.
fn without_moving(scan: &crate::Scan, labels: Option<&[Option<u32>]>) -> crate::Scan {
    let mut kept = scan.clone();
    if let Some(labels) = labels {
        for (valid, label) in kept.valid.iter_mut().zip(labels) {
            if label.is_some_and(|l| l > 0) {
                *valid = false;
            }
        }
    }
    kept
}

/// A rigid motion scaled by `factor` (translation and angle; exact for pure
/// translations, first order in the angle otherwise).
fn scale(motion: &Pose2, factor: f64) -> Pose2 {
    Pose2::new(
        motion.x() * factor,
        motion.y() * factor,
        motion.theta() * factor,
    )
}

fn centroid(points: &[Point2<f64>]) -> Point2<f64> {
    let sum = points.iter().fold(Vector2::zeros(), |a, p| a + p.coords);
    Point2::from(sum / points.len().max(1) as f64)
}

/// Translation-only ICP of `predicted` onto the returns `candidates` (indices into
/// `points`): the shift that brings the predicted returns onto them (a small object's
/// rotation over one scan is not observable from its few returns; the velocity keeps
/// the rotation it was born with). The correspondence distance shrinks from `gate` to
/// `inlier`.
fn refine(
    predicted: &[Point2<f64>],
    points: &[Point2<f64>],
    candidates: &[usize],
    gate: f64,
    inlier: f64,
) -> Vector2<f64> {
    let mut shift = Vector2::zeros();
    let mut distance = gate;
    for _ in 0..30 {
        let mut sum = Vector2::zeros();
        let mut pairs = 0;
        for q in predicted {
            let q = q + shift;
            let nearest = candidates
                .iter()
                .map(|&k| points[k] - q)
                .min_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()));
            if let Some(d) = nearest.filter(|d| d.norm() <= distance) {
                sum += d;
                pairs += 1;
            }
        }
        if pairs == 0 {
            break;
        }
        let delta = sum / pairs as f64;
        shift += delta;
        if delta.norm() < 1e-4 && distance <= inlier {
            break;
        }
        distance = (distance * 0.7).max(inlier);
    }
    shift
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scan;

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
        let detector = Scripted(HashMap::from([(
            second.name.clone(),
            (box_beams(second), Pose2::new(0.06, -0.08, 0.0)),
        )]));
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
            let motion = c.motions.iter().find(|m| m.label == object).unwrap().motion;
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
        let detector = Scripted(HashMap::from([(
            sixth.name.clone(),
            (box_beams(sixth), Pose2::new(0.06, -0.08, 0.0)),
        )]));
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
            let motion = c.motions.iter().find(|m| m.label == object).unwrap().motion;
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
        let detector = Scripted(HashMap::from([(
            seventh.name.clone(),
            (box_beams(seventh), Pose2::new(0.06, -0.08, 0.0)),
        )]));
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
        let detector = Scripted(HashMap::from([
            (
                pairs[0].name.clone(),
                (box_beams(&pairs[0]), Pose2::new(0.6, -0.8, 0.0)),
            ),
            (
                pairs[1].name.clone(),
                (box_beams(&pairs[1]), Pose2::new(0.06, -0.08, 0.0)),
            ),
        ]));
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
        let detector = Scripted(HashMap::from([
            // Birth without a previous scan, the detector's motion ten times too large.
            (pairs[0].name.clone(), (box_beams(&pairs[0]), over(1.0))),
            // Found again after the gap with its true motion over the pair.
            (pairs[2].name.clone(), (box_beams(&pairs[2]), over(0.3))),
        ]));
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
        let detector = Scripted(HashMap::from([
            (
                third.name.clone(),
                (box_beams(third)[..2].to_vec(), Pose2::new(0.06, -0.08, 0.0)),
            ),
            (
                sixth.name.clone(),
                (box_beams(sixth), Pose2::new(0.06, -0.08, 0.0)),
            ),
        ]));
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
        let detector = Scripted(HashMap::from([(
            third.name.clone(),
            (two.clone(), Pose2::new(0.06, -0.08, 0.0)),
        )]));
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
        let detector = Scripted(HashMap::from([(
            third.name.clone(),
            (box_beams(third), Pose2::new(0.0, -0.1, 0.0)),
        )]));
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
        let detector = Scripted(
            pairs
                .iter()
                .map(|p| {
                    let gap = p.current.timestamp - p.reference.timestamp;
                    (
                        p.name.clone(),
                        (box_beams(p), Pose2::new(0.6 * gap, -0.8 * gap, 0.0)),
                    )
                })
                .collect(),
        );
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
}
