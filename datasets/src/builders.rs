//! Builders of [`ScanPair`]s with ground truth from the real logs.
//!
//! - [`relation_pairs`] (mit-csail): one pair per relation of a Kümmerle-style
//!   `.relations` file, reference = the scan at `t1`, current = the scan at `t2`
//!   (matched to laser time stamps within a tolerance, default 1e-4 s). The true
//!   ego-motion is the relation carried into the laser frames, `inverse(L₁) ∘
//!   relation ∘ L₂`, and the background's [`ClusterMotion`] is the ego-motion. The
//!   returns get no labels: nobody annotated what moved in these logs, and labelling
//!   every return static would let a clustering evaluation score a guess (`pgm eval
//!   clustering` refuses such pairs; issue 16, kind 10).
//! - [`consecutive_pairs`] (intel-lab): consecutive laser scans that both follow a
//!   `VERTEX2` pose; true ego-motion `inverse(V_i ∘ L_i) ∘ (V_{i+1} ∘ L_{i+1})`, no
//!   labels, as above. A log without any `VERTEX2` line (a plain CARMEN log such as
//!   mit-csail's) gives its consecutive laser scans without ground truth (the odometry
//!   prior only), to run a model on or to track (`pgm track --log`); a scan without a
//!   valid return is left out (its neighbours are paired across it). In the FLIRT logs the robot pose of each ROBOTLASER1 line *is*
//!   the corrected vertex pose, so it is not an independent odometry: when more than
//!   half of the scans have odometry equal to their vertex pose (within 1e-6; in
//!   intel-lab all but the first, whose vertex is rounded), the builder removes the
//!   odometry from the scans and gives no odometry prior, so no method can read the
//!   ground truth through it ([`ConsecutivePairs::odometry_was_ground_truth`]).
//! - [`leigh_pairs`] (leigh-gtm1): pairs of scans `k` indices apart, labels from the
//!   annotated people (rule below). A `k` larger than the span of the log's scan
//!   indices is an error (`i + k` is never allowed to wrap).
//! - [`carmen_scan_pair`], [`leigh_scan_pair`]: two chosen scans of a log, without
//!   ground truth, to run a model on (`pgm cluster`); a scan that does not exist or has
//!   no valid return is an [`Error::Scan`] naming the file, its line and its index, so a
//!   model never meets it anonymously.
//!
//! In every builder the odometry prior is the motion of the laser between the scans
//! as the odometry sees it, `inverse(odo_i ∘ L) ∘ (odo_j ∘ L)`, in the reference
//! laser frame; pairs are built without it when a scan has no odometry.
//!
//! # leigh-gtm1 pairs and labels
//!
//! **Which pairs.** For every annotated scan `i` (at least one `PERSON` line) such that
//! scan `j = i + k` exists and is annotated too, one pair (reference `i`, current `j`).
//! Scans without annotations are not "scans without people" — most of the log was
//! never annotated — so a pair is only built when both scans are annotated and the
//! labels mean something. With the published annotations (123 annotated scans in
//! 133–404) that gives 106 pairs at `k = 1`.
//!
//! **Which people move: the track rule** ([`LabelRule::Track`], the default; the data
//! README's rule). Every annotated centre is carried into the odometry frame (odometry
//! ∘ laser offset). For each person annotated in scan `j`, a straight line is fitted
//! by least squares, against the scan index, to that person's centres in the scans
//! from `i − w` to `j + w` ([`LeighPairOptions::track_window`] `w`, default 10;
//! [`track_fit`]); the person *walks* when the line's speed — its slope over the log's
//! scan period ([`scan_period`], the median time between consecutive scans, 0.1332 s in
//! leigh-gtm1) — is at least [`LeighPairOptions::walking_speed`] (default 0.5 m/s). A
//! person with fewer than two annotations in the window is not judged walking.
//! Single annotations jitter by up to about 0.5 m, so the line, not two centres, says
//! who walks: five people walk (0.6-1.6 m/s) and the others stand (under 0.45 m/s);
//! pairs with a walker: 33 of 106 at `k = 1`, 30 of 97 at `k = 3`, 26 of 92 at `k = 5`.
//! The rule needs odometry (a walking speed of 0 makes every person annotated in `j`
//! a mover and needs none). A walker's true motion comes from its line: the prior's
//! rotation and the line's displacement over `j − i` scans carried into the reference
//! frame (it agrees with the annotated centres to a median of 0.2 m).
//!
//! **The displacement rule** ([`LabelRule::Displacement`], the rule before issue 18).
//! A person annotated in both scans moved by the distance
//! between its centre in scan `j` and its centre in scan `i` carried into scan `j`'s
//! laser frame by the odometry prior. The person is *moving* when that distance is at
//! least [`LeighPairOptions::moving_threshold`] (default 0.2 m). A person annotated
//! in scan `j` but not in scan `i` has no measured displacement;
//! [`LeighPairOptions::unannotated`] decides ([`Unannotated::Moving`] by default). The
//! annotations are sparse: many scans annotate one of two people present, so at
//! `k = 5` 48 of the 92 pairs have a person annotated in `j` only. Those people are
//! nearly all walking: carried by the odometry from the nearest scan where the same
//! person is annotated and scaled to five scans, 28 of the 31 such cases moved at
//! least 0.2 m. Counting them as moving gives 46 of 92 pairs with a moving person
//! (the data README's "roughly half", and the figure the baselines' reference scores
//! were measured on); counting them as standing ([`Unannotated::Static`]) gives 23.
//! A person annotated in scan `i` only has no returns to label in scan `j`. With a
//! threshold of 0 every person annotated in scan `j` is its own cluster, whether
//! annotated in scan `i` or not, and no odometry is needed; a positive threshold
//! needs odometry (the builder returns [`Error::Mismatch`] without it).
//!
//! **Labels.** Moving people get labels 1, 2, … in increasing `person_id`. A return
//! of scan `j` within [`LeighPairOptions::person_radius`] (default 0.35 m) of the
//! annotated centre of a moving person in scan `j` gets that person's label (the
//! nearest centre if several are that close); every other valid return is
//! background 0, standing people included. Reference labels are built the same way
//! from scan `i` and the centres annotated there.
//!
//! **Motions** (displacement rule; the track rule's are above). For each moving person
//! annotated in both scans, a [`ClusterMotion`]
//! (kind `"person <id>"`) that maps the current frame onto the reference frame: the
//! rotation of the odometry prior (a centre carries no orientation) and the
//! translation that takes the centre in `j` onto the centre in `i`. The ego-motion is
//! not ground truth here (odometry is only a prior), so `truth.ego_motion` is `None`
//! and no background motion is given.

