//! A conformance kit for factors and schedules of one's own (feature `testing`): the
//! checks the built-in ones pass, to call from a user's tests.
//!
//! - [`check_factor`]: shape and scope, log-potentials never NaN or +∞, the log-table
//!   and [`Factor::has_hard_zeros`] consistent with [`Factor::log_potential`], and
//!   [`Factor::message`] equal to brute-force enumeration for every target position,
//!   in both modes, every output entry written, for incoming messages that are
//!   uniform, random, partly −∞ (hard zeros), all −∞ at one position (a contradiction,
//!   whose message must be all −∞), and of magnitude 10⁸ (log-space stability); and a
//!   [`Factor::message_kernel`], if the factor gives one, describing exactly its table.
//! - [`check_schedule`]: on random trees of 2-9 variables (unary and pairwise tables,
//!   some with hard zeros), belief propagation with the schedule converges in both
//!   modes, to the exact marginals (sum-product) and to an assignment of the exact MAP
//!   score (max-product): which also shows that every edge's message was passed.
//! - [`check_continuous_model`]: observed-continuous nodes of the hybrid engine
//!   ([`ContinuousModel`]) on forests: hybrid inference with exact sweeps and a
//!   re-solve after each one is coordinate ascent, so the joint log-score it traces
//!   must never decrease, and the final decoding must be at least as good as the last
//!   sweep; and incremental updates must equal a fresh start (a model moved from one
//!   labelling to another, old states taken out, solves to the same potentials as a
//!   fresh model given the second labelling).
//! - [`factor_conformance!`](crate::factor_conformance) and
//!   [`schedule_conformance!`](crate::schedule_conformance) write the `#[test]`.
//!
//! Inputs are drawn from a fixed-seed generator (the same cases every run, so a
//! failure reproduces); a failure is a [`Nonconformance`] naming the check, the case
//! and the values.
//!
//! ```
//! use pgm_core::{Factor, VariableId};
//! use pgm_core::testing::check_factor;
//!
//! /// Rewards two variables for differing by exactly one, with a message of its own.
//! #[derive(Debug)]
//! struct NextTo { scope: [VariableId; 2], shape: [usize; 2] }
//!
//! impl Factor for NextTo {
//!     fn scope(&self) -> &[VariableId] { &self.scope }
//!     fn shape(&self) -> &[usize] { &self.shape }
//!     fn log_potential(&self, s: &[usize]) -> f64 {
//!         if s[0].abs_diff(s[1]) == 1 { 2.0 } else { 0.0 }
//!     }
//! }
//!
//! check_factor(&NextTo { scope: [VariableId(0), VariableId(1)], shape: [3, 4] }).unwrap();
//! ```

use crate::exact::{tree_map, tree_marginals};
use crate::factor::{enumerated_message, Factor, Incoming, MessageKernel, Mode};
use crate::hook::Potentials;
use crate::hybrid::{
    ContinuousModel, DiscreteSummary, HybridInference, UpdatePolicy, VariableState,
};
use crate::{BpParams, FactorGraph, ParamGuard, Schedule, TableFactor, VariableId};

/// What a conformance check found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{check}: {detail}")]
pub struct Nonconformance {
    /// The check that failed.
    pub check: &'static str,
    /// The case and the values.
    pub detail: String,
}

fn fail<T>(check: &'static str, detail: String) -> Result<T, Nonconformance> {
    Err(Nonconformance { check, detail })
}

/// Joint states at most [`check_factor`] enumerates.
pub const MAX_JOINT_STATES: usize = 1 << 20;

/// A small deterministic generator (xorshift64*), so the kit needs no dependency.
struct Cases(u64);

