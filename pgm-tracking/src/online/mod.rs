//! The online tracker: push one scan, get that scan's objects, with no look-ahead.
//!
//! **One step** (scan `n`, `Δt` seconds after scan `n − 1`):
//! 1. Every track's constant-velocity filter ([`ConstantVelocity`]) is moved on by
//!    `Δt`.
//! 2. The ego-motion from scan `n − 1` ([`EgoMotion`]): predicted from the previous
//!    steps or taken from the wheel odometry, registered without the returns of the
//!    confirmed moving tracks (where their filters put them now, and where they were
//!    found in scan `n − 1`), within the platform's limits.
//! 3. The detector (any pair-wise [`MotionClusterer`]) runs on the pair of scan
//!    `n − k` (by default the latest scan [`OnlineParams::reference_gap`] seconds
//!    before scan `n`) and scan `n`, with that sequence's ego-motion as the pair's odometry
//!    prior: every pair-wise method sees the same motion model. Its moving objects
//!    with at least [`OnlineParams::min_returns`] returns whose returns come within
//!    [`OnlineParams::merge_distance`] of each other are one object (a walker's two
//!    legs).
//! 4. Detections are assigned to tracks by a minimum-sum assignment (Hungarian,
//!    `pathfinding`) on the distance of their centres to the tracks' predicted
//!    centres, gated by [`OnlineParams::gate`] plus half the track's extent; a
//!    detection left over starts a tentative track at rest (its velocity comes from
//!    its own later measurements only).
//! 5. A track no detection continues looks for its object itself: the segments of
//!    scan `n` (split where consecutive returns lie more than
//!    [`OnlineParams::segment_gap`] apart) no larger than
//!    [`OnlineParams::max_extent`] that come within the gate of its predicted centre,
//!    nearest first, with those within the merge distance of it. This is how a person
//!    who stops stays tracked (state [`TrackState::Stopped`]) while seen.
//! 6. Each measured track takes its centre ([`shape::centre`]: the box along its
//!    heading completed to the largest extent it has shown, behind the visible
//!    returns) into its filter. Its score is the logistic of a log-likelihood ratio
//!    that grows with each detection and shrinks with each scan it is not found in
//!    (the sequential track score of S. S. Blackman, "Multiple-Target Tracking with
//!    Radar Applications", 1986, chapter 4, with hand-set increments).
//! 7. A tentative track is confirmed after [`OnlineParams::confirm`] steps with
//!    evidence of motion (a detection, or found where its net displacement since
//!    birth, over the time since, is at least [`OnlineParams::min_speed`] and the
//!    displacement at least twice the noise of the difference of two measured
//!    centres: clutter found in place does not move on, and a centre's jitter over
//!    one step is no speed), the confirming step itself one of found displaced (a
//!    detector that reports the same static clutter again and again does not make
//!    it a mover), within [`OnlineParams::confirm_time`] seconds of its birth, else
//!    ends; a track not found for more than [`OnlineParams::max_coast`] scans ends
//!    (a tentative one after two).
//!
//! A scan less than [`OnlineParams::min_step`] or more than [`OnlineParams::max_gap`]
//! seconds after the previous (or before it) starts a new sequence: its tracks end
//! and its pose is the identity.
//!
//! [`smooth`] is the offline mode on the same steps: after a finished log, a confirmed
//! track is reported from its birth (its tentative scans included) and a track never
//! confirmed is dropped from every scan.

mod ego;
mod filter;
pub mod shape;

pub use ego::{EgoMotion, EgoParams, EgoSource, EgoStep};
pub use filter::ConstantVelocity;

use nalgebra::{Point2, Vector2};
use pathfinding::matrix::Matrix;
use pgm_core::{InvalidParameter, ParamGuard};
use pgm_scan::methods::MotionClusterer;
use pgm_scan::pair::ScanPair;
use pgm_scan::{Error, Pose2, Result, Scan};
use serde::Serialize;
use shape::Extent;
use std::collections::{HashSet, VecDeque};

/// `motion` (over some duration) scaled to `factor` times that duration: translation
/// and rotation scaled alike.
pub(crate) fn scale(motion: &Pose2, factor: f64) -> Pose2 {
    Pose2::new(
        motion.x() * factor,
        motion.y() * factor,
        motion.theta() * factor,
    )
}

