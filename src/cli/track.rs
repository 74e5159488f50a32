//! `pgm track`: moving objects tracked over a whole log or bag, no ground truth
//! needed.
//!
//! `pgm track --method NAME [--associations SRC] (--bag FILE --scan-topic T
//! [--odom-topic T] | --scans FILE --people FILE [--odometry FILE] | --log FILE |
//! --pairs DIR) [--k K] [--min-evidence N] [--min-speed V] [--forward-only] [--out FILE]` runs the
//! clustering method on every pair of scans `k` apart and tracks its moving objects
//! over the current scans ([`pgm_tracking`]). It prints (or writes to
//! `--out`, atomically) one JSON object `{"method", "associations", "data",
//! "weights", "tracking": {"min_evidence", "min_speed", "backward", "sequences",
//! "tracks", "tracked_objects", "dropped", "backward_objects"}, "scans": [{"pair",
//! "time", "ego_motion", "converged", "objects": [{"label", "track", "detected",
//! "returns", "beams", "centre", "velocity", "motion"}]}]}`: per pair (in time order
//! of the current scan) every moving object with its track number (the same number in
//! two pairs is the same object; `null` for a detection that starts no track), whether
//! the detector reported it or the track did, its returns and their beams, the centre
//! of its returns and its velocity over the ground in the current sensor frame (m,
//! m/s; `null` without a track), and its motion over the pair (maps its returns onto
//! the reference scan). A summary goes to stderr. `--svg FILE` draws the
//! longest sequence ([`pgm::plot::TrackPicture`]).

use super::data::{
    load_pairs, pair_source, parse_pose, BagArgs, CarmenLaserArgs, LeighArgs, SourceArgs,
};
use super::eval_clustering::MethodArgs;
use super::{check_not_an_input, check_output_file, resolved_output, CliError, CliResult};
use clap::Args;
use nalgebra::Point2;
use pgm::plot::{TrackPicture, TrackedScan};
use pgm_scan::{ParamGuard, Pose2};
use pgm_tracking::{time_order, TrackedObject, TrackingCounts, TrackingParams};
use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;

/// `pgm track`.
#[derive(Args, Debug)]
pub struct TrackArgs {
    /// The detector and its options.
    #[command(flatten)]
    pub method: MethodArgs,
    /// A stored scan-pair data set (pairs of one log in time order).
    #[arg(long, conflicts_with_all = ["log", "scans", "bag"])]
    pub pairs: Option<PathBuf>,
    /// The log or bag.
    #[command(flatten)]
    pub source: SequenceSourceArgs,
    /// Scan distance of the pairs the detector runs on (bags and leigh-gtm1 logs;
    /// default 1). A stored data set has its pairs, a CARMEN `--log` gives consecutive
    /// scans.
    #[arg(long)]
    pub k: Option<usize>,
    /// Steps with evidence of motion a track needs for its objects to be reported (1
    /// drops only the detections that the previous scan shows slower than the speed
    /// that counts).
    #[arg(long, default_value_t = TrackingParams::default().min_evidence, hide_short_help = true)]
    pub min_evidence: usize,
    /// Slowest speed (m/s) that counts as moving.
    #[arg(long, default_value_t = TrackingParams::default().min_speed, hide_short_help = true)]
    pub min_speed: f64,
    /// Do not follow confirmed tracks backward in time (the scans before an object's
    /// first detection keep the method's output).
    #[arg(long, hide_short_help = true)]
    pub forward_only: bool,
    /// Write the JSON here (atomically) instead of printing it.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Draw the longest sequence into this SVG file: every scan's returns in the
    /// first scan's frame, the sensor's path and each track's path.
    #[arg(long)]
    pub svg: Option<PathBuf>,
}

/// Where `pgm track`'s scans come from: a bag, a CARMEN log or a leigh-gtm1 scan log
/// (or `--pairs`). Only what a sequence needs: no ground-truth labelling options, since
/// `pgm track` reads no ground truth (`pgm eval clustering --track` scores tracks).
#[derive(Args, Debug, Default, Clone)]
pub struct SequenceSourceArgs {
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
    /// Bag: the laser's pose X,Y,YAW (m, m, rad) in the robot frame that the odometry
    /// follows (default: the bag's tf, else the identity).
    #[arg(long, requires = "bag", allow_hyphen_values = true, value_parser = parse_pose, hide_short_help = true)]
    pub laser_mount: Option<Pose2>,
    /// CARMEN log: pairs of consecutive laser scans.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// leigh-gtm1 scan log (`SCAN idx …` lines).
    #[arg(long, requires = "people")]
    pub scans: Option<PathBuf>,
    /// leigh-gtm1 person annotations (`PERSON scan_idx person_id x y`): the text log's
    /// reader needs them; `pgm track` does not score against them.
    #[arg(long, requires = "scans", hide_short_help = true)]
    pub people: Option<PathBuf>,
    /// leigh-gtm1 odometry per scan (`ODOM idx stamp x y theta`).
    #[arg(long, requires = "scans", hide_short_help = true)]
    pub odometry: Option<PathBuf>,
    /// CARMEN FLASER lines: the laser's geometry.
    #[command(flatten)]
    pub laser: CarmenLaserArgs,
}

