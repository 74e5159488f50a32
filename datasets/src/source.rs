//! Where scan pairs come from: a stored data set, or one of the real-log formats with
//! its ground truth, as one value ([`PairSource`]) that every command and example
//! loads the same way.
//!
//! ```no_run
//! use pgm_datasets::source::PairSource;
//!
//! # fn main() -> pgm_datasets::Result<()> {
//! let source = PairSource::CarmenRelations {
//!     log: "mit-csail.clf".into(),
//!     relations: "mit-csail.relations".into(),
//!     options: Default::default(),
//! };
//! let loaded = source.load()?;
//! for note in &loaded.notes {
//!     eprintln!("note: {note}");
//! }
//! println!("{} pairs from {}", loaded.pairs.len(), source);
//! # Ok(())
//! # }
//! ```

use crate::bag::pairs::{bag_pairs, BagPairOptions};
use crate::bag::{read_bag, BagTopics};
use crate::builders::{
    consecutive_pairs, leigh_pairs, relation_pairs, LeighPairOptions, RelationPairOptions,
};
use crate::carmen::CarmenOptions;
use crate::error::Result;
use crate::stamps::StampClock;
use crate::tracking_truth::{
    bag_objects, leigh_objects, leigh_what, stored_objects, TrackingTruth,
};
use crate::{carmen, leigh, relations, ScanPair};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// Which kind of source the pairs came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SourceKind {
    /// A stored data set (`datasets/FORMAT.md`).
    Stored,
    /// A CARMEN log with a Kümmerle-style relations file (mit-csail).
    Relations,
    /// A CARMEN log read as consecutive scans: with `VERTEX2` poses the true
    /// ego-motion (intel-lab), without them no ground truth (mit-csail's `.clf`).
    ConsecutiveLog,
    /// leigh-gtm1 text logs.
    Leigh,
    /// A ROS bag (ROS 1 or MCAP).
    Bag,
}

/// A source of scan pairs.
// Built once per command; boxing the bag options would only make them clumsier to write.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum PairSource {
    /// A stored data set: a directory, its `index.json`, or one pair file.
    Stored(PathBuf),
    /// One pair per relation of `relations` between scans of the CARMEN `log`, with
    /// the relation as the true ego-motion.
    CarmenRelations {
        /// The CARMEN log (FLASER / ROBOTLASER1 lines).
        log: PathBuf,
        /// The relations file (`t1 t2 x y z roll pitch yaw`).
        relations: PathBuf,
        /// The CARMEN reader's options (laser geometry overrides).
        options: CarmenOptions,
    },
    /// Consecutive scans of a CARMEN log: with `VERTEX2` poses the poses give the true
    /// ego-motion; a log without any gives its consecutive scans without ground truth
    /// ([`crate::builders::consecutive_pairs`]).
    ConsecutiveLog {
        /// The CARMEN log.
        log: PathBuf,
        /// The CARMEN reader's options (laser geometry overrides).
        options: CarmenOptions,
    },
    /// leigh-gtm1 style logs: pairs `k` scans apart with per-point motion labels.
    Leigh {
        /// `SCAN` lines.
        scans: PathBuf,
        /// `PERSON` annotations.
        people: PathBuf,
        /// `ODOM` lines (optional).
        odometry: Option<PathBuf>,
        /// The builder's options (`k`, thresholds, labelling rule).
        options: LeighPairOptions,
        /// Which clock places the scans in time ([`crate::stamps`]).
        clock: StampClock,
    },
    /// A ROS bag (ROS 1, MCAP, a ROS 2 bag directory, or one of them zipped): pairs
    /// `k` scans apart with the ground truth its topics give ([`crate::bag::pairs`]).
    Bag {
        /// The bag.
        path: PathBuf,
        /// The topics to read.
        topics: BagTopics,
        /// The pair builder's options.
        options: BagPairOptions,
    },
}

/// Pairs loaded from a [`PairSource`], with what the readers noted on the way.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedPairs {
    /// The pairs.
    pub pairs: Vec<ScanPair>,
    /// The kind of source.
    pub kind: SourceKind,
    /// Notes for the user (skipped lines, unmatched relations, dropped odometry), each
    /// naming its file.
    pub notes: Vec<String>,
}

