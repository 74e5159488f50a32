//! Residual belief propagation (Elidan, McGraw and Koller, 2006): always commit the
//! message whose recomputation would change it most.
//!
//! With damping a commit moves a message only part of the way to its candidate, so
//! the committed edge keeps the rest of its residual in the queue
//! ([`MessagePasser::commit_candidate_pending`]): damping changes the path to the
//! fixed point, never the fixed point, and a damped run cannot stop half-way.

use super::{MessagePasser, Schedule};
use crate::graph::{EdgeId, FactorId};

/// Residual BP. Each iteration commits up to as many messages as the graph has edges,
/// largest residual first; after a commit, the messages that read the changed one are
/// recomputed and re-queued. An iteration ends early when the largest pending residual
/// is within the engine's tolerance, and reports that residual as the fixed-point
/// residual. Ties go to the lowest edge id, so runs are deterministic.
#[derive(Clone, Debug, Default)]
pub struct Residual {
    heap: IndexedMaxHeap,
    initialised: bool,
    /// For each edge `e`, the edges whose messages read `e`'s (see `affected_by`):
    /// `readers[reader_start[e]..reader_start[e + 1]]`.
    reader_start: Vec<u32>,
    readers: Vec<u32>,
}

/// The edges whose messages read the message of edge `e` (a factor `a` to its variable
/// `v`): every other factor `b` of `v`, towards `b`'s other variables.
fn affected_by(graph: &crate::FactorGraph, e: EdgeId, out: &mut Vec<u32>) {
    let v = graph.edge_variable(e);
    let a = graph.edge_factor(e);
    for &e2 in graph.variable_edges(v) {
        let b: FactorId = graph.edge_factor(e2);
        if b == a {
            continue;
        }
        out.extend(
            graph
                .factor_edges(b)
                .filter(|&e3| e3 != e2.0)
                .map(|e3| e3 as u32),
        );
    }
}

impl Schedule for Residual {
    fn name(&self) -> &str {
        "residual"
    }

    fn prepare(&mut self, graph: &crate::FactorGraph) -> crate::Result<()> {
        self.heap = IndexedMaxHeap::new(graph.num_edges());
        self.initialised = false;
        self.index_readers(graph);
        Ok(())
    }

    fn iteration(&mut self, passer: &mut dyn MessagePasser) -> Option<f64> {
        let num_edges = passer.graph().num_edges();
        if self.heap.positions.len() != num_edges || self.reader_start.len() != num_edges + 1 {
            self.heap = IndexedMaxHeap::new(num_edges);
            self.initialised = false;
            self.index_readers(passer.graph());
        }
        if !self.initialised {
            for e in 0..num_edges {
                let r = passer.compute_candidate(EdgeId(e));
                self.heap.set(e, r);
            }
            self.initialised = true;
        }
        let tolerance = passer.tolerance();
        for step in 0..num_edges {
            let Some((e, r)) = self.heap.top() else { break };
            if r <= tolerance {
                break;
            }
            if step % 1024 == 1023 && passer.out_of_time() {
                break;
            }
            let pending = passer.commit_candidate_pending(EdgeId(e));
            self.heap.set(e, pending);
            // Messages that read the changed message.
            let (lo, hi) = (
                self.reader_start[e] as usize,
                self.reader_start[e + 1] as usize,
            );
            for i in lo..hi {
                let e3 = self.readers[i] as usize;
                let r3 = passer.compute_candidate(EdgeId(e3));
                self.heap.set(e3, r3);
            }
        }
        Some(self.heap.top().map_or(0.0, |(_, r)| r))
    }
}

impl Residual {
    /// Indexes, for every edge, the edges that read its message ([`affected_by`]).
    fn index_readers(&mut self, graph: &crate::FactorGraph) {
        self.reader_start.clear();
        self.readers.clear();
        self.reader_start.push(0);
        for e in 0..graph.num_edges() {
            affected_by(graph, EdgeId(e), &mut self.readers);
            self.reader_start.push(self.readers.len() as u32);
        }
    }
}

/// A 4-ary max-heap over edge ids with updatable priorities: half the depth of a
/// binary heap. Priorities are stored as the bits of their absolute value, which
/// order like the numbers for non-negative values (+∞ above every number, NaN above
/// +∞, so that a NaN surfaces instead of hiding); sifts move a hole instead of
/// swapping. An entry is 12 bytes and a position 4, so that the heap of a large graph
/// stays in as few cache lines as it can.
#[derive(Clone, Debug, Default)]
struct IndexedMaxHeap {
    /// Entries in heap order.
    heap: Vec<Item>,
    /// Heap position of each edge, `ABSENT` when absent.
    positions: Vec<u32>,
}

/// A heap entry: an edge and the order key of its priority.
#[derive(Clone, Copy, Debug)]
#[repr(C, packed(4))]
struct Item {
    key: u64,
    edge: u32,
}

const ABSENT: u32 = u32::MAX;

impl IndexedMaxHeap {
    fn new(n: usize) -> Self {
        assert!(
            n < ABSENT as usize,
            "residual BP indexes edges with 32 bits"
        );
        Self {
            heap: Vec::with_capacity(n),
            positions: vec![ABSENT; n],
        }
    }

