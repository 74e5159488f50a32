//! Association sources: which reference return each current return corresponds to
//! (its correspondence), or that it is an outlier.
//!
//! CRF-Clustering takes the associations as an input (section IV-B of its paper: the
//! distance feature compares a current point, moved by its cluster's motion, with its
//! *associated* reference point). The paper runs it with the true, hand-made
//! associations (CRF-T) and with associations from CRF-Matching (CRF-M). A source is
//! anything implementing [`AssociationSource`]; the built-in ones:
//!
//! - [`GroundTruthAssociations`]: the pair's `truth.associations` (the simulator has
//!   them; real logs do not);
//! - [`NearestAfterIcp`]: point-to-point ICP ([`crate::registration`]) estimates the
//!   ego-motion from the odometry prior (the identity without odometry), then every
//!   current point, moved by that ego-motion, takes its nearest reference return
//!   within a gate ([`NearestParams::gate`]) as partner, or is an outlier. Static
//!   points then get a partner on the same surface, and points of an object that
//!   moved by less than the gate usually get a partner on the object's earlier
//!   position, so its motion shows in the distance feature. A point the reference
//!   scan cannot have seen is an outlier whatever its nearest neighbour: moved into
//!   the reference frame it lies outside the reference field of view, where the
//!   reference beams near its bearing have no return, or more than
//!   [`NearestParams::occlusion_margin`] behind the nearest of their returns (an
//!   occluded, newly revealed surface; [`Scan::sees`](crate::Scan::sees)). Without
//!   this check such surfaces take a far partner and look like moving objects.
//! - [`SegmentIcp`]: as above, but every segment of the current scan that does not
//!   fit the ego-motion and that the free-space test marks as moved is aligned by ICP
//!   on its own, so points of a car that moved metres find their partners on the car.
//!
//! CRF-Matching (learned associations) plugs in by implementing [`AssociationSource`]
//! in its own crate.
//!
//! **Points without a partner** (outliers, or `None` entries) carry no motion
//! evidence; how a model treats them is the model's choice.
//!
//! ```
//! use pgm_scan::association::{AssociationSource, NearestAfterIcp};
//! let source = NearestAfterIcp::default();
//! assert_eq!(source.name(), "icp");
//! ```

use crate::correlative::CorrelativeParams;
use crate::pair::{Association, ScanPair};
use crate::registration::{Icp, IcpParams};
use crate::scan::{segment_by_gap, segment_ranges};
use crate::{Error, Pose2, Result};
use nalgebra::Point2;
use pgm_core::param::{InvalidParameter, ParamGuard};
use rayon::prelude::*;

/// The associations of one pair and, when the source estimated one, its ego-motion.
#[derive(Clone, Debug, PartialEq)]
pub struct PointAssociations {
    /// One entry per beam of the current scan: `None` for beams without a return (or
    /// unknown), otherwise a reference beam or [`Association::Outlier`].
    pub associations: Vec<Option<Association>>,
    /// The ego-motion the source estimated on the way (ICP), if any.
    pub ego_motion: Option<Pose2>,
}

/// A source of point associations (correspondences) for scan pairs: where each return
/// of the current scan was in the reference scan, or that it is an outlier.
pub trait AssociationSource: Send + Sync {
    /// A short name for reports (`true`, `icp`, …), as typed on the command line.
    fn name(&self) -> &str;

    /// The associations of `pair`'s current scan into its reference scan. Errors name
    /// the pair.
    fn associate(&self, pair: &ScanPair) -> Result<PointAssociations>;
}

/// The pair's own ground-truth associations (the simulator has them; real logs do
/// not): an error naming the pair when it has none.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GroundTruthAssociations;

impl AssociationSource for GroundTruthAssociations {
    fn name(&self) -> &str {
        "true"
    }

    fn associate(&self, pair: &ScanPair) -> Result<PointAssociations> {
        let truth = pair
            .truth
            .as_ref()
            .and_then(|t| t.associations.clone())
            .ok_or_else(|| Error::BadPair {
                pair: pair.name.clone(),
                problem: "no ground-truth associations (use an automatic association source)"
                    .into(),
            })?;
        if truth.len() != pair.current.len() {
            return Err(Error::AssociationCount {
                pair: pair.name.clone(),
                associations: truth.len(),
                beams: pair.current.len(),
            });
        }
        Ok(PointAssociations {
            associations: truth,
            ego_motion: None,
        })
    }
}