/// Parameters of the [`OnlineTracker`] (checked by [`ParamGuard::check`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OnlineParams {
    /// The detector runs on scans `n − k` and `n`; `None` (the default): on scan `n`
    /// and the latest scan at least [`OnlineParams::reference_gap`] seconds before it.
    pub k: Option<usize>,
    /// With `k` unset, the shortest time (s) from the detector's reference scan to the
    /// current scan (0.3: an object at [`OnlineParams::min_speed`], 0.5 m/s, moves
    /// 0.15 m in that time, CRF-Clustering's smallest displacement of a moving object;
    /// over one scan of a 7.5-12.5 Hz scanner a walker moves less than that and is not
    /// seen to move).
    pub reference_gap: f64,
    /// The sequence ego-motion.
    pub ego: EgoParams,
    /// Slowest speed (m/s) that counts as moving (0.5: the walking-speed threshold by
    /// which the leigh-gtm1 and datmo labels call a person or a car moving).
    pub min_speed: f64,
    /// Largest distance (m) of a measured centre from a track's predicted centre,
    /// beyond half the track's extent (0.5).
    pub gate: f64,
    /// Detected objects whose returns come this close (m) are one object (0.6: a
    /// walker's legs are at most a stride apart).
    pub merge_distance: f64,
    /// Consecutive returns farther apart than this (m) belong to different segments
    /// when a track looks for its object (0.15).
    pub segment_gap: f64,
    /// Largest extent (m) of an object a track may take (segments larger are
    /// background) (5.0).
    pub max_extent: f64,
    /// Fewest returns of a detected object (3, CRF-Clustering's smallest object).
    pub min_returns: usize,
    /// Steps with evidence of motion that confirm a track (2), the last of them with
    /// the track displaced since its birth (see the module docs).
    pub confirm: usize,
    /// Time (s) after its birth within which a track must be confirmed (2.0: an
    /// object at [`OnlineParams::min_speed`] moves twice the noise of two measured
    /// centres, 0.42 m at the default noise, in 0.85 s; the rest allows for scans in
    /// which it is not found).
    pub confirm_time: f64,
    /// Scans a confirmed track survives without being found (5).
    pub max_coast: usize,
    /// Standard deviation (m) of a measured centre per axis (0.15: the visible legs of
    /// a walker swing up to about half a stride, 0.3-0.35 m, either side of the body's
    /// centre, and one leg often hides the other).
    pub measurement_sigma: f64,
    /// Spectral density (m²/s³) of the filters' white-noise acceleration (1.0: about
    /// 1 m/s² over one second, a walker's typical acceleration).
    pub acceleration: f64,
    /// Standard deviation (m/s) per axis of a new track's velocity, which starts at
    /// rest (2.0).
    pub initial_speed_sigma: f64,
    /// Smallest depth (m) of an object's centre behind its visible returns (0.05).
    pub min_depth: f64,
    /// Shortest gap (s) between consecutive scans of one sequence (0.01).
    pub min_step: f64,
    /// Longest gap (s) between consecutive scans of one sequence (1.0).
    pub max_gap: f64,
}

impl Default for OnlineParams {
    fn default() -> Self {
        Self {
            k: None,
            reference_gap: 0.3,
            ego: EgoParams::default(),
            min_speed: 0.5,
            gate: 0.5,
            merge_distance: 0.6,
            segment_gap: 0.15,
            max_extent: 5.0,
            min_returns: 3,
            confirm: 2,
            confirm_time: 2.0,
            max_coast: 5,
            measurement_sigma: 0.15,
            acceleration: 1.0,
            initial_speed_sigma: 2.0,
            min_depth: 0.05,
            min_step: 0.01,
            max_gap: 1.0,
        }
    }
}

impl OnlineParams {
    /// The tracker over `detector` (parameters checked).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the first parameter out of range.
    pub fn tracker<'d>(&self, detector: &'d dyn MotionClusterer) -> Result<OnlineTracker<'d>> {
        self.check_ref()?;
        Ok(OnlineTracker {
            params: *self,
            ego: self.ego.check()?,
            detector,
            history: VecDeque::new(),
            tracks: Vec::new(),
            next_id: 0,
            scans: 0,
            sequence: 0,
            pose: Pose2::identity(),
            previous_movers: Vec::new(),
        })
    }
}

impl ParamGuard for OnlineParams {
    type Checked = OnlineParams;
    type Error = Error;

    fn check_ref(&self) -> Result<()> {
        if self.k == Some(0) {
            return Err(InvalidParameter::new("k", 0, "at least 1").into());
        }
        InvalidParameter::non_negative(
            "reference_gap",
            self.reference_gap,
            "a finite time in seconds >= 0",
        )?;
        self.ego.check_ref()?;
        InvalidParameter::non_negative("min_speed", self.min_speed, "a finite speed in m/s >= 0")?;
        for (name, value) in [
            ("gate", self.gate),
            ("merge_distance", self.merge_distance),
            ("segment_gap", self.segment_gap),
            ("max_extent", self.max_extent),
            ("measurement_sigma", self.measurement_sigma),
        ] {
            InvalidParameter::positive(name, value, "a distance in metres > 0")?;
        }
        InvalidParameter::positive(
            "acceleration",
            self.acceleration,
            "a spectral density in m²/s³ > 0",
        )?;
        InvalidParameter::positive(
            "initial_speed_sigma",
            self.initial_speed_sigma,
            "a speed in m/s > 0",
        )?;
        InvalidParameter::non_negative(
            "min_depth",
            self.min_depth,
            "a finite distance in metres >= 0",
        )?;
        if self.min_returns < 2 {
            return Err(
                InvalidParameter::new("min_returns", self.min_returns, "at least 2").into(),
            );
        }
        if self.confirm == 0 {
            return Err(InvalidParameter::new("confirm", 0, "at least 1").into());
        }
        InvalidParameter::positive("confirm_time", self.confirm_time, "a time in seconds > 0")?;
        crate::params::check_scan_gaps(self.max_gap, self.min_step)
    }

