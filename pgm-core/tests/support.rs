//! Models with hard zeros: every inference says the same about the same model. A
//! model with no assignment of positive probability (`Z = 0`) is refused by
//! max-product under every schedule, by sum-product (its marginals cannot be
//! normalised) and by TRW-S, with [`Error::Infeasible`] and a proof; a model with one
//! is never refused and never gets an assignment of probability 0 (a loopy decoding
//! that violates a hard zero is replaced by a positive one, recorded in
//! `zero_decoding`). Checked on the hardening case `uai-infeasible-loop` (an odd cycle
//! with two colours, K4 with three, a feasible even cycle) built by hand, and on random
//! loopy models against brute force.

mod common;

use pgm_core::exact::{brute_force, BruteForceLimit};
use pgm_core::strategies;
use pgm_core::support::{
    first_violation, has_hard_zeros, positive_assignment, Method, Support, ZeroProbability,
    ZeroProof, DEFAULT_SEARCH_LIMIT,
};
use pgm_core::{
    BpParams, Error, FactorGraph, Flooding, Mode, ParamGuard, PottsFactor, Sequential, TableFactor,
    TrwsParams, VariableId,
};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};

const INF: f64 = f64::NEG_INFINITY;

/// Hard "not equal" tables with `k` colours on `edges`, as Potts factors or as dense
/// tables (the two message paths).
fn colouring(n: usize, k: usize, edges: &[(usize, usize)], dense: bool) -> FactorGraph {
    let mut g = FactorGraph::with_variables(&vec![k; n]).unwrap();
    for &(a, b) in edges {
        let (a, b) = (VariableId(a), VariableId(b));
        if dense {
            let table = (0..k * k)
                .map(|i| if i / k == i % k { INF } else { 0.0 })
                .collect();
            g.add_factor(TableFactor::new(vec![a, b], vec![k, k], table).unwrap())
                .unwrap();
        } else {
            g.add_factor(PottsFactor::new(a, b, k, INF, 0.0).unwrap())
                .unwrap();
        }
    }
    g
}

fn cycle(n: usize) -> Vec<(usize, usize)> {
    (0..n).map(|i| (i, (i + 1) % n)).collect()
}

fn complete(n: usize) -> Vec<(usize, usize)> {
    (0..n)
        .flat_map(|a| (a + 1..n).map(move |b| (a, b)))
        .collect()
}

/// The three models of the case, and variants of the same kinds.
fn infeasible_models() -> Vec<(String, FactorGraph)> {
    let kinds = [
        ("triangle, 2 colours", 3, 2, cycle(3)),
        ("K4, 3 colours", 4, 3, complete(4)),
        ("7-cycle, 2 colours", 7, 2, cycle(7)),
        ("K6, 5 colours", 6, 5, complete(6)),
    ];
    let mut out = Vec::new();
    for dense in [false, true] {
        for (name, n, k, edges) in &kinds {
            out.push((
                format!("{name}, dense {dense}"),
                colouring(*n, *k, edges, dense),
            ));
        }
    }
    out
}

/// Checks a refusal: a proof, the method, and a factor really violated by the
/// method's assignment.
fn check_refusal(graph: &FactorGraph, why: &ZeroProbability, method: Method, what: &str) {
    assert_eq!(why.method, method, "{what}");
    assert!(why.proof.is_some(), "{what}: no proof: {why}");
    let violated = why.violated.as_ref().expect("a violated factor");
    assert_eq!(
        first_violation(graph, &why.assignment).as_ref(),
        Some(violated)
    );
    let message = why.to_string();
    assert!(message.contains("Z = 0"), "{what}: {message}");
    assert!(
        message.contains(&format!("factor {}", violated.factor)),
        "{message}"
    );
}

