//! Correlative scan matching: a global search for the rigid motion of a scan pair in
//! a window around a prior, the initialisation ICP needs when the prior is bad.
//!
//! **What it implements.** E. Olson, "Real-time correlative scan matching", ICRA
//! 2009: the reference scan's returns are rasterised into a lookup grid whose cells
//! hold how well a return landing there is explained (a Gaussian of the distance to
//! the nearest reference return, Olson's rasterised cost table), and a motion is
//! scored by summing the grid under the current returns it moves into the reference
//! frame. The window is searched by branch and bound over max-pooled copies of the
//! grid (Olson's multi-resolution search, in the form of W. Hess, D. Kohler, H. Rapp,
//! D. Andor, "Real-time loop closure in 2D LIDAR SLAM", ICRA 2016, Algorithms 2-3 and
//! eq. 14-15, Cartographer's `FastCorrelativeScanMatcher2D`): the grid of depth `h`
//! holds, in each cell, the maximum of the lookup grid over the `2^h × 2^h` cells
//! starting there, so one lookup per return bounds the score of every translation of
//! a `2^h × 2^h` block, and a block is only split when its bound beats the best
//! scores found so far.
//!
//! **Rotations are bounded too.** Hess et al. enumerate every rotation and branch on
//! translations only; with a ±30° window and returns 80 m away that is 700-800
//! rotations, each costing one lookup per return before any pruning. Here a node of
//! depth `h ≥ 1` also spans `2^h` rotation steps (fewer when a user-set step is
//! coarse): rotated by the block's middle rotation, a return at range `d` is at most
//! `ρ = d · (2^h − 1)/2 · δθ` (the arc) from where any rotation of the block puts it,
//! so the cells it can fall in span `⌊x − ρ⌋ ..= ⌊x + ρ⌋`, and a return whose span is
//! a single cell is bounded by depth `h`, any other by depth `h + 1` from
//! `⌊x − ρ⌋` (the derived step makes `ρ` at most `(2^h − 1)/2` cells, so the wider
//! window always fits). Both this and a search rotation by rotation are exact; the
//! rotation blocks pay where the rotations are many (the measurement is in the book,
//! `docs/decisions.md`, "Correlative search").
//!
//! The search is exact on its lattice: the first hypothesis is the best-scoring
//! lattice point, as an exhaustive search finds it (the unit tests check both the
//! bounds and the result against one).
//!
//! **Conventions.** A motion maps current points into the reference frame (`g ≈ R s +
//! T`, [`crate::pose`]), the convention of [`crate::registration`] and of
//! [`ScanPair::odometry`](crate::ScanPair::odometry). The search lattice is centred
//! on the prior: rotations `θ_prior + j·δθ` for `|j| ≤ J = ⌊rotation_window / δθ +
//! 1/2⌋`, translations `t_prior + (i_x, i_y)·resolution` for `|i_x|, |i_y| ≤ K =
//! ⌊translation_window / resolution⌋`.
//!
//! **Choices the papers leave open**, and why:
//! - *Lookup values*: `exp(−d²/(2σ²))` for the distance `d` from a cell's centre to
//!   the nearest reference return (the likelihood field of a return under Gaussian
//!   noise, Olson §III-A), stored as a byte (0-255, as Cartographer stores its
//!   probabilities in 16 bits): sums are exact integers, so the branch and bound
//!   compares without rounding, and a byte per cell keeps the grids in cache.
//! - *Score*: the mean grid value over the current returns used (in `[0, 1]`), not a
//!   log-likelihood: it is what the bounds are computed on, reads as "share of
//!   returns explained", and does not let one far-off return veto a motion (Olson
//!   also clamps the cost of a return).
//! - *Decimation*: a voxel filter keeps one current return per square cell of side
//!   [`CorrelativeParams::point_spacing`] (the one nearest the cell's centre), so
//!   the score weighs surfaces by length rather than by how close they are to the
//!   sensor (near surfaces get many more beams), the search touches fewer returns
//!   (Cartographer's voxel filter serves the same purpose), and the result does not
//!   depend on the beam order. (A first version kept returns at least that far from
//!   the previously kept one in beam order: a scan with its beams reversed then
//!   scored differently, and near-equal hypotheses swapped.)
//! - *Angular step* (unless set): the rotation that moves the farthest current return
//!   used by one cell along its arc, `r/d` (Hess et al., eq. 7, take the chord,
//!   `acos(1 − r²/(2d²))`, larger by a factor `1 + O(r²/d²)`; the arc makes the
//!   slack of a block of rotations an exact number of cells).
//! - *Grid extent*: the bounding box of the reference returns within
//!   [`CorrelativeParams::max_range`], padded by the kernel and the search window, so
//!   building it costs O(area / resolution²) bytes per depth.
//! - *Max-pooling by hand*: depth `h` is depth `h − 1` maxed with itself shifted by
//!   `2^(h−1)` cells along x, then along y (in place): two byte comparisons per cell
//!   and depth, which the compiler vectorises (Cartographer slides a window instead).
//!   An image crate computes the same windows as a grey-level dilation with a
//!   `2^h × 2^h` mask, `O(4^h)` a cell (why it is written by hand: the measurement
//!   is in `docs/decisions.md`, "Correlative search").
//! - *Several hypotheses*: the branch and bound keeps the `hypotheses` best lattice
//!   points that are pairwise distinct (non-maximum suppression: two motions closer
//!   than [`CorrelativeParams::suppression_translation`] in translation *and*
//!   [`CorrelativeParams::suppression_rotation`] in rotation are one mode, the
//!   better one is kept; a leaf that a later, better leaf of its mode displaces is
//!   not brought back, so the runners-up are those of a greedy suppression in the
//!   order the search met them) and prunes with the worst of them, so asking for more
//!   hypotheses costs more search; [`CorrelativeParams::min_relative_score`] keeps
//!   that cost down.
//!
//! [`CorrelativeMatcher::align`] refines the hypotheses with ICP and keeps the refined
//! motion that scores best (see there for why); [`CorrelativeIcpMatcher`] is that as
//! a [`ScanMatcher`] (`icp+csm`).
//!
//! ```
//! use pgm_scan::correlative::CorrelativeParams;
//! use pgm_scan::{ParamGuard, Pose2, Scan};
//!
//! // A room 8 m × 5 m seen from the origin and from a pose 0.3 m and 0.2 rad away.
//! let room = |pose: Pose2| -> Scan {
//!     let walls = [(-4.0, -2.5, 4.0, -2.5), (4.0, -2.5, 4.0, 2.5),
//!                  (4.0, 2.5, -4.0, 2.5), (-4.0, 2.5, -4.0, -2.5), (1.0, 0.5, 1.5, 1.2)];
//!     let angles: Vec<f64> = (0..361).map(|k| -1.5 + 3.0 * k as f64 / 360.0).collect();
//!     let ranges = angles.iter().map(|a| {
//!         let (dy, dx) = (pose.theta() + a).sin_cos();
//!         walls.iter().filter_map(|&(x1, y1, x2, y2): &(f64, f64, f64, f64)| {
//!             let (ex, ey) = (x2 - x1, y2 - y1);
//!             let den = dx * ey - dy * ex;
//!             let t = ((x1 - pose.x()) * ey - (y1 - pose.y()) * ex) / den;
//!             let u = ((x1 - pose.x()) * dy - (y1 - pose.y()) * dx) / den;
//!             (den.abs() > 1e-12 && t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
//!         }).fold(f64::INFINITY, f64::min)
//!     }).collect();
//!     Scan::from_ranges(angles, ranges, 30.0)
//! };
//! let truth = Pose2::new(0.3, -0.1, 0.2);
//! let matcher = CorrelativeParams::default().check().unwrap();
//! // A prior 0.7 m and 0.4 rad off.
//! let prior = Pose2::new(-0.3, 0.3, -0.2);
//! let found = matcher.search(&room(Pose2::identity()), &room(truth), prior).unwrap();
//! assert!(found[0].motion.translation_error(&truth) < 0.1, "{found:?}");
//! assert!(found[0].motion.rotation_error(&truth) < 0.02, "{found:?}");
//! ```

