//! `pgm train`: learn model weights from labelled data.
//!
//! `pgm train clustering (--data DIR | --simulate N [--seed S] [--preset P])
//! --out weights.json [--associations true|icp|segment-icp|both] [--prior-variance V]` learns the
//! CRF-Clustering weights by pseudo-likelihood (L-BFGS) from labelled pairs: each
//! pair's CRF with features computed from the motions of its true clusters
//! ([`pgm_crf_clustering::learning`]). `both` uses every pair twice, once with true
//! and once with ICP associations.

use super::cluster::CrfArgs;
use super::{CliError, CliResult};
use clap::{Args, Subcommand, ValueEnum};
use pgm::methods::association_source;
use pgm_crf_clustering::learning::{learn, training_instances};
use pgm_crf_matching::learning::{train as train_matching, TrainingOptions};
use pgm_datasets::sim::{simulate_pairs, Preset, SimConfig};
use pgm_scan::ParamGuard;
use std::path::PathBuf;
use std::process::ExitCode;

/// `pgm train …`.
#[derive(Args, Debug)]
pub struct TrainArgs {
    /// What to train.
    #[command(subcommand)]
    pub command: TrainCommand,
}

/// The `pgm train` subcommands.
#[derive(Subcommand, Debug)]
pub enum TrainCommand {
    /// CRF-Clustering weights by pseudo-likelihood.
    Clustering(TrainClusteringArgs),
    /// CRF-Matching boosters and weights (pseudo-likelihood).
    Matching(TrainMatchingArgs),
    /// The joint model's boosters and 30 weights (pseudo-likelihood).
    Joint(TrainJointArgs),
}

/// `pgm train joint`: the options of `pgm train matching`, and where the association
/// chain's part may come from.
#[derive(Args, Debug)]
pub struct TrainJointArgs {
    /// The options shared with `pgm train matching`.
    #[command(flatten)]
    pub common: TrainMatchingArgs,
    /// Take the association chain's 18 weights and two boosters from this CRF-Matching
    /// weight file (written by `pgm train matching`) and learn only the 12 clustering
    /// weights (piecewise training; the shipped weights are made this way).
    #[arg(long, value_name = "FILE")]
    pub association_weights: Option<PathBuf>,
}

/// `pgm train matching` and `pgm train joint`.
#[derive(Args, Debug)]
pub struct TrainMatchingArgs {
    /// Labelled scan-pair data set with ground-truth associations (the simulator's).
    #[arg(long, conflicts_with = "simulate")]
    pub data: Option<PathBuf>,
    /// Instead of --data: simulate this many pairs.
    #[arg(long)]
    pub simulate: Option<usize>,
    /// Simulator seed for --simulate (keep it disjoint from evaluation seeds).
    #[arg(long, default_value_t = 1000)]
    pub seed: u64,
    /// Simulator preset for --simulate.
    #[arg(long, default_value = "mixed")]
    pub preset: String,
    /// Output weight file (JSON: named weights and both boosters).
    #[arg(long)]
    pub out: PathBuf,
    /// Candidates per return.
    #[arg(long, default_value_t = TrainingOptions::default().candidates)]
    pub candidates: usize,
    /// Stumps per booster.
    #[arg(long, default_value_t = TrainingOptions::default().stumps)]
    pub stumps: usize,
    /// Variance of the Gaussian prior on each weight.
    #[arg(long, default_value_t = TrainingOptions::default().prior_variance)]
    pub prior_variance: f64,
}

/// Which associations the training features use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TrainAssociations {
    /// Ground-truth associations.
    True,
    /// Nearest neighbour after ICP.
    Icp,
    /// Segment-wise ICP (see `pgm cluster --associations segment-icp`).
    SegmentIcp,
    /// Every pair once with true and once with ICP associations.
    Both,
}

/// `pgm train clustering`.
#[derive(Args, Debug)]
pub struct TrainClusteringArgs {
    /// Labelled scan-pair data set (directory written by `pgm sim --out` / `pgm data pairs`).
    #[arg(long, conflicts_with = "simulate")]
    pub data: Option<PathBuf>,
    /// Instead of --data: simulate this many pairs.
    #[arg(long)]
    pub simulate: Option<usize>,
    /// Simulator seed for --simulate (keep it disjoint from evaluation seeds).
    #[arg(long, default_value_t = 1000)]
    pub seed: u64,
    /// Simulator preset for --simulate.
    #[arg(long, default_value = "mixed")]
    pub preset: String,
    /// Output weight file (JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Associations used for the training features.
    #[arg(long, value_enum, default_value = "true")]
    pub associations: TrainAssociations,
    /// Variance of the Gaussian prior on each weight.
    #[arg(long, default_value_t = 10.0)]
    pub prior_variance: f64,
    /// CRF options (only --knn and --gate matter for training).
    #[command(flatten)]
    pub crf: CrfArgs,
}