use crate::carmen::CarmenLog;
use crate::error::{Error, Result};
use crate::leigh::{IndexedScan, LeighScans, PersonAnnotation};
use crate::pair::{ClusterMotion, GroundTruth, ScanPair};
use crate::relations::Relation;
use crate::tracking_truth::returns_near;
use nalgebra::Point2;
use pgm_scan::{ObjectCentre, Pose2, Scan};
use std::collections::BTreeMap;
use std::path::Path;

/// The odometry prior `inverse(odo_ref ∘ L_ref) ∘ (odo_cur ∘ L_cur)` when both scans
/// have odometry.
pub fn odometry_prior(reference: &Scan, current: &Scan) -> Option<Pose2> {
    Some(
        reference
            .laser_odometry()?
            .between(&current.laser_odometry()?),
    )
}

fn ego_motion_pair(name: String, reference: Scan, current: Scan, ego_motion: Pose2) -> ScanPair {
    let truth = GroundTruth {
        ego_motion: Some(ego_motion),
        labels: None,
        reference_labels: None,
        associations: None,
        motions: vec![ClusterMotion {
            label: 0,
            motion: ego_motion,
            kind: "background".into(),
        }],
        objects: None,
    };
    ScanPair {
        name,
        odometry: odometry_prior(&reference, &current),
        reference,
        current,
        truth: Some(truth),
    }
}

/// Checks that scan `index` of the log at `path` (on `line`) has a valid return.
fn require_returns(path: &Path, line: usize, index: usize, scan: &Scan) -> Result<()> {
    if scan.valid_count() == 0 {
        return Err(Error::Scan {
            path: path.to_path_buf(),
            line,
            scan: index,
            problem: format!(
                "no valid return among its {} beams (all without a return or beyond the \
                 maximum range {} m)",
                scan.len(),
                scan.max_range
            ),
        });
    }
    Ok(())
}

/// The pair of scans `i` (reference) and `j` (current) of a log, without ground truth,
/// named `<name>:<i>-<j>`, with the odometry prior of the two scans.
fn log_pair(name: &str, i: usize, j: usize, a: &Scan, b: &Scan) -> ScanPair {
    ScanPair {
        name: format!("{name}:{i}-{j}"),
        odometry: odometry_prior(a, b),
        reference: a.clone(),
        current: b.clone(),
        truth: None,
    }
}

/// The pair of laser scans `i` (reference) and `j` (current) of a CARMEN log read from
/// `path` (FLASER / ROBOTLASER1 lines counted from 0), for running a model on: no
/// ground truth, the odometry prior from the poses on the two lines, named
/// `<file stem>:<i>-<j>`. A missing scan or one without any valid return is an
/// [`Error::Scan`] naming the file, the line and the scan index; so is `i == j` (the
/// two scans of a pair must differ).
pub fn carmen_scan_pair(path: &Path, log: &CarmenLog, i: usize, j: usize) -> Result<ScanPair> {
    distinct_scans(path, i, j)?;
    let get = |k: usize| {
        let s = log.scans.get(k).ok_or_else(|| Error::Scan {
            path: path.to_path_buf(),
            line: 0,
            scan: k,
            problem: format!(
                "no such laser scan (the log has {} FLASER / ROBOTLASER1 lines, counted from 0)",
                log.scans.len()
            ),
        })?;
        require_returns(path, s.line, k, &s.scan)?;
        Ok::<_, Error>(&s.scan)
    };
    let (a, b) = (get(i)?, get(j)?);
    Ok(log_pair(&file_stem(path), i, j, a, b))
}

