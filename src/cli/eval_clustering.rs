//! `pgm eval clustering`: homogeneity, completeness and V-measure of a clustering
//! method against ground-truth labels (Table I of the CRF-Clustering paper).
//!
//! `pgm eval clustering --method NAME (--pairs DIR | --scans FILE --people FILE
//! [--odometry FILE] --k K [--moving-threshold M]) [--associations NAME] [--weights
//! FILE] [--json]` scores every pair with ground-truth labels
//! ([`pgm_datasets::evaluation::evaluate_clustering`]) and prints the mean and standard
//! deviation over pairs. The methods and association sources are those of
//! [`pgm::methods`]. `--json` prints one object `{"method", "pairs",
//! "homogeneity_mean", "homogeneity_std", "completeness_mean", "completeness_std",
//! "v_measure_mean", "v_measure_std", "iterations_mean", "objects_found",
//! "objects_total", "centroid_error_median", "rotation_error_median"}`. Without
//! odometry the ego-motion comes from the model itself (the largest cluster) or from
//! ICP (CBD, associations). `--no-prior` hides the pairs' odometry prior from the
//! methods while the labels still use it (leigh-gtm1 needs odometry to decide who
//! moved), to measure the methods as they run on a log without odometry.

use super::cluster::{association_names, CrfArgs};
use super::data::{load_pairs, pair_source, LeighArgs, SourceArgs};
use super::{CliError, CliResult};
use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::Args;
use pgm::methods::{
    association_source, clusterer, clusterer_needs_associations, default_association, CLUSTERERS,
};
use pgm_datasets::evaluation::{evaluate_clustering, scorable_for_clustering};
use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;

/// The names of the clustering methods, for clap.
pub fn clusterer_names() -> PossibleValuesParser {
    PossibleValuesParser::new(
        CLUSTERERS
            .iter()
            .map(|(name, help)| PossibleValue::new(*name).help(*help)),
    )
}

/// `pgm eval clustering`.
#[derive(Args, Debug)]
pub struct ClusteringEvalArgs {
    /// The method to evaluate.
    #[arg(long, value_parser = clusterer_names())]
    pub method: String,
    /// A stored scan-pair data set with ground-truth labels.
    #[arg(long, conflicts_with_all = ["carmen", "log", "scans"])]
    pub pairs: Option<PathBuf>,
    /// Input logs (leigh-gtm1 style: --scans, --people, optional --odometry).
    #[command(flatten)]
    pub source: SourceArgs,
    /// leigh-gtm1 options (moving threshold, person radius).
    #[command(flatten)]
    pub leigh: LeighArgs,
    /// leigh-gtm1: scan distance of the pairs.
    #[arg(long, default_value_t = 5)]
    pub k: usize,
    /// Point associations for crf and kmeans (default: true when every pair has them,
    /// else icp).
    #[arg(long, value_parser = association_names())]
    pub associations: Option<String>,
    /// CRF-Clustering options.
    #[command(flatten)]
    pub crf: CrfArgs,
    /// Motion K-Means: number of clusters.
    #[arg(long, default_value_t = pgm::methods::MethodOptions::default().kmeans.k)]
    pub kmeans_k: usize,
    /// CBD: how much closer (m) than the reference return a dynamic point is.
    #[arg(long, default_value_t = pgm::methods::MethodOptions::default().cbd.margin)]
    pub cbd_margin: f64,
    /// Hide the pairs' odometry prior from the methods (the labels still use it): the
    /// methods run as on a log without odometry.
    #[arg(long)]
    pub no_prior: bool,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// The `--json` object.
#[derive(Serialize)]
struct Report<'a> {
    method: &'a str,
    #[serde(flatten)]
    summary: &'a pgm_datasets::evaluation::ClusteringSummary,
    objects_found: usize,
    objects_total: usize,
    centroid_error_median: Option<f64>,
    rotation_error_median: Option<f64>,
}

/// Runs `pgm eval clustering`.
pub fn run(args: ClusteringEvalArgs) -> CliResult {
    let source = pair_source(args.pairs.as_deref(), &args.source, &args.leigh, args.k)?;
    let mut pairs = load_pairs(&source)?.pairs;
    if args.no_prior {
        for p in &mut pairs {
            p.odometry = None;
        }
    }
    let total = pairs.len();
    pairs.retain(scorable_for_clustering);
    if pairs.is_empty() {
        return Err(CliError(format!(
            "{source}: none of the {total} pairs has a ground-truth label on any return \
             (nothing to score)"
        )));
    }
    if pairs.len() < total {
        eprintln!(
            "note: {} of {total} pairs have no ground-truth label on any return and are not scored",
            total - pairs.len()
        );
    }
    let mut options = args.crf.options()?;
    options.kmeans.k = args.kmeans_k;
    options.cbd.margin = args.cbd_margin;
    let which = args
        .associations
        .as_deref()
        .unwrap_or_else(|| default_association(&pairs));
    let associations = association_source(which, &options).map_err(CliError::from_display)?;
    let method = clusterer(&args.method, associations, &options).map_err(CliError::from_display)?;
    let report = evaluate_clustering(&pairs, method.as_ref()).map_err(CliError::from_display)?;
    let summary = report.summary;
    let found = report.found_objects;
    if args.json {
        let json = Report {
            method: &report.method,
            summary: &summary,
            objects_found: found.found,
            objects_total: found.total,
            centroid_error_median: found.centroid_error_median,
            rotation_error_median: found.rotation_error_median,
        };
        println!(
            "{}",
            serde_json::to_string(&json).map_err(CliError::from_display)?
        );
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "method {}: {} pairs of {source}",
        report.method, summary.pairs
    );
    println!(
        "homogeneity   {:.3} ± {:.3}",
        summary.homogeneity_mean, summary.homogeneity_std
    );
    println!(
        "completeness  {:.3} ± {:.3}",
        summary.completeness_mean, summary.completeness_std
    );
    println!(
        "V-measure     {:.3} ± {:.3}",
        summary.v_measure_mean, summary.v_measure_std
    );
    println!("iterations    {:.1}", summary.iterations_mean);
    if clusterer_needs_associations(&args.method) {
        println!(
            "moving objects found {} of {}; median motion error {} m at the centroid, {} rad",
            found.found,
            found.total,
            found
                .centroid_error_median
                .map_or("-".into(), |x| format!("{x:.3}")),
            found
                .rotation_error_median
                .map_or("-".into(), |x| format!("{x:.4}"))
        );
    }
    Ok(ExitCode::SUCCESS)
}
