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
//! Methods (see [`pgm::methods::SCAN_MATCHERS`]): `odometry` returns the pair's
//! odometry prior (the identity when the pair has none, as for intel-lab, whose log has
//! no independent odometry); `icp` runs point-to-point ICP
//! ([`pgm_scan::registration`]) started from the same prior. A pair where the
//! method does not converge (too few correspondences: the estimate is the prior) or
//! cannot run is counted in `not_converged` and in a note on stderr.

use super::data::{load_pairs, pair_source, LeighArgs, SourceArgs};
use super::{print_json, CliError, CliResult};
use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::{Args, Subcommand};
use pgm::methods::{scan_matcher, MethodOptions, SCAN_MATCHERS};
use pgm_datasets::metrics::ErrorSummary;
use pgm_datasets::source::SourceKind;
use pgm_eval::evaluate_matching;
use pgm_scan::registration::IcpParams;
use std::path::PathBuf;
use std::process::ExitCode;

/// The names of the scan matchers, for clap.
pub fn matcher_names() -> PossibleValuesParser {
    PossibleValuesParser::new(
        SCAN_MATCHERS
            .iter()
            .map(|m| PossibleValue::new(m.name).help(m.about)),
    )
}

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
    /// Point association: accuracy, edit distance and outliers against the truth.
    Association(super::matching::AssociationEvalArgs),
    /// Joint methods: associations, clusters with the outlier cluster, object motions
    /// and ego-motion against the truth (Tables I-III of the joint paper).
    Joint(super::joint::JointEvalArgs),
    /// Tracking: CLEAR-MOT (MOTA, MOTP, ID switches) of a tracker's output under the
    /// leg_tracker benchmark's protocol and the standard one.
    Tracking(Box<super::eval_tracking::TrackingEvalArgs>),
    /// Ego-motion over a sequence: the online tracker's (with or without the wheel
    /// odometry) beside ICP from the odometry prior.
    EgoMotion(Box<super::eval_ego::EgoEvalArgs>),
}

