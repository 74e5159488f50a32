//! `pgm map` and `pgm marginals`: loopy belief propagation on UAI files, and MAP by
//! TRW-S with its bound (`pgm map --algorithm trws`).
//!
//! Every algorithm says the same about a model with hard zeros: an assignment of
//! probability 0 is never printed, and a model with no assignment of positive
//! probability (`Z = 0`) is refused with status 2 by `pgm map` (both algorithms, every
//! schedule) and `pgm marginals` alike, naming the model file, the proof and a factor
//! the method's own assignment violates ([`pgm_core::Error::Infeasible`]). When loopy
//! decoding violates a hard zero although positive assignments exist, `pgm map`
//! prints instead the first positive assignment found by the library's search guided
//! by the method's messages, with a warning naming the refused decoding
//! ([`pgm_core::BpResult::zero_decoding`], [`pgm_core::TrwsResult::zero_decoding`]);
//! `pgm marginals` warns when the search could not verify `Z > 0`
//! ([`pgm_core::BpResult::support_undecided`]).

use super::{CliError, CliResult};
use clap::Args;
use pgm_core::support::{self, Support};
use pgm_core::uai::{mar_result, mpe_result, Evidence, UaiModel};
use pgm_core::{BpParams, FactorGraph, Mode, ParamGuard, ScheduleKind, TrwsParams};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Which result a run prints.
#[derive(Clone, Copy, Debug)]
pub enum Task {
    /// MPE by max-product.
    Map,
    /// Marginals by sum-product.
    Marginals,
}

/// Options shared by `pgm map` and `pgm marginals`.
#[derive(Args, Debug)]
pub struct InferArgs {
    /// Model file in the UAI format (MARKOV or BAYES).
    pub model: PathBuf,
    /// Evidence file (UAI 2014 `q v x …`, or the 2010 variant with several samples).
    #[arg(long)]
    pub evidence: Option<PathBuf>,
    /// Which sample of a UAI 2010 evidence file to use (index from 0; default 0, with a
    /// note on stderr when the file holds more than one).
    #[arg(long, requires = "evidence")]
    pub sample: Option<usize>,
    /// Inference algorithm: loopy belief propagation, or (`pgm map` only) TRW-S, which
    /// also gives an upper bound on the best log-score and the gap to it.
    #[arg(long, default_value = "bp", value_parser = ["bp", "trws"])]
    pub algorithm: String,
    /// Message schedule (belief propagation).
    #[arg(long, default_value = "sequential", value_parser = ["flooding", "sequential", "residual"])]
    pub schedule: String,
    /// Damping λ in [0, 1): messages become (1 − λ)·new + λ·old in log space.
    #[arg(long, default_value_t = 0.0)]
    pub damping: f64,
    /// Maximum number of iterations.
    #[arg(long, default_value_t = 1000)]
    pub max_iters: usize,
    /// Convergence tolerance: on the largest undamped message change (BP); relative, on
    /// the gap and on the bound's change per iteration (TRW-S).
    #[arg(long, default_value_t = 1e-9)]
    pub tolerance: f64,
    /// Print one JSON line on stderr: `{"iterations", "converged", "residual",
    /// "seconds"}` (BP) or `{"iterations", "converged", "termination", "bound",
    /// "score", "gap", "seconds"}` (TRW-S).
    #[arg(long)]
    pub stats: bool,
}