impl SequenceSourceArgs {
    /// The general source options these stand for (every labelling option at its
    /// default).
    fn source(&self) -> SourceArgs {
        SourceArgs {
            bag: BagArgs {
                bag: self.bag.clone(),
                scan_topic: self.scan_topic.clone(),
                odom_topic: self.odom_topic.clone(),
                laser_mount: self.laser_mount,
                ..BagArgs::default()
            },
            log: self.log.clone(),
            scans: self.scans.clone(),
            people: self.people.clone(),
            odometry: self.odometry.clone(),
            laser: self.laser.clone(),
            ..SourceArgs::default()
        }
    }
}

#[derive(Serialize)]
struct Output<'a> {
    method: &'a str,
    associations: Option<&'a str>,
    data: String,
    weights: &'a str,
    tracking: TrackingFields,
    scans: Vec<ScanObjects>,
}

/// The `tracking` object of the JSON output (also `pgm eval clustering --track`'s):
/// the tracking options and what tracking changed.
#[derive(Serialize)]
pub(super) struct TrackingFields {
    pub(super) min_evidence: usize,
    pub(super) min_speed: f64,
    pub(super) backward: bool,
    #[serde(flatten)]
    pub(super) counts: TrackingCounts,
}

#[derive(Serialize)]
struct ScanObjects {
    pair: String,
    time: f64,
    ego_motion: Option<Pose2>,
    converged: bool,
    objects: Vec<Object>,
}

#[derive(Serialize)]
struct Object {
    #[serde(flatten)]
    object: TrackedObject,
    motion: Option<Pose2>,
}

/// Options that only make sense together: bag topics without a bag, and a scan
/// distance for sources that have their pairs.
fn refuse_inconsistent_options(args: &TrackArgs) -> Result<(), CliError> {
    let bag = &args.source;
    if bag.bag.is_none() {
        let bag_only = [
            ("--scan-topic", bag.scan_topic.is_some()),
            ("--odom-topic", bag.odom_topic.is_some()),
            ("--laser-mount", bag.laser_mount.is_some()),
        ];
        if let Some((name, _)) = bag_only.iter().find(|(_, g)| *g) {
            return Err(CliError(format!(
                "{name}: an option of --bag input, given without --bag"
            )));
        }
    }
    if let (Some(k), true) = (args.k, args.pairs.is_some() || args.source.log.is_some()) {
        return Err(CliError(format!(
            "--k {k}: a stored data set has its pairs and a CARMEN log gives consecutive scans; \
             --k sets the scan distance of bag and leigh-gtm1 pairs only"
        )));
    }
    Ok(())
}

/// The tracker of the command-line options `(value, flag)`; a bad value is refused
/// naming its flag.
pub(super) fn tracker(
    (min_evidence, evidence_flag): (usize, &str),
    (min_speed, speed_flag): (f64, &str),
    backward: bool,
) -> Result<pgm_tracking::Tracker, CliError> {
    if min_evidence == 0 {
        return Err(CliError(format!(
            "{evidence_flag} 0: a track needs at least 1 step of evidence of motion"
        )));
    }
    if !(min_speed.is_finite() && min_speed >= 0.0) {
        return Err(CliError(format!(
            "{speed_flag} {min_speed}: expected a finite speed in m/s >= 0"
        )));
    }
    TrackingParams {
        min_evidence,
        min_speed,
        backward,
        ..TrackingParams::default()
    }
    .check()
    .map_err(CliError::from_display)
}