/// `pgm eval matching`.
#[derive(Args, Debug)]
pub struct MatchingArgs {
    /// The method to evaluate.
    #[arg(long, value_parser = matcher_names())]
    pub method: String,
    /// Input logs.
    #[command(flatten)]
    pub source: SourceArgs,
    /// A stored scan-pair data set (directory, index or pair file) instead of logs.
    #[arg(long, conflicts_with_all = ["carmen", "log", "scans", "bag"])]
    pub pairs: Option<PathBuf>,
    /// Bags: the scan distance of the pairs.
    #[arg(long, default_value_t = 1, allow_hyphen_values = true, value_parser = super::parse_scan_distance)]
    pub k: usize,
    /// Pairs less than this many seconds apart form the subset `near`, others `far`.
    #[arg(long, default_value_t = 1.5, hide_short_help = true)]
    pub near_seconds: f64,
    /// ICP: correspondence distance of the first iteration (m).
    #[arg(long, default_value_t = IcpParams::default().initial_max_distance, hide_short_help = true)]
    pub icp_initial_distance: f64,
    /// ICP: correspondence distance the schedule ends at (m).
    #[arg(long, default_value_t = IcpParams::default().final_max_distance, hide_short_help = true)]
    pub icp_final_distance: f64,
    /// ICP: factor applied to the correspondence distance per iteration.
    #[arg(long, default_value_t = IcpParams::default().distance_decay, hide_short_help = true)]
    pub icp_decay: f64,
    /// ICP: largest number of iterations.
    #[arg(long, default_value_t = IcpParams::default().max_iterations, hide_short_help = true)]
    pub icp_max_iterations: usize,
    /// ICP: convergence tolerance on the change per iteration (m and rad).
    #[arg(long, default_value_t = IcpParams::default().translation_tolerance, hide_short_help = true)]
    pub icp_tolerance: f64,
    /// ICP: match only every N-th return while the distance is coarse.
    #[arg(long, default_value_t = IcpParams::default().coarse_stride, hide_short_help = true)]
    pub icp_coarse_stride: usize,
    /// ICP: fewest matched returns for a rigid fit, at least 2 (fewer: the prior is
    /// kept and the pair counts as not converged).
    #[arg(long, default_value_t = IcpParams::default().min_correspondences, hide_short_help = true)]
    pub icp_min_correspondences: usize,
    /// CRF-Matching options.
    #[command(flatten)]
    pub matching: super::matching::MatchingOptionArgs,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Runs `pgm eval …`.
pub fn run(args: EvalArgs) -> CliResult {
    match args.command {
        EvalCommand::Matching(a) => run_matching(a),
        EvalCommand::Clustering(a) => super::eval_clustering::run(a),
        EvalCommand::Association(a) => super::matching::run_eval_association(a),
        EvalCommand::Joint(a) => super::joint::run_eval_joint(a),
        EvalCommand::Tracking(a) => super::eval_tracking::run(*a),
        EvalCommand::EgoMotion(a) => super::eval_ego::run(*a),
    }
}

fn run_matching(args: MatchingArgs) -> CliResult {
    if !(args.near_seconds.is_finite() && args.near_seconds > 0.0) {
        return Err(CliError(format!(
            "--near-seconds {:?}: expected a positive finite number of seconds",
            args.near_seconds
        )));
    }
    if args.icp_min_correspondences < 2 {
        return Err(CliError(format!(
            "--icp-min-correspondences {}: a rigid fit needs at least 2 matched returns",
            args.icp_min_correspondences
        )));
    }
    let leigh = LeighArgs {
        moving_threshold: 0.0,
        person_radius: 0.35,
        unannotated: Default::default(),
        annotated_sector: false,
    };
    let source = pair_source(args.pairs.as_deref(), &args.source, &leigh, args.k)?;
    let loaded = load_pairs(&source)?;
    let pairs = loaded.pairs;
    let scored = pairs
        .iter()
        .filter(|p| p.truth.as_ref().is_some_and(|t| t.ego_motion.is_some()))
        .count();
    if scored < pairs.len() {
        eprintln!(
            "note: {} of {} pairs have no ground-truth ego-motion and are not scored",
            pairs.len() - scored,
            pairs.len()
        );
    }
    if pairs.iter().any(|p| p.odometry.is_none()) {
        eprintln!("note: pairs without an odometry prior start from the identity");
    }
    let options = MethodOptions {
        icp: IcpParams {
            initial_max_distance: args.icp_initial_distance,
            final_max_distance: args.icp_final_distance,
            distance_decay: args.icp_decay,
            max_iterations: args.icp_max_iterations,
            translation_tolerance: args.icp_tolerance,
            rotation_tolerance: args.icp_tolerance,
            coarse_stride: args.icp_coarse_stride,
            min_correspondences: args.icp_min_correspondences,
        },
        ..MethodOptions::default()
    };
    let options = args.matching.apply(options)?;
    options.check().map_err(CliError::from_display)?;
    let matcher = scan_matcher(&args.method, &options).map_err(CliError::from_display)?;
    let near = matches!(loaded.kind, SourceKind::Relations | SourceKind::Stored)
        .then_some(args.near_seconds);
    let report = evaluate_matching(&pairs, matcher.as_ref(), near)
        .map_err(|e| CliError(format!("{source}: {e}")))?;
    if report.not_converged > 0 {
        let example = report
            .outcomes
            .iter()
            .find(|o| !o.converged)
            .map(|o| {
                let note = o.note.as_deref().unwrap_or("did not converge");
                // An error of the method names the pair already.
                let prefix = format!("pair `{}`: ", o.name);
                format!(
                    " (e.g. pair `{}`: {})",
                    o.name,
                    note.strip_prefix(&prefix).unwrap_or(note)
                )
            })
            .unwrap_or_default();
        eprintln!(
            "note: {} did not converge on {} of {} pairs{example}",
            report.method, report.not_converged, report.all.pairs
        );
    }
    if args.json {
        #[derive(serde::Serialize)]
        struct WithData<'a> {
            data: String,
            #[serde(flatten)]
            report: &'a pgm_eval::MatchingReport,
        }
        let json = WithData {
            data: format!("{source}; every pair scored"),
            report: &report,
        };
        print_json(&json)?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "method {}: {} pairs of {source} (every pair scored)",
        report.method, report.all.pairs
    );
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
        // A subset holding every pair repeats the row above: say so instead.
        if s.pairs == report.all.pairs {
            println!("(every pair is {label})");
        } else {
            print(label, s);
        }
    }
    Ok(ExitCode::SUCCESS)
}
