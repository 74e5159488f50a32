//! CLEAR-MOT scoring of a multi-object tracker's output, under the leg_tracker
//! benchmark's protocol or the standard one (as py-motmetrics).
//!
//! Sources: K. Bernardin, R. Stiefelhagen, "Evaluating multiple object tracking
//! performance: the CLEAR MOT metrics", EURASIP J. Image and Video Processing, 2008
//! (the metrics); A. Leigh, J. Pineau, N. Olmedo, H. Zhang, "Person Tracking and
//! Following with 2D Laser Scanners", ICRA 2015 (the benchmark protocol, its
//! `clear_mot.py`, and Table III). The protocols are specified in
//! `../shared/tools/TRACKING.md`; `../shared/tools/clear_mot_cases.json` holds
//! hand-computed cases that `datasets/tests/clear_mot.rs` reproduces under both.
//!
//! # Input
//! One [`Frame`] per scan, in order: the tracker's estimates `(track_id, x, y)` and the
//! annotations `(person_id, x, y)` of that scan, in metres, in the same frame (the
//! laser frame of the scan). Every frame counts, also one without annotations (its
//! estimates are false positives) or without estimates (its annotations are misses).
//! An optional [`BearingWindow`] drops estimates and annotations whose bearing
//! `atan2(y, x)` lies outside `[lo, hi]` before anything is counted.
//!
//! # Matching, per frame
//! A pair (estimate, annotation) *may* match only when its Euclidean distance is
//! strictly below the threshold (default 0.75 m).
//! 1. **Kept matches.** A pair matched in an earlier frame whose two ids are both present
//!    now and closer than the threshold is kept, before anything else. Which earlier
//!    matches are remembered depends on the protocol (below).
//! 2. **Assignment** of the remaining estimates and annotations by a minimum-sum
//!    assignment (Hungarian method, `pathfinding::kuhn_munkres`):
//!    - [`Protocol::Benchmark`]: over the raw distances of all remaining pairs, not
//!      gated; an assigned pair counts only if closer than the threshold. The
//!      assignment may therefore choose a pair beyond the threshold and so block a valid
//!      one (as the benchmark's `clear_mot.py` does with the `munkres` package).
//!    - [`Protocol::Standard`]: over the pairs closer than the threshold only (gated):
//!      the most matches possible, and among those the smallest summed distance (as
//!      py-motmetrics, which gives the other pairs a cost so large that none is chosen
//!      while a valid alternative exists).
//!
//!    Distances enter the assignment as integers in nanometres (`i128`, distances capped
//!    at 10⁹ m), so two assignments whose sums differ by less than about a nanometre
//!    count as tied; the threshold test and MOTP use the `f64` distances.
//!
//! # ID switches and the record of last matches
//! - [`Protocol::Benchmark`] (`clear_mot.py`): the record is a one-to-one set of
//!   (track, person) pairs. A match is an ID switch when its track is in the record with
//!   another person, or when its track is not in the record but its person is (with
//!   another track). The record survives frames in which a track or a person is absent;
//!   after each frame, record entries that share a track or a person with a current
//!   match are removed and the current matches added. Step 1 keeps the record's pairs.
//! - [`Protocol::Standard`] (Bernardin & Stiefelhagen; py-motmetrics 1.4
//!   `MOTAccumulator.update`): the record maps each person to the last track it was
//!   matched to, and is only ever overwritten for that person (a track that moves on to
//!   another person does not erase it). A match is an ID switch when its person was
//!   last matched to a different track. Step 1 keeps, for each annotated person in the
//!   frame's order, its last track if that track is present, not yet kept this frame,
//!   and closer than the threshold.
//!
//! A kept match is never an ID switch. ID switches are counted among the matches.
//!
//! # Counts and metrics
//! Over all frames ([`Counts`]): `truth` (annotations), `matches` (switches included),
//! `id_switches`, `false_positives` (estimates matched to nothing) and `misses`
//! (annotations matched to nothing), so that `matches + misses = truth` and
//! `matches + false_positives = estimates`.
//! - MOTA = 1 − (id_switches + false_positives + misses) / truth
//!   (not defined without annotations, or when false positives are not counted).
//! - MOTP = (Σ distances of all matches, switches included) / matches, in metres
//!   (not defined without matches).
//!
//! Logs are pooled by adding their counts ([`Counts`] implements `Add` and `Sum`;
//! [`pool`]); MOTA and MOTP are recomputed from the pooled counts, never averaged. The
//! record of last matches never crosses logs: score each log with its own [`ClearMot`].
//!
//! **The paper's "matches".** Table III of Leigh et al. lists "matches", ID switches and
//! misses that add up to the annotations (149 + 15 + 481 = 645): its "matches" (the
//! script's `correct`, the "valid" of the following logs) exclude the ID switches. That
//! figure is [`Counts::correct`] = `matches − id_switches`; `matches` here includes
//! switches, as TRACKING.md and py-motmetrics (`num_detections`) count them.
//!
//! **Following logs** (only the followed person is annotated): set
//! [`ClearMotOptions::count_false_positives`] to `false`; false positives are then not
//! counted (0) and MOTA is `None`, as the paper prints it "not applicable".
//!
//! ```
//! use pgm_datasets::clear_mot::{ClearMot, ClearMotOptions, Frame, Protocol};
//!
//! # fn main() -> Result<(), pgm_datasets::clear_mot::ClearMotError> {
//! let mut scorer = ClearMot::new(ClearMotOptions {
//!     protocol: Protocol::Benchmark,
//!     ..Default::default()
//! })?;
//! let frame = Frame { estimates: vec![(1, 1.1, 0.0)], truth: vec![(7, 1.0, 0.0)] };
//! let detail = scorer.push(&frame)?;
//! assert_eq!(detail.matches.len(), 1);
//! let summary = scorer.summary();
//! assert_eq!(summary.counts.matches, 1);
//! assert_eq!(summary.mota, Some(1.0));
//! assert!((summary.motp_m.unwrap() - 0.1).abs() < 1e-12);
//! # Ok(())
//! # }
//! ```

