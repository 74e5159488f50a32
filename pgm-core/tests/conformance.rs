//! The conformance kit (`pgm_core::testing`) on every built-in factor, schedule and
//! continuous model, and on broken ones, which it must catch.

use pgm_core::factor::{Factor, Incoming, MessageKernel, Mode};
use pgm_core::hybrid::{ClusterMeans, ContinuousModel, DiscreteSummary, VariableState};
use pgm_core::testing::{check_continuous_model, check_factor, check_schedule};
use pgm_core::{
    factor_conformance, schedule_conformance, Flooding, MessagePasser, PottsFactor, Residual,
    Schedule, Sequential, ShiftedIdentityFactor, TableFactor, VariableId,
};
use pgm_core::{FactorId, Potentials};

const NEG: f64 = f64::NEG_INFINITY;

fn v(i: usize) -> VariableId {
    VariableId(i)
}

/// A table over `shape` with entries from a fixed pattern, `-inf` where `hard` says.
fn table(shape: &[usize], hard: impl Fn(usize) -> bool) -> TableFactor {
    let size: usize = shape.iter().product();
    let values = (0..size)
        .map(|i| {
            if hard(i) {
                NEG
            } else {
                ((i * 37 % 11) as f64 - 5.0) * 0.7
            }
        })
        .collect();
    let scope = (0..shape.len()).map(v).collect();
    TableFactor::new(scope, shape.to_vec(), values).unwrap()
}

factor_conformance!(a_unary_table, table(&[4], |_| false));
factor_conformance!(a_pairwise_table, table(&[3, 5], |i| i % 4 == 1));
factor_conformance!(a_ternary_table, table(&[2, 3, 4], |i| i % 5 == 0));
factor_conformance!(a_table_of_one_state, table(&[1, 3], |_| false));
factor_conformance!(
    a_potts_factor,
    PottsFactor::new(v(0), v(1), 5, 1.5, -0.5).unwrap()
);
factor_conformance!(
    a_hard_potts_factor,
    PottsFactor::new(v(0), v(1), 4, 0.0, NEG).unwrap()
);
factor_conformance!(
    a_shifted_identity,
    ShiftedIdentityFactor::new(v(0), v(1), 5, 7, 2, 1.0, -1.0).unwrap()
);
factor_conformance!(
    a_hard_shifted_identity,
    ShiftedIdentityFactor::new(v(0), v(1), 6, 4, -1, 0.5, NEG).unwrap()
);

schedule_conformance!(flooding, || Box::new(Flooding));
schedule_conformance!(sequential, || Box::new(Sequential::default()));
schedule_conformance!(residual, || Box::new(Residual::default()));

/// A pairwise factor whose own message is wrong in the way `fault` says.
#[derive(Debug)]
struct Broken {
    scope: [VariableId; 2],
    shape: [usize; 2],
    fault: &'static str,
}

impl Factor for Broken {
    fn scope(&self) -> &[VariableId] {
        &self.scope
    }
    fn shape(&self) -> &[usize] {
        &self.shape
    }
    fn log_potential(&self, s: &[usize]) -> f64 {
        match self.fault {
            "nan" if s == [1, 1] => f64::NAN,
            _ => (s[0] as f64) - 0.5 * (s[1] as f64),
        }
    }
    fn message(&self, target: usize, incoming: &Incoming<'_>, mode: Mode, out: &mut [f64]) {
        pgm_core::factor::enumerated_message(self, target, incoming, mode, out);
        match self.fault {
            // Forgets the log-sum-exp: max instead of sum in sum-product.
            "max for sum" if mode == Mode::SumProduct => {
                pgm_core::factor::enumerated_message(self, target, incoming, Mode::MaxProduct, out);
            }
            // Leaves one entry unwritten.
            "unwritten" => out[0] = f64::NAN,
            // Naive exp/ln: overflows at large magnitudes.
            "naive" => {
                let other = incoming.slot(1 - target);
                for (x, o) in out.iter_mut().enumerate() {
                    let sum: f64 = (0..self.shape[1 - target])
                        .map(|y| {
                            let s = if target == 0 { [x, y] } else { [y, x] };
                            (self.log_potential(&s) + other[y]).exp()
                        })
                        .sum();
                    if mode == Mode::SumProduct {
                        *o = sum.ln();
                    }
                }
            }
            _ => {}
        }
    }
    fn has_hard_zeros(&self) -> bool {
        self.fault == "says hard zeros"
    }
    fn message_kernel(&self) -> Option<MessageKernel<'_>> {
        match self.fault {
            // Claims to be Potts: the engine would evaluate the wrong messages.
            "claims potts" => Some(MessageKernel::Potts {
                same: 1.0,
                different: 0.0,
            }),
            // Claims a table of the wrong size.
            "claims table" => Some(MessageKernel::Table(&[0.0, 1.0])),
            _ => None,
        }
    }
}

