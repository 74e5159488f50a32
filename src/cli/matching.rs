//! `pgm match` (CRF-Matching of one pair) and `pgm eval association` (association
//! accuracy of any association source against ground truth, Table I of the joint
//! paper).
//!
//! `pgm match (--pairs DIR [--pair NAME|INDEX] | --scans FILE --reference I --current J
//! | --carmen FILE --reference I --current J) [--matching-weights FILE] [--svg FILE]`
//! prints one JSON object: per current beam the association (a reference beam, `-1`
//! for an outlier, `null` without a return) and its max-marginal confidence, the
//! ego-motion, every motion group's motion, sweeps, rounds and convergence. `--svg`
//! draws the association lines like Fig. 3 of the joint paper.
//!
//! `pgm eval association --method NAME --pairs DIR [--json]` scores every pair with
//! ground-truth associations: exact accuracy (the same reference beam, or both
//! outlier), accuracy within one beam, string edit distance, and the outlier
//! percentages (predicted, true, and the share of true outliers found, over the pairs
//! with a true outlier; `null` without one), through
//! [`pgm_eval::evaluate_association`].

use super::cluster::{association_names, OnePairArgs};
use super::data::{load_pairs, pair_source, LeighArgs, SourceArgs};
use super::{print_json, to_json, CliError, CliResult};
use clap::Args;
use pgm::methods::{association_source, MethodOptions};
use pgm::plot::PairPicture;
use pgm_crf_matching::StateSpace;
use pgm_eval::{evaluate_association, AssociationSummary};
use pgm_scan::ParamGuard;
use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;

/// The CRF-Matching options every command that runs it takes.
#[derive(Args, Debug, Clone)]
pub struct MatchingOptionArgs {
    /// CRF-Matching: weights and boosters written by `pgm train matching` (default:
    /// the shipped ones).
    #[arg(long, hide_short_help = true)]
    pub matching_weights: Option<PathBuf>,
    /// CRF-Matching (and the joint model): the states of a point: `K` (its K nearest
    /// reference returns under its motion estimate, plus the outlier state; 1-64) or
    /// `full` (every reference return and the outlier state).
    #[arg(long, default_value = "6", value_parser = parse_state_space)]
    pub candidates: StateSpace,
    /// CRF-Matching (and the joint model's background): how every motion solve ends:
    /// `point-to-line` (eq. 6 on the MAP partners, then each return against the line
    /// through its partner's surface; the default) or `point-to-point` (eq. 6 alone,
    /// as the paper).
    #[arg(long, value_enum, default_value_t = MotionFit::PointToLine, hide_short_help = true)]
    pub motion_fit: MotionFit,
}

/// `--motion-fit`: how CRF-Matching's and the joint model's motion solves end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MotionFit {
    /// Eq. 6, then the point-to-line refinement
    /// (`pgm_scan::alignment::refine_point_to_line`, point-to-point weight 0.1).
    PointToLine,
    /// Eq. 6 alone (the paper's).
    PointToPoint,
}

impl MotionFit {
    /// The value as typed (`point-to-line`, `point-to-point`), for the JSON outputs.
    pub fn name(self) -> &'static str {
        match self {
            MotionFit::PointToLine => "point-to-line",
            MotionFit::PointToPoint => "point-to-point",
        }
    }

    /// The `point_to_line` parameter of `MatchingParams` and `JointParams`.
    pub fn point_to_line(self) -> Option<f64> {
        match self {
            MotionFit::PointToLine => Some(pgm_scan::alignment::POINT_TO_POINT_WEIGHT),
            MotionFit::PointToPoint => None,
        }
    }
}

/// `K` or `full`, as typed after `--candidates`.
pub fn state_space_name(space: StateSpace) -> String {
    match space {
        StateSpace::Full => "full".into(),
        StateSpace::Pruned(k) => k.to_string(),
    }
}

/// Parses `--candidates`: `full` or a number of candidates in 1..=64.
pub fn parse_state_space(value: &str) -> Result<StateSpace, String> {
    if value == "full" {
        return Ok(StateSpace::Full);
    }
    match value.parse::<usize>() {
        Ok(k) if (1..=64).contains(&k) => Ok(StateSpace::Pruned(k)),
        _ => Err(format!(
            "`{value}` is neither `full` nor a number of candidates in 1..=64"
        )),
    }
}

impl MatchingOptionArgs {
    /// `options` with these CRF-Matching settings.
    pub fn apply(&self, mut options: MethodOptions) -> Result<MethodOptions, CliError> {
        if let Some(path) = &self.matching_weights {
            options = options
                .with_matching_weights(path)
                .map_err(CliError::from_display)?;
        }
        options.matching.state_space = self.candidates;
        options.joint.state_space = self.candidates;
        options.matching.point_to_line = self.motion_fit.point_to_line();
        options.joint.point_to_line = self.motion_fit.point_to_line();
        Ok(options)
    }
}

/// `pgm match`.
#[derive(Args, Debug)]
pub struct MatchArgs {
    /// The pair.
    #[command(flatten)]
    pub source: OnePairArgs,
    /// CRF-Matching options.
    #[command(flatten)]
    pub matching: MatchingOptionArgs,
    /// The SVG picture and the MCAP recording.
    #[command(flatten)]
    pub outputs: super::PairOutputArgs,
}

