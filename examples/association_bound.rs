//! How far can association accuracy go on the simulator? Oracles that know more than
//! any method can, each told less than the one before, on the pairs of one seed.
//!
//! Every oracle decides the outliers perfectly (a return whose true association is the
//! outlier state is counted correct) and associates every true inlier with the
//! reference return nearest to it under a motion, on surface points
//! ([`pgm_features::scan::surface_points`]); they differ in the motion of each true
//! object (the background included):
//!
//! 1. **true motion**: the simulator's;
//! 2. **fit to the true associations**: eq. 6 of the joint paper (closed-form rigid
//!    fit) on the object's returns and their true partners;
//! 3. **ICP on the true object**: point-to-point ICP from the true motion, with only
//!    the object's own returns in both scans (a perfect segmentation and a perfect
//!    start; it settles where the returns of the two scans overlap best).
//!
//! Then the models themselves: CRF-Matching and the joint model with their shipped
//! weights. The exact association accuracy is over every return with a true
//! association (as `pgm eval association`).
//!
//! ```text
//! cargo run --release --example association_bound [-- --seed 7 --pairs 30]
//! ```
//! Defaults: seed 3 (the design seed of CRF-Matching and the joint model), 30 pairs per
//! preset, every simulator preset.

use pgm_crf_matching::Matcher;
use pgm_datasets::sim::{simulate_pairs, Preset, SimConfig};
use pgm_features::alignment::RigidAlignment;
use pgm_features::matching::ScanShape;
use pgm_features::{Association, ParamGuard, Pose2, ScanPair};
use pgm_joint::Joint;
use rayon::prelude::*;

/// Point-to-point ICP iterations of oracle 3.
const ICP_ITERATIONS: usize = 30;
/// Correspondences farther apart than this (m) are left out of oracle 3's ICP.
const ICP_DISTANCE: f64 = 0.3;

/// Correct and scored returns.
#[derive(Clone, Copy, Default)]
struct Count {
    correct: usize,
    scored: usize,
}

impl Count {
    fn add(&mut self, other: Count) {
        self.correct += other.correct;
        self.scored += other.scored;
    }

    fn percent(&self) -> f64 {
        100.0 * self.correct as f64 / self.scored.max(1) as f64
    }
}

/// The nearest reference surface point to `q` (its index among the valid returns).
fn nearest(reference: &ScanShape, q: &nalgebra::Point2<f64>) -> usize {
    (0..reference.len())
        .min_by(|&a, &b| {
            (reference.surface[a] - q)
                .norm_squared()
                .total_cmp(&(reference.surface[b] - q).norm_squared())
        })
        .unwrap_or(0)
}