#[test]
fn the_kit_catches_broken_factors() {
    for (fault, check, needle) in [
        ("nan", "log_potential", "NaN"),
        ("max for sum", "message", "SumProduct"),
        ("unwritten", "message", "NaN"),
        ("naive", "message", "large"),
        ("says hard zeros", "has_hard_zeros", "says true"),
        ("claims potts", "message_kernel", "Potts"),
        ("claims table", "message_kernel", "Table"),
    ] {
        let broken = Broken {
            scope: [v(0), v(1)],
            shape: [3, 4],
            fault,
        };
        let e = check_factor(&broken).unwrap_err();
        assert_eq!(e.check, check, "{fault}: {e}");
        assert!(e.to_string().contains(needle), "{fault}: {e}");
    }
    let twice = Broken {
        scope: [v(2), v(2)],
        shape: [3, 3],
        fault: "",
    };
    assert_eq!(check_factor(&twice).unwrap_err().check, "scope");
}

/// A schedule that updates only the first half of the edges.
struct Lazy;

impl Schedule for Lazy {
    fn name(&self) -> &str {
        "lazy"
    }
    fn iteration(&mut self, passer: &mut dyn MessagePasser) -> Option<f64> {
        let n = passer.graph().num_edges();
        for e in 0..n / 2 {
            passer.update_edge(pgm_core::EdgeId(e));
        }
        None
    }
}

#[test]
fn the_kit_catches_a_schedule_that_skips_edges() {
    let e = check_schedule(|| Box::new(Lazy), 50).unwrap_err();
    assert!(e.check.starts_with("schedule"), "{e}");
    assert!(e.to_string().contains("\"lazy\""), "{e}");
}

/// Chains of 4-19 observations around 2-4 centres, with initial means and labels that
/// are deliberately off, as [`check_continuous_model`]'s cases.
fn means_case(case: usize) -> (Vec<f64>, Vec<f64>, Vec<usize>) {
    let k = 2 + case % 3;
    let n = 4 + (case * 7) % 16;
    let y: Vec<f64> = (0..n)
        .map(|i| ((i * 5 + case) % k) as f64 * 3.0 + ((i * 13 + case * 3) % 7) as f64 * 0.3 - 1.0)
        .collect();
    let means: Vec<f64> = (0..k).map(|l| l as f64 * 1.7 - 0.5).collect();
    let labels: Vec<usize> = (0..n).map(|i| (i + case) % k).collect();
    (y, means, labels)
}

#[test]
fn cluster_means_passes_coordinate_ascent() {
    check_continuous_model(40, |case| {
        let (y, means, labels) = means_case(case);
        let coupling = [0.0, 0.8, 2.0, -0.5][case % 4];
        let (graph, model) = ClusterMeans::chain(&y, &means, 1.0, coupling).unwrap();
        (graph, model, Some(labels))
    })
    .unwrap();
}

/// [`ClusterMeans`] with the classic bug of an incremental model: a variable's old
/// state is never taken out of the statistics.
struct Forgetful(ClusterMeans);

impl ContinuousModel for Forgetful {
    fn summary(&self) -> DiscreteSummary {
        self.0.summary()
    }
    fn update_variable(
        &mut self,
        v: VariableId,
        _old: Option<VariableState<'_>>,
        new: VariableState<'_>,
    ) {
        self.0.update_variable(v, None, new);
    }
    fn solve(&mut self) -> f64 {
        self.0.solve()
    }
    fn dependent_factors(&self, v: VariableId) -> &[FactorId] {
        self.0.dependent_factors(v)
    }
    fn refresh_factor(&self, a: FactorId, potentials: &mut Potentials<'_>) -> pgm_core::Result<()> {
        self.0.refresh_factor(a, potentials)
    }
}

#[test]
fn the_kit_catches_a_model_that_forgets_old_states() {
    let e = check_continuous_model(40, |case| {
        let (y, means, labels) = means_case(case);
        let (graph, model) = ClusterMeans::chain(&y, &means, 1.0, 0.0).unwrap();
        (graph, Forgetful(model), Some(labels))
    })
    .unwrap_err();
    assert_eq!(e.check, "incremental statistics", "{e}");
    assert!(e.to_string().contains("are old states taken out?"), "{e}");
}
