//! `pgm cluster`: CRF-Clustering of one scan pair (see [`pgm_crf_clustering`]).
//!
//! The pair comes from a stored data set (`--pairs PATH --pair NAME|INDEX`), from a
//! leigh-gtm1 style log (`--scans FILE --reference I --current J [--odometry FILE]`;
//! `I`, `J` are the log's scan indices) or from a CARMEN log (`--carmen FILE
//! --reference I --current J`; `I`, `J` count the log's FLASER / ROBOTLASER1 lines
//! from 0, and the odometry prior comes from the poses on those lines) or from a ROS
//! bag (`--bag FILE --scan-topic T [--odom-topic T] --reference I --current J`; scans
//! numbered from 0 in record-time order, the odometry prior from the odometry topic).
//! Prints one JSON object: per-beam cluster labels (0 background, 1, 2, … moving
//! objects, null without a return), the clusters with motion, point count and
//! background flag, the number of sweeps and rounds and whether inference converged.
//! `--svg FILE` draws the result like Fig. 4/5 of the paper: points coloured by
//! cluster, motion arrows and boxes around moving objects.

use super::{to_json, CliError, CliResult};
use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::{Args, ValueEnum};
use pgm::methods::{association_source, default_association, MethodOptions, ASSOCIATION_SOURCES};
use pgm::plot::PairPicture;
use pgm_crf_clustering::{Clustering, UpdateSchedule};
use pgm_datasets::{builders, leigh, ClusterMotion, ScanPair};
use pgm_scan::ParamGuard;
use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;

/// The names of the association sources, for clap.
pub fn association_names() -> PossibleValuesParser {
    PossibleValuesParser::new(
        ASSOCIATION_SOURCES
            .iter()
            .map(|m| PossibleValue::new(m.name).help(m.about)),
    )
}

/// When motions are re-solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum UpdateArg {
    /// After every forward-backward sweep.
    EverySweep,
    /// After every variable visit.
    EveryVisit,
}

/// CRF-Clustering and association options shared by `pgm cluster`, `pgm eval
/// clustering` and `pgm train clustering`.
#[derive(Args, Debug, Clone)]
pub struct CrfArgs {
    /// Weight file written by `pgm train clustering` (default: the shipped weights).
    #[arg(long)]
    pub weights: Option<PathBuf>,
    /// Largest number of clusters.
    #[arg(long, default_value_t = MethodOptions::default().crf.max_clusters, hide_short_help = true)]
    pub max_clusters: usize,
    /// Extra edges to each point's K nearest neighbours (0: chain only).
    #[arg(long, default_value_t = 0, hide_short_help = true)]
    pub knn: usize,
    /// Add an outlier state at this partner distance (m).
    #[arg(long, hide_short_help = true)]
    pub outlier_distance: Option<f64>,
    /// Gap (m) that starts a new initial segment.
    #[arg(long, default_value_t = MethodOptions::default().crf.segment_gap, hide_short_help = true)]
    pub segment_gap: f64,
    /// Mean effective number of clusters above which a cluster is merged (eq. 8).
    #[arg(long, default_value_t = MethodOptions::default().crf.merge_threshold, hide_short_help = true)]
    pub merge_threshold: f64,
    /// Smallest displacement (m) of a moving object relative to the background.
    #[arg(long, default_value_t = MethodOptions::default().crf.detection.min_object_displacement, hide_short_help = true)]
    pub min_displacement: f64,
    /// Smallest fraction of a moving object's points that free space shows moved
    /// (0: no free-space test).
    #[arg(long, default_value_t = MethodOptions::default().crf.detection.min_free_fraction, hide_short_help = true)]
    pub min_free_fraction: f64,
    /// When motions are re-solved during message passing.
    #[arg(
        long,
        value_enum,
        default_value = "every-sweep",
        hide_short_help = true
    )]
    pub update: UpdateArg,
    /// ICP associations: gate (m) of the nearest-neighbour search (segment-icp: upper
    /// bound of its range-dependent gate).
    #[arg(long, default_value_t = MethodOptions::default().nearest.gate, hide_short_help = true)]
    pub gate: f64,
    /// CRF-Matching associations.
    #[command(flatten)]
    pub matching: super::matching::MatchingOptionArgs,
}

