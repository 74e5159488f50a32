//! Registration: point-to-point ICP (iterative closest point), the scan-matching
//! baseline of the joint-model paper (van de Ven, Ramos and Tipaldi, Table I and III)
//! and the ego-motion step of the nearest-neighbour association sources
//! ([`crate::association`]).
//!
//! Each iteration moves the current scan's returns by the motion estimate, pairs each
//! with its nearest reference return within the correspondence distance (a 2D k-d
//! tree and a hashed grid, built once on the reference scan and searched with the
//! distance to the previous partner as a bound; exact nearest neighbours),
//! drops pairs farther apart than a correspondence distance, and re-solves the motion
//! in closed form from the kept pairs (eq. 3 of the CRF-Clustering paper,
//! [`crate::RigidAlignment`]). The correspondence distance starts at
//! [`IcpParams::initial_max_distance`] and shrinks by [`IcpParams::distance_decay`]
//! per iteration down to [`IcpParams::final_max_distance`], so large initial errors
//! are still caught while the final estimate ignores outliers; when the estimate
//! settles (changes less than the tolerances) before the schedule ends, the next
//! iteration uses the final distance directly. The iteration stops
//! when the distance has reached its final value and the estimate changes by less than
//! the tolerances, or after [`IcpParams::max_iterations`].
//!
//! The result follows the project convention: [`IcpResult::motion`] maps current
//! points onto reference points (the ego-motion), and [`IcpResult::associations`]
//! has one entry per beam of the current scan: `None` without a return,
//! `Some(Association::Point(k))` for the nearest reference beam `k` within the final
//! distance at the final estimate, `Some(Association::Outlier)` otherwise.
//!
//! **Too little data.** A rigid fit needs correspondences that pin down three degrees
//! of freedom, and ICP on a handful of returns converges to whatever its nearest
//! neighbours suggest. When fewer than [`IcpParams::min_correspondences`] returns
//! are matched (in the first iteration, or at the final estimate), ICP keeps the
//! starting motion (the prior) and says so: [`IcpResult::status`] is
//! [`IcpStatus::TooFewCorrespondences`] and `converged` is false.
//!
//! **Cost.** Building the search structures is O(m log m) for `m` reference returns
//! and a query O(log m) plus the points it inspects: the grid's cell side shrinks on
//! dense scans so that a cell holds a bounded number of returns on average, and a
//! run stays near O(n log m) for `n` current returns (`carmen-long100000`: two
//! 100 000-beam scans).
//!
//! ```
//! use pgm_scan::registration::IcpParams;
//! use pgm_scan::{ParamGuard, Pose2, Scan};
//!
//! // A wall of returns seen from two poses 0.2 m apart.
//! let wall = |dx: f64| -> Scan {
//!     let angles: Vec<f64> = (0..181).map(|k| -1.2 + 2.4 * k as f64 / 180.0).collect();
//!     let ranges: Vec<f64> = angles.iter().map(|a| (3.0 - dx) / a.cos()).collect();
//!     Scan::from_ranges(angles, ranges, 30.0)
//! };
//! let icp = IcpParams::default().check().unwrap().reference(&wall(0.0)).unwrap();
//! let result = icp.align(&wall(0.2), Pose2::new(0.15, 0.0, 0.0)).unwrap();
//! assert!((result.motion.x() - 0.2).abs() < 0.01, "{:?}", result.motion);
//! ```

use crate::pair::{Association, ScanPair};
use crate::{Error, Pose2, Result, RigidAlignment, Scan};
use nalgebra::Point2;
use pgm_core::param::{InvalidParameter, ParamGuard};
use serde::Serialize;

/// ICP parameters (checked by [`IcpParams::check`] when an [`Icp`] is built).
///
/// The defaults (2 m shrinking by 0.8 per iteration to 0.1 m, at most 60 iterations,
/// tolerances 1e-4 m and 1e-4 rad, every third return while the distance is above
/// 0.2 m) were chosen on the real logs with `pgm eval matching --method icp`: against
/// matching every return with tolerances 1e-5 they change the median errors by less
/// than 0.0004 m and 0.0003 rad and take about a third less time
/// (`cargo bench --bench icp`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcpParams {
    /// Largest number of iterations.
    pub max_iterations: usize,
    /// Correspondence distance of the first iteration (m).
    pub initial_max_distance: f64,
    /// Correspondence distance the schedule ends at (m); also the outlier distance of
    /// the returned associations.
    pub final_max_distance: f64,
    /// Factor in (0, 1] applied to the correspondence distance after each iteration.
    pub distance_decay: f64,
    /// Convergence tolerance on the change of translation per iteration (m).
    pub translation_tolerance: f64,
    /// Convergence tolerance on the change of rotation per iteration (rad).
    pub rotation_tolerance: f64,
    /// While the correspondence distance is above twice its final value, only every
    /// `coarse_stride`-th current return is matched (1 = all); the final iterations
    /// always use every return.
    pub coarse_stride: usize,
    /// Fewest matched returns for a rigid fit (10; 0 turns the check off, otherwise at
    /// least 2): with fewer, ICP keeps the starting motion (see the module docs).
    pub min_correspondences: usize,
}

impl Default for IcpParams {
    fn default() -> Self {
        Self {
            max_iterations: 60,
            initial_max_distance: 2.0,
            final_max_distance: 0.1,
            distance_decay: 0.8,
            translation_tolerance: 1e-4,
            rotation_tolerance: 1e-4,
            coarse_stride: 3,
            min_correspondences: 10,
        }
    }
}

