//! Diagnostics of CRF-Clustering on simulated pairs (development aid): per pair the
//! V-measure, the true objects (points, associated points, motion size) and which
//! were found, plus an "oracle" V-measure upper bound where objects whose points have
//! no association (or fewer than the minimum) are labelled background.
//!
//! Run: `cargo run --release -p pgm-tools --bin analyse_clustering -- [seed] [pairs] [true|icp|segment] [preset]`.

use pgm_crf_clustering::{ClusteringParams, DetectionParams};
use pgm_datasets::metrics::clustering_v_measure;
use pgm_datasets::sim::{simulate_pairs, SimConfig};
use pgm_datasets::Association;
use pgm_eval::evaluate_clustering_pair;
use pgm_scan::association::{
    AssociationSource, GroundTruthAssociations, NearestAfterIcp, SegmentIcp,
};
use pgm_scan::methods::Associated;
use pgm_scan::ParamGuard;
use std::sync::Arc;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1);
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(50);
    let which = args.get(3).map(String::as_str).unwrap_or("true");
    let preset = args.get(4).map(String::as_str).unwrap_or("mixed");
    let config = SimConfig {
        preset: preset.parse().expect("preset"),
        ..SimConfig::default()
    }
    .check()
    .expect("config");
    let pairs = simulate_pairs(&config, seed, n);
    let associations: Arc<dyn AssociationSource> = match which {
        "true" => Arc::new(GroundTruthAssociations),
        "icp" => Arc::new(NearestAfterIcp::default()),
        _ => Arc::new(SegmentIcp::default()),
    };
    let min_points: usize = std::env::var("MIN_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let clusterer = ClusteringParams {
        detection: DetectionParams {
            min_object_points: min_points,
            ..DetectionParams::default()
        },
        ..Default::default()
    }
    .check()
    .unwrap();
    let eval = Associated::new(clusterer, associations.clone());
    let (mut sum, mut oracle_sum) = (0.0, 0.0);
    for pair in &pairs {
        let out = evaluate_clustering_pair(pair, &eval).expect("evaluates");
        let truth = pair.truth.as_ref().unwrap();
        let labels = truth.labels.as_ref().unwrap();
        let assoc = associations.associate(pair).unwrap().associations;
        // Oracle: objects with < 3 associated points become background.
        let mut oracle = labels.clone();
        let mut desc = Vec::new();
        for m in truth.motions.iter().filter(|m| m.label > 0) {
            let members: Vec<usize> = (0..labels.len())
                .filter(|&k| labels[k] == Some(m.label))
                .collect();
            if members.is_empty() {
                continue;
            }
            let associated = members
                .iter()
                .filter(|&&k| matches!(assoc[k], Some(Association::Point(_))))
                .count();
            let ego = truth.ego_motion.unwrap_or_default();
            let c = members.iter().fold(nalgebra::Vector2::zeros(), |a, &k| {
                a + pair.current.beam_point(k).coords
            }) / members.len() as f64;
            let cp = nalgebra::Point2::from(c);
            let disp = (m.motion.transform_point(&cp) - ego.transform_point(&cp)).norm();
            let found = out
                .labels
                .iter()
                .enumerate()
                .filter(|(k, l)| labels[*k] == Some(m.label) && l.is_some_and(|l| l > 0))
                .count();
            if associated < min_points {
                for &k in &members {
                    oracle[k] = Some(0);
                }
            }
            desc.push(format!(
                "{}:{} n{} a{} d{:.2} hit{}",
                m.label,
                m.kind,
                members.len(),
                associated,
                disp,
                found
            ));
        }
        let true_assoc = truth.associations.clone().unwrap_or_default();
        let near = |k: usize| match (assoc[k], true_assoc.get(k).copied().flatten()) {
            (Some(Association::Point(a)), Some(Association::Point(b))) => {
                pair.reference
                    .beam_point(a)
                    .coords
                    .metric_distance(&pair.reference.beam_point(b).coords)
                    < 0.5
            }
            _ => false,
        };
        let bg_wrong = (0..labels.len())
            .filter(|&k| {
                labels[k] == Some(0) && matches!(assoc[k], Some(Association::Point(_))) && !near(k)
            })
            .count();
        let obj_right = (0..labels.len())
            .filter(|&k| labels[k].is_some_and(|l| l > 0) && near(k))
            .count();
        desc.push(format!("bg_wrong {bg_wrong} obj_right {obj_right}"));
        let ov = clustering_v_measure(labels, &oracle, 1.0)
            .unwrap()
            .v_measure;
        let predicted = out
            .labels
            .iter()
            .flatten()
            .filter(|&&l| l > 0)
            .collect::<std::collections::BTreeSet<_>>()
            .len();
        sum += out.score.v_measure;
        oracle_sum += ov;
        let mut confusion: std::collections::BTreeMap<(u32, u32), usize> = Default::default();
        for (k, t) in labels.iter().enumerate() {
            if let (Some(t), Some(p)) = (t, out.labels[k]) {
                *confusion.entry((*t, p)).or_insert(0) += 1;
            }
        }
        let cells: Vec<String> = confusion
            .iter()
            .map(|((t, p), c)| format!("{t}>{p}:{c}"))
            .collect();
        println!(
            "{} V {:.3} (H {:.3} C {:.3}) oracle {:.3} pred {} | {} | {}",
            pair.name,
            out.score.v_measure,
            out.score.homogeneity,
            out.score.completeness,
            ov,
            predicted,
            desc.join("; "),
            cells.join(" ")
        );
    }
    println!(
        "mean V {:.3}, oracle {:.3}",
        sum / pairs.len() as f64,
        oracle_sum / pairs.len() as f64
    );
}
