//! `pgm eval clustering`: homogeneity, completeness and V-measure of a clustering
//! method against ground-truth labels (Table I of the CRF-Clustering paper).
//!
//! `pgm eval clustering --method NAME (--pairs DIR | --scans FILE --people FILE
//! [--odometry FILE] --k K [--moving-threshold M]) [--associations NAME] [--weights
//! FILE] [--json]` scores every pair with ground-truth labels
//! ([`pgm_eval::evaluate_clustering`]) and prints the mean and standard
//! deviation over pairs, and the detection metrics
//! ([`pgm_eval::DetectionSummary`]; `--min-object-returns N`, default
//! 5). The text output says what each object count counts: `detection (true movers
//! with >= N returns in the current scan): D of C detected` (JSON `objects_detected`,
//! `objects_counted`) and, for methods that estimate motions, `motion errors (every
//! true mover with a known motion, any number of returns): F of T found` (JSON
//! `objects_found`, `objects_total`; the stricter "found" rule of the motion errors,
//! [`pgm_eval`]). The data may also come from a bag (`--bag FILE
//! --scan-topic T …`, see `pgm data pairs`). The methods and association sources are those of [`pgm::methods`];
//! `--method joint` scores the joint model's clusters (a return of the outlier
//! cluster takes the moving cluster of its surface, else the background,
//! [`pgm_scan::methods::JointClusters`]; `--joint-weights FILE`).
//! `--json` prints one object `{"method", "associations", "data", "pair_sets",
//! "weights", "pairs",
//! "homogeneity_mean", "homogeneity_std", "completeness_mean", "completeness_std",
//! "v_measure_mean", "v_measure_std", "iterations_mean", "objects_found",
//! "objects_total", "centroid_error_median", "rotation_error_median",
//! "min_object_returns", "objects_counted", "objects_detected", "object_recall",
//! "false_alarms_per_pair", "pairs_without_mover", "false_alarm_pair_share",
//! "moving_precision", "moving_recall", "object_translation_error_median",
//! "object_rotation_error_median", "mover_pairs", "v_measure_mover_pairs",
//! "tracking"}` (`null` where a figure has nothing to be computed from). `--track`
//! tracks the method's moving objects over the sequence of current scans
//! ([`pgm_tracking`]; `--track-min-evidence N`, `--track-min-speed V`) and
//! scores the tracked output; `tracking` is then `{"min_evidence", "min_speed",
//! "sequences", "tracks", "tracked_objects", "dropped", "backward", "backward_objects"}`. Without
//! odometry the ego-motion comes from the model itself (the largest cluster) or from
//! ICP (CBD, associations). `--no-prior` hides the pairs' odometry prior from the
//! methods while the labels still use it (leigh-gtm1 needs odometry to decide who
//! moved), to measure the methods as they run on a log without odometry.

use super::cluster::{association_names, CrfArgs};
use super::data::{load_pairs, LogPairsArgs};
use super::track::TrackingFields;
use super::{or_dash, print_json, CliError, CliResult};
use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::Args;
use pgm::methods::{
    association_source, clusterer, clusterer_needs_associations, default_association, find,
    weights_used, Clusterer, Method, MethodOptions, WeightKind, ASSOCIATION_SOURCES, CLUSTERERS,
};
use pgm_eval::{
    evaluate_clustering_with, scorable_for_clustering, DetectionOptions, DetectionSummary,
};
use pgm_scan::methods::MotionClusterer;
use pgm_tracking::TrackingParams;
use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;

/// The names of the clustering methods, for clap.
pub fn clusterer_names() -> PossibleValuesParser {
    PossibleValuesParser::new(
        CLUSTERERS
            .iter()
            .map(|m| PossibleValue::new(m.name).help(m.about)),
    )
}

/// A motion clustering method and its options (`pgm eval clustering`, `pgm track`).
#[derive(Args, Debug)]
pub struct MethodArgs {
    /// The method.
    #[arg(long, value_parser = clusterer_names())]
    pub method: String,
    /// Point associations for crf and kmeans (default: true when every pair has them,
    /// else icp).
    #[arg(long, value_parser = association_names())]
    pub associations: Option<String>,
    /// CRF-Clustering options.
    #[command(flatten)]
    pub crf: CrfArgs,
    /// Motion K-Means: number of clusters.
    #[arg(long, default_value_t = pgm::methods::MethodOptions::default().kmeans.k, hide_short_help = true)]
    pub kmeans_k: usize,
    /// CBD: how much closer (m) than the reference return a dynamic point is.
    #[arg(long, default_value_t = pgm::methods::MethodOptions::default().cbd.margin, hide_short_help = true)]
    pub cbd_margin: f64,
    /// The joint model's weights and boosters for `--method joint`, written by `pgm
    /// train joint` (default: the shipped ones).
    #[arg(long, hide_short_help = true)]
    pub joint_weights: Option<PathBuf>,
}