use std::collections::{HashMap, HashSet};
use std::iter::Sum;
use std::ops::{Add, AddAssign};

use pathfinding::kuhn_munkres::kuhn_munkres_min;
use pathfinding::matrix::Matrix;
use serde::{Deserialize, Serialize};

/// The benchmark's match threshold, metres (a pair matches only when strictly closer).
pub const DEFAULT_THRESHOLD_M: f64 = 0.75;

/// The bearing window of the benchmark's general-tracking bags, degrees: `[−80°, +12°]`.
pub const GENERAL_TRACKING_WINDOW_DEG: (f64, f64) = (-80.0, 12.0);

/// Distances beyond this (metres) enter the assignment as this value, so the integer
/// costs cannot overflow.
const MAX_COST_M: f64 = 1e9;
/// Fixed-point scale of the assignment costs: nanometres per metre.
const COST_SCALE: f64 = 1e9;

/// One tracker estimate: `(track_id, x, y)`, position in metres.
pub type Estimate = (u64, f64, f64);
/// One annotation: `(person_id, x, y)`, position in metres.
pub type Annotation = (u64, f64, f64);

/// One scan's tracker output and annotations (see the module docs). Deserialises from
/// the JSON of `clear_mot_cases.json` (`{"estimates": [[id, x, y], …], "truth": […]}`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// The tracker's estimates of the scan: `(track_id, x, y)`, metres. Track ids must be
    /// unique within the frame.
    pub estimates: Vec<Estimate>,
    /// The annotations of the scan: `(person_id, x, y)`, metres. Person ids must be
    /// unique within the frame.
    pub truth: Vec<Annotation>,
}

/// Which CLEAR-MOT protocol to score under (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Protocol {
    /// The leg_tracker benchmark's (Leigh et al. 2015, `clear_mot.py`): ungated
    /// assignment, ID switches by the track's or the person's record.
    #[default]
    Benchmark,
    /// The usual CLEAR-MOT (Bernardin & Stiefelhagen 2008, as py-motmetrics with
    /// Euclidean distance): gated assignment, an ID switch when a person is matched to
    /// a different track than the last time.
    Standard,
}

