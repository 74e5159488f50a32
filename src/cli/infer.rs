//! `pgm map` and `pgm marginals`: loopy belief propagation on UAI files.

use super::{CliError, CliResult};
use clap::Args;
use pgm_core::uai::{mar_result, mpe_result, Evidence, UaiModel};
use pgm_core::{BeliefPropagation, Mode, ScheduleKind};
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
    /// Message schedule.
    #[arg(long, default_value = "sequential", value_parser = ["flooding", "sequential", "residual"])]
    pub schedule: String,
    /// Damping λ in [0, 1): messages become (1 − λ)·new + λ·old in log space.
    #[arg(long, default_value_t = 0.0)]
    pub damping: f64,
    /// Maximum number of iterations.
    #[arg(long, default_value_t = 1000)]
    pub max_iters: usize,
    /// Convergence tolerance on the largest undamped message change.
    #[arg(long, default_value_t = 1e-9)]
    pub tolerance: f64,
    /// Print `{"iterations", "converged", "residual", "seconds"}` as one JSON line on stderr.
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
    model.check_positive(&evidence).map_err(|e| {
        let inputs = match &args.evidence {
            Some(path) => format!("{} with {}", args.model.display(), path.display()),
            None => args.model.display().to_string(),
        };
        CliError(format!("{inputs}: {e}"))
    })?;
    let kind: ScheduleKind = args.schedule.parse().map_err(CliError::from_display)?;
    let mode = match task {
        Task::Map => Mode::MaxProduct,
        Task::Marginals => Mode::SumProduct,
    };
    let bp = BeliefPropagation::new(mode)
        .damping(args.damping)
        .tolerance(args.tolerance)
        .max_iterations(args.max_iters);
    let mut schedule = kind.build();
    let started = Instant::now();
    let mut result = bp
        .run(&graph, &mut schedule)
        .map_err(CliError::from_display)?;
    let seconds = started.elapsed().as_secs_f64();
    check_result(&args, task, &evidence, &mut result)?;
    if result.contradictions > 0 {
        eprintln!(
            "pgm: warning: {} message updates were all-zero (the evidence or hard zeros contradict each other); beliefs there are uniform",
            result.contradictions
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

/// Refuses a result that contradicts the model: an MPE of probability 0 (which loopy
/// max-product can decode even when positive assignments exist) or NaN beliefs; pins
/// the beliefs of observed variables to their observed state.
fn check_result(
    args: &InferArgs,
    task: Task,
    evidence: &Evidence,
    result: &mut pgm_core::BpResult,
) -> Result<(), CliError> {
    if let Task::Map = task {
        if result.log_score == f64::NEG_INFINITY {
            return Err(CliError(format!(
                "{}: max-product found no assignment of positive probability (its best \
                 assignment {:?} has probability 0); the zeros of the model{} may leave none",
                args.model.display(),
                result.assignment,
                if evidence.0.is_empty() {
                    ""
                } else {
                    " and the evidence"
                },
            )));
        }
    }
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
