//! `pgm eval tracking`: CLEAR-MOT of a tracker's output against tracking truth
//! ([`pgm_datasets::clear_mot`], [`pgm_datasets::tracking_truth`]).
//!
//! `pgm eval tracking --method NAME [--associations SRC] [tracker options] (--bag FILE --scan-topic T [--odom-topic T] (--people-topic T | --ego-pose-topic
//! T --object-pose-topic T --object-footprint …) | --scans FILE --people FILE [--odometry
//! FILE] | --pairs DIR) [--threshold M] [--window=LO,HI] [--no-false-positives]
//! [--moving-only] [--min-returns N] [--min-score S] [--json] [--out FILE]` runs the
//! online tracker of `pgm track` over the source's scans and scores each annotated scan under the leg_tracker benchmark's
//! protocol and under the standard one (`../shared/tools/TRACKING.md`).
//!
//! - **Frames**: the scans the truth annotates (a leigh-gtm1 log's scans with people
//!   annotations; every scan the motion capture covers; every current scan of a
//!   simulated sequence). Each log (sequence) is scored with its own record of
//!   matches; the counts are pooled.
//! - **Estimates**: the tracker's objects that are not tentative (as `pgm track`
//!   reports them), or, with `--min-score S`, every object whose score is at least S
//!   (an operating point).
//! - **Annotations left out** (`--moving-only`: an annotation not known to move;
//!   `--min-returns N`: one with fewer than N returns) are *don't care*: they are not
//!   counted, and an estimate whose nearest annotation within the threshold is one of
//!   them is dropped too (neither a match nor a false positive).
//!
//! Prints a table (or with `--json` one object `{"data", "truth", "tracker",
//! "options", "frames", "left_out", "benchmark", "standard", "moving", "objects"}`;
//! `--out FILE` writes that object atomically). `benchmark` and `standard` hold the
//! counts with `mota` and `motp_m`; `moving` the annotations known to move and how many
//! the benchmark protocol matched; `objects` per truth id the annotations, matches and
//! ID switches (benchmark protocol).

use super::data::{pair_source, LeighArgs, SourceArgs};
use super::eval_clustering::MethodArgs;
use super::online::{track_truth_source, OnlineArgs};
use super::{check_not_an_input, check_output_file, to_json, CliError, CliResult};
use clap::Args;
use pgm_datasets::clear_mot::{
    pool, BearingWindow, ClearMot, ClearMotOptions, Protocol, Summary, DEFAULT_THRESHOLD_M,
};
use pgm_datasets::tracking_truth::TrackingTruth;
use pgm_scan::ObjectCentre;
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// `pgm eval tracking`.
#[derive(Args, Debug)]
pub struct TrackingEvalArgs {
    /// The detector and its options.
    #[command(flatten)]
    pub detector: MethodArgs,
    /// A stored scan-pair data set with tracking truth (`pgm sim --sequence`).
    #[arg(long, conflicts_with_all = ["log", "scans", "bag", "carmen"])]
    pub pairs: Option<PathBuf>,
    /// The log or bag and its truth (`--people-topic`, or the motion-capture topics).
    #[command(flatten)]
    pub source: SourceArgs,
    /// leigh-gtm1 options (the person radius counts an annotation's returns).
    #[command(flatten)]
    pub leigh: LeighArgs,
    /// The detector runs on scans n − k and n (default: scan n and the latest scan at
    /// least --reference-gap seconds before it).
    #[arg(long, conflicts_with = "reference_gap", allow_hyphen_values = true, value_parser = super::parse_scan_distance)]
    pub k: Option<usize>,
    /// The online tracker's options.
    #[command(flatten)]
    pub online: OnlineArgs,
    /// Match threshold (m): an estimate matches an annotation strictly closer.
    #[arg(long, default_value_t = DEFAULT_THRESHOLD_M)]
    pub threshold: f64,
    /// Bearing window LO,HI in degrees: estimates and annotations outside are dropped
    /// (the benchmark's general-tracking bags: --window=-80,12).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_window)]
    pub window: Option<(f64, f64)>,
    /// Do not count false positives (following logs: only one person is annotated);
    /// MOTA is then not defined.
    #[arg(long)]
    pub no_false_positives: bool,
    /// Only annotations known to move count; the others are don't-care.
    #[arg(long)]
    pub moving_only: bool,
    /// Only annotations with at least this many returns count; the others are
    /// don't-care (0: all).
    #[arg(long, default_value_t = 0)]
    pub min_returns: usize,
    /// Estimates: every object whose score is at least this (default: the objects
    /// that are not tentative, as `pgm track` reports them).
    #[arg(long)]
    pub min_score: Option<f64>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// The JSON lists every scored scan's matches, misses and false positives.
    #[arg(long, hide_short_help = true)]
    pub per_scan: bool,
    /// Also write the JSON object here (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

fn parse_window(text: &str) -> Result<(f64, f64), String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [lo, hi] = parts.as_slice() else {
        return Err(format!(
            "{text:?}: expected LO,HI in degrees (for example -80,12)"
        ));
    };
    let number = |p: &str| {
        p.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{text:?}: {p:?} is not a finite number of degrees"))
    };
    let (lo, hi) = (number(lo)?, number(hi)?);
    if lo > hi || lo < -180.0 || hi > 180.0 {
        return Err(format!(
            "{text:?}: expected -180 <= LO <= HI <= 180 degrees"
        ));
    }
    Ok((lo, hi))
}