/// Runs `pgm map` or `pgm marginals`.
pub fn run(args: InferArgs, task: Task) -> CliResult {
    let model = UaiModel::read(&args.model).map_err(CliError::from_display)?;
    let mut graph = model
        .to_factor_graph()
        .map_err(|e| CliError(format!("{}: {e}", args.model.display())))?;
    let evidence = read_evidence(&args, &model)?;
    if let Some(path) = &args.evidence {
        evidence
            .apply(&mut graph)
            .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    }
    let inputs = match &args.evidence {
        Some(path) => format!("{} with {}", args.model.display(), path.display()),
        None => args.model.display().to_string(),
    };
    model
        .check_positive(&evidence)
        .map_err(|e| CliError(format!("{inputs}: {e}")))?;
    let refusal = |e: pgm_core::Error| refusal(&inputs, &model, &evidence, e);
    // Potts tables (as UAI files write them) pass their messages in O(K).
    graph.specialise_factors();
    if args.algorithm == "trws" {
        return run_trws(&args, &graph, task, &refusal);
    }
    let kind: ScheduleKind = args.schedule.parse().map_err(CliError::from_display)?;
    let mode = match task {
        Task::Map => Mode::MaxProduct,
        Task::Marginals => Mode::SumProduct,
    };
    let bp = BpParams::new(mode)
        .damping(args.damping)
        .tolerance(args.tolerance)
        .max_iterations(args.max_iters)
        .check()
        .map_err(CliError::from_display)?;
    let mut schedule = kind.build();
    let started = Instant::now();
    let mut result = bp.run(&graph, &mut schedule).map_err(refusal)?;
    let seconds = started.elapsed().as_secs_f64();
    check_result(&args, &evidence, &mut result)?;
    if let Some(zero) = &result.zero_decoding {
        eprintln!(
            "pgm: warning: max-product ({} schedule) decoded {:?}, which has probability 0 ({}); printing instead the first assignment of positive probability found by a search guided by its messages (log-score {}, no optimality claim: --algorithm trws bounds the gap)",
            args.schedule, zero.assignment, zero.violated, result.log_score
        );
    }
    if result.support_undecided {
        eprintln!(
            "pgm: warning: {}: the search for an assignment of positive probability gave up before a verdict, so Z > 0 is unverified and these marginals may describe a model with none",
            args.model.display()
        );
    }
    if result.contradictions > 0 {
        eprintln!(
            "pgm: warning: {} message updates were all-zero (the evidence or hard zeros contradict each other); beliefs there are uniform",
            result.contradictions
        );
    }
    if !result.converged {
        eprintln!(
            "pgm: warning: belief propagation ({} schedule) stopped at {} without converging: the last iteration's residual {:e} is above the tolerance {:e}; the result may be inaccurate (try --damping, more --max-iters or --algorithm trws)",
            args.schedule,
            if result.out_of_time { "its time budget" } else { "its iteration limit" },
            result.residual,
            args.tolerance
        );
    }
    match task {
        Task::Map => print!("{}", mpe_result(&result.assignment)),
        Task::Marginals => print!("{}", mar_result(&result.beliefs)),
    }
    if args.stats {
        let stats = serde_json::json!({
            "iterations": result.iterations,
            "converged": result.converged,
            "residual": if result.residual.is_finite() { serde_json::json!(result.residual) } else { serde_json::json!(null) },
            "seconds": seconds,
        });
        eprintln!("{stats}");
    }
    Ok(ExitCode::SUCCESS)
}

/// The evidence sample the arguments ask for (empty without `--evidence`).
fn read_evidence(args: &InferArgs, model: &UaiModel) -> Result<Evidence, CliError> {
    let Some(path) = &args.evidence else {
        return Ok(Evidence::default());
    };
    let read =
        Evidence::read_samples(path, &model.cardinalities).map_err(CliError::from_display)?;
    let count = read.samples.len();
    let index = args.sample.unwrap_or(0);
    if index >= count {
        return Err(CliError(format!(
            "{}: --sample {index}, but the file holds {count} evidence sample{} (counted from 0)",
            path.display(),
            if count == 1 { "" } else { "s" }
        )));
    }
    if count > 1 && args.sample.is_none() {
        eprintln!(
            "pgm: note: {} holds {count} evidence samples (UAI 2010 layout); using sample 0 \
             and ignoring the others (--sample N picks another)",
            path.display()
        );
    }
    Ok(read.samples.into_iter().nth(index).unwrap_or_default())
}

