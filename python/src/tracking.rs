//! The online tracker from Python: push one scan, get that scan's objects (no
//! look-ahead), as `pgm track` does.

use crate::methods::scan_of;
use crate::{pgm_err, PgmError};
use numpy::{PyArray1, PyArrayMethods};
use pgm::methods::{association_source, clusterer, MethodOptions};
use pgm_scan::methods::MotionClusterer;
use pgm_tracking::online::{OnlineParams, OnlineTracker, TrackState};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

type Detector = Box<dyn MotionClusterer>;

self_cell::self_cell!(
    struct TrackerCell {
        owner: Detector,
        #[covariant]
        dependent: OnlineTracker,
    }
);

/// Moving objects followed online over a stream of scans.
///
/// `OnlineTracker(method="crf", associations="crf-matching", k=None)`: the detector is
/// the clustering method `method` of the command line's registry, fed by the
/// association source `associations`; `k` pairs each scan with the one `k` scans
/// before (default: the scan about 0.3 s before). `push(scan)` takes the next scan (a
/// dict as `pgm.scan` gives, with its `stamp`, and optionally `odometry` `[x, y,
/// theta]`, the ego-motion prior) and returns that scan's report.
#[pyclass(name = "OnlineTracker", module = "pgm", unsendable)]
pub struct PyOnlineTracker {
    cell: TrackerCell,
}

fn state_name(s: TrackState) -> &'static str {
    match s {
        TrackState::Tentative => "tentative",
        TrackState::Confirmed => "confirmed",
        TrackState::Coasting => "coasting",
        TrackState::Stopped => "stopped",
    }
}

#[pymethods]
impl PyOnlineTracker {
    #[new]
    #[pyo3(signature = (method="crf", associations="crf-matching", k=None))]
    fn new(method: &str, associations: &str, k: Option<i64>) -> PyResult<Self> {
        let k = k.map(|k| crate::count("k", k)).transpose()?;
        let options = MethodOptions::default();
        let source = association_source(associations, &options).map_err(|e| pgm_err(None, e))?;
        let detector = clusterer(method, source, &options).map_err(|e| pgm_err(None, e))?;
        let params = OnlineParams {
            k,
            ..OnlineParams::default()
        };
        let cell = TrackerCell::try_new(detector, |d| params.tracker(d.as_ref()))
            .map_err(|e| pgm_err(None, e))?;
        Ok(Self { cell })
    }

    /// Takes in the next scan and returns its report: `index`, `time` (s),
    /// `sequence`, `pose` (`[x, y, theta]` of this scan's sensor in the frame of its
    /// sequence's first scan), `converged`, and `objects`, a dict of arrays with one
    /// entry per track alive in this scan: `track` (id, unique within the scan and
    /// stable over time), `state` (tentative, confirmed, coasting, stopped),
    /// `detected`, `centre` (m, this scan's sensor frame), `velocity` (m/s) with
    /// `velocity_covariance` (2 x 2), `extent` (m, along and across its heading),
    /// `score` (in [0, 1]) and `beams` (a list of beam-index arrays).
    fn push<'py>(
        &mut self,
        py: Python<'py>,
        scan: &Bound<'py, PyDict>,
    ) -> PyResult<Bound<'py, PyDict>> {
        if scan.get_item("stamp")?.is_none() {
            return Err(PgmError::new_err(
                "scan: no `stamp`: the tracker places each scan in time (seconds; pgm.scan(log, i) gives it)",
            ));
        }
        let mut s = scan_of("scan", scan)?;
        if let Some(odometry) = scan.get_item("odometry")? {
            let v: Vec<f64> = odometry.extract().map_err(|e| {
                PgmError::new_err(format!("scan.odometry: {e} (expected [x, y, theta])"))
            })?;
            // A row of NaN (a log without odometry at this scan) is no prior.
            if !v.iter().all(|c| c.is_nan()) {
                s.odometry = Some(crate::methods::pose_of("scan.odometry", &v)?);
            }
        }
        let report = self
            .cell
            .with_dependent_mut(|_, tracker| py.detach(|| tracker.push(s)))
            .map_err(|e| pgm_err(None, e))?;
        let d = PyDict::new(py);
        d.set_item("index", report.index)?;
        d.set_item("time", report.time)?;
        d.set_item("sequence", report.sequence)?;
        let p = &report.pose;
        d.set_item("pose", PyArray1::from_slice(py, &[p.x(), p.y(), p.theta()]))?;
        d.set_item("converged", report.converged)?;
        let objects = &report.objects;
        let o = PyDict::new(py);
        let ids: Vec<i64> = objects.iter().map(|t| t.track as i64).collect();
        o.set_item("track", PyArray1::from_vec(py, ids))?;
        let states: Vec<&str> = objects.iter().map(|t| state_name(t.state)).collect();
        o.set_item("state", states)?;
        let detected: Vec<bool> = objects.iter().map(|t| t.detected).collect();
        o.set_item("detected", PyArray1::from_vec(py, detected))?;
        let n = objects.len();
        let flat = |f: &dyn Fn(&pgm_tracking::online::TrackedObject) -> Vec<f64>| -> Vec<f64> {
            objects.iter().flat_map(f).collect()
        };
        o.set_item(
            "centre",
            PyArray1::from_vec(py, flat(&|t| t.centre.to_vec())).reshape([n, 2])?,
        )?;
        o.set_item(
            "velocity",
            PyArray1::from_vec(py, flat(&|t| t.velocity.to_vec())).reshape([n, 2])?,
        )?;
        let covariance = flat(&|t| t.velocity_covariance.iter().flatten().copied().collect());
        o.set_item(
            "velocity_covariance",
            PyArray1::from_vec(py, covariance).reshape([n, 2, 2])?,
        )?;
        o.set_item(
            "extent",
            PyArray1::from_vec(py, flat(&|t| t.extent.to_vec())).reshape([n, 2])?,
        )?;
        let scores: Vec<f64> = objects.iter().map(|t| t.score).collect();
        o.set_item("score", PyArray1::from_vec(py, scores))?;
        let beams = PyList::empty(py);
        for t in objects {
            let b: Vec<i64> = t.beams.iter().map(|&k| k as i64).collect();
            beams.append(PyArray1::from_vec(py, b))?;
        }
        o.set_item("beams", beams)?;
        d.set_item("objects", o)?;
        Ok(d)
    }
}
