//! Diagnostics of CRF-Clustering and CBD on leigh-gtm1 pairs (development aid): per
//! pair the V-measure of each method, the true moving people (label, returns) and the
//! predicted moving objects (returns, how many of them are true mover returns).
//!
//! Run: `cargo run --release -p pgm-tools --bin analyse_leigh -- [DATA_DIR] [k] [icp|segment]`
//! (`DATA_DIR` defaults to `../shared/data/leigh-gtm1`). The last lines sum V per
//! kind of pair: no labelled mover, a walker, standing people only (see the
//! `leigh_labels` example of pgm-datasets).
//!
//! Environment overrides (experiments only): `MAX_CLUSTERS`, `SEGMENT_GAP`,
//! `MIN_POINTS`, `MIN_DISP`, `MIN_FREE`, `FREE_MARGIN`, `MERGE`, `CHI2` (clusterer),
//! `STATIC_TOL`, `GATE` (associations), `SECTOR=1` (score the annotated sector),
//! `NOPRIOR=1` (hide the odometry prior from the methods), `DETAIL=1` (per true
//! mover: associated returns, partner distance, free-space count), `ORACLE=1` (the
//! CRF gets oracle associations for every person annotated in both scans: an upper
//! bound for any better association source, CRF-Matching included).

use pgm_baselines::consistency::ConsistencyDetector;
use pgm_crf_clustering::{ClusteringParams, DetectionParams};
use pgm_datasets::builders::{leigh_pairs, LeighPairOptions};
use pgm_datasets::leigh;
use pgm_eval::evaluate_clustering_pair;
use pgm_scan::association::{
    AssociationSource, GroundTruthAssociations, NearestParams, SegmentIcp,
};
use pgm_scan::methods::Associated;
use pgm_scan::ParamGuard;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

fn describe(
    pair: &pgm_datasets::ScanPair,
    centres: &[nalgebra::Point2<f64>],
    truth: &[Option<u32>],
    labels: &[Option<u32>],
) -> String {
    let mut objects: BTreeMap<u32, (usize, usize, nalgebra::Vector2<f64>)> = BTreeMap::new();
    for (k, (t, p)) in truth.iter().zip(labels).enumerate() {
        if let (Some(t), Some(p)) = (t, p) {
            if *p > 0 {
                let e = objects
                    .entry(*p)
                    .or_insert((0, 0, nalgebra::Vector2::zeros()));
                e.0 += 1;
                e.1 += usize::from(*t > 0);
                e.2 += pair.current.beam_point(k).coords;
            }
        }
    }
    objects
        .iter()
        .map(|(l, (n, hit, sum))| {
            let c = nalgebra::Point2::from(sum / *n as f64);
            let person = centres
                .iter()
                .map(|p| (p - c).norm())
                .fold(f64::INFINITY, f64::min);
            format!("{l}:{n}/{hit}@{:.1}m,p{:.1}", c.coords.norm(), person)
        })
        .collect::<Vec<_>>()
        .join(" ")
}

fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// Default parameters with overrides from the environment (experiments only).
fn params() -> ClusteringParams {
    let d = ClusteringParams::default();
    let e = DetectionParams::default();
    ClusteringParams {
        max_clusters: env("MAX_CLUSTERS", d.max_clusters),
        segment_gap: env("SEGMENT_GAP", d.segment_gap),
        merge_threshold: env("MERGE", d.merge_threshold),
        detection: DetectionParams {
            min_object_points: env("MIN_POINTS", e.min_object_points),
            min_object_displacement: env("MIN_DISP", e.min_object_displacement),
            min_free_fraction: env("MIN_FREE", e.min_free_fraction),
            free_space_margin: env("FREE_MARGIN", e.free_space_margin),
            min_object_chi2: env("CHI2", e.min_object_chi2),
            ..e
        },
        ..d
    }
}

