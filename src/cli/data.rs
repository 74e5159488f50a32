//! `pgm data`: build scan-pair data sets from real logs and summarise them.
//!
//! - `pgm data pairs --carmen FILE --relations FILE --out DIR`: one pair per relation
//!   (mit-csail style: true ego-motion, no motion labels).
//! - `pgm data pairs --log FILE --out DIR`: consecutive scans of a CARMEN log; with
//!   `VERTEX2` poses they carry the true ego-motion (intel-lab style), without them no
//!   ground truth.
//! - `pgm data pairs --scans FILE --people FILE [--odometry FILE] --k K
//!   [--moving-threshold M] --out DIR`: leigh-gtm1 pairs `K` scans apart with
//!   moving-person labels (without odometry only `--moving-threshold 0` works).
//! - `pgm data pairs --bag FILE --scan-topic T [--odom-topic T] [--people-topic T]
//!   [--ego-pose-topic T [--object-pose-topic T --object-footprint L,W,CX,CY]]
//!   [--laser-mount X,Y,YAW] [--pose-delay S] [--label-margin M] [--object-min-speed V]
//!   --k K --out DIR`: pairs of a ROS bag `K` scans apart with the ground truth its
//!   topics give ([`pgm_datasets::bag::pairs`]).
//! - `pgm data summary (--scans FILE --people FILE [--odometry FILE] | --bag FILE
//!   --scan-topic T --odom-topic T --people-topic T) [--k 1,3,5] [--json]`: for each
//!   `k` and each labelling rule (track, displacement), the number of pairs, valid
//!   returns per scan, moving-person returns per pair and pairs with a moving person.
//!
//! leigh-gtm1 labels follow `--labels track` (default; `--walking-speed`,
//! `--track-window`) or `--labels displacement` (`--moving-threshold`,
//! `--unannotated`).
//!
//! Pairs are written in the format of `datasets/FORMAT.md`
//! ([`pgm_datasets::format`]). Notes (skipped lines, unmatched relations) go to stderr.

use super::{or_dash, print_json, CliError, CliResult};
use clap::{Args, Subcommand};
use pgm_datasets::bag::pairs::BagPairOptions;
use pgm_datasets::bag::pairs::{laser_mount, prepared_scans, to_leigh};
use pgm_datasets::bag::read_bag;
use pgm_datasets::bag::BagTopics;
use pgm_datasets::builders::{
    leigh_pairs, summarize_leigh_pairs, LabelRule, LeighPairOptions, Unannotated,
};
use pgm_datasets::mocap::{Footprint, MocapOptions};
use pgm_datasets::source::{read_leigh, LoadedPairs, PairSource};
use pgm_datasets::stamps::StampClock;
use pgm_datasets::{carmen, leigh};
use pgm_scan::Pose2;
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