/// Parameters of [`NearestAfterIcp`], unchecked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearestParams {
    /// ICP parameters for the ego-motion.
    pub icp: IcpParams,
    /// Largest distance (m) between a current point moved by the ego-motion and its
    /// nearest reference return for the two to be associated (default 1 m).
    pub gate: f64,
    /// How far (m) behind the reference returns near its bearing a point may lie and
    /// still count as seen by the reference scan (default 0.3 m).
    pub occlusion_margin: f64,
    /// Points hidden from the reference scan still take their nearest reference
    /// return when their gap segment (gap [`NearestParams::segment_gap`]) does not
    /// follow the ego-motion: fewer than half of its points lie within this distance
    /// (m) of a reference return. `None` (default): hidden points are always
    /// outliers. See [`NearestAfterIcp`]; on leigh-gtm1 (k = 5) `Some(0.1)` finds
    /// more walking people but more false movers too (mean V 0.408 → 0.331).
    pub static_tolerance: Option<f64>,
    /// Gap (m) between consecutive current points that separates segments for
    /// [`NearestParams::static_tolerance`] (default 0.5 m).
    pub segment_gap: f64,
}

impl Default for NearestParams {
    fn default() -> Self {
        Self {
            icp: IcpParams::default(),
            gate: 1.0,
            occlusion_margin: 0.3,
            static_tolerance: None,
            segment_gap: 0.5,
        }
    }
}

/// Parameters of [`SegmentIcp`], unchecked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentParams {
    /// The ego-motion ICP, the gate and the occlusion margin of the final
    /// nearest-neighbour step.
    pub nearest: NearestParams,
    /// Gap (m) between consecutive current points that starts a new segment (0.5).
    pub segment_gap: f64,
    /// Fewest points of a segment that gets its own alignment (3).
    pub min_points: usize,
    /// A point is an inlier of a motion when its nearest reference return lies within
    /// this distance (m) of it moved by the motion (0.2); costs truncate there.
    pub inlier_distance: f64,
    /// Segments with at least this fraction of inliers under the ego-motion keep it
    /// (0.8).
    pub static_fraction: f64,
    /// Reference segments whose centroid lies within this distance (m) of the
    /// segment's centroid moved by the ego-motion seed an alignment (8).
    pub search_radius: f64,
    /// A segment's own motion is accepted when its truncated cost is below this
    /// fraction of the cost under the ego-motion (0.5).
    pub improvement: f64,
    /// How far (m) in front of the reference returns a point moved by the ego-motion
    /// must lie to be in space the reference saw free (0.3).
    pub free_space_margin: f64,
    /// Fewest fraction of a segment's points in free space for it to be aligned on
    /// its own (0.2).
    pub free_space_fraction: f64,
    /// Fewest fraction of inliers under a segment's own motion for it to be accepted
    /// (0.5).
    pub aligned_fraction: f64,
    /// The final gate (m) is this plus twice the point's beam spacing (range times
    /// the angle increment), at most [`NearestParams::gate`] (1; 0.3 was measured
    /// worse on simulated pairs: V 0.71 against 0.74).
    pub association_gate: f64,
    /// The ego-motion ICP also runs from the prior with this first correspondence
    /// distance (m), and the run with more inliers at the final distance wins
    /// ([`Icp::align_best`], which gives the measurement: objects moving with the
    /// sensor pull a wide schedule off the static scene) (0.3; 0 turns it off).
    pub tight_ego_distance: f64,
    /// A correlative search for the ego-motion within a window around the prior
    /// ([`crate::correlative`]; default: ±1 m, ±30°), whose best motion starts one
    /// more ICP run; `None`: ICP from the prior only. With it the ego-motion survives
    /// a prior that is off by up to the window (see the `bad_start` example).
    pub global_search: Option<CorrelativeParams>,
}

impl Default for SegmentParams {
    fn default() -> Self {
        Self {
            nearest: NearestParams::default(),
            segment_gap: 0.5,
            min_points: 3,
            inlier_distance: 0.2,
            static_fraction: 0.8,
            search_radius: 8.0,
            improvement: 0.5,
            free_space_margin: 0.3,
            free_space_fraction: 0.2,
            aligned_fraction: 0.5,
            association_gate: 1.0,
            tight_ego_distance: 0.3,
            global_search: Some(CorrelativeParams::default()),
        }
    }
}

impl NearestParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        self.icp.check_ref()?;
        InvalidParameter::non_negative(
            "occlusion_margin",
            self.occlusion_margin,
            "a number of metres >= 0",
        )?;
        if let Some(t) = self.static_tolerance {
            InvalidParameter::non_negative("static_tolerance", t, "a number of metres >= 0")?;
        }
        InvalidParameter::positive(
            "segment_gap",
            self.segment_gap,
            "a positive number of metres",
        )?;
        InvalidParameter::positive("gate", self.gate, "a positive number of metres")?;
        Ok(())
    }
}

