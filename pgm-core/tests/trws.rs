//! TRW-S against the exact references: exact on chains and trees; on random loopy
//! models its bound is an upper bound on the optimum that never increases, and its
//! assignment never scores above the bound.

mod common;

use pgm_core::exact::{brute_force, BruteForceLimit};
use pgm_core::observer::{History, TrwsProgress};
use pgm_core::strategies::{self, GraphSpec};
use pgm_core::support::{Method, ZeroProof};
use pgm_core::trws::{TrwsParams, TrwsTermination};
use pgm_core::{Error, FactorGraph, ParamGuard, PottsFactor, TableFactor, VariableId};
use proptest::prelude::*;
use std::ops::ControlFlow;

const MAX_STATES: u64 = 1 << 16;

/// Rounding slack for comparing sums of log-potentials of magnitude `scale`.
fn slack(scale: f64) -> f64 {
    1e-9 * (1.0 + scale.abs())
}

/// `a ≤ b` up to rounding (exact for infinite values).
fn at_most(a: f64, b: f64) -> bool {
    a <= b || (b.is_finite() && a <= b + slack(b))
}

/// Runs `check` with the backward pass decoding off and on.
fn for_both_decodings(
    spec: &GraphSpec,
    check: fn(&GraphSpec, bool) -> Result<(), TestCaseError>,
) -> Result<(), TestCaseError> {
    for decode_backward in [false, true] {
        check(spec, decode_backward)?;
    }
    Ok(())
}

fn check_exact(spec: &GraphSpec, decode_backward: bool) -> Result<(), TestCaseError> {
    let graph = spec.build();
    let Ok(exact) = brute_force(&graph, BruteForceLimit(MAX_STATES)) else {
        return Ok(());
    };
    let result = TrwsParams::default()
        .max_iterations(500)
        .tolerance(1e-12)
        .decode_backward(decode_backward)
        .check()
        .unwrap()
        .run(&graph)
        .unwrap();
    let optimum = exact.map_log_score;
    prop_assert!(
        (result.log_score - optimum).abs() <= slack(optimum),
        "score {} vs optimum {optimum} ({:?}, {} iterations)",
        result.log_score,
        result.termination,
        result.iterations
    );
    prop_assert!(
        (result.bound - optimum).abs() <= slack(optimum),
        "bound {} vs optimum {optimum} ({:?}, {} iterations)",
        result.bound,
        result.termination,
        result.iterations
    );
    prop_assert!(result.converged);
    Ok(())
}

fn check_bound(spec: &GraphSpec, decode_backward: bool) -> Result<(), TestCaseError> {
    let graph = spec.build();
    let mut history = History::<TrwsProgress>::default();
    let run = TrwsParams::default()
        .max_iterations(40)
        .tolerance(0.0)
        .decode_backward(decode_backward)
        .check()
        .unwrap()
        .run_observed(&graph, &mut history);
    let result = match run {
        Ok(result) => result,
        Err(Error::Infeasible(why)) => {
            // Refused only with a proof that no assignment has positive probability
            // (these models are far too small for the search to give up).
            prop_assert!(why.proof.is_some(), "{why}");
            prop_assert!(
                brute_force(&graph, BruteForceLimit(MAX_STATES)).is_err(),
                "refused a model with positive assignments: {why}"
            );
            return Ok(());
        }
        Err(e) => panic!("{e}"),
    };
    // A returned assignment always has positive probability.
    prop_assert!(result.log_score.is_finite(), "{result:?}");
    prop_assert_eq!(history.0.len(), result.iterations);
    prop_assert!(
        at_most(result.log_score, result.bound),
        "score {} above bound {}",
        result.log_score,
        result.bound
    );
    prop_assert_eq!(
        result.log_score,
        graph.log_score(&result.assignment).unwrap()
    );
    for pair in history.0.windows(2) {
        prop_assert!(
            at_most(pair[1].bound, pair[0].bound),
            "bound rose from {} to {} at iteration {}",
            pair[0].bound,
            pair[1].bound,
            pair[1].iteration
        );
    }
    for p in &history.0 {
        prop_assert!(at_most(p.iteration_log_score, p.bound));
        prop_assert!(at_most(p.log_score, p.bound));
    }
    if let Ok(exact) = brute_force(&graph, BruteForceLimit(MAX_STATES)) {
        let optimum = exact.map_log_score;
        prop_assert!(at_most(result.log_score, optimum));
        for p in &history.0 {
            prop_assert!(
                at_most(optimum, p.bound),
                "bound {} below the optimum {optimum} at iteration {}",
                p.bound,
                p.iteration
            );
        }
        if result.termination == TrwsTermination::GapClosed {
            prop_assert!((result.log_score - optimum).abs() <= slack(optimum));
        }
    } else {
        prop_assert!(
            false,
            "an assignment of positive probability on a model without one"
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(common::persisted(200, "proptest-regressions/trws.txt"))]

    #[test]
    fn trws_is_exact_on_chains(spec in strategies::enumerable(strategies::chain(12, 4, 20.0, 0.1), MAX_STATES)) {
        for_both_decodings(&spec, check_exact)?;
    }

    #[test]
    fn trws_is_exact_on_trees(spec in strategies::enumerable(strategies::tree(12, 4, 20.0, 0.1), MAX_STATES)) {
        for_both_decodings(&spec, check_exact)?;
    }

    #[test]
    fn trws_bound_holds_on_loopy_graphs(spec in strategies::enumerable(strategies::loopy(9, 3, 5, 10.0, 0.1), MAX_STATES)) {
        for_both_decodings(&spec, check_bound)?;
    }

    #[test]
    fn trws_bound_holds_on_potts_grids(spec in strategies::enumerable(strategies::potts_grid(4, 3, 3.0), MAX_STATES)) {
        for_both_decodings(&spec, check_bound)?;
    }
}

#[test]
fn contradictory_evidence_is_refused_by_the_infinite_negative_bound() {
    let mut g = FactorGraph::with_variables(&[2, 2]).unwrap();
    let inf = f64::NEG_INFINITY;
    g.add_factor(TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, inf]).unwrap())
        .unwrap();
    g.add_factor(TableFactor::new(vec![VariableId(1)], vec![2], vec![0.0, inf]).unwrap())
        .unwrap();
    // The pair may not agree, but both are forced to state 0.
    g.add_factor(PottsFactor::new(VariableId(0), VariableId(1), 2, inf, 0.0).unwrap())
        .unwrap();
    let Err(Error::Infeasible(why)) = TrwsParams::default().check().unwrap().run(&g) else {
        panic!("TRW-S returned an assignment of probability 0");
    };
    assert_eq!(why.proof, Some(ZeroProof::DualBound));
    assert_eq!(why.method, Method::Trws);
    assert!(why.violated.is_some());
}