/// A sector of bearings `[lo_rad, hi_rad]` (radians, `atan2(y, x)` in `(−π, π]`,
/// bounds included). Estimates and annotations outside it are dropped before counting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BearingWindow {
    /// Lowest bearing kept, radians.
    pub lo_rad: f64,
    /// Highest bearing kept, radians.
    pub hi_rad: f64,
}

impl BearingWindow {
    /// The window `[lo, hi]` in radians.
    ///
    /// # Errors
    /// [`ClearMotError::InvalidWindow`] when a bound is not finite or `lo > hi`.
    pub fn radians(lo: f64, hi: f64) -> Result<Self, ClearMotError> {
        let w = BearingWindow {
            lo_rad: lo,
            hi_rad: hi,
        };
        w.validate()?;
        Ok(w)
    }

    /// The window `[lo, hi]` in degrees (stored in radians).
    ///
    /// # Errors
    /// [`ClearMotError::InvalidWindow`] when a bound is not finite or `lo > hi`.
    pub fn degrees(lo: f64, hi: f64) -> Result<Self, ClearMotError> {
        Self::radians(lo.to_radians(), hi.to_radians())
    }

    /// The benchmark's window for its general-tracking bags (leigh-gtm1 is one):
    /// `[−80°, +12°]` ([`GENERAL_TRACKING_WINDOW_DEG`]).
    pub fn general_tracking() -> Self {
        BearingWindow {
            lo_rad: GENERAL_TRACKING_WINDOW_DEG.0.to_radians(),
            hi_rad: GENERAL_TRACKING_WINDOW_DEG.1.to_radians(),
        }
    }

    /// Whether the point `(x, y)` (metres) lies in the window:
    /// `lo_rad ≤ atan2(y, x) ≤ hi_rad`.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let bearing = y.atan2(x);
        bearing >= self.lo_rad && bearing <= self.hi_rad
    }

    fn validate(&self) -> Result<(), ClearMotError> {
        if self.lo_rad.is_finite() && self.hi_rad.is_finite() && self.lo_rad <= self.hi_rad {
            Ok(())
        } else {
            Err(ClearMotError::InvalidWindow {
                lo_rad: self.lo_rad,
                hi_rad: self.hi_rad,
            })
        }
    }
}

/// How to score (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClearMotOptions {
    /// Match threshold, metres: a pair matches only when its distance is strictly
    /// below it. Default [`DEFAULT_THRESHOLD_M`] (0.75 m). Must be finite and > 0.
    pub threshold_m: f64,
    /// The protocol. Default [`Protocol::Benchmark`].
    pub protocol: Protocol,
    /// Drop estimates and annotations outside this bearing window before counting.
    /// Default `None` (keep all); the benchmark's general-tracking bags use
    /// [`BearingWindow::general_tracking`].
    pub bearing_window: Option<BearingWindow>,
    /// Count false positives (default `true`). `false` for following logs, where only
    /// the followed person is annotated: false positives stay 0 and MOTA is `None`.
    pub count_false_positives: bool,
}

impl Default for ClearMotOptions {
    fn default() -> Self {
        ClearMotOptions {
            threshold_m: DEFAULT_THRESHOLD_M,
            protocol: Protocol::Benchmark,
            bearing_window: None,
            count_false_positives: true,
        }
    }
}

/// Bad options or bad tracker output. Frames are indexed from 0 in the order they are
/// pushed to one [`ClearMot`]; a rejected frame leaves the scorer unchanged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ClearMotError {
    /// An estimate has a NaN or infinite coordinate.
    #[error(
        "frame {frame}: estimate of track {track} has a non-finite position (x = {x}, y = {y})"
    )]
    NonFiniteEstimate {
        /// Index of the frame (from 0).
        frame: usize,
        /// Its track id.
        track: u64,
        /// x, metres.
        x: f64,
        /// y, metres.
        y: f64,
    },
    /// An annotation has a NaN or infinite coordinate.
    #[error(
        "frame {frame}: annotation of person {person} has a non-finite position (x = {x}, y = {y})"
    )]
    NonFiniteTruth {
        /// Index of the frame (from 0).
        frame: usize,
        /// Its person id.
        person: u64,
        /// x, metres.
        x: f64,
        /// y, metres.
        y: f64,
    },
    /// The same track id twice in one frame.
    #[error("frame {frame}: track id {track} appears more than once among the estimates")]
    DuplicateTrack {
        /// Index of the frame (from 0).
        frame: usize,
        /// The repeated track id.
        track: u64,
    },
    /// The same person id twice in one frame.
    #[error("frame {frame}: person id {person} appears more than once among the annotations")]
    DuplicatePerson {
        /// Index of the frame (from 0).
        frame: usize,
        /// The repeated person id.
        person: u64,
    },
    /// The match threshold is not a finite positive number.
    #[error("match threshold {threshold_m} m: must be finite and > 0")]
    InvalidThreshold {
        /// The threshold given, metres.
        threshold_m: f64,
    },
    /// The bearing window has a non-finite bound or `lo > hi`.
    #[error("bearing window [{lo_rad}, {hi_rad}] rad: bounds must be finite with lo <= hi")]
    InvalidWindow {
        /// Lower bound given, radians.
        lo_rad: f64,
        /// Upper bound given, radians.
        hi_rad: f64,
    },
}

