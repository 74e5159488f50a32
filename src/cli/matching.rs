//! `pgm match` (CRF-Matching of one pair) and `pgm eval association` (association
//! accuracy of any association source against ground truth, Table I of the joint
//! paper).
//!
//! `pgm match (--pairs DIR [--pair NAME|INDEX] | --scans FILE --reference I --current J
//! | --carmen FILE --reference I --current J) [--matching-weights FILE] [--svg FILE]`
//! prints one JSON object: per current beam the association (a reference beam, `-1`
//! for an outlier, `null` without a return) and its max-marginal confidence, the
//! ego-motion, every motion group's motion, sweeps, rounds and convergence. `--svg`
//! draws the association lines like Fig. 3 of the joint paper.
//!
//! `pgm eval association --method NAME --pairs DIR [--json]` scores every pair with
//! ground-truth associations: exact accuracy (the same reference beam, or both
//! outlier), accuracy within one beam, string edit distance, and the outlier
//! percentages (predicted, true, and the share of true outliers found).

use super::cluster::{association_names, OnePairArgs};
use super::data::{load_pairs, pair_source, LeighArgs, SourceArgs};
use super::{CliError, CliResult};
use clap::Args;
use pgm::methods::{association_source, MethodOptions};
use pgm::plot::PairPicture;
use pgm_crf_matching::StateSpace;
use pgm_datasets::metrics::{
    association_accuracy_within, association_edit_distance, outlier_stats,
};
use pgm_features::ParamGuard;
use rayon::prelude::*;
use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;

/// The CRF-Matching options every command that runs it takes.
#[derive(Args, Debug, Clone)]
pub struct MatchingOptionArgs {
    /// CRF-Matching: weights and boosters written by `pgm train matching` (default:
    /// the shipped ones).
    #[arg(long)]
    pub matching_weights: Option<PathBuf>,
    /// CRF-Matching: the states of a point: `K` (its K nearest reference returns under
    /// its motion estimate, plus the outlier state; 1-64) or `full` (every reference
    /// return and the outlier state).
    #[arg(long, default_value = "6", value_parser = parse_state_space)]
    pub candidates: StateSpace,
}

/// Parses `--candidates`.
fn parse_state_space(value: &str) -> Result<StateSpace, String> {
    if value == "full" {
        return Ok(StateSpace::Full);
    }
    match value.parse::<usize>() {
        Ok(k) if (1..=64).contains(&k) => Ok(StateSpace::Pruned(k)),
        _ => Err(format!(
            "`{value}` is neither `full` nor a number of candidates in 1..=64"
        )),
    }
}

impl MatchingOptionArgs {
    /// `options` with these CRF-Matching settings.
    pub fn apply(&self, mut options: MethodOptions) -> Result<MethodOptions, CliError> {
        if let Some(path) = &self.matching_weights {
            options = options
                .with_matching_weights(path)
                .map_err(CliError::from_display)?;
        }
        options.matching.state_space = self.candidates;
        Ok(options)
    }
}

/// `pgm match`.
#[derive(Args, Debug)]
pub struct MatchArgs {
    /// The pair.
    #[command(flatten)]
    pub source: OnePairArgs,
    /// CRF-Matching options.
    #[command(flatten)]
    pub matching: MatchingOptionArgs,
    /// Draw the associations into this SVG file.
    #[arg(long)]
    pub svg: Option<PathBuf>,
}

#[derive(Serialize)]
struct MatchOutput<'a> {
    pair: &'a str,
    #[serde(flatten)]
    matching: &'a pgm_crf_matching::Matching,
}