pgm_core::checked_params! {
    /// Nearest reference return within a gate after ICP (see also the module docs).
    ///
    /// ICP from the odometry prior (identity without) gives the ego-motion; each current
    /// point moved by it takes its nearest reference return within
    /// [`NearestParams::gate`]. A point the reference scan cannot have seen ([`Scan::sees`](crate::Scan::sees):
    /// outside its field of view, no return near its bearing, or more than
    /// [`NearestParams::occlusion_margin`] behind the returns there) is an outlier —
    /// typically background revealed behind an object that moved, whose nearest return
    /// is the object's old position — unless its gap segment as a whole does not follow
    /// the ego-motion ([`NearestParams::static_tolerance`]). That case is an object that
    /// moved away along the beams, a person walking away from the robot: its points lie
    /// behind where the reference saw it, and the nearest reference return is that old
    /// position, the right partner, provided the current scan sees through that old
    /// position (the object left it; [`Scan::in_free_space`](crate::Scan::in_free_space)). Revealed background belongs to a
    /// surface whose other points fit the ego-motion, or lies behind an occluder that is
    /// still there.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct NearestAfterIcp(NearestParams) -> Error;
}

impl AssociationSource for NearestAfterIcp {
    fn name(&self) -> &str {
        "icp"
    }

    fn associate(&self, pair: &ScanPair) -> Result<PointAssociations> {
        nearest_after_icp(pair, &self.params).map_err(|e| e.in_pair(&pair.name))
    }
}

impl SegmentParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        self.nearest.check_ref()?;
        for (name, value) in [
            ("segment_gap", self.segment_gap),
            ("inlier_distance", self.inlier_distance),
            ("search_radius", self.search_radius),
            ("association_gate", self.association_gate),
        ] {
            InvalidParameter::positive(name, value, "a positive number of metres")?;
        }
        for (name, value) in [
            ("static_fraction", self.static_fraction),
            ("improvement", self.improvement),
        ] {
            if !(value.is_finite() && value > 0.0 && value <= 1.0) {
                return Err(InvalidParameter::new(name, value, "a fraction in (0, 1]").into());
            }
        }
        InvalidParameter::non_negative(
            "free_space_margin",
            self.free_space_margin,
            "a number of metres >= 0",
        )?;
        if let Some(search) = &self.global_search {
            search.check_ref()?;
        }
        InvalidParameter::non_negative(
            "tight_ego_distance",
            self.tight_ego_distance,
            "a number of metres >= 0 (0: off)",
        )?;
        InvalidParameter::fraction("free_space_fraction", self.free_space_fraction)?;
        InvalidParameter::fraction("aligned_fraction", self.aligned_fraction)?;
        if self.min_points < 2 {
            return Err(InvalidParameter::new("min_points", self.min_points, "at least 2").into());
        }
        Ok(())
    }
}

pgm_core::checked_params! {
    /// Segment-wise ICP, then nearest neighbours under each segment's own motion.
    ///
    /// ICP nearest neighbours follow the ego-motion only, so the points of a car that
    /// moved metres find no partner on the car (or a wrong one). Here:
    ///
    /// 1. ICP from the odometry prior (identity without) gives the ego-motion.
    /// 2. The current scan is cut into segments at gaps above
    ///    [`SegmentParams::segment_gap`]. A segment with at least
    ///    [`SegmentParams::static_fraction`] inliers under the ego-motion keeps it.
    /// 3. Every other segment with at least [`SegmentParams::min_points`] points is
    ///    aligned on its own by ICP, started from the ego-motion and from the ego-motion
    ///    shifted so that the segment's centroid lands on the centroid of each reference
    ///    segment within [`SegmentParams::search_radius`] (a moved object is some
    ///    reference segment nearby). The start with the lowest truncated cost wins; it is
    ///    accepted when its cost is below [`SegmentParams::improvement`] times the cost
    ///    under the ego-motion, at least [`SegmentParams::aligned_fraction`] of the
    ///    segment's points are inliers under it, and free space shows that something
    ///    moved: at least [`SegmentParams::free_space_fraction`] of the segment's points,
    ///    moved by the ego-motion, lie where the reference scan saw free space, or as many
    ///    of the reference returns it aligned to, moved back into the current frame, lie
    ///    where the current scan sees free space (the object left). A newly revealed
    ///    static surface fits the ego-motion poorly too, and a straight wall fits many
    ///    shifted walls, but neither passes the free-space test.
    /// 4. Each point then takes its nearest reference return within the gate under
    ///    the motion (ego or its segment's) that puts it nearer to one, provided the
    ///    reference scan can have seen it there ([`Scan::sees`](crate::Scan::sees)); otherwise it is an
    ///    outlier.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct SegmentIcp(SegmentParams) -> Error;
}