/// The CLEAR-MOT counts of one or more frames (and logs, pooled by `+`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Counts {
    /// Frames (scans) scored.
    pub frames: u64,
    /// Annotations inside the window (the `truth`, `GT` or "total objects").
    pub truth: u64,
    /// Estimates inside the window.
    pub estimates: u64,
    /// Matched (estimate, annotation) pairs, ID switches included.
    pub matches: u64,
    /// Matches that are ID switches.
    pub id_switches: u64,
    /// Estimates matched to nothing (0 when not counted, see
    /// [`Counts::false_positives_counted`]).
    pub false_positives: u64,
    /// Annotations matched to nothing (`truth − matches`).
    pub misses: u64,
    /// Σ of the distances of all matches (switches included), metres; MOTP is this over
    /// `matches`.
    pub match_distance_sum_m: f64,
    /// Whether false positives were counted in every frame and log of these counts
    /// (`false` once a following log is pooled in; MOTA is then `None`).
    pub false_positives_counted: bool,
}

impl Default for Counts {
    /// Zero counts with false positives counted (the identity of `+`).
    fn default() -> Self {
        Counts {
            frames: 0,
            truth: 0,
            estimates: 0,
            matches: 0,
            id_switches: 0,
            false_positives: 0,
            misses: 0,
            match_distance_sum_m: 0.0,
            false_positives_counted: true,
        }
    }
}

impl Counts {
    /// MOTA = 1 − (id_switches + false_positives + misses) / truth; `None` without
    /// annotations or when false positives were not counted.
    pub fn mota(&self) -> Option<f64> {
        if self.truth == 0 || !self.false_positives_counted {
            return None;
        }
        let errors = self.id_switches + self.false_positives + self.misses;
        Some(1.0 - errors as f64 / self.truth as f64)
    }

    /// MOTP = match_distance_sum_m / matches, metres; `None` without matches.
    pub fn motp_m(&self) -> Option<f64> {
        (self.matches > 0).then(|| self.match_distance_sum_m / self.matches as f64)
    }

    /// Matches that are not ID switches (`matches − id_switches`): the "matches" column
    /// of Table III of Leigh et al. (the `correct` of `clear_mot.py`, the "valid" of the
    /// following logs), for which `correct + id_switches + misses = truth`.
    pub fn correct(&self) -> u64 {
        self.matches - self.id_switches
    }
}

impl Add for Counts {
    type Output = Counts;
    fn add(self, o: Counts) -> Counts {
        Counts {
            frames: self.frames + o.frames,
            truth: self.truth + o.truth,
            estimates: self.estimates + o.estimates,
            matches: self.matches + o.matches,
            id_switches: self.id_switches + o.id_switches,
            false_positives: self.false_positives + o.false_positives,
            misses: self.misses + o.misses,
            match_distance_sum_m: self.match_distance_sum_m + o.match_distance_sum_m,
            false_positives_counted: self.false_positives_counted && o.false_positives_counted,
        }
    }
}

impl AddAssign for Counts {
    fn add_assign(&mut self, o: Counts) {
        *self = *self + o;
    }
}

impl Sum for Counts {
    fn sum<I: Iterator<Item = Counts>>(iter: I) -> Counts {
        iter.fold(Counts::default(), Add::add)
    }
}