/// Per true mover: returns, associated returns, mean partner distance under the ICP
/// ego-motion, fraction in the reference's free space; and the background's median.
fn detail(pair: &pgm_datasets::ScanPair, truth: &[Option<u32>], source: &dyn AssociationSource) {
    let a = source.associate(pair).expect("associations");
    let ego = a.ego_motion.unwrap_or_default();
    let dist = |k: usize| match a.associations[k] {
        Some(pgm_datasets::Association::Point(r)) => Some(
            (ego.transform_point(&pair.current.beam_point(k)) - pair.reference.beam_point(r))
                .norm(),
        ),
        _ => None,
    };
    let mut bg: Vec<f64> = (0..truth.len())
        .filter(|&k| truth[k] == Some(0))
        .filter_map(dist)
        .collect();
    bg.sort_by(f64::total_cmp);
    let labels: std::collections::BTreeSet<u32> =
        truth.iter().flatten().copied().filter(|&l| l > 0).collect();
    let mut out = vec![format!(
        "bg median {:.3} p90 {:.3}",
        bg.get(bg.len() / 2).copied().unwrap_or(f64::NAN),
        bg.get(bg.len() * 9 / 10).copied().unwrap_or(f64::NAN)
    )];
    for l in labels {
        let members: Vec<usize> = (0..truth.len()).filter(|&k| truth[k] == Some(l)).collect();
        let d: Vec<f64> = members.iter().filter_map(|&k| dist(k)).collect();
        let free = members
            .iter()
            .filter(|&&k| {
                pair.reference
                    .in_free_space(&ego.transform_point(&pair.current.beam_point(k)), 0.3)
            })
            .count();
        let r = members.iter().map(|&k| pair.current.ranges[k]).sum::<f64>() / members.len() as f64;
        out.push(format!(
            "mover {l}: n {} assoc {} mean d {:.2} free {} range {:.1}",
            members.len(),
            d.len(),
            d.iter().sum::<f64>() / d.len().max(1) as f64,
            free,
            r
        ));
    }
    println!("  {}", out.join(" | "));
}