impl fmt::Display for PairSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PairSource::Stored(path) => write!(f, "data set {}", path.display()),
            PairSource::CarmenRelations { log, relations, .. } => {
                write!(
                    f,
                    "{} with relations {}",
                    log.display(),
                    relations.display()
                )
            }
            PairSource::ConsecutiveLog { log, .. } => {
                write!(f, "consecutive scans of {}", log.display())
            }
            PairSource::Leigh { scans, options, .. } => {
                write!(
                    f,
                    "{} (k = {}, {} labels)",
                    scans.display(),
                    options.k,
                    options.rule
                )
            }
            PairSource::Bag {
                path,
                topics,
                options,
            } => {
                write!(f, "bag {} (scans {}", path.display(), topics.scan)?;
                if let Some(t) = &topics.people {
                    write!(f, ", people {t}, {} labels", options.leigh.rule)?;
                }
                if let Some(t) = &topics.ego_pose {
                    write!(f, ", ego pose {t}")?;
                }
                if let Some(t) = &topics.object_pose {
                    write!(f, ", object pose {t}")?;
                }
                write!(f, ", k = {})", options.k)
            }
        }
    }
}

/// The file name without extension, or `log`.
pub fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "log".into())
}

fn skipped_note(path: &Path, skipped: &BTreeMap<String, usize>) -> Option<String> {
    (!skipped.is_empty()).then(|| {
        let list: Vec<String> = skipped.iter().map(|(k, v)| format!("{k} ×{v}")).collect();
        format!("{}: skipped lines: {}", path.display(), list.join(", "))
    })
}

/// The error for a log without a single scan: a summary or evaluation of it would be
/// figures of nothing.
fn no_scans(path: &Path, lines: &str, skipped: &BTreeMap<String, usize>) -> crate::Error {
    let skipped: Vec<String> = skipped.iter().map(|(k, v)| format!("{k} ×{v}")).collect();
    crate::Error::Invalid {
        path: path.to_path_buf(),
        field: lines.into(),
        problem: if skipped.is_empty() {
            "the log holds no scan (an empty file?)".into()
        } else {
            format!("the log holds no scan (its lines: {})", skipped.join(", "))
        },
    }
}

/// Reads leigh-gtm1 scans (with odometry when given, placed by the clock `clock`
/// chooses) and annotations; notes on skipped lines and stamps go to `notes`.
pub fn read_leigh(
    scans: &Path,
    people: &Path,
    odometry: Option<&Path>,
    clock: StampClock,
    notes: &mut Vec<String>,
) -> Result<(leigh::LeighScans, Vec<leigh::PersonAnnotation>)> {
    let mut log = leigh::read_scans_with(scans, clock)?;
    notes.extend(skipped_note(scans, &log.skipped));
    notes.extend(log.notes.iter().cloned());
    if log.scans.is_empty() {
        return Err(no_scans(scans, "SCAN", &log.skipped));
    }
    if let Some(path) = odometry {
        let odo = leigh::read_odometry(path)?;
        leigh::attach_odometry(&mut log, &odo, path)?;
    }
    let annotations = leigh::read_people(people)?;
    if annotations.is_empty() {
        return Err(crate::Error::Invalid {
            path: people.to_path_buf(),
            field: "PERSON".into(),
            problem: "no annotation (`PERSON scan_idx person_id x y` lines): an empty people \
                      file labels nothing"
                .into(),
        });
    }
    leigh::check_people_reach(&log, scans, &annotations, people)?;
    Ok((log, annotations))
}

/// Reads a CARMEN log with `options`, noting its skipped lines and the reader's notes
/// in `notes`; a log without a laser scan is an error.
fn read_carmen_log(
    path: &Path,
    options: carmen::CarmenOptions,
    notes: &mut Vec<String>,
) -> Result<carmen::CarmenLog> {
    let log = carmen::read_carmen_with(path, options)?;
    notes.extend(skipped_note(path, &log.skipped));
    notes.extend(log.notes.iter().cloned());
    if log.scans.is_empty() {
        return Err(no_scans(path, "FLASER / ROBOTLASER1", &log.skipped));
    }
    Ok(log)
}

impl PairSource {
    /// The scans and annotations of a [`PairSource::Leigh`] ([`read_leigh`]); another
    /// source has none (an error).
    fn leigh_log(
        &self,
        notes: &mut Vec<String>,
    ) -> Result<(leigh::LeighScans, Vec<leigh::PersonAnnotation>)> {
        match self {
            PairSource::Leigh {
                scans,
                people,
                odometry,
                clock,
                ..
            } => read_leigh(scans, people, odometry.as_deref(), *clock, notes),
            other => Err(crate::Error::Mismatch {
                what: format!("{other}: not a leigh-gtm1 source"),
            }),
        }
    }

    /// The log of a [`PairSource::Bag`] ([`read_bag`]); another source has none (an
    /// error).
    fn bag_log(&self) -> Result<crate::bag::BagLog> {
        match self {
            PairSource::Bag { path, topics, .. } => read_bag(path, topics),
            other => Err(crate::Error::Mismatch {
                what: format!("{other}: not a bag source"),
            }),
        }
    }