/// A ROS bag as the source (`--bag FILE --scan-topic T …`): what every command that
/// reads a scan log also reads.
#[derive(Args, Debug, Clone)]
pub struct BagArgs {
    /// ROS bag: a ROS 1 `.bag`, an MCAP file, a ROS 2 bag directory (MCAP storage), or
    /// a `.zip` holding one bag.
    #[arg(long)]
    pub bag: Option<PathBuf>,
    /// Bag: topic of the laser scans (sensor_msgs/LaserScan).
    #[arg(long, requires = "bag")]
    pub scan_topic: Option<String>,
    /// Bag: topic of the wheel odometry (nav_msgs/Odometry), the prior.
    #[arg(long, requires = "bag")]
    pub odom_topic: Option<String>,
    /// Bag: topic of the annotated people (leigh-gtm1 leg_tracker/Person): labels by
    /// the leigh-gtm1 rules.
    #[arg(long, requires = "bag", hide_short_help = true)]
    pub people_topic: Option<String>,
    /// Bag: topic of the robot's true pose (motion capture, geometry_msgs/PoseStamped):
    /// the true ego-motion.
    #[arg(long, requires = "bag", hide_short_help = true)]
    pub ego_pose_topic: Option<String>,
    /// Bag: topic of a moving object's true pose (motion capture): its motion and
    /// per-point labels from --object-footprint.
    #[arg(long, requires = "ego_pose_topic", hide_short_help = true)]
    pub object_pose_topic: Option<String>,
    /// Bag: the laser's pose X,Y,YAW (m, m, rad) in the robot frame that the odometry
    /// and the ego pose follow (default: the bag's tf, else the identity).
    #[arg(long, requires = "bag", allow_hyphen_values = true, value_parser = parse_pose, hide_short_help = true)]
    pub laser_mount: Option<Pose2>,
    /// Bag: the pose that matches a scan is read at its header stamp plus this many
    /// seconds.
    #[arg(
        long,
        requires = "bag",
        default_value_t = 0.0,
        allow_hyphen_values = true,
        hide_short_help = true
    )]
    pub pose_delay: f64,
    /// Bag: the object's footprint LENGTH,WIDTH,CENTRE_X,CENTRE_Y (m), a rectangle in
    /// its pose frame.
    #[arg(long, requires = "object_pose_topic", allow_hyphen_values = true, value_parser = parse_footprint, hide_short_help = true)]
    pub object_footprint: Option<Footprint>,
    /// Bag: returns within this distance (m) of the object's footprint are the object.
    #[arg(long, requires = "bag", default_value_t = MocapOptions::default().label_margin, hide_short_help = true)]
    pub label_margin: f64,
    /// Bag: the object is a mover only when it moves at least this fast (m/s) between
    /// the two scans, else its returns are static background (0: always a mover).
    #[arg(long, requires = "bag", default_value_t = MocapOptions::default().object_min_speed, hide_short_help = true)]
    pub object_min_speed: f64,
    /// Which clock places the messages of a bag, a leigh-gtm1 text log or a CARMEN log
    /// in time: `auto` uses the header stamps (CARMEN: ipc_timestamp) unless a
    /// topic's are zero, repeated or go backwards, then the record times (CARMEN:
    /// logger_timestamp) for every topic; `header` refuses such stamps; `record` always
    /// uses record times.
    #[arg(long, default_value_t = StampClock::Auto, value_parser = parse_clock, hide_short_help = true)]
    pub stamps: StampClock,
}

pub(super) fn parse_clock(text: &str) -> Result<StampClock, String> {
    text.parse()
}

impl Default for BagArgs {
    fn default() -> Self {
        Self {
            bag: None,
            scan_topic: None,
            odom_topic: None,
            people_topic: None,
            ego_pose_topic: None,
            object_pose_topic: None,
            laser_mount: None,
            pose_delay: 0.0,
            object_footprint: None,
            label_margin: MocapOptions::default().label_margin,
            object_min_speed: MocapOptions::default().object_min_speed,
            stamps: StampClock::Auto,
        }
    }
}

fn numbers<const N: usize>(text: &str, what: &str) -> Result<[f64; N], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!(
            "{text:?}: expected {what} ({N} numbers separated by commas)"
        ));
    }
    let mut out = [0.0; N];
    for (k, p) in parts.iter().enumerate() {
        let v: f64 = p
            .parse()
            .map_err(|_| format!("{text:?}: {p:?} is not a number ({what})"))?;
        if !v.is_finite() {
            return Err(format!("{text:?}: {p:?} is not finite ({what})"));
        }
        out[k] = v;
    }
    Ok(out)
}

/// Parses `X,Y,YAW`.
pub fn parse_pose(text: &str) -> Result<Pose2, String> {
    let [x, y, yaw] = numbers::<3>(text, "X,Y,YAW")?;
    Ok(Pose2::new(x, y, yaw))
}

/// Parses `LENGTH,WIDTH,CENTRE_X,CENTRE_Y`.
pub fn parse_footprint(text: &str) -> Result<Footprint, String> {
    let [length, width, centre_x, centre_y] = numbers::<4>(text, "LENGTH,WIDTH,CENTRE_X,CENTRE_Y")?;
    let f = Footprint {
        length,
        width,
        centre_x,
        centre_y,
    };
    f.validate()?;
    Ok(f)
}

impl BagArgs {
    /// The topics to read; `--bag` needs `--scan-topic`.
    pub fn topics(&self) -> Result<BagTopics, CliError> {
        let Some(scan) = &self.scan_topic else {
            return Err(CliError(
                "--bag needs --scan-topic T (the sensor_msgs/LaserScan topic)".into(),
            ));
        };
        Ok(BagTopics {
            scan: scan.clone(),
            odometry: self.odom_topic.clone(),
            people: self.people_topic.clone(),
            ego_pose: self.ego_pose_topic.clone(),
            object_pose: self.object_pose_topic.clone(),
            clock: self.stamps,
        })
    }

