//! `pgm joint` (the joint model of van de Ven, Ramos and Tipaldi on one pair) and
//! `pgm eval joint` (any joint method scored the way Tables I-III of the joint paper
//! do).
//!
//! `pgm joint (--pairs DIR [--pair NAME|INDEX] | --scans FILE --reference I --current
//! J | --carmen FILE --reference I --current J | --bag FILE --scan-topic T --reference
//! I --current J) [--candidates K|full] [--clusters D|auto] [--weights FILE] [--svg
//! FILE]` prints one JSON object: per current beam its association (a reference beam,
//! `-1` for the outlier state, `null` without a return), the max-marginal confidence
//! of that association, its cluster (an index into `motions`, `-1` for the outlier
//! cluster, `null` without a return); every motion cluster's motion (`motions`, and
//! `cluster_motions` with the cluster's returns and whether it is the background),
//! the background cluster, the ego-motion, the returns in the outlier cluster, sweeps,
//! rounds and convergence. `--svg` draws the association lines and the current scan
//! coloured by cluster (outlier cluster black), like Figs. 3 and 4 of the paper.
//!
//! `pgm eval joint --method joint|icp+kmeans|crf-matching+kmeans|separate (--pairs DIR
//! | log or bag options as pgm eval clustering) [--json]` runs the method on every pair
//! with ground truth ([`pgm_eval::evaluate_joint`]) and prints the
//! data, the pair sets (simulator preset and seed) and the weights it ran with, then
//! the association, clustering, object-motion and ego-motion figures. `--json` prints
//! one object `{"method", "data", "pair_sets", "weights", "pairs",
//! "association_accuracy", "association_accuracy_within_one", "association_sed",
//! "clustering_accuracy", "clustering_sed", "v_measure_mean", "outliers_predicted",
//! "outliers_true", "outliers_found", "object_rotation_error_median",
//! "object_translation_error_median", "ego_rotation_error_median",
//! "ego_translation_error_median", "iterations_mean"}` (accuracies as fractions,
//! outliers as percentages of the scored returns, errors in rad and m; `null` where a
//! figure has nothing to be computed from, such as associations on real data).
//! `--per-pair` adds every pair's outcome (a table, or an `outcomes` array).

use super::cluster::OnePairArgs;
use super::data::{load_pairs, LogPairsArgs};
use super::matching::{parse_state_space, state_space_name, MatchingOptionArgs, MotionFit};
use super::{print_json, to_json, CliError, CliResult};
use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::Args;
use pgm::methods::{
    find, joint_estimator, weights_used, MethodOptions, WeightKind, JOINT_ESTIMATORS,
    JOINT_PAPER_KMEANS_K,
};
use pgm::plot::PairPicture;
use pgm_crf_matching::StateSpace;
use pgm_datasets::ClusterMotion;
use pgm_eval::{evaluate_joint, scorable_for_joint, JointOutcome, JointReport, JointSummary};
use pgm_joint::{Clusters, JointParams, JointResult};
use pgm_scan::methods::{JointCluster, JointEstimate, OutlierReturns};
use pgm_scan::{Association, ParamGuard, Pose2};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// `--object-rotation-sigma`: a standard deviation in rad, or none (`None`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotationSigma(pub Option<f64>);

/// Parses `--object-rotation-sigma`: a standard deviation in rad (> 0), or `none`.
pub fn parse_rotation_sigma(value: &str) -> Result<RotationSigma, String> {
    if value == "none" {
        return Ok(RotationSigma(None));
    }
    match value.parse::<f64>() {
        Ok(sigma) if sigma.is_finite() && sigma > 0.0 => Ok(RotationSigma(Some(sigma))),
        _ => Err(format!(
            "`{value}` is neither `none` nor a standard deviation in rad > 0"
        )),
    }
}

/// Parses `--clusters`: `auto` (adaptive, at most the default number of cluster
/// states) or a fixed number of cluster states `D` (2-32, the outlier cluster
/// included; the paper's experiments use 5).
pub fn parse_clusters(value: &str) -> Result<Clusters, String> {
    if value == "auto" {
        return Ok(JointParams::default().clusters);
    }
    match value.parse::<usize>() {
        Ok(d) if (2..=32).contains(&d) => Ok(Clusters::Fixed(d)),
        _ => Err(format!(
            "`{value}` is neither `auto` nor a number of cluster states in 2..=32 (the \
             outlier cluster included)"
        )),
    }
}