use crate::methods::{EgoMotionEstimate, ScanMatcher};
use crate::pair::ScanPair;
use crate::registration::{IcpMatcher, IcpParams, IcpResult, IcpStatus};
use crate::{Error, Pose2, Result, Scan};
use nalgebra::Point2;
use pgm_core::param::{InvalidParameter, ParamGuard};
use serde::Serialize;

/// Parameters of the correlative search (checked by [`CorrelativeParams::check`] into a
/// [`CorrelativeMatcher`]). Lengths in metres, angles in radians.
///
/// The defaults search the window the task asks for (±1 m, ±30°) and were chosen on
/// simulated and mit-csail pairs with `cargo run --release --example bad_start` and
/// `cargo bench --bench correlative` (see the README's measured results).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CorrelativeParams {
    /// Half-width of the translation window around the prior, along x and along y
    /// (m, default 1.0; the window is a square).
    pub translation_window: f64,
    /// Half-width of the rotation window around the prior (rad, default π/6 = 30°; at
    /// most π).
    pub rotation_window: f64,
    /// Side of a grid cell and translation step of the search (m, default 0.15: the
    /// hypotheses only need to fall in ICP's basin; 0.1 gave the same success on
    /// simulated and mit-csail pairs for twice the lookups and 2.5 times the grid).
    pub resolution: f64,
    /// Rotation step of the search (rad); `None` (default) derives it from the scan:
    /// the rotation moving the farthest current return used by one cell (module docs).
    pub angular_step: Option<f64>,
    /// Standard deviation `σ` of the Gaussian that blurs each reference return in the
    /// lookup grid (m, default 0.15, one cell); the grid holds it out to `3σ`.
    pub kernel_sigma: f64,
    /// Side of the voxel filter's cells: the score uses one current return per cell
    /// (m, default 0.2; 0 keeps every return).
    pub point_spacing: f64,
    /// Returns farther than this from their sensor are left out, of the grid and of
    /// the score (m, default 100); bounds the grid's size.
    pub max_range: f64,
    /// Number of distinct hypotheses returned, best first (default 3, at least 1).
    pub hypotheses: usize,
    /// Two motions whose translations differ by at most this much (m, default 0.3)…
    pub suppression_translation: f64,
    /// …and whose rotations differ by at most this much (rad, default 0.05) are one
    /// mode: only the better is a hypothesis.
    pub suppression_rotation: f64,
    /// Lowest score (mean grid value, in `[0, 1]`, default 0.05) of a hypothesis;
    /// motions explaining less are not returned, so the result may be empty.
    pub min_score: f64,
    /// Lowest score of a hypothesis as a fraction of the best one's (in `[0, 1]`,
    /// default 0.9): a mode far below the best is not worth an ICP run, and the
    /// search prunes with it as soon as the best is known.
    pub min_relative_score: f64,
}

impl Default for CorrelativeParams {
    fn default() -> Self {
        Self {
            translation_window: 1.0,
            rotation_window: std::f64::consts::FRAC_PI_6,
            resolution: 0.15,
            angular_step: None,
            kernel_sigma: 0.15,
            point_spacing: 0.2,
            max_range: 100.0,
            hypotheses: 3,
            suppression_translation: 0.3,
            suppression_rotation: 0.05,
            min_score: 0.05,
            min_relative_score: 0.9,
        }
    }
}

/// Most cells along one side of the search window or of the grid: keeps every
/// allocation bounded whatever the parameters (2^15 cells of 5 cm is 1.6 km).
const MAX_CELLS_PER_SIDE: f64 = 32_768.0;

/// Most bytes the grids of one reference scan may take, every depth (256 MiB).
const MAX_GRID_BYTES: f64 = 268_435_456.0;

/// Most rotations searched (one step of 1e-5 rad over ±π is 6.3e5).
const MAX_ROTATIONS: f64 = 1.0e6;

/// Deepest max-pooled grid: blocks of at most 2^7 × 2^7 translations (Cartographer's
/// default depth); wider windows start from several blocks per rotation.
const MAX_DEPTH: u32 = 7;

/// Largest lookup value (a return exactly on a reference return).
const FULL: u32 = 255;

impl CorrelativeParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        let p = self;
        InvalidParameter::non_negative(
            "translation_window",
            p.translation_window,
            "a finite number of metres >= 0",
        )?;
        if !(0.0..=std::f64::consts::PI).contains(&p.rotation_window) {
            return Err(InvalidParameter::new(
                "rotation_window",
                p.rotation_window,
                "radians in [0, π]",
            )
            .into());
        }
        InvalidParameter::positive("resolution", p.resolution, "a positive number of metres")?;
        InvalidParameter::positive("max_range", p.max_range, "a positive number of metres")?;
        if p.translation_window / p.resolution > MAX_CELLS_PER_SIDE
            || p.max_range / p.resolution > MAX_CELLS_PER_SIDE
        {
            return Err(InvalidParameter::new(
                "resolution",
                p.resolution,
                "at least translation_window and max_range over 32768 (grids of at most 2^16 cells a side)",
            )
            .into());
        }
        if let Some(step) = p.angular_step {
            InvalidParameter::positive("angular_step", step, "a positive number of radians")?;
            if p.rotation_window / step > MAX_ROTATIONS {
                return Err(InvalidParameter::new(
                    "angular_step",
                    step,
                    "at least rotation_window / 1e6",
                )
                .into());
            }
        }
        InvalidParameter::positive(
            "kernel_sigma",
            p.kernel_sigma,
            "a positive number of metres",
        )?;
        if p.kernel_sigma / p.resolution > 64.0 {
            return Err(InvalidParameter::new(
                "kernel_sigma",
                p.kernel_sigma,
                "at most 64 grid cells (64 × resolution)",
            )
            .into());
        }
        // The largest grid these parameters can build (`CorrelativeGrid::new`): returns
        // up to `max_range` on every side, the padding, every depth.
        let window_cells = (p.translation_window / p.resolution + 1e-9).floor();
        let depths = f64::from(top_depth(window_cells as i64) + 2);
        let radius = (3.0 * p.kernel_sigma / p.resolution).ceil();
        let side = 2.0 * (p.max_range / p.resolution).ceil()
            + 4.0 * window_cells
            + depths.exp2()
            + 2.0 * radius
            + 3.0;
        if side * side * depths > MAX_GRID_BYTES {
            return Err(InvalidParameter::new(
                "resolution",
                p.resolution,
                "a cell side giving grids of at most 2^28 bytes (about (2 max_range + 4 translation_window) / resolution cells a side, squared, once per depth)",
            )
            .into());
        }
        InvalidParameter::non_negative(
            "point_spacing",
            p.point_spacing,
            "a finite number of metres >= 0",
        )?;
        if p.hypotheses == 0 {
            return Err(InvalidParameter::new("hypotheses", p.hypotheses, "at least 1").into());
        }
        InvalidParameter::non_negative(
            "suppression_translation",
            p.suppression_translation,
            "a finite number of metres >= 0",
        )?;
        InvalidParameter::non_negative(
            "suppression_rotation",
            p.suppression_rotation,
            "a finite number of radians >= 0",
        )?;
        InvalidParameter::fraction("min_score", p.min_score)?;
        InvalidParameter::fraction("min_relative_score", p.min_relative_score)?;
        Ok(())
    }
}

