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
use pgm_datasets::builders::{leigh_pairs, summarize_leigh_pairs, LeighPairOptions, Unannotated};
use pgm_datasets::carmen;
use pgm_datasets::source::{read_leigh, LoadedPairs, PairSource};
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

impl LeighArgs {
    /// The pair builder's options for pairs `k` scans apart.
    pub fn options(&self, k: usize) -> LeighPairOptions {
        LeighPairOptions {
            k,
            moving_threshold: self.moving_threshold,
            person_radius: self.person_radius,
            unannotated: self.unannotated,
            annotated_sector: self.annotated_sector,
            name: "leigh-gtm1".into(),
        }
    }
}

/// The pair source the arguments name: `stored` (`--pairs`) or exactly one of the log
/// sources of [`SourceArgs`].
pub fn pair_source(
    stored: Option<&Path>,
    source: &SourceArgs,
    leigh_args: &LeighArgs,
    k: usize,
) -> Result<PairSource, CliError> {
    let given = [
        stored.is_some(),
        source.carmen.is_some(),
        source.log.is_some(),
        source.scans.is_some(),
    ]
    .iter()
    .filter(|g| **g)
    .count();
    if given != 1 {
        return Err(CliError(
            "give exactly one source: --pairs DIR, --carmen FILE --relations FILE, --log FILE, \
             or --scans FILE --people FILE [--odometry FILE]"
                .into(),
        ));
    }
    if let Some(path) = stored {
        return Ok(PairSource::Stored(path.to_path_buf()));
    }
    if let (Some(log), Some(relations)) = (&source.carmen, &source.relations) {
        return Ok(PairSource::CarmenRelations {
            log: log.clone(),
            relations: relations.clone(),
            options: source.carmen_options(),
        });
    }
    if let Some(log) = &source.log {
        return Ok(PairSource::ConsecutiveLog {
            log: log.clone(),
            options: source.carmen_options(),
        });
    }
    let (Some(scans), Some(people)) = (&source.scans, &source.people) else {
        return Err(CliError("--scans needs --people".into()));
    };
    Ok(PairSource::Leigh {
        scans: scans.clone(),
        people: people.clone(),
        odometry: source.odometry.clone(),
        options: leigh_args.options(k),
    })
}

/// Loads the pairs of `source`, printing the readers' notes on stderr.
pub fn load_pairs(source: &PairSource) -> Result<LoadedPairs, CliError> {
    let loaded = source.load().map_err(CliError::from_display)?;
    for note in &loaded.notes {
        eprintln!("note: {note}");
    }
    Ok(loaded)
}

/// Runs `pgm data …`.
pub fn run(args: DataArgs) -> CliResult {
    match args.command {
        DataCommand::Pairs(a) => run_pairs(a),
        DataCommand::Summary(a) => run_summary(a),
    }
}

fn run_pairs(args: PairsArgs) -> CliResult {
    let pairs = load_pairs(&pair_source(None, &args.source, &args.leigh, args.k)?)?.pairs;
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
    let mut notes = Vec::new();
    let (log, annotations) = read_leigh(
        &args.scans,
        &args.people,
        args.odometry.as_deref(),
        &mut notes,
    )
    .map_err(CliError::from_display)?;
    for note in &notes {
        eprintln!("note: {note}");
    }
    let mut rows = Vec::new();
    for &k in &args.k {
        let pairs = leigh_pairs(&log, &annotations, &args.leigh.options(k))
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
