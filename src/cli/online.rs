//! `pgm track`'s online run: the scans of the source pushed one by one into
//! [`pgm_tracking::OnlineTracker`], each scan's objects reported as they come
//! (`--smooth`: the offline pass over the finished log, [`pgm_tracking::online::smooth`]).

use super::CliError;
use clap::Args;
use pgm_scan::methods::MotionClusterer;
use pgm_scan::{Scan, ScanPair};
use pgm_tracking::online::EgoParams;
use pgm_tracking::{OnlineParams, ScanReport};
use serde::Serialize;

/// Options of the online tracker.
#[derive(Args, Debug, Clone)]
pub struct OnlineArgs {
    /// Offline: after the whole log, report each confirmed track from its birth and
    /// drop the tracks never confirmed.
    #[arg(long)]
    pub smooth: bool,
    /// Shortest time (s) from the detector's reference scan to the current scan, when
    /// --k is not given: an object at --min-speed moves 0.15 m (CRF-Clustering's
    /// smallest displacement) in the default time.
    #[arg(long, default_value_t = OnlineParams::default().reference_gap, hide_short_help = true)]
    pub reference_gap: f64,
    /// Slowest speed (m/s) that counts as moving.
    #[arg(long, default_value_t = OnlineParams::default().min_speed, hide_short_help = true)]
    pub min_speed: f64,
    /// Fastest the platform drives (m/s): ego-motion hypotheses beyond it are refused.
    #[arg(long, default_value_t = EgoParams::default().max_speed, hide_short_help = true)]
    pub max_speed: f64,
    /// Fastest the platform turns (rad/s): ego-motion hypotheses beyond it are refused.
    #[arg(long, default_value_t = EgoParams::default().max_yaw_rate, hide_short_help = true)]
    pub max_yaw_rate: f64,
}

impl OnlineArgs {
    /// The tracker's parameters, for detector pairs `k` scans apart (`None`: the
    /// tracker's reference gap in time).
    pub fn params(&self, k: Option<usize>) -> OnlineParams {
        let d = OnlineParams::default();
        OnlineParams {
            k,
            reference_gap: self.reference_gap,
            min_speed: self.min_speed,
            ego: EgoParams {
                max_speed: self.max_speed,
                max_yaw_rate: self.max_yaw_rate,
                ..d.ego
            },
            ..d
        }
    }
}

/// The scans of `pairs` as sequences, each scan once. Pairs named `LOG:A-B` (as every
/// reader and `pgm sim --sequence` name them: scans `A` and `B` of `LOG`) give scan `A`
/// and scan `B` of `LOG`, the first pair that holds a scan giving it; each log's scans
/// follow in index order, the logs in the order of their first pair. A pair named
/// otherwise (an independent simulated scene) is a sequence of its two scans. Each
/// scan is named `LOG:A`.
pub fn scan_sequence(pairs: &[ScanPair]) -> Vec<(String, Scan)> {
    use std::collections::BTreeMap;
    let mut logs: Vec<(String, BTreeMap<usize, &Scan>)> = Vec::new();
    let mut alone: Vec<(usize, String)> = Vec::new();
    for (i, pair) in pairs.iter().enumerate() {
        let parsed = pair.name.rsplit_once(':').and_then(|(log, ab)| {
            let (a, b) = ab.split_once('-')?;
            Some((log, a.parse::<usize>().ok()?, b.parse::<usize>().ok()?))
        });
        match parsed {
            Some((log, a, b)) => {
                let at = match logs.iter().position(|(l, _)| l == log) {
                    Some(at) => at,
                    None => {
                        logs.push((log.to_string(), BTreeMap::new()));
                        logs.len() - 1
                    }
                };
                logs[at].1.entry(a).or_insert(&pair.reference);
                logs[at].1.entry(b).or_insert(&pair.current);
            }
            None => alone.push((i, pair.name.clone())),
        }
    }
    let mut out = Vec::new();
    for (log, scans) in logs {
        out.extend(
            scans
                .into_iter()
                .map(|(k, s)| (format!("{log}:{k}"), s.clone())),
        );
    }
    for (i, name) in alone {
        out.push((format!("{name} (reference)"), pairs[i].reference.clone()));
        out.push((name, pairs[i].current.clone()));
    }
    out
}

/// One scan of the output.
#[derive(Serialize)]
pub struct NamedReport {
    /// The scan's name (its pair's).
    pub scan: String,
    #[serde(flatten)]
    pub report: ScanReport,
}