    fn check(self) -> Result<OnlineParams> {
        self.check_ref()?;
        Ok(self)
    }
}

/// A track's state in one scan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TrackState {
    /// Not yet confirmed.
    Tentative,
    /// Confirmed and found moving in this scan.
    Confirmed,
    /// Confirmed, not found in this scan: reported where its filter predicts it.
    Coasting,
    /// Confirmed, found in this scan, slower than the speed that counts as moving.
    Stopped,
}

/// One object of one scan.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrackedObject {
    /// The track (unique within the scan, stable over time; numbered from 0 in the
    /// order tracks start).
    pub track: u64,
    /// Its state.
    pub state: TrackState,
    /// Whether the detector reported it in this scan.
    pub detected: bool,
    /// Its centre in this scan's sensor frame (m): the filter's estimate.
    pub centre: [f64; 2],
    /// Its velocity over the ground in this scan's sensor frame (m/s).
    pub velocity: [f64; 2],
    /// The velocity's covariance (m²/s², row-major 2 × 2, same frame).
    pub velocity_covariance: [[f64; 2]; 2],
    /// Its extent (m): along its heading and across.
    pub extent: [f64; 2],
    /// The beams of its returns in this scan (empty when coasting).
    pub beams: Vec<usize>,
    /// Confidence in [0, 1] (the track score's logistic), for sweeping operating
    /// points.
    pub score: f64,
}

/// What the tracker says of one scan.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScanReport {
    /// The scan's position in the stream (from 0).
    pub index: usize,
    /// Its time stamp (s).
    pub time: f64,
    /// Its sequence (numbered from 0).
    pub sequence: usize,
    /// The step's ego-motion; `None` at a sequence's first scan.
    pub ego: Option<EgoStep>,
    /// The pose of this scan's sensor frame in the frame of its sequence's first scan.
    pub pose: Pose2,
    /// Whether the detector converged (true at a sequence's first scan, where it does
    /// not run).
    pub converged: bool,
    /// The tracks alive in this scan.
    pub objects: Vec<TrackedObject>,
}

#[derive(Clone, Debug)]
struct Track {
    id: u64,
    filter: ConstantVelocity,
    extent: Extent,
    confirmed: bool,
    /// Steps with evidence of motion: a detection, or found where its net displacement
    /// since birth shows it moving at least the speed that counts.
    evidence: usize,
    /// Where (sequence frame) and when (s) it started.
    birth: (Point2<f64>, f64),
    /// The scan it started in and that scan's pose (shared by the tracks born in it);
    /// `None` once confirmed.
    birth_scan: Option<std::sync::Arc<(Scan, Pose2)>>,
    /// The returns (sequence frame) of that scan within [`OnlineParams::max_extent`]
    /// of its first centre, each with the distance (m) within which a return of the
    /// same static surface lies (see [`Track::left_birth_surfaces`]); emptied once
    /// confirmed.
    birth_returns: Vec<(Point2<f64>, f64)>,
    age: usize,
    coast: usize,
    llr: f64,
}

impl Track {
    /// Whether most of `points` (the current scan's frame, whose pose is `pose`), and
    /// at least `min_returns` of them (as many as a detection needs: one or two
    /// returns on a far, sparsely seen surface say little), lie where the scan the
    /// track started in saw no static surface: static clutter
    /// whose measured centre jitters (a box completed behind a changing visible part,
    /// a wall piece sliding along the wall) is still on the surfaces it was seen on,
    /// a mover has left them. A point has left them when that scan saw the space at
    /// it free (more than the surface tolerance in front of its return; or no return
    /// on that bearing and the point within half the maximum range: beyond that,
    /// dark or grazing surfaces often give no return, such as datmo's arena walls at
    /// 7 m of an 8 m laser), or when that scan could not see it (hidden behind nearer
    /// returns, or outside its field of view: a walker going away from the sensor is
    /// behind where it was) and it lies farther than the tolerance from every return
    /// of that scan. The tolerance is the beam spacing at the range plus 0.1 m of
    /// noise (range noise and the ego-motion's error).
    fn left_birth_surfaces(
        &self,
        points: &[Point2<f64>],
        pose: &Pose2,
        min_returns: usize,
    ) -> bool {
        let Some(birth) = &self.birth_scan else {
            return true;
        };
        let (scan, birth_pose) = &**birth;
        let to_birth = birth_pose.inverse().compose(pose);
        let spacing = scan.angle_increment().abs();
        let off = points
            .iter()
            .filter(|q| {
                let b = to_birth.transform_point(q);
                let tolerance = 0.1 + b.coords.norm() * spacing;
                let range = b.coords.norm();
                if scan.beam_near_bearing(b.y.atan2(b.x)).is_none() {
                    // Outside its field of view.
                    return self.off_birth_returns(&pose.transform_point(q));
                }
                match scan.range_towards(&b) {
                    None => range + tolerance < scan.max_range / 2.0,
                    Some(r) if range < r - tolerance => true,
                    Some(r) if range > r + tolerance => {
                        self.off_birth_returns(&pose.transform_point(q))
                    }
                    Some(_) => false,
                }
            })
            .count();
        2 * off >= points.len() && off >= min_returns
    }

