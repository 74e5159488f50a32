//! Features, segmentation, merging and background selection on hand-made inputs.

use nalgebra::Point2;
use pgm_core::learning::Weights;
use pgm_crf_clustering::segmentation::initial_clusters;
use pgm_crf_clustering::weights::{feature_set, DEFAULT_WEIGHTS_JSON};
use pgm_crf_clustering::{
    BackgroundChoice, Clusterer, ClusteringInput, ClusteringParams, ClusteringWeights,
    DetectionParams,
};
use pgm_features::clustering_features::{
    association_variance, distance_feature, stiffness_feature, weighted_neighbour_feature,
};
use pgm_scan::scan::segment_by_gap;
use pgm_scan::{ParamGuard, Pose2};

/// Points on a wall at y = 5 (x from -6 to 6, 5 cm apart) and a 0.6 m object at
/// x in [1, 1.6], y = 3, as current-scan points; the wall moves with `ego`, the object
/// with `object`.
fn scene(ego: Pose2, object: Pose2) -> (ClusteringInput, Vec<bool>) {
    let mut points = Vec::new();
    let mut is_object = Vec::new();
    // Sorted by bearing: the object (in front of the wall) interrupts the wall.
    let mut all: Vec<(Point2<f64>, bool)> = (0..=240)
        .map(|i| (Point2::new(-6.0 + 0.05 * i as f64, 5.0), false))
        .collect();
    all.extend((0..=12).map(|i| (Point2::new(1.0 + 0.05 * i as f64, 3.0), true)));
    all.retain(|(p, obj)| {
        *obj || !(p.y.atan2(p.x) < 3.0f64.atan2(1.0) && p.y.atan2(p.x) > 3.0f64.atan2(1.6))
    });
    all.sort_by(|a, b| b.0.y.atan2(b.0.x).total_cmp(&a.0.y.atan2(a.0.x)).reverse());
    let mut partners = Vec::new();
    for (p, obj) in all {
        let m = if obj { object } else { ego };
        partners.push(Some(m.transform_point(&p)));
        points.push(p);
        is_object.push(obj);
    }
    let n = points.len();
    let variances = points
        .iter()
        .map(|p| association_variance(p.coords.norm(), 0.01))
        .collect();
    (
        ClusteringInput {
            beams: (0..n).collect(),
            beam_count: n,
            points,
            partners,
            variances,
            odometry: None,
            scans: None,
            ego_motion: None,
        },
        is_object,
    )
}

#[test]
fn features_match_hand_computed_values() {
    let m = Pose2::new(0.5, -1.0, 0.0);
    let s = Point2::new(1.0, 1.0);
    // (1.5, 0) − (1, 0) → 0.25.
    assert!((distance_feature(&m, &s, &Point2::new(1.0, 0.0)) - 0.25).abs() < 1e-12);
    // Pure translations keep the vector between two points: stiffness 0 within one
    // cluster; across the identity and m it is ‖T‖² = 1.25.
    let t = Point2::new(2.0, 3.0);
    assert!(stiffness_feature(&m, &m, &s, &t).abs() < 1e-12);
    assert!((stiffness_feature(&m, &Pose2::identity(), &s, &t) - 1.25).abs() < 1e-12);
    assert_eq!(
        weighted_neighbour_feature(true, &s, &Point2::new(1.0, 1.5)),
        [2.0, 0.0]
    );
    assert!((association_variance(10.0, 0.01) - (0.0025 + 0.01)).abs() < 1e-12);
}

#[test]
fn shipped_weights_match_the_feature_set_and_are_checked() {
    let w = Weights::from_json(feature_set(), DEFAULT_WEIGHTS_JSON).expect("default weights load");
    assert_eq!(w.values().len(), 8);
    assert!(ClusteringParams::default().check().is_ok());
    for distance in [[1.0, 0.0], [0.01, -1.0], [-1.0, 1.0]] {
        let bad = ClusteringParams {
            weights: ClusteringWeights {
                distance,
                ..ClusteringWeights::default()
            },
            ..ClusteringParams::default()
        };
        assert!(
            bad.check().is_err(),
            "a distance weight that attracts at some range must be rejected: {distance:?}"
        );
    }
    assert!(ClusteringParams {
        max_clusters: 0,
        ..ClusteringParams::default()
    }
    .check()
    .is_err());
    assert!(ClusteringParams {
        segment_gap: f64::NAN,
        ..ClusteringParams::default()
    }
    .check()
    .is_err());
}

