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
use pgm::methods::{association_source, load_weights, WeightKind};
use pgm_core::learning::LearningObjective;
use pgm_crf_clustering::learning::ClusteringTrainer;
use pgm_crf_matching::learning::{MatchingTrainer, TrainingOptions};
use pgm_datasets::sim::{simulate_pairs, Preset, SimConfig};
use pgm_features::training::ModelTrainer;
use pgm_features::ModelWeights;
use pgm_joint::learning::JointTrainer;
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

/// Where the labelled pairs come from and where the weights go (every `pgm train`
/// subcommand).
#[derive(Args, Debug)]
pub struct TrainingDataArgs {
    /// Labelled scan-pair data set (directory written by `pgm sim --out` / `pgm data
    /// pairs`; CRF-Matching and the joint model need ground-truth associations, as the
    /// simulator's).
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
    /// Output weight file (JSON: the model's named weights and its other learned
    /// parts).
    #[arg(long)]
    pub out: PathBuf,
    /// Variance of the Gaussian prior on each weight.
    #[arg(long, default_value_t = TrainingOptions::default().prior_variance)]
    pub prior_variance: f64,
    /// What the weights maximise: `pl` (pseudo-likelihood, as the papers), `ml` (the
    /// likelihood with exact marginals: chains and trees, refused on a model with a
    /// cycle) or `bethe` (the Bethe likelihood of loopy belief propagation).
    #[arg(long, default_value = "pl", value_parser = parse_objective)]
    pub objective: LearningObjective,
}

/// `--objective`.
fn parse_objective(text: &str) -> Result<LearningObjective, String> {
    text.parse()
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
    /// The labelled pairs and the output.
    #[command(flatten)]
    pub data: TrainingDataArgs,
    /// Candidates per return.
    #[arg(long, default_value_t = TrainingOptions::default().candidates)]
    pub candidates: usize,
    /// Stumps per booster.
    #[arg(long, default_value_t = TrainingOptions::default().stumps)]
    pub stumps: usize,
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
    /// The labelled pairs and the output.
    #[command(flatten)]
    pub data: TrainingDataArgs,
    /// Associations used for the training features.
    #[arg(long, value_enum, default_value = "true")]
    pub associations: TrainAssociations,
    /// CRF options (only --knn and --gate matter for training).
    #[command(flatten)]
    pub crf: CrfArgs,
}

/// Runs `pgm train …`: each model's options make its trainer (checked before any pair
/// is read), then one procedure trains any model ([`train`]).
pub fn run(args: TrainArgs) -> CliResult {
    match args.command {
        TrainCommand::Clustering(a) => train(&a.data, &a.trainer()?, &[]),
        TrainCommand::Matching(a) => train(&a.data, &a.trainer()?, &[]),
        TrainCommand::Joint(a) => {
            let shown = a
                .association_weights
                .as_ref()
                .map(|p| p.display().to_string());
            train(
                &a.common.data,
                &a.trainer()?,
                &[("association_weights", shown.into())],
            )
        }
    }
}

impl TrainClusteringArgs {
    /// CRF-Clustering's trainer.
    fn trainer(&self) -> Result<ClusteringTrainer, CliError> {
        super::check_output_file(&self.data.out)?;
        let options = self.crf.options()?;
        let names: &[&str] = match self.associations {
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
        Ok(ClusteringTrainer {
            params: options.crf,
            sources,
            prior_variance: self.data.prior_variance,
            objective: self.data.objective,
        })
    }
}

impl TrainMatchingArgs {
    /// The training options, `--candidates` in 1..=64 checked before the pairs are
    /// read or simulated (the joint model's learning allocates that many states per
    /// return).
    fn options(&self) -> Result<TrainingOptions, CliError> {
        super::check_output_file(&self.data.out)?;
        if !(1..=64).contains(&self.candidates) {
            return Err(CliError(format!(
                "--candidates {}: expected 1..=64 candidates per return",
                self.candidates
            )));
        }
        Ok(TrainingOptions {
            candidates: self.candidates,
            stumps: self.stumps,
            prior_variance: self.data.prior_variance,
            objective: self.data.objective,
            ..TrainingOptions::default()
        })
    }