/// One annotated scan of a log: its index, name and objects.
type AnnotatedScan<'a> = (usize, &'a str, &'a Vec<ObjectCentre>);

/// What the tracker reported in one scan: `(track, state, centre, score)`.
type Reported = Vec<(u64, String, [f64; 2], Option<f64>)>;

#[derive(Serialize)]
struct Scores {
    #[serde(flatten)]
    counts: pgm_datasets::clear_mot::Counts,
    correct: u64,
    mota: Option<f64>,
    motp_m: Option<f64>,
}

impl From<&Summary> for Scores {
    fn from(s: &Summary) -> Self {
        Scores {
            counts: s.counts,
            correct: s.counts.correct(),
            mota: s.mota,
            motp_m: s.motp_m,
        }
    }
}

#[derive(Serialize, Default, Clone, Copy)]
struct ObjectScore {
    annotations: u64,
    matched: u64,
    id_switches: u64,
}

#[derive(Serialize)]
struct OptionsOut {
    threshold_m: f64,
    window_deg: Option<[f64; 2]>,
    count_false_positives: bool,
    moving_only: bool,
    min_returns: usize,
    estimates: String,
}

#[derive(Serialize)]
struct Output {
    data: String,
    truth: String,
    tracker: String,
    options: OptionsOut,
    frames: usize,
    left_out: u64,
    benchmark: Scores,
    standard: Scores,
    moving: Option<ObjectScore>,
    objects: BTreeMap<u64, ObjectScore>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    scans: Vec<ScanScore>,
}

/// One scored scan (`--per-scan`), benchmark protocol.
#[derive(Serialize)]
struct ScanScore {
    scan: String,
    /// `(track, person, distance m, id switch)`.
    matches: Vec<(u64, u64, f64, bool)>,
    /// Annotations matched to nothing: `(person, x, y)`.
    misses: Vec<(u64, f64, f64)>,
    /// Estimates matched to nothing: `(track, x, y)`.
    false_positives: Vec<(u64, f64, f64)>,
}

/// The log and scan index of a scan named `LOG:J`; other names are a log of their own.
fn log_and_index(name: &str) -> (String, usize) {
    match name.rsplit_once(':') {
        Some((log, j)) => match j.parse() {
            Ok(j) => (log.to_string(), j),
            Err(_) => (name.to_string(), 0),
        },
        None => (name.to_string(), 0),
    }
}

