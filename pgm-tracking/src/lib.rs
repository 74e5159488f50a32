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

mod backward;
mod forward;
mod geometry;
mod objects;
pub mod online;
mod params;
mod tracker;

pub use geometry::time_order;
pub use objects::{Tracked, TrackedClusterer, TrackedObject, TrackingCounts};
pub use online::{OnlineParams, OnlineTracker, ScanReport, TrackState};
pub use params::TrackingParams;
pub use tracker::Tracker;

#[doc(no_inline)]
pub use pgm_scan::methods::{MotionClusterer, MotionClustering};

#[allow(unused_imports)]
use {geometry::*, objects::*, tracker::*};

#[cfg(test)]
mod tests;