/// A method built from [`MethodArgs`] for a set of pairs.
pub struct BuiltMethod {
    /// The method.
    pub method: Box<dyn MotionClusterer>,
    /// The association source it runs on, as typed (or the default), for the methods
    /// that take one.
    pub associations: Option<String>,
    /// Which weights it uses (its own and its association source's).
    pub weights: String,
    /// Whether it uses learned weights.
    pub has_weights: bool,
}

impl MethodArgs {
    /// The options of every method, checked (before any data is read: an option
    /// that means nothing is refused whichever method would read it).
    pub fn options(&self) -> Result<MethodOptions, CliError> {
        let mut options = self.crf.options()?;
        if let Some(path) = &self.joint_weights {
            options = options
                .with_joint_weights(path)
                .map_err(CliError::from_display)?;
        }
        options.kmeans.k = self.kmeans_k;
        options.cbd.margin = self.cbd_margin;
        options.check().map_err(CliError::from_display)?;
        Ok(options)
    }

    /// The method with `options` ([`MethodArgs::options`]) for `pairs` (whose ground
    /// truth decides the default association source).
    pub fn build(
        &self,
        options: &MethodOptions,
        pairs: &[pgm_scan::ScanPair],
    ) -> Result<BuiltMethod, CliError> {
        if let (Some(a), false) = (
            &self.associations,
            clusterer_needs_associations(&self.method),
        ) {
            eprintln!(
                "note: --associations {a} is not used: method {} takes no associations",
                self.method
            );
        }
        let which = self
            .associations
            .as_deref()
            .unwrap_or_else(|| default_association(pairs));
        let source = association_source(which, options).map_err(CliError::from_display)?;
        let method = clusterer(&self.method, source, options).map_err(CliError::from_display)?;
        // The method's weights, and its association source's when it takes one.
        let takes_associations = clusterer_needs_associations(&self.method);
        let mut weight_kinds = self.entry().weights.to_vec();
        if takes_associations {
            let source = find(ASSOCIATION_SOURCES, which).map_or(&[][..], |m| m.weights);
            for kind in source {
                if !weight_kinds.contains(kind) {
                    weight_kinds.push(*kind);
                }
            }
        }
        let weights = weights_used(&weight_kinds, |kind| match kind {
            WeightKind::Clustering => self.crf.weights.as_deref(),
            WeightKind::Matching => self.crf.matching.matching_weights.as_deref(),
            WeightKind::Joint => self.joint_weights.as_deref(),
        });
        Ok(BuiltMethod {
            method,
            // Names as typed on the command line: the method, and its association
            // source apart (the library's `crf (icp)` joins them).
            associations: takes_associations.then(|| which.to_string()),
            weights,
            has_weights: !weight_kinds.is_empty(),
        })
    }

    /// The method's registry entry (clap has checked the name).
    fn entry(&self) -> &'static Method<Clusterer> {
        find(CLUSTERERS, &self.method).expect("clap offers the registered clusterers only")
    }

    /// Whether the method estimates its clusters' motions (its registry entry says).
    pub fn estimates_motions(&self) -> bool {
        self.entry().build.motions
    }
}