/// The message of a library error, naming the inputs. With evidence, a refusal for
/// `Z = 0` also says whether the model alone has positive assignments (then the
/// evidence has probability 0) and that the factors from `functions` on are the
/// evidence's.
fn refusal(inputs: &str, model: &UaiModel, evidence: &Evidence, e: pgm_core::Error) -> CliError {
    let pgm_core::Error::Infeasible(why) = &e else {
        return CliError::from_display(e);
    };
    if evidence.0.is_empty() {
        return CliError(format!("{inputs}: {e}"));
    }
    let functions = model.scopes.len();
    let alone = match (&why.proof, model.to_factor_graph()) {
        (Some(_), Ok(graph)) => {
            match support::positive_assignment(&graph, None, support::DEFAULT_SEARCH_LIMIT) {
                Support::Positive(_) => {
                    "; the model alone has assignments of positive probability, so the \
                     evidence has probability 0 (P(evidence) = 0)"
                }
                Support::Empty(_) => "; the model alone has none either",
                Support::Undecided { .. } => "",
            }
        }
        _ => "",
    };
    CliError(format!(
        "{inputs}: with the evidence applied (as factors {functions} and above): {e}{alone}"
    ))
}

/// Refuses NaN beliefs and pins the beliefs of observed variables to their observed
/// state. (Results of probability 0 are refused by the library: `pgm_core::Error::Infeasible`.)
fn check_result(
    args: &InferArgs,
    evidence: &Evidence,
    result: &mut pgm_core::BpResult,
) -> Result<(), CliError> {
    for &(v, x) in &evidence.0 {
        if let Some(belief) = result.beliefs.get_mut(v) {
            belief
                .iter_mut()
                .enumerate()
                .for_each(|(s, p)| *p = f64::from(s == x));
        }
    }
    if let Some(v) = result
        .beliefs
        .iter()
        .position(|b| b.iter().any(|p| p.is_nan()))
    {
        return Err(CliError(format!(
            "{}: belief propagation produced NaN beliefs for variable {v}",
            args.model.display()
        )));
    }
    Ok(())
}

/// `pgm map --algorithm trws`: the MPE result, and the bound and gap with `--stats`.
fn run_trws(
    args: &InferArgs,
    graph: &FactorGraph,
    task: Task,
    refusal: &dyn Fn(pgm_core::Error) -> CliError,
) -> CliResult {
    if let Task::Marginals = task {
        return Err(CliError(
            "--algorithm trws computes MAP assignments only: use pgm map, or --algorithm bp for marginals".into(),
        ));
    }
    let trws = TrwsParams::default()
        .max_iterations(args.max_iters)
        .tolerance(args.tolerance)
        .check()
        .map_err(CliError::from_display)?;
    let started = Instant::now();
    let result = trws.run(graph).map_err(refusal)?;
    let seconds = started.elapsed().as_secs_f64();
    if let Some(zero) = &result.zero_decoding {
        eprintln!(
            "pgm: warning: TRW-S decoded {:?}, which has probability 0 ({}); printing instead the first assignment of positive probability found by a search guided by its messages (log-score {}, gap {} to the bound)",
            zero.assignment, zero.violated, result.log_score, result.gap
        );
    }
    if !result.converged {
        eprintln!(
            "pgm: warning: TRW-S stopped at its iteration limit ({} iterations) before the bound settled; the assignment is at most {} below the optimum",
            result.iterations, result.gap
        );
    }
    print!("{}", mpe_result(&result.assignment));
    if args.stats {
        let finite = |x: f64| {
            if x.is_finite() {
                serde_json::json!(x)
            } else {
                serde_json::json!(null)
            }
        };
        let stats = serde_json::json!({
            "algorithm": "trws",
            "iterations": result.iterations,
            "converged": result.converged,
            "termination": format!("{:?}", result.termination),
            "bound": finite(result.bound),
            "score": finite(result.log_score),
            "gap": finite(result.gap),
            "seconds": seconds,
        });
        eprintln!("{stats}");
    }
    Ok(ExitCode::SUCCESS)
}
