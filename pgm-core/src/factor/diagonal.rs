//! Pairwise factors that are a constant plus a bonus on one "diagonal": the Potts
//! factor (equal states) and the shifted-identity factor of association chains
//! (state `j` of the first variable favours state `j + shift` of the second).
//!
//! Both send a message in O(K): with `q` the incoming message of the other variable,
//! the message to state `y` combines `q[partner(y)] + on` with
//! `off + agg_{x ≠ partner(y)} q[x]`, where the leave-one-out aggregate comes from the
//! top two entries (max-product) or prefix/suffix log-sum-exp (sum-product), so no
//! subtraction of large numbers ever happens and −∞ entries stay exact.

use super::{check_log_values, Factor, Incoming, Mode};
use crate::error::{Error, Result};
use crate::graph::VariableId;
use crate::logspace::log_add_exp;

/// Potts factor over two variables with `k` states each: log-potential `same` when the
/// states are equal, `different` otherwise. Either may be −∞.
#[derive(Clone, Debug, PartialEq)]
pub struct PottsFactor {
    scope: [VariableId; 2],
    shape: [usize; 2],
    same: f64,
    different: f64,
}

impl PottsFactor {
    /// A Potts factor between `a` and `b`, both with `k` states.
    pub fn new(a: VariableId, b: VariableId, k: usize, same: f64, different: f64) -> Result<Self> {
        check_log_values(&[same, different])?;
        if k == 0 {
            return Err(Error::ZeroCardinality { variable: a.0 });
        }
        Ok(Self {
            scope: [a, b],
            shape: [k, k],
            same,
            different,
        })
    }

    /// Log-potential for equal states.
    pub fn same(&self) -> f64 {
        self.same
    }

    /// Log-potential for different states.
    pub fn different(&self) -> f64 {
        self.different
    }
}

impl Factor for PottsFactor {
    fn scope(&self) -> &[VariableId] {
        &self.scope
    }

    fn shape(&self) -> &[usize] {
        &self.shape
    }

    fn log_potential(&self, s: &[usize]) -> f64 {
        if s[0] == s[1] {
            self.same
        } else {
            self.different
        }
    }

    fn message(&self, target: usize, incoming: &Incoming<'_>, mode: Mode, out: &mut [f64]) {
        let q = incoming.slot(1 - target);
        if mode == Mode::MaxProduct && q.len() <= SMALL && q.len() == out.len() {
            let (same, different) = (self.same, self.different);
            // Fixed sizes let the compiler unroll the two loops.
            with_small_states!(
                q.len(),
                K => potts_max_fixed::<K>(q, out, same, different),
                potts_max_small(q, out, same, different),
            );
            return;
        }
        diagonal_message(q, out, 0, self.same, self.different, mode);
    }

    fn kind(&self) -> &'static str {
        "potts"
    }

    fn message_kernel(&self) -> Option<super::MessageKernel<'_>> {
        Some(super::MessageKernel::Potts {
            same: self.same,
            different: self.different,
        })
    }

    fn has_hard_zeros(&self) -> bool {
        self.same == f64::NEG_INFINITY || (self.different == f64::NEG_INFINITY && self.shape[0] > 1)
    }

    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        Some(self)
    }
}

/// Shifted-identity factor between `first` (`k_first` states) and `second`
/// (`k_second` states): log-potential `on` when `second = first + shift`, `off`
/// otherwise. With `shift = 1` it is the association-chain factor of scan matching:
/// point `i` matched to point `j` of the other scan makes point `i + 1` likely to
/// match `j + 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct ShiftedIdentityFactor {
    scope: [VariableId; 2],
    shape: [usize; 2],
    shift: isize,
    on: f64,
    off: f64,
}

impl ShiftedIdentityFactor {
    /// A shifted-identity factor; `on`/`off` may be −∞.
    pub fn new(
        first: VariableId,
        second: VariableId,
        k_first: usize,
        k_second: usize,
        shift: isize,
        on: f64,
        off: f64,
    ) -> Result<Self> {
        check_log_values(&[on, off])?;
        if k_first == 0 {
            return Err(Error::ZeroCardinality { variable: first.0 });
        }
        if k_second == 0 {
            return Err(Error::ZeroCardinality { variable: second.0 });
        }
        Ok(Self {
            scope: [first, second],
            shape: [k_first, k_second],
            shift,
            on,
            off,
        })
    }

    /// The shift between the favoured states.
    pub fn shift(&self) -> isize {
        self.shift
    }
}

impl Factor for ShiftedIdentityFactor {
    fn scope(&self) -> &[VariableId] {
        &self.scope
    }

    fn shape(&self) -> &[usize] {
        &self.shape
    }

    fn log_potential(&self, s: &[usize]) -> f64 {
        if s[1] as isize == s[0] as isize + self.shift {
            self.on
        } else {
            self.off
        }
    }

    fn message(&self, target: usize, incoming: &Incoming<'_>, mode: Mode, out: &mut [f64]) {
        let q = incoming.slot(1 - target);
        // Message to `second`: partner of y is y - shift; to `first`: partner of x is x + shift.
        let offset = if target == 1 { -self.shift } else { self.shift };
        diagonal_message(q, out, offset, self.on, self.off, mode);
    }

    fn kind(&self) -> &'static str {
        "shifted-identity"
    }

    fn has_hard_zeros(&self) -> bool {
        // Conservative: true whenever either value is a hard zero (even if the shift
        // leaves no entry holding it).
        self.on == f64::NEG_INFINITY || self.off == f64::NEG_INFINITY
    }

    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        Some(self)
    }
}