/// `pgm eval clustering`.
#[derive(Args, Debug)]
pub struct ClusteringEvalArgs {
    /// The method to evaluate and its options.
    #[command(flatten)]
    pub method: MethodArgs,
    /// A stored scan-pair data set with ground-truth labels.
    #[arg(long, conflicts_with_all = ["carmen", "log", "scans", "bag"])]
    pub pairs: Option<PathBuf>,
    /// Input logs or a bag, labelling and scan distance.
    #[command(flatten)]
    pub logs: LogPairsArgs,
    /// Hide the pairs' odometry prior from the methods (the labels still use it): the
    /// methods run as on a log without odometry.
    #[arg(long, hide_short_help = true)]
    pub no_prior: bool,
    /// Detection metrics: objects with fewer returns in the current scan are left out
    /// of the object recall.
    #[arg(long, default_value_t = DetectionOptions::default().min_object_returns, hide_short_help = true)]
    pub min_object_returns: usize,
    /// Track the method's moving objects over the sequence of current scans
    /// (pgm_tracking): pairs of one log or bag (or of `pgm sim --sequence`) in
    /// time order; each pair of independent simulated scenes is a sequence of its own
    /// and gets the method's output.
    #[arg(long)]
    pub track: bool,
    /// Tracking: steps with evidence of motion a track needs for its objects to be
    /// reported (1 drops only the detections that the previous scan shows slower than
    /// the speed that counts).
    #[arg(long, requires = "track", default_value_t = TrackingParams::default().min_evidence, hide_short_help = true)]
    pub track_min_evidence: usize,
    /// Tracking: slowest speed (m/s) that counts as moving.
    #[arg(long, requires = "track", default_value_t = TrackingParams::default().min_speed, hide_short_help = true)]
    pub track_min_speed: f64,
    /// Tracking: do not follow confirmed tracks backward in time (the scans before an
    /// object's first detection keep the method's output).
    #[arg(long, requires = "track", hide_short_help = true)]
    pub track_forward_only: bool,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// The `--json` object.
#[derive(Serialize)]
struct Report<'a> {
    /// The method as typed on the command line (`--method`).
    method: &'a str,
    /// The association source it ran on (`--associations`, or the default), `null` for
    /// methods that take none.
    associations: Option<&'a str>,
    data: String,
    /// The distinct pair-name prefixes (`sim:PRESET:SEED`, `leigh-gtm1`, a bag's stem):
    /// which sets and seeds the pairs come from.
    pair_sets: Vec<String>,
    weights: String,
    #[serde(flatten)]
    summary: &'a pgm_eval::ClusteringSummary,
    objects_found: usize,
    objects_total: usize,
    centroid_error_median: Option<f64>,
    rotation_error_median: Option<f64>,
    #[serde(flatten)]
    detection: DetectionFields,
    /// `--track`: the tracking parameters and what tracking changed; `null` without.
    tracking: Option<TrackingFields>,
}

/// The detection metrics of the `--json` object (`v_measure_mean` is the summary's).
#[derive(Serialize)]
struct DetectionFields {
    min_object_returns: usize,
    objects_counted: usize,
    objects_detected: usize,
    object_recall: Option<f64>,
    false_alarms_per_pair: f64,
    pairs_without_mover: usize,
    false_alarm_pair_share: Option<f64>,
    moving_precision: Option<f64>,
    moving_recall: Option<f64>,
    object_translation_error_median: Option<f64>,
    object_rotation_error_median: Option<f64>,
    mover_pairs: usize,
    v_measure_mover_pairs: Option<f64>,
}

impl From<&DetectionSummary> for DetectionFields {
    fn from(d: &DetectionSummary) -> Self {
        Self {
            min_object_returns: d.min_object_returns,
            objects_counted: d.objects_counted,
            objects_detected: d.objects_detected,
            object_recall: d.object_recall,
            false_alarms_per_pair: d.false_alarms_per_pair,
            pairs_without_mover: d.pairs_without_mover,
            false_alarm_pair_share: d.false_alarm_pair_share,
            moving_precision: d.moving_precision,
            moving_recall: d.moving_recall,
            object_translation_error_median: d.object_translation_error_median,
            object_rotation_error_median: d.object_rotation_error_median,
            mover_pairs: d.mover_pairs,
            v_measure_mover_pairs: d.v_measure_mover_pairs,
        }
    }
}

