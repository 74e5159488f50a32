//! What the tracker reports: each pair's moving objects with their tracks, the
//! counts of what tracking changed, and the clusterings answered pair by pair.

#[allow(unused_imports)]
use super::*;
use nalgebra::Point2;
use pgm_scan::methods::{MotionClusterer, MotionClustering};
use pgm_scan::pair::ScanPair;
use pgm_scan::{Error, Pose2, Result};
use std::collections::HashMap;

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
    pub(crate) name: String,
    pub(crate) by_name: HashMap<String, MotionClustering>,
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

/// The report of the object labelled `label` in `pair`, followed by `track`.
pub(crate) fn tracked_object(
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
pub(crate) fn untracked_object(
    pair: &ScanPair,
    labels: &[Option<u32>],
    label: u32,
) -> TrackedObject {
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