/// One candidate motion found by the search.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Hypothesis {
    /// The motion mapping current points into the reference frame (a lattice point of
    /// the search, see the module docs).
    pub motion: Pose2,
    /// Mean lookup-grid value over the current returns used, in `[0, 1]`: 1 when every
    /// return lands on a reference return.
    pub score: f64,
}

pgm_core::checked_params! {
    /// The correlative matcher with checked parameters: builds the lookup grids of a
    /// reference scan ([`CorrelativeMatcher::reference`]) and searches motions
    /// ([`CorrelativeMatcher::search`], [`CorrelativeMatcher::align`]).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct CorrelativeMatcher(CorrelativeParams) -> Error;
}

/// What [`CorrelativeMatcher::align`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct CorrelativeAlignment {
    /// ICP's result from the chosen start: the estimated motion is `icp.motion`.
    pub icp: IcpResult,
    /// The hypothesis ICP started from; `None` when ICP started from the prior (the
    /// search found no hypothesis, or none gave ICP enough correspondences).
    pub start: Option<Hypothesis>,
    /// Every hypothesis of the search, best first.
    pub hypotheses: Vec<Hypothesis>,
}

impl CorrelativeMatcher {
    /// Builds the lookup grid and its max-pooled copies on `reference`'s valid
    /// returns within `max_range`, for any number of searches.
    ///
    /// # Errors
    /// [`Error::EmptyScan`] when no valid return lies within `max_range`.
    pub fn reference(&self, reference: &Scan) -> Result<CorrelativeGrid> {
        CorrelativeGrid::new(reference, self.params)
    }

    /// The best distinct motions mapping `current` into the frame of `reference`
    /// within the window around `prior`, best first: at most
    /// [`CorrelativeParams::hypotheses`], each scoring at least
    /// [`CorrelativeParams::min_score`] (so possibly none). The same as
    /// `self.reference(reference)?.search(current, prior)`.
    ///
    /// # Errors
    /// [`Error::EmptyScan`] when either scan has no valid return within `max_range`;
    /// [`Error::InvalidParameter`] (`prior`) for a non-finite prior.
    pub fn search(
        &self,
        reference: &Scan,
        current: &Scan,
        prior: Pose2,
    ) -> Result<Vec<Hypothesis>> {
        self.reference(reference)?.search(current, prior)
    }

    /// Search, then ICP (`icp`'s parameters) from every hypothesis; the result is the
    /// refined motion with the highest correlative score
    /// ([`CorrelativeGrid::score`], interpolated), ties going to the better-ranked
    /// hypothesis. Runs that kept their start for want of correspondences
    /// ([`IcpStatus::TooFewCorrespondences`]) never win; when every run did, the
    /// result is ICP from `prior` (which keeps the prior when it too matches too few
    /// returns: too little data keeps the prior). Without any hypothesis (nothing
    /// scores `min_score`) ICP starts from `prior`.
    ///
    /// Why the correlative score and not ICP's own figures: it is the objective the
    /// search ranked the hypotheses by, now at the refined motions instead of lattice
    /// points, and each return's contribution is bounded, so a moving object or
    /// clutter cannot outweigh the static scene; ICP's inlier count (returns within its
    /// final correspondence distance) can. On 2000 simulated pairs (preset mixed) from
    /// priors up to 1 m and 30 degrees off, choosing by the correlative score ended
    /// within 0.1 m and 0.02 rad of the truth on 99.2 %, by inliers on 98.5 %; on the
    /// 1044 mit-csail pairs less than 1.5 s apart on 96.2 % and 96.3 %. Refining the
    /// best hypothesis alone did about as well on those sets (99.2 %, 96.1 %): the
    /// runners-up are insurance for scenes with several near-equal modes (a corridor,
    /// a repeated facade), at one ICP run each.
    ///
    /// ICP should start with a short correspondence distance: a hypothesis lies within
    /// a cell or two of the optimum, and the 2 m of [`IcpParams`]'s default let moving
    /// cars drag the estimate (started at the *true* motion, default ICP ends within
    /// 0.1 m and 0.02 rad on 90.7 % of those simulated pairs, with 0.5 m on 99.9 %;
    /// search then default ICP: 90.1 %). [`CorrelativeIcpMatcher::default`] uses
    /// 0.5 m ([`CorrelativeIcpMatcher::refinement_icp`]).
    ///
    /// # Errors
    /// As [`CorrelativeMatcher::search`] and [`IcpMatcher::reference`].
    pub fn align(
        &self,
        reference: &Scan,
        current: &Scan,
        prior: Pose2,
        icp: &IcpMatcher,
    ) -> Result<CorrelativeAlignment> {
        let grid = self.reference(reference)?;
        let hypotheses = grid.search(current, prior)?;
        let icp = icp.reference(reference)?;
        let starts: Vec<Option<Hypothesis>> = if hypotheses.is_empty() {
            vec![None]
        } else {
            hypotheses.iter().copied().map(Some).collect()
        };
        let mut best: Option<(bool, f64, IcpResult, Option<Hypothesis>)> = None;
        for start in starts {
            let result = icp.align(current, start.map_or(prior, |h| h.motion))?;
            let kept = result.status != IcpStatus::TooFewCorrespondences;
            let score = grid.score(current, result.motion)?;
            if best
                .as_ref()
                .is_none_or(|(k, s, _, _)| (kept, score) > (*k, *s))
            {
                best = Some((kept, score, result, start));
            }
        }
        let (kept, _, result, start) = best.expect("at least one start");
        if !kept && start.is_some() {
            // Every run from a hypothesis matched too few returns for a rigid fit and
            // kept its hypothesis: too little data to trust the search either, so the
            // estimate is ICP from the prior (which keeps the prior in turn).
            return Ok(CorrelativeAlignment {
                icp: icp.align(current, prior)?,
                start: None,
                hypotheses,
            });
        }
        Ok(CorrelativeAlignment {
            icp: result,
            start,
            hypotheses,
        })
    }
}

/// The lookup grid of one reference scan and its max-pooled copies (depth `h` holds
/// the maximum over the `2^h × 2^h` cells starting at each cell); built by
/// [`CorrelativeMatcher::reference`], searched by [`CorrelativeGrid::search`].
#[derive(Clone)]
pub struct CorrelativeGrid {
    params: CorrelativeParams,
    /// Lower-left corner of cell (0, 0) in the reference frame (m).
    origin: [f64; 2],
    /// Cells along x (the row stride) and along y.
    width: usize,
    height: usize,
    /// First and last cell (inclusive) of the region where the lookup grid may be
    /// non-zero, along x and y.
    inner: [[i64; 2]; 2],
    /// Half-width of the translation window in cells (`K`).
    window_cells: i64,
    /// Number of depths (0 to `depths − 1`).
    depths: usize,
    /// The max-pooled grid of each depth, one after the other, each row-major; depth 0
    /// is the lookup grid itself.
    cells: Vec<u8>,
}

impl std::fmt::Debug for CorrelativeGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CorrelativeGrid")
            .field("params", &self.params)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("depths", &self.depths)
            .finish()
    }
}

/// A node of the branch and bound at depth `h`: the translations `dx .. dx + 2^h`
/// and `dy .. dy + 2^h` (cells from the prior's translation, both ends clipped to the
/// window) at the rotations `rotation .. rotation + 2^r` (steps from the first rotation
/// of the window), `r` the rotation level of depth `h`; `score` bounds the score of
/// every lattice point of the block in grid units (at depth 0 it is that score).
#[derive(Clone, Copy, Debug)]
struct Node {
    rotation: u32,
    dx: i32,
    dy: i32,
    score: u64,
}