impl AssociationSource for SegmentIcp {
    fn name(&self) -> &str {
        "segment-icp"
    }

    fn associate(&self, pair: &ScanPair) -> Result<PointAssociations> {
        segment_icp(pair, &self.params).map_err(|e| e.in_pair(&pair.name))
    }
}

/// [`NearestAfterIcp`] on one pair (parameters already checked).
fn nearest_after_icp(pair: &ScanPair, params: &NearestParams) -> Result<PointAssociations> {
    let icp = Icp::new(&pair.reference, params.icp)?;
    let ego = icp
        .align(&pair.current, pair.odometry.unwrap_or_default())?
        .motion;
    let n = pair.current.len();
    let mut seen = vec![false; n];
    let mut nearest = vec![None; n];
    for k in (0..n).filter(|&k| pair.current.valid[k]) {
        let q = ego.transform_point(&pair.current.beam_point(k));
        seen[k] = pair.reference.sees(&q, params.occlusion_margin);
        nearest[k] = icp.nearest_reference(&q, params.gate);
    }
    // Gap segments of the current scan that do not follow the ego-motion.
    let mut free_segment = vec![false; n];
    if let Some(tolerance) = params.static_tolerance {
        let t2 = tolerance * tolerance;
        let (points, beams) = pair.current.points();
        let segments = segment_by_gap(&points, params.segment_gap);
        let count = segments.last().map_or(0, |&s| s + 1);
        let (mut size, mut fitting) = (vec![0usize; count], vec![0usize; count]);
        for (&segment, &k) in segments.iter().zip(&beams) {
            size[segment] += 1;
            fitting[segment] += usize::from(nearest[k].is_some_and(|(_, d2)| d2 <= t2));
        }
        for (&segment, &k) in segments.iter().zip(&beams) {
            free_segment[k] = 2 * fitting[segment] < size[segment];
        }
    }
    let back = ego.inverse();
    let associations = (0..n)
        .map(|k| {
            if !pair.current.valid[k] {
                return None;
            }
            Some(match nearest[k] {
                Some((beam, _))
                    if seen[k]
                        || (free_segment[k]
                            && pair.current.in_free_space(
                                &back.transform_point(&pair.reference.beam_point(beam)),
                                params.occlusion_margin,
                            )) =>
                {
                    Association::Point(beam)
                }
                _ => Association::Outlier,
            })
        })
        .collect();
    Ok(PointAssociations {
        associations,
        ego_motion: Some(ego),
    })
}

/// Weight of a free-space violation in the choice of a segment's motion, in units of
/// an unmatched return's truncated cost `tau²` (2: the laser saw through where the
/// surface would be, stronger evidence than not seeing it; on simulated pairs, seed
/// 3, 1 gave overtaking 70.6 % exact, 2 gave 72.3 %, 4 gave 72.0 %, 8 gave 72.0 %).
const VIOLATION_WEIGHT: f64 = 2.0;

/// Candidate shifts along a segment's principal axis: this many each way, this far
/// apart (m), up to 2.4 m.
const SLIDE_STEPS: usize = 12;
const SLIDE_STEP: f64 = 0.2;

/// The unit principal axis of `points` (the eigenvector of the larger eigenvalue of
/// their scatter), `None` for coincident points.
fn principal_axis(points: &[Point2<f64>]) -> Option<nalgebra::Vector2<f64>> {
    let c = centroid(points);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = p - c;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let half_trace = 0.5 * (sxx + syy);
    let root = (0.25 * (sxx - syy).powi(2) + sxy * sxy).sqrt();
    let large = half_trace + root;
    if large <= 0.0 {
        return None;
    }
    let v = if sxy.abs() > 1e-12 {
        nalgebra::Vector2::new(large - syy, sxy)
    } else if sxx >= syy {
        nalgebra::Vector2::new(1.0, 0.0)
    } else {
        nalgebra::Vector2::new(0.0, 1.0)
    };
    Some(v.normalize())
}

