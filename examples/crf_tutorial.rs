//! Tutorial: a conditional random field built from scratch, the way a researcher
//! would: denoising a label image.
//!
//! The task: every pixel of an image belongs to one of three classes (background, a
//! disc, a rectangle) and we only see a noisy intensity per pixel,
//! `z = class + N(0, σ²)` with σ = 0.6, so that a pixel on its own is often
//! misread. A CRF over the pixel grid couples neighbours, and learning tells it how
//! much to trust the intensities against the neighbours. The steps:
//!
//! 1. **Features** (log-linear, `log φ_c(x_c) = w · f_c(x_c, z)`): a `pixel` template
//!    with, per class `c`, the features `[x = c]`, `[x = c]·z`, `[x = c]·z²` (so the
//!    model can learn one Gaussian per class), and a `neighbour` template with
//!    `[x_i = x_j]` and the contrast-sensitive `[x_i = x_j]·exp(−(z_i − z_j)²/2)`.
//! 2. **Learning** the 11 weights by maximum pseudo-likelihood with L-BFGS
//!    ([`pgm::core::learning`]) on simulated training images.
//! 3. **Inference** on held-out images: loopy max-product belief propagation, and
//!    TRW-S ([`pgm::core::trws`]), which returns the MAP assignment *with an upper
//!    bound* on the best log-score: the gap says how far from optimal the answer can
//!    be. Sum-product BP gives per-pixel marginals.
//! 4. **Evaluation**: pixel accuracy against the ground truth, next to the pixel-wise
//!    classifier that ignores the neighbours.
//!
//! The certificate earns its keep in step 4: when TRW-S closes the gap, its labelling
//! is the best the learned model has, so a labelling that is still wrong points at the
//! model (its features, or pseudo-likelihood over-trusting neighbours), not at the
//! inference. With the defaults TRW-S closes the gap on every test image and beats
//! BP, whose labellings score lower under the same model.
//!
//! Run: `cargo run --release --example crf_tutorial -- [SIDE] [TRAIN] [TEST] [SEED]`
//! (defaults 48 8 4 1). Exits non-zero if the CRF does not beat the pixel-wise
//! classifier or a TRW-S bound is below its own assignment's score.

use pgm::core::learning::{
    DenseFeatures, FeatureSet, LabelledInstance, LearnerParams, LogLinearModel, Progress,
    TemplateId,
};
use pgm::core::observer::TrwsProgress;
use pgm::core::trws::TrwsParams;
use pgm::core::{BpParams, FactorGraph, Mode, ParamGuard, Sequential, VariableId};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::Instant;

/// Number of classes.
const CLASSES: usize = 3;
/// Standard deviation of the intensity noise.
const NOISE: f64 = 0.6;

/// One image: true classes and noisy intensities, row-major.
struct Image {
    side: usize,
    labels: Vec<usize>,
    intensities: Vec<f64>,
}

/// A background with a disc (class 1) and a rectangle (class 2) at random places,
/// observed through Gaussian noise.
fn simulate(side: usize, rng: &mut ChaCha8Rng) -> Image {
    let s = side as f64;
    let (cx, cy) = (
        rng.random_range(0.2..0.8) * s,
        rng.random_range(0.2..0.8) * s,
    );
    let radius = rng.random_range(0.12..0.3) * s;
    let (x0, y0) = (
        rng.random_range(0.0..0.6) * s,
        rng.random_range(0.0..0.6) * s,
    );
    let (w, h) = (
        rng.random_range(0.2..0.4) * s,
        rng.random_range(0.2..0.4) * s,
    );
    let mut labels = vec![0; side * side];
    for r in 0..side {
        for c in 0..side {
            let (x, y) = (c as f64 + 0.5, r as f64 + 0.5);
            if x >= x0 && x < x0 + w && y >= y0 && y < y0 + h {
                labels[r * side + c] = 2;
            } else if (x - cx).powi(2) + (y - cy).powi(2) <= radius * radius {
                labels[r * side + c] = 1;
            }
        }
    }
    let intensities = labels
        .iter()
        .map(|&l| l as f64 + NOISE * rng.sample::<f64, _>(StandardNormal))
        .collect();
    Image {
        side,
        labels,
        intensities,
    }
}

