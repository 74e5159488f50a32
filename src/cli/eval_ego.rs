//! `pgm eval ego-motion`: the online tracker's sequence ego-motion
//! ([`pgm_tracking::online::EgoMotion`]) against ground truth, beside pair-wise ICP
//! started from the odometry prior on the same pairs, in one run.
//!
//! `pgm eval ego-motion --method NAME [--associations SRC] (--log FILE | --carmen FILE
//! --relations FILE | --bag FILE --scan-topic T [--odom-topic T] --ego-pose-topic T |
//! --pairs DIR) [--no-odometry] [--max-gap S] [--json]` runs the online tracker of
//! `pgm track` over every scan of the log in order (a relation file's log: all its
//! consecutive scans), with the wheel odometry withheld under `--no-odometry`. Every
//! ground-truth pair whose two scans are at most `--max-gap` seconds apart (default
//! 1.5) and in one tracked sequence is scored: the tracker's relative pose
//! `inverse(P_a) ∘ P_b` of its two scans against the truth, and ICP
//! ([`pgm_scan::registration`], the `icp` matcher of `pgm eval matching`) from the
//! pair's odometry prior. Printed: pairs, median and 90th-percentile translation (m)
//! and rotation (rad) errors, and the share of pairs off by more than 0.2 m or 0.1
//! rad, for both.

use super::data::{load_pairs, pair_source, LeighArgs, SourceArgs};
use super::eval_clustering::MethodArgs;
use super::online::{sequence_count, track_truth_source, OnlineArgs};
use super::{print_json, CliError, CliResult};
use clap::Args;
use pgm::methods::{scan_matcher, MethodOptions};
use pgm_scan::{Pose2, ScanPair};
use serde::Serialize;
use std::process::ExitCode;

/// Translation (m) beyond which a step counts as off.
const OFF_TRANSLATION: f64 = 0.2;
/// Rotation (rad) beyond which a step counts as off.
const OFF_ROTATION: f64 = 0.1;
/// Two stamps closer than this (s) are the same scan.
const SAME_STAMP: f64 = 1e-4;

/// `pgm eval ego-motion`.
#[derive(Args, Debug)]
pub struct EgoEvalArgs {
    /// The tracker's detector and its options.
    #[command(flatten)]
    pub detector: MethodArgs,
    /// A stored scan-pair data set with ground-truth ego-motion.
    #[arg(long, conflicts_with_all = ["log", "scans", "bag", "carmen"])]
    pub pairs: Option<std::path::PathBuf>,
    /// The log or bag with its ego-motion truth (VERTEX2 poses, relations, motion
    /// capture).
    #[command(flatten)]
    pub source: SourceArgs,
    /// The detector runs on scans n − k and n (default: by --reference-gap).
    #[arg(long, conflicts_with = "reference_gap", allow_hyphen_values = true, value_parser = super::parse_scan_distance)]
    pub k: Option<usize>,
    /// The online tracker's options.
    #[command(flatten)]
    pub online: OnlineArgs,
    /// Withhold the wheel odometry from the tracker (ICP keeps its prior).
    #[arg(long)]
    pub no_odometry: bool,
    /// Score pairs whose scans are at most this many seconds apart.
    #[arg(long, default_value_t = 1.5)]
    pub max_gap: f64,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// The JSON lists every scored pair's errors.
    #[arg(long, hide_short_help = true)]
    pub per_pair: bool,
}