impl Node {
    /// The node at `rotation` and the cell offset `(dx, dy)`, not yet scored.
    fn unscored(rotation: u32, dx: i32, dy: i32) -> Node {
        Node {
            rotation,
            dx,
            dy,
            score: 0,
        }
    }
}

/// One search: the current returns, the lattice, and the rotated returns of every
/// block of rotations visited so far.
struct Search<'a> {
    grid: &'a CorrelativeGrid,
    /// Current returns in cells (sensor frame divided by the resolution).
    points: Vec<[f64; 2]>,
    /// Their distances from the sensor in cells.
    ranges: Vec<f64>,
    /// Rotation step (rad), rotation of step 0 (rad), number of rotations.
    step: f64,
    first_angle: f64,
    rotations: u32,
    /// The prior's translation in cells from the grid's origin.
    translation: [f64; 2],
    /// Rotation level of each depth: a node of depth `h` spans `2^levels[h]` rotations.
    levels: Vec<u32>,
    /// Per rotation level, where each block's rotated returns start in `rotated`
    /// (`usize::MAX` until computed).
    slots: Vec<Vec<usize>>,
    /// Per computed block, one grid index per current return (see [`Search::block`]),
    /// the returns whose window is one translation block ("narrow") first.
    rotated: Vec<u32>,
    /// Per computed block, its number of narrow returns.
    narrow: Vec<usize>,
}

impl Search<'_> {
    /// The motion of a leaf (a lattice point).
    fn motion(&self, leaf: &Node, prior: Pose2) -> Pose2 {
        let res = self.grid.params.resolution;
        Pose2::new(
            prior.x() + f64::from(leaf.dx) * res,
            prior.y() + f64::from(leaf.dy) * res,
            self.first_angle + f64::from(leaf.rotation) * self.step,
        )
    }

    /// A score in grid units as the mean lookup value in `[0, 1]`.
    fn mean(&self, score: u64) -> f64 {
        score as f64 / (f64::from(FULL) * self.points.len() as f64)
    }

    /// Where the returns rotated for the block of `2^level` rotations starting at
    /// `start` begin in `rotated`, computing them on first use.
    ///
    /// Each return is rotated by the block's middle rotation and moved by the prior;
    /// any rotation of the block moves it by at most `ρ = range · (2^level − 1)/2 · step`
    /// (the arc; cells) from there, so it falls in the cells from `⌊x − ρ⌋` to
    /// `⌊x + ρ⌋`: the stored index is that window's lowest cell for the translation
    /// offset `(−K, −K)`. Returns whose window cannot reach the reference returns from
    /// any translation of the search get index 0, a corner of the grid that is zero at
    /// every depth.
    fn block(&mut self, level: u32, start: u32) -> (usize, usize) {
        let slot = &mut self.slots[level as usize][(start >> level) as usize];
        if *slot != usize::MAX {
            let at = *slot;
            return (at, self.narrow[at / self.points.len()]);
        }
        let at = self.rotated.len();
        *slot = at;
        let grid = self.grid;
        let k = grid.window_cells;
        let widest = 1i64 << (grid.depths - 1);
        let [[x_lo, x_hi], [y_lo, y_hi]] = grid.inner;
        let (x_lo, y_lo) = (x_lo - k - widest + 1, y_lo - k - widest + 1);
        let (x_hi, y_hi) = (x_hi + k, y_hi + k);
        let width = grid.width as i64;
        let half_span = ((1u64 << level) - 1) as f64 / 2.0;
        let angle = self.first_angle + (f64::from(start) + half_span) * self.step;
        let (sin, cos) = angle.sin_cos();
        let [tx, ty] = self.translation;
        // Narrow returns fill the block's slots from the front, wide ones from the
        // back (the order within each kind does not matter to a sum).
        let n = self.points.len();
        self.rotated.resize(at + n, 0);
        let slots = &mut self.rotated[at..];
        let (mut front, mut back) = (0, n);
        for (q, range) in self.points.iter().zip(&self.ranges) {
            // A hair more than the arc, against rounding in the rotations.
            let slack = if level == 0 {
                0.0
            } else {
                range * half_span * self.step + 1e-6
            };
            let x = cos * q[0] - sin * q[1] + tx;
            let y = sin * q[0] + cos * q[1] + ty;
            let (x0, y0, narrow) = if level == 0 {
                // No slack: the window is the cell itself.
                (floor(x), floor(y), true)
            } else {
                let (x0, y0) = (floor(x - slack), floor(y - slack));
                (x0, y0, floor(x + slack) == x0 && floor(y + slack) == y0)
            };
            let index = if x0 >= x_lo && x0 <= x_hi && y0 >= y_lo && y0 <= y_hi {
                ((y0 - k) * width + (x0 - k)) as u32
            } else {
                0
            };
            if narrow {
                slots[front] = index;
                front += 1;
            } else {
                back -= 1;
                slots[back] = index;
            }
        }
        self.narrow.push(front);
        (at, front)
    }

    /// The bound of `node` at depth `depth`: the sum over the returns of the grid
    /// holding the maximum over each return's window (depth `depth`, one deeper for a
    /// block of several rotations, whose windows are wider by the returns' slack).
    fn bound(&mut self, node: &Node, depth: usize) -> u64 {
        let level = self.levels[depth];
        let (at, narrow) = self.block(level, node.rotation);
        let grid = self.grid;
        let k = grid.window_cells as i32;
        let shift = (node.dy + k) as usize * grid.width + (node.dx + k) as usize;
        // Sums of bytes in u32 (exact below 2^24 returns), widened per block of them;
        // four running sums, so that the loads do not wait on one another (integers:
        // the same sum in any order).
        let sum = |indices: &[u32], depth: usize| -> u64 {
            let values = &grid.cells[depth * grid.width * grid.height + shift..];
            let at = |i: u32| u32::from(values[i as usize]);
            indices
                .chunks(1 << 24)
                .map(|chunk| {
                    let mut quads = chunk.chunks_exact(4);
                    let mut sums = [0u32; 4];
                    for q in &mut quads {
                        sums[0] += at(q[0]);
                        sums[1] += at(q[1]);
                        sums[2] += at(q[2]);
                        sums[3] += at(q[3]);
                    }
                    let rest: u32 = quads.remainder().iter().map(|&i| at(i)).sum();
                    u64::from(sums.iter().sum::<u32>() + rest)
                })
                .sum()
        };
        let (narrow, wide) = self.rotated[at..at + self.points.len()].split_at(narrow);
        sum(narrow, depth)
            + if wide.is_empty() {
                0
            } else {
                sum(wide, depth + 1)
            }
    }

    /// Depth-first branch and bound over `nodes` (sorted best first) of depth `depth`
    /// (Hess et al., Algorithm 3, with blocks of rotations as well as translations).
    fn branch(&mut self, nodes: &[Node], depth: usize, best: &mut Best) {
        let k = self.grid.window_cells as i32;
        for node in nodes {
            if node.score <= best.threshold() {
                break;
            }
            if depth == 0 {
                best.offer(*node);
                continue;
            }
            let level = self.levels[depth];
            let span = 1i32 << depth;
            let extent = [span.min(k - node.dx + 1), span.min(k - node.dy + 1)];
            if best.dominated(node, 1 << level, extent) {
                continue;
            }
            let half = 1i32 << (depth - 1);
            let child_level = self.levels[depth - 1];
            let mut children = [*node; 8];
            let mut count = 0;
            for rotation in [node.rotation, node.rotation + (1 << child_level)] {
                if rotation >= self.rotations || (rotation != node.rotation && child_level == level)
                {
                    continue;
                }
                for (ox, oy) in [(0, 0), (half, 0), (0, half), (half, half)] {
                    let (dx, dy) = (node.dx + ox, node.dy + oy);
                    if dx <= k && dy <= k {
                        let mut child = Node::unscored(rotation, dx, dy);
                        child.score = self.bound(&child, depth - 1);
                        children[count] = child;
                        count += 1;
                    }
                }
            }
            let children = &mut children[..count];
            sort_nodes(children);
            self.branch(children, depth - 1, best);
        }
    }
}