/// Free-space violations of a segment's candidate motion, both ways: its points
/// moved into the reference frame that lie where the reference scan saw free space,
/// and the returns of the reference segments it matches (a partner within `tau`)
/// moved back into the current frame that lie where the current scan sees free space.
/// A rigid object under its true motion violates neither: it cannot have been where
/// the reference saw through, nor extend now where the current scan sees through (a
/// motion slid along a car's side does the latter with the car's old ends).
#[allow(clippy::too_many_arguments)]
fn free_space_violations(
    pair: &ScanPair,
    icp: &Icp,
    points: &[Point2<f64>],
    motion: &Pose2,
    tau: f64,
    margin: f64,
    reference_segment_of_beam: &[usize],
    reference_ranges: &[std::ops::Range<usize>],
    reference_points: &[Point2<f64>],
) -> usize {
    let mut violations = 0;
    let mut matched: Vec<usize> = Vec::new();
    for s in points {
        let q = motion.transform_point(s);
        if pair.reference.in_free_space(&q, margin) {
            violations += 1;
        }
        if let Some((r, _)) = icp.nearest_reference(&q, tau) {
            let g = reference_segment_of_beam[r];
            if g != usize::MAX && !matched.contains(&g) {
                matched.push(g);
            }
        }
    }
    let back = motion.inverse();
    for g in matched {
        for p in &reference_points[reference_ranges[g].clone()] {
            if pair.current.in_free_space(&back.transform_point(p), margin) {
                violations += 1;
            }
        }
    }
    violations
}

/// Truncated cost (`Σ min(d², tau²)`) and inlier count (`d ≤ tau`) of `points`
/// (of `segment`) moved by `motion` against the reference returns of `icp`, where a
/// reference return that another segment explains (`explained_by`, per reference
/// beam; `usize::MAX`: none) counts as no match.
fn fit_unexplained(
    icp: &Icp,
    points: &[Point2<f64>],
    motion: &Pose2,
    tau: f64,
    segment: usize,
    explained_by: &[usize],
) -> (f64, usize) {
    let mut cost = 0.0;
    let mut inliers = 0;
    for s in points {
        match icp.nearest_reference(&motion.transform_point(s), tau) {
            Some((r, d2)) if explained_by[r] == usize::MAX || explained_by[r] == segment => {
                cost += d2;
                inliers += 1;
            }
            _ => cost += tau * tau,
        }
    }
    (cost, inliers)
}

fn centroid(points: &[Point2<f64>]) -> Point2<f64> {
    let sum = points
        .iter()
        .fold(nalgebra::Vector2::zeros(), |a, p| a + p.coords);
    Point2::from(sum / points.len().max(1) as f64)
}

/// [`SegmentIcp`] on one pair (parameters already checked).
fn segment_icp(pair: &ScanPair, params: &SegmentParams) -> Result<PointAssociations> {
    let nearest = &params.nearest;
    let icp = Icp::new(&pair.reference, nearest.icp)?;
    let SegmentMotions { ego, motion_of, .. } = segment_motions_with(pair, params, &icp)?;
    let (points, beams) = pair.current.points();
    let increment = pair.current.angle_increment();
    let mut associations = vec![None; pair.current.len()];
    for (i, (&beam, s)) in beams.iter().zip(&points).enumerate() {
        let gate = nearest
            .gate
            .min(params.association_gate + 2.0 * pair.current.ranges[beam] * increment);
        let mut choice: Option<(f64, usize)> = None;
        for m in [ego, motion_of[i]] {
            let q = m.transform_point(s);
            if !pair.reference.sees(&q, nearest.occlusion_margin) {
                continue;
            }
            if let Some((r, d2)) = icp.nearest_reference(&q, gate) {
                if choice.is_none_or(|(b, _)| d2 < b) {
                    choice = Some((d2, r));
                }
            }
        }
        associations[beam] = Some(match choice {
            Some((_, r)) => Association::Point(r),
            None => Association::Outlier,
        });
    }
    Ok(PointAssociations {
        associations,
        ego_motion: Some(ego),
    })
}

/// Motion hypotheses of one pair: the ego-motion, and for every valid point of the
/// current scan (in beam order) its gap segment and the motion of that segment. Made
/// by segment-wise ICP (steps 1-3 of [`SegmentIcp`], [`segment_motions`]), or given
/// from elsewhere (a tracker's predictions, an oracle) to CRF-Matching and the joint
/// model, which start every moved segment as a motion group of its own.
///
/// Reading rules (what [`SegmentMotions::check_for`] enforces): one entry per valid
/// current return in `motion_of` and `segment_of`; every segment index within
/// `moved`; all returns of a moved segment carry the same motion. The motions of the
/// returns of segments that did not move are not read (they follow the ego-motion),
/// and a segment marked moved that holds no return is ignored.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentMotions {
    /// The ego-motion (maps current points onto the reference scan).
    pub ego: Pose2,
    /// The motion of each valid current point's segment (the ego-motion for segments
    /// that did not move, as segment-wise ICP writes them).
    pub motion_of: Vec<Pose2>,
    /// The gap segment of each valid current point (indices from 0, beam order).
    pub segment_of: Vec<usize>,
    /// Whether each segment moved (was aligned on its own), by segment index.
    pub moved: Vec<bool>,
}