impl IcpParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, value: f64, expected: &'static str| {
            Err(InvalidParameter::new(name, value, expected).into())
        };
        if self.max_iterations == 0 {
            return Err(InvalidParameter::new("max_iterations", 0, "at least 1").into());
        }
        if self.coarse_stride == 0 {
            return Err(InvalidParameter::new("coarse_stride", 0, "at least 1").into());
        }
        if self.min_correspondences == 1 {
            return Err(InvalidParameter::new(
                "min_correspondences",
                1,
                "0 (no check) or at least 2 (a rigid fit needs two points)",
            )
            .into());
        }
        if !(self.final_max_distance > 0.0 && self.final_max_distance.is_finite()) {
            return bad(
                "final_max_distance",
                self.final_max_distance,
                "a positive number of metres",
            );
        }
        if !(self.initial_max_distance >= self.final_max_distance
            && self.initial_max_distance.is_finite())
        {
            return bad(
                "initial_max_distance",
                self.initial_max_distance,
                "a finite number of metres at least final_max_distance",
            );
        }
        if !(self.distance_decay > 0.0 && self.distance_decay <= 1.0) {
            return bad("distance_decay", self.distance_decay, "a factor in (0, 1]");
        }
        if self.distance_decay == 1.0 && self.initial_max_distance > self.final_max_distance {
            return bad(
                "distance_decay",
                self.distance_decay,
                "a factor below 1 when initial_max_distance exceeds final_max_distance",
            );
        }
        if !(self.translation_tolerance >= 0.0 && self.translation_tolerance.is_finite()) {
            return bad(
                "translation_tolerance",
                self.translation_tolerance,
                "a finite number of metres >= 0",
            );
        }
        if !(self.rotation_tolerance >= 0.0 && self.rotation_tolerance.is_finite()) {
            return bad(
                "rotation_tolerance",
                self.rotation_tolerance,
                "a finite number of radians >= 0",
            );
        }
        Ok(())
    }
}

pgm_core::checked_params! {
    /// ICP with checked parameters: prepares the search structures of a reference scan
    /// ([`IcpMatcher::reference`]) and estimates the ego-motion of scan pairs (a
    /// [`ScanMatcher`](crate::methods::ScanMatcher), started from the pair's odometry
    /// prior, the identity without one).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct IcpMatcher(IcpParams) -> Error;
}

impl IcpMatcher {
    /// Builds the search structures on `reference`'s returns.
    ///
    /// # Errors
    /// [`Error::EmptyScan`] when the scan has no valid return.
    pub fn reference(&self, reference: &Scan) -> Result<Icp> {
        Icp::prepared(reference, self.params)
    }

    /// Aligns the current scan of `pair` to its reference scan from its odometry prior
    /// (the identity without one). Errors name the pair.
    pub fn align_pair(&self, pair: &ScanPair) -> Result<IcpResult> {
        self.reference(&pair.reference)
            .and_then(|icp| icp.align(&pair.current, pair.odometry.unwrap_or_default()))
            .map_err(|e| e.in_pair(&pair.name))
    }
}

/// How an ICP run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum IcpStatus {
    /// The estimate settled within the tolerances at the final distance.
    Converged,
    /// The iteration limit came first.
    IterationLimit,
    /// Fewer than [`IcpParams::min_correspondences`] returns were matched: the motion
    /// is the starting motion (the prior).
    TooFewCorrespondences,
}

/// What [`Icp::align`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct IcpResult {
    /// Motion mapping current points onto reference points.
    pub motion: Pose2,
    /// How the run ended.
    pub status: IcpStatus,
    /// Per beam of the current scan (see the module docs).
    pub associations: Vec<Option<Association>>,
    /// Number of iterations run.
    pub iterations: usize,
    /// True when the tolerances were met before `max_iterations`.
    pub converged: bool,
    /// Number of current returns associated to a reference return.
    pub inliers: usize,
    /// Root-mean-square distance of the associated pairs at the final estimate (m);
    /// 0 when there is none.
    pub rms_error: f64,
}

impl IcpResult {
    /// Whether this run beats `earlier`, a run of [`Icp::align_best`] that came
    /// before it: more inliers, or as many with a lower RMS error; runs that end at
    /// the same minimum (within [`SAME_MINIMUM`]) keep the earlier one — their RMS
    /// errors differ only by rounding, which would make the choice depend on the
    /// order the returns were summed in.
    pub fn is_better_run_than(&self, earlier: &IcpResult) -> bool {
        let same = self.motion.translation_error(&earlier.motion) <= SAME_MINIMUM
            && self.motion.rotation_error(&earlier.motion) <= SAME_MINIMUM;
        !same
            && (self.inliers > earlier.inliers
                || (self.inliers == earlier.inliers && self.rms_error < earlier.rms_error))
    }
}

/// Two ICP runs of [`Icp::align_best`] whose motions differ by at most this (m and
/// rad) ended at the same minimum.
pub const SAME_MINIMUM: f64 = 1e-6;

/// Marks a current return without a partner in the previous iteration.
const NO_PARTNER: usize = usize::MAX;