    /// Whether `q` (sequence frame) lies beyond the tolerance of every return of the
    /// track's first scan near it.
    fn off_birth_returns(&self, q: &Point2<f64>) -> bool {
        !self
            .birth_returns
            .iter()
            .any(|(r, within)| (r - q).norm() <= *within)
    }
}

/// The returns of `scan` (pose `pose`) within `radius` of `centre` (sequence frame),
/// with their surface tolerance (see [`Track::left_birth_surfaces`]).
fn birth_returns(
    scan: &Scan,
    pose: &Pose2,
    centre: &Point2<f64>,
    radius: f64,
) -> Vec<(Point2<f64>, f64)> {
    let spacing = scan.angle_increment().abs();
    let (points, beams) = scan.points();
    points
        .iter()
        .zip(beams)
        .map(|(q, k)| (pose.transform_point(q), 0.1 + scan.ranges[k] * spacing))
        .filter(|(q, _)| (q - centre).norm() <= radius)
        .collect()
}

/// A set of returns of the current scan taken as one object's measurement.
struct Measurement {
    beams: Vec<usize>,
    detected: bool,
}

/// Log-likelihood-ratio increments of the track score.
const LLR_START: f64 = -1.0;
const LLR_DETECTED: f64 = 1.5;
const LLR_FOUND: f64 = 0.2;
const LLR_FOUND_MOVING: f64 = 1.0;
const LLR_MISSED: f64 = -1.0;
const LLR_RANGE: (f64, f64) = (-6.0, 8.0);

/// The online tracker (see the module docs): built by [`OnlineParams::tracker`].
/// A clone carries on from the same state (a bench measures one step that way).
#[derive(Clone)]
pub struct OnlineTracker<'d> {
    params: OnlineParams,
    ego: EgoMotion,
    detector: &'d dyn MotionClusterer,
    /// The last `k + 1` scans with their poses in the sequence frame.
    history: VecDeque<(Scan, Pose2)>,
    tracks: Vec<Track>,
    next_id: u64,
    scans: usize,
    sequence: usize,
    pose: Pose2,
    /// Beams of the previous scan held by confirmed moving tracks.
    previous_movers: Vec<bool>,
}