/// How many distinct sequences the tracker reported scans of.
pub fn sequence_count(reports: &[NamedReport]) -> usize {
    reports
        .iter()
        .map(|r| r.report.sequence)
        .collect::<std::collections::BTreeSet<_>>()
        .len()
}

/// Runs the tracker over `scans`, in order; smoothed when asked.
///
/// # Errors
/// The tracker's, naming the scan.
pub fn track_scans(
    scans: Vec<(String, Scan)>,
    detector: &dyn MotionClusterer,
    params: &OnlineParams,
    smooth: bool,
) -> Result<Vec<NamedReport>, CliError> {
    let mut tracker = params.tracker(detector).map_err(CliError::from_display)?;
    let mut names = Vec::with_capacity(scans.len());
    let mut reports = Vec::with_capacity(scans.len());
    for (name, scan) in scans {
        let report = tracker
            .push(scan)
            .map_err(|e| CliError(format!("{name}: {e}")))?;
        names.push(name);
        reports.push(report);
    }
    if smooth {
        reports = pgm_tracking::online::smooth(reports, params.min_speed);
    }
    Ok(names
        .into_iter()
        .zip(reports)
        .map(|(scan, report)| NamedReport { scan, report })
        .collect())
}

/// `"smoothed"` or `"online"`: the mode `pgm track` states in its JSON.
pub fn mode_name(smooth: bool) -> &'static str {
    if smooth {
        "smoothed"
    } else {
        "online"
    }
}

/// The tracker of a scored run, for a report: `"crf on segment-icp associations
/// (online)"`.
pub fn tracker_label(method: &str, associations: Option<&str>, smooth: bool) -> String {
    format!(
        "{method}{} ({})",
        associations.map_or(String::new(), |a| format!(" on {a} associations")),
        mode_name(smooth)
    )
}

/// What a scoring command (`pgm eval tracking`, `pgm eval ego-motion`) tracked.
pub struct TrackedRun {
    /// Each scan's report, in the order tracked.
    pub reports: Vec<NamedReport>,
    /// The tracker, as [`tracker_label`] names it.
    pub tracker: String,
    /// Scans tracked.
    pub scans: usize,
}

/// Runs the online tracker over every consecutive scan of the source whose truth
/// `truth_source` reads: a bag without its truth topics, a relation file's whole
/// CARMEN log, any other source as it is. `no_odometry` withholds the scans' odometry.
///
/// # Errors
/// A reader's, the method's or the tracker's; `--associations true` (the tracker's
/// pairs have no ground-truth associations).
pub fn track_truth_source(
    truth_source: &pgm_datasets::source::PairSource,
    source: &super::data::SourceArgs,
    method: &super::eval_clustering::MethodArgs,
    online: &OnlineArgs,
    k: Option<usize>,
    no_odometry: bool,
) -> Result<TrackedRun, CliError> {
    use super::data::{load_pairs, pair_source, BagArgs, LeighArgs, SourceArgs};
    use pgm_datasets::source::PairSource;
    use pgm_scan::ParamGuard;
    if method.associations.as_deref() == Some("true") {
        return Err(CliError(
            "--associations true: the online tracker pairs scans itself, and those pairs \
             have no ground-truth associations (use icp, segment-icp or crf-matching)"
                .into(),
        ));
    }
    let sequence_source = match truth_source {
        PairSource::CarmenRelations { log, options, .. } => PairSource::ConsecutiveLog {
            log: log.clone(),
            options: *options,
        },
        PairSource::Bag { .. } => {
            let plain = SourceArgs {
                bag: BagArgs {
                    people_topic: None,
                    ego_pose_topic: None,
                    object_pose_topic: None,
                    object_footprint: None,
                    ..source.bag.clone()
                },
                ..source.clone()
            };
            pair_source(None, &plain, &LeighArgs::default(), 1)?
        }
        other => other.clone(),
    };
    let pairs = load_pairs(&sequence_source)?.pairs;
    if pairs.is_empty() {
        return Err(CliError(format!("{sequence_source}: no pair to track")));
    }
    let mut sequence = scan_sequence(&pairs);
    if no_odometry {
        for (_, scan) in &mut sequence {
            scan.odometry = None;
        }
    }
    let scans = sequence.len();
    let method_options = method.options()?;
    let params = online.params(k);
    params.check_ref().map_err(CliError::from_display)?;
    let built = method.build(&method_options, &[])?;
    let reports = track_scans(sequence, built.method.as_ref(), &params, online.smooth)?;
    Ok(TrackedRun {
        reports,
        tracker: tracker_label(&method.method, built.associations.as_deref(), online.smooth),
        scans,
    })
}