/// The pair of scans with indices `i` (reference) and `j` (current) of a leigh-gtm1
/// style scan log read from `path`, as [`carmen_scan_pair`] (odometry prior when the
/// scans carry odometry).
pub fn leigh_scan_pair(path: &Path, scans: &LeighScans, i: usize, j: usize) -> Result<ScanPair> {
    distinct_scans(path, i, j)?;
    let get = |k: usize| {
        let s = scans.get(k).ok_or_else(|| Error::Scan {
            path: path.to_path_buf(),
            line: 0,
            scan: k,
            problem: match (scans.scans.first(), scans.scans.last()) {
                (Some(first), Some(last)) => format!(
                    "no scan with this index in the log (its {} scans have indices {}..={})",
                    scans.scans.len(),
                    first.index,
                    last.index
                ),
                _ => "no scan with this index: the log has no scan".into(),
            },
        })?;
        require_returns(path, s.line, k, &s.scan)?;
        Ok::<_, Error>(&s.scan)
    };
    let (a, b) = (get(i)?, get(j)?);
    Ok(log_pair(&file_stem(path), i, j, a, b))
}

/// The one-pair builders refuse a scan paired with itself, as the pair builders refuse
/// `k = 0`: the two scans of a pair must differ.
pub(crate) fn distinct_scans(path: &Path, i: usize, j: usize) -> Result<()> {
    if i == j {
        return Err(Error::Scan {
            path: path.to_path_buf(),
            line: 0,
            scan: i,
            problem: "reference and current are the same scan: the two scans of a pair must differ"
                .into(),
        });
    }
    Ok(())
}

fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "log".into(), |s| s.to_string_lossy().into_owned())
}

/// Options of [`relation_pairs`].
#[derive(Clone, Debug, PartialEq)]
pub struct RelationPairOptions {
    /// Largest accepted difference between a relation's time stamp and a scan's (s).
    pub tolerance: f64,
    /// Prefix of the pair names (`<prefix>:<t1>-<t2>`).
    pub name: String,
}

impl Default for RelationPairOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-4,
            name: "relations".into(),
        }
    }
}

/// The result of [`relation_pairs`].
#[derive(Clone, Debug, PartialEq)]
pub struct RelationPairs {
    /// One pair per relation whose two time stamps both matched a scan.
    pub pairs: Vec<ScanPair>,
    /// Relations for which a time stamp matched no scan.
    pub unmatched: Vec<Relation>,
}

/// Builds one pair per relation (see the module docs).
pub fn relation_pairs(
    log: &CarmenLog,
    relations: &[Relation],
    options: &RelationPairOptions,
) -> RelationPairs {
    let mut by_time: Vec<(f64, usize)> = log
        .scans
        .iter()
        .enumerate()
        .map(|(k, s)| (s.scan.timestamp, k))
        .collect();
    by_time.sort_by(|a, b| a.0.total_cmp(&b.0));
    let find = |t: f64| -> Option<usize> {
        let at = by_time.partition_point(|(ts, _)| *ts < t);
        [at.checked_sub(1), Some(at)]
            .into_iter()
            .flatten()
            .filter_map(|k| by_time.get(k))
            .filter(|(ts, _)| (ts - t).abs() <= options.tolerance)
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
            .map(|(_, k)| *k)
    };
    let mut out = RelationPairs {
        pairs: Vec::new(),
        unmatched: Vec::new(),
    };
    for r in relations {
        let (Some(a), Some(b)) = (find(r.t1), find(r.t2)) else {
            out.unmatched.push(*r);
            continue;
        };
        let reference = log.scans[a].scan.clone();
        let current = log.scans[b].scan.clone();
        let ego = reference
            .laser_offset
            .inverse()
            .compose(&r.motion)
            .compose(&current.laser_offset);
        let name = format!("{}:{:.5}-{:.5}", options.name, r.t1, r.t2);
        out.pairs
            .push(ego_motion_pair(name, reference, current, ego));
    }
    out
}

/// The result of [`consecutive_pairs`].
#[derive(Clone, Debug, PartialEq)]
pub struct ConsecutivePairs {
    /// One pair per two consecutive scans with vertex poses.
    pub pairs: Vec<ScanPair>,
    /// True when the log's odometry equalled the vertex poses and was removed.
    pub odometry_was_ground_truth: bool,
    /// True when the log has no `VERTEX2` line: the pairs have no ground truth.
    pub without_ground_truth: bool,
    /// Laser scans left out for having no valid return (log without `VERTEX2` lines).
    pub empty_scans: usize,
}

