//! The engine's compiled message plan (flat steps for Potts factors, small dense tables
//! and unary tables) against the general path through the factor trait objects.
//!
//! A run with an update hook never builds a plan (a hook may change potentials), so
//! the same run with a hook that does nothing takes the general path for every
//! message. The two must give bit-identical messages, under every schedule, in both
//! modes, with and without damping, on graphs that mix every kind of step: Potts
//! factors with −∞ parameters, dense tables with −∞ entries, factors of one's own
//! (which the plan leaves to the general path), few and many states (the plan's
//! unrolled loops cover 2 to 8 states), and variables of different cardinalities.

use pgm_core::{
    BpParams, Factor, FactorGraph, Flooding, Incoming, Messages, Mode, ParamGuard, PottsFactor,
    TableFactor, UpdateHook, VariableId,
};
use proptest::prelude::*;

mod common;

/// A hook that changes nothing: its presence alone turns the plan off.
struct Inert;
impl UpdateHook for Inert {}

/// A dense table without a message kernel, so the plan leaves it to the general path.
#[derive(Debug)]
struct Opaque(TableFactor);

impl Factor for Opaque {
    fn scope(&self) -> &[VariableId] {
        self.0.scope()
    }
    fn shape(&self) -> &[usize] {
        self.0.shape()
    }
    fn log_potential(&self, states: &[usize]) -> f64 {
        self.0.log_potential(states)
    }
    fn message(&self, target: usize, incoming: &Incoming<'_>, mode: Mode, out: &mut [f64]) {
        self.0.message(target, incoming, mode, out)
    }
}

/// What one pairwise factor of a generated graph is.
#[derive(Clone, Debug)]
enum PairKind {
    Potts { same: f64, different: f64 },
    Table,
    Opaque,
}

#[derive(Clone, Debug)]
struct Spec {
    cardinalities: Vec<usize>,
    /// (first, second, kind, seed of the table)
    pairs: Vec<(usize, usize, PairKind, u64)>,
    /// Variables with a unary table, and the table's seed.
    unaries: Vec<(usize, u64)>,
}

/// Deterministic log-values from a seed: mostly in [−2, 2], some −∞ when `zeros`.
fn values(seed: u64, n: usize, zeros: bool) -> Vec<f64> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            if zeros && state % 7 == 0 {
                f64::NEG_INFINITY
            } else {
                ((state >> 11) as f64 / (1u64 << 53) as f64) * 4.0 - 2.0
            }
        })
        .collect()
}

fn log_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -3.0f64..3.0,
        1 => Just(f64::NEG_INFINITY),
        1 => Just(0.0),
    ]
}

fn spec() -> impl Strategy<Value = Spec> {
    (2usize..9)
        .prop_flat_map(|n| {
            // Mostly one shared cardinality (so Potts factors apply), sometimes mixed;
            // 1 and 9 states are outside the plan's unrolled sizes.
            let shared = prop_oneof![Just(1usize), 2usize..=9];
            (
                shared,
                proptest::collection::vec(prop_oneof![3 => Just(0usize), 1 => 1usize..=9], n),
                proptest::collection::vec(
                    (
                        0..n,
                        0..n,
                        prop_oneof![
                            (log_value(), log_value())
                                .prop_map(|(same, different)| PairKind::Potts { same, different }),
                            Just(PairKind::Table),
                            Just(PairKind::Opaque),
                        ],
                        any::<u64>(),
                    ),
                    1..(3 * n),
                ),
                proptest::collection::vec((0..n, any::<u64>()), 0..(2 * n)),
            )
        })
        .prop_map(|(shared, own, pairs, unaries)| {
            let cardinalities = own
                .iter()
                .map(|&k| if k == 0 { shared } else { k })
                .collect();
            Spec {
                cardinalities,
                pairs: pairs.into_iter().filter(|(a, b, _, _)| a != b).collect(),
                unaries,
            }
        })
}