impl SegmentMotions {
    /// Checks that these hypotheses fit `pair` by the reading rules above. Only the
    /// number of valid returns ties hypotheses to a pair: another pair's hypotheses
    /// with as many returns pass.
    ///
    /// # Errors
    /// [`Error::BadPair`] naming the pair and the first mismatch (the return as its
    /// index among the valid returns and its beam).
    pub fn check_for(&self, pair: &ScanPair) -> Result<()> {
        let beams: Vec<usize> = (0..pair.current.len())
            .filter(|&b| pair.current.valid[b])
            .collect();
        let n = beams.len();
        let bad = |problem: String| Error::BadPair {
            pair: pair.name.clone(),
            problem: format!("motion hypotheses: {problem}"),
        };
        if self.motion_of.len() != n || self.segment_of.len() != n {
            return Err(bad(format!(
                "motions for {} and segments for {} returns, but the current scan has {n} \
                 valid returns",
                self.motion_of.len(),
                self.segment_of.len()
            )));
        }
        if let Some(i) = self.segment_of.iter().position(|&s| s >= self.moved.len()) {
            return Err(bad(format!(
                "valid return {i} (beam {}): segment {} is not among the {} segments of \
                 `moved`",
                beams[i],
                self.segment_of[i],
                self.moved.len()
            )));
        }
        let finite = |m: &Pose2| m.x().is_finite() && m.y().is_finite() && m.theta().is_finite();
        if !finite(&self.ego) {
            return Err(bad(format!(
                "the ego-motion ({}, {}, {}) is not finite",
                self.ego.x(),
                self.ego.y(),
                self.ego.theta()
            )));
        }
        let mut first: Vec<Option<usize>> = vec![None; self.moved.len()];
        for (i, m) in self.motion_of.iter().enumerate() {
            let s = self.segment_of[i];
            if !self.moved[s] {
                continue;
            }
            if !finite(m) {
                return Err(bad(format!(
                    "the motion of valid return {i} (beam {}), ({}, {}, {}), is not finite",
                    beams[i],
                    m.x(),
                    m.y(),
                    m.theta()
                )));
            }
            match first[s] {
                None => first[s] = Some(i),
                Some(k) if self.motion_of[k] != *m => {
                    return Err(bad(format!(
                        "segment {s} moved with two motions: ({}, {}, {}) at valid return {k} \
                         (beam {}) and ({}, {}, {}) at valid return {i} (beam {})",
                        self.motion_of[k].x(),
                        self.motion_of[k].y(),
                        self.motion_of[k].theta(),
                        beams[k],
                        m.x(),
                        m.y(),
                        m.theta(),
                        beams[i]
                    )));
                }
                Some(_) => {}
            }
        }
        Ok(())
    }

    /// These hypotheses with the motion of every return of a moved segment replaced
    /// by `f` of it (a prediction of where the moving objects went, say); the motions
    /// of the segments that did not move are kept.
    ///
    /// # Panics
    /// If a return's segment is not among those of `moved` (hypotheses that do not
    /// pass [`SegmentMotions::check_for`] on any pair).
    pub fn map_moved(&self, mut f: impl FnMut(Pose2) -> Pose2) -> SegmentMotions {
        let mut mapped = self.clone();
        for (m, &s) in mapped.motion_of.iter_mut().zip(&self.segment_of) {
            if self.moved[s] {
                *m = f(*m);
            }
        }
        mapped
    }
}

/// [`SegmentMotions`] of `pair` with the parameters of segment-wise ICP. Errors name
/// the pair.
pub fn segment_motions(pair: &ScanPair, params: &SegmentIcp) -> Result<SegmentMotions> {
    let icp =
        Icp::new(&pair.reference, params.params.nearest.icp).map_err(|e| e.in_pair(&pair.name))?;
    segment_motions_with(pair, &params.params, &icp).map_err(|e| e.in_pair(&pair.name))
}

