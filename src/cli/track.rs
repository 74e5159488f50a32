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
    load_pairs, pair_source, parse_clock, parse_pose, BagArgs, CarmenLaserArgs, LeighArgs,
    SourceArgs,
};
use super::eval_clustering::MethodArgs;
use super::online::{
    mode_name, scan_sequence, sequence_count, track_scans, NamedReport, OnlineArgs,
};
use super::{to_json, CliError, CliResult};
use clap::Args;
use nalgebra::Point2;
use pgm::plot::{ObjectState, TrackPicture, TrackedScan};
use pgm_datasets::stamps::StampClock;
use pgm_scan::{ParamGuard, Pose2};
use pgm_tracking::{TrackState, TrackingCounts, TrackingParams};
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
    /// The detector runs on scans n − k and n (default: on scan n and the latest scan
    /// at least --reference-gap seconds before it).
    #[arg(long, conflicts_with = "reference_gap", allow_hyphen_values = true, value_parser = super::parse_scan_distance)]
    pub k: Option<usize>,
    /// The online tracker's options.
    #[command(flatten)]
    pub online: OnlineArgs,
    /// Write the JSON here (atomically) instead of printing it.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Draw the longest sequence into this SVG file: every scan's returns in the
    /// first scan's frame, the sensor's path and each track's path.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Record every scan, the sensor's pose and the tracks into this MCAP file for
    /// Foxglove (docs/foxglove.md).
    #[arg(long)]
    pub mcap: Option<PathBuf>,
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
    /// Which clock places the scans and the odometry in time: `auto` uses the header
    /// stamps (CARMEN: ipc_timestamp) unless a topic's are zero, repeated or go
    /// backwards, then the record times (CARMEN: logger_timestamp) for every topic;
    /// `header` refuses such stamps; `record` always uses record times.
    #[arg(long, default_value_t = StampClock::Auto, value_parser = parse_clock, hide_short_help = true)]
    pub stamps: StampClock,
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
                stamps: self.stamps,
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
    mode: &'a str,
    method: &'a str,
    associations: Option<&'a str>,
    data: String,
    weights: &'a str,
    tracking: OnlineFields,
    scans: Vec<NamedReport>,
}