/// ICP against one reference scan; the k-d tree is built once and reused by every
/// [`align`](Icp::align) call.
pub struct Icp {
    params: IcpParams,
    tree: NearestTree,
    grid: CellGrid,
    /// Beam index of each tree item.
    reference_beams: Vec<usize>,
    reference_points: Vec<[f64; 2]>,
    /// Per reference return, the squared distance to the nearest other one (see
    /// [`Icp::isolation`]); computed on the first alignment.
    isolation: std::sync::OnceLock<Vec<f64>>,
}

impl std::fmt::Debug for Icp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Icp")
            .field("params", &self.params)
            .field("reference_points", &self.reference_points.len())
            .finish()
    }
}

impl Icp {
    /// Checks `params` and builds the search structures on the reference scan's
    /// returns (the same as `params.check()?.reference(reference)`).
    pub fn new(reference: &Scan, params: IcpParams) -> Result<Self> {
        params.check()?.reference(reference)
    }

    fn prepared(reference: &Scan, params: IcpParams) -> Result<Self> {
        let (points, reference_beams) = reference.points();
        if points.is_empty() {
            return Err(Error::EmptyScan { which: "reference" });
        }
        let reference_points: Vec<[f64; 2]> = points.iter().map(|p| [p.x, p.y]).collect();
        let tree = NearestTree::new(&reference_points);
        let grid = CellGrid::new(&reference_points, 2.0 * params.final_max_distance);
        Ok(Self {
            params,
            tree,
            grid,
            reference_beams,
            reference_points,
            isolation: std::sync::OnceLock::new(),
        })
    }

    /// Per reference return (tree item), the squared distance to the nearest other
    /// reference return (0 for a duplicate, infinite for a lone return). A query
    /// closer to a return than half that distance has that return as its strict
    /// nearest neighbour (triangle inequality), which lets ICP confirm a previous
    /// partner without a search (see [`Icp::align_from`]).
    fn isolation(&self) -> &[f64] {
        self.isolation.get_or_init(|| {
            let mut found = Vec::with_capacity(2);
            self.reference_points
                .iter()
                .map(|&p| {
                    self.tree.k_nearest_within(p, 2, f64::INFINITY, &mut found);
                    found.get(1).map_or(f64::INFINITY, |x| x.1)
                })
                .collect()
        })
    }

