//! Scan pairs and their ground truth: the unit every model and metric works on.
//!
//! Indexing convention: every per-point array is indexed by **beam index** of the scan
//! it describes (so it has one entry per beam, `None` for beams without a return).
//! Cluster label `0` is the static background; moving objects get labels `1, 2, …`.
//! A cluster's motion maps points of the **current** scan onto the **reference** scan
//! (`g ≈ R s + T`, eq. 2 of the CRF-Clustering paper); for the background that is the
//! ego-motion, the pose of the current sensor frame in the reference sensor frame.

use crate::pose::Pose2;
use crate::scan::Scan;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Where a point of one scan goes in the other scan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Association {
    /// The point corresponds to the point of this beam index in the other scan.
    Point(usize),
    /// The surface was not seen in the other scan (occluded, out of range, new).
    Outlier,
}

impl Serialize for Association {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Association::Point(k) => s.serialize_i64(*k as i64),
            Association::Outlier => s.serialize_i64(-1),
        }
    }
}

impl<'de> Deserialize<'de> for Association {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = i64::deserialize(d)?;
        match v {
            -1 => Ok(Association::Outlier),
            k if k >= 0 => Ok(Association::Point(k as usize)),
            k => Err(serde::de::Error::custom(format!(
                "association {k}: expected a beam index >= 0 or -1 for outlier"
            ))),
        }
    }
}

/// The true motion of one cluster between the two scans.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClusterMotion {
    /// The cluster label this motion belongs to (0 = background).
    pub label: u32,
    /// Motion mapping current-scan points of this cluster onto the reference scan.
    pub motion: Pose2,
    /// Free-form kind ("background", "car", "pedestrian", "person", …).
    #[serde(default)]
    pub kind: String,
}

/// Whatever ground truth is known for a pair; every field is optional because real
/// logs give only parts of it (mit-csail: ego-motion only; leigh-gtm1: labels and
/// person displacements; the simulator: everything).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundTruth {
    /// True ego-motion (pose of the current sensor frame in the reference sensor frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ego_motion: Option<Pose2>,
    /// Per beam of the current scan: cluster label, `None` for beams without a return.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub labels: Option<Vec<Option<u32>>>,
    /// Per beam of the reference scan: cluster label, `None` for beams without a return.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_labels: Option<Vec<Option<u32>>>,
    /// Per beam of the current scan: association into the reference scan.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub associations: Option<Vec<Option<Association>>>,
    /// True motion of each cluster, background included when known.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub motions: Vec<ClusterMotion>,
    /// The objects to track in the current scan, with their true centres, for
    /// tracking metrics (CLEAR-MOT). `None`: the scan is not annotated for tracking;
    /// `Some(vec![])`: annotated, and no object is there.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objects: Option<Vec<ObjectCentre>>,
}

/// One object's true centre in the current scan (see [`GroundTruth::objects`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectCentre {
    /// The object's identity, the same in every scan of a sequence (a person id of
    /// an annotation, a simulated body's index, a motion-capture rigid body).
    pub id: u64,
    /// Centre (m) in the current scan's sensor frame: a person's body centre between
    /// the legs, a car's box centre.
    pub x: f64,
    /// See `x`.
    pub y: f64,
    /// Whether the object moves at this scan, when the source knows (leigh-gtm1: the
    /// data README's track rule; the simulator: its trajectory).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moving: Option<bool>,
    /// How many returns of the current scan hit the object, when the source knows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub returns: Option<usize>,
}

/// Two scans, the prior on the sensor's motion between them, and the ground truth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScanPair {
    /// A name that says where the pair came from (for example `leigh-gtm1:133-138`).
    pub name: String,
    /// The reference scan (`g` in the papers).
    pub reference: Scan,
    /// The current scan (`s` in the papers), whose points the clustering CRF labels.
    pub current: Scan,
    /// Odometry prior on the ego-motion, in the reference sensor frame, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub odometry: Option<Pose2>,
    /// Ground truth, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<GroundTruth>,
}

/// The first invariant a [`ScanPair`] violates (see [`ScanPair::validate`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PairViolation {
    /// Path of the offending field, for example `truth.labels[17]` or `current`.
    pub field: String,
    /// What is wrong with it.
    pub problem: String,
}

impl std::fmt::Display for PairViolation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "`{}`: {}", self.field, self.problem)
    }
}