/// The names of the joint methods, for clap.
fn joint_method_names() -> PossibleValuesParser {
    PossibleValuesParser::new(
        JOINT_ESTIMATORS
            .iter()
            .map(|m| PossibleValue::new(m.name).help(m.about)),
    )
}

/// `pgm joint`.
#[derive(Args, Debug)]
pub struct JointArgs {
    /// The pair.
    #[command(flatten)]
    pub source: OnePairArgs,
    /// The association states of a return: `K` (its K nearest reference returns under
    /// its cluster's motion, plus the outlier state; 1-64) or `full` (every reference
    /// return and the outlier state).
    #[arg(long, default_value = "6", value_parser = parse_state_space)]
    pub candidates: StateSpace,
    /// How the background cluster's motion solve ends: `point-to-line` (eq. 6, then
    /// the point-to-line refinement; the default) or `point-to-point` (eq. 6 alone, as
    /// the paper). The other clusters are eq. 6 either way.
    #[arg(long, value_enum, default_value_t = MotionFit::PointToLine)]
    pub motion_fit: MotionFit,
    /// The cluster states: `auto` (one per group of moving segments, at most 8 with the
    /// outlier cluster) or a fixed number `D` (2-32, the outlier cluster included; the
    /// paper's experiments use 5).
    #[arg(long, default_value = "auto", value_parser = parse_clusters, hide_short_help = true)]
    pub clusters: Clusters,
    /// The prior on the rotation of the reported object motions: a standard
    /// deviation in rad around the background's rotation (default 0.05, a car turning
    /// at 0.5 rad/s seen 0.1 s apart), or `none` for eq. 6 alone (inference is the
    /// same either way).
    #[arg(long, default_value = "0.05", value_parser = parse_rotation_sigma, hide_short_help = true)]
    pub object_rotation_sigma: RotationSigma,
    /// Weights and boosters written by `pgm train joint` (default: the shipped ones).
    #[arg(long)]
    pub weights: Option<PathBuf>,
    /// The SVG picture and the MCAP recording.
    #[command(flatten)]
    pub outputs: super::PairOutputArgs,
}

/// One motion cluster in the output of `pgm joint`.
#[derive(Serialize)]
struct ClusterSummary {
    /// Index into `motions` (the value in `clusters`).
    cluster: usize,
    motion: Pose2,
    /// Returns in the cluster.
    points: usize,
    background: bool,
}

#[derive(Serialize)]
struct JointOutput<'a> {
    pair: &'a str,
    weights: String,
    candidates: String,
    /// `--motion-fit` as typed.
    motion_fit: &'static str,
    #[serde(flatten)]
    result: &'a JointResult,
    cluster_motions: Vec<ClusterSummary>,
    /// Returns in the outlier cluster.
    outliers: usize,
}

/// The joint model's parameters from the command line.
fn joint_params(
    candidates: StateSpace,
    motion_fit: MotionFit,
    clusters: Clusters,
    object_rotation_sigma: RotationSigma,
    weights: Option<&Path>,
) -> Result<JointParams, CliError> {
    let mut params = JointParams {
        state_space: candidates,
        point_to_line: motion_fit.point_to_line(),
        clusters,
        object_rotation_sigma: object_rotation_sigma.0,
        ..JointParams::default()
    };
    if let Some(path) = weights {
        params.weights = pgm::methods::load_weights(path, WeightKind::Joint, |p| {
            pgm_joint::JointWeights::load(p)
        })
        .map_err(CliError::from_display)?;
    }
    Ok(params)
}

/// Draws a joint method's `estimate` of `pair` into `path` (see [`with_joint_picture`]).
pub fn draw_joint(
    pair: &pgm_datasets::ScanPair,
    estimate: &JointEstimate,
    title: String,
    path: &Path,
) -> Result<(), CliError> {
    with_joint_picture(pair, estimate, title, |picture| {
        picture.write_svg(path).map_err(CliError::from_display)
    })
}

