//! Tests of hybrid observed-continuous inference.

mod common;

use pgm_core::hybrid::{ClusterMeans, DiscreteSummary, HybridInference, UpdatePolicy};
use pgm_core::{BpParams, Flooding, Mode, ParamGuard, Residual, Schedule, Sequential};
use proptest::prelude::*;

fn observations() -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (2usize..40, 1usize..5).prop_flat_map(|(n, k)| {
        (
            proptest::collection::vec(-10.0..10.0f64, n),
            proptest::collection::vec(-10.0..10.0f64, k),
        )
    })
}

proptest! {
    #![proptest_config(common::persisted(128, "proptest-regressions/hybrid.txt"))]

    /// With the continuous values frozen, hybrid inference is plain BP on the same
    /// potentials: same messages, beliefs and assignment, bit for bit.
    #[test]
    fn frozen_continuous_equals_plain_bp(
        (y, means) in observations(),
        weight in 0.1..3.0f64,
        coupling in -2.0..2.0f64,
        mode in prop_oneof![Just(Mode::MaxProduct), Just(Mode::SumProduct)],
        schedule in 0usize..3,
    ) {
        let make = |s: usize| -> Box<dyn Schedule> {
            match s { 0 => Box::new(Flooding), 1 => Box::new(Sequential::default()), _ => Box::new(Residual::default()) }
        };
        let (mut graph, mut model) = ClusterMeans::chain(&y, &means, weight, coupling).unwrap();
        let bp = BpParams::new(mode).max_iterations(50).check_unwrap();
        let hybrid = HybridInference::new(bp.clone(), UpdatePolicy::Frozen)
            .run(&mut graph, &mut model, &mut make(schedule), None)
            .unwrap();
        let plain = bp.run(&graph, &mut make(schedule)).unwrap();
        prop_assert_eq!(&hybrid.discrete.assignment, &plain.assignment);
        prop_assert_eq!(hybrid.discrete.messages.as_slice(), plain.messages.as_slice());
        prop_assert_eq!(&hybrid.discrete.beliefs, &plain.beliefs);
        prop_assert_eq!(hybrid.discrete.iterations, plain.iterations);
        prop_assert_eq!(model.means(), &means[..]);
    }

    /// On a chain with the sequential two-pass schedule (exact MAP per sweep) and MAP
    /// label updates after every sweep, hybrid inference is coordinate ascent on the
    /// joint log-score: it never decreases from one outer iteration to the next.
    #[test]
    fn coordinate_ascent_never_decreases(
        (y, means) in observations(),
        weight in 0.1..3.0f64,
        coupling in -1.0..3.0f64,
        initial in any::<bool>(),
    ) {
        let (mut graph, mut model) = ClusterMeans::chain(&y, &means, weight, coupling).unwrap();
        let labels: Vec<usize> = (0..y.len()).map(|i| i % means.len()).collect();
        let result = HybridInference::new(BpParams::new(Mode::MaxProduct).max_iterations(40).check_unwrap(), UpdatePolicy::EverySweep)
            .trace_scores(true)
            .run(&mut graph, &mut model, &mut Sequential::default(), initial.then_some(&labels[..]))
            .unwrap();
        let s = &result.sweep_scores;
        prop_assert!(!s.is_empty());
        for w in s.windows(2) {
            prop_assert!(w[1] >= w[0] - 1e-9 * (1.0 + w[0].abs()), "score decreased: {s:?}");
        }
        // The final decoding is at least as good as the last traced state.
        prop_assert!(result.joint_log_score >= s[s.len() - 1] - 1e-9 * (1.0 + s[s.len() - 1].abs()));
    }
}

