//! The rigid-motion nodes (`RigidMotionNodes`, the continuous nodes `x^RT` of the
//! papers' models) through the core's conformance kit for continuous models: on
//! chains of point pairs that move by two or three rigid motions, hybrid inference is
//! coordinate ascent (the traced score never falls) and moving a point from one
//! cluster to another through the incremental statistics equals a fresh start.

use nalgebra::Point2;
use pgm_core::testing::check_continuous_model;
use pgm_core::{FactorGraph, PottsFactor, TableFactor, VariableId};
use pgm_features::motion_nodes::RigidMotionNodes;
use pgm_scan::Pose2;

/// Case `case`: 6-29 points on a curve, in runs that move by one of `k` motions, with
/// a few points mislabelled at the start and an outlier state of log-potential −3
/// when `case` is odd.
fn case(case: usize) -> (FactorGraph, RigidMotionNodes, Option<Vec<usize>>) {
    let k = 2 + case % 2;
    let n = 6 + (case * 7) % 24;
    let motions = [
        Pose2::new(0.0, 0.0, 0.0),
        Pose2::new(0.8, -0.3, 0.05),
        Pose2::new(-0.5, 0.6, -0.1),
    ];
    let truth: Vec<usize> = (0..n).map(|i| (i * k) / n).collect();
    let pairs: Vec<(Point2<f64>, Point2<f64>)> = (0..n)
        .map(|i| {
            let t = i as f64 * 0.4 + case as f64 * 0.1;
            let s = Point2::new(3.0 + t.cos() * (2.0 + 0.1 * t), t.sin() * 2.0 + 0.2 * t);
            let noise = 0.02 * (((i * 31 + case * 7) % 11) as f64 - 5.0) / 5.0;
            let g = motions[truth[i]].transform_point(&s) + nalgebra::Vector2::new(noise, -noise);
            (s, g)
        })
        .collect();
    let outlier = case % 2 == 1;
    let states = k + usize::from(outlier);
    let mut graph = FactorGraph::with_variables(&vec![states; n]).unwrap();
    let local = (0..n)
        .map(|i| {
            graph
                .add_factor(
                    TableFactor::new(vec![VariableId(i)], vec![states], vec![0.0; states]).unwrap(),
                )
                .unwrap()
        })
        .collect();
    for i in 1..n {
        graph
            .add_factor(
                PottsFactor::new(VariableId(i - 1), VariableId(i), states, 1.0, 0.0).unwrap(),
            )
            .unwrap();
    }
    let extra = if outlier { vec![-3.0] } else { Vec::new() };
    let start = vec![Pose2::identity(); k];
    let nodes = RigidMotionNodes::new(pairs, local, start, 20.0, extra).unwrap();
    // Start from the truth with every fifth point moved to the next cluster.
    let labels = truth
        .iter()
        .enumerate()
        .map(|(i, &l)| if i % 5 == 0 { (l + 1) % k } else { l })
        .collect();
    (graph, nodes, Some(labels))
}

#[test]
fn rigid_motion_nodes_pass_the_continuous_model_kit() {
    check_continuous_model(30, case).unwrap();
}