#[test]
fn odd_cycles_and_k4_are_refused_by_every_method() {
    for (what, g) in infeasible_models() {
        for (name, mut schedule) in common::schedules() {
            for (mode, method) in [
                (Mode::MaxProduct, Method::MaxProduct),
                (Mode::SumProduct, Method::SumProduct),
            ] {
                let run = BpParams::new(mode)
                    .max_iterations(200)
                    .check_unwrap()
                    .run(&g, &mut schedule);
                match run {
                    Err(Error::Infeasible(why)) => {
                        check_refusal(&g, &why, method, &format!("{what}, {name}"));
                        if mode == Mode::SumProduct {
                            assert!(why.to_string().contains("cannot be normalised"));
                        }
                    }
                    Ok(r) => panic!("{what}, {name}, {mode:?}: returned {:?}", r.assignment),
                    Err(e) => panic!("{what}, {name}, {mode:?}: {e}"),
                }
            }
        }
        for decode_backward in [false, true] {
            let run = TrwsParams::default()
                .decode_backward(decode_backward)
                .check()
                .unwrap()
                .run(&g);
            let Err(Error::Infeasible(why)) = run else {
                panic!("{what}: TRW-S returned {run:?}");
            };
            check_refusal(&g, &why, Method::Trws, &what);
            // The relaxation is feasible on these loops: the proof is the search's.
            assert!(matches!(why.proof, Some(ZeroProof::Search { .. })), "{why}");
        }
    }
}

#[test]
fn the_even_cycle_succeeds_everywhere() {
    for dense in [false, true] {
        let g = colouring(6, 2, &cycle(6), dense);
        for (name, mut schedule) in common::schedules() {
            let map = BpParams::new(Mode::MaxProduct)
                .check_unwrap()
                .run(&g, &mut schedule)
                .unwrap();
            assert_eq!(map.log_score, 0.0, "{name}");
            assert_eq!(g.log_score(&map.assignment).unwrap(), 0.0);
            assert!(map.zero_decoding.is_none());
            let mar = BpParams::new(Mode::SumProduct)
                .check_unwrap()
                .run(&g, &mut schedule)
                .unwrap();
            assert!(!mar.support_undecided);
            for b in &mar.beliefs {
                assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                // Exactly two colourings, mirror images: every marginal is uniform.
                assert!(b.iter().all(|p| (p - 0.5).abs() < 1e-12), "{name}: {b:?}");
            }
        }
        let t = TrwsParams::default().check().unwrap().run(&g).unwrap();
        assert_eq!(t.log_score, 0.0);
        assert_eq!(t.bound, 0.0);
        assert!(t.zero_decoding.is_none());
    }
}

/// x0 = x1 = x2 = x3 (hard), x3 = 1 (hard), x0 prefers 0: one flooding iteration
/// has not carried x3's evidence to x0, so the decoding is [0, 0, 0, 0], of
/// probability 0; the model has one positive assignment, all ones.
#[test]
fn an_infeasible_decoding_of_a_feasible_model_is_replaced_and_recorded() {
    let mut g = FactorGraph::with_variables(&[2; 4]).unwrap();
    g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, -1.0]).unwrap())
        .unwrap();
    for v in 0..3 {
        g.add_factor(PottsFactor::new(VariableId(v), VariableId(v + 1), 2, 0.0, INF).unwrap())
            .unwrap();
    }
    g.add_factor(TableFactor::new(vec![VariableId(3)], vec![2], vec![INF, 0.0]).unwrap())
        .unwrap();
    let bp = BpParams::new(Mode::MaxProduct)
        .max_iterations(1)
        .check_unwrap();
    let raw = bp.finish(&g, bp.on(&g).propagate(&mut Flooding).unwrap());
    assert_eq!(raw.log_score, INF, "the premise: {:?}", raw.assignment);
    let r = bp.run(&g, &mut Flooding).unwrap();
    assert_eq!(r.assignment, vec![1, 1, 1, 1]);
    assert_eq!(r.log_score, -1.0);
    let zero = r.zero_decoding.expect("the refused decoding is recorded");
    assert_eq!(zero.assignment, raw.assignment);
    assert_eq!(first_violation(&g, &zero.assignment), Some(zero.violated));
    // Converged runs decode the optimum directly.
    let r = BpParams::new(Mode::MaxProduct)
        .check_unwrap()
        .run(&g, &mut Flooding)
        .unwrap();
    assert_eq!((r.assignment, r.zero_decoding), (vec![1, 1, 1, 1], None));
}