/// Builds pairs of consecutive scans with `VERTEX2` poses (see the module docs).
pub fn consecutive_pairs(log: &CarmenLog, name: &str) -> ConsecutivePairs {
    if log.vertices.is_empty() {
        // A plain log: consecutive scans with returns, no ground truth.
        let seen: Vec<(usize, &Scan)> = log
            .scans
            .iter()
            .enumerate()
            .filter(|(_, s)| s.scan.valid_count() > 0)
            .map(|(i, s)| (i, &s.scan))
            .collect();
        return ConsecutivePairs {
            pairs: seen
                .windows(2)
                .map(|w| log_pair(name, w[0].0, w[1].0, w[0].1, w[1].1))
                .collect(),
            odometry_was_ground_truth: false,
            without_ground_truth: true,
            empty_scans: log.scans.len() - seen.len(),
        };
    }
    let with_pose: Vec<_> = log
        .scans
        .iter()
        .filter_map(|s| s.vertex.map(|v| (s, v)))
        .collect();
    let same = |a: &Pose2, b: &Pose2| a.translation_error(b) < 1e-6 && a.rotation_error(b) < 1e-6;
    let equal = with_pose
        .iter()
        .filter(|(s, v)| s.scan.odometry.is_some_and(|o| same(&o, &v.pose)))
        .count();
    let odometry_was_ground_truth = 2 * equal > with_pose.len();
    let mut pairs = Vec::new();
    for w in with_pose.windows(2) {
        let ((a, va), (b, vb)) = (w[0], w[1]);
        let mut reference = a.scan.clone();
        let mut current = b.scan.clone();
        let ego = va
            .pose
            .compose(&reference.laser_offset)
            .between(&vb.pose.compose(&current.laser_offset));
        if odometry_was_ground_truth {
            reference.odometry = None;
            current.odometry = None;
        }
        let pair_name = format!("{name}:{}-{}", va.id, vb.id);
        pairs.push(ego_motion_pair(pair_name, reference, current, ego));
    }
    ConsecutivePairs {
        pairs,
        odometry_was_ground_truth,
        without_ground_truth: false,
        empty_scans: 0,
    }
}

/// Options of [`leigh_pairs`].
#[derive(Clone, Debug, PartialEq)]
pub struct LeighPairOptions {
    /// Distance between the two scans of a pair, in scan indices (≥ 1).
    pub k: usize,
    /// Smallest displacement (m) for a person to count as moving; 0 makes every
    /// annotated person its own cluster.
    pub moving_threshold: f64,
    /// Returns within this distance (m) of an annotated centre belong to the person.
    pub person_radius: f64,
    /// What a person annotated in the current scan but not in the reference scan is.
    pub unannotated: Unannotated,
    /// Score only the annotated sector: returns whose bearing lies outside the
    /// bearings of all annotated centres (over the whole log, each widened by the
    /// person radius) get no label (`None`) instead of background (module docs).
    pub annotated_sector: bool,
    /// Prefix of the pair names (`<prefix>:<i>-<j>`).
    pub name: String,
    /// How to decide who moves: the track rule of the data README (default) or the
    /// older displacement rule (module docs).
    pub rule: LabelRule,
    /// Track rule: smallest speed (m/s) of the line fitted to a person's track for the
    /// person to walk; 0 makes every annotated person its own cluster.
    pub walking_speed: f64,
    /// Track rule: the line is fitted to the annotations from scan `i − track_window`
    /// to scan `j + track_window`.
    pub track_window: usize,
}

/// Which rule decides whether an annotated person moves ([`leigh_pairs`], module
/// docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LabelRule {
    /// The data README's rule: the speed of a straight line fitted (least squares,
    /// against the scan index) to the person's annotated centres in the odometry frame
    /// over scans `i − w … j + w`.
    #[default]
    Track,
    /// The older rule: the displacement between the two annotated centres of the pair
    /// (a person missing from the reference scan per [`Unannotated`]).
    Displacement,
}

/// Implements `Display` (the name) and `FromStr` (from the name) for a fieldless enum
/// given each variant's name; another string is the error
/// `unknown <what> "<string>": expected <expected>`.
macro_rules! named_variants {
    ($ty:ident, $what:literal, $expected:literal, { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(match self {
                    $($ty::$variant => $name,)+
                })
            }
        }

        impl std::str::FromStr for $ty {
            type Err = String;
            fn from_str(s: &str) -> std::result::Result<Self, String> {
                match s {
                    $($name => Ok($ty::$variant),)+
                    other => Err(format!(
                        concat!("unknown ", $what, " {:?}: expected ", $expected),
                        other
                    )),
                }
            }
        }
    };
}

named_variants!(LabelRule, "labelling rule", "track or displacement", {
    Track => "track",
    Displacement => "displacement",
});

