//! The scan-pair methods from Python, looked up in the facade's registry by the names
//! `--method`, `--associations` and `--matcher` take on the command line: scan
//! matching (ego-motion), point association and motion clustering of two scans.

use crate::{float_array, pgm_err, PgmError};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pgm::methods::{association_source, clusterer, scan_matcher, MethodOptions};
use pgm_scan::pair::{Association, ScanPair};
use pgm_scan::{Pose2, Scan};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A scan from a dict with `ranges` (m) and `angles` (rad), one per beam, and
/// `max_range` (m); optional `valid` (bool per beam; without it a beam is a return
/// when its range is finite and inside (0, max_range), and other ranges become 0) and
/// `stamp` (s). One row of what the readers return.
pub(crate) fn scan_of(which: &str, d: &Bound<'_, PyDict>) -> PyResult<Scan> {
    let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
        d.get_item(key)?.ok_or_else(|| {
            PgmError::new_err(format!(
                "{which}: no `{key}` (a scan has ranges, angles and max_range)"
            ))
        })
    };
    let vector = |key: &str, unit: &str| -> PyResult<Vec<f64>> {
        let a = float_array(&get(key)?, &format!("{which}.{key}"))?;
        if a.ndim() != 1 {
            return Err(PgmError::new_err(format!(
                "{which}.{key}: {} axes, expected one value per beam ({unit})",
                a.ndim()
            )));
        }
        Ok(a.as_array().iter().copied().collect())
    };
    let ranges = vector("ranges", "metres")?;
    let angles = vector("angles", "radians")?;
    let max_range: f64 = get("max_range")?
        .extract()
        .map_err(|e| PgmError::new_err(format!("{which}.max_range: {e} (a number of metres)")))?;
    if ranges.len() != angles.len() {
        return Err(PgmError::new_err(format!(
            "{which}: {} ranges but {} angles (one of each per beam)",
            ranges.len(),
            angles.len()
        )));
    }
    let mut scan = match d.get_item("valid")? {
        // The readers' own flags, and their ranges as read (a return beyond the
        // maximum range is kept: free-space tests read it).
        Some(valid) => {
            let valid: Vec<bool> = valid.extract()?;
            if valid.len() != ranges.len() {
                return Err(PgmError::new_err(format!(
                    "{which}.valid: {} flags for {} beams",
                    valid.len(),
                    ranges.len()
                )));
            }
            let mut scan = Scan::from_ranges(angles, ranges.clone(), max_range);
            scan.ranges = ranges;
            scan.valid = valid;
            scan
        }
        None => Scan::from_ranges(angles, ranges, max_range),
    };
    if let Some(stamp) = d.get_item("stamp")? {
        scan.timestamp = stamp
            .extract()
            .map_err(|e| PgmError::new_err(format!("{which}.stamp: {e} (a time in seconds)")))?;
    }
    scan.validate()
        .map_err(|e| PgmError::new_err(format!("{which}: {e}")))?;
    Ok(scan)
}

/// `[x, y, theta]` as a pose, or an error naming `name`.
pub(crate) fn pose_of(name: &str, v: &[f64]) -> PyResult<Pose2> {
    match v {
        [x, y, theta] if v.iter().all(|c| c.is_finite()) => Ok(Pose2::new(*x, *y, *theta)),
        [_, _, _] => Err(PgmError::new_err(format!(
            "{name} = {v:?}: expected finite numbers [x, y, theta]"
        ))),
        _ => Err(PgmError::new_err(format!(
            "{name}: {} numbers, expected 3: [x, y, theta] (m, m, rad)",
            v.len()
        ))),
    }
}

fn pair_of(
    reference: &Bound<'_, PyDict>,
    current: &Bound<'_, PyDict>,
    odometry: Option<Vec<f64>>,
) -> PyResult<ScanPair> {
    let odometry = odometry.map(|v| pose_of("odometry", &v)).transpose()?;
    let pair = ScanPair {
        name: "python".into(),
        reference: scan_of("reference", reference)?,
        current: scan_of("current", current)?,
        odometry,
        truth: None,
    };
    pair.validate().map_err(|e| pgm_err(None, e))?;
    Ok(pair)
}

fn pose(p: &Pose2) -> [f64; 3] {
    [p.x(), p.y(), p.theta()]
}