fn violation(field: impl Into<String>, problem: impl Into<String>) -> PairViolation {
    PairViolation {
        field: field.into(),
        problem: problem.into(),
    }
}

fn check_pose(field: &str, pose: &Pose2) -> Result<(), PairViolation> {
    if pose.is_finite() {
        Ok(())
    } else {
        Err(violation(field, format!("pose {pose:?} is not finite")))
    }
}

fn check_labels(
    field: &str,
    labels: &[Option<u32>],
    scan: &Scan,
    scan_name: &str,
) -> Result<(), PairViolation> {
    if labels.len() != scan.len() {
        return Err(violation(
            field,
            format!(
                "{} labels for the {} beams of the {scan_name} scan",
                labels.len(),
                scan.len()
            ),
        ));
    }
    for (k, label) in labels.iter().enumerate() {
        if label.is_some() && !scan.valid[k] {
            return Err(violation(
                format!("{field}[{k}]"),
                format!("label {label:?} on a beam without a return"),
            ));
        }
    }
    Ok(())
}

impl ScanPair {
    /// Whether the ground truth labels a beam of the current scan with a moving object
    /// (a label other than the background's 0).
    pub fn has_labelled_mover(&self) -> bool {
        self.truth
            .as_ref()
            .and_then(|t| t.labels.as_ref())
            .is_some_and(|l| l.iter().any(|x| x.is_some_and(|v| v > 0)))
    }

    /// Time from the reference scan to the current scan, in seconds.
    pub fn time_gap(&self) -> f64 {
        self.current.timestamp - self.reference.timestamp
    }

    /// Checks the invariants every stored pair must satisfy: both scans pass
    /// [`Scan::validate`]; poses are finite; label arrays have one entry per beam of
    /// their scan and no label on a beam without a return; associations have one
    /// entry per beam of the current scan, only on returns, and point at returns of
    /// the reference scan.
    pub fn validate(&self) -> Result<(), PairViolation> {
        self.reference
            .validate()
            .map_err(|p| violation("reference", p))?;
        self.current
            .validate()
            .map_err(|p| violation("current", p))?;
        if let Some(o) = &self.odometry {
            check_pose("odometry", o)?;
        }
        let Some(truth) = &self.truth else {
            return Ok(());
        };
        if let Some(e) = &truth.ego_motion {
            check_pose("truth.ego_motion", e)?;
        }
        if let Some(labels) = &truth.labels {
            check_labels("truth.labels", labels, &self.current, "current")?;
        }
        if let Some(labels) = &truth.reference_labels {
            check_labels(
                "truth.reference_labels",
                labels,
                &self.reference,
                "reference",
            )?;
        }
        if let Some(assoc) = &truth.associations {
            if assoc.len() != self.current.len() {
                return Err(violation(
                    "truth.associations",
                    format!(
                        "{} associations for the {} beams of the current scan",
                        assoc.len(),
                        self.current.len()
                    ),
                ));
            }
            for (k, a) in assoc.iter().enumerate() {
                let field = || format!("truth.associations[{k}]");
                match a {
                    Some(_) if !self.current.valid[k] => {
                        return Err(violation(field(), "association on a beam without a return"))
                    }
                    Some(Association::Point(r)) if *r >= self.reference.len() => {
                        return Err(violation(
                            field(),
                            format!(
                                "reference beam {r} out of range (the reference scan has {} beams)",
                                self.reference.len()
                            ),
                        ))
                    }
                    Some(Association::Point(r)) if !self.reference.valid[*r] => {
                        return Err(violation(
                            field(),
                            format!("reference beam {r} has no return"),
                        ))
                    }
                    _ => {}
                }
            }
        }
        for (k, m) in truth.motions.iter().enumerate() {
            check_pose(&format!("truth.motions[{k}].motion"), &m.motion)?;
        }
        let objects = truth.objects.as_deref().unwrap_or(&[]);
        for (k, o) in objects.iter().enumerate() {
            if !(o.x.is_finite() && o.y.is_finite()) {
                return Err(violation(
                    format!("truth.objects[{k}]"),
                    format!("centre ({}, {}) is not finite", o.x, o.y),
                ));
            }
            if objects[..k].iter().any(|p| p.id == o.id) {
                return Err(violation(
                    format!("truth.objects[{k}].id"),
                    format!("object {} appears twice in the scan", o.id),
                ));
            }
        }
        Ok(())
    }
}