#[test]
fn a_search_limit_too_small_for_a_verdict_refuses_map_and_flags_marginals() {
    // K7 with 6 colours has no colouring, but proving it takes hundreds of dead ends.
    let g = colouring(7, 6, &complete(7), false);
    let run = BpParams::new(Mode::MaxProduct)
        .search_limit(5)
        .check_unwrap()
        .run(&g, &mut Sequential::default());
    let Err(Error::Infeasible(why)) = run else {
        panic!("{run:?}");
    };
    assert_eq!(why.proof, None);
    assert!(
        why.to_string().contains("gave up after 6 dead ends"),
        "{why}"
    );
    let r = BpParams::new(Mode::SumProduct)
        .search_limit(5)
        .check_unwrap()
        .run(&g, &mut Sequential::default())
        .unwrap();
    assert!(r.support_undecided);
    let run = TrwsParams::default()
        .search_limit(5)
        .check()
        .unwrap()
        .run(&g);
    assert!(matches!(run, Err(Error::Infeasible(ref why)) if why.proof.is_none()));
    // The default limit decides it.
    let run = BpParams::new(Mode::SumProduct)
        .check_unwrap()
        .run(&g, &mut Sequential::default());
    assert!(matches!(run, Err(Error::Infeasible(ref why)) if why.proof.is_some()));
}

/// A random loopy model: `n` variables with `k` states, a ring and random chords,
/// pairwise tables with many hard zeros (or hard colouring tables), soft unaries.
fn random_model(seed: u64) -> FactorGraph {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let n = rng.random_range(3..9);
    let k = rng.random_range(2..4);
    let mut g = FactorGraph::with_variables(&vec![k; n]).unwrap();
    let colouring = rng.random::<bool>();
    for a in 0..n {
        for b in a + 1..n {
            if b != a + 1 && !(a == 0 && b == n - 1) && rng.random::<f64>() > 0.35 {
                continue;
            }
            let table = (0..k * k)
                .map(|i| {
                    let hard = if colouring {
                        i / k == i % k
                    } else {
                        rng.random::<f64>() < 0.35
                    };
                    if hard {
                        INF
                    } else {
                        rng.random_range(-1.0..1.0)
                    }
                })
                .collect();
            g.add_factor(
                TableFactor::new(vec![VariableId(a), VariableId(b)], vec![k, k], table).unwrap(),
            )
            .unwrap();
        }
    }
    for v in 0..n {
        let table = (0..k).map(|_| rng.random_range(-1.0..1.0)).collect();
        g.add_factor(TableFactor::new(vec![VariableId(v)], vec![k], table).unwrap())
            .unwrap();
    }
    g
}