#[test]
fn gap_segmentation_and_motion_merging() {
    let points: Vec<Point2<f64>> = [0.0, 0.1, 0.2, 1.0, 1.1, 3.0]
        .iter()
        .map(|&x| Point2::new(x, 0.0))
        .collect();
    assert_eq!(segment_by_gap(&points, 0.5), vec![0, 0, 0, 1, 1, 2]);
    // Segments 0 and 2 move together, segment 1 differently: capped at 2 clusters the
    // two agreeing segments merge.
    let a = Pose2::new(0.3, 0.0, 0.0);
    let b = Pose2::new(-0.5, 0.8, 0.1);
    let partners: Vec<Option<Point2<f64>>> = points
        .iter()
        .enumerate()
        .map(|(i, p)| Some(if (3..5).contains(&i) { b } else { a }.transform_point(p)))
        .collect();
    let (labels, k) = initial_clusters(&points, &partners, &[0.01; 6], 0.5, 2);
    assert_eq!(k, 2);
    assert_eq!(labels, vec![0, 0, 0, 1, 1, 0]);
    // Uncapped, every segment keeps its own cluster.
    let (_, k) = initial_clusters(&points, &partners, &[0.01; 6], 0.5, 8);
    assert_eq!(k, 3);
}

#[test]
fn finds_the_moving_object_and_its_motion_without_odometry() {
    let ego = Pose2::new(0.6, 0.05, 0.02);
    let object = Pose2::new(-0.4, 0.9, 0.0);
    let (input, is_object) = scene(ego, object);
    // Eq. 3 alone recovers the noise-free motion exactly; the default rotation prior
    // (towards the background's rotation, 0.02 rad away here) moves it a little.
    let exact = ClusteringParams {
        object_rotation_sigma: None,
        ..ClusteringParams::default()
    }
    .check()
    .unwrap();
    let plain = exact.cluster(&input).expect("clusters");
    let moving = &plain.clusters[1];
    assert!(
        moving.motion.translation_error(&object) < 1e-6
            && moving.motion.rotation_error(&object) < 1e-6
    );
    let result = Clusterer::default().cluster(&input).expect("clusters");
    assert_eq!(result.labels, plain.labels);
    assert_eq!(result.background_choice, BackgroundChoice::LargestCluster);
    assert_eq!(result.clusters.len(), 2, "{:?}", result.clusters);
    assert!(result.background_motion.translation_error(&ego) < 1e-6);
    let moving = &result.clusters[1];
    let pulled = moving.motion.rotation_error(&object);
    assert!(
        pulled > 0.0 && pulled < 0.02,
        "rotation pulled by {pulled} rad"
    );
    for (i, &obj) in is_object.iter().enumerate() {
        assert_eq!(result.labels[i], Some(u32::from(obj)), "point {i}");
    }
    assert!(result.converged);
    assert!((2..=30).contains(&result.iterations));
}

#[test]
fn odometry_picks_the_background_by_mahalanobis_distance() {
    let ego = Pose2::new(0.6, 0.05, 0.02);
    let object = Pose2::new(-0.4, 0.9, 0.0);
    // The object's motion is near the odometry: then the object is the background.
    let (mut input, _) = scene(ego, object);
    input.odometry = Some(Pose2::new(-0.35, 0.85, 0.0));
    let result = Clusterer::default().cluster(&input).expect("clusters");
    assert_eq!(result.background_choice, BackgroundChoice::Odometry);
    assert!(result.background_motion.translation_error(&object) < 1e-6);
    input.odometry = Some(Pose2::new(0.5, 0.0, 0.0));
    let result = Clusterer::default().cluster(&input).expect("clusters");
    assert!(result.background_motion.translation_error(&ego) < 1e-6);
}

#[test]
fn duplicate_clusters_merge_by_the_effective_number_of_clusters() {
    // Everything moves with the ego-motion, but the object stands apart by a gap, so
    // the segmentation gives it its own cluster: merging must leave one cluster.
    let ego = Pose2::new(0.6, 0.05, 0.02);
    let (input, _) = scene(ego, ego);
    let result = Clusterer::default().cluster(&input).expect("clusters");
    assert_eq!(result.clusters.len(), 1);
    assert!(result.labels.iter().all(|l| *l == Some(0)));
    assert!(result.final_clusters <= result.initial_clusters);
}