#[test]
fn every_visit_updates_recover_well_separated_means() {
    let mut y = Vec::new();
    for i in 0..60 {
        let centre = [0.0, 4.0, -5.0][i / 20];
        y.push(centre + 0.1 * ((i * 7 % 11) as f64 - 5.0) / 5.0);
    }
    // Initialise the continuous nodes from a crude labelling (nearest initial mean), as
    // CRF-Clustering initialises its motions from a segmentation.
    let start = [1.0, 2.5, -1.0];
    let initial: Vec<usize> = y
        .iter()
        .map(|v| {
            (0..3)
                .min_by(|&a, &b| {
                    (v - start[a])
                        .abs()
                        .partial_cmp(&(v - start[b]).abs())
                        .unwrap()
                })
                .unwrap()
        })
        .collect();
    for policy in [
        UpdatePolicy::EveryVisit,
        UpdatePolicy::EveryVisits(5),
        UpdatePolicy::EverySweep,
    ] {
        for summary in [DiscreteSummary::MapLabels, DiscreteSummary::Beliefs] {
            let (mut graph, model) = ClusterMeans::chain(&y, &start, 1.0, 1.0).unwrap();
            let mut model = model.with_summary(summary);
            let mode = match summary {
                DiscreteSummary::MapLabels => Mode::MaxProduct,
                DiscreteSummary::Beliefs => Mode::SumProduct,
            };
            let r = HybridInference::new(
                BpParams::new(mode).max_iterations(100).check_unwrap(),
                policy,
            )
            .continuous_tolerance(1e-6)
            .run(
                &mut graph,
                &mut model,
                &mut Sequential::default(),
                Some(&initial),
            )
            .unwrap();
            let mut m = model.means().to_vec();
            m.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let truth = [-5.0, 0.0, 4.0];
            for (got, want) in m.iter().zip(truth) {
                assert!(
                    (got - want).abs() < 0.05,
                    "{policy:?} {summary:?}: means {m:?}"
                );
            }
            assert!(
                r.continuous_converged,
                "{policy:?} {summary:?}: change {}",
                r.continuous_change
            );
            assert!(r.solves > 1);
            // Labels are constant on each true segment.
            for seg in r.discrete.assignment.chunks(20) {
                assert!(
                    seg.iter().all(|&l| l == seg[0]),
                    "{policy:?} {summary:?}: {:?}",
                    r.discrete.assignment
                );
            }
        }
    }
}

/// A user-defined schedule that visits the chain forward and backward and asks for a
/// continuous update after every second visit, as the joint-model paper does.
struct EverySecondVisit {
    n: usize,
    requests: usize,
}

impl pgm_core::Schedule for EverySecondVisit {
    fn name(&self) -> &str {
        "every-second-visit"
    }

    fn iteration(&mut self, passer: &mut dyn pgm_core::MessagePasser) -> Option<f64> {
        let order: Vec<usize> = (0..self.n).chain((0..self.n).rev()).collect();
        for (step, v) in order.into_iter().enumerate() {
            passer.visit_variable(pgm_core::VariableId(v));
            if step % 2 == 1 {
                passer.update_continuous();
                self.requests += 1;
            }
        }
        None
    }
}

#[test]
fn schedules_can_drive_continuous_updates() {
    let y: Vec<f64> = (0..40)
        .map(|i| {
            if i < 20 {
                1.0 + 0.01 * i as f64
            } else {
                6.0 - 0.01 * i as f64
            }
        })
        .collect();
    let initial: Vec<usize> = (0..40).map(|i| usize::from(i >= 25)).collect();
    let (mut graph, mut model) = ClusterMeans::chain(&y, &[0.0, 3.0], 1.0, 1.0).unwrap();
    let mut schedule = EverySecondVisit { n: 40, requests: 0 };
    let r = HybridInference::new(
        BpParams::new(Mode::MaxProduct)
            .max_iterations(30)
            .check_unwrap(),
        UpdatePolicy::OnRequest,
    )
    .run(&mut graph, &mut model, &mut schedule, Some(&initial))
    .unwrap();
    // One solve at initialisation, one per request, one in the final decoding.
    assert_eq!(r.solves, schedule.requests + 2);
    assert_eq!(&r.discrete.assignment[..20], &[0; 20]);
    assert_eq!(&r.discrete.assignment[20..], &[1; 20]);
    assert!(r.continuous_converged);
}