impl Default for LeighPairOptions {
    fn default() -> Self {
        Self {
            rule: LabelRule::Track,
            walking_speed: 0.5,
            track_window: 10,
            k: 5,
            moving_threshold: 0.2,
            person_radius: 0.35,
            unannotated: Unannotated::Moving,
            annotated_sector: false,
            name: "leigh-gtm1".into(),
        }
    }
}

/// How [`leigh_pairs`] labels a person annotated in the current scan of a pair but not
/// in its reference scan, whose displacement is therefore unknown (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Unannotated {
    /// The person is a moving object of its own (default; the data README's count).
    #[default]
    Moving,
    /// The person is background, like a person who stood still.
    Static,
}

named_variants!(Unannotated, "policy for unannotated people", "moving or static", {
    Moving => "moving",
    Static => "static",
});

/// The bearings `[min, max]` (rad, laser frame) covered by the annotated centres,
/// each widened by the angle `person_radius` subtends at its range.
pub fn annotated_sector(people: &[PersonAnnotation], person_radius: f64) -> Option<[f64; 2]> {
    people
        .iter()
        .filter(|a| a.centre.coords.norm() > 0.0)
        .map(|a| {
            let r = a.centre.coords.norm();
            let b = a.centre.y.atan2(a.centre.x);
            let w = (person_radius / r).min(1.0).asin();
            [b - w, b + w]
        })
        .reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])])
}

fn label_returns(
    scan: &Scan,
    centres: &[(u32, Point2<f64>)],
    radius: f64,
    sector: Option<[f64; 2]>,
) -> Vec<Option<u32>> {
    let r2 = radius * radius;
    (0..scan.len())
        .map(|k| {
            if !scan.valid[k] {
                return None;
            }
            if let Some([lo, hi]) = sector {
                let a = scan.angles[k];
                if a < lo || a > hi {
                    return None;
                }
            }
            let p = scan.beam_point(k);
            let nearest = centres
                .iter()
                .map(|(label, c)| (*label, (p - c).norm_squared()))
                .filter(|(_, d2)| *d2 <= r2)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            Some(nearest.map_or(0, |(label, _)| label))
        })
        .collect()
}

/// Builds leigh-gtm1 pairs `k` scans apart with motion labels (see the module docs).
/// The scans' odometry (if any) must already be attached
/// ([`crate::leigh::attach_odometry`]).
pub fn leigh_pairs(
    scans: &LeighScans,
    people: &[PersonAnnotation],
    options: &LeighPairOptions,
) -> Result<Vec<ScanPair>> {
    if options.k == 0 {
        return Err(Error::Mismatch {
            what: "k = 0: the two scans of a pair must differ".into(),
        });
    }
    if !(options.moving_threshold >= 0.0 && options.moving_threshold.is_finite()) {
        return Err(Error::Mismatch {
            what: format!(
                "moving threshold {:?} must be finite and >= 0",
                options.moving_threshold
            ),
        });
    }
    if !(options.person_radius > 0.0 && options.person_radius.is_finite()) {
        return Err(Error::Mismatch {
            what: format!(
                "person radius {:?} must be positive and finite",
                options.person_radius
            ),
        });
    }
    if !(options.walking_speed >= 0.0 && options.walking_speed.is_finite()) {
        return Err(Error::Mismatch {
            what: format!(
                "walking speed {:?} must be finite and >= 0",
                options.walking_speed
            ),
        });
    }

    let mut by_scan: BTreeMap<usize, BTreeMap<u32, Point2<f64>>> = BTreeMap::new();
    for a in people {
        by_scan
            .entry(a.scan)
            .or_default()
            .insert(a.person, a.centre);
    }
    let sector = if options.annotated_sector {
        annotated_sector(people, options.person_radius)
    } else {
        None
    };
    if let (Some(first), Some(last)) = (scans.scans.first(), scans.scans.last()) {
        let span = last.index.saturating_sub(first.index);
        if options.k > span {
            return Err(Error::Mismatch {
                what: format!(
                    "k = {}: no two scans of the log are that far apart (scan indices {}..={}, \
                     lines {} and {})",
                    options.k, first.index, last.index, first.line, last.line
                ),
            });
        }
    }
    let tracks = match options.rule {
        LabelRule::Track if options.walking_speed > 0.0 => Some(Tracks {
            world: leigh_annotations_in_odometry_frame(scans, people).map_err(|e| {
                Error::Mismatch {
                    what: format!(
                        "{e}; the track rule needs odometry (or a walking speed of 0, \
                         which makes every annotated person a mover)"
                    ),
                }
            })?,
            period: scan_period(scans),
            window: options.track_window,
        }),
        _ => None,
    };
    let mut pairs = Vec::new();
    for (&i, people_i) in &by_scan {
        let Some(j) = i.checked_add(options.k) else {
            continue;
        };
        let Some(people_j) = by_scan.get(&j) else {
            continue;
        };
        let (Some(ref_scan), Some(cur_scan)) = (scans.get(i), scans.get(j)) else {
            continue;
        };
        let input = PairInput {
            reference: ref_scan,
            current: cur_scan,
            people_i,
            people_j,
            options,
            sector,
        };
        pairs.push(leigh_pair(&input, tracks.as_ref())?);
    }
    Ok(pairs)
}

