//! Property tests of the inference engine against the exact references.

mod common;

use pgm_core::exact::{brute_force, forward_backward, tree_marginals, viterbi, BruteForceLimit};
use pgm_core::strategies::{self, GraphSpec};
use pgm_core::uai::UaiModel;
use pgm_core::{
    BpParams, Error, Factor, FactorGraph, Flooding, Incoming, Mode, ParamGuard, PottsFactor,
    Schedule, Sequential, ShiftedIdentityFactor, TableFactor, VariableId,
};
use proptest::prelude::*;

const MAX_STATES: u64 = 1 << 17;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a == b) || (a - b).abs() <= tol * (1.0 + b.abs())
}

/// Compares two ways `a` and `b` of computing the messages of a pairwise factor whose
/// first variable receives `q0` and second `q1`: under both modes, towards both
/// variables, they agree to 1e-12. Failures start with `what`.
fn check_pairwise_messages(
    q0: &[f64],
    q1: &[f64],
    what: &str,
    a: impl Fn(usize, &Incoming<'_>, Mode, &mut [f64]),
    b: impl Fn(usize, &Incoming<'_>, Mode, &mut [f64]),
) -> Result<(), TestCaseError> {
    let (k0, k1) = (q0.len(), q1.len());
    let mut values = q0.to_vec();
    values.extend_from_slice(q1);
    let offsets = [0, k0, k0 + k1];
    let incoming = Incoming::new(&values, &offsets);
    for mode in [Mode::MaxProduct, Mode::SumProduct] {
        for (target, k) in [(0usize, k0), (1, k1)] {
            let mut x = vec![0.0; k];
            let mut y = vec![0.0; k];
            a(target, &incoming, mode, &mut x);
            b(target, &incoming, mode, &mut y);
            for (p, q) in x.iter().zip(&y) {
                prop_assert!(
                    close(*p, *q, 1e-12),
                    "{what}{mode:?} target {target}: {x:?} vs {y:?}"
                );
            }
        }
    }
    Ok(())
}

/// Checks max-product and sum-product on a tree-structured graph with every schedule.
fn check_exact_on_tree(spec: &GraphSpec) -> Result<(), TestCaseError> {
    let graph = spec.build();
    let Ok(exact) = brute_force(&graph, BruteForceLimit(MAX_STATES)) else {
        // Every assignment has probability zero: nothing to compare.
        return Ok(());
    };
    // A run of `mode` with at most `iterations` iterations.
    let run = |mode, iterations, schedule: &mut dyn Schedule| {
        BpParams::new(mode)
            .max_iterations(iterations)
            .check_unwrap()
            .run(&graph, schedule)
            .unwrap()
    };
    // The default sequential schedule (two-pass edge order) is exact after one iteration.
    let one = run(Mode::SumProduct, 1, &mut Sequential::default());
    for (b, e) in one.beliefs.iter().zip(&exact.marginals) {
        for (p, q) in b.iter().zip(e) {
            prop_assert!(
                (p - q).abs() <= 1e-9,
                "one two-pass iteration: {p} vs exact {q}"
            );
        }
    }
    let one = run(Mode::MaxProduct, 1, &mut Sequential::default());
    prop_assert!(close(one.log_score, exact.map_log_score, 1e-9));
    let mut first_marginals: Option<Vec<Vec<f64>>> = None;
    for (name, mut schedule) in common::schedules() {
        let map = run(Mode::MaxProduct, 200, &mut schedule);
        prop_assert!(
            map.converged,
            "{name}: max-product did not converge ({} iterations)",
            map.iterations
        );
        prop_assert!(
            close(map.log_score, exact.map_log_score, 1e-9),
            "{name}: MAP score {} vs exact {}",
            map.log_score,
            exact.map_log_score
        );
        let mar = run(Mode::SumProduct, 200, &mut schedule);
        prop_assert!(mar.converged, "{name}: sum-product did not converge");
        for (v, (b, e)) in mar.beliefs.iter().zip(&exact.marginals).enumerate() {
            for (x, (p, q)) in b.iter().zip(e).enumerate() {
                prop_assert!(
                    (p - q).abs() <= 1e-9,
                    "{name}: P(x{v} = {x}) = {p}, exact {q}"
                );
            }
        }
        match &first_marginals {
            None => first_marginals = Some(mar.beliefs.clone()),
            Some(m) => {
                for (b, c) in mar.beliefs.iter().zip(m) {
                    for (p, q) in b.iter().zip(c) {
                        prop_assert!((p - q).abs() <= 1e-9, "{name} disagrees with flooding");
                    }
                }
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(common::persisted(200, "proptest-regressions/inference.txt"))]

    #[test]
    fn bp_is_exact_on_random_trees(spec in strategies::enumerable(strategies::tree(12, 4, 50.0, 0.1), MAX_STATES)) {
        check_exact_on_tree(&spec)?;
    }

    #[test]
    fn bp_is_exact_on_random_chains(spec in strategies::enumerable(strategies::chain(12, 4, 50.0, 0.1), MAX_STATES)) {
        check_exact_on_tree(&spec)?;
    }

    /// Log-potentials in {−1, 0, 1} (and −∞) make many assignments tie for the MAP;
    /// consistent decoding must still return one of them on trees.
    #[test]
    fn decoding_is_exact_on_trees_with_ties(spec in strategies::enumerable(strategies::tree(10, 3, 1.0, 0.1), MAX_STATES)) {
        let mut spec = spec;
        for f in &mut spec.factors {
            if let strategies::FactorSpec::Table { log_table, .. } = f {
                log_table.iter_mut().for_each(|x| if x.is_finite() { *x = x.round() });
            }
        }
        let graph = spec.build();
        let Ok(exact) = brute_force(&graph, BruteForceLimit(MAX_STATES)) else { return Ok(()); };
        for (name, mut schedule) in common::schedules() {
            let r = BpParams::new(Mode::MaxProduct).max_iterations(200).check_unwrap().run(&graph, &mut schedule).unwrap();
            prop_assert!(close(r.log_score, exact.map_log_score, 1e-12), "{name}: {} vs {}", r.log_score, exact.map_log_score);
        }
    }

    #[test]
    fn exact_references_agree(spec in strategies::tree(9, 3, 20.0, 0.1)) {
        let graph = spec.build();
        let Ok(bf) = brute_force(&graph, BruteForceLimit(MAX_STATES)) else { return Ok(()); };
        let tree = tree_marginals(&graph).unwrap();
        prop_assert!(close(tree.map_log_score, bf.map_log_score, 1e-9));
        prop_assert!(close(tree.log_partition, bf.log_partition, 1e-9));
        for (a, b) in tree.marginals.iter().zip(&bf.marginals) {
            for (p, q) in a.iter().zip(b) {
                prop_assert!((p - q).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn chain_references_agree(spec in strategies::enumerable(strategies::chain(10, 4, 20.0, 0.1), MAX_STATES)) {
        let graph = spec.build();
        let Ok(bf) = brute_force(&graph, BruteForceLimit(MAX_STATES)) else { return Ok(()); };
        let (_, score) = viterbi(&graph).unwrap();
        prop_assert!(close(score, bf.map_log_score, 1e-9));
        let fb = forward_backward(&graph).unwrap();
        prop_assert!(close(fb.log_partition, bf.log_partition, 1e-9));
        for (a, b) in fb.marginals.iter().zip(&bf.marginals) {
            for (p, q) in a.iter().zip(b) {
                prop_assert!((p - q).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn loopy_beliefs_are_finite_and_normalised(
        spec in strategies::loopy(10, 4, 6, 1e6, 0.1),
        damping in prop_oneof![Just(0.0), Just(0.5), Just(0.9)],
    ) {
        let graph = spec.build();
        for mode in [Mode::MaxProduct, Mode::SumProduct] {
            for (name, mut schedule) in common::schedules() {
                // Unchecked decoding: the numbers of every run, feasible or not (`run`
                // refuses models without positive assignments, tested below).
                let bp = BpParams::new(mode).damping(damping).max_iterations(30).check_unwrap();
                let p = bp.on(&graph).propagate(&mut schedule).unwrap();
                let r = bp.finish(&graph, p);
                prop_assert!(!r.residual.is_nan(), "{name}: NaN residual");
                for (v, b) in r.beliefs.iter().enumerate() {
                    let sum: f64 = b.iter().sum();
                    prop_assert!(b.iter().all(|p| p.is_finite() && *p >= 0.0), "{name} {mode:?}: belief of x{v} = {b:?}");
                    prop_assert!((sum - 1.0).abs() < 1e-9, "{name} {mode:?}: belief of x{v} sums to {sum}");
                }
                prop_assert!(r.messages.as_slice().iter().all(|m| !m.is_nan()));
                prop_assert!(r.assignment.iter().zip(graph.cardinalities()).all(|(x, k)| x < k));
            }
        }
    }

    #[test]
    fn potts_grids_give_normalised_beliefs(spec in strategies::potts_grid(5, 4, 5.0)) {
        let graph = spec.build();
        for (_, mut schedule) in common::schedules() {
            let r = BpParams::new(Mode::SumProduct).damping(0.3).max_iterations(50).check_unwrap()
                .run(&graph, &mut schedule).unwrap();
            for b in &r.beliefs {
                prop_assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-9);
            }
        }
    }

    /// Dyadic log-potentials keep max-product arithmetic exact, so adding a constant to
    /// a table must leave every max-product message and decision bit-for-bit unchanged;
    /// sum-product beliefs agree to rounding.
    #[test]
    fn constant_shift_changes_nothing(
        spec in strategies::loopy(8, 3, 3, 8.0, 0.1),
        which in any::<prop::sample::Index>(),
        shift in -16i32..16,
    ) {
        let round = |x: f64| if x.is_finite() { (x * 4.0).round() / 4.0 } else { x };
        let mut spec = spec;
        for f in &mut spec.factors {
            if let strategies::FactorSpec::Table { log_table, .. } = f {
                log_table.iter_mut().for_each(|x| *x = round(*x));
            }
        }
        let base = spec.build();
        let mut shifted_spec = spec.clone();
        let k = which.index(shifted_spec.factors.len());
        if let strategies::FactorSpec::Table { log_table, .. } = &mut shifted_spec.factors[k] {
            log_table.iter_mut().for_each(|x| *x += shift as f64);
        }
        let shifted = shifted_spec.build();
        for (name, mut schedule) in common::schedules() {
            let bp = BpParams::new(Mode::MaxProduct).max_iterations(20).check_unwrap();
            // A shift keeps the hard zeros: both runs are refused or neither is.
            let (a, b) = match (bp.run(&base, &mut schedule), bp.run(&shifted, &mut schedule)) {
                (Ok(a), Ok(b)) => (a, b),
                (Err(Error::Infeasible(x)), Err(Error::Infeasible(y))) => {
                    prop_assert_eq!(&x.proof, &y.proof);
                    continue;
                }
                (a, b) => {
                    prop_assert!(false, "{name}: {:?} vs {:?}", a.map(|r| r.log_score), b.map(|r| r.log_score));
                    unreachable!()
                }
            };
            prop_assert_eq!(&a.assignment, &b.assignment, "{}", name);
            prop_assert_eq!(a.messages.as_slice(), b.messages.as_slice());
            // log-sum-exp rounds differently after a shift, so sum-product agrees to
            // rounding only; residual BP orders its updates by those rounded residuals,
            // so on a loopy graph that has not converged it may take another path, and
            // only the fixed-order schedules are compared for sum-product.
            if name == "residual" {
                continue;
            }
            let sp = BpParams::new(Mode::SumProduct).max_iterations(20).check_unwrap();
            // The max-product runs were not refused: the model has positive assignments.
            let a = sp.run(&base, &mut schedule).unwrap();
            let b = sp.run(&shifted, &mut schedule).unwrap();
            for (x, y) in a.beliefs.iter().flatten().zip(b.beliefs.iter().flatten()) {
                prop_assert!((x - y).abs() < 1e-9, "{name}: {x} vs {y}");
            }
        }
    }

    #[test]
    fn uai_write_then_read_is_identity(spec in strategies::loopy(8, 4, 4, 30.0, 0.1)) {
        let model = UaiModel::from_factor_graph(&spec.build());
        let text = model.to_uai_string();
        let back = UaiModel::parse_str("roundtrip.uai", &text).unwrap();
        prop_assert_eq!(&back, &model);
        prop_assert_eq!(back.to_uai_string(), text);
    }

    /// The O(K) structured factors send exactly the messages of their dense tables.
    #[test]
    fn structured_factors_match_dense_tables(
        k0 in prop_oneof![1usize..7, 14usize..40], k1 in prop_oneof![1usize..7, 14usize..40], shift in -3isize..4,
        on in strategies::log_potential(30.0, 0.2), off in strategies::log_potential(30.0, 0.2),
        q0 in proptest::collection::vec(strategies::log_potential(30.0, 0.2), 40),
        q1 in proptest::collection::vec(strategies::log_potential(30.0, 0.2), 40),
    ) {
        let (a, b) = (VariableId(0), VariableId(1));
        let shifted = ShiftedIdentityFactor::new(a, b, k0, k1, shift, on, off).unwrap();
        let potts = PottsFactor::new(a, b, k0, on, off).unwrap();
        let dense_shifted = TableFactor::new(vec![a, b], vec![k0, k1], shifted.log_table()).unwrap();
        let dense_potts = TableFactor::new(vec![a, b], vec![k0, k0], potts.log_table()).unwrap();
        for (structured, dense, k1) in [
            (&shifted as &dyn Factor, &dense_shifted, k1),
            (&potts as &dyn Factor, &dense_potts, k0),
        ] {
            check_pairwise_messages(
                &q0[..k0],
                &q1[..k1],
                &format!("{} ", structured.kind()),
                |target, incoming, mode, out| structured.message(target, incoming, mode, out),
                |target, incoming, mode, out| dense.message(target, incoming, mode, out),
            )?;
        }
    }
}

#[test]
fn warm_start_from_converged_messages_converges_at_once() {
    let mut g = FactorGraph::with_variables(&[3; 6]).unwrap();
    for v in 0..6 {
        g.add_factor(
            TableFactor::new(
                vec![VariableId(v)],
                vec![3],
                vec![0.1 * v as f64, 0.0, -0.2],
            )
            .unwrap(),
        )
        .unwrap();
    }
    for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (5, 0)] {
        g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 3, 0.7, 0.0).unwrap())
            .unwrap();
    }
    let bp = BpParams::new(Mode::SumProduct)
        .tolerance(1e-12)
        .max_iterations(500)
        .check_unwrap();
    let first = bp.run(&g, &mut Flooding).unwrap();
    assert!(first.converged && first.iterations > 2);
    let second = bp
        .on(&g)
        .warm_start(first.messages.clone())
        .run(&mut Flooding)
        .unwrap();
    assert!(second.converged);
    assert_eq!(second.iterations, 1);
}

#[test]
fn ties_decode_to_one_consistent_map() {
    // Two equally good labellings of a repulsive chain: independent argmaxes of the
    // max-marginals would mix them; consistent decoding must pick one.
    let mut g = FactorGraph::with_variables(&[2; 5]).unwrap();
    for v in 0..4 {
        g.add_factor(PottsFactor::new(VariableId(v), VariableId(v + 1), 2, 0.0, 1.0).unwrap())
            .unwrap();
    }
    for (_, mut s) in common::schedules() {
        let r = BpParams::new(Mode::MaxProduct)
            .check_unwrap()
            .run(&g, &mut s)
            .unwrap();
        assert_eq!(r.log_score, 4.0, "{:?}", r.assignment);
        assert_eq!(r.assignment, vec![0, 1, 0, 1, 0]);
    }
}

#[test]
fn damping_slows_but_does_not_fake_convergence() {
    let mut g = FactorGraph::with_variables(&[2; 4]).unwrap();
    for v in 0..4 {
        g.add_factor(
            TableFactor::new(vec![VariableId(v)], vec![2], vec![0.3, -0.1 * v as f64]).unwrap(),
        )
        .unwrap();
    }
    for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 0)] {
        g.add_factor(PottsFactor::new(VariableId(a), VariableId(b), 2, 0.4, 0.0).unwrap())
            .unwrap();
    }
    let tol = 1e-10;
    let undamped = BpParams::new(Mode::SumProduct)
        .tolerance(tol)
        .max_iterations(1000)
        .check_unwrap()
        .run(&g, &mut Flooding)
        .unwrap();
    let damped = BpParams::new(Mode::SumProduct)
        .tolerance(tol)
        .damping(0.9)
        .max_iterations(1000)
        .check_unwrap()
        .run(&g, &mut Flooding)
        .unwrap();
    assert!(undamped.converged && damped.converged);
    assert!(damped.iterations > undamped.iterations);
    for (a, b) in undamped
        .beliefs
        .iter()
        .flatten()
        .zip(damped.beliefs.iter().flatten())
    {
        assert!((a - b).abs() < 1e-8, "{a} vs {b}");
    }
}

#[test]
fn invalid_parameters_are_errors() {
    let g = FactorGraph::with_variables(&[2]).unwrap();
    for (params, name) in [
        (BpParams::new(Mode::MaxProduct).damping(1.0), "damping = 1"),
        (
            BpParams::new(Mode::MaxProduct).damping(-0.1),
            "damping = -0.1",
        ),
        (
            BpParams::new(Mode::SumProduct).tolerance(f64::NAN),
            "tolerance = NaN",
        ),
        (
            BpParams::new(Mode::SumProduct).max_iterations(0),
            "max_iterations = 0",
        ),
    ] {
        let err = params.check().unwrap_err();
        assert!(err.to_string().contains(name), "{err}");
    }
    // A checked engine runs.
    assert!(BpParams::new(Mode::MaxProduct)
        .check()
        .unwrap()
        .run(&g, &mut Flooding)
        .is_ok());
    let err = TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0, f64::NAN]).unwrap_err();
    assert!(err.to_string().contains("NaN"), "{err}");
    let err = TableFactor::new(vec![VariableId(0)], vec![2], vec![0.0]).unwrap_err();
    assert!(err.to_string().contains("expected 2"), "{err}");
}

#[test]
fn uai_errors_name_file_line_and_expectation() {
    let bad = "MARKOV\n2\n2 2\n1\n2 0 1\n\n4\n1 2 x 4\n";
    let err = UaiModel::parse_str("m.uai", bad).unwrap_err().to_string();
    assert!(err.starts_with("m.uai:8:"), "{err}");
    assert!(err.contains("entry 2 of the table of function 0"), "{err}");
    let short = "MARKOV\n2\n2 2\n1\n2 0 1\n\n4\n1 2 3\n";
    let err = UaiModel::parse_str("m.uai", short).unwrap_err().to_string();
    assert!(err.contains("unexpected end of file"), "{err}");
    let wrong_size = "MARKOV\n2\n2 2\n1\n2 0 1\n\n3\n1 2 3\n";
    let err = UaiModel::parse_str("m.uai", wrong_size)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("m.uai:7:") && err.contains("4 joint states"),
        "{err}"
    );
    let scope = "MARKOV\n2\n2 2\n1\n2 0 2\n";
    let err = UaiModel::parse_str("m.uai", scope).unwrap_err().to_string();
    assert!(
        err.contains("m.uai:5:") && err.contains("outside [0, 1]"),
        "{err}"
    );
    let err = pgm_core::uai::Evidence::parse_str("e.evid", "1 0 5", &[2, 2])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("e.evid:1:") && err.contains("state 5 of variable 0"),
        "{err}"
    );
    let ev = pgm_core::uai::Evidence::parse_str("e.evid", "1\n1 1 0\n", &[2, 2]).unwrap();
    assert_eq!(ev.0, vec![(1, 0)]);
}

/// The star of hardening case B15: x0 with ten binary leaves, each leaf copying x0
/// with probability 0.9, three leaves observed in state 1.
fn star_with_evidence() -> FactorGraph {
    let mut g = FactorGraph::with_variables(&[2; 11]).unwrap();
    g.add_factor(TableFactor::from_potentials(vec![VariableId(0)], vec![2], &[0.5, 0.5]).unwrap())
        .unwrap();
    for leaf in 1..11 {
        g.add_factor(
            TableFactor::from_potentials(
                vec![VariableId(0), VariableId(leaf)],
                vec![2, 2],
                &[0.9, 0.1, 0.1, 0.9],
            )
            .unwrap(),
        )
        .unwrap();
    }
    for leaf in 1..4 {
        g.add_factor(
            TableFactor::new(
                vec![VariableId(leaf)],
                vec![2],
                vec![f64::NEG_INFINITY, 0.0],
            )
            .unwrap(),
        )
        .unwrap();
    }
    g
}

#[test]
fn damping_never_changes_the_fixed_point_on_the_b15_star() {
    let g = star_with_evidence();
    let exact = brute_force(&g, BruteForceLimit::default()).unwrap();
    for damping in [0.0, 0.5, 0.9] {
        for (name, mut schedule) in common::schedules() {
            let r = BpParams::new(Mode::SumProduct)
                .damping(damping)
                .tolerance(1e-12)
                .max_iterations(10_000)
                .check_unwrap()
                .run(&g, &mut schedule)
                .unwrap();
            assert!(r.converged, "{name}, damping {damping}: not converged");
            for (v, (b, e)) in r.beliefs.iter().zip(&exact.marginals).enumerate() {
                for (p, q) in b.iter().zip(e) {
                    assert!(
                        (p - q).abs() < 1e-9,
                        "{name}, damping {damping}: P(x{v}) = {b:?}, exact {e:?} after {} iterations",
                        r.iterations
                    );
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(common::persisted(100, "proptest-regressions/inference.txt"))]

    /// Damping changes the path to the fixed point, never the fixed point: on trees
    /// (a unique fixed point, the exact one) every schedule with every damping ends at
    /// the exact marginals and MAP score, and reports convergence only there.
    #[test]
    fn damping_never_changes_the_fixed_point(
        spec in strategies::enumerable(strategies::tree(9, 3, 5.0, 0.05), MAX_STATES),
        damping in prop_oneof![Just(0.3), Just(0.6), Just(0.9)],
    ) {
        let graph = spec.build();
        let Ok(exact) = brute_force(&graph, BruteForceLimit(MAX_STATES)) else { return Ok(()); };
        for (name, mut schedule) in common::schedules() {
            let mut run = |mode| BpParams::new(mode)
                .damping(damping)
                .tolerance(1e-12)
                .max_iterations(20_000).check_unwrap()
                .run(&graph, &mut schedule)
                .unwrap();
            let mar = run(Mode::SumProduct);
            prop_assert!(mar.converged, "{name}, damping {damping}: sum-product not converged");
            for (v, (b, e)) in mar.beliefs.iter().zip(&exact.marginals).enumerate() {
                for (p, q) in b.iter().zip(e) {
                    prop_assert!((p - q).abs() < 1e-8, "{name}, damping {damping}: P(x{v}) = {b:?}, exact {e:?}");
                }
            }
            let map = run(Mode::MaxProduct);
            prop_assert!(map.converged, "{name}, damping {damping}: max-product not converged");
            prop_assert!(close(map.log_score, exact.map_log_score, 1e-9), "{name}, damping {damping}: {} vs {}", map.log_score, exact.map_log_score);
        }
    }
}

#[test]
fn observer_sees_every_iteration_of_every_schedule() {
    use pgm_core::observer::{BpProgress, History};
    let g = star_with_evidence();
    for (name, mut schedule) in common::schedules() {
        let mut history = History::<BpProgress>::default();
        let r = BpParams::new(Mode::SumProduct)
            .damping(0.5)
            .tolerance(1e-12)
            .max_iterations(10_000)
            .check_unwrap()
            .on(&g)
            .observer(&mut history)
            .run(&mut schedule)
            .unwrap();
        assert_eq!(history.0.len(), r.iterations, "{name}");
        let last = history.0.last().unwrap();
        assert_eq!(last.residual, r.residual, "{name}");
        assert!(last.converged && r.converged, "{name}");
        assert!(
            history.0[..history.0.len() - 1]
                .iter()
                .all(|p| !p.converged && p.residual > 1e-12),
            "{name}"
        );
        assert!(
            history
                .0
                .iter()
                .enumerate()
                .all(|(i, p)| p.iteration == i + 1),
            "{name}"
        );
        // Stopping after three iterations.
        let mut stop = |p: &BpProgress| {
            if p.iteration == 3 {
                std::ops::ControlFlow::Break(())
            } else {
                std::ops::ControlFlow::Continue(())
            }
        };
        let r = BpParams::new(Mode::SumProduct)
            .damping(0.5)
            .tolerance(1e-12)
            .check_unwrap()
            .on(&g)
            .observer(&mut stop)
            .run(&mut schedule)
            .unwrap();
        assert_eq!(r.iterations, 3, "{name}");
        assert!(r.stopped_by_observer && !r.converged, "{name}");
        assert_eq!(r.termination(), pgm_core::Termination::Observer, "{name}");
    }
}

proptest! {
    #![proptest_config(common::persisted(60, "proptest-regressions/inference.txt"))]

    /// Potts tables written out densely (as UAI files hold them) and turned back into
    /// Potts factors give the same max-product messages and decisions, and the same
    /// sum-product beliefs to rounding, under every schedule.
    #[test]
    fn specialised_potts_tables_pass_the_same_messages(spec in strategies::potts_grid(4, 4, 5.0)) {
        let mut dense_spec = spec.clone();
        for f in &mut dense_spec.factors {
            if let strategies::FactorSpec::Potts { a, b, same, different } = *f {
                let k = spec.cardinalities[a];
                let log_table = (0..k * k).map(|i| if i / k == i % k { same } else { different }).collect();
                *f = strategies::FactorSpec::Table { scope: vec![a, b], log_table };
            }
        }
        let dense = dense_spec.build();
        let mut specialised = dense_spec.build();
        let pairs = dense_spec.factors.iter().filter(|f| matches!(f, strategies::FactorSpec::Table { scope, .. } if scope.len() == 2)).count();
        let k = spec.cardinalities[0];
        prop_assert_eq!(specialised.specialise_factors(), if k >= 2 { pairs } else { 0 });
        for (name, mut schedule) in common::schedules() {
            let bp = BpParams::new(Mode::MaxProduct).max_iterations(15).check_unwrap();
            let a = bp.run(&dense, &mut schedule).unwrap();
            let b = bp.run(&specialised, &mut schedule).unwrap();
            prop_assert_eq!(&a.assignment, &b.assignment, "{}", name);
            prop_assert_eq!(a.messages.as_slice(), b.messages.as_slice(), "{}", name);
            let sp = BpParams::new(Mode::SumProduct).max_iterations(15).check_unwrap();
            let a = sp.run(&dense, &mut schedule).unwrap();
            let b = sp.run(&specialised, &mut schedule).unwrap();
            if name != "residual" {
                for (x, y) in a.beliefs.iter().flatten().zip(b.beliefs.iter().flatten()) {
                    prop_assert!((x - y).abs() < 1e-9, "{name}: {x} vs {y}");
                }
            }
        }
    }
}

proptest! {
    /// Dense tables' messages (with their fixed-size fast paths for few states) equal
    /// the enumeration of every joint state, for every arity-2 shape up to 10 × 10.
    #[test]
    fn dense_messages_match_enumeration(
        k0 in 1usize..11, k1 in 1usize..11,
        table in proptest::collection::vec(strategies::log_potential(30.0, 0.2), 100),
        q in proptest::collection::vec(strategies::log_potential(30.0, 0.2), 20),
    ) {
        let factor = TableFactor::new(vec![VariableId(0), VariableId(1)], vec![k0, k1], table[..k0 * k1].to_vec()).unwrap();
        check_pairwise_messages(
            &q[..k0],
            &q[10..10 + k1],
            "",
            |target, incoming, mode, out| factor.message(target, incoming, mode, out),
            |target, incoming, mode, out| {
                pgm_core::factor::enumerated_message(&factor, target, incoming, mode, out)
            },
        )?;
    }
}