/// Every method on `g` against brute force: refused exactly when `Z = 0`; otherwise an
/// assignment of positive probability no better than the optimum. Returns how many
/// results were fallbacks for a zero-probability decoding (BP, TRW-S).
fn check_against_brute_force(g: &FactorGraph, what: &str) -> (usize, usize) {
    let optimum = brute_force(g, BruteForceLimit(1 << 16))
        .ok()
        .map(|e| e.map_log_score);
    let mut fallbacks = (0, 0);
    for iterations in [1, 300] {
        for (name, mut schedule) in common::schedules() {
            for mode in [Mode::MaxProduct, Mode::SumProduct] {
                let run = BpParams::new(mode)
                    .max_iterations(iterations)
                    .check_unwrap()
                    .run(g, &mut schedule);
                match (run, optimum) {
                    (Ok(r), Some(best)) => {
                        if mode == Mode::MaxProduct {
                            assert!(r.log_score.is_finite() && r.log_score <= best + 1e-9);
                            assert_eq!(r.log_score, g.log_score(&r.assignment).unwrap());
                            fallbacks.0 += usize::from(r.zero_decoding.is_some());
                        }
                        assert!(!r.support_undecided);
                    }
                    (Err(Error::Infeasible(why)), None) => {
                        assert!(why.proof.is_some(), "{what}: {why}");
                    }
                    (run, _) => panic!(
                        "{what}, {name}, {mode:?}, {iterations} iterations, optimum {optimum:?}: {:?}",
                        run.map(|r| r.assignment)
                    ),
                }
            }
        }
        let run = TrwsParams::default()
            .max_iterations(iterations)
            .check()
            .unwrap()
            .run(g);
        match (run, optimum) {
            (Ok(t), Some(best)) => {
                assert!(t.log_score.is_finite() && t.log_score <= best + 1e-9);
                assert!(t.bound >= best - 1e-9 && t.gap >= 0.0);
                if let Some(zero) = &t.zero_decoding {
                    assert_eq!(
                        first_violation(g, &zero.assignment).as_ref(),
                        Some(&zero.violated)
                    );
                    fallbacks.1 += 1;
                }
            }
            (Err(Error::Infeasible(why)), None) => assert!(why.proof.is_some(), "{what}: {why}"),
            (run, _) => panic!("{what}, TRW-S, optimum {optimum:?}: {run:?}"),
        }
    }
    fallbacks
}

#[test]
fn random_loopy_models_are_refused_exactly_when_z_is_zero() {
    let (mut bp, mut trws, mut infeasible) = (0, 0, 0);
    for seed in 0..600 {
        let g = random_model(seed);
        infeasible += usize::from(brute_force(&g, BruteForceLimit(1 << 16)).is_err());
        let (b, t) = check_against_brute_force(&g, &format!("seed {seed}"));
        bp += b;
        trws += t;
    }
    // The sample holds every case: models without positive assignments, and feasible
    // models whose BP and TRW-S decodings hit a hard zero.
    assert!(infeasible > 20, "{infeasible} infeasible models");
    assert!(bp > 0 && trws > 0, "fallbacks: BP {bp}, TRW-S {trws}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn refused_exactly_when_no_assignment_is_positive(
        spec in strategies::enumerable(strategies::loopy(7, 3, 4, 5.0, 0.4), 1 << 16)
    ) {
        check_against_brute_force(&spec.build(), &format!("{spec:?}"));
    }
}

// ---------------------------------------------------------------------------------
// The search for an assignment of positive probability

#[test]
fn odd_cycles_and_complete_graphs_have_no_colouring_even_cycles_do() {
    for n in [3, 5, 7, 21] {
        let g = colouring(n, 2, &cycle(n), false);
        assert!(
            matches!(
                positive_assignment(&g, None, DEFAULT_SEARCH_LIMIT),
                Support::Empty(ZeroProof::Search { .. })
            ),
            "odd cycle {n}"
        );
        let g = colouring(n + 1, 2, &cycle(n + 1), false);
        let Support::Positive(x) = positive_assignment(&g, None, DEFAULT_SEARCH_LIMIT) else {
            panic!("even cycle {} has a colouring", n + 1);
        };
        assert!(g.log_score(&x).unwrap().is_finite());
        assert_eq!(first_violation(&g, &x), None);
    }
    for n in 3..8 {
        let g = colouring(n, n - 1, &complete(n), false);
        assert!(matches!(
            positive_assignment(&g, None, DEFAULT_SEARCH_LIMIT),
            Support::Empty(ZeroProof::Search { .. })
        ));
        let g = colouring(n, n, &complete(n), false);
        assert!(matches!(
            positive_assignment(&g, None, DEFAULT_SEARCH_LIMIT),
            Support::Positive(_)
        ));
    }
}

