//! Closed-form weighted rigid alignment of two 2D point sets, eq. (3) of the
//! CRF-Clustering paper (Tipaldi and Ramos, "Motion Clustering and Estimation with
//! Conditional Random Fields"):
//!
//! `R_l, T_l = argmin_{R, T} Σ_i w_i ‖T + R s_i − g_i‖²`
//!
//! over the point pairs `(s_i, g_i)` of one cluster, where `s_i` is a point of the
//! **current** scan and `g_i` its partner in the **reference** scan. The result maps
//! current points onto reference points (`g ≈ R s + T`), the project's motion
//! convention (see [`crate::pose`]).
//!
//! [`RigidAlignment`] keeps only weighted sufficient statistics (Σw, Σw s, Σw g,
//! Σw s gᵀ, Σw‖s‖², Σw‖g‖²), so adding or removing a pair is O(1) and solving is O(1):
//! the hybrid nodes of the joint model recompute every cluster's motion after each
//! variable visit by moving one point from one cluster's statistics to another's.
//!
//! # The solution and its special cases
//!
//! With weighted centroids `s̄`, `ḡ` and the centred cross terms
//! `a = Σw (s−s̄)·(g−ḡ)` and `b = Σw (s−s̄)×(g−ḡ)` (2D cross product), the optimal
//! rotation is `θ = atan2(b, a)` and `T = ḡ − R s̄`. The minimum of the objective is
//! `Σw‖s−s̄‖² + Σw‖g−ḡ‖² − 2 √(a² + b²)`.
//!
//! - **No points, or total weight (numerically) zero**: [`RigidAlignment::solve`]
//!   returns `None` — there is no motion to estimate, and the caller decides what an
//!   empty cluster means.
//! - **One point** (or all points at one place in either scan): the rotation is not
//!   observable (`a = b = 0`); the result is the pure translation `ḡ − s̄` with
//!   rotation 0 and [`Alignment::degenerate`] set.
//! - **Collinear points**: in 2D the rotation is still unique as long as the centred
//!   point sets are not orthogonal to each other (`a² + b² > 0`), so collinear points
//!   give the exact least-squares motion, *not* flagged degenerate. Only when
//!   `√(a² + b²)` is negligible against the spread of the points is the rotation
//!   undetermined; then the result is the pure translation with rotation 0 and
//!   `degenerate` set, as for one point.
//!
//! # Numerical robustness of removal
//!
//! Removing pairs subtracts from running sums, which can leave rounding residue. The
//! statistics therefore count their pairs and reset to exact zeros when the count
//! returns to 0, and [`RigidAlignment::solve`] treats a total weight below `1e-12`
//! times the largest total weight seen since the last reset as empty (returns `None`).
//! Sums are kept relative to the first point added after a reset (an internal origin),
//! which keeps the cross terms small for points far from the sensor origin.
//!
//! Weights must be finite and non-negative; a zero-weight pair is counted but does not
//! influence the motion.
//!
//! ```
//! use nalgebra::Point2;
//! use pgm_scan::alignment::RigidAlignment;
//! use pgm_scan::Pose2;
//!
//! let truth = Pose2::new(0.3, -0.2, 0.1);
//! let mut stats = RigidAlignment::new();
//! for (x, y) in [(1.0, 0.0), (0.0, 2.0), (-1.0, 1.0)] {
//!     let s = Point2::new(x, y);
//!     stats.add(&s, &truth.transform_point(&s), 1.0);
//! }
//! let alignment = stats.solve().expect("three points");
//! assert!(alignment.motion.translation_error(&truth) < 1e-12);
//! assert!(alignment.motion.rotation_error(&truth) < 1e-12);
//! ```

use crate::pose::Pose2;
use nalgebra::{Point2, Vector2};

/// Relative threshold under which the total weight counts as zero (see module docs).
const RELATIVE_WEIGHT_EPSILON: f64 = 1e-12;
/// Relative threshold under which `√(a² + b²)` counts as zero against the spread.
const RELATIVE_ROTATION_EPSILON: f64 = 1e-12;

/// Weighted sufficient statistics of a set of point pairs `(s_i, g_i, w_i)`, with O(1)
/// [`add`](Self::add), [`remove`](Self::remove) and [`solve`](Self::solve).
#[derive(Clone, Debug, PartialEq)]
pub struct RigidAlignment {
    /// Number of pairs currently added.
    count: usize,
    /// Internal origin subtracted from every point (first point after a reset).
    origin_s: Vector2<f64>,
    origin_g: Vector2<f64>,
    /// Σw.
    sum_w: f64,
    /// Largest Σw since the last reset (scale for the "weight is zero" test).
    max_sum_w: f64,
    /// Σw s and Σw g (relative to the origins).
    sum_s: Vector2<f64>,
    sum_g: Vector2<f64>,
    /// Σw s·g and Σw s×g (relative to the origins).
    sum_dot: f64,
    sum_cross: f64,
    /// Σw ‖s‖² and Σw ‖g‖² (relative to the origins).
    sum_ss: f64,
    sum_gg: f64,
}