impl<'a> Sum<&'a Counts> for Counts {
    fn sum<I: Iterator<Item = &'a Counts>>(iter: I) -> Counts {
        iter.copied().sum()
    }
}

/// Counts with the metrics computed from them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// The counts.
    pub counts: Counts,
    /// MOTA = 1 − (id_switches + false_positives + misses) / truth, a fraction (1 is
    /// perfect, unbounded below); `None` without annotations or when false positives
    /// are not counted.
    pub mota: Option<f64>,
    /// MOTP, the mean distance of all matches (switches included), metres; `None`
    /// without matches.
    pub motp_m: Option<f64>,
}

impl From<Counts> for Summary {
    fn from(counts: Counts) -> Self {
        Summary {
            counts,
            mota: counts.mota(),
            motp_m: counts.motp_m(),
        }
    }
}

impl Add for Summary {
    type Output = Summary;
    /// Pools two summaries: adds the counts and recomputes MOTA and MOTP.
    fn add(self, o: Summary) -> Summary {
        Summary::from(self.counts + o.counts)
    }
}

/// Pools the summaries of several logs: their counts added, MOTA and MOTP recomputed
/// from the pooled counts (as the benchmark aggregates its bags).
pub fn pool<'a>(parts: impl IntoIterator<Item = &'a Summary>) -> Summary {
    Summary::from(parts.into_iter().map(|s| s.counts).sum::<Counts>())
}

/// The `ids` that are not `matched`, sorted.
fn unmatched(ids: impl Iterator<Item = u64>, matched: impl Iterator<Item = u64>) -> Vec<u64> {
    let matched: HashSet<u64> = matched.collect();
    let mut out: Vec<u64> = ids.filter(|id| !matched.contains(id)).collect();
    out.sort_unstable();
    out
}

/// One matched pair of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Match {
    /// The estimate's track id.
    pub track: u64,
    /// The annotation's person id.
    pub person: u64,
    /// Their distance, metres (below the threshold).
    pub distance_m: f64,
    /// Kept from an earlier frame's match (step 1) rather than assigned (step 2).
    pub kept: bool,
    /// Counted as an ID switch.
    pub id_switch: bool,
}

/// What one frame contributed, for debugging.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameResult {
    /// Index of the frame in its scorer (from 0).
    pub frame: usize,
    /// The frame's matches, sorted by track id.
    pub matches: Vec<Match>,
    /// Track ids (inside the window) matched to nothing, sorted: the false positives
    /// when they are counted.
    pub unmatched_tracks: Vec<u64>,
    /// Person ids (inside the window) matched to nothing, sorted: the misses.
    pub unmatched_persons: Vec<u64>,
    /// Estimates dropped by the bearing window.
    pub dropped_estimates: usize,
    /// Annotations dropped by the bearing window.
    pub dropped_truth: usize,
    /// This frame's counts alone.
    pub counts: Counts,
}

/// The streaming CLEAR-MOT scorer of one log: push each scan's frame as the tracker
/// produces it, read the [`summary`](ClearMot::summary) at any time.
#[derive(Debug, Clone)]
pub struct ClearMot {
    opts: ClearMotOptions,
    frames: usize,
    counts: Counts,
    /// Benchmark record: track → person (one-to-one with `person_to_track`).
    track_to_person: HashMap<u64, u64>,
    /// Benchmark record, reversed: person → track.
    person_to_track: HashMap<u64, u64>,
    /// Standard record: person → the track it was last matched to.
    last_track_of_person: HashMap<u64, u64>,
}

impl ClearMot {
    /// A scorer with no frames yet.
    ///
    /// # Errors
    /// [`ClearMotError::InvalidThreshold`] or [`ClearMotError::InvalidWindow`].
    pub fn new(opts: ClearMotOptions) -> Result<Self, ClearMotError> {
        if !(opts.threshold_m.is_finite() && opts.threshold_m > 0.0) {
            return Err(ClearMotError::InvalidThreshold {
                threshold_m: opts.threshold_m,
            });
        }
        if let Some(w) = &opts.bearing_window {
            w.validate()?;
        }
        Ok(ClearMot {
            opts,
            frames: 0,
            counts: Counts {
                false_positives_counted: opts.count_false_positives,
                ..Counts::default()
            },
            track_to_person: HashMap::new(),
            person_to_track: HashMap::new(),
            last_track_of_person: HashMap::new(),
        })
    }

