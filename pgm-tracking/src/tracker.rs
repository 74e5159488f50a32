//! The tracker: the run over a sequence (tracks, their evidence and the steps),
//! a track's velocity from its previous detection, and a pair's motion.

#[allow(unused_imports)]
use super::*;
use nalgebra::{Point2, Vector2};
use pgm_scan::methods::{MotionClusterer, MotionClustering};
use pgm_scan::pair::ScanPair;
use pgm_scan::{Error, Pose2, Result};
use rayon::prelude::*;

/// Multi-scan tracking with checked parameters (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tracker {
    pub(crate) params: TrackingParams,
}

/// One object followed over the current scans.
#[derive(Clone, Debug)]
pub(crate) struct Track {
    /// Index into the evidence of every track of the run.
    pub(crate) id: usize,
    /// Its returns in the frame of the last current scan.
    pub(crate) points: Vec<Point2<f64>>,
    /// Its motion over `step` seconds, in that frame (maps its returns at the earlier
    /// time onto where they are at the later).
    pub(crate) velocity: Pose2,
    /// Seconds `velocity` spans.
    pub(crate) step: f64,
    /// Scans since it was last found.
    pub(crate) coast: usize,
    /// The centre of its returns where it was last found or detected, in the frame
    /// of the last current scan (carried along by the ego-motion alone).
    pub(crate) seen: Point2<f64>,
    /// Where it started (centre of its returns, in the frame of the first scan of the
    /// sequence) and when (s).
    pub(crate) origin: Point2<f64>,
    pub(crate) born: f64,
}

/// What the run learned about a track, kept after it ends.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Evidence {
    /// Steps with evidence of motion.
    pub(crate) steps: usize,
    /// Times it was looked for in a later scan.
    pub(crate) followed: usize,
}

/// A track found in one scan.
pub(crate) struct Found {
    /// Position in the list of live tracks.
    pub(crate) track: usize,
    /// Beams of the current scan it takes.
    pub(crate) beams: Vec<usize>,
    /// Whether this step shows it moving.
    pub(crate) moving: bool,
}

/// A requested pair's clustering, and the label and track id of each of its moving
/// objects.
pub(crate) type Reported = (MotionClustering, Vec<TrackedObject>);

/// One requested pair's place in the run.
pub(crate) struct Step {
    /// The requested pair (index into the input).
    pub(crate) pair: usize,
    /// The previous current scan's pair and the seconds since it, when the sequence
    /// goes on.
    pub(crate) previous: Option<(usize, f64)>,
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
}

impl Tracker {
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
    pub(crate) fn newborn_continued(
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
    pub(crate) fn velocity_from_previous(
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
    pub(crate) fn pair_motion(
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
