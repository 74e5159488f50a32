//! Factors: the trait the engine passes messages through, and the built-in kinds.
//!
//! A factor gives its scope, its shape and its log-potentials, and computes the
//! factor-to-variable message for one scope position from the incoming
//! variable-to-factor messages. The default message enumerates the factor's joint
//! states through [`Factor::log_potential`]; structured factors override it:
//! [`TableFactor`] with strided dense loops, [`PottsFactor`] and
//! [`ShiftedIdentityFactor`] in O(K) instead of O(K²).
//!
//! Log-potentials may be −∞ (hard zeros) anywhere; they are never NaN or +∞.

mod diagonal;
mod table;

pub(crate) use diagonal::potts_max_small;
pub use diagonal::{PottsFactor, ShiftedIdentityFactor};
pub(crate) use table::table_max_fixed;
pub use table::TableFactor;

use crate::graph::VariableId;
use std::fmt::Debug;

/// Which semiring message passing works in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Max-product (max-sum in log space): MAP assignments and max-marginals.
    MaxProduct,
    /// Sum-product (log-sum-exp in log space): marginals and the partition function.
    SumProduct,
}

/// The incoming variable-to-factor messages of one factor, one log-vector per scope
/// position, stored in one flat buffer. The entry at the target position of a message
/// computation is unspecified and must not be read.
#[derive(Clone, Copy, Debug)]
pub struct Incoming<'a> {
    values: &'a [f64],
    offsets: &'a [usize],
}

impl<'a> Incoming<'a> {
    /// Wraps a flat buffer where position `j` occupies `values[offsets[j]..offsets[j + 1]]`.
    pub fn new(values: &'a [f64], offsets: &'a [usize]) -> Self {
        debug_assert!(offsets.last().is_some_and(|&l| l <= values.len()));
        Self { values, offsets }
    }

    /// The message from the variable at scope position `slot`.
    #[inline]
    pub fn slot(&self, slot: usize) -> &'a [f64] {
        &self.values[self.offsets[slot]..self.offsets[slot + 1]]
    }

    /// Number of scope positions.
    pub fn arity(&self) -> usize {
        self.offsets.len() - 1
    }
}

/// A factor of a [`FactorGraph`](crate::FactorGraph).
///
/// Implement `scope`, `shape` and `log_potential`; override `message` when the factor
/// has structure that makes messages cheaper than enumerating its joint states.
///
/// ```
/// use pgm_core::{Factor, FactorGraph, VariableId, BpParams, ParamGuard, Mode, Sequential};
///
/// /// A factor that rewards two variables for differing by exactly one.
/// #[derive(Debug)]
/// struct NextTo { scope: [VariableId; 2], shape: [usize; 2] }
///
/// impl Factor for NextTo {
///     fn scope(&self) -> &[VariableId] { &self.scope }
///     fn shape(&self) -> &[usize] { &self.shape }
///     fn log_potential(&self, s: &[usize]) -> f64 {
///         if s[0].abs_diff(s[1]) == 1 { 2.0 } else { 0.0 }
///     }
/// }
///
/// let mut g = FactorGraph::with_variables(&[3, 3]).unwrap();
/// g.add_factor(NextTo { scope: [VariableId(0), VariableId(1)], shape: [3, 3] }).unwrap();
/// let result = BpParams::new(Mode::MaxProduct).check_unwrap()
///     .run(&g, &mut Sequential::default())
///     .unwrap();
/// assert_eq!(result.log_score, 2.0);
/// ```
pub trait Factor: Send + Sync + Debug {
    /// The variables this factor depends on, in the order of its table.
    fn scope(&self) -> &[VariableId];

    /// The number of states of each scope variable.
    fn shape(&self) -> &[usize];

    /// The log-potential at a joint state of the scope (`states[j]` is the state of
    /// `scope()[j]`). May be −∞; must not be NaN or +∞.
    fn log_potential(&self, states: &[usize]) -> f64;

    /// Writes the unnormalised message to scope position `target` into `out`
    /// (length `shape()[target]`; its incoming contents are arbitrary and every entry
    /// must be written): for each state `x` of the target,
    /// `max` (max-product) or `log Σ exp` (sum-product) over the other positions'
    /// states of `log_potential + Σ_{j ≠ target} incoming.slot(j)[x_j]`.
    fn message(&self, target: usize, incoming: &Incoming<'_>, mode: Mode, out: &mut [f64]) {
        enumerated_message(self, target, incoming, mode, out);
    }