/// Calls `f` with the picture of a joint method's `estimate` of `pair`: association
/// lines, the current scan coloured by cluster (outlier cluster black), motion arrows
/// and boxes around the moving clusters, aligned by the estimated ego-motion.
fn with_joint_picture<T>(
    pair: &pgm_datasets::ScanPair,
    estimate: &JointEstimate,
    title: String,
    f: impl FnOnce(&PairPicture<'_>) -> T,
) -> T {
    let clustering = estimate.to_motion_clustering(OutlierReturns::Unlabelled);
    let motions: Vec<ClusterMotion> = clustering
        .motions
        .iter()
        .filter(|m| m.label != 0)
        .cloned()
        .collect();
    let mut picture = PairPicture::new(pair);
    picture.labels = Some(&clustering.labels);
    picture.motions = &motions;
    picture.alignment = estimate.ego_motion;
    picture.associations = Some(&estimate.associations);
    picture.framing = pgm::plot::Framing::MovingObjects;
    picture.unlabelled = Some("outlier cluster".into());
    picture.title = title;
    f(&picture)
}

/// Runs `pgm joint`.
pub fn run_joint(args: JointArgs) -> CliResult {
    args.outputs.check(&args.source.inputs())?;
    let pair = args.source.load()?;
    let params = joint_params(
        args.candidates,
        args.motion_fit,
        args.clusters,
        args.object_rotation_sigma,
        args.weights.as_deref(),
    )?;
    let joint = params.check().map_err(CliError::from_display)?;
    let result = joint.estimate(&pair).map_err(CliError::from_display)?;
    let count = |c: JointCluster| result.clusters.iter().filter(|x| **x == Some(c)).count();
    let output = JointOutput {
        pair: &pair.name,
        weights: weights_used(&[WeightKind::Joint], |_| args.weights.as_deref()),
        candidates: state_space_name(args.candidates),
        motion_fit: args.motion_fit.name(),
        result: &result,
        cluster_motions: result
            .motions
            .iter()
            .enumerate()
            .map(|(k, m)| ClusterSummary {
                cluster: k,
                motion: *m,
                points: count(JointCluster::Object(k)),
                background: k == result.background,
            })
            .collect(),
        outliers: count(JointCluster::Outlier),
    };
    let json = to_json(&output)?;
    let estimate = JointEstimate {
        associations: result.associations.clone(),
        clusters: result.clusters.clone(),
        motions: result.motions.clone(),
        background: result.background,
        ego_motion: result.ego_motion,
        iterations: result.sweeps,
        converged: result.converged,
    };
    let outliers = result
        .associations
        .iter()
        .filter(|a| **a == Some(Association::Outlier))
        .count();
    let title = format!(
        "{}: joint model, {} moving clusters, {} association outliers, {} sweeps",
        pair.name,
        result.motions.len().saturating_sub(1),
        outliers,
        result.sweeps
    );
    // Staged before the result is printed, renamed into place after: a command that
    // fails writes nothing.
    let staged = with_joint_picture(&pair, &estimate, title, |picture| {
        args.outputs.stage(picture)
    })?;
    println!("{json}");
    staged.commit(&pair.name)?;
    if !result.converged {
        eprintln!(
            "pgm: warning: the joint model did not converge on {} ({} sweeps in {} rounds); \
             the result may be inaccurate",
            pair.name, result.sweeps, result.rounds
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// `pgm eval joint`.
#[derive(Args, Debug)]
pub struct JointEvalArgs {
    /// The joint method to evaluate.
    #[arg(long, default_value = "joint", value_parser = joint_method_names())]
    pub method: String,
    /// A stored scan-pair data set with ground truth (simulated pairs have
    /// associations, labels and motions).
    #[arg(long, conflicts_with_all = ["carmen", "log", "scans", "bag"])]
    pub pairs: Option<PathBuf>,
    /// Input logs or a bag, labelling and scan distance.
    #[command(flatten)]
    pub logs: LogPairsArgs,
    /// The joint model's weights and boosters, written by `pgm train joint` (default:
    /// the shipped ones).
    #[arg(long)]
    pub weights: Option<PathBuf>,
    /// The joint model's cluster states: `auto` or a fixed `D` (2-32, the outlier
    /// cluster included).
    #[arg(long, default_value = "auto", value_parser = parse_clusters, hide_short_help = true)]
    pub clusters: Clusters,
    /// The prior on the rotation of the reported object motions: a standard
    /// deviation in rad around the background's rotation (default 0.05, a car turning
    /// at 0.5 rad/s seen 0.1 s apart), or `none` for eq. 6 alone (inference is the
    /// same either way).
    #[arg(long, default_value = "0.05", value_parser = parse_rotation_sigma, hide_short_help = true)]
    pub object_rotation_sigma: RotationSigma,
    /// CRF-Matching (crf-matching+kmeans, separate) and the joint model: `--candidates`
    /// sets the association states of both; `--matching-weights` CRF-Matching's.
    #[command(flatten)]
    pub matching: MatchingOptionArgs,
    /// CRF-Clustering's weights for `separate` (default: the shipped ones).
    #[arg(long, hide_short_help = true)]
    pub crf_weights: Option<PathBuf>,
    /// Motion K-Means: number of clusters (the joint paper's experiments: 4).
    #[arg(long, default_value_t = JOINT_PAPER_KMEANS_K, hide_short_help = true)]
    pub kmeans_k: usize,
    /// Also print every pair's outcome (JSON: an `outcomes` array of
    /// [`pgm_eval::JointOutcome`]).
    #[arg(long)]
    pub per_pair: bool,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// The `--json` object of `pgm eval joint`.
#[derive(Serialize)]
struct EvalOutput<'a> {
    method: &'a str,
    data: String,
    /// The distinct pair-name prefixes (`sim:PRESET:SEED`, `leigh-gtm1`, a bag's
    /// stem): which sets and seeds the pairs come from.
    pair_sets: Vec<String>,
    weights: String,
    /// CRF-Matching's and the joint model's `--candidates` and `--motion-fit`, as typed.
    candidates: String,
    motion_fit: &'static str,
    #[serde(flatten)]
    summary: &'a JointSummary,
    #[serde(skip_serializing_if = "Option::is_none")]
    outcomes: Option<&'a [JointOutcome]>,
}

/// The distinct pair-name prefixes (before the last `:`) of `pairs`.
pub fn pair_sets(pairs: &[pgm_datasets::ScanPair]) -> Vec<String> {
    pairs
        .iter()
        .map(|p| {
            p.name
                .rsplit_once(':')
                .map_or(p.name.as_str(), |(set, _)| set)
                .to_string()
        })
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect()
}

/// A figure or `n/a`.
fn show(x: Option<f64>, scale: f64, digits: usize, unit: &str) -> String {
    x.map_or("n/a".into(), |x| format!("{:.digits$}{unit}", scale * x))
}

/// Runs `pgm eval joint`.
pub fn run_eval_joint(args: JointEvalArgs) -> CliResult {
    let source = args.logs.pair_source(args.pairs.as_deref())?;
    let mut options = args.matching.apply(MethodOptions::default())?;
    options.joint = joint_params(
        args.matching.candidates,
        args.matching.motion_fit,
        args.clusters,
        args.object_rotation_sigma,
        args.weights.as_deref(),
    )?;
    if let Some(path) = &args.crf_weights {
        options = options
            .with_crf_weights(path)
            .map_err(CliError::from_display)?;
    }
    options.kmeans.k = args.kmeans_k;
    // Every method's options, used by `--method` or not (`--kmeans-k 0` is refused
    // with `--method joint` too).
    options.check().map_err(CliError::from_display)?;
    let mut pairs = load_pairs(&source)?.pairs;
    let total = pairs.len();
    pairs.retain(scorable_for_joint);
    if pairs.is_empty() {
        return Err(CliError(format!(
            "{source}: none of the {total} pairs has a ground-truth label, association or \
             ego-motion (nothing to score)"
        )));
    }
    if pairs.len() < total {
        eprintln!(
            "note: {} of {total} pairs have no ground truth and are not scored",
            total - pairs.len()
        );
    }
    let method = joint_estimator(&args.method, &options).map_err(CliError::from_display)?;
    let report = evaluate_joint(&pairs, method.as_ref()).map_err(CliError::from_display)?;
    let data = format!("{source}; every pair scored, none trained on");
    let sets = pair_sets(&pairs);
    let entry = find(JOINT_ESTIMATORS, &args.method).expect("clap offers the registered methods");
    let weights = weights_used(entry.weights, |kind| match kind {
        WeightKind::Clustering => args.crf_weights.as_deref(),
        WeightKind::Matching => args.matching.matching_weights.as_deref(),
        WeightKind::Joint => args.weights.as_deref(),
    });
    let unconverged = report.outcomes.iter().filter(|o| !o.converged).count();
    if unconverged > 0 {
        eprintln!(
            "note: {} stopped unconverged on {unconverged} of {} pairs",
            report.method, report.summary.pairs
        );
    }
    if args.json {
        let json = EvalOutput {
            method: &report.method,
            data,
            pair_sets: sets,
            weights,
            candidates: state_space_name(args.matching.candidates),
            motion_fit: args.matching.motion_fit.name(),
            summary: &report.summary,
            outcomes: args.per_pair.then_some(report.outcomes.as_slice()),
        };
        print_json(&json)?;
        return Ok(ExitCode::SUCCESS);
    }
    print_report(&report, &data, &sets, &weights);
    if args.per_pair {
        print_outcomes(&report.outcomes);
    }
    Ok(ExitCode::SUCCESS)
}

/// The text form of a joint report.
fn print_report(report: &JointReport, data: &str, sets: &[String], weights: &str) {
    let s = &report.summary;
    println!("method {}: {} pairs of {data}", report.method, s.pairs);
    println!("pair sets (names before the last `:`): {}", sets.join(", "));
    println!("weights: {weights}");
    println!(
        "associations   {} exact, {} within one beam, SED {}",
        show(s.association_accuracy, 100.0, 2, " %"),
        show(s.association_accuracy_within_one, 100.0, 2, " %"),
        show(s.association_sed, 1.0, 2, "")
    );
    println!(
        "outliers       {} predicted, {} true, {} of the true ones found",
        show(s.outliers_predicted, 1.0, 2, " %"),
        show(s.outliers_true, 1.0, 2, " %"),
        show(s.outliers_found, 1.0, 2, " %")
    );
    println!(
        "clustering     {} accuracy, SED {}, V-measure {}",
        show(s.clustering_accuracy, 100.0, 2, " %"),
        show(s.clustering_sed, 1.0, 2, ""),
        show(s.v_measure_mean, 1.0, 3, "")
    );
    println!(
        "moving objects {} of {} correctly clustered; median error {}, {}",
        report.objects_correct,
        report.objects_total,
        show(s.object_rotation_error_median, 1.0, 4, " rad"),
        show(s.object_translation_error_median, 1.0, 3, " m")
    );
    println!(
        "ego-motion     median error {}, {}",
        show(s.ego_rotation_error_median, 1.0, 5, " rad"),
        show(s.ego_translation_error_median, 1.0, 4, " m")
    );
    println!("iterations     {:.1} mean", s.iterations_mean);
}

/// One line per pair: association and clustering accuracy, objects, ego error.
fn print_outcomes(outcomes: &[JointOutcome]) {
    println!(
        "{:<28} {:>8} {:>8} {:>8} {:>7} {:>9} {:>10} {:>6}",
        "pair", "assoc %", "clust %", "V", "objects", "ego m", "ego rad", "iters"
    );
    for o in outcomes {
        let a = o.association.as_ref();
        let c = o.clustering.as_ref();
        println!(
            "{:<28} {:>8} {:>8} {:>8} {:>7} {:>9} {:>10} {:>6}",
            o.name,
            show(a.map(|a| a.accuracy), 100.0, 2, ""),
            show(c.map(|c| c.accuracy), 100.0, 2, ""),
            show(c.map(|c| c.v_measure.v_measure), 1.0, 3, ""),
            format!(
                "{}/{}",
                o.objects.iter().filter(|x| x.correct).count(),
                o.objects.len()
            ),
            show(o.ego_error.map(|e| e.translation), 1.0, 4, ""),
            show(o.ego_error.map(|e| e.rotation), 1.0, 5, ""),
            o.iterations
        );
    }
}