    /// ICP against the same reference scan with other `params`, without building the
    /// search structures again where they do not depend on the parameters: the k-d
    /// tree is shared as is, and the grid too when the final correspondence distance
    /// (which sets its cells) is the same. The same as `Icp::new(reference, params)`
    /// on the scan this one was built on.
    ///
    /// # Errors
    /// As [`IcpParams::check`].
    pub fn with_params(&self, params: IcpParams) -> Result<Self> {
        let params = *params.check()?.params();
        let grid = if params.final_max_distance == self.params.final_max_distance {
            self.grid.clone()
        } else {
            CellGrid::new(&self.reference_points, 2.0 * params.final_max_distance)
        };
        Ok(Self {
            params,
            tree: self.tree.clone(),
            grid,
            reference_beams: self.reference_beams.clone(),
            reference_points: self.reference_points.clone(),
            isolation: self.isolation.clone(),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &IcpParams {
        &self.params
    }

    /// The reference return nearest to `p` (in the reference frame) within
    /// `max_distance`: its beam index and squared distance.
    pub fn nearest_reference(&self, p: &Point2<f64>, max_distance: f64) -> Option<(usize, f64)> {
        self.nearest_within([p.x, p.y], max_distance * max_distance)
            .map(|(item, d2)| (self.reference_beams[item], d2))
    }

    /// The `k` reference returns nearest to `p` (reference frame) within
    /// `max_distance`, nearest first, into `out` as (beam index, squared distance).
    pub fn k_nearest_references(
        &self,
        p: &Point2<f64>,
        k: usize,
        max_distance: f64,
        out: &mut Vec<(usize, f64)>,
    ) {
        self.tree
            .k_nearest_within([p.x, p.y], k, max_distance * max_distance, out);
        for x in out.iter_mut() {
            x.0 = self.reference_beams[x.0];
        }
    }

    /// The nearest reference return strictly closer than `sqrt(bound)`: the grid for
    /// small bounds, the k-d tree otherwise (both exact).
    #[inline]
    fn nearest_within(&self, q: [f64; 2], bound: f64) -> Option<(usize, f64)> {
        if bound <= self.grid.max_bound {
            self.grid.nearest_within(q, bound)
        } else {
            self.tree.nearest_within(q, bound)
        }
    }

    /// One association per beam of a scan of `beams_total` beams whose returns are
    /// `points` (at `beams`), moved by `motion`: the nearest reference return strictly
    /// within `sqrt(limit)`; also the number of matched returns and their summed
    /// squared distances.
    fn associate(
        &self,
        points: &[Point2<f64>],
        beams: &[usize],
        beams_total: usize,
        motion: &Pose2,
        limit: f64,
    ) -> (Vec<Option<Association>>, usize, f64) {
        let (sin, cos) = motion.theta().sin_cos();
        let mut associations = vec![None; beams_total];
        let mut inliers = 0;
        let mut sum_d2 = 0.0;
        for (s, &beam) in points.iter().zip(beams) {
            let q = [
                cos * s.x - sin * s.y + motion.x(),
                sin * s.x + cos * s.y + motion.y(),
            ];
            associations[beam] = Some(match self.nearest_within(q, limit) {
                Some((item, d2)) => {
                    inliers += 1;
                    sum_d2 += d2;
                    Association::Point(self.reference_beams[item])
                }
                None => Association::Outlier,
            });
        }
        (associations, inliers, sum_d2)
    }

    /// Aligns `current` once per run `(start, first correspondence distance in m)` of
    /// `runs` (the distance replaces [`IcpParams::initial_max_distance`] for that run)
    /// and returns the run with the most inliers at the final distance (ties: the
    /// lower RMS error, then the earlier run; runs within [`SAME_MINIMUM`] of each
    /// other count as one, the earlier). The support at the final distance is
    /// the number of current returns the motion explains; a wrong local minimum
    /// explains fewer.
    ///
    /// Why several schedules: objects moving with the sensor (a car overtaking or
    /// oncoming along a street) lie within a wide first distance of their earlier
    /// returns while the static scene is offset by the odometry error; a wide schedule
    /// from a good prior then locks onto them and slides along the street's walls,
    /// where a tight one keeps to the static scene. On 30 simulated `overtaking` and
    /// `oncoming` pairs each (seed 7), the default wide schedule ended 0.12-0.51 m
    /// from the true ego-motion on 10 pairs; a first distance of 0.3 m ended within
    /// 0.11 m on all ten, with more inliers at 0.1 m on nine of them.
    ///
    /// # Errors
    /// As [`Icp::align`]; [`Error::InvalidParameter`] for no run, or a distance that
    /// is not finite and positive.
    pub fn align_best(&self, current: &Scan, runs: &[(Pose2, f64)]) -> Result<IcpResult> {
        if runs.is_empty() {
            return Err(InvalidParameter::new("runs", 0, "at least one ICP run").into());
        }
        let mut best: Option<IcpResult> = None;
        for &(start, d) in runs {
            InvalidParameter::positive("first distance", d, "a distance in metres > 0")?;
            let r = self.align_from(current, start, d.max(self.params.final_max_distance))?;
            if best.as_ref().is_none_or(|b| r.is_better_run_than(b)) {
                best = Some(r);
            }
        }
        Ok(best.expect("at least one run"))
    }

    /// Aligns `current` to the reference scan starting from `initial` (for example
    /// the odometry prior, or the identity).
    pub fn align(&self, current: &Scan, initial: Pose2) -> Result<IcpResult> {
        self.align_from(current, initial, self.params.initial_max_distance)
    }

    /// [`Icp::align`] with the schedule starting at `initial_max_distance`.
    fn align_from(
        &self,
        current: &Scan,
        initial: Pose2,
        initial_max_distance: f64,
    ) -> Result<IcpResult> {
        if !initial.is_finite() {
            return Err(
                InvalidParameter::new("initial", initial, "a finite starting motion").into(),
            );
        }
        let (points, beams) = current.points();
        if points.is_empty() {
            return Err(Error::EmptyScan { which: "current" });
        }
        let p = self.params;
        let mut motion = initial;
        let mut max_distance = initial_max_distance;
        let mut iterations = 0;
        let mut converged = false;
        let mut stats = RigidAlignment::new();
        // Previous partner of each current return: its distance under the new estimate
        // bounds the search (the nearest is at most that far), which prunes most of
        // the tree once the estimate settles. The result is still the exact nearest.
        let mut previous = vec![NO_PARTNER; points.len()];
        let isolation = self.isolation();
        while iterations < p.max_iterations {
            iterations += 1;
            let limit = max_distance * max_distance;
            let (sin, cos) = motion.theta().sin_cos();
            let (tx, ty) = (motion.x(), motion.y());
            stats.clear();
            let stride = if max_distance > 2.0 * p.final_max_distance {
                p.coarse_stride
            } else {
                1
            };
            for (s, partner) in points.iter().zip(previous.iter_mut()).step_by(stride) {
                let q = [cos * s.x - sin * s.y + tx, sin * s.x + cos * s.y + ty];
                let mut bound = limit;
                if *partner != NO_PARTNER {
                    let g = self.reference_points[*partner];
                    let d2 = (g[0] - q[0]) * (g[0] - q[0]) + (g[1] - q[1]) * (g[1] - q[1]);
                    // Closer to the previous partner than half its distance to any
                    // other reference return (with a relative margin far above
                    // rounding): the partner is the strict nearest, which the search
                    // below would return.
                    if d2 < limit && 4.0 * d2 * (1.0 + ISOLATION_MARGIN) < isolation[*partner] {
                        stats.add(s, &Point2::new(g[0], g[1]), 1.0);
                        continue;
                    }
                    // Slightly above d2 so that the previous partner itself qualifies.
                    bound = bound.min(d2 * (1.0 + 1e-12) + f64::MIN_POSITIVE);
                }
                match self.nearest_within(q, bound) {
                    Some((item, _)) => {
                        *partner = item;
                        let g = self.reference_points[item];
                        stats.add(s, &Point2::new(g[0], g[1]), 1.0);
                    }
                    None => *partner = NO_PARTNER,
                }
            }
            let Some(solution) = stats.solve() else {
                break;
            };
            let next = solution.motion;
            let at_final = max_distance <= p.final_max_distance;
            let small = next.translation_error(&motion) < p.translation_tolerance
                && next.rotation_error(&motion) < p.rotation_tolerance;
            motion = next;
            if at_final && small {
                converged = true;
                break;
            }
            max_distance = if small {
                // Settled before the schedule ended: the coarse distances only serve
                // to catch large initial errors, so go straight to the final one.
                p.final_max_distance
            } else {
                (max_distance * p.distance_decay).max(p.final_max_distance)
            };
        }
        // Associations at the final estimate and the final distance.
        let limit = p.final_max_distance * p.final_max_distance;
        let (mut associations, mut inliers, mut sum_d2) =
            self.associate(&points, &beams, current.len(), &motion, limit);
        let status = if inliers < p.min_correspondences {
            // Too little data for a rigid fit: keep the prior (and its associations).
            motion = initial;
            (associations, inliers, sum_d2) =
                self.associate(&points, &beams, current.len(), &motion, limit);
            converged = false;
            IcpStatus::TooFewCorrespondences
        } else if converged {
            IcpStatus::Converged
        } else {
            IcpStatus::IterationLimit
        };
        Ok(IcpResult {
            motion,
            status,
            associations,
            iterations,
            converged,
            inliers,
            rms_error: if inliers > 0 {
                (sum_d2 / inliers as f64).sqrt()
            } else {
                0.0
            },
        })
    }
}

/// One-shot ICP: builds the tree on `reference` and aligns `current`, starting from
/// `initial` or the identity.
pub fn icp(
    reference: &Scan,
    current: &Scan,
    initial: Option<Pose2>,
    params: IcpParams,
) -> Result<IcpResult> {
    Icp::new(reference, params)?.align(current, initial.unwrap_or_default())
}

/// A static 2D k-d tree over a few hundred points, specialised for ICP's repeated
/// bounded nearest-neighbour queries. kiddo 6 (the workspace's general k-d tree) has
/// no distance bound on its nearest-one query; ICP knows a tight bound for most
/// queries (the distance to the previous iteration's partner), and the bound, with
/// [`CellGrid`] answering small-bound queries, is what makes queries cheap. Measured
/// on mit-csail pairs (all returns matched, tolerance 1e-5, about 25 iterations):
/// kiddo 6 trees 1.0–1.3 ms per pair, this tree unbounded about the same, with the
/// bound and the grid 0.66–0.77 ms (see docs/decisions.md).
///
/// Layout: points are stored in tree order in one array (the node of a range
/// `[lo, hi)` is its middle element, split on the axis of larger spread), leaves of
/// up to [`LEAF_SIZE`] points are scanned linearly, and a query allocates nothing and
/// prunes with the best squared distance found so far, starting from the bound.
#[derive(Clone, Debug)]
struct NearestTree {
    /// Points in tree order.
    points: Vec<[f64; 2]>,
    /// Original index of each point in tree order.
    items: Vec<u32>,
    /// Split axis of the node stored at each position (unused for leaf positions).
    axes: Vec<u8>,
}

/// Largest number of points scanned linearly at a leaf.
const LEAF_SIZE: usize = 16;

impl NearestTree {
    fn new(source: &[[f64; 2]]) -> Self {
        let mut order: Vec<([f64; 2], u32)> = source
            .iter()
            .enumerate()
            .map(|(k, p)| (*p, k as u32))
            .collect();
        let mut axes = vec![0u8; source.len()];
        Self::build(&mut order, 0, &mut axes);
        Self {
            points: order.iter().map(|(p, _)| *p).collect(),
            items: order.iter().map(|(_, k)| *k).collect(),
            axes,
        }
    }

    fn build(slice: &mut [([f64; 2], u32)], offset: usize, axes: &mut [u8]) {
        if slice.len() <= LEAF_SIZE {
            return;
        }
        let spread = |a: usize| {
            let (lo, hi) = slice
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (p, _)| {
                    (lo.min(p[a]), hi.max(p[a]))
                });
            hi - lo
        };
        let axis = usize::from(spread(1) > spread(0));
        let mid = slice.len() / 2;
        slice.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
        axes[offset + mid] = axis as u8;
        let (left, rest) = slice.split_at_mut(mid);
        Self::build(left, offset, axes);
        Self::build(&mut rest[1..], offset + mid + 1, axes);
    }

    /// The nearest point to `q` strictly closer than `sqrt(bound)`: (item, squared
    /// distance), or `None` when no point is that close.
    #[inline]
    fn nearest_within(&self, q: [f64; 2], bound: f64) -> Option<(usize, f64)> {
        let mut best = (usize::MAX, bound);
        self.search(0, self.points.len(), q, &mut best);
        (best.0 != usize::MAX).then(|| (self.items[best.0] as usize, best.1))
    }

    /// The `k` nearest points to `q` strictly closer than `sqrt(bound)`, nearest first,
    /// into `out` as (item, squared distance).
    fn k_nearest_within(&self, q: [f64; 2], k: usize, bound: f64, out: &mut Vec<(usize, f64)>) {
        out.clear();
        if k == 0 {
            return;
        }
        self.search_k(0, self.points.len(), q, k, bound, out);
        for x in out.iter_mut() {
            x.0 = self.items[x.0] as usize;
        }
    }

    /// Keeps `best` sorted by distance, at most `k` long, all strictly closer than
    /// `sqrt(bound)` (indices into the tree order).
    fn search_k(
        &self,
        lo: usize,
        hi: usize,
        q: [f64; 2],
        k: usize,
        bound: f64,
        best: &mut Vec<(usize, f64)>,
    ) {
        let limit = |best: &Vec<(usize, f64)>| {
            if best.len() == k {
                best[k - 1].1
            } else {
                bound
            }
        };
        let offer = |best: &mut Vec<(usize, f64)>, item: usize, d: f64| {
            if d < limit(best) {
                let at = best.partition_point(|x| x.1 <= d);
                best.insert(at, (item, d));
                best.truncate(k);
            }
        };
        if hi - lo <= LEAF_SIZE {
            for i in lo..hi {
                offer(best, i, self.squared_distance(i, q));
            }
            return;
        }
        let (mid, diff, near, far) = self.split(lo, hi, q);
        offer(best, mid, self.squared_distance(mid, q));
        self.search_k(near.0, near.1, q, k, bound, best);
        if diff * diff < limit(best) {
            self.search_k(far.0, far.1, q, k, bound, best);
        }
    }

    fn search(&self, lo: usize, hi: usize, q: [f64; 2], best: &mut (usize, f64)) {
        let mut offer = |k: usize| {
            let d = self.squared_distance(k, q);
            if d < best.1 {
                *best = (k, d);
            }
        };
        if hi - lo <= LEAF_SIZE {
            (lo..hi).for_each(&mut offer);
            return;
        }
        let (mid, diff, near, far) = self.split(lo, hi, q);
        offer(mid);
        self.search(near.0, near.1, q, best);
        if diff * diff < best.1 {
            self.search(far.0, far.1, q, best);
        }
    }

    /// The squared distance from the point at `k` (tree order) to `q`.
    #[inline]
    fn squared_distance(&self, k: usize, q: [f64; 2]) -> f64 {
        let p = self.points[k];
        (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1])
    }

    /// The split of the subtree `lo..hi` (more than a leaf): its middle point, `q`'s
    /// signed distance from it along the split axis, and the near and far halves
    /// (ranges of tree order) as seen from `q`.
    #[inline]
    fn split(
        &self,
        lo: usize,
        hi: usize,
        q: [f64; 2],
    ) -> (usize, f64, (usize, usize), (usize, usize)) {
        let mid = lo + (hi - lo) / 2;
        let axis = self.axes[mid] as usize;
        let diff = q[axis] - self.points[mid][axis];
        if diff < 0.0 {
            (mid, diff, (lo, mid), (mid + 1, hi))
        } else {
            (mid, diff, (mid + 1, hi), (lo, mid))
        }
    }
}

/// A hashed uniform grid over the reference returns for bounded nearest-neighbour
/// queries with a small bound, the common case once ICP has a partner for a return
/// from the previous iteration. With cells of side `c`, every point closer than
/// `c / 2` to a query lies in the 2 × 2 block of cells nearest to it, so a query
/// looks up four cells (open addressing, no allocation) and scans their points.
#[derive(Clone, Debug)]
struct CellGrid {
    /// Cell side (m).
    cell: f64,
    /// Largest squared bound the grid answers exactly, `(cell / 2)²`.
    max_bound: f64,
    /// Points sorted by cell, with their original indices.
    points: Vec<[f64; 2]>,
    items: Vec<u32>,
    /// Open-addressing table: cell key (or `EMPTY_CELL`) and its range in `points`.
    keys: Vec<u64>,
    ranges: Vec<(u32, u32)>,
    /// Number of bits of the table index.
    bits: u32,
}

const EMPTY_CELL: u64 = u64::MAX;

/// Largest mean number of returns per occupied cell: denser scans get smaller cells
/// (and queries with larger bounds go to the tree), so a query inspects a bounded
/// number of points however many beams the scanner has.
const MAX_CELL_OCCUPANCY: usize = 8;

impl CellGrid {
    /// A grid with cells of side `cell`, halved (at most 16 times) while the occupied
    /// cells hold more than [`MAX_CELL_OCCUPANCY`] points on average.
    fn new(source: &[[f64; 2]], cell: f64) -> Self {
        let mut cell = cell;
        let mut order: Vec<(u64, [f64; 2], u32)>;
        let mut occupied;
        let mut halvings = 0;
        loop {
            let key_of = |p: &[f64; 2]| cell_key(floor(p[0] / cell), floor(p[1] / cell));
            order = source
                .iter()
                .enumerate()
                .map(|(k, p)| (key_of(p), *p, k as u32))
                .collect();
            order.sort_unstable_by_key(|e| e.0);
            occupied = order.windows(2).filter(|w| w[0].0 != w[1].0).count() + 1;
            if source.len() <= MAX_CELL_OCCUPANCY * occupied || halvings == 16 {
                break;
            }
            cell /= 2.0;
            halvings += 1;
        }
        let bits = (2 * occupied).next_power_of_two().max(16).trailing_zeros();
        let size = 1usize << bits;
        let mut grid = Self {
            cell,
            max_bound: 0.25 * cell * cell,
            points: order.iter().map(|e| e.1).collect(),
            items: order.iter().map(|e| e.2).collect(),
            keys: vec![EMPTY_CELL; size],
            ranges: vec![(0, 0); size],
            bits,
        };
        let mut start = 0;
        while start < order.len() {
            let key = order[start].0;
            let mut end = start + 1;
            while end < order.len() && order[end].0 == key {
                end += 1;
            }
            let mut slot = grid.slot(key);
            while grid.keys[slot] != EMPTY_CELL {
                slot = (slot + 1) & (size - 1);
            }
            grid.keys[slot] = key;
            grid.ranges[slot] = (start as u32, end as u32);
            start = end;
        }
        grid
    }

