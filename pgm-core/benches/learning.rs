//! Pseudo-likelihood learning at the scale of the papers: 30 weights learned from 30
//! instances of 361-variable chains (one per laser beam) with 5 states each, labels
//! drawn exactly from a model with known weights. Measures the whole `Learner::learn`
//! call (validation pass plus L-BFGS to convergence, default parameters), and one pass
//! (objective and gradient) of the exact likelihood over the same chains, which takes
//! its fast path for chains (scaled forward-backward), and of the Bethe likelihood
//! (the general log-space belief-propagation path) for comparison.

use criterion::{criterion_group, criterion_main, Criterion};
use pgm_core::exact::ChainSampler;
use pgm_core::learning::{
    CliqueFeatures, FeatureSet, FnFeatures, LabelledInstance, LearnerParams, Likelihood,
    LikelihoodKind, LogLinearModel, TemplateId,
};
use pgm_core::{ParamGuard, VariableId};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::sync::Arc;

const STATES: usize = 5;
const OBSERVATIONS: usize = 4;
const LENGTH: usize = 361;
const INSTANCES: usize = 30;

fn training_set() -> (Arc<FeatureSet>, Vec<LabelledInstance>) {
    let mut features = FeatureSet::new("bench-chain", 1);
    let unary_names: Vec<String> = (0..STATES)
        .flat_map(|k| (0..OBSERVATIONS).map(move |j| format!("state{k}_z{j}")))
        .collect();
    let pair_names: Vec<String> = (0..STATES)
        .map(|k| format!("same{k}"))
        .chain((0..STATES).map(|k| format!("same{k}_distance")))
        .collect();
    let observation = features
        .add_template(
            "observation",
            &unary_names.iter().map(String::as_str).collect::<Vec<_>>(),
        )
        .unwrap();
    let neighbour = features
        .add_template(
            "neighbour",
            &pair_names.iter().map(String::as_str).collect::<Vec<_>>(),
        )
        .unwrap();
    let features = Arc::new(features);
    assert_eq!(features.num_weights(), 30);

    let mut rng = ChaCha8Rng::seed_from_u64(361);
    let truth: Vec<f64> = (0..30).map(|_| rng.random::<f64>() * 2.0 - 1.0).collect();
    let data = (0..INSTANCES)
        .map(|_| {
            let model = chain(&features, observation, neighbour, &mut rng);
            let graph = model.to_factor_graph(&truth).unwrap();
            let labels = ChainSampler::new(&graph).unwrap().sample(&mut rng);
            LabelledInstance::new(model, labels)
        })
        .collect();
    (features, data)
}

fn chain(
    features: &Arc<FeatureSet>,
    observation: TemplateId,
    neighbour: TemplateId,
    rng: &mut ChaCha8Rng,
) -> LogLinearModel {
    let mut model = LogLinearModel::new(Arc::clone(features), &[STATES; LENGTH]).unwrap();
    for i in 0..LENGTH {
        let z = std::array::from_fn(|_| rng.random::<f64>() * 2.0 - 1.0);
        model
            .add_clique(observation, observation_clique(i, z))
            .unwrap();
        if i > 0 {
            let distance = rng.random::<f64>() * 0.5;
            model
                .add_clique(neighbour, neighbour_clique(i, distance))
                .unwrap();
        }
    }
    model
}

/// Unary at point `i`: state `k` weighs each of the point's 4 observations `z` with
/// its own weight (5 × 4 = 20 weights).
fn observation_clique(i: usize, z: [f64; OBSERVATIONS]) -> impl CliqueFeatures {
    FnFeatures::new([VariableId(i)], [STATES], move |states, out| {
        let k = states[0];
        out[k * OBSERVATIONS..(k + 1) * OBSERVATIONS].copy_from_slice(&z);
    })
}

/// Pairwise between points `i - 1` and `i`: neighbours in the same state `k` get
/// `[1, d]` on that state's two weights (5 × 2 = 10 weights), `d` the distance
/// between the points.
fn neighbour_clique(i: usize, distance: f64) -> impl CliqueFeatures {
    let scope = [VariableId(i - 1), VariableId(i)];
    FnFeatures::new(scope, [STATES; 2], move |states, out| {
        if states[0] == states[1] {
            out[states[0]] = 1.0;
            out[STATES + states[0]] = distance;
        }
    })
}

fn learning(c: &mut Criterion) {
    let (features, data) = training_set();
    let learner = LearnerParams::default().check().unwrap();
    let result = learner.learn(&features, &data, &mut ()).unwrap();
    eprintln!(
        "learning bench: {} iterations, {} evaluations, objective {:.3}, |gradient| {:.1e}, {}",
        result.iterations,
        result.evaluations,
        result.objective,
        result.gradient_norm,
        result.termination
    );
    let mut group = c.benchmark_group("learning");
    group.sample_size(10);
    group.bench_function("pseudo_likelihood_30w_30x361x5", |b| {
        b.iter(|| black_box(learner.learn(&features, &data, &mut ()).unwrap()))
    });
    let weights = result.weights.values();
    for (name, kind) in [
        ("likelihood_pass_chain_30x361x5", LikelihoodKind::Exact),
        ("bethe_pass_general_30x361x5", LikelihoodKind::Bethe),
    ] {
        let objective = Likelihood::new(kind, Arc::clone(&features), &data, 10.0).unwrap();
        group.bench_function(name, |b| {
            b.iter(|| black_box(objective.value_and_gradient(weights).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(benches, learning);
criterion_main!(benches);