#[test]
fn no_points_is_not_an_error() {
    let input = ClusteringInput {
        beams: vec![],
        beam_count: 3,
        points: vec![],
        partners: vec![],
        variances: vec![],
        odometry: None,
        scans: None,
        ego_motion: None,
    };
    let result = Clusterer::default()
        .cluster(&input)
        .expect("empty input clusters");
    assert_eq!(result.labels, vec![None; 3]);
    let bad = ClusteringInput {
        beams: vec![5],
        beam_count: 3,
        points: vec![Point2::origin()],
        partners: vec![None],
        variances: vec![1.0],
        odometry: None,
        scans: None,
        ego_motion: None,
    };
    assert!(Clusterer::default().cluster(&bad).is_err());
}

#[test]
fn unassociated_background_next_to_an_object_stays_background() {
    // The wall points right after the object (in beam order) lose their partners, as
    // a stretch revealed behind a moved object would; they must stay background.
    let ego = Pose2::new(0.6, 0.05, 0.02);
    let object = Pose2::new(-0.4, 0.9, 0.0);
    let (mut input, is_object) = scene(ego, object);
    let last = is_object.iter().rposition(|&o| o).expect("object points");
    for i in last + 1..(last + 15).min(input.points.len()) {
        input.partners[i] = None;
    }
    let result = Clusterer::default().cluster(&input).expect("clusters");
    assert_eq!(result.clusters.len(), 2, "{:?}", result.clusters);
    for (i, &obj) in is_object.iter().enumerate() {
        assert_eq!(result.labels[i], Some(u32::from(obj)), "point {i}");
    }
}

#[test]
fn model_tables_are_the_papers_features_times_the_weights() {
    use pgm_core::hybrid::chain::{HybridChainModel, WeightedTable};
    use pgm_crf_clustering::model::{build_edges, ClusteringModel};
    let ego = Pose2::new(0.6, 0.05, 0.02);
    let object = Pose2::new(-0.4, 0.3, -0.1);
    let (input, _) = scene(ego, object);
    let mut partners = input.partners.clone();
    partners[3] = None;
    let edges = build_edges(&input.points, 0);
    let motions = vec![ego, object, Pose2::default()];
    let w = ClusteringWeights::default();
    let d_out = 1.0;
    let model = ClusteringModel::new(
        &input.points,
        &partners,
        &input.variances,
        &edges,
        motions.clone(),
        &w,
        Some(d_out),
    )
    .expect("model");
    let s = model.states();
    assert_eq!(s, 4);
    let weights = model.weights().to_vec();
    for i in [0, 3, 17, input.points.len() - 1] {
        let mut table = vec![0.0; s];
        model.write_local(0, i, &mut WeightedTable::new(&weights, &mut table));
        for (l, m) in motions.iter().enumerate() {
            let expected = match &partners[i] {
                // Eq. (2) and its normalised form.
                Some(g) => {
                    let d = distance_feature(m, &input.points[i], g);
                    w.distance[0] * d + w.distance[1] * d / input.variances[i]
                }
                None => 0.0,
            };
            assert!((table[l] - expected).abs() < 1e-9, "local {i} {l}");
        }
        let outlier = match &partners[i] {
            Some(_) => (w.distance[0] + w.distance[1] / input.variances[i]) * d_out * d_out,
            None => 0.0,
        };
        assert!((table[3] - outlier).abs() < 1e-9, "outlier state of {i}");
    }
    for e in [0, 5, edges.len() - 1] {
        let (i, j) = (edges[e].i, edges[e].j);
        let mut table = vec![0.0; s * s];
        model.write_pair(0, e, &mut WeightedTable::new(&weights, &mut table));
        for a in 0..s {
            for b in 0..s {
                let same = a == b;
                let k = usize::from(!same);
                // Eqs. (4), (5) and (6); no stiffness with the outlier state.
                let mut expected = w.neighbour[k]
                    + w.weighted_neighbour[k]
                        * weighted_neighbour_feature(true, &input.points[i], &input.points[j])[0];
                if a < 3 && b < 3 {
                    expected += w.stiffness[k]
                        * stiffness_feature(
                            &motions[a],
                            &motions[b],
                            &input.points[i],
                            &input.points[j],
                        );
                }
                assert!(
                    (table[a * s + b] - expected).abs() < 1e-9,
                    "pair {e} {a} {b}"
                );
            }
        }
    }
}

