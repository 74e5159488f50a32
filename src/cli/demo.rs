//! `pgm demo`: CRF-Clustering on the built-in simulator, no user data needed.
//!
//! Simulates `--pairs` urban pairs (preset `mixed`, seed `--seed`, disjoint from the
//! training seed 1000 of the shipped weights), runs CRF-Clustering with true and with
//! automatic associations and the two baselines through the common evaluation
//! ([`pgm_datasets::evaluation`]), prints mean V-measures and the number of sweeps,
//! and draws pair `--svg-pair` clustered by CRF-Clustering into `--svg`.

use super::cluster::draw;
use super::{CliError, CliResult};
use clap::Args;
use pgm::methods::{association_source, clusterer, MethodOptions};
use pgm_datasets::evaluation::evaluate_clustering;
use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_features::ParamGuard;
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

/// The rows of the demo: label, method, association source.
const ROWS: [(&str, &str, &str); 5] = [
    ("CRF, true associations", "crf", "true"),
    ("CRF, segment-ICP assoc.", "crf", "segment-icp"),
    ("CRF, ICP associations", "crf", "icp"),
    ("CBD", "cbd", "icp"),
    ("motion K-Means, ICP", "kmeans", "icp"),
];

/// Runs `pgm demo`.
pub fn run(args: DemoArgs) -> CliResult {
    if args.pairs == 0 || args.svg_pair >= args.pairs {
        return Err(CliError(format!(
            "--pairs {} and --svg-pair {}: need at least one pair and a pair index below --pairs",
            args.pairs, args.svg_pair
        )));
    }
    super::check_output_file(&args.svg)?;
    let config = SimConfig::default()
        .check()
        .map_err(CliError::from_display)?;
    config
        .check_pairs(args.pairs)
        .map_err(CliError::from_display)?;
    let pairs = simulate_pairs(&config, args.seed, args.pairs);
    let options = MethodOptions::default();
    println!(
        "CRF-Clustering on {} simulated pairs (preset mixed, seed {})",
        pairs.len(),
        args.seed
    );
    println!(
        "{:<28} {:>8} {:>8} {:>8} {:>8}",
        "method", "H", "C", "V", "sweeps"
    );
    for (i, (name, method, associations)) in ROWS.into_iter().enumerate() {
        let source = association_source(associations, &options).map_err(CliError::from_display)?;
        let method = clusterer(method, source, &options).map_err(CliError::from_display)?;
        let report =
            evaluate_clustering(&pairs, method.as_ref()).map_err(CliError::from_display)?;
        let s = report.summary;
        println!(
            "{name:<28} {:>8.3} {:>8.3} {:>8.3} {:>8.1}",
            s.homogeneity_mean, s.completeness_mean, s.v_measure_mean, s.iterations_mean
        );
        if i == 0 {
            let f = report.found_objects;
            println!(
                "{:<28} found {} of {} moving objects; median motion error {} m, {} rad",
                "",
                f.found,
                f.total,
                f.centroid_error_median
                    .map_or("-".into(), |x| format!("{x:.3}")),
                f.rotation_error_median
                    .map_or("-".into(), |x| format!("{x:.4}"))
            );
        }
    }
    let pair = &pairs[args.svg_pair];
    let source = association_source("true", &options).map_err(CliError::from_display)?;
    let clustering = options
        .crf
        .check()
        .map_err(CliError::from_display)?
        .cluster_pair(
            pair,
            &source.associate(pair).map_err(CliError::from_display)?,
        )
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
    eprintln!(
        "pgm: drew pair {} ({}) into {}",
        args.svg_pair,
        pair.name,
        args.svg.display()
    );
    Ok(ExitCode::SUCCESS)
}
