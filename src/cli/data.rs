//! `pgm data`: build scan-pair data sets from real logs and summarise them.
//!
//! - `pgm data pairs --carmen FILE --relations FILE --out DIR`: one pair per relation
//!   (mit-csail style, static labels, true ego-motion).
//! - `pgm data pairs --log FILE --out DIR`: consecutive scans of a CARMEN log with
//!   `VERTEX2` poses (intel-lab style).
//! - `pgm data pairs --scans FILE --people FILE [--odometry FILE] --k K
//!   [--moving-threshold M] --out DIR`: leigh-gtm1 pairs `K` scans apart with
//!   moving-person labels (without odometry only `--moving-threshold 0` works).
//! - `pgm data summary --scans FILE --people FILE [--odometry FILE] [--k 1,3,5]
//!   [--moving-threshold M] [--json]`: for each `k`, the number of pairs, valid returns
//!   per scan, moving-person returns per pair and pairs with a moving person.
//!
//! Pairs are written in the format of `datasets/FORMAT.md`
//! ([`pgm_datasets::format`]). Notes (skipped lines, unmatched relations) go to stderr.

use super::{CliError, CliResult};
use clap::{Args, Subcommand};
use pgm_datasets::builders::{
    consecutive_pairs, leigh_pairs, relation_pairs, summarize_leigh_pairs, LeighPairOptions,
    RelationPairOptions, Unannotated,
};
use pgm_datasets::{carmen, leigh, relations, ScanPair};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// `pgm data …`.
#[derive(Args, Debug)]
pub struct DataArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: DataCommand,
}

/// The `pgm data` subcommands.
#[derive(Subcommand, Debug)]
pub enum DataCommand {
    /// Build a scan-pair data set (directory of JSON files) from real logs.
    Pairs(PairsArgs),
    /// Summarise leigh-gtm1 pairs for several scan distances.
    Summary(SummaryArgs),
}

/// Where pairs come from: exactly one of `--carmen` with `--relations`, `--log`,
/// `--scans` with `--people` (and optionally `--odometry`), or `--pairs`.
#[derive(Args, Debug, Default, Clone)]
pub struct SourceArgs {
    /// CARMEN log (FLASER / ROBOTLASER1) whose scans the relations refer to.
    #[arg(long, requires = "relations")]
    pub carmen: Option<PathBuf>,
    /// Kümmerle-style relations file (`t1 t2 x y z roll pitch yaw`).
    #[arg(long, requires = "carmen")]
    pub relations: Option<PathBuf>,
    /// CARMEN log with VERTEX2 poses: pairs of consecutive scans.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// leigh-gtm1 scan log (`SCAN idx …` lines).
    #[arg(long, requires = "people")]
    pub scans: Option<PathBuf>,
    /// leigh-gtm1 person annotations (`PERSON scan_idx person_id x y`).
    #[arg(long, requires = "scans")]
    pub people: Option<PathBuf>,
    /// leigh-gtm1 odometry per scan (`ODOM idx stamp x y theta`).
    #[arg(long, requires = "scans")]
    pub odometry: Option<PathBuf>,
    /// CARMEN FLASER lines: field of view of the laser in degrees (overrides the log's
    /// PARAM lines and CARMEN's rule for the beam count).
    #[arg(long)]
    pub laser_fov: Option<f64>,
    /// CARMEN FLASER lines: angle between beams in degrees (overrides the log's PARAM
    /// lines and CARMEN's rule for the beam count).
    #[arg(long)]
    pub laser_resolution: Option<f64>,
    /// CARMEN FLASER lines: angle of the first beam in degrees (default -90, CARMEN's).
    #[arg(long, allow_negative_numbers = true)]
    pub laser_start: Option<f64>,
}

impl SourceArgs {
    /// The CARMEN reader options these arguments ask for.
    pub fn carmen_options(&self) -> carmen::CarmenOptions {
        carmen::CarmenOptions {
            front_laser_fov: self.laser_fov,
            front_laser_resolution: self.laser_resolution,
            front_laser_start: self.laser_start,
            ..Default::default()
        }
    }
}

/// Reads a CARMEN log with `options` and notes its skipped lines and where the FLASER
/// beam angles came from.
pub fn read_carmen_log(
    path: &Path,
    options: carmen::CarmenOptions,
) -> Result<carmen::CarmenLog, CliError> {
    let log = carmen::read_carmen_with(path, options).map_err(CliError::from_display)?;
    note_skipped(path, &log.skipped);
    Ok(log)
}