impl CorrelativeGrid {
    fn new(reference: &Scan, params: CorrelativeParams) -> Result<Self> {
        let points = returns_within(reference, params.max_range);
        if points.is_empty() {
            return Err(Error::EmptyScan { which: "reference" });
        }
        let res = params.resolution;
        let window_cells = (params.translation_window / res + 1e-9).floor() as i64;
        // Blocks of several rotations read one depth deeper than their translations.
        let depth = top_depth(window_cells) + u32::from(params.rotation_window > 0.0);
        let widest = 1i64 << depth;
        let radius = (3.0 * params.kernel_sigma / res).ceil() as i64;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &points {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        // Padding: the windows of the search that can reach the inner region, from
        // the returns kept by `Search::block`, stay inside the grid, and the cells
        // `[0, 2K]²` (where dropped returns read) are zero at every depth.
        let pad_low = 2 * window_cells + widest + radius;
        let pad_high = 2 * window_cells + radius + 1;
        let mut origin = [0.0; 2];
        let mut size = [0usize; 2];
        let mut inner = [[0i64; 2]; 2];
        for a in 0..2 {
            let first = (lo[a] / res).floor() as i64;
            let last = (hi[a] / res).floor() as i64;
            origin[a] = (first - pad_low) as f64 * res;
            inner[a] = [pad_low - radius, pad_low + (last - first) + radius];
            size[a] = (pad_low + (last - first) + pad_high + 1) as usize;
        }
        let (width, height) = (size[0], size[1]);
        let area = width * height;
        let depths = depth as usize + 1;
        // One allocation for every depth: freed and allocated again per pair, a block
        // this size is reused by the allocator instead of being faulted in anew.
        let mut cells = vec![0u8; area * depths];
        let fine = &mut cells[..area];
        // exp(−d²/2σ²) = exp(−dx²/2σ²) · exp(−dy²/2σ²): 2(2R + 1) exponentials a return.
        let inverse_two_sigma2 = 1.0 / (2.0 * params.kernel_sigma * params.kernel_sigma);
        let side = (2 * radius + 1) as usize;
        let (mut along_x, mut along_y) = (vec![0.0; side], vec![0.0; side]);
        for p in &points {
            let cx = floor((p[0] - origin[0]) / res);
            let cy = floor((p[1] - origin[1]) / res);
            for (i, (wx, wy)) in along_x.iter_mut().zip(along_y.iter_mut()).enumerate() {
                let offset = i as i64 - radius;
                let ex = origin[0] + ((cx + offset) as f64 + 0.5) * res - p[0];
                let ey = origin[1] + ((cy + offset) as f64 + 0.5) * res - p[1];
                *wx = f64::from(FULL) * (-ex * ex * inverse_two_sigma2).exp();
                *wy = (-ey * ey * inverse_two_sigma2).exp();
            }
            for (i, wy) in along_y.iter().enumerate() {
                let row = (cy - radius + i as i64) as usize * width + (cx - radius) as usize;
                for (cell, wx) in fine[row..row + side].iter_mut().zip(&along_x) {
                    // Rounded to the nearest unit (`as` truncates; the value is >= 0).
                    *cell = (*cell).max((wx * wy + 0.5) as u8);
                }
            }
        }
        for h in 1..depths {
            let (done, rest) = cells.split_at_mut(h * area);
            let next = &mut rest[..area];
            let shift = 1usize << (h - 1);
            max_shifted(&done[(h - 1) * area..], next, shift);
            max_in_place(next, shift * width);
        }
        Ok(Self {
            params,
            origin,
            width,
            height,
            inner,
            window_cells,
            depths,
            cells,
        })
    }

    /// The parameters the grid was built with.
    pub fn params(&self) -> &CorrelativeParams {
        &self.params
    }

    /// Number of cells along x and along y (padding for the search included).
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The score of `motion` for `current`: the mean over the current returns used
    /// (valid, within `max_range`, decimated) of the lookup grid at each moved return,
    /// interpolated bilinearly between cell centres, in `[0, 1]`. The search scores its
    /// lattice points by the cell each return falls in instead (no interpolation);
    /// this is the score of any motion, such as ICP's refinements of the hypotheses.
    ///
    /// # Errors
    /// [`Error::EmptyScan`] when `current` has no valid return within `max_range`;
    /// [`Error::InvalidParameter`] (`motion`) for a non-finite motion.
    pub fn score(&self, current: &Scan, motion: Pose2) -> Result<f64> {
        if !motion.is_finite() {
            return Err(InvalidParameter::new("motion", motion, "a finite motion").into());
        }
        let points = self.current_points(current)?;
        let fine = &self.cells[..self.width * self.height];
        let res = self.params.resolution;
        let value = |x: i64, y: i64| -> f64 {
            if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
                f64::from(fine[y as usize * self.width + x as usize])
            } else {
                0.0
            }
        };
        let total: f64 = points
            .iter()
            .map(|p| {
                let q = motion.transform_point(&Point2::new(p[0], p[1]));
                // Cell centres at integer coordinates.
                let u = (q.x - self.origin[0]) / res - 0.5;
                let v = (q.y - self.origin[1]) / res - 0.5;
                if !(u.abs() < 1e9 && v.abs() < 1e9) {
                    return 0.0;
                }
                let (x, y) = (floor(u), floor(v));
                let (a, b) = (u - x as f64, v - y as f64);
                (1.0 - b) * ((1.0 - a) * value(x, y) + a * value(x + 1, y))
                    + b * ((1.0 - a) * value(x, y + 1) + a * value(x + 1, y + 1))
            })
            .sum();
        Ok(total / (f64::from(FULL) * points.len() as f64))
    }

    /// The current returns the score uses: valid, within `max_range`, decimated by a
    /// voxel filter of cell side `point_spacing` (sensor frame, m): in each cell the
    /// return nearest to the cell's centre (ties: the smaller coordinates), in cell
    /// order. The result does not depend on the beam order.
    fn current_points(&self, current: &Scan) -> Result<Vec<[f64; 2]>> {
        let all = returns_within(current, self.params.max_range);
        if all.is_empty() {
            return Err(Error::EmptyScan { which: "current" });
        }
        let side = self.params.point_spacing;
        if side == 0.0 {
            return Ok(all);
        }
        let mut cells: std::collections::BTreeMap<(i64, i64), ([f64; 2], f64)> =
            std::collections::BTreeMap::new();
        for p in all {
            let (cx, cy) = ((p[0] / side).floor(), (p[1] / side).floor());
            let (dx, dy) = (p[0] - (cx + 0.5) * side, p[1] - (cy + 0.5) * side);
            let d2 = dx * dx + dy * dy;
            // Keyed by row first: the search then reads the grid (row-major) in order.
            let entry = cells.entry((cy as i64, cx as i64)).or_insert((p, d2));
            if d2 < entry.1 || (d2 == entry.1 && (p[0], p[1]) < (entry.0[0], entry.0[1])) {
                *entry = (p, d2);
            }
        }
        Ok(cells.into_values().map(|(p, _)| p).collect())
    }

