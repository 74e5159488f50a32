//! Inference speed: max-product iterations on a 100×100 Potts grid with 5 labels per
//! schedule (one thread; flooding also on two) and TRW-S iterations on the same grid,
//! with the pairwise factors as O(K) Potts factors and as dense 5×5 tables (the form a
//! UAI file gives); and one forward-backward sweep over a chain of 361 variables with
//! 362 states (dense pairwise tables and the O(K) shifted-identity factor). The grid is
//! the distribution of `gen_models.py potts --n 100 --k 5`: unary log-potentials
//! N(0, 1), log-potential 1 for equal labels (our own seeded draws).
//!
//! The `uai_file` group runs what `pgm map FILE --schedule flooding` runs, on the
//! generator's own file: `UaiModel::read`, `to_factor_graph`, `specialise_factors`
//! (Potts tables become O(K) Potts factors) and `BeliefPropagation::run` with decoding,
//! 10 iterations on one thread; and the same without `specialise_factors` (the dense
//! 5×5 tables). The file is `$PGM_BENCH_UAI`, or else written by `python3
//! ../shared/tools/gen_models.py potts --n 100 --k 5 --seed 1` into a temporary
//! directory; without either the group is skipped with a message.
//!
//! Run: `cargo bench --bench inference`. Grid figures are for 10 iterations from
//! uniform messages (divide by 10 for one iteration).

use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkGroup, Criterion};
use pgm_core::{
    BeliefPropagation, BpParams, FactorGraph, Flooding, Messages, Mode, ParamGuard, PottsFactor,
    Residual, Schedule, Sequential, ShiftedIdentityFactor, TableFactor, TrwsParams, VariableId,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::time::Duration;

/// The grid in the factor order of `gen_models.py potts`: unaries, horizontal pairs,
/// vertical pairs; pairs as Potts factors or as dense tables.
fn potts_grid(n: usize, k: usize, seed: u64, dense: bool) -> FactorGraph {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut g = FactorGraph::with_variables(&vec![k; n * n]).unwrap();
    for v in 0..n * n {
        let t: Vec<f64> = (0..k).map(|_| rng.sample(StandardNormal)).collect();
        g.add_factor(TableFactor::new(vec![VariableId(v)], vec![k], t).unwrap())
            .unwrap();
    }
    let pair = |g: &mut FactorGraph, a: usize, b: usize| {
        let (a, b) = (VariableId(a), VariableId(b));
        if dense {
            let t = (0..k * k)
                .map(|i| if i / k == i % k { 1.0 } else { 0.0 })
                .collect();
            g.add_factor(TableFactor::new(vec![a, b], vec![k, k], t).unwrap())
                .unwrap();
        } else {
            g.add_factor(PottsFactor::new(a, b, k, 1.0, 0.0).unwrap())
                .unwrap();
        }
    };
    for r in 0..n {
        for c in 0..n - 1 {
            pair(&mut g, r * n + c, r * n + c + 1);
        }
    }
    for r in 0..n - 1 {
        for c in 0..n {
            pair(&mut g, r * n + c, (r + 1) * n + c);
        }
    }
    g
}

fn chain(len: usize, states: usize, dense: bool, seed: u64) -> FactorGraph {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut g = FactorGraph::with_variables(&vec![states; len]).unwrap();
    for v in 0..len {
        let t: Vec<f64> = (0..states).map(|_| rng.sample(StandardNormal)).collect();
        g.add_factor(TableFactor::new(vec![VariableId(v)], vec![states], t).unwrap())
            .unwrap();
    }
    for v in 0..len - 1 {
        let (a, b) = (VariableId(v), VariableId(v + 1));
        if dense {
            let t: Vec<f64> = (0..states * states)
                .map(|_| rng.sample(StandardNormal))
                .collect();
            g.add_factor(TableFactor::new(vec![a, b], vec![states, states], t).unwrap())
                .unwrap();
        } else {
            g.add_factor(ShiftedIdentityFactor::new(a, b, states, states, 1, 2.0, 0.0).unwrap())
                .unwrap();
        }
    }
    g
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// Max-product belief propagation of exactly `n` iterations (tolerance 0).
fn max_product(n: usize) -> BeliefPropagation {
    BpParams::new(Mode::MaxProduct)
        .tolerance(0.0)
        .max_iterations(n)
        .check_unwrap()
}

/// Makes a run's schedule (a fresh one for every batch).
type MakeSchedule = Box<dyn Fn() -> Box<dyn Schedule>>;

/// Benchmarks `bp` on `graph` from uniform messages for each run: its name, the pool
/// it runs in and its schedule.
fn bench_runs(
    group: &mut BenchmarkGroup<'_, WallTime>,
    bp: &BeliefPropagation,
    graph: &FactorGraph,
    runs: Vec<(&str, &rayon::ThreadPool, MakeSchedule)>,
) {
    for (name, pool, make) in runs {
        group.bench_function(name, |b| {
            b.iter_batched(
                || (make(), Messages::uniform(graph, Mode::MaxProduct)),
                |(mut schedule, start)| {
                    pool.install(|| iterations(bp, graph, schedule.as_mut(), start))
                },
                BatchSize::LargeInput,
            )
        });
    }
}

fn iterations(
    bp: &BeliefPropagation,
    graph: &FactorGraph,
    schedule: &mut dyn Schedule,
    start: Messages,
) {
    let p = bp.on(graph).warm_start(start).propagate(schedule).unwrap();
    assert!(p.iterations >= 1);
    std::hint::black_box(p);
}

fn grid(c: &mut Criterion) {
    for (label, dense) in [("potts_factors", false), ("dense_tables", true)] {
        let graph = potts_grid(100, 5, 1, dense);
        let bp = max_product(10);
        let one = pool(1);
        let two = pool(2);
        let mut group = c.benchmark_group(format!(
            "potts_grid_100x100_k5_{label}_max_product_10_iterations"
        ));
        group
            .sample_size(20)
            .measurement_time(Duration::from_secs(8));
        let runs: Vec<(&str, &rayon::ThreadPool, MakeSchedule)> = vec![
            ("flooding_1_thread", &one, Box::new(|| Box::new(Flooding))),
            ("flooding_2_threads", &two, Box::new(|| Box::new(Flooding))),
            (
                "sequential_1_thread",
                &one,
                Box::new(|| Box::new(Sequential::default())),
            ),
            (
                "residual_1_thread",
                &one,
                Box::new(|| Box::new(Residual::default())),
            ),
        ];
        bench_runs(&mut group, &bp, &graph, runs);
        // TRW-S: ten iterations (forward and backward pass each), bound and decoding
        // included, tolerance 0 so that all ten run.
        let trws = TrwsParams::default()
            .max_iterations(10)
            .tolerance(0.0)
            .check()
            .unwrap();
        group.bench_function("trws_1_thread", |b| {
            b.iter(|| {
                let r = one.install(|| trws.run(&graph)).unwrap();
                assert_eq!(r.iterations, 10);
                std::hint::black_box(r);
            })
        });
        group.finish();
    }
}

fn chains(c: &mut Criterion) {
    let bp = max_product(1);
    let one = pool(1);
    let two = pool(2);
    let mut group = c.benchmark_group("chain_361x362_max_product_one_sweep");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10));
    let shifted = chain(361, 362, false, 2);
    bench_runs(
        &mut group,
        &bp,
        &shifted,
        vec![(
            "shifted_identity_sequential_1_thread",
            &one,
            Box::new(|| Box::new(Sequential::default())),
        )],
    );
    let dense = chain(361, 362, true, 2);
    bench_runs(
        &mut group,
        &bp,
        &dense,
        vec![
            (
                "dense_sequential_1_thread",
                &one,
                Box::new(|| Box::new(Sequential::default())),
            ),
            (
                "dense_flooding_1_thread",
                &one,
                Box::new(|| Box::new(Flooding)),
            ),
            (
                "dense_flooding_2_threads",
                &two,
                Box::new(|| Box::new(Flooding)),
            ),
        ],
    );
    group.finish();
}