/// The `tracking` object of `pgm track`'s JSON: the tracker's options.
#[derive(Serialize)]
struct OnlineFields {
    #[serde(skip_serializing_if = "Option::is_none")]
    k: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    reference_gap: Option<f64>,
    min_speed: f64,
    max_speed: f64,
    max_yaw_rate: f64,
    sequences: usize,
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
        // The scans come from the consecutive pairs; the tracker pairs them k apart.
        1,
    )?;
    let options = args.method.options()?;
    let params = args.online.params(args.k);
    params.check_ref().map_err(CliError::from_display)?;
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
    super::check_outputs(
        &[
            ("--out", args.out.as_deref()),
            ("--svg", args.svg.as_deref()),
            ("--mcap", args.mcap.as_deref()),
        ],
        &inputs,
    )?;
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
    // The tracker pairs scans n − k and n itself: those pairs carry no ground truth,
    // so the default association source is the automatic one and `true` is refused.
    if args.method.associations.as_deref() == Some("true") {
        return Err(CliError(
            "--associations true: the online tracker pairs each scan with the one k scans \
             before it, and those pairs have no ground-truth associations (use an automatic \
             source: icp, segment-icp, crf-matching)"
                .into(),
        ));
    }
    let built = args.method.build(&options, &[])?;
    let sequence = scan_sequence(&pairs);
    let n_scans = sequence.len();
    let kept_scans: Vec<pgm_scan::Scan> = if args.svg.is_some() || args.mcap.is_some() {
        sequence.iter().map(|(_, s)| s.clone()).collect()
    } else {
        Vec::new()
    };
    let reports = track_scans(sequence, built.method.as_ref(), &params, args.online.smooth)
        .map_err(|e| CliError(format!("{source}: {}", e.0)))?;
    let shown = |o: &&pgm_tracking::online::TrackedObject| o.state != TrackState::Tentative;
    // Every file is staged beside its destination and renamed into place once all are
    // written: a command that fails writes nothing.
    let mut staged = super::StagedOutputs::default();
    if let Some(path) = &args.svg {
        // The longest sequence, scans in time order.
        let mut length = std::collections::BTreeMap::<usize, usize>::new();
        for r in &reports {
            *length.entry(r.report.sequence).or_default() += 1;
        }
        let longest = length
            .iter()
            .max_by_key(|(q, n)| (**n, std::cmp::Reverse(**q)))
            .map(|(q, _)| *q);
        let scans = reports
            .iter()
            .zip(&kept_scans)
            .filter(|(r, _)| Some(r.report.sequence) == longest)
            .map(|(r, scan)| TrackedScan {
                scan,
                pose: r.report.pose,
                objects: r
                    .report
                    .objects
                    .iter()
                    .filter(shown)
                    .map(|o| {
                        let state = match o.state {
                            TrackState::Stopped => ObjectState::Stopped,
                            TrackState::Coasting => ObjectState::Coasting,
                            _ => ObjectState::Moving,
                        };
                        (
                            o.track as usize,
                            Point2::new(o.centre[0], o.centre[1]),
                            state,
                        )
                    })
                    .collect(),
            })
            .collect::<Vec<_>>();
        let title = format!(
            "{}: {} scans, tracks shown: {} ({}{}, {})",
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
            mode_name(args.online.smooth),
        );
        let svg = TrackPicture {
            scans,
            title,
            width: 900,
        }
        .to_svg_string()
        .map_err(CliError::from_display)?;
        staged.stage(path, svg.as_bytes(), "drew")?;
    }
    if let Some(path) = &args.mcap {
        let scans = reports
            .iter()
            .zip(&kept_scans)
            .map(|(r, scan)| (r.scan.as_str(), scan, &r.report));
        let bytes = pgm::foxglove::track_recording(scans)
            .map_err(|e| CliError(format!("--mcap {}: {e}", path.display())))?;
        staged.stage(path, &bytes, "recorded")?;
    }
    let reported: usize = reports
        .iter()
        .map(|r| r.report.objects.iter().filter(shown).count())
        .sum();
    let tracks = reports
        .iter()
        .flat_map(|r| r.report.objects.iter().filter(shown).map(|o| o.track))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let sequences = sequence_count(&reports);
    let output = Output {
        mode: mode_name(args.online.smooth),
        method: &args.method.method,
        associations: built.associations.as_deref(),
        data: source.to_string(),
        weights: &built.weights,
        tracking: OnlineFields {
            k: params.k,
            reference_gap: params.k.is_none().then_some(params.reference_gap),
            min_speed: params.min_speed,
            max_speed: params.ego.max_speed,
            max_yaw_rate: params.ego.max_yaw_rate,
            sequences,
        },
        scans: reports,
    };
    let json = to_json(&output)?;
    match &args.out {
        Some(path) => staged.stage(path, format!("{json}\n").as_bytes(), "wrote the tracks")?,
        None => println!("{json}"),
    }
    staged.commit_quietly()?;
    eprintln!(
        "pgm: {n_scans} scans of {source} tracked {}; objects reported (confirmed, stopped or \
         coasting): {reported} on {tracks} tracks; sequences: {sequences}{}",
        if args.online.smooth {
            "and smoothed"
        } else {
            "online"
        },
        [
            ("", &args.out),
            ("picture ", &args.svg),
            ("recording ", &args.mcap)
        ]
        .iter()
        .filter_map(|(what, p)| p
            .as_ref()
            .map(|p| format!("; {what}written to {}", p.display())))
        .collect::<String>()
    );
    Ok(ExitCode::SUCCESS)
}