#[derive(Serialize)]
struct MatchOutput<'a> {
    pair: &'a str,
    /// `--candidates` as typed (`K` or `full`).
    candidates: String,
    /// `--motion-fit` as typed.
    motion_fit: &'static str,
    #[serde(flatten)]
    matching: &'a pgm_crf_matching::Matching,
}

/// Runs `pgm match`.
pub fn run_match(args: MatchArgs) -> CliResult {
    args.outputs.check(&args.source.inputs())?;
    let pair = args.source.load()?;
    let options = args.matching.apply(MethodOptions::default())?;
    let matcher = options
        .matching
        .clone()
        .check()
        .map_err(CliError::from_display)?;
    let matching = matcher.match_pair(&pair).map_err(CliError::from_display)?;
    let json = to_json(&MatchOutput {
        pair: &pair.name,
        candidates: state_space_name(args.matching.candidates),
        motion_fit: args.matching.motion_fit.name(),
        matching: &matching,
    })?;
    // Staged before the result is printed, renamed into place after: a command that
    // fails writes nothing.
    let mut picture = PairPicture::new(&pair);
    picture.labels = None;
    picture.motions = &[];
    picture.alignment = matching.motion;
    picture.associations = Some(&matching.associations);
    picture.title = format!(
        "{}: CRF-Matching, {} outliers",
        pair.name,
        matching
            .associations
            .iter()
            .filter(|a| **a == Some(pgm_scan::Association::Outlier))
            .count()
    );
    let staged = args.outputs.stage(&picture)?;
    println!("{json}");
    staged.commit(&pair.name)?;
    if !matching.converged {
        eprintln!(
            "pgm: warning: CRF-Matching of {} did not converge: {}",
            pair.name,
            matching.note.as_deref().unwrap_or(
                "the last round stopped at its sweep limit; the result may be inaccurate"
            )
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// `pgm eval association`.
#[derive(Args, Debug)]
pub struct AssociationEvalArgs {
    /// The association source to evaluate.
    #[arg(long, value_parser = association_names())]
    pub method: String,
    /// A stored scan-pair data set with ground-truth associations.
    #[arg(long, conflicts_with_all = ["carmen", "log", "scans"])]
    pub pairs: Option<PathBuf>,
    /// Input logs (rarely useful: real logs have no true associations).
    #[command(flatten)]
    pub source: SourceArgs,
    /// CRF-Matching options (crf-matching).
    #[command(flatten)]
    pub matching: MatchingOptionArgs,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// The `--json` object of `pgm eval association`.
#[derive(Serialize)]
struct AssociationJson<'a> {
    method: &'a str,
    /// CRF-Matching's `--candidates` and `--motion-fit` (as typed; they do not apply to
    /// the other sources).
    candidates: String,
    motion_fit: &'static str,
    #[serde(flatten)]
    summary: &'a AssociationSummary,
}

/// Runs `pgm eval association`.
pub fn run_eval_association(args: AssociationEvalArgs) -> CliResult {
    let leigh = LeighArgs {
        moving_threshold: 0.0,
        person_radius: 0.35,
        unannotated: Default::default(),
        annotated_sector: false,
    };
    let source = pair_source(args.pairs.as_deref(), &args.source, &leigh, 1)?;
    let mut scored = load_pairs(&source)?.pairs;
    let total = scored.len();
    scored.retain(|p| {
        p.truth
            .as_ref()
            .and_then(|t| t.associations.as_ref())
            .is_some_and(|a| a.iter().any(Option::is_some))
    });
    if scored.is_empty() {
        return Err(CliError(format!(
            "{source}: none of the {total} pairs has ground-truth associations (simulated \
             pairs have them; real logs do not)"
        )));
    }
    if scored.len() < total {
        eprintln!(
            "note: {} of {total} pairs have no ground-truth associations and are not scored",
            total - scored.len()
        );
    }
    let options = args.matching.apply(MethodOptions::default())?;
    options.check().map_err(CliError::from_display)?;
    let method = association_source(&args.method, &options).map_err(CliError::from_display)?;
    let evaluated =
        evaluate_association(&scored, method.as_ref()).map_err(CliError::from_display)?;
    let report = &evaluated.summary;
    if args.json {
        let json = AssociationJson {
            method: &evaluated.method,
            candidates: state_space_name(args.matching.candidates),
            motion_fit: args.matching.motion_fit.name(),
            summary: report,
        };
        print_json(&json)?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "method {}: {} pairs of {source}",
        evaluated.method, report.pairs
    );
    println!("accuracy (exact)        {:.1} %", 100.0 * report.accuracy);
    println!(
        "accuracy within 1 beam  {:.1} %",
        100.0 * report.accuracy_within_one
    );
    println!("string edit distance    {:.1}", report.sed_mean);
    println!(
        "outliers                {:.1} % predicted, {:.1} % true, {} of the true ones found",
        report.outliers_predicted,
        report.outliers_true,
        report
            .outliers_found
            .map_or("n/a (no true outlier)".into(), |x| format!("{x:.1} %"))
    );
    Ok(ExitCode::SUCCESS)
}