/// Max-product Potts message for few states (`q.len() == out.len() <= SMALL`,
/// at least one): `out[y] = max(q[y] + same, different + max_{x ≠ y} q[x])`. Every
/// target but the first maximiser of `q` sees the maximum as its best other state;
/// that one sees the second largest entry. Branch-free loops.
#[inline(always)]
pub(crate) fn potts_max_small(q: &[f64], out: &mut [f64], same: f64, different: f64) {
    let (mut best, mut best_at, mut second) = (q[0], 0usize, f64::NEG_INFINITY);
    for (x, &v) in q.iter().enumerate().skip(1) {
        let above = v > best;
        let lower = if above { best } else { v };
        second = if lower > second { lower } else { second };
        best_at = if above { x } else { best_at };
        best = if above { v } else { best };
    }
    let all = different + best;
    for (o, &qy) in out.iter_mut().zip(q) {
        let d = qy + same;
        *o = if d > all { d } else { all };
    }
    let rest = different + second;
    let d = q[best_at] + same;
    out[best_at] = if d > rest { d } else { rest };
}

/// [`potts_max_small`] for exactly `K` states.
#[inline(always)]
fn potts_max_fixed<const K: usize>(q: &[f64], out: &mut [f64], same: f64, different: f64) {
    if q.len() != K || out.len() != K {
        return potts_max_small(q, out, same, different);
    }
    potts_max_small(&q[..K], &mut out[..K], same, different);
}

/// `out[y] = agg(q[y + offset] + on, off + agg_{x ≠ y + offset} q[x])`, with the first
/// term absent when `y + offset` is out of range.
/// Up to this many states, max-product messages use scalar single-pass loops.
const SMALL: usize = 16;

pub(crate) fn diagonal_message(
    q: &[f64],
    out: &mut [f64],
    offset: isize,
    on: f64,
    off: f64,
    mode: Mode,
) {
    let n = q.len() as isize;
    let n_out = out.len() as isize;
    // Targets y whose partner y + offset is a valid state of the other variable.
    let lo = (-offset).clamp(0, n_out) as usize;
    let hi = (n - offset).clamp(lo as isize, n_out) as usize;
    match mode {
        Mode::MaxProduct if q.len() <= SMALL && out.len() <= SMALL => {
            // Few states: one branch-free pass for the top two (the first position
            // of the maximum, and the maximum of the rest), then one over targets.
            let (mut best, mut best_at, mut second) = (q[0], 0usize, f64::NEG_INFINITY);
            for (x, &v) in q.iter().enumerate().skip(1) {
                let above = v > best;
                second = if above {
                    best
                } else if v > second {
                    v
                } else {
                    second
                };
                best_at = if above { x } else { best_at };
                best = if above { v } else { best };
            }
            let all = off + best;
            if offset == 0 && out.len() == q.len() {
                // Potts: every target pairs with the same state.
                let rest_second = off + second;
                for (y, (o, &qy)) in out.iter_mut().zip(q).enumerate() {
                    let rest = if y == best_at { rest_second } else { all };
                    let d = qy + on;
                    *o = if d > rest { d } else { rest };
                }
                return;
            }
            for (y, o) in out.iter_mut().enumerate() {
                let p = y as isize + offset;
                *o = if p >= 0 && p < n {
                    let p = p as usize;
                    let rest = off + if p == best_at { second } else { best };
                    let d = q[p] + on;
                    if d > rest {
                        d
                    } else {
                        rest
                    }
                } else {
                    all
                };
            }
        }
        Mode::MaxProduct => {
            // Top two entries give max over x ≠ p for any p: the maximum, its first
            // position, and the maximum of everything else (three packed passes).
            let best = crate::logspace::max(q);
            let best_at = q.iter().position(|&v| v == best).unwrap_or(0);
            let second = crate::logspace::max(&q[..best_at])
                .max(crate::logspace::max(&q[(best_at + 1).min(q.len())..]));
            let all = off + best;
            out[..lo].iter_mut().for_each(|o| *o = all);
            out[hi..].iter_mut().for_each(|o| *o = all);
            if lo < hi {
                let partners = &q[(lo as isize + offset) as usize..(hi as isize + offset) as usize];
                for (o, &qp) in out[lo..hi].iter_mut().zip(partners) {
                    let d = qp + on;
                    *o = if d > all { d } else { all };
                }
            }
            // The target paired with the best entry must use the second best instead.
            let y = best_at as isize - offset;
            if y >= lo as isize && y < hi as isize {
                let rest = off + second;
                let d = q[best_at] + on;
                out[y as usize] = if d > rest { d } else { rest };
            }
        }
        Mode::SumProduct => {
            let n = q.len();
            // prefix[x] = lse(q[..x]), suffix[x] = lse(q[x..]); on the stack for few states.
            let mut small = [[f64::NEG_INFINITY; SMALL + 1]; 2];
            let mut large: Vec<f64> = Vec::new();
            let (prefix, suffix): (&mut [f64], &mut [f64]) = if n <= SMALL {
                let [p, s] = &mut small;
                (&mut p[..n + 1], &mut s[..n + 1])
            } else {
                large.resize(2 * (n + 1), f64::NEG_INFINITY);
                large.split_at_mut(n + 1)
            };
            for x in 0..n {
                prefix[x + 1] = log_add_exp(prefix[x], q[x]);
            }
            for x in (0..n).rev() {
                suffix[x] = log_add_exp(suffix[x + 1], q[x]);
            }
            let all = off + prefix[n];
            out[..lo].iter_mut().for_each(|o| *o = all);
            out[hi..].iter_mut().for_each(|o| *o = all);
            for (y, o) in out.iter_mut().enumerate().take(hi).skip(lo) {
                let p = (y as isize + offset) as usize;
                let rest = log_add_exp(prefix[p], suffix[p + 1]);
                *o = log_add_exp(q[p] + on, off + rest);
            }
        }
    }
}