/// Oracle person associations (upper bound for a better association source): the
/// automatic associations, except that the returns of a person annotated in both
/// scans take the reference return nearest to where the annotated displacement puts
/// them (within 0.3 m; else outliers).
fn oracle(
    pair: &mut pgm_datasets::ScanPair,
    people: &[leigh::PersonAnnotation],
    source: &dyn AssociationSource,
) {
    let a = source.associate(pair).expect("associations");
    let ego = a.ego_motion.unwrap_or_default();
    let mut out = a.associations;
    let mut ij = pair.name.rsplit(':').next().unwrap().split('-');
    let i: usize = ij.next().unwrap().parse().unwrap();
    let j: usize = ij.next().unwrap().parse().unwrap();
    let (refs, beams) = pair.reference.points();
    for cur in people.iter().filter(|p| p.scan == j) {
        let Some(old) = people
            .iter()
            .find(|p| p.scan == i && p.person == cur.person)
        else {
            continue;
        };
        for k in (0..pair.current.len()).filter(|&k| pair.current.valid[k]) {
            let p = pair.current.beam_point(k);
            if (p - cur.centre).norm() > 0.35 {
                continue;
            }
            let q = old.centre + ego.isometry().rotation * (p - cur.centre);
            let best = refs
                .iter()
                .zip(&beams)
                .map(|(r, &b)| ((r - q).norm(), b))
                .min_by(|x, y| x.0.total_cmp(&y.0));
            out[k] = Some(match best {
                Some((d, b)) if d <= 0.3 => pgm_datasets::Association::Point(b),
                _ => pgm_datasets::Association::Outlier,
            });
        }
    }
    pair.truth.as_mut().unwrap().associations = Some(out);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = PathBuf::from(
        args.get(1)
            .cloned()
            .unwrap_or_else(|| "../shared/data/leigh-gtm1".into()),
    );
    let k: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let associations: Arc<dyn AssociationSource> = match args.get(3).map(String::as_str) {
        Some("segment") => Arc::new(SegmentIcp::default()),
        _ => Arc::new(
            NearestParams {
                static_tolerance: Some(env("STATIC_TOL", -1.0)).filter(|&t| t >= 0.0),
                gate: env("GATE", 1.0),
                ..NearestParams::default()
            }
            .check()
            .expect("valid association parameters"),
        ),
    };
    let mut log = leigh::read_scans(dir.join("scans.txt")).expect("scans");
    let odometry = dir.join("odom_at_scan.txt");
    let odo = leigh::read_odometry(&odometry).expect("odometry");
    leigh::attach_odometry(&mut log, &odo, &odometry).expect("attach");
    let people = leigh::read_people(dir.join("people_gt.txt")).expect("people");
    let pairs = leigh_pairs(
        &log,
        &people,
        &LeighPairOptions {
            k,
            annotated_sector: env("SECTOR", 0) == 1,
            ..Default::default()
        },
    )
    .expect("pairs");
    let cbd = ConsistencyDetector::default();
    let (mut s_crf, mut s_cbd) = (0.0, 0.0);
    // Pairs by what their labelled movers do over their whole tracks (see the
    // `leigh_labels` example of pgm-datasets): kind -> (pairs, CRF sum, CBD sum).
    let tracks =
        pgm_datasets::builders::leigh_track_displacements(&log, &people, k).expect("tracks");
    let defaults = LeighPairOptions::default();
    let mut kinds: BTreeMap<&str, (usize, f64, f64)> = BTreeMap::new();
    let mut pairs = pairs;
    if env("NOPRIOR", 0) == 1 {
        for p in &mut pairs {
            p.odometry = None;
        }
    }
    if env("ORACLE", 0) == 1 {
        for pair in &mut pairs {
            oracle(pair, &people, associations.as_ref());
        }
    }
    let associations: Arc<dyn AssociationSource> = if env("ORACLE", 0) == 1 {
        Arc::new(GroundTruthAssociations)
    } else {
        associations
    };
    let crf = Associated::new(params().check().unwrap(), associations.clone());
    for pair in &pairs {
        let truth = pair.truth.as_ref().unwrap().labels.as_ref().unwrap();
        let mut movers: BTreeMap<u32, usize> = BTreeMap::new();
        for l in truth.iter().flatten().filter(|&&l| l > 0) {
            *movers.entry(*l).or_default() += 1;
        }
        if std::env::var("DETAIL").is_ok() {
            detail(pair, truth, associations.as_ref());
        }
        let j: usize = pair
            .name
            .rsplit('-')
            .next()
            .and_then(|s| s.parse().ok())
            .unwrap();
        let centres: Vec<nalgebra::Point2<f64>> = people
            .iter()
            .filter(|p| p.scan == j)
            .map(|p| p.centre)
            .collect();
        let a = evaluate_clustering_pair(pair, &crf).expect("crf");
        let b = evaluate_clustering_pair(pair, &cbd).expect("cbd");
        s_crf += a.score.v_measure;
        s_cbd += b.score.v_measure;
        // Labelled movers: annotated people of scan j with a moving return near them.
        let walker = people
            .iter()
            .filter(|p| p.scan == j)
            .filter(|p| {
                truth.iter().enumerate().any(|(b, l)| {
                    l.is_some_and(|l| l > 0)
                        && (pair.current.beam_point(b) - p.centre).norm() <= defaults.person_radius
                })
            })
            .any(|p| tracks[&p.person].per_k_scans >= defaults.moving_threshold);
        let kind = if movers.is_empty() {
            "no labelled mover"
        } else if walker {
            "a walker"
        } else {
            "standing people only"
        };
        let e = kinds.entry(kind).or_default();
        e.0 += 1;
        e.1 += a.score.v_measure;
        e.2 += b.score.v_measure;
        println!(
            "{:<22} truth [{}] | CRF V {:.2} [{}] | CBD V {:.2} [{}]",
            pair.name,
            movers
                .iter()
                .map(|(l, n)| format!("{l}:{n}"))
                .collect::<Vec<_>>()
                .join(" "),
            a.score.v_measure,
            describe(pair, &centres, truth, &a.labels),
            b.score.v_measure,
            describe(pair, &centres, truth, &b.labels),
        );
    }
    for (kind, (count, crf, cbd)) in &kinds {
        println!("pairs with {kind}: {count}, V summed: CRF {crf:.2}, CBD {cbd:.2}");
    }
    let n = pairs.len() as f64;
    println!(
        "mean V: CRF {:.3}, CBD {:.3} ({} pairs)",
        s_crf / n,
        s_cbd / n,
        pairs.len()
    );
}