impl CrfArgs {
    /// The method options these arguments set (everything else at its default).
    pub fn options(&self) -> Result<MethodOptions, CliError> {
        let mut o = MethodOptions::default();
        if let Some(path) = &self.weights {
            o = o.with_crf_weights(path).map_err(CliError::from_display)?;
        }
        o = self.matching.apply(o)?;
        o.crf.max_clusters = self.max_clusters;
        o.crf.knn = self.knn;
        o.crf.outlier_distance = self.outlier_distance;
        o.crf.segment_gap = self.segment_gap;
        o.crf.merge_threshold = self.merge_threshold;
        o.crf.detection.min_object_displacement = self.min_displacement;
        o.crf.detection.min_free_fraction = self.min_free_fraction;
        o.crf.update = match self.update {
            UpdateArg::EverySweep => UpdateSchedule::EverySweep,
            UpdateArg::EveryVisit => UpdateSchedule::EveryVisit,
        };
        o.nearest.gate = self.gate;
        o.segment.nearest.gate = self.gate;
        o.check().map_err(CliError::from_display)?;
        Ok(o)
    }
}

/// One scan pair, from a stored data set or two scans of a log (`pgm cluster`,
/// `pgm match`).
#[derive(Args, Debug, Clone)]
pub struct OnePairArgs {
    /// Stored data set (directory, index.json or pair file).
    #[arg(long, conflicts_with_all = ["scans", "carmen", "bag"])]
    pub pairs: Option<PathBuf>,
    /// ROS bag (`--bag FILE --scan-topic T [--odom-topic T] --reference I --current J`;
    /// scans numbered from 0 in record-time order). Ground-truth topics are accepted
    /// and not used.
    #[command(flatten)]
    pub bag: super::data::BagArgs,
    /// Which pair of the data set: its name or its index from 0.
    #[arg(long, default_value = "0")]
    pub pair: String,
    /// leigh-gtm1 style scan log.
    #[arg(long, requires_all = ["reference", "current"], hide_short_help = true)]
    pub scans: Option<PathBuf>,
    /// Odometry per scan of the log (optional).
    #[arg(long, requires = "scans", hide_short_help = true)]
    pub odometry: Option<PathBuf>,
    /// CARMEN log (FLASER / ROBOTLASER1 lines); the odometry prior comes from the
    /// poses on the laser lines.
    #[arg(long, conflicts_with_all = ["scans", "bag"], requires_all = ["reference", "current"])]
    pub carmen: Option<PathBuf>,
    /// Index of the reference scan in the log (CARMEN: the laser line's position
    /// among the log's laser lines, from 0).
    #[arg(long)]
    pub reference: Option<usize>,
    /// Index of the current scan in the log (as `--reference`).
    #[arg(long)]
    pub current: Option<usize>,
    /// CARMEN FLASER lines: field of view of the laser in degrees (overrides the log's
    /// PARAM lines and CARMEN's rule for the beam count).
    #[arg(long, requires = "carmen", hide_short_help = true)]
    pub laser_fov: Option<f64>,
    /// CARMEN FLASER lines: angle between beams in degrees (overrides as --laser-fov).
    #[arg(long, requires = "carmen", hide_short_help = true)]
    pub laser_resolution: Option<f64>,
    /// CARMEN FLASER lines: angle of the first beam in degrees (default -90, CARMEN's).
    #[arg(
        long,
        requires = "carmen",
        allow_negative_numbers = true,
        hide_short_help = true
    )]
    pub laser_start: Option<f64>,
}