fn segment_motions_with(
    pair: &ScanPair,
    params: &SegmentParams,
    icp: &Icp,
) -> Result<SegmentMotions> {
    let nearest = &params.nearest;
    let prior = pair.odometry.unwrap_or_default();
    let mut runs = vec![(prior, nearest.icp.initial_max_distance)];
    if params.tight_ego_distance > 0.0 {
        runs.push((prior, params.tight_ego_distance));
    }
    let ego = match params.global_search {
        None => icp.align_best(&pair.current, &runs)?.motion,
        Some(search) => {
            // The best motion of a correlative search around the prior, refined by the
            // tight schedule (the search's grid is finer than its first distance).
            // Only the best is used: asking for one lets the search prune with it
            // alone. The search and the runs from the prior are independent: they
            // run side by side (rayon; one thread runs them in turn), and the
            // result is [`Icp::align_best`] over all the runs in their order.
            let matcher = CorrelativeParams {
                hypotheses: 1,
                ..search
            }
            .check()?;
            let (hypotheses, from_prior) = rayon::join(
                || matcher.search(&pair.reference, &pair.current, prior),
                || icp.align_best(&pair.current, &runs),
            );
            let (hypotheses, mut best) = (hypotheses?, from_prior?);
            if let Some(h) = hypotheses.first() {
                let first = if params.tight_ego_distance > 0.0 {
                    params.tight_ego_distance
                } else {
                    nearest.icp.initial_max_distance
                };
                let r = icp.align_best(&pair.current, &[(h.motion, first)])?;
                if r.is_better_run_than(&best) {
                    best = r;
                }
            }
            best.motion
        }
    };
    let (points, beams) = pair.current.points();
    let segments = segment_by_gap(&points, params.segment_gap);
    let (reference_points, reference_beams) = pair.reference.points();
    let reference_segments = segment_by_gap(&reference_points, params.segment_gap);
    let reference_ranges = segment_ranges(&reference_segments);
    let reference_centroids: Vec<Point2<f64>> = reference_ranges
        .iter()
        .map(|r| centroid(&reference_points[r.clone()]))
        .collect();
    let mut reference_segment_of_beam = vec![usize::MAX; pair.reference.len()];
    for (&b, &g) in reference_beams.iter().zip(&reference_segments) {
        reference_segment_of_beam[b] = g;
    }
    let segment_params = IcpParams {
        initial_max_distance: 1.0,
        coarse_stride: 1,
        // Each candidate alignment is judged by its own truncated cost and inlier
        // fraction below, so ICP itself keeps its last iterate whatever it matched.
        min_correspondences: 0,
        ..nearest.icp
    };
    // The same reference scan as `icp`: its search structures are reused.
    let segment_icp = icp.with_params(segment_params)?;
    let tau = params.inlier_distance;
    // Which current segment explains each reference return under the ego-motion (its
    // nearest current return within `tau`, moved back): a segment's own motion may
    // only match reference returns that no other segment explains — a car's side
    // matched onto a wall that is still there is not where the car came from.
    let back = ego.inverse();
    let current_search = Icp::new(&pair.current, nearest.icp)?;
    let mut segment_of_beam = vec![usize::MAX; pair.current.len()];
    for (i, &b) in beams.iter().enumerate() {
        segment_of_beam[b] = segments[i];
    }
    let mut explained_by = vec![usize::MAX; pair.reference.len()];
    for (g, &r) in reference_points.iter().zip(&reference_beams) {
        if let Some((c, _)) = current_search.nearest_reference(&back.transform_point(g), tau) {
            explained_by[r] = segment_of_beam[c];
        }
    }
    // Per reference segment: how many of its returns each current segment explains.
    let mut reference_explained: Vec<Vec<(usize, usize)>> =
        vec![Vec::new(); reference_ranges.len()];
    for (&r, &g) in reference_beams.iter().zip(&reference_segments) {
        let by = explained_by[r];
        if by == usize::MAX {
            continue;
        }
        match reference_explained[g].iter_mut().find(|(s, _)| *s == by) {
            Some((_, count)) => *count += 1,
            None => reference_explained[g].push((by, 1)),
        }
    }
    let mut motion_of = vec![ego; points.len()];
    // Each segment's motion, if it moved (the segments are independent: side by side
    // on rayon's pool when it has more than one thread, as the segments cost unequal
    // amounts; the same answers either way).
    let segment_motion = |range: std::ops::Range<usize>| -> Option<Pose2> {
        let members = &points[range.clone()];
        if members.len() < params.min_points {
            return None;
        }
        let segment = segments[range.start];
        let fit =
            |motion: &Pose2| fit_unexplained(icp, members, motion, tau, segment, &explained_by);
        let (ego_cost, ego_inliers) = fit(&ego);
        if ego_inliers as f64 >= params.static_fraction * members.len() as f64 {
            return None;
        }
        // Only a segment that the reference scan saw through (free space where the
        // ego-motion puts it) can have moved; a newly revealed static surface lies
        // behind the reference returns instead.
        let violations = members
            .iter()
            .filter(|s| {
                pair.reference
                    .in_free_space(&ego.transform_point(s), params.free_space_margin)
            })
            .count();
        let free = violations as f64 >= params.free_space_fraction * members.len() as f64;
        let mut sub = pair.current.clone();
        sub.valid.fill(false);
        for &b in &beams[range.clone()] {
            sub.valid[b] = true;
        }
        let moved = ego.transform_point(&centroid(members));
        // Starts: the ego-motion, and a shift onto every nearby reference segment that
        // the other current segments do not explain under the ego-motion (where an
        // object can have come from; a wall that is still there is not).
        let starts = std::iter::once(ego).chain(
            reference_centroids
                .iter()
                .zip(&reference_explained)
                .zip(&reference_ranges)
                .filter(|((c, explained), range)| {
                    let by_others: usize = explained
                        .iter()
                        .filter(|(g, _)| *g != segment)
                        .map(|(_, count)| count)
                        .sum();
                    (*c - moved).norm() <= params.search_radius
                        && (by_others as f64) < params.static_fraction * range.len() as f64
                })
                .map(|((c, _), _)| {
                    let shift = c - moved;
                    Pose2::new(ego.x() + shift.x, ego.y() + shift.y, ego.theta())
                }),
        );
        // A candidate motion is chosen by its truncated cost plus `VIOLATION_WEIGHT ·
        // tau²` for every free-space violation both ways (see
        // `free_space_violations`).
        let select = |motion: &Pose2, bound: f64| {
            let (cost, inliers) = fit(motion);
            if cost >= bound {
                // The violations can only add to it.
                return (f64::INFINITY, cost, inliers);
            }
            let violations = free_space_violations(
                pair,
                icp,
                members,
                motion,
                tau,
                params.free_space_margin,
                &reference_segment_of_beam,
                &reference_ranges,
                &reference_points,
            );
            let penalty = VIOLATION_WEIGHT * tau * tau * violations as f64;
            (cost + penalty, cost, inliers)
        };
        let best_of = |motions: &mut dyn Iterator<Item = Pose2>, bound: f64| {
            let mut best: Option<(f64, f64, usize, Pose2)> = None;
            for m in motions {
                let (score, cost, inliers) = select(&m, best.map_or(bound, |b| b.0));
                if score < best.map_or(bound, |b| b.0) {
                    best = Some((score, cost, inliers, m));
                }
            }
            best
        };
        let mut best = best_of(
            &mut starts.filter_map(|guess| segment_icp.align(&sub, guess).ok().map(|r| r.motion)),
            f64::INFINITY,
        );
        // ICP lets a segment slide along its principal axis (a car's side) to where
        // the visible extents overlap most; the ends and the free space around them
        // decide where it belongs: shifts along the axis are candidates too. (Shifting only
        // segments 10 times longer than wide changed no accuracy figure measurably.)
        if let (Some(found), Some(axis)) = (best, principal_axis(members)) {
            let motion = found.3;
            let along = motion.isometry().rotation * axis;
            let slid = best_of(
                &mut (1..=SLIDE_STEPS).flat_map(|k| {
                    [-1.0, 1.0].map(|sign| {
                        let d = along * (sign * k as f64 * SLIDE_STEP);
                        Pose2::new(motion.x() + d.x, motion.y() + d.y, motion.theta())
                    })
                }),
                found.0,
            );
            if slid.is_some() {
                best = slid;
            }
        }
        if let Some((_, cost, inliers, motion)) = best {
            let fraction = inliers as f64 / members.len() as f64;
            // The reverse test: the reference returns the segment aligns to, moved
            // into the current frame, lie where the current scan sees free space
            // (the object left); a static surface matched to another static one
            // fails it, as that one is still there.
            let left = free || {
                let back = ego.inverse();
                let vacated = members
                    .iter()
                    .filter_map(|s| icp.nearest_reference(&motion.transform_point(s), tau))
                    .filter(|&(r, _)| {
                        let g = back.transform_point(&pair.reference.beam_point(r));
                        pair.current.in_free_space(&g, params.free_space_margin)
                    })
                    .count();
                vacated as f64 >= params.free_space_fraction * members.len() as f64
            };
            if left && cost < params.improvement * ego_cost && fraction >= params.aligned_fraction {
                return Some(motion);
            }
        }
        None
    };
    let ranges = segment_ranges(&segments);
    let found: Vec<Option<Pose2>> = if rayon::current_num_threads() > 1 {
        ranges.par_iter().cloned().map(segment_motion).collect()
    } else {
        ranges.iter().cloned().map(segment_motion).collect()
    };
    for (range, motion) in ranges.into_iter().zip(found) {
        if let Some(motion) = motion {
            motion_of[range].fill(motion);
        }
    }
    let count = segments.last().map_or(0, |&x| x + 1);
    let mut moved = vec![false; count];
    for (i, m) in motion_of.iter().enumerate() {
        if *m != ego {
            moved[segments[i]] = true;
        }
    }
    Ok(SegmentMotions {
        ego,
        motion_of,
        segment_of: segments,
        moved,
    })
}