    /// The pair builder's options for pairs `k` scans apart with people labels by
    /// `leigh`.
    pub fn options(&self, k: usize, leigh: LeighPairOptions) -> Result<BagPairOptions, CliError> {
        self.check()?;
        Ok(BagPairOptions {
            k,
            laser_mount: self.laser_mount,
            mocap: MocapOptions {
                pose_delay: self.pose_delay,
                label_margin: self.label_margin,
                object_min_speed: self.object_min_speed,
                ..MocapOptions::default()
            },
            object_footprint: self.object_footprint,
            leigh,
            name: None,
        })
    }

    /// Checks the numeric bag options, whether a bag is read or not (an option that
    /// means nothing is an error even where the command does not use it).
    pub fn check(&self) -> Result<(), CliError> {
        if !(self.label_margin.is_finite() && self.label_margin >= 0.0) {
            return Err(CliError(format!(
                "--label-margin {}: must be a finite distance >= 0",
                self.label_margin
            )));
        }
        if !(self.object_min_speed.is_finite() && self.object_min_speed >= 0.0) {
            return Err(CliError(format!(
                "--object-min-speed {}: must be a finite speed >= 0",
                self.object_min_speed
            )));
        }
        if !self.pose_delay.is_finite() || self.pose_delay.abs() > 10.0 {
            return Err(CliError(format!(
                "--pose-delay {}: must be finite seconds within ±10",
                self.pose_delay
            )));
        }
        Ok(())
    }
}

/// How leigh-gtm1 people labels decide who moves (text logs and bags).
#[derive(Args, Debug, Clone)]
pub struct LabelArgs {
    /// Who moves: `track` (the speed of a line fitted to the person's track, the data
    /// README's rule) or `displacement` (the older rule: the two annotated centres of
    /// the pair, --moving-threshold and --unannotated).
    #[arg(long, default_value_t = LabelRule::Track, hide_short_help = true)]
    pub labels: LabelRule,
    /// Track rule: smallest speed (m/s) of a walking person; 0: every annotated person
    /// is a mover.
    #[arg(long, default_value_t = LeighPairOptions::default().walking_speed, hide_short_help = true)]
    pub walking_speed: f64,
    /// Track rule: the line is fitted over the annotated scans from i - W to j + W.
    #[arg(long, default_value_t = LeighPairOptions::default().track_window, hide_short_help = true)]
    pub track_window: usize,
}

impl LabelArgs {
    /// Checks `--walking-speed` (used by the track rule only, checked always).
    pub fn check(&self) -> Result<(), CliError> {
        if !(self.walking_speed.is_finite() && self.walking_speed >= 0.0) {
            return Err(CliError(format!(
                "--walking-speed {}: must be a finite speed >= 0 (m/s)",
                self.walking_speed
            )));
        }
        Ok(())
    }
}

impl Default for LabelArgs {
    fn default() -> Self {
        let d = LeighPairOptions::default();
        Self {
            labels: d.rule,
            walking_speed: d.walking_speed,
            track_window: d.track_window,
        }
    }
}

/// Where pairs come from: exactly one of `--carmen` with `--relations`, `--log`,
/// `--scans` with `--people` (and optionally `--odometry`), `--bag` with
/// `--scan-topic`, or `--pairs`.
#[derive(Args, Debug, Default, Clone)]
pub struct SourceArgs {
    /// ROS bag input.
    #[command(flatten)]
    pub bag: BagArgs,
    /// leigh-gtm1 labelling rule.
    #[command(flatten)]
    pub labels: LabelArgs,
    /// CARMEN log (FLASER / ROBOTLASER1) whose scans the relations refer to.
    #[arg(long, requires = "relations")]
    pub carmen: Option<PathBuf>,
    /// Kümmerle-style relations file (`t1 t2 x y z roll pitch yaw`).
    #[arg(long, requires = "carmen")]
    pub relations: Option<PathBuf>,
    /// CARMEN log: pairs of consecutive laser scans (with VERTEX2 poses, their true
    /// ego-motion; without, no ground truth).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// leigh-gtm1 scan log (`SCAN idx …` lines).
    #[arg(long, requires = "people", hide_short_help = true)]
    pub scans: Option<PathBuf>,
    /// leigh-gtm1 person annotations (`PERSON scan_idx person_id x y`).
    #[arg(long, requires = "scans", hide_short_help = true)]
    pub people: Option<PathBuf>,
    /// leigh-gtm1 odometry per scan (`ODOM idx stamp x y theta`).
    #[arg(long, requires = "scans", hide_short_help = true)]
    pub odometry: Option<PathBuf>,
    /// CARMEN FLASER lines: the laser's geometry.
    #[command(flatten)]
    pub laser: CarmenLaserArgs,
}

