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

use super::data::{load_pairs, pair_source, LeighArgs, SourceArgs};
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
    #[arg(long, conflicts_with_all = ["carmen", "log", "scans", "bag"])]
    pub pairs: Option<PathBuf>,
    /// The log or bag.
    #[command(flatten)]
    pub source: SourceArgs,
    /// leigh-gtm1 options (used for its labels only).
    #[command(flatten)]
    pub leigh: LeighArgs,
    /// Scan distance of the pairs the detector runs on (bags and leigh-gtm1 logs;
    /// default 1). A stored data set has its pairs, a CARMEN `--log` gives consecutive
    /// scans.
    #[arg(long)]
    pub k: Option<usize>,
    /// Steps with evidence of motion a track needs for its objects to be reported (1
    /// drops only the detections that the previous scan shows slower than the speed
    /// that counts).
    #[arg(long, default_value_t = TrackingParams::default().min_evidence)]
    pub min_evidence: usize,
    /// Slowest speed (m/s) that counts as moving.
    #[arg(long, default_value_t = TrackingParams::default().min_speed)]
    pub min_speed: f64,
    /// Do not follow confirmed tracks backward in time (the scans before an object's
    /// first detection keep the method's output).
    #[arg(long)]
    pub forward_only: bool,
    /// Write the JSON here (atomically) instead of printing it.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Draw the longest sequence into this SVG file: every scan's returns in the
    /// first scan's frame, the sensor's path and each track's path.
    #[arg(long)]
    pub svg: Option<PathBuf>,
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

/// Options that only decide ground-truth labels, which `pgm track` does not read: a
/// value other than the default is refused, naming the option.
fn refuse_labelling_options(args: &TrackArgs) -> Result<(), CliError> {
    use pgm_datasets::builders::{LabelRule, LeighPairOptions, Unannotated};
    use pgm_datasets::mocap::MocapOptions;
    let bag = &args.source.bag;
    let labels = &args.source.labels;
    let leigh = &args.leigh;
    let given = [
        ("--people-topic", bag.people_topic.is_some()),
        ("--ego-pose-topic", bag.ego_pose_topic.is_some()),
        ("--object-pose-topic", bag.object_pose_topic.is_some()),
        ("--object-footprint", bag.object_footprint.is_some()),
        (
            "--label-margin",
            bag.label_margin != MocapOptions::default().label_margin,
        ),
        (
            "--object-min-speed",
            bag.object_min_speed != MocapOptions::default().object_min_speed,
        ),
        ("--labels", labels.labels != LabelRule::Track),
        (
            "--walking-speed",
            labels.walking_speed != LeighPairOptions::default().walking_speed,
        ),
        (
            "--track-window",
            labels.track_window != LeighPairOptions::default().track_window,
        ),
        ("--moving-threshold", leigh.moving_threshold != 0.2),
        ("--person-radius", leigh.person_radius != 0.35),
        ("--unannotated", leigh.unannotated != Unannotated::Moving),
        ("--annotated-sector", leigh.annotated_sector),
        ("--pose-delay", bag.pose_delay != 0.0),
    ];
    if let Some((name, _)) = given.iter().find(|(_, g)| *g) {
        return Err(CliError(format!(
            "{name}: a ground-truth labelling option; pgm track reads no ground truth (use it \
             with pgm eval clustering --track)"
        )));
    }
    if args.source.carmen.is_some() {
        return Err(CliError(
            "--carmen with --relations: the pairs of a relations file are not a sequence of \
             scans (loop closures minutes apart); track a CARMEN log with --log"
                .into(),
        ));
    }
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
    if let (Some(k), true) = (
        args.k,
        args.pairs.is_some() || args.source.log.is_some() || args.source.carmen.is_some(),
    ) {
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
    refuse_labelling_options(&args)?;
    let source = pair_source(
        args.pairs.as_deref(),
        &args.source,
        &args.leigh,
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
        args.source.bag.bag.as_deref(),
        args.source.scans.as_deref(),
        args.source.people.as_deref(),
        args.source.odometry.as_deref(),
        args.source.log.as_deref(),
        args.source.carmen.as_deref(),
        args.source.relations.as_deref(),
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