/// Options of the leigh-gtm1 pair builder.
#[derive(Args, Debug, Clone)]
pub struct LeighArgs {
    /// Moving threshold (m): people who moved less are background; 0 makes every
    /// annotated person its own cluster.
    #[arg(long, default_value_t = 0.2)]
    pub moving_threshold: f64,
    /// Returns within this distance (m) of an annotated centre belong to the person.
    #[arg(long, default_value_t = 0.35)]
    pub person_radius: f64,
    /// A person annotated in the current scan but not in the reference scan (unknown
    /// displacement) is `moving` (its own cluster) or `static` (background).
    #[arg(long, default_value_t = Unannotated::Moving)]
    pub unannotated: Unannotated,
    /// Score only the sector of bearings where people were annotated (returns outside
    /// it get no label): the annotators marked people in front of the wheelchair only.
    #[arg(long)]
    pub annotated_sector: bool,
}

/// `pgm data pairs`.
#[derive(Args, Debug)]
pub struct PairsArgs {
    /// Input logs.
    #[command(flatten)]
    pub source: SourceArgs,
    /// leigh-gtm1 options.
    #[command(flatten)]
    pub leigh: LeighArgs,
    /// leigh-gtm1: scan distance of the pairs.
    #[arg(long, default_value_t = 5)]
    pub k: usize,
    /// Output directory: created, or an empty directory, or one holding a data set,
    /// which is replaced (datasets/FORMAT.md; other files are never removed).
    #[arg(long)]
    pub out: PathBuf,
}

/// `pgm data summary`.
#[derive(Args, Debug)]
pub struct SummaryArgs {
    /// leigh-gtm1 scan log.
    #[arg(long)]
    pub scans: PathBuf,
    /// leigh-gtm1 person annotations.
    #[arg(long)]
    pub people: PathBuf,
    /// leigh-gtm1 odometry per scan (needed for a positive moving threshold).
    #[arg(long)]
    pub odometry: Option<PathBuf>,
    /// Scan distances to summarise.
    #[arg(long, value_delimiter = ',', default_value = "1,3,5")]
    pub k: Vec<usize>,
    /// leigh-gtm1 options.
    #[command(flatten)]
    pub leigh: LeighArgs,
    /// Print one JSON array instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Which kind of source the arguments name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SourceKind {
    /// CARMEN log + relations.
    Relations,
    /// CARMEN log with VERTEX2 poses.
    ConsecutiveLog,
    /// leigh-gtm1 text logs.
    Leigh,
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "log".into())
}

fn note_skipped(path: &Path, skipped: &std::collections::BTreeMap<String, usize>) {
    if !skipped.is_empty() {
        let list: Vec<String> = skipped.iter().map(|(k, v)| format!("{k} ×{v}")).collect();
        eprintln!(
            "note: {}: skipped lines: {}",
            path.display(),
            list.join(", ")
        );
    }
}

/// Reads leigh-gtm1 scans (with odometry when given) and annotations.
pub fn read_leigh(
    scans: &Path,
    people: &Path,
    odometry: Option<&Path>,
) -> Result<(leigh::LeighScans, Vec<leigh::PersonAnnotation>), CliError> {
    let mut log = leigh::read_scans(scans).map_err(CliError::from_display)?;
    note_skipped(scans, &log.skipped);
    if let Some(path) = odometry {
        let odo = leigh::read_odometry(path).map_err(CliError::from_display)?;
        leigh::attach_odometry(&mut log, &odo, path).map_err(CliError::from_display)?;
    }
    let annotations = leigh::read_people(people).map_err(CliError::from_display)?;
    Ok((log, annotations))
}

