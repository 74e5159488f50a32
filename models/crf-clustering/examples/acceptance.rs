//! Tuning aid for the acceptance of moving clusters
//! ([`ClusteringParams::min_object_chi2`]): mean V-measure of CRF-Clustering on
//! simulated pairs (presets mixed and pedestrians, seed 2, true and segment-ICP
//! associations) and on leigh-gtm1 k = 5 (ICP associations) split at scan 270
//! (tune on the first half only; the second half, the held-out report, is printed
//! only with `--held-out`).
//!
//! Run: `cargo run --release -p pgm-crf-clustering --example acceptance -- 0 8 16 32 [--held-out]`
//! (each argument one threshold; needs the shared data folder for the leigh rows).

use pgm_crf_clustering::evaluation::{evaluate_pair, EvaluationConfig, Method};
use pgm_crf_clustering::{AssociationSource, ClusteringParams, NearestParams};
use pgm_datasets::builders::{leigh_pairs, LeighPairOptions};
use pgm_datasets::sim::{simulate_pairs, Preset, SimConfig};
use pgm_datasets::{leigh, testdata, ScanPair};

fn mean_v(pairs: &[&ScanPair], chi2: f64, associations: AssociationSource) -> f64 {
    let clusterer = ClusteringParams {
        min_free_fraction: chi2,
        ..Default::default()
    }
    .check()
    .expect("valid threshold");
    let config = EvaluationConfig {
        method: Method::Crf,
        associations,
        clusterer,
        kmeans: Default::default(),
        cbd: Default::default(),
    };
    let sum: f64 = pairs
        .iter()
        .map(|p| {
            evaluate_pair(p, &config)
                .map(|r| r.score.v_measure)
                .unwrap_or(0.0)
        })
        .sum();
    sum / pairs.len().max(1) as f64
}

fn first_scan(name: &str) -> Option<usize> {
    name.rsplit(':').next()?.split('-').next()?.parse().ok()
}

fn main() {
    let held_out = std::env::args().any(|a| a == "--held-out");
    let thresholds: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let mut sims = Vec::new();
    for preset in [Preset::Mixed, Preset::Pedestrians] {
        let config = SimConfig {
            preset,
            ..SimConfig::default()
        }
        .check()
        .expect("config");
        sims.push((preset.name(), simulate_pairs(&config, 2, 40)));
    }
    let leigh_pairs_k5 = testdata::shared_data_dir().and_then(|dir| {
        let base = dir.join("leigh-gtm1");
        let mut log = leigh::read_scans(base.join("scans.txt")).ok()?;
        let odometry = base.join("odom_at_scan.txt");
        let odo = leigh::read_odometry(&odometry).ok()?;
        leigh::attach_odometry(&mut log, &odo, &odometry).ok()?;
        let people = leigh::read_people(base.join("people_gt.txt")).ok()?;
        leigh_pairs(&log, &people, &LeighPairOptions::default()).ok()
    });
    let leigh = leigh_pairs_k5.unwrap_or_default();
    let first: Vec<&ScanPair> = leigh
        .iter()
        .filter(|p| first_scan(&p.name).is_some_and(|i| i < 270))
        .collect();
    let second: Vec<&ScanPair> = leigh
        .iter()
        .filter(|p| first_scan(&p.name).is_none_or(|i| i >= 270))
        .collect();
    let all: Vec<&ScanPair> = leigh.iter().collect();
    if std::env::args().any(|a| a == "--diagnose") {
        diagnose(&first);
        return;
    }
    println!(
        "free   sim-mixed-T sim-mixed-seg sim-ped-T sim-ped-seg  leigh<270 ({})  leigh>=270 ({})  leigh-all ({})",
        first.len(),
        second.len(),
        all.len()
    );
    let icp = AssociationSource::NearestAfterIcp(NearestParams::default());
    for &t in &thresholds {
        let mut row = format!("{t:<6}");
        for (_, pairs) in &sims {
            let refs: Vec<&ScanPair> = pairs.iter().collect();
            for a in [
                AssociationSource::GroundTruth,
                AssociationSource::automatic(),
            ] {
                row += &format!(" {:.4}", mean_v(&refs, t, a));
            }
        }
        row += &format!(" {:.4}", mean_v(&first, t, icp));
        if held_out {
            for set in [&second, &all] {
                row += &format!(" {:.4}", mean_v(set, t, icp));
            }
        }
        println!("{row}");
    }
}

/// Prints the objects found on the first-half leigh pairs (diagnostics).
fn diagnose(pairs: &[&ScanPair]) {
    use pgm_crf_clustering::{AssociationProvider, Clusterer};
    let icp = AssociationSource::NearestAfterIcp(NearestParams::default());
    for pair in pairs {
        let Ok(a) = icp.associate(pair) else { continue };
        let Ok(r) = Clusterer::default().cluster_pair(pair, &a) else {
            continue;
        };
        let truth_objects = pair
            .truth
            .as_ref()
            .and_then(|t| t.labels.as_ref())
            .map_or(0, |l| l.iter().flatten().filter(|&&x| x > 0).count());
        for c in r.clusters.iter().skip(1) {
            let mut beams: Vec<usize> = (0..r.labels.len())
                .filter(|&b| r.labels[b] == Some(c.label))
                .collect();
            beams.truncate(1);
            println!(
                "{} truth-moving-points {} object pts {} disp {:.2} first beam {:?}",
                pair.name, truth_objects, c.points, c.displacement, beams
            );
        }
    }
}