impl Cases {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in 0..n.
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Row-major successor of `states` (last position fastest).
fn increment(states: &mut [usize], shape: &[usize]) {
    crate::factor::increment(states, shape);
}

/// Close enough for log-space values: both −∞, or within `1e-9 + 1e-12 · scale`.
fn close(a: f64, b: f64, scale: f64) -> bool {
    (a == f64::NEG_INFINITY && b == f64::NEG_INFINITY)
        || (a.is_finite() && b.is_finite() && (a - b).abs() <= 1e-9 + 1e-12 * scale)
}

/// A factor's [`Factor::message_kernel`] must describe its own table: the engine
/// evaluates the kernel instead of calling [`Factor::message`].
fn check_kernel<F: Factor + ?Sized>(
    factor: &F,
    shape: &[usize],
    table: &[f64],
) -> Result<(), Nonconformance> {
    let same_values = |kernel: &[f64]| {
        kernel.len() == table.len()
            && kernel
                .iter()
                .zip(table)
                .all(|(a, b)| a.to_bits() == b.to_bits() || a == b)
    };
    match factor.message_kernel() {
        None => Ok(()),
        Some(MessageKernel::Unary(t)) if shape.len() == 1 && same_values(t) => Ok(()),
        Some(MessageKernel::Table(t)) if shape.len() == 2 && same_values(t) => Ok(()),
        Some(MessageKernel::Potts { same, different })
            if shape.len() == 2 && shape[0] == shape[1] =>
        {
            let k = shape[0];
            match (0..table.len()).find(|&i| {
                let want = if i / k == i % k { same } else { different };
                table[i] != want
            }) {
                None => Ok(()),
                Some(i) => fail(
                    "message_kernel",
                    format!(
                        "Potts {{ same: {same}, different: {different} }}, but the table's \
                         entry {i} ({:?}) is {}",
                        [i / k, i % k],
                        table[i]
                    ),
                ),
            }
        }
        Some(kernel) => fail(
            "message_kernel",
            format!("{kernel:?} does not describe a factor of shape {shape:?} and its table"),
        ),
    }
}

/// Checks `factor` as the engine relies on it (see the module docs).
///
/// # Errors
/// The first [`Nonconformance`] found.
pub fn check_factor<F: Factor + ?Sized>(factor: &F) -> Result<(), Nonconformance> {
    let scope = factor.scope();
    let shape = factor.shape();
    if scope.is_empty() {
        return fail("shape", "the scope is empty".into());
    }
    if scope.len() != shape.len() {
        return fail(
            "shape",
            format!(
                "{} scope variables but {} shape entries",
                scope.len(),
                shape.len()
            ),
        );
    }
    if let Some(j) = shape.iter().position(|&k| k == 0) {
        return fail("shape", format!("scope position {j} has 0 states"));
    }
    for (j, v) in scope.iter().enumerate() {
        if scope[..j].contains(v) {
            return fail("scope", format!("variable {} appears twice", v.0));
        }
    }
    let size = shape
        .iter()
        .try_fold(1usize, |n, &k| n.checked_mul(k))
        .filter(|&n| n <= MAX_JOINT_STATES);
    let Some(size) = size else {
        return fail(
            "shape",
            format!("{shape:?}: more than {MAX_JOINT_STATES} joint states, too many to enumerate"),
        );
    };
    // Log-potentials, the table, hard zeros.
    let table = factor.log_table();
    if table.len() != size {
        return fail(
            "log_table",
            format!("{} entries for {size} joint states", table.len()),
        );
    }
    let mut states = vec![0usize; shape.len()];
    let mut hard_zero = false;
    for (index, &t) in table.iter().enumerate() {
        let p = factor.log_potential(&states);
        if p.is_nan() || p == f64::INFINITY {
            return fail(
                "log_potential",
                format!("{p} at {states:?} (must not be NaN or +inf)"),
            );
        }
        if !close(p, t, p.abs()) {
            return fail(
                "log_table",
                format!("entry {index} ({states:?}) is {t}, log_potential says {p}"),
            );
        }
        hard_zero |= p == f64::NEG_INFINITY;
        increment(&mut states, shape);
    }
    if factor.has_hard_zeros() != hard_zero {
        return fail(
            "has_hard_zeros",
            format!(
                "says {}, the table {} a -inf entry",
                factor.has_hard_zeros(),
                if hard_zero { "has" } else { "has no" }
            ),
        );
    }
    check_kernel(factor, shape, &table)?;
    // Messages against enumeration.
    let mut offsets = vec![0usize];
    for &k in shape {
        offsets.push(offsets.last().copied().unwrap_or(0) + k);
    }
    let total = offsets[shape.len()];
    let mut cases = Cases(0x9E37_79B9_7F4A_7C15);
    let scenarios: [&str; 5] = ["uniform", "random", "partly -inf", "contradiction", "large"];
    for mode in [Mode::MaxProduct, Mode::SumProduct] {
        for target in 0..shape.len() {
            for scenario in scenarios {
                for trial in 0..3 {
                    let mut values = vec![0.0; total];
                    let mut scale: f64 = 0.0;
                    for (j, w) in offsets.windows(2).enumerate() {
                        let slot = &mut values[w[0]..w[1]];
                        match scenario {
                            "uniform" => {}
                            "random" => slot.iter_mut().for_each(|x| *x = cases.range(-3.0, 3.0)),
                            "partly -inf" => {
                                slot.iter_mut().for_each(|x| {
                                    *x = if cases.unit() < 0.35 {
                                        f64::NEG_INFINITY
                                    } else {
                                        cases.range(-3.0, 3.0)
                                    }
                                });
                                // Not every state blocked.
                                let keep = cases.below(slot.len());
                                slot[keep] = cases.range(-3.0, 3.0);
                            }
                            "contradiction" => {
                                if j == (target + 1) % shape.len() && shape.len() > 1 {
                                    slot.iter_mut().for_each(|x| *x = f64::NEG_INFINITY);
                                } else {
                                    slot.iter_mut().for_each(|x| *x = cases.range(-3.0, 3.0));
                                }
                            }
                            _ => {
                                let offset = if cases.unit() < 0.5 { 1e8 } else { -1e8 };
                                slot.iter_mut()
                                    .for_each(|x| *x = offset + cases.range(-1e3, 1e3));
                            }
                        }
                        if j != target {
                            scale += slot
                                .iter()
                                .filter(|x| x.is_finite())
                                .fold(0.0f64, |m, x| m.max(x.abs()));
                        }
                    }
                    // The target's own entry is unspecified: garbage there.
                    values[offsets[target]..offsets[target + 1]]
                        .iter_mut()
                        .for_each(|x| *x = f64::NAN);
                    let incoming = Incoming::new(&values, &offsets);
                    let mut expected = vec![0.0; shape[target]];
                    enumerated_message(factor, target, &incoming, mode, &mut expected);
                    let mut got = vec![f64::NAN; shape[target]];
                    factor.message(target, &incoming, mode, &mut got);
                    let table_scale = table
                        .iter()
                        .filter(|x| x.is_finite())
                        .fold(0.0f64, |m, x| m.max(x.abs()));
                    for (x, (g, e)) in got.iter().zip(&expected).enumerate() {
                        if !close(*g, *e, scale + table_scale + e.abs()) {
                            return fail(
                                "message",
                                format!(
                                    "{mode:?}, target position {target}, incoming {scenario} \
                                     (case {trial}): state {x} is {g}, enumeration gives {e} \
                                     (incoming {values:?})"
                                ),
                            );
                        }
                    }
                    if scenario == "contradiction" && shape.len() > 1 {
                        if let Some(x) = got.iter().position(|g| *g != f64::NEG_INFINITY) {
                            return fail(
                                "message",
                                format!(
                                    "{mode:?}, target position {target}: another position's \
                                     incoming message is all -inf, yet state {x} is {}",
                                    got[x]
                                ),
                            );
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

/// A random tree of 2-9 variables with 1-4 states: a unary table on most variables and
/// a pairwise table on every edge, log-potentials in [-2, 2], some −∞ (never all of a
/// table). Returns `None` when the draw has no assignment of positive probability.
fn random_tree(cases: &mut Cases) -> Option<FactorGraph> {
    let n = 2 + cases.below(8);
    let cards: Vec<usize> = (0..n).map(|_| 1 + cases.below(4)).collect();
    let mut graph = FactorGraph::with_variables(&cards).ok()?;
    let table = |cases: &mut Cases, size: usize| -> Vec<f64> {
        let mut t: Vec<f64> = (0..size)
            .map(|_| {
                if cases.unit() < 0.1 {
                    f64::NEG_INFINITY
                } else {
                    cases.range(-2.0, 2.0)
                }
            })
            .collect();
        let keep = cases.below(size);
        t[keep] = cases.range(-2.0, 2.0);
        t
    };
    for (v, &k) in cards.iter().enumerate() {
        if cases.unit() < 0.7 {
            let t = table(cases, k);
            graph
                .add_factor(TableFactor::new(vec![VariableId(v)], vec![k], t).ok()?)
                .ok()?;
        }
    }
    for v in 1..n {
        let parent = cases.below(v);
        let (a, b) = if cases.unit() < 0.5 {
            (parent, v)
        } else {
            (v, parent)
        };
        let t = table(cases, cards[a] * cards[b]);
        graph
            .add_factor(
                TableFactor::new(
                    vec![VariableId(a), VariableId(b)],
                    vec![cards[a], cards[b]],
                    t,
                )
                .ok()?,
            )
            .ok()?;
    }
    tree_marginals(&graph)
        .ok()
        .filter(|s| s.log_partition > f64::NEG_INFINITY)
        .map(|_| graph)
}

/// Checks the schedules `make` builds (a fresh one per run) on random trees: belief
/// propagation converges in both modes and is exact there (see the module docs);
/// `trees` of them (at least 1; the built-in schedules pass 200).
///
/// # Errors
/// The first [`Nonconformance`] found, naming the tree's case number and sizes.
pub fn check_schedule(
    make: impl Fn() -> Box<dyn Schedule>,
    trees: usize,
) -> Result<(), Nonconformance> {
    let mut cases = Cases(0xD1B5_4A32_D192_ED03);
    let mut checked = 0;
    let mut case = 0;
    while checked < trees.max(1) {
        case += 1;
        let Some(graph) = random_tree(&mut cases) else {
            continue;
        };
        checked += 1;
        let exact = tree_marginals(&graph).map_err(|e| Nonconformance {
            check: "schedule",
            detail: format!("case {case}: exact reference failed: {e}"),
        })?;
        let (_, map_score) = tree_map(&graph).map_err(|e| Nonconformance {
            check: "schedule",
            detail: format!("case {case}: exact reference failed: {e}"),
        })?;
        for mode in [Mode::SumProduct, Mode::MaxProduct] {
            let bp = BpParams::new(mode)
                .tolerance(1e-12)
                .max_iterations(10_000)
                .check()
                .map_err(|e| Nonconformance {
                    check: "schedule",
                    detail: e.to_string(),
                })?;
            let mut schedule = make();
            let name = schedule.name().to_string();
            let what = format!(
                "schedule {name:?}, {mode:?}, case {case} ({} variables, {} factors)",
                graph.num_variables(),
                graph.num_factors()
            );
            let result = bp
                .run(&graph, schedule.as_mut())
                .map_err(|e| Nonconformance {
                    check: "schedule",
                    detail: format!("{what}: {e}"),
                })?;
            if !result.converged {
                return fail(
                    "schedule converges on a tree",
                    format!(
                        "{what}: {} iterations, residual {}",
                        result.iterations, result.residual
                    ),
                );
            }
            match mode {
                Mode::SumProduct => {
                    for (v, (b, e)) in result.beliefs.iter().zip(&exact.marginals).enumerate() {
                        if b.iter().zip(e).any(|(x, y)| (x - y).abs() > 1e-8) {
                            return fail(
                                "schedule exact on a tree",
                                format!(
                                    "{what}: variable {v}: beliefs {b:?}, exact marginals {e:?}"
                                ),
                            );
                        }
                    }
                }
                Mode::MaxProduct => {
                    if (result.log_score - map_score).abs() > 1e-9 * map_score.abs().max(1.0) {
                        return fail(
                            "schedule exact on a tree",
                            format!(
                                "{what}: decoded log-score {}, exact MAP {map_score}",
                                result.log_score
                            ),
                        );
                    }
                }
            }
        }
    }
    Ok(())
}

/// Checks a continuous model by coordinate ascent, on each of `cases` instances that
/// `make(case)` builds: a forest-shaped graph, its model (summarising the discrete
/// variables by MAP labels) and optional initial labels. Hybrid inference runs
/// max-product with the sequential two-pass schedule (exact on a forest in one sweep)
/// and re-solves the continuous values after every sweep
/// ([`UpdatePolicy::EverySweep`]), for at most 40 sweeps. Each traced joint
/// log-score must be finite or −∞ and at least the previous one (to `1e-9` relative),
/// and the final decoding's at least the last traced one.
///
/// Then, on two more instances of each case: one model is given a labelling `L1`
/// (each variable's initial label, else `v mod` its states), solved, moved to `L2`
/// (`L1` rotated by one variable: the same labels in use) through
/// [`ContinuousModel::update_variable`] with the old states, and solved again; a fresh
/// model is given `L2` and solved. Every dependent factor refreshed from the two must
/// have the same log-table (to `1e-9` relative): statistics that keep a stale state
/// fail here (one-hot beliefs stand for labels when the model summarises by beliefs).
///
/// # Errors
/// The first [`Nonconformance`] found, naming the case and the scores; the engine's
/// errors (a graph that is not a forest, a model that refuses its factors).
pub fn check_continuous_model<M: ContinuousModel>(
    cases: usize,
    make: impl Fn(usize) -> (FactorGraph, M, Option<Vec<usize>>),
) -> Result<(), Nonconformance> {
    let bp = BpParams::new(Mode::MaxProduct)
        .max_iterations(40)
        .check()
        .map_err(|e| Nonconformance {
            check: "continuous model",
            detail: e.to_string(),
        })?;
    let hybrid = HybridInference::new(bp, UpdatePolicy::EverySweep).trace_scores(true);
    for case in 0..cases {
        let (mut graph, mut model, labels) = make(case);
        if !graph.is_forest() {
            return fail(
                "continuous model",
                format!("case {case}: the graph has a cycle; coordinate ascent is only guaranteed on forests"),
            );
        }
        let result = hybrid
            .run(
                &mut graph,
                &mut model,
                &mut crate::Sequential::default(),
                labels.as_deref(),
            )
            .map_err(|e| Nonconformance {
                check: "continuous model",
                detail: format!("case {case}: {e}"),
            })?;
        let s = &result.sweep_scores;
        if let Some(bad) = s.iter().find(|x| x.is_nan() || **x == f64::INFINITY) {
            return fail(
                "continuous model",
                format!("case {case}: a traced score is {bad}"),
            );
        }
        for (k, w) in s.windows(2).enumerate() {
            if w[1] < w[0] - 1e-9 * (1.0 + w[0].abs()) {
                return fail(
                    "coordinate ascent",
                    format!(
                        "case {case}: the joint log-score fell from {} to {} at sweep {} \
                         (scores {s:?})",
                        w[0],
                        w[1],
                        k + 2
                    ),
                );
            }
        }
        if let Some(&last) = s.last() {
            if result.joint_log_score < last - 1e-9 * (1.0 + last.abs()) {
                return fail(
                    "coordinate ascent",
                    format!(
                        "case {case}: the final decoding scores {}, below the last sweep's {last}",
                        result.joint_log_score
                    ),
                );
            }
        }
        check_incremental(case, &make)?;
    }
    Ok(())
}

/// Feeds `labels` to `model`, taking `old` out first, in the model's summary.
fn feed(model: &mut dyn ContinuousModel, labels: &[usize], old: Option<&[usize]>, cards: &[usize]) {
    let beliefs = model.summary() == DiscreteSummary::Beliefs;
    let one_hot = |v: usize, l: usize| {
        let mut b = vec![0.0; cards[v]];
        b[l] = 1.0;
        b
    };
    for (v, &l) in labels.iter().enumerate() {
        let (new_b, old_b) = (one_hot(v, l), old.map(|o| one_hot(v, o[v])));
        let new = if beliefs {
            VariableState::Belief(&new_b)
        } else {
            VariableState::Label(l)
        };
        let old = match (old, &old_b) {
            (Some(_), Some(b)) if beliefs => Some(VariableState::Belief(b)),
            (Some(o), _) => Some(VariableState::Label(o[v])),
            _ => None,
        };
        model.update_variable(VariableId(v), old, new);
    }
}

/// The log-tables of every dependent factor of `model`, refreshed into `graph`.
fn refreshed(
    graph: &mut FactorGraph,
    model: &dyn ContinuousModel,
) -> Result<Vec<(usize, Vec<f64>)>, crate::Error> {
    let factors = model.all_dependent_factors(graph);
    let mut potentials = Potentials::new(graph);
    for &a in &factors {
        model.refresh_factor(a, &mut potentials)?;
    }
    Ok(factors
        .iter()
        .map(|&a| (a.0, graph.factor(a).log_table()))
        .collect())
}

fn check_incremental<M: ContinuousModel>(
    case: usize,
    make: &impl Fn(usize) -> (FactorGraph, M, Option<Vec<usize>>),
) -> Result<(), Nonconformance> {
    let engine = |e: crate::Error| Nonconformance {
        check: "incremental statistics",
        detail: format!("case {case}: {e}"),
    };
    let (mut moved_graph, mut moved, labels) = make(case);
    let cards: Vec<usize> = (0..moved_graph.num_variables())
        .map(|v| moved_graph.cardinality(VariableId(v)))
        .collect();
    let n = cards.len();
    let first: Vec<usize> = labels.unwrap_or_else(|| (0..n).map(|v| v % cards[v]).collect());
    let second: Vec<usize> = (0..n)
        .map(|v| {
            let l = first[(v + 1) % n];
            if l < cards[v] {
                l
            } else {
                first[v]
            }
        })
        .collect();
    feed(&mut moved, &first, None, &cards);
    moved.solve();
    feed(&mut moved, &second, Some(&first), &cards);
    moved.solve();
    let (mut fresh_graph, mut fresh, _) = make(case);
    feed(&mut fresh, &second, None, &cards);
    fresh.solve();
    let a = refreshed(&mut moved_graph, &moved).map_err(engine)?;
    let b = refreshed(&mut fresh_graph, &fresh).map_err(engine)?;
    for ((factor, x), (_, y)) in a.iter().zip(&b) {
        let scale = x
            .iter()
            .chain(y)
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        if let Some(k) = (0..x.len().min(y.len())).find(|&k| !close(x[k], y[k], 1e3 * scale)) {
            return fail(
                "incremental statistics",
                format!(
                    "case {case}: factor {factor} entry {k} is {} after moving the model from \
                     labels {first:?} to {second:?}, but {} from a fresh model given {second:?}: \
                     are old states taken out?",
                    x[k], y[k]
                ),
            );
        }
    }
    Ok(())
}

/// Writes a `#[test]` that runs [`check_factor`] on a factor:
/// `pgm_core::factor_conformance!(test_name, expression building the factor);`
#[macro_export]
macro_rules! factor_conformance {
    ($name:ident, $factor:expr) => {
        #[test]
        fn $name() {
            if let Err(e) = $crate::testing::check_factor(&$factor) {
                panic!("{}", e);
            }
        }
    };
}

/// Writes a `#[test]` that runs [`check_schedule`] on 200 random trees:
/// `pgm_core::schedule_conformance!(test_name, || Box::new(MySchedule::default()));`
#[macro_export]
macro_rules! schedule_conformance {
    ($name:ident, $make:expr) => {
        #[test]
        fn $name() {
            if let Err(e) = $crate::testing::check_schedule($make, 200) {
                panic!("{}", e);
            }
        }
    };
}