/// A 6x6 grid with three labels, deterministic pseudo-random unaries and couplings
/// of both signs (frustrated): TRW-S needs many iterations on it.
fn frustrated_grid() -> FactorGraph {
    let side = 6;
    let mut g = FactorGraph::with_variables(&[3; 36]).unwrap();
    let value = |i: usize| ((i as f64 * 12.9898).sin() * 43758.5453).fract();
    for v in 0..side * side {
        let t = (0..3).map(|x| value(3 * v + x)).collect();
        g.add_factor(TableFactor::new(vec![VariableId(v)], vec![3], t).unwrap())
            .unwrap();
    }
    let mut pair = 0;
    for r in 0..side {
        for c in 0..side {
            let v = r * side + c;
            let mut neighbours = Vec::new();
            if c + 1 < side {
                neighbours.push(v + 1);
            }
            if r + 1 < side {
                neighbours.push(v + side);
            }
            for u in neighbours {
                pair += 1;
                let w = value(1000 + pair);
                g.add_factor(PottsFactor::new(VariableId(v), VariableId(u), 3, w, 0.0).unwrap())
                    .unwrap();
            }
        }
    }
    g
}

#[test]
fn observer_sees_every_iteration_and_can_stop() {
    let g = frustrated_grid();
    let trws = TrwsParams::default()
        .tolerance(0.0)
        .max_iterations(30)
        .check()
        .unwrap();
    let free = trws.run(&g).unwrap();
    assert!(
        free.iterations > 2,
        "{:?} after {}",
        free.termination,
        free.iterations
    );
    let mut seen = Vec::new();
    let mut stop_at_two = |p: &TrwsProgress| {
        seen.push(*p);
        if p.iteration == 2 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    };
    let r = trws.run_observed(&g, &mut stop_at_two).unwrap();
    assert_eq!(r.iterations, 2);
    assert_eq!(r.termination, TrwsTermination::Observer);
    assert!(!r.converged);
    assert_eq!(seen.len(), 2);
    assert!(seen.iter().all(|p| p.gap >= 0.0 && p.bound >= p.log_score));
    assert!((seen[1].log_score - r.log_score).abs() <= 1e-9 * (1.0 + r.log_score.abs()));
}

#[test]
fn bad_settings_and_orders_are_errors() {
    let err = TrwsParams::default().max_iterations(0).check().unwrap_err();
    assert!(err.to_string().contains("max_iterations = 0"), "{err}");
    let err = TrwsParams::default()
        .tolerance(f64::NAN)
        .check()
        .unwrap_err();
    assert!(err.to_string().contains("tolerance = NaN"), "{err}");
    let g = FactorGraph::with_variables(&[2, 2, 2]).unwrap();
    for order in [vec![0, 1], vec![0, 1, 1], vec![0, 1, 3]] {
        let order = order.into_iter().map(VariableId).collect();
        let err = TrwsParams::default()
            .order(order)
            .check()
            .unwrap()
            .run(&g)
            .unwrap_err();
        assert!(err.to_string().contains("TRW-S order"), "{err}");
    }
}

#[test]
fn any_order_gives_a_valid_bound() {
    // A 3x3 frustrated grid visited in a scrambled order.
    let mut g = FactorGraph::with_variables(&[2; 9]).unwrap();
    for v in 0..9 {
        g.add_factor(
            TableFactor::new(vec![VariableId(v)], vec![2], vec![0.1 * v as f64, 0.2]).unwrap(),
        )
        .unwrap();
    }
    for (a, b) in [
        (0, 1),
        (1, 2),
        (3, 4),
        (4, 5),
        (6, 7),
        (7, 8),
        (0, 3),
        (3, 6),
        (1, 4),
        (4, 7),
        (2, 5),
        (5, 8),
    ] {
        g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 2, 0.0, 1.0).unwrap())
            .unwrap();
    }
    let exact = brute_force(&g, BruteForceLimit::default()).unwrap();
    let order = [4, 0, 8, 2, 6, 1, 7, 3, 5]
        .into_iter()
        .map(VariableId)
        .collect();
    let r = TrwsParams::default()
        .order(order)
        .check()
        .unwrap()
        .run(&g)
        .unwrap();
    assert!(r.bound >= exact.map_log_score - 1e-9);
    assert!(r.log_score <= exact.map_log_score + 1e-9);
    assert!(r.gap >= 0.0);
}