    /// Reads the source and builds its pairs.
    ///
    /// # Errors
    /// The first reader or builder error, naming its file and line.
    pub fn load(&self) -> Result<LoadedPairs> {
        let mut notes = Vec::new();
        let (kind, pairs) = match self {
            PairSource::Stored(path) => (SourceKind::Stored, crate::read_pairs(path)?),
            PairSource::CarmenRelations {
                log,
                relations,
                options,
            } => {
                let carmen_log = read_carmen_log(log, *options, &mut notes)?;
                let relations::Deduplicated {
                    relations: rels,
                    repeated,
                } = relations::dedupe_relations(relations, relations::read_relations(relations)?)?;
                if let Some((first, again)) = repeated.first() {
                    notes.push(format!(
                        "{}: {} relation(s) repeat an earlier one with the same motion and are \
                         scored once (first: line {again} repeats line {first})",
                        relations.display(),
                        repeated.len()
                    ));
                }
                let options = RelationPairOptions {
                    name: file_stem(log),
                    ..Default::default()
                };
                let built = relation_pairs(&carmen_log, &rels, &options);
                if let Some(first) = built.unmatched.first() {
                    notes.push(format!(
                        "{}: {} of {} relations name a time stamp with no scan within {} s \
                         (first on line {})",
                        relations.display(),
                        built.unmatched.len(),
                        rels.len(),
                        options.tolerance,
                        first.line
                    ));
                }
                (SourceKind::Relations, built.pairs)
            }
            PairSource::ConsecutiveLog { log: path, options } => {
                let log = read_carmen_log(path, *options, &mut notes)?;
                let built = consecutive_pairs(&log, &file_stem(path));
                if built.without_ground_truth {
                    notes.push(format!(
                        "{}: no VERTEX2 poses: {} pairs of consecutive laser scans without \
                         ground truth (odometry prior only){}",
                        path.display(),
                        built.pairs.len(),
                        if built.empty_scans > 0 {
                            format!(
                                "; {} scans without a valid return left out",
                                built.empty_scans
                            )
                        } else {
                            String::new()
                        }
                    ));
                }
                if built.odometry_was_ground_truth {
                    notes.push(format!(
                        "{}: the robot poses of the laser lines equal the VERTEX2 poses; \
                         they are ground truth, not odometry, and were removed (no odometry prior)",
                        path.display()
                    ));
                }
                (SourceKind::ConsecutiveLog, built.pairs)
            }
            PairSource::Leigh { scans, options, .. } => {
                let (log, annotations) = self.leigh_log(&mut notes)?;
                let pairs = leigh_pairs(&log, &annotations, options).map_err(|e| {
                    crate::Error::Mismatch {
                        what: format!("{}: {e}", scans.display()),
                    }
                })?;
                (SourceKind::Leigh, pairs)
            }
            PairSource::Bag { options, .. } => {
                let built = bag_pairs(&self.bag_log()?, options)?;
                notes.extend(built.notes);
                (SourceKind::Bag, built.pairs)
            }
        };
        Ok(LoadedPairs { pairs, kind, notes })
    }

    /// The source's tracking truth scan by scan ([`crate::tracking_truth`]): a stored
    /// data set's objects, a leigh-gtm1 log's annotated people (every annotated scan,
    /// whether or not it forms a pair), a bag's people topic or motion-captured object.
    ///
    /// # Errors
    /// A reader's error; [`crate::Error::Mismatch`] for a source with no tracking truth
    /// (CARMEN logs, a bag without people or object topics).
    pub fn tracking_truth(&self) -> Result<TrackingTruth> {
        match self {
            PairSource::Stored(path) => {
                let pairs = crate::read_pairs(path)?;
                let truth = stored_objects(&pairs);
                if truth.scans.is_empty() {
                    return Err(crate::Error::Mismatch {
                        what: format!(
                            "{}: no pair holds tracking truth (ground-truth `objects`;                              `pgm sim` writes them)",
                            path.display()
                        ),
                    });
                }
                Ok(truth)
            }
            PairSource::CarmenRelations { log, .. } | PairSource::ConsecutiveLog { log, .. } => {
                Err(crate::Error::Mismatch {
                    what: format!(
                        "{}: a CARMEN log has no tracking truth (annotated people or a                          motion-captured object)",
                        log.display()
                    ),
                })
            }
            PairSource::Leigh { options, .. } => {
                let mut notes = Vec::new();
                let (log, annotations) = self.leigh_log(&mut notes)?;
                let objects = leigh_objects(&log, &annotations, options, &mut notes);
                Ok(TrackingTruth {
                    scans: objects
                        .into_iter()
                        .map(|(j, o)| (format!("{}:{j}", options.name), o))
                        .collect(),
                    what: leigh_what(options),
                    notes,
                })
            }
            PairSource::Bag { options, .. } => bag_objects(&self.bag_log()?, options),
        }
    }
}