/// Runs `pgm train …`.
pub fn run(args: TrainArgs) -> CliResult {
    match args.command {
        TrainCommand::Clustering(a) => run_clustering(a),
        TrainCommand::Matching(a) => run_matching(a),
        TrainCommand::Joint(a) => run_joint(a),
    }
}

fn run_clustering(args: TrainClusteringArgs) -> CliResult {
    super::check_output_file(&args.out)?;
    let pairs = match (&args.data, args.simulate) {
        (Some(dir), _) => pgm_datasets::read_pairs(dir).map_err(CliError::from_display)?,
        (None, Some(n)) => {
            let preset: Preset = args.preset.parse().map_err(CliError::from_display)?;
            let config = SimConfig {
                preset,
                ..SimConfig::default()
            }
            .check()
            .map_err(CliError::from_display)?;
            config.check_pairs(n).map_err(CliError::from_display)?;
            simulate_pairs(&config, args.seed, n)
        }
        (None, None) => return Err(CliError("give --data DIR or --simulate N".into())),
    };
    let options = args.crf.options()?;
    let clusterer = options
        .crf
        .clone()
        .check()
        .map_err(CliError::from_display)?;
    let names: &[&str] = match args.associations {
        TrainAssociations::True => &["true"],
        TrainAssociations::Icp => &["icp"],
        TrainAssociations::SegmentIcp => &["segment-icp"],
        TrainAssociations::Both => &["true", "icp"],
    };
    let sources = names
        .iter()
        .map(|n| association_source(n, &options))
        .collect::<Result<Vec<_>, _>>()
        .map_err(CliError::from_display)?;
    let sources: Vec<&dyn pgm_scan::AssociationSource> =
        sources.iter().map(|s| s.as_ref()).collect();
    let instances = training_instances(&pairs, &sources, clusterer.params())
        .map_err(|e| in_data(&args.data, e))?;
    if instances.is_empty() {
        return Err(CliError(format!(
            "none of the {} pairs has ground-truth labels",
            pairs.len()
        )));
    }
    // Progress on stderr (indicatif hides it when stderr is not a terminal).
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} L-BFGS {msg} [{elapsed}]")
            .map_err(CliError::from_display)?,
    );
    let mut observer = |p: &pgm_core::learning::Progress| {
        bar.set_message(format!(
            "iteration {}: objective {:.4}, |gradient| {:.2e}",
            p.iteration, p.objective, p.gradient_norm
        ));
        bar.tick();
        std::ops::ControlFlow::Continue(())
    };
    let learned = learn(&instances, args.prior_variance, &mut observer);
    bar.finish_and_clear();
    let (weights, result) = learned.map_err(|e| in_data(&args.data, e))?;
    let named = weights.to_weights().map_err(CliError::from_display)?;
    weights
        .save(&args.out)
        .map_err(|e| CliError(format!("{}: {e}", args.out.display())))?;
    warn_unconverged(result.converged, result.iterations);
    let summary = serde_json::json!({
        "model": "crf-clustering",
        "out": args.out.display().to_string(),
        "instances": instances.len(),
        "pairs": pairs.len(),
        "iterations": result.iterations,
        "converged": result.converged,
        "objective": result.objective,
        "weights": serde_json::from_str::<serde_json::Value>(&named.to_json())
            .map_err(CliError::from_display)?["weights"],
    });
    println!("{summary}");
    Ok(ExitCode::SUCCESS)
}

/// A training error naming the data set it came from (`--data DIR`; simulated pairs
/// name themselves).
fn in_data(data: &Option<PathBuf>, e: impl std::fmt::Display) -> CliError {
    match data {
        Some(dir) => CliError(format!("{}: {e}", dir.display())),
        None => CliError(format!("simulated pairs: {e}")),
    }
}

/// The training pairs of `--data` or `--simulate N --seed S --preset P`.
fn training_pairs(
    data: Option<&std::path::Path>,
    simulate: Option<usize>,
    seed: u64,
    preset: &str,
) -> Result<Vec<pgm_datasets::ScanPair>, CliError> {
    match (data, simulate) {
        (Some(dir), _) => pgm_datasets::read_pairs(dir).map_err(CliError::from_display),
        (None, Some(n)) => {
            let preset: Preset = preset.parse().map_err(CliError::from_display)?;
            let config = SimConfig {
                preset,
                ..SimConfig::default()
            }
            .check()
            .map_err(CliError::from_display)?;
            config.check_pairs(n).map_err(CliError::from_display)?;
            Ok(simulate_pairs(&config, seed, n))
        }
        (None, None) => Err(CliError("give --data DIR or --simulate N".into())),
    }
}

impl TrainMatchingArgs {
    /// `--candidates` in 1..=64, checked before the pairs are read or simulated (the
    /// joint model's learning allocates that many states per return).
    fn check(&self) -> Result<(), CliError> {
        super::check_output_file(&self.out)?;
        if !(1..=64).contains(&self.candidates) {
            return Err(CliError(format!(
                "--candidates {}: expected 1..=64 candidates per return",
                self.candidates
            )));
        }
        Ok(())
    }
}

