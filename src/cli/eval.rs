//! `pgm eval`: evaluate methods against ground truth.
//!
//! `pgm eval matching --method odometry|icp (--carmen FILE --relations FILE | --log FILE
//! | --pairs PATH) [--json]` estimates the ego-motion of every pair with ground truth
//! and prints the number of pairs and the median and 90th-percentile translation (m)
//! and rotation (rad) errors. For relation files and stored data sets the pairs less
//! than `--near-seconds` (default 1.5 s) apart and the others are also reported as
//! subsets `near` and `far`. `--json` prints one object
//! `{"method", "pairs", "translation_median", "translation_p90", "rotation_median",
//! "rotation_p90", "subsets": {NAME: {same fields}}}`.
//!
//! Methods: `odometry` returns the pair's odometry prior (the identity when the pair
//! has none, as for intel-lab, whose log has no independent odometry); `icp` runs
//! point-to-point ICP ([`pgm_baselines::icp`]) started from the same prior. When ICP
//! cannot run on a pair (a scan without returns) its estimate is the prior and the
//! pair is counted in a note on stderr.

use super::data::{load_pairs, LeighArgs, SourceArgs, SourceKind};
use super::{CliError, CliResult};
use clap::{Args, Subcommand, ValueEnum};
use pgm_baselines::icp::{Icp, IcpParams};
use pgm_datasets::metrics::{motion_error, summarize_errors, ErrorSummary, MotionError};
use pgm_datasets::ScanPair;
use pgm_features::Pose2;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

/// `pgm eval …`.
#[derive(Args, Debug)]
pub struct EvalArgs {
    /// What to evaluate.
    #[command(subcommand)]
    pub command: EvalCommand,
}

/// The `pgm eval` subcommands.
#[derive(Subcommand, Debug)]
pub enum EvalCommand {
    /// Scan matching: ego-motion error against the ground truth.
    Matching(MatchingArgs),
    /// Motion clustering: homogeneity, completeness and V-measure against the labels.
    Clustering(super::eval_clustering::ClusteringEvalArgs),
}

/// A scan-matching method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MatchingMethod {
    /// The odometry prior (identity without odometry).
    Odometry,
    /// Point-to-point ICP started from the odometry prior.
    Icp,
}