#[derive(Serialize, Default)]
struct Errors {
    pairs: usize,
    translation_median: f64,
    translation_p90: f64,
    rotation_median: f64,
    rotation_p90: f64,
    /// Pairs off by more than 0.2 m or 0.1 rad.
    off: usize,
    /// `off / pairs`.
    off_share: f64,
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

fn summarise(errors: &[(f64, f64)]) -> Errors {
    let mut t: Vec<f64> = errors.iter().map(|e| e.0).collect();
    let mut r: Vec<f64> = errors.iter().map(|e| e.1).collect();
    t.sort_by(f64::total_cmp);
    r.sort_by(f64::total_cmp);
    let off = errors
        .iter()
        .filter(|(t, r)| *t > OFF_TRANSLATION || *r > OFF_ROTATION)
        .count();
    Errors {
        pairs: errors.len(),
        translation_median: quantile(&t, 0.5),
        translation_p90: quantile(&t, 0.9),
        rotation_median: quantile(&r, 0.5),
        rotation_p90: quantile(&r, 0.9),
        off,
        off_share: if errors.is_empty() {
            0.0
        } else {
            off as f64 / errors.len() as f64
        },
    }
}

#[derive(Serialize)]
struct Output {
    data: String,
    tracker: String,
    odometry: bool,
    max_gap: f64,
    scans: usize,
    sequences: usize,
    tracked: Errors,
    icp_with_odometry_prior: Errors,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    per_pair: Vec<PairErrors>,
}

/// One scored pair (`--per-pair`).
#[derive(Serialize)]
struct PairErrors {
    pair: String,
    /// The tracker's translation (m) and rotation (rad) errors.
    tracked: (f64, f64),
    /// ICP's.
    icp: (f64, f64),
}

/// `(translation error m, rotation error rad)` of `estimate` against `truth`.
fn error(estimate: &Pose2, truth: &Pose2) -> (f64, f64) {
    (
        estimate.translation_error(truth),
        estimate.rotation_error(truth),
    )
}

/// Runs `pgm eval ego-motion`.
pub fn run(args: EgoEvalArgs) -> CliResult {
    if !(args.max_gap.is_finite() && args.max_gap > 0.0) {
        return Err(CliError(format!(
            "--max-gap {}: expected a positive finite number of seconds",
            args.max_gap
        )));
    }
    let truth_source = pair_source(
        args.pairs.as_deref(),
        &args.source,
        &LeighArgs::default(),
        1,
    )?;
    let truth_pairs: Vec<ScanPair> = load_pairs(&truth_source)?
        .pairs
        .into_iter()
        .filter(|p| p.truth.as_ref().is_some_and(|t| t.ego_motion.is_some()))
        .filter(|p| (p.current.timestamp - p.reference.timestamp).abs() <= args.max_gap)
        .collect();
    if truth_pairs.is_empty() {
        return Err(CliError(format!(
            "{truth_source}: no pair with ground-truth ego-motion whose scans are at most \
             {} s apart",
            args.max_gap
        )));
    }
    // The scans the tracker sees: every consecutive scan of the log.
    let run = track_truth_source(
        &truth_source,
        &args.source,
        &args.detector,
        &args.online,
        args.k,
        args.no_odometry,
    )?;
    let reports = run.reports;
    // Scans by stamp: (stamp, sequence, pose).
    let mut stamps: Vec<(f64, usize, Pose2)> = reports
        .iter()
        .map(|r| (r.report.time, r.report.sequence, r.report.pose))
        .collect();
    stamps.sort_by(|a, b| a.0.total_cmp(&b.0));
    let find = |t: f64| {
        let i = stamps.partition_point(|s| s.0 < t - SAME_STAMP);
        stamps
            .get(i)
            .filter(|s| (s.0 - t).abs() <= SAME_STAMP)
            .map(|s| (s.1, s.2))
    };
    let icp = scan_matcher("icp", &MethodOptions::default()).map_err(CliError::from_display)?;
    let mut tracked = Vec::new();
    let mut baseline = Vec::new();
    let mut per_pair = Vec::new();
    for pair in &truth_pairs {
        let truth = pair
            .truth
            .as_ref()
            .and_then(|t| t.ego_motion)
            .expect("filtered");
        let (Some((qa, pa)), Some((qb, pb))) =
            (find(pair.reference.timestamp), find(pair.current.timestamp))
        else {
            continue;
        };
        if qa != qb {
            continue;
        }
        let estimate = pa.inverse().compose(&pb);
        let icp_estimate = icp
            .estimate(pair)
            .map_err(|e| CliError(format!("{}: {e}", pair.name)))?;
        tracked.push(error(&estimate, &truth));
        baseline.push(error(&icp_estimate.motion, &truth));
        if args.per_pair {
            per_pair.push(PairErrors {
                pair: pair.name.clone(),
                tracked: tracked[tracked.len() - 1],
                icp: baseline[baseline.len() - 1],
            });
        }
    }
    if tracked.is_empty() {
        return Err(CliError(format!(
            "{truth_source}: no ground-truth pair has both scans in one tracked sequence"
        )));
    }
    let sequences = sequence_count(&reports);
    let output = Output {
        data: truth_source.to_string(),
        tracker: run.tracker,
        odometry: !args.no_odometry,
        max_gap: args.max_gap,
        scans: run.scans,
        sequences,
        tracked: summarise(&tracked),
        icp_with_odometry_prior: summarise(&baseline),
        per_pair,
    };
    if args.json {
        print_json(&output)?;
    } else {
        println!("data: {}", output.data);
        println!(
            "tracker: {}, {}; {} scans in {} sequences; pairs at most {} s apart",
            output.tracker,
            if output.odometry {
                "odometry prior"
            } else {
                "no odometry"
            },
            output.scans,
            output.sequences,
            output.max_gap
        );
        println!(
            "{:<26} {:>6} {:>9} {:>9} {:>9} {:>9} {:>12}",
            "ego-motion", "pairs", "t med m", "t p90 m", "r med", "r p90", "off (share)"
        );
        for (name, e) in [
            ("online tracker", &output.tracked),
            ("ICP, odometry prior", &output.icp_with_odometry_prior),
        ] {
            println!(
                "{:<26} {:>6} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>5} ({:.2} %)",
                name,
                e.pairs,
                e.translation_median,
                e.translation_p90,
                e.rotation_median,
                e.rotation_p90,
                e.off,
                100.0 * e.off_share
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