#[test]
fn acceptance_thresholds_reject_objects_and_are_checked() {
    let ego = Pose2::new(0.6, 0.05, 0.02);
    let object = Pose2::new(-0.4, 0.9, 0.0);
    let (input, _) = scene(ego, object);
    let with = |chi2: f64| {
        ClusteringParams {
            detection: DetectionParams {
                min_object_chi2: chi2,
                ..DetectionParams::default()
            },
            ..ClusteringParams::default()
        }
        .check()
        .expect("valid")
        .cluster(&input)
        .expect("clusters")
    };
    // The object's 13 points move ~1 m: a likelihood ratio of thousands.
    assert_eq!(with(16.0).clusters.len(), 2);
    assert_eq!(with(1e9).clusters.len(), 1);
    for bad in [
        DetectionParams {
            min_free_fraction: 1.5,
            ..DetectionParams::default()
        },
        DetectionParams {
            min_object_chi2: f64::NAN,
            ..DetectionParams::default()
        },
        DetectionParams {
            free_space_margin: -1.0,
            ..DetectionParams::default()
        },
    ] {
        let params = ClusteringParams {
            detection: bad,
            ..ClusteringParams::default()
        };
        assert!(params.check().is_err());
    }
}

#[test]
fn thousands_of_segments_merge_without_a_quadratic_matrix() {
    // 3000 two-point segments (a long, noisy scan): the first half moves by `a`, the
    // second by `b`. Capped at 2 clusters, the halves must end apart.
    let a = Pose2::new(0.3, 0.0, 0.0);
    let b = Pose2::new(-0.5, 0.8, 0.1);
    let mut points = Vec::new();
    for s in 0..3000 {
        let x = s as f64;
        points.push(Point2::new(x, 0.0));
        points.push(Point2::new(x + 0.1, 0.05 * (s % 3) as f64));
    }
    let partners: Vec<Option<Point2<f64>>> = points
        .iter()
        .enumerate()
        .map(|(i, p)| Some(if i < 3000 { a } else { b }.transform_point(p)))
        .collect();
    let variances = vec![0.01; points.len()];
    let (labels, k) = initial_clusters(&points, &partners, &variances, 0.5, 2);
    assert_eq!(k, 2);
    assert!(labels[..3000].iter().all(|&l| l == 0));
    assert!(labels[3000..].iter().all(|&l| l == 1));
}

/// CRF-Clustering's continuous nodes (one rigid motion per cluster, solved from the
/// labelled points) through the core's conformance kit: on its chain graphs (no extra
/// neighbour edges), with and without the outlier state, hybrid inference is
/// coordinate ascent, and moving points between clusters through the incremental
/// statistics equals a fresh start.
#[test]
fn the_clustering_model_passes_the_continuous_model_kit() {
    use pgm_crf_clustering::model::{build_edges, ClusteringModel};
    pgm_core::testing::check_continuous_model(12, |case| {
        let ego = Pose2::new(0.6 - 0.05 * case as f64, 0.05, 0.02);
        let object = Pose2::new(-0.4 + 0.1 * case as f64, 0.3, -0.1);
        let (input, is_object) = scene(ego, object);
        let edges = build_edges(&input.points, 0);
        let outlier = (case % 2 == 1).then_some(1.0);
        let mut model = ClusteringModel::new(
            &input.points,
            &input.partners,
            &input.variances,
            &edges,
            vec![ego, Pose2::default()],
            &ClusteringWeights::default(),
            outlier,
        )
        .expect("model");
        let graph = model.build_graph().expect("graph");
        // The truth with every seventh point in the other cluster.
        let labels = is_object
            .iter()
            .enumerate()
            .map(|(i, &o)| usize::from(o) ^ usize::from(i % 7 == 0))
            .collect();
        (graph, model, Some(labels))
    })
    .unwrap();
}