impl OnlineTracker<'_> {
    /// The parameters.
    pub fn params(&self) -> &OnlineParams {
        &self.params
    }

    /// Takes in the next scan (its own odometry, if any, is the ego-motion prior) and
    /// returns its objects.
    ///
    /// # Errors
    /// [`Error::BadPair`] naming the scan (by its index in the stream) when it breaks
    /// a [`Scan`] invariant or the detector gives a wrong number of labels; the
    /// detector's and the registration's errors.
    pub fn push(&mut self, scan: Scan) -> Result<ScanReport> {
        let index = self.scans;
        let name = format!("scan {index} (t = {} s)", scan.timestamp);
        scan.validate().map_err(|problem| Error::BadPair {
            pair: name.clone(),
            problem,
        })?;
        if !scan.timestamp.is_finite() {
            return Err(Error::BadPair {
                pair: name,
                problem: format!("time stamp {}: not a finite time", scan.timestamp),
            });
        }
        self.scans += 1;
        let p = self.params;
        let continues = self.history.back().is_some_and(|(prev, _)| {
            let dt = scan.timestamp - prev.timestamp;
            dt >= p.min_step.max(f64::MIN_POSITIVE) && dt <= p.max_gap
        });
        if !continues {
            if index > 0 {
                self.sequence += 1;
            }
            self.tracks.clear();
            self.ego.reset();
            self.history.clear();
            self.pose = Pose2::identity();
            self.previous_movers = vec![false; scan.len()];
            let report = ScanReport {
                index,
                time: scan.timestamp,
                sequence: self.sequence,
                ego: None,
                pose: self.pose,
                converged: true,
                objects: Vec::new(),
            };
            self.history.push_back((scan, self.pose));
            return Ok(report);
        }
        let (previous, previous_pose) = self.history.back().expect("a previous scan");
        let dt = scan.timestamp - previous.timestamp;
        for t in &mut self.tracks {
            t.filter.predict(dt, p.acceleration);
            t.age += 1;
        }
        // Where the confirmed movers are now, by the prior: left out of the ego-motion.
        let (prior, _) = self.ego.predict(previous, &scan);
        let prior_pose = previous_pose.compose(&prior);
        let movers = self.mover_mask(&scan, &prior_pose);
        let step = self
            .ego
            .estimate(previous, &self.previous_movers, &scan, &movers)?;
        self.pose = previous_pose.compose(&step.motion);
        // The detector on scans n − k and n, with the sequence's ego-motion as prior.
        let (reference, reference_pose) = &self.history[self.reference_at(scan.timestamp)];
        let pair = ScanPair {
            name: name.clone(),
            reference: reference.clone(),
            current: scan.clone(),
            odometry: Some(reference_pose.between(&self.pose)),
            truth: None,
        };
        let clustering = self.detector.cluster(&pair)?;
        if clustering.labels.len() != scan.len() {
            return Err(Error::BadPair {
                pair: name,
                problem: format!(
                    "the detector gave {} labels for the {} beams of the scan",
                    clustering.labels.len(),
                    scan.len()
                ),
            });
        }
        let detections = self.detections(&scan, &clustering.labels);
        let measured = self.associate(&scan, detections);
        let objects = self.update(&scan, measured);
        self.previous_movers = vec![false; scan.len()];
        for o in &objects {
            let speed = Vector2::from(o.velocity).norm();
            if o.state != TrackState::Tentative && speed >= p.min_speed {
                for &b in &o.beams {
                    self.previous_movers[b] = true;
                }
            }
        }
        self.history.push_back((scan, self.pose));
        // Keep what the next scan's reference can be: k scans, or every scan after
        // the latest one more than the reference gap before this one (the next scan
        // comes later, so earlier ones are never its reference).
        let keep = match p.k {
            Some(k) => k,
            None => {
                let now = self.history.back().expect("just pushed").0.timestamp;
                self.history
                    .iter()
                    .rev()
                    .position(|(s, _)| now - s.timestamp >= p.reference_gap)
                    .unwrap_or(self.history.len() - 1)
            }
        };
        while self.history.len() > keep + 1 {
            self.history.pop_front();
        }
        Ok(ScanReport {
            index,
            time: self.history.back().expect("just pushed").0.timestamp,
            sequence: self.sequence,
            ego: Some(step),
            pose: self.pose,
            converged: clustering.converged,
            objects,
        })
    }

    /// The detector's reference scan for a scan at `time`: the index in the history
    /// of scan `n − k`, or of the latest at least the reference gap before `time`
    /// (the oldest kept when none is).
    fn reference_at(&self, time: f64) -> usize {
        let p = &self.params;
        match p.k {
            Some(k) => self.history.len().saturating_sub(k),
            None => self
                .history
                .iter()
                .rposition(|(s, _)| time - s.timestamp >= p.reference_gap)
                .unwrap_or(0),
        }
    }

    /// Beams of `scan` near where the confirmed moving tracks are predicted, the scan's
    /// pose in the sequence frame taken to be `pose`.
    fn mover_mask(&self, scan: &Scan, pose: &Pose2) -> Vec<bool> {
        let p = &self.params;
        let to_scan = pose.inverse();
        let around: Vec<(Point2<f64>, f64)> = self
            .tracks
            .iter()
            .filter(|t| t.confirmed && t.filter.moves_faster_than(p.min_speed))
            .map(|t| {
                let r = p.gate + t.extent.length.max(t.extent.width) / 2.0;
                (to_scan.transform_point(&t.filter.centre()), r * r)
            })
            .collect();
        (0..scan.len())
            .map(|b| {
                scan.valid[b] && {
                    let q = scan.beam_point(b);
                    around.iter().any(|(c, r2)| (q - c).norm_squared() <= *r2)
                }
            })
            .collect()
    }

    /// The detector's moving objects with enough returns, those whose returns come
    /// within the merge distance of each other joined: beams of each.
    fn detections(&self, scan: &Scan, labels: &[Option<u32>]) -> Vec<Vec<usize>> {
        let p = &self.params;
        let mut groups: Vec<Vec<usize>> = Vec::new();
        let mut by_label: std::collections::BTreeMap<u32, Vec<usize>> = Default::default();
        for (b, l) in labels.iter().enumerate() {
            if let Some(l) = *l {
                if l > 0 && scan.valid[b] {
                    by_label.entry(l).or_default().push(b);
                }
            }
        }
        for (_, beams) in by_label {
            if beams.len() >= p.min_returns {
                groups.push(beams);
            }
        }
        merge_close(scan, groups, p.merge_distance)
    }

    /// Each track's measurement in `scan`: the detection assigned to it, else the
    /// segments it finds near its prediction; the detections no track takes start
    /// tracks. Returns (track position or `None` for a new track, measurement).
    fn associate(
        &mut self,
        scan: &Scan,
        detections: Vec<Vec<usize>>,
    ) -> Vec<(Option<usize>, Measurement)> {
        let p = self.params;
        let to_scan = self.pose.inverse();
        let predicted: Vec<Point2<f64>> = self
            .tracks
            .iter()
            .map(|t| to_scan.transform_point(&t.filter.centre()))
            .collect();
        let reach: Vec<f64> = self
            .tracks
            .iter()
            .map(|t| p.gate + t.extent.length.max(t.extent.width) / 2.0)
            .collect();
        let centres: Vec<Point2<f64>> = detections
            .iter()
            .map(|g| mean(&points_of(scan, g)))
            .collect();
        // Minimum-sum assignment over the gated distances (fixed point, µm).
        const FAR: i64 = 1_000_000_000;
        let (nt, nd) = (self.tracks.len(), detections.len());
        let mut assigned: Vec<Option<usize>> = vec![None; nt];
        let mut taken = vec![false; nd];
        if nt > 0 && nd > 0 {
            let cost = |t: usize, d: usize| {
                let dist = (predicted[t] - centres[d]).norm();
                if dist <= reach[t] {
                    (dist * 1e6).round() as i64
                } else {
                    FAR
                }
            };
            let (rows, cols) = (nt.min(nd), nt.max(nd));
            let tracks_are_rows = nt <= nd;
            let matrix = Matrix::from_fn(rows, cols, |(r, c)| {
                if tracks_are_rows {
                    cost(r, c)
                } else {
                    cost(c, r)
                }
            });
            let (_, assignment) = pathfinding::kuhn_munkres::kuhn_munkres_min(&matrix);
            for (r, &c) in assignment.iter().enumerate() {
                let (t, d) = if tracks_are_rows { (r, c) } else { (c, r) };
                if cost(t, d) < FAR {
                    assigned[t] = Some(d);
                    taken[d] = true;
                }
            }
        }
        let mut used: HashSet<usize> = detections.iter().flatten().copied().collect();
        let mut out = Vec::new();
        // Tracks without a detection look for their object, confirmed and older first.
        let mut order: Vec<usize> = (0..nt).collect();
        order.sort_by(|&a, &b| {
            let (ta, tb) = (&self.tracks[a], &self.tracks[b]);
            tb.confirmed
                .cmp(&ta.confirmed)
                .then(tb.llr.total_cmp(&ta.llr))
        });
        let segments = self.segments(scan);
        for t in order {
            if let Some(d) = assigned[t] {
                out.push((
                    Some(t),
                    Measurement {
                        beams: detections[d].clone(),
                        detected: true,
                    },
                ));
                continue;
            }
            let track = &self.tracks[t];
            let size =
                (track.extent.length.max(track.extent.width) + p.merge_distance).min(p.max_extent);
            let found = self.search(scan, &segments, &used, &predicted[t], reach[t], size);
            if !found.is_empty() {
                used.extend(found.iter().copied());
                out.push((
                    Some(t),
                    Measurement {
                        beams: found,
                        detected: false,
                    },
                ));
            }
        }
        for (d, g) in detections.into_iter().enumerate() {
            if !taken[d] {
                out.push((
                    None,
                    Measurement {
                        beams: g,
                        detected: true,
                    },
                ));
            }
        }
        out
    }

    /// The segments of `scan` (beams of each) no larger than the largest extent.
    fn segments(&self, scan: &Scan) -> Vec<Vec<usize>> {
        let (_, beams) = scan.points();
        scan.gap_segments(self.params.segment_gap)
            .into_iter()
            .map(|r| beams[r].to_vec())
            .filter(|s| {
                let pts = points_of(scan, s);
                match (pts.first(), pts.last()) {
                    (Some(a), Some(b)) => {
                        (a - b).norm() <= self.params.max_extent
                            && pts.iter().all(|q| (q - a).norm() <= self.params.max_extent)
                    }
                    _ => false,
                }
            })
            .collect()
    }

    /// The free segments near `centre` (within `reach`): the nearest and those within
    /// the merge distance of it.
    fn search(
        &self,
        scan: &Scan,
        segments: &[Vec<usize>],
        used: &HashSet<usize>,
        centre: &Point2<f64>,
        reach: f64,
        size: f64,
    ) -> Vec<usize> {
        type Candidate<'a> = (&'a Vec<usize>, Vec<Point2<f64>>, f64);
        let free: Vec<Candidate> = segments
            .iter()
            .filter(|s| s.iter().all(|b| !used.contains(b)))
            .map(|s| (s, points_of(scan, s)))
            .filter(|(_, pts)| diameter(pts) <= size)
            .map(|(s, pts)| {
                let d = pts
                    .iter()
                    .map(|q| (q - centre).norm())
                    .fold(f64::INFINITY, f64::min);
                (s, pts, d)
            })
            .filter(|(_, _, d)| *d <= reach)
            .collect();
        let Some(nearest) = free.iter().min_by(|a, b| a.2.total_cmp(&b.2)) else {
            return Vec::new();
        };
        let mut beams: Vec<usize> = free
            .iter()
            .filter(|(_, pts, _)| close(pts, &nearest.1, self.params.merge_distance))
            .flat_map(|(s, _, _)| s.iter().copied())
            .collect();
        beams.sort_unstable();
        beams.dedup();
        if diameter(&points_of(scan, &beams)) > size {
            beams = nearest.0.clone();
        }
        beams
    }

    /// Takes the measurements into the tracks, starts the new ones, ends the lost
    /// ones, and reports the live ones.
    fn update(
        &mut self,
        scan: &Scan,
        measured: Vec<(Option<usize>, Measurement)>,
    ) -> Vec<TrackedObject> {
        let p = self.params;
        let mut beams_of: Vec<Option<(Vec<usize>, bool)>> = vec![None; self.tracks.len()];
        let mut born_in: Option<std::sync::Arc<(Scan, Pose2)>> = None;
        for (t, m) in measured {
            let points: Vec<Point2<f64>> = points_of(scan, &m.beams);
            match t {
                Some(t) => {
                    let track = &mut self.tracks[t];
                    let velocity = track.filter.velocity();
                    let axis = axis_of(&points, &self.pose, velocity, p.min_speed);
                    let (_, seen) = shape::visible_box(&points, &axis);
                    // The extent grows with what the detector shows moving only: a
                    // segment a track finds by itself may hold background next to
                    // the object, and a track whose extent grew on it would reach
                    // ever farther (a wall).
                    let extent = if m.detected {
                        Extent {
                            length: track.extent.length.max(seen.length).min(p.max_extent),
                            width: track.extent.width.max(seen.width).min(p.max_extent),
                        }
                    } else {
                        track.extent
                    };
                    let c = self.pose.transform_point(&shape::centre(
                        &points,
                        &axis,
                        &extent,
                        p.min_depth,
                    ));
                    // The measured centre must lie within the gate of the prediction
                    // (beyond half the extent the track had): else it is another
                    // object's, and the track is not found.
                    let reach = p.gate + track.extent.length.max(track.extent.width) / 2.0;
                    if (c - track.filter.centre()).norm() > reach {
                        continue;
                    }
                    track.extent = extent;
                    track.filter.update(&c, p.measurement_sigma);
                    track.coast = 0;
                    let elapsed = scan.timestamp - track.birth.1;
                    let displaced = (c - track.birth.0).norm();
                    // Significant against two measurements' noise, and fast enough.
                    let noise = 2.0 * std::f64::consts::SQRT_2 * p.measurement_sigma;
                    let moving_since_birth =
                        elapsed > 0.0 && displaced >= (p.min_speed * elapsed).max(noise);
                    if m.detected {
                        track.evidence += 1;
                        track.llr += LLR_DETECTED;
                    } else if moving_since_birth {
                        track.evidence += 1;
                        track.llr += LLR_FOUND_MOVING;
                    } else {
                        track.llr += LLR_FOUND;
                    }
                    if !track.confirmed
                        && track.evidence >= p.confirm
                        && moving_since_birth
                        && track.left_birth_surfaces(&points, &self.pose, p.min_returns)
                    {
                        track.confirmed = true;
                        track.birth_returns = Vec::new();
                        track.birth_scan = None;
                    }
                    beams_of[t] = Some((m.beams, m.detected));
                }
                None => {
                    let axis = shape::principal_axis(&points);
                    let (_, seen) = shape::visible_box(&points, &axis);
                    let extent = Extent {
                        length: seen.length.min(p.max_extent),
                        width: seen.width.min(p.max_extent),
                    };
                    let c = self.pose.transform_point(&shape::centre(
                        &points,
                        &axis,
                        &extent,
                        p.min_depth,
                    ));
                    let track = Track {
                        id: self.next_id,
                        filter: ConstantVelocity::new(
                            c,
                            p.measurement_sigma,
                            p.initial_speed_sigma,
                        ),
                        extent,
                        confirmed: p.confirm <= 1,
                        evidence: 1,
                        birth: (c, scan.timestamp),
                        birth_returns: birth_returns(scan, &self.pose, &c, p.max_extent),
                        birth_scan: Some(
                            born_in
                                .get_or_insert_with(|| {
                                    std::sync::Arc::new((scan.clone(), self.pose))
                                })
                                .clone(),
                        ),
                        age: 0,
                        coast: 0,
                        llr: LLR_START + LLR_DETECTED,
                    };
                    self.next_id += 1;
                    self.tracks.push(track);
                    beams_of.push(Some((m.beams, true)));
                }
            }
        }
        for (t, b) in self.tracks.iter_mut().zip(&beams_of) {
            if b.is_none() {
                t.coast += 1;
                t.llr += LLR_MISSED;
            }
            t.llr = t.llr.clamp(LLR_RANGE.0, LLR_RANGE.1);
        }
        // End the lost and the unconfirmed.
        let keep: Vec<bool> = self
            .tracks
            .iter()
            .map(|t| {
                if t.confirmed {
                    t.coast <= p.max_coast
                } else {
                    t.coast <= 1 && scan.timestamp - t.birth.1 < p.confirm_time
                }
            })
            .collect();
        let mut objects = Vec::new();
        let to_scan = self.pose.inverse();
        let rotation = to_scan.theta();
        let (s, c) = rotation.sin_cos();
        for ((t, b), k) in self.tracks.iter().zip(beams_of).zip(&keep) {
            if !k {
                continue;
            }
            let v = t.filter.velocity();
            let v = Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y);
            let cov = t.filter.velocity_covariance();
            let r = nalgebra::Matrix2::new(c, -s, s, c);
            let cov = r * cov * r.transpose();
            let centre = to_scan.transform_point(&t.filter.centre());
            let (beams, detected) = b.unwrap_or_default();
            let state = if !t.confirmed {
                TrackState::Tentative
            } else if t.coast > 0 {
                TrackState::Coasting
            } else if v.norm() < p.min_speed {
                TrackState::Stopped
            } else {
                TrackState::Confirmed
            };
            objects.push(TrackedObject {
                track: t.id,
                state,
                detected,
                centre: [centre.x, centre.y],
                velocity: [v.x, v.y],
                velocity_covariance: [[cov[(0, 0)], cov[(0, 1)]], [cov[(1, 0)], cov[(1, 1)]]],
                extent: [t.extent.length, t.extent.width],
                beams,
                score: 1.0 / (1.0 + (-t.llr).exp()),
            });
        }
        let mut k = keep.into_iter();
        self.tracks.retain(|_| k.next().unwrap_or(false));
        objects
    }
}