impl Default for RigidAlignment {
    fn default() -> Self {
        Self::new()
    }
}

/// The solution of eq. (3) for one set of point pairs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// The motion `(R, T)` mapping current points onto reference points.
    pub motion: Pose2,
    /// Weighted sum of squared residuals `Σ w_i ‖T + R s_i − g_i‖²` at the solution.
    pub residual: f64,
    /// Total weight Σw of the pairs.
    pub weight: f64,
    /// Number of pairs.
    pub count: usize,
    /// True when the rotation was not observable (one point, coincident points) and
    /// the motion is the pure translation between the weighted centroids.
    pub degenerate: bool,
}

impl RigidAlignment {
    /// Empty statistics.
    pub fn new() -> Self {
        Self {
            count: 0,
            origin_s: Vector2::zeros(),
            origin_g: Vector2::zeros(),
            sum_w: 0.0,
            max_sum_w: 0.0,
            sum_s: Vector2::zeros(),
            sum_g: Vector2::zeros(),
            sum_dot: 0.0,
            sum_cross: 0.0,
            sum_ss: 0.0,
            sum_gg: 0.0,
        }
    }

    /// Statistics of all pairs of an iterator of `(s, g, w)`.
    pub fn from_pairs<'a>(
        pairs: impl IntoIterator<Item = (&'a Point2<f64>, &'a Point2<f64>, f64)>,
    ) -> Self {
        let mut stats = Self::new();
        for (s, g, w) in pairs {
            stats.add(s, g, w);
        }
        stats
    }

    /// Number of pairs currently in the statistics.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True when no pair is in the statistics.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Total weight Σw.
    pub fn total_weight(&self) -> f64 {
        self.sum_w
    }

    /// Forgets every pair.
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Adds the pair (current point `s`, reference point `g`) with weight `w ≥ 0`.
    #[inline]
    pub fn add(&mut self, s: &Point2<f64>, g: &Point2<f64>, w: f64) {
        debug_assert!(
            w.is_finite() && w >= 0.0,
            "weight {w} must be finite and >= 0"
        );
        if self.count == 0 {
            self.origin_s = s.coords;
            self.origin_g = g.coords;
        }
        self.count += 1;
        self.accumulate(s, g, w);
        if self.sum_w > self.max_sum_w {
            self.max_sum_w = self.sum_w;
        }
    }

    /// Removes a pair previously added with the same `s`, `g` and `w`. Removing a pair
    /// that was never added leaves meaningless statistics (not checked, O(1)).
    #[inline]
    pub fn remove(&mut self, s: &Point2<f64>, g: &Point2<f64>, w: f64) {
        debug_assert!(
            w.is_finite() && w >= 0.0,
            "weight {w} must be finite and >= 0"
        );
        if self.count <= 1 {
            self.clear();
            return;
        }
        self.count -= 1;
        self.accumulate(s, g, -w);
    }

    /// Adds all pairs of `other` (both must describe pairs in the same frames).
    pub fn merge(&mut self, other: &RigidAlignment) {
        if other.count == 0 {
            return;
        }
        if self.count == 0 {
            *self = other.clone();
            return;
        }
        // Re-express other's sums around our origins: with d = o_other − o_self,
        // Σw (x + d) = Σw x + W d, Σw (x+ds)·(y+dg) = Σw x·y + Σw x·dg + ds·Σw y + W ds·dg.
        let ds = other.origin_s - self.origin_s;
        let dg = other.origin_g - self.origin_g;
        let w = other.sum_w;
        self.sum_w += w;
        self.sum_s += other.sum_s + ds * w;
        self.sum_g += other.sum_g + dg * w;
        self.sum_dot +=
            other.sum_dot + other.sum_s.dot(&dg) + ds.dot(&other.sum_g) + w * ds.dot(&dg);
        self.sum_cross += other.sum_cross
            + cross(&other.sum_s, &dg)
            + cross(&ds, &other.sum_g)
            + w * cross(&ds, &dg);
        self.sum_ss += other.sum_ss + 2.0 * other.sum_s.dot(&ds) + w * ds.norm_squared();
        self.sum_gg += other.sum_gg + 2.0 * other.sum_g.dot(&dg) + w * dg.norm_squared();
        self.count += other.count;
        self.max_sum_w = self.max_sum_w.max(self.sum_w);
    }

    #[inline]
    fn accumulate(&mut self, s: &Point2<f64>, g: &Point2<f64>, w: f64) {
        let s = s.coords - self.origin_s;
        let g = g.coords - self.origin_g;
        self.sum_w += w;
        self.sum_s += s * w;
        self.sum_g += g * w;
        self.sum_dot += w * s.dot(&g);
        self.sum_cross += w * cross(&s, &g);
        self.sum_ss += w * s.norm_squared();
        self.sum_gg += w * g.norm_squared();
    }

    /// The weighted sum of squared residuals at the solution,
    /// `Σw‖s−s̄‖² + Σw‖g−ḡ‖² − 2√(a² + b²)` (see the module docs), without building the
    /// motion (no trigonometry): `None` when [`RigidAlignment::solve`] is `None`, and
    /// equal to its [`Alignment::residual`] up to rounding. Merging decisions that
    /// compare many candidate sets use it.
    pub fn residual(&self) -> Option<f64> {
        let Moments {
            a,
            b,
            spread_s,
            spread_g,
            scale,
            ..
        } = self.moments()?;
        let magnitude = (a * a + b * b).sqrt();
        let degenerate = magnitude.is_nan() || magnitude <= RELATIVE_ROTATION_EPSILON * scale;
        // The rotation maximises a cos θ + b sin θ: its value is √(a² + b²), or a at
        // θ = 0 when the rotation is not observable.
        let aligned = if degenerate { a } else { magnitude };
        Some((spread_s + spread_g - 2.0 * aligned).max(0.0))
    }

    /// The weighted least-squares motion of eq. (3); `None` when there is no pair or
    /// the total weight is (numerically) zero. See the module docs for degenerate sets.
    pub fn solve(&self) -> Option<Alignment> {
        self.solve_with_prior(None)
    }

    /// The motion of eq. (3) with a von Mises prior on the rotation, mean `theta0`
    /// (rad) and concentration `precision` (1/rad², in the units of the weights times
    /// m²: with weights `1/σ_i²` it is `1/σ_θ²` of a prior `θ ~ N(theta0, σ_θ²)` near its
    /// mean). The maximum a posteriori rotation is closed form: the objective is
    /// `const − 2(a cos θ + b sin θ) − 2κ cos(θ − θ₀)`, so `θ = atan2(b + κ sin θ₀,
    /// a + κ cos θ₀)`, and `T = ḡ − R s̄` as without the prior. The rotation of a set
    /// whose spread hardly observes it (a few returns of a person's legs) stays near
    /// `theta0`; a long surface is hardly moved by it. `residual` is the data term at
    /// the result. `None` as [`RigidAlignment::solve`], and when `theta0` or
    /// `precision` is not finite or `precision` is negative (no silent NaN motion);
    /// a precision of 0 is [`RigidAlignment::solve`]. Never `degenerate` with a
    /// positive precision.
    pub fn solve_with_rotation_prior(&self, theta0: f64, precision: f64) -> Option<Alignment> {
        if !(theta0.is_finite() && precision.is_finite() && precision >= 0.0) {
            return None;
        }
        self.solve_with_prior(Some((theta0, precision)))
    }

    /// The centred moments of the pairs, `None` when there is no pair or the total
    /// weight is (numerically) zero.
    fn moments(&self) -> Option<Moments> {
        if self.count == 0
            || self.sum_w.is_nan()
            || self.sum_w <= RELATIVE_WEIGHT_EPSILON * self.max_sum_w
            || self.sum_w <= 0.0
        {
            return None;
        }
        let w = self.sum_w;
        let mean_s = self.sum_s / w;
        let mean_g = self.sum_g / w;
        let spread_s = (self.sum_ss - w * mean_s.norm_squared()).max(0.0);
        let spread_g = (self.sum_gg - w * mean_g.norm_squared()).max(0.0);
        Some(Moments {
            w,
            mean_s,
            mean_g,
            a: self.sum_dot - w * mean_s.dot(&mean_g),
            b: self.sum_cross - w * cross(&mean_s, &mean_g),
            spread_s,
            spread_g,
            scale: (spread_s * spread_g).sqrt(),
        })
    }

    fn solve_with_prior(&self, prior: Option<(f64, f64)>) -> Option<Alignment> {
        let Moments {
            w,
            mean_s,
            mean_g,
            a,
            b,
            spread_s,
            spread_g,
            scale,
        } = self.moments()?;
        let magnitude = a.hypot(b);
        let (degenerate, theta) = match prior {
            Some((theta0, kappa)) if kappa > 0.0 => (
                false,
                (b + kappa * theta0.sin()).atan2(a + kappa * theta0.cos()),
            ),
            _ => {
                let degenerate =
                    magnitude.is_nan() || magnitude <= RELATIVE_ROTATION_EPSILON * scale;
                (degenerate, if degenerate { 0.0 } else { b.atan2(a) })
            }
        };
        let (sin, cos) = theta.sin_cos();
        // T = ḡ − R s̄ in absolute coordinates.
        let abs_s = mean_s + self.origin_s;
        let abs_g = mean_g + self.origin_g;
        let rotated = Vector2::new(cos * abs_s.x - sin * abs_s.y, sin * abs_s.x + cos * abs_s.y);
        let t = abs_g - rotated;
        let residual = (spread_s + spread_g - 2.0 * (a * cos + b * sin)).max(0.0);
        Some(Alignment {
            motion: Pose2::new(t.x, t.y, theta),
            residual,
            weight: w,
            count: self.count,
            degenerate,
        })
    }
}