/// Builds pairs from whichever source the arguments name (see [`SourceArgs`]).
pub fn load_pairs(
    source: &SourceArgs,
    leigh_args: &LeighArgs,
    k: usize,
) -> Result<(SourceKind, Vec<ScanPair>), CliError> {
    let given = [
        source.carmen.is_some(),
        source.log.is_some(),
        source.scans.is_some(),
    ]
    .iter()
    .filter(|g| **g)
    .count();
    if given != 1 {
        return Err(CliError(
            "give exactly one source: --carmen FILE --relations FILE, --log FILE, or \
             --scans FILE --people FILE [--odometry FILE]"
                .into(),
        ));
    }
    if let (Some(log_path), Some(rel_path)) = (&source.carmen, &source.relations) {
        let log = read_carmen_log(log_path, source.carmen_options())?;
        let rels = relations::read_relations(rel_path).map_err(CliError::from_display)?;
        let options = RelationPairOptions {
            name: stem(log_path),
            ..Default::default()
        };
        let built = relation_pairs(&log, &rels, &options);
        if !built.unmatched.is_empty() {
            eprintln!(
                "note: {}: {} of {} relations name a time stamp with no scan within {} s \
                 (first on line {})",
                rel_path.display(),
                built.unmatched.len(),
                rels.len(),
                options.tolerance,
                built.unmatched[0].line
            );
        }
        return Ok((SourceKind::Relations, built.pairs));
    }
    if let Some(log_path) = &source.log {
        let log = read_carmen_log(log_path, source.carmen_options())?;
        let built = consecutive_pairs(&log, &stem(log_path));
        if built.odometry_was_ground_truth {
            eprintln!(
                "note: {}: the robot poses of the laser lines equal the VERTEX2 poses; \
                 they are ground truth, not odometry, and were removed (no odometry prior)",
                log_path.display()
            );
        }
        return Ok((SourceKind::ConsecutiveLog, built.pairs));
    }
    let (Some(scans), Some(people)) = (&source.scans, &source.people) else {
        return Err(CliError("--scans needs --people".into()));
    };
    let (log, annotations) = read_leigh(scans, people, source.odometry.as_deref())?;
    let options = LeighPairOptions {
        k,
        moving_threshold: leigh_args.moving_threshold,
        person_radius: leigh_args.person_radius,
        unannotated: leigh_args.unannotated,
        annotated_sector: leigh_args.annotated_sector,
        name: "leigh-gtm1".into(),
    };
    let pairs = leigh_pairs(&log, &annotations, &options)
        .map_err(|e| CliError(format!("{}: {e}", scans.display())))?;
    Ok((SourceKind::Leigh, pairs))
}

/// Runs `pgm data …`.
pub fn run(args: DataArgs) -> CliResult {
    match args.command {
        DataCommand::Pairs(a) => run_pairs(a),
        DataCommand::Summary(a) => run_summary(a),
    }
}

fn run_pairs(args: PairsArgs) -> CliResult {
    let (_, pairs) = load_pairs(&args.source, &args.leigh, args.k)?;
    if pairs.is_empty() {
        return Err(CliError(
            "no pair could be built from the given logs".into(),
        ));
    }
    pgm_datasets::write_pairs(&args.out, &pairs).map_err(CliError::from_display)?;
    println!("wrote {} pairs to {}", pairs.len(), args.out.display());
    Ok(ExitCode::SUCCESS)
}

fn run_summary(args: SummaryArgs) -> CliResult {
    let (log, annotations) = read_leigh(&args.scans, &args.people, args.odometry.as_deref())?;
    let mut rows = Vec::new();
    for &k in &args.k {
        let options = LeighPairOptions {
            k,
            moving_threshold: args.leigh.moving_threshold,
            person_radius: args.leigh.person_radius,
            unannotated: args.leigh.unannotated,
            annotated_sector: args.leigh.annotated_sector,
            name: "leigh-gtm1".into(),
        };
        let pairs = leigh_pairs(&log, &annotations, &options)
            .map_err(|e| CliError(format!("{}: {e}", args.scans.display())))?;
        rows.push(summarize_leigh_pairs(k, &pairs));
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&rows).map_err(CliError::from_display)?
        );
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "leigh-gtm1 pairs (moving threshold {} m, person radius {} m)",
        args.leigh.moving_threshold, args.leigh.person_radius
    );
    println!(
        "{:>3}  {:>5}  {:>12}  {:>20}  {:>24}  {:>13}",
        "k",
        "pairs",
        "returns/scan",
        "moving returns/pair",
        "pairs with moving person",
        "moving people"
    );
    for r in rows {
        println!(
            "{:>3}  {:>5}  {:>12.1}  {:>20.2}  {:>24}  {:>13}",
            r.k,
            r.pairs,
            r.returns_per_scan,
            r.moving_returns_per_pair,
            r.pairs_with_moving_person,
            r.moving_people
        );
    }
    Ok(ExitCode::SUCCESS)
}
