//! Scan matching from a bad start (issue 14): every pair's odometry prior moved by up to
//! 1 m and 30 degrees (seeded); CRF-Matching must end within 0.1 m and 0.02 rad of the
//! true ego-motion on at least 90 % of the pairs, on simulated pairs and on mit-csail
//! pairs less than 1.5 s apart (the latter reads `../shared/data`: skipped with a note
//! when it is missing, a failure when `CI=true`). Plain ICP from the same priors is
//! printed beside it and must do clearly worse on the simulated pairs.

mod common;

use common::fixtures::{mit_csail_near_pairs, perturb};
use pgm::methods::{scan_matcher, MethodOptions};
use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_datasets::{ParamGuard, ScanPair};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The pairs with their prior moved by up to 1 m (uniform in the disc) and 30 degrees.
fn perturbed(pairs: &[ScanPair], seed: u64) -> Vec<ScanPair> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    pairs
        .iter()
        .map(|p| {
            let mut q = p.clone();
            q.odometry = Some(perturb(p.odometry.unwrap_or_default(), &mut rng));
            q
        })
        .collect()
}

/// Share of pairs whose estimate lies within 0.1 m and 0.02 rad of the truth.
fn success(pairs: &[ScanPair], method: &str) -> f64 {
    let matcher = scan_matcher(method, &MethodOptions::default()).unwrap();
    let ok: usize = pairs
        .par_iter()
        .map(|p| {
            let truth = p.truth.as_ref().unwrap().ego_motion.unwrap();
            let e = matcher.estimate(p).unwrap().motion;
            usize::from(e.translation_error(&truth) <= 0.1 && e.rotation_error(&truth) <= 0.02)
        })
        .sum();
    ok as f64 / pairs.len() as f64
}

#[test]
fn crf_matching_recovers_from_bad_priors_on_simulated_pairs() {
    let pairs = simulate_pairs(&SimConfig::default().check().unwrap(), 11, 20);
    let bad = perturbed(&pairs, 5);
    let (crf, icp) = (success(&bad, "crf-matching"), success(&bad, "icp"));
    eprintln!("simulated, bad start: CRF-Matching {crf:.2}, ICP {icp:.2}");
    assert!(crf >= 0.9, "CRF-Matching {crf}");
    assert!(icp <= crf - 0.3, "ICP {icp} vs CRF-Matching {crf}");
}

#[test]
fn crf_matching_recovers_from_bad_priors_on_mit_csail() {
    let Some(near) = mit_csail_near_pairs() else {
        return;
    };
    let near: Vec<ScanPair> = near.into_iter().step_by(4).collect();
    assert!(near.len() > 250, "{} pairs", near.len());
    let bad = perturbed(&near, 5);
    let crf = success(&bad, "crf-matching");
    eprintln!("mit-csail near (every 4th), bad start: CRF-Matching {crf:.3}");
    assert!(crf >= 0.9, "CRF-Matching {crf}");
}