/// The weighted moments of a [`RigidAlignment`]'s pairs about their means (the
/// quantities of the module docs): total weight `w`, means `s̄` and `ḡ`, the
/// centred second moments `a = Σw (s−s̄)·(g−ḡ)` and `b = Σw (s−s̄)×(g−ḡ)`, the spreads
/// `Σw‖s−s̄‖²` and `Σw‖g−ḡ‖²`, and the geometric mean of the spreads.
struct Moments {
    w: f64,
    mean_s: Vector2<f64>,
    mean_g: Vector2<f64>,
    a: f64,
    b: f64,
    spread_s: f64,
    spread_g: f64,
    scale: f64,
}

#[inline]
fn cross(a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// One associated pair of a trimmed motion fit ([`fit_trimmed`]): a current return's
/// surface point, its partner's in the reference scan, the partner's surface normal,
/// and the variance of the association.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePair {
    /// The current return's surface point (current sensor frame, m).
    pub source: Point2<f64>,
    /// Its partner's surface point (reference sensor frame, m).
    pub target: Point2<f64>,
    /// Unit normal of the partner's surface line (reference frame), `None` where no
    /// line describes it ([`crate::scan::SurfacePoint::normal`]).
    pub normal: Option<Vector2<f64>>,
    /// Variance `σ²` of the association (m², positive): the pair's weight is `1/σ²`.
    pub variance: f64,
}

