//! Scan matching on the real logs against their ground truth (issue 5 targets).
//!
//! Reads `../shared/data` beside the workspace (or `$PGM_SHARED_DATA`); skipped with a
//! note when the folder is missing, a failure when `CI=true`
//! (`pgm_datasets::testdata::shared_data_dir`).
//!
//! Targets (an independent plain ICP reaches them): mit-csail pairs less than 1.5 s
//! apart, ICP from odometry: rotation median ≤ 0.005 rad (odometry alone: about
//! 0.032) and translation median ≤ 0.025 m; intel-lab consecutive pairs, ICP from the
//! identity (the log has no independent odometry): ≤ 0.025 m and ≤ 0.006 rad.
//! CRF-Matching (issue 14): medians no worse than ICP's on both sets.

mod common;

use common::fixtures::mit_csail_near_pairs;
use pgm_datasets::builders::consecutive_pairs;
use pgm_datasets::metrics::{motion_error, summarize_errors, ErrorSummary, MotionError};
use pgm_datasets::{carmen, testdata, ScanPair};
use pgm_eval::evaluate_matching;
use pgm_scan::registration::IcpMatcher;

fn icp_errors(pairs: &[ScanPair]) -> ErrorSummary {
    let report = evaluate_matching(pairs, &IcpMatcher::default(), None).expect("pairs");
    assert_eq!(
        report.not_converged,
        report.outcomes.iter().filter(|o| !o.converged).count()
    );
    report.all
}

/// CRF-Matching's ego-motion errors (issue 14: no worse than ICP's medians).
fn crf_matching_errors(pairs: &[ScanPair]) -> ErrorSummary {
    evaluate_matching(pairs, &pgm_crf_matching::Matcher::default(), None)
        .expect("pairs")
        .all
}

fn odometry_errors(pairs: &[ScanPair]) -> ErrorSummary {
    let errors: Vec<MotionError> = pairs
        .iter()
        .map(|p| {
            let truth = p
                .truth
                .as_ref()
                .and_then(|t| t.ego_motion)
                .expect("ground truth");
            motion_error(&p.odometry.expect("odometry prior"), &truth)
        })
        .collect();
    summarize_errors(&errors).expect("pairs")
}

#[test]
fn mit_csail_near_pairs_meet_the_targets() {
    let Some(near) = mit_csail_near_pairs() else {
        return;
    };
    assert!(near.len() > 1000, "{} near pairs", near.len());
    let odometry = odometry_errors(&near);
    eprintln!("mit-csail near, odometry: {odometry:?}");
    assert!(
        (0.025..0.04).contains(&odometry.rotation_median),
        "odometry rotation median {} (data README: 0.032)",
        odometry.rotation_median
    );
    let icp = icp_errors(&near);
    eprintln!("mit-csail near, ICP: {icp:?}");
    assert!(icp.rotation_median <= 0.005, "{icp:?}");
    assert!(icp.translation_median <= 0.025, "{icp:?}");
    let crf = crf_matching_errors(&near);
    eprintln!("mit-csail near, CRF-Matching: {crf:?}");
    assert!(crf.translation_median <= icp.translation_median, "{crf:?}");
    assert!(crf.rotation_median <= icp.rotation_median, "{crf:?}");
}

#[test]
fn intel_lab_consecutive_pairs_meet_the_targets() {
    let Some(data) = testdata::shared_data_dir() else {
        return;
    };
    let log = carmen::read_carmen(data.join("intel-lab/intel-lab.log")).expect("log");
    let built = consecutive_pairs(&log, "intel-lab");
    assert_eq!(built.pairs.len(), 2671);
    assert!(built.pairs.iter().all(|p| p.odometry.is_none()));
    let icp = icp_errors(&built.pairs);
    eprintln!("intel-lab consecutive, ICP: {icp:?}");
    assert!(icp.translation_median <= 0.025, "{icp:?}");
    assert!(icp.rotation_median <= 0.006, "{icp:?}");
    let crf = crf_matching_errors(&built.pairs);
    eprintln!("intel-lab consecutive, CRF-Matching: {crf:?}");
    assert!(crf.translation_median <= icp.translation_median, "{crf:?}");
    assert!(crf.rotation_median <= icp.rotation_median, "{crf:?}");
}