/// Runs `pgm match`.
pub fn run_match(args: MatchArgs) -> CliResult {
    let pair = args.source.load()?;
    let options = args.matching.apply(MethodOptions::default())?;
    let matcher = options
        .matching
        .clone()
        .check()
        .map_err(CliError::from_display)?;
    let matching = matcher.match_pair(&pair).map_err(CliError::from_display)?;
    let json = serde_json::to_string(&MatchOutput {
        pair: &pair.name,
        matching: &matching,
    })
    .map_err(CliError::from_display)?;
    // Staged before the result is printed, renamed into place after: a command that
    // fails writes nothing.
    let staged = match &args.svg {
        Some(path) => {
            let mut picture = PairPicture::new(&pair);
            picture.labels = None;
            picture.motions = &[];
            picture.alignment = matching.motion;
            picture.associations = Some(&matching.associations);
            picture.title = format!(
                "{}: CRF-Matching, {} outliers",
                pair.name,
                matching
                    .associations
                    .iter()
                    .filter(|a| **a == Some(pgm_features::Association::Outlier))
                    .count()
            );
            let svg = picture.to_svg_string().map_err(CliError::from_display)?;
            Some(
                pgm_datasets::format::StagedFile::stage(path, svg.as_bytes())
                    .map_err(CliError::from_display)?,
            )
        }
        None => None,
    };
    println!("{json}");
    if let (Some(staged), Some(path)) = (staged, &args.svg) {
        staged.commit().map_err(CliError::from_display)?;
        eprintln!("pgm: drew {} into {}", pair.name, path.display());
    }
    if !matching.converged {
        eprintln!(
            "pgm: warning: CRF-Matching of {} did not converge: {}",
            pair.name,
            matching.note.as_deref().unwrap_or(
                "the last round stopped at its sweep limit; the result may be inaccurate"
            )
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// `pgm eval association`.
#[derive(Args, Debug)]
pub struct AssociationEvalArgs {
    /// The association source to evaluate.
    #[arg(long, value_parser = association_names())]
    pub method: String,
    /// A stored scan-pair data set with ground-truth associations.
    #[arg(long, conflicts_with_all = ["carmen", "log", "scans"])]
    pub pairs: Option<PathBuf>,
    /// Input logs (rarely useful: real logs have no true associations).
    #[command(flatten)]
    pub source: SourceArgs,
    /// CRF-Matching options (crf-matching).
    #[command(flatten)]
    pub matching: MatchingOptionArgs,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// The `--json` object of `pgm eval association`.
#[derive(Serialize)]
struct AssociationReport {
    method: String,
    pairs: usize,
    /// Exact accuracy, a fraction.
    accuracy: f64,
    /// Accuracy within one reference beam, a fraction.
    accuracy_within_one: f64,
    /// Mean string edit distance per pair.
    sed_mean: f64,
    /// Predicted outliers, percent of the scored returns.
    outliers_predicted: f64,
    /// True outliers, percent of the scored returns.
    outliers_true: f64,
    /// Percent of the true outliers predicted as outliers.
    outliers_found: f64,
}

/// Runs `pgm eval association`.
pub fn run_eval_association(args: AssociationEvalArgs) -> CliResult {
    let leigh = LeighArgs {
        moving_threshold: 0.0,
        person_radius: 0.35,
        unannotated: Default::default(),
        annotated_sector: false,
    };
    let source = pair_source(args.pairs.as_deref(), &args.source, &leigh, 1)?;
    let pairs = load_pairs(&source)?.pairs;
    let scored: Vec<_> = pairs
        .iter()
        .filter(|p| {
            p.truth
                .as_ref()
                .and_then(|t| t.associations.as_ref())
                .is_some_and(|a| a.iter().any(Option::is_some))
        })
        .collect();
    if scored.is_empty() {
        return Err(CliError(format!(
            "{source}: none of the {} pairs has ground-truth associations (simulated pairs \
             have them; real logs do not)",
            pairs.len()
        )));
    }
    if scored.len() < pairs.len() {
        eprintln!(
            "note: {} of {} pairs have no ground-truth associations and are not scored",
            pairs.len() - scored.len(),
            pairs.len()
        );
    }
    let options = args.matching.apply(MethodOptions::default())?;
    let method = association_source(&args.method, &options).map_err(CliError::from_display)?;
    let rows: Vec<[f64; 6]> = scored
        .par_iter()
        .map(|pair| -> Result<[f64; 6], CliError> {
            let truth = pair
                .truth
                .as_ref()
                .and_then(|t| t.associations.as_ref())
                .expect("filtered");
            let predicted = method
                .associate(pair)
                .map_err(CliError::from_display)?
                .associations;
            let e = |e: pgm_datasets::Error| CliError(format!("pair `{}`: {e}", pair.name));
            let exact = association_accuracy_within(truth, &predicted, 0).map_err(e)?;
            let within = association_accuracy_within(truth, &predicted, 1).map_err(e)?;
            let sed = association_edit_distance(truth, &predicted).map_err(e)?;
            let outliers = outlier_stats(truth, &predicted).map_err(e)?;
            match (exact, within, outliers) {
                (Some(a), Some(b), Some(o)) => Ok([
                    a,
                    b,
                    sed as f64,
                    o.predicted_percentage,
                    o.true_percentage,
                    o.found_percentage,
                ]),
                _ => Err(CliError(format!(
                    "pair `{}`: no return with a ground-truth association",
                    pair.name
                ))),
            }
        })
        .collect::<Result<_, _>>()?;
    let n = rows.len() as f64;
    let mean = |k: usize| rows.iter().map(|r| r[k]).sum::<f64>() / n;
    let report = AssociationReport {
        method: method.name().to_string(),
        pairs: rows.len(),
        accuracy: mean(0),
        accuracy_within_one: mean(1),
        sed_mean: mean(2),
        outliers_predicted: mean(3),
        outliers_true: mean(4),
        outliers_found: mean(5),
    };
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&report).map_err(CliError::from_display)?
        );
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "method {}: {} pairs of {source}",
        report.method, report.pairs
    );
    println!("accuracy (exact)        {:.1} %", 100.0 * report.accuracy);
    println!(
        "accuracy within 1 beam  {:.1} %",
        100.0 * report.accuracy_within_one
    );
    println!("string edit distance    {:.1}", report.sed_mean);
    println!(
        "outliers                {:.1} % predicted, {:.1} % true, {:.1} % of the true ones found",
        report.outliers_predicted, report.outliers_true, report.outliers_found
    );
    Ok(ExitCode::SUCCESS)
}