/// The three oracles' counts and the two models' on one pair.
fn score_pair(pair: &ScanPair, joint: &Joint, matcher: &Matcher) -> [Count; 5] {
    let truth = pair
        .truth
        .as_ref()
        .expect("simulated pairs carry their truth");
    let associations = truth.associations.as_ref().expect("true associations");
    let labels = truth.labels.as_ref().expect("true labels");
    let reference_labels = truth.reference_labels.as_ref().expect("reference labels");
    let current = ScanShape::new(&pair.current);
    let reference = ScanShape::new(&pair.reference);
    let mut reference_index = vec![None; pair.reference.len()];
    for (j, &b) in reference.beams.iter().enumerate() {
        reference_index[b] = Some(j);
    }
    // The three oracle motions of every true object.
    let mut motions: Vec<(u32, [Pose2; 3])> = Vec::new();
    for object in &truth.motions {
        let own = |i: usize| labels[current.beams[i]] == Some(object.label);
        let mut fit = RigidAlignment::new();
        for i in (0..current.len()).filter(|&i| own(i)) {
            if let Some(Association::Point(b)) = associations[current.beams[i]] {
                if let Some(j) = reference_index[b] {
                    fit.add(&current.surface[i], &reference.surface[j], 1.0);
                }
            }
        }
        let fitted = fit.solve().map_or(object.motion, |a| a.motion);
        let sources: Vec<_> = (0..current.len())
            .filter(|&i| own(i))
            .map(|i| current.surface[i])
            .collect();
        let targets: Vec<_> = (0..reference.len())
            .filter(|&j| reference_labels[reference.beams[j]] == Some(object.label))
            .map(|j| reference.surface[j])
            .collect();
        let mut icp = object.motion;
        if !targets.is_empty() && sources.len() >= 3 {
            for _ in 0..ICP_ITERATIONS {
                let mut step = RigidAlignment::new();
                for s in &sources {
                    let q = icp.transform_point(s);
                    let g = targets
                        .iter()
                        .min_by(|a, b| (*a - q).norm().total_cmp(&(*b - q).norm()))
                        .expect("targets is not empty");
                    if (g - q).norm() < ICP_DISTANCE {
                        step.add(s, g, 1.0);
                    }
                }
                match step.solve() {
                    Some(a) => icp = a.motion,
                    None => break,
                }
            }
        }
        motions.push((object.label, [object.motion, fitted, icp]));
    }
    let mut counts = [Count::default(); 5];
    for (i, &b) in current.beams.iter().enumerate() {
        let (Some(truth_i), Some(label)) = (associations[b], labels[b]) else {
            continue;
        };
        let oracle = motions.iter().find(|(l, _)| *l == label).map(|(_, m)| m);
        for (k, count) in counts.iter_mut().enumerate().take(3) {
            count.scored += 1;
            let correct = match (truth_i, oracle) {
                (Association::Outlier, _) => true,
                (Association::Point(t), Some(m)) => {
                    let q = m[k].transform_point(&current.surface[i]);
                    reference.beams[nearest(&reference, &q)] == t
                }
                (Association::Point(_), None) => false,
            };
            count.correct += usize::from(correct);
        }
    }
    let joint = joint
        .estimate(pair)
        .expect("the joint model runs on simulated pairs");
    let matching = matcher
        .match_pair(pair)
        .expect("CRF-Matching runs on simulated pairs");
    for (k, predicted) in [(3, &joint.associations), (4, &matching.associations)] {
        for (t, p) in associations.iter().zip(predicted) {
            if let Some(t) = t {
                counts[k].scored += 1;
                counts[k].correct += usize::from(p.as_ref() == Some(t));
            }
        }
    }
    counts
}

fn main() {
    let mut seed = 3u64;
    let mut pairs = 30usize;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let value = args.next();
        let parsed = value.as_deref().and_then(|v| v.parse::<u64>().ok());
        match (arg.as_str(), parsed) {
            ("--seed", Some(v)) => seed = v,
            ("--pairs", Some(v)) if v > 0 => pairs = v as usize,
            _ => {
                eprintln!(
                    "association_bound: unknown argument or bad value `{arg} {}` (use --seed S --pairs N)",
                    value.unwrap_or_default()
                );
                std::process::exit(2);
            }
        }
    }
    let joint = Joint::default();
    let matcher = Matcher::default();
    println!(
        "Association accuracy (exact, %), simulated pairs: {pairs} per preset, seed {seed}; oracles decide every outlier perfectly"
    );
    println!(
        "{:<14} {:>12} {:>14} {:>12} {:>8} {:>8}",
        "preset", "true motion", "fit to truth", "ICP on obj.", "joint", "CRF-M"
    );
    let mut all = [Count::default(); 5];
    for preset in Preset::ALL {
        let config = SimConfig {
            preset,
            ..SimConfig::default()
        }
        .check()
        .expect("the default configuration is valid");
        let simulated = simulate_pairs(&config, seed, pairs);
        let counts = simulated
            .par_iter()
            .map(|p| score_pair(p, &joint, &matcher))
            .reduce(
                || [Count::default(); 5],
                |mut a, b| {
                    for (x, y) in a.iter_mut().zip(b) {
                        x.add(y);
                    }
                    a
                },
            );
        for (x, y) in all.iter_mut().zip(counts) {
            x.add(y);
        }
        let c: Vec<f64> = counts.iter().map(Count::percent).collect();
        println!(
            "{:<14} {:>12.1} {:>14.1} {:>12.1} {:>8.1} {:>8.1}",
            preset.name(),
            c[0],
            c[1],
            c[2],
            c[3],
            c[4]
        );
    }
    let c: Vec<f64> = all.iter().map(Count::percent).collect();
    println!(
        "{:<14} {:>12.1} {:>14.1} {:>12.1} {:>8.1} {:>8.1}",
        "all", c[0], c[1], c[2], c[3], c[4]
    );
}