/// The generator's UAI file: `$PGM_BENCH_UAI`, or written by `gen_models.py` from
/// `../shared/tools` into a temporary directory.
fn generator_file() -> Result<std::path::PathBuf, String> {
    if let Some(path) = std::env::var_os("PGM_BENCH_UAI") {
        return Ok(path.into());
    }
    let tool =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/tools/gen_models.py");
    if !tool.exists() {
        return Err(format!(
            "{} not found and PGM_BENCH_UAI not set",
            tool.display()
        ));
    }
    let dir = std::env::temp_dir().join(format!("pgm-bench-uai-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let out = dir.join("potts");
    let status = std::process::Command::new("python3")
        .arg(&tool)
        .args([
            "potts", "--n", "100", "--k", "5", "--seed", "1", "--no-fg", "--out",
        ])
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .status()
        .map_err(|e| format!("python3 {}: {e}", tool.display()))?;
    if !status.success() {
        return Err(format!("python3 {} failed: {status}", tool.display()));
    }
    Ok(out.with_extension("uai"))
}

fn uai_file(c: &mut Criterion) {
    let path = match generator_file() {
        Ok(path) => path,
        Err(why) => {
            eprintln!("uai_file: skipped ({why})");
            return;
        }
    };
    let model = pgm_core::uai::UaiModel::read(&path).unwrap();
    let one = pool(1);
    let bp = max_product(10);
    let mut group = c.benchmark_group("uai_file_potts_100x100_k5_max_product_10_iterations");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(8));
    for (name, specialise) in [
        ("as_pgm_map_runs_it_flooding_1_thread", true),
        ("dense_tables_flooding_1_thread", false),
    ] {
        let mut graph = model.to_factor_graph().unwrap();
        if specialise {
            assert!(
                graph.specialise_factors() > 0,
                "{}: no Potts tables",
                path.display()
            );
        }
        group.bench_function(name, |b| {
            b.iter(|| {
                let r = one.install(|| bp.run(&graph, &mut Flooding)).unwrap();
                assert_eq!(r.iterations, 10);
                std::hint::black_box(r);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, grid, chains, uai_file);
criterion_main!(benches);