/// `pgm cluster`.
#[derive(Args, Debug)]
pub struct ClusterArgs {
    /// The pair.
    #[command(flatten)]
    pub source: OnePairArgs,
    /// Point associations (default: true when the pair has them, else icp).
    #[arg(long, value_parser = association_names())]
    pub associations: Option<String>,
    /// CRF-Clustering options.
    #[command(flatten)]
    pub crf: CrfArgs,
    /// The SVG picture and the MCAP recording.
    #[command(flatten)]
    pub outputs: super::PairOutputArgs,
}

impl OnePairArgs {
    /// Loads the pair named by the arguments.
    pub fn load(&self) -> Result<ScanPair, CliError> {
        load_pair(self)
    }

    /// The files and directories the pair is read from (outputs may not replace them).
    pub fn inputs(&self) -> Vec<&std::path::Path> {
        [
            self.pairs.as_deref(),
            self.bag.bag.as_deref(),
            self.scans.as_deref(),
            self.odometry.as_deref(),
            self.carmen.as_deref(),
        ]
        .into_iter()
        .flatten()
        .collect()
    }
}

/// Loads the pair named by the arguments.
fn load_pair(args: &OnePairArgs) -> Result<ScanPair, CliError> {
    if let (Some(i), Some(j)) = (args.reference, args.current) {
        // Before the log is read; the builders refuse it too.
        if i == j {
            return Err(CliError(format!(
                "--reference {i} --current {j}: the two scans of a pair must differ"
            )));
        }
    }
    if let Some(path) = &args.pairs {
        // Only the pair asked for is read: a damaged file of another pair does not
        // matter.
        let (pair, count) = pgm_datasets::read_chosen_pair(path, |names| {
            names
                .iter()
                .position(|n| *n == args.pair)
                .or_else(|| args.pair.parse::<usize>().ok())
        })
        .map_err(CliError::from_display)?;
        return pair.ok_or_else(|| {
            CliError(format!(
                "{}: no pair named {:?} and no index {:?} among its {count} pairs",
                path.display(),
                args.pair,
                args.pair,
            ))
        });
    }
    if let Some(path) = &args.bag.bag {
        if args.scans.is_some() {
            return Err(CliError("give --bag or --scans, not both".into()));
        }
        let (Some(i), Some(j)) = (args.reference, args.current) else {
            return Err(CliError(
                "--bag needs --reference I --current J (scans numbered from 0)".into(),
            ));
        };
        let log = pgm_datasets::bag::read_bag(path, &args.bag.topics()?)
            .map_err(CliError::from_display)?;
        let mut notes = Vec::new();
        let pair =
            pgm_datasets::bag::pairs::bag_scan_pair(&log, i, j, args.bag.laser_mount, &mut notes)
                .map_err(CliError::from_display)?;
        for note in notes {
            eprintln!("note: {note}");
        }
        return Ok(pair);
    }
    if let (Some(path), Some(i), Some(j)) = (&args.carmen, args.reference, args.current) {
        let options = pgm_datasets::carmen::CarmenOptions {
            front_laser_fov: args.laser_fov,
            front_laser_resolution: args.laser_resolution,
            front_laser_start: args.laser_start,
            clock: args.bag.stamps,
            ..Default::default()
        };
        let log = pgm_datasets::carmen::read_carmen_with(path, options)
            .map_err(CliError::from_display)?;
        return builders::carmen_scan_pair(path, &log, i, j).map_err(CliError::from_display);
    }
    let (Some(scans), Some(i), Some(j)) = (&args.scans, args.reference, args.current) else {
        return Err(CliError(
            "give --pairs PATH [--pair NAME|INDEX], --scans FILE --reference I --current J, \
             --carmen FILE --reference I --current J, or --bag FILE --scan-topic T \
             --reference I --current J"
                .into(),
        ));
    };
    let mut log = leigh::read_scans(scans).map_err(CliError::from_display)?;
    if let Some(path) = &args.odometry {
        let odo = leigh::read_odometry(path).map_err(CliError::from_display)?;
        leigh::attach_odometry(&mut log, &odo, path).map_err(CliError::from_display)?;
    }
    builders::leigh_scan_pair(scans, &log, i, j).map_err(CliError::from_display)
}