/// A note on stderr when L-BFGS stopped before converging (the weights are written
/// all the same: they are the best found).
fn warn_unconverged(converged: bool, iterations: u64) {
    if !converged {
        eprintln!(
            "pgm: warning: L-BFGS stopped after {iterations} iterations without converging; \
             the weights written are the last iterate"
        );
    }
}

fn run_matching(args: TrainMatchingArgs) -> CliResult {
    args.check()?;
    let pairs = training_pairs(args.data.as_deref(), args.simulate, args.seed, &args.preset)?;
    let options = TrainingOptions {
        candidates: args.candidates,
        stumps: args.stumps,
        prior_variance: args.prior_variance,
        ..TrainingOptions::default()
    };
    let (bar, mut observer) = learning_progress()?;
    let trained = train_matching(&pairs, &options, &mut observer);
    drop(observer);
    bar.finish_and_clear();
    let (weights, report) = trained.map_err(|e| in_data(&args.data, e))?;
    weights
        .save(&args.out)
        .map_err(|e| CliError(format!("{}: {e}", args.out.display())))?;
    warn_unconverged(report.learning.converged, report.learning.iterations);
    let summary = serde_json::json!({
        "model": "crf-matching",
        "out": args.out.display().to_string(),
        "booster_pairs": report.booster_pairs,
        "data_samples": report.data_samples.0,
        "data_positives": report.data_samples.1,
        "outlier_samples": report.outlier_samples.0,
        "outlier_positives": report.outlier_samples.1,
        "weight_pairs": report.weight_pairs,
        "iterations": report.learning.iterations,
        "converged": report.learning.converged,
        "objective": report.learning.objective,
        "weights": serde_json::from_str::<serde_json::Value>(
            &weights.named().map_err(CliError::from_display)?.to_json()
        )
        .map_err(CliError::from_display)?["weights"],
    });
    println!("{summary}");
    Ok(ExitCode::SUCCESS)
}

/// A spinner and the L-BFGS observer that drives it.
fn learning_progress() -> Result<
    (
        indicatif::ProgressBar,
        impl FnMut(&pgm_core::learning::Progress) -> std::ops::ControlFlow<()>,
    ),
    CliError,
> {
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} L-BFGS {msg} [{elapsed}]")
            .map_err(CliError::from_display)?,
    );
    let shown = bar.clone();
    let observer = move |p: &pgm_core::learning::Progress| {
        shown.set_message(format!(
            "iteration {}: objective {:.4}, |gradient| {:.2e}",
            p.iteration, p.objective, p.gradient_norm
        ));
        shown.tick();
        std::ops::ControlFlow::Continue(())
    };
    Ok((bar, observer))
}

fn run_joint(joint_args: TrainJointArgs) -> CliResult {
    let args = &joint_args.common;
    args.check()?;
    let association = joint_args
        .association_weights
        .as_ref()
        .map(|path| {
            pgm::methods::load_weights(path, pgm::methods::WeightKind::Matching, |p| {
                pgm_joint::AssociationPart::load_matching(p)
            })
        })
        .transpose()
        .map_err(CliError::from_display)?;
    let pairs = training_pairs(args.data.as_deref(), args.simulate, args.seed, &args.preset)?;
    let options = pgm_joint::learning::TrainingOptions {
        candidates: args.candidates,
        stumps: args.stumps,
        prior_variance: args.prior_variance,
        ..pgm_joint::learning::TrainingOptions::default()
    };
    let (bar, mut observer) = learning_progress()?;
    let trained = match &association {
        Some(a) => pgm_joint::learning::train_clustering(&pairs, &options, a, &mut observer),
        None => pgm_joint::learning::train(&pairs, &options, &mut observer),
    };
    drop(observer);
    bar.finish_and_clear();
    let (weights, report) = trained.map_err(|e| in_data(&args.data, e))?;
    weights
        .save(&args.out)
        .map_err(|e| CliError(format!("{}: {e}", args.out.display())))?;
    warn_unconverged(report.learning.converged, report.learning.iterations);
    let summary = serde_json::json!({
        "model": "joint",
        "out": args.out.display().to_string(),
        "association_weights": joint_args
            .association_weights
            .as_ref()
            .map(|p| p.display().to_string()),
        "booster_pairs": report.booster_pairs,
        "data_samples": report.data_samples.0,
        "data_positives": report.data_samples.1,
        "outlier_samples": report.outlier_samples.0,
        "outlier_positives": report.outlier_samples.1,
        "weight_pairs": report.weight_pairs,
        "iterations": report.learning.iterations,
        "converged": report.learning.converged,
        "objective": report.learning.objective,
        "weights": serde_json::from_str::<serde_json::Value>(
            &weights.named().map_err(CliError::from_display)?.to_json()
        )
        .map_err(CliError::from_display)?["weights"],
    });
    println!("{summary}");
    Ok(ExitCode::SUCCESS)
}