/// One pair to label: its two scans, the people annotated in each (person → centre),
/// the options and the annotated sector.
struct PairInput<'a> {
    reference: &'a IndexedScan,
    current: &'a IndexedScan,
    people_i: &'a BTreeMap<u32, Point2<f64>>,
    people_j: &'a BTreeMap<u32, Point2<f64>>,
    options: &'a LeighPairOptions,
    sector: Option<[f64; 2]>,
}

fn leigh_pair(input: &PairInput<'_>, tracks: Option<&Tracks>) -> Result<ScanPair> {
    if let Some(tracks) = tracks {
        return track_pair(input, tracks);
    }
    let (reference, current, options) = (input.reference, input.current, input.options);
    let prior = odometry_prior(&reference.scan, &current.scan);
    if prior.is_none() && options.moving_threshold > 0.0 && options.rule == LabelRule::Displacement
    {
        return Err(Error::Mismatch {
            what: format!(
                "scans {} and {}: deciding who moves by at least {} m needs odometry to carry \
                 person centres between the two laser frames; give the odometry or use a \
                 moving threshold of 0",
                reference.index, current.index, options.moving_threshold
            ),
        });
    }
    let mut labels = PairLabels::default();
    for (&person, &c_j) in input.people_j {
        let c_i = input.people_i.get(&person).copied();
        let displacement = match (c_i, prior) {
            (Some(c_i), Some(prior)) => {
                let carried = prior.inverse().transform_point(&c_i);
                Some((c_j - carried).norm())
            }
            _ => None,
        };
        let every_person = match options.rule {
            LabelRule::Displacement => options.moving_threshold <= 0.0,
            LabelRule::Track => true,
        };
        let moving = every_person
            || match (c_i, displacement) {
                (None, _) => options.unannotated == Unannotated::Moving,
                (Some(_), d) => d.is_some_and(|d| d >= options.moving_threshold),
            };
        labels.object(
            person,
            c_j,
            (!every_person).then_some(moving),
            &current.scan,
            options,
        );
        if !moving {
            continue;
        }
        let label = labels.mover(c_i, c_j);
        if let (Some(c_i), Some(prior)) = (c_i, prior) {
            // m(c_j) = c_i with the rotation of the prior: T = c_i − R c_j.
            let rotated = prior.transform_point(&c_j) - prior.translation();
            labels.motion(label, person, c_i - rotated, &prior);
        }
    }
    Ok(labels.into_pair(input, prior))
}

/// The ground truth of one leigh-gtm1 pair as it is gathered person by person: the
/// current scan's tracking truth `objects`, the centres of the moving people in each
/// scan under the labels they are given (1, 2, … in order) and their motions.
#[derive(Default)]
struct PairLabels {
    centres_i: Vec<(u32, Point2<f64>)>,
    centres_j: Vec<(u32, Point2<f64>)>,
    motions: Vec<ClusterMotion>,
    objects: Vec<ObjectCentre>,
    next_label: u32,
}

impl PairLabels {
    /// Records `person`, annotated at `c_j` in the `current` scan, as a tracking-truth
    /// object (`moving` as decided, if it was).
    fn object(
        &mut self,
        person: u32,
        c_j: Point2<f64>,
        moving: Option<bool>,
        current: &Scan,
        options: &LeighPairOptions,
    ) {
        self.objects.push(ObjectCentre {
            id: u64::from(person),
            x: c_j.x,
            y: c_j.y,
            moving,
            returns: Some(returns_near(current, &c_j, options.person_radius)),
        });
    }

    /// Gives a moving person, at `c_j` in the current scan (and `c_i` in the
    /// reference scan if annotated there), the next label and returns it.
    fn mover(&mut self, c_i: Option<Point2<f64>>, c_j: Point2<f64>) -> u32 {
        self.next_label += 1;
        let label = self.next_label;
        self.centres_j.push((label, c_j));
        if let Some(c_i) = c_i {
            self.centres_i.push((label, c_i));
        }
        label
    }

    /// Records the motion of the cluster `label` (`person`): the translation `t` with
    /// the rotation of the odometry `prior`.
    fn motion(&mut self, label: u32, person: u32, t: nalgebra::Vector2<f64>, prior: &Pose2) {
        self.motions.push(ClusterMotion {
            label,
            motion: Pose2::new(t.x, t.y, prior.theta()),
            kind: format!("person {person}"),
        });
    }

