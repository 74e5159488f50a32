//! The exact likelihood's fast path for chains and forests of unary and pairwise
//! cliques (scaled forward-backward in probability space): its objective and gradient
//! against brute-force enumeration, against the general log-space path (the Bethe
//! likelihood, exact on forests) and against finite differences; the instances it
//! hands back to the general path; training sets mixing both paths.

mod common;

use pgm_core::learning::{
    DenseFeatures, FeatureSet, LabelledInstance, LearnerParams, LearningObjective, Likelihood,
    LikelihoodKind, LogLinearModel, TemplateId,
};
use pgm_core::{ParamGuard, VariableId};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

const WIDTHS: [usize; 3] = [1, 2, 3];

fn feature_set() -> Arc<FeatureSet> {
    let mut features = FeatureSet::new("forest", 1);
    for (t, &w) in WIDTHS.iter().enumerate() {
        let names: Vec<String> = (0..w).map(|j| format!("f{j}")).collect();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        features.add_template(&format!("t{t}"), &names).unwrap();
    }
    Arc::new(features)
}

/// A dense feature table over `shape` for a random template, about a third of the
/// values zero, the others in [-2, 2].
fn clique(rng: &mut ChaCha8Rng, scope: &[usize], shape: Vec<usize>) -> (TemplateId, DenseFeatures) {
    let t = rng.random_range(0..WIDTHS.len());
    let size = shape.iter().product::<usize>() * WIDTHS[t];
    let table = (0..size)
        .map(|_| {
            if rng.random_bool(0.3) {
                0.0
            } else {
                rng.random_range(-2.0..2.0)
            }
        })
        .collect();
    let scope = scope.iter().map(|&v| VariableId(v)).collect();
    (
        TemplateId(t),
        DenseFeatures::new(scope, shape, WIDTHS[t], table).unwrap(),
    )
}

/// Random instances of 1-5 variables of 1-3 states: each variable after the first is
/// joined to the previous one (`chain`) or to a random earlier one, or (one time in
/// five, forests) to none, in either scope order, by 1-2 pairwise cliques; 0-2 unary
/// cliques per variable; random labels.
fn random_instances(
    rng: &mut ChaCha8Rng,
    features: &Arc<FeatureSet>,
    count: usize,
    chain: bool,
) -> Vec<LabelledInstance> {
    (0..count)
        .map(|_| {
            let n = rng.random_range(1..=5);
            let cards: Vec<usize> = (0..n).map(|_| rng.random_range(1..=3)).collect();
            let mut model = LogLinearModel::new(Arc::clone(features), &cards).unwrap();
            for v in 0..n {
                for _ in 0..rng.random_range(0..=2) {
                    let (t, c) = clique(rng, &[v], vec![cards[v]]);
                    model.add_clique(t, c).unwrap();
                }
                if v == 0 || (!chain && rng.random_bool(0.2)) {
                    continue;
                }
                let p = if chain { v - 1 } else { rng.random_range(0..v) };
                let scope = if rng.random_bool(0.5) { [p, v] } else { [v, p] };
                for _ in 0..rng.random_range(1..=2) {
                    let (t, c) = clique(rng, &scope, vec![cards[scope[0]], cards[scope[1]]]);
                    model.add_clique(t, c).unwrap();
                }
            }
            let labels = cards.iter().map(|&k| rng.random_range(0..k)).collect();
            LabelledInstance::new(model, labels)
        })
        .collect()
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1.0)
}

/// The largest `|g − fd| / max(1, |g|)` over the weights, central differences of step h.
fn worst_gradient_error(objective: &Likelihood<'_>, weights: &[f64], h: f64) -> (usize, f64) {
    let (_, gradient) = objective.value_and_gradient(weights).unwrap();
    let mut worst = (0, 0.0);
    for k in 0..weights.len() {
        let mut plus = weights.to_vec();
        let mut minus = weights.to_vec();
        plus[k] += h;
        minus[k] -= h;
        let fd = (objective.value_and_gradient(&plus).unwrap().0
            - objective.value_and_gradient(&minus).unwrap().0)
            / (2.0 * h);
        let error = (gradient[k] - fd).abs() / gradient[k].abs().max(1.0);
        if error >= worst.1 {
            worst = (k, error);
        }
    }
    worst
}

proptest! {
    #![proptest_config(common::persisted(256, "proptest-regressions/likelihood_chain.txt"))]

    /// On random chains and forests the exact likelihood (the fast path) equals brute
    /// force to 1e-10 relative, its value and gradient equal the general log-space
    /// path's (the Bethe likelihood, exact on forests) to 1e-10 relative, and the
    /// gradient matches central finite differences (step 1e-5) to 1e-5.
    #[test]
    fn fast_path_equals_brute_force_and_the_general_path(
        seed in any::<u64>(),
        chain in any::<bool>(),
        count in 1..=3usize,
        scale in prop_oneof![Just(1.5), Just(20.0)],
        prior in prop_oneof![Just(f64::INFINITY), 0.5..5.0f64],
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let features = feature_set();
        let data = random_instances(&mut rng, &features, count, chain);
        let weights: Vec<f64> = (0..features.num_weights()).map(|_| rng.random_range(-scale..scale)).collect();
        let exact = Likelihood::new(LikelihoodKind::Exact, Arc::clone(&features), &data, prior).unwrap();
        let general = Likelihood::new(LikelihoodKind::Bethe, Arc::clone(&features), &data, prior).unwrap();
        let (value, gradient) = exact.value_and_gradient(&weights).unwrap();
        let expected = common::brute_force_objective(&data, &weights, prior);
        prop_assert!(relative(value, expected) < 1e-10, "{} vs brute force {}", value, expected);
        let (general_value, general_gradient) = general.value_and_gradient(&weights).unwrap();
        prop_assert!(relative(value, general_value) < 1e-10, "{} vs general {}", value, general_value);
        for (j, (g, e)) in gradient.iter().zip(&general_gradient).enumerate() {
            prop_assert!(relative(*g, *e) < 1e-10, "weight {}: {} vs general {}", j, g, e);
        }
        if scale < 2.0 {
            let (k, error) = worst_gradient_error(&exact, &weights, 1e-5);
            prop_assert!(error < 1e-5, "weight {}: finite-difference error {:e}", k, error);
        }
    }
}