    /// The best distinct motions of `current` within the window around `prior`, best
    /// first (see [`CorrelativeMatcher::search`]).
    ///
    /// # Errors
    /// [`Error::EmptyScan`] when `current` has no valid return within `max_range`;
    /// [`Error::InvalidParameter`] (`prior`) for a non-finite prior.
    pub fn search(&self, current: &Scan, prior: Pose2) -> Result<Vec<Hypothesis>> {
        let mut search = self.prepare(current, prior)?;
        let p = &self.params;
        let top = search.levels.len() - 1;
        let rotations = search.rotations;
        // Every block of the top depth.
        let k = self.window_cells as i32;
        let width = 1i32 << top;
        let top_level = search.levels[top];
        let mut nodes = Vec::new();
        for rotation in (0..rotations).step_by(1 << top_level) {
            for dy in (-k..=k).step_by(width as usize) {
                for dx in (-k..=k).step_by(width as usize) {
                    let mut node = Node::unscored(rotation, dx, dy);
                    node.score = search.bound(&node, top);
                    nodes.push(node);
                }
            }
        }
        let mut best = Best {
            kept: Vec::with_capacity(p.hypotheses + 1),
            capacity: p.hypotheses,
            floor: ((p.min_score * f64::from(FULL) * search.points.len() as f64).ceil() as u64)
                .max(1),
            same_translation: p.suppression_translation / p.resolution,
            same_rotation: p.suppression_rotation / search.step,
            relative: p.min_relative_score,
        };
        sort_nodes(&mut nodes);
        search.branch(&nodes, top, &mut best);
        Ok(best
            .into_leaves()
            .iter()
            .map(|n| Hypothesis {
                motion: search.motion(n, prior),
                score: search.mean(n.score),
            })
            .collect())
    }

    /// The search of `current` from `prior`: its returns, lattice and rotation levels.
    fn prepare(&self, current: &Scan, prior: Pose2) -> Result<Search<'_>> {
        if !prior.is_finite() {
            return Err(InvalidParameter::new("prior", prior, "a finite starting motion").into());
        }
        let points = self.current_points(current)?;
        let p = &self.params;
        let res = p.resolution;
        let ranges: Vec<f64> = points.iter().map(|q| q[0].hypot(q[1]) / res).collect();
        let farthest = ranges.iter().copied().fold(0.0f64, f64::max);
        let step = p
            .angular_step
            .unwrap_or_else(|| derived_angular_step(farthest));
        let each_side = (p.rotation_window / step + 0.5 - 1e-9).floor().max(0.0) as u32;
        let rotations = 2 * each_side + 1;
        let top = self.depths - 1 - usize::from(self.depths > 1 && p.rotation_window > 0.0);
        // Rotation level of each depth: the widest block of rotations whose slack
        // (farthest return, cells) fits the translation block, so the windows stay
        // within one more depth.
        let levels: Vec<u32> = (0..=top)
            .map(|h| {
                if self.depths <= h + 1 {
                    return 0;
                }
                (0..=h as u32)
                    .rev()
                    .find(|&r| {
                        let slack = farthest * ((1u64 << r) - 1) as f64 / 2.0 * step + 1e-6;
                        r == 0 || (2.0 * slack).ceil() <= (1u64 << h) as f64
                    })
                    .unwrap_or(0)
            })
            .collect();
        Ok(Search {
            grid: self,
            points: points.iter().map(|q| [q[0] / res, q[1] / res]).collect(),
            ranges,
            step,
            first_angle: prior.theta() - f64::from(each_side) * step,
            rotations,
            translation: [
                (prior.x() - self.origin[0]) / res,
                (prior.y() - self.origin[1]) / res,
            ],
            slots: levels
                .iter()
                .map(|&r| vec![usize::MAX; rotations.div_ceil(1 << r) as usize])
                .collect(),
            levels,
            rotated: Vec::new(),
            narrow: Vec::new(),
        })
    }
}

/// The distinct best leaves found so far (non-maximum suppressed), best first.
struct Best {
    kept: Vec<Node>,
    capacity: usize,
    /// Lowest score a hypothesis may have (grid units, at least 1).
    floor: u64,
    /// Suppression distances in cells and in rotation steps.
    same_translation: f64,
    same_rotation: f64,
    /// Lowest score of a hypothesis relative to the best.
    relative: f64,
}

impl Best {
    /// A node must score above this to change the result.
    fn threshold(&self) -> u64 {
        let worst = if self.kept.len() == self.capacity {
            self.kept[self.capacity - 1].score
        } else {
            self.floor - 1
        };
        worst.max(self.relative_floor().saturating_sub(1))
    }

    /// Lowest score a hypothesis may have relative to the best kept so far.
    fn relative_floor(&self) -> u64 {
        self.kept
            .first()
            .map_or(0, |b| (b.score as f64 * self.relative).ceil() as u64)
    }

    /// The kept leaves, best first, without those that fell below the relative floor
    /// when a better leaf came after them.
    fn into_leaves(self) -> Vec<Node> {
        let floor = self.relative_floor();
        self.kept.into_iter().filter(|k| k.score >= floor).collect()
    }

    fn same_mode(&self, a: &Node, b: &Node) -> bool {
        let (dx, dy) = (f64::from(a.dx - b.dx), f64::from(a.dy - b.dy));
        dx.hypot(dy) <= self.same_translation + 1e-9
            && (f64::from(a.rotation) - f64::from(b.rotation)).abs() <= self.same_rotation + 1e-9
    }

    /// Whether every lattice point of `node`'s block (rotations `node.rotation ..
    /// node.rotation + rotations`, translations `node.dx .. node.dx + extent[0]` and
    /// `node.dy .. node.dy + extent[1]`) is of the mode of a kept leaf scoring at least
    /// `node.score`: then none of them can be kept.
    fn dominated(&self, node: &Node, rotations: u32, extent: [i32; 2]) -> bool {
        // Farthest lattice coordinate of `low .. low + count` from `at`.
        let reach =
            |low: i32, count: i32, at: i32| (at - low).abs().max((low + count - 1 - at).abs());
        self.kept.iter().any(|k| {
            let turn = k
                .rotation
                .abs_diff(node.rotation)
                .max((node.rotation + rotations - 1).abs_diff(k.rotation));
            let (x, y) = (
                reach(node.dx, extent[0], k.dx),
                reach(node.dy, extent[1], k.dy),
            );
            k.score >= node.score
                && f64::from(turn) <= self.same_rotation + 1e-9
                && f64::from(x).hypot(f64::from(y)) <= self.same_translation + 1e-9
        })
    }

    /// Takes a leaf scoring above [`Best::threshold`]: dropped when a kept leaf of the
    /// same mode scores at least as well, else kept in place of the worse leaves of its
    /// mode.
    fn offer(&mut self, leaf: Node) {
        if self
            .kept
            .iter()
            .any(|k| k.score >= leaf.score && self.same_mode(k, &leaf))
        {
            return;
        }
        let kept = std::mem::take(&mut self.kept);
        self.kept = kept
            .into_iter()
            .filter(|k| !self.same_mode(k, &leaf))
            .collect();
        let at = self.kept.partition_point(|k| k.score >= leaf.score);
        self.kept.insert(at, leaf);
        self.kept.truncate(self.capacity);
    }
}

/// Best bound first; ties by rotation and offsets, so the search is deterministic.
fn sort_nodes(nodes: &mut [Node]) {
    nodes.sort_unstable_by(|a, b| {
        b.score
            .cmp(&a.score)
            .then(a.rotation.cmp(&b.rotation))
            .then(a.dy.cmp(&b.dy))
            .then(a.dx.cmp(&b.dx))
    });
}