fn build(spec: &Spec) -> FactorGraph {
    let mut g = FactorGraph::with_variables(&spec.cardinalities).unwrap();
    let k = |v: usize| spec.cardinalities[v];
    for &(v, seed) in &spec.unaries {
        g.add_factor(
            TableFactor::new(vec![VariableId(v)], vec![k(v)], values(seed, k(v), true)).unwrap(),
        )
        .unwrap();
    }
    for (a, b, kind, seed) in &spec.pairs {
        let (a, b) = (*a, *b);
        let scope = vec![VariableId(a), VariableId(b)];
        let table = || {
            TableFactor::new(
                scope.clone(),
                vec![k(a), k(b)],
                values(*seed, k(a) * k(b), true),
            )
            .unwrap()
        };
        match kind {
            PairKind::Potts { same, different } if k(a) == k(b) => {
                g.add_factor(
                    PottsFactor::new(VariableId(a), VariableId(b), k(a), *same, *different)
                        .unwrap(),
                )
                .unwrap();
            }
            PairKind::Opaque => {
                g.add_factor(Opaque(table())).unwrap();
            }
            _ => {
                g.add_factor(table()).unwrap();
            }
        }
    }
    g
}

fn bits(m: &Messages) -> Vec<u64> {
    m.as_slice().iter().map(|x| x.to_bits()).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn plan_messages_equal_the_general_path(spec in spec(), damping in prop_oneof![Just(0.0), Just(0.3)]) {
        let graph = build(&spec);
        for mode in [Mode::MaxProduct, Mode::SumProduct] {
            let bp = BpParams::new(mode).damping(damping).tolerance(0.0).max_iterations(6).check_unwrap();
            for ((name, mut first), (_, mut second)) in common::schedules().into_iter().zip(common::schedules()) {
                let planned = bp.on(&graph).propagate(&mut first).unwrap();
                let mut copy = build(&spec);
                let general = bp.with_hook(&mut copy, &mut Inert).propagate(&mut second).unwrap();
                prop_assert_eq!(
                    bits(&planned.messages),
                    bits(&general.messages),
                    "{} {:?} damping {}", name, mode, damping
                );
                prop_assert_eq!(planned.iterations, general.iterations);
                prop_assert_eq!(planned.contradictions, general.contradictions);
                prop_assert_eq!(planned.residual.to_bits(), general.residual.to_bits());
            }
        }
    }
}

/// The plan on the grid the benchmarks run (5 states, Potts and dense tables, unary
/// tables): the same messages as the general path after 20 flooding iterations, so
/// the speed figures measure the same computation.
#[test]
fn grid_messages_are_bit_identical() {
    let n = 12;
    let k = 5;
    for dense in [false, true] {
        let mut g = FactorGraph::with_variables(&vec![k; n * n]).unwrap();
        for v in 0..n * n {
            g.add_factor(
                TableFactor::new(vec![VariableId(v)], vec![k], values(v as u64 + 1, k, false))
                    .unwrap(),
            )
            .unwrap();
        }
        let mut pair = |a: usize, b: usize| {
            if dense {
                let t = values((a * 1000 + b) as u64, k * k, false);
                g.add_factor(
                    TableFactor::new(vec![VariableId(a), VariableId(b)], vec![k, k], t).unwrap(),
                )
                .unwrap();
            } else {
                g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), k, 1.0, 0.0).unwrap())
                    .unwrap();
            }
        };
        for r in 0..n {
            for c in 0..n {
                if c + 1 < n {
                    pair(r * n + c, r * n + c + 1);
                }
                if r + 1 < n {
                    pair(r * n + c, (r + 1) * n + c);
                }
            }
        }
        let bp = BpParams::new(Mode::MaxProduct)
            .tolerance(0.0)
            .max_iterations(20)
            .check_unwrap();
        let planned = bp.on(&g).propagate(&mut Flooding).unwrap();
        let general = bp
            .with_hook(&mut g, &mut Inert)
            .propagate(&mut Flooding)
            .unwrap();
        assert_eq!(
            bits(&planned.messages),
            bits(&general.messages),
            "dense {dense}"
        );
        // The messages moved: the comparison is not between two untouched buffers.
        assert!(planned.messages.as_slice().iter().any(|&x| x != 0.0));
    }
}