/// Two binary variables whose potentials meet only 800 nats below their maxima:
/// `θ_1 = (0, −800)` and `θ_01(x_0, x_1) = −800 [x_1 = 0]`. In probability space the
/// message to variable 0 underflows to zero, so the fast path sweeps the instance in
/// log space instead, which is exact: `log Z = log 4 − 800`.
#[test]
fn an_instance_beyond_the_range_of_exp_is_evaluated_in_log_space() {
    let mut features = FeatureSet::new("far", 1);
    let unary = features.add_template("unary", &["low"]).unwrap();
    let pair = features.add_template("pair", &["low"]).unwrap();
    let features = Arc::new(features);
    let build = |labels: Vec<usize>| {
        let mut model = LogLinearModel::new(Arc::clone(&features), &[2, 2]).unwrap();
        model
            .add_clique(
                unary,
                DenseFeatures::new(vec![VariableId(1)], vec![2], 1, vec![0.0, -800.0]).unwrap(),
            )
            .unwrap();
        let table = vec![-800.0, 0.0, -800.0, 0.0];
        model
            .add_clique(
                pair,
                DenseFeatures::new(vec![VariableId(0), VariableId(1)], vec![2, 2], 1, table)
                    .unwrap(),
            )
            .unwrap();
        LabelledInstance::new(model, labels)
    };
    let data = vec![build(vec![0, 0]), build(vec![1, 1])];
    let objective = Likelihood::new(
        LikelihoodKind::Exact,
        Arc::clone(&features),
        &data,
        f64::INFINITY,
    )
    .unwrap();
    let weights = [1.0, 1.0];
    let (value, gradient) = objective.value_and_gradient(&weights).unwrap();
    // Every joint state scores −800, so p is uniform and each −log p = log 4.
    let expected = 2.0 * 4f64.ln();
    assert!(relative(value, expected) < 1e-12, "{value} vs {expected}");
    assert!(
        relative(
            value,
            common::brute_force_objective(&data, &weights, f64::INFINITY)
        ) < 1e-12
    );
    // Under the uniform p each feature's expectation is −400 per instance; the labels'
    // totals are (0, −800) and (−800, 0): the gradient E[F] − F(y) is zero.
    for g in gradient {
        assert!(g.abs() < 1e-9, "{g}");
    }
    let (k, error) = worst_gradient_error(&objective, &weights, 1e-5);
    assert!(
        error < 1e-5,
        "weight {k}: finite-difference error {error:e}"
    );
}

/// A training set mixing chains (fast path), a tree and an instance with a clique over
/// three variables (general path) equals brute force, and the learner trains on it.
#[test]
fn fast_and_general_instances_in_one_training_set() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let features = feature_set();
    let mut data = random_instances(&mut rng, &features, 3, true);
    data.extend(random_instances(&mut rng, &features, 2, false));
    let mut model = LogLinearModel::new(Arc::clone(&features), &[2, 3, 2]).unwrap();
    for v in 0..3 {
        let (t, c) = clique(&mut rng, &[v], vec![[2, 3, 2][v]]);
        model.add_clique(t, c).unwrap();
    }
    let (t, c) = clique(&mut rng, &[0, 1, 2], vec![2, 3, 2]);
    model.add_clique(t, c).unwrap();
    data.push(LabelledInstance::new(model, vec![1, 2, 0]));
    let weights: Vec<f64> = (0..features.num_weights())
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    let objective =
        Likelihood::new(LikelihoodKind::Exact, Arc::clone(&features), &data, 3.0).unwrap();
    let (value, _) = objective.value_and_gradient(&weights).unwrap();
    let expected = common::brute_force_objective(&data, &weights, 3.0);
    assert!(relative(value, expected) < 1e-10, "{value} vs {expected}");
    let (k, error) = worst_gradient_error(&objective, &weights, 1e-5);
    assert!(
        error < 1e-5,
        "weight {k}: finite-difference error {error:e}"
    );
    let learner = LearnerParams::default()
        .prior_variance(3.0)
        .objective(LearningObjective::Likelihood)
        .check()
        .unwrap();
    let result = learner.learn(&features, &data, &mut ()).unwrap();
    assert!(result.converged, "{}", result.termination);
    let at_optimum = common::brute_force_objective(&data, result.weights.values(), 3.0);
    assert!(relative(result.objective, at_optimum) < 1e-10);
    assert!(
        result.objective < value,
        "{} not below {}",
        result.objective,
        value
    );
}
