//! `pgm demo`: CRF-Clustering on the built-in simulator, no user data needed.
//!
//! Simulates `--pairs` urban pairs (preset `mixed`, seed `--seed`, disjoint from the
//! training seed 1000 of the shipped weights), runs CRF-Clustering with true and with
//! ICP associations and the two baselines, prints mean V-measures and the number of
//! sweeps, and draws pair `--svg-pair` clustered by CRF-Clustering into `--svg`.

use super::cluster::draw;
use super::{CliError, CliResult};
use clap::Args;
use pgm_crf_clustering::evaluation::{
    evaluate_pair, motion_error_summary, summarize, EvaluationConfig, Method, PairOutcome,
};
use pgm_crf_clustering::{AssociationProvider, AssociationSource, Clusterer, NearestParams};
use pgm_datasets::sim::{simulate_pairs, SimConfig};
use rayon::prelude::*;
use std::path::PathBuf;
use std::process::ExitCode;

/// `pgm demo`.
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Number of simulated pairs.
    #[arg(long, default_value_t = 20)]
    pub pairs: usize,
    /// Simulator seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// SVG file of one clustered pair.
    #[arg(long, default_value = "crf-clustering.svg")]
    pub svg: PathBuf,
    /// Which pair to draw.
    #[arg(long, default_value_t = 0)]
    pub svg_pair: usize,
}

/// Runs `pgm demo`.
pub fn run(args: DemoArgs) -> CliResult {
    if args.pairs == 0 || args.svg_pair >= args.pairs {
        return Err(CliError(format!(
            "--pairs {} and --svg-pair {}: need at least one pair and a pair index below --pairs",
            args.pairs, args.svg_pair
        )));
    }
    let config = SimConfig::default()
        .check()
        .map_err(CliError::from_display)?;
    let pairs = simulate_pairs(&config, args.seed, args.pairs);
    let clusterer = Clusterer::default();
    let icp = AssociationSource::NearestAfterIcp(NearestParams::default());
    let segment = AssociationSource::automatic();
    println!(
        "CRF-Clustering on {} simulated pairs (preset mixed, seed {})",
        pairs.len(),
        args.seed
    );
    println!(
        "{:<28} {:>8} {:>8} {:>8} {:>8}",
        "method", "H", "C", "V", "sweeps"
    );
    for (name, method, associations) in [
        (
            "CRF, true associations",
            Method::Crf,
            AssociationSource::GroundTruth,
        ),
        ("CRF, segment-ICP assoc.", Method::Crf, segment),
        ("CRF, ICP associations", Method::Crf, icp),
        ("CBD", Method::Cbd, icp),
        ("motion K-Means, ICP", Method::KMeans, icp),
    ] {
        let config = EvaluationConfig {
            method,
            associations,
            clusterer: clusterer.clone(),
            kmeans: Default::default(),
            cbd: Default::default(),
        };
        let outcomes: Vec<PairOutcome> = pairs
            .par_iter()
            .map(|p| evaluate_pair(p, &config))
            .collect::<Result<_, _>>()
            .map_err(CliError::from_display)?;
        let s = summarize(&outcomes);
        println!(
            "{name:<28} {:>8.3} {:>8.3} {:>8.3} {:>8.1}",
            s.homogeneity_mean, s.completeness_mean, s.v_measure_mean, s.iterations_mean
        );
        if method == Method::Crf && associations == AssociationSource::GroundTruth {
            let (found, total, centroid, rotation) = motion_error_summary(&outcomes);
            println!(
                "{:<28} found {found} of {total} moving objects; median motion error {} m, {} rad",
                "",
                centroid.map_or("-".into(), |x| format!("{x:.3}")),
                rotation.map_or("-".into(), |x| format!("{x:.4}"))
            );
        }
    }
    let pair = &pairs[args.svg_pair];
    let a = AssociationSource::GroundTruth
        .associate(pair)
        .map_err(CliError::from_display)?;
    let clustering = clusterer
        .cluster_pair(pair, &a)
        .map_err(CliError::from_display)?;
    draw(
        pair,
        &clustering,
        format!(
            "{}: CRF-Clustering, {} moving objects, {} sweeps",
            pair.name,
            clustering.clusters.len().saturating_sub(1),
            clustering.iterations
        ),
        &args.svg,
    )?;
    println!(
        "drew pair {} ({}) into {}",
        args.svg_pair,
        pair.name,
        args.svg.display()
    );
    Ok(ExitCode::SUCCESS)
}