    /// The options.
    pub fn options(&self) -> &ClearMotOptions {
        &self.opts
    }

    /// Frames scored so far (the index the next frame gets).
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The counts so far.
    pub fn counts(&self) -> Counts {
        self.counts
    }

    /// The counts so far with MOTA and MOTP.
    pub fn summary(&self) -> Summary {
        Summary::from(self.counts)
    }

    /// Scores the next frame; see [`ClearMot::push_parts`].
    ///
    /// # Errors
    /// As [`ClearMot::push_parts`].
    pub fn push(&mut self, frame: &Frame) -> Result<FrameResult, ClearMotError> {
        self.push_parts(&frame.estimates, &frame.truth)
    }

    /// Scores the next frame from its estimates `(track_id, x, y)` and annotations
    /// `(person_id, x, y)` (metres) and returns what it contributed.
    ///
    /// # Errors
    /// A non-finite coordinate or a repeated id within the estimates or within the
    /// annotations (checked before the bearing window); the scorer is then unchanged.
    pub fn push_parts(
        &mut self,
        estimates: &[Estimate],
        truth: &[Annotation],
    ) -> Result<FrameResult, ClearMotError> {
        let frame = self.frames;
        validate(frame, estimates, truth)?;
        let thr = self.opts.threshold_m;

        let inside = |&&(_, x, y): &&(u64, f64, f64)| {
            self.opts.bearing_window.is_none_or(|w| w.contains(x, y))
        };
        let est: Vec<Estimate> = estimates.iter().filter(inside).copied().collect();
        let tru: Vec<Annotation> = truth.iter().filter(inside).copied().collect();
        let (n, m) = (est.len(), tru.len());
        let dist = |i: usize, j: usize| {
            let dx = est[i].1 - tru[j].1;
            let dy = est[i].2 - tru[j].2;
            (dx * dx + dy * dy).sqrt()
        };
        let est_index: HashMap<u64, usize> =
            est.iter().enumerate().map(|(i, e)| (e.0, i)).collect();
        let tru_index: HashMap<u64, usize> =
            tru.iter().enumerate().map(|(j, t)| (t.0, j)).collect();

        // (estimate index, truth index, kept)
        let mut pairs: Vec<(usize, usize, bool)> = Vec::new();
        let mut est_used = vec![false; n];
        let mut tru_used = vec![false; m];

        // 1. Kept matches.
        match self.opts.protocol {
            Protocol::Benchmark => {
                for (track, person) in &self.track_to_person {
                    if let (Some(&i), Some(&j)) = (est_index.get(track), tru_index.get(person)) {
                        // The record is one-to-one, so i and j are free here.
                        if dist(i, j) < thr {
                            est_used[i] = true;
                            tru_used[j] = true;
                            pairs.push((i, j, true));
                        }
                    }
                }
            }
            Protocol::Standard => {
                for (j, t) in tru.iter().enumerate() {
                    let Some(track) = self.last_track_of_person.get(&t.0) else {
                        continue;
                    };
                    let Some(&i) = est_index.get(track) else {
                        continue;
                    };
                    if !est_used[i] && dist(i, j) < thr {
                        est_used[i] = true;
                        tru_used[j] = true;
                        pairs.push((i, j, true));
                    }
                }
            }
        }

        // 2. Assignment of the rest.
        let rest_e: Vec<usize> = (0..n).filter(|&i| !est_used[i]).collect();
        let rest_t: Vec<usize> = (0..m).filter(|&j| !tru_used[j]).collect();
        let gated = self.opts.protocol == Protocol::Standard;
        let sub: Vec<Vec<f64>> = rest_e
            .iter()
            .map(|&i| rest_t.iter().map(|&j| dist(i, j)).collect())
            .collect();
        for (a, b) in min_sum_assignment(&sub, thr, gated) {
            pairs.push((rest_e[a], rest_t[b], false));
        }

        // ID switches, against the record before this frame.
        let mut matches: Vec<Match> = pairs
            .iter()
            .map(|&(i, j, kept)| {
                let (track, person) = (est[i].0, tru[j].0);
                let id_switch = !kept
                    && match self.opts.protocol {
                        Protocol::Benchmark => match self.track_to_person.get(&track) {
                            Some(&p) => p != person,
                            None => self.person_to_track.contains_key(&person),
                        },
                        Protocol::Standard => self
                            .last_track_of_person
                            .get(&person)
                            .is_some_and(|&h| h != track),
                    };
                Match {
                    track,
                    person,
                    distance_m: dist(i, j),
                    kept,
                    id_switch,
                }
            })
            .collect();
        matches.sort_by_key(|mt| mt.track);

        // Update the record.
        match self.opts.protocol {
            Protocol::Benchmark => {
                for mt in &matches {
                    if let Some(p) = self.track_to_person.remove(&mt.track) {
                        self.person_to_track.remove(&p);
                    }
                    if let Some(h) = self.person_to_track.remove(&mt.person) {
                        self.track_to_person.remove(&h);
                    }
                }
                for mt in &matches {
                    self.track_to_person.insert(mt.track, mt.person);
                    self.person_to_track.insert(mt.person, mt.track);
                }
            }
            Protocol::Standard => {
                for mt in &matches {
                    self.last_track_of_person.insert(mt.person, mt.track);
                }
            }
        }

        let unmatched_tracks =
            unmatched(est.iter().map(|e| e.0), matches.iter().map(|mt| mt.track));
        let unmatched_persons =
            unmatched(tru.iter().map(|t| t.0), matches.iter().map(|mt| mt.person));

        let counts = Counts {
            frames: 1,
            truth: m as u64,
            estimates: n as u64,
            matches: matches.len() as u64,
            id_switches: matches.iter().filter(|mt| mt.id_switch).count() as u64,
            false_positives: if self.opts.count_false_positives {
                unmatched_tracks.len() as u64
            } else {
                0
            },
            misses: unmatched_persons.len() as u64,
            match_distance_sum_m: matches.iter().map(|mt| mt.distance_m).sum(),
            false_positives_counted: self.opts.count_false_positives,
        };
        self.counts += counts;
        self.frames += 1;
        Ok(FrameResult {
            frame,
            matches,
            unmatched_tracks,
            unmatched_persons,
            dropped_estimates: estimates.len() - n,
            dropped_truth: truth.len() - m,
            counts,
        })
    }
}