/// `destination[i] = max(source[i], source[i + shift])`, `source[i]` where `i + shift`
/// is past the end: the pooling along x of one depth into the next. A shift wraps
/// into the next row's first cells, which are padding and zero at every depth that
/// reads them (see `CorrelativeGrid::new`).
fn max_shifted(source: &[u8], destination: &mut [u8], shift: usize) {
    let n = source.len();
    let shift = shift.min(n);
    for ((d, a), b) in destination[..n - shift]
        .iter_mut()
        .zip(&source[..n - shift])
        .zip(&source[shift..])
    {
        *d = (*a).max(*b);
    }
    destination[n - shift..].copy_from_slice(&source[n - shift..]);
}

/// `cells[i] = max(cells[i], cells[i + shift])` for every `i + shift` inside, in place
/// (ascending `i` reads only cells not yet written): the pooling along y, with a
/// shift of whole rows.
fn max_in_place(cells: &mut [u8], shift: usize) {
    let n = cells.len();
    if shift == 0 {
        return;
    }
    let mut start = 0;
    while start + shift < n {
        let end = (start + shift).min(n - shift);
        let (head, tail) = cells.split_at_mut(start + shift);
        for (a, b) in head[start..end].iter_mut().zip(&tail[..end - start]) {
            *a = (*a).max(*b);
        }
        start = end;
    }
}

/// The depth of the coarsest grid: the smallest whose blocks cover the whole window
/// of `2K + 1` translations per axis, at most [`MAX_DEPTH`].
fn top_depth(window_cells: i64) -> u32 {
    let span = (2 * window_cells + 1) as u64;
    span.next_power_of_two().trailing_zeros().min(MAX_DEPTH)
}

/// The rotation that moves a return `farthest` cells from the sensor by one cell along
/// its arc, a hair less so that rounding cannot make it more, at most π (Hess et al.,
/// eq. 7, take the chord, `acos(1 − 1/(2 farthest²))`, larger by a factor `1 +
/// O(1/farthest²)`; the arc makes the slack of a block of rotations an exact number of
/// cells).
fn derived_angular_step(farthest: f64) -> f64 {
    if farthest <= 1.0 / std::f64::consts::PI {
        return std::f64::consts::PI;
    }
    (1.0 - 1e-9) / farthest
}

/// The valid returns of `scan` within `max_range` of the sensor, in beam order (m,
/// sensor frame); beams with a non-finite range or angle are skipped even if marked
/// valid (a hand-built scan may break [`Scan`]'s invariants).
fn returns_within(scan: &Scan, max_range: f64) -> Vec<[f64; 2]> {
    (0..scan.len().min(scan.angles.len()).min(scan.valid.len()))
        .filter(|&k| {
            scan.valid[k]
                && scan.ranges[k].is_finite()
                && scan.ranges[k] <= max_range
                && scan.angles[k].is_finite()
        })
        .map(|k| {
            let p = scan.beam_point(k);
            [p.x, p.y]
        })
        .collect()
}

/// Correlative search, then ICP from its hypotheses ([`CorrelativeMatcher::align`]),
/// as a [`ScanMatcher`] named `icp+csm`, started from the pair's odometry prior (the
/// identity without one).
///
/// The default searches with [`CorrelativeParams::default`] and refines with
/// [`CorrelativeIcpMatcher::refinement_icp`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CorrelativeIcpMatcher {
    /// The search.
    pub correlative: CorrelativeMatcher,
    /// The refinement.
    pub icp: IcpMatcher,
}

impl Default for CorrelativeIcpMatcher {
    fn default() -> Self {
        Self {
            correlative: CorrelativeMatcher::default(),
            icp: Self::refinement_icp()
                .check()
                .expect("the refinement parameters are valid"),
        }
    }
}

impl CorrelativeIcpMatcher {
    /// Search with `correlative`, refine with `icp`.
    pub fn new(correlative: CorrelativeMatcher, icp: IcpMatcher) -> Self {
        Self { correlative, icp }
    }

    /// ICP's parameters for refining a hypothesis: [`IcpParams::default`] with a first
    /// correspondence distance of 0.5 m instead of 2 m (see
    /// [`CorrelativeMatcher::align`] for why).
    pub fn refinement_icp() -> IcpParams {
        IcpParams {
            initial_max_distance: 0.5,
            ..IcpParams::default()
        }
    }

    /// [`CorrelativeMatcher::align`] on `pair` from its odometry prior. Errors name the
    /// pair.
    pub fn align_pair(&self, pair: &ScanPair) -> Result<CorrelativeAlignment> {
        self.correlative
            .align(
                &pair.reference,
                &pair.current,
                pair.odometry.unwrap_or_default(),
                &self.icp,
            )
            .map_err(|e| e.in_pair(&pair.name))
    }
}

impl ScanMatcher for CorrelativeIcpMatcher {
    fn name(&self) -> &str {
        "icp+csm"
    }

    fn estimate(&self, pair: &ScanPair) -> Result<EgoMotionEstimate> {
        let found = self.align_pair(pair)?;
        let r = &found.icp;
        Ok(EgoMotionEstimate {
            motion: r.motion,
            converged: r.converged,
            iterations: r.iterations,
            note: match (r.status, found.start) {
                (IcpStatus::Converged, Some(_)) => None,
                (IcpStatus::Converged, None) => {
                    Some("no usable correlative hypothesis: ICP from the prior".into())
                }
                (IcpStatus::IterationLimit, _) => Some("iteration limit".into()),
                (IcpStatus::TooFewCorrespondences, _) => Some(format!(
                    "{} correspondences, fewer than the {} a rigid fit needs: kept the prior",
                    r.inliers,
                    self.icp.params().min_correspondences
                )),
            },
        })
    }
}

