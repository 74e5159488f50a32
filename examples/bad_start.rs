//! Scan matching from a bad start: the odometry prior of every pair is perturbed by a
//! random translation of up to 1 m and a random rotation of up to 30 degrees (uniform,
//! seeded), and each scan matcher runs from there. Printed: the share of pairs that end
//! within 0.1 m and 0.02 rad of the true ego-motion, for ICP, CRF-Matching and
//! `icp+csm` (correlative scan matching over the whole ±1 m, ±30° window, then ICP from
//! its hypotheses: `pgm_scan::correlative::CorrelativeIcpMatcher`) side by side, on
//! held-out simulated pairs (preset mixed, seed 7) and on the mit-csail pairs less than
//! 1.5 s apart (skipped without the shared data folder).
//!
//! Run: `cargo run --release --example bad_start [-- --pairs N --seed S]`.

use pgm::methods::{scan_matcher, MethodOptions};
use pgm_datasets::builders::{relation_pairs, RelationPairOptions};
use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_datasets::{carmen, relations, testdata, ParamGuard, ScanPair};
use pgm_scan::correlative::CorrelativeIcpMatcher;
use pgm_scan::methods::ScanMatcher;
use pgm_scan::Pose2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::process::ExitCode;

/// The pairs with their prior moved by up to `translation` metres and `rotation`
/// radians (uniform in a disc and an interval), seeded.
fn perturbed(pairs: &[ScanPair], seed: u64, translation: f64, rotation: f64) -> Vec<ScanPair> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    pairs
        .iter()
        .map(|p| {
            let r = translation * rng.random::<f64>().sqrt();
            let a = std::f64::consts::TAU * rng.random::<f64>();
            let t = rotation * (2.0 * rng.random::<f64>() - 1.0);
            let prior = p.odometry.unwrap_or_default();
            let mut q = p.clone();
            q.odometry = Some(Pose2::new(
                prior.x() + r * a.cos(),
                prior.y() + r * a.sin(),
                prior.theta() + t,
            ));
            q
        })
        .collect()
}

/// The matcher called `method`: a registered one, or `icp+csm`.
fn matcher(method: &str) -> Result<Box<dyn ScanMatcher>, String> {
    if method == "icp+csm" {
        return Ok(Box::new(CorrelativeIcpMatcher::default()));
    }
    scan_matcher(method, &MethodOptions::default()).map_err(|e| e.to_string())
}

/// Share of pairs whose estimate lies within 0.1 m and 0.02 rad of the truth.
fn success(pairs: &[ScanPair], method: &str) -> Result<f64, String> {
    let matcher = matcher(method)?;
    let ok: usize = pairs
        .par_iter()
        .map(|p| {
            let truth = p.truth.as_ref().and_then(|t| t.ego_motion).expect("truth");
            let e = matcher
                .estimate(p)
                .map(|e| e.motion)
                .unwrap_or(p.odometry.unwrap_or_default());
            usize::from(e.translation_error(&truth) <= 0.1 && e.rotation_error(&truth) <= 0.02)
        })
        .sum();
    Ok(ok as f64 / pairs.len() as f64)
}

fn arg(name: &str, default: u64) -> u64 {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() -> ExitCode {
    let n = arg("--pairs", 50) as usize;
    let seed = arg("--seed", 7);
    let mut sets: Vec<(String, Vec<ScanPair>)> = Vec::new();
    match SimConfig::default().check() {
        Ok(c) => sets.push((
            format!("simulated, preset mixed, seed {seed}, {n} pairs"),
            simulate_pairs(&c, seed, n),
        )),
        Err(e) => {
            eprintln!("bad_start: {e}");
            return ExitCode::from(2);
        }
    }
    if let Some(dir) = testdata::shared_data_dir() {
        let dir = dir.join("mit-csail");
        let loaded = carmen::read_carmen(dir.join("mit-csail.clf")).and_then(|log| {
            relations::read_relations(dir.join("mit-csail.relations"))
                .map(|r| relation_pairs(&log, &r, &RelationPairOptions::default()).pairs)
        });
        match loaded {
            Ok(pairs) => {
                let near: Vec<ScanPair> = pairs
                    .into_iter()
                    .filter(|p| p.time_gap().abs() < 1.5)
                    .collect();
                sets.push((
                    format!("mit-csail, {} pairs < 1.5 s apart", near.len()),
                    near,
                ));
            }
            Err(e) => {
                eprintln!("bad_start: mit-csail: {e}");
                return ExitCode::from(2);
            }
        }
    } else {
        println!("(mit-csail skipped: shared data folder not found)");
    }
    println!("prior perturbed by up to 1 m and 30 degrees (perturbation seed {seed}); share of pairs ending within 0.1 m and 0.02 rad");
    for (name, pairs) in &sets {
        let bad = perturbed(pairs, seed, 1.0, 30f64.to_radians());
        let mut row = format!("{name:<45}");
        for method in ["icp", "crf-matching", "icp+csm"] {
            match success(&bad, method) {
                Ok(s) => row += &format!("  {method} {:.1} %", 100.0 * s),
                Err(e) => {
                    eprintln!("bad_start: {method}: {e}");
                    return ExitCode::from(2);
                }
            }
        }
        println!("{row}");
    }
    ExitCode::SUCCESS
}
