//! Ego-motion over a sequence: each scan's motion predicted from the previous steps
//! (a constant-velocity model, as KISS-ICP does: I. Vizzo et al., "KISS-ICP: In
//! Defense of Point-to-Point ICP", RA-L 2023) or taken from the wheel odometry, then
//! registered against the previous scan without the returns of the tracked movers,
//! within the platform's motion limits.
//!
//! **Why not the pair alone.** Registration of two scans finds the motion that brings
//! the most returns into agreement. A person walking just ahead of the robot at its
//! speed, or a car beside it, can hold most of the returns of a sparse scene; their
//! motion is then the one ICP finds, and the world seems to move. Three things keep
//! the background the world here:
//! - the *prediction* (the last step's motion, scaled to this step's duration, or the
//!   odometry) starts the registration where the world will be, and the hypothesis
//!   that ICP reaches from it competes with the one it reaches from rest;
//! - the *support* of a hypothesis counts the current scan's returns once per cell of
//!   a grid of [`EgoParams::voxel`] metres (a person 1 m ahead covers a few cells
//!   whatever the number of its returns; the background's posts, trunks and walls many
//!   cells), and the returns of the tracks reported moving are left out of both scans;
//! - hypotheses that the platform cannot drive ([`EgoParams::max_speed`],
//!   [`EgoParams::max_yaw_rate`]) are refused.

use super::scale;
use pgm_core::{InvalidParameter, ParamGuard};
use pgm_scan::alignment::{refine_point_to_line, SurfacePair, POINT_TO_POINT_WEIGHT};
use pgm_scan::pair::Association;
use pgm_scan::registration::{Icp, IcpParams, IcpResult};
use pgm_scan::scan::surface_model;
use pgm_scan::{Pose2, Result, Scan};
use std::collections::HashSet;

/// Parameters of [`EgoMotion`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EgoParams {
    /// Fastest the platform drives (m/s); a hypothesis implying more is refused (3.0:
    /// above a wheelchair's, a walking robot's and an indoor platform's top speed; set
    /// it to the platform's for a car).
    pub max_speed: f64,
    /// Fastest the platform turns (rad/s); a hypothesis implying more is refused (3.0).
    pub max_yaw_rate: f64,
    /// Cell size (m) of the grid by which a hypothesis's support counts returns once
    /// per cell (0.2).
    pub voxel: f64,
    /// Distance (m) within which a current return agrees with the previous scan (0.1,
    /// ICP's final correspondence distance).
    pub inlier_distance: f64,
    /// The registration (point-to-point ICP).
    pub icp: IcpParams,
}

impl Default for EgoParams {
    fn default() -> Self {
        Self {
            max_speed: 3.0,
            max_yaw_rate: 3.0,
            voxel: 0.2,
            inlier_distance: 0.1,
            icp: IcpParams::default(),
        }
    }
}

impl ParamGuard for EgoParams {
    type Checked = EgoMotion;
    type Error = pgm_scan::Error;

    fn check_ref(&self) -> Result<()> {
        InvalidParameter::positive("max_speed", self.max_speed, "a speed in m/s > 0")?;
        InvalidParameter::positive("max_yaw_rate", self.max_yaw_rate, "a rate in rad/s > 0")?;
        InvalidParameter::positive("voxel", self.voxel, "a cell size in metres > 0")?;
        InvalidParameter::positive(
            "inlier_distance",
            self.inlier_distance,
            "a distance in metres > 0",
        )?;
        self.icp.check_ref()
    }

    fn check(self) -> Result<EgoMotion> {
        self.check_ref()?;
        Ok(EgoMotion {
            params: self,
            velocity: None,
            periods: std::collections::VecDeque::with_capacity(PERIODS),
        })
    }
}

/// Where a step's ego-motion came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EgoSource {
    /// Registration started from the wheel odometry.
    Odometry,
    /// Registration started from the constant-velocity prediction.
    Prediction,
    /// Registration started from rest (the identity).
    Rest,
    /// No hypothesis was feasible and supported: the prediction (or the odometry)
    /// itself.
    Predicted,
}

/// One step's ego-motion.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct EgoStep {
    /// The pose of the current sensor frame in the previous one (maps current points
    /// into the previous frame), m and rad.
    pub motion: Pose2,
    /// Seconds since the previous scan.
    pub dt: f64,
    /// Which hypothesis won.
    pub source: EgoSource,
    /// Grid cells of the current scan's returns (movers left out) that agree with the
    /// previous scan under `motion`, and the cells there were.
    pub support: usize,
    /// Cells there were.
    pub cells: usize,
}

/// The sequence ego-motion estimator (checked [`EgoParams`]); it keeps the last
/// step's velocity for the next prediction.
#[derive(Clone, Debug, PartialEq)]
pub struct EgoMotion {
    params: EgoParams,
    /// The last step's motion and its duration.
    velocity: Option<(Pose2, f64)>,
    /// The durations of the last [`PERIODS`] steps (over every sequence: a property
    /// of the sensor).
    periods: std::collections::VecDeque<f64>,
}