/// `pgm eval matching`.
#[derive(Args, Debug)]
pub struct MatchingArgs {
    /// The method to evaluate.
    #[arg(long, value_enum)]
    pub method: MatchingMethod,
    /// Input logs.
    #[command(flatten)]
    pub source: SourceArgs,
    /// A stored scan-pair data set (directory, index or pair file) instead of logs.
    #[arg(long, conflicts_with_all = ["carmen", "log", "scans"])]
    pub pairs: Option<PathBuf>,
    /// Pairs less than this many seconds apart form the subset `near`, others `far`.
    #[arg(long, default_value_t = 1.5)]
    pub near_seconds: f64,
    /// ICP: correspondence distance of the first iteration (m).
    #[arg(long, default_value_t = IcpParams::default().initial_max_distance)]
    pub icp_initial_distance: f64,
    /// ICP: correspondence distance the schedule ends at (m).
    #[arg(long, default_value_t = IcpParams::default().final_max_distance)]
    pub icp_final_distance: f64,
    /// ICP: factor applied to the correspondence distance per iteration.
    #[arg(long, default_value_t = IcpParams::default().distance_decay)]
    pub icp_decay: f64,
    /// ICP: largest number of iterations.
    #[arg(long, default_value_t = IcpParams::default().max_iterations)]
    pub icp_max_iterations: usize,
    /// ICP: convergence tolerance on the change per iteration (m and rad).
    #[arg(long, default_value_t = IcpParams::default().translation_tolerance)]
    pub icp_tolerance: f64,
    /// ICP: match only every N-th return while the distance is coarse.
    #[arg(long, default_value_t = IcpParams::default().coarse_stride)]
    pub icp_coarse_stride: usize,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Runs `pgm eval …`.
pub fn run(args: EvalArgs) -> CliResult {
    match args.command {
        EvalCommand::Matching(a) => run_matching(a),
        EvalCommand::Clustering(a) => super::eval_clustering::run(a),
    }
}

/// Estimates the ego-motion of one pair with `method`; `Err` carries the fallback
/// (the prior) when ICP could not run.
pub fn estimate(
    pair: &ScanPair,
    method: MatchingMethod,
    params: IcpParams,
) -> Result<Pose2, Pose2> {
    let prior = pair.odometry.unwrap_or_default();
    match method {
        MatchingMethod::Odometry => Ok(prior),
        MatchingMethod::Icp => Icp::new(&pair.reference, params)
            .and_then(|icp| icp.align(&pair.current, prior))
            .map(|r| r.motion)
            .map_err(|_| prior),
    }
}

#[derive(Serialize)]
struct Report {
    method: MatchingMethod,
    #[serde(flatten)]
    all: ErrorSummary,
    subsets: BTreeMap<String, ErrorSummary>,
}

fn run_matching(args: MatchingArgs) -> CliResult {
    let (kind, pairs) = match &args.pairs {
        Some(path) => (
            SourceKind::Relations,
            pgm_datasets::read_pairs(path).map_err(CliError::from_display)?,
        ),
        None => {
            let leigh = LeighArgs {
                moving_threshold: 0.0,
                person_radius: 0.35,
                unannotated: Default::default(),
                annotated_sector: false,
            };
            load_pairs(&args.source, &leigh, 1)?
        }
    };
    let with_truth: Vec<(&ScanPair, Pose2)> = pairs
        .iter()
        .filter_map(|p| p.truth.as_ref()?.ego_motion.map(|e| (p, e)))
        .collect();
    if with_truth.is_empty() {
        return Err(CliError(format!(
            "none of the {} pairs has a ground-truth ego-motion",
            pairs.len()
        )));
    }
    if with_truth.len() < pairs.len() {
        eprintln!(
            "note: {} of {} pairs have no ground-truth ego-motion and are not scored",
            pairs.len() - with_truth.len(),
            pairs.len()
        );
    }
    if with_truth.iter().any(|(p, _)| p.odometry.is_none()) {
        eprintln!("note: pairs without an odometry prior start from the identity");
    }
    let params = IcpParams {
        initial_max_distance: args.icp_initial_distance,
        final_max_distance: args.icp_final_distance,
        distance_decay: args.icp_decay,
        max_iterations: args.icp_max_iterations,
        translation_tolerance: args.icp_tolerance,
        rotation_tolerance: args.icp_tolerance,
        coarse_stride: args.icp_coarse_stride,
    };
    params.check().map_err(CliError::from_display)?;
    let results: Vec<(MotionError, f64, bool)> = with_truth
        .par_iter()
        .map(|(pair, truth)| {
            let (estimate, failed) = match estimate(pair, args.method, params) {
                Ok(e) => (e, false),
                Err(e) => (e, true),
            };
            (
                motion_error(&estimate, truth),
                pair.time_gap().abs(),
                failed,
            )
        })
        .collect();
    let failed = results.iter().filter(|r| r.2).count();
    if failed > 0 {
        eprintln!("note: ICP could not run on {failed} pairs; their estimate is the prior");
    }
    let errors: Vec<MotionError> = results.iter().map(|r| r.0).collect();
    let all = summarize_errors(&errors).ok_or_else(|| CliError("no pair to score".into()))?;
    let mut subsets = BTreeMap::new();
    if kind == SourceKind::Relations {
        let near: Vec<MotionError> = results
            .iter()
            .filter(|r| r.1 < args.near_seconds)
            .map(|r| r.0)
            .collect();
        let far: Vec<MotionError> = results
            .iter()
            .filter(|r| r.1 >= args.near_seconds)
            .map(|r| r.0)
            .collect();
        for (name, set) in [("near", near), ("far", far)] {
            if let Some(s) = summarize_errors(&set) {
                subsets.insert(name.to_string(), s);
            }
        }
    }
    let report = Report {
        method: args.method,
        all,
        subsets,
    };
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&report).map_err(CliError::from_display)?
        );
        return Ok(ExitCode::SUCCESS);
    }
    let method = match args.method {
        MatchingMethod::Odometry => "odometry",
        MatchingMethod::Icp => "icp",
    };
    println!("method {method}: {} pairs", report.all.pairs);
    println!(
        "{:<24}  {:>5}  {:>14}  {:>12}  {:>15}  {:>13}",
        "subset", "pairs", "transl. median", "transl. p90", "rot. median", "rot. p90"
    );
    let print = |name: String, s: &ErrorSummary| {
        println!(
            "{:<24}  {:>5}  {:>12.4} m  {:>10.4} m  {:>11.5} rad  {:>9.5} rad",
            name,
            s.pairs,
            s.translation_median,
            s.translation_p90,
            s.rotation_median,
            s.rotation_p90
        );
    };
    print("all".into(), &report.all);
    for (name, s) in &report.subsets {
        let label = match name.as_str() {
            "near" => format!("near (< {} s apart)", args.near_seconds),
            "far" => format!("far (>= {} s apart)", args.near_seconds),
            other => other.to_string(),
        };
        print(label, s);
    }
    Ok(ExitCode::SUCCESS)
}