/// Verdicts of the search that name their proof or count: a long feasible even cycle
/// (many choices before it) and then a triangle, whose triangle alone is proved
/// infeasible without backtracking into the cycle; K7 with 6 colours, where a small
/// limit gives no verdict; a constant zero, a proof without branching.
#[test]
fn search_verdicts_and_their_dead_ends() {
    let mut edges = cycle(40);
    edges.extend([(40, 41), (41, 42), (40, 42)]);
    let mut constant_zero = FactorGraph::with_variables(&[2]).unwrap();
    constant_zero
        .add_factor(TableFactor::new(vec![], vec![], vec![INF]).unwrap())
        .unwrap();
    let cases = [
        (
            colouring(43, 2, &edges, false),
            10,
            Support::Empty(ZeroProof::Search { dead_ends: 2 }),
        ),
        (
            colouring(7, 6, &complete(7), false),
            3,
            Support::Undecided { dead_ends: 4 },
        ),
        (
            constant_zero,
            0,
            Support::Empty(ZeroProof::ConstantZero { factor: 0 }),
        ),
    ];
    for (g, limit, verdict) in cases {
        assert_eq!(positive_assignment(&g, None, limit), verdict);
    }
}

#[test]
fn propagation_is_a_proof_without_branching() {
    // x0 = x1 (hard), x0 forced to 0, x1 forced to 1.
    let mut g = FactorGraph::with_variables(&[2, 2]).unwrap();
    g.add_factor(PottsFactor::new(VariableId(0), VariableId(1), 2, 0.0, INF).unwrap())
        .unwrap();
    g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, INF]).unwrap())
        .unwrap();
    g.add_factor(TableFactor::new(vec![VariableId(1)], vec![2], vec![INF, 0.0]).unwrap())
        .unwrap();
    assert!(matches!(
        positive_assignment(&g, None, 0),
        Support::Empty(ZeroProof::Propagation { .. })
    ));
}

#[test]
fn preferences_order_the_states_and_no_hard_zeros_needs_no_search() {
    let g = colouring(4, 2, &cycle(4), false);
    let prefer_one = |v: VariableId| {
        if v.0 == 0 {
            vec![0.0, 1.0]
        } else {
            vec![0.0, 0.0]
        }
    };
    assert_eq!(
        positive_assignment(&g, Some(&prefer_one), 0),
        Support::Positive(vec![1, 0, 1, 0])
    );
    let mut g = FactorGraph::with_variables(&[3, 3]).unwrap();
    g.add_factor(PottsFactor::new(VariableId(0), VariableId(1), 3, 1.0, 0.0).unwrap())
        .unwrap();
    assert!(!has_hard_zeros(&g));
    let prefer = |v: VariableId| vec![0.0, v.0 as f64, 0.5];
    assert_eq!(
        positive_assignment(&g, Some(&prefer), 0),
        Support::Positive(vec![2, 1])
    );
}

#[test]
fn higher_arity_tables_are_revised_exactly() {
    // x0 + x1 + x2 must be odd (a parity table), and x0 = x1 = x2 (hard): only
    // (1, 1, 1).
    let mut g = FactorGraph::with_variables(&[2, 2, 2]).unwrap();
    let parity = (0..8)
        .map(|i: usize| if i.count_ones() % 2 == 1 { 0.0 } else { INF })
        .collect();
    g.add_factor(
        TableFactor::new(
            vec![VariableId(0), VariableId(1), VariableId(2)],
            vec![2, 2, 2],
            parity,
        )
        .unwrap(),
    )
    .unwrap();
    for (a, b) in [(0, 1), (1, 2)] {
        g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 2, 0.0, INF).unwrap())
            .unwrap();
    }
    assert_eq!(
        positive_assignment(&g, None, 10),
        Support::Positive(vec![1, 1, 1])
    );
    // Now also x0 = 0: none.
    g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, INF]).unwrap())
        .unwrap();
    assert!(matches!(
        positive_assignment(&g, None, 10),
        Support::Empty(_)
    ));
}