/// Steps over which the sensor's typical scan period is taken ([`EgoMotion::feasible`]).
const PERIODS: usize = 25;

impl EgoMotion {
    /// The parameters.
    pub fn params(&self) -> &EgoParams {
        &self.params
    }

    /// Forgets the velocity (a new sequence).
    pub fn reset(&mut self) {
        self.velocity = None;
    }

    /// The prior of the step from `previous` to `current`: the wheel odometry when
    /// both scans have it, else the last step's motion scaled to this step's duration
    /// (the identity at a sequence's start).
    pub fn predict(&self, previous: &Scan, current: &Scan) -> (Pose2, EgoSource) {
        let dt = current.timestamp - previous.timestamp;
        match (previous.laser_odometry(), current.laser_odometry()) {
            (Some(a), Some(b)) => (a.between(&b), EgoSource::Odometry),
            _ => match self.velocity {
                Some((m, dt0)) if dt0 > 0.0 => (scale(&m, dt / dt0), EgoSource::Prediction),
                _ => (Pose2::identity(), EgoSource::Rest),
            },
        }
    }

    /// The sensor's typical scan period (s): the median duration of the last 25
    /// steps; `None` before the first.
    pub fn period(&self) -> Option<f64> {
        let mut d: Vec<f64> = self.periods.iter().copied().collect();
        if d.is_empty() {
            return None;
        }
        d.sort_by(f64::total_cmp);
        Some(d[d.len() / 2])
    }

    /// Whether the platform can drive `motion` in `dt` seconds, or in the sensor's
    /// typical period when that is longer ([`EgoMotion::period`]): a log whose stamps
    /// run late or early (intel-lab's go backwards 97 times, and two scans half a
    /// second apart may be stamped 0.03 s apart) must not have its true motion refused.
    pub fn feasible(&self, motion: &Pose2, dt: f64) -> bool {
        let p = &self.params;
        let dt = self.period().map_or(dt, |period| dt.max(period));
        motion.is_finite()
            && motion.translation().norm() <= p.max_speed * dt
            && motion.theta().abs() <= p.max_yaw_rate * dt
    }

    /// The motion from `previous` to `current` (see the module docs), leaving out the
    /// beams whose entry in `previous_movers` / `current_movers` is true (empty slices
    /// leave out nothing), and remembers it for the next prediction.
    ///
    /// # Errors
    /// The registration's parameter errors (scans without returns fall back to the
    /// prediction).
    pub fn estimate(
        &mut self,
        previous: &Scan,
        previous_movers: &[bool],
        current: &Scan,
        current_movers: &[bool],
    ) -> Result<EgoStep> {
        let p = self.params;
        let dt = current.timestamp - previous.timestamp;
        let (prior, prior_source) = self.predict(previous, current);
        let reference = without(previous, previous_movers);
        let full = without(current, current_movers);
        let source = cells_of(&full, p.voxel);
        let cells = source.valid_count();
        let mut best = EgoStep {
            motion: prior,
            dt,
            source: EgoSource::Predicted,
            support: 0,
            cells,
        };
        if reference.valid_count() >= 2 && cells >= 2 {
            let icp = Icp::new(&reference, p.icp)?;
            best.support = support(&icp, &source, &prior, p.inlier_distance);
            // The first correspondence distance of each run: narrow and wide from the
            // prior, wide from rest (one tree for all).
            let narrow = (4.0 * p.inlier_distance).max(p.icp.final_max_distance);
            let wide = p.icp.initial_max_distance;
            let mut hypotheses: Vec<(f64, Pose2, EgoSource)> =
                vec![(narrow, prior, prior_source), (wide, prior, prior_source)];
            if prior_source != EgoSource::Odometry {
                hypotheses.push((wide, Pose2::identity(), EgoSource::Rest));
            }
            for (first, start, from) in hypotheses {
                // Registered on every return; the support counts one per cell.
                let Ok(run) = icp.align_best(&full, &[(start, first)]) else {
                    continue;
                };
                let motion = point_to_line(&reference, &full, &run);
                if !self.feasible(&motion, dt) {
                    continue;
                }
                let s = support(&icp, &source, &motion, p.inlier_distance);
                // More support wins; a tie goes to the earlier (nearer the prior).
                if s > best.support || (best.source == EgoSource::Predicted && s == best.support) {
                    best = EgoStep {
                        motion,
                        dt,
                        source: from,
                        support: s,
                        cells,
                    };
                }
            }
        }
        // An infeasible prediction is no prediction; measured odometry is kept (the
        // platform drove it, whatever the configured limits say).
        if best.source == EgoSource::Predicted
            && prior_source != EgoSource::Odometry
            && !self.feasible(&best.motion, dt)
        {
            best.motion = Pose2::identity();
        }
        self.velocity = (dt > 0.0).then_some((best.motion, dt));
        if dt > 0.0 && dt.is_finite() {
            if self.periods.len() == PERIODS {
                self.periods.pop_front();
            }
            self.periods.push_back(dt);
        }
        Ok(best)
    }
}

