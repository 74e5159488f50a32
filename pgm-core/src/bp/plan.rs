//! The compiled message plan: every message of an iteration as one flat step, in the
//! order of the message buffer, with the closed-form messages of the built-in factors
//! ([`MessageKernel`]) evaluated in place.
//!
//! The general path computes a message through the [`Factor`](crate::Factor) trait
//! object: it looks the edge's factor up, builds an [`Incoming`](crate::Incoming)
//! view and calls [`Factor::message`](crate::Factor::message), whose loops do not know
//! the number of states. For Potts factors and small dense tables under max-product,
//! and for single-variable factors in either mode, a step here holds all a message
//! needs (where the other variable's block starts and ends, where this factor's
//! message sits in it, the factor's parameters copied beside the plan) and runs loops
//! unrolled for its number of states. The arithmetic is the general path's, operation
//! for operation (the same leave-one-out sums, the same maxima, the same commit), so
//! the messages are bit-identical; every other factor keeps the general path.
//!
//! A plan copies potentials, so it is built once per run and only for runs whose
//! potentials cannot change: runs without an [`UpdateHook`](crate::UpdateHook).

use super::{flood_commit, leave_one_out_fixed, raw_message, Scratch};
use crate::factor::{potts_max_small, table_max_fixed, MessageKernel, Mode};
use crate::graph::FactorGraph;
use crate::logspace::Normalisation;
use std::ops::Range;

/// What a step evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// A single-variable factor's message: its table, at `data`.
    Unary,
    /// A max-product Potts message; `same` and `different` at `data`, `data + 1`.
    Potts,
    /// A max-product dense-table message; the `k × k` table at `data`.
    Table,
    /// Anything else: the general path for edge `edge`.
    General,
}

/// One message of an iteration.
#[derive(Clone, Copy, Debug)]
struct Step {
    kind: Kind,
    /// The edge's scope position in its factor (0 or 1).
    slot: u8,
    /// States of the edge's variable.
    k: u32,
    /// Where the edge's message starts in the buffer.
    target: u32,
    /// The other variable's block of incoming messages (pairwise steps).
    source_start: u32,
    source_end: u32,
    /// Where this factor's message into the other variable starts, relative to
    /// `source_start` (left out of the variable-to-factor sum).
    own: u32,
    /// Offset of the step's parameters in the plan's arena.
    data: u32,
    /// The edge.
    edge: u32,
}

/// Every message of an iteration, in buffer order (see the module docs). Flooding
/// walks the steps in order; edge updates (sequential and residual schedules) look
/// their step up.
#[derive(Debug)]
pub(super) struct FloodPlan {
    steps: Vec<Step>,
    /// For each position of the graph's layout order, its first step; one more entry
    /// at the end.
    first_step: Vec<usize>,
    /// Copied potentials: unary tables, Potts parameters, small pairwise tables.
    arena: Vec<f64>,
    /// For each edge, its step.
    step_of_edge: Vec<u32>,
}

/// Largest number of states with unrolled loops (the engine's `with_small_states!`).
const LARGEST_FIXED: usize = 8;

impl FloodPlan {
    /// The plan of `graph` in `mode`, or `None` when it would hold no step that the
    /// general path does not run as well (or when the buffer does not fit 32-bit
    /// offsets).
    pub(super) fn build(graph: &FactorGraph, mode: Mode) -> Option<Self> {
        if graph.message_len() >= u32::MAX as usize {
            return None;
        }
        let order = graph.layout_order();
        let sources = graph.pair_sources();
        let mut steps = Vec::with_capacity(graph.num_edges());
        let mut first_step = Vec::with_capacity(order.len() + 1);
        let mut arena = Vec::new();
        // Each factor's parameters are copied once, where the flood first meets them.
        let mut copied = vec![u32::MAX; graph.num_factors()];
        let mut fast = 0usize;
        let mut step_of_edge = vec![0u32; graph.num_edges()];
        for &v in order {
            first_step.push(steps.len());
            for &e in graph.variable_edges(v) {
                let a = graph.edge_factor(e);
                let factor = graph.factor(a);
                let k = graph.cardinality(v);
                let range = graph.message_range(e);
                let mut step = Step {
                    kind: Kind::General,
                    slot: graph.edge_slot(e) as u8,
                    k: k as u32,
                    target: range.start as u32,
                    source_start: 0,
                    source_end: 0,
                    own: 0,
                    data: 0,
                    edge: e.0 as u32,
                };
                let pair = sources.get(e.0).filter(|p| p.target_states > 0);
                let fixed = (2..=LARGEST_FIXED).contains(&k);
                let kind = match (factor.message_kernel(), pair) {
                    (Some(MessageKernel::Unary(t)), _) if t.len() == k => Some((Kind::Unary, t)),
                    (Some(MessageKernel::Potts { .. }), Some(p))
                        if mode == Mode::MaxProduct && fixed && p.states as usize == k =>
                    {
                        Some((Kind::Potts, &[][..]))
                    }
                    (Some(MessageKernel::Table(t)), Some(p))
                        if mode == Mode::MaxProduct
                            && fixed
                            && p.states as usize == k
                            && t.len() == k * k =>
                    {
                        Some((Kind::Table, t))
                    }
                    _ => None,
                };
                if let Some((kind, table)) = kind {
                    if copied[a.0] == u32::MAX {
                        copied[a.0] = arena.len() as u32;
                        match factor.message_kernel() {
                            Some(MessageKernel::Potts { same, different }) => {
                                arena.extend_from_slice(&[same, different])
                            }
                            _ => arena.extend_from_slice(table),
                        }
                    }
                    step.kind = kind;
                    step.data = copied[a.0];
                    if let Some(p) = pair {
                        step.source_start = p.start;
                        step.source_end = p.end;
                        step.own = p.own - p.start;
                    }
                    fast += 1;
                }
                step_of_edge[e.0] = steps.len() as u32;
                steps.push(step);
            }
        }
        first_step.push(steps.len());
        if fast == 0 || arena.len() >= u32::MAX as usize {
            return None;
        }
        Some(Self {
            steps,
            first_step,
            arena,
            step_of_edge,
        })
    }