    /// The pair of the two scans of `input` with the odometry `prior`, every return of
    /// both scans labelled by the nearest moving person's centre of its scan within the
    /// person radius (0 elsewhere, unlabelled outside the annotated sector), with the
    /// people's motions and the current scan's tracking truth objects.
    fn into_pair(self, input: &PairInput<'_>, prior: Option<Pose2>) -> ScanPair {
        let (reference, current, options) = (input.reference, input.current, input.options);
        let sector = input.sector;
        let truth = GroundTruth {
            ego_motion: None,
            labels: Some(label_returns(
                &current.scan,
                &self.centres_j,
                options.person_radius,
                sector,
            )),
            reference_labels: Some(label_returns(
                &reference.scan,
                &self.centres_i,
                options.person_radius,
                sector,
            )),
            associations: None,
            motions: self.motions,
            objects: Some(self.objects),
        };
        ScanPair {
            name: format!("{}:{}-{}", options.name, reference.index, current.index),
            reference: reference.scan.clone(),
            current: current.scan.clone(),
            odometry: prior,
            truth: Some(truth),
        }
    }
}

/// What the track rule needs: every annotation in the odometry frame, the scan period
/// and the window.
struct Tracks {
    world: BTreeMap<usize, BTreeMap<u32, Point2<f64>>>,
    period: f64,
    window: usize,
}

/// The median time between consecutive scans (indices one apart) of a log, from their
/// time stamps; 1 s when no two consecutive scans have increasing stamps.
pub fn scan_period(scans: &LeighScans) -> f64 {
    let mut gaps: Vec<f64> = scans
        .scans
        .windows(2)
        .filter(|w| w[1].index == w[0].index + 1)
        .map(|w| w[1].scan.timestamp - w[0].scan.timestamp)
        .filter(|g| g.is_finite() && *g > 0.0)
        .collect();
    if gaps.is_empty() {
        return 1.0;
    }
    gaps.sort_by(f64::total_cmp);
    let n = gaps.len();
    if n % 2 == 1 {
        gaps[n / 2]
    } else {
        (gaps[n / 2 - 1] + gaps[n / 2]) / 2.0
    }
}

/// A straight line fitted to a person's track ([`track_fit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackFit {
    /// Number of annotations fitted.
    pub annotations: usize,
    /// Velocity in the odometry frame, metres per scan.
    pub per_scan: nalgebra::Vector2<f64>,
    /// Speed in m/s (the velocity over the scan period).
    pub speed: f64,
}

/// The least-squares line through `person`'s annotated centres (odometry frame,
/// against the scan index) over scans `lo..=hi`; `None` with fewer than two
/// annotations there.
pub fn track_fit(
    world: &BTreeMap<usize, BTreeMap<u32, Point2<f64>>>,
    person: u32,
    lo: usize,
    hi: usize,
    period: f64,
) -> Option<TrackFit> {
    let points: Vec<(f64, Point2<f64>)> = world
        .range(lo..=hi)
        .filter_map(|(&s, at)| at.get(&person).map(|p| (s as f64, *p)))
        .collect();
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let mean_t = points.iter().map(|(t, _)| t).sum::<f64>() / n;
    let mean_p = points
        .iter()
        .fold(nalgebra::Vector2::zeros(), |acc, (_, p)| acc + p.coords)
        / n;
    let stt: f64 = points.iter().map(|(t, _)| (t - mean_t).powi(2)).sum();
    let stp = points
        .iter()
        .fold(nalgebra::Vector2::zeros(), |acc, (t, p)| {
            acc + (p.coords - mean_p) * (t - mean_t)
        });
    let per_scan = stp / stt;
    Some(TrackFit {
        annotations: points.len(),
        per_scan,
        speed: per_scan.norm() / period,
    })
}

fn track_pair(input: &PairInput<'_>, tracks: &Tracks) -> Result<ScanPair> {
    let (reference, current, options) = (input.reference, input.current, input.options);
    let (i, j) = (reference.index, current.index);
    let (Some(w_i), Some(prior)) = (
        reference.scan.laser_odometry(),
        odometry_prior(&reference.scan, &current.scan),
    ) else {
        return Err(Error::Mismatch {
            what: format!(
                "scans {i} and {j}: the track rule needs odometry to carry person centres \
                 into the odometry frame"
            ),
        });
    };
    let lo = i.saturating_sub(tracks.window);
    let hi = j.saturating_add(tracks.window);
    let mut labels = PairLabels::default();
    for (&person, &c_j) in input.people_j {
        let fit = track_fit(&tracks.world, person, lo, hi, tracks.period);
        labels.object(
            person,
            c_j,
            fit.map(|f| f.speed >= options.walking_speed),
            &current.scan,
            options,
        );
        let Some(fit) = fit else {
            continue;
        };
        if fit.speed < options.walking_speed {
            continue;
        }
        let label = labels.mover(input.people_i.get(&person).copied(), c_j);
        // The person moved d = v (j − i) in the odometry frame; a current point p was at
        // W_j p − d at scan i: the motion is the prior followed by −R_i⁻¹ d.
        let d = fit.per_scan * (j - i) as f64;
        let back = w_i.inverse().transform_point(&Point2::from(-d)) - w_i.inverse().translation();
        labels.motion(label, person, prior.translation() + back.coords, &prior);
    }
    Ok(labels.into_pair(input, Some(prior)))
}

