//! Laser logs into numpy: CARMEN logs, leigh-style text logs, ROS 1 bags and MCAP
//! files, read by pgm's own readers (the same checks, notes and errors as the CLI).

use crate::pgm_err;
use numpy::{Element, PyArray1, PyArray2, PyArrayMethods};
use pgm_datasets::bag::{read_bag, BagTopics, StampedPose};
use pgm_datasets::carmen::{read_carmen_with, CarmenOptions};
use pgm_datasets::leigh::read_scans_with;
use pgm_datasets::stamps::StampClock;
use pgm_scan::Scan;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

fn clock(name: &str) -> PyResult<StampClock> {
    name.parse()
        .map_err(|e: String| crate::PgmError::new_err(format!("clock: {e}")))
}

/// `rows` as a 2-D array when every row has the same length, else a list of 1-D
/// arrays (a log whose scans differ in beam count).
pub(crate) fn rows<T: Element + Copy>(py: Python<'_>, rows: &[&[T]]) -> PyResult<Py<PyAny>> {
    let width = rows.first().map_or(0, |r| r.len());
    if rows.iter().all(|r| r.len() == width) {
        let flat: Vec<T> = rows.iter().flat_map(|r| r.iter().copied()).collect();
        let array = PyArray1::from_vec(py, flat).reshape([rows.len(), width])?;
        Ok(array.into_any().unbind())
    } else {
        let list = PyList::empty(py);
        for r in rows {
            list.append(PyArray1::from_slice(py, r))?;
        }
        Ok(list.into_any().unbind())
    }
}

/// `[x, y, theta]` per pose, NaN rows where there is none.
fn poses<'py>(
    py: Python<'py>,
    poses: impl Iterator<Item = Option<pgm_scan::Pose2>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = poses
        .flat_map(|p| match p {
            Some(p) => [p.x(), p.y(), p.theta()],
            None => [f64::NAN; 3],
        })
        .collect();
    let n = flat.len() / 3;
    PyArray1::from_vec(py, flat).reshape([n, 3])
}

/// The scans as a dict of arrays: `stamps` (s), `ranges` (m), `angles` (rad, sensor
/// frame), `valid` (a return, not "no return"), `max_range` (m) and `odometry`
/// (`[x, y, theta]`, NaN where the log has none).
fn scans_dict<'py>(py: Python<'py>, scans: &[&Scan]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let stamps: Vec<f64> = scans.iter().map(|s| s.timestamp).collect();
    d.set_item("stamps", PyArray1::from_vec(py, stamps))?;
    let ranges: Vec<&[f64]> = scans.iter().map(|s| s.ranges.as_slice()).collect();
    d.set_item("ranges", rows(py, &ranges)?)?;
    let angles: Vec<&[f64]> = scans.iter().map(|s| s.angles.as_slice()).collect();
    d.set_item("angles", rows(py, &angles)?)?;
    let valid: Vec<&[bool]> = scans.iter().map(|s| s.valid.as_slice()).collect();
    d.set_item("valid", rows(py, &valid)?)?;
    let max_range: Vec<f64> = scans.iter().map(|s| s.max_range).collect();
    d.set_item("max_range", PyArray1::from_vec(py, max_range))?;
    d.set_item("odometry", poses(py, scans.iter().map(|s| s.odometry))?)?;
    Ok(d)
}

fn stamped_poses<'py>(
    py: Python<'py>,
    d: &Bound<'py, PyDict>,
    key: &str,
    list: &[StampedPose],
) -> PyResult<()> {
    let stamps: Vec<f64> = list.iter().map(|p| p.stamp).collect();
    d.set_item(format!("{key}_stamps"), PyArray1::from_vec(py, stamps))?;
    d.set_item(key, poses(py, list.iter().map(|p| Some(p.pose)))?)?;
    Ok(())
}

/// The scans of a text log (scan, record time, file line) with the reader's notes:
/// the scans' arrays plus `record_times`, `lines` and `notes`.
fn text_log_dict<'a, 'py>(
    py: Python<'py>,
    rows: impl Iterator<Item = (&'a Scan, f64, usize)>,
    notes: &[String],
) -> PyResult<Bound<'py, PyDict>> {
    let (mut scans, mut record, mut lines) = (Vec::new(), Vec::new(), Vec::new());
    for (scan, time, line) in rows {
        scans.push(scan);
        record.push(time);
        lines.push(line as i64);
    }
    let d = scans_dict(py, &scans)?;
    d.set_item("record_times", PyArray1::from_vec(py, record))?;
    d.set_item("lines", PyArray1::from_vec(py, lines))?;
    d.set_item("notes", notes.to_vec())?;
    Ok(d)
}

