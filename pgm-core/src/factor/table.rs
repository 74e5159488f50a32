//! Dense log-table factors of any arity.

use super::{check_log_values, Factor, Incoming, LogSumAcc, Mode};
use crate::error::{Error, Result};
use crate::graph::VariableId;

/// A factor given by its full log-table, row-major (last scope position fastest, the
/// UAI order). Messages of unary and pairwise tables use contiguous inner loops; higher
/// arities use a strided walk over the table.
#[derive(Clone, Debug, PartialEq)]
pub struct TableFactor {
    scope: Vec<VariableId>,
    shape: Vec<usize>,
    strides: Vec<usize>,
    log_table: Vec<f64>,
}

impl TableFactor {
    /// A table factor; checks the table size and that entries are finite or −∞.
    pub fn new(scope: Vec<VariableId>, shape: Vec<usize>, log_table: Vec<f64>) -> Result<Self> {
        // The number of joint states, checked: a wrapped product could match a short table.
        if !shape.contains(&0)
            && shape
                .iter()
                .try_fold(1usize, |acc, &k| acc.checked_mul(k))
                .is_none()
        {
            return Err(Error::InvalidParameter {
                name: "table factor shape",
                value: format!("{shape:?}"),
                expected: "a product of cardinalities (number of joint states) that fits in usize",
            });
        }
        let expected = super::check_scope_shape(&scope, &shape, "table factor shape")?;
        if expected != log_table.len() {
            return Err(Error::TableSize {
                expected,
                actual: log_table.len(),
            });
        }
        check_log_values(&log_table)?;
        let strides = super::row_major_strides(&shape, 1);
        Ok(Self {
            scope,
            shape,
            strides,
            log_table,
        })
    }

    /// A table from potentials (not logs): zeros become −∞; negative or NaN entries are errors.
    pub fn from_potentials(
        scope: Vec<VariableId>,
        shape: Vec<usize>,
        potentials: &[f64],
    ) -> Result<Self> {
        let mut logs = Vec::with_capacity(potentials.len());
        for (index, &p) in potentials.iter().enumerate() {
            if p.is_nan() || p < 0.0 || p == f64::INFINITY {
                return Err(Error::BadLogPotential { index, value: p });
            }
            logs.push(p.ln());
        }
        Self::new(scope, shape, logs)
    }

    /// The log-table, row-major.
    pub fn table(&self) -> &[f64] {
        &self.log_table
    }

    /// Mutable access to the log-table for refreshing potentials in place. The caller
    /// must keep entries finite or −∞ ([`TableFactor::set_table`] checks this).
    pub fn table_mut(&mut self) -> &mut [f64] {
        &mut self.log_table
    }

    /// Replaces the log-table (same size), checking its entries.
    pub fn set_table(&mut self, log_table: Vec<f64>) -> Result<()> {
        if log_table.len() != self.log_table.len() {
            return Err(Error::TableSize {
                expected: self.log_table.len(),
                actual: log_table.len(),
            });
        }
        check_log_values(&log_table)?;
        self.log_table = log_table;
        Ok(())
    }

    /// Row-major index of a joint state.
    #[inline]
    pub fn index(&self, states: &[usize]) -> usize {
        super::strided_index(states, &self.strides)
    }
}

impl Factor for TableFactor {
    fn scope(&self) -> &[VariableId] {
        &self.scope
    }

    fn shape(&self) -> &[usize] {
        &self.shape
    }

    #[inline]
    fn log_potential(&self, states: &[usize]) -> f64 {
        self.log_table[self.index(states)]
    }

    fn log_table(&self) -> Vec<f64> {
        self.log_table.clone()
    }

    fn has_hard_zeros(&self) -> bool {
        self.log_table.contains(&f64::NEG_INFINITY)
    }

    fn kind(&self) -> &'static str {
        "table"
    }

    fn message_kernel(&self) -> Option<super::MessageKernel<'_>> {
        match self.shape.len() {
            1 => Some(super::MessageKernel::Unary(&self.log_table)),
            2 => Some(super::MessageKernel::Table(&self.log_table)),
            _ => None,
        }
    }

    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        Some(self)
    }

    fn message(&self, target: usize, incoming: &Incoming<'_>, mode: Mode, out: &mut [f64]) {
        match self.shape.len() {
            1 => out.copy_from_slice(&self.log_table),
            2 => pairwise_message(
                &self.log_table,
                self.shape[0],
                self.shape[1],
                target,
                incoming,
                mode,
                out,
            ),
            _ => strided_message(self, target, incoming, mode, out),
        }
    }
}