/// One annotated person's whole track in the odometry frame
/// ([`leigh_track_displacements`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TrackDisplacement {
    /// Number of scans the person is annotated in.
    pub annotations: usize,
    /// First and last scan index of the track.
    pub scans: [usize; 2],
    /// Straight-line distance (m) from the first to the last annotated position, per
    /// `k` scans: about the walking speed for someone who walks, a few centimetres for
    /// someone who stands whatever their annotated centre does from scan to scan.
    pub per_k_scans: f64,
}

/// Every annotated centre carried into the odometry frame (odometry ∘ laser offset):
/// scan index → person → position. Needs the scans' odometry
/// ([`crate::leigh::attach_odometry`]); an annotation on a scan without it is an error
/// naming the person, the scan and the line.
pub fn leigh_annotations_in_odometry_frame(
    scans: &LeighScans,
    people: &[PersonAnnotation],
) -> Result<BTreeMap<usize, BTreeMap<u32, Point2<f64>>>> {
    let mut world: BTreeMap<usize, BTreeMap<u32, Point2<f64>>> = BTreeMap::new();
    for a in people {
        let pose = scans
            .get(a.scan)
            .and_then(|s| s.scan.laser_odometry())
            .ok_or_else(|| Error::Mismatch {
                what: format!(
                    "person {} annotated in scan {} (people file line {}): that scan has no \
                     odometry, needed to carry the annotation into the odometry frame",
                    a.person, a.scan, a.line
                ),
            })?;
        world
            .entry(a.scan)
            .or_default()
            .insert(a.person, pose.transform_point(&a.centre));
    }
    Ok(world)
}

/// Each annotated person's net displacement per `k` scans over their whole track in
/// the odometry frame ([`leigh_annotations_in_odometry_frame`]). Tells people who
/// walk from people who stand although an annotation is missing in one scan or its
/// centre jitters by more than the moving threshold.
pub fn leigh_track_displacements(
    scans: &LeighScans,
    people: &[PersonAnnotation],
    k: usize,
) -> Result<BTreeMap<u32, TrackDisplacement>> {
    // Scans in increasing order, so each track comes out sorted.
    let mut tracks: BTreeMap<u32, Vec<(usize, Point2<f64>)>> = BTreeMap::new();
    for (scan, at) in leigh_annotations_in_odometry_frame(scans, people)? {
        for (person, position) in at {
            tracks.entry(person).or_default().push((scan, position));
        }
    }
    Ok(tracks
        .into_iter()
        .map(|(person, track)| {
            let (first, last) = (track[0], track[track.len() - 1]);
            let span = (last.0 - first.0).max(1) as f64;
            let summary = TrackDisplacement {
                annotations: track.len(),
                scans: [first.0, last.0],
                per_k_scans: (last.1 - first.1).norm() / span * k as f64,
            };
            (person, summary)
        })
        .collect())
}

/// Figures of a set of leigh-gtm1 pairs (the `pgm data summary` table).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LeighSummary {
    /// Scan distance of the pairs.
    pub k: usize,
    /// Number of pairs.
    pub pairs: usize,
    /// Mean number of valid returns per current scan (`None` without pairs: a mean of
    /// nothing).
    pub returns_per_scan: Option<f64>,
    /// Mean number of moving-person returns (label > 0) per pair (`None` without
    /// pairs).
    pub moving_returns_per_pair: Option<f64>,
    /// Number of pairs with at least one moving-person return.
    pub pairs_with_moving_person: usize,
    /// Number of moving people summed over pairs.
    pub moving_people: usize,
}

/// Summarises pairs built by [`leigh_pairs`] with scan distance `k`.
pub fn summarize_leigh_pairs(k: usize, pairs: &[ScanPair]) -> LeighSummary {
    let n = pairs.len();
    let mut returns = 0usize;
    let mut moving_returns = 0usize;
    let mut with_moving = 0usize;
    let mut moving_people = 0usize;
    for p in pairs {
        returns += p.current.valid_count();
        let labels = p.truth.as_ref().and_then(|t| t.labels.as_ref());
        let m = labels.map_or(0, |l| l.iter().filter(|x| x.is_some_and(|v| v > 0)).count());
        moving_returns += m;
        if m > 0 {
            with_moving += 1;
        }
        if let Some(l) = labels {
            let mut ids: Vec<u32> = l.iter().flatten().copied().filter(|v| *v > 0).collect();
            ids.sort_unstable();
            ids.dedup();
            moving_people += ids.len();
        }
    }
    let mean = |x: usize| (n > 0).then(|| x as f64 / n as f64);
    LeighSummary {
        k,
        pairs: n,
        returns_per_scan: mean(returns),
        moving_returns_per_pair: mean(moving_returns),
        pairs_with_moving_person: with_moving,
        moving_people,
    }
}