/// Weight of the point-to-point term beside the point-to-line term in
/// [`refine_point_to_line`] (0.1). Along a straight surface the point-to-line term
/// does not observe the motion; this term holds it there (with one-to-one partners
/// on a surface sampled at the beam spacing it is biased by up to half a spacing).
/// Measured on simulated pairs (design seed 3, 30 per preset, CRF-Matching's exact
/// association accuracy): see docs/decisions.md.
pub const POINT_TO_POINT_WEIGHT: f64 = 0.1;

/// Largest number of Gauss-Newton steps of [`refine_point_to_line`].
pub const POINT_TO_LINE_ITERATIONS: usize = 5;

/// [`refine_point_to_line`] treats its normal equations as singular when their
/// smallest eigenvalue is below this fraction of the largest.
const SINGULAR_RATIO: f64 = 1e-10;

/// The motion that minimises, over the fixed `pairs` (weights `w = 1/σ²`),
///
/// `Σ w (n·(R s + T − g))² + λ Σ w ‖R s + T − g‖² − 2κ cos(θ − θ₀)`
///
/// (`λ` = `point_weight`; a pair without a normal counts with its full point-to-point
/// distance, weight 1 instead of `λ`; the last term only with a rotation `prior`
/// `(θ₀, κ)`, `κ ≥ 0` and finite, the objective of
/// [`RigidAlignment::solve_with_rotation_prior`]). The first term is the point-to-line
/// metric of Censi ("An ICP variant using a point-to-line metric", ICRA 2008) on fixed
/// correspondences, with lines from a local fit of the reference returns
/// ([`crate::scan::surface_model`]) rather than Censi's segment between the two
/// nearest returns; the point-to-point term is added to hold the motion along a
/// straight surface, which the first term does not observe. Gauss-Newton from `start`
/// (the point-to-point solution, eq. 3 here, eq. 6 of the joint paper, is the natural
/// start), at most [`POINT_TO_LINE_ITERATIONS`] steps.
///
/// Why: eq. 3 on one-to-one partners pins every current return to one sampled
/// reference return, so the motion carries the sampling of the surfaces (up to half
/// a beam spacing along each); the line through the partner's surface lets a return
/// fall between two reference returns. Returns the last iterate (`start` if the first
/// step fails) when the normal equations are singular (all sources at one point, or
/// `λ = 0` with too few normal directions, and no prior) or a step is not finite.
pub fn refine_point_to_line(
    start: Pose2,
    pairs: &[SurfacePair],
    point_weight: f64,
    prior: Option<(f64, f64)>,
) -> Pose2 {
    use nalgebra::{Matrix3, Vector3};
    let mut motion = start;
    for _ in 0..POINT_TO_LINE_ITERATIONS {
        let mut h = Matrix3::zeros();
        let mut g = Vector3::zeros();
        let t = Vector2::new(motion.x(), motion.y());
        for p in pairs {
            let q = motion.transform_point(&p.source);
            let r = q - p.target;
            let rel = q.coords - t;
            // Derivatives of q with respect to (x, y, θ).
            let jx = Vector3::new(1.0, 0.0, -rel.y);
            let jy = Vector3::new(0.0, 1.0, rel.x);
            let w = 1.0 / p.variance;
            let point = match p.normal {
                Some(n) => {
                    let jn = jx * n.x + jy * n.y;
                    h += w * jn * jn.transpose();
                    g += w * jn * n.dot(&r);
                    point_weight
                }
                None => 1.0,
            };
            h += w * point * (jx * jx.transpose() + jy * jy.transpose());
            g += w * point * (jx * r.x + jy * r.y);
        }
        if let Some((theta0, kappa)) = prior {
            let d = crate::pose::wrap_angle(motion.theta() - theta0);
            h[(2, 2)] += kappa * d.cos().max(0.0);
            g[2] += kappa * d.sin();
        }
        // Singular normal equations (all sources at one point, or λ = 0 with too few
        // normal directions, and no prior): the motion is not observed.
        let eigen = h.symmetric_eigenvalues();
        let (smallest, largest) = (eigen.min(), eigen.max());
        if smallest.is_nan() || smallest <= SINGULAR_RATIO * largest {
            return motion;
        }
        let Some(step) = h.cholesky().map(|c| -c.solve(&g)) else {
            return motion;
        };
        if !step.iter().all(|v| v.is_finite()) {
            return motion;
        }
        motion = Pose2::new(
            motion.x() + step.x,
            motion.y() + step.y,
            motion.theta() + step.z,
        );
        if step.norm() < 1e-9 {
            break;
        }
    }
    motion
}