/// The model's weights: names and templates.
struct Templates {
    features: Arc<FeatureSet>,
    pixel: TemplateId,
    neighbour: TemplateId,
}

fn templates() -> Result<Templates, Box<dyn std::error::Error>> {
    let mut features = FeatureSet::new("denoise-tutorial", 1);
    let names: Vec<String> = (0..CLASSES)
        .flat_map(|c| [format!("bias_{c}"), format!("z_{c}"), format!("z2_{c}")])
        .collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let pixel = features.add_template("pixel", &names)?;
    let neighbour = features.add_template("neighbour", &["same", "same_contrast"])?;
    Ok(Templates {
        features: Arc::new(features),
        pixel,
        neighbour,
    })
}

/// The CRF of one image: a variable per pixel, a unary clique per pixel and a
/// pairwise clique per pair of 4-neighbours, with dense feature tables.
fn crf(image: &Image, t: &Templates) -> Result<LogLinearModel, Box<dyn std::error::Error>> {
    let side = image.side;
    let mut model = LogLinearModel::new(Arc::clone(&t.features), &vec![CLASSES; side * side])?;
    for (i, &z) in image.intensities.iter().enumerate() {
        // Row x of the table: the 9 features of state x (3 per class, 0 unless c = x).
        let mut table = vec![0.0; CLASSES * 3 * CLASSES];
        for x in 0..CLASSES {
            let row = &mut table[x * 3 * CLASSES..(x + 1) * 3 * CLASSES];
            row[3 * x..3 * x + 3].copy_from_slice(&[1.0, z, z * z]);
        }
        let features = DenseFeatures::new(vec![VariableId(i)], vec![CLASSES], 3 * CLASSES, table)?;
        model.add_clique(t.pixel, features)?;
    }
    for r in 0..side {
        for c in 0..side {
            let i = r * side + c;
            let mut pairs = Vec::new();
            if c + 1 < side {
                pairs.push(i + 1);
            }
            if r + 1 < side {
                pairs.push(i + side);
            }
            for j in pairs {
                let d = image.intensities[i] - image.intensities[j];
                let contrast = (-d * d / 2.0).exp();
                let mut table = vec![0.0; CLASSES * CLASSES * 2];
                for x in 0..CLASSES {
                    table[(x * CLASSES + x) * 2..(x * CLASSES + x) * 2 + 2]
                        .copy_from_slice(&[1.0, contrast]);
                }
                let features = DenseFeatures::new(
                    vec![VariableId(i), VariableId(j)],
                    vec![CLASSES, CLASSES],
                    2,
                    table,
                )?;
                model.add_clique(t.neighbour, features)?;
            }
        }
    }
    Ok(model)
}

/// Fraction of pixels labelled correctly.
fn accuracy(truth: &[usize], labels: &[usize]) -> f64 {
    let right = truth.iter().zip(labels).filter(|(a, b)| a == b).count();
    right as f64 / truth.len() as f64
}

