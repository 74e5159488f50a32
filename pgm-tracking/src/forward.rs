//! The forward step: tracks moved into the next current scan, found or lost there,
//! and each pair answered from them (steps 2 and 3 of the crate docs).

#[allow(unused_imports)]
use super::*;
use nalgebra::Point2;
use pgm_scan::methods::MotionClustering;
use pgm_scan::pair::{ClusterMotion, ScanPair};
use pgm_scan::registration::Icp;
use pgm_scan::Pose2;
use std::collections::HashMap;

impl Tracker {
    /// Steps 2 and 3 of the module docs on the consecutive pair `step` (previous
    /// current scan as reference; `ego` the motion of its current scan in the frame of
    /// its reference, `dt` seconds later). Moves every track into the current frame,
    /// ends the lost ones and returns the found ones.
    pub(crate) fn follow(
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
    pub(crate) fn report(
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
        let labels_seen = detection.moving_labels();
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
                .motion_of(label)
                .map(|m| m.inverse().compose(&ego_pair));
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
}