/// ICP's motion refined by the point-to-line metric on its final correspondences
/// ([`refine_point_to_line`]): point-to-point ICP on surfaces sampled at the beam
/// spacing pins each return to a sampled one, which holds the motion back along walls
/// seen at a grazing angle.
fn point_to_line(reference: &Scan, source: &Scan, run: &IcpResult) -> Pose2 {
    let (points, beams) = reference.points();
    let model = surface_model(&points, reference.angle_increment());
    let mut index = vec![usize::MAX; reference.len()];
    for (i, &b) in beams.iter().enumerate() {
        index[b] = i;
    }
    let pairs: Vec<SurfacePair> = run
        .associations
        .iter()
        .enumerate()
        .filter_map(|(b, a)| match a {
            Some(Association::Point(k)) if index[*k] != usize::MAX => {
                let m = &model[index[*k]];
                Some(SurfacePair {
                    source: source.beam_point(b),
                    target: m.point,
                    normal: m.normal,
                    variance: 1.0,
                })
            }
            _ => None,
        })
        .collect();
    if pairs.len() < 3 {
        return run.motion;
    }
    let refined = refine_point_to_line(run.motion, &pairs, POINT_TO_POINT_WEIGHT, None);
    if refined.is_finite() {
        refined
    } else {
        run.motion
    }
}

/// `scan` without the beams marked in `movers`.
fn without(scan: &Scan, movers: &[bool]) -> Scan {
    let mut out = scan.clone();
    for (v, &m) in out.valid.iter_mut().zip(movers) {
        if m {
            *v = false;
        }
    }
    out
}

/// `scan` with one return per grid cell of `voxel` metres (the first in beam order).
fn cells_of(scan: &Scan, voxel: f64) -> Scan {
    let mut out = scan.clone();
    let mut seen = HashSet::new();
    for b in 0..out.len() {
        if out.valid[b] {
            let q = scan.beam_point(b);
            let cell = ((q.x / voxel).floor() as i64, (q.y / voxel).floor() as i64);
            if !seen.insert(cell) {
                out.valid[b] = false;
            }
        }
    }
    out
}

/// Returns of `source` that have a reference return within `inlier` metres under
/// `motion`.
fn support(icp: &Icp, source: &Scan, motion: &Pose2, inlier: f64) -> usize {
    (0..source.len())
        .filter(|&b| source.valid[b])
        .filter(|&b| {
            icp.nearest_reference(&motion.transform_point(&source.beam_point(b)), inlier)
                .is_some()
        })
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A room of four walls seen from `(x, 0)`, 361 beams over 360°, stamped `t`.
    fn room(x: f64, theta: f64, t: f64) -> Scan {
        let n = 361;
        let angles: Vec<f64> = (0..n)
            .map(|k| -std::f64::consts::PI + k as f64 * 2.0 * std::f64::consts::PI / n as f64)
            .collect();
        let ranges = angles
            .iter()
            .map(|a| {
                let (s, c) = (a + theta).sin_cos();
                // Walls at x = -3 and 5, y = -2 and 4 (a non-square room).
                let tx = if c > 0.0 {
                    (5.0 - x) / c
                } else {
                    (-3.0 - x) / c
                };
                let ty = if s > 0.0 { 4.0 / s } else { -2.0 / s };
                tx.min(ty)
            })
            .collect();
        let mut scan = Scan::from_ranges(angles, ranges, 20.0);
        scan.timestamp = t;
        scan
    }

    #[test]
    fn a_late_stamp_does_not_refuse_the_true_motion() {
        let mut ego = EgoParams::default().check().unwrap();
        // Ten steps at rest, 0.5 s apart: the typical period is 0.5 s.
        for k in 0..10 {
            let (a, b) = (
                room(0.0, 0.0, 0.5 * k as f64),
                room(0.0, 0.0, 0.5 * (k + 1) as f64),
            );
            ego.estimate(&a, &[], &b, &[]).unwrap();
        }
        assert_eq!(ego.period(), Some(0.5));
        // Then a turn of 0.25 rad stamped only 0.03 s after the previous scan: 8 rad/s
        // by the stamps, beyond the 3 rad/s limit, but within it over the period.
        let previous = room(0.0, 0.0, 5.5);
        let current = room(0.0, 0.25, 5.53);
        let step = ego.estimate(&previous, &[], &current, &[]).unwrap();
        assert!(
            (step.motion.theta() - 0.25).abs() < 0.01,
            "{:?} from {:?}",
            step.motion,
            step.source
        );
        // Without the history (a fresh estimator) the stamps alone refuse it.
        let mut fresh = EgoParams::default().check().unwrap();
        let step = fresh.estimate(&previous, &[], &current, &[]).unwrap();
        assert!(step.motion.theta().abs() < 0.1, "{:?}", step.motion);
    }
}