/// The axis of an object's box: its heading (the filter's velocity, taken into this
/// scan's frame) when it moves at least `min_speed`, else the principal axis of its
/// returns.
fn axis_of(
    points: &[Point2<f64>],
    pose: &Pose2,
    velocity: Vector2<f64>,
    min_speed: f64,
) -> Vector2<f64> {
    if velocity.norm() >= min_speed {
        let (s, c) = (-pose.theta()).sin_cos();
        let v = Vector2::new(
            c * velocity.x - s * velocity.y,
            s * velocity.x + c * velocity.y,
        );
        v.normalize()
    } else {
        shape::principal_axis(points)
    }
}

/// `groups` (beams of `scan`) with every two whose returns come within `d` (m) of each
/// other joined, until no two do.
fn merge_close(scan: &Scan, mut groups: Vec<Vec<usize>>, d: f64) -> Vec<Vec<usize>> {
    loop {
        let points: Vec<Vec<Point2<f64>>> = groups.iter().map(|g| points_of(scan, g)).collect();
        let pair = (0..groups.len())
            .flat_map(|a| (a + 1..groups.len()).map(move |b| (a, b)))
            .find(|&(a, b)| close(&points[a], &points[b], d));
        let Some((a, b)) = pair else {
            return groups;
        };
        let taken = groups.remove(b);
        groups[a].extend(taken);
        groups[a].sort_unstable();
    }
}