    /// The order key of a priority (residuals are never negative; a negative value
    /// counts as its absolute value).
    #[inline]
    fn key(priority: f64) -> u64 {
        priority.abs().to_bits()
    }

    #[inline]
    fn priority(key: u64) -> f64 {
        f64::from_bits(key)
    }

    /// Higher priority first; equal priorities: lower edge id first.
    #[inline]
    fn before(a: Item, b: Item) -> bool {
        let (ak, bk, ae, be) = (a.key, b.key, a.edge, b.edge);
        ak > bk || (ak == bk && ae < be)
    }

    fn top(&self) -> Option<(usize, f64)> {
        self.heap.first().map(|&item| {
            let (key, edge) = (item.key, item.edge);
            (edge as usize, Self::priority(key))
        })
    }

    /// Sets an edge's priority; a priority of 0 takes the edge out of the heap (such an
    /// edge is never committed, and a smaller heap is cheaper to sift).
    fn set(&mut self, edge: usize, priority: f64) {
        let item = Item {
            key: Self::key(priority),
            edge: edge as u32,
        };
        if item.key == 0 {
            self.remove(edge);
            return;
        }
        let pos = self.positions[edge];
        if pos == ABSENT {
            self.heap.push(item);
            self.sift_up(self.heap.len() - 1, item);
        } else {
            let old = self.heap[pos as usize];
            if Self::before(item, old) {
                self.sift_up(pos as usize, item);
            } else {
                self.sift_down(pos as usize, item);
            }
        }
    }

    fn remove(&mut self, edge: usize) {
        let pos = self.positions[edge];
        if pos == ABSENT {
            return;
        }
        let pos = pos as usize;
        self.positions[edge] = ABSENT;
        let Some(last) = self.heap.pop() else { return };
        if pos == self.heap.len() {
            return;
        }
        // The last element fills the hole, moving up or down from there.
        if pos > 0 && Self::before(last, self.heap[(pos - 1) / 4]) {
            self.sift_up(pos, last);
        } else {
            self.sift_down(pos, last);
        }
    }

    /// Puts `item` in slot `i` and records its position.
    #[inline]
    fn place(&mut self, i: usize, item: Item) {
        self.heap[i] = item;
        self.positions[item.edge as usize] = i as u32;
    }

    /// Places `item` at the hole `i` or above it.
    #[inline]
    fn sift_up(&mut self, mut i: usize, item: Item) {
        while i > 0 {
            let parent = (i - 1) / 4;
            let p = self.heap[parent];
            if !Self::before(item, p) {
                break;
            }
            self.place(i, p);
            i = parent;
        }
        self.place(i, item);
    }

    /// Places `item` at the hole `i` or below it.
    #[inline]
    fn sift_down(&mut self, mut i: usize, item: Item) {
        let n = self.heap.len();
        loop {
            let first = 4 * i + 1;
            if first >= n {
                break;
            }
            let last = (first + 4).min(n);
            let mut best = first;
            let mut best_item = self.heap[first];
            for c in first + 1..last {
                let candidate = self.heap[c];
                if Self::before(candidate, best_item) {
                    best = c;
                    best_item = candidate;
                }
            }
            if !Self::before(best_item, item) {
                break;
            }
            self.place(i, best_item);
            i = best;
        }
        self.place(i, item);
    }
}

#[cfg(test)]
mod tests {
    use super::IndexedMaxHeap;

    #[test]
    fn heap_orders_like_a_sort() {
        // Random priorities (with ties, zeros, +∞) and updates: the top is always the
        // largest priority, lowest edge id among ties.
        let mut h = IndexedMaxHeap::new(200);
        let mut current = vec![None; 200];
        let mut state = 12345u64;
        for step in 0..5000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let edge = (state >> 33) as usize % 200;
            let priority = match (state >> 20) % 7 {
                0 => 0.0,
                1 => f64::INFINITY,
                2 => 1.5,
                _ => ((state >> 40) % 1000) as f64 / 7.0,
            };
            h.set(edge, priority);
            current[edge] = Some(priority);
            let expected = current
                .iter()
                .enumerate()
                .filter_map(|(e, p)| p.filter(|&p| p > 0.0).map(|p| (e, p)))
                .fold(None, |best: Option<(usize, f64)>, (e, p)| match best {
                    Some((_, q)) if q >= p => best,
                    _ => Some((e, p)),
                });
            assert_eq!(h.top(), expected, "step {step}");
        }
    }

    #[test]
    fn heap_orders_and_updates() {
        let mut h = IndexedMaxHeap::new(5);
        for (e, p) in [(0, 1.0), (1, 5.0), (2, 3.0), (3, 5.0), (4, 0.5)] {
            h.set(e, p);
        }
        assert_eq!(h.top(), Some((1, 5.0)));
        h.set(1, 0.0);
        assert_eq!(h.top(), Some((3, 5.0)));
        h.set(3, 0.0);
        h.set(4, 9.0);
        assert_eq!(h.top(), Some((4, 9.0)));
    }
}