/// `⌊x⌋` as an integer, without a call into libm (finite `x` well inside the `i64`
/// range, as every grid coordinate is).
#[inline]
fn floor(x: f64) -> i64 {
    let truncated = x as i64;
    truncated - i64::from((truncated as f64) > x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_scenes::{first_hit, uniform, Segment, ROOM};

    /// The room ([`ROOM`]) with a box, seen from `pose` by 181 beams over 270
    /// degrees.
    fn room_scan(pose: &Pose2) -> Scan {
        let corner_box: [Segment; 2] = [(-2.0, -1.0, -1.2, -1.0), (-1.2, -1.0, -1.2, -0.4)];
        let walls = [&ROOM[..], &corner_box[..]].concat();
        let angles: Vec<f64> = (0..181).map(|k| -2.35 + 4.7 * k as f64 / 180.0).collect();
        let ranges = angles
            .iter()
            .map(|a| {
                first_hit((pose.x(), pose.y()), pose.theta() + a, &walls).unwrap_or(f64::INFINITY)
            })
            .collect();
        Scan::from_ranges(angles, ranges, 30.0)
    }

    #[test]
    fn pooled_grids_hold_window_maxima() {
        let grid = CorrelativeParams::default()
            .check()
            .unwrap()
            .reference(&room_scan(&Pose2::identity()))
            .unwrap();
        let (w, h) = (grid.width, grid.height);
        let fine = &grid.cells[..w * h];
        assert!(fine.iter().any(|&v| v > 200));
        let mut state = 3;
        for depth in 1..grid.depths {
            let side = 1usize << depth;
            let pooled = &grid.cells[depth * w * h..(depth + 1) * w * h];
            for _ in 0..2000 {
                let x = (uniform(&mut state) * (w - side) as f64) as usize;
                let y = (uniform(&mut state) * (h - side) as f64) as usize;
                let naive = (y..y + side)
                    .flat_map(|yy| fine[yy * w + x..yy * w + x + side].iter())
                    .copied()
                    .max()
                    .unwrap();
                assert_eq!(pooled[y * w + x], naive, "depth {depth} at ({x}, {y})");
            }
        }
    }

    /// Every lattice score of a search, computed directly (rotate, translate, look up
    /// the cell), as `scores[rotation][dy + K][dx + K]`.
    fn lattice_scores(grid: &CorrelativeGrid, search: &Search, prior: Pose2) -> Vec<Vec<Vec<u64>>> {
        let k = grid.window_cells as i32;
        let fine = &grid.cells[..grid.width * grid.height];
        (0..search.rotations)
            .map(|rotation| {
                (-k..=k)
                    .map(|dy| {
                        (-k..=k)
                            .map(|dx| {
                                let leaf = Node::unscored(rotation, dx, dy);
                                let motion = search.motion(&leaf, prior);
                                let (sin, cos) = motion.theta().sin_cos();
                                search
                                    .points
                                    .iter()
                                    .map(|q| {
                                        // The search rotates about the prior's translation
                                        // and then shifts by whole cells.
                                        let x = cos * q[0] - sin * q[1] + search.translation[0];
                                        let y = sin * q[0] + cos * q[1] + search.translation[1];
                                        let (cx, cy) =
                                            (floor(x) + i64::from(dx), floor(y) + i64::from(dy));
                                        if cx >= 0
                                            && cy >= 0
                                            && (cx as usize) < grid.width
                                            && (cy as usize) < grid.height
                                        {
                                            u64::from(fine[cy as usize * grid.width + cx as usize])
                                        } else {
                                            0
                                        }
                                    })
                                    .sum()
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect()
    }

    /// Checks every node of every depth against the lattice, then the search against
    /// the exhaustive maximum.
    /// Priors within 0.3 m and 0.15 rad of the truth moved by `offset` (m).
    fn check_exact(params: CorrelativeParams, priors: usize, seed: u64, offset: [f64; 2]) {
        let truth = Pose2::new(0.25, -0.1, 0.12);
        let reference = room_scan(&Pose2::identity());
        let current = room_scan(&truth);
        let grid = params.check().unwrap().reference(&reference).unwrap();
        let k = grid.window_cells as i32;
        let mut state = seed;
        for _ in 0..priors {
            let prior = Pose2::new(
                truth.x() + offset[0] + 0.6 * (uniform(&mut state) - 0.5),
                truth.y() + offset[1] + 0.6 * (uniform(&mut state) - 0.5),
                truth.theta() + 0.3 * (uniform(&mut state) - 0.5),
            );
            let mut search = grid.prepare(&current, prior).unwrap();
            let scores = lattice_scores(&grid, &search, prior);
            let top = search.levels.len() - 1;
            for depth in 0..=top {
                let span = 1i32 << depth;
                let level = search.levels[depth];
                for rotation in (0..search.rotations).step_by(1 << level) {
                    for dy in (-k..=k).step_by(span as usize) {
                        for dx in (-k..=k).step_by(span as usize) {
                            let node = Node::unscored(rotation, dx, dy);
                            let bound = search.bound(&node, depth);
                            let last = (rotation + (1 << level)).min(search.rotations);
                            let best = (rotation..last)
                                .flat_map(|r| {
                                    let scores = &scores[r as usize];
                                    (dy..(dy + span).min(k + 1)).flat_map(move |y| {
                                        (dx..(dx + span).min(k + 1)).map(move |x| {
                                            scores[(y + k) as usize][(x + k) as usize]
                                        })
                                    })
                                })
                                .max()
                                .unwrap();
                            if depth == 0 {
                                assert_eq!(bound, best, "leaf {node:?}");
                            } else {
                                assert!(bound >= best, "depth {depth} {node:?}: {bound} < {best}");
                            }
                        }
                    }
                }
            }
            let maximum = scores.iter().flatten().flatten().copied().max().unwrap();
            let found = grid.search(&current, prior).unwrap();
            if search.mean(maximum) < params.min_score || maximum == 0 {
                assert!(found.is_empty(), "{found:?}");
                continue;
            }
            assert!(
                (found[0].score - search.mean(maximum)).abs() < 1e-12,
                "best {} against the exhaustive {}",
                found[0].score,
                search.mean(maximum)
            );
            for (i, a) in found.iter().enumerate() {
                assert!(a.score >= params.min_relative_score * found[0].score - 1e-12);
                for b in &found[..i] {
                    assert!(
                        a.motion.translation_error(&b.motion) > params.suppression_translation
                            || a.motion.rotation_error(&b.motion) > params.suppression_rotation,
                        "{a:?} and {b:?} are one mode"
                    );
                }
            }
        }
    }

    #[test]
    fn bounds_hold_and_the_best_is_the_exhaustive_best() {
        let small = CorrelativeParams {
            translation_window: 0.5,
            rotation_window: 0.2,
            resolution: 0.1,
            kernel_sigma: 0.1,
            hypotheses: 3,
            min_relative_score: 0.5,
            ..CorrelativeParams::default()
        };
        check_exact(small, 4, 1, [0.0, 0.0]);
        // Most returns outside the grid.
        check_exact(small, 2, 5, [3.5, -2.0]);
        // A coarse step (blocks of fewer rotations than translations), a single
        // rotation, a single translation.
        check_exact(
            CorrelativeParams {
                angular_step: Some(0.05),
                ..small
            },
            2,
            2,
            [0.0, 0.0],
        );
        check_exact(
            CorrelativeParams {
                rotation_window: 0.0,
                ..small
            },
            2,
            3,
            [0.0, 0.0],
        );
        check_exact(
            CorrelativeParams {
                translation_window: 0.0,
                ..small
            },
            2,
            4,
            [0.0, 0.0],
        );
    }

    #[test]
    fn finds_the_motion_from_a_bad_prior() {
        let truth = Pose2::new(0.3, -0.2, 0.25);
        let matcher = CorrelativeMatcher::default();
        let reference = room_scan(&Pose2::identity());
        let current = room_scan(&truth);
        let prior = Pose2::new(-0.4, 0.4, -0.2);
        let found = matcher.search(&reference, &current, prior).unwrap();
        assert!(
            found[0].motion.translation_error(&truth) < 0.15,
            "{found:?}"
        );
        assert!(found[0].motion.rotation_error(&truth) < 0.03, "{found:?}");
        let refined = CorrelativeIcpMatcher::default();
        let aligned = matcher
            .align(&reference, &current, prior, &refined.icp)
            .unwrap();
        let m = aligned.icp.motion;
        assert!(m.translation_error(&truth) < 0.02, "{m:?}");
        assert!(m.rotation_error(&truth) < 0.005, "{m:?}");
        assert!(aligned.start.is_some());
        let score = matcher
            .reference(&reference)
            .unwrap()
            .score(&current, truth)
            .unwrap();
        // Most returns of the room sit on the blurred walls at the truth (0.80 with the
        // voxel filter; a wrong motion scores far lower, see the search above).
        assert!(score > 0.75, "{score}");
    }

    #[test]
    fn broken_returns_are_no_returns() {
        // Hand-built scans that break `Scan`'s invariants: a valid beam with a NaN
        // range or angle is skipped, never a panic.
        let mut scan = room_scan(&Pose2::identity());
        scan.ranges[3] = f64::NAN;
        scan.angles[5] = f64::INFINITY;
        let matcher = CorrelativeMatcher::default();
        let found = matcher.search(&scan, &scan, Pose2::identity()).unwrap();
        assert!(found[0].motion.translation_error(&Pose2::identity()) < 0.2);
        let mut broken = scan.clone();
        broken.ranges.iter_mut().for_each(|r| *r = f64::NAN);
        assert!(matches!(
            matcher.search(&broken, &scan, Pose2::identity()),
            Err(Error::EmptyScan { which: "reference" })
        ));
    }
}