/// Scores one log (its frames in order) and returns the summary.
///
/// # Errors
/// As [`ClearMot::new`] and [`ClearMot::push_parts`].
pub fn score(frames: &[Frame], opts: &ClearMotOptions) -> Result<Summary, ClearMotError> {
    let mut scorer = ClearMot::new(*opts)?;
    for f in frames {
        scorer.push(f)?;
    }
    Ok(scorer.summary())
}

/// Scores one log and returns the summary and every frame's detail.
///
/// # Errors
/// As [`ClearMot::new`] and [`ClearMot::push_parts`].
pub fn score_frames(
    frames: &[Frame],
    opts: &ClearMotOptions,
) -> Result<(Summary, Vec<FrameResult>), ClearMotError> {
    let mut scorer = ClearMot::new(*opts)?;
    let detail = frames
        .iter()
        .map(|f| scorer.push(f))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((scorer.summary(), detail))
}

fn validate(
    frame: usize,
    estimates: &[Estimate],
    truth: &[Annotation],
) -> Result<(), ClearMotError> {
    let mut seen = HashSet::with_capacity(estimates.len());
    for &(track, x, y) in estimates {
        if !(x.is_finite() && y.is_finite()) {
            return Err(ClearMotError::NonFiniteEstimate { frame, track, x, y });
        }
        if !seen.insert(track) {
            return Err(ClearMotError::DuplicateTrack { frame, track });
        }
    }
    seen.clear();
    for &(person, x, y) in truth {
        if !(x.is_finite() && y.is_finite()) {
            return Err(ClearMotError::NonFiniteTruth {
                frame,
                person,
                x,
                y,
            });
        }
        if !seen.insert(person) {
            return Err(ClearMotError::DuplicatePerson { frame, person });
        }
    }
    Ok(())
}

