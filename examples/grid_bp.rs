//! Loopy max-product on a seeded Potts grid, timed per iteration: a quick way to see
//! what the engine does on a large loopy model without writing a UAI file.
//!
//! Run: `cargo run --release --example grid_bp -- [SIDE] [LABELS] [SCHEDULE] [ITERATIONS] [THREADS]`
//! (defaults: 100 5 flooding 10 1; schedules: flooding, sequential, residual). Unary
//! log-potentials are drawn N(0, 1) and equal neighbours get log-potential 1, the
//! distribution of `gen_models.py potts` (with our own draws).

use pgm_core::{
    BpParams, FactorGraph, Mode, ParamGuard, PottsFactor, ScheduleKind, TableFactor, VariableId,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.to_string());
    let side: usize = arg(0, "100").parse()?;
    let k: usize = arg(1, "5").parse()?;
    let kind: ScheduleKind = arg(2, "flooding").parse()?;
    let iterations: usize = arg(3, "10").parse()?;
    let threads: usize = arg(4, "1").parse()?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut g = FactorGraph::with_variables(&vec![k; side * side])?;
    for v in 0..side * side {
        let t = (0..k).map(|_| rng.sample(StandardNormal)).collect();
        g.add_factor(TableFactor::new(vec![VariableId(v)], vec![k], t)?)?;
    }
    for r in 0..side {
        for c in 0..side {
            let v = r * side + c;
            if c + 1 < side {
                g.add_factor(PottsFactor::new(
                    VariableId(v),
                    VariableId(v + 1),
                    k,
                    1.0,
                    0.0,
                )?)?;
            }
            if r + 1 < side {
                g.add_factor(PottsFactor::new(
                    VariableId(v),
                    VariableId(v + side),
                    k,
                    1.0,
                    0.0,
                )?)?;
            }
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let bp = BpParams::new(Mode::MaxProduct)
        .tolerance(0.0)
        .max_iterations(iterations)
        .check_unwrap();
    let mut schedule = kind.build();
    let start = Instant::now();
    let result = pool.install(|| bp.run(&g, &mut schedule))?;
    let seconds = start.elapsed().as_secs_f64();
    println!(
        "{side}x{side} grid, {k} labels, {kind:?} on {threads} thread(s): {} iterations in {:.1} ms ({:.2} ms per iteration, decoding included), MAP log-score {:.3}",
        result.iterations,
        seconds * 1e3,
        seconds * 1e3 / result.iterations as f64,
        result.log_score
    );
    Ok(())
}
