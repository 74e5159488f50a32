//! The backward pass: a confirmed track followed back in time from the scan it was
//! born in (the smoothing half of a forward-backward tracker; see the crate docs).

#[allow(unused_imports)]
use super::*;
use pgm_scan::methods::MotionClustering;
use pgm_scan::pair::{ClusterMotion, ScanPair};
use pgm_scan::Pose2;
use std::collections::HashMap;

impl Tracker {
    /// The backward pass (see the module docs): every confirmed track is followed
    /// from the scan it was born in (`births`: step and track as born) back through
    /// the earlier scans of its sequence, and a step that shows it moving reports it
    /// in that pair on the returns no reported object holds.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn backward(
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
    pub(crate) fn report_backward(
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
}
