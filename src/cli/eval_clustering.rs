//! `pgm eval clustering`: homogeneity, completeness and V-measure of a clustering
//! method against ground-truth labels (Table I of the CRF-Clustering paper).
//!
//! `pgm eval clustering --method crf|cbd|kmeans|one-cluster (--pairs DIR | --scans FILE
//! --people FILE [--odometry FILE] --k K [--moving-threshold M]) [--associations
//! true|icp|segment-icp] [--weights FILE] [--json]` scores every pair with ground-truth labels and
//! prints the mean and standard deviation over pairs. `--json` prints one object
//! `{"pairs", "homogeneity_mean", "homogeneity_std", "completeness_mean",
//! "completeness_std", "v_measure_mean", "v_measure_std", "iterations_mean"}`.
//! Without odometry the ego-motion comes from the model itself (the largest cluster)
//! or from ICP (CBD, associations). `--no-prior` hides the pairs' odometry prior from
//! the methods while the labels still use it (leigh-gtm1 needs odometry to decide who
//! moved), to measure the methods as they run on a log without odometry.

use super::cluster::{default_associations, AssociationArg, CrfArgs};
use super::data::{load_pairs, LeighArgs, SourceArgs};
use super::{CliError, CliResult};
use clap::{Args, ValueEnum};
use pgm_baselines::consistency::ConsistencyParams;
use pgm_baselines::motion_kmeans::MotionKMeansParams;
use pgm_crf_clustering::evaluation::{
    evaluate_pair, motion_error_summary, summarize, EvaluationConfig, Method, PairOutcome,
};
use rayon::prelude::*;
use std::path::PathBuf;
use std::process::ExitCode;

/// A clustering method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// CRF-Clustering.
    Crf,
    /// The consistency-based detector.
    Cbd,
    /// Motion K-Means (eq. 10).
    Kmeans,
    /// Every point in one cluster.
    OneCluster,
}

/// `pgm eval clustering`.
#[derive(Args, Debug)]
pub struct ClusteringEvalArgs {
    /// The method to evaluate.
    #[arg(long, value_enum)]
    pub method: MethodArg,
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
    #[arg(long, value_enum)]
    pub associations: Option<AssociationArg>,
    /// CRF-Clustering options.
    #[command(flatten)]
    pub crf: CrfArgs,
    /// Motion K-Means: number of clusters.
    #[arg(long, default_value_t = MotionKMeansParams::default().k)]
    pub kmeans_k: usize,
    /// CBD: how much closer (m) than the reference return a dynamic point is.
    #[arg(long, default_value_t = ConsistencyParams::default().margin)]
    pub cbd_margin: f64,
    /// Hide the pairs' odometry prior from the methods (the labels still use it): the
    /// methods run as on a log without odometry.
    #[arg(long)]
    pub no_prior: bool,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Runs `pgm eval clustering`.
pub fn run(args: ClusteringEvalArgs) -> CliResult {
    let mut pairs = match &args.pairs {
        Some(path) => pgm_datasets::read_pairs(path).map_err(CliError::from_display)?,
        None => load_pairs(&args.source, &args.leigh, args.k)?.1,
    };
    if args.no_prior {
        for p in &mut pairs {
            p.odometry = None;
        }
    }
    let scored: Vec<_> = pairs
        .iter()
        .filter(|p| p.truth.as_ref().is_some_and(|t| t.labels.is_some()))
        .collect();
    if scored.is_empty() {
        return Err(CliError(format!(
            "none of the {} pairs has ground-truth labels",
            pairs.len()
        )));
    }
    if scored.len() < pairs.len() {
        eprintln!(
            "note: {} of {} pairs have no ground-truth labels and are not scored",
            pairs.len() - scored.len(),
            pairs.len()
        );
    }
    let which = args.associations.unwrap_or_else(|| {
        if scored
            .iter()
            .all(|p| default_associations(p) == AssociationArg::True)
        {
            AssociationArg::True
        } else {
            AssociationArg::Icp
        }
    });
    let config = EvaluationConfig {
        method: match args.method {
            MethodArg::Crf => Method::Crf,
            MethodArg::Cbd => Method::Cbd,
            MethodArg::Kmeans => Method::KMeans,
            MethodArg::OneCluster => Method::OneCluster,
        },
        associations: args.crf.associations(which),
        clusterer: args.crf.clusterer()?,
        kmeans: MotionKMeansParams {
            k: args.kmeans_k,
            ..MotionKMeansParams::default()
        },
        cbd: ConsistencyParams {
            margin: args.cbd_margin,
            ..ConsistencyParams::default()
        },
    };
    let outcomes: Vec<PairOutcome> = scored
        .par_iter()
        .map(|p| evaluate_pair(p, &config))
        .collect::<Result<_, _>>()
        .map_err(CliError::from_display)?;
    let summary = summarize(&outcomes);
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&summary).map_err(CliError::from_display)?
        );
        return Ok(ExitCode::SUCCESS);
    }
    let assoc = if config.method.needs_associations() {
        format!(", {} associations", config.associations_name())
    } else {
        String::new()
    };
    println!("method {:?}{assoc}: {} pairs", args.method, summary.pairs);
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
    if config.method == Method::Crf {
        let (found, total, centroid, rotation) = motion_error_summary(&outcomes);
        println!(
            "moving objects found {found} of {total}; median motion error {} m at the centroid, {} rad",
            centroid.map_or("-".into(), |x| format!("{x:.3}")),
            rotation.map_or("-".into(), |x| format!("{x:.4}"))
        );
    }
    Ok(ExitCode::SUCCESS)
}
