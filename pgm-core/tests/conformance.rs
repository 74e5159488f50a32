//! The conformance kit (`pgm_core::testing`) on every built-in factor and schedule,
//! and on broken factors and a broken schedule, which it must catch.

use pgm_core::factor::{Factor, Incoming, Mode};
use pgm_core::testing::{check_factor, check_schedule};
use pgm_core::{
    factor_conformance, schedule_conformance, Flooding, MessagePasser, PottsFactor, Residual,
    Schedule, Sequential, ShiftedIdentityFactor, TableFactor, VariableId,
};

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
}

#[test]
fn the_kit_catches_broken_factors() {
    for (fault, check, needle) in [
        ("nan", "log_potential", "NaN"),
        ("max for sum", "message", "SumProduct"),
        ("unwritten", "message", "NaN"),
        ("naive", "message", "large"),
        ("says hard zeros", "has_hard_zeros", "says true"),
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