/// The geometry of a CARMEN log's FLASER lines, where the log does not say it
/// (`pgm data pairs`, `pgm eval`, `pgm track`).
#[derive(Args, Debug, Default, Clone)]
pub struct CarmenLaserArgs {
    /// CARMEN FLASER lines: field of view of the laser in degrees (overrides the log's
    /// PARAM lines and CARMEN's rule for the beam count).
    #[arg(long, hide_short_help = true)]
    pub laser_fov: Option<f64>,
    /// CARMEN FLASER lines: angle between beams in degrees (overrides the log's PARAM
    /// lines and CARMEN's rule for the beam count).
    #[arg(long, hide_short_help = true)]
    pub laser_resolution: Option<f64>,
    /// CARMEN FLASER lines: angle of the first beam in degrees (default -90, CARMEN's).
    #[arg(long, allow_negative_numbers = true, hide_short_help = true)]
    pub laser_start: Option<f64>,
}

impl SourceArgs {
    /// Checks every numeric option of the sources (bag, labelling rule, CARMEN laser
    /// geometry), whichever source is given: an option that means nothing is an error
    /// even where the command does not read it.
    pub fn check(&self) -> Result<(), CliError> {
        self.bag.check()?;
        self.labels.check()?;
        self.laser.check()
    }

    /// The CARMEN reader options these arguments ask for.
    pub fn carmen_options(&self) -> carmen::CarmenOptions {
        carmen::CarmenOptions {
            front_laser_fov: self.laser.laser_fov,
            front_laser_resolution: self.laser.laser_resolution,
            front_laser_start: self.laser.laser_start,
            clock: self.bag.stamps,
            ..Default::default()
        }
    }
}

impl CarmenLaserArgs {
    /// Checks the angles, whether or not a CARMEN log is read.
    pub fn check(&self) -> Result<(), CliError> {
        for (option, value) in [
            ("--laser-fov", self.laser_fov),
            ("--laser-resolution", self.laser_resolution),
        ] {
            if let Some(v) = value {
                if !(v.is_finite() && v > 0.0 && v <= 360.0) {
                    return Err(CliError(format!(
                        "{option} {v}: expected degrees in (0, 360]"
                    )));
                }
            }
        }
        if let Some(v) = self.laser_start {
            if !(v.is_finite() && v.abs() <= 360.0) {
                return Err(CliError(format!(
                    "--laser-start {v}: expected degrees in [-360, 360]"
                )));
            }
        }
        Ok(())
    }
}

/// Options of the leigh-gtm1 pair builder.
#[derive(Args, Debug, Clone)]
pub struct LeighArgs {
    /// Moving threshold (m): people who moved less are background; 0 makes every
    /// annotated person its own cluster.
    #[arg(long, default_value_t = 0.2, hide_short_help = true)]
    pub moving_threshold: f64,
    /// Returns within this distance (m) of an annotated centre belong to the person.
    #[arg(long, default_value_t = 0.35, hide_short_help = true)]
    pub person_radius: f64,
    /// A person annotated in the current scan but not in the reference scan (unknown
    /// displacement) is `moving` (its own cluster) or `static` (background).
    #[arg(long, default_value_t = Unannotated::Moving, hide_short_help = true)]
    pub unannotated: Unannotated,
    /// Score only the sector of bearings where people were annotated (returns outside
    /// it get no label): the annotators marked people in front of the wheelchair only.
    #[arg(long, hide_short_help = true)]
    pub annotated_sector: bool,
}

impl Default for LeighArgs {
    fn default() -> Self {
        Self {
            moving_threshold: 0.2,
            person_radius: 0.35,
            unannotated: Unannotated::Moving,
            annotated_sector: false,
        }
    }
}

/// Pairs made from logs or a bag: where the scans come from, the leigh-gtm1
/// labelling and the scan distance (`pgm data pairs`, `pgm eval clustering`, `pgm
/// eval joint`).
#[derive(Args, Debug)]
pub struct LogPairsArgs {
    /// Input logs or a bag.
    #[command(flatten)]
    pub source: SourceArgs,
    /// leigh-gtm1 options.
    #[command(flatten)]
    pub leigh: LeighArgs,
    /// Logs and bags: scan distance of the pairs.
    #[arg(long, default_value_t = 5, allow_hyphen_values = true, value_parser = super::parse_scan_distance)]
    pub k: usize,
}