    #[inline]
    fn slot(&self, key: u64) -> usize {
        (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - self.bits)) as usize
    }

    #[inline]
    fn range(&self, key: u64) -> (usize, usize) {
        let mask = self.keys.len() - 1;
        let mut slot = self.slot(key);
        loop {
            let k = self.keys[slot];
            if k == key {
                let (a, b) = self.ranges[slot];
                return (a as usize, b as usize);
            }
            if k == EMPTY_CELL {
                return (0, 0);
            }
            slot = (slot + 1) & mask;
        }
    }

    /// As [`NearestTree::nearest_within`], for `bound <= max_bound`.
    #[inline]
    fn nearest_within(&self, q: [f64; 2], bound: f64) -> Option<(usize, f64)> {
        debug_assert!(bound <= self.max_bound);
        let fx = q[0] / self.cell;
        let fy = q[1] / self.cell;
        let (ix, iy) = (floor(fx), floor(fy));
        let (nx, gx) = if fx - ix < 0.5 {
            (ix - 1.0, fx - ix)
        } else {
            (ix + 1.0, ix + 1.0 - fx)
        };
        let (ny, gy) = if fy - iy < 0.5 {
            (iy - 1.0, fy - iy)
        } else {
            (iy + 1.0, iy + 1.0 - fy)
        };
        // The gaps (m) from `q` to the neighbouring column and row of cells, less a
        // slack far above rounding: every point of a neighbouring cell lies at least
        // that far from `q` along the gap's axis, so a cell whose gap (squared, both
        // gaps for the diagonal cell) is not below the best squared distance so far
        // holds no point that could win (wins are strictly closer), and is not read.
        // The cells read are read in the same order, so the answer is the same as
        // reading all four.
        let gap = |g: f64| (g * self.cell - GAP_SLACK).max(0.0);
        let (gx, gy) = (gap(gx), gap(gy));
        let mut best = (usize::MAX, bound);
        for (key, reach) in [
            (cell_key(ix, iy), 0.0),
            (cell_key(nx, iy), gx * gx),
            (cell_key(ix, ny), gy * gy),
            (cell_key(nx, ny), gx * gx + gy * gy),
        ] {
            if reach >= best.1 {
                continue;
            }
            let (a, b) = self.range(key);
            for k in a..b {
                let p = self.points[k];
                let d = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]);
                if d < best.1 {
                    best = (k, d);
                }
            }
        }
        (best.0 != usize::MAX).then(|| (self.items[best.0] as usize, best.1))
    }
}