/// Runs `pgm track`.
pub fn run(args: TrackArgs) -> CliResult {
    refuse_inconsistent_options(&args)?;
    let source = pair_source(
        args.pairs.as_deref(),
        &args.source.source(),
        &LeighArgs::default(),
        args.k.unwrap_or(1),
    )?;
    let options = args.method.options()?;
    let tracker = tracker(
        (args.min_evidence, "--min-evidence"),
        (args.min_speed, "--min-speed"),
        !args.forward_only,
    )?;
    let inputs: Vec<&std::path::Path> = [
        args.pairs.as_deref(),
        args.source.bag.as_deref(),
        args.source.scans.as_deref(),
        args.source.people.as_deref(),
        args.source.odometry.as_deref(),
        args.source.log.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();
    for out in [&args.out, &args.svg].into_iter().flatten() {
        check_output_file(out)?;
        check_not_an_input(out, &inputs)?;
    }
    if let (Some(a), Some(b)) = (&args.out, &args.svg) {
        if a == b || resolved_output(a).is_some_and(|r| Some(r) == resolved_output(b)) {
            return Err(CliError(format!(
                "--out {} and --svg {} are the same file",
                a.display(),
                b.display()
            )));
        }
    }
    let pairs = load_pairs(&source)?.pairs;
    if pairs.is_empty() {
        return Err(CliError(format!(
            "{source}: no pair to track{}",
            if args.source.log.is_some() {
                " (--log pairs consecutive laser scans that have valid returns, and in a log \
                 with VERTEX2 lines the scans that follow one)"
            } else {
                ""
            }
        )));
    }
    let built = args.method.build(&options, &pairs)?;
    let tracked = tracker
        .track(&pairs, built.method.as_ref())
        .map_err(|e| CliError(format!("{source}: {e}")))?;
    let order = time_order(&pairs);
    let scans: Vec<ScanObjects> = order
        .iter()
        .map(|&i| {
            let clustering = &tracked.clusterings[i];
            ScanObjects {
                pair: pairs[i].name.clone(),
                time: pairs[i].current.timestamp,
                ego_motion: clustering.ego_motion,
                converged: clustering.converged,
                objects: tracked.objects[i]
                    .iter()
                    .map(|object| Object {
                        motion: clustering
                            .motions
                            .iter()
                            .find(|m| m.label == object.label)
                            .map(|m| m.motion),
                        object: object.clone(),
                    })
                    .collect(),
            }
        })
        .collect();
    if let Some(path) = &args.svg {
        // The longest sequence, scans in time order.
        let mut length = vec![0usize; tracked.counts.sequences];
        for &q in &tracked.sequences {
            length[q] += 1;
        }
        let longest = (0..length.len()).max_by_key(|&q| (length[q], std::cmp::Reverse(q)));
        let scans = order
            .iter()
            .filter(|&&i| Some(tracked.sequences[i]) == longest)
            .map(|&i| TrackedScan {
                scan: &pairs[i].current,
                pose: tracked.poses[i],
                objects: tracked.objects[i]
                    .iter()
                    .filter_map(|o| Some((o.track?, Point2::new(o.centre[0], o.centre[1]))))
                    .collect(),
            })
            .collect::<Vec<_>>();
        let title = format!(
            "{}: {} scans, tracks shown: {} ({}{})",
            super::joint::pair_sets(&pairs).join(", "),
            scans.len(),
            scans
                .iter()
                .flat_map(|s| s.objects.iter().map(|o| o.0))
                .collect::<std::collections::BTreeSet<_>>()
                .len(),
            args.method.method,
            built
                .associations
                .as_deref()
                .map_or(String::new(), |a| format!(", {a} associations")),
        );
        TrackPicture {
            scans,
            title,
            width: 900,
        }
        .write_svg(path)
        .map_err(CliError::from_display)?;
    }
    let counts = tracked.counts;
    let reported: usize = scans.iter().map(|s| s.objects.len()).sum();
    let reported_tracks = scans
        .iter()
        .flat_map(|s| s.objects.iter().filter_map(|o| o.object.track))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let output = Output {
        method: &args.method.method,
        associations: built.associations.as_deref(),
        data: source.to_string(),
        weights: &built.weights,
        tracking: TrackingFields {
            min_evidence: args.min_evidence,
            min_speed: args.min_speed,
            backward: !args.forward_only,
            counts,
        },
        scans,
    };
    let json = serde_json::to_string(&output).map_err(CliError::from_display)?;
    match &args.out {
        Some(path) => pgm_datasets::format::write_atomically(path, format!("{json}\n").as_bytes())
            .map_err(CliError::from_display)?,
        None => println!("{json}"),
    }
    eprintln!(
        "pgm: pairs: {} of {source}; moving objects reported: {reported}, on tracks: \
         {reported_tracks} (tracks started: {}; sequences: {}; objects added from tracks: {} \
         following them, {} before their first detection; detections dropped as unconfirmed: \
         {}){}",
        pairs.len(),
        counts.tracks,
        counts.sequences,
        counts.tracked_objects,
        counts.backward_objects,
        counts.dropped,
        [("", &args.out), ("picture ", &args.svg)]
            .iter()
            .filter_map(|(what, p)| p
                .as_ref()
                .map(|p| format!("; {what}written to {}", p.display())))
            .collect::<String>()
    );
    Ok(ExitCode::SUCCESS)
}
