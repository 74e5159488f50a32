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