/// The pixel-wise classifier: each pixel's best class under the unary cliques alone.
fn pixelwise(graph: &FactorGraph) -> Vec<usize> {
    (0..graph.num_variables())
        .map(|v| {
            let mut score = vec![0.0; CLASSES];
            for &e in graph.variable_edges(VariableId(v)) {
                let factor = graph.factor(graph.edge_factor(e));
                if factor.scope().len() == 1 {
                    for (x, s) in score.iter_mut().enumerate() {
                        *s += factor.log_potential(&[x]);
                    }
                }
            }
            pgm::core::bp::first_argmax(&score)
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: usize| -> Result<usize, std::num::ParseIntError> {
        args.get(i).map_or(Ok(default), |s| s.parse())
    };
    let (side, train, test, seed) = (arg(0, 48)?, arg(1, 8)?, arg(2, 4)?, arg(3, 1)? as u64);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let t = templates()?;

    // 1-2. Features and learning.
    let mut data = Vec::with_capacity(train);
    for _ in 0..train {
        let image = simulate(side, &mut rng);
        let model = crf(&image, &t)?;
        data.push(LabelledInstance::new(model, image.labels));
    }
    let learner = LearnerParams::default().prior_variance(10.0).check()?;
    let started = Instant::now();
    let mut last = None;
    let mut observer = |p: &Progress| {
        last = Some(*p);
        ControlFlow::Continue(())
    };
    let learned = learner.learn(&t.features, &data, &mut observer)?;
    println!(
        "learned {} weights from {train} images of {side}x{side} pixels by pseudo-likelihood: {} L-BFGS iterations, {:.2} s, converged: {}",
        t.features.num_weights(),
        last.map_or(0, |p| p.iteration),
        started.elapsed().as_secs_f64(),
        learned.converged
    );
    println!("{}", learned.weights);
    let weights = learned.weights.values();

    // 3-4. Inference on held-out images and evaluation.
    println!(
        "\n{:>5} {:>10} {:>9} {:>9} {:>9} {:>11} {:>11} {:>11} {:>9} {:>9}",
        "image",
        "pixelwise",
        "BP",
        "TRW-S",
        "marginal",
        "BP score",
        "TRW-S score",
        "TRW-S bound",
        "gap",
        "TRW-S ms"
    );
    let bp = BpParams::new(Mode::MaxProduct)
        .max_iterations(50)
        .check_unwrap();
    let marginals = BpParams::new(Mode::SumProduct)
        .max_iterations(50)
        .damping(0.3)
        .check_unwrap();
    let trws = TrwsParams::default()
        .max_iterations(50)
        .tolerance(1e-9)
        .check()?;
    let mut ok = true;
    let mut totals = [0.0; 4];
    for index in 0..test {
        let image = simulate(side, &mut rng);
        let graph = crf(&image, &t)?.to_factor_graph(weights)?;
        let pixelwise = pixelwise(&graph);
        let map = bp.run(&graph, &mut Sequential::default())?;
        let started = Instant::now();
        let mut bounds = Vec::new();
        let mut watch = |p: &TrwsProgress| {
            bounds.push(p.bound);
            ControlFlow::Continue(())
        };
        let certified = trws.run_observed(&graph, &mut watch)?;
        let trws_ms = started.elapsed().as_secs_f64() * 1e3;
        let mar = marginals.run(&graph, &mut Sequential::default())?;
        let accuracies = [
            accuracy(&image.labels, &pixelwise),
            accuracy(&image.labels, &map.assignment),
            accuracy(&image.labels, &certified.assignment),
            accuracy(&image.labels, &mar.assignment),
        ];
        for (total, a) in totals.iter_mut().zip(accuracies) {
            *total += a / test as f64;
        }
        println!(
            "{index:>5} {:>10.3} {:>9.3} {:>9.3} {:>9.3} {:>11.2} {:>11.2} {:>11.2} {:>9.1e} {:>9.1}",
            accuracies[0],
            accuracies[1],
            accuracies[2],
            accuracies[3],
            map.log_score,
            certified.log_score,
            certified.bound,
            certified.gap,
            trws_ms
        );
        // The certificate: no assignment scores above the bound, which never rose.
        ok &= certified.log_score <= certified.bound + 1e-9 * certified.bound.abs().max(1.0);
        ok &= bounds
            .windows(2)
            .all(|w| w[1] <= w[0] + 1e-9 * w[0].abs().max(1.0));
    }
    println!(
        "{:>5} {:>10.3} {:>9.3} {:>9.3} {:>9.3}",
        "mean", totals[0], totals[1], totals[2], totals[3]
    );
    println!(
        "\nBP: sequential max-product, 50 iterations at most; TRW-S: 50 iterations at most, its bound is an upper bound on every labelling's log-score, so its labelling is at most `gap` below the optimum; marginal: argmax of sum-product marginals (damping 0.3)."
    );
    ok &= totals[1] > totals[0] && totals[2] > totals[0];
    if !ok {
        eprintln!("the CRF did not beat the pixel-wise classifier, or a TRW-S bound failed");
        std::process::exit(1);
    }
    Ok(())
}