fn points_of(scan: &Scan, beams: &[usize]) -> Vec<Point2<f64>> {
    beams.iter().map(|&b| scan.beam_point(b)).collect()
}

fn mean(points: &[Point2<f64>]) -> Point2<f64> {
    let n = points.len().max(1) as f64;
    Point2::from(points.iter().fold(Vector2::zeros(), |a, p| a + p.coords) / n)
}

/// The largest distance between two of `points` (m).
fn diameter(points: &[Point2<f64>]) -> f64 {
    let mut d2: f64 = 0.0;
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            d2 = d2.max((a - b).norm_squared());
        }
    }
    d2.sqrt()
}

/// Whether some point of `a` lies within `d` of some point of `b`.
fn close(a: &[Point2<f64>], b: &[Point2<f64>], d: f64) -> bool {
    let d2 = d * d;
    a.iter()
        .any(|p| b.iter().any(|q| (p - q).norm_squared() <= d2))
}

/// The offline mode over a finished log (see the module docs): a track that was ever
/// confirmed is reported from its birth, its tentative scans marked with the state it
/// reached; a track never confirmed is dropped from every scan.
///
/// `min_speed` (m/s) decides whether such a scan's object was moving
/// ([`TrackState::Confirmed`]) or not ([`TrackState::Stopped`]).
pub fn smooth(mut reports: Vec<ScanReport>, min_speed: f64) -> Vec<ScanReport> {
    let confirmed: HashSet<(usize, u64)> = reports
        .iter()
        .flat_map(|r| {
            r.objects
                .iter()
                .filter(|o| o.state != TrackState::Tentative)
                .map(move |o| (r.sequence, o.track))
        })
        .collect();
    for r in &mut reports {
        let sequence = r.sequence;
        r.objects
            .retain(|o| confirmed.contains(&(sequence, o.track)));
        for o in &mut r.objects {
            if o.state == TrackState::Tentative {
                o.state = if Vector2::from(o.velocity).norm() >= min_speed {
                    TrackState::Confirmed
                } else {
                    TrackState::Stopped
                };
            }
        }
    }
    reports
}

#[cfg(test)]
mod tests;