    /// The dense log-table in row-major order (last scope position fastest), the
    /// order of the UAI format.
    fn log_table(&self) -> Vec<f64> {
        let shape = self.shape().to_vec();
        let size: usize = shape.iter().product();
        let mut out = Vec::with_capacity(size);
        let mut states = vec![0usize; shape.len()];
        for _ in 0..size {
            out.push(self.log_potential(&states));
            increment(&mut states, &shape);
        }
        out
    }

    /// True when some log-potential is −∞ (a hard zero). The default scans
    /// [`log_table`](Self::log_table); structured factors answer from their
    /// parameters.
    fn has_hard_zeros(&self) -> bool {
        self.log_table().contains(&f64::NEG_INFINITY)
    }

    /// A short name of the factor's kind, for diagnostics.
    fn kind(&self) -> &'static str {
        "custom"
    }

    /// Downcasting support for hooks that refresh potentials in place; factors that
    /// allow it return `Some(self)`.
    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        None
    }

    /// The closed form of this factor's max-product messages, if it has one the engine
    /// knows ([`MessageKernel`]): flooding then evaluates the messages in place,
    /// without a call through the trait object per message. The default, `None`, keeps
    /// every message on [`message`](Self::message). A factor that returns a kernel must
    /// send exactly the kernel's messages (the conformance kit,
    /// `pgm_core::testing::check_factor`, compares them).
    fn message_kernel(&self) -> Option<MessageKernel<'_>> {
        None
    }
}

/// A factor's messages in a closed form the engine evaluates itself
/// ([`Factor::message_kernel`]). Potentials are log-values (finite or −∞).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MessageKernel<'a> {
    /// A single-variable factor: its message is its log-table (length the variable's
    /// cardinality), in either mode.
    Unary(&'a [f64]),
    /// A pairwise Potts factor over two variables of equal cardinality `k`:
    /// log-potential `same` on equal states, `different` otherwise. The max-product
    /// message to either position is `out[y] = max(q[y] + same, different + max_{x≠y} q[x])`.
    Potts {
        /// Log-potential of equal states.
        same: f64,
        /// Log-potential of different states.
        different: f64,
    },
    /// A dense pairwise log-table `t[a · k1 + b]` (row-major, shape `[k0, k1]`); the
    /// max-product message to position 0 is `out[a] = max_b t[a, b] + q1[b]`, to
    /// position 1 `out[b] = max_a q0[a] + t[a, b]`.
    Table(&'a [f64]),
}

/// Advances a row-major multi-index (last position fastest); wraps to all zeros.
#[inline]
pub(crate) fn increment(states: &mut [usize], shape: &[usize]) {
    for j in (0..states.len()).rev() {
        states[j] += 1;
        if states[j] < shape[j] {
            return;
        }
        states[j] = 0;
    }
}

/// Streaming log-sum-exp accumulator: one `exp` per added term.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LogSumAcc {
    max: f64,
    sum: f64,
}

impl LogSumAcc {
    pub(crate) const EMPTY: LogSumAcc = LogSumAcc {
        max: f64::NEG_INFINITY,
        sum: 0.0,
    };

    #[inline]
    pub(crate) fn add(&mut self, v: f64) {
        if v == f64::NEG_INFINITY {
            return;
        }
        if v <= self.max {
            self.sum += (v - self.max).exp();
        } else {
            self.sum = self.sum * (self.max - v).exp() + 1.0;
            self.max = v;
        }
    }

    #[inline]
    pub(crate) fn value(&self) -> f64 {
        if self.max == f64::NEG_INFINITY {
            f64::NEG_INFINITY
        } else {
            self.max + self.sum.ln()
        }
    }
}

/// The default message: enumerate every joint state through `log_potential`.
pub fn enumerated_message<F: Factor + ?Sized>(
    factor: &F,
    target: usize,
    incoming: &Incoming<'_>,
    mode: Mode,
    out: &mut [f64],
) {
    let shape = factor.shape();
    let size: usize = shape.iter().product();
    let mut states = vec![0usize; shape.len()];
    match mode {
        Mode::MaxProduct => {
            out.iter_mut().for_each(|x| *x = f64::NEG_INFINITY);
            for _ in 0..size {
                let v = joint_value(factor, target, incoming, &states);
                let o = &mut out[states[target]];
                if v > *o {
                    *o = v;
                }
                increment(&mut states, shape);
            }
        }
        Mode::SumProduct => {
            let mut acc = vec![LogSumAcc::EMPTY; out.len()];
            for _ in 0..size {
                let v = joint_value(factor, target, incoming, &states);
                acc[states[target]].add(v);
                increment(&mut states, shape);
            }
            for (o, a) in out.iter_mut().zip(&acc) {
                *o = a.value();
            }
        }
    }
}