/// Reads a CARMEN log (FLASER and ROBOTLASER1 scans, ODOM poses interpolated at the
/// scans). `clock`: `auto`, `header` (ipc_timestamp) or `record` (logger_timestamp).
///
/// Returns the scans' arrays (see the docs) plus `record_times`, `lines` (the file
/// line of each scan) and `notes` (what the reader noticed, such as stamps at fault).
#[pyfunction]
#[pyo3(signature = (path, clock="auto"))]
pub fn read_carmen<'py>(
    py: Python<'py>,
    path: PathBuf,
    clock: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let options = CarmenOptions {
        clock: self::clock(clock)?,
        ..CarmenOptions::default()
    };
    let log = py
        .detach(|| read_carmen_with(&path, options))
        .map_err(|e| pgm_err(None, e))?;
    let rows = log.scans.iter().map(|s| (&s.scan, s.record_time, s.line));
    text_log_dict(py, rows, &log.notes)
}

/// Reads a leigh-gtm1-style text export of laser scans (`scans.txt`). `clock` as for
/// [`read_carmen`]. Returns the scans' arrays plus `indices` (the scan numbers of the
/// file), `record_times`, `lines` and `notes`.
#[pyfunction]
#[pyo3(signature = (path, clock="auto"))]
pub fn read_leigh<'py>(
    py: Python<'py>,
    path: PathBuf,
    clock: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let clock = self::clock(clock)?;
    let log = py
        .detach(|| read_scans_with(&path, clock))
        .map_err(|e| pgm_err(None, e))?;
    let rows = log.scans.iter().map(|s| (&s.scan, s.record_time, s.line));
    let d = text_log_dict(py, rows, &log.notes)?;
    let indices: Vec<i64> = log.scans.iter().map(|s| s.index as i64).collect();
    d.set_item("indices", PyArray1::from_vec(py, indices))?;
    Ok(d)
}

/// Reads the laser scans of a ROS 1 bag (`.bag`, or zipped `.bag.zip`) or an MCAP file
/// (ROS 1 or ROS 2 messages, CRCs checked) on `scan_topic`, with the optional pose
/// topics (`nav_msgs/Odometry`, `geometry_msgs/PoseStamped` and the like).
///
/// Returns the scans' arrays (their `odometry` is NaN: a bag's poses are messages of
/// their own) plus `record_times` (the bag's record times), `header_stamps` and
/// `frame`, and for each pose topic given its messages: `odom`/`ego_pose`/
/// `object_pose` (`[x, y, theta]`, one row per message) with `…_stamps`.
///
/// `people_topic` (leigh-gtm1's `/ground_truth_people_tracks`, leg_tracker `Person`
/// messages): the annotated people as `people_times` (record time, s: which scan
/// an annotation belongs to), `people_ids` (int64) and `people_positions` (`[x, y]`
/// m in the laser frame, one row per annotation).
#[pyfunction]
#[pyo3(signature = (path, scan_topic, odom_topic=None, ego_pose_topic=None, object_pose_topic=None, people_topic=None, clock="auto"))]
#[allow(clippy::too_many_arguments)]
pub fn read_bag_scans<'py>(
    py: Python<'py>,
    path: PathBuf,
    scan_topic: String,
    odom_topic: Option<String>,
    ego_pose_topic: Option<String>,
    object_pose_topic: Option<String>,
    people_topic: Option<String>,
    clock: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let topics = BagTopics {
        odometry: odom_topic,
        ego_pose: ego_pose_topic,
        object_pose: object_pose_topic,
        people: people_topic,
        clock: self::clock(clock)?,
        ..BagTopics::new(scan_topic)
    };
    let log = py
        .detach(|| read_bag(&path, &topics))
        .map_err(|e| pgm_err(None, e))?;
    let scans: Vec<&Scan> = log.scans.iter().map(|s| &s.scan).collect();
    let d = scans_dict(py, &scans)?;
    let record: Vec<f64> = log.scans.iter().map(|s| s.time).collect();
    d.set_item("record_times", PyArray1::from_vec(py, record))?;
    let header: Vec<f64> = log.scans.iter().map(|s| s.stamp).collect();
    d.set_item("header_stamps", PyArray1::from_vec(py, header))?;
    if let Some(first) = log.scans.first() {
        d.set_item("frame", first.frame.clone())?;
    }
    if topics.odometry.is_some() {
        stamped_poses(py, &d, "odom", &log.odometry)?;
    }
    if topics.ego_pose.is_some() {
        stamped_poses(py, &d, "ego_pose", &log.ego_poses)?;
    }
    if topics.object_pose.is_some() {
        stamped_poses(py, &d, "object_pose", &log.object_poses)?;
    }
    if topics.people.is_some() {
        let times: Vec<f64> = log.people.iter().map(|p| p.time).collect();
        d.set_item("people_times", PyArray1::from_vec(py, times))?;
        let ids: Vec<i64> = log.people.iter().map(|p| i64::from(p.id)).collect();
        d.set_item("people_ids", PyArray1::from_vec(py, ids))?;
        let positions: Vec<[f64; 2]> = log
            .people
            .iter()
            .map(|p| [p.position.x, p.position.y])
            .collect();
        d.set_item("people_positions", points(py, &positions)?)?;
    }
    Ok(d)
}