impl LogPairsArgs {
    /// Where the pairs come from: the `stored` data set (`--pairs`), else these logs
    /// ([`pair_source`]).
    pub fn pair_source(&self, stored: Option<&Path>) -> Result<PairSource, CliError> {
        pair_source(stored, &self.source, &self.leigh, self.k)
    }
}

/// `pgm data pairs`.
#[derive(Args, Debug)]
pub struct PairsArgs {
    /// Input logs or a bag, labelling and scan distance.
    #[command(flatten)]
    pub logs: LogPairsArgs,
    /// Output directory: created, or an empty directory, or one holding a data set,
    /// which is replaced (datasets/FORMAT.md; other files are never removed).
    #[arg(long)]
    pub out: PathBuf,
}

/// `pgm data summary`.
#[derive(Args, Debug)]
pub struct SummaryArgs {
    /// The leigh-gtm1 style log: `--scans FILE --people FILE [--odometry FILE]`, or a
    /// bag with `--people-topic` (and `--odom-topic`).
    #[command(flatten)]
    pub source: SourceArgs,
    /// Scan distances to summarise.
    #[arg(long, value_delimiter = ',', default_value = "1,3,5", allow_hyphen_values = true, value_parser = super::parse_scan_distance)]
    pub k: Vec<usize>,
    /// leigh-gtm1 options.
    #[command(flatten)]
    pub leigh: LeighArgs,
    /// Print one JSON array instead of a table.
    #[arg(long)]
    pub json: bool,
}

impl LeighArgs {
    /// Checks `--moving-threshold` and `--person-radius` (used by leigh-gtm1 logs and
    /// bags with people only, checked always).
    pub fn check(&self) -> Result<(), CliError> {
        if !(self.moving_threshold.is_finite() && self.moving_threshold >= 0.0) {
            return Err(CliError(format!(
                "--moving-threshold {}: must be a finite distance >= 0 (m)",
                self.moving_threshold
            )));
        }
        if !(self.person_radius.is_finite() && self.person_radius > 0.0) {
            return Err(CliError(format!(
                "--person-radius {}: must be a positive finite distance (m)",
                self.person_radius
            )));
        }
        Ok(())
    }

    /// The pair builder's options for pairs `k` scans apart with the rule of `labels`.
    pub fn options_with(&self, k: usize, labels: &LabelArgs) -> LeighPairOptions {
        LeighPairOptions {
            k,
            moving_threshold: self.moving_threshold,
            person_radius: self.person_radius,
            unannotated: self.unannotated,
            annotated_sector: self.annotated_sector,
            name: "leigh-gtm1".into(),
            rule: labels.labels,
            walking_speed: labels.walking_speed,
            track_window: labels.track_window,
        }
    }
}