#[inline]
fn joint_value<F: Factor + ?Sized>(
    factor: &F,
    target: usize,
    incoming: &Incoming<'_>,
    states: &[usize],
) -> f64 {
    let mut v = factor.log_potential(states);
    for (j, &s) in states.iter().enumerate() {
        if j != target {
            v += incoming.slot(j)[s];
        }
    }
    v
}

/// Checks that `shape` has one entry per variable of `scope`; `what` names the caller
/// in the error.
fn check_shape_len(scope: &[VariableId], shape: &[usize], what: &'static str) -> crate::Result<()> {
    if scope.len() != shape.len() {
        return Err(crate::Error::InvalidParameter {
            name: what,
            value: format!(
                "{} scope entries, {} shape entries",
                scope.len(),
                shape.len()
            ),
            expected: "one shape entry per scope variable",
        });
    }
    Ok(())
}

/// Checks the `scope` and `shape` of factor (or clique) `index` against the
/// `cardinalities` of the variables: one shape entry per scope variable (else
/// [`InvalidParameter`](crate::Error::InvalidParameter) named `what`), known
/// variables, their numbers of states, and no variable twice.
pub(crate) fn check_scope_against(
    index: usize,
    scope: &[VariableId],
    shape: &[usize],
    cardinalities: &[usize],
    what: &'static str,
) -> crate::Result<()> {
    use crate::Error;
    check_shape_len(scope, shape, what)?;
    for (position, (&v, &k)) in scope.iter().zip(shape).enumerate() {
        let Some(&states) = cardinalities.get(v.0) else {
            return Err(Error::UnknownVariable {
                factor: index,
                variable: v.0,
                num_variables: cardinalities.len(),
            });
        };
        if states != k {
            return Err(Error::ShapeMismatch {
                factor: index,
                position,
                variable: v.0,
                factor_states: k,
                variable_states: states,
            });
        }
        if scope[..position].contains(&v) {
            return Err(Error::RepeatedVariable { variable: v.0 });
        }
    }
    Ok(())
}

/// Checks that a scope and a shape describe the same variables with at least one state
/// each; returns the number of joint states. `what` names the caller in errors.
pub(crate) fn check_scope_shape(
    scope: &[VariableId],
    shape: &[usize],
    what: &'static str,
) -> crate::Result<usize> {
    check_shape_len(scope, shape, what)?;
    if let Some(p) = shape.iter().position(|&k| k == 0) {
        return Err(crate::Error::ZeroCardinality {
            variable: scope[p].0,
        });
    }
    shape
        .iter()
        .try_fold(1usize, |acc, &k| acc.checked_mul(k))
        .ok_or_else(|| crate::Error::InvalidParameter {
            name: what,
            value: format!("shape {shape:?}"),
            expected: "a product of cardinalities that fits in memory (it overflows usize)",
        })
}

/// Row-major strides of `shape` (last position fastest) for entries of `unit`
/// consecutive values: `strides[j] = unit · Π_{l > j} shape[l]`.
pub(crate) fn row_major_strides(shape: &[usize], unit: usize) -> Vec<usize> {
    let mut strides = vec![unit; shape.len()];
    for j in (0..shape.len().saturating_sub(1)).rev() {
        strides[j] = strides[j + 1] * shape[j + 1];
    }
    strides
}

/// The offset `Σ states[j] · strides[j]` of a joint state (see [`row_major_strides`]).
#[inline]
pub(crate) fn strided_index(states: &[usize], strides: &[usize]) -> usize {
    states.iter().zip(strides).map(|(s, st)| s * st).sum()
}

/// Checks that every log-potential is finite or −∞.
pub(crate) fn check_log_values(values: &[f64]) -> crate::Result<()> {
    for (index, &value) in values.iter().enumerate() {
        if value.is_nan() || value == f64::INFINITY {
            return Err(crate::Error::BadLogPotential { index, value });
        }
    }
    Ok(())
}