/// Distance (metres, ≥ 0, possibly +∞) as an integer cost in nanometres.
fn fixed_cost(d: f64) -> i128 {
    (d.min(MAX_COST_M) * COST_SCALE).round() as i128
}

/// The pairs `(row, column)` of `dist` (rows × columns, metres) that a minimum-sum
/// assignment matches and that are closer than `threshold`. Ungated: every pair takes
/// part with its distance. Gated: only pairs closer than `threshold` take part (the
/// others get a cost no optimal assignment chooses while a valid alternative exists,
/// as py-motmetrics' `add_expensive_edges`), so the result has the most valid pairs
/// possible and, among those, the smallest sum.
fn min_sum_assignment(dist: &[Vec<f64>], threshold: f64, gated: bool) -> Vec<(usize, usize)> {
    let rows = dist.len();
    let cols = dist.first().map_or(0, Vec::len);
    if rows == 0 || cols == 0 {
        return Vec::new();
    }
    let valid = |r: usize, c: usize| dist[r][c] < threshold;
    let invalid_cost = if gated {
        let Some(max_valid) = (0..rows)
            .flat_map(|r| (0..cols).map(move |c| (r, c)))
            .filter(|&(r, c)| valid(r, c))
            .map(|(r, c)| fixed_cost(dist[r][c]))
            .max()
        else {
            return Vec::new();
        };
        // l > (2r − 1) c with c the largest valid cost + 1: one invalid pair costs more
        // than any complete assignment of valid pairs could save.
        let r = rows.min(cols) as i128;
        2 * r * (max_valid + 1) + 1
    } else {
        0
    };
    let cost = |r: usize, c: usize| {
        if gated && !valid(r, c) {
            invalid_cost
        } else {
            fixed_cost(dist[r][c])
        }
    };
    // kuhn_munkres assigns every row a column and needs rows <= columns.
    let assigned: Vec<(usize, usize)> = if rows <= cols {
        let matrix = Matrix::from_fn(rows, cols, |(r, c)| cost(r, c));
        let (_, col_of_row) = kuhn_munkres_min(&matrix);
        col_of_row.into_iter().enumerate().collect()
    } else {
        let matrix = Matrix::from_fn(cols, rows, |(c, r)| cost(r, c));
        let (_, row_of_col) = kuhn_munkres_min(&matrix);
        row_of_col
            .into_iter()
            .enumerate()
            .map(|(c, r)| (r, c))
            .collect()
    };
    assigned.into_iter().filter(|&(r, c)| valid(r, c)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transposed_assignment_matches_rows_and_columns() {
        // 3 estimates, 1 annotation: the closest estimate wins.
        let d = vec![vec![0.5], vec![0.1], vec![0.3]];
        assert_eq!(min_sum_assignment(&d, 0.75, false), vec![(1, 0)]);
        assert_eq!(min_sum_assignment(&d, 0.75, true), vec![(1, 0)]);
        // 1 estimate, 3 annotations.
        let d = vec![vec![0.5, 0.1, 0.3]];
        assert_eq!(min_sum_assignment(&d, 0.75, false), vec![(0, 1)]);
    }

    #[test]
    fn gating_prefers_more_matches_over_a_smaller_sum() {
        // Ungated, (0,0) + (1,1) = 0.1 + 0.8 = 0.9 beats (0,1) + (1,0) = 1.4, but
        // (1,1) is beyond the threshold: one match. Gated: two.
        let d = vec![vec![0.1, 0.7], vec![0.7, 0.8]];
        assert_eq!(min_sum_assignment(&d, 0.75, false), vec![(0, 0)]);
        let mut gated = min_sum_assignment(&d, 0.75, true);
        gated.sort_unstable();
        assert_eq!(gated, vec![(0, 1), (1, 0)]);
    }

    #[test]
    fn huge_distances_do_not_overflow() {
        let d = vec![vec![f64::INFINITY, 1e300], vec![0.2, f64::MAX]];
        assert_eq!(min_sum_assignment(&d, 0.75, false), vec![(1, 0)]);
        assert_eq!(min_sum_assignment(&d, 0.75, true), vec![(1, 0)]);
    }
}