#[derive(Serialize)]
struct Output<'a> {
    pair: &'a str,
    associations: &'a str,
    #[serde(flatten)]
    clustering: &'a Clustering,
}

/// Draws `clustering` of `pair` into `path`.
pub fn draw(
    pair: &ScanPair,
    clustering: &Clustering,
    title: String,
    path: &std::path::Path,
) -> Result<(), CliError> {
    with_picture(pair, clustering, title, |picture| {
        let svg = picture.to_svg_string().map_err(CliError::from_display)?;
        pgm_datasets::format::write_atomically(path, svg.as_bytes()).map_err(CliError::from_display)
    })
}

/// Calls `f` with the picture of `clustering` of `pair`: the current scan coloured by
/// cluster, aligned by the background's motion, each moving cluster's motion.
fn with_picture<T>(
    pair: &ScanPair,
    clustering: &Clustering,
    title: String,
    f: impl FnOnce(&PairPicture<'_>) -> T,
) -> T {
    let motions: Vec<ClusterMotion> = clustering
        .clusters
        .iter()
        .filter(|c| !c.background)
        .map(|c| ClusterMotion {
            label: c.label,
            motion: c.motion,
            kind: "moving".into(),
        })
        .collect();
    let mut picture = PairPicture::new(pair);
    picture.labels = Some(&clustering.labels);
    picture.motions = &motions;
    picture.alignment = clustering.background_motion;
    picture.framing = pgm::plot::Framing::MovingObjects;
    picture.title = title;
    f(&picture)
}

/// Runs `pgm cluster`.
pub fn run(args: ClusterArgs) -> CliResult {
    args.outputs.check(&args.source.inputs())?;
    let pair = args.source.load()?;
    let options = args.crf.options()?;
    let clusterer = options
        .crf
        .clone()
        .check()
        .map_err(CliError::from_display)?;
    let which = args
        .associations
        .as_deref()
        .unwrap_or_else(|| default_association(std::slice::from_ref(&pair)));
    let source = association_source(which, &options).map_err(CliError::from_display)?;
    let associations = source.associate(&pair).map_err(CliError::from_display)?;
    let clustering = clusterer
        .cluster_pair(&pair, &associations)
        .map_err(CliError::from_display)?;
    let output = Output {
        pair: &pair.name,
        associations: source.name(),
        clustering: &clustering,
    };
    let json = to_json(&output)?;
    // The picture and the recording are staged beside their destinations before the
    // result is printed and renamed into place after: a command that fails writes
    // nothing.
    let title = format!(
        "{}: CRF-Clustering ({} associations), {} moving",
        pair.name,
        source.name(),
        clustering.clusters.len().saturating_sub(1)
    );
    let staged = with_picture(&pair, &clustering, title, |picture| {
        args.outputs.stage(picture)
    })?;
    {
        use std::io::Write;
        // A closed pipe (`| head`) is not an error worth a panic.
        let mut out = std::io::stdout().lock();
        if let Err(e) = writeln!(out, "{json}") {
            if e.kind() != std::io::ErrorKind::BrokenPipe {
                return Err(CliError(format!("writing the result: {e}")));
            }
        }
    }
    staged.commit(&pair.name)?;
    if !clustering.converged {
        eprintln!(
            "pgm: warning: CRF-Clustering of {} did not converge ({} sweeps in {} rounds{}); \
             the result may be inaccurate",
            pair.name,
            clustering.iterations,
            clustering.rounds,
            if clustering.background_choice == pgm_crf_clustering::BackgroundChoice::PriorKept {
                "; too few background points for a rigid fit: the background motion is the prior"
            } else {
                ""
            }
        );
    }
    Ok(ExitCode::SUCCESS)
}