    /// Floods the messages of the variables at `positions` of the layout order: reads
    /// `old` (the whole buffer), writes `out` (the positions' part of the next buffer,
    /// which starts at buffer offset `base`). Returns the largest undamped change and
    /// the number of contradictions, as the general flood does.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn flood(
        &self,
        graph: &FactorGraph,
        positions: Range<usize>,
        old: &[f64],
        out: &mut [f64],
        base: usize,
        (mode, how, damping): (Mode, Normalisation, f64),
        scratch: &mut Scratch,
    ) -> (f64, usize) {
        let steps = &self.steps[self.first_step[positions.start]..self.first_step[positions.end]];
        let mut residual = 0.0f64;
        let mut contradictions = 0usize;
        for s in steps {
            let message = self.raw(s, graph, old, mode, scratch);
            let (r, ok) = flood_commit(old, out, base, message, scratch, damping, how);
            contradictions += usize::from(!ok);
            residual = residual.max(r);
        }
        (residual, contradictions)
    }

    /// The unnormalised message of edge `e` from `messages`, into `scratch.out[..k]`,
    /// as [`raw_message`] computes it; returns `k` and where the edge's message starts.
    #[inline]
    pub(super) fn raw_message(
        &self,
        graph: &FactorGraph,
        messages: &[f64],
        e: usize,
        mode: Mode,
        scratch: &mut Scratch,
    ) -> (usize, usize) {
        let s = &self.steps[self.step_of_edge[e] as usize];
        self.raw(s, graph, messages, mode, scratch)
    }

    #[inline(always)]
    fn raw(
        &self,
        s: &Step,
        graph: &FactorGraph,
        old: &[f64],
        mode: Mode,
        scratch: &mut Scratch,
    ) -> (usize, usize) {
        match s.kind {
            Kind::General => raw_message(graph, old, s.edge as usize, mode, scratch),
            Kind::Unary => {
                let k = s.k as usize;
                let t = &self.arena[s.data as usize..s.data as usize + k];
                // `+ 0.0` keeps this short copy out of a library memcpy call.
                for (o, &x) in scratch.out[..k].iter_mut().zip(t) {
                    *o = x + 0.0;
                }
                (k, s.target as usize)
            }
            Kind::Potts | Kind::Table => {
                with_small_states!(
                    s.k as usize,
                    K => self.pair::<K>(s, old, &mut scratch.out),
                    unreachable!("pairwise steps have 2 to {LARGEST_FIXED} states"),
                );
                (s.k as usize, s.target as usize)
            }
        }
    }

    /// A pairwise step with `K` states on both sides: the leave-one-out sum of the
    /// other variable's block, then the factor's closed-form message, into `raw`.
    #[inline(always)]
    fn pair<const K: usize>(&self, s: &Step, old: &[f64], raw: &mut [f64]) {
        let mut q = [0.0f64; K];
        leave_one_out_fixed::<K>(
            &old[s.source_start as usize..s.source_end as usize],
            s.own as usize,
            &mut q,
        );
        let d = s.data as usize;
        if s.kind == Kind::Potts {
            potts_max_small(&q, &mut raw[..K], self.arena[d], self.arena[d + 1]);
        } else {
            table_max_fixed::<K>(&self.arena[d..d + K * K], s.slot as usize, &q, raw);
        }
    }
}
