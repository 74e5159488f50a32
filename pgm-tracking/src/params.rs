//! The tracker's parameters, checked once ([`ParamGuard`]).

#[allow(unused_imports)]
use super::*;
use pgm_core::{InvalidParameter, ParamGuard};
use pgm_scan::registration::IcpParams;
use pgm_scan::{Error, Result};

/// Parameters of the [`Tracker`] (checked by [`ParamGuard::check`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackingParams {
    /// Slowest speed (m/s) that counts as moving (0.5: the walking-speed threshold by
    /// which the leigh-gtm1 and datmo labels call a person or a car moving).
    pub min_speed: f64,
    /// Largest distance (m) from a predicted return to a current return that the track
    /// may take (0.3).
    pub gate: f64,
    /// Inlier distance (m) of the measured motion, and truncation of its costs (0.1,
    /// ICP's final correspondence distance).
    pub inlier_distance: f64,
    /// Smallest fraction of a track's returns that must have an inlier for it to be
    /// found (0.5).
    pub min_inlier_fraction: f64,
    /// The measured motion must bring the truncated cost below this fraction of each
    /// static explanation's cost to count as evidence of motion (0.5, segment-wise
    /// ICP's `improvement`).
    pub improvement: f64,
    /// Fewest returns of a track (3, CRF-Clustering's smallest object).
    pub min_returns: usize,
    /// Scans a track survives without being found (3).
    pub max_coast: usize,
    /// Longest gap (s) between consecutive current scans of one sequence (1).
    pub max_gap: f64,
    /// Shortest gap (s) between consecutive current scans of one sequence (0.01: two
    /// sweeps of a 2D laser are at least 13 ms apart even at 75 Hz, so closer stamps
    /// are a log's artefact, over which no speed can be measured; such a scan starts a
    /// new sequence).
    pub min_step: f64,
    /// Steps with evidence of motion (a detection, or the track found moving) that a
    /// track needs for its objects to be reported, once it could be followed at
    /// least once (2: an object that no later scan shows moving is dropped from every
    /// pair; a track that ends with the sequence before it could be followed keeps
    /// its objects; 1 drops only the detections that the previous scan shows slower
    /// than [`TrackingParams::min_speed`]).
    pub min_evidence: usize,
    /// Weight of a step's measured motion in the track's velocity (the beta of an
    /// alpha-beta filter; 1 keeps the last measurement only) (0.5).
    pub smoothing: f64,
    /// Follow every confirmed track backward in time from its first detection, over
    /// the scans before the detector saw it, and report it where a step shows it
    /// moving (true; see the module docs).
    pub backward: bool,
    /// ICP between consecutive current scans, and of each requested pair for its
    /// ego-motion when the detection ran on the consecutive pair.
    pub ego: IcpParams,
}

impl Default for TrackingParams {
    fn default() -> Self {
        Self {
            min_speed: 0.5,
            gate: 0.3,
            inlier_distance: 0.1,
            min_inlier_fraction: 0.5,
            improvement: 0.5,
            min_returns: 3,
            max_coast: 3,
            max_gap: 1.0,
            min_step: 0.01,
            min_evidence: 2,
            smoothing: 0.5,
            backward: true,
            ego: IcpParams::default(),
        }
    }
}

impl ParamGuard for TrackingParams {
    type Checked = Tracker;
    type Error = Error;

    fn check_ref(&self) -> Result<()> {
        InvalidParameter::non_negative("min_speed", self.min_speed, "a finite speed in m/s >= 0")?;
        InvalidParameter::positive("gate", self.gate, "a distance in metres > 0")?;
        InvalidParameter::positive(
            "inlier_distance",
            self.inlier_distance,
            "a distance in metres > 0",
        )?;
        InvalidParameter::fraction("min_inlier_fraction", self.min_inlier_fraction)?;
        in_unit_interval("improvement", self.improvement, "a factor in (0, 1]")?;
        if self.min_returns < 2 {
            return Err(InvalidParameter::new(
                "min_returns",
                self.min_returns,
                "at least 2 (a rigid fit needs two points)",
            )
            .into());
        }
        check_scan_gaps(self.max_gap, self.min_step)?;
        if self.min_evidence == 0 {
            return Err(InvalidParameter::new("min_evidence", 0, "at least 1").into());
        }
        in_unit_interval("smoothing", self.smoothing, "a weight in (0, 1]")?;
        self.ego.check_ref()
    }

    fn check(self) -> Result<Tracker> {
        self.check_ref()?;
        Ok(Tracker { params: self })
    }
}

/// `Ok(())` when `value` lies in `(0, 1]`, else the error naming `name`.
fn in_unit_interval(
    name: &'static str,
    value: f64,
    expected: &'static str,
) -> std::result::Result<(), InvalidParameter> {
    if value > 0.0 && value <= 1.0 {
        Ok(())
    } else {
        Err(InvalidParameter::new(name, value, expected))
    }
}

/// The scan-gap parameters of both trackers: `max_gap` a positive time, `min_step`
/// at least 0 and below it (seconds).
pub(crate) fn check_scan_gaps(max_gap: f64, min_step: f64) -> Result<()> {
    InvalidParameter::positive("max_gap", max_gap, "a time in seconds > 0")?;
    if !(min_step >= 0.0 && min_step < max_gap) {
        return Err(InvalidParameter::new(
            "min_step",
            min_step,
            "a time in seconds >= 0 and below max_gap",
        )
        .into());
    }
    Ok(())
}