/// Relative margin of the isolation test of [`Icp::align_from`] (a previous partner
/// confirmed without a search): far above the rounding of squared distances.
const ISOLATION_MARGIN: f64 = 1e-6;

/// Slack (m) taken off the gaps between a query and the neighbouring cells in
/// [`CellGrid::nearest_within`]: many orders of magnitude above the rounding of
/// coordinates of a laser's reach, far below any distance that matters.
const GAP_SLACK: f64 = 1e-9;

/// `⌊x⌋` without a call into libm (the baseline x86-64 target has no rounding
/// instruction, and `f64::floor` is a function call there): exact, the same value as
/// `x.floor()` for every `x` except that `-0.0` gives `0.0` (the same cell).
#[inline]
fn floor(x: f64) -> f64 {
    if x.abs() < 4.5e15 {
        let t = x as i64;
        (t - i64::from((t as f64) > x)) as f64
    } else {
        x.floor()
    }
}

/// Key of the cell with integer coordinates `(ix, iy)` (given as floats; saturated to
/// the `i32` range, far beyond any laser's reach).
#[inline]
fn cell_key(ix: f64, iy: f64) -> u64 {
    (u64::from(ix as i32 as u32) << 32) | u64::from(iy as i32 as u32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_scenes::{first_hit, uniform, ROOM};

    fn room_scan(pose: &Pose2) -> Scan {
        // The room ([`ROOM`]) seen from `pose`.
        let n = 361;
        let mut angles = Vec::new();
        let mut ranges = Vec::new();
        for k in 0..n {
            let a = -std::f64::consts::PI + k as f64 * 2.0 * std::f64::consts::PI / n as f64;
            let hit = first_hit((pose.x(), pose.y()), pose.theta() + a, &ROOM);
            angles.push(a);
            ranges.push(hit.unwrap_or(0.0));
        }
        Scan::from_ranges(angles, ranges, 30.0)
    }

    #[test]
    fn nearest_tree_matches_brute_force() {
        // Deterministic pseudo-random points, duplicates included.
        let mut state = 12345u64;
        let mut next = || uniform(&mut state) * 20.0 - 10.0;
        for n in [1usize, 2, 7, 8, 9, 50, 361] {
            let mut points: Vec<[f64; 2]> = (0..n).map(|_| [next(), next()]).collect();
            if n > 2 {
                points[1] = points[0];
            }
            let tree = NearestTree::new(&points);
            for _ in 0..200 {
                let q = [next(), next()];
                let brute = points
                    .iter()
                    .map(|p| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2))
                    .fold(f64::INFINITY, f64::min);
                let (item, d2) = tree.nearest_within(q, f64::INFINITY).unwrap();
                assert_eq!(d2, brute);
                let p = points[item];
                assert_eq!((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2), d2);
                let bound = 1.0;
                assert_eq!(
                    tree.nearest_within(q, bound).map(|x| x.1),
                    (brute < bound).then_some(brute)
                );
            }
        }
    }

    #[test]
    fn k_nearest_matches_brute_force() {
        let mut state = 99u64;
        let mut next = || uniform(&mut state) * 20.0 - 10.0;
        let points: Vec<[f64; 2]> = (0..300).map(|_| [next(), next()]).collect();
        let tree = NearestTree::new(&points);
        let mut out = Vec::new();
        for k in [1usize, 4, 9] {
            for _ in 0..50 {
                let q = [next(), next()];
                let mut brute: Vec<(usize, f64)> = points
                    .iter()
                    .enumerate()
                    .map(|(i, p)| (i, (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)))
                    .filter(|x| x.1 < 25.0)
                    .collect();
                brute.sort_by(|a, b| a.1.total_cmp(&b.1));
                brute.truncate(k);
                tree.k_nearest_within(q, k, 25.0, &mut out);
                let d: Vec<f64> = out.iter().map(|x| x.1).collect();
                let e: Vec<f64> = brute.iter().map(|x| x.1).collect();
                assert_eq!(d, e);
            }
        }
    }

    #[test]
    fn recovers_a_small_motion() {
        let reference_pose = Pose2::new(0.0, 0.0, 0.0);
        let current_pose = Pose2::new(0.3, -0.1, 0.08);
        let reference = room_scan(&reference_pose);
        let current = room_scan(&current_pose);
        let truth = reference_pose.between(&current_pose);
        let r = icp(&reference, &current, None, IcpParams::default()).unwrap();
        assert!(r.converged);
        assert!(r.motion.translation_error(&truth) < 0.02, "{:?}", r.motion);
        assert!(r.motion.rotation_error(&truth) < 0.005, "{:?}", r.motion);
        assert_eq!(r.associations.len(), current.len());
        assert!(r.inliers > 300);
    }

    #[test]
    fn too_few_correspondences_keep_the_prior() {
        // Scans with 1 and 5 returns (case L05): no rigid fit can be trusted, the prior
        // is kept and the result says why.
        let room = room_scan(&Pose2::identity());
        let moved = room_scan(&Pose2::new(0.25, 0.08, 0.06));
        let prior = Pose2::new(0.25, 0.08, 0.06);
        for keep in [1usize, 5] {
            let thin = |scan: &Scan| {
                let mut s = scan.clone();
                let valid: Vec<usize> = (0..s.len()).filter(|&k| s.valid[k]).collect();
                for &k in &valid[keep..] {
                    s.valid[k] = false;
                }
                s
            };
            let icp = Icp::new(&thin(&room), IcpParams::default()).unwrap();
            let r = icp.align(&thin(&moved), prior).unwrap();
            assert_eq!(r.status, IcpStatus::TooFewCorrespondences, "{keep} returns");
            assert_eq!(r.motion, prior);
            assert!(!r.converged);
        }
        // With the check off, ICP reports whatever it reached.
        let params = IcpParams {
            min_correspondences: 0,
            ..IcpParams::default()
        };
        let r = Icp::new(&room, params)
            .unwrap()
            .align(&moved, prior)
            .unwrap();
        assert_eq!(r.status, IcpStatus::Converged);
        assert!(IcpParams {
            min_correspondences: 1,
            ..IcpParams::default()
        }
        .check()
        .is_err());
    }

    #[test]
    fn dense_scans_get_smaller_grid_cells() {
        // 20 000 returns within a few metres: the grid halves its cells until they
        // hold few points each, so a query stays cheap, and stays exact.
        let mut state = 7u64;
        let mut next = || uniform(&mut state);
        let points: Vec<[f64; 2]> = (0..20_000).map(|_| [5.0 * next(), next()]).collect();
        let grid = CellGrid::new(&points, 0.2);
        assert!(grid.cell < 0.2, "cell {}", grid.cell);
        assert!(
            points.len()
                <= MAX_CELL_OCCUPANCY * grid.keys.iter().filter(|&&k| k != EMPTY_CELL).count()
        );
        let tree = NearestTree::new(&points);
        for _ in 0..200 {
            let q = [5.0 * next(), next()];
            let bound = grid.max_bound * 0.99;
            assert_eq!(
                grid.nearest_within(q, bound).map(|x| x.1),
                tree.nearest_within(q, bound).map(|x| x.1)
            );
        }
    }

    #[test]
    fn rejects_bad_parameters_and_empty_scans() {
        let scan = room_scan(&Pose2::identity());
        let params = IcpParams {
            distance_decay: 0.0,
            ..Default::default()
        };
        assert!(matches!(
            Icp::new(&scan, params),
            Err(Error::InvalidParameter {
                name: "distance_decay",
                ..
            })
        ));
        let mut empty = scan.clone();
        empty.valid.iter_mut().for_each(|v| *v = false);
        assert!(matches!(
            Icp::new(&empty, IcpParams::default()),
            Err(Error::EmptyScan { which: "reference" })
        ));
        let icp = Icp::new(&scan, IcpParams::default()).unwrap();
        assert!(matches!(
            icp.align(&empty, Pose2::identity()),
            Err(Error::EmptyScan { which: "current" })
        ));
    }
}