/// Parameters of [`fit_trimmed`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrimmedFitParams {
    /// Pairs farther than this many association standard deviations `σ` from the
    /// motion leave the fit.
    pub inlier_sigmas: f64,
    /// Most trim-and-solve iterations.
    pub iterations: usize,
    /// Fewest kept pairs a motion is solved from.
    pub min_pairs: usize,
    /// `Some(λ)`: end with [`refine_point_to_line`], `λ` the weight of its
    /// point-to-point term; `None`: eq. 3 alone.
    pub point_to_line: Option<f64>,
}

/// The motion of one group of returns from their associated `pairs`, trimmed (the
/// motion re-solve of CRF-Matching's groups and of the joint model's clusters): from
/// `start`, the pairs farther than [`TrimmedFitParams::inlier_sigmas`] standard
/// deviations leave and the rest are solved again by eq. 3 (the closed form of this
/// module; eq. 6 of the joint paper), weights `1/σ²`, with the rotation `prior`
/// `(θ₀, κ)` if given, until no pair leaves, at most [`TrimmedFitParams::iterations`]
/// times (a pair that left is not re-admitted, so the iteration cannot cycle); then,
/// with [`TrimmedFitParams::point_to_line`], [`refine_point_to_line`] on the kept
/// pairs. Fewer than [`TrimmedFitParams::min_pairs`] pairs within the bound of `start`
/// keep `start`; a later trim below `min_pairs` keeps the previous solve, unrefined
/// (`pairs` then holds the pairs of that last trim). `stats` is scratch space.
pub fn fit_trimmed(
    pairs: &mut Vec<SurfacePair>,
    start: Pose2,
    limits: &TrimmedFitParams,
    prior: Option<(f64, f64)>,
    stats: &mut RigidAlignment,
) -> Pose2 {
    let mut motion = start;
    let mut solved_once = false;
    let bound = limits.inlier_sigmas * limits.inlier_sigmas;
    for round in 0..limits.iterations {
        let before = pairs.len();
        pairs.retain(|p| {
            (motion.transform_point(&p.source) - p.target).norm_squared() <= bound * p.variance
        });
        if pairs.len() < limits.min_pairs || (round > 0 && pairs.len() == before) {
            break;
        }
        stats.clear();
        for p in pairs.iter() {
            stats.add(&p.source, &p.target, 1.0 / p.variance);
        }
        let solved = match prior {
            Some((theta0, kappa)) => stats.solve_with_rotation_prior(theta0, kappa),
            None => stats.solve(),
        };
        if let Some(a) = solved {
            motion = a.motion;
            solved_once = true;
        }
    }
    if let Some(point_weight) = limits.point_to_line {
        if solved_once && pairs.len() >= limits.min_pairs {
            motion = refine_point_to_line(motion, pairs, point_weight, prior);
        }
    }
    motion
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Asserts that `pose` is `expected` to 1e-9 (m and rad).
    fn assert_same_pose(pose: Pose2, expected: Pose2) {
        assert!(
            pose.translation_error(&expected) < 1e-9,
            "{pose:?} {expected:?}"
        );
        assert!(
            pose.rotation_error(&expected) < 1e-9,
            "{pose:?} {expected:?}"
        );
    }

    #[test]
    fn residual_matches_the_solution() {
        let truth = Pose2::new(0.4, -0.3, 0.2);
        let mut stats = RigidAlignment::new();
        assert_eq!(stats.residual(), None);
        for (k, (x, y)) in [(1.0, 0.0), (0.0, 2.0), (-1.0, 1.0), (3.0, -2.0)]
            .iter()
            .enumerate()
        {
            let s = Point2::new(*x, *y);
            let noise = Vector2::new(0.01 * k as f64, -0.02 * (k % 2) as f64);
            stats.add(&s, &(truth.transform_point(&s) + noise), 1.0 + k as f64);
            let solved = stats.solve().unwrap().residual;
            let fast = stats.residual().unwrap();
            assert!(
                (solved - fast).abs() <= 1e-12 * (1.0 + solved),
                "{solved} vs {fast}"
            );
        }
    }

    #[test]
    fn empty_is_none() {
        assert!(RigidAlignment::new().solve().is_none());
    }

    #[test]
    fn one_point_is_pure_translation() {
        let mut stats = RigidAlignment::new();
        stats.add(&Point2::new(1.0, 2.0), &Point2::new(3.0, -1.0), 2.0);
        let a = stats.solve().unwrap();
        assert!(a.degenerate);
        assert_eq!(a.motion.theta(), 0.0);
        assert!((a.motion.x() - 2.0).abs() < 1e-12);
        assert!((a.motion.y() + 3.0).abs() < 1e-12);
        assert!(a.residual < 1e-12);
    }

    #[test]
    fn zero_weight_only_is_none() {
        let mut stats = RigidAlignment::new();
        stats.add(&Point2::new(1.0, 2.0), &Point2::new(3.0, -1.0), 0.0);
        assert!(stats.solve().is_none());
    }

    #[test]
    fn collinear_points_give_rotation() {
        let truth = Pose2::new(0.5, 0.1, 0.4);
        let mut stats = RigidAlignment::new();
        for k in 0..5 {
            let s = Point2::new(k as f64, 2.0 * k as f64);
            stats.add(&s, &truth.transform_point(&s), 1.0);
        }
        let a = stats.solve().unwrap();
        assert!(!a.degenerate);
        assert!(a.motion.translation_error(&truth) < 1e-12);
        assert!(a.motion.rotation_error(&truth) < 1e-12);
    }

    #[test]
    fn coincident_points_are_degenerate() {
        let mut stats = RigidAlignment::new();
        for _ in 0..3 {
            stats.add(&Point2::new(1.0, 1.0), &Point2::new(2.0, 1.0), 1.0);
        }
        let a = stats.solve().unwrap();
        assert!(a.degenerate);
        assert!((a.motion.x() - 1.0).abs() < 1e-12);
    }

    /// The rotation prior's closed form is the minimum of data term plus prior over
    /// a fine scan of θ; no concentration is `solve`, a huge one is `theta0`, and one
    /// point (rotation unobservable) takes `theta0` with its translation fitted.
    #[test]
    fn rotation_prior_is_the_posterior_minimum() {
        let truth = Pose2::new(0.4, -0.1, 0.2);
        let mut stats = RigidAlignment::new();
        let points = [(2.0, 0.5), (2.2, 0.7), (2.1, 0.4), (1.9, 0.65)];
        for (k, &(x, y)) in points.iter().enumerate() {
            let s = Point2::new(x, y);
            let noise = Vector2::new(0.01 * (k as f64 - 1.5), -0.008 * k as f64);
            stats.add(&s, &(truth.transform_point(&s) + noise), 4.0);
        }
        let (theta0, kappa) = (-0.05, 0.6);
        // Data term at θ (the residual with the rotation pinned there; the translation
        // is fitted) plus the prior's −2κ cos(θ − θ₀).
        let posterior = |theta: f64| {
            let fit = stats.solve_with_rotation_prior(theta, 1e12).unwrap();
            fit.residual - 2.0 * kappa * (theta - theta0).cos()
        };
        let best = stats.solve_with_rotation_prior(theta0, kappa).unwrap();
        assert!(!best.degenerate);
        let at = best.motion.theta();
        for k in -2000..=2000 {
            let theta = at + k as f64 * 1e-4;
            assert!(
                posterior(theta) >= posterior(at) - 1e-9,
                "θ = {theta} scores below the closed form's {at}"
            );
        }
        let plain = stats.solve().unwrap();
        let none = stats.solve_with_rotation_prior(theta0, 0.0).unwrap();
        assert_eq!(plain.motion, none.motion);
        assert!(
            at > theta0 && at < plain.motion.theta(),
            "between prior and data"
        );
        let pinned = stats.solve_with_rotation_prior(theta0, 1e12).unwrap();
        assert!((pinned.motion.theta() - theta0).abs() < 1e-9);
        for (theta, kappa) in [
            (f64::NAN, 1.0),
            (0.0, f64::NAN),
            (0.0, -1.0),
            (f64::INFINITY, 1.0),
        ] {
            assert!(stats.solve_with_rotation_prior(theta, kappa).is_none());
        }
        let mut one = RigidAlignment::new();
        one.add(&Point2::new(1.0, 1.0), &Point2::new(2.0, 1.0), 1.0);
        let a = one.solve_with_rotation_prior(0.1, 100.0).unwrap();
        assert!(!a.degenerate);
        assert!((a.motion.theta() - 0.1).abs() < 1e-12);
        assert!(
            (a.motion.transform_point(&Point2::new(1.0, 1.0)) - Point2::new(2.0, 1.0)).norm()
                < 1e-12
        );
    }

    #[test]
    fn removing_all_but_a_tiny_weight_is_none() {
        let mut stats = RigidAlignment::new();
        let s = Point2::new(1.0, 1.0);
        stats.add(&s, &s, 1e6);
        stats.add(&Point2::new(2.0, 0.0), &Point2::new(2.0, 0.0), 1e-9);
        stats.remove(&s, &s, 1e6);
        // 1e-9 of 1e6 is below the relative threshold.
        assert!(stats.solve().is_none());
        assert_eq!(stats.len(), 1);
    }

    #[test]
    fn removing_every_pair_resets_exactly() {
        let mut stats = RigidAlignment::new();
        let pts = [(0.1, 0.2), (3.0, -1.0), (5.5, 2.25)];
        for (x, y) in pts {
            stats.add(&Point2::new(x, y), &Point2::new(y, x), 0.3);
        }
        for (x, y) in pts {
            stats.remove(&Point2::new(x, y), &Point2::new(y, x), 0.3);
        }
        assert_eq!(stats, RigidAlignment::new());
    }

    /// Two perpendicular walls sampled every 10 cm in both scans, the current samples
    /// half a spacing off the reference ones; each current point's partner is the
    /// nearest reference sample (a one-to-one association that carries the sampling).
    fn sampled_walls(truth: Pose2) -> Vec<SurfacePair> {
        let mut pairs = Vec::new();
        let walls = [
            (
                Point2::new(-1.0, 2.0),
                Vector2::new(1.0, 0.0),
                Vector2::new(0.0, 1.0),
                21,
            ),
            (
                Point2::new(3.0, -1.0),
                Vector2::new(0.0, 1.0),
                Vector2::new(1.0, 0.0),
                6,
            ),
        ];
        for (start, along, normal, n) in walls {
            let reference: Vec<Point2<f64>> =
                (0..n).map(|k| start + along * (0.1 * k as f64)).collect();
            for (k, &target) in reference.iter().enumerate().take(n - 1) {
                // A current point whose true position lies 4 cm past a reference sample.
                let world = start + along * (0.1 * k as f64 + 0.04);
                let source = truth.inverse().transform_point(&world);
                pairs.push(SurfacePair {
                    source,
                    target,
                    normal: Some(normal),
                    variance: 0.05 * 0.05,
                });
            }
        }
        pairs
    }

    #[test]
    fn point_to_line_removes_the_sampling_of_one_to_one_partners() {
        let truth = Pose2::new(0.3, -0.1, 0.05);
        let pairs = sampled_walls(truth);
        let mut stats = RigidAlignment::new();
        for p in &pairs {
            stats.add(&p.source, &p.target, 1.0 / p.variance);
        }
        let point_to_point = stats.solve().unwrap().motion;
        // Eq. 3 moves every point back onto its sample: 4 cm along each wall.
        assert!(
            point_to_point.translation_error(&truth) > 0.03,
            "{point_to_point:?}"
        );
        let refined = refine_point_to_line(point_to_point, &pairs, 1e-6, None);
        assert!(refined.translation_error(&truth) < 1e-4, "{refined:?}");
        assert!(refined.rotation_error(&truth) < 1e-5, "{refined:?}");
        // With the default weight the point-to-point term keeps part of the pull (here
        // every partner is off by the same 4 cm, the worst case).
        let default = refine_point_to_line(point_to_point, &pairs, POINT_TO_POINT_WEIGHT, None);
        assert!(
            default.translation_error(&truth) < 0.5 * point_to_point.translation_error(&truth),
            "{default:?}"
        );
        // Without a normal a pair counts with its full point-to-point distance.
        let bare: Vec<SurfacePair> = pairs
            .iter()
            .map(|p| SurfacePair { normal: None, ..*p })
            .collect();
        let same = refine_point_to_line(point_to_point, &bare, 1e-6, None);
        assert!(same.translation_error(&point_to_point) < 1e-9, "{same:?}");
    }

    #[test]
    fn point_to_line_on_one_point_keeps_the_start() {
        let start = Pose2::new(0.1, 0.2, 0.3);
        let pair = SurfacePair {
            source: Point2::new(1.0, 0.0),
            target: Point2::new(2.0, 0.0),
            normal: Some(Vector2::new(1.0, 0.0)),
            variance: 1.0,
        };
        // One point does not fix a rotation: the normal equations are singular.
        assert_eq!(refine_point_to_line(start, &[pair], 0.1, None), start);
        // A rotation prior makes them regular again: the rotation is the prior's, the
        // translation puts the source on its target.
        let with_prior = refine_point_to_line(start, &[pair], 0.1, Some((0.3, 1.0)));
        let expected = Pose2::new(2.0 - 0.3f64.cos(), -(0.3f64.sin()), 0.3);
        assert_same_pose(with_prior, expected);
    }

    #[test]
    fn point_to_line_with_a_prior_and_no_normals_is_the_closed_form_with_that_prior() {
        // Without normals the objective is eq. 3 with the rotation prior, which
        // `solve_with_rotation_prior` solves in closed form: the Gauss-Newton steps
        // must land on the same motion (a prior weighted otherwise would not).
        let truth = Pose2::new(0.2, -0.4, 0.15);
        let pairs: Vec<SurfacePair> = [(1.0, 0.0), (0.0, 2.0), (-1.0, 1.5), (2.0, -1.0)]
            .iter()
            .enumerate()
            .map(|(k, &(x, y))| {
                let s = Point2::new(x, y);
                let noise = Vector2::new(0.02 * k as f64, -0.03 * (k % 2) as f64);
                SurfacePair {
                    source: s,
                    target: truth.transform_point(&s) + noise,
                    normal: None,
                    variance: 0.05 * 0.05,
                }
            })
            .collect();
        let mut stats = RigidAlignment::new();
        for p in &pairs {
            stats.add(&p.source, &p.target, 1.0 / p.variance);
        }
        let (theta0, kappa) = (0.0, 1.0 / (0.05 * 0.05));
        let closed = stats
            .solve_with_rotation_prior(theta0, kappa)
            .unwrap()
            .motion;
        let start = Pose2::new(closed.x() + 0.01, closed.y() - 0.01, closed.theta() + 0.01);
        let refined = refine_point_to_line(start, &pairs, 0.1, Some((theta0, kappa)));
        assert_same_pose(refined, closed);
    }

    #[test]
    fn the_trimmed_fit_drops_a_wrong_partner_and_ends_point_to_line() {
        let truth = Pose2::new(0.3, -0.1, 0.05);
        let mut pairs = sampled_walls(truth);
        let n = pairs.len();
        // A wrong partner 1 m off.
        pairs.push(SurfacePair {
            target: pairs[0].target + Vector2::new(1.0, 0.0),
            ..pairs[0]
        });
        let limits = TrimmedFitParams {
            inlier_sigmas: 2.0,
            iterations: 6,
            min_pairs: 3,
            point_to_line: Some(1e-6),
        };
        let mut stats = RigidAlignment::new();
        // From a start within two standard deviations (6 cm) of every right partner.
        let start = Pose2::new(0.32, -0.08, 0.05);
        let mut kept = pairs.clone();
        let motion = fit_trimmed(&mut kept, start, &limits, None, &mut stats);
        assert_eq!(kept.len(), n);
        assert!(motion.translation_error(&truth) < 1e-4, "{motion:?}");
        // Without the refinement: eq. 3 on the kept pairs.
        let mut kept = pairs.clone();
        let eq3 = fit_trimmed(
            &mut kept,
            start,
            &TrimmedFitParams {
                point_to_line: None,
                ..limits
            },
            None,
            &mut stats,
        );
        assert!(eq3.translation_error(&truth) > 0.03, "{eq3:?}");
        // Too few pairs keep the start.
        let mut few = pairs[..2].to_vec();
        assert_eq!(
            fit_trimmed(&mut few, start, &limits, None, &mut stats),
            start
        );
    }
}