/// The pair source the arguments name: `stored` (`--pairs`) or exactly one of the log
/// sources of [`SourceArgs`]. Every option of every source is checked first, also
/// those the named source does not read (`--k 0` with `--pairs` is refused too).
pub fn pair_source(
    stored: Option<&Path>,
    source: &SourceArgs,
    leigh_args: &LeighArgs,
    k: usize,
) -> Result<PairSource, CliError> {
    check_k(k)?;
    source.check()?;
    leigh_args.check()?;
    let given = [
        stored.is_some(),
        source.carmen.is_some(),
        source.log.is_some(),
        source.scans.is_some(),
        source.bag.bag.is_some(),
    ]
    .iter()
    .filter(|g| **g)
    .count();
    if given != 1 {
        return Err(CliError(
            "give exactly one source: --pairs DIR, --carmen FILE --relations FILE, --log FILE, \
             --scans FILE --people FILE [--odometry FILE], or --bag FILE --scan-topic T"
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
    let leigh = leigh_args.options_with(k, &source.labels);
    if let Some(path) = &source.bag.bag {
        return Ok(PairSource::Bag {
            path: path.clone(),
            topics: source.bag.topics()?,
            options: source.bag.options(k, leigh)?,
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
        options: leigh,
        clock: source.bag.stamps,
    })
}

/// Checks a scan distance `--k`: the two scans of a pair must differ.
pub fn check_k(k: usize) -> Result<(), CliError> {
    if k == 0 {
        return Err(CliError(
            "--k 0: the two scans of a pair must differ (k >= 1)".into(),
        ));
    }
    Ok(())
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
    let source = args.logs.pair_source(None)?;
    let pairs = load_pairs(&source)?.pairs;
    if pairs.is_empty() {
        return Err(CliError(format!(
            "{source}: no pair could be built (nothing written to {})",
            args.out.display()
        )));
    }
    pgm_datasets::write_pairs(&args.out, &pairs).map_err(CliError::from_display)?;
    // The data set is the result; this line is a diagnostic, as `pgm sim --out`'s.
    eprintln!(
        "pgm: wrote {} pairs of {source} to {}",
        pairs.len(),
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// The leigh-gtm1 style log and its annotations from text files or a bag, with the
/// readers' notes printed on stderr.
fn leigh_log(
    source: &SourceArgs,
) -> Result<(leigh::LeighScans, Vec<leigh::PersonAnnotation>, String), CliError> {
    let mut notes = Vec::new();
    let out = if let Some(path) = &source.bag.bag {
        let topics = source.bag.topics()?;
        if topics.people.is_none() {
            return Err(CliError(
                "pgm data summary of a bag needs --people-topic (the annotated people)".into(),
            ));
        }
        let log = read_bag(path, &topics).map_err(CliError::from_display)?;
        let (mount, note) = laser_mount(&log, source.bag.laser_mount);
        notes.push(note);
        let scans = prepared_scans(&log, &mount, &mut notes);
        let (scans, people) = to_leigh(&log, &scans, &mut notes);
        pgm_datasets::bag::pairs::require_people(&log, &people).map_err(CliError::from_display)?;
        pgm_datasets::bag::pairs::check_people_reach(&log, &scans, &people)
            .map_err(CliError::from_display)?;
        (scans, people, format!("bag {}", path.display()))
    } else {
        let (Some(scans), Some(people)) = (&source.scans, &source.people) else {
            return Err(CliError(
                "give --scans FILE --people FILE [--odometry FILE], or --bag FILE --scan-topic T \
                 --people-topic T [--odom-topic T]"
                    .into(),
            ));
        };
        let (log, annotations) = read_leigh(
            scans,
            people,
            source.odometry.as_deref(),
            source.bag.stamps,
            &mut notes,
        )
        .map_err(CliError::from_display)?;
        (log, annotations, scans.display().to_string())
    };
    for note in &notes {
        eprintln!("note: {note}");
    }
    Ok(out)
}

/// One row of `pgm data summary --json`.
#[derive(serde::Serialize)]
struct SummaryRow {
    rule: LabelRule,
    #[serde(flatten)]
    summary: pgm_datasets::builders::LeighSummary,
}

fn run_summary(args: SummaryArgs) -> CliResult {
    for &k in &args.k {
        check_k(k)?;
    }
    args.source.check()?;
    args.leigh.check()?;
    let (log, annotations, name) = leigh_log(&args.source)?;
    let mut rows = Vec::new();
    for rule in [LabelRule::Track, LabelRule::Displacement] {
        let labels = LabelArgs {
            labels: rule,
            ..args.source.labels.clone()
        };
        for &k in &args.k {
            let pairs = leigh_pairs(&log, &annotations, &args.leigh.options_with(k, &labels))
                .map_err(|e| CliError(format!("{name}: {e}")))?;
            rows.push(SummaryRow {
                rule,
                summary: summarize_leigh_pairs(k, &pairs),
            });
        }
    }
    if args.json {
        print_json(&rows)?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "leigh-gtm1 pairs of {name}: track rule (walking speed {} m/s, window {} scans) and \
         displacement rule (moving threshold {} m, unannotated {}); person radius {} m",
        args.source.labels.walking_speed,
        args.source.labels.track_window,
        args.leigh.moving_threshold,
        args.leigh.unannotated,
        args.leigh.person_radius
    );
    println!(
        "{:<12}  {:>3}  {:>5}  {:>12}  {:>20}  {:>24}  {:>13}",
        "rule",
        "k",
        "pairs",
        "returns/scan",
        "moving returns/pair",
        "pairs with moving person",
        "moving people"
    );
    for r in rows {
        let s = r.summary;
        println!(
            "{:<12}  {:>3}  {:>5}  {:>12}  {:>20}  {:>24}  {:>13}",
            r.rule.to_string(),
            s.k,
            s.pairs,
            or_dash(s.returns_per_scan, 1),
            or_dash(s.moving_returns_per_pair, 2),
            s.pairs_with_moving_person,
            s.moving_people
        );
    }
    Ok(ExitCode::SUCCESS)
}