    /// CRF-Matching's trainer.
    fn trainer(&self) -> Result<MatchingTrainer, CliError> {
        Ok(MatchingTrainer {
            options: self.options()?,
        })
    }
}

impl TrainJointArgs {
    /// The joint model's trainer, with the association part of
    /// `--association-weights` when given.
    fn trainer(&self) -> Result<JointTrainer, CliError> {
        let options = self.common.options()?;
        let association = self
            .association_weights
            .as_ref()
            .map(|path| {
                load_weights(path, WeightKind::Matching, |p| {
                    pgm_joint::AssociationPart::load_matching(p)
                })
            })
            .transpose()
            .map_err(CliError::from_display)?;
        Ok(JointTrainer {
            options,
            association,
        })
    }
}

/// A training error naming the data set it came from (`--data DIR`; simulated pairs
/// name themselves).
fn in_data(data: &Option<PathBuf>, e: impl std::fmt::Display) -> CliError {
    match data {
        Some(dir) => CliError(format!("{}: {e}", dir.display())),
        None => CliError(format!("simulated pairs: {e}")),
    }
}

impl TrainingDataArgs {
    /// The training pairs of `--data` or `--simulate N --seed S --preset P`.
    fn pairs(&self) -> Result<Vec<pgm_datasets::ScanPair>, CliError> {
        match (&self.data, self.simulate) {
            (Some(dir), _) => pgm_datasets::read_pairs(dir).map_err(CliError::from_display),
            (None, Some(n)) => {
                let preset: Preset = self.preset.parse().map_err(CliError::from_display)?;
                let config = SimConfig {
                    preset,
                    ..SimConfig::default()
                }
                .check()
                .map_err(CliError::from_display)?;
                config.check_pairs(n).map_err(CliError::from_display)?;
                Ok(simulate_pairs(&config, self.seed, n))
            }
            (None, None) => Err(CliError("give --data DIR or --simulate N".into())),
        }
    }
}

/// Trains any model: reads or simulates the pairs of `data`, runs `trainer` with a
/// progress spinner on stderr, writes the weight file to `--out` and prints one JSON
/// object: the model, the output, what it learned from (the trainer's counts, and
/// `extra`), the L-BFGS iterations, convergence and objective, and the named weights.
fn train<T: ModelTrainer>(
    data: &TrainingDataArgs,
    trainer: &T,
    extra: &[(&str, serde_json::Value)],
) -> CliResult {
    let pairs = data.pairs()?;
    let (bar, mut observer) = learning_progress()?;
    let trained = trainer.train(&pairs, &mut observer);
    drop(observer);
    bar.finish_and_clear();
    let trained = trained.map_err(|e| in_data(&data.data, e))?;
    let file = trained
        .weights
        .to_weight_file()
        .map_err(CliError::from_display)?;
    file.save(&data.out)
        .map_err(|e| CliError(format!("{}: {e}", data.out.display())))?;
    let learning = &trained.learning;
    if !learning.converged {
        eprintln!(
            "pgm: warning: L-BFGS stopped after {} iterations without converging; \
             the weights written are the last iterate",
            learning.iterations
        );
    }
    let mut summary = serde_json::Map::new();
    summary.insert("model".into(), T::Weights::feature_set().model().into());
    summary.insert("out".into(), data.out.display().to_string().into());
    for (name, value) in extra {
        summary.insert(name.to_string(), value.clone());
    }
    for &(name, count) in &trained.counts {
        summary.insert(name.into(), count.into());
    }
    summary.insert("iterations".into(), learning.iterations.into());
    summary.insert("converged".into(), learning.converged.into());
    summary.insert("objective".into(), learning.objective.into());
    summary.insert("learning_objective".into(), data.objective.name().into());
    let named: serde_json::Value =
        serde_json::from_str(&file.weights.to_json()).map_err(CliError::from_display)?;
    summary.insert("weights".into(), named["weights"].clone());
    println!("{}", serde_json::Value::Object(summary));
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