/// `n × 2` array of points.
fn points<'py>(py: Python<'py>, points: &[[f64; 2]]) -> PyResult<Py<PyAny>> {
    let flat: Vec<f64> = points.iter().flatten().copied().collect();
    Ok(PyArray1::from_vec(py, flat)
        .reshape([points.len(), 2])?
        .into_any()
        .unbind())
}

/// Reads a leigh-gtm1 `people_gt.txt` (`PERSON scan_idx person_id x y`: hand-annotated
/// person centres, laser frame of that scan, m) with the CLI's checks and errors.
///
/// Returns a dict: `scans` (int64: the `scan_idx` each annotation belongs to, as
/// `read_leigh`'s `indices` number the scans), `ids` (int64), `positions` (`[x, y]`
/// per annotation) and `lines` (1-based line numbers).
#[pyfunction]
pub fn read_people<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let people = py
        .detach(|| pgm_datasets::leigh::read_people(&path))
        .map_err(|e| pgm_err(None, e))?;
    let d = PyDict::new(py);
    let scans: Vec<i64> = people.iter().map(|p| p.scan as i64).collect();
    d.set_item("scans", PyArray1::from_vec(py, scans))?;
    let ids: Vec<i64> = people.iter().map(|p| i64::from(p.person)).collect();
    d.set_item("ids", PyArray1::from_vec(py, ids))?;
    let positions: Vec<[f64; 2]> = people.iter().map(|p| [p.centre.x, p.centre.y]).collect();
    d.set_item("positions", points(py, &positions)?)?;
    let lines: Vec<i64> = people.iter().map(|p| p.line as i64).collect();
    d.set_item("lines", PyArray1::from_vec(py, lines))?;
    Ok(d)
}

/// Reads the ground-truth relations of a CARMEN log (the `.relations` files of the
/// Kümmerle et al. SLAM benchmark: `t1 t2 x y z roll pitch yaw`, the true motion of
/// the robot from the scan at `t1` to the scan at `t2`, in the robot frame at `t1`),
/// with the CLI's checks and errors.
///
/// Returns a dict: `t1`, `t2` (s), `motions` (`[x, y, theta]` m and rad, one row per
/// relation) and `lines` (1-based line numbers).
#[pyfunction]
pub fn read_relations<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let relations = py
        .detach(|| pgm_datasets::relations::read_relations(&path))
        .map_err(|e| pgm_err(None, e))?;
    let d = PyDict::new(py);
    let t1: Vec<f64> = relations.iter().map(|r| r.t1).collect();
    let t2: Vec<f64> = relations.iter().map(|r| r.t2).collect();
    d.set_item("t1", PyArray1::from_vec(py, t1))?;
    d.set_item("t2", PyArray1::from_vec(py, t2))?;
    d.set_item(
        "motions",
        poses(py, relations.iter().map(|r| Some(r.motion)))?,
    )?;
    let lines: Vec<i64> = relations.iter().map(|r| r.line as i64).collect();
    d.set_item("lines", PyArray1::from_vec(py, lines))?;
    Ok(d)
}
