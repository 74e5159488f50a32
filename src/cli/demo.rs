//! `pgm demo`: CRF-Clustering and the joint model on the built-in simulator, no user
//! data needed.
//!
//! Simulates `--pairs` urban pairs (preset `mixed`, seed `--seed`, disjoint from the
//! training seed 1000 of the shipped weights) and runs, through the common evaluation
//! ([`pgm_eval`]):
//!
//! 1. CRF-Clustering with true and with automatic associations and the two baselines:
//!    mean homogeneity, completeness, V-measure and sweeps;
//! 2. the joint model next to the methods of the joint paper's Tables I-III: ICP and
//!    CRF-Matching (associations and ego-motion), motion K-Means on ICP's and on
//!    CRF-Matching's associations (k = 4, as the paper), and the separate pipeline
//!    (CRF-Matching, then CRF-Clustering on its associations): association accuracy,
//!    clustering accuracy with the outlier cluster, V-measure, motion errors of the
//!    correctly clustered objects and of the ego-motion, iterations.
//!
//! It draws pair `--svg-pair` clustered by CRF-Clustering into `--svg` and by the
//! joint model (associations and clusters) into `--joint-svg`.

use super::cluster::draw;
use super::joint::draw_joint;
use super::{or_dash, CliError, CliResult};
use clap::Args;
use pgm::methods::{
    association_source, clusterer, joint_estimator, MethodOptions, JOINT_PAPER_KMEANS_K,
};
use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_eval::{evaluate_association, evaluate_clustering, evaluate_joint};
use pgm_scan::ParamGuard;
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
    /// SVG file of the same pair as the joint model sees it (associations and
    /// clusters).
    #[arg(long, default_value = "joint.svg")]
    pub joint_svg: PathBuf,
    /// Which pair to draw.
    #[arg(long, default_value_t = 0)]
    pub svg_pair: usize,
}

/// Where a row of the joint table comes from.
enum Source {
    /// An association source: associations and ego-motion only.
    Associations(&'static str),
    /// A joint method of [`pgm::methods::JOINT_ESTIMATORS`].
    Joint(&'static str),
}

/// The rows of the joint table: label and method.
const JOINT_ROWS: [(&str, Source); 6] = [
    ("ICP", Source::Associations("icp")),
    ("CRF-Matching", Source::Associations("crf-matching")),
    ("K-Means (ICP)", Source::Joint("icp+kmeans")),
    ("K-Means (CRF-M)", Source::Joint("crf-matching+kmeans")),
    ("separate (CRF-M, CRF-Cl.)", Source::Joint("separate")),
    ("joint model", Source::Joint("joint")),
];

/// `x` scaled with `digits` decimals, or `-`.
fn cell(x: Option<f64>, scale: f64, digits: usize) -> String {
    or_dash(x.map(|x| scale * x), digits)
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
    super::check_output_file(&args.joint_svg)?;
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
                or_dash(f.centroid_error_median, 3),
                or_dash(f.rotation_error_median, 4)
            );
        }
    }
    joint_table(&pairs, &options)?;
    let pair = &pairs[args.svg_pair];
    let source = association_source("true", &options).map_err(CliError::from_display)?;
    let clustering = options
        .crf
        .clone()
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
    let joint = joint_estimator("joint", &options).map_err(CliError::from_display)?;
    let estimate = joint.estimate(pair).map_err(CliError::from_display)?;
    let outliers = estimate
        .clusters
        .iter()
        .filter(|c| **c == Some(pgm_scan::methods::JointCluster::Outlier))
        .count();
    draw_joint(
        pair,
        &estimate,
        format!(
            "{}: joint model, {} moving clusters, {} returns in the outlier cluster, {} sweeps",
            pair.name,
            estimate.motions.len().saturating_sub(1),
            outliers,
            estimate.iterations
        ),
        &args.joint_svg,
    )?;
    eprintln!(
        "pgm: drew pair {} ({}) with the joint model's associations and clusters into {}",
        args.svg_pair,
        pair.name,
        args.joint_svg.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// The joint model next to the methods of the joint paper's Tables I-III.
fn joint_table(pairs: &[pgm_datasets::ScanPair], options: &MethodOptions) -> Result<(), CliError> {
    let mut options = options.clone();
    options.kmeans.k = JOINT_PAPER_KMEANS_K;
    println!(
        "\nThe joint model and the methods of the joint paper's Tables I-III, same pairs \
         (K-Means k = {JOINT_PAPER_KMEANS_K}):"
    );
    println!(
        "{:<26} {:>7} {:>7} {:>7} {:>7} {:>6} {:>8} {:>8} {:>7} {:>8} {:>7}",
        "method",
        "assoc%",
        "±1 %",
        "clust%",
        "V",
        "objs",
        "obj rad",
        "obj m",
        "ego m",
        "ego rad",
        "iters"
    );
    for (label, source) in JOINT_ROWS {
        match source {
            Source::Associations(name) => {
                let method = association_source(name, &options).map_err(CliError::from_display)?;
                let r =
                    evaluate_association(pairs, method.as_ref()).map_err(CliError::from_display)?;
                println!(
                    "{label:<26} {:>7} {:>7} {:>7} {:>7} {:>6} {:>8} {:>8} {:>7} {:>8} {:>7}",
                    cell(Some(r.summary.accuracy), 100.0, 1),
                    cell(Some(r.summary.accuracy_within_one), 100.0, 1),
                    "-",
                    "-",
                    "-",
                    "-",
                    "-",
                    cell(r.ego.map(|e| e.translation_median), 1.0, 3),
                    cell(r.ego.map(|e| e.rotation_median), 1.0, 4),
                    "-"
                );
            }
            Source::Joint(name) => {
                let method = joint_estimator(name, &options).map_err(CliError::from_display)?;
                let r = evaluate_joint(pairs, method.as_ref()).map_err(CliError::from_display)?;
                let s = r.summary;
                println!(
                    "{label:<26} {:>7} {:>7} {:>7} {:>7} {:>6} {:>8} {:>8} {:>7} {:>8} {:>7.1}",
                    cell(s.association_accuracy, 100.0, 1),
                    cell(s.association_accuracy_within_one, 100.0, 1),
                    cell(s.clustering_accuracy, 100.0, 1),
                    cell(s.v_measure_mean, 1.0, 3),
                    format!("{}/{}", r.objects_correct, r.objects_total),
                    cell(s.object_rotation_error_median, 1.0, 4),
                    cell(s.object_translation_error_median, 1.0, 3),
                    cell(s.ego_translation_error_median, 1.0, 3),
                    cell(s.ego_rotation_error_median, 1.0, 4),
                    s.iterations_mean
                );
            }
        }
    }
    println!(
        "(assoc%: exact association accuracy; clust%: clustering accuracy with the outlier \
         cluster; objs: moving objects correctly clustered; obj/ego: median motion errors)"
    );
    Ok(())
}