/// Runs `pgm eval tracking`.
pub fn run(args: TrackingEvalArgs) -> CliResult {
    if !(args.threshold.is_finite() && args.threshold > 0.0) {
        return Err(CliError(format!(
            "--threshold {}: expected a positive finite distance in metres",
            args.threshold
        )));
    }
    if let Some(s) = args.min_score {
        if !(0.0..=1.0).contains(&s) {
            return Err(CliError(format!(
                "--min-score {s}: expected a score in [0, 1]"
            )));
        }
    }
    let truth_source = pair_source(args.pairs.as_deref(), &args.source, &args.leigh, 1)?;
    let inputs: Vec<&Path> = [
        args.pairs.as_deref(),
        args.source.bag.bag.as_deref(),
        args.source.scans.as_deref(),
        args.source.people.as_deref(),
        args.source.odometry.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();
    if let Some(out) = &args.out {
        check_output_file(out)?;
        check_not_an_input(out, &inputs)?;
    }
    let options = ClearMotOptions {
        threshold_m: args.threshold,
        protocol: Protocol::Benchmark,
        bearing_window: args
            .window
            .map(|(lo, hi)| BearingWindow::degrees(lo, hi))
            .transpose()
            .map_err(CliError::from_display)?,
        count_false_positives: !args.no_false_positives,
    };
    let truth: TrackingTruth = truth_source
        .tracking_truth()
        .map_err(CliError::from_display)?;
    for note in &truth.notes {
        eprintln!("note: {note}");
    }
    // The tracker's output, scan by scan.
    let run = track_truth_source(
        &truth_source,
        &args.source,
        &args.detector,
        &args.online,
        args.k,
        false,
    )?;
    let tracker = run.tracker;
    let reported: Vec<(String, Reported)> = run
        .reports
        .into_iter()
        .map(|r| {
            let objects = r
                .report
                .objects
                .iter()
                .map(|o| {
                    let state = serde_json::to_value(o.state)
                        .ok()
                        .and_then(|v| v.as_str().map(str::to_string))
                        .unwrap_or_default();
                    (o.track, state, o.centre, Some(o.score))
                })
                .collect();
            (r.scan, objects)
        })
        .collect();
    let estimates_rule = match args.min_score {
        Some(s) => format!("every object with a score of at least {s}"),
        None => "the objects that are not tentative".into(),
    };
    let by_name: HashMap<&str, &Reported> = reported.iter().map(|(n, o)| (n.as_str(), o)).collect();
    let mut logs: BTreeMap<String, Vec<AnnotatedScan>> = BTreeMap::new();
    for (name, objects) in &truth.scans {
        let (log, j) = log_and_index(name);
        logs.entry(log)
            .or_default()
            .push((j, name.as_str(), objects));
    }
    let keep = |o: &ObjectCentre| {
        (!args.moving_only || o.moving == Some(true))
            && o.returns.is_none_or(|r| r >= args.min_returns)
    };
    let mut summaries: BTreeMap<&str, Vec<Summary>> = BTreeMap::new();
    let mut per_object: BTreeMap<u64, ObjectScore> = BTreeMap::new();
    let mut moving = ObjectScore::default();
    let any_moving_flag = truth.scans.values().flatten().any(|o| o.moving.is_some());
    let (mut frames, mut left_out, mut unseen) = (0usize, 0u64, 0usize);
    let mut scan_scores = Vec::new();
    for frames_of_log in logs.values_mut() {
        frames_of_log.sort_by_key(|f| f.0);
        let mut scorers = [Protocol::Benchmark, Protocol::Standard].map(|protocol| {
            ClearMot::new(ClearMotOptions {
                protocol,
                ..options
            })
        });
        for (_, name, objects) in frames_of_log.iter() {
            let estimates_all: Vec<(u64, f64, f64)> = match by_name.get(name) {
                Some(objects) => objects
                    .iter()
                    .filter(|(_, state, _, score)| match args.min_score {
                        Some(s) => score.is_some_and(|v| v >= s),
                        None => state != "tentative",
                    })
                    .map(|(t, _, c, _)| (*t, c[0], c[1]))
                    .collect(),
                None => {
                    unseen += 1;
                    Vec::new()
                }
            };
            let (kept, ignored): (Vec<&ObjectCentre>, Vec<&ObjectCentre>) =
                objects.iter().partition(|o| keep(o));
            left_out += ignored.len() as u64;
            // An estimate whose nearest annotation within the threshold is a
            // don't-care one is dropped.
            let estimates: Vec<(u64, f64, f64)> = estimates_all
                .into_iter()
                .filter(|&(_, x, y)| {
                    let nearest = objects
                        .iter()
                        .map(|o| (o, ((o.x - x).powi(2) + (o.y - y).powi(2)).sqrt()))
                        .filter(|(_, d)| *d < args.threshold)
                        .min_by(|a, b| a.1.total_cmp(&b.1));
                    nearest.is_none_or(|(o, _)| keep(o))
                })
                .collect();
            let annotations: Vec<(u64, f64, f64)> = kept.iter().map(|o| (o.id, o.x, o.y)).collect();
            frames += 1;
            for (p, scorer) in scorers.iter_mut().enumerate() {
                let scorer = scorer.as_mut().map_err(|e| CliError(e.to_string()))?;
                let result = scorer
                    .push_parts(&estimates, &annotations)
                    .map_err(|e| CliError(format!("{name}: {e}")))?;
                if p != 0 {
                    continue;
                }
                if args.per_scan {
                    let at = |id: u64, list: &[(u64, f64, f64)]| {
                        list.iter().copied().find(|a| a.0 == id)
                    };
                    scan_scores.push(ScanScore {
                        scan: name.to_string(),
                        matches: result
                            .matches
                            .iter()
                            .map(|m| (m.track, m.person, m.distance_m, m.id_switch))
                            .collect(),
                        misses: result
                            .unmatched_persons
                            .iter()
                            .filter_map(|&id| at(id, &annotations))
                            .collect(),
                        false_positives: result
                            .unmatched_tracks
                            .iter()
                            .filter_map(|&id| at(id, &estimates))
                            .collect(),
                    });
                }
                let window = options.bearing_window;
                for o in &kept {
                    if window.is_some_and(|w| !w.contains(o.x, o.y)) {
                        continue;
                    }
                    let hit = result.matches.iter().find(|m| m.person == o.id);
                    let entry = per_object.entry(o.id).or_default();
                    entry.annotations += 1;
                    if let Some(m) = hit {
                        entry.matched += 1;
                        entry.id_switches += u64::from(m.id_switch);
                    }
                    if o.moving == Some(true) {
                        moving.annotations += 1;
                        if let Some(m) = hit {
                            moving.matched += 1;
                            moving.id_switches += u64::from(m.id_switch);
                        }
                    }
                }
            }
        }
        for (p, scorer) in scorers.iter().enumerate() {
            let scorer = scorer.as_ref().map_err(|e| CliError(e.to_string()))?;
            summaries
                .entry(if p == 0 { "benchmark" } else { "standard" })
                .or_default()
                .push(scorer.summary());
        }
    }
    if frames == 0 {
        return Err(CliError(format!(
            "{truth_source}: no scan is annotated for tracking"
        )));
    }
    if unseen > 0 {
        eprintln!(
            "note: {unseen} of {frames} annotated scans are not in the tracker's output; \
             their annotations count as misses"
        );
    }
    let pooled = |p: &str| pool(summaries.get(p).map(Vec::as_slice).unwrap_or(&[]));
    let (benchmark, standard) = (pooled("benchmark"), pooled("standard"));
    let output = Output {
        data: truth_source.to_string(),
        truth: truth.what.clone(),
        tracker,
        options: OptionsOut {
            threshold_m: args.threshold,
            window_deg: args.window.map(|(lo, hi)| [lo, hi]),
            count_false_positives: !args.no_false_positives,
            moving_only: args.moving_only,
            min_returns: args.min_returns,
            estimates: estimates_rule,
        },
        frames,
        left_out,
        benchmark: Scores::from(&benchmark),
        standard: Scores::from(&standard),
        moving: any_moving_flag.then_some(moving),
        objects: per_object,
        scans: scan_scores,
    };
    let json = to_json(&output)?;
    if let Some(path) = &args.out {
        pgm_datasets::format::write_atomically(path, format!("{json}\n").as_bytes())
            .map_err(CliError::from_display)?;
    }
    if args.json {
        println!("{json}");
    } else {
        print_table(&output);
    }
    Ok(ExitCode::SUCCESS)
}

fn print_table(o: &Output) {
    println!("data: {}", o.data);
    println!("truth: {}", o.truth);
    println!("tracker: {}", o.tracker);
    println!(
        "options: threshold {} m, window {}, false positives {}, {}{}; estimates: {}",
        o.options.threshold_m,
        o.options
            .window_deg
            .map_or("none".to_string(), |[lo, hi]| format!("{lo}°..{hi}°")),
        if o.options.count_false_positives {
            "counted"
        } else {
            "not counted"
        },
        if o.options.moving_only {
            "moving annotations only"
        } else {
            "every annotation"
        },
        if o.options.min_returns > 0 {
            format!(", at least {} returns", o.options.min_returns)
        } else {
            String::new()
        },
        o.options.estimates
    );
    println!(
        "frames: {}; annotations left out (don't care): {}",
        o.frames, o.left_out
    );
    println!(
        "{:<10} {:>6} {:>8} {:>8} {:>5} {:>6} {:>7} {:>8} {:>7}",
        "protocol", "truth", "matches", "correct", "IDSW", "FP", "misses", "MOTA", "MOTP"
    );
    for (name, s) in [("benchmark", &o.benchmark), ("standard", &o.standard)] {
        println!(
            "{:<10} {:>6} {:>8} {:>8} {:>5} {:>6} {:>7} {:>8} {:>7}",
            name,
            s.counts.truth,
            s.counts.matches,
            s.correct,
            s.counts.id_switches,
            if o.options.count_false_positives {
                s.counts.false_positives.to_string()
            } else {
                "-".into()
            },
            s.counts.misses,
            s.mota
                .map_or("n/a".to_string(), |m| format!("{:.1} %", 100.0 * m)),
            s.motp_m.map_or("n/a".to_string(), |m| format!("{m:.3} m")),
        );
    }
    if let Some(m) = &o.moving {
        println!(
            "moving annotations matched (benchmark protocol): {} of {} ({:.1} %)",
            m.matched,
            m.annotations,
            if m.annotations > 0 {
                100.0 * m.matched as f64 / m.annotations as f64
            } else {
                0.0
            }
        );
    }
}