/// Messages of a dense pairwise table `t[a * k1 + b]`.
fn pairwise_message(
    t: &[f64],
    k0: usize,
    k1: usize,
    target: usize,
    incoming: &Incoming<'_>,
    mode: Mode,
    out: &mut [f64],
) {
    if mode == Mode::MaxProduct && k0 == k1 {
        // Few states: fixed sizes let the compiler unroll both loops.
        let fixed = with_small_states!(
            k0,
            K => pairwise_max_fixed::<K>(t, target, incoming, out),
            false,
        );
        if fixed {
            return;
        }
    }
    if target == 1 {
        // out[b] = agg_a (q0[a] + t[a, b]); row-wise accumulation keeps the inner loop contiguous.
        let q0 = incoming.slot(0);
        out.iter_mut().for_each(|x| *x = f64::NEG_INFINITY);
        for a in 0..k0 {
            let qa = q0[a];
            if qa == f64::NEG_INFINITY {
                continue;
            }
            let row = &t[a * k1..(a + 1) * k1];
            for (o, &v) in out.iter_mut().zip(row) {
                let s = qa + v;
                *o = if s > *o { s } else { *o };
            }
        }
        if mode == Mode::SumProduct {
            // Second pass: Σ_a exp(q0[a] + t[a, b] − max_b), exact for −∞ entries.
            let maxes: Vec<f64> = out.to_vec();
            let mut sums = vec![0.0f64; k1];
            for a in 0..k0 {
                let qa = q0[a];
                if qa == f64::NEG_INFINITY {
                    continue;
                }
                let row = &t[a * k1..(a + 1) * k1];
                for b in 0..k1 {
                    let m = maxes[b];
                    if m != f64::NEG_INFINITY {
                        sums[b] += (qa + row[b] - m).exp();
                    }
                }
            }
            for b in 0..k1 {
                if maxes[b] != f64::NEG_INFINITY {
                    out[b] = maxes[b] + sums[b].ln();
                }
            }
        }
    } else {
        // out[a] = agg_b (t[a, b] + q1[b]).
        let q1 = incoming.slot(1);
        for (a, o) in out.iter_mut().enumerate().take(k0) {
            let row = &t[a * k1..(a + 1) * k1];
            let mut m = f64::NEG_INFINITY;
            for (&v, &q) in row.iter().zip(q1) {
                let s = v + q;
                m = if s > m { s } else { m };
            }
            if mode == Mode::SumProduct && m != f64::NEG_INFINITY {
                let mut sum = 0.0;
                for (&v, &q) in row.iter().zip(q1) {
                    sum += (v + q - m).exp();
                }
                m += sum.ln();
            }
            *o = m;
        }
    }
}

/// Max-product message of a `K × K` table: `out[b] = max_a (q0[a] + t[a, b])` to
/// position 1, `out[a] = max_b (t[a, b] + q1[b])` to position 0. The same sums and
/// maxima as the general loops, so the same numbers. Returns false (and writes
/// nothing) when the slices do not have the sizes of a `K × K` table.
#[inline(always)]
fn pairwise_max_fixed<const K: usize>(
    t: &[f64],
    target: usize,
    incoming: &Incoming<'_>,
    out: &mut [f64],
) -> bool {
    let q = incoming.slot(1 - target);
    if t.len() != K * K || q.len() != K || out.len() != K {
        return false;
    }
    table_max_fixed::<K>(t, target, q, out);
    true
}

/// The loops of [`pairwise_max_fixed`] on slices of the right sizes (`t` at least
/// `K²`, `q` and `out` at least `K` long): the message of a `K × K` table to scope
/// position `target` from the other position's incoming message `q`.
#[inline(always)]
pub(crate) fn table_max_fixed<const K: usize>(
    t: &[f64],
    target: usize,
    q: &[f64],
    out: &mut [f64],
) {
    let (t, q, out) = (&t[..K * K], &q[..K], &mut out[..K]);
    if target == 1 {
        let mut acc = [f64::NEG_INFINITY; K];
        for a in 0..K {
            for b in 0..K {
                let s = q[a] + t[a * K + b];
                acc[b] = if s > acc[b] { s } else { acc[b] };
            }
        }
        out.copy_from_slice(&acc);
    } else {
        for a in 0..K {
            let mut m = f64::NEG_INFINITY;
            for b in 0..K {
                let s = t[a * K + b] + q[b];
                m = if s > m { s } else { m };
            }
            out[a] = m;
        }
    }
}

/// Messages of tables of arity three and more: one walk over the table.
fn strided_message(
    f: &TableFactor,
    target: usize,
    incoming: &Incoming<'_>,
    mode: Mode,
    out: &mut [f64],
) {
    let arity = f.shape.len();
    let mut states = vec![0usize; arity];
    // Partial sums of incoming messages are recomputed only for changed positions.
    let mut incoming_sum = 0.0;
    let others: Vec<usize> = (0..arity).filter(|&j| j != target).collect();
    let recompute =
        |states: &[usize]| -> f64 { others.iter().map(|&j| incoming.slot(j)[states[j]]).sum() };
    incoming_sum += recompute(&states);
    match mode {
        Mode::MaxProduct => {
            out.iter_mut().for_each(|x| *x = f64::NEG_INFINITY);
            for &v in &f.log_table {
                let s = v + incoming_sum;
                let o = &mut out[states[target]];
                if s > *o {
                    *o = s;
                }
                super::increment(&mut states, &f.shape);
                incoming_sum = recompute(&states);
            }
        }
        Mode::SumProduct => {
            let mut acc = vec![LogSumAcc::EMPTY; out.len()];
            for &v in &f.log_table {
                acc[states[target]].add(v + incoming_sum);
                super::increment(&mut states, &f.shape);
                incoming_sum = recompute(&states);
            }
            for (o, a) in out.iter_mut().zip(&acc) {
                *o = a.value();
            }
        }
    }
}