/// The ego-motion of `current` in the frame of `reference` by the scan matcher
/// `matcher` (`odometry`, `icp`, `icp+csm`, `crf-matching`, `joint`), started from
/// the `odometry` prior `[x, y, theta]` (the motion of the sensor from the reference
/// scan to the current one, in the reference frame) when given.
///
/// Returns `motion` (`[x, y, theta]`), `converged` and `iterations`.
#[pyfunction]
#[pyo3(signature = (reference, current, odometry=None, matcher="icp"))]
pub fn match_scans<'py>(
    py: Python<'py>,
    reference: &Bound<'py, PyDict>,
    current: &Bound<'py, PyDict>,
    odometry: Option<Vec<f64>>,
    matcher: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let pair = pair_of(reference, current, odometry)?;
    let method = scan_matcher(matcher, &MethodOptions::default()).map_err(|e| pgm_err(None, e))?;
    let estimate = py
        .detach(|| method.estimate(&pair))
        .map_err(|e| pgm_err(None, e))?;
    let d = PyDict::new(py);
    d.set_item("motion", PyArray1::from_slice(py, &pose(&estimate.motion)))?;
    d.set_item("converged", estimate.converged)?;
    d.set_item("iterations", estimate.iterations)?;
    Ok(d)
}

/// Point associations of `current`'s returns to `reference`'s by the association
/// source `source` (`icp`, `segment-icp` or `crf-matching`, as `--associations`; `true`
/// needs ground truth, which a pair from Python does not carry).
///
/// Returns `partners` (int64 per current beam: the reference beam it corresponds to,
/// −1 an outlier, −2 a beam without a return) and `ego_motion` (`[x, y, theta]`, NaN
/// when the source does not estimate one).
#[pyfunction]
#[pyo3(signature = (reference, current, odometry=None, source="crf-matching"))]
pub fn associate<'py>(
    py: Python<'py>,
    reference: &Bound<'py, PyDict>,
    current: &Bound<'py, PyDict>,
    odometry: Option<Vec<f64>>,
    source: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let pair = pair_of(reference, current, odometry)?;
    let method =
        association_source(source, &MethodOptions::default()).map_err(|e| pgm_err(None, e))?;
    let found = py
        .detach(|| method.associate(&pair))
        .map_err(|e| pgm_err(None, e))?;
    let partners: Vec<i64> = found
        .associations
        .iter()
        .map(|a| match a {
            Some(Association::Point(k)) => *k as i64,
            Some(Association::Outlier) => -1,
            None => -2,
        })
        .collect();
    let d = PyDict::new(py);
    d.set_item("partners", PyArray1::from_vec(py, partners))?;
    let ego = found.ego_motion.map_or([f64::NAN; 3], |p| pose(&p));
    d.set_item("ego_motion", PyArray1::from_slice(py, &ego))?;
    Ok(d)
}

/// Moving-object detection on a pair: the returns of `current` labelled by common
/// motion by the clustering method `method` (`crf`, `cbd`, `kmeans`, `one-cluster`,
/// `joint`, as `--method`), fed by the association source `associations` where the
/// method takes one.
///
/// Returns `labels` (int64 per current beam: 0 the background, k ≥ 1 a moving
/// cluster, −1 a beam without a return), `motions` (one row `[label, x, y, theta]`
/// per cluster with an estimated motion: the motion that maps the cluster's current
/// returns onto their reference positions, the convention of the ego-motion, so a
/// static background's motion is the ego-motion), `ego_motion` (NaN when not estimated),
/// `iterations` and `converged`.
#[pyfunction]
#[pyo3(signature = (reference, current, odometry=None, method="crf", associations="crf-matching"))]
pub fn cluster<'py>(
    py: Python<'py>,
    reference: &Bound<'py, PyDict>,
    current: &Bound<'py, PyDict>,
    odometry: Option<Vec<f64>>,
    method: &str,
    associations: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let pair = pair_of(reference, current, odometry)?;
    let options = MethodOptions::default();
    let source = association_source(associations, &options).map_err(|e| pgm_err(None, e))?;
    let method = clusterer(method, source, &options).map_err(|e| pgm_err(None, e))?;
    let found = py
        .detach(|| method.cluster(&pair))
        .map_err(|e| pgm_err(None, e))?;
    let labels: Vec<i64> = found
        .labels
        .iter()
        .map(|l| l.map_or(-1, i64::from))
        .collect();
    let motions: Vec<f64> = found
        .motions
        .iter()
        .flat_map(|m| {
            let [x, y, theta] = pose(&m.motion);
            [f64::from(m.label), x, y, theta]
        })
        .collect();
    let d = PyDict::new(py);
    d.set_item("labels", PyArray1::from_vec(py, labels))?;
    let rows = found.motions.len();
    let motions: Bound<'py, PyArray2<f64>> = PyArray1::from_vec(py, motions).reshape([rows, 4])?;
    d.set_item("motions", motions)?;
    let ego = found.ego_motion.map_or([f64::NAN; 3], |p| pose(&p));
    d.set_item("ego_motion", PyArray1::from_slice(py, &ego))?;
    d.set_item("iterations", found.iterations)?;
    d.set_item("converged", found.converged)?;
    Ok(d)
}