/// Runs `pgm eval clustering`.
pub fn run(args: ClusteringEvalArgs) -> CliResult {
    let source = args.logs.pair_source(args.pairs.as_deref())?;
    let options = args.method.options()?;
    let tracker = args
        .track
        .then(|| {
            super::track::tracker(
                (args.track_min_evidence, "--track-min-evidence"),
                (args.track_min_speed, "--track-min-speed"),
                !args.track_forward_only,
            )
        })
        .transpose()?;
    if args.min_object_returns == 0 {
        return Err(CliError(
            "--min-object-returns 0: an object without a return in the current scan cannot \
             be detected (expected at least 1)"
                .into(),
        ));
    }
    let mut pairs = load_pairs(&source)?.pairs;
    if args.no_prior {
        for p in &mut pairs {
            p.odometry = None;
        }
    }
    let total = pairs.len();
    pairs.retain(scorable_for_clustering);
    if pairs.is_empty() {
        return Err(CliError(format!(
            "{source}: none of the {total} pairs has a ground-truth label on any return \
             (nothing to score)"
        )));
    }
    if pairs.len() < total {
        eprintln!(
            "note: {} of {total} pairs have no ground-truth label on any return and are not scored",
            total - pairs.len()
        );
    }
    let built = args.method.build(&options, &pairs)?;
    let method = built.method;
    let tracking = if let Some(tracker) = tracker {
        let tracked = tracker
            .track(&pairs, method.as_ref())
            .map_err(|e| CliError(format!("{source}: {e}")))?;
        let counts = tracked.counts;
        let name = format!("{} + tracking", method.name());
        let method: Box<dyn MotionClusterer> = Box::new(
            tracked
                .into_clusterer(&pairs, name)
                .map_err(|e| CliError(format!("{source}: {e}")))?,
        );
        Some((method, counts))
    } else {
        None
    };
    let tracking_fields = tracking.as_ref().map(|(_, counts)| TrackingFields {
        min_evidence: args.track_min_evidence,
        min_speed: args.track_min_speed,
        backward: !args.track_forward_only,
        counts: *counts,
    });
    let method = match tracking {
        Some((tracked, _)) => tracked,
        None => method,
    };
    let detection = DetectionOptions {
        min_object_returns: args.min_object_returns,
    };
    let associations = built.associations.as_deref();
    let report = evaluate_clustering_with(&pairs, method.as_ref(), &detection)
        .map_err(|e| CliError(format!("{source}: {e}")))?;
    let unconverged = report.outcomes.iter().filter(|o| !o.converged).count();
    if unconverged > 0 {
        eprintln!(
            "note: {} did not converge on {unconverged} of {} pairs (their labels are scored \
             as they stand)",
            args.method.method,
            report.outcomes.len()
        );
    }
    let summary = report.summary;
    let found = report.found_objects;
    let weights = built.weights;
    let data = format!(
        "{source}{}; every pair scored, none trained on",
        if args.no_prior {
            ", odometry prior hidden"
        } else {
            ""
        }
    );
    let pair_sets = super::joint::pair_sets(&pairs);
    if args.json {
        let json = Report {
            method: &args.method.method,
            associations,
            data,
            pair_sets,
            weights,
            detection: DetectionFields::from(&report.detection),
            summary: &summary,
            objects_found: found.found,
            objects_total: found.total,
            centroid_error_median: found.centroid_error_median,
            rotation_error_median: found.rotation_error_median,
            tracking: tracking_fields,
        };
        print_json(&json)?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "method {}{}: {} pairs of {data}",
        args.method.method,
        associations.map_or(String::new(), |a| format!(" (associations {a})")),
        summary.pairs
    );
    println!(
        "pair sets (names before the last `:`): {}",
        pair_sets.join(", ")
    );
    if built.has_weights {
        println!("weights {weights}");
    }
    if let Some(t) = &tracking_fields {
        println!(
            "tracking (min evidence {}, min speed {} m/s{}): sequences {}, tracks {}, objects \
             added from tracks {} following them and {} before their first detection, \
             detections dropped as unconfirmed {}",
            t.min_evidence,
            t.min_speed,
            if t.backward { "" } else { ", forward only" },
            t.counts.sequences,
            t.counts.tracks,
            t.counts.tracked_objects,
            t.counts.backward_objects,
            t.counts.dropped
        );
    }
    println!(
        "homogeneity   {:.3} ± {:.3}",
        summary.homogeneity_mean, summary.homogeneity_std
    );
    println!(
        "completeness  {:.3} ± {:.3}",
        summary.completeness_mean, summary.completeness_std
    );
    println!(
        "V-measure     {:.3} ± {:.3}",
        summary.v_measure_mean, summary.v_measure_std
    );
    println!("iterations    {:.1}", summary.iterations_mean);
    let d = &report.detection;
    println!(
        "V-measure, {} pairs with a mover: {}",
        d.mover_pairs,
        or_dash(d.v_measure_mover_pairs, 3)
    );
    // Two object counts with different rules (module docs of
    // pgm_eval): the detection metrics count the true movers with at
    // least --min-object-returns returns; the found objects of the motion errors are
    // every true mover with a known motion. Each line says which.
    println!(
        "detection (true movers with >= {2} returns in the current scan): {0} of {1} \
         detected, recall {3}; false alarms per pair {4:.3}; pairs without a mover reported \
         moving {5} of {6} ({7})",
        d.objects_detected,
        d.objects_counted,
        d.min_object_returns,
        or_dash(d.object_recall, 3),
        d.false_alarms_per_pair,
        report
            .outcomes
            .iter()
            .filter(|o| !o.has_mover && o.reported_moving)
            .count(),
        d.pairs_without_mover,
        or_dash(d.false_alarm_pair_share, 3)
    );
    println!(
        "moving points: precision {}, recall {}; motion error of the detected objects (median) {} m, {} rad",
        or_dash(d.moving_precision, 3),
        or_dash(d.moving_recall, 3),
        or_dash(d.object_translation_error_median, 3),
        or_dash(d.object_rotation_error_median, 4)
    );
    if args.method.estimates_motions() {
        println!(
            "motion errors (every true mover with a known motion, any number of returns): \
             {} of {} found; median error {} m at the centroid, {} rad",
            found.found,
            found.total,
            or_dash(found.centroid_error_median, 3),
            or_dash(found.rotation_error_median, 4)
        );
    }
    Ok(ExitCode::SUCCESS)
}
